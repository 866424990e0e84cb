//! Feed planning: the speed along the path under the machine's limits, as fast as they
//! allow.
//!
//! ## Model
//! The path is parameterised by its arc length `s` (mm). Planning works in the phase plane
//! of `x = v^2` against `s`, on a grid of points `s_k` ([`grid`]): at every move boundary,
//! and inside arcs and curves as densely as the error terms between two checks require
//! (see the [`grid`] doc). On each grid
//! interval the tangential acceleration `u = dv/dt = (x_{k+1} - x_k) / (2 ds)` is
//! constant, so `x` is linear in `s` (the trapezoid, "linear acceleration" profile of Wu
//! et al. section IV, generalised to per-axis limits as in TOPP-RA).
//!
//! ## Limits ([`limits`])
//! * speed caps at every grid point: the feed (the lower of the programmed F and
//!   [`PlanOptions::feed_mm_s`]; rapids at [`PlanOptions::rapid_mm_s`]), the per-axis
//!   velocity `v |T_i| <= V_i`, the curvature limit `v^2 |K_i| <= A_i` for every axis
//!   (`K` the curvature vector; this is `v <= sqrt(a_dir R)` with `a_dir = min_i A_i/|n_i|`
//!   the largest acceleration the axes allow along the unit normal `n`), and the chord-error
//!   limit of Wu eq. 21, `v <= (2/T) sqrt(delta (2R - delta))` (for `R <= delta` any chord
//!   up to the diameter is within `delta`, so the cap becomes `2R/T`);
//! * per-axis acceleration on every interval: `|u T_i + x K_i| <= A_i`, imposed exactly
//!   (as linear constraints in `(x_k, x_{k+1})`) at *both* ends of the interval, with the
//!   geometry of that side, and at the midpoint of curved intervals (where `x` is the
//!   linear mix of the two). For lines this is exact everywhere; inside arcs and curves the
//!   grid is refined until what can happen between the checks (the tangent's turn, the
//!   product of the linear `x` with the changing curvature, curvature bumps) stays within
//!   a stated share of the limit, inside the planning reserve below.
//!
//! ## Joints
//! A tangent break (turn above [`crate::verify::TANGENT_TOL_DEG`]) at non-zero speed is an
//! infinite acceleration, so it is an **exact stop**, unless
//! [`PlanOptions::junction_dev_mm`] asks for grbl's junction-deviation rule: the corner is
//! passed at `v^2 = a delta sin(theta/2) / (1 - sin(theta/2))` (theta the angle between
//! the reversed incoming and the outgoing direction, `a` the largest acceleration the axes
//! allow along the direction change). That rule models a virtual arc the machine never
//! follows: the velocity still jumps between two setpoints, so the finite-difference
//! acceleration at such corners exceeds `--acc`; the report says so honestly.
//! A G1 joint (tangent-continuous, curvature jump `dK`) limits the speed so that the
//! per-axis step of the normal acceleration stays within the limit: `v^2 |dK_i| <= A_i`.
//! Events (spindle, coolant, tool, ...) and dwells are exact stops too (the controller
//! synchronises there); a dwell adds its time at rest. A position gap (never produced by
//! the parser) is a stop followed by a jump, counted apart.
//!
//! ## Look-ahead ([`lookahead`])
//! Bidirectional: a backward pass from the end of a window (assumed a stop) gives the
//! largest speed from which the machine can still slow down in time; a forward pass from the
//! current state accelerates as hard as the constraints allow below it. Windows are bounded
//! (a few thousand grid points) and streamed: the backward pass of a window is final at and
//! before the last grid point where it equals the static speed cap (the assumed stop at
//! the window end cannot influence anything before such a point, since a longer window
//! could only raise the backward limit, which is already at the cap). Only that prefix is
//! committed; the rest of the window is kept for the next one. The whole velocity-limit
//! curve is planned this way, never segment by segment, so dense micro-segment programs
//! do not oscillate.
//!
//! ## Choices where the papers are loose
//! * The acceleration limits are planned at `ACC_PLANNING_FACTOR` (0.99) of the given value, a
//!   1 % reserve for what happens between the grid checks and for the interpolator's
//!   sub-micrometre position errors (both show up in finite differences); the per-axis
//!   velocity limits likewise at `VAXIS_PLANNING_FACTOR` (0.999).
//!
//! ## Limits the setpoints can show ([`PlanOptions::validate`])
//! The limits are measured on the setpoints as printed (positions to
//! `PRINT_RESOLUTION_MM` (1e-9)) by finite differences at the period `T`, and must hold there
//! without any allowance ([`crate::interp::PlanReport::limits_held`]). Rounding and the
//! interpolator's arc-length landing put errors of up to half a print unit on every
//! position; a `k`-th difference weighs them with binomial weights, so it shows up to
//! `VEL_NOISE_MM` (2e-9)` / T`, `ACC_NOISE_MM` (4e-9)` / T^2` and `jerk::JERK_NOISE_MM` ` / T^3`
//! of velocity, acceleration and jerk on a motion that holds its limit exactly. Each
//! limit is therefore planned with that noise deducted on top of the share the grid's
//! between-check terms need ([`planned_acc`], [`planned_vaxis`], [`jerk::planned_jerk`]);
//! at the usual settings the relative reserves above are larger and nothing changes.
//! A limit so small that the deduction would leave less than `MIN_LIMIT_FRACTION` (0.5) of it
//! is **refused** ([`PlanOptionsError::Unresolvable`], with the smallest value that can
//! be held): no motion printed at that resolution and period can show it (any motion
//! from rest needs a third difference of at least one print unit somewhere, i.e. a
//! jerk of `1e-9 / T^3` mm/s^3, 1 mm/s^3 at 1 ms). The floors scale as `1/T`, `1/T^2`
//! and `1/T^3`: a longer period resolves smaller limits. The feed and rapid rates are
//! commanded speeds, planned at their value; the measured axis speeds may exceed them by
//! the first difference's noise, `VEL_NOISE_MM` (2e-9)` / T` (a jerk-filtered run at the feed
//! showed 1.17 print units per period on camotics_tiger), and a rate is refused when one
//! print unit per period is more than `FEED_NOISE_SHARE` (1e-3) of it.
//! * Every stop is held until the next period boundary, so the stop point itself is a
//!   setpoint (the corner is not cut between two setpoints) and the next motion starts on
//!   the period grid.
//!
//! ## Jerk limiting
//! With [`PlanOptions::jerk_mm_s3`] the profile is a jerk-limited S-curve holding every
//! axis's jerk limit: the trapezoid planned under tighter, dilated caps and a scalar
//! tangential limit, then averaged over a time window. See [`jerk`] for the scheme, its
//! proof and its cost.

