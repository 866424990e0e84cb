//! Arc splines: a smooth curve carried by tangent-continuous circular arcs, the `arc`
//! method's run mode ([`super::run_mode`] with `Family::Arcs`).
//!
//! Wu et al. (section III.A) blend each corner with one arc; along a run of micro-corners
//! that makes the curvature jump between zero (the straight remainder of a leg) and the
//! arc's `1/R` at every joint, and a jerk limit measured per period slows the feed at
//! every such step (`v^2 dk <= J T`). The run mode keeps Wu's family but places the arcs
//! along the run's band-fitted cubic B-spline instead, so that consecutive arcs differ in
//! curvature by a small share of it.
//!
//! ## The biarc
//! Between two points `P0`, `P1` with unit tangents `T0`, `T1` the equal-tangent-length
//! biarc (Bolton 1975; Meek and Walton, "Approximating smooth planar curves by arc
//! splines", J. Comput. Appl. Math. 59, 1995) is two arcs meeting at the joint
//! `J = (P0 + d T0 + P1 - d T1) / 2`, where `d` solves `|P1 - P0 - d (T0 + T1)| = 2 d`:
//! the first arc starts at `P0` along `T0`, the second ends at `P1` along `T1`, and both
//! are tangent to `P1 - d T1 - (P0 + d T0)` at `J`. In 3-D each arc lies in its own plane.
//!
//! ## The fit ([`arc_spline`])
//! Each cubic piece `[t0, t1]` gets a biarc on its end points and tangents; the piece is
//! halved until the biarc is within `max_dev_mm` of the piece and each arc's curvature
//! vector is within `CURVATURE_SHARE` (0.02) of the piece's largest curvature on the arc's half
//! (plus `CURVATURE_FLOOR_PER_MM` (1e-3)) at every sample, down to `MIN_ARC_MM` (0.01): the steps
//! between consecutive arcs are then small against the curvature, which is what a
//! jerk-limited plan pays for (`v^2 dk` per period against `J T`; with `v^2 <= A / k` on
//! a curve, a relative step of `J T / A`, 2 % at 3000 mm/s^2, 60000 mm/s^3, 1 ms). An
//! arc of curvature below `LINE_CURVATURE_PER_MM` is a line. What it bounds: the sampled
//! distance to the cubic (the caller measures the result against the band).

use crate::geom::{Arc, Line, ParamCurveCurvature};
use crate::geom::{ParamCurveNearest, Segment, Vec3};

/// Largest difference between an arc's curvature vector and the cubic's, as a share of
/// the cubic's largest curvature on the arc's span.
pub(crate) const CURVATURE_SHARE: f64 = 0.02;
/// Curvature difference (1/mm) always accepted: a step of 1e-3 /mm at 200 mm/s is
/// 40 mm/s^2 of normal acceleration.
pub(crate) const CURVATURE_FLOOR_PER_MM: f64 = 1e-3;
/// An arc of less curvature than this (1/mm, a radius of 10 m) is written as its chord:
/// a tenth of [`CURVATURE_FLOOR_PER_MM`], so the step to it is accepted too.
pub(crate) const LINE_CURVATURE_PER_MM: f64 = 0.1 * CURVATURE_FLOOR_PER_MM;
/// Arcs are not split for curvature below about this length (mm; a biarc spanning less
/// than four of it is not halved for curvature): a period's travel at 10 mm/s and 1 ms,
/// where the steps of shorter arcs fall into one period of a plan and add up to what the
/// curve's own curvature change costs. The floor trades some cycle time for fewer
/// blocks (a file with an E axis keeps every arc a block; figures in
/// `docs/benchmarks/2026-12-02.md`).
pub(crate) const MIN_ARC_MM: f64 = 0.01;
/// Most halvings of one cubic piece.
pub(crate) const MAX_DEPTH: u32 = 14;
/// Samples per biarc half for the distance and curvature tests.
const SAMPLES: usize = 6;

/// The arc from `p` along the unit tangent `t` to `q`, or the line where it is straight.
fn arc_or_line(p: Vec3, t: Vec3, q: Vec3) -> Segment {
    match Arc::from_tangent(p, t, q) {
        Some(a) if a.radius * LINE_CURVATURE_PER_MM < 1.0 => Segment::Arc(a),
        _ => Segment::Line(Line::new(p, q)),
    }
}

/// The equal-tangent-length biarc from `p0` (unit tangent `t0`) to `p1` (unit tangent
/// `t1`), module doc; `None` when it does not exist (tangents opposed to the chord).
pub fn biarc(p0: Vec3, t0: Vec3, p1: Vec3, t1: Vec3) -> Option<[Segment; 2]> {
    let v = p1 - p0;
    let t = t0 + t1;
    let (vt, vv) = (v.dot(t), v.norm_sq());
    let a = t.norm_sq() - 4.0;
    let d = if a.abs() <= 1e-12 {
        vv / (2.0 * vt)
    } else {
        (vt - (vt * vt - a * vv).max(0.0).sqrt()) / a
    };
    if !(d.is_finite() && d > 0.0) {
        return None;
    }
    let (q0, q1) = (p0 + t0 * d, p1 - t1 * d);
    let j = (q0 + q1) * 0.5;
    let tj = (q1 - q0).normalized().unwrap_or(t0);
    Some([arc_or_line(p0, t0, j), arc_or_line(j, tj, p1)])
}

/// Curvature vector of a line or arc (constant on both).
fn seg_curvature(s: &Segment, t: f64) -> Vec3 {
    match s {
        Segment::Arc(a) => a.curvature_vec(t),
        _ => Vec3::ZERO,
    }
}

