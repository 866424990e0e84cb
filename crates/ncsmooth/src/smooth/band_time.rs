//! Time shaping of a run's band fit at its slow spots: where the machine has to
//! slow down on the fitted curve, the curve is reshaped inside the same two-sided band to
//! the shape that the machine's limits traverse fastest.
//!
//! ## Why
//! The band fit ([`super::band_fit`]) is the smoothest curve in the band: it minimises
//! curvature and its variation. At a near-cusp (two vertices turning 150 degrees over a
//! quarter of a millimetre, butterfly_1000) the fastest curve in the band is not the
//! smoothest one: it enters wide along the outer edge of the band, cuts to the inner edge
//! at the apex (a tight, slow turn costs less time than a wider one once the turn exceeds
//! about 2 rad), and rounds the softer partner vertex, so that the axes keep more of their
//! acceleration for the tangential direction on the way in and out
//! (`scripts/band_time_study.py` optimises the same band directly for time, as a
//! reference for what a spot can gain).
//!
//! ## Method
//! 1. **Speed model.** The minimum-time speed profile along a fixed curve under the feed and
//!    per-axis accelerations, as in the planner ([`crate`]'s `feed` module) but on dense
//!    samples (every [`TimeShapeOptions::sample_mm`]): `x = v^2` capped by the feed and
//!    by `x |K_i| <= A_i`, then a backward and a forward pass with the tangential
//!    acceleration `u` in the range that keeps `|u T_i + x K_i| <= A_i` on every axis
//!    (`T` the unit tangent, `K` the curvature vector; the classic phase-plane scheme of
//!    Bobrow et al. 1985, per-axis as in TOPP-RA, Pham and Pham 2018). The time is the sum
//!    of `2 ds / (v_k + v_(k+1))`. Accelerations are taken at [`TimeShapeOptions::acc_share`]
//!    of the limits, the planner's reserve.
//! 2. **Spots.** Local minima of the modelled speed below
//!    [`TimeShapeOptions::slow_share`] of the feed, slowest first, far enough apart that
//!    the control points they move do not share a span; each spot is shaped on its own
//!    (in parallel, [`crate::set_threads`]) and the moved control points are merged.
//! 3. **Window.** Knots are inserted (NURBS Book A5.1, the curve unchanged) so that the
//!    spans within [`TimeShapeOptions::free_half_mm`] of the spot are at most
//!    [`TimeShapeOptions::dense_span_mm`] long; the control points whose Greville
//!    abscissae lie there are the variables, all others stay. The new curve is the same
//!    cubic B-spline outside their support, so it joins the rest with C2 continuity
//!    exactly. The time is modelled over `+-`[`TimeShapeOptions::window_mm`] around the
//!    spot (enough for the slow-down and speed-up), entering and leaving at the speeds of
//!    the whole curve's profile.
//! 4. **Optimisation.** Penalty method: model time plus `w sum (excess / r)^2` over the
//!    band's two sides at the samples (each sample's distance to the run's polyline beyond
//!    `r`, each vertex's distance to the sampled curve beyond `r`), minimised by L-BFGS
//!    (Nocedal and Wright, algorithm 7.4, Armijo backtracking) on forward-difference
//!    gradients, for a rising sequence of weights `PENALTY_WEIGHTS`, then rounds of
//!    coordinate sweeps and L-BFGS at the last weight. A difference quotient moves one
//!    control point: only its samples are re-evaluated, and the two passes are redone only
//!    until they meet the cached profile again.
//! 5. **Acceptance.** The reshaped curve is measured exactly against the run's polyline
//!    ([`crate::verify::deviation_segments`]); a window is kept only when the deviation
//!    is within the tolerance, the model time fell by at least `MIN_GAIN_S` (1e-5), and the
//!    reshaped part neither turns much more than the fit did (`MAX_EXTRA_TURN_RAD` (std::f64::consts::FRACPI2): no
//!    loop) nor slows its parameter to a cusp (`MIN_SPEED_SHARE` (0.5)).
//!
//! ## Limits
//! The optimisation is local (a start at the band fit, a fixed knot layout); the model
//! ignores jerk and the period, and samples the band; the planner runs on the result as on
//! any curve, so what it plans is what counts (butterfly_1000, tol 0.01, 50 mm/s,
//! 500 mm/s^2: see `docs/benchmarks/2026-12-02.md`). The cost is about a second per spot
//! (thousands of gradient evaluations over some 100 variables), so it is off by default
//! (`--time-shape` on the command line).

use super::band_fit::{polyline_deviation, EndCond};
use crate::geom::{Line, Nurbs, Segment, Vec3};

/// The machine limits the shaping minimises time for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeLimits {
    /// Path feed (mm/s).
    pub feed_mm_s: f64,
    /// Per-axis acceleration limits (mm/s^2).
    pub acc_mm_s2: [f64; 3],
}

/// Settings of the time shaping.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct TimeShapeOptions {
    /// The limits of the speed model.
    pub limits: TimeLimits,
    /// Share of the acceleration limits the model uses. Default 0.99, the planner's
    /// reserve (`feed::ACC_PLANNING_FACTOR`).
    pub acc_share: f64,
    /// Radius of the band the reshaped curve is held in, as a share of the tolerance
    /// (the band fit's own is [`super::band_fit::BandFitOptions::band_share`]; the
    /// reshaped curve is measured and kept only within the tolerance less the
    /// measurement's accuracy, 2 % of it for runs). Default 0.975.
    pub band_share: f64,
    /// Spots are speed minima below this share of the feed. Default 0.7.
    pub slow_share: f64,
    /// Half-length (mm) of the curve over which a spot's time is modelled. Default 4 mm
    /// (a slow-down from 50 mm/s at 500 mm/s^2 takes 2.5 mm).
    pub window_mm: f64,
    /// Half-length (mm) of the reshaped part around a spot. Default 0.7 mm.
    pub free_half_mm: f64,
    /// Longest knot span (mm) in the reshaped part. Default 0.04 mm.
    pub dense_span_mm: f64,
    /// Sample spacing (mm, in the curve's chord-length parameter) of the model and of the
    /// band penalty. Default 0.002 mm.
    pub sample_mm: f64,
    /// L-BFGS iterations per penalty weight. Default 150.
    pub max_iters: usize,
    /// Rounds of coordinate sweeps, each followed by L-BFGS, at the last penalty weight.
    /// Default 4 (more rounds gain little: `docs/benchmarks/2026-12-02.md`).
    pub polish_rounds: usize,
}

