//! Compressed sparse row storage: a sparsity pattern shared by several matrices, single- and
//! three-channel matrices over it, triplet assembly and the parallel matrix–vector product.
//!
//! The three colour channels of a diffusion system have the same mesh, hence the same pattern,
//! but different values (the medium differs per channel). A [`CsrMatrix3`] keeps one
//! [`CsrPattern`] (behind an [`Arc`], so later matrices on the same mesh reuse it) and the values
//! interleaved per nonzero as `[f64; 3]`: the SpMV streams the pattern once for all three
//! channels.

use std::sync::Arc;

use nalgebra::DMatrix;
use rayon::prelude::*;

use super::error::SparseError;
use super::ops::{row_mul, CHUNK};

/// Rows per parallel block in pattern building and assembly (fixed, for reproducibility).
pub(crate) const ROW_BLOCK: usize = 1024;

mod private {
    pub trait Sealed {}
    impl Sealed for f64 {}
    impl Sealed for [f64; 3] {}
}

/// The value type of a matrix entry: `f64` (one channel) or `[f64; 3]` (R, G, B).
///
/// Sealed: implemented only for those two types.
pub trait Entry: Copy + Send + Sync + PartialEq + std::fmt::Debug + private::Sealed {
    /// The number of channels (1 or 3).
    const CHANNELS: usize;
    /// The zero entry.
    const ZERO: Self;
    /// `self += other`, channel by channel.
    fn accumulate(&mut self, other: Self);
    /// The value of channel `c`.
    ///
    /// # Panics
    /// If `c >= CHANNELS`.
    fn channel(&self, c: usize) -> f64;
}

impl Entry for f64 {
    const CHANNELS: usize = 1;
    const ZERO: Self = 0.0;
    #[inline]
    fn accumulate(&mut self, other: Self) {
        *self += other;
    }
    #[inline]
    fn channel(&self, c: usize) -> f64 {
        assert_eq!(c, 0, "a single-channel entry has only channel 0");
        *self
    }
}

impl Entry for [f64; 3] {
    const CHANNELS: usize = 3;
    const ZERO: Self = [0.0; 3];
    #[inline]
    fn accumulate(&mut self, other: Self) {
        self[0] += other[0];
        self[1] += other[1];
        self[2] += other[2];
    }
    #[inline]
    fn channel(&self, c: usize) -> f64 {
        self[c]
    }
}

/// The sparsity pattern of an `n × n` matrix in CSR form.
///
/// Invariants (checked by every constructor): columns within a row are strictly increasing and
/// below `n`, and every row holds its diagonal entry (possibly with value zero), so Jacobi-type
/// preconditioners and row edits can rely on it.
#[derive(Debug, Clone)]
pub struct CsrPattern {
    n: usize,
    row_ptr: Vec<usize>,
    col_idx: Vec<u32>,
    diag: Vec<usize>,
    /// Whether the constructor made the pattern symmetric ([`Self::from_edges`]), so that
    /// [`Self::is_structurally_symmetric`] need not search every row; otherwise it searches on
    /// demand.
    symmetric_by_construction: bool,
}

/// Two patterns are equal when they store the same entries (however they were built).
impl PartialEq for CsrPattern {
    fn eq(&self, other: &Self) -> bool {
        self.n == other.n && self.row_ptr == other.row_ptr && self.col_idx == other.col_idx
    }
}

impl Eq for CsrPattern {}

fn check_dimension(n: usize) -> Result<(), SparseError> {
    if u32::try_from(n).is_err() {
        return Err(SparseError::TooLarge(format!("{n} rows; column indices are 32-bit, so at most {} rows", u32::MAX)));
    }
    Ok(())
}

/// Splits `data` (indexed by `row_ptr`) into one mutable slice per block of `ROW_BLOCK` rows.
pub(crate) fn split_row_blocks<'a, T>(mut data: &'a mut [T], row_ptr: &[usize]) -> Vec<&'a mut [T]> {
    let n = row_ptr.len() - 1;
    let mut out = Vec::with_capacity(n.div_ceil(ROW_BLOCK));
    let mut r0 = 0;
    while r0 < n {
        let r1 = (r0 + ROW_BLOCK).min(n);
        let len = row_ptr[r1] - row_ptr[r0];
        let (head, tail) = std::mem::take(&mut data).split_at_mut(len);
        out.push(head);
        data = tail;
        r0 = r1;
    }
    out
}

