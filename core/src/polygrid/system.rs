//! The diffusion system on a polygrid by the conservative finite-volume stencil
//! ([`PolygridSystem::finite_volume`]), its source, radiance query and energy balance, with
//! docs/ARCHITECTURE.md's boundary condition φ + 2Aκ ∇φ·n = Q, Q = 4q/(1 − Fdr), and query
//! Lo = Ft/(4π)[(1 + 1/A)φ − 4q/(1 + Fdr)] (not the paper's L = Ft(φ − q)/2π, which is
//! negative at lit points).
//!
//! **Node-centred finite volumes** (design note §1.7, generalised to mapped hexes): each node's
//! dual cell is made of the octants of its cells; the flux through the dual face of a cell
//! edge ij is κ_c (a·d)/|d|² (φ_i − φ_j), with a the dual face's area vector in cell c (the
//! quarter of the cell's mid-section next to the edge, exact by the midpoint rule: its normal
//! field is bilinear) and d = x_j − x_i. The media live on the cells (as the TransCut tets
//! carry them), so a material interface on cell faces needs no averaging of κ at all and is
//! exact in 1D; the paper's Δ(κφ) form is what fails there (§3.2 of the note). Summing the rows
//! gives the energy balance exactly: the fluxes cancel pairwise. On orthogonal cells the stencil
//! is the classic second-order 7-point one; on skewed cells its two-point flux is not
//! consistent (the FEM path is, [`Polygrid::kuhn_tets`]).
//!
//! Rows: Σ_j T_ij (φ_i − φ_j) + V_i μ_i φ_i + S_i φ_i/(2A) = S_i Q_i/(2A).

use glam::DVec3;
use rayon::prelude::*;

use super::error::PolygridError;
use super::grid::Polygrid;
use crate::optics::{BoundaryTerms, Medium};
use crate::sparse::{CsrMatrix3, CsrPattern, Triplet};

/// The boundary nodes of a system: the order of the source q and of the radiance.
#[derive(Debug, Clone, PartialEq)]
pub struct BoundaryNodes {
    /// Node ids, increasing.
    pub ids: Vec<u32>,
    /// The dual area S_i of each, mm².
    pub area_mm2: Vec<f64>,
    /// The unit outward normal of each (area-weighted over its quads).
    pub normal: Vec<DVec3>,
}

/// A polygrid's diffusion system M φ = b (see the module documentation).
#[derive(Debug, Clone)]
pub struct PolygridSystem {
    pub(super) matrix: CsrMatrix3,
    pub(super) boundary: BoundaryNodes,
    pub(super) terms: BoundaryTerms,
    /// V_i μ_i per node and channel (mm³ · mm⁻¹).
    pub(super) absorption: Vec<[f64; 3]>,
    pub(super) source: Vec<[f64; 3]>,
    pub(super) rhs: Vec<[f64; 3]>,
    /// The paper stencil's diagnostics ([`PolygridSystem::paper_lsq`]); `None` for the
    /// symmetric finite-volume matrix.
    pub(super) lsq: Option<super::paper::LsqDiagnostics>,
}

