//! The choice between the CPU and GPU paths: [`Backend`] (`TRANSCUT_BACKEND=cpu|gpu|auto`) and
//! [`solve_on`], the one entry of a diffusion solve that may run on either: it runs a
//! [`Solver`] (or a [`SolverKind`] it prepares) on the chosen backend and reports which ran.

use std::fmt;
use std::str::FromStr;

use super::error::GpuError;
use crate::diffusion::{DiffusionSystem, Solution, Solver, SolverKind};
use crate::sparse::hierarchy::HierarchyOptions;
use crate::sparse::{CsrMatrix3, SolveOptions};

/// The environment variable that chooses the backend when the caller does not.
pub const BACKEND_ENV: &str = "TRANSCUT_BACKEND";

/// Where the diffusion solve runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Backend {
    /// The CPU path (rayon), always available.
    Cpu,
    /// The GPU path (wgpu); an error if no adapter exists.
    Gpu,
    /// The GPU when a hardware adapter exists, else the CPU (the report says why). A software
    /// adapter (Mesa's lavapipe, device type CPU) is not used by `Auto`: it is many times slower
    /// than the CPU path; [`Backend::Gpu`] still runs on it. On Linux, a machine with no GPU
    /// device node ([`super::no_hardware_gpu`]) solves on the CPU without loading the drivers.
    #[default]
    Auto,
}

impl Backend {
    /// The backend named by `TRANSCUT_BACKEND`, or `default` when it is unset or empty.
    ///
    /// # Errors
    /// [`GpuError::UnknownBackend`] for a value other than cpu, gpu, auto (any case).
    pub fn from_env_or(default: Backend) -> Result<Backend, GpuError> {
        match std::env::var(BACKEND_ENV) {
            Ok(v) if !v.trim().is_empty() => v.parse(),
            _ => Ok(default),
        }
    }

    /// The lowercase name (`cpu`, `gpu`, `auto`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Backend::Cpu => "cpu",
            Backend::Gpu => "gpu",
            Backend::Auto => "auto",
        }
    }
}

impl FromStr for Backend {
    type Err = GpuError;

    fn from_str(s: &str) -> Result<Backend, GpuError> {
        match s.trim().to_ascii_lowercase().as_str() {
            "cpu" => Ok(Backend::Cpu),
            "gpu" => Ok(Backend::Gpu),
            "auto" => Ok(Backend::Auto),
            _ => Err(GpuError::UnknownBackend { value: s.to_owned() }),
        }
    }
}

impl fmt::Display for Backend {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Which path ran a solve, and why.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct BackendReport {
    /// The backend asked for.
    pub requested: Backend,
    /// The backend that ran ([`Backend::Cpu`] or [`Backend::Gpu`], never `Auto`).
    pub used: Backend,
    /// The GPU adapter's name when the GPU ran.
    pub device: Option<String>,
    /// Why `Auto` fell back to the CPU (the GPU error's message), `None` otherwise.
    pub fallback: Option<String>,
    /// The GPU timings when the GPU ran.
    #[cfg(feature = "gpu")]
    pub gpu: Option<super::GpuStats>,
}

/// What [`solve_on`] solves with.
#[derive(Debug, Clone, Copy)]
pub enum SolveWith<'a> {
    /// A solver of this kind, prepared for the backend that runs: on the CPU
    /// [`Solver::new`] (default hierarchy options), on the device its twin.
    Kind(SolverKind),
    /// A solver the caller prepared (and keeps) for this system's matrix.
    Solver(&'a Solver),
}

impl SolveWith<'_> {
    /// The kind of solver.
    #[must_use]
    pub fn kind(&self) -> SolverKind {
        match self {
            Self::Kind(k) => *k,
            Self::Solver(s) => s.kind(),
        }
    }
}

