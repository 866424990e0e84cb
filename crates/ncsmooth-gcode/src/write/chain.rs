//! Long G1 blocks from a chain of moves: the `lines` emitter's flattening.
//!
//! Flattening each smoothed move on its own (the `native` emitter) ends a block at every
//! move boundary, which leaves blocks a few micrometres long where a short transition
//! meets a line, and rounding the ends of such a block to the written decimals turns it
//! in an arbitrary direction. Controllers pay for both: LinuxCNC caps a block's speed at
//! its length over 1.02 servo periods, grbl's look-ahead covers only its last 15 blocks,
//! and every rounding kink is a junction to slow down for.
//!
//! [`simplify`] instead walks the whole chain (consecutive feed moves at one feed, lines
//! and curves alike) as one dense polyline and cuts it greedily into the longest blocks
//! whose chord stays within the tolerance:
//!
//! 1. the chain is flattened finely (within `DENSE_SHARE` of the chord tolerance), every
//!    move end being a dense point;
//! 2. from the last written point `a`, the block is extended to dense point `j` while every
//!    dense point between them lies within `chord - dense` of the segment from `a` to the
//!    *rounded* `j` (the point as it will be printed), with projections in order along it
//!    (a step back shorter than the tolerance is a wiggle, not a reversal);
//! 3. points where the dense polyline turns by more than `BREAK_TURN_DEG` (a sharp
//!    corner the smoothing left) are always written, so corners are never cut; the turn
//!    is measured over the tolerance, so a cluster of sub-micrometre steps (a CAM file's
//!    quantisation) is one corner at most, not one block per step;
//! 4. a last block shorter than `min_block_mm` is merged into the one before when that
//!    stays within tolerance, or the two share their span at its middle dense point.
//!
//! 5. for a stepper controller ([`crate::Dialect::block_floor_mm`]), blocks still shorter
//!    than its floor are lifted against the *programmed* path ([`lift_short_blocks`]): a
//!    corner transition a few micrometres across is a step or two the controller turns in
//!    whatever direction its rounding gives, and the programmed corner, which it takes at
//!    its own junction speed, is within the tolerance by definition.
//!
//! What it bounds (steps 1-4): every point of the dense polyline (hence of the curve, within the dense
//! accuracy) lies within `chord` of the written polyline and every written point within
//! `chord` of the curve, rounding included; the proof is the convexity of the distance to
//! a segment (dense chords between two points within `t` of a segment stay within `t`)
//! and the projections running from one end to the other (each point of a written
//! segment lies between the projections of two consecutive dense points, whatever their
//! order, so a point of their chord is within `t` of it).

use crate::controller::arcs::ArcChords;
#[cfg(doc)]
use crate::controller::{floor::lift_short_blocks, linuxcnc::even_out::even_out};
use crate::polyline::{fits, seg_dist};
use ncsmooth::geom::Vec3;

/// Accuracy of the dense flattening, as a share of the chord tolerance; the rest of the
/// chord is what merging may use.
pub(crate) const DENSE_SHARE: f64 = 0.25;

/// A dense point where the polyline turns by more than this (degrees) is always written.
pub(crate) const BREAK_TURN_DEG: f64 = 20.0;

/// Most dense points one written block may span (bounds the quadratic cost of the
/// greedy test on long straight runs).
pub(crate) const MAX_SPAN_POINTS: usize = 512;

/// Sharp turns of the dense polyline: `hard[k]` when the polyline turns at `k` by more
/// than `BREAK_TURN_DEG`. The turn is measured between the chords to the nearest dense
/// points at least `span_mm` away on either side (at most `MAX_SPAN_POINTS` points
/// away), and of sharp points closer than `span_mm` to each other along the polyline only
/// the sharpest is hard: a cluster of sub-micrometre steps in arbitrary directions is
/// not a corner, and writing each of its points gave blocks of one written unit turning
/// 90 degrees (camotics_vcarve on LinuxCNC: 0.0003 mm blocks, each capped at 0.25 mm/s).
/// With `span_mm = 0` every turn between neighbours counts. The first and last points are
/// always hard.
pub fn sharp_points(dense: &[Vec3], span_mm: f64) -> Vec<bool> {
    let cos_break = BREAK_TURN_DEG.to_radians().cos();
    let n = dense.len();
    let mut hard = vec![false; n];
    if n == 0 {
        return hard;
    }
    hard[0] = true;
    hard[n - 1] = true;
    // The sharpest point of the current cluster (index, cosine of its turn) and the arc
    // length of the cluster's last sharp point.
    let mut cluster: Option<(usize, f64)> = None;
    let (mut s, mut last_sharp_s) = (0.0, f64::NEG_INFINITY);
    for k in 1..n.saturating_sub(1) {
        s += dense[k].dist(dense[k - 1]);
        let Some(cos) = turn_cos(dense, k, span_mm) else {
            continue;
        };
        if cos >= cos_break {
            continue;
        }
        match cluster {
            Some((_, c)) if s - last_sharp_s < span_mm => {
                if cos < c {
                    cluster = Some((k, cos));
                }
            }
            _ => {
                if let Some((b, _)) = cluster {
                    hard[b] = true;
                }
                cluster = Some((k, cos));
            }
        }
        last_sharp_s = s;
    }
    if let Some((b, _)) = cluster {
        hard[b] = true;
    }
    hard
}

