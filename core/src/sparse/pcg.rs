//! Preconditioned conjugate gradients for three SPD systems (R, G, B) on one pattern.
//!
//! Each channel has its own α, β and stopping test; a converged channel gets α = 0 from then
//! on, so its `x` and `r` stop changing, while the loop continues for the others. No scalar or
//! vector ever mixes channels, so a channel's iterates do not depend on the other two (except
//! through the one global decision below to finish a mixed-precision solve in `f64`).
//!
//! Two paths ([`Precision`]), the mixed one with a variant for SSOR:
//!
//! * **Mixed** (default, Jacobi or Chebyshev): CG on `Â ŷ = S b`, `Â = S A S`, `S = D^-½`,
//!   `x = S ŷ`, with `Â` stored in `f32`. One iteration is three parallel passes:
//!   `q = Â p` fused with `pᵀq`; `ŷ += α p`, `r̂ −= α q` fused with `‖r̂‖²` and the unscaled
//!   `‖r‖² = Σ D r̂²`; `p = z + β p` (`z = r̂` for Jacobi, `z = p(Â) r̂` for Chebyshev). When a
//!   channel's residual estimate has dropped a hundredfold since its last recomputation, or meets
//!   the tolerance, its residual is recomputed in `f64` from `A` ("reliable update",
//!   Sleijpen & van der Vorst 1996) and replaces the recursive one; only a recomputed residual
//!   can declare a channel converged. It is also recomputed every 100 iterations; if it exceeds
//!   the recursive estimate four-fold, the `f32` operator no longer resolves what is left (a
//!   tolerance near `f32`'s limit for the conditioning, or a badly scaled system) and the solve
//!   continues in `f64` from the current iterate.
//! * **Mixed with [`super::Ssor`]**: CG on the SSOR-split system with Eisenstat's trick, in
//!   `f64` (two sweeps per iteration; see the `eisenstat_cg` module), reusing this module's
//!   stopping machinery.
//! * **Double**: everything in `f64` on `A`: `q = A p` with `pᵀq`; `x += α p`, `r −= α q` with
//!   `‖r‖²` and, for Jacobi, `rᵀD⁻¹r` (z is never stored); `p = z + β p`. When every channel's
//!   recursive residual meets the tolerance, the true residual is computed once and a channel
//!   that misses it (rounding drift, rare) is restarted from it.

use rayon::prelude::*;

use super::ops::{spmv_dot, sum_partials, Load3, CHUNK};
use super::precond::{Chebyshev, PrecondWork, Preconditioner};
use super::scaled::{reliable_residual, ScaledOperator};
use super::{
    check_inputs, relative, residual, restart, unconverged, CsrMatrix3, Precision, SolveOptions, SolveStats, SparseError,
};

/// Solves `A x = b` for the three channels by preconditioned CG, starting from the given `x`
/// (a warm start; pass zeros for a cold one). `A` must be symmetric positive definite on every
/// channel, and so must the preconditioner (Jacobi, Chebyshev and SSOR are, for SPD `A`).
///
/// A channel whose right-hand side is zero gets `x = 0` at once (0 iterations). On success `x`
/// holds the solution, also when the iteration limit was hit (`converged == false` then); on
/// error `x` is left unchanged. `options.precision` chooses the arithmetic (see the module
/// documentation of [`Precision`]); either way a channel is declared converged only on its
/// residual `b − Ax` recomputed in `f64`, which `SolveStats::relative_residual` reports.
///
/// The preconditioner must have been built from this matrix (its current values).
///
/// # Errors
/// * [`SparseError::DimensionMismatch`] if `b`, `x` or the preconditioner do not match `A`,
///   [`SparseError::PatternMismatch`] if the preconditioner was built on another pattern;
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
    let (op, cheb) = match (options.precision, precond) {
        (Precision::Mixed, Preconditioner::Jacobi(j)) => (j.operator(), None),
        (Precision::Mixed, Preconditioner::Chebyshev(c)) => (c.operator(), Some(c)),
        (Precision::Mixed, Preconditioner::Ssor(m)) => {
            return match super::eisenstat_cg::pcg_eisenstat(a, b, x, m, options, bn)? {
                Mixed::Done(stats) => Ok(stats),
                Mixed::Stagnated { x: x0, progress } => pcg_double(a, b, &x0, x, precond, options, bn, progress),
            };
        }
        _ => {
            let x0 = x.to_vec();
            return pcg_double(a, b, &x0, x, precond, options, bn, Progress::default());
        }
    };
    match pcg_mixed(a, b, x, op, cheb, options, bn)? {
        Mixed::Done(stats) => Ok(stats),
        // The f32 operator's rounding limits the attainable residual (a tolerance near the
        // conditioning limit of f32, or a badly scaled system): finish in f64 from here.
        Mixed::Stagnated { x: x0, progress } => pcg_double(a, b, &x0, x, precond, options, bn, progress),
    }
}

