//! O-word control flow, as LinuxCNC runs it: `sub`/`endsub`/`call`/`return` (with an
//! optional returned value, `#<_value>`), `do`/`while`, `while`/`endwhile`,
//! `repeat`/`endrepeat`, `if`/`elseif`/`else`/`endif`, `break` and `continue`; the
//! Fanuc-style `O<n>` program numbers, `M98` and `M99` are in [`super::fanuc`].
//!
//! Statements are matched by their O-name (a number without leading zeros, a `<name>`, or
//! a computed `O#1` / `O[expr]`, case-insensitive), which LinuxCNC requires to be unique
//! for nested constructs. The first statement executed indexes every O-line of the program
//! once (up to a closing `%`: LinuxCNC reads nothing after it). A subroutine is known once
//! the main program has passed its definition; a `call` (or `M98`) of one not yet known
//! searches forward from the call to the end of the program (also past `M2`, as LinuxCNC
//! does) and records what it finds, so the main program running into a definition it
//! already called is an error, as in LinuxCNC. Subroutines in other files (LinuxCNC's
//! subroutine path) are not searched: calling one is an error naming it.
//!
//! A subroutine gets fresh locals (`#1`..`#30` from the call's arguments, see
//! [`super::params`]). Conditions must be known: a condition that depends on machine state
//! ncsmooth cannot know (a stored offset) is an error. Calls nest at most
//! [`MAX_CALL_DEPTH`] deep, and loop iterations and calls together number at most
//! [`MAX_ITERATIONS`] (subroutines that each call the next twice would otherwise run for
//! ever), so that a program that never ends is an error rather than a hang.

use super::Interp;
use crate::cursor::Cursor;
use crate::error::{ParseError, ParseErrorKind};
use crate::expr::read_real_value;
use std::collections::HashMap;

/// Deepest subroutine nesting (LinuxCNC allows 10 in its standard build; deeper nesting is
/// refused here too so that runaway recursion ends).
pub(crate) const MAX_CALL_DEPTH: usize = 64;
/// Most loop iterations and subroutine calls (all together) before the program is
/// declared endless.
pub(crate) const MAX_ITERATIONS: u64 = 10_000_000;

/// An O-word keyword.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kw {
    Sub,
    Endsub,
    Call,
    Return,
    Do,
    While,
    Endwhile,
    If,
    Elseif,
    Else,
    Endif,
    Break,
    Continue,
    Repeat,
    Endrepeat,
    /// No keyword: a Fanuc-style program number (`O1000`), see [`super::fanuc`].
    Bare,
}

const KEYWORDS: [(&[u8], Kw); 15] = [
    (b"ENDSUB", Kw::Endsub),
    (b"SUB", Kw::Sub),
    (b"CALL", Kw::Call),
    (b"RETURN", Kw::Return),
    (b"DO", Kw::Do),
    (b"WHILE", Kw::While),
    (b"ENDWHILE", Kw::Endwhile),
    (b"IF", Kw::If),
    (b"ELSEIF", Kw::Elseif),
    (b"ELSE", Kw::Else),
    (b"ENDIF", Kw::Endif),
    (b"BREAK", Kw::Break),
    (b"CONTINUE", Kw::Continue),
    (b"REPEAT", Kw::Repeat),
    (b"ENDREPEAT", Kw::Endrepeat),
];

/// An O-statement's name, keyword and the index after the keyword.
type Header = (Box<[u8]>, Kw, usize);

/// An O-line of the file.
#[derive(Clone, Debug)]
struct OLine {
    line: usize,
    name: Box<[u8]>,
    kw: Kw,
}

/// An open control block.
#[derive(Clone, Debug)]
struct Frame {
    kw: Kw,
    name: Box<[u8]>,
    /// Line of the opening statement.
    start: usize,
    /// `if`: a branch was taken. `repeat`: iterations left.
    taken: bool,
    left: u64,
}

