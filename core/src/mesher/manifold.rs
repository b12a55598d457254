//! Making the boundary a 2-manifold where isosurface stuffing leaves two lobes of the solid
//! touching along an edge or at a vertex (a pinch: a short lattice edge with both ends warped
//! onto the surface and the lattice vertices around it alternating in, out, out, in, out, out).
//!
//! Such a vertex's star — the tets around it — falls into several groups connected through faces
//! that contain the vertex. Each group beyond the first gets its own copy of the vertex (same
//! position), which separates the lobes: the geometry is unchanged, the boundary becomes
//! manifold, and no tet changes shape.

use glam::DVec3;

use crate::mesh::{boundary_faces_among, irregular_edges, orient_tets, BoundaryFace, Incidence, TetMesh, TetMeshError};

/// What the manifold repair ([`repaired`]) changed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Repair {
    /// Vertex copies added by splitting pinched vertices.
    pub split_vertices: usize,
    /// Tets added to close the gap between two lobes meeting along an edge.
    pub filled_tets: usize,
    /// Tets removed where neither splitting nor filling applied.
    pub removed_tets: usize,
    /// Vertices exposed by a removal and moved onto the input surface (where every tet around
    /// them stays within the dihedral bounds).
    pub projected_vertices: usize,
    /// Exposed boundary vertices left off the input surface, because moving them onto it would
    /// have broken the bounds.
    pub off_surface_vertices: usize,
}

/// Moves boundary vertices among `touched` that a removal exposed (off the input surface) onto
/// it, one at a time: to the first of [`surface_candidates`] at which every tet around the
/// vertex (as `tets` stores it) stays positively oriented and within the dihedral bounds.
/// `on_boundary` flags the boundary vertices of `tets`. Adds how many moved to `repair`, sets
/// how many stayed off the surface, and returns the tets that blocked those at their closest
/// point (sorted).
fn project_exposed(
    positions: &mut [DVec3],
    tets: &[[u32; 4]],
    on_boundary: &[bool],
    touched: &[u32],
    surface: &crate::mesh::TriangleBvh,
    repair: &mut Repair,
) -> Vec<u32> {
    let scale = positions.iter().fold(0.0f64, |m, p| m.max(p.abs().max_element()));
    let star = Incidence::new(tets, positions.len());
    let (mut moved, mut stayed) = (0, 0);
    let mut failing = Vec::new();
    for &v in touched {
        if !on_boundary[v as usize] {
            continue;
        }
        let Some(target) = surface.closest_point(positions[v as usize]) else {
            continue;
        };
        if target.distance <= 1e-9 * scale {
            continue;
        }
        let old = positions[v as usize];
        let within_bounds = |positions: &[DVec3]| {
            star.around(v as usize).iter().all(|&(t, _)| tet_within_bounds(tets[t as usize].map(|w| positions[w as usize])))
        };
        let mut placed = false;
        for candidate in surface_candidates(surface, old, target.point, target.distance) {
            positions[v as usize] = candidate;
            if within_bounds(positions) {
                placed = true;
                break;
            }
        }
        if placed {
            moved += 1;
        } else {
            positions[v as usize] = target.point;
            failing.extend(
                star.around(v as usize)
                    .iter()
                    .map(|&(t, _)| t)
                    .filter(|&t| !tet_within_bounds(tets[t as usize].map(|w| positions[w as usize]))),
            );
            positions[v as usize] = old;
            stayed += 1;
        }
    }
    failing.sort_unstable();
    failing.dedup();
    repair.projected_vertices += moved;
    repair.off_surface_vertices = stayed;
    failing
}

/// Whether a tet is positively oriented with every dihedral angle within the mesher's bounds.
fn tet_within_bounds(p: [DVec3; 4]) -> bool {
    crate::mesh::tet_volume(p) > 0.0
        && crate::mesh::dihedral_angles(p).iter().all(|a| (MIN_DIHEDRAL_DEG..=MAX_DIHEDRAL_DEG).contains(&a.to_degrees()))
}

