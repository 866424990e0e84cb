//! Splines: G5 (cubic Bézier), G5.1 (quadratic B-spline) and G5.2/G5.3 (NURBS), as
//! LinuxCNC 2.9's interpreter reads them (`convert_spline` and `convert_nurbs` in
//! `interp_convert.cc`, the knot vector of `nurbs_G5_knot_vector_creator` in
//! `nurbs_additional_functions.cc`; user documentation: G5, G5.1, G5.2 in LinuxCNC's
//! G-code reference). All are feed moves in the XY plane at the current Z: a spline block
//! outside G17 is an error ("Splines must be in the XY plane"), and so is a Z, A, B or C
//! word on a G5/G5.1 ("Splines may not have motion in Z, A, B, or C"; ncsmooth refuses
//! U, V, W and E there too).
//!
//! # G5: cubic Bézier
//!
//! `G5 X Y I J P Q`: from the current point `P0` to the end `P3` (X Y, absolute or
//! incremental), with the first control point `P0 + (I, J)` and the second `P3 + (P, Q)`.
//! `P` and `Q` are required; `I` and `J` go together. Without them the first control
//! point is `P0` plus the offset LinuxCNC stored last: the negation of the previous G5's
//! `P Q`, which after a G5 makes the curve leave in the direction the previous one
//! arrived (tangent continuity). LinuxCNC keeps that offset in the store G87 uses for its
//! `I J` and does not check that a G5 came just before; neither does ncsmooth (it warns).
//! The move is a [`Segment::CubicBez`](ncsmooth::geom::Segment::CubicBez) with exactly
//! those control points. A G5 whose `P Q` a later G5 reuses is pinned: rewriting it
//! would change the later one.
//!
//! # G5.1: quadratic B-spline
//!
//! `G5.1 X Y I J`: control point `P0 + (I, J)`, both required. The quadratic
//! `P0, C, P3` is stored exactly as the cubic Bézier of its degree elevation:
//! `P0, P0 + 2/3 (C - P0), P3 + 2/3 (C - P3), P3`.
//!
//! # G5.2 ... G5.3: NURBS
//!
//! `G5.2 X Y P L` starts a NURBS: the current point is its first control point (weight
//! 1, or `P` when the block has no X Y), X Y (both or neither) the next one with weight
//! `P`. `L` is the order (degree + 1): 3 unless an `L` above 3 is given on any block of
//! the curve (LinuxCNC ignores smaller ones). Each following block `X Y P` (in the modal
//! G5.2 mode, or with G5.2 again) adds a control point; every point after the first needs
//! a positive weight. X Y of every point are taken relative to the curve's first point
//! under G91 (LinuxCNC does not move its current position until G5.3). `G5.3` ends the
//! curve (an error without a G5.2 before it, or with fewer control points than the
//! order), moves to the last control point and leaves no motion mode in force. A G5.2
//! sequence that a motion of another kind interrupts makes no motion (ncsmooth warns).
//!
//! The curve is LinuxCNC's rational B-spline of order `k` over `n + 1` control points with
//! its clamped uniform knot vector: `k` zeros, then `1, 2, ..., n - k + 1`, then `k`
//! copies of `n - k + 2`. It starts at the first control point and ends at the last. It
//! is a [`Segment::Nurbs`](ncsmooth::geom::Segment::Nurbs) (degree at most
//! [`MAX_DEGREE`]) on the G5.3 line. (LinuxCNC's motion follows this curve through
//! short pieces it computes from it; its standalone interpreter prints only
//! `NURBS_FEED(<number of control points>, ...)`.)
//!
//! Where the versions of LinuxCNC differ or LinuxCNC has no meaningful answer, ncsmooth
//! refuses: G5.2 outside G17 (2.9 ignores the plane, 2.10 uses it), a first G5.2 block
//! with X Y but no P (2.9 gives that point the weight -1), a Z word that would move Z
//! (LinuxCNC ignores it), polar words on G5.2 blocks.
//!
//! # Rewriting
//!
//! G5 and G5.1 lines with nothing else on them are replaceable like G1 lines (a rewrite
//! writes smoothed or non-native curves flattened to G1 within its chord tolerance).
//! G5.2 and G5.3 lines are pinned: a NURBS spans several lines, and replacing its motion
//! (on the G5.3 line) would leave the G5.2 lines behind.

use super::frames::bit;
use super::modal::MOTION_NONE;
use super::motion::Target;
use super::{axes_vec, Interp};
use crate::canon::Canon;
use crate::error::{ParseError, ParseErrorKind};
use crate::source::flags;
use crate::source::Plane;
use ncsmooth::geom::{CubicBez, Nurbs, Vec3, MAX_DEGREE};
use ncsmooth::path::{Block, Move};

