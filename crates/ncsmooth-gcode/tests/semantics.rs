//! Interpreter semantics on small hand-written programs: planes and arc directions with
//! exact midpoints, R arcs, full circles, helices, units, distance modes, parameters,
//! events and their order, extra axes, and located errors.
//!
//! These programs run on a known machine (LinuxCNC's standalone interpreter: every offset
//! zero, starting at machine zero), so that every position is known; what is known without
//! a machine model is tested in `frames.rs`.

use ncsmooth::geom::{ParamCurve, Segment, Vec3};
use ncsmooth::path::{Block, EventKind, MoveKind};
use ncsmooth::Units;
use ncsmooth_gcode::{
    parse_bytes, parse_str, MachineModel, ParseErrorKind, ParseOptions, Plane, Program,
};

const S: f64 = std::f64::consts::FRAC_1_SQRT_2 * 10.0;

fn known() -> ParseOptions {
    ParseOptions::with_machine(MachineModel::default())
}

/// `src` with a feed rate on its first line when it programs none (LinuxCNC refuses feed
/// moves without one), so that line numbers stay as written.
fn with_feed(src: &str) -> String {
    if src.contains(['F', 'f']) {
        return src.to_string();
    }
    match src.find('\n') {
        Some(i) => format!("{} F60{}", &src[..i], &src[i..]),
        None => format!("{src} F60"),
    }
}

fn parse(src: &str) -> Program {
    match parse_str(&with_feed(src), "t.ngc", &known()) {
        Ok(p) => p,
        Err(e) => panic!("{e}\n{src}"),
    }
}

fn err(src: &str) -> ncsmooth_gcode::ParseError {
    match parse_str(&with_feed(src), "t.ngc", &known()) {
        Ok(_) => panic!("expected an error for {src:?}"),
        Err(e) => e,
    }
}

fn close(a: Vec3, b: Vec3) -> bool {
    a.dist(b) < 1e-9
}

/// The last move's segment.
fn last(p: &Program) -> Segment {
    p.toolpath.moves().last().unwrap().segment.clone()
}

fn assert_arc(src: &str, end: Vec3, mid: Vec3, sweep_deg: f64) {
    let p = parse(src);
    let Segment::Arc(a) = last(&p) else {
        panic!("not an arc: {src}")
    };
    assert!(close(a.eval(1.0), end), "{src}: end {:?}", a.eval(1.0));
    assert!(close(a.eval(0.5), mid), "{src}: mid {:?}", a.eval(0.5));
    assert!(
        (a.sweep.to_degrees() - sweep_deg).abs() < 1e-9,
        "{src}: sweep {}",
        a.sweep.to_degrees()
    );
}

#[test]
fn g17_arc_directions() {
    // G3 = counter-clockwise seen from +Z.
    assert_arc(
        "G0 X10 Y0\nG3 X0 Y10 I-10 J0",
        Vec3::new(0.0, 10.0, 0.0),
        Vec3::new(S, S, 0.0),
        90.0,
    );
    assert_arc(
        "G0 X10 Y0\nG2 X0 Y10 I-10 J0",
        Vec3::new(0.0, 10.0, 0.0),
        Vec3::new(-S, -S, 0.0),
        270.0,
    );
}

#[test]
fn g18_arc_directions() {
    // ZX plane, normal +Y: G3 turns from +Z towards +X, so from +X towards -Z.
    assert_arc(
        "G0 X10 Y0 Z0\nG18 G3 X0 Z-10 I-10 K0",
        Vec3::new(0.0, 0.0, -10.0),
        Vec3::new(S, 0.0, -S),
        90.0,
    );
    assert_arc(
        "G0 X10 Y0 Z0\nG18 G2 X0 Z-10 I-10 K0",
        Vec3::new(0.0, 0.0, -10.0),
        Vec3::new(-S, 0.0, S),
        270.0,
    );
    assert_arc(
        "G0 X0 Z10\nG18 G3 X10 Z0 K-10",
        Vec3::new(10.0, 0.0, 0.0),
        Vec3::new(S, 0.0, S),
        90.0,
    );
}

