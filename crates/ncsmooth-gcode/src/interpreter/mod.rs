//! The modal interpreter: lines of G-code in, [`Toolpath`] out, as LinuxCNC's RS274/NGC
//! interpreter means them.
//!
//! # Structure
//!
//! * `Interp::run` walks the physical lines with a program counter; O-word statements
//!   (`oword`) move it (subroutines, loops, conditionals), and so do Fanuc-style
//!   subprogram calls and returns (`fanuc`: `O<n>` programs, `M98`, `M99`).
//! * Each line is lexed ([`crate::lexer`]), its words sorted (`block`) and executed in
//!   LinuxCNC's order of execution (`modal`): comment, feed mode, F, S, T, the M codes
//!   (tool change, spindle, coolant, overrides, I/O, user codes), dwell, plane, units,
//!   cutter compensation, tool length, coordinate system, path control, distance modes,
//!   retract mode, the non-modal group (G10, G28, G30, G52, G92), motion ([`motion`],
//!   canned cycles in `cycles`, splines in `splines`), and last the program stops.
//! * Positions and offsets live in [`frames`]: what ncsmooth cannot know (stored offsets,
//!   the tool table, home positions) is unknown, and so is every axis that depends on it
//!   until the program commands it again. Motion from or to an unknown position becomes
//!   an [`EventKind::Untracked`] event: never smoothed or planned through, written as
//!   programmed.
//!
//! The initial state is LinuxCNC's: G0 G17 G21 G40 G49 G54 G64 G80 G90 G91.1 G94 G97 G99,
//! with M82 for printer files, no feed, and every axis unknown. Everything with a length is
//! stored in mm whatever the program's units; the program's units are kept for writing.
//!
//! # Faithful output
//!
//! For every physical line the interpreter records ([`crate::source::SourceMap`]) whether
//! it was executed, whether its motion may be replaced by smoothed motion (executed once at
//! the top level, nothing else on the line), and the modal state after it, so that
//! [`crate::rewrite()`] can copy every other line verbatim. Moves of lines that may not be
//! replaced are [`Move::pinned`](ncsmooth::path::Move::pinned): the smoothing leaves them
//! exactly as programmed. A main program ended by `M99` (which LinuxCNC's task runs again
//! and again) is pinned whole.

pub(crate) mod block;
pub(crate) mod comments;
pub(crate) mod cycles;
pub(crate) mod fanuc;
pub mod frames;
pub(crate) mod modal;
pub mod motion;
pub(crate) mod oword;
pub(crate) mod params;
pub mod program;
pub(crate) mod splines;
pub(crate) mod text;

use crate::canon::Canon;
use crate::cursor::{Cursor, LexError};
use crate::error::{ParseError, ParseErrorKind, Warning};
use crate::expr::{read_real_value, ParamLookup, UNKNOWN};
use crate::lexer::{compact_line, read_block, Assign, AssignTarget, LineBuf, Word};
use crate::source::{flags, LineInfo, SourceMap, WriteState};
use block::{Code, N_SLOTS};
use frames::{Frames, N_AXES};
use modal::Modal;
use ncsmooth::path::{Block, Event, EventKind, Toolpath, Units};
use program::{ParseOptions, ParseStats, Program};
use std::collections::HashMap;
use text::{Scan, Text, TextError};

/// Millimetres per inch.
pub(crate) const MM_PER_INCH: f64 = 25.4;

