//! Fanuc-style subprograms as LinuxCNC runs them (`O<n>` programs, `M98 P L`, `M99`), and
//! the O-word definition rules they share with `O<n> sub`: calls and repeats, parameters,
//! the forward search, the errors LinuxCNC gives, `M99` in the main program, and what may
//! be smoothed (nothing a subprogram runs, nothing of a main program `M99` repeats).
//! LinuxCNC's own tests of them (`m98m99/*`) run in `conformance.rs`.

use ncsmooth::geom::ParamCurve;
use ncsmooth::path::{EventKind, Move};
use ncsmooth_gcode::flags;
use ncsmooth_gcode::{parse_str, MachineModel, ParseError, ParseErrorKind, ParseOptions, Program};

fn known() -> ParseOptions {
    ParseOptions::with_machine(MachineModel::default())
}

fn parse(src: &str) -> Program {
    parse_str(src, "f.ngc", &known()).unwrap_or_else(|e| panic!("{e}\n{src}"))
}

fn err(src: &str) -> ParseError {
    match parse_str(src, "f.ngc", &known()) {
        Ok(_) => panic!("expected an error for\n{src}"),
        Err(e) => e,
    }
}

fn ends(p: &Program) -> Vec<[f64; 3]> {
    p.toolpath
        .moves()
        .map(|m| {
            let e = m.segment.end();
            [e.x, e.y, e.z]
        })
        .collect()
}

fn moves(p: &Program) -> Vec<&Move> {
    p.toolpath.moves().collect()
}

fn replaceable(p: &Program, line: usize) -> bool {
    p.source.lines[line - 1].has(flags::REPLACEABLE)
}

#[test]
fn m98_calls_with_repeats_and_its_moves_are_pinned() {
    let src = "G21 G90 G0 X0 Y0 Z1 F600\n\
               M98 P100 L3\n\
               G1 X10\n\
               G1 X11\n\
               M2\n\
               O100 (three steps)\n\
               G91 G1 X1\n\
               G90\n\
               M99\n";
    let p = parse(src);
    assert_eq!(
        ends(&p),
        [
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [2.0, 0.0, 1.0],
            [3.0, 0.0, 1.0],
            [10.0, 0.0, 1.0],
            [11.0, 0.0, 1.0]
        ]
    );
    let pinned: Vec<bool> = moves(&p).iter().map(|m| m.pinned).collect();
    assert_eq!(pinned[1..4], [true, true, true]);
    assert!(!pinned[5], "a main-program move after the call is smoothed");
    assert!(p.source.lines[1].has(flags::OWORD));
    assert!(!replaceable(&p, 7));
    assert!(replaceable(&p, 4));
    // M98 and M99 run no comment: the comment of the program number line neither.
    assert_eq!(p.toolpath.events().count(), 1, "only M2");
}

#[test]
fn m98_p_forms_and_l0() {
    let sub = "M2\nO0100\nG1 X[#<_x> + 1]\nM99\n";
    for (call, n) in [
        ("M98 P100", 1),
        ("M98 P0100", 1),
        ("M98 P[50 * 2]", 1),
        ("#7 = 100\nM98 P#7", 1),
        ("M98 P99.99995", 1),
        ("M98 P100.00005 L2", 2),
        ("N10 M98 P100 L2.00001", 2),
        ("M98 L4 P100", 4),
        ("M98 P100 L0", 0),
        ("M98 P100 L1 (with a comment)", 1),
    ] {
        let p = parse(&format!("G0 X0 Y0 Z0 F100\n{call}\n{sub}"));
        assert_eq!(p.toolpath.moves().count(), 1 + n, "{call}");
        if n > 0 {
            assert_eq!(ends(&p).last().unwrap()[0], n as f64, "{call}");
        }
    }
    let e = err("M98 P100.5\nM2\nO100\nM99\n");
    assert!(matches!(
        e.kind,
        ParseErrorKind::InvalidValue { letter: 'P', .. }
    ));
    let e = err("M98 P-1\nM2\n");
    assert!(matches!(
        e.kind,
        ParseErrorKind::InvalidValue { letter: 'P', .. }
    ));
    for l in ["L2.4", "L-1"] {
        let e = err(&format!("M98 P100 {l}\nM2\nO100\nM99\n"));
        assert!(matches!(
            e.kind,
            ParseErrorKind::InvalidValue { letter: 'L', .. }
        ));
    }
    let e = err("M98 L2\nM2\nO100\nM99\n");
    assert_eq!(
        e.kind,
        ParseErrorKind::MissingWord {
            code: "M98".into(),
            letter: 'P'
        }
    );
    assert_eq!((e.line, e.column), (1, 1));
    // Other words are read and ignored, as LinuxCNC does; a warning says so.
    let p = parse("G0 X0 Y0 Z0\nM98 P1 G1 X5 F10 #1=7\nM2\nO1\n(debug,#1)\nM99\n");
    assert_eq!(p.toolpath.moves().count(), 1);
    assert!(p.stats.warnings.iter().any(|w| w.message.contains("M98")));
}

