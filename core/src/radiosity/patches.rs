//! Vertex patches on a scene's surfaces (design/radiosity.md §1.3): a patch per vertex with its
//! dual cell (the third of each incident triangle nearest the vertex, Aᵢ = Σ_{t∋i} A_t/3), two on
//! a two-sided surface; one BVH over every surface's triangles for the form factors' rays; and
//! longest-edge refinement of coarse surfaces to a patch size.

use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};

use glam::DVec3;

use crate::mesh::TriangleBvh;

use super::error::RadiosityError;

/// Triangles a refinement may produce at most ([`refine_to_edge_length`]).
pub const MAX_REFINED_TRIANGLES: usize = 20_000_000;

/// One surface of the scene: triangles over its own vertices, counter-clockwise about the side
/// that faces the rest of the scene (its front). A one-sided surface absorbs what reaches its
/// back; a two-sided one has patches on both sides.
#[derive(Debug, Clone, Copy)]
pub struct Surface<'a> {
    pub positions: &'a [DVec3],
    pub triangles: &'a [[u32; 3]],
    pub two_sided: bool,
}

/// One piece of a patch's dual cell: a sixth of a triangle, the corner's vertex, an edge's
/// midpoint and the centroid, and the cumulative share of the cell's area up to it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct CellPiece {
    triangle: u32,
    corners: [DVec3; 3],
    cumulative: f64,
}

/// The patches of a scene (module documentation).
#[derive(Debug, Clone)]
pub struct PatchSet {
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    areas: Vec<f64>,
    surface: Vec<u32>,
    back_side: Vec<bool>,
    /// Per surface, the index of its first front patch and of its first back patch.
    first_front: Vec<usize>,
    first_back: Vec<Option<usize>>,
    /// Per triangle of the union (the BVH's numbering): its corners' front and back patches,
    /// its unit normal and its area.
    front: Vec<[u32; 3]>,
    back: Vec<Option<[u32; 3]>>,
    face_normals: Vec<DVec3>,
    /// Per patch, its dual cell's pieces (CSR).
    cell_start: Vec<usize>,
    cells: Vec<CellPiece>,
    bvh: TriangleBvh,
    diagonal: f64,
}

