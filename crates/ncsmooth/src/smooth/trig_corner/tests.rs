use super::*;
use crate::geom::{Arc, Flatten, ParamCurveCurvature};
use crate::path::Toolpath;
use crate::smooth::{smooth, Method, SmoothOptions, Smoothed};
use crate::verify::{continuity, deviation};
use proptest::prelude::*;

const ACC_SHARE: f64 = 1e-3;

fn opts(tol: f64, corner: CornerStyle) -> SmoothOptions {
    SmoothOptions {
        method: Method::Trig,
        tol_mm: tol,
        trig: TrigOptions {
            corner,
            ..Default::default()
        },
        ..Default::default()
    }
}

/// Largest distance of a loop from its corner: dense samples plus the flattening bound.
fn loop_excursion(c: &TrigSpline) -> f64 {
    let mut m: f64 = 0.0;
    for i in 0..=2000 {
        m = m.max(c.eval(i as f64 / 2000.0).dist(c.q0));
    }
    m
}

/// Checks the contract on a smoothed polyline: two-sided tol outside loops, loops through
/// their corner within 1e-9 and within the loop size, no G0 joint except counted stops,
/// no NaN. Returns the number of loops.
fn check(points: &[Vec3], s: &Smoothed, o: &SmoothOptions) -> usize {
    let prog = Toolpath::from_polyline(points, Some(10.0));
    let tol = o.tol_mm;
    let mut loops = 0;
    let no_loops = without_loops(&s.toolpath);
    for m in s.toolpath.moves() {
        let seg = &m.segment;
        assert!(seg.start().is_finite() && seg.end().is_finite());
        for i in 0..=8 {
            assert!(seg.eval(i as f64 / 8.0).is_finite(), "{seg:?}");
        }
        if let (true, Segment::Trig(c)) = (is_loop(seg), seg) {
            loops += 1;
            let CornerStyle::Loop { loop_size_mm } = o.trig.corner else {
                panic!("loop in round mode");
            };
            // The curve itself (not its control point) passes a programmed corner.
            assert!(points.iter().any(|p| p.dist(c.eval(0.0)) <= 1e-9));
            assert!(points.iter().any(|p| p.dist(c.eval(1.0)) <= 1e-9));
            let e = loop_excursion(c);
            assert!(e <= loop_size_mm, "excursion {e} > {loop_size_mm}");
        }
    }
    // Without the loops the legs still reach every corner: both sides hold.
    let dev = deviation(&no_loops, &prog, tol * ACC_SHARE);
    assert!(
        dev.max_mm() <= tol,
        "deviation {} > tol {tol}: {dev:?}",
        dev.max_mm()
    );
    if let CornerStyle::Loop { loop_size_mm } = o.trig.corner {
        let lc = check_loops(&s.toolpath, &prog, loop_size_mm);
        assert_eq!(lc.loops, loops);
        assert!(lc.within(loop_size_mm), "{lc:?}");
    }
    let c = continuity(&s.toolpath);
    assert_eq!(c.gaps, 0, "{c:?}");
    assert!(c.g0 <= s.report.corners_stopped, "{c:?} {:?}", s.report);
    loops
}

#[test]
fn round_transition_against_the_arc() {
    for deg in [2.0_f64, 10.0, 45.0, 90.0, 120.0, 135.0, 150.0, 170.0, 178.0] {
        let beta = deg.to_radians();
        let tol = 0.01;
        let trig = round_transition_peak_curvature(beta, tol);
        let arc = arc_transition_curvature(beta, tol);
        let ratio = trig / arc;
        assert!((0.999..=1.3).contains(&ratio), "{deg}: {ratio}");
        if deg == 90.0 {
            // Eq. 9: the 90-degree transition is the circular arc itself.
            assert!((ratio - 1.0).abs() < 1e-3, "{ratio}");
        }
        assert!(!round_shape(beta, round_rho(beta)).inflects);
    }
}