#[test]
fn m98_shares_numbered_parameters_but_not_local_names() {
    let p = parse(
        "#1 = 5\n#<x> = 7\n#31 = 1\nM98 P1\nG0 X#1 Y#2 Z#<x>\nG0 X#<_call_level> Y#31 Z0\nM2\n\
         O1\n#1 = [#1 + 1]\n#2 = 3\n#<x> = 100\n#31 = #<_call_level>\nM99\n",
    );
    assert_eq!(ends(&p), [[6.0, 3.0, 7.0], [0.0, 1.0, 0.0]]);
}

#[test]
fn m98_finds_programs_forward_or_called_before() {
    // O1 is above O2's call and was never called before: LinuxCNC's forward search from
    // O2 does not find it.
    let e = err("M98 P2\nM2\nO1\nG0 X1\nM99\nO2\nM98 P1\nM99\n");
    assert_eq!(e.line, 7);
    assert!(e.to_string().contains("M98 P1"), "{e}");
    // Called before: recorded, found again.
    let p = parse("G0 X0 Y0 Z0\nM98 P1\nM98 P2\nM2\nO1\nG0 X1\nM99\nO2\nM98 P1\nM99\n");
    assert_eq!(p.toolpath.moves().count(), 3);
    // Nested calls, each level with its own repeat count.
    let p = parse("G0 X0 Y0 Z0\nM98 P2 L2\nM2\nO2\nM98 P1 L3\nM99\nO1\nG91 G0 X1\nG90\nM99\n");
    assert_eq!(ends(&p).last().unwrap()[0], 6.0);
    // A program after the closing % does not exist.
    let e = err("%\nM98 P1\n%\nO1\nM99\n");
    assert_eq!(e.line, 2);
    // Not found at all.
    let e = err("G21 G90 G0 X0 Y0 Z0\nM98 P100\nM2\n");
    assert!(e.to_string().contains("f.ngc:2:1: M98 P100"), "{e}");
}

#[test]
fn fanuc_errors_are_linuxcncs() {
    for (src, line, what) in [
        // M98 only as the first word (after N): elsewhere LinuxCNC knows no such M code.
        ("(c) M98 P1\nM2\nO1\nM99\n", 1, "M98"),
        ("G0 X1 M98 P1\nM2\nO1\nM99\n", 1, "M98"),
        // Only the three characters M98 (LinuxCNC reads them and goes on after them).
        ("M98.0 P1\nM2\nO1\nM99\n", 1, "M98"),
        ("M098 P1\nM2\nO1\nM99\n", 1, "M98"),
        // Nothing but a comment after a returning M99.
        ("M98 P1\nM2\nO1\nM99 G0 X5\n", 4, "M99"),
        ("M98 P1\nM2\nO1\nG0 X1 M99\n", 4, "M99"),
        // A program runs into the next program number.
        ("M98 P1\nM2\nO1\nG0 X1\nO2\nM99\n", 5, "inside subprogram"),
        // Styles do not mix.
        ("O1 call\nM2\nO1\nM99\n", 1, "M98 P1"),
        ("M98 P1\nM2\nO1 sub\nO1 endsub\n", 1, "o1 call"),
        ("M98 P1\nM2\nO1\nO1 endsub\n", 4, "M99"),
        ("M98 P1\nM2\nO1\nO1 return\n", 4, "M99"),
        ("O1 call\nM2\nO1 sub\nM99\nO1 endsub\n", 4, "endsub"),
        // Endless recursion ends.
        ("M98 P1\nM2\nO1\nM98 P1\nM99\n", 4, "nested"),
        // O-word definitions (shared by both styles): no redefinition, no definition
        // the main program runs into after calling it, no definition inside another.
        (
            "O1 sub\nO1 endsub\nO1 sub\nO1 endsub\nM2\n",
            3,
            "already defined",
        ),
        (
            "O1 call\nO1 sub\nG0 X1\nO1 endsub\nM2\n",
            2,
            "illegal location",
        ),
        ("O1 sub\nO2\nO1 endsub\nM2\n", 2, "inside o1 sub"),
    ] {
        let e = err(src);
        assert_eq!(e.line, line, "{src}\n{e}");
        assert!(e.to_string().contains(what), "{src}\n{e}");
    }
}

