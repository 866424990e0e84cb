//! Cubic trigonometric interpolation spline segment (Tao, Song and Yi 2013, "Description
//! and smoothing of NC motion path based on the cubic trigonometric interpolation spline").
//!
//! ## The curve
//! With `S = sin(pi u / 2)`, `C = cos(pi u / 2)` and shape parameters `lambda`, `k`, the
//! basis of eq. 1 spans `{C^3, S^3, S^2, C, S, 1}` and a segment is
//! `P(u) = sum_j q_j B_j(u)` (eq. 2) over four control points. The basis sums to one, so
//! the curve is evaluated as `q0 + sum_(j=1..3) (q_j - q0) B_j(u)`: differences of control
//! points only, which keeps full precision at huge coordinates. Eq. 3 holds:
//! `P(0) = q0`, `P(1) = q1`, `P'(0) = (q1 - q0) - k (q2 - q1)`,
//! `P'(1) = (q2 - q1) - k (q3 - q2)`.
//!
//! **Observation used throughout** (checked numerically in the tests): the segment depends
//! only on its end points, its end derivatives and `lambda`; `k` only maps control points to
//! end derivatives through eq. 3. So for `k != 0` a segment is a trigonometric Hermite
//! interpolant, and [`TrigSpline::hermite`] builds it with `k = -1`, where the control
//! points are simply `(p0, p1, p0 + t0, p1 + t1)`: Tao's corner constructions (Fig. 8
//! `(B, B, B1, B2)`, Fig. 9 `(C1, C2, C3, C4)`) are exactly this form.
//!
//! Exact shapes: the line of eq. 8 (`(B, C, B, C)`, `lambda = 0`, `k = -1`, moving as
//! `C^3`, so with zero parametric speed at both ends) and the quarter circle of eq. 9
//! (`lambda = 1`, `k = -1`). Other sweeps (section "Circular arc description"): a parameter
//! window `[u0, u1]` of a quarter circle for sweeps up to 90 degrees and joined quarters
//! beyond ([`TrigSpline::arc`]); the window is why the struct carries `u0`, `u1` besides the
//! four control points and the shape parameters. The trait parameter `t in [0, 1]` maps to
//! `u = u0 + t (u1 - u0)`.
//!
//! Free curves: [`TrigSpline::free_curve`] is eq. 2 verbatim (`n` points, `n - 3` segments,
//! interpolating the first `n - 2` points, C1 by eq. 5); [`TrigSpline::free_curve_through`]
//! adds an end condition so that every point is interpolated.
//!
//! ## Reading the paper
//! * The paper numbers its points `q_0 .. q_n` (`n + 1` points), hence its "`n - 2`
//!   segments" interpolating `q_0 .. q_(n-2)`; counted in points, as here, `n` points give
//!   `n - 3` segments. Both say the same.
//! * "In formulas (7) and (8): s is stand for ..." refers to eqs. (6) and (7) (the
//!   expanded polynomial and its coordinate form); eq. 8 is the straight line.
//! * Its Fig. 1 gives no control points; [`crate::smooth::trig_corner::figures`] uses
//!   documented ones.
//!
//! ## Accuracy
//! Evaluation and both derivatives are analytic. Arc length, its inverse and the nearest
//! point are numerical ([`arclen_adaptive`], [`inv_arclen_newton`] which is bisection-guarded
//! for the zero-speed ends of the eq. 8 line, [`nearest_generic`]). The bounding box and
//! the flattening carry proofs (see [`ParamCurveBBox`] and [`Flatten`] impls).

use super::traits::*;
use super::vec3::{Aabb, Vec3};
use super::Arc;
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_2_PI, FRAC_PI_2};

/// Deepest recursion of [`TrigSpline`] flattening (2^-depth of the parameter range).
const MAX_FLATTEN_DEPTH: u32 = 40;
/// Pieces of the parameter range whose interval boxes are united in
/// [`TrigSpline::bounding_box`].
const BBOX_PIECES: usize = 8;
/// Relative inflation of the interval bound on `|P''|` covering floating-point rounding of
/// the bound itself.
const BOUND_ROUNDING: f64 = 1e-12;

/// One cubic trigonometric spline segment: control points `q0..q3`, shape parameters
/// `lambda` and `k` (eq. 1), evaluated on the window `u in [u0, u1]` of its natural
/// parameter (`[0, 1]` for a whole segment).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrigSpline {
    /// First control point: the start `P(0)`.
    pub q0: Vec3,
    /// Second control point: the end `P(1)`.
    pub q1: Vec3,
    /// Third control point (start derivative, eq. 3).
    pub q2: Vec3,
    /// Fourth control point (end derivative, eq. 3).
    pub q3: Vec3,
    /// Shape parameter `lambda`.
    pub lambda: f64,
    /// Shape parameter `k`.
    pub k: f64,
    /// Start of the parameter window (0 for a whole segment).
    pub u0: f64,
    /// End of the parameter window (1 for a whole segment).
    pub u1: f64,
}

