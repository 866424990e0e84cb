//! Writer tests: parse -> write -> parse keeps the moves (within 1e-6 mm at end points and
//! arc midpoints, with 6 decimals: 4 decimals round by up to 5e-5 mm, more than the
//! 1e-6 mm checked here), and flattening keeps curves within `chord_mm`.

use ncsmooth::geom::{Arc, CubicBez, Line, ParamCurve, Segment, Vec3};
use ncsmooth::path::{Block, Event, EventKind, Move, Toolpath};
use ncsmooth_gcode::{parse_str, write, MachineModel, ParseOptions, Program, WriteOptions};
use proptest::prelude::*;

/// Parses on a known machine (every position known): the writer tested here writes
/// toolpaths without source; `rewrite.rs` tests writing into a program's own text.
fn parse(src: &str) -> Program {
    match parse_str(
        src,
        "rt.ngc",
        &ParseOptions::with_machine(MachineModel::default()),
    ) {
        Ok(p) => p,
        Err(e) => panic!("{e}\n---\n{src}"),
    }
}

fn opts6() -> WriteOptions {
    WriteOptions {
        decimals: 6,
        ..Default::default()
    }
}

/// The blocks of `tp` but zero-length moves, which the writer does not write (the reader
/// would run an empty block: a repeated `G1 X1`, or a `G0 G53 Z` to where Z is).
fn moving_blocks(tp: &Toolpath) -> Vec<&Block> {
    tp.blocks
        .iter()
        .filter(|b| !matches!(b, Block::Move(m) if m.segment.start() == m.segment.end()))
        .collect()
}

/// Asserts two toolpaths have the same blocks (zero-length moves left out) within `tol` mm.
fn assert_same(a: &Toolpath, b: &Toolpath, tol: f64, ctx: &str) {
    let (a, b) = (moving_blocks(a), moving_blocks(b));
    assert_eq!(a.len(), b.len(), "block count\n{ctx}");
    for (i, (&x, &y)) in a.iter().zip(&b).enumerate() {
        match (x, y) {
            (Block::Event(e), Block::Event(f)) => {
                assert_eq!(e.text, f.text, "event {i}\n{ctx}");
                assert_eq!(e.kind, f.kind, "event {i}\n{ctx}");
            }
            (Block::Move(m), Block::Move(n)) => {
                assert_eq!(m.kind, n.kind, "move {i}\n{ctx}");
                match (m.feed_mm_s, n.feed_mm_s) {
                    (Some(f), Some(g)) => assert!((f - g).abs() <= 1e-9 * f.max(1.0), "feed {i}"),
                    (f, g) => assert_eq!(f, g, "feed {i}\n{ctx}"),
                }
                for t in [0.0, 0.25, 0.5, 0.75, 1.0] {
                    let (p, q) = (m.segment.eval(t), n.segment.eval(t));
                    assert!(
                        p.dist(q) <= tol,
                        "move {i} (line {}) at t={t}: {p:?} vs {q:?} ({})\n{ctx}",
                        m.line,
                        p.dist(q)
                    );
                }
                assert_eq!(
                    m.segment.kind_name(),
                    n.segment.kind_name(),
                    "move {i}\n{ctx}"
                );
                if let (Segment::Arc(a), Segment::Arc(b)) = (&m.segment, &n.segment) {
                    assert!((a.sweep - b.sweep).abs() < 1e-6, "sweep {i}\n{ctx}");
                }
                match (m.extra, n.extra) {
                    (Some(e), Some(f)) => {
                        assert!(e.iter().zip(f).all(|(u, v)| (u - v).abs() <= tol))
                    }
                    (e, f) => assert_eq!(e, f, "extra {i}\n{ctx}"),
                }
            }
            _ => panic!("block {i} differs in type\n{ctx}"),
        }
    }
}

#[derive(Clone, Debug)]
enum Op {
    Line {
        rapid: bool,
        to: [i32; 3],
    },
    Arc {
        plane: u8,
        ccw: bool,
        off: [i32; 2],
        angle: i32,
        axial: i32,
        turns: u32,
    },
    Feed(i32),
    Event(usize),
    G53Z(i32),
    E(i32),
}

const EVENTS: [&str; 8] = [
    "M3 S1000",
    "M5",
    "M8",
    "M9",
    "G4 P0.5",
    "T2 M6",
    "G64 P0.01",
    "M1",
];

