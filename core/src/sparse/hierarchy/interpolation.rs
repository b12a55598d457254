//! The interpolation from level `l + 1` to level `l`, TransCut eq. 16:
//! `φ^l(x_i) = φ^{l+1}(x_i)` for a retained vertex, otherwise
//! `φ^l(x_i) = Σ_{j ∈ R(i)} λ_ij φ^{l+1}(x_j) / λ_i`, `R(i)` the retained one-ring neighbours,
//! `λ_ij = 1/|x_i − x_j|`, `λ_i = Σ_j λ_ij`. Stored as a sparse `n_fine × n_coarse` matrix `P`
//! (rows sum to 1) and its transpose (for the restriction `Pᵀ r` of the multigrid V-cycle),
//! both applied in parallel and deterministically (each row summed in column order).

use glam::DVec3;
use rayon::prelude::*;

use crate::sparse::{CsrPattern, SparseError};

/// The prolongation `P` of one level (TransCut eq. 16).
#[derive(Debug, Clone, PartialEq)]
pub struct Prolongation {
    n_coarse: usize,
    row_ptr: Vec<usize>,
    cols: Vec<u32>,
    weights: Vec<f64>,
    /// Transpose: for each coarse vertex, the fine rows and weights, rows increasing.
    t_ptr: Vec<usize>,
    t_rows: Vec<u32>,
    t_weights: Vec<f64>,
    /// For each fine vertex its coarse index, `u32::MAX` when dropped.
    coarse_of: Vec<u32>,
    /// Coarse vertex `c` is fine vertex `retained[c]`.
    retained: Vec<u32>,
}

impl Prolongation {
    /// Builds `P` for the fine `graph` with vertex `positions` (mm) and the retained vertices
    /// (increasing fine ids). Every dropped vertex must have a retained neighbour.
    pub(crate) fn new(graph: &CsrPattern, positions: &[DVec3], retained: &[u32]) -> Result<Self, SparseError> {
        let n = graph.n();
        let mut coarse_of = vec![u32::MAX; n];
        for (c, &i) in retained.iter().enumerate() {
            coarse_of[i as usize] = c as u32;
        }
        let rows: Vec<Result<Vec<(u32, f64)>, SparseError>> = (0..n)
            .into_par_iter()
            .map(|i| {
                if coarse_of[i] != u32::MAX {
                    return Ok(vec![(coarse_of[i], 1.0)]);
                }
                let mut r: Vec<(u32, f64)> = Vec::new();
                let mut coincident = false;
                for &j in graph.row(i) {
                    let c = coarse_of[j as usize];
                    if j as usize != i && c != u32::MAX {
                        let d = positions[i].distance(positions[j as usize]);
                        if !d.is_finite() {
                            return Err(SparseError::InvalidOption(format!(
                                "edge ({i}, {j}) has a non-finite length; 1/edge-length interpolation needs finite positions"
                            )));
                        }
                        coincident |= d == 0.0;
                        r.push((c, d));
                    }
                }
                if r.is_empty() {
                    return Err(SparseError::InvalidOption(format!(
                        "dropped vertex {i} has no retained neighbour to interpolate from"
                    )));
                }
                // λ = 1/d; a retained neighbour at the same position (a mesh with duplicated
                // vertices) takes all the weight, shared equally: the limit of 1/d as d → 0.
                if coincident {
                    r.retain(|e| e.1 == 0.0);
                    r.iter_mut().for_each(|e| e.1 = 1.0);
                } else {
                    r.iter_mut().for_each(|e| e.1 = 1.0 / e.1);
                }
                let total: f64 = r.iter().map(|e| e.1).sum();
                for e in &mut r {
                    e.1 /= total;
                }
                Ok(r)
            })
            .collect();
        let mut row_ptr = Vec::with_capacity(n + 1);
        row_ptr.push(0);
        let (mut cols, mut weights) = (Vec::new(), Vec::new());
        for r in rows {
            for (c, w) in r? {
                cols.push(c);
                weights.push(w);
            }
            row_ptr.push(cols.len());
        }
        Ok(Self { coarse_of, retained: retained.to_vec(), ..Self::from_csr(retained.len(), row_ptr, cols, weights)? })
    }

