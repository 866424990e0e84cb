//! The run mode of `bspline` (Guo), `trig` (Tao) and `arc` (Wu's arcs): a chain's runs of
//! micro-corners
//! replaced by one curve of the method's family through the tolerance band
//! ([`super::band_fit`]), before the method's own corner transitions run on what is left.
//! (`nurbs`, Wu, fits its runs in [`super::nurbs_hybrid`] itself, where the paper puts its
//! fitting step.)
//!
//! ## Rewriting a run
//! A run ([`super::screen`] with [`RunOptions::screen`](super::band_fit::RunOptions)) covers
//! the lines `first ..= last` of the chain. Its curve starts at `S` on the first line and
//! ends at `E` on the last:
//! * where the run meets a corner (a joint turning by at least the straight angle), `S`
//!   (`E`) is the middle of that line: the other half stays a line, a stub for the
//!   method's corner transition there (Guo's own rule lets a transition use at most half
//!   of a leg that ends in another transition, section 3.4), and the curve leaves along
//!   the stub with zero curvature ([`EndCond::Line`]: G2 to the stub);
//! * where it meets a straight joint or a curve (an input arc, a blend), `S` is the
//!   vertex itself and the curve leaves along the line (tangent to what comes before);
//! * at a chain end `S` is the vertex and the tangent is free ([`EndCond::Free`]), but
//!   along the line where the chain is a stream cut ([`Chain::open_ends`]).
//!
//! The fit holds the band against the run's own polyline `S, V_(first+1), .., E`, a part of
//! the programmed path, so the contract holds for the whole chain as it does for each
//! transition. The curve is then carried in the method's family:
//! * [`Family::Bezier`] (Guo): the cubic B-spline itself, cut at its knots into cubic
//!   Béziers (NURBS Book A5.6), as Guo's transitions are emitted: C2 inside the run, G2 to
//!   the stubs.
//! * [`Family::Trig`] (Tao): one cubic trigonometric segment per cubic piece of the
//!   B-spline, in Tao's Hermite form (`k = -1`, eq. 3) on a short parameter window
//!   ([`trig_window`], `TRIG_WINDOW` (0.05), `lambda = ` `TRIG_LAMBDA` (1.0)) with the piece's end
//!   points and end derivatives: G1 at the joints and G2 up to the window's small error;
//!   measured against the band like the B-spline (a fit a little inside the band,
//!   `TRIG_BAND_MARGIN` (0.01), leaves it room).
//! * [`Family::Arcs`] (Wu's arc transitions, `--method arc`): tangent-continuous arcs
//!   along the B-spline ([`super::arc_spline`], biarcs within half of `ARC_BAND_MARGIN` (0.04)
//!   of the tolerance, split until consecutive arcs differ little in curvature): G1 at the
//!   joints with curvature steps of a few per cent, where one arc per corner steps between
//!   zero and `1/R` at every leg.
//!
//! Each piece ends, on the chain, at the foot of its end point on the run's polyline
//! (`Fitted::foot`), not where its parameter would put it: the fit's parameter runs
//! along the lines at a varying speed, and the extra axes (a slicer's `E`) and feeds
//! follow these positions ([`super::assemble`]).
//!
//! A run whose fit fails stays lines, and the method handles its corners one by one as in
//! the paper.

use super::arc_spline::{arc_spline, MIN_ARC_MM};
use super::band_fit::{band_fit, polyline_deviation, BandFit, EndCond};
use super::screen::{screen, Run};
use super::{assemble, Chain, ChainPos, OutPiece, SmoothOptions, SmoothReport};
use crate::geom::{
    trig_basis, trig_basis_deriv, CubicBez, Line, Nurbs, ParamCurve, Segment, TrigSpline, Vec3,
};
use crate::path::Move;
use crate::verify::DEGENERATE_MM;

