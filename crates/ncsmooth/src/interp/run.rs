//! The planning-and-interpolation run: index the path, stream the planned profile
//! ([`crate::feed::plan_stream`]) through the sampler (one sample per period `T`, at
//! `t = n T`), the [`Interpolator`] and into a [`SetpointSink`] (the CSV
//! [`SetpointWriter`] for [`execute`]) through the measuring adapter [`Measured`], and
//! report what was measured. Nothing is collected (unless the sink collects): memory is
//! bounded by the planner's window.
//!
//! A pipeline of threads ([`std::thread::scope`]): the calling thread indexes and plans and
//! takes the samples (the planner computes the grid of the moves ahead on a thread of its
//! own on long programs, see [`crate::feed::plan_stream`]); a second thread interpolates
//! them; a third formats, measures and writes the setpoints. Each hands the next batches
//! of [`EMIT_BATCH`] through a channel of at most [`EMIT_QUEUE_BATCHES`] batches (so the
//! memory stays bounded). The order of samples and rests is kept; the stage times of the
//! threads overlap, and `total_s` is the wall-clock time of the whole run. On two cores
//! the work of all stages is shared by both, whichever stage is the longest.
//!
//! Time: every stop (corner, event, dwell, end) is held until the next period boundary,
//! so stop points are setpoints and the last row, at the first period boundary at or after
//! the end of motion, is exactly the program's end point.
//!
//! Jerk mode ([`crate::feed::jerk`]): the samples are taken on the moving average of the
//! planned arc length over the window `W` (exact integrals of the constant-acceleration
//! pieces over the window, kept in a queue of at most `W` of plan), each stop held `W`
//! longer; a sample whose whole window is at rest is exactly the rest point. The feed
//! column is the filtered speed.

use super::follow;
use super::setpoints::{FdStats, Setpoint, SetpointWriter};
use super::sink::{Measured, SetpointSink};
use super::{InterpOptions, InterpStats, Interpolator};
use crate::feed::grid::{IndexFeeder, RestRef};
use crate::feed::window::{MoveWindow, Reader};
use crate::feed::{
    plan_stream, JerkScheme, PathIndex, PlanEvent, PlanOptions, PlanOptionsError, PlanStats,
    ProfilePiece, StopCounts, StopReason, VEL_NOISE_MM,
};
use crate::path::{Toolpath, EXTRA_AXIS_NAMES};
use serde::Serialize;
use std::io::{self, Write};
use std::time::Instant;

/// Slack (in periods) when rounding a stop time up to the period grid, so a stop that
/// lands on a boundary up to rounding is not pushed a whole period later.
const PERIOD_ROUND_SLACK: f64 = 1e-9;

/// A stretch of the planned (unfiltered) time line: motion with constant acceleration or
/// rest.
#[derive(Clone, Copy, Debug)]
struct Stretch {
    t0: f64,
    t1: f64,
    s0: f64,
    v0: f64,
    a: f64,
    rest: bool,
}

impl Stretch {
    /// Means of `s` and of the speed over `[lo, hi]` (inside the stretch). Written
    /// without differences of powers of the times (`b^2 - a^2` of two times 100 s apart
    /// loses 13 digits when the window is 1e-8 s short; see [`MovingAverage::sample`]).
    fn means(&self, lo: f64, hi: f64) -> (f64, f64) {
        if self.rest {
            return (self.s0, 0.0);
        }
        let (a, b) = (lo - self.t0, hi - self.t0);
        (
            self.s0 + 0.5 * self.v0 * (a + b) + self.a * (a * a + a * b + b * b) / 6.0,
            self.v0 + 0.5 * self.a * (a + b),
        )
    }
}

/// Jerk mode: the moving average of the planned arc length over a window `w`
/// (see [`crate::feed::jerk`]): `s_f(t) = (1/w) int_{t-w}^{t} s`, the plan resting at
/// `s = 0` before `t = 0`.
struct MovingAverage {
    w: f64,
    line: std::collections::VecDeque<Stretch>,
    /// The planned time line is known up to here.
    t_known: f64,
    last_s: f64,
}

