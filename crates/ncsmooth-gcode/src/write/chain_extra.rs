//! Extra axes along a chain of long G1 blocks: a slicer's extrusion `E` carried through
//! the `lines` emitter's merging ([`crate::write::chain`]).
//!
//! A 3-D printer's program moves `E` with every extruding line. Writing each smoothed
//! piece on its own (as the writer did for every move with extra axes) gave Marlin and
//! Klipper 5-17 times the program's blocks, down to 0.0001 mm. Chained, the extruding
//! moves are one dense polyline as any other chain, and each dense point carries the
//! program's extra-axis values there, linear in arc length along every move (as the
//! controller moves them along a line, and as the writer spreads them over a flattened
//! curve):
//!
//! 1. a move boundary where the extrusion rate (E per mm of path) changes by more than
//!    [`EXTRA_RATE_VARIANCE`] of the rate the stretch started with is a hard point of the
//!    chain, always written ([`ExtraProfile::rate_breaks`]; ArcWelder's default
//!    "extrusion rate variance" is the same 5 %): a merged block never spreads a
//!    perimeter's flow over a travel or a thinner feature;
//! 2. every written point takes the values at its projection on the dense polyline
//!    ([`ExtraProfile::at`]), searched forward from the last one so that the values
//!    never run backwards along the chain; a point within the written rounding of a hard
//!    point takes that point's exact values, so the chain ends on the program's values.
//!
//! What it bounds: at every hard point, and at the chain's end, the written values are
//! the program's; in between, a written block's flow is the program's mean flow over the
//! moves it spans, all within [`EXTRA_RATE_VARIANCE`] of each other. Only the position
//! is held to the tolerance in millimetres; the extra axes are not a length of the path.

use crate::polyline::seg_dist;
use ncsmooth::geom::Vec3;
#[cfg(doc)]
use ncsmooth::path::EXTRA_RATE_VARIANCE;
use ncsmooth::path::{extra_rate, extra_rates_agree, ExtraAxes};

/// Extra-axis values along a chain's dense polyline.
#[derive(Debug, Default)]
pub struct ExtraProfile {
    /// Arc length of each dense point from the chain's start (mm).
    s_mm: Vec<f64>,
    /// Values at each dense point.
    values: Vec<ExtraAxes>,
    /// For each move, the dense index its end is at.
    move_ends: Vec<usize>,
    /// The chain's dense polyline and its hard points ([`ExtraProfile::attach`]).
    dense: Vec<Vec3>,
    hard: Vec<bool>,
    /// Dense segment the last written point projected onto.
    cursor: usize,
    /// Arc length of the last written point's projection (mm).
    last_s_mm: f64,
}

impl ExtraProfile {
    /// An empty profile starting at `start` with values `v0`.
    pub fn new(start_values: ExtraAxes) -> ExtraProfile {
        ExtraProfile {
            s_mm: vec![0.0],
            values: vec![start_values],
            ..ExtraProfile::default()
        }
    }

    /// Records the dense points `dense[from..]` (from the previous end, index `from - 1`)
    /// of a move that ends with `end` values (`None`: unchanged).
    pub fn push_move(&mut self, dense: &[Vec3], end: Option<&ExtraAxes>) {
        let i0 = self.values.len() - 1;
        let v0 = self.values[i0];
        let v1 = end.copied().unwrap_or(v0);
        for k in self.values.len()..dense.len() {
            let s = self.s_mm[k - 1] + dense[k - 1].dist(dense[k]);
            self.s_mm.push(s);
            self.values.push(v0);
        }
        let i1 = self.values.len() - 1;
        let len = self.s_mm[i1] - self.s_mm[i0];
        for k in i0 + 1..=i1 {
            let t = if len > 0.0 {
                (self.s_mm[k] - self.s_mm[i0]) / len
            } else {
                1.0
            };
            self.values[k] = lerp(&v0, &v1, t);
        }
        // A move that added no point (a zero-length step) moves the values at the last one.
        self.values[i1] = v1;
        self.move_ends.push(i1);
    }

