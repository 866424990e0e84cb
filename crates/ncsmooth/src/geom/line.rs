//! Straight line segment: every operation is exact.

use super::traits::*;
use super::vec3::{Aabb, Vec3};
use serde::{Deserialize, Serialize};

/// A straight segment from `p0` to `p1`, `C(t) = p0 + t (p1 - p0)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Line {
    /// Start point.
    pub p0: Vec3,
    /// End point.
    pub p1: Vec3,
}

impl Line {
    /// Creates a line.
    pub const fn new(p0: Vec3, p1: Vec3) -> Line {
        Line { p0, p1 }
    }
    /// Length (exact).
    #[inline]
    pub fn length(&self) -> f64 {
        self.p0.dist(self.p1)
    }
    /// Parameter of the point of the segment nearest to `p` (exact, clamped to [0, 1]).
    #[inline]
    pub fn project(&self, p: Vec3) -> f64 {
        let d = self.p1 - self.p0;
        let l2 = d.norm_sq();
        if l2 <= 0.0 {
            return 0.0;
        }
        ((p - self.p0).dot(d) / l2).clamp(0.0, 1.0)
    }
    /// Squared distance from `p` to the segment (exact).
    #[inline]
    pub fn dist_sq(&self, p: Vec3) -> f64 {
        self.eval(self.project(p)).dist_sq(p)
    }
}

impl ParamCurve for Line {
    #[inline]
    fn eval(&self, t: f64) -> Vec3 {
        self.p0.lerp(self.p1, t)
    }
    fn start(&self) -> Vec3 {
        self.p0
    }
    fn end(&self) -> Vec3 {
        self.p1
    }
}

impl ParamCurveDeriv for Line {
    #[inline]
    fn deriv(&self, _t: f64) -> Vec3 {
        self.p1 - self.p0
    }
    #[inline]
    fn deriv2(&self, _t: f64) -> Vec3 {
        Vec3::ZERO
    }
}

impl ParamCurveArclen for Line {
    /// Exact; `accuracy` is ignored.
    fn arclen(&self, _accuracy: f64) -> f64 {
        self.length()
    }
    /// Exact; `accuracy` is ignored.
    fn inv_arclen(&self, s: f64, _accuracy: f64) -> f64 {
        let l = self.length();
        if l <= 0.0 {
            0.0
        } else {
            (s / l).clamp(0.0, 1.0)
        }
    }
}

impl ParamCurveNearest for Line {
    /// Exact; `accuracy` is ignored.
    fn nearest(&self, p: Vec3, _accuracy: f64) -> Nearest {
        let t = self.project(p);
        Nearest {
            t,
            distance_sq: self.eval(t).dist_sq(p),
        }
    }
}

impl ParamCurveCurvature for Line {
    fn curvature_vec(&self, _t: f64) -> Vec3 {
        Vec3::ZERO
    }
}

impl ParamCurveBBox for Line {
    fn bounding_box(&self) -> Aabb {
        Aabb {
            min: self.p0.min(self.p1),
            max: self.p0.max(self.p1),
        }
    }
}

impl Flatten for Line {
    /// Exact: emits the end point.
    fn flatten<F: FnMut(Vec3)>(&self, _accuracy: f64, sink: &mut F) {
        sink(self.p1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_basics() {
        let l = Line::new(Vec3::new(1.0, 2.0, 3.0), Vec3::new(4.0, 6.0, 3.0));
        assert_eq!(l.arclen(0.1), 5.0);
        assert_eq!(l.eval(l.inv_arclen(2.5, 0.0)), Vec3::new(2.5, 4.0, 3.0));
        let n = l.nearest(Vec3::new(10.0, 0.0, 3.0), 0.0);
        assert!((0.0..=1.0).contains(&n.t));
        assert_eq!(l.curvature(0.3), 0.0);
        let z = Line::new(Vec3::ZERO, Vec3::ZERO);
        assert_eq!(z.inv_arclen(1.0, 0.0), 0.0);
        assert_eq!(z.dist_sq(Vec3::X), 1.0);
    }
}
