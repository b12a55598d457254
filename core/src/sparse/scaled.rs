//! The Jacobi-scaled operator `Â = S A S` (`S = D^-½`, so `Â` has a unit diagonal), stored in
//! `f32`, on which the mixed-precision PCG iterates and the Chebyshev polynomial is evaluated.
//!
//! Storing `Â` in `f32` halves the bytes the SpMV streams per nonzero (12 + 4 instead of 24 + 4)
//! and makes Jacobi scaling free inside the iteration (no inverse-diagonal vector to read). The
//! `f32` rounding perturbs `Â` by about 6e-8 per entry; the solver corrects for it with
//! residuals recomputed in `f64` from the original matrix ("reliable updates"), so the answer
//! meets the tolerance on the `f64` system.

use std::sync::Arc;

use rayon::prelude::*;

use super::csr::{split_row_blocks, CsrMatrix3, CsrPattern, ROW_BLOCK};
use super::error::SparseError;
use super::ops::{row_mul, sum_partials, CHUNK};
use super::precond::inverse_diagonal;

/// `Â = S A S` in `f32`, with `S = D^-½` and `D` kept for residual norms.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ScaledOperator {
    pub(crate) pattern: Arc<CsrPattern>,
    pub(crate) entries: Entries,
    /// `S = D^-½` per row.
    pub(crate) s: Vec<[f64; 3]>,
    /// `D` per row, in `f32` (only used to turn scaled residual norms into unscaled ones).
    pub(crate) d: Vec<[f32; 3]>,
    /// A Gershgorin upper bound of the spectrum of `Â` (equivalently of `D⁻¹A`), per channel.
    pub(crate) lambda_max: [f64; 3],
}

/// How the entries of `Â` are stored.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Entries {
    /// Every entry of `Â`, per channel, in `f32`: 12 bytes per nonzero.
    PerChannel(Vec<[f32; 3]>),
    /// The off-diagonal entries of `A` are one matrix `G` times a factor per channel,
    /// `A_c,ij = ratio_c · g_ij` (`i ≠ j`), as in a homogeneous medium, whose edge weights
    /// (TransCut eqs. 10 and 14) share one κ per channel. Then
    /// `Â_c = I + ratio_c · S_c G S_c` (the diagonal of `Â` is 1), applied from `g` in `f32`
    /// (zero in the diagonal slots) and `S` in `f32`: 4 bytes per nonzero, a third of
    /// [`Entries::PerChannel`]'s traffic. The product stays exactly symmetric in exact
    /// arithmetic, as CG needs.
    Proportional { g: Vec<f32>, ratio: [f64; 3], s32: Vec<[f32; 3]> },
}

/// Largest relative deviation `|A_c,ij − ratio_c A_0,ij| / |A_c,ij|` for which the
/// off-diagonals count as proportional (rounding of the assembly sums is ~1e-15; `f32` storage
/// perturbs every entry by ~6e-8 anyway).
const PROPORTIONAL_TOLERANCE: f64 = 1e-10;

/// The per-channel factors `ratio_c` with `A_c,ij = ratio_c A_0,ij` for every off-diagonal
/// entry (within [`PROPORTIONAL_TOLERANCE`]), or `None` if the channels are not proportional
/// (or there is no off-diagonal entry).
fn proportional_ratio(a: &CsrMatrix3) -> Option<[f64; 3]> {
    let p = a.pattern();
    let vals = a.values();
    let diag = p.diagonal_positions();
    let (rp, ci) = (p.row_ptr(), p.col_idx());
    let first = (0..a.n()).find_map(|i| (rp[i]..rp[i + 1]).find(|&k| ci[k] as usize != i && vals[k][0] != 0.0))?;
    let ratio = [0, 1, 2].map(|c| vals[first][c] / vals[first][0]);
    if !ratio.iter().all(|r| r.is_finite() && *r > 0.0) {
        return None;
    }
    let ok = (0..a.n()).into_par_iter().with_min_len(CHUNK).all(|i| {
        (rp[i]..rp[i + 1]).all(|k| {
            k == diag[i]
                || (1..3).all(|c| {
                    let v = vals[k];
                    (v[c] - ratio[c] * v[0]).abs() <= PROPORTIONAL_TOLERANCE * v[c].abs()
                })
        })
    });
    ok.then_some(ratio)
}

impl ScaledOperator {
    /// Builds `Â` from `a` in one parallel pass.
    ///
    /// # Errors
    /// [`SparseError::NonPositiveDiagonal`] for a diagonal entry that is not positive.
    pub(crate) fn new(a: &CsrMatrix3) -> Result<Self, SparseError> {
        Ok(Self::from_inverse_diagonal(a, &inverse_diagonal(a)?))
    }

