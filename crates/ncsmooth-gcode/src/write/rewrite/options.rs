//! The settings of a rewrite: the emitter, the block floor and the LinuxCNC blending it
//! writes ([`RewriteOptions`]).

#[cfg(doc)]
use super::rewrite;
use crate::controller::arcs::ArcChords;
use crate::controller::dialect::Dialect;
use crate::controller::linuxcnc::{Blend, CornerBlend};

/// Settings of [`rewrite()`].
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct RewriteOptions {
    /// Digits after the point for coordinates in millimetre programs (inch programs get
    /// one more). Default 4.
    pub decimals: usize,
    /// Chord tolerance (mm) for flattening curves G-code cannot carry. Default 0.001.
    pub chord_mm: f64,
    /// Comment lines written at the end of the file (after its last line, past the `M2` or
    /// closing `%` where the controller stops reading), each as a `;` comment. At the end
    /// they leave the numbers of the program's lines unchanged up to the first smoothed
    /// one, which a program may read (`#<_line>`) and a controller's messages quote.
    /// Default none.
    pub header: Option<String>,
    /// How smoothed motion is written. Default [`Emit::Native`].
    pub emit: Emit,
    /// LinuxCNC blending to allow on the replaced motion (`G64 P Q` before each replaced
    /// run); `None` writes no path control mode. Default `None`.
    pub blend: Option<Blend>,
    /// With [`RewriteOptions::blend`]: LinuxCNC blending for the program's own rapids that
    /// are copied verbatim, where the program's own mode is looser: set before a stretch
    /// of copied lines that moves only at rapid. Those moves are the programmed path
    /// itself, so their blending may take the whole tolerance, not what is left of it
    /// after the smoothing; LinuxCNC blends a junction with the smaller `P` of its two
    /// moves (tc.c `tcFindBlendTolerance`), so a run's ends keep the run's bound. Copied
    /// feed lines keep the runs' bound: LinuxCNC accelerates a line that an arc blend
    /// under a looser `P` joins at half the rate. Default `None`: the runs' `blend`
    /// everywhere.
    pub verbatim_blend: Option<Blend>,
    /// Planes in which arcs may be written as `G2`/`G3` (bit 0 G17, bit 1 G18, bit 2
    /// G19); arcs in other planes are flattened. Default all.
    pub arc_planes: u8,
    /// Whether the controller runs a `G2`/`G3` whose end is off the circle of its start as
    /// LinuxCNC does, a spiral about the programmed centre ([`crate::Dialect::runs_spirals`]).
    /// When false, a spiral arc whose radii differ by more than half the chord tolerance
    /// is flattened. Default true.
    pub spiral_arcs: bool,
    /// How the controller runs a `G2`/`G3` ([`crate::Dialect::arc_chords`]): an arc is
    /// written only where its chords' sagitta fits the budget (within the chord, or what
    /// an arc fit leaves). Default [`ArcChords::Exact`].
    pub arc_chords: ArcChords,
    /// Write every replaceable line with feed motion through the emitter, changed or not
    /// (compressing a program's own G1 runs with [`Emit::Lines`] or [`Emit::Arcs`]); a
    /// line of rapids only is copied (a rapid is the program's). Default false: unchanged
    /// lines are copied verbatim.
    pub rewrite_unchanged: bool,
    /// Under [`Emit::Lines`], [`Emit::G5`] and [`Emit::Nurbs`]: blocks shorter than the
    /// floor are lifted where the written path stays within its tolerance of the
    /// programmed path ([`crate::controller::floor::lift_short_blocks`]). Default `None`.
    pub block_floor: Option<BlockFloor>,
    /// Under the chaining emitters, an arc that would take
    /// `NATIVE_ARC_MIN_BLOCKS` chords stays one `G2`/`G3`; `false`
    /// flattens it with the rest of its run where it meets a flattened curve
    /// ([`crate::Dialect::keeps_long_arcs`]). Default true.
    pub long_arcs: bool,
    /// With [`RewriteOptions::blend`]: the machine's acceleration (mm/s^2). Blocks where
    /// the speed allows then get a smaller `P` ([`crate::controller::linuxcnc::blend::BlendSchedule`]),
    /// so that LinuxCNC's blends leave their lines, along which it accelerates with the
    /// whole of it. Default `None`: one `P` for the whole run.
    pub blend_acc_mm_s2: Option<f64>,
    /// With [`RewriteOptions::blend`] and a long-lines emitter: the blocks of a chain are
    /// evened out for LinuxCNC's blends, which take at most half of each line
    /// ([`crate::controller::linuxcnc::even_out::even_out`]), a point moved inside the curve by no more than its
    /// blend leaves of `P`. Default false.
    pub even_out: bool,
    /// With [`RewriteOptions::blend_acc_mm_s2`]: the machine's fastest feed (mm/s), which
    /// the blends are sized for. Default `None`: the programmed feeds.
    pub blend_feed_mm_s: Option<f64>,
}

/// The shortest block a stepper controller should be given, and the tolerance against
/// the programmed path within which shorter ones may be lifted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlockFloor {
    /// Shortest block (mm).
    pub min_block_mm: f64,
    /// Two-sided tolerance (mm) of the written path against the programmed one: what is
    /// left of the user's tolerance after the printed decimals and any blending.
    pub tol_mm: f64,
    /// LinuxCNC: short blocks are replaced only by the programmed corner, whose blend
    /// gets a `P` of its own, as do tight turns where the tolerance leaves room (`None`:
    /// every replacement, for a stepper controller).
    pub corner: Option<CornerBlend>,
}

/// Accuracy of the programmed curves' flattening for [`BlockFloor`], as a share of its
/// tolerance (deducted from it).
pub(crate) const FLOOR_PROGRAM_SHARE: f64 = 0.01;

