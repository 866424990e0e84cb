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
//! 1. the chain is flattened finely (within [`DENSE_SHARE`] of the chord tolerance), every
//!    move end being a dense point;
//! 2. from the last written point `a`, the block is extended to dense point `j` while every
//!    dense point between them lies within `chord - dense` of the segment from `a` to the
//!    *rounded* `j` (the point as it will be printed), with projections in order along it
//!    (a step back shorter than the tolerance is a wiggle, not a reversal);
//! 3. points where the dense polyline turns by more than [`BREAK_TURN_DEG`] (a sharp
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

use ncsmooth::geom::Vec3;

/// Accuracy of the dense flattening, as a share of the chord tolerance; the rest of the
/// chord is what merging may use.
pub const DENSE_SHARE: f64 = 0.25;

/// A dense point where the polyline turns by more than this (degrees) is always written.
pub const BREAK_TURN_DEG: f64 = 20.0;

/// Most dense points one written block may span (bounds the quadratic cost of the
/// greedy test on long straight runs).
pub const MAX_SPAN_POINTS: usize = 512;

/// Distance from `p` to the segment `a`-`b`, and the parameter of its foot (unclamped).
pub(crate) fn seg_dist(p: Vec3, a: Vec3, b: Vec3) -> (f64, f64) {
    let d = b - a;
    let l2 = d.norm_sq();
    if l2 <= 0.0 {
        return (p.dist(a), 0.0);
    }
    let t = (p - a).dot(d) / l2;
    (p.dist(a + d * t.clamp(0.0, 1.0)), t)
}

/// Whether the dense points strictly between `from` and `to` lie within `tol` of the
/// segment `a`-`b`, with projections in order and inside it. "In order" allows a step
/// back of up to `tol` behind the farthest projection so far: a cluster of
/// nanometre steps in arbitrary directions (a CAM file's own quantisation, e.g.
/// camotics_vcarve's 1e-6 inch moves) is a wiggle within the tolerance, not a reversal,
/// and the coverage argument of the module doc holds for any order (each written point
/// lies between the projections of two consecutive dense points). A reversal longer
/// than `tol` (a peck's retract) still ends the block.
fn fits(dense: &[Vec3], from: usize, to: usize, a: Vec3, b: Vec3, tol: f64) -> bool {
    let len = a.dist(b);
    let back = if len > 0.0 { tol / len } else { 0.0 };
    let mut far_t: f64 = 0.0;
    for &p in &dense[from + 1..to] {
        let (d, t) = seg_dist(p, a, b);
        if d > tol || t < far_t - back || t > 1.0 + back {
            return false;
        }
        far_t = far_t.max(t);
    }
    true
}

/// Sharp turns of the dense polyline: `hard[k]` when the polyline turns at `k` by more
/// than [`BREAK_TURN_DEG`]. The turn is measured between the chords to the nearest dense
/// points at least `span_mm` away on either side (at most [`MAX_SPAN_POINTS`] points
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
pub const MIN_ARC_SPAN: usize = 3;

/// Largest radius (mm) fitted as an arc; flatter runs are lines.
pub const MAX_ARC_RADIUS_MM: f64 = 1e4;

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

/// Whether the arc from `pa` to `pe` about `c` (XY, Z linear in angle) passes within `tol`
/// of the dense points strictly between `from` and `to`, in order.
#[allow(clippy::too_many_arguments)]
fn arc_fits(
    dense: &[Vec3],
    from: usize,
    to: usize,
    pa: Vec3,
    pe: Vec3,
    c: Vec3,
    ccw: bool,
    tol: f64,
) -> bool {
    let r = (pa.x - c.x).hypot(pa.y - c.y);
    if (pe.x - c.x).hypot(pe.y - c.y) - r > tol * 0.25
        || r - (pe.x - c.x).hypot(pe.y - c.y) > tol * 0.25
    {
        return false;
    }
    let u0 = (pa.y - c.y).atan2(pa.x - c.x);
    let total = swept(c, u0, pe, ccw);
    if total <= 0.0 {
        return false;
    }
    // Between two dense points the arc bulges from their chord by at most its sagitta
    // over the angle between them: the dense polyline is the path to stay near (with
    // `--method none` it is the program itself).
    let sagitta = |dth: f64| r * (1.0 - (0.5 * dth).cos());
    let (mut last, mut last_err) = (0.0, pa.dist(dense[from]));
    for &p in &dense[from + 1..to] {
        let th = swept(c, u0, p, ccw);
        if th < last || th > total {
            return false;
        }
        let z = pa.z + (pe.z - pa.z) * th / total;
        let dr = (p.x - c.x).hypot(p.y - c.y) - r;
        let err = dr.hypot(p.z - z);
        if err > tol || err.max(last_err) + sagitta(th - last) > tol {
            return false;
        }
        (last, last_err) = (th, err);
    }
    last_err.max(pe.dist(dense[to])) + sagitta(total - last) <= tol
}

/// The longest arc from the written point `pa` (dense index `a`) within `tol_mm`: its end
/// index, centre and sense, if one spans at least [`MIN_ARC_SPAN`] dense steps.
fn longest_arc(
    dense: &[Vec3],
    hard: &[bool],
    a: usize,
    pa: Vec3,
    tol_mm: f64,
    round: &impl Fn(Vec3) -> Vec3,
) -> Option<(usize, Vec3, bool)> {
    let n = dense.len();
    let mut best = None;
    // The last index that fitted (the first candidate before any did).
    let mut last_fit = a + MIN_ARC_SPAN;
    let mut j = a + MIN_ARC_SPAN;
    while j < n && j - a <= MAX_SPAN_POINTS && !hard[j - 1] && !hard[j - 2] {
        let pe = round(dense[j]);
        let mid = dense[(a + j) / 2];
        let fit = circle_xy(pa, mid, pe).and_then(|c| {
            let c = Vec3::new(c.x, c.y, pa.z);
            let r = (pa.x - c.x).hypot(pa.y - c.y);
            let turn = (mid.x - pa.x) * (pe.y - mid.y) - (mid.y - pa.y) * (pe.x - mid.x);
            let ccw = turn > 0.0;
            (r <= MAX_ARC_RADIUS_MM && arc_fits(dense, a, j, pa, pe, c, ccw, tol_mm))
                .then_some((j, c, ccw))
        });
        if let Some(f) = fit {
            best = Some(f);
            last_fit = j;
        } else if j - last_fit > SEARCH_PAST_FIT {
            break;
        }
        j += 1;
    }
    best
}

