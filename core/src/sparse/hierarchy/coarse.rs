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
//! order: deterministic for any number of threads. [`galerkin`] accumulates each coarse row's
//! products in a dense per-task array indexed by column (every column's terms added in the
//! fixed order of the triple loop), then orders the row's distinct columns: no sort of the
//! products themselves.

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

/// Row `c` of `Pᵀ M P` before symmetrisation: its distinct columns in the order first reached
/// and their sums, every column's terms added in the fixed order of the triple loop (column `c`
/// of `P`, row `u` of `M`, row `v` of `P`); the diagonal is always listed. `stamp` and `slot`
/// are scratch arrays of the coarse size (`stamp[d] == c + 1` marks column `d` as listed, at
/// `slot[d]`), all zero or marked by other rows.
fn galerkin_row(a: &CsrMatrix3, p: &Prolongation, c: usize, stamp: &mut [u32], slot: &mut [u32]) -> (Vec<u32>, Vec<[f64; 3]>) {
    let (ap, vals) = (a.pattern(), a.values());
    let mark = c as u32 + 1;
    let mut cols: Vec<u32> = Vec::new();
    let mut sums: Vec<[f64; 3]> = Vec::new();
    let (fr, fw) = p.column(c);
    for (&u, &wu) in fr.iter().zip(fw) {
        let u = u as usize;
        for k in ap.row_ptr()[u]..ap.row_ptr()[u + 1] {
            let v = ap.col_idx()[k] as usize;
            let muv = vals[k];
            let (pc, pw) = p.row(v);
            for (&d, &wv) in pc.iter().zip(pw) {
                let s = wu * wv;
                let term = [muv[0] * s, muv[1] * s, muv[2] * s];
                let d = d as usize;
                if stamp[d] == mark {
                    let o = &mut sums[slot[d] as usize];
                    for ch in 0..3 {
                        o[ch] += term[ch];
                    }
                } else {
                    stamp[d] = mark;
                    slot[d] = cols.len() as u32;
                    cols.push(d as u32);
                    sums.push(term);
                }
            }
        }
    }
    if stamp[c] != mark {
        cols.push(c as u32);
        sums.push([0.0; 3]);
    }
    (cols, sums)
}

