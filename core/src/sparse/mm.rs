//! Matrix Market I/O, so that external solvers can be timed on exactly the same systems.
//!
//! Matrices are written in the `coordinate real symmetric` format (lower triangle, when the
//! channel is exactly symmetric) or `coordinate real general`; vectors in the `array real
//! general` format. Values are written with the shortest representation that reads back to the
//! same `f64`, so a write–read round trip is exact.

use std::fs::File;
use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::Path;

use super::csr::{CsrMatrix, Entry, Triplet};
use super::error::SparseError;

fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> SparseError + '_ {
    move |source| SparseError::Io { path: path.display().to_string(), source }
}

fn mm_err(path: &Path, line: usize, message: impl Into<String>) -> SparseError {
    SparseError::MatrixMarket { path: path.display().to_string(), line, message: message.into() }
}

impl<T: Entry> CsrMatrix<T> {
    /// Writes one channel as a Matrix Market `coordinate real` file (1-based indices):
    /// `symmetric` (lower triangle only) when the channel is exactly symmetric, else `general`.
    ///
    /// # Errors
    /// [`SparseError::Io`] if the file cannot be written;
    /// [`SparseError::InvalidOption`] if `channel` is out of range.
    pub fn write_matrix_market(&self, path: impl AsRef<Path>, channel: usize) -> Result<(), SparseError> {
        let path = path.as_ref();
        if channel >= T::CHANNELS {
            return Err(SparseError::InvalidOption(format!("channel {channel}: the matrix has {} channel(s)", T::CHANNELS)));
        }
        let p = self.pattern();
        let n = self.n();
        let vals = self.values();
        let symmetric = (0..n).all(|i| {
            let r = p.row_ptr()[i];
            p.row(i).iter().enumerate().all(|(q, &j)| {
                let b = p.position(j as usize, i).map_or(0.0, |k| vals[k].channel(channel));
                vals[r + q].channel(channel) == b
            })
        });
        let keep = |i: usize, j: usize| !symmetric || j <= i;
        let count = (0..n).map(|i| p.row(i).iter().filter(|&&j| keep(i, j as usize)).count()).sum::<usize>();
        let file = File::create(path).map_err(io_err(path))?;
        let mut w = BufWriter::new(file);
        let kind = if symmetric { "symmetric" } else { "general" };
        (|| -> std::io::Result<()> {
            writeln!(w, "%%MatrixMarket matrix coordinate real {kind}")?;
            writeln!(w, "% written by transcut (channel {channel})")?;
            writeln!(w, "{n} {n} {count}")?;
            for i in 0..n {
                let r = p.row_ptr()[i];
                for (q, &j) in p.row(i).iter().enumerate() {
                    if keep(i, j as usize) {
                        writeln!(w, "{} {} {:e}", i + 1, j + 1, vals[r + q].channel(channel))?;
                    }
                }
            }
            w.flush()
        })()
        .map_err(io_err(path))
    }
}

/// The lines of `lines` that hold data (neither blank nor `%` comments), each with its 1-based
/// line number; `before` lines of the file were read already. (Their words are read with
/// `split_whitespace`, which needs no trimming.)
fn data_lines<'a>(
    path: &'a Path,
    lines: impl Iterator<Item = std::io::Result<String>> + 'a,
    before: usize,
) -> impl Iterator<Item = Result<(usize, String), SparseError>> + 'a {
    lines.enumerate().filter_map(move |(k, l)| match l {
        Ok(l) => {
            let t = l.trim();
            (!t.is_empty() && !t.starts_with('%')).then(|| Ok((before + k + 1, l)))
        }
        Err(e) => Some(Err(io_err(path)(e))),
    })
}

/// The value `s` of line `line_no`, which must be a finite number.
fn parse_value(path: &Path, line_no: usize, s: &str) -> Result<f64, SparseError> {
    let v: f64 = s.parse().map_err(|e| mm_err(path, line_no, format!("bad value `{s}`: {e}")))?;
    if !v.is_finite() {
        return Err(mm_err(path, line_no, format!("non-finite value `{s}`")));
    }
    Ok(v)
}

