//! PLY (Stanford polygon file) reader.
//!
//! Reads `format ascii 1.0`, `binary_little_endian 1.0` and `binary_big_endian 1.0`. The
//! `vertex` element must have scalar `x`, `y`, `z` properties of any type (`char`, `uchar`,
//! `short`, `ushort`, `int`, `uint`, `float`, `double` or their aliases `int8`, `uint8`, `int16`,
//! `uint16`, `int32`, `uint32`, `float32`, `float64`); its other properties (normals, colours,
//! …) are skipped. Faces come from a `face` element's list property `vertex_indices` (or
//! `vertex_index`), and from triangle strips in a `tristrips` element (`-1` restarts a strip).
//! Every other element is skipped, list properties included. Vertex indices are 0-based.

use std::path::Path;

use glam::DVec3;

use super::trimesh::{build, WeldOptions};
use super::{open_mesh, MeshError, TriMesh};
use crate::input::{clip, quote, HEAD_BYTES};

/// Loads a PLY file, triangulating n-gons and welding duplicate positions with the default
/// [`WeldOptions`].
///
/// The header is checked from the file's first [`HEAD_BYTES`] before the body is read.
///
/// # Errors
/// [`MeshError::Io`] if the file cannot be read, [`MeshError::Refused`] for a file that is not a
/// regular file or is larger than [`MAX_MESH_FILE_BYTES`](super::MAX_MESH_FILE_BYTES), and every
/// error of [`parse_ply`].
pub fn load_ply(path: &Path) -> Result<TriMesh, MeshError> {
    load_ply_with(path, &WeldOptions::default())
}

/// [`load_ply`] with explicit welding options.
///
/// # Errors
/// As [`load_ply`], and [`MeshError::InvalidTolerance`] for a bad tolerance.
pub fn load_ply_with(path: &Path, weld: &WeldOptions) -> Result<TriMesh, MeshError> {
    let name = path.display().to_string();
    let mut file = open_mesh(path, &name, None)?;
    let (head, _) = file.head().map_err(|e| MeshError::input(&name, e))?;
    parse_header(head, &name)?;
    let bytes = file.read_all().map_err(|e| MeshError::input(&name, e))?;
    parse_ply_with(&bytes, &name, weld)
}

/// Parses the bytes of a PLY file; `path_for_messages` names the source in errors.
///
/// # Errors
/// - [`MeshError::Parse`] with the 1-based line for a bad header (no `ply` magic, an unknown
///   format, keyword or type, a `vertex` element without `x`/`y`/`z`, a `face` element without a
///   `vertex_indices` list) and for a bad number in an ASCII body (naming the token, element and
///   property);
/// - [`MeshError::Truncated`] if the header has no `end_header` or the body ends early, naming
///   the element, e.g. "face 12 of 500";
/// - [`MeshError::HeaderTooLong`] if the header does not end within the first [`HEAD_BYTES`];
/// - [`MeshError::Malformed`] for a negative list length in a binary body;
/// - [`MeshError::IndexOutOfRange`] for a negative index or one past the last vertex;
/// - [`MeshError::TooFewVertices`] for a face with fewer than 3 indices;
/// - [`MeshError::NonFinite`] for a NaN or infinite coordinate;
/// - [`MeshError::Empty`] for a file without vertices or faces, and
///   [`MeshError::AllFacesDegenerate`] if every face has zero area.
///
/// Element and vertex numbers in messages are 0-based; lines are 1-based.
pub fn parse_ply(bytes: &[u8], path_for_messages: &str) -> Result<TriMesh, MeshError> {
    parse_ply_with(bytes, path_for_messages, &WeldOptions::default())
}

