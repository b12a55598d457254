//! The SSOR preconditioner, swept in parallel over the parts and separators of a level-set
//! ordering.
//!
//! On the Jacobi-scaled matrix `Â = S A S` (`S = D^-½`, unit diagonal), split as
//! `Â = L + I + U` (`U = Lᵀ`), symmetric successive over-relaxation with factor `ω ∈ (0, 2)`
//! is `M = (D̃ + L) D̃⁻¹ (D̃ + U) / (ω (2 − ω))`, `D̃ = I/ω`: SPD for SPD `A`. Its triangles are
//! swept in the [`sweep_ordering`] of the matrix's graph, so that a forward sweep is a parallel
//! pass over the parts followed by a parallel pass over the separators, and equals the
//! sequential sweep of that ordering exactly (the result does not depend on the thread count).
//!
//! [`pcg`](super::pcg) applies it with Eisenstat's trick (`eisenstat_cg.rs`) in mixed precision
//! and as `z = M⁻¹ r` ([`Preconditioner::apply`](super::Preconditioner::apply)) in `f64`.
//!
//! # Cost
//!
//! SSOR takes far fewer CG iterations than Jacobi, but an iteration costs about two Jacobi
//! iterations, not one: a sweep waits on the row just computed (each row takes the column
//! nearest the diagonal last, so its other products run while that one is awaited), and the
//! setup (the ordering, the reordered triangles and their values) costs more than Jacobi's.
//! The ordering is what makes SSOR effective: in a mesher's vertex numbering, which scatters
//! neighbours across the matrix, SSOR needs many more iterations, and block-Jacobi SSOR on row
//! blocks of it no fewer than Jacobi. The separators between the parts cost few iterations.
//! So SSOR is not the default ([`super::PreconditionerKind::Jacobi`] is); it serves where one
//! matrix is solved repeatedly, and the diffusion solver uses it for bakes and for the
//! editor's paints and cuts, where its setup is far shorter than the multigrid's.

use std::ops::Range;
use std::sync::Arc;

use rayon::prelude::*;

use super::csr::{CsrMatrix3, CsrPattern};
use super::error::SparseError;
use super::ops::sum_partials;
use super::ordering::sweep_ordering;
use super::precond::inverse_diagonal;

/// One strict triangle of the reordered, scaled matrix, rows in the new numbering.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Triangle {
    ptr: Vec<usize>,
    col: Vec<u32>,
    val: Vec<[f64; 3]>,
    /// For each value of the lower triangle, the position in the original matrix of the entry
    /// it is rounded from; of the upper triangle, the position of the lower entry it mirrors.
    src: Vec<usize>,
}

impl Triangle {
    #[inline(always)]
    pub(super) fn row(&self, i: usize) -> (&[u32], &[[f64; 3]]) {
        let (s, e) = (self.ptr[i], self.ptr[i + 1]);
        (&self.col[s..e], &self.val[s..e])
    }
}

/// The SSOR preconditioner of one matrix (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct Ssor {
    pattern: Arc<CsrPattern>,
    pub(super) omega: f64,
    /// New row `i` is original row `perm[i]`; `inv` is the inverse permutation.
    pub(super) perm: Vec<u32>,
    pub(super) inv: Vec<u32>,
    parts: Vec<Range<usize>>,
    separators: Vec<Range<usize>>,
    pub(super) lower: Triangle,
    pub(super) upper: Triangle,
    /// `S = D^-½` per new row.
    pub(super) s: Vec<[f64; 3]>,
}

/// `a ⊙ b`, channel by channel.
#[inline(always)]
pub(super) fn mul3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] * b[0], a[1] * b[1], a[2] * b[2]]
}

/// Splits the consecutive `ranges` (starting at `offset` within `v`) into mutable slices.
fn split_ranges<'a, T>(mut v: &'a mut [T], ranges: &[Range<usize>], offset: usize) -> Vec<&'a mut [T]> {
    let mut out = Vec::with_capacity(ranges.len());
    let mut at = offset;
    for r in ranges {
        debug_assert_eq!(r.start, at);
        let (head, tail) = std::mem::take(&mut v).split_at_mut(r.len());
        out.push(head);
        v = tail;
        at = r.end;
    }
    out
}

