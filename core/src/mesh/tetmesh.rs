//! The tetrahedral mesh and its topology: one-rings, unique edges, boundary faces with outward
//! normals, boundary flags, volumes, dihedral angles and per-tet material ids.
//!
//! Layout: positions and tets are plain arrays; the topology is built once in [`TetMesh::new`]
//! (parallel sorts, deterministic) and then only read. Vertex adjacency is stored in CSR form:
//! the neighbours of vertex `v` are `ring[ring_offsets[v]..ring_offsets[v + 1]]`, sorted.

use glam::DVec3;
use rayon::prelude::*;

use super::bvh::SurfacePoint;
use super::by_vertex::ByVertex;
use super::quality::{dihedral_angles, tet_volume, QualityReport, TET_EDGES, TET_FACES};

/// A triangle of the boundary surface, counter-clockwise seen from outside, and the tet it
/// belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoundaryFace {
    /// Vertex indices, oriented so that the right-hand normal points out of the solid.
    pub vertices: [u32; 3],
    /// The tet that owns this face.
    pub tet: u32,
}

/// Defects of a boundary surface (all zero for a closed 2-manifold).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize)]
pub struct BoundaryTopology {
    /// Edges in only one boundary triangle.
    pub open_edges: usize,
    /// Edges in more than two boundary triangles.
    pub nonmanifold_edges: usize,
    /// Vertices whose boundary triangles form more than one fan.
    pub nonmanifold_vertices: usize,
}

impl BoundaryTopology {
    /// Whether the boundary is a closed 2-manifold.
    #[must_use]
    pub fn is_closed_manifold(&self) -> bool {
        *self == Self::default()
    }
}

/// What is wrong with a tetrahedral mesh given to [`TetMesh::new`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TetMeshError {
    /// No vertices or no tets.
    #[error("empty tetrahedral mesh: {vertices} vertices, {tets} tets")]
    Empty { vertices: usize, tets: usize },
    /// A vertex coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate")]
    NonFinite { vertex: usize },
    /// A tet refers to a vertex that does not exist.
    #[error("tet {tet} refers to vertex {index}, but there are {vertex_count} vertices")]
    IndexOutOfRange { tet: usize, index: u32, vertex_count: usize },
    /// A tet repeats a vertex or has (numerically) zero volume.
    #[error("tet {tet} is degenerate (volume {volume:e})")]
    Degenerate { tet: usize, volume: f64 },
    /// A triangle is shared by more than two tets.
    #[error("face ({}, {}, {}) is shared by {count} tets; a tet mesh shares a face by at most 2", .face[0], .face[1], .face[2])]
    NonManifoldFace { face: [u32; 3], count: usize },
    /// The per-tet material array does not have one entry per tet.
    #[error("{materials} material ids for {tets} tets")]
    MaterialCount { materials: usize, tets: usize },
}

/// A tetrahedral mesh with positively oriented tets and its topology.
#[derive(Debug, Clone)]
pub struct TetMesh {
    positions: Vec<DVec3>,
    tets: Vec<[u32; 4]>,
    materials: Vec<u32>,
    ring_offsets: Vec<u32>,
    ring: Vec<u32>,
    edges: Vec<[u32; 2]>,
    boundary_faces: Vec<BoundaryFace>,
    on_boundary: Vec<bool>,
    surface_map: Vec<SurfacePoint>,
}

impl TetMesh {
    /// Builds a mesh and its topology. Negatively oriented tets are flipped (two vertices swapped);
    /// `materials` gives a material id per tet (empty = all 0).
    ///
    /// # Errors
    /// [`TetMeshError`] for empty input, non-finite coordinates, out-of-range indices, degenerate
    /// tets (volume below `1e-14 ×` bounding-box diagonal³) and faces shared by more than two tets.
    pub fn new(positions: Vec<DVec3>, mut tets: Vec<[u32; 4]>, materials: Vec<u32>) -> Result<Self, TetMeshError> {
        check_nonempty_finite(&positions, &tets)?;
        let materials = if materials.is_empty() { vec![0; tets.len()] } else { materials };
        if materials.len() != tets.len() {
            return Err(TetMeshError::MaterialCount { materials: materials.len(), tets: tets.len() });
        }
        orient_and_check(&positions, &mut tets)?;
        let boundary_faces = boundary_faces(&tets, positions.len())?;
        Ok(Self::with_boundary(positions, tets, materials, boundary_faces))
    }

