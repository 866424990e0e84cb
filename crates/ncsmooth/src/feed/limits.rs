//! The limits along the path, as constraints on `x = v^2` (see the [`crate::feed`] doc):
//! speed caps at a point ([`point_cap_x`]), joint caps ([`g1_joint_cap_x`],
//! [`junction_cap_x`]) and the per-axis acceleration constraints of a grid interval
//! ([`Interval`]), with the two small linear programs the look-ahead passes solve on it.

use crate::geom::Vec3;

/// Below this magnitude a tangent or curvature component does not constrain its axis
/// (a component of 1e-12 on a 1 m/s feed is 1e-9 mm/s).
pub(crate) const NEGLIGIBLE: f64 = 1e-12;

/// The limits as the planner uses them (accelerations already scaled by
/// `ACC_PLANNING_FACTOR` (0.99)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Caps {
    /// Per-axis acceleration (mm/s^2).
    pub acc: [f64; 3],
    /// Per-axis velocity (mm/s), if limited.
    pub vaxis: Option<[f64; 3]>,
    /// Interpolation period (s).
    pub period_s: f64,
    /// Chord error (mm).
    pub chord_error_mm: f64,
    /// Jerk mode (see [`super::jerk`]): the scalar tangential limit and the jerk caps.
    pub jerk: Option<super::jerk::JerkCaps>,
}

/// Largest `x = v^2` allowed at a point with unit tangent `t`, curvature vector `k` (1/mm)
/// and speed cap `vcap` (mm/s): the feed, the per-axis velocity, the per-axis curvature
/// limit `x |k_i| <= A_i` and the chord error of Wu eq. 21.
pub fn point_cap_x(t: Vec3, k: Vec3, vcap: f64, caps: &Caps) -> f64 {
    point_cap_x_kappa(t, k, k.norm(), vcap, caps)
}

/// [`point_cap_x`] with the curvature `kappa = |k|` already known.
#[inline]
pub fn point_cap_x_kappa(t: Vec3, k: Vec3, kappa: f64, vcap: f64, caps: &Caps) -> f64 {
    let mut x = vcap * vcap;
    for i in 0..3 {
        if let Some(v) = caps.vaxis {
            let ti = t[i].abs();
            if ti > NEGLIGIBLE {
                x = x.min((v[i] / ti).powi(2));
            }
        }
        let ki = k[i].abs();
        if ki > NEGLIGIBLE && caps.jerk.is_none() {
            x = x.min(caps.acc[i] / ki);
        }
    }
    if let Some(j) = &caps.jerk {
        // Jerk mode: the curvature term takes what the tangential limit leaves.
        x = x.min(j.curvature_cap_x(&caps.acc, t, k));
    }
    if kappa > NEGLIGIBLE {
        let r = 1.0 / kappa;
        let d = caps.chord_error_mm;
        // Longest chord whose sagitta is at most d: 2 sqrt(d (2R - d)) while d < R; for
        // R <= d every chord (up to the diameter) is within d.
        let chord = if d < r {
            2.0 * (d * (2.0 * r - d)).sqrt()
        } else {
            2.0 * r
        };
        let v = chord / caps.period_s;
        x = x.min(v * v);
    }
    x
}

/// G1 joint: the normal acceleration steps by `x (k_right - k_left)`; keep each axis's
/// step within its limit.
pub fn g1_joint_cap_x(k_left: Vec3, k_right: Vec3, caps: &Caps) -> f64 {
    let dk = k_right - k_left;
    let mut x = f64::INFINITY;
    for i in 0..3 {
        let d = dk[i].abs();
        if d > NEGLIGIBLE {
            x = x.min(caps.acc[i] / d);
        }
    }
    x
}

/// Cosine above which grbl treats a junction as a full reversal (stop).
const JUNCTION_REVERSAL_COS: f64 = 0.999_999;

