//! The planning grid: the program's moves in arc length ([`PathIndex`]), and the grid
//! points and intervals generated from them lazily, a window at a time ([`GridGen`]).
//!
//! Lines are one straight interval each (their limits are constant along them, and the
//! profile inside a straight interval may accelerate, cruise and decelerate, so no
//! subdivision is needed). Arcs and curves are first cut uniformly in their parameter
//! (halves no longer than about [`MAX_CURVE_DS_MM`], at least [`MIN_CURVE_INTERVALS`] per
//! move, per knot span for NURBS); their arc lengths come from the chords and end tangents
//! of the halves (`arc_from_chord`), the move's total from adaptive quadrature at
//! [`ARCLEN_ACCURACY_MM`] (the last interval takes the remainder).
//!
//! ## Refinement of curved intervals
//! The planner imposes the per-axis acceleration `a_i = u T_i + x K_i` exactly at both
//! ends of a curved interval and at its parameter midpoint ([`IntervalMid`]; the
//! midpoint's speed cap too), with `u` constant and `x = v^2` linear in `s` inside it:
//! all of these are linear in the interval's two end values of `x`. On each half `a_i`
//! then differs from the straight line between its two checked values by three terms,
//! and an interval is bisected until each term is a small share of `A_i` on both halves
//! (together well inside the [`super::ACC_PLANNING_FACTOR`] reserve):
//!
//! 1. the tangent's rotation: `u T_i` leaves the chord of its end values by up to
//!    `|u| (1 - cos(turn / 2))`, kept within [`TANGENT_SHARE`]` A_i` (and the turn within
//!    [`MAX_TURN_DEG`] for the velocity limits);
//! 2. the product of two linear functions: `x K_i` bulges by `|dx dK_i| / 4` with
//!    `dx = 2 u ds`, so `|u| ds |dK_i| / 2 <= `[`PRODUCT_SHARE`]` A_i`, with `|u|` bounded
//!    by the largest tangential acceleration the checked rows can allow ([`u_bound`]);
//!    this term shrinks with the square of the half, so curvature that changes fast over
//!    a short transition needs only a few intervals;
//! 3. curvature that is not linear in `s` inside the half: checked at the half's own
//!    midpoint (the interval's quarter points) against the chord of its end values,
//!    within [`MAX_CURVATURE_BEND`] of the larger of the local curvature and the floor
//!    `min_i A_i / x_env` (the curvature at which a speed `x_env` uses the smallest axis
//!    acceleration; below it `x_env`, not the curvature, limits `x`), so
//!    `x |dK| <= ` that share of `A`. `x_env` bounds `x` on the whole move: the speed cap
//!    `vcap^2`, and reachability: the move's uniform samples are grid points, so `x` is
//!    within its point cap at each, and inside the move it changes by at most `2 U` per
//!    mm (`U = sqrt(sum_i A_i^2)`, the bound of [`u_bound`]), so
//!    `x_env <= min_k cap_k + 2 U len`. On a short, tight transition that is far below
//!    `vcap^2`, and the flanks, where the curvature rises from zero, need fewer octaves
//!    of bisection (linuxcnc_stellabee1, `--method bspline`: 6.7 M grid points became
//!    5.4 M, the cycle time within 0.02 %);
//! 4. in jerk mode, the curvature rate: the jerk caps take it as the finite difference of
//!    the curvature over each interval ([`super::jerk`]), which is its mean there, while
//!    the jerk the setpoints show is `v^3` times its peak. A half whose two halves' rates
//!    differ by `d` is bisected while `x_env^1.5 d / 2 > `[`RATE_BEND_SHARE`]` J_i` and it
//!    is longer than a period's travel at `x_env` (shorter, the finite differences see one
//!    step, and its mean rate times `v^3` exceeds that step's `v^2 dK / T`). Terms
//!    1-3 scale with the acceleration, which is small at a low feed: camotics_tiger at 3.73
//!    mm/s left an S-shaped 0.015 mm transition (curvature +0.6 to -0.5 /mm in Z) as two
//!    intervals, whose mean rates missed its peak (`--jerk 5000` measured 5235 mm/s^3).
//!
//! The midpoint check halves the number of grid intervals against checking the ends
//! only (the halves are what the terms bound), at the price of coarser `x` (linear over
//! the whole interval): on linuxcnc_stellabee1 with `--method bspline` 12.8 M grid points
//! became 6.7 M and the cycle time grew by 0.35 %. Jerk mode keeps its caps at grid
//! points (see [`super::jerk`]), so there each half is an interval of its own.
//!
//! Arcs and helices have constant curvature turning with the swept angle `phi` of a
//! half, so the three terms are `|u| phi^2 / 8`, `|u| phi^2 / 2` and `A phi^2 / 8`:
//! arcs are cut uniformly at the largest sweep keeping all three within their shares
//! ([`arc_step`]), with no refinement.
//!
//! Earlier versions bisected until the curvature vector changed by 0.5 % of its size
//! between interval ends; that resolved the flat ends of every B-spline or trigonometric
//! transition to a few nanometres (400 grid points per corner on butterfly_1000) without
//! bounding curvature bumps inside an interval.
//! Zero-length moves (below [`crate::verify::DEGENERATE_MM`]) are dropped.
//!
//! ## Extra axes
//! Extra axes ride along with the moves, linear in arc length, in *machine* coordinates:
//! a `G92 E0` ([`EventKind::ExtraReset`]) changes the offset between programmed and machine
//! values, not the position, so the setpoints' extra columns stay continuous. A move of
//! extra axes only ([`EventKind::ExtraMove`], a slicer's retract; also a zero-length move
//! that changes them) happens at a stop, X, Y and Z at rest: it takes the time of a
//! trapezoid over the largest axis change at its rate (the rapid rate when it has none)
//! and the smallest X/Y/Z acceleration limit ([`ExtraRest`]). Extra axes have no limits
//! of their own; the report gives their measured speeds and accelerations.

use super::limits::{
    g1_joint_cap_x, junction_cap_x, line_acc, point_cap_x, point_cap_x_kappa, Caps, Interval,
    IntervalMid, NEGLIGIBLE,
};
use super::window::{MoveWindow, Reader, Summary};
use super::{PlanOptions, StopReason};
use crate::geom::{
    arclen_adaptive, curvature_vec_from, ParamCurve, ParamCurveCurvature, ParamCurveDeriv,
    PreparedNurbs, PreparedTrig, Segment, Vec3,
};
use crate::path::{Block, EventKind, ExtraAxes, Move, MoveKind, Toolpath};
use crate::verify::{DEGENERATE_MM, GAP_TOL_MM, TANGENT_TOL_DEG};
use std::sync::mpsc::{Receiver, SyncSender};
use std::sync::Arc;

/// Largest tangent turn (degrees) inside one curved grid interval, whatever the
/// accelerations: a per-axis velocity limit checked at the ends is exceeded inside by at
/// most `1 / cos(turn / 2) - 1` (6e-4), within the [`super::VAXIS_PLANNING_FACTOR`]
/// reserve. The acceleration terms usually allow less (see [`TANGENT_SHARE`]).
pub const MAX_TURN_DEG: f64 = 4.0;
/// Share of the axis acceleration allowed for the tangent's rotation inside an interval
/// (term 1 of the module doc): `|u| (1 - cos(turn / 2)) <= share A`.
pub const TANGENT_SHARE: f64 = 0.001;
/// Longest half of a curved grid interval (mm).
pub const MAX_CURVE_DS_MM: f64 = 0.5;
/// Fewest intervals per curved move (per knot span for NURBS), each checked at its ends
/// and its midpoint. Two, so that a curved move between two stops has a grid point
/// inside it (on one interval `x` is linear, so two ends at rest would leave no motion).
pub const MIN_CURVE_INTERVALS: usize = 2;
/// Most intervals per move (a guard against absurd inputs).
pub const MAX_CURVE_INTERVALS: usize = 1 << 20;
/// Accuracy (mm) of the arc lengths of curved intervals.
pub const ARCLEN_ACCURACY_MM: f64 = 1e-10;
/// Share of the axis acceleration allowed for the bulge of `x K_i` inside an interval
/// (term 2 of the module doc).
pub const PRODUCT_SHARE: f64 = 0.004;
/// Largest distance of the curvature vector at the midpoints of an interval's halves from
/// the
/// chord of its end values, relative to the local curvature or the floor (term 3 of the
/// module doc).
pub const MAX_CURVATURE_BEND: f64 = 0.004;
/// Share of each axis's jerk limit allowed for the curvature rate a grid interval does
/// not resolve (term 4 of the module doc, jerk mode only).
pub const RATE_BEND_SHARE: f64 = 0.01;
/// Smallest parameter step of the interval refinement.
const MIN_PARAM_STEP: f64 = 1e-9;
/// Parameter offset used to read the curvature next to a zero-speed end.
const ZERO_SPEED_PROBE: f64 = 1e-7;

/// What follows a move.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum After {
    /// The next move follows at a joint whose own cap is `x_cap` (`v^2`).
    Continue {
        /// Joint cap on `v^2` (infinite when the joint adds none).
        x_cap: f64,
        /// The joint is a corner passed under the junction-deviation rule.
        blended: bool,
    },
    /// The machine stops at the end of this move.
    Stop {
        /// Why.
        reason: StopReason,
        /// Time at rest before the next move (s).
        dwell_s: f64,
    },
}

