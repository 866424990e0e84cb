//! `ncsmooth compare`: every method (`none`, `bspline`, `arc`, `nurbs`, `trig`) on the same
//! program and limits, side by side: one table on the terminal, `DIR/compare.json`,
//! `DIR/index.html` (the page of [`crate::report`]; its plots also as `DIR/plots/*.svg`)
//! and each method's written G-code (`DIR/<stem>_<method>.ngc`; with `--setpoints` also
//! its setpoints CSV).
//!
//! Per method, two results of the same smoothing code:
//! * the **written G-code**: [`SmoothJob`], exactly what `smooth --method M --tol T`
//!   writes (curves built to `tol - chord - rounding`, flattened, read back and measured);
//! * the **setpoints**: the path `plan --method M --tol T` plans (curves built to the whole
//!   tolerance, [`PlanJob::smooth`]) under the same limits and default
//!   interpolation. Its JSON (`methods[i].plan`) is what `plan --report` writes for that
//!   method, timings aside (an ignored test checks this on every shared file); the plots
//!   and the table's deviation are of this path, measured against the program.
//!
//! A method whose written G-code misses the tolerance or whose setpoints break a limit is
//! shown in red on the page; the run then writes the report but none of that method's
//! files, and exits 1 (as `smooth` and `plan` would).
//!
//! `--emit` and `--dialect` are not accepted yet: every method is written for LinuxCNC
//! with [`SmoothJob`]'s defaults.

use crate::cmd_plan::axes;
use crate::cmd_smooth::job_error;
use crate::io::{self, OutputFile};
use crate::{load, progress, Ui};
use anyhow::{bail, Context, Result};
use clap::Args;
use ncsmooth::feed::PlanOptions;
use ncsmooth::interp::{execute_into, InterpOptions, SetpointWriter};
use ncsmooth::smooth::Method;
use ncsmooth::verify::{Continuity, Deviation};
use ncsmooth_gcode::PlanRunReport;
use ncsmooth_gcode::{PlanJob, SmoothJob};
use ncsmooth_report::{self as report, GcodeSummary, MethodView, PageView, PlotData};
use serde::Serialize;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Methods compared, in the table's order (`none` first: the reference of the speed-up).
pub const METHODS: [Method; Method::ALL.len()] = Method::ALL;
/// Decimals of the written G-code (`smooth`'s default).
const DECIMALS: usize = 4;
/// Write buffer of a setpoint file (bytes).
const SETPOINT_BUFFER_BYTES: usize = 1 << 20;

/// Arguments of `compare`.
#[derive(Args, Debug)]
#[command(allow_negative_numbers = true)]
pub struct CompareArgs {
    /// G-code file, or `-` for stdin.
    pub file: String,
    /// Two-sided tolerance (mm).
    #[arg(long, default_value_t = 0.01)]
    pub tol: f64,
    /// Largest feed (mm/s); a lower programmed F wins.
    #[arg(long, default_value_t = 50.0)]
    pub feed: f64,
    /// Per-axis acceleration limit (mm/s^2): one value or x,y,z.
    #[arg(long, default_value = "500")]
    pub acc: String,
    /// Per-axis jerk limit (mm/s^3): one value or x,y,z [default: none, trapezoid].
    #[arg(long)]
    pub jerk: Option<String>,
    /// Interpolation period (s), from 1e-5 to 0.1.
    #[arg(long, default_value_t = 0.001)]
    pub period: f64,
    /// Output directory (created if missing).
    #[arg(long, default_value = "ncsmooth-compare")]
    pub out: PathBuf,
    /// Also write each method's setpoints (`<stem>_<method>.csv`; one row per period).
    #[arg(long)]
    pub setpoints: bool,
}

/// What `compare` runs: one program under one set of limits.
pub struct Job<'a> {
    /// Input name.
    pub name: &'a str,
    /// Its text.
    pub src: &'a [u8],
    /// Parsed.
    pub program: &'a ncsmooth_gcode::Program,
    /// Seconds parsing.
    pub parse_s: f64,
    /// Tolerance (mm).
    pub tol: f64,
    /// Limits.
    pub popts: PlanOptions,
    /// Output directory.
    pub out: &'a Path,
    /// File-name stem of the outputs.
    pub stem: String,
    /// Write each method's setpoints.
    pub setpoints: bool,
    /// Show the program's text on the page.
    pub embed_source: bool,
}

/// One method's results in `compare.json`.
#[derive(Serialize)]
pub struct MethodResult {
    /// Method name.
    pub method: &'static str,
    /// Cycle time of `none` over this method's.
    pub speedup_vs_none: Option<f64>,
    /// Wall-clock seconds of this method's work (G-code, plan, measurements).
    pub compute_s: f64,
    /// Measured deviation of the planned path from the program.
    pub path_deviation: Deviation,
    /// Continuity of the planned path.
    pub path_continuity: Continuity,
    /// The written G-code.
    pub gcode: GcodeSummary,
    /// Setpoint file written, if any.
    pub setpoints: Option<String>,
    /// What `plan --method M --report` gives.
    pub plan: PlanRunReport,
    /// Why this method failed, if it did (then none of its files is written).
    pub failure: Option<String>,
}

