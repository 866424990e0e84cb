//! Planning jobs: a program smoothed (any method; [`Method::None`] plans it as written),
//! its feed planned under per-axis limits and its setpoints interpolated at a fixed period
//! into a sink the caller supplies, with what was measured on the rows.
//!
//! A path held whole ([`PlanInput::Path`]) is smoothed by the windowed smoother a streamed
//! file uses ([`ncsmooth::smooth_for_plan`]), so the setpoints are the same either way. A
//! file ([`PlanInput::File`]) is read, smoothed and planned a part at a time
//! ([`stream`](self::stream)): the memory does not grow with the program.
//!
//! The job refuses as bad input what the setpoints could not show: a period outside
//! [`MIN_PERIOD_S`]` ..= `[`MAX_PERIOD_S`], limits the period cannot resolve
//! ([`ncsmooth::feed`]), a plan needing more rows than [`PlanJob::max_rows`] (known up
//! front from the path at its speed caps, or as the moves arrive; a plan that turns out
//! longer stops at the row that passes it). The planner holds every limit it accepts:
//! setpoints measured beyond one are [`JobError::LimitsBroken`] (a bug of ours), unless
//! the options asked for motion beyond the limits (junction-deviation corners that were
//! blended, interpolation steps without arc correction): then the job succeeds and
//! [`Planned::limits_waived`] says which limits were exceeded. The follow scheme giving up
//! on a run is [`JobError::FollowGaveUp`]: [`PlanJob::fallback`] is the same job under the
//! filter scheme, to run again with a fresh sink.
//!
//! ```
//! use ncsmooth::{Method, Toolpath, Vec3};
//! use ncsmooth_gcode::{PlanInput, PlanJob};
//!
//! let square = [Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0), Vec3::new(10.0, 10.0, 0.0)];
//! let program = Toolpath::from_polyline(&square, None);
//! let job = PlanJob::new(Method::Bspline, 0.01);
//! let input = PlanInput::Path { name: "corner", toolpath: &program, parse_s: 0.0 };
//! let done = job.run(&input, Vec::new(), &|_| false).unwrap();
//! assert!(done.run.plan.limits_held);
//! assert_eq!(done.sink.len(), done.run.plan.setpoints);
//! ```

mod stream;

use super::JobError;
use crate::{ParseOptions, PlanRunReport};
use ncsmooth::feed::{JerkScheme, PlanOptions};
use ncsmooth::geom::{ParamCurve, ParamCurveArclen};
use ncsmooth::interp::{execute_into, InterpOptions, PlanError, PlanReport, Setpoint};
use ncsmooth::interp::{PrintedRow, SetpointSink};
use ncsmooth::smooth::band_time::TimeLimits;
use ncsmooth::smooth::Method;
use ncsmooth::Toolpath;
use std::io::{self, Write};
use std::path::Path;
use std::time::Instant;
use stream::StreamedInput;

/// Shortest period accepted (s): 10 us, a 100 kHz setpoint rate. CNC controllers take
/// position setpoints every 0.125 to 4 ms (LinuxCNC's servo thread runs at 1 ms); a
/// shorter period describes no machine, and the work and output grow as 1/period without
/// bound.
pub const MIN_PERIOD_S: f64 = 1e-5;
/// Longest period accepted (s): 100 ms, a 10 Hz setpoint rate, coarser than any position
/// loop. Longer steps no longer describe the motion (the rows' finite-difference
/// accelerations and the chord error the report measures lose their meaning), and such a
/// value is most likely milliseconds typed as seconds (10 for 10 ms).
pub const MAX_PERIOD_S: f64 = 0.1;
/// Accuracy (mm) of the arc-length sampling of [`write_path_samples`].
const SAMPLE_ACCURACY_MM: f64 = 1e-9;