/// [`parse_ply`] with explicit welding options.
///
/// # Errors
/// As [`parse_ply`], and [`MeshError::InvalidTolerance`] for a bad tolerance.
pub fn parse_ply_with(bytes: &[u8], path_for_messages: &str, weld: &WeldOptions) -> Result<TriMesh, MeshError> {
    let path = path_for_messages;
    let header = parse_header(bytes, path)?;
    if header.vertex.is_none() {
        return Err(MeshError::Empty(format!("{path}: there is no 'vertex' element")));
    }
    let body = &bytes[header.body_start..];
    let mut mesh = MeshData::new(&header, body.len());
    match header.format {
        Format::Ascii => {
            let mut src = AsciiSource { data: body, pos: 0, line: header.lines + 1 };
            read_body(&header, &mut src, &mut mesh, path)?;
        }
        Format::BinaryLittleEndian | Format::BinaryBigEndian => {
            let big = header.format == Format::BinaryBigEndian;
            let mut src = BinarySource { data: body, pos: 0, big };
            read_body(&header, &mut src, &mut mesh, path)?;
        }
    }
    build(mesh.positions, &mesh.offsets, &mesh.indices, weld, Some(path))
}

// ---------------------------------------------------------------------------------------------
// Header

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Format {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }
}

#[derive(Debug, Clone)]
enum Property {
    Scalar { name: String, ty: Scalar },
    List { name: String, count: Scalar, item: Scalar },
}

impl Property {
    fn name(&self) -> &str {
        match self {
            Property::Scalar { name, .. } | Property::List { name, .. } => name,
        }
    }
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
    /// Header line of the `element` statement.
    line: usize,
}

impl Element {
    /// Size in bytes of one instance, if it has no list property.
    fn fixed_size(&self) -> Option<usize> {
        self.properties
            .iter()
            .map(|p| match p {
                Property::Scalar { ty, .. } => Some(ty.size()),
                Property::List { .. } => None,
            })
            .sum()
    }

    /// Smallest possible size in bytes of one instance (lists empty).
    fn min_size(&self) -> usize {
        self.properties
            .iter()
            .map(|p| match p {
                Property::Scalar { ty, .. } => ty.size(),
                Property::List { count, .. } => count.size(),
            })
            .sum()
    }
}

/// What the reader does with an element.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    /// Vertices: positions from the properties at these indices.
    Vertex {
        x: usize,
        y: usize,
        z: usize,
    },
    /// Polygons from the list property at this index.
    Face {
        list: usize,
    },
    /// Triangle strips from the list property at this index.
    Strips {
        list: usize,
    },
    Skip,
}

struct Header {
    format: Format,
    elements: Vec<Element>,
    roles: Vec<Role>,
    /// Index of the vertex element.
    vertex: Option<usize>,
    /// Number of header lines, `end_header` included.
    lines: usize,
    body_start: usize,
}