impl Ssor {
    /// Over-relaxation factor of [`Self::new`], chosen on the iteration counts of diffusion
    /// systems (they vary little around it).
    pub const DEFAULT_OMEGA: f64 = 1.5;

    /// Parts the sweeps are cut into (fixed, so results do not depend on the thread count):
    /// enough parallelism for a desktop's cores, while each separator costs the sweeps only a
    /// little of their coupling.
    pub const PARTS: usize = 8;

    /// Builds SSOR with [`Self::DEFAULT_OMEGA`] for `a` (symmetric, positive diagonal).
    ///
    /// # Errors
    /// As [`Self::with_omega`].
    pub fn new(a: &CsrMatrix3) -> Result<Self, SparseError> {
        Self::with_omega(a, Self::DEFAULT_OMEGA)
    }

    /// Builds SSOR with over-relaxation `omega` for `a`: the sweep ordering of its pattern and
    /// the scaled triangles.
    ///
    /// # Errors
    /// [`SparseError::InvalidOption`] for `omega` outside (0, 2) or a pattern that is not
    /// structurally symmetric; [`SparseError::NonPositiveDiagonal`] for a diagonal entry that is
    /// not positive.
    pub fn with_omega(a: &CsrMatrix3, omega: f64) -> Result<Self, SparseError> {
        if !(omega > 0.0 && omega < 2.0) {
            return Err(SparseError::InvalidOption(format!("SSOR over-relaxation ω = {omega} must lie in (0, 2)")));
        }
        let p = a.pattern();
        if !p.is_structurally_symmetric() {
            return Err(SparseError::InvalidOption("SSOR needs a structurally symmetric matrix".into()));
        }
        let inv_diag = inverse_diagonal(a)?;
        let n = a.n();
        let o = sweep_ordering(p, Self::PARTS);
        let mut inv = vec![0u32; n];
        for (k, &i) in o.perm.iter().enumerate() {
            inv[i as usize] = k as u32;
        }
        let (lower, upper) = triangles(p, &o.perm, &inv);
        let mut m = Self {
            pattern: Arc::clone(p),
            omega,
            perm: o.perm,
            inv,
            parts: o.parts,
            separators: o.separators,
            lower,
            upper,
            s: Vec::new(),
        };
        m.fill(a, &inv_diag);
        Ok(m)
    }

    /// Follows new values of the matrix (same pattern): rescales and rounds the triangles again,
    /// keeping the ordering. On error `self` is unchanged.
    ///
    /// # Errors
    /// [`SparseError::PatternMismatch`] for another pattern; [`SparseError::NonPositiveDiagonal`]
    /// for a diagonal entry that is not positive.
    pub fn refresh(&mut self, a: &CsrMatrix3) -> Result<(), SparseError> {
        if !(Arc::ptr_eq(&self.pattern, a.pattern()) || *self.pattern == **a.pattern()) {
            return Err(SparseError::PatternMismatch("SSOR refresh: the matrix has another pattern".into()));
        }
        let inv_diag = inverse_diagonal(a)?;
        self.fill(a, &inv_diag);
        Ok(())
    }

    /// The over-relaxation factor.
    #[must_use]
    pub fn omega(&self) -> f64 {
        self.omega
    }

    /// The number of rows.
    #[must_use]
    pub fn n(&self) -> usize {
        self.perm.len()
    }

    /// The number of parts and of separators the sweeps run over.
    #[must_use]
    pub fn parts(&self) -> (usize, usize) {
        (self.parts.len(), self.separators.len())
    }

    pub(crate) fn pattern(&self) -> &Arc<CsrPattern> {
        &self.pattern
    }

