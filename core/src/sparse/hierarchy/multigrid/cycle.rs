//! One V-cycle `z = B r`.

use super::workspace::LevelWork;
use super::Multigrid;
use crate::sparse::{CsrMatrix3, SparseError};

impl Multigrid {
    /// One V-cycle `z = B r` (the preconditioner of [`mg_pcg`](super::mg_pcg)) on level 0. `B` is the V-cycle
    /// of the matrix the multigrid was built for (its level-0 smoothing uses the `f32` copy made
    /// by [`Multigrid::new`]); `a` is checked for its size only.
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
        self.with_workspace(|w| self.cycle(0, r, z, &mut w.levels));
        Ok(())
    }

    /// `z = B_l r` on level `l`; `work[0]` is level `l`'s workspace, `work[1..]` the coarser
    /// levels'.
    pub(super) fn cycle(&self, l: usize, r: &[[f64; 3]], z: &mut [[f64; 3]], work: &mut [LevelWork]) {
        if l + 1 == self.hierarchy.levels() {
            z.copy_from_slice(r);
            // A one-level hierarchy has no coarse factor (and no smoother): the identity.
            if let Some(f) = &self.coarsest {
                f.solve_in_place(z);
            }
            return;
        }
        let (here, coarser) = work.split_first_mut().expect("a workspace per level");
        let LevelWork { alt, d, res, .. } = here;
        let (op, sm) = (&self.ops32[l], &self.smoothers[l]);
        let degree = sm.steps.len();
        // The iterate switches buffers at every step after the first, 2·degree − 1 times, so
        // starting in `alt` it ends in `z`.
        let z_out = z.as_ptr();
        let (mut cur, mut next): (&mut [[f64; 3]], &mut [[f64; 3]]) = (alt, z);
        sm.first_from_zero(r, cur, d);
        for k in 1..degree {
            sm.step(op, k, r, cur, next, d);
            std::mem::swap(&mut cur, &mut next);
        }
        op.residual(r, cur, res);
        let p = self.hierarchy.prolongation(l);
        let (mut rc, mut zc) = (std::mem::take(&mut coarser[0].r), std::mem::take(&mut coarser[0].z));
        p.restrict(res, &mut rc);
        self.cycle(l + 1, &rc, &mut zc, coarser);
        p.prolong_add(&zc, cur);
        (coarser[0].r, coarser[0].z) = (rc, zc);
        for k in 0..degree {
            sm.step(op, k, r, cur, next, d);
            std::mem::swap(&mut cur, &mut next);
        }
        debug_assert!(std::ptr::eq(cur.as_ptr(), z_out), "the V-cycle ends in z");
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use nalgebra::{Cholesky, DVector};

    use super::super::fixtures::{rel_diff, system};
    use super::super::MultigridOptions;
    use super::*;
    use crate::sparse::dot3;
    use crate::sparse::fixtures::random_vector;

    fn with_degree(degree: usize) -> MultigridOptions {
        MultigridOptions { smoothing_degree: degree, ..MultigridOptions::default() }
    }

    fn vcycle(mg: &Multigrid, a: &CsrMatrix3, r: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut z = vec![[0.0; 3]; r.len()];
        mg.vcycle(a, r, &mut z).unwrap();
        z
    }

    /// The V-cycle written plainly: f64 operators, Chebyshev steps with full residuals, fresh
    /// vectors, nalgebra's Cholesky solve at the coarsest.
    fn reference_cycle(mg: &Multigrid, l: usize, a: &CsrMatrix3, r: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let n = r.len();
        if l + 1 == mg.hierarchy.levels() {
            let mut z = vec![[0.0; 3]; n];
            for c in 0..3 {
                let f = Cholesky::new(a.to_dense(c)).unwrap();
                let x = f.solve(&DVector::from_iterator(n, r.iter().map(|v| v[c])));
                for (zi, xi) in z.iter_mut().zip(x.iter()) {
                    zi[c] = *xi;
                }
            }
            return z;
        }
        let sm = &mg.smoothers[l];
        let smooth = |z: &mut Vec<[f64; 3]>, from_zero: bool| {
            let mut d = vec![[0.0; 3]; n];
            for (k, st) in sm.steps.iter().enumerate() {
                let res: Vec<[f64; 3]> = if k == 0 && from_zero {
                    r.to_vec()
                } else {
                    let az = a.mul_vec(z).unwrap();
                    (0..n).map(|i| [0, 1, 2].map(|c| r[i][c] - az[i][c])).collect()
                };
                for i in 0..n {
                    for c in 0..3 {
                        d[i][c] = st.keep[c] * d[i][c] + st.gain[c] * res[i][c] * sm.inv_diag[i][c];
                        z[i][c] += d[i][c];
                    }
                }
            }
        };
        let mut z = vec![[0.0; 3]; n];
        smooth(&mut z, true);
        let az = a.mul_vec(&z).unwrap();
        let res: Vec<[f64; 3]> = (0..n).map(|i| [0, 1, 2].map(|c| r[i][c] - az[i][c])).collect();
        let p = mg.hierarchy.prolongation(l);
        let mut rc = vec![[0.0; 3]; p.n_coarse()];
        p.restrict(&res, &mut rc);
        let zc = reference_cycle(mg, l + 1, mg.operator(l + 1), &rc);
        p.prolong_add(&zc, &mut z);
        smooth(&mut z, false);
        z
    }

    #[test]
    fn fused_f32_vcycle_equals_the_plain_f64_vcycle() {
        let (h, a) = system();
        for degree in [1, 2, 3] {
            let mg = Multigrid::new(Arc::clone(h), a, with_degree(degree)).unwrap();
            for seed in 0..2 {
                let r = random_vector(a.n(), seed);
                let z = vcycle(&mg, a, &r);
                let e = rel_diff(&z, &reference_cycle(&mg, 0, a, &r));
                // Only the f32 rounding of the operators separates the two.
                assert!(e < 1e-5, "degree {degree}: {e:e}");
                // Not the identity or a scaled copy of r: the cycle did something.
                assert!(rel_diff(&z, &r) > 1e-2);
            }
        }
    }

    #[test]
    fn vcycle_is_symmetric_positive_definite_and_contracts() {
        let (h, a) = system();
        for degree in [1, 2] {
            let mg = Multigrid::new(Arc::clone(h), a, with_degree(degree)).unwrap();
            for seed in 0..4 {
                let (u, v) = (random_vector(a.n(), 10 + seed), random_vector(a.n(), 20 + seed));
                let (bu, bv) = (vcycle(&mg, a, &u), vcycle(&mg, a, &v));
                let (ubv, vbu, ubu) = (dot3(&u, &bv), dot3(&v, &bu), dot3(&u, &bu));
                let scale = (dot3(&u, &u)[0] * dot3(&bv, &bv)[0]).sqrt();
                for c in 0..3 {
                    // B is exactly symmetric as a map of the rounded operators: only the
                    // rounding of the f64 arithmetic remains.
                    assert!((ubv[c] - vbu[c]).abs() <= 1e-10 * scale, "degree {degree} channel {c}: {} vs {}", ubv[c], vbu[c]);
                    assert!(ubu[c] > 0.0, "degree {degree} channel {c}: uᵀBu = {}", ubu[c]);
                }
                // The two-level error propagator I − BA contracts in the A-norm (multigrid
                // convergence): ‖(I − BA) x‖_A ≤ 0.5 ‖x‖_A.
                let ax = a.mul_vec(&u).unwrap();
                let bax = vcycle(&mg, a, &ax);
                let e: Vec<[f64; 3]> = u.iter().zip(&bax).map(|(x, y)| [0, 1, 2].map(|c| x[c] - y[c])).collect();
                let (ee, xx) = (dot3(&e, &a.mul_vec(&e).unwrap()), dot3(&u, &ax));
                for c in 0..3 {
                    assert!(
                        ee[c].sqrt() <= 0.5 * xx[c].sqrt(),
                        "degree {degree} channel {c}: {} of {}",
                        ee[c].sqrt(),
                        xx[c].sqrt()
                    );
                }
            }
        }
    }
}