/// The four basis functions of eq. 1 at `u`.
pub fn basis(u: f64, lambda: f64, k: f64) -> [f64; 4] {
    let f = funcs(u);
    let c = coeffs(lambda, k);
    let mut b = [0.0; 4];
    for j in 0..3 {
        b[j + 1] = (0..6).map(|m| c[j][m] * f[m]).sum();
    }
    // B0 written out as in eq. 1 (not as 1 - B1 - B2 - B3) so that the sum is a test.
    let a = FRAC_2_PI;
    b[0] = (1.0 - a * lambda) * f[0] + (a - lambda) * f[1] + lambda * (1.0 - a) * f[2] - a * f[4]
        + a * lambda;
    b
}

/// Derivatives of the four basis functions of eq. 1 with respect to `u` at `u`.
pub fn basis_deriv(u: f64, lambda: f64, k: f64) -> [f64; 4] {
    let (s, c) = (FRAC_PI_2 * u).sin_cos();
    let f = funcs_d1_sc(s, c);
    let co = coeffs(lambda, k);
    let mut b = [0.0; 4];
    for j in 0..3 {
        b[j + 1] = FRAC_PI_2 * (0..6).map(|m| co[j][m] * f[m]).sum::<f64>();
    }
    // The basis sums to one, so its derivatives sum to zero.
    b[0] = -(b[1] + b[2] + b[3]);
    b
}

/// Coefficients of `B1, B2, B3` (eq. 1) over `[C^3, S^3, S^2, C, S, 1]`.
#[inline]
fn coeffs(l: f64, k: f64) -> [[f64; 6]; 3] {
    let a = FRAC_2_PI;
    [
        [
            a * (k + 1.0) * l - (1.0 + a),
            l * (1.0 + a) - a * (k + 1.0),
            l * (a * k - 1.0),
            a,
            a * (k + 1.0),
            1.0 - a * (k + 1.0) * l,
        ],
        [
            a * (k + 1.0) - a * k * l,
            a * k - a * (k + 1.0) * l,
            a * l,
            -a * (k + 1.0),
            -a * k,
            a * k * l,
        ],
        [-a * k, a * k * l, -a * k * l, a * k, 0.0, 0.0],
    ]
}

/// `[C^3, S^3, S^2, C, S, 1]` at `u`.
#[inline]
fn funcs(u: f64) -> [f64; 6] {
    let (s, c) = (FRAC_PI_2 * u).sin_cos();
    funcs_sc(s, c)
}

/// [`funcs`] from `S` and `C`.
#[inline]
fn funcs_sc(s: f64, c: f64) -> [f64; 6] {
    [c * c * c, s * s * s, s * s, c, s, 1.0]
}

/// First derivatives of [`funcs`] with respect to `u`, without the factor `pi / 2`, from
/// `S` and `C`.
#[inline]
fn funcs_d1_sc(s: f64, c: f64) -> [f64; 6] {
    [-3.0 * c * c * s, 3.0 * s * s * c, 2.0 * s * c, -s, c, 0.0]
}

/// Second derivatives of [`funcs`] with respect to `u`, without the factor `(pi / 2)^2`,
/// from `S` and `C`.
#[inline]
fn funcs_d2_sc(s: f64, c: f64) -> [f64; 6] {
    [
        3.0 * c * (2.0 * s * s - c * c),
        3.0 * s * (2.0 * c * c - s * s),
        2.0 * (c * c - s * s),
        -c,
        -s,
        0.0,
    ]
}

/// `sum_m w_m f_m` over the first `n` terms.
#[inline]
fn combine(w: &[Vec3; 6], f: &[f64; 6], n: usize) -> Vec3 {
    let mut p = Vec3::ZERO;
    for m in 0..n {
        p += w[m] * f[m];
    }
    p
}

/// Interval `[lo, hi]` arithmetic helpers for the proofs of the bounds.
#[derive(Clone, Copy, Debug)]
struct Iv(f64, f64);

impl Iv {
    fn mul(self, o: Iv) -> Iv {
        let p = [self.0 * o.0, self.0 * o.1, self.1 * o.0, self.1 * o.1];
        Iv(
            p.iter().copied().fold(f64::INFINITY, f64::min),
            p.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        )
    }
    fn scale(self, s: f64) -> Iv {
        if s >= 0.0 {
            Iv(self.0 * s, self.1 * s)
        } else {
            Iv(self.1 * s, self.0 * s)
        }
    }
    fn add(self, o: Iv) -> Iv {
        Iv(self.0 + o.0, self.1 + o.1)
    }
    fn mag(self) -> f64 {
        self.0.abs().max(self.1.abs())
    }
}