    /// A general `n_fine × n_coarse` operator `P` in compressed rows — `row_ptr` (`n_fine + 1`
    /// offsets from 0), then each row's coarse columns `cols` and their `weights`, one weight
    /// per entry shared by the three channels — with its transpose built here, so that the
    /// restriction `Pᵀ r` is a gather like the prolongation (on the device too:
    /// `gpu::restrict`, `gpu::prolong_add`, `gpu::GpuTransfer`). For hierarchies that retain no
    /// fine vertex (smoothed aggregation, the polygrid's lattices): [`Self::retained`] is empty
    /// and [`Self::coarse_of`] always `None`. Repeated columns in a row are summed where `P` is
    /// applied.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `row_ptr` is empty, does not start at 0 or end at
    /// `cols.len()`, or `weights` is not one per column; [`SparseError::InvalidOption`] if
    /// `row_ptr` decreases or a weight is not finite; [`SparseError::IndexOutOfRange`] for a
    /// column at or above `n_coarse`; [`SparseError::TooLarge`] if `n_fine` does not fit 32-bit
    /// indices.
    pub fn from_csr(n_coarse: usize, row_ptr: Vec<usize>, cols: Vec<u32>, weights: Vec<f64>) -> Result<Self, SparseError> {
        let Some(&end) = row_ptr.last() else {
            return Err(SparseError::DimensionMismatch {
                what: "prolongation row pointer length (n_fine + 1)",
                expected: 1,
                found: 0,
            });
        };
        let n = row_ptr.len() - 1;
        if u32::try_from(n).is_err() {
            return Err(SparseError::TooLarge(format!("{n} fine rows; indices are 32-bit")));
        }
        if row_ptr[0] != 0 {
            return Err(SparseError::DimensionMismatch {
                what: "prolongation row pointer start",
                expected: 0,
                found: row_ptr[0],
            });
        }
        if end != cols.len() {
            return Err(SparseError::DimensionMismatch {
                what: "prolongation row pointer end (number of columns)",
                expected: cols.len(),
                found: end,
            });
        }
        if weights.len() != cols.len() {
            return Err(SparseError::DimensionMismatch {
                what: "prolongation weights (one per column)",
                expected: cols.len(),
                found: weights.len(),
            });
        }
        if let Some(i) = row_ptr.windows(2).position(|w| w[1] < w[0]) {
            return Err(SparseError::InvalidOption(format!("prolongation row pointer decreases at row {i}")));
        }
        if let Some(&c) = cols.iter().find(|&&c| c as usize >= n_coarse) {
            return Err(SparseError::IndexOutOfRange { what: "prolongation column".into(), index: u64::from(c), n: n_coarse });
        }
        if let Some(k) = weights.iter().position(|w| !w.is_finite()) {
            let row = row_ptr.partition_point(|&p| p <= k) - 1;
            return Err(SparseError::InvalidOption(format!("prolongation weight {} of row {row} is not finite", weights[k])));
        }
        let m = n_coarse;
        let mut counts = vec![0usize; m + 1];
        for &c in &cols {
            counts[c as usize + 1] += 1;
        }
        for k in 0..m {
            counts[k + 1] += counts[k];
        }
        let t_ptr = counts.clone();
        let mut cursor = counts;
        let mut t_rows = vec![0u32; cols.len()];
        let mut t_weights = vec![0.0; cols.len()];
        for i in 0..n {
            for k in row_ptr[i]..row_ptr[i + 1] {
                let c = cols[k] as usize;
                t_rows[cursor[c]] = i as u32;
                t_weights[cursor[c]] = weights[k];
                cursor[c] += 1;
            }
        }
        Ok(Self {
            n_coarse: m,
            row_ptr,
            cols,
            weights,
            t_ptr,
            t_rows,
            t_weights,
            coarse_of: vec![u32::MAX; n],
            retained: Vec::new(),
        })
    }

    /// Fine vertices (rows of `P`).
    #[must_use]
    pub fn n_fine(&self) -> usize {
        self.row_ptr.len() - 1
    }

    /// Coarse vertices (columns of `P`).
    #[must_use]
    pub fn n_coarse(&self) -> usize {
        self.n_coarse
    }

    /// The retained fine vertices: coarse vertex `c` is fine vertex `retained()[c]`.
    #[must_use]
    pub fn retained(&self) -> &[u32] {
        &self.retained
    }

    /// The coarse index of fine vertex `i`, `None` if it was dropped.
    #[must_use]
    pub fn coarse_of(&self, i: usize) -> Option<usize> {
        let c = self.coarse_of[i];
        (c != u32::MAX).then_some(c as usize)
    }

    /// Row `i` of `P`: the coarse vertices fine vertex `i` interpolates from, with weights
    /// `λ_ij / λ_i` (a single weight 1 for a retained vertex).
    #[must_use]
    pub fn row(&self, i: usize) -> (&[u32], &[f64]) {
        let (s, e) = (self.row_ptr[i], self.row_ptr[i + 1]);
        (&self.cols[s..e], &self.weights[s..e])
    }

