//! The block sample's node grid and its conservative finite-volume system (design note §1.7,
//! the block case of [`crate::polygrid::PolygridSystem::finite_volume`]), split into a
//! pattern built once and values refilled from per-cell media.
//!
//! Nodes (i, j, k), 0 ≤ i < nx, …, at `(i, j, k)·h` mm, id i + nx(j + ny·k); cells between
//! them, id i + (nx − 1)(j + (ny − 1)k), each with its own σa and σ′s. With cubic cells of edge
//! h the system is linear in the cells' κ and σa:
//!
//! A(κ, σa) = Σ_c κ_c T_c + Σ_c σa_c V_c + R,
//!
//! T_c the cell's edge Laplacian with transmissibility t = h/4 on each of its 12 edges (a
//! quarter of the h × h mid-section over the edge length h), V_c = diag(h³/8) on its 8 corners
//! (the octant volumes) and R = diag(S_i/(2A)) the Robin term on the boundary dual area S_i.
//! So ∂A/∂κ_c = T_c and ∂A/∂σa_c = V_c exactly, which is what the discrete adjoint uses.

use std::sync::Arc;

use crate::sparse::{CsrMatrix3, CsrPattern};

use super::error::InverseError;

/// The largest node count of a block (16 Mi nodes).
pub const MAX_NODES: usize = 1 << 24;

/// The 12 edges of a cell as corner pairs (corner bit 0: +x, bit 1: +y, bit 2: +z).
const CELL_EDGES: [[usize; 2]; 12] =
    [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5], [2, 6], [3, 7]];

/// A block's node grid with spacing `h` mm, its CSR pattern and, per cell, where its entries go.
#[derive(Debug, Clone)]
pub struct BlockGrid {
    dims: [usize; 3],
    h: f64,
    pattern: Arc<CsrPattern>,
    /// Per cell and edge: the positions of (i, j), (j, i), (i, i), (j, j) in the values.
    edge_slots: Vec<[[usize; 4]; 12]>,
    /// The 8 corner nodes of each cell.
    corners: Vec<[u32; 8]>,
    /// The Robin dual area S_i (mm²) per node, 0 inside.
    robin_area: Vec<f64>,
}

