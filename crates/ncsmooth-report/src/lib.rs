//! The HTML report of `compare` and `plan --report-html`: one self-contained page (inline
//! SVG, inline CSS, no script, nothing fetched) with the summary table first, then the
//! plots, the per-method details, the limits used and the files written.
//!
//! The plots (`plots`) are drawn by the small SVG module `svg` from data reduced while
//! it is produced (`series`, [`PlotSink`]): a page stays under a few MB whatever the program's size
//! (the butterfly demo: about 0.5 MB; the shared files' pages are measured by the tests).

#![forbid(unsafe_code)]

mod compare;
mod plots;
mod series;
mod svg;

pub use compare::{CompareJob, CompareReport, Compared, MethodFiles, MethodResult};
pub use plots::method_color;
pub use series::{curvature_profile, PlotSink, MAX_BUCKETS};

use ncsmooth::feed::PlanOptions;
use ncsmooth::path::Toolpath;
use ncsmooth::verify::{continuity, deviation_with_vertex_distances, Continuity, Deviation};
use ncsmooth_gcode::PlanRunReport;
use ncsmooth_gcode::SmoothRunReport;
use serde::Serialize;
use std::fmt::Write;
use svg::esc;

/// Largest input program embedded in the page (bytes); a larger one is shown by its
/// first [`EMBED_HEAD_LINES`] lines.
const EMBED_MAX_BYTES: usize = 64 * 1024;
/// Lines shown of a program too large to embed.
const EMBED_HEAD_LINES: usize = 200;

/// The written G-code of a method (from `compare`).
#[derive(Serialize, Debug)]
pub struct GcodeSummary {
    /// File name in the output directory.
    pub file: String,
    /// Lines written.
    pub blocks: usize,
    /// Bytes written.
    pub bytes: usize,
    /// The smoothing report of the written program (its read-back deviation).
    pub report: SmoothRunReport,
}

/// What the plots of one method are drawn from.
pub struct PlotData {
    /// The planned path (the one the setpoints follow).
    pub planned: Toolpath,
    /// Decimated feed, acceleration and jerk of the setpoints.
    pub sink: series::PlotSink,
    /// Decimated curvature along the arc length of the planned path.
    pub curvature: Vec<[f64; 2]>,
    /// Distance of every programmed vertex to the planned path (mm).
    pub vertex_dist: Vec<f64>,
    /// Measured two-sided deviation of the planned path from the program.
    pub deviation: Deviation,
    /// Continuity of the planned path.
    pub continuity: Continuity,
}

/// Points of the curvature profile (about one per pixel column of a wide plot).
const CURVATURE_POINTS: usize = 4000;
/// Accuracy of the deviation of the planned path, as a share of the tolerance (the
/// measured value is within this of the true maximum, and never above it). Finer costs
/// more than the planning itself on large programs: the curves are flattened to a quarter
/// of it (stellabee1, bspline: 24 M pieces at tol / 1000).
const DEVIATION_ACCURACY_SHARE: f64 = 0.02;

impl PlotData {
    /// Measures the planned path against the program and keeps what the plots need.
    pub fn measure(
        program: &Toolpath,
        planned: Toolpath,
        sink: series::PlotSink,
        tol: f64,
    ) -> PlotData {
        let (deviation, vertex_dist) =
            deviation_with_vertex_distances(&planned, program, tol * DEVIATION_ACCURACY_SHARE);
        PlotData {
            curvature: series::curvature_profile(&planned, CURVATURE_POINTS),
            vertex_dist,
            deviation,
            continuity: continuity(&planned),
            sink,
            planned,
        }
    }
}

/// One method on the page.
pub struct MethodView<'a> {
    /// Method name.
    pub name: &'a str,
    /// What `plan --report` gives for it.
    pub plan: &'a PlanRunReport,
    /// Its written G-code, when `compare` wrote one.
    pub gcode: Option<&'a GcodeSummary>,
    /// Cycle time of `none` over this method's.
    pub speedup: Option<f64>,
    /// Wall-clock time of the method's work (s).
    pub compute_s: f64,
    /// Plot data.
    pub data: &'a PlotData,
    /// Setpoint file written, if any.
    pub setpoints_file: Option<&'a str>,
}

/// The page.
pub struct PageView<'a> {
    /// Title.
    pub title: String,
    /// Input name.
    pub input: &'a str,
    /// Tolerance (mm).
    pub tol: f64,
    /// Limits used.
    pub limits: &'a PlanOptions,
    /// The program's path.
    pub program: &'a Toolpath,
    /// The program's text, when it should be shown.
    pub source: Option<&'a [u8]>,
    /// Methods, `none` first when present.
    pub methods: Vec<MethodView<'a>>,
    /// Lines said under the title (failures, notes).
    pub notes: Vec<String>,
}