impl PolygridSystem {
    /// The finite-volume system of `grid` with `cell_media` (one per cell), positions in scene
    /// units of `mm_per_unit` millimetres. `robin`: per boundary quad whether it carries the
    /// boundary condition (`None`: every quad); a quad without it is a mirror (zero flux), as
    /// the side faces of the slab tests.
    ///
    /// # Errors
    /// [`PolygridError::LengthMismatch`] for a media or mask list of the wrong length;
    /// [`PolygridError::InvalidMedium`] naming the first invalid cell medium or one whose η
    /// differs from the first boundary cell's.
    pub fn finite_volume(
        grid: &Polygrid,
        cell_media: &[Medium],
        mm_per_unit: f64,
        robin: Option<&[bool]>,
    ) -> Result<Self, PolygridError> {
        let terms = check_inputs(grid, cell_media, mm_per_unit, robin)?;
        let cells = grid.cells();
        let x: Vec<DVec3> = grid.positions().iter().map(|&p| p * mm_per_unit).collect();
        let n = grid.node_count();

        // Per cell: its 12 edge transmissibilities and 8 octant volumes.
        let per_cell: Vec<([f64; 12], [f64; 8])> = cells
            .par_iter()
            .map(|c| {
                let p = c.map(|i| x[i as usize]);
                (edge_transmissibilities(&p), octant_volumes(&p))
            })
            .collect();
        let mut triplets = Vec::with_capacity(cells.len() * 12 * 3 + n);
        let mut absorption = vec![[0.0; 3]; n];
        for ((c, (t, v)), m) in cells.iter().zip(&per_cell).zip(cell_media) {
            let kappa = m.diffusion_coefficient();
            for (e, &[a, b]) in CELL_EDGES.iter().enumerate() {
                let w: [f64; 3] = std::array::from_fn(|k| kappa[k] * t[e]);
                let (i, j) = (c[a], c[b]);
                triplets.push(Triplet::new(i, j, w.map(|x| -x)));
                triplets.push(Triplet::new(j, i, w.map(|x| -x)));
                triplets.push(Triplet::new(i, i, w));
                triplets.push(Triplet::new(j, j, w));
            }
            for (k, &node) in c.iter().enumerate() {
                let a = &mut absorption[node as usize];
                *a = std::array::from_fn(|ch| a[ch] + v[k] * m.sigma_a[ch]);
            }
        }
        let (ids, area, normal) = robin_boundary(grid, &x, robin);
        for &i in &ids {
            let robin_term = area[i as usize] / (2.0 * terms.a);
            triplets.push(Triplet::new(i, i, [robin_term; 3]));
        }
        for (i, a) in absorption.iter().enumerate() {
            triplets.push(Triplet::new(i as u32, i as u32, *a));
        }
        let edges: Vec<[u32; 2]> = cells.iter().flat_map(|c| CELL_EDGES.map(|[a, b]| [c[a], c[b]])).collect();
        let pattern = std::sync::Arc::new(CsrPattern::from_edges(n, &edges)?);
        let matrix = CsrMatrix3::from_triplets_with_pattern(pattern, &triplets)?;
        let boundary = BoundaryNodes {
            area_mm2: ids.iter().map(|&i| area[i as usize]).collect(),
            normal: ids.iter().map(|&i| normal[i as usize]).collect(),
            ids,
        };
        let nb = boundary.ids.len();
        Ok(Self { matrix, boundary, terms, absorption, source: vec![[0.0; 3]; nb], rhs: vec![[0.0; 3]; n], lsq: None })
    }

    /// The matrix M (symmetric positive definite).
    #[must_use]
    pub fn matrix(&self) -> &CsrMatrix3 {
        &self.matrix
    }

    /// The right-hand side b for the current source.
    #[must_use]
    pub fn rhs(&self) -> &[[f64; 3]] {
        &self.rhs
    }

    /// The source q per boundary node.
    #[must_use]
    pub fn source(&self) -> &[[f64; 3]] {
        &self.source
    }

    /// The boundary nodes: the order of q and of the radiance.
    #[must_use]
    pub fn boundary(&self) -> &BoundaryNodes {
        &self.boundary
    }

    /// Fdr, A and Ft of the object's η.
    #[must_use]
    pub fn boundary_terms(&self) -> &BoundaryTerms {
        &self.terms
    }

    /// Sets the transmitted source q (one per boundary node, any sign: a sum of solutions is
    /// one) and b_i = S_i Q_i/(2A). On error nothing changes.
    ///
    /// # Errors
    /// [`PolygridError::LengthMismatch`]; [`PolygridError::InvalidSource`] for a value that is
    /// not finite.
    pub fn set_source(&mut self, q: &[[f64; 3]]) -> Result<(), PolygridError> {
        let nb = self.boundary.ids.len();
        if q.len() != nb {
            return Err(PolygridError::LengthMismatch { what: "source q", expected: nb, found: q.len() });
        }
        if let Some((index, value)) = q.iter().enumerate().find_map(|(k, v)| v.iter().find(|x| !x.is_finite()).map(|&x| (k, x))) {
            return Err(PolygridError::InvalidSource { index, value });
        }
        let mut rhs = vec![[0.0; 3]; self.rhs.len()];
        for ((&i, &s), q) in self.boundary.ids.iter().zip(&self.boundary.area_mm2).zip(q) {
            rhs[i as usize] = q.map(|q| s * self.terms.fluence_source(q) / (2.0 * self.terms.a));
        }
        self.rhs = rhs;
        self.source = q.to_vec();
        Ok(())
    }