/// The interpreter.
pub(crate) struct Interp<'a> {
    /// The program text, whole or streamed ([`text`]).
    pub(crate) text: Text<'a>,
    pub(crate) file: &'a str,
    pub(crate) opts: &'a ParseOptions,
    /// What the first pass over the text learned: lines, O-word lines, the closing `%`.
    pub(crate) scan: Scan,
    /// Offsets of lines a call returns to (the call's line and the next one): with the
    /// O-word lines of `scan`, every place a jump can land.
    pub(crate) returns: HashMap<usize, usize>,
    /// The current line's text, and its byte range in the source.
    pub(crate) raw: String,
    pub(crate) raw_start: usize,
    pub(crate) raw_end: usize,
    /// Offset of the line `pc` (before it is read).
    pub(crate) pc_offset: usize,
    /// Lines executed at least once, a bit per line.
    pub(crate) executed: Vec<u64>,
    /// Every move is pinned (a streamed main program ended by `M99`, known from a first
    /// run: see [`crate::BlockReader`]).
    pub(crate) pin_everything: bool,
    /// Index of the line being executed.
    pub(crate) pc: usize,
    /// Index of the next line to execute (set by control flow).
    pub(crate) next_pc: usize,
    // State.
    pub(crate) m: Modal,
    pub(crate) f: Frames,
    /// Extruder (E) value, programmed units.
    pub(crate) e: f64,
    pub(crate) store: params::Store,
    pub(crate) flow: oword::Flow,
    /// The program ended (M2, M30, closing `%`).
    pub(crate) ended: bool,
    /// A `%` opened the program.
    pub(crate) percent_open: bool,
    /// The next move starts from a position a block-delete switch may have changed.
    pub(crate) pin_next: bool,
    /// `M99` ended the main program: on the machine it runs again from the top, so
    /// nothing of it may be replaced (see the module doc).
    pub(crate) main_m99: bool,
    // Output.
    pub(crate) tp: Toolpath,
    pub(crate) stats: ParseStats,
    pub(crate) map: SourceMap,
    pub(crate) canon: Option<Vec<Canon>>,
    // Per-line scratch (reused).
    pub(crate) line_no: u32,
    pub(crate) lb: LineBuf,
    pub(crate) words: Vec<Word>,
    pub(crate) assigns: Vec<Assign>,
    pub(crate) gcodes: Vec<Code>,
    pub(crate) mcodes: Vec<Code>,
    pub(crate) letters: [Option<usize>; N_SLOTS],
    /// Bit `i` set when slot `i` of `letters` holds a word.
    pub(crate) present: u32,
    /// Bit `i` set when the word of slot `i` was read.
    pub(crate) used: u32,
    /// Blocks already handed out of `tp.blocks` by a [`crate::BlockReader`].
    pub(crate) drained: usize,
    /// Index in `tp.blocks` where the current line's output starts.
    pub(crate) line_first_block: usize,
    /// The current line emitted an event.
    pub(crate) line_events: bool,
    /// The current line's `S` is a value of its motion ([`EventKind::SpindleSpeed`]): a
    /// rewrite writes it on the first block of the line's motion.
    pub(crate) line_block_s: bool,
    /// The current line may not be replaced whatever its words (set by the handlers).
    pub(crate) line_pinned: bool,
    /// The current line ran motion in the motion mode in force (no group-1 code of its
    /// own): a writer resuming verbatim text before it must restore that mode.
    pub(crate) line_modal_motion: bool,
    /// The line sets the path mode (`G61`, `G61.1`, `G64`).
    pub(crate) line_path_mode: bool,
}

/// Room for blocks [`Interp::check_held`] keeps after each line: a line adds a few (a
/// canned cycle's repeats, a spline's pieces), and a push beyond the room reserved would
/// abort where memory runs out.
const HELD_HEADROOM_BLOCKS: usize = 4096;

impl<'a> Interp<'a> {
    pub(crate) fn new(text: Text<'a>, file: &'a str, opts: &'a ParseOptions) -> Self {
        let f = match &opts.machine {
            Some(m) => Frames::known(m),
            None => Frames::unknown(),
        };
        Interp {
            text,
            file,
            opts,
            scan: Scan::default(),
            returns: HashMap::new(),
            raw: String::with_capacity(256),
            raw_start: 0,
            raw_end: 0,
            pc_offset: 0,
            executed: Vec::new(),
            pin_everything: false,
            pc: 0,
            next_pc: 0,
            m: Modal {
                units: opts.default_units,
                ..Modal::default()
            },
            f,
            e: 0.0,
            store: params::Store::new(),
            flow: oword::Flow::default(),
            ended: false,
            percent_open: false,
            pin_next: false,
            main_m99: false,
            tp: Toolpath::new(ncsmooth::geom::Vec3::ZERO),
            stats: ParseStats::default(),
            map: SourceMap::default(),
            canon: opts.canon.then(Vec::new),
            line_no: 0,
            lb: LineBuf::default(),
            words: Vec::with_capacity(16),
            assigns: Vec::new(),
            gcodes: Vec::with_capacity(8),
            mcodes: Vec::with_capacity(4),
            letters: [None; N_SLOTS],
            present: 0,
            used: 0,
            drained: 0,
            line_first_block: 0,
            line_events: false,
            line_block_s: false,
            line_pinned: false,
            line_modal_motion: false,
            line_path_mode: false,
        }
    }