/// Cosine of the turn at dense point `k` between the chords from the nearest point at
/// least `span_mm` before it and to the nearest at least `span_mm` after it (the ends, or
/// [`MAX_SPAN_POINTS`] away, when none is that far); `None` when a chord is empty.
fn turn_cos(dense: &[Vec3], k: usize, span_mm: f64) -> Option<f64> {
    let p = dense[k];
    let lo = k.saturating_sub(MAX_SPAN_POINTS);
    let hi = (k + MAX_SPAN_POINTS).min(dense.len() - 1);
    let i = (lo..k)
        .rev()
        .find(|&i| dense[i].dist(p) >= span_mm)
        .unwrap_or(lo);
    let j = (k + 1..=hi)
        .find(|&j| dense[j].dist(p) >= span_mm)
        .unwrap_or(hi);
    let (u, v) = (p - dense[i], dense[j] - p);
    let (lu, lv) = (u.norm(), v.norm());
    (lu > 0.0 && lv > 0.0).then(|| u.dot(v) / (lu * lv))
}

/// Cuts `dense` (starting at the already written point `dense[0]`) into the longest
/// blocks within `tol_mm`, see the module doc. `round` maps a point to where it will be
/// printed. Pushes the written points after the start (the last one is `round` of the
/// last dense point) to `out`, and returns the dense index of each written point, the
/// start's (0) first (what [`even_out`] takes).
pub fn simplify(
    dense: &[Vec3],
    hard: &[bool],
    tol_mm: f64,
    min_block_mm: f64,
    round: impl Fn(Vec3) -> Vec3,
    out: &mut Vec<Vec3>,
) -> Vec<usize> {
    let n = dense.len();
    if n < 2 {
        return vec![0];
    }
    let first_out = out.len();
    // Dense index of each written point (index 0 is the start).
    let mut idx = vec![0usize];
    let mut a = 0usize;
    let mut pa = round(dense[0]);
    while a + 1 < n {
        let best = longest_line(dense, hard, a, pa, tol_mm, &round);
        pa = round(dense[best]);
        out.push(pa);
        idx.push(best);
        a = best;
    }
    balance_tail(
        dense,
        &mut idx,
        tol_mm,
        min_block_mm,
        &round,
        out,
        first_out,
    );
    idx
}

/// Dense points tried past the last one that fitted before a search gives up: a later
/// fit would need the curve to come back.
const SEARCH_PAST_FIT: usize = 4;

/// The farthest dense index a line from the written point `pa` (dense index `a`) reaches
/// within `tol_mm` (at least `a + 1`).
fn longest_line(
    dense: &[Vec3],
    hard: &[bool],
    a: usize,
    pa: Vec3,
    tol_mm: f64,
    round: &impl Fn(Vec3) -> Vec3,
) -> usize {
    let n = dense.len();
    let mut best = a + 1;
    let mut j = a + 2;
    while j < n && j - a <= MAX_SPAN_POINTS && !hard[j - 1] {
        if fits(dense, a, j, pa, round(dense[j]), tol_mm) {
            best = j;
        } else if j - best > SEARCH_PAST_FIT {
            break;
        }
        j += 1;
    }
    best
}

/// Fewest dense steps an arc spans: shorter spans are lines.
pub(crate) const MIN_ARC_SPAN: usize = 3;

/// Largest radius (mm) fitted as an arc; flatter runs are lines.
pub(crate) const MAX_ARC_RADIUS_MM: f64 = 1e4;

/// A piece of the written path from [`fit_arcs`]: a line or an arc in the XY plane (its Z
/// linear in the swept angle, a helix), ending at the rounded dense point `to`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Piece {
    /// A line to `end`.
    Line {
        /// Dense index of the end.
        to: usize,
        /// End point (rounded).
        end: Vec3,
    },
    /// An arc about `center` (Z of its start) to `end`.
    Arc {
        /// Dense index of the start.
        from: usize,
        /// Dense index of the end.
        to: usize,
        /// End point (rounded).
        end: Vec3,
        /// Centre.
        center: Vec3,
        /// Counter-clockwise seen from +Z.
        ccw: bool,
    },
}

/// Centre (z = 0) of the circle through three points projected on XY; `None` when they
/// are collinear there.
fn circle_xy(a: Vec3, b: Vec3, c: Vec3) -> Option<Vec3> {
    let (bx, by) = (b.x - a.x, b.y - a.y);
    let (cx, cy) = (c.x - a.x, c.y - a.y);
    let d = 2.0 * (bx * cy - by * cx);
    if d.abs() <= f64::EPSILON * (bx.abs() + by.abs()) * (cx.abs() + cy.abs()) || d == 0.0 {
        return None;
    }
    let (b2, c2) = (bx * bx + by * by, cx * cx + cy * cy);
    let ux = (cy * b2 - by * c2) / d;
    let uy = (bx * c2 - cx * b2) / d;
    Some(Vec3::new(a.x + ux, a.y + uy, 0.0))
}

