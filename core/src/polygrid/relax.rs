//! The paper's relaxation solvers on a polygrid (J. Wang et al. 2008 §5.2–5.3, Fig. 8 and
//! Fig. 15; design note polygrid-and-inverse.md §1.10–1.11): the paper-faithful path beside
//! PCG.
//!
//! A [`RelaxHierarchy`] holds the system of the finest polygrid and of `levels − 1` coarsenings
//! ([`Polygrid::coarsened`]: the nodes of even lattice coordinates, the trilinear
//! [`Prolongation`]), each assembled by the caller's [`Stencil`]:
//!
//! - finite volumes ([`PolygridSystem::finite_volume`]) or P1 on the Kuhn split
//!   ([`crate::diffusion::assemble`]) on every level;
//! - a coarse cell's medium is the mean of its children's σa and σ′s (and g), never of κ
//!   (§5.3, "averaging the … material properties of its eight children", normalised by how many
//!   exist; design note P14);
//! - a coarse boundary node's source q is the fine source at the same lattice point
//!   (injection), so one [`RelaxHierarchy::set_source`] lights every level.
//!
//! [`RelaxHierarchy::solve`] runs one of the paper's schemes ([`Schedule`]) with one of its
//! smoothers ([`Smoother`], the sweeps of [`crate::sparse::relax`]; Gauss–Seidel on a
//! [`ColourOrdered`] copy of each level's matrix, made by the first solve that needs it, so a
//! sweep streams the matrix: the same sweep bit for bit, at the cost of the matrix's memory):
//!
//! - [`Schedule::SingleLevel`]: Jacobi (§5.2, the GPU's ping-pong update) or Gauss–Seidel in the
//!   grid's parity colouring ([`Polygrid::parity_colours`], valid for both stencils) on the
//!   finest level alone, to the tolerance;
//! - [`Schedule::Hierarchical`]: §5.3's cascade ("a simplified N-cycle multigrid without
//!   V-cycles"): the coarsest level solved, its fluence prolonged as the start of the next finer
//!   level, relaxed, and so on to the finest;
//! - [`Schedule::Adaptive`]: the cascade with Fig. 8's freezing: after each prolongation the
//!   nodes deeper than that level's shell keep the prolonged value, only the shell near the
//!   surface is relaxed; the shell depth is set from the diffusion length
//!   ([`FreezeDepth`]: by default 3 ℓd on the finest level, twice that one level coarser, …),
//!   depth being the distance to the finest level's boundary quads (split in triangles, through
//!   a [`TriangleBvh`]). A sweep skips the frozen nodes (the paper drops texture blocks without
//!   an active node); their neighbours read them as fixed values. The result is not the
//!   finest level's solution: the frozen values carry the coarser level's error, which reaches
//!   the surface damped by about e^(−2d/ℓd); at 3 ℓd the boundary radiance stays within 1e-4
//!   RMS of PCG (measured 2–5e-5), at 1.4 ℓd within 1e-3.
//!
//! Frame coherence (§5.3, last paragraph): a [`RelaxState`] keeps every level's last solution;
//! [`Start::Warm`] starts the coarsest level from its previous solution and each finer level
//! from its previous solution plus the prolonged *change* of the coarser one, so a small change
//! of the light is corrected at every scale without losing the fine detail already solved.
//!
//! Every solve counts its node updates (the unit of Fig. 15's abscissa: the active rows of
//! every sweep, summed over levels) and records, per sweep, the estimated error, and, given a
//! [`RadianceReference`], the RMS relative error of the boundary radiance against it
//! (Fig. 15's ordinate, Σ(L − L₀)²/ΣL₀² under the square root, design note P16), on coarse
//! levels at their boundary nodes' lattice points.
//!
//! The stopping rule is an error estimate, not a residual: every `check_every` sweeps on the
//! finest level (every sweep on coarser ones) the RMS change of the iterate δ and the observed
//! contraction per sweep ρ (the slower of the last two, so three checks at least) give the
//! estimated relative RMS error δ ρ/(1 − ρ) of the fluence, per channel; a level is done when
//! it is at most its tolerance ([`RelaxOptions::tolerance`] on the finest level,
//! [`RelaxOptions::coarse_tolerance`] on coarser ones). A change at round-off counts as
//! converged; a change that grows three checks in a row is a breakdown (Jacobi with too large
//! an ω diverges on the Kuhn split's P1 matrix, which is not diagonally dominant).

use std::collections::HashMap;
use std::sync::OnceLock;

use glam::DVec3;
use rayon::prelude::*;

use super::error::PolygridError;
use super::grid::{Polygrid, Prolongation};
use super::system::PolygridSystem;
use super::Stencil;
use crate::diffusion::{self, DiffusionSystem};
use crate::mesh::{TetMesh, TetMeshError, TriangleBvh};
use crate::optics::{BoundaryTerms, Medium};
use crate::sparse::relax::{jacobi_sweep, ColourOrdered, Colouring};
use crate::sparse::{CsrMatrix3, SparseError};

/// Not a boundary node (in the finest level's boundary index).
const NOT_BOUNDARY: u32 = u32::MAX;

/// The relaxation of each sweep (§5.2).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Smoother {
    /// Weighted Jacobi, `x' = x + ω D⁻¹ (b − A x)` (the paper's GPU update has ω = 1).
    Jacobi {
        /// The damping ω, finite and > 0.
        omega: f64,
    },
    /// Gauss–Seidel colour by colour in the grid's parity colouring
    /// ([`Polygrid::parity_colours`]: 8 colours, 16 with a pillow), forward sweeps.
    GaussSeidel,
}

/// Which of the paper's schemes a solve runs (§5.2–5.3).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Schedule {
    /// The finest level alone.
    SingleLevel,
    /// The coarse-to-fine cascade over every level of the hierarchy (§5.3).
    Hierarchical,
    /// The cascade with the deep nodes of each finer level frozen after its prolongation
    /// (§5.3, Fig. 8).
    Adaptive(FreezeDepth),
}

