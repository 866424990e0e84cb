//! Corner smoothing with tolerance-band cubic B-splines (Guo, Yan and Wang, "Toolpath
//! smoothing based on controlled NURBS interpolation", J. Eng. Res. Rep. 25(12), 2023,
//! sections 3.1 to 3.5): [`Method::Bspline`](super::Method::Bspline).
//!
//! ## The transition (sections 3.1, 3.2)
//! At a corner `Q0 Q1 Q2` of two lines, a cubic B-spline with five control points
//! `P0..P4`, `P2 = Q1`, `P0 P1` on the incoming leg and `P3 P4` on the outgoing one, all
//! four control-polygon edges of the same length `L`, and the knot vector
//! [`KNOTS`] `= {0,0,0,0,0.5,1,1,1,1}`. With `a`, `b` the unit vectors from `Q1` towards `Q0`
//! and `Q2`: `P0 = Q1 + 2L a`, `P1 = Q1 + L a`, `P3 = Q1 + L b`, `P4 = Q1 + 2L b`. The
//! paper's three cases (`L0 < L1`, `L0 = L1`, `L0 > L1`, [`BsplineTransition::from_corner`])
//! are this construction with `2L = min(L0, L1)`.
//!
//! The B-spline has one simple interior knot, so it is *exactly* two cubic Béziers (insert
//! `u = 1/2` twice, Boehm): `[P0, P1, (P1+P2)/2, M]` and `[M, (P2+P3)/2, P3, P4]` with the
//! shoulder point `M = C(1/2) = (P1 + 2 P2 + P3) / 4 = Q1 + L (a + b) / 4`
//! ([`BsplineTransition::beziers`]). The output carries them as two
//! [`Segment::CubicBez`] moves (no NURBS evaluation on the hot path).
//!
//! Because `P0 P1 P2` and `P2 P3 P4` are collinear, the second derivative at each end is
//! parallel to the leg: the end curvature is zero and the path `line, C, line` is GC2.
//!
//! ## Error (equation 7) and scaling (section 3.3)
//! `e = |Q1 - C(1/2)| = L |a + b| / 4 = L cos(theta) / 2` with `theta` half the corner
//! angle ([`corner_error`]). Scaling the control polygon about `P2` by `alpha` scales `e` by
//! `alpha`, so the target error `e*` is met in closed form: `alpha = e* / e0`,
//! `L* = alpha L = 2 e* / cos(theta)`. No sampling, no iteration.
//!
//! ## Tolerance: how `tol` maps to the paper's `delta`, `epsilon` and `e*`
//! For this curve both distances are known in closed form:
//! * the farthest output point from the legs is `M`, at `e sin(theta)` from both (the
//!   distance of the first half to the incoming leg is `e sin(theta) t^3`, and the feet lie
//!   on the leg: the control points' abscissae along `a` are `2L, L, L/2, L cos^2(theta)/2`,
//!   all in `[0, 2L]`);
//! * the nearest output point to the corner `Q1` is `M`, at `e` (the curve is convex, being
//!   the B-spline of the convex polygon `P0 Q1 P4`, and symmetric about the bisector).
//!
//! The paper bounds only the first: band half-width `delta`, corner allowance
//! `epsilon = delta / sin(theta)`, ideal error `e* = delta / 2`; a corner whose initial
//! error is below `epsilon` keeps it, so the corner itself may be missed by up to
//! `delta / sin(theta)` (unbounded for sharp corners). [`BandSemantics::PaperBand`] keeps
//! exactly that (`delta = tol`), to reproduce the paper's worked example.
//!
//! The default [`BandSemantics::TwoSided`] honours the crate's contract: `delta = tol`,
//! `epsilon = e* = tol (1 - TOL_SAFETY)` for every corner. Then the vertex side is `e <= tol`
//! and the output side `e sin(theta) <= e <= tol`: both hold by construction, with the
//! largest transition (lowest curvature) the contract allows.
//!
//! ## Neighbouring transitions (sections 3.4, 3.5)
//! The chain is processed in order (routines 1 to 3): each corner's transition uses what
//! is left of its incoming leg after the previous transition, `P0^{i+1} = P4^i +
//! lambda (Q_{i+2} - P4^i)` (equation 8, [`BsplineOptions::lambda`]), and its outgoing leg.
//! The edge length is `L = min(L_in, L_out) / 2` (section 3.2), reduced by section 3.3 when
//! its error is too large. Section 3.4's rule "alpha = 1/2 when `P4` reaches the next
//! vertex" is applied as a *cap*: `P4` never passes the midpoint of an outgoing leg that
//! ends in another transition (this is what the rule gives when it fires; applied only on
//! exact equality it would let `P4` stop a hair short of the vertex and starve the next
//! corner). An outgoing leg that ends at the chain end, a straight junction or an exact stop
//! may be used in full (routine 3 has no halving either). Transitions therefore never
//! overlap, never cross a programmed vertex, and shrink with micro-segments as needed:
//! every line-line corner gets one, however short its legs.
//!
//! ## Choices where the paper is silent
//! * **Straight junctions** (turn below [`SmoothOptions::straight_angle_deg`]) pass through
//!   unchanged.
//! * **Reversals**: a corner angle `2 theta` at or below `REVERSAL_ANGLE_DEG` has no plane;
//!   the B-spline would retrace the leg with a cusp at `M`. It is an exact stop
//!   (`corners_stopped`). So is a corner whose transition would be shorter than
//!   [`DEGENERATE_MM`] (possible only with `lambda` close to 1).
//! * **Arcs** (and any other curve in the input) stay exact. Tangent joints need nothing.
//!   A non-tangent joint involving an input arc has been blended before this method runs
//!   ([`super::arc_joint`]: a G1 Bezier on the trimmed arc's end tangent, within tol), so
//!   it arrives here as two tangent joints; one that could not be blended (a near
//!   reversal) is an exact stop, counted in `arc_joints` and `corners_stopped`. The
//!   adjacent line may then be used in full by its other corner.
//! * **Zero-length moves** (lines up to [`DEGENERATE_MM`]) are skipped: the corner is formed
//!   by the neighbouring lines, the vertex kept within that length. Non-finite input leaves
//!   the chain unchanged.
//! * **Closed chains** (last point equals first within [`GAP_TOL_MM`], at least three
//!   moves) get a transition at the closing corner when
//!   [`BsplineOptions::smooth_closing_corner`] is set (the default) and the chain is not
//!   cut where the path goes on ([`super::Chain::open_ends`]). The chain's ends are
//!   pinned (a rapid or an event happens there and the machine is at rest there), so the
//!   loop is entered and left through its shoulder point `M`: a half circle (two cubic
//!   quarter circles) from `Q0` to `M` arriving along the transition's direction, the second half of the closing
//!   transition, the loop, its first half, and the other half circle back to `Q0` (the two
//!   "hooks" make the circle of diameter `e = |Q0 M| <= tol` through `Q0` and `M`, so they
//!   stay within `tol` of `Q0`). The loop itself is GC2 all round and the hooks join it
//!   tangentially (G1, a curvature step the planner allows for), so no exact stop is
//!   added; a straight lead line would turn by 90 degrees at `M`, a stop in the middle of
//!   the motion. The paper's own 3-D example leaves the closing corner alone (five
//!   transitions for six corners): `smooth_closing_corner = false`.
//! * **3-D**: `a`, `b` span the plane of the two legs; nothing else is needed.
//!
//! ## Run mode (an extension; [`super::run_mode`])
//! The paper smooths one corner at a time and names the drawback itself (section 5: "the
//! inability to achieve curvature continuity along the entire toolpath"). On a curve
//! sampled every few tenths of a millimetre, one transition per vertex makes the curvature
//! go straight, blend, straight, blend, with peaks far above the sampled curve's. With
//! [`SmoothOptions::run`] enabled (the default), runs of micro-corners (turns up to
//! `RUN_MAX_TURN_DEG` (105.0) between lines of similar length) are first replaced
//! by one cubic B-spline through the whole two-sided band ([`super::band_fit`]: the curve
//! of least curvature and curvature variation within the band), carried as the cubic
//! Béziers of its knot spans like the transitions here. What follows the paper: the curve
//! family (a clamped cubic B-spline), the GC2 joins (the run curve leaves and joins its end
//! lines along them with zero curvature, because its first and last three control points
//! are collinear with the line, section 3.1's argument), and every other corner, sharp or
//! between long lines, gets the transition of sections 3.1 to 3.5 below, using the half of
//! the run's end line the run leaves it. What extends it: the run's control points are
//! chosen by an optimisation instead of the construction of section 3.2, and the tolerance
//! is measured on the fitted curve (the construction's closed forms do not apply). With
//! the run mode off, the method is the paper's alone.
//!
//! ## Limits
//! The built curve holds `tol` exactly up to the rounding of its control points to
//! `ulp(|x|)` (1.5e-11 mm at 1e5 mm), which `e* = tol (1 - TOL_SAFETY)` absorbs for
//! `tol >= 1e-4` mm at such coordinates. At 1e5 mm, a transition shorter than about 1e-3 mm
//! shows a spurious end curvature above the continuity audit's 1e-4 / mm (rounded collinear
//! points): the joint is G2 in exact arithmetic but may be audited G1.
//!
//! ## Performance
//! One pass, closed forms only (two square roots, one `atan2` per corner), no allocation
//! per corner beyond the output `Vec` (two small per-chain vectors of elements and
//! junctions). Corners per second: `cargo bench -p ncsmooth --bench bspline`.