/// Exclusive prefix sum of row counts into a row pointer of length `n + 1`.
fn prefix(counts: &[usize]) -> Vec<usize> {
    let mut ptr = Vec::with_capacity(counts.len() + 1);
    let mut s = 0;
    ptr.push(0);
    for &c in counts {
        s += c;
        ptr.push(s);
    }
    ptr
}

impl CsrPattern {
    /// The symmetric pattern of a graph on `n` vertices: the diagonal plus both `(i, j)` and
    /// `(j, i)` for every edge. Edges may come in either orientation and repeat; self-loops
    /// `[i, i]` only name the diagonal, which is always present.
    ///
    /// # Errors
    /// [`SparseError::IndexOutOfRange`] naming the first edge with a vertex `≥ n`;
    /// [`SparseError::TooLarge`] if `n` does not fit 32-bit indices.
    pub fn from_edges(n: usize, edges: &[[u32; 2]]) -> Result<Self, SparseError> {
        Self::build(n, "edge", edges, true)
    }

    /// A general (possibly unsymmetric) pattern: the diagonal plus every listed `[row, col]`.
    /// Duplicates are merged.
    ///
    /// # Errors
    /// [`SparseError::IndexOutOfRange`] naming the first entry with an index `≥ n`;
    /// [`SparseError::TooLarge`] if `n` does not fit 32-bit indices.
    pub fn from_entries(n: usize, entries: &[[u32; 2]]) -> Result<Self, SparseError> {
        Self::build(n, "entry", entries, false)
    }

    /// Takes ready CSR arrays, checking the invariants.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `row_ptr` is not `n + 1` long or does not end at
    /// `col_idx.len()`; [`SparseError::InvalidOption`] if `row_ptr` decreases, a row's columns
    /// are not strictly increasing or a row lacks its diagonal;
    /// [`SparseError::IndexOutOfRange`] for a column `≥ n`.
    pub fn from_csr(n: usize, row_ptr: Vec<usize>, col_idx: Vec<u32>) -> Result<Self, SparseError> {
        check_dimension(n)?;
        if row_ptr.len() != n + 1 {
            return Err(SparseError::DimensionMismatch {
                what: "row pointer length (n + 1)",
                expected: n + 1,
                found: row_ptr.len(),
            });
        }
        if row_ptr[0] != 0 || row_ptr[n] != col_idx.len() {
            return Err(SparseError::DimensionMismatch {
                what: "row pointer end (number of column indices)",
                expected: col_idx.len(),
                found: row_ptr[n],
            });
        }
        let mut diag = Vec::with_capacity(n);
        for i in 0..n {
            if row_ptr[i + 1] < row_ptr[i] {
                return Err(SparseError::InvalidOption(format!("row pointer decreases at row {i}")));
            }
            let cols = &col_idx[row_ptr[i]..row_ptr[i + 1]];
            if let Some(&c) = cols.iter().find(|&&c| c as usize >= n) {
                return Err(SparseError::IndexOutOfRange { what: format!("column index in row {i}"), index: u64::from(c), n });
            }
            if cols.windows(2).any(|w| w[0] >= w[1]) {
                return Err(SparseError::InvalidOption(format!("columns of row {i} are not strictly increasing")));
            }
            match cols.binary_search(&(i as u32)) {
                Ok(k) => diag.push(row_ptr[i] + k),
                Err(_) => return Err(SparseError::InvalidOption(format!("row {i} has no diagonal entry"))),
            }
        }
        Ok(Self { n, row_ptr, col_idx, diag, symmetric_by_construction: false })
    }