/// The shells of the adaptive scheme (§5.3, Fig. 8): on level l (0 the finest) the nodes at most
/// `depth₀ · growthˡ` mm from the surface are relaxed, the deeper ones keep the value prolonged
/// from level l + 1; the coarsest level is relaxed whole. Design note P14: set from the
/// diffusion length, verified against a full solve.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct FreezeDepth {
    /// depth₀ in diffusion lengths ([`RelaxHierarchy::diffusion_length_mm`]). Default 3.
    pub factor: f64,
    /// depth₀ in millimetres instead of `factor` ℓd.
    pub depth_mm: Option<f64>,
    /// How much deeper each coarser level's shell is. Default 2 (the lattice spacing's growth).
    pub growth: f64,
}

impl Default for FreezeDepth {
    fn default() -> Self {
        Self { factor: 3.0, depth_mm: None, growth: 2.0 }
    }
}

impl FreezeDepth {
    /// `factor` diffusion lengths on the finest level.
    #[must_use]
    pub fn with_factor(mut self, factor: f64) -> Self {
        self.factor = factor;
        self
    }

    /// A depth in millimetres on the finest level.
    #[must_use]
    pub fn with_depth_mm(mut self, depth_mm: f64) -> Self {
        self.depth_mm = Some(depth_mm);
        self
    }

    /// The growth of the shell per coarser level.
    #[must_use]
    pub fn with_growth(mut self, growth: f64) -> Self {
        self.growth = growth;
        self
    }
}

/// Where a solve starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Start {
    /// From zero (the coarsest level; finer ones from the prolongation).
    Cold,
    /// From the [`RelaxState`]'s previous solutions (frame coherence, §5.3): a level without
    /// one starts as [`Start::Cold`] would.
    Warm,
}

/// What a solve does and when it stops.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct RelaxOptions {
    /// The sweep. Default Gauss–Seidel.
    pub smoother: Smoother,
    /// The scheme. Default hierarchical.
    pub schedule: Schedule,
    /// The finest level stops when its estimated relative RMS error of the fluence is at most
    /// this. Default 1e-5.
    pub tolerance: f64,
    /// The same for every coarser level of a cascade: a start for the next level, whose own
    /// discretisation differs by more than this. Default 1e-2.
    pub coarse_tolerance: f64,
    /// The most sweeps per level (the solve then reports `converged == false`). Default 100 000.
    pub max_sweeps: usize,
    /// Sweeps between two error estimates on the finest level (each costs a copy and a
    /// difference of the vector; coarser levels check every sweep), at least 1. Default 4.
    pub check_every: usize,
}

impl Default for RelaxOptions {
    fn default() -> Self {
        Self {
            smoother: Smoother::GaussSeidel,
            schedule: Schedule::Hierarchical,
            tolerance: 1e-5,
            coarse_tolerance: 1e-2,
            max_sweeps: 100_000,
            check_every: 4,
        }
    }
}

impl RelaxOptions {
    /// These options with `smoother`.
    #[must_use]
    pub fn with_smoother(mut self, smoother: Smoother) -> Self {
        self.smoother = smoother;
        self
    }

    /// These options with `schedule`.
    #[must_use]
    pub fn with_schedule(mut self, schedule: Schedule) -> Self {
        self.schedule = schedule;
        self
    }

    /// These options with the finest level's `tolerance`.
    #[must_use]
    pub fn with_tolerance(mut self, tolerance: f64) -> Self {
        self.tolerance = tolerance;
        self
    }

    /// These options with the coarser levels' tolerance.
    #[must_use]
    pub fn with_coarse_tolerance(mut self, tolerance: f64) -> Self {
        self.coarse_tolerance = tolerance;
        self
    }

    /// These options with at most `max_sweeps` per level.
    #[must_use]
    pub fn with_max_sweeps(mut self, max_sweeps: usize) -> Self {
        self.max_sweeps = max_sweeps;
        self
    }

    /// These options with an estimate every `check_every` sweeps.
    #[must_use]
    pub fn with_check_every(mut self, check_every: usize) -> Self {
        self.check_every = check_every;
        self
    }

    fn validate(&self) -> Result<(), PolygridError> {
        let invalid = |m: String| Err(PolygridError::Sparse(SparseError::InvalidOption(m)));
        if let Smoother::Jacobi { omega } = self.smoother {
            if !(omega.is_finite() && omega > 0.0) {
                return invalid(format!("Jacobi damping ω = {omega} must be finite and > 0"));
            }
        }
        if let Schedule::Adaptive(f) = self.schedule {
            if !(f.factor.is_finite() && f.factor > 0.0) {
                return invalid(format!("freeze depth factor {} must be finite and > 0", f.factor));
            }
            if let Some(d) = f.depth_mm {
                if !(d.is_finite() && d > 0.0) {
                    return invalid(format!("freeze depth {d} mm must be finite and > 0"));
                }
            }
            if !(f.growth.is_finite() && f.growth >= 1.0) {
                return invalid(format!("freeze depth growth {} must be finite and ≥ 1", f.growth));
            }
        }
        for (what, t) in [("tolerance", self.tolerance), ("coarse tolerance", self.coarse_tolerance)] {
            if !(t.is_finite() && t > 0.0) {
                return invalid(format!("relaxation {what} {t} must be finite and > 0"));
            }
        }
        if self.max_sweeps == 0 || self.check_every == 0 {
            return invalid(format!(
                "relaxation max_sweeps ({}) and check_every ({}) must be at least 1",
                self.max_sweeps, self.check_every
            ));
        }
        Ok(())
    }
}

/// A converged boundary radiance to measure a solve against (Fig. 15): one value per boundary
/// node of the finest level, in the order of [`RelaxHierarchy::boundary_ids`], e.g.
/// [`RelaxHierarchy::radiance`] of a PCG solution.
#[derive(Debug, Clone, Copy)]
pub struct RadianceReference<'a> {
    /// L₀ per finest boundary node.
    pub radiance: &'a [[f64; 3]],
    /// Stop the solve as soon as the finest level's error is at most this (Fig. 15's "node
    /// updates to reach x%"), before its tolerance is met.
    pub stop_below: Option<f64>,
}

