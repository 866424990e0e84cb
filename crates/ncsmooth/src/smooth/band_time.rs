//! Time shaping of a run's band fit at its slow spots (issue 17): where the machine has to
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
//! (`scripts/band_time_study.py` measured up to 7 ms per spot at 50 mm/s, 500 mm/s^2).
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
//!    [`TimeShapeOptions::slow_share`] of the feed, slowest first.
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
//!    gradients, for a rising sequence of weights [`PENALTY_WEIGHTS`].
//! 5. **Acceptance.** The reshaped curve is measured exactly against the run's polyline
//!    ([`deviation_segments`]); a window is kept only when the deviation is within the
//!    tolerance and the model time fell by at least [`MIN_GAIN_S`].
//!
//! ## Limits
//! The optimisation is local (a start at the band fit, a fixed knot layout); the model
//! ignores jerk and the period, and samples the band; the planner runs on the result as on
//! any curve, so what it plans is what counts (butterfly_1000, tol 0.01, 50 mm/s,
//! 500 mm/s^2: see the README). The cost is a few hundred model evaluations per variable
//! and spot, so it is off by default (`--time-shape` on the command line).

use super::band_fit::EndCond;
use crate::geom::{Line, Nurbs, Segment, Vec3};
use crate::verify::deviation_segments;

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
    /// Half-length (mm) of the reshaped part around a spot. Default 0.5 mm.
    pub free_half_mm: f64,
    /// Longest knot span (mm) in the reshaped part. Default 0.04 mm.
    pub dense_span_mm: f64,
    /// Sample spacing (mm, in the curve's chord-length parameter) of the model and of the
    /// band penalty. Default 0.002 mm.
    pub sample_mm: f64,
    /// L-BFGS iterations per penalty weight. Default 150.
    pub max_iters: usize,
    /// Rounds of coordinate sweeps, each followed by L-BFGS, at the last penalty weight.
    /// Default 4 (butterfly_1000: 8.643 s after 1 round, 8.641 after 2, 8.640 after 4).
    pub polish_rounds: usize,
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
            free_half_mm: 0.5,
            dense_span_mm: 0.04,
            sample_mm: 0.002,
            max_iters: 150,
            polish_rounds: 4,
        }
    }
}

