//! Small, opt-in curve capabilities in the spirit of kurbo: a curve is evaluated on the
//! parameter interval `t in [0, 1]`, and each capability is its own trait so that a
//! curve type implements only what it can do well.
//!
//! Exact closed forms are used where they exist (lines, arcs, helices). Everything
//! else that approximates takes an explicit `accuracy` in millimetres and documents
//! what it bounds:
//!
//! * [`ParamCurveArclen::arclen`]: the absolute error of the returned length, as estimated
//!   by adaptive Gauss-Legendre quadrature ([`arclen_adaptive`]).
//! * [`ParamCurveArclen::inv_arclen`]: the error of the arc length at the returned parameter.
//! * [`ParamCurveNearest::nearest`]: the error of the returned distance.
//! * [`Flatten::flatten`]: a *guaranteed* bound on the distance between the curve and the
//!   emitted polyline (both ways), proved per curve type in its `flatten` doc.

use super::vec3::{Aabb, Vec3};

/// Gauss-Legendre nodes (on [-1, 1]) and weights, 8 points, symmetric: `(node, weight)`
/// for the positive half.
const GL8: [(f64, f64); 4] = [
    (0.183_434_642_495_649_8, 0.362_683_783_378_362),
    (0.525_532_409_916_329, 0.313_706_645_877_887_3),
    (0.796_666_477_413_626_7, 0.222_381_034_453_374_5),
    (0.960_289_856_497_536_3, 0.101_228_536_290_376_26),
];

/// Deepest bisection level of the adaptive quadrature: 2^-MAX_ARCLEN_DEPTH of the parameter
/// range. Reaching it means the integrand is not smooth at that scale (a cusp); the estimate
/// is then accepted as it stands.
const MAX_ARCLEN_DEPTH: u32 = 24;

/// A curve evaluated on `t in [0, 1]`.
pub trait ParamCurve {
    /// Point at parameter `t`.
    fn eval(&self, t: f64) -> Vec3;
    /// Start point (`eval(0)`, possibly exact).
    fn start(&self) -> Vec3 {
        self.eval(0.0)
    }
    /// End point (`eval(1)`, possibly exact).
    fn end(&self) -> Vec3 {
        self.eval(1.0)
    }
}

/// First and second derivatives with respect to `t`.
pub trait ParamCurveDeriv: ParamCurve {
    /// dC/dt.
    fn deriv(&self, t: f64) -> Vec3;
    /// d^2C/dt^2.
    fn deriv2(&self, t: f64) -> Vec3;
    /// Point, first and second derivative at `t` together (curves whose evaluation shares
    /// work between them, such as NURBS, compute all three in one pass).
    fn ders(&self, t: f64) -> [Vec3; 3] {
        [self.eval(t), self.deriv(t), self.deriv2(t)]
    }
}

/// Arc length and its inverse.
pub trait ParamCurveArclen: ParamCurve {
    /// Length of the curve, with absolute error at most `accuracy` (mm) for smooth curves;
    /// exact curves ignore `accuracy`.
    fn arclen(&self, accuracy: f64) -> f64;
    /// Parameter `t` at which the arc length from the start equals `s` (clamped to the
    /// curve), such that the arc length at `t` is within `accuracy` of `s`.
    fn inv_arclen(&self, s: f64, accuracy: f64) -> f64;
}

/// Result of a nearest-point query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Nearest {
    /// Parameter of the nearest point.
    pub t: f64,
    /// Squared distance to it.
    pub distance_sq: f64,
}

/// Nearest point on the curve.
pub trait ParamCurveNearest {
    /// Nearest point on the curve to `p`; the returned distance is within `accuracy`
    /// (mm) of the true minimum for the exact implementations and in practice for the
    /// numerical ones (see each implementation).
    fn nearest(&self, p: Vec3, accuracy: f64) -> Nearest;
}