/// One point of a solve's history: after a sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RelaxSample {
    /// The level swept (0 the finest).
    pub level: usize,
    /// Sweeps on that level so far.
    pub sweep: usize,
    /// Node updates of the whole solve so far.
    pub updates: usize,
    /// The RMS relative error of the boundary radiance against the [`RadianceReference`] at this
    /// level's boundary nodes (every sweep, when one is given).
    pub error: Option<f64>,
    /// The estimated relative RMS error of the fluence (at the checks, once two of them
    /// gave a contraction rate).
    pub estimate: Option<f64>,
}

/// What one level of a solve did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelStats {
    /// The level (0 the finest).
    pub level: usize,
    /// Its nodes.
    pub nodes: usize,
    /// The nodes relaxed (the others frozen by the adaptive scheme).
    pub active: usize,
    /// Sweeps made.
    pub sweeps: usize,
    /// Node updates made.
    pub updates: usize,
    /// The last error estimate (infinite before two checks).
    pub estimate: f64,
    /// Whether the level met its tolerance (or the reference's `stop_below`).
    pub converged: bool,
}

/// What a solve did.
#[derive(Debug, Clone, PartialEq)]
pub struct RelaxStats {
    /// Node updates over every level (Fig. 15's abscissa).
    pub updates: usize,
    /// Per level relaxed, coarsest first.
    pub levels: Vec<LevelStats>,
    /// Per sweep, in order (see [`RelaxSample`]).
    pub history: Vec<RelaxSample>,
    /// Whether the finest level met the tolerance or the reference's `stop_below`.
    pub converged: bool,
    /// Whether it stopped on the reference's `stop_below`.
    pub reached_reference: bool,
}

/// Every level's fluence between solves (the warm start of §5.3's frame coherence) and the
/// scratch vectors of a solve.
#[derive(Debug, Clone)]
pub struct RelaxState {
    x: Vec<Vec<[f64; 3]>>,
    /// Whether `x[l]` is level l's solution for the light and media of the last solve.
    valid: Vec<bool>,
    /// The coarser level's previous solution, during a warm cascade.
    old: Vec<[f64; 3]>,
    /// This level's previous solution, during a warm cascade.
    previous: Vec<[f64; 3]>,
    scratch: Vec<[f64; 3]>,
    save: Vec<[f64; 3]>,
    active: Vec<bool>,
    /// The right-hand side and the active flags in a level's colour order (Gauss–Seidel).
    ordered_rhs: Vec<[f64; 3]>,
    ordered_active: Vec<bool>,
}

impl RelaxState {
    /// Zero fluence on every level of `hierarchy`, none of it a previous solution.
    #[must_use]
    pub fn new(hierarchy: &RelaxHierarchy) -> Self {
        Self {
            x: hierarchy.levels.iter().map(|l| vec![[0.0; 3]; l.n()]).collect(),
            valid: vec![false; hierarchy.levels.len()],
            old: Vec::new(),
            previous: Vec::new(),
            scratch: Vec::new(),
            save: Vec::new(),
            active: Vec::new(),
            ordered_rhs: Vec::new(),
            ordered_active: Vec::new(),
        }
    }

    /// A state whose finest level holds `phi` as its previous solution (a warm start from a
    /// fluence solved elsewhere; the coarser levels start cold).
    ///
    /// # Errors
    /// [`PolygridError::LengthMismatch`] unless `phi` has one entry per finest node.
    pub fn from_solution(hierarchy: &RelaxHierarchy, phi: &[[f64; 3]]) -> Result<Self, PolygridError> {
        let mut state = Self::new(hierarchy);
        check_len("start fluence", state.x[0].len(), phi.len())?;
        state.x[0].copy_from_slice(phi);
        state.valid[0] = true;
        Ok(state)
    }

    /// The finest level's fluence: the answer of the last solve.
    #[must_use]
    pub fn solution(&self) -> &[[f64; 3]] {
        &self.x[0]
    }

    /// Level `level`'s fluence.
    ///
    /// # Panics
    /// If `level` is not a level of the hierarchy.
    #[must_use]
    pub fn level_solution(&self, level: usize) -> &[[f64; 3]] {
        &self.x[level]
    }
}

/// One level's system (the caller's stencil).
#[derive(Debug, Clone)]
enum LevelSystem {
    /// The finite-volume or the paper's stencil.
    Nodes(Box<PolygridSystem>),
    Fem(Box<DiffusionSystem>),
}

impl LevelSystem {
    fn matrix(&self) -> &CsrMatrix3 {
        match self {
            Self::Nodes(s) => s.matrix(),
            Self::Fem(s) => s.matrix(),
        }
    }

    fn rhs(&self) -> &[[f64; 3]] {
        match self {
            Self::Nodes(s) => s.rhs(),
            Self::Fem(s) => s.rhs(),
        }
    }

    fn source(&self) -> &[[f64; 3]] {
        match self {
            Self::Nodes(s) => s.source(),
            Self::Fem(s) => s.source(),
        }
    }

    fn boundary_ids(&self) -> &[u32] {
        match self {
            Self::Nodes(s) => &s.boundary().ids,
            Self::Fem(s) => &s.boundary().ids,
        }
    }

    fn terms(&self) -> &BoundaryTerms {
        match self {
            Self::Nodes(s) => s.boundary_terms(),
            Self::Fem(s) => s.boundary_terms(),
        }
    }

    fn set_source(&mut self, q: &[[f64; 3]]) -> Result<(), PolygridError> {
        match self {
            Self::Nodes(s) => s.set_source(q),
            Self::Fem(s) => Ok(s.set_source(q)?),
        }
    }
}

