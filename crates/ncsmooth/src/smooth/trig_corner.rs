//! `--method trig`: Tao, Song and Yi (2013), cubic trigonometric spline description of
//! micro-line runs plus trigonometric corner transitions (inside, Fig. 9) or loops (outside,
//! Fig. 8). The spline itself is [`TrigSpline`].
//!
//! ## Per chain
//! Each maximal sequence of line moves of a chain is a polyline `V_0 .. V_L` (zero-length
//! lines are skipped; their moves still count for feeds). Every inner vertex gets a kind:
//!
//! * **smooth**: inside a micro-line run found by [`screen`](super::screen) (shared with the
//!   NURBS method): the curve passes through the vertex with Bessel's tangent (the tangent of
//!   the parabola through the vertex and its two neighbours, chord-length parametrised);
//! * **straight**: turning by less than `straight_angle_deg`: passes through unchanged;
//! * **round** (default): an inside transition, Fig. 9;
//! * **loop** (`CornerStyle::Loop`): an outside loop, Fig. 8;
//! * **stop**: turning by more than [`TrigOptions::stop_turn_deg`] (a reversal): kept as an
//!   exact sharp corner, counted in `corners_stopped`.
//!
//! Chain ends, and the joints with non-line moves, are kept exactly. Input arcs stay exact
//! [`Arc`](crate::geom::Arc)s (native G2/G3, no approximation). A non-tangent joint
//! involving an arc has been blended before this method runs ([`super::arc_joint`], with
//! a trig Hermite segment on the trimmed arc's end tangent, within tol); one that could
//! not be (a near reversal, another curve kind) is a stop, counted in `corners_stopped`
//! and, when an arc is involved, in `arc_joints`.
//!
//! Each leg `V_j V_(j+1)` becomes: the rest of the line between the transitions of its two
//! ends, or, when an end is smooth, one trig segment ([`TrigSpline::hermite`], `lambda =
//! 1`) from the leg's start point to its end point with the vertex tangent at smooth ends
//! and the leg direction at the others. At a smooth vertex both segments take the same
//! derivative, the vertex tangent times the harmonic mean of the two chords, so runs are
//! C1 as eq. 5 asks; at the other ends the derivative is the leg direction times the
//! segment's chord.
//! Every such segment is **measured** with [`deviation_segments`] against the part of its
//! leg it replaces; when it is not within `tol` for any `lambda` of `RUN_LAMBDAS`, its
//! smooth ends become corners (the run is split there) and the plan is redone. This ends,
//! because vertices only ever leave the smooth kind, and the fallback (corners and lines)
//! holds `tol` by construction.
//!
//! ### Why Hermite form and Bessel tangents, not eq. 2's data points as control points
//! A trig segment depends only on its end points, end derivatives and `lambda`; `k` only
//! maps control points to derivatives (eq. 3, tested in `geom`). Eq. 2 with the data as
//! control points fixes the tangent at `q_i` to `(q_(i+1) - q_i) - k (q_(i+2) - q_(i+1))`:
//! one-sided, looking ahead only. On sampled circles its best case (`k = 1/3`, the
//! second-order one-sided difference, `lambda = 1`) has curvature rippling between 0.5 and
//! 2.6 times the true one, against 0.81 to 1.28 for Bessel tangents with `lambda = 1`, at
//! the same deviation. The segments are still the paper's (four control points each, `k =
//! -1`), and consecutive segments of a run share their joint derivative (C1). Joints with
//! lines, transitions and loops are G1 (tangent continuous): a parametric C1 there would
//! tie the derivative to the line's length, which carries no geometric meaning.
//!
//! ## Run mode (an extension; [`super::run_mode`])
//! With [`SmoothOptions::run`] enabled (the default), runs of micro-corners ([`screen`]
//! with [`super::screen::ScreenOptions::run_mode`]) are replaced before the above by one curve through the
//! whole two-sided band: the cubic B-spline of least curvature and curvature variation
//! ([`super::band_fit`]), each of its cubic pieces carried by one trigonometric spline
//! segment of eq. 2 (`lambda = 1`, `k = -1`) evaluated on a short window of its natural
//! parameter, as the paper describes circular arcs of less than 90 degrees
//! ([`super::run_mode::trig_window`]); consecutive segments share position and
//! derivative, and their curvatures agree up to the window's small error (G2 within the
//! continuity audit's tolerance on the profiles). This extends the paper: its runs
//! interpolate the vertices with C1 joints (eq. 5), and its shape parameters are not
//! chosen by any criterion; here the curve uses the band and the segments' control points
//! are solved, not taken from the data. The run's ends meet the lines beyond along them,
//! and the remaining corners get the transitions below (Fig. 9) or loops (Fig. 8). Without
//! the run mode, the method is as described above.
//!
//! ## Inside transition (Fig. 9)
//! At a corner `V` with unit directions `a` (in) and `b` (out), turning by `beta`, the
//! control points are `C1 = V - d a`, `C2 = V + d b`, `C3 = C1 + rho d a` (on the extension
//! of the incoming leg), `C4 = C2 + rho d b` (on the outgoing leg), `k = -1`, `lambda = 1`.
//! The shape scales with `d`: at `d = 1` the two-sided deviation is
//! `F = max(|V - curve|, max over the curve of the distance to the legs)`, computed per
//! corner by sampling plus golden-section refinement against unit-length legs (shorter
//! than the real ones, so conservative). Then
//! `d = min(leg shares, tol (1 - CORNER_TOL_MARGIN) / F)`: the largest transition within
//! `tol` that does not overlap its neighbours (a leg is shared half and half between two
//! transitions or smooth segments, and given whole to a transition when its other end is
//! fixed or a loop).
//!
//! **The search** (where the paper only says "choose proper lambda"): for a tol-limited
//! transition the peak curvature is `h F / tol`, `h` the peak curvature at `d = 1`. A
//! table over `beta` in whole degrees, each entry computed on first use, holds the `rho` minimising `h F`
//! (golden-section search in `[0.4, 2.2] x beta / tan(beta / 2)`, the tangent length of the
//! circular arc, excluding inflected shapes); corners interpolate it linearly. `lambda = 1`
//! is fixed: a grid over `lambda in [-1, 3]` never found a better one. The result is within
//! 0 to 25 % of the peak curvature `(1 - cos(beta/2)) / (tol cos(beta/2))` of the circular
//! arc with the same corner distance (exactly the arc at 90 degrees, where the trig
//! transition *is* that arc, eq. 9); see [`round_transition_peak_curvature`] and the tests.
//!
//! ## Loop (Fig. 8)
//! Control points `(B, B, B1, B2)`, `k = -1`, `B1 = B + tau a`, `B2 = B + tau b`: the curve
//! leaves the corner `B` along the incoming direction, loops outside and returns through
//! `B` along the outgoing direction, so the corner is cut exactly. Its excursion (largest
//! distance from `B`) is `tau e`, `e` measured at `tau = 1`; `tau = loop_size (1 -
//! CORNER_TOL_MARGIN) / e`. `lambda` per `beta` comes from a table (entries computed on first use): on a grid
//! of `LOOP_LAMBDA_MIN` (-1.0)..`LOOP_LAMBDA_MAX` (2.0) the value with the lowest peak curvature at
//! a given excursion, among shapes that turn one way only. Loops are used for turns in
//! `[loop_min_turn_deg, LOOP_MAX_TURN_DEG]`; below, a loop would be a near full circle for
//! a corner the tolerance can simply round; above, `B1`, `B2` and `B` become collinear (at
//! 180 degrees the loop degenerates into a back-and-forth line), so those corners get the
//! inside transition. Loops are the one exception to the two-sided tolerance.