impl MovingAverage {
    fn new(w: f64) -> Self {
        let mut line = std::collections::VecDeque::new();
        line.push_back(Stretch {
            t0: -w,
            t1: 0.0,
            s0: 0.0,
            v0: 0.0,
            a: 0.0,
            rest: true,
        });
        MovingAverage {
            w,
            line,
            t_known: 0.0,
            last_s: 0.0,
        }
    }
    fn push(&mut self, st: Stretch) {
        if st.t1 > st.t0 {
            self.line.push_back(st);
        }
        self.t_known = self.t_known.max(st.t1);
    }
    /// Filtered arc length and speed at `t` (`t <= t_known`): the means of the plan's `s`
    /// and speed over the window, as the span-weighted average of each stretch's own means
    /// (a convex combination of values inside the window, so the rounding of the window's
    /// ends, relative to the time, only moves weight between values that differ by the
    /// speed times the window; the integral of each stretch from its start time loses the
    /// digits of the window's length against the time).
    fn sample(&mut self, t: f64) -> (f64, f64) {
        let lo = t - self.w;
        while self.line.len() > 1 && self.line[0].t1 <= lo {
            self.line.pop_front();
        }
        let (mut span, mut sum_s, mut sum_v) = (0.0, 0.0, 0.0);
        let mut rest_s: Option<f64> = None;
        let mut all_rest = true;
        for st in &self.line {
            if st.t0 >= t {
                break;
            }
            if st.t1 <= lo {
                continue;
            }
            let (a, b) = (st.t0.max(lo), st.t1.min(t));
            let (ms, mv) = st.means(a, b);
            span += b - a;
            sum_s += (b - a) * ms;
            sum_v += (b - a) * mv;
            if st.rest && rest_s.is_none_or(|s| s == st.s0) {
                rest_s = Some(st.s0);
            } else {
                all_rest = false;
            }
        }
        let (s, v) = match rest_s {
            // At rest over the whole window: exactly the rest point.
            Some(r) if all_rest => (r, 0.0),
            _ if span > 0.0 => (sum_s / span, (sum_v / span).max(0.0)),
            _ => (self.last_s, 0.0),
        };
        // Monotone despite rounding (the interpolator never goes back).
        let s = s.max(self.last_s);
        self.last_s = s;
        (s, v)
    }
}

/// Errors of a run.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// Invalid options.
    #[error(transparent)]
    Options(PlanOptionsError),
    /// Writing the setpoints failed.
    #[error("writing setpoints: {0}")]
    Io(io::Error),
}

/// Measured maxima of one extra axis.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ExtraAxisReport {
    /// Axis name.
    pub axis: char,
    /// Largest finite-difference velocity (units/s).
    pub v_max_per_s: f64,
    /// Largest finite-difference acceleration (units/s^2).
    pub a_max_per_s2: f64,
}

/// Measured maxima of one axis against its limits.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AxisReport {
    /// Axis name.
    pub axis: char,
    /// Largest finite-difference velocity (mm/s).
    pub v_max_mm_s: f64,
    /// Velocity limit (mm/s): `--vaxis`, else the larger of feed and rapid.
    pub v_limit_mm_s: f64,
    /// `v_max <= v_limit`; when the limit is the feed (no `--vaxis`), up to the first
    /// difference's noise `VEL_NOISE_MM` (2e-9)` / T`.
    pub v_within: bool,
    /// Largest finite-difference acceleration (mm/s^2).
    pub a_max_mm_s2: f64,
    /// Time of the largest acceleration (s).
    pub a_max_at_s: f64,
    /// Acceleration limit (mm/s^2).
    pub a_limit_mm_s2: f64,
    /// `a_max / a_limit`.
    pub a_ratio: f64,
    /// `a_max <= a_limit` (the planner reserves for the finite-difference noise, see
    /// [`crate::feed`]).
    pub a_within: bool,
    /// Largest finite-difference jerk (mm/s^3).
    pub j_max_mm_s3: f64,
    /// Time of the largest jerk (s).
    pub j_max_at_s: f64,
    /// Jerk limit (mm/s^3), when jerk limiting was asked for (the trapezoid profile is not
    /// jerk-limited).
    pub j_limit_mm_s3: Option<f64>,
    /// `j_max / j_limit`, when limited.
    pub j_ratio: Option<f64>,
    /// `j_max <= j_limit` (true when not limited).
    pub j_within: bool,
}

/// Time per stage (s).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct StageTimes {
    /// Indexing the path (lengths, joints).
    pub index_s: f64,
    /// Look-ahead planning.
    pub plan_s: f64,
    /// Interpolation (finding the setpoints on the path).
    pub interpolate_s: f64,
    /// Formatting, writing and measuring the rows.
    pub write_s: f64,
    /// The whole run, wall clock. Interpolation and writing run on threads of their own
    /// while the planner works, so the stages add up to more than this.
    pub total_s: f64,
}

