//! Byte-level lexer.
//!
//! RS274/NGC ignores white space everywhere outside comments and is case-insensitive, so
//! `G 0 1 X 1 0 . 5` is the block `G01 X10.5` (LinuxCNC strips spaces before reading a
//! line the same way). The lexer therefore works in two passes over each physical line,
//! both without allocation in steady state:
//!
//! 1. `compact_line` copies the line into a reused buffer, dropping white space
//!    (space, tab, CR, VT, FF), `( )` comments and everything after `;`, upper-casing ASCII
//!    letters, and records for every kept byte its offset in the source (for error spans).
//!    A `(` without `)` on the same line is an [`UnclosedComment`](ParseErrorKind::UnclosedComment)
//!    error. A leading `/` (block delete) is dropped and recorded
//!    (`LineBuf::block_delete`). A line whose first character is `%` is a program
//!    delimiter (`LineBuf::percent`) and is empty. The source range of the last `( )`
//!    comment of the line is recorded (`LineBuf::comment`): LinuxCNC passes that one to
//!    the controller (`COMMENT`, or a message for `(MSG,...)` and the other active
//!    comments). `;` comments are recorded (`LineBuf::semicolon`) and never interpreted.
//! 2. `read_block` splits the compacted bytes into words (a letter and a real value) and
//!    `#n=value` / `#<name>=value` parameter assignments. O-word statements (control flow)
//!    are read by `crate::interpreter::oword`, not here. Values are numbers, `#n` references, `[ ]`
//!    expressions or unary functions ([`crate::expr`]). Numbers are `digits[.digits]` or
//!    `.digits` (no exponent, as NGC) and are converted with `str::parse::<f64>` on the
//!    digits, so `X1234.56789` is exactly the nearest `f64`.
//!
//! After a value the next byte must start a word (a letter or `#`); anything else is an
//! error. That is how `X1..5` is caught ([`MalformedNumber`](ParseErrorKind::MalformedNumber)).
//! An `E` written directly against a number (`X1e3`, no space) is exponent notation, which
//! NGC does not have, and an error rather than an E-axis word; slicer files write
//! `X1 E3` with a space.

use crate::cursor::{Cursor, LexError};
use crate::error::ParseErrorKind;
use crate::expr::{read_name, read_real_value, ParamLookup};

/// One line with white space and comments removed, upper case, plus a source map.
#[derive(Default)]
pub(crate) struct LineBuf {
    /// Compacted bytes.
    pub bytes: Vec<u8>,
    /// Source byte offset of each compacted byte.
    pub map: Vec<usize>,
    /// Source byte offset of the end of the line (before the `\n`).
    pub line_end: usize,
    /// The line starts with `/` (block delete).
    pub block_delete: bool,
    /// The line is a `%` program delimiter.
    pub percent: bool,
    /// Source byte range of the content of the last `( )` comment (without the
    /// parentheses).
    pub comment: Option<(usize, usize)>,
    /// Number of `( )` comments on the line.
    pub paren_comments: u32,
    /// Source byte offset of a `;` comment.
    pub semicolon: Option<usize>,
}

#[inline]
fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | 0x0b | 0x0c)
}

/// Compacts `line` (which starts at source offset `line_start`) into `out`.
pub(crate) fn compact_line(
    line: &[u8],
    line_start: usize,
    out: &mut LineBuf,
) -> Result<(), LexError> {
    out.bytes.clear();
    out.map.clear();
    out.line_end = line_start + line.len();
    out.block_delete = false;
    out.percent = false;
    out.comment = None;
    out.paren_comments = 0;
    out.semicolon = None;
    let mut i = 0;
    // Leading white space, then `%` (program delimiter) or `/` (block delete).
    while i < line.len() && is_space(line[i]) {
        i += 1;
    }
    if i < line.len() {
        match line[i] {
            b'%' => {
                out.percent = true;
                return Ok(());
            }
            b'/' => {
                out.block_delete = true;
                i += 1;
            }
            _ => {}
        }
    }
    while i < line.len() {
        let b = line[i];
        match b {
            b'(' => match line[i + 1..].iter().position(|&c| c == b')' || c == b'(') {
                Some(p) if line[i + 1 + p] == b'(' => {
                    // LinuxCNC: "nested comment found".
                    return Err(LexError {
                        kind: ParseErrorKind::NestedComment,
                        start: line_start + i + 1 + p,
                        end: line_start + i + 2 + p,
                    });
                }
                Some(p) => {
                    out.comment = Some((line_start + i + 1, line_start + i + 1 + p));
                    out.paren_comments += 1;
                    i += p + 2;
                }
                None => {
                    return Err(LexError {
                        kind: ParseErrorKind::UnclosedComment,
                        start: line_start + i,
                        end: out.line_end,
                    })
                }
            },
            b';' => {
                out.semicolon = Some(line_start + i);
                break;
            }
            _ if is_space(b) => i += 1,
            _ => {
                out.bytes.push(b.to_ascii_uppercase());
                out.map.push(line_start + i);
                i += 1;
            }
        }
    }
    Ok(())
}

