//! Canned cycles against LinuxCNC: each expected trace below is what LinuxCNC 2.9's
//! standalone interpreter (`rs274 -g`) printed for the program (its STRAIGHT_TRAVERSE,
//! STRAIGHT_FEED, DWELL and spindle commands), written as ncsmooth's moves and events.
//! LinuxCNC also prints a traverse to where the tool already is when a cycle repeats in
//! place; ncsmooth makes no move for it (the canonical record keeps it).

use ncsmooth::geom::{ParamCurve, Vec3};
use ncsmooth::path::{Block, EventKind, MoveKind};
use ncsmooth_gcode::{
    parse_str, rewrite, Canon, MachineModel, ParseErrorKind, ParseOptions, Program, RewriteOptions,
};

/// Parses on LinuxCNC's standalone machine (every position known), recording canon.
fn parse(src: &str) -> Program {
    let mut opts = ParseOptions::with_machine(MachineModel::default());
    opts.canon = true;
    parse_str(src, "t.ngc", &opts).unwrap_or_else(|e| panic!("{e}\n{src}"))
}

fn err(src: &str) -> ncsmooth_gcode::ParseError {
    match parse_str(
        src,
        "t.ngc",
        &ParseOptions::with_machine(MachineModel::default()),
    ) {
        Ok(_) => panic!("expected an error for\n{src}"),
        Err(e) => e,
    }
}

fn fmt(p: Vec3) -> String {
    let f = |v: f64| {
        let s = format!("{v:.4}");
        if s == "-0.0000" {
            "0.0000".to_string()
        } else {
            s
        }
    };
    format!("{} {} {}", f(p.x), f(p.y), f(p.z))
}

/// The moves and events of the lines from `from_line` on: `G0 x y z` / `G1 x y z` (end
/// points), `dwell t`, `spindle M5`, `stop M0`, `untracked <text>`. Checks that the moves
/// chain (between untracked events) and, with `cycles_only`, that every move listed is
/// pinned.
fn trace(p: &Program, from_line: u32, cycles_only: bool) -> Vec<String> {
    let mut out = Vec::new();
    let mut prev: Option<Vec3> = None;
    for b in &p.toolpath.blocks {
        match b {
            Block::Move(m) => {
                if let Some(q) = prev {
                    assert!(
                        q.dist(m.segment.start()) < 1e-9,
                        "gap before line {}: {q:?} -> {:?}",
                        m.line,
                        m.segment.start()
                    );
                }
                prev = Some(m.segment.end());
                if m.line < from_line {
                    continue;
                }
                assert!(
                    m.pinned || !cycles_only,
                    "cycle move of line {} not pinned",
                    m.line
                );
                let g = if m.kind == MoveKind::Rapid {
                    "G0"
                } else {
                    "G1"
                };
                out.push(format!("{g} {}", fmt(m.segment.end())));
            }
            Block::Event(e) if matches!(e.kind, EventKind::Untracked { .. }) => {
                prev = None;
                if e.line >= from_line {
                    out.push(format!("untracked {}", e.text));
                }
            }
            Block::Event(e) if e.line >= from_line => match &e.kind {
                EventKind::Dwell(t) => out.push(format!("dwell {t}")),
                EventKind::Spindle => out.push(format!("spindle {}", e.text)),
                EventKind::ProgramStop => out.push(format!("stop {}", e.text)),
                _ => {}
            },
            Block::Event(_) => {}
        }
    }
    out
}

fn assert_trace(src: &str, from_line: u32, want: &[&str]) {
    let p = parse(src);
    let got = trace(&p, from_line, true);
    assert_eq!(got, want, "\n{src}");
}

#[test]
fn g81_repeats_under_g91() {
    // R is relative to the Z where the cycle starts, the bottom to R, X Y step per repeat.
    assert_trace(
        "G21 G17 G90 G99 F100\nG0 X0 Y0 Z10\nG91 G81 X5 Y2 Z-3 R-8 L3\n",
        3,
        &[
            "G0 5.0000 2.0000 10.0000",
            "G0 5.0000 2.0000 2.0000",
            "G1 5.0000 2.0000 -1.0000",
            "G0 5.0000 2.0000 2.0000",
            "G0 10.0000 4.0000 2.0000",
            "G1 10.0000 4.0000 -1.0000",
            "G0 10.0000 4.0000 2.0000",
            "G0 15.0000 6.0000 2.0000",
            "G1 15.0000 6.0000 -1.0000",
            "G0 15.0000 6.0000 2.0000",
        ],
    );
}