/// What a run did and measured.
#[derive(Clone, Debug, Serialize)]
pub struct PlanReport {
    /// The limits used.
    pub options: PlanOptions,
    /// The interpolation settings.
    pub interp_options: InterpOptions,
    /// Time of the last setpoint (s).
    pub cycle_time_s: f64,
    /// Setpoint rows written.
    pub setpoints: usize,
    /// Path length planned (mm).
    pub path_length_mm: f64,
    /// Moves planned (zero-length moves dropped).
    pub moves: usize,
    /// Interpolation statistics (eta as a fraction).
    pub interp: InterpStats,
    /// Per-axis finite-difference maxima on the printed setpoints, against the limits.
    pub axes: Vec<AxisReport>,
    /// Extra axes of the program (their CSV columns, machine coordinates): measured
    /// finite-difference maxima. They have no limits of their own (see [`crate::feed::grid`]).
    pub extra_axes: Vec<ExtraAxisReport>,
    /// Finite-difference noise bound of the printed positions (0.5e-9 mm rounding):
    /// acceleration `2e-9 / T^2` (mm/s^2). For information: the planner reserves for it
    /// (and for the interpolator's landing errors), the limits are checked without it.
    pub fd_acc_noise_mm_s2: f64,
    /// Same for jerk: `4e-9 / T^3` (mm/s^3).
    pub fd_jerk_noise_mm_s3: f64,
    /// Every axis within its velocity and acceleration limits (and jerk, when limited),
    /// measured on the printed setpoints without a noise allowance (limits too small for
    /// the print resolution are refused by [`PlanOptions::validate`]). False when
    /// junction-deviation corners or uncorrected interpolation steps were asked for and
    /// exceeded them, or on a planner defect.
    pub limits_held: bool,
    /// Jumps between setpoint rows: the machine stopped, the controller ran motion that
    /// ncsmooth cannot place (a G28/G30 return, a G53 move, a move from a position the
    /// program had not established), and the plan resumes at the next known position.
    /// Finite differences are measured within the sections between them.
    pub jumps: Vec<super::setpoints::Jump>,
    /// Exact stops by reason (and corners blended by the junction-deviation rule).
    pub exact_stops: StopCounts,
    /// Planner statistics.
    pub planning: PlanStats,
    /// Distance from the last printed setpoint to the program's end point (mm).
    pub end_point_error_mm: f64,
    /// Distance from the first printed setpoint to the program's start (mm).
    pub start_point_error_mm: f64,
    /// Time per stage.
    pub stage_time_s: StageTimes,
    /// Cycle time / compute time.
    pub real_time_factor: f64,
}

impl PlanReport {
    /// The limits the measured setpoints exceed, named with their figures, or `None` when
    /// [`PlanReport::limits_held`].
    pub fn broken_limits(&self) -> Option<String> {
        if self.limits_held {
            return None;
        }
        let mut out = Vec::new();
        for x in &self.axes {
            if !x.v_within {
                out.push(format!(
                    "{} velocity {:.6} > {} mm/s",
                    x.axis, x.v_max_mm_s, x.v_limit_mm_s
                ));
            }
            if !x.a_within {
                out.push(format!(
                    "{} acceleration {:.6} > {} mm/s^2 at t = {:.4} s",
                    x.axis, x.a_max_mm_s2, x.a_limit_mm_s2, x.a_max_at_s
                ));
            }
            if let (false, Some(j)) = (x.j_within, x.j_limit_mm_s3) {
                out.push(format!(
                    "{} jerk {:.6} > {j} mm/s^3 at t = {:.4} s",
                    x.axis, x.j_max_mm_s3, x.j_max_at_s
                ));
            }
        }
        Some(out.join(", "))
    }
}

/// Planned samples collected before they are sent to the emitting thread, interpolated
/// and written (and their time is taken).
const EMIT_BATCH: usize = 4096;
/// Batches the channel to the emitting thread holds before the planner waits.
const EMIT_QUEUE_BATCHES: usize = 4;

/// What the planning thread sends the emitting thread, in order.
#[derive(Clone, Copy)]
enum EmitItem {
    /// A sample `(t, s, v)`.
    Sample(f64, f64, f64),
    /// The machine comes to rest at `s` (see [`Emitter::rest_at`]); extra-axis motions
    /// there begin at time `begin`.
    RestAt { s: f64, begin: f64 },
}

/// The planning thread's end of the channel: collects items into batches.
struct EmitQueue {
    tx: std::sync::mpsc::SyncSender<Vec<EmitItem>>,
    batch: Vec<EmitItem>,
}

impl EmitQueue {
    fn push(&mut self, time: f64, s: f64, v: f64) {
        self.send(EmitItem::Sample(time, s, v));
    }

    fn rest_at(&mut self, s: f64, begin: f64) {
        self.send(EmitItem::RestAt { s, begin });
    }

    fn send(&mut self, item: EmitItem) {
        self.batch.push(item);
        if self.batch.len() >= EMIT_BATCH {
            self.flush();
        }
    }

    fn flush(&mut self) {
        if !self.batch.is_empty() {
            let full = std::mem::replace(&mut self.batch, Vec::with_capacity(EMIT_BATCH));
            // A closed channel means the emitter stopped after a write error, which the
            // writing thread keeps.
            let _ = self.tx.send(full);
        }
    }
}

