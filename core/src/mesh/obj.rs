//! Wavefront OBJ reader.
//!
//! Reads the polygonal geometry of an OBJ file: `v` lines (x y z, an optional w or vertex colour
//! after them is ignored) and `f` faces whose corners are written `i`, `i/t`, `i//n` or `i/t/n`.
//! Indices are 1-based; negative indices count back from the last vertex defined so far (−1 is
//! the last one), as the OBJ specification says. Positive indices may refer to vertices defined
//! later in the file. Texture coordinates, normals, groups, materials, smoothing groups, lines,
//! points and free-form geometry are accepted and ignored, as are statements this reader does not
//! know. `#` starts a comment (to the end of the line), a `\` at the end of a line continues the
//! statement on the next one. Lines end in LF, CRLF or a lone CR (old Mac files), and a UTF-8
//! byte-order mark at the start is skipped.

use std::path::Path;

use glam::DVec3;

use super::trimesh::{build, WeldOptions};
use super::{open_mesh, MeshError, TriMesh, MAX_OBJ_LINE_BYTES};
use crate::input::quote;

/// Loads an OBJ file, triangulating n-gons and welding duplicate positions with the default
/// [`WeldOptions`].
///
/// Bytes that are not UTF-8 (e.g. Latin-1 object names in comments) are tolerated: only the
/// ASCII numbers and keywords matter.
///
/// The first statement is checked before more than the file's first
/// [`HEAD_BYTES`](crate::input::HEAD_BYTES) are read, and lines are capped at
/// [`MAX_OBJ_LINE_BYTES`] as they are read.
///
/// # Errors
/// [`MeshError::Io`] if the file cannot be read, [`MeshError::Refused`] for a file that is not a
/// regular file, is larger than [`MAX_MESH_FILE_BYTES`](super::MAX_MESH_FILE_BYTES) or has a
/// line longer than [`MAX_OBJ_LINE_BYTES`], and every error of [`parse_obj`].
pub fn load_obj(path: &Path) -> Result<TriMesh, MeshError> {
    load_obj_with(path, &WeldOptions::default())
}

/// [`load_obj`] with explicit welding options.
///
/// # Errors
/// As [`load_obj`], and [`MeshError::InvalidTolerance`] for a bad tolerance.
pub fn load_obj_with(path: &Path, weld: &WeldOptions) -> Result<TriMesh, MeshError> {
    let name = path.display().to_string();
    let mut file = open_mesh(path, &name, Some(MAX_OBJ_LINE_BYTES))?;
    let (head, all) = file.head().map_err(|e| MeshError::input(&name, e))?;
    check_head(head, all, &name)?;
    let bytes = file.read_all().map_err(|e| MeshError::input(&name, e))?;
    let text = String::from_utf8_lossy(&bytes);
    parse_obj_with(&text, &name, weld)
}

/// Checks the first statement of the file from its first bytes (`all`: they are the whole
/// file), so that a file that is not OBJ is refused before the rest is read. A statement that
/// is continued (`\`), or does not end within `head`, is left to the full parse.
fn check_head(head: &[u8], all: bool, path: &str) -> Result<(), MeshError> {
    let text = String::from_utf8_lossy(head);
    let text = text.strip_prefix('\u{FEFF}').unwrap_or(&text);
    let mut reader = ObjReader::new(path, 0);
    let mut pieces = lines(text).enumerate().peekable();
    while let Some((i, raw)) = pieces.next() {
        let complete = all || pieces.peek().is_some();
        let line = strip_comment(raw);
        if !complete || line.trim_end().ends_with('\\') {
            return Ok(());
        }
        if !line.trim().is_empty() {
            return reader.statement(line, i + 1);
        }
    }
    Ok(())
}

/// The lines of `text`, split at LF, CRLF or a lone CR (the line ends are not included); like
/// `str::split('\n')`, a text ending in a line end gives a last, empty line.
pub(super) fn lines(text: &str) -> impl Iterator<Item = &str> {
    let mut rest = Some(text);
    std::iter::from_fn(move || {
        let t = rest?;
        match t.find(['\n', '\r']) {
            Some(i) => {
                let end = if t[i..].starts_with("\r\n") { i + 2 } else { i + 1 };
                rest = Some(&t[end..]);
                Some(&t[..i])
            }
            None => {
                rest = None;
                Some(t)
            }
        }
    })
}

