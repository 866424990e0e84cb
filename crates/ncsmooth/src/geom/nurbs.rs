//! Non-uniform rational B-spline curves of any degree up to [`MAX_DEGREE`], with a clamped
//! knot vector. Algorithms from Piegl and Tiller, *The NURBS Book* (2nd ed.):
//! A2.1 (find span), A2.2 (basis functions), A2.3 (basis derivatives), A4.1/A4.2 (rational
//! point and derivatives, in homogeneous coordinates), A5.1 (knot insertion) and A5.6
//! (decomposition into Bézier pieces, used for flattening with a proved bound).
//!
//! The curve is parametrised on `t in [0, 1]`, mapped linearly onto the knot domain
//! `[U[p], U[n]]`; derivatives are with respect to `t`.

use super::cubic_bez::CubicBez;
use super::line::Line;
use super::traits::*;
use super::vec3::{Aabb, Vec3};
use serde::{Deserialize, Serialize};

/// Highest supported degree (stack buffers are sized by it).
pub const MAX_DEGREE: usize = 9;

/// Deepest recursion when flattening one rational Bézier piece.
const MAX_FLATTEN_DEPTH: u32 = 40;

/// Homogeneous point `(w x, w y, w z, w)`.
type Hom = [f64; 4];

#[inline]
fn hom(p: Vec3, w: f64) -> Hom {
    [p.x * w, p.y * w, p.z * w, w]
}
#[inline]
fn proj(h: Hom) -> Vec3 {
    Vec3::new(h[0] / h[3], h[1] / h[3], h[2] / h[3])
}
#[inline]
fn hlerp(a: Hom, b: Hom, t: f64) -> Hom {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
        a[3] + (b[3] - a[3]) * t,
    ]
}

/// A NURBS curve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Nurbs {
    degree: usize,
    ctrl: Vec<Vec3>,
    weights: Vec<f64>,
    knots: Vec<f64>,
}

