//! `ncsmooth compare`: the arguments of a [`CompareJob`] (every method on the same
//! program and limits, side by side; what each result is, is the job's module doc), its
//! table on the terminal, `DIR/compare.json`, `DIR/index.html` (its plots also as
//! `DIR/plots/*.svg`) and each method's written G-code (`DIR/<stem>_<method>.ngc`; with
//! `--setpoints` also its setpoints CSV).
//!
//! A method that fails (its written G-code misses the tolerance, or its setpoints break a
//! limit) is shown in red on the page; the run then writes the report but none of that
//! method's files, and exits 1 (as `smooth` and `plan` would).
//!
//! `--emit` and `--dialect` are not accepted yet: every method is written for LinuxCNC
//! with [`ncsmooth_gcode::SmoothJob`]'s defaults.

use crate::cmd_plan::axes;
use crate::cmd_smooth::job_error;
use crate::io::{self, OutputFile};
use crate::{load, progress, Ui};
use anyhow::{bail, Context, Result};
use clap::Args;
use ncsmooth::feed::PlanOptions;
use ncsmooth::smooth::Method;
use ncsmooth_report::CompareJob;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

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

/// The result of a [`compare`] run, for the caller to print.
pub struct Outcome {
    /// The summary table as text.
    pub table: String,
    /// Path of the page.
    pub page: PathBuf,
    /// The methods that failed (already reported on the page).
    pub failures: Vec<String>,
}

/// Runs `job`, writes the page, the JSON, the plots and the files of the methods that
/// succeeded into `out` (with each method's setpoints when `setpoints`).
pub fn compare(job: &CompareJob, out: &Path, setpoints: bool, ui: Ui) -> Result<Outcome> {
    std::fs::create_dir_all(out.join("plots"))
        .map_err(|e| io::BadInput(format!("cannot create {}: {e}", out.display())))?;
    let pb = progress::bar(ui, Method::ALL.len() as u64, "compare");
    let open_csv = |file: &str| -> std::io::Result<Option<BufWriter<OutputFile>>> {
        if !setpoints {
            return Ok(None);
        }
        let f = OutputFile::create(&out.join(file)).map_err(std::io::Error::other)?;
        Ok(Some(BufWriter::with_capacity(SETPOINT_BUFFER_BYTES, f)))
    };
    let stage = |m: Method, what: &str| {
        pb.set_position(Method::ALL.iter().position(|&x| x == m).unwrap_or(0) as u64);
        pb.set_message(format!("{}: {what}", m.name()));
    };
    let done = job.run(open_csv, &stage).map_err(job_error)?;
    pb.finish_and_clear();
    let mut files: Vec<OutputFile> = Vec::new();
    let mut csvs: Vec<OutputFile> = Vec::new();
    let mut add = |path: PathBuf, bytes: &[u8]| -> Result<()> {
        let mut f = OutputFile::create(&path)?;
        f.write_all(bytes)
            .with_context(|| format!("writing {}", path.display()))?;
        files.push(f);
        Ok(())
    };
    for (r, m) in done.report.methods.iter().zip(done.files) {
        if r.failure.is_none() {
            add(out.join(&r.gcode.file), &m.gcode)?;
            if let Some(w) = m.setpoints {
                csvs.push(w.into_inner().map_err(|e| e.into_error())?);
            }
        }
    }
    let page_path = out.join("index.html");
    add(page_path.clone(), done.html.as_bytes())?;
    add(
        out.join("compare.json"),
        serde_json::to_string_pretty(&done.report)?.as_bytes(),
    )?;
    for (id, svg) in &done.svgs {
        add(out.join("plots").join(format!("{id}.svg")), svg.as_bytes())?;
    }
    io::commit_all(files.into_iter().chain(csvs))?;
    Ok(Outcome {
        table: done.table,
        page: page_path,
        failures: done.failures,
    })
}

/// The limits `compare` plans under, validated (bad input otherwise).
pub fn limits(feed: f64, acc: &str, jerk: Option<&str>, period: f64) -> Result<PlanOptions> {
    ncsmooth_gcode::check_period(period).map_err(job_error)?;
    let popts = PlanOptions::default()
        .with_feed_mm_s(feed)
        .with_acc_mm_s2(axes("acc", acc)?)
        .with_jerk_mm_s3(jerk.map(|j| axes("jerk", j)).transpose()?)
        .with_period_s(period);
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
    for m in Method::ALL {
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
    let job = CompareJob::new(name, &loaded.src, &loaded.program, a.tol, popts)
        .with_parse_s(parse_s)
        .with_stem(stem)
        .with_read_options(crate::parse_options().clone());
    let outcome = compare(&job, &a.out, a.setpoints, ui)?;
    finish(&outcome, ui)
}