/// Formats a number with `d` decimals, or "-" when it is not finite.
fn f(v: f64, d: usize) -> String {
    if v.is_finite() {
        format!("{v:.d$}")
    } else {
        "-".into()
    }
}

/// Column headers of the summary table.
pub const TABLE_HEADERS: [&str; 12] = [
    "method",
    "cycle s",
    "speed-up",
    "deviation mm (line)",
    "G-code dev mm",
    "joints G2/G1/G0",
    "acc max mm/s2 (x lim)",
    "jerk max mm/s3 (x lim)",
    "eta max %",
    "blocks",
    "bytes",
    "compute s",
];

/// The summary table's rows (see [`TABLE_HEADERS`]).
pub fn table_rows(methods: &[MethodView]) -> Vec<[String; 12]> {
    methods
        .iter()
        .map(|m| {
            let p = &m.plan.plan;
            let d = &m.data.deviation;
            let line = if d.output_to_programmed_mm >= d.vertex_to_output_mm {
                d.output_line
            } else {
                d.vertex_line
            };
            let worst = |acc: bool| {
                p.axes
                    .iter()
                    .map(|x| {
                        if acc {
                            (x.a_max_mm_s2, Some(x.a_ratio))
                        } else {
                            (x.j_max_mm_s3, x.j_ratio)
                        }
                    })
                    .fold((0.0f64, None::<f64>), |a, b| if b.0 > a.0 { b } else { a })
            };
            let fmt = |(v, r): (f64, Option<f64>)| match r {
                Some(r) => format!("{v:.0} ({r:.3})"),
                None => format!("{v:.0} (-)"),
            };
            let c = &m.data.continuity;
            [
                m.name.to_string(),
                f(p.cycle_time_s, 3),
                m.speedup.map_or("-".into(), |s| format!("{s:.2}x")),
                format!("{} ({line})", f(d.max_mm(), 6)),
                m.gcode
                    .map_or("-".into(), |g| f(g.report.deviation.max_mm(), 6)),
                format!("{}/{}/{}", c.g2, c.g1, c.g0),
                fmt(worst(true)),
                fmt(worst(false)),
                format!("{:.2e}", p.interp.eta_max * 100.0),
                m.gcode.map_or("-".into(), |g| g.blocks.to_string()),
                m.gcode.map_or("-".into(), |g| g.bytes.to_string()),
                f(m.compute_s, 2),
            ]
        })
        .collect()
}

/// The summary table as aligned text (for the terminal).
pub fn table_text(methods: &[MethodView]) -> String {
    let rows = table_rows(methods);
    let mut w = TABLE_HEADERS.map(str::len);
    for r in &rows {
        for (i, c) in r.iter().enumerate() {
            w[i] = w[i].max(c.len());
        }
    }
    let mut out = String::new();
    let line = |cells: &[&str], out: &mut String| {
        let parts: Vec<String> = cells
            .iter()
            .enumerate()
            .map(|(i, c)| {
                if i == 0 {
                    format!("{c:<width$}", width = w[i])
                } else {
                    format!("{c:>width$}", width = w[i])
                }
            })
            .collect();
        out.push_str(parts.join("  ").trim_end());
        out.push('\n');
    };
    line(&TABLE_HEADERS, &mut out);
    for r in &rows {
        line(&r.iter().map(String::as_str).collect::<Vec<_>>(), &mut out);
    }
    out
}

/// Page style.
const CSS: &str = "body{font-family:sans-serif;margin:24px;max-width:1400px;color:#222}\
table{border-collapse:collapse;margin:8px 0}td,th{border:1px solid #ccc;padding:3px 8px;\
text-align:right}td:first-child,th:first-child{text-align:left}th{background:#f3f3f3}\
.plots{display:flex;flex-wrap:wrap;gap:12px}pre{background:#f7f7f7;padding:8px;\
max-height:400px;overflow:auto;font-size:12px}.bad{color:#b00;font-weight:bold}\
caption{text-align:left;font-weight:bold;padding:4px 0}";

