//! Throughput of Wu et al.'s methods: corners per second of `--method arc`, points per
//! second of the global cubic interpolation (banded A9.1) at 1 000 and 100 000 points, and
//! input points per second of the whole `--method nurbs`.
#![allow(missing_docs)]

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use ncsmooth::geom::global_interp::{interpolate, Parametrization};
use ncsmooth::smooth::{smooth, Method, SmoothOptions};
use ncsmooth::{Toolpath, Vec3};
use std::hint::black_box;

/// A star-like polyline: `n` corners of varying angle and leg length.
fn corners(n: usize) -> Vec<Vec3> {
    (0..=n)
        .map(|i| {
            let a = i as f64 * 2.39996;
            let r = if i % 2 == 0 {
                10.0
            } else {
                4.0 + (i % 7) as f64
            };
            Vec3::new(r * a.cos(), r * a.sin(), 0.1 * (i % 5) as f64)
        })
        .collect()
}

/// `n` points sampling a smooth wiggly curve.
fn samples(n: usize) -> Vec<Vec3> {
    (0..n)
        .map(|i| {
            let t = i as f64 * 0.05;
            Vec3::new(t, 3.0 * (0.3 * t).sin(), 0.5 * (0.1 * t).cos())
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let n = 10_000;
    let tp = Toolpath::from_polyline(&corners(n), Some(10.0));
    let opts = SmoothOptions::default()
        .with_method(Method::Arc)
        .with_tol_mm(0.01);
    let mut g = c.benchmark_group("arc_corners");
    g.throughput(Throughput::Elements((n - 1) as u64));
    g.bench_function("10k_corners", |b| b.iter(|| smooth(black_box(&tp), &opts)));
    g.finish();

    let mut g = c.benchmark_group("interp_fit");
    for n in [1_000usize, 100_000] {
        let pts = samples(n);
        g.throughput(Throughput::Elements(n as u64));
        g.bench_function(format!("{n}_points"), |b| {
            b.iter(|| interpolate(black_box(&pts), 3, Parametrization::ChordLength))
        });
    }
    g.finish();

    let pts = samples(5_000);
    let tp = Toolpath::from_polyline(&pts, Some(10.0));
    let opts = SmoothOptions::default()
        .with_method(Method::Nurbs)
        .with_tol_mm(0.01);
    let mut g = c.benchmark_group("nurbs_method");
    g.sample_size(10);
    g.throughput(Throughput::Elements(pts.len() as u64));
    g.bench_function("5k_points", |b| b.iter(|| smooth(black_box(&tp), &opts)));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
