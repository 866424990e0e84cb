//! LinuxCNC's blend schedule: the `P` each written point of a chain may be given, from the
//! speed the machine reaches there and the room the tolerance leaves ([`BlendSchedule`]).

use super::CornerBlend;
use crate::controller::dialect::LINUXCNC_SERVO_PERIOD_S;
use ncsmooth::geom::Vec3;

/// LinuxCNC's share of the acceleration its blend arcs keep for the normal direction
/// (tp.c `BLEND_ACC_RATIO_NORMAL`, `sqrt(1 - 0.5^2)`).
pub const LINUXCNC_NORMAL_ACC_SHARE: f64 = 0.866_025_403_784_438_6;

/// LinuxCNC's share of the acceleration its arcs and blend arcs keep for the tangential
/// direction (tp.c `BLEND_ACC_RATIO_TANGENTIAL`).
pub const LINUXCNC_TANGENTIAL_ACC_SHARE: f64 = 0.5;

/// Passes of a [`BlendSchedule`]'s speed estimate: each takes the acceleration along a
/// block from the share of it the previous pass's blends take.
pub(crate) const BLEND_SCHEDULE_SPEED_PASSES: usize = 4;

/// Servo periods of straight line LinuxCNC leaves between two blend arcs; a shorter
/// remainder is consumed by the blends (tp.c `ARC_BLEND_GAP_CYCLES`).
pub const LINUXCNC_BLEND_GAP_CYCLES: f64 = 4.0;
/// [`LINUXCNC_BLEND_GAP_CYCLES`] in seconds.
const LINUXCNC_BLEND_GAP_S: f64 = LINUXCNC_BLEND_GAP_CYCLES * LINUXCNC_SERVO_PERIOD_S;

/// LinuxCNC's default `[TRAJ] ARC_BLEND_KINK_RATIO`: the share of the axes' acceleration
/// a kink between two moves may take before they are blended rather than joined as
/// tangent (tp.c `tpGetTangentKinkRatio`).
pub const LINUXCNC_TANGENT_KINK_RATIO: f64 = 0.1;

/// Smallest share of `P` a block gets under a [`BlendSchedule`] (the fastest of 1/8 to
/// 1/64 on LinuxCNC 2.9, docs/benchmarks/2026-12-03.md).
pub(crate) const BLEND_SCHEDULE_MIN_SHARE: f64 = 1.0 / 16.0;

/// Steps per halving of `P` a [`BlendSchedule`] rounds its shares up to (4: shares are
/// powers of `2^(1/4)`), trading `G64` lines for time (docs/benchmarks/2026-12-03.md).
pub(crate) const BLEND_SCHEDULE_STEPS_PER_HALVING: f64 = 4.0;

/// A block cut in two by a [`BlendSchedule`] (`BlendSchedule::splits`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Split {
    /// Where the first piece ends (on the written grid).
    pub(crate) point: Vec3,
    /// The two pieces' shares of `P`.
    pub(crate) shares: (f64, f64),
}

/// The point on the grid (`rounded`) between `a` and `b`, at least `room.0` from `a` and
/// `room.1` from `b`, whose kink (the largest axis component of the change of direction)
/// is least, if that is at most `kink_max`.
fn split_point(
    a: Vec3,
    b: Vec3,
    room: (f64, f64),
    rounded: impl Fn(Vec3) -> Vec3,
    kink_max: f64,
) -> Option<Vec3> {
    let len = (b - a).norm();
    let free = len - room.0 - room.1;
    if free.is_nan() || free <= 0.0 {
        return None;
    }
    (0..=SPLIT_CANDIDATES)
        .map(|i| {
            rounded(a + (b - a) * ((room.0 + free * i as f64 / SPLIT_CANDIDATES as f64) / len))
        })
        .filter(|&q| (q - a).norm() >= room.0 && (b - q).norm() >= room.1)
        .filter_map(|q| Some((((b - q).normalized()? - (q - a).normalized()?).max_abs(), q)))
        .filter(|&(kink, _)| kink <= kink_max)
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .map(|(_, q)| q)
}