impl PatchSet {
    /// The patches of `surfaces`, front patches of each surface in its vertex order, surface by
    /// surface, then the back patches of the two-sided ones in the same order. A vertex on no
    /// triangle (or only degenerate ones) is a patch of zero area that exchanges nothing.
    ///
    /// # Errors
    /// [`RadiosityError::IndexOutOfRange`], [`RadiosityError::NonFinite`], or
    /// [`RadiosityError::NoPatches`] when no triangle has area.
    pub fn new(surfaces: &[Surface]) -> Result<Self, RadiosityError> {
        for (s, surface) in surfaces.iter().enumerate() {
            check_surface(s, surface.positions, surface.triangles)?;
        }
        let mut first_front = Vec::with_capacity(surfaces.len());
        let mut n = 0;
        for surface in surfaces {
            first_front.push(n);
            n += surface.positions.len();
        }
        let mut first_back = Vec::with_capacity(surfaces.len());
        for surface in surfaces {
            first_back.push(surface.two_sided.then_some(n));
            if surface.two_sided {
                n += surface.positions.len();
            }
        }
        let mut positions = vec![DVec3::ZERO; n];
        let mut surface_of = vec![0u32; n];
        let mut back_side = vec![false; n];
        for (s, surface) in surfaces.iter().enumerate() {
            for (v, &p) in surface.positions.iter().enumerate() {
                for first in [Some(first_front[s]), first_back[s]].into_iter().flatten() {
                    positions[first + v] = p;
                    surface_of[first + v] = s as u32;
                }
                if let Some(first) = first_back[s] {
                    back_side[first + v] = true;
                }
            }
        }
        let (mut front, mut back, mut face_normals, mut corners_all) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut normals = vec![DVec3::ZERO; n];
        let mut areas = vec![0.0; n];
        let mut pieces: Vec<Vec<(u32, [DVec3; 3], f64)>> = vec![Vec::new(); n];
        for (s, surface) in surfaces.iter().enumerate() {
            for t in surface.triangles {
                let index = front.len() as u32;
                let corners = t.map(|v| surface.positions[v as usize]);
                let cross = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
                let area = 0.5 * cross.length();
                let unit = cross.normalize_or_zero();
                let f = t.map(|v| (first_front[s] + v as usize) as u32);
                let b = first_back[s].map(|first| t.map(|v| (first + v as usize) as u32));
                if area > 0.0 {
                    let centroid = (corners[0] + corners[1] + corners[2]) / 3.0;
                    for k in 0..3 {
                        let (c, next, prev) = (corners[k], corners[(k + 1) % 3], corners[(k + 2) % 3]);
                        let halves = [[c, 0.5 * (c + next), centroid], [c, centroid, 0.5 * (c + prev)]];
                        for patch in [Some(f[k]), b.map(|b| b[k])].into_iter().flatten() {
                            let p = patch as usize;
                            areas[p] += area / 3.0;
                            normals[p] += if back_side[p] { -cross } else { cross };
                            for half in halves {
                                pieces[p].push((index, half, area / 6.0));
                            }
                        }
                    }
                }
                front.push(f);
                back.push(b);
                face_normals.push(unit);
                corners_all.push(corners);
            }
        }
        if !areas.iter().any(|&a| a > 0.0) {
            return Err(RadiosityError::NoPatches);
        }
        let mut cell_start = Vec::with_capacity(n + 1);
        let mut cells = Vec::new();
        for (p, list) in pieces.into_iter().enumerate() {
            cell_start.push(cells.len());
            let mut sum = 0.0;
            for (triangle, corners, area) in list {
                sum += area / areas[p];
                cells.push(CellPiece { triangle, corners, cumulative: sum });
            }
            if let Some(last) = cells.last_mut().filter(|_| sum > 0.0) {
                last.cumulative = 1.0;
            }
        }
        cell_start.push(cells.len());
        let (lo, hi) = positions
            .iter()
            .fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        Ok(Self {
            positions,
            normals: normals.iter().map(|n| n.normalize_or_zero()).collect(),
            areas,
            surface: surface_of,
            back_side,
            first_front,
            first_back,
            front,
            back,
            face_normals,
            cell_start,
            cells,
            bvh: TriangleBvh::new(corners_all),
            diagonal: (hi - lo).length(),
        })
    }

    /// The number of patches.
    #[must_use]
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there are no patches (never: [`PatchSet::new`] refuses that).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Each patch's vertex.
    #[must_use]
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// Each patch's unit normal (area-weighted over its triangles, reversed on a back side).
    #[must_use]
    pub fn normals(&self) -> &[DVec3] {
        &self.normals
    }

    /// Each patch's area (its dual cell's).
    #[must_use]
    pub fn areas(&self) -> &[f64] {
        &self.areas
    }

    /// The surface patch `patch` lies on.
    #[must_use]
    pub fn surface_of(&self, patch: usize) -> usize {
        self.surface[patch] as usize
    }

    /// Whether patch `patch` is on the back side of a two-sided surface.
    #[must_use]
    pub fn is_back(&self, patch: usize) -> bool {
        self.back_side[patch]
    }

    /// The patch of vertex `vertex` of surface `surface` on its front, or its back (`None` for
    /// the back of a one-sided surface).
    #[must_use]
    pub fn patch_of(&self, surface: usize, vertex: usize, back: bool) -> Option<usize> {
        if back {
            self.first_back[surface].map(|first| first + vertex)
        } else {
            Some(self.first_front[surface] + vertex)
        }
    }

    /// The BVH over every surface's triangles (numbered surface by surface).
    #[must_use]
    pub fn bvh(&self) -> &TriangleBvh {
        &self.bvh
    }

    /// The diagonal of the patches' bounding box.
    #[must_use]
    pub fn diagonal(&self) -> f64 {
        self.diagonal
    }

    /// The front patches of surface `surface`, one per vertex in its order.
    pub(crate) fn front_range(&self, surface: usize) -> std::ops::Range<usize> {
        let end = self
            .first_front
            .get(surface + 1)
            .copied()
            .unwrap_or_else(|| self.first_back.iter().flatten().copied().next().unwrap_or(self.len()));
        self.first_front[surface]..end
    }

