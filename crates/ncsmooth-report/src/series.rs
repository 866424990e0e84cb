//! The data behind the plots, reduced to what a screen can show while it is produced:
//!
//! * [`Buckets`]: a streaming min/max decimation of series along a growing abscissa
//!   (time, arc length): at most [`MAX_BUCKETS`] buckets, each keeping every series'
//!   smallest and largest value in the order they occurred, so peaks survive (a limit
//!   reached for one period still shows). When the abscissa outgrows the buckets, pairs
//!   merge and the bucket width doubles.
//! * [`PlotSink`]: a [`SetpointSink`] that measures the feed and the finite-difference
//!   acceleration and jerk per axis of the rows **as printed** (the same values and
//!   formulas as the report's [`ncsmooth::interp::FdMeter`]) into [`Buckets`].
//! * [`path_points`] and [`curvature_profile`]: the smoothed path's geometry, flattened
//!   within a chord given in mm (what a pixel is worth) and its curvature along the arc
//!   length from the curves themselves ([`ParamCurveCurvature`]).

use ncsmooth::geom::{
    arclen_gk7, Flatten, ParamCurve, ParamCurveBBox, ParamCurveCurvature, Segment, Vec3,
};
use ncsmooth::interp::{printed, Setpoint, SetpointSink, POSITION_DECIMALS};
use ncsmooth::path::{MoveKind, Toolpath};

/// Most buckets of a decimated series (about two per pixel column of a wide plot).
pub const MAX_BUCKETS: usize = 2048;
/// Bucket width (s or mm) a [`Buckets`] starts with; it doubles as needed.
const INITIAL_BUCKET_WIDTH: f64 = 1e-4;
/// Accuracy (mm) of the arc lengths along the curvature profile.
const CURVATURE_ARCLEN_ACCURACY_MM: f64 = 1e-7;
/// Curvature samples per curved segment at least (transitions are short: their peak
/// must be among the samples).
const MIN_CURVE_SAMPLES: usize = 16;
/// Curvature samples per segment at most.
const MAX_CURVE_SAMPLES: usize = 400;

/// One bucket: per series the extremes and where they occurred.
#[derive(Clone, Debug)]
struct Bucket {
    min: Vec<(f64, f64)>,
    max: Vec<(f64, f64)>,
}

impl Bucket {
    fn new(n: usize) -> Bucket {
        Bucket {
            min: vec![(f64::NAN, f64::INFINITY); n],
            max: vec![(f64::NAN, f64::NEG_INFINITY); n],
        }
    }
    fn add(&mut self, i: usize, x: f64, v: f64) {
        if v < self.min[i].1 {
            self.min[i] = (x, v);
        }
        if v > self.max[i].1 {
            self.max[i] = (x, v);
        }
    }
    fn merge(&mut self, o: &Bucket) {
        for i in 0..self.min.len() {
            let (x, v) = o.min[i];
            if v.is_finite() {
                self.add(i, x, v);
            }
            let (x, v) = o.max[i];
            if v.is_finite() {
                self.add(i, x, v);
            }
        }
    }
}

/// Streaming min/max decimation of `n` series along a non-decreasing abscissa.
#[derive(Clone, Debug)]
pub struct Buckets {
    width: f64,
    buckets: Vec<Option<Bucket>>,
    n: usize,
}

impl Buckets {
    /// Buckets for `n` series.
    pub fn new(n: usize) -> Buckets {
        Buckets {
            width: INITIAL_BUCKET_WIDTH,
            buckets: Vec::new(),
            n,
        }
    }

    /// Adds the value `v` of series `i` at abscissa `x >= 0` (NaN values are skipped).
    pub fn add(&mut self, i: usize, x: f64, v: f64) {
        if !(v.is_finite() && x.is_finite() && x >= 0.0) {
            return;
        }
        let mut k = (x / self.width) as usize;
        while k >= MAX_BUCKETS {
            self.coarsen();
            k = (x / self.width) as usize;
        }
        if self.buckets.len() <= k {
            self.buckets.resize(k + 1, None);
        }
        self.buckets[k]
            .get_or_insert_with(|| Bucket::new(self.n))
            .add(i, x, v);
    }

