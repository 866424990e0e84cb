//! Circular-arc corner transitions (Wu et al., section III.A, eqs. 10-14): `--method arc`,
//! and the transition builder shared with the NURBS hybrid (`nurbs_hybrid`).
//!
//! ## The model
//! At a corner `B` between lines `AB` and `BC` that turn by `beta` (the arc's central angle;
//! the included angle is `theta = pi - beta`, eq. 10), an arc of radius `R` tangent to both
//! legs touches them at `Q1`, `Q2`, at distance `l` from `B`, and passes at distance `e` from
//! `B` (eq. 10):
//!
//! ```text
//! l = e sin(beta/2) / (1 - cos(beta/2)),   R = e cos(beta/2) / (1 - cos(beta/2))
//! ```
//!
//! The tolerance gives `l_c` (eq. 11, `e = E_max`), the legs give `l_s = min(|AB|, |BC|) / 2`
//! (eq. 12), `l = min(l_c, l_s)` (eq. 13) and `R` from eq. 14. `1 - cos(x)` is evaluated as
//! `2 sin^2(x/2)` so near-straight corners lose no digits.
//!
//! `e` is the whole two-sided deviation of a transition: the corner `B` is the programmed
//! point farthest from the arc (distance `e`), and every arc point is nearer to the legs
//! than that (`e cos(beta/2)` at the arc's middle). So `E_max` is `--tol` (times
//! `CORNER_TOL_SHARE`, which keeps round-off on the safe side).
//!
//! 3-D corners: the arc lies in the plane of the two legs (normal `AB x BC`); the writer
//! emits it as G2/G3 when that plane is XY, XZ or YZ and flattens it otherwise.
//!
//! ## Whole path (choices where the paper is silent)
//! * Neighbouring transitions never overlap: each one uses at most half of each leg (eq.
//!   12), so the two transitions of a line leave a (possibly empty) straight piece between
//!   them. The walker checks it and emits no zero-length line.
//! * Junctions turning by less than `straight_angle_deg` pass through unchanged.
//! * A straight remainder shorter than `MIN_STRAIGHT_MM` between two transitions is not
//!   emitted (its direction would be round-off).
//! * Zero-length moves (shorter than [`DEGENERATE_MM`]) carry no direction: they are
//!   skipped and the corner is formed by their neighbours.
//! * Micro-legs (lines no longer than `MICRO_LEG_SHARE` (0.02)` tol`, a CAM file's quantisation
//!   such as camotics_vcarve's 1e-6 inch steps) between two longer lines are one corner at
//!   the run's middle point, the transitions' tolerance reduced by the shift; each of their
//!   corners would need an arc below `min_radius_mm` and stop (camotics_vcarve: 99 stops
//!   became 76, ugs_Gates_combined_R12: 96 became 66).
//! * Nearly straight stretches of lines lose the vertices they do not need
//!   (`simplify_straight_runs`, Douglas-Peucker within the same micro-leg share, taken
//!   from the transitions' tolerance): a cluster of quantised steps too long to be one
//!   merged corner otherwise has corners between sub-micrometre legs (camotics_vcarve: 84
//!   exact stops became 11). Lines next to a kept piece keep their direction.
//! * Reversals: as `beta -> 180 deg`, `R -> 0`. A turn whose legs span no plane (exact
//!   reversal) or whose arc would be smaller than [`ArcOptions::min_radius_mm`] (about 179
//!   degrees and above at tol 0.01 mm) is kept as an exact stop and counted in
//!   `corners_stopped`: such an arc is tangent to both legs within tol but far too tight
//!   to be driven faster than the stop it replaces.
//! * Input arcs stay exact. A non-tangent joint that involves an input arc is blended
//!   before this method runs ([`super::arc_joint`], a G1 Bezier within tol; Wu's paper has
//!   only lines and fitted curves); one that cannot be (a near reversal, another curve
//!   kind) is kept as an exact stop, counted in `corners_stopped` and `arc_joints`.
//! * Run mode (an extension of the paper): runs of micro-corners are first fitted through
//!   the band and carried as an arc spline ([`super::run_mode`], [`super::arc_spline`]);
//!   one arc per corner along such a run makes the curvature step between zero and `1/R`
//!   at every leg, which a jerk limit pays for at every joint (butterfly_1000 under a
//!   jerk limit: about half the cycle time as arc splines, `docs/benchmarks/2026-12-02.md`).
//!   The transitions below handle the corners that remain.
//! * Chain ends (rapids, events) are kept exactly, closed contours included: the closing
//!   corner of a closed chain is where the chain is entered and left, so it stays a stop.

use super::{Chain, ChainPos, OutPiece, SmoothOptions, SmoothReport};
use crate::geom::{Arc, Line, ParamCurve, Segment, Vec3};
use crate::path::Move;
use crate::verify::DEGENERATE_MM;

/// Share of the tolerance a transition may use: `E_max = tol * CORNER_TOL_SHARE`. The
/// missing part (1 ppm) absorbs floating-point round-off in the arc's construction.
pub(crate) const CORNER_TOL_SHARE: f64 = 1.0 - 1e-6;