/// True when the `E` at compacted index `e` directly follows a digit or point in the
/// source (no white space between) and is followed by a digit, sign or point: `X1e3`,
/// `F1.5E+2`. NGC has no exponent notation, and reading such text as a number followed by
/// an E-axis word would silently move an extruder axis instead of the intended value.
fn looks_like_exponent(c: &Cursor<'_>, e: usize) -> bool {
    if e == 0 || c.map[e] != c.map[e - 1] + 1 {
        return false;
    }
    let before = c.buf[e - 1];
    let after = c.buf.get(e + 1).copied();
    (before.is_ascii_digit() || before == b'.')
        && matches!(after, Some(b'0'..=b'9' | b'+' | b'-' | b'.'))
}

/// A word: a letter and its value, with its source span.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Word {
    pub letter: u8,
    pub value: f64,
    /// Source byte range of the word.
    pub start: usize,
    pub end: usize,
}

/// What a parameter assignment sets.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum AssignTarget {
    /// `#n`.
    Numbered(u32),
    /// `#<name>` (upper case).
    Named(Box<[u8]>),
}

/// A pending `#n=value` or `#<name>=value` assignment (applied after the line).
#[derive(Clone, Debug)]
pub(crate) struct Assign {
    pub target: AssignTarget,
    pub value: f64,
    /// Source byte range of the assignment.
    pub start: usize,
    pub end: usize,
}

/// Splits a compacted line into words and parameter assignments. Values are evaluated
/// with the parameters as they were before the line.
pub(crate) fn read_block<P: ParamLookup>(
    line: &LineBuf,
    start_at: usize,
    params: &P,
    words: &mut Vec<Word>,
    assigns: &mut Vec<Assign>,
) -> Result<(), LexError> {
    words.clear();
    assigns.clear();
    let mut c = Cursor {
        buf: &line.bytes,
        map: &line.map,
        line_end: line.line_end,
        pos: start_at,
    };
    while let Some(b) = c.peek() {
        let start = c.pos;
        match b {
            b'#' => {
                c.pos += 1;
                let target = if c.peek() == Some(b'<') {
                    AssignTarget::Named(read_name(&mut c)?.into())
                } else {
                    let idx_start = c.pos;
                    let idx = read_real_value(&mut c, params, 0, None)?;
                    let index = crate::expr::param_index(idx)
                        .ok_or_else(|| c.error(ParseErrorKind::OutOfRange, idx_start, c.pos))?;
                    AssignTarget::Numbered(index)
                };
                if c.peek() != Some(b'=') {
                    return Err(c.error(
                        ParseErrorKind::ExpressionError {
                            why: "expected '=' in parameter assignment",
                        },
                        start,
                        c.pos.max(start + 1),
                    ));
                }
                c.pos += 1;
                let value = read_real_value(&mut c, params, 0, Some(b'#'))?;
                assigns.push(Assign {
                    target,
                    value,
                    start: c.src(start),
                    end: c.src_end(c.pos),
                });
            }
            b'O' => {
                return Err(c.error(
                    ParseErrorKind::ControlFlow {
                        why: "an O-word must start its block (after an optional N number)".into(),
                    },
                    start,
                    c.buf.len(),
                ))
            }
            b'A'..=b'Z' | b'@' | b'^' => {
                if b == b'E' && looks_like_exponent(&c, start) {
                    return Err(c.error(
                        ParseErrorKind::Unsupported {
                            word: "exponent notation".into(),
                            why: "G-code numbers have no exponent (write 1000, not 1e3); \
                                  an E-axis word directly after a number needs a space before it",
                        },
                        start.saturating_sub(1),
                        start + 2,
                    ));
                }
                c.pos += 1;
                let value = read_real_value(&mut c, params, 0, Some(b))?;
                words.push(Word {
                    letter: b,
                    value,
                    start: c.src(start),
                    end: c.src_end(c.pos),
                });
            }
            _ => {
                return Err(c.error(
                    ParseErrorKind::UnexpectedChar {
                        ch: first_char(&c.buf[start..]),
                    },
                    start,
                    start + 1,
                ))
            }
        }
        // After a value, the next thing must start a word.
        match c.peek() {
            None | Some(b'#' | b'A'..=b'Z' | b'@' | b'^') => {}
            Some(b'.' | b'0'..=b'9') => {
                let mut s = c.pos;
                while s > start && (c.buf[s - 1].is_ascii_digit() || c.buf[s - 1] == b'.') {
                    s -= 1;
                }
                let mut e = c.pos;
                while e < c.buf.len() && (c.buf[e].is_ascii_digit() || c.buf[e] == b'.') {
                    e += 1;
                }
                return Err(c.error(ParseErrorKind::MalformedNumber, s, e));
            }
            Some(_) => {
                return Err(c.error(
                    ParseErrorKind::UnexpectedChar {
                        ch: first_char(&c.buf[c.pos..]),
                    },
                    c.pos,
                    c.pos + 1,
                ))
            }
        }
    }
    Ok(())
}

