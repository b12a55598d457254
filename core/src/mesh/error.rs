//! Errors of mesh input and validation.

/// What is wrong with a surface mesh or the file it came from.
///
/// Every variant names the file (where there is one) and the line, face or vertex at fault.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MeshError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    /// The file is neither OBJ nor PLY.
    #[error("{path}: not an OBJ or PLY file")]
    UnknownFormat { path: String },
    /// A syntax error at a line (OBJ, PLY header) or element (PLY body).
    #[error("{path}:{line}: {message}")]
    Parse { path: String, line: usize, message: String },
    /// The file ended before all declared data was read.
    #[error("{path}: truncated: {message}")]
    Truncated { path: String, message: String },
    /// No vertices or no faces.
    #[error("empty mesh: {0}")]
    Empty(String),
    /// A coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate ({x}, {y}, {z})")]
    NonFinite { vertex: usize, x: f64, y: f64, z: f64 },
    /// A face refers to a vertex that does not exist.
    #[error("face {face} refers to vertex {index}, but there are {vertex_count} vertices")]
    IndexOutOfRange { face: usize, index: i64, vertex_count: usize },
    /// A face has fewer than three vertices.
    #[error("face {face} has {count} vertices; a face needs at least 3")]
    TooFewVertices { face: usize, count: usize },
    /// Every face has zero area, so there is no surface.
    #[error("all {faces} faces have zero area: there is no surface")]
    AllFacesDegenerate { faces: usize },
}