#[test]
fn g19_arc_directions() {
    // YZ plane, normal +X: G3 turns from +Y towards +Z.
    assert_arc(
        "G0 X0 Y10 Z0\nG19 G3 Y0 Z10 J-10 K0",
        Vec3::new(0.0, 0.0, 10.0),
        Vec3::new(0.0, S, S),
        90.0,
    );
    assert_arc(
        "G0 X0 Y10 Z0\nG19 G2 Y0 Z10 J-10",
        Vec3::new(0.0, 0.0, 10.0),
        Vec3::new(0.0, -S, -S),
        270.0,
    );
}

#[test]
fn r_arcs() {
    // Short way (R > 0) clockwise: centre (10, 0).
    assert_arc(
        "G2 X10 Y10 R10",
        Vec3::new(10.0, 10.0, 0.0),
        Vec3::new(10.0 - S, S, 0.0),
        90.0,
    );
    // Long way (R < 0): centre (0, 10), 270 degrees.
    assert_arc(
        "G2 X10 Y10 R-10",
        Vec3::new(10.0, 10.0, 0.0),
        Vec3::new(-S, 10.0 + S, 0.0),
        270.0,
    );
    assert_arc(
        "G3 X10 Y10 R10",
        Vec3::new(10.0, 10.0, 0.0),
        Vec3::new(S, 10.0 - S, 0.0),
        90.0,
    );
    // G18 R arc: ZX plane, from +Z to +X the short way is G3 (about +Y).
    assert_arc(
        "G0 Z10\nG18 G3 X10 Z0 R10",
        Vec3::new(10.0, 0.0, 0.0),
        Vec3::new(S, 0.0, S),
        90.0,
    );
    // Half chord slightly over R (within 0.005 mm): a semicircle.
    let p = parse("G2 X10 Y0 R4.999");
    let Segment::Arc(a) = last(&p) else { panic!() };
    assert!((a.sweep - std::f64::consts::PI).abs() < 1e-12);
    assert!(close(a.eval(0.5), Vec3::new(5.0, 5.0, 0.0)));
    let e = err("G2 X10 Y0 R4");
    assert!(matches!(e.kind, ParseErrorKind::ArcRadiusTooSmall { .. }));
    let e = err("G2 X0 Y0 R4");
    assert!(matches!(e.kind, ParseErrorKind::ArcDegenerate { .. }));
}

#[test]
fn full_circles_turns_and_helices() {
    let p = parse("G0 X10\nG2 X10 Y0 I-10");
    let Segment::Arc(a) = last(&p) else { panic!() };
    assert!((a.sweep - std::f64::consts::TAU).abs() < 1e-12);
    assert!(close(a.eval(0.5), Vec3::new(-10.0, 0.0, 0.0)));
    let p = parse("G0 X10\nG3 I-10 J0 X10 P3");
    let Segment::Arc(a) = last(&p) else { panic!() };
    assert!((a.sweep - 3.0 * std::f64::consts::TAU).abs() < 1e-12);
    // Helix: Z moves along.
    let p = parse("G0 X10\nG3 X0 Y10 Z5 I-10");
    let Segment::Arc(a) = last(&p) else { panic!() };
    assert!(close(a.eval(1.0), Vec3::new(0.0, 10.0, 5.0)));
    assert!(close(a.eval(0.5), Vec3::new(S, S, 2.5)));
    // Helix in G19: X is the axial coordinate.
    let p = parse("G0 Y10\nG19 G3 Y0 Z10 X-3 J-10");
    let Segment::Arc(a) = last(&p) else { panic!() };
    assert!(close(a.eval(0.5), Vec3::new(-1.5, S, S)));
    let e = err("G0 X10\nG3 X10 I-10 P0");
    assert!(matches!(
        e.kind,
        ParseErrorKind::InvalidValue { letter: 'P', .. }
    ));
    let e = err("G0 X10\nG3 X10 I-10 P1.5");
    assert!(matches!(
        e.kind,
        ParseErrorKind::InvalidValue { letter: 'P', .. }
    ));
}

