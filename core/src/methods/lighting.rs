//! The lighting every method solves under.

use crate::light::{self, Light, LightError, SourceOptions};
use crate::mesh::{TriMesh, TriangleBvh};
use crate::DVec3;

/// The lights of a scene, the occluder that shadows them (every object's world surface, when
/// shadows are on) and how area lights, environments and shadows are sampled.
#[derive(Debug, Clone, Copy)]
pub struct Lighting<'a> {
    pub lights: &'a [Light],
    /// Triangles that cast shadows (`None`: no shadows).
    pub occluder: Option<&'a TriangleBvh>,
    pub source: &'a SourceOptions,
}

impl<'a> Lighting<'a> {
    /// The occluder of `surfaces` (world space), for [`Lighting::occluder`].
    #[must_use]
    pub fn occluder_of(surfaces: &[TriMesh]) -> TriangleBvh {
        TriangleBvh::new(surfaces.iter().flat_map(|m| (0..m.triangles().len()).map(move |t| m.triangle(t))).collect())
    }

    /// The light transmitted through the surface at `points` with outward unit `normals` into a
    /// medium of index `eta`: q(x) = ∫ Li (n·ω)⁺ T(η, ω) V dω ([`light::transmitted_source`]).
    ///
    /// # Errors
    /// [`LightError`] for an invalid light or η, or mismatched lengths.
    pub fn transmitted_source(&self, points: &[DVec3], normals: &[DVec3], eta: f64) -> Result<Vec<[f64; 3]>, LightError> {
        self.transmitted_source_with(points, normals, eta, &|_| Ok(()))
    }

    /// [`Lighting::transmitted_source`] with a progress check ([`light::transmitted_source_with`]).
    ///
    /// # Errors
    /// As [`Lighting::transmitted_source`], plus [`LightError::Cancelled`].
    pub fn transmitted_source_with(
        &self,
        points: &[DVec3],
        normals: &[DVec3],
        eta: f64,
        poll: light::Poll<'_>,
    ) -> Result<Vec<[f64; 3]>, LightError> {
        light::transmitted_source_with(self.lights, points, normals, eta, self.occluder, self.source, poll)
    }
}
