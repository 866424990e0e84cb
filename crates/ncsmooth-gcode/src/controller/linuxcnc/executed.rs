//! The path LinuxCNC executes for a written program under `G64 P Q`, and its deviation
//! from the programmed path: the tolerance contract measured on what the machine runs,
//! not on the text plus a blanket `P + Q`.
//!
//! ## LinuxCNC's blend of two lines
//! LinuxCNC 2.9's trajectory planner (`tp.c`, `blendmath.c`: `tcFindBlendTolerance`,
//! `blendInit3FromLineLine`, `blendComputeParameters`) replaces the corner `V` between two
//! lines turning by `phi` by an arc tangent to both. With `theta = (pi - phi) / 2`:
//!
//! * the tolerance is `T = min(P1, P2, L1 / 4, L2 / 4)` (a `P` of 0 counts as the line's
//!   `L / 4`);
//! * each line gives at most `d = min(L1 / 2, L2 / 2, cos(theta) T / (1 - sin(theta)))`
//!   (half of each line, `BLEND_DIST_FRACTION`, and what keeps the arc within `T` of `V`);
//! * the arc it plans has any radius up to `tan(theta) d` (the radius its speed needs,
//!   `max(v^2 / a_n, R_blend)`, never more).
//!
//! All arcs tangent to both lines are images of the largest one under a scaling about `V`
//! by `lambda` in `[0, 1]` (`lambda = 0`: the sharp corner, as where LinuxCNC joins two
//! lines as tangent). So whatever speed it plans, the executed path near `V` is one member
//! of that family, and it never leaves the halves of the two lines: the path is a chain
//! of independent *pieces*, one per junction, from the middle of one line to the middle
//! of the next.
//!
//! ## What is measured
//! * (a) every executed point to the programmed path: the written path's own figure (its
//!   straight parts are on the written lines), and over each blend the region between the
//!   largest arc and the corner, which holds every member. That region is swept by
//!   *fibres*: the radii of the largest arc continued out to the lines (length
//!   `R (sec a - 1)` at angle `a` from the nearer end, at most `h = R (sec(phi / 2) - 1)`,
//!   which is at most `T`, at the middle). Branch and bound on slices between two fibres:
//!   a slice lies in the convex hull of the sub-arc's ends, where its end tangents meet,
//!   and the fibres' ends on the line, and the distance to one programmed line is convex,
//!   so over the slice it is at most its largest at those five points (the line nearest
//!   the slice's middle; 1-Lipschitz bounds where that is an arc). At a join that is not
//!   modelled, the halves of its two moves are measured the same way, plus the blend
//!   counted: a move written as programmed lies on the programmed path, and the pieces of
//!   any other line or arc are held by convex sets (a line's ends; an arc piece's ends and
//!   tangent point, widened by its spiral and helix over the piece), so the bound shrinks
//!   with the square of the piece.
//! * (b) every programmed vertex to the executed path: every member of a family runs from
//!   one end of the largest arc to the other inside the region, so it crosses every
//!   fibre. A vertex is therefore at most its distance to its nearest written point plus
//!   the length of the fibre ending there (0 outside the blend, `h` at the corner), and
//!   at most its distance to the largest arc's ends.
//!
//! A rapid and a feed move are not blended: LinuxCNC stops between them (tp.c
//! `tpCheckCanonType`).
//!
//! Both are upper bounds within the given accuracy, for every choice LinuxCNC makes. `T` is
//! widened by `LINUXCNC_BLEND_EXCESS_SHARE`: LinuxCNC's arcs were measured up to 1.3 %
//! beyond it.
//!
//! ## Limits
//! Junctions that are not two lines in a bounded `G64 P Q0` (an arc, a naive-CAM `Q`, a
//! `G64` without `P`, a move the program runs more than once) are not modelled: there the
//! blend is counted as before, the written deviation plus the caller's `P + Q`. LinuxCNC's
//! parabolic blend, its fallback where an arc blend cannot be made, is not modelled either;
//! `linuxcnc_run.py --ref` measures the real planner. The writer bounds the main
//! program's copied moves, after a looser `G64` of the program's own too
//! ([`crate::rewrite`]), and the model caps every `P` at the largest one the writer gives
//! (`cap_mm`); a looser `G64` inside a subprogram written after the program's end stays
//! the program's and is not modelled.