pub mod grid;
pub mod jerk;
pub mod limits;
pub mod lookahead;
pub mod window;

pub use grid::{PathIndex, PlanMove};
pub use lookahead::{plan_stream, PlanEvent, PlanStats, ProfilePiece};

use serde::Serialize;

/// Fraction of the acceleration limits the planner uses (see the module doc).
pub(crate) const ACC_PLANNING_FACTOR: f64 = 0.99;
/// Fraction of the per-axis velocity limits the planner uses, a reserve for the
/// interpolator's sub-micrometre position errors; inside curved intervals the velocity
/// caps already allow for the tangent's turn (see [`grid`]).
pub(crate) const VAXIS_PLANNING_FACTOR: f64 = 0.999;
/// Resolution of the printed setpoint positions (mm): 9 decimals.
pub(crate) const PRINT_RESOLUTION_MM: f64 = 1e-9;
/// Largest error of a first difference of printed positions (mm): rounding (2 x 0.5e-9)
/// plus the interpolator's arc-length landing (2 x 0.5e-9).
pub(crate) const VEL_NOISE_MM: f64 = 2e-9;
/// Largest error of a second difference of printed positions (mm): rounding and landing
/// errors of 0.5e-9 each, weights 1, 2, 1.
pub(crate) const ACC_NOISE_MM: f64 = 4e-9;
/// Share of an acceleration limit the grid's between-check terms may use
/// ([`grid::TANGENT_SHARE`] + [`grid::PRODUCT_SHARE`] + [`grid::MAX_CURVATURE_BEND`]);
/// the rest of the [`ACC_PLANNING_FACTOR`] reserve covers the finite-difference noise
/// until that exceeds it.
pub(crate) const ACC_CHECK_SHARE: f64 =
    grid::TANGENT_SHARE + grid::PRODUCT_SHARE + grid::MAX_CURVATURE_BEND;
