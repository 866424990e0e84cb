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
//! `(d0 + d1 + l) / 2`. Two sharper bounds prune the common cases at once: along a straight
//! piece the distance to one fixed programmed line is convex, so `f <= max` of the end
//! distances to that line; and an output arc on the circle of a programmed arc, inside its
//! angular range, is within the circles' mismatch of it. A piece is split until its bound
//! is within `accuracy / 2` of the best value found so far.
//!
//! The returned values are therefore within `accuracy` of the true maxima (flattening of
//! each side `accuracy / 4`, branch-and-bound slack `accuracy / 2`). Cost: O((n + m) log m)
//! queries for paths that follow each other, each query O(log n) with the sequential hint.

use super::bvh::{Bvh, Hit};
use super::prim::{push_prims, Prim, PrimGeom};
use crate::geom::{Arc, ParamCurve, Segment, Vec3};
use crate::path::Toolpath;
use serde::Serialize;
use std::f64::consts::TAU;

/// Largest centre/radius mismatch (mm) for which an output arc is treated as lying on the
/// circle of a programmed arc (the mismatch is added to the bound).
const SAME_CIRCLE_MM: f64 = 1e-7;

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
pub fn deviation(output: &Toolpath, programmed: &Toolpath, accuracy: f64) -> Deviation {
    let out: Vec<(&Segment, u32)> = output.moves().map(|m| (&m.segment, m.line)).collect();
    let prog: Vec<(&Segment, u32)> = programmed.moves().map(|m| (&m.segment, m.line)).collect();
    deviation_segments(&out, &prog, accuracy)
}

/// Deviation between two sequences of segments tagged with source lines.
pub fn deviation_segments(
    output: &[(&Segment, u32)],
    programmed: &[(&Segment, u32)],
    accuracy: f64,
) -> Deviation {
    let accuracy = if accuracy > 0.0 && accuracy.is_finite() {
        accuracy
    } else {
        1e-6
    };
    let flat = accuracy * 0.25;
    let slack = accuracy * 0.5;
    let mut prog_prims = Vec::with_capacity(programmed.len());
    for (i, (s, _)) in programmed.iter().enumerate() {
        push_prims(s, i as u32, flat, &mut prog_prims);
    }
    let mut out_prims = Vec::with_capacity(output.len());
    for (i, (s, _)) in output.iter().enumerate() {
        push_prims(s, i as u32, flat, &mut out_prims);
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
    if out_prims.is_empty() || prog_prims.is_empty() {
        if !prog_prims.is_empty() {
            dev.vertex_to_output_mm = f64::INFINITY;
        }
        if !out_prims.is_empty() {
            dev.output_to_programmed_mm = f64::INFINITY;
        }
        return dev;
    }

    // (b) programmed vertices to the output (a few vertices are scanned against every
    // output primitive: a tree would cost more to build than it saves).
    let out_bvh = if programmed.len() < FEW_VERTICES {
        Bvh::linear(out_prims.clone())
    } else {
        Bvh::new(out_prims.clone())
    };
    let mut q = Query::new(&out_bvh);
    let vertex = |p: Vec3, line: u32, dev: &mut Deviation, q: &mut Query| {
        let d = q.dist(p);
        if d > dev.vertex_to_output_mm {
            dev.vertex_to_output_mm = d;
            dev.vertex_at = p;
            dev.vertex_line = line;
        }
    };
    vertex(programmed[0].0.start(), programmed[0].1, &mut dev, &mut q);
    for (s, line) in programmed {
        vertex(s.end(), *line, &mut dev, &mut q);
    }

    // (a) output points to the programmed path.
    let prog_bvh = Bvh::new(prog_prims);
    let mut q = Query::new(&prog_bvh);
    let mut best = 0.0_f64;
    let mut best_at = dev.output_at;
    let mut best_src = 0u32;
    let mut stack: Vec<Piece> = Vec::with_capacity(64);
    for prim in &out_prims {
        let len = prim.length();
        let p0 = prim.eval(0.0);
        let p1 = prim.eval(1.0);
        let (d0, h0) = q.dist_hit(p0);
        let (d1, h1) = q.dist_hit(p1);
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
            let ub = upper_bound(prim, &pc, len, &prog_bvh.prims);
            if ub <= best + slack {
                continue;
            }
            let tm = 0.5 * (pc.t0 + pc.t1);
            let pm = prim.eval(tm);
            let (dm, hm) = q.dist_hit(pm);
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
    dev.output_to_programmed_mm = best;
    dev.output_at = best_at;
    dev.output_line = output[best_src as usize].1;
    dev
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

fn upper_bound(prim: &Prim, pc: &Piece, len: f64, prog: &[Prim]) -> f64 {
    let piece_len = len * (pc.t1 - pc.t0);
    let mut ub = 0.5 * (pc.d0 + pc.d1 + piece_len);
    match &prim.geom {
        PrimGeom::Line(_) => {
            for h in [pc.h0, pc.h1] {
                if let PrimGeom::Line(l) = &prog[h].geom {
                    let c = l.dist_sq(pc.p0).max(l.dist_sq(pc.p1)).sqrt();
                    ub = ub.min(c);
                }
            }
        }
        PrimGeom::Arc(a) => {
            for h in [pc.h0, pc.h1] {
                if let PrimGeom::Arc(qa) = &prog[h].geom {
                    if let Some(m) = arc_piece_on_arc(&a.arc, pc.t0, pc.t1, &qa.arc) {
                        ub = ub.min(pc.d0.max(pc.d1) + m);
                    }
                }
            }
        }
    }
    ub
}

/// When the piece `[t0, t1]` of `a` lies on the circle of `q` and inside its angular range,
/// the circle mismatch (mm); else `None`.
fn arc_piece_on_arc(a: &Arc, t0: f64, t1: f64, q: &Arc) -> Option<f64> {
    let mismatch = a.center.dist(q.center) + (a.radius - q.radius).abs();
    let (na, nq) = (a.normal(), q.normal());
    if mismatch > SAME_CIRCLE_MM || na.cross(nq).norm() > 1e-9 {
        return None;
    }
    let dir = if na.dot(nq) > 0.0 { 1.0 } else { -1.0 };
    // Angle of a's start direction in q's frame.
    let base = a.u.dot(q.v).atan2(a.u.dot(q.u));
    let (s0, s1) = (base + dir * a.sweep * t0, base + dir * a.sweep * t1);
    let (lo, hi) = if s0 <= s1 { (s0, s1) } else { (s1, s0) };
    let lo_n = lo.rem_euclid(TAU);
    let lo_n = if lo_n > TAU - 1e-12 { 0.0 } else { lo_n };
    (lo_n + (hi - lo) <= q.sweep + 1e-12).then_some(mismatch)
}

/// Sequential nearest-distance queries with a hint (the previous nearest primitive).
struct Query<'a> {
    bvh: &'a Bvh,
    hint: usize,
}

impl<'a> Query<'a> {
    fn new(bvh: &'a Bvh) -> Query<'a> {
        Query { bvh, hint: 0 }
    }
    fn dist_hit(&mut self, p: Vec3) -> (f64, usize) {
        let h = self.bvh.prims[self.hint].dist_sq(p);
        let Hit { dist_sq, prim } = self.bvh.nearest(p, h);
        if prim != usize::MAX {
            self.hint = prim;
            (dist_sq.sqrt(), prim)
        } else {
            (h.sqrt(), self.hint)
        }
    }
    fn dist(&mut self, p: Vec3) -> f64 {
        self.dist_hit(p).0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{CubicBez, Line};

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
