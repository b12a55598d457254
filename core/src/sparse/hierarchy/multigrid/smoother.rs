//! The Chebyshev–Jacobi smoother of one level: the Chebyshev steps over `[λmax / ratio, λmax]`
//! and the fused passes that apply them.

use rayon::prelude::*;

use super::operator32::Operator32;
use super::{MultigridOptions, ROWS};
use crate::sparse::precond::inverse_diagonal;
use crate::sparse::{CsrMatrix3, SparseError};

/// One Chebyshev step `d = keep d + gain D⁻¹ res` (per channel; `keep` is 0 in the first step).
#[derive(Debug, Clone, Copy)]
pub(super) struct Step {
    pub(super) keep: [f64; 3],
    pub(super) gain: [f64; 3],
}

/// The steps of a degree-`degree` Chebyshev smoothing over `[λmax/ratio, λmax]` of `D⁻¹A`
/// (θ, δ the interval's centre and half-width, σ = θ/δ): step 0 `d = D⁻¹ res / θ`; step
/// `k > 0` with `ρ_0 = 1/σ`, `ρ_k = 1/(2σ − ρ_{k−1})`: `d = ρ_k ρ_{k−1} d + (2ρ_k/δ) D⁻¹ res`.
fn chebyshev_steps(lambda_max: [f64; 3], degree: usize, ratio: f64) -> Vec<Step> {
    let theta = lambda_max.map(|h| 0.5 * (h + h / ratio));
    let delta = lambda_max.map(|h| 0.5 * (h - h / ratio));
    let sigma = [0, 1, 2].map(|c| theta[c] / delta[c]);
    let mut rho = sigma.map(|s| 1.0 / s);
    let mut steps = vec![Step { keep: [0.0; 3], gain: theta.map(|t| 1.0 / t) }];
    for _ in 1..degree {
        let rho_new = [0, 1, 2].map(|c| 1.0 / (2.0 * sigma[c] - rho[c]));
        steps.push(Step { keep: [0, 1, 2].map(|c| rho_new[c] * rho[c]), gain: [0, 1, 2].map(|c| 2.0 * rho_new[c] / delta[c]) });
        rho = rho_new;
    }
    steps
}

/// The Chebyshev smoother of one level: `D⁻¹` of the level's operator `A` and the upper end
/// `λmax` of the interval, the Gershgorin bound `max_i Σ_j |ã_ij| / a_ii` of the spectrum of
/// `D⁻¹Ã` (`Ã` the `f32` operator the smoothing multiplies by). A true bound, so the smoother
/// contracts and the V-cycle is SPD with no safety factor, and a per-row one, so a change of
/// some rows updates it exactly ([`Multigrid::refresh`](super::Multigrid::refresh)). It can lie
/// well above the largest eigenvalue, which moves the interval up and damps a little less than
/// an estimate of the eigenvalue would; the guaranteed contraction is worth that.
#[derive(Debug, Clone)]
pub(super) struct Smoother {
    pub(super) inv_diag: Vec<[f64; 3]>,
    /// `Σ_j |ã_ij| / a_ii` per row.
    row_bounds: Vec<[f64; 3]>,
    pub(super) lambda_max: [f64; 3],
    pub(super) steps: Vec<Step>,
}

/// The per-channel maximum of `bounds`.
fn max_bound(bounds: &[[f64; 3]]) -> [f64; 3] {
    bounds.par_iter().copied().reduce(|| [0.0; 3], |x, y| [0, 1, 2].map(|c| x[c].max(y[c])))
}

impl Smoother {
    /// The smoother of the level whose operator is `a`, rounded to `op`.
    pub(super) fn new(a: &CsrMatrix3, op: &Operator32, options: &MultigridOptions) -> Result<Self, SparseError> {
        let inv_diag = inverse_diagonal(a)?;
        let row_bounds: Vec<[f64; 3]> = inv_diag.par_iter().enumerate().map(|(i, &d)| op.row_bound(i, d)).collect();
        let lambda_max = max_bound(&row_bounds);
        let steps = chebyshev_steps(lambda_max, options.smoothing_degree, options.smoothing_ratio);
        Ok(Self { inv_diag, row_bounds, lambda_max, steps })
    }