#[test]
fn g83_pecks_retract_to_r_and_come_back_with_clearance() {
    // Pecks of 3 from R1: -2, -5, then the bottom -7; back down to 0.254 mm (0.010 inch)
    // above each depth reached; G98 retracts to the starting Z5.
    assert_trace(
        "G21 G90 F100\nG0 X0 Y0 Z5\nG98 G83 X1 Y1 Z-7 R1 Q3\n",
        3,
        &[
            "G0 1.0000 1.0000 5.0000",
            "G0 1.0000 1.0000 1.0000",
            "G1 1.0000 1.0000 -2.0000",
            "G0 1.0000 1.0000 1.0000",
            "G0 1.0000 1.0000 -1.7460",
            "G1 1.0000 1.0000 -5.0000",
            "G0 1.0000 1.0000 1.0000",
            "G0 1.0000 1.0000 -4.7460",
            "G1 1.0000 1.0000 -7.0000",
            "G0 1.0000 1.0000 5.0000",
        ],
    );
}

#[test]
fn g73_pecks_retract_by_the_clearance_only() {
    assert_trace(
        "G21 G90 F100\nG0 X0 Y0 Z5\nG73 X2 Y1 Z-7 R1 Q3\n",
        3,
        &[
            "G0 2.0000 1.0000 5.0000",
            "G0 2.0000 1.0000 1.0000",
            "G1 2.0000 1.0000 -2.0000",
            "G0 2.0000 1.0000 -1.7460",
            "G1 2.0000 1.0000 -5.0000",
            "G0 2.0000 1.0000 -4.7460",
            "G1 2.0000 1.0000 -7.0000",
            "G0 2.0000 1.0000 1.0000",
        ],
    );
}

#[test]
fn peck_clearance_is_in_the_program_units() {
    // Inch program: 0.010 inch above each depth.
    let p = parse("G20 G90 F10\nG0 X0 Y0 Z1\nG83 X1 Y1 Z-0.3 R0.1 Q0.1\n");
    let z: Vec<f64> = p
        .canon
        .iter()
        .filter_map(|c| match c {
            Canon::Traverse { end } | Canon::Feed { end } => Some(end[2]),
            _ => None,
        })
        .collect();
    // rs274: ... feed 0, up 0.1, down 0.01, feed -0.1, up 0.1, down -0.09, feed -0.2,
    // up 0.1, down -0.19, feed -0.3, up to R (G99).
    let want = [
        1.0, 1.0, 0.1, 0.0, 0.1, 0.01, -0.1, 0.1, -0.09, -0.2, 0.1, -0.19, -0.3, 0.1,
    ];
    assert_eq!(z.len(), want.len(), "{z:?}");
    for (a, b) in z.iter().zip(want) {
        assert!((a - b).abs() < 1e-9, "{z:?}");
    }
}

#[test]
fn g98_and_g99_retract_heights() {
    // G98: back to the Z where the run of cycles started (10), even for the second hole;
    // G99: to R. A run that starts below R first rises to R, which then is the old Z; the
    // second block of that run rises again from its start level (a zero-length move,
    // which ncsmooth leaves out).
    let p = parse(
        "G21 G90 F100\nG0 X0 Y0 Z10\nG98 G81 X1 Z-1 R2\nX2\nG99 G81 X3 Z-1 R2\nX4\n\
         G0 Z1\nG98 G81 X5 R3 Z0\nX6\n",
    );
    assert!(p
        .toolpath
        .moves()
        .all(|m| m.pinned == (m.line >= 3 && m.line != 7)));
    assert_eq!(
        trace(&p, 3, false),
        [
            "G0 1.0000 0.0000 10.0000",
            "G0 1.0000 0.0000 2.0000",
            "G1 1.0000 0.0000 -1.0000",
            "G0 1.0000 0.0000 10.0000",
            "G0 2.0000 0.0000 10.0000",
            "G0 2.0000 0.0000 2.0000",
            "G1 2.0000 0.0000 -1.0000",
            "G0 2.0000 0.0000 10.0000",
            "G0 3.0000 0.0000 10.0000",
            "G0 3.0000 0.0000 2.0000",
            "G1 3.0000 0.0000 -1.0000",
            "G0 3.0000 0.0000 2.0000",
            "G0 4.0000 0.0000 2.0000",
            "G1 4.0000 0.0000 -1.0000",
            "G0 4.0000 0.0000 2.0000",
            // G0 Z1, then up to R3 before the next run.
            "G0 4.0000 0.0000 1.0000",
            "G0 4.0000 0.0000 3.0000",
            "G0 5.0000 0.0000 3.0000",
            "G1 5.0000 0.0000 0.0000",
            "G0 5.0000 0.0000 3.0000",
            "G0 6.0000 0.0000 3.0000",
            "G1 6.0000 0.0000 0.0000",
            "G0 6.0000 0.0000 3.0000",
        ]
    );
}