    /// The rest of the topology, from oriented, checked tets and their boundary faces.
    fn with_boundary(positions: Vec<DVec3>, tets: Vec<[u32; 4]>, materials: Vec<u32>, boundary_faces: Vec<BoundaryFace>) -> Self {
        let n = positions.len();
        let edges = unique_edges(&tets, n);
        let (ring_offsets, ring) = one_rings(n, &edges);
        let mut on_boundary = vec![false; n];
        for f in &boundary_faces {
            for v in f.vertices {
                on_boundary[v as usize] = true;
            }
        }
        Self { positions, tets, materials, ring_offsets, ring, edges, boundary_faces, on_boundary, surface_map: Vec::new() }
    }

    /// The same mesh with every position mapped by `f` (e.g. a rigid motion). The topology is
    /// kept; it is re-validated only for orientation and degeneracy.
    ///
    /// # Errors
    /// [`TetMeshError`] if the map makes a position non-finite or a tet degenerate or inverted.
    pub fn map_positions(mut self, f: impl Fn(DVec3) -> DVec3 + Sync) -> Result<Self, TetMeshError> {
        self.positions.par_iter_mut().for_each(|p| *p = f(*p));
        if let Some(v) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(TetMeshError::NonFinite { vertex: v });
        }
        if let Some(t) = (0..self.tets.len()).find(|&t| !(self.tet_volume(t) > 0.0)) {
            return Err(TetMeshError::Degenerate { tet: t, volume: self.tet_volume(t) });
        }
        Ok(self)
    }

    /// Vertex positions.
    #[must_use]
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// Tets as vertex quadruples, all positively oriented ([`tet_volume`] > 0).
    #[must_use]
    pub fn tets(&self) -> &[[u32; 4]] {
        &self.tets
    }

    /// Per-tet material id.
    #[must_use]
    pub fn materials(&self) -> &[u32] {
        &self.materials
    }

    /// Replaces the per-tet material ids.
    ///
    /// # Errors
    /// [`TetMeshError::MaterialCount`] when `materials.len()` is not the tet count.
    pub fn set_materials(&mut self, materials: Vec<u32>) -> Result<(), TetMeshError> {
        if materials.len() != self.tets.len() {
            return Err(TetMeshError::MaterialCount { materials: materials.len(), tets: self.tets.len() });
        }
        self.materials = materials;
        Ok(())
    }

    /// Number of vertices.
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of tets.
    #[must_use]
    pub fn tet_count(&self) -> usize {
        self.tets.len()
    }

    /// The corner positions of tet `t`.
    #[must_use]
    pub fn tet_positions(&self, t: usize) -> [DVec3; 4] {
        self.tets[t].map(|i| self.positions[i as usize])
    }

    /// Volume of tet `t` (positive).
    #[must_use]
    pub fn tet_volume(&self, t: usize) -> f64 {
        tet_volume(self.tet_positions(t))
    }

    /// Dihedral angles (radians) of tet `t` at its edges `(0,1), (0,2), (0,3), (1,2), (1,3), (2,3)`.
    #[must_use]
    pub fn dihedral_angles(&self, t: usize) -> [f64; 6] {
        dihedral_angles(self.tet_positions(t))
    }

    /// Sorted neighbours of vertex `v` (its one-ring).
    #[must_use]
    pub fn one_ring(&self, v: usize) -> &[u32] {
        &self.ring[self.ring_offsets[v] as usize..self.ring_offsets[v + 1] as usize]
    }

    /// CSR offsets of the one-rings (`vertex_count + 1` entries) and the concatenated rings.
    #[must_use]
    pub fn one_rings(&self) -> (&[u32], &[u32]) {
        (&self.ring_offsets, &self.ring)
    }

    /// Unique edges `[i, j]` with `i < j`, sorted.
    #[must_use]
    pub fn edges(&self) -> &[[u32; 2]] {
        &self.edges
    }

    /// Boundary triangles, oriented outward.
    #[must_use]
    pub fn boundary_faces(&self) -> &[BoundaryFace] {
        &self.boundary_faces
    }

    /// Outward unit normal of boundary face `f`.
    #[must_use]
    pub fn boundary_normal(&self, f: usize) -> DVec3 {
        let [a, b, c] = self.boundary_faces[f].vertices.map(|i| self.positions[i as usize]);
        (b - a).cross(c - a).normalize_or_zero()
    }

    /// Area of boundary face `f`.
    #[must_use]
    pub fn boundary_area(&self, f: usize) -> f64 {
        let [a, b, c] = self.boundary_faces[f].vertices.map(|i| self.positions[i as usize]);
        0.5 * (b - a).cross(c - a).length()
    }

    /// Whether vertex `v` lies on the boundary surface.
    #[must_use]
    pub fn is_boundary_vertex(&self, v: usize) -> bool {
        self.on_boundary[v]
    }

    /// Per-vertex boundary flags.
    #[must_use]
    pub fn boundary_flags(&self) -> &[bool] {
        &self.on_boundary
    }

    /// Total volume, summed in tet order (the same value whatever the thread schedule).
    #[must_use]
    pub fn volume(&self) -> f64 {
        let volumes: Vec<f64> = (0..self.tets.len()).into_par_iter().map(|t| self.tet_volume(t)).collect();
        volumes.iter().sum()
    }

    /// For each vertex of the user's surface mesh this was built from, its location on the
    /// boundary (`SurfacePoint::triangle` indexes [`Self::boundary_faces`]). Empty when the mesh
    /// was not built from a surface.
    #[must_use]
    pub fn surface_map(&self) -> &[SurfacePoint] {
        &self.surface_map
    }

    /// Sets the map from the user's surface vertices to the boundary (see [`Self::surface_map`]).
    pub fn set_surface_map(&mut self, map: Vec<SurfacePoint>) {
        self.surface_map = map;
    }

    /// Interpolates a per-vertex quantity at the user's surface vertices through the surface map.
    #[must_use]
    pub fn sample_at_user_vertices<const N: usize>(&self, values: &[[f64; N]]) -> Vec<[f64; N]> {
        self.surface_map
            .iter()
            .map(|sp| {
                let verts = self.boundary_faces[sp.triangle as usize].vertices;
                let mut out = [0.0; N];
                for (k, &v) in verts.iter().enumerate() {
                    for (o, x) in out.iter_mut().zip(values[v as usize]) {
                        *o += sp.bary[k] * x;
                    }
                }
                out
            })
            .collect()
    }

    /// `values` (per tet-mesh vertex) at points of the user's surface, each given as three user
    /// vertices and barycentric weights: the point Σ wₖ sₖ of the vertices' boundary points
    /// sₖ ([`Self::surface_map`]), then its closest point on the boundary, interpolated there
    /// (at a user vertex, exactly [`Self::sample_at_user_vertices`]). Panics on a user vertex
    /// beyond the map (callers check).
    #[must_use]
    pub fn sample_at_user_points<const N: usize>(&self, points: &[([u32; 3], [f64; 3])], values: &[[f64; N]]) -> Vec<[f64; N]> {
        use rayon::prelude::*;
        let faces: Vec<[u32; 3]> = self.boundary_faces.iter().map(|f| f.vertices).collect();
        let bvh = super::TriangleBvh::from_indexed(&self.positions, &faces);
        points
            .par_iter()
            .map(|(vertices, w)| {
                let p: DVec3 = (0..3).map(|k| w[k] * self.surface_map[vertices[k] as usize].point).sum();
                let sp = bvh.closest_point(p).expect("a mapped tet mesh has boundary faces");
                let mut out = [0.0; N];
                for (k, &v) in faces[sp.triangle as usize].iter().enumerate() {
                    for (o, x) in out.iter_mut().zip(values[v as usize]) {
                        *o += sp.bary[k] * x;
                    }
                }
                out
            })
            .collect()
    }

    /// Boundary edges `[a, b]` (`a < b`, sorted) that do not lie in exactly two boundary
    /// triangles, each with the indices of the boundary faces around it: open edges (one face)
    /// and non-manifold edges (more than two).
    #[must_use]
    pub fn irregular_boundary_edges(&self) -> Vec<([u32; 2], Vec<u32>)> {
        irregular_edges(&self.boundary_faces)
    }

    /// Checks that the boundary surface is closed and manifold: every boundary edge in exactly two
    /// boundary triangles, and the boundary triangles around every boundary vertex forming a
    /// single fan.
    #[must_use]
    pub fn boundary_topology(&self) -> BoundaryTopology {
        let mut report = BoundaryTopology::default();
        for (_, faces) in self.irregular_boundary_edges() {
            if faces.len() == 1 {
                report.open_edges += 1;
            } else {
                report.nonmanifold_edges += 1;
            }
        }
        // Per-vertex fan count: union-find over the faces around v, joined when they share an edge
        // through v; a manifold vertex has one component.
        let mut parent: Vec<u32> = (0..self.boundary_faces.len() as u32).collect();
        fn find(parent: &mut [u32], mut x: u32) -> u32 {
            while parent[x as usize] != x {
                parent[x as usize] = parent[parent[x as usize] as usize];
                x = parent[x as usize];
            }
            x
        }
        let mut faces_at: Vec<Vec<u32>> = vec![Vec::new(); self.positions.len()];
        for (f, face) in self.boundary_faces.iter().enumerate() {
            for &v in &face.vertices {
                faces_at[v as usize].push(f as u32);
            }
        }
        for (v, faces) in faces_at.iter().enumerate() {
            if faces.len() < 2 {
                continue;
            }
            for &f in faces {
                parent[f as usize] = f;
            }
            for (x, &f) in faces.iter().enumerate() {
                for &g in &faces[x + 1..] {
                    let shared = self.boundary_faces[f as usize]
                        .vertices
                        .iter()
                        .filter(|&&w| w as usize != v && self.boundary_faces[g as usize].vertices.contains(&w))
                        .count();
                    if shared > 0 {
                        let (a, b) = (find(&mut parent, f), find(&mut parent, g));
                        parent[a as usize] = b;
                    }
                }
            }
            let roots = faces.iter().filter(|&&f| find(&mut parent, f) == f).count();
            if roots > 1 {
                report.nonmanifold_vertices += 1;
            }
        }
        report
    }

    /// Dihedral-angle statistics over all tets.
    #[must_use]
    pub fn quality(&self) -> QualityReport {
        let per_tet: Vec<(f64, f64, f64)> = (0..self.tets.len())
            .into_par_iter()
            .map(|t| {
                let a = self.dihedral_angles(t);
                let lo = a.iter().copied().fold(f64::INFINITY, f64::min).to_degrees();
                let hi = a.iter().copied().fold(0.0, f64::max).to_degrees();
                (lo, hi, self.tet_volume(t))
            })
            .collect();
        let mut report = QualityReport {
            min_dihedral_deg: f64::INFINITY,
            max_dihedral_deg: 0.0,
            min_angle_histogram: [0; 9],
            max_angle_histogram: [0; 9],
            min_volume: f64::INFINITY,
        };
        for (lo, hi, vol) in per_tet {
            report.min_dihedral_deg = report.min_dihedral_deg.min(lo);
            report.max_dihedral_deg = report.max_dihedral_deg.max(hi);
            report.min_volume = report.min_volume.min(vol);
            report.min_angle_histogram[((lo / 10.0) as usize).min(8)] += 1;
            report.max_angle_histogram[(((hi - 90.0).max(0.0) / 10.0) as usize).min(8)] += 1;
        }
        report
    }
}