/// A planning job: the smoothing before the plan, the planner's and the interpolator's
/// options and the row limit. Build with [`PlanJob::new`] and the `with_*` methods; run
/// with [`PlanJob::run`].
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct PlanJob {
    /// Smoothing applied before planning. Default: the method of [`PlanJob::new`].
    pub method: Method,
    /// Two-sided smoothing tolerance (mm). Default: that of [`PlanJob::new`].
    pub tol_mm: f64,
    /// Reshape each method's fitted runs at their slow spots to the fastest curve inside
    /// the same band for the plan's feed and acceleration. Default false.
    pub time_shape: bool,
    /// The planner's limits. Default [`PlanOptions::default`].
    pub plan: PlanOptions,
    /// The interpolator's options. Default [`InterpOptions::default`].
    pub interp: InterpOptions,
    /// Most setpoint rows the plan may produce. Default `None`: no limit.
    pub max_rows: Option<u64>,
    /// How a file is read (the units before a G20/G21). Default [`ParseOptions::default`].
    pub read: ParseOptions,
}

/// What a [`PlanJob`] plans.
#[derive(Clone, Copy, Debug)]
pub enum PlanInput<'a> {
    /// A program's path held whole, smoothed by the job before planning; `parse_s` is the
    /// time the caller spent reading it (for the report).
    Path {
        /// Input name, for the report.
        name: &'a str,
        /// The program's path.
        toolpath: &'a Toolpath,
        /// Seconds spent reading it.
        parse_s: f64,
    },
    /// A G-code file, read, smoothed and planned a part at a time.
    File {
        /// Input name, for messages and the report.
        name: &'a str,
        /// Where it is.
        path: &'a Path,
    },
}

/// What the job tells its caller while it runs.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum PlanNote {
    /// A streamed file moves before its first G20/G21 at this line: it is read in the
    /// units of [`ParseOptions`] (LinuxCNC reads it in the machine's).
    UnitsAssumed {
        /// The line of the first such move.
        line: u32,
    },
    /// The cycle takes at least this long (s), the path at its speed caps: the rows are
    /// at least this over the period. Given whole up front, or growing as a file's moves
    /// arrive until the caller's answer is `true`.
    MinCycle {
        /// The lower bound (s).
        s: f64,
    },
}

/// A planning job's result.
#[derive(Debug)]
pub struct Planned<S> {
    /// What was done and measured.
    pub run: PlanRunReport,
    /// The sink, finished.
    pub sink: S,
    /// The smoothed path, when the input was held whole.
    pub path: Option<Toolpath>,
    /// The limits the setpoints exceed as the options asked for (`--junction-dev`,
    /// `--no-arc-correction`), named with their figures.
    pub limits_waived: Option<String>,
}

impl PlanJob {
    /// A job smoothing with `method` within `tol_mm` and planning under the default limits.
    pub fn new(method: Method, tol_mm: f64) -> PlanJob {
        PlanJob {
            method,
            tol_mm,
            time_shape: false,
            plan: PlanOptions::default(),
            interp: InterpOptions::default(),
            max_rows: None,
            read: ParseOptions::default(),
        }
    }

    /// The planner's limits.
    pub fn with_plan_options(mut self, plan: PlanOptions) -> PlanJob {
        self.plan = plan;
        self
    }

    /// The interpolator's options.
    pub fn with_interp_options(mut self, interp: InterpOptions) -> PlanJob {
        self.interp = interp;
        self
    }

    /// Whether the fitted runs are reshaped for time at their slow spots.
    pub fn with_time_shape(mut self, time_shape: bool) -> PlanJob {
        self.time_shape = time_shape;
        self
    }

    /// The most setpoint rows the plan may produce.
    pub fn with_max_rows(mut self, max_rows: Option<u64>) -> PlanJob {
        self.max_rows = max_rows;
        self
    }

    /// How a file is read.
    pub fn with_read_options(mut self, read: ParseOptions) -> PlanJob {
        self.read = read;
        self
    }

