//! Errors and warnings.
//!
//! Every error carries the file name, the 1-based line and column (counted in Unicode
//! scalar values, as editors do) and the byte range into the source, so that a caller can
//! print a rustc-style snippet (the CLI uses `ariadne`). The [`ParseErrorKind`] says what
//! went wrong in a typed way; its `Display` is the short message.
//!
//! Warnings are things a machine would run but that are worth a look (zero-length moves,
//! a feed move before any `F`, a `G28` after which the position is unknown, ignored words).

use std::fmt;
use std::ops::Range;

/// A parse error: where and what.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}:{line}:{column}: {kind}")]
pub struct ParseError {
    /// File name as given to the parser.
    pub file: String,
    /// 1-based line.
    pub line: u32,
    /// 1-based column, in characters.
    pub column: u32,
    /// Byte range of the offending text in the source.
    pub byte_range: Range<usize>,
    /// What went wrong.
    pub kind: ParseErrorKind,
}

/// What went wrong.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ParseErrorKind {
    /// The source is not valid UTF-8.
    #[error("invalid UTF-8")]
    InvalidUtf8,
    /// A streamed file could not be read.
    #[error("reading the file: {why}")]
    Io {
        /// The system's message.
        why: String,
    },
    /// A word letter with no value after it (`G1 X1 Y`).
    #[error("missing value after '{letter}'")]
    MissingValue {
        /// The word letter.
        letter: char,
    },
    /// A number that is not `digits[.digits]` (`X1..5`, `X.`).
    #[error("malformed number")]
    MalformedNumber,
    /// A `(` comment without its `)` on the same line.
    #[error("unclosed '(' comment")]
    UnclosedComment,
    /// A `(` inside a `( )` comment (LinuxCNC refuses it).
    #[error("'(' inside a comment (comments do not nest)")]
    NestedComment,
    /// A character that cannot start a word.
    #[error("unexpected character {ch:?}")]
    UnexpectedChar {
        /// The character.
        ch: char,
    },
    /// A G or M code (or letter) this reader does not know.
    #[error("unknown word {word}")]
    UnknownWord {
        /// The word as written canonically (`G12`, `M123.4`).
        word: String,
    },
    /// A known construct that ncsmooth deliberately does not support because it changes
    /// the motion in ways the path model cannot represent.
    #[error("unsupported {word}: {why}")]
    Unsupported {
        /// The word or construct (`G41`, `O-word`, `#<name>`).
        word: String,
        /// Why it is refused.
        why: &'static str,
    },
    /// The same letter twice in one block (`X1 X2`).
    #[error("word '{letter}' appears twice in the block")]
    DuplicateWord {
        /// The letter.
        letter: char,
    },
    /// Two G codes of the same modal group in one block (`G0 G1`).
    #[error("{first} and {second} are in the same modal group")]
    ModalConflict {
        /// First code.
        first: String,
        /// Second code.
        second: String,
    },
    /// A word a code needs is absent (`G4` without `P`).
    #[error("{code} needs a {letter} word")]
    MissingWord {
        /// The code that needs it.
        code: String,
        /// The missing letter.
        letter: char,
    },
    /// A value out of its allowed range (negative F, non-integer P turns, ...).
    #[error("invalid {letter} value {value}: {why}")]
    InvalidValue {
        /// The word letter.
        letter: char,
        /// The value read.
        value: f64,
        /// Why it is invalid.
        why: &'static str,
    },
    /// A canned-cycle or spline block LinuxCNC refuses: the retract plane below the bottom
    /// of the hole, a missing word a cycle needs the first time, a spline outside the XY
    /// plane, too few NURBS control points, ...
    #[error("{code}: {why}")]
    InvalidMotion {
        /// The motion code (`G81`, `G5.2`).
        code: String,
        /// What is wrong.
        why: String,
    },
    /// Axis words with no motion mode in force (after `G80`).
    #[error("axis words without a motion mode (G80 is in force)")]
    NoMotionMode,
    /// `G2`/`G3` without `I`/`J`/`K` or `R`.
    #[error("arc without centre: G2/G3 needs I/J/K offsets in the active plane or R")]
    ArcNoCentre,
    /// `G2`/`G3` with both `R` and `I`/`J`/`K`.
    #[error("arc with both R and I/J/K")]
    ArcMixedFormat,
    /// `G2`/`G3` without any axis word.
    #[error("arc without end point (no axis word)")]
    ArcNoAxes,
    /// Start and end radii of an I/J/K arc differ by more than max(0.005 mm, 0.1 %).
    #[error("arc radius mismatch: {r_start} mm at the start, {r_end} mm at the end")]
    ArcRadiusMismatch {
        /// Radius at the start (mm).
        r_start: f64,
        /// Radius at the end (mm).
        r_end: f64,
    },
    /// An R arc whose chord is longer than the diameter beyond tolerance.
    #[error("arc radius {radius} mm too small for a chord of {chord} mm")]
    ArcRadiusTooSmall {
        /// |R| (mm).
        radius: f64,
        /// Chord length (mm).
        chord: f64,
    },
    /// An arc that cannot be built (zero radius, R arc with end = start).
    #[error("degenerate arc: {why}")]
    ArcDegenerate {
        /// Why.
        why: &'static str,
    },
    /// A malformed or non-computable `[ ]` expression.
    #[error("expression error: {why}")]
    ExpressionError {
        /// Why.
        why: &'static str,
    },
    /// A numbered parameter read before any assignment.
    #[error("parameter #{index} is used before being set")]
    UndefinedParameter {
        /// The parameter number.
        index: u32,
    },
    /// A computed value or position is not finite.
    #[error("value out of range")]
    OutOfRange,
    /// A parameter word no code of its block uses (`G61 R0.5`): LinuxCNC refuses it.
    #[error("{letter} word with no code in the block that uses it")]
    UnusedWord {
        /// The letter.
        letter: char,
    },
    /// A feed move with no feed rate in force (no F yet, or F0): LinuxCNC and grbl refuse
    /// it.
    #[error("feed move with no feed rate (program an F word before the first G1/G2/G3)")]
    NoFeedRate,
    /// A named parameter read before any assignment (`#<depth>`).
    #[error("named parameter #<{name}> is used before being set")]
    UndefinedNamedParameter {
        /// The name, lower case.
        name: String,
    },
    /// A value that depends on machine state ncsmooth cannot know (a stored work offset,
    /// a home position, a tool table entry) where the program needs it to be known: a
    /// condition, a feed, a dwell, a canned-cycle depth.
    #[error("{what} depends on machine state unknown to ncsmooth (stored offsets, home positions or tool data); run it on the controller, or compute the value in CAM")]
    UnknownValue {
        /// What needed the value (`condition of O100 if`, `F word`).
        what: String,
    },
    /// An axis position beyond what the numerics carry to the micrometre
    /// (`MAX_COORDINATE`).
    #[error("{letter} reaches {value:e}, beyond the range ncsmooth computes in (|position| at most {max:e} mm, or degrees for A, B and C)")]
    CoordinateRange {
        /// The axis letter.
        letter: char,
        /// The position it reaches (mm, or degrees).
        value: f64,
        /// The largest allowed.
        max: f64,
    },
    /// The program needs more blocks held at once than the reader may hold
    /// ([`crate::ParseOptions::max_held_blocks`]), or more memory than the system gives.
    #[error("the program runs to more than {limit} moves and events held at once ({why}); `ncsmooth plan` reads a program of any size as it goes")]
    TooLarge {
        /// The limit reached.
        limit: usize,
        /// What ran out: the limit, or the system's memory.
        why: &'static str,
    },
    /// Malformed or unmatched O-word control flow (`endwhile` without `while`, a `call`
    /// to a subroutine the file does not define).
    #[error("{why}")]
    ControlFlow {
        /// What is wrong.
        why: String,
    },
}

