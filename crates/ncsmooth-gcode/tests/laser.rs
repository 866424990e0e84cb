//! Laser programs: the power `S` on every motion block (`G1 X.. S255`, as LightBurn and
//! svg2gcode write them). A run of blocks at one power is smoothed like any other; where
//! the power changes, the programmed vertex is kept and the new power is written on the
//! first block after it, on the same line as its motion (a line of its own would make
//! grbl wait for the motion before it to finish).

use ncsmooth::path::{Block, EventKind};
use ncsmooth::Method;
use ncsmooth_gcode::{parse_str, Dialect, ParseOptions, SmoothJob};

/// Coarsely flattened circles (10 degree turns) at one power each, written on every
/// block, and a wave whose power steps every ten blocks.
fn laser_program() -> String {
    let mut s = String::from("G21 G90\nM4 S0\n");
    for c in 0..3 {
        let (cx, r) = (30.0 * f64::from(c), 8.0 + f64::from(c));
        let at = |k: u32| {
            let a = std::f64::consts::TAU * f64::from(k) / 36.0;
            (cx + r * a.cos(), r * a.sin())
        };
        let (x0, y0) = at(0);
        s += &format!("G0 X{x0:.3} Y{y0:.3} S0\n");
        for k in 1..=36 {
            let (x, y) = at(k);
            s += &format!("G1 X{x:.3} Y{y:.3} S{} F6000\n", 300 + 100 * c);
        }
    }
    s += "G0 X0 Y30 S0\n";
    for i in 1..120 {
        let x = f64::from(i) * 0.8;
        let y = 30.0 + 5.0 * (x * 0.5).sin();
        s += &format!("G1 X{x:.3} Y{y:.3} S{}\n", 200 + (i / 10) * 50);
    }
    s + "M5 S0\nM2\n"
}

/// The power set on each motion block of `src`, in order, and where it starts.
fn powers(src: &str) -> Vec<(f64, [f64; 2])> {
    let p = parse_str(src, "laser.gcode", &ParseOptions::default()).unwrap();
    let mut out = Vec::new();
    let mut pending = None;
    for b in &p.toolpath.blocks {
        match b {
            Block::Event(e) => {
                if let EventKind::SpindleSpeed(v) = e.kind {
                    pending = Some(v);
                }
            }
            Block::Move(m) => {
                if let Some(v) = pending.take() {
                    let a = ncsmooth::geom::ParamCurve::start(&m.segment);
                    out.push((v, [a.x, a.y]));
                }
            }
        }
    }
    out
}

#[test]
fn power_changes_stay_at_their_vertices_and_runs_of_one_power_are_smoothed() {
    let src = laser_program();
    let programmed = powers(&src);
    // `S0` on the rapids to each shape but the first (S0 is in force), the power of each
    // circle, and the twelve steps of the wave.
    assert_eq!(
        programmed.len(),
        3 + 3 + 12,
        "one change per rapid, circle, wave step"
    );
    for dialect in [Dialect::Grbl, Dialect::LinuxCnc, Dialect::Marlin] {
        for method in [Method::Bspline, Method::Nurbs, Method::Arc, Method::Trig] {
            let job = SmoothJob::new(method, 0.02).with_dialect(dialect);
            let done = job.run_bytes("laser.gcode", src.as_bytes()).unwrap();
            done.verified().unwrap();
            let text = String::from_utf8(done.gcode).unwrap();
            let what = format!("{method:?} {dialect:?}");
            // The written powers are the program's, each within the rounding of its vertex.
            let written = powers(&text);
            assert_eq!(written.len(), programmed.len(), "{what}\n{text}");
            for ((a, p), (b, q)) in programmed.iter().zip(&written) {
                assert_eq!(a, b, "{what}");
                assert!(
                    (p[0] - q[0]).hypot(p[1] - q[1]) < 1e-3,
                    "{what}: S{a} at {p:?}, {q:?}"
                );
            }
            // No power on a line of its own, and the corners at one power were smoothed.
            assert!(!text.lines().any(|l| l.starts_with('S')), "{what}\n{text}");
            let sm = &done.report.smoothing;
            assert!(sm.corners_smoothed + sm.runs_fitted > 0, "{what}: {sm:?}");
            assert!(
                done.report.deviation.vertex_to_output_mm > 1e-3,
                "{what}: nothing moved"
            );
        }
    }
}

#[test]
fn a_repeated_power_is_no_event_and_keeps_the_line_replaceable() {
    let src = "G21 G90 G0 X0 Y0\nM3 S100\nG1 X10 S100 F600\nG1 X10 Y10 S100\nG1 X0 S200\nM2\n";
    let p = parse_str(src, "p.ngc", &ParseOptions::default()).unwrap();
    let speeds: Vec<f64> = p
        .toolpath
        .events()
        .filter_map(|e| match e.kind {
            EventKind::SpindleSpeed(v) => Some(v),
            _ => None,
        })
        .collect();
    assert_eq!(speeds, [200.0], "S100 is already in force; S200 changes it");
    assert_eq!(p.stats.replaceable_lines, 3);
    // With M3 on the line the S is the spindle's start, kept on its line as before.
    let src = "G21 G90 G0 X0 Y0\nG1 X10 M3 S100 F600\nM2\n";
    let p = parse_str(src, "p.ngc", &ParseOptions::default()).unwrap();
    assert_eq!(p.stats.replaceable_lines, 0);
}
