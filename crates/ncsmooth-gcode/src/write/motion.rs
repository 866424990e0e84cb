//! The motion writer: moves as G0/G1/G2/G3 (and G5/G5.2) lines, axis words only when
//! their printed value changes, shared by [`crate::write::write`] and
//! [`crate::write::rewrite::rewrite`].

use super::chain;
use super::chain_extra::ExtraProfile;
use super::frame::Frame;
use crate::controller::floor::{lift_short_blocks_in, Floor, Lift};
use crate::controller::linuxcnc::blend::{
    raise_for_rooms, raised_span, BlendSchedule, RunEnd, RunEnds, Split, VertexBlend, VertexRoom,
};
use crate::controller::linuxcnc::even_out::{even_out, EvenOut};
use crate::controller::linuxcnc::g64::blend_words;
use crate::numbers::{
    decimal_sum, push_fixed, CENTRE_EXTRA_DECIMALS, E_EXTRA_DECIMALS, MAX_DECIMALS,
};
use ncsmooth::geom::{Arc, CubicBez, Flatten, Nurbs, ParamCurve, Segment, Vec3};
use ncsmooth::path::{Move, MoveKind, EXTRA_AXIS_NAMES};
use std::f64::consts::TAU;
use std::fmt::{self, Write as _};

/// The bit of `E` (a printer's extrusion) in [`Frame::extra_mask`].
const E_AXIS_BIT: u8 = 1 << ncsmooth::path::E_AXIS;

/// Writes moves as G0/G1/G2/G3 lines: axis words only when their printed value changes,
/// arcs on the planes G-code has, everything else flattened.
pub(crate) struct MotionWriter {
    pub frame: Frame,
    pub line_numbers: bool,
    n: u64,
    pub line: String,
    scratch: String,
    last_axis: [String; 3],
    axis_known: [bool; 3],
    /// The last position written (unrounded; see `written_pos`).
    written: Vec3,
    last_extra: [String; 7],
    extra_known: [bool; 7],
    /// Extra-axis values written last (for interpolation and relative E: there, what the
    /// written increments add up to).
    last_extra_val: [f64; 7],
    /// Relative E: the program's value at the last written increment.
    last_e_target: f64,
    last_f: String,
    f_known: bool,
    /// The last motion code written (0, 1, 2, 3), if any.
    pub last_motion: Option<u8>,
    points: Vec<Vec3>,
    /// An axis that may not be written would have had to change: (axis, value mm).
    pub violation: Option<(char, f64)>,
    /// Under a long-lines emitter, short blocks are lifted against this program.
    pub floor: Option<Floor>,
    /// LinuxCNC's `G64 P` of the runs (mm): the long-lines emitter evens out its blocks
    /// for the blends ([`crate::controller::linuxcnc::even_out::even_out`]).
    pub blend_p_mm: Option<f64>,
    /// Per-block `G64 P` under a long-lines emitter (LinuxCNC).
    pub blend_schedule: Option<BlendSchedule>,
    /// Share of the schedule's `P` in force.
    blend_share: f64,
    /// A `G64` line (without its end of line) to write before the next line: a bound set
    /// while no move follows it yet. One set before the first is written replaces it (a
    /// chain's first block with a share of its own after the run's `P`), so no `G64` is
    /// written that no move runs under.
    pub blend_pending: Option<String>,
    /// Words the next motion block carries after its own (`S255`: a value of the
    /// program's block applied from there, [`ncsmooth::path::EventKind::SpindleSpeed`]).
    pub lead_words: Option<String>,
    /// What moves next to the moves [`MotionWriter::write_moves`] is given.
    pub run_ends: RunEnds,
    /// What moves next to the chain being written.
    chain_ends: RunEnds,
    /// The extra axes along the chain being written, when its moves carry them.
    chain_extra: Option<ExtraProfile>,
    /// The programmed point a verbatim line continues from after these moves (mm): a
    /// block ending there (within [`EXACT_END_SNAP_MM`]) writes it with the digits that
    /// read back as exactly that point ([`MotionWriter::fmt_exact`]), so that a rapid, a
    /// full circle or an incremental move after it starts where the program has it.
    pub exact_end: Option<Vec3>,
    /// [`MotionWriter::exact_end`] while the block that ends there is written.
    exact_now: Option<Vec3>,
}

/// Distance (mm) within which a written block ends on the programmed point a run ends at
/// (the writer then prints that point with its own digits).
pub(crate) const EXACT_END_SNAP_MM: f64 = 1e-9;

const AXIS_LETTERS: [char; 3] = ['X', 'Y', 'Z'];

/// Under the long-lines emitter, an arc whose flattening within the chord takes at least
/// this many lines is written as `G2`/`G3` (where its plane allows and the dialect keeps
/// long arcs, [`crate::Dialect::keeps_long_arcs`]) and ends the chain of lines; shorter
/// arcs (the small transitions of a smoothed corner) join the chain.
pub(crate) const NATIVE_ARC_MIN_BLOCKS: f64 = 4.0;

/// Largest spread of Z (mm) among the control points of a curve written as `G5`/`G5.2`
/// (which carry no Z): numerical noise of a fit in a plane, below any printed decimal.
const PLANAR_Z_MM: f64 = 1e-9;

/// Digits after the point of `G5.2` weights.
const NURBS_WEIGHT_DECIMALS: usize = 12;

/// [`MotionWriter::last_motion`] after a `G5` (no G0-G3 mode is in force).
pub(crate) const G5_MOTION: u8 = 5;

/// Flattening chord (mm) used when a frame's chord is not positive.
const DEFAULT_CHORD_MM: f64 = 0.001;

/// Smallest chord (mm) of an arc of less than half a turn written as G2/G3; shorter arcs
/// are flattened (into one or a few G1 lines within the chord tolerance: their sagitta is
/// tiny). A reader that rounds the end points (LinuxCNC's canonical output prints four
/// decimals, grbl computes in single precision) could otherwise take such an arc for a full
/// circle.
pub(crate) const MIN_ARC_CHORD_MM: f64 = 0.005;
/// The same minimum in units of the last written decimal.
const MIN_ARC_CHORD_UNITS: f64 = 20.0;