/// Turns planned samples `(t, s, v)` into setpoints: collected in batches, interpolated,
/// given the extra-axis motion of the stop they rest at (if any), and sent to the writing
/// thread ([`write_setpoints`]); stops when that thread hangs up. Times the interpolation.
struct Emitter<'i, 'p> {
    interp: Interpolator<'p>,
    /// To the writing thread; `None` once it hung up (a write failed).
    out: Option<std::sync::mpsc::SyncSender<Vec<Setpoint>>>,
    /// Where the rests come from.
    index: &'i PathIndex,
    /// Next rest to look at.
    next_rest: usize,
    /// The stop whose extra-axis motions apply: when they begin (s) and the rest.
    rest: Option<(f64, RestRef<'i>)>,
    batch: Vec<(f64, f64, f64)>,
    interp_s: f64,
}

impl<'i, 'p> Emitter<'i, 'p> {
    /// Handles the items of the planning thread until it hangs up or a write fails.
    fn run(&mut self, rx: std::sync::mpsc::Receiver<Vec<EmitItem>>) {
        for items in rx {
            for item in items {
                match item {
                    EmitItem::Sample(t, s, v) => self.batch.push((t, s, v)),
                    EmitItem::RestAt { s, begin } => self.rest_at(s, begin),
                }
            }
            self.flush();
            if self.out.is_none() {
                return;
            }
        }
    }

    /// The machine comes to rest at `s`: extra-axis motions there (if any) start at
    /// `begin`. Samples queued before belong to the motion before and are written first.
    fn rest_at(&mut self, s: f64, begin: f64) {
        self.flush();
        let mut next = self.index.rest(self.next_rest, s);
        while next.as_ref().is_some_and(|r| r.s < s) {
            self.next_rest += 1;
            next = self.index.rest(self.next_rest, s);
        }
        self.rest = match next {
            Some(r) if r.s == s => {
                self.next_rest += 1;
                Some((begin, r))
            }
            _ => None,
        };
        self.index.release_rests(self.next_rest);
    }

