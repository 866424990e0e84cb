//! Fanuc-style subprograms, as LinuxCNC runs them (enabled by default: INI
//! `[RS274NGC] DISABLE_FANUC_STYLE_SUB = 0`; ncsmooth reads the default and has no switch
//! to turn them off).
//!
//! * `O<n>` (or `O<name>`) alone on a line is a program number. Met by the main program it
//!   does nothing (a main program's title, or a subprogram the main program runs into);
//!   met inside a running subprogram other than its own it is an error, as in LinuxCNC
//!   master (nested subroutine definition; 2.9 runs on into the next program, which a
//!   subprogram without its `M99` hardly means). Numbers are names without leading zeros:
//!   `O0002` is `O2`.
//! * `M98 P<n> [L<count>]`, read only when `M98` is the first word of its block (after an
//!   `N` number; LinuxCNC knows `M98` nowhere else), calls program `O<n>`: `P` and `L` are
//!   non-negative integers (within 0.0001, `P[expr]` and `P#1` too), `L` repeats the call
//!   (LinuxCNC re-runs the `M98` block, so `P` is read again each time; `L0` skips the
//!   call). The program must be an
//!   `O<n>` program number (an `O<n> sub` is an error) that is known (called before) or
//!   comes after the call: LinuxCNC searches forward to the end of the program and
//!   records what it finds. The subprogram shares the caller's `#1`..`#30` (an `O call`
//!   gets fresh ones) and has its own local names. Other words on an `M98` line are read
//!   and ignored, as LinuxCNC does (a warning says so).
//! * `M99` as the first word of a block inside an `M98` call returns from it (nothing but
//!   a comment may follow). `M99` in the main program ends it as `M2` does: that is what
//!   LinuxCNC's standalone interpreter (`rs274`) and its preview do; LinuxCNC's task on
//!   the machine starts the program again from the top, endlessly. ncsmooth plans one pass
//!   and pins every move of such a program (written as programmed), because a second pass
//!   starts in the state the first one left and a replaced run could mean something else
//!   there.
//! * Styles do not mix: an `O<n> sub` ends with `endsub`/`return` and is called with
//!   `O<n> call`; an `O<n>` program ends with `M99` and is called with `M98`.
//!
//! Moves of a subprogram are nested (see [`super::Interp::nested`]): they are pinned and
//! never smoothed, like those of O-word subroutines.
//!
//! Not modelled: LinuxCNC leaves a call frame behind after `M98 ... L0` (its
//! `#<_call_level>` stays one higher, and a later `M99` in the main program then reads as
//! a return); ncsmooth skips the call cleanly.

use super::oword::{linuxcnc_integer, name_text, CallKind, Kw};
use super::Interp;
use crate::error::{ParseError, ParseErrorKind};

/// A Fanuc-style statement line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Statement {
    /// `M98 P<n> [L<count>]`.
    Call,
    /// `M99` returning from an `M98` call.
    Return,
}

