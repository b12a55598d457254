//! The TransCut diffusion solver (Li et al., *TransCut: Interactive Rendering of Translucent
//! Cutouts*, TVCG 2013, §3; the equations as restated in ARCHITECTURE.md "The equations").
//!
//! The fluence φ inside a translucent object solves ∇·(κ∇φ) − μφ = 0 with the Robin condition
//! φ + 2Aκ(∇φ·n) = 4q/(1 − Fdr) on its surface, q the transmitted incident light. On a tet mesh
//! with piecewise-constant media and piecewise-linear φ this becomes a symmetric positive definite
//! system M φ = b per colour channel:
//!
//! - [`assemble`] ([`system`], kernel in `transcut.rs`): TransCut eqs. 10–14, cotangent edge
//!   weights and lumped masses;
//! - [`assemble_consistent`] (kernel in `fem.rs`): the consistent P1 Galerkin reference,
//!   scaled alike;
//! - [`Solver`] ([`solver`]): CG with a Jacobi, SSOR or multigrid preconditioner, or the §4
//!   cascade ([`SolverKind`]), on the three channels, from warm starts; [`solve`] the bake's
//!   cold solve;
//! - [`surface_radiance`]: eq. 3 along the normal, the per-vertex value a bake returns;
//! - [`energy_balance`]: absorbed + exitant = incident power.
//!
//! # Data layout
//!
//! A [`DiffusionSystem`] keeps the mesh-only structure (sparsity pattern from the mesh edges,
//! per-tet volumes and cotangent coefficients in millimetres, for every row the tets around its
//! vertex and the value slots they write) apart from the values: [`DiffusionSystem::set_media`]
//! (painting) refills the matrix values in place, [`DiffusionSystem::set_source`] (relighting)
//! only recomputes b. Rows are filled in parallel, each summed in a fixed order, so results are
//! bit-identical for any thread count and M is exactly symmetric.
//!
//! Units: mesh positions are in scene units and `mm_per_unit` converts them; media are in mm⁻¹
//! ([`crate::optics`]), so κ is in mm, M in mm² and b in (units of q) · mm². Per-boundary-vertex
//! arrays (q, radiance) follow [`DiffusionSystem::boundary`] (vertex ids increasing).
//!
//! # Example
//!
//! A 10 mm marble cube made of one Kuhn-split cell, lit uniformly:
//!
//! ```
//! use transcut::diffusion::{assemble, solve, surface_radiance, energy_balance};
//! use transcut::mesh::TetMesh;
//! use transcut::optics::Medium;
//! use transcut::sparse::SolveOptions;
//! use transcut::DVec3;
//!
//! let corners: Vec<DVec3> =
//!     (0..8).map(|d| DVec3::new((d & 1) as f64, ((d >> 1) & 1) as f64, ((d >> 2) & 1) as f64)).collect();
//! let tets = vec![[0, 1, 3, 7], [0, 1, 5, 7], [0, 2, 3, 7], [0, 2, 6, 7], [0, 4, 5, 7], [0, 4, 6, 7]];
//! let mesh = TetMesh::new(corners, tets, vec![])?;
//! let mut system = assemble(&mesh, &[Medium::preset("marble")?], 10.0)?; // 1 unit = 10 mm
//! system.set_source(&vec![[1.0; 3]; system.boundary().len()])?;
//! let solution = solve(&system, None, &SolveOptions::default())?;
//! let lo = surface_radiance(&system, &solution.phi)?; // Lo(x, n) per boundary vertex
//! assert_eq!(lo.len(), 8);
//! let balance = energy_balance(&system, &solution.phi)?;
//! assert!(balance.relative_defect().iter().all(|d| d.abs() < 1e-4));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod error;
mod fem;
mod fitted;
mod layer;
pub(crate) mod resolution;
pub mod solve;
pub mod solver;
mod structure;
pub mod system;
mod transcut;

pub use error::DiffusionError;
#[cfg(feature = "gpu")]
pub(crate) use fitted::layer_excess;
pub use resolution::{max_resolution, Unresolved, MAX_RESOLUTION};
pub use solve::{energy_balance, solve, surface_fluence, surface_radiance, EnergyBalance, Solution};
#[cfg(feature = "gpu")]
pub(crate) use solver::start_vector;
pub use solver::{Solver, SolverKind};
pub use structure::BoundaryVertices;
#[cfg(feature = "gpu")]
pub(crate) use structure::Coefficients;
pub use system::{assemble, assemble_consistent, assemble_fitted, assemble_with, rhs, DiffusionSystem, Discretization};
