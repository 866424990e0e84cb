//! The lazy generator [`GridGen`]: grid points ([`GridPoint`]) and intervals a window at
//! a time, or in [`GridBatch`]es computed ahead on another thread.

use super::index::{geo_at, spans, PathIndex};
use super::joints::caps_of;
use super::refine::{arc_from_chord, arc_step, jerk_caps, refine, vaxis_caps, Sample};
use super::{After, PlanMove, MAX_CURVE_DS_MM, MAX_CURVE_INTERVALS, MIN_CURVE_INTERVALS};
use crate::feed::limits::{line_acc, point_cap_x, point_cap_x_kappa, Caps, Interval, IntervalMid};
use crate::feed::window::Reader;
use crate::feed::{PlanOptions, StopReason};
use crate::geom::{PreparedNurbs, PreparedTrig, Segment, Vec3};
use std::sync::mpsc::{Receiver, SyncSender};

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
pub(crate) const GRID_BATCH_MOVES: usize = 256;
/// Intervals after which a message of [`GridGen::produce`] is sent even with fewer than
/// [`GRID_BATCH_MOVES`] moves: a long curve has thousands (a NURBS run of the `nurbs`
/// method), and the queue's memory is in its intervals (about 160 bytes each).
pub(crate) const GRID_BATCH_INTERVALS: usize = 4096;
/// Messages [`GridGen::produce`] may run ahead of the planner (bounds the memory held).
pub(crate) const GRID_QUEUE_BATCHES: usize = 16;

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
    /// `GRID_BATCH_MOVES` (for a generator on another thread that [`GridGen::take_from`]
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