fn parse_header(bytes: &[u8], path: &str) -> Result<Header, MeshError> {
    let err = |line: usize, message: String| MeshError::Parse { path: path.to_owned(), line, message };
    let mut pos = 0;
    let mut line_no = 0;
    let mut format: Option<Format> = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        if pos >= bytes.len() {
            if line_no == 0 {
                return Err(err(1, "empty file: a PLY file starts with the line 'ply'".into()));
            }
            return Err(MeshError::Truncated {
                path: path.to_owned(),
                message: format!("the header ends after line {line_no} without 'end_header'"),
            });
        }
        let end = bytes[pos..].iter().position(|&b| b == b'\n').map_or(bytes.len(), |i| pos + i);
        if end >= HEAD_BYTES {
            return Err(MeshError::HeaderTooLong { path: path.to_owned(), max: HEAD_BYTES });
        }
        let raw = &bytes[pos..end];
        pos = (end + 1).min(bytes.len());
        line_no += 1;
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        let text = String::from_utf8_lossy(raw);
        if line_no == 1 {
            if text.trim_end() != "ply" {
                return Err(err(1, format!("not a PLY file: the first line is {}, not 'ply'", quote(&text))));
            }
            continue;
        }
        let mut tokens = text.split_ascii_whitespace();
        let Some(keyword) = tokens.next() else {
            continue;
        };
        match keyword {
            "comment" | "obj_info" => {}
            "format" => {
                let (Some(kind), Some(version)) = (tokens.next(), tokens.next()) else {
                    return Err(err(line_no, format!("incomplete format line {}", quote(text.trim()))));
                };
                format = Some(match kind {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::BinaryLittleEndian,
                    "binary_big_endian" => Format::BinaryBigEndian,
                    other => {
                        return Err(err(
                            line_no,
                            format!("unknown format {}: expected ascii, binary_little_endian or binary_big_endian", quote(other)),
                        ))
                    }
                });
                if version != "1.0" && version != "1" {
                    return Err(err(line_no, format!("unsupported PLY version {}: expected 1.0", quote(version))));
                }
            }
            "element" => {
                let (Some(name), Some(count)) = (tokens.next(), tokens.next()) else {
                    return Err(err(line_no, format!("incomplete element line {}", quote(text.trim()))));
                };
                let count: usize = count.parse().map_err(|_| {
                    err(line_no, format!("cannot read {} as the number of {} elements", quote(count), quote(name)))
                })?;
                if elements.iter().any(|e| e.name == name) {
                    return Err(err(line_no, format!("element {} is declared twice", quote(name))));
                }
                elements.push(Element { name: name.to_owned(), count, properties: Vec::new(), line: line_no });
            }
            "property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(err(line_no, "'property' before any 'element'".into()));
                };
                let Some(first) = tokens.next() else {
                    return Err(err(line_no, "incomplete property line".into()));
                };
                let property = if first == "list" {
                    let (Some(ct), Some(it), Some(name)) = (tokens.next(), tokens.next(), tokens.next()) else {
                        return Err(err(line_no, format!("incomplete list property {}", quote(text.trim()))));
                    };
                    let count =
                        Scalar::parse(ct).ok_or_else(|| err(line_no, format!("unknown type {} of a list length", quote(ct))))?;
                    let item =
                        Scalar::parse(it).ok_or_else(|| err(line_no, format!("unknown type {} of list items", quote(it))))?;
                    if !count.is_integer() {
                        return Err(err(line_no, format!("list length type {} is not an integer type", quote(ct))));
                    }
                    Property::List { name: name.to_owned(), count, item }
                } else {
                    let Some(name) = tokens.next() else {
                        return Err(err(line_no, format!("property of type {} has no name", quote(first))));
                    };
                    let ty =
                        Scalar::parse(first).ok_or_else(|| err(line_no, format!("unknown property type {}", quote(first))))?;
                    Property::Scalar { name: name.to_owned(), ty }
                };
                if element.properties.iter().any(|p| p.name() == property.name()) {
                    return Err(err(
                        line_no,
                        format!("property {} of element {} is declared twice", quote(property.name()), quote(&element.name)),
                    ));
                }
                element.properties.push(property);
            }
            "end_header" => break,
            other => {
                return Err(err(
                    line_no,
                    format!("unknown header keyword {}: expected format, element, property, comment or end_header", quote(other)),
                ))
            }
        }
    }
    let Some(format) = format else {
        return Err(err(line_no, "the header has no 'format' line".into()));
    };

    let mut roles = Vec::with_capacity(elements.len());
    let mut vertex = None;
    for (k, e) in elements.iter().enumerate() {
        let find = |name: &str| e.properties.iter().position(|p| p.name() == name);
        let role = match e.name.as_str() {
            "vertex" => {
                let mut axes = [0usize; 3];
                for (a, axis) in ["x", "y", "z"].iter().enumerate() {
                    let Some(i) = find(axis) else {
                        return Err(err(e.line, format!("element 'vertex' has no property '{axis}'")));
                    };
                    if matches!(e.properties[i], Property::List { .. }) {
                        return Err(err(e.line, format!("vertex property '{axis}' is a list, not a number")));
                    }
                    axes[a] = i;
                }
                vertex = Some(k);
                Role::Vertex { x: axes[0], y: axes[1], z: axes[2] }
            }
            "face" | "tristrips" => {
                let Some(list) = find("vertex_indices").or_else(|| find("vertex_index")) else {
                    return Err(err(e.line, format!("element {} has no list property 'vertex_indices'", quote(&e.name))));
                };
                let Property::List { item, .. } = e.properties[list] else {
                    return Err(err(
                        e.line,
                        format!("{} of element {} is not a list", quote(e.properties[list].name()), quote(&e.name)),
                    ));
                };
                if !item.is_integer() {
                    return Err(err(e.line, format!("vertex indices of type '{}' are not integers", item.name())));
                }
                if e.name == "face" {
                    Role::Face { list }
                } else {
                    Role::Strips { list }
                }
            }
            _ => Role::Skip,
        };
        roles.push(role);
    }
    Ok(Header { format, elements, roles, vertex, lines: line_no, body_start: pos })
}