/// The page of one plan (`ncsmooth plan --report-html`): the page of a comparison with
/// this one method: its table row, the path with the tolerance band, curvature, feed,
/// per-axis acceleration and jerk. `program` is the path planned from (the band is drawn
/// around it), `planned` the smoothed path, `plots` the sink the setpoints went through.
pub fn plan_page(
    run: &PlanRunReport,
    tol: f64,
    popts: &PlanOptions,
    program: &Toolpath,
    planned: Toolpath,
    plots: PlotSink,
) -> String {
    let data = PlotData::measure(program, planned, plots, tol);
    let name = run.input.as_str();
    let page = PageView {
        title: format!("ncsmooth plan: {name}, {}", run.method),
        input: name,
        tol,
        limits: popts,
        program,
        source: None,
        methods: vec![MethodView {
            name: &run.method,
            plan: run,
            gcode: None,
            speedup: None,
            compute_s: run.plan.stage_time_s.total_s + run.smooth_s + run.parse_s,
            data: &data,
            setpoints_file: None,
        }],
        notes: Vec::new(),
    };
    render_page(&page).0
}

/// Renders the page; also returns every plot as `(id, svg)` for separate files.
pub fn render_page(page: &PageView) -> (String, Vec<(String, String)>) {
    let groups = plots::all(page);
    let mut h = String::with_capacity(1 << 20);
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{t}</title>\
         <style>{CSS}</style></head><body><h1>{t}</h1>",
        t = esc(&page.title)
    );
    let _ = write!(
        h,
        "<p>Input <b>{}</b>; tolerance {} mm (two-sided); feed {} mm/s, acceleration {} mm/s\u{b2}, {}period {} s.</p>",
        esc(page.input),
        page.tol,
        page.limits.feed_mm_s,
        axes_text(page.limits.acc_mm_s2),
        page.limits
            .jerk_mm_s3
            .map_or("no jerk limit (trapezoid), ".into(), |j| format!(
                "jerk {} mm/s\u{b3}, ",
                axes_text(j)
            )),
        page.limits.period_s
    );
    for n in &page.notes {
        let _ = write!(h, "<p class=\"bad\">{}</p>", esc(n));
    }
    summary_table(&mut h, &page.methods, page.tol);
    let mut all_svgs = Vec::new();
    for g in groups {
        let _ = write!(
            h,
            "<h2>{}</h2><p>{}</p><div class=\"plots\">",
            esc(&g.title),
            g.text
        );
        for p in g.plots {
            let svg = p.render();
            h.push_str(&svg);
            all_svgs.push((p.id.clone(), svg));
        }
        h.push_str("</div>");
    }
    details(&mut h, page);
    h.push_str("</body></html>\n");
    (h, all_svgs)
}

fn axes_text(v: [f64; 3]) -> String {
    if v[0] == v[1] && v[1] == v[2] {
        format!("{}", v[0])
    } else {
        format!("{},{},{} (x,y,z)", v[0], v[1], v[2])
    }
}

fn summary_table(h: &mut String, methods: &[MethodView], tol: f64) {
    h.push_str(
        "<table id=\"summary\"><caption>Summary: cycle time and kinematics measured on the \
         setpoints (finite differences), deviation of the planned path and of the written \
         G-code read back</caption><tr>",
    );
    for c in TABLE_HEADERS {
        let _ = write!(h, "<th>{}</th>", esc(c));
    }
    h.push_str("</tr>");
    for (m, r) in methods.iter().zip(table_rows(methods)) {
        let bad = !m.plan.plan.limits_held
            || m.gcode.is_some_and(|g| !g.report.within_tol)
            || !m.data.deviation.within(tol);
        h.push_str(if bad { "<tr class=\"bad\">" } else { "<tr>" });
        for c in r {
            let _ = write!(h, "<td>{}</td>", esc(&c));
        }
        h.push_str("</tr>");
    }
    h.push_str("</table>");
}

/// A two-column table of `(name, value)`.
fn kv_table(h: &mut String, caption: Option<&str>, rows: &[(&str, String)]) {
    h.push_str("<table>");
    if let Some(c) = caption {
        let _ = write!(h, "<caption>{}</caption>", esc(c));
    }
    for (k, v) in rows {
        let _ = write!(h, "<tr><td>{}</td><td>{}</td></tr>", esc(k), esc(v));
    }
    h.push_str("</table>");
}

