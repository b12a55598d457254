//! placeholder
pub struct TetMesh; pub struct BoundaryFace; pub struct TetMeshError;