/// One move as the planner sees it.
#[derive(Clone, Debug)]
pub struct PlanMove {
    /// Geometry.
    pub segment: Segment,
    /// Rapid or feed.
    pub kind: MoveKind,
    /// Speed cap (mm/s): the feed or rapid rate.
    pub vcap_mm_s: f64,
    /// Arc length of the program before this move (mm).
    pub s0: f64,
    /// Arc length of the move (mm).
    pub len: f64,
    /// Extra-axis values at the start and end, when the program has extra axes.
    pub extra: Option<(ExtraAxes, ExtraAxes)>,
    /// What follows.
    pub after: After,
}

/// One motion of the extra axes at a stop (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExtraMotion {
    /// Start, seconds into the stop.
    pub t0: f64,
    /// Duration (s).
    pub duration: f64,
    /// Machine values before and after.
    pub from: ExtraAxes,
    /// Machine values after.
    pub to: ExtraAxes,
    /// Rate of the axis that moves most (units/s).
    pub v: f64,
    /// Acceleration of that axis (units/s^2).
    pub a: f64,
}

impl ExtraMotion {
    /// A trapezoid from `from` to `to` at rate `v` and acceleration `a`, starting `t0`
    /// seconds into the stop.
    fn new(t0: f64, from: ExtraAxes, to: ExtraAxes, v: f64, a: f64) -> ExtraMotion {
        let d = (0..from.len())
            .map(|i| (to[i] - from[i]).abs())
            .fold(0.0, f64::max);
        let duration = if d <= 0.0 || !(v > 0.0 && a > 0.0) {
            0.0
        } else if d >= v * v / a {
            d / v + v / a
        } else {
            2.0 * (d / a).sqrt()
        };
        ExtraMotion {
            t0,
            duration,
            from,
            to,
            v,
            a,
        }
    }

    /// Share of the motion done `tau` seconds after its start.
    fn share(&self, tau: f64) -> f64 {
        if self.duration <= 0.0 || tau >= self.duration {
            return 1.0;
        }
        if tau <= 0.0 {
            return 0.0;
        }
        let d = (0..self.from.len())
            .map(|i| (self.to[i] - self.from[i]).abs())
            .fold(0.0, f64::max);
        // Cruise speed actually reached, and the distance covered by `tau`.
        let vp = self.v.min((d * self.a).sqrt());
        let ta = vp / self.a;
        let covered = if tau < ta {
            0.5 * self.a * tau * tau
        } else if tau <= self.duration - ta {
            0.5 * vp * ta + vp * (tau - ta)
        } else {
            let r = self.duration - tau;
            d - 0.5 * self.a * r * r
        };
        (covered / d).clamp(0.0, 1.0)
    }
}

/// Extra-axis motions while X, Y and Z rest at the stop at arc length `s`.
#[derive(Clone, Debug, PartialEq)]
pub struct ExtraRest {
    /// Arc length of the stop (mm).
    pub s: f64,
    /// Values when the stop begins (machine coordinates).
    pub start: ExtraAxes,
    /// The motions, in order.
    pub motions: Vec<ExtraMotion>,
}

impl ExtraRest {
    /// Machine values `tau` seconds into the stop.
    pub fn at(&self, tau: f64) -> ExtraAxes {
        let mut v = self.start;
        for m in &self.motions {
            if tau < m.t0 {
                break;
            }
            let f = m.share(tau - m.t0);
            for i in 0..v.len() {
                v[i] = m.from[i] + (m.to[i] - m.from[i]) * f;
            }
        }
        v
    }
}

/// The program's moves in arc length, with the joints classified: the whole program
/// ([`PathIndex::new`]) or a window of a streamed one ([`PathIndex::streamed`]).
#[derive(Clone, Debug)]
pub struct PathIndex {
    /// Moves (zero-length moves dropped) of a whole program; empty when streamed.
    pub moves: Vec<PlanMove>,
    /// The window of a streamed program.
    stream: Option<Arc<MoveWindow>>,
    /// Start point of the program.
    pub start: Vec3,
    /// Events before the first move: `(reason, dwell seconds)`, if any.
    pub lead: Option<(StopReason, f64)>,
    /// Total arc length (mm).
    pub total_len: f64,
    /// Bit mask of the extra axes present ([`crate::path::EXTRA_AXIS_NAMES`]).
    pub extra_axes_mask: u8,
    /// Extra-axis motions at stops, in order of `s`.
    pub rests: Vec<ExtraRest>,
}

fn move_len(seg: &Segment) -> f64 {
    match seg {
        Segment::Line(l) => l.length(),
        Segment::Arc(a) => a.length(),
        // The spline's weights once, not at every node.
        Segment::Trig(c) => arclen_adaptive(&PreparedTrig::new(c), 0.0, 1.0, ARCLEN_ACCURACY_MM),
        // Span by span, split at the knots where the speed's derivatives jump (equal
        // parameter pieces cut spans of non-uniform knots and recurse deep there).
        Segment::Nurbs(n) => match PreparedNurbs::new(n) {
            Some(p) => {
                let br = p.breaks();
                let share = ARCLEN_ACCURACY_MM / (br.len() - 1) as f64;
                br.windows(2)
                    .map(|w| arclen_adaptive(&p, w[0], w[1], share))
                    .sum()
            }
            None => crate::geom::ParamCurveArclen::arclen(n.as_ref(), ARCLEN_ACCURACY_MM),
        },
        _ => {
            let mut s = 0.0;
            let n = spans(seg);
            for j in 0..n {
                s += arclen_adaptive(
                    seg,
                    j as f64 / n as f64,
                    (j + 1) as f64 / n as f64,
                    ARCLEN_ACCURACY_MM,
                );
            }
            s
        }
    }
}

/// Fewest moves for which [`move_lens_and_joints`] starts threads.
const PARALLEL_MIN_MOVES: usize = 4096;

/// For every move of `path`, in order: its [`move_len`], and the [`joint_after`] it with
/// the next move (if any). On up to [`crate::par::MAX_THREADS`] threads: the adaptive
/// quadrature of curved moves and the joints' tangents and curvatures are most of the
/// indexing time, and each is computed alone, so the result does not depend on the number
/// of threads. The joint is the one the index uses when nothing comes between the two
/// moves (no event, no dropped zero-length move).
fn move_lens_and_joints(
    path: &Toolpath,
    opts: &PlanOptions,
    caps: &Caps,
) -> Vec<(f64, Option<After>)> {
    let segs: Vec<&Segment> = path
        .blocks
        .iter()
        .filter_map(|b| match b {
            Block::Move(m) => Some(&m.segment),
            Block::Event(_) => None,
        })
        .collect();
    crate::par::map(segs.len(), PARALLEL_MIN_MOVES, |i| {
        let joint = segs
            .get(i + 1)
            .map(|next| joint_after(segs[i], next, opts, caps));
        (move_len(segs[i]), joint)
    })
}

fn spans(seg: &Segment) -> usize {
    match seg {
        Segment::Nurbs(n) => {
            let mut k: Vec<f64> = n.knots().to_vec();
            k.dedup();
            (k.len().max(2) - 1).max(1)
        }
        _ => 1,
    }
}

/// Curvature vector at `t`, read slightly inside where the parametric speed vanishes.
fn curvature_at(seg: &Segment, t: f64) -> Vec3 {
    let d1 = seg.deriv(t);
    let d2 = seg.deriv2(t);
    if d1.norm_sq() > 1e-18 * d2.norm_sq().max(1e-300) && d1.norm_sq() > 0.0 {
        return seg.curvature_vec(t);
    }
    let tp = if t > 0.5 {
        t - ZERO_SPEED_PROBE
    } else {
        t + ZERO_SPEED_PROBE
    };
    seg.curvature_vec(tp)
}

/// Unit tangent, curvature vector and point at `t` (as [`tangent_at`], [`curvature_at`]
/// and `eval`), from one evaluation of the point and its derivatives where the
/// parametric speed does not vanish.
///
/// `curve` is `seg` itself or an equivalent evaluator of it (a [`PreparedTrig`]).
fn geo_at(seg: &Segment, curve: &impl ParamCurveDeriv, t: f64) -> (Vec3, Vec3, Vec3) {
    let [p, d1, d2] = curve.ders(t);
    let (s1, s2) = (d1.norm_sq(), d2.norm_sq());
    if !(s1 > 1e-18 * s2.max(1e-300) && s1 > 0.0) || t <= 0.0 || t >= 1.0 {
        return (tangent_at(seg, t), curvature_at(seg, t), p);
    }
    let tangent = d1 / s1.sqrt();
    (tangent, curvature_vec_from(d1, d2), p)
}

fn tangent_at(seg: &Segment, t: f64) -> Vec3 {
    if t <= 0.0 {
        return seg.start_tangent().unwrap_or(Vec3::X);
    }
    if t >= 1.0 {
        return seg.end_tangent().unwrap_or(Vec3::X);
    }
    seg.deriv(t).normalized().unwrap_or_else(|| {
        (seg.eval((t + ZERO_SPEED_PROBE).min(1.0)) - seg.eval(t))
            .normalized()
            .unwrap_or(Vec3::X)
    })
}

