//! Heterogeneous materials: media that vary inside an object, reduced to one medium per tet
//! for the diffusion solver.
//!
//! The TransCut assembly ([`crate::diffusion`]) takes κ and μ constant per tet. This module
//! produces a [`PerTetMedia`] (per-tet σa and σ′s per RGB channel in mm⁻¹, one η and one g for
//! the object) from:
//!
//! - a **material-id table**: [`PerTetMedia::from_materials`] (`mesh.materials()` indexing a
//!   `&[Medium]`);
//! - a dense **voxel grid** ([`VoxelGrid`], the TCVOX1 file format documented in [`voxel`]):
//!   trilinear sampling between voxel centres, clamped to the border;
//! - **procedural fields**: [`Layers`] (media by depth below the surface, e.g. epidermis,
//!   dermis, fat, blended smoothly) and [`Veins`] (marble veins from seeded Perlin noise with
//!   fractal turbulence, [`PerlinNoise`]), or any [`MediumField`] (every closure
//!   `Fn(DVec3) -> Coefficients + Sync` is one).
//!
//! A field becomes per-tet values by [`TetSampling`]: the centroid, or the mean over the
//! centroid and the four degree-2 quadrature points (exact for linear fields). σa and σ′s are
//! averaged, so κ_t = 1/(3(σ̄a + σ̄′s)).
//!
//! **One η per object**: the Robin boundary condition and the radiance query use one Fdr, A
//! and Ft, so a [`PerTetMedia`] has a single η (and g, which the diffusion equation does not
//! use); see [`PerTetMedia`] for where each source takes them from.
//!
//! **Into the solver**: the assembly reads material ids from the mesh and a media table;
//! [`PerTetMedia::apply`] writes the ids ([`TableLayout::PerTet`]: id = tet, so
//! [`crate::diffusion::DiffusionSystem::set_media`] can refill the matrix after painting;
//! [`TableLayout::Compact`]: identical media share an id) and returns the table for
//! [`crate::diffusion::assemble`].
//!
//! Everything is computed in parallel with rayon and is bit-identical for any thread count
//! (per-tet work is independent; sums run in a fixed order; the noise is seeded).
//!
//! # Example
//!
//! ```
//! use transcut::diffusion::assemble;
//! use transcut::mesh::TetMesh;
//! use transcut::optics::Medium;
//! use transcut::volume::{Layers, PerTetMedia, TableLayout, TetSampling, VeinParams, Veins};
//! use transcut::DVec3;
//!
//! // The cube [0, 2]³ (scene units = mm) as 8 cells of 6 Kuhn tets.
//! let idx = |x: u32, y: u32, z: u32| x + 3 * (y + 3 * z);
//! let mut positions = Vec::new();
//! for z in 0..3 { for y in 0..3 { for x in 0..3 { positions.push(DVec3::new(x as f64, y as f64, z as f64)); } } }
//! let mut tets = Vec::new();
//! for z in 0..2 { for y in 0..2 { for x in 0..2 {
//!     let c = |d: u32| idx(x + (d & 1), y + ((d >> 1) & 1), z + ((d >> 2) & 1));
//!     for [a, b] in [[1, 3], [1, 5], [2, 3], [2, 6], [4, 5], [4, 6]] { tets.push([c(0), c(a), c(b), c(7)]); }
//! } } }
//! let mut mesh = TetMesh::new(positions, tets, vec![])?;
//!
//! // Skin-like layers by depth below the surface.
//! let skin = Medium::preset("skin1")?;
//! let deep = Medium { sigma_a: [0.05, 0.08, 0.1], ..skin };
//! let layers = Layers::new(&[(0.5, skin), (f64::INFINITY, deep)], 0.1)?;
//! let media = layers.per_tet(&mesh, 1.0, TetSampling::Centroid)?;
//!
//! // Or marble veins.
//! let marble = Medium::preset("marble")?;
//! let vein = Medium { sigma_a: [0.05, 0.06, 0.08], ..marble };
//! let veins = Veins::new(marble, vein, 7, VeinParams { period: 1.5, ..VeinParams::default() })?;
//! let marbled = veins.per_tet(&mesh, TetSampling::FivePoint)?;
//! assert_eq!(marbled.len(), mesh.tet_count());
//!
//! let table = media.apply(&mut mesh, TableLayout::PerTet)?;
//! let system = assemble(&mesh, &table, 1.0)?;
//! assert_eq!(system.media().len(), 48);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod error;
mod field;
mod layers;
pub mod noise;
mod per_tet;
mod veins;
pub mod voxel;

pub use error::{VolumeError, VOXEL_CHANNEL_NAMES};
pub use field::{Coefficients, MediumField, TetSampling};
pub use layers::{Layer, LayeredField, Layers};
pub use noise::PerlinNoise;
pub(crate) use per_tet::check_object;
pub use per_tet::{MaterialTable, PerTetMedia, TableLayout};
pub use veins::{VeinParams, Veins};
pub use voxel::VoxelGrid;