/// Smallest arc radius written as G2/G3 (mm): twice LinuxCNC's zero-radius limit
/// ([`crate::interpreter::motion::RADIUS_TOLERANCE_MM`]), so that no reader refuses it; smaller
/// arcs are flattened.
pub(crate) const MIN_ARC_RADIUS_MM: f64 = 2.0 * crate::interpreter::motion::RADIUS_TOLERANCE_MM;

fn coord(v: Vec3, i: usize) -> f64 {
    match i {
        0 => v.x,
        1 => v.y,
        _ => v.z,
    }
}

fn set_coord(v: &mut Vec3, i: usize, x: f64) {
    match i {
        0 => v.x = x,
        1 => v.y = x,
        _ => v.z = x,
    }
}

impl MotionWriter {
    /// A writer at `start` (mm): the allowed axes are taken as already written there.
    pub(crate) fn new(frame: Frame, start: Vec3) -> MotionWriter {
        let mut w = MotionWriter {
            frame,
            line_numbers: false,
            n: 0,
            line: String::with_capacity(128),
            scratch: String::with_capacity(32),
            last_axis: Default::default(),
            axis_known: [false; 3],
            written: start,
            last_extra: Default::default(),
            extra_known: [false; 7],
            last_extra_val: [0.0; 7],
            last_e_target: 0.0,
            last_f: String::new(),
            f_known: false,
            last_motion: None,
            points: Vec::new(),
            violation: None,
            floor: None,
            blend_p_mm: None,
            blend_schedule: None,
            blend_share: 1.0,
            blend_pending: None,
            lead_words: None,
            run_ends: RunEnds::default(),
            chain_ends: RunEnds::default(),
            chain_extra: None,
            exact_end: None,
            exact_now: None,
        };
        w.forget_axes();
        w
    }

    /// Coordinate decimals, clamped to [`MAX_DECIMALS`].
    fn decimals(&self) -> usize {
        self.frame.decimals.min(MAX_DECIMALS)
    }

    pub(crate) fn begin(&mut self) {
        self.line.clear();
        if self.line_numbers {
            self.n += 1;
            let _ = write!(self.line, "N{} ", self.n);
        }
    }

    pub(crate) fn end<W: fmt::Write>(&mut self, out: &mut W) -> fmt::Result {
        if let Some(g64) = self.blend_pending.take() {
            out.write_str(&g64)?;
            out.write_char('\n')?;
        }
        out.write_str(&self.line)?;
        out.write_char('\n')
    }

    /// Ends a motion block: its [`MotionWriter::lead_words`], then [`MotionWriter::end`].
    fn end_block<W: fmt::Write>(&mut self, out: &mut W) -> fmt::Result {
        if let Some(words) = self.lead_words.take() {
            self.line.push(' ');
            self.line.push_str(&words);
        }
        self.end(out)
    }

    /// Writes a block value no block took (the motion it came with wrote nothing: a move
    /// of no length) on a `G1` of no length where the writer is, as the program has it.
    pub(crate) fn write_due_lead<W: fmt::Write>(&mut self, out: &mut W) -> fmt::Result {
        if self.lead_words.is_none() {
            return Ok(());
        }
        self.begin();
        self.line.push_str("G1");
        let p = self.written;
        for i in 0..3 {
            if self.allowed(i) {
                self.axis(i, coord(p, i), true);
            }
        }
        self.last_motion = Some(1);
        self.end_block(out)
    }

    /// The next move writes every axis (the position was changed by something else).
    pub(crate) fn forget_axes(&mut self) {
        self.axis_known = [false; 3];
    }

    /// The next move writes its extra axes again.
    pub(crate) fn forget_extras(&mut self) {
        self.extra_known = [false; 7];
    }

    /// The next feed move writes F again.
    pub(crate) fn forget_feed(&mut self) {
        self.f_known = false;
    }

    /// Relative E (M83): what the written increments add up to less the program's value,
    /// within half a written unit. A later run's increments start from it
    /// ([`MotionWriter::assume_at`]), so the rounding never accumulates across runs.
    pub(crate) fn relative_e_carry(&self) -> f64 {
        self.last_extra_val[6] - self.last_e_target
    }

    /// The program's extra-axis values at the last written point (with relative E, what
    /// the written increments add up to is [`MotionWriter::relative_e_carry`] away).
    fn program_extra(&self) -> [f64; 7] {
        let mut e = self.last_extra_val;
        if self.frame.e_relative {
            e[6] = self.last_e_target;
        }
        e
    }

    /// Sets the position the reader is at (mm), as if written: axes whose printed value
    /// does not change are not written again. With relative E, `e_carry` is what the
    /// machine's E is ahead of `extra` ([`MotionWriter::relative_e_carry`] of the run
    /// before, when no reset came between).
    pub(crate) fn assume_at(&mut self, p: Vec3, extra: Option<&[f64; 7]>, e_carry: f64) {
        for i in 0..3 {
            if self.frame.incremental {
                // Increments are taken from exactly where the reader is.
                self.fmt_exact(i, coord(p, i));
            } else {
                let v = self.mm_to_units(i, coord(p, i));
                self.fmt(v);
            }
            std::mem::swap(&mut self.last_axis[i], &mut self.scratch);
            self.axis_known[i] = true;
        }
        self.written = p;
        if let Some(e) = extra {
            self.last_extra_val = *e;
            self.last_e_target = e[6];
            if self.frame.e_relative {
                self.last_extra_val[6] += e_carry;
            }
            for i in 0..7 {
                let v = self.extra_units(i, e[i]);
                self.fmt_extra(i, v);
                std::mem::swap(&mut self.last_extra[i], &mut self.scratch);
                self.extra_known[i] = true;
            }
        }
    }

    /// Axis value `v` (mm) in written units.
    fn mm_to_units(&self, i: usize, v: f64) -> f64 {
        let v = v / self.frame.scale;
        if i == 0 && self.frame.diameter {
            2.0 * v
        } else {
            v
        }
    }

