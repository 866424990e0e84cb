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
//! * The acceleration limits are planned at [`ACC_PLANNING_FACTOR`] of the given value, a
//!   1 % reserve for what happens between the grid checks and for the interpolator's
//!   sub-micrometre position errors (both show up in finite differences); the per-axis
//!   velocity limits likewise at [`VAXIS_PLANNING_FACTOR`].
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

pub use grid::{PathIndex, PlanMove};
pub use lookahead::{plan_stream, PlanEvent, PlanStats, ProfilePiece};

use serde::Serialize;

/// Fraction of the acceleration limits the planner uses (see the module doc).
pub const ACC_PLANNING_FACTOR: f64 = 0.99;
/// Fraction of the per-axis velocity limits the planner uses, a reserve for the
/// interpolator's sub-micrometre position errors; inside curved intervals the velocity
/// caps already allow for the tangent's turn (see [`grid`]).
pub const VAXIS_PLANNING_FACTOR: f64 = 0.999;

/// Machine limits and planning settings.
#[derive(Clone, Debug, PartialEq, Serialize)]
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
        }
    }
}

/// Invalid planning options.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{name} = {value} is invalid: a positive finite number is required")]
pub struct PlanOptionsError {
    /// Option name.
    pub name: &'static str,
    /// Offending value.
    pub value: f64,
}

fn positive(name: &'static str, value: f64) -> Result<(), PlanOptionsError> {
    if value > 0.0 && value.is_finite() {
        Ok(())
    } else {
        Err(PlanOptionsError { name, value })
    }
}

impl PlanOptions {
    /// Checks that every limit is a positive finite number.
    pub fn validate(&self) -> Result<(), PlanOptionsError> {
        positive("feed", self.feed_mm_s)?;
        if let Some(r) = self.rapid_mm_s {
            positive("rapid", r)?;
        }
        for a in self.acc_mm_s2 {
            positive("acc", a)?;
        }
        if let Some(v) = self.jerk_mm_s3 {
            for a in v {
                positive("jerk", a)?;
            }
        }
        if let Some(v) = self.vaxis_mm_s {
            for a in v {
                positive("vaxis", a)?;
            }
        }
        positive("period", self.period_s)?;
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
    /// The jerk-mode caps, when jerk limiting is asked for (options must be valid).
    pub fn jerk_caps(&self) -> Option<jerk::JerkCaps> {
        self.jerk_mm_s3.map(|j| {
            jerk::JerkCaps::new(
                self.acc_mm_s2.map(|a| a * ACC_PLANNING_FACTOR),
                j,
                self.period_s,
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
