//! `smooth` (the whole verified job: budget, curves, rewrite, read-back, LinuxCNC's
//! executed-path model) per dialect on a generated program, so that a regression in any
//! stage shows: a raster of a 3-D surface as CAM writes it for finishing, 24 passes of
//! 0.2 mm chords rounded to 3 decimals, rapids between the passes.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use ncsmooth::smooth::Method;
use ncsmooth_gcode::{Dialect, SmoothJob};
use std::fmt::Write;
use std::hint::black_box;

/// Passes of the raster.
const PASSES: usize = 24;
/// Chords per pass.
const CHORDS: usize = 250;
/// Chord length along X (mm).
const STEP_MM: f64 = 0.2;
/// Distance between passes along Y (mm).
const STEPOVER_MM: f64 = 0.5;

/// The surface `z(x, y)` (mm): a bump with a ripple, curvature radii from a few mm up.
fn surface(x: f64, y: f64) -> f64 {
    -2.0 + 1.5 * (-((x - 25.0).powi(2) + (y - 6.0).powi(2)) / 200.0).exp()
        + 0.2 * (x / 3.0).sin() * (y / 4.0).cos()
}

/// The raster program (G21, feed moves zig-zag along X, a retract and rapid per pass).
fn raster() -> String {
    let mut s = String::from("G21 G90 G17\nG0 Z5\nF1200\n");
    for p in 0..PASSES {
        let y = p as f64 * STEPOVER_MM;
        let x_at = |i: usize| {
            let i = if p % 2 == 0 { i } else { CHORDS - i };
            i as f64 * STEP_MM
        };
        let (x0, z0) = (x_at(0), surface(x_at(0), y));
        let _ = writeln!(s, "G0 X{x0:.3} Y{y:.3}\nG1 Z{z0:.3}");
        for i in 1..=CHORDS {
            let x = x_at(i);
            let _ = writeln!(s, "G1 X{x:.3} Z{:.3}", surface(x, y));
        }
        s.push_str("G0 Z5\n");
    }
    s.push_str("M2\n");
    s
}

fn bench(c: &mut Criterion) {
    let src = raster();
    let mut g = c.benchmark_group("smooth");
    g.throughput(Throughput::Bytes(src.len() as u64));
    g.sample_size(10);
    let cases = [
        (Method::Bspline, Dialect::LinuxCnc),
        (Method::None, Dialect::LinuxCnc),
        (Method::Bspline, Dialect::Grbl),
        (Method::Bspline, Dialect::Marlin),
        (Method::Bspline, Dialect::Generic),
    ];
    for (method, dialect) in cases {
        let job = SmoothJob::new(method, 0.01).with_dialect(dialect);
        let name = format!("{}/{}", method.name(), dialect.name());
        g.bench_function(name, |b| {
            b.iter(|| {
                let out = job.run_bytes("raster.ngc", black_box(src.as_bytes()));
                let out = out.expect("the raster smooths");
                assert!(out.report.within_tol, "within tol");
                black_box(out.gcode.len())
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
