//! Canned cycles: G73, G74, G81, G82, G83, G84, G85, G86, G87, G88 and G89, expanded
//! into the moves LinuxCNC's interpreter makes for them (`interp_cycles.cc`:
//! `convert_cycle`, `convert_cycle_xy`/`_yz`/`_zx`, the `CYCLE_MACRO` of
//! `interp_internal.hh` and one `convert_cycle_g8x` per code; user documentation: "Canned
//! Cycles" in LinuxCNC's G-code reference). G76 (threading) stays refused.
//!
//! # Axes
//!
//! The drilling axis is the normal of the active plane: Z under G17, Y under G18, X
//! under G19. The other two are the plane's axes, in LinuxCNC's order (X Y, Z X, Y Z):
//! written `a` and `b` below, the drilling axis `n`. Its word (Z, Y or X) gives the
//! bottom of the hole. A, B, C (and U, V, W, E) words are refused in a cycle block
//! ("Cannot put an A in canned cycle"). Polar words (`@` radius, `^` angle in degrees,
//! G17 only) place the hole as LinuxCNC's `convert_cycle_xy` does: under G90 about the
//! origin (a missing word from the current point's radius or angle); under G91 they are
//! increments of the radius and then of the angle, applied at every repeat after the X
//! and Y increments (an error at the origin).
//!
//! # Levels and repeats
//!
//! * `R` is the retract plane; `old` is the drilling-axis position when the first block of
//!   a run of cycles started (LinuxCNC's `cycle_il`: kept until a motion that is not a
//!   cycle runs). Under G90 `R` and the bottom are absolute; under G91 `R` is added to
//!   `old` and the bottom to `R`, and the plane words are increments applied once per
//!   repeat.
//! * The bottom above `R` is an error ("R less than Z in cycle").
//! * When `old` is below `R`, the block starts with a rapid of the drilling axis alone to
//!   `R`, and `old` counts as `R` for this block.
//! * The clearance level is `R` under G99 and `old` under G98.
//! * `L` repeats the cycle (default 1; 0, negative and non-integer values are errors; as
//!   in LinuxCNC 2.9, G74 takes no `L`).
//!   Each repeat first moves to the hole: on the first repeat, if the drilling axis is
//!   above `R`, a rapid to the hole at the current level and then down to `R`; otherwise a
//!   rapid to the hole at the clearance level, then down to `R` if that is above it.
//! * Afterwards LinuxCNC takes the tool to be at the hole, at the clearance level.
//!
//! `R`, the bottom, `P`, `Q` (and G87's `I J K`) are sticky: a block may leave them out
//! when the previous block ran the same cycle code (R and the bottom must be given when the
//! code changes, P for G82/G86/G88/G89, Q for G73/G83, I J K for G87). LinuxCNC keeps one
//! store for all cycle codes (`cycle_r`, `cycle_cc`, `cycle_p`, `cycle_q`, `cycle_i`...):
//! G84's optional dwell takes the last P of any cycle, 0 at first. As in LinuxCNC a `P` or
//! `Q` of exactly -1 counts as absent (its reader's "no value" sentinel). The values are
//! kept as programmed (program units, increments under G91).
//!
//! # The cycles (after the move to `R`)
//!
//! * G81: feed to the bottom, rapid to the clearance level.
//! * G82: the same with a dwell of `P` seconds at the bottom.
//! * G83: pecks of `Q`: feed `Q` deeper, rapid out to `R`, rapid back down to
//!   [`PECK_CLEARANCE_INCH`] above the depth reached; then the last feed to the bottom and
//!   the rapid to the clearance level.
//! * G73: the same but the retract between pecks is only the peck clearance.
//! * G84 (G74): right-hand (left-hand) tapping: feed to the bottom, spindle stop, spindle
//!   reversed, dwell `P` (0 by default), feed to the clearance level, spindle stop, the
//!   original direction again. The spindle must turn clockwise (G74: counter-clockwise).
//! * G85: feed to the bottom and back to `R`, rapid to the clearance level.
//! * G86: feed to the bottom, dwell, spindle stop, rapid to the clearance level, spindle
//!   restarted.
//! * G87 (back boring): rapid to the hole offset by the plane words `I J` (G18: `K I`,
//!   G19: `J K`) at `R`, spindle stop and orientation, rapid down to the bottom, rapid
//!   to the hole, spindle start, feed up to `K` (G18 `J`, G19 `I`: absolute under G90,
//!   above the bottom under G91) and back down, spindle stop and orientation, rapid to the
//!   offset point, up to the clearance level, back over the hole, spindle start.
//! * G88: feed to the bottom, dwell, spindle stop, program stop (the operator retracts the
//!   spindle by hand), spindle start. The drilling axis is unknown afterwards.
//! * G89: feed to the bottom, dwell, feed to the clearance level.
//!
//! G86, G87 and G88 need the spindle turning. LinuxCNC 2.9 (the version of the standalone
//! `rs274` the conformance tests compare with) feeds G84/G74 in the G18 and G19 planes to
//! points whose coordinates are permuted (its `convert_cycle_g74_g84` passes the plane
//! coordinates to `cycle_feed` in the wrong order): under G19 the feeds go to
//! (X, Y, Z) = (`b`, level, `a`), under G18 to (level, `a`, `b`). ncsmooth makes the same
//! moves; since LinuxCNC's interpreter then believes the tool is at the hole, not where
//! it is, X, Y and Z are unknown after such a block, and the next moves from there are
//! kept as programmed.
//!
//! The peck clearance is LinuxCNC 2.9's constant (`G83_RAPID_DELTA`, `G73_RETRACT`):
//! 0.010 inch, in the program's units. (LinuxCNC 2.10 reads it from the INI file and a D
//! word; 2.9 refuses D in a cycle, and so does ncsmooth.) A negative dwell, which LinuxCNC
//! passes on, is refused as it is for G4.
//!
//! # Output
//!
//! Every rapid and feed of a cycle is a [`Move`], always
//! [`pinned`](ncsmooth::path::Move::pinned): cycles are exact stops, never smoothed, and
//! their lines are written back verbatim. Dwells, spindle stops and starts, orientations
//! and G88's stop are events between the moves (their text is the G-code a controller
//! without cycles would run). When a position the cycle needs is unknown (the drilling
//! axis never established, the plane axes after an offset change), the whole block is
//! one [`EventKind::Untracked`] event, and afterwards each axis is known if its final value
//! (hole position, clearance level) can be computed without the unknown.
//!
//! LinuxCNC keeps positions in program units; ncsmooth keeps millimetres. For inch
//! programs a position is converted back and rounded to [`INCH_SNAP`] inch so that a
//! position programmed as a decimal compares with `R` and the bottom exactly as LinuxCNC
//! compares them.

