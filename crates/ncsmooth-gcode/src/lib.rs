//! # ncsmooth-gcode
//!
//! RS274/NGC G-code (as LinuxCNC and grbl accept it) to and from the ncsmooth path
//! model ([`ncsmooth::Toolpath`]).
//!
//! * [`parse_str`] / [`parse_bytes`]: a hand-written byte-level [`lexer`] (no regex, no
//!   allocation per word), real-value [`expr`]essions with numbered parameters, and a
//!   modal interpreter ([`parser`]) that produces lines, arcs (all three planes, helical,
//!   multi-turn, I/J/K or R) and events, in millimetres. Errors are typed
//!   ([`ParseErrorKind`]) and located (file, line, column, byte range); no input, however
//!   malformed, makes the parser panic.
//! * [`write()`]: the toolpath back to G-code ([`writer`]), flattening what G-code cannot
//!   carry natively.
//!
//! See each module for the rules and the decisions taken where the standard leaves room.
#![forbid(unsafe_code)]

pub mod error;
pub mod expr;
pub mod lexer;
pub mod parser;
pub mod writer;

pub use error::{ParseError, ParseErrorKind, Warning};
pub use ncsmooth::path::Units;
pub use writer::{write, write_to, WriteOptions};

use ncsmooth::geom::Vec3;
use ncsmooth::Toolpath;

/// Parser settings.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ParseOptions {
    /// Position before the first move (mm); the origin by default.
    pub start: Vec3,
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
    /// Planes selected by the program (G17/G18/G19), in order of first appearance.
    pub planes_seen: Vec<Plane>,
    /// Warnings, in source order.
    pub warnings: Vec<Warning>,
}

/// A parsed program.
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    /// Moves and events, in mm and mm/s.
    pub toolpath: Toolpath,
    /// Counts and warnings.
    pub stats: ParseStats,
}

/// Parses G-code text. `file_name` is only used in error messages.
pub fn parse_str(src: &str, file_name: &str, opts: &ParseOptions) -> Result<Program, ParseError> {
    parser::Interp::new(src, file_name, opts).run()
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
fn non_ascii_comments_replaced(src: &[u8]) -> Vec<u8> {
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
