//! # ncsmooth-gcode
//!
//! RS274/NGC G-code (as LinuxCNC and grbl accept it) to and from the ncsmooth path
//! model ([`ncsmooth::Toolpath`]).
//!
//! * [`parse_str`] / [`parse_bytes`]: a hand-written byte-level [`lexer`] (no regex, no
//!   allocation per word), real-value [`expr`]essions with numbered and named parameters,
//!   and a modal interpreter ([`interp`]) with LinuxCNC's semantics: O-word control flow,
//!   coordinate systems and offsets, what is known of the position, lines, arcs (all three
//!   planes, helical, multi-turn, I/J/K or R), canned cycles, splines, and events, in
//!   millimetres. Errors are typed ([`ParseErrorKind`]) and located (file, line, column,
//!   byte range); no input, however malformed, makes the parser panic.
//! * [`rewrite()`]: a smoothed toolpath written back into the program's own text: every
//!   line that is not smoothed motion is copied verbatim ([`mod@rewrite`]).
//! * [`write()`]: a toolpath without source to G-code ([`writer`]), flattening what
//!   G-code cannot carry natively.
//!
//! See each module for the rules and the decisions taken where the standard leaves room.
//!
//! ## Read a program, smooth it, write it
//!
//! ```
//! use ncsmooth::{smooth, Method, SmoothOptions};
//! use ncsmooth_gcode::{parse_str, read_back, rewrite, Budget, ParseOptions, RewriteOptions};
//!
//! let src = "G21 G90 G17 (a zig-zag)\nG0 X0 Y0 Z1\nG1 Z0 F600\n\
//!            G1 X1 Y0.5\nG1 X2 Y0\nG1 X3 Y0.5\nG1 X4 Y0\nM5\nM2\n";
//! let program = parse_str(src, "zigzag.ngc", &ParseOptions::default()).unwrap();
//!
//! // 0.01 mm in all: the curves get what the flattening chord (0.001 mm) and the
//! // printed decimals (4: up to 0.00009 mm per point) leave; no controller blending.
//! let budget = Budget::new(&program, 0.01, 0.001, 4, 0.0);
//! let mut opts = SmoothOptions::default();
//! opts.method = Method::Bspline;
//! opts.tol_mm = budget.curve_tol_mm();
//! let smoothed = smooth(&program.toolpath, &opts).unwrap();
//! let text = rewrite(src.as_bytes(), &program, &smoothed.toolpath, &RewriteOptions::new(4, 0.001))
//!     .unwrap();
//!
//! // The comment, the spindle stop and the end are where they were; the corners are curves
//! // (flattened into short G1 lines) within 0.01 mm of the program, both ways, as read back.
//! let as_text = String::from_utf8(text.clone()).unwrap();
//! assert!(as_text.starts_with("G21 G90 G17 (a zig-zag)\n") && as_text.contains("M5\nM2\n"));
//! let (written, dev) = read_back(&text, "out.ngc", &program.toolpath, 1e-6).unwrap();
//! assert!(written.moves().count() > program.toolpath.moves().count());
//! assert!(budget.holds(&dev));
//! ```
#![forbid(unsafe_code)]

pub mod budget;
pub mod canon;
pub mod controller;
pub mod error;
pub mod expr;
pub mod interp;
pub mod lexer;
pub mod numbers;
pub(crate) mod polyline;
pub mod source;
pub mod stream;
pub mod write;

pub use budget::{read_back, Budget};
pub use stream::BlockReader;

pub use canon::Canon;
pub use controller::dialect::Dialect;
pub use error::{ParseError, ParseErrorKind, Warning};
pub use interp::frames::MachineModel;
pub use ncsmooth::path::Units;
pub use source::SourceMap;
pub use write::rewrite::{rewrite, RewriteOptions};
pub use write::{write, write_to, WriteOptions};