use super::block::code_name;
use super::frames::{bit, AXIS_LETTERS};
use super::Interp;
use crate::canon::Canon;
use crate::error::{ParseError, ParseErrorKind};
use crate::source::Plane;
use ncsmooth::geom::{Line, Vec3};
use ncsmooth::path::{EventKind, Move, Units};

/// LinuxCNC 2.9's `G83_RAPID_DELTA` and `G73_RETRACT`: how far above the depth reached a
/// G83 rapid returns, and how far a G73 retracts between pecks (inch, converted to the
/// program's units).
pub const PECK_CLEARANCE_INCH: f64 = 0.010;
/// The value LinuxCNC's reader stores for an absent `P` or `Q` (so a programmed -1 counts
/// as absent).
const ABSENT_PQ: f64 = -1.0;
/// LinuxCNC's `read_integer_value`: a value within this of an integer is that integer.
const INTEGER_TOLERANCE: f64 = 1e-4;
/// Grid (inch) to which an inch position converted back from millimetres is rounded.
pub(crate) const INCH_SNAP: f64 = 1e-10;
/// Positions beyond this magnitude (program units) are not rounded (the grid would lose
/// precision).
const SNAP_LIMIT: f64 = 1e5;
/// Most moves and events one cycle block may expand into (a tiny `Q` or a huge `L` would
/// otherwise exhaust memory).
pub(crate) const MAX_CYCLE_STEPS: usize = 100_000;

/// Whether motion code `m` (tenths) is a canned cycle.
pub(crate) fn is_cycle(m: u16) -> bool {
    matches!(m, 730 | 740 | 810..=890)
}

/// The values LinuxCNC keeps from one cycle block to the next (see the module doc).
#[derive(Clone, Debug, Default)]
pub(crate) struct CycleMemory {
    /// Last `R` (program units, as programmed).
    pub r: f64,
    /// Last bottom word (program units, as programmed).
    pub bottom: f64,
    /// Last `P`.
    pub p: f64,
    /// Last `Q`.
    pub q: f64,
    /// Last G87 `I`, `J`, `K`; G5 stores the negation of its `P Q` in `I J` (LinuxCNC
    /// shares the store).
    pub ijk: [f64; 3],
    /// The initial level of the run of cycles (mm): `None` before the first block of a
    /// run, `Some(None)` when it was unknown.
    pub initial: Option<Option<f64>>,
}

