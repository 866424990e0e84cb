//! O-word control flow, as LinuxCNC runs it: `sub`/`endsub`/`call`/`return` (with an
//! optional returned value, `#<_value>`), `do`/`while`, `while`/`endwhile`,
//! `repeat`/`endrepeat`, `if`/`elseif`/`else`/`endif`, `break` and `continue`.
//!
//! Statements are matched by their O-name (a number or a `<name>`, case-insensitive), which
//! LinuxCNC requires to be unique for nested constructs. The first statement executed
//! indexes every O-line of the file once; a `call` finds its `sub` anywhere in the file
//! (also after `M2`, as LinuxCNC does). Subroutines in other files (LinuxCNC's subroutine
//! path) are not searched: calling one is an error naming it.
//!
//! A subroutine gets fresh locals (`#1`..`#30` from the call's arguments, see
//! [`super::params`]). Conditions must be known: a condition that depends on machine state
//! ncsmooth cannot know (a stored offset) is an error. Calls nest at most
//! [`MAX_CALL_DEPTH`] deep and a loop may run at most [`MAX_ITERATIONS`] times in all, so
//! that a program that never ends is an error rather than a hang.

use super::Interp;
use crate::error::{ParseError, ParseErrorKind};
use crate::expr::read_real_value;
use crate::lexer::{compact_line, Cursor, LineBuf};
use std::collections::HashMap;

/// Deepest subroutine nesting (LinuxCNC allows 10 in its standard build; deeper nesting is
/// refused here too so that runaway recursion ends).
pub const MAX_CALL_DEPTH: usize = 64;
/// Most loop iterations (all loops together) before the program is declared endless.
pub const MAX_ITERATIONS: u64 = 10_000_000;

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

/// An active subroutine call.
#[derive(Clone, Debug)]
struct Call {
    name: Box<[u8]>,
    return_line: usize,
    /// Open blocks of the caller (restored on return).
    blocks: usize,
}

/// Control-flow state.
#[derive(Default)]
pub(crate) struct Flow {
    index: Option<Vec<OLine>>,
    blocks: Vec<Frame>,
    calls: Vec<Call>,
    subs: HashMap<Box<[u8]>, usize>,
    iterations: u64,
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
            let (s, e) = it.lines[f.start];
            return Err(it.err_at(
                s..e,
                ParseErrorKind::ControlFlow {
                    why: format!("o{} {} is never closed", name_text(&f.name), kw_text(f.kw)),
                },
            ));
        }
        if let Some(c) = self.calls.last() {
            return Err(it.err_at(
                it.lines.last().map_or(0..0, |&(s, e)| s..e),
                ParseErrorKind::ControlFlow {
                    why: format!("the file ends inside subroutine o{}", name_text(&c.name)),
                },
            ));
        }
        Ok(())
    }
}