/// Builders: each sets one field (see its doc for the default).
impl TimeShapeOptions {
    /// Sets [`TimeShapeOptions::limits`].
    pub fn with_limits(mut self, limits: TimeLimits) -> Self {
        self.limits = limits;
        self
    }

    /// Sets [`TimeShapeOptions::acc_share`].
    pub fn with_acc_share(mut self, acc_share: f64) -> Self {
        self.acc_share = acc_share;
        self
    }

    /// Sets [`TimeShapeOptions::band_share`].
    pub fn with_band_share(mut self, band_share: f64) -> Self {
        self.band_share = band_share;
        self
    }

    /// Sets [`TimeShapeOptions::slow_share`].
    pub fn with_slow_share(mut self, slow_share: f64) -> Self {
        self.slow_share = slow_share;
        self
    }

    /// Sets [`TimeShapeOptions::window_mm`].
    pub fn with_window_mm(mut self, window_mm: f64) -> Self {
        self.window_mm = window_mm;
        self
    }

    /// Sets [`TimeShapeOptions::free_half_mm`].
    pub fn with_free_half_mm(mut self, free_half_mm: f64) -> Self {
        self.free_half_mm = free_half_mm;
        self
    }

    /// Sets [`TimeShapeOptions::dense_span_mm`].
    pub fn with_dense_span_mm(mut self, dense_span_mm: f64) -> Self {
        self.dense_span_mm = dense_span_mm;
        self
    }

    /// Sets [`TimeShapeOptions::sample_mm`].
    pub fn with_sample_mm(mut self, sample_mm: f64) -> Self {
        self.sample_mm = sample_mm;
        self
    }

    /// Sets [`TimeShapeOptions::max_iters`].
    pub fn with_max_iters(mut self, max_iters: usize) -> Self {
        self.max_iters = max_iters;
        self
    }

    /// Sets [`TimeShapeOptions::polish_rounds`].
    pub fn with_polish_rounds(mut self, polish_rounds: usize) -> Self {
        self.polish_rounds = polish_rounds;
        self
    }
}

impl TimeShapeOptions {
    /// The default settings for `limits`.
    pub fn new(limits: TimeLimits) -> TimeShapeOptions {
        TimeShapeOptions {
            limits,
            acc_share: 0.99,
            band_share: 0.975,
            slow_share: 0.7,
            window_mm: 4.0,
            free_half_mm: 0.7,
            dense_span_mm: 0.04,
            sample_mm: 0.002,
            max_iters: 150,
            polish_rounds: 4,
        }
    }
}

/// The penalty weights, applied in turn (each stage starts where the last ended).
pub(crate) const PENALTY_WEIGHTS: [f64; 3] = [10.0, 1e3, 1e5];
/// Smallest model gain (s) for which a reshaped window is kept.
pub(crate) const MIN_GAIN_S: f64 = 1e-5;
/// Forward-difference step (mm) of the gradient.
const FD_STEP_MM: f64 = 1e-6;
/// Spacing (mm) of the whole-curve profile that finds the spots.
const PROFILE_STEP_MM: f64 = 0.01;
/// The penalty's band, as a share of the fit's band radius: a little inside, so that
/// the small excess the penalty leaves is still within it.
const PENALTY_BAND_SHARE: f64 = 0.995;
/// How far along the curve (mm) a vertex's nearest sample is looked for.
const VERTEX_REACH_MM: f64 = 0.5;
/// An L-BFGS iteration gaining less than this (s) is flat ...
const FLAT_S: f64 = 1e-10;
/// ... and this many flat iterations in a row end a stage.
const FLAT_PATIENCE: usize = 5;
/// How much more (rad) the reshaped part of a curve may turn than the fit did there. An
/// apex entered wide turns out first and back later (butterfly_1000: up to 40 degrees
/// more); a loop adds a whole turn and is invisible to the band (camotics_vcarve, whose
/// quantised points give knot spans of a tenth of a micrometre: 390 and 715 degrees more
/// inside spans shorter than a sample step, before those spans got samples of their own;
/// written as lines, a loop is a run of reversing blocks).
pub(crate) const MAX_EXTRA_TURN_RAD: f64 = std::f64::consts::FRAC_PI_2;
/// The least parametric speed `|C'|` of the reshaped part, as a share of the fit's there
/// (about 1 with the chord-length parameter, 0.44-0.98 at butterfly_1000's spots, which
/// keep 0.85 of it): a cusp, where it vanishes, is a reversal, the limit of a tight apex
/// that the model takes for a stop and a controller for a corner.
pub(crate) const MIN_SPEED_SHARE: f64 = 0.5;
/// Samples inside a knot span shorter than two sample steps.
const SPAN_SAMPLES_SHORT: usize = 3;
/// Tangent samples per knot span of the turn check.
const TURN_SAMPLES_PER_SPAN: usize = 16;
/// The steps (mm) of the coordinate sweeps, in turn.
const PATTERN_STEPS_MM: [f64; 4] = [1e-3, 3e-4, 1e-4, 3e-5];
/// L-BFGS memory.
const LBFGS_MEMORY: usize = 8;

/// Geometry at one sample: point, unit tangent, curvature vector.
#[derive(Clone, Copy, Debug, Default)]
struct Geo {
    p: Vec3,
    t: Vec3,
    k: Vec3,
}

impl Geo {
    fn from_ders(d: [Vec3; 3]) -> Geo {
        let sp = d[1].norm().max(f64::MIN_POSITIVE);
        let t = d[1] / sp;
        Geo {
            p: d[0],
            t,
            k: (d[2] - t * d[2].dot(t)) / (sp * sp),
        }
    }
}

/// The speed model's limits: feed squared and the per-axis accelerations.
#[derive(Clone, Copy, Debug)]
struct Model {
    x_feed: f64,
    acc: [f64; 3],
}