    /// Marks in `hard` the move ends where an extra axis's rate (per mm of path) leaves
    /// the rate its stretch started with by more than [`EXTRA_RATE_VARIANCE`].
    pub fn rate_breaks(&self, hard: &mut [bool]) {
        let mut start = 0;
        let rates: Vec<ExtraAxes> = self
            .move_ends
            .iter()
            .map(|&end| {
                let len = self.s_mm[end] - self.s_mm[start];
                let r = extra_rate(&self.values[start], &self.values[end], len);
                start = end;
                r
            })
            .collect();
        let Some(mut first) = rates.first().copied() else {
            return;
        };
        for k in 1..rates.len() {
            if !extra_rates_agree(&first, &rates[k]) {
                hard[self.move_ends[k - 1]] = true;
                first = rates[k];
            }
        }
    }

    /// Keeps the chain's dense polyline (every move pushed) and its hard points, rate
    /// breaks included, for [`ExtraProfile::at`].
    pub fn attach(&mut self, dense: &[Vec3], hard: &[bool]) {
        self.dense = dense.to_vec();
        self.hard = hard.to_vec();
    }

    /// The values at `p`, a written point of the chain after the one before it (`len_mm`
    /// from it): those at its projection on the dense polyline, or at a hard point within
    /// `snap_mm` of it.
    pub fn at(&mut self, p: Vec3, len_mm: f64, snap_mm: f64) -> ExtraAxes {
        let (dense, hard) = (&self.dense, &self.hard);
        let reach = self.last_s_mm + 2.0 * len_mm + SEARCH_SLACK_MM;
        let mut best = (f64::INFINITY, self.cursor, self.last_s_mm);
        let mut j = self.cursor;
        while j + 1 < dense.len() && (j == self.cursor || self.s_mm[j] <= reach) {
            let (d, t) = seg_dist(p, dense[j], dense[j + 1]);
            if d < best.0 {
                let t = t.clamp(0.0, 1.0);
                let s = self.s_mm[j] + t * (self.s_mm[j + 1] - self.s_mm[j]);
                best = (d, j, s);
            }
            j += 1;
        }
        let (_, seg, mut s) = best;
        for k in [seg, seg + 1] {
            if hard.get(k) == Some(&true) && dense[k].dist(p) <= snap_mm {
                s = self.s_mm[k];
            }
        }
        self.cursor = seg;
        self.last_s_mm = s.max(self.last_s_mm);
        self.value_at(self.cursor, self.last_s_mm)
    }

    /// The values at dense point `k` (a written point that is one, as a fitted arc's end:
    /// its chord says nothing of how far along the chain it is).
    pub fn at_dense(&mut self, k: usize) -> ExtraAxes {
        let k = k.min(self.values.len() - 1);
        self.cursor = k.saturating_sub(1);
        self.last_s_mm = self.s_mm[k].max(self.last_s_mm);
        self.values[k]
    }

    /// The values at arc length `s_mm` on dense segment `seg` or the next ones.
    fn value_at(&self, mut seg: usize, s_mm: f64) -> ExtraAxes {
        let n = self.s_mm.len();
        if n == 1 {
            return self.values[0];
        }
        while seg + 2 < n && self.s_mm[seg + 1] < s_mm {
            seg += 1;
        }
        let (s0, s1) = (self.s_mm[seg], self.s_mm[(seg + 1).min(n - 1)]);
        if s_mm >= s1 {
            return self.values[(seg + 1).min(n - 1)];
        }
        let t = if s1 > s0 {
            (s_mm - s0) / (s1 - s0)
        } else {
            1.0
        };
        lerp(&self.values[seg], &self.values[seg + 1], t.clamp(0.0, 1.0))
    }
}

/// Arc length (mm) the projection search looks past twice the written block's length:
/// a written point is within the tolerance of the polyline, so its projection is never
/// farther along than that.
const SEARCH_SLACK_MM: f64 = 0.1;

