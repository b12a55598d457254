//! The part of a diffusion system that depends on the mesh only (STYLE: split structure from
//! values): the sparsity pattern, for every matrix row the tets and boundary triangles around its
//! vertex with the value slots they write to, the per-tet geometry in millimetres (volumes and
//! the cotangent edge coefficients of TransCut eq. 10), and the boundary vertices with their
//! areas S_i. Built once per mesh; changing media (painting) or light (relighting) only refills
//! values from it.

use std::sync::Arc;

use glam::DVec3;
use rayon::prelude::*;

use super::error::DiffusionError;
use super::layer;
use crate::mesh::TetMesh;
use crate::optics::Medium;
use crate::sparse::CsrPattern;

/// The six edges of a tet as local vertex pairs, the order of the per-tet edge coefficients.
pub(crate) const TET_EDGES: [[usize; 2]; 6] = [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]];

/// `EDGE_INDEX[a][b]`: the index in [`TET_EDGES`] of the edge between local vertices `a ≠ b`.
pub(crate) const EDGE_INDEX: [[usize; 4]; 4] =
    [[usize::MAX, 0, 1, 2], [0, usize::MAX, 3, 4], [1, 3, usize::MAX, 5], [2, 4, 5, usize::MAX]];

/// `OTHERS[a]`: the three local vertices of a tet other than `a`, increasing.
pub(crate) const OTHERS: [[usize; 3]; 4] = [[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]];

/// Marks an interior vertex in the vertex → boundary index map.
pub(crate) const INTERIOR: u32 = u32::MAX;

/// Rows per parallel block in assembly (fixed, so that results do not depend on the thread
/// count; each row is summed on its own, in a fixed order, anyway).
pub(crate) const ROW_BLOCK: usize = 512;

/// The vertices on the object's surface, in increasing vertex order: the order of every
/// per-boundary-vertex array of this module (the source q, the exitant radiance).
#[derive(Debug, Clone, PartialEq)]
pub struct BoundaryVertices {
    /// Mesh vertex ids, increasing.
    pub ids: Vec<u32>,
    /// S_i: the total area (mm²) of the boundary triangles around each vertex. Its Voronoi share
    /// of the surface, the |∂Υ ∩ ∂Ω| of TransCut eq. 11, is S_i/3.
    pub area_mm2: Vec<f64>,
    /// Area-weighted outward unit normal (for evaluating the source q and the view direction).
    pub normal: Vec<DVec3>,
}

impl BoundaryVertices {
    /// Number of boundary vertices.
    #[must_use]
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// Whether there are none (never for a valid tet mesh, whose boundary is closed).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// Total surface area (mm²): Σ S_i / 3.
    #[must_use]
    pub fn total_area_mm2(&self) -> f64 {
        self.area_mm2.iter().sum::<f64>() / 3.0
    }
}

/// One tet around the vertex of a row: the tet, the vertex's local index in it, and the value
/// slots (relative to the row start) of the other three local vertices ([`OTHERS`] order).
#[derive(Debug, Clone, Copy)]
pub(crate) struct TetIncidence {
    pub tet: u32,
    pub local: u32,
    pub slots: [u32; 3],
}

/// One boundary triangle around a boundary vertex: the face, its other two vertices and their
/// value slots in the vertex's row.
#[derive(Debug, Clone, Copy)]
pub(crate) struct FaceIncidence {
    pub face: u32,
    pub others: [u32; 2],
    pub slots: [u32; 2],
}

/// Per-material coefficients (mm and mm⁻¹), per channel.
#[derive(Debug, Clone)]
pub(crate) struct Coefficients {
    /// κ = 1/(3(σa + σ′s)).
    pub kappa: Vec<[f64; 3]>,
    /// μ = σa.
    pub mu: Vec<[f64; 3]>,
    /// σtr = √(μ/κ), the inverse thickness of the boundary layer (the fitted assembly's).
    pub sigma_tr: Vec<[f64; 3]>,
}