    /// Every triangle of the union (the BVH's numbering) by its corners' front patches.
    pub(crate) fn front_triangles(&self) -> &[[u32; 3]] {
        &self.front
    }

    /// The pieces of patch `patch`'s dual cell (sixths of its triangles: the vertex, an edge's
    /// midpoint and the centroid, counter-clockwise about the triangle's front normal).
    pub(crate) fn cell_pieces(&self, patch: usize) -> impl Iterator<Item = [DVec3; 3]> + '_ {
        self.cells[self.cell_start[patch]..self.cell_start[patch + 1]].iter().map(|p| p.corners)
    }

    /// The patches at triangle `triangle`'s corners on the side a ray travelling along
    /// `direction` hits, with its unit normal facing the ray; `None` when it hits the back of a
    /// one-sided surface (the light is absorbed there).
    pub(crate) fn hit_side(&self, triangle: u32, direction: DVec3) -> Option<[u32; 3]> {
        let t = triangle as usize;
        if direction.dot(self.face_normals[t]) < 0.0 {
            Some(self.front[t])
        } else {
            self.back[t]
        }
    }

    /// A point of patch `patch`'s dual cell, uniform in area for `u` uniform in [0, 1)², and the
    /// unit normal of the triangle it lies on, facing the patch's side; `None` for a patch of no
    /// area.
    pub(crate) fn sample_cell(&self, patch: usize, [u, v]: [f64; 2]) -> Option<(DVec3, DVec3)> {
        let pieces = &self.cells[self.cell_start[patch]..self.cell_start[patch + 1]];
        let at = pieces.iter().position(|p| u < p.cumulative).unwrap_or(pieces.len().checked_sub(1)?);
        let piece = pieces[at];
        let below = if at == 0 { 0.0 } else { pieces[at - 1].cumulative };
        let u = ((u - below) / (piece.cumulative - below)).clamp(0.0, 1.0);
        // Uniform on a triangle from the unit square (the square-root map).
        let su = u.sqrt();
        let [a, b, c] = piece.corners;
        let point = a * (1.0 - su) + b * (su * (1.0 - v)) + c * (su * v);
        let n = self.face_normals[piece.triangle as usize];
        Some((point, if self.back_side[patch] { -n } else { n }))
    }
}

/// Surface `surface`'s positions are finite and its triangles' indices in range.
fn check_surface(surface: usize, positions: &[DVec3], triangles: &[[u32; 3]]) -> Result<(), RadiosityError> {
    let vertices = positions.len();
    if let Some((vertex, p)) = positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
        return Err(RadiosityError::NonFinite { surface, vertex, value: p.to_array() });
    }
    match triangles
        .iter()
        .enumerate()
        .find_map(|(triangle, t)| t.iter().find(|&&i| i as usize >= vertices).map(|&i| (triangle, i)))
    {
        Some((triangle, index)) => Err(RadiosityError::IndexOutOfRange { surface, triangle, index, vertices }),
        None => Ok(()),
    }
}

