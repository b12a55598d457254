//! The surface each object's patches lie on (design/radiosity.md §1.3): a translucent object's
//! tet-mesh boundary, its vertices in the order of the diffusion system's boundary (so patch k
//! of the object is boundary vertex k, where q and B live); an opaque object's world surface
//! refined to the patch size, its vertices first in their welded order, facing as its sides say;
//! a translucent object scattered by a profile, its world surface refined likewise, one-sided,
//! facing out.

use glam::DVec3;

use super::super::transcut::Prepared;
use super::super::Target;
use crate::radiosity::{refine_to_edge_length, RadiosityError, Surface};
use crate::scene::{SceneError, Sides};

/// One object's patch surface (module documentation).
#[derive(Debug, Clone)]
pub(super) struct PatchSurface {
    pub positions: Vec<DVec3>,
    /// Counter-clockwise about the front, the side that reflects (both for a two-sided one).
    pub triangles: Vec<[u32; 3]>,
    pub two_sided: bool,
}

impl PatchSurface {
    pub(super) fn as_surface(&self) -> Surface<'_> {
        Surface { positions: &self.positions, triangles: &self.triangles, two_sided: self.two_sided }
    }

    pub(super) fn vertex_count(&self) -> usize {
        self.positions.len()
    }
}

/// The patch surface of `target`: from its prepared tets when it has them, else its world
/// surface refined to edges of at most `max_edge` scene units (one-sided, front out, for a
/// translucent object).
///
/// # Errors
/// [`SceneError::InvalidObject`] when the refinement refuses (too fine a patch size).
pub(super) fn patch_surface(target: &Target<'_>, prepared: Option<&Prepared>, max_edge: f64) -> Result<PatchSurface, SceneError> {
    if let Some(p) = prepared {
        let boundary = &p.system().boundary().ids;
        let mut index = vec![u32::MAX; p.tet_mesh().vertex_count()];
        for (k, &v) in boundary.iter().enumerate() {
            index[v as usize] = k as u32;
        }
        let positions = boundary.iter().map(|&v| p.tet_mesh().positions()[v as usize]).collect();
        let triangles = p.tet_mesh().boundary_faces().iter().map(|f| f.vertices.map(|v| index[v as usize])).collect();
        return Ok(PatchSurface { positions, triangles, two_sided: false });
    }
    let sides = target.object.material.diffuse().map_or(Sides::Front, |d| d.sides);
    let world = target.world;
    let (positions, mut triangles) = refine_to_edge_length(world.positions(), world.triangles(), max_edge).map_err(|e| {
        let message = match e {
            RadiosityError::TooFine { .. } => format!("{e}: choose a larger patch_size_mm"),
            e => e.to_string(),
        };
        target.invalid(format!("patches: {message}"))
    })?;
    if sides == Sides::Back {
        for t in &mut triangles {
            t.swap(1, 2);
        }
    }
    Ok(PatchSurface { positions, triangles, two_sided: sides == Sides::Both })
}
