//! CG preconditioned with one V-cycle per iteration.

use rayon::prelude::*;

use super::workspace::{Outer, Workspace};
use super::{Multigrid, ROWS};
use crate::sparse::ops::{dot3, first_non_finite, norm3, spmv_dot};
use crate::sparse::pcg::{make_stats, update, zero_channels};
use crate::sparse::{relative, residual, restart, unconverged, CsrMatrix3, SolveOptions, SolveStats, SparseError};

/// Solves `a x = b` (three SPD channels) by CG preconditioned with one V-cycle of `mg` per
/// iteration, from the given `x` (a warm start; zeros for a cold one). Conventions as for
/// [`crate::sparse::pcg`]: per-channel scalars and stopping tests, a channel is declared
/// converged on its recomputed residual `‖b − Ax‖/‖b‖ ≤ tolerance`, `x` unchanged on error.
/// Uses `mg`'s workspace (no allocation); a cold start costs no product.
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
    for (what, v) in [("right-hand side", b), ("initial guess", &*x)] {
        if let Some((row, channel, value)) = first_non_finite(v) {
            return Err(SparseError::NonFinite { what, row, channel, value });
        }
    }
    mg.with_workspace(|w| mg_pcg_in(a, b, x, mg, options, w))
}

fn mg_pcg_in(
    a: &CsrMatrix3,
    b: &[[f64; 3]],
    x: &mut [[f64; 3]],
    mg: &Multigrid,
    options: &SolveOptions<'_>,
    work: &mut Workspace,
) -> Result<SolveStats, SparseError> {
    let Workspace { levels, outer } = work;
    let Outer { x: xw, r, z, p, q } = outer;
    let tol = options.tolerance;
    let bn = norm3(b);
    xw.copy_from_slice(x);
    zero_channels(xw, bn);
    // `b − A·0` is `b` bit for bit (each row's product sums to +0).
    let rr = if xw.par_iter().all(|v| v.iter().all(|&t| t == 0.0)) {
        r.copy_from_slice(b);
        dot3(r, r)
    } else {
        residual(a, b, xw, r)
    };
    let mut relres = relative(rr, bn);
    let mut active = unconverged(relres, bn, tol);
    let mut iterations = [0usize; 3];
    let mut it = 0;
    let mut restarts = 0;
    while active.iter().any(|&t| t) && it < options.max_iterations {
        mg.cycle(0, r, z, levels);
        let mut rz = dot3(r, z);
        p.copy_from_slice(z);
        while it < options.max_iterations {
            it += 1;
            for c in 0..3 {
                if active[c] && !(rz[c] > 0.0 && rz[c].is_finite()) {
                    return Err(SparseError::Breakdown {
                        method: "MG-PCG",
                        channel: c,
                        iteration: it,
                        reason: format!("rᵀBr = {:e}", rz[c]),
                    });
                }
            }
            let pq = spmv_dot(a.pattern(), a.values(), p, q, p);
            let mut alpha = [0.0; 3];
            for c in 0..3 {
                if active[c] {
                    if !(pq[c] > 0.0 && pq[c].is_finite()) {
                        return Err(SparseError::Breakdown {
                            method: "MG-PCG",
                            channel: c,
                            iteration: it,
                            reason: format!("pᵀAp = {:e}", pq[c]),
                        });
                    }
                    alpha[c] = rz[c] / pq[c];
                    iterations[c] += 1;
                }
            }
            relres = relative(update(xw, r, p, q, alpha), bn);
            options.report(it, relres)?;
            for c in 0..3 {
                if active[c] && relres[c] <= tol {
                    active[c] = false;
                }
            }
            if !active.iter().any(|&t| t) {
                break;
            }
            mg.cycle(0, r, z, levels);
            let rz_new = dot3(r, z);
            let beta = [0, 1, 2].map(|c| if active[c] { rz_new[c] / rz[c] } else { 0.0 });
            rz = rz_new;
            p.par_iter_mut().zip(&**z).with_min_len(ROWS).for_each(|(pi, zi)| {
                for c in 0..3 {
                    pi[c] = if active[c] { zi[c] + beta[c] * pi[c] } else { 0.0 };
                }
            });
        }
        // Confirm on the true residual; restart the channels that drifted.
        relres = relative(residual(a, b, xw, r), bn);
        match restart(relres, bn, tol, &mut restarts) {
            Some(again) => active = again,
            None => break,
        }
    }
    // `relres` is the true residual of `xw` here (the initial one, or the last confirmation).
    x.copy_from_slice(xw);
    Ok(make_stats(iterations, relres, tol))
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::super::fixtures::{rel_diff, system};
    use super::super::MultigridOptions;
    use super::*;
    use crate::sparse::fixtures::random_vector;

    #[test]
    fn mg_pcg_solves_and_is_reproducible_across_threads_clones_and_reuse() {
        let (h, a) = system();
        let mg = Multigrid::new(Arc::clone(h), a, MultigridOptions::default()).unwrap();
        let b = random_vector(a.n(), 7);
        let solve = |mg: &Multigrid| {
            let mut x = vec![[0.0; 3]; a.n()];
            let s = mg_pcg(a, &b, &mut x, mg, &SolveOptions::default().with_tolerance(1e-10)).unwrap();
            (x, s)
        };
        let (x, stats) = solve(&mg);
        assert!(stats.converged, "{stats:?}");
        assert!(stats.iterations.iter().all(|&k| k <= 20), "{stats:?}");
        let ax = a.mul_vec(&x).unwrap();
        assert!(rel_diff(&ax, &b) <= 1e-10 * 1.01);
        assert_eq!(stats.relative_residual, {
            let mut r = vec![[0.0; 3]; a.n()];
            let (rr, bb) = (residual(a, &b, &x, &mut r), dot3(&b, &b));
            [0, 1, 2].map(|c| rr[c].sqrt() / bb[c].sqrt())
        });
        // Bit-identical: again (reused workspace), on a clone (fresh workspace), on one and on
        // two threads, and from two threads sharing the multigrid at once.
        assert_eq!(solve(&mg).0, x);
        assert_eq!(solve(&mg.clone()).0, x);
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            assert_eq!(pool.install(|| solve(&mg)).0, x);
        }
        let (x1, x2) = std::thread::scope(|s| {
            let t = s.spawn(|| solve(&mg).0);
            (solve(&mg).0, t.join().unwrap())
        });
        assert_eq!((x1, x2), (x.clone(), x.clone()));
        // A warm start from the solution stops at once; a wrong size is an error.
        let mut xw = x.clone();
        let s = mg_pcg(a, &b, &mut xw, &mg, &SolveOptions::default().with_tolerance(1e-10)).unwrap();
        assert_eq!((s.iterations, xw), ([0; 3], x));
        let mut short = vec![[0.0; 3]; 3];
        assert!(matches!(mg.vcycle(a, &b, &mut short), Err(SparseError::DimensionMismatch { .. })));
    }
}
