//! Wavefront OBJ reader (placeholder until the reader lands).
use super::{MeshError, TriMesh};
use std::path::Path;
pub fn load_obj(path: &Path) -> Result<TriMesh, MeshError> { Err(MeshError::UnknownFormat { path: path.display().to_string() }) }
pub fn parse_obj(_text: &str, path: &str) -> Result<TriMesh, MeshError> { Err(MeshError::UnknownFormat { path: path.into() }) }
