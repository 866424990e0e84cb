//! The modal interpreter: blocks of words in, [`Toolpath`] out.
//!
//! # State
//!
//! Motion mode (G0 G1 G2 G3, or none after G80), plane (G17 G18 G19), units (G20 G21),
//! distance mode (G90 G91), arc centre mode (G90.1 absolute, G91.1 incremental, the
//! default), E mode (M82 absolute, the default, M83 relative), feed (mm/s), the current
//! position (mm, work coordinates) and the extra-axis values. The initial state is G0 G17
//! G21 G90 G91.1 G94 M82 at `ParseOptions::start`, with no feed.
//!
//! Inch input (G20) is converted to mm for everything with a length: X Y Z, I J K R,
//! U V W and E, F, and the P/Q tolerances of G64. Rotary axes A B C are degrees and
//! are not scaled. F is stored as mm/s, converted with the units in force in the block
//! that sets it (a later G20/G21 does not rescale an already programmed feed).
//!
//! # Order within a block
//!
//! A block is executed in LinuxCNC's documented order of execution, so a block with
//! motion and other words gives, in this order: events for spindle speed and on/off
//! (`S`, `M3 M4 M5`), tool select and change (`T`, `M6`), coolant (`M7 M8 M9`), other M
//! codes, dwell (`G4`), cutter compensation off (`G40`), tool length offset (`G43 H`,
//! `G49`), coordinate system (`G54`..`G59.3`), path control (`G61 G61.1 G64`), canned
//! cycle cancel (`G80`), retract mode, `G28`/`G30`/`G92 E`; then the move; then program
//! stops (`M0 M1 M2 M30 M60`), which LinuxCNC executes last, after the motion of their
//! block. Plane, units, distance modes, `G94` and `F` change the interpreter state and are
//! reflected in the geometry; they are not events (the writer emits its own `G21 G90 G94`
//! header, and re-emitting a `G20` would corrupt its mm output).
//!
//! Printer M codes (any M code other than LinuxCNC's M0-M9, M30, M48-M53, M60-M68,
//! M70-M73) take the `S`, `P`, `R` and `T` words of their block as parameters
//! (`M104 S200`, `M106 S255`), as slicer firmware does, instead of those being spindle or
//! tool words.
//!
//! # Moves
//!
//! Axis words (X Y Z A B C U V W E) in a motion mode make a move. When the block moves
//! X, Y or Z, it is a [`Move`]: a [`Line`] for G0/G1, an [`Arc`] for G2/G3 (built by
//! [`Arc::from_center`]). When it moves only extra axes (an extruder retract `G1 E-1.5
//! F2400`), it is an [`Event`] of kind `Other` whose text is the canonical absolute form
//! (`G1 E<absolute mm> F<mm/min>`), and the extra-axis state is updated. Zero-length
//! moves are kept and warned about.
//!
//! Arcs follow LinuxCNC's plane conventions: G17 is the XY plane with normal +Z (centre
//! words I J), G18 the ZX plane with normal +Y (K I; G3 turns from +Z towards +X), G19 the
//! YZ plane with normal +X (J K). G3 is a positive (counter-clockwise) rotation about the
//! normal, G2 negative. The axis word along the normal makes a helix. `P` is the number
//! of turns (P1 = the default single turn). A centre-format arc whose start and end radii
//! differ by more than max(0.005 mm, 0.1 % of the radius) is an
//! [`ArcRadiusMismatch`](ParseErrorKind::ArcRadiusMismatch) error; within tolerance
//! `Arc::from_center` moves the centre onto the chord bisector so the arc ends exactly
//! at the programmed point. For `R` arcs, a negative R takes the long way (more than
//! 180 degrees); when the half chord exceeds |R| by no more than the same tolerance the
//! arc is a semicircle, beyond it an [`ArcRadiusTooSmall`](ParseErrorKind::ArcRadiusTooSmall)
//! error. An R arc cannot be a full circle.
//!
//! # Treatments of note
//!
//! * `G53` with G0/G1 motion makes a move with `machine_coords = true`, placed as if the
//!   work offset were zero (the parser cannot know the offsets); G53 with G2/G3 or under
//!   G91 is an error, as in LinuxCNC.
//! * `G28`/`G30` (with or without axis words) and `G28.1`/`G30.1` are kept as events.
//!   `G28`/`G30` move the machine home, after which the real position is unknown to the
//!   parser: it warns and keeps the position unchanged, so the next move starts from the
//!   last programmed point. The event text carries the axis words as programmed
//!   (converted to mm); their intermediate-point meaning is not interpreted.
//! * `G92` with only `E` (slicer `G92 E0`) resets the E axis and is an event. `G92` on any
//!   other axis, and `G92.1`..`G92.3`, `G52`, `G10`, are unsupported: they shift the
//!   coordinate system under the program.
//! * `M83` (relative E) is accepted and kept as an event; E is then tracked relatively,
//!   and the stored extra-axis values are always absolute.
//! * Unsupported, with an error naming the word: cutter compensation G41/G42, inverse
//!   time and per-revolution feed G93/G95, canned cycles G73 G76 G81-G89, threading G33,
//!   probing G38.x, splines G5.x, lathe diameter mode G7/G8, polar G16, O-words,
//!   subprograms M98/M99, program repeat M47, named parameters.
//! * A feed move before any `F` gets `feed_mm_s = None` and one warning (the first
//!   time). `F0` likewise counts as no feed.
//! * `G80` cancels the motion mode (axis words without a new motion code are then an
//!   error, as in LinuxCNC) and is kept as an event. `G80` together with G0-G3 in one
//!   block (`G80 G00`, as CAM headers write it) is accepted: the cycle is cancelled and
//!   the motion code is in force, although LinuxCNC itself rejects two codes of group 1.
//! * A centre word of another plane on an arc (`K` on a G17 arc) is an error, as in
//!   LinuxCNC; under `G90.1` both centre words of the plane are required. Other unused
//!   words (`I` on a line) are warned about and ignored. A letter twice in a block is an
//!   error; G and M codes may repeat, but two codes of one modal group in a block (`G90
//!   G91`, `M3 M5`; `M7 M8` excepted) and more than four M codes are errors, as in LinuxCNC.