/// Ranges of `S` and `C` over `[ua, ub]` within `[0, 1]`: `S` increases and `C` decreases
/// there, so the ranges are their end values.
fn sc_ranges(ua: f64, ub: f64) -> (Iv, Iv) {
    let (sa, ca) = (FRAC_PI_2 * ua).sin_cos();
    let (sb, cb) = (FRAC_PI_2 * ub).sin_cos();
    (Iv(sa.max(0.0), sb.min(1.0)), Iv(cb.max(0.0), ca.min(1.0)))
}

impl TrigSpline {
    /// A whole segment (window `[0, 1]`) from its four control points and shape parameters.
    pub const fn new(q0: Vec3, q1: Vec3, q2: Vec3, q3: Vec3, lambda: f64, k: f64) -> TrigSpline {
        TrigSpline {
            q0,
            q1,
            q2,
            q3,
            lambda,
            k,
            u0: 0.0,
            u1: 1.0,
        }
    }

    /// Hermite form with `k = -1`: from `p0` to `p1` with derivatives `t0`, `t1` (with
    /// respect to the natural parameter) at the ends; control points `(p0, p1, p0 + t0,
    /// p1 + t1)` by eq. 3.
    pub fn hermite(p0: Vec3, p1: Vec3, t0: Vec3, t1: Vec3, lambda: f64) -> TrigSpline {
        TrigSpline::new(p0, p1, p0 + t0, p1 + t1, lambda, -1.0)
    }

    /// The exact straight line of eq. 8 from `b` to `c`: control points `(B, C, B, C)`,
    /// `lambda = 0`, `k = -1`; `P(u) = c + (b - c) C^3`, at rest at both ends.
    pub fn line(b: Vec3, c: Vec3) -> TrigSpline {
        TrigSpline::new(b, c, b, c, 0.0, -1.0)
    }

    /// The exact quarter circle of eq. 9, generalised to any plane: centre `center`, radius
    /// `r`, from `center + r u` to `center + r v` (`u`, `v` orthonormal):
    /// `P(u) = center + r (C u + S v)`.
    pub fn quarter_circle(center: Vec3, r: f64, u: Vec3, v: Vec3) -> TrigSpline {
        let a = center + u * r;
        let b = center + v * r;
        let c = a + v * (FRAC_PI_2 * r);
        let d = b - u * (FRAC_PI_2 * r);
        TrigSpline::new(a, b, c, d, 1.0, -1.0)
    }

