//! Jerk limiting (`--jerk`): a conservative, provable S-curve scheme built on the
//! trapezoid planner.
//!
//! ## Per-axis jerk along a curve
//! For motion `P(s(t))` with unit tangent `T` and curvature vector `K`, axis `i` sees
//! `a_i = s'' T_i + s'^2 K_i` and
//! `j_i = s''' T_i + 3 s' s'' K_i + s'^3 dK_i/ds`.
//! The tangential term is bounded by `J_t |T_i|` (`J_t` a share of `min_i J_i`, see
//! [`JerkSplit`]); the three speed-dependent terms (and a curvature jump at a G1 joint)
//! share the rest, `J_i - J_t |T_i|` at each point, as one speed cap
//! ([`JerkCaps::speed_cap_x`]). Likewise the acceleration: `|s''| <= U` leaves
//! `A_i - U |T_i|` to the curvature term ([`JerkCaps::curvature_cap_x`]). Where the
//! curvature loads an axis the tangent has little of it (on a circle the two terms of
//! axis `i` peak a quarter turn apart: `U |sin| + x |cos| / R`), so the pointwise room is
//! much more than the fixed shares `1 - U / A` and `1 - J_t / J` of earlier versions,
//! which it never falls below.
//!
//! ## Scheme: trapezoid, then a moving average in time
//! 1. The trapezoid planner ([`super::lookahead`]) plans `s(t)` with a *scalar* tangential
//!    acceleration limit `|s''| <= U` ([`JerkCaps::u_max_mm_s2`]), `U` at most
//!    `u_share min_i A_i` (planning factor applied; [`JerkSplit`], by default
//!    `1 - ` `CURVATURE_ACC_SHARE` (0.7)), and the curvature limit
//!    `U |T_i| + v^2 |K_i| <= A_i` at each point. `U` also sets the window of point 2,
//!    `W = 2 U / J_t` with `J_t = jt_share min_i J_i` (by default
//!    `TANGENTIAL_JERK_SHARE` (0.5)), and a rest-to-rest ramp to the top speed `V` costs
//!    `V / U` in the plan plus `W` in the filter; `V / U + 2 U / J_t` is least at
//!    `U* = sqrt(V J_t / 2)`. So `U = min(u_share A, U*)`, with `V` the larger of the
//!    feed and rapid rates. At the usual settings (50 mm/s, 500 mm/s^2, 5000 mm/s^3)
//!    `U*` = 248 mm/s^2 is above the default share (148.5 mm/s^2) and changes nothing;
//!    when the jerk is small against the acceleration it keeps the window, which every
//!    stop waits out twice, from growing as `A / J`.
//! 2. The setpoint time line is the moving average of that plan over a window `W`
//!    ([`JerkCaps::window_s`]): `s_f(t) = (1/W) int_{t-W}^{t} s`. Then
//!    `s_f' = mean of s'`, `|s_f''| = |s'(t) - s'(t-W)| / W <= U` and
//!    `|s_f'''| = |s''(t) - s''(t-W)| / W <= 2U/W`. With `W = 2U / J_t` the tangential
//!    term is at most `J_t |T_i|`. The filtered
//!    acceleration is continuous, its jerk bounded: an S-curve (for a rest-to-rest move,
//!    the classic "trapezoid convolved with a box" profile).
//! 3. The filtered speed is the mean plan speed over the window, `v_f(t) = (b - a)/W`
//!    with `[a, b] = [s(t-W), s(t)]` the positions the plan covers in the window, and
//!    `s_f(t)` lies in `[a, b]`. So every speed cap `v^2 <= X(sigma)` holds for the
//!    filtered motion if the plan covers at most `W sqrt(X(sigma))` in any window that
//!    passes `sigma`; that is sure when the plan moves at most at `sqrt(X(sigma))` while
//!    within `W sqrt(X(sigma))` of `sigma` (crossing that distance at that speed takes
//!    the whole window). The plan's caps are therefore **dilated**: the cap at `s` is the
//!    least `X(sigma)` over the `sigma` with `|s - sigma| <= W sqrt(X(sigma))`. The
//!    sources are the grid points' caps; a grid point takes the least source reaching any
//!    position of its two neighbouring intervals, so the speed anywhere inside an
//!    interval (linear in `v^2` on curves, at most the inside cap on lines) holds the
//!    dilated cap of every position in it. Lines are cut in jerk mode (every
//!    `MAX_CURVE_DS_MM` (0.5), and geometrically finer towards their ends from
//!    `LINE_CUT_MIN_MM` (1e-3)) so that a low cap at a corner does not slow a whole line. A
//!    low cap thus spreads only
//!    over the short distance covered at its own low speed. Then the filtered motion
//!    holds every cap at its own position: feed, per-axis velocity, curvature
//!    acceleration (the cap `x <= (A_i - U |T_i|) / |K_i|` with the tangent and curvature
//!    of that position, so `|a_i| <= |s_f''| |T_i| + v_f^2 |K_i| <= U |T_i| + v^2 |K_i|
//!    <= A_i`), chord error, and the jerk caps below. Between grid points the tangent
//!    and curvature change within the grid's shares (see [`super::grid`]), which the
//!    acceleration reserve covers as in the trapezoid mode.
//! 4. The speed-dependent jerk terms become a speed cap (per axis, applied to the plan and
//!    dilated like the others), [`JerkCaps::speed_cap_x`]:
//!    `3 v min(U, v/W) |K_i| + v^3 |dK_i/ds| (+ 0.75 v^2 |dK_i| / T at a G1 joint)
//!    <= J_i - J_t |T_i|`, with `|T_i|` the largest of the tangents at the ends of the
//!    point's two intervals (inside an interval `|T_i|` exceeds its end values only near
//!    its extremum, by at most `1 - cos(turn / 2)`, 6e-4, inside the planning reserve),
//!    so with the tangential term the axis's jerk is at most `J_i`. The coupling term uses `|s_f''| = |s'(t) - s'(t-W)| / W
//!    <= v/W`: both plan speeds lie in the window's span, where (point 3) the plan moves
//!    at most at the cap's speed `v`; so slow, tight corners are not charged the full `U`. `dK/ds` is the finite difference of the curvature vector over
//!    each curved grid interval (the larger of the two intervals beside a point; at joints
//!    over the first/last 1e-4 of the move's parameter). At a G1 joint the curvature jumps
//!    by `dK`: the acceleration steps by `v^2 dK_i` at once, an infinite jerk that no speed
//!    makes finite. Measured on setpoints at period `T`, a step `Delta` changes the
//!    finite-difference acceleration of consecutive samples by at most `0.75 Delta` (the
//!    hat kernel of the second difference; the worst case is a step half-way between two
//!    samples), i.e. a finite-difference jerk of `0.75 Delta / T` on top of the smooth
//!    terms, which are evaluated with the larger curvature and rate of the two sides.
//!    This bounds what the setpoints show, as the issue asks; the true (continuous) jerk
//!    at a curvature jump is unbounded whatever the speed. A joint whose tangent turns
//!    by less than the tangent tolerance (passed without a stop) jumps the velocity by
//!    `v dT`: up to `v |dT_i| / T^2` more ([`JerkCaps::joint_speed_cap_x`]), and such a
//!    kink counts as a curved point for point 6. Joints closer than three periods of
//!    travel are seen together by one third difference: their steps (of one sign) and
//!    kinks are summed into one cap over the moves between them
//!    (`grid::IndexBuilder::close_joints`).
//! 5. Stops: the plan rests at every stop for `W` more than the trapezoid would, so the
//!    filter window never straddles a corner (the filtered motion comes to rest exactly
//!    at the stop point and leaves from it). The end of motion is therefore `W` later.
//! 6. Lines far from curves: points 2 to 4 need `|s''| <= U` only over the positions a
//!    window can span around a filtered position `sigma` on a curve. The window's plan
//!    span `[a, b]` holds `sigma` and is at most `W v_f <= W V` long (`V` the top speed),
//!    so a straight interval farther than `W V` from every curved interval
//!    ([`JerkCaps::line_u_max`], set per window by the look-ahead) may accelerate at
//!    `U_L = min_i min(A_i, J_i W / 2)`: a filtered position on a curve never sees it,
//!    and one on a line sees `|a_i| = |s_f''| |T_i| <= U_L <= A_i` and
//!    `|j_i| = |s_f'''| |T_i| <= 2 U_L / W <= J_i` (no curvature terms there). Beyond
//!    the look-ahead window, unknown positions count as curved.
//!
//! ## Choosing the split per path
//! Points 1 to 5 hold for any `U` and `J_t` in `(0, 1)` of the limits ([`JerkSplit`]);
//! which is fastest depends on the path and the limits. A small `U` shortens the window
//! (less dilation, shorter holds) and leaves the curvature more room, but every speed
//! change takes longer; a small `J_t` leaves the geometric jerk terms more room but
//! lengthens the window. No one split is fastest on every path and every set of limits
//! (`docs/benchmarks/2026-12-02.md`). So unless [`super::PlanOptions::jerk_split`] gives one, the planning run
//! ([`crate::interp::execute`]) plans the path with each of `SPLIT_CANDIDATES` and
//! a short local search around the best ([`fastest_split`]: planning passes only, no
//! setpoints; a program longer than [`SPLIT_SEARCH_MAX_BLOCKS`] is judged by its first
//! blocks) and keeps the shortest plan. Choosing among plans that each hold every limit
//! keeps the proof; the report's options give the split used.
//!
//! ## Finite-difference noise
//! Positions are printed to 1e-9 mm and the interpolator lands on the planned arc length
//! to `ARC_CORRECTION_TOL_MM` (1e-9): a third difference of such errors is up to
//! `JERK_NOISE_MM` (8e-9)`/T^3` (8 mm/s^3 at T = 1 ms, 1 mm/s^3 at T = 2 ms). The jerk limits
//! are planned at `0.99 J - JERK_NOISE_MM / T^3` ([`planned_jerk`]), so the measured
//! finite-difference jerk holds the limit itself, not only up to the noise. A limit for
//! which that leaves less than `MIN_LIMIT_FRACTION` (0.5) of `J` (below
//! [`min_jerk_mm_s3`], 16.3 mm/s^3 at 1 ms) is refused by
//! [`super::PlanOptions::validate`]: the printed setpoints cannot show it held.
//!
//! ## Limits of the scheme
//! It is conservative, not time-optimal: `|s''| <= U` is global (not the larger
//! acceleration a single axis would allow along a diagonal, nor the full `A_i` on a
//! line), the plan accelerates at `U` where a jerk-limited S-curve would reach `A_i`, and
//! the coupling cap assumes `|s''| = U` wherever the curvature is large. A curvature jump
//! at a G1 joint (the `arc` method's line-arc joints) costs the most: its step term makes
//! the speed there `sqrt(J T / (0.75 |dK|))` at best, whatever the scheme, since the
//! setpoints' finite-difference jerk shows the step. The cycle-time cost against the
//! trapezoid is reported by `ncsmooth plan`. Junction-deviation
//! corners (`--junction-dev`) remain velocity jumps and are reported, not limited.
//!
//! Where the time goes (each part switched off in turn, in builds that do not hold the
//! limits) is measured in `docs/benchmarks/2026-12-02.md`: for the `arc` method's path
//! the G1 steps dominate, and a trapezoid plan with the step cap alone at the best sample
//! alignment (`v^2 <= J T / (0.5 |dK_i|)`, the full `J`) is a floor for any planner
//! measured this way. The `follow` scheme ([`super::JerkScheme::Follow`],
//! `crate::interp`'s follower) chooses the setpoints themselves under the measured
//! limits, with the coupling term exact.

