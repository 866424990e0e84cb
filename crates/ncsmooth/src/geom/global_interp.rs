//! Global curve interpolation through points (Piegl and Tiller, *The NURBS Book*, 2nd ed.,
//! section 9.2.1, algorithm A9.1, and section 9.2.2 for end-derivative constraints).
//!
//! Given points `Q_0 .. Q_n` and a degree `p`:
//!
//! 1. parameters `ubar_k`: chord length (eq. 9.5, the default) or centripetal (eq. 9.6,
//!    square roots of the chord lengths), normalised to `[0, 1]`;
//! 2. knots by averaging (eq. 9.8, Wu et al. eq. 5): `u_(j+p) = (1/p) sum_(i=j)^(j+p-1)
//!    ubar_i`, `j = 1 .. n-p`, clamped at 0 and 1; with end derivatives, eq. 9.22;
//! 3. the collocation system `sum_i N_(i,p)(ubar_k) P_i = Q_k`, banded (each row has `p + 1`
//!    non-zeros around the diagonal), solved in `O(n)` by [`BandedMatrix`] (never a dense
//!    matrix).
//!
//! The results are non-rational B-splines ([`Nurbs`] with unit weights). They match
//! `geomdl.fitting.interpolate_curve(points, p)` (same parameters and knots, see
//! `scripts/geomdl_compare.py`).
//!
//! With end tangents (9.2.2) two equations `P_1 - P_0 = (u_(p+1) / p) D_0` and
//! `P_(n+2) - P_(n+1) = ((1 - u_(m-p-1)) / p) D_n` are added. The book leaves the derivative
//! magnitudes open; we use the local parametric speed of the data,
//! `|D_0| = |Q_1 - Q_0| / ubar_1` (the total chord length for chord-length parameters, as the
//! book suggests), and likewise at the end, so the curve's speed matches its first and last
//! chords under either parametrization.
//!
//! Exact methods: no accuracy parameter. `None` for fewer points than the degree needs, two
//! consecutive coincident points (repeated parameters make the system singular: callers
//! remove them first), non-finite input or a singular system.

use super::banded::BandedMatrix;
use super::nurbs::{basis_funs, Nurbs, MAX_DEGREE};
use super::vec3::Vec3;
use serde::Serialize;

/// How the data points are parametrised.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize)]
pub enum Parametrization {
    /// Proportional to chord length (NURBS Book eq. 9.5). Default.
    #[default]
    ChordLength,
    /// Proportional to the square root of chord length (eq. 9.6): follows sharp turns of
    /// the data more tightly.
    Centripetal,
}

/// Parameters `ubar_k` in `[0, 1]` (first 0, last exactly 1). `None` for fewer than two
/// points, coincident consecutive points or non-finite input.
pub fn parameters(points: &[Vec3], kind: Parametrization) -> Option<Vec<f64>> {
    if points.len() < 2 {
        return None;
    }
    let mut u = Vec::with_capacity(points.len());
    u.push(0.0);
    let mut acc = 0.0;
    for w in points.windows(2) {
        let d = w[0].dist(w[1]);
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        acc += match kind {
            Parametrization::ChordLength => d,
            Parametrization::Centripetal => d.sqrt(),
        };
        u.push(acc);
    }
    if !(acc > 0.0 && acc.is_finite()) {
        return None;
    }
    for v in u.iter_mut() {
        *v /= acc;
    }
    *u.last_mut()? = 1.0;
    Some(u)
}

/// Averaging knots (NURBS Book eq. 9.8) for `params.len()` control points of degree `p`.
pub fn averaging_knots(params: &[f64], p: usize) -> Vec<f64> {
    let n = params.len().saturating_sub(1);
    let mut k = Vec::with_capacity(n + p + 2);
    k.extend(std::iter::repeat_n(0.0, p + 1));
    for j in 1..=n.saturating_sub(p) {
        k.push(params[j..j + p].iter().sum::<f64>() / p as f64);
    }
    k.extend(std::iter::repeat_n(1.0, p + 1));
    k
}

/// Averaging knots with end derivatives (NURBS Book eq. 9.22) for `params.len() + 2`
/// control points of degree `p` (`p <= params.len() + 1`).
pub fn averaging_knots_with_ends(params: &[f64], p: usize) -> Vec<f64> {
    let n = params.len().saturating_sub(1);
    let mut k = Vec::with_capacity(n + p + 4);
    k.extend(std::iter::repeat_n(0.0, p + 1));
    if !params.is_empty() && n + 1 >= p {
        for j in 0..=(n + 1 - p) {
            k.push(params[j..j + p].iter().sum::<f64>() / p as f64);
        }
    }
    k.extend(std::iter::repeat_n(1.0, p + 1));
    k
}

