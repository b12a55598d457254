//! The surface triangle mesh every method starts from.

use glam::{DMat4, DVec3, DVec4};

use super::orient::{orient, reversed};
use super::triangulate::triangulate;
use super::weld::weld;
use super::MeshError;

/// Triangles with less than this fraction of the squared bounding-box diagonal as area are
/// degenerate and dropped.
const DEGENERATE_AREA: f64 = 1e-14;

/// Options for merging duplicate vertex positions.
///
/// Files often repeat a position for every face that uses it (a cube as 6 separate quads with 24
/// vertices, a mesh split along UV seams or hard edges). Welding makes those faces share
/// vertices, so the surface is connected and closed where it should be.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WeldOptions {
    /// Positions closer than `relative_tolerance × bounding-box diagonal` are merged (the
    /// diagonal of the box around all user vertices). `0` merges only identical positions.
    /// Must be finite and `>= 0`. The default is `1e-7`.
    pub relative_tolerance: f64,
}

impl Default for WeldOptions {
    fn default() -> Self {
        Self { relative_tolerance: 1e-7 }
    }
}

/// A welded triangle mesh with a map back to the user's vertices.
///
/// Internal vertices are the welded ones; `user_to_internal[i]` is the internal vertex that stands
/// for the user's vertex `i` (in the order of the file or array the mesh came from), so results
/// can always be returned in the user's own vertex order.
#[derive(Debug, Clone, PartialEq)]
pub struct TriMesh {
    pub(crate) positions: Vec<DVec3>,
    pub(crate) triangles: Vec<[u32; 3]>,
    pub(crate) user_to_internal: Vec<u32>,
    /// Triangles whose winding [`build`] reversed to orient the surface consistently.
    pub(crate) flipped_faces: usize,
}

impl TriMesh {
    /// Builds a welded triangle mesh from polygons over the user's vertices.
    ///
    /// Each polygon lists 0-based indices into `user_positions`, in counter-clockwise order seen
    /// from outside. The mesh is built in these steps:
    /// 1. validation (see Errors);
    /// 2. welding: positions closer than `weld.relative_tolerance` × the bounding-box diagonal are
    ///    merged; the lowest user index of each group is its representative, and every user vertex
    ///    keeps an entry in [`user_to_internal`](Self::user_to_internal), also vertices that no
    ///    face uses (they map to a welded vertex that may be unreferenced);
    /// 3. triangulation of polygons with more than 3 corners (quads along their better diagonal,
    ///    convex polygons as a fan, non-convex ones by ear clipping in the plane of their Newell
    ///    normal), keeping each polygon's winding;
    /// 4. dropping triangles that are degenerate: a corner repeated after welding, or an area
    ///    below `1e-14 ×` diagonal²;
    /// 5. orientation: every shell wound consistently (across its manifold edges), each closed
    ///    shell outwards by its own signed volume, each open one keeping the winding of the
    ///    larger part of its area; a reversed triangle swaps its last two corners, and
    ///    [`flipped_faces`](Self::flipped_faces) counts them (0 for a consistent, outward input,
    ///    which is kept exactly).
    ///
    /// # Errors
    /// - [`MeshError::Empty`]: no vertices or no polygons;
    /// - [`MeshError::InvalidTolerance`]: a negative or non-finite weld tolerance;
    /// - [`MeshError::NonFinite`]: a NaN or infinite coordinate (naming the first such vertex);
    /// - [`MeshError::CoordinateTooLarge`]: a coordinate beyond [`MAX_COORDINATE`] in magnitude;
    /// - [`MeshError::TooFewVertices`]: a polygon with fewer than 3 indices;
    /// - [`MeshError::IndexOutOfRange`]: an index `>= user_positions.len()`;
    /// - [`MeshError::AllFacesDegenerate`]: no triangle with a non-zero area is left;
    /// - [`MeshError::NonOrientable`]: the surface cannot be wound consistently (a Möbius strip,
    ///   a Klein bottle).
    pub fn from_polygons(user_positions: Vec<DVec3>, polygons: &[Vec<u32>], weld: &WeldOptions) -> Result<TriMesh, MeshError> {
        let mut offsets = Vec::with_capacity(polygons.len() + 1);
        offsets.push(0);
        let mut indices = Vec::with_capacity(polygons.iter().map(Vec::len).sum());
        for poly in polygons {
            indices.extend_from_slice(poly);
            offsets.push(indices.len());
        }
        build(user_positions, &offsets, &indices, weld, None)
    }