/// Solves the diffusion system on `backend` with `with`, from `warm_start` or cold.
///
/// - [`Backend::Cpu`] runs [`Solver::solve`].
/// - [`Backend::Gpu`] runs, on the process-wide device ([`super::GpuContext::shared`]), the
///   device twin of the kind: the single-level kinds ([`SolverKind::Pcg`], [`SolverKind::SsorPcg`])
///   run Jacobi PCG ([`super::solve`]; SSOR's sweeps are sequential within each level set, so
///   it has no device path), the multigrid kinds CG preconditioned by their V-cycle
///   ([`super::GpuSolver::with_multigrid`], the hierarchy and Galerkin operators built on the
///   CPU and uploaded once per call). [`SolverKind::Cascade`] has no device path: an error.
/// - [`Backend::Auto`] runs on the device unless none can be had (on Linux: no GPU device node,
///   then the drivers are not even loaded), the only one is a software rasteriser (lavapipe) or
///   the kind is the cascade; then the CPU, with the reason in
///   [`BackendReport::fallback`].
///
/// Every path meets the same f64 tolerance. Errors of the solve itself (not converged, bad warm
/// start) are returned as they are, never hidden by a fallback.
///
/// # Errors
/// [`GpuError::NoAdapter`], [`GpuError::DeviceRequest`] or [`GpuError::NotBuilt`] when the GPU
/// was required and cannot be had; [`GpuError::Unsupported`] for the cascade on
/// [`Backend::Gpu`]; [`GpuError::Diffusion`] for the errors of [`Solver::solve`]; the other
/// variants for a failing device.
pub fn solve_on(
    backend: Backend,
    with: SolveWith<'_>,
    system: &DiffusionSystem,
    warm_start: Option<&[[f64; 3]]>,
    options: &SolveOptions<'_>,
) -> Result<(Solution, BackendReport), GpuError> {
    let on_cpu = || -> Result<Solution, GpuError> {
        Ok(match with {
            SolveWith::Kind(kind) => {
                Solver::new(system, kind, &HierarchyOptions::default())?.solve(system, warm_start, options)?
            }
            SolveWith::Solver(solver) => solver.solve(system, warm_start, options)?,
        })
    };
    if with.kind() == SolverKind::Cascade {
        return match backend {
            Backend::Cpu => Ok((on_cpu()?, cpu_report(backend, None))),
            Backend::Auto => {
                Ok((on_cpu()?, cpu_report(backend, Some("the multiresolution cascade runs on the CPU only".into()))))
            }
            Backend::Gpu => {
                Err(GpuError::Unsupported { what: "the multiresolution cascade on the GPU (every other solver kind runs there)" })
            }
        };
    }
    on_backend(
        backend,
        on_cpu,
        #[cfg(feature = "gpu")]
        |context| {
            if with.kind().is_single_level() {
                return super::solve(context, system, warm_start, options);
            }
            let prepared;
            let solver = match with {
                SolveWith::Solver(solver) => solver,
                SolveWith::Kind(kind) => {
                    prepared = Solver::new(system, kind, &HierarchyOptions::default())?;
                    &prepared
                }
            };
            let mg = solver.multigrid().ok_or(GpuError::Unsupported { what: "a multigrid solver without its multigrid" })?;
            super::GpuSolver::with_multigrid(context, system, mg)?.solve(system, warm_start, options)
        },
    )
}

/// Solves a symmetric positive definite `matrix` x = `b` of one's own (the polygrid's
/// finite-volume system) where `backend` says, by the rule of [`solve_on`]: on the CPU by
/// `on_cpu`, on the device by Jacobi PCG inside the same f64 refinement
/// ([`super::pcg::GpuSolver::for_matrix`]), to the same tolerance.
///
/// # Errors
/// As [`solve_on`].
pub fn solve_matrix_on(
    backend: Backend,
    #[cfg_attr(not(feature = "gpu"), allow(unused_variables))] matrix: &CsrMatrix3,
    #[cfg_attr(not(feature = "gpu"), allow(unused_variables))] b: &[[f64; 3]],
    #[cfg_attr(not(feature = "gpu"), allow(unused_variables))] warm_start: Option<&[[f64; 3]]>,
    #[cfg_attr(not(feature = "gpu"), allow(unused_variables))] options: &SolveOptions<'_>,
    on_cpu: impl FnOnce() -> Result<Solution, GpuError>,
) -> Result<(Solution, BackendReport), GpuError> {
    on_backend(
        backend,
        on_cpu,
        #[cfg(feature = "gpu")]
        |context| super::GpuSolver::for_matrix(context, matrix)?.solve_matrix(matrix, b, warm_start, options),
    )
}