    /// Interpolates the queued samples and sends them to the writing thread.
    fn flush(&mut self) {
        if self.batch.is_empty() {
            return;
        }
        let c0 = Instant::now();
        let mut points = Vec::with_capacity(self.batch.len());
        for &(time, s, feed) in &self.batch {
            let (p, mut extra) = self.interp.advance(s);
            if let Some((begin, r)) = &self.rest {
                // At rest on the stop's point, after its extra-axis motions began.
                if s == r.s && time >= *begin {
                    extra = Some(r.at(time - begin));
                }
            }
            points.push(Setpoint {
                t: time,
                p,
                feed,
                extra,
                jump: self.interp.take_jump(),
            });
        }
        self.batch.clear();
        self.interp_s += c0.elapsed().as_secs_f64();
        if let Some(tx) = &self.out {
            if tx.send(points).is_err() {
                self.out = None;
            }
        }
    }
}

/// The writing thread: formats, measures and writes the setpoints it receives until the
/// emitter hangs up or a write fails (then it hangs up, which stops the emitter). Returns
/// the first error and the time spent.
fn write_setpoints<S: SetpointSink>(
    writer: &mut Measured<S>,
    rx: std::sync::mpsc::Receiver<Vec<Setpoint>>,
) -> (Option<io::Error>, f64) {
    let mut write_s = 0.0;
    for batch in rx {
        let c0 = Instant::now();
        for sp in &batch {
            if let Err(e) = writer.push(sp) {
                return (Some(e), write_s + c0.elapsed().as_secs_f64());
            }
        }
        write_s += c0.elapsed().as_secs_f64();
    }
    (None, write_s)
}

/// Plans `path` under `popts`, interpolates it with `iopts` and writes the setpoints to
/// `out` as CSV ([`SetpointWriter`]; use [`execute_into`] with a
/// [`super::NullSink`] to only measure). Returns the report and the writer.
pub fn execute<W: Write + Send>(
    path: &Toolpath,
    popts: &PlanOptions,
    iopts: &InterpOptions,
    out: W,
) -> Result<(PlanReport, W), PlanError> {
    let (report, writer) = execute_into(path, popts, iopts, SetpointWriter::new(out))?;
    Ok((report, writer.into_inner().map_err(PlanError::Io)?))
}

/// Plans `path` under `popts`, interpolates it with `iopts` and hands the setpoints to
/// `sink` (see [`SetpointSink`]; the report is measured on the rows as printed, whichever
/// the sink). Returns the report and the sink, finished.
///
/// ```
/// use ncsmooth::feed::PlanOptions;
/// use ncsmooth::geom::Vec3;
/// use ncsmooth::interp::{execute_into, InterpOptions, Setpoint};
/// use ncsmooth::path::Toolpath;
///
/// let tp = Toolpath::from_polyline(&[Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)], None);
/// let (report, rows) = execute_into(
///     &tp,
///     &PlanOptions::default(),
///     &InterpOptions::default(),
///     Vec::<Setpoint>::new(),
/// )
/// .unwrap();
/// assert_eq!(rows.len(), report.setpoints);
/// assert_eq!(rows.last().unwrap().p, Vec3::new(10.0, 0.0, 0.0));
/// ```
pub fn execute_into<S: SetpointSink + Send>(
    path: &Toolpath,
    popts: &PlanOptions,
    iopts: &InterpOptions,
    sink: S,
) -> Result<(PlanReport, S), PlanError> {
    popts.validate().map_err(PlanError::Options)?;
    let clock = Instant::now();
    // The path's own top speed (raising a limit no move reaches changes nothing), and in
    // jerk mode without a given split the fastest candidate for this path.
    let mut tuned = PlanOptions {
        top_speed_mm_s: popts.top_speed_mm_s.or(Some(popts.top_speed_of(path))),
        ..popts.clone()
    };
    if tuned.jerk_mm_s3.is_some()
        && tuned.jerk_split.is_none()
        && tuned.jerk_scheme == JerkScheme::Filter
    {
        tuned.jerk_split = Some(crate::feed::jerk::fastest_split(path, &tuned));
    }
    let popts = &tuned;
    let index = PathIndex::new(path, popts);
    let index_s = clock.elapsed().as_secs_f64();
    run_index(&index, popts, iopts, sink, clock, index_s)
}

/// Plans a program that arrives block by block, in memory bounded by what the planner's
/// readers still need ([`crate::feed::window`]): `feed` runs on a thread of its own and
/// hands every block of the program, in order, to the [`IndexFeeder`] it is given
/// (stopping early when [`IndexFeeder::wanted`] turns false); planning, interpolation and
/// the `sink` work as in [`execute_into`], while it feeds. `start` is where the program
/// starts and `extra_axes_mask` the extra axes it uses (the setpoints' columns, needed
/// before the first row). Jerk mode plans with `popts.jerk_split`, or the default split
/// when it is `None` (choose one from the program's first blocks with
/// [`crate::feed::jerk::fastest_split`]). The setpoints equal those of [`execute_into`] on
/// the same blocks. Returns the planning result and `feed`'s.
///
/// Smoothing and planning a program that is never held whole (here a zig-zag made on the
/// fly; a G-code file would come from `ncsmooth_gcode::BlockReader`):
///
/// ```
/// use ncsmooth::smooth::{Method, SmoothOptions};
/// use ncsmooth::{execute_streamed, Block, InterpOptions, Line, Move, PlanOptions};
/// use ncsmooth::{Setpoint, StreamOptions, StreamSmoother, Vec3};
///
/// let p = |k: usize| Vec3::new(k as f64, if k % 2 == 0 { 0.0 } else { 0.5 }, 0.0);
/// let mut sopts = SmoothOptions::default();
/// sopts.method = Method::Bspline;
/// sopts.tol_mm = 0.01;
/// let mut smoother = StreamSmoother::new(sopts, StreamOptions::default()).unwrap();
/// let (planned, fed) = execute_streamed(
///     p(0),
///     0,
///     &PlanOptions::default(),
///     &InterpOptions::default(),
///     Vec::<Setpoint>::new(),
///     |feeder| {
///         let mut out = Vec::new();
///         for k in 1..=20 {
///             let m = Move::feed(Line::new(p(k - 1), p(k)), Some(50.0), k as u32);
///             smoother.push(Block::Move(m), &mut out);
///             out.drain(..).for_each(|b| feeder.push(b));
///         }
///         smoother.finish(&mut out);
///         out.drain(..).for_each(|b| feeder.push(b));
///         Ok::<(), ()>(())
///     },
/// );
/// fed.unwrap();
/// let (report, rows) = planned.unwrap();
/// assert!(report.limits_held);
/// assert_eq!(rows.last().unwrap().p, p(20));
/// ```
pub fn execute_streamed<S, E>(
    start: crate::geom::Vec3,
    extra_axes_mask: u8,
    popts: &PlanOptions,
    iopts: &InterpOptions,
    sink: S,
    feed: impl FnOnce(&mut IndexFeeder<'_>) -> Result<(), E> + Send,
) -> (Result<(PlanReport, S), PlanError>, Result<(), E>)
where
    S: SetpointSink + Send,
    E: Send,
{
    if let Err(e) = popts.validate() {
        return (Err(PlanError::Options(e)), Ok(()));
    }
    let clock = Instant::now();
    let window = std::sync::Arc::new(MoveWindow::default());
    let index = PathIndex::streamed(window.clone(), start, extra_axes_mask);
    std::thread::scope(|scope| {
        let feeding = scope.spawn(|| {
            let mut guard = FinishOnDrop(Some(&window));
            let mut feeder = IndexFeeder::new(popts, window.clone());
            let r = feed(&mut feeder);
            feeder.finish(start);
            guard.disarm();
            r
        });
        let planned = run_index(&index, popts, iopts, sink, clock, 0.0);
        let fed = feeding
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e));
        (planned, fed)
    })
}