/// Curvature.
pub trait ParamCurveCurvature: ParamCurveDeriv {
    /// Curvature vector at `t` (1/mm, pointing to the centre of curvature); zero where
    /// the parametric speed vanishes.
    fn curvature_vec(&self, t: f64) -> Vec3 {
        curvature_vec_from(self.deriv(t), self.deriv2(t))
    }
    /// Unsigned curvature at `t` (1/mm).
    fn curvature(&self, t: f64) -> f64 {
        self.curvature_vec(t).norm()
    }
}

/// A conservative axis-aligned bounding box.
pub trait ParamCurveBBox {
    /// A box that contains the whole curve (not necessarily the tightest).
    fn bounding_box(&self) -> Aabb;
}

/// Approximation by a polyline with a guaranteed bound.
pub trait Flatten {
    /// Emits the points of a polyline that approximates the curve, without the start
    /// point and ending exactly at the end point. Every point of the curve lies within
    /// `accuracy` (mm) of the polyline and every point of the polyline within `accuracy`
    /// of the curve.
    fn flatten<F: FnMut(Vec3)>(&self, accuracy: f64, sink: &mut F);
}

/// Curvature vector from the first and second derivatives:
/// `kappa = (d2 - (d2 . t) t) / |d1|^2` with `t = d1 / |d1|`.
#[inline]
pub fn curvature_vec_from(d1: Vec3, d2: Vec3) -> Vec3 {
    let s2 = d1.norm_sq();
    if s2 <= f64::MIN_POSITIVE || !s2.is_finite() {
        return Vec3::ZERO;
    }
    (d2 - d1 * (d2.dot(d1) / s2)) / s2
}

fn gauss8<C: ParamCurveDeriv + ?Sized>(c: &C, a: f64, b: f64) -> f64 {
    let h = 0.5 * (b - a);
    let m = 0.5 * (a + b);
    let mut s = 0.0;
    for &(x, w) in &GL8 {
        s += w * (c.deriv(m - h * x).norm() + c.deriv(m + h * x).norm());
    }
    s * h
}

fn arclen_rec<C: ParamCurveDeriv + ?Sized>(
    c: &C,
    a: f64,
    b: f64,
    whole: f64,
    accuracy: f64,
    depth: u32,
) -> f64 {
    let m = 0.5 * (a + b);
    let left = gauss8(c, a, m);
    let right = gauss8(c, m, b);
    let both = left + right;
    if (both - whole).abs() <= accuracy || depth >= MAX_ARCLEN_DEPTH {
        return both;
    }
    arclen_rec(c, a, m, left, 0.5 * accuracy, depth + 1)
        + arclen_rec(c, m, b, right, 0.5 * accuracy, depth + 1)
}

/// Gauss-Kronrod 7-point rule on [-1, 1], extending the 3-point Gauss-Legendre rule:
/// `(node, Kronrod weight, Gauss weight)`, the Gauss weight zero on the nodes the Kronrod
/// rule adds. The Kronrod sum is exact for polynomials of degree 11, the Gauss one for
/// degree 5; their difference bounds the error of the Kronrod sum with a wide margin.
/// Nodes and weights from Kronrod's tables (checked by the tests: exact moments through
/// degree 11).
pub(crate) const GK7: [(f64, f64, f64); 7] = [
    (0.0, 0.450_916_538_658_474_1, 8.0 / 9.0),
    (-0.434_243_749_346_802_6, 0.401_397_414_775_962_2, 0.0),
    (0.434_243_749_346_802_6, 0.401_397_414_775_962_2, 0.0),
    (-0.774_596_669_241_483_4, 0.268_488_089_868_333_4, 5.0 / 9.0),
    (0.774_596_669_241_483_4, 0.268_488_089_868_333_4, 5.0 / 9.0),
    (-0.960_491_268_708_020_3, 0.104_656_226_026_467_27, 0.0),
    (0.960_491_268_708_020_3, 0.104_656_226_026_467_27, 0.0),
];