/// Share of the tolerance used by the accuracy of the fits' measurements (a fit is
/// accepted when measured + accuracy <= tol; the band's dense check holds the curve to
/// `tol - 2 accuracy`, still outside the band of [`super::band_fit::BandFitOptions`]).
pub(crate) const MEASURE_SHARE: f64 = 0.02;
/// Share of a line left to the corner transition at a run end that meets a corner.
pub(crate) const STUB_SHARE: f64 = 0.5;
/// Parameter window of the trigonometric run segments ([`trig_window`]).
pub(crate) const TRIG_WINDOW: f64 = 0.05;
/// `lambda` of the trigonometric run segments: the circle's (eq. 9).
pub(crate) const TRIG_LAMBDA: f64 = 1.0;
/// Share of the tolerance taken off the B-spline's band when a trigonometric spline is to
/// follow it.
pub(crate) const TRIG_BAND_MARGIN: f64 = 0.01;
/// Share of the tolerance taken off the B-spline's band when arcs are to follow it; the
/// arcs keep within half of it from the B-spline.
pub(crate) const ARC_BAND_MARGIN: f64 = 0.04;

/// How far along the run (mm of its chord-length parameter) a piece end's foot on the
/// polyline is searched from the parameter's own chord (`Fitted::foot`).
pub(crate) const POS_SEARCH_MM: f64 = 2.0;
/// Chords whose distance to a piece end is within this share of the tolerance of the
/// nearest are equally near for `Fitted::foot` (a hairpin narrower than the band).
pub(crate) const POS_TIE_SHARE: f64 = 0.1;

/// Fewest runs in a chain for fitting them on several threads.
pub(crate) const PARALLEL_MIN_RUNS: usize = 16;

/// How the run curves are carried.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// Cubic Béziers (Guo).
    Bezier,
    /// Cubic trigonometric splines (Tao).
    Trig,
    /// Tangent-continuous circular arcs (Wu's arc transitions, [`super::arc_spline`]).
    Arcs,
}

/// The previous (`forward = false`) or next non-degenerate move of the chain from `i`.
pub(crate) fn neighbour(moves: &[Move], i: usize, forward: bool) -> Option<usize> {
    let mut j = i;
    loop {
        if forward {
            j += 1;
            if j >= moves.len() {
                return None;
            }
        } else {
            j = j.checked_sub(1)?;
        }
        if moves[j].segment.length(DEGENERATE_MM) > DEGENERATE_MM {
            return Some(j);
        }
    }
}

/// Where a run ends: the share of its end line kept as a stub, and the end condition.
fn run_end(
    chain: &Chain<'_>,
    line: usize,
    dir: Vec3,
    at_start: bool,
    straight_deg: f64,
) -> (f64, EndCond) {
    let moves = chain.moves;
    let Some(nb) = neighbour(moves, line, !at_start) else {
        return (0.0, chain_end_cond(chain, at_start, dir));
    };
    let (a, b) = if at_start {
        (&moves[nb].segment, &moves[line].segment)
    } else {
        (&moves[line].segment, &moves[nb].segment)
    };
    let corner = matches!(moves[nb].segment, Segment::Line(_))
        && super::turn_angle_deg(a, b).is_none_or(|t| t >= straight_deg);
    (if corner { STUB_SHARE } else { 0.0 }, EndCond::Line(dir))
}

/// The end condition of a run curve at the chain's start (`at_start`) or end: free, but
/// along the move's direction `dir` where the chain was cut and the path goes on.
pub(crate) fn chain_end_cond(chain: &Chain<'_>, at_start: bool, dir: Vec3) -> EndCond {
    if chain.open_ends[usize::from(!at_start)] {
        EndCond::Line(dir)
    } else {
        EndCond::Free
    }
}

/// A fitted run: its curve, the chord-length parameters of its points and where they lie
/// on the chain.
struct Fitted {
    fit: BandFit,
    /// Chord-length parameter (mm) of each run point.
    u: Vec<f64>,
    /// Per chord of the run: its move and the shares of that move where it starts and ends.
    chords: Vec<(usize, f64, f64)>,
    pts: Vec<Vec3>,
}

impl Fitted {
    /// Chain position of the share `f` of chord `j`.
    fn chord_pos(&self, j: usize, f: f64) -> ChainPos {
        let (index, fa, fb) = self.chords[j];
        let f = f.clamp(0.0, 1.0);
        ChainPos {
            index,
            frac: fa + (fb - fa) * f,
        }
    }