impl Model {
    fn new(o: &TimeShapeOptions) -> Model {
        let a = o.limits.acc_mm_s2;
        Model {
            x_feed: o.limits.feed_mm_s * o.limits.feed_mm_s,
            acc: [a[0] * o.acc_share, a[1] * o.acc_share, a[2] * o.acc_share],
        }
    }
    /// Largest `x = v^2` the feed and the curvature allow at `g`.
    fn cap(&self, g: &Geo) -> f64 {
        (0..3).fold(self.x_feed, |x, i| {
            let k = g.k[i].abs();
            if k > 0.0 {
                x.min(self.acc[i] / k)
            } else {
                x
            }
        })
    }
    /// The tangential accelerations `(lowest, highest)` that keep every axis within its
    /// limit at speed `x` on `g`.
    fn u_range(&self, g: &Geo, x: f64) -> (f64, f64) {
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        for i in 0..3 {
            let ti = g.t[i];
            if ti.abs() < 1e-12 {
                continue;
            }
            let n = x * g.k[i];
            let (a, b) = ((-self.acc[i] - n) / ti, (self.acc[i] - n) / ti);
            let (l, h) = if ti > 0.0 { (a, b) } else { (b, a) };
            lo = lo.max(l);
            hi = hi.min(h);
        }
        (lo.min(0.0), hi.max(0.0))
    }
    /// The backward pass: `x` below `cap` at a sample `ds` before one at `next` on
    /// `g_next`, from which the machine can still slow down to it.
    fn back_step(&self, g_next: &Geo, ds: f64, cap: f64, next: f64) -> f64 {
        let (lo, _) = self.u_range(g_next, next);
        cap.min(next - 2.0 * ds * lo)
    }
    /// The forward pass: `x` below the backward limit `xb` at a sample `ds` after one at
    /// `prev` on `g_prev`, as far as the machine can speed up from it.
    fn fwd_step(&self, g_prev: &Geo, ds: f64, xb: f64, prev: f64) -> f64 {
        let (_, hi) = self.u_range(g_prev, prev);
        xb.min(prev + 2.0 * ds * hi)
    }
    /// The time (s) along samples `g` with chord lengths `ds`, entering at `x0` and
    /// leaving at `x1` (at most); `x` is scratch.
    #[cfg(test)]
    fn time(&self, g: &[Geo], ds: &[f64], x0: f64, x1: f64, x: &mut Vec<f64>) -> f64 {
        self.profile(g, ds, x0, x1, x);
        ds.iter()
            .zip(x.windows(2))
            .map(|(d, w)| dt(*d, w[0], w[1]))
            .sum()
    }
    /// The speed profile (`x = v^2` per sample) into `x`.
    fn profile(&self, g: &[Geo], ds: &[f64], x0: f64, x1: f64, x: &mut Vec<f64>) {
        let n = g.len();
        x.clear();
        x.extend(g.iter().map(|g| self.cap(g)));
        x[0] = x[0].min(x0);
        x[n - 1] = x[n - 1].min(x1);
        for k in (0..n - 1).rev() {
            x[k] = self.back_step(&g[k + 1], ds[k], x[k], x[k + 1]);
        }
        for k in 1..n {
            x[k] = self.fwd_step(&g[k - 1], ds[k - 1], x[k], x[k - 1]);
        }
    }
}

/// The whole curve's speed profile: `(parameters, x)` every [`PROFILE_STEP_MM`].
fn whole_profile(c: &Nurbs, m: &Model) -> (Vec<f64>, Vec<f64>) {
    let (a, b) = c.domain();
    let n = (((b - a) / PROFILE_STEP_MM).ceil() as usize).max(2);
    let v: Vec<f64> = (0..=n).map(|i| a + (b - a) * i as f64 / n as f64).collect();
    let g: Vec<Geo> = v
        .iter()
        .map(|&u| Geo::from_ders(c.ders_at_param(u)))
        .collect();
    let ds: Vec<f64> = g.windows(2).map(|w| w[0].p.dist(w[1].p)).collect();
    let mut x = Vec::new();
    m.profile(&g, &ds, f64::INFINITY, f64::INFINITY, &mut x);
    (v, x)
}

/// The spots: parameters of local speed minima below `x_slow`, slowest first, more than
/// `min_gap` apart (a minimum closer to a slower one is left to that one's shaping).
fn spots(v: &[f64], x: &[f64], x_slow: f64, min_gap: f64) -> Vec<(f64, f64)> {
    let mut m: Vec<(f64, f64)> = (1..x.len() - 1)
        .filter(|&i| x[i] < x_slow && x[i] <= x[i - 1] && x[i] < x[i + 1])
        .map(|i| (v[i], x[i]))
        .collect();
    m.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut out: Vec<(f64, f64)> = Vec::new();
    for s in m {
        if out.iter().all(|o| (o.0 - s.0).abs() > min_gap) {
            out.push(s);
        }
    }
    out
}

/// One spot's optimisation problem.
struct Window<'a> {
    model: Model,
    /// Control points of the whole (refined) curve; the free ones change.
    ctrl: Vec<Vec3>,
    /// Free control points and their coordinates: `(index, axis)`.
    vars: Vec<(usize, usize)>,
    /// Per sample: first control point index and the basis with derivatives.
    basis: Vec<(usize, [[f64; 4]; 3])>,
    params: Vec<f64>,
    /// Sample range each control point influences.
    reach: Vec<(usize, usize)>,
    /// Samples whose geometry can change: `lo..hi`.
    live: (usize, usize),
    x_in: f64,
    x_out: f64,
    band: Band<'a>,
    /// Vertices in reach of the live samples, with the sample range searched for each.
    verts: Vec<(usize, usize, usize)>,
    geo: Vec<Geo>,
    ds: Vec<f64>,
    /// The objective's parts at the control points of the last full evaluation.
    cache: Cache,
}

/// What a full evaluation leaves for the incremental ones: per sample the speed cap, the
/// backward and the final profile, per interval its time, per live sample and vertex its
/// penalty term, and the totals.
#[derive(Default)]
struct Cache {
    cap: Vec<f64>,
    xb: Vec<f64>,
    x: Vec<f64>,
    dt: Vec<f64>,
    pen_s: Vec<f64>,
    pen_v: Vec<f64>,
    time: f64,
    pen: f64,
}

/// Time of one interval of length `ds` between speeds `sqrt(xa)` and `sqrt(xb)`.
fn dt(ds: f64, xa: f64, xb: f64) -> f64 {
    2.0 * ds / (xa.sqrt() + xb.sqrt()).max(1e-9)
}