use super::screen::screen;
use super::{assemble, Chain, ChainPos, OutPiece, SmoothOptions, SmoothReport};
use crate::geom::{Line, ParamCurve, ParamCurveDeriv, PreparedTrig, Segment, TrigSpline, Vec3};
use crate::path::Move;
use crate::verify::{deviation_segments, DEGENERATE_MM};
use std::sync::OnceLock;

mod options;

pub use options::{CornerStyle, TrigOptions};

/// Share of the tolerance (or loop size) kept in reserve by the corner constructions for
/// the refinement error of the measured unit-scale deviation.
pub(crate) const CORNER_TOL_MARGIN: f64 = 1e-3;
/// `lambda` values tried, in order, for a trig segment of a run before splitting the run.
pub(crate) const RUN_LAMBDAS: [f64; 2] = [1.0, 1.5];
/// Accuracy of the per-segment run measurement, as a share of `tol`; the measured value
/// plus this must be within `tol`.
pub(crate) const RUN_MEASURE_SHARE: f64 = 0.01;
/// Largest turn (degrees) that gets a loop in loop mode (see module doc).
pub(crate) const LOOP_MAX_TURN_DEG: f64 = 170.0;
/// Smallest `lambda` of the loop table grid.
pub(crate) const LOOP_LAMBDA_MIN: f64 = -1.0;
/// Largest `lambda` of the loop table grid.
pub(crate) const LOOP_LAMBDA_MAX: f64 = 2.0;
/// Grid step of the loop `lambda` table.
const LOOP_LAMBDA_STEP: f64 = 0.1;
/// `lambda` of inside transitions (see module doc).
pub(crate) const ROUND_LAMBDA: f64 = 1.0;
/// Samples of a unit-scale shape measurement (before refinement).
const SHAPE_SAMPLES: usize = 64;
/// Samples used while building the tables (choice of shape only; safety comes from the
/// per-corner measurement with [`SHAPE_SAMPLES`] and refinement).
const TABLE_SAMPLES: usize = 64;
/// Golden-section iterations (interval shrinks by 0.618 each).
const GOLDEN_ITERS: usize = 32;
/// Bracket of the `rho` search, as multiples of the arc's tangent length `beta/tan(beta/2)`.
const RHO_BRACKET: (f64, f64) = (0.4, 2.2);
/// Relative slack on the curvature sign when deciding whether a shape inflects.
const INFLECTION_SLACK: f64 = 1e-6;

// ---------------------------------------------------------------------------------------
// Unit-scale shapes

fn golden_max(f: &impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> (f64, f64) {
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let mut x1 = hi - g * (hi - lo);
    let mut x2 = lo + g * (hi - lo);
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..GOLDEN_ITERS {
        if f1 < f2 {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + g * (hi - lo);
            f2 = f(x2);
        } else {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - g * (hi - lo);
            f1 = f(x1);
        }
    }
    if f1 > f2 {
        (x1, f1)
    } else {
        (x2, f2)
    }
}

/// Largest value of `f` on `[0, 1]`: the best of `n + 1` samples, refined by golden
/// section between its neighbours.
fn sampled_max(f: &impl Fn(f64) -> f64, n: usize, refine: bool) -> f64 {
    let mut best = (0usize, f64::NEG_INFINITY);
    for i in 0..=n {
        let v = f(i as f64 / n as f64);
        if v > best.1 {
            best = (i, v);
        }
    }
    if !refine {
        return best.1;
    }
    let lo = best.0.saturating_sub(1) as f64 / n as f64;
    let hi = (best.0 + 1).min(n) as f64 / n as f64;
    best.1.max(golden_max(f, lo, hi).1)
}

fn plane_dir(beta: f64) -> Vec3 {
    Vec3::new(beta.cos(), beta.sin(), 0.0)
}

/// Signed curvature in the xy plane (both derivatives from one evaluation; the same
/// values as the spline's own `deriv` and `deriv2`).
fn signed_curvature(c: &PreparedTrig, u: f64) -> f64 {
    let [_, d1, d2] = c.ders(u);
    let s = d1.norm();
    if s <= f64::MIN_POSITIVE {
        return 0.0;
    }
    d1.cross(d2).z / (s * s * s)
}

/// Measurements of an inside transition at `d = 1` (corner at the origin, incoming
/// direction `+x`, turning left by `beta`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoundShape {
    /// Turning angle (radians).
    pub beta: f64,
    /// Derivative length over `d` at both ends.
    pub rho: f64,
    /// Two-sided deviation at `d = 1`: the larger of the corner-to-curve distance and the
    /// curve-to-legs distance.
    pub deviation: f64,
    /// Peak curvature at `d = 1`.
    pub peak_curvature: f64,
    /// The curvature changes sign (an S-shaped, rejected transition).
    pub inflects: bool,
}