/// `compare.json`.
#[derive(Serialize)]
pub struct CompareReport {
    /// Input name.
    pub input: String,
    /// Tolerance (mm).
    pub tol_mm: f64,
    /// Limits.
    pub limits: PlanOptions,
    /// The program, inspected.
    pub program: ncsmooth_gcode::InspectReport,
    /// Per method, in [`METHODS`] order.
    pub methods: Vec<MethodResult>,
    /// Size of `index.html` (bytes).
    pub page_bytes: usize,
}

/// The result of a [`compare`] run, for the caller to print.
pub struct Outcome {
    /// The summary table as text.
    pub table: String,
    /// Path of the page.
    pub page: PathBuf,
    /// The methods that failed (already reported on the page).
    pub failures: Vec<String>,
}

/// One method's run, files still uncommitted.
struct Run {
    result: MethodResult,
    data: PlotData,
    files: Vec<OutputFile>,
}

/// Runs one method (see the module doc).
fn run_method(job: &Job, m: Method, pb: &indicatif::ProgressBar) -> Result<Run> {
    let t0 = Instant::now();
    let name = m.name();
    pb.set_message(format!("{name}: smoothing, writing and verifying G-code"));
    let out = SmoothJob::new(m, job.tol)
        .with_decimals(DECIMALS)
        .with_read_options(crate::parse_options().clone())
        .run(job.name, job.src, job.program)
        .map_err(job_error)?;
    let gfile = format!("{}_{name}.ngc", job.stem);
    let mut gout = OutputFile::create(&job.out.join(&gfile))?;
    gout.write_all(&out.gcode)
        .with_context(|| format!("writing {gfile}"))?;
    pb.set_message(format!("{name}: planning"));
    let t1 = Instant::now();
    let smoothed = PlanJob::new(m, job.tol)
        .smooth(&job.program.toolpath)
        .map_err(job_error)?;
    let smooth_s = t1.elapsed().as_secs_f64();
    let sfile = job.setpoints.then(|| format!("{}_{name}.csv", job.stem));
    let csv = match &sfile {
        Some(f) => Some(SetpointWriter::new(BufWriter::with_capacity(
            SETPOINT_BUFFER_BYTES,
            OutputFile::create(&job.out.join(f))?,
        ))),
        None => None,
    };
    let (plan, (csv, sink)) = execute_into(
        &smoothed.toolpath,
        &job.popts,
        &InterpOptions::default(),
        (csv, report::PlotSink::default()),
    )?;
    let mut files = vec![gout];
    if let Some(w) = csv {
        files.push(w.into_inner()?.into_inner().map_err(|e| e.into_error())?);
    }
    pb.set_message(format!("{name}: measuring the planned path"));
    let data = PlotData::measure(&job.program.toolpath, smoothed.toolpath, sink, job.tol);
    let mut failure = plan
        .broken_limits()
        .map(|b| format!("{name}: the plan does not hold its limits: {b}"));
    if !out.report.within_tol {
        failure = Some(format!(
            "{name}: the written G-code deviates {:.6} mm from the program (tol {} mm)",
            out.report.deviation.max_mm(),
            job.tol
        ));
    }
    let blocks = out.gcode.iter().filter(|&&b| b == b'\n').count();
    let total = job.parse_s + smooth_s + plan.stage_time_s.total_s;
    let result = MethodResult {
        method: name,
        speedup_vs_none: None,
        compute_s: t0.elapsed().as_secs_f64(),
        path_deviation: data.deviation.clone(),
        path_continuity: data.continuity.clone(),
        gcode: GcodeSummary {
            file: gfile,
            blocks,
            bytes: out.gcode.len(),
            report: out.report,
        },
        setpoints: sfile,
        plan: PlanRunReport {
            input: job.name.to_string(),
            method: name.to_string(),
            smoothing: smoothed.report,
            parse_s: job.parse_s,
            smooth_s,
            end_to_end_real_time_factor: plan.cycle_time_s / total,
            plan,
        },
        failure,
    };
    Ok(Run {
        result,
        data,
        files,
    })
}

/// The page of the methods' runs.
fn page_view<'a>(job: &'a Job, runs: &'a [Run], failures: &[String]) -> PageView<'a> {
    PageView {
        title: format!("ncsmooth compare: {}", job.name),
        input: job.name,
        tol: job.tol,
        limits: &job.popts,
        program: &job.program.toolpath,
        source: job.embed_source.then_some(job.src),
        methods: runs
            .iter()
            .map(|r| MethodView {
                name: r.result.method,
                plan: &r.result.plan,
                gcode: Some(&r.result.gcode),
                speedup: r.result.speedup_vs_none,
                compute_s: r.result.compute_s,
                data: &r.data,
                setpoints_file: r.result.setpoints.as_deref(),
            })
            .collect(),
        notes: failures.to_vec(),
    }
}

