//! The parallel multiresolution hierarchy of TransCut §4 (Li et al., TVCG 2013) and the solvers
//! built on it.
//!
//! * [`Hierarchy`] (§4.1): progressively coarser graphs `G^l = (P^l, E^l)` of the mesh's vertex
//!   graph. `P^{l+1}` is an independent set of `P^l` chosen in parallel rounds with hashed
//!   random codes ([`codes`]), enhanced until no edge connection is lost, and `E^{l+1}` links
//!   vertices that were two-ring neighbours (`edges.rs`). Each level carries the interpolation
//!   `P` of eq. 16 with 1/edge-length weights ([`Prolongation`]).
//! * [`substituted`] (eq. 17) and [`galerkin`] (`Pᵀ M P`, and [`galerkin_rows`] to follow a
//!   change of some fine rows): coarse operators (`coarse.rs`).
//! * [`Cascade`] (§4.2): the paper's coarse-to-fine solver — BiCGSTAB on the (nonsymmetric)
//!   eq.-17 systems from the coarsest level up, each level started from the interpolated
//!   coarser solution, CG at level 0.
//! * [`Multigrid`] / [`mg_pcg`]: the same `P` used as a symmetric multigrid V-cycle
//!   (Galerkin operators, Chebyshev–Jacobi smoothing, dense Cholesky at the coarsest level) to
//!   precondition CG.
//! * [`Hierarchy::aggregated`] / [`Multigrid::aggregated`]: an algebraic alternative to §4.1,
//!   smoothed aggregation (`aggregation.rs`), on which the same V-cycle runs: each level
//!   shrinks by about the size of a vertex neighbourhood and its Galerkin operator stays
//!   sparse, so the hierarchy costs far less to build than the §4.1 one.
//!
//! Everything is deterministic for a given seed, for any number of rayon threads.
//!
//! # Which solver
//!
//! All of them meet the tolerance on the level-0 system. The Galerkin operators of the §4.1
//! levels fill in (a coarse level can have more nonzeros than the level above), so the
//! multigrid's setup costs far more than a single-level PCG solve, while MG-PCG needs only a
//! few iterations where PCG needs many: it pays off for repeated solves on one matrix
//! (relighting, the §5 edits that keep the matrix), and [`Multigrid::refresh`] follows a local
//! change of the matrix without a rebuild. The cascade's coarse levels only give level-0 PCG a
//! start, and a warm start skips them. The diffusion solver's cold solve of a bake is a
//! single-level PCG.

mod aggregation;
mod cascade;
mod coarse;
pub mod codes;
mod edges;
mod interpolation;
mod multigrid;

use std::sync::Arc;

use glam::DVec3;

pub use aggregation::{aggregates, smoothed_prolongation};
pub use cascade::{Cascade, CascadeOptions, CascadeStats};
pub use coarse::{galerkin, galerkin_rows, substituted};
pub use edges::lost_connections;
pub use interpolation::Prolongation;
pub use multigrid::{mg_pcg, Multigrid, MultigridOptions};

use super::{CsrPattern, SparseError};

/// Options of [`Hierarchy::build`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct HierarchyOptions {
    /// Seed of the random vertex codes (§4.1.1). Default 1.
    pub seed: u32,
    /// Stop coarsening once a level has at most this many vertices. Default 150: the
    /// multigrid factors the coarsest Galerkin operator densely (three channels, `n³/3` flops
    /// each), on setup and whenever a paint reaches it ([`Multigrid::refresh`]), so a small
    /// coarsest level keeps a refresh cheap; one more level costs the V-cycle little.
    pub min_vertices: usize,
    /// Stop coarsening when a level keeps more than this fraction of the vertices of the level
    /// above (the graph no longer shrinks usefully). Default 0.8.
    pub max_ratio: f64,
    /// At most this many levels including level 0. Default 20.
    pub max_levels: usize,
}

impl Default for HierarchyOptions {
    fn default() -> Self {
        Self { seed: 1, min_vertices: 150, max_ratio: 0.8, max_levels: 20 }
    }
}

