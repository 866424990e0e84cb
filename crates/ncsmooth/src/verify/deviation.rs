//! Two-sided deviation between an output path and the programmed path, the measure the
//! tolerance contract is stated in:
//!
//! * (a) `output_to_programmed`: the largest distance from any point of the output path
//!   to the programmed path (a directed Hausdorff distance), and
//! * (b) `vertex_to_output`: the largest distance from any programmed vertex (start, end
//!   and every junction of two moves) to the output path.
//!
//! ## Algorithm
//! Both paths become exact primitives (lines and planar arcs; helical arcs and free-form
//! curves are flattened with chord error `accuracy / 4`, see [`Flatten`](crate::geom::Flatten))
//! indexed by a bounding-volume hierarchy.
//!
//! (b) is a nearest-primitive query per vertex. (a) is a branch and bound over each output
//! primitive: the distance `f` to the programmed path is 1-Lipschitz along the arc length,
//! so on a piece of length `l` with end values `d0`, `d1` it never exceeds
//! `(d0 + d1 + l) / 2`. Sharper bounds against the programmed primitives nearest to the
//! piece's ends prune the common cases at once: along a straight piece the distance to
//! one fixed programmed line is convex, so `f <= max` of the end distances to that line;
//! along a circular piece it is at most that plus the piece's sagitta (the piece leaves
//! its chord by no more); and the distance from a straight or circular piece to a
//! programmed planar arc, where
//! the piece's nearest points on its circle stay inside its sweep, has its exact maximum
//! in closed form ([`PlanarArc::arc_piece_max`], [`PlanarArc::segment_max`]: an output
//! arc that follows a programmed one, a few rounding units off its circle, is bounded in
//! one step; the Lipschitz bound alone needs pieces of `accuracy` length there, 43 M
//! queries on linuxcnc_arcspiral); an arc piece against a programmed line in its plane
//! has the same ([`PlanarArc::piece_max_to_line`]), and a piece whose ends are nearest
//! to two lines meeting at a vertex is bounded by the first line up to the vertex's angle
//! and the second after it. A piece is split until its bound is within
//! `accuracy / 2` of the best value found so far, at the point where an exact maximum is
//! attained when there is one inside it (that point is then measured), else at its middle.
//!
//! The returned values are therefore within `accuracy` of the true maxima (flattening of
//! each side `accuracy / 4`, branch-and-bound slack `accuracy / 2`). Cost: O((n + m) log m)
//! queries for paths that follow each other, each query O(log n) with the sequential hint;
//! (a) runs in tasks of a fixed number of output primitives on [`crate::par`]'s threads,
//! each pruning against a floor measured first (the distance at every primitive's
//! middle); a point whose distance to the primitive nearest its neighbours', or to one
//! of the next few sources after it, is within the best value so far needs no query (an
//! upper bound serves the bounds as well), and where only the largest distance counts
//! (the floors; (b) without the per-vertex figures) a point is tested for a primitive
//! within the best so far by a search that stops at the first.
//! (b) runs in tasks of a fixed number of vertices. The programmed side is indexed once
//! ([`ProgramIndex`]) for any number of outputs. Memory: each side's primitives once (64
//! bytes a line), the output's becoming the index of side (b) after side (a); [`deviation`]
//! and [`ProgramIndex::into_deviation`] drop the programmed index before that.

use super::bvh::{Bvh, Hit};
use super::prim::{push_prims, Prim, PrimGeom};
use crate::geom::{ParamCurve, Segment, Vec3};
use crate::path::Toolpath;
use serde::Serialize;

/// A piece is split at the parameter of an exact maximum when it lies at least this share
/// of the piece from both ends (else at the middle).
const SPLIT_AT_MAX_MARGIN: f64 = 1e-3;

/// Output primitives per task of (a), the tasks measured in parallel: a fixed count, so
/// the result does not depend on the number of threads (each task's branch and bound
/// prunes against the shared floor and its own best value).
const OUTPUT_TASK_PRIMS: usize = 512;

/// Fewest programmed vertices for which the vertex queries (b) use a tree over the
/// output; below, each vertex scans the output's primitives (the smoothing methods measure
/// thousands of single curves against one or two programmed pieces).
const FEW_VERTICES: usize = 8;

/// Measured two-sided deviation.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Deviation {
    /// (a) Largest distance from the output path to the programmed path (mm).
    pub output_to_programmed_mm: f64,
    /// Where on the output path (a) occurs.
    pub output_at: Vec3,
    /// Source line of the output move where (a) occurs.
    pub output_line: u32,
    /// (b) Largest distance from a programmed vertex to the output path (mm).
    pub vertex_to_output_mm: f64,
    /// The programmed vertex where (b) occurs.
    pub vertex_at: Vec3,
    /// Source line of the programmed move ending at that vertex.
    pub vertex_line: u32,
    /// Accuracy of both figures (mm).
    pub accuracy_mm: f64,
}

impl Deviation {
    /// The larger of (a) and (b).
    pub fn max_mm(&self) -> f64 {
        self.output_to_programmed_mm.max(self.vertex_to_output_mm)
    }
    /// True when both sides are within `tol_mm`.
    pub fn within(&self, tol_mm: f64) -> bool {
        self.max_mm() <= tol_mm
    }
}

/// Deviation between two toolpaths (all moves, rapids included), within `accuracy` mm.
///
/// A zero-length line is no path: it is left out on both sides. Its one point is where
/// the machine already is, the end of the move before it or of a motion neither side can
/// place (after a `G28`, a slicer's repeated `G1 Z0.2` with X and Y not yet established
/// sits at the reader's placeholder for them), and a writer skips it.
pub fn deviation(output: &Toolpath, programmed: &Toolpath, accuracy: f64) -> Deviation {
    ProgramIndex::new(programmed, accuracy).into_deviation(output)
}

