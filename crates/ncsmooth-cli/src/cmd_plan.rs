//! `ncsmooth plan`: the arguments of a [`PlanJob`] (smoothing, limits, period, row
//! limit), its setpoints streamed to the CSV (never collected), its JSON report and page.
//! A file is read, smoothed and planned a part at a time ([`PlanInput::File`]) unless an
//! output needs the whole program (`--report-html`, `--path-samples`) or it is stdin.
//!
//! The input may also be `builtin:butterfly`: the published butterfly NURBS as one curve
//! (F 50 mm/s), for planning a smooth curve without a smoothing step.
//!
//! What is refused and when, and what a plan breaking its limits means, is the job's
//! (its module doc): bad input exits 2, a plan breaking a limit not waived exits 1 with
//! nothing written, and a `--jerk-scheme follow` plan that gives up is planned again with
//! `filter` (said on stderr) unless setpoints already went to stdout.

use crate::cmd_smooth::job_error;
use crate::io::OutputFile;
use crate::table_arg::MethodArg;
use crate::{diag, io, load, progress, Ui};
use anyhow::Result;
use clap::{Args, ValueEnum};
use ncsmooth::feed::{JerkScheme, PlanOptions};
use ncsmooth::interp::{InterpMethod, InterpOptions, SetpointWriter};
use ncsmooth::path::{Move, Toolpath};
use ncsmooth_gcode::{JobError, PlanInput, PlanJob, PlanNote, PlanRunReport, Planned};
use ncsmooth_report::PlotSink;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Name of the built-in butterfly input.
pub const BUILTIN_BUTTERFLY: &str = "builtin:butterfly";
/// Feed (mm/s) of the built-in butterfly.
const BUILTIN_FEED_MM_S: f64 = 50.0;
/// Write buffer of the setpoint stream (bytes).
const SETPOINT_BUFFER_BYTES: usize = 1 << 20;
/// Typical bytes of one setpoint row (`t,x,y,z,feed` at 9 decimals, no extra axis): the
/// 6 927 405 rows of stellabee1 take 436 MB, 63 bytes each.
const TYPICAL_ROW_BYTES: u64 = 63;
/// Setpoint output (bytes, estimated from the lower bound on the rows) above which `plan`
/// says on stderr, before writing, how much it is about to write.
pub const LARGE_OUTPUT_BYTES: u64 = 1_000_000_000;

/// Jerk scheme names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum JerkSchemeArg {
    /// Trapezoid under jerk caps, averaged over a time window.
    Filter,
    /// Setpoints followed period by period under the measured limits.
    Follow,
}

/// Interpolation method names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum InterpArg {
    /// Newton-Raphson on the chord length (Wu eqs. 17-20).
    Newton,
    /// First-order Taylor step (Wu eq. 19).
    Taylor1,
    /// Second-order Taylor step.
    Taylor2,
}

/// Stopping rule of Wu eq. 20.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum NewtonStop {
    /// Stop when eta <= eta_tol and n iterations were made (eq. 20 as printed).
    Both,
    /// Stop when eta <= eta_tol or after n iterations (cheaper, noisier setpoints).
    Either,
}

