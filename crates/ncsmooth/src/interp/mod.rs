//! Setpoint interpolation: at every period `T` the next point of the path, given the arc
//! length the planned profile ([`crate::feed`]) has reached.
//!
//! ## Algorithm (Wu et al., section IV, eqs. 15-20)
//! The interpolator keeps its place on the path as a move index, the curve parameter `u_i`
//! and its arc-length position `s_i`. For a step to the planned arc length `s*` the chord
//! to travel is `L = s* - s_i` (the paper's `V_temp T`, eq. 15, with the tracking error of
//! the previous step folded in, so errors never accumulate). Where the step is not small
//! against the radius of curvature, the chord of arc `L` is shorter than `L`; the chord
//! target is therefore the chord of arc `L` on the osculating circle at `u_i`,
//! `2 sin(L kappa / 2) / kappa` (equal to `L` within `(L kappa)^2 / 24`; without it a step
//! round a tight bend lands ahead of the plan, which shows in finite differences). The next
//! parameter solves
//! `F(xi) = L - |P(xi) - P(u_i)| = 0` (eq. 17) by Newton-Raphson (eq. 18) from the
//! first-order Taylor guess `xi_0 = u_i + L / |P'(u_i)|` (eq. 19), stopping when the feed
//! fluctuation `eta = 1 - |P(xi) - P(u_i)| / L` (eq. 16) is within `eta_tol` and `n`
//! iterations have been made (eq. 20 as printed, "eta <= eta_tol and k = n").
//!
//! Why "and": the common reading "whichever comes first" accepts a step as soon as
//! `|eta| <= eta_tol`, i.e. a position error up to `eta_tol L` (1e-4 mm for Wu's 0.1 % of a
//! 0.1 mm step) that changes from step to step; a second difference turns that into
//! `4 eta_tol L / T^2` of acceleration noise. Measured on the butterfly NURBS in Wu's
//! setting (`ncsmooth plan builtin:butterfly --period 0.002 --no-arc-correction`, 50
//! mm/s, 500 mm/s^2), the largest finite-difference acceleration is 0.991 x the limit
//! for Newton with "and", 1.030 x with "either", 1.087 x for Taylor 1 and 0.998 x for
//! Taylor 2 (feed fluctuation 0.1 %, 0.1 %, 7.8 %, 1.2 %); "and" costs 8502 iterations
//! against 3086. [`InterpOptions::stop_on_either`] selects the common reading. With the
//! arc-length correction (the default, below) all four stay at 0.991 x.
//! After the step, `s_i` advances by the true arc length `int |P'|` over `[u_i, xi]`
//! (7-point Gauss-Kronrod checked against its embedded 3-point Gauss rule, then against
//! its two halves, adaptive where those disagree by more than
//! [`STEP_ARCLEN_ACCURACY_MM`]; see [`step_arclen`]), so the setpoints follow the planned
//! arc length even though the solve is on chords.
//!
//! [`InterpMethod::Taylor1`] (eq. 19 alone) and [`InterpMethod::Taylor2`] (the usual
//! second-order Taylor step `L/|P'| - L^2 (P'.P'') / (2 |P'|^4)`) are there for comparison.
//!
//! ## Boundaries and degenerate curves
//! A step that passes the end of a move continues on the next one with what is left of
//! `L` measured in arc length (`s` is continuous across moves), so no distance is lost or
//! counted twice; a stop point is reached exactly. The end of the program is the exact
//! end point of the last move. Segments may have zero parametric speed at an end (a
//! Bézier with a repeated control point, a trigonometric-spline line): there eq. 19 would
//! divide by zero, so the guess becomes the root of `|P'| h + |P''| h^2 / 2 = L` (which
//! reduces to eq. 19 when the speed dominates), and every Newton step is kept inside a
//! bracket `[lo, hi]` of the root, falling back to bisection when it leaves it or when
//! `F'` has the wrong sign. If the chord never reaches `L` on the move (a very curved
//! remainder), the step is solved on arc length instead (Newton-bisection on
//! `int |P'| = L`), counted as a fallback.
//!
//! Lines are stepped exactly (`u = (s - s0)/len`): Newton would converge in zero iterations.
//! The chord solve lands on the planned arc length to within `(L kappa)^2` effects of the
//! curvature's variation and the method's own error; where it misses by more than
//! `ARC_CORRECTION_TOL_MM` (1e-9), a safeguarded Newton step on arc length puts the setpoint
//! back on the plan (counted in [`InterpStats::arc_corrections`]; eta is that of the
//! chord solve, as in the paper). The correction is on by default
//! ([`InterpOptions::arc_correction`]); with it off the setpoints are the method's own,
//! which is how the methods are compared: the report's
//! [`InterpStats::feed_fluctuation_max`] and the finite differences then show each
//! method's error (measured figures in the tests of this module).
//!
//! `eta` is recorded on steps longer than `ETA_MIN_STEP_MM` (1e-6): below that the rounding of
//! the coordinates themselves dominates the ratio.

