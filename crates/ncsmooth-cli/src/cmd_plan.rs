//! `ncsmooth plan`: smooth a program (any method; `none` plans it as written), plan the
//! feed under per-axis limits and write setpoints at a fixed period, streamed to the CSV
//! (never collected), with a JSON report of what was measured on the written rows. A
//! file is read, smoothed and planned a part at a time ([`crate::plan_stream`]) unless
//! an output needs the whole program (`--report-html`, `--path-samples`) or it is stdin.
//!
//! The input may also be `builtin:butterfly`: the published butterfly NURBS as one curve
//! (F 50 mm/s), for planning a smooth curve without a smoothing step.
//!
//! Limits the setpoints cannot show at the period (see [`ncsmooth::feed`]) are refused as
//! bad input (exit 2) before planning. The planner holds every limit it accepts; setpoints
//! measured beyond one ([`PlanReport::limits_held`] false) are an internal error (exit 1)
//! and nothing is written, unless the user asked for motion beyond the limits
//! (`--junction-dev` corners that were blended, `--no-arc-correction`): then the run
//! succeeds and says which limits were exceeded.

use crate::io::OutputFile;
use crate::plan_stream::StreamedInput;
use crate::table_arg::MethodArg;
use crate::{io, load, progress, Ui};
use anyhow::Result;
use clap::{Args, ValueEnum};
use ncsmooth::feed::{JerkScheme, PlanOptions};
use ncsmooth::geom::{ParamCurve, ParamCurveArclen};
use ncsmooth::interp::{
    execute_into, InterpMethod, InterpOptions, PlanError, PlanReport, SetpointSink, SetpointWriter,
};
use ncsmooth::path::{Move, Toolpath};
use ncsmooth::smooth::band_time::TimeLimits;
use ncsmooth::smooth::{Method, SmoothReport, Smoothed};
use ncsmooth_gcode::PlanRunReport;
use ncsmooth_report::{self as report, MethodView, PageView, PlotData, PlotSink};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Name of the built-in butterfly input.
pub const BUILTIN_BUTTERFLY: &str = "builtin:butterfly";
/// Feed (mm/s) of the built-in butterfly.
const BUILTIN_FEED_MM_S: f64 = 50.0;
/// Accuracy (mm) of the arc-length sampling of `--path-samples`.
const SAMPLE_ACCURACY_MM: f64 = 1e-9;
/// Write buffer of the setpoint stream (bytes).
const SETPOINT_BUFFER_BYTES: usize = 1 << 20;
/// Shortest `--period` accepted (s): 10 us, a 100 kHz setpoint rate. CNC controllers take
/// position setpoints every 0.125 to 4 ms (LinuxCNC's servo thread runs at 1 ms); a shorter
/// period describes no machine, and the work and output grow as 1/period without bound.
pub const MIN_PERIOD_S: f64 = 1e-5;
/// Longest `--period` accepted (s): 100 ms, a 10 Hz setpoint rate, coarser than any
/// position loop. Longer steps no longer describe the motion (the rows' finite-difference
/// accelerations and the chord error the report measures lose their meaning), and such a
/// value is most likely milliseconds typed as seconds (`--period 10` for 10 ms).
pub const MAX_PERIOD_S: f64 = 0.1;
/// Typical bytes of one setpoint row (`t,x,y,z,feed` at 9 decimals, no extra axis): the
/// 6 927 405 rows of stellabee1 take 436 MB, 63 bytes each.
const TYPICAL_ROW_BYTES: u64 = 63;
/// Setpoint output (bytes, estimated from the lower bound on the rows) above which `plan`
/// says on stderr, before writing, how much it is about to write.
pub const LARGE_OUTPUT_BYTES: u64 = 1_000_000_000;

/// Jerk scheme names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum JerkSchemeArg {
    /// Trapezoid under jerk caps, averaged over a time window.
    Filter,
    /// Setpoints followed period by period under the measured limits.
    Follow,
}

/// Interpolation method names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum InterpArg {
    /// Newton-Raphson on the chord length (Wu eqs. 17-20).
    Newton,
    /// First-order Taylor step (Wu eq. 19).
    Taylor1,
    /// Second-order Taylor step.
    Taylor2,
}

/// Stopping rule of Wu eq. 20.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum NewtonStop {
    /// Stop when eta <= eta_tol and n iterations were made (eq. 20 as printed).
    Both,
    /// Stop when eta <= eta_tol or after n iterations (cheaper, noisier setpoints).
    Either,
}