/// One level of the hierarchy.
#[derive(Debug, Clone)]
struct Level {
    system: LevelSystem,
    colouring: Colouring,
    /// Per node, the distance to the finest level's surface (mm).
    depth_mm: Vec<f64>,
    /// Per boundary node (system order), its index among the finest level's boundary nodes
    /// (the node at the same lattice point).
    finest_boundary: Vec<u32>,
    /// The matrix renumbered by the colouring, for the Gauss–Seidel sweeps: made by the first
    /// solve that sweeps this level, as it costs the matrix's memory again.
    ordered: OnceLock<ColourOrdered>,
}

impl Level {
    fn n(&self) -> usize {
        self.depth_mm.len()
    }

    /// The colour-ordered matrix, made on first use.
    fn colour_ordered(&self) -> Result<&ColourOrdered, SparseError> {
        if let Some(o) = self.ordered.get() {
            return Ok(o);
        }
        let made = ColourOrdered::new(self.system.matrix(), &self.colouring)?;
        Ok(self.ordered.get_or_init(|| made))
    }
}

/// The paper's multiresolution polygrid (§5.3) with a system per level: see the module
/// documentation.
#[derive(Debug, Clone)]
pub struct RelaxHierarchy {
    stencil: Stencil,
    /// Finest first.
    levels: Vec<Level>,
    /// `prolongations[l]`: from level l + 1 to level l.
    prolongations: Vec<Prolongation>,
    /// Per channel, ℓd = 1/σtr (mm), the smallest over the finest cells.
    diffusion_lengths_mm: [f64; 3],
}

impl RelaxHierarchy {
    /// The hierarchy of `levels` levels (the finest `grid` and `levels − 1` coarsenings) with
    /// `cell_media` on the finest cells (averaged onto the coarser ones: σa, σ′s and g over the
    /// children, never κ), positions in scene units of `mm_per_unit` millimetres, every level
    /// assembled by `stencil`; the source starts at q = 0 ([`RelaxHierarchy::set_source`]).
    ///
    /// # Errors
    /// [`PolygridError::InvalidResolution`] for `levels == 0` or a resolution that `levels − 1`
    /// halvings do not divide; [`PolygridError::LengthMismatch`] unless there is one medium per
    /// cell; [`PolygridError::InvalidMedium`] (a medium, or a mixed η) and
    /// [`PolygridError::InvalidCube`] (the scale) from the assembly, or
    /// [`PolygridError::Diffusion`] from the FEM assembly; [`PolygridError::Fold`] for a level
    /// whose Kuhn split has a flat tet (a coarse level of a grid mapped too tightly).
    pub fn new(
        grid: &Polygrid,
        cell_media: &[Medium],
        mm_per_unit: f64,
        stencil: Stencil,
        levels: usize,
    ) -> Result<Self, PolygridError> {
        if levels == 0 {
            return Err(PolygridError::InvalidResolution {
                resolution: grid.resolution(),
                reason: "a relaxation hierarchy needs at least one level".into(),
            });
        }
        if cell_media.len() != grid.cells().len() {
            return Err(PolygridError::LengthMismatch {
                what: "cell media",
                expected: grid.cells().len(),
                found: cell_media.len(),
            });
        }
        if !(mm_per_unit.is_finite() && mm_per_unit > 0.0) {
            return Err(PolygridError::InvalidCube { cube: mm_per_unit });
        }
        if let Some((cell, e)) = cell_media.iter().enumerate().find_map(|(c, m)| m.validate().err().map(|e| (c, e))) {
            return Err(PolygridError::InvalidMedium { cell, message: e.to_string() });
        }
        // Every coarsening first: a resolution it cannot halve fails before any assembly.
        let mut grids = vec![grid.clone()];
        let mut prolongations = Vec::with_capacity(levels - 1);
        let mut media = vec![cell_media.to_vec()];
        for _ in 1..levels {
            let fine = grids.last().expect("the finest level");
            let (coarse, p) = fine.coarsened()?;
            media.push(average_media(media.last().expect("the finer level's media"), &p, coarse.cells().len()));
            grids.push(coarse);
            prolongations.push(p);
        }

        let depth0 = surface_depth(grid, mm_per_unit);
        let n0 = grid.node_count();
        let mut levels_out = Vec::with_capacity(levels);
        let mut finest_node: Vec<u32> = (0..n0 as u32).collect();
        let mut finest_boundary_index = vec![NOT_BOUNDARY; n0];
        for (l, (g, m)) in grids.iter().zip(&media).enumerate() {
            if l > 0 {
                let fine_of = prolongations[l - 1].fine_of();
                finest_node = fine_of.iter().map(|&f| finest_node[f as usize]).collect();
            }
            let system = assemble(g, m, mm_per_unit, stencil, l)?;
            if l == 0 {
                for (k, &i) in system.boundary_ids().iter().enumerate() {
                    finest_boundary_index[i as usize] = k as u32;
                }
            }
            let finest_boundary = system
                .boundary_ids()
                .iter()
                .map(|&i| {
                    let b = finest_boundary_index[finest_node[i as usize] as usize];
                    if b == NOT_BOUNDARY {
                        Err(PolygridError::InvalidResolution {
                            resolution: g.resolution(),
                            reason: format!(
                                "boundary node {i} of hierarchy level {l} lies on no boundary node of the finest level"
                            ),
                        })
                    } else {
                        Ok(b)
                    }
                })
                .collect::<Result<Vec<u32>, _>>()?;
            let colours = g.parity_colours().into_iter().map(u32::from).collect();
            let colouring = Colouring::from_colours(system.matrix().pattern(), colours)?;
            let depth_mm = finest_node.iter().map(|&f| depth0[f as usize]).collect();
            levels_out.push(Level { system, colouring, depth_mm, finest_boundary, ordered: OnceLock::new() });
        }
        let diffusion_lengths_mm =
            std::array::from_fn(|c| cell_media.iter().map(|m| 1.0 / m.sigma_tr()[c]).fold(f64::INFINITY, f64::min));
        Ok(Self { stencil, levels: levels_out, prolongations, diffusion_lengths_mm })
    }

    /// The stencil every level was assembled with.
    #[must_use]
    pub fn stencil(&self) -> Stencil {
        self.stencil
    }

