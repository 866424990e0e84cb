//! Tests of the whole plan-and-interpolate run against analytic answers and measured
//! limits.

use super::*;
use crate::feed::PlanOptions;
use crate::geom::{Arc, CubicBez, Line};
use crate::path::{Move, Toolpath};
use proptest::prelude::*;

/// Parsed CSV: (t, x, y, z, feed) rows.
fn rows(csv: &[u8]) -> Vec<[f64; 5]> {
    let s = std::str::from_utf8(csv).unwrap();
    let mut lines = s.lines();
    assert!(lines.next().unwrap().starts_with("t,x,y,z,feed"));
    lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3], v[4]]
        })
        .collect()
}

fn run(tp: &Toolpath, p: &PlanOptions, i: &InterpOptions) -> (PlanReport, Vec<[f64; 5]>) {
    let (rep, out) = execute(tp, p, i, Vec::new()).unwrap();
    let r = rows(&out);
    (rep, r)
}

/// The invariants every run must hold.
fn check_invariants(tp: &Toolpath, rep: &PlanReport, r: &[[f64; 5]]) {
    assert!(!r.is_empty());
    for w in r.windows(2) {
        assert!(w[1][0] > w[0][0], "time not increasing: {:?}", w);
    }
    for row in r {
        assert!(row.iter().all(|v| v.is_finite()), "NaN in {row:?}");
    }
    let end = tp.end_point();
    let last = r[r.len() - 1];
    assert!(
        Vec3::new(last[1], last[2], last[3]).dist(end) <= 1e-9,
        "end {last:?} vs {end:?}"
    );
    assert!(rep.end_point_error_mm <= 1e-9);
    assert_eq!(rep.setpoints, r.len());
}

/// The plan's pieces cover the path without a gap: each starts where the previous one
/// (or a stop) ended, and the last ends at the path's end. A gap would be a distance
/// jumped in no time.
fn assert_plan_covers(tp: &Toolpath, p: &PlanOptions) {
    let idx = crate::feed::PathIndex::new(tp, p);
    let total: f64 = idx.moves.iter().map(|m| m.len).sum();
    let mut s = 0.0;
    crate::feed::plan_stream(&idx, p, |e| match e {
        crate::feed::PlanEvent::Piece(pc) => {
            assert!((pc.s0 - s).abs() <= 1e-9 * (1.0 + s), "gap {s} -> {pc:?}");
            s = pc.s0 + pc.ds;
        }
        crate::feed::PlanEvent::Stop { s: at, .. } => {
            assert!(
                (at - s).abs() <= 1e-9 * (1.0 + s),
                "stop at {at}, plan at {s}"
            );
        }
    });
    assert!((s - total).abs() <= 1e-9 * (1.0 + total), "{s} of {total}");
}

fn assert_limits(rep: &PlanReport) {
    for a in &rep.axes {
        assert!(a.a_within, "{a:?}");
        assert!(a.v_within, "{a:?}");
    }
}

#[test]
fn line_setpoints_follow_the_trapezoid() {
    let tp = Toolpath::from_polyline(&[Vec3::ZERO, Vec3::new(30.0, 40.0, 0.0)], None);
    let p = PlanOptions::default();
    let (rep, r) = run(&tp, &p, &InterpOptions::default());
    check_invariants(&tp, &rep, &r);
    assert_limits(&rep);
    // 50 mm at 50 mm/s; the X axis carries 0.6 of the motion, Y 0.8: Y binds, so the
    // tangential acceleration is 0.99 * 500 / 0.8.
    let a = 0.99 * 500.0 / 0.8;
    let expect = 50.0 / 50.0 + 50.0 / a;
    assert!((rep.cycle_time_s - expect).abs() <= p.period_s + 1e-9);
    assert!((rep.axes[1].a_max_mm_s2 - 0.99 * 500.0).abs() < 1.0);
    assert_eq!(r[0][1..4], [0.0, 0.0, 0.0]);
    assert_eq!(rep.interp.eta_max.max(0.0), rep.interp.eta_max);
    assert!(rep.interp.eta_max < 1e-9);
}

fn butterfly_path() -> Toolpath {
    let mut tp = Toolpath::new(crate::profiles::butterfly().start());
    tp.push_move(Move::feed(crate::profiles::butterfly(), None, 1));
    tp
}

#[test]
fn butterfly_nurbs_wu_setting() {
    // Wu's setting: T = 2 ms, 50 mm/s, 500 mm/s^2, eta_tol 0.1 %, n = 2.
    let tp = butterfly_path();
    let p = PlanOptions {
        period_s: 0.002,
        ..Default::default()
    };
    let (rep, r) = run(&tp, &p, &InterpOptions::default());
    check_invariants(&tp, &rep, &r);
    assert!(rep.interp.eta_max <= 0.001, "{:?}", rep.interp);
    for a in &rep.axes {
        assert!(a.a_ratio <= 1.01, "{a:?}");
    }
    assert!(rep.interp.iterations_max <= 2);
    // Taylor steps fluctuate more than Newton's.
    let t1 = InterpOptions {
        method: InterpMethod::Taylor1,
        ..Default::default()
    };
    let (rep1, r1) = run(&tp, &p, &t1);
    check_invariants(&tp, &rep1, &r1);
    assert!(rep1.interp.eta_max > rep.interp.eta_max);
    // Without the arc-length correction the setpoints are each method's own: Taylor 1's
    // fluctuation shows in the output and its finite differences, Newton's does not.
    let own = |method| InterpOptions {
        method,
        arc_correction: false,
        ..Default::default()
    };
    let (rn, rows_n) = run(&tp, &p, &own(InterpMethod::Newton));
    let (rt, rows_t) = run(&tp, &p, &own(InterpMethod::Taylor1));
    check_invariants(&tp, &rn, &rows_n);
    check_invariants(&tp, &rt, &rows_t);
    assert_eq!(rn.interp.arc_corrections, 0);
    let worst = |r: &PlanReport| r.axes.iter().map(|a| a.a_ratio).fold(0.0, f64::max);
    assert!(worst(&rn) <= 1.0, "{:?}", rn.axes);
    assert!(worst(&rt) > 1.03, "{:?}", rt.axes);
    assert!(rt.interp.feed_fluctuation_max > 10.0 * rn.interp.feed_fluctuation_max);
    // With it (the default) both follow the plan.
    assert!(worst(&rep1) <= 1.0 && rep1.interp.arc_corrections > 0);
}

#[test]
fn zero_speed_ends_are_handled() {
    // Repeated control points at both ends: zero parametric speed at t = 0 and 1.
    let a = Vec3::ZERO;
    let b = Vec3::new(10.0, 0.0, 0.0);
    let c = CubicBez::new(a, a, b, b);
    let mut tp = Toolpath::new(a);
    tp.push_move(Move::feed(c, None, 1));
    let c2 = CubicBez::new(b, b, Vec3::new(10.0, 10.0, 0.0), Vec3::new(10.0, 10.0, 0.0));
    tp.push_move(Move::feed(c2, None, 2));
    let p = PlanOptions::default();
    let (rep, r) = run(&tp, &p, &InterpOptions::default());
    check_invariants(&tp, &rep, &r);
    assert_limits(&rep);
    assert_eq!(rep.exact_stops.corner, 1);
    // Every setpoint lies on the straight pieces.
    for row in &r {
        assert!(
            row[2].abs() < 1e-9 || (row[1] - 10.0).abs() < 1e-9,
            "{row:?}"
        );
    }
}