/// Arguments of `plan`.
#[derive(Args, Clone, Debug)]
#[command(allow_negative_numbers = true)]
pub struct PlanArgs {
    /// G-code file, `-` for stdin, or `builtin:butterfly`.
    pub file: String,
    /// Smoothing method applied before planning (`none` plans the program as written).
    #[arg(long, value_enum, default_value = "none")]
    pub method: MethodArg,
    /// Reshape each method's fitted runs at their slow spots (speed below 0.7 x feed) to
    /// the fastest curve inside the same band for `--feed` and `--acc` (minimum-time
    /// optimisation, about a second of computing per spot). Off by default.
    #[arg(long)]
    pub time_shape: bool,
    /// Two-sided smoothing tolerance (mm).
    #[arg(long, default_value_t = 0.01)]
    pub tol: f64,
    /// Largest feed (mm/s); a lower programmed F wins.
    #[arg(long, default_value_t = 50.0)]
    pub feed: f64,
    /// Per-axis acceleration limit (mm/s^2): one value or x,y,z.
    #[arg(long, default_value = "500")]
    pub acc: String,
    /// Per-axis jerk limit (mm/s^3): one value or x,y,z. Given: a jerk-limited S-curve
    /// (the trapezoid under tighter caps, averaged over a time window); without it the
    /// profile is the trapezoid (linear acceleration).
    #[arg(long)]
    pub jerk: Option<String>,
    /// How `--jerk` makes its S-curve: `filter` (the trapezoid under caps that hold for
    /// any motion, averaged over a time window; provable, conservative) or `follow` (the
    /// setpoints chosen period by period under the limits as measured, below a
    /// braking-feasible ceiling; near time-optimal on smooth paths, slower to compute; a
    /// file it cannot follow within the limits is planned again with `filter`).
    #[arg(long, value_enum, default_value = "filter")]
    pub jerk_scheme: JerkSchemeArg,
    /// Per-axis velocity limit (mm/s): one value or x,y,z [default: none].
    #[arg(long)]
    pub vaxis: Option<String>,
    /// Rapid (G0) speed (mm/s) [default: --feed].
    #[arg(long)]
    pub rapid: Option<f64>,
    // The range is MIN_PERIOD_S ..= MAX_PERIOD_S.
    /// Interpolation period T (s), from 1e-5 to 0.1.
    #[arg(long, default_value_t = 0.001)]
    pub period: f64,
    /// Largest number of setpoint rows the plan may produce (written, printed or only
    /// measured). A plan whose cycle time at the speed caps already needs more is refused
    /// as soon as that is known (before planning when the program is held whole, as the
    /// moves arrive when a file is streamed); one that turns out longer stops when it
    /// passes N. Either way the run exits 2 and writes no file (setpoints already sent to
    /// stdout stay sent). [default: no limit; an estimate above 1 GB of CSV is printed to
    /// stderr when known]
    #[arg(long, value_name = "N")]
    pub max_rows: Option<u64>,
    /// Chord error delta (mm) of Wu eq. 21: v <= (2/T) sqrt(delta (2R - delta)).
    #[arg(long, default_value_t = 0.001)]
    pub chord_error: f64,
    /// Junction deviation (mm): pass unsmoothed corners at grbl's junction speed instead
    /// of stopping (the setpoints then exceed --acc at those corners; the report says so).
    #[arg(long)]
    pub junction_dev: Option<f64>,
    /// Interpolation method.
    #[arg(long, value_enum, default_value = "newton")]
    pub interp: InterpArg,
    /// Feed-fluctuation tolerance eta_tol (fraction; 0.001 = 0.1 %).
    #[arg(long, default_value_t = 0.001)]
    pub eta_tol: f64,
    /// Newton iterations n.
    #[arg(long, default_value_t = 2)]
    pub newton_iters: usize,
    /// Newton stopping rule (eq. 20).
    #[arg(long, value_enum, default_value = "both")]
    pub newton_stop: NewtonStop,
    /// Write each interpolation method's own setpoints instead of correcting every curve
    /// step onto the planned arc length (to compare --interp methods by their output).
    #[arg(long)]
    pub no_arc_correction: bool,
    /// Setpoints CSV (t s, x y z mm, feed mm/s, extra axes) [default: measured, not written].
    #[arg(long)]
    pub setpoints: Option<PathBuf>,
    /// JSON report file.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// HTML page of the plan (the page of `compare` for this one method: table, path with
    /// the tolerance band, curvature, feed, per-axis acceleration and jerk).
    #[arg(long, value_name = "FILE")]
    pub report_html: Option<PathBuf>,
    /// Also write the planned path sampled every --sample-ds mm of arc length (CSV
    /// s,x,y,z in mm; for external comparisons such as scripts/toppra_compare.py).
    #[arg(long)]
    pub path_samples: Option<PathBuf>,
    /// Arc-length spacing (mm) of --path-samples.
    #[arg(long, default_value_t = 0.05)]
    pub sample_ds: f64,
}

