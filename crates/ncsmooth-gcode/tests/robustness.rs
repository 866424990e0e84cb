//! No input makes the parser panic: arbitrary bytes, and arbitrary strings built from
//! G-code-like characters and tokens. Errors are always located inside the source.

use ncsmooth::geom::ParamCurve;
use ncsmooth_gcode::{parse_bytes, parse_str, ParseOptions};
use proptest::prelude::*;

fn check_bytes(b: &[u8]) {
    match parse_bytes(b, "fuzz", &ParseOptions::default()) {
        Ok(p) => {
            assert!(p.toolpath.moves().all(|m| m.segment.end().is_finite()));
        }
        Err(e) => {
            assert!(e.line >= 1 && e.column >= 1);
            assert!(e.byte_range.start <= e.byte_range.end && e.byte_range.end <= b.len());
            let _ = e.to_string();
        }
    }
}

const TOKENS: &[&str] = &[
    "G0",
    "G1",
    "G2",
    "G3",
    "G4",
    "G17",
    "G18",
    "G19",
    "G20",
    "G21",
    "G90",
    "G91",
    "G90.1",
    "G91.1",
    "G53",
    "G28",
    "G92",
    "G80",
    "G43",
    "G64",
    "M3",
    "M6",
    "M30",
    "M83",
    "M104",
    "X",
    "Y",
    "Z",
    "A",
    "E",
    "I",
    "J",
    "K",
    "R",
    "P",
    "F",
    "S",
    "T",
    "N10",
    "#1",
    "#2=",
    "=",
    "[",
    "]",
    "(",
    ")",
    ";",
    "%",
    "/",
    "-",
    "+",
    "*",
    "**",
    "MOD",
    "SIN",
    "ATAN",
    "SQRT",
    "1",
    "0",
    "-0.5",
    ".",
    "10",
    "1e5",
    "999999999999",
    " ",
    "\n",
    "\r\n",
    "\t",
    "é",
    "$",
    "#<a>",
    "O1",
    "O2",
    "O[1+1]",
    " sub",
    " endsub",
    " call",
    " return",
    "M98",
    "M99",
    "P1",
    "P2",
    "L2",
    "L0",
];

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    #[test]
    fn arbitrary_bytes_never_panic(b in proptest::collection::vec(any::<u8>(), 0..200)) {
        check_bytes(&b);
    }

    #[test]
    fn gcode_like_strings_never_panic(s in "[GMXYZIJKRFPSTEN#\\[\\]()0-9. +\\-*/=;%\n]{0,120}") {
        check_bytes(s.as_bytes());
    }

    #[test]
    fn token_soup_never_panics(toks in proptest::collection::vec(proptest::sample::select(TOKENS), 0..60)) {
        let s: String = toks.concat();
        check_bytes(s.as_bytes());
        let _ = parse_str(&s, "soup", &ParseOptions::default());
    }

    #[test]
    fn valid_looking_programs_never_panic(
        lines in proptest::collection::vec(
            (proptest::sample::select(&[
                "G0", "G1", "G2", "G3", "G18", "G19", "G17", "G91", "G90", "G20", "",
                "G81", "G83", "G73", "G84 M3", "G86 M4", "G87 M3", "G98", "G99", "G80",
                "G5", "G5.1", "G5.2", "G5.3",
            ][..]),
             proptest::collection::vec((proptest::sample::select(&["X", "Y", "Z", "I", "J", "K", "R", "P", "Q", "L", "F", "E"][..]), -1000i32..1000), 0..5)),
            0..30)
    ) {
        let mut s = String::new();
        for (g, words) in &lines {
            s.push_str(g);
            for (l, v) in words {
                s.push_str(&format!(" {l}{}", *v as f64 / 100.0));
            }
            s.push('\n');
        }
        check_bytes(s.as_bytes());
    }

    #[test]
    fn fanuc_style_programs_never_panic(
        lines in proptest::collection::vec(
            proptest::sample::select(&[
                "M98 P1", "M98 P2 L3", "M98 P1 L0", "M98", "M98 P[1+1] L2", "N5 M98 P2",
                "M99", "O1", "O2", "O0001", "O<two>", "O1 sub", "O1 endsub", "O1 call",
                "O2 return", "M2", "M30", "%", "G0 X1 Y2 Z3", "G91 G1 X1 F100", "G90",
                "#1 = [#1 + 1]", "(PRINT,#1)", "/M98 P1", "G1 X2 M99",
            ][..]),
            0..40)
    ) {
        let s = lines.join("\n");
        check_bytes(s.as_bytes());
    }
}