impl PathIndex {
    /// Indexes `path` under `opts` (which supplies the feed and rapid rates and the joint
    /// rule). `opts` must be valid.
    pub fn new(path: &Toolpath, opts: &PlanOptions) -> PathIndex {
        let caps = caps_of(opts);
        let lens = move_lens_and_joints(path, opts, &caps);
        let mut b = IndexBuilder::new(opts, caps);
        let mut lens = lens.into_iter();
        for block in &path.blocks {
            match block {
                Block::Event(e) => b.event(&e.kind),
                Block::Move(m) => {
                    let (len, joint) = lens.next().expect("one per move");
                    b.push_move(m, len, joint);
                }
            }
        }
        b.end();
        PathIndex {
            moves: b.moves,
            stream: None,
            start: path.start,
            lead: b.lead,
            total_len: b.s,
            extra_axes_mask: path.extra_axes_mask,
            rests: b.rests,
        }
    }
    /// The index of a streamed program whose moves arrive in `window` (see
    /// [`super::window`]); `start` is where the program starts when it has no move.
    pub fn streamed(window: Arc<MoveWindow>, start: Vec3, extra_axes_mask: u8) -> PathIndex {
        PathIndex {
            moves: Vec::new(),
            stream: Some(window),
            start,
            lead: None,
            total_len: 0.0,
            extra_axes_mask,
            rests: Vec::new(),
        }
    }

    /// Move `j` (waiting for it when streamed), `None` past the end.
    #[inline]
    pub fn get(&self, j: usize) -> Option<MoveRef<'_>> {
        match &self.stream {
            None => self.moves.get(j).map(MoveRef::Borrowed),
            Some(w) => w.get(j).map(MoveRef::Shared),
        }
    }

    /// Rest `k` (see [`PathIndex::rests`]) when there is one at or before arc length `s`
    /// (or later); `None` when there is none up to `s` (waiting, when streamed, until
    /// that is known).
    pub fn rest(&self, k: usize, s: f64) -> Option<RestRef<'_>> {
        match &self.stream {
            None => self.rests.get(k).map(RestRef::Borrowed),
            Some(w) => w.rest(k, s).map(RestRef::Shared),
        }
    }

    /// `reader` needs no move below `j` (a streamed program drops them).
    #[inline]
    pub fn release(&self, reader: Reader, j: usize) {
        if let Some(w) = &self.stream {
            w.release(reader, j);
        }
    }

    /// The interpolator needs no rest below `k`.
    pub fn release_rests(&self, k: usize) {
        if let Some(w) = &self.stream {
            w.release_rests(k);
        }
    }

    /// `reader` does not read this index.
    pub fn not_reading(&self, reader: Reader) {
        if let Some(w) = &self.stream {
            w.not_reading(reader);
        }
    }

    /// Whether the program is streamed.
    pub fn is_streamed(&self) -> bool {
        self.stream.is_some()
    }

    /// Whether the program is known to have fewer than `n` moves (a streamed one is
    /// taken as long).
    pub fn shorter_than(&self, n: usize) -> bool {
        self.stream.is_none() && self.moves.len() < n
    }

    /// The events before the first move (waiting for them when streamed).
    pub fn lead(&self) -> Option<(StopReason, f64)> {
        match &self.stream {
            None => self.lead,
            Some(w) => w.lead(),
        }
    }

    /// Where motion starts: the first move's start, or the program's start.
    pub fn start_point(&self) -> Vec3 {
        match &self.stream {
            None => self.moves.first().map_or(self.start, |m| m.segment.start()),
            Some(w) => w.start(self.start),
        }
    }

    /// Moves, total length and end point (waiting for the end when streamed).
    pub fn summary(&self) -> Summary {
        match &self.stream {
            None => Summary {
                moves: self.moves.len(),
                total_len: self.total_len,
                end: self.end_point(),
            },
            Some(w) => w.summary(),
        }
    }

    /// End point of the program.
    pub fn end_point(&self) -> Vec3 {
        match &self.stream {
            None => self.moves.last().map_or(self.start, |m| m.segment.end()),
            Some(w) => w.summary().end,
        }
    }
}

/// Moves a [`IndexFeeder`] indexes at a time: their lengths and joints are computed in
/// parallel as [`PathIndex::new`] does for a whole program.
pub const FEED_BATCH_MOVES: usize = 4096;

/// Indexes a program that arrives block by block into the [`MoveWindow`] of a streamed
/// [`PathIndex`]: each move's length and joint, its stop, extra-axis rests, exactly as
/// [`PathIndex::new`] indexes a whole program (same functions, same order), a batch of
/// [`FEED_BATCH_MOVES`] at a time. The last move indexed is held back until the next one
/// (its joint) or the end is known.
pub struct IndexFeeder<'o> {
    builder: IndexBuilder<'o>,
    window: Arc<MoveWindow>,
    buf: Vec<Block>,
    buf_moves: usize,
    lead_sent: bool,
    /// End of the last move published.
    end: Option<Vec3>,
    published: usize,
}

impl<'o> IndexFeeder<'o> {
    /// A feeder of `window` under `opts` (which must be valid).
    pub fn new(opts: &'o PlanOptions, window: Arc<MoveWindow>) -> Self {
        IndexFeeder {
            builder: IndexBuilder::new(opts, caps_of(opts)),
            window,
            buf: Vec::new(),
            buf_moves: 0,
            lead_sent: false,
            end: None,
            published: 0,
        }
    }

    /// Whether the planner still reads the program (it stops early on a failed write).
    pub fn wanted(&self) -> bool {
        self.window.wanted()
    }

    /// Takes the next block of the program.
    pub fn push(&mut self, block: Block) {
        self.buf_moves += usize::from(matches!(block, Block::Move(_)));
        self.buf.push(block);
        if self.buf_moves > FEED_BATCH_MOVES {
            self.index_buffered(false);
        }
    }

    /// Indexes the buffered blocks (all of them at the end, else up to the last move,
    /// which stays as the next batch's first and the joint partner of the one before).
    fn index_buffered(&mut self, at_end: bool) {
        let keep_from = if at_end {
            self.buf.len()
        } else {
            self.buf
                .iter()
                .rposition(|b| matches!(b, Block::Move(_)))
                .unwrap_or(self.buf.len())
        };
        let segs: Vec<&Segment> = self
            .buf
            .iter()
            .filter_map(|b| match b {
                Block::Move(m) => Some(&m.segment),
                Block::Event(_) => None,
            })
            .collect();
        let n = if at_end { segs.len() } else { segs.len() - 1 };
        let (opts, caps) = (self.builder.opts, self.builder.caps);
        let lens = crate::par::map(n, PARALLEL_MIN_MOVES, |i| {
            let joint = segs
                .get(i + 1)
                .map(|next| joint_after(segs[i], next, opts, &caps));
            (move_len(segs[i]), joint)
        });
        drop(segs);
        let rest = self.buf.split_off(keep_from);
        let mut lens = lens.into_iter();
        for block in std::mem::replace(&mut self.buf, rest) {
            match block {
                Block::Event(e) => self.builder.event(&e.kind),
                Block::Move(m) => {
                    let (len, joint) = lens.next().expect("one per move");
                    self.builder.push_move(&m, len, joint);
                }
            }
        }
        self.buf_moves = usize::from(!at_end && !self.buf.is_empty());
        // The last move stays: its joint, or at the end the stop after it, may change it.
        self.publish(false);
    }

    /// Hands the indexed moves (all at the end, else all but the last, whose joint may
    /// still change) and the rests collected to the window.
    fn publish(&mut self, all: bool) {
        let b = &mut self.builder;
        if !self.lead_sent && (all || !b.moves.is_empty()) {
            self.window.set_lead(b.lead);
            self.lead_sent = true;
        }
        let n = b.moves.len();
        let upto = if all { n } else { b.held_back_from() };
        if let Some(m) = b.moves[..upto].last() {
            self.end = Some(m.segment.end());
        }
        self.published += upto;
        let moves: Vec<PlanMove> = b.moves.drain(..upto).collect();
        let known_to = moves.last().map(|m| m.s0 + m.len);
        self.window
            .push(moves, std::mem::take(&mut b.rests), known_to);
    }

    /// The program ended: indexes what is left and closes the window. `start` is where
    /// the program starts (its end when it has no move).
    pub fn finish(mut self, start: Vec3) {
        self.index_buffered(true);
        self.builder.end();
        self.publish(true);
        self.window.finish(Summary {
            moves: self.published,
            total_len: self.builder.s,
            end: self.end.unwrap_or(start),
        });
    }
}

/// A move of a [`PathIndex`]: borrowed from a whole program's index or shared from a
/// streamed one's window.
#[derive(Clone, Debug)]
pub enum MoveRef<'a> {
    /// In a whole program's index.
    Borrowed(&'a PlanMove),
    /// In a streamed program's window.
    Shared(Arc<PlanMove>),
}

