//! The planning grid: the program's moves in arc length ([`PathIndex`]), and the grid
//! points and intervals generated from them lazily, a window at a time ([`GridGen`]).
//!
//! Lines are one straight interval each (their limits are constant along them, and the
//! profile inside a straight interval may accelerate, cruise and decelerate, so no
//! subdivision is needed). Arcs and curves are first cut uniformly in their parameter
//! (halves no longer than about `MAX_CURVE_DS_MM` (0.5), at least `MIN_CURVE_INTERVALS` (2) per
//! move, per knot span for NURBS); their arc lengths come from the chords and end tangents
//! of the halves (`arc_from_chord`), the move's total from adaptive quadrature at
//! `ARCLEN_ACCURACY_MM` (the last interval takes the remainder).
//!
//! ## Refinement of curved intervals
//! The planner imposes the per-axis acceleration `a_i = u T_i + x K_i` exactly at both
//! ends of a curved interval and at its parameter midpoint ([`super::limits::IntervalMid`]; the
//! midpoint's speed cap too), with `u` constant and `x = v^2` linear in `s` inside it:
//! all of these are linear in the interval's two end values of `x`. On each half `a_i`
//! then differs from the straight line between its two checked values by three terms,
//! and an interval is bisected until each term is a small share of `A_i` on both halves
//! (together well inside the `ACC_PLANNING_FACTOR` (0.99) reserve):
//!
//! 1. the tangent's rotation: `u T_i` leaves the chord of its end values by up to
//!    `|u| (1 - cos(turn / 2))`, kept within `TANGENT_SHARE` (0.001)` A_i` (and the turn within
//!    `MAX_TURN_DEG` (4.0) for the velocity limits);
//! 2. the product of two linear functions: `x K_i` bulges by `|dx dK_i| / 4` with
//!    `dx = 2 u ds`, so `|u| ds |dK_i| / 2 <= ` `PRODUCT_SHARE` (0.004)` A_i`, with `|u|` bounded
//!    by the largest tangential acceleration the checked rows can allow ([`u_bound`]);
//!    this term shrinks with the square of the half, so curvature that changes fast over
//!    a short transition needs only a few intervals;
//! 3. curvature that is not linear in `s` inside the half: checked at the half's own
//!    midpoint (the interval's quarter points) against the chord of its end values,
//!    within `MAX_CURVATURE_BEND` (0.004) of the larger of the local curvature and the floor
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
//!    differ by `d` is bisected while `x_env^1.5 d / 2 > ` `RATE_BEND_SHARE` (0.01)` J_i` and it
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
//! a `G92 E0` ([`crate::path::EventKind::ExtraReset`]) changes the offset between programmed and machine
//! values, not the position, so the setpoints' extra columns stay continuous. A move of
//! extra axes only ([`crate::path::EventKind::ExtraMove`], a slicer's retract; also a zero-length move
//! that changes them) happens at a stop, X, Y and Z at rest: it takes the time of a
//! trapezoid over the largest axis change at its rate (the rapid rate when it has none)
//! and the smallest X/Y/Z acceleration limit ([`ExtraRest`]). Extra axes have no limits
//! of their own; the report gives their measured speeds and accelerations.

use super::StopReason;
use super::{jerk, planned_acc, planned_vaxis};
use crate::geom::Segment;
use crate::path::{ExtraAxes, MoveKind};

/// Largest tangent turn (degrees) inside one curved grid interval, whatever the
/// accelerations: a per-axis velocity limit checked at the ends is exceeded inside by at
/// most `1 / cos(turn / 2) - 1` (6e-4), within the [`super::VAXIS_PLANNING_FACTOR`]
/// reserve. The acceleration terms usually allow less (see [`TANGENT_SHARE`]).
pub(crate) const MAX_TURN_DEG: f64 = 4.0;
/// Share of the axis acceleration allowed for the tangent's rotation inside an interval
/// (term 1 of the module doc): `|u| (1 - cos(turn / 2)) <= share A`.
pub(crate) const TANGENT_SHARE: f64 = 0.001;
/// Longest half of a curved grid interval (mm).
pub(crate) const MAX_CURVE_DS_MM: f64 = 0.5;
/// Fewest intervals per curved move (per knot span for NURBS), each checked at its ends
/// and its midpoint. Two, so that a curved move between two stops has a grid point
/// inside it (on one interval `x` is linear, so two ends at rest would leave no motion).
pub(crate) const MIN_CURVE_INTERVALS: usize = 2;
/// Most intervals per move (a guard against absurd inputs).
pub(crate) const MAX_CURVE_INTERVALS: usize = 1 << 20;
/// Accuracy (mm) of the arc lengths of curved intervals.
pub(crate) const ARCLEN_ACCURACY_MM: f64 = 1e-10;
/// Share of the axis acceleration allowed for the bulge of `x K_i` inside an interval
/// (term 2 of the module doc).
pub(crate) const PRODUCT_SHARE: f64 = 0.004;
/// Largest distance of the curvature vector at the midpoints of an interval's halves from
/// the
/// chord of its end values, relative to the local curvature or the floor (term 3 of the
/// module doc).
pub(crate) const MAX_CURVATURE_BEND: f64 = 0.004;
/// Share of each axis's jerk limit allowed for the curvature rate a grid interval does
/// not resolve (term 4 of the module doc, jerk mode only).
pub(crate) const RATE_BEND_SHARE: f64 = 0.01;
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

mod builder;
mod feeder;
mod generate;
mod index;
mod joints;
mod refine;

#[cfg(test)]
pub(crate) use feeder::FEED_BATCH_MOVES;
pub use feeder::{IndexFeeder, MoveRef, RestRef};
pub(crate) use generate::GRID_QUEUE_BATCHES;
pub use generate::{GridBatch, GridGen, GridPoint};
pub use index::PathIndex;
pub use joints::caps_of;
pub use refine::{arc_step, u_bound};