    /// Number of levels.
    #[must_use]
    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// Nodes of level `level` (0 the finest).
    ///
    /// # Panics
    /// If `level` is not a level of the hierarchy.
    #[must_use]
    pub fn node_count(&self, level: usize) -> usize {
        self.levels[level].n()
    }

    /// Level `level`'s matrix.
    ///
    /// # Panics
    /// If `level` is not a level of the hierarchy.
    #[must_use]
    pub fn matrix(&self, level: usize) -> &CsrMatrix3 {
        self.levels[level].system.matrix()
    }

    /// Level `level`'s right-hand side for the current source.
    ///
    /// # Panics
    /// If `level` is not a level of the hierarchy.
    #[must_use]
    pub fn rhs(&self, level: usize) -> &[[f64; 3]] {
        self.levels[level].system.rhs()
    }

    /// Level `level`'s parity colouring (for its Gauss–Seidel sweeps, here or on the device's
    /// `GpuRelaxation`).
    ///
    /// # Panics
    /// If `level` is not a level of the hierarchy.
    #[must_use]
    pub fn colouring(&self, level: usize) -> &Colouring {
        &self.levels[level].colouring
    }

    /// The prolongation from level `level + 1` to level `level`.
    ///
    /// # Panics
    /// If `level + 1` is not a level of the hierarchy.
    #[must_use]
    pub fn prolongation(&self, level: usize) -> &Prolongation {
        &self.prolongations[level]
    }

    /// Per node of level `level`, its distance to the finest level's surface (mm): what the
    /// adaptive scheme freezes by.
    ///
    /// # Panics
    /// If `level` is not a level of the hierarchy.
    #[must_use]
    pub fn depth_mm(&self, level: usize) -> &[f64] {
        &self.levels[level].depth_mm
    }

    /// The diffusion length ℓd = 1/σtr (mm) [`FreezeDepth::factor`] multiplies: the smallest
    /// over the finest cells, in the channel where that is largest (the channel that reaches
    /// deepest sets the depth, since the three channels are relaxed together; infinite where a
    /// channel does not absorb, which freezes nothing).
    #[must_use]
    pub fn diffusion_length_mm(&self) -> f64 {
        self.diffusion_lengths_mm.into_iter().fold(0.0, f64::max)
    }

    /// Per channel, the smallest ℓd = 1/σtr over the finest cells (mm).
    #[must_use]
    pub fn diffusion_lengths_mm(&self) -> [f64; 3] {
        self.diffusion_lengths_mm
    }

    /// The finest level's boundary nodes: the order of the source and of the radiance.
    #[must_use]
    pub fn boundary_ids(&self) -> &[u32] {
        self.levels[0].system.boundary_ids()
    }

    /// The finest level's unit outward normals at its boundary nodes (for a source).
    #[must_use]
    pub fn boundary_normals(&self) -> &[DVec3] {
        match &self.levels[0].system {
            LevelSystem::Nodes(s) => &s.boundary().normal,
            LevelSystem::Fem(s) => &s.boundary().normal,
        }
    }

    /// The finest level's source q.
    #[must_use]
    pub fn source(&self) -> &[[f64; 3]] {
        self.levels[0].system.source()
    }

    /// Sets the transmitted source q on the finest boundary nodes (in the order of
    /// [`RelaxHierarchy::boundary_ids`]) and, by injection, on every coarser level. On error
    /// nothing changes.
    ///
    /// # Errors
    /// [`PolygridError::LengthMismatch`]; [`PolygridError::InvalidSource`] for a value that is
    /// not finite, or [`PolygridError::Diffusion`] for one the FEM system refuses (negative).
    pub fn set_source(&mut self, q: &[[f64; 3]]) -> Result<(), PolygridError> {
        let nb = self.boundary_ids().len();
        check_len("source q", nb, q.len())?;
        // The finest level checks every value (and changes nothing when one fails); a coarser
        // level's values are some of the same, so they pass too: no level is left with another
        // light than the rest.
        for level in &mut self.levels {
            let ql: Vec<[f64; 3]> = level.finest_boundary.iter().map(|&k| q[k as usize]).collect();
            level.system.set_source(&ql)?;
        }
        Ok(())
    }