/// A coordinate or level: program units (for LinuxCNC's comparisons), millimetres (for
/// the geometry), and whether it is known.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Lv {
    p: f64,
    mm: f64,
    known: bool,
}

impl Lv {
    fn word(p: f64, scale: f64) -> Lv {
        Lv {
            p,
            mm: p * scale,
            known: p.is_finite(),
        }
    }
    /// `self + d` (program units).
    fn plus(self, d: f64, scale: f64) -> Lv {
        let p = self.p + d;
        Lv {
            p,
            mm: p * scale,
            known: self.known && d.is_finite(),
        }
    }
}

/// The axes of the active plane for a cycle.
#[derive(Clone, Copy, Debug)]
struct CyclePlane {
    /// Indices of the plane's first and second axes and of the drilling axis.
    a: usize,
    b: usize,
    n: usize,
    /// G87's offset letters for `a` and `b`, and its letter for the top of the bore.
    off: [u8; 3],
    name: &'static str,
    plane: Plane,
}

impl CyclePlane {
    fn of(p: Plane) -> CyclePlane {
        match p {
            Plane::XY => CyclePlane {
                a: 0,
                b: 1,
                n: 2,
                off: *b"IJK",
                name: "XY",
                plane: p,
            },
            Plane::XZ => CyclePlane {
                a: 2,
                b: 0,
                n: 1,
                off: *b"KIJ",
                name: "XZ",
                plane: p,
            },
            Plane::YZ => CyclePlane {
                a: 1,
                b: 2,
                n: 0,
                off: *b"JKI",
                name: "YZ",
                plane: p,
            },
        }
    }
    fn n_letter(&self) -> u8 {
        AXIS_LETTERS[self.n]
    }
}

/// One step of an expanded cycle.
#[derive(Clone, Debug)]
enum Step {
    /// A rapid (`true`) or feed to a point (X Y Z).
    Go(bool, [Lv; 3]),
    Dwell(f64),
    Event(EventKind, &'static str),
}

/// The expansion of one cycle block.
struct Sim {
    pl: CyclePlane,
    scale: f64,
    /// Position (X Y Z) after the steps so far.
    pos: [Lv; 3],
    steps: Vec<Step>,
}

impl Sim {
    fn push(&mut self, s: Step) -> Result<(), &'static str> {
        if self.steps.len() >= MAX_CYCLE_STEPS {
            return Err("the cycle expands to too many moves (check Q and L)");
        }
        self.steps.push(s);
        Ok(())
    }
    /// A point from plane coordinates.
    fn point(&self, a: Lv, b: Lv, n: Lv) -> [Lv; 3] {
        let mut p = self.pos;
        p[self.pl.a] = a;
        p[self.pl.b] = b;
        p[self.pl.n] = n;
        p
    }
    fn go(&mut self, rapid: bool, p: [Lv; 3]) -> Result<(), &'static str> {
        self.pos = p;
        self.push(Step::Go(rapid, p))
    }
    fn traverse(&mut self, a: Lv, b: Lv, n: Lv) -> Result<(), &'static str> {
        self.go(true, self.point(a, b, n))
    }
    fn feed(&mut self, a: Lv, b: Lv, n: Lv) -> Result<(), &'static str> {
        self.go(false, self.point(a, b, n))
    }
    /// LinuxCNC 2.9's G84/G74 feed (see the module doc).
    fn tap_feed(&mut self, a: Lv, b: Lv, n: Lv) -> Result<(), &'static str> {
        let p = match self.pl.plane {
            Plane::XY => [a, b, n],
            Plane::YZ => [b, n, a],
            Plane::XZ => [n, a, b],
        };
        self.go(false, p)
    }
    fn event(&mut self, kind: EventKind, text: &'static str) -> Result<(), &'static str> {
        self.push(Step::Event(kind, text))
    }
}

/// Spindle start text for a direction (1 clockwise, -1 counter-clockwise).
fn spindle_start(dir: i8) -> &'static str {
    if dir > 0 {
        "M3"
    } else {
        "M4"
    }
}