/// The moves of `tp` but its zero-length lines, with their source lines.
fn with_length(tp: &Toolpath) -> Vec<(&Segment, u32)> {
    tp.moves()
        .filter(|m| !matches!(&m.segment, Segment::Line(l) if l.p0 == l.p1))
        .map(|m| (&m.segment, m.line))
        .collect()
}

/// Deviation between two sequences of segments tagged with source lines.
pub fn deviation_segments(
    output: &[(&Segment, u32)],
    programmed: &[(&Segment, u32)],
    accuracy: f64,
) -> Deviation {
    let a = ProgramIndex::of_segments(programmed.to_vec(), accuracy).side_a(output);
    a.side_b(programmed, None).0
}

/// The programmed path indexed once for [`deviation`] against any number of outputs
/// (the builds of one program, or an index built while the output is being written):
/// the same figures as [`deviation`], which builds one per call.
///
/// ```
/// use ncsmooth::geom::Vec3;
/// use ncsmooth::path::Toolpath;
/// use ncsmooth::verify::{deviation, ProgramIndex};
///
/// let square = [Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0)];
/// let program = Toolpath::from_polyline(&square, None);
/// let cut = Toolpath::from_polyline(&[square[0], Vec3::new(0.9, 0.0, 0.0), square[2]], None);
/// let index = ProgramIndex::new(&program, 1e-9);
/// assert_eq!(index.deviation(&cut), deviation(&cut, &program, 1e-9));
/// assert!((index.deviation(&cut).vertex_to_output_mm - 0.1 / 1.01f64.sqrt()).abs() < 1e-9);
/// ```
pub struct ProgramIndex<'a> {
    /// The programmed moves measured, with their source lines.
    programmed: Vec<(&'a Segment, u32)>,
    /// Their primitives.
    bvh: Bvh,
    /// Accuracy of the figures (mm).
    accuracy: f64,
}