    /// Written units back to mm.
    fn units_to_mm(&self, i: usize, v: f64) -> f64 {
        let v = if i == 0 && self.frame.diameter {
            v / 2.0
        } else {
            v
        };
        v * self.frame.scale
    }

    /// Extra axis `i` (A B C U V W E) in written units.
    fn extra_units(&self, i: usize, v: f64) -> f64 {
        if i < 3 {
            v
        } else {
            v / self.frame.scale
        }
    }

    /// Formats `v` into the scratch buffer.
    fn fmt(&mut self, v: f64) {
        self.fmt_to(v, self.decimals());
    }

    /// Formats `v` into the scratch buffer with `decimals` digits (at most [`MAX_DECIMALS`]).
    fn fmt_to(&mut self, v: f64, decimals: usize) {
        self.scratch.clear();
        push_fixed(&mut self.scratch, v, decimals.min(MAX_DECIMALS));
    }

    /// Formats axis `i`'s value `v` (mm) with the fewest decimals, from the frame's on,
    /// that read back as exactly `v` (a point of the program: its own digits), or with
    /// [`MAX_DECIMALS`] when none does.
    fn fmt_exact(&mut self, i: usize, v: f64) {
        let u = self.mm_to_units(i, v);
        for d in self.decimals()..=MAX_DECIMALS {
            self.fmt_to(u, d);
            if self
                .scratch
                .parse::<f64>()
                .is_ok_and(|b| self.units_to_mm(i, b) == v)
            {
                return;
            }
        }
    }

    /// [`MotionWriter::exact_end`] when a block to `p` ends there (`p` the point itself or
    /// its rounding to the written decimals, as the long-lines emitter chooses its ends).
    fn exact_at(&self, p: Vec3) -> Option<Vec3> {
        self.exact_end.filter(|&e| {
            e.dist(p) <= EXACT_END_SNAP_MM || self.rounded(e).dist(p) <= EXACT_END_SNAP_MM
        })
    }

    /// One unit of the last written digit, in mm.
    fn unit_mm(&self) -> f64 {
        0.1f64.powi(self.decimals() as i32) * self.frame.scale
    }

    /// Formats extra axis `i`'s value `v` (written units): `E` with
    /// [`E_EXTRA_DECIMALS`] more digits than the coordinates.
    fn fmt_extra(&mut self, i: usize, v: f64) {
        let more = if i == 6 { E_EXTRA_DECIMALS } else { 0 };
        self.fmt_to(v, self.decimals() + more);
    }

    fn allowed(&self, i: usize) -> bool {
        self.frame.allowed_xyz & (1 << i) != 0
    }

    /// Appends axis `i` = `v` (mm) when forced or changed; updates the written position.
    /// An axis that may not be written is never written: if its value would change, the
    /// violation is recorded.
    fn axis(&mut self, i: usize, v: f64, force: bool) -> bool {
        if self.frame.incremental {
            return self.axis_increment(i, v, force);
        }
        let v = match self.exact_now.filter(|_| self.allowed(i)) {
            Some(e) => {
                self.fmt_exact(i, coord(e, i));
                coord(e, i)
            }
            None => {
                let u = self.mm_to_units(i, v);
                self.fmt(u);
                v
            }
        };
        if !self.allowed(i) {
            if self.axis_known[i] && self.scratch != self.last_axis[i] && self.violation.is_none() {
                self.violation = Some((AXIS_LETTERS[i], v));
            }
            return false;
        }
        if force || !self.axis_known[i] || self.scratch != self.last_axis[i] {
            self.line.push(' ');
            self.line.push(AXIS_LETTERS[i]);
            self.line.push_str(&self.scratch);
            std::mem::swap(&mut self.last_axis[i], &mut self.scratch);
            self.axis_known[i] = true;
            set_coord(&mut self.written, i, v);
            true
        } else {
            false
        }
    }

    /// [`MotionWriter::axis`] under [`Frame::incremental`]: `last_axis[i]` is where the
    /// reader is, exactly (the decimals it added up), and the increment is rounded from
    /// there, so the reader is never more than half a digit from `v` whatever came before;
    /// at the run's programmed end ([`MotionWriter::exact_end`]) it is the exact
    /// difference to the program's own digits, so the copied lines after the run continue
    /// from exactly where the program has them.
    fn axis_increment(&mut self, i: usize, v: f64, force: bool) -> bool {
        let at: f64 = self.last_axis[i].parse().unwrap_or(f64::NAN);
        if !self.axis_known[i] || at.is_nan() {
            // An increment needs where the reader is (set by `assume_at`).
            self.violation.get_or_insert((AXIS_LETTERS[i], v));
            return false;
        }
        let inc = match self.exact_now.filter(|_| self.allowed(i)) {
            Some(e) => {
                self.fmt_exact(i, coord(e, i));
                decimal_sum(&self.scratch, &self.last_axis[i], -1)
            }
            None => {
                self.fmt(self.mm_to_units(i, v) - at);
                Some(self.scratch.clone())
            }
        };
        let Some(inc) = inc else {
            self.violation.get_or_insert((AXIS_LETTERS[i], v));
            return false;
        };
        if !self.allowed(i) {
            if inc != "0" {
                self.violation.get_or_insert((AXIS_LETTERS[i], v));
            }
            return false;
        }
        if !force && inc == "0" {
            return false;
        }
        let Some(next) = decimal_sum(&self.last_axis[i], &inc, 1) else {
            self.violation.get_or_insert((AXIS_LETTERS[i], v));
            return false;
        };
        self.line.push(' ');
        self.line.push(AXIS_LETTERS[i]);
        self.line.push_str(&inc);
        self.last_axis[i] = next;
        set_coord(&mut self.written, i, v);
        true
    }

    /// The position the reader computes: the written (rounded) coordinates (mm).
    fn written_pos(&self) -> Vec3 {
        let mut p = self.written;
        for i in 0..3 {
            if self.axis_known[i] {
                if let Ok(v) = self.last_axis[i].parse() {
                    set_coord(&mut p, i, self.units_to_mm(i, v));
                }
            }
        }
        p
    }