mod follow;
mod run;
mod setpoints;
mod sink;

pub use run::{
    execute, execute_into, execute_streamed, AxisReport, ExtraAxisReport, PlanError, PlanReport,
    StageTimes,
};
pub use setpoints::{
    printed, ExtraFdMeter, FdMeter, FdStats, Jump, Setpoint, SetpointWriter, FEED_DECIMALS,
    POSITION_DECIMALS,
};
pub use sink::{FnSink, Measured, NullSink, PrintedRow, SetpointSink};

use crate::feed::grid::MoveRef;
use crate::feed::window::Reader;
use crate::feed::PathIndex;
use crate::geom::{
    arclen_adaptive, arclen_gk7, curvature_vec_from, CubicBez, ParamCurve, ParamCurveDeriv,
    PreparedNurbs, PreparedTrig, Segment, Vec3,
};
pub use crate::geom::{step_arclen, STEP_ARCLEN_ACCURACY_MM};
use crate::path::ExtraAxes;
use serde::Serialize;

/// Steps shorter than this (mm) are not counted in the eta statistics.
pub(crate) const ETA_MIN_STEP_MM: f64 = 1e-6;
/// Most Newton iterations of one step under the default (both-conditions) stopping rule.
pub(crate) const NEWTON_HARD_CAP: usize = 20;
/// Chord residuals within this many ulps of the coordinates end the iteration.
const CHORD_ROUNDING_ULPS: f64 = 8.0;
/// Largest half-angle (rad) of a step on its osculating circle solved on the chord; beyond
/// it (a step around more than ~170 degrees of a tiny curve) the step is solved on arc
/// length.
const MAX_HALF_ANGLE: f64 = 1.5;
/// Largest difference (mm) between the arc length a step travels and the planned one
/// before the step is corrected on arc length: the printing resolution of the setpoints
/// (1e-9 mm is 4e-3 mm/s^2 of finite-difference acceleration at T = 1 ms).
pub(crate) const ARC_CORRECTION_TOL_MM: f64 = 1e-9;
/// Iteration cap of the arc-length fallback solve.
const FALLBACK_ITERS: usize = 60;
/// Accuracy (mm) of the arc-length fallback solve.
const FALLBACK_ACCURACY_MM: f64 = 1e-12;

/// How the next parameter is found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub enum InterpMethod {
    /// Newton-Raphson on the chord length (Wu eqs. 17-20).
    #[default]
    Newton,
    /// First-order Taylor step (eq. 19 alone).
    Taylor1,
    /// Second-order Taylor step.
    Taylor2,
}

impl InterpMethod {
    /// Parses a command-line name (`newton`, `taylor1`, `taylor2`).
    pub fn from_name(s: &str) -> Option<InterpMethod> {
        Some(match s {
            "newton" => InterpMethod::Newton,
            "taylor1" => InterpMethod::Taylor1,
            "taylor2" => InterpMethod::Taylor2,
            _ => return None,
        })
    }
}