/// The speed estimate and shares of a [`BlendSchedule`] for one chain.
#[derive(Clone, Debug)]
pub(crate) struct BlendPlan {
    /// Share of `P` per block.
    pub(crate) block: Vec<f64>,
    /// Share of `P` each vertex needs (at the end of block k).
    pub(crate) vertex: Vec<f64>,
    /// Speed estimate at each vertex (mm/s).
    pub(crate) speed: Vec<f64>,
    /// LinuxCNC's blend at each vertex.
    pub(crate) blends: Vec<VertexBlend>,
    /// The fastest feed the blends are sized for (mm/s).
    pub(crate) v: f64,
}

/// A [`BlendSchedule`] splits a block where that lowers a vertex's `P` by at least this
/// factor (two of its steps, [`BLEND_SCHEDULE_STEPS_PER_HALVING`]).
pub(crate) const SPLIT_MIN_GAIN: f64 = 1.41;
/// Room a split keeps on each piece over what LinuxCNC's blends need of it.
pub(crate) const SPLIT_ROOM: f64 = 1.2;
/// Largest share of the acceleration a split's kink may take (tp.c `tpSetupTangent`
/// joins two lines as tangent when the kink at full speed takes less than
/// [`LINUXCNC_TANGENT_KINK_RATIO`], and lowers both lines' acceleration by that share).
pub(crate) const SPLIT_KINK_RATIO: f64 = 0.02;
/// Points tried along a block for a split.
pub(crate) const SPLIT_CANDIDATES: usize = 256;

/// What moves next to a run of blocks at one of its ends, for a [`BlendSchedule`]'s
/// speed estimate.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum RunEnd {
    /// Not known: the estimate takes no limit there (it errs high).
    #[default]
    Free,
    /// The machine is at rest there: the program's start or end. LinuxCNC runs the
    /// program's last segment with half the acceleration (its end condition stays the
    /// parabolic blend's, tc.c `tcGetOverallMaxAccel`).
    Rest,
    /// A rapid moves there: LinuxCNC stops between a rapid and a feed move, and the feed
    /// move before it ends with a stop, at the full acceleration (tp.c
    /// `tpCheckCanonType`).
    Rapid,
    /// A move in this unit direction (of travel) joins the run there: LinuxCNC blends
    /// that junction within the run's `P` at most, which bounds the speed.
    Joins(Vec3),
}

impl RunEnd {
    /// The machine is at rest there: the program's ends, or a rapid.
    pub fn at_rest(self) -> bool {
        matches!(self, RunEnd::Rest | RunEnd::Rapid)
    }
}

/// The two ends of a run of blocks, see [`RunEnd`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RunEnds {
    /// What moves before the run's first block.
    pub before: RunEnd,
    /// What moves after its last block.
    pub after: RunEnd,
}

