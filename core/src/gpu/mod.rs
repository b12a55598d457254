//! The GPU backend (wgpu, WGSL compute kernels in `shaders/`): the TransCut assembly, the
//! three-channel PCG and the radiance query on the device, each the twin of a CPU path that is
//! always available.
//!
//! - [`Backend`] (`TRANSCUT_BACKEND=cpu|gpu|auto`) and [`solve_on`]: run a diffusion solve
//!   ([`SolveWith`] a [`crate::diffusion::SolverKind`] or a prepared
//!   [`crate::diffusion::Solver`]) on the chosen backend; `Auto` falls back to the CPU when no
//!   adapter exists or the only one is a software rasteriser (lavapipe), and says so in the
//!   [`BackendReport`].
//! - [`GpuContext`]: a headless device (adapter choice: discrete > integrated > virtual > CPU
//!   device such as Mesa's lavapipe; `WGPU_BACKEND`, `TRANSCUT_GPU_ADAPTER` narrow it), the
//!   compiled kernels and a buffer pool reused across solves.
//! - [`solve`] / [`GpuSolver`]: M φ = b on the device — assembly there for TransCut systems
//!   (`tet_geometry.wgsl` eq. 10 per tet, `assemble.wgsl` eqs. 10, 13, 14 gathered per row),
//!   Jacobi-preconditioned CG in f32 entirely on the device, inside an f64 iterative refinement
//!   on the host so the result meets the same f64 tolerance as [`crate::diffusion::solve`]
//!   (see [`pcg`](mod@pcg)).
//! - [`GpuSolver::with_multigrid`]: the same refinement around CG
//!   preconditioned by the multigrid V-cycle of [`crate::sparse::hierarchy`] on the device
//!   (Chebyshev–Jacobi smoothing, restriction `Pᵀ`, prolongation `P` of TransCut eq. 16, the
//!   coarsest solve as kernels; `core/src/gpu/multigrid.rs`).
//! - [`GpuDipole`]: the hierarchical dipole of a [`crate::hierarchy::DipoleHierarchy`] on the
//!   device (refit, pull, traversal, push; `shaders/dipole_*.wgsl`), the twin of its on-the-fly
//!   update.
//! - [`GpuPrt`]: a PRT transfer on the device, its product with the Haar-transformed
//!   irradiance (`prt_relight.wgsl`) and the combine into radiance (`prt_combine.wgsl`), the
//!   twins of [`crate::prt::Transfer::apply`] and the PRT method's combine.
//! - [`GpuRelaxation`]: weighted Jacobi and coloured Gauss–Seidel sweeps with frozen rows on
//!   the device (`relax_jacobi.wgsl`, `relax_gs.wgsl`) and [`GpuTransfer`]s between the levels
//!   of a hierarchy, the twins of [`crate::sparse::relax`] (polygrid diffusion's relaxation).
//! - [`assemble`], [`spmv_dot`], [`dot`], [`surface_radiance`] (eq. 3), [`restrict`],
//!   [`prolong_add`], [`vcycle`]: single kernels (or one V-cycle) with CPU twins, compared in
//!   `core/tests/integration/gpu*.rs` and `core/tests/gpu_*.rs`.
//!
//! Kernels ([`Kernel`]) are one WGSL file each with `shaders/common.wgsl` prepended, embedded
//! with `include_str!` and validated by naga in the tests. Without the `gpu` cargo feature only
//! [`Backend`], [`SolveWith`] and [`solve_on`] exist (the GPU then reports [`GpuError::NotBuilt`]).
//!
//! # Example
//!
//! ```no_run
//! use transcut::diffusion::SolverKind;
//! use transcut::gpu::{self, Backend, SolveWith};
//! # fn demo(system: &transcut::diffusion::DiffusionSystem) -> Result<(), transcut::gpu::GpuError> {
//! let backend = Backend::from_env_or(Backend::Auto)?;
//! let with = SolveWith::Kind(SolverKind::SsorPcg);
//! let (solution, report) = gpu::solve_on(backend, with, system, None, &Default::default())?;
//! println!("solved on {:?} ({:?}), fallback: {:?}", report.used, report.device, report.fallback);
//! # let _ = solution; Ok(()) }
//! ```

mod backend;
mod error;

pub use backend::{choose_device, solve_matrix_on, solve_on, Backend, BackendReport, DeviceChoice, SolveWith, BACKEND_ENV};
pub use error::GpuError;

#[cfg(feature = "gpu")]
mod context;
#[cfg(feature = "gpu")]
mod dipole;
#[cfg(feature = "gpu")]
mod layout;
#[cfg(feature = "gpu")]
mod matrix;
#[cfg(feature = "gpu")]
mod multigrid;
#[cfg(feature = "gpu")]
mod ops;
#[cfg(feature = "gpu")]
pub mod pcg;
#[cfg(feature = "gpu")]
mod pool;
#[cfg(feature = "gpu")]
mod prt;
#[cfg(feature = "gpu")]
mod radiance;
#[cfg(feature = "gpu")]
mod radiosity;
#[cfg(feature = "gpu")]
mod relax;
#[cfg(feature = "gpu")]
pub mod shaders;

#[cfg(feature = "gpu")]
pub use context::{no_hardware_gpu, GpuContext, ADAPTER_ENV};
#[cfg(feature = "gpu")]
pub use dipole::{GpuDipole, GpuDipoleStats, RECEIVERS_PER_TASK};
#[cfg(feature = "gpu")]
pub use matrix::assemble;
#[cfg(feature = "gpu")]
pub use multigrid::{prolong_add, restrict, vcycle};
#[cfg(feature = "gpu")]
pub use ops::{dot, spmv_dot};
#[cfg(feature = "gpu")]
pub use pcg::{solve, GpuSolution, GpuSolver, GpuStats};
#[cfg(feature = "gpu")]
pub use prt::{GpuPrt, LANES_PER_VERTEX};
#[cfg(feature = "gpu")]
pub use radiance::surface_radiance;
#[cfg(feature = "gpu")]
pub use radiosity::{GpuRadiosity, Sweep};
#[cfg(feature = "gpu")]
pub use relax::{GpuRelaxation, GpuTransfer};
#[cfg(feature = "gpu")]
pub use shaders::Kernel;