#[test]
fn helix_and_events() {
    let arc = Arc::from_center(
        Vec3::new(10.0, 0.0, 0.0),
        Vec3::new(10.0, 0.0, 2.0),
        Vec3::ZERO,
        Vec3::Z,
        true,
        1,
    )
    .unwrap();
    let mut tp = Toolpath::new(Vec3::ZERO);
    tp.push_move(Move::rapid(
        Line::new(Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)),
        1,
    ));
    tp.push_event(crate::path::Event {
        line: 2,
        kind: crate::path::EventKind::Dwell(0.25),
        text: "G4 P0.25".into(),
    });
    tp.push_move(Move::feed(arc, Some(20.0), 3));
    let p = PlanOptions {
        rapid_mm_s: Some(100.0),
        ..Default::default()
    };
    let (rep, r) = run(&tp, &p, &InterpOptions::default());
    check_invariants(&tp, &rep, &r);
    assert_limits(&rep);
    assert_eq!(rep.exact_stops.dwell, 1);
    // The feed never exceeds the programmed F on the helix.
    let rest = r.iter().filter(|row| row[4] == 0.0).count();
    assert!(rest as f64 >= 0.25 / p.period_s - 1.0);
    assert!(r.iter().all(|row| row[4] <= 100.0 + 1e-6));
}

#[test]
fn empty_program_is_one_row() {
    let tp = Toolpath::new(Vec3::new(1.0, 2.0, 3.0));
    let (rep, r) = run(&tp, &PlanOptions::default(), &InterpOptions::default());
    assert_eq!(r.len(), 1);
    assert_eq!(r[0][1..4], [1.0, 2.0, 3.0]);
    assert_eq!(rep.cycle_time_s, 0.0);
}

#[test]
fn junction_deviation_blends_corners() {
    let tp = Toolpath::from_polyline(
        &[
            Vec3::ZERO,
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
        ],
        None,
    );
    let stop = run(&tp, &PlanOptions::default(), &InterpOptions::default()).0;
    let p = PlanOptions {
        junction_dev_mm: Some(0.01),
        ..Default::default()
    };
    let (blend, r) = run(&tp, &p, &InterpOptions::default());
    check_invariants(&tp, &blend, &r);
    assert_eq!(stop.exact_stops.corner, 1);
    assert_eq!(blend.exact_stops.corner, 0);
    assert_eq!(blend.exact_stops.junction_blended, 1);
    assert!(blend.cycle_time_s < stop.cycle_time_s);
}

/// A polyline with its corners replaced by tangent cubic Bézier blends (G1 joints),
/// standing in for a smoothed path.
fn blended(points: &[Vec3], d: f64) -> Toolpath {
    let mut tp = Toolpath::new(points[0]);
    let mut from = points[0];
    for i in 1..points.len() - 1 {
        let (a, b, c) = (points[i - 1], points[i], points[i + 1]);
        let (Some(u1), Some(u2)) = ((b - a).normalized(), (c - b).normalized()) else {
            continue;
        };
        // Reversals stay sharp corners (a blend would have a cusp inside).
        if u1.dot(u2) < -0.98 {
            continue;
        }
        let dd = d.min(0.4 * a.dist(b)).min(0.4 * b.dist(c));
        let p0 = b - u1 * dd;
        let p3 = b + u2 * dd;
        if from.dist(p0) > 1e-9 {
            tp.push_move(Move::feed(Line::new(from, p0), None, i as u32));
        }
        tp.push_move(Move::feed(
            CubicBez::new(p0, b - u1 * (dd / 3.0), b + u2 * (dd / 3.0), p3),
            None,
            i as u32,
        ));
        from = p3;
    }
    tp.push_move(Move::feed(
        Line::new(from, points[points.len() - 1]),
        None,
        points.len() as u32,
    ));
    tp
}

