//! Verification core: how every smoothing and planning result is judged.
//!
//! * [`deviation`]: the two-sided distance between an output path and the programmed one
//!   (the tolerance contract), exact within a stated accuracy, O(n log n).
//! * [`NearestIndex`]: nearest distance from points to a path, for measurements built
//!   elsewhere.
//! * [`continuity`]: position, tangent and curvature continuity at every joint.
//! * [`extra_axes_kept`]: a written program's extra axes where the program has them.
//! * [`block_values_kept`]: its per-block values (`S` on motion blocks) where the program
//!   sets them.

mod block_values;
mod bvh;
mod continuity;
mod deviation;
mod extra_axes;
mod nearest;
mod prim;

pub use block_values::{block_values_kept, BlockValueMismatch};
pub use continuity::{
    continuity, continuity_joints, joint, Continuity, Joint, JointClass, CURVATURE_ABS_TOL,
    CURVATURE_REL_TOL, DEGENERATE_MM, GAP_TOL_MM, TANGENT_TOL_DEG,
};
pub use deviation::{
    deviation, deviation_segments, deviation_with_vertex_distances, Deviation, ProgramIndex,
};
pub use extra_axes::{
    extra_axes_kept, extrusion_along_path, ExtraAxesMismatch, ExtrusionAlongPath,
};
pub use nearest::NearestIndex;