#[test]
fn arc_centre_modes_and_radius_check() {
    // G90.1: absolute centre.
    assert_arc(
        "G90.1\nG0 X20 Y10\nG3 X10 Y20 I10 J10",
        Vec3::new(10.0, 20.0, 0.0),
        Vec3::new(10.0 + S, 10.0 + S, 0.0),
        90.0,
    );
    // Back to incremental.
    assert_arc(
        "G90.1\nG91.1\nG0 X20 Y10\nG3 X10 Y20 I-10 J0",
        Vec3::new(10.0, 20.0, 0.0),
        Vec3::new(10.0 + S, 10.0 + S, 0.0),
        90.0,
    );
    // Within tolerance: accepted, ends exactly at the programmed point.
    let p = parse("G0 X10\nG3 X0 Y10.004 I-10");
    assert!(close(last(&p).end(), Vec3::new(0.0, 10.004, 0.0)));
    let e = err("G0 X10\nG3 X0 Y10.1 I-10");
    assert!(matches!(e.kind, ParseErrorKind::ArcRadiusMismatch { .. }));
    assert_eq!((e.line, e.column), (2, 1));
    let e = err("G2 X1 Y1");
    assert_eq!(e.kind, ParseErrorKind::ArcNoCentre);
    assert_eq!((e.line, e.column), (1, 1));
    let e = err("G2 X1 Y1 I1 R2");
    assert_eq!(e.kind, ParseErrorKind::ArcMixedFormat);
    // A full circle needs no axis word (LinuxCNC accepts `G2 I1`); an R arc does.
    let p = parse("G2 I1");
    let Segment::Arc(a) = last(&p) else { panic!() };
    assert!((a.sweep - std::f64::consts::TAU).abs() < 1e-12);
    let e = err("G2 R1");
    assert_eq!(e.kind, ParseErrorKind::ArcNoAxes);
}