    /// The boundary radiance Lo(x, n) of a finest-level fluence (ARCHITECTURE.md's query along
    /// the normal), in the order of [`RelaxHierarchy::boundary_ids`].
    ///
    /// # Errors
    /// [`PolygridError::LengthMismatch`] unless `phi` has one entry per finest node.
    pub fn radiance(&self, phi: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, PolygridError> {
        check_len("fluence", self.levels[0].n(), phi.len())?;
        Ok(level_radiance(&self.levels[0], phi))
    }

    /// Solves the finest level's system by `options`' scheme, starting as `start` says, into
    /// `state` (its [`RelaxState::solution`]), measuring every sweep against `reference` when
    /// given (see the module documentation).
    ///
    /// # Errors
    /// [`PolygridError::Sparse`] for invalid options ([`SparseError::InvalidOption`]), a
    /// sweep's error (an unusable diagonal) or a sweep that does not contract
    /// ([`SparseError::Breakdown`]: the iterate grew over three checks in a row or stopped being
    /// finite, e.g. Jacobi with too large an ω); [`PolygridError::LengthMismatch`] for a state of
    /// another hierarchy or a reference of the wrong length. After an error the state holds no
    /// previous solution (a warm start then starts cold).
    pub fn solve(
        &self,
        state: &mut RelaxState,
        start: Start,
        options: &RelaxOptions,
        reference: Option<&RadianceReference<'_>>,
    ) -> Result<RelaxStats, PolygridError> {
        options.validate()?;
        check_len("relaxation state levels", self.levels.len(), state.x.len())?;
        for (level, x) in self.levels.iter().zip(&state.x) {
            check_len("relaxation state fluence", level.n(), x.len())?;
        }
        if let Some(r) = reference {
            check_len("reference radiance", self.boundary_ids().len(), r.radiance.len())?;
        }
        let order: Vec<usize> = match options.schedule {
            Schedule::SingleLevel => vec![0],
            Schedule::Hierarchical | Schedule::Adaptive(_) => (0..self.levels.len()).rev().collect(),
        };
        let shell0 = match options.schedule {
            Schedule::Adaptive(f) => Some(f.depth_mm.unwrap_or(f.factor * self.diffusion_length_mm())),
            _ => None,
        };
        let warm = start == Start::Warm;
        // Until it succeeds, no level holds a solution (a failed solve leaves them half done).
        let was_valid = std::mem::replace(&mut state.valid, vec![false; self.levels.len()]);
        let n0 = self.levels[0].n();
        let RelaxState { x, old, previous, scratch, save, active, ordered_rhs, ordered_active, .. } = state;
        for v in [&mut *old, &mut *previous, &mut *scratch, &mut *save, &mut *ordered_rhs] {
            v.resize(n0, [0.0; 3]);
        }
        active.resize(n0, true);
        ordered_active.resize(n0, true);

        let mut stats =
            RelaxStats { updates: 0, levels: Vec::new(), history: Vec::new(), converged: false, reached_reference: false };
        for (k, &l) in order.iter().enumerate() {
            let level = &self.levels[l];
            let n = level.n();
            let coarser = (k > 0).then(|| l + 1);
            // This level's previous solution, for the next finer level's correction.
            let keep = warm && l > 0 && was_valid[l];
            if keep {
                previous[..n].copy_from_slice(&x[l]);
            }
            // The start value.
            match coarser {
                None => {
                    if !(warm && was_valid[l]) {
                        x[l].fill([0.0; 3]);
                    }
                }
                Some(c) => {
                    let (fine, coarse) = x.split_at_mut(c);
                    let (fine, coarse) = (&mut fine[l], &coarse[0]);
                    let p = &self.prolongations[l];
                    if warm && was_valid[l] && was_valid[c] {
                        // Previous fine solution + the prolonged change of the coarse one
                        // (`old` holds the coarse level's previous solution).
                        let delta: Vec<[f64; 3]> = coarse
                            .iter()
                            .zip(&old[..coarse.len()])
                            .map(|(a, b)| std::array::from_fn(|ch| a[ch] - b[ch]))
                            .collect();
                        p.prolong(&delta, &mut scratch[..n]);
                        fine.par_iter_mut().zip(&scratch[..n]).for_each(|(f, d)| *f = std::array::from_fn(|ch| f[ch] + d[ch]));
                    } else if !(warm && was_valid[l]) {
                        p.prolong(coarse, fine);
                    }
                }
            }
            if keep {
                std::mem::swap(old, previous);
            }
            // The adaptive shell.
            let shell = match (shell0, coarser, &options.schedule) {
                (Some(d0), Some(_), Schedule::Adaptive(f)) => Some(d0 * f.growth.powi(l as i32)),
                _ => None,
            };
            let mask = shell.map(|d| {
                let a = &mut active[..n];
                a.par_iter_mut().zip(&level.depth_mm).for_each(|(a, &depth)| *a = depth <= d);
                &a[..]
            });
            let tolerance = if l == 0 { options.tolerance } else { options.coarse_tolerance };
            let run = LevelRun {
                hierarchy: self,
                level: l,
                active: mask,
                options,
                tolerance,
                reference,
                stop_below: if l == 0 { reference.and_then(|r| r.stop_below) } else { None },
            };
            let work = Work {
                scratch: &mut scratch[..n],
                save: &mut save[..n],
                ordered_rhs: &mut ordered_rhs[..n],
                ordered_active: &mut ordered_active[..n],
            };
            let level_stats = run.relax(&mut x[l], work, &mut stats)?;
            if l == 0 {
                stats.converged = level_stats.converged;
            }
            stats.levels.push(level_stats);
        }
        // The levels relaxed now hold this light's solutions; the others are stale.
        state.valid = (0..self.levels.len()).map(|l| order.contains(&l)).collect();
        Ok(stats)
    }
}

/// One level's relaxation in a solve.
struct LevelRun<'a> {
    hierarchy: &'a RelaxHierarchy,
    level: usize,
    active: Option<&'a [bool]>,
    options: &'a RelaxOptions,
    tolerance: f64,
    reference: Option<&'a RadianceReference<'a>>,
    stop_below: Option<f64>,
}

/// A level run's work vectors, one entry per node of the level.
struct Work<'a> {
    scratch: &'a mut [[f64; 3]],
    save: &'a mut [[f64; 3]],
    ordered_rhs: &'a mut [[f64; 3]],
    ordered_active: &'a mut [bool],
}