    /// The same job under the filter scheme, when it plans with the follow scheme (which
    /// gives up on a run it cannot finish within the limits, [`JobError::FollowGaveUp`]).
    pub fn fallback(&self) -> Option<PlanJob> {
        (self.plan.jerk_scheme == JerkScheme::Follow).then(|| {
            let mut job = self.clone();
            job.plan.jerk_scheme = JerkScheme::Filter;
            job
        })
    }

    /// The limits the time shaping reshapes the runs for, when it is on.
    pub fn time_limits(&self) -> Option<TimeLimits> {
        self.time_shape.then_some(TimeLimits {
            feed_mm_s: self.plan.feed_mm_s,
            acc_mm_s2: self.plan.acc_mm_s2,
        })
    }

    /// Refuses a period outside [`MIN_PERIOD_S`] ..= [`MAX_PERIOD_S`] ([`check_period`]).
    pub fn check_period(&self) -> Result<(), JobError> {
        check_period(self.plan.period_s)
    }

    /// Refuses limits the period cannot resolve and a negative feed tolerance.
    fn check_options(&self) -> Result<(), JobError> {
        self.plan
            .validate()
            .map_err(|e| JobError::BadInput(format!("--{e}")))?;
        let eta = self.interp.eta_tol;
        if !(eta >= 0.0 && eta.is_finite()) {
            return Err(JobError::BadInput(format!("--eta-tol {eta} must be >= 0")));
        }
        Ok(())
    }

    /// `tp` smoothed as this job plans it (the streamed plan's windowed smoother run on
    /// the whole path); a method refusing its options is bad input.
    pub fn smooth(&self, tp: &Toolpath) -> Result<ncsmooth::Smoothed, JobError> {
        ncsmooth::smooth_for_plan(tp, self.method, self.tol_mm, self.time_limits())
            .map_err(|e| JobError::BadInput(e.to_string()))
    }

    /// Smooths and plans `input` into `sink`; `note` hears what the caller may want to say
    /// before the setpoints come (see [`PlanNote`]; its answer matters only to
    /// [`PlanNote::MinCycle`]: `true` once it said what it wanted).
    pub fn run<S: SetpointSink + Send>(
        &self,
        input: &PlanInput<'_>,
        sink: S,
        note: &(dyn Fn(PlanNote) -> bool + Sync),
    ) -> Result<Planned<S>, JobError> {
        self.check_period()?;
        let t0 = Instant::now();
        match *input {
            PlanInput::Path {
                name,
                toolpath,
                parse_s,
            } => self.run_whole(name, toolpath, parse_s, t0, sink, note),
            PlanInput::File { name, path } => {
                let mut streamed = StreamedInput::open(path, name, &self.read, self)?;
                if let Some(line) = streamed.units_assumed() {
                    note(PlanNote::UnitsAssumed { line });
                }
                let parse_s = t0.elapsed().as_secs_f64();
                self.check_options()?;
                let popts = streamed.tuned(&self.plan);
                let announce = |s: f64| note(PlanNote::MinCycle { s });
                let planned = streamed.plan(
                    &popts,
                    &self.interp,
                    RowLimited::new(sink, self.max_rows),
                    &announce,
                )?;
                let (report, sink) = self.rows_checked(planned, &popts)?;
                let run = self.run_report(name, streamed.report(), (parse_s, 0.0), report, t0);
                self.finish(run, sink, None)
            }
        }
    }