    /// Builds a welded triangle mesh from flat arrays: `positions` (`f32` or `f64` triples) and
    /// `indices`, three 0-based vertex indices per triangle, counter-clockwise seen from outside.
    /// Welding uses [`WeldOptions::default`]; see [`from_polygons`](Self::from_polygons) for the
    /// steps.
    ///
    /// # Errors
    /// [`MeshError::IndexCountNotMultipleOf3`] if `indices.len() % 3 != 0`, and every error of
    /// [`from_polygons`](Self::from_polygons).
    pub fn from_triangles<T: Copy + Into<f64>>(positions: &[[T; 3]], indices: &[u32]) -> Result<TriMesh, MeshError> {
        if !indices.len().is_multiple_of(3) {
            return Err(MeshError::IndexCountNotMultipleOf3 { len: indices.len() });
        }
        let positions: Vec<DVec3> = positions.iter().map(|p| DVec3::new(p[0].into(), p[1].into(), p[2].into())).collect();
        let offsets: Vec<usize> = (0..=indices.len() / 3).map(|f| 3 * f).collect();
        build(positions, &offsets, indices, &WeldOptions::default(), None)
    }

    /// Edge-connected components ("shells"): two triangles are in the same shell when a chain of
    /// triangles, each sharing an edge with the next, joins them (triangles touching only at a
    /// vertex are in different shells).
    ///
    /// Returns the number of shells and, for each triangle, its shell id in `0..count`. Shells
    /// are numbered in the order of their first triangle.
    #[must_use]
    pub fn shells(&self) -> (usize, Vec<u32>) {
        let t = self.triangles.len();
        let mut parent: Vec<u32> = (0..t as u32).collect();
        fn find(parent: &mut [u32], mut x: u32) -> u32 {
            while parent[x as usize] != x {
                let up = parent[parent[x as usize] as usize];
                parent[x as usize] = up; // path halving
                x = up;
            }
            x
        }
        let edges = self.sorted_edges();
        for pair in edges.windows(2) {
            if pair[0].0 == pair[1].0 {
                let (a, b) = (find(&mut parent, pair[0].1), find(&mut parent, pair[1].1));
                if a != b {
                    // Union towards the lower triangle keeps roots deterministic.
                    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
                    parent[hi as usize] = lo;
                }
            }
        }
        let mut id = vec![u32::MAX; t];
        let mut shell_of = Vec::with_capacity(t);
        let mut count = 0u32;
        for tri in 0..t as u32 {
            let root = find(&mut parent, tri) as usize;
            if id[root] == u32::MAX {
                id[root] = count;
                count += 1;
            }
            shell_of.push(id[root]);
        }
        (count as usize, shell_of)
    }

    /// Edges used by exactly one triangle, directed as in that triangle. Empty for a closed mesh.
    #[must_use]
    pub fn boundary_edges(&self) -> Vec<[u32; 2]> {
        let edges = self.sorted_edges();
        let mut out = Vec::new();
        let mut i = 0;
        while i < edges.len() {
            let mut j = i + 1;
            while j < edges.len() && edges[j].0 == edges[i].0 {
                j += 1;
            }
            if j - i == 1 {
                let (_, tri, k) = edges[i];
                let v = self.triangles[tri as usize];
                out.push([v[k as usize], v[(k as usize + 1) % 3]]);
            }
            i = j;
        }
        out
    }

    /// Whether the surface is closed (watertight): every edge is shared by exactly two
    /// triangles.
    #[must_use]
    pub fn is_closed(&self) -> bool {
        let edges = self.sorted_edges();
        let mut i = 0;
        while i < edges.len() {
            let mut j = i + 1;
            while j < edges.len() && edges[j].0 == edges[i].0 {
                j += 1;
            }
            if j - i != 2 {
                return false;
            }
            i = j;
        }
        !self.triangles.is_empty()
    }

    /// The mesh with every position transformed by `m` (a point transform: translation applies;
    /// a projective matrix is divided through by `w`). The user vertex map is kept.
    ///
    /// If `m` mirrors (negative determinant of its linear part), the winding of every triangle
    /// is reversed, so triangles that faced outwards still do and
    /// [`signed_volume`](Self::signed_volume) keeps its sign. `m` should be finite and
    /// invertible: a singular matrix flattens the mesh (its triangles are kept, with zero area).
    #[must_use]
    pub fn transformed(&self, m: &DMat4) -> TriMesh {
        let affine = m.row(3) == DVec4::new(0.0, 0.0, 0.0, 1.0);
        let positions =
            self.positions.iter().map(|&p| if affine { m.transform_point3(p) } else { m.project_point3(p) }).collect();
        let linear = glam::DMat3::from_mat4(*m);
        let triangles = if linear.determinant() < 0.0 {
            self.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect()
        } else {
            self.triangles.clone()
        };
        TriMesh { positions, triangles, user_to_internal: self.user_to_internal.clone(), flipped_faces: self.flipped_faces }
    }