    fn extras(&mut self, e: Option<&[f64; 7]>) {
        let Some(e) = e else { return };
        for i in 0..7 {
            if self.frame.extra_mask & (1 << i) == 0 {
                continue;
            }
            let relative_e = i == 6 && self.frame.e_relative;
            if relative_e {
                // M83: the word is the increment from what was written last.
                let d = self.extra_units(i, e[i] - self.last_extra_val[i]);
                self.fmt_extra(i, d);
                if self.scratch != "0" {
                    self.line.push_str(" E");
                    self.line.push_str(&self.scratch);
                    // Track the rounded increment so that errors do not accumulate.
                    let written: f64 = self.scratch.parse().unwrap_or(0.0);
                    self.last_extra_val[i] += written * self.frame.scale;
                }
                self.last_e_target = e[i];
                continue;
            }
            let v = self.extra_units(i, e[i]);
            self.fmt_extra(i, v);
            if !self.extra_known[i] || self.scratch != self.last_extra[i] {
                self.line.push(' ');
                self.line.push(EXTRA_AXIS_NAMES[i]);
                self.line.push_str(&self.scratch);
                std::mem::swap(&mut self.last_extra[i], &mut self.scratch);
                self.extra_known[i] = true;
            }
            self.last_extra_val[i] = e[i];
        }
    }

    fn feed(&mut self, m: &Move) {
        if m.kind != MoveKind::Feed {
            return;
        }
        if let Some(f) = m.feed_mm_s {
            // A feed below the last written digit (`F0.00001`) gets the digits it needs:
            // written as `F0`, the program would not run.
            let per_min = f * 60.0 / self.frame.scale;
            let mut decimals = self.decimals();
            self.fmt_to(per_min, decimals);
            while self.scratch == "0" && per_min > 0.0 && decimals < MAX_DECIMALS {
                decimals += 1;
                self.fmt_to(per_min, decimals);
            }
            if !self.f_known || self.scratch != self.last_f {
                self.line.push_str(" F");
                self.line.push_str(&self.scratch);
                std::mem::swap(&mut self.last_f, &mut self.scratch);
                self.f_known = true;
            }
        }
    }

    /// The feed last written (units per minute), if any.
    pub(crate) fn last_feed(&self) -> Option<f64> {
        self.f_known.then(|| self.last_f.parse().ok()).flatten()
    }

    /// Writes a G0/G1 to `p`. A move whose every printed coordinate is unchanged is not
    /// written (the reader would run a zero-length block); its feed goes with the next.
    fn linear<W: fmt::Write>(
        &mut self,
        m: &Move,
        p: Vec3,
        extra: Option<&[f64; 7]>,
        out: &mut W,
    ) -> fmt::Result {
        self.begin();
        let code = if m.kind == MoveKind::Rapid { 0 } else { 1 };
        let _ = write!(self.line, "G{code}");
        let bare = self.line.len();
        self.exact_now = self.exact_at(p);
        for i in 0..3 {
            self.axis(i, coord(p, i), false);
        }
        self.exact_now = None;
        self.extras(extra);
        if self.line.len() == bare {
            return Ok(());
        }
        self.feed(m);
        self.last_motion = Some(code);
        self.end_block(out)
    }

    /// Appends ` <letter><v>` for a length `v` (mm) in written units with
    /// [`CENTRE_EXTRA_DECIMALS`] more digits than the coordinates: arc centres, G5 control
    /// offsets and interior G5.2 control points, which must not add their own rounding
    /// to that of the end points.
    fn push_fine(&mut self, letter: char, v: f64) {
        self.scratch.clear();
        let decimals = self.decimals() + CENTRE_EXTRA_DECIMALS;
        push_fixed(&mut self.scratch, v / self.frame.scale, decimals);
        self.line.push(' ');
        self.line.push(letter);
        self.line.push_str(&self.scratch);
    }

    /// Where `p` (mm) will be read back from: each writable axis rounded to the written
    /// decimals (the others are not written).
    fn rounded(&self, p: Vec3) -> Vec3 {
        let p10 = 10f64.powi(self.decimals() as i32);
        let mut q = p;
        for i in 0..3 {
            if self.allowed(i) {
                let u = (self.mm_to_units(i, coord(p, i)) * p10).round() / p10;
                set_coord(&mut q, i, self.units_to_mm(i, u));
            }
        }
        q
    }

    /// Whether `m` may join a chain of long G1 blocks, long arcs aside
    /// ([`MotionWriter::chainable_at`]): a feed move outside diameter mode, without extra
    /// axes or with `E` the only one written (a printer's extrusion, carried along the
    /// blocks by [`ExtraProfile`]; a rotary axis is not a length of the path), and no
    /// curve that `G5`/`G5.2` carries.
    fn chain_candidate(&self, m: &Move) -> bool {
        let native_curve =
            !self.moves_extra(m) && (self.g5_able(&m.segment) || self.nurbs_able(&m.segment));
        m.kind == MoveKind::Feed
            && (m.extra.is_none() || self.frame.extra_mask & !E_AXIS_BIT == 0)
            && !self.frame.diameter
            && !native_curve
    }

    /// Whether `moves[k]` may join a chain. A long arc stays native when the dialect keeps
    /// long arcs ([`ChainMode::long_arcs`]); otherwise only where both its neighbours meet
    /// it as programmed: a line (the program's own joint, tangent or a corner), another
    /// native move or the end of the run. Next to a flattened curve, whose first chord is
    /// off the arc's tangent by half its turn, it is flattened too.
    fn chainable_at(&self, moves: &[&Move], k: usize) -> bool {
        let m = moves[k];
        if !self.chain_candidate(m) {
            return false;
        }
        if !self.long_arc(&m.segment) {
            return true;
        }
        if self.frame.chain.is_none_or(|c| c.long_arcs) {
            return false;
        }
        let meets_as_programmed = |j: Option<usize>| {
            j.and_then(|j| moves.get(j)).is_none_or(|n| {
                matches!(n.segment, Segment::Line(_))
                    || !self.chain_candidate(n)
                    || self.long_arc(&n.segment)
            })
        };
        !(meets_as_programmed(k.checked_sub(1)) && meets_as_programmed(Some(k + 1)))
    }

