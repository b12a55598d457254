//! Which cells share an unknown: the optimiser's parameters on a grid of blocks of cells.
//!
//! The per-cell fit has two unknowns per cell (ln σa, ln σ′s). A fit on coarser blocks (one
//! unknown per block of `f × f × f` cells, the last block of an axis shorter) is the
//! homogeneous fit's generalisation: it is how the coarse-to-fine cascade starts
//! ([`super::AcquireOptions::coarse_levels`]) and how σa can be fitted on a coarser grid than
//! σ′s ([`super::AcquireOptions::absorption_coarsening`]), since one face's images constrain
//! σa per cell far more weakly than σ′s.
//!
//! The cells take their block's value: the prolongation `P` is piecewise constant, so the
//! gradient with respect to the block parameters is `Pᵀ g`, the sum of the per-cell gradient
//! over each block's cells (exact: f(Px) has gradient Pᵀ∇f).

use super::block::BlockGrid;

/// Per cell, the index of its σa parameter and of its σ′s parameter.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParameterGrid {
    absorption: Vec<u32>,
    scattering: Vec<u32>,
    absorption_count: usize,
    scattering_count: usize,
}

/// Per cell of a `dims` cell grid (x fastest), its block's index when blocks are `f` cells on
/// a side; and the number of blocks.
fn block_index(dims: [usize; 3], f: usize) -> (Vec<u32>, usize) {
    let f = f.max(1);
    let b = dims.map(|n| n.div_ceil(f));
    let mut index = Vec::with_capacity(dims.iter().product());
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                index.push((i / f + b[0] * (j / f + b[1] * (k / f))) as u32);
            }
        }
    }
    (index, b.iter().product())
}

impl ParameterGrid {
    /// One σa and one σ′s for every cell (the homogeneous fit).
    #[must_use]
    pub fn homogeneous(cells: usize) -> Self {
        Self { absorption: vec![0; cells], scattering: vec![0; cells], absorption_count: 1, scattering_count: 1 }
    }

    /// σa on blocks of `absorption` cells a side and σ′s on blocks of `scattering` cells a side
    /// (1: per cell; 0 is taken as 1).
    #[must_use]
    pub fn blocks(grid: &BlockGrid, absorption: usize, scattering: usize) -> Self {
        let dims = grid.cell_dims();
        let (a, absorption_count) = block_index(dims, absorption);
        let (s, scattering_count) = block_index(dims, scattering);
        Self { absorption: a, scattering: s, absorption_count, scattering_count }
    }

    /// Unknowns: the σa blocks' then the σ′s blocks'.
    #[must_use]
    pub fn len(&self) -> usize {
        self.absorption_count + self.scattering_count
    }

    /// Whether there are no unknowns (a grid without cells).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.absorption.is_empty()
    }

    /// `P x`: per cell, its (σa, σ′s) parameters' values.
    pub fn prolong<'a>(&'a self, x: &'a [f64]) -> impl Iterator<Item = (f64, f64)> + 'a {
        self.absorption.iter().zip(&self.scattering).map(|(&a, &s)| (x[a as usize], x[self.absorption_count + s as usize]))
    }

    /// `Pᵀ g`: per-cell values (σa, σ′s) summed over each block (the gradient's restriction).
    pub fn sum(&self, per_cell: impl Iterator<Item = (f64, f64)>) -> Vec<f64> {
        let mut out = vec![0.0; self.len()];
        for ((a, s), (&ba, &bs)) in per_cell.zip(self.absorption.iter().zip(&self.scattering)) {
            out[ba as usize] += a;
            out[self.absorption_count + bs as usize] += s;
        }
        out
    }

    /// Per-cell values averaged over each block: where a coarser fit's result starts a finer
    /// one (exact when blocks nest: every cell of a block already has the block's value).
    pub fn average(&self, per_cell: impl Iterator<Item = (f64, f64)>) -> Vec<f64> {
        let cells = self.sum(std::iter::repeat_n((1.0, 1.0), self.absorption.len()));
        self.sum(per_cell).iter().zip(&cells).map(|(s, n)| s / n).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_cover_every_cell_once_with_short_last_blocks() {
        // 5 × 3 × 2 cells in blocks of 2: 3 × 2 × 1 blocks, the last of x one cell wide.
        let (index, n) = block_index([5, 3, 2], 2);
        assert_eq!(n, 6);
        assert_eq!(index.len(), 30);
        let mut sizes = vec![0; n];
        for &b in &index {
            sizes[b as usize] += 1;
        }
        // Blocks (x, y): x widths 2, 2, 1; y heights 2, 1; z depth 2.
        assert_eq!(sizes, [8, 8, 4, 4, 4, 2]);
        assert_eq!(index[0], 0);
        assert_eq!(index[4], 2, "cell (4, 0, 0) is in the third x block");
        assert_eq!(index[5 * 2], 3, "cell (0, 2, 0) is in the second y block");
    }

    #[test]
    fn the_restriction_is_the_prolongations_transpose() {
        let grid = BlockGrid::new([6, 5, 4], 0.5).expect("a grid");
        let p = ParameterGrid::blocks(&grid, 2, 1);
        let cells = grid.cell_count();
        assert_eq!(p.len(), 3 * 2 * 2 + cells);
        // ⟨P x, y⟩ = ⟨x, Pᵀ y⟩ for arbitrary x and y.
        let x: Vec<f64> = (0..p.len()).map(|i| (i as f64 * 0.37).sin()).collect();
        let y: Vec<(f64, f64)> = (0..cells).map(|c| ((c as f64 * 0.11).cos(), (c as f64 * 0.23).sin())).collect();
        let left: f64 = p.prolong(&x).zip(&y).map(|((a, s), (ya, ys))| a * ya + s * ys).sum();
        let right: f64 = x.iter().zip(p.sum(y.iter().copied())).map(|(a, b)| a * b).sum();
        assert!((left - right).abs() < 1e-12 * left.abs().max(1.0), "{left} vs {right}");
    }

    #[test]
    fn averaging_a_prolonged_vector_returns_it() {
        let grid = BlockGrid::new([7, 6, 5], 0.5).expect("a grid");
        for (a, s) in [(1, 1), (2, 1), (4, 2), (3, 3)] {
            let p = ParameterGrid::blocks(&grid, a, s);
            let x: Vec<f64> = (0..p.len()).map(|i| i as f64 - 0.5).collect();
            let back = p.average(p.prolong(&x));
            assert_eq!(back, x, "blocks {a}, {s}");
        }
        let h = ParameterGrid::homogeneous(grid.cell_count());
        assert_eq!(h.len(), 2);
        assert_eq!(h.average((0..grid.cell_count()).map(|c| (c as f64, 2.0))), [(grid.cell_count() - 1) as f64 / 2.0, 2.0]);
    }
}