/// Like [`simplify`], with arcs: from each written point the piece that reaches farther,
/// the longest line or the longest XY arc (helical when Z changes), both within `tol_mm`
/// of every dense point they span, end points rounded. ArcWelder's idea (arcs through
/// runs of G1 points within a resolution) with the two-sided check of this module.
pub fn fit_arcs(
    dense: &[Vec3],
    hard: &[bool],
    tol_mm: f64,
    round: impl Fn(Vec3) -> Vec3,
    out: &mut Vec<Piece>,
) {
    let n = dense.len();
    let mut a = 0usize;
    let mut pa = round(dense.first().copied().unwrap_or_default());
    while a + 1 < n {
        let jl = longest_line(dense, hard, a, pa, tol_mm, &round);
        match longest_arc(dense, hard, a, pa, tol_mm, &round) {
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

/// Passes of [`even_out`] over a chain's written points.
pub const EVEN_OUT_SWEEPS: usize = 3;

/// Places [`even_out`] tries for a written point: this many steps of equal arc length
/// along the dense polyline between its neighbours.
pub const EVEN_OUT_STEPS: usize = 16;

/// A written point's place on the dense polyline: on the chord from `dense[i]` to
/// `dense[i + 1]` at the fraction `f` in `[0, 1)` of it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct At {
    i: usize,
    f: f64,
}

impl At {
    fn point(self, dense: &[Vec3]) -> Vec3 {
        if self.f > 0.0 {
            dense[self.i].lerp(dense[self.i + 1], self.f)
        } else {
            dense[self.i]
        }
    }

    /// The dense index that ends a block ending here, for the fit test: the dense points
    /// strictly before it and after the block's start are the ones the block covers.
    fn end(self) -> usize {
        if self.f > 0.0 {
            self.i + 1
        } else {
            self.i
        }
    }

    /// How far inside the curve this place may lie when the dense polyline is within
    /// `dense_acc` of it: a chord's sagitta profile, `4 f (1 - f)` of at most `dense_acc`.
    fn sag_mm(self, dense_acc: f64) -> f64 {
        4.0 * self.f * (1.0 - self.f) * dense_acc
    }
}

/// What [`even_out`] optimises for, and how far from the curve it may move a point.
pub struct EvenOut<S, R> {
    /// `score(a, b, c)` rates the junction at `b` between blocks `a`-`b` and `b`-`c`
    /// (e.g. the radius the controller's blend gets there; NaN where there is none).
    pub score: S,
    /// `room(a, b, c)` (mm): how far inside the curve the junction at `b` may lie (e.g.
    /// what the controller's blend there leaves of its bound; infinite where anything
    /// goes).
    pub room: R,
    /// Accuracy of the dense flattening (mm): a place between dense points lies up to
    /// this far inside the curve (0 where the dense points are the program's own lines).
    pub dense_acc_mm: f64,
}

/// Moves the written points [`simplify`] chose along the dense polyline so that the
/// smallest of `how.score` over the junctions each one touches grows, keeping every
/// block within `tol_mm` (the fit test of [`simplify`], rounding included): for a
/// controller that blends its junctions by the length of the blocks (LinuxCNC takes at
/// most half of each line for a blend arc), the greedy cut's long block beside a short
/// one leaves a tight blend where an even cut gives the curve's own radius.
///
/// `idx` is what [`simplify`] returned for `pts`, the written points after `start`.
/// Hard points and the ends stay, no block is made shorter than `min_block_mm` unless it
/// already was, and a point moved between dense points lies inside the curve by no more
/// than `how.room` allows there. Each point is tried at [`EVEN_OUT_STEPS`] places of
/// equal arc length between its neighbours, in [`EVEN_OUT_SWEEPS`] passes.
#[allow(clippy::too_many_arguments)]
pub fn even_out<S, R>(
    dense: &[Vec3],
    hard: &[bool],
    idx: &[usize],
    tol_mm: f64,
    min_block_mm: f64,
    round: impl Fn(Vec3) -> Vec3,
    how: &EvenOut<S, R>,
    start: Vec3,
    pts: &mut [Vec3],
) where
    S: Fn(Vec3, Vec3, Vec3) -> f64,
    R: Fn(Vec3, Vec3, Vec3) -> f64,
{
    let m = pts.len() + 1;
    if idx.len() != m || m < 3 {
        return;
    }
    let mut at: Vec<At> = idx.iter().map(|&i| At { i, f: 0.0 }).collect();
    let written = |pts: &[Vec3], k: usize| if k == 0 { start } else { pts[k - 1] };
    // The worst junction written point `k` touches when it is at `q`.
    let rate = |pts: &[Vec3], k: usize, q: Vec3| -> f64 {
        let w = |j: usize| if j == k { q } else { written(pts, j) };
        (k.saturating_sub(1).max(1)..=(k + 1).min(m - 2))
            .map(|j| (how.score)(w(j - 1), w(j), w(j + 1)))
            .filter(|r| !r.is_nan())
            .fold(f64::INFINITY, f64::min)
    };
    for _ in 0..EVEN_OUT_SWEEPS {
        for k in 1..m - 1 {
            if at[k].f == 0.0 && hard[at[k].i] {
                continue;
            }
            let (a, b) = (at[k - 1], at[k + 1]);
            let (pa, pb, pk) = (written(pts, k - 1), written(pts, k + 1), pts[k - 1]);
            let shortest = min_block_mm.min(pk.dist(pa)).min(pk.dist(pb));
            let mut best = (rate(pts, k, pk), at[k], pk);
            for c in places(dense, a, b) {
                let q = round(c.point(dense));
                if q.dist(pa).min(q.dist(pb)) < shortest || q == pa || q == pb {
                    continue;
                }
                let r = rate(pts, k, q);
                if r > best.0
                    && c.sag_mm(how.dense_acc_mm) <= (how.room)(pa, q, pb)
                    && fits(dense, a.i, c.end(), pa, q, tol_mm)
                    && fits(dense, c.i, b.end(), q, pb, tol_mm)
                {
                    best = (r, c, q);
                }
            }
            at[k] = best.1;
            pts[k - 1] = best.2;
        }
    }
}

/// [`EVEN_OUT_STEPS`]` - 1` places of equal arc length strictly between `a` and `b` on
/// the dense polyline.
fn places(dense: &[Vec3], a: At, b: At) -> Vec<At> {
    // The polyline from `a` to `b`: its vertices as places, and arc length at each.
    let mut verts = vec![(a, 0.0)];
    let mut prev = a.point(dense);
    for j in a.i + 1..=b.end() {
        let v = if j > b.i { b } else { At { i: j, f: 0.0 } };
        let p = v.point(dense);
        let s = verts[verts.len() - 1].1 + p.dist(prev);
        verts.push((v, s));
        prev = p;
    }
    let total = verts[verts.len() - 1].1;
    let mut out = Vec::with_capacity(EVEN_OUT_STEPS);
    let mut seg = 1;
    for step in 1..EVEN_OUT_STEPS {
        let target = total * step as f64 / EVEN_OUT_STEPS as f64;
        while seg + 1 < verts.len() && verts[seg].1 < target {
            seg += 1;
        }
        let ((v0, s0), (v1, s1)) = (verts[seg - 1], verts[seg]);
        let t = if s1 > s0 {
            (target - s0) / (s1 - s0)
        } else {
            0.0
        };
        // On the chord from v0 (a dense point, or `a`) to v1: chord `v0.i`.
        let (f0, f1) = (v0.f, if v1.i > v0.i { 1.0 } else { v1.f });
        let f = f0 + t.clamp(0.0, 1.0) * (f1 - f0);
        let c = if f >= 1.0 {
            At {
                i: v0.i + 1,
                f: 0.0,
            }
        } else {
            At { i: v0.i, f }
        };
        if c != a && c != b && out.last() != Some(&c) {
            out.push(c);
        }
    }
    out
}

/// Index of the programmed-corner replacement among [`lift_short_blocks`]' tries.
const SNAP_TRY: usize = 3;

/// Samples per tolerance along a segment in [`lift_short_blocks`]' check: the distance to
/// the program is 1-Lipschitz along the segment, so samples `tol / SAMPLES_PER_TOL` apart
/// bound it between them within half that step, which the check deducts.
const SAMPLES_PER_TOL: f64 = 16.0;

/// The programmed path a written stretch is checked against in [`lift_short_blocks`]: a
/// polyline (curves flattened, with their flattening accuracy deducted from `tol_mm`) and
/// the two-sided tolerance left for the written blocks.
#[derive(Clone, Copy, Debug)]
pub struct Program<'a> {
    /// The programmed path as a polyline (mm).
    pub points: &'a [Vec3],
    /// Largest distance (mm), both ways, between the written blocks and `points`.
    pub tol_mm: f64,
}

impl Program<'_> {
    /// Distance from `p` to the programmed segments `segs` (indices of their starts).
    fn dist(&self, p: Vec3, segs: &[usize]) -> f64 {
        segs.iter()
            .map(|&k| seg_dist(p, self.points[k], self.points[k + 1]).0)
            .fold(f64::INFINITY, f64::min)
    }

    /// Starts of the programmed segments whose box comes within `margin` of the box of
    /// `a`-`b` (the grid's candidates, or all segments when it has none to give).
    fn near(&self, grid: &SegGrid, a: Vec3, b: Vec3, margin: f64, out: &mut Vec<usize>) {
        let pad = Vec3::new(margin, margin, margin);
        let (lo, hi) = (a.min(b) - pad, a.max(b) + pad);
        if !grid.candidates(lo, hi, out) {
            out.clear();
            out.extend(0..self.points.len().saturating_sub(1));
        }
        let pts = self.points;
        out.retain(|&k| {
            let (plo, phi) = (pts[k].min(pts[k + 1]), pts[k].max(pts[k + 1]));
            plo.min(hi) == plo && phi.max(lo) == phi
        });
    }

    /// Whether every point of the segment `a`-`b` lies within the tolerance of the
    /// programmed path.
    fn covers(&self, grid: &SegGrid, a: Vec3, b: Vec3, scratch: &mut Vec<usize>) -> bool {
        let step = self.tol_mm / SAMPLES_PER_TOL;
        let within = self.tol_mm - 0.5 * step;
        self.near(grid, a, b, self.tol_mm, scratch);
        let n = (a.dist(b) / step).ceil().max(1.0) as usize;
        (0..=n).all(|i| self.dist(a + (b - a) * (i as f64 / n as f64), scratch) <= within)
    }

    /// The programmed vertices inside the box `lo`-`hi`, appended to `out`.
    fn vertices_in(&self, grid: &SegGrid, lo: Vec3, hi: Vec3, out: &mut Vec<Vec3>) {
        let inside = |v: &Vec3| v.min(lo) == lo && v.max(hi) == hi;
        match self.vertex_candidates(grid, lo, hi) {
            Some(ks) => out.extend(ks.into_iter().map(|k| self.points[k]).filter(inside)),
            None => out.extend(self.points.iter().copied().filter(inside)),
        }
    }

    /// Indices of the programmed vertices that may lie in the box `lo`-`hi` (the ends of
    /// the grid's candidate segments), sorted and unique; `None` when the grid has none
    /// to give and every vertex is a candidate.
    fn vertex_candidates(&self, grid: &SegGrid, lo: Vec3, hi: Vec3) -> Option<Vec<usize>> {
        let mut segs = Vec::new();
        if self.points.len() < 2 || !grid.candidates(lo, hi, &mut segs) {
            return None;
        }
        let mut ks: Vec<usize> = segs.iter().flat_map(|&k| [k, k + 1]).collect();
        ks.sort_unstable();
        ks.dedup();
        Some(ks)
    }

    /// The programmed vertex nearest to `p`: the grid's candidates in boxes of growing
    /// size, until the nearest one found lies within the box's half-width (any nearer
    /// vertex would be in the box).
    fn nearest_vertex(&self, grid: &SegGrid, p: Vec3) -> Option<Vec3> {
        let by_dist = |a: &Vec3, b: &Vec3| a.dist(p).total_cmp(&b.dist(p));
        let mut r = grid.cell;
        loop {
            let pad = Vec3::new(r, r, r);
            let Some(ks) = self.vertex_candidates(grid, p - pad, p + pad) else {
                return self.points.iter().copied().min_by(by_dist);
            };
            let near = ks.into_iter().map(|k| self.points[k]).min_by(by_dist);
            if let Some(v) = near.filter(|v| v.dist(p) <= r) {
                return Some(v);
            }
            r *= 2.0;
        }
    }
}