    /// Follows a change of `a` (already rounded into `op`) confined to `rows`, whose diagonal
    /// `diagonal` is checked positive: equal to [`Self::new`]`(a, op)` afterwards.
    pub(super) fn refresh(&mut self, op: &Operator32, rows: &[u32], diagonal: &[[f64; 3]], options: &MultigridOptions) {
        for (&i, d) in rows.iter().zip(diagonal) {
            let i = i as usize;
            self.inv_diag[i] = d.map(|x| 1.0 / x);
            self.row_bounds[i] = op.row_bound(i, self.inv_diag[i]);
        }
        self.lambda_max = max_bound(&self.row_bounds);
        self.steps = chebyshev_steps(self.lambda_max, options.smoothing_degree, options.smoothing_ratio);
    }

    /// The first step from `z = 0`: `d = D⁻¹ r / θ`, `z = d` (no product; `d` is only written
    /// when a further step needs it).
    pub(super) fn first_from_zero(&self, r: &[[f64; 3]], z: &mut [[f64; 3]], d: &mut [[f64; 3]]) {
        let g = self.steps[0].gain;
        let kernel = |z: &mut [[f64; 3]], r: &[[f64; 3]], inv: &[[f64; 3]], mut d: Option<&mut [[f64; 3]]>| {
            for (t, ((zi, ri), ii)) in z.iter_mut().zip(r).zip(inv).enumerate() {
                let v = [0, 1, 2].map(|c| g[c] * ri[c] * ii[c]);
                *zi = v;
                if let Some(d) = d.as_deref_mut() {
                    d[t] = v;
                }
            }
        };
        let inv = &self.inv_diag;
        if self.steps.len() == 1 {
            (z.par_chunks_mut(ROWS), r.par_chunks(ROWS), inv.par_chunks(ROWS))
                .into_par_iter()
                .for_each(|(z, r, inv)| kernel(z, r, inv, None));
        } else {
            (z.par_chunks_mut(ROWS), d.par_chunks_mut(ROWS), r.par_chunks(ROWS), inv.par_chunks(ROWS))
                .into_par_iter()
                .for_each(|(z, d, r, inv)| kernel(z, r, inv, Some(d)));
        }
    }

    /// Step `k` from `z_in` in one pass: `res = r − Ã z_in`, `d = keep d + gain D⁻¹ res`,
    /// `z_out = z_in + d` (step 0 does not read `d`, the last step does not write it).
    pub(super) fn step(
        &self,
        op: &Operator32,
        k: usize,
        r: &[[f64; 3]],
        z_in: &[[f64; 3]],
        z_out: &mut [[f64; 3]],
        d: &mut [[f64; 3]],
    ) {
        let Step { keep, gain } = self.steps[k];
        let inv = &self.inv_diag;
        let last = k + 1 == self.steps.len();
        (z_out.par_chunks_mut(ROWS), d.par_chunks_mut(ROWS)).into_par_iter().enumerate().for_each(|(b, (zo, dc))| {
            for (t, (zo, di)) in zo.iter_mut().zip(dc.iter_mut()).enumerate() {
                let i = b * ROWS + t;
                let ax = op.row(i, z_in);
                let (ri, ii, zi) = (r[i], inv[i], z_in[i]);
                let mut dn = [0.0; 3];
                for c in 0..3 {
                    let g = gain[c] * (ri[c] - ax[c]) * ii[c];
                    dn[c] = if k == 0 { g } else { keep[c] * di[c] + g };
                    zo[c] = zi[c] + dn[c];
                }
                if !last {
                    *di = dn;
                }
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use nalgebra::DMatrix;

    use super::super::fixtures::grid_system;
    use super::super::{Multigrid, MultigridOptions};

    #[test]
    fn smoother_bound_lies_above_the_spectrum_and_close_to_it() {
        let (h, a) = grid_system(9, 8, 7);
        let mg = Multigrid::new(Arc::new(h), &a, MultigridOptions::default()).unwrap();
        for l in 0..mg.hierarchy.levels() - 1 {
            let (op, sm) = (&mg.ops32[l], &mg.smoothers[l]);
            let n = sm.inv_diag.len();
            for c in 0..3 {
                // D^-½ Ã D^-½ has the spectrum of D⁻¹Ã.
                let mut m = DMatrix::<f64>::zeros(n, n);
                for i in 0..n {
                    for k in op.pattern.row_ptr()[i]..op.pattern.row_ptr()[i + 1] {
                        let j = op.pattern.col_idx()[k] as usize;
                        m[(i, j)] = f64::from(op.values[k][c]) * (sm.inv_diag[i][c] * sm.inv_diag[j][c]).sqrt();
                    }
                }
                let top = m.symmetric_eigenvalues().max();
                let bound = sm.lambda_max[c];
                assert!(bound >= top && bound <= 1.6 * top, "level {l} channel {c}: bound {bound}, λmax {top}");
            }
        }
    }
}
