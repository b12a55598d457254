//! The one public entry of every method: a [`Scene`] (objects with a surface mesh, a medium and a
//! transform; lights) goes in, per-vertex radiance comes out, in each user's own vertex order.
//!
//! ```text
//! Scene ──► per object: surface → world space → tetrahedralize → assemble M (eqs. 10–14)
//!      └──► all objects' surfaces → occluder BVH ──► q(x) at boundary vertices → solve → Lo(x, n)
//!                                                                    → user vertices (surface map)
//! ```
//!
//! What a bake returns (ARCHITECTURE.md): the multiple-scattering radiance leaving along the
//! surface normal, Lo(x, n), linear RGB, in the units of the lights' radiance. The diffusion
//! approximation can give a slightly negative Lo where φ < 2q (very absorbing media, coarse
//! meshes); such values are clamped to zero and counted in the statistics.

mod bake;

pub use bake::{bake, bake_with, Bake, BakeOptions, ObjectBake, ObjectStats, SceneError};

use glam::DMat4;

use crate::light::Light;
use crate::mesh::TriMesh;
use crate::optics::Medium;

/// A translucent object: a surface mesh in object space, its placement and its medium.
#[derive(Debug, Clone)]
pub struct Object {
    /// A name for messages and reports.
    pub name: String,
    /// The closed (or nearly closed) surface, in object space, scene units.
    pub mesh: TriMesh,
    /// Object → world transform (scene units).
    pub transform: DMat4,
    /// Millimetres per scene unit: the media are in mm⁻¹.
    pub mm_per_unit: f64,
    /// The homogeneous medium filling the object.
    pub medium: Medium,
}

impl Object {
    /// An object at the origin with the identity transform.
    #[must_use]
    pub fn new(name: impl Into<String>, mesh: TriMesh, medium: Medium, mm_per_unit: f64) -> Self {
        Self { name: name.into(), mesh, transform: DMat4::IDENTITY, mm_per_unit, medium }
    }
}

/// Objects and the lights that shine on them.
#[derive(Debug, Clone, Default)]
pub struct Scene {
    pub objects: Vec<Object>,
    pub lights: Vec<Light>,
}
