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
    check_bytes(b"\xff\xfe\x00");
    check_bytes(b"(\xe2\x82");
    check_bytes(b"G0 X1\r");
    check_bytes(b"");
    check_bytes(b"\n\n\n");
}