    /// Doubles the bucket width, merging pairs.
    fn coarsen(&mut self) {
        let old = std::mem::take(&mut self.buckets);
        for pair in old.chunks(2) {
            let mut merged: Option<Bucket> = None;
            for b in pair.iter().flatten() {
                match &mut merged {
                    Some(m) => m.merge(b),
                    None => merged = Some(b.clone()),
                }
            }
            self.buckets.push(merged);
        }
        self.width *= 2.0;
    }

    /// Series `i` as points: each bucket's extremes in the order they occurred (a
    /// polyline through them shows every peak); empty buckets are skipped (data sparser
    /// than the buckets is joined, not broken).
    pub fn series(&self, i: usize) -> Vec<[f64; 2]> {
        let mut out = Vec::with_capacity(2 * self.buckets.len());
        for b in self.buckets.iter().flatten() {
            if !b.min[i].1.is_finite() {
                continue;
            }
            let (lo, hi) = (b.min[i], b.max[i]);
            let (a, c) = if lo.0 <= hi.0 { (lo, hi) } else { (hi, lo) };
            out.push([a.0, a.1]);
            if c != a {
                out.push([c.0, c.1]);
            }
        }
        out
    }

    /// Largest value of series `i`.
    #[cfg(test)]
    pub fn max(&self, i: usize) -> f64 {
        self.buckets
            .iter()
            .flatten()
            .map(|b| b.max[i].1)
            .fold(f64::NEG_INFINITY, f64::max)
    }
}

/// Series of [`PlotSink`]: the feed, then acceleration x, y, z, then jerk x, y, z.
pub const FEED: usize = 0;
/// First acceleration series (x; y and z follow).
pub const ACC: usize = 1;
/// First jerk series (x; y and z follow).
pub const JERK: usize = 4;

/// Collects the decimated feed, acceleration and jerk of the rows (see the module doc).
#[derive(Clone, Debug)]
pub struct PlotSink {
    /// The decimated series (`FEED`, `ACC`, `JERK`).
    pub series: Buckets,
    /// Last three printed rows of the current section.
    hist: Vec<(f64, [f64; 3])>,
    last_acc: Option<(f64, [f64; 3])>,
}

impl Default for PlotSink {
    fn default() -> Self {
        PlotSink {
            series: Buckets::new(7),
            hist: Vec::with_capacity(3),
            last_acc: None,
        }
    }
}

impl SetpointSink for PlotSink {
    fn push(&mut self, sp: &Setpoint) -> std::io::Result<()> {
        let t = printed(sp.t, POSITION_DECIMALS);
        let x = [0, 1, 2].map(|i| printed(sp.p[i], POSITION_DECIMALS));
        self.series.add(FEED, t, sp.feed);
        if sp.jump {
            self.hist.clear();
            self.last_acc = None;
        }
        if self.hist.len() == 3 {
            self.hist.remove(0);
        }
        self.hist.push((t, x));
        if let [(ta, xa), (tb, xb), (tc, xc)] = self.hist[..] {
            if tb > ta && tc > tb {
                // The report's formulas (FdMeter): acceleration at the middle row from the
                // two neighbouring velocities, jerk between consecutive accelerations.
                let (inv_ab, inv_bc) = (1.0 / (tb - ta), 1.0 / (tc - tb));
                let two_inv_ac = 2.0 / (tc - ta);
                let acc = [0, 1, 2].map(|i| {
                    let v1 = (xb[i] - xa[i]) * inv_ab;
                    let v2 = (xc[i] - xb[i]) * inv_bc;
                    (v2 - v1) * two_inv_ac
                });
                for i in 0..3 {
                    self.series.add(ACC + i, tb, acc[i]);
                }
                if let Some((tp, ap)) = self.last_acc.filter(|(tp, _)| tb > *tp) {
                    let inv = 1.0 / (tb - tp);
                    for i in 0..3 {
                        self.series
                            .add(JERK + i, 0.5 * (tb + tp), (acc[i] - ap[i]) * inv);
                    }
                }
                self.last_acc = Some((tb, acc));
            }
        }
        Ok(())
    }
}

