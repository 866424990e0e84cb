//! The plots of the page, in groups: the path with the tolerance band and zoomed insets
//! of the worst and a typical corner; curvature along the arc length per method; feed
//! against time; per-axis acceleration and jerk against time with the limit lines; the
//! corner-deviation histogram; and the trigonometric spline's shape families and a loop
//! corner (Tao et al. 2013, Figs. 1 and 2/8).

use super::series::{path_points, vertex_points, view_axes, ACC, FEED, JERK};
use super::svg::{Mark, Plot, Style};
use super::{MethodView, PageView};
use ncsmooth::geom::{ParamCurve, Vec3};
use ncsmooth::path::{MoveKind, Toolpath};
use ncsmooth::smooth::trig_corner::figures;

/// A titled group of plots with a line of explanation (HTML).
pub struct Group {
    /// Heading.
    pub title: String,
    /// Explanation (HTML, trusted text of ours).
    pub text: String,
    /// Plots.
    pub plots: Vec<Plot>,
}

/// Width (px) of a full-width plot.
const WIDE_PX: f64 = 1100.0;
/// Width (px) of a half-width plot.
const HALF_PX: f64 = 640.0;
/// Size (px) of a corner inset.
const INSET_PX: f64 = 420.0;
/// Half-width of a corner inset, in tolerances.
const INSET_HALF_TOLS: f64 = 8.0;
/// Chord of the drawn paths, in pixels.
const CHORD_PX: f64 = 0.25;
/// Bins of the corner-deviation histogram over `[0, tol]`.
const HIST_BINS: usize = 20;
/// Programmed corners turning less than this (degrees) are not candidates for the
/// typical-corner inset.
const TYPICAL_MIN_TURN_DEG: f64 = 1.0;
/// Samples of each trigonometric-spline figure curve.
const FIGURE_SAMPLES: usize = 200;
/// Deviations below this share of the tolerance get no inset.
const NEGLIGIBLE_DEVIATION_SHARE: f64 = 1e-3;
/// Bottom of the logarithmic curvature axis (1/mm): a radius of 10 m; straight lines are
/// drawn there.
const CURVATURE_FLOOR_PER_MM: f64 = 1e-4;
/// Axis colours (x, y, z).
const AXIS_COLORS: [&str; 3] = ["#1f77b4", "#d62728", "#2ca02c"];

/// Method colours, in [`ncsmooth::Method::ALL`]'s order; a method past the end of the
/// palette gets its colours again from the start.
const METHOD_PALETTE: [&str; 6] = [
    "#7f7f7f", "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
];
/// The colour of a name that is no method.
const OTHER_COLOR: &str = "#9467bd";

/// The colour of a method, by its place in [`ncsmooth::Method::ALL`].
pub fn method_color(name: &str) -> &'static str {
    match ncsmooth::Method::ALL.iter().position(|m| m.name() == name) {
        Some(k) => METHOD_PALETTE[k % METHOD_PALETTE.len()],
        None => OTHER_COLOR,
    }
}

/// Every group of the page.
pub fn all(page: &PageView) -> Vec<Group> {
    let mut g = vec![path_group(page)];
    g.push(curvature_group(page));
    g.push(feed_group(page));
    g.push(kinematics_group(page, true));
    g.push(kinematics_group(page, false));
    g.push(histogram_group(page));
    if page
        .methods
        .iter()
        .any(|m| m.name == ncsmooth::Method::Trig.name())
    {
        g.push(trig_group());
    }
    g
}

fn axis_name(i: usize) -> &'static str {
    ["X", "Y", "Z"][i]
}