/// A non-fatal remark about the program.
#[derive(Clone, Debug, PartialEq)]
pub struct Warning {
    /// 1-based source line.
    pub line: u32,
    /// What is remarkable.
    pub message: String,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "line {}: {}", self.line, self.message)
    }
}

/// Line, column (1-based, in characters) and a char-aligned byte range for a byte offset
/// range in `src` (which may be any bytes: columns count UTF-8 lead bytes).
pub(crate) fn locate(src: &[u8], range: Range<usize>) -> (u32, u32, Range<usize>) {
    let start = range.start.min(src.len());
    let mut end = range.end.clamp(start, src.len());
    while end < src.len() && (src[end] & 0xC0) == 0x80 {
        end += 1;
    }
    let line_start = src[..start]
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |p| p + 1);
    let line = src[..line_start].iter().filter(|&&b| b == b'\n').count() + 1;
    let column = src[line_start..start]
        .iter()
        .filter(|&&b| (b & 0xC0) != 0x80)
        .count()
        + 1;
    (
        u32::try_from(line).unwrap_or(u32::MAX),
        u32::try_from(column).unwrap_or(u32::MAX),
        start..end,
    )
}

/// Where `range` of a line is: `(line number, column, range)`. `line` is the text of line
/// index `k` starting at offset `start`; a range outside it is clamped to it.
pub(crate) fn locate_in_line(
    line: &[u8],
    k: usize,
    start: usize,
    range: Range<usize>,
) -> (u32, u32, Range<usize>) {
    let rel = range.start.saturating_sub(start)..range.end.saturating_sub(start);
    let (_, column, r) = locate(line, rel);
    (
        u32::try_from(k + 1).unwrap_or(u32::MAX),
        column,
        start + r.start..start + r.end,
    )
}

impl ParseError {
    /// Builds an error located at `range` of line index `k`, whose text `line` starts at
    /// offset `start` of the source.
    pub(crate) fn in_line(
        file: &str,
        line: &[u8],
        k: usize,
        start: usize,
        range: Range<usize>,
        kind: ParseErrorKind,
    ) -> Self {
        let (line, column, byte_range) = locate_in_line(line, k, start, range);
        ParseError {
            file: file.to_string(),
            line,
            column,
            byte_range,
            kind,
        }
    }

    /// Builds an error located at `range` of `src`.
    pub(crate) fn at(file: &str, src: &[u8], range: Range<usize>, kind: ParseErrorKind) -> Self {
        let (line, column, byte_range) = locate(src, range);
        ParseError {
            file: file.to_string(),
            line,
            column,
            byte_range,
            kind,
        }
    }
}