/// Shortest straight piece (mm) left between a transition and its neighbour: a shorter
/// remainder is dropped and the pieces around it meet with a gap below
/// [`crate::verify::GAP_TOL_MM`]. Its direction would be round-off (at 1e5 mm coordinates the
/// last bit is 1.5e-11 mm), i.e. a spurious tangent break.
pub(crate) const MIN_STRAIGHT_MM: f64 = 0.5 * crate::verify::GAP_TOL_MM;

/// Longest line (as a share of the tolerance) that counts as a micro-leg: a run of such
/// lines between two longer ones is one corner at the run's middle point (its transition
/// takes the largest distance of the run's points from that point, at most this share,
/// from its tolerance; see the module doc).
pub(crate) const MICRO_LEG_SHARE: f64 = 0.02;

/// Settings of `--method arc` (and of the corners of `--method nurbs`).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct ArcOptions {
    /// Smallest transition radius (mm): corners that would need a smaller arc (near
    /// reversals, see the module doc) stay exact stops. Default 1e-4 mm (0.1 um), below the
    /// resolution of any G-code output and of any drive.
    pub min_radius_mm: f64,
}

/// Builders: each sets one field (see its doc for the default).
impl ArcOptions {
    /// Sets [`ArcOptions::min_radius_mm`].
    pub fn with_min_radius_mm(mut self, min_radius_mm: f64) -> Self {
        self.min_radius_mm = min_radius_mm;
        self
    }
}

impl Default for ArcOptions {
    fn default() -> Self {
        ArcOptions {
            min_radius_mm: 1e-4,
        }
    }
}

/// `1 - cos(x)` without cancellation.
#[inline]
fn one_minus_cos(x: f64) -> f64 {
    let s = (0.5 * x).sin();
    2.0 * s * s
}

/// Eq. 11: tangent length `l_c` of the arc that passes at `e_max` from a corner turning by
/// `beta` (radians, in `(0, pi)`). Infinite for `beta = 0`.
pub fn tangent_length(beta: f64, e_max: f64) -> f64 {
    let h = 0.5 * beta;
    e_max * h.sin() / one_minus_cos(h)
}

/// Eq. 10: radius of the arc that passes at `e` from a corner turning by `beta`.
pub fn radius_for_deviation(beta: f64, e: f64) -> f64 {
    let h = 0.5 * beta;
    e * h.cos() / one_minus_cos(h)
}

/// A transition arc at one corner.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CornerArc {
    /// The arc, from `Q1` on the incoming leg to `Q2` on the outgoing one.
    pub arc: Arc,
    /// Tangent length `l = |Q1 B| = |B Q2|` (eq. 13).
    pub l: f64,
    /// Radius (eq. 14).
    pub radius: f64,
    /// Distance from the corner to the arc (`E_max` when `l_c <= l_s`).
    pub e: f64,
    /// True when the legs limited the arc (`l_s < l_c`).
    pub length_limited: bool,
}

/// Eqs. 10-14: the arc at corner `b` between the incoming unit direction `d_in` and the
/// outgoing unit direction `d_out`, passing at most `e_max` from `b`, with tangent length at
/// most `l_s`. `None` when the legs span no plane (collinear or reversed), the radius would
/// be below `min_radius_mm`, or the input is not finite.
pub fn corner_arc(
    b: Vec3,
    d_in: Vec3,
    d_out: Vec3,
    e_max: f64,
    l_s: f64,
    min_radius_mm: f64,
) -> Option<CornerArc> {
    let n = d_in.cross(d_out).normalized()?;
    let beta = d_in.angle_to(d_out);
    let h = 0.5 * beta;
    let (s, c) = h.sin_cos();
    let omc = one_minus_cos(h);
    let l_c = e_max * s / omc;
    let (l, radius, e, length_limited) = if l_c <= l_s {
        (l_c, e_max * c / omc, e_max, false)
    } else {
        (l_s, l_s * c / s, l_s * omc / s, true)
    };
    if !(l > 0.0 && l.is_finite() && radius >= min_radius_mm && radius.is_finite()) {
        return None;
    }
    let q1 = b - d_in * l;
    let q2 = b + d_out * l;
    let center = q1 + n.cross(d_in) * radius;
    let arc = Arc {
        // Planar by construction: drop the round-off helical component (~1e-17 mm) that
        // `from_center` reads from `(q2 - q1) . n`.
        axial: Vec3::ZERO,
        ..Arc::from_center(q1, q2, center, n, true, 0)?
    };
    (arc.start().is_finite() && arc.end().is_finite()).then_some(CornerArc {
        arc,
        l,
        radius,
        e,
        length_limited,
    })
}

/// One piece of a chain as the transition walker sees it.
#[derive(Clone, Debug)]
pub(crate) enum Item {
    /// A straight piece a transition may trim. Each transition at an end may use
    /// `share * length` of it: 1/2 for a line with a possible transition at both ends
    /// (eq. 12), 1 for a stub reserved for a single corner (Fig. 5).
    Line {
        p0: Vec3,
        p1: Vec3,
        from: ChainPos,
        to: ChainPos,
        share: f64,
    },
    /// A piece kept as it is (input arc, fitted curve, other curve).
    Fixed {
        segment: Segment,
        from: ChainPos,
        to: ChainPos,
        input_arc: bool,
    },
}