use crate::geom::Vec3;
use crate::path::Toolpath;

use super::limits::NEGLIGIBLE;
use super::{plan_stream, PathIndex, PlanEvent, PlanOptions};

/// Share of each axis's acceleration limit given to the curvature term `v^2 K_i` by the
/// default split ([`JerkSplit::DEFAULT`]); the rest, `1 - share`, is the tangential
/// limit `U`.
pub(crate) const CURVATURE_ACC_SHARE: f64 = 0.7;
/// Share of each jerk limit for the tangential term `s''' T_i` in the default split.
pub(crate) const TANGENTIAL_JERK_SHARE: f64 = 0.5;
/// Fraction of a step in acceleration that shows as a change between two consecutive
/// finite-difference accelerations (worst case, see the module doc).
pub(crate) const FD_STEP_FRACTION: f64 = 0.75;
/// Position error (mm) whose third difference is the finite-difference jerk noise:
/// printing (4 x 0.5e-9 mm worst case with weights 1, 3, 3, 1 summing to 8 half-units)
/// plus the interpolator's arc-length tolerance.
pub(crate) const JERK_NOISE_MM: f64 = 8e-9;
/// Planning factor of the jerk limits before the noise allowance.
pub(crate) const JERK_PLANNING_FACTOR: f64 = 0.99;

