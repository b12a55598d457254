//! The multiresolution solvers of TransCut §4 on a [`DiffusionSystem`]: the hierarchy is built
//! once per mesh from the matrix pattern and the vertex positions (mm), the coarse operators
//! once per set of media, and every solve may warm-start from a previous φ.
//!
//! Five methods ([`Method`]), all reaching the same answer (level-0 residual
//! `‖b − Mφ‖/‖b‖ ≤ tolerance`):
//! - [`Method::Pcg`]: the single-level baseline, mixed-precision Jacobi PCG (the GPU's solver);
//! - [`Method::SsorPcg`]: single-level CG with the SSOR preconditioner
//!   ([`crate::sparse::Ssor`], as [`super::solve()`]), the stronger single-level solver Fig. 7
//!   is measured against;
//! - [`Method::Cascade`]: the paper's coarse-to-fine cascade (BiCGSTAB on the eq.-17 coarse
//!   systems, CG at level 0, each level started from the interpolated coarser solution);
//! - [`Method::MultigridPcg`]: CG preconditioned by a V-cycle on the same hierarchy (Galerkin
//!   coarse operators);
//! - [`Method::AggregationPcg`]: the same V-cycle on a smoothed-aggregation hierarchy built
//!   from the matrix ([`Hierarchy::aggregated`]): levels that shrink 20-fold instead of 3-fold,
//!   so about a seventh of the setup (121 against 796 ms at 500k tets) and a solve within 20%
//!   of it (103 against 87 ms), with twice the iterations at about half their cost.
//!
//! Measurements (bunny, 500k tets; `transcut bench multires`) are in the crate's module
//! documentation of [`crate::sparse::hierarchy`] and the project notes.

use std::sync::Arc;

use super::assembly::DiffusionSystem;
use super::error::DiffusionError;
use super::solve::Solution;
use crate::sparse::hierarchy::{
    mg_pcg, Cascade, CascadeOptions, Hierarchy, HierarchyKind, HierarchyOptions, Multigrid, MultigridOptions,
};
use crate::sparse::{pcg, Preconditioner, PreconditionerKind, SolveOptions, SparseError};

/// Which solver a [`MultiresSolver`] runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Method {
    /// Single-level Jacobi PCG (mixed precision).
    #[default]
    Pcg,
    /// TransCut §4.2: coarse-to-fine BiCGSTAB cascade, CG at level 0.
    Cascade,
    /// CG preconditioned by a Galerkin multigrid V-cycle on the TransCut hierarchy.
    MultigridPcg,
    /// Single-level CG preconditioned by SSOR ([`crate::sparse::Ssor`]; no hierarchy).
    SsorPcg,
    /// CG preconditioned by a Galerkin multigrid V-cycle on a smoothed-aggregation hierarchy
    /// ([`Hierarchy::aggregated`], built from the matrix rather than the mesh).
    AggregationPcg,
}

impl Method {
    /// Whether the method works on level 0 alone (needs no hierarchy).
    #[must_use]
    pub fn is_single_level(self) -> bool {
        matches!(self, Self::Pcg | Self::SsorPcg)
    }

    /// The kind of hierarchy the method runs on (`None` for a single-level method).
    #[must_use]
    pub fn hierarchy_kind(self) -> Option<HierarchyKind> {
        match self {
            Self::Pcg | Self::SsorPcg => None,
            Self::Cascade | Self::MultigridPcg => Some(HierarchyKind::IndependentSets),
            Self::AggregationPcg => Some(HierarchyKind::Aggregation),
        }
    }
}

/// The hierarchy of a system's mesh (TransCut §4.1) built from its pattern and positions.
///
/// # Errors
/// [`DiffusionError::Sparse`] from [`Hierarchy::build`].
pub fn hierarchy(system: &DiffusionSystem, options: &HierarchyOptions) -> Result<Hierarchy, DiffusionError> {
    Ok(Hierarchy::build(system.pattern(), &system.structure().positions_mm, options)?)
}

#[derive(Debug, Clone)]
enum Prepared {
    Pcg(Preconditioner),
    Cascade(Cascade),
    Multigrid(Multigrid),
}