/// Share of a per-axis velocity limit the tangent's turn inside a curved interval may use:
/// `1 / cos(`[`grid::MAX_TURN_DEG`]` / 2) - 1` = 6.09e-4, rounded up.
pub(crate) const VAXIS_CHECK_SHARE: f64 = 6.1e-4;
// The between-check shares fit inside the relative reserves.
const _: () = assert!(ACC_CHECK_SHARE < 1.0 - ACC_PLANNING_FACTOR);
const _: () = assert!(VAXIS_CHECK_SHARE < 1.0 - VAXIS_PLANNING_FACTOR);
/// Smallest fraction of a limit left after the noise deduction; a smaller limit is refused
/// (see the module doc).
pub(crate) const MIN_LIMIT_FRACTION: f64 = 0.5;
/// Largest share of the feed or rapid rate the print noise of a measured axis speed,
/// one print unit per period, may be; slower rates are refused.
pub(crate) const FEED_NOISE_SHARE: f64 = 1e-3;

/// The acceleration limit `a` (mm/s^2) as planned at period `period_s` (s): the
/// `ACC_PLANNING_FACTOR` (0.99) reserve, or the grid's share plus the finite-difference noise
/// when that is larger (see the module doc).
pub fn planned_acc(a: f64, period_s: f64) -> f64 {
    (ACC_PLANNING_FACTOR * a)
        .min((1.0 - ACC_CHECK_SHARE) * a - ACC_NOISE_MM / (period_s * period_s))
}

/// The per-axis velocity limit `v` (mm/s) as planned at period `period_s` (s), like
/// [`planned_acc`].
pub fn planned_vaxis(v: f64, period_s: f64) -> f64 {
    (VAXIS_PLANNING_FACTOR * v).min((1.0 - VAXIS_CHECK_SHARE) * v - VEL_NOISE_MM / period_s)
}

/// Smallest acceleration limit (mm/s^2) held at period `period_s`: below it
/// [`planned_acc`] would be less than `MIN_LIMIT_FRACTION` (0.5) of the limit.
pub fn min_acc_mm_s2(period_s: f64) -> f64 {
    ACC_NOISE_MM / (period_s * period_s) / (1.0 - ACC_CHECK_SHARE - MIN_LIMIT_FRACTION)
}

/// Smallest per-axis velocity limit (mm/s) held at period `period_s`.
pub fn min_vaxis_mm_s(period_s: f64) -> f64 {
    VEL_NOISE_MM / period_s / (1.0 - VAXIS_CHECK_SHARE - MIN_LIMIT_FRACTION)
}

/// Smallest feed or rapid rate (mm/s) at period `period_s`: one print unit per period is
/// `FEED_NOISE_SHARE` (1e-3) of it.
pub fn min_feed_mm_s(period_s: f64) -> f64 {
    PRINT_RESOLUTION_MM / period_s / FEED_NOISE_SHARE
}