/// NURBS Book A2.2: the `p + 1` non-zero degree-`p` basis functions at `u` in knot span
/// `span` (`knots[span] <= u < knots[span + 1]`, `p <= MAX_DEGREE`); entry `j` is
/// `N_(span-p+j)`. They are non-negative and sum to one. The one copy of A2.2: the global
/// interpolation and the band fit call it; [`Nurbs::ders_basis`] (A2.3) builds the same
/// triangle with the same arithmetic, so its zeroth row equals this bit for bit.
pub(crate) fn basis_funs(knots: &[f64], span: usize, u: f64, p: usize) -> [f64; MAX_DEGREE + 1] {
    let mut out = [0.0; MAX_DEGREE + 1];
    let mut left = [0.0; MAX_DEGREE + 1];
    let mut right = [0.0; MAX_DEGREE + 1];
    out[0] = 1.0;
    for j in 1..=p {
        left[j] = u - knots[span + 1 - j];
        right[j] = knots[span + j] - u;
        let mut saved = 0.0;
        for r in 0..j {
            let temp = out[r] / (right[r + 1] + left[j - r]);
            out[r] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        out[j] = saved;
    }
    out
}

impl Nurbs {
    /// Builds a curve, checking that `knots.len() == ctrl.len() + degree + 1`, the knots are
    /// finite and non-decreasing and clamped (first and last `degree + 1` equal), the
    /// weights are positive and finite, and `1 <= degree <= MAX_DEGREE`.
    pub fn new(
        degree: usize,
        ctrl: Vec<Vec3>,
        weights: Vec<f64>,
        knots: Vec<f64>,
    ) -> Option<Nurbs> {
        let n = ctrl.len();
        let ok = (1..=MAX_DEGREE).contains(&degree)
            && n > degree
            && weights.len() == n
            && knots.len() == n + degree + 1
            && knots.iter().all(|k| k.is_finite())
            && knots.windows(2).all(|w| w[0] <= w[1])
            && knots[..=degree].iter().all(|&k| k == knots[0])
            && knots[n..].iter().all(|&k| k == knots[n])
            && knots[n] > knots[degree]
            && weights.iter().all(|&w| w > 0.0 && w.is_finite())
            && ctrl.iter().all(|p| p.is_finite());
        ok.then_some(Nurbs {
            degree,
            ctrl,
            weights,
            knots,
        })
    }

    /// Non-rational B-spline (all weights 1).
    pub fn bspline(degree: usize, ctrl: Vec<Vec3>, knots: Vec<f64>) -> Option<Nurbs> {
        let w = vec![1.0; ctrl.len()];
        Nurbs::new(degree, ctrl, w, knots)
    }

    /// Degree.
    pub fn degree(&self) -> usize {
        self.degree
    }
    /// Control points.
    pub fn ctrl(&self) -> &[Vec3] {
        &self.ctrl
    }
    /// Weights.
    pub fn weights(&self) -> &[f64] {
        &self.weights
    }
    /// Knot vector.
    pub fn knots(&self) -> &[f64] {
        &self.knots
    }
    /// Knot domain `[U[p], U[n]]`.
    pub fn domain(&self) -> (f64, f64) {
        (self.knots[self.degree], self.knots[self.ctrl.len()])
    }
    /// Maps `t in [0, 1]` to the knot parameter.
    #[inline]
    pub fn param(&self, t: f64) -> f64 {
        let (a, b) = self.domain();
        (a + (b - a) * t).clamp(a, b)
    }
    /// Maps a knot parameter to `t`.
    #[inline]
    pub fn t_of(&self, u: f64) -> f64 {
        let (a, b) = self.domain();
        (u - a) / (b - a)
    }

    /// A2.1: index of the knot span containing `u` (the last non-empty span at the end).
    pub fn find_span(&self, u: f64) -> usize {
        let n = self.ctrl.len() - 1;
        let p = self.degree;
        let k = &self.knots;
        if u >= k[n + 1] {
            return n;
        }
        if u <= k[p] {
            return p;
        }
        // Largest i with k[i] <= u, in [p, n].
        let mut lo = p;
        let mut hi = n + 1;
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if u < k[mid] {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        lo
    }

    /// A2.3: basis functions and their derivatives up to order `nd` (<= 2) at `u` in `span`;
    /// `ders[k][j]` is the k-th derivative of `N_{span-p+j}`.
    pub(crate) fn ders_basis(&self, span: usize, u: f64, nd: usize) -> [[f64; MAX_DEGREE + 1]; 3] {
        let p = self.degree;
        let k = &self.knots;
        let mut ndu = [[0.0; MAX_DEGREE + 1]; MAX_DEGREE + 1];
        let mut left = [0.0; MAX_DEGREE + 1];
        let mut right = [0.0; MAX_DEGREE + 1];
        ndu[0][0] = 1.0;
        for j in 1..=p {
            left[j] = u - k[span + 1 - j];
            right[j] = k[span + j] - u;
            let mut saved = 0.0;
            for r in 0..j {
                ndu[j][r] = right[r + 1] + left[j - r];
                let temp = ndu[r][j - 1] / ndu[j][r];
                ndu[r][j] = saved + right[r + 1] * temp;
                saved = left[j - r] * temp;
            }
            ndu[j][j] = saved;
        }
        let mut ders = [[0.0; MAX_DEGREE + 1]; 3];
        for j in 0..=p {
            ders[0][j] = ndu[j][p];
        }
        let nd = nd.min(p).min(2);
        let mut a = [[0.0; MAX_DEGREE + 1]; 2];
        for r in 0..=p {
            let (mut s1, mut s2) = (0usize, 1usize);
            a[0][0] = 1.0;
            for kk in 1..=nd {
                let mut d = 0.0;
                let rk = r as isize - kk as isize;
                let pk = p - kk;
                if r >= kk {
                    a[s2][0] = a[s1][0] / ndu[pk + 1][rk as usize];
                    d = a[s2][0] * ndu[rk as usize][pk];
                }
                let j1 = if rk >= -1 { 1 } else { (-rk) as usize };
                let j2 = if r as isize - 1 <= pk as isize {
                    kk - 1
                } else {
                    p - r
                };
                for j in j1..=j2 {
                    let idx = (rk + j as isize) as usize;
                    a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][idx];
                    d += a[s2][j] * ndu[idx][pk];
                }
                if r <= pk {
                    a[s2][kk] = -a[s1][kk - 1] / ndu[pk + 1][r];
                    d += a[s2][kk] * ndu[r][pk];
                }
                ders[kk][r] = d;
                std::mem::swap(&mut s1, &mut s2);
            }
        }
        let mut fac = p as f64;
        for kk in 1..=nd {
            for j in 0..=p {
                ders[kk][j] *= fac;
            }
            fac *= (p - kk) as f64;
        }
        ders
    }

    /// Homogeneous derivatives `A^(k)` (k = 0..=nd) with respect to the knot parameter.
    fn hom_ders(&self, u: f64, nd: usize) -> [Hom; 3] {
        let span = self.find_span(u);
        let ders = self.ders_basis(span, u, nd);
        let mut out = [[0.0; 4]; 3];
        let p = self.degree;
        for (k, o) in out.iter_mut().enumerate().take(nd + 1) {
            for j in 0..=p {
                let i = span - p + j;
                let w = self.weights[i] * ders[k][j];
                let c = self.ctrl[i];
                o[0] += c.x * w;
                o[1] += c.y * w;
                o[2] += c.z * w;
                o[3] += w;
            }
        }
        out
    }

    /// A4.2: point and first two derivatives with respect to the knot parameter `u`.
    pub fn ders_at_param(&self, u: f64) -> [Vec3; 3] {
        let a = self.hom_ders(u, 2);
        let w = a[0][3];
        let c0 = proj(a[0]);
        let a1 = Vec3::new(a[1][0], a[1][1], a[1][2]);
        let a2 = Vec3::new(a[2][0], a[2][1], a[2][2]);
        let c1 = (a1 - c0 * a[1][3]) / w;
        let c2 = (a2 - c1 * (2.0 * a[1][3]) - c0 * a[2][3]) / w;
        [c0, c1, c2]
    }

    /// Point at the knot parameter `u` (A4.1).
    pub fn point_at_param(&self, u: f64) -> Vec3 {
        let a = self.hom_ders(u, 0);
        proj(a[0])
    }

    /// A5.1: the same curve with the knot `u` inserted `r` times (capped so that the
    /// multiplicity does not exceed the degree). The shape is unchanged.
    pub fn insert_knot(&self, u: f64, r: usize) -> Nurbs {
        let p = self.degree;
        let (a, b) = self.domain();
        if !(u > a && u < b) {
            return self.clone();
        }
        let k = self.find_span(u);
        let s = self.knots.iter().filter(|&&x| x == u).count();
        let r = r.min(p.saturating_sub(s));
        if r == 0 {
            return self.clone();
        }
        let np = self.ctrl.len() - 1;
        let pw: Vec<Hom> = self
            .ctrl
            .iter()
            .zip(&self.weights)
            .map(|(&c, &w)| hom(c, w))
            .collect();
        let mut uq = Vec::with_capacity(self.knots.len() + r);
        uq.extend_from_slice(&self.knots[..=k]);
        uq.extend(std::iter::repeat_n(u, r));
        uq.extend_from_slice(&self.knots[k + 1..]);
        let mut qw = vec![[0.0; 4]; np + 1 + r];
        qw[..=(k - p)].copy_from_slice(&pw[..=(k - p)]);
        qw[(k - s + r)..=(np + r)].copy_from_slice(&pw[(k - s)..=np]);
        let mut rw: Vec<Hom> = (0..=(p - s)).map(|i| pw[k - p + i]).collect();
        let mut l = 0;
        for j in 1..=r {
            l = k - p + j;
            for i in 0..=(p - j - s) {
                let alpha = (u - self.knots[l + i]) / (self.knots[i + k + 1] - self.knots[l + i]);
                rw[i] = hlerp(rw[i], rw[i + 1], alpha);
            }
            qw[l] = rw[0];
            qw[k + r - j - s] = rw[p - j - s];
        }
        if l + 1 < k - s {
            qw[(l + 1)..(k - s)].copy_from_slice(&rw[1..(k - s - l)]);
        }
        let weights: Vec<f64> = qw.iter().map(|h| h[3]).collect();
        let ctrl: Vec<Vec3> = qw.iter().map(|&h| proj(h)).collect();
        Nurbs {
            degree: p,
            ctrl,
            weights,
            knots: uq,
        }
    }

    /// The cubic Bézier pieces of a non-rational cubic B-spline (all weights 1), one per
    /// non-empty knot span, in order (A5.6): the same curve, each piece a polynomial that
    /// evaluates without a knot search. `None` for another degree or a rational curve.
    pub fn cubic_bezier_pieces(&self) -> Option<Vec<CubicBez>> {
        if self.degree != 3 || self.weights.iter().any(|&w| w != 1.0) {
            return None;
        }
        let h = |q: &Hom| Vec3::new(q[0] / q[3], q[1] / q[3], q[2] / q[3]);
        Some(
            self.bezier_pieces()
                .iter()
                .map(|q| CubicBez::new(h(&q[0]), h(&q[1]), h(&q[2]), h(&q[3])))
                .collect(),
        )
    }

    /// A5.6: the rational Bézier pieces (homogeneous control points, `degree + 1` each),
    /// one per non-empty knot span, in order.
    pub fn bezier_pieces(&self) -> Vec<Vec<[f64; 4]>> {
        let p = self.degree;
        let u = &self.knots;
        let m = u.len() - 1;
        let pw: Vec<Hom> = self
            .ctrl
            .iter()
            .zip(&self.weights)
            .map(|(&c, &w)| hom(c, w))
            .collect();
        let mut out: Vec<Vec<Hom>> = Vec::new();
        let mut cur: Vec<Hom> = pw[..=p].to_vec();
        let mut next: Vec<Hom> = vec![[0.0; 4]; p + 1];
        let mut alphas = [0.0; MAX_DEGREE + 1];
        let mut a = p;
        let mut b = p + 1;
        while b < m {
            let i = b;
            while b < m && u[b + 1] == u[b] {
                b += 1;
            }
            let mult = b - i + 1;
            if mult < p {
                let numer = u[b] - u[a];
                for j in ((mult + 1)..=p).rev() {
                    alphas[j - mult - 1] = numer / (u[a + j] - u[a]);
                }
                let r = p - mult;
                for j in 1..=r {
                    let save = r - j;
                    let s = mult + j;
                    for k in (s..=p).rev() {
                        let alpha = alphas[k - s];
                        cur[k] = hlerp(cur[k - 1], cur[k], alpha);
                    }
                    if b < m {
                        next[save] = cur[p];
                    }
                }
            }
            out.push(std::mem::replace(&mut cur, vec![[0.0; 4]; p + 1]));
            if b < m {
                // Entries below `keep` were produced by the insertion above; the rest are
                // the next original control points.
                let keep = p - mult;
                cur[..keep].copy_from_slice(&next[..keep]);
                cur[keep..=p].copy_from_slice(&pw[(b - mult)..=b]);
                a = b;
                b += 1;
            }
        }
        out
    }

    /// Arc length of the knot span `[ua, ub]` (t-space quadrature).
    fn span_arclen(&self, ua: f64, ub: f64, accuracy: f64) -> f64 {
        arclen_adaptive(self, self.t_of(ua), self.t_of(ub), accuracy)
    }

    /// Distinct knot values of the domain, in order (span boundaries).
    fn breaks(&self) -> Vec<f64> {
        let (a, b) = self.domain();
        let mut v: Vec<f64> = vec![a];
        for &k in &self.knots {
            if k > *v.last().unwrap_or(&a) && k <= b {
                v.push(k);
            }
        }
        v
    }
}

/// Halves a rational Bézier (homogeneous) at t = 1/2.
fn split_hom(c: &[Hom]) -> (Vec<Hom>, Vec<Hom>) {
    let n = c.len();
    let mut work = c.to_vec();
    let mut left = Vec::with_capacity(n);
    let mut right = vec![[0.0; 4]; n];
    left.push(work[0]);
    right[n - 1] = work[n - 1];
    for r in 1..n {
        for i in 0..(n - r) {
            work[i] = hlerp(work[i], work[i + 1], 0.5);
        }
        left.push(work[0]);
        right[n - 1 - r] = work[n - 1 - r];
    }
    (left, right)
}

fn flatten_hom<F: FnMut(Vec3)>(c: &[Hom], accuracy: f64, depth: u32, sink: &mut F) {
    let a = proj(c[0]);
    let b = proj(c[c.len() - 1]);
    let chord = Line::new(a, b);
    let err = c[1..c.len() - 1]
        .iter()
        .map(|&h| chord.dist_sq(proj(h)))
        .fold(0.0, f64::max)
        .sqrt();
    if err <= accuracy || depth >= MAX_FLATTEN_DEPTH {
        sink(b);
        return;
    }
    let (l, r) = split_hom(c);
    flatten_hom(&l, accuracy, depth + 1, sink);
    flatten_hom(&r, accuracy, depth + 1, sink);
}

impl ParamCurve for Nurbs {
    fn eval(&self, t: f64) -> Vec3 {
        self.point_at_param(self.param(t))
    }
    fn start(&self) -> Vec3 {
        self.ctrl[0]
    }
    fn end(&self) -> Vec3 {
        self.ctrl[self.ctrl.len() - 1]
    }
}

impl ParamCurveDeriv for Nurbs {
    fn deriv(&self, t: f64) -> Vec3 {
        let (a, b) = self.domain();
        self.ders_at_param(self.param(t))[1] * (b - a)
    }
    fn deriv2(&self, t: f64) -> Vec3 {
        let (a, b) = self.domain();
        self.ders_at_param(self.param(t))[2] * ((b - a) * (b - a))
    }
    fn ders(&self, t: f64) -> [Vec3; 3] {
        let (a, b) = self.domain();
        let [p, d1, d2] = self.ders_at_param(self.param(t));
        [p, d1 * (b - a), d2 * ((b - a) * (b - a))]
    }
}

impl ParamCurveArclen for Nurbs {
    /// Sum of adaptive Gauss-Legendre lengths of the knot spans (the integrand may have
    /// kinks at knots), the accuracy shared among the spans.
    fn arclen(&self, accuracy: f64) -> f64 {
        let br = self.breaks();
        let share = accuracy / (br.len().max(2) - 1) as f64;
        br.windows(2)
            .map(|w| self.span_arclen(w[0], w[1], share))
            .sum()
    }
    /// Finds the span by accumulated span lengths, then safeguarded Newton inside it.
    fn inv_arclen(&self, s: f64, accuracy: f64) -> f64 {
        if s <= 0.0 {
            return 0.0;
        }
        let br = self.breaks();
        let share = accuracy * 0.25 / (br.len().max(2) - 1) as f64;
        let mut acc_len = 0.0;
        for w in br.windows(2) {
            let l = self.span_arclen(w[0], w[1], share);
            if acc_len + l >= s {
                let (t0, t1) = (self.t_of(w[0]), self.t_of(w[1]));
                let target = s - acc_len;
                let (mut lo, mut hi) = (t0, t1);
                let mut t = t0 + (t1 - t0) * (target / l.max(f64::MIN_POSITIVE));
                for _ in 0..60 {
                    let err = arclen_adaptive(self, t0, t, accuracy * 0.25) - target;
                    if err.abs() <= accuracy * 0.5 {
                        break;
                    }
                    if err > 0.0 {
                        hi = t;
                    } else {
                        lo = t;
                    }
                    let sp = self.deriv(t).norm();
                    let nt = t - err / sp;
                    t = if sp > 0.0 && nt > lo && nt < hi {
                        nt
                    } else {
                        0.5 * (lo + hi)
                    };
                    if hi - lo < 1e-16 {
                        break;
                    }
                }
                return t;
            }
            acc_len += l;
        }
        1.0
    }
}

/// Samples per knot span in the nearest-point search.
const NEAREST_SAMPLES_PER_SPAN: usize = 4;

impl ParamCurveNearest for Nurbs {
    /// Samples every knot span, then refines around the best sample by Newton iteration
    /// ([`nearest_generic`] on the bracketing spans). Reliable when no span wraps around
    /// the query point more than once.
    fn nearest(&self, p: Vec3, accuracy: f64) -> Nearest {
        let br = self.breaks();
        let mut best = Nearest {
            t: 0.0,
            distance_sq: f64::INFINITY,
        };
        let mut best_span = 0;
        for (si, w) in br.windows(2).enumerate() {
            for k in 0..=NEAREST_SAMPLES_PER_SPAN {
                let u = w[0] + (w[1] - w[0]) * k as f64 / NEAREST_SAMPLES_PER_SPAN as f64;
                let d = self.point_at_param(u).dist_sq(p);
                if d < best.distance_sq {
                    best = Nearest {
                        t: self.t_of(u),
                        distance_sq: d,
                    };
                    best_span = si;
                }
            }
        }
        // Refine on the best span and its neighbours.
        let lo = self.t_of(br[best_span.saturating_sub(1)]);
        let hi = self.t_of(br[(best_span + 2).min(br.len() - 1)]);
        let sub = SubCurve {
            c: self,
            t0: lo,
            t1: hi,
        };
        let n = nearest_generic(&sub, p, accuracy);
        if n.distance_sq < best.distance_sq {
            best = Nearest {
                t: lo + (hi - lo) * n.t,
                distance_sq: n.distance_sq,
            };
        }
        best
    }
}

/// A reparametrised window `[t0, t1]` of another curve.
struct SubCurve<'a, C> {
    c: &'a C,
    t0: f64,
    t1: f64,
}
impl<C: ParamCurve> ParamCurve for SubCurve<'_, C> {
    fn eval(&self, t: f64) -> Vec3 {
        self.c.eval(self.t0 + (self.t1 - self.t0) * t)
    }
}
impl<C: ParamCurveDeriv> ParamCurveDeriv for SubCurve<'_, C> {
    fn deriv(&self, t: f64) -> Vec3 {
        self.c.deriv(self.t0 + (self.t1 - self.t0) * t) * (self.t1 - self.t0)
    }
    fn deriv2(&self, t: f64) -> Vec3 {
        let h = self.t1 - self.t0;
        self.c.deriv2(self.t0 + h * t) * (h * h)
    }
}