/// Points of the input surface an exposed vertex at `p` may move to, nearest first: its closest
/// point (at `distance`), then the closest points of the 26 points at `distance` and
/// `2 distance` from `p` along the lattice's axis, face and body diagonals. A vertex whose
/// closest point would break the quality bounds often has a nearby surface point that does not.
fn surface_candidates(surface: &crate::mesh::TriangleBvh, p: DVec3, closest: DVec3, distance: f64) -> Vec<DVec3> {
    let mut candidates = vec![closest];
    for (x, y, z) in (-1..=1).flat_map(|x| (-1..=1).flat_map(move |y| (-1..=1).map(move |z| (x, y, z)))) {
        let direction = DVec3::new(f64::from(x), f64::from(y), f64::from(z)).normalize_or_zero();
        if direction == DVec3::ZERO {
            continue;
        }
        for reach in [1.0, 2.0] {
            if let Some(c) = surface.closest_point(p + reach * distance * direction) {
                candidates.push(c.point);
            }
        }
    }
    let first = candidates[0];
    candidates[1..].sort_by(|a, b| (*a - p).length_squared().total_cmp(&(*b - p).length_squared()));
    candidates.dedup();
    candidates.retain(|c| *c == first || (*c - p).length() <= 3.0 * distance);
    candidates
}

/// What a repair round reads of the topology of its tets: the boundary faces (those
/// [`TetMesh::new`] would give, in the same order) and the boundary edges not in exactly two of
/// them. A round finds them among the faces of surface vertices only (every boundary vertex of a
/// stuffing is one, and the repair keeps it so), at the cost of those faces and not of all 4T;
/// the mesh, with its whole topology found afresh, is built once from the last round's tets.
struct Boundary<'a> {
    positions: &'a [DVec3],
    /// The tets, positively oriented.
    tets: &'a [[u32; 4]],
    faces: Vec<BoundaryFace>,
    irregular: Vec<([u32; 2], Vec<u32>)>,
}

impl<'a> Boundary<'a> {
    /// The boundary of the oriented `tets` over `positions`, whose vertices off the surface are
    /// flagged false in `on_surface`.
    ///
    /// # Errors
    /// [`TetMeshError::NonManifoldFace`] for a face shared by more than two tets.
    fn new(positions: &'a [DVec3], tets: &'a [[u32; 4]], on_surface: &[bool]) -> Result<Self, TetMeshError> {
        let faces = boundary_faces_among(tets, on_surface)?;
        let irregular = irregular_edges(&faces);
        Ok(Self { positions, tets, faces, irregular })
    }

    /// The boundary faces.
    fn faces(&self) -> &[BoundaryFace] {
        &self.faces
    }

    /// Whether each vertex is on a boundary face.
    fn on_boundary(&self) -> Vec<bool> {
        let mut flags = vec![false; self.positions.len()];
        for f in self.faces() {
            for v in f.vertices {
                flags[v as usize] = true;
            }
        }
        flags
    }
}

