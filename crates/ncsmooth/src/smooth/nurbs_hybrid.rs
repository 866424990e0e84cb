//! NURBS-circular hybrid smoothing (Wu et al., sections II and III): `--method nurbs`.
//!
//! 1. **Screening** (section II.B, eqs. 6-9): [`super::screen`] finds the runs of
//!    micro-lines that sample a smooth curve.
//! 2. **Fitting** (section II.A, eq. 5): each run becomes a cubic B-spline (a NURBS with
//!    unit weights) by global interpolation through its points
//!    ([`crate::geom::global_interp`], NURBS Book A9.1): chord-length parameters (centripetal as an
//!    option), averaging knots, a banded `O(n)` solve. With
//!    [`NurbsOptions::end_tangents`] (default) the curve is constrained (NURBS Book 9.2.2) to
//!    leave and join along its first and last chords, i.e. tangentially to the lines it
//!    continues.
//! 3. **Fit check and split rule** (the paper is silent): the fitted curve interpolates the
//!    vertices but may bulge between them. Its two-sided deviation from the run's own
//!    polyline is measured with [`crate::verify::deviation_segments`] at accuracy
//!    `fit_accuracy_share * tol`, and accepted when `measured + accuracy <= tol` (a proved
//!    bound). Otherwise the run is split at its middle vertex and both halves are fitted
//!    again, recursively; at a split vertex both halves are constrained to the same tangent
//!    (the bisector of the two chord directions) so the joint stays G1. A single chord that
//!    still fails (never seen on screened data) is emitted as its line, an exact stop at its
//!    ends.
//! 4. **Corners** (section III): line-line corners get the arc of eqs. 10-14
//!    ([`super::arc_corner`]). Line-curve (Fig. 5) and curve-curve (Fig. 6) corners: a
//!    piece `BC` of the run's end line, of length `l_c` from eq. 11 (at most half of that
//!    line), is reserved before fitting and the curve is fitted from `C`. With end-tangent
//!    constraints, the curve's tangent at `C` is the line `BC` itself, so the paper's
//!    intersection point `E` of that tangent with the neighbouring line is exactly `B`, and
//!    the transition is the ordinary line-line arc at `B` between the neighbour and the
//!    stub `BC` (which it may use whole: nothing else trims it). The arc ends on the stub,
//!    tangent to it, and the stub joins the curve tangentially: G1 throughout.
//!    Without end-tangent constraints the curve's end tangent is free; such joints are not
//!    blended (exact stop, counted) rather than risking an unmeasured `E`.
//! 5. **Input arcs** stay exact; non-tangent joints involving them are blended first
//!    ([`super::arc_joint`], as in `--method arc`), and the few that cannot be are exact
//!    stops, counted in `corners_stopped` and `arc_joints`.
//!
//! ## Run mode (an extension)
//! With [`SmoothOptions::run`] enabled (the default) steps 1 and 3 change; the rest is the
//! paper's. Screening uses [`ScreenOptions::run_mode`]: the chord-error condition of eq. 6
//! is relaxed to `RUN_CHORD_SHARE` (8.0) times the tolerance and turns up to
//! `RUN_MAX_TURN_DEG` (105.0) qualify, so the sampled tips of a curve stay in its
//! run instead of becoming arc corners. The run is fitted not by interpolating its
//! vertices (which makes the curve follow every sample and bulge between them) but by the
//! cubic B-spline of least curvature and curvature variation within the two-sided band
//! ([`super::band_fit`]; still a NURBS with unit weights, still cubic), which joins the
//! stubs along them with zero curvature (G2; the stub-arc joints of section III stay G1
//! as in the paper). Where that fit fails, step 3 runs as without the run mode.
//!
//! Report: `runs_fitted` counts the emitted curves (after splitting), `points_per_run` and
//! `fit_deviation_per_run_mm` (the measured deviation) are given per emitted curve.

