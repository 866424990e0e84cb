//! Motion: G0/G1 lines, G2/G3 arcs (any plane, helical, multi-turn, I/J/K or R, full
//! circles with no axis word), polar words, G53 moves, G28/G30 returns; dispatch to the
//! canned cycles (`super::cycles`) and splines (`super::splines`).
//!
//! # Targets and what is known
//!
//! An axis word gives the target of its axis: absolute (G90, and always under G53) or added
//! to the current position (G91); the other axes stay. Polar words (`@` radius, `^` angle
//! in degrees) give X and Y as LinuxCNC's `find_ends` does: about the origin under G90, by
//! changing the current point's radius and angle about the origin under G91. Under G7 X
//! words are diameters. A move is placed ([`Move`]) when every axis it commands is known at
//! its start and at its end; an arc also needs both axes of its plane known. Otherwise it
//! is an [`EventKind::Untracked`] event and its commanded axes are known afterwards only
//! when their targets are.
//!
//! # Arcs
//!
//! Centre format (LinuxCNC's `arc_data_ijk`): the centre is the start plus I/J/K (or I/J/K
//! themselves under G90.1); radii below [`RADIUS_TOLERANCE_MM`] are an error, and start
//! and end radii may differ by at most LinuxCNC's rule (`README.arc-radius-tolerance` of
//! its interpreter tests): with `t_abs` = 2 x 0.01 mm x sqrt(2) (metric) or 2 x 0.001 inch
//! x sqrt(2) (imperial) and `t_rel` = 0.001, an arc fails when `|r1 - r2| > 100 t_abs`, or
//! when `|r1 - r2| > t_abs` and `|r1 - r2| / max(r1, r2) > t_rel`. Within it the arc is
//! LinuxCNC's spiral about the programmed centre, its radius linear in the angle from
//! `r1` to `r2` ([`Arc::from_center_spiral`], [`Arc::spiral`]).
//!
//! Radius format (`arc_data_r`): a negative R takes the long way; a chord longer than the
//! diameter by more than [`RADIUS_TOLERANCE_MM`] (0.00005 inch in inch programs) is an
//! error, within it (or within 1e-12 relative) a semicircle.
//!
//! `P` is the number of turns (P1, the default, is one); a centre-format arc whose end is
//! its start, or with no axis word at all, is a full circle.

use super::block::{push_word, SLOT_AT, SLOT_CARET};
use super::cycles::is_cycle;
use super::frames::{bit, Axes, AXIS_LETTERS, N_AXES};
use super::modal::MOTION_NONE;
use super::{axes_vec, Interp, MM_PER_INCH};
use crate::canon::Canon;
use crate::error::{ParseError, ParseErrorKind};
use crate::source::Plane;
use ncsmooth::geom::{Arc, Line, Vec3};
use ncsmooth::path::{EventKind, ExtraAxes, Move, MoveKind, Units, E_AXIS};

/// Largest position an axis may reach (mm, or degrees for A B C): 1000 km, where an f64
/// still resolves 1.2e-7 mm. Beyond it a position cannot carry the micrometre-level
/// geometry of smoothing and verification, and the program is refused.
pub(crate) const MAX_COORDINATE: f64 = 1e9;

/// LinuxCNC's `RADIUS_TOLERANCE_INCH`: the smallest arc radius, and the slack of an R
/// arc's chord over its diameter (inch).
pub const RADIUS_TOLERANCE_INCH: f64 = 0.00005;
/// The same in mm (LinuxCNC's `RADIUS_TOLERANCE_MM`).
pub const RADIUS_TOLERANCE_MM: f64 = RADIUS_TOLERANCE_INCH * MM_PER_INCH;
/// LinuxCNC's `CENTER_ARC_RADIUS_TOLERANCE_INCH`: absolute start/end radius difference
/// allowed in inch programs (inch).
pub const CENTER_ARC_RADIUS_TOLERANCE_INCH: f64 = 2.0 * 0.001 * std::f64::consts::SQRT_2;
/// LinuxCNC's `CENTER_ARC_RADIUS_TOLERANCE_MM` (mm).
pub const CENTER_ARC_RADIUS_TOLERANCE_MM: f64 = 2.0 * 0.01 * std::f64::consts::SQRT_2;
/// LinuxCNC's `SPIRAL_RELATIVE_TOLERANCE`.
pub const SPIRAL_RELATIVE_TOLERANCE: f64 = 0.001;
/// LinuxCNC's `TINY` of `arc_data_r`: a chord within this share of the diameter is a
/// semicircle.
const SEMICIRCLE_TINY: f64 = 1e-12;