    /// Whether `s` is a NURBS that `G5.2` carries: NURBS output is on, the curve lies in
    /// an XY plane (Z constant) and X and Y may be written.
    fn nurbs_able(&self, s: &Segment) -> bool {
        match s {
            Segment::Nurbs(n) => self.nurbs_curve_able(n),
            _ => false,
        }
    }

    /// See [`MotionWriter::nurbs_able`].
    fn nurbs_curve_able(&self, n: &Nurbs) -> bool {
        let z0 = n.ctrl()[0].z;
        self.frame.nurbs
            && !self.frame.diameter
            && self.allowed(0)
            && self.allowed(1)
            && n.ctrl().iter().all(|c| (c.z - z0).abs() <= PLANAR_Z_MM)
    }

    /// Writes a NURBS as one `G5.2 ... G5.3` per Bézier span (A5.6), each LinuxCNC's
    /// rational B-spline of order `degree + 1` on the clamped knots `0^k 1^k`, i.e. the
    /// span's rational Bézier with its weights scaled so that the first is 1 (LinuxCNC
    /// gives the current point weight 1): the same curve, moved by the rounding of its
    /// control points at most (positive weights: a convex combination of them). Interior
    /// control points get [`CENTRE_EXTRA_DECIMALS`] more digits. False when it must be
    /// flattened (also when a block value is due: its first block carries it, and a
    /// `G5.2` line does not take one).
    fn try_nurbs<W: fmt::Write>(
        &mut self,
        m: &Move,
        n: &Nurbs,
        out: &mut W,
    ) -> Result<bool, fmt::Error> {
        if !self.nurbs_curve_able(n)
            || self.moves_extra(m)
            || self.lead_words.is_some()
            || self.frame.incremental
        {
            return Ok(false);
        }
        let order = n.degree() + 1;
        for piece in n.bezier_pieces() {
            let w0 = piece[0][3];
            for (i, q) in piece.iter().enumerate().skip(1) {
                let (x, y, w) = (q[0] / q[3], q[1] / q[3], q[3] / w0);
                self.begin();
                if i == 1 {
                    if self.frame.plane != 17 {
                        self.line.push_str("G17 ");
                        self.frame.plane = 17;
                    }
                    self.line.push_str("G5.2");
                }
                if i + 1 == order {
                    self.axis(0, x, true);
                    self.axis(1, y, true);
                } else {
                    self.push_fine('X', x);
                    self.push_fine('Y', y);
                }
                self.line.push_str(" P");
                push_fixed(&mut self.line, w, NURBS_WEIGHT_DECIMALS);
                if i == 1 {
                    let _ = write!(self.line, " L{order}");
                    self.feed(m);
                }
                self.end_block(out)?;
            }
            self.begin();
            self.line.push_str("G5.3");
            self.end_block(out)?;
        }
        self.last_motion = Some(G5_MOTION);
        Ok(true)
    }

    /// Whether `m` carries extra axes the writer writes: `G5` and `G5.2` may not move
    /// them (LinuxCNC's rule), so such a curve is flattened, its lines carrying them.
    fn moves_extra(&self, m: &Move) -> bool {
        m.extra.is_some() && self.frame.extra_mask != 0
    }

    /// Whether `s` is a cubic Bézier that `G5` carries: G5 is on, the curve lies in an XY
    /// plane (Z constant) and X and Y may be written.
    fn g5_able(&self, s: &Segment) -> bool {
        match s {
            Segment::CubicBez(b) => self.g5_curve_able(b),
            _ => false,
        }
    }

    /// See [`MotionWriter::g5_able`].
    fn g5_curve_able(&self, b: &CubicBez) -> bool {
        self.frame.g5
            && !self.frame.diameter
            && self.allowed(0)
            && self.allowed(1)
            && [b.p1.z, b.p2.z, b.p3.z]
                .iter()
                .all(|&z| (z - b.p0.z).abs() <= PLANAR_Z_MM)
    }

    /// Writes a cubic Bézier as `G5 X Y I J P Q` (first control point relative to the
    /// written start, second relative to the written end, both with
    /// [`CENTRE_EXTRA_DECIMALS`] more digits, so the reader's curve is the original one
    /// moved by the end points' rounding at most); false when it must be flattened.
    fn try_g5<W: fmt::Write>(
        &mut self,
        m: &Move,
        b: &CubicBez,
        out: &mut W,
    ) -> Result<bool, fmt::Error> {
        if !self.g5_curve_able(b) || self.moves_extra(m) {
            return Ok(false);
        }
        let start = self.written_pos();
        self.begin();
        if self.frame.plane != 17 {
            self.line.push_str("G17 ");
            self.frame.plane = 17;
        }
        self.line.push_str("G5");
        self.axis(0, b.p3.x, true);
        self.axis(1, b.p3.y, true);
        let end = self.written_pos();
        self.push_fine('I', b.p1.x - start.x);
        self.push_fine('J', b.p1.y - start.y);
        self.push_fine('P', b.p2.x - end.x);
        self.push_fine('Q', b.p2.y - end.y);
        self.feed(m);
        // G5 is a motion mode of its own: a following modal line must get its code back.
        self.last_motion = Some(G5_MOTION);
        self.end_block(out)?;
        Ok(true)
    }

    /// An arc that one `G2`/`G3` carries better than the lines of a chain: flattened it
    /// would take at least [`NATIVE_ARC_MIN_BLOCKS`] chords.
    fn long_arc(&self, s: &Segment) -> bool {
        let Segment::Arc(a) = s else {
            return false;
        };
        let c = self.chord();
        if a.radius.is_nan() || a.radius <= c {
            return false;
        }
        let per_chord = 2.0 * (1.0 - c / a.radius).acos();
        a.sweep >= NATIVE_ARC_MIN_BLOCKS * per_chord
    }