impl std::ops::Deref for MoveRef<'_> {
    type Target = PlanMove;
    #[inline]
    fn deref(&self) -> &PlanMove {
        match self {
            MoveRef::Borrowed(m) => m,
            MoveRef::Shared(m) => m,
        }
    }
}

/// A rest of a [`PathIndex`] (as [`MoveRef`]).
#[derive(Clone, Debug)]
pub enum RestRef<'a> {
    /// In a whole program's index.
    Borrowed(&'a ExtraRest),
    /// In a streamed program's window.
    Shared(Arc<ExtraRest>),
}

impl std::ops::Deref for RestRef<'_> {
    type Target = ExtraRest;
    fn deref(&self) -> &ExtraRest {
        match self {
            RestRef::Borrowed(r) => r,
            RestRef::Shared(r) => r,
        }
    }
}

/// The state of [`PathIndex::new`] while it walks the program's blocks.
struct IndexBuilder<'o> {
    opts: &'o PlanOptions,
    caps: Caps,
    moves: Vec<PlanMove>,
    /// The stop being collected before the next move (reason, time at rest).
    pending: Option<(StopReason, f64)>,
    lead: Option<(StopReason, f64)>,
    s: f64,
    /// Extra axes: programmed values and the machine offset (`G92 E`).
    prog: Option<ExtraAxes>,
    offset: ExtraAxes,
    extra_acc: f64,
    rests: Vec<ExtraRest>,
    rest: Option<ExtraRest>,
    /// Number of the last move indexed, and its joint with the move numbered next.
    prev_no: Option<usize>,
    prev_joint: Option<After>,
    /// Number of the next move block (zero-length ones included).
    move_no: usize,
    /// Jerk mode: the recent G1 joints with a curvature step or a kink since the last
    /// stop, for [`Self::close_joints`].
    recent_steps: std::collections::VecDeque<CloseJoint>,
}

impl<'o> IndexBuilder<'o> {
    fn new(opts: &'o PlanOptions, caps: Caps) -> Self {
        IndexBuilder {
            opts,
            caps,
            moves: Vec::new(),
            pending: None,
            lead: None,
            s: 0.0,
            prog: None,
            offset: [0.0; 7],
            extra_acc: opts.acc_mm_s2.iter().copied().fold(f64::INFINITY, f64::min),
            rests: Vec::new(),
            rest: None,
            prev_no: None,
            prev_joint: None,
            move_no: 0,
            recent_steps: std::collections::VecDeque::new(),
        }
    }

    /// The program ended: the stop collected last ends the last move (or, with no move,
    /// is the lead), and its rest is kept.
    fn end(&mut self) {
        if let Some((_, d)) = self.pending {
            match self.moves.last_mut() {
                Some(m) => {
                    m.after = After::Stop {
                        reason: StopReason::End,
                        dwell_s: d,
                    }
                }
                None => self.lead = self.pending,
            }
        }
        self.rests.extend(self.rest.take());
    }

    fn machine(&self, v: ExtraAxes) -> ExtraAxes {
        std::array::from_fn(|i| v[i] + self.offset[i])
    }

    fn add_stop(&mut self, r: StopReason, d: f64) {
        self.pending = Some(match self.pending {
            Some((pr, pd)) => (
                if pr == StopReason::Dwell || r == StopReason::Dwell {
                    StopReason::Dwell
                } else {
                    StopReason::Event
                },
                pd + d,
            ),
            None => (r, d),
        });
    }

    /// Appends an extra-axis motion to the stop being collected.
    fn extra_motion(&mut self, from: ExtraAxes, to: ExtraAxes, rate: f64) {
        let t0 = self.pending.map_or(0.0, |p| p.1);
        let m = ExtraMotion::new(t0, from, to, rate, self.extra_acc);
        let s = self.s;
        self.rest
            .get_or_insert_with(|| ExtraRest {
                s,
                start: from,
                motions: Vec::new(),
            })
            .motions
            .push(m);
        self.add_stop(StopReason::Event, m.duration);
    }

    fn event(&mut self, kind: &EventKind) {
        match *kind {
            EventKind::Dwell(t) => {
                let t = if t.is_finite() && t > 0.0 { t } else { 0.0 };
                self.add_stop(StopReason::Dwell, t);
            }
            EventKind::ExtraReset { to } => {
                if let Some(p) = self.prog {
                    let m = self.machine(p);
                    self.offset = std::array::from_fn(|i| m[i] - to[i]);
                }
                self.prog = Some(to);
                self.add_stop(StopReason::Event, 0.0);
            }
            EventKind::ExtraMove { to, feed_per_s } => {
                let from = self.machine(crate::path::extra_start_of(self.prog, to));
                let rate = feed_per_s
                    .filter(|f| *f > 0.0 && f.is_finite())
                    .unwrap_or_else(|| self.opts.rapid());
                self.prog = Some(to);
                self.extra_motion(from, self.machine(to), rate);
            }
            _ => self.add_stop(StopReason::Event, 0.0),
        }
    }

    /// Indexes the next move, of length `len` and joint `joint` with the move block that
    /// follows it (if any).
    fn push_move(&mut self, m: &Move, len: f64, joint: Option<After>) {
        let this_no = self.move_no;
        self.move_no += 1;
        let opts = self.opts;
        let extra_start = m.extra_start(self.prog).map(|v| self.machine(v));
        let extra_end = m.extra.map(|v| self.machine(v));
        self.prog = m.extra.or(self.prog);
        if len.is_nan() || len <= DEGENERATE_MM || !len.is_finite() {
            // A zero-length move that changes the extra axes moves them alone.
            if let (Some(a), Some(b)) = (extra_start, extra_end) {
                if a != b {
                    let rate = match m.kind {
                        MoveKind::Rapid => None,
                        MoveKind::Feed => m.feed_mm_s,
                    }
                    .filter(|f| *f > 0.0 && f.is_finite())
                    .unwrap_or_else(|| opts.rapid());
                    self.extra_motion(a, b, rate);
                }
            }
            return;
        }
        let vcap = match m.kind {
            MoveKind::Rapid => opts.rapid(),
            MoveKind::Feed => m
                .feed_mm_s
                .filter(|f| *f > 0.0 && f.is_finite())
                .map_or(opts.feed_mm_s, |f| f.min(opts.feed_mm_s)),
        };
        let (prev_no, caps) = (self.prev_no, &self.caps);
        if let Some(prev) = self.moves.last_mut() {
            prev.after = match self.pending.take() {
                Some((reason, dwell_s)) => After::Stop { reason, dwell_s },
                None => match prev_no {
                    // The joint computed with the lengths.
                    Some(p) if p + 1 == this_no => self.prev_joint.expect("a move follows"),
                    _ => joint_after(&prev.segment, &m.segment, opts, caps),
                },
            };
        } else if let Some(p) = self.pending.take() {
            self.lead = Some(p);
        }
        self.rests.extend(self.rest.take());
        self.moves.push(PlanMove {
            segment: m.segment.clone(),
            kind: m.kind,
            vcap_mm_s: vcap,
            s0: self.s,
            len,
            extra: extra_end.zip(extra_start).map(|(e, st)| (st, e)),
            after: After::Stop {
                reason: StopReason::End,
                dwell_s: 0.0,
            },
        });
        self.prev_no = Some(this_no);
        self.prev_joint = joint;
        self.s += len;
        self.close_joints();
    }

    /// The first of the moves a streamed index holds back: the last move (its joint is not
    /// known yet) and, in jerk mode, every move that ends within the reach of
    /// [`Self::close_joints`] before the last move's start (their caps may still change).
    fn held_back_from(&self) -> usize {
        let Some(last) = self.moves.last() else {
            return 0;
        };
        let reach = self.caps.jerk.map_or(0.0, |j| {
            JOINT_STENCIL_PERIODS * j.period_s * self.opts.top_speed()
        });
        // The next joint is at the last move's end; a move ending before `from` is out
        // of its reach.
        let from = last.s0 + last.len - reach - DEGENERATE_MM;
        self.moves
            .iter()
            .position(|m| m.s0 + m.len >= from)
            .unwrap_or(self.moves.len() - 1)
    }