fn round_unit_curve(beta: f64, rho: f64) -> TrigSpline {
    let b = plane_dir(beta);
    TrigSpline::hermite(-Vec3::X, b, Vec3::X * rho, b * rho, ROUND_LAMBDA)
}

/// Measures the inside transition of turn `beta` (radians) with derivative ratio `rho`.
pub fn round_shape(beta: f64, rho: f64) -> RoundShape {
    round_shape_n(beta, rho, SHAPE_SAMPLES, true)
}

/// Two-sided deviation of the inside transition at `d = 1` (see [`RoundShape::deviation`]):
/// the per-corner measurement, without the curvature.
pub fn round_deviation(beta: f64, rho: f64) -> f64 {
    let c = round_unit_curve(beta, rho);
    let b = plane_dir(beta);
    round_deviation_of(&c, b, SHAPE_SAMPLES, true)
}

fn round_deviation_of(c: &TrigSpline, b: Vec3, n: usize, refine: bool) -> f64 {
    let c = PreparedTrig::new(c);
    let leg_a = Line::new(-Vec3::X, Vec3::ZERO);
    let leg_b = Line::new(Vec3::ZERO, b);
    let near = |u: f64| -c.eval(u).norm();
    let off = |u: f64| {
        let p = c.eval(u);
        leg_a.dist_sq(p).min(leg_b.dist_sq(p)).sqrt()
    };
    let f = -sampled_max(&near, n, refine);
    let g = sampled_max(&off, n, refine);
    f.max(g)
}

fn round_shape_n(beta: f64, rho: f64, n: usize, refine: bool) -> RoundShape {
    let c = round_unit_curve(beta, rho);
    let b = plane_dir(beta);
    let deviation = round_deviation_of(&c, b, n, refine);
    let prepared = PreparedTrig::new(&c);
    let curv = |u: f64| signed_curvature(&prepared, u);
    let kmax = sampled_max(&curv, n, refine);
    let kmin = -sampled_max(&|u| -curv(u), n, false);
    RoundShape {
        beta,
        rho,
        deviation,
        peak_curvature: kmax.max(-kmin),
        inflects: kmin < -INFLECTION_SLACK * kmax.abs(),
    }
}

/// The derivative ratio of the circular arc tangent to both legs at the same `d`.
fn arc_rho(beta: f64) -> f64 {
    if beta < 1e-6 {
        2.0
    } else {
        beta / (0.5 * beta).tan()
    }
}

/// Entries of the per-degree tables (0 to 180 degrees).
const TABLE_LEN: usize = 181;

/// The `rho` table entry for a whole number of degrees, computed on first use (a program
/// turns by a few distinct angles, so most of the 181 entries are never needed).
fn rho_entry(deg: usize) -> f64 {
    static TABLE: [OnceLock<f64>; TABLE_LEN] = [const { OnceLock::new() }; TABLE_LEN];
    *TABLE[deg.min(TABLE_LEN - 1)].get_or_init(|| {
        let beta = (deg as f64).clamp(1.0, 179.0).to_radians();
        let r0 = arc_rho(beta);
        let score = |s: f64| {
            let sh = round_shape_n(beta, r0 * s, TABLE_SAMPLES, false);
            if sh.inflects || sh.deviation.is_nan() || sh.deviation <= 0.0 {
                f64::NEG_INFINITY
            } else {
                -(sh.peak_curvature * sh.deviation)
            }
        };
        let (s, v) = golden_max(&score, RHO_BRACKET.0, RHO_BRACKET.1);
        if v.is_finite() {
            r0 * s
        } else {
            r0
        }
    })
}

/// Step (degrees) of the deviation table of [`corner_deviation`].
const DEVIATION_STEP_DEG: f64 = 0.05;
/// Entries of the deviation table (0 to 180 degrees).
const DEVIATION_LEN: usize = (180.0 / DEVIATION_STEP_DEG) as usize + 1;
/// Relative allowance added to interpolated table deviations: the interpolation error of
/// this smooth function over [`DEVIATION_STEP_DEG`] is below 1e-6 relative (checked by a
/// test against [`round_deviation`] at random angles).
const DEVIATION_TABLE_ALLOWANCE: f64 = 1e-4;

/// The unit-scale deviation of the inside transition for a turn of `beta` radians, with
/// its table `rho` ([`round_rho`]): a table every `DEVIATION_STEP_DEG` (entries computed
/// on first use), interpolated linearly and raised by `DEVIATION_TABLE_ALLOWANCE` so it
/// never underestimates. Measuring every corner (64 samples and a golden-section
/// refinement) took most of the method's time on large files.
pub fn corner_deviation(beta: f64) -> f64 {
    static TABLE: [OnceLock<f64>; DEVIATION_LEN] = [const { OnceLock::new() }; DEVIATION_LEN];
    let entry = |i: usize| {
        *TABLE[i].get_or_init(|| {
            let b = (i as f64 * DEVIATION_STEP_DEG).to_radians();
            round_deviation(b, round_rho(b))
        })
    };
    let x = beta.to_degrees().clamp(0.0, 180.0) / DEVIATION_STEP_DEG;
    let i = (x.floor() as usize).min(DEVIATION_LEN - 2);
    let f = x - i as f64;
    (entry(i) * (1.0 - f) + entry(i + 1) * f) * (1.0 + DEVIATION_TABLE_ALLOWANCE)
}

/// The `rho` of the inside transition for a turn of `beta` radians (table, linear
/// interpolation in degrees; see module doc).
pub fn round_rho(beta: f64) -> f64 {
    let x = beta.to_degrees().clamp(0.0, 180.0);
    let i = (x.floor() as usize).min(179);
    let f = x - i as f64;
    rho_entry(i) * (1.0 - f) + rho_entry(i + 1) * f
}

