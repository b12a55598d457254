//! SSOR-preconditioned CG, applied with Eisenstat's trick, swept in parallel over the parts and
//! separators of a level-set ordering.
//!
//! # The preconditioner
//!
//! On the Jacobi-scaled matrix `Â = S A S` (`S = D^-½`, unit diagonal), split as
//! `Â = L + I + U` (`U = Lᵀ`), symmetric successive over-relaxation with factor `ω ∈ (0, 2)`
//! is `M = (D̃ + L) D̃⁻¹ (D̃ + U) / (ω (2 − ω))`, `D̃ = I/ω`: SPD for SPD `A`. Its triangles are
//! swept in the [`sweep_ordering`] of the matrix's graph, so that a forward sweep is a parallel
//! pass over the parts followed by a parallel pass over the separators, and equals the
//! sequential sweep of that ordering exactly (the result does not depend on the thread count).
//!
//! # Eisenstat's trick (Eisenstat 1981)
//!
//! With `K = (D̃ + L)⁻¹`, CG runs on `Ã = K Â Kᵀ` (SPD), right-hand side `K S b`, and
//! `x = S Kᵀ ỹ`. Since `Â = (D̃ + L) + (D̃ + U) + (1 − 2/ω) I`,
//!
//! `Ã v = t + K (v + (1 − 2/ω) t)`, `t = Kᵀ v`,
//!
//! one backward and one forward sweep: each off-diagonal entry is read once per iteration, as in
//! a Jacobi-PCG iteration's product, where plain SSOR-PCG would read the matrix twice (product
//! and preconditioner).
//!
//! # Precision and stopping
//!
//! Everything is `f64`. The triangles are rounded from the same product for an entry and its
//! transpose, so `Ã` is exactly symmetric. (With `f32` triangles the bunny solve took 12% less
//! time, but on a badly conditioned channel, a 14³ grid with little absorption, the `f32`
//! operator's rounding slowed CG from 54 to 69 iterations: `f64` was kept.) The residual of `Ã`
//! is `r̃ = K S r`, `r = b − A x`. Its recursive norm, scaled to `‖r‖` at the last check, drives
//! the iteration; the true residual (the only one that can declare a channel converged) is
//! recomputed for every active channel at once, when *all* their estimates have reached 4× the
//! tolerance, then the tolerance, or after `RELIABLE_PERIOD` iterations without a check. A sweep
//! costs the same for one active channel as for three, so a channel that meets the tolerance
//! early goes on iterating (and gets more accurate) until the others are due too, and reports
//! the iterations to the check that found it converged. A check at each channel's arrival took 4
//! checks per solve (at 21, 24, 30 and 35 iterations on the 500k-tet bunny), 1.5 iterations'
//! work each; this schedule takes 2. It is
//! recomputed in the new numbering from the `f64` triangles (which hold `a_ij s_i s_j`): an
//! upper sweep, one product and a lower sweep, no permutation. Checking each channel on its own
//! schedule, in the original numbering, as the Jacobi PCG does, took 9 recomputations of 9.5 ms
//! on the bunny, 40% of the solve. The reported residual is computed from `A` and the final `x`;
//! if rounding makes it miss the tolerance where the scaled one met it (near the limit of
//! `f64`), or a recomputed residual exceeds the estimate fourfold, plain PCG with the same
//! preconditioner finishes the solve.
//!
//! # Measured (bunny, 60 mm, marble, one sun)
//!
//! Iterations to 1e-6 (R/G/B) on the 500k-tet system (93 481 vertices): Jacobi 125/106/86; SSOR
//! in this ordering with 8 parts: ω = 1.0: 45, 1.2: 38, 1.4: 33/29/24, 1.5: 32/28/23, 1.6:
//! 32/28/23, 1.7: 34/29/25 (prototype); as built, ω = 1.5: 35/30/25 (reported as 35/31/31
//! with the check schedule above). One part (sequential) needs 30 at ω = 1.4, 16 parts 37: the
//! separators cost little. In the mesher's own vertex
//! numbering SSOR needs 62 (ω = 1), and block-Jacobi SSOR on row blocks of it no fewer than
//! Jacobi (123): that numbering scatters neighbours across the whole matrix.
//!
//! Time, `transcut bench multires --tets 500000 --runs 3` (2 cores under a load of about 1.7,
//! medians): SSOR setup 89 ms (ordering, triangles
//! and values; Jacobi's 22 ms), solve to 1e-6 160 ms against Jacobi's 243 ms (0.66), warm start
//! after a 5° sun move 133 against 195 ms, time to 1% error 106 against 114 ms. A cold setup and
//! solve together gain only ~6% at 500k (at 1M, from the exported system before the in-place
//! residual: setup 177–237 ms, solve 452–474 against 626–779 ms). An iteration costs about two
//! Jacobi iterations, not one: a sweep waits on the row just computed (taking the nearest column
//! last cut a one-thread solve from 532 to 418 ms), and the fixed cost of a solve (first and
//! last residuals, the conversions) is about 45 ms. So SSOR is not the default
//! ([`super::PreconditionerKind::Jacobi`] is) and serves where one matrix is solved repeatedly
//! ([`crate::diffusion::Method::SsorPcg`], the editor's default: its paints and cuts beat the
//! multigrid's, whose setup is ten times longer; see [`crate::edit`]).