impl Coefficients {
    /// κ = 1/(3(σa + σ′s)), μ = σa and σtr = √(μ/κ) of every medium of a table.
    pub(crate) fn of(media: &[Medium]) -> Self {
        let kappa: Vec<[f64; 3]> = media.par_iter().map(Medium::diffusion_coefficient).collect();
        let mu: Vec<[f64; 3]> = media.par_iter().map(|m| m.sigma_a).collect();
        let sigma_tr = mu.iter().zip(&kappa).map(|(&m, &k)| sigma_tr(m, k)).collect();
        Self { kappa, mu, sigma_tr }
    }

    /// Entry `m` from `medium`, as [`Coefficients::of`] derives it.
    pub(crate) fn set(&mut self, m: usize, medium: &Medium) {
        self.kappa[m] = medium.diffusion_coefficient();
        self.mu[m] = medium.sigma_a;
        self.sigma_tr[m] = sigma_tr(self.mu[m], self.kappa[m]);
    }
}

/// σtr = √(μ/κ) per channel.
fn sigma_tr(mu: [f64; 3], kappa: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|ch| (mu[ch] / kappa[ch]).sqrt())
}

/// Mesh-only data shared by every system assembled on one mesh (see the module docs).
#[derive(Debug)]
pub(crate) struct Structure {
    pub pattern: Arc<CsrPattern>,
    pub mm_per_unit: f64,
    /// Vertex positions in millimetres.
    pub positions_mm: Vec<DVec3>,
    pub tets: Vec<[u32; 4]>,
    pub materials: Vec<u32>,
    /// V_t (mm³).
    pub volume: Vec<f64>,
    /// (1/6)|kl| cot θ_kl (mm) for each edge ij of the tet in [`TET_EDGES`] order, k, l the
    /// other two vertices and θ_kl the dihedral angle at edge kl (TransCut eq. 10 without κ).
    pub edge_coef: Vec<[f64; 6]>,
    /// Row i's tets: `tet_inc[tet_inc_offsets[i]..tet_inc_offsets[i + 1]]`, by increasing tet.
    pub tet_inc_offsets: Vec<usize>,
    pub tet_inc: Vec<TetIncidence>,
    pub boundary: BoundaryVertices,
    /// Vertex → index into `boundary.ids`, or [`INTERIOR`].
    pub boundary_index: Vec<u32>,
    /// Areas (mm²) of the boundary triangles (in the mesh's boundary-face order).
    pub face_area: Vec<f64>,
    /// Mean curvature (mm⁻¹, positive where convex) at each boundary vertex from its ring of
    /// boundary neighbours ([`super::layer::mean_curvature`]); None at edges and corners.
    pub curvature: Vec<Option<f64>>,
    /// Material of the tet owning each boundary face.
    pub face_material: Vec<u32>,
    /// Boundary vertex b's faces: `face_inc[face_inc_offsets[b]..face_inc_offsets[b + 1]]`.
    pub face_inc_offsets: Vec<usize>,
    pub face_inc: Vec<FaceIncidence>,
}

/// Gradients of the four barycentric (hat) functions of a tet: with e_k = p_k − p_0 and
/// det = e_1·(e_2 × e_3) (six times the signed volume), ∇β_1 = (e_2 × e_3)/det,
/// ∇β_2 = (e_3 × e_1)/det, ∇β_3 = (e_1 × e_2)/det and ∇β_0 = −(∇β_1 + ∇β_2 + ∇β_3), so that
/// ∇β_a·(p_b − p_0) = δ_ab − δ_0b. |∇β_a| = 1/h_a and it points from the face opposite a
/// towards p_a (TransCut §3.3: ∇β_a = S_a n_a / (3V)). Independent of the tet's orientation
/// (numerators and det change sign together); not finite for a flat tet.
#[must_use]
pub(crate) fn hat_gradients(p: [DVec3; 4]) -> [DVec3; 4] {
    let (e1, e2, e3) = (p[1] - p[0], p[2] - p[0], p[3] - p[0]);
    let c1 = e2.cross(e3);
    let inv = 1.0 / e1.dot(c1);
    let (g1, g2, g3) = (c1 * inv, e3.cross(e1) * inv, e1.cross(e2) * inv);
    [-(g1 + g2 + g3), g1, g2, g3]
}

