//! Test fixtures of the multigrid: a grid system with its hierarchy.

use std::sync::Arc;

use glam::DVec3;

use crate::sparse::hierarchy::{Hierarchy, HierarchyOptions};
use crate::sparse::{CsrMatrix3, CsrPattern, Triplet};

/// A reproducible value in [0, 1) from an integer.
fn hash01(k: u64) -> f64 {
    let mut x = k.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03;
    x ^= x >> 31;
    x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x ^= x >> 29;
    (x >> 11) as f64 / (1u64 << 53) as f64
}

pub(super) fn random_vector(n: usize, seed: u64) -> Vec<[f64; 3]> {
    (0..n).map(|i| [0, 1, 2].map(|c| hash01(seed * 1_000_003 + 3 * i as u64 + c) - 0.5)).collect()
}

/// A jittered `nx × ny × nz` grid with its 6 axis neighbours and one diagonal per cell (as a
/// tetrahedral mesh's graph has), and an SPD diffusion-like matrix on it: per channel
/// `A_ij = −κ_c w_ij`, `A_ii = Σ_j κ_c w_ij + σ_c`, edge weights `w_ij` in [0.5, 1.5).
pub(super) fn grid_system(nx: usize, ny: usize, nz: usize) -> (Hierarchy, CsrMatrix3) {
    let id = |x: usize, y: usize, z: usize| (x + nx * (y + ny * z)) as u32;
    let mut positions = Vec::new();
    let mut edges = Vec::new();
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let i = u64::from(id(x, y, z));
                let j = [0, 1, 2].map(|c| 0.3 * (hash01(7 * i + c) - 0.5));
                positions.push(DVec3::new(x as f64 + j[0], y as f64 + j[1], z as f64 + j[2]));
                if x + 1 < nx {
                    edges.push([id(x, y, z), id(x + 1, y, z)]);
                }
                if y + 1 < ny {
                    edges.push([id(x, y, z), id(x, y + 1, z)]);
                }
                if z + 1 < nz {
                    edges.push([id(x, y, z), id(x, y, z + 1)]);
                }
                if x + 1 < nx && y + 1 < ny && z + 1 < nz {
                    edges.push([id(x, y, z), id(x + 1, y + 1, z + 1)]);
                }
            }
        }
    }
    let n = nx * ny * nz;
    let graph = Arc::new(CsrPattern::from_edges(n, &edges).unwrap());
    let (kappa, sigma) = ([1.0, 0.4, 0.1], [0.02, 0.05, 0.2]);
    let mut trips = Vec::new();
    for (e, &[i, j]) in edges.iter().enumerate() {
        let w = 0.5 + hash01(1_000_000 + e as u64);
        let v = kappa.map(|k| -k * w);
        trips.push(Triplet::new(i, j, v));
        trips.push(Triplet::new(j, i, v));
        trips.push(Triplet::new(i, i, v.map(|t| -t)));
        trips.push(Triplet::new(j, j, v.map(|t| -t)));
    }
    for i in 0..n as u32 {
        trips.push(Triplet::new(i, i, sigma));
    }
    let a = CsrMatrix3::from_triplets_with_pattern(Arc::clone(&graph), &trips).unwrap();
    let h = Hierarchy::build(&graph, &positions, &HierarchyOptions::default().with_min_vertices(150)).unwrap();
    (h, a)
}

pub(super) fn system() -> &'static (Arc<Hierarchy>, CsrMatrix3) {
    static CELL: std::sync::OnceLock<(Arc<Hierarchy>, CsrMatrix3)> = std::sync::OnceLock::new();
    CELL.get_or_init(|| {
        let (h, a) = grid_system(15, 14, 13);
        assert!(h.levels() >= 3, "{:?}", h.vertex_counts());
        (Arc::new(h), a)
    })
}

pub(super) fn rel_diff(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let num: f64 = a.iter().zip(b).map(|(x, y)| (0..3).map(|c| (x[c] - y[c]).powi(2)).sum::<f64>()).sum();
    let den: f64 = b.iter().map(|y| (0..3).map(|c| y[c] * y[c]).sum::<f64>()).sum();
    (num / den).sqrt()
}
