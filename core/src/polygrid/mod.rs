//! Polygrid diffusion (Wang et al. 2008 §5, App. B): the diffusion equation of
//! docs/ARCHITECTURE.md solved on a grid with regular (6-connected) connectivity and the
//! object's shape, cut from a polycube.
//!
//! - [`domain`]: the polycube ([`Polycube`]): a block, a caller's cell list, or the user's
//!   surface voxelised without hand work;
//! - [`grid`]: its cells at a resolution per cube, nodes shared across cube faces, the
//!   paper's coarse levels ([`Polygrid::coarsened`]);
//! - [`map`]: the nodes moved onto the object (a cubed sphere, or a surface by projection and
//!   relaxation), folds refused.
//!
//! The design and its departures from the paper (the boundary condition and radiance query of
//! ARCHITECTURE.md instead of the paper's L = Ft(φ − q)/2π, conservative stencils by default)
//! are in docs/ARCHITECTURE.md, "Polygrid".

pub mod domain;
mod error;
pub mod grid;
pub mod map;
mod system;

pub use domain::Polycube;
pub use error::PolygridError;
pub use grid::{Polygrid, Prolongation, MAX_RESOLUTION};
pub use map::{map_to_sphere, map_to_surface, CellQuality, MapOptions};
pub use system::{BoundaryNodes, PolygridSystem, CELL_EDGES};