    fn build(n: usize, what: &str, entries: &[[u32; 2]], symmetric: bool) -> Result<Self, SparseError> {
        check_dimension(n)?;
        let mut counts = vec![1usize; n];
        for (k, &[i, j]) in entries.iter().enumerate() {
            for v in [i, j] {
                if v as usize >= n {
                    return Err(SparseError::IndexOutOfRange { what: format!("{what} {k}"), index: u64::from(v), n });
                }
            }
            if i != j {
                counts[i as usize] += 1;
                if symmetric {
                    counts[j as usize] += 1;
                }
            }
        }
        let start = prefix(&counts);
        let mut tmp = vec![0u32; start[n]];
        let mut cursor: Vec<usize> = start[..n].to_vec();
        for (i, c) in cursor.iter_mut().enumerate() {
            tmp[*c] = i as u32;
            *c += 1;
        }
        for &[i, j] in entries {
            if i != j {
                tmp[cursor[i as usize]] = j;
                cursor[i as usize] += 1;
                if symmetric {
                    tmp[cursor[j as usize]] = i;
                    cursor[j as usize] += 1;
                }
            }
        }
        drop(cursor);
        // Sort and deduplicate every row in parallel; record the unique counts.
        let blocks = split_row_blocks(&mut tmp, &start);
        let lens: Vec<Vec<usize>> = blocks
            .into_par_iter()
            .enumerate()
            .map(|(b, slice)| {
                let r0 = b * ROW_BLOCK;
                let r1 = (r0 + ROW_BLOCK).min(n);
                let off = start[r0];
                (r0..r1)
                    .map(|r| {
                        let row = &mut slice[start[r] - off..start[r + 1] - off];
                        row.sort_unstable();
                        let mut len = 0;
                        for k in 0..row.len() {
                            if k == 0 || row[k] != row[len - 1] {
                                row[len] = row[k];
                                len += 1;
                            }
                        }
                        len
                    })
                    .collect()
            })
            .collect();
        let mut row_ptr = Vec::with_capacity(n + 1);
        row_ptr.push(0);
        let mut col_idx = Vec::with_capacity(start[n]);
        let mut diag = Vec::with_capacity(n);
        for (r, len) in lens.into_iter().flatten().enumerate() {
            let row = &tmp[start[r]..start[r] + len];
            let d = row.binary_search(&(r as u32)).expect("diagonal inserted above");
            diag.push(col_idx.len() + d);
            col_idx.extend_from_slice(row);
            row_ptr.push(col_idx.len());
        }
        Ok(Self { n, row_ptr, col_idx, diag, symmetric_by_construction: symmetric })
    }

    /// The number of rows (and columns).
    #[must_use]
    pub fn n(&self) -> usize {
        self.n
    }

    /// The number of stored entries.
    #[must_use]
    pub fn nnz(&self) -> usize {
        self.col_idx.len()
    }

    /// Row pointers: row `i` occupies `row_ptr()[i]..row_ptr()[i + 1]` of the column indices
    /// and values.
    #[must_use]
    pub fn row_ptr(&self) -> &[usize] {
        &self.row_ptr
    }

    /// Column indices of all entries, row by row, increasing within a row.
    #[must_use]
    pub fn col_idx(&self) -> &[u32] {
        &self.col_idx
    }

    /// The columns of row `i`.
    ///
    /// # Panics
    /// If `i >= n`.
    #[must_use]
    pub fn row(&self, i: usize) -> &[u32] {
        &self.col_idx[self.row_ptr[i]..self.row_ptr[i + 1]]
    }

    /// The index (into the values of a matrix on this pattern) of entry `(row, col)`, or `None`
    /// if the pattern does not hold it or an index is out of range. Binary search in the row.
    #[must_use]
    pub fn position(&self, row: usize, col: usize) -> Option<usize> {
        if row >= self.n || col >= self.n {
            return None;
        }
        self.row(row).binary_search(&(col as u32)).ok().map(|k| self.row_ptr[row] + k)
    }

    /// For every row, the index of its diagonal entry.
    #[must_use]
    pub fn diagonal_positions(&self) -> &[usize] {
        &self.diag
    }

    /// Whether `(j, i)` is stored for every stored `(i, j)`.
    #[must_use]
    pub fn is_structurally_symmetric(&self) -> bool {
        self.symmetric_by_construction
            || (0..self.n).into_par_iter().all(|i| self.row(i).iter().all(|&j| self.position(j as usize, i).is_some()))
    }

    /// For every stored entry `k = (i, j)`, the position of `(j, i)` (`k` itself on the
    /// diagonal), `usize::MAX` where the mirror is not stored: what [`Self::position`]`(j, i)`
    /// gives, in one merge-like pass over the rows instead of a search per entry. (Rows are
    /// visited in increasing order, so the lower entries of each row `j` are asked for in
    /// increasing column order and a cursor per row finds them.)
    #[must_use]
    pub fn mirror_positions(&self) -> Vec<usize> {
        let mut mirror = vec![usize::MAX; self.nnz()];
        let mut cursor: Vec<usize> = self.row_ptr[..self.n].to_vec();
        for i in 0..self.n {
            for k in self.row_ptr[i]..self.row_ptr[i + 1] {
                let j = self.col_idx[k] as usize;
                if j == i {
                    mirror[k] = k;
                } else if j > i {
                    let end = self.row_ptr[j + 1];
                    while cursor[j] < end && (self.col_idx[cursor[j]] as usize) < i {
                        cursor[j] += 1;
                    }
                    if cursor[j] < end && self.col_idx[cursor[j]] as usize == i {
                        mirror[k] = cursor[j];
                        mirror[cursor[j]] = k;
                    }
                }
            }
        }
        mirror
    }
}