    /// [`PlanJob::run`] of a path held whole.
    fn run_whole<S: SetpointSink + Send>(
        &self,
        name: &str,
        toolpath: &Toolpath,
        parse_s: f64,
        t0: Instant,
        sink: S,
        note: &(dyn Fn(PlanNote) -> bool + Sync),
    ) -> Result<Planned<S>, JobError> {
        self.check_options()?;
        let t1 = Instant::now();
        let smoothed = self.smooth(toolpath)?;
        let smooth_s = t1.elapsed().as_secs_f64();
        let popts = &self.plan;
        // Every row is a period of the cycle, which cannot be shorter than the path at its
        // speed caps: refuse or announce a huge output before producing any of it.
        let min_cycle_s = popts.min_cycle_time_s(&smoothed.toolpath);
        // Truncated (not the row at t = 0 added): a margin of one row for rounding.
        let min_rows = (min_cycle_s / popts.period_s) as u64;
        if let Some(max) = self.max_rows.filter(|&max| min_rows > max) {
            return Err(JobError::BadInput(format!(
                "the cycle takes at least {min_cycle_s:.3} s (the path at its speed caps), so \
                 at least {min_rows} setpoint rows at --period {:?} s, more than --max-rows \
                 {max}; nothing written",
                popts.period_s
            )));
        }
        note(PlanNote::MinCycle { s: min_cycle_s });
        let planned = execute_into(
            &smoothed.toolpath,
            popts,
            &self.interp,
            RowLimited::new(sink, self.max_rows),
        );
        let (report, sink) = self.rows_checked(planned, popts)?;
        let run = self.run_report(name, smoothed.report, (parse_s, smooth_s), report, t0);
        self.finish(run, sink, Some(smoothed.toolpath))
    }

    /// The plan's result with the row limit's refusal as bad input.
    fn rows_checked<S>(
        &self,
        planned: Result<(PlanReport, RowLimited<S>), PlanError>,
        popts: &PlanOptions,
    ) -> Result<(PlanReport, S), JobError> {
        match planned {
            Ok((report, limited)) => Ok((report, limited.inner)),
            Err(PlanError::Io(e))
                if e.get_ref()
                    .is_some_and(|e| e.downcast_ref::<RowLimitExceeded>().is_some()) =>
            {
                Err(JobError::BadInput(format!(
                    "the plan needs more than --max-rows {} setpoint rows (at --period {:?} \
                     s); stopped, nothing written",
                    self.max_rows.unwrap_or_default(),
                    popts.period_s
                )))
            }
            Err(e) => Err(JobError::Plan(e)),
        }
    }

    /// The report of a run that started at `t0`.
    fn run_report(
        &self,
        name: &str,
        smoothing: ncsmooth::SmoothReport,
        (parse_s, smooth_s): (f64, f64),
        plan: PlanReport,
        t0: Instant,
    ) -> PlanRunReport {
        let total = parse_s + t0.elapsed().as_secs_f64();
        PlanRunReport {
            input: name.to_string(),
            method: self.method.name().to_string(),
            smoothing,
            parse_s,
            smooth_s,
            end_to_end_real_time_factor: plan.cycle_time_s / total,
            plan,
        }
    }

    /// The result, or the error when the measured setpoints break a limit the options
    /// did not waive.
    fn finish<S>(
        &self,
        run: PlanRunReport,
        sink: S,
        path: Option<Toolpath>,
    ) -> Result<Planned<S>, JobError> {
        let mut limits_waived = None;
        if let Some(broken) = run.plan.broken_limits() {
            let waived = self.waivers(&run.plan);
            if waived.is_empty() {
                if self.plan.jerk_scheme == JerkScheme::Follow {
                    return Err(JobError::FollowGaveUp(format!(
                        "--jerk-scheme follow gave up on a stop-to-stop run (sampled from \
                         the trapezoid, it breaks the limits: {broken})"
                    )));
                }
                return Err(JobError::LimitsBroken(format!(
                    "the plan does not hold its limits: {broken}; nothing written"
                )));
            }
            limits_waived = Some(format!(
                "limits exceeded as asked for by {}: {broken}",
                waived.join(" and ")
            ));
        }
        Ok(Planned {
            run,
            sink,
            path,
            limits_waived,
        })
    }

    /// The options under which the user asked for motion beyond the limits, if they took
    /// effect: blended junction-deviation corners (velocity jumps) and uncorrected
    /// interpolation steps (each method's own setpoints).
    fn waivers(&self, r: &PlanReport) -> Vec<&'static str> {
        let mut w = Vec::new();
        if self.plan.junction_dev_mm.is_some() && r.exact_stops.junction_blended > 0 {
            w.push("--junction-dev");
        }
        if !self.interp.arc_correction {
            w.push("--no-arc-correction");
        }
        w
    }
}