/// The volume V (mm³) of one tet and its TransCut edge coefficients in [`TET_EDGES`] order: for
/// edge ij with other vertices k, l, c_ij = (1/6)|kl| cot θ_kl, θ_kl the interior dihedral angle
/// at edge kl, so that the tet's part of TransCut eq. 10 is w_ijt = −κ_t c_ij.
///
/// Computed through the identity of TransCut §3.3, c_ij = −V ∇β_i·∇β_j (the P1 stiffness entry
/// without κ): θ_kl is the angle between the faces opposite i and j, so cos θ_kl =
/// −∇β_i·∇β_j / (|∇β_i||∇β_j|), and |∇β_i × ∇β_j| = |kl|/(6V) (from V = (2/3) A_i A_j sin θ_kl / |kl|),
/// hence cot θ_kl = −6V ∇β_i·∇β_j / |kl|. One determinant, three cross products and no square
/// root: this is the hot loop of the mesh-only part of assembly. (The tests check it against
/// the dihedral angles of [`crate::mesh::quality`].)
#[must_use]
pub(crate) fn tet_geometry(p: [DVec3; 4]) -> (f64, [f64; 6]) {
    let g = hat_gradients(p);
    let v = signed_volume(p).abs();
    (v, TET_EDGES.map(|[i, j]| -v * g[i].dot(g[j])))
}

/// The two local vertices of a tet other than `i` and `j` (for the tests' independent formulas).
#[cfg(test)]
pub(crate) fn other_pair(i: usize, j: usize) -> [usize; 2] {
    let mut out = [0; 2];
    let mut n = 0;
    for v in 0..4 {
        if v != i && v != j {
            out[n] = v;
            n += 1;
        }
    }
    out
}

/// Signed volume of a tet, (p1 − p0)·((p2 − p0) × (p3 − p0))/6.
#[must_use]
pub(crate) fn signed_volume(p: [DVec3; 4]) -> f64 {
    (p[1] - p[0]).dot((p[2] - p[0]).cross(p[3] - p[0])) / 6.0
}

/// Checks the length scale.
pub(crate) fn check_scale(mm_per_unit: f64) -> Result<(), DiffusionError> {
    if mm_per_unit.is_finite() && mm_per_unit > 0.0 {
        Ok(())
    } else {
        Err(DiffusionError::InvalidScale { value: mm_per_unit })
    }
}