use crate::error::{ParseError, ParseErrorKind, Warning};
use crate::expr::Params;
use crate::lexer::{compact_line, read_block, Assign, LexError, LineBuf, Word};
use crate::{ParseOptions, ParseStats, Plane, Program};
use ncsmooth::geom::{Arc, Line, Vec3};
use ncsmooth::path::{Event, EventKind, ExtraAxes, Move, MoveKind, Toolpath, Units};
use std::fmt::Write as _;

const MM_PER_INCH: f64 = 25.4;

/// Index of the extra axis letter in `EXTRA_AXIS_NAMES` order (A B C U V W E).
fn extra_index(letter: u8) -> Option<usize> {
    match letter {
        b'A' => Some(0),
        b'B' => Some(1),
        b'C' => Some(2),
        b'U' => Some(3),
        b'V' => Some(4),
        b'W' => Some(5),
        b'E' => Some(6),
        _ => None,
    }
}

/// True for the linear extra axes (scaled by the units).
fn extra_is_linear(i: usize) -> bool {
    i >= 3
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Motion {
    G0,
    G1,
    G2,
    G3,
    None,
}

/// Formats `v` for event text: up to 10 decimals, no trailing zeros, never `-0`.
pub(crate) fn push_num(s: &mut String, v: f64) {
    crate::writer::push_fixed(s, v, 10);
}

/// Formats a G/M code stored as tenths (`901` -> `90.1`).
fn push_code(s: &mut String, letter: char, code10: u32) {
    if !s.is_empty() {
        s.push(' ');
    }
    s.push(letter);
    let _ = write!(s, "{}", code10 / 10);
    if code10 % 10 != 0 {
        let _ = write!(s, ".{}", code10 % 10);
    }
}

fn code_name(letter: char, code10: u32) -> String {
    let mut s = String::new();
    push_code(&mut s, letter, code10);
    s
}

fn push_word(s: &mut String, letter: u8, v: f64) {
    if !s.is_empty() {
        s.push(' ');
    }
    s.push(letter as char);
    push_num(s, v);
}

/// A located code word of the block.
#[derive(Clone, Copy)]
struct Code {
    code10: u32,
    word: usize,
}

/// Most M codes LinuxCNC accepts in one block.
const MAX_M_CODES_PER_BLOCK: usize = 4;
/// Number of G modal groups [`g_modal_group`] distinguishes.
const G_GROUPS: usize = 16;
/// Number of M modal groups [`m_modal_group`] distinguishes.
const M_GROUPS: usize = 4;

/// LinuxCNC's modal group of a G code (in tenths: `G90.1` is 901), as an index below
/// [`G_GROUPS`]; `None` for codes outside the groups. Group 0 (non-modal codes: G4, G10,
/// G28, G30, G53, G92, ...) also allows only one code per block.
fn g_modal_group(code10: u32) -> Option<usize> {
    Some(match code10 {
        40 | 100 | 280 | 281 | 300 | 301 | 520 | 530 | 920..=923 => 0,
        // G80 is left out: `G80 G00` in CAM headers is accepted (see the module doc).
        0 | 10 | 20 | 30 | 330 | 331 | 382..=385 | 730 | 760 | 810..=890 => 1,
        170 | 171 | 180 | 181 | 190 | 191 => 2,
        900 | 910 => 3,
        901 | 911 => 4,
        930 | 940 | 950 => 5,
        200 | 210 => 6,
        400 | 410 | 411 | 420 | 421 => 7,
        430..=432 | 490 => 8,
        980 | 990 => 9,
        540..=593 => 10,
        610 | 611 | 640 => 11,
        960 | 970 => 12,
        70 | 80 => 13,
        150 | 160 => 14,
        _ => return None,
    })
}

/// LinuxCNC's modal group of an M code (tenths), as an index below [`M_GROUPS`]: stops
/// (M0 M1 M2 M30 M60), tool change (M6), spindle (M3 M4 M5), coolant (M7 M8 M9).
fn m_modal_group(code10: u32) -> Option<usize> {
    Some(match code10 {
        0 | 10 | 20 | 300 | 600 => 0,
        60 => 1,
        30 | 40 | 50 => 2,
        70 | 80 | 90 => 3,
        _ => return None,
    })
}

/// The interpreter.
pub(crate) struct Interp<'a> {
    src: &'a str,
    file: &'a str,
    // Modal state.
    motion: Motion,
    plane: Plane,
    units: Units,
    absolute: bool,
    arc_absolute: bool,
    e_relative: bool,
    feed: Option<f64>,
    feed_warned: bool,
    pos: Vec3,
    extra: ExtraAxes,
    params: Params,
    // Output.
    tp: Toolpath,
    stats: ParseStats,
    // Per-line scratch (reused).
    line_no: u32,
    lb: LineBuf,
    words: Vec<Word>,
    assigns: Vec<Assign>,
    gcodes: Vec<Code>,
    mcodes: Vec<Code>,
    letters: [Option<usize>; 26],
    used: u32,
}

