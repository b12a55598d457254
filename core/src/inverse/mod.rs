//! Inverse diffusion (Wang et al. 2008 §4, App. A): a heterogeneous material volume from images
//! of a block-shaped sample lit by known patterns.
//!
//! - [`setup`]: the acquisition (a block on a node grid, patterns on its top face, a front-lit
//!   or back-lit camera, the lit-pixel mask);
//! - [`block`]: the block's conservative finite-volume system, linear in each cell's κ and σa;
//! - [`model`]: the forward model per pattern, the predicted images and the objective;
//! - [`regularize`]: the unit-free smoothness of κ;
//! - [`adjoint`]: the discrete adjoint gradient and the gradient check;
//! - [`optimize`]: the homogeneous fit, L-BFGS (default) and the paper's Polak–Ribière CG with
//!   golden-section search, λ given or by the discrepancy principle, optionally coarse to fine;
//! - [`parameters`]: the unknowns on blocks of cells (the homogeneous fit's one block, the
//!   coarse-to-fine levels, σa on a coarser grid than σ′s);
//! - [`synth`]: synthetic images from an independent discretisation (the polygrid
//!   finite-volume system on a 2×-finer grid), so tests never fit the model to itself;
//! - [`description`]: an acquisition on disk (a description of setup, patterns and optimiser,
//!   one linear image file per pattern) read into the in-memory inputs above;
//! - [`output`]: the recovered cells as a [`crate::volume::VoxelGrid`] (TCVOX1).
//!
//! The boundary condition and radiance query are docs/ARCHITECTURE.md's (not the paper's
//! L = Ft(φ − q)/2π, design note P1), so an acquired material renders the same in every method.
//!
//! # Departures from the design note (design/polygrid-and-inverse.md), and why
//!
//! - **Media on cells, no κ averaging.** The note's gradient uses κ_kj, the harmonic mean of
//!   node values; here σa and σ′s live on the cells (as in `polygrid`'s finite volumes and
//!   the TCVOX1 output), so A is *linear* in each cell's κ and σa and ∂A/∂κ_c, ∂A/∂σa_c are
//!   exact and parameter-free ([`block`]).
//! - **One channel at a time.** The channels are independent problems; one optimiser over all
//!   three shares a line search, and a channel whose start is far too bright lowered its
//!   misfit towards 1 by turning black (σ′s → 4·10⁵) while the others descended. The solves
//!   still carry three channels; the held ones are warm-started at their solution.
//! - **A curvature check in the L-BFGS line search.** Armijo backtracking alone accepts short
//!   steps, and on the homogeneous fit's curved σa–σ′s valley L-BFGS crawled (90 iterations
//!   against paper mode's 7); a step that fails ∇f(x + αd)·d ≥ 0.9∇f(x)·d makes the next
//!   search expand (16 iterations, 0.21 of paper mode's forward solves on the veined block).
//! - **A unit-free regulariser** ([`regularize`]), so λ does not depend on grid or brightness.
//! - **The front-lit margin is a setting**, not 2/σ′t (P13): σ′t is what is being measured.
//!   With a margin the σa/σ′s split is weakly determined: on a 4 mm block a 0.7% RMS model
//!   error moves a front-lit homogeneous fit by 4%, a back-lit one by under 1%.
//! - **Fourth-order differences in [`check_gradient`]**: the two-point formula cannot reach
//!   1e-6 relative with solves to 1e-13.
//!
//! # Cost
//!
//! An evaluation is M forward solves (three channels each, warm-started), a gradient M more
//! (adjoint). The last φ_m and ψ_m of every image are kept for warm starts: 48·M bytes per
//! node (15 MB for 40 × 40 × 12 nodes and M = 16; 1 GB at the paper's marble, 256 × 256 × 20).

pub mod adjoint;
pub mod block;
pub mod description;
mod error;
pub mod held_out;
pub mod model;
pub mod optimize;
pub mod output;
pub mod parameters;
pub mod regularize;
pub mod setup;
pub mod synth;

pub use adjoint::{check_gradient, GradientComponent};
pub use block::BlockGrid;
pub use description::{read_image, write_image, Description, Loaded};
pub use error::InverseError;
pub use held_out::{random_patterns, single_node_patterns, uniform_sequence, with_noise};
pub use model::{Acquisition, CellMedia, Evaluation, Setup, SolveSettings, WorkCounts};
pub use optimize::{acquire, AcquireOptions, Acquired, Channels, IterationRecord, Lambda, Method, Sample, StopReason};
pub use output::to_voxel_grid;
pub use parameters::ParameterGrid;
pub use setup::{Observation, Pattern};
pub use synth::{synthesize, SynthOptions, VeinedBlock};