// ---------------------------------------------------------------------------------------------
// Body

/// A number read from the body.
#[derive(Debug, Clone, Copy)]
enum Num {
    Int(i64),
    Float(f64),
}

impl Num {
    /// The value as an integer (list lengths and indices have integer types, checked when the
    /// header is read, so the float case does not arise).
    fn as_i64(self) -> i64 {
        match self {
            Num::Int(i) => i,
            Num::Float(f) => f as i64,
        }
    }

    fn as_f64(self) -> f64 {
        match self {
            Num::Int(i) => i as f64,
            Num::Float(f) => f,
        }
    }
}

/// Why a value could not be read.
enum ReadError {
    /// The data ended.
    End,
    /// An ASCII token that is not a number of the type (token, line).
    Bad(String, usize),
}

trait Source {
    fn read(&mut self, ty: Scalar) -> Result<Num, ReadError>;
    /// Skips `n` instances of a fixed-size element of `size` bytes; `false` if the data ends.
    fn skip_fixed(&mut self, n: usize, size: usize) -> Option<bool>;
    /// Line of the next value, for ASCII bodies.
    fn line(&self) -> Option<usize>;
}

struct BinarySource<'a> {
    data: &'a [u8],
    pos: usize,
    big: bool,
}

impl BinarySource<'_> {
    #[inline]
    fn take<const N: usize>(&mut self) -> Result<[u8; N], ReadError> {
        let end = self.pos.checked_add(N).ok_or(ReadError::End)?;
        let bytes = self.data.get(self.pos..end).ok_or(ReadError::End)?;
        self.pos = end;
        let mut a: [u8; N] = bytes.try_into().map_err(|_| ReadError::End)?;
        if self.big {
            a.reverse();
        }
        Ok(a)
    }
}

impl Source for BinarySource<'_> {
    #[inline]
    fn read(&mut self, ty: Scalar) -> Result<Num, ReadError> {
        Ok(match ty {
            Scalar::I8 => Num::Int(i64::from(i8::from_le_bytes(self.take()?))),
            Scalar::U8 => Num::Int(i64::from(u8::from_le_bytes(self.take()?))),
            Scalar::I16 => Num::Int(i64::from(i16::from_le_bytes(self.take()?))),
            Scalar::U16 => Num::Int(i64::from(u16::from_le_bytes(self.take()?))),
            Scalar::I32 => Num::Int(i64::from(i32::from_le_bytes(self.take()?))),
            Scalar::U32 => Num::Int(i64::from(u32::from_le_bytes(self.take()?))),
            Scalar::F32 => Num::Float(f64::from(f32::from_le_bytes(self.take()?))),
            Scalar::F64 => Num::Float(f64::from_le_bytes(self.take()?)),
        })
    }

    fn skip_fixed(&mut self, n: usize, size: usize) -> Option<bool> {
        let len = n.checked_mul(size)?;
        if self.data.len() - self.pos >= len {
            self.pos += len;
            Some(true)
        } else {
            Some(false)
        }
    }

    fn line(&self) -> Option<usize> {
        None
    }
}