    /// Runs a program held whole and returns it with its source map.
    pub(crate) fn run(mut self) -> Result<Program, ParseError> {
        let Text::Whole(src) = self.text else {
            unreachable!("run() reads a whole program; BlockReader streams a file")
        };
        self.stats.bytes = src.len();
        let mut lines = Vec::new();
        self.begin(Some(&mut lines))?;
        self.map.lines = lines;
        // One block per line at most, give or take: reserve up front instead of growing
        // (and copying) a vector of 200-byte blocks many times.
        let want = (self.scan.n_lines + 1).min(self.opts.max_held_blocks);
        if self.tp.blocks.try_reserve(want).is_err() {
            return Err(self.too_large("the system's memory ran out"));
        }
        while self.step()? {}
        self.finish()?;
        Ok(Program {
            toolpath: self.tp,
            stats: self.stats,
            source: self.map,
            canon: self.canon.unwrap_or_default(),
        })
    }

    /// The first pass over the text ([`text::scan`]).
    /// `lines` receives every line's range when given (the source map of a whole program).
    pub(crate) fn begin(&mut self, lines: Option<&mut Vec<LineInfo>>) -> Result<(), ParseError> {
        self.scan = text::scan(&mut self.text, self.file, lines).map_err(|e| self.text_err(e))?;
        self.stats.lines = self.scan.n_lines;
        self.executed = vec![0; self.scan.n_lines.div_ceil(64)];
        Ok(())
    }

    /// Executes the next line; false when the program has ended or the text is done.
    pub(crate) fn step(&mut self) -> Result<bool, ParseError> {
        if self.pc >= self.scan.n_lines || self.ended {
            return Ok(false);
        }
        let end = match (&self.text, self.map.lines.get(self.pc)) {
            // A whole program with its source map: the line's range is known.
            (Text::Whole(src), Some(info)) => {
                self.raw.clear();
                self.raw.push_str(&src[info.start..info.end]);
                info.end
            }
            _ => {
                let read = self
                    .text
                    .line_at(self.pc_offset, self.pc, &mut self.raw, self.file)
                    .map_err(|e| self.text_err(e))?;
                let Some(end) = read else {
                    return Ok(false);
                };
                end
            }
        };
        self.raw_start = self.pc_offset;
        self.raw_end = end;
        self.next_pc = self.pc + 1;
        self.exec_line()?;
        self.check_held()?;
        self.note_assumed_units();
        self.pc_offset = self.offset_of(self.next_pc);
        self.pc = self.next_pc;
        Ok(true)
    }

    /// The blocks held stay within [`ParseOptions::max_held_blocks`], and the next lines
    /// have room to grow them into (reserved here, where running out of memory is an
    /// error, rather than in a push, where it would abort).
    fn check_held(&mut self) -> Result<(), ParseError> {
        let held = self.tp.blocks.len();
        if held > self.opts.max_held_blocks {
            return Err(self.too_large("the reader's limit"));
        }
        if self.tp.blocks.capacity() - held < HELD_HEADROOM_BLOCKS {
            let more = held.max(HELD_HEADROOM_BLOCKS);
            if self.tp.blocks.try_reserve(more).is_err() {
                return Err(self.too_large("the system's memory ran out"));
            }
        }
        Ok(())
    }