/// The path at full scale with the inset windows marked, and the two insets.
fn path_group(page: &PageView) -> Group {
    let axes = view_axes(page.program);
    let (ax, ay) = (axis_name(axes[0]), axis_name(axes[1]));
    let mut full = Plot::new(
        "path",
        "The programmed path and where the insets are",
        &format!("{ax} (mm)"),
        &format!("{ay} (mm)"),
        [WIDE_PX, 640.0],
    );
    full.equal_aspect = true;
    let prog_feed = path_points(page.program, MoveKind::Feed, axes, f64::INFINITY, None);
    let extent = span(&prog_feed);
    let chord = extent / WIDE_PX * CHORD_PX;
    full.marks.push(Mark::Line {
        pts: path_points(page.program, MoveKind::Rapid, axes, chord, None),
        style: Style::dashed("#bbb", 1.0),
        label: Some("rapid".into()),
    });
    full.marks.push(Mark::Line {
        pts: path_points(page.program, MoveKind::Feed, axes, chord, None),
        style: Style::solid("#000", 2.5),
        label: Some("program".into()),
    });
    let mut plots = vec![full];
    let mut text = String::from(
        "The whole program (feed moves black, rapids dashed). Every method's path lies within \
         the tolerance of it, far less than a pixel here, so only the insets draw them: the \
         tolerance band (grey: every point within tol of the program), the program's \
         vertices (dots) and each method's planned path.",
    );
    let h = INSET_HALF_TOLS * page.tol;
    let mut insets = Vec::new();
    if let Some((name, at)) = worst_point(page) {
        insets.push((
            "inset-worst",
            format!("A: worst deviation ({name})"),
            [at[axes[0]], at[axes[1]]],
        ));
    }
    if let Some(at) = typical_corner(page.program) {
        insets.push((
            "inset-typical",
            "B: a typical corner (median turn)".to_string(),
            [at[axes[0]], at[axes[1]]],
        ));
    }
    for (id, title, c) in insets {
        let w = [c[0] - h, c[0] + h, c[1] - h, c[1] + h];
        plots[0].marks.push(Mark::Marker {
            at: c,
            text: title[..1].to_string(),
            color: "#9467bd".into(),
        });
        plots.push(inset(page, id, &title, w, axes));
    }
    if plots.len() == 1 {
        text.push_str(" (no corner to zoom into)");
    }
    Group {
        title: "Path".into(),
        text,
        plots,
    }
}

/// Largest extent of the points (mm).
fn span(pts: &[[f64; 2]]) -> f64 {
    let mut e = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    for p in pts.iter().filter(|p| p[0].is_finite()) {
        e = [
            e[0].min(p[0]),
            e[1].max(p[0]),
            e[2].min(p[1]),
            e[3].max(p[1]),
        ];
    }
    let s = (e[1] - e[0]).max(e[3] - e[2]);
    if s.is_finite() && s > 0.0 {
        s
    } else {
        1.0
    }
}

/// Where the largest deviation of any smoothing method is, and which method.
fn worst_point<'a>(page: &'a PageView) -> Option<(&'a str, Vec3)> {
    page.methods
        .iter()
        .filter(|m| m.name != "none")
        .map(|m| {
            let d = &m.data.deviation;
            let at = if d.output_to_programmed_mm >= d.vertex_to_output_mm {
                d.output_at
            } else {
                d.vertex_at
            };
            (m.name, at, d.max_mm())
        })
        // A path that follows the program to rounding has no worst corner to show.
        .filter(|x| x.2.is_finite() && x.2 > page.tol * NEGLIGIBLE_DEVIATION_SHARE)
        .max_by(|a, b| a.2.total_cmp(&b.2))
        .map(|(n, at, _)| (n, at))
}

/// The programmed feed corner with the median turn among those turning more than
/// [`TYPICAL_MIN_TURN_DEG`].
fn typical_corner(program: &Toolpath) -> Option<Vec3> {
    let moves: Vec<_> = program.moves().collect();
    let mut corners: Vec<(f64, Vec3)> = moves
        .windows(2)
        .filter(|w| w[0].kind == MoveKind::Feed && w[1].kind == MoveKind::Feed)
        .filter_map(|w| {
            let (a, b) = (w[0].segment.end_tangent()?, w[1].segment.start_tangent()?);
            let turn = a.dot(b).clamp(-1.0, 1.0).acos().to_degrees();
            (turn > TYPICAL_MIN_TURN_DEG).then(|| (turn, w[0].segment.end()))
        })
        .collect();
    corners.sort_by(|a, b| a.0.total_cmp(&b.0));
    corners.get(corners.len() / 2).map(|c| c.1)
}