/// The penalty weights, applied in turn (each stage starts where the last ended).
pub const PENALTY_WEIGHTS: [f64; 3] = [10.0, 1e3, 1e5];
/// Smallest model gain (s) for which a reshaped window is kept.
pub const MIN_GAIN_S: f64 = 1e-5;
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
    /// The time (s) along samples `g` with chord lengths `ds`, entering at `x0` and
    /// leaving at `x1` (at most); `x` is scratch.
    fn time(&self, g: &[Geo], ds: &[f64], x0: f64, x1: f64, x: &mut Vec<f64>) -> f64 {
        self.profile(g, ds, x0, x1, x);
        ds.iter()
            .zip(x.windows(2))
            .map(|(d, w)| 2.0 * d / (w[0].sqrt() + w[1].sqrt()).max(1e-9))
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
            let (lo, _) = self.u_range(&g[k + 1], x[k + 1]);
            x[k] = x[k].min(x[k + 1] - 2.0 * ds[k] * lo);
        }
        for k in 0..n - 1 {
            let (_, hi) = self.u_range(&g[k], x[k]);
            x[k + 1] = x[k + 1].min(x[k] + 2.0 * ds[k] * hi);
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

/// The spots: parameters of local speed minima below `x_slow`, slowest first, at least
/// `2 free_half` apart.
fn spots(v: &[f64], x: &[f64], x_slow: f64, free_half: f64) -> Vec<(f64, f64)> {
    let mut m: Vec<(f64, f64)> = (1..x.len() - 1)
        .filter(|&i| x[i] < x_slow && x[i] <= x[i - 1] && x[i] < x[i + 1])
        .map(|i| (v[i], x[i]))
        .collect();
    m.sort_by(|a, b| a.1.total_cmp(&b.1));
    let mut out: Vec<(f64, f64)> = Vec::new();
    for s in m {
        if out.iter().all(|o| (o.0 - s.0).abs() > 2.0 * free_half) {
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
    pts: &'a [Vec3],
    u: &'a [f64],
    /// Vertices in reach of the live samples, with the sample range searched for each.
    verts: Vec<(usize, usize, usize)>,
    r: f64,
    geo: Vec<Geo>,
    scratch: Vec<f64>,
    ds: Vec<f64>,
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
    fn time(&mut self) -> f64 {
        let mut x = std::mem::take(&mut self.scratch);
        let t = self
            .model
            .time(&self.geo, &self.ds, self.x_in, self.x_out, &mut x);
        self.scratch = x;
        t
    }
    /// `sum (excess / r)^2` over the live samples and the window's vertices.
    fn penalty(&self) -> f64 {
        let r = self.r * PENALTY_BAND_SHARE;
        let ex = |d: f64| ((d - r).max(0.0) / r).powi(2);
        let mut p = 0.0;
        for k in self.live.0..self.live.1 {
            let q = self.geo[k].p;
            let c = self.u.partition_point(|&w| w <= self.params[k]).max(1) - 1;
            let lo = c.saturating_sub(2);
            let hi = (c + 3).min(self.pts.len() - 1);
            let d = (lo..hi)
                .map(|j| seg_dist(q, self.pts[j], self.pts[j + 1]))
                .fold(f64::INFINITY, f64::min);
            p += ex(d);
        }
        for &(i, lo, hi) in &self.verts {
            let d = (lo..hi)
                .map(|k| self.geo[k].p.dist(self.pts[i]))
                .fold(f64::INFINITY, f64::min);
            p += ex(d);
        }
        p
    }
    fn objective(&mut self, w: f64) -> f64 {
        self.time() + w * self.penalty()
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
    /// Objective and its forward-difference gradient at the current control points.
    fn grad(&mut self, w: f64) -> (f64, Vec<f64>) {
        let f0 = self.objective(w);
        let mut g = Vec::with_capacity(self.vars.len());
        for vi in 0..self.vars.len() {
            let (j, a) = self.vars[vi];
            let (lo, hi) = self.reach[j];
            let old = self.ctrl[j];
            let mut c = old.to_array();
            c[a] += FD_STEP_MM;
            self.ctrl[j] = Vec3::from_array(c);
            self.refresh(lo, hi);
            g.push((self.objective(w) - f0) / FD_STEP_MM);
            self.ctrl[j] = old;
            self.refresh(lo, hi);
        }
        (f0, g)
    }
}

/// Distance from `q` to the segment `a b`.
fn seg_dist(q: Vec3, a: Vec3, b: Vec3) -> f64 {
    let d = b - a;
    let l2 = d.norm_sq();
    let t = if l2 > 0.0 {
        ((q - a).dot(d) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    q.dist(a + d * t)
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
            let (j, a) = win.vars[vi];
            let (lo, hi) = win.reach[j];
            let old = win.ctrl[j];
            for sgn in [1.0, -1.0] {
                let mut c = old.to_array();
                c[a] += sgn * step;
                win.ctrl[j] = Vec3::from_array(c);
                win.refresh(lo, hi);
                let fnew = win.objective(w);
                if fnew < f {
                    f = fnew;
                    break;
                }
                win.ctrl[j] = old;
                win.refresh(lo, hi);
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
/// its slow spots within `r` (mm) of the run's polyline `pts` and within `tol_mm`
/// measured (`accuracy`); `None` when no spot gained. Returns the curve, its measured
/// deviation and the model time gained (s).
#[allow(clippy::too_many_arguments)]
pub(crate) fn time_shape(
    c: &Nurbs,
    pts: &[Vec3],
    u: &[f64],
    start: EndCond,
    end: EndCond,
    r: f64,
    tol_mm: f64,
    accuracy: f64,
    o: &TimeShapeOptions,
) -> Option<(Nurbs, f64, f64)> {
    let model = Model::new(o);
    let (v, x) = whole_profile(c, &model);
    let x_slow = (o.slow_share * o.limits.feed_mm_s).powi(2);
    let mut cur = c.clone();
    let mut gained = 0.0;
    let mut dev = None;
    for (spot, _) in spots(&v, &x, x_slow, o.free_half_mm) {
        let ends = (
            x_at(&v, &x, spot - o.window_mm),
            x_at(&v, &x, spot + o.window_mm),
        );
        let band = Band {
            pts,
            u,
            r,
            tol_mm,
            accuracy,
        };
        if let Some((n, d, g)) = shape_spot(&cur, spot, ends, &band, start, end, o, model) {
            cur = n;
            gained += g;
            dev = Some(d);
        }
    }
    Some((cur, dev?, gained))
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

/// One spot, entering and leaving the modelled window at `ends` (`x`): see the module
/// doc, steps 3 to 5.
#[allow(clippy::too_many_arguments)]
fn shape_spot(
    c: &Nurbs,
    spot: f64,
    ends: (f64, f64),
    band: &Band<'_>,
    start: EndCond,
    end: EndCond,
    o: &TimeShapeOptions,
    model: Model,
) -> Option<(Nurbs, f64, f64)> {
    let Band {
        pts,
        u,
        r,
        tol_mm,
        accuracy,
    } = *band;
    let (da, db) = c.domain();
    let (fa, fb) = (spot - o.free_half_mm, spot + o.free_half_mm);
    // Knots every dense_span in the free part.
    let mut c = c.clone();
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
                c = c.insert_knot(t, 1);
            }
        }
    }
    let knots = c.knots().to_vec();
    let ctrl = c.ctrl().to_vec();
    let m = ctrl.len();
    let (f0, f1) = (fixed_count(start), m - fixed_count(end));
    let free: Vec<usize> = (f0..f1)
        .filter(|&j| {
            let g = (knots[j + 1] + knots[j + 2] + knots[j + 3]) / 3.0;
            g >= fa && g <= fb
        })
        .collect();
    if free.is_empty() {
        return None;
    }
    let axes: Vec<usize> = (0..3)
        .filter(|&a| pts.iter().any(|p| (p[a] - pts[0][a]).abs() > 1e-12))
        .collect();
    let (wa, wb) = ((spot - o.window_mm).max(da), (spot + o.window_mm).min(db));
    let n = (((wb - wa) / o.sample_mm).ceil() as usize).max(2);
    let params: Vec<f64> = (0..=n)
        .map(|i| wa + (wb - wa) * i as f64 / n as f64)
        .collect();
    let basis: Vec<(usize, [[f64; 4]; 3])> = params
        .iter()
        .map(|&p| {
            let s = c.find_span(p);
            let d = c.ders_basis(s, p, 2);
            let b = [0, 1, 2].map(|m| [d[m][0], d[m][1], d[m][2], d[m][3]]);
            (s - 3, b)
        })
        .collect();
    let range = |a: f64, b: f64| {
        (
            params.partition_point(|&p| p < a),
            params.partition_point(|&p| p <= b),
        )
    };
    let reach: Vec<(usize, usize)> = (0..m).map(|j| range(knots[j], knots[j + 4])).collect();
    let live = (reach[free[0]].0, reach[*free.last()?].1);
    let (la, lb) = (params[live.0.min(n)], params[(live.1.max(1) - 1).min(n)]);
    let verts = (0..pts.len())
        .filter(|&i| u[i] >= la - o.dense_span_mm && u[i] <= lb + o.dense_span_mm)
        .map(|i| {
            let (lo, hi) = range(u[i] - VERTEX_REACH_MM, u[i] + VERTEX_REACH_MM);
            (i, lo, hi)
        })
        .filter(|v| v.2 > v.1)
        .collect();
    let mut win = Window {
        model,
        ctrl,
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
        pts,
        u,
        verts,
        r,
        geo: vec![Geo::default(); n + 1],
        scratch: Vec::new(),
        ds: vec![0.0; n],
    };
    win.refresh(0, n + 1);
    let t0 = win.time();
    for w in PENALTY_WEIGHTS {
        lbfgs(&mut win, w, o.max_iters);
    }
    let w_last = PENALTY_WEIGHTS[PENALTY_WEIGHTS.len() - 1];
    for _ in 0..o.polish_rounds {
        pattern(&mut win, w_last);
        lbfgs(&mut win, w_last, o.max_iters);
    }
    let t1 = win.time();
    let gain = t0 - t1;
    if gain.is_nan() || gain < MIN_GAIN_S {
        return None;
    }
    let shaped = Nurbs::bspline(3, win.ctrl, knots)?;
    let lines: Vec<Segment> = pts
        .windows(2)
        .map(|s| Segment::Line(Line::new(s[0], s[1])))
        .collect();
    let prog: Vec<(&Segment, u32)> = lines.iter().map(|s| (s, 0)).collect();
    let seg = Segment::Nurbs(Box::new(shaped));
    let dm = deviation_segments(&[(&seg, 0)], &prog, accuracy).max_mm();
    let Segment::Nurbs(shaped) = seg else {
        unreachable!("built as a NURBS above")
    };
    (dm.is_finite() && dm + accuracy <= tol_mm).then_some((*shaped, dm, gain))
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
}
