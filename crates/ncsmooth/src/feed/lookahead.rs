//! Bidirectional look-ahead over bounded windows of the planning grid (see the
//! [`crate::feed`] doc for why a committed prefix is final), producing the speed profile
//! as a stream of constant-acceleration pieces ([`ProfilePiece`]) and stops.
//!
//! On programs of at least `GRID_THREAD_MIN_MOVES` (4096) moves (and more than one core) the
//! grid of the moves ahead is computed on a second thread ([`GridGen::produce`]) while
//! this one runs the passes: each move's grid depends on that move alone, so the plan is
//! the same bit for bit (tested), and the producer runs at most
//! `GRID_QUEUE_BATCHES` (16) batches ahead.

use super::grid::{GridGen, GridPoint, PathIndex};
use super::limits::Interval;
use super::{PlanOptions, StopCounts, StopReason};
use serde::Serialize;
use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::time::Instant;

/// Grid points a window starts with; a window grows (doubles) when no point in it is
/// free of the assumed stop at its end.
pub(crate) const WINDOW_POINTS: usize = 4096;

/// A piece of the profile with constant tangential acceleration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProfilePiece {
    /// Arc length at the start (mm).
    pub s0: f64,
    /// Length (mm), > 0.
    pub ds: f64,
    /// Speed at the start (mm/s).
    pub v0: f64,
    /// Speed at the end (mm/s).
    pub v1: f64,
    /// Duration (s): `2 ds / (v0 + v1)`.
    pub dt: f64,
}

impl ProfilePiece {
    /// Tangential acceleration (mm/s^2).
    pub fn acc(&self) -> f64 {
        (self.v1 - self.v0) / self.dt
    }
    /// Arc length and speed `tau` seconds into the piece (clamped to the piece).
    pub fn at(&self, tau: f64) -> (f64, f64) {
        let tau = tau.clamp(0.0, self.dt);
        let a = self.acc();
        let s = (self.v0 * tau + 0.5 * a * tau * tau).clamp(0.0, self.ds);
        (self.s0 + s, (self.v0 + a * tau).max(0.0))
    }
}

/// What the planner emits, in order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PlanEvent {
    /// Motion.
    Piece(ProfilePiece),
    /// The machine is at rest at `s` for `dwell_s` seconds (then until the next period
    /// boundary).
    Stop {
        /// Arc length (mm).
        s: f64,
        /// Why.
        reason: StopReason,
        /// Time at rest (s).
        dwell_s: f64,
    },
}

/// Statistics of a planning run.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct PlanStats {
    /// Windows committed.
    pub windows: usize,
    /// Grid points generated.
    pub grid_points: usize,
    /// Largest window (grid points).
    pub max_window_points: usize,
    /// Times a window had to grow before any of it could be committed.
    pub window_growths: usize,
    /// Exact stops by reason.
    pub stops: StopCounts,
    /// Time spent planning (s), excluding what the sink does.
    pub plan_time_s: f64,
}

fn backward(
    pts: &[f64],
    ivs: &[Interval],
    caps: &super::limits::Caps,
    bwd: &mut Vec<f64>,
    free: &mut Vec<bool>,
) {
    let n = pts.len();
    bwd.clear();
    bwd.resize(n, 0.0);
    free.clear();
    free.resize(n, false);
    bwd[n - 1] = 0.0;
    for k in (0..n - 1).rev() {
        let (p, f) = ivs[k].backward(pts[k], bwd[k + 1], caps);
        bwd[k] = p;
        free[k] = f;
    }
}