use super::arc_corner::{
    blend_items, merge_micro_legs, simplify_straight_runs, tangent_length, Item, CORNER_TOL_SHARE,
    MICRO_LEG_SHARE,
};
use super::band_fit::{band_fit, EndCond};
use super::run_mode::neighbour;
use super::screen::{screen, Run, ScreenOptions};
use super::{Chain, ChainPos, SmoothOptions, SmoothReport};
use crate::geom::global_interp::{interpolate, interpolate_with_tangents, Parametrization};
use crate::geom::{Line, Segment, Vec3};
use crate::path::Move;
use crate::verify::{deviation_segments, DEGENERATE_MM};

/// Degree of the fitted curves (the paper's cubic NURBS).
pub(crate) const FIT_DEGREE: usize = 3;

/// Settings of `--method nurbs`.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct NurbsOptions {
    /// Screening of micro-line runs (eqs. 6-9). Default: [`ScreenOptions::default`].
    pub screen: ScreenOptions,
    /// Parametrisation of the fit. Default: chord length (as geomdl and the paper).
    pub parametrization: Parametrization,
    /// Constrain the curve's end tangents to its end chords (NURBS Book 9.2.2). Default
    /// true; false fits plain A9.1 and leaves the curve-line joints as exact stops.
    pub end_tangents: bool,
    /// Accuracy of the fit-deviation measurement as a share of the tolerance. Default
    /// 0.01: the measured deviation is within 1 % of tol of the truth.
    pub fit_accuracy_share: f64,
}

/// Builders: each sets one field (see its doc for the default).
impl NurbsOptions {
    /// Sets [`NurbsOptions::screen`].
    pub fn with_screen(mut self, screen: ScreenOptions) -> Self {
        self.screen = screen;
        self
    }

    /// Sets [`NurbsOptions::parametrization`].
    pub fn with_parametrization(mut self, parametrization: Parametrization) -> Self {
        self.parametrization = parametrization;
        self
    }

    /// Sets [`NurbsOptions::end_tangents`].
    pub fn with_end_tangents(mut self, end_tangents: bool) -> Self {
        self.end_tangents = end_tangents;
        self
    }

    /// Sets [`NurbsOptions::fit_accuracy_share`].
    pub fn with_fit_accuracy_share(mut self, fit_accuracy_share: f64) -> Self {
        self.fit_accuracy_share = fit_accuracy_share;
        self
    }
}

impl Default for NurbsOptions {
    fn default() -> Self {
        NurbsOptions {
            screen: ScreenOptions::default(),
            parametrization: Parametrization::ChordLength,
            end_tangents: true,
            fit_accuracy_share: 0.01,
        }
    }
}

/// A fitted piece (or a fallback chord) between run points `a..=b`.
struct Piece {
    segment: Segment,
    a: usize,
    b: usize,
    fitted: bool,
    deviation_mm: f64,
}

/// Fits `pts[a..=b]` (tangents `ta`, `tb` when given), splitting until the tolerance holds.
#[allow(clippy::too_many_arguments)]
fn fit_range(
    pts: &[Vec3],
    a: usize,
    b: usize,
    ta: Option<Vec3>,
    tb: Option<Vec3>,
    kind: Parametrization,
    tol: f64,
    accuracy: f64,
    out: &mut Vec<Piece>,
) {
    let sub = &pts[a..=b];
    let curve = match (ta, tb) {
        (Some(ta), Some(tb)) => interpolate_with_tangents(sub, FIT_DEGREE, kind, ta, tb),
        _ => interpolate(sub, FIT_DEGREE, kind),
    };
    if let Some(c) = curve {
        let seg = Segment::from(c);
        let lines: Vec<Segment> = sub
            .windows(2)
            .map(|w| Segment::Line(Line::new(w[0], w[1])))
            .collect();
        let prog: Vec<(&Segment, u32)> = lines.iter().map(|s| (s, 0)).collect();
        let dev = deviation_segments(&[(&seg, 0)], &prog, accuracy).max_mm();
        if dev.is_finite() && dev + accuracy <= tol {
            out.push(Piece {
                segment: seg,
                a,
                b,
                fitted: true,
                deviation_mm: dev,
            });
            return;
        }
    }
    if b - a <= 1 {
        out.push(Piece {
            segment: Segment::Line(Line::new(pts[a], pts[b])),
            a,
            b,
            fitted: false,
            deviation_mm: 0.0,
        });
        return;
    }
    let m = (a + b) / 2;
    let u0 = (pts[m] - pts[m - 1]).normalized();
    let u1 = (pts[m + 1] - pts[m]).normalized();
    let tm = match (u0, u1) {
        (Some(x), Some(y)) => (x + y).normalized().or(Some(y)),
        (x, y) => x.or(y),
    };
    // Without tangents at the run ends, a half keeps plain interpolation only if it has
    // enough points; the split vertex always gets a tangent (G1 there).
    let (ta_l, tb_r) = match (ta, tb) {
        (Some(x), Some(y)) => (Some(x), Some(y)),
        _ => (
            (pts[a + 1] - pts[a]).normalized(),
            (pts[b] - pts[b - 1]).normalized(),
        ),
    };
    fit_range(pts, a, m, ta_l, tm, kind, tol, accuracy, out);
    fit_range(pts, m, b, tm, tb_r, kind, tol, accuracy, out);
}