/// The jerk limit `j` (mm/s^3) as planned at period `period_s` (s): the planning factor
/// and the finite-difference noise deducted (see the module doc).
pub fn planned_jerk(j: f64, period_s: f64) -> f64 {
    JERK_PLANNING_FACTOR * j - JERK_NOISE_MM / period_s.powi(3)
}

/// Smallest jerk limit (mm/s^3) held at period `period_s`: below it [`planned_jerk`] would
/// be less than `MIN_LIMIT_FRACTION` (0.5) of the limit.
pub fn min_jerk_mm_s3(period_s: f64) -> f64 {
    JERK_NOISE_MM / period_s.powi(3) / (JERK_PLANNING_FACTOR - super::MIN_LIMIT_FRACTION)
}

/// How the limits are split between the tangential motion and the path's geometry
/// (point 1 of the module doc): `U` is `u_share` of the smallest axis acceleration (or
/// less, see [`JerkCaps::with_split`]), the bound `J_t` on `|s'''|` is `jt_share` of the
/// smallest axis jerk. Any shares in `(0, 1)` hold every limit; which is fastest depends
/// on the path.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct JerkSplit {
    /// `U / min_i A_i`, in `(0, 1)`.
    pub u_share: f64,
    /// `J_t / min_i J_i`, in `(0, 1)`.
    pub jt_share: f64,
}

