//! The conversions between the core's types and the C ABI's that several entry points share:
//! the medium struct, and the status of each core error.

use transcut_core::edit::EditError;
use transcut_core::mesh::MeshError;
use transcut_core::optics::{ArtistMapping, ArtistParams, Medium};
use transcut_core::prt::PrtError;
use transcut_core::{SceneError, SessionError};

use super::status::{
    Failure, TC_CANCELLED, TC_GPU_UNAVAILABLE, TC_INVALID_ARGUMENT, TC_INVALID_HANDLE, TC_INVALID_MESH, TC_IO_ERROR,
    TC_MESHING_FAILED, TC_NOTHING_LEFT, TC_NOT_FOUND, TC_SOLVE_FAILED, TC_UNRESOLVED, TC_UNSUPPORTED,
};

/// A homogeneous medium. Coefficients per RGB channel in mm⁻¹ (whatever the scene unit; see
/// `tc_object_set_scale`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcMedium {
    /// Absorption coefficient σa (mm⁻¹), ≥ 0.
    pub sigma_a: [f64; 3],
    /// Reduced scattering coefficient σ′s = (1 − g) σs (mm⁻¹), ≥ 0; σa + σ′s > 0.
    pub sigma_s_prime: [f64; 3],
    /// Refractive index relative to air, in [1, 4).
    pub eta: f64,
    /// Scattering anisotropy (Henyey–Greenstein g), in (−1, 1).
    pub g: f64,
}

impl From<Medium> for TcMedium {
    fn from(m: Medium) -> Self {
        Self { sigma_a: m.sigma_a, sigma_s_prime: m.sigma_s_prime, eta: m.eta, g: m.g }
    }
}

/// A validated core medium from the caller's struct.
pub(crate) fn medium_from(m: &TcMedium, what: &str) -> Result<Medium, Failure> {
    Medium::new(m.sigma_a, m.sigma_s_prime, m.eta, m.g).map_err(|e| Failure::invalid(format!("{what}: {e}")))
}

/// The status of a failed bake.
pub(crate) fn scene_failure(e: &SceneError) -> Failure {
    let status = match e {
        SceneError::Cancelled(_) => TC_CANCELLED,
        // The polygrid's grid (polycube, map) is its mesh: a fold or a changed topology at every
        // cube size tried fails as a tet mesher's would.
        SceneError::Mesher { .. } | SceneError::Polygrid { .. } => TC_MESHING_FAILED,
        SceneError::Diffusion { .. } => TC_SOLVE_FAILED,
        SceneError::Gpu { .. } => TC_GPU_UNAVAILABLE,
        SceneError::Unsupported { .. } => TC_UNSUPPORTED,
        SceneError::Unresolved { .. } => TC_UNRESOLVED,
        SceneError::NoObjects | SceneError::InvalidOptions(_) | SceneError::InvalidObject { .. } | SceneError::Light(_) => {
            TC_INVALID_ARGUMENT
        }
        _ => TC_SOLVE_FAILED,
    };
    Failure::new(status, e.to_string())
}

/// The status of a failed edit (`EditError` variants; new ones default to `TC_SOLVE_FAILED`).
pub(crate) fn edit_failure(e: &EditError) -> Failure {
    match e {
        EditError::Scene(s) => scene_failure(s),
        _ => Failure::new(edit_status(e), e.to_string()),
    }
}

fn edit_status(e: &EditError) -> super::status::TcStatus {
    match e {
        EditError::InvalidCutter(_)
        | EditError::InvalidStroke(_)
        | EditError::InvalidRegion(_)
        | EditError::InvalidOptions(_)
        | EditError::NotRigid(_)
        | EditError::Medium(_)
        | EditError::Volume(_)
        | EditError::Light(_)
        | EditError::Hierarchy(_) => TC_INVALID_ARGUMENT,
        EditError::NothingLeft { .. } => TC_NOTHING_LEFT,
        EditError::NoSuchPiece { .. } => TC_INVALID_HANDLE,
        EditError::Mesh(_) => TC_INVALID_MESH,
        EditError::Gpu(_) => TC_GPU_UNAVAILABLE,
        EditError::Cancelled(_) => TC_CANCELLED,
        EditError::Unresolved(_) => TC_UNRESOLVED,
        EditError::Scene(s) => scene_failure(s).status,
        EditError::Prt(PrtError::Medium(_)) => TC_INVALID_ARGUMENT,
        EditError::Prt(PrtError::File(_)) => TC_IO_ERROR,
        _ => TC_SOLVE_FAILED,
    }
}