    /// Jerk mode: caps the speed where G1 joints with curvature steps or kinks lie closer
    /// together than the finite-difference stencil reaches. A step's share of the
    /// finite-difference jerk is `w v^2 step_i / T` with a weight
    /// `0 <= w <= `[`super::jerk::FD_STEP_FRACTION`] that depends on where it falls in the
    /// stencil's three periods, so steps of one sign within `3 v T` of each other add up
    /// (a short line between two blends: linuxcnc_51MeanderAve had a 0.001 mm one, its
    /// steps of -1.25 and -3.61 /mm in y read together as 5183 mm/s^3 at a 5000 limit),
    /// while steps of opposite signs (into and out of a corner arc) partly cancel: per
    /// axis the larger of the positive and the negative steps' sums bounds them. A kink's
    /// weight changes sign across the stencil, so kinks add up in magnitude
    /// ([`CloseJoint::group_cap_x`]). The joint just indexed (between the last two moves)
    /// is checked against the earlier ones within that reach at the speed its own cap
    /// allows; when others are there, the moves between them get the group's cap (it
    /// bounds the speed at every joint in between) and the earliest joint's cap is
    /// lowered to it too. A stop or a junction-blended corner ends a group.
    fn close_joints(&mut self) {
        let Some(jerk) = self.caps.jerk else {
            return;
        };
        let n = self.moves.len();
        // A stop or a corner blended under the junction deviation (a velocity jump the
        // plan reports rather than limits, see `super::jerk`) ends the group.
        let x_own = match (n >= 2).then(|| self.moves[n - 2].after) {
            Some(After::Continue {
                x_cap,
                blended: false,
            }) => x_cap,
            _ => {
                self.recent_steps.clear();
                return;
            }
        };
        let (a, b) = (&self.moves[n - 2], &self.moves[n - 1]);
        let (ka, kb) = (curvature_at(&a.segment, 1.0), curvature_at(&b.segment, 0.0));
        let (ta, tb) = (tangent_at(&a.segment, 1.0), tangent_at(&b.segment, 0.0));
        let joint = CloseJoint {
            s: b.s0,
            step: kb - ka,
            kink: abs_max(tb - ta, Vec3::ZERO),
            t: abs_max(ta, tb),
            k: abs_max(ka, kb),
            rate: abs_max(end_rate(&a.segment, true), end_rate(&b.segment, false)),
        };
        let v_own = a.vcap_mm_s.max(b.vcap_mm_s).min(x_own.sqrt());
        let reach = JOINT_STENCIL_PERIODS * jerk.period_s * v_own;
        // Joints farther back than any speed's reach are forgotten.
        let forget = JOINT_STENCIL_PERIODS * jerk.period_s * a.vcap_mm_s.max(b.vcap_mm_s);
        while let Some(front) = self.recent_steps.front() {
            if joint.s - front.s > forget {
                self.recent_steps.pop_front();
            } else {
                break;
            }
        }
        if joint.step.norm() <= NEGLIGIBLE && joint.kink.norm() <= NEGLIGIBLE {
            return;
        }
        let close: Vec<CloseJoint> = self
            .recent_steps
            .iter()
            .copied()
            .filter(|c| joint.s - c.s <= reach)
            .chain([joint])
            .collect();
        self.recent_steps.push_back(joint);
        let first = close[0].s;
        if close.len() < 2 {
            return;
        }
        let x = CloseJoint::group_cap_x(&close, &jerk);
        for m in self.moves[..n - 1].iter_mut().rev() {
            if let After::Continue { x_cap, .. } = &mut m.after {
                *x_cap = x_cap.min(x);
            }
            if m.s0 < first - DEGENERATE_MM {
                // The move that ends at the earliest joint: only that joint is capped.
                break;
            }
            m.vcap_mm_s = m.vcap_mm_s.min(x.sqrt());
        }
    }
}

/// A G1 joint remembered by [`IndexBuilder::close_joints`]: its arc length, curvature step
/// and tangent kink (componentwise magnitude), and the componentwise largest tangent,
/// curvature and curvature rate of its two sides.
#[derive(Clone, Copy, Debug)]
struct CloseJoint {
    s: f64,
    step: Vec3,
    kink: Vec3,
    t: Vec3,
    k: Vec3,
    rate: Vec3,
}

impl CloseJoint {
    /// The cap on `v^2` of joints one third difference may see together: the steps of
    /// one sign summed per axis (their weights are all positive), the kinks summed in
    /// magnitude (a velocity jump's weight changes sign across the stencil, at most one
    /// period either way), the largest tangent, curvature and rate of any of them.
    fn group_cap_x(group: &[CloseJoint], jerk: &super::jerk::JerkCaps) -> f64 {
        let step = one_sign_sum(group.iter().map(|c| c.step));
        let kink = group.iter().fold(Vec3::ZERO, |acc, c| acc + c.kink);
        let max =
            |f: fn(&CloseJoint) -> Vec3| group.iter().fold(Vec3::ZERO, |acc, c| abs_max(acc, f(c)));
        jerk.joint_speed_cap_x(max(|c| c.t), max(|c| c.k), max(|c| c.rate), step, kink)
    }
}

/// Per axis, the larger of the sums of the positive and of the negative components.
fn one_sign_sum(steps: impl Iterator<Item = Vec3>) -> Vec3 {
    let (mut pos, mut neg) = (Vec3::ZERO, Vec3::ZERO);
    for st in steps {
        pos += st.max(Vec3::ZERO);
        neg -= st.min(Vec3::ZERO);
    }
    pos.max(neg)
}

/// Periods a third difference spans: curvature steps this close (in time) are seen
/// together ([`IndexBuilder::close_joints`]).
const JOINT_STENCIL_PERIODS: f64 = 3.0;

/// The caps the planner uses for `opts`.
pub fn caps_of(opts: &PlanOptions) -> Caps {
    // Jerk mode: the curvature term's share of the acceleration limits is a speed cap
    // at each point ([`super::jerk::JerkCaps::curvature_cap_x`]).
    Caps {
        jerk: opts.jerk_caps(),
        acc: opts.acc_mm_s2.map(|a| super::planned_acc(a, opts.period_s)),
        vaxis: opts
            .vaxis_mm_s
            .map(|v| v.map(|x| super::planned_vaxis(x, opts.period_s))),
        period_s: opts.period_s,
        chord_error_mm: opts.chord_error_mm,
    }
}

fn joint_after(a: &Segment, b: &Segment, opts: &PlanOptions, caps: &Caps) -> After {
    if a.end().dist(b.start()) > GAP_TOL_MM {
        return After::Stop {
            reason: StopReason::Gap,
            dwell_s: 0.0,
        };
    }
    let ta = tangent_at(a, 1.0);
    let tb = tangent_at(b, 0.0);
    if ta.angle_to(tb).to_degrees() > TANGENT_TOL_DEG {
        return match opts.junction_dev_mm {
            Some(dev) => {
                let x = junction_cap_x(ta, tb, dev, caps);
                if x > 0.0 {
                    After::Continue {
                        x_cap: x,
                        blended: true,
                    }
                } else {
                    After::Stop {
                        reason: StopReason::Corner,
                        dwell_s: 0.0,
                    }
                }
            }
            None => After::Stop {
                reason: StopReason::Corner,
                dwell_s: 0.0,
            },
        };
    }
    let (ka, kb) = (curvature_at(a, 1.0), curvature_at(b, 0.0));
    let jerk_cap = caps.jerk.map_or(f64::INFINITY, |j| {
        j.joint_speed_cap_x(
            abs_max(ta, tb),
            abs_max(ka, kb),
            abs_max(end_rate(a, true), end_rate(b, false)),
            kb - ka,
            tb - ta,
        )
    });
    After::Continue {
        x_cap: g1_joint_cap_x(ka, kb, caps).min(jerk_cap),
        blended: false,
    }
}

/// Componentwise largest magnitude.
fn abs_max(a: Vec3, b: Vec3) -> Vec3 {
    Vec3::new(
        a[0].abs().max(b[0].abs()),
        a[1].abs().max(b[1].abs()),
        a[2].abs().max(b[2].abs()),
    )
}

/// Parameter step of the curvature-rate probe at a move's end.
const RATE_PROBE_PARAM: f64 = 1e-4;

/// Curvature rate `dK/ds` (1/mm^2) at the end (`at_end`) or start of a move, by a finite
/// difference over the last (first) [`RATE_PROBE_PARAM`] of its parameter.
fn end_rate(seg: &Segment, at_end: bool) -> Vec3 {
    if matches!(seg, Segment::Line(_)) {
        return Vec3::ZERO;
    }
    let (a, b) = if at_end {
        (1.0 - RATE_PROBE_PARAM, 1.0)
    } else {
        (0.0, RATE_PROBE_PARAM)
    };
    let ds = crate::geom::step_arclen::step_arclen(seg, a, b);
    if ds > 0.0 {
        (curvature_at(seg, b) - curvature_at(seg, a)) / ds
    } else {
        Vec3::ZERO
    }
}

/// A grid point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridPoint {
    /// Arc length (mm).
    pub s: f64,
    /// Static cap on `v^2`.
    pub x_cap: f64,
    /// The geometric cap on `v^2` (the static cap without a stop's zero), the source of
    /// the jerk mode's dilated caps.
    pub x_src: f64,
    /// The machine stops here (a window end).
    pub stop: Option<(StopReason, f64)>,
}

/// Bound on the tangential acceleration `|u|` (mm/s^2) the row at an end of a curved
/// interval with unit tangent `t` can allow. The row holds `a_j = u T_j + x K_j` within
/// `|a_j| <= A_j` for every axis, and the curvature vector is normal to the tangent
/// (`T . K = 0`, `|T| = 1`), so `u = T . a` and `|u| <= sum_j |T_j| A_j`, whatever the
/// speed and the curvature: `A_j` on a path along axis `j`, and never more than
/// `|A| = sqrt(sum_j A_j^2)` (`u_global`). The bound is taken for any tangent within
/// [`MAX_TURN_DEG`] of `t` (a change `e` of the unit tangent adds at most
/// `|e| |A| <= turn |A|`).
pub fn u_bound(t: Vec3, caps: &Caps) -> f64 {
    TurnBounds::new(caps).u_bound(t)
}