    /// Writes consecutive moves: with [`Frame::chain_min_block_mm`], each run of
    /// chainable moves at one feed as long G1 blocks ([`crate::write::chain`]), the rest move by
    /// move.
    pub(crate) fn write_moves<W: fmt::Write>(
        &mut self,
        moves: &[&Move],
        out: &mut W,
    ) -> fmt::Result {
        let Some(mode) = self.frame.chain else {
            return moves.iter().try_for_each(|m| self.write_move(m, out));
        };
        let mut k = 0;
        while k < moves.len() {
            let m = moves[k];
            let mut e = k + 1;
            let chainable = self.chainable_at(moves, k);
            if chainable {
                while e < moves.len()
                    && self.chainable_at(moves, e)
                    && moves[e].feed_mm_s == m.feed_mm_s
                {
                    e += 1;
                }
            }
            // A lone line or arc is written as itself; a lone curve is flattened as a chain.
            let lone_curve = chainable && !matches!(m.segment, Segment::Line(_) | Segment::Arc(_));
            if e - k > 1 || lone_curve {
                let min_block = mode
                    .min_block_mm
                    .max(m.feed_mm_s.unwrap_or(0.0) * mode.min_block_s);
                self.chain_ends = RunEnds {
                    before: if k == 0 {
                        self.run_ends.before
                    } else {
                        RunEnd::Free
                    },
                    after: if e == moves.len() {
                        self.run_ends.after
                    } else {
                        RunEnd::Free
                    },
                };
                self.write_chain(&moves[k..e], min_block, mode.arcs, out)?;
            } else {
                self.write_move(m, out)?;
            }
            k = e;
        }
        Ok(())
    }

    /// Writes a run of chainable moves as long G1 blocks within the chord tolerance.
    fn write_chain<W: fmt::Write>(
        &mut self,
        moves: &[&Move],
        min_block_mm: f64,
        arcs: bool,
        out: &mut W,
    ) -> fmt::Result {
        let chord = self.chord();
        let dense_tol = chord * chain::DENSE_SHARE;
        let mut dense = std::mem::take(&mut self.points);
        dense.clear();
        dense.push(moves[0].segment.start());
        let mut profile = moves
            .iter()
            .any(|m| self.moves_extra(m))
            .then(|| ExtraProfile::new(self.program_extra()));
        for m in moves {
            let mut push = |p: Vec3| {
                if dense.last() != Some(&p) {
                    dense.push(p);
                }
            };
            match &m.segment {
                Segment::Line(l) => push(l.p1),
                s => s.flatten(dense_tol, &mut push),
            }
            if let Some(profile) = profile.as_mut() {
                profile.push_move(&dense, m.extra.as_ref());
            }
        }
        // Lines are their own dense points: merging may use the whole chord.
        let all_lines = moves.iter().all(|m| matches!(m.segment, Segment::Line(_)));
        let tol = if all_lines { chord } else { chord - dense_tol };
        let mut hard = chain::sharp_points(&dense, tol);
        if let Some(profile) = profile.as_mut() {
            profile.rate_breaks(&mut hard);
            profile.attach(&dense, &hard);
        }
        self.chain_extra = profile;
        let r = if arcs {
            self.write_arc_pieces(moves[0], &dense, &hard, tol, out)
        } else {
            let dense_acc = if all_lines { 0.0 } else { dense_tol };
            self.write_lines(
                moves[0],
                &dense,
                &hard,
                tol,
                dense_acc,
                min_block_mm,
                true,
                out,
            )
        };
        self.points = dense;
        self.chain_extra = None;
        r
    }

    /// The extra-axis values a written point `p` of the chain being written carries
    /// ([`ExtraProfile::at`]); `None` when its moves carry none.
    fn chain_values(&mut self, p: Vec3) -> Option<[f64; 7]> {
        let len_mm = self.written_pos().dist(p);
        let snap_mm = self.unit_mm();
        let profile = self.chain_extra.as_mut()?;
        Some(profile.at(p, len_mm, snap_mm))
    }

    /// The extra-axis values at dense point `k` of the chain being written
    /// ([`ExtraProfile::at_dense`]); `None` when its moves carry none.
    fn chain_values_at(&mut self, k: usize) -> Option<[f64; 7]> {
        Some(self.chain_extra.as_mut()?.at_dense(k))
    }

    /// Writes `dense` as the longest lines within `tol` ([`crate::write::chain::simplify`]);
    /// with `lift` and a [`Floor`], short blocks are then lifted against the program.
    #[allow(clippy::too_many_arguments)]
    fn write_lines<W: fmt::Write>(
        &mut self,
        m: &Move,
        dense: &[Vec3],
        hard: &[bool],
        tol: f64,
        dense_acc: f64,
        min_block_mm: f64,
        lift: bool,
        out: &mut W,
    ) -> fmt::Result {
        let mut pts = Vec::with_capacity(dense.len() / 4 + 2);
        let idx = chain::simplify(
            dense,
            hard,
            tol,
            min_block_mm,
            |p| self.rounded(p),
            &mut pts,
        );
        if let Some(p_mm) = self.blend_p_mm.filter(|_| lift) {
            // LinuxCNC's blends: even out the blocks for their radius within `P`, a point
            // moved inside the curve by no more than its blend leaves of `P`.
            let blend = |a: Vec3, b: Vec3, c: Vec3| VertexBlend::new(b - a, c - b, 0.0);
            let how = EvenOut {
                score: |a, b, c| blend(a, b, c).radius_mm(p_mm),
                room: |a, b, c| p_mm - blend(a, b, c).depth_mm(p_mm),
                dense_acc_mm: dense_acc,
            };
            even_out(
                dense,
                hard,
                &idx,
                tol,
                min_block_mm,
                |p| self.rounded(p),
                &how,
                self.written_pos(),
                &mut pts,
            );
        }
        let floor = lift.then(|| self.floor.take()).flatten();
        let mut snapped = Vec::new();
        if let Some(f) = floor.as_ref() {
            let program = f.program_ref();
            let mut how = Lift {
                corners_only: f.corner.is_some(),
                last_block: self.chain_ends.after == RunEnd::Rapid,
                ..Default::default()
            };
            lift_short_blocks_in(
                self.written_pos(),
                &mut pts,
                f.min_block_mm,
                &program,
                &f.grid,
                |p| self.rounded(p),
                &mut how,
            );
            snapped = how.snapped;
        }
        let (shares, splits) = match self.blend_schedule.filter(|_| lift) {
            Some(s) => {
                let start = self.written_pos();
                let rooms = |wanted: &[bool]| match floor.as_ref() {
                    Some(f) => f.rooms(start, &pts, &snapped, wanted),
                    None => Vec::new(),
                };
                self.blocks_blends(s, m, &pts, rooms)
            }
            None => (Vec::new(), Vec::new()),
        };
        if floor.is_some() {
            self.floor = floor;
        }
        for (k, p) in pts.into_iter().enumerate() {
            if let Some(Some(split)) = splits.get(k) {
                self.set_blend_share(split.shares.0);
                let values = self.chain_values(split.point);
                self.linear(m, split.point, values.as_ref(), out)?;
                self.set_blend_share(split.shares.1);
            } else if let Some(&share) = shares.get(k) {
                self.set_blend_share(share);
            }
            let values = self.chain_values(p);
            self.linear(m, p, values.as_ref(), out)?;
        }
        self.set_blend_share(1.0);
        Ok(())
    }