/// Machine limits and planning settings.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[non_exhaustive]
pub struct PlanOptions {
    /// Largest feed (mm/s); a lower programmed F wins. Default 50 mm/s.
    pub feed_mm_s: f64,
    /// Rapid (G0) speed (mm/s). Default `None`: equal to `feed_mm_s`.
    pub rapid_mm_s: Option<f64>,
    /// Per-axis acceleration limits x, y, z (mm/s^2). Default 500 mm/s^2 each.
    pub acc_mm_s2: [f64; 3],
    /// Per-axis jerk limits x, y, z (mm/s^3). Default `None`: the trapezoid profile
    /// (linear acceleration, not jerk-limited); `Some`: the S-curve of [`jerk`].
    pub jerk_mm_s3: Option<[f64; 3]>,
    /// Per-axis velocity limits x, y, z (mm/s). Default `None` (only the feed applies).
    pub vaxis_mm_s: Option<[f64; 3]>,
    /// Interpolation period T (s). Default 0.001 s.
    pub period_s: f64,
    /// Chord error delta (mm) of Wu eq. 21. Default 0.001 mm.
    pub chord_error_mm: f64,
    /// Junction deviation (mm) of grbl's corner rule; `None` (default) makes every tangent
    /// break an exact stop.
    pub junction_dev_mm: Option<f64>,
    /// Jerk mode: the split of the limits ([`jerk::JerkSplit`]); `None` (default): the
    /// planning run ([`crate::interp::execute`]) takes the fastest of
    /// `SPLIT_CANDIDATES` for the path ([`jerk::fastest_split`]); planning
    /// functions given `None` directly use `jerk::JerkSplit::DEFAULT`.
    pub jerk_split: Option<jerk::JerkSplit>,
    /// Jerk mode: how the S-curve is made. Default [`JerkScheme::Filter`].
    pub jerk_scheme: JerkScheme,
    /// The fastest any move of the path may go (mm/s), when known below the feed and
    /// rapid limits: the programmed feeds' largest under `feed_mm_s`, the rapid speed if
    /// the path has rapids. It sets jerk mode's window and the reach of its dilated caps
    /// ([`PlanOptions::top_speed`]), which the limits alone would size for a speed no
    /// move reaches. Default `None`: [`crate::interp::execute_into`] finds it on the
    /// path; a streamed plan takes the feed and rapid limits.
    pub top_speed_mm_s: Option<f64>,
}

/// Builders: each sets one field (see its doc for the default).
impl PlanOptions {
    /// Sets [`PlanOptions::feed_mm_s`].
    pub fn with_feed_mm_s(mut self, feed_mm_s: f64) -> Self {
        self.feed_mm_s = feed_mm_s;
        self
    }

    /// Sets [`PlanOptions::rapid_mm_s`].
    pub fn with_rapid_mm_s(mut self, rapid_mm_s: Option<f64>) -> Self {
        self.rapid_mm_s = rapid_mm_s;
        self
    }

    /// Sets [`PlanOptions::acc_mm_s2`].
    pub fn with_acc_mm_s2(mut self, acc_mm_s2: [f64; 3]) -> Self {
        self.acc_mm_s2 = acc_mm_s2;
        self
    }

    /// Sets [`PlanOptions::jerk_mm_s3`].
    pub fn with_jerk_mm_s3(mut self, jerk_mm_s3: Option<[f64; 3]>) -> Self {
        self.jerk_mm_s3 = jerk_mm_s3;
        self
    }

    /// Sets [`PlanOptions::vaxis_mm_s`].
    pub fn with_vaxis_mm_s(mut self, vaxis_mm_s: Option<[f64; 3]>) -> Self {
        self.vaxis_mm_s = vaxis_mm_s;
        self
    }

    /// Sets [`PlanOptions::period_s`].
    pub fn with_period_s(mut self, period_s: f64) -> Self {
        self.period_s = period_s;
        self
    }

    /// Sets [`PlanOptions::chord_error_mm`].
    pub fn with_chord_error_mm(mut self, chord_error_mm: f64) -> Self {
        self.chord_error_mm = chord_error_mm;
        self
    }

    /// Sets [`PlanOptions::junction_dev_mm`].
    pub fn with_junction_dev_mm(mut self, junction_dev_mm: Option<f64>) -> Self {
        self.junction_dev_mm = junction_dev_mm;
        self
    }

    /// Sets [`PlanOptions::jerk_split`].
    pub fn with_jerk_split(mut self, jerk_split: Option<jerk::JerkSplit>) -> Self {
        self.jerk_split = jerk_split;
        self
    }

    /// Sets [`PlanOptions::jerk_scheme`].
    pub fn with_jerk_scheme(mut self, jerk_scheme: JerkScheme) -> Self {
        self.jerk_scheme = jerk_scheme;
        self
    }

