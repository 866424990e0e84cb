//! The planning grid: the program's moves in arc length ([`PathIndex`]), and the grid
//! points and intervals generated from them lazily, a window at a time ([`GridGen`]).
//!
//! Lines are one straight interval each (their limits are constant along them, and the
//! profile inside a straight interval may accelerate, cruise and decelerate, so no
//! subdivision is needed). Arcs and curves are first cut uniformly in their parameter
//! (no longer than about [`MAX_CURVE_DS_MM`], at least [`MIN_CURVE_INTERVALS`] per move,
//! per knot span for NURBS), then intervals are bisected until the tangent turns by at
//! most [`MAX_TURN_DEG`] and the curvature vector changes by at most
//! [`MAX_CURVATURE_CHANGE`] of its size between their ends; their arc lengths come from
//! Gauss-Legendre quadrature checked to [`crate::interp::STEP_ARCLEN_ACCURACY_MM`]
//! ([`crate::interp::step_arclen`]), the move's total from adaptive quadrature at
//! [`ARCLEN_ACCURACY_MM`] (the last interval takes the remainder).
//! Zero-length moves (below [`crate::verify::DEGENERATE_MM`]) are dropped: their extra-axis
//! change, if any, happens at once at their position (a known limitation: extra axes
//! ride along and are not planned).

use super::limits::{g1_joint_cap_x, junction_cap_x, line_acc, point_cap_x, Caps, Interval};
use super::{PlanOptions, StopReason};
use crate::geom::{
    arclen_adaptive, ParamCurve, ParamCurveCurvature, ParamCurveDeriv, Segment, Vec3,
};
use crate::path::{Block, EventKind, ExtraAxes, MoveKind, Toolpath};
use crate::verify::{DEGENERATE_MM, GAP_TOL_MM, TANGENT_TOL_DEG};

/// Largest tangent turn (degrees) inside one curved grid interval.
pub const MAX_TURN_DEG: f64 = 1.25;
/// Longest curved grid interval (mm).
pub const MAX_CURVE_DS_MM: f64 = 0.5;
/// Fewest intervals per curved move (per knot span for NURBS).
pub const MIN_CURVE_INTERVALS: usize = 2;
/// Most intervals per move (a guard against absurd inputs).
pub const MAX_CURVE_INTERVALS: usize = 1 << 20;
/// Accuracy (mm) of the arc lengths of curved intervals.
pub const ARCLEN_ACCURACY_MM: f64 = 1e-10;
/// Largest change of the curvature vector over one curved interval (its caps are checked
/// at the ends only), relative to the larger of the end curvatures and of the curvature
/// floor `min_i A_i / vcap^2`: the curvature at which the move's speed cap alone uses the
/// smallest axis acceleration. Below that floor a change is judged by the normal
/// acceleration it can cause at the cap, `vcap^2 dK <= 0.005 A`, well inside the 1 %
/// planning reserve; relative to zero curvature alone (the flat ends of a B-spline
/// transition) the refinement would never stop.
pub const MAX_CURVATURE_CHANGE: f64 = 0.005;
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
pub struct PlanMove<'a> {
    /// Geometry.
    pub segment: &'a Segment,
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

/// The program's moves in arc length, with the joints classified.
#[derive(Clone, Debug)]
pub struct PathIndex<'a> {
    /// Moves (zero-length moves dropped).
    pub moves: Vec<PlanMove<'a>>,
    /// Start point of the program.
    pub start: Vec3,
    /// Events before the first move: `(reason, dwell seconds)`, if any.
    pub lead: Option<(StopReason, f64)>,
    /// Total arc length (mm).
    pub total_len: f64,
    /// Bit mask of the extra axes present ([`crate::path::EXTRA_AXIS_NAMES`]).
    pub extra_axes_mask: u8,
}