    /// The schedule's share of `P` for each block of the chain `pts` (from the written
    /// position), raised where the rooms of its points (`rooms`, given which points want
    /// one: those whose speed needs all of the run's `P`) allow more than the run's `P`
    /// ([`raise_for_rooms`]), and the blocks it splits.
    fn blocks_blends(
        &self,
        s: BlendSchedule,
        m: &Move,
        pts: &[Vec3],
        rooms: impl FnOnce(&[bool]) -> Vec<Option<VertexRoom>>,
    ) -> (Vec<f64>, Vec<Option<Split>>) {
        let start = self.written_pos();
        let Some(plan) = s.plan(start, pts, m.feed_mm_s, self.chain_ends) else {
            return (Vec::new(), Vec::new());
        };
        let mut shares = plan.block.clone();
        let sharp = |k: usize| {
            let needs_all = BlendSchedule::round_share(*plan.vertex.get(k)?) >= 1.0;
            needs_all.then(|| plan.speed.get(k).copied()).flatten()
        };
        let (first, last) = raised_span(pts.len(), self.chain_ends);
        let wanted: Vec<bool> = (0..pts.len().saturating_sub(1))
            .map(|k| k >= first && k + 1 < last && sharp(k).is_some())
            .collect();
        let rooms = rooms(&wanted);
        raise_for_rooms(&mut shares, &rooms, s.p_mm, self.chain_ends, sharp);
        let splits = s.splits(&plan, start, pts, &shares, |p| self.rounded(p));
        (shares, splits)
    }

    /// Puts the schedule's `G64` for `share` of its `P` before the next line written, when
    /// another is in force ([`MotionWriter::blend_pending`]).
    fn set_blend_share(&mut self, share: f64) {
        let Some(s) = self.blend_schedule else {
            return;
        };
        if share == self.blend_share {
            return;
        }
        self.blend_share = share;
        let text = blend_words(s.p_mm * share, s.q_mm, self.frame.scale, self.decimals());
        self.blend_pending = Some(text);
    }

    /// Writes `dense` as lines and XY arcs within `tol` ([`crate::write::chain::fit_arcs`]); an
    /// arc the writer cannot carry as `G2`/`G3` is written as lines instead.
    fn write_arc_pieces<W: fmt::Write>(
        &mut self,
        m: &Move,
        dense: &[Vec3],
        hard: &[bool],
        tol: f64,
        out: &mut W,
    ) -> fmt::Result {
        let mut pieces = Vec::with_capacity(dense.len() / 8 + 2);
        let chords = self.frame.arc_chords;
        chain::fit_arcs(dense, hard, tol, chords, |p| self.rounded(p), &mut pieces);
        for piece in pieces {
            match piece {
                chain::Piece::Line { end, to } => {
                    let values = self.chain_values_at(to);
                    self.linear(m, end, values.as_ref(), out)?
                }
                chain::Piece::Arc {
                    from,
                    to,
                    end,
                    center,
                    ccw,
                } => {
                    let start = self.written_pos();
                    let arc = Arc::from_center(start, end, center, Vec3::Z, ccw, 0);
                    let values = self.chain_values_at(to);
                    let written = match arc {
                        Some(a) => self.try_arc(m, &a, values.as_ref(), out)?,
                        None => false,
                    };
                    if !written {
                        let span = &dense[from..=to];
                        self.write_lines(m, span, &hard[from..=to], tol, 0.0, 0.0, false, out)?;
                    }
                }
            }
        }
        Ok(())
    }

    /// The flattening chord (mm).
    fn chord(&self) -> f64 {
        if self.frame.chord_mm > 0.0 {
            self.frame.chord_mm
        } else {
            DEFAULT_CHORD_MM
        }
    }

    /// Writes one move (lines and native arcs as such, everything else flattened).
    pub(crate) fn write_move<W: fmt::Write>(&mut self, m: &Move, out: &mut W) -> fmt::Result {
        match &m.segment {
            Segment::Line(l) => self.linear(m, l.p1, m.extra.as_ref(), out),
            Segment::Arc(a) => {
                if !self.try_arc(m, a, m.extra.as_ref(), out)? {
                    self.flattened(m, out)?;
                }
                Ok(())
            }
            Segment::Nurbs(n) if self.frame.nurbs => {
                if !self.try_nurbs(m, n, out)? {
                    self.flattened(m, out)?;
                }
                Ok(())
            }
            Segment::CubicBez(b) if self.frame.g5 => {
                if !self.try_g5(m, b, out)? {
                    self.flattened(m, out)?;
                }
                Ok(())
            }
            _ => self.flattened(m, out),
        }
    }