/// Builds the tet mesh with a closed 2-manifold boundary from a stuffing.
///
/// First every pinched vertex is split (no geometric change). Where the boundary is still not
/// manifold — two lobes meeting along an edge — a tet that closes the gap is added where it can
/// be. What is left needs tets removed: the tets of the smaller side (the smaller wedge around
/// the edge, the smaller fans at a vertex), and the split repeated. That happens at a handful of
/// places on features thinner than the lattice and removes a few tets, whose exposed vertices
/// are then moved onto the surface where the quality bounds allow. For a closed input
/// (`closed`), the tets that keep an exposed vertex off the surface (flattened or turned over at
/// its closest point, across a feature thinner than the lattice) are removed in turn, for up to
/// [`BLOCKING_ROUNDS`] rounds: before, the mesher stuffed again at up to three other lattice
/// offsets, which made such inputs two to three times slower per tet. An open input's boundary
/// is off the input wherever the solid closes a hole, so there nothing more is removed.
/// [`Repair`] reports what was changed.
pub(crate) fn repaired(
    mut positions: Vec<DVec3>,
    mut tets: Vec<[u32; 4]>,
    mut on_surface: Vec<bool>,
    surface: &crate::mesh::TriangleBvh,
    closed: bool,
) -> Result<(TetMesh, Repair), TetMeshError> {
    let mut repair = Repair::default();
    // Gap tets are added positively oriented; splits and removals keep the orientation.
    orient_tets(&positions, &mut tets)?;
    // Vertices of removed tets (current numbering): candidates for projection at the end.
    let mut touched: Vec<u32> = Vec::new();
    let mut blocking_rounds = 0;
    for _ in 0..REPAIR_ROUNDS {
        let before = positions.len() as u32;
        repair.split_vertices += split_pinched_vertices(&mut positions, &mut tets, &mut on_surface);
        // A copy may be of an exposed vertex (copies of vertices on the surface stay put).
        touched.extend(before..positions.len() as u32);
        let boundary = Boundary::new(&positions, &tets, &on_surface)?;
        let fill = gap_tets(&boundary);
        if !fill.is_empty() {
            repair.filled_tets += fill.len();
            tets.extend(fill);
            continue;
        }
        let mut remove = tets_to_remove(&boundary);
        if remove.is_empty() {
            let faces = boundary.faces.len();
            if !touched.is_empty() {
                let on_boundary = boundary.on_boundary();
                let blocking = project_exposed(&mut positions, &tets, &on_boundary, &touched, surface, &mut repair);
                if closed && repair.off_surface_vertices > 0 && blocking_rounds < BLOCKING_ROUNDS {
                    blocking_rounds += 1;
                    remove = blocking;
                }
            }
            if remove.is_empty() {
                let mesh = TetMesh::new(positions, tets, Vec::new())?;
                debug_assert_eq!(mesh.boundary_faces().len(), faces, "a boundary face has a vertex off the surface");
                return Ok((mesh, repair));
            }
        }
        repair.removed_tets += remove.len();
        touched.extend(remove.iter().flat_map(|&t| tets[t as usize]));
        // A removal exposes the vertices of the removed tets: they join the surface (where a
        // pinch can be), the others keep what they were.
        for &t in &remove {
            for v in tets[t as usize] {
                on_surface[v as usize] = true;
            }
        }
        let mut keep = vec![true; tets.len()];
        for t in remove {
            keep[t as usize] = false;
        }
        let mut k = 0;
        tets.retain(|_| {
            k += 1;
            keep[k - 1]
        });
        if tets.is_empty() {
            return Err(TetMeshError::Empty { vertices: positions.len(), tets: 0 });
        }
        // Vertices left without tets are dropped by renumbering.
        let mut id = vec![u32::MAX; positions.len()];
        let mut kept = Vec::new();
        let mut kept_surface = Vec::new();
        for t in tets.iter_mut() {
            for v in t.iter_mut() {
                if id[*v as usize] == u32::MAX {
                    id[*v as usize] = kept.len() as u32;
                    kept.push(positions[*v as usize]);
                    kept_surface.push(on_surface[*v as usize]);
                }
                *v = id[*v as usize];
            }
        }
        positions = kept;
        on_surface = kept_surface;
        touched.retain_mut(|v| {
            *v = id[*v as usize];
            *v != u32::MAX
        });
        touched.sort_unstable();
        touched.dedup();
    }
    // Out of rounds: the last removal's exposed vertices still go onto the surface where they
    // can, and those that cannot are counted.
    let on_boundary = Boundary::new(&positions, &tets, &on_surface)?.on_boundary();
    project_exposed(&mut positions, &tets, &on_boundary, &touched, surface, &mut repair);
    let mesh = TetMesh::new(positions, tets, Vec::new())?;
    Ok((mesh, repair))
}