/// One entry `(row, col, value)` to assemble; duplicates are summed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Triplet<T> {
    /// Row index.
    pub row: u32,
    /// Column index.
    pub col: u32,
    /// Value (`f64` or `[f64; 3]`).
    pub value: T,
}

impl<T> Triplet<T> {
    /// A triplet.
    #[must_use]
    pub fn new(row: u32, col: u32, value: T) -> Self {
        Self { row, col, value }
    }
}

/// A sparse `n × n` matrix: a shared [`CsrPattern`] and one value per stored entry.
///
/// `T` is `f64` (one channel; the default) or `[f64; 3]` (three channels, see [`CsrMatrix3`]).
#[derive(Debug, Clone, PartialEq)]
pub struct CsrMatrix<T = f64> {
    pattern: Arc<CsrPattern>,
    values: Vec<T>,
}

/// Three matrices (R, G, B) on one pattern, values interleaved per entry.
pub type CsrMatrix3 = CsrMatrix<[f64; 3]>;

/// Stable-scatters triplet indices by row; validates indices. Returns `(row_start, order)`.
fn scatter_by_row<T>(n: usize, triplets: &[Triplet<T>]) -> Result<(Vec<usize>, Vec<u32>), SparseError> {
    if u32::try_from(triplets.len()).is_err() {
        return Err(SparseError::TooLarge(format!("{} triplets; at most {}", triplets.len(), u32::MAX)));
    }
    let mut counts = vec![0usize; n];
    for (k, t) in triplets.iter().enumerate() {
        for (v, which) in [(t.row, "row"), (t.col, "column")] {
            if v as usize >= n {
                return Err(SparseError::IndexOutOfRange { what: format!("triplet {k} {which}"), index: u64::from(v), n });
            }
        }
        counts[t.row as usize] += 1;
    }
    let start = prefix(&counts);
    let mut cursor: Vec<usize> = start[..n].to_vec();
    let mut order = vec![0u32; triplets.len()];
    for (k, t) in triplets.iter().enumerate() {
        let c = &mut cursor[t.row as usize];
        order[*c] = k as u32;
        *c += 1;
    }
    Ok((start, order))
}

fn check_triplets_finite<T: Entry>(triplets: &[Triplet<T>]) -> Result<(), SparseError> {
    let bad = triplets.par_iter().position_first(|t| (0..T::CHANNELS).any(|c| !t.value.channel(c).is_finite()));
    if let Some(k) = bad {
        let t = &triplets[k];
        let c = (0..T::CHANNELS).find(|&c| !t.value.channel(c).is_finite()).unwrap_or(0);
        return Err(SparseError::NonFinite {
            what: "matrix triplet",
            row: t.row as usize,
            channel: c,
            value: t.value.channel(c),
        });
    }
    Ok(())
}

impl<T: Entry> CsrMatrix<T> {
    /// A matrix with all stored entries zero.
    #[must_use]
    pub fn zeros(pattern: Arc<CsrPattern>) -> Self {
        let values = vec![T::ZERO; pattern.nnz()];
        Self { pattern, values }
    }

    /// Wraps values (one per pattern entry, in pattern order).
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `values.len() != pattern.nnz()`.
    pub fn new(pattern: Arc<CsrPattern>, values: Vec<T>) -> Result<Self, SparseError> {
        if values.len() != pattern.nnz() {
            return Err(SparseError::DimensionMismatch {
                what: "number of values (pattern nnz)",
                expected: pattern.nnz(),
                found: values.len(),
            });
        }
        Ok(Self { pattern, values })
    }