    /// Where `q`, the curve's point at the run parameter `p` (mm), lies on the run's
    /// polyline: its foot on the nearest chord within [`POS_SEARCH_MM`] of `p`, not before
    /// `after` (a chord and a share of it), among chords about as near (within
    /// [`POS_TIE_SHARE`] of `tol`) the one whose foot is nearest to `p` in the parameter.
    ///
    /// The curve's parameter runs along the polyline at varying speed (a taut spline
    /// through the band): on cncjs_sample_slic3r, a 1.55 mm line's point at a parameter
    /// was up to 0.2 mm off the one at the same chord length, so the extrusion put at the
    /// parameter's position strayed by up to 0.0125 mm of filament.
    fn foot(&self, q: Vec3, p: f64, after: (usize, f64), tol: f64) -> (usize, f64) {
        let n = self.u.len() - 1;
        let lo = self
            .u
            .partition_point(|&x| x < p - POS_SEARCH_MM)
            .saturating_sub(1);
        let hi = self.u.partition_point(|&x| x <= p + POS_SEARCH_MM).min(n);
        let cands: Vec<(usize, f64, f64)> = (lo.max(after.0)..hi.max(after.0 + 1).min(n))
            .map(|j| {
                let (a, b) = (self.pts[j], self.pts[j + 1]);
                let d = b - a;
                let l2 = d.norm_sq();
                let mut f = if l2 > 0.0 { (q - a).dot(d) / l2 } else { 0.0 };
                f = f.clamp(0.0, 1.0);
                if j == after.0 {
                    f = f.max(after.1);
                }
                (j, f, q.dist(a + d * f))
            })
            .collect();
        let best = cands.iter().map(|c| c.2).fold(f64::INFINITY, f64::min);
        let at = |c: &(usize, f64, f64)| {
            let (j, f, _) = *c;
            (self.u[j] + (self.u[j + 1] - self.u[j]) * f - p).abs()
        };
        cands
            .iter()
            .filter(|c| c.2 <= best + POS_TIE_SHARE * tol)
            .min_by(|x, y| at(x).total_cmp(&at(y)))
            .map_or(after, |c| (c.0, c.1))
    }

    /// Chain positions of the curve's start and end.
    fn ends(&self) -> (ChainPos, ChainPos) {
        let (i0, f0, _) = self.chords[0];
        let (i1, _, f1) = self.chords[self.chords.len() - 1];
        (
            ChainPos {
                index: i0,
                frac: f0,
            },
            ChainPos {
                index: i1,
                frac: f1,
            },
        )
    }
}

/// Fits run `r` of the chain; `None` when the fit fails.
fn fit_run(chain: &Chain<'_>, r: Run, opts: &SmoothOptions, family: Family) -> Option<Fitted> {
    let moves = chain.moves;
    let line = |i: usize| match &moves[i].segment {
        Segment::Line(l) => Some(*l),
        _ => None,
    };
    let (first, last) = (line(r.first)?, line(r.last)?);
    let (df, dl) = (
        (first.p1 - first.p0).normalized()?,
        (last.p1 - last.p0).normalized()?,
    );
    let straight = opts.straight_angle_deg;
    let (s0, c0) = run_end(chain, r.first, df, true, straight);
    let (s1, c1) = run_end(chain, r.last, dl, false, straight);
    let mut pts = vec![first.p0.lerp(first.p1, s0)];
    for i in r.first..r.last {
        pts.push(line(i)?.p1);
    }
    pts.push(last.p1.lerp(last.p0, s1));
    let chords = (r.first..=r.last)
        .map(|i| {
            let fa = if i == r.first { s0 } else { 0.0 };
            let fb = if i == r.last { 1.0 - s1 } else { 1.0 };
            (i, fa, fb)
        })
        .collect();
    let tol = opts.tol_mm * super::arc_corner::CORNER_TOL_SHARE;
    let mut fo = opts.run.fit.clone();
    // Room for the trigonometric spline or the arcs that follow the B-spline.
    let margin = match family {
        Family::Trig => TRIG_BAND_MARGIN,
        Family::Arcs => ARC_BAND_MARGIN,
        Family::Bezier => 0.0,
    };
    fo.band_share -= margin;
    if let Some(ts) = fo.time_shape.as_mut() {
        ts.band_share -= margin;
    }
    let fit = band_fit(&pts, c0, c1, tol, opts.tol_mm * MEASURE_SHARE, &fo)?;
    let mut u = vec![0.0];
    for w in pts.windows(2) {
        u.push(u[u.len() - 1] + w[0].dist(w[1]));
    }
    Some(Fitted {
        fit,
        u,
        chords,
        pts,
    })
}