/// Refuses a period (s) outside [`MIN_PERIOD_S`] ..= [`MAX_PERIOD_S`] as bad input.
pub fn check_period(period_s: f64) -> Result<(), JobError> {
    if !(MIN_PERIOD_S..=MAX_PERIOD_S).contains(&period_s) {
        return Err(JobError::BadInput(format!(
            "--period {period_s:?} s is outside {MIN_PERIOD_S:?} ..= {MAX_PERIOD_S:?} s (the \
             interpolation period is in seconds: 1 ms is 0.001)"
        )));
    }
    Ok(())
}

/// Marks the write error of [`RowLimited`].
#[derive(Debug)]
struct RowLimitExceeded;

impl std::fmt::Display for RowLimitExceeded {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("row limit exceeded")
    }
}
impl std::error::Error for RowLimitExceeded {}

/// A sink under a row limit: fails the row that would pass it (before the inner sink sees
/// it), which stops the interpolation.
struct RowLimited<S> {
    inner: S,
    /// Rows still allowed; `None` without a limit.
    rows_left: Option<u64>,
}

impl<S> RowLimited<S> {
    fn new(inner: S, max_rows: Option<u64>) -> Self {
        RowLimited {
            inner,
            rows_left: max_rows,
        }
    }

    fn take_row(&mut self) -> io::Result<()> {
        match &mut self.rows_left {
            Some(0) => Err(io::Error::other(RowLimitExceeded)),
            Some(n) => {
                *n -= 1;
                Ok(())
            }
            None => Ok(()),
        }
    }
}

impl<S: SetpointSink> SetpointSink for RowLimited<S> {
    fn begin(&mut self, extra_axes_mask: u8) -> io::Result<()> {
        self.inner.begin(extra_axes_mask)
    }
    #[inline]
    fn push(&mut self, sp: &Setpoint) -> io::Result<()> {
        self.take_row()?;
        self.inner.push(sp)
    }
    #[inline]
    fn push_printed(&mut self, sp: &Setpoint) -> io::Result<Option<PrintedRow>> {
        self.take_row()?;
        self.inner.push_printed(sp)
    }
    fn finish(&mut self) -> io::Result<()> {
        self.inner.finish()
    }
}

/// Writes `s,x,y,z` (mm, 9 decimals) every `ds_mm` of arc length along the moves of `tp`
/// (and each move's end), for comparisons with other planners.
pub fn write_path_samples<W: Write>(mut w: W, tp: &Toolpath, ds_mm: f64) -> io::Result<()> {
    writeln!(w, "s,x,y,z")?;
    let mut s0 = 0.0;
    let mut first = true;
    for m in tp.moves() {
        let seg = &m.segment;
        let len = seg.arclen(SAMPLE_ACCURACY_MM);
        if len <= 0.0 {
            continue;
        }
        let n = (len / ds_mm).ceil().max(1.0) as usize;
        for i in usize::from(!first)..=n {
            let s = len * i as f64 / n as f64;
            let p = seg.eval(seg.inv_arclen(s, SAMPLE_ACCURACY_MM));
            writeln!(w, "{:.9},{:.9},{:.9},{:.9}", s0 + s, p.x, p.y, p.z)?;
        }
        first = false;
        s0 += len;
    }
    w.flush()
}

#[cfg(test)]
mod tests {
    use super::*;
    use ncsmooth::geom::Vec3;

    fn corner() -> Toolpath {
        Toolpath::from_polyline(
            &[
                Vec3::ZERO,
                Vec3::new(5.0, 0.0, 0.0),
                Vec3::new(5.0, 5.0, 0.0),
            ],
            None,
        )
    }

    fn plan(job: &PlanJob) -> PlanReport {
        execute_into(
            &corner(),
            &job.plan,
            &job.interp,
            ncsmooth::interp::NullSink,
        )
        .unwrap()
        .0
    }

