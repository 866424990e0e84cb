//! Geometry: a `Copy` vector type, the curve capability traits and the curve kinds
//! (line, arc/helix, cubic Bézier, NURBS, cubic trigonometric spline), gathered in the
//! [`Segment`] enum; global curve interpolation ([`global_interp`]) on a banded solver ([`BandedMatrix`]).

mod arc;
mod banded;
mod cubic_bez;
pub mod global_interp;
mod line;
mod nurbs;
mod seg_grid;
mod segment;
mod simplify;
mod step_arclen;
mod traits;
mod trig_spline;
mod vec3;

pub use arc::Arc;
pub use banded::BandedMatrix;
pub(crate) use banded::{SymBanded, BAND};
pub use cubic_bez::CubicBez;
pub use line::Line;
pub(crate) use nurbs::basis_funs;
pub use nurbs::{Nurbs, PreparedNurbs, MAX_DEGREE};
pub use seg_grid::{segment_meets_box, SegmentGrid};
pub use segment::Segment;
pub use simplify::{douglas_peucker, douglas_peucker_from};
pub use step_arclen::{step_arclen, STEP_ARCLEN_ACCURACY_MM};
pub use traits::*;
pub use trig_spline::{
    basis as trig_basis, basis_deriv as trig_basis_deriv, PreparedTrig, TrigSpline,
};
pub use vec3::{Aabb, Vec3};