/// grbl's junction-deviation corner speed (as `x = v^2`) between unit directions `d_in`
/// and `d_out`: `v^2 = a delta sin(theta/2) / (1 - sin(theta/2))` with `theta` the angle
/// between `-d_in` and `d_out` and `a` the largest acceleration the axes allow along
/// `d_out - d_in`. Zero for a reversal.
pub fn junction_cap_x(d_in: Vec3, d_out: Vec3, deviation_mm: f64, caps: &Caps) -> f64 {
    let cos_theta = -d_in.dot(d_out);
    if cos_theta > JUNCTION_REVERSAL_COS {
        return 0.0;
    }
    let Some(u) = (d_out - d_in).normalized() else {
        return f64::INFINITY;
    };
    let mut a = f64::INFINITY;
    for i in 0..3 {
        if u[i].abs() > NEGLIGIBLE {
            a = a.min(caps.acc[i] / u[i].abs());
        }
    }
    let sin_half = (0.5 * (1.0 - cos_theta)).max(0.0).sqrt();
    a * deviation_mm * sin_half / (1.0 - sin_half)
}

/// Largest tangential acceleration (mm/s^2) along a fixed unit direction `t` on a straight
/// piece: `min_i A_i / |t_i|`.
pub fn line_acc(t: Vec3, caps: &Caps) -> f64 {
    let mut u = f64::INFINITY;
    for i in 0..3 {
        if t[i].abs() > NEGLIGIBLE {
            u = u.min(caps.acc[i] / t[i].abs());
        }
    }
    u
}

/// Most rows of one interval: two per axis at each of the start, end and midpoint, and
/// the midpoint's speed cap.
const MAX_ROWS: usize = 19;

/// One grid interval of length `ds` with the geometry at its two ends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    /// Arc length (mm), > 0.
    pub ds: f64,
    /// Straight (no curvature at either end, same tangent): the acceleration bound is the
    /// constant [`Interval::u_line`] and the profile inside may switch phases.
    pub straight: bool,
    /// For straight intervals, the tangential acceleration bound (mm/s^2).
    pub u_line: f64,
    /// For straight intervals, the cap on `v^2` inside (the line's own speed limits; the
    /// end points may carry lower joint caps).
    pub x_inside: f64,
    /// Unit tangent at the start.
    pub t0: Vec3,
    /// Curvature vector at the start (1/mm).
    pub k0: Vec3,
    /// Unit tangent at the end.
    pub t1: Vec3,
    /// Curvature vector at the end (1/mm).
    pub k1: Vec3,
    /// Geometry at an interior point of a curved interval where the axis limits are
    /// imposed as well (see [`IntervalMid`]); `None` for straight intervals and in jerk
    /// mode.
    pub mid: Option<IntervalMid>,
}

/// An interior check point of a curved interval, at the share `f` of its arc length: the
/// per-axis rows `|u T_i + x K_i| <= A_i` hold there too, with `x = (1 - f) x_start +
/// f x_end` (linear in `s`), so they stay linear in `(x_start, x_end)`. Between the three
/// checks the grid bounds what can happen on each half as it bounds whole intervals
/// without one (see [`super::grid`]), so an interval with a midpoint can be twice as long.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntervalMid {
    /// Share of the interval's arc length before the point, in (0, 1).
    pub f: f64,
    /// Unit tangent there.
    pub t: Vec3,
    /// Curvature vector there (1/mm).
    pub k: Vec3,
    /// The point's own cap on `x = v^2` ([`point_cap_x`]), imposed as the row
    /// `(1 - f) x_start + f x_end <= x_cap`.
    pub x_cap: f64,
}

