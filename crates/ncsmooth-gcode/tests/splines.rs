//! Splines: G5 and G5.1 control points against hand-computed Béziers, the rule for a G5
//! without I J, G5.2/G5.3 NURBS against known curves and an independent evaluation of
//! LinuxCNC's basis functions, LinuxCNC's errors, and rewriting programs with splines.

use ncsmooth::geom::{CubicBez, ParamCurve, ParamCurveDeriv, Segment, Vec3};
use ncsmooth::path::{Block, EventKind};
use ncsmooth_gcode::{
    parse_str, rewrite, Canon, MachineModel, ParseOptions, Program, RewriteOptions,
};

fn parse(src: &str) -> Program {
    let mut opts = ParseOptions::with_machine(MachineModel::default());
    opts.canon = true;
    parse_str(src, "t.ngc", &opts).unwrap_or_else(|e| panic!("{e}\n{src}"))
}

fn err(src: &str) -> String {
    match parse_str(
        src,
        "t.ngc",
        &ParseOptions::with_machine(MachineModel::default()),
    ) {
        Ok(_) => panic!("expected an error for\n{src}"),
        Err(e) => e.to_string(),
    }
}

fn v(x: f64, y: f64, z: f64) -> Vec3 {
    Vec3::new(x, y, z)
}

fn bez(p: &Program, k: usize) -> CubicBez {
    match &p.toolpath.moves().nth(k).unwrap().segment {
        Segment::CubicBez(c) => *c,
        other => panic!("move {k} is a {}", other.kind_name()),
    }
}

fn g5_warnings(p: &Program) -> usize {
    p.stats
        .warnings
        .iter()
        .filter(|w| w.message.contains("G5 without I J"))
        .count()
}

fn close(a: Vec3, b: Vec3, tol: f64) -> bool {
    a.dist(b) <= tol
}

#[test]
fn g5_control_points() {
    // P1 = start + (I, J), P2 = end + (P, Q), at the current Z.
    let p = parse("G21 G17 G90 F100\nG0 X1 Y2 Z3\nG5 X10 Y5 I2 J1 P-3 Q2\n");
    let c = bez(&p, 1);
    assert_eq!(c.p0, v(1.0, 2.0, 3.0));
    assert_eq!(c.p1, v(3.0, 3.0, 3.0));
    assert_eq!(c.p2, v(7.0, 7.0, 3.0));
    assert_eq!(c.p3, v(10.0, 5.0, 3.0));
    let m = p.toolpath.moves().nth(1).unwrap();
    assert_eq!(m.feed_mm_s, Some(100.0 / 60.0));
    assert!(!m.pinned, "a G5 line alone may be smoothed");
    assert!(matches!(
        p.canon.last(),
        Some(Canon::Spline { end }) if end[..3] == [10.0, 5.0, 3.0]
    ));
}

#[test]
fn g5_incremental_inch() {
    // G91: the end is relative to the start; offsets are always relative; inches.
    let p = parse("G20 G90 F10\nG0 X1 Y1 Z0\nG91 G5 X1 Y-1 I0.5 J0 P0 Q0.5\n");
    let c = bez(&p, 1);
    let i = 25.4;
    assert!(close(c.p0, v(i, i, 0.0), 1e-12));
    assert!(close(c.p1, v(1.5 * i, i, 0.0), 1e-12));
    assert!(close(c.p2, v(2.0 * i, 0.5 * i, 0.0), 1e-12));
    assert!(close(c.p3, v(2.0 * i, 0.0, 0.0), 1e-12));
}

#[test]
fn g5_without_ij_continues_the_previous_g5() {
    // The second G5 starts in the direction the first ended: its first control point is
    // its start minus the first one's (P, Q).
    let p = parse("G21 G90 F100\nG0 X0 Y0 Z0\nG5 X10 Y0 I3 J4 P-2 Q3\nG5 X20 Y5 P-1 Q-1\n");
    let (a, b) = (bez(&p, 1), bez(&p, 2));
    assert_eq!(b.p0, a.p3);
    assert_eq!(b.p1, v(12.0, -3.0, 0.0));
    assert_eq!(b.p2, v(19.0, 4.0, 0.0));
    let (ta, tb) = (
        a.deriv(1.0).normalized().unwrap(),
        b.deriv(0.0).normalized().unwrap(),
    );
    assert!(close(ta, tb, 1e-12), "{ta:?} {tb:?}");
    // The first G5 is pinned: rewriting it would change the second.
    let moves: Vec<_> = p.toolpath.moves().collect();
    assert!(moves[1].pinned && !moves[2].pinned);
    assert!(
        !p.stats.warnings.iter().any(|w| w.message.contains("G5")),
        "{:?}",
        p.stats.warnings
    );
}