/// The first two checks of [`TetMesh::new`]: some vertices and tets, every coordinate finite.
fn check_nonempty_finite(positions: &[DVec3], tets: &[[u32; 4]]) -> Result<(), TetMeshError> {
    if positions.is_empty() || tets.is_empty() {
        return Err(TetMeshError::Empty { vertices: positions.len(), tets: tets.len() });
    }
    if let Some(v) = positions.iter().position(|p| !p.is_finite()) {
        return Err(TetMeshError::NonFinite { vertex: v });
    }
    Ok(())
}

/// Flips every negatively oriented tet (swapping its last two vertices) and rejects indices out
/// of range and tets whose volume is below `1e-14 ×` the bounding-box diagonal³.
fn orient_and_check(positions: &[DVec3], tets: &mut [[u32; 4]]) -> Result<(), TetMeshError> {
    let n = positions.len();
    let (lo, hi) =
        positions.iter().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(a, b), p| (a.min(*p), b.max(*p)));
    let min_volume = 1e-14 * (hi - lo).length().powi(3);
    tets.par_iter_mut().enumerate().try_for_each(|(t, tet)| {
        if let Some(&index) = tet.iter().find(|&&i| i as usize >= n) {
            return Err(TetMeshError::IndexOutOfRange { tet: t, index, vertex_count: n });
        }
        let mut volume = tet_volume(tet.map(|i| positions[i as usize]));
        if volume < 0.0 {
            tet.swap(2, 3);
            volume = -volume;
        }
        if volume <= min_volume {
            return Err(TetMeshError::Degenerate { tet: t, volume });
        }
        Ok(())
    })
}

