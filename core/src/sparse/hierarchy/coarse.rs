//! Coarse-level operators.
//!
//! * [`substituted`]: TransCut eq. 17. Substituting the interpolation (eq. 16) into the
//!   equations (eq. 15) of the retained vertices gives, for a retained vertex `i`,
//!   `M^{l+1}_{ik} = Σ_{j ∈ N^l(i) ∪ {i}} M^l_{ij} P_{jk}` (with `P_{jk} = λ_jk / λ_j` for a dropped
//!   `j` and `P_{jj} = 1` for a retained one) and `b^{l+1}_i = b^l_i`: the diagonal picks up
//!   `Σ_{j ∈ K(i)} M_ij λ_ji / λ_j`, the retained neighbours `M_ij` plus the same sums, and the
//!   vertices reached through dropped neighbours only the sums — exactly the three cases of
//!   eq. 17. In matrix form `M^{l+1} = E M^l P` with `E` the row injection of the retained
//!   vertices. Not symmetric; every entry lies in the coarse edge set of §4.1.2 (a retained `i`
//!   and a `k ∈ R(j)` of a dropped neighbour `j` are two-ring neighbours through `j`).
//! * [`galerkin`]: `M^{l+1} = Pᵀ M^l P`, the symmetric (SPD for SPD `M^l` and full-rank `P`)
//!   Galerkin operator the multigrid preconditioner uses; its pattern may extend beyond the
//!   coarse edge set, so it is built from the products. Symmetrised exactly (the mean of the
//!   two mirrored sums), so CG sees a symmetric preconditioner.
//!
//! Both act per channel with the same `P`, rows computed in parallel, each summed in a fixed
//! order: deterministic for any number of threads.

use std::sync::Arc;

use rayon::prelude::*;

use super::interpolation::Prolongation;
use crate::sparse::{CsrMatrix3, CsrPattern, SparseError};

/// TransCut eq. 17: `E M P` on the coarse graph's pattern (see the module documentation).
///
/// # Errors
/// [`SparseError::NotInPattern`] if an entry falls outside `coarse_pattern` (a hierarchy that
/// does not belong to this matrix), [`SparseError::DimensionMismatch`] for mismatched sizes.
pub fn substituted(a: &CsrMatrix3, p: &Prolongation, coarse_pattern: &Arc<CsrPattern>) -> Result<CsrMatrix3, SparseError> {
    check_sizes(a, p)?;
    if coarse_pattern.n() != p.n_coarse() {
        return Err(SparseError::DimensionMismatch {
            what: "coarse pattern rows",
            expected: p.n_coarse(),
            found: coarse_pattern.n(),
        });
    }
    let ap = a.pattern();
    let vals = a.values();
    let rows: Result<Vec<Vec<[f64; 3]>>, SparseError> = (0..p.n_coarse())
        .into_par_iter()
        .map(|c| {
            let i = p.retained()[c] as usize;
            let cols = coarse_pattern.row(c);
            let mut out = vec![[0.0; 3]; cols.len()];
            for k in ap.row_ptr()[i]..ap.row_ptr()[i + 1] {
                let j = ap.col_idx()[k] as usize;
                let m = vals[k];
                let (pc, pw) = p.row(j);
                for (&d, &w) in pc.iter().zip(pw) {
                    let pos = cols
                        .binary_search(&d)
                        .map_err(|_| SparseError::NotInPattern { row: c, col: d as usize })?;
                    for ch in 0..3 {
                        out[pos][ch] += m[ch] * w;
                    }
                }
            }
            Ok(out)
        })
        .collect();
    let values: Vec<[f64; 3]> = rows?.into_iter().flatten().collect();
    CsrMatrix3::new(Arc::clone(coarse_pattern), values)
}

fn check_sizes(a: &CsrMatrix3, p: &Prolongation) -> Result<(), SparseError> {
    if a.n() != p.n_fine() {
        return Err(SparseError::DimensionMismatch { what: "matrix rows (fine vertices)", expected: p.n_fine(), found: a.n() });
    }
    Ok(())
}

/// `Pᵀ M P`, exactly symmetrised (see the module documentation).
///
/// # Errors
/// [`SparseError::DimensionMismatch`] if `a` and `p` differ in size.
pub fn galerkin(a: &CsrMatrix3, p: &Prolongation) -> Result<CsrMatrix3, SparseError> {
    check_sizes(a, p)?;
    let ap = a.pattern();
    let vals = a.values();
    let m = p.n_coarse();
    let rows: Vec<(Vec<u32>, Vec<[f64; 3]>)> = (0..m)
        .into_par_iter()
        .map(|c| {
            let mut acc: Vec<(u32, [f64; 3])> = Vec::new();
            let (fr, fw) = p.column(c);
            for (&u, &wu) in fr.iter().zip(fw) {
                let u = u as usize;
                for k in ap.row_ptr()[u]..ap.row_ptr()[u + 1] {
                    let v = ap.col_idx()[k] as usize;
                    let muv = vals[k];
                    let (pc, pw) = p.row(v);
                    for (&d, &wv) in pc.iter().zip(pw) {
                        let s = wu * wv;
                        acc.push((d, [muv[0] * s, muv[1] * s, muv[2] * s]));
                    }
                }
            }
            acc.sort_by_key(|e| e.0); // stable: equal columns keep their (fixed) order
            let mut cols: Vec<u32> = Vec::new();
            let mut out: Vec<[f64; 3]> = Vec::new();
            for (d, v) in acc {
                if cols.last() == Some(&d) {
                    let o = out.last_mut().expect("pushed with its column");
                    for ch in 0..3 {
                        o[ch] += v[ch];
                    }
                } else {
                    cols.push(d);
                    out.push(v);
                }
            }
            if cols.binary_search(&(c as u32)).is_err() {
                let pos = cols.partition_point(|&x| x < c as u32);
                cols.insert(pos, c as u32);
                out.insert(pos, [0.0; 3]);
            }
            (cols, out)
        })
        .collect();
    let mut row_ptr = Vec::with_capacity(m + 1);
    row_ptr.push(0);
    let mut col_idx = Vec::new();
    let mut values = Vec::new();
    for (c, v) in rows {
        col_idx.extend_from_slice(&c);
        values.extend_from_slice(&v);
        row_ptr.push(col_idx.len());
    }
    let pattern = Arc::new(CsrPattern::from_csr(m, row_ptr, col_idx)?);
    // Exact symmetry: the pattern is symmetric (M's is), so average mirrored entries.
    let sym: Vec<[f64; 3]> = (0..m)
        .into_par_iter()
        .flat_map_iter(|r| {
            let pat = &pattern;
            let vals = &values;
            (pat.row_ptr()[r]..pat.row_ptr()[r + 1]).map(move |k| {
                let c = pat.col_idx()[k] as usize;
                match pat.position(c, r) {
                    Some(t) => [0, 1, 2].map(|ch| 0.5 * (vals[k][ch] + vals[t][ch])),
                    None => vals[k],
                }
            })
        })
        .collect();
    CsrMatrix3::new(pattern, sym)
}