fn details(h: &mut String, page: &PageView) {
    h.push_str("<h2>Methods in detail</h2>");
    for m in &page.methods {
        let p = &m.plan.plan;
        let s = &m.plan.smoothing;
        let d = &m.data.deviation;
        let _ = write!(h, "<h3>{}</h3>", esc(m.name));
        let mut rows = vec![
            (
                "corners smoothed / straight / stopped",
                format!(
                    "{} / {} / {}",
                    s.corners_smoothed, s.corners_straight, s.corners_stopped
                ),
            ),
            ("runs fitted", s.runs_fitted.to_string()),
            (
                "segments of the planned path",
                s.segments_emitted.to_string(),
            ),
            (
                "deviation, path to program (mm, line)",
                format!("{:.6} ({})", d.output_to_programmed_mm, d.output_line),
            ),
            (
                "deviation, program vertex to path (mm, line)",
                format!("{:.6} ({})", d.vertex_to_output_mm, d.vertex_line),
            ),
            (
                "cycle time (s), setpoints",
                format!("{:.4}, {}", p.cycle_time_s, p.setpoints),
            ),
            (
                "exact stops: corner / event / dwell",
                format!(
                    "{} / {} / {}",
                    p.exact_stops.corner, p.exact_stops.event, p.exact_stops.dwell
                ),
            ),
            ("jumps", p.jumps.len().to_string()),
            ("limits held (measured)", p.limits_held.to_string()),
            (
                "eta max / mean (%)",
                format!(
                    "{:.3e} / {:.3e}",
                    p.interp.eta_max * 100.0,
                    p.interp.eta_mean * 100.0
                ),
            ),
            ("real-time factor", format!("{:.0}", p.real_time_factor)),
        ];
        for x in &p.axes {
            rows.push((
                "axis v / a / j max",
                format!(
                    "{}: {:.3} mm/s, {:.3} mm/s2 at {:.3} s, {:.1} mm/s3 at {:.3} s",
                    x.axis, x.v_max_mm_s, x.a_max_mm_s2, x.a_max_at_s, x.j_max_mm_s3, x.j_max_at_s
                ),
            ));
        }
        if let Some(g) = m.gcode {
            let r = &g.report;
            rows.push((
                "G-code written",
                format!("{} ({} lines, {} bytes)", g.file, g.blocks, g.bytes),
            ));
            rows.push((
                "G-code deviation read back (mm, lines)",
                format!(
                    "{:.6} ({}) / {:.6} ({}); curves built to {:.6}, chord {:.6}, rounding {:.2e}",
                    r.deviation.output_to_programmed_mm,
                    r.deviation.output_line,
                    r.deviation.vertex_to_output_mm,
                    r.deviation.vertex_line,
                    r.curve_tol_mm,
                    r.chord_mm,
                    r.rounding_mm
                ),
            ));
        }
        if let Some(f) = m.setpoints_file {
            rows.push(("setpoints written", f.to_string()));
        }
        kv_table(h, None, &rows);
    }
    let l = page.limits;
    kv_table(
        h,
        Some("Limits used"),
        &[
            ("tolerance (mm)", page.tol.to_string()),
            ("feed (mm/s)", l.feed_mm_s.to_string()),
            ("rapid (mm/s)", l.rapid().to_string()),
            ("acceleration per axis (mm/s2)", axes_text(l.acc_mm_s2)),
            (
                "jerk per axis (mm/s3)",
                l.jerk_mm_s3.map_or("none".into(), axes_text),
            ),
            ("period (s)", l.period_s.to_string()),
            ("chord error (mm)", l.chord_error_mm.to_string()),
        ],
    );
    files(h, page);
}

fn files(h: &mut String, page: &PageView) {
    let links: Vec<(&str, &str)> = page
        .methods
        .iter()
        .flat_map(|m| {
            m.gcode
                .map(|g| (m.name, g.file.as_str()))
                .into_iter()
                .chain(m.setpoints_file.map(|f| (m.name, f)))
        })
        .collect();
    if !links.is_empty() {
        h.push_str("<h2>Files</h2><ul>");
        for (m, file) in links {
            let _ = write!(
                h,
                "<li>{}: <a href=\"{f}\">{f}</a></li>",
                esc(m),
                f = esc(file)
            );
        }
        h.push_str("</ul>");
    }
    if let Some(src) = page.source {
        let text = String::from_utf8_lossy(src);
        let shown: String = if src.len() <= EMBED_MAX_BYTES {
            text.into_owned()
        } else {
            let head: Vec<&str> = text.lines().take(EMBED_HEAD_LINES).collect();
            format!("{}\n... ({} bytes in all)", head.join("\n"), src.len())
        };
        let _ = write!(
            h,
            "<details><summary>The program ({})</summary><pre>{}</pre></details>",
            esc(page.input),
            esc(&shown)
        );
    }
}
