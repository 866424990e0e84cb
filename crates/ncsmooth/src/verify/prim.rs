//! Exact primitives for distance queries: lines and planar arcs. Every [`Segment`] is
//! turned into primitives, exactly (lines, planar arcs) or through [`Flatten`] with a stated
//! chord bound (helical arcs and free-form curves).

use crate::geom::{Aabb, Arc, Flatten, Line, ParamCurve, ParamCurveBBox, Segment, Vec3};
use std::f64::consts::{PI, TAU};

/// A line or a planar arc, tagged with the index of the move it came from.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Prim {
    pub geom: PrimGeom,
    /// Index of the source move (in the caller's move list).
    pub source: u32,
}

#[derive(Clone, Copy, Debug)]
pub(crate) enum PrimGeom {
    Line(Line),
    Arc(PlanarArc),
}

/// A planar arc with what its exact distance needs precomputed, so that a distance costs
/// no trigonometry (the queries of the deviation measurement are most of its time).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlanarArc {
    pub arc: Arc,
    /// Unit normal of the plane, `u x v`.
    normal: Vec3,
    /// Cosine and sine of the sweep: the end direction in the `(u, v)` frame.
    end_dir: (f64, f64),
}

impl PlanarArc {
    /// `a` must be planar.
    pub fn new(a: &Arc) -> PlanarArc {
        let (s, c) = a.sweep.sin_cos();
        PlanarArc {
            arc: *a,
            normal: a.normal(),
            end_dir: (c, s),
        }
    }

    /// Exact squared distance from `p`: with `(x, y)` the in-plane coordinates of `p`
    /// about the centre in the `(u, v)` frame and `z` its height over the plane, the foot
    /// on the circle, `(x, y) r / |(x, y)|`, is on the arc when its angle is within the
    /// sweep (two cross products with the end directions decide it), and the distance is
    /// then `(|(x, y)| - r)^2 + z^2`; otherwise the nearer end point is nearest. A point on
    /// the axis is `r` from every point of the circle.
    #[inline]
    pub fn dist_sq(&self, p: Vec3) -> f64 {
        let a = &self.arc;
        let q = p - a.center;
        let (x, y, z) = (q.dot(a.u), q.dot(a.v), q.dot(self.normal));
        let (c, s) = self.end_dir;
        // Sign of the end direction's cross product with (x, y): >= 0 when (x, y) is not
        // past the end, turning from it the way the arc sweeps.
        let before_end = x * s - y * c >= 0.0;
        let inside = if a.sweep >= TAU {
            true
        } else if a.sweep <= PI {
            y >= 0.0 && before_end
        } else {
            y >= 0.0 || before_end
        };
        let r = a.radius;
        if inside {
            // No overflow to guard against at machine coordinates (plain sqrt, not hypot).
            let rho = (x * x + y * y).sqrt();
            let d = rho - r;
            return d * d + z * z;
        }
        let d0 = (x - r) * (x - r) + y * y;
        let d1 = (x - r * c) * (x - r * c) + (y - r * s) * (y - r * s);
        d0.min(d1) + z * z
    }
}

impl Prim {
    #[inline]
    pub fn dist_sq(&self, p: Vec3) -> f64 {
        match &self.geom {
            PrimGeom::Line(l) => l.dist_sq(p),
            PrimGeom::Arc(a) => a.dist_sq(p),
        }
    }
    #[inline]
    pub fn eval(&self, t: f64) -> Vec3 {
        match &self.geom {
            PrimGeom::Line(l) => l.eval(t),
            PrimGeom::Arc(a) => a.arc.eval(t),
        }
    }
    pub fn length(&self) -> f64 {
        match &self.geom {
            PrimGeom::Line(l) => l.length(),
            PrimGeom::Arc(a) => a.arc.length(),
        }
    }
    pub fn bbox(&self) -> Aabb {
        match &self.geom {
            PrimGeom::Line(l) => l.bounding_box(),
            PrimGeom::Arc(a) => a.arc.bounding_box(),
        }
    }
}