    /// Scaling and rounded triangle values from `a` and its (checked) inverse diagonal.
    fn fill(&mut self, a: &CsrMatrix3, inv_diag: &[[f64; 3]]) {
        self.s = self.perm.par_iter().map(|&i| inv_diag[i as usize].map(f64::sqrt)).collect();
        let (s, vals) = (&self.s, a.values());
        let t = &mut self.lower;
        let (ptr, col, src) = (&t.ptr, &t.col, &t.src);
        let blocks = super::csr::split_row_blocks(&mut t.val, ptr);
        blocks.into_par_iter().enumerate().for_each(|(b, out)| {
            let r0 = b * super::csr::ROW_BLOCK;
            let r1 = (r0 + super::csr::ROW_BLOCK).min(ptr.len() - 1);
            let off = ptr[r0];
            for i in r0..r1 {
                let si = s[i];
                for e in ptr[i]..ptr[i + 1] {
                    let (sj, v) = (s[col[e] as usize], vals[src[e]]);
                    #[allow(clippy::cast_possible_truncation)]
                    {
                        out[e - off] = [v[0] * si[0] * sj[0], v[1] * si[1] * sj[1], v[2] * si[2] * sj[2]];
                    }
                }
            }
        });
        let lower = &self.lower.val;
        let upper = &mut self.upper;
        upper.val.par_iter_mut().zip(&upper.src).for_each(|(v, &e)| *v = lower[e]);
    }

    /// `u = (D̃ + L)⁻¹ v` (`v` given per new row), parts then separators in parallel; returns
    /// `Σ_i dot(i, u_i)` per channel, summed in a fixed order.
    pub(super) fn solve_lower(
        &self,
        v: impl Fn(usize) -> [f64; 3] + Sync,
        u: &mut [[f64; 3]],
        dot: impl Fn(usize, [f64; 3]) -> [f64; 3] + Sync,
    ) -> [f64; 3] {
        let split = self.parts.last().map_or(0, |r| r.end);
        let (head, tail) = u.split_at_mut(split);
        let omega = self.omega;
        let sweep = |rows: &Range<usize>, own: &mut [[f64; 3]], done: &[[f64; 3]]| -> [f64; 3] {
            let mut sum = [0.0; 3];
            for i in rows.clone() {
                let (cols, vals) = self.lower.row(i);
                let mut acc = v(i);
                for (&j, w) in cols.iter().zip(vals) {
                    let j = j as usize;
                    let uj = if j >= rows.start { own[j - rows.start] } else { done[j] };
                    for c in 0..3 {
                        acc[c] -= w[c] * uj[c];
                    }
                }
                let ui = [omega * acc[0], omega * acc[1], omega * acc[2]];
                own[i - rows.start] = ui;
                let d = dot(i, ui);
                for c in 0..3 {
                    sum[c] += d[c];
                }
            }
            sum
        };
        let mut sums: Vec<[f64; 3]> = split_ranges(head, &self.parts, 0)
            .into_par_iter()
            .zip(&self.parts)
            .map(|(own, rows)| sweep(rows, own, &[]))
            .collect();
        let done: &[[f64; 3]] = head;
        sums.extend(
            split_ranges(tail, &self.separators, split)
                .into_par_iter()
                .zip(&self.separators)
                .map(|(own, rows)| sweep(rows, own, done))
                .collect::<Vec<_>>(),
        );
        sum_partials(&sums)
    }

    /// `t = (D̃ + U)⁻¹ v` (`v` per new row): separators, then parts, in parallel.
    pub(super) fn solve_upper(&self, v: &[[f64; 3]], t: &mut [[f64; 3]]) {
        let split = self.parts.last().map_or(0, |r| r.end);
        let (head, tail) = t.split_at_mut(split);
        let omega = self.omega;
        let sweep = |rows: &Range<usize>, own: &mut [[f64; 3]], done: &[[f64; 3]]| {
            for i in rows.clone().rev() {
                let (cols, vals) = self.upper.row(i);
                let mut acc = v[i];
                for (&j, w) in cols.iter().zip(vals) {
                    let j = j as usize;
                    let tj = if j < rows.end { own[j - rows.start] } else { done[j - split] };
                    for c in 0..3 {
                        acc[c] -= w[c] * tj[c];
                    }
                }
                own[i - rows.start] = [omega * acc[0], omega * acc[1], omega * acc[2]];
            }
        };
        split_ranges(tail, &self.separators, split)
            .into_par_iter()
            .zip(&self.separators)
            .for_each(|(own, rows)| sweep(rows, own, &[]));
        let done: &[[f64; 3]] = tail;
        split_ranges(head, &self.parts, 0).into_par_iter().zip(&self.parts).for_each(|(own, rows)| sweep(rows, own, done));
    }

