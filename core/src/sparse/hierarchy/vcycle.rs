//! A multigrid V-cycle on the TransCut hierarchy, used as the preconditioner of CG.
//!
//! The paper (§4.2) keeps to its one-way cascade and remarks that its interpolation could
//! serve a full multigrid solver; this is that solver in its symmetric form. With `P` the
//! eq.-16 interpolation of each level, the coarse operators are the Galerkin products
//! `A^{l+1} = Pᵀ A^l P` ([`galerkin`]), which stay symmetric positive definite. One V-cycle
//! `z = B r`:
//!
//! 1. pre-smooth from `z = 0` with a degree-`d` Chebyshev polynomial in `D⁻¹A` over
//!    `[λmax / 30, λmax]` (`λmax` of `D⁻¹A` from 12 power iterations, ×1.1);
//! 2. restrict the residual `r_c = Pᵀ (r − A z)`, recurse (dense Cholesky at the coarsest);
//! 3. correct `z += P z_c`, post-smooth with the same polynomial.
//!
//! Pre- and post-smoothing are the same symmetric polynomial, the coarse solve is exact and the
//! restriction is `Pᵀ`, so `B` is symmetric positive definite and plain CG applies
//! ([`mg_pcg`]). All arithmetic is `f64`; every kernel is a fixed-order parallel loop, so results
//! are bit-identical for any thread count.

use std::sync::Arc;

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use rayon::prelude::*;

use super::coarse::galerkin;
use super::Hierarchy;
use crate::sparse::ops::{dot3, norm3, row_mul, CHUNK};
use crate::sparse::precond::inverse_diagonal;
use crate::sparse::{CsrMatrix3, SolveOptions, SolveStats, SparseError};

/// Options of [`Multigrid::new`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct MultigridOptions {
    /// Degree of the Chebyshev smoother (matrix products per smoothing). Default 2.
    pub smoothing_degree: usize,
    /// The smoothing interval is `[λmax / ratio, λmax]`. Default 30.
    pub smoothing_ratio: f64,
    /// Largest coarsest level factored densely; coarser hierarchies beyond it are an error.
    /// Default 4000.
    pub max_direct: usize,
}

impl Default for MultigridOptions {
    fn default() -> Self {
        Self { smoothing_degree: 2, smoothing_ratio: 30.0, max_direct: 4000 }
    }
}

#[derive(Debug, Clone)]
struct Smoother {
    inv_diag: Vec<[f64; 3]>,
    lambda_max: [f64; 3],
}

/// The Galerkin hierarchy, smoothers and coarsest factorisation for one matrix.
#[derive(Debug, Clone)]
pub struct Multigrid {
    hierarchy: Arc<Hierarchy>,
    /// `operators[l - 1]` is `A^l`, `l ≥ 1`.
    operators: Vec<CsrMatrix3>,
    smoothers: Vec<Smoother>,
    coarsest: Option<[Cholesky<f64, Dyn>; 3]>,
    options: MultigridOptions,
}

/// `y = A x` (three channels), deterministic.
fn spmv(a: &CsrMatrix3, x: &[[f64; 3]], y: &mut [[f64; 3]]) {
    let p = a.pattern();
    let v = a.values();
    y.par_iter_mut().enumerate().with_min_len(CHUNK / 4).for_each(|(i, yi)| {
        let (s, e) = (p.row_ptr()[i], p.row_ptr()[i + 1]);
        *yi = row_mul(&p.col_idx()[s..e], &v[s..e], x);
    });
}

/// `r = b − A x`.
fn residual(a: &CsrMatrix3, b: &[[f64; 3]], x: &[[f64; 3]], r: &mut [[f64; 3]]) {
    let p = a.pattern();
    let v = a.values();
    r.par_iter_mut().enumerate().with_min_len(CHUNK / 4).for_each(|(i, ri)| {
        let (s, e) = (p.row_ptr()[i], p.row_ptr()[i + 1]);
        let ax = row_mul(&p.col_idx()[s..e], &v[s..e], x);
        *ri = [0, 1, 2].map(|c| b[i][c] - ax[c]);
    });
}