/// How a subroutine was called (LinuxCNC's call types): each style must be ended by its
/// own statement.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum CallKind {
    /// `O<name> call` of an `O<name> sub`, ended by `endsub` or `return`.
    OWord,
    /// `M98 P<n>` of a Fanuc-style `O<n>` program, ended by `M99`.
    M98,
}

/// An active subroutine call.
#[derive(Clone, Debug)]
pub(crate) struct Call {
    pub(crate) name: Box<[u8]>,
    pub(crate) kind: CallKind,
    pub(crate) return_line: usize,
    /// Open blocks of the caller (restored on return).
    pub(crate) blocks: usize,
    /// The call had a block-delete `/`: whether it ran depends on the switch, so the first
    /// move after the return may not be smoothed into what came before.
    pub(crate) block_delete: bool,
}

/// Control-flow state.
#[derive(Default)]
pub(crate) struct Flow {
    index: Option<Vec<OLine>>,
    blocks: Vec<Frame>,
    pub(crate) calls: Vec<Call>,
    /// Known subroutines: the line of their definition and its kind (`Sub` or `Bare`).
    subs: HashMap<Box<[u8]>, (usize, Kw)>,
    iterations: u64,
    /// `M98 ... L` repeats left, per call level of the `M98` (-1: none running).
    pub(crate) m98_loops: Vec<i64>,
}

impl Flow {
    /// Inside a block (if, loop) of the current call level or any.
    pub(crate) fn in_block(&self) -> bool {
        !self.blocks.is_empty()
    }

    /// At the end of the file: every block closed (a call still open is an error too).
    pub(crate) fn check_closed(&self, it: &Interp<'_>) -> Result<(), ParseError> {
        if it.ended {
            return Ok(());
        }
        if let Some(f) = self.blocks.last() {
            let (s, e) = it.line_range(f.start);
            return Err(it.err_at(
                s..e,
                ParseErrorKind::ControlFlow {
                    why: format!("o{} {} is never closed", name_text(&f.name), kw_text(f.kw)),
                },
            ));
        }
        if let Some(c) = self.calls.last() {
            return Err(it.err_at(
                it.scan.last_line.0..it.scan.last_line.1,
                ParseErrorKind::ControlFlow {
                    why: format!("the file ends inside subroutine o{}", name_text(&c.name)),
                },
            ));
        }
        Ok(())
    }
}

pub(crate) fn name_text(n: &[u8]) -> String {
    if n.first().is_some_and(u8::is_ascii_digit) {
        String::from_utf8_lossy(n).into_owned()
    } else {
        format!("<{}>", String::from_utf8_lossy(n).to_lowercase())
    }
}

fn kw_text(k: Kw) -> &'static str {
    KEYWORDS
        .iter()
        .find(|(_, kw)| *kw == k)
        .map_or("", |(t, _)| std::str::from_utf8(t).unwrap_or("?"))
}

/// Largest magnitude LinuxCNC reads as an integer (a C `int`).
const MAX_INTEGER: f64 = i32::MAX as f64;

/// A value as LinuxCNC's `read_integer_value` takes it: within 0.0001 of an integer
/// (`None` otherwise, or when unknown or out of range).
pub(crate) fn linuxcnc_integer(v: f64) -> Option<i64> {
    /// How far from an integer LinuxCNC still reads a value as that integer.
    const INTEGER_TOLERANCE: f64 = 0.0001;
    if !v.is_finite() || v.abs() > MAX_INTEGER {
        return None;
    }
    let n = v.floor();
    let d = v - n;
    if d > 1.0 - INTEGER_TOLERANCE {
        Some(n as i64 + 1)
    } else if d > INTEGER_TOLERANCE {
        None
    } else {
        Some(n as i64)
    }
}