/// Tets that close the gap between two wedges meeting along a non-manifold boundary edge
/// `(u, v)`: around the edge the boundary faces `(u, v, x)` alternate between the wedges; a tet
/// `(u, v, x, y)` of two neighbouring faces from different wedges fills the empty sector between
/// them. All its vertices are already on the surface, so fidelity is kept; it is only used when
/// its dihedral angles stay within the mesher's bounds and it overlaps no tet (its sector is
/// empty: no other face of the edge lies inside it).
fn gap_tets(boundary: &Boundary<'_>) -> Vec<[u32; 4]> {
    let mut out: Vec<[u32; 4]> = boundary
        .irregular
        .iter()
        .filter(|(_, faces)| faces.len() > 2)
        .filter_map(|&([u, v], ref faces)| best_gap_tet(boundary, u, v, faces))
        .collect();
    out.sort_unstable();
    out.dedup();
    // The same tet can close the gaps of two edges (listed from each with its vertices in
    // another order); adding it twice would make its faces shared by three tets.
    let mut seen = std::collections::HashSet::new();
    out.retain(|t| {
        let mut key = *t;
        key.sort_unstable();
        seen.insert(key)
    });
    out
}

/// The best-shaped gap tet at edge `(u, v)` whose boundary faces are `edge_faces`.
fn best_gap_tet(boundary: &Boundary<'_>, u: u32, v: u32, edge_faces: &[u32]) -> Option<[u32; 4]> {
    let p = boundary.positions;
    let (pu, pv) = (p[u as usize], p[v as usize]);
    let axis = (pv - pu).normalize_or_zero();
    let frame_x = axis.any_orthonormal_vector();
    let frame_y = axis.cross(frame_x);
    // Third vertex of each face, its angle around the edge, and whether the owning tet lies on
    // the counter-clockwise side of the face (the face's solid side).
    let mut around: Vec<(f64, u32, bool)> = edge_faces
        .iter()
        .map(|&f| {
            let face = boundary.faces()[f as usize];
            let x = face.vertices.into_iter().find(|&w| w != u && w != v).unwrap_or(u);
            let d = p[x as usize] - pu;
            let angle = d.dot(frame_y).atan2(d.dot(frame_x));
            let tet = boundary.tets[face.tet as usize];
            let inner = tet.into_iter().find(|w| !face.vertices.contains(w)).unwrap_or(u);
            let di = p[inner as usize] - pu;
            let inner_angle = di.dot(frame_y).atan2(di.dot(frame_x));
            let ccw = (inner_angle - angle).rem_euclid(std::f64::consts::TAU) < std::f64::consts::PI;
            (angle, x, ccw)
        })
        .collect();
    around.sort_by(|a, b| a.0.total_cmp(&b.0));
    let n = around.len();
    let mut best: Option<(f64, [u32; 4])> = None;
    for k in 0..n {
        let (a0, x, side_x) = around[k];
        let (a1, y, side_y) = around[(k + 1) % n];
        // An empty sector runs from a face whose solid lies clockwise to the next face whose
        // solid lies counter-clockwise.
        if side_x || !side_y {
            continue;
        }
        let sweep = (a1 - a0).rem_euclid(std::f64::consts::TAU);
        if sweep >= std::f64::consts::PI {
            continue;
        }
        let mut t = [u, v, x, y];
        let pos = t.map(|w| p[w as usize]);
        let vol = crate::mesh::tet_volume(pos);
        if vol < 0.0 {
            t.swap(2, 3);
        }
        let angles = crate::mesh::dihedral_angles(t.map(|w| p[w as usize]));
        let lo = angles.iter().copied().fold(f64::INFINITY, f64::min).to_degrees();
        let hi = angles.iter().copied().fold(0.0, f64::max).to_degrees();
        if vol.abs() > 0.0 && lo >= MIN_DIHEDRAL_DEG && hi <= MAX_DIHEDRAL_DEG && best.is_none_or(|(q, _)| lo > q) {
            best = Some((lo, t));
        }
    }
    best.map(|b| b.1)
}