/// Interpolation settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct InterpOptions {
    /// Method. Default Newton.
    pub method: InterpMethod,
    /// Feed-fluctuation tolerance eta_tol as a fraction (0.001 = 0.1 %, the default).
    pub eta_tol: f64,
    /// Newton iterations n. Default 2.
    pub max_iters: usize,
    /// Stopping rule of eq. 20. `false` (default): stop when `eta <= eta_tol` **and**
    /// `k >= n` (eq. 20 as printed; at most `NEWTON_HARD_CAP` (20) iterations). `true`: stop
    /// when either holds (the common reading, cheaper, but it leaves position errors up to
    /// `eta_tol L` that show as finite-difference acceleration noise; see the module doc).
    pub stop_on_either: bool,
    /// Put every curve step back on the planned arc length when the method's solution
    /// misses it by more than `ARC_CORRECTION_TOL_MM` (default true). `false` writes the
    /// method's own setpoints, so the methods can be compared by what they produce: the
    /// miss then shows as feed fluctuation and finite-difference noise (never as drift:
    /// the next step aims at the plan again).
    pub arc_correction: bool,
}

/// Builders: each sets one field (see its doc for the default).
impl InterpOptions {
    /// Sets [`InterpOptions::method`].
    pub fn with_method(mut self, method: InterpMethod) -> Self {
        self.method = method;
        self
    }

    /// Sets [`InterpOptions::eta_tol`].
    pub fn with_eta_tol(mut self, eta_tol: f64) -> Self {
        self.eta_tol = eta_tol;
        self
    }

    /// Sets [`InterpOptions::max_iters`].
    pub fn with_max_iters(mut self, max_iters: usize) -> Self {
        self.max_iters = max_iters;
        self
    }

    /// Sets [`InterpOptions::stop_on_either`].
    pub fn with_stop_on_either(mut self, stop_on_either: bool) -> Self {
        self.stop_on_either = stop_on_either;
        self
    }

    /// Sets [`InterpOptions::arc_correction`].
    pub fn with_arc_correction(mut self, arc_correction: bool) -> Self {
        self.arc_correction = arc_correction;
        self
    }
}

impl Default for InterpOptions {
    fn default() -> Self {
        InterpOptions {
            method: InterpMethod::Newton,
            eta_tol: 0.001,
            max_iters: 2,
            stop_on_either: false,
            arc_correction: true,
        }
    }
}

/// Interpolation statistics.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct InterpStats {
    /// Largest |eta| (fraction).
    pub eta_max: f64,
    /// Mean |eta| over the measured steps (fraction).
    pub eta_mean: f64,
    /// Steps whose eta was measured.
    pub eta_steps: usize,
    /// Steps solved on a curve (not a line).
    pub curve_steps: usize,
    /// Newton iterations in all.
    pub iterations_total: usize,
    /// Most Newton iterations in one step.
    pub iterations_max: usize,
    /// Steps by number of Newton iterations used (index = iterations).
    pub iterations_histogram: Vec<usize>,
    /// Steps solved by the arc-length fallback.
    pub fallback_steps: usize,
    /// Steps whose chord solution missed the planned arc length by more than
    /// `ARC_CORRECTION_TOL_MM` (1e-9) and were corrected on arc length.
    pub arc_corrections: usize,
    /// Largest miss (mm) of a step's solution from the planned arc length, before any
    /// correction: the method's own accuracy.
    pub arc_miss_max_mm: f64,
    /// Largest relative miss of a step (miss over the planned step), before any
    /// correction: the feed fluctuation the method alone would cause.
    pub feed_fluctuation_max: f64,
    #[serde(skip)]
    eta_sum: f64,
}

