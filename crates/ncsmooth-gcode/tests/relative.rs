//! Programs that run from wherever the tool is (LightBurn's "current position", a jog
//! macro): `G91` throughout from a start the program never places. The shape is known
//! relative to that start, so it is smoothed in those terms and written back in
//! increments; the start stays unknown, and the program runs the same from any start.

use ncsmooth::verify::deviation;
use ncsmooth::Method;
use ncsmooth_gcode::{parse_str, Dialect, MachineModel, ParseOptions, SmoothJob};

/// A LightBurn-shaped program: a coarse circle (10 degree turns) and a zigzag, all
/// incremental, a rapid between, power on every block, and the return to an absolute
/// finish position.
fn current_position_program() -> String {
    let mut s = String::from("G00 G17 G40 G21 G54\nG91\nM4\nG0X12.34Y5.67\n");
    let at = |k: u32| {
        let a = std::f64::consts::TAU * f64::from(k) / 36.0;
        (10.0 * a.cos(), 10.0 * a.sin())
    };
    for k in 1..=36 {
        let ((x0, y0), (x1, y1)) = (at(k - 1), at(k));
        let feed = if k == 1 { "F6000" } else { "" };
        s += &format!("G1X{:.3}Y{:.3}S800{feed}\n", x1 - x0, y1 - y0);
    }
    s += "G0X25Y0\n";
    for k in 0..40 {
        s += &format!("G1X1Y{}S500\n", if k % 2 == 0 { -0.3 } else { 0.3 });
    }
    s + "G1S0\nM5\nG90\nG0 X0 Y0\nM2\n"
}

/// The program read from the machine position `start`.
fn read_from(src: &str, start: [f64; 3]) -> ncsmooth::path::Toolpath {
    let mut m = MachineModel::default();
    m.start[..3].copy_from_slice(&start);
    parse_str(src, "p.ngc", &ParseOptions::with_machine(m))
        .unwrap()
        .toolpath
}

#[test]
fn a_program_from_the_current_position_is_smoothed_in_increments() {
    let src = current_position_program();
    let tol = 0.02;
    for dialect in [Dialect::Grbl, Dialect::LinuxCnc, Dialect::Generic] {
        for method in [Method::Bspline, Method::Nurbs, Method::Arc, Method::Trig] {
            let what = format!("{method:?} {dialect:?}");
            let job = SmoothJob::new(method, tol).with_dialect(dialect);
            let done = job.run_bytes("lb.gcode", src.as_bytes()).unwrap();
            done.verified().unwrap();
            let text = String::from_utf8(done.gcode).unwrap();
            assert!(
                done.report.deviation.vertex_to_output_mm > 1e-3,
                "{what}: not smoothed"
            );
            // Never an absolute coordinate before the program's own G90.
            let body: Vec<&str> = text.lines().take_while(|l| *l != "G90").collect();
            assert!(!body.contains(&"G90"), "{what}\n{text}");
            // From any start, the machine runs the program's path within tol.
            for start in [[0.0, 0.0, 0.0], [137.25, -41.5, 12.0]] {
                let (a, b) = (read_from(&src, start), read_from(&text, start));
                let dev = deviation(&b, &a, 1e-4);
                assert!(dev.within(tol + 1e-4), "{what} from {start:?}: {dev:?}");
            }
        }
    }
}

#[test]
fn an_axis_known_only_relatively_is_never_written_absolute() {
    // Z starts relative (a retract from wherever), X and Y become known; the feed moves
    // after it that also move Z are written in increments.
    let src = "G21\nG91 G0 Z5\nG90 G0 X0 Y0\nG91\nG1 X10 Z-1 F600\nG1 X0.2 Y10\n\
               G1 X-10 Y0.2\nG1 X-0.2 Y-10 Z1\nM2\n";
    let job = SmoothJob::new(Method::Bspline, 0.05).with_dialect(Dialect::Grbl);
    let done = job.run_bytes("p.ngc", src.as_bytes()).unwrap();
    done.verified().unwrap();
    let text = String::from_utf8(done.gcode).unwrap();
    for start in [[0.0, 0.0, 0.0], [5.0, 6.0, -30.0]] {
        let (a, b) = (read_from(src, start), read_from(&text, start));
        let dev = deviation(&b, &a, 1e-4);
        assert!(dev.within(0.05 + 1e-4), "from {start:?}: {dev:?}\n{text}");
    }
    // An absolute word on an axis known only relatively is a move from an unknown place:
    // copied as it is.
    let src = "G21 G91\nG1 X1 Y1 F600\nG1 X1 Y0\nG90 G1 X0 Y5\nG1 X10 Y5\nM2\n";
    let p = parse_str(src, "p.ngc", &ParseOptions::default()).unwrap();
    assert_eq!(
        p.stats.untracked, 2,
        "the first increment and the absolute move"
    );
}
