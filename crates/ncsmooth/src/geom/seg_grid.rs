//! A uniform grid over line segments, for box queries: the segments that may meet a box.
//!
//! Each segment is cut into pieces at most one cell long and entered in every cell its
//! pieces' bounding boxes touch (at most 8 per piece), so a segment of length `L` costs at
//! most `8 (L / cell + 1)` entries and a segment that meets a box is listed in one of the
//! box's cells. A query returns a superset of the segments meeting the box, sorted and
//! unique; callers apply their exact test to it. The grid is the one box index of the
//! project: the stepper controllers' short-block lifting (`ncsmooth-gcode`) and the
//! extrusion check of [`crate::verify`] use it. Nearest-distance queries over a smoothed
//! path's arcs and curves use the verifier's bounding-volume hierarchy instead (a different
//! query: a nearest hit pruned by distance, not a box).

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use super::Vec3;

/// Hasher of the grid's cell keys: three integers, mixed by multiplication (the keys are
/// the program's own coordinates, not an adversary's, and SipHash's resistance to chosen
/// keys cost most of building the grid).
#[derive(Default)]
struct CellHasher(u64);

impl Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        // (A key's three integers come as one slice of 24 bytes.)
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }

    fn write_i64(&mut self, v: i64) {
        self.write_u64(v as u64);
    }

    fn write_u64(&mut self, v: u64) {
        // FxHash's step: rotate, xor, multiply by an odd constant near 2^64 / phi.
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
}

type Cells = HashMap<[i64; 3], Vec<usize>, BuildHasherDefault<CellHasher>>;

/// Largest number of cells a query looks at; [`SegmentGrid::candidates`] returns `false`
/// for a larger box and the caller scans every segment.
pub(crate) const MAX_QUERY_CELLS: i64 = 4096;

/// Largest number of pieces a segment is cut into; a longer (or non-finite) segment is a
/// candidate of every query.
pub(crate) const MAX_SEGMENT_PIECES: f64 = 65536.0;

/// Relative padding of a piece's box: the pieces' interior ends are rounded points of the
/// segment, and the padding keeps the segment itself inside the union of the boxes.
const PIECE_PAD: f64 = 1e-9;

/// Uniform grid of segment indices (see the module doc).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SegmentGrid {
    cell_mm: f64,
    cells: Cells,
    /// Segments too long (or not finite) to enter: candidates of every query.
    wide: Vec<usize>,
}

impl SegmentGrid {
    /// The grid of `segments` (indexed in iteration order) with cells of `cell_mm` (mm; a
    /// non-positive or non-finite size is taken as 1 um).
    ///
    /// ```
    /// use ncsmooth::geom::{SegmentGrid, Vec3};
    /// let segs = [(Vec3::ZERO, Vec3::new(10.0, 0.0, 0.0)), (Vec3::new(0.0, 5.0, 0.0), Vec3::new(10.0, 5.0, 0.0))];
    /// let grid = SegmentGrid::new(segs, 1.0);
    /// let mut out = Vec::new();
    /// assert!(grid.candidates(Vec3::new(4.0, -0.5, -0.5), Vec3::new(4.5, 0.5, 0.5), &mut out));
    /// assert_eq!(out, [0]);
    /// ```
    pub fn new(segments: impl IntoIterator<Item = (Vec3, Vec3)>, cell_mm: f64) -> SegmentGrid {
        let cell_mm = if cell_mm.is_finite() && cell_mm > 0.0 {
            cell_mm
        } else {
            1e-6
        };
        let mut grid = SegmentGrid {
            cell_mm,
            cells: Cells::default(),
            wide: Vec::new(),
        };
        for (k, (a, b)) in segments.into_iter().enumerate() {
            grid.enter(k, a, b);
        }
        grid
    }

    /// Cell size (mm).
    pub fn cell_mm(&self) -> f64 {
        self.cell_mm
    }

