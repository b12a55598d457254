//! Surface and volume meshes: loading user meshes (OBJ, PLY), welding, triangulating n-gons,
//! shells, the tetrahedral mesh topology and quality measures, and spatial queries (BVH).
//!
//! Results are always returned in the user's own vertex order: a [`TriMesh`] keeps, for every
//! vertex of the file it came from, the internal (welded) vertex that stands for it.

mod bvh;
mod error;
mod obj;
mod ply;
mod quality;
mod tetmesh;
mod triangulate;
mod trimesh;
mod vtk;
mod weld;

pub use bvh::{RayHit, SurfacePoint, TriangleBvh};
pub use error::MeshError;
pub use obj::{load_obj, parse_obj};
pub use ply::{load_ply, parse_ply};
pub use quality::{dihedral_angles, tet_volume, QualityReport};
pub use tetmesh::{BoundaryFace, TetMesh, TetMeshError};
pub use trimesh::{TriMesh, WeldOptions};
pub use vtk::write_vtk;

use std::path::Path;

/// Loads a triangle mesh from an OBJ or PLY file (chosen by extension, or by content when the
/// extension is unknown), triangulating n-gons and welding duplicate positions.
///
/// # Errors
/// [`MeshError`] naming the file and line/element for I/O, parse and validation failures.
pub fn load(path: impl AsRef<Path>) -> Result<TriMesh, MeshError> {
    let path = path.as_ref();
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("obj") => load_obj(path),
        Some("ply") => load_ply(path),
        _ => {
            let head = std::fs::read(path)
                .map_err(|source| MeshError::Io { path: path.display().to_string(), source })?;
            if head.starts_with(b"ply") {
                load_ply(path)
            } else if looks_like_obj(&head) {
                load_obj(path)
            } else {
                Err(MeshError::UnknownFormat { path: path.display().to_string() })
            }
        }
    }
}

fn looks_like_obj(bytes: &[u8]) -> bool {
    let text = match std::str::from_utf8(&bytes[..bytes.len().min(4096)]) {
        Ok(t) => t,
        Err(e) => match std::str::from_utf8(&bytes[..e.valid_up_to()]) {
            Ok(t) => t,
            Err(_) => return false,
        },
    };
    text.lines().any(|l| {
        let l = l.trim_start();
        l.starts_with("v ") || l.starts_with("f ") || l.starts_with("vn ") || l.starts_with("o ")
    })
}