/// Per-block `G64 P` for LinuxCNC's blending of a flattened curve.
///
/// LinuxCNC blends two lines turning by `phi` with an arc tangent to both that takes
/// `d = min(P / tan(phi / 4), half the shorter line)` of each and has radius
/// `d / tan(phi / 2)` (`VertexBlend`, blendmath.c `blendComputeParameters`). At the
/// chords of a curve flattened within `c`, `P = c` gives about the curve's radius and
/// consumes every line, and LinuxCNC accelerates along what its blends consume with half
/// the acceleration (tc.c `tcGetTangentialMaxAccel`). A vertex whose speed `v` needs a
/// smaller radius (`v^2 / a_n`, `a_n` = [`LINUXCNC_NORMAL_ACC_SHARE`] of the
/// acceleration) gets the least `P` that gives it, and leaves LinuxCNC the rest of the
/// lines to accelerate on at the full rate.
///
/// `v` is a look-ahead estimate along the written lines: at most the machine's fastest
/// feed (or else the programmed one), at most what the blend with all of `P` allows, and
/// at most what the acceleration along the blocks reaches from the neighbouring vertices
/// (a forward and a backward pass). Along what the blends take of a block LinuxCNC
/// accelerates with [`LINUXCNC_TANGENTIAL_ACC_SHARE`] of the acceleration, the full rate
/// only on the line they leave, so the estimate is made again with the shares the last
/// one gave (`BLEND_SCHEDULE_SPEED_PASSES` passes at most). So the vertices where
/// LinuxCNC brakes for, or leaves, a tight turn get a small `P` as well, not only the
/// gently curved ones at full feed. A block whose blends leave less than
/// [`LINUXCNC_BLEND_GAP_CYCLES`] servo periods of line at that speed is consumed
/// (blendmath.c `blendCheckConsume`) and run at the blend's half acceleration; its
/// vertices still get only what their speed needs, the least `P` consuming the least of
/// the next blocks. Vertices LinuxCNC joins as tangent (below
/// [`LINUXCNC_TANGENT_KINK_RATIO`]) take nothing. Shares are clamped to
/// `BLEND_SCHEDULE_MIN_SHARE ..= 1` and rounded up to a power of `2^(1/4)`
/// (`BLEND_SCHEDULE_STEPS_PER_HALVING`); a block gets the larger of its two vertices'
/// (a blend uses the smaller `P` of its two blocks), and the run's ends where a move
/// may join them, and the run's own `P` after the chain, get all of it. `P` is never
/// larger than the run's, so the
/// tolerance budget is unchanged (the schedule's own shares; a programmed corner put in
/// place of short blocks, and a point whose speed needs all of `P`, get more where the
/// tolerance leaves it, [`crate::controller::linuxcnc::CornerBlend`], checked by the model of the
/// executed path).
///
/// A vertex between two blocks that carry more for their other vertices (a gentle turn
/// between two tight ones) gets its own share from a split of one of them
/// (`BlendSchedule::splits`): the point cutting it is on its line, a join LinuxCNC takes
/// as tangent, so the blend there leaves LinuxCNC its lines to accelerate on at the full
/// rate. What each of these steps gained on LinuxCNC 2.9 is in
/// docs/benchmarks/2026-12-03.md.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlendSchedule {
    /// The run's `P` (mm), the largest written.
    pub p_mm: f64,
    /// The run's `Q` (mm), written unchanged.
    pub q_mm: f64,
    /// The machine's acceleration (mm/s^2).
    pub acc_mm_s2: f64,
    /// The machine's fastest feed (mm/s), which a feed override may reach: the blends
    /// are sized for it; infinite for the programmed feeds.
    pub feed_max_mm_s: f64,
}

impl BlendSchedule {
    /// The share of `P` for each block from `start` through `pts` (one per point), or an
    /// empty list when `feed_mm_s` is unknown. `ends` bound the speed estimate at the
    /// run's ends: after a rapid that turns into the run, LinuxCNC starts it nearly at
    /// rest, and its first blocks need only the blends their speed from there needs.
    pub fn shares(
        &self,
        start: Vec3,
        pts: &[Vec3],
        feed_mm_s: Option<f64>,
        ends: RunEnds,
    ) -> Vec<f64> {
        self.plan(start, pts, feed_mm_s, ends)
            .map_or_else(Vec::new, |p| p.block)
    }

    /// The speed estimate and shares of [`BlendSchedule::shares`], `None` when the feed
    /// is unknown.
    pub(crate) fn plan(
        &self,
        start: Vec3,
        pts: &[Vec3],
        feed_mm_s: Option<f64>,
        ends: RunEnds,
    ) -> Option<BlendPlan> {
        self.plan_in(start, pts, feed_mm_s, ends, BLEND_SCHEDULE_SPEED_PASSES)
    }

    /// [`BlendSchedule::plan`] with at most `passes` of the speed estimate.
    fn plan_in(
        &self,
        start: Vec3,
        pts: &[Vec3],
        feed_mm_s: Option<f64>,
        ends: RunEnds,
        passes: usize,
    ) -> Option<BlendPlan> {
        let fastest = Some(self.feed_max_mm_s).filter(|v| v.is_finite());
        let v = fastest.or(feed_mm_s).filter(|v| *v > 0.0)?;
        let at = |j: usize| if j == 0 { start } else { pts[j - 1] };
        let n = pts.len();
        // blocks[k]: block k as a vector; blends[k]: the blend at the vertex ending it.
        let blocks: Vec<Vec3> = (0..n).map(|k| at(k + 1) - at(k)).collect();
        let tangent_rad = self.tangent_turn_rad(v);
        let blends: Vec<VertexBlend> = blocks
            .windows(2)
            .map(|b| VertexBlend::new(b[0], b[1], tangent_rad))
            .collect();
        // LinuxCNC accelerates along its blend arcs with half the acceleration: the
        // speeds are estimated again with the acceleration the shares leave, until the
        // shares settle.
        let mut arc_share = vec![0.0; n];
        let mut share = Vec::new();
        let mut vertex = Vec::new();
        let mut speed = Vec::new();
        for _ in 0..passes {
            speed = self.speeds(&blocks, &blends, v, ends, &arc_share);
            vertex = self.shares_at(blocks.len(), &blends, &speed);
            let next = Self::block_shares(&vertex, ends);
            let settled = next == share;
            share = next;
            if settled {
                break;
            }
            arc_share = self.arc_shares(&blocks, &blends, &share, &speed);
        }
        Some(BlendPlan {
            block: share,
            vertex,
            speed,
            blends,
            v,
        })
    }