impl ParamCurveCurvature for Nurbs {}

impl ParamCurveBBox for Nurbs {
    /// Box of the control points (convex hull property, positive weights).
    fn bounding_box(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for &p in &self.ctrl {
            b.include(p);
        }
        b
    }
}

impl Flatten for Nurbs {
    /// Decomposes into rational Bézier pieces (A5.6) and halves each until every inner
    /// control point is within `accuracy` of the chord. With positive weights a rational
    /// Bézier lies in the convex hull of its control points, so the same argument as for
    /// [`super::CubicBez`] bounds the deviation both ways.
    fn flatten<F: FnMut(Vec3)>(&self, accuracy: f64, sink: &mut F) {
        for piece in self.bezier_pieces() {
            flatten_hom(&piece, accuracy, 0, sink);
        }
    }
}

/// A non-rational cubic [`Nurbs`] as its Bézier pieces ([`Nurbs::cubic_bezier_pieces`]),
/// for code that evaluates one curve many times (the interpolator's steps, the planning
/// grid): a point or derivative is a binary search over the breakpoints and a cubic
/// polynomial, instead of a knot search and de Boor's recurrences. The same curve and
/// parameter `t` as the NURBS (values equal up to rounding, about 1e-15 relative).
#[derive(Clone, Debug, PartialEq)]
pub struct PreparedNurbs {
    pieces: Vec<CubicBez>,
    /// `t` of the pieces' ends: `breaks[i]..breaks[i + 1]` is piece `i`.
    breaks: Vec<f64>,
}