/// Peak curvature (1/mm) of the tol-limited inside transition for a turn of `beta`
/// radians.
pub fn round_transition_peak_curvature(beta: f64, tol_mm: f64) -> f64 {
    let sh = round_shape(beta, round_rho(beta));
    sh.peak_curvature * sh.deviation / tol_mm
}

/// Curvature (1/mm) of the circular arc tangent to both legs whose distance from the
/// corner is `tol_mm`: `R = e cos(b/2) / (1 - cos(b/2))`.
pub fn arc_transition_curvature(beta: f64, tol_mm: f64) -> f64 {
    let c = (0.5 * beta).cos();
    (1.0 - c) / (tol_mm * c)
}

/// Measurements of a loop at `tau = 1` (corner at the origin, incoming `+x`, turning left
/// by `beta`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoopShape {
    /// Shape parameter.
    pub lambda: f64,
    /// Largest distance from the corner.
    pub excursion: f64,
    /// Peak curvature.
    pub peak_curvature: f64,
    /// The curvature changes sign.
    pub inflects: bool,
}

fn loop_unit_curve(beta: f64, lambda: f64) -> TrigSpline {
    TrigSpline::hermite(Vec3::ZERO, Vec3::ZERO, Vec3::X, plane_dir(beta), lambda)
}

/// Measures the loop of turn `beta` (radians) with shape parameter `lambda`.
pub fn loop_shape(beta: f64, lambda: f64) -> LoopShape {
    loop_shape_n(beta, lambda, SHAPE_SAMPLES, true)
}

fn loop_shape_n(beta: f64, lambda: f64, n: usize, refine: bool) -> LoopShape {
    let c = PreparedTrig::new(&loop_unit_curve(beta, lambda));
    let exc = sampled_max(&|u| c.eval(u).norm(), n, refine);
    // A left corner is looped clockwise: negative curvature throughout.
    let curv = |u: f64| signed_curvature(&c, u);
    let kmax = sampled_max(&curv, n, false);
    let kmin = -sampled_max(&|u| -curv(u), n, refine);
    LoopShape {
        lambda,
        excursion: exc,
        peak_curvature: kmin.abs().max(kmax.abs()),
        inflects: kmax > INFLECTION_SLACK * kmin.abs(),
    }
}

/// The loop `lambda` table entry for a whole number of degrees, computed on first use.
fn loop_entry(deg: usize) -> f64 {
    static TABLE: [OnceLock<f64>; TABLE_LEN] = [const { OnceLock::new() }; TABLE_LEN];
    *TABLE[deg.min(TABLE_LEN - 1)].get_or_init(|| {
        let steps = ((LOOP_LAMBDA_MAX - LOOP_LAMBDA_MIN) / LOOP_LAMBDA_STEP).round() as usize;
        let beta = (deg as f64).clamp(1.0, LOOP_MAX_TURN_DEG).to_radians();
        let mut best = (f64::INFINITY, 0.0);
        for i in 0..=steps {
            let l = LOOP_LAMBDA_MIN + i as f64 * LOOP_LAMBDA_STEP;
            let sh = loop_shape_n(beta, l, TABLE_SAMPLES, false);
            let score = sh.peak_curvature * sh.excursion;
            if !sh.inflects && score < best.0 {
                best = (score, l);
            }
        }
        best.1
    })
}

/// The loop `lambda` for a turn of `beta` radians (table, nearest whole degree).
pub fn loop_lambda(beta: f64) -> f64 {
    loop_entry(beta.to_degrees().round().clamp(0.0, 180.0) as usize)
}

// ---------------------------------------------------------------------------------------
// Corner constructions in place

/// An inside transition at `v` from direction `a` to `b` (unit vectors) within `tol_mm`,
/// using at most `d_max` of each leg. Returns the curve and its `d`.
pub fn inside_transition(
    v: Vec3,
    a: Vec3,
    b: Vec3,
    tol_mm: f64,
    d_max: f64,
) -> Option<(TrigSpline, f64)> {
    let beta = a.angle_to(b);
    let rho = round_rho(beta);
    let sh = RoundShape {
        beta,
        rho,
        deviation: corner_deviation(beta),
        peak_curvature: f64::NAN,
        inflects: false,
    };
    inside_transition_with(v, a, b, &sh, tol_mm, d_max)
}

fn inside_transition_with(
    v: Vec3,
    a: Vec3,
    b: Vec3,
    sh: &RoundShape,
    tol_mm: f64,
    d_max: f64,
) -> Option<(TrigSpline, f64)> {
    if sh.deviation.is_nan() || sh.deviation <= 0.0 {
        return None;
    }
    let d = (tol_mm * (1.0 - CORNER_TOL_MARGIN) / sh.deviation).min(d_max);
    if !(d > 0.0 && d.is_finite()) {
        return None;
    }
    let c = TrigSpline::hermite(
        v - a * d,
        v + b * d,
        a * (sh.rho * d),
        b * (sh.rho * d),
        ROUND_LAMBDA,
    );
    Some((c, d))
}

/// A loop through the corner `v` from direction `a` to `b` (unit vectors) whose excursion
/// is at most `loop_size_mm`.
pub fn loop_corner(v: Vec3, a: Vec3, b: Vec3, loop_size_mm: f64) -> Option<TrigSpline> {
    let beta = a.angle_to(b);
    let sh = loop_shape(beta, loop_lambda(beta));
    if !(sh.excursion > 0.0 && loop_size_mm > 0.0) {
        return None;
    }
    let tau = loop_size_mm * (1.0 - CORNER_TOL_MARGIN) / sh.excursion;
    Some(TrigSpline::hermite(v, v, a * tau, b * tau, sh.lambda))
}

// ---------------------------------------------------------------------------------------
// The chain strategy

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    /// Chain end, joint with a non-line move, straight pass-through or stop.
    Fixed,
    /// Inside a micro-line run, unit tangent.
    Smooth(Vec3),
    /// Inside transition (shape at unit scale).
    Round(RoundShape),
    /// Loop.
    Loop,
}

