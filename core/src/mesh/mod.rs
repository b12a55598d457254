//! Surface and volume meshes: loading user meshes (OBJ, PLY), welding, triangulating n-gons,
//! orienting shells consistently (outwards where closed), shells, the tetrahedral mesh topology
//! and quality measures, and spatial queries (BVH).
//!
//! Results are always returned in the user's own vertex order: a [`TriMesh`] keeps, for every
//! vertex of the file it came from, the internal (welded) vertex that stands for it.

mod bvh;
mod error;
mod obj;
mod orient;
mod ply;
mod quality;
mod tetmesh;
mod triangulate;
mod trimesh;
mod vtk;
mod weld;

pub use bvh::{RayHit, SurfacePoint, TriangleBvh};
pub use error::MeshError;
pub use obj::{load_obj, load_obj_with, parse_obj, parse_obj_with};
pub use ply::{load_ply, load_ply_with, parse_ply, parse_ply_with};
pub use quality::{dihedral_angles, dihedral_cotangents, tet_volume, QualityReport};
pub use tetmesh::{BoundaryFace, BoundaryTopology, TetMesh, TetMeshError};
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
            let bytes = std::fs::read(path).map_err(|source| MeshError::Io { path: path.display().to_string(), source })?;
            let name = path.display().to_string();
            if bytes.starts_with(b"ply") {
                parse_ply(&bytes, &name)
            } else if looks_like_obj(&bytes) {
                let text = String::from_utf8_lossy(&bytes);
                parse_obj(&text, &name)
            } else {
                Err(MeshError::UnknownFormat { path: name })
            }
        }
    }
}

/// Whether the text starts like an OBJ file: its first statement (after comments and blank
/// lines) is an OBJ keyword followed by whitespace.
fn looks_like_obj(bytes: &[u8]) -> bool {
    const KEYWORDS: [&str; 10] = ["v", "vt", "vn", "f", "o", "g", "s", "usemtl", "mtllib", "l"];
    let text = String::from_utf8_lossy(&bytes[..bytes.len().min(1 << 16)]);
    text.lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .and_then(|l| l.split_whitespace().next())
        .is_some_and(|k| KEYWORDS.contains(&k))
}