impl Item {
    fn start_tangent(&self) -> Option<Vec3> {
        match self {
            Item::Line { p0, p1, .. } => (*p1 - *p0).normalized(),
            Item::Fixed { segment, .. } => segment.start_tangent(),
        }
    }
    fn end_tangent(&self) -> Option<Vec3> {
        match self {
            Item::Line { p0, p1, .. } => (*p1 - *p0).normalized(),
            Item::Fixed { segment, .. } => segment.end_tangent(),
        }
    }
    fn is_input_arc(&self) -> bool {
        matches!(
            self,
            Item::Fixed {
                input_arc: true,
                ..
            }
        )
    }
}

/// Chain position of the point at distance `s` from `p0` on a line item lying within one
/// programmed move.
fn line_pos(from: ChainPos, to: ChainPos, s: f64, len: f64) -> ChainPos {
    if from.index != to.index || len <= 0.0 {
        return if s <= 0.0 { from } else { to };
    }
    ChainPos {
        index: from.index,
        frac: (from.frac + (to.frac - from.frac) * (s / len)).clamp(0.0, 1.0),
    }
}

/// Blends every line-line corner between consecutive items with an arc (eqs. 10-14) and
/// returns the pieces. Counts corners in `report`.
pub(crate) fn blend_items(
    items: &[Item],
    tol_mm: f64,
    straight_angle_deg: f64,
    arc_opts: &ArcOptions,
    report: &mut SmoothReport,
) -> Vec<OutPiece> {
    let e_max = tol_mm * CORNER_TOL_SHARE;
    let k = items.len();
    let mut corners: Vec<Option<CornerArc>> = vec![None; k.saturating_sub(1)];
    for j in 0..k.saturating_sub(1) {
        let (a, b) = (&items[j], &items[j + 1]);
        let (Some(t_in), Some(t_out)) = (a.end_tangent(), b.start_tangent()) else {
            report.corners_stopped += 1;
            continue;
        };
        if t_in.angle_to(t_out).to_degrees() < straight_angle_deg {
            report.corners_straight += 1;
            continue;
        }
        match (a, b) {
            (
                Item::Line {
                    p0: a0,
                    p1: a1,
                    share: sa,
                    ..
                },
                Item::Line {
                    p0: b0,
                    p1: b1,
                    share: sb,
                    ..
                },
            ) => {
                let l_s = (sa * a0.dist(*a1)).min(sb * b0.dist(*b1));
                match corner_arc(*a1, t_in, t_out, e_max, l_s, arc_opts.min_radius_mm) {
                    Some(c) => {
                        report.corners_smoothed += 1;
                        corners[j] = Some(c);
                    }
                    None => report.corners_stopped += 1,
                }
            }
            _ => {
                report.corners_stopped += 1;
                if a.is_input_arc() || b.is_input_arc() {
                    report.arc_joints += 1;
                }
            }
        }
    }
    let mut out = Vec::with_capacity(2 * k);
    for (j, it) in items.iter().enumerate() {
        match it {
            Item::Line {
                p0, p1, from, to, ..
            } => {
                let len = p0.dist(*p1);
                let (start, s0) = match j.checked_sub(1).and_then(|i| corners[i].as_ref()) {
                    Some(c) => (c.arc.end(), c.l),
                    None => (*p0, 0.0),
                };
                let (end, s1) = match corners.get(j).and_then(|c| c.as_ref()) {
                    Some(c) => (c.arc.start(), len - c.l),
                    None => (*p1, len),
                };
                let trimmed = s0 > 0.0 || s1 < len;
                if s1 - s0 > if trimmed { MIN_STRAIGHT_MM } else { 0.0 } {
                    out.push(OutPiece {
                        segment: Segment::Line(crate::geom::Line::new(start, end)),
                        from: line_pos(*from, *to, s0, len),
                        to: line_pos(*from, *to, s1, len),
                    });
                }
                if let Some(c) = corners.get(j).and_then(|c| c.as_ref()) {
                    let Item::Line {
                        p0: n0,
                        p1: n1,
                        from: nf,
                        to: nt,
                        ..
                    } = &items[j + 1]
                    else {
                        unreachable!("corners are only built between two lines")
                    };
                    out.push(OutPiece {
                        segment: Segment::Arc(c.arc),
                        from: line_pos(*from, *to, len - c.l, len),
                        to: line_pos(*nf, *nt, c.l, n0.dist(*n1)),
                    });
                }
            }
            Item::Fixed {
                segment, from, to, ..
            } => out.push(OutPiece {
                segment: segment.clone(),
                from: *from,
                to: *to,
            }),
        }
    }
    out
}