impl Interp<'_> {
    fn cycle_err(&self, code10: u16, why: impl Into<String>) -> ParseError {
        self.err_line(ParseErrorKind::InvalidMotion {
            code: code_name('G', u32::from(code10)),
            why: why.into(),
        })
    }

    fn cycle_word_err(&self, code10: u16, l: u8, why: impl Into<String>) -> ParseError {
        self.err_word(
            self.word_of(l),
            ParseErrorKind::InvalidMotion {
                code: code_name('G', u32::from(code10)),
                why: why.into(),
            },
        )
    }

    /// A word in program units (X halved under G7), NaN when it depends on unknown state.
    fn prog_word(&mut self, l: u8) -> Option<f64> {
        let v = self.val(l)?;
        Some(if l == b'X' && self.m.diameter {
            v / 2.0
        } else {
            v
        })
    }

    /// The current position of axis `i` as a cycle level.
    fn cycle_pos(&self, i: usize) -> Lv {
        let scale = self.scale();
        let mm = self.f.pos[i];
        Lv {
            p: to_program(mm, scale),
            mm,
            known: self.f.known & bit(i) != 0,
        }
    }

    /// Runs canned cycle `code10` for this block; `prev` is the motion mode before it.
    pub(crate) fn cycle(&mut self, code10: u16, prev: u16) -> Result<(), ParseError> {
        self.line_pinned = true;
        let pl = CyclePlane::of(self.m.plane);
        let scale = self.scale();
        let same = prev == code10;
        // Words a cycle cannot take.
        for l in *b"ABCUVWE" {
            if self.has(l) && (l != b'E' || self.takes_e_axis()) {
                return Err(self.cycle_word_err(
                    code10,
                    l,
                    format!("cannot put {} word in a canned cycle", l as char),
                ));
            }
        }
        let polar = self.cycle_polar(code10)?;
        if self.m.feed.is_none() {
            return Err(self.err_line(ParseErrorKind::NoFeedRate));
        }
        let r_word = match self.known_val(b'R')? {
            Some(r) => r,
            None if same => self.m.cycle.r,
            None => {
                return Err(self.cycle_err(code10, "R clearance plane unspecified in cycle"));
            }
        };
        let repeats = self.cycle_repeats(code10)?;
        let n_letter = pl.n_letter();
        let bottom_word = match self.known_val(n_letter)? {
            Some(v) if n_letter == b'X' && self.m.diameter => v / 2.0,
            Some(v) => v,
            None if same => self.m.cycle.bottom,
            None => {
                return Err(self.cycle_word_err(
                    code10,
                    n_letter,
                    format!(
                        "{} value unspecified in {} plane canned cycle",
                        n_letter as char, pl.name
                    ),
                ));
            }
        };
        // The per-code words (checked before any motion, as far as they are errors).
        let p = self.cycle_p(code10, same)?;
        let q = self.cycle_q(code10, same)?;
        let ijk = self.cycle_ijk(code10, same, &pl)?;
        let spindle = self.m.spindle;
        self.cycle_spindle_check(code10, spindle)?;

        // Levels.
        let cur = [self.cycle_pos(0), self.cycle_pos(1), self.cycle_pos(2)];
        let initial = self.cycle_initial(cur[pl.n], scale);
        let (mut aa, mut bb, r, bottom, inc) =
            self.cycle_levels(&pl, cur, polar, (initial, r_word, bottom_word), scale);
        if r.p < bottom.p {
            return Err(self.cycle_err(
                code10,
                format!(
                    "R less than {} in cycle in {} plane",
                    n_letter as char, pl.name
                ),
            ));
        }
        let mut sim = Sim {
            pl,
            scale,
            pos: cur,
            steps: Vec::new(),
        };
        let mut old = initial;
        let mut current_n = cur[pl.n];
        let mut decided = initial.known && r.known;
        if old.p < r.p {
            // Below the R plane: straight up to it first.
            let to = sim.point(cur[pl.a], cur[pl.b], r);
            sim.go(true, to).map_err(|e| self.cycle_err(code10, e))?;
            old = r;
            current_n = r;
        }
        if !decided {
            old.known = false;
        }
        let clear = if self.m.retract_r { r } else { old };
        let middle = ijk.map(|[_, _, k]| {
            if self.m.absolute {
                Lv::word(k, scale)
            } else {
                bottom.plus(k, scale)
            }
        });
        let peck = PECK_CLEARANCE_INCH
            * match self.m.units {
                Units::Inches => 1.0,
                Units::Millimetres => super::MM_PER_INCH,
            };
        let cyc = Cycle {
            code10,
            r,
            bottom,
            clear,
            middle,
            dwell: p.unwrap_or(0.0),
            q: q.unwrap_or(1.0),
            peck,
            offsets: ijk.map_or((0.0, 0.0), |[i, j, _]| (i, j)),
            dir: spindle,
        };
        for rep in 0..repeats {
            aa = aa.plus(inc.a, scale);
            bb = bb.plus(inc.b, scale);
            (aa, bb) = inc
                .polar(aa, bb, scale)
                .map_err(|e| self.cycle_err(code10, e))?;
            decided &= current_n.known && r.known && clear.known;
            let mut repeat = || -> Result<(), &'static str> {
                if rep == 0 && current_n.p > r.p {
                    sim.traverse(aa, bb, current_n)?;
                    sim.traverse(aa, bb, r)?;
                } else {
                    sim.traverse(aa, bb, clear)?;
                    if clear.p > r.p {
                        sim.traverse(aa, bb, r)?;
                    }
                }
                sim.body(&cyc, aa, bb)
            };
            repeat().map_err(|e| self.cycle_err(code10, e))?;
        }
        // Record what was used.
        self.m.cycle.r = r_word;
        self.m.cycle.bottom = bottom_word;
        if let Some(p) = p {
            self.m.cycle.p = p;
        }
        if let Some(q) = q {
            self.m.cycle.q = q;
        }
        if let Some(v) = ijk {
            self.m.cycle.ijk = v;
        }
        self.emit_cycle(code10, &sim, cur, decided, [aa, bb, clear]);
        Ok(())
    }

    /// Errors when the spindle does not turn as canned cycle `code10` needs.
    fn cycle_spindle_check(&self, code10: u16, spindle: i8) -> Result<(), ParseError> {
        match (code10, spindle) {
            (840, 0) | (740, 0) => {
                return Err(self.cycle_err(code10, "spindle not turning"));
            }
            (840, -1) => {
                return Err(self.cycle_err(code10, "spindle turning counterclockwise in G84"));
            }
            (740, 1) => {
                return Err(self.cycle_err(code10, "spindle turning clockwise in G74"));
            }
            (860..=880, 0) => {
                return Err(self.cycle_err(code10, "spindle not turning"));
            }
            _ => {}
        }
        Ok(())
    }

    /// The initial level of the cycles (the drilling axis where the first of them started,
    /// recorded then from `cur_n`, the current level).
    fn cycle_initial(&mut self, cur_n: Lv, scale: f64) -> Lv {
        match self.m.cycle.initial {
            Some(Some(mm)) => Lv {
                p: to_program(mm, scale),
                mm,
                known: true,
            },
            Some(None) => Lv {
                known: false,
                ..cur_n
            },
            None => {
                let v = cur_n;
                self.m.cycle.initial = Some(v.known.then_some(v.mm));
                v
            }
        }
    }

    /// The cycle's position in the plane, its R and bottom levels and the increments of
    /// each repeat, from the words (`polar`, the R and bottom words) and the current
    /// position `cur`.
    fn cycle_levels(
        &mut self,
        pl: &CyclePlane,
        cur: [Lv; 3],
        polar: Option<PolarWords>,
        (initial, r_word, bottom_word): (Lv, f64, f64),
        scale: f64,
    ) -> (Lv, Lv, Lv, Lv, Increments) {
        if self.m.absolute {
            let aa = match self.prog_word(AXIS_LETTERS[pl.a]) {
                Some(v) => Lv::word(v, scale),
                None => cur[pl.a],
            };
            let bb = match self.prog_word(AXIS_LETTERS[pl.b]) {
                Some(v) => Lv::word(v, scale),
                None => cur[pl.b],
            };
            // Polar words (G17 only): about the origin, a missing one from the current
            // point's radius or angle.
            let (aa, bb) = match polar {
                Some((radius, theta)) => {
                    let (x, y) = (cur[0], cur[1]);
                    let r = radius.unwrap_or_else(|| y.p.hypot(x.p));
                    let th = theta.unwrap_or_else(|| y.p.atan2(x.p));
                    let known = x.known && y.known || radius.is_some() && theta.is_some();
                    let (a, b) = (Lv::word(r * th.cos(), scale), Lv::word(r * th.sin(), scale));
                    (
                        Lv {
                            known: a.known && known,
                            ..a
                        },
                        Lv {
                            known: b.known && known,
                            ..b
                        },
                    )
                }
                None => (aa, bb),
            };
            let r = Lv::word(r_word, scale);
            (
                aa,
                bb,
                r,
                Lv::word(bottom_word, scale),
                Increments::default(),
            )
        } else {
            let (radius, theta) = polar.unwrap_or((None, None));
            let inc = Increments {
                a: self.prog_word(AXIS_LETTERS[pl.a]).unwrap_or(0.0),
                b: self.prog_word(AXIS_LETTERS[pl.b]).unwrap_or(0.0),
                radius: radius.unwrap_or(0.0),
                theta_rad: theta.unwrap_or(0.0),
            };
            let r = initial.plus(r_word, scale);
            let bottom = r.plus(bottom_word, scale);
            (cur[pl.a], cur[pl.b], r, bottom, inc)
        }
    }

    /// The polar words of a cycle block, `(@ in program units, ^ in rad)`, if it has any:
    /// under G17 only, and without X or Y (LinuxCNC's `enhance_block`).
    fn cycle_polar(&mut self, code10: u16) -> Result<Option<PolarWords>, ParseError> {
        if !(self.has(b'@') || self.has(b'^')) {
            return Ok(None);
        }
        if self.m.plane != Plane::XY {
            return Err(self.cycle_err(
                code10,
                "cannot use polar coordinates except in the G17 plane",
            ));
        }
        if self.has(b'X') || self.has(b'Y') {
            return Err(
                self.cycle_err(code10, "cannot specify X or Y words with polar coordinates")
            );
        }
        let radius = self.known_val(b'@')?;
        let theta = self.known_val(b'^')?.map(f64::to_radians);
        Ok(Some((radius, theta)))
    }

    /// `L`: the number of repeats.
    fn cycle_repeats(&mut self, code10: u16) -> Result<u32, ParseError> {
        let Some(l) = self.known_val(b'L')? else {
            return Ok(1);
        };
        let bad = |it: &Self, why: &'static str| {
            it.err_word(
                it.word_of(b'L'),
                ParseErrorKind::InvalidValue {
                    letter: 'L',
                    value: l,
                    why,
                },
            )
        };
        if l < 0.0 {
            return Err(bad(self, "negative L word used"));
        }
        if code10 == 740 {
            // LinuxCNC 2.9's check of L words leaves G74 out of the canned cycles.
            return Err(bad(self, "L word with no canned cycle that uses it (G74)"));
        }
        let n = l.round();
        if (l - n).abs() > INTEGER_TOLERANCE {
            return Err(bad(self, "L must be an integer"));
        }
        if n == 0.0 {
            return Err(bad(self, "cannot do zero repeats of a canned cycle"));
        }
        if n > MAX_CYCLE_STEPS as f64 {
            return Err(bad(self, "too many repeats"));
        }
        Ok(n as u32)
    }

    /// The dwell `P` of cycles that take one (`None` for the others).
    fn cycle_p(&mut self, code10: u16, same: bool) -> Result<Option<f64>, ParseError> {
        let needs = matches!(code10, 820 | 860 | 880 | 890);
        if !needs && !matches!(code10, 740 | 840) {
            return Ok(None);
        }
        let p = match self.known_val(b'P')? {
            Some(p) if p != ABSENT_PQ => p,
            _ if needs && !same => {
                return Err(self.cycle_err(code10, "dwell time P word missing"));
            }
            _ => self.m.cycle.p,
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
        Ok(Some(p))
    }

    /// The peck `Q` of G73 and G83.
    fn cycle_q(&mut self, code10: u16, same: bool) -> Result<Option<f64>, ParseError> {
        if !matches!(code10, 730 | 830) {
            return Ok(None);
        }
        let q = match self.known_val(b'Q')? {
            Some(q) if q != ABSENT_PQ => q,
            _ if !same => {
                return Err(self.cycle_err(code10, "Q word missing"));
            }
            _ => self.m.cycle.q,
        };
        if q <= 0.0 {
            return Err(self.err_word(
                self.word_of(b'Q'),
                ParseErrorKind::InvalidValue {
                    letter: 'Q',
                    value: q,
                    why: "negative or zero Q value used",
                },
            ));
        }
        Ok(Some(q))
    }

    /// G87's offsets and bore top, as `[a offset, b offset, top]` (program units).
    fn cycle_ijk(
        &mut self,
        code10: u16,
        same: bool,
        pl: &CyclePlane,
    ) -> Result<Option<[f64; 3]>, ParseError> {
        if code10 != 870 {
            return Ok(None);
        }
        let mut by_letter = self.m.cycle.ijk;
        for (k, l) in [b'I', b'J', b'K'].into_iter().enumerate() {
            match self.known_val(l)? {
                Some(v) => by_letter[k] = v,
                None if !same => {
                    return Err(
                        self.cycle_err(code10, format!("{} word missing with G87", l as char))
                    );
                }
                None => {}
            }
        }
        let get = |l: u8| by_letter[usize::from(l - b'I')];
        self.m.cycle.ijk = by_letter;
        // A G5 without I J now takes these, not the last G5's P Q.
        self.m.last_g5 = None;
        Ok(Some([get(pl.off[0]), get(pl.off[1]), get(pl.off[2])]))
    }

    /// Emits the expanded cycle: moves and events when everything is known, else one
    /// untracked event; then the position LinuxCNC assumes afterwards.
    fn emit_cycle(
        &mut self,
        code10: u16,
        sim: &Sim,
        start: [Lv; 3],
        decided: bool,
        [aa, bb, clear]: [Lv; 3],
    ) {
        let pl = sim.pl;
        let tracked = decided
            && start.iter().all(|v| v.known)
            && sim.steps.iter().all(|s| match s {
                Step::Go(_, p) => p.iter().all(|v| v.known),
                _ => true,
            });
        let mut prev = Vec3::new(start[0].mm, start[1].mm, start[2].mm);
        for s in &sim.steps {
            match *s {
                Step::Go(rapid, p) => {
                    for (i, v) in p.iter().enumerate() {
                        self.f.pos[i] = v.mm;
                    }
                    let end = Vec3::new(p[0].mm, p[1].mm, p[2].mm);
                    let prog = [p[0].p, p[1].p, p[2].p];
                    self.canon(|it| {
                        let mut end = it.canon_pos();
                        end[..3].copy_from_slice(&prog);
                        if rapid {
                            Canon::Traverse { end }
                        } else {
                            Canon::Feed { end }
                        }
                    });
                    // A move to where the tool is (a repeat in place) is no motion.
                    if tracked && end != prev {
                        let seg = Line::new(prev, end);
                        let mut mv = if rapid {
                            Move::rapid(seg, self.line_no)
                        } else {
                            Move::feed(seg, self.m.feed, self.line_no)
                        };
                        mv.pinned = true;
                        if self.tp.extra_axes_mask != 0 {
                            mv.extra = Some(self.extra_axes());
                        }
                        self.tp.push_move(mv);
                    }
                    prev = end;
                }
                Step::Dwell(t) => {
                    self.canon(|_| Canon::Dwell(t));
                    if tracked {
                        let mut text = String::from("G4");
                        super::block::push_word(&mut text, b'P', t);
                        self.event(EventKind::Dwell(t), text);
                    }
                }
                Step::Event(ref kind, text) => {
                    if tracked {
                        self.event(kind.clone(), text.to_string());
                    }
                }
            }
        }
        if !tracked {
            self.untracked("a canned cycle from or to a position not established in this frame");
        }
        // Where LinuxCNC's interpreter takes the tool to be.
        for (i, v) in [(pl.a, aa), (pl.b, bb), (pl.n, clear)] {
            self.f.pos[i] = v.mm;
            self.f.set(i, v.known.then_some(v.mm));
        }
        if code10 == 880 {
            // The operator retracted the spindle by hand.
            self.f.forget(bit(pl.n));
        }
        if matches!(code10, 740 | 840) && pl.plane != Plane::XY {
            // LinuxCNC 2.9's permuted tapping feed: the tool is not where LinuxCNC assumes.
            self.f.forget(0b111);
        }
    }
}