impl InterpStats {
    fn record(&mut self, eta: f64, len: f64, iters: usize) {
        if len > ETA_MIN_STEP_MM {
            let e = eta.abs();
            self.eta_max = self.eta_max.max(e);
            self.eta_sum += e;
            self.eta_steps += 1;
            self.eta_mean = self.eta_sum / self.eta_steps as f64;
        }
        self.iterations_total += iters;
        self.iterations_max = self.iterations_max.max(iters);
        if self.iterations_histogram.len() <= iters {
            self.iterations_histogram.resize(iters + 1, 0);
        }
        self.iterations_histogram[iters] += 1;
    }
}

/// Gauss-Legendre 3-point nodes on [-1, 1] and weights.
const GL3: [(f64, f64); 3] = [
    (0.0, 8.0 / 9.0),
    (-0.774_596_669_241_483_4, 5.0 / 9.0),
    (0.774_596_669_241_483_4, 5.0 / 9.0),
];

/// Largest share of a step's parameter span that an arc-length correction may move by
/// and still be integrated as a short piece ([`gl3_signed_arclen`]); the piece's
/// quadrature error is then below the sixth power of that share relative to the step's
/// own (already resolved) arc length.
const CORRECTION_PIECE_SHARE: f64 = 0.01;

/// Signed arc length from `a` to `b` (negative when `b < a`) by 3-point Gauss-Legendre,
/// for the short pieces of an arc-length correction.
fn gl3_signed_arclen(seg: &Segment, a: f64, b: f64) -> f64 {
    gauss_arclen(&GL3, seg, a, b)
}

/// Gauss-Legendre integral of `|P'|` over `[a, b]` with `nodes` (signed: negative when
/// `b < a`).
fn gauss_arclen(nodes: &[(f64, f64)], seg: &Segment, a: f64, b: f64) -> f64 {
    match seg {
        // The spline's weights once, not at every node.
        Segment::Trig(c) => {
            let c = PreparedTrig::new(c);
            gauss(nodes, |t| c.deriv(t), a, b)
        }
        _ => gauss(nodes, |t| seg.deriv(t), a, b),
    }
}

/// Gauss-Legendre integral of `|d(t)|` over `[a, b]` with `nodes` on [-1, 1].
#[inline]
fn gauss(nodes: &[(f64, f64)], d: impl Fn(f64) -> Vec3, a: f64, b: f64) -> f64 {
    let h = 0.5 * (b - a);
    let m = 0.5 * (a + b);
    nodes
        .iter()
        .map(|&(x, w)| w * d(m + h * x).norm())
        .sum::<f64>()
        * h
}

/// A curve the interpolator steps on: a [`Segment`], a [`PreparedTrig`] (a
/// trigonometric spline with its weights computed once per move) or a [`CubicBez`]
/// (stepped directly rather than through the `Segment` dispatch, so that its polynomial
/// evaluations inline into the step); the same results whichever way a move is stepped.
trait StepCurve: ParamCurveDeriv {
    /// True when one evaluation of the point costs about as much as [`ParamCurveDeriv::ders`]
    /// (a trigonometric spline: one `sin_cos` either way). The step then evaluates `ders`
    /// at every point it tries and keeps the derivatives for the Newton iteration, the
    /// arc-length correction and the next step's start, instead of evaluating the point and
    /// each derivative apart: the same numbers, fewer `sin_cos`.
    const DERS_ARE_CHEAP: bool;
    /// Arc length over one step, as [`step_arclen`] (for a curve evaluated directly:
    /// [`arclen_gk7`] on its own derivative).
    #[inline]
    fn step_arclen(&self, a: f64, b: f64) -> f64 {
        arclen_gk7(self, a, b, STEP_ARCLEN_ACCURACY_MM)
    }
    /// Signed 3-point Gauss-Legendre arc length, as [`gl3_signed_arclen`].
    #[inline]
    fn gl3_signed_arclen(&self, a: f64, b: f64) -> f64 {
        gauss(&GL3, |t| self.deriv(t), a, b)
    }
}

impl StepCurve for Segment {
    const DERS_ARE_CHEAP: bool = false;
    #[inline]
    fn step_arclen(&self, a: f64, b: f64) -> f64 {
        step_arclen(self, a, b)
    }
    #[inline]
    fn gl3_signed_arclen(&self, a: f64, b: f64) -> f64 {
        gl3_signed_arclen(self, a, b)
    }
}

