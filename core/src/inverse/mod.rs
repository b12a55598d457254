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
//!   golden-section search, λ given or by the discrepancy principle;
//! - [`synth`]: synthetic images from an independent discretisation (the polygrid
//!   finite-volume system on a 2×-finer grid), so tests never fit the model to itself;
//! - [`output`]: the recovered cells as a [`crate::volume::VoxelGrid`] (TCVOX1).
//!
//! The boundary condition and radiance query are docs/ARCHITECTURE.md's (not the paper's
//! L = Ft(φ − q)/2π, design note P1), so an acquired material renders the same in every method.

pub mod adjoint;
pub mod block;
mod error;
pub mod model;
pub mod optimize;
pub mod output;
pub mod regularize;
pub mod setup;
pub mod synth;

pub use adjoint::{check_gradient, GradientComponent};
pub use block::BlockGrid;
pub use error::InverseError;
pub use model::{Acquisition, CellMedia, Evaluation, Setup, SolveSettings, WorkCounts};
pub use optimize::{acquire, AcquireOptions, Acquired, IterationRecord, Lambda, Method, Sample, StopReason};
pub use output::to_voxel_grid;
pub use setup::{Observation, Pattern};
pub use synth::{synthesize, SynthOptions};