    /// A first move before any G20/G21: read in the default units, which LinuxCNC may not
    /// share (see [`ParseOptions::default_units`]).
    fn note_assumed_units(&mut self) {
        let s = &self.stats;
        if s.units_assumed.is_some() || !s.units_seen.is_empty() || s.g0 + s.g1 + s.g2 + s.g3 == 0 {
            return;
        }
        self.stats.units_assumed = Some(self.line_no);
        let (name, other) = match self.opts.default_units {
            Units::Millimetres => ("millimetres", "inch"),
            Units::Inches => ("inches", "mm"),
        };
        self.warn(format!(
            "the program moves before any G20/G21: read in {name}; LinuxCNC reads it in the \
             machine's units ([TRAJ] LINEAR_UNITS; rs274 alone: inches): give --units {other} \
             if the machine's are {other}"
        ));
    }

    fn too_large(&self, why: &'static str) -> ParseError {
        self.err_line(ParseErrorKind::TooLarge {
            limit: self.opts.max_held_blocks,
            why,
        })
    }

    /// After the last line: open blocks are errors; the toolpath's start and units.
    pub(crate) fn finish(&mut self) -> Result<(), ParseError> {
        self.flow.check_closed(self)?;
        if self.main_m99 {
            self.pin_all();
        }
        self.tp.units = self
            .stats
            .units_seen
            .first()
            .copied()
            .unwrap_or(self.opts.default_units);
        let first = self
            .tp
            .moves()
            .next()
            .map(|m| ncsmooth::geom::ParamCurve::start(&m.segment));
        if let Some(start) = first {
            self.tp.start = start;
        }
        Ok(())
    }

    /// Offset of line `k`, the next one to run: the line after the current one, an O-word
    /// line or the line after one, or a line a call returns to.
    fn offset_of(&self, k: usize) -> usize {
        if k == self.pc + 1 {
            return self.raw_end + 1;
        }
        if let Some(o) = self.oline_at(k) {
            return o.start;
        }
        if let Some(o) = k.checked_sub(1).and_then(|j| self.oline_at(j)) {
            return o.next;
        }
        match self.returns.get(&k) {
            Some(&off) => off,
            None => unreachable!("a jump to line {k}, which is no O-word line nor a return"),
        }
    }

    /// The O-word line of index `k`, if it is one.
    pub(crate) fn oline_at(&self, k: usize) -> Option<&text::OLineAt> {
        let o = &self.scan.olines;
        o.binary_search_by_key(&k, |o| o.line).ok().map(|i| &o[i])
    }

    /// Byte range of line `k`: the current line or an O-word line.
    pub(crate) fn line_range(&self, k: usize) -> (usize, usize) {
        if k == self.pc {
            return (self.raw_start, self.raw_end);
        }
        self.oline_at(k)
            .map_or((self.raw_start, self.raw_end), |o| (o.start, o.end))
    }

    /// Records the lines a call on the current line returns to.
    pub(crate) fn remember_return_lines(&mut self) {
        self.returns.insert(self.pc, self.raw_start);
        self.returns.insert(self.pc + 1, self.raw_end + 1);
    }

    fn text_err(&self, e: TextError) -> ParseError {
        match e {
            TextError::Parse(e) => *e,
            TextError::Io(e) => ParseError::in_line(
                self.file,
                b"",
                self.pc,
                self.pc_offset,
                self.pc_offset..self.pc_offset,
                ParseErrorKind::Io { why: e.to_string() },
            ),
        }
    }

    /// An error at source bytes `range`: in the current line, or in an O-word line.
    fn error_at(&self, range: std::ops::Range<usize>, kind: ParseErrorKind) -> ParseError {
        if (self.raw_start..=self.raw_end).contains(&range.start) {
            return ParseError::in_line(
                self.file,
                self.raw.as_bytes(),
                self.pc,
                self.raw_start,
                range,
                kind,
            );
        }
        if let Text::Whole(src) = &self.text {
            return ParseError::at(self.file, src.as_bytes(), range, kind);
        }
        match self
            .scan
            .olines
            .iter()
            .find(|o| (o.start..=o.end).contains(&range.start))
        {
            Some(o) => {
                ParseError::in_line(self.file, o.raw.as_bytes(), o.line, o.start, range, kind)
            }
            None => {
                let sc = &self.scan;
                let last = sc.n_lines.saturating_sub(1);
                ParseError::in_line(
                    self.file,
                    sc.last_text.as_bytes(),
                    last,
                    sc.last_line.0,
                    range,
                    kind,
                )
            }
        }
    }