    /// Writes a native arc; false when it must be flattened instead.
    fn try_arc<W: fmt::Write>(
        &mut self,
        m: &Move,
        a: &Arc,
        extra: Option<&[f64; 7]>,
        out: &mut W,
    ) -> Result<bool, fmt::Error> {
        let n = a.normal();
        let close = |v: Vec3| (n - v).norm() <= 1e-9;
        // (plane code, first axis, second axis, G3?)
        let (plane, i0, i1, ccw) = if close(Vec3::Z) {
            (17u8, 0, 1, true)
        } else if close(-Vec3::Z) {
            (17, 0, 1, false)
        } else if close(Vec3::Y) {
            (18, 2, 0, true)
        } else if close(-Vec3::Y) {
            (18, 2, 0, false)
        } else if close(Vec3::X) {
            (19, 1, 2, true)
        } else if close(-Vec3::X) {
            (19, 1, 2, false)
        } else {
            return Ok(false);
        };
        // Absolute centres (G90.1) have no place on axes known only relatively.
        if self.frame.arc_planes & (1 << (plane - 17)) == 0
            || (self.frame.incremental && self.frame.arc_absolute)
        {
            return Ok(false);
        }
        // A controller that runs the start's circle would leave the spiral by up to its
        // change of radius.
        if !self.frame.spiral_arcs && a.spiral.abs() > 0.5 * self.chord() {
            return Ok(false);
        }
        let unit = self.unit_mm();
        let min_radius = (2.0 * unit).max(MIN_ARC_RADIUS_MM);
        if a.radius.is_nan() || a.radius < min_radius || !a.sweep.is_finite() || a.sweep <= 0.0 {
            return Ok(false);
        }
        // The controller's chords of the arc must be within our own flattening's.
        if self.frame.arc_chords.sagitta_mm(a.radius, a.sweep) > self.chord() {
            return Ok(false);
        }
        let normal_axis = 3 - i0 - i1;
        let chord = {
            let (p, q) = (a.eval(0.0), a.eval(1.0));
            (coord(p, i0) - coord(q, i0)).hypot(coord(p, i1) - coord(q, i1))
        };
        if a.sweep < std::f64::consts::PI
            && chord < (MIN_ARC_CHORD_UNITS * unit).max(MIN_ARC_CHORD_MM)
        {
            return Ok(false);
        }
        // An arc needs both axes of its plane (and the normal one for a helix) writable,
        // and no diameter-mode X.
        let helix = (coord(a.eval(1.0), normal_axis) - coord(a.eval(0.0), normal_axis)).abs() > 0.0;
        if !self.allowed(i0)
            || !self.allowed(i1)
            || (helix && !self.allowed(normal_axis))
            || self.frame.diameter
        {
            return Ok(false);
        }
        let turns = ((a.sweep / TAU) - 1e-9).ceil().max(1.0);
        if turns > 10_000.0 {
            return Ok(false);
        }
        let full = (a.sweep - turns * TAU).abs() <= 1e-9 * turns;
        let mut end = a.eval(1.0);
        let start_written = self.written_pos();
        if full {
            // End exactly where the reader's start is, in the plane.
            set_coord(&mut end, i0, coord(start_written, i0));
            set_coord(&mut end, i1, coord(start_written, i1));
        } else {
            // Would rounding make start and end coincide (a full circle for the reader)?
            let s0 = self.mm_to_units(i0, coord(end, i0));
            self.fmt(s0);
            let e0: f64 = self.scratch.parse().unwrap_or(f64::NAN);
            let s1 = self.mm_to_units(i1, coord(end, i1));
            self.fmt(s1);
            let e1: f64 = self.scratch.parse().unwrap_or(f64::NAN);
            let w0 = self.mm_to_units(i0, coord(start_written, i0));
            let w1 = self.mm_to_units(i1, coord(start_written, i1));
            self.fmt(w0);
            let w0: f64 = self.scratch.parse().unwrap_or(f64::NAN);
            self.fmt(w1);
            let w1: f64 = self.scratch.parse().unwrap_or(f64::NAN);
            if e0 == w0 && e1 == w1 {
                return Ok(false);
            }
        }
        self.begin();
        if plane != self.frame.plane {
            let _ = write!(self.line, "G{plane} ");
            self.frame.plane = plane;
        }
        self.line.push_str(if ccw { "G3" } else { "G2" });
        self.exact_now = if full { None } else { self.exact_at(end) };
        for i in 0..3 {
            if i == normal_axis && !self.allowed(i) {
                continue;
            }
            let force = i != normal_axis || !self.axis_known[i];
            self.axis(i, coord(end, i), force);
        }
        self.exact_now = None;
        const CENTRE: [char; 3] = ['I', 'J', 'K'];
        for i in [0, 1, 2] {
            if i == normal_axis {
                continue;
            }
            let c = if self.frame.arc_absolute {
                coord(a.center, i)
            } else {
                coord(a.center, i) - coord(start_written, i)
            };
            self.push_fine(CENTRE[i], c);
        }
        if turns > 1.0 {
            let _ = write!(self.line, " P{}", turns as u64);
        }
        self.extras(extra);
        self.feed(m);
        self.last_motion = Some(if ccw { 3 } else { 2 });
        self.end_block(out)?;
        Ok(true)
    }

    fn flattened<W: fmt::Write>(&mut self, m: &Move, out: &mut W) -> fmt::Result {
        let mut pts = std::mem::take(&mut self.points);
        pts.clear();
        let start = m.segment.start();
        pts.push(start);
        let chord = self.chord();
        m.segment.flatten(chord, &mut |p| pts.push(p));
        // Extra axes: interpolate from the previous values by cumulative chord length.
        let total: f64 = pts.windows(2).map(|w| w[0].dist(w[1])).sum();
        let e0 = self.program_extra();
        let mut acc = 0.0;
        let mut r = Ok(());
        for k in 1..pts.len() {
            acc += pts[k - 1].dist(pts[k]);
            let extra = m.extra.map(|e1| {
                if k + 1 == pts.len() || total <= 0.0 {
                    e1
                } else {
                    let t = acc / total;
                    std::array::from_fn(|i| e0[i] + (e1[i] - e0[i]) * t)
                }
            });
            r = self.linear(m, pts[k], extra.as_ref(), out);
            if r.is_err() {
                break;
            }
        }
        self.points = pts;
        r
    }
}