fn point() -> impl Strategy<Value = Vec3> {
    (-50.0f64..50.0, -50.0f64..50.0, -5.0f64..5.0).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// Random polylines with degenerate features mixed in: repeated points, 1 um steps,
/// reversals and near-collinear points.
fn polyline() -> impl Strategy<Value = Vec<Vec3>> {
    prop::collection::vec((point(), 0u8..6), 2..25).prop_map(|v| {
        let mut out: Vec<Vec3> = Vec::new();
        for (p, kind) in v {
            let last = out.last().copied();
            match (kind, last) {
                (0, Some(l)) => out.push(l),
                (1, Some(l)) => out.push(l + Vec3::new(1e-3, 0.0, 0.0)),
                (2, Some(l)) if out.len() >= 2 => out.push(out[out.len() - 2] * 0.5 + l * 0.5),
                (3, Some(l)) => out.push(l + (p - l) * 1e-3 + Vec3::new(0.0, 1e-6, 0.0)),
                _ => out.push(p),
            }
        }
        out
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn raw_paths_hold_limits(pts in polyline(), feed in 5.0f64..120.0, acc in 100.0f64..3000.0) {
        let tp = Toolpath::from_polyline(&pts, None);
        let p = PlanOptions { feed_mm_s: feed, acc_mm_s2: [acc, acc * 0.7, acc * 0.5], ..Default::default() };
        let (rep, r) = run(&tp, &p, &InterpOptions::default());
        check_invariants(&tp, &rep, &r);
        assert_limits(&rep);
        assert_plan_covers(&tp, &p);
    }

    #[test]
    fn blended_paths_hold_limits(pts in polyline(), d in 0.05f64..3.0, feed in 5.0f64..120.0) {
        let tp = blended(&pts, d);
        let p = PlanOptions { feed_mm_s: feed, vaxis_mm_s: Some([feed, feed * 0.8, feed * 0.3]), period_s: 0.002, ..Default::default() };
        let (rep, r) = run(&tp, &p, &InterpOptions::default());
        check_invariants(&tp, &rep, &r);
        assert_limits(&rep);
        assert_plan_covers(&tp, &p);
    }
}

#[test]
fn curved_move_between_two_stops_is_travelled() {
    // A 0.8 um straight Bezier blend between a line and a corner (shrunk from a property
    // failure): its interval ends are both at rest, so it needs a grid point inside.
    let pts = [
        Vec3::new(11.682009124806093, 0.0, 0.0),
        Vec3::new(-49.699533251729356, 0.0, 0.0),
        Vec3::new(-49.69853325172936, 0.0, 0.0),
        Vec3::new(-49.69753325172936, 0.0, 0.0),
        Vec3::new(-49.69753325172936, 0.0, 0.0),
        Vec3::new(-49.64783571847763, 1e-6, -0.0015512097141885657),
    ];
    let tp = blended(&pts, 0.05);
    let p = PlanOptions {
        feed_mm_s: 5.0,
        period_s: 0.002,
        ..Default::default()
    };
    assert_plan_covers(&tp, &p);
    let (rep, r) = run(&tp, &p, &InterpOptions::default());
    check_invariants(&tp, &rep, &r);
    assert_limits(&rep);
}

/// Jerk mode: every axis within acceleration and jerk (the report's rule: the limit plus
/// the finite-difference noise of the printed positions).
fn assert_jerk_limits(rep: &PlanReport) {
    assert_limits(rep);
    for a in &rep.axes {
        assert!(a.j_within, "{a:?}");
        assert!(a.j_limit_mm_s3.is_some());
    }
    assert!(rep.limits_held);
}

#[test]
fn jerk_line_is_the_averaged_trapezoid() {
    // 100 mm along X: no curve anywhere, so the plan is a trapezoid at the line limit
    // (`line_u_max`, point 6 of feed::jerk); the setpoints follow its moving average over
    // W, resting W at the end.
    let tp = Toolpath::from_polyline(&[Vec3::ZERO, Vec3::new(100.0, 0.0, 0.0)], None);
    let p = PlanOptions {
        jerk_mm_s3: Some([5000.0; 3]),
        ..Default::default()
    };
    let (rep, r) = run(&tp, &p, &InterpOptions::default());
    check_invariants(&tp, &rep, &r);
    assert_jerk_limits(&rep);
    // The run chose the split (the fastest candidate for the path) and reports it.
    assert!(rep.options.jerk_split.is_some());
    let jc = rep.options.jerk_caps().unwrap();
    // The duration the choice was made by is the cycle time.
    let planned = crate::feed::jerk::planned_duration(&tp, &rep.options);
    assert!(
        (planned - rep.cycle_time_s).abs() <= p.period_s + 1e-9,
        "{planned}"
    );
    let u = jc.line_u_max(&p.acc_mm_s2.map(|a| crate::feed::planned_acc(a, p.period_s)));
    assert!(u > jc.u_max_mm_s2, "{u} {jc:?}");
    let plan = 100.0 / 50.0 + 50.0 / u;
    let expect = ((plan + jc.window_s) / p.period_s - 1e-9).ceil() * p.period_s;
    assert!(
        (rep.cycle_time_s - expect).abs() <= p.period_s + 1e-9,
        "{}",
        rep.cycle_time_s
    );
    // The S-curve: the acceleration ramps at u / W (the box filter of a step in u) up to
    // u, or to 50 / W when the plan's ramp to 50 mm/s is shorter than the window.
    let x = &rep.axes[0];
    let a_peak = u.min(50.0 / jc.window_s);
    assert!((x.a_max_mm_s2 - a_peak).abs() < 1.0, "{x:?} {u} {jc:?}");
    let ramp = u / jc.window_s;
    assert!((x.j_max_mm_s3 - ramp).abs() < 0.02 * ramp, "{x:?}");
    // The trapezoid on the same line jumps in acceleration: its jerk is far above.
    let (trap, _) = run(&tp, &PlanOptions::default(), &InterpOptions::default());
    assert!(trap.axes[0].j_max_mm_s3 > 20.0 * 5000.0);
    assert!(trap.axes[0].j_within && trap.axes[0].j_limit_mm_s3.is_none());
}

#[test]
fn jerk_butterfly_wu_setting() {
    let tp = butterfly_path();
    let p = PlanOptions {
        period_s: 0.002,
        jerk_mm_s3: Some([5000.0, 4000.0, 5000.0]),
        ..Default::default()
    };
    let (rep, r) = run(&tp, &p, &InterpOptions::default());
    check_invariants(&tp, &rep, &r);
    assert_jerk_limits(&rep);
    assert!(rep.interp.eta_max <= 0.001);
    for a in &rep.axes {
        assert!(a.a_ratio <= 1.01 && a.j_ratio.unwrap() <= 1.01, "{a:?}");
    }
}

/// A path built by heading and turns: lines and tangent arcs in the XY plane.
struct Turtle {
    tp: Toolpath,
    at: Vec3,
    heading: f64,
    feed_mm_s: f64,
}

impl Turtle {
    fn new(start: Vec3, feed_mm_s: f64) -> Turtle {
        Turtle {
            tp: Toolpath::new(start),
            at: start,
            heading: 0.0,
            feed_mm_s,
        }
    }
    fn push(&mut self, seg: Segment, end: Vec3) {
        let line = self.tp.moves().count() as u32 + 1;
        self.tp
            .push_move(Move::feed(seg, Some(self.feed_mm_s), line));
        self.at = end;
    }
    fn line(&mut self, len: f64) {
        let end = self.at + Vec3::new(self.heading.cos(), self.heading.sin(), 0.0) * len;
        self.push(Line::new(self.at, end).into(), end);
    }
    /// An arc of `len` mm turning left (`curvature > 0`) or right.
    fn arc(&mut self, curvature: f64, len: f64) {
        let r = 1.0 / curvature.abs();
        let side = curvature.signum();
        let normal = Vec3::new(-self.heading.sin(), self.heading.cos(), 0.0) * side;
        let center = self.at + normal * r;
        self.heading += len * curvature;
        let end_normal = Vec3::new(-self.heading.sin(), self.heading.cos(), 0.0) * side;
        let end = center - end_normal * r;
        let arc = Arc::from_center(self.at, end, center, Vec3::Z, side > 0.0, 0).unwrap();
        self.push(arc.into(), end);
    }
    /// Two short arcs (curvature `k1` then `k2`, `arc_mm` each) with a 0.001 mm line
    /// between them: with 0.009 mm arcs, the shape of two blends on linuxcnc_51MeanderAve.
    fn s_bend(&mut self, k1: f64, k2: f64, arc_mm: f64) {
        self.arc(k1, arc_mm);
        self.line(0.001);
        self.arc(k2, arc_mm);
    }
}

/// An S-bend (curvature 1.25 then -3.6 /mm) between two lines; the lead-in line is
/// `lead_mm` long (it sets where the joints fall between setpoints).
fn s_bend(feed_mm_s: f64, lead_mm: f64) -> Toolpath {
    let mut t = Turtle::new(Vec3::new(-lead_mm, 0.0, 0.0), feed_mm_s);
    t.line(lead_mm);
    t.s_bend(1.25, -3.6, 0.009);
    t.line(2.0);
    t.tp
}

#[test]
fn jerk_close_curvature_steps_add_up() {
    // The two steps in y at the ends of the 0.001 mm line (-1.25 and -3.6 /mm) fall into
    // one third difference at these speeds: each alone allows about 1.36 mm/s at 5000
    // mm/s^3, together they must not. Without the combined cap, the worst of these
    // phases reads 5200 mm/s^3 or more at 1.32 mm/s.
    let mut worst: f64 = 0.0;
    for (feed, k) in [1.2, 1.32, 5.0]
        .into_iter()
        .flat_map(|f| (0..12).map(move |k| (f, k)))
    {
        let tp = s_bend(feed, 2.0 + k as f64 * 1.1e-4);
        let p = PlanOptions {
            acc_mm_s2: [500.0; 3],
            jerk_mm_s3: Some([5000.0; 3]),
            ..Default::default()
        };
        let (rep, r) = run(&tp, &p, &InterpOptions::default());
        check_invariants(&tp, &rep, &r);
        assert_eq!(rep.exact_stops.corner, 0, "feed {feed}");
        assert_jerk_limits(&rep);
        worst = worst.max(rep.axes[1].j_max_mm_s3);
    }
    // The bend is still taken at a good share of the limit (the summed steps are a bound:
    // both weights are never 0.75 at once; measured 0.73 of the limit at worst).
    assert!(worst > 0.6 * 5000.0, "{worst}");
}

#[test]
fn jerk_kinks_below_the_tangent_tolerance_hold() {
    // Diagonal lines with a 0.009 degree kink (passed as tangent, no stop) while the
    // feed ramps up to 100 mm/s: the velocity jumps by v |kink| between two setpoints,
    // which the joint's speed cap allows for (without it: y jerk 6248 mm/s^3 at lead 11).
    // The kink also counts as a curved point for the lines' tangential limit (on
    // linuxcnc_LHchips4, bspline, a 0.006 degree kink on a line ramping at the full
    // line jerk read 5051 mm/s^3 at 5000).
    let theta = 0.009_f64.to_radians();
    for lead in [11.0, 12.5, 14.0, 16.0] {
        let d1 = Vec3::new(1.0, 1.0, 0.0) * std::f64::consts::FRAC_1_SQRT_2;
        let a = std::f64::consts::FRAC_PI_4 + theta;
        let d2 = Vec3::new(a.cos(), a.sin(), 0.0);
        let p1 = d1 * lead;
        let tp = Toolpath::from_polyline(&[Vec3::ZERO, p1, p1 + d2 * 60.0], None);
        let p = PlanOptions {
            feed_mm_s: 100.0,
            jerk_mm_s3: Some([5000.0; 3]),
            ..Default::default()
        };
        let (rep, r) = run(&tp, &p, &InterpOptions::default());
        check_invariants(&tp, &rep, &r);
        assert_eq!(rep.exact_stops.corner, 0);
        assert_jerk_limits(&rep);
    }
}

#[test]
fn jerk_close_kinks_add_up() {
    // A zig-zag of alternating +-0.009 degree kinks (passed as tangent) about a period
    // apart at the speed each kink's own cap allows: one third difference sees two of
    // opposite sign, twice one kink's share (without grouping them: 9877 mm/s^3 at 5000).
    let theta = 0.009_f64.to_radians();
    for seg in [0.026, 0.029, 0.0315, 0.034] {
        let mut pts = vec![Vec3::ZERO, Vec3::new(5.0, 0.0, 0.0)];
        let mut at = pts[1];
        for k in 0..400 {
            let h = if k % 2 == 0 {
                0.5 * theta
            } else {
                -0.5 * theta
            };
            at += Vec3::new(h.cos(), h.sin(), 0.0) * seg;
            pts.push(at);
        }
        pts.push(at + Vec3::new(5.0, 0.0, 0.0));
        let tp = Toolpath::from_polyline(&pts, None);
        let p = PlanOptions {
            jerk_mm_s3: Some([5000.0; 3]),
            jerk_split: Some(crate::feed::jerk::JerkSplit::DEFAULT),
            ..Default::default()
        };
        let (rep, r) = run(&tp, &p, &InterpOptions::default());
        check_invariants(&tp, &rep, &r);
        assert_eq!(rep.exact_stops.corner, 0);
        assert_jerk_limits(&rep);
    }
}

#[test]
fn jerk_close_joints_leave_blended_corners_alone() {
    // A 0.002 mm arc just before a corner blended under the junction deviation: the
    // corner is a velocity jump the plan reports, not a joint to group with the arc's
    // curvature steps (grouped, its cap fell from v = 12.6 to 0.008 mm/s).
    let corner_cap = |with_arc: bool| {
        let mut t = Turtle::new(Vec3::ZERO, 50.0);
        t.line(5.0);
        if with_arc {
            t.arc(2.0, 0.002);
        }
        t.heading += 0.5;
        t.line(5.0);
        let p = PlanOptions {
            jerk_mm_s3: Some([5000.0; 3]),
            jerk_split: Some(crate::feed::jerk::JerkSplit::DEFAULT),
            junction_dev_mm: Some(0.01),
            ..Default::default()
        };
        let (rep, r) = run(&t.tp, &p, &InterpOptions::default());
        check_invariants(&t.tp, &rep, &r);
        assert_eq!(rep.exact_stops.junction_blended, 1);
        let idx = crate::feed::PathIndex::new(&t.tp, &p);
        let caps: Vec<f64> = idx
            .moves
            .iter()
            .filter_map(|m| match m.after {
                crate::feed::grid::After::Continue {
                    x_cap,
                    blended: true,
                } => Some(x_cap),
                _ => None,
            })
            .collect();
        assert_eq!(caps.len(), 1);
        caps[0]
    };
    let (plain, with_arc) = (corner_cap(false), corner_cap(true));
    // The arc turns the path by 0.004 rad before the corner: nearly the same cap.
    assert!(plain > 100.0, "{plain}");
    assert!(
        (with_arc - plain).abs() < 0.01 * plain,
        "{with_arc} vs {plain}"
    );
}

#[test]
fn jerk_stops_hold_the_corner() {
    // A square corner: the filtered motion comes to rest at the corner (a setpoint exactly
    // there) and the jerk holds on both sides.
    let c = Vec3::new(10.0, 0.0, 0.0);
    let tp = Toolpath::from_polyline(&[Vec3::ZERO, c, Vec3::new(10.0, 10.0, 0.0)], None);
    let p = PlanOptions {
        jerk_mm_s3: Some([2000.0; 3]),
        ..Default::default()
    };
    let (rep, r) = run(&tp, &p, &InterpOptions::default());
    check_invariants(&tp, &rep, &r);
    assert_jerk_limits(&rep);
    assert_eq!(rep.exact_stops.corner, 1);
    assert!(r
        .iter()
        .any(|row| Vec3::new(row[1], row[2], row[3]).dist(c) == 0.0));
    // Off the two lines nothing is ever commanded (no corner cutting).
    for row in &r {
        assert!(
            row[2].abs() < 1e-9 || (row[1] - 10.0).abs() < 1e-9,
            "{row:?}"
        );
    }
}

#[test]
fn line_cuts_are_ordered_and_fine_at_the_ends() {
    for len in [1e-3, 0.01, 0.7, 3.0, 100.0] {
        let c = crate::feed::jerk::line_cuts(len);
        assert!(c.windows(2).all(|w| w[1] > w[0]), "{len}: {c:?}");
        assert!(c.iter().all(|&x| x > 0.0 && x < len));
        let mut all = vec![0.0];
        all.extend(&c);
        all.push(len);
        for w in all.windows(2) {
            assert!(w[1] - w[0] <= crate::feed::grid::MAX_CURVE_DS_MM + 1e-12);
        }
        if len > 0.1 {
            assert!(
                c[0] <= 1.5e-3 && len - c[c.len() - 1] <= 1.5e-3,
                "{len}: {c:?}"
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]

    #[test]
    fn jerk_raw_paths_hold_limits(pts in polyline(), feed in 5.0f64..120.0, acc in 100.0f64..3000.0, jerk in 500.0f64..50000.0) {
        let tp = Toolpath::from_polyline(&pts, None);
        let p = PlanOptions { feed_mm_s: feed, acc_mm_s2: [acc, acc * 0.7, acc * 0.5], jerk_mm_s3: Some([jerk, jerk * 0.6, jerk * 2.0]), ..Default::default() };
        let (rep, r) = run(&tp, &p, &InterpOptions::default());
        check_invariants(&tp, &rep, &r);
        assert_jerk_limits(&rep);
    }

    #[test]
    fn jerk_blended_paths_hold_limits(pts in polyline(), d in 0.05f64..3.0, feed in 5.0f64..120.0, jerk in 1000.0f64..20000.0, period in prop::sample::select(vec![0.001, 0.002])) {
        let tp = blended(&pts, d);
        let p = PlanOptions { feed_mm_s: feed, vaxis_mm_s: Some([feed, feed * 0.8, feed * 0.3]), period_s: period, jerk_mm_s3: Some([jerk; 3]), ..Default::default() };
        let (rep, r) = run(&tp, &p, &InterpOptions::default());
        check_invariants(&tp, &rep, &r);
        assert_jerk_limits(&rep);
    }
}

#[test]
fn jerk_micro_segments_do_not_oscillate() {
    // 20000 collinear 0.01 mm segments (several planning windows): with jerk limiting the
    // planned feed rises once, cruises and falls once, like one 200 mm line.
    let pts: Vec<Vec3> = (0..=20000)
        .map(|i| Vec3::new(i as f64 * 0.01, 0.0, 0.0))
        .collect();
    let tp = Toolpath::from_polyline(&pts, None);
    let p = PlanOptions {
        jerk_mm_s3: Some([5000.0; 3]),
        ..Default::default()
    };
    let (rep, r) = run(&tp, &p, &InterpOptions::default());
    check_invariants(&tp, &rep, &r);
    assert_jerk_limits(&rep);
    assert!(rep.planning.windows > 1);
    let one = Toolpath::from_polyline(&[Vec3::ZERO, Vec3::new(200.0, 0.0, 0.0)], None);
    let (single, _) = run(&one, &p, &InterpOptions::default());
    assert!((rep.cycle_time_s - single.cycle_time_s).abs() <= p.period_s + 1e-9);
    let mut falling = false;
    for w in r.windows(2) {
        let (f0, f1) = (w[0][4], w[1][4]);
        if f1 < f0 - 1e-6 {
            falling = true;
        }
        assert!(
            !falling || f1 <= f0 + 1e-6,
            "feed rises after falling: {w:?}"
        );
    }
}

/// A slicer's extruder: `G92 E0` resets are offsets (the `e` column, in machine
/// coordinates, stays continuous), E-only moves take their time with X, Y, Z at rest,
/// and the report measures the column, in trapezoid and jerk mode.
#[test]
fn extruder_moves_and_resets() {
    // G92 E0 / G1 X10 Y0 E5 F1200 / G1 E3 F1800 / G92 E0 / G1 E2 / G1 X10 Y10 E3 F1200
    use crate::path::{Event, EventKind};
    let e = |v: f64| [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, v];
    let mut tp = Toolpath::new(Vec3::ZERO);
    tp.extra_axes_mask = 1 << 6;
    let event = |line, kind, text: &str| Event {
        line,
        kind,
        text: text.into(),
    };
    tp.push_event(event(1, EventKind::ExtraReset { to: e(0.0) }, "G92 E0"));
    let mut m = Move::feed(
        Line::new(Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)),
        Some(20.0),
        2,
    );
    m.extra = Some(e(5.0));
    tp.push_move(m);
    let retract = EventKind::ExtraMove {
        to: e(3.0),
        feed_per_s: Some(30.0),
    };
    tp.push_event(event(3, retract, "G1 E3 F1800"));
    tp.push_event(event(4, EventKind::ExtraReset { to: e(0.0) }, "G92 E0"));
    let unretract = EventKind::ExtraMove {
        to: e(2.0),
        feed_per_s: Some(30.0),
    };
    tp.push_event(event(5, unretract, "G1 E2"));
    let mut m = Move::feed(
        Line::new(Vec3::new(10.0, 0.0, 0.0), Vec3::new(10.0, 10.0, 0.0)),
        Some(20.0),
        6,
    );
    m.extra = Some(e(3.0));
    tp.push_move(m);
    for jerk in [None, Some([5000.0; 3])] {
        let p = PlanOptions {
            jerk_mm_s3: jerk,
            ..Default::default()
        };
        let (rep, out) = execute(&tp, &p, &InterpOptions::default(), Vec::new()).unwrap();
        let text = String::from_utf8(out).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("t,x,y,z,feed,e"));
        let r: Vec<[f64; 6]> = lines
            .map(|l| {
                let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
                [v[0], v[1], v[2], v[3], v[4], v[5]]
            })
            .collect();
        // Machine E: 5 after the first line, 3 after the retract, the reset to 0 moves
        // nothing, the unretract to (programmed) 2 is machine 5, the last line ends at 6.
        let last = r.last().unwrap();
        assert!((last[5] - 6.0).abs() < 1e-9, "{last:?}");
        // Continuous: no step larger than the fastest rate (30 mm/s) allows.
        for w in r.windows(2) {
            assert!(
                (w[1][5] - w[0][5]).abs() <= 30.0 * p.period_s + 1e-9,
                "{w:?}"
            );
        }
        // The retract and unretract happen at rest at (10, 0): E goes 5 -> 3 -> 5 there.
        let at_corner: Vec<&[f64; 6]> = r
            .iter()
            .filter(|row| row[1] == 10.0 && row[2] == 0.0)
            .collect();
        let e_min = at_corner
            .iter()
            .map(|row| row[5])
            .fold(f64::INFINITY, f64::min);
        // (The turn-around at 3 falls between two rows: within a T^2 / 2 of it.)
        assert!((e_min - 3.0).abs() <= 500.0 * p.period_s.powi(2), "{e_min}");
        // Each takes a trapezoid over 2 mm at 30 mm/s and the smallest axis acceleration:
        // 2/30 + 30/500 s.
        let moving = at_corner.windows(2).filter(|w| w[0][5] != w[1][5]).count();
        let expect = 2.0 * (2.0 / 30.0 + 30.0 / 500.0) / p.period_s;
        assert!(
            (moving as f64 - expect).abs() <= 4.0,
            "{moving} vs {expect}"
        );
        assert_eq!(rep.extra_axes.len(), 1);
        let e = &rep.extra_axes[0];
        assert_eq!(e.axis, 'e');
        assert!((e.v_max_per_s - 30.0).abs() < 0.1, "{e:?}");
    }
}

/// With nothing setting E before it (no `G92 E0`: E counts from 0), the first extruding
/// line extrudes along its length, and a first prime in place moves E from 0 (E sat at
/// the line's end value from the first row, and the prime planned no motion).
#[test]
fn extrusion_with_nothing_before_it_starts_at_zero() {
    use crate::path::{Event, EventKind};
    let e = |v: f64| [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, v];
    for prime in [false, true] {
        let mut tp = Toolpath::new(Vec3::ZERO);
        tp.extra_axes_mask = 1 << 6;
        if prime {
            let kind = EventKind::ExtraMove {
                to: e(1.0),
                feed_per_s: Some(30.0),
            };
            tp.push_event(Event {
                line: 1,
                kind,
                text: "G1 E1".into(),
            });
        }
        let mut m = Move::feed(
            Line::new(Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)),
            Some(20.0),
            2,
        );
        m.extra = Some(e(if prime { 6.0 } else { 5.0 }));
        tp.push_move(m);
        let (_, out) = execute(
            &tp,
            &PlanOptions::default(),
            &InterpOptions::default(),
            Vec::new(),
        )
        .unwrap();
        let text = String::from_utf8(out).unwrap();
        let rows: Vec<Vec<f64>> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
            .collect();
        let first = &rows[0];
        let last = rows.last().unwrap();
        assert_eq!(first[5], 0.0, "prime {prime}: {first:?}");
        assert!((last[5] - if prime { 6.0 } else { 5.0 }).abs() < 1e-9);
        // Along the line, E is 0.5 per mm of X (after the prime's 1).
        let base = if prime { 1.0 } else { 0.0 };
        for r in rows.iter().filter(|r| r[1] > 0.0) {
            assert!(
                (r[5] - base - 0.5 * r[1]).abs() < 1e-6,
                "prime {prime}: {r:?}"
            );
        }
    }
}

/// A sink that fails once it has taken `room` bytes.
struct FailingSink {
    room: usize,
}

impl std::io::Write for FailingSink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if buf.len() > self.room {
            return Err(std::io::Error::other("disk full"));
        }
        self.room -= buf.len();
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn a_failed_write_ends_the_run_with_its_error() {
    // 200 mm at 50 mm/s: 4000+ setpoints, several batches; the sink fails after about
    // 100 rows, mid-run. The writing thread stops, the emitter and the planner notice,
    // and the error comes back (no hang, no panic).
    let tp = Toolpath::from_polyline(&[Vec3::ZERO, Vec3::new(200.0, 0.0, 0.0)], None);
    let res = execute(
        &tp,
        &PlanOptions::default(),
        &InterpOptions::default(),
        std::io::BufWriter::with_capacity(64, FailingSink { room: 5000 }),
    );
    match res {
        Err(PlanError::Io(e)) => assert_eq!(e.to_string(), "disk full"),
        other => panic!("expected the write error, got {:?}", other.map(|r| r.0)),
    }
}

#[test]
fn step_arclen_matches_adaptive_quadrature() {
    // Steps of a tight cubic (a cusp-like bend and a zero-speed start) against adaptive
    // quadrature to 1e-14 mm: within the step accuracy everywhere.
    let c = crate::geom::tight_cubic();
    let n = 400;
    for i in 0..n {
        let (a, b) = (i as f64 / n as f64, (i + 1) as f64 / n as f64);
        let got = step_arclen(&c, a, b);
        let want = arclen_adaptive(&c, a, b, 1e-14);
        assert!(
            (got - want).abs() <= 2.0 * STEP_ARCLEN_ACCURACY_MM,
            "step {i}: {got} vs {want}"
        );
    }
}

/// Steps the single move of `idx` (whose segment is `seg`) as `seg` and as `fast`, an
/// equivalent [`StepCurve`], with and without the arc-length correction, under steps of
/// varying length (`len(k)`, as under a changing feed) up to `u = 0.95`: the points, arc
/// lengths and statistics must be the same bit for bit. Returns the statistics of each
/// run (with the correction, then without).
fn assert_steps_match<C: StepCurve>(
    idx: &crate::feed::PathIndex,
    seg: &Segment,
    fast_curve: &C,
    len: impl Fn(usize) -> f64,
) -> Vec<InterpStats> {
    let mut stats = Vec::new();
    for arc_correction in [true, false] {
        let opts = InterpOptions {
            arc_correction,
            ..InterpOptions::default()
        };
        let mut plain = Interpolator::new(idx, opts);
        let mut fast = Interpolator::new(idx, opts);
        let mut steps = 0;
        while fast.u < 0.95 {
            plain.step_curve(seg, len(steps));
            fast.step_curve(fast_curve, len(steps));
            assert_eq!((fast.u, fast.s, fast.p), (plain.u, plain.s, plain.p));
            steps += 1;
        }
        assert!(steps > 50, "{steps} steps");
        assert_eq!(fast.stats, plain.stats);
        stats.push(fast.stats);
    }
    stats
}

#[test]
fn prepared_trig_steps_are_the_plain_steps() {
    // The interpolator steps a trigonometric spline through `PreparedTrig`, evaluating
    // `ders` at every point it tries and carrying them to the next step; stepping the
    // plain segment (point and derivatives apart, nothing carried) must give the same
    // points and arc lengths bit for bit, with and without the arc-length correction.
    use crate::geom::TrigSpline;
    let c = TrigSpline::hermite(
        Vec3::new(1.0, 2.0, 0.5),
        Vec3::new(4.0, 3.0, 0.0),
        Vec3::new(6.0, -1.0, 0.2),
        Vec3::new(0.5, 5.0, -0.3),
        0.8,
    );
    let mut tp = Toolpath::new(c.q0);
    tp.push_move(Move::feed(c, None, 1));
    let idx = crate::feed::PathIndex::new(&tp, &PlanOptions::default());
    assert_steps_match(&idx, &Segment::Trig(c), &PreparedTrig::new(&c), |k| {
        0.01 + 0.04 * ((k as f64) * 0.37).sin().abs()
    });
}

#[test]
fn cubic_steps_are_the_segment_steps() {
    // A cubic Bezier move is stepped as a `CubicBez` (inlined evaluation, derivatives
    // carried from step to step); stepping it as a `Segment` must give the same points
    // and arc lengths bit for bit, with and without the arc-length correction.
    let c = CubicBez::new(
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.1, 0.2, 0.0),
        Vec3::new(0.3, -0.1, 0.05),
        Vec3::new(0.4, 0.1, 0.0),
    );
    let mut tp = Toolpath::new(c.p0);
    tp.push_move(Move::feed(c, None, 1));
    let idx = crate::feed::PathIndex::new(&tp, &PlanOptions::default());
    let stats = assert_steps_match(&idx, &Segment::CubicBez(c), &c, |k| {
        0.001 + 0.005 * ((k as f64) * 0.37).sin().abs()
    });
    // The correction ran (and so was compared) on the corrected run.
    assert!(stats[0].arc_corrections > 0);
}

/// Largest finite-difference speed, acceleration and jerk per axis of parsed setpoint
/// rows, on their own time column (independent of the report's meter).
fn fd_maxima(r: &[[f64; 5]]) -> [[f64; 3]; 3] {
    let mut m = [[0.0f64; 3]; 3];
    let vel = |a: &[f64; 5], b: &[f64; 5], i: usize| (b[i + 1] - a[i + 1]) / (b[0] - a[0]);
    for i in 0..3 {
        for w in r.windows(2) {
            m[0][i] = m[0][i].max(vel(&w[0], &w[1], i).abs());
        }
        let acc: Vec<(f64, f64)> = r
            .windows(3)
            .map(|w| {
                let a = (vel(&w[1], &w[2], i) - vel(&w[0], &w[1], i)) * 2.0 / (w[2][0] - w[0][0]);
                (w[1][0], a)
            })
            .collect();
        for &(_, a) in &acc {
            m[1][i] = m[1][i].max(a.abs());
        }
        for w in acc.windows(2) {
            m[2][i] = m[2][i].max(((w[1].1 - w[0].1) / (w[1].0 - w[0].0)).abs());
        }
    }
    m
}

/// A jerk limit far below what setpoints printed to 1e-9 mm show at 1 ms (one print unit
/// of third difference is 1 mm/s^3) was planned at half its value and measured at 3 to 4
/// times it while the report said the limits held. It is refused now, with the smallest
/// limit held; at a period that resolves it, it is held.
#[test]
fn tiny_jerk_is_refused_or_held() {
    let tp = Toolpath::from_polyline(
        &[
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
        ],
        Some(10.0),
    );
    let mut p = PlanOptions {
        jerk_mm_s3: Some([1.0; 3]),
        ..Default::default()
    };
    match execute(&tp, &p, &InterpOptions::default(), Vec::new()) {
        Err(PlanError::Options(crate::feed::PlanOptionsError::Unresolvable {
            name, min, ..
        })) => {
            assert_eq!(name, "jerk");
            assert!(min > 1.0 && min < 20.0, "{min}");
        }
        Err(e) => panic!("{e}"),
        Ok((rep, out)) => {
            let m = fd_maxima(&rows(&out));
            panic!(
                "planned, jerk measured {:?} for a limit of 1 ({rep:?})",
                m[2]
            );
        }
    }
    p.period_s = 0.005;
    let (rep, r) = run(&tp, &p, &InterpOptions::default());
    check_invariants(&tp, &rep, &r);
    let m = fd_maxima(&r);
    assert!(m[2].iter().all(|&j| j <= 1.0), "{m:?}");
    assert!(rep.limits_held);
}

/// A window far below the period (tiny acceleration, large jerk: W = 2e-8 s, T = 3 ms,
/// some 100 s into the motion): the moving average integrated each stretch from its
/// start time, and `b^3 - a^3` of two times 2e-8 s apart lost the digits the window
/// needs (Z acceleration measured 7.5e-3 for a limit of 1.55e-3; shrunk from
/// [`limits_across_scales_are_held_or_refused`]).
#[test]
fn jerk_filter_with_a_window_far_below_the_period() {
    let tp = Toolpath::from_polyline(&[Vec3::ZERO, Vec3::new(0.0, 0.0, 0.2320925734926941)], None);
    let (a, j) = (0.0011951242828107098, 33203.11529050823);
    let p = PlanOptions {
        feed_mm_s: 1.0,
        acc_mm_s2: [a, a * 0.7, a * 1.3],
        jerk_mm_s3: Some([j, j * 1.5, j * 0.8]),
        period_s: 0.00316,
        ..Default::default()
    };
    let jc = p.jerk_caps().unwrap();
    assert!(jc.window_s < 1e-5 * p.period_s, "{jc:?}");
    let (rep, r) = run(&tp, &p, &InterpOptions::default());
    check_invariants(&tp, &rep, &r);
    let m = fd_maxima(&r);
    assert!(m[1][2] <= p.acc_mm_s2[2], "{m:?}");
    assert!(m[2][2] <= j * 0.8, "{m:?}");
    assert!(rep.limits_held);
}

/// Log-uniform values in `[lo, hi]`.
fn log_uniform(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    (lo.ln()..hi.ln()).prop_map(f64::exp)
}

/// Periods tried in turn by [`limits_across_scales_are_held_or_refused`] (s).
const SCALE_PERIODS: [f64; 5] = [0.001, 0.00316, 0.01, 0.0316, 0.1];

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]

    /// Acceleration and jerk limits from 1e-3 to 1e6 on short raw and blended paths: at
    /// each period of [`SCALE_PERIODS`] the options are either refused as too small for
    /// the printed setpoints to show (only within a small factor of one print unit per
    /// `T^k`), or planned, and then the finite differences of the printed setpoints hold
    /// every limit without allowance. Each case is planned at the first period that
    /// accepts it, and the last one accepts every case.
    #[test]
    fn limits_across_scales_are_held_or_refused(
        pts in prop::collection::vec((-3.0f64..3.0, -3.0f64..3.0, -0.5f64..0.5), 2..5),
        blend in any::<bool>(),
        acc in log_uniform(1e-3, 1e6),
        jerk in prop::option::of(log_uniform(1e-3, 1e6)),
        feed in log_uniform(0.5, 100.0),
    ) {
        let pts: Vec<Vec3> = pts.into_iter().map(|(x, y, z)| Vec3::new(x, y, z)).collect();
        let tp = if blend { blended(&pts, 0.5) } else { Toolpath::from_polyline(&pts, None) };
        let mut planned = false;
        for period in SCALE_PERIODS {
            let p = PlanOptions {
                feed_mm_s: feed,
                acc_mm_s2: [acc, acc * 0.7, acc * 1.3],
                jerk_mm_s3: jerk.map(|j| [j, j * 1.5, j * 0.8]),
                period_s: period,
                ..Default::default()
            };
            let (rep, out) = match execute(&tp, &p, &InterpOptions::default(), Vec::new()) {
                Err(PlanError::Options(crate::feed::PlanOptionsError::Unresolvable {
                    value, min, order, ..
                })) => {
                    prop_assert!(value < min);
                    // Refused only near the print resolution: 1e-9 mm per T^k.
                    prop_assert!(value < 20.0 * 1e-9 / period.powi(order.into()), "{value} {min}");
                    continue;
                }
                Err(e) => panic!("{e}"),
                Ok(x) => x,
            };
            let r = rows(&out);
            check_invariants(&tp, &rep, &r);
            let m = fd_maxima(&r);
            for i in 0..3 {
                prop_assert!(m[1][i] <= p.acc_mm_s2[i], "axis {i} acc {} > {} at T {period}", m[1][i], p.acc_mm_s2[i]);
                if let Some(j) = p.jerk_mm_s3 {
                    prop_assert!(m[2][i] <= j[i], "axis {i} jerk {} > {} at T {period}", m[2][i], j[i]);
                }
                prop_assert!(m[0][i] <= feed + crate::feed::VEL_NOISE_MM / period, "axis {i} speed {}", m[0][i]);
            }
            prop_assert!(rep.limits_held, "{:?}", rep.axes);
            planned = true;
            break;
        }
        prop_assert!(planned);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, ..ProptestConfig::default() })]

    /// Any split of the limits ([`crate::feed::jerk::JerkSplit`]) holds every per-axis
    /// acceleration and jerk limit on blended paths (the split search only picks among
    /// them): measured by finite differences on the printed setpoints.
    #[test]
    fn every_jerk_split_holds_the_limits(
        pts in prop::collection::vec((-3.0f64..3.0, -3.0f64..3.0, -0.5f64..0.5), 2..5),
        u_share in 0.02f64..0.95,
        jt_share in 0.02f64..0.95,
        acc in log_uniform(50.0, 5000.0),
        jerk in log_uniform(500.0, 100000.0),
        feed in log_uniform(5.0, 200.0),
    ) {
        let pts: Vec<Vec3> = pts.into_iter().map(|(x, y, z)| Vec3::new(x, y, z)).collect();
        let tp = blended(&pts, 0.5);
        let p = PlanOptions {
            feed_mm_s: feed,
            acc_mm_s2: [acc, acc * 0.7, acc * 1.3],
            jerk_mm_s3: Some([jerk, jerk * 1.5, jerk * 0.8]),
            jerk_split: Some(crate::feed::jerk::JerkSplit { u_share, jt_share }),
            ..Default::default()
        };
        let (rep, out) = execute(&tp, &p, &InterpOptions::default(), Vec::new()).unwrap();
        let r = rows(&out);
        check_invariants(&tp, &rep, &r);
        let m = fd_maxima(&r);
        let j = p.jerk_mm_s3.unwrap();
        for i in 0..3 {
            prop_assert!(m[1][i] <= p.acc_mm_s2[i], "axis {i} acc {} > {}", m[1][i], p.acc_mm_s2[i]);
            prop_assert!(m[2][i] <= j[i], "axis {i} jerk {} > {}", m[2][i], j[i]);
        }
        prop_assert!(rep.limits_held, "{:?}", rep.axes);
    }
}

