//! Property tests of the writer that keeps the program's text ([`ncsmooth_gcode::rewrite`]):
//! random programs mixing frames (G54/G55, G92, G53, G28), units, distance modes,
//! comments, M codes with their words, block delete, dwells, parameters, O-word
//! conditionals and Fanuc-style subprogram calls (`M98 P L`, nested, after `M2`), with
//! axes the program never commands, survive parse -> rewrite -> parse:
//!
//! * unchanged motion gives the program back byte for byte;
//! * with every replaceable line rewritten (each move cut in two halves), the program
//!   reads back with the same events (kinds and texts, in order), the same untracked
//!   motions, the same path (within the flattening of arcs and the rounding of 6
//!   decimals), and no word for an axis the program never commands. Arcs are rewritten as
//!   lines, so the motion mode after a rewritten run differs from the program's and the
//!   next line that relies on it must get it back;
//! * the moves a subprogram runs are pinned, and its lines come back byte for byte.

use ncsmooth::geom::{Flatten, Line, ParamCurve, Segment, Vec3};
use ncsmooth::path::{Block, MoveKind, Toolpath, EXTRA_RATE_VARIANCE};
use ncsmooth_gcode::{parse_str, rewrite, Blend, Emit, ParseOptions, Program, RewriteOptions};
use proptest::prelude::*;

#[derive(Clone, Debug)]
enum Op {
    /// G0/G1 to integer hundredths on a subset of X Y Z, with `S<100 s>` when `s > 0` (a
    /// laser's power on every block: a few values, so that most repeat).
    Line {
        rapid: bool,
        axes: u8,
        to: [i32; 3],
        s: u8,
    },
    /// Axis words with no motion code: the motion mode in force (G0..G3) applies.
    Modal {
        to: [i32; 2],
    },
    /// A G17 arc from the current point: centre offset and an end on the circle.
    Arc {
        ccw: bool,
        off: [i32; 2],
        angle: i32,
    },
    Text(usize),
    Frame(usize),
    Units(bool),
    Distance(bool),
    Feed(u32),
    /// `M98 P<SUBS[k]> [L<repeat>]`.
    Call {
        k: usize,
        repeat: u8,
    },
}

const TEXTS: &[&str] = &[
    "(a comment)",
    "; semicolon comment",
    "(MSG, operator message)",
    "M3 S1200",
    "M8",
    "M5 M9",
    "M62 P1",
    "M68 E1 Q100",
    "G4 P0.5",
    "/M7",
    "T2 M6",
    "G64 P0.01",
    "#<depth> = 1.5",
    "O100 if [1 GT 0]\n(in the branch)\nO100 endif",
    "M1",
];

/// Fanuc-style subprograms written after `M2` (in this order: `O101` calls `O100`, which
/// LinuxCNC finds only after it), the program number, and the distance mode they leave
/// (`None`: the caller's). Each ends with a G0/G1 motion in force.
const SUBS: &[(&str, u32, Option<bool>)] = &[
    (
        "O101 (a subprogram)\nM98 P100\nG1 X-1 Y1 F300\nM99\n",
        101,
        None,
    ),
    ("O102\nG91 G1 X1 Y0.5\nG90\nM99\n", 102, Some(true)),
    ("O0100\nG1 X1.5 Y-2\nG0 X3 Y4\nM99\n", 100, None),
];

const FRAMES: &[&str] = &[
    "G54",
    "G55",
    "G92 X0 Y0",
    "G92.1",
    "G0 G53 Z-5",
    "G28",
    "G43 H1",
];

fn op() -> impl Strategy<Value = Op> {
    let c = -5_000i32..5_000;
    prop_oneof![
        6 => (any::<bool>(), 1u8..8, [c.clone(), c.clone(), c.clone()], 0u8..4)
            .prop_map(|(rapid, axes, to, s)| Op::Line { rapid, axes, to, s }),
        2 => [c.clone(), c.clone()].prop_map(|to| Op::Modal { to }),
        3 => (any::<bool>(), [c.clone(), c], 10i32..300)
            .prop_map(|(ccw, off, angle)| Op::Arc { ccw, off, angle }),
        2 => (0..TEXTS.len()).prop_map(Op::Text),
        1 => (0..FRAMES.len()).prop_map(Op::Frame),
        1 => any::<bool>().prop_map(Op::Units),
        1 => any::<bool>().prop_map(Op::Distance),
        1 => (1u32..5000).prop_map(Op::Feed),
        1 => (0..SUBS.len(), 0u8..4).prop_map(|(k, repeat)| Op::Call { k, repeat }),
    ]
}

/// The program text for `ops`, and whether it ever commands Z.
fn program(ops: &[Op], no_z: bool) -> String {
    let mut s = String::from("F100\n");
    let mut absolute = true;
    let mut last_motion_is_line = false;
    for op in ops {
        match op {
            Op::Line {
                rapid,
                axes,
                to,
                s: power,
            } => {
                let mut l = String::from(if *rapid { "G0" } else { "G1" });
                for (i, name) in ['X', 'Y', 'Z'].iter().enumerate() {
                    if axes & (1 << i) != 0 && !(no_z && i == 2) {
                        l += &format!(" {name}{}", f64::from(to[i]) / 100.0);
                    }
                }
                if l.len() > 2 {
                    if *power > 0 {
                        l += &format!(" S{}", 100 * u32::from(*power));
                    }
                    s += &l;
                    s.push('\n');
                    last_motion_is_line = true;
                }
            }
            Op::Modal { to } => {
                let (x, y) = (f64::from(to[0]) / 100.0, f64::from(to[1]) / 100.0);
                if last_motion_is_line {
                    s += &format!("X{x} Y{y}\n");
                } else if x.hypot(y) >= 0.5 {
                    // Under G2/G3: a full circle in the mode in force.
                    s += &format!("I{x} J{y}\n");
                }
            }
            Op::Arc { ccw, off, angle } => {
                // Only under G90 (the end is computed relative to the centre's frame by the
                // reader either way; keep the generator simple).
                if !absolute {
                    continue;
                }
                let (i, j) = (f64::from(off[0]) / 100.0, f64::from(off[1]) / 100.0);
                if i.hypot(j) < 0.5 {
                    continue;
                }
                // Incremental end: polar about the centre, written with G91 for one block
                // would change the mode; use the full-circle form with P instead when needed.
                let _ = angle;
                s += &format!("{} I{i} J{j}\n", if *ccw { "G3" } else { "G2" });
                last_motion_is_line = false;
            }
            Op::Text(k) => {
                s += TEXTS[*k];
                s.push('\n');
            }
            Op::Frame(k) => {
                if !(no_z && FRAMES[*k].contains('Z')) {
                    s += FRAMES[*k];
                    s.push('\n');
                }
            }
            Op::Units(inch) => s += if *inch { "G20\n" } else { "G21\n" },
            Op::Distance(abs) => {
                absolute = *abs;
                s += if *abs { "G90\n" } else { "G91\n" }
            }
            Op::Feed(f) => s += &format!("F{f}\n"),
            Op::Call { k, repeat } => {
                let (_, n, mode) = SUBS[*k];
                s += &match repeat {
                    1 => format!("M98 P{n}\n"),
                    r => format!("M98 P{n} L{r}\n"),
                };
                if *repeat > 0 {
                    absolute = mode.unwrap_or(absolute);
                    last_motion_is_line = true;
                }
            }
        }
    }
    s += "M2\n";
    s += MAIN_END;
    s.push('\n');
    for (sub, _, _) in SUBS {
        s += sub;
    }
    s
}

