//! Descriptive statistics of a toolpath, for `ncsmooth inspect` and the reports: move
//! counts, lengths, segment-length percentiles, a histogram of corner angles, the bounding
//! box.

use crate::geom::{Aabb, ParamCurveArclen, ParamCurveBBox, Segment};
use crate::path::{Block, MoveKind, Toolpath};
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

/// Feed-segment lengths a [`PathStatsBuilder`] keeps exactly; beyond, it counts them in
/// [`LengthHistogram`] bins, so that its memory does not grow with the program.
pub(crate) const EXACT_LENGTHS_MAX: usize = 1 << 20;

/// Mantissa bits of a [`LengthHistogram`] bin: a bin spans a relative width of
/// `2^-LENGTH_BIN_BITS` (1.5e-5), and a percentile read from it (its centre) is within
/// half of that of the exact one.
const LENGTH_BIN_BITS: u32 = 16;

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    sorted[percentile_rank(sorted.len(), q)]
}

/// Index of the `q` percentile in `n` sorted values (the nearest rank).
fn percentile_rank(n: usize, q: f64) -> usize {
    ((n - 1) as f64 * q).round() as usize
}

/// Counts of positive lengths in bins of relative width `2^-LENGTH_BIN_BITS` (a bin is
/// the length's exponent and leading mantissa bits), one dense table per binary octave
/// that occurs: memory bounded by the octaves of the lengths (lengths from 1e-9 mm to
/// 1e10 mm span 64), not by their number.
#[derive(Clone, Debug, Default)]
struct LengthHistogram {
    /// Counts by octave (the f64 exponent), each `2^LENGTH_BIN_BITS` bins.
    octaves: std::collections::BTreeMap<u64, Vec<u64>>,
    count: usize,
}

impl LengthHistogram {
    fn push(&mut self, len: f64) {
        let bits = len.to_bits();
        let octave = bits >> 52;
        let bin = ((bits >> (52 - LENGTH_BIN_BITS)) & ((1 << LENGTH_BIN_BITS) - 1)) as usize;
        let table = self
            .octaves
            .entry(octave)
            .or_insert_with(|| vec![0; 1 << LENGTH_BIN_BITS]);
        table[bin] += 1;
        self.count += 1;
    }

    /// The centre of the bin holding the value of sorted rank `rank`.
    fn at_rank(&self, rank: usize) -> f64 {
        let mut seen = 0usize;
        for (&octave, table) in &self.octaves {
            for (bin, &c) in table.iter().enumerate() {
                seen += c as usize;
                if seen > rank {
                    let lo = (octave << 52) | ((bin as u64) << (52 - LENGTH_BIN_BITS));
                    let hi = lo + (1 << (52 - LENGTH_BIN_BITS));
                    return 0.5 * (f64::from_bits(lo) + f64::from_bits(hi));
                }
            }
        }
        0.0
    }
}

/// [`PathStats`] of a program handed over block by block, in memory that does not grow
/// with it (`ncsmooth inspect` of a file of any size). The percentiles of the feed-segment
/// lengths are exact up to 2^20 feed moves; beyond, they are read from
/// bins of relative width 1.5e-5 (the minimum and the maximum stay exact).
///
/// ```
/// use ncsmooth::geom::Vec3;
/// use ncsmooth::path::Toolpath;
/// use ncsmooth::{PathStats, PathStatsBuilder};
///
/// let square = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y, Vec3::ZERO];
/// let tp = Toolpath::from_polyline(&square, Some(10.0));
/// let mut b = PathStatsBuilder::new();
/// for block in &tp.blocks {
///     b.push(block);
/// }
/// let s = b.finish();
/// assert_eq!(s, PathStats::of(&tp));
/// assert_eq!((s.feed_lines, s.feed_length_mm), (4, 4.0));
/// ```
#[derive(Clone, Debug)]
pub struct PathStatsBuilder {
    s: PathStats,
    lengths: Vec<f64>,
    histogram: Option<LengthHistogram>,
    min_len: f64,
    max_len: f64,
    bbox: Aabb,
    bins: [usize; CORNER_BINS_DEG.len() + 1],
    /// End tangent of the previous feed move of the chain (none after an event, a rapid
    /// or a move without a direction).
    prev_tangent: Option<crate::geom::Vec3>,
}

impl Default for PathStatsBuilder {
    fn default() -> Self {
        Self::new()
    }
}

impl PathStatsBuilder {
    /// Statistics of an empty program, to push blocks into.
    pub fn new() -> Self {
        PathStatsBuilder {
            s: PathStats {
                rapids: 0,
                feed_lines: 0,
                feed_arcs: 0,
                feed_curves: 0,
                events: 0,
                zero_length_moves: 0,
                feed_length_mm: 0.0,
                rapid_length_mm: 0.0,
                feed_segment_length_mm: LengthStats::default(),
                corner_angles: Vec::new(),
                bbox: None,
            },
            lengths: Vec::new(),
            histogram: None,
            min_len: f64::INFINITY,
            max_len: 0.0,
            bbox: Aabb::EMPTY,
            bins: [0; CORNER_BINS_DEG.len() + 1],
            prev_tangent: None,
        }
    }