use super::{extra_at, Chain, ChainPos, OptionsError, SmoothOptions, SmoothReport};
use crate::geom::{
    CubicBez, Line, ParamCurve, ParamCurveArclen, ParamCurveCurvature, ParamCurveDeriv, Segment,
    Vec3,
};
use crate::path::{Block, Move, MoveKind, Toolpath};
use crate::verify::{DEGENERATE_MM, GAP_TOL_MM, TANGENT_TOL_DEG};
use serde::Serialize;

/// The knot vector of every transition (section 3.1): clamped, one interior knot at 1/2,
/// which makes `C(u)` symmetric.
pub const KNOTS: [f64; 9] = [0.0, 0.0, 0.0, 0.0, 0.5, 1.0, 1.0, 1.0, 1.0];

/// Relative margin below `tol` of the target error in [`BandSemantics::TwoSided`]: absorbs
/// the rounding of the control points (a few ulps of the coordinates), so that the built
/// curve holds `tol` exactly and not just in exact arithmetic.
pub(crate) const TOL_SAFETY: f64 = 1e-7;

/// Corner angle (degrees; the angle between the legs at the vertex, 0 for a full reversal)
/// at or below which a corner is a reversal and becomes an exact stop.
pub(crate) const REVERSAL_ANGLE_DEG: f64 = TANGENT_TOL_DEG;

/// Accuracy (mm) of the arc-length sampling of [`curvature_profile`], relative to the step.
const PROFILE_ACCURACY_REL: f64 = 1e-6;

/// How `tol` is read (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize)]
pub enum BandSemantics {
    /// The crate's two-sided contract: output within `tol` of the programmed path and every
    /// corner within `tol` of the output. `delta = tol`, `epsilon = e* = tol`.
    #[default]
    TwoSided,
    /// The paper's tolerance band: `tol` is the band half-width `delta`, a corner is only
    /// scaled when its error exceeds `epsilon = delta / sin(theta)`, and then to
    /// `e* = delta / 2`. The corner may be missed by up to `delta / sin(theta)`.
    PaperBand,
}

/// Settings of [`Method::Bspline`](super::Method::Bspline).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct BsplineOptions {
    /// Tolerance semantics. Default: [`BandSemantics::TwoSided`].
    pub band_semantics: BandSemantics,
    /// Overlap-avoidance fraction `lambda` of equation 8, in `[0, 1)`: the next transition
    /// starts `lambda` of the way from the previous one's end to its vertex. The paper
    /// leaves it to "the actual machining". Default 0: neighbouring transitions may touch
    /// (the joint is then GC2 between two curves, both with zero end curvature), which
    /// leaves the most room on micro-segments.
    pub lambda: f64,
    /// Give the closing corner of a closed chain a transition (see the module
    /// documentation). Default true.
    pub smooth_closing_corner: bool,
}

/// Builders: each sets one field (see its doc for the default).
impl BsplineOptions {
    /// Sets [`BsplineOptions::band_semantics`].
    pub fn with_band_semantics(mut self, band_semantics: BandSemantics) -> Self {
        self.band_semantics = band_semantics;
        self
    }

    /// Sets [`BsplineOptions::lambda`].
    pub fn with_lambda(mut self, lambda: f64) -> Self {
        self.lambda = lambda;
        self
    }

    /// Sets [`BsplineOptions::smooth_closing_corner`].
    pub fn with_smooth_closing_corner(mut self, smooth_closing_corner: bool) -> Self {
        self.smooth_closing_corner = smooth_closing_corner;
        self
    }
}

impl Default for BsplineOptions {
    fn default() -> Self {
        BsplineOptions {
            band_semantics: BandSemantics::TwoSided,
            lambda: 0.0,
            smooth_closing_corner: true,
        }
    }
}

impl BsplineOptions {
    /// Checks the ranges.
    pub fn validate(&self) -> Result<(), OptionsError> {
        if !(0.0..1.0).contains(&self.lambda) {
            return Err(OptionsError::OutOfRange(
                "bspline lambda",
                self.lambda,
                "a fraction in [0, 1)",
            ));
        }
        Ok(())
    }
}

/// Equation 7 in closed form: the error `|Q1 - C(1/2)|` of a transition with edge length
/// `l` at a corner whose half angle has cosine `cos_half`.
#[inline]
pub fn corner_error(l: f64, cos_half: f64) -> f64 {
    0.5 * l * cos_half
}

/// Edge length `L` of a transition (sections 3.2 to 3.4), closed form: `min(avail_in,
/// avail_out) / 2`, scaled by `alpha = e* / e0` (3.3) when its error `e0` exceeds the
/// allowance (`tol` for [`BandSemantics::TwoSided`], `tol / sin(theta)` for
/// [`BandSemantics::PaperBand`]). `avail_in` / `avail_out`: the lengths of the legs the
/// transition may use (`2L` is taken on each). `cos_half`, `sin_half`: of half the corner
/// angle.
#[inline]
pub fn edge_length(
    avail_in: f64,
    avail_out: f64,
    cos_half: f64,
    sin_half: f64,
    tol_mm: f64,
    semantics: BandSemantics,
) -> f64 {
    let l_geom = 0.5 * avail_in.min(avail_out);
    let e0 = corner_error(l_geom, cos_half);
    let (epsilon, e_star) = match semantics {
        BandSemantics::TwoSided => {
            let t = tol_mm * (1.0 - TOL_SAFETY);
            (t, t)
        }
        BandSemantics::PaperBand => (tol_mm / sin_half, 0.5 * tol_mm),
    };
    if e0 > epsilon {
        // alpha = e* / e0; L* = alpha L = 2 e* / cos(theta).
        2.0 * e_star / cos_half
    } else {
        l_geom
    }
}

