//! Tet meshes kept between bakes: an object's tets as the mesher made them, with the surface
//! and budget they were made from, so that a later bake of the same surface takes them instead
//! of meshing again (meshing is most of a bake; a change of medium, lights or another object
//! leaves an object's surface as it was).
//!
//! Reuse is exact: the mesher is deterministic, so a kept mesh is the mesh that meshing the
//! same world surface at the same budget makes, and the bake that takes it equals a fresh one
//! bit for bit. What "the same surface" means is strict equality of the welded world-space
//! surface (positions, triangles, the user's vertex map): a moved, scaled or edited object is
//! meshed again.

use std::sync::Arc;

use crate::mesh::{TetMesh, TriMesh};
use crate::mesher::{MesherOptions, MesherStats};

/// An object's tet mesh as the mesher made it (world space, every material id 0, before a
/// medium was put on it), kept by a bake that was asked to keep its meshes
/// ([`crate::bake::bake_reusing`]).
#[derive(Debug, Clone)]
pub struct Meshed {
    /// The world-space surface it was meshed from.
    surface: TriMesh,
    /// The mesher's options: the tet budget ([`crate::scene::TransCutOptions::tets`]) and grading.
    options: MesherOptions,
    mesh: TetMesh,
    stats: MesherStats,
}

impl Meshed {
    pub(crate) fn new(surface: &TriMesh, options: &MesherOptions, mesh: TetMesh, stats: MesherStats) -> Self {
        Self { surface: surface.clone(), options: options.clone(), mesh, stats }
    }

    /// Whether this is what meshing `surface` with `options` makes.
    #[must_use]
    pub fn made_from(&self, surface: &TriMesh, options: &MesherOptions) -> bool {
        self.options == *options && self.surface == *surface
    }

    /// The tet mesh (world space, material ids 0).
    #[must_use]
    pub fn mesh(&self) -> &TetMesh {
        &self.mesh
    }

    /// The mesher's statistics of the meshing that made it.
    #[must_use]
    pub fn stats(&self) -> &MesherStats {
        &self.stats
    }
}

/// What a bake does about meshes made before ([`crate::methods::Target::reuse`]).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) enum Reuse<'a> {
    /// Mesh, keep nothing (a bake whose meshes are not wanted again).
    #[default]
    Nothing,
    /// Take the given mesh when it was made from the object's surface at the bake's budget,
    /// mesh otherwise; keep the mesh used ([`super::TransCutState::meshed`]).
    Keep(Option<&'a Arc<Meshed>>),
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::icosphere;
    use crate::mesher::{tetrahedralize_with, Grading};
    use crate::progress::Progress;

    #[test]
    fn only_the_same_surface_with_the_same_options_is_the_same_mesh() {
        let sphere = icosphere(1.0, 2);
        let options = MesherOptions::with_tets(2000);
        let meshed = tetrahedralize_with(&sphere, &options, Progress::none()).unwrap();
        let kept = Meshed::new(&sphere, &options, meshed.mesh, meshed.stats);
        assert!(kept.made_from(&sphere, &options));
        assert!(!kept.made_from(&sphere, &MesherOptions::with_tets(2001)), "another budget");
        let graded = MesherOptions { grading: Grading::Graded { layers: 1 }, ..options.clone() };
        assert!(!kept.made_from(&sphere, &graded), "another grading");
        assert!(!kept.made_from(&icosphere(1.0 + 1e-12, 2), &options), "a surface moved by 1e-12");
        assert!(!kept.made_from(&icosphere(1.0, 3), &options), "another surface");
    }
}