/// Parses a per-axis value: one number for all axes or `x,y,z`.
pub(crate) fn axes(name: &str, s: &str) -> Result<[f64; 3]> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| io::BadInput(format!("--{name} {s}: expected one number or x,y,z")))?;
    match v.as_slice() {
        [a] => Ok([*a; 3]),
        [a, b, c] => Ok([*a, *b, *c]),
        _ => Err(io::BadInput(format!("--{name} {s}: expected one number or x,y,z")).into()),
    }
}

fn builtin_butterfly() -> Toolpath {
    let b = ncsmooth::profiles::butterfly();
    let mut tp = Toolpath::new(b.start());
    tp.push_move(Move::feed(b, Some(BUILTIN_FEED_MM_S), 1));
    tp
}

/// Writes `s,x,y,z` every `ds` mm along the moves (and each move's end).
fn write_samples(out: &mut OutputFile, tp: &Toolpath, ds: f64) -> Result<()> {
    let mut w = BufWriter::new(out);
    writeln!(w, "s,x,y,z")?;
    let mut s0 = 0.0;
    let mut first = true;
    for m in tp.moves() {
        let seg = &m.segment;
        let len = seg.arclen(SAMPLE_ACCURACY_MM);
        if len <= 0.0 {
            continue;
        }
        let n = (len / ds).ceil().max(1.0) as usize;
        for i in usize::from(!first)..=n {
            let s = len * i as f64 / n as f64;
            let p = seg.eval(seg.inv_arclen(s, SAMPLE_ACCURACY_MM));
            writeln!(w, "{:.9},{:.9},{:.9},{:.9}", s0 + s, p.x, p.y, p.z)?;
        }
        first = false;
        s0 += len;
    }
    w.flush()?;
    Ok(())
}

/// Where `plan` takes its path from: a program held whole (smoothed at once), or a file
/// read, smoothed and planned a part at a time ([`crate::plan_stream`]).
enum Source<'o> {
    Whole(Smoothed),
    Streamed(Box<StreamedInput<'o>>),
}

impl Source<'_> {
    /// Plans into `sink`: the outer error is the input's, the inner the plan's.
    fn plan<S: SetpointSink + Send>(
        &mut self,
        popts: &PlanOptions,
        iopts: &InterpOptions,
        sink: S,
        max_rows: Option<u64>,
        announce: &(dyn Fn(f64) -> bool + Sync),
    ) -> Result<Result<(PlanReport, S), PlanError>> {
        match self {
            Source::Whole(s) => Ok(execute_into(&s.toolpath, popts, iopts, sink)),
            Source::Streamed(i) => i.plan(popts, iopts, sink, max_rows, announce),
        }
    }

    /// What smoothing did.
    fn report(&self) -> SmoothReport {
        match self {
            Source::Whole(s) => s.report.clone(),
            Source::Streamed(i) => i.report(),
        }
    }
}

/// Number of rows the writer lets through before [`RowLimit`] refuses a write: the row
/// limit plus the CSV header.
fn lines_allowed(max_rows: u64) -> u64 {
    max_rows.saturating_add(1)
}

/// Bytes counted per step of [`newlines`]: the most a `u8` counter can hold.
const NEWLINE_COUNT_CHUNK: usize = u8::MAX as usize;

/// Number of `\n` in `bytes`, counted in byte-wide lanes (the per-row count must not
/// slow the writing thread, the bottleneck of a large plan).
fn newlines(bytes: &[u8]) -> u64 {
    bytes
        .chunks(NEWLINE_COUNT_CHUNK)
        .map(|c| u64::from(c.iter().fold(0u8, |n, &b| n + u8::from(b == b'\n'))))
        .sum()
}

/// Refuses a `--period` outside [`MIN_PERIOD_S`] ..= [`MAX_PERIOD_S`] (bad input).
pub(crate) fn check_period(period: f64) -> Result<()> {
    if !(MIN_PERIOD_S..=MAX_PERIOD_S).contains(&period) {
        return Err(io::BadInput(format!(
            "--period {period:?} s is outside {MIN_PERIOD_S:?} ..= {MAX_PERIOD_S:?} s (the \
             interpolation period is in seconds: 1 ms is 0.001)"
        ))
        .into());
    }
    Ok(())
}

/// The smoothing `plan --method M --tol T` plans ([`ncsmooth::smooth_for_plan`]: the
/// streamed plan's windowed smoother run on the whole path, so that a program held whole
/// plans the path a streamed file does); a method refusing its options is bad input.
pub(crate) fn smooth_for_plan(
    tp: &Toolpath,
    method: Method,
    tol: f64,
    time_shape: Option<TimeLimits>,
) -> Result<Smoothed> {
    ncsmooth::smooth_for_plan(tp, method, tol, time_shape)
        .map_err(|e| io::BadInput(e.to_string()).into())
}