#[test]
fn single_corner_uses_the_largest_fitting_transition() {
    let v = Vec3::new(3.0, 4.0, 5.0);
    let a = Vec3::new(1.0, 1.0, 0.0).normalized().unwrap();
    let b = Vec3::new(0.0, 1.0, 1.0).normalized().unwrap();
    let tol = 0.05;
    let (c, d) = inside_transition(v, a, b, tol, 100.0).unwrap();
    assert!(c.eval(0.0).dist(v - a * d) < 1e-12 && c.eval(1.0).dist(v + b * d) < 1e-12);
    assert!(c.deriv(0.0).normalized().unwrap().dist(a) < 1e-12);
    assert!(c.deriv(1.0).normalized().unwrap().dist(b) < 1e-12);
    let prog = [
        (Segment::Line(Line::new(v - a * 10.0, v)), 1),
        (Segment::Line(Line::new(v, v + b * 10.0)), 2),
    ];
    let out = [(Segment::Trig(c), 1)];
    let p: Vec<(&Segment, u32)> = prog.iter().map(|(s, l)| (s, *l)).collect();
    let o: Vec<(&Segment, u32)> = out.iter().map(|(s, l)| (s, *l)).collect();
    let dev = deviation_segments(&o, &p, 1e-7);
    // (a) within tol; the corner itself (b) is at tol (1 - margin): the largest that fits.
    assert!(dev.output_to_programmed_mm <= tol);
    let corner_gap = c.nearest(v, 1e-12).distance_sq.sqrt();
    assert!(corner_gap <= tol && corner_gap >= tol * (1.0 - 2.0 * CORNER_TOL_MARGIN));
    // Limited by the legs: d is clipped.
    let (_, d2) = inside_transition(v, a, b, tol, 0.01).unwrap();
    assert_eq!(d2, 0.01);
}

use crate::geom::ParamCurveNearest;

#[test]
fn loop_passes_the_corner_and_stays_within_its_size() {
    for deg in [30.0_f64, 60.0, 90.0, 135.0, 170.0] {
        let beta = deg.to_radians();
        let v = Vec3::new(1e5, -2e5, 7.0);
        let a = Vec3::X;
        let b = Vec3::new(beta.cos(), 0.0, beta.sin());
        let c = loop_corner(v, a, b, 0.5).unwrap();
        assert!(c.eval(0.0).dist(v) <= 1e-9 && c.eval(1.0).dist(v) <= 1e-9);
        assert!(c.deriv(0.0).normalized().unwrap().dist(a) < 1e-12);
        assert!(c.deriv(1.0).normalized().unwrap().dist(b) < 1e-12);
        let e = loop_excursion(&c);
        assert!((0.45..=0.5).contains(&e), "{deg}: {e}");
        // It lies outside the corner: no point inside the wedge between the legs, and it
        // turns one way only.
        let sh = loop_shape(beta, c.lambda);
        assert!(!sh.inflects, "{deg}");
        // Never stops: the speed stays away from zero.
        for i in 0..=100 {
            assert!(c.deriv(i as f64 / 100.0).norm() > 1e-3 * e);
        }
    }
}

#[test]
fn square_with_loops_and_rounds() {
    let pts = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(20.0, 0.0, 0.0),
        Vec3::new(20.0, 20.0, 0.0),
        Vec3::new(0.0, 20.0, 0.0),
        Vec3::new(0.0, 0.0, 0.0),
    ];
    let tp = Toolpath::from_polyline(&pts, Some(10.0));
    let o = opts(0.02, CornerStyle::Round);
    let s = smooth(&tp, &o).unwrap();
    assert_eq!(s.report.corners_smoothed, 3);
    assert_eq!(check(&pts, &s, &o), 0);
    let c = continuity(&s.toolpath);
    assert_eq!(c.g0, 0);
    // Every corner transition is the exact arc (90 degrees, eq. 9).
    for m in s.toolpath.moves() {
        if let Segment::Trig(t) = &m.segment {
            let k0 = t.curvature(0.5);
            assert!((t.curvature(0.1) - k0).abs() < 1e-6 * k0);
        }
    }
    let o = opts(0.02, CornerStyle::Loop { loop_size_mm: 2.0 });
    let s = smooth(&tp, &o).unwrap();
    assert_eq!(check(&pts, &s, &o), 3);
    assert_eq!(continuity(&s.toolpath).g0, 0);
}

fn circle_points(n: usize, r: f64, sweep: f64) -> Vec<Vec3> {
    (0..=n)
        .map(|i| {
            let t = sweep * i as f64 / n as f64;
            Vec3::new(r * t.cos(), r * t.sin(), 0.1 * t)
        })
        .collect()
}