/// Where a solve continues from: the iteration number and the per-channel iteration counts.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Progress {
    pub(super) iteration: usize,
    pub(super) iterations: [usize; 3],
}

/// The outcome of the mixed-precision iteration.
pub(super) enum Mixed {
    Done(SolveStats),
    /// The recursive residual drifted from the true one: continue from `x` in `f64`.
    Stagnated {
        x: Vec<[f64; 3]>,
        progress: Progress,
    },
}

/// The `f64` PCG on the original matrix (Jacobi fused into the vector updates), from `x0`,
/// writing the solution to `x` on success; `start` continues the counts of an earlier phase.
#[allow(clippy::too_many_arguments)]
fn pcg_double(
    a: &CsrMatrix3,
    b: &[[f64; 3]],
    x0: &[[f64; 3]],
    x: &mut [[f64; 3]],
    precond: &Preconditioner,
    options: &SolveOptions<'_>,
    bn: [f64; 3],
    start: Progress,
) -> Result<SolveStats, SparseError> {
    let n = a.n();
    let tol = options.tolerance;
    let max_it = options.max_iterations;
    let mut xw = x0.to_vec();
    zero_channels(&mut xw, bn);
    let mut r = vec![[0.0; 3]; n];
    let mut rel = relative(residual(a, b, &xw, &mut r), bn);
    let mut active = unconverged(rel, bn, tol);
    let mut iterations = start.iterations;
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
        check_rho(rho, active, start.iteration)?;
        let mut restarts = 0;
        let mut it = start.iteration;
        let mut rel_is_true = false;
        while it < max_it {
            it += 1;
            let pq = spmv_dot(a.pattern(), a.values(), &p, &mut q, &p);
            let alpha = step_lengths(rho, pq, active, it)?;
            let (rr, rz) = match jacobi {
                Some(d) => update_weighted(&mut xw, &mut r, &p, &q, d, alpha),
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
            options.report(it, rel)?;
            if !active.iter().any(|&t| t) {
                // Every channel met the tolerance by its recursive residual: check the true one.
                rel = relative(residual(a, b, &xw, &mut r), bn);
                rel_is_true = true;
                let Some(again) = restart(rel, bn, tol, &mut restarts) else { break };
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
            let beta = next_beta(&mut rho, rho_new, active, it)?;
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

/// In mixed precision, the residual is recomputed in `f64` when its estimate has dropped by
/// this factor since the last recomputation: a smaller factor recomputes less often and lets
/// the recursive residual drift further between recomputations.
const RELIABLE_FACTOR: f64 = 0.01;

/// In mixed precision, a channel's residual is also recomputed after this many iterations
/// without one (so that a drifting estimate that stalls is caught).
pub(super) const RELIABLE_PERIOD: usize = 100;

/// When a recomputed residual exceeds the recursive estimate by more than this factor, the
/// `f32` operator no longer resolves the remaining residual: the solve continues in `f64`.
pub(super) const DRIFT_LIMIT: f64 = 4.0;

/// Mixed-precision PCG on the scaled system `Â ŷ = S b` (`Â = S A S` in `f32`, `x = S ŷ`), with
/// an optional Chebyshev polynomial in `Â` as preconditioner. The residual estimate (in the
/// unscaled norm, through `D`) drives the iteration; the `f64` residual `S (b − A S ŷ)` replaces
/// the recursive one whenever the estimate has dropped by [`RELIABLE_FACTOR`] or meets the
/// tolerance, and only such a recomputed residual can declare a channel converged.
#[allow(clippy::too_many_lines)]
fn pcg_mixed(
    a: &CsrMatrix3,
    b: &[[f64; 3]],
    x: &mut [[f64; 3]],
    op: &ScaledOperator,
    cheb: Option<&Chebyshev>,
    options: &SolveOptions<'_>,
    bn: [f64; 3],
) -> Result<Mixed, SparseError> {
    let n = a.n();
    let tol = options.tolerance;
    let max_it = options.max_iterations;
    let s = &op.s;
    let mut y: Vec<[f64; 3]> = x.par_iter().zip(s).map(|(x, s)| [0, 1, 2].map(|c| x[c] / s[c])).collect();
    zero_channels(&mut y, bn);
    let mut rh = vec![[0.0; 3]; n];
    let (rr, mut rho_plain) = reliable_residual(a, b, s, &y, &mut rh, [true; 3]);
    let mut rel = relative(rr, bn);
    let mut active = unconverged(rel, bn, tol);
    // Channels whose x is rewritten from ŷ (the others keep the caller's bits exactly).
    let touched = [0, 1, 2].map(|c| active[c] || bn[c] == 0.0);
    let mut iterations = [0usize; 3];
    if active.iter().any(|&t| t) {
        let mut last_true = rel;
        let mut p = vec![[0.0; 3]; n];
        let mut q = vec![[0.0; 3]; n];
        let mut z = if cheb.is_some() { vec![[0.0; 3]; n] } else { Vec::new() };
        let mut work = PrecondWork::default();
        let mut rho = match cheb {
            None => {
                p.copy_from_slice(&rh);
                rho_plain
            }
            Some(c) => c.apply_scaled(&rh, &mut p, None, &mut work),
        };
        check_rho(rho, active, 0)?;
        let mut it = 0;
        let mut rel_is_true = true;
        let mut last_recompute = [0usize; 3];
        while it < max_it {
            it += 1;
            let pq = op.spmv_dot(&p, &mut q);
            let alpha = step_lengths(rho, pq, active, it)?;
            // `‖r̂‖²` and `Σ D r̂²`, the unscaled `‖r‖²`.
            let (rhrh, rr_est) = update_weighted(&mut y, &mut rh, &p, &q, &op.d, alpha);
            rho_plain = rhrh;
            let est = relative(rr_est, bn);
            // Per channel, so that each channel's iterates do not depend on the others.
            let recompute = [0, 1, 2].map(|c| {
                active[c]
                    && (est[c] <= tol || est[c] <= RELIABLE_FACTOR * last_true[c] || it - last_recompute[c] >= RELIABLE_PERIOD)
            });
            let mut checked = est;
            if recompute.iter().any(|&t| t) {
                let (rr, rhrh) = reliable_residual(a, b, s, &y, &mut rh, recompute);
                checked = relative(rr, bn);
                let t = checked;
                for c in 0..3 {
                    if recompute[c] {
                        if t[c] > tol && t[c] > DRIFT_LIMIT * est[c] {
                            let x = y.iter().zip(s).map(|(y, s)| [0, 1, 2].map(|k| y[k] * s[k])).collect();
                            let progress = Progress { iteration: it, iterations };
                            return Ok(Mixed::Stagnated { x, progress });
                        }
                        rho_plain[c] = rhrh[c];
                        last_true[c] = t[c];
                        last_recompute[c] = it;
                    }
                }
                // Channels not recomputed now still count as true only if inactive.
                rel_is_true = (0..3).all(|c| !active[c] || recompute[c]);
            } else {
                rel_is_true = false;
            }
            end_iteration(it, &mut active, recompute, (checked, est), &mut rel, &mut iterations, tol, options)?;
            if !active.iter().any(|&t| t) || it == max_it {
                break;
            }
            let rho_new = match cheb {
                None => rho_plain,
                Some(c) => c.apply_scaled(&rh, &mut z, None, &mut work),
            };
            let beta = next_beta(&mut rho, rho_new, active, it)?;
            p_update(&mut p, if cheb.is_some() { &z } else { &rh }, beta);
        }
        if !rel_is_true {
            let (rr, _) = reliable_residual(a, b, s, &y, &mut rh, [false; 3]);
            let t = relative(rr, bn);
            for c in 0..3 {
                if active[c] {
                    rel[c] = t[c];
                }
            }
        }
    }
    x.par_iter_mut().zip(&y).zip(s).for_each(|((x, y), s)| {
        for c in 0..3 {
            if touched[c] {
                x[c] = y[c] * s[c];
            }
        }
    });
    Ok(Mixed::Done(make_stats(iterations, rel, tol)))
}

pub(crate) fn make_stats(iterations: [usize; 3], rel: [f64; 3], tol: f64) -> SolveStats {
    let converged_channels = rel.map(|r| r <= tol);
    SolveStats { iterations, relative_residual: rel, converged_channels, converged: converged_channels.iter().all(|&c| c) }
}

/// Sets the channels whose right-hand side is zero to zero.
pub(crate) fn zero_channels(x: &mut [[f64; 3]], bn: [f64; 3]) {
    for c in 0..3 {
        if bn[c] == 0.0 {
            x.par_iter_mut().for_each(|v| v[c] = 0.0);
        }
    }
}

/// `α = ρ / pᵀAp` for the active channels (0 for the others).
///
/// # Errors
/// [`SparseError::Breakdown`] naming the channel where `pᵀAp` is not positive and finite.
pub(super) fn step_lengths(rho: [f64; 3], pq: [f64; 3], active: [bool; 3], iteration: usize) -> Result<[f64; 3], SparseError> {
    let mut alpha = [0.0; 3];
    for c in 0..3 {
        if active[c] {
            if !(pq[c] > 0.0 && pq[c].is_finite()) {
                return Err(SparseError::Breakdown {
                    method: "PCG",
                    channel: c,
                    iteration,
                    reason: breakdown_reason("pᵀAp", pq[c], "the matrix is not positive definite"),
                });
            }
            alpha[c] = rho[c] / pq[c];
        }
    }
    Ok(alpha)
}

/// Closes iteration `it` of the mixed-precision solvers: each active channel reports its
/// relative residual in `rel` (the recomputed true one, `checked`, where `recompute` says it
/// was recomputed, the recurrence's estimate `est` elsewhere), counts the iteration, and
/// retires if its true residual meets the tolerance; then the monitor is called with `rel`.
///
/// # Errors
/// [`SparseError::Cancelled`] when the monitor returns `false`.
#[allow(clippy::too_many_arguments)]
pub(super) fn end_iteration(
    it: usize,
    active: &mut [bool; 3],
    recompute: [bool; 3],
    (checked, est): ([f64; 3], [f64; 3]),
    rel: &mut [f64; 3],
    iterations: &mut [usize; 3],
    tol: f64,
    options: &SolveOptions<'_>,
) -> Result<(), SparseError> {
    for c in 0..3 {
        if active[c] {
            rel[c] = if recompute[c] { checked[c] } else { est[c] };
            iterations[c] += 1;
            if recompute[c] && rel[c] <= tol {
                active[c] = false;
            }
        }
    }
    options.report(it, *rel)
}

/// `β = ρ_new / ρ` for the active channels (0 for the others), which then take `ρ_new` as
/// their `ρ`.
///
/// # Errors
/// [`SparseError::Breakdown`] as [`check_rho`] for `ρ_new`.
pub(super) fn next_beta(
    rho: &mut [f64; 3],
    rho_new: [f64; 3],
    active: [bool; 3],
    iteration: usize,
) -> Result<[f64; 3], SparseError> {
    check_rho(rho_new, active, iteration)?;
    let mut beta = [0.0; 3];
    for c in 0..3 {
        if active[c] {
            beta[c] = rho_new[c] / rho[c];
            rho[c] = rho_new[c];
        }
    }
    Ok(beta)
}

/// Why a quantity that must be positive and finite is not: negative (or NaN) means `not_spd`;
/// 0 or subnormal means it underflowed (a residual too small for `f64` to represent, from a
/// system whose scale is far outside `f64`'s comfortable range), which says nothing about
/// definiteness; infinite means it overflowed.
pub(super) fn breakdown_reason(what: &str, value: f64, not_spd: &str) -> String {
    if (0.0..f64::MIN_POSITIVE).contains(&value) {
        format!(
            "{what} = {value:e} underflowed (below the smallest normal f64): the system is scaled far outside the range \
             of f64 (a tiny object or extreme coefficients), not indefinite"
        )
    } else if value == f64::INFINITY {
        format!("{what} overflowed to infinity: the system is scaled far outside the range of f64")
    } else {
        format!("{what} = {value:e} ≤ 0: {not_spd}")
    }
}

pub(super) fn check_rho(rho: [f64; 3], active: [bool; 3], iteration: usize) -> Result<(), SparseError> {
    for c in 0..3 {
        if active[c] && !(rho[c] > 0.0 && rho[c].is_finite()) {
            return Err(SparseError::Breakdown {
                method: "PCG",
                channel: c,
                iteration,
                reason: breakdown_reason("rᵀM⁻¹r", rho[c], "the preconditioner is not positive definite"),
            });
        }
    }
    Ok(())
}

/// `x += α p`, `r −= α q`; returns `(‖r‖², Σ w r²)` per channel: with `w = D⁻¹` (Jacobi)
/// `rᵀD⁻¹r`, with `w = D` (`f32`, the scaled system) the unscaled `‖r‖²` of `r = S⁻¹ r̂`.
fn update_weighted<W: Load3>(
    x: &mut [[f64; 3]],
    r: &mut [[f64; 3]],
    p: &[[f64; 3]],
    q: &[[f64; 3]],
    w: &[W],
    alpha: [f64; 3],
) -> ([f64; 3], [f64; 3]) {
    let parts: Vec<[f64; 6]> =
        (x.par_chunks_mut(CHUNK), r.par_chunks_mut(CHUNK), p.par_chunks(CHUNK), q.par_chunks(CHUNK), w.par_chunks(CHUNK))
            .into_par_iter()
            .map(|(x, r, p, q, w)| {
                let mut s = [0.0; 6];
                for ((((x, r), p), q), w) in x.iter_mut().zip(r.iter_mut()).zip(p).zip(q).zip(w) {
                    let w = w.load();
                    for c in 0..3 {
                        x[c] += alpha[c] * p[c];
                        r[c] -= alpha[c] * q[c];
                        let r2 = r[c] * r[c];
                        s[c] += r2;
                        s[3 + c] += r2 * w[c];
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

/// `p = z + β p` (the search direction, also of SSOR's Eisenstat CG with `z = r̃`).
pub(super) fn p_update(p: &mut [[f64; 3]], z: &[[f64; 3]], beta: [f64; 3]) {
    (p.par_chunks_mut(CHUNK), z.par_chunks(CHUNK)).into_par_iter().for_each(|(p, z)| {
        for (p, z) in p.iter_mut().zip(z) {
            for c in 0..3 {
                p[c] = z[c] + beta[c] * p[c];
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_underflowed_quantity_is_not_called_indefinite() {
        let not_spd = "the preconditioner is not positive definite";
        let under = breakdown_reason("rᵀM⁻¹r", 1e-320, not_spd);
        assert!(under.contains("underflowed") && !under.contains("not positive definite"), "{under}");
        let zero = breakdown_reason("rᵀM⁻¹r", 0.0, not_spd);
        assert!(zero.contains("underflowed") && !zero.contains("not positive definite"), "{zero}");
        assert_eq!(
            breakdown_reason("pᵀAp", -2.0, "the matrix is not positive definite"),
            "pᵀAp = -2e0 ≤ 0: the matrix is not positive definite"
        );
        assert!(breakdown_reason("rᵀM⁻¹r", f64::NAN, not_spd).ends_with(not_spd));
        assert!(breakdown_reason("pᵀAp", f64::INFINITY, not_spd).contains("overflowed"));
        match check_rho([1.0, 0.0, 1.0], [true; 3], 7) {
            Err(SparseError::Breakdown { channel: 1, iteration: 7, reason, .. }) => {
                assert!(reason.contains("underflowed"), "{reason}")
            }
            other => panic!("{other:?}"),
        }
        assert!(check_rho([1.0, 0.0, 1.0], [true, false, true], 7).is_ok(), "an inactive channel is not checked");
    }
}