impl<'a> Interp<'a> {
    pub(crate) fn new(src: &'a str, file: &'a str, opts: &ParseOptions) -> Self {
        Interp {
            src,
            file,
            motion: Motion::G0,
            plane: Plane::XY,
            units: Units::Millimetres,
            absolute: true,
            arc_absolute: false,
            e_relative: false,
            feed: None,
            feed_warned: false,
            pos: opts.start,
            extra: [0.0; 7],
            params: Params::default(),
            tp: Toolpath::new(opts.start),
            stats: ParseStats::default(),
            line_no: 0,
            lb: LineBuf::default(),
            words: Vec::with_capacity(16),
            assigns: Vec::new(),
            gcodes: Vec::with_capacity(8),
            mcodes: Vec::with_capacity(4),
            letters: [None; 26],
            used: 0,
        }
    }

    pub(crate) fn run(mut self) -> Result<Program, ParseError> {
        let src = self.src;
        let bytes = src.as_bytes();
        self.stats.bytes = bytes.len();
        // One block per line at most, give or take: reserve up front instead of growing
        // (and copying) a vector of 200-byte blocks many times.
        let newlines = bytes.iter().filter(|&&b| b == b'\n').count();
        self.tp.blocks.reserve(newlines + 1);
        let mut start = 0;
        while start < bytes.len() {
            let end = memchr_newline(&bytes[start..]).map_or(bytes.len(), |p| start + p);
            self.line_no = self.line_no.saturating_add(1);
            self.line(&bytes[start..end], start)?;
            start = end + 1;
        }
        self.stats.lines = self.line_no as usize;
        if let Some(&u) = self.stats.units_seen.first() {
            self.tp.units = u;
        }
        Ok(Program {
            toolpath: self.tp,
            stats: self.stats,
        })
    }

    fn lex_err(&self, e: LexError) -> ParseError {
        ParseError::at(self.file, self.src.as_bytes(), e.start..e.end, e.kind)
    }

    fn err_word(&self, w: usize, kind: ParseErrorKind) -> ParseError {
        let w = self.words[w];
        ParseError::at(self.file, self.src.as_bytes(), w.start..w.end, kind)
    }

    fn err_line(&self, kind: ParseErrorKind) -> ParseError {
        let (s, e) = match (self.words.first(), self.words.last()) {
            (Some(a), Some(b)) => (a.start, b.end),
            _ => (self.lb.line_end, self.lb.line_end),
        };
        ParseError::at(self.file, self.src.as_bytes(), s..e, kind)
    }

    fn warn(&mut self, message: impl Into<String>) {
        self.stats.warnings.push(Warning {
            line: self.line_no,
            message: message.into(),
        });
    }

    fn scale(&self) -> f64 {
        match self.units {
            Units::Millimetres => 1.0,
            Units::Inches => MM_PER_INCH,
        }
    }

    /// The value of letter `l`, marking it used.
    fn val(&mut self, l: u8) -> Option<f64> {
        let i = (l - b'A') as usize;
        let w = self.letters[i]?;
        self.used |= 1 << i;
        Some(self.words[w].value)
    }

    fn has(&self, l: u8) -> bool {
        self.letters[(l - b'A') as usize].is_some()
    }

    fn word_of(&self, l: u8) -> usize {
        self.letters[(l - b'A') as usize].unwrap_or(0)
    }

    fn line(&mut self, line: &[u8], line_start: usize) -> Result<(), ParseError> {
        compact_line(line, line_start, &mut self.lb).map_err(|e| self.lex_err(e))?;
        if self.lb.bytes.is_empty() {
            return Ok(());
        }
        read_block(&self.lb, &self.params, &mut self.words, &mut self.assigns)
            .map_err(|e| self.lex_err(e))?;
        if !self.words.is_empty() {
            self.block()?;
        }
        for a in &self.assigns {
            self.params.set(a.index, a.value);
        }
        Ok(())
    }

    /// Sorts the words of the block into codes and letter slots.
    fn classify(&mut self) -> Result<(), ParseError> {
        self.gcodes.clear();
        self.mcodes.clear();
        self.letters = [None; 26];
        self.used = 0;
        for (i, w) in self.words.iter().enumerate() {
            match w.letter {
                b'G' | b'M' => {
                    let t = w.value * 10.0;
                    let r = t.round();
                    if (t - r).abs() > 1e-3 || !(0.0..=1e6).contains(&r) {
                        let mut word = String::new();
                        push_word(&mut word, w.letter, w.value);
                        return Err(self.err_word(i, ParseErrorKind::UnknownWord { word }));
                    }
                    let c = Code {
                        code10: r as u32,
                        word: i,
                    };
                    if w.letter == b'G' {
                        self.gcodes.push(c);
                    } else {
                        self.mcodes.push(c);
                    }
                }
                b'N' => {}
                l => {
                    let slot = &mut self.letters[(l - b'A') as usize];
                    if slot.is_some() {
                        return Err(
                            self.err_word(i, ParseErrorKind::DuplicateWord { letter: l as char })
                        );
                    }
                    *slot = Some(i);
                }
            }
        }
        Ok(())
    }