#[test]
fn g5_without_ij_elsewhere_uses_what_linuxcnc_stored() {
    // Not right after a G5: LinuxCNC still takes the last G5's -P -Q (0 0 at first),
    // ncsmooth too, with a warning.
    let p = parse("G21 G90 F100\nG0 X0 Y0 Z0\nG5 X1 Y1 P1 Q0\n");
    assert_eq!(bez(&p, 1).p1, v(0.0, 0.0, 0.0));
    assert_eq!(g5_warnings(&p), 1);
    let p =
        parse("G21 G90 F100\nG0 X0 Y0 Z0\nG5 X10 Y0 I1 J1 P-2 Q3\nG1 X10 Y10\nG5 X0 Y10 P1 Q1\n");
    assert_eq!(bez(&p, 3).p1, v(12.0, 7.0, 0.0));
    assert_eq!(g5_warnings(&p), 1);
}

#[test]
fn g5_1_is_the_degree_elevated_quadratic() {
    let p = parse("G21 G90 F100\nG0 X0 Y0 Z1\nG5.1 X10 Y0 I5 J5\n");
    let c = bez(&p, 1);
    let t = 10.0 / 3.0;
    assert!(close(c.p0, v(0.0, 0.0, 1.0), 1e-12));
    assert!(close(c.p1, v(t, t, 1.0), 1e-12));
    assert!(close(c.p2, v(2.0 * t, t, 1.0), 1e-12));
    assert!(close(c.p3, v(10.0, 0.0, 1.0), 1e-12));
    // The quadratic (0,0), (5,5), (10,0) everywhere.
    for k in 0..=10 {
        let s = f64::from(k) / 10.0;
        let q = v(0.0, 0.0, 1.0) * ((1.0 - s) * (1.0 - s))
            + v(5.0, 5.0, 1.0) * (2.0 * s * (1.0 - s))
            + v(10.0, 0.0, 1.0) * (s * s);
        assert!(close(c.eval(s), q, 1e-12), "t = {s}");
    }
}

#[test]
fn spline_errors() {
    for (src, msg) in [
        ("G0 X0 Y0 Z0\nG18 G5 X1 Z1 I1 J0 P-1 Q0 F10\n", "XY plane"),
        ("G0 X0 Y0 Z0\nG5 X1 Y1 Z1 I1 J0 P-1 Q0 F10\n", "motion in Z"),
        (
            "G0 X0 Y0 Z0\nG5 X1 Y1 I1 P-1 Q0 F10\n",
            "both I and J, or neither",
        ),
        ("G0 X0 Y0 Z0\nG5 X1 Y1 I1 J1 F10\n", "both P and Q"),
        ("G0 X0 Y0 Z0\nG5.1 X1 Y1 I1 F10\n", "both I and J with G5.1"),
        ("G0 X0 Y0 Z0\nG5.1 X1 Y1 I1 J1 A1 F10\n", "motion in Z, A"),
        ("G0 X0 Y0 Z0\nG5 I1 J1 P1 Q1 F10\n", "all axes missing"),
        ("G0 X0 Y0 Z0\nG5.3\n", "without G5.2"),
        (
            "G0 X0 Y0 Z0\nG5.2 X1 Y1 P1 L5 F10\nX2 Y2 P1\nG5.3\n",
            "order L = 5",
        ),
        (
            "G0 X0 Y0 Z0\nG5.2 X1 Y1 P1 F10\nX2 Y2 P0\nG5.3\n",
            "positive weight",
        ),
        (
            "G0 X0 Y0 Z0\nG5.2 X1 Y1 P1 F10\nX2 Y2\nG5.3\n",
            "positive weight",
        ),
        (
            "G0 X0 Y0 Z0\nG5.2 X1 Y1 P1 F10\nP2\nX2 Y2 P1\nG5.3\n",
            "P word",
        ),
        ("G0 X0 Y0 Z0\nG5.2 X1 P1 F10\n", "both X and Y"),
        (
            "G0 X0 Y0 Z0\nG5.2 X1 Y1 F10\nX2 Y2 P1\nG5.3\n",
            "positive weight",
        ),
        ("G0 X0 Y0 Z0\nG18 G5.2 X1 Y1 P1 F10\n", "XY plane"),
        ("G0 X0 Y0 Z0\nG5.2 X1 Y1 Z2 P1 F10\n", "may not move Z"),
        (
            "G0 X0 Y0 Z0\nG5.2 X1 Y1 P1 F10\nX2 Y2 P1\nX3 Y3 P1\nG5.3 X7\n",
            "no axis",
        ),
        (
            "G0 X0 Y0 Z0\nG5.2 X1 Y1 P1 F10\nX2 Y2 P1\nX3 Y3 P1\nG5.3\nX1\n",
            "motion mode",
        ),
        (
            "G0 X0 Y0 Z0\nG5.2 X1 Y1 P1 F10\nX2 Y2 P1\nX3 Y3 P1\nG1 X0\nG5.3\n",
            "without G5.2",
        ),
    ] {
        let e = err(src);
        assert!(e.contains(msg), "{src}: {e}");
    }
    // The error is located on the offending block.
    let e = parse_str(
        "G0 X0 Y0 Z0\nG5.2 X1 Y1 P1 F10\nX2 Y2 P0\n",
        "t.ngc",
        &ParseOptions::default(),
    )
    .unwrap_err();
    assert_eq!((e.line, e.column), (3, 1));
}