    /// Builds `Â` from `a` and its (checked, positive) inverse diagonal, in the compact
    /// [`Entries::Proportional`] form when the channels' off-diagonals are proportional.
    pub(crate) fn from_inverse_diagonal(a: &CsrMatrix3, inv: &[[f64; 3]]) -> Self {
        let s: Vec<[f64; 3]> = inv.par_iter().map(|v| v.map(f64::sqrt)).collect();
        #[allow(clippy::cast_possible_truncation)]
        let d: Vec<[f32; 3]> = inv.par_iter().map(|v| v.map(|t| (1.0 / t) as f32)).collect();
        #[allow(clippy::cast_possible_truncation)]
        let (entries, lambda_max) = match proportional_ratio(a) {
            Some(ratio) => {
                let (g, bound) = scaled_entries(a, &s, inv, |v, i, j| if i == j { 0.0 } else { v[0] as f32 });
                let s32 = s.par_iter().map(|v| v.map(|t| t as f32)).collect();
                (Entries::Proportional { g, ratio, s32 }, bound)
            }
            None => {
                let (values, bound) =
                    scaled_entries(a, &s, inv, |v, i, j| [0, 1, 2].map(|c| (v[c] * s[i][c] * s[j][c]) as f32));
                (Entries::PerChannel(values), bound)
            }
        };
        Self { pattern: Arc::clone(a.pattern()), entries, s, d, lambda_max }
    }

    /// `(Â x)_i`.
    #[inline]
    pub(crate) fn row(&self, i: usize, x: &[[f64; 3]]) -> [f64; 3] {
        let (s, e) = (self.pattern.row_ptr()[i], self.pattern.row_ptr()[i + 1]);
        let cols = &self.pattern.col_idx()[s..e];
        match &self.entries {
            Entries::PerChannel(v) => row_mul(cols, &v[s..e], x),
            Entries::Proportional { g, ratio, s32 } => proportional_row(i, cols, &g[s..e], *ratio, s32, x),
        }
    }

    /// `q = Â p`; returns `pᵀq` per channel (deterministic).
    pub(crate) fn spmv_dot(&self, p: &[[f64; 3]], q: &mut [[f64; 3]]) -> [f64; 3] {
        match &self.entries {
            Entries::PerChannel(v) => spmv_dot_raw(&self.pattern, v, p, q),
            Entries::Proportional { g, ratio, s32 } => {
                let (rp, ci) = (self.pattern.row_ptr(), self.pattern.col_idx());
                spmv_dot_rows(p, q, |i| {
                    let (s, e) = (rp[i], rp[i + 1]);
                    proportional_row(i, &ci[s..e], &g[s..e], *ratio, s32, p)
                })
            }
        }
    }
}

/// Row `i` of [`Entries::Proportional`]: `x_i + ratio ∘ s_i ∘ Σ_j g_ij (s_j ∘ x_j)`.
#[inline(always)]
fn proportional_row(i: usize, cols: &[u32], g: &[f32], ratio: [f64; 3], s32: &[[f32; 3]], x: &[[f64; 3]]) -> [f64; 3] {
    let (mut a0, mut a1, mut a2) = (0.0, 0.0, 0.0);
    for (&j, &gk) in cols.iter().zip(g) {
        let j = j as usize;
        let (sj, xj, gk) = (s32[j], x[j], f64::from(gk));
        a0 += gk * (f64::from(sj[0]) * xj[0]);
        a1 += gk * (f64::from(sj[1]) * xj[1]);
        a2 += gk * (f64::from(sj[2]) * xj[2]);
    }
    let (si, xi) = (s32[i], x[i]);
    [
        xi[0] + ratio[0] * f64::from(si[0]) * a0,
        xi[1] + ratio[1] * f64::from(si[1]) * a1,
        xi[2] + ratio[2] * f64::from(si[2]) * a2,
    ]
}

