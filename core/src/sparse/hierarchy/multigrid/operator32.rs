//! The level operators inside the V-cycle: exactly symmetric, rounded to `f32`.

use std::sync::Arc;

use rayon::prelude::*;

use super::ROWS;
use crate::sparse::ops::{row_mul, CHUNK};
use crate::sparse::{CsrMatrix3, CsrPattern};

/// A level operator inside the V-cycle: exactly symmetric, rounded to `f32`.
#[derive(Debug, Clone)]
pub(super) struct Operator32 {
    pub(super) pattern: Arc<CsrPattern>,
    pub(super) values: Vec<[f32; 3]>,
    /// Whether entries are symmetrised before rounding (level 0).
    symmetrise: bool,
}

/// Entry `k` (in row `i`) of `values` rounded to `f32`, as the mean with its mirror when
/// `symmetrise`.
#[inline]
fn rounded(p: &CsrPattern, values: &[[f64; 3]], symmetrise: bool, i: usize, k: usize) -> [f32; 3] {
    let mirror = if symmetrise { p.position(p.col_idx()[k] as usize, i) } else { None };
    rounded_with_mirror(values, k, mirror)
}

/// Entry `k` of `values` rounded to `f32`, as the mean with entry `mirror` when that is
/// another entry.
#[inline]
fn rounded_with_mirror(v: &[[f64; 3]], k: usize, mirror: Option<usize>) -> [f32; 3] {
    let s = match mirror {
        Some(t) if t != k => [0, 1, 2].map(|c| 0.5 * (v[k][c] + v[t][c])),
        _ => v[k],
    };
    #[allow(clippy::cast_possible_truncation)]
    s.map(|x| x as f32)
}

impl Operator32 {
    /// `a` rounded to `f32`; with `symmetrise`, each entry is `(a_ij + a_ji)/2` first (an entry
    /// whose mirror is not in the pattern is rounded as it is), for a matrix that is symmetric
    /// only up to rounding. (For an exactly symmetric one the mean is the entry itself.)
    pub(super) fn new(a: &CsrMatrix3, symmetrise: bool) -> Self {
        let p = a.pattern();
        // The mirrors in one pass rather than a search per entry.
        let mirror = if symmetrise { p.mirror_positions() } else { Vec::new() };
        let values: Vec<[f32; 3]> = (0..a.nnz())
            .into_par_iter()
            .with_min_len(CHUNK)
            .map(|k| rounded_with_mirror(a.values(), k, mirror.get(k).copied().filter(|&t| t != usize::MAX)))
            .collect();
        Self { pattern: Arc::clone(p), values, symmetrise }
    }

    /// Re-rounds from `a` (this operator's pattern) the entries of `rows`, as [`Self::new`]
    /// does: after a symmetric change of `a` confined to those rows (and so to their columns),
    /// the result equals `Operator32::new(a, ..)` bit for bit.
    pub(super) fn refresh_rows(&mut self, a: &CsrMatrix3, rows: &[u32]) {
        let p = Arc::clone(&self.pattern);
        for &i in rows {
            let i = i as usize;
            for k in p.row_ptr()[i]..p.row_ptr()[i + 1] {
                self.values[k] = rounded(&p, a.values(), self.symmetrise, i, k);
            }
        }
    }

    /// Row `i`'s Gershgorin bound `Σ_j |ã_ij| / a_ii` (`inv` = `1 / a_ii`).
    pub(super) fn row_bound(&self, i: usize, inv: [f64; 3]) -> [f64; 3] {
        let rp = self.pattern.row_ptr();
        let mut s = [0.0f64; 3];
        for v in &self.values[rp[i]..rp[i + 1]] {
            for c in 0..3 {
                s[c] += f64::from(v[c].abs());
            }
        }
        [0, 1, 2].map(|c| s[c] * inv[c])
    }

    /// `(Ã x)_i`.
    #[inline(always)]
    pub(super) fn row(&self, i: usize, x: &[[f64; 3]]) -> [f64; 3] {
        let rp = self.pattern.row_ptr();
        let (s, e) = (rp[i], rp[i + 1]);
        row_mul(&self.pattern.col_idx()[s..e], &self.values[s..e], x)
    }

    /// `res = r − Ã z`.
    pub(super) fn residual(&self, r: &[[f64; 3]], z: &[[f64; 3]], res: &mut [[f64; 3]]) {
        res.par_chunks_mut(ROWS).enumerate().for_each(|(b, rc)| {
            for (t, ri) in rc.iter_mut().enumerate() {
                let i = b * ROWS + t;
                let ax = self.row(i, z);
                *ri = [0, 1, 2].map(|c| r[i][c] - ax[c]);
            }
        });
    }
}