/// The surface `positions`/`triangles` with its edges bisected, longest first, until none is
/// longer than `max_edge`: the input's vertices keep their indices and come first, each new
/// vertex is an edge's midpoint, orientation and non-manifold edges are kept. Splitting the
/// globally longest edge splits the longest edge of every triangle on it (longest-edge
/// bisection, conforming), so no triangle gets worse than the input's by more than halving.
///
/// # Errors
/// [`RadiosityError::InvalidPatchSize`] unless `max_edge` is finite and > 0;
/// [`RadiosityError::TooFine`] when the surface would need more than
/// [`MAX_REFINED_TRIANGLES`]; the index and finiteness errors of [`PatchSet::new`].
pub fn refine_to_edge_length(
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    max_edge: f64,
) -> Result<(Vec<DVec3>, Vec<[u32; 3]>), RadiosityError> {
    if !(max_edge.is_finite() && max_edge > 0.0) {
        return Err(RadiosityError::InvalidPatchSize(max_edge));
    }
    check_surface(0, positions, triangles)?;
    // Each split halves an edge; a triangle of area A needs about A/(√3/4 · h²) pieces.
    let estimate: f64 = triangles
        .iter()
        .map(|t| {
            let c = t.map(|v| positions[v as usize]);
            let area = 0.5 * (c[1] - c[0]).cross(c[2] - c[0]).length();
            let longest = (0..3).map(|k| c[k].distance(c[(k + 1) % 3])).fold(0.0, f64::max);
            (4.0 * area / (3f64.sqrt() * max_edge * max_edge)).max(longest / max_edge) + 1.0
        })
        .sum();
    if estimate > MAX_REFINED_TRIANGLES as f64 {
        return Err(RadiosityError::TooFine { estimated: estimate as usize, limit: MAX_REFINED_TRIANGLES });
    }
    let mut positions = positions.to_vec();
    let mut triangles = triangles.to_vec();
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    let mut edges: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for (t, tri) in triangles.iter().enumerate() {
        for k in 0..3 {
            edges.entry(key(tri[k], tri[(k + 1) % 3])).or_default().push(t as u32);
        }
    }
    let length = |positions: &[DVec3], (a, b): (u32, u32)| positions[a as usize].distance(positions[b as usize]);
    let mut heap: BinaryHeap<Longest> =
        edges.keys().map(|&e| Longest(length(&positions, e), e)).filter(|l| l.0 > max_edge).collect();
    while let Some(Longest(_, edge)) = heap.pop() {
        let Some(on) = edges.remove(&edge) else { continue };
        let (a, b) = edge;
        let m = positions.len() as u32;
        positions.push(0.5 * (positions[a as usize] + positions[b as usize]));
        let mut fresh = vec![key(a, m), key(m, b)];
        for t in on {
            let tri = triangles[t as usize];
            // The edge as it runs in this triangle's orientation, x → y, and the third corner.
            let k = (0..3).find(|&k| key(tri[k], tri[(k + 1) % 3]) == edge).expect("the triangle has the edge");
            let (x, y, c) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            let new = triangles.len() as u32;
            let mut first = tri;
            first[(k + 1) % 3] = m;
            triangles[t as usize] = first;
            let mut second = tri;
            second[k] = m;
            triangles.push(second);
            edges.entry(key(x, m)).or_default().push(t);
            edges.entry(key(m, y)).or_default().push(new);
            edges.entry(key(m, c)).or_default().extend([t, new]);
            if let Some(list) = edges.get_mut(&key(y, c)) {
                for id in list.iter_mut().filter(|id| **id == t) {
                    *id = new;
                }
            }
            fresh.push(key(m, c));
        }
        for e in fresh {
            let l = length(&positions, e);
            if l > max_edge {
                heap.push(Longest(l, e));
            }
        }
    }
    Ok((positions, triangles))
}

/// An edge by its length, ordered longest first (lengths are finite).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Longest(f64, (u32, u32));

impl Eq for Longest {}