fn nurbs(p: &Program) -> ncsmooth::geom::Nurbs {
    match &p.toolpath.moves().last().unwrap().segment {
        Segment::Nurbs(n) => (**n).clone(),
        other => panic!("not a NURBS: {}", other.kind_name()),
    }
}

#[test]
fn g5_2_quarter_circle() {
    // Control points (1,0) (1,1) (0,1), middle weight sqrt(2)/2, order 3: a quarter of the
    // unit circle.
    let p = parse(
        "G21 G90 F100\nG0 X1 Y0 Z2\nG5.2 X1 Y1 P0.7071067811865476\nX0 Y1 P1\nG5.3\nG1 X0 Y0\n",
    );
    let mv = p.toolpath.moves().nth(1).unwrap();
    assert!(mv.pinned, "NURBS lines are written back verbatim");
    let Segment::Nurbs(n) = &mv.segment else {
        panic!("not a NURBS")
    };
    assert_eq!(n.degree(), 2);
    assert_eq!(n.knots(), &[0.0, 0.0, 0.0, 1.0, 1.0, 1.0]);
    for k in 0..=20 {
        let q = n.eval(f64::from(k) / 20.0);
        assert!((q.x.hypot(q.y) - 1.0).abs() < 1e-12, "{q:?}");
        assert_eq!(q.z, 2.0);
    }
    assert_eq!(n.eval(0.0), v(1.0, 0.0, 2.0));
    assert!(close(n.eval(1.0), v(0.0, 1.0, 2.0), 1e-15));
    // 45 degrees at the middle of the parameter range (symmetric weights).
    let m = n.eval(0.5);
    assert!((m.x - m.y).abs() < 1e-12);
    // The next move starts at the last control point.
    let next = p.toolpath.moves().nth(2).unwrap();
    assert_eq!(next.segment.start(), v(0.0, 1.0, 2.0));
    assert_eq!(
        p.canon
            .iter()
            .filter(|c| matches!(c, Canon::Spline { .. }))
            .count(),
        1
    );
}

/// LinuxCNC's basis function N_{i,k}(u) (order k) by the Cox-de Boor recursion, with its
/// knot vector: an independent check of the curve ncsmooth builds.
fn basis(i: usize, k: usize, u: f64, knots: &[f64]) -> f64 {
    if k == 1 {
        // Half-open spans, the last one closed.
        let last = knots[knots.len() - 1];
        let inside = knots[i] <= u && (u < knots[i + 1] || (u == last && knots[i + 1] == last));
        let nonempty = knots[i] < knots[i + 1];
        return if inside && nonempty { 1.0 } else { 0.0 };
    }
    let mut s = 0.0;
    let d1 = knots[i + k - 1] - knots[i];
    if d1 > 0.0 {
        s += (u - knots[i]) / d1 * basis(i, k - 1, u, knots);
    }
    let d2 = knots[i + k] - knots[i + 1];
    if d2 > 0.0 {
        s += (knots[i + k] - u) / d2 * basis(i + 1, k - 1, u, knots);
    }
    s
}