    /// The exact arc `arc` as trigonometric splines: windows of quarter circles, one per
    /// started 90 degrees of sweep. `None` for helical and spiral arcs (a linear axial
    /// motion, or a radius linear in the angle, is not in the span of the basis).
    pub fn arc(arc: &Arc) -> Option<Vec<TrigSpline>> {
        if arc.is_helical() || arc.is_spiral() || !(arc.sweep > 0.0 && arc.sweep.is_finite()) {
            return None;
        }
        let n = (arc.sweep / FRAC_PI_2 - 1e-12).ceil().max(1.0) as usize;
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let a0 = i as f64 * FRAC_PI_2;
            let a1 = ((i + 1) as f64 * FRAC_PI_2).min(arc.sweep);
            let (s, c) = a0.sin_cos();
            let u = arc.u * c + arc.v * s;
            let v = arc.v * c - arc.u * s;
            let mut q = TrigSpline::quarter_circle(arc.center, arc.radius, u, v);
            q.u1 = (a1 - a0) / FRAC_PI_2;
            out.push(q);
        }
        Some(out)
    }

    /// The free curve of eq. 2 verbatim: `n >= 4` points give `n - 3` segments, segment `i`
    /// with control points `points[i..i + 4]`; it interpolates `points[0..n - 2]` and is C1
    /// by eq. 5. Empty for fewer than 4 points.
    pub fn free_curve(points: &[Vec3], lambda: f64, k: f64) -> Vec<TrigSpline> {
        points
            .windows(4)
            .map(|w| TrigSpline::new(w[0], w[1], w[2], w[3], lambda, k))
            .collect()
    }

    /// The free curve of eq. 2 through *every* point: `n >= 2` points give `n - 1`
    /// segments. End condition (the paper has none): two phantom control points continue
    /// the last chord straight, `p_n = p_(n-1) + c`, `p_(n+1) = p_(n-1) + 2 c` with
    /// `c = p_(n-1) - p_(n-2)`, so the curve arrives along its last chord with derivative
    /// `(1 - k) c` (eq. 3). Empty for fewer than 2 points.
    pub fn free_curve_through(points: &[Vec3], lambda: f64, k: f64) -> Vec<TrigSpline> {
        let n = points.len();
        if n < 2 {
            return Vec::new();
        }
        let c = points[n - 1] - points[n - 2];
        let mut q = points.to_vec();
        q.push(points[n - 1] + c);
        q.push(points[n - 1] + c * 2.0);
        TrigSpline::free_curve(&q, lambda, k)
    }

    /// The sub-curve on `t in [t0, t1]` (exact: a narrower window).
    pub fn subsegment(&self, t0: f64, t1: f64) -> TrigSpline {
        let span = self.u1 - self.u0;
        TrigSpline {
            u0: self.u0 + t0 * span,
            u1: self.u0 + t1 * span,
            ..*self
        }
    }

    /// The control points.
    pub fn control_points(&self) -> [Vec3; 4] {
        [self.q0, self.q1, self.q2, self.q3]
    }

    /// Weights `W_m` of `[C^3, S^3, S^2, C, S, 1]`: `P(u) = q0 + sum_m W_m f_m(u)`.
    #[inline]
    fn weights(&self) -> [Vec3; 6] {
        let c = coeffs(self.lambda, self.k);
        let d = [self.q1 - self.q0, self.q2 - self.q0, self.q3 - self.q0];
        let mut w = [Vec3::ZERO; 6];
        for (m, wm) in w.iter_mut().enumerate() {
            *wm = d[0] * c[0][m] + d[1] * c[1][m] + d[2] * c[2][m];
        }
        w
    }

    #[inline]
    fn u_of(&self, t: f64) -> f64 {
        self.u0 + t * (self.u1 - self.u0)
    }

    /// Point at the natural parameter `u` (ignores the window).
    #[inline]
    pub fn eval_u(&self, u: f64) -> Vec3 {
        self.q0 + combine(&self.weights(), &funcs(u), 6)
    }

    /// A bound on `|d^2 P / dt^2|` over `t in [ta, tb]`, by interval arithmetic on the
    /// basis terms (`S` and `C` are monotone on the window, every term is a polynomial in
    /// them).
    pub fn deriv2_bound(&self, ta: f64, tb: f64) -> f64 {
        self.deriv2_bound_w(&self.weights(), ta, tb)
    }

    /// [`TrigSpline::deriv2_bound`] with the weights given.
    fn deriv2_bound_w(&self, w: &[Vec3; 6], ta: f64, tb: f64) -> f64 {
        let (s, c) = sc_ranges(self.u_of(ta), self.u_of(tb));
        let s2 = s.mul(s);
        let c2 = c.mul(c);
        let g = [
            c.scale(3.0).mul(s2.scale(2.0).add(c2.scale(-1.0))),
            s.scale(3.0).mul(c2.scale(2.0).add(s2.scale(-1.0))),
            c2.add(s2.scale(-1.0)).scale(2.0),
            c.scale(-1.0),
            s.scale(-1.0),
        ];
        let mut sq = 0.0;
        for axis in 0..3 {
            let mut acc = Iv(0.0, 0.0);
            for m in 0..5 {
                acc = acc.add(g[m].scale(w[m][axis]));
            }
            sq += acc.mag() * acc.mag();
        }
        let span = self.u1 - self.u0;
        sq.sqrt() * FRAC_PI_2 * FRAC_PI_2 * span * span * (1.0 + BOUND_ROUNDING)
    }

    /// Box containing the curve for `t in [ta, tb]`: each term `W_m f_m` ranges over
    /// `W_m` times the range of `f_m`, which is monotone on the window.
    fn interval_box(&self, ta: f64, tb: f64) -> Aabb {
        let (s, c) = sc_ranges(self.u_of(ta), self.u_of(tb));
        let f = [
            Iv(c.0 * c.0 * c.0, c.1 * c.1 * c.1),
            Iv(s.0 * s.0 * s.0, s.1 * s.1 * s.1),
            Iv(s.0 * s.0, s.1 * s.1),
            c,
            s,
            Iv(1.0, 1.0),
        ];
        let w = self.weights();
        let mut lo = [0.0; 3];
        let mut hi = [0.0; 3];
        for axis in 0..3 {
            let mut acc = Iv(self.q0[axis], self.q0[axis]);
            for m in 0..6 {
                acc = acc.add(f[m].scale(w[m][axis]));
            }
            lo[axis] = acc.0;
            hi[axis] = acc.1;
        }
        let pad = BOUND_ROUNDING * (self.q0.max_abs() + w.iter().map(|v| v.max_abs()).sum::<f64>());
        Aabb {
            min: Vec3::from_array(lo),
            max: Vec3::from_array(hi),
        }
        .inflate(pad)
    }

    /// Flattening of `[ta, tb]` with the weights `w` (computed once per flattening).
    #[allow(clippy::too_many_arguments)]
    fn flatten_rec<F: FnMut(Vec3)>(
        &self,
        w: &[Vec3; 6],
        ta: f64,
        tb: f64,
        accuracy: f64,
        depth: u32,
        sink: &mut F,
    ) {
        let h = tb - ta;
        if depth >= MAX_FLATTEN_DEPTH || h * h * 0.125 * self.deriv2_bound_w(w, ta, tb) <= accuracy
        {
            sink(if tb >= 1.0 {
                self.end()
            } else {
                self.eval_w(w, tb)
            });
            return;
        }
        let m = 0.5 * (ta + tb);
        self.flatten_rec(w, ta, m, accuracy, depth + 1, sink);
        self.flatten_rec(w, m, tb, accuracy, depth + 1, sink);
    }
}