/// A corner transition: the five control points of section 3.1 (knots [`KNOTS`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsplineTransition {
    /// `P0..P4`; `P2` is the corner.
    pub ctrl: [Vec3; 5],
}

impl BsplineTransition {
    /// The symmetric transition at `vertex` with unit leg directions `back` (towards `Q0`)
    /// and `fwd` (towards `Q2`) and edge length `l`.
    #[inline]
    pub fn symmetric(vertex: Vec3, back: Vec3, fwd: Vec3, l: f64) -> BsplineTransition {
        BsplineTransition {
            ctrl: [
                vertex + back * (2.0 * l),
                vertex + back * l,
                vertex,
                vertex + fwd * l,
                vertex + fwd * (2.0 * l),
            ],
        }
    }

    /// Section 3.2, the paper's three cases, literally: `L0 < L1`: `P0 = Q0`,
    /// `P4 = Q1 + (L0/L1)(Q2 - Q1)`; `L0 = L1`: `P0 = Q0`, `P4 = Q2`; `L0 > L1`:
    /// `P0 = Q1 + (L1/L0)(Q0 - Q1)`, `P4 = Q2`; `P1`, `P3` the midpoints of `P0 P2`,
    /// `P2 P4`. `None` for a zero-length or non-finite leg.
    pub fn from_corner(q0: Vec3, q1: Vec3, q2: Vec3) -> Option<BsplineTransition> {
        let (l0, l1) = (q0.dist(q1), q1.dist(q2));
        if !(l0 > 0.0 && l1 > 0.0 && l0.is_finite() && l1.is_finite()) {
            return None;
        }
        let (p0, p4) = if l0 < l1 {
            (q0, q1 + (q2 - q1) * (l0 / l1))
        } else if l0 == l1 {
            (q0, q2)
        } else {
            (q1 + (q0 - q1) * (l1 / l0), q2)
        };
        Some(BsplineTransition {
            ctrl: [p0, p0.lerp(q1, 0.5), q1, q1.lerp(p4, 0.5), p4],
        })
    }

    /// Control-polygon edge length `L = |P1 P2|`.
    pub fn edge_len(&self) -> f64 {
        self.ctrl[1].dist(self.ctrl[2])
    }

    /// Section 3.3: the control polygon scaled by `alpha` about `P2`.
    pub fn scaled(&self, alpha: f64) -> BsplineTransition {
        let c = self.ctrl[2];
        BsplineTransition {
            ctrl: self.ctrl.map(|p| c + (p - c) * alpha),
        }
    }

    /// The shoulder point `C(1/2) = (P1 + 2 P2 + P3) / 4`.
    #[inline]
    pub fn shoulder(&self) -> Vec3 {
        (self.ctrl[1] + self.ctrl[2] * 2.0 + self.ctrl[3]) * 0.25
    }

    /// Equation 7: `e = |P2 - C(1/2)|`.
    pub fn error(&self) -> f64 {
        self.ctrl[2].dist(self.shoulder())
    }

    /// The exact Bézier decomposition (knot `1/2` inserted twice): `C(u)` for `u` in
    /// `[0, 1/2]` is the first Bézier at `t = 2u`, for `u` in `[1/2, 1]` the second at
    /// `t = 2u - 1`.
    #[inline]
    pub fn beziers(&self) -> [CubicBez; 2] {
        let [p0, p1, p2, p3, p4] = self.ctrl;
        let m = self.shoulder();
        [
            CubicBez::new(p0, p1, p1.lerp(p2, 0.5), m),
            CubicBez::new(m, p2.lerp(p3, 0.5), p3, p4),
        ]
    }

    /// `C(u)`, `u` in `[0, 1]` (through [`BsplineTransition::beziers`]).
    pub fn eval(&self, u: f64) -> Vec3 {
        let [b0, b1] = self.beziers();
        if u <= 0.5 {
            b0.eval(2.0 * u)
        } else {
            b1.eval(2.0 * u - 1.0)
        }
    }
}

/// How consecutive elements of a chain meet.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Junction {
    /// Turn below the straight threshold: unchanged.
    Straight,
    /// Line-line corner: transition. Cosine and sine of half the corner angle.
    Corner { cos_half: f64, sin_half: f64 },
    /// Exact stop (`arc` when a curve is involved).
    Stop { arc: bool },
}

/// A non-degenerate move of the chain.
#[derive(Clone, Copy, Debug)]
struct Elem {
    /// Index of the move in the chain.
    idx: usize,
    /// A line (else any curve, kept exact).
    line: bool,
    a: Vec3,
    b: Vec3,
    /// Length (lines).
    len: f64,
    /// Unit direction (lines).
    dir: Vec3,
}

fn classify(e0: &Elem, e1: &Elem, m0: &Move, m1: &Move, straight_deg: f64) -> Junction {
    if e0.line && e1.line {
        let (d0, d1) = (e0.dir, e1.dir);
        let turn = d0.angle_to(d1).to_degrees();
        if turn < straight_deg {
            return Junction::Straight;
        }
        if 180.0 - turn <= REVERSAL_ANGLE_DEG {
            return Junction::Stop { arc: false };
        }
        // a = -d0, b = d1: |a + b| = 2 cos(theta), |b - a| = 2 sin(theta).
        return Junction::Corner {
            cos_half: 0.5 * (d1 - d0).norm(),
            sin_half: 0.5 * (d1 + d0).norm(),
        };
    }
    match (m0.segment.end_tangent(), m1.segment.start_tangent()) {
        (Some(t0), Some(t1)) if t0.angle_to(t1).to_degrees() < straight_deg => Junction::Straight,
        _ => Junction::Stop { arc: true },
    }
}

/// A placed transition with its chain positions.
struct Placed {
    bez: [CubicBez; 2],
    p0: Vec3,
    pos0: ChainPos,
    pos4: ChainPos,
}

/// Places the transition at the corner between line elements `e_in` and `e_out`. `s`: the
/// start of what is left of the incoming leg (after the lambda rule); `avail_out`: the
/// length of the outgoing leg it may use; `out_full`: whether that is the whole leg (then
/// `P4` may be its end exactly).
#[allow(clippy::too_many_arguments)]
#[inline]
fn place(
    e_in: &Elem,
    e_out: &Elem,
    s: Vec3,
    avail_out: f64,
    out_full: bool,
    cos_half: f64,
    sin_half: f64,
    tol_mm: f64,
    semantics: BandSemantics,
) -> Option<Placed> {
    let v = e_in.b;
    let avail_in = s.dist(v);
    let l = edge_length(avail_in, avail_out, cos_half, sin_half, tol_mm, semantics);
    let two_l = 2.0 * l;
    if !(two_l > DEGENERATE_MM && two_l.is_finite()) {
        return None;
    }
    let (a, b) = (-e_in.dir, e_out.dir);
    let mut t = BsplineTransition::symmetric(v, a, b, l);
    // Where the whole available leg is used (up to a zero-length remainder), end exactly
    // on its end point: no zero-length line, programmed vertices kept bit for bit.
    if two_l >= avail_in - DEGENERATE_MM {
        t.ctrl[0] = s;
    }
    if out_full && two_l >= avail_out - DEGENERATE_MM {
        t.ctrl[4] = e_out.b;
    }
    let pos0 = ChainPos {
        index: e_in.idx,
        frac: (1.0 - two_l / e_in.len).clamp(0.0, 1.0),
    };
    let pos4 = ChainPos {
        index: e_out.idx,
        frac: (two_l / e_out.len).clamp(0.0, 1.0),
    };
    Some(Placed {
        bez: t.beziers(),
        p0: t.ctrl[0],
        pos0,
        pos4,
    })
}

