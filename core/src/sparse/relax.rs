//! Relaxation sweeps on three-channel systems `A x = b`: weighted Jacobi and coloured
//! Gauss–Seidel, with frozen rows — the smoothers of the polygrid diffusion's coarse-to-fine
//! relaxation (J. Wang et al. 2008, §5.2–5.3), and the CPU twins of the device's
//! (`gpu::GpuRelaxation`, `shaders/relax_jacobi.wgsl`, `shaders/relax_gs.wgsl`).
//!
//! Neither needs a symmetric matrix (the polygrid stencil is not), only a diagonal that is
//! finite and nonzero in the rows that are updated; each converges where its iteration matrix
//! contracts (for instance on a strictly diagonally dominant matrix, or Gauss–Seidel on an SPD
//! one).
//!
//! * [`jacobi_sweep`]: `x' = x + ω D⁻¹ (b − A x)` from `x` into a second vector, every row in
//!   parallel.
//! * [`Colouring`]: rows partitioned into colours such that no stored off-diagonal entry couples
//!   two rows of one colour (on a lattice's 7-point stencil, the parity of `x + y + z`:
//!   red-black); given ([`Colouring::from_colours`], validated) or greedy
//!   ([`Colouring::greedy`], any pattern).
//! * [`coloured_gauss_seidel_sweep`]: Gauss–Seidel colour by colour, in place. The rows of one
//!   colour read only rows of other colours, so they are updated in parallel and the sweep
//!   equals the sequential Gauss–Seidel sweep of the rows ordered by colour, exactly.
//! * [`ColourOrdered`]: the matrix renumbered colour by colour, whose sweep is the same sweep
//!   on vectors in that order, streaming the matrix instead of striding through it: the form for
//!   many sweeps of one matrix.
//!
//! A row whose `active` flag is `false` is *frozen*: it keeps its value, bit for bit, and the
//! other rows read it as fixed (Dirichlet) data.
//!
//! Every sweep returns the number of row updates it made (active rows times passes), the
//! unit of work the polygrid's budget counts. Each row's sum runs in column order, so the result
//! does not depend on the thread count.

use std::sync::Arc;

use rayon::prelude::*;

pub use super::colour_ordered::ColourOrdered;
use super::csr::{CsrMatrix3, CsrPattern};
use super::error::SparseError;
use super::ops::{row_mul, CHUNK};

/// Rows per parallel task within one colour.
const MIN_ROWS_PER_TASK: usize = 256;

/// A partition of the rows of a pattern into colours such that no stored off-diagonal entry
/// `(i, j)` joins two rows of one colour; the rows of each colour are kept in increasing order.
///
/// It remembers the pattern it was checked against; a sweep on a matrix of another pattern checks
/// it again.
#[derive(Debug, Clone, PartialEq)]
pub struct Colouring {
    pattern: Arc<CsrPattern>,
    colour_of: Vec<u32>,
    /// Colour `c` holds `rows[offsets[c]..offsets[c + 1]]`.
    offsets: Vec<usize>,
    rows: Vec<u32>,
}

impl Colouring {
    /// The colouring `colours` (one per row) of `pattern`, checked.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] unless there is one colour per row;
    /// [`SparseError::IndexOutOfRange`] for a colour at or above the number of rows (no
    /// colouring needs more colours than rows); [`SparseError::ColouringConflict`] naming the
    /// first stored entry (by row, then column) that couples two rows of one colour.
    pub fn from_colours(pattern: &Arc<CsrPattern>, colours: Vec<u32>) -> Result<Self, SparseError> {
        let n = pattern.n();
        if colours.len() != n {
            return Err(SparseError::DimensionMismatch { what: "colours (one per row)", expected: n, found: colours.len() });
        }
        if let Some(i) = colours.iter().position(|&c| c as usize >= n) {
            return Err(SparseError::IndexOutOfRange { what: format!("colour of row {i}"), index: u64::from(colours[i]), n });
        }
        check_colours(pattern, &colours)?;
        Ok(Self::grouped(Arc::clone(pattern), colours))
    }

    /// A greedy colouring of any pattern: rows in increasing order, each taking the smallest
    /// colour that none of its neighbours coloured before it has, neighbours being the rows it
    /// couples to in either direction (`(i, j)` or `(j, i)` stored). At most one more colour
    /// than the largest number of neighbours of a row; on the 7-point stencil of a lattice
    /// numbered `x + nx (y + ny z)`, the red-black colouring by the parity of `x + y + z`.
    #[must_use]
    pub fn greedy(pattern: &Arc<CsrPattern>) -> Self {
        let n = pattern.n();
        // The transposed pattern, for the neighbours `j` whose row stores `(j, i)` but whose
        // column `j` row `i` does not store.
        let transpose = (!pattern.is_structurally_symmetric()).then(|| transpose(pattern));
        let mut colour_of = vec![u32::MAX; n];
        // seen[c] == i + 1: a neighbour of row i has colour c.
        let mut seen: Vec<usize> = Vec::new();
        for i in 0..n {
            let mut mark = |j: u32| {
                let c = colour_of[j as usize];
                if c != u32::MAX {
                    let c = c as usize;
                    if c >= seen.len() {
                        seen.resize(c + 1, 0);
                    }
                    seen[c] = i + 1;
                }
            };
            pattern.row(i).iter().copied().for_each(&mut mark);
            if let Some((ptr, rows)) = &transpose {
                rows[ptr[i]..ptr[i + 1]].iter().copied().for_each(&mut mark);
            }
            let c = (0..).find(|&c| seen.get(c).is_none_or(|&s| s != i + 1)).expect("some colour is free");
            colour_of[i] = c as u32;
        }
        Self::grouped(Arc::clone(pattern), colour_of)
    }