/// A program of more than two feeder batches: a spiral of short lines with arcs, dwells,
/// an event, a zero-length move, rapids and extruder moves with resets and retractions.
fn long_mixed_program() -> Toolpath {
    use crate::path::{Event, EventKind};
    let e = |v: f64| [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, v];
    let mut tp = Toolpath::new(Vec3::ZERO);
    tp.extra_axes_mask = 1 << 6;
    let event = |kind| Event {
        line: 1,
        kind,
        text: String::new(),
    };
    let mut p = Vec3::ZERO;
    let mut e_val = 0.0;
    let n = 2 * crate::feed::grid::FEED_BATCH_MOVES + 1500;
    for k in 0..n {
        let a = k as f64 * 0.01;
        let r = 5.0 + 0.002 * k as f64;
        let q = Vec3::new(r * a.cos(), r * a.sin(), 0.0);
        let mut m = if k % 1000 == 500 {
            Move::rapid(Line::new(p, q), k as u32)
        } else {
            Move::feed(Line::new(p, q), Some(40.0), k as u32)
        };
        e_val += 0.01;
        m.extra = Some(e(e_val));
        tp.push_move(m);
        if k % 997 == 0 {
            tp.push_event(event(EventKind::Dwell(0.01)));
        }
        if k % 1499 == 3 {
            tp.push_event(event(EventKind::ExtraMove {
                to: e(e_val - 1.0),
                feed_per_s: Some(30.0),
            }));
            tp.push_event(event(EventKind::ExtraReset { to: e(e_val) }));
        }
        if k == 4100 {
            // A zero-length move (dropped by the index) at a batch's edge.
            let mut z = Move::feed(Line::new(q, q), Some(40.0), k as u32);
            z.extra = Some(e(e_val));
            tp.push_move(z);
        }
        p = q;
    }
    // Events after the last move: the stop they make ends the program's last move.
    tp.push_event(event(EventKind::Dwell(0.25)));
    tp.push_event(event(EventKind::ExtraMove {
        to: e(e_val - 2.0),
        feed_per_s: Some(30.0),
    }));
    tp
}