/// The entries `entry(A_ij, i, j)` of a scaled operator, one parallel pass over `a`, with the
/// Gershgorin bound of `Â = S A S` (the smaller of its row-sum bound and that of `D⁻¹A`).
fn scaled_entries<T: Copy + Default + Send>(
    a: &CsrMatrix3,
    s: &[[f64; 3]],
    inv: &[[f64; 3]],
    entry: impl Fn([f64; 3], usize, usize) -> T + Sync,
) -> (Vec<T>, [f64; 3]) {
    let p = a.pattern();
    let n = a.n();
    let vals = a.values();
    let mut out = vec![T::default(); a.nnz()];
    let blocks = split_row_blocks(&mut out, p.row_ptr());
    let bounds: Vec<[f64; 6]> = blocks
        .into_par_iter()
        .enumerate()
        .map(|(b, out)| {
            let r0 = b * ROW_BLOCK;
            let r1 = (r0 + ROW_BLOCK).min(n);
            let off = p.row_ptr()[r0];
            let mut m = [0.0f64; 6];
            for i in r0..r1 {
                let mut row = [0.0; 6];
                for k in p.row_ptr()[i]..p.row_ptr()[i + 1] {
                    let j = p.col_idx()[k] as usize;
                    let v = vals[k];
                    for c in 0..3 {
                        row[c] += (v[c] * s[i][c] * s[j][c]).abs();
                        row[3 + c] += v[c].abs() * inv[i][c];
                    }
                    out[k - off] = entry(v, i, j);
                }
                for c in 0..6 {
                    m[c] = m[c].max(row[c]);
                }
            }
            m
        })
        .collect();
    let mut m = [0.0f64; 6];
    for b in &bounds {
        for c in 0..6 {
            m[c] = m[c].max(b[c]);
        }
    }
    (out, [0, 1, 2].map(|c| m[c].min(m[3 + c])))
}

/// `q_i = row(i)` for every row; returns `pᵀq` per channel (deterministic).
fn spmv_dot_rows(p: &[[f64; 3]], q: &mut [[f64; 3]], row: impl Fn(usize) -> [f64; 3] + Sync) -> [f64; 3] {
    let parts: Vec<[f64; 3]> = q
        .par_chunks_mut(CHUNK)
        .enumerate()
        .map(|(k, qc)| {
            let r0 = k * CHUNK;
            let mut s = [0.0; 3];
            for (li, qi) in qc.iter_mut().enumerate() {
                let i = r0 + li;
                let v = row(i);
                let pi = p[i];
                for c in 0..3 {
                    s[c] += pi[c] * v[c];
                }
                *qi = v;
            }
            s
        })
        .collect();
    sum_partials(&parts)
}

/// `q = A p` on raw parts; returns `pᵀq` per channel (deterministic).
pub(crate) fn spmv_dot_raw<E: super::ops::Load3>(
    pat: &CsrPattern,
    vals: &[E],
    p: &[[f64; 3]],
    q: &mut [[f64; 3]],
) -> [f64; 3] {
    let (rp, ci) = (pat.row_ptr(), pat.col_idx());
    spmv_dot_rows(p, q, |i| row_mul(&ci[rp[i]..rp[i + 1]], &vals[rp[i]..rp[i + 1]], p))
}