/// What [`u_bound`] and [`TurnBounds::cos_max_turn_at`] take from the caps, computed once
/// per refined move rather than at every check (the same operations, so the same values).
#[derive(Clone, Copy, Debug)]
struct TurnBounds {
    acc: [f64; 3],
    /// Smallest axis acceleration.
    a_min: f64,
    /// [`u_global`].
    global: f64,
    /// `turn |A|` of [`u_bound`].
    turn_allowance: f64,
    /// Cosine of [`MAX_TURN_DEG`].
    cos_max_turn: f64,
}

impl TurnBounds {
    fn new(caps: &Caps) -> TurnBounds {
        let global = u_global(caps);
        TurnBounds {
            acc: caps.acc,
            a_min: caps.acc.iter().copied().fold(f64::INFINITY, f64::min),
            global,
            turn_allowance: MAX_TURN_DEG.to_radians() * global,
            cos_max_turn: MAX_TURN_DEG.to_radians().cos(),
        }
    }

    /// [`u_bound`].
    #[inline]
    fn u_bound(&self, t: Vec3) -> f64 {
        let a = self.acc;
        let along = t[0].abs() * a[0] + t[1].abs() * a[1] + t[2].abs() * a[2];
        (along + self.turn_allowance).min(self.global)
    }

    /// Cosine of the largest tangent turn of a curve interval starting with unit tangent
    /// `t`: term 1 of the module doc with the local [`u_bound`], the turn at most
    /// [`MAX_TURN_DEG`]. An interval is within it when its end tangents' dot product is at
    /// least this (no inverse trigonometry on the hot path).
    #[inline]
    fn cos_max_turn_at(&self, t: Vec3) -> f64 {
        let u = self.u_bound(t) / self.a_min;
        // 1 - cos(turn / 2) <= share / u: cos(turn / 2) >= c, so cos(turn) >= 2 c^2 - 1.
        let c = (1.0 - TANGENT_SHARE / u).clamp(0.0, 1.0);
        (2.0 * c * c - 1.0).max(self.cos_max_turn)
    }
}

/// Bound on the tangential acceleration `|u|` (mm/s^2) on any curved interval: [`u_bound`]
/// whatever the tangent, `|A| = sqrt(sum_j A_j^2)` (Cauchy-Schwarz on `T . a`).
fn u_global(caps: &Caps) -> f64 {
    let a = caps.acc;
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// Largest swept angle (radians) of an arc interval (see the module doc), with `|u|`
/// at its global bound [`u_bound`] (the tangent of an arc turns).
pub fn arc_step(caps: &Caps) -> f64 {
    let a_min = caps.acc.iter().copied().fold(f64::INFINITY, f64::min);
    let u = u_global(caps) / a_min;
    let by_tangent = (8.0 * TANGENT_SHARE / u).sqrt();
    let by_product = (2.0 * PRODUCT_SHARE / u).sqrt();
    let by_bend = (8.0 * MAX_CURVATURE_BEND).sqrt();
    by_tangent
        .min(by_product)
        .min(by_bend)
        .min(MAX_TURN_DEG.to_radians())
}

/// Per-axis velocity over a whole interval: both of its ends take the cap of the largest
/// tangent component inside it (the point caps alone let `v |T_i|` bulge between two
/// binding ends). `mv` are one move's intervals with their end caps; `start_cap` the cap at its start.
fn vaxis_caps(mv: &mut [(Interval, f64)], v: &[f64; 3], start_cap: &mut f64) {
    let n = mv.len();
    for k in 0..n {
        let c = vaxis_interval_cap(&mv[k].0, v);
        if k == 0 {
            *start_cap = start_cap.min(c);
        } else {
            mv[k - 1].1 = mv[k - 1].1.min(c);
        }
        mv[k].1 = mv[k].1.min(c);
    }
}

/// Jerk caps at every point: its curvature, and the curvature rate (finite difference
/// over each interval) of the intervals beside it. `mv` are one move's intervals (at least one) with their end caps; `start_cap` the
/// cap at its start.
fn jerk_caps(mv: &mut [(Interval, f64)], j: &super::jerk::JerkCaps, start_cap: &mut f64) {
    let n = mv.len();
    let rates: Vec<Vec3> = mv.iter().map(|(iv, _)| (iv.k1 - iv.k0) / iv.ds).collect();
    let rate = |i: usize| rates[i];
    for p in 0..=n {
        let r = abs_max(
            p.checked_sub(1).map_or(Vec3::ZERO, rate),
            if p < n { rate(p) } else { Vec3::ZERO },
        );
        let k = if p == 0 { mv[0].0.k0 } else { mv[p - 1].0.k1 };
        // The largest tangent components of the two intervals' ends.
        let t = abs_max(
            p.checked_sub(1)
                .map_or(Vec3::ZERO, |i| abs_max(mv[i].0.t0, mv[i].0.t1)),
            mv.get(p).map_or(Vec3::ZERO, |iv| abs_max(iv.0.t0, iv.0.t1)),
        );
        let c = j.speed_cap_x(t, k, r, Vec3::ZERO);
        if p == 0 {
            *start_cap = start_cap.min(c);
        } else {
            mv[p - 1].1 = mv[p - 1].1.min(c);
        }
    }
}

/// Cap on `x = v^2` from the per-axis velocity limits `v` over a whole curved interval: a
/// tangent component turning by `phi` between two checks exceeds the larger of their
/// values by at most the factor `1 / cos(phi / 2)` between them.
fn vaxis_interval_cap(iv: &Interval, v: &[f64; 3]) -> f64 {
    let (turn, tmax) = match &iv.mid {
        Some(m) => (
            iv.t0.angle_to(m.t).max(m.t.angle_to(iv.t1)),
            abs_max(abs_max(iv.t0, m.t), iv.t1),
        ),
        None => (iv.t0.angle_to(iv.t1), abs_max(iv.t0, iv.t1)),
    };
    let grow = 1.0 / (0.5 * turn).cos();
    let mut x = f64::INFINITY;
    for i in 0..3 {
        let t = tmax[i] * grow;
        if t > NEGLIGIBLE {
            x = x.min((v[i] / t).powi(2));
        }
    }
    x
}

/// Arc length of a piece of curve from its chord and the cosine `cos_turn` of the angle
/// between its end tangents, as on a circular arc: `chord (turn/2) / sin(turn/2)`, i.e.
/// `chord asin(x) / x` with `x = sin(turn/2) = sqrt((1 - cos_turn) / 2)`. For the grid's
/// intervals (turn at most [`MAX_TURN_DEG`]) the whole correction is below 2e-5 of the
/// chord and its error of a higher order; the move's last interval takes the remainder of
/// the move's exact length, so the grid never drifts from the path's arc length.
fn arc_from_chord(chord: f64, cos_turn: f64) -> f64 {
    let x2 = (0.5 * (1.0 - cos_turn)).clamp(0.0, 1.0);
    if x2 < ARC_SERIES_MAX_X2 {
        // asin(x)/x = 1 + x^2/6 + 3 x^4/40 + 5 x^6/112 + O(x^8): the next term is below
        // 4e-10 of the chord here.
        chord * (1.0 + x2 * (1.0 / 6.0 + x2 * (3.0 / 40.0 + x2 * (5.0 / 112.0))))
    } else {
        let x = x2.sqrt();
        chord * x.asin() / x
    }
}

/// Largest `sin^2(turn/2)` for which [`arc_from_chord`] uses its series.
const ARC_SERIES_MAX_X2: f64 = 0.01;

/// Geometry sample: parameter, unit tangent, curvature vector, point, curvature (the
/// norm of the curvature vector, used by several checks).
type Sample = (f64, Vec3, Vec3, Vec3, f64);

/// Grid samples of a curved move: `n0` uniform intervals, each taken as two halves
/// around its parameter midpoint, bisected (when `split`) until both halves keep the
/// three terms of the module doc within their shares. `geo` gives the unit tangent,
/// curvature vector and point at a parameter. Returns `2 N + 1` samples for the `N`
/// accepted intervals: their ends at even indices (first `t = 0`, last `t = 1`) and their
/// midpoints at odd ones.
fn refine(
    n0: usize,
    split: bool,
    vcap_mm_s: f64,
    len_mm: f64,
    caps: &Caps,
    geo: &impl Fn(f64) -> (Vec3, Vec3, Vec3),
) -> Vec<Sample> {
    let sample = |t: f64| {
        let (tt, kk, p) = geo(t);
        (t, tt, kk, p, kk.norm())
    };
    let bounds = TurnBounds::new(caps);
    let a_min = bounds.a_min;
    let mut params: Vec<Sample> = Vec::with_capacity(2 * n0 + 1);
    params.push(sample(0.0));
    // Pending right ends, with the interval's midpoint sample when already known.
    let mut stack: Vec<(Sample, Option<Sample>)> = (1..=n0)
        .rev()
        .map(|i| (sample(i as f64 / n0 as f64), None))
        .collect();
    // Reachability: the uniform samples are grid points, so `x` is within its point cap
    // there, and inside the move it changes by at most `2 U` per mm of arc.
    let x_reach = stack
        .iter()
        .map(|(s, _)| s)
        .chain(params.iter())
        .map(|s| point_cap_x_kappa(s.1, s.2, s.4, vcap_mm_s, caps))
        .fold(f64::INFINITY, f64::min)
        + 2.0 * bounds.global * len_mm;
    let x_env = (vcap_mm_s * vcap_mm_s).min(x_reach);
    let k_floor = if x_env > 0.0 && x_env.is_finite() {
        a_min / x_env
    } else {
        0.0
    };
    // Terms 1 and 2 on one half.
    let turn_or_product = |l: &Sample, r: &Sample| {
        if l.1.dot(r.1) < bounds.cos_max_turn_at(l.1) {
            return true;
        }
        // Term 2: |u| ds |dK_i| / 2 <= share A_i (ds from the chord, a lower bound of the
        // arc that is within 1e-4 of it at the turn bound).
        let ds = l.3.dist(r.3);
        let dk = r.2 - l.2;
        let half_u = 0.5 * bounds.u_bound(l.1);
        (0..3).any(|i| half_u * ds * dk[i].abs() > PRODUCT_SHARE * caps.acc[i])
    };
    // Term 3 on one half: the curvature at its midpoint `q` against the chord of its end
    // values, at the sample's share of the arc length (the parameter is not proportional
    // to it; chords measure it within the turn bound).
    let bent = |l: &Sample, r: &Sample, q: &Sample| {
        let kref = l.4.max(r.4).max(q.4).max(k_floor);
        let lim = MAX_CURVATURE_BEND * kref + 1e-12;
        let (a, b) = (l.3.dist(q.3), q.3.dist(r.3));
        let f = if a + b > 0.0 { a / (a + b) } else { 0.5 };
        (q.2 - (l.2 * (1.0 - f) + r.2 * f)).norm() > lim
    };
    // Term 4 on one half (jerk mode): the curvature rates of its two halves, against the
    // jerk `x_env^1.5` times their difference makes.
    let v3 = x_env.max(0.0).powf(1.5);
    let rate_room = caps
        .jerk
        .as_ref()
        .filter(|_| v3.is_finite() && v3 > 0.0)
        .map(|j| j.jerk_mm_s3.map(|ji| RATE_BEND_SHARE * ji / v3));
    // A half shorter than a period's travel is one step to the finite differences: its
    // rate is not resolved further (the mean over it already exceeds the step it makes).
    let rate_min_ds = x_env.max(0.0).sqrt() * caps.period_s;
    let rate_bent = |l: &Sample, r: &Sample, q: &Sample| {
        let Some(room) = rate_room else {
            return false;
        };
        let (a, b) = (l.3.dist(q.3), q.3.dist(r.3));
        if a <= 0.0 || b <= 0.0 || a + b < rate_min_ds {
            return false;
        }
        let d = (q.2 - l.2) / a - (r.2 - q.2) / b;
        (0..3).any(|i| 0.5 * d[i].abs() > room[i])
    };
    while let Some(&(right, known_mid)) = stack.last() {
        let left = *params.last().expect("non-empty");
        let (t0, t1) = (left.0, right.0);
        let mid = known_mid.unwrap_or_else(|| sample(0.5 * (t0 + t1)));
        let can_split = split
            && params.len() / 2 + stack.len() < MAX_CURVE_INTERVALS
            && t1 - t0 > MIN_PARAM_STEP;
        let mut bad = false;
        let (mut q1, mut q3) = (None, None);
        if can_split {
            bad = turn_or_product(&left, &mid) || turn_or_product(&mid, &right);
            if !bad {
                let a = sample(t0 + 0.25 * (t1 - t0));
                let b = sample(t0 + 0.75 * (t1 - t0));
                bad = bent(&left, &mid, &a)
                    || bent(&mid, &right, &b)
                    || rate_bent(&left, &mid, &a)
                    || rate_bent(&mid, &right, &b);
                (q1, q3) = (Some(a), Some(b));
            }
        }
        if bad {
            // Bisect: the right half keeps `right` with `q3` as its midpoint; the left half
            // ends at `mid` with `q1` as its midpoint.
            stack.last_mut().expect("non-empty").1 = q3;
            stack.push((mid, q1));
        } else {
            params.push(mid);
            params.push(right);
            stack.pop();
        }
    }
    params
}

/// The grids of consecutive moves, flat: for each move the cap of its start point and the
/// end of its intervals in `intervals`, each interval with the cap of its end point. A
/// batch is two allocations however many moves it holds: vectors per move, allocated on
/// the producing thread and freed on the planning one, made the two threads contend for
/// the allocator's lock (most of the futex calls of a run).
#[derive(Clone, Debug, Default)]
pub struct GridBatch {
    /// Per move: the start cap and the end (exclusive) of its intervals.
    pub moves: Vec<(f64, usize)>,
    /// The intervals of all the batch's moves, in order, with their end caps.
    pub intervals: Vec<(Interval, f64)>,
}

/// Moves per message of [`GridGen::produce`].
pub const GRID_BATCH_MOVES: usize = 256;
/// Intervals after which a message of [`GridGen::produce`] is sent even with fewer than
/// [`GRID_BATCH_MOVES`] moves: a long curve has thousands (a NURBS run of the `nurbs`
/// method), and the queue's memory is in its intervals (about 160 bytes each).
pub const GRID_BATCH_INTERVALS: usize = 4096;
/// Messages [`GridGen::produce`] may run ahead of the planner (bounds the memory held).
pub const GRID_QUEUE_BATCHES: usize = 16;

/// Lazily generates grid points and intervals from a [`PathIndex`].
pub struct GridGen<'p> {
    index: &'p PathIndex,
    /// Which reader of a streamed index this generator is.
    reader: Reader,
    caps: Caps,
    /// Swept angle of arc intervals ([`arc_step`]).
    arc_step: f64,
    next_move: usize,
    /// The batch being consumed: received from [`GridGen::produce`] on another thread, or
    /// the current move computed here.
    batch: GridBatch,
    /// Next move of `batch`.
    batch_move: usize,
    /// Pending intervals of the current move, `batch.intervals[pending.0..pending.1]`.
    pending: (usize, usize),
    /// The producer's channel, when the grid is computed ahead on another thread.
    ahead: Option<Receiver<GridBatch>>,
    /// Blended junction corners passed.
    pub blended: usize,
}