#[test]
fn streamed_plan_equals_the_whole_plan() {
    let tp = long_mixed_program();
    let iopts = InterpOptions::default();
    for jerk in [None, Some([5000.0; 3])] {
        let popts = PlanOptions {
            jerk_mm_s3: jerk,
            jerk_split: jerk.map(|_| crate::feed::jerk::JerkSplit::DEFAULT),
            ..Default::default()
        };
        let (whole_rep, whole): (_, Vec<Setpoint>) =
            execute_into(&tp, &popts, &iopts, Vec::new()).unwrap();
        let (planned, fed) = execute_streamed(
            tp.start,
            tp.extra_axes_mask,
            &popts,
            &iopts,
            Vec::<Setpoint>::new(),
            |f| {
                for b in &tp.blocks {
                    f.push(b.clone());
                }
                Ok::<(), ()>(())
            },
        );
        fed.unwrap();
        let (rep, rows) = planned.unwrap();
        assert_eq!(rows.len(), whole.len());
        assert!(
            rows == whole,
            "jerk {jerk:?}: the streamed setpoints differ"
        );
        assert_eq!(rep.moves, whole_rep.moves);
        assert_eq!(rep.path_length_mm, whole_rep.path_length_mm);
        assert_eq!(rep.exact_stops, whole_rep.exact_stops);
        assert!(rep.limits_held);
    }
}