/// Arguments of `plan`.
#[derive(Args, Clone, Debug)]
#[command(allow_negative_numbers = true)]
pub struct PlanArgs {
    /// G-code file, `-` for stdin, or `builtin:butterfly`.
    pub file: String,
    /// Smoothing method applied before planning (`none` plans the program as written).
    #[arg(long, value_enum, default_value = "none")]
    pub method: MethodArg,
    /// Reshape each method's fitted runs at their slow spots (speed below 0.7 x feed) to
    /// the fastest curve inside the same band for `--feed` and `--acc` (minimum-time
    /// optimisation, about a second of computing per spot). Off by default.
    #[arg(long)]
    pub time_shape: bool,
    /// Two-sided smoothing tolerance (mm).
    #[arg(long, default_value_t = 0.01)]
    pub tol: f64,
    /// Largest feed (mm/s); a lower programmed F wins.
    #[arg(long, default_value_t = 50.0)]
    pub feed: f64,
    /// Per-axis acceleration limit (mm/s^2): one value or x,y,z.
    #[arg(long, default_value = "500")]
    pub acc: String,
    /// Per-axis jerk limit (mm/s^3): one value or x,y,z. Given: a jerk-limited S-curve
    /// (the trapezoid under tighter caps, averaged over a time window); without it the
    /// profile is the trapezoid (linear acceleration).
    #[arg(long)]
    pub jerk: Option<String>,
    /// How `--jerk` makes its S-curve: `filter` (the trapezoid under caps that hold for
    /// any motion, averaged over a time window; provable, conservative) or `follow` (the
    /// setpoints chosen period by period under the limits as measured, below a
    /// braking-feasible ceiling; near time-optimal on smooth paths, slower to compute; a
    /// file it cannot follow within the limits is planned again with `filter`).
    #[arg(long, value_enum, default_value = "filter")]
    pub jerk_scheme: JerkSchemeArg,
    /// Per-axis velocity limit (mm/s): one value or x,y,z [default: none].
    #[arg(long)]
    pub vaxis: Option<String>,
    /// Rapid (G0) speed (mm/s) [default: --feed].
    #[arg(long)]
    pub rapid: Option<f64>,
    // The range is ncsmooth_gcode::MIN_PERIOD_S ..= MAX_PERIOD_S.
    /// Interpolation period T (s), from 1e-5 to 0.1.
    #[arg(long, default_value_t = 0.001)]
    pub period: f64,
    /// Largest number of setpoint rows the plan may produce (written, printed or only
    /// measured). A plan whose cycle time at the speed caps already needs more is refused
    /// as soon as that is known (before planning when the program is held whole, as the
    /// moves arrive when a file is streamed); one that turns out longer stops when it
    /// passes N. Either way the run exits 2 and writes no file (setpoints already sent to
    /// stdout stay sent). [default: no limit; an estimate above 1 GB of CSV is printed to
    /// stderr when known]
    #[arg(long, value_name = "N")]
    pub max_rows: Option<u64>,
    /// Chord error delta (mm) of Wu eq. 21: v <= (2/T) sqrt(delta (2R - delta)).
    #[arg(long, default_value_t = 0.001)]
    pub chord_error: f64,
    /// Junction deviation (mm): pass unsmoothed corners at grbl's junction speed instead
    /// of stopping (the setpoints then exceed --acc at those corners; the report says so).
    #[arg(long)]
    pub junction_dev: Option<f64>,
    /// Interpolation method.
    #[arg(long, value_enum, default_value = "newton")]
    pub interp: InterpArg,
    /// Feed-fluctuation tolerance eta_tol (fraction; 0.001 = 0.1 %).
    #[arg(long, default_value_t = 0.001)]
    pub eta_tol: f64,
    /// Newton iterations n.
    #[arg(long, default_value_t = 2)]
    pub newton_iters: usize,
    /// Newton stopping rule (eq. 20).
    #[arg(long, value_enum, default_value = "both")]
    pub newton_stop: NewtonStop,
    /// Write each interpolation method's own setpoints instead of correcting every curve
    /// step onto the planned arc length (to compare --interp methods by their output).
    #[arg(long)]
    pub no_arc_correction: bool,
    /// Setpoints CSV (t s, x y z mm, feed mm/s, extra axes) [default: measured, not written].
    #[arg(long)]
    pub setpoints: Option<PathBuf>,
    /// JSON report file.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// HTML page of the plan (the page of `compare` for this one method: table, path with
    /// the tolerance band, curvature, feed, per-axis acceleration and jerk).
    #[arg(long, value_name = "FILE")]
    pub report_html: Option<PathBuf>,
    /// Also write the planned path sampled every --sample-ds mm of arc length (CSV
    /// s,x,y,z in mm; for external comparisons such as scripts/toppra_compare.py).
    #[arg(long)]
    pub path_samples: Option<PathBuf>,
    /// Arc-length spacing (mm) of --path-samples.
    #[arg(long, default_value_t = 0.05)]
    pub sample_ds: f64,
}

/// Parses a per-axis value: one number for all axes or `x,y,z`.
pub(crate) fn axes(name: &str, s: &str) -> Result<[f64; 3]> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| io::BadInput(format!("--{name} {s}: expected one number or x,y,z")))?;
    match v.as_slice() {
        [a] => Ok([*a; 3]),
        [a, b, c] => Ok([*a, *b, *c]),
        _ => Err(io::BadInput(format!("--{name} {s}: expected one number or x,y,z")).into()),
    }
}

fn builtin_butterfly() -> Toolpath {
    let b = ncsmooth::profiles::butterfly();
    let mut tp = Toolpath::new(ncsmooth::geom::ParamCurve::start(&b));
    tp.push_move(Move::feed(b, Some(BUILTIN_FEED_MM_S), 1));
    tp
}