#[test]
fn the_g0_z1_line_is_not_part_of_the_cycles() {
    let p = parse("G21 G90 F100\nG0 X0 Y0 Z10\nG98 G81 X1 Z-1 R2\nG0 Z1\n");
    let last = p.toolpath.moves().last().unwrap();
    assert_eq!(last.line, 4);
    assert!(
        !last.pinned,
        "an ordinary G0 after a cycle stays smoothable"
    );
}

#[test]
fn dwells_spindle_and_sticky_words() {
    // G82's P and the R and Z are reused by the next block; G84 takes the last P of any
    // cycle (G89's 2 s); G88 stops the program for a manual retract.
    assert_trace(
        "G21 G90 F100 S1000 M3\nG0 X0 Y0 Z5\nG82 X1 Y0 Z-2 R1 P0.5\nX2\n\
         G86 X3 Z-2 R1 P1.5\nG89 X4 Z-2 R1 P2\nG85 X5 Z-2 R1\nG84 X6 Z-2 R1\n\
         G88 X7 Z-2 R1 P0.25\n",
        3,
        &[
            "G0 1.0000 0.0000 5.0000",
            "G0 1.0000 0.0000 1.0000",
            "G1 1.0000 0.0000 -2.0000",
            "dwell 0.5",
            "G0 1.0000 0.0000 1.0000",
            "G0 2.0000 0.0000 1.0000",
            "G1 2.0000 0.0000 -2.0000",
            "dwell 0.5",
            "G0 2.0000 0.0000 1.0000",
            // G86
            "G0 3.0000 0.0000 1.0000",
            "G1 3.0000 0.0000 -2.0000",
            "dwell 1.5",
            "spindle M5",
            "G0 3.0000 0.0000 1.0000",
            "spindle M3",
            // G89
            "G0 4.0000 0.0000 1.0000",
            "G1 4.0000 0.0000 -2.0000",
            "dwell 2",
            "G1 4.0000 0.0000 1.0000",
            // G85
            "G0 5.0000 0.0000 1.0000",
            "G1 5.0000 0.0000 -2.0000",
            "G1 5.0000 0.0000 1.0000",
            // G84: feed in, reverse, dwell, feed out, forward again
            "G0 6.0000 0.0000 1.0000",
            "G1 6.0000 0.0000 -2.0000",
            "spindle M5",
            "spindle M4",
            "dwell 2",
            "G1 6.0000 0.0000 1.0000",
            "spindle M5",
            "spindle M3",
            // G88
            "G0 7.0000 0.0000 1.0000",
            "G1 7.0000 0.0000 -2.0000",
            "dwell 0.25",
            "spindle M5",
            "stop M0",
            "spindle M3",
        ],
    );
}

#[test]
fn after_g88_the_drilling_axis_is_unknown() {
    // The operator retracted by hand: the next move from there is kept as programmed.
    let p = parse("G21 G90 F100 S1000 M3\nG0 X0 Y0 Z5\nG88 X7 Y0 Z-2 R1 P0.25\nG0 Z5\nG0 X1\n");
    let t = trace(&p, 4, false);
    assert_eq!(t, ["untracked G0 Z5", "G0 1.0000 0.0000 5.0000"]);
}

