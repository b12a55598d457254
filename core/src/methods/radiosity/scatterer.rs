//! What scatters the light of one translucent object (design/radiosity.md §1.5): its prepared
//! TransCut system (S through its diffusion solve) or its profile matrix, and the operator the
//! coupled solver applies for either.

use super::super::transcut::Prepared;
use super::profile_object::{ProfileObject, ProfileOperator};
use super::scattering::DiffusionScattering;
use crate::radiosity::Scattering;
use crate::scene::SceneError;

/// One translucent object's scattering state (module documentation). The variants differ in
/// size (a prepared system is ~500 bytes of handles, a profile object ~100), but there is one per
/// object, so boxing would buy nothing.
#[derive(Clone)]
#[allow(clippy::large_enum_variant)]
pub(super) enum Scatterer {
    /// Tets, media and the assembled system; its source and fluence are scratch.
    Diffusion(Prepared),
    /// The profile matrix on the object's surface.
    Profile(ProfileObject),
}

impl Scatterer {
    /// The refractive index at the object's surface.
    pub(super) fn eta(&self) -> f64 {
        match self {
            Scatterer::Diffusion(p) => p.system().boundary_terms().eta,
            Scatterer::Profile(o) => o.eta(),
        }
    }

    /// The prepared system of a diffusion object.
    pub(super) fn prepared(&self) -> Option<&Prepared> {
        match self {
            Scatterer::Diffusion(p) => Some(p),
            Scatterer::Profile(_) => None,
        }
    }

    /// The prepared system of a diffusion object, to solve on.
    pub(super) fn prepared_mut(&mut self) -> Option<&mut Prepared> {
        match self {
            Scatterer::Diffusion(p) => Some(p),
            Scatterer::Profile(_) => None,
        }
    }

    /// The profile matrix of a profile object.
    pub(super) fn profile(&self) -> Option<&ProfileObject> {
        match self {
            Scatterer::Diffusion(_) => None,
            Scatterer::Profile(o) => Some(o),
        }
    }

    /// The number of the object's patches.
    pub(super) fn patch_count(&self) -> usize {
        match self {
            Scatterer::Diffusion(p) => p.system().boundary().len(),
            Scatterer::Profile(o) => o.len(),
        }
    }
}

/// The coupled solver's S of one translucent object.
pub(super) enum Operator<'a> {
    Diffusion(DiffusionScattering<'a>),
    Profile(ProfileOperator<'a>),
}

impl Scattering for Operator<'_> {
    type Error = SceneError;

    fn scatter(&mut self, q: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, SceneError> {
        match self {
            Operator::Diffusion(op) => op.scatter(q),
            Operator::Profile(op) => op.scatter(q),
        }
    }
}
