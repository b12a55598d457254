//! Why a bake failed.

use crate::diffusion::{DiffusionError, Unresolved};
use crate::gpu::GpuError;
use crate::light::LightError;
use crate::mesher::MesherError;
use crate::polygrid::PolygridError;
use crate::progress::Cancelled;
use crate::radiosity::RadiosityError;
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
    /// Building or solving an object's polygrid failed.
    #[error("object {index} ({name}): polygrid: {source}")]
    Polygrid {
        index: usize,
        name: String,
        #[source]
        source: PolygridError,
    },
    /// A light is invalid or the source could not be computed.
    #[error("lights: {0}")]
    Light(LightError),
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
    /// The method's discretisation cannot resolve the object's medium, so its radiance would be
    /// wrong (TransCut: `σtr · h` at the surface above the bound; too dark, then zero): never a
    /// wrong picture instead. Names the worst channel and what would resolve it.
    #[error(
        "object {index} ({name}): the mesh does not resolve the medium's {channel} channel: σtr·h = {sigma_tr_h:.3} at the \
         surface (mesh spacing {spacing_mm:.4} mm) is above its bound {bound:.3}, where the radiance would be too dark \
         or zero; about {tets_needed:.0} tets instead of {tets} would resolve it, or the object at {scale:.3e} times \
         its size (mm_per_unit)"
    )]
    Unresolved {
        index: usize,
        name: String,
        /// `red`, `green` or `blue`.
        channel: &'static str,
        /// σtr · h of that channel.
        sigma_tr_h: f64,
        /// The largest σtr · h the method bakes in this channel of this medium (TransCut: its
        /// assembly's `max_resolution` over the radiance amplification of the channel's albedo).
        bound: f64,
        /// The mesh's spacing at the surface in mm (TransCut: the mean boundary edge length).
        spacing_mm: f64,
        /// The tets the bake had.
        tets: usize,
        /// About how many tets would resolve the channel.
        tets_needed: f64,
        /// The factor on the object's size (its `mm_per_unit`) that would resolve it at the
        /// same tet count.
        scale: f64,
    },
    /// The radiosity method's patches, form factors or solve refused the scene.
    #[error("radiosity: {0}")]
    Radiosity(RadiosityError),
    /// Cancelled through the progress callback.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// A radiosity error of a bake: a cancellation is the bake's [`SceneError::Cancelled`],
/// anything else [`SceneError::Radiosity`].
impl From<RadiosityError> for SceneError {
    fn from(e: RadiosityError) -> Self {
        match e {
            RadiosityError::Cancelled(c) => Self::Cancelled(c),
            e => Self::Radiosity(e),
        }
    }
}

/// A light error of a bake: a cancellation while sampling is the bake's
/// [`SceneError::Cancelled`], anything else [`SceneError::Light`].
impl From<LightError> for SceneError {
    fn from(e: LightError) -> Self {
        match e {
            LightError::Cancelled(c) => Self::Cancelled(c),
            e => Self::Light(e),
        }
    }
}

impl SceneError {
    /// [`SceneError::Unresolved`] for object `index` (`name`).
    #[must_use]
    pub(crate) fn unresolved(index: usize, name: String, u: Unresolved) -> Self {
        let Unresolved { channel, sigma_tr_h, bound, spacing_mm, tets, tets_needed, scale } = u;
        Self::Unresolved { index, name, channel, sigma_tr_h, bound, spacing_mm, tets, tets_needed, scale }
    }
}