/// The writer's numbers, plain writer, motion constants and LinuxCNC blend schedule, at
/// their old path ([`numbers`], [`mod@write`], [`controller::linuxcnc::blend`]).
pub mod writer {
    // compatibility path
    pub use crate::controller::linuxcnc::blend::{
        BlendSchedule, RunEnd, RunEnds, BLEND_SCHEDULE_MIN_SHARE, BLEND_SCHEDULE_SPEED_PASSES,
        BLEND_SCHEDULE_STEPS_PER_HALVING, LINUXCNC_BLEND_GAP_CYCLES, LINUXCNC_NORMAL_ACC_SHARE,
        LINUXCNC_TANGENTIAL_ACC_SHARE, LINUXCNC_TANGENT_KINK_RATIO, ROOM_SAMPLES, SPLIT_CANDIDATES,
        SPLIT_KINK_RATIO, SPLIT_MIN_GAIN, SPLIT_ROOM,
    };
    pub use crate::numbers::{
        push_fixed, rounding_mm, CENTRE_EXTRA_DECIMALS, E_EXTRA_DECIMALS, MAX_DECIMALS,
        PRINT_DECIMALS_MAX,
    };
    pub use crate::write::motion::{
        EXACT_END_SNAP_MM, MIN_ARC_CHORD_MM, MIN_ARC_RADIUS_MM, NATIVE_ARC_MIN_BLOCKS,
    };
    pub use crate::write::{write, write_to, WriteOptions};
}

/// A program rewritten in its own text, at its old path ([`write::rewrite`]).
pub mod rewrite {
    // compatibility path
    pub use crate::controller::linuxcnc::{Blend, CornerBlend};
    pub use crate::write::rewrite::*;
}

/// Chains of long blocks, evening out and lifting, at their old path
/// ([`write::chain`], [`controller::linuxcnc::even_out`], [`controller::floor`]).
pub mod chain {
    // compatibility path
    pub use crate::controller::floor::{lift_short_blocks, Program};
    pub use crate::controller::linuxcnc::even_out::{
        even_out, EvenOut, EVEN_OUT_STEPS, EVEN_OUT_SWEEPS,
    };
    pub use crate::write::chain::*;
}

/// Extra axes along a chain, at their old path ([`write::chain_extra`]).
pub mod chain_extra {
    // compatibility path
    pub use crate::write::chain_extra::*;
}

/// The capability table, at its old path ([`controller::dialect`]).
pub mod dialect {
    // compatibility path
    pub use crate::controller::dialect::*;
}

/// LinuxCNC's executed path, at its old path ([`controller::linuxcnc::executed`]).
pub mod executed {
    // compatibility path
    pub use crate::controller::linuxcnc::executed::*;
}

use ncsmooth::Toolpath;

/// Most blocks (moves and events) a reader holds at once, by default: about 1.8 GB of
/// blocks. A whole program ([`parse_bytes`]) holds all of its own, so a larger one (a loop
/// that runs millions of times, a CAM file of tens of millions of lines) is refused with
/// [`ParseErrorKind::TooLarge`] instead of taking the machine's memory; a
/// [`BlockReader`] hands its blocks out as it reads and holds few.
pub const MAX_HELD_BLOCKS: usize = 8_000_000;

/// Parser settings.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct ParseOptions {
    /// The machine's stored state (offsets, tool table, home positions, start position),
    /// when it is known. Default `None`: unknown, as it is for a program ncsmooth rewrites;
    /// positions are then known only where the program establishes them. A model (e.g.
    /// [`MachineModel::default`], LinuxCNC's standalone interpreter) makes every position
    /// known, for comparisons with LinuxCNC's canonical output.
    pub machine: Option<MachineModel>,
    /// Record the canonical commands ([`Program::canon`]). Default false.
    pub canon: bool,
    /// Most blocks held at once ([`ParseErrorKind::TooLarge`] beyond). Default
    /// [`MAX_HELD_BLOCKS`].
    pub max_held_blocks: usize,
    /// Units of a program until its first G20/G21. LinuxCNC reads such a program in the
    /// machine's units (its `[TRAJ] LINEAR_UNITS`; `rs274` standalone: inches); a program
    /// that moves before choosing gets a warning ([`ParseStats::units_assumed`]). Default
    /// millimetres.
    pub default_units: Units,
}

impl Default for ParseOptions {
    fn default() -> Self {
        ParseOptions {
            machine: None,
            canon: false,
            max_held_blocks: MAX_HELD_BLOCKS,
            default_units: Units::Millimetres,
        }
    }
}

impl ParseOptions {
    /// The same options reading a program in `units` until its first G20/G21.
    pub fn with_default_units(self, units: Units) -> ParseOptions {
        ParseOptions {
            default_units: units,
            ..self
        }
    }

    /// The same options holding at most `n` blocks at once.
    pub fn with_max_held_blocks(self, n: usize) -> ParseOptions {
        ParseOptions {
            max_held_blocks: n,
            ..self
        }
    }