fn name_text(n: &[u8]) -> String {
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
        .map_or("?", |(t, _)| std::str::from_utf8(t).unwrap_or("?"))
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
/// and the index after it.
fn read_header(b: &[u8], at: usize) -> Option<Header> {
    let (name, i) = read_name_at(b, at + 1)?;
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
    /// Every O-line of the file (built once).
    fn o_index(&mut self) -> &[OLine] {
        if self.flow.index.is_none() {
            let mut lb = LineBuf::default();
            let mut v = Vec::new();
            for (k, &(s, e)) in self.lines.iter().enumerate() {
                let line = &self.src.as_bytes()[s..e];
                if !line.iter().any(|&c| c == b'o' || c == b'O') {
                    continue;
                }
                if compact_line(line, s, &mut lb).is_err() {
                    continue;
                }
                let at = skip_line_number(&lb.bytes);
                if lb.bytes.get(at) != Some(&b'O') {
                    continue;
                }
                if let Some((name, kw, _)) = read_header(&lb.bytes, at) {
                    v.push(OLine { line: k, name, kw });
                }
            }
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

    fn flow_err(&self, why: String) -> ParseError {
        let (s, e) = self.lines[self.pc];
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
            let (s, e) = self.lines[self.pc];
            return Err(self.err_at(
                s..e,
                ParseErrorKind::UnknownValue {
                    what: format!("the condition of o{} {}", name_text(name), kw_text(kw)),
                },
            ));
        }
        Ok(v != 0.0)
    }

    fn count_iteration(&mut self) -> Result<(), ParseError> {
        self.flow.iterations += 1;
        if self.flow.iterations > MAX_ITERATIONS {
            return Err(self.flow_err(format!(
                "more than {MAX_ITERATIONS} loop iterations: the program does not end"
            )));
        }
        Ok(())
    }

    /// Executes the O-word statement at compacted index `at` of the current line.
    pub(crate) fn o_statement(&mut self, at: usize) -> Result<(), ParseError> {
        let header = if self.lb.bytes.get(at + 1) == Some(&b'#') {
            self.computed_header(at)?
        } else {
            read_header(&self.lb.bytes, at)
        };
        let Some((name, kw, after)) = header else {
            let (s, e) = self.lines[self.pc];
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
            Kw::Sub => {
                if !self.flow.calls.is_empty() {
                    return Err(self.flow_err(format!(
                        "o{}: nested subroutine definition (LinuxCNC refuses it)",
                        name_text(&name)
                    )));
                }
                self.flow.subs.insert(name.clone(), pc);
                let end = self.find_after(pc, &name, &[Kw::Endsub]).ok_or_else(|| {
                    self.flow_err(format!("o{} sub without endsub", name_text(&name)))
                })?;
                self.next_pc = end + 1;
            }
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
                    let (s, e) = self.lines[pc];
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

    /// `O#<name> call` and the like: the O-number is a parameter's value.
    fn computed_header(&mut self, at: usize) -> Result<Option<Header>, ParseError> {
        let lb = std::mem::take(&mut self.lb);
        let mut c = Cursor {
            buf: &lb.bytes,
            map: &lb.map,
            line_end: lb.line_end,
            pos: at + 1,
        };
        let r = read_real_value(&mut c, &*self, 0, None);
        let pos = c.pos;
        let out = match r {
            Err(e) => Err(self.lex_err(e)),
            Ok(v) if v.is_nan() || v < 0.0 || v.fract() != 0.0 => {
                let (s, e) = self.lines[self.pc];
                Err(self.err_at(
                    s..e,
                    ParseErrorKind::ControlFlow {
                        why: format!("computed O-number {v} is not a known non-negative integer"),
                    },
                ))
            }
            Ok(v) => Ok(read_keyword(&lb.bytes, pos).map(|(kw, i)| {
                (
                    format!("{}", v as u64).into_bytes().into_boxed_slice(),
                    kw,
                    i,
                )
            })),
        };
        self.lb = lb;
        out
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
        let sub = match self.flow.subs.get(&name) {
            Some(&l) => l,
            None => {
                let found = self
                    .o_index()
                    .iter()
                    .find(|o| o.kw == Kw::Sub && o.name == name)
                    .map(|o| o.line);
                found.ok_or_else(|| {
                    self.flow_err(format!(
                        "subroutine o{} is not defined in this file (subroutines in separate files are not read)",
                        name_text(&name)
                    ))
                })?
            }
        };
        if self.flow.calls.len() >= MAX_CALL_DEPTH {
            return Err(self.flow_err(format!(
                "subroutine calls nested more than {MAX_CALL_DEPTH} deep"
            )));
        }
        self.flow.calls.push(Call {
            name,
            return_line: self.pc + 1,
            blocks: self.flow.blocks.len(),
        });
        self.store.enter(args);
        self.m.value_returned = false;
        self.next_pc = sub + 1;
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
        let c = self.flow.calls.pop().unwrap_or_else(|| unreachable!());
        self.flow.blocks.truncate(c.blocks);
        self.store.leave();
        match args.first() {
            Some(&v) => {
                self.m.value = v;
                self.m.value_returned = true;
            }
            None => {
                self.m.value = 0.0;
                self.m.value_returned = false;
            }
        }
        self.next_pc = c.return_line;
        Ok(())
    }
}
