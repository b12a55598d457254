//! The coarse-to-fine multiresolution solver of TransCut §4.2.
//!
//! The systems of the coarse levels are the eq.-17 substitutions `M^{l+1} = E M^l P`,
//! `b^{l+1} = E b^l` ([`substituted`]); they are not symmetric, so they are solved by
//! Jacobi-preconditioned BiCGSTAB, to a loose tolerance (they only provide a start). The
//! coarsest level starts from zero, every finer level from the interpolated (eq. 16) solution
//! of the level below, and level 0 — the original SPD system — is solved by the default
//! (mixed-precision Jacobi) PCG to the requested tolerance, so the answer is the PCG answer.
//!
//! As the paper notes, a coarse system need not be invertible; a coarse level whose BiCGSTAB
//! breaks down or misses its tolerance keeps its best available iterate (the interpolated start
//! if it broke down) and the cascade moves on to the next finer level.

use std::sync::Arc;

use super::coarse::substituted;
use super::{Hierarchy, HierarchyKind};
use crate::sparse::{bicgstab, pcg, CsrMatrix3, Preconditioner, PreconditionerKind, SolveOptions, SolveStats, SparseError};

/// Options of the coarse levels of [`Cascade::solve`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct CascadeOptions {
    /// Relative residual at which a coarse level stops. Default 1e-2.
    pub coarse_tolerance: f64,
    /// Iteration cap of a coarse level. Default 100.
    pub coarse_max_iterations: usize,
}

impl Default for CascadeOptions {
    fn default() -> Self {
        Self { coarse_tolerance: 1e-2, coarse_max_iterations: 100 }
    }
}

/// What a cascade solve did.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct CascadeStats {
    /// The level-0 PCG statistics (the reported convergence).
    pub fine: SolveStats,
    /// BiCGSTAB iterations per coarse level `1..levels` (0 where a level broke down).
    pub coarse_iterations: Vec<[usize; 3]>,
    /// Coarse levels whose BiCGSTAB broke down (their interpolated start was passed on).
    pub breakdowns: usize,
}

/// The coarse operators and preconditioners of a [`Hierarchy`] for one matrix.
#[derive(Debug, Clone)]
pub struct Cascade {
    hierarchy: Arc<Hierarchy>,
    /// `operators[l - 1]` is `M^l`, `l ≥ 1`.
    operators: Vec<CsrMatrix3>,
    preconditioners: Vec<Preconditioner>,
    fine: Preconditioner,
    options: CascadeOptions,
}

impl Cascade {
    /// Builds the eq.-17 operators of every coarse level of `hierarchy` for `a` (the level-0
    /// matrix, on the hierarchy's level-0 graph) and their Jacobi preconditioners (the identity
    /// where a coarse diagonal is not positive).
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] / [`SparseError::NotInPattern`] if `a` does not belong
    /// to the hierarchy; [`SparseError::NonPositiveDiagonal`] if `a`'s own diagonal is not
    /// positive; [`SparseError::InvalidOption`] for a non-positive coarse tolerance.
    pub fn new(hierarchy: Arc<Hierarchy>, a: &CsrMatrix3, options: CascadeOptions) -> Result<Self, SparseError> {
        if !(options.coarse_tolerance > 0.0 && options.coarse_tolerance.is_finite()) {
            return Err(SparseError::InvalidOption(format!("coarse tolerance {} must be positive", options.coarse_tolerance)));
        }
        if hierarchy.kind() != HierarchyKind::IndependentSets && hierarchy.levels() > 1 {
            return Err(SparseError::InvalidOption(
                "the cascade needs the TransCut hierarchy (eq. 17 injects at retained vertices), not an aggregation".into(),
            ));
        }
        let fine = Preconditioner::new(a, PreconditionerKind::Jacobi)?;
        let mut operators: Vec<CsrMatrix3> = Vec::new();
        let mut preconditioners = Vec::new();
        for l in 1..hierarchy.levels() {
            let m = {
                let above = if l == 1 { a } else { &operators[l - 2] };
                substituted(above, hierarchy.prolongation(l - 1), &hierarchy.level(l).graph)?
            };
            preconditioners.push(Preconditioner::new(&m, PreconditionerKind::Jacobi).unwrap_or(Preconditioner::Identity));
            operators.push(m);
        }
        Ok(Self { hierarchy, operators, preconditioners, fine, options })
    }

    /// The coarse operator of level `l ≥ 1`.
    ///
    /// # Panics
    /// If `l` is 0 or not below the level count.
    #[must_use]
    pub fn operator(&self, l: usize) -> &CsrMatrix3 {
        &self.operators[l - 1]
    }

    /// Solves `a x = b` (the matrix this cascade was built for): the coarse-to-fine cascade
    /// from zero, or — with `warm_start` — level-0 PCG from `x` alone (a previous solution is a
    /// better start than any interpolated coarse one). On success `x` holds the solution.
    ///
    /// # Errors
    /// Those of [`pcg`] at level 0 (coarse-level failures are absorbed, see the module
    /// documentation); [`SparseError::DimensionMismatch`] if `a` is not the level-0 size.
    pub fn solve(
        &self,
        a: &CsrMatrix3,
        b: &[[f64; 3]],
        x: &mut [[f64; 3]],
        warm_start: bool,
        options: &SolveOptions<'_>,
    ) -> Result<CascadeStats, SparseError> {
        let n0 = self.hierarchy.level(0).graph.n();
        if a.n() != n0 || b.len() != n0 || x.len() != n0 {
            return Err(SparseError::DimensionMismatch {
                what: "cascade system size",
                expected: n0,
                found: a.n().min(b.len()).min(x.len()),
            });
        }
        let levels = self.hierarchy.levels();
        let mut coarse_iterations = vec![[0usize; 3]; levels - 1];
        let mut breakdowns = 0;
        if !warm_start && levels > 1 {
            // Right-hand sides by injection (b^{l+1} = E b^l).
            let mut rhs: Vec<Vec<[f64; 3]>> = vec![b.to_vec()];
            for l in 1..levels {
                let next = self.hierarchy.prolongation(l - 1).inject(&rhs[l - 1]);
                rhs.push(next);
            }
            let coarse_opts = SolveOptions::default()
                .with_tolerance(self.options.coarse_tolerance)
                .with_max_iterations(self.options.coarse_max_iterations);
            let mut current = vec![[0.0; 3]; self.hierarchy.level(levels - 1).graph.n()];
            for l in (1..levels).rev() {
                match bicgstab(&self.operators[l - 1], &rhs[l], &mut current, &self.preconditioners[l - 1], &coarse_opts) {
                    Ok(stats) => coarse_iterations[l - 1] = stats.iterations,
                    Err(SparseError::Breakdown { .. }) => breakdowns += 1,
                    Err(e) => return Err(e),
                }
                if current.iter().flatten().any(|v| !v.is_finite()) {
                    current.iter_mut().for_each(|v| *v = [0.0; 3]);
                    breakdowns += 1;
                }
                let mut finer = vec![[0.0; 3]; self.hierarchy.level(l - 1).graph.n()];
                self.hierarchy.prolongation(l - 1).prolong(&current, &mut finer);
                current = finer;
            }
            x.copy_from_slice(&current);
        }
        let fine = pcg(a, b, x, &self.fine, options)?;
        Ok(CascadeStats { fine, coarse_iterations, breakdowns })
    }
}