/// What the cycle of a block does over each hole.
#[derive(Clone, Copy, Debug)]
struct Cycle {
    code10: u16,
    /// Retract plane, bottom and clearance levels.
    r: Lv,
    bottom: Lv,
    clear: Lv,
    /// G87's top of the back bore.
    middle: Option<Lv>,
    /// Dwell at the bottom (s).
    dwell: f64,
    /// Peck depth (G73, G83) and clearance (program units).
    q: f64,
    peck: f64,
    /// G87's offsets of the way down along the plane axes (program units).
    offsets: (f64, f64),
    /// Spindle direction at the start (1 clockwise, -1 counter-clockwise).
    dir: i8,
}

/// A cycle block's polar words: `@` (program units) and `^` (rad), each if given.
type PolarWords = (Option<f64>, Option<f64>);

/// Plane increments of an incremental block: of the plane's axes, then of the radius and
/// the angle about the origin (polar words, G17 only), applied in that order at every
/// repeat (LinuxCNC's `CYCLE_MACRO`).
#[derive(Clone, Copy, Debug, Default)]
struct Increments {
    a: f64,
    b: f64,
    /// `@` (program units).
    radius: f64,
    /// `^` (rad).
    theta_rad: f64,
}

impl Increments {
    /// The hole after the polar increments, from `(aa, bb)` (program units): the radius
    /// grows by `radius`, then the point turns by `theta_rad` about the origin.
    fn polar(&self, aa: Lv, bb: Lv, scale: f64) -> Result<(Lv, Lv), &'static str> {
        let (mut a, mut b) = (aa, bb);
        for (dr, dt) in [(self.radius, 0.0), (0.0, self.theta_rad)] {
            if dr == 0.0 && dt == 0.0 {
                continue;
            }
            if a.p == 0.0 && b.p == 0.0 {
                return Err(
                    "incremental motion with polar coordinates is indeterminate when at the origin",
                );
            }
            let (r, th) = (b.p.hypot(a.p) + dr, b.p.atan2(a.p) + dt);
            let known = a.known && b.known;
            a = Lv {
                known,
                ..Lv::word(r * th.cos(), scale)
            };
            b = Lv {
                known,
                ..Lv::word(r * th.sin(), scale)
            };
        }
        Ok((a, b))
    }
}