impl Kind {
    /// Share of an adjacent leg this vertex leaves to the vertex at the leg's other end.
    fn leaves(&self) -> f64 {
        match self {
            Kind::Fixed | Kind::Loop => 1.0,
            Kind::Smooth(_) | Kind::Round(_) => 0.5,
        }
    }
}

struct Poly {
    /// Vertices `V_0 .. V_L`.
    v: Vec<Vec3>,
    /// Move index of leg `j` (`V_j -> V_(j+1)`).
    mv: Vec<usize>,
    /// Unit directions and lengths of the legs.
    dir: Vec<Vec3>,
    len: Vec<f64>,
}

/// Counters of one chain, merged into the report.
#[derive(Default)]
struct Counts {
    smoothed: usize,
    straight: usize,
    stopped: usize,
    arc_joints: usize,
}

/// Smooths one chain with the trig method (see module doc).
pub fn smooth_chain_trig(
    chain: &Chain<'_>,
    opts: &SmoothOptions,
    report: &mut SmoothReport,
) -> Vec<Move> {
    let moves = chain.moves;
    if moves.is_empty() {
        return Vec::new();
    }
    let finite = moves
        .iter()
        .all(|m| m.segment.start().is_finite() && m.segment.end().is_finite());
    if !(finite && opts.tol_mm > 0.0) {
        return chain.moves.to_vec();
    }
    let runs = screen(chain, &opts.trig.screen, opts.tol_mm);
    // run_vertex[i]: the junction at the start of move i is inside a run.
    let mut run_vertex = vec![false; moves.len() + 1];
    for r in &runs {
        for i in r.first + 1..=r.last {
            run_vertex[i] = true;
        }
    }
    let mut pieces = Vec::with_capacity(moves.len() * 2);
    let mut counts = Counts::default();
    let mut i = 0;
    while i < moves.len() {
        if i > 0 {
            joint_between_groups(moves, i, opts, &mut counts);
        }
        if matches!(moves[i].segment, Segment::Line(_)) {
            let mut j = i;
            while j + 1 < moves.len() && matches!(moves[j + 1].segment, Segment::Line(_)) {
                j += 1;
            }
            smooth_lines(
                i,
                j,
                moves,
                &run_vertex,
                opts,
                report,
                &mut counts,
                &mut pieces,
            );
            i = j + 1;
        } else {
            pieces.push(OutPiece {
                segment: moves[i].segment.clone(),
                from: ChainPos::start_of(i),
                to: ChainPos::end_of(i),
            });
            i += 1;
        }
    }
    report.corners_smoothed += counts.smoothed;
    report.corners_straight += counts.straight;
    report.corners_stopped += counts.stopped;
    report.arc_joints += counts.arc_joints;
    assemble(chain, pieces)
}

/// Classifies the joint at the start of move `i` when it is not a line-line joint.
/// Zero-length lines carry no direction: the joint is the one between the moves around
/// them (classified once: here when the move after them is a line, whose group starts at
/// `i`, else at that move's own start).
fn joint_between_groups(moves: &[Move], i: usize, opts: &SmoothOptions, counts: &mut Counts) {
    let degenerate =
        |k: usize| matches!(&moves[k].segment, Segment::Line(l) if l.length() <= DEGENERATE_MM);
    let Some(k) = (i..moves.len()).find(|&k| !degenerate(k)) else {
        return;
    };
    if k != i && !matches!(moves[k].segment, Segment::Line(_)) {
        return;
    }
    let Some(j) = (0..i).rev().find(|&j| !degenerate(j)) else {
        return;
    };
    let (a, b) = (&moves[j].segment, &moves[k].segment);
    if matches!((a, b), (Segment::Line(_), Segment::Line(_))) {
        return;
    }
    match super::turn_angle_deg(a, b) {
        Some(t) if t < opts.straight_angle_deg => counts.straight += 1,
        _ => {
            counts.stopped += 1;
            if matches!(a, Segment::Arc(_)) || matches!(b, Segment::Arc(_)) {
                counts.arc_joints += 1;
            }
        }
    }
}

/// Lines `first..=last` of the chain: plan, measure, split, emit.
#[allow(clippy::too_many_arguments)]
fn smooth_lines(
    first: usize,
    last: usize,
    moves: &[Move],
    run_vertex: &[bool],
    opts: &SmoothOptions,
    report: &mut SmoothReport,
    counts: &mut Counts,
    pieces: &mut Vec<OutPiece>,
) {
    let poly = polyline(first, last, moves);
    if poly.mv.is_empty() {
        for i in first..=last {
            pieces.push(OutPiece {
                segment: moves[i].segment.clone(),
                from: ChainPos::start_of(i),
                to: ChainPos::end_of(i),
            });
        }
        return;
    }
    let (mut kind, turn) = vertex_kinds(&poly, run_vertex, opts);
    let (d, segs, devs) = fit_smooth_legs(&poly, &mut kind, &turn, opts);
    report_runs(&kind, &devs, report);
    count_vertices(&kind, &turn, opts, counts);
    emit_legs(&poly, &kind, &d, &segs, opts, pieces);
    // Zero-length moves after the last leg (skipped above) keep the chain's end exact.
    let last_leg_move = *poly.mv.last().unwrap();
    let end = *poly.v.last().unwrap();
    for i in last_leg_move + 1..=last {
        if moves[i].segment.end().dist(end) > 0.0 {
            pieces.push(OutPiece {
                segment: Segment::Line(Line::new(end, moves[i].segment.end())),
                from: ChainPos::start_of(i),
                to: ChainPos::end_of(i),
            });
        }
    }
}

/// The polyline of lines `first..=last` without zero-length legs.
fn polyline(first: usize, last: usize, moves: &[Move]) -> Poly {
    let mut poly = Poly {
        v: Vec::new(),
        mv: Vec::new(),
        dir: Vec::new(),
        len: Vec::new(),
    };
    for (i, m) in moves.iter().enumerate().take(last + 1).skip(first) {
        let Segment::Line(l) = &m.segment else {
            continue;
        };
        if poly.v.is_empty() {
            poly.v.push(l.p0);
        }
        let p0 = *poly.v.last().unwrap();
        let d = l.p1 - p0;
        let n = d.norm();
        if n <= DEGENERATE_MM {
            continue;
        }
        poly.v.push(l.p1);
        poly.mv.push(i);
        poly.dir.push(d / n);
        poly.len.push(n);
    }
    poly
}