struct AsciiSource<'a> {
    data: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> AsciiSource<'a> {
    fn token(&mut self) -> Option<&'a [u8]> {
        let data = self.data;
        while self.pos < self.data.len() && self.data[self.pos].is_ascii_whitespace() {
            if self.data[self.pos] == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
        let start = self.pos;
        while self.pos < self.data.len() && !self.data[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        (self.pos > start).then(|| &data[start..self.pos])
    }
}

impl Source for AsciiSource<'_> {
    fn read(&mut self, ty: Scalar) -> Result<Num, ReadError> {
        let Some(tok) = self.token() else {
            return Err(ReadError::End);
        };
        let text = std::str::from_utf8(tok).unwrap_or("");
        let bad = || ReadError::Bad(String::from_utf8_lossy(tok).into_owned(), self.line);
        if ty.is_integer() {
            match text.parse::<i64>() {
                Ok(i) => Ok(Num::Int(i)),
                // Some writers print integers as "3.0".
                Err(_) => match text.parse::<f64>() {
                    Ok(f) if f.fract() == 0.0 && f.abs() < 9e15 => Ok(Num::Int(f as i64)),
                    _ => Err(bad()),
                },
            }
        } else {
            text.parse::<f64>().map(Num::Float).map_err(|_| bad())
        }
    }

    fn skip_fixed(&mut self, _n: usize, _size: usize) -> Option<bool> {
        None // element by element
    }

    fn line(&self) -> Option<usize> {
        Some(self.line)
    }
}

struct MeshData {
    positions: Vec<DVec3>,
    offsets: Vec<usize>,
    indices: Vec<u32>,
}

impl MeshData {
    fn new(header: &Header, body_len: usize) -> Self {
        // Reserve no more than the body could hold (a header may declare absurd counts).
        let cap = |role: fn(&Role) -> bool| -> usize {
            header
                .elements
                .iter()
                .zip(&header.roles)
                .filter(|(_, r)| role(r))
                .map(|(e, _)| e.count.min(body_len / e.min_size().max(1)))
                .sum()
        };
        let vertices = cap(|r| matches!(r, Role::Vertex { .. }));
        let faces = cap(|r| matches!(r, Role::Face { .. }));
        let mut offsets = Vec::with_capacity(faces + 1);
        offsets.push(0);
        MeshData { positions: Vec::with_capacity(vertices), offsets, indices: Vec::with_capacity(3 * faces) }
    }
}