#[test]
fn streamed_close_joints_equal_the_whole_plan() {
    // Thousands of S-bends and curls (their close joints share one speed cap; a curl's
    // curvature steps up by 1 /mm four times within 0.004 mm, so a joint lowers the caps
    // of the arcs before it) across the feeder's batches, which fall at every place of
    // the 11-move unit: the setpoints are the whole program's. (A streamed index holds
    // back the moves whose caps a later joint may lower; under the filter the cap of the
    // last joint reaches them anyway, the window W being far longer than 3 periods, so
    // this checks the caps agree, not the hold-back alone.)
    let mut t = Turtle::new(Vec3::ZERO, 2.0);
    for k in 0..(12 * crate::feed::grid::FEED_BATCH_MOVES / 11 + 7) {
        t.line(0.004 + 1e-4 * (k % 7) as f64);
        t.s_bend(1.25, -3.6, 0.009);
        t.line(0.004);
        let turn = if k % 2 == 0 { 1.0 } else { -1.0 };
        for c in 1..=4 {
            t.arc(turn * c as f64, 0.001);
        }
    }
    let tp = t.tp;
    let mut popts = PlanOptions {
        jerk_mm_s3: Some([5000.0; 3]),
        jerk_split: Some(crate::feed::jerk::JerkSplit::DEFAULT),
        ..Default::default()
    };
    // The whole plan finds the path's top speed; the streamed one is given it.
    popts.top_speed_mm_s = Some(popts.top_speed_of(&tp));
    let iopts = InterpOptions::default();
    let (whole_rep, whole): (_, Vec<Setpoint>) =
        execute_into(&tp, &popts, &iopts, Vec::new()).unwrap();
    assert!(whole_rep.limits_held);
    let (planned, fed) = execute_streamed(
        tp.start,
        tp.extra_axes_mask,
        &popts,
        &iopts,
        Vec::<Setpoint>::new(),
        |f| {
            for b in &tp.blocks {
                f.push(b.clone());
            }
            Ok::<(), ()>(())
        },
    );
    fed.unwrap();
    let (rep, rows) = planned.unwrap();
    assert!(rows == whole, "the streamed setpoints differ");
    assert!(rep.limits_held);
}