/// Where a move goes.
pub(crate) struct Target {
    /// Target of every axis (placeholder where unknown).
    pub pos: Axes,
    /// Bit set when the target of the axis is known.
    pub known: u16,
    /// Bit set when the target of the axis is known only relative to a placeholder start
    /// (an increment from a position known that way, or from an unknown one).
    pub relative: u16,
    /// Axes the block commands.
    pub commanded: u16,
}

impl Interp<'_> {
    /// The motion of the block, after every other group.
    pub(crate) fn motion_block(&mut self) -> Result<(), ParseError> {
        let prev = self.m.motion;
        let g80 = self.gcode(|c| c == 800).is_some();
        if g80 {
            self.m.motion = MOTION_NONE;
            self.event(EventKind::Other, "G80".to_string());
        }
        let explicit = self.gcode(|c| super::block::g_modal_group(c) == Some(1));
        if let Some(c) = explicit {
            self.m.motion = c.code10 as u16;
        }
        // G10, G28, G30, G52 and G92 use the axis words themselves.
        if self
            .gcode(|c| matches!(c, 100 | 280 | 300 | 520 | 920))
            .is_some()
        {
            return Ok(());
        }
        let g53 = self.gcode(|c| c == 530).is_some();
        let e_axis = self.takes_e_axis() && self.has(b'E');
        let any_axis =
            AXIS_LETTERS.iter().any(|&l| self.has(l)) || self.has(b'@') || self.has(b'^') || e_axis;
        let motion = self.m.motion;
        if (explicit.is_some() || g80 || any_axis) && !is_cycle(motion) {
            // A motion that is not a cycle ends a run of cycles (LinuxCNC's cycle_il_flag).
            self.m.cycle.initial = None;
        }
        if matches!(motion, 52 | 53) && (explicit.is_some() || any_axis) {
            self.line_modal_motion = explicit.is_none();
            // NURBS blocks may have no axis word; they are pinned (see `splines`).
            self.pin_next = false;
            let r = self.spline(motion, prev);
            if self.lb.block_delete {
                self.pin_next = true;
            }
            return r;
        }
        self.drop_unfinished_nurbs(any_axis || explicit.is_some() || g80);
        let arc_words = self.has(b'I') || self.has(b'J') || self.has(b'K');
        if !any_axis {
            if explicit.is_some() && (is_cycle(motion) || matches!(motion, 50 | 51)) {
                // LinuxCNC: "All axes missing with motion code".
                return Err(self.err_line(ParseErrorKind::InvalidMotion {
                    code: super::block::code_name('G', u32::from(motion)),
                    why: "all axes missing with a motion code".into(),
                }));
            }
            if matches!(motion, 20 | 30) && arc_words && !self.has(b'R') {
                // A full circle with no axis word (LinuxCNC accepts it).
                self.line_modal_motion = explicit.is_none();
                return self.arc(motion == 30);
            }
            if matches!(motion, 20 | 30) && self.has(b'R') {
                return Err(self.err_line(ParseErrorKind::ArcNoAxes));
            }
            if g53 {
                return Err(self.err_line(ParseErrorKind::MissingWord {
                    code: "G53".into(),
                    letter: 'X',
                }));
            }
            return Ok(());
        }
        if g53 {
            // G53 is absolute whatever the distance mode (LinuxCNC's find_ends).
            if !matches!(motion, 0 | 10) {
                return Err(self.err_line(ParseErrorKind::Unsupported {
                    word: "G53".into(),
                    why: "G53 is only allowed with G0 or G1",
                }));
            }
        }
        if self.pin_next {
            self.line_pinned = true;
            self.pin_next = false;
        }
        self.line_modal_motion = explicit.is_none();
        let r = match motion {
            MOTION_NONE => Err(self.err_line(ParseErrorKind::NoMotionMode)),
            0 | 10 => self.straight(motion == 0, g53),
            20 | 30 => self.arc(motion == 30),
            50 | 51 => self.spline(motion, prev),
            730 | 740 | 810..=890 => self.cycle(motion, prev),
            _ => Err(self.err_line(ParseErrorKind::NoMotionMode)),
        };
        if self.lb.block_delete {
            // Whether this motion runs depends on the block-delete switch: the next move
            // may not be smoothed into it.
            self.pin_next = true;
        }
        r
    }

    /// The X/Y targets of polar words (`@` radius, `^` angle), if the block has any.
    fn polar(&mut self, cur: (Option<f64>, Option<f64>)) -> Result<Option<(f64, f64)>, ParseError> {
        let (r, a) = (self.val(b'@'), self.val(b'^'));
        if r.is_none() && a.is_none() {
            return Ok(None);
        }
        if self.has(b'X') || self.has(b'Y') {
            return Err(self.err_word(
                self.letters[SLOT_AT]
                    .or(self.letters[SLOT_CARET])
                    .unwrap_or(0),
                ParseErrorKind::ControlFlow {
                    why: "cannot specify X or Y words with polar coordinates".into(),
                },
            ));
        }
        let scale = self.scale();
        let r = r.map(|r| r * scale);
        let (Some(px), Some(py)) = cur else {
            // Relative to an unknown point: unknown unless both words are absolute.
            return Ok(match (self.m.absolute, r, a) {
                (true, Some(r), Some(a)) => Some(polar_xy(r, a.to_radians())),
                _ => Some((f64::NAN, f64::NAN)),
            });
        };
        let at_origin = px == 0.0 && py == 0.0;
        let need_angle = |it: &Self| {
            it.err_line(ParseErrorKind::ControlFlow {
                why: "polar coordinates at the origin need an angle (^)".into(),
            })
        };
        let xy = if self.m.absolute {
            match (r, a) {
                (Some(r), Some(a)) => polar_xy(r, a.to_radians()),
                (Some(r), None) => {
                    if at_origin {
                        return Err(need_angle(self));
                    }
                    polar_xy(r, py.atan2(px))
                }
                (None, Some(a)) => polar_xy(py.hypot(px), a.to_radians()),
                (None, None) => unreachable!(),
            }
        } else {
            if at_origin {
                return Err(need_angle(self));
            }
            let radius = py.hypot(px) + r.unwrap_or(0.0);
            let theta = py.atan2(px) + a.unwrap_or(0.0).to_radians();
            polar_xy(radius, theta)
        };
        Ok(Some(xy))
    }

    /// The target of the block's axis words (G53: machine coordinates).
    pub(crate) fn target(&mut self, g53: bool) -> Result<Target, ParseError> {
        let words = self.axis_words();
        let mut t = Target {
            pos: self.f.pos,
            known: self.f.known,
            relative: self.f.relative,
            commanded: 0,
        };
        if g53 {
            let mut m = self.f.machine();
            for i in 0..N_AXES {
                if let Some(v) = words[i] {
                    m[i] = (!v.is_nan()).then_some(v);
                    t.commanded |= bit(i);
                }
            }
            let saved = (self.f.pos, self.f.known, self.f.relative);
            self.f.set_from_machine(&m, t.commanded);
            t.pos = self.f.pos;
            t.known = (self.f.known & t.commanded) | (saved.1 & !t.commanded);
            t.relative = saved.2 & !t.commanded;
            (self.f.pos, self.f.known, self.f.relative) = saved;
            return self.in_range(t);
        }
        for i in 0..N_AXES {
            let Some(v) = words[i] else { continue };
            t.commanded |= bit(i);
            if !self.m.absolute && self.f.get(i).is_none() {
                // An increment from a position known relatively, or from an unknown one
                // (which it starts knowing so: X Y Z only, see `Frames::relative`).
                let from = self.f.get_relative(i).or((i < 3).then_some(self.f.pos[i]));
                set_relative_target(&mut t, i, from.map(|p| p + v));
                continue;
            }
            let v = if self.m.absolute {
                Some(v)
            } else {
                self.f.get(i).map(|p| p + v)
            };
            set_target(&mut t, i, v);
        }
        if let Some((x, y)) = self.polar((self.f.get(0), self.f.get(1)))? {
            t.commanded |= 0b11;
            set_target(&mut t, 0, Some(x));
            set_target(&mut t, 1, Some(y));
        }
        self.in_range(t)
    }

    /// `t`, when every axis it commands is within [`MAX_COORDINATE`] (else an error at
    /// the axis's word).
    fn in_range(&self, t: Target) -> Result<Target, ParseError> {
        for i in 0..N_AXES {
            let known = (t.known | t.relative) & bit(i) != 0;
            if t.commanded & bit(i) != 0 && known && t.pos[i].abs() > MAX_COORDINATE {
                let letter = AXIS_LETTERS[i];
                let w = if self.has(letter) {
                    self.word_of(letter)
                } else {
                    self.letters[SLOT_AT]
                        .or(self.letters[SLOT_CARET])
                        .unwrap_or(0)
                };
                return Err(self.err_word(
                    w,
                    ParseErrorKind::CoordinateRange {
                        letter: letter as char,
                        value: t.pos[i],
                        max: MAX_COORDINATE,
                    },
                ));
            }
        }
        Ok(t)
    }

    /// The E target (printers), if the block moves the extruder.
    fn e_target(&mut self) -> Option<f64> {
        if !self.takes_e_axis() {
            return None;
        }
        let v = self.val(b'E')? * self.scale();
        self.tp.extra_axes_mask |= 1 << E_AXIS;
        Some(if self.m.e_relative || !self.m.absolute {
            self.e + v
        } else {
            v
        })
    }

    /// The extra axes (A B C U V W E) as the path model stores them.
    pub(crate) fn extra_axes(&self) -> ExtraAxes {
        let p = &self.f.pos;
        [p[3], p[4], p[5], p[6], p[7], p[8], self.e]
    }

    /// Marks the extra axes the block uses.
    pub(super) fn note_extra_axes(&mut self, commanded: u16) {
        for i in 3..N_AXES {
            if commanded & bit(i) != 0 {
                self.tp.extra_axes_mask |= 1 << (i - 3);
            }
        }
    }

    /// Whether a move with target `t` can be placed: every commanded axis known at the
    /// start and at the end, plus `also` known at the start.
    fn trackable(&self, t: &Target, also: u16) -> bool {
        let need = t.commanded | also;
        // Known, or known relatively on both ends (an axis never changes between the two
        // within a move: its offset is not known).
        let before = self.f.known | self.f.relative;
        let after = t.known | t.relative;
        before & need == need && after & need == need && self.f.relative & need == t.relative & need
    }

    /// Moves the state to `t` (the commanded axes take their targets, known or not).
    fn go_to(&mut self, t: &Target) {
        for i in 0..N_AXES {
            if t.commanded & bit(i) != 0 {
                if t.relative & bit(i) != 0 {
                    self.f.set_relative(i, t.pos[i]);
                } else if t.known & bit(i) != 0 {
                    self.f.set(i, Some(t.pos[i]));
                } else {
                    self.f.set(i, None);
                }
            }
        }
    }

    /// A motion ncsmooth cannot place: kept as an event (written as programmed), with the
    /// extra axes after it where they are known (call it once the state has moved).
    pub(crate) fn untracked(&mut self, why: &str) {
        let mut text = self.raw.trim().to_string();
        if text.is_empty() {
            text = why.to_string();
        }
        self.stats.untracked += 1;
        if self.stats.untracked_first.is_none() {
            self.stats.untracked_first = Some((self.line_no, why.to_string()));
        }
        let extra_known = self
            .f
            .all_known(((self.tp.extra_axes_mask & 0b11_1111) as u16) << 3);
        let extra = (self.tp.extra_axes_mask != 0 && extra_known).then(|| self.extra_axes());
        self.event(EventKind::Untracked { extra }, text);
    }

    /// G0/G1 (and G53 G0/G1).
    fn straight(&mut self, rapid: bool, g53: bool) -> Result<(), ParseError> {
        let t = self.target(g53)?;
        let e = self.e_target();
        self.note_extra_axes(t.commanded);
        let xyz = t.commanded & 0b111 != 0;
        let feed = if rapid { None } else { self.m.feed };
        if !rapid && self.m.feed.is_none() {
            return Err(self.err_line(ParseErrorKind::NoFeedRate));
        }
        if xyz {
            if rapid {
                self.stats.g0 += 1;
            } else {
                self.stats.g1 += 1;
            }
        }
        if !self.trackable(&t, 0) {
            let why = if g53 {
                "a G53 move to machine coordinates (offsets unknown)"
            } else {
                "a move from or to a position not established in this frame"
            };
            self.go_to(&t);
            if let Some(e) = e {
                self.e = e;
            }
            self.untracked(why);
            // What LinuxCNC prints: its interpreter's idea of the target (the placeholders
            // of unknown axes are that idea after a cycle it runs differently).
            self.canon(|it| {
                let end = it.canon_pos();
                if rapid {
                    Canon::Traverse { end }
                } else {
                    Canon::Feed { end }
                }
            });
            return Ok(());
        }
        if !xyz {
            return self.extra_move(rapid, &t, e);
        }
        let start = axes_vec(&self.f.pos);
        let end = axes_vec(&t.pos);
        let line = self.line_no;
        let seg = Line::new(start, end);
        let mut mv = if rapid {
            Move::rapid(seg, line)
        } else {
            Move::feed(seg, feed, line)
        };
        if start == end {
            self.stats.zero_length_moves += 1;
            self.warn("zero-length move");
        }
        mv.pinned = g53;
        self.go_to(&t);
        if let Some(e) = e {
            self.e = e;
        }
        if self.tp.extra_axes_mask != 0 {
            mv.extra = Some(self.extra_axes());
        }
        self.canon(|it| {
            let end = it.canon_pos();
            if rapid {
                Canon::Traverse { end }
            } else {
                Canon::Feed { end }
            }
        });
        self.tp.push_move(mv);
        Ok(())
    }

    /// A move of extra axes only (X, Y, Z at rest): an event with the canonical text.
    fn extra_move(&mut self, rapid: bool, t: &Target, e: Option<f64>) -> Result<(), ParseError> {
        let before = self.extra_axes();
        self.go_to(t);
        if let Some(e) = e {
            self.e = e;
        }
        let extra = self.extra_axes();
        let mut text = String::from(if rapid { "G0" } else { "G1" });
        for (i, &name) in ncsmooth::path::EXTRA_AXIS_NAMES.iter().enumerate() {
            let l = name as u8;
            let given = if i == E_AXIS {
                e.is_some()
            } else {
                t.commanded & bit(i + 3) != 0
            };
            if given {
                push_word(&mut text, l, extra[i]);
            }
        }
        if !rapid {
            if let (true, Some(f)) = (self.has(b'F'), self.m.feed) {
                push_word(&mut text, b'F', f * 60.0);
            }
        }
        // The feed is stored in mm/s, the rate of linear extra axes (stored in mm too);
        // rotary-only moves run at the programmed degrees per minute.
        let linear = (3..extra.len()).any(|i| extra[i] != before[i]);
        let feed_per_s = match (rapid, linear) {
            (true, _) => None,
            (false, true) => self.m.feed,
            (false, false) => self.m.feed.map(|f| f / self.scale()),
        };
        self.canon(|it| {
            let end = it.canon_pos();
            if rapid {
                Canon::Traverse { end }
            } else {
                Canon::Feed { end }
            }
        });
        self.event(
            EventKind::ExtraMove {
                to: extra,
                feed_per_s,
            },
            text,
        );
        Ok(())
    }

    /// The current position in program units (A B C in degrees), for canonical output.
    pub(crate) fn canon_pos(&self) -> [f64; N_AXES] {
        std::array::from_fn(|i| self.prog_units(i, self.f.pos[i]))
    }

    /// G2/G3.
    fn arc(&mut self, ccw: bool) -> Result<(), ParseError> {
        let (a, b, n, la, lb, ln) = plane_axes(self.m.plane);
        let t = self.target(false)?;
        self.note_extra_axes(t.commanded);
        let e = self.e_target();
        let turns = self.arc_turns()?;
        if self.has(ln) {
            // LinuxCNC: "K word given for arc in XY plane" (and likewise I, J).
            return Err(self.err_word(
                self.word_of(ln),
                ParseErrorKind::Unsupported {
                    word: format!("{} on a {} arc", ln as char, plane_code(self.m.plane)),
                    why: "it is not a centre offset of the active plane",
                },
            ));
        }
        let plane_axes = bit(a) | bit(b);
        if self.m.feed.is_none() {
            return Err(self.err_line(ParseErrorKind::NoFeedRate));
        }
        if ccw {
            self.stats.g3 += 1;
        } else {
            self.stats.g2 += 1;
        }
        // Absolute centres (G90.1) are not placed on axes known only relatively.
        let centre_unplaced =
            self.m.arc_absolute && (self.f.relative | t.relative) & plane_axes != 0;
        if !self.trackable(&t, plane_axes) || centre_unplaced {
            // Consume the centre words so they are not reported unused.
            for l in [la, lb, b'R'] {
                let _ = self.val(l);
            }
            self.go_to(&t);
            if let Some(e) = e {
                self.e = e;
            }
            self.untracked("an arc from or to a position not established in this frame");
            return Ok(());
        }
        let start = axes_vec(&self.f.pos);
        let end = axes_vec(&t.pos);
        let center = self.arc_center(start, end, (a, b), (la, lb), ccw, turns)?;
        let arc = Arc::from_center_spiral(start, end, center, n, ccw, turns)
            .ok_or_else(|| self.err_line(ParseErrorKind::ArcDegenerate { why: "zero radius" }))?;
        let mut mv = Move::feed(arc, self.m.feed, self.line_no);
        self.go_to(&t);
        if let Some(e) = e {
            self.e = e;
        }
        if self.tp.extra_axes_mask != 0 {
            mv.extra = Some(self.extra_axes());
        }
        self.canon(|it| Canon::Arc {
            end: it.canon_pos(),
            center: [
                it.prog_units(a, vget(center, a)),
                it.prog_units(b, vget(center, b)),
            ],
            turn: if ccw {
                turns as i32 + 1
            } else {
                -(turns as i32 + 1)
            },
        });
        self.tp.push_move(mv);
        Ok(())
    }

    /// `P` turns of an arc, as extra full turns (P1 = 0).
    fn arc_turns(&mut self) -> Result<u32, ParseError> {
        match self.val(b'P') {
            None => Ok(0),
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
                Ok(r as u32 - 1)
            }
        }
    }

    /// The centre of a G2/G3 arc from its I/J/K or R words (LinuxCNC's rules, see the
    /// module doc).
    fn arc_center(
        &mut self,
        start: Vec3,
        end: Vec3,
        (a, b): (usize, usize),
        (la, lb): (u8, u8),
        ccw: bool,
        turns: u32,
    ) -> Result<Vec3, ParseError> {
        let scale = self.scale();
        let inch = self.m.units == Units::Inches;
        let radius_tol = if inch {
            RADIUS_TOLERANCE_INCH * MM_PER_INCH
        } else {
            RADIUS_TOLERANCE_MM
        };
        let has_centre = self.has(la) || self.has(lb);
        let r_word = self.known_val(b'R')?;
        let (pa, pb) = (vget(start, a), vget(start, b));
        let (ea, eb) = (vget(end, a), vget(end, b));
        let (ca, cb) = match (r_word, has_centre) {
            (Some(_), true) => return Err(self.err_line(ParseErrorKind::ArcMixedFormat)),
            (None, false) => return Err(self.err_line(ParseErrorKind::ArcNoCentre)),
            (None, true) => {
                let ia = self.known_val(la)?.map(|v| v * scale);
                let ib = self.known_val(lb)?.map(|v| v * scale);
                if self.m.arc_absolute {
                    for (l, v) in [(la, ia), (lb, ib)] {
                        if v.is_none() {
                            return Err(self.err_line(ParseErrorKind::MissingWord {
                                code: "an arc under G90.1".into(),
                                letter: l as char,
                            }));
                        }
                    }
                }
                let (ca, cb) = if self.m.arc_absolute {
                    (ia.unwrap_or(pa), ib.unwrap_or(pb))
                } else {
                    (pa + ia.unwrap_or(0.0), pb + ib.unwrap_or(0.0))
                };
                let r_start = (pa - ca).hypot(pb - cb);
                let r_end = (ea - ca).hypot(eb - cb);
                if !r_start.is_finite() || !r_end.is_finite() {
                    return Err(self.err_line(ParseErrorKind::OutOfRange));
                }
                if r_start < radius_tol || r_end < radius_tol {
                    return Err(self.err_line(ParseErrorKind::ArcDegenerate {
                        why: "zero-radius arc",
                    }));
                }
                if radius_mismatch(r_start, r_end, inch) {
                    return Err(self.err_line(ParseErrorKind::ArcRadiusMismatch { r_start, r_end }));
                }
                (ca, cb)
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
                let mut half = chord / 2.0;
                if half - rad > radius_tol {
                    return Err(
                        self.err_line(ParseErrorKind::ArcRadiusTooSmall { radius: rad, chord })
                    );
                }
                if half / rad > 1.0 - SEMICIRCLE_TINY {
                    half = rad;
                }
                let h = (rad * rad - half * half).max(0.0).sqrt();
                // Left normal of the chord in the plane: (-db, da). CCW short arcs have
                // their centre on the left.
                let side = if ccw == (r_mm > 0.0) { 1.0 } else { -1.0 };
                let (ua, ub) = (da / chord, db / chord);
                (pa + da / 2.0 - ub * h * side, pb + db / 2.0 + ua * h * side)
            }
        };
        let _ = turns;
        let mut c = start;
        vset(&mut c, a, ca);
        vset(&mut c, b, cb);
        if !c.is_finite() {
            return Err(self.err_line(ParseErrorKind::OutOfRange));
        }
        Ok(c)
    }

    /// G28/G30: an optional rapid through the given axes' intermediate point (work
    /// coordinates), then those axes (all, when none is given) to the stored position.
    pub(crate) fn go_home(&mut self, c: super::block::Code) -> Result<(), ParseError> {
        let k = usize::from(c.code10 == 300);
        let text = {
            let mut t = super::block::code_name('G', c.code10);
            for &l in AXIS_LETTERS.iter() {
                if let Some(v) = self.letters[super::block::slot(l)].map(|w| self.words[w].value) {
                    push_word(&mut t, l, v);
                }
            }
            t
        };
        let t = self.target(false)?;
        let mask = if t.commanded == 0 {
            super::frames::ALL_AXES
        } else {
            t.commanded
        };
        if t.commanded == 0 {
            // LinuxCNC still moves "through" the current point.
            self.canon(|it| Canon::Traverse {
                end: it.canon_pos(),
            });
        } else {
            if self.trackable(&t, 0) {
                let start = axes_vec(&self.f.pos);
                let mut mv = Move::rapid(Line::new(start, axes_vec(&t.pos)), self.line_no);
                mv.pinned = true;
                self.go_to(&t);
                if self.tp.extra_axes_mask != 0 {
                    mv.extra = Some(self.extra_axes());
                }
                self.canon(|it| Canon::Traverse {
                    end: it.canon_pos(),
                });
                if mv.kind == MoveKind::Rapid {
                    self.tp.push_move(mv);
                }
            } else {
                self.go_to(&t);
                self.untracked("the intermediate point of a G28/G30 from an unknown position");
            }
        }
        // The return itself: to the stored machine position.
        let mut m = self.f.machine();
        for i in 0..N_AXES {
            if mask & bit(i) != 0 {
                m[i] = self.f.home[k][i];
            }
        }
        let before = self.f.known;
        let start = axes_vec(&self.f.pos);
        self.f.set_from_machine(&m, mask);
        let home_known = self.f.all_known(mask) && before & mask == mask;
        if home_known {
            let mut mv = Move::rapid(Line::new(start, axes_vec(&self.f.pos)), self.line_no);
            mv.pinned = true;
            if self.tp.extra_axes_mask != 0 {
                mv.extra = Some(self.extra_axes());
            }
            self.canon(|it| Canon::Traverse {
                end: it.canon_pos(),
            });
            self.tp.push_move(mv);
        } else {
            self.untracked("a G28/G30 return to a home position ncsmooth cannot know");
            self.warn(format!(
                "G{} moves the machine to its stored position; the position afterwards is unknown until commanded",
                if k == 0 { 28 } else { 30 }
            ));
        }
        self.event(EventKind::Other, text);
        Ok(())
    }
}