    pub(crate) fn lex_err(&self, e: LexError) -> ParseError {
        self.error_at(e.start..e.end, e.kind)
    }

    pub(crate) fn err_word(&self, w: usize, kind: ParseErrorKind) -> ParseError {
        match self.words.get(w) {
            Some(w) => self.error_at(w.start..w.end, kind),
            None => self.err_line(kind),
        }
    }

    pub(crate) fn err_line(&self, kind: ParseErrorKind) -> ParseError {
        let (s, e) = match (self.words.first(), self.words.last()) {
            (Some(a), Some(b)) => (a.start, b.end),
            _ => (self.raw_start, self.raw_end),
        };
        self.error_at(s..e, kind)
    }

    /// An error spanning source bytes `range`.
    pub(crate) fn err_at(&self, range: std::ops::Range<usize>, kind: ParseErrorKind) -> ParseError {
        self.error_at(range, kind)
    }

    pub(crate) fn warn(&mut self, message: impl Into<String>) {
        self.stats.warnings.push(Warning {
            line: self.line_no,
            message: message.into(),
        });
    }

    /// Millimetres per program unit.
    #[inline]
    pub(crate) fn scale(&self) -> f64 {
        match self.m.units {
            Units::Millimetres => 1.0,
            Units::Inches => MM_PER_INCH,
        }
    }

    /// True while executing inside a subroutine call or an O-word block.
    #[inline]
    pub(crate) fn nested(&self) -> bool {
        self.store.depth() > 0 || self.flow.in_block()
    }

    /// Executes line `self.pc`.
    fn exec_line(&mut self) -> Result<(), ParseError> {
        self.line_no = u32::try_from(self.pc + 1).unwrap_or(u32::MAX);
        compact_line(self.raw.as_bytes(), self.raw_start, &mut self.lb)
            .map_err(|e| self.lex_err(e))?;
        self.line_first_block = self.tp.blocks.len();
        self.line_events = false;
        self.line_block_s = false;
        self.line_modal_motion = false;
        self.line_path_mode = false;
        self.line_pinned = self.nested() || self.lb.block_delete || self.pin_everything;
        self.words.clear();
        self.assigns.clear();
        // The block's sorted words too: a line without words must not see the last ones.
        self.gcodes.clear();
        self.mcodes.clear();
        self.letters = [None; N_SLOTS];
        self.present = 0;
        self.used = 0;
        let (word, bit) = (self.pc / 64, 1u64 << (self.pc % 64));
        let first_time = self.executed[word] & bit == 0;
        self.executed[word] |= bit;
        if first_time {
            let before = self.write_state();
            if let Some(info) = self.map.lines.get_mut(self.pc) {
                info.flags |= flags::EXECUTED;
                info.before = before;
            }
        }
        if self.lb.percent {
            // A `%` line: the first one opens the program, the next one ends it.
            if self.percent_open || self.has_executed_content() {
                self.end_program();
            } else {
                self.percent_open = true;
            }
            return Ok(());
        }
        let body = oword::skip_line_number(&self.lb.bytes);
        if self.lb.bytes.get(body) == Some(&b'O') {
            // O-word statements run no comment (LinuxCNC).
            self.mark_line(flags::OWORD);
            self.pin_last_move();
            return self.o_statement(body);
        }
        if self.lb.bytes.get(body) == Some(&b'M') {
            if let Some(statement) = self.fanuc_statement_at(body) {
                // Like O-word statements, M98 and a returning M99 run no comment.
                self.mark_line(flags::OWORD);
                self.pin_last_move();
                return self.fanuc_statement(statement, body);
            }
        }
        // Comments and messages come first, as in LinuxCNC.
        self.comment()?;
        if !self.lb.bytes.is_empty() {
            self.read_words()?;
            if !self.words.is_empty() {
                self.block()?;
            }
            self.assign_params()?;
        }
        self.finish_line(first_time);
        Ok(())
    }