impl PreparedNurbs {
    /// Prepares `n`; `None` unless it is a non-rational cubic.
    pub fn new(n: &Nurbs) -> Option<PreparedNurbs> {
        let pieces = n.cubic_bezier_pieces()?;
        let breaks: Vec<f64> = n.breaks().into_iter().map(|k| n.t_of(k)).collect();
        (breaks.len() == pieces.len() + 1 && !pieces.is_empty())
            .then_some(PreparedNurbs { pieces, breaks })
    }
    /// The breakpoints in `t` (piece ends), in order.
    pub fn breaks(&self) -> &[f64] {
        &self.breaks
    }
    /// The piece holding `t`, its local parameter and `dt_local / dt`.
    #[inline]
    fn locate(&self, t: f64) -> (&CubicBez, f64, f64) {
        let n = self.pieces.len();
        let i = self.breaks[1..n].partition_point(|&b| b <= t);
        let (a, b) = (self.breaks[i], self.breaks[i + 1]);
        let h = b - a;
        (&self.pieces[i], ((t - a) / h).clamp(0.0, 1.0), 1.0 / h)
    }
}

impl ParamCurve for PreparedNurbs {
    #[inline]
    fn eval(&self, t: f64) -> Vec3 {
        let (c, s, _) = self.locate(t);
        c.eval(s)
    }
    fn start(&self) -> Vec3 {
        self.pieces[0].p0
    }
    fn end(&self) -> Vec3 {
        self.pieces[self.pieces.len() - 1].p3
    }
}