/// Quality bounds a repair tet must meet: those the stuffing guarantees.
const MIN_DIHEDRAL_DEG: f64 = 10.0;
/// Rounds of [`repaired`] (splits, gap tets, removals), at most.
const REPAIR_ROUNDS: usize = 24;
/// Rounds in which [`repaired`] removes the tets that keep an exposed vertex off the surface.
const BLOCKING_ROUNDS: usize = 8;
const MAX_DIHEDRAL_DEG: f64 = 165.0;

/// Tets to remove so that non-manifold boundary edges and vertices go away: around each edge in
/// more than two boundary faces, the smaller face-connected group of the tets sharing the edge;
/// at each vertex whose boundary faces form several fans, the owners of all but the largest fan.
fn tets_to_remove(boundary: &Boundary<'_>) -> Vec<u32> {
    let faces = boundary.faces();
    let tets = boundary.tets;
    let mut remove = Vec::new();
    let mut star: Option<Incidence> = None;
    for &([u, v], ref edge_faces) in &boundary.irregular {
        if edge_faces.len() > 2 {
            let star = star.get_or_insert_with(|| Incidence::new(tets, boundary.positions.len()));
            let around: Vec<u32> =
                star.around(u as usize).iter().map(|&(t, _)| t).filter(|&t| tets[t as usize].contains(&v)).collect();
            let groups = groups_by_shared_face(tets, &around);
            if let Some(smallest) = groups.iter().min_by_key(|g| g.len()) {
                remove.extend(smallest);
            }
        }
    }
    // Fans at each vertex: the faces around each vertex in compressed rows, ascending.
    let n = boundary.positions.len();
    let mut offsets = vec![0u32; n + 1];
    for face in faces {
        for &v in &face.vertices {
            offsets[v as usize + 1] += 1;
        }
    }
    for v in 0..n {
        offsets[v + 1] += offsets[v];
    }
    let mut fill = offsets[..n].to_vec();
    let mut faces_at = vec![0u32; offsets[n] as usize];
    for (f, face) in faces.iter().enumerate() {
        for &v in &face.vertices {
            faces_at[fill[v as usize] as usize] = f as u32;
            fill[v as usize] += 1;
        }
    }
    for v in 0..n {
        let around = &faces_at[offsets[v] as usize..offsets[v + 1] as usize];
        let fans = fans(faces, v as u32, around);
        if fans.len() > 1 {
            let largest = fans.iter().enumerate().max_by_key(|(_, f)| f.len()).map_or(0, |(i, _)| i);
            for (k, fan) in fans.iter().enumerate() {
                if k != largest {
                    remove.extend(fan.iter().map(|&f| faces[f as usize].tet));
                }
            }
        }
    }
    remove.sort_unstable();
    remove.dedup();
    remove
}

/// Groups of `around` (indices into `tets`) connected through shared faces (three shared
/// vertices).
fn groups_by_shared_face(tets: &[[u32; 4]], around: &[u32]) -> Vec<Vec<u32>> {
    let mut group: Vec<usize> = (0..around.len()).collect();
    for a in 0..around.len() {
        for b in a + 1..around.len() {
            let (ta, tb) = (tets[around[a] as usize], tets[around[b] as usize]);
            if ta.iter().filter(|x| tb.contains(x)).count() == 3 {
                let (ra, rb) = (root(&mut group, a), root(&mut group, b));
                group[ra] = rb;
            }
        }
    }
    collect_groups(&mut group, around)
}

/// The fans of boundary faces around vertex `v`: groups joined through edges at `v`.
fn fans(faces: &[BoundaryFace], v: u32, around: &[u32]) -> Vec<Vec<u32>> {
    let mut group: Vec<usize> = (0..around.len()).collect();
    for a in 0..around.len() {
        for b in a + 1..around.len() {
            let (fa, fb) = (faces[around[a] as usize].vertices, faces[around[b] as usize].vertices);
            if fa.iter().any(|&w| w != v && fb.contains(&w)) {
                let (ra, rb) = (root(&mut group, a), root(&mut group, b));
                group[ra] = rb;
            }
        }
    }
    collect_groups(&mut group, around)
}

