//! The dense Cholesky solve at the coarsest level of the V-cycle.

#[cfg(feature = "gpu")]
use nalgebra::DMatrix;
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

    /// The dense `L` of channel `c`.
    #[cfg(feature = "gpu")]
    pub(super) fn dense(&self, c: usize) -> DMatrix<f64> {
        DMatrix::from_fn(self.n, self.n, |i, j| if j <= i { self.l[i * (i + 1) / 2 + j][c] } else { 0.0 })
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
}
