//! A translucent object scattered by a profile matrix (design/radiosity.md §1.5 (b); Sheng et
//! al. 2014 eq. 8) instead of its diffusion solve: no tets. Its patches are its own surface
//! refined to the patch size (one-sided, front outside, the user's vertices first), and
//!
//! - S_ji = ∫_{Aᵢ} R(d(x_j, y)) dA_y + δ_ji·local, R the medium's half-space or dipole profile
//!   per channel, built in millimetres ([`ProfileScattering`]);
//! - the radiosity B = S(q_d + tFB) with t = 1 − F_ext(η) (design §1.2);
//! - the radiance Lo(x, n) = T(η, 0)/(π η² (1 − Fdr)) · B ([`radiance_factor`]), clamped at 0.
//!
//! A heterogeneous medium (layers, voxels, veins; [`super::profile_media`]) is quantised into at
//! most [`crate::radiosity::MAX_MEDIA`] distinct media, each path's lengths in each gathered along
//! its chord, and each sample's profile value is the options' rule of those lengths
//! ([`crate::radiosity::HetRule`]: the consistent one by default, or Sheng et al. 2014 eq. 16;
//! [`ProfileMatrix::build_media`](crate::radiosity::ProfileMatrix::build_media)). A field of one
//! distinct medium is that homogeneous medium, with no per-pair cost. Chord distances only for a
//! heterogeneous medium; material tables and per-tet media (which need tets) are refused.
//!
//! A new homogeneous medium in place of a homogeneous one re-indexes S from its cached samples
//! (no geometry) when its profiles reach no further than the build's, and builds S afresh
//! otherwise; a heterogeneous medium, old or new, builds S afresh on the same patches.

use std::sync::Arc;

use glam::DVec3;

use super::super::Target;
use super::profile_media::{check_medium, ObjectMedia, ProfileMediumError};
use super::surfaces::PatchSurface;
use crate::optics::fresnel::f_ext;
use crate::optics::Medium;
use crate::radiosity::{
    radiance_factor, DistanceMode, InteriorGraph, ObjectPatches, Profile, ProfileOptions, ProfileScattering, RadiosityError,
    Scattering, MAX_VOXELS,
};
use crate::scene::{MediumSource, OpticalDistance, ProfileKind, ProfileScatteringOptions, SceneError};

/// One translucent object's profile S, with what a rebuild for a new medium needs.
#[derive(Debug, Clone)]
pub(super) struct ProfileObject {
    /// Shared between a session's solution and its scratch copies (never mutated in place).
    scattering: Arc<ProfileScattering>,
    /// The object's patches in millimetres.
    patches: Arc<ObjectPatches>,
    distance: Arc<DistanceMode>,
    options: ProfileScatteringOptions,
    media: Arc<ObjectMedia>,
    mm_per_unit: f64,
}

impl ProfileObject {
    /// The profile S of `target` on its patch surface `surface` (scene units, `mm_per_unit`).
    ///
    /// # Errors
    /// [`SceneError::InvalidObject`] for a medium [`check_medium`] refuses, a heterogeneous
    /// medium with interior distances, a tet-mesh shape, a distance graph beyond its budget, or
    /// a het rule the profile cannot take; [`SceneError::Medium`] for an invalid medium.
    pub(super) fn build(
        target: &Target<'_>,
        surface: &PatchSurface,
        mm_per_unit: f64,
        options: &ProfileScatteringOptions,
    ) -> Result<ProfileObject, SceneError> {
        check_medium(target, target.object.medium())?;
        let source = target.object.medium().expect("checked");
        let invalid = |e: RadiosityError| target.invalid(format!("profile scattering: {e}"));
        let positions: Vec<DVec3> = surface.positions.iter().map(|&p| p * mm_per_unit).collect();
        let patches = ObjectPatches::from_surface(&positions, &surface.triangles).map_err(invalid)?;
        let media = object_media(target, source, &patches, mm_per_unit, options)?;
        let distance = match &media {
            ObjectMedia::Homogeneous(medium) => {
                distance_mode(&patches, &positions, &surface.triangles, medium, &options.distance).map_err(invalid)?
            }
            ObjectMedia::Heterogeneous(_) => DistanceMode::Euclidean,
        };
        let scattering = matrix(&patches, &distance, options, &media).map_err(invalid)?;
        Ok(ProfileObject {
            scattering: Arc::new(scattering),
            patches: Arc::new(patches),
            distance: Arc::new(distance),
            options: *options,
            media: Arc::new(media),
            mm_per_unit,
        })
    }