/// The distinct knots of `c` (its breakpoints).
fn breakpoints(c: &Nurbs) -> Vec<f64> {
    let mut b = c.knots().to_vec();
    b.dedup();
    b
}

/// The run curve as cubic Béziers (the B-spline cut at its knots), with their parameter
/// ranges (mm).
fn bezier_pieces(f: &Fitted) -> Vec<(Segment, f64, f64)> {
    let c = &f.fit.curve;
    let len = f.u[f.u.len() - 1];
    let b = breakpoints(c);
    let h = |q: &[f64; 4]| Vec3::new(q[0] / q[3], q[1] / q[3], q[2] / q[3]);
    c.bezier_pieces()
        .iter()
        .zip(b.windows(2))
        .map(|(q, w)| {
            let bez = CubicBez::new(h(&q[0]), h(&q[1]), h(&q[2]), h(&q[3]));
            (Segment::CubicBez(bez), w[0] * len, w[1] * len)
        })
        .collect()
}

/// A trigonometric spline segment (eq. 2, shape `lambda`, `k = -1`) on the parameter
/// window `[0, eps]` of its natural parameter that starts at `p0` with derivative `d0`
/// and ends at `p1` with derivative `d1` (derivatives with respect to the window's own
/// parameter `t in [0, 1]`, `u = eps t`): the four control points solve the 4 x 4 system
/// `B(0) q = p0`, `B(eps) q = p1`, `eps B'(0) q = d0`, `eps B'(eps) q = d1`.
///
/// This is how Tao et al. describe a circular arc of less than 90 degrees (a window of
/// the quarter-circle segment, "through the control of the value of parameter u"),
/// applied to a cubic piece: on a short window the basis `{C^3, S^3, S^2, C, S, 1}`
/// spans the cubics up to `O(eps)`, so the segment follows the cubic Hermite curve with
/// the same end data (a Bézier piece of the run's B-spline) closely, curvature included
/// (`TRIG_WINDOW` (0.05); measured by the caller). `None` when the system is singular.
pub fn trig_window(
    p0: Vec3,
    d0: Vec3,
    p1: Vec3,
    d1: Vec3,
    eps: f64,
    lambda: f64,
) -> Option<TrigSpline> {
    let k = -1.0;
    let b0 = trig_basis(0.0, lambda, k);
    let b1 = trig_basis(eps, lambda, k);
    let (e0, e1) = (
        trig_basis_deriv(0.0, lambda, k),
        trig_basis_deriv(eps, lambda, k),
    );
    let mut a = [[0.0; 4]; 4];
    for j in 0..4 {
        a[0][j] = b0[j];
        a[1][j] = b1[j];
        a[2][j] = eps * e0[j];
        a[3][j] = eps * e1[j];
    }
    // The system in differences from p0 keeps the digits at large coordinates: the basis
    // sums to one and its derivatives to zero.
    let mut r = [Vec3::ZERO, p1 - p0, d0, d1];
    // Gaussian elimination with partial pivoting.
    for c in 0..4 {
        let piv = (c..4).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))?;
        if a[piv][c].is_nan() || a[piv][c].abs() <= f64::MIN_POSITIVE {
            return None;
        }
        a.swap(c, piv);
        r.swap(c, piv);
        for i in c + 1..4 {
            let f = a[i][c] / a[c][c];
            for j in c..4 {
                a[i][j] -= f * a[c][j];
            }
            r[i] -= r[c] * f;
        }
    }
    let mut q = [Vec3::ZERO; 4];
    for i in (0..4).rev() {
        let mut v = r[i];
        for j in i + 1..4 {
            v -= q[j] * a[i][j];
        }
        q[i] = v / a[i][i];
    }
    let seg = TrigSpline {
        u0: 0.0,
        u1: eps,
        ..TrigSpline::new(p0 + q[0], p0 + q[1], p0 + q[2], p0 + q[3], lambda, k)
    };
    seg.q0.is_finite().then_some(seg)
}