    /// Lo(x, n) at every boundary node (ARCHITECTURE.md's query along the normal), not clamped.
    ///
    /// # Errors
    /// [`PolygridError::LengthMismatch`] unless `phi` has one entry per node.
    pub fn radiance(&self, phi: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, PolygridError> {
        self.check_phi(phi)?;
        Ok(self
            .boundary
            .ids
            .iter()
            .zip(&self.source)
            .map(|(&i, q)| std::array::from_fn(|c| self.terms.radiance_normal(phi[i as usize][c], q[c])))
            .collect())
    }

    /// Absorbed, exitant and incident power of a solution ([`crate::diffusion::EnergyBalance`]'s
    /// quantities): Σ V_i μ_i φ_i, Σ S_i (φ_i − 2q_i)/(2A) and Σ S_i q_i; equal (absorbed +
    /// exitant = incident) up to the solver's tolerance, since the rows sum to it.
    ///
    /// # Errors
    /// [`PolygridError::LengthMismatch`] unless `phi` has one entry per node.
    pub fn energy_balance(&self, phi: &[[f64; 3]]) -> Result<[[f64; 3]; 3], PolygridError> {
        self.check_phi(phi)?;
        let mut absorbed = [0.0; 3];
        for (a, p) in self.absorption.iter().zip(phi) {
            for c in 0..3 {
                absorbed[c] += a[c] * p[c];
            }
        }
        let (mut exitant, mut incident) = ([0.0; 3], [0.0; 3]);
        for ((&i, &s), q) in self.boundary.ids.iter().zip(&self.boundary.area_mm2).zip(&self.source) {
            for c in 0..3 {
                exitant[c] += s * (phi[i as usize][c] - 2.0 * q[c]) / (2.0 * self.terms.a);
                incident[c] += s * q[c];
            }
        }
        Ok([absorbed, exitant, incident])
    }

    fn check_phi(&self, phi: &[[f64; 3]]) -> Result<(), PolygridError> {
        if phi.len() != self.rhs.len() {
            return Err(PolygridError::LengthMismatch { what: "fluence", expected: self.rhs.len(), found: phi.len() });
        }
        Ok(())
    }
}

/// Checks the inputs shared by the stencils' assemblies and returns the object's boundary
/// terms (see [`PolygridSystem::finite_volume`]'s errors).
pub(super) fn check_inputs(
    grid: &Polygrid,
    cell_media: &[Medium],
    mm_per_unit: f64,
    robin: Option<&[bool]>,
) -> Result<BoundaryTerms, PolygridError> {
    if cell_media.len() != grid.cells().len() {
        return Err(PolygridError::LengthMismatch { what: "cell media", expected: grid.cells().len(), found: cell_media.len() });
    }
    if let Some(r) = robin {
        if r.len() != grid.quads().len() {
            return Err(PolygridError::LengthMismatch { what: "Robin quad mask", expected: grid.quads().len(), found: r.len() });
        }
    }
    if !(mm_per_unit.is_finite() && mm_per_unit > 0.0) {
        return Err(PolygridError::InvalidCube { cube: mm_per_unit });
    }
    if let Some((cell, e)) = cell_media.iter().enumerate().find_map(|(c, m)| m.validate().err().map(|e| (c, e))) {
        return Err(PolygridError::InvalidMedium { cell, message: e.to_string() });
    }
    let eta = cell_media[0].eta;
    if let Some(cell) = cell_media.iter().position(|m| m.eta != eta) {
        return Err(PolygridError::InvalidMedium {
            cell,
            message: format!("its η {} differs from the object's {eta} (one η per object)", cell_media[cell].eta),
        });
    }
    BoundaryTerms::new(eta).map_err(|e| PolygridError::InvalidMedium { cell: 0, message: e.to_string() })
}

/// The nodes under the boundary condition (increasing ids), with the dual area S_i (mm², per
/// node) and unit outward normal (per node, area-weighted over its quads; zero off the
/// boundary) from each Robin quad's corner quarters; `x` in mm.
pub(super) fn robin_boundary(grid: &Polygrid, x: &[DVec3], robin: Option<&[bool]>) -> (Vec<u32>, Vec<f64>, Vec<DVec3>) {
    let n = grid.node_count();
    let mut area = vec![0.0; n];
    let mut normal = vec![DVec3::ZERO; n];
    for (qi, q) in grid.quads().iter().enumerate() {
        if robin.is_some_and(|r| !r[qi]) {
            continue;
        }
        let p = q.map(|i| x[i as usize]);
        for (k, a) in quad_corner_areas(&p).into_iter().enumerate() {
            area[q[k] as usize] += a.length();
            normal[q[k] as usize] += a;
        }
    }
    for v in &mut normal {
        *v = v.normalize_or_zero();
    }
    let ids = (0..n as u32).filter(|&i| area[i as usize] > 0.0).collect();
    (ids, area, normal)
}

/// The 12 edges of a hex as corner pairs (lattice order), x edges first, then y, then z.
pub const CELL_EDGES: [[usize; 2]; 12] =
    [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5], [2, 6], [3, 7]];

