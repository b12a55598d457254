//! Preconditioned conjugate gradients for three SPD systems (R, G, B) on one pattern.
//!
//! One iteration is three parallel passes over memory:
//! 1. `q = A p` fused with `pᵀq` (the SpMV streams the pattern once for the three channels);
//! 2. `x += α p`, `r −= α q`, `‖r‖²` and, with Jacobi, `rᵀD⁻¹r` (z is never stored);
//! 3. `p = z + β p` (with Jacobi, `z = D⁻¹ r` on the fly).
//!
//! Each channel has its own α, β and stopping test; a converged channel gets α = 0 from then
//! on, so its `x` and `r` stop changing, while the loop continues for the others. When every
//! channel's recursively updated residual has met the tolerance, the true residual `b − Ax` is
//! computed once; a channel whose true residual misses the tolerance (rounding drift, rare) is
//! restarted from it.

use rayon::prelude::*;

use super::ops::{row_mul, sum_partials, CHUNK};
use super::precond::{PrecondWork, Preconditioner};
use super::{check_inputs, relative, residual, CsrMatrix3, SolveOptions, SolveStats, SparseError};

/// How often the true-residual check may restart channels before giving up.
const MAX_RESTARTS: usize = 3;

/// Solves `A x = b` for the three channels by preconditioned CG, starting from the given `x`
/// (a warm start; pass zeros for a cold one). `A` must be symmetric positive definite on every
/// channel, and so must the preconditioner (Jacobi and Chebyshev are, for SPD `A`).
///
/// A channel whose right-hand side is zero gets `x = 0` at once (0 iterations). On success `x`
/// holds the solution, also when the iteration limit was hit (`converged == false` then); on
/// error `x` is left unchanged.
///
/// # Errors
/// * [`SparseError::DimensionMismatch`] if `b`, `x` or the preconditioner do not match `A`;
/// * [`SparseError::NonFinite`] naming the row and channel of a NaN/infinite value in `b`, `x`
///   or `A`;
/// * [`SparseError::InvalidOption`] for a negative or NaN tolerance;
/// * [`SparseError::Breakdown`] naming the channel and iteration where `pᵀAp ≤ 0` (`A` not
///   positive definite) or `rᵀM⁻¹r ≤ 0` (preconditioner not positive definite);
/// * [`SparseError::Cancelled`] when the monitor returns `false`.
pub fn pcg(
    a: &CsrMatrix3,
    b: &[[f64; 3]],
    x: &mut [[f64; 3]],
    precond: &Preconditioner,
    options: &SolveOptions<'_>,
) -> Result<SolveStats, SparseError> {
    let bn = check_inputs(a, b, x, precond, options)?;
    let n = a.n();
    let tol = options.tolerance;
    let max_it = options.max_iterations;
    let mut xw = x.to_vec();
    zero_channels(&mut xw, bn);
    let mut r = vec![[0.0; 3]; n];
    let mut rel = relative(residual(a, b, &xw, &mut r), bn);
    let mut active = [0, 1, 2].map(|c| bn[c] > 0.0 && rel[c] > tol);
    let mut iterations = [0usize; 3];
    if active.iter().any(|&t| t) {
        let jacobi = match precond {
            Preconditioner::Jacobi(j) => Some(j.inv_diag()),
            _ => None,
        };
        let mut p = vec![[0.0; 3]; n];
        let mut q = vec![[0.0; 3]; n];
        let mut z = if jacobi.is_some() { Vec::new() } else { vec![[0.0; 3]; n] };
        let mut work = PrecondWork::default();
        let mut rho = precond.apply_dot(&r, &mut p, &mut work);
        check_rho(rho, active, 0)?;
        let mut restarts = 0;
        let mut it = 0;
        let mut rel_is_true = false;
        while it < max_it {
            it += 1;
            let pq = spmv_dot(a, &p, &mut q);
            let mut alpha = [0.0; 3];
            for c in 0..3 {
                if active[c] {
                    if !(pq[c] > 0.0 && pq[c].is_finite()) {
                        return Err(SparseError::Breakdown {
                            method: "PCG",
                            channel: c,
                            iteration: it,
                            reason: format!("pᵀAp = {:e} ≤ 0: the matrix is not positive definite", pq[c]),
                        });
                    }
                    alpha[c] = rho[c] / pq[c];
                }
            }
            let (rr, rz) = match jacobi {
                Some(d) => update_jacobi(&mut xw, &mut r, &p, &q, d, alpha),
                None => (update(&mut xw, &mut r, &p, &q, alpha), [0.0; 3]),
            };
            rel_is_true = false;
            for c in 0..3 {
                if active[c] {
                    iterations[c] += 1;
                    rel[c] = rr[c].sqrt() / bn[c];
                    if rel[c] <= tol {
                        active[c] = false;
                    }
                }
            }
            if let Some(m) = options.monitor {
                if !m(it, rel) {
                    return Err(SparseError::Cancelled { iteration: it });
                }
            }
            if !active.iter().any(|&t| t) {
                // Every channel met the tolerance by its recursive residual: check the true one.
                rel = relative(residual(a, b, &xw, &mut r), bn);
                rel_is_true = true;
                let again = [0, 1, 2].map(|c| bn[c] > 0.0 && rel[c] > tol);
                if !again.iter().any(|&t| t) || restarts == MAX_RESTARTS {
                    break;
                }
                restarts += 1;
                active = again;
                rho = precond.apply_dot(&r, &mut p, &mut work);
                check_rho(rho, active, it)?;
                continue;
            }
            if it == max_it {
                break;
            }
            let rho_new = match jacobi {
                Some(_) => rz,
                None => precond.apply_dot(&r, &mut z, &mut work),
            };
            check_rho(rho_new, active, it)?;
            let mut beta = [0.0; 3];
            for c in 0..3 {
                if active[c] {
                    beta[c] = rho_new[c] / rho[c];
                    rho[c] = rho_new[c];
                }
            }
            match jacobi {
                Some(d) => p_update_jacobi(&mut p, &r, d, beta),
                None => p_update(&mut p, &z, beta),
            }
        }
        if !rel_is_true {
            rel = relative(residual(a, b, &xw, &mut r), bn);
        }
    }
    x.copy_from_slice(&xw);
    Ok(make_stats(iterations, rel, tol))
}

