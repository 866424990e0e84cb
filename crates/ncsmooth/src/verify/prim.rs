//! Exact primitives for distance queries: lines and planar arcs. Every [`Segment`] is
//! turned into primitives, exactly (lines, planar arcs) or through [`Flatten`] with a stated
//! chord bound (helical arcs and free-form curves).

use crate::geom::{
    Aabb, Arc, Flatten, Line, ParamCurve, ParamCurveBBox, ParamCurveNearest, Segment, Vec3,
};

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
    Arc(Arc),
}

impl Prim {
    #[inline]
    pub fn dist_sq(&self, p: Vec3) -> f64 {
        match &self.geom {
            PrimGeom::Line(l) => l.dist_sq(p),
            PrimGeom::Arc(a) => a.nearest(p, 0.0).distance_sq,
        }
    }
    #[inline]
    pub fn eval(&self, t: f64) -> Vec3 {
        match &self.geom {
            PrimGeom::Line(l) => l.eval(t),
            PrimGeom::Arc(a) => a.eval(t),
        }
    }
    pub fn length(&self) -> f64 {
        match &self.geom {
            PrimGeom::Line(l) => l.length(),
            PrimGeom::Arc(a) => a.length(),
        }
    }
    pub fn bbox(&self) -> Aabb {
        match &self.geom {
            PrimGeom::Line(l) => l.bounding_box(),
            PrimGeom::Arc(a) => a.bounding_box(),
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
            geom: PrimGeom::Arc(*a),
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