/// Marks the write error of [`RowLimit`].
#[derive(Debug)]
struct RowLimitExceeded;

impl std::fmt::Display for RowLimitExceeded {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("row limit exceeded")
    }
}
impl std::error::Error for RowLimitExceeded {}

/// The setpoint stream under `--max-rows`: counts the lines written and fails the write
/// that would pass the limit (before any of it reaches the output), which stops the
/// interpolation. Without a limit it only passes the bytes on.
struct RowLimit<W> {
    inner: W,
    /// Lines still allowed; `None` without a limit.
    lines_left: Option<u64>,
}

impl<W: Write> Write for RowLimit<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let Some(left) = self.lines_left else {
            return self.inner.write(buf);
        };
        let lines = newlines(buf);
        if lines > left {
            return Err(std::io::Error::other(RowLimitExceeded));
        }
        let n = self.inner.write(buf)?;
        // A short write passes on only part of the lines (rare: the rest comes again).
        let passed = if n == buf.len() {
            lines
        } else {
            newlines(&buf[..n])
        };
        self.lines_left = Some(left - passed);
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// Plans and interpolates into `out` (CSV) and `plots` (when given) under the row limit;
/// passing the limit is bad input.
#[allow(clippy::too_many_arguments)]
fn execute_limited<W: Write + Send>(
    source: &mut Source<'_>,
    popts: &PlanOptions,
    iopts: &InterpOptions,
    out: W,
    max_rows: Option<u64>,
    plots: Option<PlotSink>,
    announce: &(dyn Fn(f64) -> bool + Sync),
) -> Result<(PlanReport, W, Option<PlotSink>)> {
    let out = RowLimit {
        inner: out,
        lines_left: max_rows.map(lines_allowed),
    };
    match source.plan(
        popts,
        iopts,
        (SetpointWriter::new(out), plots),
        max_rows,
        announce,
    )? {
        Ok((report, (w, plots))) => Ok((report, w.into_inner()?.inner, plots)),
        Err(PlanError::Io(e))
            if e.get_ref()
                .is_some_and(|e| e.downcast_ref::<RowLimitExceeded>().is_some()) =>
        {
            Err(io::BadInput(format!(
                "the plan needs more than --max-rows {} setpoint rows (at --period {:?} s); \
                 stopped, nothing written",
                max_rows.unwrap_or_default(),
                popts.period_s
            ))
            .into())
        }
        Err(e) => Err(e.into()),
    }
}

/// The options under which the user asked for motion beyond the limits, if they took
/// effect: blended junction-deviation corners (velocity jumps) and uncorrected
/// interpolation steps (each method's own setpoints).
fn waivers(a: &PlanArgs, r: &PlanReport) -> Vec<&'static str> {
    let mut w = Vec::new();
    if a.junction_dev.is_some() && r.exact_stops.junction_blended > 0 {
        w.push("--junction-dev");
    }
    if a.no_arc_correction {
        w.push("--no-arc-correction");
    }
    w
}

/// The page of one plan ([`crate::report`]).
fn page_html(
    run: &PlanRunReport,
    name: &str,
    tol: f64,
    popts: &PlanOptions,
    program: &Toolpath,
    planned: Toolpath,
    plots: PlotSink,
) -> String {
    let data = PlotData::measure(program, planned, plots, tol);
    let page = PageView {
        title: format!("ncsmooth plan: {name}, {}", run.method),
        input: name,
        tol,
        limits: popts,
        program,
        source: None,
        methods: vec![MethodView {
            name: &run.method,
            plan: run,
            gcode: None,
            speedup: None,
            compute_s: run.plan.stage_time_s.total_s + run.smooth_s + run.parse_s,
            data: &data,
            setpoints_file: None,
        }],
        notes: Vec::new(),
    };
    report::render_page(&page).0
}