impl StepCurve for PreparedTrig {
    const DERS_ARE_CHEAP: bool = true;
}

impl StepCurve for PreparedNurbs {
    /// Cubic pieces: as for [`CubicBez`].
    const DERS_ARE_CHEAP: bool = true;
    /// Split at the breakpoints inside the step, as [`step_arclen`] splits a NURBS at its
    /// knots.
    fn step_arclen(&self, a: f64, b: f64) -> f64 {
        if b <= a {
            return 0.0;
        }
        let br = self.breaks();
        let first = br.partition_point(|&k| k <= a);
        let inside = br[first..].partition_point(|&k| k < b);
        let share = STEP_ARCLEN_ACCURACY_MM / (inside + 1) as f64;
        let (mut t, mut sum) = (a, 0.0);
        for &k in &br[first..first + inside] {
            sum += arclen_gk7(self, t, k, share);
            t = k;
        }
        sum + arclen_gk7(self, t, b, share)
    }
}

impl StepCurve for CubicBez {
    /// Point and derivatives of a cubic are a few multiply-adds each: evaluating them
    /// together at every point tried costs less than evaluating the point and the
    /// derivatives again at the next step's start.
    const DERS_ARE_CHEAP: bool = true;
}

/// Walks the path of a [`PathIndex`] to planned arc lengths.
pub struct Interpolator<'p> {
    index: &'p PathIndex,
    opts: InterpOptions,
    cur: usize,
    /// Move `cur`, `None` for a program without moves.
    cur_move: Option<MoveRef<'p>>,
    u: f64,
    s: f64,
    p: Vec3,
    /// The current move prepared, when it is a trigonometric spline: `(move, prepared)`.
    prepared: Option<(usize, PreparedTrig)>,
    /// The current move as Bézier pieces, when it is a non-rational cubic NURBS.
    prepared_nurbs: Option<(usize, PreparedNurbs)>,
    /// Point and derivatives at the current place, when the last step computed them
    /// ([`StepCurve::DERS_ARE_CHEAP`]): `(move, parameter, ders)`.
    here: Option<(usize, f64, [Vec3; 3])>,
    /// The last advance crossed into a move that does not start where the previous one
    /// ended (motion ncsmooth cannot place came between).
    jumped: bool,
    /// Statistics so far.
    pub stats: InterpStats,
}

impl<'p> Interpolator<'p> {
    /// At the start of the program.
    pub fn new(index: &'p PathIndex, opts: InterpOptions) -> Self {
        let first = index.get(0);
        let p = first.as_ref().map_or(index.start, |m| m.segment.start());
        Interpolator {
            index,
            opts,
            cur: 0,
            cur_move: first,
            u: 0.0,
            s: 0.0,
            p,
            prepared: None,
            prepared_nurbs: None,
            here: None,
            jumped: false,
            stats: InterpStats::default(),
        }
    }

    /// Whether the position jumped since the last call (and forgets it).
    pub fn take_jump(&mut self) -> bool {
        std::mem::take(&mut self.jumped)
    }

    /// Extra-axis values at the current place.
    fn extra(&self) -> Option<ExtraAxes> {
        let m = self.cur_move.as_ref()?;
        let (a, b) = m.extra?;
        let f = ((self.s - m.s0) / m.len).clamp(0.0, 1.0);
        let mut v = a;
        for i in 0..v.len() {
            v[i] = a[i] + (b[i] - a[i]) * f;
        }
        Some(v)
    }

