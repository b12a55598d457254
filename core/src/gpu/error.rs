//! Errors of the GPU backend.

use crate::diffusion::DiffusionError;
use crate::hierarchy::HierarchyError;

/// What went wrong in choosing, starting or using the GPU.
///
/// Every variant says what was asked and what was found, so a bake that required the GPU fails
/// with a message the user can act on (install a driver, set `TRANSCUT_BACKEND=cpu`).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GpuError {
    /// `TRANSCUT_BACKEND` (or a backend option) holds something other than cpu, gpu or auto.
    #[error("unknown backend {value:?}: expected one of cpu, gpu, auto")]
    UnknownBackend {
        /// The value given.
        value: String,
    },
    /// The library was built without the `gpu` feature.
    #[error("the GPU backend was requested but libtranscut was built without the `gpu` feature")]
    NotBuilt,
    /// No GPU adapter could be found (no Vulkan/Metal/DX12 driver, or none matched the filter).
    #[error(
        "no GPU adapter found ({detail}); install a Vulkan driver (on Debian, `mesa-vulkan-drivers` \
         provides the lavapipe software device) or use TRANSCUT_BACKEND=cpu"
    )]
    NoAdapter {
        /// What was searched and what was seen.
        detail: String,
    },
    /// The adapter refused to create a device.
    #[error("GPU adapter {adapter:?} could not create a device: {message}")]
    DeviceRequest {
        /// The adapter's name.
        adapter: String,
        /// wgpu's message.
        message: String,
    },
    /// A problem is larger than the device allows (buffer size or dispatch limits).
    #[error("{what} needs {needed} but the GPU {device:?} allows at most {limit}")]
    TooLarge {
        /// What is too large, e.g. `"matrix values buffer (bytes)"`.
        what: &'static str,
        /// The size needed.
        needed: u64,
        /// The device's limit.
        limit: u64,
        /// The device's name.
        device: String,
    },
    /// The device reported an error (validation, out of memory, device lost) or a buffer could
    /// not be read back.
    #[error("GPU error during {during}: {message}")]
    Device {
        /// The operation, e.g. `"PCG iterations"`.
        during: &'static str,
        /// wgpu's message.
        message: String,
    },
    /// The operation is not available on the GPU for this input.
    #[error("{what} is not supported")]
    Unsupported {
        /// What was asked.
        what: &'static str,
    },
    /// The diffusion system or a vector argument is invalid, or the solve failed in the way the
    /// CPU solver reports (not converged, breakdown); the same error the CPU path gives.
    #[error(transparent)]
    Diffusion(#[from] DiffusionError),
    /// The hierarchical dipole's input is invalid (positions, irradiance); the error the CPU
    /// path gives.
    #[error(transparent)]
    Hierarchy(#[from] HierarchyError),
}
