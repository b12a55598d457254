//! BiCGSTAB (van der Vorst 1992) for three nonsymmetric systems on one pattern, right
//! preconditioned (so the residual it tests is the true, unpreconditioned one).
//!
//! Like [`pcg`](super::pcg), the three channels iterate together with their own scalars and
//! stopping tests; a converged channel stops changing. A channel may also converge at the half
//! step (`s = r − αv` already small), as in the original algorithm.

use rayon::prelude::*;

use super::ops::{spmv_dot, spmv_fold, sum_partials, CHUNK};
use super::pcg::{make_stats, zero_channels};
use super::precond::{PrecondWork, Preconditioner};
use super::{check_inputs, relative, residual, restart, unconverged, CsrMatrix3, SolveOptions, SolveStats, SparseError};

fn breakdown(channel: usize, iteration: usize, reason: String) -> SparseError {
    SparseError::Breakdown { method: "BiCGSTAB", channel, iteration, reason }
}

/// Solves `A x = b` for the three channels by right-preconditioned BiCGSTAB, starting from the
/// given `x`. `A` need not be symmetric; any nonsingular matrix with a positive diagonal (for
/// Jacobi) works, diagonally dominant ones best. Jacobi is the recommended preconditioner here
/// (Chebyshev assumes a real spectrum).
///
/// Conventions as for [`pcg`](super::pcg): zero right-hand-side channels return zero at once,
/// `relative_residual` is the true final residual, `x` is unchanged on error.
///
/// # Errors
/// * [`SparseError::DimensionMismatch`], [`SparseError::PatternMismatch`],
///   [`SparseError::NonFinite`], [`SparseError::InvalidOption`] for bad inputs, as for
///   [`pcg`](super::pcg);
/// * [`SparseError::Breakdown`] naming the channel and iteration when `r̂ᵀr`, `r̂ᵀv` or `ω`
///   vanishes (or turns non-finite);
/// * [`SparseError::Cancelled`] when the monitor returns `false`.
#[allow(clippy::too_many_lines)]
pub fn bicgstab(
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
    let rr0 = residual(a, b, &xw, &mut r);
    let mut rel = relative(rr0, bn);
    let mut active = unconverged(rel, bn, tol);
    let mut iterations = [0usize; 3];
    if active.iter().any(|&t| t) {
        let zeros = || vec![[0.0; 3]; n];
        let mut rhat = r.clone();
        let (mut p, mut v, mut phat, mut shat, mut t) = (zeros(), zeros(), zeros(), zeros(), zeros());
        let mut work = PrecondWork::default();
        let mut rho = [1.0; 3];
        let mut alpha = [1.0; 3];
        let mut omega = [1.0; 3];
        let mut rho_new = rr0;
        let mut restarts = 0;
        let mut rel_is_true = false;
        let mut it = 0;
        while it < max_it {
            it += 1;
            rel_is_true = false;
            let mut beta = [0.0; 3];
            for c in 0..3 {
                if active[c] {
                    if !(rho_new[c] != 0.0 && rho_new[c].is_finite()) {
                        return Err(breakdown(c, it, format!("r̂ᵀr = {:e}", rho_new[c])));
                    }
                    beta[c] = (rho_new[c] / rho[c]) * (alpha[c] / omega[c]);
                    rho[c] = rho_new[c];
                }
            }
            // p = r + β (p − ω v)
            (p.par_chunks_mut(CHUNK), r.par_chunks(CHUNK), v.par_chunks(CHUNK)).into_par_iter().for_each(|(p, r, v)| {
                for ((p, r), v) in p.iter_mut().zip(r).zip(v) {
                    for c in 0..3 {
                        p[c] = r[c] + beta[c] * (p[c] - omega[c] * v[c]);
                    }
                }
            });
            precond.apply_dot(&p, &mut phat, &mut work);
            let rv = spmv_dot(a.pattern(), a.values(), &phat, &mut v, &rhat);
            let mut half = [false; 3];
            for c in 0..3 {
                alpha[c] = 0.0;
                if active[c] {
                    if !(rv[c] != 0.0 && rv[c].is_finite()) {
                        return Err(breakdown(c, it, format!("r̂ᵀv = {:e}", rv[c])));
                    }
                    alpha[c] = rho[c] / rv[c];
                }
            }
            // s = r − α v (in r); ‖s‖²
            let ss = axpy_norm(&mut r, &v, alpha);
            for c in 0..3 {
                if active[c] && ss[c].sqrt() / bn[c] <= tol {
                    half[c] = true;
                }
            }
            precond.apply_dot(&r, &mut shat, &mut work);
            let [ts, tt] = spmv_two_dots(a, &shat, &mut t, &r);
            let mut om = [0.0; 3];
            for c in 0..3 {
                if active[c] && !half[c] {
                    if !(tt[c] > 0.0 && tt[c].is_finite()) {
                        return Err(breakdown(c, it, format!("‖A M⁻¹ s‖² = {:e}", tt[c])));
                    }
                    om[c] = ts[c] / tt[c];
                    if !(om[c] != 0.0 && om[c].is_finite()) {
                        return Err(breakdown(c, it, format!("ω = {:e} (stagnation)", om[c])));
                    }
                }
            }
            // x += α p̂ + ω ŝ; r = s − ω t; ‖r‖², r̂ᵀr
            let (rr, rhr) = final_update(&mut xw, &mut r, &phat, &shat, &t, &rhat, alpha, om);
            for c in 0..3 {
                if active[c] {
                    omega[c] = om[c];
                    iterations[c] += 1;
                    rel[c] = rr[c].sqrt() / bn[c];
                    if half[c] || rel[c] <= tol {
                        active[c] = false;
                    }
                }
            }
            rho_new = rhr;
            options.report(it, rel)?;
            if !active.iter().any(|&t| t) {
                rel = relative(residual(a, b, &xw, &mut r), bn);
                rel_is_true = true;
                let Some(again) = restart(rel, bn, tol, &mut restarts) else { break };
                active = again;
                rhat.copy_from_slice(&r);
                p.fill([0.0; 3]);
                v.fill([0.0; 3]);
                rho = [1.0; 3];
                alpha = [1.0; 3];
                omega = [1.0; 3];
                rho_new = super::dot3(&r, &r);
            }
        }
        if !rel_is_true {
            rel = relative(residual(a, b, &xw, &mut r), bn);
        }
    }
    x.copy_from_slice(&xw);
    Ok(make_stats(iterations, rel, tol))
}