/// A [`TrigSpline`] with its weights `W_m` computed once, for code that evaluates one
/// segment many times (the interpolator's steps, the planning grid, arc lengths): every
/// evaluation is the same arithmetic as the segment's own, so the results are identical
/// bit for bit, without the 18 vector products of the weights at each call.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreparedTrig {
    /// The segment.
    pub spline: TrigSpline,
    w: [Vec3; 6],
}

impl PreparedTrig {
    /// Prepares `spline`.
    #[inline]
    pub fn new(spline: &TrigSpline) -> PreparedTrig {
        PreparedTrig {
            spline: *spline,
            w: spline.weights(),
        }
    }
}

impl TrigSpline {
    #[inline]
    fn eval_w(&self, w: &[Vec3; 6], t: f64) -> Vec3 {
        self.q0 + combine(w, &funcs(self.u_of(t)), 6)
    }
    #[inline]
    fn deriv_w(&self, w: &[Vec3; 6], t: f64) -> Vec3 {
        let (s, c) = (FRAC_PI_2 * self.u_of(t)).sin_cos();
        combine(w, &funcs_d1_sc(s, c), 5) * (FRAC_PI_2 * (self.u1 - self.u0))
    }
    #[inline]
    fn deriv2_w(&self, w: &[Vec3; 6], t: f64) -> Vec3 {
        let (s, c) = (FRAC_PI_2 * self.u_of(t)).sin_cos();
        let span = FRAC_PI_2 * (self.u1 - self.u0);
        combine(w, &funcs_d2_sc(s, c), 5) * (span * span)
    }
    #[inline]
    fn ders_w(&self, w: &[Vec3; 6], t: f64) -> [Vec3; 3] {
        let (s, c) = (FRAC_PI_2 * self.u_of(t)).sin_cos();
        let span = FRAC_PI_2 * (self.u1 - self.u0);
        [
            self.q0 + combine(w, &funcs_sc(s, c), 6),
            combine(w, &funcs_d1_sc(s, c), 5) * span,
            combine(w, &funcs_d2_sc(s, c), 5) * (span * span),
        ]
    }
}

impl ParamCurve for PreparedTrig {
    #[inline]
    fn eval(&self, t: f64) -> Vec3 {
        self.spline.eval_w(&self.w, t)
    }
    #[inline]
    fn start(&self) -> Vec3 {
        self.spline.start()
    }
    #[inline]
    fn end(&self) -> Vec3 {
        self.spline.end()
    }
}

impl ParamCurveDeriv for PreparedTrig {
    #[inline]
    fn deriv(&self, t: f64) -> Vec3 {
        self.spline.deriv_w(&self.w, t)
    }
    #[inline]
    fn deriv2(&self, t: f64) -> Vec3 {
        self.spline.deriv2_w(&self.w, t)
    }
    #[inline]
    fn ders(&self, t: f64) -> [Vec3; 3] {
        self.spline.ders_w(&self.w, t)
    }
}

impl ParamCurveCurvature for PreparedTrig {}

impl ParamCurve for TrigSpline {
    #[inline]
    fn eval(&self, t: f64) -> Vec3 {
        self.eval_u(self.u_of(t))
    }
    fn start(&self) -> Vec3 {
        if self.u0 == 0.0 {
            self.q0
        } else {
            self.eval(0.0)
        }
    }
    fn end(&self) -> Vec3 {
        if self.u1 == 1.0 {
            self.q1
        } else {
            self.eval(1.0)
        }
    }
}