    /// Splits that give a vertex the `P` its speed needs where both of its blocks carry
    /// more for their other vertices (a blend uses the smaller `P` of its two blocks):
    /// the block with room is cut by a point on its line, which LinuxCNC joins as tangent,
    /// and the piece at the vertex gets the vertex's share. `block` are the shares
    /// written (the plan's, raised at programmed corners), `rounded` puts a point on the
    /// written grid. Returns, per block, the point and the shares of its two pieces.
    ///
    /// A piece next to a blend holds twice what the blend takes (LinuxCNC takes at most
    /// half of a line) and four times its `P` (the blend tolerance is at most a quarter
    /// of the line), and the piece before a blend leaves [`LINUXCNC_BLEND_GAP_CYCLES`]
    /// of line at the vertex's speed, all with [`SPLIT_ROOM`]; the point is the one of
    /// [`SPLIT_CANDIDATES`] on the grid whose kink LinuxCNC's tangent rule takes with at
    /// most [`SPLIT_KINK_RATIO`] of the acceleration (tp.c `tpSetupTangent` lowers both
    /// pieces' acceleration by that share).
    pub(crate) fn splits(
        &self,
        plan: &BlendPlan,
        start: Vec3,
        pts: &[Vec3],
        block: &[f64],
        rounded: impl Fn(Vec3) -> Vec3,
    ) -> Vec<Option<Split>> {
        let n = pts.len();
        let mut out: Vec<Option<Split>> = vec![None; n];
        if block.len() != n {
            return out;
        }
        let at = |j: usize| if j == 0 { start } else { pts[j - 1] };
        let kink_max = SPLIT_KINK_RATIO * self.acc_mm_s2 * LINUXCNC_SERVO_PERIOD_S / plan.v;
        // Vertex k joins block k and block k + 1.
        for k in 0..n.saturating_sub(1) {
            // A vertex needing all of the run's `P` (or more) is left as it is: a share
            // above 1 is a programmed corner's own `P`.
            let want = Self::round_share(plan.vertex[k]);
            if want >= 1.0 || block[k].min(block[k + 1]) < want * SPLIT_MIN_GAIN {
                continue;
            }
            // Block k + 1 cut at its front (its end vertex keeps its share), or block k
            // at its back.
            let front = (k + 2 < n && out[k + 1].is_none()).then(|| {
                let keep = block[k + 1].min(block[k + 2]);
                let room = (
                    self.split_room(plan, k, want, false),
                    self.split_room(plan, k + 1, keep, true),
                );
                (k + 1, room, (want, block[k + 1]))
            });
            let back = (k >= 1 && out[k].is_none()).then(|| {
                let keep = block[k - 1].min(block[k]);
                let room = (
                    self.split_room(plan, k - 1, keep, false),
                    self.split_room(plan, k, want, true),
                );
                (k, room, (block[k], want))
            });
            let found = [front, back]
                .into_iter()
                .flatten()
                .find_map(|(j, room, shares)| {
                    let point = split_point(at(j), pts[j], room, &rounded, kink_max)?;
                    Some((j, Split { point, shares }))
                });
            if let Some((j, split)) = found {
                out[j] = Some(split);
            }
        }
        out
    }

    /// Length a piece needs next to vertex `k` under `share` of `P`; `before`: the piece
    /// ends there (LinuxCNC's line before the blend).
    fn split_room(&self, plan: &BlendPlan, k: usize, share: f64, before: bool) -> f64 {
        let p = share * self.p_mm;
        let reach = plan.blends[k].reach_mm(p);
        let gap = if before {
            reach + LINUXCNC_BLEND_GAP_S * plan.speed[k]
        } else {
            0.0
        };
        (2.0 * reach).max(gap).max(4.0 * p) * SPLIT_ROOM
    }