use crate::interpreter::program::Program;
use crate::source::PathMode;
use ncsmooth::geom::{Line, ParamCurve, Segment, Vec3};
use ncsmooth::path::MoveKind;
use ncsmooth::verify::{Deviation, NearestIndex};
use ncsmooth::Toolpath;

/// Turn (rad) below which two lines are collinear: no blend, no deviation.
const COLLINEAR_RAD: f64 = 1e-9;
/// Turn (rad) above which LinuxCNC cannot blend (a reversal): it stops at the corner.
const REVERSAL_RAD: f64 = std::f64::consts::PI - 1e-6;
/// Gap (mm) between one move's end and the next one's start above which they do not
/// meet (they are read from the same printed coordinates when they do).
const CONTIGUOUS_MM: f64 = 1e-9;
/// Cells a blend's region may be split into before its bound is taken as it stands.
const MAX_CELLS_PER_BLEND: usize = 1024;
/// Share by which the model widens LinuxCNC's blend tolerance `T`. LinuxCNC 2.9's arcs run
/// slightly beyond it: measured with `linuxcnc_run.py` (50 mm/s, 500 mm/s^2) at lone
/// corners between 20 mm lines under `G64 P0.00971 Q0`, the corner's distance to the
/// executed path was 1.003 to 1.013 `P` (turns of 15 to 150 degrees, `scripts/linuxcnc_corner_excess.py`).
pub(crate) const LINUXCNC_BLEND_EXCESS_SHARE: f64 = 0.02;

/// Deviation of the path LinuxCNC executes (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Executed {
    /// (a) Largest distance from the executed path to the programmed path (mm).
    pub path_to_programmed_mm: f64,
    /// (b) Largest distance from a programmed vertex to the executed path (mm).
    pub vertex_to_path_mm: f64,
    /// Junctions whose blend was modelled (two lines under a bounded `P`, `Q0`).
    pub blends_modelled: usize,
    /// Junctions counted as the written deviation plus the caller's blend.
    pub blends_counted: usize,
}

impl Executed {
    /// The larger of (a) and (b).
    pub fn max_mm(&self) -> f64 {
        self.path_to_programmed_mm.max(self.vertex_to_path_mm)
    }
}

/// The largest arc LinuxCNC may blend a corner with, and its family.
#[derive(Clone, Copy, Debug)]
struct BlendArc {
    /// Length each line gives (mm).
    d: f64,
    /// Centre of the largest arc.
    center: Vec3,
    radius: f64,
    /// Unit vector from the centre to the arc's start.
    u: Vec3,
    /// Unit direction of the first line (the arc's direction at its start).
    w: Vec3,
    /// Swept angle: the turn.
    sweep: f64,
}

impl BlendArc {
    /// The blend of `a` then `b` (meeting at `a.p1`) within tolerance `t_mm`; `None` where
    /// LinuxCNC makes none (collinear, reversing, degenerate, `t_mm` of 0).
    fn new(a: &Line, b: &Line, t_mm: f64) -> Option<BlendArc> {
        let (da, db) = (a.p1 - a.p0, b.p1 - b.p0);
        let (la, lb) = (da.norm(), db.norm());
        let w = da.normalized()?;
        let w2 = db.normalized()?;
        let phi = w.angle_to(w2);
        if !(phi > COLLINEAR_RAD && phi < REVERSAL_RAD && t_mm > 0.0) {
            return None;
        }
        let theta = 0.5 * (std::f64::consts::PI - phi);
        let d_tol = theta.cos() * t_mm / (1.0 - theta.sin());
        let d = (0.5 * la).min(0.5 * lb).min(d_tol);
        let radius = theta.tan() * d;
        let inward = (w2 - w).normalized()?;
        let center = a.p1 + inward * (radius / theta.sin());
        let start = a.p1 - w * d;
        let u = (start - center).normalized()?;
        (radius > 0.0 && radius.is_finite()).then_some(BlendArc {
            d,
            center,
            radius,
            u,
            w,
            sweep: phi,
        })
    }

    /// Point `t` (0..1) of the largest arc.
    fn arc_point(&self, t: f64) -> Vec3 {
        let a = t * self.sweep;
        self.center + (self.u * a.cos() + self.w * a.sin()) * self.radius
    }

    /// Angle (rad) of `t` from the nearer end of the largest arc.
    fn end_offset_rad(&self, t: f64) -> f64 {
        let a = t * self.sweep;
        a.min(self.sweep - a)
    }

