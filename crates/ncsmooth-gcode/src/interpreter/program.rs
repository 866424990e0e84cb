//! A parsed program and the entry points that read one whole: [`parse_str`],
//! [`parse_bytes`], with their settings ([`ParseOptions`]) and counts ([`ParseStats`]).

use super::frames::MachineModel;
use crate::canon::Canon;
use crate::error::{ParseError, ParseErrorKind, Warning};
use crate::source::{Plane, SourceMap};
use ncsmooth::path::Units;
use ncsmooth::Toolpath;

/// Most blocks (moves and events) a reader holds at once, by default: about 1.8 GB of
/// blocks. A whole program ([`parse_bytes`]) holds all of its own, so a larger one (a loop
/// that runs millions of times, a CAM file of tens of millions of lines) is refused with
/// [`ParseErrorKind::TooLarge`] instead of taking the machine's memory; a
/// [`BlockReader`](crate::BlockReader) hands its blocks out as it reads and holds few.
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
    /// Lines whose motion a rewrite may replace ([`crate::source::flags::REPLACEABLE`]: executed
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
    /// What each physical line is, for [`rewrite()`](crate::rewrite()).
    pub source: SourceMap,
    /// Canonical commands, when [`ParseOptions::canon`] asked for them.
    pub canon: Vec<Canon>,
}

/// Parses G-code text. `file_name` is only used in error messages.
pub fn parse_str(src: &str, file_name: &str, opts: &ParseOptions) -> Result<Program, ParseError> {
    super::Interp::new(super::text::Text::Whole(src), file_name, opts).run()
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