/// The 7-point Kronrod and embedded 3-point Gauss integrals of `|d(t)|` over `[a, b]`.
#[inline]
fn gauss_kronrod7(d: impl Fn(f64) -> Vec3, a: f64, b: f64) -> (f64, f64) {
    let h = 0.5 * (b - a);
    let m = 0.5 * (a + b);
    let (mut k, mut g) = (0.0, 0.0);
    for &(x, wk, wg) in &GK7 {
        let f = d(m + h * x).norm();
        k += wk * f;
        g += wg * f;
    }
    (k * h, g * h)
}

/// Arc length of `c` between parameters `t0 <= t1`, within `accuracy` (mm), for short
/// smooth pieces: the 7-point Gauss-Kronrod sum (`GK7`) is accepted when it agrees with
/// its embedded 3-point Gauss sum within `accuracy` (the Gauss sum is much the weaker, so
/// their difference bounds the Kronrod sum's error with a wide margin); otherwise when
/// it agrees with the Kronrod sums over the two halves; otherwise [`arclen_adaptive`]
/// decides (tight bends, zero parametric speed). Seven evaluations of `C'` on a smooth
/// piece, where [`arclen_adaptive`] takes at least 48.
pub fn arclen_gk7<C: ParamCurveDeriv + ?Sized>(c: &C, t0: f64, t1: f64, accuracy: f64) -> f64 {
    if t1 <= t0 {
        return 0.0;
    }
    let d = |t| c.deriv(t);
    let (whole, gauss) = gauss_kronrod7(d, t0, t1);
    if (whole - gauss).abs() <= accuracy {
        return whole;
    }
    let m = 0.5 * (t0 + t1);
    let halves = gauss_kronrod7(d, t0, m).0 + gauss_kronrod7(d, m, t1).0;
    if (whole - halves).abs() <= accuracy {
        halves
    } else {
        arclen_adaptive(c, t0, t1, accuracy)
    }
}

/// Arc length of `c` between parameters `t0 <= t1` by adaptive 8-point Gauss-Legendre
/// quadrature of `|C'(t)|`: an interval is accepted when the estimate on it and the sum of
/// the estimates on its halves agree within its share of `accuracy` (mm).
pub fn arclen_adaptive<C: ParamCurveDeriv + ?Sized>(c: &C, t0: f64, t1: f64, accuracy: f64) -> f64 {
    if t1 <= t0 {
        return 0.0;
    }
    let whole = gauss8(c, t0, t1);
    arclen_rec(c, t0, t1, whole, accuracy.max(1e-15), 0)
}

/// Inverse arc length for any curve with derivatives: Newton steps on
/// `L(t) - s = 0` safeguarded by bisection (the speed may vanish at points).
/// The result's arc length is within `accuracy` of `s` (clamped to `[0, total]`).
pub fn inv_arclen_newton<C: ParamCurveDeriv + ?Sized>(
    c: &C,
    s: f64,
    total: f64,
    accuracy: f64,
) -> f64 {
    if s <= 0.0 {
        return 0.0;
    }
    if s >= total {
        return 1.0;
    }
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    let mut t = s / total;
    // Integrate from the nearer bracket end to keep each quadrature short.
    for _ in 0..60 {
        let len = arclen_adaptive(c, 0.0, t, accuracy * 0.25);
        let err = len - s;
        if err.abs() <= accuracy {
            return t;
        }
        if err > 0.0 {
            hi = t;
        } else {
            lo = t;
        }
        let speed = c.deriv(t).norm();
        let newton = t - err / speed;
        t = if speed > 0.0 && newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
        if hi - lo < 1e-15 {
            break;
        }
    }
    t
}

/// Number of initial samples of the generic nearest-point search.
const NEAREST_SAMPLES: usize = 32;