fn read_body(header: &Header, src: &mut impl Source, mesh: &mut MeshData, path: &str) -> Result<(), MeshError> {
    let vertex_count = header.vertex.map_or(0, |v| header.elements[v].count);
    let mut values: Vec<f64> = Vec::new();
    let mut strip: Vec<i64> = Vec::new();
    for (element, role) in header.elements.iter().zip(&header.roles) {
        if element.properties.is_empty() {
            // Nothing to read, however many instances it declares (an ASCII body would
            // otherwise loop over them one by one).
            continue;
        }
        let of = |i: usize| format!("{} {i} of {}", clip(&element.name), element.count);
        let fail = |e: ReadError, i: usize, property: &str| match e {
            ReadError::End => MeshError::Truncated {
                path: path.to_owned(),
                message: format!("the data ends in {} (property {})", of(i), quote(property)),
            },
            ReadError::Bad(token, line) => MeshError::Parse {
                path: path.to_owned(),
                line,
                message: format!("cannot read {} as a number ({}, property {})", quote(&token), of(i), quote(property)),
            },
        };
        if *role == Role::Skip {
            if let Some(size) = element.fixed_size() {
                if src.skip_fixed(element.count, size) == Some(true) {
                    continue;
                }
                // ASCII, or binary data too short: read instance by instance, so that a
                // truncation is reported at the instance where the data ends.
            }
        }
        for i in 0..element.count {
            values.clear();
            for (pi, property) in element.properties.iter().enumerate() {
                match *property {
                    Property::Scalar { ty, ref name } => {
                        let v = src.read(ty).map_err(|e| fail(e, i, name))?;
                        values.push(v.as_f64());
                    }
                    Property::List { count, item, ref name } => {
                        let n = src.read(count).map_err(|e| fail(e, i, name))?.as_i64();
                        let line = src.line();
                        if n < 0 {
                            let message = format!("negative list length {n} in {} (property {})", of(i), quote(name));
                            return Err(match line {
                                Some(line) => MeshError::Parse { path: path.to_owned(), line, message },
                                None => MeshError::Malformed { path: path.to_owned(), message },
                            });
                        }
                        let n = n as usize;
                        let is_faces = matches!(*role, Role::Face { list } | Role::Strips { list } if list == pi);
                        if !is_faces {
                            for _ in 0..n {
                                src.read(item).map_err(|e| fail(e, i, name))?;
                            }
                            values.push(f64::NAN);
                            continue;
                        }
                        if let Role::Face { .. } = role {
                            if n < 3 {
                                return Err(MeshError::TooFewVertices {
                                    face: mesh.offsets.len() - 1,
                                    count: n,
                                    path: Some(path.to_owned()),
                                    line,
                                });
                            }
                            let face = mesh.offsets.len() - 1;
                            for _ in 0..n {
                                let index = src.read(item).map_err(|e| fail(e, i, name))?.as_i64();
                                if index < 0 || index as u64 >= vertex_count as u64 {
                                    return Err(MeshError::IndexOutOfRange {
                                        face,
                                        index,
                                        vertex_count,
                                        path: Some(path.to_owned()),
                                        line: src.line(),
                                    });
                                }
                                mesh.indices.push(index as u32);
                            }
                            mesh.offsets.push(mesh.indices.len());
                        } else {
                            strip.clear();
                            for _ in 0..n {
                                let index = src.read(item).map_err(|e| fail(e, i, name))?.as_i64();
                                if index < -1 || index >= vertex_count as i64 {
                                    return Err(MeshError::IndexOutOfRange {
                                        face: mesh.offsets.len() - 1,
                                        index,
                                        vertex_count,
                                        path: Some(path.to_owned()),
                                        line: src.line(),
                                    });
                                }
                                strip.push(index);
                            }
                            push_strip(&strip, mesh);
                        }
                        values.push(f64::NAN);
                    }
                }
            }
            if let Role::Vertex { x, y, z } = *role {
                let p = DVec3::new(values[x], values[y], values[z]);
                if !p.is_finite() {
                    return Err(MeshError::NonFinite {
                        vertex: i,
                        x: p.x,
                        y: p.y,
                        z: p.z,
                        path: Some(path.to_owned()),
                        line: src.line(),
                    });
                }
                mesh.positions.push(p);
            }
        }
    }
    Ok(())
}