/// The first character of `b` (lossy: U+FFFD for a broken sequence).
pub(crate) fn first_char(b: &[u8]) -> char {
    let n = b.len().min(4);
    for k in (1..=n).rev() {
        if let Ok(s) = std::str::from_utf8(&b[..k]) {
            if let Some(ch) = s.chars().next() {
                return ch;
            }
        }
    }
    char::REPLACEMENT_CHARACTER
}

#[cfg(test)]
mod tests {
    use super::*;

    fn compact(s: &str) -> Result<String, LexError> {
        let mut lb = LineBuf::default();
        compact_line(s.as_bytes(), 0, &mut lb)?;
        Ok(String::from_utf8(lb.bytes).unwrap())
    }

    fn words(s: &str) -> Result<Vec<(char, f64)>, LexError> {
        let mut lb = LineBuf::default();
        compact_line(s.as_bytes(), 0, &mut lb)?;
        let p = crate::expr::Params::default();
        let mut w = Vec::new();
        let mut a = Vec::new();
        read_block(&lb, 0, &p, &mut w, &mut a)?;
        Ok(w.iter().map(|w| (w.letter as char, w.value)).collect())
    }

    #[test]
    fn compaction() {
        assert_eq!(compact("g 0 1 x 1 0 . 5\r").unwrap(), "G01X10.5");
        assert_eq!(compact("G1 (a ; comment) X1 ; rest (").unwrap(), "G1X1");
        assert_eq!(compact("  % anything").unwrap(), "");
        assert_eq!(compact("/G0 X1").unwrap(), "G0X1");
        assert_eq!(compact("\tN10 G0").unwrap(), "N10G0");
        let e = compact("G1 (oops").unwrap_err();
        assert_eq!(e.kind, ParseErrorKind::UnclosedComment);
        assert_eq!(e.start, 3);
    }

    #[test]
    fn word_values_are_exact() {
        assert_eq!(
            words("G 0 1 X 1 0 . 5").unwrap(),
            vec![('G', 1.0), ('X', 10.5)]
        );
        assert_eq!(
            words("X1234.56789 Y-.5 Z+3.").unwrap(),
            vec![
                ('X', "1234.56789".parse().unwrap()),
                ('Y', -0.5),
                ('Z', 3.0)
            ]
        );
        assert_eq!(words("G0Z  0.1000").unwrap(), vec![('G', 0.0), ('Z', 0.1)]);
    }

    #[test]
    fn fast_number_path_matches_str_parse() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for _ in 0..20_000 {
            let int = next() % 10u64.pow((next() % 10) as u32);
            let nfrac = (next() % 12) as usize;
            let frac: String = (0..nfrac)
                .map(|_| (b'0' + (next() % 10) as u8) as char)
                .collect();
            let text = if nfrac == 0 {
                format!("{int}")
            } else {
                format!("{int}.{frac}")
            };
            let w = words(&format!("X{text}")).unwrap();
            assert_eq!(w[0].1, text.parse::<f64>().unwrap(), "{text}");
        }
        for text in [
            "0.1",
            ".3",
            "3.",
            "123456789012345",
            "1234567890123456",
            "0.000000000000000000001",
            "9007199254740993",
            "00000000000000000000001.5",
        ] {
            let w = words(&format!("X{text}")).unwrap();
            assert_eq!(w[0].1, text.parse::<f64>().unwrap(), "{text}");
        }
    }

    #[test]
    fn lexical_errors_with_spans() {
        let e = words("G1 X1 Y").unwrap_err();
        assert_eq!(e.kind, ParseErrorKind::MissingValue { letter: 'Y' });
        assert_eq!(e.start, 6);
        let e = words("G1 X1..5").unwrap_err();
        assert_eq!(e.kind, ParseErrorKind::MalformedNumber);
        assert_eq!((e.start, e.end), (4, 8));
        let e = words("G1 X.").unwrap_err();
        assert_eq!(e.kind, ParseErrorKind::MalformedNumber);
        let e = words("G1 X1 $").unwrap_err();
        assert_eq!(e.kind, ParseErrorKind::UnexpectedChar { ch: '$' });
        assert_eq!(e.start, 6);
        let e = words("G1 XY1").unwrap_err();
        assert_eq!(e.kind, ParseErrorKind::MissingValue { letter: 'X' });
        let e = words("G1 O100 sub").unwrap_err();
        assert!(matches!(e.kind, ParseErrorKind::ControlFlow { .. }));
        let e = words("G1 X#<foo>").unwrap_err();
        assert!(matches!(
            e.kind,
            ParseErrorKind::UndefinedNamedParameter { .. }
        ));
        let e = words("G1 Xé").unwrap_err();
        assert_eq!(e.kind, ParseErrorKind::MissingValue { letter: 'X' });
    }
}