/// Orients `tets` in place and checks them as [`TetMesh::new`] does: for callers that change
/// the tets round after round and need only their boundary in between
/// ([`boundary_faces_among`]).
///
/// # Errors
/// As [`TetMesh::new`] on the same arrays.
pub(crate) fn orient_tets(positions: &[DVec3], tets: &mut [[u32; 4]]) -> Result<(), TetMeshError> {
    check_nonempty_finite(positions, tets)?;
    orient_and_check(positions, tets)
}

/// The boundary faces of positively oriented `tets` ([`orient_tets`]) among the faces whose
/// three vertices are flagged in `candidates`, in the order [`TetMesh::new`] gives them. When
/// every boundary vertex is flagged (the mesher's surface vertices) these are all the boundary
/// faces, found at the cost of the flagged faces instead of all 4T.
///
/// # Errors
/// [`TetMeshError::NonManifoldFace`] for a flagged face shared by more than two tets.
pub(crate) fn boundary_faces_among(tets: &[[u32; 4]], candidates: &[bool]) -> Result<Vec<BoundaryFace>, TetMeshError> {
    boundary_faces_where(tets, candidates.len(), |key| key.iter().all(|&v| candidates[v as usize]))
}

/// Boundary edges `[a, b]` (`a < b`, sorted) of `faces` that do not lie in exactly two of them,
/// each with the indices of the faces around it (ascending); see
/// [`TetMesh::irregular_boundary_edges`].
pub(crate) fn irregular_edges(faces: &[BoundaryFace]) -> Vec<([u32; 2], Vec<u32>)> {
    let mut edges: Vec<(u64, u32)> = faces
        .iter()
        .enumerate()
        .flat_map(|(f, face)| {
            (0..3).map(move |k| {
                let (a, b) = (face.vertices[k], face.vertices[(k + 1) % 3]);
                ((u64::from(a.min(b)) << 32) | u64::from(a.max(b)), f as u32)
            })
        })
        .collect();
    edges.par_sort_unstable();
    edges
        .chunk_by(|x, y| x.0 == y.0)
        .filter(|group| group.len() != 2)
        .map(|group| ([(group[0].0 >> 32) as u32, group[0].0 as u32], group.iter().map(|e| e.1).collect()))
        .collect()
}

