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
//!   smoothed aggregation (`aggregation.rs`), on which the same V-cycle runs: levels that
//!   shrink about 20-fold (93 481 → 4 253 → 85 on the 500k-tet bunny, coarse operators adding
//!   12% to the level-0 nonzeros), built in about 0.1 s; CG needs 15/14/13 iterations to 1e-6.
//!
//! Everything is deterministic for a given seed, for any number of rayon threads.
//!
//! # Measured (bunny, 60 mm, marble, one sun; 507 851 tets, 93 481 vertices)
//!
//! `transcut bench multires --tets 500000 --runs 3`, release build, 2 shared cores, methods
//! interleaved run by run, medians of 3. Levels 93 481 → 32 941 → 9 476 → 2 425 → 540; the
//! Galerkin operators have 1.33 M (level 0), 1.68 M, 1.04 M, 0.40 M and 0.09 M nonzeros (they
//! fill in: level 1 has more than level 0).
//!
//! **MG-PCG after the V-cycle rework** (`f32` level operators, fused smoothing passes, a reused
//! workspace, degree-1 smoothing over `[λmax/4, λmax]`, sort-free Galerkin products; see
//! `vcycle.rs`) against the version before it, whole benchmarks alternated old/new under a
//! load of 5–6 (other builds on the 2 cores; absolute times are 2–3× those of a quiet machine,
//! the ratios within one run hold):
//!
//! | MG-PCG          | setup ms | to 1e-6: ms, iterations | ms per iteration | error after 2 / 3 iterations | time to 1% ms | PCG's time to 1% ms (same run) | ratio |
//! |-----------------|----------|-------------------------|------------------|------------------------------|---------------|--------------------------------|-------|
//! | before (3 runs) | 5413 / 6056 / 6177 | 647 / 856 / 970, 10 | 65 / 86 / 97 | 1.61% / 0.39% | 205 / 267 / 263 | 207 / 262 / 193 | 0.99 / 1.02 / 1.36 |
//! | after (4 runs)  | 4229 / 4772 / 3071 / 3082 | 155 / 154 / 240 / 259, 7 | 22 / 22 / 34 / 37 | 0.27% / 0.03% | 48 / 48 / 70 / 78 | 161 / 170 / 231 / 309 | 0.30 / 0.28 / 0.30 / 0.25 |
//!
//! (The last two "after" runs include the sort-free Galerkin product, setup −1.5 s.) Two more
//! runs at commit a2fe343, whose PCG then kept its search direction in `f32` (since reverted:
//! measured slower, which flatters these two ratios), under a load of 6:
//! MG-PCG 1% in 76 / 77 ms, PCG in 347 / 318 ms, ratio 0.22 / 0.24; 7 iterations to 1e-6 in
//! 258 / 251 ms; setup 3115 / 3220 ms. MG-PCG now
//! reaches 1% error in 2 iterations at 0.25–0.30 of single-level PCG's time, the goal
//! being ≤ 0.5; the error at tolerance 1e-6 is 7e-8, and the warm start after moving the sun 5°
//! takes 6/6/5 iterations against 7 cold. Where the time went before: the degree-2 smoother
//! over `[λmax/30, λmax]` damped the high frequencies too little (10 iterations, 1.6% after 2;
//! the interval ratio alone, measured 30 → 10 → 5 → 4 → 3 → 2 at degree 1, took the iterations
//! to 1e-6 from 13 to 9, 7, 7, 7, 8, and degree 2 at ratio 5 needs 5 iterations but twice the
//! products), every V-cycle allocated its vectors afresh, and the operators were `f64`.
//! Lumping the weak Galerkin entries onto the diagonal to curb the fill-in was tried and
//! dropped: dropping entries below 0.5% / 1% of `√(a_ii a_jj)` cut the nonzeros of levels 1–3
//! by 48% / 65% but raised the error after 2 iterations from 0.26% to 0.55% / 3.3% (ratio 5).
//!
//! **Before the rework**, two whole-benchmark runs, A under a load of 10–12 and B under 2.5–5
//! (the 5° rotation exact in B only):
//!
//! | method (run)  | setup ms | solve to 1e-6 ms | iterations R/G/B | time to 1% error ms |
//! |---------------|----------|------------------|------------------|---------------------|
//! | PCG (A / B)     | 91 / 35 | 888 / 658 | 125/107/86 (level 0) | 504 / 281 |
//! | cascade (A / B) | 1158 / 1094 | 703 / 732 | 105/90/75 (level 0) | 319 / 294 |
//! | MG-PCG (A / B)  | 12 071 / 6520 | 1320 / 1033 | 10/10/10 | 415 / 327 |
//!
//! The hierarchy takes 0.7–1.2 s. The cascade's time to 1% is 0.63 (A) / 1.05 (B) of PCG's. The
//! error at tolerance 1e-6 is 2e-6 for PCG and the cascade (‖φ − φ*‖/‖φ*‖). Warm start after
//! moving the sun 5° (B): 99/83/69 iterations against 125/107/86 cold for PCG (and the cascade,
//! whose warm start is level-0 PCG). MG-PCG's setup (hierarchy and Galerkin operators, 3–6 s
//! under load) still costs far more than a PCG solve, so it pays off for repeated solves on one
//! matrix (relighting, §5 edits that keep the matrix), and a single-level PCG stays the solver
//! of [`crate::diffusion::solve()`] (SSOR-preconditioned since session 7).

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
    /// multigrid factors the coarsest Galerkin operator densely (three channels, `n³/3` each),
    /// on setup and whenever a paint reaches it ([`Multigrid::refresh`]); on the 500k-tet bunny
    /// a stop at 600 left 540 vertices (27 ms per factorisation, a fifth of a refresh), a stop
    /// at 150 one level more with 110 (0.3 ms), with the same iteration counts (the error
    /// after 2 MG-PCG iterations rises from 0.37% to 0.59%; 1% is still reached in 2).
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
        options.check_input(graph.n(), positions)?;
        if !graph.is_structurally_symmetric() {
            return Err(SparseError::InvalidOption("the hierarchy needs a symmetric graph".into()));
        }
        let mut levels = vec![Level::finest(graph, positions)];
        let mut prolongations = Vec::new();
        while levels.len() < options.max_levels {
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