impl<'a> Window<'a> {
    fn geo_at(&self, k: usize) -> Geo {
        let (first, b) = &self.basis[k];
        let mut d = [Vec3::ZERO; 3];
        for (m, dm) in d.iter_mut().enumerate() {
            for i in 0..4 {
                *dm += self.ctrl[first + i] * b[m][i];
            }
        }
        Geo::from_ders(d)
    }
    fn refresh(&mut self, lo: usize, hi: usize) {
        for k in lo..hi {
            self.geo[k] = self.geo_at(k);
        }
        for k in lo.saturating_sub(1)..hi.min(self.ds.len()) {
            self.ds[k] = self.geo[k].p.dist(self.geo[k + 1].p);
        }
    }
    /// The speed cap at sample `k`, the window's entry and exit speeds included.
    fn cap_at(&self, k: usize) -> f64 {
        let c = self.model.cap(&self.geo[k]);
        if k == 0 {
            c.min(self.x_in)
        } else if k + 1 == self.geo.len() {
            c.min(self.x_out)
        } else {
            c
        }
    }
    /// The penalty term `(excess / r)^2` of live sample `k` (distance to the polyline).
    fn sample_pen(&self, k: usize) -> f64 {
        let Band { pts, u, r, .. } = self.band;
        let q = self.geo[k].p;
        let c = u.partition_point(|&w| w <= self.params[k]).max(1) - 1;
        let (lo, hi) = (c.saturating_sub(2), (c + 3).min(pts.len() - 1));
        let d = (lo..hi)
            .map(|j| Line::new(pts[j], pts[j + 1]).dist_sq(q))
            .fold(f64::INFINITY, f64::min)
            .sqrt();
        excess(d, r)
    }
    /// The penalty term of window vertex `vi` (its distance to the sampled curve).
    fn vertex_pen(&self, vi: usize) -> f64 {
        let (i, lo, hi) = self.verts[vi];
        let p = self.band.pts[i];
        let d = (lo..hi)
            .map(|k| self.geo[k].p.dist_sq(p))
            .fold(f64::INFINITY, f64::min)
            .sqrt();
        excess(d, self.band.r)
    }
    /// Evaluates everything at the current control points into the cache; the objective
    /// at penalty weight `w`.
    fn objective(&mut self, w: f64) -> f64 {
        let n = self.geo.len();
        let mut c = std::mem::take(&mut self.cache);
        c.cap = (0..n).map(|k| self.cap_at(k)).collect();
        c.xb = c.cap.clone();
        for k in (0..n - 1).rev() {
            c.xb[k] = self.back_step(k, c.cap[k], c.xb[k + 1]);
        }
        c.x = c.xb.clone();
        for k in 1..n {
            c.x[k] = self.fwd_step(k, c.xb[k], c.x[k - 1]);
        }
        c.dt = (0..n - 1)
            .map(|k| dt(self.ds[k], c.x[k], c.x[k + 1]))
            .collect();
        c.time = c.dt.iter().sum();
        c.pen_s = (self.live.0..self.live.1)
            .map(|k| self.sample_pen(k))
            .collect();
        c.pen_v = (0..self.verts.len()).map(|v| self.vertex_pen(v)).collect();
        c.pen = c.pen_s.iter().sum::<f64>() + c.pen_v.iter().sum::<f64>();
        let f = c.time + w * c.pen;
        self.cache = c;
        f
    }
    /// The backward pass at sample `k` below its cap, from `next` at `k + 1`.
    fn back_step(&self, k: usize, cap: f64, next: f64) -> f64 {
        self.model
            .back_step(&self.geo[k + 1], self.ds[k], cap, next)
    }
    /// The forward pass at sample `k` below its backward limit, from `prev` at `k - 1`.
    fn fwd_step(&self, k: usize, xb: f64, prev: f64) -> f64 {
        self.model
            .fwd_step(&self.geo[k - 1], self.ds[k - 1], xb, prev)
    }
    /// The objective at weight `w` after the geometry of samples `lo..hi` changed since
    /// the last full evaluation (the cache), without updating it: the passes are redone
    /// only until they meet the cached profile again, which on a short change they do
    /// within a few samples unless it moves the slowest point.
    fn changed_objective(&self, w: f64, lo: usize, hi: usize) -> f64 {
        let c = &self.cache;
        let n = self.geo.len();
        let top = hi.min(n);
        // Backward: new values at indices kb..top, stored top-down.
        let mut xb_new: Vec<f64> = Vec::with_capacity(top - lo + 8);
        let mut k = top;
        while k > 0 {
            k -= 1;
            let cap = if k >= lo { self.cap_at(k) } else { c.cap[k] };
            let v = if k + 1 < n {
                let next = xb_new.last().copied().unwrap_or(c.xb[k + 1]);
                self.back_step(k, cap, next)
            } else {
                cap
            };
            if k + 2 <= lo && v == c.xb[k] {
                k += 1;
                break;
            }
            xb_new.push(v);
        }
        let kb = k;
        let xb_at = |k: usize| {
            if k >= kb && k < top {
                xb_new[top - 1 - k]
            } else {
                c.xb[k]
            }
        };
        // Forward from kb until it meets the cached profile beyond the change.
        let mut x_new: Vec<f64> = Vec::with_capacity(top - kb + 8);
        let mut k = kb;
        while k < n {
            let v = if k == 0 {
                xb_at(0)
            } else {
                let prev = if k > kb {
                    x_new[k - kb - 1]
                } else {
                    c.x[k - 1]
                };
                self.fwd_step(k, xb_at(k), prev)
            };
            if k > top && v == c.x[k] {
                break;
            }
            x_new.push(v);
            k += 1;
        }
        let kf = kb + x_new.len();
        let x_at = |k: usize| {
            if k >= kb && k < kf {
                x_new[k - kb]
            } else {
                c.x[k]
            }
        };
        let (i0, i1) = (kb.saturating_sub(1), kf.min(n - 1));
        let mut time = c.time;
        for i in i0..i1 {
            time += dt(self.ds[i], x_at(i), x_at(i + 1)) - c.dt[i];
        }
        let mut pen = c.pen;
        let (la, lb) = (lo.max(self.live.0), hi.min(self.live.1));
        for k in la..lb {
            pen += self.sample_pen(k) - c.pen_s[k - self.live.0];
        }
        for (vi, &(_, a, b)) in self.verts.iter().enumerate() {
            if a < hi && lo < b {
                pen += self.vertex_pen(vi) - c.pen_v[vi];
            }
        }
        time + w * pen
    }
    fn get(&self) -> Vec<f64> {
        self.vars.iter().map(|&(j, a)| self.ctrl[j][a]).collect()
    }
    fn set(&mut self, z: &[f64]) {
        for (&(j, a), &v) in self.vars.iter().zip(z) {
            let mut c = self.ctrl[j].to_array();
            c[a] = v;
            self.ctrl[j] = Vec3::from_array(c);
        }
        let (lo, hi) = self.live;
        self.refresh(lo, hi);
    }
    /// Moves variable `vi` by `step` (mm) and refreshes the samples it reaches: the
    /// objective at `w` after the move (the cache left as it was) and the control point
    /// before it, for [`Window::restore`].
    fn nudge(&mut self, vi: usize, step: f64, w: f64) -> (f64, Vec3) {
        let (j, a) = self.vars[vi];
        let old = self.ctrl[j];
        let mut c = old.to_array();
        c[a] += step;
        self.ctrl[j] = Vec3::from_array(c);
        let (lo, hi) = self.reach[j];
        self.refresh(lo, hi);
        (self.changed_objective(w, lo, hi), old)
    }
    /// Puts back the control point of variable `vi` that [`Window::nudge`] moved.
    fn restore(&mut self, vi: usize, old: Vec3) {
        let j = self.vars[vi].0;
        self.ctrl[j] = old;
        let (lo, hi) = self.reach[j];
        self.refresh(lo, hi);
    }
    /// Objective and its forward-difference gradient at the current control points.
    fn grad(&mut self, w: f64) -> (f64, Vec<f64>) {
        let f0 = self.objective(w);
        let mut g = Vec::with_capacity(self.vars.len());
        for vi in 0..self.vars.len() {
            let (f, old) = self.nudge(vi, FD_STEP_MM, w);
            g.push((f - f0) / FD_STEP_MM);
            self.restore(vi, old);
        }
        (f0, g)
    }
}