    /// Groups the rows by colour (the colours already checked).
    fn grouped(pattern: Arc<CsrPattern>, colour_of: Vec<u32>) -> Self {
        let count = colour_of.iter().map(|&c| c as usize + 1).max().unwrap_or(0);
        let mut offsets = vec![0usize; count + 1];
        for &c in &colour_of {
            offsets[c as usize + 1] += 1;
        }
        for c in 0..count {
            offsets[c + 1] += offsets[c];
        }
        let mut cursor = offsets[..count].to_vec();
        let mut rows = vec![0u32; colour_of.len()];
        for (i, &c) in colour_of.iter().enumerate() {
            rows[cursor[c as usize]] = i as u32;
            cursor[c as usize] += 1;
        }
        Self { pattern, colour_of, offsets, rows }
    }

    /// The number of rows.
    #[must_use]
    pub fn n(&self) -> usize {
        self.colour_of.len()
    }

    /// The number of colours (one more than the largest colour; a colour may hold no row when
    /// the colours were given).
    #[must_use]
    pub fn count(&self) -> usize {
        self.offsets.len() - 1
    }

    /// The colour of every row.
    #[must_use]
    pub fn colours(&self) -> &[u32] {
        &self.colour_of
    }

    /// The colour of row `i`.
    ///
    /// # Panics
    /// If `i >= n`.
    #[must_use]
    pub fn colour_of(&self, i: usize) -> u32 {
        self.colour_of[i]
    }

    /// The rows of colour `c`, increasing.
    ///
    /// # Panics
    /// If `c >= count()`.
    #[must_use]
    pub fn rows(&self, c: usize) -> &[u32] {
        &self.rows[self.offsets[c]..self.offsets[c + 1]]
    }

    /// The pattern the colouring was checked against.
    #[must_use]
    pub fn pattern(&self) -> &Arc<CsrPattern> {
        &self.pattern
    }

    /// Checks that the colouring is valid for `pattern`: immediate for the pattern it was built
    /// on (or an equal one), a pass over the entries otherwise.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if the row counts differ;
    /// [`SparseError::ColouringConflict`] naming the first entry of `pattern` that couples two
    /// rows of one colour.
    pub fn check(&self, pattern: &Arc<CsrPattern>) -> Result<(), SparseError> {
        if pattern.n() != self.n() {
            return Err(SparseError::DimensionMismatch {
                what: "colouring rows (matrix rows)",
                expected: pattern.n(),
                found: self.n(),
            });
        }
        if Arc::ptr_eq(pattern, &self.pattern) || **pattern == *self.pattern {
            return Ok(());
        }
        check_colours(pattern, &self.colour_of)
    }

    /// The colours in which some row is active, in order (all non-empty colours without a
    /// mask), with their active rows: the passes of a sweep.
    pub(crate) fn active_passes(&self, active: Option<&[bool]>) -> Vec<(usize, usize)> {
        (0..self.count())
            .map(|c| (c, self.rows(c).iter().filter(|&&i| active.is_none_or(|a| a[i as usize])).count()))
            .filter(|&(_, count)| count > 0)
            .collect()
    }
}

/// The first stored entry `(i, j)`, `i ≠ j`, with `colours[i] == colours[j]`, as an error.
fn check_colours(pattern: &CsrPattern, colours: &[u32]) -> Result<(), SparseError> {
    let conflict = (0..pattern.n()).into_par_iter().with_min_len(MIN_ROWS_PER_TASK).find_map_first(|i| {
        pattern.row(i).iter().find(|&&j| j as usize != i && colours[j as usize] == colours[i]).map(|&j| (i, j as usize))
    });
    match conflict {
        Some((row, col)) => Err(SparseError::ColouringConflict { row, col, colour: colours[row] }),
        None => Ok(()),
    }
}

/// The transposed pattern as `(ptr, rows)`: column `j` is stored in the rows `rows[ptr[j]..ptr[j + 1]]`.
fn transpose(pattern: &CsrPattern) -> (Vec<usize>, Vec<u32>) {
    let n = pattern.n();
    let mut ptr = vec![0usize; n + 1];
    for &j in pattern.col_idx() {
        ptr[j as usize + 1] += 1;
    }
    for j in 0..n {
        ptr[j + 1] += ptr[j];
    }
    let mut cursor = ptr[..n].to_vec();
    let mut rows = vec![0u32; pattern.nnz()];
    for i in 0..n {
        for &j in pattern.row(i) {
            rows[cursor[j as usize]] = i as u32;
            cursor[j as usize] += 1;
        }
    }
    (ptr, rows)
}

pub(super) fn check_len(what: &'static str, expected: usize, found: usize) -> Result<(), SparseError> {
    if expected == found {
        Ok(())
    } else {
        Err(SparseError::DimensionMismatch { what, expected, found })
    }
}

/// Whether a relaxation can divide by the diagonal value `d`.
#[inline]
pub(crate) fn usable_diagonal(d: f64) -> bool {
    d.is_finite() && d != 0.0
}

/// Checks the lengths of `b` and `active` and the diagonal of every active row.
fn check_system(matrix: &CsrMatrix3, b: &[[f64; 3]], active: Option<&[bool]>) -> Result<(), SparseError> {
    let n = matrix.n();
    check_len("right-hand side length", n, b.len())?;
    if let Some(a) = active {
        check_len("active flags (one per row)", n, a.len())?;
    }
    let diag = matrix.pattern().diagonal_positions();
    let values = matrix.values();
    let bad = (0..n).into_par_iter().with_min_len(CHUNK).find_map_first(|i| {
        if active.is_some_and(|a| !a[i]) {
            return None;
        }
        let d = values[diag[i]];
        (0..3).find(|&c| !usable_diagonal(d[c])).map(|c| (i, c, d[c]))
    });
    match bad {
        Some((row, channel, value)) => Err(SparseError::UnusableDiagonal { row, channel, value }),
        None => Ok(()),
    }
}

