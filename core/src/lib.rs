//! # libtranscut core
//!
//! Subsurface light transport for translucent objects, returned as per-vertex outgoing radiance.
//! Data flows one way through the stages (each a module):
//!
//! `mesh` (surface input, tetrahedral topology) → `mesher` (surface → quality tetrahedra) →
//! `optics` (media) → `sparse` (linear algebra) → …
//!
//! Every stage reports typed errors; nothing panics on bad input.

pub mod diffusion;
pub mod edit;
pub mod gpu;
pub mod light;
pub mod mesh;
pub mod mesher;
pub mod optics;
pub mod progress;
pub mod render;
pub mod scene;
pub mod sparse;
pub mod volume;

pub use glam::DVec3;
pub use progress::{Cancelled, Progress};
