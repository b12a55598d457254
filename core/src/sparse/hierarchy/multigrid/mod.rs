//! A multigrid V-cycle on the TransCut hierarchy (or on a smoothed aggregation,
//! [`Hierarchy::aggregated`], whose `P` takes the place of eq. 16's), used as the preconditioner
//! of CG.
//!
//! The paper (§4.2) keeps to its one-way cascade and remarks that its interpolation could
//! serve a full multigrid solver; this is that solver in its symmetric form. With `P` the
//! eq.-16 interpolation of each level, the coarse operators are the Galerkin products
//! `A^{l+1} = Pᵀ A^l P` ([`galerkin`]), which stay symmetric positive definite. One V-cycle
//! `z = B r`, per level `l` above the coarsest (`Ã^l` the level's operator rounded to `f32`,
//! see below):
//!
//! 1. pre-smooth from `z = 0` with a degree-`d` Chebyshev polynomial in `D⁻¹Ã` over
//!    `[λmax / ratio, λmax]` (`λmax` the Gershgorin bound `max_i Σ_j |ã_ij| / a_ii` of the
//!    spectrum of `D⁻¹Ã`, see [`Smoother`]): the first step
//!    is `z = D⁻¹ r / θ` (no product), each further step `res = r − Ã z`,
//!    `d = ρ_k ρ_{k−1} d + (2ρ_k/δ) D⁻¹ res`, `z += d` in one fused pass;
//! 2. restrict the residual `r_c = Pᵀ (r − Ã z)`, recurse (dense Cholesky at the coarsest);
//! 3. correct `z += P z_c`, post-smooth with the same polynomial (`d` steps, each one fused
//!    residual-and-update pass).
//!
//! That is `2d` products with `Ã^l` per level and V-cycle, the fewest a degree-`d` smoother
//! needs (each step needs the residual of the previous iterate, and the restriction that of the
//! last pre-smoothing iterate).
//!
//! **Precision.** The operators inside the V-cycle are stored in `f32` (12 + 4 bytes per
//! nonzero instead of 24 + 4; the products accumulate in `f64`, vectors stay `f64`): the level-0
//! matrix given to [`Multigrid::new`] is symmetrised `(a_ij + a_ji)/2` before rounding and the
//! Galerkin operators are exactly symmetric already, so each `Ã^l` is exactly symmetric. The
//! V-cycle is therefore the symmetric two-sided smoother `M = q(D⁻¹Ã)D⁻¹` around a symmetric
//! coarse correction: with `C = P B_c Pᵀ` (`B_c` the next level's cycle, symmetric by
//! induction, the exact inverse at the coarsest), `B = 2M − MÃM + (I − MÃ) C (I − ÃM)`, a
//! fixed symmetric linear operator, positive definite since the smoother contracts (`λmax`
//! is a true upper bound of the spectrum of `D⁻¹Ã`, computed from the rounded entries
//! themselves). Plain CG on the exact `f64` level-0 matrix stays valid ([`mg_pcg`]); `B` only
//! approximates `A⁻¹` less well by the rounding, far below what one V-cycle leaves anyway.
//!
//! **Memory.** Every vector a V-cycle and [`mg_pcg`] use lives in a workspace allocated (and
//! touched) by [`Multigrid::new`] and reused, so a solve allocates nothing; two threads using
//! the same [`Multigrid`] at once get the second a temporary workspace (same results).
//!
//! Every kernel is a fixed-order parallel loop (each row summed in column order, reductions in
//! fixed blocks), so results are bit-identical for any thread count.
//!
//! The parts: the `f32` level operators (`operator32.rs`), the Chebyshev smoother
//! (`smoother.rs`), the dense solve at the coarsest level (`coarse_solve.rs`), the reused
//! vectors (`workspace.rs`), the cycle itself (`cycle.rs`) and the outer CG (`mg_pcg.rs`); this
//! file holds the options and builds and refreshes the [`Multigrid`].

mod coarse_solve;
mod cycle;
#[cfg(test)]
mod fixtures;
mod mg_pcg;
mod operator32;
mod smoother;
mod workspace;

use std::sync::Arc;

use glam::DVec3;