pub(crate) fn make_stats(iterations: [usize; 3], rel: [f64; 3], tol: f64) -> SolveStats {
    let converged_channels = rel.map(|r| r <= tol);
    SolveStats {
        iterations,
        relative_residual: rel,
        converged_channels,
        converged: converged_channels.iter().all(|&c| c),
    }
}

/// Sets the channels whose right-hand side is zero to zero.
pub(crate) fn zero_channels(x: &mut [[f64; 3]], bn: [f64; 3]) {
    for c in 0..3 {
        if bn[c] == 0.0 {
            x.par_iter_mut().for_each(|v| v[c] = 0.0);
        }
    }
}

fn check_rho(rho: [f64; 3], active: [bool; 3], iteration: usize) -> Result<(), SparseError> {
    for c in 0..3 {
        if active[c] && !(rho[c] > 0.0 && rho[c].is_finite()) {
            return Err(SparseError::Breakdown {
                method: "PCG",
                channel: c,
                iteration,
                reason: format!("rᵀM⁻¹r = {:e} ≤ 0: the preconditioner is not positive definite", rho[c]),
            });
        }
    }
    Ok(())
}

/// `q = A p`; returns `pᵀq` per channel.
pub(crate) fn spmv_dot(a: &CsrMatrix3, p: &[[f64; 3]], q: &mut [[f64; 3]]) -> [f64; 3] {
    let pat = a.pattern();
    let vals = a.values();
    let (rp, ci) = (pat.row_ptr(), pat.col_idx());
    let parts: Vec<[f64; 3]> = q
        .par_chunks_mut(CHUNK)
        .enumerate()
        .map(|(k, qc)| {
            let r0 = k * CHUNK;
            let mut s = [0.0; 3];
            for (li, qi) in qc.iter_mut().enumerate() {
                let i = r0 + li;
                let (s0, e0) = (rp[i], rp[i + 1]);
                let v = row_mul(&ci[s0..e0], &vals[s0..e0], p);
                let pi = p[i];
                for c in 0..3 {
                    s[c] += pi[c] * v[c];
                }
                *qi = v;
            }
            s
        })
        .collect();
    sum_partials(&parts)
}

