//! Checks a planned speed profile in continuous time, between the planner's grid points:
//! along every constant-acceleration piece, the per-axis acceleration `u T_i + v^2 K_i`
//! is evaluated at interior points from the exact geometry and compared with the limit.
//! A development tool for the planning grid (`ncsmooth::feed::grid`); the finite
//! differences of the setpoints are what the CLI and the tests measure.
//!
//! Usage: `profile_check FILE.ngc METHOD TOL [ACC] [PERIOD]`, e.g.
//! `profile_check butterfly_1000.ngc bspline 0.01 500 0.002`. Prints grid statistics, the
//! worst interior ratio and where it is.
#![forbid(unsafe_code)]

use ncsmooth::feed::{plan_stream, PathIndex, PlanEvent, PlanOptions};
use ncsmooth::geom::{ParamCurveArclen, ParamCurveCurvature, ParamCurveDeriv, Segment};
use ncsmooth::smooth::{smooth, Method, SmoothOptions};
use std::time::Instant;

/// Interior samples per profile piece.
const SAMPLES: usize = 16;
/// Pieces shorter than this (mm) are skipped.
const MIN_PIECE_MM: f64 = 1e-9;
/// Accuracy (mm) of the arc-length inversion.
const ACCURACY_MM: f64 = 1e-10;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 4 {
        eprintln!("usage: profile_check FILE METHOD TOL [ACC] [PERIOD]");
        std::process::exit(2);
    }
    let src = std::fs::read(&args[1]).expect("readable file");
    let prog = ncsmooth_gcode::parse_bytes(&src, &args[1], &Default::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let method = Method::from_name(&args[2]).expect("method name");
    let tol: f64 = args[3].parse().expect("tol");
    let acc: f64 = args.get(4).map_or(500.0, |a| a.parse().expect("acc"));
    let period: f64 = args.get(5).map_or(0.001, |a| a.parse().expect("period"));
    let s = smooth(
        &prog.toolpath,
        &SmoothOptions::default()
            .with_method(method)
            .with_tol_mm(tol),
    )
    .expect("valid options");
    let opts = PlanOptions::default()
        .with_acc_mm_s2([acc; 3])
        .with_period_s(period);
    let index = PathIndex::new(&s.toolpath, &opts);
    let mut pieces = Vec::new();
    let clock = Instant::now();
    let stats = plan_stream(&index, &opts, |ev| {
        if let PlanEvent::Piece(p) = ev {
            pieces.push(p)
        }
    });
    let plan_s = clock.elapsed().as_secs_f64();
    let mut worst = (0.0f64, 0.0f64, String::new());
    let mut time = 0.0;
    let mut mv = 0usize;
    for p in &pieces {
        time += p.dt;
        // Rounding slivers of the accelerate/cruise/decelerate split carry no motion.
        if p.ds < MIN_PIECE_MM {
            continue;
        }
        for i in 1..SAMPLES {
            let tau = p.dt * i as f64 / SAMPLES as f64;
            let (s_at, v) = p.at(tau);
            while mv + 1 < index.moves.len() && index.moves[mv + 1].s0 <= s_at {
                mv += 1;
            }
            while mv > 0 && index.moves[mv].s0 > s_at {
                mv -= 1;
            }
            let m = &index.moves[mv];
            let seg: &Segment = &m.segment;
            let t = seg.inv_arclen((s_at - m.s0).clamp(0.0, m.len), ACCURACY_MM);
            let tan = seg.deriv(t).normalized().unwrap_or_default();
            let k = seg.curvature_vec(t);
            let u = p.acc();
            for ax in 0..3 {
                let a = (u * tan[ax] + v * v * k[ax]).abs();
                let r = a / acc;
                if r > worst.0 {
                    let kind = match seg {
                        Segment::Line(_) => "line",
                        Segment::Arc(_) => "arc",
                        Segment::CubicBez(_) => "bezier",
                        Segment::Nurbs(_) => "nurbs",
                        Segment::Trig(_) => "trig",
                    };
                    worst = (
                        r,
                        s_at,
                        format!(
                            "move {mv} ({kind}, s0 {:.6}, len {:.6}), piece s0 {:.6} ds {:.3e}, t = {t:.6}, axis {ax}, v = {v:.4}, u = {u:.2}, |K| = {:.4}, T = {:?}",
                            m.s0, m.len, p.s0, p.ds,
                            k.norm(), tan
                        ),
                    );
                }
            }
        }
    }
    println!(
        "grid points {}, plan {:.4} s, pieces {}, cycle {:.4} s; worst interior acc {:.5} x limit at s = {:.4}: {}",
        stats.grid_points,
        plan_s,
        pieces.len(),
        time,
        worst.0,
        worst.1,
        worst.2
    );
}