    /// Rejects two codes of one modal group in a block (LinuxCNC: "two G codes used from
    /// same modal group"; M7 with M8 is the one allowed pair) and more than
    /// [`MAX_M_CODES_PER_BLOCK`] M codes. Besides matching LinuxCNC, this bounds how many
    /// codes of each kind [`Self::block`] has to keep.
    fn check_modal_groups(&self) -> Result<(), ParseError> {
        let mut g_seen: [Option<Code>; G_GROUPS] = [None; G_GROUPS];
        for &c in &self.gcodes {
            if let Some(g) = g_modal_group(c.code10) {
                if let Some(prev) = g_seen[g] {
                    return Err(self.err_word(
                        c.word,
                        ParseErrorKind::ModalConflict {
                            first: code_name('G', prev.code10),
                            second: code_name('G', c.code10),
                        },
                    ));
                }
                g_seen[g] = Some(c);
            }
        }
        if self.mcodes.len() > MAX_M_CODES_PER_BLOCK {
            let c = self.mcodes[MAX_M_CODES_PER_BLOCK];
            return Err(self.err_word(
                c.word,
                ParseErrorKind::InvalidValue {
                    letter: 'M',
                    value: f64::from(c.code10) / 10.0,
                    why: "more than 4 M codes in one block",
                },
            ));
        }
        let mut m_seen: [Option<Code>; M_GROUPS] = [None; M_GROUPS];
        for &c in &self.mcodes {
            if let Some(g) = m_modal_group(c.code10) {
                if let Some(prev) = m_seen[g] {
                    let mist_and_flood = matches!((prev.code10, c.code10), (70, 80) | (80, 70));
                    if !mist_and_flood {
                        return Err(self.err_word(
                            c.word,
                            ParseErrorKind::ModalConflict {
                                first: code_name('M', prev.code10),
                                second: code_name('M', c.code10),
                            },
                        ));
                    }
                }
                m_seen[g] = Some(c);
            }
        }
        Ok(())
    }