/// One row of the collocation system: first column and up to `p + 1` coefficients.
struct Row {
    col0: usize,
    len: usize,
    coef: [f64; MAX_DEGREE + 1],
}

impl Row {
    fn unit(col: usize) -> Row {
        let mut coef = [0.0; MAX_DEGREE + 1];
        coef[0] = 1.0;
        Row {
            col0: col,
            len: 1,
            coef,
        }
    }
    fn diff(col: usize) -> Row {
        let mut coef = [0.0; MAX_DEGREE + 1];
        coef[0] = -1.0;
        coef[1] = 1.0;
        Row {
            col0: col,
            len: 2,
            coef,
        }
    }
}

/// Collocation rows at `params` (non-decreasing) for `n_ctrl` control points; the span
/// index walks forward, so the whole set costs `O(n p^2)`.
fn basis_rows(params: &[f64], p: usize, knots: &[f64], n_ctrl: usize) -> Vec<Row> {
    let mut rows = Vec::with_capacity(params.len());
    let mut span = p;
    for &u in params {
        if u >= knots[n_ctrl] {
            span = n_ctrl - 1;
        } else {
            while span + 1 < n_ctrl && knots[span + 1] <= u {
                span += 1;
            }
        }
        rows.push(Row {
            col0: span - p,
            len: p + 1,
            coef: basis_funs(knots, span, u, p),
        });
    }
    rows
}

/// Solves the banded system given by `rows` (one per control point) for `rhs`.
fn solve_rows(rows: &[Row], rhs: &mut [Vec3]) -> Option<()> {
    let n = rows.len();
    let (mut kl, mut ku) = (0, 0);
    for (i, r) in rows.iter().enumerate() {
        kl = kl.max(i.saturating_sub(r.col0));
        ku = ku.max((r.col0 + r.len - 1).saturating_sub(i));
    }
    let mut m = BandedMatrix::zeros(n, kl, ku);
    for (i, r) in rows.iter().enumerate() {
        for j in 0..r.len {
            if r.col0 + j >= n || !m.set(i, r.col0 + j, r.coef[j]) {
                return None;
            }
        }
    }
    m.solve(rhs)
}

/// Global interpolation (A9.1): the degree-`p` B-spline through every point, with
/// `points.len()` control points. Needs `points.len() > p` and `1 <= p <= MAX_DEGREE`.
pub fn interpolate(points: &[Vec3], p: usize, kind: Parametrization) -> Option<Nurbs> {
    if !(1..=MAX_DEGREE).contains(&p) || points.len() <= p {
        return None;
    }
    let ubar = parameters(points, kind)?;
    let knots = averaging_knots(&ubar, p);
    let n_ctrl = points.len();
    let mut rows = basis_rows(&ubar, p, &knots, n_ctrl);
    // The end rows are exactly unit rows (clamped knots); set them so to avoid round-off.
    rows[0] = Row::unit(0);
    rows[n_ctrl - 1] = Row::unit(n_ctrl - 1);
    let mut ctrl = points.to_vec();
    solve_rows(&rows, &mut ctrl)?;
    Nurbs::bspline(p, ctrl, knots)
}