/// Largest number of grid cells a programmed segment is entered in; a longer one is a
/// candidate of every query ([`SegGrid`]).
const GRID_SEGMENT_CELLS: i64 = 64;

/// Largest number of grid cells a query looks at; a larger box scans every segment.
const GRID_QUERY_CELLS: i64 = 4096;

/// Uniform grid over a program's segments for [`lift_short_blocks`]: its queries (the
/// segments near a written block, the vertices near a replacement, the vertex nearest a
/// block) were linear scans of the run's programmed polyline, and a stepper dialect on
/// linuxcnc_stellabee1 (one run of most of its 169 k lines) took over ten minutes.
/// Queries return a superset of the segments whose boxes meet the query box; the callers
/// apply the exact tests.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct SegGrid {
    /// Cell size (mm): four tolerances or the mean segment length, the larger.
    cell: f64,
    cells: std::collections::HashMap<[i64; 3], Vec<usize>>,
    /// Segments spanning more than [`GRID_SEGMENT_CELLS`] cells.
    wide: Vec<usize>,
}

impl SegGrid {
    fn new(points: &[Vec3], tol_mm: f64) -> SegGrid {
        let n = points.len().saturating_sub(1);
        let total: f64 = points.windows(2).map(|w| w[0].dist(w[1])).sum();
        let mean = if n > 0 { total / n as f64 } else { 0.0 };
        let cell = (4.0 * tol_mm).max(mean).max(1e-6);
        let mut grid = SegGrid {
            cell,
            cells: std::collections::HashMap::new(),
            wide: Vec::new(),
        };
        for (k, w) in points.windows(2).enumerate() {
            let (a, b) = (grid.key(w[0].min(w[1])), grid.key(w[0].max(w[1])));
            if Self::count(a, b) > GRID_SEGMENT_CELLS {
                grid.wide.push(k);
                continue;
            }
            for x in a[0]..=b[0] {
                for y in a[1]..=b[1] {
                    for z in a[2]..=b[2] {
                        grid.cells.entry([x, y, z]).or_default().push(k);
                    }
                }
            }
        }
        grid
    }