use std::ops::Range;
use std::sync::Arc;

use rayon::prelude::*;

use super::csr::{CsrMatrix3, CsrPattern};
use super::error::SparseError;
use super::ops::{row_mul, sum_partials, CHUNK};
use super::ordering::sweep_ordering;
use super::pcg::{check_rho, end_iteration, make_stats, p_update, step_lengths, Mixed, Progress, DRIFT_LIMIT, RELIABLE_PERIOD};
use super::precond::inverse_diagonal;
use super::{relative, SolveOptions};

/// One strict triangle of the reordered, scaled matrix, rows in the new numbering.
#[derive(Debug, Clone, PartialEq)]
struct Triangle {
    ptr: Vec<usize>,
    col: Vec<u32>,
    val: Vec<[f64; 3]>,
    /// For each value of the lower triangle, the position in the original matrix of the entry
    /// it is rounded from; of the upper triangle, the position of the lower entry it mirrors.
    src: Vec<usize>,
}

impl Triangle {
    #[inline(always)]
    fn row(&self, i: usize) -> (&[u32], &[[f64; 3]]) {
        let (s, e) = (self.ptr[i], self.ptr[i + 1]);
        (&self.col[s..e], &self.val[s..e])
    }
}

/// The SSOR preconditioner of one matrix (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct Ssor {
    pattern: Arc<CsrPattern>,
    omega: f64,
    /// New row `i` is original row `perm[i]`; `inv` is the inverse permutation.
    perm: Vec<u32>,
    inv: Vec<u32>,
    parts: Vec<Range<usize>>,
    separators: Vec<Range<usize>>,
    lower: Triangle,
    upper: Triangle,
    /// `S = D^-½` per new row.
    s: Vec<[f64; 3]>,
}