/// One weighted Jacobi sweep (polygrid diffusion, J. Wang et al. 2008 §5.2, with the damping
/// `ω` of weighted Jacobi): `out = x + ω D⁻¹ (b − A x)` for every channel, `D` the diagonal of
/// `A`, computed per row as `x_i + ω (b_i − (A x)_i) / a_ii` with `(A x)_i` summed in column
/// order. A row with `active[i] == false` is copied: `out[i] = x[i]`. Every row in parallel.
/// `ω = 1` is plain Jacobi; `ω = 2/3` damps the high frequencies of a Laplacian best.
///
/// Returns the number of row updates: the active rows.
///
/// # Errors
/// [`SparseError::DimensionMismatch`] if `b`, `x`, `out` or `active` is not one per row;
/// [`SparseError::InvalidOption`] unless `ω` is finite and positive;
/// [`SparseError::UnusableDiagonal`] naming the first active row whose diagonal is zero or not
/// finite.
pub fn jacobi_sweep(
    matrix: &CsrMatrix3,
    b: &[[f64; 3]],
    x: &[[f64; 3]],
    out: &mut [[f64; 3]],
    omega: f64,
    active: Option<&[bool]>,
) -> Result<usize, SparseError> {
    let n = matrix.n();
    check_len("x length", n, x.len())?;
    check_len("output length", n, out.len())?;
    if !(omega.is_finite() && omega > 0.0) {
        return Err(SparseError::InvalidOption(format!("Jacobi damping ω = {omega} must be finite and positive")));
    }
    check_system(matrix, b, active)?;
    let p = matrix.pattern();
    let (rp, ci, diag) = (p.row_ptr(), p.col_idx(), p.diagonal_positions());
    let values = matrix.values();
    let updates = out
        .par_chunks_mut(CHUNK)
        .enumerate()
        .map(|(k, chunk)| {
            let r0 = k * CHUNK;
            let mut updates = 0;
            for (li, o) in chunk.iter_mut().enumerate() {
                let i = r0 + li;
                if active.is_some_and(|a| !a[i]) {
                    *o = x[i];
                    continue;
                }
                let ax = row_mul(&ci[rp[i]..rp[i + 1]], &values[rp[i]..rp[i + 1]], x);
                let d = values[diag[i]];
                *o = [0, 1, 2].map(|c| x[i][c] + omega * (b[i][c] - ax[c]) / d[c]);
                updates += 1;
            }
            updates
        })
        .sum();
    Ok(updates)
}

/// The Gauss–Seidel value of row `i`: `(b_i − Σ_{j≠i} a_ij x_j) / a_ii` per channel, the sum in
/// column order.
#[inline(always)]
fn gauss_seidel_row(ci: &[u32], values: &[[f64; 3]], i: usize, b: [f64; 3], d: [f64; 3], x: &[[f64; 3]]) -> [f64; 3] {
    let mut acc = [0.0; 3];
    for (&j, a) in ci.iter().zip(values) {
        if j as usize != i {
            let xj = x[j as usize];
            for c in 0..3 {
                acc[c] += a[c] * xj[c];
            }
        }
    }
    [0, 1, 2].map(|c| (b[c] - acc[c]) / d[c])
}