/// `y = A x`; returns `[yᵀw, yᵀy]` per channel.
fn spmv_two_dots(a: &CsrMatrix3, x: &[[f64; 3]], y: &mut [[f64; 3]], w: &[[f64; 3]]) -> [[f64; 3]; 2] {
    let s = spmv_fold(a.pattern(), a.values(), x, y, |i, v, yi| {
        *yi = v;
        let wi = w[i];
        [wi[0] * v[0], wi[1] * v[1], wi[2] * v[2], v[0] * v[0], v[1] * v[1], v[2] * v[2]]
    });
    [[s[0], s[1], s[2]], [s[3], s[4], s[5]]]
}

/// `r −= α v`; returns `‖r‖²`.
fn axpy_norm(r: &mut [[f64; 3]], v: &[[f64; 3]], alpha: [f64; 3]) -> [f64; 3] {
    let parts: Vec<[f64; 3]> = (r.par_chunks_mut(CHUNK), v.par_chunks(CHUNK))
        .into_par_iter()
        .map(|(r, v)| {
            let mut s = [0.0; 3];
            for (r, v) in r.iter_mut().zip(v) {
                for c in 0..3 {
                    r[c] -= alpha[c] * v[c];
                    s[c] += r[c] * r[c];
                }
            }
            s
        })
        .collect();
    sum_partials(&parts)
}

/// `x += α p̂ + ω ŝ`, `r −= ω t`; returns `(‖r‖², r̂ᵀr)`.
#[allow(clippy::too_many_arguments)]
fn final_update(
    x: &mut [[f64; 3]],
    r: &mut [[f64; 3]],
    phat: &[[f64; 3]],
    shat: &[[f64; 3]],
    t: &[[f64; 3]],
    rhat: &[[f64; 3]],
    alpha: [f64; 3],
    omega: [f64; 3],
) -> ([f64; 3], [f64; 3]) {
    let parts: Vec<[f64; 6]> = (
        x.par_chunks_mut(CHUNK),
        r.par_chunks_mut(CHUNK),
        phat.par_chunks(CHUNK),
        shat.par_chunks(CHUNK),
        t.par_chunks(CHUNK),
        rhat.par_chunks(CHUNK),
    )
        .into_par_iter()
        .map(|(x, r, ph, sh, t, rh)| {
            let mut s = [0.0; 6];
            for i in 0..x.len() {
                for c in 0..3 {
                    x[i][c] += alpha[c] * ph[i][c] + omega[c] * sh[i][c];
                    r[i][c] -= omega[c] * t[i][c];
                    s[c] += r[i][c] * r[i][c];
                    s[3 + c] += rh[i][c] * r[i][c];
                }
            }
            s
        })
        .collect();
    let s = sum_partials(&parts);
    ([s[0], s[1], s[2]], [s[3], s[4], s[5]])
}