/// Jerk mode: the dilated caps of a window (see [`super::jerk`], point 3).
/// `tail` holds committed `(s, source cap)` points behind the window; a source cap `c`
/// reaches the positions within `W sqrt(c)` of it (`W = window_s`), and every point's
/// cap becomes the least source cap reaching its two neighbouring intervals; straight intervals' inside caps likewise
/// (`xin`). `radius` bounds every reach. Unless `ended`, points whose neighbourhood
/// reaches past the window's last point get 0 (their future caps are unknown).
#[allow(clippy::too_many_arguments)]
fn dilate(
    pts: &[GridPoint],
    ivs: &[Interval],
    tail: &[(f64, f64)],
    radius: f64,
    window_s: f64,
    ended: bool,
    src: &mut Vec<f64>,
    capv: &mut Vec<f64>,
    dil: &mut Vec<f64>,
    xin: &mut Vec<f64>,
) {
    let n = pts.len();
    src.clear();
    src.extend((0..n).map(|k| {
        let mut c = pts[k].x_src;
        for iv in [k.checked_sub(1).map(|j| &ivs[j]), ivs.get(k)]
            .into_iter()
            .flatten()
        {
            if iv.straight {
                c = c.min(iv.x_inside);
            }
        }
        c
    }));
    // Each source cap c_j reaches the points within its own radius W sqrt(c_j) + margin.
    let seq = |i: usize| -> (f64, f64) {
        if i < tail.len() {
            tail[i]
        } else {
            (pts[i - tail.len()].s, src[i - tail.len()])
        }
    };
    let total = tail.len() + n;
    let s_last = pts[n - 1].s;
    // Sweep: sources as intervals [s - reach, s + reach] sorted by start; a min-heap
    // (by cap) of the started ones, dropping those that ended before the query.
    let mut iv_src: Vec<(f64, f64, f64)> = (0..total)
        .filter_map(|i| {
            let (sj, cj) = seq(i);
            let r = (window_s * cj.sqrt()).min(radius);
            cj.is_finite().then_some((sj - r, sj + r, cj))
        })
        .collect();
    iv_src.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut heap: BinaryHeap<Reverse<(u64, usize)>> = BinaryHeap::new();
    let mut next = 0;
    capv.clear();
    dil.clear();
    for k in 0..n {
        // The point's two neighbouring intervals.
        let (a, b) = (pts[k.saturating_sub(1)].s, pts[(k + 1).min(n - 1)].s);
        while next < iv_src.len() && iv_src[next].0 <= b {
            // Caps are >= 0, so their bit patterns order like the values.
            heap.push(Reverse((iv_src[next].2.max(0.0).to_bits(), next)));
            next += 1;
        }
        while heap.peek().is_some_and(|Reverse((_, j))| iv_src[*j].1 < a) {
            heap.pop();
        }
        let mut c = heap
            .peek()
            .map_or(f64::INFINITY, |Reverse((bits, _))| f64::from_bits(*bits));
        if !ended && b + radius > s_last {
            c = 0.0;
        }
        dil.push(c);
        capv.push(pts[k].x_cap.min(c));
    }
    // Inside a straight interval: the dilated sources at its ends (not a stop's 0).
    xin.clear();
    xin.extend(
        ivs.iter()
            .enumerate()
            .map(|(k, iv)| iv.x_inside.min(dil[k]).min(dil[k + 1])),
    );
}

/// Largest turn (the norm of the tangent's change) of a joint of two straight intervals
/// taken as collinear by [`line_accels`]: rounding of a line split in two stays far below,
/// a programmed kink (coordinates rounded to 4 decimals) far above.
const KINK_NEGLIGIBLE: f64 = 1e-12;

/// Whether straight intervals `k` and `k + 1` meet at a kink ([`KINK_NEGLIGIBLE`]).
fn kinked(ivs: &[Interval], k: usize) -> bool {
    ivs.get(k + 1).is_some_and(|next| {
        ivs[k].straight && next.straight && (ivs[k].t1 - next.t0).norm() > KINK_NEGLIGIBLE
    })
}