/// Drops the vertices of nearly straight stretches of lines: within each stretch of
/// connected trimmable lines (share 1/2), the Douglas-Peucker simplification with
/// tolerance `eps_mm` keeps only the vertices the shape needs. CAM files that sample a
/// curve in quantised micro-steps (camotics_vcarve: runs of 0.2-0.3 um moves along a
/// straight tool path, more than `micro_mm` long in all, so [`merge_micro_legs`] cannot
/// make them one corner) otherwise give corners between sub-micrometre legs, whose arcs
/// fall below [`ArcOptions::min_radius_mm`]: 84 exact stops on camotics_vcarve.
///
/// Each kept line joins two programmed points whose skipped points lie within `eps_mm`
/// of it, so the two polylines are within `eps_mm` of each other both ways (the skipped
/// points' projections cover the line). Lines next to a kept piece, and a streamed
/// chain's open ends, keep their direction. Returns `eps_mm` when a vertex was dropped (the
/// transitions take it from their tolerance), else 0.
pub(crate) fn simplify_straight_runs(items: &mut Vec<Item>, chain: &Chain<'_>, eps_mm: f64) -> f64 {
    let moves = chain.moves;
    // A merged line is written at the lowest feed of the moves it spans, with extra axes
    // interpolated along it: a stretch keeps to one feed and to moves without extra axes.
    let plain = |it: &Item| {
        let m = &moves[item_from(it).index];
        matches!(it, Item::Line { share, .. } if *share == 0.5) && m.extra.is_none() && !m.pinned
    };
    let feed = |it: &Item| moves[item_from(it).index].feed_mm_s;
    let mut out: Vec<Item> = Vec::with_capacity(items.len());
    let mut dropped = false;
    let mut i = 0;
    while i < items.len() {
        // A line after a kept piece (a run curve, an input arc) may be tangent to it: it
        // keeps its direction, and so does the last line before one.
        // A chain cut by the streaming smoother is left along its first and last lines'
        // own directions.
        if (i > 0 && matches!(items[i - 1], Item::Fixed { .. })) || (i == 0 && chain.open_ends[0]) {
            out.push(items[i].clone());
            i += 1;
            continue;
        }
        let mut end = i;
        while end < items.len()
            && plain(&items[end])
            && feed(&items[end]) == feed(&items[i])
            && joins(&items[i..end], &items[end])
        {
            end += 1;
        }
        let last_open = end == items.len() && chain.open_ends[1];
        if (last_open || matches!(items.get(end), Some(Item::Fixed { .. }))) && end > i + 1 {
            end -= 1;
        }
        if end - i < 2 {
            out.push(items[i].clone());
            i += 1;
            continue;
        }
        let stretch = &items[i..end];
        let pts: Vec<Vec3> = std::iter::once(line_ends(&stretch[0]).0)
            .chain(stretch.iter().map(|it| line_ends(it).1))
            .collect();
        let keep = douglas_peucker(&pts, eps_mm);
        dropped |= keep.iter().filter(|&&k| k).count() < pts.len();
        let kept: Vec<usize> = (0..pts.len()).filter(|&k| keep[k]).collect();
        for w in kept.windows(2) {
            let (a, b) = (&stretch[w[0]], &stretch[w[1] - 1]);
            out.push(Item::Line {
                p0: pts[w[0]],
                p1: pts[w[1]],
                from: item_from(a),
                to: item_to(b),
                share: 0.5,
            });
        }
        i = end;
    }
    *items = out;
    if dropped {
        eps_mm
    } else {
        0.0
    }
}

/// Whether `next` starts where the last of `run` ends (true for an empty run).
fn joins(run: &[Item], next: &Item) -> bool {
    run.last()
        .is_none_or(|last| line_ends(last).1.dist(line_ends(next).0) <= crate::verify::GAP_TOL_MM)
}

/// The ends of a line item (a fixed item's are never asked for).
fn line_ends(it: &Item) -> (Vec3, Vec3) {
    match it {
        Item::Line { p0, p1, .. } => (*p0, *p1),
        Item::Fixed { segment, .. } => (segment.start(), segment.end()),
    }
}

fn item_from(it: &Item) -> ChainPos {
    match it {
        Item::Line { from, .. } | Item::Fixed { from, .. } => *from,
    }
}

fn item_to(it: &Item) -> ChainPos {
    match it {
        Item::Line { to, .. } | Item::Fixed { to, .. } => *to,
    }
}

/// Douglas-Peucker ([`crate::geom::douglas_peucker`]): which of `pts` to keep so that
/// every dropped point lies within `eps_mm` of the kept line spanning it, and no kept line
/// is shorter than [`DEGENERATE_MM`] where a point was dropped (a stretch that returns to
/// its start keeps its farthest point). The ends are always kept.
fn douglas_peucker(pts: &[Vec3], eps_mm: f64) -> Vec<bool> {
    crate::geom::douglas_peucker(
        pts.len(),
        eps_mm,
        |a, b, k| Line::new(pts[a], pts[b]).dist_sq(pts[k]).sqrt(),
        |a, b| pts[a].dist(pts[b]) <= DEGENERATE_MM,
    )
}