/// The note that a plan of at least `min_cycle_s` seconds makes more than
/// [`LARGE_OUTPUT_BYTES`] of setpoints, if it does.
pub(crate) fn huge_output_note(a: &PlanArgs, min_cycle_s: f64) -> Option<String> {
    // Truncated (not the row at t = 0 added): a margin of one row for rounding.
    let min_rows = (min_cycle_s / a.period) as u64;
    let min_bytes = min_rows.saturating_mul(TYPICAL_ROW_BYTES);
    if min_bytes <= LARGE_OUTPUT_BYTES {
        return None;
    }
    let fate = if a.setpoints.is_some() {
        "of setpoint CSV to write"
    } else {
        "of setpoints to compute (not written)"
    };
    Some(format!(
        "note: the cycle takes at least {min_cycle_s:.3} s: at least {min_rows} setpoint \
         rows at --period {:?} s, about {:.1} GB {fate} (--max-rows bounds it)",
        a.period,
        min_bytes as f64 / 1e9
    ))
}

/// Runs `plan`. With `--jerk-scheme follow`, a plan the follower could not finish within
/// the limits is planned again with the filter scheme (said on stderr; the report's
/// options give the scheme used), unless setpoints already went to stdout.
pub fn run(a: PlanArgs, ui: Ui) -> Result<()> {
    check_plan_outputs(&a)?;
    let job = plan_job(&a)?;
    let to_stdout = a.setpoints.as_deref().is_some_and(|p| p.as_os_str() == "-");
    match (
        run_once(&a, &job, ui),
        job.fallback().filter(|_| !to_stdout),
    ) {
        (Err(e), Some(filter))
            if matches!(
                e.downcast_ref::<JobError>(),
                Some(JobError::FollowGaveUp(_))
            ) =>
        {
            ui.status(format!(
                "note: {e}; planning again with --jerk-scheme filter"
            ));
            run_once(&a, &filter, ui)
        }
        (r, _) => r,
    }
}

/// Plans once with `job`: reads the input, opens every output before the work (a bad
/// directory fails at once) and moves them into place only when all were written.
fn run_once(a: &PlanArgs, job: &PlanJob, ui: Ui) -> Result<()> {
    job.check_period().map_err(job_error)?;
    let t0 = Instant::now();
    let name = if a.file == BUILTIN_BUTTERFLY {
        a.file.clone()
    } else {
        io::display_name(&a.file).to_string()
    };
    let program = read_whole(a, ui, &name)?;
    let parse_s = t0.elapsed().as_secs_f64();
    let mut samples_out = open(&a.path_samples)?;
    let setpoints_out = open(&a.setpoints)?;
    let mut report_out = open(&a.report)?;
    let mut html_out = open(&a.report_html)?;
    if samples_out.is_some() && (a.sample_ds.is_nan() || a.sample_ds <= 0.0) {
        return Err(io::BadInput("--sample-ds must be positive".into()).into());
    }
    let input = match &program {
        Some(toolpath) => PlanInput::Path {
            name: &name,
            toolpath,
            parse_s,
        },
        None => PlanInput::File {
            name: &name,
            path: Path::new(&a.file),
        },
    };
    let note = |n: PlanNote| match n {
        PlanNote::UnitsAssumed { line } => {
            ui.status(crate::units_warning(&name, line));
            true
        }
        PlanNote::MinCycle { s } => huge_output_note(a, s).map(|n| ui.status(n)).is_some(),
        _ => false,
    };
    let plots = (program.is_some() && a.report_html.is_some()).then(PlotSink::default);
    let pb = progress::spinner(ui, "planning and interpolating");
    let (planned, setpoints_out) = plan_to(job, &input, setpoints_out, a, plots, &note)?;
    pb.finish_and_clear();
    let Planned {
        run,
        sink: plots,
        path,
        limits_waived,
    } = planned;
    if let Some(w) = &limits_waived {
        ui.status(format!("warning: {w}"));
    }
    if let (Some(out), Some(path)) = (&mut samples_out, &path) {
        write_path_samples(out, path, a.sample_ds)?;
    }
    write_json(a, &run, &mut report_out)?;
    if let (Some(f), Some(program), Some(plots), Some(path)) =
        (&mut html_out, &program, plots, path)
    {
        let pb = progress::spinner(ui, "measuring the path for the page");
        let html = ncsmooth_report::plan_page(&run, a.tol, &job.plan, program, path, plots);
        pb.finish_and_clear();
        f.write_all(html.as_bytes())?;
    }
    io::commit_all(
        [samples_out, setpoints_out, report_out, html_out]
            .into_iter()
            .flatten(),
    )?;
    summary(ui, &name, &run);
    Ok(())
}