/// Faces that belong to exactly one tet, oriented outward, in ascending order of their sorted
/// vertex triples; errors on the first (in that order) face shared by more than two tets.
fn boundary_faces(tets: &[[u32; 4]], vertex_count: usize) -> Result<Vec<BoundaryFace>, TetMeshError> {
    boundary_faces_where(tets, vertex_count, |_| true)
}

/// [`boundary_faces`] among the faces whose sorted vertex triple passes `keep`.
///
/// Each face is filed under its smallest vertex with the other two as its key ([`ByVertex`]),
/// so the tets sharing it meet in one short sorted list.
fn boundary_faces_where(
    tets: &[[u32; 4]],
    vertex_count: usize,
    keep: impl Fn(&[u32; 3]) -> bool + Sync,
) -> Result<Vec<BoundaryFace>, TetMeshError> {
    let keep = &keep;
    let pairs: Vec<_> = tets
        .par_iter()
        .enumerate()
        .flat_map_iter(|(t, tet)| {
            (0..4u8).filter_map(move |f| {
                let mut key = TET_FACES[f as usize].map(|i| tet[i]);
                key.sort_unstable();
                keep(&key).then(|| (key[0], ((u64::from(key[1]) << 32) | u64::from(key[2]), t as u32, f)))
            })
        })
        .collect();
    let faces = ByVertex::new(vertex_count, &pairs);
    faces.collect(|a, filed, out| {
        for group in filed.chunk_by(|x, y| x.0 == y.0) {
            match group.len() {
                1 => {
                    let (_, t, f) = group[0];
                    let vertices = TET_FACES[f as usize].map(|k| tets[t as usize][k]);
                    out.push(BoundaryFace { vertices, tet: t });
                }
                2 => {}
                count => {
                    let face = [a, (group[0].0 >> 32) as u32, group[0].0 as u32];
                    return Err(TetMeshError::NonManifoldFace { face, count });
                }
            }
        }
        Ok(())
    })
}