/// The kind of a corner turning by `beta` (rad) that is not inside a run.
fn corner_kind(beta: f64, opts: &SmoothOptions) -> Kind {
    let trig = &opts.trig;
    let deg = beta.to_degrees();
    if deg < opts.straight_angle_deg || deg > trig.stop_turn_deg {
        return Kind::Fixed;
    }
    if let CornerStyle::Loop { .. } = trig.corner {
        if deg >= trig.loop_min_turn_deg && deg <= LOOP_MAX_TURN_DEG {
            return Kind::Loop;
        }
    }
    let rho = round_rho(beta);
    Kind::Round(RoundShape {
        beta,
        rho,
        deviation: corner_deviation(beta),
        // Not needed to place the transition (see `round_shape` for it).
        peak_curvature: f64::NAN,
        inflects: false,
    })
}

/// The kind and turn (rad) of every vertex of `poly` (the ends are fixed).
fn vertex_kinds(poly: &Poly, run_vertex: &[bool], opts: &SmoothOptions) -> (Vec<Kind>, Vec<f64>) {
    let legs = poly.mv.len();
    let mut kind = vec![Kind::Fixed; legs + 1];
    let mut turn = vec![0.0; legs + 1];
    for j in 1..legs {
        let (a, b) = (poly.dir[j - 1], poly.dir[j]);
        turn[j] = a.angle_to(b);
        let consecutive = poly.mv[j] == poly.mv[j - 1] + 1;
        kind[j] = if consecutive && run_vertex[poly.mv[j]] {
            let (h0, h1) = (poly.len[j - 1], poly.len[j]);
            let t = a * (h1 / (h0 + h1)) + b * (h0 / (h0 + h1));
            match t.normalized() {
                Some(t) => Kind::Smooth(t),
                None => corner_kind(turn[j], opts),
            }
        } else {
            corner_kind(turn[j], opts)
        };
    }
    (kind, turn)
}

/// Transition lengths, and the trigonometric segment (with its measured deviation) of
/// every leg next to a smooth vertex: planned, measured, and the smooth vertices of a leg
/// whose segment misses the tolerance turned into corners, until every one holds it.
#[allow(clippy::type_complexity)]
fn fit_smooth_legs(
    poly: &Poly,
    kind: &mut [Kind],
    turn: &[f64],
    opts: &SmoothOptions,
) -> (Vec<f64>, Vec<Option<TrigSpline>>, Vec<f64>) {
    let tol = opts.tol_mm;
    let legs = poly.mv.len();
    loop {
        let d = transition_lengths(poly, kind, tol);
        let mut segs: Vec<Option<TrigSpline>> = vec![None; legs];
        let mut devs = vec![0.0; legs];
        let mut failed = Vec::new();
        for j in 0..legs {
            let (ks, ke) = (kind[j], kind[j + 1]);
            if !matches!(ks, Kind::Smooth(_)) && !matches!(ke, Kind::Smooth(_)) {
                continue;
            }
            match smooth_leg(poly, j, ks, ke, &d, tol) {
                Some((c, dev)) => {
                    segs[j] = Some(c);
                    devs[j] = dev;
                }
                None => failed.push(j),
            }
        }
        if failed.is_empty() {
            return (d, segs, devs);
        }
        for j in failed {
            for v in [j, j + 1] {
                if matches!(kind[v], Kind::Smooth(_)) {
                    kind[v] = corner_kind(turn[v], opts);
                }
            }
        }
    }
}

/// The segment of leg `j` between its transitions (`d`), with vertex kinds `ks`, `ke` at
/// its ends, and its measured deviation from the leg; `None` when no shape holds `tol`.
fn smooth_leg(
    poly: &Poly,
    j: usize,
    ks: Kind,
    ke: Kind,
    d: &[f64],
    tol: f64,
) -> Option<(TrigSpline, f64)> {
    let s = poly.v[j] + poly.dir[j] * d[j];
    let e = poly.v[j + 1] - poly.dir[j] * d[j + 1];
    let h = s.dist(e);
    // One derivative per smooth vertex, shared by the two segments meeting there (C1);
    // the leg direction and the segment's own chord at the other ends.
    let t0 = match ks {
        Kind::Smooth(t) => t * smooth_speed(poly, j),
        _ => poly.dir[j] * h,
    };
    let t1 = match ke {
        Kind::Smooth(t) => t * smooth_speed(poly, j + 1),
        _ => poly.dir[j] * h,
    };
    let chord = Segment::Line(Line::new(s, e));
    let acc = tol * RUN_MEASURE_SHARE;
    RUN_LAMBDAS.iter().find_map(|&lambda| {
        let c = TrigSpline::hermite(s, e, t0, t1, lambda);
        let seg = Segment::Trig(c);
        let dev = deviation_segments(&[(&seg, 0)], &[(&chord, 0)], acc).max_mm();
        (dev + acc <= tol).then_some((c, dev))
    })
}

/// Reports the runs: maximal sequences of smooth vertices.
fn report_runs(kind: &[Kind], devs: &[f64], report: &mut SmoothReport) {
    let legs = kind.len() - 1;
    let mut j = 1;
    while j < legs {
        if matches!(kind[j], Kind::Smooth(_)) {
            let start = j;
            while j < legs && matches!(kind[j], Kind::Smooth(_)) {
                j += 1;
            }
            let dev = devs[start - 1..j].iter().copied().fold(0.0, f64::max);
            report.runs_fitted += 1;
            report.points_per_run.push(j - start + 2);
            report.fit_deviation_per_run_mm.push(dev);
        } else {
            j += 1;
        }
    }
}