    /// Assembles an `n × n` matrix from triplets, summing duplicates. The pattern is the union
    /// of the triplets' positions and the diagonal.
    ///
    /// Deterministic: duplicates are summed in the order they appear in `triplets`, whatever
    /// the number of threads. Rows are processed in parallel.
    ///
    /// # Errors
    /// [`SparseError::IndexOutOfRange`] naming the first triplet with an index `≥ n`;
    /// [`SparseError::NonFinite`] for a NaN or infinite value;
    /// [`SparseError::TooLarge`] for `n` or the triplet count beyond 32-bit indices.
    pub fn from_triplets(n: usize, triplets: &[Triplet<T>]) -> Result<Self, SparseError> {
        check_dimension(n)?;
        check_triplets_finite(triplets)?;
        let (start, order) = scatter_by_row(n, triplets)?;
        let blocks: Vec<(Vec<usize>, Vec<u32>, Vec<T>)> = (0..n.div_ceil(ROW_BLOCK))
            .into_par_iter()
            .map(|b| {
                let r0 = b * ROW_BLOCK;
                let r1 = (r0 + ROW_BLOCK).min(n);
                let mut lens = Vec::with_capacity(r1 - r0);
                let mut cols = Vec::new();
                let mut vals = Vec::new();
                let mut scratch: Vec<(u32, u32)> = Vec::new();
                for r in r0..r1 {
                    scratch.clear();
                    scratch.push((r as u32, u32::MAX)); // the diagonal, value zero
                    scratch.extend(order[start[r]..start[r + 1]].iter().map(|&k| (triplets[k as usize].col, k)));
                    scratch.sort_by_key(|e| e.0); // stable: input order among duplicates
                    let before = cols.len();
                    for &(c, k) in &scratch {
                        if cols.len() == before || *cols.last().expect("nonempty") != c {
                            cols.push(c);
                            vals.push(T::ZERO);
                        }
                        if k != u32::MAX {
                            vals.last_mut().expect("pushed").accumulate(triplets[k as usize].value);
                        }
                    }
                    lens.push(cols.len() - before);
                }
                (lens, cols, vals)
            })
            .collect();
        let nnz: usize = blocks.iter().map(|b| b.1.len()).sum();
        let mut row_ptr = Vec::with_capacity(n + 1);
        row_ptr.push(0);
        let mut col_idx = Vec::with_capacity(nnz);
        let mut values = Vec::with_capacity(nnz);
        for (lens, cols, vals) in blocks {
            for l in lens {
                row_ptr.push(row_ptr.last().expect("nonempty") + l);
            }
            col_idx.extend_from_slice(&cols);
            values.extend_from_slice(&vals);
        }
        let pattern = CsrPattern::from_csr(n, row_ptr, col_idx)?;
        Ok(Self { pattern: Arc::new(pattern), values })
    }

    /// Assembles triplets onto a given pattern (entries the triplets miss are zero), summing
    /// duplicates in input order. Rows are processed in parallel; deterministic.
    ///
    /// # Errors
    /// [`SparseError::IndexOutOfRange`], [`SparseError::NonFinite`] as for
    /// [`from_triplets`](Self::from_triplets); [`SparseError::NotInPattern`] naming the first
    /// (by row, then input order) triplet outside the pattern.
    pub fn from_triplets_with_pattern(pattern: Arc<CsrPattern>, triplets: &[Triplet<T>]) -> Result<Self, SparseError> {
        check_triplets_finite(triplets)?;
        let n = pattern.n();
        let (start, order) = scatter_by_row(n, triplets)?;
        let mut values = vec![T::ZERO; pattern.nnz()];
        let blocks = split_row_blocks(&mut values, pattern.row_ptr());
        let p = &*pattern;
        let results: Vec<Result<(), SparseError>> = blocks
            .into_par_iter()
            .enumerate()
            .map(|(b, vals)| {
                let r0 = b * ROW_BLOCK;
                let r1 = (r0 + ROW_BLOCK).min(n);
                let off = p.row_ptr[r0];
                for r in r0..r1 {
                    let cols = p.row(r);
                    let base = p.row_ptr[r] - off;
                    for &k in &order[start[r]..start[r + 1]] {
                        let t = &triplets[k as usize];
                        match cols.binary_search(&t.col) {
                            Ok(q) => vals[base + q].accumulate(t.value),
                            Err(_) => return Err(SparseError::NotInPattern { row: r, col: t.col as usize }),
                        }
                    }
                }
                Ok(())
            })
            .collect();
        results.into_iter().collect::<Result<(), _>>()?;
        Ok(Self { pattern, values })
    }

    /// The pattern (shared).
    #[must_use]
    pub fn pattern(&self) -> &Arc<CsrPattern> {
        &self.pattern
    }

    /// The number of rows.
    #[must_use]
    pub fn n(&self) -> usize {
        self.pattern.n
    }

    /// The number of stored entries.
    #[must_use]
    pub fn nnz(&self) -> usize {
        self.values.len()
    }

    /// All values, in pattern order.
    #[must_use]
    pub fn values(&self) -> &[T] {
        &self.values
    }

    /// All values, mutable (the pattern stays fixed): for in-place reassembly and row edits.
    #[must_use]
    pub fn values_mut(&mut self) -> &mut [T] {
        &mut self.values
    }

    /// Takes the values out.
    #[must_use]
    pub fn into_values(self) -> Vec<T> {
        self.values
    }