    /// `x` rounded up to a power of `2^(1/4)` ([`BLEND_SCHEDULE_STEPS_PER_HALVING`]), at
    /// most 1.
    pub(crate) fn round_share(x: f64) -> f64 {
        let steps = (x.log2() * BLEND_SCHEDULE_STEPS_PER_HALVING).ceil();
        2f64.powf(steps / BLEND_SCHEDULE_STEPS_PER_HALVING).min(1.0)
    }

    /// Each block's share from the shares at its two vertices: the larger (a blend uses
    /// the smaller `P` of its two blocks), rounded up to a power of `2^(1/4)`. The run's
    /// ends take all of `P` (a move outside the run may blend there), unless the machine
    /// is at rest there (LinuxCNC stops between a rapid and a feed move): then the end
    /// block's share is its other vertex's, and LinuxCNC's blend there takes no more of
    /// the block than that vertex's speed needs (camotics_vcarve trig: the first block
    /// after a plunge was blended with all of `P`, along its whole length, at half the
    /// acceleration).
    fn block_shares(vertex: &[f64], ends: RunEnds) -> Vec<f64> {
        let n = vertex.len();
        let end_share = |end: RunEnd| if end.at_rest() { 0.0 } else { 1.0 };
        (0..n)
            .map(|k| {
                let before = if k == 0 {
                    end_share(ends.before)
                } else {
                    vertex[k - 1]
                };
                let after = if k + 1 == n {
                    end_share(ends.after)
                } else {
                    vertex[k]
                };
                Self::round_share(before.max(after).max(BLEND_SCHEDULE_MIN_SHARE))
            })
            .collect()
    }

    /// The share of each block's length LinuxCNC's blends take under the blocks' shares
    /// `block` of `P` (a blend uses the smaller of its two blocks'): all of a block they
    /// consume.
    fn arc_shares(
        &self,
        blocks: &[Vec3],
        blends: &[VertexBlend],
        block: &[f64],
        speed: &[f64],
    ) -> Vec<f64> {
        let vertex: Vec<f64> = block.windows(2).map(|w| w[0].min(w[1])).collect();
        let last = speed.last().copied().unwrap_or(0.0);
        let at = |k: usize| speed.get(k).copied().unwrap_or(last);
        self.blend_takes(blocks, blends, &vertex, at)
            .into_iter()
            .zip(blocks)
            .map(|((taken, consumed), b)| if consumed { 1.0 } else { taken / b.norm() })
            .collect()
    }

    /// What LinuxCNC's blends take of each block (mm), the share of `P` at the vertex
    /// ending block k being `vertex[k]`, and whether they consume it: a block whose blends
    /// leave less than LinuxCNC's gap of straight line at `speed(k)` is consumed whatever
    /// its `P` (blendmath.c `blendCheckConsume`, at the blend's speed). At the run's ends,
    /// whose other side is not known here, the blend takes as much as LinuxCNC ever does.
    fn blend_takes(
        &self,
        blocks: &[Vec3],
        blends: &[VertexBlend],
        vertex: &[f64],
        speed: impl Fn(usize) -> f64,
    ) -> Vec<(f64, bool)> {
        // What the blend at the vertex ending block k takes of each line.
        let taken = |k: usize| match blends.get(k) {
            Some(b) => b.reach_mm(vertex[k] * self.p_mm),
            None => 0.5 * blocks[k].norm(),
        };
        (0..blocks.len())
            .map(|k| {
                let len = blocks[k].norm();
                let before = if k == 0 { 0.5 * len } else { taken(k - 1) };
                let arcs = before + taken(k);
                (arcs, len - arcs < LINUXCNC_BLEND_GAP_S * speed(k))
            })
            .collect()
    }

