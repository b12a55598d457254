//! Errors of mesh input and validation.

use crate::input::{fmt_num, InputError};

/// What is wrong with a surface mesh or the file it came from.
///
/// Every variant names the file (where there is one) and the line, face or vertex at fault.
///
/// Numbering conventions: `face` and `vertex` are 0-based positions in the list of faces and
/// vertices (in file order); `line` is the 1-based line of a text file; `index` is a vertex
/// reference exactly as the user wrote it (1-based or negative in OBJ, 0-based in PLY and arrays).
/// `path` is `None` for meshes built from in-memory arrays.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MeshError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The file was refused before it was parsed: it is not a regular file, it is larger than
    /// [`MAX_MESH_FILE_BYTES`](super::MAX_MESH_FILE_BYTES), or an OBJ line is longer than
    /// [`MAX_OBJ_LINE_BYTES`](super::MAX_OBJ_LINE_BYTES).
    #[error("cannot read {path}: {source}")]
    Refused {
        /// The file.
        path: String,
        /// Which bound it broke.
        #[source]
        source: InputError,
    },
    /// A PLY header that does not end within the first [`HEAD_BYTES`](crate::input::HEAD_BYTES)
    /// bytes of the file.
    #[error("{path}: the PLY header does not end within the first {max} bytes")]
    HeaderTooLong {
        /// The file.
        path: String,
        /// The longest header read.
        max: usize,
    },
    /// The file is neither OBJ nor PLY.
    #[error("{path}: not an OBJ or PLY file")]
    UnknownFormat {
        /// The file.
        path: String,
    },
    /// A syntax error at a line (OBJ, PLY header, ASCII PLY body).
    #[error("{path}:{line}: {message}")]
    Parse {
        /// The file.
        path: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong, naming the offending token.
        message: String,
    },
    /// The file ended before all declared data was read.
    #[error("{path}: truncated: {message}")]
    Truncated {
        /// The file.
        path: String,
        /// What was missing, e.g. "face 12 of 500".
        message: String,
    },
    /// Binary data that cannot be valid (e.g. a negative list length), naming the element.
    #[error("{path}: {message}")]
    Malformed {
        /// The file.
        path: String,
        /// What is wrong and where (element and property).
        message: String,
    },
    /// No vertices or no faces.
    #[error("empty mesh: {0}")]
    Empty(String),
    /// A coordinate is NaN or infinite.
    #[error("{}vertex {vertex} has a non-finite coordinate ({}, {}, {})", at(path, line), fmt_num(*x), fmt_num(*y), fmt_num(*z))]
    NonFinite {
        /// 0-based vertex number.
        vertex: usize,
        /// The coordinates as read.
        x: f64,
        /// See `x`.
        y: f64,
        /// See `x`.
        z: f64,
        /// The file, if the mesh came from one.
        path: Option<String>,
        /// The 1-based line, for text files.
        line: Option<usize>,
    },
    /// A coordinate's magnitude exceeds [`MAX_COORDINATE`](super::MAX_COORDINATE): the mesh's
    /// extent would overflow in squared lengths.
    #[error("{}vertex {vertex} has a coordinate of magnitude {}, more than the {} supported", at(path, &None), fmt_num(*value), fmt_num(*max))]
    CoordinateTooLarge {
        /// 0-based vertex number.
        vertex: usize,
        /// The largest magnitude among its coordinates.
        value: f64,
        /// The limit.
        max: f64,
        /// The file, if the mesh came from one.
        path: Option<String>,
    },
    /// A face refers to a vertex that does not exist.
    #[error("{}face {face} refers to vertex {index}, but there are {vertex_count} vertices", at(path, line))]
    IndexOutOfRange {
        /// 0-based face number.
        face: usize,
        /// The vertex reference as written by the user.
        index: i64,
        /// How many vertices there are (in OBJ, for a relative index: defined so far).
        vertex_count: usize,
        /// The file, if the mesh came from one.
        path: Option<String>,
        /// The 1-based line, for text files.
        line: Option<usize>,
    },
    /// A face has fewer than three vertices.
    #[error("{}face {face} has {count} vertices; a face needs at least 3", at(path, line))]
    TooFewVertices {
        /// 0-based face number.
        face: usize,
        /// How many vertices it has.
        count: usize,
        /// The file, if the mesh came from one.
        path: Option<String>,
        /// The 1-based line, for text files.
        line: Option<usize>,
    },
    /// Every face has zero area (or collapsed when duplicate vertices were welded), so there is
    /// no surface.
    #[error("{}all {faces} faces have zero area: there is no surface", at(path, &None))]
    AllFacesDegenerate {
        /// Number of faces in the input.
        faces: usize,
        /// The file, if the mesh came from one.
        path: Option<String>,
    },
    /// A flat triangle index array whose length is not a multiple of 3.
    #[error("the triangle index array has {len} entries, which is not a multiple of 3")]
    IndexCountNotMultipleOf3 {
        /// Length of the index array.
        len: usize,
    },
    /// The surface cannot be wound consistently: walking across its edges from triangle to
    /// triangle comes back to `triangle` needing the opposite winding (a Möbius strip, a Klein
    /// bottle), so it has no inside and outside. Triangles are numbered after triangulation.
    #[error(
        "{}the surface is not orientable (like a Möbius strip or a Klein bottle): triangles {other} and {triangle} \
         at the edge ({}, {}, {})–({}, {}, {}) cannot be wound consistently, so it has no inside and outside",
        at(path, &None), from[0], from[1], from[2], to[0], to[1], to[2]
    )]
    NonOrientable {
        /// The triangle reached a second time with the opposite winding.
        triangle: usize,
        /// The triangle it was reached from.
        other: usize,
        /// One end of the edge they share.
        from: [f64; 3],
        /// The other end.
        to: [f64; 3],
        /// The file, if the mesh came from one.
        path: Option<String>,
    },
    /// The weld tolerance is negative, NaN or infinite.
    #[error("weld tolerance {} is invalid: it must be finite and >= 0", fmt_num(*value))]
    InvalidTolerance {
        /// The tolerance given.
        value: f64,
    },
}

/// `"path:line: "`, `"path: "` or `""`, the prefix that locates an error.
fn at(path: &Option<String>, line: &Option<usize>) -> String {
    match (path, line) {
        (Some(p), Some(l)) => format!("{p}:{l}: "),
        (Some(p), None) => format!("{p}: "),
        (None, Some(l)) => format!("line {l}: "),
        (None, None) => String::new(),
    }
}

impl MeshError {
    /// The error for an input file that `path` names and [`crate::input`] refused.
    pub(crate) fn input(path: &str, e: InputError) -> Self {
        match e {
            InputError::Io(source) => MeshError::Io { path: path.to_owned(), source },
            source => MeshError::Refused { path: path.to_owned(), source },
        }
    }
}