/// What `plan` does with a whole smoothed program before planning it: the path samples,
/// and the lower bound on the cycle time, against `--max-rows` (refused up front) and
/// the size of the output (announced).
fn whole_checks(
    a: &PlanArgs,
    ui: Ui,
    popts: &PlanOptions,
    smoothed: &Smoothed,
    samples_out: &mut Option<OutputFile>,
) -> Result<()> {
    if let Some(out) = samples_out {
        if a.sample_ds.is_nan() || a.sample_ds <= 0.0 {
            return Err(io::BadInput("--sample-ds must be positive".into()).into());
        }
        write_samples(out, &smoothed.toolpath, a.sample_ds)?;
    }
    // Every row is a period of the cycle, which cannot be shorter than the path at its
    // speed caps: refuse or announce a huge output before producing any of it.
    let min_cycle_s = popts.min_cycle_time_s(&smoothed.toolpath);
    // Truncated (not the row at t = 0 added): a margin of one row for rounding.
    let min_rows = (min_cycle_s / popts.period_s) as u64;
    if let Some(max) = a.max_rows.filter(|&max| min_rows > max) {
        return Err(io::BadInput(format!(
            "the cycle takes at least {min_cycle_s:.3} s (the path at its speed caps), so at \
             least {min_rows} setpoint rows at --period {:?} s, more than --max-rows {max}; \
             nothing written",
            a.period
        ))
        .into());
    }
    if let Some(note) = huge_output_note(a, min_cycle_s) {
        ui.status(note);
    }
    Ok(())
}

/// The note that a plan of at least `min_cycle_s` seconds makes more than
/// [`LARGE_OUTPUT_BYTES`] of setpoints, if it does.
pub(crate) fn huge_output_note(a: &PlanArgs, min_cycle_s: f64) -> Option<String> {
    // Truncated (not the row at t = 0 added): a margin of one row for rounding.
    let min_rows = (min_cycle_s / a.period) as u64;
    let min_bytes = min_rows.saturating_mul(TYPICAL_ROW_BYTES);
    if min_bytes <= LARGE_OUTPUT_BYTES {
        return None;
    }
    let fate = if a.setpoints.is_some() {
        "of setpoint CSV to write"
    } else {
        "of setpoints to compute (not written)"
    };
    Some(format!(
        "note: the cycle takes at least {min_cycle_s:.3} s: at least {min_rows} setpoint \
         rows at --period {:?} s, about {:.1} GB {fate} (--max-rows bounds it)",
        a.period,
        min_bytes as f64 / 1e9
    ))
}

/// Runs `plan`.
/// `--jerk-scheme follow` gave up on a run: the plan would break the jerk limit.
#[derive(Debug)]
struct FollowGaveUp(String);

impl std::fmt::Display for FollowGaveUp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for FollowGaveUp {}

/// Runs `plan`. With `--jerk-scheme follow`, a plan the follower could not finish within
/// the limits is planned again with the filter scheme (said on stderr; the report's
/// options give the scheme used), unless setpoints already went to stdout.
pub fn run(a: PlanArgs, ui: Ui) -> Result<()> {
    let to_stdout = a.setpoints.as_deref().is_some_and(|p| p.as_os_str() == "-");
    let fallback = (a.jerk_scheme == JerkSchemeArg::Follow && !to_stdout).then(|| PlanArgs {
        jerk_scheme: JerkSchemeArg::Filter,
        ..a.clone()
    });
    match (run_once(a, ui), fallback) {
        (Err(e), Some(b)) if e.downcast_ref::<FollowGaveUp>().is_some() => {
            ui.status(format!(
                "note: {e}; planning again with --jerk-scheme filter"
            ));
            run_once(b, ui)
        }
        (r, _) => r,
    }
}

fn run_once(a: PlanArgs, ui: Ui) -> Result<()> {
    check_plan_outputs(&a)?;
    check_period(a.period)?;
    let t0 = Instant::now();
    let method: Method = a.method.into();
    let name = if a.file == BUILTIN_BUTTERFLY {
        a.file.clone()
    } else {
        io::display_name(&a.file).to_string()
    };
    let shape = time_limits(&a)?;
    let (toolpath, streamed_input) = read_source(&a, ui, &name, method, shape)?;
    let parse_s = t0.elapsed().as_secs_f64();
    // Every output is opened before the work (a bad directory fails at once) and moved into
    // place only when all of them were written: a failed run leaves none behind.
    let mut samples_out = open(&a.path_samples)?;
    let setpoints_out = open(&a.setpoints)?;
    let mut report_out = open(&a.report)?;
    let mut html_out = open(&a.report_html)?;
    let (popts, iopts) = plan_options(&a)?;
    let t1 = Instant::now();
    let (mut source, program) = source_of(&a, (toolpath, streamed_input), method, shape)?;
    let smooth_s = t1.elapsed().as_secs_f64();
    let popts = match &source {
        Source::Whole(smoothed) => {
            whole_checks(&a, ui, &popts, smoothed, &mut samples_out)?;
            popts
        }
        // The jerk split of the first blocks; --max-rows is checked as the moves arrive.
        Source::Streamed(input) => input.tuned(&popts),
    };
    // A streamed plan learns its lower bound on the cycle time as the moves arrive.
    let announce = |min_cycle_s: f64| match huge_output_note(&a, min_cycle_s) {
        Some(note) => {
            ui.status(note);
            true
        }
        None => false,
    };
    let plots = program.is_some().then(PlotSink::default);
    let pb = progress::spinner(ui, "planning and interpolating");
    let (report, setpoints_out, plots) = execute_to(
        &mut source,
        (&popts, &iopts),
        setpoints_out,
        &a,
        plots,
        &announce,
    )?;
    pb.finish_and_clear();
    check_limits(&a, ui, &popts, &report)?;
    let total = t0.elapsed().as_secs_f64();
    let run = PlanRunReport {
        input: name.clone(),
        method: method.name().to_string(),
        smoothing: source.report(),
        parse_s,
        smooth_s,
        end_to_end_real_time_factor: report.cycle_time_s / total,
        plan: report,
    };
    write_reports(
        &a,
        ui,
        &run,
        &popts,
        (&mut report_out, &mut html_out),
        (program, plots, source),
    )?;
    io::commit_all(
        [samples_out, setpoints_out, report_out, html_out]
            .into_iter()
            .flatten(),
    )?;
    summary(ui, &name, &run);
    Ok(())
}

