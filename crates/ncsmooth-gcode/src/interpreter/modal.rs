//! Executing one block in LinuxCNC's order of execution, and the parameters that read the
//! interpreter's state.
//!
//! Order (LinuxCNC's `execute_block`, `convert_m`, `convert_g`): comment; feed mode (G93
//! G94 G95); F; S; T; M6 and M61; spindle M3 M4 M5; coolant M7 M8 M9; overrides M48-M53;
//! other M codes (I/O M62-M68, user M100-M199, printer codes); dwell G4; plane; units;
//! cutter compensation; tool length; coordinate system; path control; distance mode; arc
//! distance mode; retract mode; lathe diameter mode; the non-modal group (G10, G28, G30,
//! G52, G92); motion (or a canned cycle); then the program stops M0 M1 M2 M30 M60, after
//! the motion of their block.
//!
//! Printer M codes (any M code outside LinuxCNC's set: M0-M9, M19, M30, M48-M53, M60-M68,
//! M70-M73) take the `S`, `P`, `Q`, `R` and `T` words of their block as parameters
//! (`M104 S200`, `M106 S255`), as slicer firmware does, instead of those being spindle or
//! tool words. `M66`, `M67` and `M68` take `E` (an analog port), so `E` is then not an
//! extruder axis.

use super::block::{code_name, push_code, push_word, Code};
use super::frames::{MaybeAxes, ALL_AXES, AXIS_LETTERS, N_AXES, N_SYSTEMS};
use super::{Interp, MM_PER_INCH};
use crate::error::{ParseError, ParseErrorKind};
use crate::source::Plane;
use ncsmooth::path::{Event, EventKind, Units};

/// Group-1 code meaning "no motion mode" (after G80), in tenths.
pub(crate) const MOTION_NONE: u16 = 800;

/// Modal state other than positions.
#[derive(Clone, Debug)]
pub(crate) struct Modal {
    /// Group-1 code in tenths (0 G0, 10 G1, 20 G2, 30 G3, 50 G5, 51 G5.1, 52 G5.2, 810..890
    /// canned cycles, 730 G73, [`MOTION_NONE`]).
    pub motion: u16,
    pub plane: Plane,
    pub units: Units,
    pub absolute: bool,
    pub arc_absolute: bool,
    /// G7: X words are diameters.
    pub diameter: bool,
    /// M83: E words are relative.
    pub e_relative: bool,
    /// Feed (mm/s), `None` before any F (or after F0).
    pub feed: Option<f64>,
    /// F as programmed (units per minute).
    pub feed_word: Option<f64>,
    /// G99 (retract to R) rather than G98 (to the old Z).
    pub retract_r: bool,
    /// Spindle: 0 off, 1 clockwise, -1 counter-clockwise.
    pub spindle: i8,
    /// Last S word.
    pub rpm: f64,
    /// An S word has been read (the speed the controller starts with is not known).
    pub rpm_known: bool,
    pub mist: bool,
    pub flood: bool,
    /// Tool in the spindle and tool selected (T), -1 unknown.
    pub tool: f64,
    pub selected_tool: f64,
    /// A tool length offset is in force (G43...).
    pub tlo: bool,
    /// What canned cycles (and G5) keep between blocks.
    pub cycle: super::cycles::CycleMemory,
    /// The G5.2 NURBS being built (control points so far), if any.
    pub nurbs: Option<super::splines::NurbsBuild>,
    /// Index in the toolpath's blocks of the last G5 move, whose `P Q` a G5 without `I J`
    /// reuses.
    pub last_g5: Option<usize>,
    /// The line of [`Self::last_g5`] was counted replaceable (a later `G5` without `I J`
    /// pins it, and takes it off the count).
    pub last_g5_replaceable: bool,
    /// Returned value of the last subroutine (`#<_value>`), and whether there was one.
    pub value: f64,
    pub value_returned: bool,
    /// Path control mode (G61, G61.1, G64 P Q).
    pub path: crate::source::PathMode,
}

impl Default for Modal {
    fn default() -> Self {
        Modal {
            motion: 0,
            plane: Plane::XY,
            units: Units::Millimetres,
            absolute: true,
            arc_absolute: false,
            diameter: false,
            e_relative: false,
            feed: None,
            feed_word: None,
            retract_r: true,
            spindle: 0,
            rpm: 0.0,
            rpm_known: false,
            mist: false,
            flood: false,
            tool: -1.0,
            selected_tool: -1.0,
            tlo: false,
            cycle: Default::default(),
            nurbs: None,
            last_g5: None,
            last_g5_replaceable: false,
            value: 0.0,
            value_returned: false,
            path: crate::source::PathMode::Unset,
        }
    }
}

/// LinuxCNC's standard M codes (tenths): these take their own words; every other M code
/// is a printer or user code.
fn is_standard_m(code10: u32) -> bool {
    matches!(
        code10,
        0..=90 | 190 | 300 | 480..=530 | 600..=680 | 700..=730 | 980 | 990
    )
}