#[test]
fn units_and_distance_modes() {
    let p = parse("G20\nG0 X1 Y2\nG1 X2 F10\nG2 X3 Y3 I0.5 J0.5\nG21\nG1 X10");
    let m: Vec<_> = p.toolpath.moves().collect();
    assert!(close(m[0].segment.end(), Vec3::new(25.4, 50.8, 0.0)));
    assert!((m[1].feed_mm_s.unwrap() - 254.0 / 60.0).abs() < 1e-12);
    let Segment::Arc(a) = &m[2].segment else {
        panic!()
    };
    assert!(close(a.center, Vec3::new(2.5 * 25.4, 2.5 * 25.4, 0.0)));
    assert!(close(m[3].segment.end(), Vec3::new(10.0, 76.2, 0.0)));
    assert_eq!(p.stats.units_seen, vec![Units::Inches, Units::Millimetres]);
    assert_eq!(p.toolpath.units, Units::Inches);
    // G91 incremental, then G90.
    let p = parse("G0 X1 Y1\nG91 G1 X1 Y1 F60\nX1\nG90 X0");
    let ends: Vec<_> = p.toolpath.moves().map(|m| m.segment.end()).collect();
    assert_eq!(
        ends,
        vec![
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(2.0, 2.0, 0.0),
            Vec3::new(3.0, 2.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0)
        ]
    );
    assert_eq!(p.toolpath.moves().nth(1).unwrap().feed_mm_s, Some(1.0));
    // The machine's start position.
    let p = parse_str(
        "G1 X1 F60",
        "t",
        &ParseOptions::with_machine(MachineModel {
            start: [0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            ..Default::default()
        }),
    )
    .unwrap();
    assert_eq!(p.toolpath.start, Vec3::new(0.0, 0.0, 5.0));
    assert_eq!(last(&p).start(), Vec3::new(0.0, 0.0, 5.0));
}

#[test]
fn lexical_liberties() {
    let p = parse("%\n/n10 g 0 1 x 1 0 . 5 (c) f 6 0 ; trailing\r\n y2\r\n%\n");
    let m: Vec<_> = p.toolpath.moves().collect();
    assert_eq!(m.len(), 2);
    assert_eq!(m[0].segment.end(), Vec3::new(10.5, 0.0, 0.0));
    assert_eq!(m[1].segment.end(), Vec3::new(10.5, 2.0, 0.0));
    assert_eq!(m[1].line, 3);
    assert_eq!(p.stats.lines, 4);
    let p = parse("G0 X1234.56789");
    assert_eq!(last(&p).end().x, 1234.56789);
}

#[test]
fn parameters_take_effect_after_the_line() {
    let p = parse("#2=-1.5\nG1 Z#2 F100\nG1 X[#2 * 2 + 1]");
    assert_eq!(p.toolpath.moves().next().unwrap().segment.end().z, -1.5);
    assert_eq!(last(&p).end().x, -2.0);
    // (On a known machine an unset parameter reads 0, as LinuxCNC's; without one it is an
    // error, which shows that the assignment has not happened yet.)
    let e = parse_str("#1=5 G0 X#1", "t", &ParseOptions::default()).unwrap_err();
    assert_eq!(e.kind, ParseErrorKind::UndefinedParameter { index: 1 });
    assert_eq!((e.line, e.column), (1, 10));
    let p = parse("#1=1\n#1=2 G0 X#1\nG0 Y#1");
    assert_eq!(last(&p).end(), Vec3::new(1.0, 2.0, 0.0));
    let p = parse("G0 X[ATAN[1]/[1]] Y[SQRT[2]**2] Z-ABS[-3]");
    assert!(close(last(&p).end(), Vec3::new(45.0, 2.0, -3.0)));
}

#[test]
fn events_in_order() {
    let p = parse("G1 X1 Y2 S1000 M3 F100 M8 T2 M6\nG4 P0.5\nG43 H1 Z5\nG0 X0 M30");
    let b = &p.toolpath.blocks;
    let texts: Vec<String> = b
        .iter()
        .map(|b| match b {
            Block::Event(e) => format!("{:?}:{}", e.kind, e.text),
            Block::Move(m) => format!("move:{}", m.line),
        })
        .collect();
    assert_eq!(
        texts,
        vec![
            "Spindle:S1000",
            "Tool:T2 M6",
            "Spindle:M3",
            "Coolant:M8",
            "move:1",
            "Dwell(0.5):G4 P0.5",
            "ToolOffset:G43 H1",
            "move:3",
            "move:4",
            "ProgramStop:M30",
        ]
    );
    let p = parse("G17 G90 G21 G40 G80 G64 P0.1 Q0.1 G54\nG20 G64 P0.001\nG61\nG49");
    let texts: Vec<&str> = p.toolpath.events().map(|e| e.text.as_str()).collect();
    assert_eq!(
        texts,
        vec![
            "G40",
            "G54",
            "G64 P0.1 Q0.1",
            "G80",
            "G20",
            "G64 P0.0254",
            "G61",
            "G49"
        ]
    );
    assert!(p.toolpath.events().all(|e| matches!(
        e.kind,
        EventKind::Other | EventKind::ToolOffset | EventKind::Units(_)
    )));
}

#[test]
fn slicer_codes_and_extra_axes() {
    let src = "M104 S200 T0\nG28\nG92 E0\nM82\nG1 F3600 E-4\nG1 X1 Y1 E1 F1200\nG1 E0.5\nM83\nG1 E-1\nG1 X2 E0.5\nM106 S255\nG28 X0\n";
    // A printer's home position is its firmware's business: without a machine model the
    // position after G28 is unknown, so the first XY move after it is untracked.
    let p = parse_str(src, "t.ngc", &ParseOptions::default()).unwrap();
    let texts: Vec<&str> = p.toolpath.events().map(|e| e.text.as_str()).collect();
    assert_eq!(
        texts,
        vec![
            "M104 S200 T0",
            "G28",
            "G28",
            "G92 E0",
            "M82",
            "G1 E-4 F3600",
            "G1 X1 Y1 E1 F1200",
            "G1 E0.5",
            "M83",
            "G1 E-0.5",
            "M106 S255",
            "G28 X0",
            "G28 X0"
        ]
    );
    // E-only moves and `G92 E` carry the extruder values they leave (absolute, mm) and
    // the rate (mm/s) for the planner and for smoothing.
    let kinds: Vec<&EventKind> = p
        .toolpath
        .events()
        .filter(|e| !matches!(e.kind, EventKind::Untracked { .. }))
        .map(|e| &e.kind)
        .collect();
    let e = |v: f64| [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, v];
    assert_eq!(kinds[2], &EventKind::ExtraReset { to: e(0.0) });
    assert_eq!(
        kinds[4],
        &EventKind::ExtraMove {
            to: e(-4.0),
            feed_per_s: Some(60.0)
        }
    );
    assert_eq!(
        kinds[5],
        &EventKind::ExtraMove {
            to: e(0.5),
            feed_per_s: Some(20.0)
        }
    );
    assert_eq!(
        kinds[7],
        &EventKind::ExtraMove {
            to: e(-0.5),
            feed_per_s: Some(20.0)
        }
    );
    let m: Vec<_> = p.toolpath.moves().collect();
    // G1 X2 E0.5, then the G28 X0 intermediate point (a known rapid).
    assert_eq!(m.len(), 2);
    assert_eq!(m[0].extra.unwrap()[6], 0.0); // -0.5 + 0.5 relative
    assert_eq!(p.stats.untracked, 3);
    assert_eq!(p.toolpath.extra_axes_mask, 1 << 6);
    assert_eq!(p.stats.g1, 2);
    assert!(p
        .stats
        .warnings
        .iter()
        .any(|w| w.line == 2 && w.message.contains("G28")));
    assert!(p
        .stats
        .warnings
        .iter()
        .any(|w| w.line == 12 && w.message.contains("G28")));
    // Extra axes before first use are None, after Some.
    let p = parse("G0 X1\nG0 X2 A90\nG0 X3");
    let m: Vec<_> = p.toolpath.moves().collect();
    assert_eq!(m[0].extra, None);
    assert_eq!(m[1].extra.unwrap()[0], 90.0);
    assert_eq!(m[2].extra.unwrap()[0], 90.0);
}

#[test]
fn g53_and_feed_warnings() {
    let p = parse("G0 X5 Y5 Z5\nG0 G53 Z-10.0\nG1 X1");
    let m: Vec<_> = p.toolpath.moves().collect();
    assert!(m[1].pinned && m[1].kind == MoveKind::Rapid);
    assert_eq!(m[1].segment.end(), Vec3::new(5.0, 5.0, -10.0));
    assert!(!m[2].pinned);
    // A feed move with no feed rate: LinuxCNC and grbl refuse it, so does ncsmooth.
    let e = parse_str("G0 X5\nG1 X1", "t", &known()).unwrap_err();
    assert_eq!((e.kind, e.line), (ParseErrorKind::NoFeedRate, 2));
    let e = parse_str("G0 X5 F0\nG2 X1 I-2", "t", &known()).unwrap_err();
    assert_eq!((e.kind, e.line), (ParseErrorKind::NoFeedRate, 2));
    // G53 is absolute even under G91 (LinuxCNC's find_ends).
    let p = parse("G0 X5 Y5 Z5\nG91 G0 G53 Z1");
    assert_eq!(last(&p).end(), Vec3::new(5.0, 5.0, 1.0));
    // Zero-length moves are kept and warned about.
    let p = parse("G1 X0 Y0 F100");
    assert_eq!(p.toolpath.move_count(), 1);
    assert_eq!(p.stats.zero_length_moves, 1);
    assert_eq!(p.stats.planes_seen, Vec::<Plane>::new());
}

#[test]
fn located_errors() {
    let e = err("G0 X0\nG1 X1 Y\n");
    assert_eq!(e.kind, ParseErrorKind::MissingValue { letter: 'Y' });
    assert_eq!((e.line, e.column), (2, 7));
    assert_eq!(e.to_string(), "t.ngc:2:7: missing value after 'Y'");
    let e = err("G1 X1..5");
    assert_eq!(e.kind, ParseErrorKind::MalformedNumber);
    assert_eq!((e.line, e.column, e.byte_range.clone()), (1, 5, 4..8));
    let e = err("G0 X1\n  G0 X2 (no end");
    assert_eq!(e.kind, ParseErrorKind::UnclosedComment);
    assert_eq!((e.line, e.column), (2, 9));
    let e = err("(é) G0 X1 $");
    assert_eq!((e.line, e.column), (1, 11));
    let e = parse_bytes(b"G0 X1\nG1 \xff X2", "b.ngc", &ParseOptions::default()).unwrap_err();
    assert_eq!(e.kind, ParseErrorKind::InvalidUtf8);
    assert_eq!((e.line, e.column, e.byte_range), (2, 4, 9..10));
    let e = err("HELLO");
    assert_eq!(e.kind, ParseErrorKind::MissingValue { letter: 'H' });
    for (src, word) in [
        ("G41 D1", "G41"),
        ("G42", "G42"),
        ("G93", "G93"),
        ("G95", "G95"),
        ("G33 Z1 K1", "G33"),
        ("G38.2 Z-1", "G38.2"),
        ("G76 P1 Z-1 I1 J1 K1", "G76"),
        ("G71 Q1", "G71"),
        ("G0 X1 M98 P100", "M98"),
    ] {
        match err(src).kind {
            ParseErrorKind::Unsupported { word: w, .. } => assert_eq!(w, word, "{src}"),
            k => panic!("{src}: {k:?}"),
        }
    }
    assert!(matches!(
        err("G12").kind,
        ParseErrorKind::UnknownWord { .. }
    ));
    assert!(matches!(
        err("G0 G1 X1").kind,
        ParseErrorKind::ModalConflict { .. }
    ));
    assert!(matches!(
        err("G0 X1 X2").kind,
        ParseErrorKind::DuplicateWord { letter: 'X' }
    ));
    assert!(matches!(err("G80\nX1").kind, ParseErrorKind::NoMotionMode));
    assert!(matches!(
        err("G1 X1 F-5").kind,
        ParseErrorKind::InvalidValue { letter: 'F', .. }
    ));
    assert!(matches!(
        err("G4").kind,
        ParseErrorKind::MissingWord { letter: 'P', .. }
    ));
}

#[test]
fn modal_groups_words_of_other_planes_and_exponents() {
    // Two codes of one modal group in a block are errors at the second code, as in
    // LinuxCNC; M7 with M8 (mist and flood) is the allowed pair.
    for (src, first, second, column) in [
        ("G90 G91 X1", "G90", "G91", 5),
        ("G17 G18", "G17", "G18", 5),
        ("G20 G21", "G20", "G21", 5),
        ("G90.1 G91.1", "G90.1", "G91.1", 7),
        ("G4 P1 G53 G0 X1", "G4", "G53", 7),
        ("M3 M5 S100", "M3", "M5", 4),
        ("M8 M9", "M8", "M9", 4),
        ("M0 M30", "M0", "M30", 4),
    ] {
        let e = err(src);
        assert_eq!(
            e.kind,
            ParseErrorKind::ModalConflict {
                first: first.into(),
                second: second.into()
            },
            "{src}"
        );
        assert_eq!((e.line, e.column), (1, column), "{src}");
    }
    let p = parse("M7 M8\nG80 G0 X1\nM3 M8 M6 T1 M61 Q1");
    assert!(p.toolpath.events().count() >= 5);
    let e = err("M3 M8 M6 M61 Q1 M48 T1");
    assert!(
        matches!(e.kind, ParseErrorKind::InvalidValue { letter: 'M', .. }),
        "{e}"
    );
    assert_eq!(e.column, 17);
    // A centre word of another plane on an arc is an error (LinuxCNC: "K word given for
    // arc in XY plane"); under G90.1 both centre words are needed.
    let e = err("G0 X10\nG3 X0 Y10 I-10 K1");
    assert!(
        matches!(&e.kind, ParseErrorKind::Unsupported { word, .. } if word == "K on a G17 arc"),
        "{e}"
    );
    assert_eq!((e.line, e.column), (2, 16));
    assert!(matches!(
        err("G18\nG0 X10\nG3 X0 Z10 I-10 J1").kind,
        ParseErrorKind::Unsupported { .. }
    ));
    let e = err("G90.1\nG0 X20 Y10\nG3 X10 Y20 I10");
    assert_eq!(
        e.kind,
        ParseErrorKind::MissingWord {
            code: "an arc under G90.1".into(),
            letter: 'J'
        }
    );
    // Exponent notation is not read as a number followed by an E-axis word.
    for (src, column) in [("G1 X1e400", 5), ("G1 X1 F1.5E+2", 10), ("G1 X2.E3", 6)] {
        let e = err(src);
        assert!(
            matches!(&e.kind, ParseErrorKind::Unsupported { word, .. } if word == "exponent notation"),
            "{src}: {e}"
        );
        assert_eq!(e.column, column, "{src}");
    }
    // With a space, E is the extruder axis of slicer files.
    let p = parse("G1 X1 E3 F600\nG1 X2 E 4");
    assert_eq!(p.toolpath.moves().count(), 2);
}

#[test]
fn non_utf8_bytes_in_comments_are_harmless() {
    // Windows-1252 degree and slashed-O signs in comments, as CAM posts write them.
    let src = b"(TOOL \xd8 6 mm, 90\xb0)\nG0 X1 ; note \xb0\nG1 X2 F100\n";
    let p = parse_bytes(src, "w.ngc", &known()).unwrap();
    assert_eq!(p.toolpath.moves().count(), 2);
    // Outside a comment the byte is still an error at its place.
    let e = parse_bytes(b"(\xb0)\nG0 X1 \xb0", "w.ngc", &ParseOptions::default()).unwrap_err();
    assert_eq!(e.kind, ParseErrorKind::InvalidUtf8);
    assert_eq!((e.line, e.column, e.byte_range), (2, 7, 10..11));
}

/// LinuxCNC's radius rule for centre-format arcs (its interpreter tests'
/// `README.arc-radius-tolerance`): refused when |r1 - r2| > 100 t_abs, or when
/// |r1 - r2| > t_abs and the relative error exceeds 0.1 %, with t_abs = 2 x 0.01 mm x
/// sqrt(2) in mm programs and 2 x 0.001 in x sqrt(2) in inch programs. (The interpreter
/// used to refuse anything above max(0.005 mm, 0.1 %).)
#[test]
fn arc_radius_rule_is_linuxcncs() {
    let arc = |units: &str, r: f64, dr: f64| {
        // Start at (r, 0), centre at the origin, end at (0, r + dr): radii r and r + dr.
        let src = format!("{units} G0 X{r} Y0 F100\nG3 X0 Y{} I-{r} J0", r + dr);
        parse_str(&src, "t.ngc", &known())
    };
    // 0.01 mm on a 10 mm arc: within t_abs = 0.0283 mm.
    assert!(arc("G21", 10.0, 0.01).is_ok());
    assert!(arc("G21", 10.0, 0.028).is_ok());
    // 0.03 mm on 10 mm: above t_abs and 0.3 %.
    let e = arc("G21", 10.0, 0.03).unwrap_err();
    assert!(
        matches!(e.kind, ParseErrorKind::ArcRadiusMismatch { .. }),
        "{e}"
    );
    // 0.5 mm on 1000 mm: above t_abs but only 0.05 %, and below 100 t_abs.
    assert!(arc("G21", 1000.0, 0.5).is_ok());
    // 3 mm on 5000 mm: 0.06 % but above 100 t_abs = 2.83 mm.
    assert!(arc("G21", 5000.0, 3.0).is_err());
    // Inch: t_abs = 0.00283 in.
    assert!(arc("G20", 1.0, 0.0028).is_ok());
    assert!(arc("G20", 1.0, 0.0029).is_err());
}

/// LinuxCNC's polar words (`find_ends`): `@` radius and `^` angle (degrees) about the
/// origin under G90; under G91 they change the current point's radius and angle about the
/// origin.
#[test]
fn polar_words() {
    let p = parse("G0 @10 ^90");
    assert!(close(last(&p).end(), Vec3::new(0.0, 10.0, 0.0)));
    let p = parse("G0 X10 Y0\nG1 ^90 F60");
    assert!(close(last(&p).end(), Vec3::new(0.0, 10.0, 0.0)));
    let p = parse("G0 X10 Y0\nG1 @5 F60");
    assert!(close(last(&p).end(), Vec3::new(5.0, 0.0, 0.0)));
    let p = parse("G0 X10 Y0\nG91 G1 @5 ^90 F60");
    assert!(close(last(&p).end(), Vec3::new(0.0, 15.0, 0.0)));
    assert!(err("G0 @10 X1").to_string().contains("polar"));
    assert!(err("G0 X0 Y0\nG1 @5 F60").to_string().contains("angle"));
}

/// Words no code of the block uses: D H I J K L P Q R are errors, named in slot order
/// (A..Z, @, ^) at their own word, as LinuxCNC refuses them.
#[test]
fn unused_words_are_errors() {
    for (src, letter, col) in [
        ("G0 X1 R2 D3", 'D', 10),
        ("G0 X1 Q2", 'Q', 7),
        ("G1 X1 L2 H1", 'H', 10),
        ("G0 X1 P2 K1", 'K', 10),
    ] {
        let e = err(src);
        assert!(
            matches!(e.kind, ParseErrorKind::UnusedWord { letter: l } if l == letter),
            "{src}: {e}"
        );
        assert!(e.to_string().contains(&format!(":1:{col}")), "{src}: {e}");
    }
    let p = parse("G21 G0 X1 Y2\nG1 X2 F100\nG2 X3 Y3 I0.5 J0.5");
    assert!(p.stats.warnings.is_empty(), "{:?}", p.stats.warnings);
}