    /// `z = M⁻¹ r` in the original numbering; returns `r·z`.
    pub(crate) fn apply_dot(&self, r: &[[f64; 3]], z: &mut [[f64; 3]]) -> [f64; 3] {
        let n = self.n();
        let mut u = vec![[0.0; 3]; n];
        let mut t = vec![[0.0; 3]; n];
        let scale = 2.0 - self.omega;
        self.solve_lower(|i| mul3(self.s[i], r[self.perm[i] as usize]), &mut u, |_, _| [0.0; 3]);
        u.par_iter_mut().for_each(|u| *u = u.map(|x| scale * x));
        self.solve_upper(&u, &mut t);
        z.par_iter_mut().zip(&self.inv).for_each(|(z, &k)| *z = [0, 1, 2].map(|c| self.s[k as usize][c] * t[k as usize][c]));
        super::ops::dot3(r, z)
    }
}

/// The strict lower and upper triangles of `p` renumbered by `perm` (`inv` its inverse), rows
/// and columns in the new numbering. The lower triangle's columns increase and its `src` are
/// positions in the original matrix; the upper triangle is its transpose, columns decreasing
/// (in both, the column nearest the diagonal comes last: in a sweep it is the row computed just
/// before, so the other products can run while it is awaited), its `src` the positions of the
/// lower entries it mirrors, so both triangles hold the same rounded numbers.
fn triangles(p: &CsrPattern, perm: &[u32], inv: &[u32]) -> (Triangle, Triangle) {
    use super::csr::{split_row_blocks, ROW_BLOCK};
    let n = p.n();
    let below = |i: usize| p.row(perm[i] as usize).iter().filter(|&&j| (inv[j as usize] as usize) < i).count();
    let counts: Vec<usize> = (0..n).into_par_iter().map(below).collect();
    let mut ptr = Vec::with_capacity(n + 1);
    ptr.push(0usize);
    for c in &counts {
        ptr.push(ptr.last().expect("non-empty") + c);
    }
    let nnz = ptr[n];
    let mut lower = Triangle { ptr, col: vec![0; nnz], val: vec![[0.0; 3]; nnz], src: vec![0; nnz] };
    {
        let ptr = &lower.ptr;
        let cols = split_row_blocks(&mut lower.col, ptr);
        let srcs = split_row_blocks(&mut lower.src, ptr);
        cols.into_par_iter().zip(srcs).enumerate().for_each(|(b, (col, src))| {
            let r0 = b * ROW_BLOCK;
            let r1 = (r0 + ROW_BLOCK).min(n);
            let off = ptr[r0];
            let mut row: Vec<(u32, usize)> = Vec::new();
            for i in r0..r1 {
                let o = perm[i] as usize;
                let start = p.row_ptr()[o];
                row.clear();
                row.extend(
                    p.row(o).iter().enumerate().map(|(k, &j)| (inv[j as usize], start + k)).filter(|&(jn, _)| (jn as usize) < i),
                );
                row.sort_unstable_by_key(|e| e.0);
                for (e, &(jn, k)) in (ptr[i]..ptr[i + 1]).zip(&row) {
                    col[e - off] = jn;
                    src[e - off] = k;
                }
            }
        });
    }
    let mut uptr = vec![0usize; n + 1];
    for &j in &lower.col {
        uptr[j as usize + 1] += 1;
    }
    for i in 0..n {
        uptr[i + 1] += uptr[i];
    }
    let mut cursor = uptr[..n].to_vec();
    let mut upper = Triangle { ptr: uptr, col: vec![0; nnz], val: vec![[0.0; 3]; nnz], src: vec![0; nnz] };
    for i in (0..n).rev() {
        for e in lower.ptr[i]..lower.ptr[i + 1] {
            let j = lower.col[e] as usize;
            upper.col[cursor[j]] = i as u32;
            upper.src[cursor[j]] = e;
            cursor[j] += 1;
        }
    }
    (lower, upper)
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, DVector};

    use super::*;
    use crate::sparse::fixtures::{grid_matrix, rhs};

    /// `M⁻¹` applied by the parallel sweeps equals the dense SSOR formula in the sweep ordering:
    /// `M = (D̃ + L) D̃⁻¹ (D̃ + U) / (ω (2 − ω))` on `Â = S A S` renumbered.
    #[test]
    fn apply_equals_the_dense_ssor_formula() {
        let a = grid_matrix(7);
        let n = a.n();
        for omega in [1.0, 1.5] {
            let m = Ssor::with_omega(&a, omega).unwrap();
            assert!(m.parts().0 > 1 && m.parts().1 > 0, "{:?}", m.parts());
            for c in 0..3 {
                let ad = a.to_dense(c);
                let s: Vec<f64> = (0..n).map(|i| 1.0 / ad[(i, i)].sqrt()).collect();
                // Â in the new numbering.
                let ah = DMatrix::from_fn(n, n, |i, j| {
                    let (oi, oj) = (m.perm[i] as usize, m.perm[j] as usize);
                    ad[(oi, oj)] * s[oi] * s[oj]
                });
                let dt = DMatrix::from_diagonal_element(n, n, 1.0 / omega);
                let l = DMatrix::from_fn(n, n, |i, j| if j < i { ah[(i, j)] } else { 0.0 });
                let mm =
                    (&dt + &l) * DMatrix::from_diagonal_element(n, n, omega) * (&dt + l.transpose()) / (omega * (2.0 - omega));
                let r = rhs(n);
                let mut z = vec![[0.0; 3]; n];
                m.apply_dot(&r, &mut z);
                // z = S Πᵀ M̂⁻¹ Π S r.
                let rh = DVector::from_fn(n, |i, _| s[m.perm[i] as usize] * r[m.perm[i] as usize][c]);
                let zh = mm.clone().lu().solve(&rh).unwrap();
                for i in 0..n {
                    let o = m.perm[i] as usize;
                    let want = s[o] * zh[i];
                    assert!(
                        (z[o][c] - want).abs() <= 1e-5 * (1.0 + want.abs()),
                        "ω {omega} channel {c} row {o}: {} vs {want}",
                        z[o][c]
                    );
                }
            }
        }
    }

    #[test]
    fn a_refresh_equals_a_fresh_build_and_bad_input_is_an_error() {
        let a = grid_matrix(8);
        // New values, same pattern: a refresh equals a fresh build, bit for bit.
        let mut a2 = a.clone();
        for v in a2.values_mut() {
            v[2] *= 1.5;
        }
        let mut old = Ssor::new(&a).unwrap();
        old.refresh(&a2).unwrap();
        assert_eq!(old, Ssor::new(&a2).unwrap());
        // A failed refresh leaves it unchanged.
        let mut bad = a2.clone();
        let k = bad.pattern().diagonal_positions()[5];
        bad.values_mut()[k][0] = -1.0;
        let before = old.clone();
        assert!(matches!(old.refresh(&bad), Err(SparseError::NonPositiveDiagonal { row: 5, channel: 0, .. })));
        assert_eq!(old, before);
        assert!(matches!(old.refresh(&grid_matrix(5)), Err(SparseError::PatternMismatch(_))));
        for omega in [0.0, 2.0, f64::NAN] {
            assert!(matches!(Ssor::with_omega(&a, omega), Err(SparseError::InvalidOption(_))));
        }
    }
}