    /// The G code of the active plane.
    fn plane_code(&self) -> &'static str {
        match self.plane {
            Plane::XY => "G17",
            Plane::XZ => "G18",
            Plane::YZ => "G19",
        }
    }

    fn unsupported(&self, c: Code, why: &'static str) -> ParseError {
        let letter = self.words[c.word].letter as char;
        self.err_word(
            c.word,
            ParseErrorKind::Unsupported {
                word: code_name(letter, c.code10),
                why,
            },
        )
    }

    fn block(&mut self) -> Result<(), ParseError> {
        self.classify()?;
        self.check_modal_groups()?;

        // --- G codes: validate and pick up modal changes.
        let mut motion_code: Option<Code> = None;
        let mut g80 = false;
        let mut new_plane = None;
        let mut new_units = None;
        let mut dwell = false;
        let mut g53 = false;
        let mut g28: Option<Code> = None;
        let mut g92 = false;
        let mut g43: Option<Code> = None;
        let mut g64: Option<Code> = None;
        let mut misc_g: [Option<Code>; 8] = [None; 8];
        let mut n_misc = 0;
        let mut spindle_g: Option<Code> = None;
        for k in 0..self.gcodes.len() {
            let c = self.gcodes[k];
            match c.code10 {
                800 => g80 = true,
                0 | 10 | 20 | 30 => {
                    if let Some(prev) = motion_code {
                        return Err(self.err_word(
                            c.word,
                            ParseErrorKind::ModalConflict {
                                first: code_name('G', prev.code10),
                                second: code_name('G', c.code10),
                            },
                        ));
                    }
                    motion_code = Some(c);
                }
                40 => dwell = true,
                170 => new_plane = Some(Plane::XY),
                180 => new_plane = Some(Plane::XZ),
                190 => new_plane = Some(Plane::YZ),
                200 => new_units = Some(Units::Inches),
                210 => new_units = Some(Units::Millimetres),
                900 => self.absolute = true,
                910 => self.absolute = false,
                901 => self.arc_absolute = true,
                911 => self.arc_absolute = false,
                940 => {}
                530 => g53 = true,
                280 | 300 => g28 = Some(c),
                920 => g92 = true,
                430 | 490 => g43 = Some(c),
                610 | 611 | 640 => g64 = Some(c),
                960 | 970 => spindle_g = Some(c),
                150 | 281 | 301 | 400 | 540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593
                | 980 | 990 => {
                    if n_misc < misc_g.len() {
                        misc_g[n_misc] = Some(c);
                        n_misc += 1;
                    }
                }
                930 | 950 => {
                    return Err(self.unsupported(
                        c,
                        "only units-per-minute feed (G94) is supported",
                    ))
                }
                410 | 411 | 420 | 421 => {
                    return Err(self.unsupported(
                        c,
                        "cutter radius compensation changes the tool path; post-process with compensation in CAM",
                    ))
                }
                431 | 432 => {
                    return Err(self.unsupported(c, "dynamic tool length offsets are not supported"))
                }
                730 | 760 | 810..=890 if c.code10 % 10 == 0 => {
                    return Err(self.unsupported(c, "canned cycles are not supported"))
                }
                330 | 331 => return Err(self.unsupported(c, "spindle-synchronised motion is not supported")),
                382..=385 => return Err(self.unsupported(c, "probing is not supported")),
                50..=53 => return Err(self.unsupported(c, "spline motion is not supported")),
                70 | 80 => return Err(self.unsupported(c, "lathe diameter/radius mode is not supported")),
                160 => return Err(self.unsupported(c, "polar coordinates are not supported")),
                100 => {
                    return Err(self.unsupported(
                        c,
                        "G10 changes offsets or tool data under the program",
                    ))
                }
                520 | 921 | 922 | 923 => {
                    return Err(self.unsupported(
                        c,
                        "coordinate system offsets shift the program and are not supported",
                    ))
                }
                _ => {
                    return Err(self.err_word(
                        c.word,
                        ParseErrorKind::UnknownWord {
                            word: code_name('G', c.code10),
                        },
                    ))
                }
            }
        }

        // Units and plane take effect for this block's words.
        if let Some(u) = new_units {
            self.units = u;
            if !self.stats.units_seen.contains(&u) {
                self.stats.units_seen.push(u);
            }
        }
        if let Some(p) = new_plane {
            self.plane = p;
            if !self.stats.planes_seen.contains(&p) {
                self.stats.planes_seen.push(p);
            }
        }
        let scale = self.scale();

        // --- M codes.
        let mut spindle_m: [Option<Code>; 2] = [None; 2];
        let mut n_spindle_m = 0;
        let mut m6 = false;
        let mut coolant: [Option<Code>; 3] = [None; 3];
        let mut n_coolant = 0;
        let mut stops: [Option<Code>; 2] = [None; 2];
        let mut n_stops = 0;
        let mut other_m: [Option<Code>; 4] = [None; 4];
        let mut n_other = 0;
        let mut printer_m = false;
        for k in 0..self.mcodes.len() {
            let c = self.mcodes[k];
            match c.code10 {
                30 | 40 | 50 => {
                    if n_spindle_m < 2 {
                        spindle_m[n_spindle_m] = Some(c);
                        n_spindle_m += 1;
                    }
                }
                60 => m6 = true,
                70 | 80 | 90 => {
                    if n_coolant < 3 {
                        coolant[n_coolant] = Some(c);
                        n_coolant += 1;
                    }
                }
                0 | 10 | 20 | 300 | 600 => {
                    if n_stops < 2 {
                        stops[n_stops] = Some(c);
                        n_stops += 1;
                    }
                }
                470 => return Err(self.unsupported(c, "program repeat changes the motion")),
                980 | 990 => return Err(self.unsupported(c, "subprograms are not supported")),
                code if code % 10 != 0 => {
                    return Err(self.err_word(
                        c.word,
                        ParseErrorKind::UnknownWord {
                            word: code_name('M', code),
                        },
                    ))
                }
                code => {
                    if code == 820 {
                        self.e_relative = false;
                    } else if code == 830 {
                        self.e_relative = true;
                    }
                    let standard = matches!(code, 480..=530 | 610..=680 | 700..=730);
                    if !standard {
                        printer_m = true;
                    }
                    if n_other < 4 {
                        other_m[n_other] = Some(c);
                        n_other += 1;
                    }
                }
            }
        }

        // --- F.
        if let Some(f) = self.val(b'F') {
            if f < 0.0 {
                return Err(self.err_word(
                    self.word_of(b'F'),
                    ParseErrorKind::InvalidValue {
                        letter: 'F',
                        value: f,
                        why: "feed rate must not be negative",
                    },
                ));
            }
            self.feed = if f > 0.0 {
                Some(f * scale / 60.0)
            } else {
                None
            };
        }

        // --- Events before the motion, in LinuxCNC's execution order.
        let spindle_s = !printer_m || n_spindle_m > 0 || spindle_g.is_some();
        // Spindle: G96/G97, S, M3/M4/M5.
        {
            let mut text = String::new();
            if let Some(c) = spindle_g {
                push_code(&mut text, 'G', c.code10);
                if c.code10 == 960 {
                    if let Some(d) = self.val(b'D') {
                        push_word(&mut text, b'D', d);
                    }
                }
            }
            if spindle_s {
                if let Some(s) = self.val(b'S') {
                    push_word(&mut text, b'S', s);
                }
            }
            for c in spindle_m.iter().flatten() {
                push_code(&mut text, 'M', c.code10);
            }
            self.event(EventKind::Spindle, text);
        }
        // Tool: T, M6.
        {
            let mut text = String::new();
            if !printer_m || m6 {
                if let Some(t) = self.val(b'T') {
                    push_word(&mut text, b'T', t);
                }
            }
            if m6 {
                push_code(&mut text, 'M', 60);
            }
            self.event(EventKind::Tool, text);
        }
        // Coolant.
        {
            let mut text = String::new();
            for c in coolant.iter().flatten() {
                push_code(&mut text, 'M', c.code10);
            }
            self.event(EventKind::Coolant, text);
        }
        // Other M codes. The first printer M code takes S P R T (`M104 S200 T0`); the
        // first standard one takes its P Q (and E L for M62-M68) parameters.
        let arc_motion = matches!(
            (motion_code.map(|m| m.code10), self.motion),
            (Some(20 | 30), _) | (None, Motion::G2 | Motion::G3)
        );
        let mut printer_taken = false;
        let mut standard_taken = false;
        for c in other_m.into_iter().flatten() {
            let mut text = String::new();
            push_code(&mut text, 'M', c.code10);
            let standard = matches!(c.code10, 480..=530 | 610..=680 | 700..=730);
            let letters: &[u8] = if standard {
                if standard_taken {
                    b""
                } else {
                    standard_taken = true;
                    if matches!(c.code10, 620..=680) {
                        b"PQEL"
                    } else {
                        b"PQ"
                    }
                }
            } else if printer_taken {
                b""
            } else {
                printer_taken = true;
                b"SPRT"
            };
            for &l in letters {
                let taken_elsewhere = match l {
                    b'S' => spindle_s,
                    b'T' => m6,
                    b'P' | b'Q' => dwell || g64.is_some() || (l == b'P' && arc_motion),
                    b'R' => arc_motion,
                    _ => false,
                };
                if !taken_elsewhere {
                    if let Some(v) = self.val(l) {
                        push_word(&mut text, l, v);
                    }
                }
            }
            self.event(EventKind::Other, text);
        }
        // Dwell.
        if dwell {
            let Some(p) = self.val(b'P') else {
                return Err(self.err_line(ParseErrorKind::MissingWord {
                    code: "G4".into(),
                    letter: 'P',
                }));
            };
            if p < 0.0 {
                return Err(self.err_word(
                    self.word_of(b'P'),
                    ParseErrorKind::InvalidValue {
                        letter: 'P',
                        value: p,
                        why: "dwell time must not be negative",
                    },
                ));
            }
            let mut text = String::from("G4");
            push_word(&mut text, b'P', p);
            self.event(EventKind::Dwell(p), text);
        }
        // G40, G54.., G98/G99, G15, G28.1/G30.1 (kept in source order) and G43/G49.
        for c in misc_g.into_iter().flatten() {
            if c.code10 == 400 {
                self.event(EventKind::Other, code_name('G', c.code10));
            }
        }
        if let Some(c) = g43 {
            let mut text = code_name('G', c.code10);
            if c.code10 == 430 {
                if let Some(h) = self.val(b'H') {
                    push_word(&mut text, b'H', h);
                }
            }
            self.event(EventKind::ToolOffset, text);
        }
        for c in misc_g.into_iter().flatten() {
            if c.code10 != 400 {
                self.event(EventKind::Other, code_name('G', c.code10));
            }
        }
        if let Some(c) = g64 {
            let mut text = code_name('G', c.code10);
            if c.code10 == 640 {
                for l in [b'P', b'Q'] {
                    if let Some(v) = self.val(l) {
                        push_word(&mut text, l, v * scale);
                    }
                }
            }
            self.event(EventKind::Other, text);
        }
        if g80 {
            self.event(EventKind::Other, "G80".to_string());
            self.motion = Motion::None;
        }

        // Motion mode for this block.
        if let Some(c) = motion_code {
            self.motion = match c.code10 {
                0 => Motion::G0,
                10 => Motion::G1,
                20 => Motion::G2,
                _ => Motion::G3,
            };
        }

        const AXES: &[u8] = b"XYZABCUVWE";
        let any_axis = AXES.iter().any(|&l| self.has(l));

        // G28/G30 (home), G92 (E only): they take the axis words.
        if let Some(c) = g28 {
            let mut text = code_name('G', c.code10);
            for &l in AXES {
                if let Some(v) = self.val(l) {
                    let s = match extra_index(l) {
                        Some(i) if !extra_is_linear(i) => 1.0,
                        _ => scale,
                    };
                    push_word(&mut text, l, v * s);
                }
            }
            self.event(EventKind::Other, text);
            self.warn(format!(
                "{} moves the machine home; the position afterwards is unknown and is assumed unchanged",
                code_name('G', c.code10)
            ));
        } else if g92 {
            for &l in b"XYZABCUVW" {
                if self.has(l) {
                    let w = self
                        .gcodes
                        .iter()
                        .find(|c| c.code10 == 920)
                        .map_or(0, |c| c.word);
                    return Err(self.err_word(
                        w,
                        ParseErrorKind::Unsupported {
                            word: "G92".into(),
                            why: "G92 on X/Y/Z/A/B/C/U/V/W shifts the coordinate system; only G92 E is supported",
                        },
                    ));
                }
            }
            let mut text = String::from("G92");
            let mut kind = EventKind::Other;
            if let Some(e) = self.val(b'E') {
                let e = e * scale;
                push_word(&mut text, b'E', e);
                self.extra[6] = e;
                self.tp.extra_axes_mask |= 1 << 6;
                kind = EventKind::ExtraReset { to: self.extra };
            }
            self.event(kind, text);
        } else if any_axis {
            self.motion_block(g53, scale)?;
        } else if matches!(self.motion, Motion::G2 | Motion::G3)
            && (self.has(b'I') || self.has(b'J') || self.has(b'K') || self.has(b'R'))
        {
            // `G2 I5` with no end point: LinuxCNC refuses it too.
            return Err(self.err_line(ParseErrorKind::ArcNoAxes));
        }

        // --- Program stops, after the motion.
        for c in stops.into_iter().flatten() {
            self.event(EventKind::ProgramStop, code_name('M', c.code10));
        }

        // --- Leftover words.
        let mut unused = String::new();
        for (i, slot) in self.letters.iter().enumerate() {
            if slot.is_some() && self.used & (1 << i) == 0 {
                unused.push((b'A' + i as u8) as char);
            }
        }
        if !unused.is_empty() {
            self.warn(format!("word(s) {unused} unused in this block, ignored"));
        }
        Ok(())
    }

    fn event(&mut self, kind: EventKind, text: String) {
        if text.is_empty() {
            return;
        }
        self.tp.push_event(Event {
            line: self.line_no,
            kind,
            text,
        });
    }

    /// Target of the axis words (mm; rotary axes in degrees) and whether X/Y/Z appear.
    fn target(&mut self, g53: bool, scale: f64) -> Result<(Vec3, ExtraAxes, bool), ParseError> {
        let mut p = self.pos;
        let mut xyz = false;
        for (k, l) in [b'X', b'Y', b'Z'].into_iter().enumerate() {
            if let Some(v) = self.val(l) {
                xyz = true;
                let v = v * scale;
                let coord = match k {
                    0 => &mut p.x,
                    1 => &mut p.y,
                    _ => &mut p.z,
                };
                *coord = if self.absolute || g53 { v } else { *coord + v };
            }
        }
        let mut e = self.extra;
        for l in *b"ABCUVWE" {
            if let Some(v) = self.val(l) {
                let i = extra_index(l).unwrap_or(6);
                let v = if extra_is_linear(i) { v * scale } else { v };
                let relative = !(self.absolute || g53) || (i == 6 && self.e_relative);
                e[i] = if relative { e[i] + v } else { v };
                self.tp.extra_axes_mask |= 1 << i;
            }
        }
        if !p.is_finite() || e.iter().any(|v| !v.is_finite()) {
            return Err(self.err_line(ParseErrorKind::OutOfRange));
        }
        Ok((p, e, xyz))
    }

    fn motion_block(&mut self, g53: bool, scale: f64) -> Result<(), ParseError> {
        let motion = self.motion;
        if motion == Motion::None {
            return Err(self.err_line(ParseErrorKind::NoMotionMode));
        }
        if g53 && !self.absolute {
            return Err(self.err_line(ParseErrorKind::Unsupported {
                word: "G53".into(),
                why: "G53 cannot be used in incremental distance mode (G91)",
            }));
        }
        if g53 && matches!(motion, Motion::G2 | Motion::G3) {
            return Err(self.err_line(ParseErrorKind::Unsupported {
                word: "G53".into(),
                why: "G53 is only allowed with G0 or G1",
            }));
        }
        let (target, extra, xyz) = self.target(g53, scale)?;
        let line = self.line_no;
        if !xyz {
            // Extra-axis-only move: an event with the canonical absolute text.
            if matches!(motion, Motion::G2 | Motion::G3) {
                return Err(self.err_line(ParseErrorKind::ArcNoAxes));
            }
            let mut text = String::from(if motion == Motion::G0 { "G0" } else { "G1" });
            for (i, &name) in ncsmooth::path::EXTRA_AXIS_NAMES.iter().enumerate() {
                let l = name as u8;
                if self.has(l) {
                    push_word(&mut text, l, extra[i]);
                }
            }
            if motion == Motion::G1 {
                if let (true, Some(f)) = (self.has(b'F'), self.feed) {
                    push_word(&mut text, b'F', f * 60.0);
                }
            }
            // The feed is stored in mm/s, which is the rate of linear extra axes (stored in
            // mm too); rotary-only moves run at the programmed degrees per minute.
            let linear = (0..extra.len()).any(|i| extra_is_linear(i) && extra[i] != self.extra[i]);
            self.extra = extra;
            let feed_per_s = match motion {
                Motion::G1 if linear => self.feed,
                Motion::G1 => self.feed.map(|f| f / scale),
                _ => None,
            };
            self.event(
                EventKind::ExtraMove {
                    to: extra,
                    feed_per_s,
                },
                text,
            );
            return Ok(());
        }
        let start = self.pos;
        let extra_out = (self.tp.extra_axes_mask != 0).then_some(extra);
        let (mv, code) = match motion {
            Motion::G0 | Motion::G1 => {
                let seg = Line::new(start, target);
                let mut mv = if motion == Motion::G0 {
                    Move::rapid(seg, line)
                } else {
                    if self.feed.is_none() && !self.feed_warned {
                        self.feed_warned = true;
                        self.warn("feed move without a feed rate (no F programmed yet)");
                    }
                    Move::feed(seg, self.feed, line)
                };
                mv.machine_coords = g53;
                (mv, if motion == Motion::G0 { 0 } else { 1 })
            }
            _ => {
                let arc = self.arc(start, target, motion == Motion::G3, scale)?;
                if self.feed.is_none() && !self.feed_warned {
                    self.feed_warned = true;
                    self.warn("feed move without a feed rate (no F programmed yet)");
                }
                (
                    Move::feed(arc, self.feed, line),
                    if motion == Motion::G2 { 2 } else { 3 },
                )
            }
        };
        if code < 2 && start == target {
            self.stats.zero_length_moves += 1;
            self.warn("zero-length move");
        }
        match code {
            0 => self.stats.g0 += 1,
            1 => self.stats.g1 += 1,
            2 => self.stats.g2 += 1,
            _ => self.stats.g3 += 1,
        }
        let mut mv = mv;
        if mv.kind == MoveKind::Rapid {
            mv.feed_mm_s = None;
        }
        mv.extra = extra_out;
        self.tp.push_move(mv);
        self.pos = target;
        self.extra = extra;
        Ok(())
    }

    /// Builds the arc of a G2/G3 block from `start` to `end`.
    fn arc(&mut self, start: Vec3, end: Vec3, ccw: bool, scale: f64) -> Result<Arc, ParseError> {
        // (first in-plane axis, second in-plane axis, normal axis) as coordinate indices,
        // and the centre letters of the two in-plane axes.
        let (a, b, normal, la, lb, lnormal) = match self.plane {
            Plane::XY => (0usize, 1usize, Vec3::Z, b'I', b'J', b'K'),
            Plane::XZ => (2, 0, Vec3::Y, b'K', b'I', b'J'),
            Plane::YZ => (1, 2, Vec3::X, b'J', b'K', b'I'),
        };
        let get = |v: Vec3, i: usize| match i {
            0 => v.x,
            1 => v.y,
            _ => v.z,
        };
        let set = |v: &mut Vec3, i: usize, x: f64| match i {
            0 => v.x = x,
            1 => v.y = x,
            _ => v.z = x,
        };
        let turns = match self.val(b'P') {
            None => 0,
            Some(p) => {
                let r = p.round();
                if (p - r).abs() > 1e-9 || !(1.0..=10_000.0).contains(&r) {
                    return Err(self.err_word(
                        self.word_of(b'P'),
                        ParseErrorKind::InvalidValue {
                            letter: 'P',
                            value: p,
                            why: "arc turns must be an integer from 1 to 10000",
                        },
                    ));
                }
                r as u32 - 1
            }
        };
        if self.has(lnormal) {
            // LinuxCNC: "K word given for arc in XY plane" (and likewise I, J).
            return Err(self.err_word(
                self.word_of(lnormal),
                ParseErrorKind::Unsupported {
                    word: format!("{} on a {} arc", lnormal as char, self.plane_code()),
                    why: "it is not a centre offset of the active plane",
                },
            ));
        }
        let has_centre = self.has(la) || self.has(lb);
        let r_word = self.val(b'R');
        let tol = |r: f64| (0.001 * r).max(0.005);
        let (pa, pb) = (get(start, a), get(start, b));
        let (ea, eb) = (get(end, a), get(end, b));
        let center = match (r_word, has_centre) {
            (Some(_), true) => return Err(self.err_line(ParseErrorKind::ArcMixedFormat)),
            (None, false) => return Err(self.err_line(ParseErrorKind::ArcNoCentre)),
            (None, true) => {
                let ia = self.val(la).map(|v| v * scale);
                let ib = self.val(lb).map(|v| v * scale);
                if self.arc_absolute {
                    // Absolute centres have no default: LinuxCNC wants both words.
                    for (l, v) in [(la, ia), (lb, ib)] {
                        if v.is_none() {
                            return Err(self.err_line(ParseErrorKind::MissingWord {
                                code: "an arc under G90.1".into(),
                                letter: l as char,
                            }));
                        }
                    }
                }
                let (ca, cb) = if self.arc_absolute {
                    (ia.unwrap_or(pa), ib.unwrap_or(pb))
                } else {
                    (pa + ia.unwrap_or(0.0), pb + ib.unwrap_or(0.0))
                };
                let r_start = (pa - ca).hypot(pb - cb);
                let r_end = (ea - ca).hypot(eb - cb);
                if !r_start.is_finite() || !r_end.is_finite() {
                    return Err(self.err_line(ParseErrorKind::OutOfRange));
                }
                if (r_start - r_end).abs() > tol(r_start.max(r_end)) {
                    return Err(self.err_line(ParseErrorKind::ArcRadiusMismatch { r_start, r_end }));
                }
                let mut c = start;
                set(&mut c, a, ca);
                set(&mut c, b, cb);
                c
            }
            (Some(r), false) => {
                let r_mm = r * scale;
                let (da, db) = (ea - pa, eb - pb);
                let chord = da.hypot(db);
                if chord == 0.0 {
                    return Err(self.err_line(ParseErrorKind::ArcDegenerate {
                        why: "an R-format arc cannot end where it starts",
                    }));
                }
                let rad = r_mm.abs();
                let half = chord / 2.0;
                let h = if half > rad {
                    if half - rad > tol(rad) {
                        return Err(
                            self.err_line(ParseErrorKind::ArcRadiusTooSmall { radius: rad, chord })
                        );
                    }
                    0.0
                } else {
                    (rad * rad - half * half).sqrt()
                };
                // Left normal of the chord in the plane (rotate +90 degrees about the plane
                // normal): (-db, da) in (a, b) coordinates. CCW short arcs have their centre
                // on the left.
                let side = if ccw == (r_mm > 0.0) { 1.0 } else { -1.0 };
                let (ua, ub) = (da / chord, db / chord);
                let ca = pa + da / 2.0 - ub * h * side;
                let cb = pb + db / 2.0 + ua * h * side;
                let mut c = start;
                set(&mut c, a, ca);
                set(&mut c, b, cb);
                c
            }
        };
        if !center.is_finite() {
            return Err(self.err_line(ParseErrorKind::OutOfRange));
        }
        Arc::from_center(start, end, center, normal, ccw, turns)
            .ok_or_else(|| self.err_line(ParseErrorKind::ArcDegenerate { why: "zero radius" }))
    }
}

/// Position of the first `\n`.
#[inline]
fn memchr_newline(b: &[u8]) -> Option<usize> {
    b.iter().position(|&c| c == b'\n')
}