    /// Reads the words and parameter assignments of the current line.
    pub(crate) fn read_words(&mut self) -> Result<(), ParseError> {
        let (mut words, mut assigns) = (
            std::mem::take(&mut self.words),
            std::mem::take(&mut self.assigns),
        );
        let r = read_block(&self.lb, 0, &*self, &mut words, &mut assigns);
        self.words = words;
        self.assigns = assigns;
        r.map_err(|e| self.lex_err(e))
    }

    /// A real value (number, parameter or expression) read at compacted index `pos` of the
    /// current line (`letter`: the word it belongs to, for messages), and the index after
    /// it.
    pub(crate) fn value_at(
        &mut self,
        pos: usize,
        letter: Option<u8>,
    ) -> (Result<f64, LexError>, usize) {
        let lb = std::mem::take(&mut self.lb);
        let mut c = Cursor {
            buf: &lb.bytes,
            map: &lb.map,
            line_end: lb.line_end,
            pos,
        };
        let r = read_real_value(&mut c, &*self, 0, letter);
        let end = c.pos;
        self.lb = lb;
        (r, end)
    }

    /// Sets flag `f` of the current line in the source map (when one is kept).
    pub(crate) fn mark_line(&mut self, f: u8) {
        if let Some(info) = self.map.lines.get_mut(self.pc) {
            info.flags |= f;
        }
    }

    /// Whether any line before this one did something (for the opening-`%` rule).
    fn has_executed_content(&self) -> bool {
        self.drained > 0 || !self.tp.blocks.is_empty()
    }

    /// Applies the line's parameter assignments (after the line, as NGC says).
    fn assign_params(&mut self) -> Result<(), ParseError> {
        if self.assigns.is_empty() {
            return Ok(());
        }
        self.line_pinned = true;
        let assigns = std::mem::take(&mut self.assigns);
        for a in &assigns {
            match &a.target {
                AssignTarget::Numbered(i) => self.store.set(*i, a.value),
                AssignTarget::Named(n) => {
                    if n.first() == Some(&b'_') && modal::is_predefined(n) {
                        return Err(self.err_at(
                            a.start..a.end,
                            ParseErrorKind::ControlFlow {
                                why: format!(
                                    "#<{}> is a read-only predefined parameter",
                                    String::from_utf8_lossy(n).to_lowercase()
                                ),
                            },
                        ));
                    }
                    self.store.set_named(n, a.value)
                }
            }
        }
        self.assigns = assigns;
        Ok(())
    }

    /// Records what the writer needs of the line just executed, and pins its moves when
    /// the line may not be replaced.
    fn finish_line(&mut self, first_time: bool) {
        let explicit_motion = self.gcode(|c| block::g_modal_group(c) == Some(1) || c == 800);
        let replaceable = first_time && !self.line_pinned && !self.line_events && {
            let lb = &self.lb;
            lb.paren_comments == 0 && lb.semicolon.is_none() && self.only_motion_words()
        };
        if !replaceable {
            for b in &mut self.tp.blocks[self.line_first_block..] {
                if let Block::Move(mv) = b {
                    mv.pinned = true;
                }
            }
        }
        if first_time {
            self.stats.axes_known |= self.f.known | self.f.relative;
        }
        if replaceable {
            self.stats.replaceable_lines += 1;
            self.m.last_g5_replaceable |=
                self.m.last_g5.is_some_and(|k| k >= self.line_first_block);
        }
        if self.map.lines.is_empty() {
            return;
        }
        let state = self.write_state();
        let info = &mut self.map.lines[self.pc];
        if self.line_modal_motion {
            info.flags |= flags::MODAL_MOTION;
        }
        if self.line_path_mode {
            info.flags |= flags::PATH_MODE;
        }
        if explicit_motion.is_some() {
            info.flags |= flags::EXPLICIT_MOTION;
        }
        if replaceable {
            info.flags |= flags::REPLACEABLE;
        }
        if first_time {
            info.state = state;
        }
    }

