//! What the interpreter learned about each physical line, for writers that rewrite the
//! program in place ([`crate::rewrite()`]): which lines may be replaced by smoothed motion,
//! and the modal state a replacement must restore after itself.

use ncsmooth::path::Units;

/// The active plane for arcs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Plane {
    /// G17: XY, normal +Z.
    #[default]
    XY,
    /// G18: ZX, normal +Y.
    XZ,
    /// G19: YZ, normal +X.
    YZ,
}

/// The modal state a writer needs after a line: how its successors read axis words.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WriteState {
    /// G20/G21 (as assumed when the program never says: millimetres).
    pub units: Units,
    /// G90 (true) or G91.
    pub absolute: bool,
    /// G90.1 (true) or G91.1 arc centres.
    pub arc_absolute: bool,
    /// Active plane.
    pub plane: Plane,
    /// G7 lathe diameter mode (X words are diameters).
    pub diameter: bool,
    /// M83: E words are relative.
    pub e_relative: bool,
    /// Group-1 motion code in force, in tenths (`10` = G1, `800` = none after G80).
    pub motion10: u16,
    /// The feed word in force as programmed (units per minute), NaN when none.
    pub feed_word: f64,
    /// Bit `i` set when axis `i` of X Y Z A B C U V W is known in the work frame.
    pub known: u16,
    /// Bit `i` set when axis `i` is known only relative to a start the program never
    /// placed (incremental moves from an unknown position): written only as increments.
    pub relative: u16,
    /// Path control mode in force (G61, G61.1, G64 P Q).
    pub path: PathMode,
}

/// LinuxCNC's path control mode: how the controller may blend between blocks.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum PathMode {
    /// Nothing programmed: the controller's start-up mode (LinuxCNC's is `G64` without
    /// `P`, which blends without a bound on the deviation).
    #[default]
    Unset,
    /// `G61`: exact path, no blending.
    ExactPath,
    /// `G61.1`: exact stop at the end of every block.
    ExactStop,
    /// `G64` with its `P` (blend tolerance) and `Q` (naive-CAM tolerance) in millimetres,
    /// NaN when not given (LinuxCNC then takes `Q = P`; without `P` blending is unbounded).
    Blend {
        /// `P` in mm, NaN when absent.
        p_mm: f64,
        /// `Q` in mm, NaN when absent.
        q_mm: f64,
    },
}

impl PathMode {
    /// Largest deviation (mm) the controller's blending and naive-CAM merging may add to
    /// the written path in this mode (`P + Q`, `Q` defaulting to `P`); infinite when
    /// unbounded (start-up mode or `G64` without `P`).
    pub fn blend_bound_mm(self) -> f64 {
        match self {
            PathMode::ExactPath | PathMode::ExactStop => 0.0,
            PathMode::Unset => f64::INFINITY,
            PathMode::Blend { p_mm, q_mm } => {
                if p_mm.is_nan() {
                    return f64::INFINITY;
                }
                let q = if q_mm.is_nan() { p_mm } else { q_mm };
                p_mm.max(0.0) + q.max(0.0)
            }
        }
    }
}

impl Default for WriteState {
    fn default() -> Self {
        WriteState {
            units: Units::Millimetres,
            absolute: true,
            arc_absolute: false,
            plane: Plane::XY,
            diameter: false,
            e_relative: false,
            motion10: 0,
            feed_word: f64::NAN,
            known: 0,
            relative: 0,
            path: PathMode::Unset,
        }
    }
}

/// Flags of a line.
pub mod flags {
    /// The line was executed.
    pub const EXECUTED: u8 = 1;
    /// Its motion may be replaced: executed once at the top level (not in a subroutine,
    /// loop or conditional), no block delete, no comment, no parameter assignment, no
    /// event, and only motion, plane, distance-mode and feed words.
    pub const REPLACEABLE: u8 = 2;
    /// It runs motion with no group-1 code of its own: it relies on the motion mode in
    /// force (`X1 Y2` after `G1`, `I5 J0` after `G2`).
    pub const MODAL_MOTION: u8 = 4;
    /// It has a group-1 code (G0..G3, G5.x, a canned cycle, G80, ...).
    pub const EXPLICIT_MOTION: u8 = 8;
    /// It is an O-word statement.
    pub const OWORD: u8 = 16;
    /// It sets the path mode (`G61`, `G61.1`, `G64`), on some execution.
    pub const PATH_MODE: u8 = 32;
}

/// One physical line.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct LineInfo {
    /// Byte range in the source (without the line break).
    pub start: usize,
    /// End of the byte range.
    pub end: usize,
    /// [`flags`].
    pub flags: u8,
    /// State before the line (meaningful for replaceable lines).
    pub before: WriteState,
    /// State after the line (meaningful for replaceable lines).
    pub state: WriteState,
}

impl LineInfo {
    /// Whether flag `f` is set.
    #[inline]
    pub fn has(&self, f: u8) -> bool {
        self.flags & f != 0
    }
}

/// Every physical line of a program, in order.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct SourceMap {
    /// Lines (index 0 is line 1).
    pub lines: Vec<LineInfo>,
    /// Index of the line that ends the program (M2, M30 or a closing `%`), if any: what
    /// follows is never executed and is copied verbatim.
    pub end_line: Option<usize>,
}
