//! A translucent object scattered by a profile matrix (design/radiosity.md §1.5 (b); Sheng et
//! al. 2014 eq. 8) instead of its diffusion solve: no tets. Its patches are its own surface
//! refined to the patch size (one-sided, front outside, the user's vertices first), and
//!
//! - S_ji = ∫_{Aᵢ} R(d(x_j, y)) dA_y + δ_ji·local, R the medium's half-space or dipole profile
//!   per channel, built in millimetres ([`ProfileScattering`]);
//! - the radiosity B = S(q_d + tFB) with t = 1 − F_ext(η) (design §1.2);
//! - the radiance Lo(x, n) = T(η, 0)/(π η² (1 − Fdr)) · B ([`radiance_factor`]), clamped at 0.
//!
//! The medium must be homogeneous: the heterogeneous rules of `radiosity::heterogeneous` need
//! per-material path lengths along each pair's optical path, which no distance mode gathers yet.
//! A new medium re-indexes S from its cached samples (no geometry) when its profiles reach no
//! further than the build's, and builds S afresh otherwise.

use std::sync::Arc;

use glam::DVec3;

use super::super::Target;
use super::surfaces::PatchSurface;
use crate::optics::fresnel::f_ext;
use crate::optics::Medium;
use crate::radiosity::{
    radiance_factor, DistanceMode, InteriorGraph, ObjectPatches, Profile, ProfileOptions, ProfileScattering, RadiosityError,
    Scattering, MAX_VOXELS,
};
use crate::scene::{MediumSource, OpticalDistance, ProfileKind, ProfileScatteringOptions, SceneError, Shape};

/// One translucent object's profile S, with what a rebuild for a new medium needs.
#[derive(Debug, Clone)]
pub(super) struct ProfileObject {
    /// Shared between a session's solution and its scratch copies (never mutated in place).
    scattering: Arc<ProfileScattering>,
    /// The object's patches in millimetres.
    patches: Arc<ObjectPatches>,
    distance: Arc<DistanceMode>,
    options: ProfileScatteringOptions,
    medium: Medium,
}

impl ProfileObject {
    /// The profile S of `target` on its patch surface `surface` (scene units, `mm_per_unit`).
    ///
    /// # Errors
    /// [`SceneError::InvalidObject`] for a heterogeneous medium, a tet-mesh shape, or a distance
    /// graph beyond its budget; [`SceneError::Medium`] for an invalid medium.
    pub(super) fn build(
        target: &Target<'_>,
        surface: &PatchSurface,
        mm_per_unit: f64,
        options: &ProfileScatteringOptions,
    ) -> Result<ProfileObject, SceneError> {
        let medium = homogeneous_medium(target, target.object.medium())?;
        let invalid = |e: RadiosityError| target.invalid(format!("profile scattering: {e}"));
        let positions: Vec<DVec3> = surface.positions.iter().map(|&p| p * mm_per_unit).collect();
        let patches = ObjectPatches::from_surface(&positions, &surface.triangles).map_err(invalid)?;
        let distance = distance_mode(&patches, &positions, &surface.triangles, &medium, &options.distance).map_err(invalid)?;
        let scattering = matrix(&patches, &distance, options, &medium).map_err(invalid)?;
        Ok(ProfileObject {
            scattering: Arc::new(scattering),
            patches: Arc::new(patches),
            distance: Arc::new(distance),
            options: *options,
            medium,
        })
    }

    /// The same object with `medium` (the geometry kept): S re-indexed, or built afresh when a
    /// channel's profile now reaches beyond the samples gathered.
    ///
    /// # Errors
    /// As [`ProfileObject::build`].
    pub(super) fn with_medium(&self, target: &Target<'_>, medium: &MediumSource) -> Result<ProfileObject, SceneError> {
        let medium = homogeneous_medium(target, Some(medium))?;
        let new = profiles(self.options.profile, &medium);
        let mut scattering = (*self.scattering).clone();
        if scattering.set_profiles(&new).is_err() {
            scattering = self.matrix_for(&medium).map_err(|e| target.invalid(format!("profile scattering: {e}")))?;
        }
        Ok(ProfileObject { scattering: Arc::new(scattering), medium, ..self.clone() })
    }

    /// S built from the geometry for `medium`, gathering within its own cutoffs.
    fn matrix_for(&self, medium: &Medium) -> Result<ProfileScattering, RadiosityError> {
        matrix(&self.patches, &self.distance, &self.options, medium)
    }

    /// The refractive index of the object's medium.
    pub(super) fn eta(&self) -> f64 {
        self.medium.eta
    }

    /// t = 1 − F_ext(η): the part of diffuse light that enters (design §1.2).
    pub(super) fn transmittance(&self) -> f64 {
        1.0 - f_ext(self.eta())
    }

    /// The number of patches.
    pub(super) fn len(&self) -> usize {
        self.patches.len()
    }

