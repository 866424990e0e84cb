//! The planner's caps ([`caps_of`]) and the joints between moves: their classification
//! ([`joint_after`]) and the curvature rate at a move's end.

use super::index::{curvature_at, tangent_at};
use super::After;
use crate::feed::limits::{g1_joint_cap_x, junction_cap_x, Caps};
use crate::feed::{PlanOptions, StopReason};
use crate::geom::{ParamCurve, Segment, Vec3};
use crate::verify::{GAP_TOL_MM, TANGENT_TOL_DEG};

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

pub(super) fn joint_after(a: &Segment, b: &Segment, opts: &PlanOptions, caps: &Caps) -> After {
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
pub(super) fn abs_max(a: Vec3, b: Vec3) -> Vec3 {
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
pub(super) fn end_rate(seg: &Segment, at_end: bool) -> Vec3 {
    if matches!(seg, Segment::Line(_)) {
        return Vec3::ZERO;
    }
    let (a, b) = if at_end {
        (1.0 - RATE_PROBE_PARAM, 1.0)
    } else {
        (0.0, RATE_PROBE_PARAM)
    };
    let ds = crate::geom::step_arclen(seg, a, b);
    if ds > 0.0 {
        (curvature_at(seg, b) - curvature_at(seg, a)) / ds
    } else {
        Vec3::ZERO
    }
}