    /// The block has only words a rewrite restores: motion codes G0-G3, G5 and G5.1 with
    /// their axis, centre and spline words, plane, distance modes, G94, F and N. (Canned
    /// cycles and G5.2/G5.3 NURBS pin their lines themselves.)
    fn only_motion_words(&self) -> bool {
        let g_ok = self.gcodes.iter().all(|c| {
            matches!(
                c.code10,
                0 | 10 | 20 | 30 | 50 | 51 | 170 | 180 | 190 | 900 | 910 | 901 | 911 | 940
            )
        });
        let mut allowed = block::MOTION_LETTER_SLOTS;
        if self.line_block_s {
            allowed |= 1 << block::slot(b'S');
        }
        let letters_ok = self.present & !allowed == 0;
        g_ok && self.mcodes.is_empty() && letters_ok
    }

    /// The modal state a writer must restore after this line.
    pub(crate) fn write_state(&self) -> WriteState {
        WriteState {
            units: self.m.units,
            absolute: self.m.absolute,
            arc_absolute: self.m.arc_absolute,
            plane: self.m.plane,
            diameter: self.m.diameter,
            e_relative: self.m.e_relative,
            motion10: self.m.motion,
            feed_word: self.m.feed_word.unwrap_or(f64::NAN),
            known: self.f.known,
            relative: self.f.relative,
            path: self.m.path,
        }
    }

    /// Pins the last move produced (before an O-word statement at the top level), so that a
    /// writer resumes verbatim text in the motion mode the source had.
    fn pin_last_move(&mut self) {
        if let Some(Block::Move(mv)) = self
            .tp
            .blocks
            .iter_mut()
            .rev()
            .find(|b| matches!(b, Block::Move(_)))
        {
            mv.pinned = true;
        }
    }

    /// Pins every move and clears every replaceable mark (a main program ended by `M99`).
    fn pin_all(&mut self) {
        self.stats.replaceable_lines = 0;
        for info in &mut self.map.lines {
            info.flags &= !flags::REPLACEABLE;
        }
        for b in &mut self.tp.blocks {
            if let Block::Move(mv) = b {
                mv.pinned = true;
            }
        }
    }

    /// Ends the program: nothing after this line is executed.
    pub(crate) fn end_program(&mut self) {
        self.ended = true;
        self.map.end_line = Some(self.pc);
    }

    /// Appends an event of the current line.
    pub(crate) fn event(&mut self, kind: EventKind, text: String) {
        if text.is_empty() {
            return;
        }
        self.line_events = true;
        self.tp.push_event(Event {
            line: self.line_no,
            kind,
            text,
        });
    }

    /// Records a canonical command (conformance runs only).
    pub(crate) fn canon(&mut self, c: impl FnOnce(&Self) -> Canon) {
        if self.canon.is_some() {
            let c = c(self);
            if let Some(v) = &mut self.canon {
                v.push(c);
            }
        }
    }

    /// A position value of axis `i` in program units (for parameters and canon).
    pub(crate) fn prog_units(&self, i: usize, v: f64) -> f64 {
        if (3..6).contains(&i) {
            v
        } else {
            v / self.scale()
        }
    }
}

impl ParamLookup for Interp<'_> {
    fn numbered(&self, index: u32) -> Option<f64> {
        if let Some(v) = modal::system_param(self, index) {
            return Some(v);
        }
        match self.store.get(index) {
            Some(v) => Some(v),
            // A known machine reads unset parameters as its parameter file would: 0.
            None if self.opts.machine.is_some() => Some(0.0),
            None if index > 5000 => Some(UNKNOWN),
            None => None,
        }
    }

    fn named(&self, name: &[u8]) -> Option<f64> {
        if name.first() == Some(&b'_') {
            if let Some(v) = modal::predefined_param(self, name) {
                return Some(v);
            }
        }
        self.store.get_named(name)
    }
}

/// Unused-axis helper: the value of the axes array for the geometry.
pub(crate) fn axes_vec(p: &[f64; N_AXES]) -> ncsmooth::geom::Vec3 {
    ncsmooth::geom::Vec3::new(p[0], p[1], p[2])
}