/// Merges every run of micro-legs (lines no longer than `micro_mm`, a CAM file's
/// quantisation: camotics_vcarve's 1e-6 inch steps in arbitrary directions) lying between
/// two longer lines into one corner: the line before ends, and the line after starts, at
/// the point halfway along the run. Each corner of such a run needed an arc of a few
/// nanometres, below [`ArcOptions::min_radius_mm`], and was kept as an exact stop (99 on
/// camotics_vcarve). The merged path is within the returned shift (the largest distance of
/// a run's points from its middle point, at most `micro_mm`) of the programmed one both
/// ways, by convexity: the moved lines' ends move by at most that. The transitions take
/// the shift from their tolerance. Runs at either end of the items are kept.
pub(crate) fn merge_micro_legs(items: &mut Vec<Item>, micro_mm: f64) -> f64 {
    let len = |it: &Item| match it {
        Item::Line { p0, p1, .. } => Some(p0.dist(*p1)),
        Item::Fixed { .. } => None,
    };
    let is_micro = |it: &Item| len(it).is_some_and(|l| l <= micro_mm);
    let is_long = |it: &Item| len(it).is_some_and(|l| l > micro_mm);
    let mut shift: f64 = 0.0;
    let mut out: Vec<Item> = Vec::with_capacity(items.len());
    let mut i = 0;
    while i < items.len() {
        let run_end = (i..items.len())
            .find(|&j| !is_micro(&items[j]))
            .unwrap_or(items.len());
        let merged = run_end > i
            && out.last().is_some_and(is_long)
            && items.get(run_end).is_some_and(is_long)
            && merge_run(&items[i..run_end], &mut out, &items[run_end], micro_mm)
                .map(|d| shift = shift.max(d))
                .is_some();
        if merged {
            // `merge_run` pushed the line after the run, its start moved.
            i = run_end + 1;
        } else {
            out.push(items[i].clone());
            i += 1;
        }
    }
    *items = out;
    shift
}

/// One run of [`merge_micro_legs`]: moves the end of `out`'s last line and the start of
/// `next` (pushed to `out`) to the run's middle point. `None` (nothing changed) when the
/// pieces do not connect or a run point lies farther than `micro_mm` from the middle.
fn merge_run(run: &[Item], out: &mut Vec<Item>, next: &Item, micro_mm: f64) -> Option<f64> {
    let pts: Vec<Vec3> = std::iter::once(run.first()?)
        .map(|it| match it {
            Item::Line { p0, .. } => *p0,
            Item::Fixed { .. } => unreachable!("runs hold lines"),
        })
        .chain(run.iter().map(|it| match it {
            Item::Line { p1, .. } => *p1,
            Item::Fixed { .. } => unreachable!("runs hold lines"),
        }))
        .collect();
    let total: f64 = pts.windows(2).map(|w| w[0].dist(w[1])).sum();
    let mut walked = 0.0;
    let mut mid = pts[0];
    for w in pts.windows(2) {
        let l = w[0].dist(w[1]);
        if walked + l >= 0.5 * total && l > 0.0 {
            mid = w[0] + (w[1] - w[0]) * ((0.5 * total - walked) / l);
            break;
        }
        walked += l;
    }
    let shift = pts.iter().map(|p| p.dist(mid)).fold(0.0, f64::max);
    let (Some(Item::Line { p1: prev_end, .. }), Item::Line { p0: next_start, .. }) =
        (out.last(), next)
    else {
        return None;
    };
    let joined = prev_end.dist(pts[0]) <= crate::verify::GAP_TOL_MM
        && next_start.dist(pts[pts.len() - 1]) <= crate::verify::GAP_TOL_MM;
    if !joined || shift > micro_mm {
        return None;
    }
    if let Some(Item::Line { p1, .. }) = out.last_mut() {
        *p1 = mid;
    }
    let mut next = next.clone();
    if let Item::Line { p0, .. } = &mut next {
        *p0 = mid;
    }
    out.push(next);
    Some(shift)
}

/// The items of a chain for `--method arc`: every non-degenerate move, lines trimmable
/// by half (eq. 12), everything else fixed.
fn arc_items(chain: &Chain<'_>) -> Vec<Item> {
    chain
        .moves
        .iter()
        .enumerate()
        .filter_map(|(i, m)| match &m.segment {
            Segment::Line(l) if l.length() > DEGENERATE_MM => Some(Item::Line {
                p0: l.p0,
                p1: l.p1,
                from: ChainPos::start_of(i),
                to: ChainPos::end_of(i),
                share: 0.5,
            }),
            Segment::Line(_) => None,
            s => Some(Item::Fixed {
                segment: s.clone(),
                from: ChainPos::start_of(i),
                to: ChainPos::end_of(i),
                input_arc: matches!(s, Segment::Arc(_)),
            }),
        })
        .collect()
}

