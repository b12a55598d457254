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
//! order: deterministic for any number of threads. [`galerkin`] works in two stages: the rows
//! of `M P` first ([`ap_rows`]), then each coarse row `c` as `Σ_u P_uc (M P)_u` over column `c`
//! of `P` ([`ptap_rows`]); a fine row's `M P` row is computed once instead of once per coarse
//! vertex it interpolates from. Each stage accumulates a row's terms through per-task arrays
//! indexed by column into per-task output blocks (every column's terms added in a fixed order),
//! then the row's distinct columns are ordered: no sort of the products themselves.
//! [`galerkin_rows`] recomputes chosen coarse rows the same way, bit for bit.

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
            let row = ap.row_ptr()[i]..ap.row_ptr()[i + 1];
            for (&j, &m) in ap.col_idx()[row.clone()].iter().zip(&vals[row]) {
                let (pc, pw) = p.row(j as usize);
                for (&d, &w) in pc.iter().zip(pw) {
                    let pos = cols.binary_search(&d).map_err(|_| SparseError::NotInPattern { row: c, col: d as usize })?;
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

/// Sparse rows stored back to back: row `r`'s `(column, value)` entries are
/// `entries[start[r]..start[r + 1]]`.
struct Rows {
    start: Vec<usize>,
    entries: Vec<(u32, [f64; 3])>,
}

impl Rows {
    fn row(&self, r: usize) -> &[(u32, [f64; 3])] {
        &self.entries[self.start[r]..self.start[r + 1]]
    }

    /// Row by row, `count` rows (in parallel blocks, concatenated in order): `fill(i, acc,
    /// out)` appends row `i`'s entries to `out` through `acc`.
    fn build(count: usize, m: usize, fill: impl Fn(usize, &mut Accumulator, &mut Vec<(u32, [f64; 3])>) + Sync) -> Self {
        let per_task = count.div_ceil(8 * rayon::current_num_threads()).max(1);
        let blocks: Vec<Self> = (0..count.div_ceil(per_task))
            .into_par_iter()
            .map(|b| {
                let mut acc = Accumulator::new(m);
                let rows = b * per_task..((b + 1) * per_task).min(count);
                let mut out = Self { start: Vec::with_capacity(rows.len()), entries: Vec::new() };
                for i in rows {
                    out.start.push(out.entries.len());
                    acc.start_row();
                    fill(i, &mut acc, &mut out.entries);
                }
                out
            })
            .collect();
        let mut all = Self {
            start: Vec::with_capacity(count + 1),
            entries: Vec::with_capacity(blocks.iter().map(|b| b.entries.len()).sum()),
        };
        for b in blocks {
            let offset = all.entries.len();
            all.start.extend(b.start.iter().map(|s| s + offset));
            all.entries.extend_from_slice(&b.entries);
        }
        all.start.push(all.entries.len());
        all
    }
}

/// Scratch of a sparse row accumulation over columns `0..m`: `stamp[d] == mark` says column `d`
/// is in the current row, at `slot[d]` of the output.
struct Accumulator {
    stamp: Vec<u32>,
    slot: Vec<usize>,
    mark: u32,
}

impl Accumulator {
    fn new(m: usize) -> Self {
        Self { stamp: vec![0; m], slot: vec![0; m], mark: 0 }
    }

    fn start_row(&mut self) {
        self.mark = self.mark.wrapping_add(1);
        if self.mark == 0 {
            self.stamp.fill(0);
            self.mark = 1;
        }
    }

    /// Adds `term` to column `d` of the current row (its first term is its start value, not
    /// `0 + term`; columns are listed in the order first reached).
    #[inline(always)]
    fn add(&mut self, d: u32, term: [f64; 3], out: &mut Vec<(u32, [f64; 3])>) {
        let du = d as usize;
        if self.stamp[du] == self.mark {
            let o = &mut out[self.slot[du]].1;
            o[0] += term[0];
            o[1] += term[1];
            o[2] += term[2];
        } else {
            self.stamp[du] = self.mark;
            self.slot[du] = out.len();
            out.push((d, term));
        }
    }

    fn contains(&self, d: usize) -> bool {
        self.stamp[d] == self.mark
    }
}

/// The rows `rows` of `M P`: row `u` is `Σ_v M_uv P_v`, over row `u` of `M` in column order and
/// each row `v` of `P` in its order.
fn ap_rows(a: &CsrMatrix3, p: &Prolongation, rows: &[u32]) -> Rows {
    let (ap, vals) = (a.pattern(), a.values());
    Rows::build(rows.len(), p.n_coarse(), |r, acc, out| {
        let u = rows[r] as usize;
        let row = ap.row_ptr()[u]..ap.row_ptr()[u + 1];
        for (&j, &m) in ap.col_idx()[row.clone()].iter().zip(&vals[row]) {
            let (pc, pw) = p.row(j as usize);
            for (&d, &w) in pc.iter().zip(pw) {
                acc.add(d, [m[0] * w, m[1] * w, m[2] * w], out);
            }
        }
    })
}

/// The rows `rows` of `Pᵀ (M P)` before symmetrisation, each with its columns ascending: row `c`
/// is `Σ_u P_uc (M P)_u` over column `c` of `P` in its order, `ap(u)` giving row `u` of `M P`.
/// The diagonal is always listed.
fn ptap_rows<'r>(p: &Prolongation, rows: &[u32], ap: impl Fn(usize) -> &'r [(u32, [f64; 3])] + Sync) -> Rows {
    Rows::build(rows.len(), p.n_coarse(), |r, acc, out| {
        let c = rows[r] as usize;
        let first = out.len();
        let (fr, fw) = p.column(c);
        for (&u, &w) in fr.iter().zip(fw) {
            for &(d, v) in ap(u as usize) {
                acc.add(d, [v[0] * w, v[1] * w, v[2] * w], out);
            }
        }
        if !acc.contains(c) {
            out.push((c as u32, [0.0; 3]));
        }
        // Columns are distinct: order them by column.
        out[first..].sort_unstable_by_key(|e| e.0);
    })
}

/// `Pᵀ M P`, exactly symmetrised (see the module documentation).
///
/// # Errors
/// [`SparseError::DimensionMismatch`] if `a` and `p` differ in size.
pub fn galerkin(a: &CsrMatrix3, p: &Prolongation) -> Result<CsrMatrix3, SparseError> {
    check_sizes(a, p)?;
    let m = p.n_coarse();
    let mp = ap_rows(a, p, &(0..a.n() as u32).collect::<Vec<_>>());
    let rows = ptap_rows(p, &(0..m as u32).collect::<Vec<_>>(), |u| mp.row(u));
    drop(mp);
    let (col_idx, values): (Vec<u32>, Vec<[f64; 3]>) = rows.entries.into_iter().unzip();
    let pattern = Arc::new(CsrPattern::from_csr(m, rows.start, col_idx)?);
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
/// operator of `a`'s pattern. `coarse` is unchanged on error.
pub fn galerkin_rows(
    a: &CsrMatrix3,
    p: &Prolongation,
    coarse: &mut CsrMatrix3,
    fine_rows: &[u32],
) -> Result<Vec<u32>, SparseError> {
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
    // The rows of `M P` those coarse rows need: the fine rows of their columns of `P`.
    let mut need = vec![false; a.n()];
    for &c in &rows {
        for &u in p.column(c as usize).0 {
            need[u as usize] = true;
        }
    }
    let fine: Vec<u32> = (0..a.n() as u32).filter(|&u| need[u as usize]).collect();
    let mp = ap_rows(a, p, &fine);
    let new_rows =
        ptap_rows(p, &rows, |u| mp.row(fine.binary_search(&(u as u32)).expect("the fine rows of the recomputed columns")));
    let pattern = Arc::clone(coarse.pattern());
    for (r, &c) in rows.iter().enumerate() {
        let c = c as usize;
        let row = new_rows.row(r);
        if row.len() != pattern.row(c).len() || row.iter().zip(pattern.row(c)).any(|(e, &d)| e.0 != d) {
            let col = row.iter().find(|e| pattern.row(c).binary_search(&e.0).is_err()).map_or(c, |e| e.0 as usize);
            return Err(SparseError::NotInPattern { row: c, col });
        }
    }
    // Entries between two recomputed rows are the mean of their two new sums; the others keep
    // their values (see above).
    let mut slot = vec![u32::MAX; m];
    for (r, &c) in rows.iter().enumerate() {
        slot[c as usize] = r as u32;
    }
    let updated: Vec<Vec<(usize, [f64; 3])>> = rows
        .par_iter()
        .enumerate()
        .map(|(r, &c)| {
            let c = c as usize;
            (pattern.row_ptr()[c]..pattern.row_ptr()[c + 1])
                .zip(new_rows.row(r))
                .filter_map(|(k, &(_, own))| {
                    let d = pattern.col_idx()[k] as usize;
                    let rd = slot[d];
                    (rd != u32::MAX).then(|| {
                        let mirror = pattern.row(d).binary_search(&(c as u32)).expect("a Galerkin pattern is symmetric");
                        (k, [0, 1, 2].map(|ch| 0.5 * (own[ch] + new_rows.row(rd as usize)[mirror].1[ch])))
                    })
                })
                .collect()
        })
        .collect();
    let values = coarse.values_mut();
    for (k, v) in updated.into_iter().flatten() {
        values[k] = v;
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::*;
    use crate::sparse::fixtures::diffusion_matrix;
    use crate::sparse::Triplet;

    /// Sums `(column, value)` terms per column in list order (a stable sort by column).
    fn merged(mut terms: Vec<(u32, [f64; 3])>) -> Vec<(u32, [f64; 3])> {
        terms.sort_by_key(|e| e.0);
        let mut out: Vec<(u32, [f64; 3])> = Vec::new();
        for (d, v) in terms {
            match out.last_mut() {
                Some(last) if last.0 == d => (0..3).for_each(|ch| last.1[ch] += v[ch]),
                _ => out.push((d, v)),
            }
        }
        out
    }

    /// `Pᵀ (M P)` the plain way: every product `(column, value)` listed, stably sorted by column
    /// and summed in list order — the rows of `M P` first, then those of `Pᵀ (M P)` — then
    /// symmetrised.
    fn galerkin_by_sorting(a: &CsrMatrix3, p: &Prolongation) -> CsrMatrix3 {
        let (ap, vals, m) = (a.pattern(), a.values(), p.n_coarse());
        let mp: Vec<Vec<(u32, [f64; 3])>> = (0..a.n())
            .map(|u| {
                let mut terms = Vec::new();
                let row = ap.row_ptr()[u]..ap.row_ptr()[u + 1];
                for (&j, v) in ap.col_idx()[row.clone()].iter().zip(&vals[row]) {
                    let (pc, pw) = p.row(j as usize);
                    terms.extend(pc.iter().zip(pw).map(|(&d, &w)| (d, v.map(|x| x * w))));
                }
                merged(terms)
            })
            .collect();
        let mut trips = Vec::new();
        for c in 0..m {
            let mut terms = Vec::new();
            let (fr, fw) = p.column(c);
            for (&u, &w) in fr.iter().zip(fw) {
                terms.extend(mp[u as usize].iter().map(|&(d, v)| (d, v.map(|x| x * w))));
            }
            trips.extend(merged(terms).into_iter().map(|(d, v)| Triplet::new(c as u32, d, v)));
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
        let positions: Vec<DVec3> =
            (0..n).map(|i| DVec3::new((i % 300) as f64 + 0.1 * ((i * 37) % 7) as f64, (i / 300) as f64, 0.0)).collect();
        let coupling = |e: usize, _| [1.0, 0.5, 0.25].map(|k| k * (1.0 + ((e * 13) % 11) as f64 / 7.0));
        let a = diffusion_matrix(n, &edges, coupling, [0.1, 0.2, 0.3]);
        let graph = Arc::clone(a.pattern());
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