impl BlockGrid {
    /// The grid of `dims` nodes at spacing `h` mm.
    ///
    /// # Errors
    /// [`InverseError::InvalidGrid`] for fewer than 2 nodes along an axis or more than
    /// [`MAX_NODES`]; [`InverseError::InvalidSetting`] for `h` not finite and > 0.
    pub fn new(dims: [usize; 3], h: f64) -> Result<Self, InverseError> {
        if dims.iter().any(|&d| d < 2) {
            return Err(InverseError::InvalidGrid { dims, reason: "at least 2 nodes per axis" });
        }
        if dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d)).is_none_or(|n| n > MAX_NODES) {
            return Err(InverseError::InvalidGrid { dims, reason: "more than 2^24 nodes" });
        }
        if !(h.is_finite() && h > 0.0) {
            return Err(InverseError::InvalidSetting { what: "node spacing (mm)", value: h, expected: "finite and > 0" });
        }
        let [nx, ny, nz] = dims;
        let n = nx * ny * nz;
        let node = |i: usize, j: usize, k: usize| (i + nx * (j + ny * k)) as u32;
        let edges = axis_pairs(dims);
        let pattern = Arc::new(CsrPattern::from_edges(n, &edges)?);
        let mut corners = Vec::with_capacity((nx - 1) * (ny - 1) * (nz - 1));
        for k in 0..nz - 1 {
            for j in 0..ny - 1 {
                for i in 0..nx - 1 {
                    corners.push(std::array::from_fn(|c| node(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1))));
                }
            }
        }
        let pos = |r: u32, c: u32| pattern.position(r as usize, c as usize).expect("an edge of the pattern");
        let edge_slots = corners
            .iter()
            .map(|c: &[u32; 8]| {
                CELL_EDGES.map(|[a, b]| {
                    let (i, j) = (c[a], c[b]);
                    [pos(i, j), pos(j, i), pos(i, i), pos(j, j)]
                })
            })
            .collect();
        let robin_area = (0..n)
            .map(|id| {
                let ijk = [id % nx, (id / nx) % ny, id / (nx * ny)];
                face_areas(ijk, dims, h).iter().sum()
            })
            .collect();
        Ok(Self { dims, h, pattern, edge_slots, corners, robin_area })
    }

    /// Nodes along x, y, z.
    #[must_use]
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Cells along x, y, z (one fewer than nodes).
    #[must_use]
    pub fn cell_dims(&self) -> [usize; 3] {
        self.dims.map(|d| d - 1)
    }

    /// The node spacing, mm.
    #[must_use]
    pub fn spacing(&self) -> f64 {
        self.h
    }

    /// The number of nodes.
    #[must_use]
    pub fn node_count(&self) -> usize {
        self.dims.iter().product()
    }

    /// The number of cells.
    #[must_use]
    pub fn cell_count(&self) -> usize {
        self.corners.len()
    }

    /// The node id of (i, j, k).
    #[must_use]
    pub fn node(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// The 8 corners of every cell (corner bit 0: +x, bit 1: +y, bit 2: +z).
    #[must_use]
    pub fn corners(&self) -> &[[u32; 8]] {
        &self.corners
    }

    /// The Robin dual area S_i (mm²) per node: the node's quarter, half or whole h × h of each
    /// boundary face it lies on; 0 inside.
    #[must_use]
    pub fn robin_area(&self) -> &[f64] {
        &self.robin_area
    }

    /// The transmissibility t = h/4 of each cell edge: eq. (FV flux) κ_c t (φ_i − φ_j).
    #[must_use]
    pub fn edge_transmissibility(&self) -> f64 {
        self.h / 4.0
    }

    /// The octant volume h³/8 of each cell corner.
    #[must_use]
    pub fn octant_volume(&self) -> f64 {
        self.h.powi(3) / 8.0
    }

    /// The centre of cell `c`, mm.
    #[must_use]
    pub fn cell_centre(&self, c: usize) -> [f64; 3] {
        let [cx, cy, _] = self.cell_dims();
        let ijk = [c % cx, (c / cx) % cy, c / (cx * cy)];
        ijk.map(|i| (i as f64 + 0.5) * self.h)
    }

    /// The matrix A(κ, σa) for per-cell κ and σa (per channel), with the Robin term of
    /// `a_coefficient` (A = (1 + Fdr)/(1 − Fdr)): the module's sum.
    ///
    /// # Panics
    /// If `kappa` or `sigma_a` does not have one entry per cell.
    #[must_use]
    pub fn matrix(&self, kappa: &[[f64; 3]], sigma_a: &[[f64; 3]], a_coefficient: f64) -> CsrMatrix3 {
        assert_eq!(kappa.len(), self.cell_count());
        assert_eq!(sigma_a.len(), self.cell_count());
        let mut values = vec![[0.0; 3]; self.pattern.nnz()];
        let t = self.edge_transmissibility();
        let v = self.octant_volume();
        let add = |values: &mut [[f64; 3]], p: usize, w: [f64; 3]| {
            let e = &mut values[p];
            *e = std::array::from_fn(|c| e[c] + w[c]);
        };
        for ((slots, corners), (k, s)) in self.edge_slots.iter().zip(&self.corners).zip(kappa.iter().zip(sigma_a)) {
            let w = k.map(|k| k * t);
            for &[ij, ji, ii, jj] in slots {
                add(&mut values, ij, w.map(|x| -x));
                add(&mut values, ji, w.map(|x| -x));
                add(&mut values, ii, w);
                add(&mut values, jj, w);
            }
            let absorb = s.map(|s| s * v);
            for &node in corners {
                add(&mut values, self.pattern.diagonal_positions()[node as usize], absorb);
            }
        }
        for (i, &s) in self.robin_area.iter().enumerate() {
            if s > 0.0 {
                add(&mut values, self.pattern.diagonal_positions()[i], [s / (2.0 * a_coefficient); 3]);
            }
        }
        CsrMatrix3::new(self.pattern.clone(), values).expect("values match the pattern")
    }

    /// ψᵀ T_c φ per cell and channel: Σ over the cell's edges of t (ψ_i − ψ_j)(φ_i − φ_j), the
    /// derivative of ψᵀAφ with respect to κ_c.
    #[must_use]
    pub fn stiffness_products(&self, psi: &[[f64; 3]], phi: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let t = self.edge_transmissibility();
        self.corners
            .iter()
            .map(|c| {
                let mut s = [0.0; 3];
                for &[a, b] in &CELL_EDGES {
                    let (i, j) = (c[a] as usize, c[b] as usize);
                    for ch in 0..3 {
                        s[ch] += t * (psi[i][ch] - psi[j][ch]) * (phi[i][ch] - phi[j][ch]);
                    }
                }
                s
            })
            .collect()
    }

    /// ψᵀ V_c φ per cell and channel: (h³/8) Σ over the cell's corners of ψ_k φ_k, the
    /// derivative of ψᵀAφ with respect to σa_c.
    #[must_use]
    pub fn mass_products(&self, psi: &[[f64; 3]], phi: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let v = self.octant_volume();
        self.corners
            .iter()
            .map(|c| {
                let mut s = [0.0; 3];
                for &k in c {
                    for ch in 0..3 {
                        s[ch] += v * psi[k as usize][ch] * phi[k as usize][ch];
                    }
                }
                s
            })
            .collect()
    }

    /// The pairs of face-adjacent cells (each once, lower id first): the differences the
    /// smoothness regulariser penalises.
    #[must_use]
    pub fn cell_neighbours(&self) -> Vec<[u32; 2]> {
        axis_pairs(self.cell_dims())
    }
}

