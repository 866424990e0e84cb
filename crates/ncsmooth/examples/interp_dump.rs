//! Dumps the control points and knots of our global cubic interpolation (NURBS Book A9.1,
//! `ncsmooth::geom::global_interp::interpolate`) as JSON, for comparison with geomdl
//! (`scripts/geomdl_compare.py`).
//!
//! Usage: `interp_dump POINTS.txt [--centripetal] [--reps N]`; POINTS.txt holds one point
//! per line, `x y z` separated by blanks. Prints `{"ctrl": [[x,y,z],...], "knots": [...],
//! "seconds": best time of N runs}` on stdout.
#![forbid(unsafe_code)]

use ncsmooth::geom::global_interp::{interpolate, Parametrization};
use ncsmooth::Vec3;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let Some(path) = args.get(1) else {
        eprintln!("usage: interp_dump POINTS.txt [--centripetal] [--reps N]");
        std::process::exit(2);
    };
    let kind = if args.iter().any(|a| a == "--centripetal") {
        Parametrization::Centripetal
    } else {
        Parametrization::ChordLength
    };
    let reps: usize = args
        .iter()
        .position(|a| a == "--reps")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| {
        eprintln!("{path}: {e}");
        std::process::exit(1);
    });
    let pts: Vec<Vec3> = text
        .lines()
        .filter_map(|l| {
            let v: Vec<f64> = l
                .split_whitespace()
                .filter_map(|w| w.parse().ok())
                .collect();
            (v.len() == 3).then(|| Vec3::new(v[0], v[1], v[2]))
        })
        .collect();
    let mut best = f64::INFINITY;
    let mut curve = None;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        let c = interpolate(&pts, 3, kind);
        best = best.min(t.elapsed().as_secs_f64());
        curve = c;
    }
    let Some(c) = curve else {
        eprintln!("interpolation failed (degenerate points?)");
        std::process::exit(1);
    };
    let ctrl: Vec<String> = c
        .ctrl()
        .iter()
        .map(|p| format!("[{:?},{:?},{:?}]", p.x, p.y, p.z))
        .collect();
    let knots: Vec<String> = c.knots().iter().map(|k| format!("{k:?}")).collect();
    println!(
        "{{\"ctrl\":[{}],\"knots\":[{}],\"seconds\":{:?}}}",
        ctrl.join(","),
        knots.join(","),
        best
    );
}