    /// Sets [`PlanOptions::top_speed_mm_s`].
    pub fn with_top_speed_mm_s(mut self, top_speed_mm_s: Option<f64>) -> Self {
        self.top_speed_mm_s = top_speed_mm_s;
        self
    }
}

/// How jerk mode makes its S-curve.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub enum JerkScheme {
    /// The trapezoid under tighter caps, averaged over a time window: provable by
    /// construction, conservative ([`jerk`]).
    #[default]
    Filter,
    /// The setpoints chosen one period at a time under the limits as measured, below a
    /// braking-feasible ceiling, with backtracking ([`crate::interp`]'s follower): near
    /// time-optimal on smooth paths, slower to compute, a run held whole.
    Follow,
}

impl Default for PlanOptions {
    fn default() -> Self {
        PlanOptions {
            feed_mm_s: 50.0,
            rapid_mm_s: None,
            acc_mm_s2: [500.0; 3],
            jerk_mm_s3: None,
            vaxis_mm_s: None,
            period_s: 0.001,
            chord_error_mm: 0.001,
            junction_dev_mm: None,
            jerk_split: None,
            jerk_scheme: JerkScheme::Filter,
            top_speed_mm_s: None,
        }
    }
}

/// Invalid planning options.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlanOptionsError {
    /// Not a positive finite number.
    #[error("{name} = {value} is invalid: a positive finite number is required")]
    NotPositive {
        /// Option name.
        name: &'static str,
        /// Offending value.
        value: f64,
    },
    /// A limit too small for the setpoints to show at this period (see the module doc).
    #[error(
        "{name} = {value} {unit} cannot be held at period {period_s} s: setpoints are printed \
         to 1e-9 mm, and rounding and interpolation alone show up to {noise:.4e} {unit} in \
         their finite differences; the smallest {name} held at this period is {min:.4e} {unit} \
         (it scales as 1/period^{order}: a longer period allows smaller limits)"
    )]
    Unresolvable {
        /// Option name.
        name: &'static str,
        /// Offending value.
        value: f64,
        /// Unit of the value.
        unit: &'static str,
        /// Finite-difference noise of the printed setpoints at this period.
        noise: f64,
        /// Smallest value held at this period.
        min: f64,
        /// The period (s).
        period_s: f64,
        /// Order of the finite difference (1 velocity, 2 acceleration, 3 jerk).
        order: u8,
    },
}

fn positive(name: &'static str, value: f64) -> Result<(), PlanOptionsError> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(PlanOptionsError::NotPositive { name, value })
    }
}

/// `value` (already positive) is at least `min`; else [`PlanOptionsError::Unresolvable`].
fn resolvable(
    name: &'static str,
    value: f64,
    unit: &'static str,
    order: u8,
    min: f64,
    period_s: f64,
) -> Result<(), PlanOptionsError> {
    if value >= min {
        return Ok(());
    }
    let noise = match order {
        1 => VEL_NOISE_MM / period_s,
        2 => ACC_NOISE_MM / period_s.powi(2),
        _ => jerk::JERK_NOISE_MM / period_s.powi(3),
    };
    Err(PlanOptionsError::Unresolvable {
        name,
        value,
        unit,
        noise,
        min,
        period_s,
        order,
    })
}

/// Accuracy (mm) of the move lengths in [`PlanOptions::min_cycle_time_s`].
pub(crate) const ESTIMATE_ACCURACY_MM: f64 = 1e-6;

impl PlanOptions {
    /// A lower bound on the cycle time (s) of `tp`: every move run at its speed cap
    /// throughout, as the planner caps it (rapids at the rapid speed, feed moves at the
    /// lower of their programmed F and [`PlanOptions::feed_mm_s`]). Acceleration, stops,
    /// dwells and the other limits only add time.
    pub fn min_cycle_time_s(&self, tp: &crate::path::Toolpath) -> f64 {
        tp.moves().map(|m| self.move_floor_s(m)).sum()
    }