fn lambda_max(a: &CsrMatrix3, inv_diag: &[[f64; 3]]) -> [f64; 3] {
    let n = a.n();
    // A fixed, non-smooth start vector.
    let mut x: Vec<[f64; 3]> = (0..n).map(|i| [1.0 + ((i * 7919) % 13) as f64 / 13.0; 3]).collect();
    let mut y = vec![[0.0; 3]; n];
    let mut lambda = [0.0; 3];
    for _ in 0..12 {
        let xn = norm3(&x);
        x.par_iter_mut().for_each(|v| *v = [0, 1, 2].map(|c| if xn[c] > 0.0 { v[c] / xn[c] } else { 0.0 }));
        spmv(a, &x, &mut y);
        y.par_iter_mut().zip(inv_diag).for_each(|(v, d)| *v = [0, 1, 2].map(|c| v[c] * d[c]));
        // Rayleigh-like quotient in the D inner product is not needed: the norm ratio bounds it.
        lambda = norm3(&y);
        std::mem::swap(&mut x, &mut y);
    }
    lambda.map(|l| 1.1 * l)
}

impl Smoother {
    fn new(a: &CsrMatrix3) -> Result<Self, SparseError> {
        let inv_diag = inverse_diagonal(a)?;
        let lambda_max = lambda_max(a, &inv_diag);
        Ok(Self { inv_diag, lambda_max })
    }

    /// Chebyshev smoothing of `a z = r` from the current `z` (degree `degree`).
    fn smooth(&self, a: &CsrMatrix3, r: &[[f64; 3]], z: &mut [[f64; 3]], degree: usize, ratio: f64, from_zero: bool) {
        let n = a.n();
        let hi = self.lambda_max;
        let lo = hi.map(|h| h / ratio);
        let theta = [0, 1, 2].map(|c| 0.5 * (hi[c] + lo[c]));
        let delta = [0, 1, 2].map(|c| 0.5 * (hi[c] - lo[c]));
        let sigma = [0, 1, 2].map(|c| theta[c] / delta[c]);
        let mut res = vec![[0.0; 3]; n];
        if from_zero {
            res.copy_from_slice(r);
        } else {
            residual(a, r, z, &mut res);
        }
        let mut d: Vec<[f64; 3]> =
            res.par_iter().zip(&self.inv_diag).map(|(x, di)| [0, 1, 2].map(|c| x[c] * di[c] / theta[c])).collect();
        let mut rho = sigma.map(|s| 1.0 / s);
        for k in 0..degree {
            z.par_iter_mut().zip(&d).for_each(|(zi, di)| {
                for c in 0..3 {
                    zi[c] += di[c];
                }
            });
            if k + 1 == degree {
                break;
            }
            residual(a, r, z, &mut res);
            let rho_new = [0, 1, 2].map(|c| 1.0 / (2.0 * sigma[c] - rho[c]));
            d.par_iter_mut().zip(&res).zip(&self.inv_diag).for_each(|((di, ri), inv)| {
                for c in 0..3 {
                    di[c] = rho_new[c] * rho[c] * di[c] + 2.0 * rho_new[c] / delta[c] * ri[c] * inv[c];
                }
            });
            rho = rho_new;
        }
    }
}