/// `((d - r') / r')^2` beyond `r' = r * `[`PENALTY_BAND_SHARE`], zero inside.
fn excess(d: f64, r: f64) -> f64 {
    let r = r * PENALTY_BAND_SHARE;
    ((d - r).max(0.0) / r).powi(2)
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// L-BFGS on the window's objective at weight `w`, from its current control points.
fn lbfgs(win: &mut Window<'_>, w: f64, iters: usize) {
    let mut z = win.get();
    let (mut f, mut g) = win.grad(w);
    let mut hist: Vec<(Vec<f64>, Vec<f64>, f64)> = Vec::new();
    let mut flat = 0;
    for _ in 0..iters {
        // Two-loop recursion.
        let mut q = g.clone();
        let mut alphas = Vec::with_capacity(hist.len());
        for (s, y, rho) in hist.iter().rev() {
            let a = rho * dot(s, &q);
            q.iter_mut().zip(y).for_each(|(qi, yi)| *qi -= a * yi);
            alphas.push(a);
        }
        let gamma = hist
            .last()
            .map(|(s, y, _)| dot(s, y) / dot(y, y))
            .unwrap_or_else(|| 1e-4 / g.iter().fold(0.0, |m: f64, v| m.max(v.abs())).max(1e-30));
        q.iter_mut().for_each(|v| *v *= gamma);
        for ((s, y, rho), a) in hist.iter().zip(alphas.iter().rev()) {
            let b = rho * dot(y, &q);
            q.iter_mut().zip(s).for_each(|(qi, si)| *qi += (a - b) * si);
        }
        let dir: Vec<f64> = q.iter().map(|v| -v).collect();
        let slope = dot(&g, &dir);
        if slope.is_nan() || slope >= 0.0 {
            // Not a descent direction: restart from steepest descent, or stop there.
            if hist.is_empty() {
                break;
            }
            hist.clear();
            continue;
        }
        // Armijo backtracking.
        let mut step = 1.0;
        let mut accepted = None;
        for _ in 0..30 {
            let zn: Vec<f64> = z.iter().zip(&dir).map(|(a, d)| a + step * d).collect();
            win.set(&zn);
            let fnew = win.objective(w);
            if fnew <= f + 1e-4 * step * slope {
                accepted = Some((zn, fnew));
                break;
            }
            step *= 0.5;
        }
        let Some((zn, _)) = accepted else {
            win.set(&z);
            if hist.is_empty() {
                break;
            }
            hist.clear();
            continue;
        };
        let (fn_, gn) = win.grad(w);
        let s: Vec<f64> = zn.iter().zip(&z).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = gn.iter().zip(&g).map(|(a, b)| a - b).collect();
        let sy = dot(&s, &y);
        if sy > 1e-16 {
            hist.push((s, y, 1.0 / sy));
            if hist.len() > LBFGS_MEMORY {
                hist.remove(0);
            }
        }
        flat = if (f - fn_).abs() < FLAT_S {
            flat + 1
        } else {
            0
        };
        let done = flat >= FLAT_PATIENCE;
        z = zn;
        f = fn_;
        g = gn;
        if done {
            break;
        }
    }
    win.set(&z);
}

/// Coordinate sweeps at shrinking steps [`PATTERN_STEPS_MM`]: each variable moved by
/// `+-step` where that lowers the objective at weight `w` (what a gradient method misses
/// at the kinks of the speed model, where another sample's cap takes over).
fn pattern(win: &mut Window<'_>, w: f64) {
    let mut f = win.objective(w);
    for step in PATTERN_STEPS_MM {
        for vi in 0..win.vars.len() {
            for sgn in [1.0, -1.0] {
                let (fnew, old) = win.nudge(vi, sgn * step, w);
                if fnew < f {
                    f = win.objective(w);
                    break;
                }
                win.restore(vi, old);
            }
        }
    }
}

/// Which control points may move: not the ends the end conditions fix.
fn fixed_count(c: EndCond) -> usize {
    match c {
        EndCond::Line(_) => 3,
        EndCond::Free => 1,
    }
}

/// The curve `c` (knot parameter = the run's chord length `u`, mm) reshaped for time at
/// its slow spots within `o.band_share * tol_mm` of the run's polyline `pts` and within
/// `tol_mm` measured (`accuracy`); `None` when no spot gained. Returns the curve, its measured
/// deviation and the model time gained (s). The spots are shaped in parallel, each from
/// `c` alone, their moved control points then merged (their supports are apart).
#[allow(clippy::too_many_arguments)]
pub(crate) fn time_shape(
    c: &Nurbs,
    pts: &[Vec3],
    u: &[f64],
    start: EndCond,
    end: EndCond,
    tol_mm: f64,
    accuracy: f64,
    o: &TimeShapeOptions,
) -> Option<(Nurbs, f64, f64)> {
    let model = Model::new(o);
    let (v, x) = whole_profile(c, &model);
    let x_slow = (o.slow_share * o.limits.feed_mm_s).powi(2);
    // Twice the distance that keeps two spots' moved control points (their supports
    // reaching 4 dense spans beyond the free part) apart: the spacing the figures in
    // this module's docs were measured with.
    let min_gap = 2.0 * (2.0 * o.free_half_mm + 8.0 * o.dense_span_mm);
    let found = spots(&v, &x, x_slow, min_gap);
    if found.is_empty() {
        return None;
    }
    let refined = found
        .iter()
        .fold(c.clone(), |c, &(spot, _)| dense_knots(&c, spot, o));
    let band = Band {
        pts,
        u,
        r: o.band_share * tol_mm,
        tol_mm,
        accuracy,
    };
    let shaped = crate::par::map(found.len(), 2, |i| {
        let spot = found[i].0;
        let ends = (
            x_at(&v, &x, spot - o.window_mm),
            x_at(&v, &x, spot + o.window_mm),
        );
        let win = Window::new(&refined, spot, ends, band, (start, end), o, model)?;
        shape_spot(win, &refined, o)
    });
    let mut ctrl = refined.ctrl().to_vec();
    let mut gained = 0.0;
    for (moved, gain) in shaped.into_iter().flatten() {
        for (j, p) in moved {
            ctrl[j] = p;
        }
        gained += gain;
    }
    if gained <= 0.0 {
        return None;
    }
    let curve = Nurbs::bspline(3, ctrl, refined.knots().to_vec())?;
    let dev = measured(&curve, &band)?;
    Some((curve, dev, gained))
}

/// The profile's `x` at parameter `s` (nearest sample, clamped to the curve).
fn x_at(v: &[f64], x: &[f64], s: f64) -> f64 {
    let i = ((s - v[0]) / PROFILE_STEP_MM).round();
    x[i.clamp(0.0, (x.len() - 1) as f64) as usize]
}

/// The run's band: its polyline `pts` at parameters `u`, the fit's radius `r`, the
/// tolerance and the accuracy of the final measurement (mm).
#[derive(Clone, Copy)]
struct Band<'a> {
    pts: &'a [Vec3],
    u: &'a [f64],
    r: f64,
    tol_mm: f64,
    accuracy: f64,
}