/// The run curve as trigonometric spline segments, one per cubic piece of the B-spline
/// ([`trig_window`] on that piece's end points and end derivatives: C1 in the pieces'
/// parameters, so G1, and G2 up to the window's small error), measured against the band;
/// `None` when it does not hold it.
fn trig_pieces(f: &Fitted, tol: f64, accuracy: f64) -> Option<Vec<(Segment, f64, f64)>> {
    let mut out = Vec::new();
    for (seg, a, b) in bezier_pieces(f) {
        let Segment::CubicBez(c) = seg else {
            return None;
        };
        let (d0, d1) = ((c.p1 - c.p0) * 3.0, (c.p3 - c.p2) * 3.0);
        let t = trig_window(c.p0, d0, c.p3, d1, TRIG_WINDOW, TRIG_LAMBDA)?;
        out.push((Segment::Trig(t), a, b));
    }
    holds_band(f, out, tol, accuracy)
}

/// `pieces` when they hold the band around the run's polyline (measured within `accuracy`).
fn holds_band(
    f: &Fitted,
    pieces: Vec<(Segment, f64, f64)>,
    tol: f64,
    accuracy: f64,
) -> Option<Vec<(Segment, f64, f64)>> {
    let refs: Vec<(&Segment, u32)> = pieces.iter().map(|s| (&s.0, 0)).collect();
    let dev = polyline_deviation(&refs, &f.pts, accuracy).max_mm();
    (dev.is_finite() && dev + accuracy <= tol).then_some(pieces)
}

/// The run curve as an arc spline ([`super::arc_spline`], each cubic piece within half
/// of [`ARC_BAND_MARGIN`] of the tolerance), measured against the band; `None` when it
/// does not hold it.
fn arc_pieces(f: &Fitted, tol: f64, accuracy: f64) -> Option<Vec<(Segment, f64, f64)>> {
    let c = &f.fit.curve;
    let len = f.u[f.u.len() - 1];
    if len < 2.0 * MIN_ARC_MM {
        // A cluster of steps shorter than two arcs is one corner of the arc transitions
        // (their micro-leg merging), not a curve.
        return None;
    }
    let mut arcs = Vec::new();
    // Knot spans shorter than the shortest arc (a CAM file's quantisation steps) go with
    // the next: a biarc a few nanometres long turns in whatever direction round-off says.
    let b = breakpoints(c);
    let mut from = b[0];
    for (i, &t) in b.iter().enumerate().skip(1) {
        let last = i + 1 == b.len();
        if !last && c.eval(from).dist(c.eval(t)) < 2.0 * MIN_ARC_MM {
            continue;
        }
        if !arc_spline(c, from, t, 0.5 * ARC_BAND_MARGIN * tol, &mut arcs) {
            return None;
        }
        from = t;
    }
    let mut a = b[0];
    let out = arcs
        .into_iter()
        .map(|(s, t)| {
            let piece = (s, a * len, t * len);
            a = t;
            piece
        })
        .collect();
    holds_band(f, out, tol, accuracy)
}