fn op() -> impl Strategy<Value = Op> {
    let c = -50_000i32..50_000;
    prop_oneof![
        4 => (any::<bool>(), [c.clone(), c.clone(), c.clone()]).prop_map(|(rapid, to)| Op::Line { rapid, to }),
        4 => (0u8..3, any::<bool>(), [c.clone(), c.clone()], 1i32..=360, -5000i32..5000, 1u32..3)
            .prop_map(|(plane, ccw, off, angle, axial, turns)| Op::Arc { plane, ccw, off, angle, axial, turns }),
        1 => (1i32..10_000_000).prop_map(Op::Feed),
        1 => (0..EVENTS.len()).prop_map(Op::Event),
        1 => c.clone().prop_map(Op::G53Z),
        1 => c.prop_map(Op::E),
    ]
}

/// Program text (mm, 3 decimals) for `ops`; arcs are computed from the current position.
fn program(ops: &[Op]) -> String {
    let mut s = String::from("G21 G90 F1000\n");
    let mut pos = [0i64; 3]; // thousandths of a mm
    let k = |v: i64| format!("{}", v as f64 / 1000.0);
    for op in ops {
        match op {
            Op::Line { rapid, to } => {
                let g = if *rapid { "G0" } else { "G1" };
                s += &format!(
                    "{g} X{} Y{} Z{}\n",
                    k(to[0] as i64),
                    k(to[1] as i64),
                    k(to[2] as i64)
                );
                pos = [to[0] as i64, to[1] as i64, to[2] as i64];
            }
            Op::Arc {
                plane,
                ccw,
                off,
                angle,
                axial,
                turns,
            } => {
                // (first, second, normal) axis indices and letters.
                let (a, b, n, pl) = match plane {
                    0 => (0, 1, 2, "G17"),
                    1 => (2, 0, 1, "G18"),
                    _ => (1, 2, 0, "G19"),
                };
                let r = ((off[0] as f64).powi(2) + (off[1] as f64).powi(2)).sqrt();
                if r < 1000.0 {
                    continue;
                }
                let ca = pos[a] as f64 + off[0] as f64;
                let cb = pos[b] as f64 + off[1] as f64;
                let th0 = (-(off[1] as f64)).atan2(-(off[0] as f64));
                let d = (*angle as f64).to_radians() * if *ccw { 1.0 } else { -1.0 };
                let mut end = pos;
                if *angle < 360 {
                    end[a] = (ca + r * (th0 + d).cos()).round() as i64;
                    end[b] = (cb + r * (th0 + d).sin()).round() as i64;
                    if end[a] == pos[a] && end[b] == pos[b] {
                        continue;
                    }
                }
                end[n] = pos[n] + *axial as i64;
                let letters = ['X', 'Y', 'Z'];
                let centre = ['I', 'J', 'K'];
                s += &format!(
                    "{pl} {} {}{} {}{} {}{} {}{} {}{}",
                    if *ccw { "G3" } else { "G2" },
                    letters[a],
                    k(end[a]),
                    letters[b],
                    k(end[b]),
                    letters[n],
                    k(end[n]),
                    centre[a],
                    k(off[0] as i64),
                    centre[b],
                    k(off[1] as i64),
                );
                if *turns > 1 {
                    s += &format!(" P{turns}");
                }
                s.push('\n');
                pos = end;
            }
            Op::Feed(f) => s += &format!("F{}\n", k(*f as i64)),
            Op::Event(i) => {
                s += EVENTS[*i];
                s.push('\n');
            }
            Op::G53Z(z) => {
                s += &format!("G0 G53 Z{}\n", k(*z as i64));
                pos[2] = *z as i64;
            }
            Op::E(e) => {
                s += &format!("G1 X{} E{}\n", k(pos[0] + 1000), k(*e as i64));
                pos[0] += 1000;
            }
        }
    }
    s
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn parse_write_parse_keeps_moves(ops in proptest::collection::vec(op(), 1..40)) {
        let src = program(&ops);
        let first = parse(&src);
        let text = write(&first.toolpath, &opts6());
        let second = parse(&text);
        assert_same(&first.toolpath, &second.toolpath, 1e-6, &format!("{src}\n--- written:\n{text}"));
        // The writer is deterministic.
        prop_assert_eq!(write(&first.toolpath, &opts6()), text);
    }
}

/// Distance from `p` to the polyline `pts`.
fn dist_to_polyline(p: Vec3, pts: &[Vec3]) -> f64 {
    pts.windows(2)
        .map(|w| Line::new(w[0], w[1]).dist_sq(p).sqrt())
        .fold(f64::INFINITY, f64::min)
}

fn written_polyline(tp: &Toolpath, opts: &WriteOptions) -> Vec<Vec3> {
    let p = parse(&write(tp, opts));
    let mut pts = vec![p.toolpath.start];
    for m in p.toolpath.moves() {
        assert!(matches!(m.segment, Segment::Line(_)));
        if m.is_rapid() {
            pts.clear();
        }
        pts.push(m.segment.end());
    }
    pts
}