/// The limits `--time-shape` reshapes the runs for.
fn time_limits(a: &PlanArgs) -> Result<Option<TimeLimits>> {
    a.time_shape
        .then(|| -> Result<TimeLimits> {
            Ok(TimeLimits {
                feed_mm_s: a.feed,
                acc_mm_s2: axes("acc", &a.acc)?,
            })
        })
        .transpose()
}

/// The output file at `p`, created (not yet in place); `None` for none or stdout.
fn open(p: &Option<PathBuf>) -> Result<Option<OutputFile>> {
    match p {
        Some(p) if p.as_os_str() != "-" => Ok(Some(OutputFile::create(p)?)),
        _ => Ok(None),
    }
}

/// What is planned: a path held whole, smoothed now (with the program kept for the page
/// only), or the file streamed.
fn source_of<'o>(
    a: &PlanArgs,
    (toolpath, streamed_input): (Option<Toolpath>, Option<StreamedInput<'o>>),
    method: Method,
    shape: Option<TimeLimits>,
) -> Result<(Source<'o>, Option<Toolpath>)> {
    Ok(match (toolpath, streamed_input) {
        (Some(toolpath), _) => {
            let smoothed = smooth_for_plan(&toolpath, method, a.tol, shape)?;
            // The program is kept only for the page (its path and the tolerance band).
            let program = a.report_html.is_some().then_some(toolpath);
            (Source::Whole(smoothed), program)
        }
        (None, Some(input)) => (Source::Streamed(Box::new(input)), None),
        (None, None) => unreachable!("a file is loaded or streamed"),
    })
}

/// Fails when an output is the input or cannot be written.
fn check_plan_outputs(a: &PlanArgs) -> Result<()> {
    let outputs: Vec<(&str, &Path)> = [
        ("--path-samples", &a.path_samples),
        ("--setpoints", &a.setpoints),
        ("--report", &a.report),
        ("--report-html", &a.report_html),
    ]
    .into_iter()
    .filter_map(|(flag, p)| p.as_deref().map(|p| (flag, p)))
    .collect();
    let input = (a.file != BUILTIN_BUTTERFLY).then_some(a.file.as_str());
    io::check_outputs(input, &outputs)?;
    io::check_outputs(input, &outputs)
}

/// The built-in profile or the program loaded whole, or the file opened to be streamed.
fn read_source<'o>(
    a: &'o PlanArgs,
    ui: Ui,
    name: &'o str,
    method: Method,
    shape: Option<TimeLimits>,
) -> Result<(Option<Toolpath>, Option<StreamedInput<'o>>)> {
    // A file is read, smoothed and planned a part at a time unless an output needs the
    // whole path (the page, the path samples) or it comes from stdin.
    let streamed = a.file != BUILTIN_BUTTERFLY
        && a.file != "-"
        && a.report_html.is_none()
        && a.path_samples.is_none();
    let mut streamed_input = None;
    let toolpath = if a.file == BUILTIN_BUTTERFLY {
        Some(builtin_butterfly())
    } else if streamed {
        let input = StreamedInput::open(
            Path::new(&a.file),
            name,
            crate::parse_options(),
            method,
            a.tol,
            shape,
        )?;
        if let Some(line) = input.units_assumed() {
            ui.status(crate::units_warning(name, line));
        }
        streamed_input = Some(input);
        None
    } else {
        let program = load(&a.file)?.program;
        if let Some(line) = program.stats.units_assumed {
            ui.status(crate::units_warning(name, line));
        }
        Some(program.toolpath)
    };
    Ok((toolpath, streamed_input))
}

