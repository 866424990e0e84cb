//! Throughput of the verification core: two-sided deviation on a 200k-segment program,
//! and on a spiral of 1000 arcs against the same arcs as a written program reads them back
//! (end points rounded to 1e-4 mm, centres 2e-4 mm off: every output arc runs a few
//! rounding units off a programmed circle, the case of linuxcnc_arcspiral).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use ncsmooth::geom::{Arc, Line, Segment, Vec3};
use ncsmooth::verify::deviation_segments;
use std::f64::consts::TAU;

fn zigzag(n: usize, dz: f64) -> Vec<Segment> {
    let pts: Vec<Vec3> = (0..=n)
        .map(|i| {
            Vec3::new(
                i as f64 * 0.1,
                (i % 2) as f64 * 0.05 + (i as f64 * 0.001).sin(),
                dz,
            )
        })
        .collect();
    pts.windows(2)
        .map(|w| Segment::Line(Line::new(w[0], w[1])))
        .collect()
}

/// Arcs per turn of [`spiral`].
const ARCS_PER_TURN: usize = 36;

/// `n` arcs of a spiral (radius 50 mm shrinking 1.8 mm per turn, centre drifting), as
/// programmed and as read back.
fn spiral(n: usize) -> (Vec<Segment>, Vec<Segment>) {
    let step = TAU / ARCS_PER_TURN as f64;
    let at = |k: usize| {
        let a = -(k as f64) * step;
        let rad = 50.0 - 1.8 * k as f64 / ARCS_PER_TURN as f64;
        let c = Vec3::new(0.02 * (k as f64 * 0.1).sin(), 0.0, -2.5);
        (c, c + Vec3::new(a.cos(), a.sin(), 0.0) * rad)
    };
    let round = |p: Vec3| Vec3::new((p.x * 1e4).round() / 1e4, (p.y * 1e4).round() / 1e4, p.z);
    let (mut prog, mut out) = (Vec::new(), Vec::new());
    for k in 0..n {
        let (c, p0) = at(k);
        let (_, p1) = at(k + 1);
        prog.push(Segment::Arc(
            Arc::from_center(p0, p1, c, Vec3::Z, false, 0).expect("arc"),
        ));
        let off = Vec3::new((k as f64 * 1.7).sin(), (k as f64 * 2.3).cos(), 0.0) * 2e-4;
        out.push(Segment::Arc(
            Arc::from_center(round(p0), round(p1), c + off, Vec3::Z, false, 0).expect("arc"),
        ));
    }
    (prog, out)
}

fn bench(c: &mut Criterion) {
    let n = 200_000;
    let a = zigzag(n, 0.0);
    let b = zigzag(n, 0.01);
    let ta: Vec<(&Segment, u32)> = a.iter().map(|s| (s, 1)).collect();
    let tb: Vec<(&Segment, u32)> = b.iter().map(|s| (s, 1)).collect();
    let mut g = c.benchmark_group("verify");
    g.throughput(Throughput::Elements(n as u64));
    g.sample_size(10);
    g.bench_function("deviation_200k_segments", |bch| {
        bch.iter(|| deviation_segments(&tb, &ta, 1e-5))
    });
    let arcs = 1000;
    let (prog, out) = spiral(arcs);
    let tp: Vec<(&Segment, u32)> = prog.iter().map(|s| (s, 1)).collect();
    let to: Vec<(&Segment, u32)> = out.iter().map(|s| (s, 1)).collect();
    g.throughput(Throughput::Elements(arcs as u64));
    g.bench_function("deviation_1000_rounded_spiral_arcs", |bch| {
        bch.iter(|| deviation_segments(&to, &tp, 1e-5))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