#[test]
fn g87_back_boring() {
    // I J offset the hole for the way down and up; K is the top of the bore (under G91
    // above the bottom). The spindle turns counter-clockwise and is oriented twice.
    assert_trace(
        "G21 G90 F100 S1000 M4\nG0 X0 Y0 Z5\nG87 X1 Y2 Z-3 R1 I0.5 J-0.5 K-1\n\
         G91 G87 X1 Z-2 R-1 K0.5\n",
        3,
        &[
            "G0 1.0000 2.0000 5.0000",
            "G0 1.0000 2.0000 1.0000",
            "G0 1.5000 1.5000 1.0000",
            "spindle M5",
            "spindle M19 R0",
            "G0 1.5000 1.5000 -3.0000",
            "G0 1.0000 2.0000 -3.0000",
            "spindle M4",
            "G1 1.0000 2.0000 -1.0000",
            "G1 1.0000 2.0000 -3.0000",
            "spindle M5",
            "spindle M19 R0",
            "G0 1.5000 1.5000 -3.0000",
            "G0 1.5000 1.5000 1.0000",
            "G0 1.0000 2.0000 1.0000",
            "spindle M4",
            // G91: R = 5 - 1 = 4 (from the Z where the run started), bottom 4 - 2 = 2,
            // top 2 + 0.5; the offsets are sticky.
            "G0 2.0000 2.0000 4.0000",
            "G0 2.5000 1.5000 4.0000",
            "spindle M5",
            "spindle M19 R0",
            "G0 2.5000 1.5000 2.0000",
            "G0 2.0000 2.0000 2.0000",
            "spindle M4",
            "G1 2.0000 2.0000 2.5000",
            "G1 2.0000 2.0000 2.0000",
            "spindle M5",
            "spindle M19 R0",
            "G0 2.5000 1.5000 2.0000",
            "G0 2.5000 1.5000 4.0000",
            "G0 2.0000 2.0000 4.0000",
            "spindle M4",
        ],
    );
}

#[test]
fn g84_in_g19_feeds_to_linuxcnc_s_permuted_points() {
    // LinuxCNC 2.9 feeds to (X, Y, Z) = (Z of the hole, bottom, Y of the hole) under G19;
    // its interpreter then takes the tool to be at the hole, so the axes are unknown here
    // and the next move is kept as programmed.
    assert_trace(
        "G21 G19 G90 F100 S1000 M3\nG0 X5 Y0 Z0\nG84 X-1 Y1 Z2 R1\nG0 X5 Y0 Z0\n",
        3,
        &[
            "G0 5.0000 1.0000 2.0000",
            "G0 1.0000 1.0000 2.0000",
            "G1 2.0000 -1.0000 1.0000",
            "spindle M5",
            "spindle M4",
            "dwell 0",
            "G1 2.0000 1.0000 1.0000",
            "spindle M5",
            "spindle M3",
            "untracked G0 X5 Y0 Z0",
        ],
    );
}

#[test]
fn cycles_in_the_g18_plane_drill_along_y() {
    // G18: the plane axes are Z and X, Y is drilled; G98 returns to the old Y.
    assert_trace(
        "G21 G18 G90 G98 F100\nG0 X0 Y5 Z0\nG81 X1 Z2 Y-1 R1\n",
        3,
        &[
            "G0 1.0000 5.0000 2.0000",
            "G0 1.0000 1.0000 2.0000",
            "G1 1.0000 -1.0000 2.0000",
            "G0 1.0000 5.0000 2.0000",
        ],
    );
}

#[test]
fn unknown_start_makes_the_block_untracked() {
    // No machine model: Z was never set. The block is one untracked event; afterwards X
    // and Y are the hole's and Z is R (G99), all known, but the next block still depends
    // on the unknown starting level (LinuxCNC's "old Z") and stays untracked too.
    let src = "G21 G90 F100\nG0 X0 Y0\nG81 X1 Y1 Z-1 R2\nX2\nG80\nG0 Z5\nG81 X3 Z-1 R2\nX4\n";
    let p = parse_str(src, "t.ngc", &ParseOptions::default()).unwrap();
    let t = trace(&p, 3, false);
    assert_eq!(
        t,
        [
            "untracked G81 X1 Y1 Z-1 R2",
            "untracked X2",
            "G0 2.0000 1.0000 5.0000",
            "G0 3.0000 1.0000 5.0000",
            "G0 3.0000 1.0000 2.0000",
            "G1 3.0000 1.0000 -1.0000",
            "G0 3.0000 1.0000 2.0000",
            "G0 4.0000 1.0000 2.0000",
            "G1 4.0000 1.0000 -1.0000",
            "G0 4.0000 1.0000 2.0000",
        ]
    );
    assert!(p.toolpath.moves().filter(|m| m.line != 6).all(|m| m.pinned));
    // The G0 Z5 of line 6 is an ordinary move (not pinned by the cycles around it).
    let g0 = p.toolpath.moves().find(|m| m.line == 6).unwrap();
    assert!(!g0.pinned);
}