/// A solver prepared for one system's matrix: the hierarchy (kept while the mesh is the same)
/// and the method's matrix-dependent parts (rebuilt by [`MultiresSolver::update_matrix`] after
/// [`DiffusionSystem::set_media`]; a new source needs nothing).
#[derive(Debug, Clone)]
pub struct MultiresSolver {
    hierarchy: Arc<Hierarchy>,
    method: Method,
    prepared: Prepared,
}

impl MultiresSolver {
    /// Builds the hierarchy of `system` (unless `method` is single-level, [`Method::Pcg`] or
    /// [`Method::SsorPcg`], which need none; [`Method::AggregationPcg`] aggregates the matrix
    /// itself) and prepares `method` for its matrix.
    ///
    /// # Errors
    /// [`DiffusionError::Sparse`] from the hierarchy or the coarse operators.
    pub fn new(system: &DiffusionSystem, method: Method, options: &HierarchyOptions) -> Result<Self, DiffusionError> {
        if method == Method::AggregationPcg {
            let mg =
                Multigrid::aggregated(system.matrix(), &system.structure().positions_mm, options, MultigridOptions::default())?;
            return Ok(Self { hierarchy: Arc::clone(mg.hierarchy()), method, prepared: Prepared::Multigrid(mg) });
        }
        let h = if method.is_single_level() {
            Hierarchy::build(system.pattern(), &system.structure().positions_mm, &HierarchyOptions { max_levels: 1, ..*options })?
        } else {
            hierarchy(system, options)?
        };
        Self::with_hierarchy(system, Arc::new(h), method)
    }

    /// Prepares `method` for `system` on a ready hierarchy of its mesh, of the kind the method
    /// runs on ([`Method::hierarchy_kind`]; any kind for a single-level method).
    ///
    /// # Errors
    /// [`DiffusionError::LengthMismatch`] if the hierarchy belongs to another mesh;
    /// [`DiffusionError::Sparse`] for a hierarchy of another kind, and from the coarse
    /// operators.
    pub fn with_hierarchy(system: &DiffusionSystem, hierarchy: Arc<Hierarchy>, method: Method) -> Result<Self, DiffusionError> {
        if hierarchy.level(0).graph.n() != system.vertex_count() {
            return Err(DiffusionError::LengthMismatch {
                what: "hierarchy level 0 (one vertex per mesh vertex)",
                expected: system.vertex_count(),
                found: hierarchy.level(0).graph.n(),
            });
        }
        if let Some(kind) = method.hierarchy_kind() {
            if hierarchy.levels() > 1 && hierarchy.kind() != kind {
                return Err(SparseError::InvalidOption(format!(
                    "{method:?} runs on a hierarchy of kind {kind:?}, not {:?}",
                    hierarchy.kind()
                ))
                .into());
            }
        }
        let prepared = prepare(system, &hierarchy, method)?;
        Ok(Self { hierarchy, method, prepared })
    }

    /// Rebuilds the matrix-dependent parts after the media changed (the hierarchy is kept; for
    /// [`Method::AggregationPcg`] that includes its prolongations, smoothed with the matrix it
    /// was built for: still a valid, if slightly weaker, V-cycle for the new one).
    ///
    /// # Errors
    /// As [`Self::with_hierarchy`].
    pub fn update_matrix(&mut self, system: &DiffusionSystem) -> Result<(), DiffusionError> {
        self.prepared = prepare(system, &self.hierarchy, self.method)?;
        Ok(())
    }

    /// Follows a change of the matrix confined to `rows` (after
    /// [`DiffusionSystem::update_media_rows`] or a refill of single media entries) more cheaply
    /// than [`Self::update_matrix`], with the same result: [`Method::MultigridPcg`] and
    /// [`Method::AggregationPcg`] recompute
    /// only what the rows reach ([`Multigrid::refresh`]); [`Method::SsorPcg`] rescales its
    /// triangles in its kept ordering ([`crate::sparse::Ssor::refresh`]); [`Method::Pcg`] and
    /// [`Method::Cascade`] prepare afresh (cheap, or not built row by row). On error the solver
    /// is unchanged, except as [`Multigrid::refresh`] says for a matrix that is not SPD.
    ///
    /// # Errors
    /// As [`Self::with_hierarchy`]; [`DiffusionError::Sparse`] for a row outside the matrix.
    pub fn refresh_rows(&mut self, system: &DiffusionSystem, rows: &[u32]) -> Result<(), DiffusionError> {
        match &mut self.prepared {
            Prepared::Multigrid(m) => m.refresh(system.matrix(), rows)?,
            Prepared::Pcg(Preconditioner::Ssor(s)) => s.refresh(system.matrix())?,
            _ => self.update_matrix(system)?,
        }
        Ok(())
    }

