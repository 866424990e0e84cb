//! Comparison jobs: every method ([`Method::ALL`], `none` first: the reference of the
//! speed-up) on the same program and limits, side by side: the table, the JSON report,
//! the page and its plots, and each method's written G-code and setpoints.
//!
//! Per method, two results of the same smoothing code:
//! * the **written G-code**: [`SmoothJob`], exactly what `smooth --method M --tol T`
//!   writes (curves built to `tol - chord - rounding`, flattened, read back and measured);
//! * the **setpoints**: the path a [`PlanJob`] with the same method and tolerance plans
//!   (curves built to the whole tolerance, [`PlanJob::smooth`]) under the same limits and
//!   default interpolation. Its JSON (`methods[i].plan`) is what `plan --report` writes for
//!   that method, timings aside; the plots and the table's deviation are of this path,
//!   measured against the program.
//!
//! A method whose written G-code misses the tolerance or whose setpoints break a limit is
//! a failure: shown in red on the page, named in [`Compared::failures`]; its files should
//! not be written.

use crate::{render_page, table_text, GcodeSummary, MethodView, PageView, PlotData, PlotSink};
use ncsmooth::feed::PlanOptions;
use ncsmooth::interp::{execute_into, InterpOptions, SetpointWriter};
use ncsmooth::smooth::Method;
use ncsmooth::verify::{Continuity, Deviation};
use ncsmooth_gcode::SmoothJob;
use ncsmooth_gcode::{InspectReport, JobError, ParseOptions, PlanJob, PlanRunReport, Program};
use serde::Serialize;
use std::io::{self, Write};
use std::time::Instant;

/// Decimals of the written G-code (`smooth`'s default).
const DECIMALS: usize = 4;

/// A comparison: one program under one set of limits.
#[derive(Clone, Debug)]
#[non_exhaustive]
pub struct CompareJob<'a> {
    /// Input name.
    pub name: &'a str,
    /// Its text.
    pub src: &'a [u8],
    /// Parsed.
    pub program: &'a Program,
    /// Seconds the caller spent parsing it (for the reports). Default 0.
    pub parse_s: f64,
    /// Tolerance (mm).
    pub tol_mm: f64,
    /// Limits.
    pub limits: PlanOptions,
    /// File-name stem of the outputs (`<stem>_<method>.ngc`, `.csv`). Default `program`.
    pub stem: String,
    /// Show the program's text on the page. Default true.
    pub embed_source: bool,
    /// How the written G-code is read back. Default [`ParseOptions::default`].
    pub read: ParseOptions,
}

/// One method's results in `compare.json`.
#[derive(Serialize, Debug)]
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
    /// Why this method failed, if it did (then none of its files should be written).
    pub failure: Option<String>,
}

/// `compare.json`.
#[derive(Serialize, Debug)]
pub struct CompareReport {
    /// Input name.
    pub input: String,
    /// Tolerance (mm).
    pub tol_mm: f64,
    /// Limits.
    pub limits: PlanOptions,
    /// The program, inspected.
    pub program: InspectReport,
    /// Per method, in [`Method::ALL`] order.
    pub methods: Vec<MethodResult>,
    /// Size of the page (bytes).
    pub page_bytes: usize,
}

/// One method's files: its G-code and, when asked for, its setpoint sink.
#[derive(Debug)]
pub struct MethodFiles<W> {
    /// The method.
    pub method: Method,
    /// The written G-code (file name in [`MethodResult::gcode`]).
    pub gcode: Vec<u8>,
    /// The setpoint CSV's writer, flushed (file name in [`MethodResult::setpoints`]).
    pub setpoints: Option<W>,
}

/// A comparison's results.
#[derive(Debug)]
pub struct Compared<W> {
    /// The JSON report.
    pub report: CompareReport,
    /// The page (`index.html`).
    pub html: String,
    /// Every plot of the page as `(id, svg)`.
    pub svgs: Vec<(String, String)>,
    /// The summary table as text.
    pub table: String,
    /// The methods that failed, with why (also on the page).
    pub failures: Vec<String>,
    /// Per method, in [`Method::ALL`] order.
    pub files: Vec<MethodFiles<W>>,
}

/// One method's run.
struct Run<W> {
    result: MethodResult,
    data: PlotData,
    files: MethodFiles<W>,
}

impl<'a> CompareJob<'a> {
    /// A comparison of `program` (text `src`, named `name`) within `tol_mm` under `limits`.
    pub fn new(
        name: &'a str,
        src: &'a [u8],
        program: &'a Program,
        tol_mm: f64,
        limits: PlanOptions,
    ) -> Self {
        CompareJob {
            name,
            src,
            program,
            parse_s: 0.0,
            tol_mm,
            limits,
            stem: "program".into(),
            embed_source: true,
            read: ParseOptions::default(),
        }
    }

    /// The seconds spent parsing the program.
    pub fn with_parse_s(mut self, parse_s: f64) -> Self {
        self.parse_s = parse_s;
        self
    }

    /// The outputs' file-name stem.
    pub fn with_stem(mut self, stem: impl Into<String>) -> Self {
        self.stem = stem.into();
        self
    }