/// Plans and interpolates `index` into `sink` (see [`execute_into`]); `index_s` is the
/// time spent indexing before, `clock` started with the run.
fn run_index<S: SetpointSink + Send>(
    index: &PathIndex,
    popts: &PlanOptions,
    iopts: &InterpOptions,
    sink: S,
    clock: Instant,
    index_s: f64,
) -> Result<(PlanReport, S), PlanError> {
    // However the run ends (a panic in a reader included), nothing more is read: a feeder
    // waiting for room goes on (and learns it is not wanted) instead of waiting forever.
    let _done = StopReading(index);
    run_index_inner(index, popts, iopts, sink, clock, index_s)
}

/// Tells a streamed index, when dropped, that none of its readers reads any more.
struct StopReading<'i>(&'i PathIndex);

impl Drop for StopReading<'_> {
    fn drop(&mut self) {
        for r in [
            Reader::GridProducer,
            Reader::GridConsumer,
            Reader::Interpolator,
        ] {
            self.0.not_reading(r);
        }
    }
}

/// Closes a window when dropped before [`FinishOnDrop::disarm`]: a feed that panics ends
/// the program for the readers (the panic is raised again when the feeding thread is
/// joined) instead of leaving them waiting.
struct FinishOnDrop<'w>(Option<&'w MoveWindow>);

impl FinishOnDrop<'_> {
    fn disarm(&mut self) {
        self.0 = None;
    }
}

impl Drop for FinishOnDrop<'_> {
    fn drop(&mut self) {
        if let Some(w) = self.0 {
            w.finish(crate::feed::window::Summary::default());
        }
    }
}

fn run_index_inner<S: SetpointSink + Send>(
    index: &PathIndex,
    popts: &PlanOptions,
    iopts: &InterpOptions,
    sink: S,
    clock: Instant,
    index_s: f64,
) -> Result<(PlanReport, S), PlanError> {
    let period = popts.period_s;
    let mut writer = Measured::new(sink);
    writer.begin(index.extra_axes_mask).map_err(PlanError::Io)?;
    let (out_tx, out_rx) = std::sync::mpsc::sync_channel(EMIT_QUEUE_BATCHES);
    let mut emitter = Emitter {
        interp: Interpolator::new(index, *iopts),
        out: Some(out_tx),
        index,
        next_rest: 0,
        rest: None,
        batch: Vec::with_capacity(EMIT_BATCH),
        interp_s: 0.0,
    };
    let (tx, rx) = std::sync::mpsc::sync_channel(EMIT_QUEUE_BATCHES);
    let mut em = EmitQueue {
        tx,
        batch: Vec::with_capacity(EMIT_BATCH),
    };
    let (planning, em, (err, write_s)) = std::thread::scope(|scope| {
        let writing = scope.spawn(|| write_setpoints(&mut writer, out_rx));
        let worker = scope.spawn(move || {
            emitter.run(rx);
            // Hang up so the writing thread ends.
            emitter.out = None;
            emitter
        });
        let planning = plan_samples(index, popts, &mut em);
        em.flush();
        drop(em);
        let emitter = worker
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e));
        let written = writing
            .join()
            .unwrap_or_else(|e| std::panic::resume_unwind(e));
        (planning, emitter, written)
    });
    let Emitter {
        interp, interp_s, ..
    } = em;
    if let Some(e) = err {
        return Err(PlanError::Io(e));
    }
    let fd: FdStats = writer.fd.stats;
    let extra_axes: Vec<ExtraAxisReport> = (0..EXTRA_AXIS_NAMES.len())
        .filter(|i| index.extra_axes_mask & (1 << i) != 0)
        .map(|i| ExtraAxisReport {
            axis: EXTRA_AXIS_NAMES[i].to_ascii_lowercase(),
            v_max_per_s: writer.extra_fd.v_max[i],
            a_max_per_s2: writer.extra_fd.a_max[i],
        })
        .collect();
    let rows = writer.rows;
    let last = writer.last;
    let first = writer.first;
    let jumps = std::mem::take(&mut writer.jumps);
    writer.finish().map_err(PlanError::Io)?;
    let out = writer.inner;
    let total_s = clock.elapsed().as_secs_f64();
    let acc_noise = 2e-9 / (period * period);
    let jerk_noise = 4e-9 / (period * period * period);
    let v_default = popts.feed_mm_s.max(popts.rapid());
    let axes: Vec<AxisReport> = (0..3)
        .map(|i| {
            let v_limit = popts.vaxis_mm_s.map_or(v_default, |v| v[i]);
            let a_limit = popts.acc_mm_s2[i];
            AxisReport {
                axis: ['x', 'y', 'z'][i],
                v_max_mm_s: fd.v_max[i],
                v_limit_mm_s: v_limit,
                // A per-axis limit holds strictly; the feed (a commanded speed, planned at
                // its value) up to the first difference's noise (rounding and landing).
                v_within: match popts.vaxis_mm_s {
                    Some(_) => fd.v_max[i] <= v_limit,
                    None => fd.v_max[i] <= v_limit * (1.0 + 1e-9) + VEL_NOISE_MM / period,
                },
                a_max_mm_s2: fd.a_max[i],
                a_max_at_s: fd.a_max_t[i],
                a_limit_mm_s2: a_limit,
                a_ratio: fd.a_max[i] / a_limit,
                a_within: fd.a_max[i] <= a_limit,
                j_max_mm_s3: fd.j_max[i],
                j_max_at_s: fd.j_max_t[i],
                j_limit_mm_s3: popts.jerk_mm_s3.map(|j| j[i]),
                j_ratio: popts.jerk_mm_s3.map(|j| fd.j_max[i] / j[i]),
                j_within: popts.jerk_mm_s3.is_none_or(|j| fd.j_max[i] <= j[i]),
            }
        })
        .collect();
    let summary = index.summary();
    let end = summary.end;
    let dist = |p: Option<(f64, [f64; 3])>, q: crate::geom::Vec3| {
        p.map_or(f64::NAN, |(_, x)| crate::geom::Vec3::from_array(x).dist(q))
    };
    let start = index.start_point();
    let cycle = last.map_or(0.0, |(t, _)| t);
    let report = PlanReport {
        options: popts.clone(),
        interp_options: *iopts,
        cycle_time_s: cycle,
        setpoints: rows,
        path_length_mm: summary.total_len,
        moves: summary.moves,
        interp: interp.stats.clone(),
        extra_axes,
        limits_held: axes.iter().all(|a| a.v_within && a.a_within && a.j_within),
        jumps,
        axes,
        fd_acc_noise_mm_s2: acc_noise,
        fd_jerk_noise_mm_s3: jerk_noise,
        exact_stops: planning.stops,
        end_point_error_mm: dist(last, end),
        start_point_error_mm: dist(first, start),
        stage_time_s: StageTimes {
            index_s,
            plan_s: planning.plan_time_s,
            interpolate_s: interp_s,
            write_s,
            total_s,
        },
        planning,
        real_time_factor: if total_s > 0.0 { cycle / total_s } else { 0.0 },
    };
    Ok((report, out))
}