#[test]
fn micro_line_runs_become_trig_curves() {
    // A long line, a finely sampled arc (a run), a sharp corner, a long line.
    let mut pts = vec![Vec3::new(30.0, -40.0, 0.0)];
    pts.extend(circle_points(200, 30.0, 2.0));
    let last = *pts.last().unwrap();
    pts.push(last + Vec3::new(25.0, 3.0, 0.0));
    let tp = Toolpath::from_polyline(&pts, Some(10.0));
    let o = opts(0.01, CornerStyle::Round);
    let s = smooth(&tp, &o).unwrap();
    assert!(s.report.runs_fitted >= 1, "{:?}", s.report);
    assert!(s.report.points_per_run.iter().sum::<usize>() > 150);
    assert!(s
        .report
        .fit_deviation_per_run_mm
        .iter()
        .all(|&d| d + o.tol_mm * RUN_MEASURE_SHARE <= o.tol_mm));
    check(&pts, &s, &o);
    let c = continuity(&s.toolpath);
    assert_eq!(c.g0, 0, "{c:?}");
    // The curve is much smoother than the polyline: its tangent turns continuously.
    assert!(c.max_smooth_angle_deg <= crate::verify::TANGENT_TOL_DEG);
}

#[test]
fn runs_split_where_the_fit_fails() {
    // Long chords on a tight tolerance pass the screen at a generous tolerance only;
    // force the screen open and check that the measurement splits the run.
    let pts = circle_points(12, 5.0, 3.0);
    let tp = Toolpath::from_polyline(&pts, Some(10.0));
    let mut o = opts(0.001, CornerStyle::Round);
    o.trig.screen.chord_share = 1e9;
    o.trig.screen.min_angle_deg = 0.0;
    let s = smooth(&tp, &o).unwrap();
    check(&pts, &s, &o);
    assert!(s.report.corners_smoothed > 0, "{:?}", s.report);
}

#[test]
fn arcs_stay_exact_and_their_corners_blend() {
    let mut tp = Toolpath::new(Vec3::ZERO);
    tp.push_move(Move::feed(
        Line::new(Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)),
        Some(5.0),
        1,
    ));
    // Tangent arc.
    let arc = Arc::from_center(
        Vec3::new(10.0, 0.0, 0.0),
        Vec3::new(15.0, 5.0, 0.0),
        Vec3::new(10.0, 5.0, 0.0),
        Vec3::Z,
        true,
        0,
    )
    .unwrap();
    tp.push_move(Move::feed(arc, Some(5.0), 2));
    // Non-tangent line after it.
    tp.push_move(Move::feed(
        Line::new(Vec3::new(15.0, 5.0, 0.0), Vec3::new(0.0, 5.0, 0.0)),
        Some(5.0),
        3,
    ));
    tp.push_move(Move::feed(
        Line::new(Vec3::new(0.0, 5.0, 0.0), Vec3::new(0.0, 20.0, 0.0)),
        Some(5.0),
        4,
    ));
    let o = opts(0.01, CornerStyle::Round);
    let s = smooth(&tp, &o).unwrap();
    // The arc -> line joint (90 degrees) is blended with a trig segment (see
    // smooth::arc_joint), the line-line corner gets Tao's transition.
    assert_eq!(s.report.arc_joints, 1);
    assert_eq!(s.report.arc_joints_blended, 1);
    assert_eq!(s.report.corners_stopped, 0);
    assert_eq!(s.report.corners_smoothed, 2);
    assert!(s.toolpath.moves().any(|m| matches!(m.segment,
        Segment::Arc(b) if b.center == arc.center && b.u == arc.u && b.sweep < arc.sweep)));
    assert!(deviation(&s.toolpath, &tp, 1e-5).max_mm() <= 0.01);
    assert_eq!(continuity(&s.toolpath).g0, 0);
}

#[test]
fn figures_data() {
    let fa = figures::fig1_lambda_family(50);
    let fb = figures::fig1_k_family(50);
    assert_eq!(fa.len(), 4);
    assert_eq!(fb.len(), 4);
    for f in fa.iter().chain(&fb) {
        assert_eq!(f.points.len(), 51);
        assert!(f.points[0].dist(figures::FIG1_CONTROL[0]) < 1e-12);
        assert!(f.points[50].dist(figures::FIG1_CONTROL[1]) < 1e-12);
    }
    // Different parameters give different curves.
    assert!(fa[0].points[25].dist(fa[3].points[25]) > 0.1);
    assert!(fb[0].points[25].dist(fb[3].points[25]) > 0.1);
    let (legs, lp) = figures::loop_corner_figure(90.0, 2.0, 100).unwrap();
    assert_eq!(legs.len(), 3);
    assert!(lp.points.iter().all(|p| p.norm() <= 2.0));
    assert!(lp.points[0].norm() < 1e-12 && lp.points[100].norm() < 1e-9);
    // Outside the corner: the loop stays in the half plane y <= 0 (the incoming leg is
    // the -x axis, the outgoing leg +y).
    assert!(lp.points.iter().all(|p| p.y <= 1e-12 || p.x >= -1e-12));
}