impl PartialOrd for Longest {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Longest {
    fn cmp(&self, other: &Self) -> Ordering {
        self.0.total_cmp(&other.0).then(self.1.cmp(&other.1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let p = vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        (p, vec![[0, 1, 2], [0, 2, 3]])
    }

    #[test]
    fn dual_cells_partition_the_area_and_sides_are_apart() {
        let (p, t) = square();
        let patches = PatchSet::new(&[Surface { positions: &p, triangles: &t, two_sided: true }]).unwrap();
        assert_eq!(patches.len(), 8);
        let front: f64 = patches.areas()[..4].iter().sum();
        let back: f64 = patches.areas()[4..].iter().sum();
        assert!((front - 1.0).abs() < 1e-15 && (back - 1.0).abs() < 1e-15, "{front} {back}");
        // Vertex 0 and 2 are on both triangles: 1/3 of the square; 1 and 3 on one: 1/6.
        assert!((patches.areas()[0] - 1.0 / 3.0).abs() < 1e-15 && (patches.areas()[1] - 1.0 / 6.0).abs() < 1e-15);
        assert_eq!(patches.normals()[0], DVec3::Z);
        assert_eq!(patches.normals()[4], -DVec3::Z);
        assert_eq!(patches.hit_side(0, -DVec3::Z), Some([0, 1, 2]));
        assert_eq!(patches.hit_side(0, DVec3::Z), Some([4, 5, 6]));
        assert_eq!(patches.patch_of(0, 3, true), Some(7));
    }

    /// Samples of a dual cell lie in it: nearer their vertex (in barycentric terms) than any
    /// other corner, and spread over its area (their mean is the cell's centroid).
    #[test]
    fn cell_samples_cover_the_cell_uniformly() {
        let (p, t) = square();
        let patches = PatchSet::new(&[Surface { positions: &p, triangles: &t, two_sided: false }]).unwrap();
        let n = 4096;
        let mut mean = DVec3::ZERO;
        for i in 0..n {
            let u = [(i as f64 + 0.5) / n as f64, ((i * 2_654_435_761usize) % n) as f64 / n as f64];
            let (x, normal) = patches.sample_cell(1, u).unwrap();
            assert_eq!(normal, DVec3::Z);
            // Vertex 1 = (1, 0) lies on triangle 0 only: its cell is where x − y ≥ max(1 − x, y)…
            assert!(x.x >= 0.5 - 1e-12 && x.y <= 0.5 + 1e-12 && x.x >= x.y - 1e-12, "{x}");
            mean += x / n as f64;
        }
        // The cell: the quadrilateral (1,0), (1,½), (⅔,⅓), (½,0), centroid (29/36, 7/36).
        assert!((mean - DVec3::new(29.0 / 36.0, 7.0 / 36.0, 0.0)).length() < 2e-3, "{mean}");
    }

    #[test]
    fn refinement_keeps_the_vertices_the_area_and_the_orientation() {
        let (p, t) = square();
        let (q, u) = refine_to_edge_length(&p, &t, 0.1).unwrap();
        assert_eq!(&q[..4], &p[..]);
        let mut area = 0.0;
        let mut edges: HashMap<(u32, u32), usize> = HashMap::new();
        for tri in &u {
            let c = tri.map(|v| q[v as usize]);
            let cross = (c[1] - c[0]).cross(c[2] - c[0]);
            assert!(cross.z > 0.0, "a triangle turned over");
            area += 0.5 * cross.z;
            for k in 0..3 {
                assert!(c[k].distance(c[(k + 1) % 3]) <= 0.1 + 1e-12);
                *edges.entry((tri[k].min(tri[(k + 1) % 3]), tri[k].max(tri[(k + 1) % 3]))).or_default() += 1;
            }
        }
        assert!((area - 1.0).abs() < 1e-12, "{area}");
        // Conforming: every edge is shared by two triangles or lies on the square's boundary.
        for (&(a, b), &count) in &edges {
            let (x, y) = (q[a as usize], q[b as usize]);
            let boundary = [x.x, y.x].iter().all(|&c| c == 0.0 || c == 1.0) && x.x == y.x
                || [x.y, y.y].iter().all(|&c| c == 0.0 || c == 1.0) && x.y == y.y;
            assert_eq!(count, if boundary { 1 } else { 2 }, "edge {x} {y}");
        }
        assert!(matches!(refine_to_edge_length(&p, &t, 0.0), Err(RadiosityError::InvalidPatchSize(_))));
        assert!(matches!(refine_to_edge_length(&p, &t, 1e-6), Err(RadiosityError::TooFine { .. })));
        assert!(matches!(refine_to_edge_length(&p, &[[0, 1, 9]], 0.5), Err(RadiosityError::IndexOutOfRange { index: 9, .. })));
    }

    #[test]
    fn bad_input_is_named() {
        let p = [DVec3::ZERO, DVec3::X, DVec3::new(f64::NAN, 0.0, 0.0)];
        let e = PatchSet::new(&[Surface { positions: &p, triangles: &[[0, 1, 2]], two_sided: false }]).unwrap_err();
        assert!(matches!(e, RadiosityError::NonFinite { surface: 0, vertex: 2, .. }), "{e}");
        let p = [DVec3::ZERO, DVec3::X, DVec3::new(2.0, 0.0, 0.0)];
        let e = PatchSet::new(&[Surface { positions: &p, triangles: &[[0, 1, 2]], two_sided: false }]).unwrap_err();
        assert_eq!(e, RadiosityError::NoPatches);
    }
}