    /// Length (mm) of the fibre at `t`: from the largest arc out to the lines, along the
    /// radius through its point `t` (0 at the ends, `h` at the middle).
    fn fibre_len_mm(&self, t: f64) -> f64 {
        self.radius * (1.0 / self.end_offset_rad(t).cos() - 1.0)
    }

    /// Point `mu` (0: on the largest arc, 1: on the lines) of the fibre at `t`. The fibres
    /// sweep the region between the largest arc and the corner, which holds every member.
    fn fibre_point(&self, t: f64, mu: f64) -> Vec3 {
        let a = t * self.sweep;
        let out = 1.0 + mu * (1.0 / self.end_offset_rad(t).cos() - 1.0);
        self.center + (self.u * a.cos() + self.w * a.sin()) * (self.radius * out)
    }

    /// Five points whose convex hull holds the region between the fibres at `t0` and `t1`
    /// (both in one half, `t0 < t1`): the largest arc's points there and where its
    /// tangents at them meet (the sub-arc lies in that triangle), and the fibres' ends on
    /// the line.
    fn slice(&self, t0: f64, t1: f64) -> [Vec3; 5] {
        let half = 0.5 * (t1 - t0) * self.sweep;
        let a = 0.5 * (t0 + t1) * self.sweep;
        let apex = self.center + (self.u * a.cos() + self.w * a.sin()) * (self.radius / half.cos());
        [
            self.arc_point(t0),
            self.arc_point(t1),
            apex,
            self.fibre_point(t0, 1.0),
            self.fibre_point(t1, 1.0),
        ]
    }

    /// How far (mm) a fibre point moves per unit of `t`, at most: the radius out to the
    /// corner's `sec(phi / 2)` times the sweep, plus its stretch along the fibre.
    fn along_t_mm(&self) -> f64 {
        let half = 0.5 * self.sweep;
        self.radius * self.sweep / half.cos() * (1.0 + half.tan())
    }
}

/// How LinuxCNC joins move `k` to move `k + 1`.
#[derive(Clone, Copy, Debug)]
enum Join {
    /// A sharp corner (or none: collinear, or a stop).
    Exact,
    /// An arc blend of two lines.
    Blend(BlendArc),
    /// Not modelled: the written path plus this much (mm).
    Counted(f64),
}

/// The modelled `P` (mm) of a move in `mode`, capped at `cap_mm`: `None` when the mode
/// does not blend (exact path or stop), `Some(None)` when it is not modelled (a naive-CAM
/// `Q`, no `P`).
fn modelled_p(mode: PathMode, cap_mm: f64) -> Option<Option<f64>> {
    match mode {
        PathMode::ExactPath | PathMode::ExactStop => None,
        PathMode::Unset => Some(None),
        PathMode::Blend { p_mm, q_mm } => {
            if p_mm.is_nan() || q_mm.is_nan() || q_mm > 0.0 {
                Some(None)
            } else {
                Some(Some(p_mm.max(0.0).min(cap_mm)))
            }
        }
    }
}

/// A written move as LinuxCNC plans it: its segment, its path mode and its kind.
type Planned<'a> = (&'a Segment, PathMode, MoveKind);

/// The join of `a` then `b`.
fn join(a: Planned, b: Planned, cap_mm: f64, counted_mm: f64) -> Join {
    // Moves that do not meet (motion the path does not hold between them, such as a G53
    // move) have no corner between them to blend; nor do a rapid and a feed move, between
    // which LinuxCNC stops (tp.c `tpCheckCanonType`).
    if a.0.end().dist(b.0.start()) > CONTIGUOUS_MM || a.2 != b.2 {
        return Join::Exact;
    }
    // The first move's mode decides whether LinuxCNC blends at its end at all.
    let Some(pa) = modelled_p(a.1, cap_mm) else {
        return Join::Exact;
    };
    let pb = modelled_p(b.1, cap_mm).unwrap_or(Some(0.0));
    match (a.0, b.0, pa, pb) {
        (Segment::Line(la), Segment::Line(lb), Some(pa), Some(pb)) => {
            let (na, nb) = (la.length(), lb.length());
            // tc.c tcFindBlendTolerance: a zero tolerance counts as a quarter of the line.
            let ta = if pa == 0.0 { 0.25 * na } else { pa };
            let tb = if pb == 0.0 { 0.25 * nb } else { pb };
            let t = ta.min(tb).min(0.25 * na).min(0.25 * nb).min(cap_mm);
            let t = t * (1.0 + LINUXCNC_BLEND_EXCESS_SHARE);
            BlendArc::new(la, lb, t).map_or(Join::Exact, Join::Blend)
        }
        _ => Join::Counted(counted_mm),
    }
}

