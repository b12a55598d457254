//! A three-channel matrix stored colour by colour, for Gauss–Seidel sweeps that stream it: the
//! CPU form of the polygrid relaxation's sweep (J. Wang et al. 2008 §5.2).
//!
//! [`super::relax::coloured_gauss_seidel_sweep`] visits the rows of one colour where they lie in
//! the matrix. On a lattice's parity colouring those are every other row of every other line,
//! so each colour's pass reads the matrix and the iterate in strides, through most of their
//! cache lines, and writes its values back one by one. A [`ColourOrdered`] renumbers the rows
//! colour by colour once (the colouring's order, increasing within a colour): a colour is then a
//! contiguous range of rows, its pass streams its part of the matrix and writes its range of the
//! iterate in place, and its neighbours lie in the other colours' ranges, in nearly the same
//! order. Vectors are taken in this order ([`ColourOrdered::gather`],
//! [`ColourOrdered::scatter`]); a relaxation gathers once, sweeps many times and scatters once.
//!
//! The sweep is the same sweep, bit for bit: the rows of each colour in increasing order of
//! the matrix's numbering, each row's sum over its off-diagonal entries in the matrix's column
//! order, frozen rows kept. Only the storage differs, and the copy costs the matrix's memory
//! again.

use rayon::prelude::*;

use super::csr::{split_row_blocks, CsrMatrix3, ROW_BLOCK};
use super::error::SparseError;
use super::relax::{check_len, usable_diagonal, Colouring};

/// Rows per parallel task within one colour.
const ROWS_PER_TASK: usize = 512;

/// A matrix renumbered colour by colour for [`ColourOrdered::sweep`]: see the module
/// documentation. Positions are the rows in the new order; position `k` holds matrix row
/// `order()[k]`.
#[derive(Debug, Clone)]
pub struct ColourOrdered {
    /// Position `k` holds matrix row `order[k]`.
    order: Vec<u32>,
    /// The position of every matrix row.
    rank: Vec<u32>,
    /// Colour `c` occupies positions `offsets[c]..offsets[c + 1]`.
    offsets: Vec<usize>,
    /// Position `k`'s off-diagonal entries are `cols[ptr[k]..ptr[k + 1]]` (positions) and the
    /// same range of `values`, in the matrix's column order.
    ptr: Vec<usize>,
    cols: Vec<u32>,
    values: Vec<[f64; 3]>,
    /// The diagonal entry of every position.
    diagonal: Vec<[f64; 3]>,
    /// The matrix rows whose diagonal is zero or not finite (row, channel, value), increasing:
    /// a sweep refuses them unless they are frozen.
    unusable: Vec<(usize, usize, f64)>,
}

impl ColourOrdered {
    /// `matrix` renumbered by `colouring`.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] or [`SparseError::ColouringConflict`] if `colouring`
    /// does not fit the matrix's pattern ([`Colouring::check`]).
    pub fn new(matrix: &CsrMatrix3, colouring: &Colouring) -> Result<Self, SparseError> {
        colouring.check(matrix.pattern())?;
        let n = matrix.n();
        let order: Vec<u32> = (0..colouring.count()).flat_map(|c| colouring.rows(c).iter().copied()).collect();
        let mut offsets = Vec::with_capacity(colouring.count() + 1);
        offsets.push(0);
        for c in 0..colouring.count() {
            offsets.push(offsets[c] + colouring.rows(c).len());
        }
        let mut rank = vec![0u32; n];
        for (k, &i) in order.iter().enumerate() {
            rank[i as usize] = k as u32;
        }
        let p = matrix.pattern();
        let (rp, ci, diag) = (p.row_ptr(), p.col_idx(), p.diagonal_positions());
        let all = matrix.values();
        // Every row stores its diagonal, so a position has its row's length less one entries.
        let mut ptr = Vec::with_capacity(n + 1);
        ptr.push(0);
        for &i in &order {
            let i = i as usize;
            ptr.push(ptr.last().expect("the first offset") + rp[i + 1] - rp[i] - 1);
        }
        let nnz = *ptr.last().expect("the total");
        let mut cols = vec![0u32; nnz];
        let mut values = vec![[0.0; 3]; nnz];
        split_row_blocks(&mut cols, &ptr).into_par_iter().zip(split_row_blocks(&mut values, &ptr)).enumerate().for_each(
            |(block, (cols, values))| {
                let rows = &order[block * ROW_BLOCK..((block + 1) * ROW_BLOCK).min(n)];
                let entries = rows.iter().flat_map(|&i| {
                    let i = i as usize;
                    (rp[i]..rp[i + 1]).filter(move |&e| ci[e] as usize != i)
                });
                for ((col, value), e) in cols.iter_mut().zip(values.iter_mut()).zip(entries) {
                    *col = rank[ci[e] as usize];
                    *value = all[e];
                }
            },
        );
        let diagonal: Vec<[f64; 3]> = order.par_iter().map(|&i| all[diag[i as usize]]).collect();
        let unusable = (0..n)
            .flat_map(|i| {
                let d = all[diag[i]];
                (0..3).filter(move |&c| !usable_diagonal(d[c])).map(move |c| (i, c, d[c]))
            })
            .collect();
        Ok(Self { order, rank, offsets, ptr, cols, values, diagonal, unusable })
    }

