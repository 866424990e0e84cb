//! A small SVG plotting module: line plots with axes, ticks, legend, limit lines, a
//! tolerance tube and histogram bars, written as plain SVG text (no font is loaded: the
//! browser draws the text; label widths are estimated from the character count for the
//! layout).
//!
//! What a screen can show decides the size: every polyline is simplified in pixel space
//! (Douglas-Peucker, [`SIMPLIFY_PX`]), clipped to the view (points outside it are
//! dropped, the line is broken where it leaves), and written as relative path commands
//! at 0.1 px. A plot is therefore a few kB to a few tens of kB whatever the data size.

use std::fmt::Write;

/// Pixel tolerance of the polyline simplification: no drawn point moves by more.
pub const SIMPLIFY_PX: f64 = 0.3;
/// Margins (px): left (tick labels), right, top (title and legend), bottom (x label).
const MARGIN: [f64; 4] = [64.0, 16.0, 44.0, 40.0];
/// Font size (px) of the labels.
const FONT_PX: f64 = 12.0;
/// Estimated width of one character of the labels, as a share of the font size.
const CHAR_WIDTH_SHARE: f64 = 0.6;
/// Pixels per x tick and per y tick, about.
const TICK_SPACING_PX: [f64; 2] = [90.0, 45.0];
/// Height (px) of a legend row.
const LEGEND_ROW_PX: f64 = 16.0;
/// Share of the data range added on each side of an automatic range.
const RANGE_PAD: f64 = 0.03;

/// How a line is drawn.
#[derive(Clone, Debug)]
pub struct Style {
    /// CSS colour.
    pub color: String,
    /// Stroke width (px).
    pub width: f64,
    /// SVG dash array, if dashed.
    pub dash: Option<&'static str>,
}

impl Style {
    /// A solid line.
    pub fn solid(color: &str, width: f64) -> Style {
        Style {
            color: color.to_string(),
            width,
            dash: None,
        }
    }
    /// A dashed line.
    pub fn dashed(color: &str, width: f64) -> Style {
        Style {
            dash: Some("5 3"),
            ..Style::solid(color, width)
        }
    }
}

/// Something drawn in a plot, in data coordinates. A NaN point breaks a line.
#[derive(Clone, Debug)]
pub enum Mark {
    /// A polyline.
    Line {
        /// Points.
        pts: Vec<[f64; 2]>,
        /// Stroke.
        style: Style,
        /// Legend entry.
        label: Option<String>,
    },
    /// A polyline drawn as a tube of half-width `half_width` data units (a tolerance band:
    /// with equal axis scales, every point within that distance of the line is covered).
    Tube {
        /// Points.
        pts: Vec<[f64; 2]>,
        /// Half-width (data units).
        half_width: f64,
        /// Fill colour.
        color: String,
        /// Legend entry.
        label: Option<String>,
    },
    /// A horizontal line across the plot (a limit).
    HLine {
        /// Height.
        y: f64,
        /// Stroke.
        style: Style,
        /// Legend entry.
        label: Option<String>,
    },
    /// Dots.
    Dots {
        /// Points.
        pts: Vec<[f64; 2]>,
        /// Radius (px).
        r: f64,
        /// Colour.
        color: String,
        /// Legend entry.
        label: Option<String>,
    },
    /// A ring of fixed pixel size with a text beside it (marks a place too small to see).
    Marker {
        /// Where.
        at: [f64; 2],
        /// Text.
        text: String,
        /// Colour.
        color: String,
    },
    /// Histogram bars: bin `i` spans `[x0 + i w, x0 + (i+1) w]`, drawn `shift` of a bin
    /// width to the right and `share` of it wide (side-by-side groups).
    Bars {
        /// Left edge of the first bin.
        x0: f64,
        /// Bin width.
        w: f64,
        /// Bar heights.
        heights: Vec<f64>,
        /// Offset of the bar in its bin, as a share of the bin.
        shift: f64,
        /// Width of the bar, as a share of the bin.
        share: f64,
        /// Colour.
        color: String,
        /// Legend entry.
        label: Option<String>,
    },
}