impl Interp<'_> {
    /// The Fanuc-style statement of the current line, whose compacted text has an `M` at
    /// `at` (just after any `N` number): `M98`, or `M99` inside a call, written so (LinuxCNC
    /// reads the three characters `m98` / `m99` there; `M098` or `M98.0` are then errors).
    /// `None` for any other line, including one where a comment comes before the `M`
    /// (LinuxCNC then reads it as an ordinary M code, an error for both).
    pub(crate) fn fanuc_statement_at(&self, at: usize) -> Option<Statement> {
        let b = &self.lb.bytes[at..];
        let statement = match b.get(..3) {
            Some(b"M98") => Statement::Call,
            Some(b"M99") if !self.flow.calls.is_empty() => Statement::Return,
            _ => return None,
        };
        if b.get(3).is_some_and(|c| c.is_ascii_digit() || *c == b'.') {
            return None;
        }
        let comment_first = self
            .lb
            .map
            .get(at)
            .is_some_and(|&m| self.raw.as_bytes()[..m - self.raw_start].contains(&b'('));
        (!comment_first).then_some(statement)
    }

    /// Executes the Fanuc-style statement `s` of the current line (`M` at `at`).
    pub(crate) fn fanuc_statement(&mut self, s: Statement, at: usize) -> Result<(), ParseError> {
        match s {
            Statement::Call => self.m98(),
            Statement::Return => self.m99_return(at),
        }
    }

    /// `M98 P<n> [L<count>]`.
    fn m98(&mut self) -> Result<(), ParseError> {
        self.read_words()?;
        self.classify()?;
        let m98_word = self.mcodes.first().map_or(0, |c| c.word);
        let p = self.known_val(b'P')?.ok_or_else(|| {
            self.err_word(
                m98_word,
                ParseErrorKind::MissingWord {
                    code: "M98".into(),
                    letter: 'P',
                },
            )
        })?;
        let number = self.non_negative_integer(b'P', p, "M98 P is a program number")?;
        let count = match self.known_val(b'L')? {
            Some(l) => Some(self.non_negative_integer(b'L', l, "M98 L is a repeat count")?),
            None => None,
        };
        self.warn_ignored_m98_words();
        let Some(again) = self.m98_repeat(count)? else {
            return Ok(());
        };
        let name: Box<[u8]> = number.to_string().into_bytes().into();
        let line = match self.find_sub(&name) {
            Some((line, Kw::Bare)) => line,
            Some(_) => {
                return Err(self.flow_err(format!(
                    "M98 P{number}: o{number} is an O-word subroutine (o{number} sub); \
                     LinuxCNC calls it only with o{number} call"
                )))
            }
            None => {
                return Err(self.flow_err(format!(
                    "M98 P{number}: program O{number} was not called before and is not after \
                     the call up to the end of the program (LinuxCNC searches forward only; \
                     programs in separate files are not read)"
                )))
            }
        };
        let return_line = if again { self.pc } else { self.pc + 1 };
        self.remember_return_lines();
        self.enter_call(name, CallKind::M98, return_line)?;
        self.store.enter_shared();
        self.next_pc = line + 1;
        Ok(())
    }

    /// `value` of word `letter` as LinuxCNC reads a non-negative integer (within 0.0001).
    fn non_negative_integer(
        &self,
        letter: u8,
        value: f64,
        what: &'static str,
    ) -> Result<i64, ParseError> {
        match linuxcnc_integer(value) {
            Some(n) if n >= 0 => Ok(n),
            _ => Err(self.err_word(
                self.word_of(letter),
                ParseErrorKind::InvalidValue {
                    letter: letter as char,
                    value,
                    why: what,
                },
            )),
        }
    }

    /// The `L` repeat count of an `M98` block, kept per call level as LinuxCNC keeps it
    /// (read when the block starts its repeats, counted down each time it runs):
    /// `Some(true)` when the block runs again after this call, `Some(false)` for its last
    /// (or only) call, `None` for `L0` (no call).
    fn m98_repeat(&mut self, count: Option<i64>) -> Result<Option<bool>, ParseError> {
        let Some(l) = count else {
            return Ok(Some(false));
        };
        let depth = self.flow.calls.len();
        if self.flow.m98_loops.len() <= depth {
            self.flow.m98_loops.resize(depth + 1, -1);
        }
        let left = &mut self.flow.m98_loops[depth];
        if *left == -1 {
            *left = l;
        }
        *left -= 1;
        let again = *left > 0;
        if !again {
            *left = -1;
        }
        if l == 0 {
            return Ok(None);
        }
        Ok(Some(again))
    }

    /// Warns about the words of an `M98` block other than `N`, `M98`, `P` and `L`, and its
    /// parameter assignments: LinuxCNC reads them and does nothing with them.
    fn warn_ignored_m98_words(&mut self) {
        let ignored = self
            .words
            .iter()
            .filter(|w| !matches!(w.letter, b'N' | b'P' | b'L'))
            .count()
            .saturating_sub(1);
        if ignored > 0 || !self.assigns.is_empty() {
            self.warn(
                "words other than P and L and parameter assignments on an M98 line are \
                 ignored (as LinuxCNC ignores them)",
            );
        }
    }

    /// `M99` returning from an `M98` call (`M` at compacted index `at`).
    fn m99_return(&mut self, at: usize) -> Result<(), ParseError> {
        if &self.lb.bytes[at..] != b"M99" {
            return Err(self.flow_err(
                "M99 returning from a subprogram stands alone on its line (nothing but a \
                 comment may follow it, as in LinuxCNC)"
                    .into(),
            ));
        }
        let Some(c) = self.flow.calls.last() else {
            return Ok(());
        };
        if c.kind == CallKind::OWord {
            return Err(self.flow_err(format!(
                "M99 inside o{n} sub: an O-word subroutine ends with o{n} endsub or o{n} \
                 return (LinuxCNC)",
                n = name_text(&c.name)
            )));
        }
        self.return_from_call(None);
        if self.lb.block_delete {
            // Whether this return runs depends on the block-delete switch.
            self.pin_next = true;
        }
        Ok(())
    }

    /// An `O<n>` program number met while running (see the module doc).
    pub(crate) fn fanuc_program_number(&mut self, name: &[u8]) -> Result<(), ParseError> {
        let Some(c) = self.flow.calls.last() else {
            return Ok(());
        };
        if &*c.name != name {
            return Err(self.flow_err(format!(
                "O{}: a program number inside subprogram o{} (LinuxCNC: nested subroutine \
                 definition); end the subprogram with M99 before the next program",
                name_text(name),
                name_text(&c.name)
            )));
        }
        if c.kind == CallKind::OWord {
            return Err(self.flow_err(format!(
                "O{n}: a Fanuc-style program inside o{n} sub; LinuxCNC calls it only with \
                 M98 P{n}",
                n = name_text(name)
            )));
        }
        Ok(())
    }
}