#[test]
fn m99_in_the_main_program_ends_it_and_pins_everything() {
    let src = "O1000 (main program title)\nG0 X0 Y0 Z0 F600\nG1 X1\nG1 X2 Y1\nM99\nG1 X3\n";
    let p = parse(src);
    assert_eq!(ends(&p).len(), 3, "nothing after M99 runs");
    assert!(moves(&p).iter().all(|m| m.pinned));
    assert!(p.source.lines.iter().all(|l| !l.has(flags::REPLACEABLE)));
    assert_eq!(p.source.end_line, Some(4));
    let ev: Vec<_> = p
        .toolpath
        .events()
        .map(|e| (e.kind.clone(), e.text.clone()))
        .collect();
    // An O-line runs no comment (LinuxCNC); the rewrite copies it verbatim.
    assert_eq!(ev, [(EventKind::ProgramStop, "M99".to_string())]);
    assert!(p.stats.warnings.iter().any(|w| w.message.contains("M99")));
    // The same program ended by M2 is smoothed.
    let p = parse(&src.replace("M99", "M2"));
    assert!(moves(&p).iter().any(|m| !m.pinned));
    // M99 with other codes of its group is a conflict, as M2 with M30 is.
    assert!(matches!(
        err("G0 X0\nM2 M99\n").kind,
        ParseErrorKind::ModalConflict { .. }
    ));
}