use self::coarse_solve::CoarseFactor;
use self::operator32::Operator32;
use self::smoother::Smoother;
use self::workspace::WorkCell;
use super::coarse::{galerkin, galerkin_rows};
use super::{Hierarchy, HierarchyOptions};
use crate::sparse::ops::CHUNK;
use crate::sparse::precond::positive_diagonal;
use crate::sparse::{CsrMatrix3, SparseError};

pub use self::mg_pcg::mg_pcg;

/// Rows per parallel task of the V-cycle kernels (fixed: per-row results do not depend on it).
const ROWS: usize = CHUNK / 4;

/// Options of [`Multigrid::new`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct MultigridOptions {
    /// Degree of the Chebyshev smoother (matrix products per smoothing). Default 1 (damped
    /// Jacobi `z += D⁻¹ res / θ`, θ the interval's centre): a higher degree saves fewer MG-PCG
    /// iterations than the products it adds cost.
    pub smoothing_degree: usize,
    /// The smoothing interval is `[λmax / ratio, λmax]`. Default 4: the smoother has to damp
    /// the high frequencies, which the coarse correction does not reach; a wider interval
    /// spreads its damping over the low ones and costs MG-PCG iterations.
    pub smoothing_ratio: f64,
    /// Largest coarsest level factored densely; coarser hierarchies beyond it are an error.
    /// Default 4000.
    pub max_direct: usize,
}

impl Default for MultigridOptions {
    fn default() -> Self {
        Self { smoothing_degree: 1, smoothing_ratio: 4.0, max_direct: 4000 }
    }
}

/// The Galerkin hierarchy, smoothers and coarsest factorisation for one matrix.
#[derive(Debug, Clone)]
pub struct Multigrid {
    hierarchy: Arc<Hierarchy>,
    /// `operators[l - 1]` is `A^l`, `l ≥ 1`.
    operators: Vec<CsrMatrix3>,
    /// `ops32[l]` is `Ã^l` for the levels above the coarsest (level 0 included).
    ops32: Vec<Operator32>,
    smoothers: Vec<Smoother>,
    coarsest: Option<CoarseFactor>,
    options: MultigridOptions,
    work: WorkCell,
}

/// Checks the smoothing degree (1 to 16) and ratio (above 1).
fn validate(options: &MultigridOptions) -> Result<(), SparseError> {
    if options.smoothing_degree == 0 || options.smoothing_degree > 16 || !(options.smoothing_ratio > 1.0) {
        return Err(SparseError::InvalidOption(format!(
            "multigrid smoothing degree {} must be 1 to 16 and ratio {} above 1",
            options.smoothing_degree, options.smoothing_ratio
        )));
    }
    Ok(())
}

/// The diagonal of `a` on `rows`, checked positive ([`positive_diagonal`]).
fn diagonal_rows(a: &CsrMatrix3, rows: &[u32]) -> Result<Vec<[f64; 3]>, SparseError> {
    rows.iter().map(|&i| positive_diagonal(a, i as usize)).collect()
}

impl Multigrid {
    /// Builds the Galerkin operators of `hierarchy` for `a` (SPD, on the level-0 graph), their
    /// `f32` copies (and `a`'s) for the V-cycle, the smoothers of every level but the coarsest,
    /// the dense Cholesky factors of the coarsest and the workspace of the V-cycle and
    /// [`mg_pcg`].
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `a` is not the level-0 size;
    /// [`SparseError::NonPositiveDiagonal`] for a non-positive diagonal;
    /// [`SparseError::InvalidOption`] for bad options, a coarsest level above
    /// `options.max_direct`, or a coarsest operator that is not positive definite.
    pub fn new(hierarchy: Arc<Hierarchy>, a: &CsrMatrix3, options: MultigridOptions) -> Result<Self, SparseError> {
        validate(&options)?;
        let n0 = hierarchy.level(0).graph.n();
        if a.n() != n0 {
            return Err(SparseError::DimensionMismatch { what: "multigrid matrix rows", expected: n0, found: a.n() });
        }
        let mut operators: Vec<CsrMatrix3> = Vec::new();
        for l in 1..hierarchy.levels() {
            let g = galerkin(if l == 1 { a } else { &operators[l - 2] }, hierarchy.prolongation(l - 1))?;
            operators.push(g);
        }
        Self::with_operators(hierarchy, a, operators, options)
    }