/// Angle (0..2 pi) swept from `u0` to `p` about `c` in the XY plane, in the sense `ccw`.
fn swept(c: Vec3, u0: f64, p: Vec3, ccw: bool) -> f64 {
    let a = (p.y - c.y).atan2(p.x - c.x) - u0;
    let a = if ccw { a } else { -a };
    a.rem_euclid(std::f64::consts::TAU)
}

/// How far a point is from an arc: outside and inside its circle (XY, at most one of
/// them non-zero for a point known exactly) and in Z.
#[derive(Clone, Copy)]
struct Miss {
    out: f64,
    inside: f64,
    z: f64,
}

impl Miss {
    /// A gap of `d` in any direction.
    fn any(d: f64) -> Miss {
        Miss {
            out: d,
            inside: d,
            z: d,
        }
    }

    /// Largest distance from the executed path at the point's angle: the controller's
    /// chords run between the circle and `sag` inside it.
    fn gap(self, sag: f64) -> f64 {
        (self.out + sag).max(self.inside).hypot(self.z)
    }
}

/// An arc in the XY plane about `c` of radius `r` from angle `u0`, turning `ccw`, its Z
/// linear in the swept angle from `z0` at `dz_per_rad`; the controller runs it as chords
/// whose points at each angle lie between the circle and `sag` inside it (0 when it runs
/// the circle itself).
#[derive(Clone, Copy)]
struct ArcXy {
    c: Vec3,
    r: f64,
    u0: f64,
    ccw: bool,
    z0: f64,
    dz_per_rad: f64,
    sag: f64,
}

impl ArcXy {
    /// The point swept `th` from the start, `depth` inside the circle.
    fn at(&self, th: f64, depth: f64) -> Vec3 {
        let u = if self.ccw { self.u0 + th } else { self.u0 - th };
        let r = self.r - depth;
        Vec3::new(
            self.c.x + r * u.cos(),
            self.c.y + r * u.sin(),
            self.z0 + self.dz_per_rad * th,
        )
    }

    /// How far the point at `p` (swept `th`) is from the arc.
    fn miss(&self, p: Vec3, th: f64) -> Miss {
        let dr = (p.x - self.c.x).hypot(p.y - self.c.y) - self.r;
        Miss {
            out: dr.max(0.0),
            inside: (-dr).max(0.0),
            z: (p.z - (self.z0 + self.dz_per_rad * th)).abs(),
        }
    }

    /// Whether the executed arc piece swept from `t0` to `t1` and the segment `a`-`b`
    /// (whose ends are swept `t0` and `t1`, at `miss[0]` and `miss[1]` from the arc) are
    /// within `tol` of each other both ways.
    ///
    /// Segment to executed path: a segment point's distance from it is at most the
    /// hypotenuse of its radial and Z gaps ([`Miss::gap`]). How far outside the circle
    /// the segment goes is at most its ends' (the distance to the centre is convex along
    /// it), how far inside at most the ends' and that of its nearest point to the centre;
    /// Z is linear along both, so its gap is at most its ends'. Executed path to segment:
    /// its point at each angle lies on the ray between the circle and `sag` inside it, and
    /// the distance to the segment is convex along that ray, so the circle and the circle
    /// `sag` inside are checked. Each is sampled so that it leaves the chords between
    /// samples by at most `tol / 64`; the distance to the segment, convex along each such
    /// chord, is at most its samples' plus that.
    fn piece_within(&self, t0: f64, t1: f64, a: Vec3, b: Vec3, miss: [Miss; 2], tol: f64) -> bool {
        let flat = |p: Vec3| Vec3::new(p.x, p.y, 0.0);
        let (d_near, foot) = seg_dist(flat(self.c), flat(a), flat(b));
        let dips = if (0.0..=1.0).contains(&foot) {
            (self.r - d_near).max(0.0)
        } else {
            0.0
        };
        let whole = Miss {
            out: miss[0].out.max(miss[1].out),
            inside: miss[0].inside.max(miss[1].inside).max(dips),
            z: miss[0].z.max(miss[1].z),
        };
        if miss[1].gap(self.sag) > tol || whole.gap(self.sag) > tol {
            return false;
        }
        let span = t1 - t0;
        let slack = tol / 64.0;
        // Sagitta of a sample chord: r (1 - cos(step / 2)) <= slack.
        let step = if slack < self.r {
            2.0 * (1.0 - slack / self.r).acos()
        } else {
            span
        };
        let n = ((span / step).ceil() as usize).clamp(1, 256);
        let depths: &[f64] = if self.sag > 0.0 {
            &[0.0, self.sag]
        } else {
            &[0.0]
        };
        (0..=n).all(|k| {
            let th = t0 + span * k as f64 / n as f64;
            depths
                .iter()
                .all(|&d| seg_dist(self.at(th, d), a, b).0 + slack <= tol)
        })
    }
}

