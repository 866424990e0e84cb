//! Parse throughput on the largest real file (linuxcnc_stellabee1.ngc, 3.2 MB, inch,
//! G18 arcs and axis-only continuation lines), and write throughput of its toolpath.
//! Skips with a message when the shared test data is absent.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use ncsmooth_gcode::{parse_bytes, write, ParseOptions, WriteOptions};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/gcode/linuxcnc_stellabee1.ngc"
    );
    let Ok(src) = std::fs::read(path) else {
        println!("SKIP: {path} not found; no parse benchmark");
        return;
    };
    let mut g = c.benchmark_group("parse");
    g.throughput(Throughput::Bytes(src.len() as u64));
    g.sample_size(20);
    g.bench_function("stellabee1", |b| {
        b.iter(|| {
            let p = parse_bytes(black_box(&src), "stellabee1.ngc", &ParseOptions::default())
                .expect("parses");
            black_box(p.toolpath.blocks.len())
        })
    });
    g.finish();
    let prog = parse_bytes(&src, "stellabee1.ngc", &ParseOptions::default()).expect("parses");
    let mut g = c.benchmark_group("write");
    g.throughput(Throughput::Bytes(src.len() as u64));
    g.sample_size(20);
    g.bench_function("stellabee1", |b| {
        b.iter(|| black_box(write(black_box(&prog.toolpath), &WriteOptions::default()).len()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