/// Counts the interior vertices: smoothed corners, straight joints and stops.
fn count_vertices(kind: &[Kind], turn: &[f64], opts: &SmoothOptions, counts: &mut Counts) {
    for j in 1..kind.len() - 1 {
        match kind[j] {
            Kind::Round(_) | Kind::Loop => counts.smoothed += 1,
            Kind::Fixed => {
                if turn[j].to_degrees() < opts.straight_angle_deg {
                    counts.straight += 1;
                } else {
                    counts.stopped += 1;
                }
            }
            Kind::Smooth(_) => {}
        }
    }
}

/// Emits, leg by leg, the corner transition at its start vertex and then the leg's
/// smooth segment or its remaining line.
fn emit_legs(
    poly: &Poly,
    kind: &[Kind],
    d: &[f64],
    segs: &[Option<TrigSpline>],
    opts: &SmoothOptions,
    pieces: &mut Vec<OutPiece>,
) {
    let pos = |j: usize, along: f64| ChainPos {
        index: poly.mv[j],
        frac: (along / poly.len[j]).clamp(0.0, 1.0),
    };
    for j in 0..poly.mv.len() {
        if j > 0 {
            let from = pos(j - 1, poly.len[j - 1] - d[j]);
            let to = pos(j, d[j]);
            if let Some(c) = corner_transition(poly, j, kind[j], d[j], opts) {
                pieces.push(OutPiece {
                    segment: Segment::Trig(c),
                    from,
                    to,
                });
            }
        }
        let from = pos(j, d[j]);
        let to = pos(j, poly.len[j] - d[j + 1]);
        if let Some(c) = segs[j] {
            pieces.push(OutPiece {
                segment: Segment::Trig(c),
                from,
                to,
            });
        } else {
            let s = poly.v[j] + poly.dir[j] * d[j];
            let e = poly.v[j + 1] - poly.dir[j] * d[j + 1];
            // Exact end points where nothing was cut, so the joints stay gap-free.
            let s = if d[j] == 0.0 { poly.v[j] } else { s };
            let e = if d[j + 1] == 0.0 { poly.v[j + 1] } else { e };
            if s.dist(e) > DEGENERATE_MM {
                pieces.push(OutPiece {
                    segment: Segment::Line(Line::new(s, e)),
                    from,
                    to,
                });
            }
        }
    }
}

/// The transition at corner vertex `j` of kind `k` with length `dj`, if it has one.
fn corner_transition(
    poly: &Poly,
    j: usize,
    k: Kind,
    dj: f64,
    opts: &SmoothOptions,
) -> Option<TrigSpline> {
    let vj = poly.v[j];
    let (a, b) = (poly.dir[j - 1], poly.dir[j]);
    match k {
        Kind::Round(sh) => inside_transition_with(vj, a, b, &sh, opts.tol_mm, dj).map(|(c, _)| c),
        Kind::Loop => match opts.trig.corner {
            CornerStyle::Loop { loop_size_mm } => loop_corner(vj, a, b, loop_size_mm),
            _ => None,
        },
        Kind::Fixed | Kind::Smooth(_) => None,
    }
}

/// Derivative magnitude at smooth vertex `j`: the harmonic mean of its two chords, so the
/// segments on both sides share one derivative (C1) that stays close to the shorter chord
/// (the screen keeps neighbouring chords within `ratio_max` of each other).
fn smooth_speed(poly: &Poly, j: usize) -> f64 {
    let (h0, h1) = (poly.len[j - 1], poly.len[j]);
    2.0 * h0 * h1 / (h0 + h1)
}

/// Transition length `d_j` of every vertex: zero except at round corners, where it is the
/// tol-limited length clipped to the leg shares (see module doc).
fn transition_lengths(poly: &Poly, kind: &[Kind], tol: f64) -> Vec<f64> {
    let legs = poly.mv.len();
    let mut d = vec![0.0; legs + 1];
    for j in 1..legs {
        if let Kind::Round(sh) = kind[j] {
            let avail_in = poly.len[j - 1] * kind[j - 1].leaves();
            let avail_out = poly.len[j] * kind[j + 1].leaves();
            let by_tol = if sh.deviation > 0.0 {
                tol * (1.0 - CORNER_TOL_MARGIN) / sh.deviation
            } else {
                0.0
            };
            d[j] = by_tol.min(avail_in).min(avail_out).max(0.0);
        }
    }
    d
}

/// True for a loop segment of this method: a trig segment starting and ending at the same
/// point (transitions and run segments always have distinct ends).
pub fn is_loop(seg: &Segment) -> bool {
    matches!(seg, Segment::Trig(c) if c.q0 == c.q1)
}

/// Relative flattening accuracy (share of the loop size) of [`check_loops`].
const LOOP_CHECK_SHARE: f64 = 1e-4;

/// The loops' own bound, measured on a smoothed program.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct LoopCheck {
    /// Loops in the program.
    pub loops: usize,
    /// Largest excursion of a loop from its corner (mm): an upper bound (flattened points
    /// plus the flattening accuracy).
    pub max_excursion_mm: f64,
    /// Largest distance from a loop's start or end point, as the curve evaluates them, to
    /// the nearest vertex of the programmed path (mm).
    pub max_corner_miss_mm: f64,
}

impl LoopCheck {
    /// True when every loop passes its corner within 1e-9 mm and stays within
    /// `loop_size_mm`.
    pub fn within(&self, loop_size_mm: f64) -> bool {
        self.max_corner_miss_mm <= 1e-9 && self.max_excursion_mm <= loop_size_mm
    }
}