/// The G codes the interpreter executes (tenths), grouped as it handles them.
mod g {
    pub const DWELL: u32 = 40;
    pub const G10: u32 = 100;
    pub const G28: u32 = 280;
    pub const G28_1: u32 = 281;
    pub const G30: u32 = 300;
    pub const G30_1: u32 = 301;
    pub const G52: u32 = 520;
    pub const G92: u32 = 920;
    pub const G92_1: u32 = 921;
    pub const G92_2: u32 = 922;
}

impl Interp<'_> {
    /// Executes the words of the current line (already classified by the caller).
    pub(crate) fn block(&mut self) -> Result<(), ParseError> {
        self.classify()?;
        self.check_modal_groups()?;
        self.check_known_codes()?;
        self.feed_mode()?;
        self.feed_rate()?;
        let printer_m = self.mcode(|c| !is_standard_m(c)).is_some();
        self.spindle_and_tool(printer_m)?;
        self.other_m(printer_m)?;
        self.dwell()?;
        self.plane_and_units();
        self.cutter_comp()?;
        self.tool_length()?;
        self.coord_system();
        self.path_control();
        self.distance_modes();
        self.non_modal()?;
        self.motion_block()?;
        self.stops();
        self.warn_unused()
    }

    /// Refuses G codes ncsmooth does not model, naming what to do instead.
    fn check_known_codes(&self) -> Result<(), ParseError> {
        for &c in &self.gcodes {
            let why: &'static str = match c.code10 {
                0 | 10 | 20 | 30 | 40 | 50 | 51 | 52 | 53 | 70 | 80 | 100 | 170 | 180 | 190
                | 200 | 210 | 280 | 281 | 300 | 301 | 400 | 430 | 431 | 432 | 490 | 520 | 530
                | 540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 | 610 | 611 | 640 | 730 | 740
                | 800..=890 | 900 | 901 | 910 | 911 | 920..=923 | 940 | 960 | 970 | 980 | 990 => {
                    continue
                }
                930 => "inverse-time feed (G93) is not supported; post-process with units-per-minute feed (G94) in CAM",
                950 => "feed per revolution (G95) is not supported; post-process with units-per-minute feed (G94) in CAM",
                410 | 411 | 420 | 421 => "cutter radius compensation changes the tool path; post-process with compensation applied in CAM",
                330 | 331 | 760 => "spindle-synchronised motion (threading, rigid tapping, G76) is not supported",
                382..=385 => "probing moves the machine to a position ncsmooth cannot know",
                150 | 160 => "Fanuc-style polar mode is not LinuxCNC's; use the @ and ^ words",
                700..=720 => "lathe roughing cycles (G70-G72) are not supported",
                _ => {
                    return Err(self.err_word(
                        c.word,
                        ParseErrorKind::UnknownWord {
                            word: code_name('G', c.code10),
                        },
                    ))
                }
            };
            return Err(self.unsupported(c, why));
        }
        for &c in &self.mcodes {
            let why: &'static str = match c.code10 {
                470 => "program repeat (M47) changes the motion",
                // A first-word M98 (or a returning M99) is a statement (`fanuc`).
                980 => "M98 calls a subprogram only as the first word of its block (after an N number); LinuxCNC knows it nowhere else",
                990 if !self.flow.calls.is_empty() => "M99 returns from a subprogram only as the first word of its block (LinuxCNC)",
                code if code % 10 != 0 => {
                    return Err(self.err_word(
                        c.word,
                        ParseErrorKind::UnknownWord {
                            word: code_name('M', code),
                        },
                    ))
                }
                _ => continue,
            };
            return Err(self.unsupported(c, why));
        }
        Ok(())
    }

    pub(crate) fn unsupported(&self, c: Code, why: &'static str) -> ParseError {
        let letter = self.words[c.word].letter as char;
        self.err_word(
            c.word,
            ParseErrorKind::Unsupported {
                word: code_name(letter, c.code10),
                why,
            },
        )
    }

    fn feed_mode(&mut self) -> Result<(), ParseError> {
        // G93/G95 were refused; G94 is the only mode.
        Ok(())
    }

    fn feed_rate(&mut self) -> Result<(), ParseError> {
        let Some(f) = self.known_val(b'F')? else {
            return Ok(());
        };
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
        let scale = if self.has_units_change() {
            self.units_of_block_scale()
        } else {
            self.scale()
        };
        self.m.feed_word = Some(f);
        self.m.feed = (f > 0.0).then_some(f * scale / 60.0);
        Ok(())
    }

    /// The block changes the units (G20/G21).
    fn has_units_change(&self) -> bool {
        self.gcode(|c| c == 200 || c == 210).is_some()
    }

    /// Millimetres per unit of the units this block selects (or those in force).
    pub(crate) fn units_of_block_scale(&self) -> f64 {
        match self.gcode(|c| c == 200 || c == 210) {
            Some(c) if c.code10 == 200 => MM_PER_INCH,
            Some(_) => 1.0,
            None => self.scale(),
        }
    }

    /// S, T, M6, M61, spindle and coolant, as events in LinuxCNC's order.
    fn spindle_and_tool(&mut self, printer_m: bool) -> Result<(), ParseError> {
        let spindle_m: Vec<Code> = self
            .mcodes
            .iter()
            .copied()
            .filter(|c| matches!(c.code10, 30 | 40 | 50 | 190))
            .collect();
        let mut m19_words = String::new();
        if self.mcode(|c| c == 190).is_some() {
            // M19: orientation angle R, direction P, timeout Q.
            for l in [b'R', b'P', b'Q'] {
                if let Some(v) = self.known_val(l)? {
                    push_word(&mut m19_words, l, v);
                }
            }
        }
        let spindle_g = self.gcode(|c| c == 960 || c == 970);
        // Spindle: G96/G97, S, M3/M4/M5.
        let takes_s = !printer_m || !spindle_m.is_empty() || spindle_g.is_some();
        let mut text = String::new();
        if let Some(c) = spindle_g {
            push_code(&mut text, 'G', c.code10);
            if c.code10 == 960 {
                if let Some(d) = self.known_val(b'D')? {
                    push_word(&mut text, b'D', d);
                }
            }
        }
        // S alone on a motion block is a value of that block's motion.
        let block_s = spindle_m.is_empty() && spindle_g.is_none() && self.runs_motion();
        if takes_s {
            if let Some(s) = self.known_val(b'S')? {
                if block_s {
                    self.block_speed(s);
                } else {
                    push_word(&mut text, b'S', s);
                }
                self.m.rpm = s;
                self.m.rpm_known = true;
            }
        }
        // S (and G96/G97) before the tool, M3/M4/M5 after M6, as LinuxCNC runs them.
        self.event(EventKind::Spindle, std::mem::take(&mut text));
        let m6 = self.mcode(|c| c == 60);
        let m61 = self.mcode(|c| c == 610);
        // Tool: T, M6, M61 (tool select and change come before the spindle codes).
        let mut tool = String::new();
        if !printer_m || m6.is_some() {
            if let Some(t) = self.known_val(b'T')? {
                push_word(&mut tool, b'T', t);
                self.m.selected_tool = t;
            }
        }
        if m6.is_some() {
            push_code(&mut tool, 'M', 60);
            self.m.tool = self.m.selected_tool;
            if self.opts.machine.is_none() {
                // A tool change may move to a tool-change position ncsmooth cannot know.
                self.f.forget(ALL_AXES);
            }
        }
        if let Some(c) = m61 {
            let q = self.known_val(b'Q')?.ok_or_else(|| {
                self.err_word(
                    c.word,
                    ParseErrorKind::MissingWord {
                        code: "M61".into(),
                        letter: 'Q',
                    },
                )
            })?;
            push_code(&mut tool, 'M', 610);
            push_word(&mut tool, b'Q', q);
            self.m.tool = q;
        }
        self.event(EventKind::Tool, tool);
        for c in &spindle_m {
            push_code(&mut text, 'M', c.code10);
            if c.code10 == 190 && !m19_words.is_empty() {
                text.push(' ');
                text.push_str(&m19_words);
            }
            self.m.spindle = match c.code10 {
                30 => 1,
                40 => -1,
                50 => 0,
                _ => self.m.spindle,
            };
        }
        self.event(EventKind::Spindle, text);
        // Coolant.
        let mut text = String::new();
        for c in self.mcodes.clone() {
            match c.code10 {
                70 => self.m.mist = true,
                80 => self.m.flood = true,
                90 => (self.m.mist, self.m.flood) = (false, false),
                _ => continue,
            }
            push_code(&mut text, 'M', c.code10);
        }
        self.event(EventKind::Coolant, text);
        Ok(())
    }

    /// Whether the block runs a G0-G3 or G5/G5.1 motion (its own code or the modal one,
    /// with words that move).
    fn runs_motion(&self) -> bool {
        matches!(self.block_motion(), 0 | 10 | 20 | 30 | 50 | 51)
            && b"XYZABCUVWEIJKR@^".iter().any(|&l| self.has(l))
    }

    /// `S` on a motion block with nothing else of the spindle: a value of the block
    /// ([`EventKind::SpindleSpeed`], only where it changes), which keeps the line
    /// replaceable.
    fn block_speed(&mut self, s: f64) {
        self.line_block_s = true;
        if self.m.rpm_known && s == self.m.rpm {
            return;
        }
        let mut text = String::new();
        push_word(&mut text, b'S', s);
        self.tp.push_event(Event {
            line: self.line_no,
            kind: EventKind::SpindleSpeed(s),
            text,
        });
    }

    /// Other M codes with their words: overrides (M48-M53), I/O (M62-M68), M70-M73, user
    /// codes (M100-M199) and printer codes. The first standard one takes `P Q` (and `E L`
    /// for M62-M68); the first printer or user code takes `S P Q R T`.
    fn other_m(&mut self, printer_m: bool) -> Result<(), ParseError> {
        let dwell = self.gcode(|c| c == g::DWELL).is_some();
        let g64 = self.gcode(|c| c == 640).is_some();
        // An arc takes P (turns) and R only when the block runs one.
        let arc_motion = matches!(self.block_motion(), 20 | 30)
            && b"XYZABCUVWIJK@^".iter().any(|&l| self.has(l));
        let mut printer_taken = false;
        let mut standard_taken = false;
        let spindle_takes_s = !printer_m
            || self.mcode(|c| matches!(c, 30 | 40 | 50 | 190)).is_some()
            || self.gcode(|c| c == 960 || c == 970).is_some();
        let m6 = self.mcode(|c| c == 60).is_some();
        for c in self.mcodes.clone() {
            if matches!(c.code10, 0..=90 | 190 | 300 | 600 | 610 | 990) {
                continue;
            }
            match c.code10 {
                820 => self.m.e_relative = false,
                830 => self.m.e_relative = true,
                _ => {}
            }
            let mut text = String::new();
            push_code(&mut text, 'M', c.code10);
            let standard = is_standard_m(c.code10);
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
                b"SPQRT"
            };
            for &l in letters {
                let taken_elsewhere = match l {
                    b'S' => spindle_takes_s,
                    b'T' => m6,
                    b'P' | b'Q' => dwell || g64 || (l == b'P' && arc_motion),
                    b'R' => arc_motion,
                    _ => false,
                };
                if !taken_elsewhere {
                    if let Some(v) = self.known_val(l)? {
                        push_word(&mut text, l, v);
                    }
                }
            }
            self.event(EventKind::Other, text);
        }
        Ok(())
    }

    /// The group-1 code this block runs (its own, or the modal one).
    pub(crate) fn block_motion(&self) -> u16 {
        match self.gcode(|c| super::block::g_modal_group(c) == Some(1) || c == 800) {
            Some(c) => c.code10 as u16,
            None => self.m.motion,
        }
    }

    fn dwell(&mut self) -> Result<(), ParseError> {
        if self.gcode(|c| c == g::DWELL).is_none() {
            return Ok(());
        }
        let Some(p) = self.known_val(b'P')? else {
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
        self.canon(|_| crate::canon::Canon::Dwell(p));
        Ok(())
    }

    fn plane_and_units(&mut self) {
        for c in self.gcodes.clone() {
            match c.code10 {
                170 => self.set_plane(Plane::XY),
                180 => self.set_plane(Plane::XZ),
                190 => self.set_plane(Plane::YZ),
                200 | 210 => {
                    let u = if c.code10 == 200 {
                        Units::Inches
                    } else {
                        Units::Millimetres
                    };
                    if !self.stats.units_seen.contains(&u) {
                        self.stats.units_seen.push(u);
                    }
                    if u != self.m.units {
                        // A units change is an event of the controller (and ends a chain).
                        self.event(EventKind::Units(u), code_name('G', c.code10));
                    }
                    self.m.units = u;
                }
                _ => {}
            }
        }
    }

    fn set_plane(&mut self, p: Plane) {
        self.m.plane = p;
        if !self.stats.planes_seen.contains(&p) {
            self.stats.planes_seen.push(p);
        }
    }

    fn cutter_comp(&mut self) -> Result<(), ParseError> {
        if self.gcode(|c| c == 400).is_some() {
            self.event(EventKind::Other, "G40".to_string());
        }
        Ok(())
    }

    /// G43 H, G43.1, G43.2 H, G49: the tool length offset changes, and with it the work
    /// position of the tool tip.
    fn tool_length(&mut self) -> Result<(), ParseError> {
        let Some(c) = self.gcode(|c| matches!(c, 430 | 431 | 432 | 490)) else {
            return Ok(());
        };
        let mut text = code_name('G', c.code10);
        let scale = self.scale();
        match c.code10 {
            430 | 432 => {
                let h = match self.known_val(b'H')? {
                    Some(h) => {
                        push_word(&mut text, b'H', h);
                        h
                    }
                    None if c.code10 == 430 => self.m.tool.max(0.0),
                    None => {
                        return Err(self.err_word(
                            c.word,
                            ParseErrorKind::MissingWord {
                                code: "G43.2".into(),
                                letter: 'H',
                            },
                        ))
                    }
                };
                let entry = self.f.tool_entry(h.round().max(0.0) as u32);
                let t: MaybeAxes = if c.code10 == 430 {
                    entry
                } else {
                    std::array::from_fn(|i| Some(self.f.tool[i]? + entry[i]?))
                };
                self.f.set_tool_offset(t);
                self.m.tlo = true;
            }
            431 => {
                let mut t: MaybeAxes = [Some(0.0); N_AXES];
                for (i, &l) in AXIS_LETTERS.iter().enumerate() {
                    if let Some(v) = self.val(l) {
                        let v = if (3..6).contains(&i) { v } else { v * scale };
                        push_word(&mut text, l, v);
                        t[i] = (!v.is_nan()).then_some(v);
                    }
                }
                self.f.set_tool_offset(t);
                self.m.tlo = true;
            }
            _ => {
                self.f.set_tool_offset([Some(0.0); N_AXES]);
                self.m.tlo = false;
            }
        }
        self.event(EventKind::ToolOffset, text);
        Ok(())
    }

    fn coord_system(&mut self) {
        let Some(c) = self.gcode(|c| (540..=593).contains(&c)) else {
            return;
        };
        let k = match c.code10 {
            540 => 0,
            550 => 1,
            560 => 2,
            570 => 3,
            580 => 4,
            590 => 5,
            591 => 6,
            592 => 7,
            _ => 8,
        };
        self.f.select_system(k);
        self.event(EventKind::Other, code_name('G', c.code10));
    }

    fn path_control(&mut self) {
        let Some(c) = self.gcode(|c| matches!(c, 610 | 611 | 640)) else {
            return;
        };
        let mut text = code_name('G', c.code10);
        self.line_path_mode = true;
        self.m.path = match c.code10 {
            610 => crate::source::PathMode::ExactPath,
            611 => crate::source::PathMode::ExactStop,
            _ => crate::source::PathMode::Blend {
                p_mm: f64::NAN,
                q_mm: f64::NAN,
            },
        };
        if c.code10 == 640 {
            let scale = self.scale();
            let mut pq = [f64::NAN; 2];
            for (k, l) in [b'P', b'Q'].into_iter().enumerate() {
                if let Some(v) = self.val(l) {
                    push_word(&mut text, l, v * scale);
                    pq[k] = v * scale;
                }
            }
            self.m.path = crate::source::PathMode::Blend {
                p_mm: pq[0],
                q_mm: pq[1],
            };
        }
        self.event(EventKind::Other, text);
    }

    fn distance_modes(&mut self) {
        for c in self.gcodes.clone() {
            match c.code10 {
                900 => self.m.absolute = true,
                910 => self.m.absolute = false,
                901 => self.m.arc_absolute = true,
                911 => self.m.arc_absolute = false,
                980 => self.m.retract_r = false,
                990 => self.m.retract_r = true,
                70 => self.m.diameter = true,
                80 => self.m.diameter = false,
                _ => {}
            }
        }
    }

    /// The axis words of the block as machine-independent values (mm, degrees), `None`
    /// where absent; unknown parameter values stay NaN.
    pub(crate) fn axis_words(&mut self) -> MaybeAxes {
        let scale = self.scale();
        let mut v: MaybeAxes = [None; N_AXES];
        for (i, &l) in AXIS_LETTERS.iter().enumerate() {
            if let Some(x) = self.val(l) {
                let x = if i == 0 && self.m.diameter {
                    x / 2.0
                } else {
                    x
                };
                v[i] = Some(if (3..6).contains(&i) { x } else { x * scale });
            }
        }
        v
    }

    /// G10, G28/G30 (and .1), G52, G92 and its variants. G53 is handled with the motion.
    fn non_modal(&mut self) -> Result<(), ParseError> {
        let Some(c) = self.gcode(|c| {
            matches!(
                c,
                g::G10 | g::G28 | g::G28_1 | g::G30 | g::G30_1 | g::G52 | 920..=923
            )
        }) else {
            return Ok(());
        };
        match c.code10 {
            g::G10 => self.g10(c),
            g::G28 | g::G30 => self.go_home(c),
            g::G28_1 | g::G30_1 => {
                let k = usize::from(c.code10 == g::G30_1);
                self.f.home[k] = self.f.machine();
                self.event(EventKind::Other, code_name('G', c.code10));
                Ok(())
            }
            g::G52 => {
                let text = self.block_text(c);
                let v = self.axis_words();
                self.f.g52(&nan_to_none_keep_given(&v));
                for (i, x) in v.iter().enumerate() {
                    if x.is_some_and(f64::is_nan) {
                        self.f.set(i, None);
                    }
                }
                self.event(EventKind::Other, text);
                Ok(())
            }
            g::G92 => self.g92(c),
            g::G92_1 | g::G92_2 => {
                self.f.g92_cancel(c.code10 == g::G92_1);
                self.event(EventKind::Other, code_name('G', c.code10));
                Ok(())
            }
            _ => {
                self.f.g92_restore();
                self.event(EventKind::Other, code_name('G', c.code10));
                Ok(())
            }
        }
    }

    /// The text of a non-modal block for its event: the code and the axis words as written.
    fn block_text(&mut self, c: Code) -> String {
        let mut text = code_name('G', c.code10);
        for &l in b"LPRXYZABCUVWE" {
            if let Some(v) = self.val(l) {
                push_word(&mut text, l, v);
            }
        }
        text
    }

    /// G92: X..W set the current position; E alone resets the extruder (printers).
    fn g92(&mut self, c: Code) -> Result<(), ParseError> {
        let v = self.axis_words();
        let e = if self.takes_e_axis() {
            self.val(b'E')
        } else {
            None
        };
        let any_axis = v.iter().any(|x| x.is_some());
        if !any_axis && e.is_none() {
            return Err(self.err_word(
                c.word,
                ParseErrorKind::MissingWord {
                    code: "G92".into(),
                    letter: 'X',
                },
            ));
        }
        if any_axis {
            // An unknown value makes that axis unknown.
            let given: MaybeAxes = v.map(|x| x.map(|x| if x.is_nan() { f64::NAN } else { x }));
            self.f.g92(&nan_to_none_keep_given(&given));
            for (i, x) in given.iter().enumerate() {
                if x.is_some_and(f64::is_nan) {
                    self.f.set(i, None);
                }
            }
        }
        let mut text = self.block_text(c);
        let mut kind = EventKind::Other;
        if let Some(e) = e {
            let e = e * self.scale();
            self.e = e;
            self.tp.extra_axes_mask |= 1 << 6;
            kind = EventKind::ExtraReset {
                to: self.extra_axes(),
            };
            if !any_axis {
                text = String::from("G92");
                push_word(&mut text, b'E', e);
            }
        }
        // Extra axes given (`G92 A0`) are set to known values: the moves after it start
        // from them (`Move::extra_start` takes an unset axis at the move's own end, which
        // lost a first `G1 X10 A90` rotation: exit 1 on a valid program).
        let extra_given = (3..N_AXES)
            .filter(|&i| v[i].is_some())
            .fold(0u16, |m, i| m | 1 << i);
        if extra_given != 0 {
            self.note_extra_axes(extra_given);
            let in_use = ((self.tp.extra_axes_mask & 0b11_1111) as u16) << 3;
            if kind == EventKind::Other && self.f.all_known(in_use) {
                kind = EventKind::ExtraReset {
                    to: self.extra_axes(),
                };
            }
        }
        self.event(kind, text);
        Ok(())
    }

    /// G10 L1/L10/L11 (tool table) and L2/L20 (coordinate systems).
    fn g10(&mut self, c: Code) -> Result<(), ParseError> {
        let l = self.known_val(b'L')?.ok_or_else(|| {
            self.err_word(
                c.word,
                ParseErrorKind::MissingWord {
                    code: "G10".into(),
                    letter: 'L',
                },
            )
        })?;
        let p = self.known_val(b'P')?;
        let text = self.block_text(c);
        let vals = self.axis_words();
        let vals = nan_to_none_keep_given(&vals);
        let l = l.round() as i64;
        match l {
            2 | 20 => {
                let p = p.unwrap_or(0.0).round() as i64;
                if !(0..=9).contains(&p) {
                    return Err(self.err_word(
                        self.word_of(b'P'),
                        ParseErrorKind::InvalidValue {
                            letter: 'P',
                            value: p as f64,
                            why: "coordinate system number must be 0 to 9",
                        },
                    ));
                }
                let target = if p == 0 {
                    self.f.active
                } else {
                    Some(p as usize - 1)
                };
                if l == 2 {
                    let r = self
                        .val(b'R')
                        .map(|r| if r.is_nan() { f64::NAN } else { r });
                    self.f.g10_l2(target, &vals, r.filter(|r| !r.is_nan()));
                    if r.is_some_and(f64::is_nan) {
                        self.f.forget(0b11);
                    }
                } else {
                    self.f.g10_l20(target, &vals);
                }
            }
            1 | 10 | 11 => {
                let n = p.unwrap_or(0.0).round().max(0.0) as u32;
                let entry = if l == 1 {
                    Some(vals)
                } else {
                    self.f
                        .tool_touch_off(n, &vals, (l == 11).then_some(N_SYSTEMS - 1))
                };
                match entry {
                    Some(e) => self.f.set_tool_entry(n, &e),
                    None => self.f.forget_tools(),
                }
            }
            _ => {
                return Err(self.err_word(
                    self.word_of(b'L'),
                    ParseErrorKind::InvalidValue {
                        letter: 'L',
                        value: l as f64,
                        why: "G10 takes L1, L2, L10, L11 or L20",
                    },
                ))
            }
        }
        self.event(EventKind::Other, text);
        Ok(())
    }

    /// Program stops, after the motion of their block. `M99` in the main program ends it
    /// as `M2` does (see [`super::fanuc`]).
    fn stops(&mut self) {
        for c in self.mcodes.clone() {
            if matches!(c.code10, 0 | 10 | 20 | 300 | 600 | 990) {
                self.event(EventKind::ProgramStop, code_name('M', c.code10));
                if matches!(c.code10, 20 | 300 | 990) {
                    self.canon(|_| crate::canon::Canon::ProgramEnd);
                    self.end_program();
                }
                if c.code10 == 990 {
                    self.main_m99 = true;
                    self.warn(
                        "M99 in the main program: LinuxCNC's task runs the program again from \
                         the top, endlessly (its preview and rs274 stop here); ncsmooth plans \
                         one pass and writes the program as programmed",
                    );
                }
            }
        }
    }

    /// Refuses the parameter words no code of the block uses (LinuxCNC: "R word with no
    /// G code that uses it" and the like), and warns about other unused words.
    fn warn_unused(&mut self) -> Result<(), ParseError> {
        if self.has(b'R')
            && self.gcode(|c| c == 640).is_some()
            && self.mcode(|c| c == 190).is_some()
        {
            return Err(self.err_word(
                self.word_of(b'R'),
                ParseErrorKind::ControlFlow {
                    why: "R word is ambiguous on a line with both G64 and M19; use separate lines"
                        .into(),
                },
            ));
        }
        let unused_slots = self.present & !self.used;
        if unused_slots == 0 {
            return Ok(());
        }
        let mut unused = String::new();
        for (i, &letter) in super::block::SLOT_LETTERS.iter().enumerate() {
            if unused_slots & (1 << i) == 0 {
                continue;
            }
            let w = self.letters[i].unwrap_or(0);
            if super::block::MUST_USE_SLOTS & (1 << i) != 0 {
                return Err(self.err_word(
                    w,
                    ParseErrorKind::UnusedWord {
                        letter: letter as char,
                    },
                ));
            }
            unused.push(letter as char);
        }
        if !unused.is_empty() {
            self.warn(format!("word(s) {unused} unused in this block, ignored"));
        }
        Ok(())
    }

    /// Whether an `E` word of this block is the extruder axis (not an M66-M68 port).
    pub(crate) fn takes_e_axis(&self) -> bool {
        self.mcode(|c| matches!(c, 660 | 670 | 680)).is_none()
    }
}

