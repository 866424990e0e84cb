//! [`PathIndex`]: the program's moves in arc length, their lengths (adaptive quadrature,
//! in parallel) and the geometry read at a parameter of a move.

use super::builder::IndexBuilder;
use super::feeder::{MoveRef, RestRef};
use super::joints::{caps_of, joint_after};
use super::{After, ExtraRest, PlanMove, ARCLEN_ACCURACY_MM, ZERO_SPEED_PROBE};
use crate::feed::limits::Caps;
use crate::feed::window::{MoveWindow, Reader, Summary};
use crate::feed::{PlanOptions, StopReason};
use crate::geom::{
    arclen_adaptive, curvature_vec_from, ParamCurve, ParamCurveCurvature, ParamCurveDeriv,
    PreparedNurbs, PreparedTrig, Segment, Vec3,
};
use crate::path::{Block, Toolpath};
use std::sync::Arc;

/// The program's moves in arc length, with the joints classified: the whole program
/// ([`PathIndex::new`]) or a window of a streamed one ([`PathIndex::streamed`]).
#[derive(Clone, Debug)]
pub struct PathIndex {
    /// Moves (zero-length moves dropped) of a whole program; empty when streamed.
    pub moves: Vec<PlanMove>,
    /// The window of a streamed program.
    stream: Option<Arc<MoveWindow>>,
    /// Start point of the program.
    pub start: Vec3,
    /// Events before the first move: `(reason, dwell seconds)`, if any.
    pub lead: Option<(StopReason, f64)>,
    /// Total arc length (mm).
    pub total_len: f64,
    /// Bit mask of the extra axes present ([`crate::path::EXTRA_AXIS_NAMES`]).
    pub extra_axes_mask: u8,
    /// Extra-axis motions at stops, in order of `s`.
    pub rests: Vec<ExtraRest>,
}

pub(super) fn move_len(seg: &Segment) -> f64 {
    match seg {
        Segment::Line(l) => l.length(),
        Segment::Arc(a) => a.length(),
        // The spline's weights once, not at every node.
        Segment::Trig(c) => arclen_adaptive(&PreparedTrig::new(c), 0.0, 1.0, ARCLEN_ACCURACY_MM),
        // Span by span, split at the knots where the speed's derivatives jump (equal
        // parameter pieces cut spans of non-uniform knots and recurse deep there).
        Segment::Nurbs(n) => match PreparedNurbs::new(n) {
            Some(p) => {
                let br = p.breaks();
                let share = ARCLEN_ACCURACY_MM / (br.len() - 1) as f64;
                br.windows(2)
                    .map(|w| arclen_adaptive(&p, w[0], w[1], share))
                    .sum()
            }
            None => crate::geom::ParamCurveArclen::arclen(n.as_ref(), ARCLEN_ACCURACY_MM),
        },
        _ => {
            let mut s = 0.0;
            let n = spans(seg);
            for j in 0..n {
                s += arclen_adaptive(
                    seg,
                    j as f64 / n as f64,
                    (j + 1) as f64 / n as f64,
                    ARCLEN_ACCURACY_MM,
                );
            }
            s
        }
    }
}

/// Fewest moves for which [`move_lens_and_joints`] starts threads.
pub(super) const PARALLEL_MIN_MOVES: usize = 4096;

/// For every move of `path`, in order: its [`move_len`], and the [`joint_after`] it with
/// the next move (if any). On up to [`crate::par::MAX_THREADS`] threads: the adaptive
/// quadrature of curved moves and the joints' tangents and curvatures are most of the
/// indexing time, and each is computed alone, so the result does not depend on the number
/// of threads. The joint is the one the index uses when nothing comes between the two
/// moves (no event, no dropped zero-length move).
fn move_lens_and_joints(
    path: &Toolpath,
    opts: &PlanOptions,
    caps: &Caps,
) -> Vec<(f64, Option<After>)> {
    let segs: Vec<&Segment> = path
        .blocks
        .iter()
        .filter_map(|b| match b {
            Block::Move(m) => Some(&m.segment),
            Block::Event(_) => None,
        })
        .collect();
    crate::par::map(segs.len(), PARALLEL_MIN_MOVES, |i| {
        let joint = segs
            .get(i + 1)
            .map(|next| joint_after(segs[i], next, opts, caps));
        (move_len(segs[i]), joint)
    })
}

pub(super) fn spans(seg: &Segment) -> usize {
    match seg {
        Segment::Nurbs(n) => {
            let mut k: Vec<f64> = n.knots().to_vec();
            k.dedup();
            (k.len().max(2) - 1).max(1)
        }
        _ => 1,
    }
}

/// Curvature vector at `t`, read slightly inside where the parametric speed vanishes.
pub(super) fn curvature_at(seg: &Segment, t: f64) -> Vec3 {
    let d1 = seg.deriv(t);
    let d2 = seg.deriv2(t);
    if d1.norm_sq() > 1e-18 * d2.norm_sq().max(1e-300) && d1.norm_sq() > 0.0 {
        return seg.curvature_vec(t);
    }
    let tp = if t > 0.5 {
        t - ZERO_SPEED_PROBE
    } else {
        t + ZERO_SPEED_PROBE
    };
    seg.curvature_vec(tp)
}