/// Runs the planner over `index` and queues one sample per period (and the rests) on
/// `em`, through the jerk filter when jerk limiting is on. Returns the planner's stats.
fn plan_samples(index: &PathIndex, popts: &PlanOptions, em: &mut EmitQueue) -> PlanStats {
    if let (JerkScheme::Follow, Some(jerk)) = (popts.jerk_scheme, popts.jerk_mm_s3) {
        return follow_samples(index, popts, jerk, em);
    }
    let period = popts.period_s;
    let (mut t, mut n) = (0.0f64, 0u64);
    let hold = popts.stop_hold_s();
    let mut filter = popts.jerk_caps().map(|j| MovingAverage::new(j.window_s));
    plan_stream(index, popts, |ev| match ev {
        ev if filter.is_some() => {
            let f = filter.as_mut().expect("jerk mode");
            let last = match ev {
                PlanEvent::Piece(pc) => {
                    f.push(Stretch {
                        t0: t,
                        t1: t + pc.dt,
                        s0: pc.s0,
                        v0: pc.v0,
                        a: pc.acc(),
                        rest: false,
                    });
                    t += pc.dt;
                    None
                }
                PlanEvent::Stop { s, reason, dwell_s } => {
                    // Rest for the filter window more than the trapezoid would, so the
                    // filtered motion comes to rest at the stop (see feed::jerk); the
                    // filtered X, Y, Z are at rest from one window after the plan.
                    let rest_end = t + dwell_s + hold;
                    let mut k = (rest_end / period - PERIOD_ROUND_SLACK).ceil().max(0.0) as u64;
                    if reason == StopReason::End {
                        k = k.max(n);
                    }
                    em.rest_at(s, t + hold);
                    f.push(Stretch {
                        t0: t,
                        t1: k as f64 * period,
                        s0: s,
                        v0: 0.0,
                        a: 0.0,
                        rest: true,
                    });
                    t = k as f64 * period;
                    (reason == StopReason::End).then_some(k)
                }
            };
            while (n as f64) * period <= f.t_known || last.is_some_and(|k| n <= k) {
                let time = n as f64 * period;
                let (s, v) = f.sample(time);
                em.push(time, s, v);
                n += 1;
            }
        }
        PlanEvent::Piece(pc) => {
            // Samples of this piece (interpolated and written in batches).
            while (n as f64) * period < t + pc.dt {
                let time = n as f64 * period;
                let (s, v) = pc.at(time - t);
                em.push(time, s, v);
                n += 1;
            }
            t += pc.dt;
        }
        PlanEvent::Stop { s, reason, dwell_s } => {
            t = hold_stop(em, (s, reason, dwell_s), t, &mut n, period);
        }
    })
}