impl Mark {
    fn label(&self) -> Option<(&str, &str)> {
        match self {
            Mark::Line { label, style, .. } | Mark::HLine { label, style, .. } => {
                label.as_deref().map(|l| (l, style.color.as_str()))
            }
            Mark::Tube { label, color, .. }
            | Mark::Dots { label, color, .. }
            | Mark::Bars { label, color, .. } => label.as_deref().map(|l| (l, color.as_str())),
            Mark::Marker { .. } => None,
        }
    }

    /// The data extent of the mark: `[xmin, xmax, ymin, ymax]` (infinite when empty).
    fn extent(&self) -> [f64; 4] {
        let mut e = [
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        let mut add = |x: f64, y: f64| {
            if x.is_finite() && y.is_finite() {
                e = [e[0].min(x), e[1].max(x), e[2].min(y), e[3].max(y)];
            }
        };
        match self {
            Mark::Line { pts, .. } | Mark::Tube { pts, .. } | Mark::Dots { pts, .. } => {
                pts.iter().for_each(|p| add(p[0], p[1]))
            }
            Mark::HLine { y, .. } => {
                e[2] = *y;
                e[3] = *y;
            }
            Mark::Marker { at, .. } => add(at[0], at[1]),
            Mark::Bars { x0, w, heights, .. } => {
                add(*x0, 0.0);
                for (i, h) in heights.iter().enumerate() {
                    add(x0 + (i + 1) as f64 * w, *h);
                }
            }
        }
        e
    }
}

/// A plot.
#[derive(Clone, Debug)]
pub struct Plot {
    /// Unique id in the page (for the clip path).
    pub id: String,
    /// Title.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// Size (px).
    pub size: [f64; 2],
    /// Same scale on both axes (paths).
    pub equal_aspect: bool,
    /// X range; automatic when `None`.
    pub x_range: Option<[f64; 2]>,
    /// Y range; automatic when `None`.
    pub y_range: Option<[f64; 2]>,
    /// Logarithmic y axis with this floor (smaller values are drawn at it); linear when
    /// `None`. Only lines, dots and horizontal lines are drawn on a log axis.
    pub y_log_floor: Option<f64>,
    /// What is drawn, in order.
    pub marks: Vec<Mark>,
}

/// Maps data to pixels.
#[derive(Clone, Copy, Debug)]
struct Frame {
    x: [f64; 2],
    y: [f64; 2],
    /// Plot area: left, top, width, height (px).
    area: [f64; 4],
}

impl Frame {
    fn px(&self, p: [f64; 2]) -> [f64; 2] {
        let [l, t, w, h] = self.area;
        [
            l + (p[0] - self.x[0]) / (self.x[1] - self.x[0]) * w,
            t + h - (p[1] - self.y[0]) / (self.y[1] - self.y[0]) * h,
        ]
    }
    /// Pixels per data unit along x.
    fn scale(&self) -> f64 {
        self.area[2] / (self.x[1] - self.x[0])
    }
    fn contains_px(&self, q: [f64; 2], margin: f64) -> bool {
        let [l, t, w, h] = self.area;
        q[0] >= l - margin && q[0] <= l + w + margin && q[1] >= t - margin && q[1] <= t + h + margin
    }
}

/// A range with a little padding, never empty.
fn padded(lo: f64, hi: f64) -> [f64; 2] {
    if !(lo.is_finite() && hi.is_finite()) {
        return [0.0, 1.0];
    }
    let span = hi - lo;
    if span <= f64::EPSILON * hi.abs().max(1.0) {
        let d = if lo == 0.0 { 1.0 } else { lo.abs() * 0.1 };
        return [lo - d, hi + d];
    }
    [lo - RANGE_PAD * span, hi + RANGE_PAD * span]
}

/// Tick positions (a 1-2-5 step) covering `[lo, hi]` with about `n` ticks, and the
/// decimals their labels need.
pub fn ticks(lo: f64, hi: f64, n: f64) -> (Vec<f64>, usize) {
    let raw = (hi - lo) / n.max(1.0);
    if !(raw > 0.0 && raw.is_finite()) {
        return (vec![lo], 0);
    }
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    ((first..=last).map(|k| k as f64 * step).collect(), decimals)
}

/// Escapes text for XML.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// A number at 0.1 px, without a trailing `.0`.
fn num(v: f64) -> String {
    let r = (v * 10.0).round() / 10.0;
    let s = format!("{r:.1}");
    s.strip_suffix(".0").map_or(s.clone(), str::to_string)
}

/// Douglas-Peucker simplification ([`ncsmooth::geom::douglas_peucker`]) of one run of
/// pixel points within `tol` px.
pub fn simplify(pts: &[[f64; 2]], tol: f64) -> Vec<[f64; 2]> {
    if pts.len() < 3 {
        return pts.to_vec();
    }
    let dist = |a: usize, b: usize, k: usize| {
        let (pa, pb, p) = (pts[a], pts[b], pts[k]);
        let d = [pb[0] - pa[0], pb[1] - pa[1]];
        let len = d[0].hypot(d[1]);
        let v = [p[0] - pa[0], p[1] - pa[1]];
        if len > 0.0 {
            (v[0] * d[1] - v[1] * d[0]).abs() / len
        } else {
            v[0].hypot(v[1])
        }
    };
    let keep = ncsmooth::geom::douglas_peucker(pts.len(), tol, dist, |_, _| false);
    pts.iter()
        .zip(keep)
        .filter_map(|(p, k)| k.then_some(*p))
        .collect()
}

/// Data points to pixel runs: mapped, clipped to the frame (with `margin` px), broken at
/// NaN, each run simplified.
fn pixel_runs(frame: &Frame, pts: &[[f64; 2]], margin: f64) -> Vec<Vec<[f64; 2]>> {
    let q: Vec<Option<[f64; 2]>> = pts
        .iter()
        .map(|p| (p[0].is_finite() && p[1].is_finite()).then(|| frame.px(*p)))
        .collect();
    let inside = |i: usize| q[i].is_some_and(|p| frame.contains_px(p, margin));
    let mut runs = Vec::new();
    let mut run: Vec<[f64; 2]> = Vec::new();
    for i in 0..q.len() {
        // A point outside is kept when a neighbour is inside (the line leaves the view).
        let keep = q[i].is_some()
            && (inside(i) || (i > 0 && inside(i - 1)) || (i + 1 < q.len() && inside(i + 1)));
        match (keep, q[i]) {
            (true, Some(p)) => run.push(p),
            _ => {
                if run.len() > 1 {
                    runs.push(simplify(&run, SIMPLIFY_PX));
                }
                run.clear();
            }
        }
    }
    if run.len() > 1 {
        runs.push(simplify(&run, SIMPLIFY_PX));
    }
    runs
}

/// SVG path data of pixel runs: absolute move, relative lines from rounded positions
/// (no drift).
fn path_data(runs: &[Vec<[f64; 2]>]) -> String {
    let mut d = String::new();
    for run in runs {
        let r = |v: f64| (v * 10.0).round() / 10.0;
        let mut prev = [r(run[0][0]), r(run[0][1])];
        let _ = write!(d, "M{} {}", num(prev[0]), num(prev[1]));
        let mut first = true;
        for p in &run[1..] {
            let cur = [r(p[0]), r(p[1])];
            let (dx, dy) = (cur[0] - prev[0], cur[1] - prev[1]);
            if dx == 0.0 && dy == 0.0 {
                continue;
            }
            let sep = if first { "l" } else { " " };
            let sy = if dy < 0.0 { "" } else { " " };
            let _ = write!(d, "{sep}{}{sy}{}", num(dx), num(dy));
            first = false;
            prev = cur;
        }
    }
    d
}

impl Plot {
    /// A plot of `size` px with no marks yet.
    pub fn new(id: &str, title: &str, x_label: &str, y_label: &str, size: [f64; 2]) -> Plot {
        Plot {
            id: id.to_string(),
            title: title.to_string(),
            x_label: x_label.to_string(),
            y_label: y_label.to_string(),
            size,
            equal_aspect: false,
            x_range: None,
            y_range: None,
            y_log_floor: None,
            marks: Vec::new(),
        }
    }