/// `a ⊙ b`, channel by channel.
#[inline(always)]
fn mul3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
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
    /// Over-relaxation factor of [`Self::new`]; measured best on the bunny (module
    /// documentation): 1.5 and 1.6 tie, 1.4 and 1.7 take one or two iterations more.
    pub const DEFAULT_OMEGA: f64 = 1.5;

    /// Parts the sweeps are cut into (fixed, so results do not depend on the thread count).
    /// Eight parts cost about one iteration in 32 against one part (module documentation).
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
    fn solve_lower(
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
    fn solve_upper(&self, v: &[[f64; 3]], t: &mut [[f64; 3]]) {
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

    /// `ỹ = (D̃ + U) w`, `w_i = x_{perm i} / s_i` (so that `x = S Kᵀ ỹ`), on the channels
    /// in `keep`; the others are zero.
    fn iterate_of(&self, x: &[[f64; 3]], keep: [bool; 3]) -> Vec<[f64; 3]> {
        let w: Vec<[f64; 3]> = self
            .perm
            .par_iter()
            .zip(&self.s)
            .map(|(&o, s)| [0, 1, 2].map(|c| if keep[c] { x[o as usize][c] / s[c] } else { 0.0 }))
            .collect();
        (0..w.len())
            .into_par_iter()
            .map(|i| {
                let (cols, vals) = self.upper.row(i);
                let u = row_mul(cols, vals, &w);
                [0, 1, 2].map(|c| w[i][c] / self.omega + u[c])
            })
            .collect()
    }

    /// `x = S Kᵀ ỹ` in the original numbering, written to `x` on the channels in `write`;
    /// `t` is scratch.
    fn to_solution(&self, y: &[[f64; 3]], t: &mut [[f64; 3]], x: &mut [[f64; 3]], write: [bool; 3]) {
        self.solve_upper(y, t);
        x.par_iter_mut().zip(&self.inv).for_each(|(x, &k)| {
            let k = k as usize;
            for c in 0..3 {
                if write[c] {
                    x[c] = self.s[k][c] * t[k][c];
                }
            }
        });
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

/// Scratch vectors of [`pcg_eisenstat`], in the new numbering.
struct Work {
    t: Vec<[f64; 3]>,
    u: Vec<[f64; 3]>,
    r: Vec<[f64; 3]>,
}

impl Ssor {
    /// The true residual of the iterate `ỹ`, all in the new numbering: `ŵ = Kᵀ ỹ`,
    /// `r̂ = b̂ − Â ŵ` (`b̂ = S b` renumbered; `Â ŵ = ŵ + L ŵ + U ŵ` from the `f64` triangles,
    /// which hold `a_ij s_i s_j`) and `r̃ = K r̂`, written to the channels of `rt` selected by
    /// `replace`. Returns `(‖r‖², ‖r̃‖²)`, `r = S⁻¹ r̂` being the residual `b − A x` of
    /// `x = S ŵ` in the original scaling.
    fn reliable_residual(
        &self,
        bh: &[[f64; 3]],
        y: &[[f64; 3]],
        rt: &mut [[f64; 3]],
        replace: [bool; 3],
        w: &mut Work,
    ) -> ([f64; 3], [f64; 3]) {
        self.solve_upper(y, &mut w.t);
        let t = &w.t;
        let parts: Vec<[f64; 3]> =
            w.r.par_chunks_mut(CHUNK)
                .enumerate()
                .map(|(k, rc)| {
                    let mut sum = [0.0; 3];
                    for (li, r) in rc.iter_mut().enumerate() {
                        let i = k * CHUNK + li;
                        let (lc, lv) = self.lower.row(i);
                        let (uc, uv) = self.upper.row(i);
                        let l = row_mul(lc, lv, t);
                        let u = row_mul(uc, uv, t);
                        for c in 0..3 {
                            r[c] = bh[i][c] - (t[i][c] + l[c] + u[c]);
                            let unscaled = r[c] / self.s[i][c];
                            sum[c] += unscaled * unscaled;
                        }
                    }
                    sum
                })
                .collect();
        let rr = sum_partials(&parts);
        let r = &w.r;
        let rtrt = self.solve_lower(|i| r[i], &mut w.u, |_, u| [u[0] * u[0], u[1] * u[1], u[2] * u[2]]);
        rt.par_iter_mut().zip(&w.u).for_each(|(rt, u)| {
            for c in 0..3 {
                if replace[c] {
                    rt[c] = u[c];
                }
            }
        });
        (rr, rtrt)
    }

    /// [`Self::reliable_residual`] of `ỹ = 0` (all channels), equal to it bit for bit without
    /// its sweeps and product: `r̂ = b̂` (`b̂ − Â·0` is `b̂`, each product summing to ±0), and
    /// `r̃ = K b̂`.
    fn residual_of_zero(&self, bh: &[[f64; 3]], rt: &mut [[f64; 3]]) -> ([f64; 3], [f64; 3]) {
        let parts: Vec<[f64; 3]> = bh
            .par_chunks(CHUNK)
            .zip(self.s.par_chunks(CHUNK))
            .map(|(bc, sc)| {
                let mut sum = [0.0; 3];
                for (b, s) in bc.iter().zip(sc) {
                    for c in 0..3 {
                        let unscaled = b[c] / s[c];
                        sum[c] += unscaled * unscaled;
                    }
                }
                sum
            })
            .collect();
        let rtrt = self.solve_lower(|i| bh[i], rt, |_, u| [u[0] * u[0], u[1] * u[1], u[2] * u[2]]);
        (sum_partials(&parts), rtrt)
    }
}

/// A channel's first true-residual check comes when its estimate reaches this many times the
/// tolerance (see [`pcg_eisenstat`]).
const EARLY_CHECK: f64 = 4.0;

/// `ỹ += α p`, `r̃ −= α (t + u)`; returns `‖r̃‖²`.
fn update(y: &mut [[f64; 3]], rt: &mut [[f64; 3]], p: &[[f64; 3]], t: &[[f64; 3]], u: &[[f64; 3]], alpha: [f64; 3]) -> [f64; 3] {
    let parts: Vec<[f64; 3]> =
        (y.par_chunks_mut(CHUNK), rt.par_chunks_mut(CHUNK), p.par_chunks(CHUNK), t.par_chunks(CHUNK), u.par_chunks(CHUNK))
            .into_par_iter()
            .map(|(y, r, p, t, u)| {
                let mut s = [0.0; 3];
                for ((((y, r), p), t), u) in y.iter_mut().zip(r.iter_mut()).zip(p).zip(t).zip(u) {
                    for c in 0..3 {
                        y[c] += alpha[c] * p[c];
                        r[c] -= alpha[c] * (t[c] + u[c]);
                        s[c] += r[c] * r[c];
                    }
                }
                s
            })
            .collect();
    sum_partials(&parts)
}

/// CG on `Ã ỹ = K S b` with Eisenstat's trick (module documentation), from the caller's `x`;
/// `bn` is `‖b‖` per channel. Channels are independent, as in the Jacobi PCG: each has its own
/// scalars and stopping test, and a converged channel stops changing.
#[allow(clippy::too_many_lines)]
pub(crate) fn pcg_eisenstat(
    a: &CsrMatrix3,
    b: &[[f64; 3]],
    x: &mut [[f64; 3]],
    m: &Ssor,
    options: &SolveOptions<'_>,
    bn: [f64; 3],
) -> Result<Mixed, SparseError> {
    let n = a.n();
    let tol = options.tolerance;
    let max_it = options.max_iterations;
    let mut w = Work { t: vec![[0.0; 3]; n], u: vec![[0.0; 3]; n], r: vec![[0.0; 3]; n] };
    let bh: Vec<[f64; 3]> = m.perm.par_iter().zip(&m.s).map(|(&o, s)| mul3(*s, b[o as usize])).collect();
    let nonzero = bn.map(|v| v > 0.0);
    let mut rt = vec![[0.0; 3]; n];
    // A cold start (`x = 0`) costs no sweep and no product: `ỹ = 0` and `r̂ = b̂`.
    let cold = x.par_iter().all(|v| v.iter().all(|&t| t == 0.0));
    let (mut y, (rr, mut rtrt)) = if cold {
        (vec![[0.0; 3]; n], m.residual_of_zero(&bh, &mut rt))
    } else {
        let y = m.iterate_of(x, nonzero);
        let residual = m.reliable_residual(&bh, &y, &mut rt, [true; 3], &mut w);
        (y, residual)
    };
    let mut rel = relative(rr, bn);
    let mut active = [0, 1, 2].map(|c| nonzero[c] && rel[c] > tol);
    // Channels whose x is rewritten (the others keep the caller's bits exactly).
    let touched = [0, 1, 2].map(|c| active[c] || !nonzero[c]);
    let mut iterations = [0usize; 3];
    if active.iter().any(|&t| t) {
        check_rho(rtrt, active, 0)?;
        let mut last_true = rel;
        let mut last_rtrt = rtrt;
        let mut last_recompute = [0usize; 3];
        let mut slack = [EARLY_CHECK; 3];
        let mut p = vec![[0.0; 3]; n];
        let mut beta = [0.0; 3];
        let shift = 1.0 - 2.0 / m.omega;
        let mut it = 0;
        while it < max_it {
            it += 1;
            p_update(&mut p, &rt, beta);
            m.solve_upper(&p, &mut w.t);
            let (t, pv) = (&w.t, &p);
            let pq = m.solve_lower(
                |i| {
                    let (p, t) = (pv[i], t[i]);
                    [p[0] + shift * t[0], p[1] + shift * t[1], p[2] + shift * t[2]]
                },
                &mut w.u,
                |i, u| {
                    let (p, t) = (pv[i], t[i]);
                    [p[0] * (t[0] + u[0]), p[1] * (t[1] + u[1]), p[2] * (t[2] + u[2])]
                },
            );
            let alpha = step_lengths(rtrt, pq, active, it)?;
            let new_rtrt = update(&mut y, &mut rt, &p, &w.t, &w.u, alpha);
            // ‖r‖ estimated from ‖r̃‖ relative to the last recomputation.
            let est =
                [0, 1, 2].map(|c| if last_rtrt[c] > 0.0 { last_true[c] * (new_rtrt[c] / last_rtrt[c]).sqrt() } else { 0.0 });
            // One schedule for all channels (module documentation): a check, for every active
            // channel, when all their estimates meet the tolerance or one has gone unchecked for
            // `RELIABLE_PERIOD` iterations. The estimate can be pessimistic (‖r‖ and ‖r̃‖ need
            // not fall at the same rate), so the first check comes at `EARLY_CHECK` times the
            // tolerance; after a check that misses, the estimate restarts from the true residual
            // and the next comes at the tolerance itself.
            let due = (0..3).all(|c| !active[c] || est[c] <= slack[c] * tol)
                || (0..3).any(|c| active[c] && it - last_recompute[c] >= RELIABLE_PERIOD);
            let recompute = active.map(|a| a && due);
            let mut fresh = new_rtrt;
            let mut checked = est;
            if recompute.iter().any(|&t| t) {
                let (rr, rr_t) = m.reliable_residual(&bh, &y, &mut rt, recompute, &mut w);
                checked = relative(rr, bn);
                let t = checked;
                for c in 0..3 {
                    if recompute[c] {
                        if t[c] > tol && t[c] > DRIFT_LIMIT * est[c] {
                            let mut xs = x.to_vec();
                            m.to_solution(&y, &mut w.t, &mut xs, touched);
                            return Ok(Mixed::Stagnated { x: xs, progress: Progress { iteration: it, iterations } });
                        }
                        fresh[c] = rr_t[c];
                        slack[c] = 1.0;
                        last_true[c] = t[c];
                        last_rtrt[c] = rr_t[c];
                        last_recompute[c] = it;
                    }
                }
            }
            end_iteration(it, &mut active, recompute, (checked, est), &mut rel, &mut iterations, tol, options)?;
            if !active.iter().any(|&t| t) || it == max_it {
                break;
            }
            check_rho(fresh, active, it)?;
            for c in 0..3 {
                beta[c] = if active[c] { fresh[c] / rtrt[c] } else { 0.0 };
                if active[c] {
                    rtrt[c] = fresh[c];
                }
            }
        }
    }
    // The reported residual is recomputed from `A` and the final `x` (the checks above used the
    // scaled triangles, equal up to rounding). Where rounding makes the two disagree about a
    // channel meeting the tolerance (only near the limit of `f64`), plain PCG finishes.
    let mut xs = x.to_vec();
    m.to_solution(&y, &mut w.t, &mut xs, touched);
    let rel_a = relative(super::residual(a, b, &xs, &mut w.r), bn);
    if (0..3).any(|c| rel_a[c] > tol && rel[c] <= tol && touched[c]) {
        return Ok(Mixed::Stagnated {
            x: xs,
            progress: Progress { iteration: iterations.into_iter().max().unwrap_or(0), iterations },
        });
    }
    x.copy_from_slice(&xs);
    Ok(Mixed::Done(make_stats(iterations, rel_a, tol)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sparse::csr::Triplet;
    use crate::sparse::{pcg, Precision, Preconditioner};
    use nalgebra::{DMatrix, DVector};

    /// A 3-D grid Laplacian (7-point) with a per-channel absorption, like a diffusion matrix:
    /// SPD, unit-free, with a spread diagonal.
    fn grid(nx: usize) -> CsrMatrix3 {
        let id = |x: usize, y: usize, z: usize| ((z * nx + y) * nx + x) as u32;
        let mut t = Vec::new();
        for z in 0..nx {
            for y in 0..nx {
                for x in 0..nx {
                    let i = id(x, y, z);
                    let mut deg = 0.0;
                    for (dx, dy, dz) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                        let (u, v, w) = (x + dx, y + dy, z + dz);
                        if u < nx && v < nx && w < nx {
                            let k = 1.0 + 0.5 * ((x + 2 * y + 3 * z) % 5) as f64;
                            t.push(Triplet::new(i, id(u, v, w), [-k, -0.7 * k, -1.3 * k]));
                            t.push(Triplet::new(id(u, v, w), i, [-k, -0.7 * k, -1.3 * k]));
                            t.push(Triplet::new(id(u, v, w), id(u, v, w), [k, 0.7 * k, 1.3 * k]));
                            deg += k;
                        }
                    }
                    t.push(Triplet::new(i, i, [deg + 0.01, 0.7 * deg + 0.05, 1.3 * deg + 0.2]));
                }
            }
        }
        CsrMatrix3::from_triplets(nx * nx * nx, &t).unwrap()
    }

    fn rhs(n: usize) -> Vec<[f64; 3]> {
        (0..n).map(|i| [((i * 7) % 11) as f64 - 3.0, (i % 5) as f64, 1.0 + (i % 3) as f64]).collect()
    }

    /// `M⁻¹` applied by the parallel sweeps equals the dense SSOR formula in the sweep ordering:
    /// `M = (D̃ + L) D̃⁻¹ (D̃ + U) / (ω (2 − ω))` on `Â = S A S` renumbered.
    #[test]
    fn apply_equals_the_dense_ssor_formula() {
        let a = grid(7);
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
    fn eisenstat_cg_takes_the_iterations_of_plain_ssor_pcg_and_far_fewer_than_jacobi() {
        let a = grid(14);
        let b = rhs(a.n());
        let m = Preconditioner::Ssor(Ssor::new(&a).unwrap());
        let jacobi = Preconditioner::new(&a, crate::sparse::PreconditionerKind::Jacobi).unwrap();
        let opts = SolveOptions::default();
        let mut x = vec![[0.0; 3]; a.n()];
        let fast = pcg(&a, &b, &mut x, &m, &opts).unwrap();
        let mut xd = vec![[0.0; 3]; a.n()];
        let plain = pcg(&a, &b, &mut xd, &m, &opts.with_precision(Precision::Double)).unwrap();
        let mut xj = vec![[0.0; 3]; a.n()];
        let jac = pcg(&a, &b, &mut xj, &jacobi, &opts).unwrap();
        assert!(fast.converged && plain.converged && jac.converged);
        let most = |s: &crate::sparse::SolveStats| s.iterations.into_iter().max().unwrap();
        // Same Krylov space, same iterates in exact arithmetic; the stopping tests differ (the
        // recursive estimate of ‖r‖ here, ‖r‖ itself there), and here a channel done early
        // iterates on until every active channel is due for a check (module documentation).
        assert!(most(&fast).abs_diff(most(&plain)) <= 1, "{fast:?} vs {plain:?}");
        for c in 0..3 {
            assert!(fast.iterations[c] + 1 >= plain.iterations[c], "{fast:?} vs {plain:?}");
        }
        // On this small grid SSOR saves a third to a half of Jacobi's iterations (more on larger
        // meshes: a quarter of them on the 500k-tet bunny).
        assert!(4 * most(&fast) <= 3 * most(&jac), "{fast:?} vs Jacobi {jac:?}");
        for c in 0..3 {
            assert!(fast.relative_residual[c] <= 1e-6);
            // No channel ends much above plain SSOR-PCG's residual (those done early end below).
            assert!(fast.relative_residual[c] <= plain.relative_residual[c] * 1.5, "{fast:?} vs {plain:?}");
        }
        let err = x.iter().zip(&xj).map(|(u, v)| (0..3).map(|c| (u[c] - v[c]).abs()).fold(0.0, f64::max)).fold(0.0, f64::max);
        let scale = xj.iter().map(|v| v.iter().fold(0.0f64, |m, t| m.max(t.abs()))).fold(0.0, f64::max);
        assert!(err <= 1e-6 * scale, "{err:e} vs {scale:e}");
    }

    #[test]
    fn warm_starts_zero_channels_and_refresh() {
        let a = grid(8);
        let n = a.n();
        let mut b = rhs(n);
        for v in &mut b {
            v[1] = 0.0;
        }
        let m = Preconditioner::Ssor(Ssor::new(&a).unwrap());
        let mut x = vec![[1.0; 3]; n];
        let s = pcg(&a, &b, &mut x, &m, &SolveOptions::default()).unwrap();
        assert!(s.converged && s.iterations[1] == 0 && x.iter().all(|v| v[1] == 0.0), "{s:?}");
        // From the solution: nothing to do, and the caller's bits are kept.
        let x0 = x.clone();
        let s = pcg(&a, &b, &mut x, &m, &SolveOptions::default()).unwrap();
        assert_eq!(s.iterations, [0; 3]);
        assert_eq!(x, x0);
        // New values, same pattern: a refresh equals a fresh build, bit for bit.
        let mut a2 = a.clone();
        for v in a2.values_mut() {
            v[2] *= 1.5;
        }
        let Preconditioner::Ssor(mut old) = m else { unreachable!() };
        old.refresh(&a2).unwrap();
        assert_eq!(old, Ssor::new(&a2).unwrap());
        // A failed refresh leaves it unchanged.
        let mut bad = a2.clone();
        let k = bad.pattern().diagonal_positions()[5];
        bad.values_mut()[k][0] = -1.0;
        let before = old.clone();
        assert!(matches!(old.refresh(&bad), Err(SparseError::NonPositiveDiagonal { row: 5, channel: 0, .. })));
        assert_eq!(old, before);
        assert!(matches!(old.refresh(&grid(5)), Err(SparseError::PatternMismatch(_))));
        for omega in [0.0, 2.0, f64::NAN] {
            assert!(matches!(Ssor::with_omega(&a, omega), Err(SparseError::InvalidOption(_))));
        }
    }

    #[test]
    fn the_residual_of_a_cold_start_needs_no_product_and_is_the_same_bits() {
        let a = grid(9);
        let m = Ssor::new(&a).unwrap();
        let n = a.n();
        let b = rhs(n);
        let bh: Vec<[f64; 3]> = m.perm.iter().zip(&m.s).map(|(&o, s)| mul3(*s, b[o as usize])).collect();
        let mut w = Work { t: vec![[0.0; 3]; n], u: vec![[0.0; 3]; n], r: vec![[0.0; 3]; n] };
        let (mut rt, mut rt0) = (vec![[0.0; 3]; n], vec![[0.0; 3]; n]);
        let general = m.reliable_residual(&bh, &vec![[0.0; 3]; n], &mut rt, [true; 3], &mut w);
        let cold = m.residual_of_zero(&bh, &mut rt0);
        assert_eq!(general, cold);
        assert_eq!(rt, rt0);
        // ‖r‖ of x = 0 is ‖b‖.
        let bn = crate::sparse::norm3(&b);
        for c in 0..3 {
            assert!((cold.0[c].sqrt() - bn[c]).abs() <= 1e-14 * bn[c]);
        }
    }
}
