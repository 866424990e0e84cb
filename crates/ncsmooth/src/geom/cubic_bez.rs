//! Cubic Bézier segment: the polynomial building block of the B-spline corner transitions
//! (a clamped cubic B-spline with one interior knot is two Béziers).
//! Evaluation and derivatives are exact; arc length, its inverse and the nearest point are
//! numerical with the accuracy given; flattening carries a proved bound.

use super::traits::*;
use super::vec3::{Aabb, Vec3};
use serde::{Deserialize, Serialize};

/// A cubic Bézier curve with control points `p0..p3`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CubicBez {
    /// Start point.
    pub p0: Vec3,
    /// First control point.
    pub p1: Vec3,
    /// Second control point.
    pub p2: Vec3,
    /// End point.
    pub p3: Vec3,
}

/// Deepest recursion of [`CubicBez`] flattening (2^-depth of the parameter range).
const MAX_FLATTEN_DEPTH: u32 = 40;

impl CubicBez {
    /// Creates a cubic Bézier.
    pub const fn new(p0: Vec3, p1: Vec3, p2: Vec3, p3: Vec3) -> CubicBez {
        CubicBez { p0, p1, p2, p3 }
    }

    /// De Casteljau split at `t`.
    pub fn split(&self, t: f64) -> (CubicBez, CubicBez) {
        let a = self.p0.lerp(self.p1, t);
        let b = self.p1.lerp(self.p2, t);
        let c = self.p2.lerp(self.p3, t);
        let d = a.lerp(b, t);
        let e = b.lerp(c, t);
        let f = d.lerp(e, t);
        (
            CubicBez::new(self.p0, a, d, f),
            CubicBez::new(f, e, c, self.p3),
        )
    }

    /// Largest distance from an inner control point to the chord `p0 p3`: by the convex
    /// hull property it bounds the distance from the curve to the chord.
    pub fn hull_chord_error(&self) -> f64 {
        let chord = super::line::Line::new(self.p0, self.p3);
        chord.dist_sq(self.p1).max(chord.dist_sq(self.p2)).sqrt()
    }

    fn flatten_rec<F: FnMut(Vec3)>(&self, accuracy: f64, depth: u32, sink: &mut F) {
        if depth >= MAX_FLATTEN_DEPTH || self.hull_chord_error() <= accuracy {
            sink(self.p3);
            return;
        }
        let (a, b) = self.split(0.5);
        a.flatten_rec(accuracy, depth + 1, sink);
        b.flatten_rec(accuracy, depth + 1, sink);
    }
}

impl ParamCurve for CubicBez {
    #[inline]
    fn eval(&self, t: f64) -> Vec3 {
        let mt = 1.0 - t;
        self.p0 * (mt * mt * mt)
            + (self.p1 * (mt * mt * 3.0) + (self.p2 * (mt * 3.0) + self.p3 * t) * t) * t
    }
    fn start(&self) -> Vec3 {
        self.p0
    }
    fn end(&self) -> Vec3 {
        self.p3
    }
}

impl ParamCurveDeriv for CubicBez {
    #[inline]
    fn deriv(&self, t: f64) -> Vec3 {
        let mt = 1.0 - t;
        (self.p1 - self.p0) * (3.0 * mt * mt)
            + (self.p2 - self.p1) * (6.0 * mt * t)
            + (self.p3 - self.p2) * (3.0 * t * t)
    }
    #[inline]
    fn deriv2(&self, t: f64) -> Vec3 {
        let a = self.p2 - self.p1 * 2.0 + self.p0;
        let b = self.p3 - self.p2 * 2.0 + self.p1;
        (a * (1.0 - t) + b * t) * 6.0
    }
}

impl ParamCurveArclen for CubicBez {
    /// Adaptive Gauss-Legendre ([`arclen_adaptive`]); error within `accuracy`.
    fn arclen(&self, accuracy: f64) -> f64 {
        arclen_adaptive(self, 0.0, 1.0, accuracy)
    }
    /// Safeguarded Newton ([`inv_arclen_newton`]).
    fn inv_arclen(&self, s: f64, accuracy: f64) -> f64 {
        let total = self.arclen(accuracy * 0.25);
        inv_arclen_newton(self, s, total, accuracy)
    }
}

impl ParamCurveNearest for CubicBez {
    /// [`nearest_generic`].
    fn nearest(&self, p: Vec3, accuracy: f64) -> Nearest {
        nearest_generic(self, p, accuracy)
    }
}

impl ParamCurveCurvature for CubicBez {}

impl ParamCurveBBox for CubicBez {
    /// Box of the control polygon (convex hull property).
    fn bounding_box(&self) -> Aabb {
        let mut b = Aabb::point(self.p0);
        b.include(self.p1);
        b.include(self.p2);
        b.include(self.p3);
        b
    }
}

impl Flatten for CubicBez {
    /// Recursive halving until both inner control points are within `accuracy` of the
    /// chord. Curve to chord: the curve lies in the hull of its control points and the
    /// distance to a segment is convex, so it is within `accuracy`. Chord to curve: the
    /// curve's projection on the chord runs continuously from one end to the other, so every
    /// chord point is the foot of some curve point, at most `accuracy` away.
    fn flatten<F: FnMut(Vec3)>(&self, accuracy: f64, sink: &mut F) {
        self.flatten_rec(accuracy, 0, sink);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> CubicBez {
        CubicBez::new(
            Vec3::ZERO,
            Vec3::new(1.0, 2.0, 0.0),
            Vec3::new(3.0, 2.0, 1.0),
            Vec3::new(4.0, 0.0, 0.0),
        )
    }

    #[test]
    fn derivatives_and_split() {
        let c = sample();
        let h = 1e-6;
        for &t in &[0.0, 0.3, 0.7, 1.0] {
            let fd = (c.eval(t + h) - c.eval(t - h)) / (2.0 * h);
            assert!((fd - c.deriv(t)).norm() < 1e-8);
            let fd2 = (c.deriv(t + h) - c.deriv(t - h)) / (2.0 * h);
            assert!((fd2 - c.deriv2(t)).norm() < 1e-7);
        }
        let (a, b) = c.split(0.3);
        assert!(a.eval(0.5).dist(c.eval(0.15)) < 1e-14);
        assert!(b.eval(0.5).dist(c.eval(0.65)) < 1e-14);
        // A straight cubic with uniform control points has the exact length.
        let l = CubicBez::new(Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::X * 3.0);
        assert!((l.arclen(1e-12) - 3.0).abs() < 1e-12);
        let t = c.inv_arclen(1.0, 1e-10);
        assert!((arclen_adaptive(&c, 0.0, t, 1e-12) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn flatten_within_bound() {
        let c = sample();
        let acc = 1e-4;
        let mut pts = vec![c.p0];
        c.flatten(acc, &mut |p| pts.push(p));
        assert_eq!(*pts.last().unwrap(), c.p3);
        // Dense samples of the curve are within acc of the polyline.
        for i in 0..=2000 {
            let p = c.eval(i as f64 / 2000.0);
            let d = pts
                .windows(2)
                .map(|w| super::super::line::Line::new(w[0], w[1]).dist_sq(p))
                .fold(f64::INFINITY, f64::min);
            assert!(d.sqrt() <= acc * (1.0 + 1e-9));
        }
    }
}