    /// The plot with y in decades (`log10`), for a log axis.
    fn in_decades(&self, floor: f64) -> Plot {
        let lg = |y: f64| y.max(floor).log10();
        let pts =
            |p: &Vec<[f64; 2]>| -> Vec<[f64; 2]> { p.iter().map(|q| [q[0], lg(q[1])]).collect() };
        let marks = self
            .marks
            .iter()
            .map(|m| match m {
                Mark::Line {
                    pts: p,
                    style,
                    label,
                } => Mark::Line {
                    pts: pts(p),
                    style: style.clone(),
                    label: label.clone(),
                },
                Mark::Dots {
                    pts: p,
                    r,
                    color,
                    label,
                } => Mark::Dots {
                    pts: pts(p),
                    r: *r,
                    color: color.clone(),
                    label: label.clone(),
                },
                Mark::HLine { y, style, label } => Mark::HLine {
                    y: lg(*y),
                    style: style.clone(),
                    label: label.clone(),
                },
                other => other.clone(),
            })
            .collect();
        Plot {
            marks,
            y_range: self.y_range.map(|r| r.map(lg)),
            y_log_floor: None,
            ..self.clone()
        }
    }

    /// Legend entries `(label, colour, x offset)` by row, wrapped to the plot's width.
    fn legend_rows(&self) -> Vec<Vec<(&str, &str, f64)>> {
        let width = self.size[0] - MARGIN[0] - MARGIN[1];
        let mut rows: Vec<Vec<(&str, &str, f64)>> = Vec::new();
        let mut seen: Vec<&str> = Vec::new();
        let mut x = 0.0;
        for (label, color) in self.marks.iter().filter_map(Mark::label) {
            if seen.contains(&label) {
                continue;
            }
            seen.push(label);
            let w = 30.0 + label.chars().count() as f64 * FONT_PX * CHAR_WIDTH_SHARE;
            if rows.is_empty() || (x + w > width && x > 0.0) {
                rows.push(Vec::new());
                x = 0.0;
            }
            if let Some(r) = rows.last_mut() {
                r.push((label, color, x));
            }
            x += w;
        }
        rows
    }

