//! Surface and volume meshes: loading user meshes (OBJ, PLY), welding, triangulating n-gons,
//! orienting shells consistently (outwards where closed), shells, the tetrahedral mesh topology
//! and quality measures, and spatial queries (BVH).
//!
//! Results are always returned in the user's own vertex order: a [`TriMesh`] keeps, for every
//! vertex of the file it came from, the internal (welded) vertex that stands for it.

mod bvh;
mod by_vertex;
mod error;
mod incidence;
mod obj;
mod orient;
mod ply;
mod quality;
mod shapes;
mod tetmesh;
mod triangulate;
mod trimesh;
mod vtk;
mod weld;

pub(crate) use bvh::closest_point_on_triangle;
pub use bvh::{RayHit, SurfacePoint, TriangleBvh};
pub use error::MeshError;
pub use incidence::Incidence;
pub use obj::{load_obj, load_obj_uv_map, load_obj_with, parse_obj, parse_obj_uv_map, parse_obj_with, UvMap};
pub use ply::{load_ply, load_ply_with, parse_ply, parse_ply_with};
pub use quality::{dihedral_angles, dihedral_cotangents, tet_volume, QualityReport};
pub use shapes::{gridded_box, icosphere};
pub(crate) use tetmesh::{boundary_faces_among, irregular_edges, orient_tets};
pub use tetmesh::{BoundaryFace, BoundaryTopology, TetMesh, TetMeshError};
pub use trimesh::{area_weighted_normals, TriMesh, WeldOptions, MAX_COORDINATE};
pub use vtk::write_vtk;

use std::path::Path;

use crate::input::{BoundedFile, Limits};

/// The largest mesh file [`load`], [`load_obj`] and [`load_ply`] read, in bytes (4 GiB).
pub const MAX_MESH_FILE_BYTES: u64 = 4 << 30;

/// The longest line of an OBJ file, in bytes (1 MiB): an n-gon of ten thousand corners fits.
pub const MAX_OBJ_LINE_BYTES: usize = 1 << 20;

/// Loads a triangle mesh from an OBJ or PLY file (chosen by extension, or by content when the
/// extension is unknown), triangulating n-gons and welding duplicate positions.
///
/// The file is read through [`crate::input`]: a directory, device or FIFO is refused unopened,
/// and the first bytes are checked (the `ply` magic and header, or the first OBJ statement)
/// before the rest is read.
///
/// # Errors
/// [`MeshError`] naming the file and line/element for I/O, parse and validation failures;
/// [`MeshError::Refused`] for a file that is not a regular file, is larger than
/// [`MAX_MESH_FILE_BYTES`], or has an OBJ line longer than [`MAX_OBJ_LINE_BYTES`].
pub fn load(path: impl AsRef<Path>) -> Result<TriMesh, MeshError> {
    let path = path.as_ref();
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("obj") => load_obj(path),
        Some("ply") => load_ply(path),
        _ => {
            let name = path.display().to_string();
            // The OBJ line cap: a PLY header's lines are within the head anyway, and its body
            // is read with no line cap once the magic has chosen PLY.
            let mut file = open_mesh(path, &name, Some(MAX_OBJ_LINE_BYTES))?;
            let (head, _) = file.head().map_err(|e| MeshError::input(&name, e))?;
            if head.starts_with(b"ply") {
                drop(file);
                load_ply(path)
            } else if looks_like_obj(head) {
                drop(file);
                load_obj(path)
            } else {
                Err(MeshError::UnknownFormat { path: name })
            }
        }
    }
}

/// Opens a mesh file with the mesh limits and the given line cap.
fn open_mesh(path: &Path, name: &str, max_line: Option<usize>) -> Result<BoundedFile, MeshError> {
    BoundedFile::open(path, Limits { max_bytes: MAX_MESH_FILE_BYTES, max_line }).map_err(|e| MeshError::input(name, e))
}

/// Whether the text starts like an OBJ file: its first statement (after a byte-order mark,
/// comments and blank lines) is an OBJ keyword followed by whitespace.
fn looks_like_obj(bytes: &[u8]) -> bool {
    const KEYWORDS: [&str; 10] = ["v", "vt", "vn", "f", "o", "g", "s", "usemtl", "mtllib", "l"];
    let bytes = bytes.strip_prefix("\u{FEFF}".as_bytes()).unwrap_or(bytes);
    let text = String::from_utf8_lossy(&bytes[..bytes.len().min(1 << 16)]);
    let first = obj::lines(&text).map(str::trim).find(|l| !l.is_empty() && !l.starts_with('#'));
    first.and_then(|l| l.split_whitespace().next()).is_some_and(|k| KEYWORDS.contains(&k))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_is_recognised_after_a_bom_and_cr_line_ends() {
        assert!(looks_like_obj(b"\xEF\xBB\xBF# c\rv 0 0 0\r"));
        assert!(looks_like_obj(b"\n\n  f 1 2 3"));
        assert!(!looks_like_obj(b"1 2 3\nv 0 0 0"));
        assert!(!looks_like_obj(b"\0\0\0"));
    }
}
