//! Smoothed aggregation (Vaněk, Mandel & Brezina, Computing 56, 1996): an algebraic hierarchy
//! for the same V-cycle ([`super::Multigrid`]) as an alternative to the §4 independent sets.
//!
//! Per level, with `A` the level's operator:
//!
//! 1. **Aggregates** ([`aggregates`]): the standard three-pass greedy aggregation on the graph of
//!    `A` (every off-diagonal entry counts as a strong connection: the diffusion operator is an
//!    isotropic Laplacian plus a diagonal, so no connection is weak). Pass 1 makes each vertex
//!    whose neighbours are all free a root with its neighbourhood as aggregate; pass 2 adds each
//!    free vertex to a neighbouring aggregate; pass 3 groups what is left with its free
//!    neighbours. Sequential in vertex order, hence deterministic.
//! 2. **Tentative prolongation** `P̂`: `P̂_ic = 1` if vertex `i` lies in aggregate `c` (the
//!    constant is the operator's near-null space).
//! 3. **Smoothed prolongation** ([`smoothed_prolongation`]): `P = (I − ω/ρ D⁻¹S) P̂`, one damped
//!    Jacobi step with `ω = 4/3` and `ρ` the Gershgorin bound of the spectrum of `D⁻¹S`, `S` the
//!    sum of the three channels' operators. One `P` serves all three channels, so the coarse
//!    operators share one pattern like the level-0 matrix.
//! 4. **Coarse operator** `Pᵀ A P` ([`super::galerkin`]), per channel.
//!
//! Aggregates hold one vertex and its neighbours, about 15–25 vertices on a tetrahedral mesh,
//! so the levels shrink 15–25-fold and the coarse operators stay small (their nonzeros sum to a
//! few percent of the level-0 matrix's), where the §4 hierarchy shrinks 3-fold and its Galerkin
//! operators fill in. The V-cycle on these levels therefore costs little more than its level-0
//! smoothing.

use std::sync::Arc;

use glam::DVec3;
use rayon::prelude::*;

use super::{galerkin, Hierarchy, HierarchyKind, HierarchyOptions, Level, Prolongation};
use crate::sparse::{CsrMatrix3, CsrPattern, SparseError};

/// Damping of the prolongation smoother, `ω` of `P = (I − ω/ρ D⁻¹S) P̂` (the classical 4/3).
const PROLONGATION_OMEGA: f64 = 4.0 / 3.0;

/// The standard aggregation of a symmetric graph (Vaněk et al. 1996, §3): the aggregate of
/// every vertex (`u32`) and the aggregate count. Every vertex lies in an aggregate with at
/// least one of its neighbours unless it has none.
#[must_use]
pub fn aggregates(graph: &CsrPattern) -> (Vec<u32>, usize) {
    const FREE: u32 = u32::MAX;
    let n = graph.n();
    let mut agg = vec![FREE; n];
    let mut count = 0u32;
    let neighbours = |i: usize| graph.row(i).iter().map(|&j| j as usize).filter(move |&j| j != i);
    // Pass 1: roots whose whole neighbourhood is free.
    for i in 0..n {
        if agg[i] == FREE && neighbours(i).all(|j| agg[j] == FREE) {
            agg[i] = count;
            for j in neighbours(i) {
                agg[j] = count;
            }
            count += 1;
        }
    }
    // Pass 2: free vertices join a neighbouring aggregate of pass 1 (the first one, in column
    // order); the aggregates of pass 1 are all that exists yet, so the choice does not depend
    // on the order of this pass.
    let pass1 = agg.clone();
    for (i, a) in agg.iter_mut().enumerate() {
        if *a == FREE {
            if let Some(j) = neighbours(i).find(|&j| pass1[j] != FREE) {
                *a = pass1[j];
            }
        }
    }
    // Pass 3: what is left (vertices whose neighbours are all still free) groups with its free
    // neighbours.
    for i in 0..n {
        if agg[i] == FREE {
            agg[i] = count;
            for j in neighbours(i) {
                if agg[j] == FREE {
                    agg[j] = count;
                }
            }
            count += 1;
        }
    }
    (agg, count as usize)
}