impl Structure {
    /// Builds the structure of `mesh` with positions scaled by `mm_per_unit` to millimetres.
    ///
    /// # Errors
    /// [`DiffusionError::InvalidScale`]; [`DiffusionError::DegenerateTet`] for a tet whose
    /// volume or edge coefficients are not finite and positive / finite in millimetres (e.g. a
    /// scale that over- or underflows); [`DiffusionError::Sparse`] if the pattern cannot be
    /// built (more than 2³² vertices).
    pub(crate) fn new(mesh: &TetMesh, mm_per_unit: f64) -> Result<Structure, DiffusionError> {
        check_scale(mm_per_unit)?;
        let n = mesh.vertex_count();
        let positions_mm: Vec<DVec3> = mesh.positions().par_iter().map(|&p| p * mm_per_unit).collect();
        let tets = mesh.tets().to_vec();
        let mut volume = vec![0.0; tets.len()];
        let mut edge_coef = vec![[0.0; 6]; tets.len()];
        (&mut volume, &mut edge_coef, &tets).into_par_iter().with_min_len(1024).for_each(|(v, c, t)| {
            (*v, *c) = tet_geometry(t.map(|v| positions_mm[v as usize]));
        });
        let bad = |v: f64, c: &[f64; 6]| !(v.is_finite() && v > 0.0) || c.iter().any(|x| !x.is_finite());
        if let Some(t) = (0..tets.len()).into_par_iter().position_first(|t| bad(volume[t], &edge_coef[t])) {
            let (v, c) = (volume[t], edge_coef[t]);
            let (what, value) = if !(v.is_finite() && v > 0.0) {
                ("volume", v)
            } else {
                ("edge weight", c.iter().copied().find(|x| !x.is_finite()).unwrap_or(f64::NAN))
            };
            return Err(DiffusionError::DegenerateTet { tet: t, what, value });
        }
        let pattern = Arc::new(CsrPattern::from_edges(n, mesh.edges())?);

        // Vertex → tets (counting sort over the tets in order: each row's list is by tet id).
        let mut tet_inc_offsets = vec![0usize; n + 1];
        for t in &tets {
            for &v in t {
                tet_inc_offsets[v as usize + 1] += 1;
            }
        }
        for i in 0..n {
            tet_inc_offsets[i + 1] += tet_inc_offsets[i];
        }
        let mut fill = tet_inc_offsets.clone();
        let mut tet_inc = vec![TetIncidence { tet: 0, local: 0, slots: [0; 3] }; 4 * tets.len()];
        for (t, tet) in tets.iter().enumerate() {
            for (a, &v) in tet.iter().enumerate() {
                let k = &mut fill[v as usize];
                tet_inc[*k] = TetIncidence { tet: t as u32, local: a as u32, slots: [0; 3] };
                *k += 1;
            }
        }
        // The slot of `col` in `row`: the number of the row's (sorted) columns below it, a
        // branch-free count that vectorises (rows hold ~15 columns; a binary search
        // mispredicts at every step). Every tet edge is a mesh edge, so `col` is in the row.
        let slot = |row: usize, col: u32| -> u32 {
            let cols = pattern.row(row);
            let k = cols.iter().map(|&c| u32::from(c < col)).sum::<u32>();
            debug_assert_eq!(cols[k as usize], col, "every tet edge is a mesh edge");
            k
        };
        tet_inc.par_chunks_mut(4096).enumerate().for_each(|(c, chunk)| {
            let first = c * 4096;
            // The row of an incidence: found by walking the offsets from the chunk's first row.
            let mut row = tet_inc_offsets.partition_point(|&o| o <= first) - 1;
            for (k, inc) in chunk.iter_mut().enumerate() {
                while tet_inc_offsets[row + 1] <= first + k {
                    row += 1;
                }
                let tet = tets[inc.tet as usize];
                inc.slots = OTHERS[inc.local as usize].map(|b| slot(row, tet[b]));
            }
        });

        // Boundary vertices, their areas S_i and normals, and vertex → boundary faces.
        let faces: Vec<[u32; 3]> = mesh.boundary_faces().iter().map(|f| f.vertices).collect();
        let face_material: Vec<u32> = mesh.boundary_faces().iter().map(|f| mesh.materials()[f.tet as usize]).collect();
        let face_cross: Vec<DVec3> = faces
            .par_iter()
            .map(|f| {
                let [a, b, c] = f.map(|v| positions_mm[v as usize]);
                (b - a).cross(c - a)
            })
            .collect();
        let face_area: Vec<f64> = face_cross.iter().map(|c| 0.5 * c.length()).collect();
        let ids: Vec<u32> = (0..n as u32).filter(|&v| mesh.is_boundary_vertex(v as usize)).collect();
        let mut boundary_index = vec![INTERIOR; n];
        for (b, &v) in ids.iter().enumerate() {
            boundary_index[v as usize] = b as u32;
        }
        let nb = ids.len();
        let mut face_inc_offsets = vec![0usize; nb + 1];
        for f in &faces {
            for &v in f {
                face_inc_offsets[boundary_index[v as usize] as usize + 1] += 1;
            }
        }
        for b in 0..nb {
            face_inc_offsets[b + 1] += face_inc_offsets[b];
        }
        let mut fill = face_inc_offsets.clone();
        let mut face_inc = vec![FaceIncidence { face: 0, others: [0; 2], slots: [0; 2] }; 3 * faces.len()];
        let mut area_mm2 = vec![0.0; nb];
        let mut normal = vec![DVec3::ZERO; nb];
        for (fi, f) in faces.iter().enumerate() {
            for a in 0..3 {
                let v = f[a];
                let b = boundary_index[v as usize] as usize;
                let others = [f[(a + 1) % 3], f[(a + 2) % 3]];
                face_inc[fill[b]] = FaceIncidence { face: fi as u32, others, slots: others.map(|o| slot(v as usize, o)) };
                fill[b] += 1;
                area_mm2[b] += face_area[fi];
                normal[b] += face_cross[fi];
            }
        }
        let normal: Vec<DVec3> = normal.into_iter().map(DVec3::normalize_or_zero).collect();
        let curvature = (0..nb)
            .into_par_iter()
            .map(|b| {
                let here = positions_mm[ids[b] as usize];
                let offsets: Vec<DVec3> = face_inc[face_inc_offsets[b]..face_inc_offsets[b + 1]]
                    .iter()
                    .flat_map(|f| f.others)
                    .map(|o| positions_mm[o as usize] - here)
                    .collect();
                layer::mean_curvature(normal[b], &offsets)
            })
            .collect();
        Ok(Structure {
            pattern,
            mm_per_unit,
            positions_mm,
            tets,
            materials: mesh.materials().to_vec(),
            volume,
            edge_coef,
            tet_inc_offsets,
            tet_inc,
            boundary: BoundaryVertices { ids, area_mm2, normal },
            boundary_index,
            face_area,
            curvature,
            face_material,
            face_inc_offsets,
            face_inc,
        })
    }