/// The samples of `--path-samples` ([`ncsmooth_gcode::write_path_samples`]).
fn write_path_samples(out: &mut OutputFile, tp: &Toolpath, ds: f64) -> Result<()> {
    ncsmooth_gcode::write_path_samples(BufWriter::new(out), tp, ds)?;
    Ok(())
}

/// The output file at `p`, created (not yet in place); `None` for none or stdout.
fn open(p: &Option<PathBuf>) -> Result<Option<OutputFile>> {
    match p {
        Some(p) if p.as_os_str() != "-" => Ok(Some(OutputFile::create(p)?)),
        _ => Ok(None),
    }
}

/// Fails when an output is the input or cannot be written.
fn check_plan_outputs(a: &PlanArgs) -> Result<()> {
    let outputs: Vec<(&str, &Path)> = [
        ("--path-samples", &a.path_samples),
        ("--setpoints", &a.setpoints),
        ("--report", &a.report),
        ("--report-html", &a.report_html),
    ]
    .into_iter()
    .filter_map(|(flag, p)| p.as_deref().map(|p| (flag, p)))
    .collect();
    let input = (a.file != BUILTIN_BUTTERFLY).then_some(a.file.as_str());
    io::check_outputs(input, &outputs)
}

/// The built-in profile or the program loaded whole; `None` for a file to be streamed: a
/// file is read, smoothed and planned a part at a time unless an output needs the whole
/// path (the page, the path samples) or it comes from stdin.
fn read_whole(a: &PlanArgs, ui: Ui, name: &str) -> Result<Option<Toolpath>> {
    if a.file == BUILTIN_BUTTERFLY {
        return Ok(Some(builtin_butterfly()));
    }
    if a.file != "-" && a.report_html.is_none() && a.path_samples.is_none() {
        return Ok(None);
    }
    let program = load(&a.file)?.program;
    if let Some(line) = program.stats.units_assumed {
        ui.status(crate::units_warning(name, line));
    }
    Ok(Some(program.toolpath))
}

/// The JSON report, to its file or stdout.
fn write_json(a: &PlanArgs, run: &PlanRunReport, out: &mut Option<OutputFile>) -> Result<()> {
    let json = serde_json::to_string_pretty(run)?;
    match (out, &a.report) {
        (Some(f), _) => f.write_all(json.as_bytes())?,
        (None, Some(_)) => io::print_stdout(json.as_bytes())?,
        (None, None) => {}
    }
    Ok(())
}

/// The job these arguments ask for.
fn plan_job(a: &PlanArgs) -> Result<PlanJob> {
    let plan = PlanOptions::default()
        .with_feed_mm_s(a.feed)
        .with_rapid_mm_s(a.rapid)
        .with_acc_mm_s2(axes("acc", &a.acc)?)
        .with_jerk_mm_s3(a.jerk.as_deref().map(|v| axes("jerk", v)).transpose()?)
        .with_vaxis_mm_s(a.vaxis.as_deref().map(|v| axes("vaxis", v)).transpose()?)
        .with_period_s(a.period)
        .with_chord_error_mm(a.chord_error)
        .with_junction_dev_mm(a.junction_dev)
        .with_jerk_scheme(match a.jerk_scheme {
            JerkSchemeArg::Filter => JerkScheme::Filter,
            JerkSchemeArg::Follow => JerkScheme::Follow,
        });
    let interp = InterpOptions::default()
        .with_method(match a.interp {
            InterpArg::Newton => InterpMethod::Newton,
            InterpArg::Taylor1 => InterpMethod::Taylor1,
            InterpArg::Taylor2 => InterpMethod::Taylor2,
        })
        .with_eta_tol(a.eta_tol)
        .with_max_iters(a.newton_iters)
        .with_stop_on_either(a.newton_stop == NewtonStop::Either)
        .with_arc_correction(!a.no_arc_correction);
    Ok(PlanJob::new(a.method.into(), a.tol)
        .with_time_shape(a.time_shape)
        .with_plan_options(plan)
        .with_interp_options(interp)
        .with_max_rows(a.max_rows)
        .with_read_options(crate::parse_options().clone()))
}