/// The smoothed prolongation `P = (I − ω/ρ D⁻¹S) P̂` of aggregates `agg` (`count` of them) for
/// the operator `a`, `S = Σ_c A_c` its channel sum, `ρ = max_i Σ_j |s_ij| / s_ii` (Vaněk et al.
/// 1996, eq. 3.3 with the Gershgorin bound for the spectral radius).
///
/// # Errors
/// [`SparseError::NonPositiveDiagonal`] if a diagonal entry of `S` is not positive.
pub fn smoothed_prolongation(a: &CsrMatrix3, agg: &[u32], count: usize) -> Result<Prolongation, SparseError> {
    /// Rows per parallel task.
    const ROWS: usize = 2048;
    let p = a.pattern();
    let sum = |k: usize| a.values()[k].iter().sum::<f64>();
    let diagonal: Vec<f64> = p.diagonal_positions().iter().map(|&k| sum(k)).collect();
    if let Some(i) = diagonal.iter().position(|&d| !(d > 0.0 && d.is_finite())) {
        return Err(SparseError::NonPositiveDiagonal { row: i, channel: 0, value: diagonal[i] });
    }
    let rho = (0..p.n())
        .into_par_iter()
        .map(|i| (p.row_ptr()[i]..p.row_ptr()[i + 1]).map(|k| sum(k).abs()).sum::<f64>() / diagonal[i])
        .reduce(|| 0.0, f64::max);
    let damping = PROLONGATION_OMEGA / rho;
    // Each task fills its rows' lengths, columns and weights; a row gathers its few distinct
    // aggregates by linear search (in column order), then sorts them.
    let blocks: Vec<(Vec<usize>, Vec<u32>, Vec<f64>)> = (0..p.n().div_ceil(ROWS))
        .into_par_iter()
        .map(|b| {
            let rows = b * ROWS..((b + 1) * ROWS).min(p.n());
            let (mut lens, mut cols, mut weights) = (Vec::with_capacity(rows.len()), Vec::new(), Vec::new());
            let mut row: Vec<(u32, f64)> = Vec::new();
            for i in rows {
                row.clear();
                for k in p.row_ptr()[i]..p.row_ptr()[i + 1] {
                    let j = p.col_idx()[k] as usize;
                    let term = -damping * sum(k) / diagonal[i] + if j == i { 1.0 } else { 0.0 };
                    match row.iter_mut().find(|e| e.0 == agg[j]) {
                        Some(e) => e.1 += term,
                        None => row.push((agg[j], term)),
                    }
                }
                row.sort_unstable_by_key(|e| e.0);
                let before = cols.len();
                for &(c, w) in row.iter().filter(|e| e.1 != 0.0) {
                    cols.push(c);
                    weights.push(w);
                }
                lens.push(cols.len() - before);
            }
            (lens, cols, weights)
        })
        .collect();
    let mut row_ptr = Vec::with_capacity(p.n() + 1);
    row_ptr.push(0);
    let (mut cols, mut weights) = (Vec::new(), Vec::new());
    for (lens, c, w) in blocks {
        for len in lens {
            row_ptr.push(row_ptr.last().expect("starts at 0") + len);
        }
        cols.extend_from_slice(&c);
        weights.extend_from_slice(&w);
    }
    Prolongation::from_csr(count, row_ptr, cols, weights)
}

