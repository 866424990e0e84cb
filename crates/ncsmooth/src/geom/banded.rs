//! Banded linear systems: Gaussian elimination with partial pivoting on a matrix stored by
//! its band, in `O(n kl (kl + ku))` time and `O(n (2 kl + ku + 1))` memory (the LAPACK
//! `gbsv` scheme). Used by the global curve interpolation ([`super::global_interp`]), whose
//! collocation matrix has `p + 1` non-zeros per row around the diagonal.
//!
//! Storage: row `i` keeps the absolute columns `i - kl ..= i + kl + ku`; the extra `kl`
//! columns on the right hold the fill-in that row exchanges create (a pivot row `r <= i + kl`
//! has its non-zeros in `r - kl ..= r + ku`, inside row `i`'s window). Pivoting is partial
//! (largest magnitude in the column among the `kl` rows below), so the solver is safe for
//! any non-singular banded matrix, not only the totally positive B-spline collocation
//! matrices (which would also be safe without pivoting, de Boor 1977).

//!
//! [`SymBanded`] is the second solver here: a symmetric positive definite matrix of
//! half-bandwidth [`BAND`] (3) (the quadratic forms of a cubic B-spline, as in the band fit of
//! `smooth::band_fit`), stored by its lower band and solved by Cholesky. It is kept beside
//! the general solver, not replaced by it, because it stores half the band, needs no pivot
//! search, and is factored once and solved many times (once per ADMM iteration), each solve
//! `O(n BAND)`; on the band fit's systems it is faster than the pivoting LU (figures in
//! docs/benchmarks/2026-12-03.md).
use std::ops::{Mul, Sub};

use super::Vec3;

/// A square banded matrix with `kl` sub-diagonals and `ku` super-diagonals.
#[derive(Clone, Debug, PartialEq)]
pub struct BandedMatrix {
    n: usize,
    kl: usize,
    ku: usize,
    /// Row-major, `width()` entries per row; entry `(i, j)` at `i * width + (j + kl - i)`.
    data: Vec<f64>,
}

impl BandedMatrix {
    /// A zero `n x n` matrix with `kl` sub-diagonals and `ku` super-diagonals.
    pub fn zeros(n: usize, kl: usize, ku: usize) -> BandedMatrix {
        let w = 2 * kl + ku + 1;
        BandedMatrix {
            n,
            kl,
            ku,
            data: vec![0.0; n * w],
        }
    }

    /// Order of the matrix.
    pub fn n(&self) -> usize {
        self.n
    }

    #[inline]
    fn width(&self) -> usize {
        2 * self.kl + self.ku + 1
    }

    #[inline]
    fn idx(&self, i: usize, j: usize) -> Option<usize> {
        // Column window of row i: [i - kl, i + kl + ku].
        if j + self.kl < i || j > i + self.kl + self.ku || i >= self.n || j >= self.n {
            return None;
        }
        Some(i * self.width() + (j + self.kl - i))
    }

    /// Entry `(i, j)` (zero outside the band).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.idx(i, j).map_or(0.0, |k| self.data[k])
    }

    /// Sets entry `(i, j)`. Returns `false` (and changes nothing) when `(i, j)` lies
    /// outside the declared band `i - kl <= j <= i + ku`.
    pub fn set(&mut self, i: usize, j: usize, v: f64) -> bool {
        if j + self.kl < i || j > i + self.ku {
            return false;
        }
        match self.idx(i, j) {
            Some(k) => {
                self.data[k] = v;
                true
            }
            None => false,
        }
    }

    /// Solves `A x = b` in place (`rhs` becomes `x`), consuming the matrix. `T` is any
    /// vector-like value (`f64`, [`Vec3`](super::Vec3)). Returns `None` when a pivot is
    /// zero or not finite (singular matrix) or `rhs.len() != n`.
    pub fn solve<T>(mut self, rhs: &mut [T]) -> Option<()>
    where
        T: Copy + Sub<Output = T> + Mul<f64, Output = T>,
    {
        let n = self.n;
        if rhs.len() != n {
            return None;
        }
        let (kl, ku) = (self.kl, self.ku);
        let w = self.width();
        for k in 0..n {
            let last_row = (k + kl).min(n - 1);
            let last_col = (k + kl + ku).min(n - 1);
            // Partial pivoting within the band.
            let mut piv = k;
            let mut best = self.data[k * w + kl].abs();
            for r in (k + 1)..=last_row {
                let v = self.data[r * w + (k + kl - r)].abs();
                if v > best {
                    best = v;
                    piv = r;
                }
            }
            if !(best > 0.0 && best.is_finite()) {
                return None;
            }
            if piv != k {
                for c in k..=last_col {
                    let a = k * w + (c + kl - k);
                    let b = piv * w + (c + kl - piv);
                    self.data.swap(a, b);
                }
                rhs.swap(k, piv);
            }
            let d = self.data[k * w + kl];
            for r in (k + 1)..=last_row {
                let ir = r * w + (k + kl - r);
                let f = self.data[ir] / d;
                if f == 0.0 {
                    continue;
                }
                self.data[ir] = 0.0;
                for c in (k + 1)..=last_col {
                    let v = self.data[k * w + (c + kl - k)];
                    self.data[r * w + (c + kl - r)] -= f * v;
                }
                rhs[r] = rhs[r] - rhs[k] * f;
            }
        }
        // Back substitution: U has kl + ku super-diagonals.
        for k in (0..n).rev() {
            let last_col = (k + kl + ku).min(n - 1);
            let mut s = rhs[k];
            for c in (k + 1)..=last_col {
                s = s - rhs[c] * self.data[k * w + (c + kl - k)];
            }
            rhs[k] = s * (1.0 / self.data[k * w + kl]);
        }
        Some(())
    }
}