    /// The entry `(row, col)`: `None` if it is not stored.
    #[must_use]
    pub fn get(&self, row: usize, col: usize) -> Option<T> {
        self.pattern.position(row, col).map(|k| self.values[k])
    }

    /// Adds `value` to the stored entry `(row, col)`.
    ///
    /// # Errors
    /// [`SparseError::NotInPattern`] if the pattern does not hold `(row, col)`.
    pub fn add_to(&mut self, row: usize, col: usize, value: T) -> Result<(), SparseError> {
        let k = self.pattern.position(row, col).ok_or(SparseError::NotInPattern { row, col })?;
        self.values[k].accumulate(value);
        Ok(())
    }

    /// The diagonal entries, one per row.
    #[must_use]
    pub fn diagonal(&self) -> Vec<T> {
        self.pattern.diag.iter().map(|&k| self.values[k]).collect()
    }

    /// Checks that every value is finite.
    ///
    /// # Errors
    /// [`SparseError::NonFinite`] naming the row and channel of the first bad entry.
    pub fn check_finite(&self) -> Result<(), SparseError> {
        let bad = self
            .values
            .par_chunks(CHUNK * 8)
            .position_first(|c| c.iter().any(|v| (0..T::CHANNELS).any(|ch| !v.channel(ch).is_finite())));
        let Some(b) = bad else { return Ok(()) };
        let k0 = b * CHUNK * 8;
        for (k, v) in self.values.iter().enumerate().skip(k0) {
            if let Some(ch) = (0..T::CHANNELS).find(|&ch| !v.channel(ch).is_finite()) {
                let row = self.pattern.row_ptr.partition_point(|&p| p <= k) - 1;
                return Err(SparseError::NonFinite { what: "matrix", row, channel: ch, value: v.channel(ch) });
            }
        }
        Ok(())
    }

    /// Whether every channel is symmetric up to a relative tolerance: for every stored `(i, j)`,
    /// `|a_ij − a_ji| ≤ tol · max(|a_ij|, |a_ji|)`, a missing mirror entry counting as zero.
    /// `tol = 0` asks for exact symmetry.
    #[must_use]
    pub fn is_symmetric(&self, tol: f64) -> bool {
        let p = &*self.pattern;
        (0..p.n).into_par_iter().all(|i| {
            let r = p.row_ptr[i];
            p.row(i).iter().enumerate().all(|(q, &j)| {
                let j = j as usize;
                if j == i {
                    return true;
                }
                let a = self.values[r + q];
                let b = p.position(j, i).map_or(T::ZERO, |k| self.values[k]);
                (0..T::CHANNELS).all(|c| {
                    let (x, y) = (a.channel(c), b.channel(c));
                    (x - y).abs() <= tol * x.abs().max(y.abs())
                })
            })
        })
    }

    /// Channel `channel` as a dense matrix (for tests and small systems).
    ///
    /// # Panics
    /// If `channel >= T::CHANNELS`.
    #[must_use]
    pub fn to_dense(&self, channel: usize) -> DMatrix<f64> {
        assert!(channel < T::CHANNELS, "channel {channel} out of range");
        let n = self.n();
        let mut m = DMatrix::zeros(n, n);
        for i in 0..n {
            for k in self.pattern.row_ptr[i]..self.pattern.row_ptr[i + 1] {
                m[(i, self.pattern.col_idx[k] as usize)] = self.values[k].channel(channel);
            }
        }
        m
    }
}

fn check_len(what: &'static str, expected: usize, found: usize) -> Result<(), SparseError> {
    if expected == found {
        Ok(())
    } else {
        Err(SparseError::DimensionMismatch { what, expected, found })
    }
}

impl CsrMatrix<[f64; 3]> {
    /// `y = A x` for the three channels at once: the pattern is streamed once, each channel
    /// uses its own values. Parallel over row blocks; every `y_i` is summed in column order, so
    /// the result does not depend on the thread count.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `x` or `y` is not `n` long.
    pub fn spmv(&self, x: &[[f64; 3]], y: &mut [[f64; 3]]) -> Result<(), SparseError> {
        check_len("x length", self.n(), x.len())?;
        check_len("y length", self.n(), y.len())?;
        spmv3(&self.pattern, &self.values, x, y);
        Ok(())
    }