impl Hierarchy {
    /// Builds a smoothed-aggregation hierarchy (see the module documentation of
    /// `aggregation.rs`) for the SPD operator `a` with vertex `positions` (a coarse vertex sits
    /// at the centroid of its aggregate), and its Galerkin operators (`operators[l − 1]` is
    /// `A^l`), coarsening until a level has at most `options.min_vertices` vertices, stops
    /// shrinking below `options.max_ratio`, or `options.max_levels` is reached (`seed` is not
    /// used: the aggregation is deterministic). These levels have no retained vertices, so the
    /// §4.2 cascade ([`super::Cascade`]) does not run on them; [`super::Multigrid`] does.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `positions` does not have one entry per row;
    /// [`SparseError::InvalidOption`] for bad options or non-finite positions;
    /// [`SparseError::NonPositiveDiagonal`] for a non-positive diagonal.
    pub fn aggregated(
        a: &CsrMatrix3,
        positions: &[DVec3],
        options: &HierarchyOptions,
    ) -> Result<(Self, Vec<CsrMatrix3>), SparseError> {
        options.check_input(a.n(), positions)?;
        let mut levels = vec![Level::finest(a.pattern(), positions)];
        let mut prolongations = Vec::new();
        let mut operators: Vec<CsrMatrix3> = Vec::new();
        while levels.len() < options.max_levels {
            let fine = operators.last().unwrap_or(a);
            let nf = fine.n();
            if nf <= options.min_vertices.max(1) {
                break;
            }
            let (agg, count) = aggregates(fine.pattern());
            if count as f64 > options.max_ratio * nf as f64 {
                break;
            }
            let p = smoothed_prolongation(fine, &agg, count)?;
            let coarse = galerkin(fine, &p)?;
            let fine_positions = &levels.last().expect("level 0 exists").positions;
            let mut centroid = vec![(DVec3::ZERO, 0u32); count];
            for (i, &c) in agg.iter().enumerate() {
                centroid[c as usize].0 += fine_positions[i];
                centroid[c as usize].1 += 1;
            }
            let positions = centroid.into_iter().map(|(s, k)| s / f64::from(k)).collect();
            levels.push(Level { graph: Arc::clone(coarse.pattern()), positions, independent: count, enhancement_rounds: 0 });
            prolongations.push(p);
            operators.push(coarse);
        }
        Ok((Self { kind: HierarchyKind::Aggregation, levels, prolongations }, operators))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sparse::fixtures::{diffusion_matrix, Grid};

    /// The 7-point Laplacian plus `shift` on an `nx × ny × nz` grid, channels scaled 1, 2, 3,
    /// and the grid's positions.
    fn grid(nx: usize, ny: usize, nz: usize, shift: f64) -> (CsrMatrix3, Vec<DVec3>) {
        let g = Grid::new(nx, ny, nz);
        let a = diffusion_matrix(g.n(), &g.edges(false), |_, _| [1.0, 2.0, 3.0], [shift, 2.0 * shift, 3.0 * shift]);
        (a, g.positions(0.0))
    }

    #[test]
    fn aggregates_cover_every_vertex_with_connected_neighbours() {
        let (a, _) = grid(9, 8, 7, 0.1);
        let p = a.pattern();
        let (agg, count) = aggregates(p);
        assert!(agg.iter().all(|&c| (c as usize) < count));
        // Every aggregate is non-empty, and every vertex shares its aggregate with a neighbour.
        let mut sizes = vec![0usize; count];
        for &c in &agg {
            sizes[c as usize] += 1;
        }
        assert!(sizes.iter().all(|&s| s >= 2), "sizes {sizes:?}");
        for i in 0..p.n() {
            assert!(p.row(i).iter().any(|&j| j as usize != i && agg[j as usize] == agg[i]), "vertex {i} alone in its aggregate");
        }
        // A 7-point neighbourhood holds 7 vertices: the grid shrinks at least 3-fold.
        assert!(count * 3 < p.n(), "{count} aggregates of {} vertices", p.n());
    }

    #[test]
    fn smoothed_prolongation_keeps_constants_where_the_operator_annihilates_them() {
        // Interior rows of a pure Laplacian annihilate constants; there `P 1 = 1` (each row of
        // `P̂` sums to 1 and `D⁻¹S 1 = 0`), at the boundary rows (shift 0: also 0) as well.
        let (a, _) = grid(8, 8, 8, 0.0);
        let (agg, count) = aggregates(a.pattern());
        let p = smoothed_prolongation(&a, &agg, count).unwrap();
        let mut fine = vec![[0.0; 3]; a.n()];
        p.prolong(&vec![[1.0; 3]; count], &mut fine);
        for f in &fine {
            assert!((f[0] - 1.0).abs() < 1e-12, "{f:?}");
        }
        // With a shift, rows lose `ω/ρ · shift / d_i`.
        let (a, _) = grid(8, 8, 8, 0.5);
        let p = smoothed_prolongation(&a, &agg, count).unwrap();
        p.prolong(&vec![[1.0; 3]; count], &mut fine);
        assert!(fine.iter().all(|f| f[0] < 1.0 && f[0] > 0.8), "{:?}", &fine[..4]);
    }

    #[test]
    fn aggregated_hierarchy_shrinks_fast_and_its_operators_are_galerkin_products() {
        let (a, positions) = grid(20, 20, 20, 0.05);
        let (h, ops) = Hierarchy::aggregated(&a, &positions, &HierarchyOptions::default()).unwrap();
        let counts = h.vertex_counts();
        assert!(counts.len() >= 3, "{counts:?}");
        for w in counts.windows(2) {
            assert!(w[1] * 6 < w[0], "levels {counts:?} shrink less than 6-fold");
        }
        assert!(*counts.last().unwrap() <= 150);
        for l in 1..counts.len() {
            let fine = if l == 1 { &a } else { &ops[l - 2] };
            let g = galerkin(fine, h.prolongation(l - 1)).unwrap();
            assert_eq!(g, ops[l - 1]);
            assert!(ops[l - 1].is_symmetric(0.0));
            assert_eq!(h.level(l).graph.n(), ops[l - 1].n());
        }
    }

    #[test]
    fn aggregation_rejects_bad_input() {
        let (a, positions) = grid(4, 4, 4, 0.1);
        assert!(matches!(
            Hierarchy::aggregated(&a, &positions[1..], &HierarchyOptions::default()),
            Err(SparseError::DimensionMismatch { .. })
        ));
        let mut bad = positions.clone();
        bad[3].x = f64::NAN;
        assert!(matches!(Hierarchy::aggregated(&a, &bad, &HierarchyOptions::default()), Err(SparseError::InvalidOption(_))));
    }
}
