//! The solvers of a [`DiffusionSystem`]: one [`Solver`] type, prepared once per matrix for a
//! [`SolverKind`], solving M φ = b for the three channels from a warm start or cold.
//!
//! The kinds, all reaching the same answer (level-0 residual `‖b − Mφ‖/‖b‖ ≤ tolerance`):
//! - [`SolverKind::Pcg`]: single-level CG with the Jacobi preconditioner in mixed precision
//!   (the device's solver, [`crate::gpu`]);
//! - [`SolverKind::SsorPcg`]: single-level CG with the SSOR preconditioner
//!   ([`crate::sparse::Ssor`]): the cold solve of a bake ([`super::solve()`]);
//! - [`SolverKind::Cascade`]: TransCut §4.2's coarse-to-fine cascade on the §4.1 hierarchy
//!   (BiCGSTAB on the eq.-17 coarse systems, CG at level 0, each level started from the
//!   interpolated coarser solution);
//! - [`SolverKind::MultigridPcg`]: CG preconditioned by a Galerkin V-cycle on the same
//!   hierarchy;
//! - [`SolverKind::AggregationPcg`]: the same V-cycle on a smoothed-aggregation hierarchy built
//!   from the matrix ([`Hierarchy::aggregated`], Vaněk et al. 1996), whose levels shrink about
//!   20-fold instead of 3-fold: the editor's solver.
//!
//! The hierarchy depends on the mesh only and is kept while the mesh is the same; the
//! matrix-dependent parts (preconditioner, coarse operators) follow the media
//! ([`Solver::update_matrix`], [`Solver::refresh_rows`]); a new source needs nothing. Where the
//! solve runs (CPU or GPU) is chosen one level up, by [`crate::gpu::solve_on`]. Measurements of
//! the kinds against each other are in `docs/benchmarks.md` (`transcut bench multires`).

use std::sync::Arc;

use super::error::DiffusionError;
use super::solve::Solution;
use super::system::DiffusionSystem;
use crate::sparse::hierarchy::{
    mg_pcg, Cascade, CascadeOptions, Hierarchy, HierarchyKind, HierarchyOptions, Multigrid, MultigridOptions,
};
use crate::sparse::{pcg, Preconditioner, PreconditionerKind, SolveOptions, SparseError};

/// Which solver a [`Solver`] runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum SolverKind {
    /// Single-level CG with the Jacobi preconditioner, mixed precision.
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

impl SolverKind {
    /// Every kind, in the order front ends list them.
    pub const ALL: [SolverKind; 5] = [Self::Pcg, Self::SsorPcg, Self::Cascade, Self::MultigridPcg, Self::AggregationPcg];

    /// The name front ends use (`pcg`, `ssor-pcg`, `cascade`, `mg-pcg`, `sa-pcg`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Pcg => "pcg",
            Self::SsorPcg => "ssor-pcg",
            Self::Cascade => "cascade",
            Self::MultigridPcg => "mg-pcg",
            Self::AggregationPcg => "sa-pcg",
        }
    }

    /// The kind called `name` ([`Self::name`], any case), or `None`.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        let name = name.trim();
        Self::ALL.into_iter().find(|k| k.name().eq_ignore_ascii_case(name))
    }

    /// One line saying what the kind is.
    #[must_use]
    pub fn description(self) -> &'static str {
        match self {
            Self::Pcg => "CG with the Jacobi preconditioner (mixed precision; the GPU's single-level solver)",
            Self::SsorPcg => "CG with the SSOR preconditioner (the bake's cold solve on the CPU)",
            Self::Cascade => "TransCut §4.2 coarse-to-fine cascade (BiCGSTAB on coarse levels, CG at level 0)",
            Self::MultigridPcg => "CG preconditioned by a V-cycle on the TransCut §4.1 hierarchy",
            Self::AggregationPcg => "CG preconditioned by a V-cycle on a smoothed-aggregation hierarchy (the editor's solver)",
        }
    }

    /// Whether the kind works on level 0 alone (needs no hierarchy).
    #[must_use]
    pub fn is_single_level(self) -> bool {
        matches!(self, Self::Pcg | Self::SsorPcg)
    }

    /// The kind of hierarchy the solver runs on (`None` for a single-level kind).
    #[must_use]
    pub fn hierarchy_kind(self) -> Option<HierarchyKind> {
        match self {
            Self::Pcg | Self::SsorPcg => None,
            Self::Cascade | Self::MultigridPcg => Some(HierarchyKind::IndependentSets),
            Self::AggregationPcg => Some(HierarchyKind::Aggregation),
        }
    }
}