/// Given values with NaN (unknown) mapped to `None` but still marking the axis as given:
/// callers that need the distinction check the raw words; frames treat `None` as "not
/// given", so an unknown given value is handled by forgetting the axis afterwards.
fn nan_to_none_keep_given(v: &MaybeAxes) -> MaybeAxes {
    v.map(|x| x.filter(|x| !x.is_nan()))
}

/// Named parameters LinuxCNC predefines (read-only), upper case without `_`.
const PREDEFINED: &[&[u8]] = &[
    b"_VMAJOR",
    b"_VMINOR",
    b"_LINE",
    b"_MOTION_MODE",
    b"_PLANE",
    b"_CCOMP",
    b"_METRIC",
    b"_IMPERIAL",
    b"_ABSOLUTE",
    b"_INCREMENTAL",
    b"_INVERSE_TIME",
    b"_UNITS_PER_MINUTE",
    b"_UNITS_PER_REV",
    b"_COORD_SYSTEM",
    b"_TOOL_OFFSET",
    b"_RETRACT_R_PLANE",
    b"_RETRACT_OLD_Z",
    b"_SPINDLE_RPM_MODE",
    b"_SPINDLE_CSS_MODE",
    b"_IJK_ABSOLUTE_MODE",
    b"_LATHE_DIAMETER_MODE",
    b"_LATHE_RADIUS_MODE",
    b"_SPINDLE_ON",
    b"_SPINDLE_CW",
    b"_MIST",
    b"_FLOOD",
    b"_SPEED_OVERRIDE",
    b"_FEED_OVERRIDE",
    b"_ADAPTIVE_FEED",
    b"_FEED_HOLD",
    b"_FEED",
    b"_RPM",
    b"_CURRENT_TOOL",
    b"_CURRENT_POCKET",
    b"_SELECTED_POCKET",
    b"_SELECTED_TOOL",
    b"_X",
    b"_Y",
    b"_Z",
    b"_A",
    b"_B",
    b"_C",
    b"_U",
    b"_V",
    b"_W",
    b"_ABS_X",
    b"_ABS_Y",
    b"_ABS_Z",
    b"_ABS_A",
    b"_ABS_B",
    b"_ABS_C",
    b"_ABS_U",
    b"_ABS_V",
    b"_ABS_W",
    b"_VALUE",
    b"_VALUE_RETURNED",
    b"_TASK",
    b"_CALL_LEVEL",
    b"_REMAP_LEVEL",
    b"_METRIC_MACHINE",
];