#[test]
fn untracked_cycle_with_unknown_plane_axes() {
    // X and Y never set: the first hole's approach cannot be placed; the block after it is
    // known again.
    let src = "G21 G90 F100\nG0 Z5\nG81 X1 Y1 Z-1 R2\nX2\n";
    let p = parse_str(src, "t.ngc", &ParseOptions::default()).unwrap();
    assert_eq!(
        trace(&p, 3, true),
        [
            "untracked G81 X1 Y1 Z-1 R2",
            "G0 2.0000 1.0000 2.0000",
            "G1 2.0000 1.0000 -1.0000",
            "G0 2.0000 1.0000 2.0000",
        ]
    );
}

#[test]
fn errors_are_located_on_the_block() {
    let cases: [(&str, u32, u32, &str); 8] = [
        ("G0 Z1\nG81 X1 Z2 R1 F10\n", 2, 1, "R less than Z"),
        ("G0 Z1\nG81 X1 R1 F10\n", 2, 1, "Z value unspecified"),
        (
            "G0 Z1\nG81 X1 Z-1 F10\n",
            2,
            1,
            "R clearance plane unspecified",
        ),
        ("G0 Z1\nG83 X1 Z-1 R0.5 F10\n", 2, 1, "Q word missing"),
        ("G0 Z1\nG83 X1 Z-1 R0.5 Q0 F10\n", 2, 17, "zero Q"),
        ("G0 Z1\nG82 X1 Z-1 R0.5 F10\n", 2, 1, "P word missing"),
        ("G0 Z1\nG81 X1 Z-1 R0.5 L0 F10\n", 2, 17, "zero repeats"),
        (
            "G0 Z1\nG18 G81 X1 Z-1 R0.5 F10\n",
            2,
            1,
            "Y value unspecified",
        ),
    ];
    for (src, line, column, msg) in cases {
        let e = err(src);
        assert_eq!((e.line, e.column), (line, column), "{src}: {e}");
        assert!(e.to_string().contains(msg), "{src}: {e}");
    }
    // Spindle requirements.
    assert!(err("G0 Z1\nG86 X1 Z-1 R0.5 P1 F10\n")
        .to_string()
        .contains("spindle not turning"));
    assert!(err("G0 Z1\nM4 S1\nG84 X1 Z-1 R0.5 F10\n")
        .to_string()
        .contains("counterclockwise"));
    // Words the cycle does not use are refused as LinuxCNC refuses them.
    for src in [
        "G0 Z1\nG81 X1 Z-1 R0.5 Q1 F10\n",
        "G0 Z1\nG81 X1 Z-1 R0.5 P1 F10\n",
        "G0 Z1\nG81 X1 Z-1 R0.5 K1 F10\n",
    ] {
        assert!(
            matches!(err(src).kind, ParseErrorKind::UnusedWord { .. }),
            "{src}"
        );
    }
}

#[test]
fn linuxcnc_a_in_canned_cycle_programs_are_refused_on_their_line() {
    let dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data/linuxcnc-interp-tests/bad");
    let Ok(a) = std::fs::read_to_string(dir.join("a-in-canned-cycle.ngc")) else {
        println!("SKIP: LinuxCNC interpreter tests not found");
        return;
    };
    let b = std::fs::read_to_string(dir.join("a-in-canned-cycle2.ngc")).unwrap();
    // The A word on its own line under G81, and the A word in the G81 block.
    let e = err(&a);
    assert_eq!((e.line, e.column), (3, 1), "{e}");
    let e = err(&b);
    assert_eq!(e.line, 2, "{e}");
    assert!(e.to_string().contains("cannot put A word"), "{e}");
}

#[test]
fn pathological_pecks_are_refused() {
    let e = err("G21 G90 F100\nG0 Z1\nG83 X0 Y0 Z-1000 R0 Q0.0001\n");
    assert!(e.to_string().contains("too many moves"), "{e}");
}

