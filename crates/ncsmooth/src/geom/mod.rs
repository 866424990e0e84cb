//! Geometry: a `Copy` vector type, the curve capability traits and the curve kinds
//! (line, arc/helix, cubic Bézier, NURBS, cubic trigonometric spline), gathered in the
//! [`Segment`] enum; global curve interpolation ([`global_interp`]) on a banded solver ([`banded`]).

mod arc;
pub mod banded;
mod cubic_bez;
pub mod global_interp;
mod line;
mod nurbs;
mod segment;
mod simplify;
pub mod step_arclen;
mod traits;
mod trig_spline;
mod vec3;

pub use arc::Arc;
pub use cubic_bez::CubicBez;
pub use line::Line;
pub use nurbs::{Nurbs, PreparedNurbs, MAX_DEGREE};
pub use segment::Segment;
pub use simplify::{douglas_peucker, douglas_peucker_from};
pub use traits::*;
pub use trig_spline::{
    basis as trig_basis, basis_deriv as trig_basis_deriv, PreparedTrig, TrigSpline,
};
pub use vec3::{Aabb, Vec3};