impl JerkSplit {
    /// The fixed split of earlier versions.
    pub(crate) const DEFAULT: JerkSplit = JerkSplit {
        u_share: 1.0 - CURVATURE_ACC_SHARE,
        jt_share: TANGENTIAL_JERK_SHARE,
    };
    /// Both shares inside `(0, 1)`.
    pub fn is_valid(&self) -> bool {
        self.u_share > 0.0 && self.u_share < 1.0 && self.jt_share > 0.0 && self.jt_share < 1.0
    }
}

/// The jerk-mode limits as the planner uses them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JerkCaps {
    /// Per-axis jerk limits as planned (mm/s^3), noise allowance deducted.
    pub jerk_mm_s3: [f64; 3],
    /// Scalar tangential acceleration limit `U` of the plan (mm/s^2).
    pub u_max_mm_s2: f64,
    /// Bound `J_t = 2 U / W` on the filtered tangential jerk `|s_f'''|` (mm/s^3).
    pub jt_mm_s3: f64,
    /// Moving-average window `W` (s).
    pub window_s: f64,
    /// Interpolation period `T` (s).
    pub period_s: f64,
}

impl JerkCaps {
    /// Jerk caps from the user's limits with the default split (`JerkSplit::DEFAULT`);
    /// see [`JerkCaps::with_split`].
    pub fn new(acc: [f64; 3], jerk: [f64; 3], period_s: f64, v_top: f64) -> JerkCaps {
        JerkCaps::with_split(acc, jerk, period_s, v_top, JerkSplit::DEFAULT)
    }

    /// Jerk caps from the user's limits: acceleration `acc` (already as planned, see
    /// [`super::planned_acc`]), jerk `jerk` (valid at `period_s`, see
    /// [`super::PlanOptions::validate`]), period `period_s`, the top speed `v_top`
    /// (the larger of the feed and rapid rates, mm/s) and the split of the limits (an
    /// invalid split is taken as `JerkSplit::DEFAULT`).
    /// `J_t = jt_share min_i J_i`; `U = min(u_share min_i A_i, U*)` with
    /// `U* = sqrt(v_top J_t / 2)` (point 1 of the module doc); `W = 2 U / J_t`.
    pub fn with_split(
        acc: [f64; 3],
        jerk: [f64; 3],
        period_s: f64,
        v_top: f64,
        split: JerkSplit,
    ) -> JerkCaps {
        let j = jerk.map(|j| planned_jerk(j, period_s));
        debug_assert!(
            j.iter()
                .zip(jerk)
                .all(|(p, j)| *p >= super::MIN_LIMIT_FRACTION * j),
            "jerk {jerk:?} is below the floor at period {period_s}"
        );
        let split = if split.is_valid() {
            split
        } else {
            JerkSplit::DEFAULT
        };
        let a_min = acc.iter().copied().fold(f64::INFINITY, f64::min);
        let j_min = j.iter().copied().fold(f64::INFINITY, f64::min);
        let jt = split.jt_share * j_min;
        let u_star = (v_top * jt / 2.0).sqrt();
        let u = (split.u_share * a_min).min(u_star);
        JerkCaps {
            jerk_mm_s3: j,
            u_max_mm_s2: u,
            jt_mm_s3: jt,
            window_s: 2.0 * u / jt,
            period_s,
        }
    }

    /// Tangential limit (mm/s^2) of a straight interval far from any curve (point 6 of the
    /// module doc): `min_i min(A_i, J_i W / 2)`, so that on a line `|s_f''| |T_i| <= A_i`
    /// and `|s_f'''| |T_i| <= 2 U / W |T_i| <= J_i` whatever the direction; never below `U`.
    pub fn line_u_max(&self, acc: &[f64; 3]) -> f64 {
        let mut u = f64::INFINITY;
        for i in 0..3 {
            u = u.min(acc[i]).min(0.5 * self.jerk_mm_s3[i] * self.window_s);
        }
        u.max(self.u_max_mm_s2)
    }

    /// Cap on `x = v^2` from the curvature term of the per-axis acceleration at a point
    /// with unit tangent `t` and curvature vector `k`: `U |t_i| + x |k_i| <= A_i` for
    /// every axis (point 3 of the module doc), `acc` the planned `A_i`.
    pub fn curvature_cap_x(&self, acc: &[f64; 3], t: Vec3, k: Vec3) -> f64 {
        let mut x = f64::INFINITY;
        for i in 0..3 {
            let ki = k[i].abs();
            if ki > NEGLIGIBLE {
                let room = (acc[i] - self.u_max_mm_s2 * t[i].abs().min(1.0)).max(0.0);
                x = x.min(room / ki);
            }
        }
        x
    }