impl LevelRun<'_> {
    /// Sweeps `x` until the estimate meets the tolerance, the reference error `stop_below`, or
    /// `max_sweeps`; appends to `stats`. Gauss–Seidel sweeps the level's colour-ordered matrix:
    /// `x`, the right-hand side and the mask are taken into its order once, and `x` is put back
    /// at the end.
    fn relax(&self, x: &mut [[f64; 3]], work: Work<'_>, stats: &mut RelaxStats) -> Result<LevelStats, PolygridError> {
        let level = &self.hierarchy.levels[self.level];
        let (matrix, b) = (level.system.matrix(), level.system.rhs());
        let Work { scratch, save, ordered_rhs, ordered_active } = work;
        match self.options.smoother {
            Smoother::Jacobi { omega } => {
                let active = self.active;
                let sweep = |x: &mut [[f64; 3]]| {
                    let u = jacobi_sweep(matrix, b, x, scratch, omega, active)?;
                    x.copy_from_slice(scratch);
                    Ok(u)
                };
                self.sweeps(x, active, save, None, sweep, stats)
            }
            Smoother::GaussSeidel => {
                let ordered = level.colour_ordered()?;
                ordered.gather(x, scratch)?;
                ordered.gather(b, ordered_rhs)?;
                let active = match self.active {
                    Some(a) => {
                        ordered.gather(a, ordered_active)?;
                        Some(&ordered_active[..])
                    }
                    None => None,
                };
                let sweep = |x: &mut [[f64; 3]]| ordered.sweep(ordered_rhs, x, active, false);
                let out = self.sweeps(scratch, active, save, Some(ordered.rank()), sweep, stats)?;
                ordered.scatter(scratch, x)?;
                Ok(out)
            }
        }
    }

    /// The sweeps of [`LevelRun::relax`] on `x` by `step`, `active` being its mask and `rank`
    /// the position of each node in `x` (None: the level's own order).
    fn sweeps(
        &self,
        x: &mut [[f64; 3]],
        active: Option<&[bool]>,
        save: &mut [[f64; 3]],
        rank: Option<&[u32]>,
        mut step: impl FnMut(&mut [[f64; 3]]) -> Result<usize, SparseError>,
        stats: &mut RelaxStats,
    ) -> Result<LevelStats, PolygridError> {
        let level = &self.hierarchy.levels[self.level];
        let nodes = level.n();
        let active_count = active.map_or(nodes, |a| a.iter().filter(|&&f| f).count());
        let mut out = LevelStats {
            level: self.level,
            nodes,
            active: active_count,
            sweeps: 0,
            updates: 0,
            estimate: f64::INFINITY,
            converged: false,
        };
        if active_count == 0 {
            out.converged = true;
            out.estimate = 0.0;
            return Ok(out);
        }
        // Coarser levels are cheap to check: every sweep, so that a good start (a warm one)
        // is left after three sweeps.
        let m = if self.level == 0 { self.options.check_every } else { 1 };
        // The last two checks' (sweep, relative change per channel), for the contraction rate.
        let mut last: Option<(usize, [f64; 3])> = None;
        let mut last_rate: Option<[f64; 3]> = None;
        // Per channel, the checks in a row at which the iterate's change grew.
        let mut growing = [0usize; 3];
        for sweep in 1..=self.options.max_sweeps {
            let check = sweep % m == 0;
            if check {
                save.copy_from_slice(x);
            }
            let updates = step(x)?;
            out.sweeps = sweep;
            out.updates += updates;
            stats.updates += updates;
            let error = self.reference.map(|r| reference_error(level, x, rank, r.radiance));
            let mut estimate = None;
            if check {
                let delta = relative_change(x, save, active);
                if let Some(channel) = (0..3).find(|&c| !delta[c].is_finite()) {
                    return Err(self.breakdown(channel, sweep, "the iterate is no longer finite".into()));
                }
                if let Some((k0, d0)) = last {
                    let rate: [f64; 3] = std::array::from_fn(|c| {
                        if d0[c] <= ROUND_OFF {
                            0.0
                        } else {
                            (delta[c] / d0[c]).powf(1.0 / (sweep - k0) as f64)
                        }
                    });
                    for c in 0..3 {
                        growing[c] = if rate[c] > 1.001 && delta[c] > 1e-8 { growing[c] + 1 } else { 0 };
                        if growing[c] >= 3 {
                            let reason = format!(
                                "the iterate grows ({:.4} per sweep over {} checks): the sweep does not contract on this \
                                 matrix (for Jacobi, a smaller ω)",
                                rate[c], growing[c]
                            );
                            return Err(self.breakdown(c, sweep, reason));
                        }
                    }
                    // The slower of the last two rates (none before two: the first checks
                    // see the fast modes decay, which would promise too much).
                    if let Some(previous) = last_rate {
                        let e = (0..3)
                            .map(|c| {
                                let slow = rate[c].max(previous[c]);
                                if delta[c] <= ROUND_OFF {
                                    0.0
                                } else if slow < 1.0 {
                                    delta[c] * slow / (1.0 - slow)
                                } else {
                                    f64::INFINITY
                                }
                            })
                            .fold(0.0, f64::max);
                        out.estimate = e;
                        estimate = Some(e);
                    }
                    last_rate = Some(rate);
                } else if delta.iter().all(|&d| d <= ROUND_OFF) {
                    // Nothing moved: the start was the fixed point.
                    out.estimate = 0.0;
                    estimate = Some(0.0);
                }
                last = Some((sweep, delta));
            }
            if error.is_some() || estimate.is_some() {
                stats.history.push(RelaxSample { level: self.level, sweep, updates: stats.updates, error, estimate });
            }
            if let (Some(e), Some(target)) = (error, self.stop_below) {
                if e <= target {
                    out.converged = true;
                    stats.reached_reference = true;
                    break;
                }
            }
            if estimate.is_some_and(|e| e <= self.tolerance) {
                out.converged = true;
                break;
            }
        }
        Ok(out)
    }

    /// The sweep's breakdown on `channel` at `sweep`.
    fn breakdown(&self, channel: usize, sweep: usize, reason: String) -> PolygridError {
        let method = match self.options.smoother {
            Smoother::Jacobi { .. } => "Jacobi relaxation",
            Smoother::GaussSeidel => "Gauss–Seidel relaxation",
        };
        PolygridError::Sparse(SparseError::Breakdown { method, channel, iteration: sweep, reason })
    }
}

/// A relative change of the iterate at or below this is round-off: that channel has converged.
const ROUND_OFF: f64 = 1e-13;

/// Per channel, ‖x − y‖ / ‖x‖ over the active rows (0 where x is 0).
fn relative_change(x: &[[f64; 3]], y: &[[f64; 3]], active: Option<&[bool]>) -> [f64; 3] {
    let (num, den) = x
        .par_iter()
        .zip(y)
        .enumerate()
        .filter(|(i, _)| active.is_none_or(|a| a[*i]))
        .map(|(_, (a, b))| {
            let d: [f64; 3] = std::array::from_fn(|c| (a[c] - b[c]) * (a[c] - b[c]));
            let s: [f64; 3] = std::array::from_fn(|c| a[c] * a[c]);
            (d, s)
        })
        .reduce(
            || ([0.0; 3], [0.0; 3]),
            |(a, b), (c, d)| (std::array::from_fn(|k| a[k] + c[k]), std::array::from_fn(|k| b[k] + d[k])),
        );
    std::array::from_fn(|c| if den[c] > 0.0 { (num[c] / den[c]).sqrt() } else { 0.0 })
}

