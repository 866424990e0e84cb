//! Nearest distance from points to a path, for measurements built outside this crate (the
//! G-code crate's model of what a controller's blending executes,
//! `ncsmooth_gcode::executed`).
//!
//! The path's segments become the same exact primitives [`super::deviation`] measures
//! against (lines and planar arcs; helical arcs and curves flattened within a given chord,
//! which bounds the error of every distance), indexed by the same bounding-volume
//! hierarchy. Queries along a path are nearly O(log n): each starts from the primitive
//! nearest the previous point.

use super::bvh::{Bvh, Hit};
use super::prim::{push_prims, PrimGeom};
use crate::geom::{Line, ParamCurve, Segment, Vec3};

/// A path indexed for nearest-distance queries.
///
/// ```
/// use ncsmooth::geom::{Line, Segment, Vec3};
/// use ncsmooth::verify::NearestIndex;
///
/// let l = Segment::Line(Line::new(Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)));
/// let mut idx = NearestIndex::new([&l], 1e-6);
/// let (d, seg) = idx.nearest(Vec3::new(5.0, 2.0, 0.0));
/// assert!((d - 2.0).abs() < 1e-12 && seg == 0);
/// ```
pub struct NearestIndex {
    bvh: Bvh,
    hint: usize,
}

impl NearestIndex {
    /// Indexes `segments` (in order; [`NearestIndex::nearest`] returns positions in it),
    /// flattening those that are not lines or planar arcs within `flatten_mm`.
    pub fn new<'a>(segments: impl IntoIterator<Item = &'a Segment>, flatten_mm: f64) -> Self {
        let mut prims = Vec::new();
        for (i, s) in segments.into_iter().enumerate() {
            push_prims(s, i as u32, flatten_mm, &mut prims);
        }
        NearestIndex {
            bvh: Bvh::new(prims),
            hint: 0,
        }
    }

    /// Whether the path has no segment.
    pub fn is_empty(&self) -> bool {
        self.bvh.prims.is_empty()
    }

    /// Distance from `p` to the path (infinite for an empty path) and the position of the
    /// nearest segment among those indexed.
    pub fn nearest(&mut self, p: Vec3) -> (f64, usize) {
        if self.is_empty() {
            return (f64::INFINITY, usize::MAX);
        }
        let h = self.bvh.prims[self.hint].dist_sq(p);
        let Hit { dist_sq, prim } = self.bvh.nearest(p, h);
        if prim != usize::MAX {
            self.hint = prim;
        }
        let best = if prim != usize::MAX { dist_sq } else { h };
        (best.sqrt(), self.bvh.prims[self.hint].source as usize)
    }

    /// Distance from `p` to the path.
    pub fn dist(&mut self, p: Vec3) -> f64 {
        self.nearest(p).0
    }

    /// [`NearestIndex::nearest`]'s distance, and the nearest primitive when it is a line (a
    /// line segment of the path, or of a flattened curve): the distance to it is convex,
    /// so over a convex set it is largest at an extreme point.
    pub fn nearest_line(&mut self, p: Vec3) -> (f64, Option<Line>) {
        let (d, _) = self.nearest(p);
        let line = match self.bvh.prims.get(self.hint).map(|q| &q.geom) {
            Some(PrimGeom::Line(l)) if d.is_finite() => Some(*l),
            _ => None,
        };
        (d, line)
    }

    /// An upper bound on the distance to the path over the convex hull of `hull`, when the
    /// primitive nearest the last query ([`NearestIndex::nearest`]) is a planar arc: the
    /// largest distance of a point of `hull` to the chord of the arc between its points'
    /// feet (the distance to a line segment is convex, so over the hull it is largest at a
    /// point of `hull`), plus the chord's sagitta (every point of the chord is within it
    /// of the arc). It shrinks with the square of the hull's size, where a Lipschitz bound
    /// shrinks with the size. `None` for another primitive, or when the feet span more than
    /// `MAX_HULL_FOOT_SPAN_RAD` of the arc.
    pub fn arc_hull_bound(&self, hull: &[Vec3]) -> Option<f64> {
        let PrimGeom::Arc(a) = &self.bvh.prims.get(self.hint)?.geom else {
            return None;
        };
        let arc = &a.arc;
        let n = arc.normal();
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for &v in hull {
            let q = v - arc.center;
            let q = q - n * q.dot(n);
            let mut th = q.dot(arc.v).atan2(q.dot(arc.u));
            if th < 0.0 {
                th += std::f64::consts::TAU;
            }
            if th > arc.sweep {
                // Past the end: the nearer end (the way round that is shorter).
                th = if th - arc.sweep < std::f64::consts::TAU - th {
                    arc.sweep
                } else {
                    0.0
                };
            }
            lo = lo.min(th);
            hi = hi.max(th);
        }
        if hi - lo > MAX_HULL_FOOT_SPAN_RAD || hi.is_nan() || lo.is_nan() {
            return None;
        }
        let chord = Line::new(arc.eval(lo / arc.sweep), arc.eval(hi / arc.sweep));
        let sagitta = arc.radius * (1.0 - (0.5 * (hi - lo)).cos());
        let far = hull
            .iter()
            .map(|&v| chord.dist_sq(v))
            .fold(0.0, f64::max)
            .sqrt();
        Some(far + sagitta)
    }
}

/// Largest angle (rad) of an arc that [`NearestIndex::arc_hull_bound`] replaces by its chord.
pub(crate) const MAX_HULL_FOOT_SPAN_RAD: f64 = std::f64::consts::FRAC_PI_2;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Arc, Line};

    #[test]
    fn nearest_segment_of_a_line_and_an_arc() {
        let l = Segment::Line(Line::new(Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)));
        let a = Arc::from_center(
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
            Vec3::new(10.0, 5.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
            true,
            0,
        )
        .unwrap();
        let segs = [l, Segment::Arc(a)];
        let mut idx = NearestIndex::new(&segs, 1e-6);
        let (d, k) = idx.nearest(Vec3::new(3.0, -1.0, 0.0));
        assert!((d - 1.0).abs() < 1e-12 && k == 0);
        // (20, 5) is 5 from the circle of radius 5 about (10, 5).
        let (d, k) = idx.nearest(Vec3::new(20.0, 5.0, 0.0));
        assert!((d - 5.0).abs() < 1e-12 && k == 1);
        assert_eq!(NearestIndex::new([], 1e-6).dist(Vec3::ZERO), f64::INFINITY);
    }
}