    fn key(&self, p: Vec3) -> [i64; 3] {
        let k = |v: f64| (v / self.cell).floor() as i64;
        [k(p.x), k(p.y), k(p.z)]
    }

    /// Cells of the box between the keys `a` and `b` (saturating).
    fn count(a: [i64; 3], b: [i64; 3]) -> i64 {
        (0..3)
            .map(|i| b[i].saturating_sub(a[i]).saturating_add(1).max(0))
            .fold(1i64, |acc, c| acc.saturating_mul(c))
    }

    /// Candidate segments for the box `lo`-`hi`, sorted and unique, in `out`; `false` when
    /// the box spans more than [`GRID_QUERY_CELLS`] cells (or is not finite) and the
    /// caller must scan every segment.
    fn candidates(&self, lo: Vec3, hi: Vec3, out: &mut Vec<usize>) -> bool {
        out.clear();
        if !(lo.is_finite() && hi.is_finite()) {
            return false;
        }
        let (a, b) = (self.key(lo), self.key(hi));
        if Self::count(a, b) > GRID_QUERY_CELLS {
            return false;
        }
        for x in a[0]..=b[0] {
            for y in a[1]..=b[1] {
                for z in a[2]..=b[2] {
                    if let Some(v) = self.cells.get(&[x, y, z]) {
                        out.extend_from_slice(v);
                    }
                }
            }
        }
        out.extend_from_slice(&self.wide);
        out.sort_unstable();
        out.dedup();
        true
    }
}

/// Distance from `p` to the polyline `pl`.
fn polyline_dist(p: Vec3, pl: &[Vec3]) -> f64 {
    pl.windows(2)
        .map(|w| seg_dist(p, w[0], w[1]).0)
        .fold(f64::INFINITY, f64::min)
}

/// A stretched block's length, as a share of the floor (its rounding must not take it
/// below).
const STRETCH_MARGIN: f64 = 1.05;

/// Written neighbours on each side of a replaced stretch that the programmed vertices
/// near it are measured against (besides the new blocks).
const CHECK_NEIGHBOURS: usize = 2;

/// Whether replacing the written points strictly between `poly[lo]` and `poly[hi]` by
/// `new` keeps the stretch within the program's tolerance both ways: every point of the
/// new blocks near the programmed path, and every programmed vertex the old stretch
/// covered near the new one.
fn replacement_fits(
    poly: &[Vec3],
    lo: usize,
    hi: usize,
    new: Option<Vec3>,
    program: &Program,
    grid: &SegGrid,
    scratch: &mut Vec<usize>,
) -> bool {
    let first = lo.saturating_sub(CHECK_NEIGHBOURS);
    let last = (hi + CHECK_NEIGHBOURS).min(poly.len() - 1);
    let mut local: Vec<Vec3> = poly[first..=lo].to_vec();
    local.extend(new);
    local.extend_from_slice(&poly[hi..=last]);
    let new_from = lo - first;
    let new_to = new_from + 1 + usize::from(new.is_some());
    if !(new_from..new_to).all(|k| program.covers(grid, local[k], local[k + 1], scratch)) {
        return false;
    }
    // The programmed vertices near the replaced blocks: each must stay within the
    // tolerance of the new local stretch, unless the old one did not cover it either (its
    // nearest written point is elsewhere, where nothing changes).
    let tol = program.tol_mm;
    let old = &poly[first..=last];
    let (mut lo_box, mut hi_box) = (poly[lo], poly[lo]);
    for &p in &poly[lo..=hi] {
        lo_box = lo_box.min(p);
        hi_box = hi_box.max(p);
    }
    let pad = Vec3::new(tol, tol, tol);
    let mut near = Vec::new();
    program.vertices_in(grid, lo_box - pad, hi_box + pad, &mut near);
    near.into_iter()
        .all(|v| polyline_dist(v, &local) <= tol || polyline_dist(v, old) > tol)
}

/// Removes written blocks shorter than `min_block_mm` (a stepper controller's few steps:
/// a block of one or two steps turns in whatever direction its rounding gives) where the
/// written path, checked against the programmed path itself rather than the smoothed
/// curve, stays within `program.tol_mm` both ways. Each short block from `start` through
/// `pts` (whose last point stays) is tried, in order, as: its two ends replaced by their
/// midpoint, its end dropped, its start dropped, its two ends replaced by the nearest
/// programmed vertex (a corner transition too small for the controller becomes the
/// programmed corner, which the controller takes at its own junction speed), or, where one
/// end must stay (the ends of a run), the other moved along the block to the floor's
/// length. (Moving it to the programmed corner instead takes the last steps off a run
/// but puts a sharp junction there: cncjs_jsdc on grbl ran 0.25 % slower.) A block no replacement fits
/// stays. `round` maps a point to where it will be printed. Returns the blocks left
/// shorter than `min_block_mm`.
pub fn lift_short_blocks(
    start: Vec3,
    pts: &mut Vec<Vec3>,
    min_block_mm: f64,
    program: &Program,
    round: impl Fn(Vec3) -> Vec3,
) -> usize {
    let grid = std::cell::OnceCell::new();
    let mut how = Lift::default();
    lift_short_blocks_in(start, pts, min_block_mm, program, &grid, round, &mut how)
}