    fn enter(&mut self, k: usize, a: Vec3, b: Vec3) {
        let pieces = (a.dist(b) / self.cell_mm).ceil().max(1.0);
        if !(a.is_finite() && b.is_finite()) || pieces > MAX_SEGMENT_PIECES {
            self.wide.push(k);
            return;
        }
        let n = pieces as usize;
        let pad = PIECE_PAD * self.cell_mm;
        let pad = Vec3::new(pad, pad, pad);
        let at = |i: usize| {
            if i == n {
                b
            } else {
                a + (b - a) * (i as f64 / n as f64)
            }
        };
        for i in 0..n {
            let (p, q) = (at(i), at(i + 1));
            let (lo, hi) = (self.key(p.min(q) - pad), self.key(p.max(q) + pad));
            for x in lo[0]..=hi[0] {
                for y in lo[1]..=hi[1] {
                    for z in lo[2]..=hi[2] {
                        let v = self.cells.entry([x, y, z]).or_default();
                        if v.last() != Some(&k) {
                            v.push(k);
                        }
                    }
                }
            }
        }
    }

    fn key(&self, p: Vec3) -> [i64; 3] {
        [p.x, p.y, p.z].map(|v| (v / self.cell_mm).floor() as i64)
    }

    /// The segments that may meet the box `lo`-`hi` (every one that does, perhaps more),
    /// sorted and unique, in `out`; `false` (and `out` empty) when the box spans more than
    /// 4096 cells or is not finite, and the caller must scan every segment.
    pub fn candidates(&self, lo: Vec3, hi: Vec3, out: &mut Vec<usize>) -> bool {
        out.clear();
        if !(lo.is_finite() && hi.is_finite()) {
            return false;
        }
        let (a, b) = (self.key(lo), self.key(hi));
        let cells = (0..3)
            .map(|i| b[i].saturating_sub(a[i]).saturating_add(1).max(0))
            .fold(1i64, |acc, c| acc.saturating_mul(c));
        if cells > MAX_QUERY_CELLS {
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

/// Whether the segment `a`-`b` meets the closed box `lo`-`hi` (the slab test).
pub fn segment_meets_box(a: Vec3, b: Vec3, lo: Vec3, hi: Vec3) -> bool {
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, d, l, h) in [
        (a.x, b.x - a.x, lo.x, hi.x),
        (a.y, b.y - a.y, lo.y, hi.y),
        (a.z, b.z - a.z, lo.z, hi.z),
    ] {
        if d == 0.0 {
            if p < l || p > h {
                return false;
            }
        } else {
            let (u, v) = ((l - p) / d, (h - p) / d);
            t0 = t0.max(u.min(v));
            t1 = t1.min(u.max(v));
        }
    }
    t0 <= t1
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn v3() -> impl Strategy<Value = Vec3> {
        (-20.0..20.0f64, -20.0..20.0f64, -2.0..2.0f64).prop_map(|(x, y, z)| Vec3::new(x, y, z))
    }

    proptest! {
        #[test]
        fn every_segment_meeting_a_box_is_a_candidate(
            segs in prop::collection::vec((v3(), v3()), 1..40),
            c in v3(),
            half in 0.0..3.0f64,
            cell in 0.3..5.0f64,
        ) {
            let grid = SegmentGrid::new(segs.iter().copied(), cell);
            let h = Vec3::new(half, half, half * 0.5);
            let (lo, hi) = (c - h, c + h);
            let mut out = Vec::new();
            prop_assert!(grid.candidates(lo, hi, &mut out));
            for (k, &(a, b)) in segs.iter().enumerate() {
                if segment_meets_box(a, b, lo, hi) {
                    prop_assert!(out.binary_search(&k).is_ok(), "segment {k} missed");
                }
            }
            prop_assert!(out.windows(2).all(|w| w[0] < w[1]));
        }
    }

    #[test]
    fn huge_boxes_and_segments_fall_back() {
        let far = Vec3::new(1e12, 0.0, 0.0);
        let grid = SegmentGrid::new([(Vec3::ZERO, far), (Vec3::ZERO, Vec3::X)], 1.0);
        let mut out = Vec::new();
        assert!(grid.candidates(
            Vec3::new(5e11, -1.0, -1.0),
            Vec3::new(5e11, 1.0, 1.0),
            &mut out
        ));
        assert_eq!(out, [0]);
        assert!(!grid.candidates(Vec3::ZERO, Vec3::new(100.0, 100.0, 100.0), &mut out));
        assert!(out.is_empty());
        let nan = Vec3::new(f64::NAN, 0.0, 0.0);
        assert!(!grid.candidates(nan, Vec3::ZERO, &mut out));
    }
}