    /// `start + (P coarse)_i`, the terms added to `start` in column order.
    #[inline(always)]
    fn add_row(&self, i: usize, start: [f64; 3], coarse: &[[f64; 3]]) -> [f64; 3] {
        let (c, w) = self.row(i);
        let mut s = start;
        for (&j, &wj) in c.iter().zip(w) {
            let x = coarse[j as usize];
            for k in 0..3 {
                s[k] += wj * x[k];
            }
        }
        s
    }

    /// `fine = P coarse` (eq. 16).
    pub fn prolong(&self, coarse: &[[f64; 3]], fine: &mut [[f64; 3]]) {
        fine.par_iter_mut().enumerate().for_each(|(i, f)| *f = self.add_row(i, [0.0; 3], coarse));
    }

    /// `fine += P coarse`.
    pub fn prolong_add(&self, coarse: &[[f64; 3]], fine: &mut [[f64; 3]]) {
        fine.par_iter_mut().enumerate().for_each(|(i, f)| *f = self.add_row(i, *f, coarse));
    }

    /// `coarse = Pᵀ fine` (the multigrid restriction).
    pub fn restrict(&self, fine: &[[f64; 3]], coarse: &mut [[f64; 3]]) {
        coarse.par_iter_mut().enumerate().for_each(|(c, out)| {
            let mut s = [0.0; 3];
            for k in self.t_ptr[c]..self.t_ptr[c + 1] {
                let x = fine[self.t_rows[k] as usize];
                let w = self.t_weights[k];
                for ch in 0..3 {
                    s[ch] += w * x[ch];
                }
            }
            *out = s;
        });
    }

    /// The values at the retained vertices (`b^{l+1}_i = b^l_i` of eq. 17).
    #[must_use]
    pub fn inject(&self, fine: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.retained.par_iter().map(|&i| fine[i as usize]).collect()
    }

    /// Column `c` of `P`: the fine rows and weights.
    pub(crate) fn column(&self, c: usize) -> (&[u32], &[f64]) {
        let (s, e) = (self.t_ptr[c], self.t_ptr[c + 1]);
        (&self.t_rows[s..e], &self.t_weights[s..e])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_general_operator_from_csr_is_checked_and_restricts_with_its_transpose() {
        // P (4 × 3): rows [0: ½ c0 + ½ c2], [1: empty], [2: c1 − 2 c1 (summed)], [3: 3 c0].
        let p = Prolongation::from_csr(3, vec![0, 2, 2, 4, 5], vec![0, 2, 1, 1, 0], vec![0.5, 0.5, 1.0, -2.0, 3.0]).unwrap();
        assert_eq!((p.n_fine(), p.n_coarse()), (4, 3));
        assert!(p.retained().is_empty() && p.coarse_of(0).is_none());
        let coarse = [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]];
        let mut fine = vec![[1.0; 3]; 4];
        p.prolong_add(&coarse, &mut fine);
        assert_eq!(fine, vec![[5.0, 6.0, 7.0], [1.0; 3], [-3.0, -4.0, -5.0], [4.0, 7.0, 10.0]]);
        let r = [[1.0, 0.0, 2.0], [5.0, 5.0, 5.0], [1.0, 1.0, 1.0], [0.0, 1.0, 0.0]];
        let mut rc = vec![[0.0; 3]; 3];
        p.restrict(&r, &mut rc);
        assert_eq!(rc, vec![[0.5, 3.0, 1.0], [-1.0, -1.0, -1.0], [0.5, 0.0, 1.0]]);
        let bad = |rp: Vec<usize>, c: Vec<u32>, w: Vec<f64>| Prolongation::from_csr(3, rp, c, w).unwrap_err();
        assert!(matches!(bad(vec![], vec![], vec![]), SparseError::DimensionMismatch { .. }));
        assert!(matches!(bad(vec![1, 1], vec![0], vec![1.0]), SparseError::DimensionMismatch { found: 1, .. }));
        assert!(matches!(bad(vec![0, 2], vec![0], vec![1.0]), SparseError::DimensionMismatch { found: 2, .. }));
        assert!(matches!(bad(vec![0, 1], vec![0], vec![]), SparseError::DimensionMismatch { found: 0, .. }));
        assert!(matches!(bad(vec![0, 2, 1, 2], vec![0, 1], vec![1.0; 2]), SparseError::InvalidOption(m) if m.contains("row 1")));
        assert!(matches!(bad(vec![0, 1], vec![3], vec![1.0]), SparseError::IndexOutOfRange { index: 3, n: 3, .. }));
        let e = bad(vec![0, 1, 1, 2], vec![0, 1], vec![1.0, f64::NAN]);
        assert!(matches!(&e, SparseError::InvalidOption(m) if m.contains("row 2")), "{e}");
    }
}