/// Parses OBJ text; `path_for_messages` names the source in errors.
///
/// # Errors
/// - [`MeshError::Parse`] with the 1-based line and the bad token: a coordinate or index that is
///   not a number, a vertex with fewer than 3 coordinates, a vertex index of 0, a corner with
///   more than three `/`-separated parts, a line that does not start with a keyword;
/// - [`MeshError::NonFinite`] (with the line) for a NaN or infinite coordinate;
/// - [`MeshError::TooFewVertices`] (with the line) for a face with fewer than 3 corners;
/// - [`MeshError::IndexOutOfRange`] (with the line) for an index past the last vertex of the
///   file, or a negative index reaching before the first vertex; the index is reported as
///   written;
/// - [`MeshError::Empty`] for a file without vertices or faces, and
///   [`MeshError::AllFacesDegenerate`] if every face has zero area.
pub fn parse_obj(text: &str, path_for_messages: &str) -> Result<TriMesh, MeshError> {
    parse_obj_with(text, path_for_messages, &WeldOptions::default())
}

/// [`parse_obj`] with explicit welding options.
///
/// # Errors
/// As [`parse_obj`], and [`MeshError::InvalidTolerance`] for a bad tolerance.
pub fn parse_obj_with(text: &str, path_for_messages: &str, weld: &WeldOptions) -> Result<TriMesh, MeshError> {
    read_statements(text, path_for_messages)?.finish(weld)
}

/// The texture coordinates of an OBJ file's faces ([`parse_obj_uv_map`]) read from `path`.
///
/// # Errors
/// As [`load_obj`], and those of [`parse_obj_uv_map`].
pub fn load_obj_uv_map(path: &Path) -> Result<UvMap, MeshError> {
    let name = path.display().to_string();
    let file = open_mesh(path, &name, Some(MAX_OBJ_LINE_BYTES))?;
    let bytes = file.read_all().map_err(|e| MeshError::input(&name, e))?;
    parse_obj_uv_map(&String::from_utf8_lossy(&bytes), &name)
}

/// A UV map: triangles over a mesh's vertices (as the file numbers them, from 0) with one UV
/// per corner.
#[derive(Debug, Clone, PartialEq)]
pub struct UvMap {
    /// Vertex indices of each triangle (n-gons fanned from their first corner).
    pub triangles: Vec<[u32; 3]>,
    /// (u, v) of each triangle's corners in turn, 3 per triangle.
    pub uvs: Vec<[f64; 2]>,
}

/// The faces of OBJ text with their texture coordinates (`vt`, referenced as `f v/t ...`):
/// each face fanned into triangles from its first corner, the vertices as the file numbers
/// them (the user vertex order of [`parse_obj`]'s mesh), a UV per corner.
///
/// # Errors
/// Those of [`parse_obj`] for the statements; [`MeshError::Parse`] naming the line of a face
/// corner without a texture coordinate, a texture index out of range, or a `vt` that is not
/// numbers.
pub fn parse_obj_uv_map(text: &str, path_for_messages: &str) -> Result<UvMap, MeshError> {
    let reader = read_statements(text, path_for_messages)?;
    let mut map = UvMap { triangles: Vec::new(), uvs: Vec::new() };
    for face in 0..reader.offsets.len() - 1 {
        let (start, end) = (reader.offsets[face], reader.offsets[face + 1]);
        let line = reader.face_lines[face];
        let mut corners = Vec::with_capacity(end - start);
        for k in start..end {
            let t = reader.corner_uvs[k];
            if t == NO_UV {
                return Err(reader
                    .parse_error(line, "a face corner has no texture coordinate ('f v/t ...' is needed for a UV map)".into()));
            }
            if t as usize >= reader.uv_coords.len() {
                return Err(reader.parse_error(
                    line,
                    format!("a texture index beyond the file's {} texture coordinates ('vt')", reader.uv_coords.len()),
                ));
            }
            corners.push((reader.indices[k], reader.uv_coords[t as usize]));
        }
        for k in 1..corners.len() - 1 {
            map.triangles.push([corners[0].0, corners[k].0, corners[k + 1].0]);
            map.uvs.extend([corners[0].1, corners[k].1, corners[k + 1].1]);
        }
    }
    Ok(map)
}