impl Multigrid {
    /// Builds the Galerkin operators of `hierarchy` for `a` (SPD, on the level-0 graph), the
    /// smoothers of every level but the coarsest and the dense Cholesky factors of the coarsest.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `a` is not the level-0 size;
    /// [`SparseError::NonPositiveDiagonal`] for a non-positive diagonal;
    /// [`SparseError::InvalidOption`] for bad options, a coarsest level above
    /// `options.max_direct`, or a coarsest operator that is not positive definite.
    pub fn new(hierarchy: Arc<Hierarchy>, a: &CsrMatrix3, options: MultigridOptions) -> Result<Self, SparseError> {
        if options.smoothing_degree == 0 || options.smoothing_degree > 16 || !(options.smoothing_ratio > 1.0) {
            return Err(SparseError::InvalidOption(format!(
                "multigrid smoothing degree {} must be 1 to 16 and ratio {} above 1",
                options.smoothing_degree, options.smoothing_ratio
            )));
        }
        let n0 = hierarchy.level(0).graph.n();
        if a.n() != n0 {
            return Err(SparseError::DimensionMismatch { what: "multigrid matrix rows", expected: n0, found: a.n() });
        }
        let levels = hierarchy.levels();
        let mut operators: Vec<CsrMatrix3> = Vec::new();
        for l in 1..levels {
            let g = galerkin(if l == 1 { a } else { &operators[l - 2] }, hierarchy.prolongation(l - 1))?;
            operators.push(g);
        }
        let mut smoothers = Vec::new();
        for l in 0..levels.saturating_sub(1) {
            smoothers.push(Smoother::new(if l == 0 { a } else { &operators[l - 1] })?);
        }
        let coarsest = if levels > 1 {
            let m = &operators[levels - 2];
            if m.n() > options.max_direct {
                return Err(SparseError::InvalidOption(format!(
                    "the coarsest level has {} vertices, above the direct-solve limit {}; build the hierarchy deeper",
                    m.n(),
                    options.max_direct
                )));
            }
            let factor = |c: usize| -> Result<Cholesky<f64, Dyn>, SparseError> {
                let dense: DMatrix<f64> = m.to_dense(c);
                Cholesky::new(dense).ok_or_else(|| {
                    SparseError::InvalidOption(format!("the coarsest Galerkin operator is not positive definite on channel {c}"))
                })
            };
            Some([factor(0)?, factor(1)?, factor(2)?])
        } else {
            None
        };
        Ok(Self { hierarchy, operators, smoothers, coarsest, options })
    }

    /// The Galerkin operator of level `l ≥ 1`.
    ///
    /// # Panics
    /// If `l` is 0 or not below the level count.
    #[must_use]
    pub fn operator(&self, l: usize) -> &CsrMatrix3 {
        &self.operators[l - 1]
    }

    /// The hierarchy the V-cycle runs on.
    #[must_use]
    pub fn hierarchy(&self) -> &Arc<Hierarchy> {
        &self.hierarchy
    }

    /// The options it was built with.
    #[must_use]
    pub fn options(&self) -> MultigridOptions {
        self.options
    }

    /// The smoother of level `l` (below the coarsest): `D⁻¹` of the level's operator and the
    /// `λmax` estimate of `D⁻¹A` (×1.1), for the GPU twin of the V-cycle.
    #[cfg(feature = "gpu")]
    pub(crate) fn smoother(&self, l: usize) -> (&[[f64; 3]], [f64; 3]) {
        (&self.smoothers[l].inv_diag, self.smoothers[l].lambda_max)
    }

    /// `A_c⁻¹` of the coarsest level per channel (dense, from its Cholesky factor, exactly
    /// symmetrised), `None` for a one-level hierarchy; for the GPU twin of the coarse solve.
    #[cfg(feature = "gpu")]
    pub(crate) fn coarsest_inverse(&self) -> Option<[DMatrix<f64>; 3]> {
        self.coarsest.as_ref().map(|f| {
            [0, 1, 2].map(|c| {
                let inv = f[c].inverse();
                (&inv + inv.transpose()) * 0.5
            })
        })
    }

