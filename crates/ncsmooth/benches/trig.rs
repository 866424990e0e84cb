//! Criterion benchmarks of the trig method: corners per second (inside transitions and
//! loops on a zig-zag of long lines, every vertex a corner), trig free-curve runs (a finely
//! sampled spiral) and segment flattening.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use ncsmooth::geom::{Flatten, TrigSpline, Vec3};
use ncsmooth::smooth::trig_corner::{CornerStyle, TrigOptions};
use ncsmooth::smooth::{smooth, Method, SmoothOptions};
use ncsmooth::Toolpath;
use std::hint::black_box;

/// Corners of the zig-zag benchmark.
const CORNERS: usize = 1000;

fn zigzag() -> Toolpath {
    // Turns of varying angle (20..160 degrees), legs of 5..10 mm.
    let mut pts = vec![Vec3::ZERO];
    let mut dir: f64 = 0.0;
    for i in 0..=CORNERS {
        let last = *pts.last().unwrap();
        let len = 5.0 + (i % 6) as f64;
        pts.push(last + Vec3::new(dir.cos(), dir.sin(), 0.0) * len);
        let turn = (20.0 + (i * 37 % 140) as f64).to_radians();
        dir += if i % 2 == 0 { turn } else { -turn };
    }
    Toolpath::from_polyline(&pts, Some(50.0))
}

fn spiral() -> Toolpath {
    let pts: Vec<Vec3> = (0..=5000)
        .map(|i| {
            let t = i as f64 * 0.01;
            let r = 20.0 + 0.5 * t;
            Vec3::new(r * t.cos(), r * t.sin(), 0.0)
        })
        .collect();
    Toolpath::from_polyline(&pts, Some(50.0))
}

fn opts(corner: CornerStyle) -> SmoothOptions {
    SmoothOptions::default()
        .with_method(Method::Trig)
        .with_tol_mm(0.01)
        .with_trig(TrigOptions::default().with_corner(corner))
}

fn bench(c: &mut Criterion) {
    let zz = zigzag();
    let mut g = c.benchmark_group("trig_corners");
    g.throughput(Throughput::Elements(CORNERS as u64));
    g.bench_function("round", |b| {
        let o = opts(CornerStyle::Round);
        b.iter(|| smooth(black_box(&zz), &o).unwrap())
    });
    g.bench_function("loop", |b| {
        let o = opts(CornerStyle::Loop { loop_size_mm: 1.0 });
        b.iter(|| smooth(black_box(&zz), &o).unwrap())
    });
    g.finish();

    let sp = spiral();
    let mut g = c.benchmark_group("trig_runs");
    g.throughput(Throughput::Elements(5000));
    g.bench_function("spiral_5000_lines", |b| {
        let o = opts(CornerStyle::Round);
        b.iter(|| smooth(black_box(&sp), &o).unwrap())
    });
    g.finish();

    let seg = TrigSpline::hermite(
        Vec3::ZERO,
        Vec3::new(10.0, 0.0, 0.0),
        Vec3::new(10.0, 10.0, 0.0),
        Vec3::new(0.0, 10.0, 0.0),
        1.0,
    );
    c.bench_function("trig_flatten_1um", |b| {
        b.iter(|| {
            let mut n = 0usize;
            black_box(&seg).flatten(1e-3, &mut |_| n += 1);
            n
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