/// Global interpolation with end tangents (NURBS Book 9.2.2): the degree-`p` B-spline
/// through every point whose tangent at the start is `start_dir` and at the end `end_dir`
/// (directions; their lengths are ignored, see the module doc for the magnitudes).
/// `points.len() + 2` control points. Needs at least two points and `p <= points.len() + 1`.
pub fn interpolate_with_tangents(
    points: &[Vec3],
    p: usize,
    kind: Parametrization,
    start_dir: Vec3,
    end_dir: Vec3,
) -> Option<Nurbs> {
    let np = points.len();
    if !(1..=MAX_DEGREE).contains(&p) || np < 2 || p > np + 1 {
        return None;
    }
    let t0 = start_dir.normalized()?;
    let t1 = end_dir.normalized()?;
    let ubar = parameters(points, kind)?;
    let knots = averaging_knots_with_ends(&ubar, p);
    let n_ctrl = np + 2;
    let speed0 = points[0].dist(points[1]) / ubar[1];
    let speed1 = points[np - 2].dist(points[np - 1]) / (1.0 - ubar[np - 2]);
    let d0 = t0 * (speed0 * knots[p + 1] / p as f64);
    let d1 = t1 * (speed1 * (1.0 - knots[n_ctrl - 1]) / p as f64);
    let mut rows = Vec::with_capacity(n_ctrl);
    let mut rhs = Vec::with_capacity(n_ctrl);
    rows.push(Row::unit(0));
    rhs.push(points[0]);
    rows.push(Row::diff(0));
    rhs.push(d0);
    rows.extend(basis_rows(&ubar[1..np - 1], p, &knots, n_ctrl));
    rhs.extend_from_slice(&points[1..np - 1]);
    rows.push(Row::diff(n_ctrl - 2));
    rhs.push(d1);
    rows.push(Row::unit(n_ctrl - 1));
    rhs.push(points[np - 1]);
    solve_rows(&rows, &mut rhs)?;
    Nurbs::bspline(p, rhs, knots)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::ParamCurveDeriv;

    fn rng(seed: &mut u64) -> f64 {
        *seed ^= *seed << 13;
        *seed ^= *seed >> 7;
        *seed ^= *seed << 17;
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    fn random_points(n: usize, seed: &mut u64) -> Vec<Vec3> {
        let mut p = Vec3::ZERO;
        (0..n)
            .map(|_| {
                p += Vec3::new(0.1 + rng(seed), rng(seed) - 0.5, 0.3 * (rng(seed) - 0.5));
                p
            })
            .collect()
    }

    #[test]
    fn passes_through_every_point() {
        let mut seed = 12345u64;
        for kind in [Parametrization::ChordLength, Parametrization::Centripetal] {
            for p in 1..=5 {
                for n in (p + 1)..(p + 40) {
                    let pts = random_points(n, &mut seed);
                    let c = interpolate(&pts, p, kind).unwrap();
                    let u = parameters(&pts, kind).unwrap();
                    for (q, &uk) in pts.iter().zip(&u) {
                        assert!(c.point_at_param(uk).dist(*q) < 1e-9, "p {p} n {n}");
                    }
                }
            }
        }
    }

    #[test]
    fn knots_are_the_averages() {
        let u = [0.0, 0.1, 0.3, 0.6, 0.8, 1.0];
        let k = averaging_knots(&u, 3);
        assert_eq!(k.len(), 10);
        assert!((k[4] - (0.1 + 0.3 + 0.6) / 3.0).abs() < 1e-15);
        assert!((k[5] - (0.3 + 0.6 + 0.8) / 3.0).abs() < 1e-15);
        let k = averaging_knots_with_ends(&u, 3);
        assert_eq!(k.len(), u.len() + 2 + 4);
        assert!((k[4] - (0.0 + 0.1 + 0.3) / 3.0).abs() < 1e-15);
    }

    #[test]
    fn tangent_constraints_hold() {
        let mut seed = 777u64;
        for n in 2..30 {
            let pts = random_points(n, &mut seed);
            let (a, b) = (Vec3::new(1.0, 0.2, 0.0), Vec3::new(0.3, -1.0, 0.1));
            let c = interpolate_with_tangents(&pts, 3, Parametrization::ChordLength, a, b).unwrap();
            let u = parameters(&pts, Parametrization::ChordLength).unwrap();
            for (q, &uk) in pts.iter().zip(&u) {
                assert!(c.point_at_param(uk).dist(*q) < 1e-9);
            }
            let s = c.deriv(0.0).normalized().unwrap();
            let e = c.deriv(1.0).normalized().unwrap();
            assert!(s.dist(a.normalized().unwrap()) < 1e-9);
            assert!(e.dist(b.normalized().unwrap()) < 1e-9);
        }
    }

    #[test]
    fn reproduces_a_cubic_exactly() {
        // Cubic data interpolated by a cubic spline with matching end derivatives is the
        // cubic itself only for special parameters; a straight line is reproduced exactly
        // for any parameters, with collinear control points.
        let pts: Vec<Vec3> = (0..10)
            .map(|i| Vec3::new(i as f64 * 0.7, 2.0, 1.0))
            .collect();
        let c = interpolate(&pts, 3, Parametrization::ChordLength).unwrap();
        for cp in c.ctrl() {
            assert!((cp.y - 2.0).abs() < 1e-12 && (cp.z - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn rejects_degenerate_input() {
        let pts = [Vec3::ZERO, Vec3::X, Vec3::X, Vec3::Y];
        assert!(interpolate(&pts, 3, Parametrization::ChordLength).is_none());
        assert!(interpolate(&pts[..3], 3, Parametrization::ChordLength).is_none());
        let nan = [Vec3::ZERO, Vec3::new(f64::NAN, 0.0, 0.0), Vec3::X, Vec3::Y];
        assert!(interpolate(&nan, 3, Parametrization::ChordLength).is_none());
        assert!(
            interpolate_with_tangents(&pts[..2], 3, Default::default(), Vec3::ZERO, Vec3::X)
                .is_none()
        );
    }
}