    /// The least time (s) move `m` takes: its length (to `ESTIMATE_ACCURACY_MM` (1e-6)) at its
    /// speed cap (see [`PlanOptions::min_cycle_time_s`]).
    pub fn move_floor_s(&self, m: &crate::path::Move) -> f64 {
        use crate::geom::ParamCurveArclen;
        let cap = match m.kind {
            crate::path::MoveKind::Rapid => self.rapid(),
            crate::path::MoveKind::Feed => m
                .feed_mm_s
                .filter(|f| *f > 0.0 && f.is_finite())
                .map_or(self.feed_mm_s, |f| f.min(self.feed_mm_s)),
        };
        m.segment.arclen(ESTIMATE_ACCURACY_MM) / cap
    }

    /// Checks that every limit is a positive finite number, and large enough for the
    /// setpoints at the period to show it held (see the module doc).
    pub fn validate(&self) -> Result<(), PlanOptionsError> {
        let t = self.period_s;
        positive("period", t)?;
        positive("feed", self.feed_mm_s)?;
        resolvable("feed", self.feed_mm_s, "mm/s", 1, min_feed_mm_s(t), t)?;
        if let Some(r) = self.rapid_mm_s {
            positive("rapid", r)?;
            resolvable("rapid", r, "mm/s", 1, min_feed_mm_s(t), t)?;
        }
        for a in self.acc_mm_s2 {
            positive("acc", a)?;
            resolvable("acc", a, "mm/s^2", 2, min_acc_mm_s2(t), t)?;
        }
        if let Some(v) = self.jerk_mm_s3 {
            for a in v {
                positive("jerk", a)?;
                resolvable("jerk", a, "mm/s^3", 3, jerk::min_jerk_mm_s3(t), t)?;
            }
        }
        if let Some(v) = self.vaxis_mm_s {
            for a in v {
                positive("vaxis", a)?;
                resolvable("vaxis", a, "mm/s", 1, min_vaxis_mm_s(t), t)?;
            }
        }
        positive("chord-error", self.chord_error_mm)?;
        if let Some(j) = self.junction_dev_mm {
            positive("junction-dev", j)?;
        }
        Ok(())
    }
    /// Rapid speed (mm/s).
    pub fn rapid(&self) -> f64 {
        self.rapid_mm_s.unwrap_or(self.feed_mm_s)
    }
    /// The fastest speed of the path (mm/s): the larger of the feed and rapid limits, or
    /// [`PlanOptions::top_speed_mm_s`] when that is lower.
    pub fn top_speed(&self) -> f64 {
        let limits = self.feed_mm_s.max(self.rapid());
        self.top_speed_mm_s
            .filter(|v| *v > 0.0)
            .map_or(limits, |v| v.min(limits))
    }
    /// [`PlanOptions::top_speed_mm_s`] of `path`: each feed move at its programmed feed
    /// under the feed limit, each rapid at the rapid speed.
    pub fn top_speed_of(&self, path: &crate::path::Toolpath) -> f64 {
        path.moves()
            .map(|m| match m.kind {
                crate::path::MoveKind::Rapid => self.rapid(),
                crate::path::MoveKind::Feed => m
                    .feed_mm_s
                    .map_or(self.feed_mm_s, |f| f.min(self.feed_mm_s)),
            })
            .fold(0.0, f64::max)
    }
    /// The jerk-mode caps, when jerk limiting is asked for (options must be valid).
    pub fn jerk_caps(&self) -> Option<jerk::JerkCaps> {
        if self.jerk_scheme == JerkScheme::Follow {
            // The follower plans under a trapezoid ceiling (interp::follow).
            return None;
        }
        self.jerk_mm_s3.map(|j| {
            jerk::JerkCaps::with_split(
                self.acc_mm_s2.map(|a| planned_acc(a, self.period_s)),
                j,
                self.period_s,
                self.top_speed(),
                self.jerk_split.unwrap_or(jerk::JerkSplit::DEFAULT),
            )
        })
    }
    /// Extra time the machine rests at every stop (s): the jerk filter's window, zero
    /// without jerk limiting.
    pub fn stop_hold_s(&self) -> f64 {
        self.jerk_caps().map_or(0.0, |j| j.window_s)
    }
}

