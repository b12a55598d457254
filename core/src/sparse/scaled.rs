//! The Jacobi-scaled operator `Â = S A S` (`S = D^-½`, so `Â` has a unit diagonal), stored in
//! `f32`, on which the mixed-precision PCG iterates and the Chebyshev polynomial is evaluated.
//!
//! Storing `Â` in `f32` halves the bytes the SpMV streams per nonzero (12 + 4 instead of 24 + 4)
//! and makes Jacobi scaling free inside the iteration (no inverse-diagonal vector to read). The
//! `f32` rounding perturbs `Â` by about 6e-8 per entry; the solver corrects for it with
//! residuals recomputed in `f64` from the original matrix ("reliable updates"), so the answer
//! meets the tolerance on the `f64` system.

use std::sync::Arc;

use rayon::prelude::*;

use super::csr::{split_row_blocks, CsrMatrix3, CsrPattern, ROW_BLOCK};
use super::error::SparseError;
use super::ops::{spmv_dot, sum_partials, CHUNK};
use super::precond::inverse_diagonal;

/// `Â = S A S` in `f32`, with `S = D^-½` and `D` kept for residual norms.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ScaledOperator {
    pub(crate) pattern: Arc<CsrPattern>,
    pub(crate) values: Vec<[f32; 3]>,
    /// `S = D^-½` per row.
    pub(crate) s: Vec<[f64; 3]>,
    /// `D` per row, in `f32` (only used to turn scaled residual norms into unscaled ones).
    pub(crate) d: Vec<[f32; 3]>,
    /// A Gershgorin upper bound of the spectrum of `Â` (equivalently of `D⁻¹A`), per channel.
    pub(crate) lambda_max: [f64; 3],
}

impl ScaledOperator {
    /// Builds `Â` from `a` in one parallel pass.
    ///
    /// # Errors
    /// [`SparseError::NonPositiveDiagonal`] for a diagonal entry that is not positive.
    pub(crate) fn new(a: &CsrMatrix3) -> Result<Self, SparseError> {
        Ok(Self::from_inverse_diagonal(a, &inverse_diagonal(a)?))
    }

    /// Builds `Â` from `a` and its (checked, positive) inverse diagonal.
    pub(crate) fn from_inverse_diagonal(a: &CsrMatrix3, inv: &[[f64; 3]]) -> Self {
        let s: Vec<[f64; 3]> = inv.par_iter().map(|v| v.map(f64::sqrt)).collect();
        #[allow(clippy::cast_possible_truncation)]
        let d: Vec<[f32; 3]> = inv.par_iter().map(|v| v.map(|t| (1.0 / t) as f32)).collect();
        let p = a.pattern();
        let n = a.n();
        let vals = a.values();
        let mut values = vec![[0.0f32; 3]; a.nnz()];
        let blocks = split_row_blocks(&mut values, p.row_ptr());
        let bounds: Vec<[f64; 6]> = blocks
            .into_par_iter()
            .enumerate()
            .map(|(b, out)| {
                let r0 = b * ROW_BLOCK;
                let r1 = (r0 + ROW_BLOCK).min(n);
                let off = p.row_ptr()[r0];
                let mut m = [0.0f64; 6];
                for i in r0..r1 {
                    let mut row = [0.0; 6];
                    for k in p.row_ptr()[i]..p.row_ptr()[i + 1] {
                        let j = p.col_idx()[k] as usize;
                        let v = vals[k];
                        let mut o = [0.0f32; 3];
                        for c in 0..3 {
                            let scaled = v[c] * s[i][c] * s[j][c];
                            #[allow(clippy::cast_possible_truncation)]
                            {
                                o[c] = scaled as f32;
                            }
                            row[c] += scaled.abs();
                            row[3 + c] += v[c].abs() * inv[i][c];
                        }
                        out[k - off] = o;
                    }
                    for c in 0..6 {
                        m[c] = m[c].max(row[c]);
                    }
                }
                m
            })
            .collect();
        let mut m = [0.0f64; 6];
        for b in &bounds {
            for c in 0..6 {
                m[c] = m[c].max(b[c]);
            }
        }
        let lambda_max = [0, 1, 2].map(|c| m[c].min(m[3 + c]));
        Self { pattern: Arc::clone(p), values, s, d, lambda_max }
    }

    /// `q = Â p`; returns `pᵀq` per channel.
    pub(crate) fn spmv_dot(&self, p: &[[f64; 3]], q: &mut [[f64; 3]]) -> [f64; 3] {
        spmv_dot(&self.pattern, &self.values, p, q, p)
    }
}

/// The true residual of the scaled iterate: `r = b − A S ŷ` (in `f64`, original matrix) and
/// `r̂ = S r`, written to the channels of `rh` selected by `replace`. Returns `(‖r‖², ‖r̂‖²)`
/// per channel.
pub(crate) fn reliable_residual(
    a: &CsrMatrix3,
    b: &[[f64; 3]],
    s: &[[f64; 3]],
    yhat: &[[f64; 3]],
    rh: &mut [[f64; 3]],
    replace: [bool; 3],
) -> ([f64; 3], [f64; 3]) {
    let p = a.pattern();
    let (rp, ci) = (p.row_ptr(), p.col_idx());
    let vals = a.values();
    let parts: Vec<[f64; 6]> = (rh.par_chunks_mut(CHUNK), b.par_chunks(CHUNK))
        .into_par_iter()
        .enumerate()
        .map(|(k, (rc, bc))| {
            let r0 = k * CHUNK;
            let mut acc = [0.0; 6];
            for (li, (ri, bi)) in rc.iter_mut().zip(bc).enumerate() {
                let i = r0 + li;
                let (mut a0, mut a1, mut a2) = (0.0, 0.0, 0.0);
                for k in rp[i]..rp[i + 1] {
                    let j = ci[k] as usize;
                    let (v, sj, yj) = (vals[k], s[j], yhat[j]);
                    a0 += v[0] * (sj[0] * yj[0]);
                    a1 += v[1] * (sj[1] * yj[1]);
                    a2 += v[2] * (sj[2] * yj[2]);
                }
                let ax = [a0, a1, a2];
                for c in 0..3 {
                    let r = bi[c] - ax[c];
                    acc[c] += r * r;
                    let rs = s[i][c] * r;
                    acc[3 + c] += rs * rs;
                    if replace[c] {
                        ri[c] = rs;
                    }
                }
            }
            acc
        })
        .collect();
    let t = sum_partials(&parts);
    ([t[0], t[1], t[2]], [t[3], t[4], t[5]])
}