/// The chain with its runs replaced by stubs and fitted curves of `family` (module doc),
/// or `None` when no run was fitted. Counts the fitted runs in `report`.
pub(crate) fn rewrite_runs(
    chain: &Chain<'_>,
    opts: &SmoothOptions,
    family: Family,
    report: &mut SmoothReport,
) -> Option<Vec<Move>> {
    if !opts.run.enabled {
        return None;
    }
    let runs = screen(chain, &opts.run.screen, opts.tol_mm);
    let moves = chain.moves;
    let tol = opts.tol_mm * super::arc_corner::CORNER_TOL_SHARE;
    let accuracy = opts.tol_mm * MEASURE_SHARE;
    let mut pieces: Vec<OutPiece> = Vec::with_capacity(moves.len());
    let mut any = false;
    let mut next = 0;
    // The fits are independent: made on all cores, then put in place in order.
    let curves = crate::par::map(runs.len(), PARALLEL_MIN_RUNS, |k| {
        let f = fit_run(chain, runs[k], opts, family)?;
        let segs = match family {
            Family::Bezier => Some(bezier_pieces(&f)),
            Family::Trig => trig_pieces(&f, tol, accuracy),
            Family::Arcs => arc_pieces(&f, tol, accuracy),
        }?;
        Some((f, segs))
    });
    for (&r, curve) in runs.iter().zip(curves) {
        let Some((f, segs)) = curve else {
            continue;
        };
        for i in next..r.first {
            pieces.push(OutPiece {
                segment: moves[i].segment.clone(),
                from: ChainPos::start_of(i),
                to: ChainPos::end_of(i),
            });
        }
        let (s, e) = (f.pts[0], f.pts[f.pts.len() - 1]);
        let (pos_s, pos_e) = f.ends();
        let first = moves[r.first].segment.start();
        if s != first {
            pieces.push(OutPiece {
                segment: Segment::Line(Line::new(first, s)),
                from: ChainPos::start_of(r.first),
                to: pos_s,
            });
        }
        report.runs_fitted += 1;
        report.points_per_run.push(f.pts.len());
        report.fit_deviation_per_run_mm.push(f.fit.deviation_mm);
        // Each piece ends where its end point's foot on the polyline is, so that the
        // extra axes (a slicer's E) follow the program along the curve.
        let mut at = (0, 0.0);
        let mut from = pos_s;
        let n_segs = segs.len();
        for (k, (seg, _, b)) in segs.into_iter().enumerate() {
            let to = if k + 1 == n_segs {
                pos_e
            } else {
                at = f.foot(seg.end(), b, at, tol);
                f.chord_pos(at.0, at.1)
            };
            pieces.push(OutPiece {
                segment: seg,
                from,
                to,
            });
            from = to;
        }
        let last = moves[r.last].segment.end();
        if e != last {
            pieces.push(OutPiece {
                segment: Segment::Line(Line::new(e, last)),
                from: pos_e,
                to: ChainPos::end_of(r.last),
            });
        }
        any = true;
        next = r.last + 1;
    }
    if !any {
        return None;
    }
    for i in next..moves.len() {
        pieces.push(OutPiece {
            segment: moves[i].segment.clone(),
            from: ChainPos::start_of(i),
            to: ChainPos::end_of(i),
        });
    }
    Some(assemble(chain, pieces))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trig_window_follows_a_cubic() {
        use crate::geom::{ParamCurve, ParamCurveCurvature, ParamCurveDeriv};
        let c = CubicBez::new(
            Vec3::new(100.0, 50.0, 0.0),
            Vec3::new(100.1, 50.02, 0.0),
            Vec3::new(100.2, 50.07, 0.0),
            Vec3::new(100.3, 50.15, 0.0),
        );
        let (d0, d1) = ((c.p1 - c.p0) * 3.0, (c.p3 - c.p2) * 3.0);
        let t = trig_window(c.p0, d0, c.p3, d1, TRIG_WINDOW, TRIG_LAMBDA).unwrap();
        assert!(t.start().dist(c.p0) < 1e-12 && t.end().dist(c.p3) < 1e-9);
        assert!(t.deriv(0.0).dist(d0) < 1e-9 && t.deriv(1.0).dist(d1) < 1e-9);
        for i in 0..=20 {
            let x = i as f64 / 20.0;
            assert!(t.eval(x).dist(c.eval(x)) < 1e-5, "{x}");
            let (kt, kc) = (t.curvature(x), c.curvature(x));
            assert!((kt - kc).abs() < 0.02 * kc + 1e-6, "{x}: {kt} {kc}");
        }
    }

    /// Every method with a run mode, on a sampled curve with sharp tips: the two-sided
    /// tolerance holds, no tangent break appears, the curve is G2 or nearly (the largest
    /// curvature step is small against the curvature), runs were fitted, and the peak
    /// curvature is well below the corner-by-corner one.
    #[test]
    fn run_mode_holds_tol_and_lowers_the_peaks() {
        use crate::geom::{ParamCurveArclen, ParamCurveCurvature};
        use crate::path::Toolpath;
        use crate::smooth::{smooth, Method};
        use crate::verify::{continuity_joints, deviation, JointClass};
        // The first 300 chords of butterfly_1000, its first sampled tip included.
        let pts = &crate::profiles::butterfly_polyline(1000, 1e-7)[..300];
        let tp = Toolpath::from_polyline(pts, Some(50.0));
        let tol = 0.01;
        let peak = |t: &Toolpath| {
            t.moves()
                .flat_map(|m| {
                    let len = m.segment.arclen(1e-9);
                    (0..=8).map(move |i| (m.segment.clone(), len, i))
                })
                .filter(|(s, len, _)| !matches!(s, Segment::Line(_)) && *len > 1e-6)
                .map(|(s, _, i)| s.curvature((i as f64 / 8.0).clamp(1e-6, 1.0 - 1e-6)))
                .fold(0.0, f64::max)
        };
        for method in [Method::Bspline, Method::Nurbs, Method::Trig, Method::Arc] {
            let mut o = SmoothOptions {
                method,
                tol_mm: tol,
                ..Default::default()
            };
            let s = smooth(&tp, &o).unwrap();
            let dev = deviation(&s.toolpath, &tp, tol * 1e-3);
            assert!(dev.max_mm() <= tol, "{method:?}: {dev:?}");
            assert!(s.report.runs_fitted >= 1, "{method:?}: {:?}", s.report);
            let (_, joints) = continuity_joints(&s.toolpath);
            assert!(joints
                .iter()
                .all(|j| !matches!(j.class, JointClass::G0 | JointClass::Gap)));
            let run_peak = peak(&s.toolpath);
            let big_jumps = |joints: &[crate::verify::Joint]| {
                joints
                    .iter()
                    .filter(|j| j.curvature_jump >= 0.1 * run_peak)
                    .count()
            };
            o.run.enabled = false;
            let corners = smooth(&tp, &o).unwrap();
            let corner_peak = peak(&corners.toolpath);
            if method == Method::Arc {
                // Wu's arcs step in curvature at the corners left to the transitions
                // (from the line into 1/R); between the arcs of a run the steps are a few
                // per cent of the curvature (biarcs spanning less than 4 MIN_ARC_MM are
                // not split for it: their arcs are up to about 2 MIN_ARC_MM long).
                use crate::smooth::arc_spline::{CURVATURE_FLOOR_PER_MM, MIN_ARC_MM};
                let moves: Vec<_> = s.toolpath.moves().collect();
                let k = |i: usize| match moves[i].segment {
                    Segment::Arc(a) if a.length() >= 3.0 * MIN_ARC_MM => Some(1.0 / a.radius),
                    _ => None,
                };
                let mut arc_joints = 0;
                for j in &joints {
                    if let (Some(a), Some(b)) = (k(j.move_index), k(j.move_index + 1)) {
                        let allow = 0.1 * a.max(b) + 2.0 * CURVATURE_FLOOR_PER_MM;
                        assert!(j.curvature_jump <= allow, "{j:?}: {a} {b}");
                        arc_joints += 1;
                    }
                }
                assert!(arc_joints > 100, "{arc_joints}");
            } else {
                let jump = joints.iter().map(|j| j.curvature_jump).fold(0.0, f64::max);
                assert!(
                    big_jumps(&joints) == 0,
                    "{method:?}: jump {jump}, peak {run_peak}"
                );
            }
            assert!(
                run_peak < 0.8 * corner_peak,
                "{method:?}: {run_peak} against {corner_peak}"
            );
        }
    }
}