/// The report of a solve that ran on the CPU.
fn cpu_report(requested: Backend, fallback: Option<String>) -> BackendReport {
    BackendReport {
        requested,
        used: Backend::Cpu,
        device: None,
        fallback,
        #[cfg(feature = "gpu")]
        gpu: None,
    }
}

/// Where work with a GPU twin runs under `backend` (the rule of [`solve_on`]).
#[derive(Debug, Clone, Copy)]
pub enum DeviceChoice {
    /// On the CPU.
    Cpu,
    /// On this device.
    #[cfg(feature = "gpu")]
    Gpu(&'static super::GpuContext),
}

/// The device `backend` picks, and for `Auto` on the CPU why not the GPU: `Cpu` always the
/// CPU; `Gpu` the shared device (an error when there is none); `Auto` a hardware GPU when one
/// exists, else the CPU with the reason (no device node, no adapter, only a software adapter
/// such as lavapipe, not built with the `gpu` feature).
///
/// # Errors
/// For `Gpu` only: [`GpuError::NotBuilt`], or why the device could not be opened.
pub fn choose_device(backend: Backend) -> Result<(DeviceChoice, Option<String>), GpuError> {
    if backend == Backend::Cpu {
        return Ok((DeviceChoice::Cpu, None));
    }
    #[cfg(feature = "gpu")]
    {
        let cpu = |why: String| Ok((DeviceChoice::Cpu, Some(why)));
        if backend == Backend::Auto {
            if let Some(why) = super::no_hardware_gpu() {
                return cpu(why);
            }
        }
        let context = match super::GpuContext::shared() {
            Ok(c) => c,
            Err(e) if backend == Backend::Auto => return cpu(e.to_string()),
            Err(e) => return Err(e),
        };
        if backend == Backend::Auto && context.is_software() {
            return cpu(format!(
                "the only GPU adapter is a software one ({}), slower than the CPU path; \
                 TRANSCUT_BACKEND=gpu uses it anyway",
                context.device_name()
            ));
        }
        Ok((DeviceChoice::Gpu(context), None))
    }
    #[cfg(not(feature = "gpu"))]
    {
        match backend {
            Backend::Auto => Ok((DeviceChoice::Cpu, Some(GpuError::NotBuilt.to_string()))),
            _ => Err(GpuError::NotBuilt),
        }
    }
}

/// Where a solve runs, by [`choose_device`]: `on_cpu` for
/// [`Backend::Cpu`], `on_gpu` on the process-wide device for [`Backend::Gpu`]; for
/// [`Backend::Auto`] the device unless none can be had or the only one is a software
/// rasteriser, then `on_cpu` with the reason in [`BackendReport::fallback`].
fn on_backend(
    backend: Backend,
    on_cpu: impl FnOnce() -> Result<Solution, GpuError>,
    #[cfg(feature = "gpu")] on_gpu: impl FnOnce(&super::GpuContext) -> Result<super::GpuSolution, GpuError>,
) -> Result<(Solution, BackendReport), GpuError> {
    match choose_device(backend)? {
        (DeviceChoice::Cpu, fallback) => Ok((on_cpu()?, cpu_report(backend, fallback))),
        #[cfg(feature = "gpu")]
        (DeviceChoice::Gpu(context), _) => {
            let out = on_gpu(context)?;
            Ok((
                out.solution,
                BackendReport {
                    requested: backend,
                    used: Backend::Gpu,
                    device: Some(context.device_name().to_owned()),
                    fallback: None,
                    gpu: Some(out.stats),
                },
            ))
        }
    }
}