impl ParamCurveDeriv for TrigSpline {
    #[inline]
    fn deriv(&self, t: f64) -> Vec3 {
        self.deriv_w(&self.weights(), t)
    }
    #[inline]
    fn deriv2(&self, t: f64) -> Vec3 {
        self.deriv2_w(&self.weights(), t)
    }
    /// One `sin_cos` and one set of weights for all three.
    #[inline]
    fn ders(&self, t: f64) -> [Vec3; 3] {
        self.ders_w(&self.weights(), t)
    }
}

impl ParamCurveArclen for TrigSpline {
    /// Adaptive Gauss-Legendre ([`arclen_adaptive`]); error within `accuracy`.
    fn arclen(&self, accuracy: f64) -> f64 {
        arclen_adaptive(self, 0.0, 1.0, accuracy)
    }
    /// Bisection-guarded Newton ([`inv_arclen_newton`]): copes with the zero parametric
    /// speed at the ends of the eq. 8 line and of loops.
    fn inv_arclen(&self, s: f64, accuracy: f64) -> f64 {
        let total = self.arclen(accuracy * 0.25);
        inv_arclen_newton(self, s, total, accuracy)
    }
}

impl ParamCurveNearest for TrigSpline {
    /// [`nearest_generic`].
    fn nearest(&self, p: Vec3, accuracy: f64) -> Nearest {
        nearest_generic(self, p, accuracy)
    }
}

impl ParamCurveCurvature for TrigSpline {}

impl ParamCurveBBox for TrigSpline {
    /// Union of `BBOX_PIECES` (8) interval boxes. Proof: on a piece of the window, `S`
    /// increases and `C` decreases (the window lies in `[0, 1]`, where `pi u / 2` is in the
    /// first quadrant), so each of `C^3, S^3, S^2, C, S` lies between its end values; the
    /// curve is `q0 + sum W_m f_m`, and the box of sums of ranges contains it.
    fn bounding_box(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for i in 0..BBOX_PIECES {
            let ta = i as f64 / BBOX_PIECES as f64;
            let tb = (i + 1) as f64 / BBOX_PIECES as f64;
            b = b.union(self.interval_box(ta, tb));
        }
        b
    }
}