/// The last line of the main program text: the subprograms follow it.
const MAIN_END: &str = "G0 X999 (after the end: never run)";

/// The lines of the subprograms, and the 1-based number of the first.
fn subprogram_lines(src: &str) -> (Vec<&str>, u32) {
    let at = src.lines().position(|l| l == MAIN_END).unwrap_or(0);
    (src.lines().skip(at + 1).collect(), at as u32 + 2)
}

fn parse(src: &str) -> Result<Program, String> {
    parse_str(src, "p.ngc", &ParseOptions::default()).map_err(|e| e.to_string())
}

/// Every unpinned move cut in two halves.
fn halves(tp: &Toolpath) -> Toolpath {
    let mut out = tp.clone();
    out.blocks.clear();
    for b in &tp.blocks {
        match b {
            Block::Move(m) if !m.pinned => {
                let (a, c): (Segment, Segment) = match &m.segment {
                    Segment::Line(l) => {
                        let mid = l.eval(0.5);
                        (Line::new(l.p0, mid).into(), Line::new(mid, l.p1).into())
                    }
                    // Arcs become lines (as a smoothing may write them), so that the motion
                    // mode after a rewritten run differs from the program's.
                    Segment::Arc(a) => {
                        let mut prev = a.eval(0.0);
                        a.flatten(1e-4, &mut |p| {
                            out.blocks
                                .push(Block::Move(m.with_segment(Line::new(prev, p))));
                            prev = p;
                        });
                        continue;
                    }
                    other => (other.clone(), other.clone()),
                };
                out.blocks.push(Block::Move(m.with_segment(a)));
                out.blocks.push(Block::Move(m.with_segment(c)));
            }
            other => out.blocks.push(other.clone()),
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn programs_survive_parse_rewrite_parse(
        ops in proptest::collection::vec(op(), 1..40),
        no_z in any::<bool>(),
        emit in 0u8..3,
        blend in any::<bool>(),
    ) {
        let src = program(&ops, no_z);
        let p = match parse(&src) {
            Ok(p) => p,
            // Random programs may be invalid (an arc too small for its radius rule, ...):
            // those are the parser's business, tested elsewhere.
            Err(_) => return Ok(()),
        };
        let mut opts = RewriteOptions::new(6, 1e-4);
        let lines = emit > 0;
        match emit {
            1 => opts = opts.with_emit(Emit::Lines { min_block_mm: 0.05, min_block_s: 0.0 }),
            2 => opts = opts.with_emit(Emit::Arcs),
            _ => {}
        }
        if blend {
            opts = opts.with_blend(Some(Blend { p_mm: 1e-3, q_mm: 0.0 }));
        }
        // Unchanged, the program comes back as it is, but for the bound on its copied
        // motion where blending is bounded.
        let same = String::from_utf8(rewrite(src.as_bytes(), &p, &p.toolpath, &opts).unwrap());
        let ours = |t: &str| -> String {
            let bound = |l: &str| l.starts_with("G64 P0.") && l.ends_with(" Q0");
            t.lines().filter(|l| !bound(l)).map(|l| format!("{l}\n")).collect()
        };
        prop_assert_eq!(ours(&same.unwrap()), ours(&src));
        let cut = halves(&p.toolpath);
        let text = String::from_utf8(rewrite(src.as_bytes(), &p, &cut, &opts).unwrap()).unwrap();
        let q = parse(&text).map_err(|e| TestCaseError::fail(format!("{e}\n{src}\n---\n{text}")))?;
        // An untracked block's text is its line, which may have received the motion code
        // it relied on: compare without it.
        // Path control modes are written around smoothed runs when blending is bounded
        // (tested on their own below).
        let ev = |t: &Toolpath| -> Vec<String> {
            t.events()
                .filter(|e| !(blend && (e.text.starts_with("G64") || e.text.starts_with("G61"))))
                .map(|e| {
                    let text = ["G0 ", "G1 ", "G2 ", "G3 "]
                        .iter()
                        .find_map(|g| e.text.strip_prefix(g))
                        .unwrap_or(&e.text);
                    format!("{:?} {text}", e.kind)
                })
                .collect()
        };
        prop_assert_eq!(ev(&p.toolpath), ev(&q.toolpath), "{}\n---\n{}", src, text);
        prop_assert_eq!(p.stats.untracked, q.stats.untracked);
        // Every `S` on a motion block where the program sets it (the halves meet at the
        // programmed vertices).
        let kept = ncsmooth::verify::block_values_kept(&p.toolpath, &q.toolpath, 1e-5);
        prop_assert!(kept.is_none(), "{:?}\n{}\n---\n{}", kept, src, text);
        let (subs, first_sub_line) = subprogram_lines(&src);
        prop_assert!(
            p.toolpath.moves().filter(|m| m.line >= first_sub_line).all(|m| m.pinned),
            "a subprogram move is not pinned\n{}", src
        );
        prop_assert_eq!(subs, subprogram_lines(&text).0, "{}\n---\n{}", src, text);
        let dev = ncsmooth::verify::deviation(&q.toolpath, &p.toolpath, 1e-8);
        // Long lines and arcs may cut a vertex that turns by less than the break angle by
        // up to the chord; the arcs `halves` gives as lines within the chord may be joined
        // into longer lines within the chord again.
        let vertex_bound = if lines { 1e-4 + 1e-5 } else { 1e-5 };
        let output_bound = if lines { 2e-4 + 1e-5 } else { 1e-4 + 1e-5 };
        prop_assert!(
            dev.output_to_programmed_mm <= output_bound && dev.vertex_to_output_mm <= vertex_bound,
            "{:?}\n{}\n---\n{}", dev, src, text
        );
        if no_z {
            let code: String = text
                .lines()
                .map(|l| l.split(['(', ';']).next().unwrap_or(""))
                .collect();
            prop_assert!(!code.contains('Z'), "Z invented:\n{}", text);
        }
    }
}

/// A subroutine defined after the main program runs lines after its caller's: the moves
/// of the main program after the call are still smoothed into their own lines (they used
/// to be counted as the subroutine's, whose pinned lines then looked changed: the rewrite
/// failed).
#[test]
fn subroutines_after_the_main_program_keep_their_lines() {
    let src = "G0 X0 Y0 Z0 F100\nG1 X1\nG1 X2 Y1\nO1 call\nG1 X3\nG1 X4 Y2\nG1 X5\n\
               O1 call\nG1 X6 Y3\nM2\nO1 sub\nG1 Y9\nG1 X0\nO1 endsub\n";
    let p = parse(src).unwrap();
    let opts = RewriteOptions::new(6, 1e-4);
    let text = String::from_utf8(rewrite(src.as_bytes(), &p, &halves(&p.toolpath), &opts).unwrap())
        .unwrap();
    assert!(
        text.ends_with("M2\nO1 sub\nG1 Y9\nG1 X0\nO1 endsub\n"),
        "{text}"
    );
    let q = parse(&text).unwrap();
    let dev = ncsmooth::verify::deviation(&q.toolpath, &p.toolpath, 1e-8);
    assert!(dev.output_to_programmed_mm <= 1e-5 && dev.vertex_to_output_mm <= 1e-5);
    assert!(q.toolpath.moves().count() > p.toolpath.moves().count());
}

/// The header goes after the program's last line, so every line before the first smoothed
/// one keeps its number (`#<_line>` reads it; LinuxCNC's return-value test prints it), also
/// with an opening `%` and a last line without a newline.
#[test]
fn the_header_goes_at_the_end_and_line_numbers_stay() {
    for src in [
        "%\n(DEBUG, line #<_line>)\nG0 X0 Y0 F100\nG1 X1\nG1 X2 Y1\n%",
        "(DEBUG, line #<_line>)\r\nG0 X0 Y0 F100\r\nG1 X1\r\nG1 X2 Y1\r\nM2\r\n",
    ] {
        let p = parse(src).unwrap();
        let opts = RewriteOptions::new(4, 1e-4).with_header("made by\nncsmooth");
        let same =
            String::from_utf8(rewrite(src.as_bytes(), &p, &p.toolpath, &opts).unwrap()).unwrap();
        let eol = if src.contains('\r') { "\r\n" } else { "\n" };
        let header = format!("; made by{eol}; ncsmooth{eol}");
        let newline = if src.ends_with('\n') { "" } else { eol };
        assert_eq!(same, format!("{src}{newline}{header}"));
        let cut = halves(&p.toolpath);
        let text = String::from_utf8(rewrite(src.as_bytes(), &p, &cut, &opts).unwrap()).unwrap();
        let first_lines: Vec<&str> = src.lines().take(2).collect();
        assert_eq!(
            text.lines().take(2).collect::<Vec<_>>(),
            first_lines,
            "{text}"
        );
        assert!(text.ends_with(&header), "{text:?}");
    }
}

/// Bounded blending: `G64 P Q` before every smoothed run, in the program's units (rounded
/// down); the program's own mode comes back after the run only when it is at least as
/// tight; a `P` that would print as 0 (which LinuxCNC reads as no bound) becomes `G61`.
#[test]
fn blending_is_bounded_around_smoothed_runs() {
    let run = |src: &str, p_mm: f64| -> String {
        let p = parse(src).unwrap();
        let opts = RewriteOptions::new(4, 1e-4).with_blend(Some(Blend { p_mm, q_mm: 0.0 }));
        String::from_utf8(rewrite(src.as_bytes(), &p, &halves(&p.toolpath), &opts).unwrap())
            .unwrap()
    };
    // Start-up mode (unbounded): bounded from the first motion line on (the rapid from
    // an unknown position, written as programmed), and ours stays in force after the run.
    let t = run("G0 X0 Y0 F100\nG1 X1\nG1 X2 Y1\nM2\n", 0.002);
    assert!(t.starts_with("G64 P0.002 Q0\nG0 X0 Y0 F100\n"), "{t}");
    assert_eq!(t.matches("G6").count(), 2, "{t}");
    // A program given back unchanged is bounded the same way: LinuxCNC would otherwise
    // blend its corners without limit.
    let unchanged = |src: &str| {
        let p = parse(src).unwrap();
        let opts = RewriteOptions::new(4, 1e-4).with_blend(Some(Blend {
            p_mm: 0.002,
            q_mm: 0.0,
        }));
        String::from_utf8(rewrite(src.as_bytes(), &p, &p.toolpath, &opts).unwrap()).unwrap()
    };
    let src = "G0 X0 Y0 F100\nG1 X1\nM2\n";
    assert_eq!(unchanged(src), format!("G64 P0.002 Q0\n{src}"));
    // The program's own G64 without P later on (twice, and once with motion on its line)
    // is bounded again before the motion after it; a tighter mode of its own is kept, and
    // nothing is added where no motion follows.
    let src = "G64 P0.001\nG0 X0 Y0 F100\nG1 X1\nG64\nG1 X2\nG61\nG1 X3\n\
               G64\nG1 X4\nG64 G1 X5\nG1 X6\nG64\nM2\n";
    let want = "G64 P0.001\nG0 X0 Y0 F100\nG1 X1\nG64\nG64 P0.002 Q0\nG1 X2\nG61\nG1 X3\n\
                G64\nG64 P0.002 Q0\nG1 X4\nG64 G1 X5\nG64 P0.002 Q0\nG1 X6\nG64\nM2\n";
    assert_eq!(unchanged(src), want);
    // A subprogram's own G64 stays in force after the call: bounded after the call.
    let src = "G64 P0.0005\nG0 X0 Y0 F100\nM98 P100\nG1 X1\nG1 X2 Y1\nM30\n\
               O100\nG64\nG1 X0\nM99\n";
    let t = unchanged(src);
    assert!(t.contains("M98 P100\nG64 P0.002 Q0\nG1 X1\n"), "{t}");
    assert!(t.contains("M30\nO100\nG64\nG1 X0\nM99\n"), "{t}");
    assert_eq!(t.matches("G64 P0.002").count(), 1, "{t}");
    // A G64 on a later pass of a loop than the first: the lines after the loop are
    // bounded although their first (only) state was recorded after it.
    let src = "#1 = 0\nG64 P0.0005\nG0 X0 Y0 F100\no1 repeat [2]\no2 if [#1 EQ 1]\nG64\n\
               o2 endif\n#1 = 1\no1 endrepeat\nG1 X5\nG1 X6 Y2\nM2\n";
    let t = unchanged(src);
    assert!(t.contains("o1 endrepeat\nG64 P0.002 Q0\nG1 X5\n"), "{t}");
    // A subprogram defined above the main program: bounded after its G64 and after the
    // call; the program's own tighter mode set after the definition is kept.
    let src = "o100 sub\nG64\nG1 X10 Y0\no100 endsub\nG21 G90 G17\nG64 P0.001\n\
               G0 X0 Y0 Z1\nG1 Z0 F600\no100 call\nG1 X10 Y10\nG1 X20 Y10\nM2\n";
    let t = unchanged(src);
    assert!(t.contains("G64\nG64 P0.002 Q0\nG1 X10 Y0\n"), "{t}");
    assert!(t.contains("G64 P0.001\nG0 X0 Y0 Z1\n"), "{t}");
    assert!(t.contains("o100 call\nG64 P0.002 Q0\nG1 X10 Y10\n"), "{t}");
    // No looser mode anywhere: control flow adds nothing, an exact-path G61 is kept.
    let src = "G61\nG0 X0 Y0 F100\no1 repeat [2]\nG1 X1\nG1 X0\no1 endrepeat\nM2\n";
    assert_eq!(unchanged(src), src);
    // An exact-path program gets its G61 back after the run.
    let t = run("G61\nG0 X0 Y0 F100\nG1 X1\nG1 X2 Y1\nM0\nG1 X3\n", 0.002);
    let after = t.split("G64 P0.002 Q0").nth(1).unwrap();
    assert!(after.contains("G61"), "{t}");
    // A looser G64 P0.1 is bounded from the first motion on and not restored after a run
    // (each run writes its own bound); a tighter G64 P0.001 is left alone and restored.
    let t = run(
        "G64 P0.1\nG0 X0 Y0 F100\nG1 X1\nG1 X2 Y1\nM0\nG1 X3\n",
        0.002,
    );
    assert_eq!(t.matches("G64 P0.1").count(), 1, "{t}");
    assert_eq!(t.matches("G64 P0.002 Q0").count(), 3, "{t}");
    let t = run(
        "G64 P0.001 Q0.0005\nG0 X0 Y0 F100\nG1 X1\nG1 X2 Y1\nM0\n",
        0.002,
    );
    assert!(
        t.contains("G64 P0.001 Q0.0005\n") && t.matches("G64").count() == 3,
        "{t}"
    );
    // Inch program: P in inches, rounded down to 3 significant digits (the coordinates'
    // 5 decimals would give 0.00039, and 0.00003 for the default 0.001 mm).
    let t = run("G20\nG0 X0 Y0 F10\nG1 X1\nG1 X2 Y1\nM2\n", 0.01);
    assert!(t.contains("G64 P0.000393 Q0\n"), "{t}");
    let t = run("G20\nG0 X0 Y0 F10\nG1 X1\nG1 X2 Y1\nM2\n", 0.001);
    assert!(t.contains("G64 P0.0000393 Q0\n"), "{t}");
    // A small P keeps its digits too.
    let t = run("G0 X0 Y0 F100\nG1 X1\nG1 X2 Y1\nM2\n", 1e-5);
    assert!(t.contains("G64 P0.00001 Q0\n"), "{t}");
    // 1e-14 mm prints as P0 even with the most decimals: exact path instead.
    let t = run("G0 X0 Y0 F100\nG1 X1\nG1 X2 Y1\nM2\n", 1e-14);
    assert!(t.contains("G61\n") && !t.contains("G64"), "{t}");
    // The written modes read back as such.
    let q = parse(&t).unwrap();
    assert!(q.toolpath.events().any(|e| e.text == "G61"));
}

/// The program's own rapids copied verbatim get the verbatim bound where the program's
/// mode is looser: before the first motion and after each run, while each run keeps its
/// own; a program mode within the verbatim bound comes back, and one within the runs'
/// bound (the default) too. Copied feed lines keep the runs' bound.
#[test]
fn verbatim_motion_gets_its_own_bound() {
    let run = |src: &str, verbatim_mm: f64| -> String {
        let p = parse(src).unwrap();
        // The two G1 after the first rapid are replaced; the rest is copied.
        let first_g1 = src.lines().position(|l| l.starts_with("G1")).unwrap() as u32 + 1;
        let replaced =
            |b: &Block| matches!(b, Block::Move(m) if m.line == first_g1 || m.line == first_g1 + 1);
        let h = halves(&p.toolpath);
        let mut out = p.toolpath.clone();
        out.blocks.clear();
        for b in &p.toolpath.blocks {
            if replaced(b) {
                if let Block::Move(m) = b {
                    out.blocks.extend(
                        h.blocks
                            .iter()
                            .filter(|c| matches!(c, Block::Move(n) if n.line == m.line))
                            .cloned(),
                    );
                }
            } else {
                out.blocks.push(b.clone());
            }
        }
        let opts = RewriteOptions::new(4, 1e-4)
            .with_blend(Some(Blend {
                p_mm: 0.001,
                q_mm: 0.0,
            }))
            .with_verbatim_blend(Some(Blend {
                p_mm: verbatim_mm,
                q_mm: 0.0,
            }));
        String::from_utf8(rewrite(src.as_bytes(), &p, &out, &opts).unwrap()).unwrap()
    };
    let src = "G0 X0 Y0 F100\nG1 X1\nG1 X2 Y1\nG0 X5\nG0 Y5\nM2\n";
    let t = run(src, 0.0095);
    assert!(
        t.starts_with("G64 P0.0095 Q0\nG0 X0 Y0 F100\nG64 P0.001 Q0\n"),
        "{t}"
    );
    let after = t.split("G64 P0.001 Q0\n").nth(1).unwrap();
    assert!(after.contains("G64 P0.0095 Q0\nG0 X5\n"), "{t}");
    // The same as the runs' bound: one G64 before the first motion, one per run, as before.
    let t = run(src, 0.001);
    assert_eq!(t.matches("G64").count(), 2, "{t}");
    // A program mode between the two bounds comes back after the run; `G64 P0.005`
    // alone is looser (LinuxCNC's Q defaults to P: 0.01 mm in all).
    let t = run(&format!("G64 P0.005 Q0\n{src}"), 0.0095);
    assert!(t.contains("G64 P0.005 Q0\nG0 X5\n"), "{t}");
    assert!(!t.contains("P0.0095"), "{t}");
    let t = run(&format!("G64 P0.005\n{src}"), 0.0095);
    assert!(t.contains("G64 P0.0095 Q0\nG0 X5\n"), "{t}");
    // A copied feed line after the rapid: the runs' bound stays in force.
    let t = run(&src.replace("G0 Y5", "G1 Y5"), 0.0095);
    assert!(t.starts_with("G64 P0.0095 Q0\nG0 X0 Y0 F100\n"), "{t}");
    assert_eq!(t.matches("G64").count(), 2, "{t}");
    // Rapids after a copied feed line: the verbatim bound from the first rapid on.
    let t = run(&src.replace("G0 X5", "G1 Y-1\nG0 X5"), 0.0095);
    assert!(t.contains("G1 Y-1\nG64 P0.0095 Q0\nG0 X5\n"), "{t}");
    assert_eq!(t.matches("G64").count(), 3, "{t}");
    // Not where the program has set a mode of its own in between.
    let t = run(&src.replace("G0 X5", "G1 Y-1\nG61\nG0 X5"), 0.0095);
    assert_eq!(t.matches("G64").count(), 2, "{t}");
}

/// Long lines: a finely cut arc comes back as a few long blocks within the chord, its end
/// exact.
#[test]
fn long_lines_join_the_pieces_of_a_run() {
    let src = "G0 X10 Y0 F600\nG3 X-10 Y0 I-10 J0\nM2\n";
    let p = parse(src).unwrap();
    let cut = halves(&p.toolpath);
    let chord = 1e-3;
    let native = RewriteOptions::new(4, chord);
    let lines = native.clone().with_emit(Emit::Lines {
        min_block_mm: 0.05,
        min_block_s: 0.0,
    });
    let count = |o: &RewriteOptions| {
        let t = String::from_utf8(rewrite(src.as_bytes(), &p, &cut, o).unwrap()).unwrap();
        let q = parse(&t).unwrap();
        let dev = ncsmooth::verify::deviation(&q.toolpath, &p.toolpath, 1e-7);
        assert!(dev.within(chord + 1e-4), "{dev:?}");
        assert!(t.contains("X-10 Y0"), "{t}");
        q.toolpath.moves().count()
    };
    let (n_native, n_lines) = (count(&native), count(&lines));
    // The arc flattened within 1e-4 mm (blocks of 0.18 mm) becomes blocks of up to
    // sqrt(8 r 0.75 chord) = 0.24 mm less what rounding takes.
    assert!(
        n_native > 300 && n_lines < n_native / 2,
        "{n_native} {n_lines}"
    );
}

/// `src` parsed, and smoothed by the B-spline method within 0.05 mm.
fn bspline_smoothed(src: &str) -> (Program, Toolpath) {
    let p = parse(src).unwrap();
    let smoothed = smoothed_with(&p, ncsmooth::smooth::Method::Bspline);
    (p, smoothed)
}

/// `p` smoothed by `method` within 0.05 mm.
fn smoothed_with(p: &Program, method: ncsmooth::smooth::Method) -> Toolpath {
    use ncsmooth::smooth::{smooth, SmoothOptions};
    let opts = SmoothOptions::default()
        .with_method(method)
        .with_tol_mm(0.05);
    smooth(&p.toolpath, &opts).unwrap().toolpath
}

/// `G5`: the B-spline method's corner curves (cubic Béziers) are written exactly: read
/// back, each equals the smoothed curve at sampled parameters to 1e-9 mm (9 decimals, the
/// control-point offsets with two more).
#[test]
fn g5_carries_the_bspline_corners_exactly() {
    let src = "G21 G90 G17\nG0 X0 Y0 Z1\nG1 X10 F600\nG1 X10 Y10\nG1 X0 Y12\nM2\n";
    let (p, smoothed) = bspline_smoothed(src);
    let curves = |tp: &Toolpath| -> Vec<ncsmooth::geom::CubicBez> {
        tp.moves()
            .filter_map(|m| match &m.segment {
                Segment::CubicBez(b) => Some(*b),
                _ => None,
            })
            .collect()
    };
    let want = curves(&smoothed);
    assert!(want.len() >= 2, "two corners: {want:?}");
    let g5 = RewriteOptions::new(9, 1e-3).with_emit(Emit::G5 {
        min_block_mm: 0.0,
        min_block_s: 0.0,
    });
    let text = String::from_utf8(rewrite(src.as_bytes(), &p, &smoothed, &g5).unwrap()).unwrap();
    assert_eq!(text.matches("G5 ").count(), want.len(), "{text}");
    let got = curves(&parse(&text).unwrap().toolpath);
    assert_eq!(got.len(), want.len());
    for (a, b) in want.iter().zip(&got) {
        for k in 0..=64 {
            let t = k as f64 / 64.0;
            let d = a.eval(t).dist(b.eval(t));
            assert!(d <= 1e-9, "{d:e} at t = {t}\n{text}");
        }
    }
}

/// `G5.2 ... G5.3`: the NURBS method's curves are written exactly, one NURBS per Bézier
/// span; read back, the path is the smoothed one to 1e-9 mm (9 decimals).
#[test]
fn nurbs_are_written_exactly_span_by_span() {
    use ncsmooth::smooth::{smooth, Method, SmoothOptions};
    let mut src = String::from("G21 G90 G17\nG0 X10 Y0 Z1\nG1 F600\n");
    for k in 1..=60 {
        let a = 1.5 * k as f64 / 60.0;
        src += &format!("X{:.4} Y{:.4}\n", 10.0 * a.cos(), 10.0 * a.sin());
    }
    src += "M2\n";
    let p = parse(&src).unwrap();
    let opts = SmoothOptions::default()
        .with_method(Method::Nurbs)
        .with_tol_mm(0.01);
    let smoothed = smooth(&p.toolpath, &opts).unwrap().toolpath;
    let n_nurbs = smoothed
        .moves()
        .filter(|m| matches!(m.segment, Segment::Nurbs(_)))
        .count();
    assert!(n_nurbs >= 1);
    let emit = RewriteOptions::new(9, 1e-3).with_emit(Emit::Nurbs {
        min_block_mm: 0.0,
        min_block_s: 0.0,
    });
    let text = String::from_utf8(rewrite(src.as_bytes(), &p, &smoothed, &emit).unwrap()).unwrap();
    assert!(text.contains("G5.2 ") && text.contains("G5.3"), "{text}");
    let back = parse(&text).unwrap().toolpath;
    let dev = ncsmooth::verify::deviation(&back, &smoothed, 1e-10);
    assert!(
        dev.output_to_programmed_mm <= 1e-9 && dev.vertex_to_output_mm <= 1e-9,
        "{dev:?}\n{text}"
    );
}

/// LinuxCNC never blends a rapid with a feed move (tp.c `tpCheckCanonType` stops between
/// them): a run after a rapid starts from rest, and the blend schedule gives its first
/// vertices the little `P` that speed needs, where a feed line tangent to it lets it
/// start at speed.
#[test]
fn a_run_after_a_rapid_starts_from_rest() {
    let first_ps = |lead_in: &str| -> Vec<f64> {
        let src = format!("G21\n{lead_in} Y0\nG3 X-10 Y0 I-10 J0\nM2\n");
        let p = parse(&src).unwrap();
        // Only the arc is smoothed: flattened into lines.
        let mut out = p.toolpath.clone();
        out.blocks.clear();
        for b in &p.toolpath.blocks {
            match b {
                Block::Move(m) if matches!(m.segment, Segment::Arc(_)) => {
                    let mut prev = m.segment.start();
                    m.segment.flatten(1e-3, &mut |q| {
                        out.blocks
                            .push(Block::Move(m.with_segment(Line::new(prev, q))));
                        prev = q;
                    });
                }
                other => out.blocks.push(other.clone()),
            }
        }
        let opts = RewriteOptions::new(4, 1e-4)
            .with_blend(Some(Blend {
                p_mm: 0.004,
                q_mm: 0.0,
            }))
            .with_blend_limits(Some(500.0), Some(50.0))
            .with_emit(Emit::Lines {
                min_block_mm: 0.0,
                min_block_s: 0.0,
            });
        let t = String::from_utf8(rewrite(src.as_bytes(), &p, &out, &opts).unwrap()).unwrap();
        let run = t.split_once("G3").map_or(t.as_str(), |(_, r)| r);
        let run = t.split_once(" Y0\n").map_or(run, |(_, r)| r);
        run.lines()
            .filter_map(|l| l.strip_prefix("G64 P"))
            .map(|l| l.split(' ').next().unwrap().parse().unwrap())
            .take(3)
            .collect()
    };
    let rest = first_ps("G0 X10 Y-5 F3000\nG0");
    let moving = first_ps("G0 X10 Y-5 F3000\nG1");
    // The program's first move, from an unknown position, is not placed (an untracked
    // motion): LinuxCNC may blend with it, so the run does not start at rest there.
    let unknown = first_ps("G1 X10 F3000");
    // From rest the run's first block and the vertex after it get the least share,
    // 1/16 (no blend at the stop); arriving at speed along the tangent feed line the
    // first block keeps all of P and the vertex after it needs more than the least.
    assert_eq!(rest.first(), Some(&0.00025), "{rest:?}");
    assert_eq!(moving.first(), Some(&0.004), "{moving:?}");
    assert_eq!(unknown.first(), Some(&0.004), "{unknown:?}");
    assert!(moving.len() > 1 && moving[1] > 0.0003, "{moving:?}");
}

/// A replaced run begins with the extra axes where the program has them before it, not
/// at its first move's end: a slicer's extrusion run after an un-retract (`G1 E1`, an
/// event), written as one move, extrudes from 1 to 4 (the writer once took the move's
/// own end value for the start and wrote no `E` at all: the printer would have moved
/// without extruding).
#[test]
fn a_run_starts_from_the_programs_extrusion() {
    let src = "G21 G90 M82\nG92 E0\nG1 X0 Y0 F3000\nG1 E1 F1800\n\
               G1 X10 Y0 E2 F600\nG1 X20 Y0 E3\nG1 X30 Y0 E4\nG1 E3 F1800\nM2\n";
    let p = parse(src).unwrap();
    let mut out = p.toolpath.clone();
    out.blocks.clear();
    for b in &p.toolpath.blocks {
        match b {
            Block::Move(m) if m.line == 5 => {
                let mut whole = m.with_segment(Line::new(
                    m.segment.start(),
                    ncsmooth::geom::Vec3::new(30.0, 0.0, 0.0),
                ));
                whole.extra = p.toolpath.moves().last().and_then(|l| l.extra);
                out.blocks.push(Block::Move(whole));
            }
            Block::Move(m) if m.line == 6 || m.line == 7 => {}
            other => out.blocks.push(other.clone()),
        }
    }
    let t = String::from_utf8(
        rewrite(src.as_bytes(), &p, &out, &RewriteOptions::new(4, 1e-4)).unwrap(),
    )
    .unwrap();
    let q = parse(&t).unwrap();
    let last = q.toolpath.moves().last().unwrap();
    assert_eq!(last.segment.end().x, 30.0, "{t}");
    assert_eq!(last.extra.map(|e| e[6]), Some(4.0), "{t}");
    assert!(t.contains("X30 E4"), "{t}");
}

/// `G5` may not move an extra axis (LinuxCNC's rule, which the reader follows): a
/// slicer's extruding corner curve is flattened into lines that carry its `E`, so the
/// extrusion at the end is the program's.
#[test]
fn g5_leaves_extruding_curves_to_lines() {
    let src = "G21 G90 G17 M82\nG92 E0\nG0 X0 Y0 Z1\nG1 X10 E1 F600\nG1 X10 Y10 E2\n\
               G1 X0 Y12 E3\nG1 E2 F1800\nM2\n";
    let (p, smoothed) = bspline_smoothed(src);
    assert!(smoothed
        .moves()
        .any(|m| matches!(m.segment, Segment::CubicBez(_)) && m.extra.is_some()));
    let g5 = RewriteOptions::new(4, 1e-3).with_emit(Emit::G5 {
        min_block_mm: 0.0,
        min_block_s: 0.0,
    });
    let (text, q) = written_keeping_extra_axes(src, &p, &smoothed, &g5, 1e-4);
    assert!(!text.contains("G5"), "{text}");
    let last = q.toolpath.moves().last().unwrap();
    assert_eq!(last.extra.map(|e| e[6]), Some(3.0), "{text}");
}

/// A slicer's extruding moves are chained into long blocks like any others (each piece
/// once was written on its own: Marlin got 5-17 times the program's blocks), with `E`
/// carried along: collinear moves at one flow become one block, and a vertex where the
/// flow changes (here it triples at X4) is written with the program's `E` there.
#[test]
fn extruding_runs_are_chained_with_their_flow() {
    let src = "G21 G90 G17 M82\nG92 E0\nG0 X0 Y0 Z0.2\nG1 X1 E0.1 F1200\nG1 X2 E0.2\n\
               G1 X3 E0.3\nG1 X4 E0.4\nG1 X5 E0.7\nG1 X6 E1\nG1 X7 E1.3\nG1 X7 Y1 E1.4\n\
               G1 X0 Y1 E2.1\nG1 E1.1 F1800\nM2\n";
    let (p, smoothed) = bspline_smoothed(src);
    let lines = RewriteOptions::new(4, 1e-3).with_emit(Emit::Lines {
        min_block_mm: 0.0,
        min_block_s: 0.0,
    });
    let (text, q) = written_keeping_extra_axes(src, &p, &smoothed, &lines, 1e-4);
    // One block to the flow change (the smoothed run passes within 0.05 mm of X4).
    let ends: Vec<(Vec3, f64)> = q
        .toolpath
        .moves()
        .filter(|m| m.kind == MoveKind::Feed)
        .map(|m| (m.segment.end(), m.extra.unwrap()[6]))
        .collect();
    let (first, e_first) = ends[0];
    assert!(
        first.dist(Vec3::new(4.0, 0.0, 0.2)) < 1e-3 && e_first == 0.4,
        "{text}"
    );
    // On to the corner, E follows the program's 0.3 per mm of path (within the rate
    // variance a chain allows; the corner's curve is shorter than the program's path).
    for w in ends.windows(2) {
        let ((a, ea), (b, eb)) = (w[0], w[1]);
        if b.x < 6.5 && b.y.abs() < 0.1 {
            let rate = (eb - ea) / a.dist(b);
            assert!(
                (rate - 0.3).abs() < 0.3 * EXTRA_RATE_VARIANCE,
                "{rate} {text}"
            );
        }
    }
}

/// A slicer's first extruding move from a position not yet established (here: no move
/// before it) is copied as programmed, and the run after it starts from its `E` (the
/// path model once lost it: the run's first line was written without `E`).
#[test]
fn a_run_after_an_untracked_extruding_move_keeps_its_extrusion() {
    let src = "G21 G90 M82\nG1 X-11 Y14 E1.05973 F1080\nG1 X0 Y14 E2\nG1 X1 Y20 E3\n\
               G1 X-5 Y22 E4\nG1 F3600 E3\nM2\n";
    let (p, smoothed) = bspline_smoothed(src);
    let lines = RewriteOptions::new(4, 1e-3);
    let (text, _) = written_keeping_extra_axes(src, &p, &smoothed, &lines, 1e-4);
    assert!(text.contains("E1.05973"), "{text}");
    // Every move extrudes (none is written without its E word).
    for l in text
        .lines()
        .filter(|l| l.starts_with("G1 X") || l.starts_with("G1 Y"))
    {
        assert!(l.contains(" E"), "{l}\n{text}");
    }
}

/// Relative E (M83): each run's increments are rounded to the written decimals, and the
/// next run starts from what they add up to, not from the program's value: over many
/// runs between two resets the rounding does not accumulate (it once reached 0.00017 mm
/// on a relative copy of cncjs_sample_slic3r, twice the rounding).
#[test]
fn relative_extrusion_rounding_does_not_add_up_over_runs() {
    let mut src = String::from("G21 G90 M83\nG92 E0\nG0 X0 Y0 Z0.2\n");
    for k in 0..40 {
        let y = k as f64;
        src.push_str(&format!(
            "G1 X10 Y{y} E0.123456 F1200\nG1 X10 Y{} E0.0123456\nG1 X0 Y{} E0.123456\nM106 S255\n",
            y + 0.5,
            y + 0.6
        ));
    }
    src.push_str("G1 E-1 F1800\nG92 E0\nM2\n");
    let (p, smoothed) = bspline_smoothed(&src);
    let opts = RewriteOptions::new(4, 1e-3);
    written_keeping_extra_axes(&src, &p, &smoothed, &opts, 0.5e-4 + 1e-9);
}

/// `--emit arcs` on a slicer's ring of short extruding lines: the arcs fitted through it
/// carry the ring's extrusion (an arc's end once took the E at its chord's length along
/// the ring, nearly none for a whole ring, and the ring was written without E).
#[test]
fn fitted_arcs_carry_the_extrusion_of_what_they_replace() {
    let mut src = String::from("G21 G90 M82\nG92 E0\nG0 X6 Y0 Z0.2\nG1 X6 Y0 F1800\n");
    let n = 72;
    for k in 1..=n {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        src.push_str(&format!(
            "G1 X{:.4} Y{:.4} E{:.5}\n",
            6.0 * a.cos(),
            6.0 * a.sin(),
            0.02 * k as f64
        ));
    }
    src.push_str("G1 E0.5 F2100\nM2\n");
    let p = parse(&src).unwrap();
    // A chord of 0.008 mm holds the ring's 0.0057 mm sagitta: arcs fit.
    let opts = RewriteOptions::new(4, 0.008)
        .with_emit(Emit::Arcs)
        .with_rewrite_unchanged(true);
    let (text, _) = written_keeping_extra_axes(&src, &p, &p.toolpath, &opts, 1e-4);
    let arcs: Vec<&str> = text
        .lines()
        .filter(|l| l.starts_with("G2 ") || l.starts_with("G3 "))
        .collect();
    assert!(
        !arcs.is_empty() && arcs.iter().all(|l| l.contains(" E")),
        "{text}"
    );
}

/// A slicer's wipe (PrusaSlicer, relative E): the corner curve between the last extruding
/// line and the wipe carries part of the wipe's retraction, and the wipe's own lines are
/// written after the copied `;WIPE_START` and `G1 F8640` lines: they start from where the
/// curve left E, not from the program's E before their line (which counted the wipe's
/// retraction twice: 0.06 mm on a PrusaSlicer-like ring).
#[test]
fn a_wipe_after_a_copied_line_starts_where_the_curve_left_the_extrusion() {
    let src = "G21 G90 M83\nG92 E0\nG0 X0 Y0 Z0.2\nG1 X10 Y0 E0.5 F1800\nG1 X20 Y1 E0.5\n\
               ;WIPE_START\nG1 F8640\nG1 X30 Y3 E-0.4\nG1 X40 Y6 E-0.4\n;WIPE_END\n\
               G1 E-0.2 F2100\nM2\n";
    let (p, smoothed) = bspline_smoothed(src);
    let opts = RewriteOptions::new(4, 1e-3);
    written_keeping_extra_axes(src, &p, &smoothed, &opts, 1e-4);
}

/// `p` (source `src`) written with `out` under `opts` and read back, its extra axes
/// checked against the program's within `tol_mm` ([`ncsmooth::verify::extra_axes_kept`]).
fn written_keeping_extra_axes(
    src: &str,
    p: &Program,
    out: &Toolpath,
    opts: &RewriteOptions,
    tol_mm: f64,
) -> (String, Program) {
    let text = String::from_utf8(rewrite(src.as_bytes(), p, out, opts).unwrap()).unwrap();
    let q = parse(&text).unwrap();
    assert_eq!(
        ncsmooth::verify::extra_axes_kept(&p.toolpath, &q.toolpath, tol_mm),
        None,
        "{text}"
    );
    (text, q)
}

/// `E` is written with one more digit than the coordinates (5 at 4, as slicers write it):
/// a smoothed block extrudes a few thousandths of a millimetre.
#[test]
fn extrusion_keeps_a_slicers_five_decimals() {
    let src = "G21 G90 M82\nG92 E0\nG0 X0 Y0 Z0.2\nG1 X10 Y0 E0.33267 F1800\n\
               G1 X10 Y10 E0.66534\nG1 E0.1 F2100\nM2\n";
    let (p, smoothed) = bspline_smoothed(src);
    let opts = RewriteOptions::new(4, 1e-3);
    let (text, _) = written_keeping_extra_axes(src, &p, &smoothed, &opts, 0.5e-5 + 1e-9);
    assert!(text.contains(" E0.66534\n"), "{text}");
}

/// Relative E (`M83`, PrusaSlicer's default) with no `G92 E` before the first extruding
/// move: E counts from 0, so the first line's extrusion is written along it (it was
/// taken as already done: the written program extruded half of what the program does).
/// With absolute E the same program's first line keeps its flow: its start is 0, not
/// its end (which had put the whole line's extrusion on the corner's first chord).
#[test]
fn extrusion_without_a_reset_counts_from_zero() {
    for mode in ["M83", "M82"] {
        let e2 = if mode == "M83" { "0.70711" } else { "1.20711" };
        let src = format!("G21 G90 {mode}\nG1 X0 Y0 F1200\nG1 X10 Y0 E0.5\nG1 X20 Y10 E{e2}\n");
        let (p, smoothed) = bspline_smoothed(&src);
        assert!(
            smoothed.moves().count() > p.toolpath.moves().count(),
            "not smoothed"
        );
        let opts = RewriteOptions::new(4, 1e-3);
        let (text, _) = written_keeping_extra_axes(&src, &p, &smoothed, &opts, 1e-4);
        let first = text.lines().nth(2).unwrap();
        assert!(
            first.starts_with("G1 X9.") && first.contains(" E0.4"),
            "{text}"
        );
    }
}

/// A rotary axis indexing with the tool at rest (`G1 X10 A10` at X10, a move of no
/// length) stays a motion of its own for every method, at a reversal and at a corner:
/// it was merged into the next line (the table turning while X travelled 10 mm back) or
/// spread over the corner's curve.
#[test]
fn an_indexing_in_place_is_never_spread_over_other_moves() {
    use ncsmooth::smooth::Method;
    for end in ["X0", "X10 Y10"] {
        let src = format!("G21 G90\nG0 X0 Y0 A0\nG1 X10 F600\nG1 X10 A10\nG1 {end}\nM2\n");
        let p = parse(&src).unwrap();
        for method in [Method::Trig, Method::Bspline, Method::Arc, Method::Nurbs] {
            let out = smoothed_with(&p, method);
            let mut a_before = 0.0;
            for m in out.moves() {
                let a = m.extra.unwrap()[0];
                let len = m.segment.start().dist(m.segment.end());
                assert!(
                    a == a_before || len == 0.0,
                    "{method:?} {end}: A {a_before} -> {a} over {len} mm"
                );
                a_before = a;
            }
            assert_eq!(a_before, 10.0);
            let text = rewrite(src.as_bytes(), &p, &out, &RewriteOptions::new(4, 1e-3)).unwrap();
            let text = String::from_utf8(text).unwrap();
            assert!(text.contains("G1 X10 A10\n"), "{method:?} {end}\n{text}");
        }
    }
}

/// A feed below the written decimals (`F0.00001` mm/min) keeps the digits it needs: it
/// was written `F0`, which does not read back (a feed move with no feed rate).
#[test]
fn a_feed_below_the_last_digit_is_not_written_as_zero() {
    let src = "G21 G90\nG1 X0 Y0 F0.00001\nG1 X10 Y0\nG1 X10 Y10\nM2\n";
    let (p, smoothed) = bspline_smoothed(src);
    let text = rewrite(src.as_bytes(), &p, &smoothed, &RewriteOptions::new(4, 1e-3)).unwrap();
    let text = String::from_utf8(text).unwrap();
    let q = parse(&text).unwrap();
    for m in q.toolpath.moves().filter(|m| m.kind == MoveKind::Feed) {
        let f = m.feed_mm_s.unwrap() * 60.0;
        assert!((f - 1e-5).abs() < 1e-12, "F{f}\n{text}");
    }
}

/// `G92 A0` makes the rotary axis known at 0: the first move turning it (`G1 X10 A90`)
/// starts from 0. Its start was taken at the move's own end, the turn lost: the written
/// program had `A` at NaN and every method exited 1 on this valid program.
#[test]
fn a_g92_of_a_rotary_axis_starts_the_moves_after_it() {
    use ncsmooth::smooth::Method;
    let src = "G21 G90\nG92 X0 Y0 Z0 A0\nG1 X10 A90 F600\nG1 X20 Y10\nM2\n";
    let p = parse(src).unwrap();
    for method in [Method::Trig, Method::Bspline, Method::Arc, Method::Nurbs] {
        let out = smoothed_with(&p, method);
        // The first piece of the smoothed line ends short of the turn's end.
        let first = out.moves().next().unwrap();
        assert!(first.extra.unwrap()[0] < 90.0, "{method:?}: {first:?}");
        let (text, _) =
            written_keeping_extra_axes(src, &p, &out, &RewriteOptions::new(4, 1e-3), 1e-4);
        let line = text.lines().find(|l| l.starts_with("G1 X9.")).unwrap();
        assert!(
            line.contains(" A89.") || line.contains(" A8"),
            "{method:?}\n{text}"
        );
    }
}