/// The trilinear map of a hex with corners `p` (lattice order) at local (u, v, w) ∈ [0, 1]³
/// and its three partial derivatives.
pub(super) fn trilinear(p: &[DVec3; 8], u: f64, v: f64, w: f64) -> [DVec3; 3] {
    let (iu, iv, iw) = (1.0 - u, 1.0 - v, 1.0 - w);
    let du = (p[1] - p[0]) * iv * iw + (p[3] - p[2]) * v * iw + (p[5] - p[4]) * iv * w + (p[7] - p[6]) * v * w;
    let dv = (p[2] - p[0]) * iu * iw + (p[3] - p[1]) * u * iw + (p[6] - p[4]) * iu * w + (p[7] - p[5]) * u * w;
    let dw = (p[4] - p[0]) * iu * iv + (p[5] - p[1]) * u * iv + (p[6] - p[2]) * iu * v + (p[7] - p[3]) * u * v;
    [du, dv, dw]
}

/// The two-point transmissibility (a·d)/|d|² of each of [`CELL_EDGES`] in a hex with corners
/// `p` (mm): a the area vector of the quarter of the mid-section next to the edge, oriented
/// along the edge (midpoint rule, exact: its normal field is bilinear on the section).
fn edge_transmissibilities(p: &[DVec3; 8]) -> [f64; 12] {
    std::array::from_fn(|e| {
        let [a, b] = CELL_EDGES[e];
        let axis = (a ^ b).trailing_zeros() as usize;
        // The quarter's centre: ½ along the edge's axis, ¼ or ¾ along the others.
        let mut at = [0.0; 3];
        for (k, x) in at.iter_mut().enumerate() {
            *x = if k == axis {
                0.5
            } else if a & (1 << k) == 0 {
                0.25
            } else {
                0.75
            };
        }
        let j = trilinear(p, at[0], at[1], at[2]);
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let area = j[u].cross(j[v]) * 0.25;
        let d = p[b] - p[a];
        area.dot(d) / d.length_squared()
    })
}

/// The volume of each corner's octant of a hex with corners `p` (the Jacobian determinant at
/// the octant's centre × ⅛; the eight sum to the hex's volume up to the trilinear map's
/// curvature, exactly for parallelepipeds).
fn octant_volumes(p: &[DVec3; 8]) -> [f64; 8] {
    std::array::from_fn(|k| {
        let at = |bit: usize| if k & bit == 0 { 0.25 } else { 0.75 };
        let j = trilinear(p, at(1), at(2), at(4));
        j[0].dot(j[1].cross(j[2])) / 8.0
    })
}

/// The area vector of each corner's quarter of a bilinear quad with corners `p` in
/// counter-clockwise order (midpoint rule, exact: the normal field is bilinear).
fn quad_corner_areas(p: &[DVec3; 4]) -> [DVec3; 4] {
    let at = |s: f64, t: f64| {
        let ds = (p[1] - p[0]) * (1.0 - t) + (p[2] - p[3]) * t;
        let dt = (p[3] - p[0]) * (1.0 - s) + (p[2] - p[1]) * s;
        ds.cross(dt) * 0.25
    };
    [at(0.25, 0.25), at(0.75, 0.25), at(0.75, 0.75), at(0.25, 0.75)]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_cube() -> [DVec3; 8] {
        std::array::from_fn(|k| DVec3::new((k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64))
    }

    #[test]
    fn a_box_cell_gives_the_seven_point_weights() {
        // A 2 × 3 × 4 box: the x edges carry (quarter of 3 × 4)/2 each, etc.
        let p = unit_cube().map(|c| c * DVec3::new(2.0, 3.0, 4.0));
        let t = edge_transmissibilities(&p);
        for e in 0..4 {
            assert!((t[e] - 3.0 * 4.0 / 4.0 / 2.0).abs() < 1e-12);
            assert!((t[4 + e] - 2.0 * 4.0 / 4.0 / 3.0).abs() < 1e-12);
            assert!((t[8 + e] - 2.0 * 3.0 / 4.0 / 4.0).abs() < 1e-12);
        }
        let v = octant_volumes(&p);
        assert!(v.iter().all(|&v| (v - 3.0).abs() < 1e-12));
        let q = quad_corner_areas(&[p[0], p[1], p[3], p[2]]);
        for a in q {
            assert!((a - DVec3::new(0.0, 0.0, 1.5)).length() < 1e-12);
        }
    }

    #[test]
    fn octants_sum_to_the_volume_of_a_sheared_cell() {
        // A parallelepiped: exact.
        let m = glam::DMat3::from_cols(DVec3::new(1.0, 0.2, 0.1), DVec3::new(0.3, 2.0, 0.0), DVec3::new(-0.2, 0.4, 1.5));
        let p = unit_cube().map(|c| m * c);
        let v: f64 = octant_volumes(&p).iter().sum();
        assert!((v - m.determinant()).abs() < 1e-12);
    }
}