/// Length of the stub reserved at one end of a run: `l_c` of eq. 11 for the corner with
/// the neighbouring line (at most half the run's end line), or 0 when that joint is
/// straight, not with a line, or at a chain end.
fn stub_length(
    moves: &[Move],
    nb: Option<usize>,
    run_dir: Vec3,
    run_line_len: f64,
    incoming: bool,
    opts: &SmoothOptions,
) -> f64 {
    let Some(k) = nb else { return 0.0 };
    let Segment::Line(l) = &moves[k].segment else {
        return 0.0;
    };
    let Some(d) = (l.p1 - l.p0).normalized() else {
        return 0.0;
    };
    let beta = if incoming {
        d.angle_to(run_dir)
    } else {
        run_dir.angle_to(d)
    };
    if beta.to_degrees() < opts.straight_angle_deg {
        return 0.0;
    }
    let l = tangent_length(beta, opts.tol_mm * CORNER_TOL_SHARE).min(0.5 * run_line_len);
    if l.is_finite() && l > DEGENERATE_MM {
        l
    } else {
        0.0
    }
}

/// Items of one run: stubs, fitted curves (and fallback chords).
fn run_items(chain: &Chain<'_>, run: Run, opts: &SmoothOptions) -> RunItems {
    let mut out = RunItems::default();
    let items = &mut out.items;
    let moves = chain.moves;
    let no = &opts.nurbs;
    let line_of = |i: usize| match &moves[i].segment {
        Segment::Line(l) => *l,
        _ => unreachable!("screened runs hold lines only"),
    };
    let first = line_of(run.first);
    let last = line_of(run.last);
    let (len_f, len_l) = (first.length(), last.length());
    let (dir_f, dir_l) = ((first.p1 - first.p0) / len_f, (last.p1 - last.p0) / len_l);
    let (s0, s1) = if no.end_tangents {
        (
            stub_length(
                moves,
                neighbour(moves, run.first, false),
                dir_f,
                len_f,
                true,
                opts,
            ),
            stub_length(
                moves,
                neighbour(moves, run.last, true),
                dir_l,
                len_l,
                false,
                opts,
            ),
        )
    } else {
        (0.0, 0.0)
    };
    let mut pts: Vec<Vec3> = Vec::with_capacity(run.points());
    pts.push(first.p0 + dir_f * s0);
    for i in run.first..run.last {
        pts.push(line_of(i).p1);
    }
    pts.push(last.p1 - dir_l * s1);
    let np = pts.len();
    let pos = |k: usize| -> ChainPos {
        if k == 0 {
            ChainPos {
                index: run.first,
                frac: s0 / len_f,
            }
        } else if k == np - 1 {
            ChainPos {
                index: run.last,
                frac: 1.0 - s1 / len_l,
            }
        } else {
            ChainPos::start_of(run.first + k)
        }
    };
    if s0 > 0.0 {
        items.push(Item::Line {
            p0: first.p0,
            p1: pts[0],
            from: ChainPos::start_of(run.first),
            to: pos(0),
            share: 1.0,
        });
    }
    let (ta, tb) = if no.end_tangents {
        (Some(dir_f), Some(dir_l))
    } else {
        (None, None)
    };
    let accuracy = opts.tol_mm * no.fit_accuracy_share;
    let mut pieces = Vec::new();
    let band = opts.run.enabled.then(|| {
        // Run mode: one curve through the band, G2 to the lines beyond its ends (G1 to
        // an input arc or curve); free at a chain end.
        let cond = |nb: Option<usize>, at_start: bool, d: Vec3| match nb {
            Some(_) => EndCond::Line(d),
            None => super::run_mode::chain_end_cond(chain, at_start, d),
        };
        band_fit(
            &pts,
            cond(neighbour(moves, run.first, false), true, dir_f),
            cond(neighbour(moves, run.last, true), false, dir_l),
            opts.tol_mm * CORNER_TOL_SHARE,
            accuracy,
            &opts.run.fit,
        )
    });
    match band.flatten() {
        Some(f) => pieces.push(Piece {
            segment: Segment::from(f.curve),
            a: 0,
            b: np - 1,
            fitted: true,
            deviation_mm: f.deviation_mm,
        }),
        None => fit_range(
            &pts,
            0,
            np - 1,
            ta,
            tb,
            no.parametrization,
            opts.tol_mm * CORNER_TOL_SHARE,
            accuracy,
            &mut pieces,
        ),
    }
    for p in pieces {
        if p.fitted {
            out.fitted.push((p.b - p.a + 1, p.deviation_mm));
        }
        items.push(Item::Fixed {
            segment: p.segment,
            from: pos(p.a),
            to: pos(p.b),
            input_arc: false,
        });
    }
    if s1 > 0.0 {
        items.push(Item::Line {
            p0: pts[np - 1],
            p1: last.p1,
            from: pos(np - 1),
            to: ChainPos::end_of(run.last),
            share: 1.0,
        });
    }
    out
}