/// The pairs of points of a `dims` grid (x fastest) adjacent along an axis, each once, lower
/// id first: the node graph's edges, or the cells' face neighbours.
fn axis_pairs([nx, ny, nz]: [usize; 3]) -> Vec<[u32; 2]> {
    let id = |i: usize, j: usize, k: usize| (i + nx * (j + ny * k)) as u32;
    let mut pairs = Vec::with_capacity(3 * nx * ny * nz);
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if i + 1 < nx {
                    pairs.push([id(i, j, k), id(i + 1, j, k)]);
                }
                if j + 1 < ny {
                    pairs.push([id(i, j, k), id(i, j + 1, k)]);
                }
                if k + 1 < nz {
                    pairs.push([id(i, j, k), id(i, j, k + 1)]);
                }
            }
        }
    }
    pairs
}

/// The dual area of node `ijk` on each of the six faces of a block of `dims` nodes at spacing
/// `h` (−x, +x, −y, +y, −z, +z): on a face it is h² times ½ for each in-face axis along which
/// the node is at an end, 0 off the face.
#[must_use]
pub fn face_areas(ijk: [usize; 3], dims: [usize; 3], h: f64) -> [f64; 6] {
    let end = |a: usize| if ijk[a] == 0 || ijk[a] + 1 == dims[a] { 0.5 } else { 1.0 };
    std::array::from_fn(|f| {
        let axis = f / 2;
        let on = if f % 2 == 0 { ijk[axis] == 0 } else { ijk[axis] + 1 == dims[axis] };
        if on {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            h * h * end(u) * end(v)
        } else {
            0.0
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn face_areas_sum_to_the_faces() {
        // Every face's dual areas tile it: (nx − 1)(ny − 1)h² on ±z, etc.
        let dims = [4, 3, 5];
        let h = 0.5;
        let mut total = [0.0; 6];
        for k in 0..5 {
            for j in 0..3 {
                for i in 0..4 {
                    let a = face_areas([i, j, k], dims, h);
                    for f in 0..6 {
                        total[f] += a[f];
                    }
                }
            }
        }
        let expect = [2.0 * 4.0, 2.0 * 4.0, 3.0 * 4.0, 3.0 * 4.0, 3.0 * 2.0, 3.0 * 2.0].map(|x| x * h * h);
        for f in 0..6 {
            assert!((total[f] - expect[f]).abs() < 1e-12, "face {f}: {} vs {}", total[f], expect[f]);
        }
    }

    #[test]
    fn rows_sum_to_absorption_and_robin() {
        // A constant φ: the stiffness part vanishes, so each row sums to Σ V μ + S/(2A).
        let g = BlockGrid::new([3, 4, 3], 0.7).unwrap();
        let nc = g.cell_count();
        let a = g.matrix(&vec![[0.3, 0.2, 0.1]; nc], &vec![[0.05, 0.01, 0.02]; nc], 2.5);
        let y = a.mul_vec(&vec![[1.0; 3]; g.node_count()]).unwrap();
        let total: f64 = y.iter().map(|r| r[0]).sum();
        let volume = 2.0 * 3.0 * 2.0 * 0.7f64.powi(3);
        let area = 2.0 * (2.0 * 3.0 + 3.0 * 2.0 + 2.0 * 2.0) * 0.49;
        assert!((total - (0.05 * volume + area / 5.0)).abs() < 1e-12, "{total}");
        assert!(a.is_symmetric(0.0));
    }

    #[test]
    fn products_are_the_derivatives_of_the_bilinear_form() {
        // ψᵀAφ is linear in κ_c and σa_c: a finite difference is exact up to rounding.
        let g = BlockGrid::new([3, 3, 3], 1.0).unwrap();
        let nc = g.cell_count();
        let n = g.node_count();
        let phi: Vec<[f64; 3]> = (0..n).map(|i| [(i as f64 * 0.37).sin(), 1.0, i as f64]).collect();
        let psi: Vec<[f64; 3]> = (0..n).map(|i| [(i as f64 * 0.11).cos(), 0.5, 2.0]).collect();
        let form = |k: &[[f64; 3]], s: &[[f64; 3]]| -> f64 {
            let y = g.matrix(k, s, 2.0).mul_vec(&phi).unwrap();
            y.iter().zip(&psi).map(|(a, b)| a[0] * b[0]).sum()
        };
        let k0 = vec![[0.4; 3]; nc];
        let s0 = vec![[0.1; 3]; nc];
        let stiff = g.stiffness_products(&psi, &phi);
        let mass = g.mass_products(&psi, &phi);
        for c in 0..nc {
            let mut k1 = k0.clone();
            k1[c][0] += 1.0;
            assert!((form(&k1, &s0) - form(&k0, &s0) - stiff[c][0]).abs() < 1e-9);
            let mut s1 = s0.clone();
            s1[c][0] += 1.0;
            assert!((form(&k0, &s1) - form(&k0, &s0) - mass[c][0]).abs() < 1e-9);
        }
    }
}
