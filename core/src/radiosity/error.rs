//! Why the radiosity stage refused its input. Nothing changed.

use crate::progress::Cancelled;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RadiosityError {
    #[error("the scene has no surface with area to make patches on")]
    NoPatches,
    #[error("surface {surface}: triangle {triangle} refers to vertex {index}, but the surface has {vertices} vertices")]
    IndexOutOfRange { surface: usize, triangle: usize, index: u32, vertices: usize },
    #[error("surface {surface}: vertex {vertex} is not finite: {value:?}")]
    NonFinite { surface: usize, vertex: usize, value: [f64; 3] },
    #[error("the patch size must be finite and > 0, got {0}")]
    InvalidPatchSize(f64),
    #[error("refining to that patch size would make about {estimated} triangles, more than the {limit} allowed")]
    TooFine { estimated: usize, limit: usize },
    #[error("{what}: expected {expected} values (one per patch), got {got}")]
    WrongLength { what: &'static str, expected: usize, got: usize },
    #[error("{what} of patch {patch} is out of range: {value:?} (albedo in [0, 1), irradiance and emission finite and ≥ 0)")]
    InvalidValue { what: &'static str, patch: usize, value: [f64; 3] },
    #[error(
        "the {rule} rule (Sheng et al. 2014 eq. 16) needs every medium's profile to have a finite R(0) > 0, and the {profile} \
         profile has none: choose profile = \"dipole\", or the consistent rule"
    )]
    HetRuleProfile { rule: &'static str, profile: &'static str },
    #[error(
        "{media} distinct media in one object, more than the {limit} a profile matrix indexes (the media are quantised to at \
         most that many)"
    )]
    TooManyMedia { media: usize, limit: usize },
    #[error("invalid options: {0}")]
    InvalidOptions(String),
    /// The device computing the gather F B failed (its error's message: the device's own error
    /// type is of a layer above this one).
    #[error("the radiosity gather on the GPU failed: {0}")]
    Device(String),
    #[error("{0}")]
    Cancelled(#[from] Cancelled),
}