/// Measures the loops of `tp` (see [`LoopCheck`]) against the `programmed` path they were
/// made from: each loop's evaluated end points against the nearest programmed vertex, its
/// excursion from that vertex by flattening. `loop_size_mm` sets the flattening accuracy.
pub fn check_loops(
    tp: &crate::path::Toolpath,
    programmed: &crate::path::Toolpath,
    loop_size_mm: f64,
) -> LoopCheck {
    let acc = loop_size_mm * LOOP_CHECK_SHARE;
    let vertices = VertexIndex::new(programmed);
    let mut c = LoopCheck::default();
    for m in tp.moves() {
        let Segment::Trig(t) = &m.segment else {
            continue;
        };
        if !is_loop(&m.segment) {
            continue;
        }
        c.loops += 1;
        let (p0, p1) = (t.eval(0.0), t.eval(1.0));
        let Some(corner) = vertices.nearest(p0) else {
            c.max_corner_miss_mm = f64::INFINITY;
            continue;
        };
        c.max_corner_miss_mm = c
            .max_corner_miss_mm
            .max(p0.dist(corner))
            .max(p1.dist(corner));
        let mut e: f64 = 0.0;
        crate::geom::Flatten::flatten(t, acc, &mut |p| e = e.max(p.dist(corner)));
        c.max_excursion_mm = c.max_excursion_mm.max(e + acc);
    }
    c
}

/// Cell size (mm) of [`VertexIndex`]: loops must pass their corner within far less.
const VERTEX_CELL_MM: f64 = 1e-3;

/// The programmed vertices hashed on a grid, for nearest-vertex queries near a vertex.
struct VertexIndex {
    cells: std::collections::HashMap<[i64; 3], Vec<Vec3>>,
}

impl VertexIndex {
    fn key(p: Vec3) -> [i64; 3] {
        [p.x, p.y, p.z].map(|c| (c / VERTEX_CELL_MM).floor() as i64)
    }

    fn new(tp: &crate::path::Toolpath) -> Self {
        let mut cells: std::collections::HashMap<[i64; 3], Vec<Vec3>> = Default::default();
        let mut add = |p: Vec3| cells.entry(Self::key(p)).or_default().push(p);
        add(tp.start);
        for m in tp.moves() {
            add(m.segment.end());
        }
        VertexIndex { cells }
    }

    /// The nearest vertex within one cell of `p`, if any.
    fn nearest(&self, p: Vec3) -> Option<Vec3> {
        let k = Self::key(p);
        let mut best: Option<(f64, Vec3)> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let cell = [k[0] + dx, k[1] + dy, k[2] + dz];
                    for &v in self.cells.get(&cell).into_iter().flatten() {
                        let d = v.dist(p);
                        if best.is_none_or(|(bd, _)| d < bd) {
                            best = Some((d, v));
                        }
                    }
                }
            }
        }
        best.map(|(_, v)| v)
    }
}

/// The program without its loops: the legs still reach every looped corner exactly, so
/// this path is the one the two-sided tolerance applies to.
pub fn without_loops(tp: &crate::path::Toolpath) -> crate::path::Toolpath {
    let mut out = tp.clone();
    out.blocks.retain(|b| match b {
        crate::path::Block::Move(m) => !is_loop(&m.segment),
        _ => true,
    });
    out
}

/// Figure data for the report: Fig. 1 families and a loop corner, sampled.
pub mod figures {
    use super::*;

    /// One sampled curve of a figure.
    #[derive(Clone, Debug, PartialEq)]
    pub struct FigureCurve {
        /// Legend text.
        pub label: String,
        /// Shape parameter `lambda`.
        pub lambda: f64,
        /// Shape parameter `k`.
        pub k: f64,
        /// Control points.
        pub control: Vec<Vec3>,
        /// Samples of the curve, uniform in the parameter.
        pub points: Vec<Vec3>,
    }

    /// The control points `A, B, C, D` used for Fig. 1 (the paper gives none): the curve
    /// runs from `A` to `B`; `C` and `D` set its end slopes.
    pub const FIG1_CONTROL: [Vec3; 4] = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(10.0, 0.0, 0.0),
        Vec3::new(12.0, 6.0, 0.0),
        Vec3::new(18.0, 6.0, 0.0),
    ];

    fn sampled(lambda: f64, k: f64, samples: usize, label: String) -> FigureCurve {
        let [a, b, c, d] = FIG1_CONTROL;
        let s = TrigSpline::new(a, b, c, d, lambda, k);
        let n = samples.max(1);
        FigureCurve {
            label,
            lambda,
            k,
            control: FIG1_CONTROL.to_vec(),
            points: (0..=n).map(|i| s.eval(i as f64 / n as f64)).collect(),
        }
    }

    /// Fig. 1(a): `k = 0.5`, `lambda = 0, 0.5, 1, 1.5`.
    pub fn fig1_lambda_family(samples: usize) -> Vec<FigureCurve> {
        [0.0, 0.5, 1.0, 1.5]
            .iter()
            .map(|&l| sampled(l, 0.5, samples, format!("k = 0.5, lambda = {l}")))
            .collect()
    }

    /// Fig. 1(b): `lambda = 1`, `k = 0.3, 0.5, 0.6, 0.7`.
    pub fn fig1_k_family(samples: usize) -> Vec<FigureCurve> {
        [0.3, 0.5, 0.6, 0.7]
            .iter()
            .map(|&k| sampled(1.0, k, samples, format!("lambda = 1, k = {k}")))
            .collect()
    }

    /// A loop corner (Fig. 8): legs of length 10 meeting at the origin, turning left by
    /// `turn_deg`, and the loop with excursion `loop_size_mm`. Returns the polyline of the
    /// programmed legs and the sampled loop (its control points in `control`).
    pub fn loop_corner_figure(
        turn_deg: f64,
        loop_size_mm: f64,
        samples: usize,
    ) -> Option<(Vec<Vec3>, FigureCurve)> {
        let beta = turn_deg.to_radians();
        let b = Vec3::new(beta.cos(), beta.sin(), 0.0);
        let c = loop_corner(Vec3::ZERO, Vec3::X, b, loop_size_mm)?;
        let n = samples.max(1);
        Some((
            vec![Vec3::X * -10.0, Vec3::ZERO, b * 10.0],
            FigureCurve {
                label: format!("loop, turn {turn_deg} deg, lambda = {:.1}", c.lambda),
                lambda: c.lambda,
                k: c.k,
                control: c.control_points().to_vec(),
                points: (0..=n).map(|i| c.eval(i as f64 / n as f64)).collect(),
            },
        ))
    }
}

#[cfg(test)]
mod tests;