impl std::fmt::Display for SolverKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
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
/// and the kind's matrix-dependent parts (rebuilt by [`Solver::update_matrix`] after
/// [`DiffusionSystem::set_media`]; a new source needs nothing).
#[derive(Debug, Clone)]
pub struct Solver {
    /// `None` for a single-level kind made by [`Solver::new`], which needs none.
    hierarchy: Option<Arc<Hierarchy>>,
    kind: SolverKind,
    prepared: Prepared,
}

impl Solver {
    /// Builds the hierarchy of `system` (none for a single-level kind, [`SolverKind::Pcg`] or
    /// [`SolverKind::SsorPcg`]; [`SolverKind::AggregationPcg`] aggregates the matrix itself) and
    /// prepares `kind` for its matrix.
    ///
    /// # Errors
    /// [`DiffusionError::Sparse`] from the hierarchy or the coarse operators.
    pub fn new(system: &DiffusionSystem, kind: SolverKind, options: &HierarchyOptions) -> Result<Self, DiffusionError> {
        Self::new_with(system, kind, options, &|| true)
    }

    /// [`Self::new`] asking `keep_going` before each level of the hierarchy is coarsened
    /// ([`Hierarchy::build_with`]) and before the matrix-dependent parts are prepared, so that
    /// a caller can cancel inside the build.
    ///
    /// # Errors
    /// As [`Self::new`]; [`DiffusionError::Sparse`] with [`SparseError::Cancelled`] when
    /// `keep_going` returns `false`.
    pub fn new_with(
        system: &DiffusionSystem,
        kind: SolverKind,
        options: &HierarchyOptions,
        keep_going: &dyn Fn() -> bool,
    ) -> Result<Self, DiffusionError> {
        let check = || if keep_going() { Ok(()) } else { Err(SparseError::Cancelled { iteration: 0 }) };
        check()?;
        if kind == SolverKind::AggregationPcg {
            let mg =
                Multigrid::aggregated(system.matrix(), &system.structure().positions_mm, options, MultigridOptions::default())?;
            return Ok(Self { hierarchy: Some(Arc::clone(mg.hierarchy())), kind, prepared: Prepared::Multigrid(mg) });
        }
        if kind.is_single_level() {
            return Ok(Self { hierarchy: None, kind, prepared: prepare(system, None, kind)? });
        }
        let hierarchy = Hierarchy::build_with(system.pattern(), &system.structure().positions_mm, options, keep_going)?;
        check()?;
        Self::with_hierarchy(system, Arc::new(hierarchy), kind)
    }

    /// Prepares `kind` for `system` on a ready hierarchy of its mesh, of the kind the solver
    /// runs on ([`SolverKind::hierarchy_kind`]; any hierarchy for a single-level kind).
    ///
    /// # Errors
    /// [`DiffusionError::LengthMismatch`] if the hierarchy belongs to another mesh;
    /// [`DiffusionError::Sparse`] for a hierarchy of another kind, and from the coarse
    /// operators.
    pub fn with_hierarchy(system: &DiffusionSystem, hierarchy: Arc<Hierarchy>, kind: SolverKind) -> Result<Self, DiffusionError> {
        if hierarchy.level(0).graph.n() != system.vertex_count() {
            return Err(DiffusionError::LengthMismatch {
                what: "hierarchy level 0 (one vertex per mesh vertex)",
                expected: system.vertex_count(),
                found: hierarchy.level(0).graph.n(),
            });
        }
        if let Some(needed) = kind.hierarchy_kind() {
            if hierarchy.levels() > 1 && hierarchy.kind() != needed {
                return Err(SparseError::InvalidOption(format!(
                    "{kind} runs on a hierarchy of kind {needed:?}, not {:?}",
                    hierarchy.kind()
                ))
                .into());
            }
        }
        let prepared = prepare(system, Some(&hierarchy), kind)?;
        Ok(Self { hierarchy: Some(hierarchy), kind, prepared })
    }