/// A zoomed window `w` (`[xmin, xmax, ymin, ymax]` in the view axes).
fn inset(page: &PageView, id: &str, title: &str, w: [f64; 4], axes: [usize; 2]) -> Plot {
    let (ax, ay) = (axis_name(axes[0]), axis_name(axes[1]));
    let mut p = Plot::new(
        id,
        title,
        &format!("{ax} (mm)"),
        &format!("{ay} (mm)"),
        [INSET_PX, INSET_PX],
    );
    p.equal_aspect = true;
    p.x_range = Some([w[0], w[1]]);
    p.y_range = Some([w[2], w[3]]);
    let chord = (w[1] - w[0]) / INSET_PX * CHORD_PX;
    // A window a little larger than the view, so lines reach its edges.
    let wider = [
        w[0] - (w[1] - w[0]),
        w[1] + (w[1] - w[0]),
        w[2] - (w[3] - w[2]),
        w[3] + (w[3] - w[2]),
    ];
    let prog = path_points(page.program, MoveKind::Feed, axes, chord, Some(wider));
    p.marks.push(Mark::Tube {
        pts: prog.clone(),
        half_width: page.tol,
        color: "#888".into(),
        label: Some(format!("tol {} mm", page.tol)),
    });
    p.marks.push(Mark::Line {
        pts: prog.clone(),
        style: Style::solid("#000", 1.0),
        label: Some("program".into()),
    });
    p.marks.push(Mark::Dots {
        pts: vertex_points(page.program, MoveKind::Feed, axes, wider),
        r: 2.5,
        color: "#000".into(),
        label: None,
    });
    for m in page.methods.iter().filter(|m| m.name != "none") {
        p.marks.push(Mark::Line {
            pts: path_points(&m.data.planned, MoveKind::Feed, axes, chord, Some(wider)),
            style: Style::solid(method_color(m.name), 1.5),
            label: Some(m.name.into()),
        });
    }
    p
}

fn curvature_group(page: &PageView) -> Group {
    let methods: Vec<&MethodView> = page.methods.iter().filter(|m| m.name != "none").collect();
    let top = methods
        .iter()
        .flat_map(|m| m.data.curvature.iter().map(|p| p[1]))
        .filter(|v| v.is_finite())
        .fold(0.0f64, f64::max);
    let plots = methods
        .iter()
        .map(|m| {
            let mut p = Plot::new(
                &format!("curvature-{}", m.name),
                &format!("{}: curvature along the path", m.name),
                "arc length of the feed moves (mm)",
                "curvature (1/mm)",
                [WIDE_PX, 200.0],
            );
            p.y_log_floor = Some(CURVATURE_FLOOR_PER_MM);
            p.y_range = Some([CURVATURE_FLOOR_PER_MM, (top * 1.5).max(1.0)]);
            p.marks.push(Mark::Line {
                pts: m.data.curvature.clone(),
                style: Style::solid(method_color(m.name), 1.0),
                label: Some(m.name.into()),
            });
            p
        })
        .collect();
    Group {
        title: "Curvature".into(),
        text: "Curvature of each method's planned path along its arc length, from the curves \
               themselves (logarithmic, same scale for all, every peak kept; straight lines \
               lie on the bottom edge). The program itself (`none`) \
               is a polyline: zero curvature on its lines, unbounded at its corners, which \
               are exact stops or blends (see the joint counts)."
            .into(),
        plots,
    }
}

fn feed_group(page: &PageView) -> Group {
    let mut p = Plot::new(
        "feed",
        "Feed against time",
        "time (s)",
        "feed (mm/s)",
        [WIDE_PX, 320.0],
    );
    p.marks.push(Mark::HLine {
        y: page.limits.feed_mm_s,
        style: Style::dashed("#000", 1.0),
        label: Some("--feed".into()),
    });
    for m in &page.methods {
        p.marks.push(Mark::Line {
            pts: m.data.sink.series.series(FEED),
            style: Style::solid(method_color(m.name), 1.0),
            label: Some(format!("{} ({:.2} s)", m.name, m.plan.plan.cycle_time_s)),
        });
    }
    Group {
        title: "Feed".into(),
        text: "The planned feed of every setpoint (each method's cycle time in the legend).".into(),
        plots: vec![p],
    }
}

fn kinematics_group(page: &PageView, acc: bool) -> Group {
    let (what, unit, first) = if acc {
        ("acceleration", "mm/s\u{b2}", ACC)
    } else {
        ("jerk", "mm/s\u{b3}", JERK)
    };
    let limits = if acc {
        Some(page.limits.acc_mm_s2)
    } else {
        page.limits.jerk_mm_s3
    };
    let plots = page
        .methods
        .iter()
        .map(|m| {
            let mut p = Plot::new(
                &format!("{what}-{}", m.name),
                &format!("{}: {what} per axis", m.name),
                "time (s)",
                &format!("{what} ({unit})"),
                [HALF_PX, 240.0],
            );
            for i in 0..3 {
                p.marks.push(Mark::Line {
                    pts: m.data.sink.series.series(first + i),
                    style: Style::solid(AXIS_COLORS[i], 1.0),
                    label: Some(axis_name(i).into()),
                });
            }
            if let Some(l) = limits {
                for i in 0..3 {
                    // One line per distinct limit (the same limit on every axis: one).
                    if l[..i].contains(&l[i]) {
                        continue;
                    }
                    for y in [l[i], -l[i]] {
                        p.marks.push(Mark::HLine {
                            y,
                            style: Style::dashed("#000", 1.0),
                            label: Some("limit".into()),
                        });
                    }
                }
            }
            p
        })
        .collect();
    let text = if acc {
        "Finite-difference acceleration of the setpoints as printed, per axis, against the \
         limit (every peak kept: each bucket keeps its extremes)."
    } else if limits.is_some() {
        "Finite-difference jerk of the setpoints as printed, per axis, against the limit."
    } else {
        "Finite-difference jerk of the setpoints as printed, per axis (no jerk limit was \
         given: the trapezoid profile steps the acceleration, so jerk is a period's spike)."
    };
    Group {
        title: if acc { "Acceleration" } else { "Jerk" }.into(),
        text: text.into(),
        plots,
    }
}