impl<'a> ProgramIndex<'a> {
    /// The index of `programmed` (its moves but zero-length lines, see [`deviation`]) for
    /// figures within `accuracy` mm (a non-positive or non-finite one is taken as 1 nm).
    pub fn new(programmed: &'a Toolpath, accuracy: f64) -> ProgramIndex<'a> {
        ProgramIndex::of_segments(with_length(programmed), accuracy)
    }

    fn of_segments(programmed: Vec<(&'a Segment, u32)>, accuracy: f64) -> ProgramIndex<'a> {
        let accuracy = if accuracy > 0.0 && accuracy.is_finite() {
            accuracy
        } else {
            1e-6
        };
        let flat = accuracy * 0.25;
        let mut prims = Vec::with_capacity(programmed.len());
        for (i, (s, _)) in programmed.iter().enumerate() {
            push_prims(s, i as u32, flat, &mut prims);
        }
        ProgramIndex {
            programmed,
            bvh: Bvh::new(prims),
            accuracy,
        }
    }

    /// Accuracy of the figures (mm).
    pub fn accuracy_mm(&self) -> f64 {
        self.accuracy
    }

    /// The deviation of `output` from the indexed program (see [`deviation`]).
    pub fn deviation(&self, output: &Toolpath) -> Deviation {
        self.measure(&with_length(output), None).0
    }

    /// The deviation of `output`, and the number of nearest-distance queries (a) made (the
    /// work of the branch and bound, for the tests); with `vertex_distances`, the distance
    /// of every programmed vertex to the output in program order.
    fn measure(
        &self,
        output: &[(&Segment, u32)],
        vertex_distances: Option<&mut Vec<f64>>,
    ) -> (Deviation, usize) {
        let a = self.side_a(output);
        a.side_b(&self.programmed, vertex_distances)
    }

    /// [`ProgramIndex::deviation`], the index dropped once side (a) is measured: the
    /// memory of one side's index at a time, for a single output.
    pub fn into_deviation(self, output: &Toolpath) -> Deviation {
        let a = self.side_a(&with_length(output));
        let ProgramIndex {
            programmed, bvh, ..
        } = self;
        drop(bvh);
        a.side_b(&programmed, None).0
    }

    /// Side (a) of the deviation of `output` (nothing to measure when either side is
    /// empty: the figures are then final).
    fn side_a(&self, output: &[(&Segment, u32)]) -> SideA {
        let (programmed, accuracy) = (&self.programmed, self.accuracy);
        let mut out_prims = Vec::with_capacity(output.len());
        for (i, (s, _)) in output.iter().enumerate() {
            push_prims(s, i as u32, accuracy * 0.25, &mut out_prims);
        }
        let mut dev = Deviation {
            output_to_programmed_mm: 0.0,
            output_at: output.first().map(|s| s.0.start()).unwrap_or_default(),
            output_line: output.first().map(|s| s.1).unwrap_or(0),
            vertex_to_output_mm: 0.0,
            vertex_at: programmed.first().map(|s| s.0.start()).unwrap_or_default(),
            vertex_line: programmed.first().map(|s| s.1).unwrap_or(0),
            accuracy_mm: accuracy,
        };
        // One side empty: nothing of the other is near it (both empty: nothing to miss).
        if out_prims.is_empty() || self.bvh.prims.is_empty() {
            if !self.bvh.prims.is_empty() {
                dev.vertex_to_output_mm = f64::INFINITY;
            }
            if !out_prims.is_empty() {
                dev.output_to_programmed_mm = f64::INFINITY;
            }
            return SideA {
                dev,
                out_prims: None,
                queries: 0,
            };
        }
        let (best, best_at, best_src, queries) =
            output_to_programmed(&out_prims, &self.bvh, accuracy * 0.5, dev.output_at);
        dev.output_to_programmed_mm = best;
        dev.output_at = best_at;
        dev.output_line = output[best_src as usize].1;
        SideA {
            dev,
            out_prims: Some(out_prims),
            queries,
        }
    }
}

/// The deviation with side (a) measured: the output's primitives for side (b), `None`
/// when the figures are final.
struct SideA {
    dev: Deviation,
    out_prims: Option<Vec<Prim>>,
    /// Nearest-distance queries side (a) made.
    queries: usize,
}

impl SideA {
    /// Side (b): the programmed vertices to the output, whose primitives become its
    /// index. A few vertices are scanned against every output primitive: a tree would
    /// cost more to build than it saves.
    fn side_b(
        self,
        programmed: &[(&Segment, u32)],
        vertex_distances: Option<&mut Vec<f64>>,
    ) -> (Deviation, usize) {
        let SideA {
            mut dev,
            out_prims,
            queries,
        } = self;
        let Some(out_prims) = out_prims else {
            return (dev, queries);
        };
        let out_bvh = if programmed.len() < FEW_VERTICES {
            Bvh::linear(out_prims)
        } else {
            Bvh::new(out_prims)
        };
        if let Some((d, p, line)) = vertices_to_output(&out_bvh, programmed, vertex_distances) {
            (dev.vertex_to_output_mm, dev.vertex_at, dev.vertex_line) = (d, p, line);
        }
        (dev, queries)
    }
}
/// Programmed vertices per task of (b), the tasks measured in parallel (each distance is
/// exact up to the primitives, so the result does not depend on the cut).
const VERTEX_TASK: usize = 4096;

/// Side (b): the largest distance from a programmed vertex (the start, then the end of
/// every segment, tagged with its line) to the primitives of `out`, the vertex and its
/// line (the earliest of equals; `None` when no distance is above 0), the distance of
/// every vertex pushed to `distances` in order when asked for.
fn vertices_to_output(
    out: &Bvh,
    programmed: &[(&Segment, u32)],
    distances: Option<&mut Vec<f64>>,
) -> Option<(f64, Vec3, u32)> {
    let n = programmed.len() + usize::from(!programmed.is_empty());
    let vertex = |i: usize| match i {
        0 => (programmed[0].0.start(), programmed[0].1),
        _ => (programmed[i - 1].0.end(), programmed[i - 1].1),
    };
    let keep = distances.is_some();
    let tasks = crate::par::map(n.div_ceil(VERTEX_TASK), 2, |k| {
        let mut q = Query::new(out);
        let mut best: Option<(f64, Vec3, u32)> = None;
        let mut ds = Vec::new();
        for i in k * VERTEX_TASK..((k + 1) * VERTEX_TASK).min(n) {
            let (p, line) = vertex(i);
            let floor = best.map_or(0.0, |b| b.0);
            let d = if keep {
                q.look_ahead(p);
                let d = q.dist(p);
                ds.push(d);
                Some(d).filter(|&d| d > floor)
            } else {
                q.dist_above(p, floor)
            };
            if let Some(d) = d {
                best = Some((d, p, line));
            }
        }
        (best, ds)
    });
    let mut best: Option<(f64, Vec3, u32)> = None;
    let mut distances = distances;
    for (b, ds) in tasks {
        if let Some(v) = distances.as_deref_mut() {
            v.extend(ds);
        }
        if let Some(b) = b.filter(|b| b.0 > best.map_or(0.0, |x| x.0)) {
            best = Some(b);
        }
    }
    best
}

/// [`deviation`], and the distance (mm) from every programmed vertex (the start, then the
/// end of every move, rapids included) to the output path, in program order, within
/// `accuracy`: the per-vertex figures whose largest is [`Deviation::vertex_to_output_mm`]
/// (side (b)), for histograms of the corner deviation, at the cost of [`deviation`] alone.
/// The distances are empty when either path has no move.
///
/// ```
/// use ncsmooth::geom::Vec3;
/// use ncsmooth::path::Toolpath;
/// use ncsmooth::verify::deviation_with_vertex_distances;
///
/// let square = [Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0)];
/// let program = Toolpath::from_polyline(&square, None);
/// // The corner (1, 0) cut by a line from (0.9, 0) to (1, 1).
/// let cut = Toolpath::from_polyline(&[square[0], Vec3::new(0.9, 0.0, 0.0), square[2]], None);
/// let (dev, d) = deviation_with_vertex_distances(&cut, &program, 1e-9);
/// assert_eq!(d.len(), 3);
/// assert!(d[0].abs() < 1e-9 && d[2].abs() < 1e-9);
/// assert!((d[1] - 0.1 / 1.01f64.sqrt()).abs() < 1e-9);
/// assert_eq!(dev.vertex_to_output_mm, d[1]);
/// ```
pub fn deviation_with_vertex_distances(
    output: &Toolpath,
    programmed: &Toolpath,
    accuracy: f64,
) -> (Deviation, Vec<f64>) {
    let out: Vec<(&Segment, u32)> = output.moves().map(|m| (&m.segment, m.line)).collect();
    let prog: Vec<(&Segment, u32)> = programmed.moves().map(|m| (&m.segment, m.line)).collect();
    let mut distances = Vec::new();
    let (dev, _) = ProgramIndex::of_segments(prog, accuracy).measure(&out, Some(&mut distances));
    (dev, distances)
}

/// Side (a) by branch and bound (see the module doc): the largest distance from the
/// primitives of the output to those indexed by `prog`, within `slack`, where it occurs
/// (starting from `first`), the index of its output move, and the queries made.
fn output_to_programmed(
    out_prims: &[Prim],
    prog: &Bvh,
    slack: f64,
    first: Vec3,
) -> (f64, Vec3, u32, usize) {
    let tasks = out_prims.len().div_ceil(OUTPUT_TASK_PRIMS);
    let part = |k: usize| {
        let lo = k * OUTPUT_TASK_PRIMS;
        &out_prims[lo..(lo + OUTPUT_TASK_PRIMS).min(out_prims.len())]
    };
    // A floor for every task's pruning: the distance at each primitive's middle (a point
    // of the output, so the floor is attained), the same whatever the thread count.
    let floors = crate::par::map(tasks, 2, |k| middles_to_programmed(part(k), prog));
    let best = largest((0.0, first, 0, 0), floors);
    let floor = best.0;
    let parts = crate::par::map(tasks, 2, |k| {
        output_part_to_programmed(part(k), prog, slack, floor)
    });
    // A task reports only values above the floor.
    largest(best, parts)
}

/// The largest of `best` and `parts` (distance, where, source), the earliest of equals,
/// with the queries of all added up.
fn largest(
    mut best: (f64, Vec3, u32, usize),
    parts: Vec<(f64, Vec3, u32, usize)>,
) -> (f64, Vec3, u32, usize) {
    for (d, at, src, queries) in parts {
        if d > best.0 {
            best = (d, at, src, best.3);
        }
        best.3 += queries;
    }
    best
}

/// The largest distance from the middles of `out_prims` to the programmed path, where,
/// its output source and the queries made.
fn middles_to_programmed(out_prims: &[Prim], prog: &Bvh) -> (f64, Vec3, u32, usize) {
    let mut q = Query::new(prog);
    let mut best = (0.0, Vec3::default(), 0, 0);
    for prim in out_prims {
        let p = prim.eval(0.5);
        if let Some(d) = q.dist_above(p, best.0) {
            best = (d, p, prim.source, 0);
        }
    }
    best.3 = q.count;
    best
}

/// (a) over a run of output primitives, pruning against `floor` (a distance attained
/// elsewhere): the largest distance above the floor (0 if none), where, its output source
/// and the queries made.
fn output_part_to_programmed(
    out_prims: &[Prim],
    prog: &Bvh,
    slack: f64,
    floor: f64,
) -> (f64, Vec3, u32, usize) {
    let mut q = Query::new(prog);
    let mut best = floor;
    let mut best_at = Vec3::default();
    let mut best_src = 0u32;
    let mut stack: Vec<Piece> = Vec::with_capacity(64);
    let mut last: Option<(Vec3, f64, usize)> = None;
    for prim in out_prims {
        let len = prim.length();
        let p0 = prim.eval(0.0);
        let p1 = prim.eval(1.0);
        // A primitive starting where the last ended starts at its end's distance.
        let (d0, h0) = match last {
            Some((p, d, h)) if p == p0 => (d, h),
            _ => {
                let h = last.map_or(q.hint, |l| l.2);
                q.dist_or_below(p0, h, h, best)
            }
        };
        let (d1, h1) = q.dist_or_below(p1, h0, h0, best);
        last = Some((p1, d1, h1));
        for (d, p) in [(d0, p0), (d1, p1)] {
            if d > best {
                best = d;
                best_at = p;
                best_src = prim.source;
            }
        }
        stack.push(Piece {
            t0: 0.0,
            t1: 1.0,
            p0,
            p1,
            d0,
            d1,
            h0,
            h1,
        });
        while let Some(pc) = stack.pop() {
            let (ub, at) = upper_bound(prim, &pc, len, &prog.prims);
            if ub <= best + slack {
                continue;
            }
            let margin = SPLIT_AT_MAX_MARGIN * (pc.t1 - pc.t0);
            let tm = match at {
                Some(t) if t > pc.t0 + margin && t < pc.t1 - margin => t,
                _ => 0.5 * (pc.t0 + pc.t1),
            };
            let pm = prim.eval(tm);
            let (dm, hm) = q.dist_or_below(pm, pc.h0, pc.h1, best);
            if dm > best {
                best = dm;
                best_at = pm;
                best_src = prim.source;
            }
            stack.push(Piece {
                t0: pc.t0,
                t1: tm,
                p0: pc.p0,
                p1: pm,
                d0: pc.d0,
                d1: dm,
                h0: pc.h0,
                h1: hm,
            });
            stack.push(Piece {
                t0: tm,
                t1: pc.t1,
                p0: pm,
                p1: pc.p1,
                d0: dm,
                d1: pc.d1,
                h0: hm,
                h1: pc.h1,
            });
        }
    }
    let found = if best > floor { best } else { 0.0 };
    (found, best_at, best_src, q.count)
}

/// A parameter interval of an output primitive with its end distances and nearest
/// programmed primitives.
struct Piece {
    t0: f64,
    t1: f64,
    p0: Vec3,
    p1: Vec3,
    d0: f64,
    d1: f64,
    h0: usize,
    h1: usize,
}

/// Upper bound of the distance to the programmed path over the piece, and the
/// parameter where it is attained when the bound is an exact maximum (see the module
/// doc).
fn upper_bound(prim: &Prim, pc: &Piece, len: f64, prog: &[Prim]) -> (f64, Option<f64>) {
    let piece_len = len * (pc.t1 - pc.t0);
    let mut ub = 0.5 * (pc.d0 + pc.d1 + piece_len);
    let mut at = None;
    let hits = if pc.h0 == pc.h1 {
        &[pc.h0][..]
    } else {
        &[pc.h0, pc.h1][..]
    };
    for &h in hits {
        let bound = match (&prim.geom, &prog[h].geom) {
            (PrimGeom::Line(_), PrimGeom::Line(l)) => {
                Some((l.dist_sq(pc.p0).max(l.dist_sq(pc.p1)).sqrt(), None))
            }
            (PrimGeom::Line(_), PrimGeom::Arc(q)) => q
                .segment_max(pc.p0, pc.p1)
                .map(|(b, s)| (b, Some(pc.t0 + s * (pc.t1 - pc.t0)))),
            (PrimGeom::Arc(a), PrimGeom::Arc(q)) => {
                q.arc_piece_max(a, pc.t0, pc.t1).map(|(b, t)| (b, Some(t)))
            }
            // In the line's plane, the closed form; else: along the piece's chord the
            // distance to a fixed line is convex (at most its ends'), and the piece
            // leaves its chord by at most its sagitta.
            (PrimGeom::Arc(a), PrimGeom::Line(l)) => a
                .piece_max_to_line(l, pc.t0, pc.t1)
                .map(|(b, t)| (b, Some(t)))
                .or_else(|| {
                    let half = 0.5 * (pc.t1 - pc.t0) * a.arc.sweep;
                    let sagitta = a.arc.radius * (1.0 - half.min(std::f64::consts::PI).cos());
                    Some((
                        l.dist_sq(pc.p0).max(l.dist_sq(pc.p1)).sqrt() + sagitta,
                        None,
                    ))
                }),
        };
        if let Some((b, t)) = bound {
            if b < ub {
                ub = b;
                at = t;
            }
        }
    }
    if let Some((b, t)) = corner_bound(prim, pc, prog) {
        if b < ub {
            ub = b;
            at = Some(t);
        }
    }
    (ub, at)
}

/// A bound over an arc piece whose ends are nearest to two programmed lines meeting at
/// a vertex: the distance to the path is at most the distance to the first line before
/// the piece passes the vertex (its angle about the arc's centre) and to the second
/// after it, each bounded in closed form (valid wherever the piece is cut; tight where
/// the cut is where the nearest line changes).
fn corner_bound(prim: &Prim, pc: &Piece, prog: &[Prim]) -> Option<(f64, f64)> {
    if pc.h0 == pc.h1 {
        return None;
    }
    let (PrimGeom::Arc(a), PrimGeom::Line(l0), PrimGeom::Line(l1)) =
        (&prim.geom, &prog[pc.h0].geom, &prog[pc.h1].geom)
    else {
        return None;
    };
    let vertex = if l0.p1 == l1.p0 || l0.p1 == l1.p1 {
        l0.p1
    } else if l0.p0 == l1.p0 || l0.p0 == l1.p1 {
        l0.p0
    } else {
        return None;
    };
    let arc = &a.arc;
    let q = vertex - arc.center;
    let theta = q
        .dot(arc.v)
        .atan2(q.dot(arc.u))
        .rem_euclid(std::f64::consts::TAU);
    // Past the end, the nearer end of the sweep.
    let t = if theta <= arc.sweep || theta - arc.sweep < std::f64::consts::TAU - theta {
        (theta / arc.sweep).min(1.0)
    } else {
        0.0
    };
    let tv = t.clamp(pc.t0, pc.t1);
    let (b0, s0) = a.piece_max_to_line(l0, pc.t0, tv)?;
    let (b1, s1) = a.piece_max_to_line(l1, tv, pc.t1)?;
    Some(if b0 >= b1 { (b0, s0) } else { (b1, s1) })
}

/// Sequential nearest-distance queries with a hint (the previous nearest primitive).
struct Query<'a> {
    bvh: &'a Bvh,
    hint: usize,
    /// Queries made.
    count: usize,
}

impl<'a> Query<'a> {
    fn new(bvh: &'a Bvh) -> Query<'a> {
        Query {
            bvh,
            hint: 0,
            count: 0,
        }
    }
    fn dist_hit(&mut self, p: Vec3) -> (f64, usize) {
        self.count += 1;
        let h = self.bvh.prims[self.hint].dist_sq(p);
        let Hit { dist_sq, prim } = self.bvh.nearest(p, h);
        if prim != usize::MAX {
            self.hint = prim;
            (dist_sq.sqrt(), prim)
        } else {
            (h.sqrt(), self.hint)
        }
    }
    /// The distance from `p` to the programmed path where it may exceed `floor`, else an
    /// upper bound of it not above `floor`; with the primitive it is measured to. The
    /// nearer of `a`, `b` and the hint is tried first, then a primitive of each of the
    /// [`AHEAD_SOURCES`] sources after its own: when one is within `floor` the point
    /// cannot raise a maximum that is at least `floor`, and no query is made (an upper
    /// bound serves the branch and bound as well as the distance).
    fn dist_or_below(&mut self, p: Vec3, a: usize, b: usize, floor: f64) -> (f64, usize) {
        let prims = &self.bvh.prims;
        let (mut best, mut at) = (prims[self.hint].dist_sq(p), self.hint);
        for h in [a, b] {
            let d = prims[h].dist_sq(p);
            if d < best {
                (best, at) = (d, h);
            }
        }
        if best <= floor * floor {
            return (best.sqrt(), at);
        }
        let s = prims[at].source;
        for k in 1..=AHEAD_SOURCES {
            if let Some(i) = self.bvh.of_source(s.saturating_add(k)) {
                let d = prims[i].dist_sq(p);
                if d < best {
                    (best, at) = (d, i);
                }
            }
        }
        if best <= floor * floor {
            return (best.sqrt(), at);
        }
        self.hint = at;
        self.dist_hit(p)
    }
    fn dist(&mut self, p: Vec3) -> f64 {
        self.dist_hit(p).0
    }
    /// The hint replaced by the nearest to `p` of it and a primitive of each of the
    /// [`AHEAD_SOURCES`] sources after its own: points taken in path order meet them
    /// next, and a near hint bounds the query tightly. Only where the primitive found
    /// does not matter (of equally near ones, which is found depends on the hint).
    fn look_ahead(&mut self, p: Vec3) {
        let prims = &self.bvh.prims;
        let Some(hint) = prims.get(self.hint) else {
            return;
        };
        let mut best = (hint.dist_sq(p), self.hint);
        for k in 1..=AHEAD_SOURCES {
            if let Some(i) = self.bvh.of_source(hint.source.saturating_add(k)) {
                let d = prims[i].dist_sq(p);
                if d < best.0 {
                    best = (d, i);
                }
            }
        }
        self.hint = best.1;
    }
    /// The distance from `p` when it is above `floor`, else `None`: a point with a
    /// primitive within the floor (a little inside it, so that `None` never hides a
    /// distance that rounds above it) is answered by a search that stops at the first.
    fn dist_above(&mut self, p: Vec3, floor: f64) -> Option<f64> {
        self.look_ahead(p);
        let within_sq = floor * floor * (1.0 - FLOOR_SQ_MARGIN);
        if self.bvh.any_within(p, within_sq, self.hint) {
            return None;
        }
        Some(self.dist(p)).filter(|&d| d > floor)
    }
}

/// Sources after the hint's that [`Query::look_ahead`] tries.
const AHEAD_SOURCES: u32 = 4;

/// Relative margin under the square of a floor inside which [`Query::dist_above`] takes
/// a point as within it: far above the rounding of a square and its root.
const FLOOR_SQ_MARGIN: f64 = 1e-12;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Arc, CubicBez, Line};
    use std::f64::consts::TAU;

    fn poly(pts: &[Vec3]) -> Vec<Segment> {
        pts.windows(2)
            .map(|w| Segment::Line(Line::new(w[0], w[1])))
            .collect()
    }
    fn tag(s: &[Segment]) -> Vec<(&Segment, u32)> {
        s.iter()
            .enumerate()
            .map(|(i, s)| (s, i as u32 + 1))
            .collect()
    }

    /// A zero-length line is no path: a slicer's repeated `G1 Z0.2` before X and Y are
    /// established sits at the reader's placeholder for them, 10 mm from where the first
    /// ring starts, and a writer skips it (it once failed every smoothed print).
    #[test]
    fn a_zero_length_line_is_no_path() {
        use crate::path::{Block, Move, Toolpath};
        let z = Vec3::new(0.0, 0.0, 0.2);
        let (a, b) = (Vec3::new(10.0, 0.0, 0.2), Vec3::new(20.0, 0.0, 0.2));
        let path = |moves: Vec<Line>| {
            let mut tp = Toolpath::new(Vec3::ZERO);
            for (k, l) in moves.into_iter().enumerate() {
                tp.blocks
                    .push(Block::Move(Move::feed(l, Some(10.0), k as u32 + 1)));
            }
            tp
        };
        let program = path(vec![Line::new(z, z), Line::new(a, b)]);
        let written = path(vec![Line::new(a, b)]);
        let d = deviation(&written, &program, 1e-9);
        assert!(d.within(1e-9), "{d:?}");
    }

    #[test]
    fn identical_paths_have_zero_deviation() {
        let p = poly(&[
            Vec3::ZERO,
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
        ]);
        let d = deviation_segments(&tag(&p), &tag(&p), 1e-6);
        assert!(d.max_mm() < 1e-12);
    }

    #[test]
    fn square_corner_cut_by_a_chamfer() {
        // Programmed right-angle corner; output cuts it with a chamfer at distance 1 from it.
        let prog = poly(&[
            Vec3::ZERO,
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
        ]);
        let out = poly(&[
            Vec3::ZERO,
            Vec3::new(9.0, 0.0, 0.0),
            Vec3::new(10.0, 1.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
        ]);
        let d = deviation_segments(&tag(&out), &tag(&prog), 1e-7);
        // (a): chamfer midpoint (9.5, 0.5) is 0.5 from both legs.
        assert!((d.output_to_programmed_mm - 0.5).abs() <= 1e-7, "{d:?}");
        // (b): the corner (10, 0) to the chamfer line: sqrt(0.5).
        assert!(
            (d.vertex_to_output_mm - 0.5f64.sqrt()).abs() <= 1e-7,
            "{d:?}"
        );
        assert_eq!(d.vertex_line, 1);
        assert_eq!(d.output_line, 2);
    }

    #[test]
    fn arc_against_its_chord_polyline() {
        // A quarter circle (r = 10) against its 8-chord polyline: (a) is the sagitta.
        let arc = Arc::from_center(
            Vec3::new(10.0, 0.0, 0.0),
            Vec3::new(0.0, 10.0, 0.0),
            Vec3::ZERO,
            Vec3::Z,
            true,
            0,
        )
        .unwrap();
        let pts: Vec<Vec3> = (0..=8).map(|i| arc.eval(i as f64 / 8.0)).collect();
        let chords = poly(&pts);
        let arcs = vec![Segment::Arc(arc)];
        let sag = 10.0 * (1.0 - (std::f64::consts::FRAC_PI_2 / 16.0).cos());
        let d = deviation_segments(&tag(&arcs), &tag(&chords), 1e-8);
        assert!(
            (d.output_to_programmed_mm - sag).abs() <= 1e-8,
            "{} vs {sag}",
            d.output_to_programmed_mm
        );
        assert!(d.vertex_to_output_mm < 1e-9);
        // The other way round: the chord midpoints are the sagitta from the arc.
        let d = deviation_segments(&tag(&chords), &tag(&arcs), 1e-8);
        assert!((d.output_to_programmed_mm - sag).abs() <= 1e-8);
        // The same arc against itself, split in two: zero, fast.
        let halves = vec![
            Segment::Arc(arc.subsegment(0.0, 0.5)),
            Segment::Arc(arc.subsegment(0.5, 1.0)),
        ];
        let d = deviation_segments(&tag(&halves), &tag(&arcs), 1e-9);
        assert!(d.max_mm() < 1e-9);
    }

    #[test]
    fn bezier_bulge_is_measured() {
        // A symmetric Bézier bulging off a straight line: max distance 0.75 h at t = 1/2.
        let h = 2.0;
        let c = CubicBez::new(
            Vec3::ZERO,
            Vec3::new(1.0, h, 0.0),
            Vec3::new(2.0, h, 0.0),
            Vec3::new(3.0, 0.0, 0.0),
        );
        let out = vec![Segment::CubicBez(c)];
        let prog = poly(&[Vec3::ZERO, Vec3::new(3.0, 0.0, 0.0)]);
        let d = deviation_segments(&tag(&out), &tag(&prog), 1e-6);
        assert!((d.output_to_programmed_mm - 0.75 * h).abs() <= 1e-6);
    }

    #[test]
    fn an_empty_side_is_infinitely_far() {
        let prog = poly(&[Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0)]);
        let d = deviation_segments(&[], &tag(&prog), 1e-6);
        assert_eq!(d.vertex_to_output_mm, f64::INFINITY);
        assert!(!d.within(1e9));
        let d = deviation_segments(&tag(&prog), &[], 1e-6);
        assert_eq!(d.output_to_programmed_mm, f64::INFINITY);
        let d = deviation_segments(&[], &[], 1e-6);
        assert!(d.within(0.0));
    }

    /// (a) by brute force: the output sampled every `1/n` of each segment's parameter, each
    /// sample's exact distance to every programmed segment.
    fn brute_output_to_programmed(out: &[Segment], prog: &[Segment], n: usize) -> f64 {
        use crate::geom::ParamCurveNearest;
        let mut worst = 0.0f64;
        for s in out {
            for i in 0..=n {
                let p = s.eval(i as f64 / n as f64);
                let d = prog
                    .iter()
                    .map(|q| q.nearest(p, 0.0).distance_sq)
                    .fold(f64::INFINITY, f64::min)
                    .sqrt();
                worst = worst.max(d);
            }
        }
        worst
    }

    /// A spiral of arcs about drifting centres (the shape of linuxcnc_arcspiral) and the
    /// same arcs as a written program reads back: end points rounded to 1e-4 mm, centres
    /// moved by up to 2e-4 mm, some arcs replaced by their chords. Every output arc lies
    /// a few rounding units off a programmed circle, where the Lipschitz bound alone split
    /// it into pieces of the accuracy's length.
    fn spiral(turns: f64, arcs_per_turn: usize, seed: u64) -> (Vec<Segment>, Vec<Segment>) {
        let mut r = seed;
        let mut jitter = move || {
            r ^= r << 13;
            r ^= r >> 7;
            r ^= r << 17;
            (r >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let n = (turns * arcs_per_turn as f64) as usize;
        let step = TAU / arcs_per_turn as f64;
        let at = |k: usize| {
            let a = -(k as f64) * step;
            let rad = 50.0 - 1.8 * k as f64 / arcs_per_turn as f64;
            let c = Vec3::new(0.02 * (k as f64 * 0.1).sin(), 0.0, -2.5);
            (c, c + Vec3::new(a.cos(), a.sin(), 0.0) * rad)
        };
        let round = |p: Vec3| Vec3::new((p.x * 1e4).round() / 1e4, (p.y * 1e4).round() / 1e4, p.z);
        let (mut prog, mut out) = (Vec::new(), Vec::new());
        for k in 0..n {
            let (c, p0) = at(k);
            let (_, p1) = at(k + 1);
            let arc = Arc::from_center(p0, p1, c, Vec3::Z, false, 0).expect("arc");
            prog.push(Segment::Arc(arc));
            let (q0, q1) = (round(p0), round(p1));
            let cq = c + Vec3::new(jitter(), jitter(), 0.0) * 4e-4;
            if k % 7 == 3 {
                out.push(Segment::Line(Line::new(q0, q1)));
            } else {
                let a = Arc::from_center(q0, q1, cq, Vec3::Z, false, 0).expect("arc");
                out.push(Segment::Arc(a));
            }
        }
        (prog, out)
    }

    #[test]
    fn rounded_arc_spiral_against_brute_force() {
        let (prog, out) = spiral(1.5, 24, 0x2545_f491_4f6c_dd1d);
        let acc = 1e-6;
        let d = deviation_segments(&tag(&out), &tag(&prog), acc);
        let brute = brute_output_to_programmed(&out, &prog, 2000);
        // Samples 2000 per ~13 mm arc (6.5 um apart): the brute maximum is within half that
        // spacing of the true one, and (a) within `acc`.
        assert!(d.output_to_programmed_mm >= brute - acc, "{d:?} vs {brute}");
        assert!(
            d.output_to_programmed_mm <= brute + 3.3e-6 + acc,
            "{d:?} vs {brute}"
        );
        // The chords make it: their sagitta is ~0.2 mm.
        assert!(brute > 0.1);
        // Without the chords the arcs are a few rounding units off.
        let arcs: Vec<Segment> = out
            .iter()
            .zip(&prog)
            .map(|(o, p)| match o {
                Segment::Line(_) => p.clone(),
                a => a.clone(),
            })
            .collect();
        let (d, queries) = ProgramIndex::of_segments(tag(&prog), acc).measure(&tag(&arcs), None);
        let brute = brute_output_to_programmed(&arcs, &prog, 2000);
        assert!(brute > 5e-5 && brute < 1e-3, "{brute}");
        assert!(
            (d.output_to_programmed_mm - brute).abs() <= acc + 1e-8,
            "{d:?} vs {brute}"
        );
        // The closed-form bound of an arc along a programmed arc: a few queries per arc
        // (ends, the maximum, the piece across each programmed joint). The Lipschitz
        // bound alone needed pieces of ~acc length near the maximum: 13 M queries here
        // (582 now).
        assert!(
            queries < 100 * arcs.len(),
            "{queries} queries for {} arcs",
            arcs.len()
        );
        // The chords of the first spiral are bounded in closed form too.
        let (_, queries) = ProgramIndex::of_segments(tag(&prog), acc).measure(&tag(&out), None);
        assert!(
            queries < 100 * out.len(),
            "{queries} queries for {} pieces",
            out.len()
        );
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig { cases: 24, ..Default::default() })]

        /// Random chains of arcs and lines, and the same chain perturbed (centres, radii,
        /// a height offset, some arcs replaced by chords or by arcs through a shifted
        /// centre): (a) agrees with brute force.
        #[test]
        fn perturbed_arc_chains_against_brute_force(
            pieces in proptest::collection::vec((0.3f64..20.0, -2.5f64..2.5, proptest::prelude::any::<bool>(), 0u8..4), 1..6),
            shift in (-1.0f64..1.0, -1.0f64..1.0),
            scale in proptest::prop_oneof![proptest::strategy::Just(1e-4f64), proptest::strategy::Just(0.05)],
            dz in -1e-4f64..1e-4,
        ) {
            let mut prog = Vec::new();
            let mut out = Vec::new();
            let (mut p, mut dir) = (Vec3::ZERO, Vec3::X);
            for (len, turn, ccw, kind) in pieces {
                if kind == 0 || turn.abs() < 1e-3 {
                    let q = p + dir * len;
                    prog.push(Segment::Line(Line::new(p, q)));
                    let sh = Vec3::new(shift.0, shift.1, 0.0) * scale;
                    out.push(Segment::Line(Line::new(p + sh, q + sh + Vec3::new(0.0, 0.0, dz))));
                    p = q;
                    continue;
                }
                let r = len / turn.abs();
                let left = Vec3::Z.cross(dir);
                let c = if ccw { p + left * r } else { p - left * r };
                let u = (p - c) / r;
                let sgn = if ccw { 1.0 } else { -1.0 };
                let v = Vec3::Z.cross(u) * sgn;
                let q = c + (u * turn.abs().cos() + v * turn.abs().sin()) * r;
                let arc = Arc::from_center(p, q, c, Vec3::Z, ccw, 0).expect("arc");
                dir = crate::geom::ParamCurveDeriv::deriv(&arc, 1.0).normalized().expect("tangent");
                prog.push(Segment::Arc(arc));
                let cs = c + Vec3::new(shift.0, shift.1, 0.0) * scale;
                let o = if kind == 1 {
                    Segment::Line(Line::new(p, q))
                } else {
                    match Arc::from_center(p, q, cs, Vec3::Z, ccw, 0) {
                        Some(a) if !a.is_helical() => Segment::Arc(a),
                        _ => Segment::Line(Line::new(p, q)),
                    }
                };
                out.push(o);
                p = q;
            }
            let acc = 1e-6;
            let d = deviation_segments(&tag(&out), &tag(&prog), acc);
            let n = 3000;
            let brute = brute_output_to_programmed(&out, &prog, n);
            // Sample spacing at most 20 * 2.5 / 3000 mm of arc: within half of it.
            let gap = 20.0 * 2.5 / n as f64;
            proptest::prop_assert!(d.output_to_programmed_mm >= brute - acc, "{:?} vs {}", d, brute);
            proptest::prop_assert!(d.output_to_programmed_mm <= brute + 0.5 * gap + acc, "{:?} vs {}", d, brute);
        }
    }

    #[test]
    fn many_segments_offset_exactly() {
        // A 200k-segment zigzag (speed is measured by the criterion bench) against itself shifted by 0.01 along z.
        let n = 200_000;
        let pts: Vec<Vec3> = (0..=n)
            .map(|i| Vec3::new(i as f64 * 0.1, (i % 2) as f64 * 0.05, 0.0))
            .collect();
        let shifted: Vec<Vec3> = pts.iter().map(|p| *p + Vec3::new(0.0, 0.0, 0.01)).collect();
        let a = poly(&pts);
        let b = poly(&shifted);
        let d = deviation_segments(&tag(&b), &tag(&a), 1e-6);
        assert!((d.output_to_programmed_mm - 0.01).abs() <= 1e-6);
        assert!((d.vertex_to_output_mm - 0.01).abs() <= 1e-6);
    }
}
