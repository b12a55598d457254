//! Polygrid diffusion (Wang et al. 2008 §5, App. B): the diffusion equation of
//! docs/ARCHITECTURE.md solved on a grid with regular (6-connected) connectivity and the
//! object's shape, cut from a polycube.
//!
//! - [`domain`]: the polycube ([`Polycube`]): a block, a caller's cell list, or the user's
//!   surface voxelised without hand work;
//! - [`grid`]: its cells at a resolution per cube, nodes shared across cube faces, the
//!   paper's coarse levels ([`Polygrid::coarsened`]);
//! - [`map`]: the nodes moved onto the object (a cubed sphere, or a surface by projection and
//!   relaxation), folds refused;
//! - [`lsq`]: the paper's least-squares Laplacian weights (App. B) of one node;
//! - [`untangle`]: node-wise untangling and smoothing of the mapped surface quads and Kuhn
//!   tets (Escobar et al. 2003).
//!
//! The design and its departures from the paper (the boundary condition and radiance query of
//! ARCHITECTURE.md instead of the paper's L = Ft(φ − q)/2π, conservative stencils by default)
//! are in docs/ARCHITECTURE.md, "Polygrid".

pub mod domain;
mod error;
pub mod grid;
pub mod lsq;
pub mod map;
mod paper;
pub mod relax;
mod system;
pub mod untangle;

pub use domain::Polycube;
pub use error::PolygridError;
pub use grid::{Polygrid, Prolongation, MAX_RESOLUTION};
pub use map::{cubed_sphere, map_to_sphere, map_to_surface, place_first_layer, CellQuality, FirstLayer, MapOptions};
pub use paper::LsqDiagnostics;
pub use relax::{FreezeDepth, RadianceReference, RelaxHierarchy, RelaxOptions, RelaxState, Schedule, Smoother, Start};
pub use system::{BoundaryNodes, PolygridSystem, CELL_EDGES};

/// The discretisation of the diffusion equation on a polygrid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Stencil {
    /// P1 finite elements on the cells split into tets ([`Polygrid::kuhn_tets`]) with
    /// TransCut's assembly (eqs. 10–14): symmetric, conservative, second order on skewed cells
    /// (the cubed sphere: 0.14%, 0.037%, 0.009% at k = 8, 16, 32); 15 nonzeros per row.
    #[default]
    Fem,
    /// Node-centred finite volumes with two-point fluxes ([`PolygridSystem::finite_volume`]):
    /// symmetric, exactly conservative, second order on orthogonal cells (the slabs), 7
    /// nonzeros per row, but not consistent on skewed cells (the cubed sphere stays near
    /// 1.5%).
    FiniteVolume,
    /// The paper's own (eq. 9, App. B; [`PolygridSystem::paper_lsq`]): least-squares weights
    /// with the cross terms dropped, Stam's ψ = κφ form, media on the nodes; for reproduction
    /// and comparison. Not symmetric (BiCGSTAB), not conservative at κ interfaces (a
    /// two-layer slab's transmission −51%), not consistent on skewed cells.
    PaperLsq,
}

impl Stencil {
    /// Every stencil's name, as front ends spell it.
    pub const NAMES: [&'static str; 3] = ["fem", "finite-volume", "paper-lsq"];

    /// The stencil's name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Fem => "fem",
            Self::FiniteVolume => "finite-volume",
            Self::PaperLsq => "paper-lsq",
        }
    }

    /// The stencil called `name` (any case), if any.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        match name.trim().to_ascii_lowercase().as_str() {
            "fem" => Some(Self::Fem),
            "finite-volume" | "fv" => Some(Self::FiniteVolume),
            "paper-lsq" | "paper" => Some(Self::PaperLsq),
            _ => None,
        }
    }
}
