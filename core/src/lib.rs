//! # libtranscut core
//!
//! Subsurface light transport for translucent objects, returned as per-vertex outgoing
//! radiance Lo(x, n). One entry point bakes a scene with any method:
//!
//! ```no_run
//! use transcut::{bake, BakeOptions, Method, Object, Scene};
//! use transcut::light::Light;
//! use transcut::optics::Medium;
//! # fn demo() -> Result<(), Box<dyn std::error::Error>> {
//! let mesh = transcut::mesh::load(std::path::Path::new("assets/meshes/spot.obj"))?;
//! let scene = Scene {
//!     objects: vec![Object::new("spot", mesh, Medium::preset("marble")?, 30.0)],
//!     lights: vec![Light::Directional { direction: transcut::DVec3::NEG_Z, irradiance: [3.0; 3], angular_diameter_deg: 0.0 }],
//! };
//! let options = BakeOptions { method: Method::from_name("transcut").unwrap(), ..BakeOptions::default() };
//! let result = bake(&scene, &options)?;
//! println!("{} vertices, Lo of the first: {:?}", result.objects[0].radiance.len(), result.objects[0].radiance[0]);
//! # Ok(()) }
//! ```
//!
//! The modules are layers; each uses only those listed before it (`core/tests/integration/layering.rs`
//! checks it):
//!
//! | layer | what it holds |
//! |---|---|
//! | [`workers`] | the per-call thread pools every parallel stage runs on |
//! | [`progress`] | progress reports and cancellation |
//! | [`input`] | bounded reading of input files, bounded quoting in messages |
//! | [`output`] | output files written whole or not at all |
//! | [`mesh`] | surfaces (OBJ, PLY, welding, n-gons), tet meshes, BVH, quality |
//! | [`optics`] | media, Fresnel, the dipole, closed forms |
//! | [`mesher`] | surface → quality tetrahedra (winding numbers, isosurface stuffing) |
//! | [`volume`] | heterogeneous media on tets: tables, layers, veins, voxels |
//! | [`light`] | lights and environments, the transmitted source q(x) |
//! | [`hierarchy`] | the hierarchical dipole's cluster trees and links |
//! | [`prt`] | precomputed translucent transfer: the dipole's PCA basis, samples, Haar, compressed rows |
//! | [`sparse`] | CSR matrices, CG/BiCGSTAB, preconditioners, multiresolution hierarchies |
//! | [`diffusion`] | TransCut's diffusion system (eqs. 9–14), solvers, eq. 3 |
//! | [`gpu`] | the wgpu backend and the CPU/GPU choice |
//! | [`render`] | a CPU rasteriser of baked radiance |
//! | [`texture`] | texture bakes: UV rasterisation, seam padding, the image of a surface's radiance |
//! | [`scene`] | what a bake is asked for: scene, objects, [`Method`], [`BakeOptions`] |
//! | [`edit`] | TransCut's interactive editing (§5): relight, medium edits, paint, cuts |
//! | [`methods`] | the subsurface methods behind one contract, and what a bake returns |
//! | [`mod@bake`] | the driver: [`bake()`] validates and runs a method on every object |
//! | [`session`] | a baked scene kept for interactive work, for every method |
//!
//! Every stage reports typed errors; nothing panics on bad input.

pub mod bake;
pub mod diffusion;
pub mod edit;
pub mod gpu;
pub mod hierarchy;
pub mod input;
pub mod inverse;
pub mod light;
pub mod lit_face;
pub mod mesh;
pub mod mesher;
pub mod methods;
pub mod optics;
pub mod output;
pub mod polygrid;
pub mod progress;
pub mod prt;
pub mod radiosity;
pub mod render;
pub mod scene;
pub mod session;
pub mod sparse;
pub mod texture;
pub mod volume;
pub mod workers;

pub use bake::{bake, bake_reusing, bake_with, Bake};
pub use glam::DVec3;
pub use methods::{BakedState, ObjectBake, ObjectStats, RadiositySession, RadiosityUpdate};
pub use progress::{Cancelled, Progress};
pub use scene::{
    BakeOptions, Diffuse, GradingChoice, Material, MediumSource, Method, Object, OpticalDistance, PolygridOptions, ProfileKind,
    ProfileScatteringOptions, RadiosityOptions, Scene, SceneError, Shape, Sides, Stencil, TransCutOptions, TranslucentScattering,
};
pub use session::{Session, SessionError};