/// Whether `name` (upper case) is a predefined read-only parameter.
pub(crate) fn is_predefined(name: &[u8]) -> bool {
    PREDEFINED.contains(&name)
}

fn flag(b: bool) -> f64 {
    if b {
        1.0
    } else {
        0.0
    }
}

/// The value of a predefined named parameter (`None`: not predefined).
pub(crate) fn predefined_param(it: &Interp<'_>, name: &[u8]) -> Option<f64> {
    let m = &it.m;
    let unknown = f64::NAN;
    let axis = |i: usize| it.f.get(i).map_or(unknown, |v| it.prog_units(i, v));
    let abs_axis = |i: usize| it.f.machine()[i].map_or(unknown, |v| it.prog_units(i, v));
    Some(match name {
        b"_VMAJOR" => 2.0,
        b"_VMINOR" => 9.0,
        b"_LINE" => f64::from(it.line_no),
        b"_MOTION_MODE" => f64::from(m.motion),
        b"_PLANE" => match m.plane {
            Plane::XY => 170.0,
            Plane::XZ => 180.0,
            Plane::YZ => 190.0,
        },
        b"_CCOMP" => 400.0,
        b"_METRIC" => flag(m.units == Units::Millimetres),
        b"_IMPERIAL" => flag(m.units == Units::Inches),
        b"_ABSOLUTE" => flag(m.absolute),
        b"_INCREMENTAL" => flag(!m.absolute),
        b"_INVERSE_TIME" | b"_UNITS_PER_REV" => 0.0,
        b"_UNITS_PER_MINUTE" => 1.0,
        b"_COORD_SYSTEM" => match it.f.active {
            Some(k) if k < 6 => 540.0 + 10.0 * k as f64,
            Some(k) => 584.0 + k as f64,
            None => unknown,
        },
        b"_TOOL_OFFSET" => {
            if it.f.tool.iter().all(|t| *t == Some(0.0)) {
                0.0
            } else if it.f.tool.iter().all(Option::is_some) {
                1.0
            } else {
                unknown
            }
        }
        b"_RETRACT_R_PLANE" => flag(m.retract_r),
        b"_RETRACT_OLD_Z" => flag(!m.retract_r),
        b"_SPINDLE_RPM_MODE" => 1.0,
        b"_SPINDLE_CSS_MODE" => 0.0,
        b"_IJK_ABSOLUTE_MODE" => flag(m.arc_absolute),
        b"_LATHE_DIAMETER_MODE" => flag(m.diameter),
        b"_LATHE_RADIUS_MODE" => flag(!m.diameter),
        b"_SPINDLE_ON" => flag(m.spindle != 0),
        b"_SPINDLE_CW" => flag(m.spindle == 1),
        b"_MIST" => flag(m.mist),
        b"_FLOOD" => flag(m.flood),
        b"_SPEED_OVERRIDE" | b"_FEED_OVERRIDE" | b"_ADAPTIVE_FEED" | b"_FEED_HOLD" => unknown,
        b"_FEED" => m.feed_word.unwrap_or(0.0),
        b"_RPM" => m.rpm.abs(),
        b"_CURRENT_TOOL" => m.tool.max(0.0),
        b"_SELECTED_TOOL" => m.selected_tool,
        b"_CURRENT_POCKET" | b"_SELECTED_POCKET" => unknown,
        b"_X" => axis(0),
        b"_Y" => axis(1),
        b"_Z" => axis(2),
        b"_A" => axis(3),
        b"_B" => axis(4),
        b"_C" => axis(5),
        b"_U" => axis(6),
        b"_V" => axis(7),
        b"_W" => axis(8),
        b"_ABS_X" => abs_axis(0),
        b"_ABS_Y" => abs_axis(1),
        b"_ABS_Z" => abs_axis(2),
        b"_ABS_A" => abs_axis(3),
        b"_ABS_B" => abs_axis(4),
        b"_ABS_C" => abs_axis(5),
        b"_ABS_U" => abs_axis(6),
        b"_ABS_V" => abs_axis(7),
        b"_ABS_W" => abs_axis(8),
        b"_VALUE" => m.value,
        b"_VALUE_RETURNED" => flag(m.value_returned),
        b"_TASK" => 0.0,
        b"_CALL_LEVEL" => it.store.depth() as f64,
        b"_REMAP_LEVEL" => 0.0,
        b"_METRIC_MACHINE" => unknown,
        _ => return None,
    })
}