fn set_target(t: &mut Target, i: usize, v: Option<f64>) {
    t.relative &= !bit(i);
    match v {
        Some(x) if x.is_finite() => {
            t.pos[i] = x;
            t.known |= bit(i);
        }
        _ => t.known &= !bit(i),
    }
}

/// Sets the target of axis `i` to `v` relative to its placeholder start (unknown when
/// `None`).
fn set_relative_target(t: &mut Target, i: usize, v: Option<f64>) {
    t.known &= !bit(i);
    match v {
        Some(x) if x.is_finite() => {
            t.pos[i] = x;
            t.relative |= bit(i);
        }
        _ => t.relative &= !bit(i),
    }
}

fn polar_xy(r: f64, theta: f64) -> (f64, f64) {
    let (s, c) = theta.sin_cos();
    (r * c, r * s)
}

/// Whether LinuxCNC refuses a centre-format arc with radii `r1` and `r2` (mm).
pub fn radius_mismatch(r1: f64, r2: f64, inch: bool) -> bool {
    let t_abs = if inch {
        CENTER_ARC_RADIUS_TOLERANCE_INCH * MM_PER_INCH
    } else {
        CENTER_ARC_RADIUS_TOLERANCE_MM
    };
    let abs_err = (r1 - r2).abs();
    let rel_err = abs_err / r1.max(r2);
    abs_err > 100.0 * t_abs || (rel_err > SPIRAL_RELATIVE_TOLERANCE && abs_err > t_abs)
}

/// (first in-plane axis, second in-plane axis, normal, their centre letters).
pub(crate) fn plane_axes(p: Plane) -> (usize, usize, Vec3, u8, u8, u8) {
    match p {
        Plane::XY => (0, 1, Vec3::Z, b'I', b'J', b'K'),
        Plane::XZ => (2, 0, Vec3::Y, b'K', b'I', b'J'),
        Plane::YZ => (1, 2, Vec3::X, b'J', b'K', b'I'),
    }
}

pub(crate) fn plane_code(p: Plane) -> &'static str {
    match p {
        Plane::XY => "G17",
        Plane::XZ => "G18",
        Plane::YZ => "G19",
    }
}

pub(crate) fn vget(v: Vec3, i: usize) -> f64 {
    match i {
        0 => v.x,
        1 => v.y,
        _ => v.z,
    }
}

pub(crate) fn vset(v: &mut Vec3, i: usize, x: f64) {
    match i {
        0 => v.x = x,
        1 => v.y = x,
        _ => v.z = x,
    }
}