#[test]
fn g5_2_order_4_matches_linuxcnc_basis() {
    // Start weight from P on a first block without X Y, order 4 from L, 6 control points:
    // LinuxCNC's knots are 0 0 0 0 1 2 3 3 3 3.
    let src = "G21 G90 F100\nG0 X0 Y0 Z0\nG5.2 P2 L4\nX1 Y3 P1\nX4 Y4 P0.5\nX6 Y1 P3\n\
               X8 Y2 P1\nX9 Y0 P1.5\nG5.3\n";
    let p = parse(src);
    let n = nurbs(&p);
    let ctrl = [
        (0.0, 0.0, 2.0),
        (1.0, 3.0, 1.0),
        (4.0, 4.0, 0.5),
        (6.0, 1.0, 3.0),
        (8.0, 2.0, 1.0),
        (9.0, 0.0, 1.5),
    ];
    let knots = [0.0, 0.0, 0.0, 0.0, 1.0, 2.0, 3.0, 3.0, 3.0, 3.0];
    assert_eq!(n.degree(), 3);
    assert_eq!(n.knots(), &knots);
    for k in 0..=60 {
        let t = f64::from(k) / 60.0;
        let u = 3.0 * t;
        let (mut x, mut y, mut w) = (0.0, 0.0, 0.0);
        for (i, &(cx, cy, cw)) in ctrl.iter().enumerate() {
            let b = basis(i, 4, u, &knots) * cw;
            x += b * cx;
            y += b * cy;
            w += b;
        }
        let q = n.eval(t);
        assert!(close(q, v(x / w, y / w, 0.0), 1e-12), "t = {t}: {q:?}");
    }
    assert_eq!(n.eval(1.0), v(9.0, 0.0, 0.0));
}

#[test]
fn g5_2_order_rules_and_incremental_points() {
    // L2 is ignored (order 3); an L on a later block raises the order.
    let p = parse("G21 G90 F100\nG0 X0 Y0 Z0\nG5.2 X1 Y1 P1 L2\nX2 Y2 P1\nG5.3\n");
    assert_eq!(nurbs(&p).degree(), 2);
    let p = parse("G21 G90 F100\nG0 X0 Y0 Z0\nG5.2 X1 Y1 P1\nX2 Y2 P1 L4\nX3 Y0 P1\nG5.3\n");
    assert_eq!(nurbs(&p).degree(), 3);
    // G91: every control point relative to the curve's first point (LinuxCNC does not
    // move until G5.3).
    let p = parse("G21 G90 F100\nG0 X1 Y1 Z0\nG91 G5.2 X1 Y1 P1\nX1 Y2 P1\nX3 Y1 P1\nG5.3\n");
    let n = nurbs(&p);
    assert_eq!(
        n.ctrl(),
        &[
            v(1.0, 1.0, 0.0),
            v(2.0, 2.0, 0.0),
            v(2.0, 3.0, 0.0),
            v(4.0, 2.0, 0.0)
        ]
    );
    // A second explicit G5.2 continues the same curve.
    let p = parse(
        "G21 G90 F100\nG0 X0 Y0 Z0\nG5.2 X1 Y1 P1\nX2 Y2 P1\nG5.2 X3 Y3 P1\nX4 Y0 P1\nG5.3\n",
    );
    assert_eq!(nurbs(&p).ctrl().len(), 5);
}

#[test]
fn unfinished_nurbs_makes_no_motion() {
    let p = parse("G21 G90 F100\nG0 X0 Y0 Z0\nG5.2 X1 Y1 P1\nX2 Y2 P1\nG1 X5 Y0\n");
    assert_eq!(p.toolpath.move_count(), 2);
    assert_eq!(
        p.toolpath.moves().last().unwrap().segment.start(),
        v(0.0, 0.0, 0.0)
    );
    assert!(p
        .stats
        .warnings
        .iter()
        .any(|w| w.message.contains("not ended by G5.3")));
}

#[test]
fn splines_from_unknown_positions_are_untracked() {
    // No machine model: X and Y unknown at the start.
    let src = "G21 G90 F100\nG5 X10 Y0 I1 J1 P-1 Q1\nG5.1 X20 Y0 I5 J5\n";
    let p = parse_str(src, "t.ngc", &ParseOptions::default()).unwrap();
    let kinds: Vec<_> = p
        .toolpath
        .blocks
        .iter()
        .map(|b| match b {
            Block::Move(m) => m.segment.kind_name().to_string(),
            Block::Event(e) => format!("{:?}", e.kind),
        })
        .collect();
    assert_eq!(
        kinds,
        [
            format!("{:?}", EventKind::Untracked { extra: None }),
            "cubic_bezier".into()
        ]
    );
    // A NURBS whose first point is unknown; its last point is absolute, so known after.
    let src = "G21 G90 F100\nG5.2 X1 Y1 P1\nX2 Y0 P1\nG5.3\nG1 X3\n";
    let p = parse_str(src, "t.ngc", &ParseOptions::default()).unwrap();
    assert_eq!(p.stats.untracked, 1);
    let m = p.toolpath.moves().next().unwrap();
    assert_eq!(m.segment.start().x, 2.0);
    assert_eq!(m.segment.start().y, 0.0);
}

