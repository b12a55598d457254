//! What can go wrong building or solving a polygrid ([`PolygridError`]).

use thiserror::Error;

use crate::diffusion::DiffusionError;
use crate::sparse::SparseError;

/// Why a polygrid could not be built or solved. Every variant names what is wrong; the
/// caller's data is never changed by a failed call.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum PolygridError {
    /// A polycube with no cube: an empty cell list, or a surface that encloses no volume at
    /// the cube size (an open sheet, or a cube larger than the object).
    #[error("the polycube has no cube: {0}")]
    Empty(String),
    /// A cube size or origin that is not finite and > 0.
    #[error("invalid cube size {cube} (it must be finite and > 0; origin finite)")]
    InvalidCube { cube: f64 },
    /// A resolution (cells per cube edge) outside 1..=[`super::MAX_RESOLUTION`], or a hierarchy
    /// whose levels it cannot halve.
    #[error("invalid resolution {resolution} per cube: {reason}")]
    InvalidResolution { resolution: u32, reason: String },
    /// A polycube bigger than the node budget allows.
    #[error("the polygrid would have {nodes} nodes, over the limit of {limit}")]
    TooLarge { nodes: u64, limit: u64 },
    /// The same cube listed twice.
    #[error("cube {cell:?} is listed twice")]
    DuplicateCube { cell: [i32; 3] },
    /// A polycube whose surface is not a 2-manifold: cubes that touch along an edge or at a
    /// corner only (the lattice point `at`, in cube units).
    #[error("the polycube's surface is not a manifold at lattice point {at:?}: {reason}")]
    NonManifold { at: [i32; 3], reason: &'static str },
    /// A voxel polycube whose topology differs from the surface's (a handle closed or a hole
    /// opened at this cube size): a smaller cube is needed.
    #[error(
        "the polycube's topology (Euler characteristic {polycube}) differs from the surface's ({surface}) at cube size \
         {cube}: choose a smaller cube"
    )]
    TopologyChanged { surface: i64, polycube: i64, cube: f64 },
    /// A cell of the mapped polygrid is folded: one of its Kuhn tets is turned over or flat
    /// (the map turned it inside out); a wrong picture is never returned from it.
    /// `scaled_jacobian` is the cell's smallest corner Jacobian, for diagnosis.
    #[error("polygrid cell {cell} is folded (a tet of its split is turned over; its smallest corner Jacobian is {scaled_jacobian:.3}): {hint}")]
    Fold { cell: usize, scaled_jacobian: f64, hint: &'static str },
    /// The boundary nodes could not be spread over the surface without turning quads over
    /// ([`super::map::SURFACE_FOLD_LIMIT`]): the surface bends or thins within a cube.
    #[error(
        "the polygrid's surface map turns {turned} of its {corners} quad corners over: the surface's features are finer \
         than the cubes: choose a smaller cube or a higher resolution"
    )]
    SurfaceFold { turned: usize, corners: usize },
    /// A node the paper's stencil cannot carry ([`super::PolygridSystem::paper_lsq`]): folded
    /// or nearly flat links, or no link to write its row with.
    #[error("the paper stencil fails at polygrid node {node}: {reason}")]
    Stencil { node: u32, reason: String },
    /// The medium put on the cells is invalid (NaN, negative coefficients).
    #[error("invalid medium on cell {cell}: {message}")]
    InvalidMedium { cell: usize, message: String },
    /// A vector of the wrong length (a source, a start value).
    #[error("{what}: expected {expected} entries, found {found}")]
    LengthMismatch { what: &'static str, expected: usize, found: usize },
    /// A source value that is negative or not finite.
    #[error("invalid source at boundary node {index}: {value}")]
    InvalidSource { index: usize, value: f64 },
    /// The FEM path's tet mesh or system.
    #[error(transparent)]
    Diffusion(#[from] DiffusionError),
    /// A solve failed.
    #[error(transparent)]
    Sparse(#[from] SparseError),
    /// The caller cancelled.
    #[error("cancelled")]
    Cancelled,
}
