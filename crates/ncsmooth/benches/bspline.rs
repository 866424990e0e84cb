//! Corners per second of `--method bspline` (Guo et al. corner transitions) on one core:
//! `butterfly_1000.ngc` and `camotics_tiger.nc`, parsed outside the timed loop. Two
//! figures per file: the whole `smooth()` (chain split, transitions, assembly of the output
//! program) and the method alone on pre-split chains. Throughput elements = corners
//! smoothed. Skips when `../shared` is absent.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use ncsmooth::path::{Block, Move, MoveKind, Toolpath};
use ncsmooth::smooth::{bspline_corner, smooth, Chain, Method, SmoothOptions, SmoothReport};
use std::hint::black_box;
use std::path::PathBuf;

fn load(rel: &str) -> Option<Toolpath> {
    // `../shared` from the workspace root; a git worktree elsewhere may point
    // NCSMOOTH_SHARED_DATA at the data directory instead.
    let base = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    let base = match std::env::var_os("NCSMOOTH_SHARED_DATA") {
        Some(d) if !base.is_dir() => PathBuf::from(d),
        _ => base,
    };
    let p = base.join(rel);
    let Ok(bytes) = std::fs::read(&p) else {
        eprintln!("SKIP: {} not found", p.display());
        return None;
    };
    let src = String::from_utf8_lossy(&bytes);
    Some(
        ncsmooth_gcode::parse_str(&src, rel, &Default::default())
            .expect("parse")
            .toolpath,
    )
}

/// Maximal runs of feed moves (what `smooth` hands to the method).
fn chains(tp: &Toolpath) -> Vec<Vec<Move>> {
    let mut out = vec![];
    let mut run = vec![];
    for b in &tp.blocks {
        match b {
            Block::Move(m) if m.kind == MoveKind::Feed && !m.pinned => run.push(m.clone()),
            _ => {
                if !run.is_empty() {
                    out.push(std::mem::take(&mut run));
                }
            }
        }
    }
    if !run.is_empty() {
        out.push(run);
    }
    out
}

fn bench(c: &mut Criterion) {
    let opts = SmoothOptions::default()
        .with_method(Method::Bspline)
        .with_tol_mm(0.01);
    for (name, rel) in [
        ("butterfly_1000", "profiles/butterfly_1000.ngc"),
        ("camotics_tiger", "gcode/camotics_tiger.nc"),
    ] {
        let Some(tp) = load(rel) else { continue };
        let corners = smooth(&tp, &opts).unwrap().report.corners_smoothed as u64;
        let mut g = c.benchmark_group(format!("bspline/{name}"));
        g.throughput(Throughput::Elements(corners));
        g.bench_function("smooth", |b| {
            b.iter(|| smooth(black_box(&tp), &opts).unwrap())
        });
        let chains = chains(&tp);
        g.bench_function("method_only", |b| {
            b.iter(|| {
                let mut report = SmoothReport::default();
                let mut n = 0usize;
                for ch in &chains {
                    let chain = Chain {
                        moves: ch,
                        start_extra: None,
                        open_ends: [false; 2],
                    };
                    n += bspline_corner::smooth_chain(&chain, &opts, &opts.bspline, &mut report)
                        .len();
                }
                black_box(n)
            })
        });
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