/// A millimetre position in program units (see the module doc).
fn to_program(mm: f64, scale: f64) -> f64 {
    if scale == 1.0 {
        return mm;
    }
    let p = mm / scale;
    if p.abs() < SNAP_LIMIT {
        (p / INCH_SNAP).round() * INCH_SNAP
    } else {
        p
    }
}

impl Sim {
    /// The cycle proper, from the R plane over the hole (LinuxCNC's `convert_cycle_g8x`).
    fn body(&mut self, cyc: &Cycle, aa: Lv, bb: Lv) -> Result<(), &'static str> {
        let sim = self;
        let Cycle {
            r,
            bottom,
            clear,
            middle,
            dwell,
            q,
            peck,
            dir,
            ..
        } = *cyc;
        let scale = sim.scale;
        match cyc.code10 {
            810 => {
                sim.feed(aa, bb, bottom)?;
                sim.traverse(aa, bb, clear)?;
            }
            820 => {
                sim.feed(aa, bb, bottom)?;
                sim.push(Step::Dwell(dwell))?;
                sim.traverse(aa, bb, clear)?;
            }
            730 | 830 => {
                let mut depth = r.plus(-q, scale);
                while depth.p > bottom.p {
                    sim.feed(aa, bb, depth)?;
                    if cyc.code10 == 830 {
                        sim.traverse(aa, bb, r)?;
                    }
                    sim.traverse(aa, bb, depth.plus(peck, scale))?;
                    depth = depth.plus(-q, scale);
                }
                sim.feed(aa, bb, bottom)?;
                sim.traverse(aa, bb, clear)?;
            }
            740 | 840 => {
                let (reverse, back) = if cyc.code10 == 840 {
                    ("M4", "M3")
                } else {
                    ("M3", "M4")
                };
                sim.tap_feed(aa, bb, bottom)?;
                sim.event(EventKind::Spindle, "M5")?;
                sim.event(EventKind::Spindle, reverse)?;
                sim.push(Step::Dwell(dwell))?;
                sim.tap_feed(aa, bb, clear)?;
                sim.event(EventKind::Spindle, "M5")?;
                sim.event(EventKind::Spindle, back)?;
            }
            850 => {
                sim.feed(aa, bb, bottom)?;
                sim.feed(aa, bb, r)?;
                sim.traverse(aa, bb, clear)?;
            }
            860 => {
                sim.feed(aa, bb, bottom)?;
                sim.push(Step::Dwell(dwell))?;
                sim.event(EventKind::Spindle, "M5")?;
                sim.traverse(aa, bb, clear)?;
                sim.event(EventKind::Spindle, spindle_start(dir))?;
            }
            870 => {
                let (i, j) = cyc.offsets;
                let middle = middle.unwrap_or(bottom);
                let (oa, ob) = (aa.plus(i, scale), bb.plus(j, scale));
                sim.traverse(oa, ob, r)?;
                sim.event(EventKind::Spindle, "M5")?;
                sim.event(EventKind::Spindle, "M19 R0")?;
                sim.traverse(oa, ob, bottom)?;
                sim.traverse(aa, bb, bottom)?;
                sim.event(EventKind::Spindle, spindle_start(dir))?;
                sim.feed(aa, bb, middle)?;
                sim.feed(aa, bb, bottom)?;
                sim.event(EventKind::Spindle, "M5")?;
                sim.event(EventKind::Spindle, "M19 R0")?;
                sim.traverse(oa, ob, bottom)?;
                sim.traverse(oa, ob, clear)?;
                sim.traverse(aa, bb, clear)?;
                sim.event(EventKind::Spindle, spindle_start(dir))?;
            }
            880 => {
                sim.feed(aa, bb, bottom)?;
                sim.push(Step::Dwell(dwell))?;
                sim.event(EventKind::Spindle, "M5")?;
                sim.event(EventKind::ProgramStop, "M0")?;
                sim.event(EventKind::Spindle, spindle_start(dir))?;
            }
            _ => {
                // 890
                sim.feed(aa, bb, bottom)?;
                sim.push(Step::Dwell(dwell))?;
                sim.feed(aa, bb, clear)?;
            }
        }
        Ok(())
    }
}