/// The deviation of what LinuxCNC executes for `written` (parsed from the written text,
/// with its source map) from `programmed`, within `accuracy_mm`. `written_dev` is the
/// written path's own measured deviation from `programmed`; `cap_mm` the largest `P` the
/// writer gives; `counted_mm` the blend counted at junctions not modelled.
pub fn linuxcnc_executed(
    written: &Program,
    programmed: &Toolpath,
    written_dev: &Deviation,
    cap_mm: f64,
    counted_mm: f64,
    accuracy_mm: f64,
) -> Executed {
    let moves: Vec<Planned> = written
        .toolpath
        .moves()
        .map(|m| {
            let info = written.source.lines.get((m.line as usize).wrapping_sub(1));
            let mode = match info {
                Some(i) if !m.pinned => i.state.path,
                _ => PathMode::Unset,
            };
            (&m.segment, mode, m.kind)
        })
        .collect();
    let joins: Vec<Join> = moves
        .windows(2)
        .map(|w| join(w[0], w[1], cap_mm, counted_mm))
        .collect();
    let flat = 0.25 * accuracy_mm;
    let slack = 0.5 * accuracy_mm;
    // (a): the written path, the halves of the moves at a counted join with its blend on
    // top, and every blend's region.
    let mut a = written_dev.output_to_programmed_mm;
    let mut prog = NearestIndex::new(programmed.moves().map(|m| &m.segment), flat);
    let programmed_segs: Vec<&Segment> = programmed.moves().map(|m| &m.segment).collect();
    for (k, j) in joins.iter().enumerate() {
        match j {
            Join::Blend(b) => a = region_sup(b, &mut prog, a, slack),
            Join::Counted(extra) => {
                let halves = [(moves[k].0, 0.5, 1.0), (moves[k + 1].0, 0.0, 0.5)];
                for (seg, t0, t1) in halves {
                    // A move written as programmed lies on the programmed path.
                    let (_, src) = prog.nearest(seg.eval(0.5 * (t0 + t1)));
                    if programmed_segs.get(src) == Some(&seg) {
                        a = a.max(*extra);
                        continue;
                    }
                    // A curve's half: the written path's figure stands for it.
                    let sup = half_sup(seg, t0, t1, &mut prog, (a - extra).max(0.0), slack)
                        .unwrap_or(written_dev.output_to_programmed_mm);
                    a = a.max(sup + extra);
                }
            }
            Join::Exact => {}
        }
    }
    // (b): every programmed vertex to the piece holding its nearest written point.
    let mut out = NearestIndex::new(moves.iter().map(|m| m.0), flat);
    let mut b = 0.0_f64;
    let vertices = programmed
        .moves()
        .next()
        .map(|m| m.segment.start())
        .into_iter()
        .chain(programmed.moves().map(|m| m.segment.end()));
    for q in vertices {
        let (dw, k) = out.nearest(q);
        if k == usize::MAX {
            b = f64::INFINITY;
            break;
        }
        let e = vertex_bound(q, dw, k, &moves, &joins);
        b = b.max(e);
    }
    Executed {
        path_to_programmed_mm: a,
        vertex_to_path_mm: b,
        blends_modelled: joins.iter().filter(|j| matches!(j, Join::Blend(_))).count(),
        blends_counted: joins
            .iter()
            .filter(|j| matches!(j, Join::Counted(_)))
            .count(),
    }
}

