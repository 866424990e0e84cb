//! The block floor: blocks shorter than a controller should be given lifted against the
//! programmed path, within its tolerance ([`lift_short_blocks`]), with the spatial grid
//! over the programmed polyline its queries use ([`SegmentGrid`]).

use crate::controller::linuxcnc::blend::{vertex_room, VertexRoom, ROOM_SAMPLES};
use crate::controller::linuxcnc::CornerBlend;
use crate::polyline::seg_dist;
use ncsmooth::geom::{segment_meets_box, SegmentGrid, Vec3};

/// The programmed path of the moves being written and the tolerance left for the written
/// blocks against it: blocks shorter than `min_block_mm` are lifted where the program
/// allows ([`crate::controller::floor::lift_short_blocks`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Floor {
    /// The programmed path as a polyline (mm).
    pub program: Vec<Vec3>,
    /// Two-sided tolerance (mm) of the written blocks against `program`.
    pub tol_mm: f64,
    /// Shortest block the controller should be given (mm).
    pub min_block_mm: f64,
    /// The grid over `program`, built when a first short block needs it.
    pub grid: std::cell::OnceCell<SegmentGrid>,
    /// LinuxCNC: short blocks are lifted only to the programmed corner, which gets a `P`
    /// of its own.
    pub corner: Option<CornerBlend>,
}

impl Floor {
    /// The programmed path as the block floor's [`ProgrammedPath`].
    pub(crate) fn program_ref(&self) -> ProgrammedPath<'_> {
        ProgrammedPath {
            points: &self.program,
            tol_mm: self.tol_mm,
        }
    }

    /// The room of each point of the chain from `start` through `pts` (not the last) that
    /// is `wanted` or a programmed corner put in place of short blocks (`snapped`), under
    /// LinuxCNC ([`vertex_room`]); `None` for the others, and for all without
    /// [`Floor::corner`].
    pub(crate) fn rooms(
        &self,
        start: Vec3,
        pts: &[Vec3],
        snapped: &[Vec3],
        wanted: &[bool],
    ) -> Vec<Option<VertexRoom>> {
        let Some(c) = self.corner else {
            return Vec::new();
        };
        let program = self.program_ref();
        let grid = self.grid.get_or_init(|| program.grid());
        let line_dev = |a: Vec3, b: Vec3| program.max_dist_near(grid, a, b, ROOM_SAMPLES);
        let gap = |lines: &[(Vec3, Vec3)], others: &[(Vec3, Vec3)]| {
            program.vertex_gap(grid, lines, others, c.total_mm)
        };
        (0..pts.len().saturating_sub(1))
            .map(|k| {
                let corner = snapped.contains(&pts[k]);
                (corner || wanted.get(k) == Some(&true))
                    .then(|| vertex_room(k, start, pts, corner, c, line_dev, gap))
            })
            .collect()
    }
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
pub struct ProgrammedPath<'a> {
    /// The programmed path as a polyline (mm).
    pub points: &'a [Vec3],
    /// Largest distance (mm), both ways, between the written blocks and `points`.
    pub tol_mm: f64,
}