    /// [`Self::new`] on a smoothed-aggregation hierarchy of `a` ([`Hierarchy::aggregated`]),
    /// whose Galerkin operators are computed once, while building it.
    ///
    /// # Errors
    /// Those of [`Hierarchy::aggregated`] and [`Self::new`].
    pub fn aggregated(
        a: &CsrMatrix3,
        positions: &[DVec3],
        hierarchy: &HierarchyOptions,
        options: MultigridOptions,
    ) -> Result<Self, SparseError> {
        validate(&options)?;
        let (h, operators) = Hierarchy::aggregated(a, positions, hierarchy)?;
        Self::with_operators(Arc::new(h), a, operators, options)
    }

    /// The multigrid of `hierarchy` whose Galerkin operators are `operators` (`A^1, A^2, …`).
    fn with_operators(
        hierarchy: Arc<Hierarchy>,
        a: &CsrMatrix3,
        operators: Vec<CsrMatrix3>,
        options: MultigridOptions,
    ) -> Result<Self, SparseError> {
        let levels = hierarchy.levels();
        let level_op = |l: usize| if l == 0 { a } else { &operators[l - 1] };
        let mut smoothers = Vec::new();
        let mut ops32 = Vec::new();
        for l in 0..levels.saturating_sub(1) {
            // Level 0 is symmetrised before rounding; the Galerkin operators are exactly symmetric.
            let op = Operator32::new(level_op(l), l == 0);
            smoothers.push(Smoother::new(level_op(l), &op, &options)?);
            ops32.push(op);
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
            Some(CoarseFactor::new(m)?)
        } else {
            None
        };
        let work = WorkCell::new(&hierarchy);
        Ok(Self { hierarchy, operators, ops32, smoothers, coarsest, options, work })
    }

    /// Follows a change of the level-0 matrix confined to `rows` (every row in which it
    /// changed; the matrix being symmetric, it changed in no other column either): `a` is the
    /// new matrix, with the pattern of the one given to [`Self::new`]. Every level is brought up
    /// to date by recomputing only what the change reaches: the level-0 rows of the `f32`
    /// operator and the inverse diagonal, the Galerkin rows each changed row interpolates to
    /// ([`galerkin_rows`]), and so on down the levels; each touched smoother's `λmax` and, when
    /// the change reaches it, the coarsest factorisation are recomputed. The result equals
    /// [`Self::new`]`(hierarchy, a, options)` bit for bit, at a fraction of its cost for a local
    /// change (painting: TransCut §5.2 refills only the rows of the painted tets' vertices).
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] / [`SparseError::PatternMismatch`] if `a` has another
    /// size or pattern; [`SparseError::IndexOutOfRange`] for a row outside it;
    /// [`SparseError::NonPositiveDiagonal`] for a non-positive diagonal in a changed row: on
    /// these the multigrid is unchanged. [`SparseError::InvalidOption`] for a coarsest operator
    /// that is not positive definite (`a` was not): the multigrid is then partly updated, and a
    /// refresh with an SPD matrix on the same rows repairs it.
    pub fn refresh(&mut self, a: &CsrMatrix3, rows: &[u32]) -> Result<(), SparseError> {
        let n0 = self.hierarchy.level(0).graph.n();
        if a.n() != n0 {
            return Err(SparseError::DimensionMismatch { what: "multigrid matrix rows", expected: n0, found: a.n() });
        }
        if let Some(&r) = rows.iter().find(|&&r| r as usize >= n0) {
            return Err(SparseError::IndexOutOfRange { what: "changed row".into(), index: u64::from(r), n: n0 });
        }
        let levels = self.hierarchy.levels();
        if levels == 1 {
            // A one-level hierarchy: the V-cycle is the identity, nothing depends on `a`.
            return Ok(());
        }
        if !(Arc::ptr_eq(a.pattern(), &self.ops32[0].pattern) || **a.pattern() == *self.ops32[0].pattern) {
            return Err(SparseError::PatternMismatch(
                "the refreshed level-0 matrix has another pattern than the multigrid's".into(),
            ));
        }
        let mut changed = rows.to_vec();
        changed.sort_unstable();
        changed.dedup();
        for l in 0..levels - 1 {
            let (fine, rest) = self.operators.split_at_mut(l);
            let fine = if l == 0 { a } else { &fine[l - 1] };
            // At level 0 this is the first change made; below it cannot fail (SPD operators).
            let diagonal = diagonal_rows(fine, &changed)?;
            self.ops32[l].refresh_rows(fine, &changed);
            self.smoothers[l].refresh(&self.ops32[l], &changed, &diagonal, &self.options);
            changed = galerkin_rows(fine, self.hierarchy.prolongation(l), &mut rest[0], &changed)?;
            if changed.is_empty() {
                return Ok(());
            }
        }
        self.coarsest = Some(CoarseFactor::new(&self.operators[levels - 2])?);
        Ok(())
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
    /// upper end `λmax` of its interval (the Gershgorin bound of `D⁻¹Ã`), for the GPU twin of
    /// the V-cycle.
    #[cfg(feature = "gpu")]
    pub(crate) fn smoother(&self, l: usize) -> (&[[f64; 3]], [f64; 3]) {
        (&self.smoothers[l].inv_diag, self.smoothers[l].lambda_max)
    }

    /// `A_c⁻¹` of the coarsest level (dense, row-major, channels interleaved, exactly
    /// symmetric) and its order, `None` for a one-level hierarchy; for the GPU twin of the
    /// coarse solve.
    #[cfg(feature = "gpu")]
    pub(crate) fn coarsest_inverse(&self) -> Option<(usize, Vec<[f64; 3]>)> {
        self.coarsest.as_ref().map(|f| (f.n(), f.inverse()))
    }
}