fn move_len(seg: &Segment) -> f64 {
    match seg {
        Segment::Line(l) => l.length(),
        Segment::Arc(a) => a.length(),
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

impl<'a> PathIndex<'a> {
    /// Indexes `path` under `opts` (which supplies the feed and rapid rates and the joint
    /// rule). `opts` must be valid.
    pub fn new(path: &'a Toolpath, opts: &PlanOptions) -> PathIndex<'a> {
        let caps = caps_of(opts);
        let mut moves: Vec<PlanMove<'a>> = Vec::new();
        let mut pending: Option<(StopReason, f64)> = None;
        let mut lead = None;
        let mut s = 0.0;
        let mut last_extra: Option<ExtraAxes> = None;
        for b in &path.blocks {
            match b {
                Block::Event(e) => {
                    let (r, d) = match e.kind {
                        EventKind::Dwell(t) if t.is_finite() && t > 0.0 => (StopReason::Dwell, t),
                        EventKind::Dwell(_) => (StopReason::Dwell, 0.0),
                        _ => (StopReason::Event, 0.0),
                    };
                    pending = Some(match pending {
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
                Block::Move(m) => {
                    let extra_end = m.extra;
                    let extra_start = last_extra.or(extra_end);
                    last_extra = extra_end.or(last_extra);
                    let len = move_len(&m.segment);
                    if len.is_nan() || len <= DEGENERATE_MM || !len.is_finite() {
                        continue;
                    }
                    let vcap = match m.kind {
                        MoveKind::Rapid => opts.rapid(),
                        MoveKind::Feed => m
                            .feed_mm_s
                            .filter(|f| *f > 0.0 && f.is_finite())
                            .map_or(opts.feed_mm_s, |f| f.min(opts.feed_mm_s)),
                    };
                    if let Some(prev) = moves.last_mut() {
                        prev.after = match pending.take() {
                            Some((reason, dwell_s)) => After::Stop { reason, dwell_s },
                            None => joint_after(prev.segment, &m.segment, opts, &caps),
                        };
                    } else if let Some(p) = pending.take() {
                        lead = Some(p);
                    }
                    moves.push(PlanMove {
                        segment: &m.segment,
                        kind: m.kind,
                        vcap_mm_s: vcap,
                        s0: s,
                        len,
                        extra: extra_end.zip(extra_start).map(|(e, st)| (st, e)),
                        after: After::Stop {
                            reason: StopReason::End,
                            dwell_s: 0.0,
                        },
                    });
                    s += len;
                }
            }
        }
        if let Some((_, d)) = pending {
            match moves.last_mut() {
                Some(m) => {
                    m.after = After::Stop {
                        reason: StopReason::End,
                        dwell_s: d,
                    }
                }
                None => lead = pending,
            }
        }
        PathIndex {
            moves,
            start: path.start,
            lead,
            total_len: s,
            extra_axes_mask: path.extra_axes_mask,
        }
    }
    /// End point of the program.
    pub fn end_point(&self) -> Vec3 {
        self.moves.last().map_or(self.start, |m| m.segment.end())
    }
}

/// The caps the planner uses for `opts`.
pub fn caps_of(opts: &PlanOptions) -> Caps {
    let jerk = opts.jerk_caps();
    // Jerk mode: the curvature term gets its share of the acceleration limits.
    let share = if jerk.is_some() {
        super::jerk::CURVATURE_ACC_SHARE
    } else {
        1.0
    };
    Caps {
        jerk,
        acc: opts
            .acc_mm_s2
            .map(|a| a * super::ACC_PLANNING_FACTOR * share),
        vaxis: opts
            .vaxis_mm_s
            .map(|v| v.map(|x| x * super::VAXIS_PLANNING_FACTOR)),
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
        j.speed_cap_x(
            abs_max(ka, kb),
            abs_max(end_rate(a, true), end_rate(b, false)),
            kb - ka,
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
    let ds = crate::interp::step_arclen(seg, a, b);
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

/// Lazily generates grid points and intervals from a [`PathIndex`].
pub struct GridGen<'p, 'a> {
    index: &'p PathIndex<'a>,
    caps: Caps,
    next_move: usize,
    /// Pending intervals of the current move, with their end-point caps (reversed).
    pending: Vec<(Interval, f64)>,
    /// Blended junction corners passed.
    pub blended: usize,
}

impl<'p, 'a> GridGen<'p, 'a> {
    /// A generator at the start of the program.
    pub fn new(index: &'p PathIndex<'a>, opts: &PlanOptions) -> Self {
        GridGen {
            index,
            caps: caps_of(opts),
            next_move: 0,
            pending: Vec::new(),
            blended: 0,
        }
    }
    /// The caps in use.
    pub fn caps(&self) -> &Caps {
        &self.caps
    }
    /// True when every move has been generated.
    pub fn done(&self) -> bool {
        self.pending.is_empty() && self.next_move >= self.index.moves.len()
    }

    /// The intervals of move `j`, each with the cap of its end point from the move's own
    /// geometry (the move's start cap is returned separately).
    fn move_intervals(&self, j: usize) -> (f64, Vec<(Interval, f64)>) {
        let m = &self.index.moves[j];
        let caps = &self.caps;
        match m.segment {
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
                };
                let Some(j) = caps.jerk else {
                    return (cap, vec![(iv, cap)]);
                };
                // Jerk mode: the scalar tangential limit, and lines cut so that the
                // dilated caps are resolved along them (see `super::jerk`).
                iv.u_line = j.u_max_mm_s2;
                let cuts = super::jerk::line_cuts(m.len);
                let mut list = Vec::with_capacity(cuts.len() + 1);
                let mut prev = 0.0;
                for c in cuts.into_iter().chain(std::iter::once(m.len)) {
                    if c > prev {
                        list.push((Interval { ds: c - prev, ..iv }, cap));
                        prev = c;
                    }
                }
                (cap, list)
            }
            seg => {
                let sp = spans(seg);
                // Arcs and helices: curvature of constant size whose direction turns with
                // the swept angle, so uniform steps of at most MAX_TURN_DEG of sweep bound
                // both the tangent and the curvature-vector rotation (an end-point check
                // then misses an interior maximum by at most 1 - cos(step / 2), 6e-5),
                // with no refinement.
                let arc_steps = match seg {
                    Segment::Arc(a) => Some((a.sweep / MAX_TURN_DEG.to_radians()).ceil() as usize),
                    _ => None,
                };
                let n0 = ((m.len / MAX_CURVE_DS_MM).ceil() as usize)
                    .max(MIN_CURVE_INTERVALS * sp)
                    .max(arc_steps.unwrap_or(0))
                    .min(MAX_CURVE_INTERVALS);
                let geo = |t: f64| (tangent_at(seg, t), curvature_at(seg, t));
                // Uniform start, then bisection where the tangent turns too much or the
                // curvature changes too much between the two ends of an interval.
                let mut params: Vec<(f64, Vec3, Vec3)> = Vec::with_capacity(n0 + 1);
                let first = geo(0.0);
                params.push((0.0, first.0, first.1));
                let mut stack: Vec<(f64, Vec3, Vec3)> = Vec::new();
                for i in (1..=n0).rev() {
                    let t = i as f64 / n0 as f64;
                    let (tt, kk) = geo(t);
                    stack.push((t, tt, kk));
                }
                let max_turn = MAX_TURN_DEG.to_radians();
                let a_min = caps.acc.iter().copied().fold(f64::INFINITY, f64::min);
                let k_floor = if m.vcap_mm_s > 0.0 && m.vcap_mm_s.is_finite() {
                    a_min / (m.vcap_mm_s * m.vcap_mm_s)
                } else {
                    0.0
                };
                while let Some(&(t1, tt1, kk1)) = stack.last() {
                    let &(t0, tt0, kk0) = params.last().expect("non-empty");
                    let kmax = kk0.norm().max(kk1.norm()).max(k_floor);
                    let split = arc_steps.is_none()
                        && params.len() + stack.len() < MAX_CURVE_INTERVALS
                        && t1 - t0 > MIN_PARAM_STEP
                        && (tt0.angle_to(tt1) > max_turn
                            || (kk1 - kk0).norm() > MAX_CURVATURE_CHANGE * kmax + 1e-9);
                    if split {
                        let tm = 0.5 * (t0 + t1);
                        let (tt, kk) = geo(tm);
                        stack.push((tm, tt, kk));
                    } else {
                        params.push((t1, tt1, kk1));
                        stack.pop();
                    }
                }
                let mut start_cap = point_cap_x(first.0, first.1, m.vcap_mm_s, caps);
                let mut out: Vec<(Interval, f64)> = Vec::with_capacity(params.len());
                let mut s_acc = 0.0;
                let last = params.len() - 1;
                for (i, w) in params.windows(2).enumerate() {
                    let ((a, t0, k0), (b, t1, k1)) = (w[0], w[1]);
                    let ds = if i + 1 == last {
                        (m.len - s_acc).max(0.0)
                    } else {
                        crate::interp::step_arclen(seg, a, b)
                    };
                    s_acc += ds;
                    let cap = point_cap_x(t1, k1, m.vcap_mm_s, caps);
                    if ds > 0.0 {
                        out.push((
                            Interval {
                                ds,
                                straight: false,
                                u_line: 0.0,
                                x_inside: 0.0,
                                t0,
                                k0,
                                t1,
                                k1,
                            },
                            cap,
                        ));
                    } else if let Some(last) = out.last_mut() {
                        last.1 = last.1.min(cap);
                    }
                }
                if let (Some(j), false) = (caps.jerk, out.is_empty()) {
                    // Jerk caps at every point: its curvature, and the curvature rate
                    // (finite difference over each interval) of the intervals beside it.
                    let n = out.len();
                    let rates: Vec<Vec3> =
                        out.iter().map(|(iv, _)| (iv.k1 - iv.k0) / iv.ds).collect();
                    let rate = |i: usize| rates[i];
                    for p in 0..=n {
                        let r = abs_max(
                            p.checked_sub(1).map_or(Vec3::ZERO, rate),
                            if p < n { rate(p) } else { Vec3::ZERO },
                        );
                        let k = if p == 0 { out[0].0.k0 } else { out[p - 1].0.k1 };
                        let c = j.speed_cap_x(k, r, Vec3::ZERO);
                        if p == 0 {
                            start_cap = start_cap.min(c);
                        } else {
                            out[p - 1].1 = out[p - 1].1.min(c);
                        }
                    }
                }
                (start_cap, out)
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
            if pts.len() >= target && self.pending.is_empty() {
                // Only cut between moves or inside a curve, never before emitting a
                // move's end point (it carries the joint).
                return false;
            }
            if self.pending.is_empty() {
                if self.next_move >= self.index.moves.len() {
                    // Nothing left (empty program): the first point is the end.
                    if let Some(p) = pts.last_mut() {
                        p.stop = Some((StopReason::End, 0.0));
                    }
                    return true;
                }
                let j = self.next_move;
                let (start_cap, mut list) = self.move_intervals(j);
                if let Some(p) = pts.last_mut() {
                    p.x_cap = p.x_cap.min(start_cap);
                    p.x_src = p.x_src.min(start_cap);
                }
                list.reverse();
                self.pending = list;
                self.next_move += 1;
            }
            let (iv, cap) = self.pending.pop().expect("non-empty");
            let s = pts.last().map_or(0.0, |p| p.s) + iv.ds;
            ivs.push(iv);
            let mut pt = GridPoint {
                s,
                x_cap: cap,
                x_src: cap,
                stop: None,
            };
            if self.pending.is_empty() {
                let m = &self.index.moves[self.next_move - 1];
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
            if pts.len() >= target && !self.pending.is_empty() {
                return false;
            }
        }
    }
}