    /// `A x` into a new vector. See [`spmv`](Self::spmv).
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `x` is not `n` long.
    pub fn mul_vec(&self, x: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, SparseError> {
        let mut y = vec![[0.0; 3]; self.n()];
        self.spmv(x, &mut y)?;
        Ok(y)
    }

    /// One channel as a single-channel matrix sharing this pattern.
    ///
    /// # Panics
    /// If `channel > 2`.
    #[must_use]
    pub fn channel(&self, channel: usize) -> CsrMatrix<f64> {
        CsrMatrix { pattern: Arc::clone(&self.pattern), values: self.values.iter().map(|v| v[channel]).collect() }
    }

    /// Interleaves three single-channel matrices into one three-channel matrix. They must share
    /// one pattern (the same `Arc`, or equal patterns).
    ///
    /// # Errors
    /// [`SparseError::PatternMismatch`] if the patterns differ.
    pub fn from_channels(r: &CsrMatrix<f64>, g: &CsrMatrix<f64>, b: &CsrMatrix<f64>) -> Result<Self, SparseError> {
        for (name, m) in [("G", g), ("B", b)] {
            if !Arc::ptr_eq(&r.pattern, &m.pattern) && *r.pattern != *m.pattern {
                return Err(SparseError::PatternMismatch(format!("channel {name} differs from channel R")));
            }
        }
        let values = r.values.iter().zip(&g.values).zip(&b.values).map(|((&r, &g), &b)| [r, g, b]).collect();
        Ok(Self { pattern: Arc::clone(&r.pattern), values })
    }
}

impl CsrMatrix<f64> {
    /// `y = A x`, parallel over row blocks, deterministic.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `x` or `y` is not `n` long.
    pub fn spmv(&self, x: &[f64], y: &mut [f64]) -> Result<(), SparseError> {
        check_len("x length", self.n(), x.len())?;
        check_len("y length", self.n(), y.len())?;
        let p = &*self.pattern;
        y.par_chunks_mut(CHUNK).enumerate().for_each(|(ci, yc)| {
            let r0 = ci * CHUNK;
            for (li, yi) in yc.iter_mut().enumerate() {
                let (s, e) = (p.row_ptr[r0 + li], p.row_ptr[r0 + li + 1]);
                let mut acc = 0.0;
                for (&j, &v) in p.col_idx[s..e].iter().zip(&self.values[s..e]) {
                    acc += v * x[j as usize];
                }
                *yi = acc;
            }
        });
        Ok(())
    }