/// `x += α p`, `r −= α q`; returns `(‖r‖², rᵀD⁻¹r)`.
fn update_jacobi(
    x: &mut [[f64; 3]],
    r: &mut [[f64; 3]],
    p: &[[f64; 3]],
    q: &[[f64; 3]],
    dinv: &[[f64; 3]],
    alpha: [f64; 3],
) -> ([f64; 3], [f64; 3]) {
    let parts: Vec<[f64; 6]> = (
        x.par_chunks_mut(CHUNK),
        r.par_chunks_mut(CHUNK),
        p.par_chunks(CHUNK),
        q.par_chunks(CHUNK),
        dinv.par_chunks(CHUNK),
    )
        .into_par_iter()
        .map(|(x, r, p, q, d)| {
            let mut s = [0.0; 6];
            for ((((x, r), p), q), d) in x.iter_mut().zip(r.iter_mut()).zip(p).zip(q).zip(d) {
                for c in 0..3 {
                    x[c] += alpha[c] * p[c];
                    r[c] -= alpha[c] * q[c];
                    s[c] += r[c] * r[c];
                    s[3 + c] += r[c] * r[c] * d[c];
                }
            }
            s
        })
        .collect();
    let s = sum_partials(&parts);
    ([s[0], s[1], s[2]], [s[3], s[4], s[5]])
}

/// `x += α p`, `r −= α q`; returns `‖r‖²`.
pub(crate) fn update(x: &mut [[f64; 3]], r: &mut [[f64; 3]], p: &[[f64; 3]], q: &[[f64; 3]], alpha: [f64; 3]) -> [f64; 3] {
    let parts: Vec<[f64; 3]> = (x.par_chunks_mut(CHUNK), r.par_chunks_mut(CHUNK), p.par_chunks(CHUNK), q.par_chunks(CHUNK))
        .into_par_iter()
        .map(|(x, r, p, q)| {
            let mut s = [0.0; 3];
            for (((x, r), p), q) in x.iter_mut().zip(r.iter_mut()).zip(p).zip(q) {
                for c in 0..3 {
                    x[c] += alpha[c] * p[c];
                    r[c] -= alpha[c] * q[c];
                    s[c] += r[c] * r[c];
                }
            }
            s
        })
        .collect();
    sum_partials(&parts)
}

/// `p = D⁻¹ r + β p`.
fn p_update_jacobi(p: &mut [[f64; 3]], r: &[[f64; 3]], dinv: &[[f64; 3]], beta: [f64; 3]) {
    (p.par_chunks_mut(CHUNK), r.par_chunks(CHUNK), dinv.par_chunks(CHUNK)).into_par_iter().for_each(|(p, r, d)| {
        for ((p, r), d) in p.iter_mut().zip(r).zip(d) {
            for c in 0..3 {
                p[c] = d[c] * r[c] + beta[c] * p[c];
            }
        }
    });
}

/// `p = z + β p`.
fn p_update(p: &mut [[f64; 3]], z: &[[f64; 3]], beta: [f64; 3]) {
    (p.par_chunks_mut(CHUNK), z.par_chunks(CHUNK)).into_par_iter().for_each(|(p, z)| {
        for (p, z) in p.iter_mut().zip(z) {
            for c in 0..3 {
                p[c] = z[c] + beta[c] * p[c];
            }
        }
    });
}