/// The value of a numbered system parameter (`None`: an ordinary parameter).
///
/// `#5161-5169` G28 home, `#5181-5189` G30 home, `#5211-5219` G92 offset, `#5220` the
/// coordinate system number, `#5221-5390` the G54..G59.3 offsets (20 per system, the 10th
/// the XY rotation), `#5400` the tool number, `#5401-5409` the tool offsets,
/// `#5420-5428` the current position. Unknown machine state reads as unknown.
pub(crate) fn system_param(it: &Interp<'_>, index: u32) -> Option<f64> {
    let unknown = f64::NAN;
    let axis_val = |i: usize, v: Option<f64>| v.map_or(unknown, |v| it.prog_units(i, v));
    // Stored parameters are in the machine's units.
    let stored = |i: usize, v: Option<f64>| {
        v.map_or(unknown, |v| {
            if (3..6).contains(&i) {
                v
            } else {
                v / it.f.machine_scale
            }
        })
    };
    let i = index as usize;
    Some(match index {
        5021..=5029 => axis_val(i - 5021, it.f.machine()[i - 5021]),
        5161..=5169 => stored(i - 5161, it.f.home[0][i - 5161]),
        5181..=5189 => stored(i - 5181, it.f.home[1][i - 5181]),
        5210 => it.f.g92_applied.map_or(unknown, flag),
        5211..=5219 => stored(i - 5211, it.f.g92_saved[i - 5211]),
        5220 => it.f.active.map_or(unknown, |k| (k + 1) as f64),
        5221..=5390 => {
            let k = (i - 5221) / 20;
            let a = (i - 5221) % 20;
            if k >= N_SYSTEMS {
                return None;
            }
            match a {
                0..=8 => stored(a, it.f.g5x_of(k, a)),
                9 => it.f.rotation_of(k).unwrap_or(unknown),
                _ => return None,
            }
        }
        5399 => unknown,
        5400 => it.m.tool.max(0.0),
        // The table entry of the tool in the spindle.
        5401..=5409 => {
            let t = it.m.tool.max(0.0) as u32;
            axis_val(i - 5401, it.f.tool_entry(t)[i - 5401])
        }
        5420..=5428 => axis_val(i - 5420, it.f.get(i - 5420)),
        _ => return None,
    })
}