#[test]
fn streamed_plan_of_nothing_is_one_row() {
    let (planned, fed) = execute_streamed(
        Vec3::new(1.0, 2.0, 3.0),
        0,
        &PlanOptions::default(),
        &InterpOptions::default(),
        Vec::<Setpoint>::new(),
        |_| Ok::<(), ()>(()),
    );
    fed.unwrap();
    let (rep, rows) = planned.unwrap();
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0].p, Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(rep.moves, 0);
}

/// A feed that panics half-way ends the run with that panic (re-raised), not a hang
/// (checked within a minute, on a thread of its own).
#[test]
fn a_streamed_feed_that_panics_does_not_hang() {
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let tp = long_mixed_program();
        let popts = PlanOptions::default();
        let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            execute_streamed(
                tp.start,
                tp.extra_axes_mask,
                &popts,
                &InterpOptions::default(),
                Vec::<Setpoint>::new(),
                |f| {
                    for (k, b) in tp.blocks.iter().enumerate() {
                        assert!(k < 6000, "a feed that fails");
                        f.push(b.clone());
                    }
                    Ok::<(), ()>(())
                },
            )
        }));
        let _ = tx.send(run.is_err());
    });
    let panicked = rx.recv_timeout(std::time::Duration::from_secs(60));
    assert_eq!(panicked, Ok(true), "the run hung or did not panic");
}