/// Reads the header line and the size line; returns (format words, size numbers, line number).
fn read_header(
    path: &Path,
    lines: &mut impl Iterator<Item = std::io::Result<String>>,
) -> Result<(Vec<String>, Vec<usize>, usize), SparseError> {
    let header = lines.next().transpose().map_err(io_err(path))?.ok_or_else(|| mm_err(path, 0, "empty file"))?;
    let words: Vec<String> = header.split_whitespace().map(str::to_ascii_lowercase).collect();
    if words.len() != 5 || words[0] != "%%matrixmarket" || words[1] != "matrix" {
        return Err(mm_err(path, 1, "expected a `%%MatrixMarket matrix <format> <field> <symmetry>` header"));
    }
    let (line_no, t) = data_lines(path, lines, 1).next().ok_or_else(|| mm_err(path, 0, "file ends before the size line"))??;
    let sizes: Result<Vec<usize>, _> = t.split_whitespace().map(str::parse::<usize>).collect();
    let sizes = sizes.map_err(|e| mm_err(path, line_no, format!("bad size line: {e}")))?;
    Ok((words, sizes, line_no))
}

impl CsrMatrix<f64> {
    /// Reads a square Matrix Market `coordinate` matrix (`real`, `integer` or `pattern` field,
    /// `general` or `symmetric`). Duplicates are summed; the diagonal is added to the pattern
    /// when absent.
    ///
    /// # Errors
    /// [`SparseError::Io`] if the file cannot be read; [`SparseError::MatrixMarket`] naming the
    /// line for a malformed header, size line or entry, an index out of range, a non-square or
    /// unsupported (complex, skew-symmetric, hermitian, array) matrix.
    pub fn read_matrix_market(path: impl AsRef<Path>) -> Result<Self, SparseError> {
        let path = path.as_ref();
        let file = File::open(path).map_err(io_err(path))?;
        let mut lines = BufReader::new(file).lines();
        let (words, sizes, line_no) = read_header(path, &mut lines)?;
        if words[2] != "coordinate" {
            return Err(mm_err(path, 1, format!("format `{}` is not supported for matrices (need coordinate)", words[2])));
        }
        let field_pattern = match words[3].as_str() {
            "real" | "integer" | "double" => false,
            "pattern" => true,
            f => return Err(mm_err(path, 1, format!("field `{f}` is not supported"))),
        };
        let symmetric = match words[4].as_str() {
            "general" => false,
            "symmetric" => true,
            s => return Err(mm_err(path, 1, format!("symmetry `{s}` is not supported"))),
        };
        let &[rows, cols, count] = sizes.as_slice() else {
            return Err(mm_err(path, line_no, "the size line needs `rows cols entries`"));
        };
        if rows != cols {
            return Err(mm_err(path, line_no, format!("matrix is {rows} × {cols}; only square matrices are supported")));
        }
        let n = rows;
        let mut triplets = Vec::with_capacity(if symmetric { 2 * count } else { count });
        let mut seen = 0;
        for l in data_lines(path, lines, line_no) {
            let (line_no, t) = l?;
            if seen == count {
                return Err(mm_err(path, line_no, format!("more than the {count} declared entries")));
            }
            let mut it = t.split_whitespace();
            let mut index = |what: &str| -> Result<u32, SparseError> {
                let s = it.next().ok_or_else(|| mm_err(path, line_no, format!("missing {what} index")))?;
                let v: usize = s.parse().map_err(|e| mm_err(path, line_no, format!("bad {what} index `{s}`: {e}")))?;
                if v == 0 || v > n {
                    return Err(mm_err(path, line_no, format!("{what} index {v} out of range 1..={n}")));
                }
                Ok((v - 1) as u32)
            };
            let i = index("row")?;
            let j = index("column")?;
            let v = if field_pattern {
                1.0
            } else {
                parse_value(path, line_no, it.next().ok_or_else(|| mm_err(path, line_no, "missing value"))?)?
            };
            triplets.push(Triplet::new(i, j, v));
            if symmetric && i != j {
                triplets.push(Triplet::new(j, i, v));
            }
            seen += 1;
        }
        if seen != count {
            return Err(mm_err(path, 0, format!("file ends after {seen} of {count} declared entries")));
        }
        CsrMatrix::from_triplets(n, &triplets)
    }
}