/// Half-bandwidth of [`SymBanded`]: a cubic B-spline's quadratic forms couple control
/// points at most 3 apart.
pub(crate) const BAND: usize = 3;

/// A symmetric matrix with half-bandwidth [`BAND`] (3), stored by its lower band:
/// `a[i][k] = A[i][i - BAND + k]`.
#[derive(Clone, Debug)]
pub(crate) struct SymBanded {
    a: Vec<[f64; BAND + 1]>,
}

impl SymBanded {
    /// The zero `n x n` matrix.
    pub(crate) fn zeros(n: usize) -> SymBanded {
        SymBanded {
            a: vec![[0.0; BAND + 1]; n],
        }
    }
    /// Order of the matrix.
    pub(crate) fn n(&self) -> usize {
        self.a.len()
    }
    /// Adds `v` to `A[i][j]` (and so to `A[j][i]`), `|i - j| <= BAND`.
    pub(crate) fn add(&mut self, i: usize, j: usize, v: f64) {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        self.a[i][BAND + j - i] += v;
    }
    /// Entry `(i, j)` (zero outside the band).
    pub(crate) fn get(&self, i: usize, j: usize) -> f64 {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        if i - j > BAND {
            0.0
        } else {
            self.a[i][BAND + j - i]
        }
    }
    /// Sets `A[i][j]` and `A[j][i]`, `|i - j| <= BAND`.
    pub(crate) fn set(&mut self, i: usize, j: usize, v: f64) {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        self.a[i][BAND + j - i] = v;
    }
    /// Adds the symmetric part of `s f g^T` for forms `f`, `g` over `k .. k + 3`.
    pub(crate) fn add_outer(&mut self, k: usize, f: &[f64; 4], g: &[f64; 4], s: f64) {
        for x in 0..4 {
            for y in 0..=x {
                let v = if x == y {
                    s * f[x] * g[y]
                } else {
                    0.5 * s * (f[x] * g[y] + f[y] * g[x])
                };
                self.add(k + x, k + y, v);
            }
        }
    }
    /// Cholesky factor `L` (same storage), `None` when not positive definite.
    pub(crate) fn cholesky(&self) -> Option<SymBanded> {
        let n = self.n();
        let mut l = SymBanded::zeros(n);
        for i in 0..n {
            for j in i.saturating_sub(BAND)..=i {
                let mut s = self.get(i, j);
                for k in i.saturating_sub(BAND)..j {
                    s -= l.get(i, k) * l.get(j, k);
                }
                if i == j {
                    if !(s > 0.0 && s.is_finite()) {
                        return None;
                    }
                    l.set(i, i, s.sqrt());
                } else {
                    l.set(i, j, s / l.get(j, j));
                }
            }
        }
        Some(l)
    }
    /// Solves `L L^T x = b` in place, `self` being the factor `L` of [`Self::cholesky`].
    pub(crate) fn chol_solve(&self, b: &mut [Vec3]) {
        let n = self.n();
        for i in 0..n {
            let mut s = b[i];
            for k in i.saturating_sub(BAND)..i {
                s -= b[k] * self.get(i, k);
            }
            b[i] = s / self.get(i, i);
        }
        for i in (0..n).rev() {
            let mut s = b[i];
            for k in i + 1..(i + BAND + 1).min(n) {
                s -= b[k] * self.get(k, i);
            }
            b[i] = s / self.get(i, i);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Dense Gaussian elimination with partial pivoting (reference).
    fn dense_solve(mut a: Vec<Vec<f64>>, mut b: Vec<Vec3>) -> Vec<Vec3> {
        let n = a.len();
        for k in 0..n {
            let piv = (k..n)
                .max_by(|&x, &y| a[x][k].abs().total_cmp(&a[y][k].abs()))
                .unwrap();
            a.swap(k, piv);
            b.swap(k, piv);
            for r in (k + 1)..n {
                let f = a[r][k] / a[k][k];
                for c in k..n {
                    a[r][c] -= f * a[k][c];
                }
                b[r] = b[r] - b[k] * f;
            }
        }
        for k in (0..n).rev() {
            let mut s = b[k];
            for c in (k + 1)..n {
                s -= b[c] * a[k][c];
            }
            b[k] = s / a[k][k];
        }
        b
    }

    /// Small deterministic pseudo-random generator (xorshift), values in [-1, 1).
    fn rng(seed: &mut u64) -> f64 {
        *seed ^= *seed << 13;
        *seed ^= *seed >> 7;
        *seed ^= *seed << 17;
        (*seed >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }

    #[test]
    fn banded_matches_dense_on_random_band_matrices() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        for n in 1..=12 {
            for kl in 0..3 {
                for ku in 0..3 {
                    let mut m = BandedMatrix::zeros(n, kl, ku);
                    let mut dense = vec![vec![0.0; n]; n];
                    for i in 0..n {
                        for j in 0..n {
                            if j + kl >= i && j <= i + ku {
                                // Weak diagonal on purpose, so pivoting is exercised.
                                let v = rng(&mut seed) + if i == j { 0.1 } else { 0.0 };
                                assert!(m.set(i, j, v));
                                dense[i][j] = v;
                            }
                        }
                    }
                    let b: Vec<Vec3> = (0..n)
                        .map(|_| Vec3::new(rng(&mut seed), rng(&mut seed), rng(&mut seed)))
                        .collect();
                    let want = dense_solve(dense.clone(), b.clone());
                    let mut got = b.clone();
                    m.solve(&mut got).unwrap();
                    // Residual check too: A x = b.
                    for i in 0..n {
                        let mut r = Vec3::ZERO;
                        for j in 0..n {
                            r += got[j] * dense[i][j];
                        }
                        assert!((r - b[i]).norm() < 1e-9, "n {n} kl {kl} ku {ku}");
                        assert!((got[i] - want[i]).norm() < 1e-8 * (1.0 + want[i].norm()));
                    }
                }
            }
        }
    }

    #[test]
    fn pivoting_handles_a_zero_diagonal() {
        // [[0, 1], [1, 0]] x = [2, 3] -> x = [3, 2].
        let mut m = BandedMatrix::zeros(2, 1, 1);
        m.set(0, 1, 1.0);
        m.set(1, 0, 1.0);
        let mut b = [2.0, 3.0];
        m.solve(&mut b).unwrap();
        assert_eq!(b, [3.0, 2.0]);
    }

    #[test]
    fn singular_and_out_of_band() {
        let mut m = BandedMatrix::zeros(3, 1, 1);
        assert!(!m.set(0, 2, 1.0));
        m.set(0, 0, 1.0);
        m.set(1, 0, 1.0);
        let mut b = [1.0, 1.0, 1.0];
        assert!(m.clone().solve(&mut b).is_none());
        let mut short = [1.0];
        assert!(m.solve(&mut short).is_none());
        assert_eq!(BandedMatrix::zeros(4, 1, 2).get(3, 0), 0.0);
    }

    #[test]
    fn cholesky_agrees_with_the_pivoting_solver_on_spd_band_matrices() {
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        for n in 1..=20 {
            // A = B^T B + I with B of half-bandwidth <= 3 in the upper band: SPD, band 3.
            let mut sym = SymBanded::zeros(n);
            let mut lu = BandedMatrix::zeros(n, BAND, BAND);
            for k in 0..n.saturating_sub(3) {
                let f = [
                    rng(&mut seed),
                    rng(&mut seed),
                    rng(&mut seed),
                    rng(&mut seed),
                ];
                sym.add_outer(k, &f, &f, 1.0);
            }
            for i in 0..n {
                sym.add(i, i, 1.0);
            }
            for i in 0..n {
                for j in i.saturating_sub(BAND)..(i + BAND + 1).min(n) {
                    assert!(lu.set(i, j, sym.get(i, j)));
                }
            }
            let b: Vec<Vec3> = (0..n)
                .map(|_| Vec3::new(rng(&mut seed), rng(&mut seed), rng(&mut seed)))
                .collect();
            let (mut x, mut y) = (b.clone(), b.clone());
            sym.cholesky().unwrap().chol_solve(&mut x);
            lu.solve(&mut y).unwrap();
            for i in 0..n {
                assert!(
                    (x[i] - y[i]).norm() < 1e-12 * (1.0 + y[i].norm()),
                    "n {n} i {i}"
                );
            }
        }
        let mut indefinite = SymBanded::zeros(2);
        indefinite.set(0, 0, 1.0);
        indefinite.set(1, 0, 2.0);
        indefinite.set(1, 1, 1.0);
        assert!(indefinite.cholesky().is_none());
    }
}