/// The largest distance to the programmed path over the region of `b`'s family, or `best`
/// when that is larger (within `slack`): branch and bound on slices of the region between
/// two fibres ([`BlendArc::slice`]).
fn region_sup(b: &BlendArc, prog: &mut NearestIndex, mut best: f64, slack: f64) -> f64 {
    let along = b.along_t_mm();
    let mut bound = |t0: f64, t1: f64, best: &mut f64| {
        let tm = 0.5 * (t0 + t1);
        let (f, line) = prog.nearest_line(b.arc_point(tm));
        *best = best.max(f);
        let hull = b.slice(t0, t1);
        // The distance to one programmed line is convex: over the slice, at most its
        // largest at the corners of a convex set holding it.
        let over = |l: Line| hull_dist(&l, &hull);
        let ub = match line {
            Some(l) => {
                let ub = over(l);
                if ub <= *best + slack {
                    ub
                } else {
                    // The line nearest the middle may not be the one a corner of the
                    // slice lies on (a third line passing near the blend): the nearest
                    // lines of the corners are tried too, the least bound kept.
                    hull.iter()
                        .filter_map(|&v| prog.nearest_line(v).1)
                        .map(over)
                        .fold(ub, f64::min)
                }
            }
            // A programmed arc: its chord across the slice's feet, plus the sagitta. Else
            // 1-Lipschitz: half the slice along the arc, all of its fibres across.
            None => prog.arc_hull_bound(&hull).unwrap_or_else(|| {
                f + 0.5 * (t1 - t0) * along + b.fibre_len_mm(t0).max(b.fibre_len_mm(t1))
            }),
        };
        Cell { ub, t: [t0, t1] }
    };
    // Best first: when patience runs out, the largest bound left is the answer.
    let mut heap = std::collections::BinaryHeap::new();
    heap.push(bound(0.0, 0.5, &mut best));
    heap.push(bound(0.5, 1.0, &mut best));
    let mut cells = 0;
    while let Some(cell) = heap.pop() {
        if cell.ub <= best + slack {
            break;
        }
        cells += 1;
        if cells > MAX_CELLS_PER_BLEND {
            return best.max(cell.ub);
        }
        let [t0, t1] = cell.t;
        let tm = 0.5 * (t0 + t1);
        heap.push(bound(t0, tm, &mut best));
        heap.push(bound(tm, t1, &mut best));
    }
    best
}

/// The largest distance to the programmed path over `seg` from `t0` to `t1`, or `best`
/// when that is larger (within `slack`): branch and bound, the distance to one programmed
/// line being convex along a line (so at most its larger end value), else 1-Lipschitz
/// along the length (the parameter's speed bounded by the line's length or the arc's
/// [`ncsmooth::geom::Arc::max_speed`]). `None` for a curve other than a line or an arc, or when the bound
/// does not settle.
fn half_sup(
    seg: &Segment,
    t0: f64,
    t1: f64,
    prog: &mut NearestIndex,
    mut best: f64,
    slack: f64,
) -> Option<f64> {
    let len = match seg {
        Segment::Line(l) => l.length(),
        Segment::Arc(a) => a.max_speed(),
        _ => return None,
    };
    let mut stack = vec![(t0, t1)];
    let mut steps = 0;
    while let Some((ta, tb)) = stack.pop() {
        let tm = 0.5 * (ta + tb);
        let (f, near) = prog.nearest_line(seg.eval(tm));
        best = best.max(f);
        let lipschitz = f + 0.5 * len * (tb - ta);
        // The piece's bound over a convex set holding it: a line's two ends; an arc's
        // triangle ([`arc_piece_hull`]), which may be the looser bound on a long piece.
        let ub = match seg {
            Segment::Arc(a) => arc_piece_hull(a, ta, tb).map_or(lipschitz, |(h, e)| {
                hull_bound(prog, &h, e, near, lipschitz).min(lipschitz)
            }),
            _ => hull_bound(prog, &[seg.eval(ta), seg.eval(tb)], 0.0, near, lipschitz),
        };
        if ub <= best + slack {
            continue;
        }
        steps += 1;
        if steps > MAX_CELLS_PER_BLEND {
            // Out of patience (an arc that follows a programmed one): the caller's
            // figure for the whole written path stands.
            return None;
        }
        stack.push((ta, tm));
        stack.push((tm, tb));
    }
    Some(best)
}

/// Largest distance from the points `hull` to the line `l`: over their convex hull the
/// distance to one line (convex) is at most that.
fn hull_dist(l: &Line, hull: &[Vec3]) -> f64 {
    hull.iter()
        .map(|&v| l.dist_sq(v))
        .fold(0.0, f64::max)
        .sqrt()
}

/// An upper bound on the distance to the programmed path over a set within `e` of the
/// convex hull of `hull`: [`hull_dist`] to `near`, the programmed line nearest the last
/// query, or along a programmed arc its chord bound ([`NearestIndex::arc_hull_bound`]);
/// `fallback` when neither applies.
fn hull_bound(
    prog: &NearestIndex,
    hull: &[Vec3],
    e: f64,
    near: Option<Line>,
    fallback: f64,
) -> f64 {
    match near {
        Some(l) => hull_dist(&l, hull) + e,
        None => prog.arc_hull_bound(hull).map_or(fallback, |b| b + e),
    }
}