    /// The same object with `medium` (the geometry kept): S re-indexed when both media are
    /// homogeneous, or built afresh when a channel's profile now reaches beyond the samples
    /// gathered or either medium is heterogeneous.
    ///
    /// # Errors
    /// As [`ProfileObject::build`].
    pub(super) fn with_medium(&self, target: &Target<'_>, medium: &MediumSource) -> Result<ProfileObject, SceneError> {
        check_medium(target, Some(medium))?;
        let media = object_media(target, medium, &self.patches, self.mm_per_unit, &self.options)?;
        let invalid = |e: RadiosityError| target.invalid(format!("profile scattering: {e}"));
        let scattering = match (&*self.media, &media) {
            (ObjectMedia::Homogeneous(_), ObjectMedia::Homogeneous(m)) => {
                let mut scattering = (*self.scattering).clone();
                match scattering.set_profiles(&profiles(self.options.profile, m)) {
                    Ok(()) => scattering,
                    Err(_) => self.matrix_for(&media).map_err(invalid)?,
                }
            }
            _ => self.matrix_for(&media).map_err(invalid)?,
        };
        Ok(ProfileObject { scattering: Arc::new(scattering), media: Arc::new(media), ..self.clone() })
    }

    /// S built from the geometry for `media`, gathering within its own cutoffs.
    fn matrix_for(&self, media: &ObjectMedia) -> Result<ProfileScattering, RadiosityError> {
        matrix(&self.patches, &self.distance, &self.options, media)
    }

    /// The refractive index of the object's medium.
    pub(super) fn eta(&self) -> f64 {
        self.media.eta()
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

/// S of `patches` at the distances of `distance` for `media`'s profiles of `options` (the
/// heterogeneous matrix under `options.het` for several media).
fn matrix(
    patches: &ObjectPatches,
    distance: &DistanceMode,
    options: &ProfileScatteringOptions,
    media: &ObjectMedia,
) -> Result<ProfileScattering, RadiosityError> {
    let build = ProfileOptions { distance: distance.clone(), tail: options.tail, gather_radius: None };
    match media {
        ObjectMedia::Homogeneous(medium) => ProfileScattering::new(patches, &profiles(options.profile, medium), &build),
        ObjectMedia::Heterogeneous(q) => {
            let palette: Vec<[Profile; 3]> = q.palette().iter().map(|m| profiles(options.profile, m)).collect();
            ProfileScattering::with_media(patches, &palette, &**q, options.het, &build)
        }
    }
}

/// Each channel's profile of `kind` for `medium`.
fn profiles(kind: ProfileKind, medium: &Medium) -> [Profile; 3] {
    match kind {
        ProfileKind::HalfSpace => Profile::half_space_rgb(medium),
        ProfileKind::Dipole => Profile::dipole_rgb(medium),
    }
}

/// The media of `source` on `patches`, refused by name when heterogeneous under interior
/// distances, or when the het rule cannot take the profile kind.
fn object_media(
    target: &Target<'_>,
    source: &MediumSource,
    patches: &ObjectPatches,
    mm_per_unit: f64,
    options: &ProfileScatteringOptions,
) -> Result<ObjectMedia, SceneError> {
    let media = ObjectMedia::new(target, source, patches, mm_per_unit);
    if let ObjectMedia::Heterogeneous(q) = &media {
        if let OpticalDistance::Interior { .. } = options.distance {
            return Err(target.invalid(ProfileMediumError::InteriorHeterogeneous.to_string()));
        }
        for p in q.palette().iter().flat_map(|m| profiles(options.profile, m)) {
            options.het.check(&p).map_err(|e| target.invalid(format!("profile scattering: {e}")))?;
        }
    }
    Ok(media)
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