/// The true residual of the scaled iterate: `r = b − A S ŷ` (in `f64`, original matrix) and
/// `r̂ = S r`, written to the channels of `rh` selected by `replace`. Returns `(‖r‖², ‖r̂‖²)`
/// per channel.
pub(crate) fn reliable_residual(
    a: &CsrMatrix3,
    b: &[[f64; 3]],
    s: &[[f64; 3]],
    yhat: &[[f64; 3]],
    rh: &mut [[f64; 3]],
    replace: [bool; 3],
) -> ([f64; 3], [f64; 3]) {
    let p = a.pattern();
    let (rp, ci) = (p.row_ptr(), p.col_idx());
    let vals = a.values();
    let parts: Vec<[f64; 6]> = (rh.par_chunks_mut(CHUNK), b.par_chunks(CHUNK))
        .into_par_iter()
        .enumerate()
        .map(|(k, (rc, bc))| {
            let r0 = k * CHUNK;
            let mut acc = [0.0; 6];
            for (li, (ri, bi)) in rc.iter_mut().zip(bc).enumerate() {
                let i = r0 + li;
                let (mut a0, mut a1, mut a2) = (0.0, 0.0, 0.0);
                for k in rp[i]..rp[i + 1] {
                    let j = ci[k] as usize;
                    let (v, sj, yj) = (vals[k], s[j], yhat[j]);
                    a0 += v[0] * (sj[0] * yj[0]);
                    a1 += v[1] * (sj[1] * yj[1]);
                    a2 += v[2] * (sj[2] * yj[2]);
                }
                let ax = [a0, a1, a2];
                for c in 0..3 {
                    let r = bi[c] - ax[c];
                    acc[c] += r * r;
                    let rs = s[i][c] * r;
                    acc[3 + c] += rs * rs;
                    if replace[c] {
                        ri[c] = rs;
                    }
                }
            }
            acc
        })
        .collect();
    let t = sum_partials(&parts);
    ([t[0], t[1], t[2]], [t[3], t[4], t[5]])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sparse::csr::Triplet;

    /// A 3-D grid Laplacian-plus-mass: off-diagonals `−ratio_c · w_ij` (w varying per edge) and
    /// a diagonal that is not proportional across channels, like a homogeneous medium's system;
    /// `perturb` breaks the proportionality of one entry pair.
    fn grid(m: usize, ratio: [f64; 3], perturb: f64) -> CsrMatrix3 {
        let id = |x: usize, y: usize, z: usize| (x + m * (y + m * z)) as u32;
        let mut t = Vec::new();
        let mut diag = vec![[0.0; 3]; m * m * m];
        for z in 0..m {
            for y in 0..m {
                for x in 0..m {
                    let i = id(x, y, z);
                    for (dx, dy, dz) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                        let (u, v, w) = (x + dx, y + dy, z + dz);
                        if u < m && v < m && w < m {
                            let j = id(u, v, w);
                            let wij = 1.0 + 0.1 * f64::from((i * 7 + j * 3) % 11);
                            let mut val = ratio.map(|r| -r * wij);
                            if i == 0 && j == 1 {
                                val[2] *= 1.0 + perturb;
                            }
                            t.push(Triplet::new(i, j, val));
                            t.push(Triplet::new(j, i, val));
                            for c in 0..3 {
                                diag[i as usize][c] -= val[c];
                                diag[j as usize][c] -= val[c];
                            }
                        }
                    }
                }
            }
        }
        for (i, d) in diag.iter().enumerate() {
            let mass = [0.01, 0.05, 0.2].map(|k| k * (1.0 + (i % 5) as f64));
            t.push(Triplet::new(i as u32, i as u32, [0, 1, 2].map(|c| d[c] + mass[c])));
        }
        CsrMatrix3::from_triplets(m * m * m, &t).unwrap()
    }

    /// `S A S x` in `f64` from the matrix itself.
    fn reference(a: &CsrMatrix3, s: &[[f64; 3]], x: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let xs: Vec<[f64; 3]> = x.iter().zip(s).map(|(x, s)| [0, 1, 2].map(|c| x[c] * s[c])).collect();
        let y = a.mul_vec(&xs).unwrap();
        y.iter().zip(s).map(|(y, s)| [0, 1, 2].map(|c| y[c] * s[c])).collect()
    }

    #[test]
    fn proportional_channels_get_the_compact_form_and_apply_like_the_matrix() {
        let ratio = [1.0, 0.6, 0.25];
        for (perturb, compact) in [(0.0, true), (1e-12, true), (1e-6, false)] {
            let a = grid(6, ratio, perturb);
            let op = ScaledOperator::new(&a).unwrap();
            match &op.entries {
                Entries::Proportional { ratio: r, .. } => {
                    assert!(compact, "perturbation {perturb} must not count as proportional");
                    for c in 0..3 {
                        assert!((r[c] - ratio[c]).abs() < 1e-12, "{r:?}");
                    }
                }
                Entries::PerChannel(_) => assert!(!compact, "perturbation {perturb} must count as proportional"),
            }
            let x: Vec<[f64; 3]> = (0..a.n()).map(|i| [(i % 7) as f64 - 3.0, 1.0, 0.5 * (i % 3) as f64]).collect();
            let want = reference(&a, &op.s, &x);
            let mut q = vec![[0.0; 3]; a.n()];
            let dot = op.spmv_dot(&x, &mut q);
            for c in 0..3 {
                let scale = want.iter().map(|v| v[c].abs()).fold(0.0, f64::max);
                let err = q.iter().zip(&want).map(|(g, w)| (g[c] - w[c]).abs()).fold(0.0, f64::max);
                assert!(err < 1e-6 * scale, "channel {c}: error {err:e} against {scale:e}");
                let d: f64 = x.iter().zip(&q).map(|(x, q)| x[c] * q[c]).sum();
                assert!((d - dot[c]).abs() < 1e-12 * d.abs());
            }
            // The operator is symmetric: uᵀ(Â v) = vᵀ(Â u).
            let u: Vec<[f64; 3]> = (0..a.n()).map(|i| [((i * 13) % 5) as f64, -1.0, (i % 4) as f64]).collect();
            let (mut au, mut ax) = (vec![[0.0; 3]; a.n()], vec![[0.0; 3]; a.n()]);
            op.spmv_dot(&u, &mut au);
            op.spmv_dot(&x, &mut ax);
            for c in 0..3 {
                let l: f64 = x.iter().zip(&au).map(|(x, y)| x[c] * y[c]).sum();
                let r: f64 = u.iter().zip(&ax).map(|(u, y)| u[c] * y[c]).sum();
                assert!((l - r).abs() <= 1e-12 * l.abs().max(r.abs()), "channel {c}: {l} vs {r}");
            }
        }
    }
}