impl Interval {
    /// Calls `row(a, b, c)` for each linear constraint `a p + b q <= c` in `p = x_start`,
    /// `q = x_end` (at most [`MAX_ROWS`]: two per axis at the start, end and midpoint,
    /// and the midpoint's speed cap), without storing them.
    #[inline]
    fn each_row(&self, caps: &Caps, mut row: impl FnMut(f64, f64, f64)) {
        let h = 2.0 * self.ds;
        let mut push = |a: f64, b: f64, c: f64| {
            if a.abs() > NEGLIGIBLE || b.abs() > NEGLIGIBLE {
                row(a, b, c);
            }
        };
        if let Some(j) = caps.jerk {
            // Jerk mode: the plan's only acceleration constraint is |u| = |q - p| / h <= U
            // (the axes' share of the curvature term is a speed cap; see `super::jerk`).
            push(-1.0, 1.0, h * j.u_max_mm_s2);
            push(1.0, -1.0, h * j.u_max_mm_s2);
            return;
        }
        if let Some(m) = &self.mid {
            if m.x_cap.is_finite() {
                push(1.0 - m.f, m.f, m.x_cap);
            }
        }
        for i in 0..3 {
            let ha = h * caps.acc[i];
            let (t0, k0, t1, k1) = (self.t0[i], self.k0[i], self.t1[i], self.k1[i]);
            // Start: |(q - p)/h t0 + p k0| <= A.
            push(h * k0 - t0, t0, ha);
            push(t0 - h * k0, -t0, ha);
            // End: |(q - p)/h t1 + q k1| <= A.
            push(-t1, t1 + h * k1, ha);
            push(t1, -t1 - h * k1, ha);
            if let Some(m) = &self.mid {
                // Midpoint: |(q - p)/h t + ((1 - f) p + f q) k| <= A.
                let (tm, km) = (m.t[i], m.k[i]);
                let (a, b) = (h * (1.0 - m.f) * km - tm, tm + h * m.f * km);
                push(a, b, ha);
                push(-a, -b, ha);
            }
        }
    }

    /// Backward step: the largest `p <= p_cap` from which some `q` in `[0, q_cap]` is
    /// reachable over this interval. Returns `(p, free)`, `free` when `p_cap` itself is
    /// reachable (the downstream did not bind).
    pub fn backward(&self, p_cap: f64, q_cap: f64, caps: &Caps) -> (f64, bool) {
        if self.straight {
            let p = q_cap + 2.0 * self.u_line * self.ds;
            return if p >= p_cap {
                (p_cap, true)
            } else {
                (p, false)
            };
        }
        // Eliminating q: upper bounds q <= al + be p, lower bounds q >= ga + de p. The
        // feasible p form an interval containing 0 (p = q = 0 needs no acceleration: every
        // `c >= 0`), and its upper end is where the concave gap
        // `g(p) = min(al + be p) - max(ga + de p)` falls to zero (Fourier-Motzkin: the
        // least crossing of an upper and a lower bound, see `backward_pairwise`). Newton
        // on `g` from the right: at a `p` where `g < 0` the binding upper and lower rows
        // cross at or beyond the root (a concave function lies below its tangents), so the
        // steps fall monotonically onto it, each moving to another pair of rows; a step
        // that does not decrease `p` ends the search (rounding). Usually one or two steps,
        // against the `nu nl` divisions of the pairwise elimination.
        let mut up = [(q_cap, 0.0); MAX_ROWS + 1];
        let mut lo = [(0.0, 0.0); MAX_ROWS + 1];
        let (mut nu, mut nl) = (1usize, 1usize);
        let mut p = p_cap;
        self.each_row(caps, |a, b, c| {
            if b > NEGLIGIBLE {
                up[nu] = (c / b, -a / b);
                nu += 1;
            } else if b < -NEGLIGIBLE {
                lo[nl] = (c / b, -a / b);
                nl += 1;
            } else if a > NEGLIGIBLE {
                p = p.min(c / a);
            }
        });
        let (up, lo) = (&up[..nu], &lo[..nl]);
        for _ in 0..nu * nl {
            let (mut ui, mut u) = (0, f64::INFINITY);
            for (i, &(al, be)) in up.iter().enumerate() {
                let v = al + be * p;
                if v < u {
                    (ui, u) = (i, v);
                }
            }
            let (mut li, mut l) = (0, f64::NEG_INFINITY);
            for (i, &(ga, de)) in lo.iter().enumerate() {
                let v = ga + de * p;
                if v > l {
                    (li, l) = (i, v);
                }
            }
            if u >= l {
                break;
            }
            let ((al, be), (ga, de)) = (up[ui], lo[li]);
            let slope = be - de;
            let next = if slope < 0.0 { (ga - al) / slope } else { 0.0 };
            if next >= p || next.is_nan() {
                break;
            }
            p = next;
        }
        let p = p.max(0.0);
        (p, p >= p_cap)
    }