/// `Pᵀ M P`, exactly symmetrised (see the module documentation).
///
/// # Errors
/// [`SparseError::DimensionMismatch`] if `a` and `p` differ in size.
pub fn galerkin(a: &CsrMatrix3, p: &Prolongation) -> Result<CsrMatrix3, SparseError> {
    check_sizes(a, p)?;
    let m = p.n_coarse();
    let rows: Vec<(Vec<u32>, Vec<[f64; 3]>)> = (0..m)
        .into_par_iter()
        .with_min_len(256)
        .map_init(
            || (vec![0u32; m], vec![0u32; m]),
            |(stamp, slot), c| {
                let (cols, sums) = galerkin_row(a, p, c, stamp, slot);
                // Columns are distinct: order them by column.
                let mut order: Vec<u32> = (0..cols.len() as u32).collect();
                order.sort_unstable_by_key(|&t| cols[t as usize]);
                (order.iter().map(|&t| cols[t as usize]).collect(), order.iter().map(|&t| sums[t as usize]).collect())
            },
        )
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

/// Brings `coarse = Pᵀ M_old P` ([`galerkin`] of `M` before a change) up to date after `M`
/// (now `a`, same pattern, symmetric) changed only in the rows `fine_rows` (and therefore only in
/// their columns): the coarse rows `c` with `P_uc ≠ 0` for a changed `u` are recomputed, every
/// other entry of `Pᵀ M P` keeps its terms. The result equals [`galerkin`]`(a, p)` bit for bit
/// (the recomputed rows sum in the same order; an entry between a recomputed and a kept row is
/// the mean of two sums that did not change). Returns the recomputed coarse rows, ascending:
/// the only rows in which the coarse operator can have changed.
///
/// # Errors
/// [`SparseError::DimensionMismatch`] for mismatched sizes; [`SparseError::IndexOutOfRange`]
/// for a row outside `a`; [`SparseError::NotInPattern`] if `coarse` is not the Galerkin
/// operator of `a`'s pattern (then `coarse` may be partly updated).
pub fn galerkin_rows(a: &CsrMatrix3, p: &Prolongation, coarse: &mut CsrMatrix3, fine_rows: &[u32]) -> Result<Vec<u32>, SparseError> {
    check_sizes(a, p)?;
    let m = p.n_coarse();
    if coarse.n() != m {
        return Err(SparseError::DimensionMismatch { what: "coarse operator rows", expected: m, found: coarse.n() });
    }
    let mut hit = vec![false; m];
    for &u in fine_rows {
        if u as usize >= a.n() {
            return Err(SparseError::IndexOutOfRange { what: "changed fine row".into(), index: u64::from(u), n: a.n() });
        }
        for &d in p.row(u as usize).0 {
            hit[d as usize] = true;
        }
    }
    let rows: Vec<u32> = (0..m as u32).filter(|&c| hit[c as usize]).collect();
    // The unsymmetrised sums of every recomputed row, in the coarse pattern's column order.
    let pattern = Arc::clone(coarse.pattern());
    let sums: Vec<Vec<[f64; 3]>> = rows
        .par_iter()
        .map_init(
            || (vec![0u32; m], vec![0u32; m]),
            |(stamp, slot), &c| {
                let c = c as usize;
                let (cols, sums) = galerkin_row(a, p, c, stamp, slot);
                let row = pattern.row(c);
                if cols.len() != row.len() {
                    return Err(SparseError::NotInPattern { row: c, col: cols.iter().find(|d| row.binary_search(d).is_err()).map_or(c, |&d| d as usize) });
                }
                let mut out = vec![[0.0; 3]; row.len()];
                for (&d, s) in cols.iter().zip(sums) {
                    let pos = row.binary_search(&d).map_err(|_| SparseError::NotInPattern { row: c, col: d as usize })?;
                    out[pos] = s;
                }
                Ok(out)
            },
        )
        .collect::<Result<_, _>>()?;
    let slot_of = |c: usize| rows.binary_search(&(c as u32)).ok();
    let values = coarse.values_mut();
    for (r, &c) in rows.iter().enumerate() {
        let c = c as usize;
        for (t, k) in (pattern.row_ptr()[c]..pattern.row_ptr()[c + 1]).enumerate() {
            let d = pattern.col_idx()[k] as usize;
            // Only entries between two recomputed rows can change (see above).
            if let Some(rd) = slot_of(d) {
                let mirror = pattern.row(d).binary_search(&(c as u32)).expect("a Galerkin pattern is symmetric");
                values[k] = [0, 1, 2].map(|ch| 0.5 * (sums[r][t][ch] + sums[rd][mirror][ch]));
            }
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::sparse::Triplet;

    /// `Pᵀ M P` the plain way: every product `(column, value)` listed, stably sorted by column
    /// and summed in list order, then symmetrised.
    fn galerkin_by_sorting(a: &CsrMatrix3, p: &Prolongation) -> CsrMatrix3 {
        let (ap, vals, m) = (a.pattern(), a.values(), p.n_coarse());
        let mut trips = Vec::new();
        for c in 0..m {
            let mut acc: Vec<(u32, [f64; 3])> = Vec::new();
            let (fr, fw) = p.column(c);
            for (&u, &wu) in fr.iter().zip(fw) {
                for k in ap.row_ptr()[u as usize]..ap.row_ptr()[u as usize + 1] {
                    let (pc, pw) = p.row(ap.col_idx()[k] as usize);
                    for (&d, &wv) in pc.iter().zip(pw) {
                        let s = wu * wv;
                        acc.push((d, vals[k].map(|x| x * s)));
                    }
                }
            }
            acc.sort_by_key(|e| e.0);
            let mut merged: Vec<(u32, [f64; 3])> = Vec::new();
            for (d, v) in acc {
                match merged.last_mut() {
                    Some(last) if last.0 == d => (0..3).for_each(|ch| last.1[ch] += v[ch]),
                    _ => merged.push((d, v)),
                }
            }
            trips.extend(merged.into_iter().map(|(d, v)| Triplet::new(c as u32, d, v)));
        }
        let g = CsrMatrix3::from_triplets(m, &trips).unwrap();
        let pat = g.pattern();
        let sym = (0..m)
            .flat_map(|r| (pat.row_ptr()[r]..pat.row_ptr()[r + 1]).map(move |k| (r, k)))
            .map(|(r, k)| {
                let t = pat.position(pat.col_idx()[k] as usize, r).unwrap();
                [0, 1, 2].map(|ch| 0.5 * (g.values()[k][ch] + g.values()[t][ch]))
            })
            .collect();
        CsrMatrix3::new(Arc::clone(pat), sym).unwrap()
    }

    #[test]
    fn galerkin_equals_the_sorted_product_bit_for_bit() {
        // A path-and-rungs graph (a ladder 2 × 300) with uneven weights and positions.
        let n = 600;
        let mut edges = Vec::new();
        for i in 0..300u32 {
            edges.push([i, i + 300]);
            if i + 1 < 300 {
                edges.push([i, i + 1]);
                edges.push([i + 300, i + 301]);
                edges.push([i, i + 301]);
            }
        }
        let graph = Arc::new(CsrPattern::from_edges(n, &edges).unwrap());
        let positions: Vec<DVec3> =
            (0..n).map(|i| DVec3::new((i % 300) as f64 + 0.1 * ((i * 37) % 7) as f64, (i / 300) as f64, 0.0)).collect();
        let mut trips = Vec::new();
        for (e, &[i, j]) in edges.iter().enumerate() {
            let w = [1.0, 0.5, 0.25].map(|k| -k * (1.0 + ((e * 13) % 11) as f64 / 7.0));
            trips.extend([Triplet::new(i, j, w), Triplet::new(j, i, w), Triplet::new(i, i, w.map(|t| -t)), Triplet::new(j, j, w.map(|t| -t))]);
        }
        for i in 0..n as u32 {
            trips.push(Triplet::new(i, i, [0.1, 0.2, 0.3]));
        }
        let a = CsrMatrix3::from_triplets_with_pattern(Arc::clone(&graph), &trips).unwrap();
        // Every other vertex of each rail retained, the rest interpolated from retained neighbours.
        let retained: Vec<u32> = (0..n as u32).filter(|i| (i % 300) % 2 == 0).collect();
        let p = Prolongation::new(&graph, &positions, &retained).unwrap();
        let g = galerkin(&a, &p).unwrap();
        let reference = galerkin_by_sorting(&a, &p);
        assert_eq!(g.pattern().row_ptr(), reference.pattern().row_ptr());
        assert_eq!(g.pattern().col_idx(), reference.pattern().col_idx());
        assert_eq!(g.values(), reference.values());
        assert!(g.is_symmetric(0.0));
        // And the next level, from the Galerkin operator (wider rows).
        let retained2: Vec<u32> = (0..p.n_coarse() as u32).filter(|i| i % 2 == 0).collect();
        let graph2 = Arc::clone(g.pattern());
        let pos2: Vec<DVec3> = retained.iter().map(|&i| positions[i as usize]).collect();
        let p2 = Prolongation::new(&graph2, &pos2, &retained2).unwrap();
        assert_eq!(galerkin(&g, &p2).unwrap().values(), galerkin_by_sorting(&g, &p2).values());

        // A symmetric change in rows 100..110 (their diagonals and the couplings among them):
        // recomputing the coarse rows they reach gives the Galerkin operator of the new matrix.
        let rows: Vec<u32> = (100..110).collect();
        let mut changed = a.clone();
        for &i in &rows {
            for k in graph.row_ptr()[i as usize]..graph.row_ptr()[i as usize + 1] {
                let j = graph.col_idx()[k];
                if rows.contains(&j) {
                    changed.values_mut()[k] = changed.values()[k].map(|x| if j == i { x + 2.5 } else { 1.7 * x });
                }
            }
        }
        let mut updated = g.clone();
        let coarse_rows = galerkin_rows(&changed, &p, &mut updated, &rows).unwrap();
        let fresh = galerkin(&changed, &p).unwrap();
        assert_eq!(updated.values(), fresh.values());
        // Only the coarse rows the changed rows interpolate to were recomputed, and they changed.
        let mut reached: Vec<u32> = rows.iter().flat_map(|&u| p.row(u as usize).0.to_vec()).collect();
        reached.sort_unstable();
        reached.dedup();
        assert_eq!(coarse_rows, reached);
        assert!(coarse_rows.len() < p.n_coarse() / 10);
        assert_ne!(g.values(), fresh.values());
        assert!(matches!(galerkin_rows(&changed, &p, &mut updated, &[n as u32]), Err(SparseError::IndexOutOfRange { .. })));
    }
}