/// Appends the triangles of a triangle strip (`-1` restarts it), alternating the winding so that
/// all keep the first triangle's orientation.
fn push_strip(strip: &[i64], mesh: &mut MeshData) {
    for run in strip.split(|&k| k == -1) {
        for (j, w) in run.windows(3).enumerate() {
            let [a, b, c] = [w[0] as u32, w[1] as u32, w[2] as u32];
            let tri = if j % 2 == 0 { [a, b, c] } else { [b, a, c] };
            mesh.indices.extend_from_slice(&tri);
            mesh.offsets.push(mesh.indices.len());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_element_without_properties_is_skipped_whatever_its_count() {
        let text = "ply\nformat ascii 1.0\nelement empty 18446744073709551615\nelement vertex 3\nproperty float x\n\
                    property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
                    0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        let m = parse_ply(text.as_bytes(), "t.ply").unwrap();
        assert_eq!(m.triangles().len(), 1);
    }

    const CUBE_ASCII: &str = "ply\nformat ascii 1.0\ncomment unit cube\n\
        element vertex 8\nproperty float x\nproperty float y\nproperty float z\n\
        property uchar red\n\
        element face 6\nproperty list uchar int vertex_indices\n\
        element edge 1\nproperty list uchar int vertex_indices\nproperty int flags\n\
        end_header\n\
        0 0 0 1\n1 0 0 2\n1 1 0 3\n0 1 0 4\n0 0 1 5\n1 0 1 6\n1 1 1 7\n0 1 1 8\n\
        4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n\
        2 0 1 9\n";

    #[test]
    fn ascii_cube_with_extra_properties_and_elements() {
        let m = parse_ply(CUBE_ASCII.as_bytes(), "cube.ply").unwrap();
        assert_eq!(m.user_vertex_count(), 8);
        assert_eq!(m.triangles().len(), 12);
        assert!((m.signed_volume() - 1.0).abs() < 1e-12);
        assert!(m.is_closed());
    }

    #[test]
    fn big_endian_with_double_and_short_types() {
        let mut b = b"ply\r\nformat binary_big_endian 1.0\r\nelement vertex 3\r\n\
            property double x\r\nproperty short y\r\nproperty float64 z\r\n\
            element face 1\r\nproperty list uint8 uint32 vertex_index\r\nend_header\r\n"
            .to_vec();
        for (x, y, z) in [(0.0f64, 0i16, 0.0f64), (2.0, 0, 0.0), (0.0, 3, 0.0)] {
            b.extend(x.to_be_bytes());
            b.extend(y.to_be_bytes());
            b.extend(z.to_be_bytes());
        }
        b.push(3);
        for i in [0u32, 1, 2] {
            b.extend(i.to_be_bytes());
        }
        let m = parse_ply(&b, "t.ply").unwrap();
        assert_eq!(m.positions()[2], DVec3::new(0.0, 3.0, 0.0));
        assert!((m.area() - 3.0).abs() < 1e-15);
    }

    #[test]
    fn tristrips() {
        let text = "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n\
            property float z\nelement tristrips 1\nproperty list int int vertex_indices\nend_header\n\
            0 0 0\n0 1 0\n1 0 0\n1 1 0\n2 0 0\n6 0 2 1 3 -1 2\n";
        // Strip 0 2 1 3, then a one-index run (no triangle).
        let m = parse_ply(text.as_bytes(), "s.ply").unwrap();
        assert_eq!(m.triangles(), &[[0, 2, 1], [1, 2, 3]]);
        // Both triangles face the same way.
        assert!(m.triangle_cross(0).z * m.triangle_cross(1).z > 0.0);
    }

    #[test]
    fn header_errors_name_the_line() {
        let e = parse_ply(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty flot x\n", "h.ply").unwrap_err();
        assert_eq!(e.to_string(), "h.ply:4: unknown property type 'flot'");
        let e = parse_ply(b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n", "h.ply").unwrap_err();
        assert_eq!(e.to_string(), "h.ply:3: element 'vertex' has no property 'y'");
        let e = parse_ply(b"ply\nformat ascii 1.0\n", "h.ply").unwrap_err();
        assert!(matches!(e, MeshError::Truncated { .. }), "{e}");
    }

    #[test]
    fn ascii_bad_number_names_token_and_line() {
        let text = CUBE_ASCII.replace("1 1 1 7", "1 x1 1 7");
        let e = parse_ply(text.as_bytes(), "cube.ply").unwrap_err();
        assert_eq!(e.to_string(), "cube.ply:21: cannot read 'x1' as a number (vertex 6 of 8, property 'y')");
    }

    #[test]
    fn absurd_counts_do_not_allocate() {
        let text = "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000000\n\
            property float x\nproperty float y\nproperty float z\nend_header\n";
        let e = parse_ply(text.as_bytes(), "big.ply").unwrap_err();
        assert!(matches!(e, MeshError::Truncated { .. }), "{e}");
        assert!(e.to_string().contains("vertex 0 of 4000000000000"), "{e}");
    }
}