/// Reads every statement of OBJ text.
fn read_statements<'a>(text: &str, path_for_messages: &'a str) -> Result<ObjReader<'a>, MeshError> {
    let text = text.strip_prefix('\u{FEFF}').unwrap_or(text);
    let mut reader = ObjReader::new(path_for_messages, text.len());
    let mut lines = lines(text);
    let mut line_no = 0usize;
    let mut joined = String::new();
    while let Some(raw) = lines.next() {
        line_no += 1;
        let line = strip_comment(raw);
        if line.trim_end().ends_with('\\') {
            // A continued statement: join the physical lines, report errors at the first one.
            let start = line_no;
            joined.clear();
            let mut cur = line;
            loop {
                let t = cur.trim_end();
                if let Some(body) = t.strip_suffix('\\') {
                    joined.push_str(body);
                    joined.push(' ');
                    match lines.next() {
                        Some(nx) => {
                            line_no += 1;
                            cur = strip_comment(nx);
                        }
                        None => break,
                    }
                } else {
                    joined.push_str(cur);
                    break;
                }
            }
            reader.statement(&joined, start)?;
        } else {
            reader.statement(line, line_no)?;
        }
    }
    Ok(reader)
}

/// The line without its comment.
fn strip_comment(line: &str) -> &str {
    match line.find('#') {
        Some(i) => &line[..i],
        None => line,
    }
}

/// Statements that are part of OBJ but carry nothing a surface mesh needs.
const IGNORED: &[&str] = &[
    "vn",
    "vp",
    "l",
    "p",
    "o",
    "g",
    "s",
    "mg",
    "usemtl",
    "mtllib",
    "maplib",
    "usemap",
    "lod",
    "bevel",
    "c_interp",
    "d_interp",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
    "cstype",
    "deg",
    "bmat",
    "step",
    "curv",
    "curv2",
    "surf",
    "parm",
    "trim",
    "hole",
    "scrv",
    "sp",
    "end",
    "con",
    "call",
    "csh",
];

/// A face corner without a texture coordinate.
const NO_UV: u32 = u32::MAX;

struct ObjReader<'a> {
    path: &'a str,
    positions: Vec<DVec3>,
    offsets: Vec<usize>,
    indices: Vec<u32>,
    face_lines: Vec<usize>,
    /// `vt` coordinates (u, v).
    uv_coords: Vec<[f64; 2]>,
    /// Per corner (parallel to `indices`): its texture coordinate's index from 0, or [`NO_UV`];
    /// resolved when read, checked by [`parse_obj_uv_map`] only.
    corner_uvs: Vec<u32>,
}

impl<'a> ObjReader<'a> {
    fn new(path: &'a str, text_len: usize) -> Self {
        // A vertex line is at least ~20 bytes in practice; reserve for a typical mix.
        let guess = text_len / 64;
        let mut offsets = Vec::with_capacity(guess + 1);
        offsets.push(0);
        ObjReader {
            path,
            positions: Vec::with_capacity(guess / 2),
            offsets,
            indices: Vec::with_capacity(guess * 3),
            face_lines: Vec::with_capacity(guess),
            uv_coords: Vec::new(),
            corner_uvs: Vec::with_capacity(guess * 3),
        }
    }

    fn parse_error(&self, line: usize, message: String) -> MeshError {
        MeshError::Parse { path: self.path.to_owned(), line, message }
    }