#[cfg(test)]
mod tests {
    use super::fixtures::{grid_system, system};
    use super::*;

    #[test]
    fn a_refresh_after_a_local_change_equals_a_fresh_build() {
        let (h, a) = system();
        let mg = Multigrid::new(Arc::clone(h), a, MultigridOptions::default()).unwrap();
        // A local change: 40 rows get 30 more absorption and 3× their couplings among
        // themselves (symmetric, still diagonally dominant, so SPD).
        let rows: Vec<u32> = (1000..1040).collect();
        let inside = |v: usize| (1000..1040).contains(&v);
        let mut changed = a.clone();
        let p = Arc::clone(a.pattern());
        for &i in &rows {
            let i = i as usize;
            for k in p.row_ptr()[i]..p.row_ptr()[i + 1] {
                let j = p.col_idx()[k] as usize;
                let v = &mut changed.values_mut()[k];
                if j == i {
                    *v = v.map(|t| t + 30.0);
                } else if inside(j) {
                    *v = v.map(|t| 3.0 * t);
                }
            }
        }
        let mut refreshed = mg.clone();
        refreshed.refresh(&changed, &rows).unwrap();
        let fresh = Multigrid::new(Arc::clone(h), &changed, MultigridOptions::default()).unwrap();
        let same = |x: &Multigrid, y: &Multigrid| {
            for l in 0..h.levels() {
                if l > 0 {
                    assert_eq!(x.operator(l).values(), y.operator(l).values(), "operator {l}");
                }
                if l + 1 < h.levels() {
                    assert_eq!(x.ops32[l].values, y.ops32[l].values, "f32 operator {l}");
                    assert_eq!(x.smoothers[l].inv_diag, y.smoothers[l].inv_diag, "smoother {l}");
                    assert_eq!(x.smoothers[l].lambda_max, y.smoothers[l].lambda_max, "λmax {l}");
                }
            }
            assert_eq!(x.coarsest.as_ref().unwrap().l, y.coarsest.as_ref().unwrap().l);
        };
        same(&refreshed, &fresh);
        // The change did reach the coarse levels (so the comparison above tested them).
        assert_ne!(mg.operator(1).values(), fresh.operator(1).values());
        // Refreshing back on the same rows restores the original bit for bit.
        let mut back = refreshed.clone();
        back.refresh(a, &rows).unwrap();
        same(&back, &mg);
        // Bad input leaves it unchanged.
        let mut bad_diag = changed.clone();
        let d = bad_diag.pattern().diagonal_positions()[1010];
        bad_diag.values_mut()[d][1] = -1.0;
        for result in [
            refreshed.refresh(&changed, &[a.n() as u32]),
            refreshed.refresh(&bad_diag, &rows),
            refreshed.refresh(&grid_system(6, 5, 4).1, &[0]),
        ] {
            assert!(result.is_err());
        }
        same(&refreshed, &fresh);
    }
}
