//! Descriptive statistics of a toolpath, for `ncsmooth inspect` and the reports: move
//! counts, lengths, segment-length percentiles, a histogram of corner angles, the bounding
//! box.

use crate::geom::{Aabb, ParamCurveArclen, ParamCurveBBox, Segment};
use crate::path::{MoveKind, Toolpath};
use crate::smooth::turn_angle_deg;
use crate::verify::DEGENERATE_MM;
use serde::Serialize;

/// Accuracy (mm) of curve lengths in the statistics.
const STATS_ARCLEN_ACCURACY: f64 = 1e-6;

/// Upper edges (degrees) of the corner-angle histogram bins; the last bin ends at 180.
pub const CORNER_BINS_DEG: [f64; 8] = [0.01, 1.0, 5.0, 15.0, 30.0, 60.0, 90.0, 135.0];

/// Percentiles of a length distribution (mm).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct LengthStats {
    /// Smallest.
    pub min: f64,
    /// 10th percentile.
    pub p10: f64,
    /// Median.
    pub median: f64,
    /// 90th percentile.
    pub p90: f64,
    /// Largest.
    pub max: f64,
}

/// One histogram bin of corner (turning) angles between consecutive feed moves.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AngleBin {
    /// Lower edge (degrees, inclusive).
    pub from_deg: f64,
    /// Upper edge (degrees, exclusive; the last bin includes 180).
    pub to_deg: f64,
    /// Number of junctions.
    pub count: usize,
}

/// Statistics of a toolpath.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PathStats {
    /// Rapid moves.
    pub rapids: usize,
    /// Feed lines.
    pub feed_lines: usize,
    /// Feed arcs (circular or helical).
    pub feed_arcs: usize,
    /// Feed curves (splines).
    pub feed_curves: usize,
    /// Events (non-motion blocks).
    pub events: usize,
    /// Feed moves shorter than [`DEGENERATE_MM`].
    pub zero_length_moves: usize,
    /// Total feed length (mm).
    pub feed_length_mm: f64,
    /// Total rapid length (mm).
    pub rapid_length_mm: f64,
    /// Length distribution of the non-zero feed moves (mm).
    pub feed_segment_length_mm: LengthStats,
    /// Turning angles between consecutive feed moves of a chain.
    pub corner_angles: Vec<AngleBin>,
    /// Bounding box of all moves (mm), `None` for an empty program.
    pub bbox: Option<Aabb>,
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let idx = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[idx]
}

impl PathStats {
    /// Computes the statistics.
    pub fn of(tp: &Toolpath) -> PathStats {
        let mut s = PathStats {
            rapids: 0,
            feed_lines: 0,
            feed_arcs: 0,
            feed_curves: 0,
            events: tp.events().count(),
            zero_length_moves: 0,
            feed_length_mm: 0.0,
            rapid_length_mm: 0.0,
            feed_segment_length_mm: LengthStats::default(),
            corner_angles: Vec::new(),
            bbox: None,
        };
        let mut lengths = Vec::new();
        let mut bbox = Aabb::EMPTY;
        let mut bins = [0usize; CORNER_BINS_DEG.len() + 1];
        let mut prev: Option<&Segment> = None;
        for b in &tp.blocks {
            let m = match b {
                crate::path::Block::Move(m) => m,
                crate::path::Block::Event(_) => {
                    prev = None;
                    continue;
                }
            };
            bbox = bbox.union(m.segment.bounding_box());
            let len = m.segment.arclen(STATS_ARCLEN_ACCURACY);
            if m.kind == MoveKind::Rapid {
                s.rapids += 1;
                s.rapid_length_mm += len;
                prev = None;
                continue;
            }
            match &m.segment {
                Segment::Line(_) => s.feed_lines += 1,
                Segment::Arc(_) => s.feed_arcs += 1,
                _ => s.feed_curves += 1,
            }
            s.feed_length_mm += len;
            if len <= DEGENERATE_MM {
                s.zero_length_moves += 1;
                continue;
            }
            lengths.push(len);
            if let Some(p) = prev {
                if let Some(a) = turn_angle_deg(p, &m.segment) {
                    let bin = CORNER_BINS_DEG
                        .iter()
                        .position(|&edge| a < edge)
                        .unwrap_or(CORNER_BINS_DEG.len());
                    bins[bin] += 1;
                }
            }
            prev = Some(&m.segment);
        }
        lengths.sort_by(f64::total_cmp);
        s.feed_segment_length_mm = LengthStats {
            min: lengths.first().copied().unwrap_or(0.0),
            p10: percentile(&lengths, 0.1),
            median: percentile(&lengths, 0.5),
            p90: percentile(&lengths, 0.9),
            max: lengths.last().copied().unwrap_or(0.0),
        };
        let mut lo = 0.0;
        for (i, &count) in bins.iter().enumerate() {
            let hi = CORNER_BINS_DEG.get(i).copied().unwrap_or(180.0);
            s.corner_angles.push(AngleBin {
                from_deg: lo,
                to_deg: hi,
                count,
            });
            lo = hi;
        }
        s.bbox = (!bbox.is_empty()).then_some(bbox);
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Line, Vec3};
    use crate::path::Move;

    #[test]
    fn counts_and_angles() {
        let pts = [
            Vec3::ZERO,
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
            Vec3::new(20.0, 20.0, 0.0),
        ];
        let mut tp = Toolpath::from_polyline(&pts, Some(5.0));
        tp.push_move(Move::rapid(
            Line::new(Vec3::new(20.0, 20.0, 0.0), Vec3::new(20.0, 20.0, 5.0)),
            9,
        ));
        let s = PathStats::of(&tp);
        assert_eq!((s.rapids, s.feed_lines, s.zero_length_moves), (1, 4, 1));
        assert!((s.rapid_length_mm - 5.0).abs() < 1e-12);
        assert!((s.feed_length_mm - (20.0 + 200f64.sqrt())).abs() < 1e-12);
        let angles: Vec<usize> = s.corner_angles.iter().map(|b| b.count).collect();
        // A 90-degree corner, and a 45-degree one across the zero-length move (which has
        // no direction of its own and is skipped).
        assert_eq!(angles.iter().sum::<usize>(), 2);
        let bins: Vec<f64> = s
            .corner_angles
            .iter()
            .filter(|b| b.count == 1)
            .map(|b| b.from_deg)
            .collect();
        assert_eq!(bins, vec![30.0, 90.0]);
        assert_eq!(s.bbox.unwrap().max, Vec3::new(20.0, 20.0, 5.0));
        assert_eq!(s.feed_segment_length_mm.max, 200f64.sqrt());
    }
}