/// What [`run_items`] makes of a run: its items, and the points and measured deviation of
/// each fitted curve (for the report).
#[derive(Default)]
struct RunItems {
    items: Vec<Item>,
    fitted: Vec<(usize, f64)>,
}

/// `--method nurbs` on one chain.
pub fn smooth_nurbs(
    chain: &Chain<'_>,
    opts: &SmoothOptions,
    report: &mut SmoothReport,
) -> Vec<Move> {
    let screening = if opts.run.enabled {
        &opts.run.screen
    } else {
        &opts.nurbs.screen
    };
    let runs = screen(chain, screening, opts.tol_mm);
    let mut items: Vec<Item> = Vec::with_capacity(chain.moves.len());
    // The runs are fitted independently: on all cores, then put in place in order.
    let fitted = crate::par::map(runs.len(), super::run_mode::PARALLEL_MIN_RUNS, |k| {
        run_items(chain, runs[k], opts)
    });
    let mut next_run = runs.iter().zip(fitted).peekable();
    let mut i = 0;
    while i < chain.moves.len() {
        if let Some((r, _)) = next_run.peek().filter(|(r, _)| r.first == i) {
            i = r.last + 1;
            let (_, done) = next_run.next().expect("peeked");
            for (points, dev) in done.fitted {
                report.runs_fitted += 1;
                report.points_per_run.push(points);
                report.fit_deviation_per_run_mm.push(dev);
            }
            items.extend(done.items);
            continue;
        }
        match &chain.moves[i].segment {
            Segment::Line(l) if l.length() > DEGENERATE_MM => items.push(Item::Line {
                p0: l.p0,
                p1: l.p1,
                from: ChainPos::start_of(i),
                to: ChainPos::end_of(i),
                share: 0.5,
            }),
            Segment::Line(_) => {}
            s => items.push(Item::Fixed {
                segment: s.clone(),
                from: ChainPos::start_of(i),
                to: ChainPos::end_of(i),
                input_arc: matches!(s, Segment::Arc(_)),
            }),
        }
        i += 1;
    }
    if items.is_empty() {
        return super::passthrough(chain);
    }
    let micro_mm = opts.tol_mm * MICRO_LEG_SHARE;
    let shift = simplify_straight_runs(&mut items, chain, micro_mm);
    let shift = shift + merge_micro_legs(&mut items, micro_mm);
    let pieces = blend_items(
        &items,
        opts.tol_mm - shift,
        opts.straight_angle_deg,
        &opts.arc,
        report,
    );
    super::assemble(chain, pieces)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::ParamCurve;
    use crate::path::Toolpath;
    use crate::smooth::{smooth, Method};
    use crate::verify::{continuity_joints, deviation, JointClass};
    use proptest::prelude::*;

    fn nurbs_opts(tol: f64) -> SmoothOptions {
        SmoothOptions {
            method: Method::Nurbs,
            tol_mm: tol,
            ..Default::default()
        }
    }

    /// Long line, a finely sampled arc, a sharp corner, another sampled arc, a long line.
    fn crownish() -> Vec<Vec3> {
        let mut pts = vec![Vec3::new(-30.0, 0.0, 0.0), Vec3::ZERO];
        let r = 20.0;
        for i in 1..=100 {
            let a = i as f64 * 0.012;
            pts.push(Vec3::new(r * a.sin(), r - r * a.cos(), 0.0));
        }
        let c = *pts.last().unwrap();
        for i in 1..=80 {
            let a = i as f64 * 0.015;
            pts.push(c + Vec3::new(-10.0 * a.sin(), 10.0 * (1.0 - a.cos()), 0.0));
        }
        let e = *pts.last().unwrap();
        pts.push(e + Vec3::new(0.0, 25.0, 0.0));
        pts
    }

    fn check(pts: &[Vec3], opts: &SmoothOptions) -> crate::smooth::Smoothed {
        let tp = Toolpath::from_polyline(pts, Some(10.0));
        let s = smooth(&tp, opts).unwrap();
        for m in s.toolpath.moves() {
            assert!(m.segment.start().is_finite() && m.segment.end().is_finite());
        }
        let dev = deviation(&s.toolpath, &tp, opts.tol_mm * 1e-3);
        assert!(dev.max_mm() <= opts.tol_mm, "{dev:?} {:?}", s.report);
        let (_, joints) = continuity_joints(&s.toolpath);
        assert!(joints.iter().all(|j| j.class != JointClass::Gap));
        let g0 = joints.iter().filter(|j| j.class == JointClass::G0).count();
        assert!(g0 <= s.report.corners_stopped, "{g0} {:?}", s.report);
        s
    }

    #[test]
    fn fits_runs_and_blends_corners_g1() {
        for tol in [0.002, 0.01, 0.05] {
            // The paper's fit (interpolation through the vertices): the run mode off.
            let mut o = nurbs_opts(tol);
            o.run.enabled = false;
            let s = check(&crownish(), &o);
            let r = &s.report;
            assert!(r.runs_fitted >= 2, "{r:?}");
            assert_eq!(r.points_per_run.len(), r.runs_fitted);
            assert!(r.fit_deviation_per_run_mm.iter().all(|&d| d <= tol));
            assert_eq!(r.corners_stopped, 0, "{r:?}");
            // The three corners (line-curve, curve-curve, curve-line) are blended.
            assert!(r.corners_smoothed >= 3, "{r:?}");
            assert!(s
                .toolpath
                .moves()
                .any(|m| matches!(m.segment, Segment::Nurbs(_))));
        }
    }

    #[test]
    fn split_rule_holds_tolerance_on_a_tight_fit() {
        // A coarse sampling of a wiggly curve: screening with a generous chord share
        // accepts it, the first fit bulges too much and must be split.
        let pts: Vec<Vec3> = (0..200)
            .map(|i| {
                let x = i as f64 * 0.2;
                Vec3::new(x, 0.3 * (x * 0.9).sin() + 0.05 * (x * 3.1).sin(), 0.0)
            })
            .collect();
        let mut o = nurbs_opts(0.002);
        o.nurbs.screen.chord_share = 1.0;
        o.nurbs.screen.ratio_max = 10.0;
        let s = check(&pts, &o);
        assert!(s.report.runs_fitted >= 1);
        // The split rule itself: a coarse half circle fitted at a tolerance far below its
        // chord error must be split, every accepted piece within tol, pieces contiguous.
        let pts: Vec<Vec3> = (0..=24)
            .map(|i| {
                let a = i as f64 * std::f64::consts::PI / 24.0;
                Vec3::new(10.0 * a.cos(), 10.0 * a.sin(), 0.0)
            })
            .collect();
        for tol in [0.01, 0.002, 0.0005] {
            let mut pieces = Vec::new();
            let (ta, tb) = (Some(Vec3::Y), Some(-Vec3::Y));
            let kind = Parametrization::ChordLength;
            fit_range(&pts, 0, 24, ta, tb, kind, tol, tol * 0.01, &mut pieces);
            assert!(pieces.len() > 1, "tol {tol}");
            assert_eq!(pieces[0].a, 0);
            assert_eq!(pieces.last().unwrap().b, 24);
            for w in pieces.windows(2) {
                assert_eq!(w[0].b, w[1].a);
            }
            for p in &pieces {
                assert!(p.deviation_mm <= tol);
                let lines: Vec<Segment> = pts[p.a..=p.b]
                    .windows(2)
                    .map(|w| Segment::Line(Line::new(w[0], w[1])))
                    .collect();
                let prog: Vec<(&Segment, u32)> = lines.iter().map(|s| (s, 0)).collect();
                let d = deviation_segments(&[(&p.segment, 0)], &prog, tol * 1e-3);
                assert!(d.max_mm() <= tol, "tol {tol} {d:?}");
            }
        }
        let mut o = nurbs_opts(0.002);
        o.nurbs.parametrization = Parametrization::Centripetal;
        o.nurbs.end_tangents = false;
        check(&crownish(), &o);
    }

    fn polyline_strategy() -> impl Strategy<Value = (Vec<Vec3>, f64)> {
        let step = prop_oneof![
            (-5.0..5.0f64, -5.0..5.0f64, -1.0..1.0f64).prop_map(|(x, y, z)| Vec3::new(x, y, z)),
            (-1.0..1.0f64, -1.0..1.0f64).prop_map(|(x, y)| Vec3::new(x, y, 0.0) * 1e-3),
            Just(Vec3::ZERO),
        ];
        (
            prop::collection::vec(step, 1..30),
            prop_oneof![Just(0.002), Just(0.01), Just(0.05)],
            prop_oneof![Just(0.0), Just(1e5)],
            any::<u8>(),
            // A sampled arc inserted somewhere: radius, sample count, turn per sample.
            (1.0..50.0f64, 4usize..60, 0.005..0.2f64),
        )
            .prop_map(|(steps, tol, offset, mode, (r, n, dphi))| {
                let mut p = Vec3::new(offset, offset * 0.5, 0.0);
                let mut pts = vec![p];
                let insert_at = mode as usize % (steps.len() + 1);
                for (i, s) in steps.iter().enumerate() {
                    if i == insert_at {
                        let c = p + Vec3::new(0.0, r, 0.0);
                        for k in 1..=n {
                            let a = k as f64 * dphi;
                            pts.push(c + Vec3::new(r * a.sin(), -r * a.cos(), 0.0));
                        }
                        p = *pts.last().unwrap();
                    }
                    p += super::super::degenerate_step(&pts, *s, mode as usize + i);
                    pts.push(p);
                }
                (pts, tol)
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]
        #[test]
        fn nurbs_method_holds_tolerance((pts, tol) in polyline_strategy()) {
            check(&pts, &nurbs_opts(tol));
        }
    }
}