    /// The point (and extra axes) at arc length `s_target`, which must not decrease from
    /// call to call.
    pub fn advance(&mut self, s_target: f64) -> (Vec3, Option<ExtraAxes>) {
        let Some(mut m) = self.cur_move.clone() else {
            return (self.index.start, None);
        };
        loop {
            let s_end = m.s0 + m.len;
            if s_target >= s_end {
                let next = if s_target > s_end {
                    self.index.get(self.cur + 1)
                } else {
                    None
                };
                if let Some(next) = next {
                    self.cur += 1;
                    self.index.release(Reader::Interpolator, self.cur);
                    self.u = 0.0;
                    self.s = next.s0;
                    let start = next.segment.start();
                    if start.dist(m.segment.end()) > crate::verify::GAP_TOL_MM {
                        self.jumped = true;
                    }
                    self.p = start;
                    self.cur_move = Some(next.clone());
                    m = next;
                    continue;
                }
                self.u = 1.0;
                self.s = s_end;
                self.p = m.segment.end();
                return (self.p, self.extra());
            }
            let len = s_target - self.s;
            if len <= 0.0 {
                return (self.p, self.extra());
            }
            if let Segment::Line(l) = &m.segment {
                let u = ((s_target - m.s0) / m.len).clamp(self.u, 1.0);
                let p = l.p0.lerp(l.p1, u);
                let eta = 1.0 - p.dist(self.p) / len;
                self.stats.record(eta, len, 0);
                self.u = u;
                self.s = s_target;
                self.p = p;
                return (p, self.extra());
            }
            if let Segment::Trig(c) = &m.segment {
                let prepared = match self.prepared {
                    Some((j, p)) if j == self.cur => p,
                    _ => {
                        let p = PreparedTrig::new(c);
                        self.prepared = Some((self.cur, p));
                        p
                    }
                };
                self.step_curve(&prepared, len);
            } else if let Segment::CubicBez(c) = &m.segment {
                self.step_curve(c, len);
            } else if let Some(p) = self.nurbs_pieces(&m.segment) {
                self.step_curve(&p, len);
                self.prepared_nurbs = Some((self.cur, p));
            } else {
                self.step_curve(&m.segment, len);
            }
            return (self.p, self.extra());
        }
    }

    /// The current move's [`PreparedNurbs`] (taken out of the cache; the caller puts it
    /// back), when it is a non-rational cubic NURBS.
    fn nurbs_pieces(&mut self, seg: &Segment) -> Option<PreparedNurbs> {
        let Segment::Nurbs(n) = seg else {
            return None;
        };
        match self.prepared_nurbs.take() {
            Some((j, p)) if j == self.cur => Some(p),
            _ => PreparedNurbs::new(n),
        }
    }

    fn step_curve<C: StepCurve>(&mut self, seg: &C, arc: f64) {
        self.stats.curve_steps += 1;
        let (u0, p0) = (self.u, self.p);
        let [_, d1, d2] = match self.here.take() {
            Some((j, u, ders)) if j == self.cur && u == u0 => ders,
            _ => seg.ders(u0),
        };
        let len = chord_of_arc(arc, d1, d2);
        if seg.end().dist(p0) < len {
            // The chord cannot reach L on this move: solve on arc length.
            self.stats.fallback_steps += 1;
            let xi = solve_arclen(seg, u0, arc);
            let p = seg.eval(xi);
            self.stats.record(0.0, 0.0, 0);
            self.s += arclen_adaptive(seg, u0, xi, FALLBACK_ACCURACY_MM);
            self.u = xi;
            self.p = p;
            return;
        }
        let xi0 = first_guess(self.opts.method, u0, len, d1, d2);
        let it = self.chord_iteration(seg, u0, p0, len, xi0);
        self.stats.record(it.eta, len, it.k);
        let (mut xi, mut p, mut at) = (it.xi, it.p, it.at);
        let mut done = seg.step_arclen(u0, xi);
        let miss = (done - arc).abs();
        self.stats.arc_miss_max_mm = self.stats.arc_miss_max_mm.max(miss);
        if arc > ETA_MIN_STEP_MM {
            self.stats.feed_fluctuation_max = self.stats.feed_fluctuation_max.max(miss / arc);
        }
        if self.opts.arc_correction && miss > ARC_CORRECTION_TOL_MM {
            self.stats.arc_corrections += 1;
            (xi, done) = correct_arclen(seg, u0, xi, done, arc, at.take());
            (p, at) = try_at(seg, xi);
        }
        if let Some(ders) = at {
            self.here = Some((self.cur, xi, ders));
        }
        self.s += done;
        self.u = xi;
        self.p = p;
    }

