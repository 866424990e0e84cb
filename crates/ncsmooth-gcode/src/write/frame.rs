//! How a motion writer writes: the units, modes and axes of the program it writes into
//! (`Frame`) and how it writes runs of feed moves (`ChainMode`).

#[cfg(doc)]
use super::motion::{MotionWriter, NATIVE_ARC_MIN_BLOCKS};
use crate::controller::arcs::ArcChords;
#[cfg(doc)]
use ncsmooth::path::EXTRA_AXIS_NAMES;

/// How runs of feed moves are written under a long-block emitter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ChainMode {
    /// Shortest last block to aim for (mm).
    pub min_block_mm: f64,
    /// ... or this many seconds of the run's feed.
    pub min_block_s: f64,
    /// Fit XY arcs (G2/G3) as well as lines.
    pub arcs: bool,
    /// Arcs that would take [`NATIVE_ARC_MIN_BLOCKS`] chords stay `G2`/`G3` and end the
    /// chain; `false` flattens those next to a flattened curve with the rest
    /// ([`crate::Dialect::keeps_long_arcs`], [`MotionWriter::chainable_at`]).
    pub long_arcs: bool,
}

/// How a [`MotionWriter`] writes: units, modes and which axes it may write.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Frame {
    /// Coordinate decimals.
    pub decimals: usize,
    /// Flattening chord (mm).
    pub chord_mm: f64,
    /// Millimetres per written unit (1 or 25.4).
    pub scale: f64,
    /// Bit `i` set when X/Y/Z `i` may be written (its position is known).
    pub allowed_xyz: u8,
    /// Arc centres as absolute coordinates (G90.1) rather than offsets.
    pub arc_absolute: bool,
    /// E words relative (M83).
    pub e_relative: bool,
    /// G7: X is written as a diameter.
    pub diameter: bool,
    /// Plane in force (17, 18, 19).
    pub plane: u8,
    /// Extra axes in use (bit per [`EXTRA_AXIS_NAMES`]).
    pub extra_mask: u8,
    /// `Some`: runs of feed moves are written as long blocks ([`crate::write::chain`]); `None`:
    /// move by move.
    pub chain: Option<ChainMode>,
    /// Planes for `G2`/`G3` (bit 0 G17, bit 1 G18, bit 2 G19).
    pub arc_planes: u8,
    /// Spiral arcs (end radius off the start radius) are written as `G2`/`G3`; when false
    /// only those within half the chord of a circle are.
    pub spiral_arcs: bool,
    /// Cubic Béziers in the XY plane are written as `G5` (exact).
    pub g5: bool,
    /// NURBS in the XY plane are written as `G5.2`/`G5.3`, one per Bézier span (exact).
    pub nurbs: bool,
    /// X Y Z are written as increments (under `G91`): some of them are known only relative
    /// to a start the program never placed. Each increment is the exact difference of the
    /// absolute values the writer would print, so the reader is exactly where those put it.
    pub incremental: bool,
    /// How the controller runs a `G2`/`G3` (its chords' sagitta is counted).
    pub arc_chords: ArcChords,
}

impl Default for Frame {
    fn default() -> Self {
        Frame {
            decimals: 4,
            chord_mm: 0.001,
            scale: 1.0,
            allowed_xyz: 0b111,
            arc_absolute: false,
            e_relative: false,
            diameter: false,
            plane: 17,
            extra_mask: 0,
            chain: None,
            arc_planes: 0b111,
            spiral_arcs: true,
            g5: false,
            nurbs: false,
            incremental: false,
            arc_chords: ArcChords::Exact,
        }
    }
}