fn follow_opts(feed: f64, acc: f64, jerk: f64) -> PlanOptions {
    PlanOptions {
        feed_mm_s: feed,
        acc_mm_s2: [acc; 3],
        jerk_mm_s3: Some([jerk; 3]),
        jerk_scheme: crate::feed::JerkScheme::Follow,
        ..Default::default()
    }
}

fn assert_jerk_held(rep: &PlanReport) {
    assert!(rep.limits_held, "{:?}", rep.axes);
    for a in &rep.axes {
        assert!(a.j_within && a.a_within && a.v_within, "{a:?}");
    }
}

/// A straight line from rest to rest: the follower's cycle is within a few periods of the
/// time-optimal jerk-limited profile (its brake and landing use 0.6 of the limits, the
/// acceleration the whole of them).
#[test]
fn follow_line_is_near_the_jerk_limited_optimum() {
    let tp = Toolpath::from_polyline(&[Vec3::ZERO, Vec3::new(50.0, 0.0, 0.0)], None);
    let p = follow_opts(100.0, 3000.0, 60000.0);
    let (rep, r) = run(&tp, &p, &InterpOptions::default());
    check_invariants(&tp, &rep, &r);
    assert_jerk_held(&rep);
    // Optimum: 100 mm/s is reached with a peak acceleration sqrt(v J) = 2449 < 3000, in
    // 2 sqrt(v / J) = 0.0816 s over 4.08 mm, twice, and 41.84 mm cruise at 100 mm/s.
    let (j, v): (f64, f64) = (0.99 * 60000.0, 100.0);
    let ramp = 2.0 * (v / j).sqrt();
    let optimum = 2.0 * ramp + (50.0 - 2.0 * v * ramp / 2.0) / v;
    assert!(rep.cycle_time_s >= optimum - 1e-9, "{}", rep.cycle_time_s);
    assert!(
        rep.cycle_time_s <= 1.06 * optimum,
        "{} vs {optimum}",
        rep.cycle_time_s
    );
    // The filter scheme, for comparison, is slower.
    let filter = PlanOptions {
        jerk_scheme: crate::feed::JerkScheme::Filter,
        ..p.clone()
    };
    let (rf, _) = run(&tp, &filter, &InterpOptions::default());
    assert!(
        rep.cycle_time_s < rf.cycle_time_s,
        "{} {}",
        rep.cycle_time_s,
        rf.cycle_time_s
    );
}

/// Square corners (exact stops), a dwell and an arc: every stop is reached at rest and
/// held, the limits hold on the rows, the end is exact.
#[test]
fn follow_stops_dwells_and_arcs() {
    let arc = Arc::from_center(
        Vec3::new(10.0, 10.0, 0.0),
        Vec3::new(0.0, 10.0, 0.0),
        Vec3::new(5.0, 10.0, 0.0),
        Vec3::Z,
        false,
        3,
    )
    .unwrap();
    let mut tp = Toolpath::from_polyline(
        &[
            Vec3::ZERO,
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
        ],
        Some(40.0),
    );
    tp.push_event(crate::path::Event {
        line: 2,
        kind: crate::path::EventKind::Dwell(0.1),
        text: "G4 P0.1".into(),
    });
    tp.push_move(Move::feed(arc, Some(40.0), 3));
    let p = follow_opts(50.0, 500.0, 5000.0);
    let (rep, r) = run(&tp, &p, &InterpOptions::default());
    check_invariants(&tp, &rep, &r);
    assert_jerk_held(&rep);
    assert_eq!(rep.exact_stops.dwell, 1);
    assert!(rep.exact_stops.corner >= 1);
    // The corner (10, 0) is a setpoint (the follower lands on it at rest).
    let at = |x: f64, y: f64| {
        r.iter()
            .filter(|row| (row[1] - x).abs() < 1e-9 && (row[2] - y).abs() < 1e-9)
            .count()
    };
    assert!(at(10.0, 0.0) >= 1);
    // The dwell holds at least 0.1 s at (10, 10).
    assert!(at(10.0, 10.0) as f64 >= 0.1 / p.period_s);
    assert!(r.iter().all(|row| row[4] <= 40.0 + 1e-6));
}

/// The butterfly NURBS at a literature setting: the follower holds the jerk and is much
/// faster than the filter.
#[test]
fn follow_butterfly_beats_the_filter() {
    let tp = butterfly_path();
    let p = follow_opts(200.0, 3000.0, 60000.0);
    let (rep, r) = run(&tp, &p, &InterpOptions::default());
    check_invariants(&tp, &rep, &r);
    assert_jerk_held(&rep);
    let filter = PlanOptions {
        jerk_scheme: crate::feed::JerkScheme::Filter,
        ..p.clone()
    };
    let (rf, _) = run(&tp, &filter, &InterpOptions::default());
    assert_jerk_held(&rf);
    assert!(
        rep.cycle_time_s < 0.85 * rf.cycle_time_s,
        "follow {} filter {}",
        rep.cycle_time_s,
        rf.cycle_time_s
    );
}