    /// Solves `|P(xi) - p0| = len` from `xi` by the configured method (Newton on the chord,
    /// eqs. 17-18, safeguarded by a bracket; or the first guess alone).
    #[inline]
    fn chord_iteration<C: StepCurve>(
        &self,
        seg: &C,
        u0: f64,
        p0: Vec3,
        len: f64,
        mut xi: f64,
    ) -> ChordIter {
        let (mut lo, mut hi) = (u0, 1.0);
        let (mut p, mut at) = try_at(seg, xi);
        let mut chord = p.dist(p0);
        let mut eta = 1.0 - chord / len;
        // Chord differences below this are rounding of the coordinates.
        let rounding = CHORD_ROUNDING_ULPS * f64::EPSILON * (p0.max_abs() + len);
        // `hi` is a bracket end only once an iterate near the start has reached L
        // (bisecting towards the far end of the move could find a far root).
        let mut hi_known = false;
        let mut k = 0;
        if self.opts.method == InterpMethod::Newton {
            loop {
                let tol_met = eta.abs() <= self.opts.eta_tol;
                let n_met = k >= self.opts.max_iters;
                let done = if self.opts.stop_on_either {
                    tol_met || n_met
                } else {
                    (tol_met && n_met) || k >= NEWTON_HARD_CAP
                };
                if done || (len - chord).abs() <= rounding {
                    break;
                }
                if chord < len {
                    lo = xi;
                } else {
                    hi = xi;
                    hi_known = true;
                }
                // F = L - |P - P0|, F' = -(P - P0).P' / |P - P0| (eqs. 17, 18).
                let dp = at.map_or_else(|| seg.deriv(xi), |d| d[1]);
                let fprime = if chord > 0.0 {
                    -(p - p0).dot(dp) / chord
                } else {
                    0.0
                };
                let next = xi - (len - chord) / fprime;
                xi = if fprime < 0.0 && next > lo && next < hi {
                    next
                } else if hi_known {
                    0.5 * (lo + hi)
                } else {
                    (lo + (lo - u0)).min(hi)
                };
                (p, at) = try_at(seg, xi);
                chord = p.dist(p0);
                eta = 1.0 - chord / len;
                k += 1;
            }
        }
        ChordIter { xi, p, at, eta, k }
    }

    /// Arc-length position reached (mm).
    pub fn position_s(&self) -> f64 {
        self.s
    }
}

/// The parameter at which the arc length from `u0` equals `len` (Newton-bisection on
/// `int |P'| - len`; never divides by a zero speed).
/// Where one chord iteration ended: the parameter, the point (and its derivatives when
/// they are cheap), the chord error `eta` and the iterations taken.
struct ChordIter {
    xi: f64,
    p: Vec3,
    at: Option<[Vec3; 3]>,
    eta: f64,
    k: usize,
}

/// Point (and, when they are cheap, derivatives) at a parameter a step tries.
#[inline]
fn try_at<C: StepCurve>(seg: &C, xi: f64) -> (Vec3, Option<[Vec3; 3]>) {
    if C::DERS_ARE_CHEAP {
        let d = seg.ders(xi);
        (d[0], Some(d))
    } else {
        (seg.eval(xi), None)
    }
}

/// Chord of the planned arc length `arc` on the osculating circle at a point with
/// derivatives `d1`, `d2` (eq. 15's `V T` = chord, made exact for circles); infinite for
/// a step around more than [`MAX_HALF_ANGLE`] of it.
#[inline]
fn chord_of_arc(arc: f64, d1: Vec3, d2: Vec3) -> f64 {
    let kappa = curvature_vec_from(d1, d2).norm();
    let half = 0.5 * arc * kappa;
    if half > MAX_HALF_ANGLE {
        f64::INFINITY
    } else if half > 1e-6 {
        2.0 * half.sin() / kappa
    } else {
        arc
    }
}

