//! Why a bake failed.

use crate::diffusion::DiffusionError;
use crate::gpu::GpuError;
use crate::light::LightError;
use crate::mesher::MesherError;
use crate::progress::Cancelled;
use crate::volume::VolumeError;

/// Why a bake failed. Every variant names the object (index and name) where one is at fault.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneError {
    /// The scene has no objects.
    #[error("the scene has no objects")]
    NoObjects,
    /// A bake option is out of range (the message names the method for a method's option).
    #[error("invalid bake option: {0}")]
    InvalidOptions(String),
    /// An object's own parameters are invalid.
    #[error("object {index} ({name}): {message}")]
    InvalidObject { index: usize, name: String, message: String },
    /// The method cannot bake this object (e.g. a medium it does not handle): never a wrong
    /// picture instead.
    #[error("object {index} ({name}): the {method} method cannot bake it: {reason}")]
    Unsupported { index: usize, name: String, method: &'static str, reason: String },
    /// An object's heterogeneous medium could not be put on its tets.
    #[error("object {index} ({name}): medium: {source}")]
    Medium {
        index: usize,
        name: String,
        #[source]
        source: VolumeError,
    },
    /// Meshing an object failed.
    #[error("object {index} ({name}): meshing failed: {source}")]
    Mesher {
        index: usize,
        name: String,
        #[source]
        source: MesherError,
    },
    /// A light is invalid or the source could not be computed.
    #[error("lights: {0}")]
    Light(#[from] LightError),
    /// Assembly or solve failed for an object.
    #[error("object {index} ({name}): {source}")]
    Diffusion {
        index: usize,
        name: String,
        #[source]
        source: DiffusionError,
    },
    /// The GPU was required (`Backend::Gpu`) and could not be used, or failed.
    #[error("object {index} ({name}): GPU backend: {source}")]
    Gpu {
        index: usize,
        name: String,
        #[source]
        source: GpuError,
    },
    /// Cancelled through the progress callback.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}