    fn statement(&mut self, line: &str, line_no: usize) -> Result<(), MeshError> {
        let mut tokens = line.split_ascii_whitespace();
        let Some(keyword) = tokens.next() else {
            return Ok(());
        };
        match keyword {
            "v" => self.vertex(tokens, line_no),
            "vt" => self.texture_coordinate(tokens, line_no),
            "f" | "fo" => self.face(tokens, line_no),
            k if IGNORED.contains(&k) => Ok(()),
            k if k.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_') => {
                Ok(()) // an extension statement some other program writes
            }
            k => Err(self.parse_error(
                line_no,
                format!("unexpected {}: an OBJ statement starts with a keyword such as 'v' or 'f'", quote(k)),
            )),
        }
    }

    fn vertex<'t>(&mut self, mut tokens: impl Iterator<Item = &'t str>, line_no: usize) -> Result<(), MeshError> {
        let mut xyz = [0.0f64; 3];
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            let Some(tok) = tokens.next() else {
                return Err(self.parse_error(line_no, format!("vertex has {k} coordinates; 'v' needs x, y and z")));
            };
            xyz[k] = tok.parse::<f64>().map_err(|_| {
                self.parse_error(line_no, format!("cannot read {} as the {axis} coordinate of a vertex", quote(tok)))
            })?;
        }
        // An optional weight w, or vertex colours r g b (some exporters write them): ignored,
        // but they must be numbers.
        for tok in tokens {
            if tok.parse::<f64>().is_err() {
                return Err(self.parse_error(line_no, format!("cannot read {} as a number after a vertex's x y z", quote(tok))));
            }
        }
        let p = DVec3::from_array(xyz);
        if !p.is_finite() {
            return Err(MeshError::NonFinite {
                vertex: self.positions.len(),
                x: p.x,
                y: p.y,
                z: p.z,
                path: Some(self.path.to_owned()),
                line: Some(line_no),
            });
        }
        self.positions.push(p);
        Ok(())
    }

    fn texture_coordinate<'t>(&mut self, tokens: impl Iterator<Item = &'t str>, line_no: usize) -> Result<(), MeshError> {
        let mut uv = [0.0; 2];
        for (k, tok) in tokens.enumerate() {
            let x = tok
                .parse::<f64>()
                .map_err(|_| self.parse_error(line_no, format!("cannot read {} as a texture coordinate", quote(tok))))?;
            if k < 2 {
                uv[k] = x;
            }
        }
        self.uv_coords.push(uv);
        Ok(())
    }

    fn face<'t>(&mut self, tokens: impl Iterator<Item = &'t str>, line_no: usize) -> Result<(), MeshError> {
        let face = self.offsets.len() - 1;
        let defined = self.positions.len();
        let start = self.indices.len();
        for tok in tokens {
            let mut parts = tok.split('/');
            let first = parts.next().unwrap_or("");
            // Texture and normal references must be well-formed; the texture index is kept for
            // a UV map (a negative one counts back from the last `vt` so far).
            let mut extra = 0;
            let mut uv = NO_UV;
            for part in parts {
                extra += 1;
                if extra > 2 || (!part.is_empty() && parse_int(part).is_none()) {
                    return Err(
                        self.parse_error(line_no, format!("bad face corner {}: expected i, i/t, i//n or i/t/n", quote(tok)))
                    );
                }
                if extra == 1 && !part.is_empty() {
                    let t = parse_int(part).unwrap_or(0);
                    let resolved = if t > 0 { t - 1 } else { self.uv_coords.len() as i64 + t };
                    uv = u32::try_from(resolved).ok().filter(|&r| r != NO_UV && t != 0).unwrap_or(NO_UV - 1);
                }
            }
            let Some(index) = parse_int(first) else {
                return Err(self.parse_error(
                    line_no,
                    format!("cannot read {} in face corner {} as a vertex index", quote(first), quote(tok)),
                ));
            };
            let resolved = if index > 0 {
                index - 1
            } else if index < 0 {
                let r = defined as i64 + index;
                if r < 0 {
                    return Err(MeshError::IndexOutOfRange {
                        face,
                        index,
                        vertex_count: defined,
                        path: Some(self.path.to_owned()),
                        line: Some(line_no),
                    });
                }
                r
            } else {
                return Err(self.parse_error(
                    line_no,
                    format!("vertex index 0 in face corner {}: OBJ indices start at 1 (or -1 for the last vertex)", quote(tok)),
                ));
            };
            let Ok(resolved) = u32::try_from(resolved) else {
                return Err(MeshError::IndexOutOfRange {
                    face,
                    index,
                    vertex_count: defined,
                    path: Some(self.path.to_owned()),
                    line: Some(line_no),
                });
            };
            self.indices.push(resolved);
            self.corner_uvs.push(uv);
        }
        let count = self.indices.len() - start;
        if count < 3 {
            return Err(MeshError::TooFewVertices { face, count, path: Some(self.path.to_owned()), line: Some(line_no) });
        }
        self.offsets.push(self.indices.len());
        self.face_lines.push(line_no);
        Ok(())
    }

    fn finish(self, weld: &WeldOptions) -> Result<TriMesh, MeshError> {
        // Positive indices may point forward, so they are checked once every vertex is known.
        let n = self.positions.len();
        if n > 0 {
            for face in 0..self.offsets.len() - 1 {
                let poly = &self.indices[self.offsets[face]..self.offsets[face + 1]];
                if let Some(&i) = poly.iter().find(|&&i| i as usize >= n) {
                    return Err(MeshError::IndexOutOfRange {
                        face,
                        index: i64::from(i) + 1,
                        vertex_count: n,
                        path: Some(self.path.to_owned()),
                        line: Some(self.face_lines[face]),
                    });
                }
            }
        }
        build(self.positions, &self.offsets, &self.indices, weld, Some(self.path))
    }
}

