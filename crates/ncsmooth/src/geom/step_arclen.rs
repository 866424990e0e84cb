//! The arc length of one interpolation step (or one planning interval) of a move: exact
//! on lines and arcs (spirals included), 7-point Gauss-Kronrod with an adaptive fallback on curves, split at
//! the knots of a NURBS. Shared by the planner's grid ([`crate::feed`]) and the
//! interpolator ([`crate::interp`]), which sit above this module.

use super::{arclen_gk7, Nurbs, ParamCurveArclen, PreparedTrig, Segment};

/// Accuracy (mm) of the arc length of one step.
pub const STEP_ARCLEN_ACCURACY_MM: f64 = 1e-11;

/// Arc length over one step: [`arclen_gk7`] at [`STEP_ARCLEN_ACCURACY_MM`] (7-point
/// Gauss-Kronrod checked against its embedded 3-point Gauss rule, then against its two
/// halves, adaptive where those disagree: a step across a tight bend or a zero-speed
/// end). Seven evaluations of `P'` on almost every step, where the former check (5-point
/// Gauss-Legendre against its two halves) took fifteen on all.
pub fn step_arclen(seg: &Segment, a: f64, b: f64) -> f64 {
    // Lines and arcs (helices included) have constant parametric speed: exact. A spiral's
    // length has a closed form.
    match seg {
        Segment::Arc(arc) if arc.is_spiral() => return arc.length_between(a, b),
        Segment::Line(_) | Segment::Arc(_) => return ParamCurveArclen::arclen(seg, 0.0) * (b - a),
        _ => {}
    }
    match seg {
        // The spline's weights once, not at every node.
        Segment::Trig(c) => arclen_gk7(&PreparedTrig::new(c), a, b, STEP_ARCLEN_ACCURACY_MM),
        Segment::Nurbs(n) => nurbs_step_arclen(seg, n, a, b),
        _ => arclen_gk7(seg, a, b, STEP_ARCLEN_ACCURACY_MM),
    }
}

/// [`step_arclen`] of a NURBS: the step split at the knots inside it, where the speed's
/// derivatives jump (a rule across a knot converges slowly and subdivides deep), each
/// piece to its share of [`STEP_ARCLEN_ACCURACY_MM`].
fn nurbs_step_arclen(seg: &Segment, n: &Nurbs, a: f64, b: f64) -> f64 {
    if b <= a {
        return 0.0;
    }
    let (ua, ub) = (n.param(a), n.param(b));
    let knots = n.knots();
    let first = knots.partition_point(|&k| k <= ua);
    let inside = knots[first..].partition_point(|&k| k < ub);
    if inside == 0 {
        return arclen_gk7(seg, a, b, STEP_ARCLEN_ACCURACY_MM);
    }
    let share = STEP_ARCLEN_ACCURACY_MM / (inside + 1) as f64;
    let (mut t, mut sum) = (a, 0.0);
    for &k in &knots[first..first + inside] {
        let tk = n.t_of(k);
        if tk > t {
            sum += arclen_gk7(seg, t, tk, share);
            t = tk;
        }
    }
    sum + arclen_gk7(seg, t, b, share)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{arclen_adaptive, Vec3};
    /// The arc length of a step on a NURBS, split at the knots inside it, matches a fine
    /// quadrature of the whole step (steps inside one span, across one knot and across many).
    #[test]
    fn nurbs_step_arclen_across_knots() {
        let ctrl: Vec<Vec3> = (0..12)
            .map(|i| {
                let x = i as f64;
                Vec3::new(x * x * 0.3, (x * 1.7).sin() * 4.0, 0.1 * x)
            })
            .collect();
        // Non-uniform knots: chord-length-like spans of very different sizes.
        let mut knots = vec![0.0; 4];
        let mut k = 0.0;
        for i in 0..8 {
            k += 0.2 + (i as f64 * 2.3).sin().abs();
            knots.push(k);
        }
        knots.extend([k + 1.0; 4]);
        let seg = Segment::Nurbs(Box::new(Nurbs::bspline(3, ctrl, knots).unwrap()));
        for (a, b) in [
            (0.0, 1.0),
            (0.1, 0.13),
            (0.31, 0.52),
            (0.2, 0.2000001),
            (0.9, 1.0),
        ] {
            let want = arclen_adaptive(&seg, a, b, 1e-14);
            let got = step_arclen(&seg, a, b);
            assert!(
                (got - want).abs() <= STEP_ARCLEN_ACCURACY_MM,
                "{a} {b}: {got} {want}"
            );
        }
        assert_eq!(step_arclen(&seg, 0.5, 0.4), 0.0);
    }
}