impl HierarchyOptions {
    /// Checks the options (`max_ratio` in (0, 1], `max_levels` at least 1) and the `positions`
    /// of an input of `n` vertices (one each, finite).
    fn check_input(&self, n: usize, positions: &[DVec3]) -> Result<(), SparseError> {
        if positions.len() != n {
            return Err(SparseError::DimensionMismatch {
                what: "positions (one per vertex)",
                expected: n,
                found: positions.len(),
            });
        }
        if !(self.max_ratio > 0.0 && self.max_ratio <= 1.0) || self.max_levels == 0 {
            return Err(SparseError::InvalidOption(format!(
                "hierarchy options: max_ratio {} must be in (0, 1] and max_levels {} at least 1",
                self.max_ratio, self.max_levels
            )));
        }
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(SparseError::InvalidOption(format!("position of vertex {i} is not finite")));
        }
        Ok(())
    }

    /// Sets the seed.
    #[must_use]
    pub fn with_seed(mut self, seed: u32) -> Self {
        self.seed = seed;
        self
    }

    /// Sets the vertex count at which coarsening stops.
    #[must_use]
    pub fn with_min_vertices(mut self, min_vertices: usize) -> Self {
        self.min_vertices = min_vertices;
        self
    }
}

/// One level `G^l` of the hierarchy.
#[derive(Debug, Clone, PartialEq)]
pub struct Level {
    /// The graph as a symmetric pattern (off-diagonal entries are the edges `E^l`).
    pub graph: Arc<CsrPattern>,
    /// Vertex positions (those of the retained fine vertices).
    pub positions: Vec<DVec3>,
    /// For levels above 0: the size of the independent set before enhancement (the aggregate
    /// count of an aggregation level).
    pub independent: usize,
    /// For levels above 0: enhancement rounds that added vertices.
    pub enhancement_rounds: usize,
}

impl Level {
    /// Level 0: the input graph and positions.
    fn finest(graph: &Arc<CsrPattern>, positions: &[DVec3]) -> Self {
        Self { graph: Arc::clone(graph), positions: positions.to_vec(), independent: graph.n(), enhancement_rounds: 0 }
    }
}

/// How the levels of a [`Hierarchy`] were made.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum HierarchyKind {
    /// TransCut §4.1 ([`Hierarchy::build`]): each level an enhanced independent set of the
    /// level above, interpolated by eq. 16. The cascade and the V-cycle run on it.
    IndependentSets,
    /// Smoothed aggregation ([`Hierarchy::aggregated`]): each coarse vertex an aggregate of
    /// fine ones. Only the V-cycle runs on it (no vertex is retained for eq. 17).
    Aggregation,
}

/// The multiresolution hierarchy (TransCut §4.1, or the smoothed-aggregation alternative):
/// levels `0..levels()`, level 0 the input graph, and the interpolation from every level
/// `l + 1` to `l`.
#[derive(Debug, Clone, PartialEq)]
pub struct Hierarchy {
    kind: HierarchyKind,
    levels: Vec<Level>,
    prolongations: Vec<Prolongation>,
}

impl Hierarchy {
    /// Builds the hierarchy of `graph` (the mesh's vertex graph, e.g. the diffusion matrix's
    /// pattern) with vertex `positions`, coarsening until a level has at most
    /// `options.min_vertices` vertices, stops shrinking, or `options.max_levels` is reached.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `positions` does not have one entry per vertex;
    /// [`SparseError::InvalidOption`] for a non-symmetric graph, non-finite positions, or bad
    /// options.
    pub fn build(graph: &Arc<CsrPattern>, positions: &[DVec3], options: &HierarchyOptions) -> Result<Self, SparseError> {
        Self::build_with(graph, positions, options, &|| true)
    }