/// Generic nearest point: sample the curve, then refine the best few candidates by
/// Newton iteration on `(C(t) - p) . C'(t) = 0`, kept inside the bracket of the neighbouring
/// samples. Endpoints are always candidates. Adequate for curves whose features are
/// coarser than `1 / NEAREST_SAMPLES` of the parameter range (every segment this crate
/// builds); the rigorous distance used by verification goes through [`Flatten`] instead.
pub fn nearest_generic<C: ParamCurveDeriv + ?Sized>(c: &C, p: Vec3, accuracy: f64) -> Nearest {
    let n = NEAREST_SAMPLES;
    let mut best = Nearest {
        t: 0.0,
        distance_sq: c.eval(0.0).dist_sq(p),
    };
    let mut samples = [0.0_f64; NEAREST_SAMPLES + 1];
    for (i, d) in samples.iter_mut().enumerate() {
        let t = i as f64 / n as f64;
        *d = c.eval(t).dist_sq(p);
        if *d < best.distance_sq {
            best = Nearest { t, distance_sq: *d };
        }
    }
    for i in 0..=n {
        let is_min =
            (i == 0 || samples[i] <= samples[i - 1]) && (i == n || samples[i] <= samples[i + 1]);
        if !is_min {
            continue;
        }
        let lo = (i.max(1) - 1) as f64 / n as f64;
        let hi = (i + 1).min(n) as f64 / n as f64;
        let mut t = i as f64 / n as f64;
        for _ in 0..32 {
            let d = c.eval(t) - p;
            let d1 = c.deriv(t);
            let d2 = c.deriv2(t);
            let g = d.dot(d1);
            let h = d1.norm_sq() + d.dot(d2);
            if h.abs() <= f64::MIN_POSITIVE {
                break;
            }
            let next = (t - g / h).clamp(lo, hi);
            let step = (next - t).abs() * d1.norm();
            t = next;
            if step < accuracy * 1e-3 {
                break;
            }
        }
        let dsq = c.eval(t).dist_sq(p);
        if dsq < best.distance_sq {
            best = Nearest {
                t,
                distance_sq: dsq,
            };
        }
    }
    best
}

/// Test curve for arc-length rules: a tight cubic with a cusp-like bend and a zero-speed
/// start.
#[cfg(test)]
pub(crate) fn tight_cubic() -> crate::geom::Segment {
    crate::geom::Segment::CubicBez(crate::geom::CubicBez::new(
        Vec3::ZERO,
        Vec3::ZERO,
        Vec3::new(1.0, 0.02, 0.0),
        Vec3::new(0.0, 0.04, 0.0),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_kronrod_rule_is_exact_through_degree_11() {
        for k in 0..=11 {
            let exact = if k % 2 == 1 {
                0.0
            } else {
                2.0 / (k as f64 + 1.0)
            };
            let (kr, g) = GK7.iter().fold((0.0, 0.0), |(a, b), &(x, wk, wg)| {
                let f = x.powi(k);
                (a + wk * f, b + wg * f)
            });
            assert!(
                (kr - exact).abs() < 1e-15,
                "Kronrod, degree {k}: {kr} vs {exact}"
            );
            if k <= 5 {
                assert!(
                    (g - exact).abs() < 1e-15,
                    "Gauss, degree {k}: {g} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn arclen_gk7_matches_adaptive_quadrature() {
        // A tight cubic (a cusp-like bend and a zero-speed start), whole and in pieces,
        // against adaptive quadrature to 1e-14 mm.
        let c = tight_cubic();
        for n in [1, 3, 40] {
            for i in 0..n {
                let (a, b) = (i as f64 / n as f64, (i + 1) as f64 / n as f64);
                let want = arclen_adaptive(&c, a, b, 1e-14);
                for acc in [1e-8, 1e-10, 1e-12] {
                    let got = arclen_gk7(&c, a, b, acc);
                    assert!(
                        (got - want).abs() <= acc,
                        "{n} pieces, {i}: {got} vs {want}"
                    );
                }
            }
        }
        assert_eq!(arclen_gk7(&c, 0.5, 0.5, 1e-10), 0.0);
    }
}