impl<'p> GridGen<'p> {
    /// A generator at the start of the program.
    pub fn new(index: &'p PathIndex, opts: &PlanOptions) -> Self {
        let caps = caps_of(opts);
        GridGen {
            index,
            reader: Reader::GridConsumer,
            arc_step: arc_step(&caps),
            caps,
            next_move: 0,
            batch: GridBatch::default(),
            batch_move: 0,
            pending: (0, 0),
            ahead: None,
            blended: 0,
        }
    }

    /// Computes the grid of every move in order and sends it in batches of
    /// [`GRID_BATCH_MOVES`] (for a generator on another thread that [`GridGen::take_from`]
    /// the receiver); stops early when the receiver hangs up.
    pub fn produce(&self, tx: SyncSender<GridBatch>) {
        let mut j = 0;
        // Room for as many intervals as the last batch had, and a quarter more, so that a
        // batch's vector seldom grows by copying.
        let mut room = 0;
        let mut more = true;
        while more {
            let mut batch = GridBatch {
                moves: Vec::with_capacity(GRID_BATCH_MOVES),
                intervals: Vec::with_capacity(room + room / 4),
            };
            while batch.moves.len() < GRID_BATCH_MOVES
                && batch.intervals.len() < GRID_BATCH_INTERVALS
            {
                self.index.release(Reader::GridProducer, j);
                let Some(m) = self.index.get(j) else {
                    more = false;
                    break;
                };
                let cap = self.intervals_of(&m, &mut batch.intervals);
                batch.moves.push((cap, batch.intervals.len()));
                j += 1;
            }
            room = batch.intervals.len();
            if !batch.moves.is_empty() && tx.send(batch).is_err() {
                break;
            }
        }
        self.index.not_reading(Reader::GridProducer);
    }

    /// Takes the move grids from `rx` (fed by [`GridGen::produce`] of a generator over
    /// the same index and options) instead of computing them: the same grid, computed
    /// on another thread while this one plans.
    pub fn take_from(&mut self, rx: Receiver<GridBatch>) {
        self.ahead = Some(rx);
    }

    /// This generator is the one on the grid producer's thread (for a streamed index).
    pub fn as_producer(mut self) -> Self {
        self.reader = Reader::GridProducer;
        self
    }