/// Runs every method of [`METHODS`] on `job`, writes the page, the JSON, the plots and
/// the files of the methods that succeeded.
pub fn compare(job: &Job, ui: Ui) -> Result<Outcome> {
    std::fs::create_dir_all(job.out.join("plots"))
        .map_err(|e| io::BadInput(format!("cannot create {}: {e}", job.out.display())))?;
    let pb = progress::bar(ui, METHODS.len() as u64, "compare");
    let mut runs = Vec::new();
    for m in METHODS {
        runs.push(run_method(job, m, &pb)?);
        pb.inc(1);
    }
    pb.finish_and_clear();
    let none_cycle = runs[0].result.plan.plan.cycle_time_s;
    for r in &mut runs {
        r.result.speedup_vs_none = Some(none_cycle / r.result.plan.plan.cycle_time_s);
    }
    let failures: Vec<String> = runs
        .iter()
        .filter_map(|r| r.result.failure.clone())
        .collect();
    let page = page_view(job, &runs, &failures);
    let (html, svgs) = report::render_page(&page);
    let table = report::table_text(&page.methods);
    drop(page);
    let mut files: Vec<OutputFile> = Vec::new();
    let mut results = Vec::new();
    for r in runs {
        if r.result.failure.is_none() {
            files.extend(r.files);
        }
        results.push(r.result);
    }
    let report = CompareReport {
        input: job.name.to_string(),
        tol_mm: job.tol,
        limits: job.popts.clone(),
        program: ncsmooth_gcode::InspectReport::of(job.name, job.program),
        methods: results,
        page_bytes: html.len(),
    };
    let page_path = job.out.join("index.html");
    let mut add = |path: PathBuf, bytes: &[u8]| -> Result<()> {
        let mut f = OutputFile::create(&path)?;
        f.write_all(bytes)
            .with_context(|| format!("writing {}", path.display()))?;
        files.push(f);
        Ok(())
    };
    add(page_path.clone(), html.as_bytes())?;
    add(
        job.out.join("compare.json"),
        serde_json::to_string_pretty(&report)?.as_bytes(),
    )?;
    for (id, svg) in &svgs {
        add(
            job.out.join("plots").join(format!("{id}.svg")),
            svg.as_bytes(),
        )?;
    }
    io::commit_all(files)?;
    Ok(Outcome {
        table,
        page: page_path,
        failures,
    })
}

/// The limits `compare` plans under, validated (bad input otherwise).
pub fn limits(feed: f64, acc: &str, jerk: Option<&str>, period: f64) -> Result<PlanOptions> {
    ncsmooth_gcode::check_period(period).map_err(job_error)?;
    let popts = PlanOptions {
        feed_mm_s: feed,
        acc_mm_s2: axes("acc", acc)?,
        jerk_mm_s3: jerk.map(|j| axes("jerk", j)).transpose()?,
        period_s: period,
        ..Default::default()
    };
    popts
        .validate()
        .map_err(|e| io::BadInput(format!("--{e}")))?;
    Ok(popts)
}

/// Prints the outcome; failures become the run's error (exit 1).
pub fn finish(outcome: &Outcome, ui: Ui) -> Result<()> {
    if !ui.quiet {
        crate::io::print_stdout(outcome.table.as_bytes())?;
    }
    ui.status(format!("report: {}", outcome.page.display()));
    if !outcome.failures.is_empty() {
        bail!(
            "{}; the page shows it, that method's files were not written",
            outcome.failures.join("; ")
        );
    }
    Ok(())
}

/// Runs `compare`.
pub fn run(a: CompareArgs, ui: Ui) -> Result<()> {
    let popts = limits(a.feed, &a.acc, a.jerk.as_deref(), a.period)?;
    let t0 = Instant::now();
    let loaded = load(&a.file)?;
    let parse_s = t0.elapsed().as_secs_f64();
    let name = io::display_name(&a.file);
    let stem = Path::new(&a.file)
        .file_stem()
        .map_or("stdin".into(), |s| s.to_string_lossy().into_owned());
    let stem = if a.file == "-" { "stdin".into() } else { stem };
    let mut outputs: Vec<(String, PathBuf)> = ["index.html", "compare.json"]
        .iter()
        .map(|f| ("--out".to_string(), a.out.join(f)))
        .collect();
    for m in METHODS {
        outputs.push((
            "--out".into(),
            a.out.join(format!("{stem}_{}.ngc", m.name())),
        ));
        if a.setpoints {
            outputs.push((
                "--out".into(),
                a.out.join(format!("{stem}_{}.csv", m.name())),
            ));
        }
    }
    let outputs: Vec<(&str, &Path)> = outputs
        .iter()
        .map(|(f, p)| (f.as_str(), p.as_path()))
        .collect();
    io::check_outputs(Some(&a.file), &outputs)?;
    let job = Job {
        name,
        src: &loaded.src,
        program: &loaded.program,
        parse_s,
        tol: a.tol,
        popts,
        out: &a.out,
        stem,
        setpoints: a.setpoints,
        embed_source: true,
    };
    let outcome = compare(&job, ui)?;
    finish(&outcome, ui)
}