/// One Gauss–Seidel sweep colour by colour (polygrid diffusion, J. Wang et al. 2008 §5.2), in
/// place: for each colour in increasing order, every active row `i` of it becomes
/// `x_i = (b_i − Σ_{j≠i} a_ij x_j) / a_ii` per channel (the sum in column order), reading the
/// values of the colours before it from this sweep. The rows of one colour are uncoupled, so
/// they are updated in parallel, and the result equals the sequential Gauss–Seidel sweep of the
/// rows ordered by colour, bit for bit. With `symmetric`, a backward pass follows over the same
/// colours in decreasing order (symmetric Gauss–Seidel), leaving out the last colour of the
/// forward pass: its rows would be computed again from unchanged neighbours, to the same values.
/// Only colours with an active row count. Frozen rows (`active[i] == false`) keep their value.
/// Works for non-symmetric matrices.
///
/// Returns the number of row updates: the active rows, plus, with `symmetric`, those of the
/// backward pass.
///
/// # Errors
/// [`SparseError::DimensionMismatch`] if `b`, `x`, `active` or the colouring is not one per row;
/// [`SparseError::ColouringConflict`] if the colouring, made for another pattern, couples two
/// rows of one colour in this one; [`SparseError::UnusableDiagonal`] naming the first active
/// row whose diagonal is zero or not finite.
pub fn coloured_gauss_seidel_sweep(
    matrix: &CsrMatrix3,
    b: &[[f64; 3]],
    x: &mut [[f64; 3]],
    colouring: &Colouring,
    active: Option<&[bool]>,
    symmetric: bool,
) -> Result<usize, SparseError> {
    check_len("x length", matrix.n(), x.len())?;
    colouring.check(matrix.pattern())?;
    check_system(matrix, b, active)?;
    let passes = colouring.active_passes(active);
    let mut order: Vec<(usize, usize)> = passes.clone();
    if symmetric {
        order.extend(passes.iter().rev().skip(1));
    }
    let p = matrix.pattern();
    let (rp, ci, diag) = (p.row_ptr(), p.col_idx(), p.diagonal_positions());
    let values = matrix.values();
    let mut new: Vec<[f64; 3]> = Vec::new();
    let mut updates = 0;
    for &(c, count) in &order {
        let rows = colouring.rows(c);
        let xr: &[[f64; 3]] = x;
        rows.par_iter()
            .with_min_len(MIN_ROWS_PER_TASK)
            .map(|&i| {
                let i = i as usize;
                if active.is_some_and(|a| !a[i]) {
                    return xr[i];
                }
                let (s, e) = (rp[i], rp[i + 1]);
                gauss_seidel_row(&ci[s..e], &values[s..e], i, b[i], values[diag[i]], xr)
            })
            .collect_into_vec(&mut new);
        for (&i, v) in rows.iter().zip(&new) {
            x[i as usize] = *v;
        }
        updates += count;
    }
    Ok(updates)
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // per-row and per-channel loops read clearer with indices
mod tests {
    use super::super::fixtures::{diffusion_matrix, hash01, random_vector, Grid};
    use super::super::Triplet;
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// The SPD 7-point diffusion matrix on an `nx³` lattice with a mass term: couplings from 1
    /// to 3 varying along the lattice, per channel `[1, 0.7, 1.3]` of it, mass `[0.3, 0.8, 2]`.
    fn spd(nx: usize) -> CsrMatrix3 {
        let g = Grid::new(nx, nx, nx);
        let coupling = |_, [i, _]: [u32; 2]| {
            let [x, y, z] = g.coords(i);
            let k = 1.0 + 0.5 * ((x + 2 * y + 3 * z) % 5) as f64;
            [k, 0.7 * k, 1.3 * k]
        };
        diffusion_matrix(g.n(), &g.edges(false), coupling, [0.3, 0.8, 2.0])
    }

    /// A non-symmetric, strictly diagonally dominant matrix on the same 7-point pattern: an
    /// upwinded drift makes `a_ij = −w (1 + γ)` for the lower vertex of an edge and `−w (1 − γ)`
    /// for the upper; `a_ii = Σ_j |a_ij| + mass`.
    fn unsymmetric(nx: usize) -> CsrMatrix3 {
        let g = Grid::new(nx, nx, nx);
        let edges = g.edges(false);
        let pattern = Arc::new(CsrPattern::from_edges(g.n(), &edges).unwrap());
        let mut t = Vec::new();
        for (e, &[i, j]) in edges.iter().enumerate() {
            let w = 1.0 + hash01(e as u64);
            let gamma = [0.4, -0.3, 0.6];
            let lo = [0, 1, 2].map(|c| -w * (1.0 + gamma[c]));
            let hi = [0, 1, 2].map(|c| -w * (1.0 - gamma[c]));
            t.extend([
                Triplet::new(i, j, lo),
                Triplet::new(j, i, hi),
                Triplet::new(i, i, lo.map(f64::abs)),
                Triplet::new(j, j, hi.map(f64::abs)),
            ]);
        }
        t.extend((0..g.n() as u32).map(|i| Triplet::new(i, i, [0.5, 0.2, 1.0])));
        CsrMatrix3::from_triplets_with_pattern(pattern, &t).unwrap()
    }

    /// A non-symmetric matrix on an irregular, non-symmetric pattern of `n` rows (up to five
    /// hashed off-diagonal entries per row), strictly diagonally dominant by 20%, diagonal signs
    /// mixed by channel.
    fn irregular(n: usize) -> CsrMatrix3 {
        let mut entries = Vec::new();
        for i in 0..n {
            let k = 1 + (hash01(7 * i as u64) * 5.0) as usize;
            for e in 0..k {
                let j = (hash01(1000 * i as u64 + e as u64 + 3) * n as f64) as u32;
                entries.push([i as u32, j]);
            }
        }
        let pattern = Arc::new(CsrPattern::from_entries(n, &entries).unwrap());
        assert!(!pattern.is_structurally_symmetric());
        let mut t = Vec::new();
        let mut row_sum = vec![[0.0; 3]; n];
        for (e, &[i, j]) in entries.iter().enumerate() {
            if i != j {
                let v = [0, 1, 2].map(|c| hash01(31 * e as u64 + c) - 0.7);
                for c in 0..3 {
                    row_sum[i as usize][c] += v[c].abs();
                }
                t.push(Triplet::new(i, j, v));
            }
        }
        for (i, s) in row_sum.iter().enumerate() {
            // Channel 1's diagonal is negative: relaxation needs only a nonzero one.
            let sign = [1.0, -1.0, 1.0];
            t.push(Triplet::new(i as u32, i as u32, [0, 1, 2].map(|c| sign[c] * (1.2 * s[c] + 0.1))));
        }
        CsrMatrix3::from_triplets_with_pattern(pattern, &t).unwrap()
    }

    /// `A x = b` solved densely (LU), channel by channel.
    fn dense_solve(a: &CsrMatrix3, b: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut x = vec![[0.0; 3]; a.n()];
        for c in 0..3 {
            let rhs = DVector::from_iterator(a.n(), b.iter().map(|v| v[c]));
            let sol = a.to_dense(c).lu().solve(&rhs).expect("nonsingular");
            for (xi, s) in x.iter_mut().zip(sol.iter()) {
                xi[c] = *s;
            }
        }
        x
    }

    /// `max_i |x_i − y_i| / max_i |y_i|` per channel.
    fn rel_max(x: &[[f64; 3]], y: &[[f64; 3]]) -> [f64; 3] {
        [0, 1, 2].map(|c| {
            let num = x.iter().zip(y).map(|(a, b)| (a[c] - b[c]).abs()).fold(0.0, f64::max);
            num / y.iter().map(|b| b[c].abs()).fold(0.0, f64::max)
        })
    }

    fn norm(v: &[[f64; 3]], c: usize) -> f64 {
        v.iter().map(|x| x[c] * x[c]).sum::<f64>().sqrt()
    }

    /// The red-black colouring of an `nx³` lattice: the parity of `x + y + z`.
    fn parity(nx: usize) -> Vec<u32> {
        let g = Grid::new(nx, nx, nx);
        (0..g.n() as u32).map(|i| g.coords(i).iter().sum::<usize>() as u32 % 2).collect()
    }

    /// Relaxes from zero until within `1e-10` (relative, max norm) of the dense solution;
    /// returns the sweeps taken, panicking after `cap`.
    fn sweeps_to_converge(what: &str, a: &CsrMatrix3, mut sweep: impl FnMut(&mut Vec<[f64; 3]>), cap: usize) -> usize {
        let b = random_vector(a.n(), 3);
        let exact = dense_solve(a, &b);
        let mut x = vec![[0.0; 3]; a.n()];
        for k in 1..=cap {
            sweep(&mut x);
            if rel_max(&x, &exact).iter().all(|&e| e < 1e-10) {
                return k;
            }
        }
        panic!("{what}: not within 1e-10 of the dense solution after {cap} sweeps: {:?}", rel_max(&x, &exact));
    }

    #[test]
    fn jacobi_converges_to_the_dense_solution() {
        for (name, a) in [("SPD", spd(6)), ("unsymmetric", unsymmetric(6)), ("irregular", irregular(300))] {
            let b = random_vector(a.n(), 3);
            for omega in [2.0 / 3.0, 1.0] {
                let mut out = vec![[0.0; 3]; a.n()];
                let k = sweeps_to_converge(
                    name,
                    &a,
                    |x| {
                        assert_eq!(jacobi_sweep(&a, &b, x, &mut out, omega, None).unwrap(), a.n());
                        std::mem::swap(x, &mut out);
                    },
                    5000,
                );
                eprintln!("{name}: Jacobi ω = {omega:.3} within 1e-10 after {k} sweeps");
            }
        }
    }

    #[test]
    fn coloured_gauss_seidel_converges_to_the_dense_solution() {
        for (name, a) in [("SPD", spd(6)), ("unsymmetric", unsymmetric(6)), ("irregular", irregular(300))] {
            let b = random_vector(a.n(), 3);
            let mut colourings = vec![("greedy", Colouring::greedy(a.pattern()))];
            if name != "irregular" {
                colourings.push(("red-black", Colouring::from_colours(a.pattern(), parity(6)).unwrap()));
            }
            for (kind, colouring) in &colourings {
                for symmetric in [false, true] {
                    let passes = if symmetric { 2 * colouring.count() - 1 } else { colouring.count() };
                    let k = sweeps_to_converge(
                        name,
                        &a,
                        |x| {
                            let updates = coloured_gauss_seidel_sweep(&a, &b, x, colouring, None, symmetric).unwrap();
                            // Every colour is non-empty; the backward pass leaves the last out.
                            let expected: usize =
                                if symmetric { 2 * a.n() - colouring.rows(colouring.count() - 1).len() } else { a.n() };
                            assert_eq!(updates, expected);
                        },
                        5000,
                    );
                    eprintln!(
                        "{name}: {kind} Gauss–Seidel ({} colours, {passes} passes), symmetric {symmetric}: within 1e-10 after {k} sweeps",
                        colouring.count()
                    );
                }
            }
        }
    }

    #[test]
    fn gauss_seidel_contracts_faster_than_jacobi() {
        // b = 0: x is the error. The observed rate over sweeps 150..200 against the spectral
        // radius of the Jacobi iteration matrix I − D⁻¹A computed densely (the eigenvalues of
        // D^-½ A D^-½, λ ↦ 1 − λ). Red-black ordering of a 7-point stencil is consistently
        // ordered, so Gauss–Seidel's radius is Jacobi's squared (Young).
        let nx = 6;
        let a = spd(nx);
        let n = a.n();
        let zero = vec![[0.0; 3]; n];
        let rb = Colouring::from_colours(a.pattern(), parity(nx)).unwrap();
        let (k0, k1) = (150, 200);
        let rate = |sweep: &mut dyn FnMut(&mut Vec<[f64; 3]>)| {
            let mut x = random_vector(n, 9);
            let mut at_k0 = [0.0; 3];
            for k in 1..=k1 {
                sweep(&mut x);
                if k == k0 {
                    at_k0 = [0, 1, 2].map(|c| norm(&x, c));
                }
            }
            [0, 1, 2].map(|c| (norm(&x, c) / at_k0[c]).powf(1.0 / (k1 - k0) as f64))
        };
        let mut out = zero.clone();
        let jacobi = rate(&mut |x| {
            jacobi_sweep(&a, &zero, x, &mut out, 1.0, None).unwrap();
            std::mem::swap(x, &mut out);
        });
        let gs = rate(&mut |x| {
            coloured_gauss_seidel_sweep(&a, &zero, x, &rb, None, false).unwrap();
        });
        for c in 0..3 {
            let dense = a.to_dense(c);
            let s = DVector::from_iterator(n, (0..n).map(|i| 1.0 / dense[(i, i)].sqrt()));
            let scaled = DMatrix::from_diagonal(&s) * &dense * DMatrix::from_diagonal(&s);
            let rho = scaled.symmetric_eigenvalues().iter().map(|l| (1.0 - l).abs()).fold(0.0, f64::max);
            eprintln!("channel {c}: ρ(Jacobi) {rho:.5}, observed Jacobi {:.5}, Gauss–Seidel {:.5}", jacobi[c], gs[c]);
            assert!((jacobi[c] - rho).abs() < 0.01 * rho, "channel {c}: Jacobi rate {} vs ρ {rho}", jacobi[c]);
            assert!(gs[c] < jacobi[c], "channel {c}");
            assert!((gs[c] - rho * rho).abs() < 0.02 * rho * rho, "channel {c}: Gauss–Seidel rate {} vs ρ² {}", gs[c], rho * rho);
        }
    }

    /// The sequential Gauss–Seidel sweep over the rows of `order`, written out.
    fn sequential(a: &CsrMatrix3, b: &[[f64; 3]], x: &mut [[f64; 3]], order: &[usize]) {
        let d = a.diagonal();
        for &i in order {
            let mut acc = [0.0; 3];
            for j in 0..a.n() {
                if j != i {
                    if let Some(v) = a.get(i, j) {
                        for c in 0..3 {
                            acc[c] += v[c] * x[j][c];
                        }
                    }
                }
            }
            x[i] = [0, 1, 2].map(|c| (b[i][c] - acc[c]) / d[i][c]);
        }
    }

    #[test]
    fn a_red_black_sweep_equals_the_sequential_sweep_bit_for_bit() {
        let nx = 9;
        let colours = parity(nx);
        let red: Vec<usize> = (0..colours.len()).filter(|&i| colours[i] == 0).collect();
        let black: Vec<usize> = (0..colours.len()).filter(|&i| colours[i] == 1).collect();
        for a in [spd(nx), unsymmetric(nx)] {
            let rb = Colouring::from_colours(a.pattern(), colours.clone()).unwrap();
            let b = random_vector(a.n(), 4);
            let x0 = random_vector(a.n(), 5);
            for symmetric in [false, true] {
                let mut x = x0.clone();
                let mut reference = x0.clone();
                for _ in 0..3 {
                    coloured_gauss_seidel_sweep(&a, &b, &mut x, &rb, None, symmetric).unwrap();
                    // Forward red, black; the symmetric sweep's backward pass black, red in
                    // full (the library leaves black out: the same values).
                    let mut order: Vec<usize> = red.iter().chain(&black).copied().collect();
                    if symmetric {
                        order.extend(black.iter().chain(&red));
                    }
                    sequential(&a, &b, &mut reference, &order);
                }
                let bits = |v: &[[f64; 3]]| v.iter().flat_map(|x| x.map(f64::to_bits)).collect::<Vec<_>>();
                assert_eq!(bits(&x), bits(&reference), "symmetric {symmetric}");
                assert_ne!(bits(&x), bits(&x0));
            }
        }
    }

    #[test]
    fn frozen_rows_stay_bit_identical_and_act_as_fixed_values() {
        let nx = 6;
        for a in [spd(nx), unsymmetric(nx)] {
            let n = a.n();
            let b = random_vector(n, 6);
            let exact = dense_solve(&a, &b);
            let active: Vec<bool> = (0..n).map(|i| i % 5 != 2).collect();
            let frozen = active.iter().filter(|&&f| !f).count();
            // Frozen rows hold odd values (−0.0, a subnormal, the exact solution); the others
            // start at zero.
            let start: Vec<[f64; 3]> = (0..n)
                .map(|i| match (active[i], i % 3) {
                    (true, _) => [0.0; 3],
                    (false, 0) => [-0.0, f64::MIN_POSITIVE / 8.0, -1e300],
                    (false, _) => exact[i],
                })
                .collect();
            let bits = |v: &[[f64; 3]], i: usize| v[i].map(f64::to_bits);
            let rb = Colouring::from_colours(a.pattern(), parity(nx)).unwrap();
            let mut x = start.clone();
            let mut out = vec![[7.0; 3]; n];
            assert_eq!(jacobi_sweep(&a, &b, &x, &mut out, 0.8, Some(&active)).unwrap(), n - frozen);
            let updates = coloured_gauss_seidel_sweep(&a, &b, &mut x, &rb, Some(&active), true).unwrap();
            let active_black = rb.rows(1).iter().filter(|&&i| active[i as usize]).count();
            assert_eq!(updates, 2 * (n - frozen) - active_black);
            for i in 0..n {
                if !active[i] {
                    assert_eq!(bits(&out, i), bits(&start, i), "Jacobi row {i}");
                    assert_eq!(bits(&x, i), bits(&start, i), "Gauss–Seidel row {i}");
                } else {
                    assert_ne!(bits(&x, i), bits(&start, i), "row {i} was updated");
                }
            }
            // With the frozen rows at the exact solution, the others converge to it.
            let fixed: Vec<[f64; 3]> = (0..n).map(|i| if active[i] { [0.0; 3] } else { exact[i] }).collect();
            let mut x = fixed.clone();
            for _ in 0..300 {
                coloured_gauss_seidel_sweep(&a, &b, &mut x, &rb, Some(&active), false).unwrap();
            }
            assert!(rel_max(&x, &exact).iter().all(|&e| e < 1e-10), "{:?}", rel_max(&x, &exact));
            let mut y = fixed.clone();
            for _ in 0..600 {
                jacobi_sweep(&a, &b, &y, &mut out, 1.0, Some(&active)).unwrap();
                std::mem::swap(&mut y, &mut out);
            }
            assert!(rel_max(&y, &exact).iter().all(|&e| e < 1e-10), "{:?}", rel_max(&y, &exact));
        }
    }

    #[test]
    fn the_colour_ordered_sweep_is_the_coloured_sweep_bit_for_bit() {
        let bits = |v: &[[f64; 3]]| v.iter().map(|r| r.map(f64::to_bits)).collect::<Vec<_>>();
        for (name, a) in [("SPD", spd(6)), ("unsymmetric", unsymmetric(6)), ("irregular", irregular(3000))] {
            let n = a.n();
            let b = random_vector(n, 5);
            let mut colourings = vec![Colouring::greedy(a.pattern())];
            if name != "irregular" {
                colourings.push(Colouring::from_colours(a.pattern(), parity(6)).unwrap());
            }
            // Every other row of the first third frozen, and one whole colour.
            let mut active: Vec<bool> = (0..n).map(|i| i > n / 3 || i % 2 == 0).collect();
            for colouring in &colourings {
                let ordered = ColourOrdered::new(&a, colouring).unwrap();
                assert_eq!(ordered.n(), n);
                for &i in colouring.rows(colouring.count() - 1) {
                    active[i as usize] = false;
                }
                for (mask, symmetric) in [(false, false), (false, true), (true, false), (true, true)] {
                    let mask = mask.then_some(&active[..]);
                    let mut x = random_vector(n, 9);
                    let mut xo = vec![[0.0; 3]; n];
                    let mut bo = vec![[0.0; 3]; n];
                    let mut ao = vec![false; n];
                    ordered.gather(&x, &mut xo).unwrap();
                    ordered.gather(&b, &mut bo).unwrap();
                    ordered.gather(&active, &mut ao).unwrap();
                    let mask_o = mask.map(|_| &ao[..]);
                    for sweep in 0..3 {
                        let expected = coloured_gauss_seidel_sweep(&a, &b, &mut x, colouring, mask, symmetric).unwrap();
                        assert_eq!(ordered.sweep(&bo, &mut xo, mask_o, symmetric).unwrap(), expected, "{name} sweep {sweep}");
                    }
                    let mut back = vec![[0.0; 3]; n];
                    ordered.scatter(&xo, &mut back).unwrap();
                    assert!(
                        bits(&back) == bits(&x),
                        "{name}, {} colours, mask {}, symmetric {symmetric}",
                        colouring.count(),
                        mask.is_some()
                    );
                }
                // The order keeps the colours' rows in increasing order, and rank inverts it.
                let concatenated: Vec<u32> = (0..colouring.count()).flat_map(|c| colouring.rows(c).to_vec()).collect();
                assert_eq!(ordered.order(), &concatenated[..]);
                assert!(ordered.order().iter().enumerate().all(|(k, &i)| ordered.rank()[i as usize] as usize == k));
            }
        }
    }

    #[test]
    fn the_colour_ordered_sweep_refuses_what_the_coloured_sweep_refuses() {
        let nx = 5;
        let mut a = spd(nx);
        let n = a.n();
        let bad = 17;
        let d = a.pattern().diagonal_positions()[bad];
        a.values_mut()[d][2] = f64::NAN;
        let rb = Colouring::from_colours(a.pattern(), parity(nx)).unwrap();
        let ordered = ColourOrdered::new(&a, &rb).unwrap();
        let b = vec![[1.0; 3]; n];
        let mut x = vec![[0.0; 3]; n];
        let e = ordered.sweep(&b, &mut x, None, false).unwrap_err();
        assert!(matches!(e, SparseError::UnusableDiagonal { row, channel: 2, .. } if row == bad), "{e}");
        let e2 = coloured_gauss_seidel_sweep(&a, &b, &mut x, &rb, None, false).unwrap_err();
        assert_eq!(e.to_string(), e2.to_string());
        // Frozen, the row is only read.
        let mut active = vec![true; n];
        active[bad] = false;
        let mut ao = vec![false; n];
        ordered.gather(&active, &mut ao).unwrap();
        assert_eq!(ordered.sweep(&b, &mut x, Some(&ao), false).unwrap(), n - 1);
        // Lengths are named.
        let e = ordered.sweep(&b[1..], &mut x, None, false).unwrap_err();
        assert!(matches!(e, SparseError::DimensionMismatch { what: "right-hand side length", .. }), "{e}");
        let e = ordered.gather(&b, &mut x[1..]).unwrap_err();
        assert!(matches!(e, SparseError::DimensionMismatch { what: "gathered vector", .. }), "{e}");
        // A colouring of another pattern is refused when the copy is made.
        let lone = Colouring::from_colours(&Arc::new(CsrPattern::from_edges(n, &[]).unwrap()), vec![0; n]).unwrap();
        assert!(matches!(
            ColourOrdered::new(&a, &lone).unwrap_err(),
            SparseError::ColouringConflict { row: 0, col: 1, colour: 0 }
        ));
    }

    #[test]
    fn a_bad_colouring_is_rejected() {
        let nx = 5;
        let a = spd(nx);
        let n = a.n();
        // Row r = (2, 2, 2) recoloured: its first neighbour in row order, r − nx² (z − 1),
        // now shares its colour.
        let r = 2 + nx * (2 + nx * 2);
        let mut colours = parity(nx);
        colours[r] ^= 1;
        let e = Colouring::from_colours(a.pattern(), colours).unwrap_err();
        assert!(
            matches!(e, SparseError::ColouringConflict { row, col, colour } if row == r - nx * nx && col == r && colour == 1),
            "{e}"
        );
        assert!(e.to_string().contains(&format!("rows {} and {r}", r - nx * nx)), "{e}");
        let e = Colouring::from_colours(a.pattern(), vec![0; n - 1]).unwrap_err();
        assert!(matches!(e, SparseError::DimensionMismatch { expected, found, .. } if expected == n && found == n - 1), "{e}");
        let mut big = parity(nx);
        big[7] = n as u32;
        let e = Colouring::from_colours(a.pattern(), big).unwrap_err();
        assert!(matches!(e, SparseError::IndexOutOfRange { index, .. } if index == n as u64), "{e}");
        // A colouring of a diagonal pattern: valid there, not for the 7-point matrix.
        let diagonal = Arc::new(CsrPattern::from_edges(n, &[]).unwrap());
        let lone = Colouring::from_colours(&diagonal, vec![0; n]).unwrap();
        assert_eq!(lone.count(), 1);
        let mut x = vec![[0.0; 3]; n];
        let b = vec![[1.0; 3]; n];
        let e = coloured_gauss_seidel_sweep(&a, &b, &mut x, &lone, None, false).unwrap_err();
        assert!(matches!(e, SparseError::ColouringConflict { row: 0, col: 1, colour: 0 }), "{e}");
        // A colouring made on an equal pattern (another Arc) is accepted.
        let equal = Arc::new(CsrPattern::from_edges(n, &Grid::new(nx, nx, nx).edges(false)).unwrap());
        let rb = Colouring::from_colours(&equal, parity(nx)).unwrap();
        coloured_gauss_seidel_sweep(&a, &b, &mut x, &rb, None, false).unwrap();
    }

    #[test]
    fn greedy_colours_any_pattern_validly() {
        // On the lattice: red-black, two colours.
        let nx = 7;
        let a = spd(nx);
        let g = Colouring::greedy(a.pattern());
        assert_eq!(g.colours(), parity(nx).as_slice());
        assert_eq!(g.count(), 2);
        assert_eq!(g.rows(0).len() + g.rows(1).len(), a.n());
        // On an irregular, non-symmetric pattern: no entry couples a colour in either
        // direction, checked by brute force, and the rows of each colour increase.
        let m = irregular(500);
        let p = m.pattern();
        let g = Colouring::greedy(p);
        let max_degree = (0..p.n())
            .map(|i| (0..p.n()).filter(|&j| j != i && (p.position(i, j).is_some() || p.position(j, i).is_some())).count())
            .max()
            .unwrap();
        assert!(g.count() > 2 && g.count() <= max_degree + 1, "{} colours, degree {max_degree}", g.count());
        for i in 0..p.n() {
            for &j in p.row(i) {
                assert!(j as usize == i || g.colour_of(i) != g.colour_of(j as usize), "({i}, {j})");
            }
        }
        for c in 0..g.count() {
            assert!(g.rows(c).windows(2).all(|w| w[0] < w[1]));
            assert!(g.rows(c).iter().all(|&i| g.colour_of(i as usize) == c as u32));
        }
        assert_eq!(Colouring::from_colours(p, g.colours().to_vec()).unwrap(), g);
    }

    #[test]
    fn errors_name_what_is_wrong() {
        let nx = 4;
        let mut a = spd(nx);
        let n = a.n();
        let b = vec![[1.0; 3]; n];
        let x = vec![[0.0; 3]; n];
        let mut out = vec![[0.0; 3]; n];
        let rb = Colouring::from_colours(a.pattern(), parity(nx)).unwrap();
        let len = |e: SparseError| match e {
            SparseError::DimensionMismatch { what, expected, found } => (what, expected, found),
            other => panic!("{other}"),
        };
        assert_eq!(len(jacobi_sweep(&a, &b[1..], &x, &mut out, 1.0, None).unwrap_err()), ("right-hand side length", n, n - 1));
        assert_eq!(len(jacobi_sweep(&a, &b, &x[1..], &mut out, 1.0, None).unwrap_err()), ("x length", n, n - 1));
        assert_eq!(len(jacobi_sweep(&a, &b, &x, &mut out[1..], 1.0, None).unwrap_err()), ("output length", n, n - 1));
        let short = vec![true; n - 2];
        assert_eq!(
            len(jacobi_sweep(&a, &b, &x, &mut out, 1.0, Some(&short)).unwrap_err()),
            ("active flags (one per row)", n, n - 2)
        );
        let mut y = x.clone();
        assert_eq!(len(coloured_gauss_seidel_sweep(&a, &b, &mut y[1..], &rb, None, false).unwrap_err()), ("x length", n, n - 1));
        for omega in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(jacobi_sweep(&a, &b, &x, &mut out, omega, None), Err(SparseError::InvalidOption(_))));
        }
        // A zero diagonal on channel 1 of row 9, then a NaN on channel 2 of row 3.
        let d9 = a.pattern().diagonal_positions()[9];
        a.values_mut()[d9][1] = 0.0;
        let e = jacobi_sweep(&a, &b, &x, &mut out, 1.0, None).unwrap_err();
        assert!(matches!(e, SparseError::UnusableDiagonal { row: 9, channel: 1, value } if value == 0.0), "{e}");
        assert!(e.to_string().contains("row 9") && e.to_string().contains("channel 1 (G)"), "{e}");
        let e = coloured_gauss_seidel_sweep(&a, &b, &mut y, &rb, None, true).unwrap_err();
        assert!(matches!(e, SparseError::UnusableDiagonal { row: 9, channel: 1, .. }), "{e}");
        let d3 = a.pattern().diagonal_positions()[3];
        a.values_mut()[d3][2] = f64::NAN;
        let e = jacobi_sweep(&a, &b, &x, &mut out, 1.0, None).unwrap_err();
        assert!(matches!(e, SparseError::UnusableDiagonal { row: 3, channel: 2, value } if value.is_nan()), "{e}");
        // Frozen, those rows are not divided by.
        let active: Vec<bool> = (0..n).map(|i| i != 3 && i != 9).collect();
        assert_eq!(jacobi_sweep(&a, &b, &x, &mut out, 1.0, Some(&active)).unwrap(), n - 2);
        coloured_gauss_seidel_sweep(&a, &b, &mut y, &rb, Some(&active), true).unwrap();
        assert!(y.iter().flatten().all(|v| v.is_finite()));
    }
}