impl ProgrammedPath<'_> {
    /// Distance from `p` to the programmed segments `segs` (indices of their starts).
    fn dist(&self, p: Vec3, segs: &[usize]) -> f64 {
        segs.iter()
            .map(|&k| seg_dist(p, self.points[k], self.points[k + 1]).0)
            .fold(f64::INFINITY, f64::min)
    }

    /// Starts of the programmed segments that come within `margin` (on every axis) of the
    /// box of `a`-`b`: the grid's candidates (or all segments when it has none to give)
    /// that meet the padded box.
    fn near(&self, grid: &SegmentGrid, a: Vec3, b: Vec3, margin: f64, out: &mut Vec<usize>) {
        let pad = Vec3::new(margin, margin, margin);
        let (lo, hi) = (a.min(b) - pad, a.max(b) + pad);
        if !grid.candidates(lo, hi, out) {
            out.clear();
            out.extend(0..self.points.len().saturating_sub(1));
        }
        let pts = self.points;
        out.retain(|&k| segment_meets_box(pts[k], pts[k + 1], lo, hi));
    }

    /// Whether every point of the segment `a`-`b` lies within the tolerance of the
    /// programmed path.
    fn covers(&self, grid: &SegmentGrid, a: Vec3, b: Vec3, scratch: &mut Vec<usize>) -> bool {
        let step = self.tol_mm / SAMPLES_PER_TOL;
        let within = self.tol_mm - 0.5 * step;
        self.near(grid, a, b, self.tol_mm, scratch);
        let n = (a.dist(b) / step).ceil().max(1.0) as usize;
        (0..=n).all(|i| self.dist(a + (b - a) * (i as f64 / n as f64), scratch) <= within)
    }

    /// The programmed vertices inside the box `lo`-`hi`, appended to `out`.
    fn vertices_in(&self, grid: &SegmentGrid, lo: Vec3, hi: Vec3, out: &mut Vec<Vec3>) {
        let inside = |v: &Vec3| v.min(lo) == lo && v.max(hi) == hi;
        match self.vertex_candidates(grid, lo, hi) {
            Some(ks) => out.extend(ks.into_iter().map(|k| self.points[k]).filter(inside)),
            None => out.extend(self.points.iter().copied().filter(inside)),
        }
    }

    /// Indices of the programmed vertices that may lie in the box `lo`-`hi` (the ends of
    /// the grid's candidate segments), sorted and unique; `None` when the grid has none
    /// to give and every vertex is a candidate.
    fn vertex_candidates(&self, grid: &SegmentGrid, lo: Vec3, hi: Vec3) -> Option<Vec<usize>> {
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
    fn nearest_vertex(&self, grid: &SegmentGrid, p: Vec3) -> Option<Vec3> {
        let by_dist = |a: &Vec3, b: &Vec3| a.dist(p).total_cmp(&b.dist(p));
        let mut r = grid.cell_mm();
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

/// The grid over a program's segments for [`lift_short_blocks`]' queries (the segments
/// near a written block, the vertices near a replacement, the vertex nearest a block),
/// which would otherwise scan the run's whole programmed polyline. Cells are four
/// tolerances or the mean segment length, the larger.
fn seg_grid(points: &[Vec3], tol_mm: f64) -> SegmentGrid {
    let n = points.len().saturating_sub(1);
    let total: f64 = points.windows(2).map(|w| w[0].dist(w[1])).sum();
    let mean = if n > 0 { total / n as f64 } else { 0.0 };
    let cell = (4.0 * tol_mm).max(mean).max(1e-6);
    SegmentGrid::new(points.windows(2).map(|w| (w[0], w[1])), cell)
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
    program: &ProgrammedPath,
    grid: &SegmentGrid,
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
    program: &ProgrammedPath,
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
    /// LinuxCNC stops before the rapid at the full acceleration (at the program's end the
    /// last segment keeps a parabolic blend's half acceleration, so a corner there is
    /// slower). Without it a V stroke plunging and rising again before a rapid keeps a
    /// block of 0.005-0.01 mm at the bottom, which caps LinuxCNC's blend there at half
    /// its length.
    pub last_block: bool,
    /// The programmed vertices put in place of short blocks.
    pub snapped: Vec<Vec3>,
}

impl ProgrammedPath<'_> {
    /// The grid over the programmed segments, for [`ProgrammedPath::max_dist_near`] and
    /// [`ProgrammedPath::vertex_gap`].
    pub(crate) fn grid(&self) -> SegmentGrid {
        seg_grid(self.points, self.tol_mm)
    }

    /// The largest distance from a programmed vertex within `within` of the segments
    /// `lines` to the nearest of them, over the vertices no nearer to any of `others`
    /// (0 where there is none).
    pub(crate) fn vertex_gap(
        &self,
        grid: &SegmentGrid,
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
    pub(crate) fn max_dist_near(
        &self,
        grid: &SegmentGrid,
        a: Vec3,
        b: Vec3,
        samples: usize,
    ) -> f64 {
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
    program: &ProgrammedPath,
    grid: &std::cell::OnceCell<SegmentGrid>,
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
        let grid = grid.get_or_init(|| seg_grid(program.points, program.tol_mm));
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
    use crate::write::chain::tests::{dist_to_polyline, one_sided};
    use proptest::prelude::*;

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
        let prog = ProgrammedPath {
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
        let prog = ProgrammedPath {
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
        let prog = ProgrammedPath {
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
            let prog = ProgrammedPath { points: &pts, tol_mm: 0.01 };
            let grid = seg_grid(&pts, prog.tol_mm);
            let c = Vec3::new(q.0, q.1, 0.0) * scale.sqrt();
            let (a, b) = (c, c + Vec3::new(q.2, -q.2, 0.0));
            let mut got = Vec::new();
            prog.near(&grid, a, b, prog.tol_mm, &mut got);
            let pad = Vec3::new(0.01, 0.01, 0.01);
            let (lo, hi) = (a.min(b) - pad, a.max(b) + pad);
            let want: Vec<usize> = (0..pts.len() - 1)
                .filter(|&k| segment_meets_box(pts[k], pts[k + 1], lo, hi))
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
            let prog = ProgrammedPath { points: &program, tol_mm: tol };
            lift_short_blocks(Vec3::ZERO, &mut pts, 0.03, &prog, |p| p);
            let mut out = vec![Vec3::ZERO];
            out.extend_from_slice(&pts);
            prop_assert!(one_sided(&out, &program) <= tol + 1e-12);
            prop_assert!(program.iter().all(|&v| dist_to_polyline(v, &out) <= tol + 1e-12));
            prop_assert_eq!(*out.last().unwrap(), *program.last().unwrap());
        }
    }
}