/// The deviation of `c` from the band's polyline, measured; `None` unless within the
/// tolerance less the accuracy.
fn measured(c: &Nurbs, band: &Band<'_>) -> Option<f64> {
    let seg = Segment::Nurbs(Box::new(c.clone()));
    let dm = polyline_deviation(&[(&seg, 0)], band.pts, band.accuracy).max_mm();
    (dm.is_finite() && dm + band.accuracy <= band.tol_mm).then_some(dm)
}

/// `c` with knots inserted so that no span within `free_half` of `spot` is longer than
/// `dense_span` (the same curve).
fn dense_knots(c: &Nurbs, spot: f64, o: &TimeShapeOptions) -> Nurbs {
    let (fa, fb) = (spot - o.free_half_mm, spot + o.free_half_mm);
    let mut out = c.clone();
    let mut k = c.knots().to_vec();
    k.dedup();
    for w in k.windows(2) {
        let (a, b) = (
            w[0].max(fa - o.dense_span_mm),
            w[1].min(fb + o.dense_span_mm),
        );
        if b <= a {
            continue;
        }
        let n = ((w[1] - w[0]) / o.dense_span_mm).ceil() as usize;
        for i in 1..n {
            let t = w[0] + (w[1] - w[0]) * i as f64 / n as f64;
            if t > a && t < b {
                out = out.insert_knot(t, 1);
            }
        }
    }
    out
}

/// One spot's problem `win` on the (refined) curve `c` solved: the moved control points
/// and the model time gained, when the reshaped curve measures within the tolerance (see
/// the module doc, steps 4 and 5).
fn shape_spot(
    mut win: Window<'_>,
    c: &Nurbs,
    o: &TimeShapeOptions,
) -> Option<(Vec<(usize, Vec3)>, f64)> {
    let t0 = {
        win.objective(0.0);
        win.cache.time
    };
    for w in PENALTY_WEIGHTS {
        lbfgs(&mut win, w, o.max_iters);
    }
    let w_last = PENALTY_WEIGHTS[PENALTY_WEIGHTS.len() - 1];
    for _ in 0..o.polish_rounds {
        pattern(&mut win, w_last);
        lbfgs(&mut win, w_last, o.max_iters);
    }
    win.objective(0.0);
    let gain = t0 - win.cache.time;
    if gain.is_nan() || gain < MIN_GAIN_S {
        return None;
    }
    let moved: Vec<(usize, Vec3)> = win.free().map(|j| (j, win.ctrl[j])).collect();
    let mut ctrl = c.ctrl().to_vec();
    for &(j, p) in &moved {
        ctrl[j] = p;
    }
    let shaped = Nurbs::bspline(3, ctrl, c.knots().to_vec())?;
    measured(&shaped, &win.band)?;
    let knots = c.knots();
    let (first, last) = (win.vars.first()?.0, win.vars.last()?.0);
    let (a, b) = (knots[first], knots[last + 4]);
    let (turn0, speed0) = tangent_check(c, a, b);
    let (turn1, speed1) = tangent_check(&shaped, a, b);
    (turn1 <= turn0 + MAX_EXTRA_TURN_RAD && speed1 >= MIN_SPEED_SHARE * speed0)
        .then_some((moved, gain))
}