    /// `A x` into a new vector.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `x` is not `n` long.
    pub fn mul_vec(&self, x: &[f64]) -> Result<Vec<f64>, SparseError> {
        let mut y = vec![0.0; self.n()];
        self.spmv(x, &mut y)?;
        Ok(y)
    }
}

/// The three-channel SpMV kernel on raw parts (lengths already checked).
pub(crate) fn spmv3<E: super::ops::Load3>(p: &CsrPattern, values: &[E], x: &[[f64; 3]], y: &mut [[f64; 3]]) {
    y.par_chunks_mut(CHUNK).enumerate().for_each(|(ci, yc)| {
        let r0 = ci * CHUNK;
        let rp = &p.row_ptr[r0..=r0 + yc.len()];
        for (li, yi) in yc.iter_mut().enumerate() {
            let (s, e) = (rp[li], rp[li + 1]);
            *yi = row_mul(&p.col_idx[s..e], &values[s..e], x);
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirror_positions_equal_the_searched_positions() {
        // A symmetric pattern (a ring with chords), and one with unmatched entries.
        let n = 40u32;
        let edges: Vec<[u32; 2]> = (0..n).flat_map(|i| [[i, (i + 1) % n], [i, (i * 7 + 3) % n]]).collect();
        let symmetric = CsrPattern::from_edges(n as usize, &edges).unwrap();
        let entries: Vec<[u32; 2]> = (0..n).flat_map(|i| [[i, i], [i, (i * 5 + 1) % n], [(i * 3) % n, i]]).collect();
        let general = CsrPattern::from_entries(n as usize, &entries).unwrap();
        assert!(!general.is_structurally_symmetric());
        for p in [&symmetric, &general] {
            let mirror = p.mirror_positions();
            let mut unmatched = 0;
            for i in 0..p.n() {
                let row = p.row_ptr()[i]..p.row_ptr()[i + 1];
                for (k, &m) in mirror.iter().enumerate().take(row.end).skip(row.start) {
                    let expected = p.position(p.col_idx()[k] as usize, i);
                    assert_eq!(m, expected.unwrap_or(usize::MAX), "entry {k} of row {i}");
                    unmatched += usize::from(expected.is_none());
                }
            }
            assert_eq!(unmatched > 0, !p.is_structurally_symmetric());
        }
    }

    #[test]
    fn pattern_from_edges_is_sorted_symmetric_with_diagonal() {
        let p = CsrPattern::from_edges(4, &[[0, 2], [2, 0], [3, 1], [1, 1], [0, 2]]).unwrap();
        assert_eq!(p.row(0), &[0, 2]);
        assert_eq!(p.row(1), &[1, 3]);
        assert_eq!(p.row(2), &[0, 2]);
        assert_eq!(p.row(3), &[1, 3]);
        assert_eq!(p.nnz(), 8);
        assert!(p.is_structurally_symmetric());
        // from_edges knows its pattern is symmetric; the same arrays through from_csr are
        // searched, and the two patterns are equal.
        let searched = CsrPattern::from_csr(4, p.row_ptr().to_vec(), p.col_idx().to_vec()).unwrap();
        assert!(!searched.symmetric_by_construction);
        assert!(searched.is_structurally_symmetric());
        assert_eq!(searched, p);
        for i in 0..4 {
            assert_eq!(p.col_idx()[p.diagonal_positions()[i]], i as u32);
        }
        assert_eq!(p.position(3, 1), Some(6));
        assert_eq!(p.position(0, 1), None);
        assert_eq!(p.position(9, 1), None);
        let e = CsrPattern::from_edges(3, &[[0, 1], [1, 5]]).unwrap_err();
        assert!(matches!(e, SparseError::IndexOutOfRange { index: 5, n: 3, .. }), "{e}");
        let g = CsrPattern::from_entries(3, &[[0, 2]]).unwrap();
        assert!(!g.is_structurally_symmetric());
        assert_eq!(CsrPattern::from_csr(3, g.row_ptr().to_vec(), g.col_idx().to_vec()).unwrap(), g);
        // from_csr checks its invariants.
        let bad = |rp: Vec<usize>, ci: Vec<u32>| CsrPattern::from_csr(2, rp, ci).unwrap_err();
        assert!(matches!(bad(vec![0, 1], vec![0]), SparseError::DimensionMismatch { .. }));
        assert!(matches!(bad(vec![0, 1, 2], vec![0, 0]), SparseError::InvalidOption(_))); // no diagonal in row 1
        assert!(matches!(bad(vec![0, 2, 3], vec![1, 0, 1]), SparseError::InvalidOption(_))); // unsorted
        assert!(matches!(bad(vec![0, 1, 3], vec![0, 1, 2]), SparseError::IndexOutOfRange { index: 2, .. }));
    }

    #[test]
    fn triplets_sum_duplicates_and_add_diagonal() {
        let t = [
            Triplet::new(0, 1, [1.0, 2.0, 3.0]),
            Triplet::new(1, 0, [1.0, 2.0, 3.0]),
            Triplet::new(0, 1, [0.5, 0.5, 0.5]),
            Triplet::new(1, 1, [4.0, 4.0, 4.0]),
        ];
        let m = CsrMatrix3::from_triplets(3, &t).unwrap();
        assert_eq!(m.get(0, 1), Some([1.5, 2.5, 3.5]));
        assert_eq!(m.get(2, 2), Some([0.0; 3]));
        assert_eq!(m.get(0, 2), None);
        assert!(!m.is_symmetric(0.0));
        assert!(m.is_symmetric(0.5));
        let m2 = CsrMatrix3::from_triplets_with_pattern(Arc::clone(m.pattern()), &t).unwrap();
        assert_eq!(m, m2);
        let bad = CsrMatrix3::from_triplets_with_pattern(Arc::clone(m.pattern()), &[Triplet::new(0, 2, [1.0; 3])]);
        assert!(matches!(bad, Err(SparseError::NotInPattern { row: 0, col: 2 })));
        let nan = CsrMatrix3::from_triplets(3, &[Triplet::new(2, 0, [0.0, f64::NAN, 0.0])]).unwrap_err();
        assert!(matches!(nan, SparseError::NonFinite { row: 2, channel: 1, .. }), "{nan}");
        let y = m.mul_vec(&[[1.0; 3], [2.0; 3], [3.0; 3]]).unwrap();
        assert_eq!(y, vec![[3.0, 5.0, 7.0], [9.0, 10.0, 11.0], [0.0; 3]]);
        let r = m.channel(1);
        assert_eq!(r.mul_vec(&[1.0, 2.0, 3.0]).unwrap(), vec![5.0, 10.0, 0.0]);
        assert_eq!(CsrMatrix3::from_channels(&m.channel(0), &m.channel(1), &m.channel(2)).unwrap(), m);
        assert_eq!(m.to_dense(2)[(0, 1)], 3.5);
    }
}
