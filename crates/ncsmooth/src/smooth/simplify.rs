//! Merging of nearly collinear lines before a chain is smoothed: Douglas and Peucker's
//! polyline simplification (1973) within a small share of the tolerance.
//!
//! CAM output carries clusters of sub-micrometre steps in arbitrary directions (a
//! quantised tool path: camotics_vcarve writes 20-60 steps of 1e-6 inch where a line
//! meets the next one), repeated points and runs of collinear micro-lines. Every such
//! vertex is a corner to the methods and a knot to the band fit: the curve follows the
//! cluster's own tight bend, and the fit's penalty spans many orders of magnitude.
//! Merged first, the same stretch is a few clean lines and corners.
//!
//! ## Algorithm
//! Each maximal sequence of line moves of one feed, no extra axes and no pinned move is
//! simplified on its own. Repeated points go; the group's ends are kept, and so is every
//! point between two lines of at least the micro-line length (the program's own shape: a
//! profile sampled every few tenths of a millimetre is left as it is). Between kept
//! points, recursively
//! the point farthest from the chord between two kept points is kept while it lies more
//! than `eps` from that chord (3-D point-to-segment distance).
//!
//! ## What it bounds
//! Every dropped point lies within `eps` of the chord that replaces it, and every point of
//! that chord within `eps` of the lines it replaces (those lines run from one end of the
//! chord to the other inside the chord's `eps` capsule, which is convex, so their
//! projections cover the chord). A path within `tol - eps` of the merged lines (both
//! ways) is therefore within `tol` of the programmed ones (both ways).
//!
//! ## Limits
//! Moves with extra axes (a slicer's `E`, rotary axes) are never merged: their values are
//! spread over each move's own length. Merged moves take the line number of the first
//! move they replace.

use crate::geom::{Line, ParamCurve, Segment};
use crate::path::{Move, MoveKind};
use crate::verify::DEGENERATE_MM;

/// Merges the nearly collinear lines of `moves` within `eps_mm` (module doc), dropping
/// repeated points and points next to a line shorter than `micro_mm`; `None` when
/// nothing merges.
///
/// ```
/// use ncsmooth::geom::{Line, ParamCurve, Vec3};
/// use ncsmooth::path::Move;
/// use ncsmooth::smooth::simplify::merge_lines;
///
/// // A line of 0.1 mm cut into 10 steps, one of them 0.0005 mm off, then a corner.
/// let mut pts: Vec<Vec3> = (0..=10).map(|i| Vec3::new(0.01 * i as f64, 0.0, 0.0)).collect();
/// pts[5].y = 0.0005;
/// pts.push(Vec3::new(0.1, 0.1, 0.0));
/// let moves: Vec<Move> = pts
///     .windows(2)
///     .map(|w| Move::feed(Line::new(w[0], w[1]), Some(10.0), 1))
///     .collect();
/// let merged = merge_lines(&moves, 0.001, 0.02).unwrap();
/// assert_eq!(merged.len(), 2);
/// assert_eq!(merged[0].segment.end(), Vec3::new(0.1, 0.0, 0.0));
/// // Closer than the point's offset, or with steps longer than the micro-line length:
/// assert!(merge_lines(&moves, 0.0001, 0.02).unwrap().len() > 2);
/// assert!(merge_lines(&moves, 0.001, 0.005).is_none());
/// ```
pub fn merge_lines(moves: &[Move], eps_mm: f64, micro_mm: f64) -> Option<Vec<Move>> {
    if eps_mm.is_nan() || eps_mm <= 0.0 {
        return None;
    }
    let mut out = Vec::with_capacity(moves.len());
    let mut i = 0;
    while i < moves.len() {
        let j = group_end(moves, i);
        if j - i >= 2 {
            merge_group(&moves[i..j], eps_mm, micro_mm, &mut out);
        } else {
            out.extend_from_slice(&moves[i..j]);
        }
        i = j;
    }
    (out.len() < moves.len()).then_some(out)
}

/// Whether `m` may be merged with its neighbours: a feed line that carries no extra axes
/// and is not pinned.
fn mergeable(m: &Move) -> bool {
    matches!(m.segment, Segment::Line(_))
        && m.kind == MoveKind::Feed
        && m.extra.is_none()
        && !m.pinned
}

/// End (exclusive) of the group of mergeable moves of one feed starting at `i` (at least
/// `i + 1`).
fn group_end(moves: &[Move], i: usize) -> usize {
    if !mergeable(&moves[i]) {
        return i + 1;
    }
    let feed = moves[i].feed_mm_s;
    let mut j = i + 1;
    while j < moves.len() && mergeable(&moves[j]) && moves[j].feed_mm_s == feed {
        j += 1;
    }
    j
}