    /// One V-cycle `z = B r` (the preconditioner of [`mg_pcg`]) on level 0 with matrix `a`.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] unless `a`, `r` and `z` have the level-0 size.
    pub fn vcycle(&self, a: &CsrMatrix3, r: &[[f64; 3]], z: &mut [[f64; 3]]) -> Result<(), SparseError> {
        let n = self.hierarchy.level(0).graph.n();
        for (what, len) in [("matrix rows", a.n()), ("residual length", r.len()), ("output length", z.len())] {
            if len != n {
                return Err(SparseError::DimensionMismatch { what, expected: n, found: len });
            }
        }
        self.apply(a, r, z);
        Ok(())
    }

    /// One V-cycle `z = B r` on level 0 with matrix `a`.
    fn apply(&self, a: &CsrMatrix3, r: &[[f64; 3]], z: &mut [[f64; 3]]) {
        self.cycle(0, a, r, z);
    }

    fn cycle(&self, l: usize, a: &CsrMatrix3, r: &[[f64; 3]], z: &mut [[f64; 3]]) {
        let levels = self.hierarchy.levels();
        if l + 1 == levels {
            match &self.coarsest {
                Some(f) => {
                    for c in 0..3 {
                        let rc = DVector::from_iterator(r.len(), r.iter().map(|v| v[c]));
                        let x = f[c].solve(&rc);
                        for (zi, xi) in z.iter_mut().zip(x.iter()) {
                            zi[c] = *xi;
                        }
                    }
                }
                // A one-level hierarchy: Jacobi-free fallback is never reached (levels ≥ 2 for
                // a Multigrid built on a small system has no smoother); use the identity.
                None => z.copy_from_slice(r),
            }
            return;
        }
        let sm = &self.smoothers[l];
        let (deg, ratio) = (self.options.smoothing_degree, self.options.smoothing_ratio);
        z.iter_mut().for_each(|v| *v = [0.0; 3]);
        sm.smooth(a, r, z, deg, ratio, true);
        let mut res = vec![[0.0; 3]; r.len()];
        residual(a, r, z, &mut res);
        let p = self.hierarchy.prolongation(l);
        let mut rc = vec![[0.0; 3]; p.n_coarse()];
        p.restrict(&res, &mut rc);
        let mut zc = vec![[0.0; 3]; p.n_coarse()];
        self.cycle(l + 1, &self.operators[l], &rc, &mut zc);
        p.prolong_add(&zc, z);
        sm.smooth(a, r, z, deg, ratio, false);
    }
}