/// The setpoint sink of a plan: CSV rows and, for the page, the plots.
type Rows<W> = (SetpointWriter<BufWriter<W>>, Option<PlotSink>);

/// Runs `job` into the setpoint output asked for (a file, stdout, or nowhere); returns
/// the result and the file, written.
fn plan_to(
    job: &PlanJob,
    input: &PlanInput<'_>,
    setpoints_out: Option<OutputFile>,
    a: &PlanArgs,
    plots: Option<PlotSink>,
    note: &(dyn Fn(PlanNote) -> bool + Sync),
) -> Result<(Planned<Option<PlotSink>>, Option<OutputFile>)> {
    fn go<W: Write + Send>(
        job: &PlanJob,
        input: &PlanInput<'_>,
        w: W,
        plots: Option<PlotSink>,
        note: &(dyn Fn(PlanNote) -> bool + Sync),
    ) -> Result<(Planned<Option<PlotSink>>, W)> {
        let rows: Rows<W> = (
            SetpointWriter::new(BufWriter::with_capacity(SETPOINT_BUFFER_BYTES, w)),
            plots,
        );
        let done = job.run(input, rows, note).map_err(|e| match (e, input) {
            (JobError::Parse(e), PlanInput::File { path, .. }) => diag::reported_at_line(e, path),
            (e, _) => job_error(e),
        })?;
        let (writer, plots) = done.sink;
        let w = writer
            .into_inner()?
            .into_inner()
            .map_err(|e| e.into_error())?;
        let planned = Planned {
            run: done.run,
            sink: plots,
            path: done.path,
            limits_waived: done.limits_waived,
        };
        Ok((planned, w))
    }
    Ok(match (setpoints_out, &a.setpoints) {
        (Some(f), _) => {
            let (p, f) = go(job, input, f, plots, note)?;
            (p, Some(f))
        }
        // Unlocked: the setpoints are written from the planner's second thread.
        (None, Some(_)) => (go(job, input, std::io::stdout(), plots, note)?.0, None),
        (None, None) => (go(job, input, std::io::sink(), plots, note)?.0, None),
    })
}
/// The plan's one-line summary (and a note on jumps) on stderr.
fn summary(ui: Ui, name: &str, run: &PlanRunReport) {
    let r = &run.plan;
    let worst = r.axes.iter().map(|x| x.a_ratio).fold(0.0f64, f64::max);
    let jerk = r
        .axes
        .iter()
        .filter_map(|x| x.j_ratio)
        .reduce(f64::max)
        .map_or(String::new(), |j| {
            format!(", worst axis jerk {j:.4} x limit")
        });
    ui.status(format!(
        "{name}: cycle {:.3} s, {} setpoints, eta max {:.3e} %, worst axis acc {:.4} x limit{jerk}, stops: {} corner {} event {} dwell; real-time factor {:.0} (end to end {:.0})",
        r.cycle_time_s,
        r.setpoints,
        r.interp.eta_max * 100.0,
        worst,
        r.exact_stops.corner,
        r.exact_stops.event,
        r.exact_stops.dwell,
        r.real_time_factor,
        run.end_to_end_real_time_factor
    ));
    if !r.jumps.is_empty() {
        let total: f64 = r.jumps.iter().map(|j| j.distance_mm).sum();
        ui.status(format!(
            "note: {} jump(s) in the setpoints ({total:.3} mm in all, first at t = {:.3} s): the controller runs motion ncsmooth cannot place there (G28/G30, G53, a move from an unknown position); its time is not in the cycle time (see `jumps` in the report)",
            r.jumps.len(),
            r.jumps[0].t_s
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        plan: PlanArgs,
    }

    #[test]
    fn arguments_map_to_the_job() {
        let a = Cli::parse_from(["plan", "f.ngc", "--acc", "100,200,300", "--jerk", "5000"]).plan;
        let job = plan_job(&a).unwrap();
        assert_eq!(job.plan.acc_mm_s2, [100.0, 200.0, 300.0]);
        assert_eq!(job.plan.jerk_mm_s3, Some([5000.0; 3]));
        assert!(job.fallback().is_none(), "filter is the default scheme");
        let a = Cli::parse_from(["plan", "f.ngc", "--jerk-scheme", "follow"]).plan;
        assert!(plan_job(&a).unwrap().fallback().is_some());
        let a = Cli::parse_from(["plan", "f.ngc", "--acc", "1,2"]).plan;
        assert!(plan_job(&a).is_err());
    }
}