    /// The hierarchy.
    #[must_use]
    pub fn hierarchy(&self) -> &Arc<Hierarchy> {
        &self.hierarchy
    }

    /// The method.
    #[must_use]
    pub fn method(&self) -> Method {
        self.method
    }

    /// The multigrid of [`Method::MultigridPcg`] and [`Method::AggregationPcg`] (`None` for the
    /// other methods), e.g. for
    /// [`crate::gpu::GpuSolver::with_multigrid`].
    #[must_use]
    pub fn multigrid(&self) -> Option<&Multigrid> {
        match &self.prepared {
            Prepared::Multigrid(m) => Some(m),
            _ => None,
        }
    }

    /// [`Self::solve`] on `backend`: [`Method::Pcg`], [`Method::MultigridPcg`] and
    /// [`Method::AggregationPcg`] run on the GPU
    /// when it is chosen (the V-cycle on the device, see [`crate::gpu::GpuSolver::with_multigrid`]);
    /// [`Method::Cascade`] runs on the CPU ([`crate::gpu::BackendReport::fallback`] says so under
    /// `Auto`; `Gpu` is an error). See [`crate::gpu::solve_multires_on`].
    ///
    /// # Errors
    /// Those of [`crate::gpu::solve_multires_on`].
    pub fn solve_on(
        &self,
        backend: crate::gpu::Backend,
        system: &DiffusionSystem,
        warm_start: Option<&[[f64; 3]]>,
        options: &SolveOptions<'_>,
    ) -> Result<(Solution, crate::gpu::BackendReport), crate::gpu::GpuError> {
        crate::gpu::solve_multires_on(backend, self, system, warm_start, options)
    }

    /// Solves `M φ = b` of `system` (the one this solver was prepared for), from `warm_start`
    /// (a previous φ) or cold.
    ///
    /// # Errors
    /// [`DiffusionError::LengthMismatch`] for a warm start of the wrong length;
    /// [`DiffusionError::NotConverged`] when a channel misses the tolerance;
    /// [`DiffusionError::Sparse`] for the solvers' own errors.
    pub fn solve(
        &self,
        system: &DiffusionSystem,
        warm_start: Option<&[[f64; 3]]>,
        options: &SolveOptions<'_>,
    ) -> Result<Solution, DiffusionError> {
        let n = system.vertex_count();
        let mut phi = match warm_start {
            Some(x) if x.len() != n => {
                return Err(DiffusionError::LengthMismatch {
                    what: "warm start (one entry per vertex)",
                    expected: n,
                    found: x.len(),
                })
            }
            Some(x) => x.to_vec(),
            None => vec![[0.0; 3]; n],
        };
        let (a, b) = (system.matrix(), system.rhs());
        let stats = match &self.prepared {
            Prepared::Pcg(p) => pcg(a, b, &mut phi, p, options)?,
            Prepared::Cascade(c) => c.solve(a, b, &mut phi, warm_start.is_some(), options)?.fine,
            Prepared::Multigrid(m) => mg_pcg(a, b, &mut phi, m, options)?,
        };
        if !stats.converged {
            return Err(DiffusionError::NotConverged {
                iterations: stats.iterations,
                residual: stats.relative_residual,
                tolerance: options.tolerance,
            });
        }
        Ok(Solution { phi, stats })
    }
}

fn prepare(system: &DiffusionSystem, h: &Arc<Hierarchy>, method: Method) -> Result<Prepared, DiffusionError> {
    let a = system.matrix();
    Ok(match method {
        Method::Pcg => Prepared::Pcg(Preconditioner::new(a, PreconditionerKind::Jacobi)?),
        Method::Cascade => Prepared::Cascade(Cascade::new(Arc::clone(h), a, CascadeOptions::default())?),
        Method::MultigridPcg | Method::AggregationPcg => {
            Prepared::Multigrid(Multigrid::new(Arc::clone(h), a, MultigridOptions::default())?)
        }
        Method::SsorPcg => Prepared::Pcg(Preconditioner::new(a, PreconditionerKind::Ssor)?),
    })
}