/// Jerk mode: the tangential limit of each straight interval of a window (see
/// [`super::jerk`], point 6): `u_hi` when no curved interval lies within `reach` of it
/// (`curved_behind`: the end of the last curved interval before the window; beyond the
/// window's last point, unless `ended`, everything counts as curved), else `u_lo`.
#[allow(clippy::too_many_arguments)]
fn line_accels(
    pts: &[GridPoint],
    ivs: &mut [Interval],
    ended: bool,
    curved_behind: f64,
    reach: f64,
    u_lo: f64,
    u_hi: f64,
    next_curved: &mut Vec<f64>,
) {
    let n = ivs.len();
    // A joint of two straight intervals whose tangent turns (a kink below the tangent
    // tolerance, passed without a stop) jumps the velocity by `v |kink|` between two
    // setpoints: its jerk needs the room a curve needs, so it counts as a curved point.
    // Start of the first curved interval (or kink) after each interval.
    next_curved.clear();
    next_curved.resize(n, 0.0);
    let mut next = if ended { f64::INFINITY } else { pts[n].s };
    for k in (0..n).rev() {
        if kinked(ivs, k) {
            next = pts[k + 1].s;
        }
        next_curved[k] = next;
        if !ivs[k].straight {
            next = pts[k].s;
        }
    }
    let mut prev = curved_behind;
    for k in 0..n {
        if ivs[k].straight {
            let far = pts[k].s - prev > reach && next_curved[k] - pts[k + 1].s > reach;
            ivs[k].u_line = if far { u_hi.max(u_lo) } else { u_lo };
            if kinked(ivs, k) {
                prev = pts[k + 1].s;
            }
        } else {
            prev = pts[k + 1].s;
        }
    }
}

/// Splits interval `iv` travelled from `x = p` to `x = q` into constant-acceleration
/// pieces: one for a curved interval (x linear in s), up to three (accelerate, cruise,
/// decelerate) for a straight one.
fn pieces(iv: &Interval, s0: f64, p: f64, q: f64, out: &mut Vec<ProfilePiece>) {
    let mut push = |s0: f64, ds: f64, x0: f64, x1: f64| {
        if ds > 0.0 {
            let (v0, v1) = (x0.max(0.0).sqrt(), x1.max(0.0).sqrt());
            if v0 + v1 > 0.0 {
                out.push(ProfilePiece {
                    s0,
                    ds,
                    v0,
                    v1,
                    dt: 2.0 * ds / (v0 + v1),
                });
            }
        }
    };
    if !iv.straight {
        push(s0, iv.ds, p, q);
        return;
    }
    let u2 = 2.0 * iv.u_line;
    let xm = iv.x_inside.min(0.5 * (p + q + u2 * iv.ds)).max(p).max(q);
    let s1 = ((xm - p) / u2).clamp(0.0, iv.ds);
    let s3 = ((xm - q) / u2).clamp(0.0, iv.ds - s1);
    let s2 = iv.ds - s1 - s3;
    push(s0, s1, p, xm);
    push(s0 + s1, s2, xm, xm);
    push(s0 + s1 + s2, s3, xm, q);
}

/// Plans the whole program of `index` under `opts` (which must be valid), calling `sink`
/// with the profile pieces and stops in order. Memory is bounded by the window size.
pub fn plan_stream(
    index: &PathIndex,
    opts: &PlanOptions,
    sink: impl FnMut(PlanEvent),
) -> PlanStats {
    let mut gen = GridGen::new(index, opts);
    if crate::par::threads() < 2 || index.shorter_than(GRID_THREAD_MIN_MOVES) {
        index.not_reading(super::window::Reader::GridProducer);
        return plan_with(&mut gen, index, opts, sink);
    }
    // The grid of the moves ahead is computed on a second thread while this one runs the
    // passes (the same grid: each move's is computed alone, in order).
    std::thread::scope(|scope| {
        let producer = GridGen::new(index, opts).as_producer();
        let (tx, rx) = std::sync::mpsc::sync_channel(super::grid::GRID_QUEUE_BATCHES);
        scope.spawn(move || producer.produce(tx));
        gen.take_from(rx);
        plan_with(&mut gen, index, opts, sink)
    })
}

/// Fewest moves for which [`plan_stream`] computes the grid on a thread of its own.
pub(crate) const GRID_THREAD_MIN_MOVES: usize = 4096;