    /// Number of vertices (matrix rows).
    pub(crate) fn n(&self) -> usize {
        self.positions_mm.len()
    }

    /// Row i's tets.
    pub(crate) fn tets_of(&self, i: usize) -> &[TetIncidence] {
        &self.tet_inc[self.tet_inc_offsets[i]..self.tet_inc_offsets[i + 1]]
    }

    /// Boundary vertex b's faces.
    pub(crate) fn faces_of(&self, b: usize) -> &[FaceIncidence] {
        &self.face_inc[self.face_inc_offsets[b]..self.face_inc_offsets[b + 1]]
    }
}

/// Fills `values` (laid out by `row_ptr`) row by row in parallel: `f(row, row_values)` for every
/// row, in blocks of [`ROW_BLOCK`] rows. Each row is written by exactly one call, so the result
/// does not depend on the thread count.
pub(crate) fn fill_rows<T: Send>(values: &mut [T], row_ptr: &[usize], f: impl Fn(usize, &mut [T]) + Sync) {
    let n = row_ptr.len() - 1;
    let mut blocks: Vec<(usize, &mut [T])> = Vec::with_capacity(n.div_ceil(ROW_BLOCK));
    let mut rest = values;
    let mut r0 = 0;
    while r0 < n {
        let r1 = (r0 + ROW_BLOCK).min(n);
        let (head, tail) = std::mem::take(&mut rest).split_at_mut(row_ptr[r1] - row_ptr[r0]);
        blocks.push((r0, head));
        rest = tail;
        r0 = r1;
    }
    blocks.into_par_iter().for_each(|(r0, mut block)| {
        for row in r0..(r0 + ROW_BLOCK).min(n) {
            let len = row_ptr[row + 1] - row_ptr[row];
            let (head, tail) = std::mem::take(&mut block).split_at_mut(len);
            f(row, head);
            block = tail;
        }
    });
}

/// Fills only the rows `rows` (increasing, no repeats) of `values` (laid out by `row_ptr`), in
/// parallel: `f(row, row_values)` once for each listed row. The other rows are untouched.
///
/// # Panics
/// If `rows` is not strictly increasing or names a row out of range (callers build it so).
pub(crate) fn fill_selected_rows<T: Send>(values: &mut [T], row_ptr: &[usize], rows: &[u32], f: impl Fn(usize, &mut [T]) + Sync) {
    let mut slices: Vec<(usize, &mut [T])> = Vec::with_capacity(rows.len());
    let mut rest = values;
    let mut consumed = 0;
    for &r in rows {
        let r = r as usize;
        let (_, tail) = std::mem::take(&mut rest).split_at_mut(row_ptr[r] - consumed);
        let (row, tail) = tail.split_at_mut(row_ptr[r + 1] - row_ptr[r]);
        slices.push((r, row));
        rest = tail;
        consumed = row_ptr[r + 1];
    }
    slices.into_par_iter().with_min_len(ROW_BLOCK / 8).for_each(|(r, row)| f(r, row));
}