    /// Options with a known machine model.
    pub fn with_machine(machine: MachineModel) -> ParseOptions {
        ParseOptions {
            machine: Some(machine),
            ..Default::default()
        }
    }
}

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

/// Counts and remarks gathered while parsing.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ParseStats {
    /// Physical lines.
    pub lines: usize,
    /// Source size in bytes.
    pub bytes: usize,
    /// Rapid moves (G0, including G53 rapids).
    pub g0: usize,
    /// Linear feed moves (G1, including G53 feeds; extra-axis-only moves are events and
    /// are not counted).
    pub g1: usize,
    /// Clockwise arcs.
    pub g2: usize,
    /// Counter-clockwise arcs.
    pub g3: usize,
    /// Zero-length G0/G1 moves (kept, and each warned about).
    pub zero_length_moves: usize,
    /// Units selected by the program (G20/G21), in order of first appearance.
    pub units_seen: Vec<Units>,
    /// The line of the first move made before any G20/G21, read in
    /// [`ParseOptions::default_units`].
    pub units_assumed: Option<u32>,
    /// Planes selected by the program (G17/G18/G19), in order of first appearance.
    pub planes_seen: Vec<Plane>,
    /// Motions ncsmooth cannot place ([`ncsmooth::path::EventKind::Untracked`]: G53, G28,
    /// moves from positions the program has not established).
    pub untracked: usize,
    /// Line and reason of the first of them.
    pub untracked_first: Option<(u32, String)>,
    /// Warnings, in source order.
    pub warnings: Vec<Warning>,
    /// Lines whose motion a rewrite may replace ([`source::flags::REPLACEABLE`]: executed
    /// once at the top level, nothing but motion words); the others are written verbatim.
    pub replaceable_lines: usize,
    /// Bit mask of the axes (X Y Z, then the extra axes) the program establishes on some
    /// line: an axis never established is never written.
    pub axes_known: u16,
}

/// A parsed program.
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    /// Moves and events, in mm and mm/s.
    pub toolpath: Toolpath,
    /// Counts and warnings.
    pub stats: ParseStats,
    /// What each physical line is, for [`rewrite()`].
    pub source: SourceMap,
    /// Canonical commands, when [`ParseOptions::canon`] asked for them.
    pub canon: Vec<Canon>,
}

/// Parses G-code text. `file_name` is only used in error messages.
pub fn parse_str(src: &str, file_name: &str, opts: &ParseOptions) -> Result<Program, ParseError> {
    interp::Interp::new(interp::text::Text::Whole(src), file_name, opts).run()
}

/// Parses G-code bytes. Text in comments is never interpreted, so bytes that are not UTF-8
/// there (a `Ø` or `°` from a Windows-1252 CAM post) are read as `?`; invalid UTF-8 outside
/// comments is a [`ParseErrorKind::InvalidUtf8`] error at the first offending byte. Byte
/// offsets (and so error locations) are those of `src`.
pub fn parse_bytes(
    src: &[u8],
    file_name: &str,
    opts: &ParseOptions,
) -> Result<Program, ParseError> {
    let invalid = |src: &[u8], e: std::str::Utf8Error| {
        let start = e.valid_up_to();
        let len = e.error_len().unwrap_or(src.len() - start).max(1);
        ParseError::at(
            file_name,
            src,
            start..(start + len).min(src.len()),
            ParseErrorKind::InvalidUtf8,
        )
    };
    match std::str::from_utf8(src) {
        Ok(s) => parse_str(s, file_name, opts),
        Err(_) => {
            let cleaned = non_ascii_comments_replaced(src);
            match std::str::from_utf8(&cleaned) {
                Ok(s) => parse_str(s, file_name, opts),
                Err(e) => Err(invalid(src, e)),
            }
        }
    }
}

/// A copy of `src` with every non-ASCII byte inside a `( )` or `;` comment replaced by
/// `?` (one byte for one byte, so offsets are unchanged).
pub(crate) fn non_ascii_comments_replaced(src: &[u8]) -> Vec<u8> {
    let mut out = src.to_vec();
    let (mut paren, mut semicolon) = (false, false);
    for b in out.iter_mut() {
        match *b {
            b'\n' => (paren, semicolon) = (false, false),
            b'(' if !semicolon => paren = true,
            b')' if paren => paren = false,
            b';' if !paren => semicolon = true,
            0x80.. if paren || semicolon => *b = b'?',
            _ => {}
        }
    }
    out
}