/// Holds a trapezoid-mode stop reached at time `t`: the rest (and dwell) until the next
/// period boundary, its samples queued from sample `n` on (through the boundary itself at
/// the end of the program). Returns the time motion resumes.
fn hold_stop(
    em: &mut EmitQueue,
    (s, reason, dwell_s): (f64, StopReason, f64),
    t: f64,
    n: &mut u64,
    period: f64,
) -> f64 {
    em.rest_at(s, t);
    let rest_end = t + dwell_s;
    let mut k = (rest_end / period - PERIOD_ROUND_SLACK).ceil().max(0.0) as u64;
    if reason == StopReason::End {
        k = k.max(*n);
    }
    let last = if reason == StopReason::End { k + 1 } else { k };
    while *n < last {
        em.push(*n as f64 * period, s, 0.0);
        *n += 1;
    }
    k as f64 * period
}

/// `v^2` of the trapezoid plan at `s`, from the pieces of a run (sorted by `s0`).
fn pieces_x(pieces: &[ProfilePiece], s: f64) -> f64 {
    let i = pieces.partition_point(|p| p.s0 + p.ds < s);
    pieces.get(i).map_or(0.0, |p| {
        let f = ((s - p.s0) / p.ds).clamp(0.0, 1.0);
        p.v0 * p.v0 + (p.v1 * p.v1 - p.v0 * p.v0) * f
    })
}

/// The trapezoid's own samples of a run from rest at `s_a` (the follower's fallback).
fn pieces_samples(pieces: &[ProfilePiece], s_a: f64, s_b: f64, period: f64) -> Vec<f64> {
    let mut out = vec![s_a];
    let (mut t, mut n) = (0.0, 1u64);
    for pc in pieces {
        while (n as f64) * period < t + pc.dt {
            out.push(pc.at(n as f64 * period - t).0);
            n += 1;
        }
        t += pc.dt;
    }
    out.push(s_b);
    out
}

/// The move in which a run starting at `s` moves first, searching on from `j`.
fn move_at(index: &PathIndex, s: f64, mut j: usize) -> usize {
    while let Some(m) = index.get(j) {
        if s < m.s0 + m.len || index.get(j + 1).is_none() {
            break;
        }
        j += 1;
    }
    j
}

/// Jerk mode with the follower ([`JerkScheme::Follow`]): the planner's trapezoid pieces
/// of each run (stop to stop) are the ceiling of [`follow::follow_run`], whose samples
/// are queued; stops are held as in the trapezoid mode.
fn follow_samples(
    index: &PathIndex,
    popts: &PlanOptions,
    jerk: [f64; 3],
    em: &mut EmitQueue,
) -> PlanStats {
    let period = popts.period_s;
    let (mut t, mut n) = (0.0f64, 0u64);
    let mut pieces: Vec<ProfilePiece> = Vec::new();
    let mut start = (0usize, 0.0f64);
    plan_stream(index, popts, |ev| match ev {
        PlanEvent::Piece(pc) => pieces.push(pc),
        PlanEvent::Stop { s, reason, dwell_s } => {
            // Where the next run starts, looked up while the interpolator still holds the
            // moves of this one.
            let next = (move_at(index, s, start.0), s);
            if s > start.1 && !pieces.is_empty() {
                let plan_x = |q: f64| pieces_x(&pieces, q);
                let plan_t: f64 = pieces.iter().map(|p| p.dt).sum();
                let plan_n = (plan_t / period).ceil() as usize;
                let run = follow::follow_run(index, start, s, popts, jerk, &plan_x, plan_n)
                    .unwrap_or_else(|| pieces_samples(&pieces, start.1, s, period));
                let k0 = (t / period).round() as u64;
                for (i, &q) in run.iter().enumerate() {
                    let k = k0 + i as u64;
                    if k < n {
                        continue;
                    }
                    let before = run[i.saturating_sub(1)];
                    let after = run[(i + 1).min(run.len() - 1)];
                    let steps = ((i + 1).min(run.len() - 1) - i.saturating_sub(1)).max(1);
                    em.push(
                        k as f64 * period,
                        q,
                        (after - before) / (steps as f64 * period),
                    );
                    n = k + 1;
                }
                t = (k0 + run.len() as u64 - 1) as f64 * period;
            }
            pieces.clear();
            t = hold_stop(em, (s, reason, dwell_s), t, &mut n, period);
            start = next;
        }
    })
}