/// Unit tangent, curvature vector and point at `t` (as [`tangent_at`], [`curvature_at`]
/// and `eval`), from one evaluation of the point and its derivatives where the
/// parametric speed does not vanish.
///
/// `curve` is `seg` itself or an equivalent evaluator of it (a [`PreparedTrig`]).
pub(super) fn geo_at(seg: &Segment, curve: &impl ParamCurveDeriv, t: f64) -> (Vec3, Vec3, Vec3) {
    let [p, d1, d2] = curve.ders(t);
    let (s1, s2) = (d1.norm_sq(), d2.norm_sq());
    if !(s1 > 1e-18 * s2.max(1e-300) && s1 > 0.0) || t <= 0.0 || t >= 1.0 {
        return (tangent_at(seg, t), curvature_at(seg, t), p);
    }
    let tangent = d1 / s1.sqrt();
    (tangent, curvature_vec_from(d1, d2), p)
}

pub(super) fn tangent_at(seg: &Segment, t: f64) -> Vec3 {
    if t <= 0.0 {
        return seg.start_tangent().unwrap_or(Vec3::X);
    }
    if t >= 1.0 {
        return seg.end_tangent().unwrap_or(Vec3::X);
    }
    seg.deriv(t).normalized().unwrap_or_else(|| {
        (seg.eval((t + ZERO_SPEED_PROBE).min(1.0)) - seg.eval(t))
            .normalized()
            .unwrap_or(Vec3::X)
    })
}

impl PathIndex {
    /// Indexes `path` under `opts` (which supplies the feed and rapid rates and the joint
    /// rule). `opts` must be valid.
    pub fn new(path: &Toolpath, opts: &PlanOptions) -> PathIndex {
        let caps = caps_of(opts);
        let lens = move_lens_and_joints(path, opts, &caps);
        let mut b = IndexBuilder::new(opts, caps);
        let mut lens = lens.into_iter();
        for block in &path.blocks {
            match block {
                Block::Event(e) => b.event(&e.kind),
                Block::Move(m) => {
                    let (len, joint) = lens.next().expect("one per move");
                    b.push_move(m, len, joint);
                }
            }
        }
        b.end();
        PathIndex {
            moves: b.moves,
            stream: None,
            start: path.start,
            lead: b.lead,
            total_len: b.s,
            extra_axes_mask: path.extra_axes_mask,
            rests: b.rests,
        }
    }
    /// The index of a streamed program whose moves arrive in `window` (see
    /// [`crate::feed::window`]); `start` is where the program starts when it has no move.
    pub fn streamed(window: Arc<MoveWindow>, start: Vec3, extra_axes_mask: u8) -> PathIndex {
        PathIndex {
            moves: Vec::new(),
            stream: Some(window),
            start,
            lead: None,
            total_len: 0.0,
            extra_axes_mask,
            rests: Vec::new(),
        }
    }

    /// Move `j` (waiting for it when streamed), `None` past the end.
    #[inline]
    pub fn get(&self, j: usize) -> Option<MoveRef<'_>> {
        match &self.stream {
            None => self.moves.get(j).map(MoveRef::Borrowed),
            Some(w) => w.get(j).map(MoveRef::Shared),
        }
    }

    /// Rest `k` (see [`PathIndex::rests`]) when there is one at or before arc length `s`
    /// (or later); `None` when there is none up to `s` (waiting, when streamed, until
    /// that is known).
    pub fn rest(&self, k: usize, s: f64) -> Option<RestRef<'_>> {
        match &self.stream {
            None => self.rests.get(k).map(RestRef::Borrowed),
            Some(w) => w.rest(k, s).map(RestRef::Shared),
        }
    }

    /// `reader` needs no move below `j` (a streamed program drops them).
    #[inline]
    pub fn release(&self, reader: Reader, j: usize) {
        if let Some(w) = &self.stream {
            w.release(reader, j);
        }
    }

    /// The interpolator needs no rest below `k`.
    pub fn release_rests(&self, k: usize) {
        if let Some(w) = &self.stream {
            w.release_rests(k);
        }
    }

    /// `reader` does not read this index.
    pub fn not_reading(&self, reader: Reader) {
        if let Some(w) = &self.stream {
            w.not_reading(reader);
        }
    }

    /// Whether the program is streamed.
    pub fn is_streamed(&self) -> bool {
        self.stream.is_some()
    }

    /// Whether the program is known to have fewer than `n` moves (a streamed one is
    /// taken as long).
    pub fn shorter_than(&self, n: usize) -> bool {
        self.stream.is_none() && self.moves.len() < n
    }

    /// The events before the first move (waiting for them when streamed).
    pub fn lead(&self) -> Option<(StopReason, f64)> {
        match &self.stream {
            None => self.lead,
            Some(w) => w.lead(),
        }
    }

    /// Where motion starts: the first move's start, or the program's start.
    pub fn start_point(&self) -> Vec3 {
        match &self.stream {
            None => self.moves.first().map_or(self.start, |m| m.segment.start()),
            Some(w) => w.start(self.start),
        }
    }

    /// Moves, total length and end point (waiting for the end when streamed).
    pub fn summary(&self) -> Summary {
        match &self.stream {
            None => Summary {
                moves: self.moves.len(),
                total_len: self.total_len,
                end: self.end_point(),
            },
            Some(w) => w.summary(),
        }
    }

    /// End point of the program.
    pub fn end_point(&self) -> Vec3 {
        match &self.stream {
            None => self.moves.last().map_or(self.start, |m| m.segment.end()),
            Some(w) => w.summary().end,
        }
    }
}