const SPLINE_PROGRAM: &str = "G21 G90 G17 F600\n\
    G0 X0 Y0 Z1\n\
    G1 Z0\n\
    G5 X10 Y0 I3 J4 P-2 Q3\n\
    G5.1 X20 Y5 I5 J-5\n\
    G5.2 X21 Y8 P1 L4\n\
    X25 Y9 P0.5\n\
    X27 Y4 P2\n\
    X30 Y0 P1\n\
    G5.3\n\
    G1 X30 Y-5\n\
    G5 X20 Y-10 I0 J-3 P4 Q0\n\
    G0 Z5\n\
    M2\n";

#[test]
fn unchanged_program_with_splines_is_written_back_verbatim() {
    let p = parse_str(SPLINE_PROGRAM, "t.ngc", &ParseOptions::default()).unwrap();
    // Only the first G0 (from a position nobody knows) is untracked.
    assert_eq!(p.stats.untracked, 1);
    let kinds: Vec<_> = p.toolpath.moves().map(|m| m.segment.kind_name()).collect();
    assert_eq!(
        kinds,
        [
            "line",
            "cubic_bezier",
            "cubic_bezier",
            "nurbs",
            "line",
            "cubic_bezier",
            "line"
        ]
    );
    let out = rewrite(
        SPLINE_PROGRAM.as_bytes(),
        &p,
        &p.toolpath,
        &RewriteOptions::default(),
    )
    .unwrap();
    assert_eq!(String::from_utf8(out).unwrap(), SPLINE_PROGRAM);
}

#[test]
fn rewritten_splines_parse_back_within_the_chord_tolerance() {
    // Every replaceable move cut in two: the G5 and G5.1 lines are rewritten, and a
    // rewrite writes Béziers flattened to G1 within its chord tolerance; the NURBS lines
    // stay.
    let p = parse_str(SPLINE_PROGRAM, "t.ngc", &ParseOptions::default()).unwrap();
    let mut cut = p.toolpath.clone();
    cut.blocks.clear();
    for b in &p.toolpath.blocks {
        match b {
            Block::Move(m) if !m.pinned => {
                let halves: [Segment; 2] = match &m.segment {
                    Segment::Line(l) => {
                        let mid = l.eval(0.5);
                        [
                            ncsmooth::geom::Line::new(l.p0, mid).into(),
                            ncsmooth::geom::Line::new(mid, l.p1).into(),
                        ]
                    }
                    Segment::CubicBez(c) => {
                        let (a, b) = c.split(0.5);
                        [a.into(), b.into()]
                    }
                    other => panic!("unexpected {}", other.kind_name()),
                };
                for s in halves {
                    cut.blocks.push(Block::Move(m.with_segment(s)));
                }
            }
            other => cut.blocks.push(other.clone()),
        }
    }
    let chord = 0.002;
    let opts = RewriteOptions::new(5, chord);
    let text = rewrite(SPLINE_PROGRAM.as_bytes(), &p, &cut, &opts).unwrap();
    let text = String::from_utf8(text).unwrap();
    assert!(text.contains("G5.2 X21 Y8 P1 L4\n") && text.contains("G5.3\n"));
    assert!(
        !text.contains("G5 X10"),
        "the G5 lines were rewritten:\n{text}"
    );
    let back = parse_str(&text, "t.ngc", &ParseOptions::default())
        .unwrap_or_else(|e| panic!("{e}\n{text}"));
    assert!(back
        .toolpath
        .moves()
        .all(|m| !matches!(m.segment, Segment::CubicBez(_))));
    let dev = ncsmooth::verify::deviation(&back.toolpath, &p.toolpath, 1e-6);
    assert!(
        dev.output_to_programmed_mm <= chord + 1e-4 && dev.vertex_to_output_mm <= 1e-4,
        "{dev:?}\n{text}"
    );
}