#[test]
fn program_numbers_in_the_main_program_do_nothing() {
    let p = parse("O1000\nG0 X1 Y0 Z0\nO<main> (named)\nG0 X2\nO[10 * 2]\nG1 X3 F100\nM2\n");
    assert_eq!(
        ends(&p),
        [[1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [3.0, 0.0, 0.0]]
    );
    assert!(!moves(&p)[2].pinned);
    // The main program running into a subprogram it called: the body runs again at the
    // top level, and its M99 ends the program.
    let p = parse("G0 X0 Y0 Z0\nM98 P1\nO1\nG1 X5 F100\nG1 Y5\nM99\n");
    assert_eq!(ends(&p).len(), 5);
    assert!(moves(&p).iter().all(|m| m.pinned));
}

#[test]
fn block_deleted_calls_pin_the_move_after_them() {
    let p = parse("G0 X0 Y0 Z0 F100\nG1 X1\n/M98 P1\nG1 X9\nG1 X10\nM2\nO1\nG1 Y4\nM99\n");
    let m = moves(&p);
    assert_eq!(m.len(), 5);
    assert!(m[3].pinned, "the move after a block-deleted call");
    assert!(!m[4].pinned);
}

/// A CAM-style Fanuc program: a micro-line contour in the main program, a step-down
/// subprogram repeated with `L` (incremental Z, its own micro-line contour) and a nested
/// one, after `M30`.
fn cam_program() -> String {
    /// Points of a polygonal circle of radius `r` about (`cx`, 0): `n` chords.
    fn circle(s: &mut String, cx: f64, r: f64, n: usize) {
        for k in 1..=n {
            let a = std::f64::consts::TAU * k as f64 / n as f64;
            *s += &format!("G1 X{:.4} Y{:.4}\n", cx + r * a.cos(), r * a.sin());
        }
    }
    let mut s = String::from("%\nO1000 (FANUC STYLE)\nG21 G90 G17\nG0 X20 Y0 Z5\nF1200\nG1 Z-1\n");
    circle(&mut s, 0.0, 20.0, 60);
    s += "G0 Z5\nG0 X70 Y0\nG1 Z0 F600\nM98 P2000 L3\nG0 Z5\nG0 X20 Y0\nG1 Z-2 F1200\n";
    circle(&mut s, 0.0, 20.0, 60);
    s += "G0 Z5\nM30\n";
    s += "O2000 (STEP DOWN)\nG91 G1 Z-0.5\nG90\nM98 P3000\nM99\n";
    s += "O3000 (CONTOUR)\n";
    circle(&mut s, 50.0, 20.0, 40);
    s += "M99\n%\n";
    s
}

/// Smoothing never touches what a subprogram runs: every method leaves the pinned moves as
/// they are, the rewrite copies the subprograms byte for byte, and the written program
/// reads back with the same events, the same subprogram path and the main program within
/// the tolerance.
#[test]
fn smoothing_a_fanuc_program_keeps_its_subprograms() {
    use ncsmooth::smooth::{smooth, Method, SmoothOptions};
    use ncsmooth_gcode::{rewrite, RewriteOptions};
    const TOL_MM: f64 = 0.01;
    const CHORD_MM: f64 = 0.001;
    const DECIMALS: usize = 4;
    let src = cam_program();
    let p = parse_str(&src, "cam.ngc", &ParseOptions::default()).unwrap();
    let pinned = |tp: &ncsmooth::Toolpath| -> Vec<Move> {
        tp.moves().filter(|m| m.pinned).cloned().collect()
    };
    let subs = |text: &str| -> String {
        let at = text.find("O2000").unwrap();
        text[at..].to_string()
    };
    // The subprogram moves, and the main-program move before the call.
    assert_eq!(pinned(&p.toolpath).len(), 3 * (1 + 40) + 1);
    for method in [Method::Bspline, Method::Arc, Method::Nurbs, Method::Trig] {
        let rounding = ncsmooth_gcode::rounding_mm(DECIMALS);
        let opts = SmoothOptions::default()
            .with_method(method)
            .with_tol_mm(TOL_MM - CHORD_MM - rounding);
        let out = smooth(&p.toolpath, &opts).unwrap().toolpath;
        assert_eq!(pinned(&out), pinned(&p.toolpath), "{method:?}");
        let text = rewrite(
            src.as_bytes(),
            &p,
            &out,
            &RewriteOptions::new(DECIMALS, CHORD_MM),
        )
        .unwrap_or_else(|e| panic!("{method:?}: {e}"));
        let text = String::from_utf8(text).unwrap();
        assert_ne!(text, src, "{method:?}: nothing smoothed");
        assert_eq!(subs(&text), subs(&src), "{method:?}");
        let q = parse_str(&text, "out.ngc", &ParseOptions::default())
            .unwrap_or_else(|e| panic!("{method:?}: {e}\n{text}"));
        let ev = |t: &ncsmooth::Toolpath| -> Vec<String> {
            t.events()
                .map(|e| format!("{:?} {}", e.kind, e.text))
                .collect()
        };
        assert_eq!(ev(&q.toolpath), ev(&p.toolpath), "{method:?}");
        let (a, b) = (pinned(&q.toolpath), pinned(&p.toolpath));
        assert_eq!(a.len(), b.len(), "{method:?}");
        for (m, n) in a.iter().zip(&b) {
            let d =
                m.segment.start().dist(n.segment.start()) + m.segment.end().dist(n.segment.end());
            assert!(
                d < 1e-9,
                "{method:?}: pinned move of line {} moved by {d}",
                n.line
            );
        }
        let dev = ncsmooth::verify::deviation(&q.toolpath, &p.toolpath, 1e-6);
        assert!(
            dev.output_to_programmed_mm <= TOL_MM && dev.vertex_to_output_mm <= TOL_MM,
            "{method:?}: {dev:?}"
        );
    }
}