/// The sample parameters of a window `[a, b]`: every `step`, and also
/// [`SPAN_SAMPLES_SHORT`] inside every knot span shorter than two steps (quantised
/// programs have spans of a tenth of a micrometre, inside which the optimiser could
/// otherwise tie a loop that no sample sees).
fn window_params(knots: &[f64], a: f64, b: f64, step: f64) -> Vec<f64> {
    let n = (((b - a) / step).ceil() as usize).max(2);
    let mut v: Vec<f64> = (0..=n).map(|i| a + (b - a) * i as f64 / n as f64).collect();
    for w in knots.windows(2) {
        let (lo, hi) = (w[0].max(a), w[1].min(b));
        if hi > lo && w[1] - w[0] < 2.0 * step {
            let m = SPAN_SAMPLES_SHORT + 1;
            v.extend((0..=m).map(|i| lo + (hi - lo) * i as f64 / m as f64));
        }
    }
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

/// The total turn (rad) of the unit tangent of `c` over `[a, b]` and the least
/// parametric speed `|C'|` there, on [`TURN_SAMPLES_PER_SPAN`] samples per knot span
/// (so that no span is skipped however short).
fn tangent_check(c: &Nurbs, a: f64, b: f64) -> (f64, f64) {
    let mut k: Vec<f64> = c
        .knots()
        .iter()
        .copied()
        .filter(|&t| t > a && t < b)
        .collect();
    k.insert(0, a);
    k.push(b);
    k.dedup();
    let mut prev: Option<Vec3> = None;
    let (mut turn, mut speed) = (0.0, f64::INFINITY);
    for w in k.windows(2) {
        for i in 0..=TURN_SAMPLES_PER_SPAN {
            let t = w[0] + (w[1] - w[0]) * i as f64 / TURN_SAMPLES_PER_SPAN as f64;
            let d = c.ders_at_param(t)[1];
            speed = speed.min(d.norm());
            let Some(d) = d.normalized() else {
                return (f64::INFINITY, 0.0);
            };
            if let Some(p) = prev {
                turn += p.angle_to(d);
            }
            prev = Some(d);
        }
    }
    (turn, speed)
}

impl<'a> Window<'a> {
    /// The problem of `spot` on `c`, entering and leaving the modelled window at `ends`
    /// (`x`), the run's end conditions `conds` (module doc, step 3); `None` when no
    /// control point is free there.
    fn new(
        c: &Nurbs,
        spot: f64,
        ends: (f64, f64),
        band: Band<'a>,
        conds: (EndCond, EndCond),
        o: &TimeShapeOptions,
        model: Model,
    ) -> Option<Window<'a>> {
        let (da, db) = c.domain();
        let (fa, fb) = (spot - o.free_half_mm, spot + o.free_half_mm);
        let knots = c.knots();
        let m = c.ctrl().len();
        let (f0, f1) = (fixed_count(conds.0), m - fixed_count(conds.1));
        let free: Vec<usize> = (f0..f1)
            .filter(|&j| {
                let g = (knots[j + 1] + knots[j + 2] + knots[j + 3]) / 3.0;
                g >= fa && g <= fb
            })
            .collect();
        let pts = band.pts;
        let axes: Vec<usize> = (0..3)
            .filter(|&a| pts.iter().any(|p| (p[a] - pts[0][a]).abs() > 1e-12))
            .collect();
        let (wa, wb) = ((spot - o.window_mm).max(da), (spot + o.window_mm).min(db));
        let params = window_params(knots, wa, wb, o.sample_mm);
        let n = params.len() - 1;
        let basis = params
            .iter()
            .map(|&p| {
                let s = c.find_span(p);
                let d = c.ders_basis(s, p, 2);
                (
                    s - 3,
                    [0, 1, 2].map(|m| [d[m][0], d[m][1], d[m][2], d[m][3]]),
                )
            })
            .collect();
        let range = |a: f64, b: f64| {
            (
                params.partition_point(|&p| p < a),
                params.partition_point(|&p| p <= b),
            )
        };
        let reach: Vec<(usize, usize)> = (0..m).map(|j| range(knots[j], knots[j + 4])).collect();
        let live = (reach[*free.first()?].0, reach[*free.last()?].1);
        let (la, lb) = (params[live.0.min(n)], params[(live.1.max(1) - 1).min(n)]);
        let verts = (0..pts.len())
            .filter(|&i| {
                let ui = band.u[i];
                ui >= la - o.dense_span_mm && ui <= lb + o.dense_span_mm
            })
            .map(|i| {
                let (lo, hi) = range(band.u[i] - VERTEX_REACH_MM, band.u[i] + VERTEX_REACH_MM);
                (i, lo, hi)
            })
            .filter(|v| v.2 > v.1)
            .collect();
        let mut win = Window {
            model,
            ctrl: c.ctrl().to_vec(),
            vars: free
                .iter()
                .flat_map(|&j| axes.iter().map(move |&a| (j, a)))
                .collect(),
            basis,
            params,
            reach,
            live,
            x_in: ends.0,
            x_out: ends.1,
            band,
            verts,
            geo: vec![Geo::default(); n + 1],
            ds: vec![0.0; n],
            cache: Cache::default(),
        };
        win.refresh(0, n + 1);
        Some(win)
    }
    /// The free control points, in order.
    fn free(&self) -> impl Iterator<Item = usize> + '_ {
        let mut last = usize::MAX;
        self.vars.iter().filter_map(move |&(j, _)| {
            let new = j != last;
            last = j;
            new.then_some(j)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::ParamCurve;
    use crate::smooth::band_fit::{band_fit, BandFitOptions};

    /// Samples of `c` every `h` (parameter) and their chord lengths.
    fn samples(c: &Nurbs, h: f64) -> (Vec<Geo>, Vec<f64>) {
        let (a, b) = c.domain();
        let n = ((b - a) / h).ceil() as usize;
        let g: Vec<Geo> = (0..=n)
            .map(|i| Geo::from_ders(c.ders_at_param(a + (b - a) * i as f64 / n as f64)))
            .collect();
        let ds = g.windows(2).map(|w| w[0].p.dist(w[1].p)).collect();
        (g, ds)
    }

    fn limits() -> TimeShapeOptions {
        TimeShapeOptions::new(TimeLimits {
            feed_mm_s: 50.0,
            acc_mm_s2: [500.0; 3],
        })
    }

    #[test]
    fn model_gives_the_trapezoid_on_a_line_and_the_cap_on_a_circle() {
        // 10 mm along X from rest to rest at 50 mm/s, 500 mm/s^2 (x 0.99): L/V + V/A.
        let o = limits();
        let m = Model::new(&o);
        let line = Nurbs::bspline(
            3,
            (0..4)
                .map(|i| Vec3::new(10.0 * i as f64 / 3.0, 0.0, 0.0))
                .collect(),
            vec![0.0, 0.0, 0.0, 0.0, 10.0, 10.0, 10.0, 10.0],
        )
        .unwrap();
        let (g, ds) = samples(&line, 0.001);
        let t = m.time(&g, &ds, 0.0, 0.0, &mut Vec::new());
        let want = 10.0 / 50.0 + 50.0 / (500.0 * 0.99);
        assert!((t - want).abs() < 1e-3, "{t} {want}");
        // Curvature 1/R along Y only (at the apex of a circle of R 0.5): v = sqrt(A R).
        let g = Geo {
            p: Vec3::ZERO,
            t: Vec3::X,
            k: Vec3::new(0.0, 2.0, 0.0),
        };
        assert!((m.cap(&g) - 500.0 * 0.99 * 0.5).abs() < 1e-9);
    }

    /// A near-cusp as on butterfly_1000: a 6 mm line, a 60 degree turn, 0.25 mm, a 90
    /// degree turn, a 6 mm line, sampled every 0.3 mm.
    fn near_cusp() -> (Vec<Vec3>, Vec3, Vec3) {
        let d0 = Vec3::X;
        let d1 = Vec3::new(0.5, 0.75f64.sqrt(), 0.0);
        let d2 = Vec3::new(-(0.75f64.sqrt()), 0.5, 0.0);
        let mut pts: Vec<Vec3> = (0..=20).map(|i| d0 * (0.3 * i as f64 - 6.0)).collect();
        let v2 = d1 * 0.25;
        pts.push(v2);
        pts.extend((1..=20).map(|i| v2 + d2 * (0.3 * i as f64)));
        (pts, d0, d2)
    }

    #[test]
    fn a_near_cusp_gets_faster_inside_the_band() {
        let (pts, d0, d2) = near_cusp();
        let tol = 0.01;
        let fit = |shape: Option<TimeShapeOptions>| {
            let o = BandFitOptions {
                time_shape: shape,
                ..Default::default()
            };
            band_fit(
                &pts,
                EndCond::Line(d0),
                EndCond::Line(d2),
                tol,
                tol * 0.02,
                &o,
            )
            .expect("fits")
        };
        let mut o = limits();
        o.polish_rounds = 1;
        let (plain, shaped) = (fit(None), fit(Some(o.clone())));
        assert!(shaped.deviation_mm <= tol, "{}", shaped.deviation_mm);
        let m = Model::new(&o);
        let time = |c: &Nurbs| {
            let (g, ds) = samples(c, 0.5e-3);
            m.time(&g, &ds, 0.0, 0.0, &mut Vec::new())
        };
        let (t0, t1) = (time(&plain.curve), time(&shaped.curve));
        // The spot's share of the time falls by a few milliseconds (0.6 ms needed).
        assert!(t1 < t0 - 6e-4, "{t0} -> {t1}");
        // Same ends, same end tangents: the shaping moved only the spot's control points.
        assert_eq!(plain.curve.start(), shaped.curve.start());
        assert_eq!(plain.curve.end(), shaped.curve.end());
    }

    #[test]
    fn incremental_objective_equals_the_full_one() {
        let (pts, d0, d2) = near_cusp();
        let tol = 0.01;
        let fit = band_fit(
            &pts,
            EndCond::Line(d0),
            EndCond::Line(d2),
            tol,
            tol * 0.02,
            &BandFitOptions::default(),
        )
        .expect("fits");
        // Back to the chord-length parameter, as band_fit hands it to the shaping.
        let mut u = vec![0.0];
        for w in pts.windows(2) {
            u.push(u[u.len() - 1] + w[0].dist(w[1]));
        }
        let len = u[u.len() - 1];
        let c = &fit.curve;
        let knots = c.knots().iter().map(|k| k * len).collect();
        let c = Nurbs::bspline(3, c.ctrl().to_vec(), knots).unwrap();
        let o = limits();
        let spot = u[21] - 0.1;
        let c = dense_knots(&c, spot, &o);
        let band = Band {
            pts: &pts,
            u: &u,
            r: 0.0095,
            tol_mm: tol,
            accuracy: tol * 0.02,
        };
        let conds = (EndCond::Line(d0), EndCond::Line(d2));
        let mut win = Window::new(&c, spot, (2500.0, 2500.0), band, conds, &o, Model::new(&o))
            .expect("free points");
        assert!(win.vars.len() > 20);
        let mut moved = 0;
        for (vi, step) in [(0, 1e-3), (5, -4e-3), (11, 6e-3), (17, 2e-3), (23, -1e-3)] {
            let w = 1e3;
            let before = win.objective(w);
            let (inc, old) = win.nudge(vi, step, w);
            let full = win.objective(w);
            assert!((inc - full).abs() < 1e-12, "var {vi}: {inc} {full}");
            moved += usize::from((full - before).abs() > 1e-9);
            win.restore(vi, old);
            // A move that stays kept, so the next one starts elsewhere.
            win.nudge(vi, step * 0.5, w);
        }
        // The moves changed the objective (time or penalty), not only the bookkeeping.
        assert!(moved >= 4, "{moved}");
    }

    #[test]
    fn a_loop_or_a_cusp_fails_the_tangent_check_and_short_spans_are_sampled() {
        let bez = |p: [(f64, f64); 4]| {
            let ctrl = p.iter().map(|&(x, y)| Vec3::new(x, y, 0.0)).collect();
            Nurbs::bspline(3, ctrl, vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0]).unwrap()
        };
        let arch = bez([(0.0, 0.0), (0.7, 1.0), (1.3, 1.0), (2.0, 0.0)]);
        let looped = bez([(0.0, 0.0), (3.0, 1.0), (-1.0, 1.0), (2.0, 0.0)]);
        let cusp = bez([(0.0, 0.0), (2.0, 1.0), (0.0, 1.0), (2.0, 0.0)]);
        let (t0, s0) = tangent_check(&arch, 0.0, 1.0);
        let (t1, _) = tangent_check(&looped, 0.0, 1.0);
        let (t2, s2) = tangent_check(&cusp, 0.0, 1.0);
        assert!(t0 < 2.0 && s0 > 1.0, "{t0} {s0}");
        assert!(t1 > t0 + MAX_EXTRA_TURN_RAD, "loop: {t1} against {t0}");
        // The cusp's speed vanishes at t = 1/2 (or nearly, between samples).
        assert!(
            t2 > t0 + MAX_EXTRA_TURN_RAD || s2 < MIN_SPEED_SHARE * s0,
            "{t2} {s2}"
        );
        // A span of 0.1 um inside a window sampled every 2 um gets samples of its own.
        let knots = [0.0, 0.0, 0.0, 0.0, 1.0, 1.0 + 1e-7, 2.0, 2.0, 2.0, 2.0];
        let v = window_params(&knots, 0.5, 1.5, 0.002);
        let inside = v.iter().filter(|&&t| t > 1.0 && t < 1.0 + 1e-7).count();
        assert_eq!(inside, SPAN_SAMPLES_SHORT);
    }
}