/// Appends the group's lines merged within `eps` to `out`.
fn merge_group(group: &[Move], eps: f64, micro: f64, out: &mut Vec<Move>) {
    // The group's points without repeats, and the move that starts at each.
    let mut pts = vec![group[0].segment.start()];
    let mut src = vec![0];
    for (i, m) in group.iter().enumerate() {
        let p = m.segment.end();
        if p.dist(pts[pts.len() - 1]) > DEGENERATE_MM {
            pts.push(p);
            src.push(i + 1);
        }
    }
    let n = pts.len();
    if n < 2 {
        out.extend_from_slice(group);
        return;
    }
    // A point between two longer lines is the program's own shape; one next to a
    // micro-line may go.
    let keep: Vec<bool> = (0..n)
        .map(|k| {
            k == 0
                || k == n - 1
                || (pts[k].dist(pts[k - 1]) >= micro && pts[k + 1].dist(pts[k]) >= micro)
        })
        .collect();
    // Squared distances against `eps^2`.
    let dist_sq = |a: usize, b: usize, k: usize| Line::new(pts[a], pts[b]).dist_sq(pts[k]);
    let keep = crate::geom::douglas_peucker_from(keep, eps * eps, dist_sq, |_, _| false);
    let mut from = 0;
    for k in 1..n {
        if !keep[k] {
            continue;
        }
        if pts[from].dist(pts[k]) <= DEGENERATE_MM {
            // The lines return to where they started (a loop smaller than eps): kept.
            out.extend_from_slice(&group[src[from]..src[k].min(group.len())]);
        } else {
            out.push(Move {
                segment: Segment::Line(Line::new(pts[from], pts[k])),
                ..group[src[from]].clone()
            });
        }
        from = k;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Vec3;
    use proptest::prelude::*;

    fn moves_of(pts: &[Vec3]) -> Vec<Move> {
        pts.windows(2)
            .map(|w| Move::feed(Line::new(w[0], w[1]), Some(10.0), 1))
            .collect()
    }

    fn polyline_dist(p: Vec3, moves: &[Move]) -> f64 {
        moves
            .iter()
            .map(|m| {
                Line::new(m.segment.start(), m.segment.end())
                    .dist_sq(p)
                    .sqrt()
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// A vcarve-like cluster: a line, 30 sub-micrometre steps turning at random, a
    /// repeated point, and the next line: the cluster merges into the corner.
    #[test]
    fn a_cluster_of_tiny_steps_becomes_one_corner() {
        let mut pts = vec![Vec3::ZERO, Vec3::new(0.2, 0.0, 0.0)];
        for k in 1..=30 {
            let a = (k as f64) * 2.1;
            pts.push(Vec3::new(0.2 + 1e-5 * a.cos(), 1e-5 * a.sin(), 0.0));
        }
        let c = pts[pts.len() - 1];
        pts.push(c);
        pts.push(c + Vec3::new(0.2, 0.2, 0.0));
        let moves = moves_of(&pts);
        let merged = merge_lines(&moves, 0.001, 0.01).unwrap();
        assert_eq!(merged.len(), 2, "{merged:?}");
    }

    #[test]
    fn feeds_extra_axes_and_pinned_moves_are_not_merged() {
        let pts: Vec<Vec3> = (0..=4).map(|i| Vec3::new(i as f64, 0.0, 0.0)).collect();
        let mut moves = moves_of(&pts);
        moves[2].feed_mm_s = Some(20.0);
        let merged = merge_lines(&moves, 0.01, 2.0).unwrap();
        assert_eq!(merged.len(), 3);
        assert_eq!(merged[0].segment.end(), Vec3::new(2.0, 0.0, 0.0));
        let mut moves = moves_of(&pts);
        moves[1].extra = Some([0.0; 7]);
        moves[3].pinned = true;
        assert!(merge_lines(&moves, 0.01, 2.0).is_none());
        // Lines longer than the micro-line length keep their vertices.
        assert!(merge_lines(&moves_of(&pts), 0.01, 0.5).is_none());
    }

    proptest! {
        /// Both ways within eps: every programmed point within eps of the merged lines,
        /// every merged point (sampled) within eps of the programmed lines; the ends stay.
        #[test]
        fn merged_lines_stay_within_eps_both_ways(
            steps in proptest::collection::vec((-1.0f64..1.0, -1.0f64..1.0, -0.2f64..0.2), 2..60),
            scale in prop_oneof![Just(1e-3), Just(0.05), Just(1.0)],
            eps in 1e-4f64..0.01,
            micro in prop_oneof![Just(0.0), Just(0.01), Just(f64::INFINITY)],
        ) {
            let mut pts = vec![Vec3::ZERO];
            for (x, y, z) in steps {
                let last = pts[pts.len() - 1];
                pts.push(last + Vec3::new(x, y, z) * scale);
            }
            let moves = moves_of(&pts);
            let merged = merge_lines(&moves, eps, micro).unwrap_or_else(|| moves.clone());
            prop_assert_eq!(merged[0].segment.start(), pts[0]);
            prop_assert_eq!(merged[merged.len() - 1].segment.end(), pts[pts.len() - 1]);
            for w in merged.windows(2) {
                prop_assert_eq!(w[0].segment.end(), w[1].segment.start());
            }
            for &p in &pts {
                prop_assert!(polyline_dist(p, &merged) <= eps * (1.0 + 1e-9) + 1e-12);
            }
            for m in &merged {
                for k in 0..=16 {
                    let q = m.segment.start().lerp(m.segment.end(), k as f64 / 16.0);
                    prop_assert!(polyline_dist(q, &moves) <= eps * (1.0 + 1e-9) + 1e-12);
                }
            }
        }
    }
}