/// Output under construction: the moves and the current point. Moves are built as
/// [`super::assemble`] builds them from pieces (line of the move the piece starts in, the
/// lowest feed of the moves it spans, extra axes at its end), without the intermediate
/// piece list.
struct Emitter<'c, 'm> {
    chain: &'c Chain<'m>,
    out: Vec<Move>,
    cur: Vec3,
    cur_pos: ChainPos,
}

impl Emitter<'_, '_> {
    /// Appends `segment`, spanning the chain from the current position to `to`.
    #[inline]
    fn push(&mut self, segment: Segment, to: ChainPos) {
        let moves = self.chain.moves;
        let (a, b) = (
            self.cur_pos.index.min(to.index),
            self.cur_pos.index.max(to.index),
        );
        let feed = moves[a..=b]
            .iter()
            .filter_map(|m| m.feed_mm_s)
            .fold(None, |acc: Option<f64>, f| {
                Some(acc.map_or(f, |x| x.min(f)))
            });
        self.out.push(Move {
            segment,
            kind: MoveKind::Feed,
            feed_mm_s: feed,
            line: moves[self.cur_pos.index].line,
            extra: extra_at(self.chain, to),
            pinned: false,
        });
        self.cur_pos = to;
    }
    /// A line from the current point to `p`. When shorter than [`DEGENERATE_MM`] it is
    /// not emitted; instead the previous piece is made to end exactly at `p` (moving its
    /// end by at most that much), so that programmed points (the chain's end, an arc's
    /// start) are kept bit for bit.
    #[inline]
    fn line_to(&mut self, p: Vec3, pos: ChainPos) {
        if self.cur.dist_sq(p) > DEGENERATE_MM * DEGENERATE_MM {
            self.push(Segment::Line(Line::new(self.cur, p)), pos);
        } else if self.cur != p {
            match self.out.last_mut().map(|m| &mut m.segment) {
                Some(Segment::Line(l)) => l.p1 = p,
                Some(Segment::CubicBez(c)) => c.p3 = p,
                _ => {}
            }
        }
        self.cur = p;
        self.cur_pos = pos;
    }
    /// A curve starting (within [`DEGENERATE_MM`]) at the current point; its start is
    /// snapped to it so that the output is gap-free.
    #[inline]
    fn curve(&mut self, mut c: CubicBez, to: ChainPos) {
        c.p0 = self.cur;
        self.cur = c.p3;
        self.push(Segment::CubicBez(c), to);
    }
}

/// Control-point distance of a cubic Bezier quarter circle of unit radius,
/// `4 (sqrt 2 - 1) / 3`; its radial error is at most 2.7e-4 of the radius, and zero at the
/// ends.
const QUARTER_CIRCLE_K: f64 = 0.552_284_749_830_793_4;

/// The half circle of diameter `|q - m|` joining the corner `q` of a closed chain and the
/// shoulder `m` of its closing transition, tangent there to the transition's direction
/// `t_m` (which is perpendicular to `q - m` by the transition's symmetry): from `q` to `m`
/// when `into`, else from `m` to `q`; as two cubic quarter circles whose end points are
/// `q` and `m` bit for bit. The two hooks together are the circle through `q` and `m`,
/// whose points lie within `|q - m|` of `q` (the quarter circles' radial error vanishes
/// at `m`, where that distance is reached). `None` when degenerate.
fn hook(q: Vec3, m: Vec3, t_m: Vec3, into: bool) -> Option<[CubicBez; 2]> {
    let t = t_m.normalized()?;
    let c = q.lerp(m, 0.5);
    let r = 0.5 * q.dist(m);
    let (start, end) = if into { (q, m) } else { (m, q) };
    let u = (start - c).normalized()?;
    // Direction of motion at the start: `-t` to arrive at `m` along `t` after half a
    // turn, `t` to leave `m` along it.
    let v = if into { -t } else { t };
    let k = QUARTER_CIRCLE_K * r;
    let mid = c + v * r;
    Some([
        CubicBez::new(start, start + v * k, mid + u * k, mid),
        CubicBez::new(mid, mid - u * k, end + v * k, end),
    ])
}

/// Smooths one chain (see the module documentation); updates the corner counts of `report`.
pub fn smooth_chain(
    chain: &Chain<'_>,
    opts: &SmoothOptions,
    bopts: &BsplineOptions,
    report: &mut SmoothReport,
) -> Vec<Move> {
    let moves = chain.moves;
    let Some(elems) = elements(moves) else {
        return moves.to_vec();
    };
    let n = elems.len();
    let junc = junctions(&elems, moves, opts.straight_angle_deg, report);
    let is_corner = |j: usize| matches!(junc.get(j), Some(Junction::Corner { .. }));
    let lambda = bopts.lambda;
    let mut em = Emitter {
        chain,
        out: Vec::with_capacity(3 * n + 2),
        cur: elems[0].a,
        cur_pos: ChainPos::start_of(elems[0].idx),
    };
    let closing = closing_corner(&mut em, &elems, &junc, opts, bopts, report);
    let mut from_transition = closing.is_some();
    for j in 0..n {
        let e = elems[j];
        if !e.line {
            em.cur_pos = ChainPos::start_of(e.idx);
            em.push(moves[e.idx].segment.clone(), ChainPos::end_of(e.idx));
            em.cur = e.b;
            from_transition = false;
            continue;
        }
        // After a straight junction, an arc or a skipped degenerate move the last piece
        // ended in an earlier move: this element's pieces start in its own, and take its
        // line and feed, not the lower feed of the move before.
        if em.cur_pos.index < e.idx {
            em.cur_pos = ChainPos::start_of(e.idx);
        }
        if let (true, Some(pl)) = (j == n - 1, &closing) {
            close_chain(&mut em, pl, &e, elems[0].a);
            break;
        }
        let placed = match junc.get(j) {
            Some(&Junction::Corner { cos_half, sin_half }) => {
                let next = &elems[j + 1];
                let s = if from_transition {
                    em.cur.lerp(e.b, lambda)
                } else {
                    em.cur
                };
                let (avail_out, out_full) = if j + 1 == n - 1 && closing.is_some() {
                    let p0c = closing.as_ref().map_or(next.b, |c| c.p0);
                    ((1.0 - lambda) * next.a.dist(p0c), false)
                } else if is_corner(j + 1) {
                    (0.5 * next.len, false)
                } else {
                    (next.len, true)
                };
                let (tol, sem) = (opts.tol_mm, bopts.band_semantics);
                let p = place(
                    &e, next, s, avail_out, out_full, cos_half, sin_half, tol, sem,
                );
                count_corner(p.is_some(), report);
                p
            }
            _ => None,
        };
        match placed {
            Some(pl) => {
                em.line_to(pl.p0, pl.pos0);
                em.curve(pl.bez[0], ChainPos::end_of(e.idx));
                em.curve(pl.bez[1], pl.pos4);
                from_transition = true;
            }
            None => {
                em.line_to(e.b, ChainPos::end_of(e.idx));
                from_transition = false;
            }
        }
    }
    em.out
}

