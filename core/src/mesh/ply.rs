//! PLY reader (placeholder until the reader lands).
use super::{MeshError, TriMesh};
use std::path::Path;
pub fn load_ply(path: &Path) -> Result<TriMesh, MeshError> { Err(MeshError::UnknownFormat { path: path.display().to_string() }) }
pub fn parse_ply(_bytes: &[u8], path: &str) -> Result<TriMesh, MeshError> { Err(MeshError::UnknownFormat { path: path.into() }) }