    /// The share of `P` at the vertex ending each of the `n` blocks for the speeds
    /// `speed` at the blends (1 at the run's end, which [`BlendSchedule::block_shares`]
    /// replaces by what the run's end needs).
    fn shares_at(&self, n: usize, blends: &[VertexBlend], speed: &[f64]) -> Vec<f64> {
        let a_n = LINUXCNC_NORMAL_ACC_SHARE * self.acc_mm_s2;
        (0..n)
            .map(|k| match blends.get(k) {
                Some(b) => {
                    let p = b.p_for_radius_mm(speed[k] * speed[k] / a_n);
                    (p / self.p_mm).clamp(BLEND_SCHEDULE_MIN_SHARE, 1.0)
                }
                None => 1.0,
            })
            .map(|x| if x.is_nan() { 1.0 } else { x })
            .collect()
    }

    /// The speed bound at a run's end whose block there is `block`: none where the end is
    /// free, 0 at rest, and where a move joins it, what LinuxCNC's blend within the run's
    /// `P` allows at that junction (the half-line bound, which needs the other move's
    /// length, left out: the bound errs high).
    fn end_speed(&self, end: RunEnd, block: Vec3) -> Option<f64> {
        match end {
            RunEnd::Free => None,
            RunEnd::Rest | RunEnd::Rapid => Some(0.0),
            RunEnd::Joins(d) => {
                let blend = VertexBlend {
                    half_line_mm: f64::INFINITY,
                    ..VertexBlend::new(d, block, 0.0)
                };
                let r = blend.radius_mm(self.p_mm);
                r.is_finite()
                    .then(|| (LINUXCNC_NORMAL_ACC_SHARE * self.acc_mm_s2 * r).sqrt())
            }
        }
    }

    /// The turn (rad) below which LinuxCNC joins two lines at feed `v` as tangent, without a
    /// blend (tp.c `tpSetupTangent`: the kink's acceleration `(v / T + a) turn` within
    /// [`LINUXCNC_TANGENT_KINK_RATIO`] of the axes' `a`).
    fn tangent_turn_rad(&self, v: f64) -> f64 {
        let a = self.acc_mm_s2;
        LINUXCNC_TANGENT_KINK_RATIO * a / (v / LINUXCNC_SERVO_PERIOD_S + a)
    }

    /// Speed at each vertex (mm/s) between `blocks` (as vectors), `blends` at those
    /// vertices: at most `v`, what a blend with all of `P` allows, and what the
    /// acceleration along the blocks reaches from the neighbouring vertices: LinuxCNC's
    /// tangential limit of a line (the smallest axis limit over that axis's share of the
    /// direction) on the part of block `k` its blends leave, and
    /// [`LINUXCNC_TANGENTIAL_ACC_SHARE`] of the acceleration on the share `arc_share[k]`
    /// they take. The run's ends are bounded by `ends`.
    fn speeds(
        &self,
        blocks: &[Vec3],
        blends: &[VertexBlend],
        v: f64,
        ends: RunEnds,
        arc_share: &[f64],
    ) -> Vec<f64> {
        let a_n = LINUXCNC_NORMAL_ACC_SHARE * self.acc_mm_s2;
        let mut s: Vec<f64> = blends
            .iter()
            .map(|b| {
                let r = b.radius_mm(self.p_mm);
                if r.is_nan() {
                    v
                } else {
                    v.min((a_n * r).sqrt())
                }
            })
            .collect();
        // Speed reached from `from` along block `k`, whose blends take `arc_share[k]` of it.
        let along = |k: usize, from: f64| -> f64 {
            let d = blocks[k];
            let len = d.norm();
            let line = self.acc_mm_s2 * len / d.max_abs().max(f64::MIN_POSITIVE);
            let arc = LINUXCNC_TANGENTIAL_ACC_SHARE * self.acc_mm_s2;
            let x = arc_share.get(k).copied().unwrap_or(0.0);
            let acc = x * arc + (1.0 - x) * line;
            (from * from + 2.0 * acc * len).sqrt()
        };
        // Block k + 1 joins vertex k to vertex k + 1.
        let reach = |k: usize, from: f64| -> f64 { along(k + 1, from) };
        let n = blocks.len();
        if s.is_empty() {
            return s;
        }
        if let (Some(v0), Some(first)) = (self.end_speed(ends.before, blocks[0]), s.first_mut()) {
            *first = first.min(along(0, v0));
        }
        if let (Some(v1), Some(last)) = (self.end_speed(ends.after, blocks[n - 1]), s.last_mut()) {
            *last = last.min(along(n - 1, v1));
        }
        for k in 1..s.len() {
            s[k] = s[k].min(reach(k - 1, s[k - 1]));
        }
        for k in (0..s.len().saturating_sub(1)).rev() {
            s[k] = s[k].min(reach(k, s[k + 1]));
        }
        s
    }
}