/// Unique undirected edges, sorted, `[i, j]` with `i < j` (each filed under its smaller end,
/// [`ByVertex`]).
fn unique_edges(tets: &[[u32; 4]], vertex_count: usize) -> Vec<[u32; 2]> {
    let pairs: Vec<(u32, u32)> = tets
        .par_iter()
        .flat_map_iter(|tet| TET_EDGES.iter().map(move |&[a, b]| (tet[a].min(tet[b]), tet[a].max(tet[b]))))
        .collect();
    let ends = ByVertex::new(vertex_count, &pairs);
    let edges: Result<_, std::convert::Infallible> = ends.collect(|i, others, out| {
        out.extend(others.chunk_by(|x, y| x == y).map(|same| [i, same[0]]));
        Ok(())
    });
    edges.unwrap_or_else(|never| match never {})
}

/// CSR vertex adjacency from sorted unique edges; each ring comes out sorted.
fn one_rings(n: usize, edges: &[[u32; 2]]) -> (Vec<u32>, Vec<u32>) {
    let mut degree = vec![0u32; n + 1];
    for &[i, j] in edges {
        degree[i as usize + 1] += 1;
        degree[j as usize + 1] += 1;
    }
    for v in 0..n {
        degree[v + 1] += degree[v];
    }
    let offsets = degree;
    let mut fill = offsets[..n].to_vec();
    let mut ring = vec![0u32; edges.len() * 2];
    // Edges are sorted by (i, j), so vertex v first receives its lower neighbours i (from edges
    // (i, v), ascending in i) and then its upper neighbours j (from edges (v, j), ascending in j):
    // every ring comes out sorted without a sort.
    for &[i, j] in edges {
        ring[fill[i as usize] as usize] = j;
        fill[i as usize] += 1;
        ring[fill[j as usize] as usize] = i;
        fill[j as usize] += 1;
    }
    (offsets, ring)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_tet() -> TetMesh {
        let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        TetMesh::new(p, vec![[0, 1, 2, 3]], vec![]).unwrap()
    }

    #[test]
    fn single_tet_topology() {
        let m = unit_tet();
        assert_eq!(m.edges().len(), 6);
        assert_eq!(m.boundary_faces().len(), 4);
        assert!((m.volume() - 1.0 / 6.0).abs() < 1e-15);
        assert_eq!(m.one_ring(0), &[1, 2, 3]);
        // Outward normals point away from the centroid.
        let c = DVec3::splat(0.25);
        for f in 0..4 {
            let v = m.boundary_faces()[f].vertices[0] as usize;
            assert!(m.boundary_normal(f).dot(m.positions()[v] - c) > 0.0);
        }
    }

    #[test]
    fn inverted_tet_is_flipped_and_degenerate_rejected() {
        let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        let m = TetMesh::new(p.clone(), vec![[0, 2, 1, 3]], vec![]).unwrap();
        assert!(m.tet_volume(0) > 0.0);
        let flat = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::new(1.0, 1.0, 0.0)];
        assert!(matches!(TetMesh::new(flat, vec![[0, 1, 2, 3]], vec![]), Err(TetMeshError::Degenerate { tet: 0, .. })));
        assert!(matches!(
            TetMesh::new(p, vec![[0, 1, 2, 7]], vec![]),
            Err(TetMeshError::IndexOutOfRange { tet: 0, index: 7, vertex_count: 4 })
        ));
    }

    #[test]
    fn two_tets_share_an_interior_face() {
        let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, DVec3::splat(1.0)];
        let m = TetMesh::new(p, vec![[0, 1, 2, 3], [1, 2, 3, 4]], vec![]).unwrap();
        assert_eq!(m.boundary_faces().len(), 6);
        assert_eq!(m.edges().len(), 9);
        assert!(!m.is_boundary_vertex(0) || m.boundary_flags().iter().all(|&b| b));
    }

    #[test]
    fn regular_tet_dihedral_is_arccos_one_third() {
        let p =
            [DVec3::new(1.0, 1.0, 1.0), DVec3::new(1.0, -1.0, -1.0), DVec3::new(-1.0, 1.0, -1.0), DVec3::new(-1.0, -1.0, 1.0)];
        let p = if tet_volume(p) < 0.0 { [p[0], p[2], p[1], p[3]] } else { p };
        for a in dihedral_angles(p) {
            assert!((a - (1.0f64 / 3.0).acos()).abs() < 1e-12);
        }
    }

    /// Kuhn's six tets per cube on an n³ grid of cubes, vertices in grid order.
    fn kuhn_grid(n: u32) -> (Vec<DVec3>, Vec<[u32; 4]>) {
        let id = |x: u32, y: u32, z: u32| x + (n + 1) * (y + (n + 1) * z);
        let positions = (0..(n + 1).pow(3))
            .map(|i| DVec3::new(f64::from(i % (n + 1)), f64::from((i / (n + 1)) % (n + 1)), f64::from(i / (n + 1).pow(2))))
            .collect();
        let mut tets = Vec::new();
        for (x, y, z) in (0..n).flat_map(|z| (0..n).flat_map(move |y| (0..n).map(move |x| (x, y, z)))) {
            let corner = |c: [u32; 3]| id(x + c[0], y + c[1], z + c[2]);
            for axes in [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]] {
                let mut c = [0u32; 3];
                let mut tet = [corner(c); 4];
                for (k, &a) in axes.iter().enumerate() {
                    c[a] = 1;
                    tet[k + 1] = corner(c);
                }
                tets.push(tet);
            }
        }
        (positions, tets)
    }

    /// The faces in exactly one tet and the unique edges, by brute force with ordered maps, are
    /// what the per-vertex filing gives, in the same (sorted) order; restricted to faces of the
    /// boundary vertices the boundary is the same; a face in three tets is named.
    #[test]
    fn boundary_and_edges_match_a_brute_force_count() {
        let (positions, mut tets) = kuhn_grid(3);
        orient_tets(&positions, &mut tets).unwrap();
        let mut faces = std::collections::BTreeMap::<[u32; 3], Vec<(u32, usize)>>::new();
        let mut edges = std::collections::BTreeSet::new();
        for (t, tet) in tets.iter().enumerate() {
            for (f, face) in TET_FACES.iter().enumerate() {
                let mut key = face.map(|i| tet[i]);
                key.sort_unstable();
                faces.entry(key).or_default().push((t as u32, f));
            }
            for [a, b] in TET_EDGES {
                edges.insert([tet[a].min(tet[b]), tet[a].max(tet[b])]);
            }
        }
        let expected: Vec<BoundaryFace> = faces
            .values()
            .filter(|owners| owners.len() == 1)
            .map(|owners| {
                let (t, f) = owners[0];
                BoundaryFace { vertices: TET_FACES[f].map(|k| tets[t as usize][k]), tet: t }
            })
            .collect();
        assert_eq!(expected.len(), 6 * 9 * 2);
        let found = boundary_faces(&tets, positions.len()).unwrap();
        assert_eq!(found, expected);
        assert_eq!(unique_edges(&tets, positions.len()), edges.into_iter().collect::<Vec<_>>());
        let mut on_boundary = vec![false; positions.len()];
        for f in &found {
            for v in f.vertices {
                on_boundary[v as usize] = true;
            }
        }
        assert_eq!(on_boundary.iter().filter(|&&b| b).count(), 64 - 8);
        assert_eq!(boundary_faces_among(&tets, &on_boundary).unwrap(), expected);

        // A copy of one tet: its faces inside the grid are now in three tets, and the first of
        // them in sorted order is the one named.
        let copy = tets[5];
        let first = TET_FACES
            .iter()
            .map(|face| {
                let mut key = face.map(|i| copy[i]);
                key.sort_unstable();
                key
            })
            .filter(|key| faces[key].len() == 2)
            .min()
            .unwrap();
        tets.push(copy);
        assert!(matches!(
            boundary_faces(&tets, positions.len()),
            Err(TetMeshError::NonManifoldFace { face, count: 3 }) if face == first
        ));
    }
}