fn root(group: &mut [usize], mut x: usize) -> usize {
    while group[x] != x {
        group[x] = group[group[x]];
        x = group[x];
    }
    x
}

fn collect_groups(group: &mut [usize], items: &[u32]) -> Vec<Vec<u32>> {
    let mut out: Vec<(usize, Vec<u32>)> = Vec::new();
    for (i, &item) in items.iter().enumerate() {
        let r = root(group, i);
        match out.iter_mut().find(|g| g.0 == r) {
            Some(g) => g.1.push(item),
            None => out.push((r, vec![item])),
        }
    }
    out.into_iter().map(|g| g.1).collect()
}

/// Splits every vertex whose star has several face-connected groups; returns how many copies
/// were added.
///
/// Only vertices flagged in `on_surface` are examined (an interior vertex's star is a ball);
/// copies inherit the flag.
pub(crate) fn split_pinched_vertices(positions: &mut Vec<DVec3>, tets: &mut [[u32; 4]], on_surface: &mut Vec<bool>) -> usize {
    let n = positions.len();
    let star = Incidence::new(tets, n);
    let mut added = 0;
    let mut group = Vec::new();
    for v in 0..n {
        let around = star.around(v);
        if around.len() < 2 || !on_surface[v] {
            continue;
        }
        // Union-find over the star: two tets are joined when they share a face through v, i.e.
        // three vertices (v and two others).
        group.clear();
        group.extend(0..around.len() as u32);
        fn find(g: &mut [u32], mut x: u32) -> u32 {
            while g[x as usize] != x {
                g[x as usize] = g[g[x as usize] as usize];
                x = g[x as usize];
            }
            x
        }
        for a in 0..around.len() {
            for b in a + 1..around.len() {
                let (ta, tb) = (tets[around[a].0 as usize], tets[around[b].0 as usize]);
                let shared = ta.iter().filter(|x| tb.contains(x)).count();
                if shared == 3 {
                    let (ra, rb) = (find(&mut group, a as u32), find(&mut group, b as u32));
                    group[ra as usize] = rb;
                }
            }
        }
        let first_root = find(&mut group, 0);
        let mut copies: Vec<(u32, u32)> = Vec::new();
        for a in 0..around.len() {
            let root = find(&mut group, a as u32);
            if root == first_root {
                continue;
            }
            let copy = match copies.iter().find(|c| c.0 == root) {
                Some(c) => c.1,
                None => {
                    positions.push(positions[v]);
                    on_surface.push(true);
                    added += 1;
                    let id = (positions.len() - 1) as u32;
                    copies.push((root, id));
                    id
                }
            };
            for x in tets[around[a].0 as usize].iter_mut() {
                if *x as usize == v {
                    *x = copy;
                }
            }
        }
    }
    added
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_tets_touching_at_a_vertex_are_separated() {
        let mut surface = vec![true; 7];
        let mut p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, -DVec3::X, -DVec3::Y, -DVec3::Z];
        let mut tets = vec![[0, 1, 2, 3], [0, 4, 5, 6]];
        assert_eq!(split_pinched_vertices(&mut p, &mut tets, &mut surface), 1);
        assert_eq!(p.len(), 8);
        assert_eq!(tets[1][0], 7);
        assert_eq!(p[7], DVec3::ZERO);
        // Face-connected tets are left alone.
        let mut p2 = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, DVec3::splat(1.0)];
        let mut t2 = vec![[0, 1, 2, 3], [1, 2, 3, 4]];
        assert_eq!(split_pinched_vertices(&mut p2, &mut t2, &mut vec![true; 5]), 0);
    }
}