/// The chain's non-degenerate elements; `None` when a move has a non-finite end or none
/// is left (the chain is then kept as it is).
fn elements(moves: &[Move]) -> Option<Vec<Elem>> {
    let mut elems: Vec<Elem> = Vec::with_capacity(moves.len());
    for (idx, m) in moves.iter().enumerate() {
        let (a, b) = (m.segment.start(), m.segment.end());
        if !(a.is_finite() && b.is_finite()) {
            return None;
        }
        match &m.segment {
            Segment::Line(_) => {
                let d = b - a;
                let len = d.norm();
                if len > DEGENERATE_MM {
                    elems.push(Elem {
                        idx,
                        line: true,
                        a,
                        b,
                        len,
                        dir: d / len,
                    });
                }
            }
            _ => elems.push(Elem {
                idx,
                line: false,
                a,
                b,
                len: 0.0,
                dir: Vec3::ZERO,
            }),
        }
    }
    (!elems.is_empty()).then_some(elems)
}

/// The junction after each element but the last; counts the straight ones and the stops.
fn junctions(
    elems: &[Elem],
    moves: &[Move],
    straight_deg: f64,
    report: &mut SmoothReport,
) -> Vec<Junction> {
    let junc: Vec<Junction> = elems
        .windows(2)
        .map(|w| {
            classify(
                &w[0],
                &w[1],
                &moves[w[0].idx],
                &moves[w[1].idx],
                straight_deg,
            )
        })
        .collect();
    for j in &junc {
        match j {
            Junction::Straight => report.corners_straight += 1,
            Junction::Stop { arc } => {
                report.corners_stopped += 1;
                report.arc_joints += usize::from(*arc);
            }
            Junction::Corner { .. } => {}
        }
    }
    junc
}

fn count_corner(smoothed: bool, report: &mut SmoothReport) {
    if smoothed {
        report.corners_smoothed += 1;
    } else {
        report.corners_stopped += 1;
    }
}

/// The closing corner of a closed chain, placed first and entered through its shoulder
/// (its second half is emitted here, from the chain's start); `None` when the chain is
/// open, the option is off or the corner cannot be placed.
fn closing_corner(
    em: &mut Emitter<'_, '_>,
    elems: &[Elem],
    junc: &[Junction],
    opts: &SmoothOptions,
    bopts: &BsplineOptions,
    report: &mut SmoothReport,
) -> Option<Placed> {
    let n = elems.len();
    let moves = em.chain.moves;
    // A chain cut where the path goes on (a stream window, a change of flow) is not
    // entered from rest: its ends stay as they are.
    let open = em.chain.open_ends.iter().any(|&o| o);
    if !(bopts.smooth_closing_corner && n >= 2 && !open && em.chain.is_closed(GAP_TOL_MM)) {
        return None;
    }
    let (last, first) = (&elems[n - 1], &elems[0]);
    if !(last.line && first.line) {
        return None;
    }
    let straight = opts.straight_angle_deg;
    let Junction::Corner { cos_half, sin_half } =
        classify(last, first, &moves[last.idx], &moves[first.idx], straight)
    else {
        return None;
    };
    let is_corner = |j: usize| matches!(junc.get(j), Some(Junction::Corner { .. }));
    let avail_in = if is_corner(n - 2) {
        0.5 * last.len
    } else {
        last.len
    };
    let s = last.b + (last.a - last.b) * (avail_in / last.len);
    let out_full = !is_corner(0);
    let avail_out = if out_full { first.len } else { 0.5 * first.len };
    // The closing corner's vertex is the chain's start.
    let last_v = Elem {
        b: first.a,
        ..*last
    };
    let (tol, sem) = (opts.tol_mm, bopts.band_semantics);
    let closing = place(
        &last_v, first, s, avail_out, out_full, cos_half, sin_half, tol, sem,
    );
    count_corner(closing.is_some(), report);
    let pl = closing.as_ref()?;
    let m = pl.bez[1].p0;
    match hook(first.a, m, pl.bez[1].deriv(0.0), true) {
        Some([h0, h1]) => {
            em.curve(h0, ChainPos::start_of(first.idx));
            em.curve(h1, ChainPos::start_of(first.idx));
        }
        None => em.line_to(m, ChainPos::start_of(first.idx)),
    }
    em.curve(pl.bez[1], pl.pos4);
    closing
}

/// The last element `e` of a closed chain: up to the closing corner, its first half, and
/// the hook back to the chain's start `start`.
fn close_chain(em: &mut Emitter<'_, '_>, pl: &Placed, e: &Elem, start: Vec3) {
    em.line_to(pl.p0, pl.pos0);
    em.curve(pl.bez[0], ChainPos::end_of(e.idx));
    let m = pl.bez[0].p3;
    match hook(start, m, pl.bez[0].deriv(1.0), false) {
        Some([h0, h1]) => {
            em.curve(h0, ChainPos::end_of(e.idx));
            em.curve(h1, ChainPos::end_of(e.idx));
        }
        None => em.line_to(start, ChainPos::end_of(e.idx)),
    }
}