/// Whether the arc from `pa` to `pe` about `c` (XY, Z linear in angle), as the controller
/// runs it (`chords`), and the dense polyline from `from` to `to` are within `tol` of each
/// other both ways, their points in order along it: piece by piece between the dense
/// points' angles ([`ArcXy::piece_within`]), the written ends standing for the dense ones.
#[allow(clippy::too_many_arguments)]
fn arc_fits(
    dense: &[Vec3],
    from: usize,
    to: usize,
    pa: Vec3,
    pe: Vec3,
    (c, ccw): (Vec3, bool),
    tol: f64,
    chords: ArcChords,
) -> bool {
    let r = (pa.x - c.x).hypot(pa.y - c.y);
    if ((pe.x - c.x).hypot(pe.y - c.y) - r).abs() > tol * 0.25 {
        return false;
    }
    let u0 = (pa.y - c.y).atan2(pa.x - c.x);
    let total = swept(c, u0, pe, ccw);
    if total <= 0.0 {
        return false;
    }
    // The controller's chords lie inside the arc by up to their sagitta: counted where
    // they lie for a planar arc, from the whole tolerance for a helix (whose chords'
    // heights are not the helix's at each angle).
    let sag = chords.sagitta_mm(r, total);
    let (tol, sag) = if pe.z == pa.z {
        (tol, sag)
    } else {
        (tol - sag, 0.0)
    };
    if tol <= sag {
        return false;
    }
    if !radially_within(&dense[from + 1..to], c, r - sag - tol, r + tol) {
        return false;
    }
    let arc = ArcXy {
        c,
        r,
        u0,
        ccw,
        z0: pa.z,
        dz_per_rad: (pe.z - pa.z) / total,
        sag,
    };
    // The written ends stand for the dense ones: a gap of their distance either way.
    let end_off = ((pe.x - c.x).hypot(pe.y - c.y) - r).abs();
    let (mut t0, mut a, mut miss_a) = (0.0, dense[from], Miss::any(pa.dist(dense[from])));
    for k in from + 1..=to {
        let p = dense[k];
        let (t1, miss_b) = if k == to {
            let d = pe.dist(p);
            let radial = d + end_off;
            (
                total,
                Miss {
                    out: radial,
                    inside: radial,
                    z: d,
                },
            )
        } else {
            let th = swept(c, u0, p, ccw);
            (th, arc.miss(p, th))
        };
        if t1 < t0 || t1 > total || !arc.piece_within(t0, t1, a, p, [miss_a, miss_b], tol) {
            return false;
        }
        (t0, a, miss_a) = (t1, p, miss_b);
    }
    true
}

/// Whether every point of `pts` lies at an XY distance from `c` between `lo` and `hi`
/// (up to a relative 1e-9): a dense point within the tolerance of an arc run as chords
/// inside it does, so an end that fails this fails [`arc_fits`], at a square root a
/// point instead of the sampled check of every piece.
fn radially_within(pts: &[Vec3], c: Vec3, lo: f64, hi: f64) -> bool {
    let margin = 1.0 + 1e-9;
    let hi_sq = (hi * margin).powi(2);
    let lo_sq = if lo > 0.0 { (lo / margin).powi(2) } else { 0.0 };
    pts.iter().all(|p| {
        let d_sq = (p.x - c.x).powi(2) + (p.y - c.y).powi(2);
        d_sq <= hi_sq && d_sq >= lo_sq
    })
}

/// The centre (Z of `pa`) of the circle through `pa` and `pe` that bulges from their chord
/// by `h` on the side of `towards` (a point off the chord).
fn circle_with_bulge(pa: Vec3, pe: Vec3, towards: Vec3, h: f64) -> Option<Vec3> {
    let (dx, dy) = (pe.x - pa.x, pe.y - pa.y);
    let l = dx.hypot(dy);
    if l <= 0.0 || h <= 0.0 {
        return None;
    }
    let (mx, my) = (0.5 * (pa.x + pe.x), 0.5 * (pa.y + pe.y));
    // Unit normal of the chord towards the bulge.
    let (mut nx, mut ny) = (-dy / l, dx / l);
    if (towards.x - mx) * nx + (towards.y - my) * ny < 0.0 {
        (nx, ny) = (-nx, -ny);
    }
    let r = (0.25 * l * l + h * h) / (2.0 * h);
    // The centre is r - h from the chord, on the bulge's side for a minor arc.
    let off = h - r;
    Some(Vec3::new(mx + nx * off, my + ny * off, pa.z))
}