/// Why the machine comes to rest.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum StopReason {
    /// Tangent break (unsmoothed corner, reversal) without a junction-deviation rule.
    Corner,
    /// A non-motion event (spindle, coolant, tool, program stop, ...).
    Event,
    /// A dwell (G4).
    Dwell,
    /// A position gap between consecutive moves.
    Gap,
    /// End of the program.
    End,
}

/// Exact stops by reason.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct StopCounts {
    /// Tangent breaks.
    pub corner: usize,
    /// Events.
    pub event: usize,
    /// Dwells.
    pub dwell: usize,
    /// Position gaps.
    pub gap: usize,
    /// Corners passed under the junction-deviation rule (not stops).
    pub junction_blended: usize,
}

impl StopCounts {
    /// Counts one stop.
    pub fn add(&mut self, r: StopReason) {
        match r {
            StopReason::Corner => self.corner += 1,
            StopReason::Event => self.event += 1,
            StopReason::Dwell => self.dwell += 1,
            StopReason::Gap => self.gap += 1,
            StopReason::End => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_shares_cover_the_grid_terms() {
        let turn = (grid::MAX_TURN_DEG / 2.0).to_radians();
        assert!(VAXIS_CHECK_SHARE >= 1.0 / turn.cos() - 1.0);
    }

    #[test]
    fn usual_limits_are_planned_at_their_factor_and_tiny_ones_refused() {
        let t = 0.001;
        // The usual settings: the relative reserves, bit for bit.
        assert_eq!(planned_acc(500.0, t), 500.0 * ACC_PLANNING_FACTOR);
        assert_eq!(planned_vaxis(50.0, t), 50.0 * VAXIS_PLANNING_FACTOR);
        // Small limits: the noise deducted, at the floor the minimum fraction left.
        let a = min_acc_mm_s2(t);
        assert!((planned_acc(a, t) / a - MIN_LIMIT_FRACTION).abs() < 1e-12);
        let v = min_vaxis_mm_s(t);
        assert!((planned_vaxis(v, t) / v - MIN_LIMIT_FRACTION).abs() < 1e-12);
        assert!(planned_acc(4.0 * a, t) < 4.0 * a * ACC_PLANNING_FACTOR);
        let ok = PlanOptions {
            acc_mm_s2: [a * 1.0001; 3],
            jerk_mm_s3: Some([jerk::min_jerk_mm_s3(t) * 1.0001; 3]),
            vaxis_mm_s: Some([v * 1.0001; 3]),
            ..Default::default()
        };
        assert_eq!(ok.validate(), Ok(()));
        let refused = |o: PlanOptions, which: &str| match o.validate() {
            Err(PlanOptionsError::Unresolvable {
                name, value, min, ..
            }) => {
                assert_eq!(name, which);
                assert!(value < min);
            }
            other => panic!("{which}: {other:?}"),
        };
        refused(
            PlanOptions {
                acc_mm_s2: [1.0, a * 0.999, 1.0],
                ..ok.clone()
            },
            "acc",
        );
        refused(
            PlanOptions {
                jerk_mm_s3: Some([1.0; 3]),
                ..ok.clone()
            },
            "jerk",
        );
        refused(
            PlanOptions {
                vaxis_mm_s: Some([1.0, 1.0, v * 0.999]),
                ..ok.clone()
            },
            "vaxis",
        );
        refused(
            PlanOptions {
                feed_mm_s: min_feed_mm_s(t) * 0.999,
                ..ok.clone()
            },
            "feed",
        );
        // A longer period resolves the same limits.
        let slow = PlanOptions {
            jerk_mm_s3: Some([1.0; 3]),
            period_s: 0.005,
            ..ok.clone()
        };
        assert_eq!(slow.validate(), Ok(()));
        let msg = PlanOptions {
            jerk_mm_s3: Some([1.0; 3]),
            ..Default::default()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(
            msg.starts_with("jerk = 1 mm/s^3 cannot be held at period 0.001 s"),
            "{msg}"
        );
        assert_eq!(
            PlanOptions {
                acc_mm_s2: [0.0; 3],
                ..Default::default()
            }
            .validate(),
            Err(PlanOptionsError::NotPositive {
                name: "acc",
                value: 0.0
            })
        );
    }
}
