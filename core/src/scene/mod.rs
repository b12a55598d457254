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
mod object;

pub use bake::{bake, bake_with, Bake, BakeOptions, ObjectBake, ObjectStats, SceneError};
pub use object::{MediumSource, Object, Shape};

use crate::light::Light;

/// Objects and the lights that shine on them.
#[derive(Debug, Clone, Default)]
pub struct Scene {
    pub objects: Vec<Object>,
    pub lights: Vec<Light>,
}