/// The status of a failed session call: the update's own status, `TC_INVALID_HANDLE` for an
/// object that does not exist, `TC_UNSUPPORTED` for a capability the object's method lacks.
pub(crate) fn session_failure(e: &SessionError) -> Failure {
    let status = match e {
        SessionError::NoSuchObject { .. } => TC_INVALID_HANDLE,
        SessionError::Unsupported { .. } => TC_UNSUPPORTED,
        SessionError::Edit { source, .. } => edit_status(source),
        SessionError::Cancelled(_) => TC_CANCELLED,
        SessionError::Coupled(source) => return scene_failure(source),
        _ => TC_INVALID_ARGUMENT,
    };
    Failure::new(status, e.to_string())
}

/// A status for a surface mesh error: files that are missing or unreadable, or invalid data.
pub(crate) fn mesh_failure(e: &MeshError) -> Failure {
    match e {
        MeshError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
            Failure::new(TC_NOT_FOUND, e.to_string())
        }
        MeshError::Io { .. } | MeshError::Refused { .. } => Failure::new(TC_IO_ERROR, e.to_string()),
        _ => Failure::new(TC_INVALID_MESH, e.to_string()),
    }
}

/// `TcArtistMedium.mapping`: Cycles' Random Walk (and Christensen–Burley), the default (0, so a
/// zero-initialised struct gets it): the radius over 4π is the reduced mean free path, the
/// medium is index-matched (η = 1), and a thick slab of it reflects `albedo` of the diffuse
/// light entering it in this library's diffusion model.
pub const TC_ARTIST_RANDOM_WALK: u32 = 0;
/// `TcArtistMedium.mapping`: Cycles' Random Walk (Skin): the radius is a diffusion length
/// (times √(3(1 − α′)) of the classical dipole at `ior`, the subsurface IOR), index-matched.
pub const TC_ARTIST_RANDOM_WALK_SKIN: u32 = 1;
/// `TcArtistMedium.mapping`: the classical dipole's inversion: a thick slab reflects `albedo`
/// of the diffuse light entering it (Jensen et al. 2001's Rd at η = `ior`), `radius × scale`
/// is the reduced mean free path 1/σ′t, and the medium keeps η = `ior`.
pub const TC_ARTIST_DIPOLE: u32 = 2;

/// A medium as an artist sets it (Blender's Principled BSDF subsurface inputs), converted to
/// σa and σ′s by one of the `TC_ARTIST_*` mappings (each reads the colour as what a thick slab
/// reflects of the diffuse light entering it, and the radius as a length).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcArtistMedium {
    /// Subsurface colour per channel, each in (0, 1).
    pub albedo: [f64; 3],
    /// Subsurface radius per channel, in scene units, > 0.
    pub radius: [f64; 3],
    /// Multiplier of `radius`, > 0.
    pub scale: f64,
    /// Refractive index, in [1, 4): the medium's η with `TC_ARTIST_DIPOLE`, the subsurface IOR
    /// with `TC_ARTIST_RANDOM_WALK_SKIN`; unused by `TC_ARTIST_RANDOM_WALK` (index-matched).
    pub ior: f64,
    /// Scattering anisotropy g, in (−1, 1) (the random walks clamp it to [0, 0.9], as Cycles).
    pub anisotropy: f64,
    /// How colour and radius are read: `TC_ARTIST_RANDOM_WALK` (0, the default),
    /// `TC_ARTIST_RANDOM_WALK_SKIN` or `TC_ARTIST_DIPOLE`.
    pub mapping: u32,
}

/// Artist parameters to a medium, at `mm_per_unit` millimetres per scene unit.
pub(crate) fn artist_medium(a: &TcArtistMedium, mm_per_unit: f64) -> Result<Medium, Failure> {
    let mapping = match a.mapping {
        TC_ARTIST_RANDOM_WALK => ArtistMapping::RandomWalk,
        TC_ARTIST_RANDOM_WALK_SKIN => ArtistMapping::RandomWalkSkin,
        TC_ARTIST_DIPOLE => ArtistMapping::Dipole,
        other => {
            return Err(Failure::invalid(format!(
                "artist medium: mapping {other} is not one of TC_ARTIST_RANDOM_WALK (0), TC_ARTIST_RANDOM_WALK_SKIN (1), TC_ARTIST_DIPOLE (2)"
            )))
        }
    };
    let params =
        ArtistParams { albedo: a.albedo, radius: a.radius, scale: a.scale, mm_per_unit, eta: a.ior, g: a.anisotropy, mapping };
    params.to_medium().map_err(|e| Failure::invalid(format!("artist medium: {e}")))
}