impl ParamCurveDeriv for PreparedNurbs {
    #[inline]
    fn deriv(&self, t: f64) -> Vec3 {
        let (c, s, k) = self.locate(t);
        c.deriv(s) * k
    }
    #[inline]
    fn deriv2(&self, t: f64) -> Vec3 {
        let (c, s, k) = self.locate(t);
        c.deriv2(s) * (k * k)
    }
    #[inline]
    fn ders(&self, t: f64) -> [Vec3; 3] {
        let (c, s, k) = self.locate(t);
        [c.eval(s), c.deriv(s) * k, c.deriv2(s) * (k * k)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    /// Quarter circle of radius 1 as a rational quadratic.
    fn quarter_circle() -> Nurbs {
        let w = std::f64::consts::FRAC_1_SQRT_2;
        Nurbs::new(
            2,
            vec![Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
            vec![1.0, w, 1.0],
            vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
        )
        .unwrap()
    }

    fn wavy() -> Nurbs {
        let ctrl: Vec<Vec3> = (0..9)
            .map(|i| Vec3::new(i as f64, ((i * 7) % 5) as f64 - 2.0, (i % 3) as f64 * 0.5))
            .collect();
        let weights = vec![1.0, 0.5, 2.0, 1.0, 1.5, 0.8, 1.0, 3.0, 1.0];
        let knots = vec![
            0.0, 0.0, 0.0, 0.0, 0.1, 0.3, 0.3, 0.55, 0.8, 1.0, 1.0, 1.0, 1.0,
        ];
        Nurbs::new(3, ctrl, weights, knots).unwrap()
    }

    #[test]
    fn rational_quarter_circle_is_exact() {
        let c = quarter_circle();
        for i in 0..=100 {
            let p = c.eval(i as f64 / 100.0);
            assert_abs_diff_eq!(p.norm(), 1.0, epsilon = 1e-14);
            assert_abs_diff_eq!(c.curvature(i as f64 / 100.0), 1.0, epsilon = 1e-12);
        }
        assert_abs_diff_eq!(
            c.arclen(1e-12),
            std::f64::consts::FRAC_PI_2,
            epsilon = 1e-11
        );
        let t = c.inv_arclen(std::f64::consts::FRAC_PI_4, 1e-12);
        let p = c.eval(t);
        assert_abs_diff_eq!(p.x, p.y, epsilon = 1e-10);
    }

    #[test]
    fn a2_2_is_the_zeroth_row_of_a2_3_and_a_partition_of_unity() {
        let c = wavy();
        for i in 0..=200 {
            let u = i as f64 / 200.0;
            let span = c.find_span(u);
            let n = basis_funs(c.knots(), span, u, c.degree());
            let ders = c.ders_basis(span, u, 2);
            for j in 0..=c.degree() {
                assert_eq!(n[j].to_bits(), ders[0][j].to_bits(), "u={u} j={j}");
                assert!(n[j] >= 0.0);
            }
            let sum: f64 = n.iter().sum();
            assert_abs_diff_eq!(sum, 1.0, epsilon = 1e-14);
        }
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let c = wavy();
        let h = 1e-6;
        // Off the knots (0.3 is a double knot: only C1 there).
        for i in 0..40 {
            let t = (i as f64 + 0.37) / 40.0;
            let fd = (c.eval(t + h) - c.eval(t - h)) / (2.0 * h);
            assert!(
                (fd - c.deriv(t)).norm() < 1e-5 * (1.0 + c.deriv(t).norm()),
                "t={t}"
            );
            let fd2 = (c.deriv(t + h) - c.deriv(t - h)) / (2.0 * h);
            assert!(
                (fd2 - c.deriv2(t)).norm() < 1e-4 * (1.0 + c.deriv2(t).norm()),
                "t={t}"
            );
        }
    }

    #[test]
    fn knot_insertion_keeps_the_curve() {
        let c = wavy();
        for &(u, r) in &[(0.2, 1), (0.3, 2), (0.55, 3), (0.9, 2)] {
            let d = c.insert_knot(u, r);
            for i in 0..=200 {
                let uu = i as f64 / 200.0;
                assert!(
                    c.point_at_param(uu).dist(d.point_at_param(uu)) < 1e-12,
                    "u={u} r={r}"
                );
            }
        }
    }

    #[test]
    fn bezier_decomposition_matches() {
        let c = wavy();
        let pieces = c.bezier_pieces();
        let br = c.breaks();
        assert_eq!(pieces.len(), br.len() - 1);
        for (piece, w) in pieces.iter().zip(br.windows(2)) {
            // Evaluate the rational Bézier at s by de Casteljau and compare.
            for k in 0..=10 {
                let s = k as f64 / 10.0;
                let mut work = piece.clone();
                for r in 1..work.len() {
                    for i in 0..(work.len() - r) {
                        work[i] = hlerp(work[i], work[i + 1], s);
                    }
                }
                let u = w[0] + (w[1] - w[0]) * s;
                assert!(proj(work[0]).dist(c.point_at_param(u)) < 1e-12);
            }
        }
    }

    #[test]
    fn flatten_within_bound() {
        let c = wavy();
        let acc = 1e-3;
        let mut pts = vec![c.start()];
        c.flatten(acc, &mut |p| pts.push(p));
        assert!(pts.last().unwrap().dist(c.end()) < 1e-12);
        for i in 0..=3000 {
            let p = c.eval(i as f64 / 3000.0);
            let d = pts
                .windows(2)
                .map(|w| Line::new(w[0], w[1]).dist_sq(p))
                .fold(f64::INFINITY, f64::min);
            assert!(d.sqrt() <= acc * (1.0 + 1e-9));
        }
    }

    #[test]
    fn nearest_finds_the_foot() {
        let c = wavy();
        for i in 1..20 {
            let t = i as f64 / 20.0;
            let p = c.eval(t);
            let n = c.nearest(p, 1e-9);
            assert!(
                n.distance_sq.sqrt() < 1e-7,
                "t={t} d={}",
                n.distance_sq.sqrt()
            );
        }
    }

    #[test]
    fn rejects_bad_input() {
        assert!(Nurbs::bspline(3, vec![Vec3::ZERO; 3], vec![0.0; 7]).is_none());
        assert!(Nurbs::new(
            1,
            vec![Vec3::ZERO, Vec3::X],
            vec![1.0, -1.0],
            vec![0.0, 0.0, 1.0, 1.0]
        )
        .is_none());
    }

    #[test]
    fn prepared_nurbs_is_the_same_curve() {
        // The wavy curve's control points and knots (a double knot at 0.3), unit weights.
        let w = wavy();
        let c = Nurbs::bspline(3, w.ctrl().to_vec(), w.knots().to_vec()).unwrap();
        let p = PreparedNurbs::new(&c).unwrap();
        assert_eq!(p.breaks().len(), 6);
        for k in 0..=400 {
            let t = k as f64 / 400.0;
            let (a, b) = (c.ders(t), p.ders(t));
            for d in 0..3 {
                let scale = a[d].norm().max(1.0);
                assert!(
                    a[d].dist(b[d]) <= 1e-11 * scale,
                    "t {t} d{d}: {:?} {:?}",
                    a[d],
                    b[d]
                );
            }
        }
        assert_eq!(p.start(), c.start());
        assert!(p.end().dist(c.end()) < 1e-12);
        assert!(PreparedNurbs::new(&w).is_none(), "rational");
    }
}