/// `--method arc` on one chain.
pub fn smooth_arc(chain: &Chain<'_>, opts: &SmoothOptions, report: &mut SmoothReport) -> Vec<Move> {
    let mut items = arc_items(chain);
    if items.is_empty() {
        return super::passthrough(chain);
    }
    let micro_mm = opts.tol_mm * MICRO_LEG_SHARE;
    let shift = simplify_straight_runs(&mut items, chain, micro_mm);
    let shift = shift + merge_micro_legs(&mut items, micro_mm);
    let pieces = blend_items(
        &items,
        opts.tol_mm - shift,
        opts.straight_angle_deg,
        &opts.arc,
        report,
    );
    super::assemble(chain, pieces)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{ParamCurveDeriv, ParamCurveNearest};
    use crate::path::Toolpath;
    use crate::smooth::{smooth, Method};
    use crate::verify::{continuity_joints, deviation, JointClass};
    use proptest::prelude::*;
    use std::f64::consts::PI;

    fn check_tangency(c: &CornerArc, d_in: Vec3, d_out: Vec3) {
        let t0 = c.arc.deriv(0.0).normalized().unwrap();
        let t1 = c.arc.deriv(1.0).normalized().unwrap();
        assert!(t0.dist(d_in) < 1e-9, "{t0:?} {d_in:?}");
        assert!(t1.dist(d_out) < 1e-9, "{t1:?} {d_out:?}");
    }

    #[test]
    fn right_angle_matches_eqs_10_to_14() {
        let e = 0.01;
        let c = corner_arc(Vec3::ZERO, Vec3::X, Vec3::Y, e, 10.0, 1e-4).unwrap();
        // beta = 90 deg: l = R = e sin45 / (1 - cos45) = e (1 + sqrt 2).
        let k = 1.0 + 2f64.sqrt();
        assert!((c.l - k * e).abs() < 1e-15);
        assert!((c.radius - k * e).abs() < 1e-15);
        assert!((c.arc.sweep - PI / 2.0).abs() < 1e-12);
        assert!(c.arc.start().dist(Vec3::new(-k * e, 0.0, 0.0)) < 1e-15);
        assert!(c.arc.end().dist(Vec3::new(0.0, k * e, 0.0)) < 1e-15);
        let d = c.arc.nearest(Vec3::ZERO, 0.0).distance_sq.sqrt();
        assert!((d - e).abs() < 1e-15);
        check_tangency(&c, Vec3::X, Vec3::Y);
        // Length-limited: l = l_s, R = cot(45) l_s.
        let c = corner_arc(Vec3::ZERO, Vec3::X, Vec3::Y, e, 0.01, 1e-4).unwrap();
        assert!(c.length_limited && (c.l - 0.01).abs() < 1e-15);
        assert!((c.radius - 0.01).abs() < 1e-15);
        let d = c.arc.nearest(Vec3::ZERO, 0.0).distance_sq.sqrt();
        assert!((d - c.e).abs() < 1e-15 && c.e < e);
    }

    #[test]
    fn random_angles_reach_e_max_exactly() {
        let mut seed = 99u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..2000 {
            let beta = 1e-3 + rnd() * (PI - 0.05);
            // A random 3-D frame.
            let u = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5)
                .normalized()
                .unwrap();
            let w = u.any_perpendicular();
            let d_in = u;
            let d_out = u * beta.cos() + w * beta.sin();
            let b = Vec3::new(rnd() * 100.0, rnd() * 100.0, rnd() * 100.0);
            let e_max = 0.001 + rnd() * 0.05;
            let l_s = rnd() * 2.0;
            let l_c = tangent_length(beta, e_max);
            let Some(c) = corner_arc(b, d_in, d_out, e_max, l_s, 1e-4) else {
                // Only a radius below the minimum may refuse a corner that spans a plane.
                let r = if l_c <= l_s {
                    radius_for_deviation(beta, e_max)
                } else {
                    l_s / (0.5 * beta).tan()
                };
                assert!(r < 1e-4, "beta {beta} r {r}");
                continue;
            };
            let d = c.arc.nearest(b, 0.0).distance_sq.sqrt();
            assert!((d - c.e).abs() < 1e-12, "beta {beta} d {d} e {}", c.e);
            if l_c <= l_s {
                assert!(!c.length_limited);
                assert!((c.e - e_max).abs() < 1e-15 && (d - e_max).abs() < 1e-12);
                assert!((c.l - l_c).abs() < 1e-12 * l_c.max(1.0));
            } else {
                assert!(c.length_limited && c.e <= e_max && c.l == l_s);
            }
            assert!((c.arc.sweep - beta).abs() < 1e-9);
            assert!((c.arc.start().dist(b) - c.l).abs() < 1e-12);
            assert!((c.arc.end().dist(b) - c.l).abs() < 1e-12);
            check_tangency(&c, d_in, d_out);
        }
    }

    #[test]
    fn reversal_and_collinear_have_no_arc() {
        assert!(corner_arc(Vec3::ZERO, Vec3::X, -Vec3::X, 0.01, 1.0, 1e-4).is_none());
        assert!(corner_arc(Vec3::ZERO, Vec3::X, Vec3::X, 0.01, 1.0, 1e-4).is_none());
        let near = Vec3::new(-1.0, 1e-6, 0.0).normalized().unwrap();
        assert!(corner_arc(Vec3::ZERO, Vec3::X, near, 0.01, 1.0, 1e-4).is_none());
    }

    pub(crate) fn arc_opts(tol: f64) -> crate::smooth::SmoothOptions {
        crate::smooth::SmoothOptions {
            method: Method::Arc,
            tol_mm: tol,
            ..Default::default()
        }
    }

    /// The pieces and the report of [`blend_items`] on the program's own items (one
    /// chain, micro-legs not merged), straight angle 0.01 degrees.
    fn blend_as_programmed(tp: &Toolpath, tol: f64) -> (Vec<OutPiece>, SmoothReport) {
        let prog: Vec<Move> = tp.moves().cloned().collect();
        let chain = Chain {
            moves: &prog,
            start_extra: None,
            open_ends: [false; 2],
        };
        let mut rep = SmoothReport::default();
        let pieces = blend_items(
            &arc_items(&chain),
            tol,
            0.01,
            &ArcOptions::default(),
            &mut rep,
        );
        (pieces, rep)
    }

    /// Smooths a polyline and checks the contract: two-sided deviation, finite output,
    /// G1 at every smoothed corner, no overlapping transitions.
    fn check_polyline(pts: &[Vec3], tol: f64) {
        let tp = Toolpath::from_polyline(pts, Some(10.0));
        let s = smooth(&tp, &arc_opts(tol)).unwrap();
        for m in s.toolpath.moves() {
            assert!(m.segment.start().is_finite() && m.segment.end().is_finite());
        }
        let dev = deviation(&s.toolpath, &tp, tol * 1e-3);
        assert!(dev.max_mm() <= tol, "{dev:?}");
        let (_, joints) = continuity_joints(&s.toolpath);
        let g0 = joints.iter().filter(|j| j.class == JointClass::G0).count();
        if g0 > s.report.corners_stopped {
            let moves: Vec<_> = s.toolpath.moves().collect();
            for j in joints.iter().filter(|j| j.class == JointClass::G0) {
                eprintln!(
                    "{j:?}\n  {:?}\n  {:?}",
                    moves[j.move_index].segment,
                    moves.get(j.move_index + 1).map(|m| &m.segment)
                );
            }
            eprintln!("{pts:?}");
        }
        assert!(g0 <= s.report.corners_stopped, "{g0} {:?}", s.report);
        assert!(joints.iter().all(|j| j.class != JointClass::Gap));
        // Transitions never overlap: the pieces advance monotonically along the chain.
        let (pieces, _) = blend_as_programmed(&tp, tol);
        let key = |p: ChainPos| (p.index, p.frac);
        for w in pieces.windows(2) {
            assert!(key(w[0].from) <= key(w[0].to) && key(w[0].to) <= key(w[1].from));
        }
        let moves: Vec<_> = s.toolpath.moves().collect();
        for w in moves.windows(2) {
            assert!(w[0].segment.end().dist(w[1].segment.start()) <= crate::verify::GAP_TOL_MM);
        }
    }

    #[test]
    fn walker_on_a_square_and_micro_lines() {
        let sq = [
            Vec3::ZERO,
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
            Vec3::ZERO,
        ];
        check_polyline(&sq, 0.01);
        let tp = Toolpath::from_polyline(&sq, Some(10.0));
        let s = smooth(&tp, &arc_opts(0.01)).unwrap();
        assert_eq!(s.report.corners_smoothed, 3);
        assert_eq!(s.report.segments_emitted, 7);
        // Micro-lines: l_s limits every arc, arcs meet at the midpoints with no line between.
        let zig: Vec<Vec3> = (0..20)
            .map(|i| Vec3::new(i as f64 * 0.001, (i % 2) as f64 * 0.001, 0.0))
            .collect();
        check_polyline(&zig, 0.01);
        // The paper's walker: the run mode would fit the zigzag as one curve.
        let mut walker = arc_opts(0.01);
        walker.run.enabled = false;
        let s = smooth(&Toolpath::from_polyline(&zig, None), &walker).unwrap();
        assert_eq!(s.report.corners_smoothed, 18);
        assert_eq!(s.report.segments_emitted, 18 + 2);
    }

    #[test]
    fn input_arcs_stay_and_joints_blend() {
        let mut tp = Toolpath::new(Vec3::ZERO);
        tp.push_move(Move::feed(
            crate::geom::Line::new(Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)),
            Some(5.0),
            1,
        ));
        // A quarter arc starting at right angles to the line (non-tangent joint).
        let a = Arc::from_center(
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(15.0, 5.0, 0.0),
            Vec3::new(15.0, 0.0, 0.0),
            Vec3::Z,
            false,
            0,
        )
        .unwrap();
        tp.push_move(Move::feed(a, Some(5.0), 2));
        tp.push_move(Move::feed(
            crate::geom::Line::new(Vec3::new(15.0, 5.0, 0.0), Vec3::new(20.0, 5.0, 0.0)),
            Some(5.0),
            3,
        ));
        let s = smooth(&tp, &arc_opts(0.01)).unwrap();
        // The right-angle line-arc joint is blended (super::arc_joint), the arc -> line
        // joint is tangent; the rest of the arc stays an exact arc of the same circle.
        assert_eq!(s.report.arc_joints, 1);
        assert_eq!(s.report.arc_joints_blended, 1);
        assert_eq!(s.report.corners_stopped, 0);
        assert!(s.toolpath.moves().any(
            |m| matches!(m.segment, Segment::Arc(b) if b.center == a.center && b.radius == a.radius)
        ));
        assert_eq!(crate::verify::continuity(&s.toolpath).g0, 0);
        assert!(deviation(&s.toolpath, &tp, 1e-5).max_mm() <= 0.01);
    }

    #[test]
    fn micro_legs_between_two_lines_are_one_corner() {
        // A long line, a cluster of 25-75 nm steps in quantised directions (camotics_vcarve's
        // 1e-6 inch moves), then a line turning by 30 degrees: each corner of the cluster
        // needed an arc far below min_radius_mm and stopped; merged, the cluster is one
        // corner at its middle point with an ordinary arc.
        let q = 2.54e-5;
        let mut pts = vec![Vec3::ZERO, Vec3::new(5.0, 0.0, 0.0)];
        for (dx, dy) in [(1.0, 1.0), (0.0, 1.0), (1.0, 0.0), (2.0, 1.0), (1.0, 2.0)] {
            let last = *pts.last().unwrap();
            pts.push(last + Vec3::new(dx, dy, 0.0) * q);
        }
        let turn = 30f64.to_radians();
        let last = *pts.last().unwrap();
        pts.push(last + Vec3::new(turn.cos(), turn.sin(), 0.0) * 5.0);
        let tol = 0.01;
        let tp = Toolpath::from_polyline(&pts, Some(10.0));
        let (_, unmerged) = blend_as_programmed(&tp, tol);
        assert!(unmerged.corners_stopped > 0, "{unmerged:?}");
        let s = smooth(&tp, &arc_opts(tol)).unwrap();
        assert_eq!(s.report.corners_stopped, 0, "{:?}", s.report);
        assert_eq!(crate::verify::continuity(&s.toolpath).g0, 0);
        assert!(deviation(&s.toolpath, &tp, 1e-6).max_mm() <= tol);
        check_polyline(&pts, tol);
    }

    /// A 5 mm line, `steps` quantised steps of 25-80 nm along it (camotics_vcarve's 1e-6
    /// inch moves), then a 5 mm line turning by 30 degrees.
    fn quantised_steps_between_lines(steps: usize) -> Vec<Vec3> {
        let q = 2.54e-5;
        let mut pts = vec![Vec3::ZERO, Vec3::new(5.0, 0.0, 0.0)];
        for k in 0..steps {
            let (dx, dy) = [(1.0, 0.0), (2.0, 1.0), (1.0, -1.0), (2.0, 0.0)][k % 4];
            let last = *pts.last().unwrap();
            pts.push(last + Vec3::new(dx, dy, 0.0) * q);
        }
        let turn = 30f64.to_radians();
        let last = *pts.last().unwrap();
        pts.push(last + Vec3::new(turn.cos(), turn.sin(), 0.0) * 5.0);
        pts
    }

    #[test]
    fn straight_runs_of_micro_steps_lose_their_vertices() {
        // A long line, then 12 steps of 25-80 nm in quantised directions along it (0.6 um
        // in all, more than `micro_mm` from its middle, so not one merged corner), then a
        // line turning by 30 degrees: each step's corners needed an arc below
        // min_radius_mm and stopped; simplified, the steps are part of the lines.
        let pts = quantised_steps_between_lines(12);
        let tol = 0.01;
        let tp = Toolpath::from_polyline(&pts, Some(10.0));
        let s = smooth(&tp, &arc_opts(tol)).unwrap();
        assert_eq!(s.report.corners_stopped, 0, "{:?}", s.report);
        assert_eq!(crate::verify::continuity(&s.toolpath).g0, 0);
        assert!(deviation(&s.toolpath, &tp, 1e-6).max_mm() <= tol);
        check_polyline(&pts, tol);
    }

    #[test]
    fn straight_runs_keep_to_one_feed() {
        // A 5 mm line and quantised steps along it at 10 mm/s, then steps and a turning
        // line at 2 mm/s (cncjs_jsdc's cut and plunge feeds): one merged line would be
        // written at the lower feed over its whole length (slower on grbl).
        let pts = quantised_steps_between_lines(24);
        let mut tp = Toolpath::new(pts[0]);
        for (i, w) in pts.windows(2).enumerate() {
            let feed = if i <= 12 { 10.0 } else { 2.0 };
            tp.push_move(Move::feed(Line::new(w[0], w[1]), Some(feed), i as u32 + 1));
        }
        let s = smooth(&tp, &arc_opts(0.01)).unwrap();
        let fast: f64 = s
            .toolpath
            .moves()
            .filter(|m| m.feed_mm_s == Some(10.0))
            .map(|m| m.segment.length(1e-9))
            .sum();
        assert!(fast > 4.9, "{fast} mm at 10 mm/s");
        assert!(deviation(&s.toolpath, &tp, 1e-6).max_mm() <= 0.01);
    }

    fn polyline_strategy() -> impl Strategy<Value = (Vec<Vec3>, f64)> {
        let step = prop_oneof![
            // Ordinary steps.
            (-5.0..5.0f64, -5.0..5.0f64, -1.0..1.0f64).prop_map(|(x, y, z)| Vec3::new(x, y, z)),
            // Micro steps (1 um).
            (-1.0..1.0f64, -1.0..1.0f64).prop_map(|(x, y)| Vec3::new(x, y, 0.0) * 1e-3),
            // Repeated points.
            Just(Vec3::ZERO),
        ];
        (
            prop::collection::vec(step, 1..40),
            prop_oneof![Just(0.002), Just(0.01), Just(0.05)],
            prop_oneof![Just(0.0), Just(1e5)],
            any::<u8>(),
        )
            .prop_map(|(steps, tol, offset, mode)| {
                let mut p = Vec3::new(offset, -offset, 0.0);
                let mut pts = vec![p];
                for (i, s) in steps.iter().enumerate() {
                    // Every few steps inject a reversal, a 1-degree corner or a
                    // near-collinear step, depending on `mode`.
                    p += super::super::degenerate_step(&pts, *s, mode as usize + i);
                    pts.push(p);
                }
                (pts, tol)
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        #[test]
        fn arc_method_holds_tolerance((pts, tol) in polyline_strategy()) {
            check_polyline(&pts, tol);
        }
    }
}