    /// Forward step: the largest `q <= q_cap` reachable from `p`.
    pub fn forward(&self, p: f64, q_cap: f64, caps: &Caps) -> f64 {
        if self.straight {
            return q_cap.min(p + 2.0 * self.u_line * self.ds).max(0.0);
        }
        let mut q = q_cap;
        self.each_row(caps, |a, b, c| {
            if b > NEGLIGIBLE {
                q = q.min((c - a * p) / b);
            }
        });
        q.max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn caps() -> Caps {
        Caps {
            acc: [500.0, 500.0, 500.0],
            vaxis: None,
            period_s: 0.001,
            chord_error_mm: 0.001,
            jerk: None,
        }
    }

    /// Unit tangent and curvature vector at angle `a` on the circle of radius `r` about
    /// the origin in XY (counter-clockwise).
    fn circle_frame(r: f64, a: f64) -> (Vec3, Vec3) {
        let t = Vec3::new(-a.sin(), a.cos(), 0.0);
        let k = Vec3::new(-a.cos(), -a.sin(), 0.0) / r;
        (t, k)
    }

    /// The curved interval from angle `a0` to `a1` on that circle, without a midpoint.
    fn circle_interval(r: f64, a0: f64, a1: f64) -> Interval {
        let (t0, k0) = circle_frame(r, a0);
        let (t1, k1) = circle_frame(r, a1);
        Interval {
            ds: r * (a1 - a0),
            straight: false,
            u_line: 0.0,
            x_inside: 0.0,
            t0,
            k0,
            t1,
            k1,
            mid: None,
        }
    }

    #[test]
    fn curvature_and_chord_caps() {
        // Circle of radius 10 in XY at the point (10, 0): tangent +Y, curvature -X / 10.
        let x = point_cap_x(Vec3::Y, Vec3::new(-0.1, 0.0, 0.0), 1e9, &caps());
        // Curvature: v^2 <= 500 * 10 = 5000; chord: (2/T) sqrt(0.001 (20 - 0.001)).
        let chord = 2000.0 * (0.001f64 * (20.0 - 0.001)).sqrt();
        assert!((x - 5000.0f64.min(chord * chord)).abs() < 1e-9);
        // Along a diagonal normal the axes share the load: a_dir = 500 / cos 45.
        let n = Vec3::new(-1.0, -1.0, 0.0) / 2f64.sqrt();
        let x = point_cap_x(
            Vec3::new(1.0, -1.0, 0.0) / 2f64.sqrt(),
            n * 0.1,
            1e9,
            &caps(),
        );
        assert!((x - 500.0 * 2f64.sqrt() * 10.0).abs() < 1e-6);
        // Tiny radius: the chord limit is the diameter.
        let big = Caps {
            acc: [1e12; 3],
            ..caps()
        };
        let x = point_cap_x(Vec3::Y, Vec3::new(-2000.0, 0.0, 0.0), 1e9, &big);
        assert!((x - (2.0 / 2000.0 / 0.001f64).powi(2)).abs() < 1e-9);
    }

    #[test]
    fn junction_deviation_matches_grbl() {
        // 90 degree corner, X then Y: theta = 90, sin 45; direction change (-1, 1)/sqrt2.
        let x = junction_cap_x(Vec3::X, Vec3::Y, 0.01, &caps());
        let s = (0.5f64).sqrt();
        let a = 500.0 * 2f64.sqrt();
        assert!((x - a * 0.01 * s / (1.0 - s)).abs() < 1e-9);
        assert_eq!(junction_cap_x(Vec3::X, -Vec3::X, 0.01, &caps()), 0.0);
    }

    /// The backward step by pairwise Fourier-Motzkin elimination (every crossing of an
    /// upper and a lower bound on `q`): the reference for [`Interval::backward`].
    fn backward_pairwise(iv: &Interval, p_cap: f64, q_cap: f64, caps: &Caps) -> f64 {
        let mut up = vec![(q_cap, 0.0)];
        let mut lo = vec![(0.0, 0.0)];
        let mut p_max = p_cap;
        iv.each_row(caps, |a, b, c| {
            if b > NEGLIGIBLE {
                up.push((c / b, -a / b));
            } else if b < -NEGLIGIBLE {
                lo.push((c / b, -a / b));
            } else if a > NEGLIGIBLE {
                p_max = p_max.min(c / a);
            }
        });
        for &(al, be) in &up {
            for &(ga, de) in &lo {
                let slope = be - de;
                if slope < 0.0 {
                    p_max = p_max.min((ga - al) / slope);
                }
            }
        }
        p_max.max(0.0)
    }

    proptest! {
        /// The Newton search of the backward step finds the pairwise elimination's answer
        /// on random curved intervals (tangents, curvatures, midpoints and caps), to the
        /// last few bits.
        #[test]
        fn backward_is_the_pairwise_elimination(
            a0 in 0.0f64..6.3, a1 in -0.2f64..0.2, am in 0.0f64..1.0,
            k0 in proptest::array::uniform3(-50.0f64..50.0),
            k1 in proptest::array::uniform3(-50.0f64..50.0),
            km in proptest::array::uniform3(-50.0f64..50.0),
            ds in 1e-4f64..1.0,
            z in -0.5f64..0.5,
            f in 0.05f64..0.95,
            x_mid in prop_oneof![Just(f64::INFINITY), 0.0f64..3000.0],
            with_mid in proptest::bool::ANY,
            p_cap in prop_oneof![Just(1e9), 0.0f64..3000.0],
            q_cap in prop_oneof![Just(0.0), 0.0f64..3000.0, Just(1e9)],
            acc in proptest::array::uniform3(10.0f64..1000.0),
        ) {
            let dir = |a: f64| Vec3::new(a.cos(), a.sin(), z).normalized().unwrap();
            let k = |v: [f64; 3], t: Vec3| {
                let v = Vec3::new(v[0], v[1], v[2]);
                v - t * t.dot(v)
            };
            let (t0, t1, tm) = (dir(a0), dir(a0 + a1), dir(a0 + am * a1));
            let iv = Interval {
                ds,
                straight: false,
                u_line: 0.0,
                x_inside: 0.0,
                t0,
                k0: k(k0, t0),
                t1,
                k1: k(k1, t1),
                mid: with_mid.then_some(IntervalMid { f, t: tm, k: k(km, tm), x_cap: x_mid }),
            };
            let c = Caps { acc, ..caps() };
            let (p, free) = iv.backward(p_cap, q_cap, &c);
            let reference = backward_pairwise(&iv, p_cap, q_cap, &c);
            prop_assert!(
                (p - reference).abs() <= 1e-12 * reference.max(1.0),
                "{p} vs {reference}"
            );
            prop_assert_eq!(free, p >= p_cap);
        }
    }

    #[test]
    fn straight_and_lp_agree_on_lines() {
        let t = Vec3::new(3.0, 4.0, 0.0) / 5.0;
        let c = caps();
        let straight = Interval {
            ds: 0.7,
            straight: true,
            u_line: line_acc(t, &c),
            x_inside: 1e9,
            t0: t,
            k0: Vec3::ZERO,
            t1: t,
            k1: Vec3::ZERO,
            mid: None,
        };
        let lp = Interval {
            straight: false,
            ..straight
        };
        for &(p_cap, q_cap) in &[(1e9, 0.0), (100.0, 30.0), (1e9, 1e3)] {
            let (a, fa) = straight.backward(p_cap, q_cap, &c);
            let (b, fb) = lp.backward(p_cap, q_cap, &c);
            assert!((a - b).abs() < 1e-9 * a.max(1.0), "{a} {b}");
            assert_eq!(fa, fb);
        }
        for &(p, q_cap) in &[(0.0, 1e9), (100.0, 200.0), (500.0, 1e9)] {
            let a = straight.forward(p, q_cap, &c);
            let b = lp.forward(p, q_cap, &c);
            assert!((a - b).abs() < 1e-9 * a.max(1.0), "{a} {b}");
        }
        // u_line = 500 / 0.8 (the Y axis binds).
        assert!((straight.u_line - 625.0).abs() < 1e-12);
    }

    #[test]
    fn arc_interval_respects_axis_acceleration() {
        // A short piece of a radius-5 circle; check every accepted (p, q) by brute force.
        let c = caps();
        let iv = circle_interval(5.0, 0.0, 0.04);
        let (t0, k0, t1, k1) = (iv.t0, iv.k0, iv.t1, iv.k1);
        let check = |p: f64, q: f64| {
            let u = (q - p) / (2.0 * iv.ds);
            for (t, k, x) in [(t0, k0, p), (t1, k1, q)] {
                for i in 0..3 {
                    assert!((u * t[i] + x * k[i]).abs() <= c.acc[i] * (1.0 + 1e-9));
                }
            }
        };
        for q_cap in [0.0, 100.0, 1000.0, 2500.0] {
            let (p, _) = iv.backward(1e9, q_cap, &c);
            // Some q in [0, q_cap] must work: the most decelerating one is the forward
            // pass's lower end; check the pair with the smallest admissible q by scanning.
            let mut ok = false;
            for j in 0..=1000 {
                let q = q_cap * j as f64 / 1000.0;
                let u = (q - p) / (2.0 * iv.ds);
                let fits = [(t0, k0, p), (t1, k1, q)].iter().all(|(t, k, x)| {
                    (0..3).all(|i| (u * t[i] + x * k[i]).abs() <= c.acc[i] * (1.0 + 1e-6))
                });
                ok |= fits;
            }
            assert!(ok, "q_cap {q_cap}: p {p} not controllable");
            let q = iv.forward(p.min(2000.0), 1e9, &c);
            check(p.min(2000.0), q);
        }
    }

    #[test]
    fn midpoint_rows_hold_at_the_midpoint() {
        // A radius-2 arc piece of 0.3 rad with its midpoint checked, and a midpoint speed
        // cap below both end caps: every (p, q) the passes accept keeps the midpoint's
        // axis accelerations and cap; without the midpoint the passes accept a pair that
        // breaks them.
        let c = caps();
        let r = 2.0;
        let (tm, km) = circle_frame(r, 0.15);
        let x_cap = 400.0;
        let with = Interval {
            mid: Some(IntervalMid {
                f: 0.5,
                t: tm,
                k: km,
                x_cap,
            }),
            ..circle_interval(r, 0.0, 0.3)
        };
        let mid_ok = |p: f64, q: f64, slack: f64| {
            let u = (q - p) / (2.0 * with.ds);
            let x = 0.5 * (p + q);
            x <= x_cap * (1.0 + slack)
                && (0..3).all(|i| (u * tm[i] + x * km[i]).abs() <= c.acc[i] * (1.0 + slack))
        };
        for q_cap in [0.0, 100.0, 300.0, 1000.0] {
            let (p, _) = with.backward(1e9, q_cap, &c);
            let q = with.forward(p, q_cap, &c);
            assert!(mid_ok(p, q, 1e-9), "q_cap {q_cap}: ({p}, {q})");
            for p0 in [0.0, 50.0, 200.0, 390.0] {
                let q = with.forward(p0, 1e9, &c);
                assert!(mid_ok(p0, q, 1e-9), "({p0}, {q})");
            }
        }
        let without = Interval { mid: None, ..with };
        let (p, _) = without.backward(1e9, 1e9, &c);
        let q = without.forward(p, 1e9, &c);
        assert!(
            !mid_ok(p, q, 1e-6),
            "the end rows alone already hold: ({p}, {q})"
        );
    }
}