impl Flatten for TrigSpline {
    /// Recursive halving of `[ta, tb]` until `(tb - ta)^2 / 8 * M <= accuracy`, `M` the
    /// interval bound on `|P''|` over the piece ([`TrigSpline::deriv2_bound`]). Proof: the
    /// chord `L(t)` interpolates `P` at `ta`, `tb`, and `P(t) - L(t) = -int G(t, s) P''(s) ds`
    /// with the Green's function `G >= 0`, `int G ds = (t - ta)(tb - t) / 2 <= h^2 / 8`; so
    /// `|P(t) - L(t)| <= h^2 / 8 * M` for every `t`: each curve point has a chord point
    /// within `accuracy` and each chord point a curve point within `accuracy`.
    fn flatten<F: FnMut(Vec3)>(&self, accuracy: f64, sink: &mut F) {
        self.flatten_rec(&self.weights(), 0.0, 1.0, accuracy, 0, sink);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn sample() -> TrigSpline {
        TrigSpline::new(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(10.0, 1.0, 0.5),
            Vec3::new(13.0, 7.0, -1.0),
            Vec3::new(19.0, 5.0, 2.0),
            0.7,
            0.4,
        )
    }

    #[test]
    fn prepared_evaluation_is_identical() {
        let whole = sample();
        for c in [whole, whole.subsegment(0.2, 0.7)] {
            let p = PreparedTrig::new(&c);
            assert_eq!((p.start(), p.end()), (c.start(), c.end()));
            for i in 0..=50 {
                let t = i as f64 / 50.0;
                assert_eq!(p.eval(t), c.eval(t));
                assert_eq!(p.deriv(t), c.deriv(t));
                assert_eq!(p.deriv2(t), c.deriv2(t));
                assert_eq!(p.ders(t), c.ders(t));
                assert_eq!(p.curvature_vec(t), c.curvature_vec(t));
            }
        }
    }

    #[test]
    fn basis_sums_to_one() {
        for &(l, k) in &[
            (0.0, -1.0),
            (1.0, -1.0),
            (0.5, 0.5),
            (1.5, 0.3),
            (-1.0, 2.0),
        ] {
            for i in 0..=20 {
                let b = basis(i as f64 / 20.0, l, k);
                assert!((b.iter().sum::<f64>() - 1.0).abs() < 1e-14, "{l} {k} {b:?}");
            }
        }
    }

    #[test]
    fn end_conditions_of_eq3() {
        for &(l, k) in &[(0.7, 0.4), (0.0, -1.0), (1.3, 0.6), (-0.5, 1.5)] {
            let c = TrigSpline {
                lambda: l,
                k,
                ..sample()
            };
            let [q0, q1, q2, q3] = c.control_points();
            assert!(c.eval(0.0).dist(q0) < 1e-13);
            assert!(c.eval(1.0).dist(q1) < 1e-13);
            let d0 = (q1 - q0) - (q2 - q1) * k;
            let d1 = (q2 - q1) - (q3 - q2) * k;
            assert!(c.deriv(0.0).dist(d0) < 1e-12, "{:?} {:?}", c.deriv(0.0), d0);
            assert!(c.deriv(1.0).dist(d1) < 1e-12);
        }
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let c = sample().subsegment(0.1, 0.9);
        let h = 1e-6;
        for i in 1..20 {
            let t = i as f64 / 20.0;
            let fd = (c.eval(t + h) - c.eval(t - h)) / (2.0 * h);
            assert!((fd - c.deriv(t)).norm() < 1e-7 * (1.0 + fd.norm()));
            let fd2 = (c.deriv(t + h) - c.deriv(t - h)) / (2.0 * h);
            assert!((fd2 - c.deriv2(t)).norm() < 1e-6 * (1.0 + fd2.norm()));
        }
    }

    #[test]
    fn hermite_form_does_not_depend_on_k() {
        // Same end points and end derivatives, control points from eq. 3 for several k.
        let (p0, p1) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.3, 0.0));
        let (t0, t1) = (Vec3::new(0.5, 1.2, 0.1), Vec3::new(1.5, -0.4, 0.0));
        let reference = TrigSpline::hermite(p0, p1, t0, t1, 0.7);
        for &k in &[0.3, 2.0, -0.4] {
            let q2 = p1 + (p1 - p0 - t0) / k;
            let q3 = q2 + (q2 - p1 - t1) / k;
            let c = TrigSpline::new(p0, p1, q2, q3, 0.7, k);
            for i in 0..=10 {
                let t = i as f64 / 10.0;
                assert!(c.eval(t).dist(reference.eval(t)) < 1e-12);
            }
        }
    }

    #[test]
    fn exact_line_of_eq8() {
        let (b, c) = (Vec3::new(1.0, 2.0, 3.0), Vec3::new(-4.0, 7.0, 0.5));
        let l = TrigSpline::line(b, c);
        for i in 0..=50 {
            let u = i as f64 / 50.0;
            let cc = (PI * u / 2.0).cos();
            let expect = c + (b - c) * (cc * cc * cc);
            assert!(l.eval(u).dist(expect) < 1e-12);
        }
        // Zero parametric speed at both ends; tangents and arc length still work.
        assert!(l.deriv(0.0).norm() < 1e-12 && l.deriv(1.0).norm() < 1e-12);
        let seg = crate::geom::Segment::Trig(l);
        let dir = (c - b).normalized().unwrap();
        assert!(seg.start_tangent().unwrap().dist(dir) < 1e-6);
        assert!(seg.end_tangent().unwrap().dist(dir) < 1e-6);
        let len = b.dist(c);
        assert!((l.arclen(1e-12) - len).abs() < 1e-10);
        for &s in &[0.0, 1e-6, 0.3, 0.5 * len, len - 1e-6, len] {
            let t = l.inv_arclen(s, 1e-10);
            assert!((l.eval(t).dist(b) - s).abs() < 1e-8, "s {s}");
        }
    }

    #[test]
    fn exact_quarter_circle_of_eq9() {
        let a = 3.5;
        let c = TrigSpline::new(
            Vec3::new(a, 0.0, 0.0),
            Vec3::new(0.0, a, 0.0),
            Vec3::new(a, PI * a / 2.0, 0.0),
            Vec3::new(-PI * a / 2.0, a, 0.0),
            1.0,
            -1.0,
        );
        for i in 0..=50 {
            let u = i as f64 / 50.0;
            let th = PI * u / 2.0;
            assert!(c.eval(u).dist(Vec3::new(a * th.cos(), a * th.sin(), 0.0)) < 1e-12);
            assert!((c.curvature(u) - 1.0 / a).abs() < 1e-12);
        }
        assert!((c.arclen(1e-12) - PI * a / 2.0).abs() < 1e-11);
    }

    #[test]
    fn arcs_of_30_and_270_degrees() {
        let center = Vec3::new(5.0, -2.0, 1.0);
        let r = 2.5;
        for &deg in &[30.0_f64, 270.0, 90.0, 360.0] {
            let sweep = deg.to_radians();
            let end = center + Vec3::new(r * sweep.cos(), r * sweep.sin(), 0.0);
            let arc = Arc::from_center(center + Vec3::X * r, end, center, Vec3::Z, true, 0);
            let arc = arc.expect("arc");
            let parts = TrigSpline::arc(&arc).unwrap();
            assert_eq!(parts.len(), (deg / 90.0).ceil() as usize);
            assert!(parts[0].start().dist(arc.start()) < 1e-12);
            assert!(parts.last().unwrap().end().dist(arc.end()) < 1e-12);
            let mut len = 0.0;
            for (i, p) in parts.iter().enumerate() {
                len += p.arclen(1e-13);
                for j in 0..=20 {
                    let q = p.eval(j as f64 / 20.0);
                    assert!((q.dist(center) - r).abs() < 1e-12);
                    assert!((q.z - center.z).abs() < 1e-12);
                }
                if i > 0 {
                    let a = parts[i - 1].deriv(1.0).normalized().unwrap();
                    let b = p.deriv(0.0).normalized().unwrap();
                    assert!(a.dist(b) < 1e-12 && parts[i - 1].end().dist(p.start()) < 1e-12);
                }
            }
            assert!((len - r * sweep).abs() < 1e-10, "{deg}: {len}");
        }
    }

    #[test]
    fn free_curves_interpolate_with_c1_joints() {
        let pts: Vec<Vec3> = (0..10)
            .map(|i| {
                let x = i as f64;
                Vec3::new(x, (0.7 * x).sin() * 2.0, 0.1 * x)
            })
            .collect();
        let segs = TrigSpline::free_curve(&pts, 1.0, 0.5);
        assert_eq!(segs.len(), pts.len() - 3);
        for (i, s) in segs.iter().enumerate() {
            assert!(s.eval(0.0).dist(pts[i]) < 1e-12 && s.eval(1.0).dist(pts[i + 1]) < 1e-12);
            if i > 0 {
                // Eq. 5: equal derivatives (C1, not just G1).
                assert!(segs[i - 1].deriv(1.0).dist(s.deriv(0.0)) < 1e-12);
            }
        }
        let all = TrigSpline::free_curve_through(&pts, 1.0, 1.0 / 3.0);
        assert_eq!(all.len(), pts.len() - 1);
        assert_eq!(all[0].start(), pts[0]);
        assert!(all.last().unwrap().eval(1.0).dist(pts[9]) < 1e-12);
        for w in all.windows(2) {
            assert!(w[0].deriv(1.0).dist(w[1].deriv(0.0)) < 1e-12);
        }
        let last = all.last().unwrap().deriv(1.0).normalized().unwrap();
        assert!(last.dist((pts[9] - pts[8]).normalized().unwrap()) < 1e-12);
    }

    #[test]
    fn bbox_and_flatten_are_conservative() {
        for (c, acc) in [
            (sample(), 1e-4),
            (sample().subsegment(0.2, 0.7), 1e-4),
            (TrigSpline::line(Vec3::ZERO, Vec3::new(1e6, 1e6, 0.0)), 1.0),
            (
                TrigSpline::hermite(Vec3::ZERO, Vec3::ZERO, Vec3::X, Vec3::Y, 0.5),
                1e-5,
            ),
        ] {
            let b = c.bounding_box();
            let mut pts = vec![c.start()];
            c.flatten(acc, &mut |p| pts.push(p));
            assert_eq!(*pts.last().unwrap(), c.end());
            let n = pts.len() - 1;
            for i in 0..=4000 {
                let t = i as f64 / 4000.0;
                let p = c.eval(t);
                assert!(b.dist_sq(p) == 0.0, "{c:?} {t} {p:?} {b:?}");
                // Flattening is uniform in t only per piece; check against all chords.
                let d = pts
                    .windows(2)
                    .map(|w| crate::geom::Line::new(w[0], w[1]).dist_sq(p))
                    .fold(f64::INFINITY, f64::min);
                assert!(d.sqrt() <= acc * (1.0 + 1e-9), "{} pieces", n);
            }
            // The bound on |P''| holds at samples.
            let m = c.deriv2_bound(0.0, 1.0);
            for i in 0..=200 {
                assert!(c.deriv2(i as f64 / 200.0).norm() <= m);
            }
        }
    }

    #[test]
    fn nearest_and_curvature() {
        let c = sample();
        let p = c.eval(0.37) + Vec3::new(0.0, 0.0, 0.0);
        let n = c.nearest(p, 1e-12);
        assert!(n.distance_sq < 1e-18);
        assert!((n.t - 0.37).abs() < 1e-6);
        // Curvature against the finite-difference turning rate.
        let t = 0.5;
        let h = 1e-5;
        let ta = c.deriv(t - h).normalized().unwrap();
        let tb = c.deriv(t + h).normalized().unwrap();
        let ds = c.deriv(t).norm() * 2.0 * h;
        assert!((ta.angle_to(tb) / ds - c.curvature(t)).abs() < 1e-5);
    }
}