    /// Cap on `x = v^2` from the speed-dependent jerk terms, per axis:
    /// `0.75 v^2 |step_i| / T + 3 v min(U, v/W) |k_i| + v^3 |rate_i| <= J_i - J_t |t_i|`,
    /// with `t` the largest tangent components near the point, `k` the curvature vector,
    /// `rate` its derivative in arc length and `step` the curvature jump at a G1 joint
    /// (zero elsewhere). Each term grows with `v`, so the largest admissible speed is
    /// found by bisection.
    pub fn speed_cap_x(&self, t: Vec3, k: Vec3, rate: Vec3, step: Vec3) -> f64 {
        self.joint_speed_cap_x(t, k, rate, step, Vec3::ZERO)
    }

    /// [`Self::speed_cap_x`] at a G1 joint whose unit tangent jumps by `kink` (`t_b - t_a`,
    /// a turn below [`crate::verify::TANGENT_TOL_DEG`] that the plan passes as tangent):
    /// the velocity jumps by `v kink` between two setpoints, which a third difference
    /// shows as up to `v |kink_i| / T^2` (a ramp's third difference is at most one period
    /// whatever its phase), a term linear in `v` beside the others.
    pub fn joint_speed_cap_x(&self, t: Vec3, k: Vec3, rate: Vec3, step: Vec3, kink: Vec3) -> f64 {
        let mut x = f64::INFINITY;
        for i in 0..3 {
            let c0 = kink[i].abs() / (self.period_s * self.period_s);
            let c2 = FD_STEP_FRACTION * step[i].abs() / self.period_s;
            let c1 = 3.0 * k[i].abs();
            let (u, w) = (self.u_max_mm_s2, self.window_s);
            let c3 = rate[i].abs();
            // At least (1 - jt_share) J_i: J_t <= jt_share J_i and |t_i| <= 1.
            let budget = self.jerk_mm_s3[i] - self.jt_mm_s3 * t[i].abs().min(1.0);
            // |s_f''| <= min(U, v / W): see point 4 of the module doc.
            let f = |v: f64| c0 * v + c1 * v * u.min(v / w) + c2 * v * v + c3 * v * v * v;
            // Upper bound: each term alone.
            let mut hi = f64::INFINITY;
            if c0 > NEGLIGIBLE {
                hi = hi.min(budget / c0);
            }
            if c1 > NEGLIGIBLE {
                hi = hi.min((budget / (c1 * u)).max((budget * w / c1).sqrt()));
            }
            if c2 > NEGLIGIBLE {
                hi = hi.min((budget / c2).sqrt());
            }
            if c3 > NEGLIGIBLE {
                hi = hi.min((budget / c3).cbrt());
            }
            if !hi.is_finite() {
                continue;
            }
            let mut lo = 0.0;
            for _ in 0..SPEED_CAP_BISECTIONS {
                let mid = 0.5 * (lo + hi);
                if f(mid) <= budget {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            x = x.min(lo * lo);
        }
        x
    }
}

/// Splits [`fastest_split`] tries, the default first (it wins ties). The tangential share
/// `U` trades the plan's tangential acceleration against the window `W = 2 U / J_t`
/// (the stops' hold and the reach of the dilation) and the room `A_i - U |T_i|` left to
/// the curvature; `J_t` trades the window against the room `J_i - J_t |T_i|` left to
/// the speed-dependent jerk terms. Measured on butterfly_1000 (nurbs, tol 0.1 mm,
/// 200 mm/s, 3000 mm/s^2, 60000 mm/s^3) the cycle time is least near `U` = 0.12 and
/// `J_t` = 0.55 of the limits.
pub(crate) const SPLIT_CANDIDATES: [JerkSplit; 6] = [
    JerkSplit::DEFAULT,
    JerkSplit {
        u_share: 0.07,
        jt_share: 0.6,
    },
    JerkSplit {
        u_share: 0.12,
        jt_share: 0.55,
    },
    JerkSplit {
        u_share: 0.2,
        jt_share: 0.5,
    },
    JerkSplit {
        u_share: 0.5,
        jt_share: 0.5,
    },
    JerkSplit {
        u_share: 0.7,
        jt_share: 0.4,
    },
];

/// Slack (in periods) when rounding a stop time up to the period grid (as the
/// interpolation run does).
const PERIOD_ROUND_SLACK: f64 = 1e-9;

/// Duration (s) of the jerk-mode plan of `path` under `opts` (valid, with a jerk limit):
/// the planned pieces and every stop's dwell and hold, each stop rounded up to the period
/// grid as the interpolation run does; no setpoints are made.
pub fn planned_duration(path: &Toolpath, opts: &PlanOptions) -> f64 {
    let index = PathIndex::new(path, opts);
    let (hold, period) = (opts.stop_hold_s(), opts.period_s);
    let mut t = 0.0f64;
    plan_stream(&index, opts, |ev| match ev {
        PlanEvent::Piece(p) => t += p.dt,
        PlanEvent::Stop { dwell_s, .. } => {
            t = ((t + dwell_s + hold) / period - PERIOD_ROUND_SLACK)
                .ceil()
                .max(0.0)
                * period;
        }
    });
    t
}

/// Steps of the local search of [`fastest_split`] around the best candidate: the factor
/// on `u_share` (and its inverse) and the change of `jt_share`, one round each, halving
/// (four rounds rather than two: 0 to 0.9 % shorter cycles on butterfly_1000 and crown).
pub(crate) const SPLIT_REFINE_STEPS: [(f64, f64); 4] =
    [(0.7, 0.1), (0.85, 0.05), (0.92, 0.025), (0.96, 0.0125)];
/// Most program blocks [`fastest_split`] plans with: a longer program is judged by its
/// first blocks, so that the search costs at most 22 planning passes of this many
/// blocks, whatever the program's length.
pub const SPLIT_SEARCH_MAX_BLOCKS: usize = 8192;
/// Range of the shares the local search of [`fastest_split`] keeps to.
pub(crate) const SPLIT_SHARE_RANGE: (f64, f64) = (0.02, 0.9);

/// The split whose plan of `path` under `opts` (valid, with a jerk limit) is the shortest
/// ([`planned_duration`]): the best of `SPLIT_CANDIDATES`, then a local search around
/// it (`SPLIT_REFINE_STEPS`: each round tries `u_share` times and divided by the
/// factor and `jt_share` plus and minus the step, and moves to the best if it is
/// shorter). The default without a jerk limit. Every split in `(0, 1)` holds every limit
/// (module doc), so choosing among them by the plan's duration keeps the proof; each
/// try is one planning pass (no setpoints) of at most [`SPLIT_SEARCH_MAX_BLOCKS`]
/// blocks.
pub fn fastest_split(path: &Toolpath, opts: &PlanOptions) -> JerkSplit {
    if opts.jerk_mm_s3.is_none() {
        return JerkSplit::DEFAULT;
    }
    // A long program is judged by its first blocks (the choice is only a speed matter).
    let prefix;
    let path = if path.blocks.len() > SPLIT_SEARCH_MAX_BLOCKS {
        prefix = Toolpath {
            blocks: path.blocks[..SPLIT_SEARCH_MAX_BLOCKS].to_vec(),
            start: path.start,
            units: path.units,
            extra_axes_mask: path.extra_axes_mask,
        };
        &prefix
    } else {
        path
    };
    let time = |split: JerkSplit| {
        let o = PlanOptions {
            jerk_split: Some(split),
            ..opts.clone()
        };
        planned_duration(path, &o)
    };
    let mut best = (f64::INFINITY, JerkSplit::DEFAULT);
    for split in SPLIT_CANDIDATES {
        let t = time(split);
        if t < best.0 {
            best = (t, split);
        }
    }
    let (lo, hi) = SPLIT_SHARE_RANGE;
    for (f, d) in SPLIT_REFINE_STEPS {
        let c = best.1;
        let tries = [
            (c.u_share * f, c.jt_share),
            (c.u_share / f, c.jt_share),
            (c.u_share, c.jt_share - d),
            (c.u_share, c.jt_share + d),
        ];
        for (u, jt) in tries {
            let split = JerkSplit {
                u_share: u.clamp(lo, hi),
                jt_share: jt.clamp(lo, hi),
            };
            if split == c {
                continue;
            }
            let t = time(split);
            if t < best.0 {
                best = (t, split);
            }
        }
    }
    best.1
}

/// Bisection steps of [`JerkCaps::speed_cap_x`] (relative accuracy 2^-60, from below).
const SPEED_CAP_BISECTIONS: usize = 60;

/// Shortest line piece (mm) at a line's ends in jerk mode; pieces double from there.
pub(crate) const LINE_CUT_MIN_MM: f64 = 1e-3;

/// Lines shorter than this many [`LINE_CUT_MIN_MM`] get no geometric cuts at their ends.
const MIN_GEOMETRIC_CUT_LEN: f64 = 16.0;

/// Largest dilation reach (mm): `V_max W`.
pub fn dilation_radius_mm(v_max_mm_s: f64, window_s: f64) -> f64 {
    v_max_mm_s * window_s
}

/// Cut positions (arc length from the start, ascending, excluding 0 and `len`) of a line
/// of length `len` in jerk mode.
pub fn line_cuts(len: f64) -> Vec<f64> {
    let step = super::grid::MAX_CURVE_DS_MM;
    let mut cuts = Vec::new();
    // Lines this short are already finer than the corners they join need.
    let mut d = if len <= MIN_GEOMETRIC_CUT_LEN * LINE_CUT_MIN_MM {
        f64::INFINITY
    } else {
        LINE_CUT_MIN_MM
    };
    while d < step && d < 0.5 * len {
        cuts.push(d);
        cuts.push(len - d);
        d *= 2.0;
    }
    let n = (len / step).floor() as usize;
    cuts.extend((1..=n.min(super::grid::MAX_CURVE_INTERVALS)).map(|i| i as f64 * step));
    cuts.retain(|&c| c > LINE_CUT_MIN_MM * 0.5 && c < len - LINE_CUT_MIN_MM * 0.5);
    cuts.sort_by(f64::total_cmp);
    cuts.dedup_by(|a, b| (*a - *b).abs() < LINE_CUT_MIN_MM * 0.5);
    cuts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn window_and_speed_caps() {
        let c = JerkCaps::new([500.0; 3], [5000.0; 3], 0.001, 50.0);
        // U = (1 - 0.7) 500 = 150, J planned = 4950 - 8: W = 2 U / (0.5 * 4942).
        let u = (1.0 - CURVATURE_ACC_SHARE) * 500.0;
        assert!((c.u_max_mm_s2 - u).abs() < 1e-12);
        assert!((c.window_s - 2.0 * u / (0.5 * 4942.0)).abs() < 1e-12);
        // Along X (|T_x| = 1) the tangential term takes J_t = 0.5 J of the budget.
        let tx = Vec3::X;
        let budget = (1.0 - TANGENTIAL_JERK_SHARE) * 4942.0;
        // Coupling alone on a radius-1 circle in XY at (1, 0): X carries the curvature.
        // There v / W < U: 3 v (v / W) |k| = budget.
        let x = c.speed_cap_x(tx, Vec3::new(-1.0, 0.0, 0.0), Vec3::ZERO, Vec3::ZERO);
        let xw = budget * c.window_s / 3.0;
        assert!(xw.sqrt() / c.window_s < u);
        assert!((x - xw).abs() < 1e-9 * x, "{x} {xw}");
        // A gentle curve (radius 1000) is charged the full U.
        let x = c.speed_cap_x(tx, Vec3::new(-1e-3, 0.0, 0.0), Vec3::ZERO, Vec3::ZERO);
        let v = budget / (3.0 * u * 1e-3);
        assert!(v / c.window_s > u);
        assert!((x - v * v).abs() < 1e-9 * x);
        // Joint step alone: line into a radius-1 arc.
        let x = c.speed_cap_x(tx, Vec3::ZERO, Vec3::ZERO, Vec3::new(0.0, 1.0, 0.0));
        // (the step loads Y, across the tangent: the whole planned jerk is its budget).
        assert!((x - 4942.0 * 0.001 / 0.75).abs() < 1e-9 * x);
        // All three: the sum is at the budget.
        let (k, r, st) = (0.05, 0.01, 0.2);
        let x = c.speed_cap_x(
            tx,
            Vec3::new(k, 0.0, 0.0),
            Vec3::new(r, 0.0, 0.0),
            Vec3::new(st, 0.0, 0.0),
        );
        let v = x.sqrt();
        let f = 3.0 * v * (v / c.window_s).min(u) * k + v * v * v * r + 0.75 * v * v * st / 0.001;
        assert!((f - budget).abs() < 1e-9 * budget, "{f}");
        assert_eq!(
            c.speed_cap_x(tx, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO),
            f64::INFINITY
        );
        // Where the tangent is across the axis (a circle at (1, 0) moves along Y), the
        // axis's whole jerk is left to the coupling term.
        let x = c.speed_cap_x(Vec3::Y, Vec3::new(-1.0, 0.0, 0.0), Vec3::ZERO, Vec3::ZERO);
        let xw = 4942.0 * c.window_s / 3.0;
        assert!((x - xw).abs() < 1e-9 * x, "{x} {xw}");
    }

    #[test]
    fn curvature_cap_leaves_the_axis_what_the_tangent_does_not_take() {
        // Radius-2 circle in XY at angle th: T = (-sin, cos), K = -(cos, sin) / 2.
        let c = JerkCaps::new([500.0; 3], [5000.0; 3], 0.001, 50.0);
        let (a, u, r) = (500.0, c.u_max_mm_s2, 2.0);
        for i in 0..=16 {
            let th = i as f64 * std::f64::consts::PI / 16.0;
            let (sn, cs) = th.sin_cos();
            let t = Vec3::new(-sn, cs, 0.0);
            let k = Vec3::new(-cs, -sn, 0.0) / r;
            let x = c.curvature_cap_x(&[a; 3], t, k);
            // Each axis within A at that speed, one of them at it.
            let load = |ti: f64, ki: f64| u * ti.abs() + x * ki.abs();
            let worst = load(t[0], k[0]).max(load(t[1], k[1]));
            assert!((worst - a).abs() < 1e-9 * a, "{th}: {worst}");
            // Never below the fixed share of earlier versions.
            assert!(x >= (a - u) * r * (1.0 - 1e-12), "{th}: {x}");
        }
        // At the top of the circle the curvature loads Y alone and X takes the tangent.
        let x = c.curvature_cap_x(&[a; 3], Vec3::X, Vec3::new(0.0, -1.0 / r, 0.0));
        assert!((x - a * r).abs() < 1e-9);
        assert_eq!(
            c.curvature_cap_x(&[a; 3], Vec3::X, Vec3::ZERO),
            f64::INFINITY
        );
    }

    #[test]
    fn small_jerk_takes_the_tangential_limit_that_minimises_the_ramp() {
        // 500 mm/s^2 and 20 mm/s^3 at 50 mm/s: the acceleration share (148.5 mm/s^2)
        // would make the window W = 2 U / (J / 2) about 50 s. U* minimises the ramp's
        // cost V / U + W.
        let (v, t) = (50.0, 0.001);
        let c = JerkCaps::new([495.0; 3], [20.0; 3], t, v);
        let j = planned_jerk(20.0, t);
        assert!((j - (0.99 * 20.0 - 8.0)).abs() < 1e-12);
        let cost = |u: f64| v / u + 2.0 * u / (TANGENTIAL_JERK_SHARE * j);
        let u = c.u_max_mm_s2;
        assert!(u < (1.0 - CURVATURE_ACC_SHARE) * 495.0);
        assert!((u - (v * TANGENTIAL_JERK_SHARE * j / 2.0).sqrt()).abs() < 1e-12);
        for f in [0.5, 0.9, 0.99, 1.01, 1.1, 2.0] {
            assert!(cost(u) < cost(u * f), "{f}");
        }
        assert!((c.window_s - 2.0 * u / (TANGENTIAL_JERK_SHARE * j)).abs() < 1e-12);
        assert!(c.window_s < 5.0, "{}", c.window_s);
        // At the usual settings the acceleration share stays the limit.
        let usual = JerkCaps::new([495.0; 3], [5000.0; 3], t, v);
        assert_eq!(usual.u_max_mm_s2, (1.0 - CURVATURE_ACC_SHARE) * 495.0);
    }

    #[test]
    fn the_fastest_split_is_a_candidate_no_slower_than_the_default() {
        // A zigzag of lines with rounded corners (cubic Beziers): stops are few, the
        // curves and the lines both count.
        let mut tp = Toolpath::new(Vec3::ZERO);
        let mut p = Vec3::ZERO;
        for i in 0..6 {
            let dir = if i % 2 == 0 { Vec3::X } else { Vec3::Y };
            let q = p + dir * 5.0;
            tp.push_move(crate::path::Move::feed(
                crate::geom::Line::new(p, q),
                None,
                1,
            ));
            let other = if i % 2 == 0 { Vec3::Y } else { Vec3::X };
            let r = q + (dir + other) * 0.5;
            let c = crate::geom::CubicBez::new(q, q + dir * 0.3, r - other * 0.3, r);
            tp.push_move(crate::path::Move::feed(c, None, 1));
            p = r;
        }
        let opts = PlanOptions {
            jerk_mm_s3: Some([5000.0; 3]),
            ..Default::default()
        };
        let best = fastest_split(&tp, &opts);
        assert!(best.is_valid());
        let time = |s: JerkSplit| {
            planned_duration(
                &tp,
                &PlanOptions {
                    jerk_split: Some(s),
                    ..opts.clone()
                },
            )
        };
        let t_best = time(best);
        assert!(t_best > 0.0);
        for s in SPLIT_CANDIDATES {
            assert!(t_best <= time(s), "{s:?}");
        }
        // Without a jerk limit there is nothing to choose.
        let trap = PlanOptions::default();
        assert_eq!(fastest_split(&tp, &trap), JerkSplit::DEFAULT);
    }

    #[test]
    fn the_jerk_floor_leaves_the_minimum_fraction() {
        for t in [1e-4, 1e-3, 2e-3, 0.05] {
            let m = min_jerk_mm_s3(t);
            let frac = planned_jerk(m, t) / m;
            assert!(
                (frac - crate::feed::MIN_LIMIT_FRACTION).abs() < 1e-12,
                "{t}: {frac}"
            );
            // At 1 ms one print unit of third difference is 1 mm/s^3: the floor is a few.
            assert!(m * t.powi(3) / 1e-9 > 10.0 && m * t.powi(3) / 1e-9 < 20.0);
        }
    }
}