fn histogram_group(page: &PageView) -> Group {
    let methods: Vec<&MethodView> = page.methods.iter().filter(|m| m.name != "none").collect();
    let bin = page.tol / HIST_BINS as f64;
    let mut p = Plot::new(
        "corner-deviation",
        "Distance of each programmed vertex to the planned path",
        "distance (mm)",
        "vertices",
        [WIDE_PX, 300.0],
    );
    let share = 1.0 / methods.len().max(1) as f64;
    for (k, m) in methods.iter().enumerate() {
        let mut heights = vec![0.0; HIST_BINS];
        for d in &m.data.vertex_dist {
            let i = ((d / bin) as usize).min(HIST_BINS - 1);
            heights[i] += 1.0;
        }
        p.marks.push(Mark::Bars {
            x0: 0.0,
            w: bin,
            heights,
            shift: k as f64 * share,
            share: share * 0.9,
            color: method_color(m.name).into(),
            label: Some(m.name.into()),
        });
    }
    p.x_range = Some([0.0, page.tol]);
    Group {
        title: "Corner deviation".into(),
        text: format!(
            "How far the planned path passes from each programmed vertex, in {HIST_BINS} bins \
             over [0, tol] (the last bin also counts anything beyond; `none` passes through \
             every vertex)."
        ),
        plots: vec![p],
    }
}

/// A plot of figure curves with their control points.
fn figure(id: &str, title: &str, curves: &[figures::FigureCurve], extra: Vec<Mark>) -> Plot {
    let mut p = Plot::new(id, title, "x", "y", [440.0, 360.0]);
    p.equal_aspect = true;
    p.marks = extra;
    let colors = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728"];
    for (c, color) in curves.iter().zip(colors.iter().cycle()) {
        p.marks.push(Mark::Line {
            pts: c.points.iter().map(|q| [q.x, q.y]).collect(),
            style: Style::solid(color, 1.5),
            label: Some(c.label.clone()),
        });
        p.marks.push(Mark::Dots {
            pts: c.control.iter().map(|q| [q.x, q.y]).collect(),
            r: 3.0,
            color: "#000".into(),
            label: None,
        });
    }
    p
}

fn trig_group() -> Group {
    let mut plots = vec![
        figure(
            "trig-lambda",
            "Fig. 1(a): k = 0.5, lambda varies",
            &figures::fig1_lambda_family(FIGURE_SAMPLES),
            vec![],
        ),
        figure(
            "trig-k",
            "Fig. 1(b): lambda = 1, k varies",
            &figures::fig1_k_family(FIGURE_SAMPLES),
            vec![],
        ),
    ];
    if let Some((legs, curve)) = figures::loop_corner_figure(60.0, 2.0, FIGURE_SAMPLES) {
        let legs = Mark::Line {
            pts: legs.iter().map(|q| [q.x, q.y]).collect(),
            style: Style::solid("#000", 1.0),
            label: Some("programmed corner".into()),
        };
        let mut p = figure(
            "trig-loop",
            "Figs. 2 and 8: a loop corner",
            &[curve],
            vec![legs],
        );
        let c = p.marks.iter().find_map(|m| match m {
            Mark::Line { pts, .. } if pts.len() > 3 => Some(pts.clone()),
            _ => None,
        });
        if let Some(pts) = c {
            // The loop's extent, with a margin, around the corner.
            let e = span(&pts) * 1.15;
            p.x_range = Some([-e, e]);
            p.y_range = Some([-e, e]);
        }
        plots.push(p);
    }
    Group {
        title: "The trigonometric spline (Tao et al. 2013)".into(),
        text: "The cubic trigonometric spline's shape parameters (eq. 1) on the control points \
               A, B, C, D (dots; the paper gives none, these are ncsmooth's), and the outside \
               loop that cuts a corner exactly (control points B, B, B1, B2 with k = -1), as \
               `--corner loop` writes it."
            .into(),
        plots,
    }
}
