//! The demo (`ncsmooth` with no arguments): the built-in butterfly profile (a published
//! NURBS compiled into the binary) sampled into 1000 micro-lines, then `compare` on it
//! (tol 0.01 mm, 50 mm/s, 500 mm/s^2, jerk 5000 mm/s^3, 1 ms): every method smoothed,
//! verified and planned; the table on the terminal; the page `index.html`, `compare.json`,
//! the plots, the program, each method's G-code and setpoints in `--out` (default
//! `ncsmooth-demo/`).

use crate::{cmd_compare, io, Ui};
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

/// Segments of the sampled butterfly.
const DEMO_SEGMENTS: usize = 1000;
/// Accuracy (mm) of the arc-length sampling.
const DEMO_SAMPLING_ACCURACY: f64 = 1e-7;
/// Demo feed (mm/min, the program's F word).
const DEMO_FEED_MM_MIN: f64 = 3000.0;

/// Arguments of `demo`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
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

/// Demo limits: feed (mm/s), acceleration (mm/s^2), jerk (mm/s^3), period (s).
const DEMO_FEED_MM_S: f64 = 50.0;
const DEMO_ACC_MM_S2: &str = "500";
const DEMO_JERK_MM_S3: &str = "5000";
const DEMO_PERIOD_S: f64 = 0.001;

/// Runs the demo: `compare` on the sampled butterfly, with the setpoints.
pub fn run(a: DemoArgs, ui: Ui) -> Result<()> {
    std::fs::create_dir_all(&a.out)
        .map_err(|e| io::BadInput(format!("cannot create {}: {e}", a.out.display())))?;
    let t0 = std::time::Instant::now();
    let src = demo_gcode();
    let program = ncsmooth_gcode::parse_str(
        &src,
        "butterfly_1000.ngc",
        &ncsmooth_gcode::ParseOptions::default(),
    )?;
    let parse_s = t0.elapsed().as_secs_f64();
    let inspect = ncsmooth_gcode::InspectReport::of("butterfly_1000.ngc (built in)", &program);
    ui.status(inspect.text());
    io::write_atomic(&a.out.join("butterfly_1000.ngc"), src.as_bytes())?;
    let popts = cmd_compare::limits(
        DEMO_FEED_MM_S,
        DEMO_ACC_MM_S2,
        Some(DEMO_JERK_MM_S3),
        DEMO_PERIOD_S,
    )?;
    let job = ncsmooth_report::CompareJob::new(
        "butterfly_1000.ngc",
        src.as_bytes(),
        &program,
        a.tol,
        popts,
    )
    .with_parse_s(parse_s)
    .with_stem("butterfly");
    let outcome = cmd_compare::compare(&job, &a.out, true, ui)?;
    cmd_compare::finish(&outcome, ui)?;
    // The page's path, always (also with --quiet): it is what the demo is for.
    if ui.quiet {
        crate::io::print_stdout(format!("{}\n", outcome.page.display()).as_bytes())?;
    }
    Ok(())
}