/// Index just past an `N` line number at the start of compacted bytes.
pub(crate) fn skip_line_number(b: &[u8]) -> usize {
    if b.first() != Some(&b'N') {
        return 0;
    }
    let mut i = 1;
    while i < b.len() && (b[i].is_ascii_digit() || b[i] == b'.') {
        i += 1;
    }
    i
}

/// Reads `O<name>KEYWORD` at `at`: the name (numbers without leading zeros), the keyword
/// ([`Kw::Bare`] when nothing follows the name) and the index after it.
fn read_header(b: &[u8], at: usize) -> Option<Header> {
    let (name, i) = read_name_at(b, at + 1)?;
    keyword_or_bare(b, name, i)
}

/// The keyword at `i`, or [`Kw::Bare`] at the end of the line.
fn keyword_or_bare(b: &[u8], name: Box<[u8]>, i: usize) -> Option<Header> {
    if i == b.len() {
        return Some((name, Kw::Bare, i));
    }
    let (kw, i) = read_keyword(b, i)?;
    Some((name, kw, i))
}

/// The keyword at `i` and the index after it.
fn read_keyword(b: &[u8], mut i: usize) -> Option<(Kw, usize)> {
    let st = i;
    while i < b.len() && b[i].is_ascii_alphabetic() {
        i += 1;
    }
    let word = &b[st..i];
    let kw = KEYWORDS.iter().find(|(t, _)| *t == word)?.1;
    Some((kw, i))
}

/// An O-name (`<name>` or digits) at `i` and the index after it.
fn read_name_at(b: &[u8], mut i: usize) -> Option<(Box<[u8]>, usize)> {
    let name: Box<[u8]> = if b.get(i) == Some(&b'<') {
        let len = b[i + 1..].iter().position(|&c| c == b'>')?;
        let n = &b[i + 1..i + 1 + len];
        i += len + 2;
        n.into()
    } else {
        let st = i;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
        }
        if i == st {
            return None;
        }
        let digits = &b[st..i];
        let trimmed = match digits.iter().position(|&c| c != b'0') {
            Some(p) => &digits[p..],
            None => &digits[digits.len() - 1..],
        };
        trimmed.into()
    };
    Some((name, i))
}

