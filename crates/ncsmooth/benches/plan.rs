//! Planning and interpolation throughput: the butterfly as 1000 micro-lines (junction
//! deviation, so the look-ahead spans the whole path) and as its NURBS (Newton steps).
//! Throughput is in setpoints.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use ncsmooth::feed::{plan_stream, PathIndex, PlanOptions};
use ncsmooth::geom::ParamCurve;
use ncsmooth::interp::{execute, InterpOptions};
use ncsmooth::path::{Move, Toolpath};
use std::hint::black_box;

fn paths() -> Vec<(&'static str, Toolpath, PlanOptions)> {
    let lines = Toolpath::from_polyline(&ncsmooth::profiles::butterfly_polyline(1000, 1e-7), None);
    let b = ncsmooth::profiles::butterfly();
    let mut nurbs = Toolpath::new(b.start());
    nurbs.push_move(Move::feed(b, None, 1));
    vec![
        (
            "butterfly_1000_lines_jd",
            lines,
            PlanOptions::default().with_junction_dev_mm(Some(0.01)),
        ),
        ("butterfly_nurbs", nurbs, PlanOptions::default()),
    ]
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("plan");
    g.sample_size(10);
    for (name, tp, opts) in paths() {
        let (rep, _) = execute(&tp, &opts, &InterpOptions::default(), std::io::sink()).unwrap();
        g.throughput(Throughput::Elements(rep.setpoints as u64));
        g.bench_function(format!("{name}/plan_only"), |b| {
            b.iter(|| {
                let idx = PathIndex::new(&tp, &opts);
                let mut n = 0usize;
                plan_stream(&idx, &opts, |_| n += 1);
                black_box(n)
            })
        });
        g.bench_function(format!("{name}/plan_interpolate_write"), |b| {
            b.iter(|| {
                let (r, _) =
                    execute(&tp, &opts, &InterpOptions::default(), std::io::sink()).unwrap();
                black_box(r.setpoints)
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