    /// Counts the next block of the program.
    pub fn push(&mut self, b: &Block) {
        let m = match b {
            Block::Move(m) => m,
            Block::Event(_) => {
                self.s.events += 1;
                self.prev_tangent = None;
                return;
            }
        };
        let s = &mut self.s;
        self.bbox = self.bbox.union(m.segment.bounding_box());
        let len = m.segment.arclen(STATS_ARCLEN_ACCURACY);
        if m.kind == MoveKind::Rapid {
            s.rapids += 1;
            s.rapid_length_mm += len;
            self.prev_tangent = None;
            return;
        }
        match &m.segment {
            Segment::Line(_) => s.feed_lines += 1,
            Segment::Arc(_) => s.feed_arcs += 1,
            _ => s.feed_curves += 1,
        }
        s.feed_length_mm += len;
        if len <= DEGENERATE_MM {
            s.zero_length_moves += 1;
            return;
        }
        self.push_length(len);
        if let Some(t) = self.prev_tangent {
            if let Some(a) = m
                .segment
                .start_tangent()
                .map(|u| t.angle_to(u).to_degrees())
            {
                let bin = CORNER_BINS_DEG
                    .iter()
                    .position(|&edge| a < edge)
                    .unwrap_or(CORNER_BINS_DEG.len());
                self.bins[bin] += 1;
            }
        }
        self.prev_tangent = m.segment.end_tangent();
    }

    fn push_length(&mut self, len: f64) {
        self.min_len = self.min_len.min(len);
        self.max_len = self.max_len.max(len);
        if let Some(h) = &mut self.histogram {
            h.push(len);
        } else if self.lengths.len() < EXACT_LENGTHS_MAX {
            self.lengths.push(len);
        } else {
            let mut h = LengthHistogram::default();
            for &l in &self.lengths {
                h.push(l);
            }
            h.push(len);
            self.lengths = Vec::new();
            self.histogram = Some(h);
        }
    }

    /// The statistics of the blocks pushed.
    pub fn finish(mut self) -> PathStats {
        let mut s = self.s;
        s.feed_segment_length_mm = match &self.histogram {
            Some(h) => LengthStats {
                min: self.min_len,
                p10: h.at_rank(percentile_rank(h.count, 0.1)),
                median: h.at_rank(percentile_rank(h.count, 0.5)),
                p90: h.at_rank(percentile_rank(h.count, 0.9)),
                max: self.max_len,
            },
            None => {
                let l = &mut self.lengths;
                l.sort_by(f64::total_cmp);
                LengthStats {
                    min: l.first().copied().unwrap_or(0.0),
                    p10: percentile(l, 0.1),
                    median: percentile(l, 0.5),
                    p90: percentile(l, 0.9),
                    max: l.last().copied().unwrap_or(0.0),
                }
            }
        };
        let mut lo = 0.0;
        for (i, &count) in self.bins.iter().enumerate() {
            let hi = CORNER_BINS_DEG.get(i).copied().unwrap_or(180.0);
            s.corner_angles.push(AngleBin {
                from_deg: lo,
                to_deg: hi,
                count,
            });
            lo = hi;
        }
        s.bbox = (!self.bbox.is_empty()).then_some(self.bbox);
        s
    }
}

impl PathStats {
    /// Computes the statistics ([`PathStatsBuilder`] over every block).
    pub fn of(tp: &Toolpath) -> PathStats {
        let mut b = PathStatsBuilder::new();
        for block in &tp.blocks {
            b.push(block);
        }
        b.finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Line, Vec3};
    use crate::path::Move;

    /// Past the exact regime the percentiles come from the bins, within half a bin's
    /// relative width of the exact ones; the extremes stay exact.
    #[test]
    fn percentiles_beyond_the_exact_regime_are_within_half_a_bin() {
        let n = EXACT_LENGTHS_MAX + 12_345;
        let mut r = 0x2545_f491_4f6c_dd1d_u64;
        let mut lengths = Vec::with_capacity(n);
        let mut b = PathStatsBuilder::new();
        let mut p = Vec3::ZERO;
        for _ in 0..n {
            r ^= r << 13;
            r ^= r >> 7;
            r ^= r << 17;
            // Lengths from 1e-4 to 10 mm, log-uniform.
            let len = 10f64.powf(-4.0 + 5.0 * (r >> 11) as f64 / (1u64 << 53) as f64);
            let q = p + Vec3::new(len, 0.0, 0.0);
            b.push(&Block::Move(Move::feed(Line::new(p, q), Some(10.0), 1)));
            lengths.push(q.x - p.x);
            p = q;
        }
        let s = b.finish();
        lengths.sort_by(f64::total_cmp);
        let l = &s.feed_segment_length_mm;
        assert_eq!((l.min, l.max), (lengths[0], lengths[n - 1]));
        let half_bin = 2f64.powi(-(LENGTH_BIN_BITS as i32) - 1);
        for (got, q) in [(l.p10, 0.1), (l.median, 0.5), (l.p90, 0.9)] {
            let exact = percentile(&lengths, q);
            assert!(
                (got - exact).abs() <= half_bin * exact,
                "{q}: {got} vs {exact}"
            );
        }
    }

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