    /// The number of rows.
    #[must_use]
    pub fn n(&self) -> usize {
        self.order.len()
    }

    /// The matrix row at every position.
    #[must_use]
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// The position of every matrix row.
    #[must_use]
    pub fn rank(&self) -> &[u32] {
        &self.rank
    }

    /// `out[k] = natural[order[k]]`: a vector in the matrix's row order taken into this order.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] unless both have one entry per row.
    pub fn gather<T: Copy + Send + Sync>(&self, natural: &[T], out: &mut [T]) -> Result<(), SparseError> {
        check_len("vector to gather", self.n(), natural.len())?;
        check_len("gathered vector", self.n(), out.len())?;
        out.par_iter_mut().zip(&self.order).for_each(|(o, &i)| *o = natural[i as usize]);
        Ok(())
    }

    /// `out[order[k]] = ordered[k]`: the inverse of [`ColourOrdered::gather`].
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] unless both have one entry per row.
    pub fn scatter<T: Copy + Send + Sync>(&self, ordered: &[T], out: &mut [T]) -> Result<(), SparseError> {
        check_len("vector to scatter", self.n(), ordered.len())?;
        check_len("scattered vector", self.n(), out.len())?;
        out.par_iter_mut().zip(&self.rank).for_each(|(o, &k)| *o = ordered[k as usize]);
        Ok(())
    }

    /// One Gauss–Seidel sweep colour by colour, in place, on vectors in this order: exactly
    /// [`super::relax::coloured_gauss_seidel_sweep`] of the matrix and colouring this was made
    /// from, on the gathered `b`, `x` and `active` (see there for `symmetric`, frozen rows and
    /// the count returned).
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `b`, `x` or `active` is not one per row;
    /// [`SparseError::UnusableDiagonal`] naming the first active matrix row whose diagonal is
    /// zero or not finite.
    pub fn sweep(
        &self,
        b: &[[f64; 3]],
        x: &mut [[f64; 3]],
        active: Option<&[bool]>,
        symmetric: bool,
    ) -> Result<usize, SparseError> {
        let n = self.n();
        check_len("right-hand side length", n, b.len())?;
        check_len("x length", n, x.len())?;
        if let Some(a) = active {
            check_len("active flags (one per row)", n, a.len())?;
        }
        let is_active = |k: usize| active.is_none_or(|a| a[k]);
        if let Some(&(row, channel, value)) = self.unusable.iter().find(|&&(row, ..)| is_active(self.rank[row] as usize)) {
            return Err(SparseError::UnusableDiagonal { row, channel, value });
        }
        let passes: Vec<(usize, usize)> = (0..self.offsets.len() - 1)
            .map(|c| {
                let range = self.offsets[c]..self.offsets[c + 1];
                (c, active.map_or(range.len(), |a| a[range].iter().filter(|&&f| f).count()))
            })
            .filter(|&(_, count)| count > 0)
            .collect();
        let mut order = passes.clone();
        if symmetric {
            order.extend(passes.iter().rev().skip(1));
        }
        let mut updates = 0;
        for &(c, count) in &order {
            let (lo, hi) = (self.offsets[c], self.offsets[c + 1]);
            let (head, rest) = x.split_at_mut(lo);
            let (mine, tail) = rest.split_at_mut(hi - lo);
            let (head, tail): (&[[f64; 3]], &[[f64; 3]]) = (head, tail);
            mine.par_chunks_mut(ROWS_PER_TASK).enumerate().for_each(|(chunk, out)| {
                let k0 = lo + chunk * ROWS_PER_TASK;
                for (k, xk) in (k0..).zip(out.iter_mut()) {
                    if !is_active(k) {
                        continue;
                    }
                    let mut acc = [0.0; 3];
                    for (&j, a) in self.cols[self.ptr[k]..self.ptr[k + 1]].iter().zip(&self.values[self.ptr[k]..self.ptr[k + 1]])
                    {
                        let j = j as usize;
                        // The colouring keeps a colour's own rows out of its rows' entries.
                        let xj = if j < lo { head[j] } else { tail[j - hi] };
                        for ch in 0..3 {
                            acc[ch] += a[ch] * xj[ch];
                        }
                    }
                    let (bk, d) = (b[k], self.diagonal[k]);
                    *xk = std::array::from_fn(|ch| (bk[ch] - acc[ch]) / d[ch]);
                }
            });
            updates += count;
        }
        Ok(updates)
    }
}