    #[test]
    fn measured_violations_are_named_and_waived_only_when_asked_for() {
        let mut job = PlanJob::new(Method::None, 0.01);
        job.plan.jerk_mm_s3 = Some([2000.0; 3]);
        let held = plan(&job);
        assert!(held.limits_held);
        assert_eq!(held.broken_limits(), None);
        // A report whose setpoints exceed a limit names it, and a plain run has no waiver.
        let mut broken = held.clone();
        broken.limits_held = false;
        broken.axes[1].j_within = false;
        broken.axes[0].a_within = false;
        let msg = broken.broken_limits().unwrap();
        assert!(
            msg.contains("y jerk") && msg.contains("x acceleration"),
            "{msg}"
        );
        assert!(
            !msg.contains("x jerk") && !msg.contains("velocity"),
            "{msg}"
        );
        assert!(job.waivers(&broken).is_empty());
        let mut jd = job.clone();
        jd.plan.junction_dev_mm = Some(0.01);
        assert!(jd.waivers(&broken).is_empty(), "no corner was blended");
        let mut nac = job.clone();
        nac.interp.arc_correction = false;
        assert_eq!(nac.waivers(&broken), ["--no-arc-correction"]);
        // Junction deviation waives only when it blended a corner.
        let mut jd = PlanJob::new(Method::None, 0.01);
        jd.plan.junction_dev_mm = Some(0.01);
        let blended = plan(&jd);
        assert_eq!(blended.exact_stops.junction_blended, 1);
        assert!(!blended.limits_held, "a velocity jump at the corner");
        assert_eq!(jd.waivers(&blended), ["--junction-dev"]);
    }

    #[test]
    fn the_row_limit_fails_the_row_that_would_pass_it() {
        let tp = corner();
        let input = PlanInput::Path {
            name: "corner",
            toolpath: &tp,
            parse_s: 0.0,
        };
        let job = PlanJob::new(Method::None, 0.01);
        let all = job.run(&input, Vec::new(), &|_| false).unwrap();
        let n = all.sink.len() as u64;
        let exact = job.clone().with_max_rows(Some(n));
        assert_eq!(
            exact
                .run(&input, Vec::new(), &|_| false)
                .unwrap()
                .sink
                .len() as u64,
            n
        );
        // A bound the path at its caps already passes is refused before planning; one the
        // plan passes stops it at the row over the limit.
        let e = job
            .clone()
            .with_max_rows(Some(n / 10))
            .run(&input, Vec::new(), &|_| false);
        assert!(matches!(e, Err(JobError::BadInput(m)) if m.contains("--max-rows")));
        let mut rows = RowLimited::new(Vec::new(), Some(2));
        let sp = Setpoint {
            t: 0.0,
            p: Vec3::ZERO,
            feed: 0.0,
            extra: None,
            jump: false,
        };
        rows.push(&sp).unwrap();
        rows.push(&sp).unwrap();
        let e = rows.push(&sp).unwrap_err();
        assert!(e.get_ref().unwrap().is::<RowLimitExceeded>());
        assert_eq!(rows.inner.len(), 2);
    }

    #[test]
    fn a_period_outside_the_range_is_bad_input() {
        for period_s in [1e-6, 0.5, f64::NAN] {
            let mut job = PlanJob::new(Method::None, 0.01);
            job.plan.period_s = period_s;
            assert!(job.check_period().unwrap_err().is_bad_input());
        }
        assert!(PlanJob::new(Method::None, 0.01).check_period().is_ok());
    }

    #[test]
    fn samples_end_at_each_move() {
        let mut out = Vec::new();
        write_path_samples(&mut out, &corner(), 2.0).unwrap();
        let text = String::from_utf8(out).unwrap();
        let last = text.lines().last().unwrap();
        assert_eq!(last, "10.000000000,5.000000000,5.000000000,0.000000000");
        assert_eq!(text.lines().count(), 1 + 1 + 3 + 3);
    }
}