/// The first parameter tried for a chord `len` from `u0` (eq. 19, or its second-order
/// form), kept inside `(u0, 1]`.
#[inline]
fn first_guess(method: InterpMethod, u0: f64, len: f64, d1: Vec3, d2: Vec3) -> f64 {
    let (sp, acc) = (d1.norm(), d2.norm());
    let xi = match method {
        InterpMethod::Taylor2 if sp > 0.0 && sp * sp >= acc * len => {
            u0 + len / sp - len * len * d1.dot(d2) / (2.0 * sp.powi(4))
        }
        _ if sp > 0.0 && sp * sp >= acc * len => u0 + len / sp, // eq. 19
        _ if acc > 0.0 => u0 + (-sp + (sp * sp + 2.0 * acc * len).sqrt()) / acc,
        _ => f64::NAN,
    };
    if xi > u0 && xi <= 1.0 {
        return xi;
    }
    let xi = (u0 + 2.0 * len / sp.max(f64::MIN_POSITIVE)).min(1.0);
    if xi.is_nan() || xi <= u0 {
        0.5 * (u0 + 1.0)
    } else {
        xi
    }
}

/// Keeps the setpoint on the planned arc length: safeguarded Newton on `int |P'| = arc`
/// from the chord solution `xi` (whose arc length is `done`; `at` its derivatives if
/// known). Returns the parameter and its arc length.
fn correct_arclen<C: StepCurve>(
    seg: &C,
    u0: f64,
    mut xi: f64,
    mut done: f64,
    arc: f64,
    mut at: Option<[Vec3; 3]>,
) -> (f64, f64) {
    let (mut lo, mut hi) = if done > arc { (u0, xi) } else { (xi, 1.0) };
    for _ in 0..FALLBACK_ITERS {
        let sp = at.take().map_or_else(|| seg.deriv(xi), |d| d[1]).norm();
        let next = xi - (done - arc) / sp;
        let prev = xi;
        xi = if sp > 0.0 && next > lo && next < hi {
            next
        } else {
            0.5 * (lo + hi)
        };
        // The arc length moves by the piece between the two parameters: a short piece
        // (the Newton correction of a miss of at most a few micrometres) is integrated to
        // rounding by 3-point Gauss-Legendre; a long one (a bisection) is measured again
        // from the step's start.
        done = if (xi - prev).abs() <= CORRECTION_PIECE_SHARE * (xi - u0).abs() {
            done + seg.gl3_signed_arclen(prev, xi)
        } else {
            seg.step_arclen(u0, xi)
        };
        let err = done - arc;
        if err.abs() <= ARC_CORRECTION_TOL_MM * 0.5 || hi - lo < 1e-16 {
            break;
        }
        if err > 0.0 {
            hi = xi;
        } else {
            lo = xi;
        }
    }
    (xi, done)
}

fn solve_arclen<C: ParamCurveDeriv>(seg: &C, u0: f64, len: f64) -> f64 {
    let (mut lo, mut hi) = (u0, 1.0);
    let mut xi = 0.5 * (lo + hi);
    for _ in 0..FALLBACK_ITERS {
        let f = arclen_adaptive(seg, u0, xi, FALLBACK_ACCURACY_MM) - len;
        if f.abs() <= FALLBACK_ACCURACY_MM {
            break;
        }
        if f > 0.0 {
            hi = xi;
        } else {
            lo = xi;
        }
        let sp = seg.deriv(xi).norm();
        let next = xi - f / sp;
        xi = if sp > 0.0 && next > lo && next < hi {
            next
        } else {
            0.5 * (lo + hi)
        };
        if hi - lo < 1e-16 {
            break;
        }
    }
    xi
}

#[cfg(test)]
mod tests;
