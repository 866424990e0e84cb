//! How LinuxCNC is given its share of a tolerance: the chord and `G64 P` of its smoothed
//! runs and of the motion copied verbatim, and the rule that measures its blending by the
//! model of the path it executes ([`super::executed`]) instead of paying it in full.
//! Shares of `tol`; the figures that chose them are in `docs/benchmarks/`.

/// Default chord for LinuxCNC: long G1 blocks that its blending joins at speed, sharing
/// the tolerance with [`BLEND_SHARE`] under the model of its executed path
/// ([`BudgetRule::Executed`]).
pub(crate) const LINUXCNC_CHORD_SHARE: f64 = 0.4;
/// Share LinuxCNC's blending may use on the program's own motion copied verbatim
/// ([`crate::RewriteOptions::verbatim_blend`]): nearly all of it, as for the input run
/// with `G64 P<tol>`, since those moves are the programmed path; 5 % is left for whoever
/// measures the executed path from servo samples (chords between samples cut inside a
/// blend arc).
pub(crate) const VERBATIM_BLEND_SHARE: f64 = 0.95;
/// LinuxCNC's blend at a junction has a tolerance of at most a quarter of each line
/// (blendmath.c `tcFindBlendTolerance`): with an acceleration, a written block shorter
/// than this many times the run's `P` is replaced by the programmed corner where the
/// tolerance allows ([`crate::controller::linuxcnc::CornerBlend`]).
pub(crate) const LINUXCNC_CORNER_FLOOR_P: f64 = 4.0;
/// Share LinuxCNC's blending may use (`G64 P`). Its blend at a vertex of a curve
/// flattened within `chord` follows the curve's own radius once `P` reaches the chord
/// (the blend takes `P / tan(phi / 4)` of each line, the curve's chords `4 chord / phi`);
/// with the model of the executed path the two need not both be paid
/// ([`BudgetRule::Executed`]).
pub(crate) const BLEND_SHARE: f64 = 0.4;
/// Builds under the model of LinuxCNC's executed path before the program is built with
/// each part paid in full: the first, and one with what it found over tol taken off the
/// curves. (Before them, one with the blocks evened out for LinuxCNC's blends, kept when
/// the model confirms it.)
pub(crate) const EXECUTED_BUILDS: usize = 2;
/// The chord LinuxCNC gets when the model does not confirm a build or does not apply
/// (loops, emitters other than `lines`), paid in full with [`SUM_BLEND_SHARE`].
pub(crate) const SUM_CHORD_SHARE: f64 = 0.15;
/// The `G64 P` LinuxCNC gets when the model does not confirm a build or does not apply.
pub(crate) const SUM_BLEND_SHARE: f64 = 0.1;
/// LinuxCNC's blending when `Method::None` with an emitter compresses the program's own
/// lines: what [`COMPRESS_CHORD_SHARE`] leaves.
pub(crate) const COMPRESS_BLEND_SHARE: f64 = 0.1;
/// Accuracy of the model of LinuxCNC's executed path.
pub(crate) const EXECUTED_ACCURACY_SHARE: f64 = 1e-3;
/// Kept back from the curves when LinuxCNC's blending is measured by its model rather
/// than paid in full: the model's accuracy, and room for the corners where the chord and
/// the blend do add up (a curve's sharp transition), so that the first build is rarely
/// refused.
pub(crate) const EXECUTED_MARGIN_SHARE: f64 = 0.02;

/// How the tolerance is shared between the curves and the controller's blending.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum BudgetRule {
    /// `tol - chord - rounding - (P + Q)`: each part paid in full.
    Sum,
    /// `tol - max(chord, P) - rounding - margin - less_mm`, accepted only when the model
    /// of the path LinuxCNC executes ([`super::executed`]) is within tol. LinuxCNC's blend
    /// at a vertex of a flattened curve cuts inside it by at most `P`, where the chord is
    /// on the curve; between vertices the chord departs from it by at most `chord`, where
    /// the blends have left the line: the two do not add (a circle flattened within `c`
    /// and blended under `P = c` runs within `c` of the circle). At a sharp transition
    /// they can partly add: `less_mm` is what a build found over tol, taken off the next.
    Executed {
        /// Taken off the curves' tolerance (mm).
        less_mm: f64,
        /// Whether the blocks are evened out for LinuxCNC's blends
        /// ([`crate::RewriteOptions::even_out`]).
        even_out: bool,
    },
}