    /// The grid of move `j`, the next one (from the producer when there is one): its start
    /// cap and the range of its intervals in `self.batch.intervals`.
    fn next_move_grid(&mut self, j: usize) -> (f64, (usize, usize)) {
        if self.batch_move >= self.batch.moves.len() {
            match self.ahead.as_ref().map(|rx| rx.recv()) {
                Some(Ok(b)) => self.batch = b,
                // No producer, or it is gone (it panicked): compute here.
                _ => {
                    self.ahead = None;
                    let mut intervals = std::mem::take(&mut self.batch.intervals);
                    intervals.clear();
                    let cap = self.move_intervals(j, &mut intervals);
                    self.batch.moves.clear();
                    self.batch.moves.push((cap, intervals.len()));
                    self.batch.intervals = intervals;
                }
            }
            self.batch_move = 0;
        }
        let start = match self.batch_move {
            0 => 0,
            k => self.batch.moves[k - 1].1,
        };
        let (cap, end) = self.batch.moves[self.batch_move];
        self.batch_move += 1;
        (cap, (start, end))
    }
    /// The caps in use.
    pub fn caps(&self) -> &Caps {
        &self.caps
    }
    /// True when every move has been generated.
    pub fn done(&self) -> bool {
        self.pending.0 == self.pending.1 && self.index.get(self.next_move).is_none()
    }

    /// Appends the intervals of move `j` to `out` ([`GridGen::intervals_of`]).
    fn move_intervals(&self, j: usize, out: &mut Vec<(Interval, f64)>) -> f64 {
        let m = self.index.get(j).expect("the move exists");
        self.intervals_of(&m, out)
    }

    /// Appends the intervals of move `m` to `out`, each with the cap of its end point from
    /// the move's own geometry, and returns the cap of the move's start point.
    fn intervals_of(&self, m: &PlanMove, out: &mut Vec<(Interval, f64)>) -> f64 {
        let caps = &self.caps;
        match &m.segment {
            Segment::Line(l) => {
                let t = (l.p1 - l.p0).normalized().unwrap_or(Vec3::X);
                let cap = point_cap_x(t, Vec3::ZERO, m.vcap_mm_s, caps);
                let mut iv = Interval {
                    ds: m.len,
                    straight: true,
                    u_line: line_acc(t, caps),
                    x_inside: cap,
                    t0: t,
                    k0: Vec3::ZERO,
                    t1: t,
                    k1: Vec3::ZERO,
                    mid: None,
                };
                let Some(j) = caps.jerk else {
                    out.push((iv, cap));
                    return cap;
                };
                // Jerk mode: the scalar tangential limit, and lines cut so that the
                // dilated caps are resolved along them (see `super::jerk`).
                iv.u_line = j.u_max_mm_s2;
                let cuts = super::jerk::line_cuts(m.len);
                let mut prev = 0.0;
                for c in cuts.into_iter().chain(std::iter::once(m.len)) {
                    if c > prev {
                        out.push((Interval { ds: c - prev, ..iv }, cap));
                        prev = c;
                    }
                }
                cap
            }
            seg => {
                let sp = spans(seg);
                // Arcs and helices: uniform steps of `arc_step` of sweep per half interval
                // (module doc).
                let arc_steps = match seg {
                    Segment::Arc(a) => Some((0.5 * a.sweep / self.arc_step).ceil() as usize),
                    _ => None,
                };
                let n0 = ((0.5 * m.len / MAX_CURVE_DS_MM).ceil() as usize)
                    .max(MIN_CURVE_INTERVALS * sp)
                    .max(arc_steps.unwrap_or(0))
                    .min(MAX_CURVE_INTERVALS);
                let params = match seg {
                    Segment::Arc(a) => refine(n0, false, m.vcap_mm_s, m.len, caps, &|t| {
                        let (p, tt, kk) = a.frame(t);
                        (tt, kk, p)
                    }),
                    // The spline's weights once per move, not at every sample.
                    Segment::Trig(c) => {
                        let prepared = PreparedTrig::new(c);
                        refine(n0, true, m.vcap_mm_s, m.len, caps, &|t| {
                            geo_at(seg, &prepared, t)
                        })
                    }
                    // A cubic B-spline as its Bézier pieces (no knot search per sample).
                    Segment::Nurbs(n) => match PreparedNurbs::new(n) {
                        Some(p) => {
                            refine(n0, true, m.vcap_mm_s, m.len, caps, &|t| geo_at(seg, &p, t))
                        }
                        None => {
                            refine(n0, true, m.vcap_mm_s, m.len, caps, &|t| geo_at(seg, seg, t))
                        }
                    },
                    _ => refine(n0, true, m.vcap_mm_s, m.len, caps, &|t| geo_at(seg, seg, t)),
                };
                let first = (params[0].1, params[0].2);
                let mut start_cap =
                    point_cap_x_kappa(first.0, first.1, params[0].4, m.vcap_mm_s, caps);
                // Trapezoid mode imposes the rows at the midpoints too; jerk mode's caps
                // live at grid points, so there every half is an interval of its own.
                let with_mid = caps.jerk.is_none();
                // This move's intervals are `out[base..]`.
                let base = out.len();
                out.reserve(params.len() / 2 + 1);
                let mut s_acc = 0.0;
                let n = params.len() / 2;
                let piece = |a: &Sample, b: &Sample| arc_from_chord(a.3.dist(b.3), a.1.dot(b.1));
                let push = |out: &mut Vec<(Interval, f64)>,
                            ds: f64,
                            a: &Sample,
                            b: &Sample,
                            mid: Option<IntervalMid>| {
                    let cap = point_cap_x_kappa(b.1, b.2, b.4, m.vcap_mm_s, caps);
                    if ds > 0.0 {
                        let iv = Interval {
                            ds,
                            straight: false,
                            u_line: 0.0,
                            x_inside: 0.0,
                            t0: a.1,
                            k0: a.2,
                            t1: b.1,
                            k1: b.2,
                            mid,
                        };
                        out.push((iv, cap));
                    } else if out.len() > base {
                        let last = out.last_mut().expect("non-empty");
                        last.1 = last.1.min(cap);
                    }
                };
                for j in 0..n {
                    let (a, q, b) = (&params[2 * j], &params[2 * j + 1], &params[2 * j + 2]);
                    let (d1, d2) = (piece(a, q), piece(q, b));
                    // The move's last interval takes the remainder of its exact length.
                    let ds = if j + 1 == n {
                        (m.len - s_acc).max(0.0)
                    } else {
                        d1 + d2
                    };
                    s_acc += ds;
                    let f = if d1 + d2 > 0.0 { d1 / (d1 + d2) } else { 0.5 };
                    if with_mid {
                        let mid = IntervalMid {
                            f,
                            t: q.1,
                            k: q.2,
                            x_cap: point_cap_x_kappa(q.1, q.2, q.4, m.vcap_mm_s, caps),
                        };
                        push(out, ds, a, b, Some(mid));
                    } else {
                        push(out, ds * f, a, q, None);
                        push(out, ds * (1.0 - f), q, b, None);
                    }
                }
                if out.len() > base {
                    if let Some(v) = caps.vaxis {
                        vaxis_caps(&mut out[base..], &v, &mut start_cap);
                    }
                    if let Some(j) = caps.jerk {
                        jerk_caps(&mut out[base..], &j, &mut start_cap);
                    }
                }
                start_cap
            }
        }
    }

    /// Appends grid points (and the intervals before them) to `pts`/`ivs` until `pts`
    /// holds `target` points or a stop is reached; returns true at a stop (the last point
    /// then carries it). `pts` must hold the window's first point.
    pub fn fill(
        &mut self,
        pts: &mut Vec<GridPoint>,
        ivs: &mut Vec<Interval>,
        target: usize,
    ) -> bool {
        loop {
            if let Some(p) = pts.last() {
                if p.stop.is_some() {
                    return true;
                }
            }
            if pts.len() >= target && self.pending.0 == self.pending.1 {
                // Only cut between moves or inside a curve, never before emitting a
                // move's end point (it carries the joint).
                return false;
            }
            if self.pending.0 == self.pending.1 {
                // The last move's end is read below; those before are done with.
                self.index
                    .release(self.reader, self.next_move.saturating_sub(1));
                if self.index.get(self.next_move).is_none() {
                    // Nothing left (empty program): the first point is the end.
                    if let Some(p) = pts.last_mut() {
                        p.stop = Some((StopReason::End, 0.0));
                    }
                    return true;
                }
                let j = self.next_move;
                let (start_cap, range) = self.next_move_grid(j);
                if let Some(p) = pts.last_mut() {
                    p.x_cap = p.x_cap.min(start_cap);
                    p.x_src = p.x_src.min(start_cap);
                }
                self.pending = range;
                self.next_move += 1;
            }
            let (iv, cap) = &self.batch.intervals[self.pending.0];
            let cap = *cap;
            self.pending.0 += 1;
            let s = pts.last().map_or(0.0, |p| p.s) + iv.ds;
            ivs.push(*iv);
            let mut pt = GridPoint {
                s,
                x_cap: cap,
                x_src: cap,
                stop: None,
            };
            if self.pending.0 == self.pending.1 {
                let m = self.index.get(self.next_move - 1).expect("the move exists");
                pt.s = m.s0 + m.len;
                match m.after {
                    After::Stop { reason, dwell_s } => {
                        pt.x_cap = 0.0;
                        pt.stop = Some((reason, dwell_s));
                    }
                    After::Continue { x_cap, blended } => {
                        pt.x_cap = pt.x_cap.min(x_cap);
                        pt.x_src = pt.x_src.min(x_cap);
                        self.blended += blended as usize;
                    }
                }
            }
            pts.push(pt);
            if pts.len() >= target && self.pending.0 < self.pending.1 {
                return false;
            }
        }
    }
}