/// The JSON report and, for a plan held whole, the page.
fn write_reports(
    a: &PlanArgs,
    ui: Ui,
    run: &PlanRunReport,
    popts: &PlanOptions,
    (report_out, html_out): (&mut Option<OutputFile>, &mut Option<OutputFile>),
    (program, plots, source): (Option<Toolpath>, Option<PlotSink>, Source),
) -> Result<()> {
    let json = serde_json::to_string_pretty(run)?;
    match (report_out, &a.report) {
        (Some(f), _) => f.write_all(json.as_bytes())?,
        (None, Some(_)) => io::print_stdout(json.as_bytes())?,
        (None, None) => {}
    }
    if let (Some(f), Some(program), Some(plots), Source::Whole(smoothed)) =
        (html_out, &program, plots, source)
    {
        let pb = progress::spinner(ui, "measuring the path for the page");
        let html = page_html(
            run,
            &run.input,
            a.tol,
            popts,
            program,
            smoothed.toolpath,
            plots,
        );
        pb.finish_and_clear();
        f.write_all(html.as_bytes())?;
    }
    Ok(())
}

/// The planner's and the interpolator's options these arguments ask for.
fn plan_options(a: &PlanArgs) -> Result<(PlanOptions, InterpOptions)> {
    let popts = PlanOptions {
        feed_mm_s: a.feed,
        rapid_mm_s: a.rapid,
        acc_mm_s2: axes("acc", &a.acc)?,
        jerk_mm_s3: a.jerk.as_deref().map(|v| axes("jerk", v)).transpose()?,
        vaxis_mm_s: a.vaxis.as_deref().map(|v| axes("vaxis", v)).transpose()?,
        period_s: a.period,
        chord_error_mm: a.chord_error,
        junction_dev_mm: a.junction_dev,
        jerk_split: None,
        jerk_scheme: match a.jerk_scheme {
            JerkSchemeArg::Filter => JerkScheme::Filter,
            JerkSchemeArg::Follow => JerkScheme::Follow,
        },
        top_speed_mm_s: None,
    };
    popts
        .validate()
        .map_err(|e| io::BadInput(format!("--{e}")))?;
    if !(a.eta_tol >= 0.0 && a.eta_tol.is_finite()) {
        return Err(io::BadInput(format!("--eta-tol {} must be >= 0", a.eta_tol)).into());
    }
    let iopts = InterpOptions {
        method: match a.interp {
            InterpArg::Newton => InterpMethod::Newton,
            InterpArg::Taylor1 => InterpMethod::Taylor1,
            InterpArg::Taylor2 => InterpMethod::Taylor2,
        },
        eta_tol: a.eta_tol,
        max_iters: a.newton_iters,
        stop_on_either: a.newton_stop == NewtonStop::Either,
        arc_correction: !a.no_arc_correction,
    };
    Ok((popts, iopts))
}

/// Plans `source` into the setpoint output asked for (a file, stdout, or nowhere).
fn execute_to(
    source: &mut Source,
    (popts, iopts): (&PlanOptions, &InterpOptions),
    setpoints_out: Option<OutputFile>,
    a: &PlanArgs,
    plots: Option<PlotSink>,
    announce: &(dyn Fn(f64) -> bool + Sync),
) -> Result<(PlanReport, Option<OutputFile>, Option<PlotSink>)> {
    let max = a.max_rows;
    Ok(match (setpoints_out, &a.setpoints) {
        (Some(f), _) => {
            let w = BufWriter::with_capacity(SETPOINT_BUFFER_BYTES, f);
            let (rep, w, plots) = execute_limited(source, popts, iopts, w, max, plots, announce)?;
            (
                rep,
                Some(w.into_inner().map_err(|e| e.into_error())?),
                plots,
            )
        }
        (None, Some(_)) => {
            // Unlocked: the setpoints are written from the planner's second thread.
            let w = BufWriter::with_capacity(SETPOINT_BUFFER_BYTES, std::io::stdout());
            let (rep, _, plots) = execute_limited(source, popts, iopts, w, max, plots, announce)?;
            (rep, None, plots)
        }
        (None, None) => {
            let (rep, _, plots) =
                execute_limited(source, popts, iopts, std::io::sink(), max, plots, announce)?;
            (rep, None, plots)
        }
    })
}

/// Fails when the measured setpoints break a limit the user did not waive.
fn check_limits(a: &PlanArgs, ui: Ui, popts: &PlanOptions, report: &PlanReport) -> Result<()> {
    let waived = waivers(a, report);
    if let Some(broken) = report.broken_limits() {
        if waived.is_empty() {
            if popts.jerk_scheme == JerkScheme::Follow {
                return Err(FollowGaveUp(format!(
                    "--jerk-scheme follow gave up on a stop-to-stop run (sampled from the \
                     trapezoid, it breaks the limits: {broken})"
                ))
                .into());
            }
            anyhow::bail!("the plan does not hold its limits: {broken}; nothing written");
        }
        ui.status(format!(
            "warning: limits exceeded as asked for by {}: {broken}",
            waived.join(" and ")
        ));
    }
    Ok(())
}