/// Of the circles through `pa` and `pe` (dense indices `a` and `j`), the one that best
/// balances the dense points outside it against the dense chords inside it, from the
/// circle `c` through `mid` (a minor arc): flattening the arc by `d` at the middle of its
/// chord moves it by about `4 u (1 - u) d` at chord parameter `u`, so the largest miss,
/// the larger of the points' and the chord middles' offsets, is convex in `d` and its
/// minimum is found by a ternary search; the circles at and around it are then checked
/// exactly by the caller, in [`BULGE_TRIES`] order.
fn banded_circle(
    dense: &[Vec3],
    a: usize,
    j: usize,
    pa: Vec3,
    pe: Vec3,
    mid: Vec3,
    c: Vec3,
) -> Vec<Vec3> {
    let side = |p: Vec3| (pe.x - pa.x) * (p.y - pa.y) - (pe.y - pa.y) * (p.x - pa.x);
    if side(mid) * side(c) >= 0.0 {
        return Vec::new();
    }
    let r = (pa.x - c.x).hypot(pa.y - c.y);
    let (dx, dy) = (pe.x - pa.x, pe.y - pa.y);
    let l2 = dx * dx + dy * dy;
    if l2 <= 0.0 {
        return Vec::new();
    }
    let centre_to_chord = (0.5 * (pa.x + pe.x) - c.x).hypot(0.5 * (pa.y + pe.y) - c.y);
    let bulge = r - centre_to_chord;
    let weight = |p: Vec3| {
        let u = (((p.x - pa.x) * dx + (p.y - pa.y) * dy) / l2).clamp(0.0, 1.0);
        4.0 * u * (1.0 - u)
    };
    let off = |p: Vec3| (p.x - c.x).hypot(p.y - c.y) - r;
    // (offset outside the circle, weight) of the points and of the chord middles.
    let mut terms: Vec<(f64, f64)> = Vec::with_capacity(2 * (j - a));
    for k in a..j {
        let (p, q) = (dense[k], dense[k + 1]);
        if k > a {
            terms.push((off(p), weight(p)));
        }
        let m = (p + q) * 0.5;
        terms.push((off(m), weight(m)));
    }
    let miss = |d: f64| {
        terms
            .iter()
            .map(|&(o, w)| (o + w * d).abs())
            .fold(0.0, f64::max)
    };
    let (mut lo, mut hi) = (0.0, bulge);
    for _ in 0..40 {
        let (m1, m2) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
        if miss(m1) <= miss(m2) {
            hi = m2;
        } else {
            lo = m1;
        }
    }
    let d = 0.5 * (lo + hi);
    if d <= 0.0 {
        return Vec::new();
    }
    // The model's optimum first, then around it (the parabola is only the model).
    BULGE_TRIES
        .iter()
        .filter_map(|f| circle_with_bulge(pa, pe, mid, bulge - d * f))
        .collect()
}

/// Shares of the model's flattening [`banded_circle`] tries, in order.
const BULGE_TRIES: [f64; 5] = [1.0, 0.8, 1.2, 0.6, 1.4];

/// The longest arc from the written point `pa` (dense index `a`) within `tol_mm`: its end
/// index, centre and sense, if one spans at least [`MIN_ARC_SPAN`] dense steps. The end
/// is searched by galloping then bisection (an arc that fits to `j` nearly always fits
/// to every end before it), so a long arc costs a logarithmic number of checks.
fn longest_arc(
    dense: &[Vec3],
    hard: &[bool],
    a: usize,
    pa: Vec3,
    tol_mm: f64,
    chords: ArcChords,
    round: &impl Fn(Vec3) -> Vec3,
) -> Option<(usize, Vec3, bool)> {
    // The farthest end: no hard point inside the arc, at most MAX_SPAN_POINTS steps.
    let mut limit = a + MIN_ARC_SPAN;
    if limit >= dense.len() || hard[limit - 1] || hard[limit - 2] {
        return None;
    }
    while limit + 1 < dense.len() && limit + 1 - a <= MAX_SPAN_POINTS && !hard[limit] {
        limit += 1;
    }
    let arc_to = |j: usize| {
        let pe = round(dense[j]);
        let mid = dense[(a + j) / 2];
        let turn = (mid.x - pa.x) * (pe.y - mid.y) - (mid.y - pa.y) * (pe.x - mid.x);
        let ccw = turn > 0.0;
        let try_centre = |c: Vec3| {
            let r = (pa.x - c.x).hypot(pa.y - c.y);
            (r <= MAX_ARC_RADIUS_MM && arc_fits(dense, a, j, pa, pe, (c, ccw), tol_mm, chords))
                .then_some((j, c, ccw))
        };
        circle_xy(pa, mid, pe).and_then(|c| {
            let c = Vec3::new(c.x, c.y, pa.z);
            // The circle through the middle of the band between the points and their
            // chords (a flattened circle's lines lie inside it by their sagitta), else the
            // circle through the points.
            banded_circle(dense, a, j, pa, pe, mid, c)
                .into_iter()
                .find_map(try_centre)
                .or_else(|| try_centre(c))
        })
    };
    let first = a + MIN_ARC_SPAN;
    let (mut good, mut best) =
        (first..=limit.min(first + SEARCH_PAST_FIT)).find_map(|j| arc_to(j).map(|f| (j, f)))?;
    let mut step = 1;
    let mut bad = None;
    while good < limit {
        let j = (good + step).min(limit);
        match arc_to(j) {
            Some(f) => (good, best, step) = (j, f, step * 2),
            None => {
                bad = Some(j);
                break;
            }
        }
    }
    if let Some(mut hi) = bad {
        while hi - good > 1 {
            let j = (good + hi) / 2;
            match arc_to(j) {
                Some(f) => (good, best) = (j, f),
                None => hi = j,
            }
        }
    }
    Some(best)
}