/// Points sampled along each line where LinuxCNC's blend at a point given more than the
/// run's `P` may run, to bound the line's deviation there.
pub(crate) const ROOM_SAMPLES: usize = 32;

/// The `P` point `k` of a chain from `start` through `pts` (not the last) may take under
/// LinuxCNC, as a [`VertexRoom`]; `corner`: a programmed corner put in place of short
/// blocks. LinuxCNC's blend there runs within `reach` of the point along its two lines
/// (at most half of each, and what `c.max_p_mm` gives: [`VertexBlend`]) and within its
/// `P` of them.
///
/// * (a) Every point of the blend is within `P` of a point of the lines within reach,
///   which are at most `line_dev` from the programmed path ([`ROOM_SAMPLES`] samples
///   each, 1-Lipschitz).
/// * (b) A programmed vertex whose nearest written point is within reach is at most its
///   distance to it plus the blend's depth from the executed path (`gap`: the largest
///   such distance, given the parts within reach and the written lines around them).
///
/// The blend may take what the tolerance leaves after the larger of the two, up to
/// `c.max_p_mm`.
pub(crate) fn vertex_room(
    k: usize,
    start: Vec3,
    pts: &[Vec3],
    corner: bool,
    c: CornerBlend,
    line_dev: impl Fn(Vec3, Vec3) -> f64,
    gap: impl Fn(&[(Vec3, Vec3)], &[(Vec3, Vec3)]) -> f64,
) -> VertexRoom {
    let at = |j: usize| if j == 0 { start } else { pts[j - 1] };
    let (a, v, b) = (at(k), pts[k], pts[k + 1]);
    let reach = VertexBlend::new(v - a, b - v, 0.0).reach_mm(c.max_p_mm);
    let toward = |p: Vec3| v + (p - v) * (reach / v.dist(p)).min(0.5);
    let (ra, rb) = (toward(a), toward(b));
    let within = [(ra, v), (v, rb)];
    // The rest of the written lines around them.
    let mut others = vec![(a, ra), (rb, b)];
    others.extend((k >= 1).then(|| (at(k - 1), a)));
    others.extend((k + 2 < pts.len()).then(|| (b, pts[k + 2])));
    let taken = line_dev(ra, v)
        .max(line_dev(v, rb))
        .max(gap(&within, &others));
    let p_mm = c.max_p_mm.min(c.total_mm - taken);
    VertexRoom {
        p_mm: if p_mm.is_nan() { 0.0 } else { p_mm },
        corner,
    }
}

/// The `P` a written point may take under LinuxCNC ([`vertex_room`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct VertexRoom {
    /// Largest `P` (mm) within the tolerance there.
    p_mm: f64,
    /// A programmed corner put in place of short blocks.
    corner: bool,
}

