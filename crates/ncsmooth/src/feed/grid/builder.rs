//! [`IndexBuilder`], the walk over the program's blocks shared by [`PathIndex::new`] and
//! [`IndexFeeder`](super::IndexFeeder): moves, stops, extra-axis rests, and in jerk mode the
//! close G1 joints ([`CloseJoint`]).

use super::index::{curvature_at, tangent_at};
use super::joints::{abs_max, end_rate, joint_after};
use super::{After, ExtraMotion, ExtraRest, PlanMove};
use crate::feed::limits::{Caps, NEGLIGIBLE};
use crate::feed::{PlanOptions, StopReason};
use crate::geom::Vec3;
use crate::path::{EventKind, ExtraAxes, Move, MoveKind};
use crate::verify::DEGENERATE_MM;

/// The state of [`PathIndex::new`] while it walks the program's blocks.
pub(super) struct IndexBuilder<'o> {
    pub(super) opts: &'o PlanOptions,
    pub(super) caps: Caps,
    pub(super) moves: Vec<PlanMove>,
    /// The stop being collected before the next move (reason, time at rest).
    pending: Option<(StopReason, f64)>,
    pub(super) lead: Option<(StopReason, f64)>,
    pub(super) s: f64,
    /// Extra axes: programmed values and the machine offset (`G92 E`).
    prog: Option<ExtraAxes>,
    offset: ExtraAxes,
    extra_acc: f64,
    pub(super) rests: Vec<ExtraRest>,
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
    pub(super) fn new(opts: &'o PlanOptions, caps: Caps) -> Self {
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
    pub(super) fn end(&mut self) {
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

    pub(super) fn event(&mut self, kind: &EventKind) {
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
            // Applied from the next block on, without a stop (the corner there is the
            // program's, and its joint is planned as any other).
            EventKind::SpindleSpeed(_) => {}
            _ => self.add_stop(StopReason::Event, 0.0),
        }
    }

    /// Indexes the next move, of length `len` and joint `joint` with the move block that
    /// follows it (if any).
    pub(super) fn push_move(&mut self, m: &Move, len: f64, joint: Option<After>) {
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
    pub(super) fn held_back_from(&self) -> usize {
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