/// Like [`simplify`], with arcs: from each written point the piece that reaches farther,
/// the longest line or the longest XY arc (helical when Z changes), both within `tol_mm`
/// of every dense point they span, end points rounded. ArcWelder's idea (arcs through
/// runs of G1 points within a resolution) with the two-sided check of this module.
pub fn fit_arcs(
    dense: &[Vec3],
    hard: &[bool],
    tol_mm: f64,
    chords: ArcChords,
    round: impl Fn(Vec3) -> Vec3,
    out: &mut Vec<Piece>,
) {
    let n = dense.len();
    let mut a = 0usize;
    let mut pa = round(dense.first().copied().unwrap_or_default());
    while a + 1 < n {
        let jl = longest_line(dense, hard, a, pa, tol_mm, &round);
        match longest_arc(dense, hard, a, pa, tol_mm, chords, &round) {
            Some((ja, center, ccw)) if ja > jl => {
                let end = round(dense[ja]);
                out.push(Piece::Arc {
                    from: a,
                    to: ja,
                    end,
                    center,
                    ccw,
                });
                a = ja;
                pa = end;
            }
            _ => {
                pa = round(dense[jl]);
                out.push(Piece::Line { to: jl, end: pa });
                a = jl;
            }
        }
    }
}

/// Step 4 of the module doc: a short last block is merged into the one before or the two
/// share their span.
fn balance_tail(
    dense: &[Vec3],
    idx: &mut Vec<usize>,
    tol_mm: f64,
    min_block_mm: f64,
    round: &impl Fn(Vec3) -> Vec3,
    out: &mut Vec<Vec3>,
    first_out: usize,
) {
    let k = out.len();
    if k < first_out + 2 || idx.len() < 3 {
        return;
    }
    let (last, prev) = (out[k - 1], out[k - 2]);
    if last.dist(prev) >= min_block_mm {
        return;
    }
    let (i0, i1, i2) = (idx[idx.len() - 3], idx[idx.len() - 2], idx[idx.len() - 1]);
    let p0 = if k >= first_out + 3 {
        out[k - 3]
    } else {
        round(dense[i0])
    };
    if i2 - i0 <= MAX_SPAN_POINTS && fits(dense, i0, i2, p0, last, tol_mm) {
        out.remove(k - 2);
        idx.remove(idx.len() - 2);
        return;
    }
    let mid = (i0 + i2) / 2;
    if mid == i1 || mid == i0 || mid == i2 {
        return;
    }
    let pm = round(dense[mid]);
    if fits(dense, i0, mid, p0, pm, tol_mm) && fits(dense, mid, i2, pm, last, tol_mm) {
        out[k - 2] = pm;
        let j = idx.len() - 2;
        idx[j] = mid;
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::polyline::seg_dist;
    use proptest::prelude::*;

    pub(crate) fn dist_to_polyline(p: Vec3, pl: &[Vec3]) -> f64 {
        pl.windows(2)
            .map(|w| seg_dist(p, w[0], w[1]).0)
            .fold(f64::INFINITY, f64::min)
    }

    /// Largest distance of the points of `a` (sampled along each segment) from `b`.
    pub(crate) fn one_sided(a: &[Vec3], b: &[Vec3]) -> f64 {
        let mut m: f64 = 0.0;
        for w in a.windows(2) {
            for s in 0..=16 {
                let p = w[0] + (w[1] - w[0]) * (s as f64 / 16.0);
                m = m.max(dist_to_polyline(p, b));
            }
        }
        m
    }

    pub(crate) fn arc_points(r: f64, sweep: f64, n: usize) -> Vec<Vec3> {
        (0..=n)
            .map(|k| {
                let t = sweep * k as f64 / n as f64;
                Vec3::new(r * t.cos(), r * t.sin(), 0.0)
            })
            .collect()
    }

    /// The firmwares' chords the arc tests run (`controller::arcs`' defaults).
    const FIRMWARES: [ArcChords; 4] = [
        ArcChords::Exact,
        ArcChords::Tolerance { mm: 0.002 },
        ArcChords::Segments {
            max_mm: 1.0,
            min_mm: 0.1,
            per_turn: 72.0,
        },
        ArcChords::Floor { resolution_mm: 1.0 },
    ];

    /// The points a controller runs for the minor or major arc from `start` to `end`
    /// about `center` (XY, Z linear): equal chords no longer in angle than the sagitta
    /// model allows (the circle itself sampled finely for [`ArcChords::Exact`]).
    pub(crate) fn executed_arc(
        start: Vec3,
        end: Vec3,
        center: Vec3,
        ccw: bool,
        chords: ArcChords,
    ) -> Vec<Vec3> {
        let r = (start.x - center.x).hypot(start.y - center.y);
        let u0 = (start.y - center.y).atan2(start.x - center.x);
        let total = swept(center, u0, end, ccw);
        let sag = chords.sagitta_mm(r, total);
        // The chord angle whose sagitta is `sag`, or a fine one for the exact circle.
        let angle = if sag > 0.0 {
            2.0 * (1.0 - sag / r).clamp(-1.0, 1.0).acos()
        } else {
            total / 4096.0
        };
        let n = ((total / angle) - 1e-9).ceil().max(1.0) as usize;
        (1..=n)
            .map(|k| {
                let t = total * k as f64 / n as f64;
                let u = if ccw { u0 + t } else { u0 - t };
                if k == n {
                    end
                } else {
                    Vec3::new(
                        center.x + r * u.cos(),
                        center.y + r * u.sin(),
                        start.z + (end.z - start.z) * k as f64 / n as f64,
                    )
                }
            })
            .collect()
    }

    #[test]
    fn points_outside_the_circle_and_chords_inside_share_the_band() {
        // A chord whose ends lie 0.02 mm outside a radius-10 circle and whose middle dips
        // 0.02 mm inside it: the arc and the chord are 0.02 mm apart, no more.
        let (r_out, sag): (f64, f64) = (10.02, 0.04);
        let half = (1.0 - sag / r_out).acos();
        let at = |u: f64| Vec3::new(r_out * u.cos(), r_out * u.sin(), 0.0);
        let (a, b) = (at(-half), at(half));
        let arc = |sag| ArcXy {
            c: Vec3::ZERO,
            r: 10.0,
            u0: -half,
            ccw: true,
            z0: 0.0,
            dz_per_rad: 0.0,
            sag,
        };
        let miss = arc(0.0).miss(a, 0.0);
        let within = |sag, tol| arc(sag).piece_within(0.0, 2.0 * half, a, b, [miss; 2], tol);
        // (The arc is sampled with a slack of tol / 64.)
        assert!(within(0.0, 0.0204) && !within(0.0, 0.0199));
        // Run as chords dipping up to 0.0125 mm inside the circle, the points outside it are
        // that much farther from the path.
        assert!(within(0.0125, 0.0331) && !within(0.0125, 0.0324));
    }

    #[test]
    fn a_fine_arc_becomes_long_blocks_within_the_tolerance() {
        // Radius 10 mm, flattened at 1e-5 mm: chords of 0.028 mm. Within 1e-3 mm a
        // chord may be sqrt(8 r t) = 0.28 mm long.
        let dense = arc_points(10.0, 1.0, 360);
        let hard = sharp_points(&dense, 1e-3);
        let mut out = Vec::new();
        simplify(&dense, &hard, 1e-3, 0.0, |p| p, &mut out);
        assert!(out.len() < 60, "{} blocks", out.len());
        assert_eq!(*out.last().unwrap(), *dense.last().unwrap());
        let mut written = vec![dense[0]];
        written.extend_from_slice(&out);
        assert!(one_sided(&dense, &written) <= 1e-3 + 1e-12);
        assert!(one_sided(&written, &dense) <= 1e-3 + 1e-12);
    }

    #[test]
    fn sharp_corners_are_kept() {
        let dense = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1e-4, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
        ];
        let hard = sharp_points(&dense, 1e-3);
        assert!(hard[1] && !hard[2]);
        let mut out = Vec::new();
        simplify(&dense, &hard, 1e-3, 0.0, |p| p, &mut out);
        assert!(out.contains(&dense[1]), "{out:?}");
    }

    /// A straight cut with, in its middle, a cluster of 20 steps of 25-100 nm in
    /// quantised directions (camotics_vcarve's 1e-6 inch moves), written to 1e-5 inch.
    fn vcarve_like_cluster() -> Vec<Vec3> {
        let inch = 25.4;
        let mut dense: Vec<Vec3> = (0..=10)
            .map(|k| Vec3::new(0.2837, 0.1070 + k as f64 * 1.2e-4, -0.016) * inch)
            .collect();
        let steps = [
            (0, 1),
            (1, 1),
            (0, 1),
            (0, 1),
            (1, 2),
            (0, 1),
            (1, 2),
            (0, 2),
            (1, 3),
        ];
        let mut p = *dense.last().unwrap();
        for k in 0..20 {
            let (dx, dy) = steps[k % steps.len()];
            p += Vec3::new(dx as f64, dy as f64, 0.0) * (1e-6 * inch);
            dense.push(p);
        }
        let end = Vec3::new(0.2851, 0.1165, -0.0162) * inch;
        dense.extend((1..=10).map(|k| p + (end - p) * (k as f64 / 10.0)));
        dense
    }

    #[test]
    fn a_cluster_of_nanometre_steps_is_not_a_corner() {
        let dense = vcarve_like_cluster();
        let (tol, unit) = (7.5e-4, 2.54e-4);
        let round = |p: Vec3| {
            let r = |x: f64| (x / unit).round() * unit;
            Vec3::new(r(p.x), r(p.y), r(p.z))
        };
        let hard = sharp_points(&dense, tol);
        assert_eq!(hard.iter().filter(|&&h| h).count(), 2, "{hard:?}");
        let mut out = Vec::new();
        simplify(&dense, &hard, tol, 0.0, round, &mut out);
        let mut written = vec![round(dense[0])];
        written.extend_from_slice(&out);
        let shortest = written
            .windows(2)
            .map(|w| w[0].dist(w[1]))
            .fold(f64::INFINITY, f64::min);
        // Before: every step of the cluster was written, 0.000254 mm blocks turning 90
        // degrees.
        assert!(written.len() <= 4 && shortest > 0.01, "{written:?}");
        assert!(one_sided(&dense, &written) <= tol + unit);
        assert!(one_sided(&written, &dense) <= tol + unit);
        // The turn between neighbours still counts when asked for.
        assert!(sharp_points(&dense, 0.0).iter().filter(|&&h| h).count() > 3);
    }

    /// The shorter block at each junction of `written`, the least of them.
    #[test]
    fn a_short_tail_is_merged() {
        // A straight run whose last piece is 1 um: merged into the block before.
        let dense = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.000_001, 0.0, 0.0),
        ];
        let hard = vec![true, false, true];
        let mut out = Vec::new();
        simplify(&dense, &hard, 1e-3, 0.05, |p| p, &mut out);
        assert_eq!(out, vec![dense[2]]);
    }

    #[test]
    fn a_flattened_circle_becomes_arcs() {
        // 360 lines of a radius-10 circle (chords 0.17 mm) within 1e-3 mm: a few arcs.
        let dense = arc_points(10.0, 6.0, 360);
        let hard = sharp_points(&dense, 1e-3);
        let mut out = Vec::new();
        fit_arcs(&dense, &hard, 1e-3, ArcChords::Exact, |p| p, &mut out);
        let arcs = out
            .iter()
            .filter(|p| matches!(p, Piece::Arc { .. }))
            .count();
        assert!(out.len() <= 3 && arcs >= 1, "{out:?}");
        match out.last().unwrap() {
            Piece::Arc {
                end, center, ccw, ..
            } => {
                assert_eq!(*end, *dense.last().unwrap());
                assert!(center.norm() < 1e-6 && *ccw, "{center:?}");
            }
            Piece::Line { end, .. } => assert_eq!(*end, *dense.last().unwrap()),
        }
        // A straight run stays a line.
        let line: Vec<Vec3> = (0..50)
            .map(|k| Vec3::new(k as f64 * 0.1, 0.0, 0.0))
            .collect();
        let mut out = Vec::new();
        fit_arcs(
            &line,
            &sharp_points(&line, 1e-3),
            1e-3,
            ArcChords::Exact,
            |p| p,
            &mut out,
        );
        assert_eq!(
            out,
            vec![Piece::Line {
                to: 49,
                end: line[49]
            }]
        );
    }

    proptest! {
        /// Two-sided: the written polyline (rounded to a grid) is within the tolerance of
        /// the dense one, both ways, and the end point is the last dense point, rounded.
        #[test]
        fn written_within_tolerance_both_ways(
            r in 0.2f64..50.0,
            sweep in 0.1f64..6.0,
            n in 8usize..400,
            tol in 1e-4f64..0.05,
            wiggle in 0.0f64..1.0,
            decimals in 3i32..7,
        ) {
            let unit = 10f64.powi(-decimals);
            prop_assume!(unit < tol / 4.0);
            let mut dense = arc_points(r, sweep, n);
            for (k, p) in dense.iter_mut().enumerate() {
                p.z = wiggle * tol * 0.2 * ((k as f64) * 0.7).sin();
            }
            let round = |p: Vec3| {
                Vec3::new((p.x / unit).round() * unit, (p.y / unit).round() * unit,
                    (p.z / unit).round() * unit)
            };
            let hard = sharp_points(&dense, tol);
            let mut out = Vec::new();
            simplify(&dense, &hard, tol, 0.1, round, &mut out);
            prop_assert_eq!(*out.last().unwrap(), round(*dense.last().unwrap()));
            let mut written = vec![round(dense[0])];
            written.extend_from_slice(&out);
            prop_assert!(one_sided(&dense, &written) <= tol * (1.0 + 1e-9));
            prop_assert!(one_sided(&written, &dense) <= tol * (1.0 + 1e-9));
        }

        /// Arcs: every dense point within the tolerance of the written pieces (arcs
        /// sampled finely), and every written point within it of the dense polyline.
        #[test]
        fn arcs_within_tolerance_both_ways(
            r in 0.5f64..50.0,
            sweep in 0.2f64..6.0,
            n in 8usize..300,
            tol in 1e-4f64..0.05,
            wiggle in 0.0f64..1.0,
            lift in prop_oneof![Just(0.0), -1.0f64..1.0],
            firmware in 0usize..4,
        ) {
            let mut dense = arc_points(r, sweep, n);
            for (k, p) in dense.iter_mut().enumerate() {
                p.x += wiggle * tol * 0.3 * ((k as f64) * 1.3).sin();
                p.z = lift * k as f64 / n as f64;
            }
            let chords = FIRMWARES[firmware];
            let hard = sharp_points(&dense, tol);
            let mut out = Vec::new();
            fit_arcs(&dense, &hard, tol, chords, |p| p, &mut out);
            // The path the controller runs: lines, and arcs as its chords.
            let mut run = vec![dense[0]];
            for piece in &out {
                match *piece {
                    Piece::Line { end, .. } => run.push(end),
                    Piece::Arc { end, center, ccw, .. } => {
                        let start = *run.last().unwrap();
                        run.extend(executed_arc(start, end, center, ccw, chords));
                    }
                }
            }
            prop_assert!(run.last().unwrap().dist(*dense.last().unwrap()) <= 1e-9);
            let worst = one_sided(&dense, &run);
            prop_assert!(worst <= tol * (1.0 + 1e-9), "dense to run {}", worst);
            let worst = one_sided(&run, &dense);
            prop_assert!(worst <= tol * (1.0 + 1e-9), "run to dense {}", worst);
        }
    }
}
