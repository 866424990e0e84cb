//! LinuxCNC as a model: the `G64 P Q` it is given ([`Blend`], [`g64`]) and its share of
//! the tolerance (`budget`), the blend schedule
//! that sizes a smaller `P` where the speed allows ([`blend`]), evening out a chain's
//! blocks ([`even_out`]) and the path it executes ([`executed`]).

pub mod blend;
pub(crate) mod budget;
pub mod even_out;
pub mod executed;
pub mod g64;

/// LinuxCNC blending allowed on the written motion: `G64 P<p> Q<q>` is written before
/// each replaced run, so the controller's blending (`P`) and naive-CAM merging (`Q`) add
/// at most `p + q` to the deviation of the written path.
///
/// After the run the program's own mode is restored when it is at least as tight as the
/// bound of the copied lines that follow (this one, or [`RewriteOptions::verbatim_blend`](crate::RewriteOptions::verbatim_blend)
/// before a stretch of rapids): `G61`, `G61.1`, or a `G64` whose `P + Q` is within it. A
/// looser mode (LinuxCNC's start-up `G64` without `P`, or a larger `P`) is not restored:
/// that bound is written instead, so the blending of the moves that follow stays bounded
/// until the program sets a mode of its own.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blend {
    /// Blend tolerance `P` (mm), positive.
    pub p_mm: f64,
    /// Naive-CAM tolerance `Q` (mm), positive.
    pub q_mm: f64,
}

/// The `P` a written point may get under LinuxCNC beyond the run's ([`BlockFloor::corner`](crate::write::rewrite::BlockFloor::corner)):
/// a programmed corner put in place of short blocks, and a point whose speed needs all of
/// the run's `P` (a tight turn), may have their blends take what the tolerance leaves
/// after the lines beside them (the writer's `vertex_room`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CornerBlend {
    /// The tolerance less the printed decimals, and less a share left to whoever
    /// measures the blends from servo samples (mm): the blend's `P` and the lines'
    /// deviation where it runs share it.
    pub total_mm: f64,
    /// Largest `P` to write (mm), within what the model of the executed path caps.
    pub max_p_mm: f64,
}