/// The two axes a path is drawn in: the two with the largest extent of `tp` (X and Y for
/// a milling program; X and Z for a lathe's), in X, Y, Z order.
pub fn view_axes(tp: &Toolpath) -> [usize; 2] {
    let b = tp
        .moves()
        .map(|m| m.segment.bounding_box())
        .fold(ncsmooth::geom::Aabb::EMPTY, |a, b| a.union(b));
    let ext = [0, 1, 2].map(|i| (b.max[i] - b.min[i]).max(0.0));
    let smallest = (0..3)
        .min_by(|&a, &b| ext[a].total_cmp(&ext[b]).then(b.cmp(&a)))
        .unwrap_or(2);
    match smallest {
        0 => [1, 2],
        1 => [0, 2],
        _ => [0, 1],
    }
}

/// The moves of `kind` of `tp` as 2-D polylines in `axes`, flattened within `chord_mm`
/// (broken by NaN where a move does not start at the previous one's end), keeping only
/// moves whose box meets `window` (`[xmin, xmax, ymin, ymax]`, in the view axes) when
/// one is given.
pub fn path_points(
    tp: &Toolpath,
    kind: MoveKind,
    axes: [usize; 2],
    chord_mm: f64,
    window: Option<[f64; 4]>,
) -> Vec<[f64; 2]> {
    let to2 = |p: Vec3| [p[axes[0]], p[axes[1]]];
    let mut out: Vec<[f64; 2]> = Vec::new();
    let mut last: Option<Vec3> = None;
    for m in tp.moves().filter(|m| m.kind == kind) {
        let seg = &m.segment;
        if let Some(w) = window {
            let b = seg.bounding_box();
            let (lo, hi) = (to2(b.min), to2(b.max));
            if hi[0] < w[0] || lo[0] > w[1] || hi[1] < w[2] || lo[1] > w[3] {
                last = None;
                continue;
            }
        }
        let start = seg.start();
        if last.is_none_or(|q| q.dist(start) > chord_mm) {
            if !out.is_empty() {
                out.push([f64::NAN, f64::NAN]);
            }
            out.push(to2(start));
        }
        match seg {
            Segment::Line(_) => out.push(to2(seg.end())),
            _ => seg.flatten(chord_mm, &mut |p| out.push(to2(p))),
        }
        last = Some(seg.end());
    }
    out
}

/// The programmed vertices (start and end of every move of `kind`) of `tp` in `axes` that
/// lie inside `window` (`[xmin, xmax, ymin, ymax]`).
pub fn vertex_points(
    tp: &Toolpath,
    kind: MoveKind,
    axes: [usize; 2],
    window: [f64; 4],
) -> Vec<[f64; 2]> {
    let inside = |p: &[f64; 2]| {
        p[0] >= window[0] && p[0] <= window[1] && p[1] >= window[2] && p[1] <= window[3]
    };
    tp.moves()
        .filter(|m| m.kind == kind)
        .flat_map(|m| [m.segment.start(), m.segment.end()])
        .map(|p| [p[axes[0]], p[axes[1]]])
        .filter(inside)
        .collect()
}

