//! Throughput of the verification core: two-sided deviation on a 200k-segment program.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use ncsmooth::geom::{Line, Segment, Vec3};
use ncsmooth::verify::deviation_segments;

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
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