#[test]
fn flattened_output_is_g_code_ready() {
    let pts = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(5.0, 0.0, 0.0),
        Vec3::new(5.0, 5.0, 0.0),
        Vec3::new(10.0, 5.0, 1.0),
    ];
    let tp = Toolpath::from_polyline(&pts, Some(10.0));
    let o = opts(0.01, CornerStyle::Round);
    let s = smooth(&tp, &o).unwrap();
    let f = s.toolpath.flattened(o.tol_mm * 0.01);
    assert!(f.moves().all(|m| m.segment.is_native_gcode()));
    assert!(deviation(&f, &tp, 1e-5).max_mm() <= o.tol_mm * 1.01);
}

// ---------------------------------------------------------------------------------------
// Property tests on random and degenerate polylines.

fn base_polyline() -> impl Strategy<Value = Vec<Vec3>> {
    prop::collection::vec(
        (-50.0..50.0f64, -50.0..50.0f64, -5.0..5.0f64).prop_map(|(x, y, z)| Vec3::new(x, y, z)),
        2..10,
    )
}

/// Degenerate variants: 0 none, 1 repeated point, 2 a 1 um segment, 3 a 180-degree
/// reversal, 4 a near-collinear point, 5 a 1-degree corner, 6 huge coordinates, 7 a fine
/// arc (micro-line run).
fn degenerate(mut p: Vec<Vec3>, mode: u8, at: usize) -> Vec<Vec3> {
    let i = at % p.len();
    match mode {
        1 => {
            let q = p[i];
            p.insert(i, q);
        }
        2 => {
            let q = p[i];
            p.insert(i + 1, q + Vec3::new(0.001, 0.0, 0.0));
        }
        3 => {
            let q = p[i];
            p.insert(i + 1, q + Vec3::new(7.0, 3.0, 0.0));
            p.insert(i + 2, q);
        }
        4 => {
            let q = p[i];
            p.insert(i + 1, q + Vec3::new(10.0, 0.0, 0.0));
            p.insert(i + 2, q + Vec3::new(20.0, 1e-6, 0.0));
        }
        5 => {
            let q = p[i];
            let a = 1f64.to_radians();
            p.insert(i + 1, q + Vec3::new(10.0, 0.0, 0.0));
            p.insert(
                i + 2,
                q + Vec3::new(10.0 + 10.0 * a.cos(), 10.0 * a.sin(), 0.0),
            );
        }
        6 => {
            for q in p.iter_mut() {
                *q += Vec3::new(1e6, -2e6, 3e5);
            }
        }
        7 => {
            let q = p[i];
            let arc = circle_points(40, 8.0, 1.5);
            for (k, c) in arc.iter().enumerate() {
                p.insert(i + 1 + k, q + *c - arc[0]);
            }
        }
        _ => {}
    }
    p
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn round_corners_hold_tol(
        p in base_polyline(), mode in 0u8..8, at in 0usize..20, tol in 0.001..0.2f64
    ) {
        let pts = degenerate(p, mode, at);
        let tp = Toolpath::from_polyline(&pts, Some(10.0));
        let o = opts(tol, CornerStyle::Round);
        let s = smooth(&tp, &o).unwrap();
        prop_assert_eq!(check(&pts, &s, &o), 0);
        let c = continuity(&s.toolpath);
        prop_assert_eq!(c.g0, s.report.corners_stopped);
    }

    #[test]
    fn loops_pass_corners_and_stay_small(
        p in base_polyline(), mode in 0u8..8, at in 0usize..20,
        tol in 0.001..0.2f64, size in 0.05..5.0f64
    ) {
        let pts = degenerate(p, mode, at);
        let tp = Toolpath::from_polyline(&pts, Some(10.0));
        let o = opts(tol, CornerStyle::Loop { loop_size_mm: size });
        let s = smooth(&tp, &o).unwrap();
        check(&pts, &s, &o);
        let c = continuity(&s.toolpath);
        prop_assert_eq!(c.g0, s.report.corners_stopped);
    }
}