    /// [`Self::build`] asking `keep_going` before each level is coarsened and before its
    /// prolongation is built, so that a caller can cancel inside the build (the first level is
    /// the largest part of it).
    ///
    /// # Errors
    /// As [`Self::build`]; [`SparseError::Cancelled`] (its `iteration` the number of levels
    /// built) when `keep_going` returns `false`.
    pub fn build_with(
        graph: &Arc<CsrPattern>,
        positions: &[DVec3],
        options: &HierarchyOptions,
        keep_going: &dyn Fn() -> bool,
    ) -> Result<Self, SparseError> {
        options.check_input(graph.n(), positions)?;
        if !graph.is_structurally_symmetric() {
            return Err(SparseError::InvalidOption("the hierarchy needs a symmetric graph".into()));
        }
        let mut levels = vec![Level::finest(graph, positions)];
        let mut prolongations = Vec::new();
        while levels.len() < options.max_levels {
            if !keep_going() {
                return Err(SparseError::Cancelled { iteration: levels.len() });
            }
            let fine = levels.last().expect("level 0 exists");
            let nf = fine.graph.n();
            if nf <= options.min_vertices.max(1) {
                break;
            }
            let l = levels.len() as u32;
            let codes = codes::vertex_codes(nf, options.seed.wrapping_add(l.wrapping_mul(0x9E37_79B9)));
            let step = edges::coarsen(&fine.graph, &codes)?;
            if step.retained.len() as f64 > options.max_ratio * nf as f64 {
                break;
            }
            if !keep_going() {
                return Err(SparseError::Cancelled { iteration: levels.len() });
            }
            let p = Prolongation::new(&fine.graph, &fine.positions, &step.retained)?;
            let positions = step.retained.iter().map(|&i| fine.positions[i as usize]).collect();
            prolongations.push(p);
            levels.push(Level {
                graph: Arc::new(step.graph),
                positions,
                independent: step.independent,
                enhancement_rounds: step.enhancement_rounds,
            });
        }
        Ok(Self { kind: HierarchyKind::IndependentSets, levels, prolongations })
    }

    /// How the levels were made.
    #[must_use]
    pub fn kind(&self) -> HierarchyKind {
        self.kind
    }

    /// The number of levels (1 when the input was already small).
    #[must_use]
    pub fn levels(&self) -> usize {
        self.levels.len()
    }

    /// Level `l`.
    ///
    /// # Panics
    /// If `l >= levels()`.
    #[must_use]
    pub fn level(&self, l: usize) -> &Level {
        &self.levels[l]
    }

    /// The interpolation from level `l + 1` to level `l` (eq. 16).
    ///
    /// # Panics
    /// If `l + 1 >= levels()`.
    #[must_use]
    pub fn prolongation(&self, l: usize) -> &Prolongation {
        &self.prolongations[l]
    }

    /// The vertex count of every level, finest first.
    #[must_use]
    pub fn vertex_counts(&self) -> Vec<usize> {
        self.levels.iter().map(|l| l.graph.n()).collect()
    }
}

/// Checks the invariants of TransCut §4.1 between level `l` and `l + 1` of `h`, returning a
/// description of the first violation: every dropped vertex has a retained neighbour; no edge
/// connection is lost (for every fine edge `(i, j)`, the interpolation supports `S(i)`, `S(j)`
/// — `{i}` for a retained vertex, `R(i)` for a dropped one — share a vertex, or both ends are
/// retained and adjacent at level `l + 1`); every coarse edge joins two-ring neighbours of
/// level `l`.
///
/// # Errors
/// The violated invariant, in words.
pub fn check_invariants(h: &Hierarchy, l: usize) -> Result<(), String> {
    let fine = &h.level(l).graph;
    let coarse = &h.level(l + 1).graph;
    let p = h.prolongation(l);
    let support = |i: usize| -> Vec<u32> {
        match p.coarse_of(i) {
            Some(c) => vec![c as u32],
            None => fine.row(i).iter().filter_map(|&j| p.coarse_of(j as usize).map(|c| c as u32)).collect(),
        }
    };
    for i in 0..fine.n() {
        let si = support(i);
        if si.is_empty() {
            return Err(format!("level {l}: dropped vertex {i} has no retained neighbour"));
        }
        for &j in fine.row(i) {
            let j = j as usize;
            if j <= i {
                continue;
            }
            let sj = support(j);
            let shared = si.iter().any(|a| sj.contains(a));
            let adjacent =
                p.coarse_of(i).is_some() && p.coarse_of(j).is_some() && coarse.position(si[0] as usize, sj[0] as usize).is_some();
            if !shared && !adjacent {
                return Err(format!("level {l}: the connection of edge ({i}, {j}) is lost"));
            }
        }
    }
    for c in 0..coarse.n() {
        let i = p.retained()[c] as usize;
        for &d in coarse.row(c) {
            let j = p.retained()[d as usize] as usize;
            let two_ring =
                i == j || fine.position(i, j).is_some() || fine.row(i).iter().any(|&k| fine.position(k as usize, j).is_some());
            if !two_ring {
                return Err(format!("level {}: edge ({c}, {d}) joins fine vertices {i}, {j} beyond two rings", l + 1));
            }
        }
    }
    Ok(())
}