/// Whether `s` follows `c` on `[t0, t1]`: within `max_dev_mm` and, when `curv`, in
/// curvature (module doc).
fn follows<C: ParamCurveCurvature>(
    c: &C,
    t0: f64,
    t1: f64,
    s: &Segment,
    max_dev_mm: f64,
    curv: bool,
) -> bool {
    let ts: Vec<f64> = (0..=SAMPLES)
        .map(|i| t0 + (t1 - t0) * i as f64 / SAMPLES as f64)
        .collect();
    let peak = ts.iter().map(|&t| c.curvature(t)).fold(0.0, f64::max);
    let allow = CURVATURE_SHARE * peak + CURVATURE_FLOOR_PER_MM;
    ts.iter().all(|&t| {
        let p = c.eval(t);
        let n = s.nearest(p, max_dev_mm * 1e-3);
        n.distance_sq <= max_dev_mm * max_dev_mm
            && (!curv || seg_curvature(s, n.t).dist(c.curvature_vec(t)) <= allow)
    })
}

/// The curve `c` on `[t0, t1]` as an arc spline within `max_dev_mm` (module doc), pushed
/// to `out` with the curve's parameters where each piece ends; `false` when a part cannot
/// be fitted.
pub fn arc_spline<C: ParamCurveCurvature>(
    c: &C,
    t0: f64,
    t1: f64,
    max_dev_mm: f64,
    out: &mut Vec<(Segment, f64)>,
) -> bool {
    fit(c, t0, t1, max_dev_mm, 0, out)
}

fn fit<C: ParamCurveCurvature>(
    c: &C,
    t0: f64,
    t1: f64,
    max_dev_mm: f64,
    depth: u32,
    out: &mut Vec<(Segment, f64)>,
) -> bool {
    let tangent = |t: f64| c.deriv(t).normalized();
    let pair = match (tangent(t0), tangent(t1)) {
        (Some(a), Some(b)) => biarc(c.eval(t0), a, c.eval(t1), b),
        _ => None,
    };
    let tm = 0.5 * (t0 + t1);
    if let Some([s0, s1]) = pair {
        let curv = c.eval(t0).dist(c.eval(t1)) > 4.0 * MIN_ARC_MM;
        if follows(c, t0, tm, &s0, max_dev_mm, curv) && follows(c, tm, t1, &s1, max_dev_mm, curv) {
            out.push((s0, tm));
            out.push((s1, t1));
            return true;
        }
    }
    depth < MAX_DEPTH
        && fit(c, t0, tm, max_dev_mm, depth + 1, out)
        && fit(c, tm, t1, max_dev_mm, depth + 1, out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{CubicBez, ParamCurve, ParamCurveArclen, ParamCurveDeriv};

    #[test]
    fn biarc_of_a_circle_is_the_circle() {
        // A quarter circle of radius 2: both arcs have radius 2 and meet on it.
        let (p0, p1) = (Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0));
        let [a, b] = biarc(p0, Vec3::Y, p1, -Vec3::X).unwrap();
        for s in [a, b] {
            let Segment::Arc(arc) = s else {
                panic!("{s:?}")
            };
            assert!((arc.radius - 2.0).abs() < 1e-12 && arc.center.norm() < 1e-12);
        }
    }

    #[test]
    fn biarc_is_tangent_at_both_ends_and_the_joint() {
        let (p0, p1) = (Vec3::new(0.0, 0.0, 0.0), Vec3::new(3.0, 1.0, 0.5));
        let t0 = Vec3::new(1.0, 0.5, 0.0).normalized().unwrap();
        let t1 = Vec3::new(0.6, -0.2, 0.3).normalized().unwrap();
        let [a, b] = biarc(p0, t0, p1, t1).unwrap();
        assert!(a.start().dist(p0) < 1e-12 && b.end().dist(p1) < 1e-12);
        assert!(a.end().dist(b.start()) < 1e-12);
        let tan = |s: &Segment, t: f64| s.deriv(t).normalized().unwrap();
        assert!(tan(&a, 0.0).dist(t0) < 1e-9 && tan(&b, 1.0).dist(t1) < 1e-9);
        assert!(tan(&a, 1.0).dist(tan(&b, 0.0)) < 1e-9);
    }

    #[test]
    fn arc_spline_follows_a_cubic_in_curvature() {
        let c = CubicBez::new(
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
            Vec3::new(2.0, 3.0, 0.0),
        );
        let mut out = Vec::new();
        assert!(arc_spline(&c, 0.0, 1.0, 1e-4, &mut out));
        assert!(out.len() >= 4);
        let peak = (0..=100)
            .map(|i| c.curvature(i as f64 / 100.0))
            .fold(0.0, f64::max);
        let mut prev = out[0].0.start();
        let mut prev_k: Option<Vec3> = None;
        for (s, _) in &out {
            assert!(s.start().dist(prev) < 1e-12);
            prev = s.end();
            let k = seg_curvature(s, 0.5);
            if let Some(pk) = prev_k {
                // Neighbouring arcs: steps of a few shares of the peak at most.
                assert!(
                    pk.dist(k) <= 4.0 * CURVATURE_SHARE * peak + 2e-3,
                    "{pk:?} {k:?}"
                );
            }
            prev_k = Some(k);
            for i in 0..=10 {
                let n = c.nearest(s.eval(i as f64 / 10.0), 1e-9);
                assert!(n.distance_sq.sqrt() <= 1.01e-4);
            }
        }
        assert!(prev.dist(c.p3) < 1e-12);
        let len: f64 = out.iter().map(|(s, _)| s.arclen(1e-9)).sum();
        assert!((len - c.arclen(1e-9)).abs() < 1e-3);
    }
}