/// Curvature along arc length of the feed moves of `tp`, as `(s_mm, kappa_per_mm)` pairs:
/// every move is sampled at its ends and about every `step_mm` of arc length in between
/// (arc length of curves within `step_mm * 1e-6`); `s` runs over the feed moves only, in
/// order. Lines give zero, arcs `1 / r`, transitions their Bézier curvature. Empty for a
/// non-positive or non-finite step. For plots (e.g. the paper's figure 13(b)).
pub fn curvature_profile(tp: &Toolpath, step_mm: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    if !(step_mm > 0.0 && step_mm.is_finite()) {
        return out;
    }
    let acc = step_mm * PROFILE_ACCURACY_REL;
    let mut s0 = 0.0;
    for b in &tp.blocks {
        let Block::Move(m) = b else { continue };
        if m.kind != MoveKind::Feed {
            continue;
        }
        let seg = &m.segment;
        let len = seg.arclen(acc);
        if !len.is_finite() {
            continue;
        }
        let k = match seg {
            Segment::Line(_) => 1,
            _ => ((len / step_mm).ceil() as usize).max(1),
        };
        for i in 0..=k {
            let s = len * i as f64 / k as f64;
            let t = match seg {
                Segment::Line(_) => i as f64 / k as f64,
                _ => seg.inv_arclen(s, acc),
            };
            out.push((s0 + s, seg.curvature(t)));
        }
        s0 += len;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::{smooth, Method};
    use super::*;
    use crate::geom::{Arc, Nurbs, ParamCurveDeriv};
    use crate::verify::{continuity_joints, deviation, JointClass};
    use proptest::prelude::*;

    fn corner(theta_deg: f64, l0: f64, l1: f64) -> (Vec3, Vec3, Vec3) {
        // Q1 at the origin, legs at +-theta from the -x axis... symmetric about x.
        let th = theta_deg.to_radians();
        let q1 = Vec3::new(1.0, 2.0, 3.0);
        let a = Vec3::new(th.cos(), th.sin(), 0.0);
        let b = Vec3::new(th.cos(), -th.sin(), 0.0);
        (q1 + a * l0, q1, q1 + b * l1)
    }

    #[test]
    fn paper_worked_example() {
        // Section 3.3: delta = 0.01 mm, theta = 35 deg, L = 0.0479 mm: e0 ~ 0.0195 mm,
        // out of the band (epsilon ~ 0.0173 mm), alpha = e*/e0 ~ 0.256, L* ~ 0.0123 mm.
        // (The paper rounds its intermediates: exact values are e0 = 0.019619,
        // epsilon = 0.017434, alpha = 0.25486, L* = 0.012208.)
        let delta = 0.01;
        let l = 0.0479;
        let (q0, q1, q2) = corner(35.0, 2.0 * l, 2.0 * l);
        let t0 = BsplineTransition::from_corner(q0, q1, q2).unwrap();
        assert!((t0.edge_len() - l).abs() < 1e-12);
        let e0 = t0.error();
        assert!((e0 - 0.0195).abs() < 2e-4, "e0 = {e0}");
        let theta = 35f64.to_radians();
        let epsilon = delta / theta.sin();
        assert!((epsilon - 0.0173).abs() < 2e-4);
        assert!(e0 > epsilon);
        let e_star = 0.5 * delta;
        let alpha = e_star / e0;
        assert!((alpha - 0.256).abs() < 2e-3, "alpha = {alpha}");
        let t1 = t0.scaled(alpha);
        assert!((t1.edge_len() - 0.0123).abs() < 2e-4, "{}", t1.edge_len());
        assert!((t1.error() - e_star).abs() < 1e-12);
        // The closed form gives the same L*.
        let l_star = edge_length(
            2.0 * l,
            2.0 * l,
            theta.cos(),
            theta.sin(),
            delta,
            BandSemantics::PaperBand,
        );
        assert!((l_star - t1.edge_len()).abs() < 1e-12);
        // And the whole chain with the paper's band: the curve misses the corner by e*.
        let tp = Toolpath::from_polyline(&[q0, q1, q2], Some(10.0));
        let opts = SmoothOptions {
            method: Method::Bspline,
            tol_mm: delta,
            bspline: BsplineOptions {
                band_semantics: BandSemantics::PaperBand,
                ..Default::default()
            },
            ..Default::default()
        };
        let out = smooth(&tp, &opts).unwrap().toolpath;
        let d = deviation(&out, &tp, 1e-9);
        assert!((d.vertex_to_output_mm - e_star).abs() < 2e-9, "{d:?}");
        assert!((d.output_to_programmed_mm - e_star * theta.sin()).abs() < 2e-9);
    }

    #[test]
    fn three_cases_of_section_3_2() {
        let (q0, q1, q2) = corner(50.0, 3.0, 5.0);
        let t = BsplineTransition::from_corner(q0, q1, q2).unwrap();
        assert_eq!(t.ctrl[0], q0);
        assert!((t.edge_len() - 1.5).abs() < 1e-12);
        assert!((t.ctrl[4].dist(q1) - 3.0).abs() < 1e-12);
        let t = BsplineTransition::from_corner(q2, q1, q0).unwrap();
        assert_eq!(t.ctrl[4], q0);
        assert!((t.ctrl[0].dist(q1) - 3.0).abs() < 1e-12);
        // Exactly equal legs.
        let (q0, q1, q2) = (
            Vec3::new(0.0, 4.0, 1.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(4.0, 0.0, 1.0),
        );
        let t = BsplineTransition::from_corner(q0, q1, q2).unwrap();
        assert_eq!((t.ctrl[0], t.ctrl[4]), (q0, q2));
        for i in 0..4 {
            assert!((t.ctrl[i].dist(t.ctrl[i + 1]) - 2.0).abs() < 1e-12);
        }
        assert!(BsplineTransition::from_corner(q1, q1, q2).is_none());
    }

    #[test]
    fn beziers_are_the_bspline_exactly() {
        let (q0, q1, q2) = corner(23.0, 3.0, 7.0);
        let t = BsplineTransition::from_corner(q0, q1, q2).unwrap();
        let nb = Nurbs::bspline(3, t.ctrl.to_vec(), KNOTS.to_vec()).unwrap();
        for i in 0..=200 {
            let u = i as f64 / 200.0;
            let d = nb.point_at_param(u).dist(t.eval(u));
            assert!(d < 1e-13, "u = {u}: {d}");
        }
    }

    #[test]
    fn ends_tangents_curvature_and_symmetry() {
        for &(th, l0, l1) in &[(35.0, 1.0, 1.0), (0.7, 0.3, 2.0), (89.0, 5.0, 0.01)] {
            let (q0, q1, q2) = corner(th, l0, l1);
            let t = BsplineTransition::from_corner(q0, q1, q2).unwrap();
            let [b0, b1] = t.beziers();
            assert_eq!(t.eval(0.0), t.ctrl[0]);
            assert_eq!(t.eval(1.0), t.ctrl[4]);
            assert_eq!(b0.p3, b1.p0);
            let din = (q1 - q0).normalized().unwrap();
            let dout = (q2 - q1).normalized().unwrap();
            assert!(b0.deriv(0.0).normalized().unwrap().dist(din) < 1e-12);
            assert!(b1.deriv(1.0).normalized().unwrap().dist(dout) < 1e-12);
            let scale = 1.0 / t.edge_len();
            assert!(b0.curvature(0.0) < 1e-9 * scale);
            assert!(b1.curvature(1.0) < 1e-9 * scale);
            // C2 at the interior knot.
            assert!(b0.deriv(1.0).dist(b1.deriv(0.0)) < 1e-12 * t.edge_len().max(1.0));
            assert!(b0.deriv2(1.0).dist(b1.deriv2(0.0)) < 1e-9);
            // Symmetry: C(1 - u) is C(u) mirrored in the bisector plane through Q1.
            let nrm = (dout + din).normalized().unwrap();
            for i in 0..=50 {
                let u = i as f64 / 50.0;
                let p = t.eval(u);
                let mirrored = p - nrm * (2.0 * (p - q1).dot(nrm));
                assert!(mirrored.dist(t.eval(1.0 - u)) < 1e-12, "{th} {u}");
            }
        }
    }

    proptest! {
        #[test]
        fn error_is_l_cos_theta_over_2(
            theta in 0.01f64..89.99,
            l in 1e-4f64..100.0,
            ax in -1.0f64..1.0, ay in -1.0f64..1.0, az in -1.0f64..1.0,
            bx in -1.0f64..1.0, by in -1.0f64..1.0, bz in -1.0f64..1.0,
        ) {
            // Random plane: rotate the symmetric corner into span(a, b).
            let u = Vec3::new(ax, ay, az).normalized().unwrap_or(Vec3::X);
            let w = u.cross(Vec3::new(bx, by, bz)).normalized().unwrap_or(u.any_perpendicular());
            let v = w.cross(u);
            let th = theta.to_radians();
            let a = u * th.cos() + v * th.sin();
            let b = u * th.cos() - v * th.sin();
            let q1 = Vec3::new(bx, by, bz) * 50.0;
            let t = BsplineTransition::symmetric(q1, a, b, l);
            let e = q1.dist(t.eval(0.5));
            prop_assert!((e - corner_error(l, th.cos())).abs() <= 1e-12 * l.max(1.0) * 100.0);
            prop_assert!((t.error() - e).abs() <= 1e-12 * l.max(1.0) * 100.0);
        }
    }

    #[test]
    fn a_line_after_a_straight_junction_keeps_its_own_line_and_feed() {
        // cncjs_jsdc's plunge: a slow approach (line 3), a fast move on (line 4) straight
        // through it, a corner into the cut (line 6). The trimmed part of line 4 before the
        // corner is line 4's, at its feed: a comment between lines 4 and 5 stays after it,
        // and the fast move is not slowed to the approach's feed (nor the reverse).
        let z = |z: f64| Vec3::new(0.0, 0.0, z);
        for (f3, f4) in [(2.0, 40.0), (40.0, 2.0)] {
            let mut tp = Toolpath::new(z(5.0));
            tp.push_move(Move::feed(Line::new(z(5.0), z(1.0)), Some(f3), 3));
            tp.push_move(Move::feed(Line::new(z(1.0), z(0.0)), Some(f4), 4));
            let cut = Line::new(z(0.0), Vec3::new(10.0, 0.0, 0.0));
            tp.push_move(Move::feed(cut, Some(17.0), 6));
            let out = smooth(&tp, &bspline_opts(0.01)).unwrap();
            let moves: Vec<&Move> = out.toolpath.moves().collect();
            for m in &moves {
                let (a, b) = (m.segment.start(), m.segment.end());
                let line = if a.z + b.z > 2.0 {
                    3
                } else if a.x.max(b.x) < 1e-12 {
                    4
                } else {
                    continue;
                };
                let feed = if line == 3 { f3 } else { f4 };
                assert_eq!((m.line, m.feed_mm_s), (line, Some(feed)), "{moves:?}");
            }
            assert!(moves.iter().any(|m| m.line == 4), "{moves:?}");
        }
    }

    fn bspline_opts(tol: f64) -> SmoothOptions {
        SmoothOptions {
            method: Method::Bspline,
            tol_mm: tol,
            ..Default::default()
        }
    }

    /// Smooths `tp` and checks the contract: two-sided deviation within tol (measured to
    /// tol * 1e-3), no NaN, every transition joint G2, corners accounted for.
    fn check(tp: &Toolpath, tol: f64, g2: bool) -> Result<(), TestCaseError> {
        let out = smooth(tp, &bspline_opts(tol)).unwrap();
        for m in out.toolpath.moves() {
            let s = &m.segment;
            prop_assert!(s.start().is_finite() && s.end().is_finite());
            if let Segment::CubicBez(c) = s {
                prop_assert!(c.p1.is_finite() && c.p2.is_finite());
            }
        }
        let d = deviation(&out.toolpath, tp, tol * 1e-3);
        prop_assert!(d.max_mm() <= tol * (1.0 + 1e-9), "{d:?}");
        prop_assert_eq!(out.toolpath.end_point(), tp.end_point());
        // Exact stops by design (reversals of the lines the method smooths, after the
        // merging of micro-lines: a 1 um line between two halves of a reversal is merged
        // into one): their joints are G0.
        let stops = reversal_vertices(&merged_moves(tp, &bspline_opts(tol)));
        let (_, joints) = continuity_joints(&out.toolpath);
        let moves: Vec<&Move> = out.toolpath.moves().collect();
        for j in &joints {
            let (a, b) = (
                &moves[j.move_index].segment,
                &moves[j.move_index + 1].segment,
            );
            // A Bezier next to an input arc is an arc-joint blend (super::arc_joint): G1.
            let is_arc =
                |k: usize| matches!(moves.get(k).map(|m| &m.segment), Some(Segment::Arc(_)));
            let blend = |k: usize| {
                matches!(moves[k].segment, Segment::CubicBez(_))
                    && (is_arc(k + 1) || k.checked_sub(1).is_some_and(is_arc))
            };
            if blend(j.move_index) || blend(j.move_index + 1) {
                prop_assert!(j.class != JointClass::G0, "{:?}", j);
                continue;
            }
            let involves_transition =
                matches!(a, Segment::CubicBez(_)) || matches!(b, Segment::CubicBez(_));
            // The hooks of a closed loop (within tol of its start) join tangentially: G1.
            let closed = tp.start.dist(tp.end_point()) <= GAP_TOL_MM;
            let hook = closed && j.at.dist(tp.start) <= tol;
            let at_stop = stops.iter().any(|v| v.dist(j.at) <= 1e-9);
            if involves_transition && g2 && !hook && !at_stop {
                prop_assert_eq!(j.class, JointClass::G2, "{:?}", j);
            }
            if hook && !at_stop {
                prop_assert!(j.class != JointClass::G0, "{:?}", j);
            }
            prop_assert!(j.class != JointClass::Gap, "{:?}", j);
        }
        Ok(())
    }

    /// Vertices of a polyline toolpath where the legs (zero-length moves skipped) reverse
    /// within [`REVERSAL_ANGLE_DEG`].
    /// The moves of `tp` as the method smooths them: micro-lines merged as
    /// `super::smooth_stretch` does.
    fn merged_moves(tp: &Toolpath, opts: &SmoothOptions) -> Vec<Move> {
        let moves: Vec<Move> = tp.moves().cloned().collect();
        let eps = opts.tol_mm * opts.run.merge_share;
        let micro = opts.tol_mm * super::super::MICRO_LINE_TOLS;
        super::super::simplify::merge_lines(&moves, eps, micro).unwrap_or(moves)
    }

    fn reversal_vertices(moves: &[Move]) -> Vec<Vec3> {
        let legs: Vec<(Vec3, Vec3)> = moves
            .iter()
            .map(|m| (m.segment.start(), m.segment.end()))
            .filter(|(a, b)| a.dist(*b) > DEGENERATE_MM)
            .collect();
        legs.windows(2)
            .filter(|w| {
                let ang = (w[0].1 - w[0].0).angle_to(w[1].1 - w[1].0).to_degrees();
                180.0 - ang <= REVERSAL_ANGLE_DEG
            })
            .map(|w| w[0].1)
            .collect()
    }

    /// Polyline from a start and steps, with degenerate features chosen by `kind`.
    fn polyline(start: Vec3, steps: &[(f64, f64, f64, u8)], planar: bool) -> Vec<Vec3> {
        let mut pts = vec![start];
        let mut p = start;
        let mut prev = Vec3::X;
        for &(x, y, z, kind) in steps {
            let z = if planar { 0.0 } else { z };
            let d = Vec3::new(x, y, z);
            let step = match kind % 8 {
                0 => Vec3::ZERO,                               // repeated point
                1 => d.normalized().unwrap_or(Vec3::X) * 1e-3, // 1 um segment
                2 => -prev * (0.5 + x.abs()),                  // 180-degree reversal
                3 => prev * (1.0 + x.abs()) + d * 1e-7,        // near-collinear
                4 => {
                    // 1-degree corner (turn of 179 degrees).
                    let perp = prev
                        .cross(if planar { Vec3::Z } else { d })
                        .normalized()
                        .unwrap_or(prev.any_perpendicular());
                    let ang = 179f64.to_radians();
                    (prev * ang.cos() + perp * ang.sin()) * (0.2 + y.abs())
                }
                _ => d,
            };
            p += step;
            if let Some(u) = step.normalized() {
                prev = u;
            }
            pts.push(p);
        }
        pts
    }

    fn step_strategy() -> impl Strategy<Value = Vec<(f64, f64, f64, u8)>> {
        prop::collection::vec(
            (-5.0f64..5.0, -5.0f64..5.0, -5.0f64..5.0, any::<u8>()),
            2..40,
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        #[test]
        fn random_polylines_hold_tol_2d(steps in step_strategy(), tol in 1e-4f64..0.2) {
            let pts = polyline(Vec3::new(3.0, -2.0, 0.0), &steps, true);
            check(&Toolpath::from_polyline(&pts, Some(20.0)), tol, true)?;
        }

        #[test]
        fn random_polylines_hold_tol_3d(steps in step_strategy(), tol in 1e-4f64..0.2) {
            let pts = polyline(Vec3::new(3.0, -2.0, 1.0), &steps, false);
            check(&Toolpath::from_polyline(&pts, Some(20.0)), tol, true)?;
        }

        #[test]
        fn closed_polylines(steps in step_strategy(), tol in 1e-3f64..0.1) {
            let mut pts = polyline(Vec3::ZERO, &steps, false);
            pts.push(pts[0]);
            check(&Toolpath::from_polyline(&pts, Some(20.0)), tol, true)?;
        }

        #[test]
        fn huge_coordinates(steps in step_strategy(), tol in 1e-3f64..0.1) {
            // Legs of 0.01 mm and more keep the transitions long enough for the G2 audit
            // at 1e5 mm (see the module's limits); micro-legs are checked for tolerance.
            let big = Vec3::new(1e5, -1e5, 5e4);
            let coarse: Vec<_> = steps.iter().map(|&(x, y, z, k)| {
                let k = if k % 8 == 1 { 5 } else { k };
                (x.signum() * (x.abs() + 0.01), y, z, k)
            }).collect();
            check(&Toolpath::from_polyline(&polyline(big, &coarse, false), None), tol, true)?;
            check(&Toolpath::from_polyline(&polyline(big, &steps, false), None), tol, false)?;
        }
    }

    #[test]
    fn micro_segments_all_get_transitions() {
        // A zigzag of 1 um segments: every corner smoothed, no overlap, within tol.
        let pts: Vec<Vec3> = (0..200)
            .map(|i| Vec3::new(i as f64 * 1e-3, (i % 2) as f64 * 1e-3, 0.0))
            .collect();
        let tp = Toolpath::from_polyline(&pts, Some(5.0));
        // The paper's transitions: the run mode (which fits the zigzag as one curve) off.
        let mut o = bspline_opts(0.01);
        o.run.enabled = false;
        let out = smooth(&tp, &o).unwrap();
        assert_eq!(out.report.corners_smoothed, 198);
        check(&tp, 0.01, true).unwrap();
    }

    #[test]
    fn arcs_stay_exact_and_non_tangent_joints_blend() {
        let mut tp = Toolpath::new(Vec3::ZERO);
        tp.push_move(Move::feed(Line::new(Vec3::ZERO, Vec3::X * 10.0), None, 1));
        // Tangent arc (centre above the end of the line).
        let arc = Arc::from_center(
            Vec3::X * 10.0,
            Vec3::new(15.0, 5.0, 0.0),
            Vec3::new(10.0, 5.0, 0.0),
            Vec3::Z,
            true,
            0,
        )
        .unwrap();
        tp.push_move(Move::feed(arc, None, 2));
        // Non-tangent line after the arc (arc ends going +y; line goes -x).
        tp.push_move(Move::feed(
            Line::new(Vec3::new(15.0, 5.0, 0.0), Vec3::new(5.0, 5.0, 0.0)),
            None,
            3,
        ));
        tp.push_move(Move::feed(
            Line::new(Vec3::new(5.0, 5.0, 0.0), Vec3::new(5.0, 15.0, 0.0)),
            None,
            4,
        ));
        let out = smooth(&tp, &bspline_opts(0.01)).unwrap();
        let r = &out.report;
        // The arc -> line joint turns by 90 degrees: blended (super::arc_joint); the
        // line-line corner gets its B-spline transition.
        assert_eq!(
            (
                r.arc_joints,
                r.arc_joints_blended,
                r.corners_stopped,
                r.corners_smoothed
            ),
            (1, 1, 0, 2)
        );
        assert!(out.toolpath.moves().any(|m| matches!(m.segment,
            Segment::Arc(b) if b.center == arc.center && b.u == arc.u && b.sweep < arc.sweep)));
        check(&tp, 0.01, true).unwrap();
    }

    #[test]
    fn closed_hexagon_smooths_every_corner() {
        let pts: Vec<Vec3> = (0..=6)
            .map(|i| {
                let a = i as f64 * std::f64::consts::PI / 3.0;
                Vec3::new(30.0 * a.cos(), 30.0 * a.sin(), 4.0 * (2.0 * a).sin())
            })
            .collect();
        let mut pts = pts;
        pts[6] = pts[0];
        let tp = Toolpath::from_polyline(&pts, Some(50.0));
        let out = smooth(&tp, &bspline_opts(0.05)).unwrap();
        assert_eq!(out.report.corners_smoothed, 6);
        assert_eq!(out.toolpath.moves().next().unwrap().segment.start(), pts[0]);
        check(&tp, 0.05, true).unwrap();
        // Tolerance-limited corners: the corner is missed by e* = tol (1 - TOL_SAFETY).
        let d = deviation(&out.toolpath, &tp, 1e-9);
        assert!(
            (d.vertex_to_output_mm - 0.05 * (1.0 - TOL_SAFETY)).abs() < 2e-9,
            "{d:?}"
        );
        let open = SmoothOptions {
            bspline: BsplineOptions {
                smooth_closing_corner: false,
                ..Default::default()
            },
            ..bspline_opts(0.05)
        };
        assert_eq!(smooth(&tp, &open).unwrap().report.corners_smoothed, 5);
        let prof = curvature_profile(&out.toolpath, 0.01);
        assert!(prof.windows(2).all(|w| w[1].0 >= w[0].0));
        let kmax = prof.iter().map(|p| p.1).fold(0.0, f64::max);
        assert!(kmax > 0.0 && kmax.is_finite());
    }

    #[test]
    fn feeds_lines_and_extra_axes_follow_the_program() {
        let mut tp = Toolpath::new(Vec3::ZERO);
        let mut r = Move::rapid(Line::new(Vec3::Z, Vec3::ZERO), 6);
        r.extra = Some([0.0; 7]);
        tp.push_move(r);
        let mut m1 = Move::feed(Line::new(Vec3::ZERO, Vec3::X * 4.0), Some(10.0), 7);
        m1.extra = Some([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 4.0]);
        let mut m2 = Move::feed(
            Line::new(Vec3::X * 4.0, Vec3::new(4.0, 4.0, 0.0)),
            Some(5.0),
            8,
        );
        m2.extra = Some([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 8.0]);
        tp.push_move(m1);
        tp.push_move(m2);
        let out = smooth(&tp, &bspline_opts(0.1)).unwrap().toolpath;
        let moves: Vec<&Move> = out.moves().skip(1).collect();
        assert_eq!(moves.len(), 4);
        // Line on leg 1, first half (leg 1), second half (spans both), line on leg 2.
        let feeds: Vec<_> = moves.iter().map(|m| m.feed_mm_s.unwrap()).collect();
        assert_eq!(feeds, vec![10.0, 10.0, 5.0, 5.0]);
        let lines: Vec<_> = moves.iter().map(|m| m.line).collect();
        assert_eq!(lines, vec![7, 7, 7, 8]);
        // E is linear in arc length within each programmed move, evaluated at piece ends.
        let l = 2.0 * 0.1 * (1.0 - TOL_SAFETY) / std::f64::consts::FRAC_PI_4.cos();
        let e = |m: &Move| m.extra.unwrap()[6];
        assert!((e(moves[0]) - (4.0 - 2.0 * l)).abs() < 1e-12);
        assert_eq!(e(moves[1]), 4.0);
        assert!((e(moves[2]) - (4.0 + 2.0 * l)).abs() < 1e-12);
        assert_eq!(e(moves[3]), 8.0);
    }

    #[test]
    fn lambda_leaves_a_line_between_transitions() {
        let pts = [
            Vec3::ZERO,
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
        ];
        let tp = Toolpath::from_polyline(&pts, None);
        let mut opts = bspline_opts(10.0);
        opts.bspline.lambda = 0.5;
        // Three 1 mm lines are a run at tol 10 mm: the paper's transitions, run mode off.
        opts.run.enabled = false;
        let out = smooth(&tp, &opts).unwrap().toolpath;
        let kinds: Vec<&str> = out
            .moves()
            .map(|m| match m.segment {
                Segment::Line(_) => "L",
                _ => "C",
            })
            .collect();
        // Line, corner 1 (to the middle of leg 2), line (lambda), corner 2, line.
        assert_eq!(kinds.join(""), "LCCLCCL");
        let moves: Vec<&Move> = out.moves().collect();
        assert!((moves[3].segment.arclen(0.0) - 0.25).abs() < 1e-12);
        opts.bspline.lambda = 1.0;
        assert!(smooth(&tp, &opts).is_err());
    }
}