/// Which replacements [`lift_short_blocks`] tries, and what it reports back.
#[derive(Debug, Default)]
pub(crate) struct Lift {
    /// Only the programmed corner, and not at the chain's last block unless
    /// [`Lift::last_block`] (LinuxCNC: a block shorter than four `P` caps its blends at a
    /// quarter of its length, the programmed corner is blended within a `P` of its own).
    pub corners_only: bool,
    /// With [`Lift::corners_only`], the chain's last block too: a rapid follows it, and
    /// LinuxCNC stops before the rapid at the full acceleration. (At the program's end the
    /// last segment keeps a parabolic blend's half acceleration: crown's last 40 mm line,
    /// made to end at the programmed corner, ran 7.520 s against 7.443 for all of crown.)
    /// camotics_vcarve's V strokes, plunging and rising again before a rapid, kept a
    /// block of 0.005-0.01 mm at the bottom, which capped LinuxCNC's blend there at half
    /// its length.
    pub last_block: bool,
    /// The programmed vertices put in place of short blocks.
    pub snapped: Vec<Vec3>,
}

impl Program<'_> {
    /// The grid over the programmed segments, for [`Program::max_dist_near`] and
    /// [`Program::vertex_gap`].
    pub(crate) fn grid(&self) -> SegGrid {
        SegGrid::new(self.points, self.tol_mm)
    }

    /// The largest distance from a programmed vertex within `within` of the segments
    /// `lines` to the nearest of them, over the vertices no nearer to any of `others`
    /// (0 where there is none).
    pub(crate) fn vertex_gap(
        &self,
        grid: &SegGrid,
        lines: &[(Vec3, Vec3)],
        others: &[(Vec3, Vec3)],
        within: f64,
    ) -> f64 {
        let Some(&(first, _)) = lines.first() else {
            return 0.0;
        };
        let (lo, hi) = lines.iter().fold((first, first), |(lo, hi), &(a, b)| {
            (lo.min(a).min(b), hi.max(a).max(b))
        });
        let pad = Vec3::new(within, within, within);
        let nearest = |q: Vec3, segs: &[(Vec3, Vec3)]| {
            segs.iter()
                .map(|&(a, b)| seg_dist(q, a, b).0)
                .fold(f64::INFINITY, f64::min)
        };
        let mut near = Vec::new();
        self.vertices_in(grid, lo - pad, hi + pad, &mut near);
        near.into_iter()
            .map(|q| (nearest(q, lines), nearest(q, others)))
            .filter(|&(e, other)| e < within && e <= other)
            .fold(0.0, |m, (e, _)| m.max(e))
    }

    /// An upper bound on the distance from the segment `a`-`b` to the programmed path:
    /// the largest at `samples + 1` evenly spaced points plus half their spacing (the
    /// distance is 1-Lipschitz); infinite where a point has no programmed segment within
    /// the tolerance.
    pub(crate) fn max_dist_near(&self, grid: &SegGrid, a: Vec3, b: Vec3, samples: usize) -> f64 {
        let mut segs = Vec::new();
        self.near(grid, a, b, self.tol_mm, &mut segs);
        let n = samples.max(1);
        let worst = (0..=n)
            .map(|i| self.dist(a + (b - a) * (i as f64 / n as f64), &segs))
            .fold(0.0, f64::max);
        worst + 0.5 * a.dist(b) / n as f64
    }
}

