//! Why an edit failed. Every failed edit leaves the editor exactly as it was.

/// Why an edit (relight, material edit, paint, cut, split, fracture, move, recombine) failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EditError {
    /// A cutter (plane, stroke or solid) is degenerate or not finite.
    #[error("invalid cutter: {0}")]
    InvalidCutter(String),
    /// A paint stroke or a swept cut stroke is invalid.
    #[error("invalid stroke: {0}")]
    InvalidStroke(String),
    /// A material-edit region is invalid (a mask of the wrong length, a negative radius…).
    #[error("invalid region: {0}")]
    InvalidRegion(String),
    /// An edit option is out of range.
    #[error("invalid edit option: {0}")]
    InvalidOptions(String),
    /// The cut would remove every tetrahedron that is left.
    #[error("the cut removes every tetrahedron of piece {piece}")]
    NothingLeft { piece: usize },
    /// A piece index is out of range.
    #[error("piece {index} does not exist (there are {count})")]
    NoSuchPiece { index: usize, count: usize },
    /// A piece transform is not a rotation plus a translation.
    #[error("piece transform is not rigid: {0}")]
    NotRigid(String),
    /// A medium is invalid.
    #[error("medium: {0}")]
    Medium(#[from] crate::optics::OpticsError),
    /// Per-tet media could not be built.
    #[error("volume: {0}")]
    Volume(#[from] crate::volume::VolumeError),
    /// A tet mesh produced by the edit is invalid.
    #[error("tet mesh: {0}")]
    Mesh(#[from] crate::mesh::TetMeshError),
    /// A light is invalid or the source could not be computed.
    #[error("lights: {0}")]
    Light(crate::light::LightError),
    /// Assembly or solve failed.
    #[error("diffusion: {0}")]
    Diffusion(#[from] crate::diffusion::DiffusionError),
    /// The GPU was required and failed.
    #[error("GPU backend: {0}")]
    Gpu(#[from] crate::gpu::GpuError),
    /// Meshing or baking the starting object failed.
    #[error("scene: {0}")]
    Scene(#[from] crate::scene::SceneError),
    /// The edit would put a medium at the surface that the mesh cannot resolve, so the edited
    /// radiance would be wrong (too dark, then zero): the object must be baked again with more
    /// tets (or smaller) before it takes that medium.
    #[error("the edited medium is too dense for the mesh: {0}")]
    Unresolved(crate::diffusion::Unresolved),
    /// The hierarchical dipole refused the update (vertex positions of another count, or not
    /// finite).
    #[error("hierarchical dipole: {0}")]
    Hierarchy(crate::hierarchy::HierarchyError),
    /// The PRT method refused the update (a medium its transfer cannot take).
    #[error("prt: {0}")]
    Prt(crate::prt::PrtError),
    /// Cancelled through the progress callback.
    #[error(transparent)]
    Cancelled(#[from] crate::progress::Cancelled),
}

impl From<crate::prt::PrtError> for EditError {
    fn from(e: crate::prt::PrtError) -> Self {
        match e {
            crate::prt::PrtError::Cancelled(c) => Self::Cancelled(c),
            e => Self::Prt(e),
        }
    }
}

/// A light error of an update: a cancellation while sampling is [`EditError::Cancelled`],
/// anything else [`EditError::Light`].
impl From<crate::light::LightError> for EditError {
    fn from(e: crate::light::LightError) -> Self {
        match e {
            crate::light::LightError::Cancelled(c) => Self::Cancelled(c),
            e => Self::Light(e),
        }
    }
}

impl From<crate::hierarchy::HierarchyError> for EditError {
    fn from(e: crate::hierarchy::HierarchyError) -> Self {
        match e {
            crate::hierarchy::HierarchyError::Cancelled(c) => Self::Cancelled(c),
            e => Self::Hierarchy(e),
        }
    }
}