/// The forward pass over the first `commit` intervals from `x0` under the backward limits
/// `bwd`: the speeds at the points into `xf`, the profile pieces into `out`. In jerk mode
/// `dilated` holds each interval's dilated inside cap.
#[allow(clippy::too_many_arguments)]
fn forward_prefix(
    pts: &[GridPoint],
    ivs: &[Interval],
    bwd: &[f64],
    commit: usize,
    x0: f64,
    dilated: Option<&[f64]>,
    caps: &super::limits::Caps,
    xf: &mut Vec<f64>,
    out: &mut Vec<ProfilePiece>,
) {
    xf.clear();
    xf.push(x0.min(bwd[0]).max(0.0));
    out.clear();
    for k in 0..commit {
        let q = ivs[k].forward(xf[k], bwd[k + 1], caps);
        xf.push(q);
        // (An interval is some 200 bytes: not copied unless it changes.)
        let changed;
        let iv = match dilated {
            Some(xin) => {
                changed = Interval {
                    x_inside: xin[k],
                    ..ivs[k]
                };
                &changed
            }
            None => &ivs[k],
        };
        pieces(iv, pts[k].s, xf[k], q, out);
    }
}

/// [`plan_stream`] with the grid from `gen`.
fn plan_with(
    gen: &mut GridGen<'_>,
    index: &PathIndex,
    opts: &PlanOptions,
    mut sink: impl FnMut(PlanEvent),
) -> PlanStats {
    let mut stats = PlanStats::default();
    let caps = *gen.caps();
    if let Some((reason, dwell_s)) = index.lead() {
        stats.stops.add(reason);
        sink(PlanEvent::Stop {
            s: 0.0,
            reason,
            dwell_s,
        });
    }
    let mut pts = vec![GridPoint {
        s: 0.0,
        x_cap: 0.0,
        x_src: f64::INFINITY,
        stop: None,
    }];
    let mut ivs: Vec<Interval> = Vec::new();
    let (mut bwd, mut free, mut xf) = (Vec::new(), Vec::new(), Vec::new());
    // Jerk mode: dilation radius, committed sources behind the window, work arrays.
    let radius = caps
        .jerk
        .map(|j| super::jerk::dilation_radius_mm(opts.top_speed(), j.window_s));
    let mut tail: Vec<(f64, f64)> = Vec::new();
    // Jerk mode: end of the last curved interval committed (lines far from curves take
    // the larger tangential limit, see `super::jerk` point 6), and a work array.
    let mut curved_behind = f64::NEG_INFINITY;
    let mut next_curved: Vec<f64> = Vec::new();
    let (mut src, mut capv, mut dil, mut xin) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut out: Vec<ProfilePiece> = Vec::new();
    let mut x0: f64 = 0.0;
    loop {
        let clock = Instant::now();
        let mut target = WINDOW_POINTS.max(pts.len() + 1);
        let mut generated = 0;
        let (ended, commit) = loop {
            let len0 = pts.len();
            let ended = gen.fill(&mut pts, &mut ivs, target);
            generated += pts.len() - len0;
            let s_last = pts[pts.len() - 1].s;
            match radius {
                Some(r) => dilate(
                    &pts,
                    &ivs,
                    &tail,
                    r,
                    caps.jerk.map_or(0.0, |j| j.window_s),
                    ended,
                    &mut src,
                    &mut capv,
                    &mut dil,
                    &mut xin,
                ),
                None => {
                    capv.clear();
                    capv.extend(pts.iter().map(|p| p.x_cap));
                }
            }
            if let (Some(j), Some(r)) = (caps.jerk, radius) {
                line_accels(
                    &pts,
                    &mut ivs,
                    ended,
                    curved_behind,
                    r,
                    j.u_max_mm_s2,
                    j.line_u_max(&caps.acc),
                    &mut next_curved,
                );
            }
            backward(&capv, &ivs, &caps, &mut bwd, &mut free);
            if ended {
                break (true, pts.len() - 1);
            }
            // In jerk mode a committed point's dilated cap must be final: the reach of
            // its neighbouring intervals lies inside the window.
            let reach = radius.unwrap_or(0.0);
            if let Some(c) = (1..pts.len() - 1)
                .rev()
                .find(|&j| free[j] && pts[j + 1].s + reach <= s_last)
            {
                break (false, c);
            }
            target *= 2;
            stats.window_growths += 1;
        };
        stats.grid_points += generated;
        stats.max_window_points = stats.max_window_points.max(pts.len());
        stats.windows += 1;
        // Forward pass over the committed prefix.
        let dilated = radius.map(|_| xin.as_slice());
        forward_prefix(
            &pts, &ivs, &bwd, commit, x0, dilated, &caps, &mut xf, &mut out,
        );
        stats.plan_time_s += clock.elapsed().as_secs_f64();
        for pc in &out {
            sink(PlanEvent::Piece(*pc));
        }
        if ended {
            let last = pts[pts.len() - 1];
            let (reason, dwell_s) = last.stop.unwrap_or((StopReason::End, 0.0));
            stats.stops.add(reason);
            sink(PlanEvent::Stop {
                s: last.s,
                reason,
                dwell_s,
            });
            if reason == StopReason::End {
                break;
            }
            pts.clear();
            pts.push(GridPoint {
                s: last.s,
                x_cap: 0.0,
                x_src: f64::INFINITY,
                stop: None,
            });
            ivs.clear();
            tail.clear();
            x0 = 0.0;
        } else {
            if let Some(r) = radius {
                // Sources within the radius behind the new window start stay known.
                let s_c = pts[commit].s;
                tail.extend((0..=commit).map(|j| (pts[j].s, src[j])));
                let keep = tail.partition_point(|&(s, _)| s < s_c - r);
                tail.drain(..keep);
            }
            // A kink counts as curved (see `line_accels`), also across windows.
            if let Some(k) = (0..commit)
                .rev()
                .find(|&k| !ivs[k].straight || kinked(&ivs, k))
            {
                curved_behind = pts[k + 1].s;
            }
            x0 = xf[commit];
            pts.drain(..commit);
            ivs.drain(..commit);
        }
    }
    stats.stops.junction_blended = gen.blended;
    stats
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Line, Vec3};
    use crate::path::{Move, Toolpath};

    fn run(tp: &Toolpath, opts: &PlanOptions) -> (Vec<PlanEvent>, PlanStats) {
        let idx = PathIndex::new(tp, opts);
        let mut ev = Vec::new();
        let st = plan_stream(&idx, opts, |e| ev.push(e));
        (ev, st)
    }

    fn duration(ev: &[PlanEvent]) -> f64 {
        ev.iter()
            .map(|e| match e {
                PlanEvent::Piece(p) => p.dt,
                PlanEvent::Stop { dwell_s, .. } => *dwell_s,
            })
            .sum()
    }

    #[test]
    fn single_line_is_a_trapezoid() {
        // 100 mm along X at 50 mm/s, 500 mm/s^2 (planned at 99 %): time = L/v + v/a.
        let tp = Toolpath::from_polyline(&[Vec3::ZERO, Vec3::new(100.0, 0.0, 0.0)], None);
        let opts = PlanOptions::default();
        let (ev, st) = run(&tp, &opts);
        let a = 500.0 * crate::feed::ACC_PLANNING_FACTOR;
        let expect = 100.0 / 50.0 + 50.0 / a;
        assert!((duration(&ev) - expect).abs() < 1e-9, "{}", duration(&ev));
        assert_eq!(ev.len(), 4); // accelerate, cruise, decelerate, end
        assert_eq!(st.stops.corner, 0);
    }

    #[test]
    fn short_line_is_a_triangle_and_corners_stop() {
        let tp = Toolpath::from_polyline(
            &[
                Vec3::ZERO,
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
            ],
            None,
        );
        let opts = PlanOptions::default();
        let (ev, st) = run(&tp, &opts);
        let a = 500.0 * crate::feed::ACC_PLANNING_FACTOR;
        // Each 1 mm line: accelerate over 0.5 mm and decelerate: t = 2 sqrt(2 * 0.5 / a).
        let expect = 2.0 * 2.0 * (1.0 / a).sqrt();
        assert!((duration(&ev) - expect).abs() < 1e-9);
        assert_eq!(st.stops.corner, 1);
    }

    #[test]
    fn collinear_micro_segments_plan_like_one_line_across_windows() {
        // 20000 collinear 0.01 mm segments (several windows): same time as one 200 mm line,
        // and the speed never dips (no oscillation).
        let pts: Vec<Vec3> = (0..=20000)
            .map(|i| Vec3::new(i as f64 * 0.01, 0.0, 0.0))
            .collect();
        let tp = Toolpath::from_polyline(&pts, None);
        let opts = PlanOptions::default();
        let (ev, st) = run(&tp, &opts);
        assert!(st.windows > 1);
        let a = 500.0 * crate::feed::ACC_PLANNING_FACTOR;
        let expect = 200.0 / 50.0 + 50.0 / a;
        assert!((duration(&ev) - expect).abs() < 1e-6, "{}", duration(&ev));
        let mut peak = false;
        for e in &ev {
            if let PlanEvent::Piece(p) = e {
                if p.v1 < p.v0 - 1e-9 {
                    peak = true;
                } else {
                    assert!(
                        !peak || p.v1 <= p.v0 + 1e-9,
                        "speed rises after falling: {p:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn events_and_dwells_stop() {
        let mut tp = Toolpath::new(Vec3::ZERO);
        tp.push_move(Move::feed(Line::new(Vec3::ZERO, Vec3::X), None, 1));
        tp.push_event(crate::path::Event {
            line: 2,
            kind: crate::path::EventKind::Dwell(0.5),
            text: "G4 P0.5".into(),
        });
        tp.push_move(Move::feed(
            Line::new(Vec3::X, Vec3::new(2.0, 0.0, 0.0)),
            None,
            3,
        ));
        let (ev, st) = run(&tp, &PlanOptions::default());
        assert_eq!(st.stops.dwell, 1);
        assert!(ev
            .iter()
            .any(|e| matches!(e, PlanEvent::Stop { dwell_s, .. } if *dwell_s == 0.5)));
    }

    #[test]
    fn index_joints_skip_dropped_moves_and_events() {
        // The joints come with the move lengths for consecutive moves; a dropped
        // zero-length move or an event between two moves must not borrow them.
        use super::super::grid::After;
        // Along Y first: a zero-length move's fallback tangent is X, so borrowing the
        // joint across it would find a corner.
        let (a, b, c) = (Vec3::ZERO, Vec3::Y, Vec3::new(0.0, 2.0, 0.0));
        let d = Vec3::new(1.0, 2.0, 0.0);
        let e = Vec3::new(2.0, 2.0, 0.0);
        let mut tp = Toolpath::new(a);
        tp.push_move(Move::feed(Line::new(a, b), None, 1));
        // Zero length, and a direction of its own had it not been dropped.
        tp.push_move(Move::feed(Line::new(b, b), None, 2));
        tp.push_move(Move::feed(Line::new(b, c), None, 3));
        tp.push_move(Move::feed(Line::new(c, d), None, 4));
        tp.push_event(crate::path::Event {
            line: 5,
            kind: crate::path::EventKind::Dwell(0.25),
            text: "G4 P0.25".into(),
        });
        tp.push_move(Move::feed(Line::new(d, e), None, 6));
        let idx = PathIndex::new(&tp, &PlanOptions::default());
        let after: Vec<After> = idx.moves.iter().map(|m| m.after).collect();
        assert_eq!(after.len(), 4, "{after:?}");
        // A to B to C is straight: no stop where the zero-length move was.
        assert!(matches!(after[0], After::Continue { .. }), "{after:?}");
        // B to C to D turns 90 degrees.
        assert!(matches!(
            after[1],
            After::Stop {
                reason: StopReason::Corner,
                ..
            }
        ));
        // C to D to E is straight, but the dwell stops it.
        assert!(matches!(
            after[2],
            After::Stop {
                reason: StopReason::Dwell,
                dwell_s
            } if dwell_s == 0.25
        ));
        assert!(matches!(
            after[3],
            After::Stop {
                reason: StopReason::End,
                ..
            }
        ));
    }

    #[test]
    fn jerk_mode_lines_far_from_curves_take_the_line_limit() {
        // 60 mm along X, a quarter-circle-like cubic turn of radius about 2 mm, 60 mm
        // along Y: straight intervals within V W of the curve accelerate at most at U,
        // those farther away up to the line limit, never more.
        let a = Vec3::new(60.0, 0.0, 0.0);
        let b = Vec3::new(62.0, 2.0, 0.0);
        let mut tp = Toolpath::new(Vec3::ZERO);
        tp.push_move(Move::feed(Line::new(Vec3::ZERO, a), None, 1));
        let k = 0.5523 * 2.0;
        tp.push_move(Move::feed(
            crate::geom::CubicBez::new(a, a + Vec3::X * k, b - Vec3::Y * k, b),
            None,
            2,
        ));
        tp.push_move(Move::feed(
            Line::new(b, b + Vec3::new(0.0, 60.0, 0.0)),
            None,
            3,
        ));
        let opts = PlanOptions {
            jerk_mm_s3: Some([5000.0; 3]),
            ..Default::default()
        };
        let caps = super::super::grid::caps_of(&opts);
        let j = caps.jerk.unwrap();
        let (u_lo, u_hi) = (j.u_max_mm_s2, j.line_u_max(&caps.acc));
        assert!(u_hi > 1.5 * u_lo, "{u_lo} {u_hi}");
        let reach = opts.feed_mm_s * j.window_s;
        let curve0 = 60.0;
        let (ev, _) = run(&tp, &opts);
        let (mut fast, mut near) = (0.0f64, 0.0f64);
        for e in &ev {
            if let PlanEvent::Piece(p) = e {
                let acc = p.acc().abs();
                assert!(acc <= u_hi * (1.0 + 1e-9), "{p:?}");
                // Pieces touching the curve's neighbourhood (the curve from 60 mm to about
                // 63.2 mm): at most U.
                let (lo, hi) = (p.s0, p.s0 + p.ds);
                if hi > curve0 - reach && lo < curve0 + 3.3 + reach {
                    near = near.max(acc);
                } else {
                    fast = fast.max(acc);
                }
            }
        }
        assert!(near <= u_lo * (1.0 + 1e-9), "{near} {u_lo}");
        assert!(fast > u_lo * 1.5, "{fast} {u_hi}");
    }

    #[test]
    fn grid_thread_plans_exactly_as_one_thread() {
        // A zigzag of curved (Bezier) and straight moves, more than GRID_THREAD_MIN_MOVES:
        // plan_stream computes the grid on a second thread; plan_with on this one. The
        // events must be identical, bit for bit.
        let mut tp = Toolpath::new(Vec3::ZERO);
        let mut p = Vec3::ZERO;
        for i in 0..(GRID_THREAD_MIN_MOVES / 2 + 100) {
            let a = i as f64 * 0.37;
            let q = p + Vec3::new(0.3 + 0.1 * a.sin(), 0.2 * a.cos(), 0.0);
            let c = p + Vec3::new(0.1, 0.15 * (a * 1.7).sin(), 0.0);
            let d = q - Vec3::new(0.1, 0.0, 0.0);
            tp.push_move(Move::feed(
                crate::geom::CubicBez::new(p, c, d, q),
                None,
                i as u32,
            ));
            let r = q + (q - d) * 2.0;
            tp.push_move(Move::feed(Line::new(q, r), None, i as u32));
            p = r;
        }
        let opts = PlanOptions::default();
        let idx = PathIndex::new(&tp, &opts);
        assert!(idx.moves.len() >= GRID_THREAD_MIN_MOVES);
        let mut threaded = Vec::new();
        let st_a = plan_stream(&idx, &opts, |e| threaded.push(e));
        let mut single = Vec::new();
        let mut gen = GridGen::new(&idx, &opts);
        let st_b = plan_with(&mut gen, &idx, &opts, |e| single.push(e));
        assert_eq!(threaded, single);
        assert_eq!(st_a.grid_points, st_b.grid_points);
        assert!(threaded.len() > 2 * GRID_THREAD_MIN_MOVES);
    }
}