#[test]
fn cycle_lines_are_written_back_verbatim() {
    let src =
        "G21 G90 F100\nG0 X0 Y0 Z5\nG1 X10 Y0\nG99 G81 X1 Y1 Z-1 R2\nX2 Y2\nG80\nG1 X0 Y0 Z5\n";
    let p = parse_str(src, "t.ngc", &ParseOptions::default()).unwrap();
    let opts = RewriteOptions::new(4, 0.001);
    let same = rewrite(src.as_bytes(), &p, &p.toolpath, &opts).unwrap();
    assert_eq!(String::from_utf8(same).unwrap(), src);
    // The feed of the replaceable moves changed: those lines are rewritten, the cycle
    // lines stay as they are.
    let mut moved = p.toolpath.clone();
    for b in &mut moved.blocks {
        if let Block::Move(m) = b {
            if !m.pinned {
                m.feed_mm_s = Some(2.0);
            }
        }
    }
    let text = String::from_utf8(rewrite(src.as_bytes(), &p, &moved, &opts).unwrap()).unwrap();
    for l in ["G99 G81 X1 Y1 Z-1 R2", "X2 Y2", "G80"] {
        assert!(text.lines().any(|x| x == l), "{l} missing in\n{text}");
    }
    let back = parse_str(&text, "t.ngc", &ParseOptions::default()).unwrap();
    let ends = |p: &Program| -> Vec<String> {
        p.toolpath
            .moves()
            .filter(|m| m.pinned)
            .map(|m| fmt(m.segment.end()))
            .collect()
    };
    assert_eq!(ends(&back), ends(&p));
}

#[test]
fn polar_words_place_the_holes_under_g90() {
    // rs274 -g: about the origin; a block without one of them keeps the current point's
    // radius or angle (`^120` at radius 10, `@5` at 120 degrees).
    assert_trace(
        "G21 G17 G90 G98 F100\nG0 X0 Y0 Z10\nG81 @10 ^30 R2 Z-1\n^120\n@5\nG80\n",
        3,
        &[
            "G0 8.6603 5.0000 10.0000",
            "G0 8.6603 5.0000 2.0000",
            "G1 8.6603 5.0000 -1.0000",
            "G0 8.6603 5.0000 10.0000",
            "G0 -5.0000 8.6603 10.0000",
            "G0 -5.0000 8.6603 2.0000",
            "G1 -5.0000 8.6603 -1.0000",
            "G0 -5.0000 8.6603 10.0000",
            "G0 -2.5000 4.3301 10.0000",
            "G0 -2.5000 4.3301 2.0000",
            "G1 -2.5000 4.3301 -1.0000",
            "G0 -2.5000 4.3301 10.0000",
        ],
    );
}

#[test]
fn polar_words_are_increments_at_every_repeat_under_g91() {
    // rs274 -g: each repeat grows the radius by 2 and then turns by 90 degrees.
    assert_trace(
        "G21 G17 G90 G99 F100\nG0 X10 Y0 Z10\nG91 G81 @2 ^90 R-8 Z-3 L3\nG80\n",
        3,
        &[
            "G0 0.0000 12.0000 10.0000",
            "G0 0.0000 12.0000 2.0000",
            "G1 0.0000 12.0000 -1.0000",
            "G0 0.0000 12.0000 2.0000",
            "G0 -14.0000 0.0000 2.0000",
            "G1 -14.0000 0.0000 -1.0000",
            "G0 -14.0000 0.0000 2.0000",
            "G0 0.0000 -16.0000 2.0000",
            "G1 0.0000 -16.0000 -1.0000",
            "G0 0.0000 -16.0000 2.0000",
        ],
    );
}

#[test]
fn polar_words_in_a_cycle_keep_linuxcncs_errors() {
    for (src, why) in [
        (
            "G21 G18 G90 F100\nG0 X1 Y0 Z10\nG81 @10 ^30 R2 Y-1\n",
            "G17",
        ),
        (
            "G21 G17 G90 F100\nG0 X1 Y0 Z10\nG81 @10 X3 R2 Z-1\n",
            "X or Y",
        ),
        (
            "G21 G17 G90 F100\nG0 X0 Y0 Z10\nG91 G81 ^30 R-2 Z-1\n",
            "origin",
        ),
    ] {
        let e = err(src);
        assert!(e.to_string().contains(why), "{src}: {e}");
    }
}