    /// Whether the page shows the program's text.
    pub fn with_embed_source(mut self, embed_source: bool) -> Self {
        self.embed_source = embed_source;
        self
    }

    /// How the written G-code is read back.
    pub fn with_read_options(mut self, read: ParseOptions) -> Self {
        self.read = read;
        self
    }

    /// Runs every method. `setpoints` gives, by file name, the writer a method's setpoint
    /// CSV goes to (`None`: not written); `progress` hears each method's stage.
    pub fn run<W: Write + Send>(
        &self,
        mut setpoints: impl FnMut(&str) -> io::Result<Option<W>>,
        progress: &dyn Fn(Method, &str),
    ) -> Result<Compared<W>, JobError> {
        let mut runs = Vec::new();
        for m in Method::ALL {
            runs.push(self.run_method(m, &mut setpoints, progress)?);
        }
        let none_cycle = runs[0].result.plan.plan.cycle_time_s;
        for r in &mut runs {
            r.result.speedup_vs_none = Some(none_cycle / r.result.plan.plan.cycle_time_s);
        }
        let failures: Vec<String> = runs
            .iter()
            .filter_map(|r| r.result.failure.clone())
            .collect();
        let page = self.page_view(&runs, &failures);
        let (html, svgs) = render_page(&page);
        let table = table_text(&page.methods);
        drop(page);
        let (results, files) = runs.into_iter().map(|r| (r.result, r.files)).unzip();
        let report = CompareReport {
            input: self.name.to_string(),
            tol_mm: self.tol_mm,
            limits: self.limits.clone(),
            program: InspectReport::of(self.name, self.program),
            methods: results,
            page_bytes: html.len(),
        };
        Ok(Compared {
            report,
            html,
            svgs,
            table,
            failures,
            files,
        })
    }

    /// Runs one method (see the module doc).
    fn run_method<W: Write + Send>(
        &self,
        m: Method,
        setpoints: &mut impl FnMut(&str) -> io::Result<Option<W>>,
        progress: &dyn Fn(Method, &str),
    ) -> Result<Run<W>, JobError> {
        let t0 = Instant::now();
        let name = m.name();
        progress(m, "smoothing, writing and verifying G-code");
        let out = SmoothJob::new(m, self.tol_mm)
            .with_decimals(DECIMALS)
            .with_read_options(self.read.clone())
            .run(self.name, self.src, self.program)?;
        progress(m, "planning");
        let t1 = Instant::now();
        let smoothed = PlanJob::new(m, self.tol_mm).smooth(&self.program.toolpath)?;
        let smooth_s = t1.elapsed().as_secs_f64();
        let sfile = format!("{}_{name}.csv", self.stem);
        let csv = setpoints(&sfile).map_err(ncsmooth::interp::PlanError::Io)?;
        let sfile = csv.is_some().then_some(sfile);
        let (plan, (csv, sink)) = execute_into(
            &smoothed.toolpath,
            &self.limits,
            &InterpOptions::default(),
            (csv.map(SetpointWriter::new), PlotSink::default()),
        )?;
        let csv = csv
            .map(|w| w.into_inner())
            .transpose()
            .map_err(ncsmooth::interp::PlanError::Io)?;
        progress(m, "measuring the planned path");
        let data = PlotData::measure(&self.program.toolpath, smoothed.toolpath, sink, self.tol_mm);
        let mut failure = plan
            .broken_limits()
            .map(|b| format!("{name}: the plan does not hold its limits: {b}"));
        if !out.report.within_tol {
            failure = Some(format!(
                "{name}: the written G-code deviates {:.6} mm from the program (tol {} mm)",
                out.report.deviation.max_mm(),
                self.tol_mm
            ));
        }
        let blocks = out.gcode.iter().filter(|&&b| b == b'\n').count();
        let total = self.parse_s + smooth_s + plan.stage_time_s.total_s;
        let result = MethodResult {
            method: name,
            speedup_vs_none: None,
            compute_s: t0.elapsed().as_secs_f64(),
            path_deviation: data.deviation.clone(),
            path_continuity: data.continuity.clone(),
            gcode: GcodeSummary {
                file: format!("{}_{name}.ngc", self.stem),
                blocks,
                bytes: out.gcode.len(),
                report: out.report,
            },
            setpoints: sfile,
            plan: PlanRunReport {
                input: self.name.to_string(),
                method: name.to_string(),
                smoothing: smoothed.report,
                parse_s: self.parse_s,
                smooth_s,
                end_to_end_real_time_factor: plan.cycle_time_s / total,
                plan,
            },
            failure,
        };
        let files = MethodFiles {
            method: m,
            gcode: out.gcode,
            setpoints: csv,
        };
        Ok(Run {
            result,
            data,
            files,
        })
    }

    /// The page of the methods' runs.
    fn page_view<'r, W>(&'r self, runs: &'r [Run<W>], failures: &[String]) -> PageView<'r> {
        PageView {
            title: format!("ncsmooth compare: {}", self.name),
            input: self.name,
            tol: self.tol_mm,
            limits: &self.limits,
            program: &self.program.toolpath,
            source: self.embed_source.then_some(self.src),
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
}