    /// Every triangle edge as (undirected key, triangle, corner where it starts), sorted by key.
    fn sorted_edges(&self) -> Vec<(u64, u32, u8)> {
        super::orient::sorted_edges(&self.triangles)
    }

    /// Internal (welded) vertex positions.
    #[must_use]
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// Triangles over internal vertices, counter-clockwise seen from outside (each closed shell
    /// outwards; an open one in the winding of the larger part of its area).
    #[must_use]
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// For each user vertex, the internal vertex that stands for it.
    #[must_use]
    pub fn user_to_internal(&self) -> &[u32] {
        &self.user_to_internal
    }

    /// Triangles whose winding was reversed when the mesh was built, to wind every shell
    /// consistently and every closed shell outwards (0 when the input already was).
    #[must_use]
    pub fn flipped_faces(&self) -> usize {
        self.flipped_faces
    }

    /// Number of vertices in the user's input.
    #[must_use]
    pub fn user_vertex_count(&self) -> usize {
        self.user_to_internal.len()
    }

    /// Axis-aligned bounds `(min, max)` of the internal vertices.
    #[must_use]
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.positions
            .iter()
            .fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
    }

    /// Length of the bounding-box diagonal.
    #[must_use]
    pub fn diagonal(&self) -> f64 {
        let (lo, hi) = self.bounds();
        (hi - lo).length()
    }

    /// The three corner positions of triangle `t`.
    #[must_use]
    pub fn triangle(&self, t: usize) -> [DVec3; 3] {
        let [a, b, c] = self.triangles[t];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    /// Area-weighted normal of triangle `t` (length = twice the area).
    #[must_use]
    pub fn triangle_cross(&self, t: usize) -> DVec3 {
        let [a, b, c] = self.triangle(t);
        (b - a).cross(c - a)
    }

    /// Total surface area.
    #[must_use]
    pub fn area(&self) -> f64 {
        (0..self.triangles.len()).map(|t| 0.5 * self.triangle_cross(t).length()).sum()
    }

    /// Signed enclosed volume by the divergence theorem: the sum of the signed volumes of the
    /// tets joining each triangle to a reference point. Exact (and independent of the point) for
    /// closed, consistently oriented meshes; for open ones an estimate whose value depends on the
    /// point, so the area-weighted centroid of the surface is used, which makes the estimate
    /// invariant under rotation and translation.
    #[must_use]
    pub fn signed_volume(&self) -> f64 {
        let (weighted, area) = (0..self.triangles.len()).fold((DVec3::ZERO, 0.0), |(c, a), t| {
            let [p, q, r] = self.triangle(t);
            let w = 0.5 * (q - p).cross(r - p).length();
            (c + w * (p + q + r) / 3.0, a + w)
        });
        let origin = if area > 0.0 { weighted / area } else { DVec3::ZERO };
        (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.triangle(t).map(|p| p - origin);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }
}

/// Area-weighted vertex normals: n_i = normalize(Σ_{t ∋ i} (p1 − p0) × (p2 − p0)), the cross
/// product being twice the triangle's area times its unit normal. Vertices no (non-degenerate)
/// triangle uses get a zero normal. Indices must be in range.
#[must_use]
pub fn area_weighted_normals(positions: &[DVec3], triangles: &[[u32; 3]]) -> Vec<DVec3> {
    let mut sum = vec![DVec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let cross = (b - a).cross(c - a);
        for &i in t {
            sum[i as usize] += cross;
        }
    }
    for n in &mut sum {
        *n = n.normalize_or_zero();
    }
    sum
}

pub(crate) fn check_finite(vertex: usize, p: DVec3) -> Result<(), MeshError> {
    if !p.is_finite() {
        return Err(MeshError::NonFinite { vertex, x: p.x, y: p.y, z: p.z, path: None, line: None });
    }
    let value = p.abs().max_element();
    if value > MAX_COORDINATE {
        return Err(MeshError::CoordinateTooLarge { vertex, value, max: MAX_COORDINATE, path: None });
    }
    Ok(())
}

/// The largest coordinate magnitude a surface mesh may have (1e30 in any unit): squared
/// lengths, areas and volumes of the mesh then stay far from `f64` overflow, so the weld
/// tolerance, the degeneracy thresholds and the mesher's measures are finite.
pub const MAX_COORDINATE: f64 = 1e30;

/// Builds a [`TriMesh`] from user positions and polygons given as `indices[offsets[f] ..
/// offsets[f + 1]]`; `path` names the file in errors. Readers validate with line numbers first
/// where they have them; this validates again for everything else.
pub(crate) fn build(
    user_positions: Vec<DVec3>,
    offsets: &[usize],
    indices: &[u32],
    weld_options: &WeldOptions,
    path: Option<&str>,
) -> Result<TriMesh, MeshError> {
    let prefix = path.map(|p| format!("{p}: ")).unwrap_or_default();
    let owned_path = || path.map(str::to_owned);
    let tolerance = weld_options.relative_tolerance;
    if !(tolerance.is_finite() && tolerance >= 0.0) {
        return Err(MeshError::InvalidTolerance { value: tolerance });
    }
    if user_positions.is_empty() {
        return Err(MeshError::Empty(format!("{prefix}there are no vertices")));
    }
    let faces = offsets.len().saturating_sub(1);
    if faces == 0 {
        return Err(MeshError::Empty(format!(
            "{prefix}there are no faces ({} vertices but nothing connects them)",
            user_positions.len()
        )));
    }
    let n = user_positions.len();
    if u32::try_from(n).is_err() {
        return Err(MeshError::Malformed {
            path: path.unwrap_or("mesh").to_owned(),
            message: format!("{n} vertices: at most {} are supported", u32::MAX),
        });
    }
    for (i, p) in user_positions.iter().enumerate() {
        check_finite(i, *p).map_err(|e| match e {
            MeshError::NonFinite { vertex, x, y, z, .. } => {
                MeshError::NonFinite { vertex, x, y, z, path: owned_path(), line: None }
            }
            MeshError::CoordinateTooLarge { vertex, value, max, .. } => {
                MeshError::CoordinateTooLarge { vertex, value, max, path: owned_path() }
            }
            other => other,
        })?;
    }
    for face in 0..faces {
        let poly = &indices[offsets[face]..offsets[face + 1]];
        if poly.len() < 3 {
            return Err(MeshError::TooFewVertices { face, count: poly.len(), path: owned_path(), line: None });
        }
        if let Some(&index) = poly.iter().find(|&&i| i as usize >= n) {
            return Err(MeshError::IndexOutOfRange {
                face,
                index: i64::from(index),
                vertex_count: n,
                path: owned_path(),
                line: None,
            });
        }
    }

    let (lo, hi) = user_positions
        .iter()
        .fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    let diagonal = (hi - lo).length();
    let welded = weld(&user_positions, tolerance * diagonal);
    drop(user_positions);
    let positions = welded.positions;
    let map = welded.map;
    let min_cross = 2.0 * DEGENERATE_AREA * diagonal * diagonal;

    let mut triangles: Vec<[u32; 3]> = Vec::with_capacity(indices.len().saturating_sub(2 * faces));
    let mut corners: Vec<u32> = Vec::new();
    let mut scratch: Vec<[u32; 3]> = Vec::new();
    for face in 0..faces {
        corners.clear();
        for &i in &indices[offsets[face]..offsets[face + 1]] {
            let v = map[i as usize];
            if corners.last() != Some(&v) {
                corners.push(v);
            }
        }
        while corners.len() > 1 && corners.first() == corners.last() {
            corners.pop();
        }
        if corners.len() < 3 {
            continue; // collapsed by welding
        }
        scratch.clear();
        triangulate(&positions, &corners, &mut scratch);
        for &[a, b, c] in &scratch {
            if a == b || b == c || c == a {
                continue;
            }
            let (pa, pb, pc) = (positions[a as usize], positions[b as usize], positions[c as usize]);
            // Written so that an unexpected NaN also counts as degenerate.
            let has_area = (pb - pa).cross(pc - pa).length() > min_cross;
            if !has_area {
                continue;
            }
            triangles.push([a, b, c]);
        }
    }
    if triangles.is_empty() {
        return Err(MeshError::AllFacesDegenerate { faces, path: owned_path() });
    }
    let orientation = orient(&positions, &triangles).map_err(|e| MeshError::NonOrientable {
        triangle: e.triangle,
        other: e.other,
        from: e.edge[0].to_array(),
        to: e.edge[1].to_array(),
        path: owned_path(),
    })?;
    for (tri, &flip) in triangles.iter_mut().zip(&orientation.reverse) {
        if flip {
            *tri = reversed(*tri);
        }
    }
    Ok(TriMesh { positions, triangles, user_to_internal: map, flipped_faces: orientation.count })
}