fn lerp(a: &ExtraAxes, b: &ExtraAxes, t: f64) -> ExtraAxes {
    std::array::from_fn(|i| a[i] + (b[i] - a[i]) * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(v: f64) -> ExtraAxes {
        let mut a = [0.0; 7];
        a[6] = v;
        a
    }

    /// Three collinear moves along X: 0-1 extruding 0.1, 1-2 extruding 0.1 more, 2-3
    /// extruding 0.3 more (three times the rate).
    fn three_moves() -> (Vec<Vec3>, ExtraProfile) {
        let mut dense = vec![Vec3::ZERO];
        let mut prof = ExtraProfile::new(e(1.0));
        for (x, v) in [(1.0, 1.1), (2.0, 1.2), (3.0, 1.5)] {
            dense.push(Vec3::new(x - 0.5, 0.0, 0.0));
            dense.push(Vec3::new(x, 0.0, 0.0));
            prof.push_move(&dense, Some(&e(v)));
        }
        (dense, prof)
    }

    #[test]
    fn values_are_linear_along_each_move() {
        let (dense, mut prof) = three_moves();
        prof.attach(&dense, &vec![false; dense.len()]);
        let at = |prof: &mut ExtraProfile, x: f64| prof.at(Vec3::new(x, 1e-4, 0.0), 1.0, 0.0)[6];
        assert!((at(&mut prof, 0.25) - 1.025).abs() < 1e-12);
        assert!((at(&mut prof, 1.5) - 1.15).abs() < 1e-12);
        assert!((at(&mut prof, 2.5) - 1.35).abs() < 1e-12);
        // Never backwards: a point behind the last one keeps the last values.
        assert!((at(&mut prof, 2.0) - 1.35).abs() < 1e-12);
        assert!((at(&mut prof, 3.0) - 1.5).abs() < 1e-12);
    }

    #[test]
    fn a_change_of_flow_is_a_hard_point_and_a_steady_one_is_not() {
        let (dense, prof) = three_moves();
        let mut hard = vec![false; dense.len()];
        prof.rate_breaks(&mut hard);
        // Ends of moves are dense points 2, 4 (and 6, the end); the flow triples at 4.
        assert_eq!(hard, [false, false, false, false, true, false, false]);
    }

    #[test]
    fn a_slow_drift_of_flow_breaks_against_the_stretchs_first_rate() {
        let mut dense = vec![Vec3::ZERO];
        let mut prof = ExtraProfile::new(e(0.0));
        let mut v = 0.0;
        for k in 1..=10 {
            // Each move's rate is 2 % above the one before: 1.02^3 > 1.05.
            v += 1.02f64.powi(k);
            dense.push(Vec3::new(k as f64, 0.0, 0.0));
            prof.push_move(&dense, Some(&e(v)));
        }
        let mut hard = vec![false; dense.len()];
        prof.rate_breaks(&mut hard);
        let breaks: Vec<usize> = (0..hard.len()).filter(|&k| hard[k]).collect();
        assert_eq!(breaks, [3, 6, 9]);
    }

    #[test]
    fn a_point_near_a_hard_point_takes_its_exact_values() {
        let (dense, mut prof) = three_moves();
        let mut hard = vec![false; dense.len()];
        prof.rate_breaks(&mut hard);
        prof.attach(&dense, &hard);
        let p = Vec3::new(2.0 - 3e-5, 2e-5, 0.0);
        assert_eq!(prof.at(p, 2.0, 1e-4)[6], 1.2);
    }

    #[test]
    fn moves_without_extra_values_keep_them() {
        let mut dense = vec![Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0)];
        let mut prof = ExtraProfile::new(e(2.0));
        prof.push_move(&dense, None);
        dense.push(Vec3::new(2.0, 0.0, 0.0));
        prof.push_move(&dense, Some(&e(3.0)));
        let mut hard = vec![false; dense.len()];
        prof.rate_breaks(&mut hard);
        assert!(hard[1]);
        prof.attach(&dense, &hard);
        let mid = prof.at(Vec3::new(0.5, 0.0, 0.0), 0.5, 0.0);
        assert_eq!(mid[6], 2.0);
    }
}
