//! The demo (`ncsmooth` with no arguments): the built-in butterfly profile (a published
//! NURBS compiled into the binary) sampled into 1000 micro-lines, inspected, smoothed with
//! every method, verified, and written with a JSON report into `--out` (default
//! `ncsmooth-demo/`).

use crate::cmd_smooth::smooth_program;
use crate::{cmd_inspect, io, Ui};
use anyhow::Result;
use clap::Args;
use ncsmooth::feed::PlanOptions;
use ncsmooth::interp::{execute, InterpOptions};
use ncsmooth::smooth::Method;
use serde::Serialize;
use std::path::PathBuf;

/// Segments of the sampled butterfly.
const DEMO_SEGMENTS: usize = 1000;
/// Accuracy (mm) of the arc-length sampling.
const DEMO_SAMPLING_ACCURACY: f64 = 1e-7;
/// Demo feed (mm/min, the program's F word).
const DEMO_FEED_MM_MIN: f64 = 3000.0;

/// Arguments of `demo`.
#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Output directory.
    #[arg(long, default_value = "ncsmooth-demo")]
    pub out: PathBuf,
    /// Two-sided tolerance (mm).
    #[arg(long, default_value_t = 0.01)]
    pub tol: f64,
}

impl Default for DemoArgs {
    fn default() -> Self {
        DemoArgs {
            out: PathBuf::from("ncsmooth-demo"),
            tol: 0.01,
        }
    }
}

/// The demo program as G-code text.
pub fn demo_gcode() -> String {
    use std::fmt::Write;
    let pts = ncsmooth::profiles::butterfly_polyline(DEMO_SEGMENTS, DEMO_SAMPLING_ACCURACY);
    let mut s =
        String::from("(ncsmooth demo: butterfly NURBS as 1000 micro-lines)\nG21 G90 G17 G94\n");
    let _ = writeln!(s, "G0 X{:.4} Y{:.4}", pts[0].x, pts[0].y);
    let _ = writeln!(s, "G1 F{DEMO_FEED_MM_MIN}");
    for p in &pts[1..] {
        let _ = writeln!(s, "G1 X{:.4} Y{:.4}", p.x, p.y);
    }
    s.push_str("M2\n");
    s
}

#[derive(Serialize)]
struct MethodResult {
    method: &'static str,
    output: String,
    deviation_output_to_program_mm: f64,
    deviation_vertex_to_output_mm: f64,
    within_tol: bool,
    corners_smoothed: usize,
    g2_joints: usize,
    g1_joints: usize,
    g0_joints: usize,
    seconds: f64,
    setpoints: String,
    plan: PlanSummary,
}

/// Planning figures of one method in the demo.
#[derive(Serialize)]
struct PlanSummary {
    cycle_time_s: f64,
    setpoints: usize,
    eta_max: f64,
    limits_held: bool,
    max_fd_acc_mm_s2: f64,
    max_fd_acc_ratio: f64,
    real_time_factor: f64,
}

#[derive(Serialize)]
struct DemoReport {
    tol_mm: f64,
    input: cmd_inspect::InspectReport,
    methods: Vec<MethodResult>,
}

/// Methods the demo runs.
const DEMO_METHODS: [Method; 5] = [
    Method::None,
    Method::Bspline,
    Method::Arc,
    Method::Nurbs,
    Method::Trig,
];

/// Runs the demo.
pub fn run(a: DemoArgs, ui: Ui) -> Result<()> {
    std::fs::create_dir_all(&a.out)
        .map_err(|e| io::BadInput(format!("cannot create {}: {e}", a.out.display())))?;
    let src = demo_gcode();
    let program = ncsmooth_gcode::parse_str(
        &src,
        "butterfly_1000.ngc",
        &ncsmooth_gcode::ParseOptions::default(),
    )?;
    let inspect = cmd_inspect::report("butterfly_1000.ngc (built in)", &program);
    ui.status(cmd_inspect::render_text(&inspect));
    io::write_atomic(&a.out.join("butterfly_1000.ngc"), src.as_bytes())?;
    let mut methods = Vec::new();
    for m in DEMO_METHODS {
        let t0 = std::time::Instant::now();
        let out = smooth_program(
            "butterfly_1000.ngc",
            src.as_bytes(),
            &program,
            ncsmooth::smooth::SmoothOptions {
                method: m,
                ..Default::default()
            },
            a.tol,
            None,
            4,
        )?;
        let file = format!("butterfly_{}.ngc", m.name());
        io::write_atomic(&a.out.join(&file), &out.gcode)?;
        // Plan the smoothed path (curves as they are) with the default machine limits.
        let (plan, csv) = execute(
            &out.smoothed,
            &PlanOptions::default(),
            &InterpOptions::default(),
            Vec::new(),
        )?;
        let setpoints = format!("butterfly_{}.csv", m.name());
        io::write_atomic(&a.out.join(&setpoints), &csv)?;
        let plan = PlanSummary {
            cycle_time_s: plan.cycle_time_s,
            setpoints: plan.setpoints,
            eta_max: plan.interp.eta_max,
            limits_held: plan.limits_held,
            max_fd_acc_mm_s2: plan
                .axes
                .iter()
                .map(|ax| ax.a_max_mm_s2)
                .fold(0.0, f64::max),
            max_fd_acc_ratio: plan.axes.iter().map(|ax| ax.a_ratio).fold(0.0, f64::max),
            real_time_factor: plan.real_time_factor,
        };
        let r = &out.report;
        ui.status(format!(
            "{:>8}: deviation {:.6} / {:.6} mm (tol {}), {} corners smoothed, joints G2 {} G1 {} G0 {}; cycle {:.3} s at 50 mm/s, 500 mm/s^2",
            m.name(),
            r.deviation.output_to_programmed_mm,
            r.deviation.vertex_to_output_mm,
            a.tol,
            r.smoothing.corners_smoothed,
            r.continuity.g2,
            r.continuity.g1,
            r.continuity.g0,
            plan.cycle_time_s
        ));
        methods.push(MethodResult {
            method: m.name(),
            output: file,
            deviation_output_to_program_mm: r.deviation.output_to_programmed_mm,
            deviation_vertex_to_output_mm: r.deviation.vertex_to_output_mm,
            within_tol: r.within_tol,
            corners_smoothed: r.smoothing.corners_smoothed,
            g2_joints: r.continuity.g2,
            g1_joints: r.continuity.g1,
            g0_joints: r.continuity.g0,
            seconds: t0.elapsed().as_secs_f64(),
            setpoints,
            plan,
        });
    }
    let report = DemoReport {
        tol_mm: a.tol,
        input: inspect,
        methods,
    };
    let path = a.out.join("report.json");
    io::write_atomic(&path, serde_json::to_string_pretty(&report)?.as_bytes())?;
    ui.status(format!("demo report written to {}", path.display()));
    Ok(())
}