#[test]
fn pathological_inputs() {
    let deep = format!("G0 X{}1{}", "[".repeat(100_000), "]".repeat(100_000));
    check_bytes(deep.as_bytes());
    let signs = format!("G0 X{}1", "-".repeat(100_000));
    check_bytes(signs.as_bytes());
    let hashes = format!("#1=1\nG0 X{}1", "#".repeat(100_000));
    check_bytes(hashes.as_bytes());
    let long_number = format!("G0 X{}", "9".repeat(400));
    check_bytes(long_number.as_bytes());
    check_bytes(b"G0 X1e308");
    check_bytes(b"G2 X1 I1e300 J1e300");
    check_bytes(b"G3 X0 I-1 P10000");
    check_bytes(b"G0 X0 Y0 Z1\nG83 Z-999999999999 R0 Q0.000001 F1");
    check_bytes(b"G0 X0 Y0 Z1\nG81 Z-1 R0 L99999999 F1");
    check_bytes(b"G0 X0 Y0 Z1\nG91 G81 X999999999999 Z-1 R0 L99999 F1");
    check_bytes(b"G0 X0 Y0\nG5.2 X999999999999 Y1 P0.000001 L10 F1\nX1 Y1 P999999999999\nG5.3");
    check_bytes(b"M98 P1\nM2\nO1\nM98 P1 L2\nM99\n");
    check_bytes(b"\xff\xfe\x00");
    check_bytes(b"(\xe2\x82");
    check_bytes(b"G0 X1\r");
    check_bytes(b"");
    check_bytes(b"\n\n\n");
}

/// Subprograms that each call the next twice would make 2^60 calls: the count of calls and
/// loop iterations ends them with an error (10 million of them take seconds in release).
#[test]
#[ignore = "ten million subroutine calls: release only (CI)"]
fn call_trees_that_never_end_are_errors() {
    for (call, ret, sub) in [("M98 P", "M99", ""), ("O", "O{k} endsub", " sub")] {
        let mut s = if call == "O" {
            String::from("O1 call\nM2\n")
        } else {
            String::from("M98 P1\nM2\n")
        };
        for k in 1..60 {
            let n = k + 1;
            let c = if call == "O" {
                format!("O{n} call")
            } else {
                format!("M98 P{n}")
            };
            let r = ret.replace("{k}", &k.to_string());
            s += &format!("O{k}{sub}\n{c}\n{c}\n{r}\n");
        }
        s += &format!("O60{sub}\n{}\n", ret.replace("{k}", "60"));
        let e = parse_bytes(s.as_bytes(), "tree", &ParseOptions::default()).unwrap_err();
        assert!(e.to_string().contains("does not end"), "{e}");
    }
}

/// A whole program holds at most `max_held_blocks` blocks: a loop without end is refused
/// there, naming its line, where it used to grow until memory ran out; a
/// [`ncsmooth_gcode::BlockReader`] hands its blocks out and is not limited by it.
#[test]
fn an_endless_loop_is_refused_at_the_held_block_limit() {
    let src = "G21 G90 F600\nG0 X0 Y0 Z0\no100 while [1]\nG1 X1\nG1 X0\no100 endwhile\nM2\n";
    let opts = ncsmooth_gcode::ParseOptions::default().with_max_held_blocks(1000);
    let e = ncsmooth_gcode::parse_str(src, "loop.ngc", &opts).unwrap_err();
    assert!(
        matches!(
            e.kind,
            ncsmooth_gcode::ParseErrorKind::TooLarge { limit: 1000, .. }
        ),
        "{e}"
    );
    assert!(e.line == 4 || e.line == 5, "{e}");
    // A finite loop of more moves than the limit streams through a reader.
    let dir = std::env::temp_dir().join(format!("ncsmooth-held-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("loop.ngc");
    let src = "G21 G90 F600\nG0 X0 Y0 Z0\n#1=0\no100 while [#1 LT 3000]\nG1 X1\nG1 X0\n#1=[#1+1]\no100 endwhile\nM2\n";
    std::fs::write(&path, src).unwrap();
    let mut reader = ncsmooth_gcode::BlockReader::open(&path, "loop.ngc", &opts).unwrap();
    let (mut blocks, mut n) = (Vec::new(), 0);
    while reader.read_blocks(&mut blocks, 100).unwrap() {
        n += blocks.len();
        blocks.clear();
    }
    n += blocks.len();
    assert!(n >= 6000, "{n}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Until its first G20/G21 a program is read in the reader's default units, and a move
/// made before choosing is noted and warned about.
#[test]
fn a_program_without_units_is_read_in_the_default_units() {
    let src = "F10\nG0 X0 Y0 Z0\nG1 X1\nG20\nG1 X2\n";
    for (units, x1) in [
        (ncsmooth::Units::Millimetres, 1.0),
        (ncsmooth::Units::Inches, 25.4),
    ] {
        let opts = ncsmooth_gcode::ParseOptions::default().with_default_units(units);
        let p = ncsmooth_gcode::parse_str(src, "u.ngc", &opts).unwrap();
        let ends: Vec<f64> = p.toolpath.moves().map(|m| m.segment.end().x).collect();
        assert_eq!(ends, vec![x1, 50.8], "{units:?}");
        assert_eq!(p.stats.units_assumed, Some(2), "{units:?}");
        assert!(p
            .stats
            .warnings
            .iter()
            .any(|w| w.message.contains("before any G20/G21")));
    }
    let p = ncsmooth_gcode::parse_str("G21 F10\nG1 X1\n", "u.ngc", &Default::default()).unwrap();
    assert_eq!(p.stats.units_assumed, None);
}