    /// Top margin: the title and the legend's rows.
    fn top_margin(&self) -> f64 {
        MARGIN[2] + LEGEND_ROW_PX * self.legend_rows().len().saturating_sub(1) as f64
    }

    fn frame(&self) -> Frame {
        let [w, h] = self.size;
        let top = self.top_margin();
        let area = [
            MARGIN[0],
            top,
            w - MARGIN[0] - MARGIN[1],
            h - top - MARGIN[3],
        ];
        let mut e = [
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for m in &self.marks {
            let f = m.extent();
            e = [
                e[0].min(f[0]),
                e[1].max(f[1]),
                e[2].min(f[2]),
                e[3].max(f[3]),
            ];
        }
        let mut x = self.x_range.unwrap_or_else(|| padded(e[0], e[1]));
        let mut y = self.y_range.unwrap_or_else(|| padded(e[2], e[3]));
        if self.equal_aspect {
            // Widen the range that is too narrow for the area's aspect ratio.
            let (sx, sy) = ((x[1] - x[0]) / area[2], (y[1] - y[0]) / area[3]);
            if sx > sy {
                let c = 0.5 * (y[0] + y[1]);
                let half = 0.5 * sx * area[3];
                y = [c - half, c + half];
            } else {
                let c = 0.5 * (x[0] + x[1]);
                let half = 0.5 * sy * area[2];
                x = [c - half, c + half];
            }
        }
        Frame { x, y, area }
    }

    /// The plot as an `<svg>` element.
    pub fn render(&self) -> String {
        if let Some(floor) = self.y_log_floor {
            return self.in_decades(floor).render_with(true);
        }
        self.render_with(false)
    }

    fn render_with(&self, log_y: bool) -> String {
        let f = self.frame();
        let [w, h] = self.size;
        let [l, t, aw, ah] = f.area;
        let mut s = String::new();
        let _ = write!(
            s,
            r##"<svg xmlns="http://www.w3.org/2000/svg" class="plot" id="{id}" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="{FONT_PX}"><rect width="{w}" height="{h}" fill="#fff"/><defs><clipPath id="{id}-clip"><rect x="{l}" y="{t}" width="{aw}" height="{ah}"/></clipPath></defs>"##,
            id = esc(&self.id),
        );
        let _ = write!(
            s,
            r#"<text x="{}" y="16" font-weight="bold">{}</text>"#,
            l,
            esc(&self.title)
        );
        self.axes(&mut s, &f, log_y);
        let _ = write!(s, r#"<g clip-path="url(#{}-clip)">"#, esc(&self.id));
        for m in &self.marks {
            draw(&mut s, &f, m);
        }
        s.push_str("</g>");
        let _ = write!(
            s,
            r##"<rect x="{l}" y="{t}" width="{aw}" height="{ah}" fill="none" stroke="#444"/>"##
        );
        self.legend(&mut s, l, 34.0);
        s.push_str("</svg>");
        s
    }

    fn axes(&self, s: &mut String, f: &Frame, log_y: bool) {
        let [l, t, aw, ah] = f.area;
        let (xt, xd) = ticks(f.x[0], f.x[1], aw / TICK_SPACING_PX[0]);
        let (yt, yd) = if log_y {
            let decades = (f.y[0].ceil() as i32..=f.y[1].floor() as i32).map(f64::from);
            (decades.collect(), 0)
        } else {
            ticks(f.y[0], f.y[1], ah / TICK_SPACING_PX[1])
        };
        s.push_str(r##"<g stroke="#ddd">"##);
        for x in &xt {
            let p = num(f.px([*x, f.y[0]])[0]);
            let _ = write!(s, r#"<path d="M{p} {t}v{ah}"/>"#);
        }
        for y in &yt {
            let p = num(f.px([f.x[0], *y])[1]);
            let _ = write!(s, r#"<path d="M{l} {p}h{aw}"/>"#);
        }
        s.push_str("</g>");
        s.push_str(r##"<g fill="#333">"##);
        for x in &xt {
            let p = num(f.px([*x, f.y[0]])[0]);
            let _ = write!(
                s,
                r#"<text x="{p}" y="{}" text-anchor="middle">{x:.xd$}</text>"#,
                t + ah + 15.0
            );
        }
        for y in &yt {
            let p = num(f.px([f.x[0], *y])[1] + 4.0);
            let label = if log_y {
                decade_label(*y as i32)
            } else {
                format!("{y:.yd$}")
            };
            let _ = write!(
                s,
                r#"<text x="{}" y="{p}" text-anchor="end">{label}</text>"#,
                l - 4.0
            );
        }
        let _ = write!(
            s,
            r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
            num(l + aw / 2.0),
            t + ah + 32.0,
            esc(&self.x_label)
        );
        let (cx, cy) = (14.0, num(t + ah / 2.0));
        let _ = write!(
            s,
            r#"<text transform="translate({cx} {cy}) rotate(-90)" text-anchor="middle">{}</text></g>"#,
            esc(&self.y_label)
        );
    }

    fn legend(&self, s: &mut String, x0: f64, y0: f64) {
        for (row, entries) in self.legend_rows().iter().enumerate() {
            let y = y0 + row as f64 * LEGEND_ROW_PX;
            for (label, color, dx) in entries {
                let x = x0 + dx;
                let _ = write!(
                    s,
                    r#"<rect x="{}" y="{}" width="14" height="4" fill="{color}"/><text x="{}" y="{}">{}</text>"#,
                    num(x),
                    y - 4.0,
                    num(x + 18.0),
                    y,
                    esc(label)
                );
            }
        }
    }
}

/// `10^k` as a plain decimal number ("0.01", "1", "100").
fn decade_label(k: i32) -> String {
    if k >= 0 {
        format!("{}", 10f64.powi(k))
    } else {
        format!("{:.*}", (-k) as usize, 10f64.powi(k))
    }
}

/// Draws one mark.
fn draw(s: &mut String, f: &Frame, m: &Mark) {
    let [l, _, aw, _] = f.area;
    match m {
        Mark::Line { pts, style, .. } => {
            let runs = pixel_runs(f, pts, style.width + 2.0);
            if runs.is_empty() {
                return;
            }
            let dash = style
                .dash
                .map_or(String::new(), |d| format!(r#" stroke-dasharray="{d}""#));
            let _ = write!(
                s,
                r#"<path d="{}" fill="none" stroke="{}" stroke-width="{}" stroke-linejoin="round"{dash}/>"#,
                path_data(&runs),
                style.color,
                style.width
            );
        }
        Mark::Tube {
            pts,
            half_width,
            color,
            ..
        } => {
            let width = (2.0 * half_width * f.scale()).max(0.5);
            let runs = pixel_runs(f, pts, width);
            if runs.is_empty() {
                return;
            }
            let _ = write!(
                s,
                r#"<path d="{}" fill="none" stroke="{color}" stroke-opacity="0.25" stroke-width="{}" stroke-linejoin="round" stroke-linecap="round"/>"#,
                path_data(&runs),
                num(width)
            );
        }
        Mark::HLine { y, style, .. } => {
            let p = num(f.px([f.x[0], *y])[1]);
            let dash = style
                .dash
                .map_or(String::new(), |d| format!(r#" stroke-dasharray="{d}""#));
            let _ = write!(
                s,
                r#"<path d="M{l} {p}h{aw}" stroke="{}" stroke-width="{}"{dash}/>"#,
                style.color, style.width
            );
        }
        Mark::Dots { pts, r, color, .. } => {
            let _ = write!(s, r#"<g fill="{color}">"#);
            for p in pts.iter().filter(|p| p[0].is_finite() && p[1].is_finite()) {
                let q = f.px(*p);
                if f.contains_px(q, *r) {
                    let _ = write!(
                        s,
                        r#"<circle cx="{}" cy="{}" r="{r}"/>"#,
                        num(q[0]),
                        num(q[1])
                    );
                }
            }
            s.push_str("</g>");
        }
        Mark::Marker { at, text, color } => {
            let q = f.px(*at);
            let _ = write!(
                s,
                r#"<circle cx="{x}" cy="{y}" r="8" fill="none" stroke="{color}" stroke-width="2"/><text x="{}" y="{}" fill="{color}" font-weight="bold">{}</text>"#,
                num(q[0] + 10.0),
                num(q[1] - 8.0),
                esc(text),
                x = num(q[0]),
                y = num(q[1]),
            );
        }
        Mark::Bars {
            x0,
            w,
            heights,
            shift,
            share,
            color,
            ..
        } => {
            let _ = write!(s, r#"<g fill="{color}">"#);
            for (i, h) in heights.iter().enumerate().filter(|(_, h)| **h > 0.0) {
                let a = f.px([x0 + (i as f64 + shift) * w, *h]);
                let b = f.px([x0 + (i as f64 + shift + share) * w, 0.0]);
                let _ = write!(
                    s,
                    r#"<rect x="{}" y="{}" width="{}" height="{}"/>"#,
                    num(a[0]),
                    num(a[1]),
                    num((b[0] - a[0]).max(0.5)),
                    num(b[1] - a[1])
                );
            }
            s.push_str("</g>");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_round_numbers_covering_the_range() {
        let (t, d) = ticks(0.0, 9.87, 5.0);
        assert_eq!(t, vec![0.0, 2.0, 4.0, 6.0, 8.0]);
        assert_eq!(d, 0);
        let (t, d) = ticks(-0.013, 0.012, 5.0);
        assert_eq!(d, 3);
        assert!(t.contains(&0.0) && t.len() >= 4, "{t:?}");
    }

    #[test]
    fn simplification_keeps_corners_and_drops_collinear_points() {
        let line: Vec<[f64; 2]> = (0..100).map(|i| [i as f64, 0.0]).collect();
        assert_eq!(simplify(&line, 0.3), vec![[0.0, 0.0], [99.0, 0.0]]);
        let mut vee = line.clone();
        vee.extend((1..100).map(|i| [99.0, i as f64]));
        let s = simplify(&vee, 0.3);
        assert_eq!(s, vec![[0.0, 0.0], [99.0, 0.0], [99.0, 99.0]]);
    }

    #[test]
    fn a_plot_is_well_formed_and_bounded_whatever_the_data_size() {
        let n = 200_000;
        let pts: Vec<[f64; 2]> = (0..n)
            .map(|i| {
                let t = i as f64 / n as f64 * 20.0;
                [t, t.sin()]
            })
            .collect();
        let mut p = Plot::new("p<1>", "sine & co", "t (s)", "y", [800.0, 300.0]);
        p.marks.push(Mark::Line {
            pts,
            style: Style::solid("#1f77b4", 1.0),
            label: Some("sin".into()),
        });
        p.marks.push(Mark::HLine {
            y: 0.9,
            style: Style::dashed("#c00", 1.0),
            label: Some("limit".into()),
        });
        let svg = p.render();
        assert!(svg.starts_with("<svg") && svg.ends_with("</svg>"));
        assert!(svg.contains("p&lt;1&gt;") && svg.contains("sine &amp; co"));
        assert!(svg.len() < 20_000, "{} bytes", svg.len());
        // Every opened element is closed (a crude well-formedness check).
        assert_eq!(svg.matches("<g").count(), svg.matches("</g>").count());
    }

    #[test]
    fn a_log_axis_labels_decades_and_a_long_legend_wraps() {
        let mut p = Plot::new("log", "", "", "", [300.0, 200.0]);
        p.y_log_floor = Some(1e-3);
        for k in 0..6 {
            p.marks.push(Mark::Line {
                pts: vec![[0.0, 0.0], [1.0, 10f64.powi(k - 2)]],
                style: Style::solid("#000", 1.0),
                label: Some(format!("a rather long legend entry {k}")),
            });
        }
        assert!(p.legend_rows().len() >= 3);
        assert!(p.top_margin() > MARGIN[2]);
        let svg = p.render();
        for label in [">0.001<", ">0.1<", ">1<", ">100<"] {
            assert!(svg.contains(label), "{label} in {svg}");
        }
    }

    #[test]
    fn points_outside_the_view_are_dropped_and_the_line_broken() {
        let mut p = Plot::new("c", "", "", "", [200.0, 200.0]);
        p.x_range = Some([0.0, 1.0]);
        p.y_range = Some([0.0, 1.0]);
        let f = p.frame();
        let pts: Vec<[f64; 2]> = (0..=100)
            .map(|i| [i as f64 * 0.05 - 1.0, 0.5])
            .chain([[f64::NAN, f64::NAN], [0.2, 0.2], [0.3, 0.3]])
            .collect();
        let runs = pixel_runs(&f, &pts, 1.0);
        assert_eq!(runs.len(), 2);
        assert_eq!(runs[0].len(), 2, "clipped and simplified: {:?}", runs[0]);
    }
}