impl Structure {
    /// The vertices of `tets` (the matrix rows their media write to), increasing, no repeats.
    ///
    /// # Errors
    /// [`DiffusionError::TetOutOfRange`] naming the first tet id that does not exist.
    pub(crate) fn rows_of_tets(&self, tets: &[u32]) -> Result<Vec<u32>, DiffusionError> {
        if let Some(&t) = tets.iter().find(|&&t| t as usize >= self.tets.len()) {
            return Err(DiffusionError::TetOutOfRange { tet: t as usize, count: self.tets.len() });
        }
        let mut hit = vec![false; self.n()];
        for &t in tets {
            for v in self.tets[t as usize] {
                hit[v as usize] = true;
            }
        }
        Ok((0..self.n() as u32).filter(|&v| hit[v as usize]).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::dihedral_angles;

    fn sample_tets() -> Vec<[DVec3; 4]> {
        vec![
            [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z],
            [DVec3::new(0.1, -0.2, 0.3), DVec3::new(1.7, 0.1, -0.2), DVec3::new(0.4, 1.3, 0.2), DVec3::new(0.5, 0.6, 2.1)],
            // Negatively oriented and with an obtuse dihedral angle.
            [DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.9, 0.9, 0.3)],
        ]
    }

    #[test]
    fn tet_geometry_is_the_cotangent_formula_and_the_p1_stiffness() {
        for q in sample_tets() {
            let p = if signed_volume(q) > 0.0 { q } else { [q[0], q[1], q[3], q[2]] };
            let (vol, c) = tet_geometry(p);
            assert!((vol - signed_volume(p)).abs() < 1e-14, "volume");
            // The mesh module's independent dihedral angles (positively oriented tets).
            let angles = dihedral_angles(p);
            let v = signed_volume(p);
            let g = hat_gradients(p);
            for (e, [i, j]) in TET_EDGES.iter().copied().enumerate() {
                let [k, l] = other_pair(i, j);
                let expect = (p[k] - p[l]).length() / angles[EDGE_INDEX[k][l]].tan() / 6.0;
                assert!((c[e] - expect).abs() < 1e-12 * (1.0 + expect.abs()), "{e}: {} vs {expect}", c[e]);
                // TransCut §3.3: −(1/6)|kl| cot θ_kl = V ∇β_i·∇β_j (the P1 stiffness entry).
                let stiffness = v * g[i].dot(g[j]);
                assert!((c[e] + stiffness).abs() < 1e-12 * (1.0 + stiffness.abs()));
            }
            // Orientation does not matter: swapping local vertices 2 and 3 permutes the edges.
            let s = tet_geometry([p[0], p[1], p[3], p[2]]).1;
            for (e, f) in [(0, 0), (1, 2), (2, 1), (3, 4), (4, 3), (5, 5)] {
                assert!((s[e] - c[f]).abs() < 1e-12 * (1.0 + c[f].abs()));
            }
        }
        // One sample has an obtuse dihedral angle: a negative coefficient.
        assert!(sample_tets().iter().any(|&p| tet_geometry(p).1.iter().any(|&x| x < 0.0)));
    }

    #[test]
    fn hat_gradients_sum_to_zero_and_reproduce_linear_functions() {
        for p in sample_tets() {
            let g = hat_gradients(p);
            assert!((g[0] + g[1] + g[2] + g[3]).length() < 1e-12);
            let f = |x: DVec3| 0.3 * x.x - 1.2 * x.y + 2.0 * x.z + 0.7;
            let grad: DVec3 = (0..4).map(|a| f(p[a]) * g[a]).sum();
            assert!((grad - DVec3::new(0.3, -1.2, 2.0)).length() < 1e-12);
        }
    }

    #[test]
    fn fill_rows_visits_every_row_once_with_its_own_slice() {
        // Rows of length 3 up to 700, then of length 1.
        let mut row_ptr = vec![0];
        for r in 0..1500 {
            row_ptr.push(row_ptr[r] + if r < 700 { 3 } else { 1 });
        }
        let mut values = vec![usize::MAX; row_ptr[1500]];
        fill_rows(&mut values, &row_ptr, |row, vals| {
            assert_eq!(vals.len(), row_ptr[row + 1] - row_ptr[row]);
            vals.iter_mut().for_each(|v| *v = row);
        });
        for r in 0..1500 {
            assert!(values[row_ptr[r]..row_ptr[r + 1]].iter().all(|&v| v == r));
        }
    }
}