/// Raises the blocks' shares `block` of the run's `P` (`run_p_mm`) so that the blends at
/// the programmed corners put in place of short blocks, and at the points `sharp` says
/// need all of the run's `P` (giving their speed estimate), get what `rooms` allows them.
/// LinuxCNC blends a point with the smaller `P` of its two blocks, so a point's raise
/// lifts both of them, as far as the points at their other ends stay within their own
/// room (or the share they had: the run's `P` is within the tolerance only where the
/// model of the executed path confirms it). Corners go first, then the slowest points;
/// a chain's end point is raised only next to a stop (`ends` at rest: LinuxCNC stops
/// between a rapid and a feed move, tp.c `tpCheckCanonType`), since the move beyond it
/// has a `P` of its own.
pub(crate) fn raise_for_rooms(
    block: &mut [f64],
    rooms: &[Option<VertexRoom>],
    run_p_mm: f64,
    ends: RunEnds,
    sharp: impl Fn(usize) -> Option<f64>,
) {
    let n = block.len();
    // The largest share each point's blend may get: its room, or what it had.
    let had: Vec<f64> = block.windows(2).map(|w| w[0].min(w[1])).collect();
    let lim = |k: usize| match rooms.get(k).copied().flatten() {
        Some(r) => (r.p_mm / run_p_mm).max(had[k]),
        None => had[k],
    };
    let (first, last) = raised_span(n, ends);
    // Corners first, then the slowest points.
    let mut order: Vec<(usize, f64, f64)> = rooms
        .iter()
        .enumerate()
        .filter_map(|(k, r)| Some((k, (*r)?)))
        .filter(|&(k, r)| r.p_mm > run_p_mm && k + 1 < n)
        .filter_map(|(k, r)| match (r.corner, k >= first && k + 1 < last) {
            (true, _) => Some((k, f64::NEG_INFINITY, r.p_mm)),
            (false, true) => sharp(k).map(|v| (k, v, r.p_mm)),
            (false, false) => None,
        })
        .collect();
    order.sort_by(|x, y| x.1.total_cmp(&y.1));
    for (k, _, p_mm) in order {
        let share = p_mm / run_p_mm;
        // Each block's raise, held where the point at its other end would get more than
        // it may.
        let mut a = block[k].max(share);
        if k >= 1 && block[k - 1] > lim(k - 1) {
            a = a.min(lim(k - 1).max(block[k]));
        }
        let mut b = block[k + 1].max(share);
        if k + 2 < n && block[k + 2] > lim(k + 1) {
            b = b.min(lim(k + 1).max(block[k + 1]));
        }
        let got = a.min(b);
        if got > 1.0 {
            block[k] = block[k].max(got);
            block[k + 1] = block[k + 1].max(got);
        }
    }
}

/// The points of a chain of `n` blocks (`first..last - 1`) whose blend may be raised
/// unless they are programmed corners: not a chain's end point next to a move of
/// unknown `P` (`ends`), which LinuxCNC blends with the smaller of the two.
pub(crate) fn raised_span(n: usize, ends: RunEnds) -> (usize, usize) {
    let first = if ends.before.at_rest() { 0 } else { 1 };
    let last = if ends.after.at_rest() {
        n
    } else {
        n.saturating_sub(1)
    };
    (first, last)
}

/// LinuxCNC's blend arc between two lines (blendmath.c `blendComputeParameters`): tangent
/// to both, it takes at most half of each line (`BLEND_DIST_FRACTION`) and, within `P`,
/// at most `P / tan(phi / 4)` of each, `phi` the turn; its radius is what it takes over
/// `tan(phi / 2)`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct VertexBlend {
    /// `tan(phi / 2)`.
    tan_half: f64,
    /// `tan(phi / 4)`.
    tan_quarter: f64,
    /// Half the shorter line (mm).
    half_line_mm: f64,
}

impl VertexBlend {
    /// The blend between lines `u` and `w`; none (it takes nothing, and its radius is
    /// NaN) where they turn less than `tangent_rad`.
    pub(crate) fn new(u: Vec3, w: Vec3, tangent_rad: f64) -> VertexBlend {
        let phi = u.angle_to(w);
        if phi < tangent_rad {
            return VertexBlend {
                tan_half: 0.0,
                tan_quarter: 0.0,
                half_line_mm: 0.0,
            };
        }
        VertexBlend {
            tan_half: (0.5 * phi).tan(),
            tan_quarter: (0.25 * phi).tan(),
            half_line_mm: 0.5 * u.norm().min(w.norm()),
        }
    }

    /// Length of each line a blend within `p_mm` takes.
    fn reach_mm(&self, p_mm: f64) -> f64 {
        self.half_line_mm.min(p_mm / self.tan_quarter)
    }

    /// How far inside the vertex the blend within `p_mm` passes (at most `p_mm`).
    pub(crate) fn depth_mm(&self, p_mm: f64) -> f64 {
        self.reach_mm(p_mm) * self.tan_quarter
    }

    /// Radius of the blend within `p_mm`.
    pub(crate) fn radius_mm(&self, p_mm: f64) -> f64 {
        self.reach_mm(p_mm) / self.tan_half
    }

    /// The least `P` whose blend has radius `r_mm`, or all the lines allow.
    fn p_for_radius_mm(&self, r_mm: f64) -> f64 {
        (r_mm * self.tan_half).min(self.half_line_mm) * self.tan_quarter
    }
}

#[cfg(test)]
mod tests;