/// Appends the primitives of `seg` to `out`. Lines and planar arcs are exact; helical arcs
/// and curves are flattened with chord error at most `flatten_mm`.
pub(crate) fn push_prims(seg: &Segment, source: u32, flatten_mm: f64, out: &mut Vec<Prim>) {
    match seg {
        Segment::Line(l) => out.push(Prim {
            geom: PrimGeom::Line(*l),
            source,
        }),
        Segment::Arc(a) if !a.is_helical() => out.push(Prim {
            geom: PrimGeom::Arc(PlanarArc::new(a)),
            source,
        }),
        other => {
            let mut prev = other.start();
            other.flatten(flatten_mm, &mut |p| {
                out.push(Prim {
                    geom: PrimGeom::Line(Line::new(prev, p)),
                    source,
                });
                prev = p;
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::ParamCurveNearest;
    use proptest::prelude::*;

    proptest! {
        /// The trigonometry-free distance is the exact nearest-point distance of the arc
        /// (angle by `atan2`), for sweeps below, at and above a half and a full turn, and
        /// points in and off the plane, near the axis and far away.
        #[test]
        fn planar_arc_distance_is_the_nearest_distance(
            r in 0.01f64..50.0,
            start in -7.0f64..7.0,
            sweep in prop_oneof![1e-6f64..PI, Just(PI), PI..TAU, Just(TAU)],
            ccw in any::<bool>(),
            tilt in 0.0f64..1.5,
            px in -100.0f64..100.0,
            py in -100.0f64..100.0,
            pz in -5.0f64..5.0,
            scale in prop_oneof![Just(1e-3f64), Just(1.0)],
        ) {
            let axis = Vec3::new(tilt.sin(), 0.0, tilt.cos());
            let center = Vec3::new(1.0, -2.0, 0.5);
            // A start point on the circle in the plane normal to `axis`.
            let e1 = Vec3::new(tilt.cos(), 0.0, -tilt.sin());
            let e2 = axis.cross(e1);
            let dir = |a: f64| e1 * a.cos() + e2 * a.sin();
            let sgn = if ccw { 1.0 } else { -1.0 };
            let s0 = center + dir(start) * r;
            let s1 = center + dir(start + sgn * sweep) * r;
            let turns = if sweep >= TAU { 1 } else { 0 };
            let Some(a) = Arc::from_center(s0, s1, center, axis, ccw, turns) else {
                return Ok(());
            };
            prop_assume!(!a.is_helical());
            let p = center + Vec3::new(px, py, pz) * (scale * r);
            let exact = a.nearest(p, 0.0).distance_sq;
            let fast = PlanarArc::new(&a).dist_sq(p);
            let scale_sq = (p - center).norm_sq() + r * r;
            prop_assert!((fast - exact).abs() <= 1e-12 * scale_sq, "{fast} vs {exact}");
        }
    }

    #[test]
    fn planar_arc_distance_on_the_axis_and_at_the_ends() {
        let a = Arc::from_center(
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::ZERO,
            Vec3::Z,
            true,
            0,
        )
        .expect("quarter circle");
        let pa = PlanarArc::new(&a);
        // On the axis, 2 above the plane: sqrt(1 + 4) from every point.
        assert!((pa.dist_sq(Vec3::new(0.0, 0.0, 2.0)) - 5.0).abs() < 1e-15);
        // Outside the sweep, nearest to the start point (1, 0).
        assert!((pa.dist_sq(Vec3::new(2.0, -1.0, 0.0)) - 2.0).abs() < 1e-15);
        // Inside the sweep at 45 degrees, 1 outside the circle.
        let p = Vec3::new(2.0, 2.0, 0.0) / 2f64.sqrt();
        assert!((pa.dist_sq(p) - 1.0).abs() < 1e-15);
    }
}
