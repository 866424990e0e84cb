//! The `Segment` enum: every curve kind a toolpath can hold, implementing the curve traits
//! by `match` (no dynamic dispatch on hot paths).

use super::traits::*;
use super::vec3::{Aabb, Vec3};
use super::{Arc, CubicBez, Line, Nurbs, TrigSpline};
use serde::{Deserialize, Serialize};

/// One piece of a toolpath.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Segment {
    /// Straight line.
    Line(Line),
    /// Circular or helical arc.
    Arc(Arc),
    /// Cubic Bézier (corner transitions).
    CubicBez(CubicBez),
    /// General NURBS (fitted curves).
    Nurbs(Box<Nurbs>),
    /// Cubic trigonometric spline (Tao et al.: free curves, corner transitions, loops).
    Trig(TrigSpline),
}

macro_rules! dispatch {
    ($s:expr, $c:ident => $e:expr) => {
        match $s {
            Segment::Line($c) => $e,
            Segment::Arc($c) => $e,
            Segment::CubicBez($c) => $e,
            Segment::Trig($c) => $e,
            Segment::Nurbs($c) => {
                let $c: &Nurbs = $c;
                $e
            }
        }
    };
}

impl Segment {
    /// Short name of the kind, for reports.
    pub fn kind_name(&self) -> &'static str {
        match self {
            Segment::Line(_) => "line",
            Segment::Arc(_) => "arc",
            Segment::CubicBez(_) => "cubic_bezier",
            Segment::Nurbs(_) => "nurbs",
            Segment::Trig(_) => "trig",
        }
    }
    /// Length: exact for lines and arcs, else within `accuracy` (mm).
    pub fn length(&self, accuracy: f64) -> f64 {
        self.arclen(accuracy)
    }
    /// Unit tangent at the start, if the curve has one there (looks slightly inside when
    /// the parametric speed vanishes at the end point).
    pub fn start_tangent(&self) -> Option<Vec3> {
        end_tangent_of(self, 0.0, 1.0)
    }
    /// Unit tangent at the end (direction of motion).
    pub fn end_tangent(&self) -> Option<Vec3> {
        end_tangent_of(self, 1.0, -1.0)
    }
    /// True for exact-geometry segments (lines and arcs) that G-code can carry as-is.
    pub fn is_native_gcode(&self) -> bool {
        matches!(self, Segment::Line(_) | Segment::Arc(_))
    }
}

/// Parameter offsets tried when the derivative vanishes at an end (a zero-speed end such
/// as a Bézier with a repeated control point): the tangent is the limit direction.
const TANGENT_PROBES: [f64; 3] = [1e-9, 1e-6, 1e-3];

fn end_tangent_of(s: &Segment, t: f64, dir: f64) -> Option<Vec3> {
    if let Some(v) = s.deriv(t).normalized() {
        return Some(v);
    }
    for h in TANGENT_PROBES {
        // Secant towards a nearby interior point, oriented along the motion.
        let d = (s.eval(t + dir * h) - s.eval(t)) * dir;
        if let Some(v) = d.normalized() {
            return Some(v);
        }
    }
    None
}

impl ParamCurve for Segment {
    #[inline]
    fn eval(&self, t: f64) -> Vec3 {
        dispatch!(self, c => c.eval(t))
    }
    #[inline]
    fn start(&self) -> Vec3 {
        dispatch!(self, c => c.start())
    }
    #[inline]
    fn end(&self) -> Vec3 {
        dispatch!(self, c => c.end())
    }
}

impl ParamCurveDeriv for Segment {
    #[inline]
    fn deriv(&self, t: f64) -> Vec3 {
        dispatch!(self, c => c.deriv(t))
    }
    #[inline]
    fn deriv2(&self, t: f64) -> Vec3 {
        dispatch!(self, c => c.deriv2(t))
    }
    #[inline]
    fn ders(&self, t: f64) -> [Vec3; 3] {
        dispatch!(self, c => c.ders(t))
    }
}

impl ParamCurveArclen for Segment {
    fn arclen(&self, accuracy: f64) -> f64 {
        dispatch!(self, c => c.arclen(accuracy))
    }
    fn inv_arclen(&self, s: f64, accuracy: f64) -> f64 {
        dispatch!(self, c => c.inv_arclen(s, accuracy))
    }
}

impl ParamCurveNearest for Segment {
    fn nearest(&self, p: Vec3, accuracy: f64) -> Nearest {
        dispatch!(self, c => c.nearest(p, accuracy))
    }
}

impl ParamCurveCurvature for Segment {
    fn curvature_vec(&self, t: f64) -> Vec3 {
        dispatch!(self, c => c.curvature_vec(t))
    }
}

impl ParamCurveBBox for Segment {
    fn bounding_box(&self) -> Aabb {
        dispatch!(self, c => c.bounding_box())
    }
}

impl Flatten for Segment {
    fn flatten<F: FnMut(Vec3)>(&self, accuracy: f64, sink: &mut F) {
        dispatch!(self, c => c.flatten(accuracy, sink))
    }
}

impl From<Line> for Segment {
    fn from(l: Line) -> Segment {
        Segment::Line(l)
    }
}
impl From<Arc> for Segment {
    fn from(a: Arc) -> Segment {
        Segment::Arc(a)
    }
}
impl From<CubicBez> for Segment {
    fn from(c: CubicBez) -> Segment {
        Segment::CubicBez(c)
    }
}
impl From<TrigSpline> for Segment {
    fn from(c: TrigSpline) -> Segment {
        Segment::Trig(c)
    }
}
impl From<Nurbs> for Segment {
    fn from(n: Nurbs) -> Segment {
        Segment::Nurbs(Box::new(n))
    }
}