/// [`lift_short_blocks`] with the program's grid built on the first short block and kept
/// in `grid` for the next call on the same program (a run's chains share it), and the
/// replacements `how` says (for LinuxCNC, [`Lift::corners_only`]: only the programmed
/// corner), the programmed corners put in recorded there.
pub(crate) fn lift_short_blocks_in(
    start: Vec3,
    pts: &mut Vec<Vec3>,
    min_block_mm: f64,
    program: &Program,
    grid: &std::cell::OnceCell<SegGrid>,
    round: impl Fn(Vec3) -> Vec3,
    how: &mut Lift,
) -> usize {
    let mut poly = Vec::with_capacity(pts.len() + 1);
    poly.push(start);
    poly.append(pts);
    let mut scratch = Vec::new();
    // Point-for-point replacements (stretches) left: each makes a block longer, and their
    // number is bounded so the loop ends whatever the geometry.
    let mut swaps_left = poly.len();
    let mut i = 1;
    while i < poly.len() {
        if poly[i - 1].dist(poly[i]) >= min_block_mm {
            i += 1;
            continue;
        }
        let n = poly.len();
        let grid = grid.get_or_init(|| SegGrid::new(program.points, program.tol_mm));
        let mid = (poly[i - 1] + poly[i]) * 0.5;
        let snap = program.nearest_vertex(grid, mid).map(&round);
        // The block from `fixed` through `free`, lengthened to the floor.
        let stretch = |fixed: usize, free: usize| {
            let d = poly[free] - poly[fixed];
            let len = d.norm();
            (len > 0.0).then(|| round(poly[fixed] + d * (STRETCH_MARGIN * min_block_mm / len)))
        };
        // (lo, hi, new point): the points strictly between lo and hi are replaced.
        let inner = i >= 2 && i + 1 < n;
        // Lazily: `i - 2` exists only when `i >= 2`.
        let tries = [
            inner.then(|| (i - 2, i + 1, Some(round(mid)))),
            (i + 1 < n).then(|| (i - 1, i + 1, None)),
            (i >= 2).then(|| (i - 2, i, None)),
            (inner && (!how.corners_only || how.last_block || i + 2 < n))
                .then(|| (i - 2, i + 1, snap)),
            (i + 1 < n && swaps_left > 0).then(|| (i - 1, i + 1, stretch(i - 1, i))),
            (i >= 2 && swaps_left > 0).then(|| (i - 2, i, stretch(i, i - 1))),
        ];
        let fit = tries
            .into_iter()
            .enumerate()
            .filter(|&(k, _)| !how.corners_only || k == SNAP_TRY)
            .filter_map(|(k, t)| t.map(|t| (k, t)))
            .find(|&(_, (lo, hi, new))| {
                replacement_fits(&poly, lo, hi, new, program, grid, &mut scratch)
            });
        match fit {
            Some((k, (lo, hi, new))) => {
                if hi - lo == 2 && new.is_some() {
                    swaps_left -= 1;
                }
                if let (SNAP_TRY, Some(v)) = (k, new) {
                    if !how.snapped.contains(&v) {
                        how.snapped.push(v);
                    }
                }
                poly.splice(lo + 1..hi, new);
                // The blocks around the change are looked at again.
                i = lo.max(1);
            }
            None => i += 1,
        }
    }
    pts.extend_from_slice(&poly[1..]);
    poly.windows(2)
        .filter(|w| w[0].dist(w[1]) < min_block_mm)
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn dist_to_polyline(p: Vec3, pl: &[Vec3]) -> f64 {
        pl.windows(2)
            .map(|w| seg_dist(p, w[0], w[1]).0)
            .fold(f64::INFINITY, f64::min)
    }

    /// Largest distance of the points of `a` (sampled along each segment) from `b`.
    fn one_sided(a: &[Vec3], b: &[Vec3]) -> f64 {
        let mut m: f64 = 0.0;
        for w in a.windows(2) {
            for s in 0..=16 {
                let p = w[0] + (w[1] - w[0]) * (s as f64 / 16.0);
                m = m.max(dist_to_polyline(p, b));
            }
        }
        m
    }

    fn arc_points(r: f64, sweep: f64, n: usize) -> Vec<Vec3> {
        (0..=n)
            .map(|k| {
                let t = sweep * k as f64 / n as f64;
                Vec3::new(r * t.cos(), r * t.sin(), 0.0)
            })
            .collect()
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
    fn shortest_neighbour(written: &[Vec3]) -> f64 {
        written
            .windows(3)
            .map(|w| w[0].dist(w[1]).min(w[1].dist(w[2])))
            .fold(f64::INFINITY, f64::min)
    }

    /// `dense` cut by [`simplify`] within 1e-3 mm (the start first), then by [`even_out`]
    /// with the junction rated by its shorter block (what LinuxCNC's blend takes half of),
    /// `room` inside the curve and a dense accuracy of 1e-5 mm.
    fn greedy_and_even(dense: &[Vec3], room: f64) -> (Vec<Vec3>, Vec<Vec3>) {
        let hard = sharp_points(dense, 1e-3);
        let mut out = Vec::new();
        let idx = simplify(dense, &hard, 1e-3, 0.0, |p| p, &mut out);
        assert_eq!(idx.len(), out.len() + 1);
        assert!(idx.iter().skip(1).zip(&out).all(|(&i, &p)| dense[i] == p));
        let with_start = |out: &[Vec3]| {
            std::iter::once(dense[0])
                .chain(out.iter().copied())
                .collect()
        };
        let greedy = with_start(&out);
        let how = EvenOut {
            score: |a: Vec3, b: Vec3, c: Vec3| a.dist(b).min(b.dist(c)),
            room: move |_: Vec3, _: Vec3, _: Vec3| room,
            dense_acc_mm: 1e-5,
        };
        even_out(
            dense,
            &hard,
            &idx,
            1e-3,
            0.0,
            |p| p,
            &how,
            dense[0],
            &mut out,
        );
        (greedy, with_start(&out))
    }

    #[test]
    fn even_out_lengthens_the_short_blocks_of_a_greedy_cut() {
        // Radius 10 mm in dense chords of 0.028 mm, over 1.05 rad: the greedy cut within
        // 1e-3 mm gives blocks of up to 0.28 mm and a shorter one where the arc runs out.
        // Evening out makes the shortest longer, keeps the ends, and stays within the
        // tolerance both ways.
        let dense = arc_points(10.0, 1.05, 378);
        let (before, after) = greedy_and_even(&dense, f64::INFINITY);
        let (short_before, short_after) = (shortest_neighbour(&before), shortest_neighbour(&after));
        assert_eq!(after.len(), before.len());
        assert_eq!(after.last(), before.last());
        let mean =
            after.windows(2).map(|w| w[0].dist(w[1])).sum::<f64>() / (after.len() - 1) as f64;
        // Greedy: blocks of 10 dense chords (0.278 mm) and one of 8 (0.222 mm); the
        // shortest moves at least 40 % of the way to the mean.
        assert!(
            short_after > short_before + 0.4 * (mean - short_before),
            "{short_before} -> {short_after} (mean {mean})"
        );
        assert!(one_sided(&dense, &after) <= 1e-3 + 1e-12);
        assert!(one_sided(&after, &dense) <= 1e-3 + 1e-12);
    }

    #[test]
    fn even_out_keeps_hard_points() {
        // Two legs of a square corner, each a fine arc: the corner stays where it is.
        let mut dense = arc_points(10.0, 0.3, 100);
        let corner = *dense.last().unwrap();
        dense.extend(
            arc_points(10.0, 0.3, 100)
                .iter()
                .skip(1)
                .map(|p| corner + Vec3::new(-(p.y), p.x - 10.0, 0.0)),
        );
        assert!(sharp_points(&dense, 1e-3)[100]);
        let (_, written) = greedy_and_even(&dense, f64::INFINITY);
        assert!(written.contains(&corner), "{written:?}");
        assert!(one_sided(&dense, &written) <= 1e-3 + 1e-12);
        assert!(one_sided(&written, &dense) <= 1e-3 + 1e-12);
    }

    #[test]
    fn even_out_moves_off_the_dense_points_only_within_the_room() {
        // As above, but no room inside the curve: every point stays a dense point. With
        // room for the whole dense accuracy, some move between them.
        let dense = arc_points(10.0, 1.05, 378);
        let on_dense = |room: f64| {
            greedy_and_even(&dense, room)
                .1
                .iter()
                .all(|p| dense.contains(p))
        };
        assert!(on_dense(0.0));
        assert!(!on_dense(1e-5));
    }

    proptest! {
        /// Whatever the curve and rounding, evening out keeps every block within the
        /// tolerance both ways (rounding aside, as for the greedy cut) and the ends.
        #[test]
        fn even_out_stays_within_the_tolerance(
            r in 0.5f64..50.0,
            sweep in 0.05f64..3.0,
            n in 20usize..300,
            wobble in 0.0f64..2e-4,
            unit in prop_oneof![Just(0.0), Just(1e-4), Just(2.54e-4)],
        ) {
            let tol = 1e-3;
            let dense: Vec<Vec3> = arc_points(r, sweep, n)
                .into_iter()
                .enumerate()
                .map(|(k, p)| p * (1.0 + wobble * ((k * 7919) % 13) as f64 / 13.0))
                .collect();
            let round = |p: Vec3| if unit > 0.0 {
                Vec3::new((p.x / unit).round() * unit, (p.y / unit).round() * unit, p.z)
            } else {
                p
            };
            let hard = sharp_points(&dense, tol);
            let mut out = Vec::new();
            let idx = simplify(&dense, &hard, tol, 0.0, round, &mut out);
            let radius = |a: Vec3, b: Vec3, c: Vec3| {
                let (u, w) = (b - a, c - b);
                0.5 * u.norm().min(w.norm()) / (0.5 * u.angle_to(w)).tan()
            };
            let how = EvenOut { score: radius, room: |_, _, _| f64::INFINITY, dense_acc_mm: 0.0 };
            even_out(&dense, &hard, &idx, tol, 0.0, round, &how, round(dense[0]), &mut out);
            prop_assert_eq!(*out.last().unwrap(), round(*dense.last().unwrap()));
            let written: Vec<Vec3> = std::iter::once(round(dense[0])).chain(out.iter().copied()).collect();
            // Every dense point within tol of the written line (rounding included by
            // the fit test), every written point within tol plus a rounding unit of the
            // dense polyline.
            for p in &dense {
                prop_assert!(dist_to_polyline(*p, &written) <= tol + 1e-12);
            }
            prop_assert!(one_sided(&written, &dense) <= tol + unit + 1e-12);
        }
    }

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
        fit_arcs(&dense, &hard, 1e-3, |p| p, &mut out);
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
        fit_arcs(&line, &sharp_points(&line, 1e-3), 1e-3, |p| p, &mut out);
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
            lift in -1.0f64..1.0,
        ) {
            let mut dense = arc_points(r, sweep, n);
            for (k, p) in dense.iter_mut().enumerate() {
                p.x += wiggle * tol * 0.3 * ((k as f64) * 1.3).sin();
                p.z = lift * k as f64 / n as f64;
            }
            use ncsmooth::geom::{Arc, Line, ParamCurve, ParamCurveNearest, Segment};
            let hard = sharp_points(&dense, tol);
            let mut out = Vec::new();
            fit_arcs(&dense, &hard, tol, |p| p, &mut out);
            let mut pieces: Vec<Segment> = Vec::new();
            let mut start = dense[0];
            for piece in &out {
                let seg: Segment = match *piece {
                    Piece::Line { end, .. } => Line::new(start, end).into(),
                    Piece::Arc { end, center, ccw, .. } => {
                        Arc::from_center(start, end, center, Vec3::Z, ccw, 0).unwrap().into()
                    }
                };
                start = seg.eval(1.0);
                pieces.push(seg);
            }
            prop_assert!(start.dist(*dense.last().unwrap()) <= 1e-9);
            // Dense polyline (sampled) to the written pieces, exactly.
            let to_written = |p: Vec3| pieces.iter()
                .map(|s| s.nearest(p, 1e-12).distance_sq.sqrt())
                .fold(f64::INFINITY, f64::min);
            let mut worst: f64 = 0.0;
            for w in dense.windows(2) {
                for k in 0..=16 {
                    worst = worst.max(to_written(w[0] + (w[1] - w[0]) * (k as f64 / 16.0)));
                }
            }
            prop_assert!(worst <= tol * (1.0 + 1e-9), "{}", worst);
            // Written pieces (sampled) to the dense polyline.
            let mut worst: f64 = 0.0;
            for s in &pieces {
                for k in 0..=256 {
                    worst = worst.max(dist_to_polyline(s.eval(k as f64 / 256.0), &dense));
                }
            }
            prop_assert!(worst <= tol * (1.0 + 1e-9), "{}", worst);
        }
    }

    /// A sharp programmed corner with a written transition of blocks far below the floor.
    fn corner_case() -> (Vec<Vec3>, Vec3, Vec<Vec3>) {
        let program = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
        ];
        // A quarter circle of radius 0.008 cut into 1.6 um blocks inside the corner.
        let mut pts = vec![Vec3::new(0.992, 0.0, 0.0)];
        for k in 1..=8 {
            let a = std::f64::consts::FRAC_PI_2 * k as f64 / 8.0;
            pts.push(Vec3::new(
                0.992 + 0.008 * a.sin(),
                0.008 - 0.008 * a.cos(),
                0.0,
            ));
        }
        pts.push(Vec3::new(1.0, 1.0, 0.0));
        (program, Vec3::ZERO, pts)
    }

    #[test]
    fn short_blocks_of_a_corner_are_lifted_within_the_program_tolerance() {
        let (program, start, mut pts) = corner_case();
        let prog = Program {
            points: &program,
            tol_mm: 0.01,
        };
        let left = lift_short_blocks(start, &mut pts, 0.03, &prog, |p| p);
        let mut out = vec![start];
        out.extend_from_slice(&pts);
        assert_eq!(left, 0, "{out:?}");
        assert!(out.windows(2).all(|w| w[0].dist(w[1]) >= 0.03), "{out:?}");
        assert!(one_sided(&out, &program) <= 0.01);
        assert!(program.iter().all(|&v| dist_to_polyline(v, &out) <= 0.01));
        assert_eq!(*out.last().unwrap(), Vec3::new(1.0, 1.0, 0.0));
    }

    #[test]
    fn for_linuxcnc_short_blocks_become_the_programmed_corner_only() {
        let (program, start, pts) = corner_case();
        let prog = Program {
            points: &program,
            tol_mm: 0.01,
        };
        let corner = Vec3::new(1.0, 0.0, 0.0);
        let grid = std::cell::OnceCell::new();
        let mut how = Lift {
            corners_only: true,
            ..Default::default()
        };
        let mut out = pts.clone();
        lift_short_blocks_in(start, &mut out, 0.03, &prog, &grid, |p| p, &mut how);
        assert_eq!(how.snapped, vec![corner]);
        // Nothing but the programmed corner is put in: no midpoint, no stretched block.
        assert!(
            out.iter().all(|p| *p == corner || pts.contains(p)),
            "{out:?}"
        );
        assert!(out.contains(&corner) && out.len() < pts.len(), "{out:?}");
        let mut path = vec![start];
        path.extend_from_slice(&out);
        assert!(one_sided(&path, &program) <= 0.01);
        // Not where the corner would end the chain (LinuxCNC ran such a last line at half
        // the acceleration): the transition as the chain's last blocks stays.
        let mut tail = pts[..pts.len() - 1].to_vec();
        let before = tail.clone();
        let mut how = Lift {
            corners_only: true,
            ..Default::default()
        };
        lift_short_blocks_in(start, &mut tail, 0.03, &prog, &grid, |p| p, &mut how);
        assert!(tail.len() < 2 || tail[tail.len() - 2] != corner, "{tail:?}");
        assert!(
            tail.iter().all(|p| *p == corner || before.contains(p)),
            "{tail:?}"
        );
        // Unless a rapid follows the chain: LinuxCNC stops there at the full acceleration.
        let mut how = Lift {
            corners_only: true,
            last_block: true,
            ..Default::default()
        };
        let mut tail = before.clone();
        lift_short_blocks_in(start, &mut tail, 0.03, &prog, &grid, |p| p, &mut how);
        assert_eq!(how.snapped, vec![corner]);
        assert_eq!(tail[tail.len() - 2], corner, "{tail:?}");
        assert_eq!(tail.last(), before.last());
        let mut path = vec![start];
        path.extend_from_slice(&tail);
        assert!(one_sided(&path, &program) <= 0.01);
    }

    #[test]
    fn short_blocks_stay_where_the_program_tolerance_is_too_tight() {
        // The transition is 0.0023 mm inside the corner; a 1 um tolerance forbids every
        // replacement that would lengthen its blocks.
        let (program, start, mut pts) = corner_case();
        let before = pts.clone();
        let prog = Program {
            points: &program,
            tol_mm: 0.001,
        };
        let left = lift_short_blocks(start, &mut pts, 0.03, &prog, |p| p);
        assert!(left > 0);
        let mut out = vec![start];
        out.extend_from_slice(&pts);
        // What was changed is still within the tolerance.
        assert!(pts.len() <= before.len());
        assert!(
            one_sided(&out, &program) <= 0.0031,
            "{}",
            one_sided(&out, &program)
        );
    }

    proptest! {
        /// The grid's queries give what the linear scans they replace gave: the segments
        /// near a block, the vertices in a box and the nearest vertex.
        #[test]
        fn grid_queries_equal_the_scans(
            steps in prop::collection::vec((-1.0f64..1.0, -1.0f64..1.0, -0.1f64..0.1), 2..200),
            scale in prop_oneof![Just(1e-4), Just(0.01), Just(1.0), Just(50.0)],
            q in (-3.0f64..3.0, -3.0f64..3.0, 0.0f64..0.5),
            long in 0usize..400,
        ) {
            // Mostly short steps; one far longer (a segment spanning many cells, which
            // every query must still see).
            let mut pts = vec![Vec3::ZERO];
            for (k, (x, y, z)) in steps.into_iter().enumerate() {
                let last = *pts.last().unwrap();
                let f = if k == long { 300.0 } else { 1.0 };
                pts.push(last + Vec3::new(x, y, z) * (scale * f));
            }
            let prog = Program { points: &pts, tol_mm: 0.01 };
            let grid = SegGrid::new(&pts, prog.tol_mm);
            let c = Vec3::new(q.0, q.1, 0.0) * scale.sqrt();
            let (a, b) = (c, c + Vec3::new(q.2, -q.2, 0.0));
            let mut got = Vec::new();
            prog.near(&grid, a, b, prog.tol_mm, &mut got);
            let pad = Vec3::new(0.01, 0.01, 0.01);
            let (lo, hi) = (a.min(b) - pad, a.max(b) + pad);
            let want: Vec<usize> = (0..pts.len() - 1)
                .filter(|&k| {
                    let (plo, phi) = (pts[k].min(pts[k + 1]), pts[k].max(pts[k + 1]));
                    plo.min(hi) == plo && phi.max(lo) == phi
                })
                .collect();
            prop_assert_eq!(got, want);
            let mut vin = Vec::new();
            prog.vertices_in(&grid, lo, hi, &mut vin);
            let mut vwant: Vec<Vec3> = pts
                .iter()
                .copied()
                .filter(|v| v.min(lo) == lo && v.max(hi) == hi)
                .collect();
            let key = |v: &Vec3| (v.x.to_bits(), v.y.to_bits(), v.z.to_bits());
            vin.sort_by_key(key);
            vin.dedup();
            vwant.sort_by_key(key);
            vwant.dedup();
            prop_assert_eq!(vin, vwant);
            let near = prog.nearest_vertex(&grid, c).unwrap();
            let best = pts.iter().map(|v| v.dist(c)).fold(f64::INFINITY, f64::min);
            prop_assert_eq!(near.dist(c), best);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Lifting keeps the written polyline within the program tolerance both ways when
        /// it starts there: a noisy resampling of a random polyline, every block checked.
        #[test]
        fn lifting_stays_within_the_program_tolerance(
            turns in proptest::collection::vec(-2.5f64..2.5, 2..8),
            lens in proptest::collection::vec(0.02f64..0.5, 8),
            step in 0.002f64..0.02,
            noise in proptest::collection::vec(-1.0f64..1.0, 400),
        ) {
            let tol = 0.01;
            let mut program = vec![Vec3::ZERO];
            let mut dir: f64 = 0.0;
            for (k, t) in turns.iter().enumerate() {
                dir += t;
                let p = *program.last().unwrap();
                program.push(p + Vec3::new(dir.cos(), dir.sin(), 0.0) * lens[k]);
            }
            // Written: points every `step` along the program, moved sideways by up to
            // tol / 2, the last point exact.
            let mut pts = Vec::new();
            let mut n = 0;
            for w in program.windows(2) {
                let d = w[1] - w[0];
                let m = (d.norm() / step).ceil() as usize;
                let side = Vec3::new(-d.y, d.x, 0.0) * (1.0 / d.norm());
                for j in 1..=m {
                    let e = noise[n % noise.len()] * tol * 0.5;
                    n += 1;
                    pts.push(w[0] + d * (j as f64 / m as f64) + side * e);
                }
            }
            *pts.last_mut().unwrap() = *program.last().unwrap();
            let prog = Program { points: &program, tol_mm: tol };
            lift_short_blocks(Vec3::ZERO, &mut pts, 0.03, &prog, |p| p);
            let mut out = vec![Vec3::ZERO];
            out.extend_from_slice(&pts);
            prop_assert!(one_sided(&out, &program) <= tol + 1e-12);
            prop_assert!(program.iter().all(|&v| dist_to_polyline(v, &out) <= tol + 1e-12));
            prop_assert_eq!(*out.last().unwrap(), *program.last().unwrap());
        }
    }
}
