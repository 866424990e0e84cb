//! The caps and refinement of curved intervals: the tangential-acceleration bound
//! ([`u_bound`]), the arc step, the per-axis velocity and jerk caps of intervals, and the
//! bisection of curved moves ([`refine`], terms 1-4 of the module doc).

use super::joints::abs_max;
use super::{
    MAX_CURVATURE_BEND, MAX_CURVE_INTERVALS, MAX_TURN_DEG, MIN_PARAM_STEP, PRODUCT_SHARE,
    RATE_BEND_SHARE, TANGENT_SHARE,
};
use crate::feed::limits::{point_cap_x_kappa, Caps, Interval, NEGLIGIBLE};
use crate::geom::Vec3;

/// Bound on the tangential acceleration `|u|` (mm/s^2) the row at an end of a curved
/// interval with unit tangent `t` can allow. The row holds `a_j = u T_j + x K_j` within
/// `|a_j| <= A_j` for every axis, and the curvature vector is normal to the tangent
/// (`T . K = 0`, `|T| = 1`), so `u = T . a` and `|u| <= sum_j |T_j| A_j`, whatever the
/// speed and the curvature: `A_j` on a path along axis `j`, and never more than
/// `|A| = sqrt(sum_j A_j^2)` (`u_global`). The bound is taken for any tangent within
/// `MAX_TURN_DEG` (4.0) of `t` (a change `e` of the unit tangent adds at most
/// `|e| |A| <= turn |A|`).
pub fn u_bound(t: Vec3, caps: &Caps) -> f64 {
    TurnBounds::new(caps).u_bound(t)
}

/// What [`u_bound`] and [`TurnBounds::cos_max_turn_at`] take from the caps, computed once
/// per refined move rather than at every check (the same operations, so the same values).
#[derive(Clone, Copy, Debug)]
struct TurnBounds {
    acc: [f64; 3],
    /// Smallest axis acceleration.
    a_min: f64,
    /// [`u_global`].
    global: f64,
    /// `turn |A|` of [`u_bound`].
    turn_allowance: f64,
    /// Cosine of [`MAX_TURN_DEG`].
    cos_max_turn: f64,
}

impl TurnBounds {
    fn new(caps: &Caps) -> TurnBounds {
        let global = u_global(caps);
        TurnBounds {
            acc: caps.acc,
            a_min: caps.acc.iter().copied().fold(f64::INFINITY, f64::min),
            global,
            turn_allowance: MAX_TURN_DEG.to_radians() * global,
            cos_max_turn: MAX_TURN_DEG.to_radians().cos(),
        }
    }

    /// [`u_bound`].
    #[inline]
    fn u_bound(&self, t: Vec3) -> f64 {
        let a = self.acc;
        let along = t[0].abs() * a[0] + t[1].abs() * a[1] + t[2].abs() * a[2];
        (along + self.turn_allowance).min(self.global)
    }

    /// Cosine of the largest tangent turn of a curve interval starting with unit tangent
    /// `t`: term 1 of the module doc with the local [`u_bound`], the turn at most
    /// [`MAX_TURN_DEG`]. An interval is within it when its end tangents' dot product is at
    /// least this (no inverse trigonometry on the hot path).
    #[inline]
    fn cos_max_turn_at(&self, t: Vec3) -> f64 {
        let u = self.u_bound(t) / self.a_min;
        // 1 - cos(turn / 2) <= share / u: cos(turn / 2) >= c, so cos(turn) >= 2 c^2 - 1.
        let c = (1.0 - TANGENT_SHARE / u).clamp(0.0, 1.0);
        (2.0 * c * c - 1.0).max(self.cos_max_turn)
    }
}