/// A decimal integer with an optional sign; `None` if malformed or out of `i64` range.
fn parse_int(s: &str) -> Option<i64> {
    let b = s.as_bytes();
    let (neg, digits) = match b.first()? {
        b'-' => (true, &b[1..]),
        b'+' => (false, &b[1..]),
        _ => (false, b),
    };
    if digits.is_empty() {
        return None;
    }
    let mut v: i64 = 0;
    for &c in digits {
        if !c.is_ascii_digit() {
            return None;
        }
        v = v.checked_mul(10)?.checked_add(i64::from(c - b'0'))?;
    }
    Some(if neg { -v } else { v })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uv_maps_fan_faces_and_name_what_is_missing() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
                    f 1/1 2/2 3/3 4/4\nf 2/2/1 5/-3 3/-2\n";
        let map = parse_obj_uv_map(text, "t.obj").unwrap();
        assert_eq!(map.triangles, vec![[0, 1, 2], [0, 2, 3], [1, 4, 2]]);
        assert_eq!(map.uvs[..6], [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
        assert_eq!(map.uvs[6..], [[1.0, 0.0], [1.0, 0.0], [1.0, 1.0]]);
        // The mesh of the same text is unchanged by the texture coordinates.
        assert_eq!(parse_obj(text, "t.obj").unwrap().positions().len(), 5);
        let e = parse_obj_uv_map("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2 3/1\n", "t.obj").unwrap_err();
        assert!(e.to_string().contains("no texture coordinate") && e.to_string().contains(":5:"), "{e}");
        let e = parse_obj_uv_map("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n", "t.obj").unwrap_err();
        assert!(e.to_string().contains("beyond the file's 1 texture coordinates"), "{e}");
        let e = parse_obj_uv_map("v 0 0 0\nvt 0 x\n", "t.obj").unwrap_err();
        assert!(e.to_string().contains("'x'"), "{e}");
    }

    #[test]
    fn parse_int_forms() {
        assert_eq!(parse_int("12"), Some(12));
        assert_eq!(parse_int("-3"), Some(-3));
        assert_eq!(parse_int("+4"), Some(4));
        assert_eq!(parse_int(""), None);
        assert_eq!(parse_int("-"), None);
        assert_eq!(parse_int("1.5"), None);
        assert_eq!(parse_int("99999999999999999999"), None);
    }

    #[test]
    fn corner_forms_and_relative_indices() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n\
                    f 1/1/1 2/1/1 3//1\nf -4 -2/1 -1\n";
        let m = parse_obj(text, "t.obj").unwrap();
        assert_eq!(m.triangles(), &[[0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn continuation_comments_crlf() {
        let text = "# header\r\nv 0 0 0 # origin\r\nv 1 0 0\r\nv 0 \\\r\n 1 0\r\nf 1 2 \\\r\n3\r\n";
        let m = parse_obj(text, "t.obj").unwrap();
        assert_eq!(m.user_vertex_count(), 3);
        assert_eq!(m.triangles(), &[[0, 1, 2]]);
        assert!((m.area() - 0.5).abs() < 1e-15);
    }

    #[test]
    fn continued_statement_errors_at_its_first_line() {
        let text = "v 0 0 0\nv 1 0 \\\n  zz\n";
        let e = parse_obj(text, "t.obj").unwrap_err();
        assert!(matches!(e, MeshError::Parse { line: 2, .. }), "{e}");
        assert!(e.to_string().contains("'zz'"), "{e}");
    }

    #[test]
    fn forward_references_are_allowed() {
        let m = parse_obj("f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n", "t.obj").unwrap();
        assert_eq!(m.triangles().len(), 1);
    }

    #[test]
    fn bad_corner_token_is_named() {
        let e = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2/x 3\n", "t.obj").unwrap_err();
        assert!(matches!(e, MeshError::Parse { line: 4, .. }));
        assert!(e.to_string().contains("'2/x'"), "{e}");
        let e = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2/1/1/1 3\n", "t.obj").unwrap_err();
        assert!(e.to_string().contains("'2/1/1/1'"), "{e}");
    }

    #[test]
    fn too_few_coordinates() {
        let e = parse_obj("v 0 0\n", "t.obj").unwrap_err();
        assert_eq!(e.to_string(), "t.obj:1: vertex has 2 coordinates; 'v' needs x, y and z");
    }

    #[test]
    fn bom_and_lone_cr_line_ends() {
        let m = parse_obj("\u{FEFF}# mac\rv 0 0 0\rv 1 0 0\rv 0 1 0\rf 1 2 3\r", "t.obj").unwrap();
        assert_eq!(m.user_vertex_count(), 3);
        assert_eq!(m.triangles(), &[[0, 1, 2]]);
        // Line numbers count a lone CR, a CRLF and an LF once each.
        let e = parse_obj("v 0 0 0\rv 1 0 0\r\nv 0 1 0\nv 1 x 0\n", "t.obj").unwrap_err();
        assert!(matches!(e, MeshError::Parse { line: 4, .. }), "{e}");
    }

    #[test]
    fn lines_split_at_every_line_end() {
        assert_eq!(lines("a\rb\r\nc\nd").collect::<Vec<_>>(), ["a", "b", "c", "d"]);
        assert_eq!(lines("a\n").collect::<Vec<_>>(), ["a", ""]);
        assert_eq!(lines("\r\r").collect::<Vec<_>>(), ["", "", ""]);
    }

    #[test]
    fn head_check_reads_the_first_statement_only() {
        // A bad first statement is refused from the head alone.
        let e = check_head(b"# c\n1 2 3\n", false, "t.obj").unwrap_err();
        assert!(matches!(e, MeshError::Parse { line: 2, .. }), "{e}");
        // A good one passes, whatever follows.
        check_head(b"v 0 0 0\nzz", false, "t.obj").unwrap();
        // A statement cut off by the end of the head is not judged.
        check_head(b"v 0 0", false, "t.obj").unwrap();
        assert!(check_head(b"v 0 0", true, "t.obj").is_err());
        // Nor is a continued one.
        check_head(b"v 0 \\\n 0 0\n", false, "t.obj").unwrap();
    }

    #[test]
    fn long_tokens_are_quoted_short() {
        let text = format!("v 0 0 {}\n", "9".repeat(5000) + "x");
        let e = parse_obj(&text, "t.obj").unwrap_err();
        let msg = e.to_string();
        assert!(msg.len() < 200, "{msg}");
        assert!(msg.contains("(5001 bytes)"), "{msg}");
    }

    #[test]
    fn coordinates_whose_extent_overflows_are_refused() {
        // 1e190 is finite, but the bounding-box diagonal (its square) would overflow.
        let e = parse_obj("v 0 0 1e190\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "t.obj").unwrap_err();
        assert!(matches!(e, MeshError::CoordinateTooLarge { vertex: 0, value, .. } if value == 1e190), "{e}");
        assert_eq!(e.to_string(), "t.obj: vertex 0 has a coordinate of magnitude 1e190, more than the 1e30 supported");
        parse_obj("v 0 0 -1e30\nv 1e30 0 0\nv 0 1e30 0\nf 1 2 3\n", "t.obj").unwrap();
    }

    #[test]
    fn garbage_line_is_rejected() {
        let e = parse_obj("v 0 0 0\n1 2 3\n", "t.obj").unwrap_err();
        assert!(matches!(e, MeshError::Parse { line: 2, .. }));
        assert!(e.to_string().contains("'1'"), "{e}");
    }
}