/// LinuxCNC's NURBS order when no `L` above it is given.
pub const DEFAULT_NURBS_ORDER: usize = 3;
/// A value within this of an integer is that integer (LinuxCNC's `read_integer_value`).
const INTEGER_TOLERANCE: f64 = 1e-4;

/// A NURBS being built by G5.2 blocks.
#[derive(Clone, Debug)]
pub(crate) struct NurbsBuild {
    /// Control points (mm; Z of the first point).
    pub ctrl: Vec<Vec3>,
    /// Their weights.
    pub weights: Vec<f64>,
    /// Whether every control point is known.
    pub known: bool,
    /// Whether the last control point is known.
    pub last_known: bool,
    /// Order (degree + 1).
    pub order: usize,
    /// Line of the first G5.2 block.
    pub first_line: u32,
}

/// The clamped uniform knot vector LinuxCNC uses for `count` control points of order
/// `order` (see the module doc).
pub fn linuxcnc_knots(count: usize, order: usize) -> Vec<f64> {
    let n = count - 1;
    (0..=n + order)
        .map(|i| {
            if i < order {
                0.0
            } else if i <= n {
                (i + 1 - order) as f64
            } else {
                (n + 2 - order) as f64
            }
        })
        .collect()
}

/// The cubic Bézier of quadratic `p0 c p2` (degree elevation: the same curve).
pub fn elevate_quadratic(p0: Vec3, c: Vec3, p2: Vec3) -> CubicBez {
    const TWO_THIRDS: f64 = 2.0 / 3.0;
    CubicBez::new(
        p0,
        p0 + (c - p0) * TWO_THIRDS,
        p2 + (c - p2) * TWO_THIRDS,
        p2,
    )
}