    /// Nonzero entries of S.
    pub(super) fn nonzeros(&self) -> usize {
        self.scattering.matrix().cache().nonzeros()
    }

    /// Bytes S and its samples hold.
    pub(super) fn bytes(&self) -> usize {
        self.scattering.matrix().bytes()
    }

    /// The solver's operator (B = S q).
    pub(super) fn operator(&self) -> ProfileOperator<'_> {
        ProfileOperator { scattering: &self.scattering }
    }

    /// Lo(x, n) = radiance_factor(η)·B per patch, clamped at 0 (module documentation), and
    /// which patches were clamped.
    pub(super) fn radiance(&self, b: &[[f64; 3]]) -> (Vec<[f64; 3]>, Vec<bool>) {
        let k = radiance_factor(self.eta());
        let clamped = b.iter().map(|x| x.iter().any(|&x| x < 0.0)).collect();
        (b.iter().map(|x| x.map(|x| (k * x).max(0.0))).collect(), clamped)
    }
}

/// [`ProfileScattering`] as the solver's operator, its errors the scene's.
pub(super) struct ProfileOperator<'a> {
    scattering: &'a ProfileScattering,
}

impl Scattering for ProfileOperator<'_> {
    type Error = SceneError;

    fn scatter(&mut self, q: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, SceneError> {
        Ok(self.scattering.matrix().apply(q)?)
    }
}

/// S of `patches` at the distances of `distance` for `medium`'s profiles of `options`.
fn matrix(
    patches: &ObjectPatches,
    distance: &DistanceMode,
    options: &ProfileScatteringOptions,
    medium: &Medium,
) -> Result<ProfileScattering, RadiosityError> {
    let build = ProfileOptions { distance: distance.clone(), tail: options.tail, gather_radius: None };
    ProfileScattering::new(patches, &profiles(options.profile, medium), &build)
}

/// Each channel's profile of `kind` for `medium`.
fn profiles(kind: ProfileKind, medium: &Medium) -> [Profile; 3] {
    match kind {
        ProfileKind::HalfSpace => Profile::half_space_rgb(medium),
        ProfileKind::Dipole => Profile::dipole_rgb(medium),
    }
}

/// The one medium of a profile object, or an error naming what the profile S cannot take.
///
/// # Errors
/// [`SceneError::InvalidObject`] for a tet-mesh shape or a medium other than
/// [`MediumSource::Homogeneous`]; [`SceneError::Medium`] for an invalid one.
pub(super) fn homogeneous_medium(target: &Target<'_>, medium: Option<&MediumSource>) -> Result<Medium, SceneError> {
    if matches!(target.object.shape, Shape::Tetrahedra(_)) {
        return Err(target.invalid(
            "profile scattering works on surfaces: give the object as a surface, or use scattering = \"diffusion\" for a tet mesh",
        ));
    }
    match medium {
        Some(MediumSource::Homogeneous(m)) => {
            m.validate().map_err(|e| target.invalid(format!("medium: {e}")))?;
            Ok(*m)
        }
        Some(_) => Err(target.invalid(
            "profile scattering needs a homogeneous medium (per-material path lengths are not gathered yet): use scattering = \
             \"diffusion\" for a heterogeneous one",
        )),
        None => Err(target.invalid("an opaque diffuse surface has no profile")),
    }
}

/// The distance mode of `options` on the object of `patches` (mm): for the interior one, its
/// voxel graph at the voxel size asked for, or a quarter of its smallest 1/σtr, coarsened to
/// stay within half of [`MAX_VOXELS`].
fn distance_mode(
    patches: &ObjectPatches,
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    medium: &Medium,
    options: &OpticalDistance,
) -> Result<DistanceMode, RadiosityError> {
    let OpticalDistance::Interior { voxel_mm, any_angle } = *options else { return Ok(DistanceMode::Euclidean) };
    let corners: Vec<[DVec3; 3]> = triangles.iter().map(|t| t.map(|v| positions[v as usize])).collect();
    let spacing = voxel_mm.unwrap_or_else(|| default_voxel_mm(positions, medium));
    let graph = InteriorGraph::voxels(patches.bvh(), &corners, spacing)?;
    Ok(DistanceMode::Interior { graph, any_angle })
}

/// A quarter of the smallest diffusion length 1/σtr (design pitfall 3), no finer than half of
/// [`MAX_VOXELS`] in the bounding box of `positions` (mm) allows.
fn default_voxel_mm(positions: &[DVec3], medium: &Medium) -> f64 {
    let finest = medium.sigma_tr().iter().map(|&s| 0.25 / s).fold(f64::INFINITY, f64::min);
    let (lo, hi) = positions
        .iter()
        .fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let size = hi - lo;
    let budget = (size.x * size.y * size.z / (0.5 * MAX_VOXELS as f64)).cbrt();
    finest.max(budget)
}