/// Bound on the tangential acceleration `|u|` (mm/s^2) on any curved interval: [`u_bound`]
/// whatever the tangent, `|A| = sqrt(sum_j A_j^2)` (Cauchy-Schwarz on `T . a`).
fn u_global(caps: &Caps) -> f64 {
    let a = caps.acc;
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// Largest swept angle (radians) of an arc interval (see the module doc), with `|u|`
/// at its global bound [`u_bound`] (the tangent of an arc turns).
pub fn arc_step(caps: &Caps) -> f64 {
    let a_min = caps.acc.iter().copied().fold(f64::INFINITY, f64::min);
    let u = u_global(caps) / a_min;
    let by_tangent = (8.0 * TANGENT_SHARE / u).sqrt();
    let by_product = (2.0 * PRODUCT_SHARE / u).sqrt();
    let by_bend = (8.0 * MAX_CURVATURE_BEND).sqrt();
    by_tangent
        .min(by_product)
        .min(by_bend)
        .min(MAX_TURN_DEG.to_radians())
}

/// Per-axis velocity over a whole interval: both of its ends take the cap of the largest
/// tangent component inside it (the point caps alone let `v |T_i|` bulge between two
/// binding ends). `mv` are one move's intervals with their end caps; `start_cap` the cap at its start.
pub(super) fn vaxis_caps(mv: &mut [(Interval, f64)], v: &[f64; 3], start_cap: &mut f64) {
    let n = mv.len();
    for k in 0..n {
        let c = vaxis_interval_cap(&mv[k].0, v);
        if k == 0 {
            *start_cap = start_cap.min(c);
        } else {
            mv[k - 1].1 = mv[k - 1].1.min(c);
        }
        mv[k].1 = mv[k].1.min(c);
    }
}

/// Jerk caps at every point: its curvature, and the curvature rate (finite difference
/// over each interval) of the intervals beside it. `mv` are one move's intervals (at least one) with their end caps; `start_cap` the
/// cap at its start.
pub(super) fn jerk_caps(
    mv: &mut [(Interval, f64)],
    j: &super::jerk::JerkCaps,
    start_cap: &mut f64,
) {
    let n = mv.len();
    let rates: Vec<Vec3> = mv.iter().map(|(iv, _)| (iv.k1 - iv.k0) / iv.ds).collect();
    let rate = |i: usize| rates[i];
    for p in 0..=n {
        let r = abs_max(
            p.checked_sub(1).map_or(Vec3::ZERO, rate),
            if p < n { rate(p) } else { Vec3::ZERO },
        );
        let k = if p == 0 { mv[0].0.k0 } else { mv[p - 1].0.k1 };
        // The largest tangent components of the two intervals' ends.
        let t = abs_max(
            p.checked_sub(1)
                .map_or(Vec3::ZERO, |i| abs_max(mv[i].0.t0, mv[i].0.t1)),
            mv.get(p).map_or(Vec3::ZERO, |iv| abs_max(iv.0.t0, iv.0.t1)),
        );
        let c = j.speed_cap_x(t, k, r, Vec3::ZERO);
        if p == 0 {
            *start_cap = start_cap.min(c);
        } else {
            mv[p - 1].1 = mv[p - 1].1.min(c);
        }
    }
}

/// Cap on `x = v^2` from the per-axis velocity limits `v` over a whole curved interval: a
/// tangent component turning by `phi` between two checks exceeds the larger of their
/// values by at most the factor `1 / cos(phi / 2)` between them.
fn vaxis_interval_cap(iv: &Interval, v: &[f64; 3]) -> f64 {
    let (turn, tmax) = match &iv.mid {
        Some(m) => (
            iv.t0.angle_to(m.t).max(m.t.angle_to(iv.t1)),
            abs_max(abs_max(iv.t0, m.t), iv.t1),
        ),
        None => (iv.t0.angle_to(iv.t1), abs_max(iv.t0, iv.t1)),
    };
    let grow = 1.0 / (0.5 * turn).cos();
    let mut x = f64::INFINITY;
    for i in 0..3 {
        let t = tmax[i] * grow;
        if t > NEGLIGIBLE {
            x = x.min((v[i] / t).powi(2));
        }
    }
    x
}

/// Arc length of a piece of curve from its chord and the cosine `cos_turn` of the angle
/// between its end tangents, as on a circular arc: `chord (turn/2) / sin(turn/2)`, i.e.
/// `chord asin(x) / x` with `x = sin(turn/2) = sqrt((1 - cos_turn) / 2)`. For the grid's
/// intervals (turn at most [`MAX_TURN_DEG`]) the whole correction is below 2e-5 of the
/// chord and its error of a higher order; the move's last interval takes the remainder of
/// the move's exact length, so the grid never drifts from the path's arc length.
pub(super) fn arc_from_chord(chord: f64, cos_turn: f64) -> f64 {
    let x2 = (0.5 * (1.0 - cos_turn)).clamp(0.0, 1.0);
    if x2 < ARC_SERIES_MAX_X2 {
        // asin(x)/x = 1 + x^2/6 + 3 x^4/40 + 5 x^6/112 + O(x^8): the next term is below
        // 4e-10 of the chord here.
        chord * (1.0 + x2 * (1.0 / 6.0 + x2 * (3.0 / 40.0 + x2 * (5.0 / 112.0))))
    } else {
        let x = x2.sqrt();
        chord * x.asin() / x
    }
}

/// Largest `sin^2(turn/2)` for which [`arc_from_chord`] uses its series.
const ARC_SERIES_MAX_X2: f64 = 0.01;

/// Geometry sample: parameter, unit tangent, curvature vector, point, curvature (the
/// norm of the curvature vector, used by several checks).
pub(super) type Sample = (f64, Vec3, Vec3, Vec3, f64);

/// Grid samples of a curved move: `n0` uniform intervals, each taken as two halves
/// around its parameter midpoint, bisected (when `split`) until both halves keep the
/// three terms of the module doc within their shares. `geo` gives the unit tangent,
/// curvature vector and point at a parameter. Returns `2 N + 1` samples for the `N`
/// accepted intervals: their ends at even indices (first `t = 0`, last `t = 1`) and their
/// midpoints at odd ones.
pub(super) fn refine(
    n0: usize,
    split: bool,
    vcap_mm_s: f64,
    len_mm: f64,
    caps: &Caps,
    geo: &impl Fn(f64) -> (Vec3, Vec3, Vec3),
) -> Vec<Sample> {
    let sample = |t: f64| {
        let (tt, kk, p) = geo(t);
        (t, tt, kk, p, kk.norm())
    };
    let bounds = TurnBounds::new(caps);
    let a_min = bounds.a_min;
    let mut params: Vec<Sample> = Vec::with_capacity(2 * n0 + 1);
    params.push(sample(0.0));
    // Pending right ends, with the interval's midpoint sample when already known.
    let mut stack: Vec<(Sample, Option<Sample>)> = (1..=n0)
        .rev()
        .map(|i| (sample(i as f64 / n0 as f64), None))
        .collect();
    // Reachability: the uniform samples are grid points, so `x` is within its point cap
    // there, and inside the move it changes by at most `2 U` per mm of arc.
    let x_reach = stack
        .iter()
        .map(|(s, _)| s)
        .chain(params.iter())
        .map(|s| point_cap_x_kappa(s.1, s.2, s.4, vcap_mm_s, caps))
        .fold(f64::INFINITY, f64::min)
        + 2.0 * bounds.global * len_mm;
    let x_env = (vcap_mm_s * vcap_mm_s).min(x_reach);
    let k_floor = if x_env > 0.0 && x_env.is_finite() {
        a_min / x_env
    } else {
        0.0
    };
    // Terms 1 and 2 on one half.
    let turn_or_product = |l: &Sample, r: &Sample| {
        if l.1.dot(r.1) < bounds.cos_max_turn_at(l.1) {
            return true;
        }
        // Term 2: |u| ds |dK_i| / 2 <= share A_i (ds from the chord, a lower bound of the
        // arc that is within 1e-4 of it at the turn bound).
        let ds = l.3.dist(r.3);
        let dk = r.2 - l.2;
        let half_u = 0.5 * bounds.u_bound(l.1);
        (0..3).any(|i| half_u * ds * dk[i].abs() > PRODUCT_SHARE * caps.acc[i])
    };
    // Term 3 on one half: the curvature at its midpoint `q` against the chord of its end
    // values, at the sample's share of the arc length (the parameter is not proportional
    // to it; chords measure it within the turn bound).
    let bent = |l: &Sample, r: &Sample, q: &Sample| {
        let kref = l.4.max(r.4).max(q.4).max(k_floor);
        let lim = MAX_CURVATURE_BEND * kref + 1e-12;
        let (a, b) = (l.3.dist(q.3), q.3.dist(r.3));
        let f = if a + b > 0.0 { a / (a + b) } else { 0.5 };
        (q.2 - (l.2 * (1.0 - f) + r.2 * f)).norm() > lim
    };
    // Term 4 on one half (jerk mode): the curvature rates of its two halves, against the
    // jerk `x_env^1.5` times their difference makes.
    let v3 = x_env.max(0.0).powf(1.5);
    let rate_room = caps
        .jerk
        .as_ref()
        .filter(|_| v3.is_finite() && v3 > 0.0)
        .map(|j| j.jerk_mm_s3.map(|ji| RATE_BEND_SHARE * ji / v3));
    // A half shorter than a period's travel is one step to the finite differences: its
    // rate is not resolved further (the mean over it already exceeds the step it makes).
    let rate_min_ds = x_env.max(0.0).sqrt() * caps.period_s;
    let rate_bent = |l: &Sample, r: &Sample, q: &Sample| {
        let Some(room) = rate_room else {
            return false;
        };
        let (a, b) = (l.3.dist(q.3), q.3.dist(r.3));
        if a <= 0.0 || b <= 0.0 || a + b < rate_min_ds {
            return false;
        }
        let d = (q.2 - l.2) / a - (r.2 - q.2) / b;
        (0..3).any(|i| 0.5 * d[i].abs() > room[i])
    };
    while let Some(&(right, known_mid)) = stack.last() {
        let left = *params.last().expect("non-empty");
        let (t0, t1) = (left.0, right.0);
        let mid = known_mid.unwrap_or_else(|| sample(0.5 * (t0 + t1)));
        let can_split = split
            && params.len() / 2 + stack.len() < MAX_CURVE_INTERVALS
            && t1 - t0 > MIN_PARAM_STEP;
        let mut bad = false;
        let (mut q1, mut q3) = (None, None);
        if can_split {
            bad = turn_or_product(&left, &mid) || turn_or_product(&mid, &right);
            if !bad {
                let a = sample(t0 + 0.25 * (t1 - t0));
                let b = sample(t0 + 0.75 * (t1 - t0));
                bad = bent(&left, &mid, &a)
                    || bent(&mid, &right, &b)
                    || rate_bent(&left, &mid, &a)
                    || rate_bent(&mid, &right, &b);
                (q1, q3) = (Some(a), Some(b));
            }
        }
        if bad {
            // Bisect: the right half keeps `right` with `q3` as its midpoint; the left half
            // ends at `mid` with `q1` as its midpoint.
            stack.last_mut().expect("non-empty").1 = q3;
            stack.push((mid, q1));
        } else {
            params.push(mid);
            params.push(right);
            stack.pop();
        }
    }
    params
}