/// A dense Matrix Market `array`: `rows × cols` values in column-major order.
#[derive(Debug, Clone, PartialEq)]
pub struct MmArray {
    /// Number of rows.
    pub rows: usize,
    /// Number of columns.
    pub cols: usize,
    /// Values, column-major (column `c` is `data[c * rows..(c + 1) * rows]`).
    pub data: Vec<f64>,
}

impl MmArray {
    /// Column `c` as a slice.
    ///
    /// # Panics
    /// If `c >= cols`.
    #[must_use]
    pub fn column(&self, c: usize) -> &[f64] {
        assert!(c < self.cols, "column {c} out of range");
        &self.data[c * self.rows..(c + 1) * self.rows]
    }
}

/// Writes a dense `rows × cols` array (column-major data) as Matrix Market `array real general`.
///
/// # Errors
/// [`SparseError::DimensionMismatch`] if `data.len() != rows * cols`; [`SparseError::Io`].
pub fn write_array_matrix_market(path: impl AsRef<Path>, rows: usize, cols: usize, data: &[f64]) -> Result<(), SparseError> {
    let path = path.as_ref();
    if data.len() != rows * cols {
        return Err(SparseError::DimensionMismatch {
            what: "array data length (rows × cols)",
            expected: rows * cols,
            found: data.len(),
        });
    }
    let file = File::create(path).map_err(io_err(path))?;
    let mut w = BufWriter::new(file);
    (|| -> std::io::Result<()> {
        writeln!(w, "%%MatrixMarket matrix array real general")?;
        writeln!(w, "{rows} {cols}")?;
        for v in data {
            writeln!(w, "{v:e}")?;
        }
        w.flush()
    })()
    .map_err(io_err(path))
}

/// Writes a vector as an `n × 1` Matrix Market array.
///
/// # Errors
/// [`SparseError::Io`].
pub fn write_vector_matrix_market(path: impl AsRef<Path>, v: &[f64]) -> Result<(), SparseError> {
    write_array_matrix_market(path, v.len(), 1, v)
}

/// Writes a three-channel vector as an `n × 3` Matrix Market array (columns R, G, B).
///
/// # Errors
/// [`SparseError::Io`].
pub fn write_vector3_matrix_market(path: impl AsRef<Path>, v: &[[f64; 3]]) -> Result<(), SparseError> {
    let data: Vec<f64> = (0..3).flat_map(|c| v.iter().map(move |x| x[c])).collect();
    write_array_matrix_market(path, v.len(), 3, &data)
}

/// Reads a Matrix Market `array real general` (or `integer`) file.
///
/// # Errors
/// [`SparseError::Io`]; [`SparseError::MatrixMarket`] naming the line for a malformed or
/// unsupported file, a bad or non-finite value, or a wrong number of values.
pub fn read_array_matrix_market(path: impl AsRef<Path>) -> Result<MmArray, SparseError> {
    let path = path.as_ref();
    let file = File::open(path).map_err(io_err(path))?;
    let mut lines = BufReader::new(file).lines();
    let (words, sizes, line_no) = read_header(path, &mut lines)?;
    if words[2] != "array" || !matches!(words[3].as_str(), "real" | "integer" | "double") || words[4] != "general" {
        return Err(mm_err(path, 1, "only `array real general` is supported for vectors"));
    }
    let &[rows, cols] = sizes.as_slice() else {
        return Err(mm_err(path, line_no, "the size line needs `rows cols`"));
    };
    let mut data = Vec::with_capacity(rows * cols);
    for l in data_lines(path, lines, line_no) {
        let (line_no, t) = l?;
        for s in t.split_whitespace() {
            let v = parse_value(path, line_no, s)?;
            if data.len() == rows * cols {
                return Err(mm_err(path, line_no, format!("more than the {} declared values", rows * cols)));
            }
            data.push(v);
        }
    }
    if data.len() != rows * cols {
        return Err(mm_err(path, 0, format!("file ends after {} of {} values", data.len(), rows * cols)));
    }
    Ok(MmArray { rows, cols, data })
}