#[test]
fn cubic_bezier_is_flattened_within_chord() {
    let c = CubicBez::new(
        Vec3::ZERO,
        Vec3::new(10.0, 20.0, 1.0),
        Vec3::new(30.0, -10.0, 2.0),
        Vec3::new(40.0, 5.0, 0.0),
    );
    let mut tp = Toolpath::new(Vec3::ZERO);
    tp.push_move(Move::feed(c, Some(20.0), 1));
    for (chord, decimals) in [(0.001, 6), (0.01, 6), (0.001, 4)] {
        let opts = WriteOptions {
            chord_mm: chord,
            decimals,
            ..Default::default()
        };
        let pts = written_polyline(&tp, &opts);
        assert!(pts.len() > 10);
        let rounding = 0.5 * 10f64.powi(-(decimals as i32)) * 3f64.sqrt();
        for i in 0..=2000 {
            let p = c.eval(i as f64 / 2000.0);
            let d = dist_to_polyline(p, &pts);
            assert!(d <= chord + rounding, "chord {chord}: {d} at {i}");
        }
        assert!(pts.last().unwrap().dist(c.eval(1.0)) <= rounding);
    }
}

#[test]
fn off_axis_arcs_are_flattened_and_axis_arcs_kept() {
    let tilted = Arc::from_center(
        Vec3::new(10.0, 10.0, 0.0),
        Vec3::new(0.0, 10.0, 10.0),
        Vec3::ZERO,
        Vec3::new(1.0, -1.0, 1.0),
        true,
        0,
    )
    .unwrap();
    assert!(tilted.axial.norm() < 1e-12);
    let mut tp = Toolpath::new(Vec3::ZERO);
    tp.push_move(Move::rapid(Line::new(Vec3::ZERO, tilted.eval(0.0)), 1));
    tp.push_move(Move::feed(tilted, Some(10.0), 2));
    let opts = WriteOptions {
        decimals: 6,
        ..Default::default()
    };
    let pts = written_polyline(&tp, &opts);
    for i in 0..=1000 {
        let d = dist_to_polyline(tilted.eval(i as f64 / 1000.0), &pts);
        assert!(d <= 0.001 + 1e-6, "{d}");
    }
    // A G18 arc comes back as a G18 arc (with a plane word) and a G2 in G19.
    let p = parse("G0 X10 F60\nG18 G3 X0 Z-10 I-10\nG19 G2 Y5 Z-5 J5 K0\nG17 G1 X1");
    let text = write(&p.toolpath, &WriteOptions::default());
    assert!(text.contains("G18 G3 X0 Z-10 I-10 K0"), "{text}");
    assert!(text.contains("G19 G2 Y5 Z-5 J5 K0"), "{text}");
    assert!(text.ends_with("K0\nG1 X1\n"), "{text}");
}

#[test]
fn writer_format_details() {
    let src =
        "G20\nG0 X1 Y1\nG1 X2 F10\nG1 Y2\nG1 Y3 F20\nM3 S100\nG0 G53 Z-0.5\nG1 X0\nG1 A90 X1\n";
    let p = parse(src);
    let opts = WriteOptions {
        line_numbers: true,
        header: Some("made by (test)\nsecond".into()),
        ..Default::default()
    };
    let text = write(&p.toolpath, &opts);
    let expected = "(made by [test])
(second)
N1 G21 G90 G94 G17
N2 (source units G20)
N3 G0 X25.4 Y25.4 Z0
N4 G1 X50.8 F254
N5 G1 Y50.8
N6 G1 Y76.2 F508
N7 S100
N8 M3
N9 G0 Z-12.7
N10 G1 X0
N11 G1 X25.4 A90
";
    assert_eq!(text, expected);
    // No `-0`, no exponent.
    let mut tp = Toolpath::new(Vec3::ZERO);
    tp.push_move(Move::feed(
        Line::new(Vec3::ZERO, Vec3::new(-1e-9, 1e-12, 123456789.0)),
        Some(1e-9),
        1,
    ));
    let t = write(&tp, &WriteOptions::default());
    assert!(!t.contains("-0 ") && !t.contains('e'), "{t}");
    // Full circles and multi-turn helices.
    let p = parse("G0 X10 F60\nG2 X10 I-10\nG3 X10 Z3 I-10 P3");
    let t = write(&p.toolpath, &WriteOptions::default());
    assert!(t.contains("G2 X10 Y0 I-10 J0 F60\n"), "{t}");
    assert!(t.contains("G3 X10 Y0 Z3 I-10 J0 P3\n"), "{t}");
    // M83 is written as M82 (the writer writes absolute E), events keep their order.
    let mut tp = Toolpath::new(Vec3::ZERO);
    tp.push_event(Event {
        line: 1,
        kind: EventKind::Other,
        text: "M83".into(),
    });
    assert!(write(&tp, &WriteOptions::default()).contains("\nM82 ("));
}