impl Interp<'_> {
    /// Every O-line of the program up to a closing `%` (built once, from the O-word lines
    /// the first pass found).
    fn o_index(&mut self) -> &[OLine] {
        if self.flow.index.is_none() {
            let v = self
                .scan
                .olines
                .iter()
                .filter_map(|o| {
                    let at = skip_line_number(&o.compact);
                    read_header(&o.compact, at).map(|(name, kw, _)| OLine {
                        line: o.line,
                        name,
                        kw,
                    })
                })
                .collect();
            self.flow.index = Some(v);
        }
        self.flow.index.as_deref().unwrap_or(&[])
    }

    /// The first O-line after line `from` with `name` and one of `kws`.
    fn find_after(&mut self, from: usize, name: &[u8], kws: &[Kw]) -> Option<usize> {
        self.o_index()
            .iter()
            .find(|o| o.line > from && &*o.name == name && kws.contains(&o.kw))
            .map(|o| o.line)
    }

    pub(crate) fn flow_err(&self, why: String) -> ParseError {
        let (s, e) = (self.raw_start, self.raw_end);
        self.err_at(s..e, ParseErrorKind::ControlFlow { why })
    }

    /// Reads the `[expr]` arguments after the keyword.
    fn o_args(&mut self, at: usize) -> Result<Vec<f64>, ParseError> {
        let lb = std::mem::take(&mut self.lb);
        let mut c = Cursor {
            buf: &lb.bytes,
            map: &lb.map,
            line_end: lb.line_end,
            pos: at,
        };
        let mut args = Vec::new();
        let mut r = Ok(());
        while c.peek() == Some(b'[') {
            match read_real_value(&mut c, &*self, 0, None) {
                Ok(v) => args.push(v),
                Err(e) => {
                    r = Err(self.lex_err(e));
                    break;
                }
            }
        }
        if r.is_ok() && c.peek().is_some() {
            r = Err(self.lex_err(c.error(
                ParseErrorKind::ControlFlow {
                    why: "unexpected text after the O-word statement".into(),
                },
                c.pos,
                c.buf.len(),
            )));
        }
        self.lb = lb;
        r.map(|()| args)
    }

    /// A known condition.
    fn condition(&self, args: &[f64], name: &[u8], kw: Kw) -> Result<bool, ParseError> {
        let Some(&v) = args.first() else {
            return Err(self.flow_err(format!(
                "o{} {} needs a condition in brackets",
                name_text(name),
                kw_text(kw)
            )));
        };
        if v.is_nan() {
            let (s, e) = (self.raw_start, self.raw_end);
            return Err(self.err_at(
                s..e,
                ParseErrorKind::UnknownValue {
                    what: format!("the condition of o{} {}", name_text(name), kw_text(kw)),
                },
            ));
        }
        Ok(v != 0.0)
    }

    pub(crate) fn count_iteration(&mut self) -> Result<(), ParseError> {
        self.flow.iterations += 1;
        if self.flow.iterations > MAX_ITERATIONS {
            return Err(self.flow_err(format!(
                "more than {MAX_ITERATIONS} loop iterations and subroutine calls: the program \
                 does not end"
            )));
        }
        Ok(())
    }

    /// Executes the O-word statement at compacted index `at` of the current line.
    pub(crate) fn o_statement(&mut self, at: usize) -> Result<(), ParseError> {
        let header = if matches!(self.lb.bytes.get(at + 1), Some(b'#' | b'[')) {
            self.computed_header(at)?
        } else {
            read_header(&self.lb.bytes, at)
        };
        let Some((name, kw, after)) = header else {
            let (s, e) = (self.raw_start, self.raw_end);
            return Err(self.err_at(
                s..e,
                ParseErrorKind::ControlFlow {
                    why: "malformed O-word statement (expected O<name> or O<number> and a keyword)"
                        .into(),
                },
            ));
        };
        let args = self.o_args(after)?;
        let pc = self.pc;
        match kw {
            Kw::Sub => self.define_sub(name)?,
            Kw::Bare => self.fanuc_program_number(&name)?,
            Kw::Endsub | Kw::Return => self.leave_sub(&name, kw, &args)?,
            Kw::Call => self.call(name, &args)?,
            Kw::Do => self.flow.blocks.push(Frame {
                kw,
                name,
                start: pc,
                taken: false,
                left: 0,
            }),
            Kw::While => self.o_while(name, &args)?,
            Kw::Endwhile => {
                let f = self.pop_block(&name, Kw::While, kw)?;
                self.next_pc = f.start;
            }
            Kw::Repeat => {
                let n = args.first().copied().unwrap_or(f64::NAN);
                if n.is_nan() {
                    let (s, e) = self.line_range(pc);
                    return Err(self.err_at(
                        s..e,
                        ParseErrorKind::UnknownValue {
                            what: format!("the count of o{} repeat", name_text(&name)),
                        },
                    ));
                }
                let n = n.round().max(0.0) as u64;
                if n == 0 {
                    self.skip_past(&name, &[Kw::Endrepeat])?;
                } else {
                    self.flow.blocks.push(Frame {
                        kw,
                        name,
                        start: pc,
                        taken: false,
                        left: n,
                    });
                }
            }
            Kw::Endrepeat => {
                self.count_iteration()?;
                let top = self.top_block(&name, Kw::Repeat, kw)?;
                let f = &mut self.flow.blocks[top];
                f.left -= 1;
                if f.left > 0 {
                    self.next_pc = f.start + 1;
                } else {
                    self.flow.blocks.pop();
                }
            }
            Kw::If => {
                let c = self.condition(&args, &name, kw)?;
                self.flow.blocks.push(Frame {
                    kw,
                    name: name.clone(),
                    start: pc,
                    taken: c,
                    left: 0,
                });
                if !c {
                    self.next_branch(&name)?;
                }
            }
            Kw::Elseif | Kw::Else => {
                let top = self.top_block(&name, Kw::If, kw)?;
                if self.flow.blocks[top].taken {
                    self.skip_past(&name, &[Kw::Endif])?;
                    self.flow.blocks.pop();
                } else {
                    let c = kw == Kw::Else || self.condition(&args, &name, kw)?;
                    self.flow.blocks[top].taken = c;
                    if !c {
                        self.next_branch(&name)?;
                    }
                }
            }
            Kw::Endif => {
                self.pop_block(&name, Kw::If, kw)?;
            }
            Kw::Break | Kw::Continue => self.break_continue(&name, kw)?,
        }
        Ok(())
    }

    /// `O<name> sub` met by the main program: records the definition and skips its body.
    fn define_sub(&mut self, name: Box<[u8]>) -> Result<(), ParseError> {
        let pc = self.pc;
        if !self.flow.calls.is_empty() {
            return Err(self.flow_err(format!(
                "o{}: nested subroutine definition (LinuxCNC refuses it)",
                name_text(&name)
            )));
        }
        if let Some(&(line, _)) = self.flow.subs.get(&name) {
            return Err(self.flow_err(if line == pc {
                format!(
                    "o{} sub: the main program runs into a subroutine it has already called \
                     (LinuxCNC: found in illegal location); end the main program with M2 or \
                     M30 before the subroutine definitions",
                    name_text(&name)
                )
            } else {
                format!(
                    "o{} sub: already defined at line {} (LinuxCNC refuses a redefinition)",
                    name_text(&name),
                    line + 1
                )
            }));
        }
        let end = self
            .find_after(pc, &name, &[Kw::Endsub])
            .ok_or_else(|| self.flow_err(format!("o{} sub without endsub", name_text(&name))))?;
        // LinuxCNC refuses a definition inside a definition, also a Fanuc-style one.
        let nested = self
            .o_index()
            .iter()
            .find(|o| o.line > pc && o.line < end && matches!(o.kw, Kw::Sub | Kw::Bare))
            .map(|o| (o.line, o.name.clone()));
        if let Some((line, inner)) = nested {
            let (s, e) = self.line_range(line);
            return Err(self.err_at(
                s..e,
                ParseErrorKind::ControlFlow {
                    why: format!(
                        "o{}: subroutine definition inside o{} sub (LinuxCNC refuses nested \
                         definitions)",
                        name_text(&inner),
                        name_text(&name)
                    ),
                },
            ));
        }
        self.flow.subs.insert(name, (pc, Kw::Sub));
        self.next_pc = end + 1;
        Ok(())
    }

    /// The definition of subroutine `name` (line and kind): known, or the first one after
    /// the current line (then recorded, as LinuxCNC records what its forward search finds).
    pub(crate) fn find_sub(&mut self, name: &[u8]) -> Option<(usize, Kw)> {
        if let Some(&found) = self.flow.subs.get(name) {
            return Some(found);
        }
        let pc = self.pc;
        let found = self
            .o_index()
            .iter()
            .find(|o| o.line > pc && &*o.name == name && matches!(o.kw, Kw::Sub | Kw::Bare))
            .map(|o| (o.line, o.kw))?;
        self.flow.subs.insert(name.into(), found);
        Some(found)
    }

    /// `O#<name> call`, `O[expr] call` and the like: the O-number is a computed value.
    fn computed_header(&mut self, at: usize) -> Result<Option<Header>, ParseError> {
        let (r, pos) = self.value_at(at + 1, None);
        match r.map(|v| (v, linuxcnc_integer(v))) {
            Err(e) => Err(self.lex_err(e)),
            Ok((_, Some(n))) if n >= 0 => Ok(keyword_or_bare(
                &self.lb.bytes,
                n.to_string().into_bytes().into_boxed_slice(),
                pos,
            )),
            Ok((v, _)) => {
                let (s, e) = (self.raw_start, self.raw_end);
                Err(self.err_at(
                    s..e,
                    ParseErrorKind::ControlFlow {
                        why: format!("computed O-number {v} is not a known non-negative integer"),
                    },
                ))
            }
        }
    }

    /// `while`: the tail of a `do` loop, or the head of a `while` loop.
    fn o_while(&mut self, name: Box<[u8]>, args: &[f64]) -> Result<(), ParseError> {
        let c = self.condition(args, &name, Kw::While)?;
        if let Some(f) = self.flow.blocks.last() {
            if f.kw == Kw::Do && f.name == name {
                let start = f.start;
                if c {
                    self.count_iteration()?;
                    self.next_pc = start + 1;
                } else {
                    self.flow.blocks.pop();
                }
                return Ok(());
            }
        }
        if c {
            self.count_iteration()?;
            self.flow.blocks.push(Frame {
                kw: Kw::While,
                name,
                start: self.pc,
                taken: true,
                left: 0,
            });
        } else {
            self.skip_past(&name, &[Kw::Endwhile])?;
        }
        Ok(())
    }

    /// Jumps to the next `elseif`/`else`/`endif` of `name`.
    fn next_branch(&mut self, name: &[u8]) -> Result<(), ParseError> {
        let l = self
            .find_after(self.pc, name, &[Kw::Elseif, Kw::Else, Kw::Endif])
            .ok_or_else(|| self.flow_err(format!("o{} if without endif", name_text(name))))?;
        self.next_pc = l;
        Ok(())
    }

    /// Jumps past the next statement of `name` among `kws`.
    fn skip_past(&mut self, name: &[u8], kws: &[Kw]) -> Result<(), ParseError> {
        let l = self.find_after(self.pc, name, kws).ok_or_else(|| {
            self.flow_err(format!(
                "o{}: no matching {}",
                name_text(name),
                kw_text(kws[0])
            ))
        })?;
        self.next_pc = l + 1;
        Ok(())
    }

    /// Index of the innermost open block, which must be `want` named `name`.
    fn top_block(&self, name: &[u8], want: Kw, kw: Kw) -> Result<usize, ParseError> {
        let base = self.flow.calls.last().map_or(0, |c| c.blocks);
        match self.flow.blocks.last() {
            Some(f) if self.flow.blocks.len() > base && f.kw == want && &*f.name == name => {
                Ok(self.flow.blocks.len() - 1)
            }
            _ => Err(self.flow_err(format!(
                "o{} {} without o{} {}",
                name_text(name),
                kw_text(kw),
                name_text(name),
                kw_text(want)
            ))),
        }
    }

    fn pop_block(&mut self, name: &[u8], want: Kw, kw: Kw) -> Result<Frame, ParseError> {
        self.top_block(name, want, kw)?;
        Ok(self.flow.blocks.pop().unwrap_or_else(|| unreachable!()))
    }

    fn break_continue(&mut self, name: &[u8], kw: Kw) -> Result<(), ParseError> {
        let base = self.flow.calls.last().map_or(0, |c| c.blocks);
        let Some(k) = (base..self.flow.blocks.len()).rev().find(|&k| {
            let f = &self.flow.blocks[k];
            &*f.name == name && matches!(f.kw, Kw::While | Kw::Do | Kw::Repeat)
        }) else {
            return Err(self.flow_err(format!(
                "o{} {} outside a loop of that name",
                name_text(name),
                kw_text(kw)
            )));
        };
        self.flow.blocks.truncate(k + 1);
        let f = self.flow.blocks[k].clone();
        let end_kw = match f.kw {
            Kw::While => Kw::Endwhile,
            Kw::Do => Kw::While,
            _ => Kw::Endrepeat,
        };
        let end = self
            .find_after(f.start, name, &[end_kw])
            .ok_or_else(|| self.flow_err(format!("o{}: loop without end", name_text(name))))?;
        if kw == Kw::Break {
            self.flow.blocks.truncate(k);
            self.next_pc = end + 1;
        } else {
            self.count_iteration()?;
            match f.kw {
                // Re-evaluate the condition at the head (`while`) or the tail (`do`).
                Kw::While => {
                    self.flow.blocks.truncate(k);
                    self.next_pc = f.start;
                }
                Kw::Do => self.next_pc = end,
                _ => self.next_pc = end,
            }
        }
        Ok(())
    }

    /// `call`: enters the subroutine with the arguments as `#1`, `#2`, ...
    fn call(&mut self, name: Box<[u8]>, args: &[f64]) -> Result<(), ParseError> {
        let sub = match self.find_sub(&name) {
            Some((l, Kw::Sub)) => l,
            Some(_) => {
                return Err(self.flow_err(format!(
                    "o{n} call: O{n} is a Fanuc-style program (no sub keyword); LinuxCNC calls \
                     it only with M98 P{n}",
                    n = name_text(&name)
                )))
            }
            None => {
                return Err(self.flow_err(format!(
                    "subroutine o{} is neither defined before the call nor after it up to the \
                     end of the program (subroutines in separate files are not read)",
                    name_text(&name)
                )))
            }
        };
        self.remember_return_lines();
        self.enter_call(name, CallKind::OWord, self.pc + 1)?;
        self.store.enter(args);
        self.next_pc = sub + 1;
        Ok(())
    }

    /// Pushes a call frame returning to `return_line`.
    pub(crate) fn enter_call(
        &mut self,
        name: Box<[u8]>,
        kind: CallKind,
        return_line: usize,
    ) -> Result<(), ParseError> {
        if self.flow.calls.len() >= MAX_CALL_DEPTH {
            return Err(self.flow_err(format!(
                "subroutine calls nested more than {MAX_CALL_DEPTH} deep"
            )));
        }
        self.count_iteration()?;
        self.flow.calls.push(Call {
            name,
            kind,
            return_line,
            blocks: self.flow.blocks.len(),
            block_delete: self.lb.block_delete,
        });
        self.m.value_returned = false;
        Ok(())
    }

    /// `endsub` / `return`: back to the caller, with the value if one is given.
    fn leave_sub(&mut self, name: &[u8], kw: Kw, args: &[f64]) -> Result<(), ParseError> {
        let Some(c) = self.flow.calls.last() else {
            return Err(self.flow_err(format!(
                "o{} {} outside a subroutine call",
                name_text(name),
                kw_text(kw)
            )));
        };
        if c.kind == CallKind::M98 {
            return Err(self.flow_err(format!(
                "o{} {}: Fanuc-style program O{} was called by M98 and must end with M99 \
                 (LinuxCNC)",
                name_text(name),
                kw_text(kw),
                name_text(&c.name)
            )));
        }
        // `return` may carry any O-name (LinuxCNC returns from the enclosing subroutine);
        // `endsub` must close the subroutine being run.
        if kw == Kw::Endsub && &*c.name != name {
            return Err(self.flow_err(format!(
                "o{} {} inside subroutine o{}",
                name_text(name),
                kw_text(kw),
                name_text(&c.name)
            )));
        }
        self.return_from_call(args.first().copied());
        Ok(())
    }

    /// Leaves the innermost call, with the returned value if any.
    pub(crate) fn return_from_call(&mut self, value: Option<f64>) {
        let Some(c) = self.flow.calls.pop() else {
            return;
        };
        self.flow.blocks.truncate(c.blocks);
        self.store.leave();
        self.m.value = value.unwrap_or(0.0);
        self.m.value_returned = value.is_some();
        if c.block_delete {
            self.pin_next = true;
        }
        self.next_pc = c.return_line;
    }
}