/// Lo along the normal at a level's boundary nodes.
fn level_radiance(level: &Level, phi: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let terms = level.system.terms();
    level
        .system
        .boundary_ids()
        .iter()
        .zip(level.system.source())
        .map(|(&i, q)| std::array::from_fn(|c| terms.radiance_normal(phi[i as usize][c], q[c])))
        .collect()
}

/// √(Σ(L − L₀)² / ΣL₀²) over a level's boundary nodes and the channels, L₀ the reference at the
/// finest boundary node of the same lattice point; node i's fluence is `phi[rank[i]]` (`phi[i]`
/// without a rank).
fn reference_error(level: &Level, phi: &[[f64; 3]], rank: Option<&[u32]>, reference: &[[f64; 3]]) -> f64 {
    let terms = level.system.terms();
    let (num, den) = level.system.boundary_ids().iter().zip(level.system.source()).zip(&level.finest_boundary).fold(
        (0.0, 0.0),
        |(num, den), ((&i, q), &k)| {
            let l0 = reference[k as usize];
            let phi = phi[rank.map_or(i as usize, |r| r[i as usize] as usize)];
            (0..3).fold((num, den), |(n, d), c| {
                let l = terms.radiance_normal(phi[c], q[c]);
                (n + (l - l0[c]) * (l - l0[c]), d + l0[c] * l0[c])
            })
        },
    );
    if den > 0.0 {
        (num / den).sqrt()
    } else {
        num.sqrt()
    }
}

/// The coarse cells' media: per coarse cell the mean σa, σ′s and g of its children (never κ).
fn average_media(fine: &[Medium], p: &Prolongation, coarse_cells: usize) -> Vec<Medium> {
    let mut sum = vec![([0.0; 3], [0.0; 3], 0.0, 0usize); coarse_cells];
    for (m, &c) in fine.iter().zip(p.cell_parent()) {
        let s = &mut sum[c as usize];
        for k in 0..3 {
            s.0[k] += m.sigma_a[k];
            s.1[k] += m.sigma_s_prime[k];
        }
        s.2 += m.g;
        s.3 += 1;
    }
    let eta = fine[0].eta;
    sum.into_iter()
        .map(|(a, s, g, n)| {
            let n = n.max(1) as f64;
            // Means of valid coefficients are valid; η is the object's.
            Medium { sigma_a: a.map(|x| x / n), sigma_s_prime: s.map(|x| x / n), eta, g: g / n }
        })
        .collect()
}

/// Level `l`'s system of `grid` by `stencil`.
fn assemble(
    grid: &Polygrid,
    media: &[Medium],
    mm_per_unit: f64,
    stencil: Stencil,
    l: usize,
) -> Result<LevelSystem, PolygridError> {
    match stencil {
        Stencil::FiniteVolume => Ok(LevelSystem::Nodes(Box::new(PolygridSystem::finite_volume(grid, media, mm_per_unit, None)?))),
        Stencil::PaperLsq => Ok(LevelSystem::Nodes(Box::new(PolygridSystem::paper_lsq(grid, media, mm_per_unit, None)?))),
        Stencil::Fem => {
            // Tets 6c … 6c + 5 are cell c's; equal media share a table entry.
            let mut table: Vec<Medium> = Vec::new();
            let mut index: HashMap<[u64; 8], u32> = HashMap::new();
            let cell_ids: Vec<u32> = media
                .iter()
                .map(|m| {
                    let key = [
                        m.sigma_a[0].to_bits(),
                        m.sigma_a[1].to_bits(),
                        m.sigma_a[2].to_bits(),
                        m.sigma_s_prime[0].to_bits(),
                        m.sigma_s_prime[1].to_bits(),
                        m.sigma_s_prime[2].to_bits(),
                        m.eta.to_bits(),
                        m.g.to_bits(),
                    ];
                    *index.entry(key).or_insert_with(|| {
                        table.push(*m);
                        (table.len() - 1) as u32
                    })
                })
                .collect();
            let materials: Vec<u32> = cell_ids.iter().flat_map(|&id| [id; 6]).collect();
            let mesh = TetMesh::new(grid.positions().to_vec(), grid.kuhn_tets(), materials).map_err(|e| match e {
                TetMeshError::Degenerate { tet, .. } => PolygridError::Fold {
                    cell: tet / 6,
                    scaled_jacobian: 0.0,
                    hint: "a Kuhn tet of a level of the relaxation hierarchy is flat: use fewer levels",
                },
                other => PolygridError::InvalidResolution {
                    resolution: grid.resolution(),
                    reason: format!("hierarchy level {l}'s Kuhn split is not a tet mesh: {other}"),
                },
            })?;
            Ok(LevelSystem::Fem(Box::new(diffusion::assemble(&mesh, &table, mm_per_unit)?)))
        }
    }
}

/// Per node of `grid`, its distance (mm) to the surface: the boundary quads split in two
/// triangles each, through a [`TriangleBvh`].
fn surface_depth(grid: &Polygrid, mm_per_unit: f64) -> Vec<f64> {
    let x: Vec<DVec3> = grid.positions().iter().map(|&p| p * mm_per_unit).collect();
    let triangles: Vec<[u32; 3]> = grid.quads().iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
    let on_boundary = grid.on_boundary();
    if triangles.is_empty() {
        return vec![0.0; x.len()];
    }
    let bvh = TriangleBvh::from_indexed(&x, &triangles);
    x.par_iter()
        .enumerate()
        .map(|(i, &p)| if on_boundary[i] { 0.0 } else { bvh.closest_point(p).map_or(0.0, |s| s.distance) })
        .collect()
}

fn check_len(what: &'static str, expected: usize, found: usize) -> Result<(), PolygridError> {
    if expected == found {
        Ok(())
    } else {
        Err(PolygridError::LengthMismatch { what, expected, found })
    }
}