impl Interp<'_> {
    fn spline_err(&self, code10: u16, why: impl Into<String>) -> ParseError {
        self.err_line(ParseErrorKind::InvalidMotion {
            code: super::block::code_name('G', u32::from(code10)),
            why: why.into(),
        })
    }

    /// Runs spline motion `code10` (50 G5, 51 G5.1, 52 G5.2, 53 G5.3) for this block;
    /// `prev` is the motion mode before it.
    pub(crate) fn spline(&mut self, code10: u16, prev: u16) -> Result<(), ParseError> {
        match code10 {
            52 => return self.nurbs_point(prev),
            53 => return self.nurbs_end(prev),
            _ => {}
        }
        if self.m.plane != Plane::XY {
            return Err(self.spline_err(code10, "splines must be in the XY plane"));
        }
        if self.m.feed.is_none() {
            return Err(self.err_line(ParseErrorKind::NoFeedRate));
        }
        for l in *b"ZABCUVWE" {
            if self.has(l) && (l != b'E' || self.takes_e_axis()) {
                return Err(self.err_word(
                    self.word_of(l),
                    ParseErrorKind::InvalidMotion {
                        code: super::block::code_name('G', u32::from(code10)),
                        why: "splines may not have motion in Z, A, B, C, U, V, W or E".into(),
                    },
                ));
            }
        }
        let scale = self.scale();
        let (i, j) = (self.known_val(b'I')?, self.known_val(b'J')?);
        let t = self.target(false)?;
        let start = axes_vec(&self.f.pos);
        let end = axes_vec(&t.pos);
        let seg = if code10 == 50 {
            let (p, q) = match (self.known_val(b'P')?, self.known_val(b'Q')?) {
                (Some(p), Some(q)) => (p, q),
                _ => return Err(self.spline_err(code10, "must specify both P and Q with G5")),
            };
            let (i, j) = match (i, j) {
                (Some(i), Some(j)) => (i, j),
                (None, None) => {
                    if prev != 50 {
                        self.warn(
                            "G5 without I J not right after a G5: its first control point uses the offset LinuxCNC stored last",
                        );
                    }
                    self.pin_last_g5();
                    (self.m.cycle.ijk[0], self.m.cycle.ijk[1])
                }
                _ => return Err(self.spline_err(code10, "must specify both I and J, or neither")),
            };
            self.m.cycle.ijk[0] = -p;
            self.m.cycle.ijk[1] = -q;
            let p1 = start + Vec3::new(i, j, 0.0) * scale;
            let p2 = end + Vec3::new(p, q, 0.0) * scale;
            CubicBez::new(start, p1, p2, end)
        } else {
            let (Some(i), Some(j)) = (i, j) else {
                return Err(self.spline_err(code10, "must specify both I and J with G5.1"));
            };
            let c = start + Vec3::new(i, j, 0.0) * scale;
            elevate_quadratic(start, c, end)
        };
        self.spline_move(code10, &t, seg.into())
    }

    /// Places a spline move to `t` (or an untracked event).
    fn spline_move(
        &mut self,
        code10: u16,
        t: &Target,
        seg: ncsmooth::geom::Segment,
    ) -> Result<(), ParseError> {
        if !self.trackable_xy(t) {
            self.untracked("a spline from or to a position not established in this frame");
            self.go_to_target(t);
            if code10 == 50 {
                self.m.last_g5 = None;
            }
            self.canon(|it| Canon::Spline {
                end: it.canon_pos(),
            });
            return Ok(());
        }
        let mut mv = Move::feed(seg, self.m.feed, self.line_no);
        self.go_to_target(t);
        if self.tp.extra_axes_mask != 0 {
            mv.extra = Some(self.extra_axes());
        }
        if !ncsmooth::geom::ParamCurve::end(&mv.segment).is_finite() {
            return Err(self.err_line(ParseErrorKind::OutOfRange));
        }
        self.canon(|it| Canon::Spline {
            end: it.canon_pos(),
        });
        if code10 == 50 {
            self.m.last_g5 = Some(self.tp.blocks.len());
            self.m.last_g5_replaceable = false;
        }
        self.tp.push_move(mv);
        Ok(())
    }

    /// Pins the last G5 move (a G5 without I J depends on its P Q).
    fn pin_last_g5(&mut self) {
        let Some(k) = self.m.last_g5 else { return };
        if std::mem::take(&mut self.m.last_g5_replaceable) {
            self.stats.replaceable_lines -= 1;
        }
        if let Some(Block::Move(mv)) = self.tp.blocks.get_mut(k) {
            mv.pinned = true;
            if let Some(info) = (mv.line as usize)
                .checked_sub(1)
                .and_then(|l| self.map.lines.get_mut(l))
            {
                info.flags &= !flags::REPLACEABLE;
            }
        }
    }

    /// Whether a spline to `t` can be placed: X and Y known at both ends.
    fn trackable_xy(&self, t: &Target) -> bool {
        self.f.all_known(0b11) && t.known & 0b11 == 0b11
    }

    /// Moves the commanded axes to `t`.
    fn go_to_target(&mut self, t: &Target) {
        for i in 0..2 {
            if t.commanded & bit(i) != 0 {
                let v = (t.known & bit(i) != 0).then_some(t.pos[i]);
                self.f.set(i, v);
            }
        }
    }

    /// A G5.2 block: starts the NURBS or adds a control point.
    fn nurbs_point(&mut self, prev: u16) -> Result<(), ParseError> {
        const CODE: u16 = 52;
        self.line_pinned = true;
        if self.m.plane != Plane::XY {
            return Err(self.spline_err(CODE, "NURBS must be in the XY plane"));
        }
        if self.has(b'@') || self.has(b'^') {
            return Err(self.spline_err(CODE, "polar coordinates are not allowed on G5.2"));
        }
        for l in *b"ABCUVWE" {
            if self.has(l) && (l != b'E' || self.takes_e_axis()) {
                return Err(self.err_word(
                    self.word_of(l),
                    ParseErrorKind::InvalidMotion {
                        code: "G5.2".into(),
                        why: "a NURBS may only move X and Y".into(),
                    },
                ));
            }
        }
        let (hx, hy) = (self.has(b'X'), self.has(b'Y'));
        if hx != hy {
            return Err(self.spline_err(
                CODE,
                "you must specify both X and Y coordinates for control points",
            ));
        }
        let xy = hx && hy;
        let p = self.known_val(b'P')?;
        if prev != CODE {
            self.m.nurbs = None;
        }
        let started = self.m.nurbs.is_some();
        let weight_ok = p.is_some_and(|p| p > 0.0);
        if started && !xy && weight_ok {
            return Err(self.spline_err(
                CODE,
                "can specify P without X and Y only for the first control point",
            ));
        }
        if started && !weight_ok {
            return Err(self.spline_err(
                CODE,
                "must specify positive weight P for every control point",
            ));
        }
        if self.m.feed.is_none() {
            return Err(self.err_line(ParseErrorKind::NoFeedRate));
        }
        if !started {
            if xy && !weight_ok {
                return Err(self.spline_err(
                    CODE,
                    "the control point needs a positive weight P (LinuxCNC would take -1)",
                ));
            }
            let w0 = match p {
                Some(p) if !xy && p > 0.0 => p,
                _ => 1.0,
            };
            self.m.nurbs = Some(NurbsBuild {
                ctrl: vec![axes_vec(&self.f.pos)],
                weights: vec![w0],
                known: self.f.all_known(0b11),
                last_known: self.f.all_known(0b11),
                order: DEFAULT_NURBS_ORDER,
                first_line: self.line_no,
            });
        }
        if let Some(l) = self.known_val(b'L')? {
            let n = l.round();
            if l < 0.0 || (l - n).abs() > INTEGER_TOLERANCE {
                return Err(self.err_word(
                    self.word_of(b'L'),
                    ParseErrorKind::InvalidValue {
                        letter: 'L',
                        value: l,
                        why: "the NURBS order must be a positive integer",
                    },
                ));
            }
            if n > DEFAULT_NURBS_ORDER as f64 {
                if n > (MAX_DEGREE + 1) as f64 {
                    return Err(self.spline_err(
                        CODE,
                        format!("NURBS of order above {} are not supported", MAX_DEGREE + 1),
                    ));
                }
                if let Some(b) = &mut self.m.nurbs {
                    b.order = n as usize;
                }
            }
        }
        if xy {
            let t = self.target(false)?;
            if t.commanded & bit(2) != 0 {
                let same_z =
                    self.f.all_known(bit(2)) && t.known & bit(2) != 0 && t.pos[2] == self.f.pos[2];
                if !same_z {
                    return Err(self.err_word(
                        self.word_of(b'Z'),
                        ParseErrorKind::InvalidMotion {
                            code: "G5.2".into(),
                            why: "a NURBS may not move Z (LinuxCNC ignores the word)".into(),
                        },
                    ));
                }
            }
            let point = Vec3::new(t.pos[0], t.pos[1], self.f.pos[2]);
            let known = t.known & 0b11 == 0b11 && point.is_finite();
            if let Some(b) = &mut self.m.nurbs {
                b.ctrl.push(point);
                b.weights.push(p.unwrap_or(1.0));
                b.known &= known;
                b.last_known = known;
            }
        }
        Ok(())
    }

    /// G5.3: the NURBS move.
    fn nurbs_end(&mut self, prev: u16) -> Result<(), ParseError> {
        const CODE: u16 = 53;
        self.line_pinned = true;
        self.m.motion = MOTION_NONE;
        let build = self.m.nurbs.take();
        let b = match build {
            Some(b) if prev == 52 => b,
            _ => return Err(self.spline_err(CODE, "cannot use G5.3 without G5.2 first")),
        };
        if let Some(l) = super::frames::AXIS_LETTERS
            .iter()
            .copied()
            .find(|&l| self.has(l))
        {
            return Err(self.err_word(
                self.word_of(l),
                ParseErrorKind::InvalidMotion {
                    code: "G5.3".into(),
                    why: "G5.3 takes no axis words".into(),
                },
            ));
        }
        if b.ctrl.len() < b.order {
            return Err(self.spline_err(
                CODE,
                format!(
                    "you must specify a number of control points at least equal to the order L = {}",
                    b.order
                ),
            ));
        }
        let last = *b.ctrl.last().unwrap_or(&b.ctrl[0]);
        let knots = linuxcnc_knots(b.ctrl.len(), b.order);
        let (known, last_known) = (b.known, b.last_known);
        let curve = Nurbs::new(b.order - 1, b.ctrl, b.weights, knots)
            .ok_or_else(|| self.err_line(ParseErrorKind::OutOfRange))?;
        if known {
            let mut mv = Move::feed(curve, self.m.feed, self.line_no);
            mv.pinned = true;
            self.f.set(0, Some(last.x));
            self.f.set(1, Some(last.y));
            if self.tp.extra_axes_mask != 0 {
                mv.extra = Some(self.extra_axes());
            }
            self.tp.push_move(mv);
        } else {
            self.untracked("a NURBS from or through a position not established in this frame");
            self.f.pos[0] = last.x;
            self.f.pos[1] = last.y;
            self.f.set(0, last_known.then_some(last.x));
            self.f.set(1, last_known.then_some(last.y));
        }
        self.canon(|it| Canon::Spline {
            end: it.canon_pos(),
        });
        Ok(())
    }

    /// Drops a G5.2 sequence that a motion of another kind interrupted (LinuxCNC makes no
    /// motion for it).
    pub(crate) fn drop_unfinished_nurbs(&mut self, motion_runs: bool) {
        if !motion_runs {
            return;
        }
        if let Some(b) = self.m.nurbs.take() {
            self.warn(format!(
                "the G5.2 NURBS started on line {} was not ended by G5.3: no motion for it",
                b.first_line
            ));
        }
    }
}