impl Default for RewriteOptions {
    fn default() -> Self {
        RewriteOptions {
            decimals: 4,
            chord_mm: 0.001,
            header: None,
            emit: Emit::Native,
            blend: None,
            verbatim_blend: None,
            arc_planes: 0b111,
            spiral_arcs: true,
            arc_chords: ArcChords::Exact,
            rewrite_unchanged: false,
            block_floor: None,
            long_arcs: true,
            blend_acc_mm_s2: None,
            blend_feed_mm_s: None,
            even_out: false,
        }
    }
}

/// How smoothed motion is written.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum Emit {
    /// Move by move: lines as `G1`, arcs in a G-code plane as `G2`/`G3`, every other curve
    /// flattened on its own within the chord.
    Native,
    /// Each run of feed moves at one feed (lines, arcs and curves alike) as the longest
    /// `G1` blocks whose chord, rounding included, stays within the chord tolerance
    /// (`write::chain`); `E` is carried along the blocks (`write::chain_extra`), moves
    /// with other extra axes (A..W) are written move by move.
    Lines {
        /// A last block of a run shorter than `min_block_mm`, or than the run's feed
        /// times `min_block_s`, is merged or balanced with the one before when the
        /// tolerance allows.
        min_block_mm: f64,
        /// See `min_block_mm` (seconds of feed).
        min_block_s: f64,
    },
    /// As [`Emit::Lines`], with arcs: from each written point the longer of the longest
    /// line and the longest XY arc (`G2`/`G3`, helical when Z changes) within the chord
    /// of every point and every chord it spans (`write::chain::fit_arcs`).
    Arcs,
    /// As [`Emit::Lines`], with every cubic Bézier in an XY plane (the B-spline method's
    /// curves) written exactly as one `G5` (LinuxCNC, grblHAL, Marlin).
    G5 {
        /// See [`Emit::Lines`].
        min_block_mm: f64,
        /// See [`Emit::Lines`].
        min_block_s: f64,
    },
    /// As [`Emit::G5`], with every NURBS in an XY plane (the NURBS method's curves)
    /// written exactly as `G5.2 ... G5.3`, one per Bézier span (LinuxCNC).
    Nurbs {
        /// See [`Emit::Lines`].
        min_block_mm: f64,
        /// See [`Emit::Lines`].
        min_block_s: f64,
    },
}

impl RewriteOptions {
    /// Options with `decimals` and `chord_mm`.
    pub fn new(decimals: usize, chord_mm: f64) -> RewriteOptions {
        RewriteOptions {
            decimals,
            chord_mm,
            ..Default::default()
        }
    }

    /// The same options with another emitter.
    pub fn with_emit(self, emit: Emit) -> RewriteOptions {
        RewriteOptions { emit, ..self }
    }

    /// The same options for `dialect`: its arc planes, whether it keeps long arcs and,
    /// when it blends, `blend`.
    pub fn for_dialect(self, dialect: Dialect, blend: Option<Blend>) -> RewriteOptions {
        RewriteOptions {
            arc_planes: dialect.arc_planes(),
            spiral_arcs: dialect.runs_spirals(),
            arc_chords: dialect.arc_chords(),
            long_arcs: dialect.keeps_long_arcs(),
            blend: if dialect.blends() { blend } else { None },
            ..self
        }
    }

    /// The same options with another way the controller runs arcs (a firmware set
    /// otherwise than its dialect's defaults, [`ArcChords::with_segment_mm`]); after
    /// [`RewriteOptions::for_dialect`], which sets the dialect's.
    pub fn with_arc_chords(self, arc_chords: ArcChords) -> RewriteOptions {
        RewriteOptions { arc_chords, ..self }
    }

    /// The same options with [`RewriteOptions::rewrite_unchanged`] set to `all`.
    pub fn with_rewrite_unchanged(self, all: bool) -> RewriteOptions {
        RewriteOptions {
            rewrite_unchanged: all,
            ..self
        }
    }

    /// The same options with a block floor.
    pub fn with_block_floor(self, block_floor: Option<BlockFloor>) -> RewriteOptions {
        RewriteOptions {
            block_floor,
            ..self
        }
    }

    /// The same options with LinuxCNC blending bounds.
    pub fn with_blend(self, blend: Option<Blend>) -> RewriteOptions {
        RewriteOptions { blend, ..self }
    }

    /// The same options with LinuxCNC blending for the verbatim motion
    /// ([`RewriteOptions::verbatim_blend`]).
    pub fn with_verbatim_blend(self, verbatim_blend: Option<Blend>) -> RewriteOptions {
        RewriteOptions {
            verbatim_blend,
            ..self
        }
    }

    /// The blending in force on verbatim motion: `None` when nothing blends.
    pub(crate) fn verbatim_blend_in_force(&self) -> Option<Blend> {
        self.blend.map(|b| self.verbatim_blend.unwrap_or(b))
    }

    /// The same options with the machine's acceleration and fastest feed for the
    /// blending schedule ([`RewriteOptions::blend_acc_mm_s2`]).
    pub fn with_blend_limits(
        self,
        acc_mm_s2: Option<f64>,
        feed_mm_s: Option<f64>,
    ) -> RewriteOptions {
        RewriteOptions {
            blend_acc_mm_s2: acc_mm_s2,
            blend_feed_mm_s: feed_mm_s,
            ..self
        }
    }

    /// The same options with [`RewriteOptions::even_out`] set.
    pub fn with_even_out(self, even_out: bool) -> RewriteOptions {
        RewriteOptions { even_out, ..self }
    }

    /// The same options with header lines.
    pub fn with_header(self, header: impl Into<String>) -> RewriteOptions {
        RewriteOptions {
            header: Some(header.into()),
            ..self
        }
    }
}
