//! Test fixtures shared by the unit tests of the sparse module: grid graphs, SPD diffusion-like
//! matrices on a graph, reproducible vectors.

use std::sync::Arc;

use glam::DVec3;

use super::csr::{CsrMatrix3, CsrPattern, Triplet};

/// A reproducible value in [0, 1) from an integer.
pub(crate) fn hash01(k: u64) -> f64 {
    let mut x = k.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03;
    x ^= x >> 31;
    x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x ^= x >> 29;
    (x >> 11) as f64 / (1u64 << 53) as f64
}

/// A reproducible vector of `n` rows with entries in [−0.5, 0.5).
pub(crate) fn random_vector(n: usize, seed: u64) -> Vec<[f64; 3]> {
    (0..n).map(|i| [0, 1, 2].map(|c| hash01(seed * 1_000_003 + 3 * i as u64 + c) - 0.5)).collect()
}

/// A right-hand side of `n` rows with small integer entries.
pub(crate) fn rhs(n: usize) -> Vec<[f64; 3]> {
    (0..n).map(|i| [((i * 7) % 11) as f64 - 3.0, (i % 5) as f64, 1.0 + (i % 3) as f64]).collect()
}

/// An `nx × ny × nz` grid of vertices, vertex `(x, y, z)` numbered `x + nx (y + ny z)`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Grid {
    nx: usize,
    ny: usize,
    nz: usize,
}

impl Grid {
    pub(crate) fn new(nx: usize, ny: usize, nz: usize) -> Self {
        Self { nx, ny, nz }
    }

    /// The number of vertices.
    pub(crate) fn n(self) -> usize {
        self.nx * self.ny * self.nz
    }

    fn id(self, x: usize, y: usize, z: usize) -> u32 {
        (x + self.nx * (y + self.ny * z)) as u32
    }

    /// The coordinates `(x, y, z)` of vertex `i`.
    pub(crate) fn coords(self, i: u32) -> [usize; 3] {
        let i = i as usize;
        [i % self.nx, (i / self.nx) % self.ny, i / (self.nx * self.ny)]
    }

    /// Vertex by vertex, the edges to its `+x`, `+y` and `+z` neighbours and, with `diagonal`,
    /// to its `+(1, 1, 1)` neighbour (one diagonal per cell, as a tetrahedral mesh's graph has);
    /// the lower-numbered vertex first.
    pub(crate) fn edges(self, diagonal: bool) -> Vec<[u32; 2]> {
        let (nx, ny, nz) = (self.nx, self.ny, self.nz);
        let mut edges = Vec::new();
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    let i = self.id(x, y, z);
                    if x + 1 < nx {
                        edges.push([i, self.id(x + 1, y, z)]);
                    }
                    if y + 1 < ny {
                        edges.push([i, self.id(x, y + 1, z)]);
                    }
                    if z + 1 < nz {
                        edges.push([i, self.id(x, y, z + 1)]);
                    }
                    if diagonal && x + 1 < nx && y + 1 < ny && z + 1 < nz {
                        edges.push([i, self.id(x + 1, y + 1, z + 1)]);
                    }
                }
            }
        }
        edges
    }

    /// The vertex positions (unit spacing), every coordinate moved by a reproducible amount in
    /// `[−jitter/2, jitter/2)`.
    pub(crate) fn positions(self, jitter: f64) -> Vec<DVec3> {
        (0..self.n() as u32)
            .map(|i| {
                let [x, y, z] = self.coords(i);
                let j = [0, 1, 2].map(|c| jitter * (hash01(7 * u64::from(i) + c) - 0.5));
                DVec3::new(x as f64 + j[0], y as f64 + j[1], z as f64 + j[2])
            })
            .collect()
    }
}

/// The SPD diffusion-like matrix on the graph `edges` of `n` vertices, on the pattern
/// [`CsrPattern::from_edges`] gives: per channel `a_ij = −w_e` for edge `e = [i, j]`
/// (`w_e = coupling(e, [i, j])`, positive) and `a_ii = Σ_e w_e + absorption`, summed edge by
/// edge, then the absorption.
pub(crate) fn diffusion_matrix(
    n: usize,
    edges: &[[u32; 2]],
    coupling: impl Fn(usize, [u32; 2]) -> [f64; 3],
    absorption: [f64; 3],
) -> CsrMatrix3 {
    let graph = Arc::new(CsrPattern::from_edges(n, edges).unwrap());
    let mut trips = Vec::with_capacity(4 * edges.len() + n);
    for (e, &[i, j]) in edges.iter().enumerate() {
        let w = coupling(e, [i, j]);
        let off = w.map(|t| -t);
        trips.extend([Triplet::new(i, j, off), Triplet::new(j, i, off), Triplet::new(i, i, w), Triplet::new(j, j, w)]);
    }
    trips.extend((0..n as u32).map(|i| Triplet::new(i, i, absorption)));
    CsrMatrix3::from_triplets_with_pattern(graph, &trips).unwrap()
}

/// The 7-point diffusion-like matrix on the `nx³` grid ([`diffusion_matrix`]): couplings
/// `k [1, 0.7, 1.3]` with `k` from 1 to 3 varying along the grid (a spread diagonal), absorption
/// `[0.01, 0.05, 0.2]`.
pub(crate) fn grid_matrix(nx: usize) -> CsrMatrix3 {
    let g = Grid::new(nx, nx, nx);
    let coupling = |_, [i, _]: [u32; 2]| {
        let [x, y, z] = g.coords(i);
        let k = 1.0 + 0.5 * ((x + 2 * y + 3 * z) % 5) as f64;
        [k, 0.7 * k, 1.3 * k]
    };
    diffusion_matrix(g.n(), &g.edges(false), coupling, [0.01, 0.05, 0.2])
}