/// Solves `a x = b` (three SPD channels) by CG preconditioned with one V-cycle of `mg` per
/// iteration, from the given `x` (a warm start; zeros for a cold one). Conventions as for
/// [`crate::sparse::pcg`]: per-channel scalars and stopping tests, a channel is declared
/// converged on its recomputed residual `‖b − Ax‖/‖b‖ ≤ tolerance`, `x` unchanged on error.
///
/// # Errors
/// [`SparseError::DimensionMismatch`] for sizes that do not match `mg`;
/// [`SparseError::NonFinite`] for non-finite `b` or `x`; [`SparseError::Breakdown`] if
/// `pᵀAp` or `rᵀBr` is not positive; [`SparseError::Cancelled`] when the monitor says so.
pub fn mg_pcg(
    a: &CsrMatrix3,
    b: &[[f64; 3]],
    x: &mut [[f64; 3]],
    mg: &Multigrid,
    options: &SolveOptions<'_>,
) -> Result<SolveStats, SparseError> {
    let n = mg.hierarchy.level(0).graph.n();
    for (what, len) in [("matrix rows", a.n()), ("right-hand side length", b.len()), ("initial guess length", x.len())] {
        if len != n {
            return Err(SparseError::DimensionMismatch { what, expected: n, found: len });
        }
    }
    options.validate()?;
    for (what, v) in [("right-hand side", &*b), ("initial guess", &*x)] {
        if let Some((row, channel, value)) = crate::sparse::ops::first_non_finite(v) {
            return Err(SparseError::NonFinite { what, row, channel, value });
        }
    }
    let tol = options.tolerance;
    let bn = norm3(b);
    let mut xw = x.to_vec();
    for v in &mut xw {
        for c in 0..3 {
            if bn[c] == 0.0 {
                v[c] = 0.0;
            }
        }
    }
    let rel = |rr: [f64; 3]| [0, 1, 2].map(|c| if bn[c] > 0.0 { rr[c].sqrt() / bn[c] } else { 0.0 });
    let mut r = vec![[0.0; 3]; n];
    residual(a, b, &xw, &mut r);
    let mut relres = rel(dot3(&r, &r));
    let mut active = [0, 1, 2].map(|c| bn[c] > 0.0 && relres[c] > tol);
    let mut iterations = [0usize; 3];
    let mut it = 0;
    let mut restarts = 0;
    'outer: while active.iter().any(|&t| t) && it < options.max_iterations {
        let mut z = vec![[0.0; 3]; n];
        mg.apply(a, &r, &mut z);
        let mut rz = dot3(&r, &z);
        let mut p = z.clone();
        let mut q = vec![[0.0; 3]; n];
        while it < options.max_iterations {
            it += 1;
            for c in 0..3 {
                if active[c] && !(rz[c] > 0.0 && rz[c].is_finite()) {
                    return Err(SparseError::Breakdown { method: "MG-PCG", channel: c, iteration: it, reason: format!("rᵀBr = {:e}", rz[c]) });
                }
            }
            spmv(a, &p, &mut q);
            let pq = dot3(&p, &q);
            let mut alpha = [0.0; 3];
            for c in 0..3 {
                if active[c] {
                    if !(pq[c] > 0.0 && pq[c].is_finite()) {
                        return Err(SparseError::Breakdown { method: "MG-PCG", channel: c, iteration: it, reason: format!("pᵀAp = {:e}", pq[c]) });
                    }
                    alpha[c] = rz[c] / pq[c];
                    iterations[c] += 1;
                }
            }
            xw.par_iter_mut().zip(&p).for_each(|(xi, pi)| {
                for c in 0..3 {
                    xi[c] += alpha[c] * pi[c];
                }
            });
            r.par_iter_mut().zip(&q).for_each(|(ri, qi)| {
                for c in 0..3 {
                    ri[c] -= alpha[c] * qi[c];
                }
            });
            relres = rel(dot3(&r, &r));
            if let Some(m) = options.monitor {
                if !m(it, relres) {
                    return Err(SparseError::Cancelled { iteration: it });
                }
            }
            for c in 0..3 {
                if active[c] && relres[c] <= tol {
                    active[c] = false;
                }
            }
            if !active.iter().any(|&t| t) {
                break;
            }
            mg.apply(a, &r, &mut z);
            let rz_new = dot3(&r, &z);
            let beta = [0, 1, 2].map(|c| if active[c] { rz_new[c] / rz[c] } else { 0.0 });
            rz = rz_new;
            p.par_iter_mut().zip(&z).for_each(|(pi, zi)| {
                for c in 0..3 {
                    pi[c] = if active[c] { zi[c] + beta[c] * pi[c] } else { 0.0 };
                }
            });
        }
        // Confirm on the true residual; restart the channels that drifted.
        residual(a, b, &xw, &mut r);
        relres = rel(dot3(&r, &r));
        active = [0, 1, 2].map(|c| bn[c] > 0.0 && relres[c] > tol);
        if !active.iter().any(|&t| t) {
            break 'outer;
        }
        restarts += 1;
        if restarts > 3 {
            break;
        }
    }
    residual(a, b, &xw, &mut r);
    let relative_residual = rel(dot3(&r, &r));
    let converged_channels = [0, 1, 2].map(|c| bn[c] == 0.0 || relative_residual[c] <= tol);
    x.copy_from_slice(&xw);
    Ok(SolveStats { iterations, relative_residual, converged_channels, converged: converged_channels.iter().all(|&t| t) })
}