    /// Rebuilds the matrix-dependent parts after the media changed (the hierarchy is kept; for
    /// [`SolverKind::AggregationPcg`] that includes its prolongations, smoothed with the matrix
    /// it was built for: still a valid, if slightly weaker, V-cycle for the new one).
    ///
    /// # Errors
    /// As [`Self::with_hierarchy`].
    pub fn update_matrix(&mut self, system: &DiffusionSystem) -> Result<(), DiffusionError> {
        self.prepared = prepare(system, self.hierarchy.as_ref(), self.kind)?;
        Ok(())
    }

    /// Follows a change of the matrix confined to `rows` (after
    /// [`DiffusionSystem::update_media_rows`] or a refill of single media entries) more cheaply
    /// than [`Self::update_matrix`], with the same result: [`SolverKind::MultigridPcg`] and
    /// [`SolverKind::AggregationPcg`] recompute only what the rows reach
    /// ([`Multigrid::refresh`]); [`SolverKind::SsorPcg`] rescales its triangles in its kept
    /// ordering ([`crate::sparse::Ssor::refresh`]); [`SolverKind::Pcg`] and
    /// [`SolverKind::Cascade`] prepare afresh (cheap, or not built row by row). On error the
    /// solver is unchanged, except as [`Multigrid::refresh`] says for a matrix that is not SPD.
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

    /// The hierarchy (`None` for a single-level kind made by [`Solver::new`]).
    #[must_use]
    pub fn hierarchy(&self) -> Option<&Arc<Hierarchy>> {
        self.hierarchy.as_ref()
    }

    /// The kind.
    #[must_use]
    pub fn kind(&self) -> SolverKind {
        self.kind
    }

    /// The multigrid of [`SolverKind::MultigridPcg`] and [`SolverKind::AggregationPcg`]
    /// (`None` for the other kinds), which the device's V-cycle runs on
    /// ([`crate::gpu::GpuSolver::with_multigrid`]).
    #[must_use]
    pub fn multigrid(&self) -> Option<&Multigrid> {
        match &self.prepared {
            Prepared::Multigrid(m) => Some(m),
            _ => None,
        }
    }

    /// Solves `M φ = b` of `system` (the one this solver was prepared for) on the CPU, from
    /// `warm_start` (a previous φ) or cold.
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
        let mut phi = start_vector(system.vertex_count(), warm_start)?;
        let (a, b) = (system.matrix(), system.rhs());
        let stats = match &self.prepared {
            Prepared::Pcg(p) => pcg(a, b, &mut phi, p, options)?,
            Prepared::Cascade(c) => c.solve(a, b, &mut phi, warm_start.is_some(), options)?.fine,
            Prepared::Multigrid(m) => mg_pcg(a, b, &mut phi, m, options)?,
        };
        Solution::converged(phi, stats, options.tolerance)
    }
}

/// The iterate a solve of `n` unknowns starts from: `warm_start` (one entry per vertex) or zero.
///
/// # Errors
/// [`DiffusionError::LengthMismatch`] for a warm start of the wrong length.
pub(crate) fn start_vector(n: usize, warm_start: Option<&[[f64; 3]]>) -> Result<Vec<[f64; 3]>, DiffusionError> {
    match warm_start {
        Some(x) if x.len() != n => {
            Err(DiffusionError::LengthMismatch { what: "warm start (one entry per vertex)", expected: n, found: x.len() })
        }
        Some(x) => Ok(x.to_vec()),
        None => Ok(vec![[0.0; 3]; n]),
    }
}

/// The matrix-dependent parts of `kind` for `system`, on the hierarchy `h` (which every kind but
/// the single-level ones has).
fn prepare(system: &DiffusionSystem, h: Option<&Arc<Hierarchy>>, kind: SolverKind) -> Result<Prepared, DiffusionError> {
    let a = system.matrix();
    let h = || h.cloned().ok_or_else(|| SparseError::InvalidOption(format!("{kind} needs a hierarchy")));
    Ok(match kind {
        SolverKind::Pcg => Prepared::Pcg(Preconditioner::new(a, PreconditionerKind::Jacobi)?),
        SolverKind::SsorPcg => Prepared::Pcg(Preconditioner::new(a, PreconditionerKind::Ssor)?),
        SolverKind::Cascade => Prepared::Cascade(Cascade::new(h()?, a, CascadeOptions::default())?),
        SolverKind::MultigridPcg | SolverKind::AggregationPcg => {
            Prepared::Multigrid(Multigrid::new(h()?, a, MultigridOptions::default())?)
        }
    })
}
