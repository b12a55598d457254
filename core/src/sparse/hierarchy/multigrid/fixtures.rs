//! Test fixtures of the multigrid: a grid system with its hierarchy.

use std::sync::Arc;

use crate::sparse::fixtures::{diffusion_matrix, hash01, Grid};
use crate::sparse::hierarchy::{Hierarchy, HierarchyOptions};
use crate::sparse::CsrMatrix3;

/// A jittered `nx × ny × nz` grid with its axis neighbours and one diagonal per cell, an SPD
/// diffusion-like matrix on it (couplings `κ w_e`, `κ = [1, 0.4, 0.1]`, `w_e` in [0.5, 1.5);
/// absorption `σ = [0.02, 0.05, 0.2]`) and its hierarchy.
pub(super) fn grid_system(nx: usize, ny: usize, nz: usize) -> (Hierarchy, CsrMatrix3) {
    let g = Grid::new(nx, ny, nz);
    let coupling = |e: usize, _| [1.0, 0.4, 0.1].map(|k| k * (0.5 + hash01(1_000_000 + e as u64)));
    let a = diffusion_matrix(g.n(), &g.edges(true), coupling, [0.02, 0.05, 0.2]);
    let h = Hierarchy::build(a.pattern(), &g.positions(0.3), &HierarchyOptions::default().with_min_vertices(150)).unwrap();
    (h, a)
}

/// The grid system of 15 × 14 × 13 vertices, built once.
pub(super) fn system() -> &'static (Arc<Hierarchy>, CsrMatrix3) {
    static CELL: std::sync::OnceLock<(Arc<Hierarchy>, CsrMatrix3)> = std::sync::OnceLock::new();
    CELL.get_or_init(|| {
        let (h, a) = grid_system(15, 14, 13);
        assert!(h.levels() >= 3, "{:?}", h.vertex_counts());
        (Arc::new(h), a)
    })
}

/// `‖a − b‖ / ‖b‖` over all channels.
pub(super) fn rel_diff(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (0..3).map(|c| (x[c] - y[c]).powi(2)).sum::<f64>()).sum();
    let den: f64 = b.iter().map(|y| (0..3).map(|c| y[c] * y[c]).sum::<f64>()).sum();
    (num / den).sqrt()
}