/// Curvature (1/mm) along the arc length (mm) of the feed moves of `tp`, as a decimated
/// series: lines are zero, curves sampled at least `MIN_CURVE_SAMPLES` times (more on
/// long curves, about `max_points` over the whole length); rapids are skipped and do not
/// count in the arc length. The exact corners of a polyline (unbounded curvature) are not
/// shown: see the continuity counts for them.
pub fn curvature_profile(tp: &Toolpath, max_points: usize) -> Vec<[f64; 2]> {
    let feed = || tp.moves().filter(|m| m.kind == MoveKind::Feed);
    let total: f64 = feed()
        .map(|m| m.segment.length(CURVATURE_ARCLEN_ACCURACY_MM))
        .sum();
    let ds = total / max_points.max(1) as f64;
    let mut b = Buckets::new(1);
    let mut s0 = 0.0;
    for m in feed() {
        let seg = &m.segment;
        let len = seg.length(CURVATURE_ARCLEN_ACCURACY_MM);
        if let Segment::Line(_) = seg {
            b.add(0, s0, 0.0);
            b.add(0, s0 + len, 0.0);
            s0 += len;
            continue;
        }
        let n = ((len / ds).ceil() as usize).clamp(MIN_CURVE_SAMPLES, MAX_CURVE_SAMPLES);
        let mut s = s0;
        let mut t_prev = 0.0;
        for k in 0..=n {
            let t = k as f64 / n as f64;
            if k > 0 {
                s += arclen_gk7(seg, t_prev, t, CURVATURE_ARCLEN_ACCURACY_MM);
            }
            b.add(0, s, seg.curvature(t));
            t_prev = t;
        }
        s0 += len;
    }
    b.series(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ncsmooth::geom::Arc;

    #[test]
    fn buckets_keep_every_peak_and_stay_bounded() {
        let mut b = Buckets::new(1);
        let n = 1_000_000;
        for k in 0..n {
            let x = k as f64 * 1e-3;
            let v = if k == 654_321 { 99.0 } else { (x * 0.01).sin() };
            b.add(0, x, v);
        }
        let s = b.series(0);
        assert!(s.len() <= 2 * MAX_BUCKETS, "{}", s.len());
        assert_eq!(b.max(0), 99.0);
        assert!(s
            .iter()
            .any(|p| p[1] == 99.0 && (p[0] - 654.321).abs() < 1e-9));
    }

    #[test]
    fn the_plot_sink_measures_what_the_report_measures() {
        // x = 100 t^2 / 2 (a = 100 mm/s^2), y = 1000 t^3 / 6 (jerk 1000 mm/s^3).
        let mut sink = PlotSink::default();
        let mut fd = ncsmooth::interp::FdMeter::default();
        for k in 0..500 {
            let t = k as f64 * 1e-3;
            let p = Vec3::new(50.0 * t * t, 1000.0 * t * t * t / 6.0, 0.0);
            sink.push(&Setpoint {
                t,
                p,
                feed: 1.0,
                extra: None,
                jump: false,
            })
            .unwrap();
            // The report measures the printed time too.
            let t_printed = printed(t, POSITION_DECIMALS);
            fd.push(
                t_printed,
                [0, 1, 2].map(|i| printed(p[i], POSITION_DECIMALS)),
            );
        }
        assert_eq!(sink.series.max(ACC), fd.stats.a_max[0]);
        assert!((sink.series.max(ACC) - 100.0).abs() < 1e-3);
        assert_eq!(sink.series.max(JERK + 1), fd.stats.j_max[1]);
    }

    #[test]
    fn the_curvature_of_an_arc_is_its_inverse_radius() {
        // A half circle of radius 2.
        let (a, b) = (Vec3::new(2.0, 0.0, 0.0), Vec3::new(-2.0, 0.0, 0.0));
        let arc = Arc::from_center(a, b, Vec3::ZERO, Vec3::Z, true, 0).unwrap();
        let mut tp = Toolpath::new(arc.start());
        tp.push_move(ncsmooth::path::Move::feed(arc, None, 1));
        let k = curvature_profile(&tp, 100);
        assert!(k.iter().all(|p| (p[1] - 0.5).abs() < 1e-9), "{k:?}");
        let s_end = k.iter().map(|p| p[0]).fold(0.0, f64::max);
        assert!((s_end - 2.0 * std::f64::consts::PI).abs() < 1e-6);
    }
}