#[test]
fn every_loop_range_corner_gets_a_loop() {
    // Corners of 30..170 degrees, long legs: each becomes a loop through the corner.
    let mut pts = vec![Vec3::ZERO];
    let mut dir: f64 = 0.0;
    for (i, turn) in [40.0_f64, -100.0, 160.0, -35.0, 90.0].iter().enumerate() {
        let last = *pts.last().unwrap();
        pts.push(last + Vec3::new(dir.cos(), dir.sin(), 0.0) * (10.0 + i as f64));
        dir += turn.to_radians();
    }
    let last = *pts.last().unwrap();
    pts.push(last + Vec3::new(dir.cos(), dir.sin(), 0.0) * 10.0);
    let tp = Toolpath::from_polyline(&pts, Some(10.0));
    let o = opts(0.01, CornerStyle::Loop { loop_size_mm: 1.5 });
    let s = smooth(&tp, &o).unwrap();
    assert_eq!(check(&pts, &s, &o), 5);
    let c = continuity(&s.toolpath);
    assert_eq!(c.g0, 0);
    assert!(c.joints > 0 && c.gaps == 0);
    let mut n = 0;
    for m in s.toolpath.moves() {
        if is_loop(&m.segment) {
            // Flattened as the writer does it: the lines return to the corner and stay
            // within the loop size.
            let corner = m.segment.eval(0.0);
            let mut last = corner;
            let mut far: f64 = 0.0;
            m.segment.flatten(1e-4, &mut |p| {
                far = far.max(p.dist(corner));
                last = p;
            });
            assert!(
                last.dist(corner) <= 1e-9 && far > 0.1 && far <= 1.5,
                "{far}"
            );
            n += 1;
        }
    }
    assert_eq!(n, 5);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Without the run mode, a finely sampled smooth curve is one run of the paper's
    /// construction: its trig segments share their joint derivatives (C1, eq. 5),
    /// whatever the (screened) spacing of the samples.
    #[test]
    fn runs_are_c1(
        r in 5.0..200.0f64,
        wiggle in 0.0..0.3f64,
        steps in prop::collection::vec(0.7..1.4f64, 20..80),
        tol in 0.002..0.05f64,
    ) {
        let mut a = 0.0f64;
        let mut pts = Vec::with_capacity(steps.len() + 1);
        let dphi = 0.2 / r.sqrt();
        for (i, s) in std::iter::once(&0.0).chain(&steps).enumerate() {
            a += s * dphi;
            let rr = r * (1.0 + wiggle * (3.0 * a).sin());
            pts.push(Vec3::new(rr * a.cos(), rr * a.sin(), 0.01 * i as f64));
        }
        let tp = Toolpath::from_polyline(&pts, Some(10.0));
        // The paper's construction of runs (eq. 5): the run mode off.
        let mut o = opts(tol, CornerStyle::Round);
        o.run.enabled = false;
        let s = smooth(&tp, &o).unwrap();
        check(&pts, &s, &o);
        let moves: Vec<_> = s.toolpath.moves().collect();
        let mut run_joints = 0;
        for w in moves.windows(2) {
            let (Segment::Trig(c0), Segment::Trig(c1)) = (&w[0].segment, &w[1].segment) else {
                continue;
            };
            // A joint of two trig segments on a programmed vertex that turns is a smooth
            // vertex of a run (transitions are cut around their vertex; straight vertices
            // pass unchanged and are only G1).
            let Some(i) = pts.iter().position(|q| *q == c0.q1) else { continue };
            if i == 0 || i + 1 == pts.len() {
                continue;
            }
            let turn = (pts[i] - pts[i - 1]).angle_to(pts[i + 1] - pts[i]).to_degrees();
            if turn < o.straight_angle_deg {
                continue;
            }
            let (d0, d1) = (c0.deriv(1.0), c1.deriv(0.0));
            prop_assert!(d0.dist(d1) <= 1e-9 * d0.norm().max(1.0), "{:?} {:?}", d0, d1);
            run_joints += 1;
        }
        prop_assert!(run_joints > 0 || s.report.runs_fitted == 0);
    }
}

#[test]
fn deviation_table_never_underestimates() {
    // Deterministic pseudo-random turns over the whole range, and a few at the ends.
    let mut x = 0x2545_f491_4f6c_dd1du64;
    let mut betas: Vec<f64> = vec![0.01, 0.5, 1.0, 89.99, 90.0, 178.9, 179.0];
    for _ in 0..400 {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        betas.push((x >> 11) as f64 / (1u64 << 53) as f64 * 179.0 + 0.01);
    }
    for deg in betas {
        let b = f64::to_radians(deg);
        let direct = round_deviation(b, round_rho(b));
        let table = corner_deviation(b);
        assert!(table >= direct, "{deg}: {table} < {direct}");
        assert!(table <= direct * (1.0 + 2e-4), "{deg}: {table} vs {direct}");
    }
}