/// The plan's one-line summary (and a note on jumps) on stderr.
fn summary(ui: Ui, name: &str, run: &PlanRunReport) {
    let r = &run.plan;
    let worst = r.axes.iter().map(|x| x.a_ratio).fold(0.0f64, f64::max);
    let jerk = r
        .axes
        .iter()
        .filter_map(|x| x.j_ratio)
        .reduce(f64::max)
        .map_or(String::new(), |j| {
            format!(", worst axis jerk {j:.4} x limit")
        });
    ui.status(format!(
        "{name}: cycle {:.3} s, {} setpoints, eta max {:.3e} %, worst axis acc {:.4} x limit{jerk}, stops: {} corner {} event {} dwell; real-time factor {:.0} (end to end {:.0})",
        r.cycle_time_s,
        r.setpoints,
        r.interp.eta_max * 100.0,
        worst,
        r.exact_stops.corner,
        r.exact_stops.event,
        r.exact_stops.dwell,
        r.real_time_factor,
        run.end_to_end_real_time_factor
    ));
    if !r.jumps.is_empty() {
        let total: f64 = r.jumps.iter().map(|j| j.distance_mm).sum();
        ui.status(format!(
            "note: {} jump(s) in the setpoints ({total:.3} mm in all, first at t = {:.3} s): the controller runs motion ncsmooth cannot place there (G28/G30, G53, a move from an unknown position); its time is not in the cycle time (see `jumps` in the report)",
            r.jumps.len(),
            r.jumps[0].t_s
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;
    use ncsmooth::geom::Vec3;
    use ncsmooth::interp::execute;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        plan: PlanArgs,
    }

    fn report(popts: &PlanOptions, iopts: &InterpOptions) -> PlanReport {
        let tp = Toolpath::from_polyline(
            &[
                Vec3::ZERO,
                Vec3::new(5.0, 0.0, 0.0),
                Vec3::new(5.0, 5.0, 0.0),
            ],
            None,
        );
        execute(&tp, popts, iopts, std::io::sink()).unwrap().0
    }

    #[test]
    fn measured_violations_are_named_and_waived_only_when_asked_for() {
        let popts = PlanOptions {
            jerk_mm_s3: Some([2000.0; 3]),
            ..Default::default()
        };
        let held = report(&popts, &InterpOptions::default());
        assert!(held.limits_held);
        assert_eq!(held.broken_limits(), None);
        // A report whose setpoints exceed a limit names it, and a plain run has no waiver:
        // `run` fails (exit 1, nothing committed).
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
        let args = |extra: &[&str]| {
            let mut v = vec!["plan", "f.ngc"];
            v.extend_from_slice(extra);
            Cli::parse_from(v).plan
        };
        assert!(waivers(&args(&[]), &broken).is_empty());
        assert!(waivers(&args(&["--junction-dev", "0.01"]), &broken).is_empty());
        assert_eq!(
            waivers(&args(&["--no-arc-correction"]), &broken),
            ["--no-arc-correction"]
        );
        // Junction deviation waives only when it blended a corner.
        let jd = PlanOptions {
            junction_dev_mm: Some(0.01),
            ..Default::default()
        };
        let blended = report(&jd, &InterpOptions::default());
        assert_eq!(blended.exact_stops.junction_blended, 1);
        assert!(!blended.limits_held, "a velocity jump at the corner");
        assert_eq!(
            waivers(&args(&["--junction-dev", "0.01"]), &blended),
            ["--junction-dev"]
        );
    }

    #[test]
    fn newlines_are_counted_across_chunks() {
        let text = "a\n\n".repeat(1000);
        assert_eq!(newlines(text.as_bytes()), 2000);
        assert_eq!(newlines(&[b'\n'; 256]), 256);
        assert_eq!(newlines(b""), 0);
    }

    #[test]
    fn row_limit_fails_the_write_that_would_pass_it() {
        let mut w = RowLimit {
            inner: Vec::new(),
            lines_left: Some(lines_allowed(2)),
        };
        w.write_all(b"t,x\n0,1\n").unwrap();
        w.write_all(b"1,2\n").unwrap();
        let e = w.write_all(b"2,3\n").unwrap_err();
        assert!(e.get_ref().unwrap().is::<RowLimitExceeded>());
        assert_eq!(w.inner, b"t,x\n0,1\n1,2\n");
    }
}
