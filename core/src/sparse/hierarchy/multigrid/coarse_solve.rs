//! The dense Cholesky solve at the coarsest level of the V-cycle.

use nalgebra::{Cholesky, Dyn};

use crate::sparse::{CsrMatrix3, SparseError};

/// The dense Cholesky factors `L` of the coarsest operator, the three channels interleaved,
/// lower triangle packed row by row (row `i` starts at `i(i+1)/2`).
#[derive(Debug, Clone)]
pub(super) struct CoarseFactor {
    n: usize,
    pub(super) l: Vec<[f64; 3]>,
}

impl CoarseFactor {
    /// The dense Cholesky factors of the coarsest operator `m`, per channel.
    pub(super) fn new(m: &CsrMatrix3) -> Result<Self, SparseError> {
        let factor = |c: usize| -> Result<Cholesky<f64, Dyn>, SparseError> {
            Cholesky::new(m.to_dense(c)).ok_or_else(|| {
                SparseError::InvalidOption(format!("the coarsest Galerkin operator is not positive definite on channel {c}"))
            })
        };
        let ((f0, f1), f2) = rayon::join(|| rayon::join(|| factor(0), || factor(1)), || factor(2));
        Ok(Self::from_factors(&[f0?, f1?, f2?]))
    }

    /// The three channels' factors packed together.
    fn from_factors(factors: &[Cholesky<f64, Dyn>; 3]) -> Self {
        let n = factors[0].l_dirty().nrows();
        let mut l = Vec::with_capacity(n * (n + 1) / 2);
        for i in 0..n {
            for j in 0..=i {
                l.push([0, 1, 2].map(|c| factors[c].l_dirty()[(i, j)]));
            }
        }
        Self { n, l }
    }

    /// The order of the coarsest operator.
    #[cfg(feature = "gpu")]
    pub(super) fn n(&self) -> usize {
        self.n
    }

    /// `x ← (L Lᵀ)⁻¹ x`: forward substitution by rows, back substitution by columns (both
    /// walk the packed rows of `L` contiguously).
    pub(super) fn solve_in_place(&self, x: &mut [[f64; 3]]) {
        for i in 0..self.n {
            let row = &self.l[i * (i + 1) / 2..][..=i];
            let mut s = x[i];
            for (lij, xj) in row[..i].iter().zip(&x[..i]) {
                for c in 0..3 {
                    s[c] -= lij[c] * xj[c];
                }
            }
            x[i] = [0, 1, 2].map(|c| s[c] / row[i][c]);
        }
        for i in (0..self.n).rev() {
            let row = &self.l[i * (i + 1) / 2..][..=i];
            let xi = [0, 1, 2].map(|c| x[i][c] / row[i][c]);
            x[i] = xi;
            for (lij, xj) in row[..i].iter().zip(&mut x[..i]) {
                for c in 0..3 {
                    xj[c] -= lij[c] * xi[c];
                }
            }
        }
    }

    /// `A⁻¹ = (L Lᵀ)⁻¹` of every channel, dense and row-major (`n × n`, channels interleaved),
    /// exactly symmetric.
    ///
    /// Column `j` solves `L Lᵀ x = e_j` for `x_k`, `k ≥ j` only: the forward substitution starts
    /// at row `j` (the rows above stay zero) and the back substitution stops there (the rows
    /// above are the mirror of columns already solved). That is `n³/3` multiply-adds per channel
    /// where a full inverse by substitution costs `2n³`, and the columns run in parallel.
    #[cfg(feature = "gpu")]
    pub(super) fn inverse(&self) -> Vec<[f64; 3]> {
        use rayon::prelude::*;
        let n = self.n;
        let row = |i: usize| &self.l[i * (i + 1) / 2..][..=i];
        let columns: Vec<Vec<[f64; 3]>> = (0..n)
            .into_par_iter()
            .map(|j| {
                // x[k - j] holds x_k.
                let mut x = vec![[0.0; 3]; n - j];
                for i in j..n {
                    let r = row(i);
                    let mut s = if i == j { [1.0; 3] } else { [0.0; 3] };
                    for (lik, xk) in r[j..i].iter().zip(&x) {
                        for c in 0..3 {
                            s[c] -= lik[c] * xk[c];
                        }
                    }
                    x[i - j] = [0, 1, 2].map(|c| s[c] / r[i][c]);
                }
                for i in (j..n).rev() {
                    let r = row(i);
                    let xi = [0, 1, 2].map(|c| x[i - j][c] / r[i][c]);
                    x[i - j] = xi;
                    for (lik, xk) in r[j..i].iter().zip(&mut x) {
                        for c in 0..3 {
                            xk[c] -= lik[c] * xi[c];
                        }
                    }
                }
                x
            })
            .collect();
        let mut inv = vec![[0.0; 3]; n * n];
        for (j, column) in columns.iter().enumerate() {
            for (k, &v) in (j..n).zip(column) {
                inv[k * n + j] = v;
                inv[j * n + k] = v;
            }
        }
        inv
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::super::fixtures::system;
    use super::*;
    use crate::sparse::fixtures::random_vector;

    #[test]
    fn coarse_factor_solves_like_nalgebra() {
        let (_, a) = system();
        let m = 40;
        let dense: [DMatrix<f64>; 3] = [0, 1, 2].map(|c| {
            let d = a.to_dense(c);
            d.view((0, 0), (m, m)).into_owned()
        });
        let factors = dense.clone().map(|d| Cholesky::new(d).unwrap());
        let f = CoarseFactor::from_factors(&factors);
        let r = random_vector(m, 3);
        let mut x = r.clone();
        f.solve_in_place(&mut x);
        for c in 0..3 {
            let ax = &dense[c] * DVector::from_iterator(m, x.iter().map(|v| v[c]));
            for i in 0..m {
                assert!((ax[i] - r[i][c]).abs() < 1e-12, "channel {c} row {i}: {} vs {}", ax[i], r[i][c]);
            }
        }
    }

    #[cfg(feature = "gpu")]
    #[test]
    fn the_inverse_is_symmetric_and_inverts_every_channel() {
        let (_, a) = system();
        let m = 60;
        let dense: [DMatrix<f64>; 3] = [0, 1, 2].map(|c| a.to_dense(c).view((0, 0), (m, m)).into_owned());
        let f = CoarseFactor::from_factors(&dense.clone().map(|d| Cholesky::new(d).unwrap()));
        let inv = f.inverse();
        for c in 0..3 {
            let x = DMatrix::from_fn(m, m, |i, j| inv[i * m + j][c]);
            assert_eq!(x, x.transpose(), "channel {c}: not exactly symmetric");
            let residual = (&dense[c] * &x - DMatrix::identity(m, m)).abs().max();
            assert!(residual < 1e-12, "channel {c}: |A A⁻¹ − I|max = {residual:e}");
        }
    }
}