/// Largest half-turn (rad) of an arc piece that [`arc_piece_hull`] bounds by a triangle
/// (its apex is `1 / cos` of it out from the arc).
const MAX_HULL_HALF_TURN_RAD: f64 = std::f64::consts::FRAC_PI_4;

/// A triangle holding the piece of `a` from `ta` to `tb` up to `e` (mm): the piece's ends
/// and the meeting point of its end tangents, on the planar circle through its middle
/// radius and height; `e` bounds how far the piece leaves that circle (its radius and its
/// height change linearly along the parameter, by `spiral` and `axial` over the arc, so
/// a point at `t` is within `|t - tm| |(spiral, axial)|` of the circle's point at the same
/// angle). `None` for a piece turning by more than twice [`MAX_HULL_HALF_TURN_RAD`].
fn arc_piece_hull(a: &ncsmooth::geom::Arc, ta: f64, tb: f64) -> Option<([Vec3; 3], f64)> {
    let half = 0.5 * a.sweep * (tb - ta);
    if half.is_nan() || half.abs() >= MAX_HULL_HALF_TURN_RAD {
        return None;
    }
    let tm = 0.5 * (ta + tb);
    let r = a.radius + a.spiral * tm;
    let base = a.center + a.axial * tm;
    let dir = |t: f64| {
        let (s, c) = (a.sweep * t).sin_cos();
        a.u * c + a.v * s
    };
    let hull = [
        base + dir(ta) * r,
        base + dir(tb) * r,
        base + dir(tm) * (r / half.cos()),
    ];
    let e = 0.5 * (tb - ta) * a.spiral.hypot(a.axial.norm());
    Some((hull, e))
}

/// A cell of [`region_sup`], ordered by its upper bound.
struct Cell {
    ub: f64,
    t: [f64; 2],
}

impl PartialEq for Cell {
    fn eq(&self, o: &Self) -> bool {
        self.ub.total_cmp(&o.ub).is_eq()
    }
}
impl Eq for Cell {}
impl PartialOrd for Cell {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Cell {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.ub.total_cmp(&o.ub)
    }
}

/// An upper bound on the distance from `q` to the executed path, `q`'s nearest written
/// point being `dw` away on move `k`.
fn vertex_bound(q: Vec3, dw: f64, k: usize, moves: &[Planned], joins: &[Join]) -> f64 {
    let Segment::Line(line) = moves[k].0 else {
        // Not a line: its joins are counted, whichever is nearer.
        let worst = [k.checked_sub(1), Some(k)]
            .into_iter()
            .flatten()
            .filter_map(|j| joins.get(j))
            .map(|j| match j {
                Join::Counted(b) => *b,
                _ => 0.0,
            })
            .fold(0.0, f64::max);
        return dw + worst;
    };
    // The nearest written point, and which half of move k it is on: its start belongs to
    // join k - 1, its end to join k.
    let dir = line.p1 - line.p0;
    let len_sq = dir.dot(dir);
    let s = if len_sq > 0.0 {
        ((q - line.p0).dot(dir) / len_sq).clamp(0.0, 1.0)
    } else {
        1.0
    };
    let (j, from_corner) = if s >= 0.5 {
        (Some(k), (1.0 - s) * len_sq.sqrt())
    } else {
        (k.checked_sub(1), s * len_sq.sqrt())
    };
    match j.and_then(|j| joins.get(j)) {
        None | Some(Join::Exact) => dw,
        Some(Join::Counted(b)) => dw + b,
        Some(Join::Blend(arc)) => fibre_bound(q, dw, from_corner, arc),
    }
}

/// An upper bound on the distance from `q` to any member of `arc`'s family, through its
/// nearest written point `y` (`dw` away, `from_corner` from the corner along its line).
/// Every member crosses every fibre, so it passes within the fibre's length of `y`, and
/// through the largest arc's ends, where the fibres have none.
fn fibre_bound(q: Vec3, dw: f64, from_corner: f64, arc: &BlendArc) -> f64 {
    let along_tangent = (arc.d - from_corner).max(0.0);
    let fibre = if from_corner >= arc.d {
        0.0
    } else {
        arc.radius.hypot(along_tangent) - arc.radius
    };
    let ends = q.dist(arc.arc_point(0.0)).min(q.dist(arc.arc_point(1.0)));
    (dw + fibre).min(ends)
}

#[cfg(test)]
mod tests;
