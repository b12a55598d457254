//! Cutting a tetrahedral mesh (TransCut §5.1): [`cut`] removes the cutter's positive side
//! ([`super::cutter::Cutter`]) and moves the kept vertices near the cut onto the cut surface
//! without letting any tet fall below a quality bound.
//!
//! # The cut, step by step
//!
//! With `d(x)` the cutter's signed distance ([`Cutter::signed_distance`], `> 0` on the removed
//! side) and `h_v` the mean length of the edges at vertex `v`:
//!
//! 1. **Classify.** A vertex is a *cut vertex* when `d_v ≥ −β h_v` ([`SNAP_BAND`] `β = 0.25`):
//!    on the removed side, or on the kept side but so close to the cut surface that a tet
//!    between it and the surface would be a sliver. Every other vertex is *firm*.
//!    A vertex is also a cut vertex when one of its edges passes through the removed side
//!    between two vertices that are not on it (`bridging_vertices`): a cutter thinner than the
//!    tets, such as a slab through a graded mesh's coarse interior, would otherwise leave tets
//!    with four firm vertices reaching across it and joining its two sides.
//!    Far from a solid cutter (two of the vertex's longest edges outside the cutter's box) a
//!    bound stands in for `d_v`: the distance to the box, with the sign every point there has
//!    (`Prepared::classifying_distance`). It decides both rules as the exact value would, and
//!    saves a closest-point and winding-number query per vertex away from a local cut.
//! 2. **Delete.** A tet is kept when at least one of its vertices is firm; tets whose four vertices
//!    are all cut vertices (entirely on the removed side, or in the thin band that will collapse
//!    onto the cut surface) are deleted. Vertices no kept tet uses are removed. Kept tets keep
//!    their id in the ORIGINAL mesh (`original_tet`), vertices are compacted in increasing old id.
//! 3. **Separate.** A kept vertex inside a removed part thinner than its tets can still be used
//!    by kept tets on both sides of it; it gets one copy per side (`separate_sides`), and a
//!    vertex (or copy) whose closest point lies on the far side of the removed part aims at the
//!    point where the segment from its side's firm vertex enters the removed part instead.
//! 4. **Snap.** Every kept cut vertex is moved onto the cut surface, to
//!    [`Cutter::closest_point`], in up to `relax_iterations` Gauss–Seidel sweeps in increasing
//!    vertex order (deterministic). A move is accepted only if every kept tet of the vertex's one
//!    ring stays positively oriented (volume above `1e-12 ×` the bounding-box diagonal³) and keeps
//!    its minimum dihedral angle at or above the bound; otherwise the largest accepted fraction of
//!    the step is found by bisection ([`BISECTIONS`] halvings) and the vertex tries again in the
//!    next sweep. Sweeps stop early when a sweep moves nothing.
//! 5. **Unblock.** A cut vertex inside the object can stay held back where its closest point
//!    would leave a sliver triangle on the cut surface (where tet sizes change, as on graded
//!    meshes). The cut surface only needs the vertex on the cutter, not at its closest point: for
//!    up to [`UNBLOCK_ROUNDS`] rounds, each such vertex tries the cutter's points nearest the
//!    centroid of its snapped neighbours and half way to it (within one mean edge of its closest
//!    point, so it cannot jump to another sheet of the cutter), under the same guard, and then
//!    its closest point again, whole or in part.
//! 6. **Rim.** Snapping a vertex of the object's surface along the cutter normal pulls the rim
//!    of the cross-section inside the object (a sphere cut this way lost 2.4% of its
//!    cross-section area). In one more pass, each such vertex that reached the cutter moves,
//!    along the cutter, to where the cutter meets the surface's tangent plane at the vertex's
//!    input position (`snap_target`, then projected onto the cutter), a full move under the same
//!    guard or none, so the cut surface stays on the cutter.
//!
//! The order (classify, delete, then snap on the kept mesh only) is what makes the result valid:
//! every kept tet has a firm vertex, which never moves and lies at least `β h_v` inside, so no
//! kept tet can be flattened onto the cut surface; the guard is evaluated on kept tets only, so
//! deleted tets never block a move; and since the guard holds after every single move, the output
//! has positive volumes and no dihedral angle below the bound by induction. Compared with
//! TransCut's relaxation (`x ← x + 0.1 (x̄ − x)` towards the one-ring average, with a fixed 0.5°
//! guard), the cut surface here converges to the cutter itself, not to a smoothed band near it,
//! and the guard is tied to the mesh's own quality.
//!
//! [`CutStats::max_cut_distance`] reports how far from the cutter the cut vertices ended: 0 up to
//! rounding when every move was accepted; a vertex the guard held back leaves it larger.
//!
//! # The quality bound
//!
//! The enforced bound is `min(options.min_dihedral_degrees, worst minimum dihedral angle of the
//! kept input tets)`. The default floor is **5°**: our meshes come from isosurface stuffing
//! (`crate::mesher`), whose tets all have dihedral angles of at least about 10.7°, so the
//! cotangent weights of the diffusion matrix (TransCut eq. 10) are at most cot 10.7° ≈ 5.3. A 5°
//! floor lets the cut surface tets be half as sharp while bounding every cotangent weight by
//! cot 5° ≈ 11.4 — about twice the mesher's — so the matrix stays as well conditioned as the
//! mesher's output in order of magnitude, also in the GPU's single precision, where TransCut's
//! 0.5° (cot ≈ 115) caused the artefacts of its Fig. 9a. Taking the minimum with the input's own
//! worst angle means a mesh that is already worse than the floor (a user mesh, or one cut before
//! with a lower floor) is never made worse than it was, and the guard can always be met by not
//! moving at all.

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use super::cutter::{Cutter, Prepared};
use super::EditError;
use crate::mesh::{dihedral_angles, tet_volume, Incidence, TetMesh};
use crate::progress::{ms, Cancelled};

/// Cut vertices: `d ≥ −SNAP_BAND · h` (with `h` the mean length of the vertex's edges).
pub const SNAP_BAND: f64 = 0.25;

/// Halvings of a rejected step in the bisection for the largest acceptable part-way move.
pub const BISECTIONS: usize = 10;

/// Levels of halving in the search for edges that reach through the removed side between two
/// kept vertices ([`segment_reaches`]): removed parts down to 1/64 of an edge are found.
pub const BRIDGE_HALVINGS: u32 = 6;

/// Rounds of the unblocking pass (held-back cut vertices landing on the cutter near their
/// snapped neighbours).
pub const UNBLOCK_ROUNDS: usize = 10;

/// Options of [`cut`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CutOptions {
    /// Gauss–Seidel sweeps moving kept cut vertices onto the cut surface (0: no snapping, the
    /// cut surface is the jagged boundary of the kept tets). Default 20.
    pub relax_iterations: usize,
    /// Floor of the quality bound, degrees: no tet may end with a minimum dihedral angle below
    /// `min(min_dihedral_degrees, the kept input tets' worst)`. Default 5° (see the module docs).
    pub min_dihedral_degrees: f64,
}

impl Default for CutOptions {
    fn default() -> Self {
        Self { relax_iterations: 20, min_dihedral_degrees: 5.0 }
    }
}

impl CutOptions {
    /// # Errors
    /// [`EditError::InvalidOptions`] for a bound that is not finite or outside `[0, 70.5]` degrees
    /// (70.53° is the regular tetrahedron's dihedral angle, the most any tet can have).
    pub fn validate(&self) -> Result<(), EditError> {
        if !(0.0..=70.5).contains(&self.min_dihedral_degrees) {
            return Err(EditError::InvalidOptions(format!(
                "min_dihedral_degrees {} is not in [0, 70.5]",
                self.min_dihedral_degrees
            )));
        }
        Ok(())
    }
}

/// What a cut did.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CutStats {
    /// Tets and vertices deleted.
    pub removed_tets: usize,
    pub removed_vertices: usize,
    /// Kept vertices whose position changed.
    pub moved_vertices: usize,
    /// Kept cut vertices (those snapped onto the cut surface), and the largest |signed distance|
    /// among them after snapping (scene units): the tolerance within which the cut surface lies
    /// on the cutter.
    pub cut_surface_vertices: usize,
    pub max_cut_distance: f64,
    /// Worst dihedral angle after the cut, degrees, and the bound that was enforced.
    pub min_dihedral_degrees: f64,
    pub bound_degrees: f64,
    /// Milliseconds in the steps of the module docs: classify (1, signed distances and
    /// bridging edges), separate (2 and 3, deletion and the copies of vertices inside a thin
    /// removed part), snap (4 to 6: snap, unblock, rim) and the whole cut (with the new mesh's
    /// topology).
    pub classify_ms: f64,
    pub separate_ms: f64,
    pub snap_ms: f64,
    pub total_ms: f64,
}

/// A cut mesh and where its parts came from.
#[derive(Debug, Clone)]
pub struct CutResult {
    /// Compacted mesh; materials are the kept tets' materials.
    pub mesh: TetMesh,
    /// Per new tet: its id in the ORIGINAL (uncut) mesh.
    pub original_tet: Vec<u32>,
    /// Per new vertex: its index in the input mesh.
    pub kept_vertex: Vec<u32>,
    pub stats: CutStats,
}

/// Cuts `mesh` (whose tets carry the ids `original_tet` in the original mesh), removing the
/// cutter's positive side: classify, delete, snap (see the module docs).
///
/// # Errors
/// - [`EditError::InvalidCutter`] / [`EditError::InvalidStroke`] from [`Cutter::validate`];
/// - [`EditError::InvalidOptions`] for a bad bound or an `original_tet` of the wrong length;
/// - [`EditError::NothingLeft`] (piece 0; the editor renumbers) when every tet is removed;
/// - [`EditError::Mesh`] if the result fails [`TetMesh::new`] (not expected: the guard keeps
///   volumes positive).
pub fn cut(mesh: &TetMesh, original_tet: &[u32], cutter: &Cutter, options: &CutOptions) -> Result<CutResult, EditError> {
    cut_with(mesh, original_tet, cutter, options, &|| Ok(()))
}

/// [`cut`] calling `poll` between its steps (distances, deletion, each snapping pass, the rim,
/// the new mesh's topology), so that a caller can cancel inside a large cut.
///
/// # Errors
/// As [`cut`]; [`EditError::Cancelled`] when `poll` returns it.
pub fn cut_with(
    mesh: &TetMesh,
    original_tet: &[u32],
    cutter: &Cutter,
    options: &CutOptions,
    poll: &dyn Fn() -> Result<(), Cancelled>,
) -> Result<CutResult, EditError> {
    cutter.validate()?;
    options.validate()?;
    if original_tet.len() != mesh.tet_count() {
        return Err(EditError::InvalidOptions(format!(
            "original_tet has {} entries for {} tets",
            original_tet.len(),
            mesh.tet_count()
        )));
    }
    let start = Instant::now();
    let prepared = cutter.prepare();
    let positions = mesh.positions();
    // Per vertex: the mean and the longest length of its edges.
    let (mean_edge, longest_edge): (Vec<f64>, Vec<f64>) = (0..positions.len())
        .into_par_iter()
        .map(|v| {
            let ring = mesh.one_ring(v);
            let (sum, longest) = ring
                .iter()
                .map(|&w| (positions[w as usize] - positions[v]).length())
                .fold((0.0, 0.0f64), |(s, m), l| (s + l, m.max(l)));
            (sum / ring.len().max(1) as f64, longest)
        })
        .unzip();
    // Far from a solid cutter a bound stands in for the distance (`classifying_distance`): two
    // longest edges away, it decides the snap band and every edge's Lipschitz test alike.
    let distance: Vec<f64> =
        positions.par_iter().zip(&longest_edge).map(|(&p, &l)| prepared.classifying_distance(p, 2.0 * l)).collect();
    let mut is_cut: Vec<bool> = (0..positions.len()).map(|v| distance[v] >= -SNAP_BAND * mean_edge[v]).collect();
    for v in bridging_vertices(mesh, &prepared, &distance, &is_cut) {
        is_cut[v as usize] = true;
    }
    let classify_ms = ms(start);

    poll()?;
    let t = Instant::now();
    // Delete: keep tets with a firm vertex.
    let kept: Vec<u32> = (0..mesh.tet_count() as u32)
        .into_par_iter()
        .filter(|&t| mesh.tets()[t as usize].iter().any(|&v| !is_cut[v as usize]))
        .collect();
    if kept.is_empty() {
        return Err(EditError::NothingLeft { piece: 0 });
    }
    let mut new_index = vec![u32::MAX; positions.len()];
    for &t in &kept {
        for &v in &mesh.tets()[t as usize] {
            new_index[v as usize] = 0;
        }
    }
    let mut kept_vertex = Vec::new();
    for (v, slot) in new_index.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = kept_vertex.len() as u32;
            kept_vertex.push(v as u32);
        }
    }
    let mut tets: Vec<[u32; 4]> = kept.iter().map(|&t| mesh.tets()[t as usize].map(|v| new_index[v as usize])).collect();
    let mut pos: Vec<DVec3> = kept_vertex.iter().map(|&v| positions[v as usize]).collect();
    let distinct_kept = pos.len();
    let anchor = separate_sides(&prepared, &distance, &is_cut, &mut tets, &mut pos, &mut kept_vertex);
    let materials: Vec<u32> = kept.iter().map(|&t| mesh.materials()[t as usize]).collect();
    let original: Vec<u32> = kept.iter().map(|&t| original_tet[t as usize]).collect();
    let separate_ms = ms(t);

    poll()?;
    let t = Instant::now();
    // The bound: the floor, or the kept input's own worst angle if that is lower.
    let input_worst = tets.par_iter().map(|t| min_dihedral(t.map(|v| pos[v as usize]))).reduce(|| f64::INFINITY, f64::min);
    let bound_degrees = options.min_dihedral_degrees.min(input_worst.to_degrees());
    let bound = bound_degrees.to_radians();
    let (lo, hi) =
        pos.iter().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(a, b), p| (a.min(*p), b.max(*p)));
    let min_volume = 1e-12 * (hi - lo).length().powi(3);

    // Outward normals of the input boundary at kept vertices (zero inside), for sliding.
    let mut boundary_normal = vec![DVec3::ZERO; pos.len()];
    for face in mesh.boundary_faces() {
        let [a, b, c] = face.vertices.map(|v| positions[v as usize]);
        let n = (b - a).cross(c - a);
        for v in face.vertices {
            if new_index[v as usize] != u32::MAX {
                boundary_normal[new_index[v as usize] as usize] += n;
            }
        }
    }
    for copy in distinct_kept..pos.len() {
        boundary_normal[copy] = boundary_normal[new_index[kept_vertex[copy] as usize] as usize];
    }
    let target_of = |v: usize, pos: &[DVec3]| anchor[v].unwrap_or_else(|| prepared.closest_point(pos[v]));

    // Snap.
    let incident = Incidence::new(&tets, pos.len());
    let movable: Vec<u32> = (0..pos.len() as u32).filter(|&v| is_cut[kept_vertex[v as usize] as usize]).collect();
    let valid = |v: usize, p: DVec3, pos: &[DVec3]| ring_is_valid(incident.around(v), &tets, pos, v, p, bound, min_volume);
    let mut done = vec![false; movable.len()];
    for _ in 0..options.relax_iterations {
        poll()?;
        let mut any = false;
        for (i, &v) in movable.iter().enumerate() {
            if !done[i] {
                let target = target_of(v as usize, &pos);
                let (moved, reached) = step_towards(&mut pos, v as usize, target, &valid);
                any |= moved;
                done[i] = reached;
            }
        }
        if !any {
            break;
        }
    }

    poll()?;
    // Unblock (step 5 of the module docs).
    if options.relax_iterations > 0 {
        for _ in 0..UNBLOCK_ROUNDS {
            let mut any = false;
            for (i, &v) in movable.iter().enumerate() {
                if done[i] {
                    continue;
                }
                let v = v as usize;
                let target = target_of(v, &pos);
                let mut reached = false;
                if boundary_normal[v] == DVec3::ZERO {
                    let snapped = |w: usize| {
                        let original = kept_vertex[w] as usize;
                        w != v && is_cut[original] && prepared.signed_distance(pos[w]).abs() <= 1e-12 * mean_edge[original]
                    };
                    let (sum, n) = incident
                        .around(v)
                        .iter()
                        .flat_map(|&(t, _)| tets[t as usize])
                        .map(|w| w as usize)
                        .filter(|&w| snapped(w))
                        .fold((DVec3::ZERO, 0.0), |(s, n), w| (s + pos[w], n + 1.0));
                    if n > 0.0 {
                        let centroid = sum / n;
                        let reach = mean_edge[kept_vertex[v] as usize];
                        for goal in [prepared.closest_point(0.5 * (target + centroid)), prepared.closest_point(centroid)] {
                            if (goal - target).length() <= reach && valid(v, goal, &pos) {
                                pos[v] = goal;
                                (any, reached) = (true, true);
                                break;
                            }
                        }
                    }
                }
                if !reached {
                    let (moved, arrived) = step_towards(&mut pos, v, target, &valid);
                    any |= moved;
                    reached = arrived;
                }
                done[i] = reached;
            }
            if !any {
                break;
            }
        }
    }

    poll()?;
    // Rim: vertices of the object's surface that reached the cutter slide along it back to
    // where the cutter meets the surface's tangent plane (one pass, full moves only, same guard),
    // so the cross-section's rim is not pulled inside the object.
    if options.relax_iterations > 0 {
        for (i, &v) in movable.iter().enumerate() {
            let v = v as usize;
            if !done[i] || boundary_normal[v] == DVec3::ZERO || anchor[v].is_some() {
                continue;
            }
            let start = positions[kept_vertex[v] as usize];
            let slide = snap_target(&prepared, start, boundary_normal[v]);
            let target = prepared.closest_point(slide);
            if target == pos[v] || (target - slide).length() > 0.5 * (slide - start).length() {
                continue;
            }
            let ring = incident.around(v);
            if ring_is_valid(ring, &tets, &pos, v, target, bound, min_volume) {
                pos[v] = target;
            }
        }
    }

    let snap_ms = ms(t);
    let max_cut_distance = movable.par_iter().map(|&v| prepared.signed_distance(pos[v as usize]).abs()).reduce(|| 0.0, f64::max);
    let moved_vertices = (0..pos.len()).filter(|&v| pos[v] != positions[kept_vertex[v] as usize]).count();
    let min_after = tets.par_iter().map(|t| min_dihedral(t.map(|v| pos[v as usize]))).reduce(|| f64::INFINITY, f64::min);
    let removed_tets = mesh.tet_count() - tets.len();
    poll()?;
    let mesh = TetMesh::new(pos, tets, materials)?;
    let stats = CutStats {
        removed_tets,
        removed_vertices: positions.len() - distinct_kept,
        moved_vertices,
        cut_surface_vertices: movable.len(),
        max_cut_distance,
        min_dihedral_degrees: min_after.to_degrees(),
        bound_degrees,
        classify_ms,
        separate_ms,
        snap_ms,
        total_ms: ms(start),
    };
    Ok(CutResult { mesh, original_tet: original, kept_vertex, stats })
}

/// The second rule of step 1: both ends of every edge that passes through the removed side
/// although neither end lies on it (`d < 0` at both), with at least one end firm (an edge of two
/// cut vertices changes nothing). Such an edge reaches across a cutter thinner than the tets
/// (a slab through a graded mesh's interior): without this rule, its tets, whose four vertices are
/// all firm, would be kept and join the two sides. Sorted, without repeats.
fn bridging_vertices(mesh: &TetMesh, cutter: &Prepared<'_>, distance: &[f64], is_cut: &[bool]) -> Vec<u32> {
    if cutter.kept_side_is_convex() {
        return Vec::new();
    }
    let p = mesh.positions();
    let mut ends: Vec<u32> = mesh
        .edges()
        .par_iter()
        .filter(|&&[a, b]| {
            let (a, b) = (a as usize, b as usize);
            distance[a] < 0.0
                && distance[b] < 0.0
                && !(is_cut[a] && is_cut[b])
                && segment_reaches(cutter, (p[a], distance[a]), (p[b], distance[b]), BRIDGE_HALVINGS)
        })
        .flat_map_iter(|&[a, b]| [a, b])
        .collect();
    ends.par_sort_unstable();
    ends.dedup();
    ends
}

/// Whether the segment between `a` and `b` (points with their signed distances, both `< 0`)
/// reaches the removed side (`d ≥ 0`). The signed distance is 1-Lipschitz, so no point of the
/// segment is removed when `|d_a| + |d_b| ≥ |b − a|`; otherwise the midpoint is tested, then
/// both halves in turn, for at most `halvings` levels (a removed part thinner than
/// `|b − a| / 2^halvings` can be missed).
fn segment_reaches(cutter: &Prepared<'_>, (a, da): (DVec3, f64), (b, db): (DVec3, f64), halvings: u32) -> bool {
    if -(da + db) >= (b - a).length() || halvings == 0 {
        return false;
    }
    let m = 0.5 * (a + b);
    let dm = cutter.signed_distance(m);
    dm >= 0.0
        || segment_reaches(cutter, (a, da), (m, dm), halvings - 1)
        || segment_reaches(cutter, (m, dm), (b, db), halvings - 1)
}

/// Step 3 of the module docs: a kept vertex on the removed side (`d ≥ 0`) that kept tets on BOTH sides of a thin
/// removed part still use would join them. Its kept tets are grouped by side (two tets are on
/// the same side when the segment between firm vertices of theirs does not reach the removed
/// side, [`segment_reaches`]); each group after the first gets its own copy of the vertex
/// (appended to `pos` and `kept_vertex`, the group's tets renumbered).
///
/// Returns per new vertex the fixed point its snap aims at, `None` for its closest point
/// (recomputed as it moves). The closest point of a vertex inside a thin removed part can lie on
/// the far side of it, away from the vertex's tets; then, and only then, the vertex (or copy)
/// aims at the point where the segment from its side's firm vertex to it enters the removed side.
fn separate_sides(
    cutter: &Prepared<'_>,
    distance: &[f64],
    is_cut: &[bool],
    tets: &mut [[u32; 4]],
    pos: &mut Vec<DVec3>,
    kept_vertex: &mut Vec<u32>,
) -> Vec<Option<DVec3>> {
    if cutter.kept_side_is_convex() {
        return vec![None; pos.len()];
    }
    let incident = Incidence::new(tets, pos.len());
    let d = |v: u32| distance[kept_vertex[v as usize] as usize];
    let firm = |t: u32| tets[t as usize].into_iter().find(|&w| !is_cut[kept_vertex[w as usize] as usize]);
    let apart = |a: u32, b: DVec3, db: f64| segment_reaches(cutter, (pos[a as usize], d(a)), (b, db), BRIDGE_HALVINGS);
    // Per vertex inside the removed side: its sides (tets, and the anchor if not the closest point).
    type Side = (Vec<u32>, Option<DVec3>);
    let split: Vec<(u32, Vec<Side>)> = (0..pos.len() as u32)
        .into_par_iter()
        .filter(|&v| d(v) > 0.0)
        .filter_map(|v| {
            let mut sides: Vec<(u32, Vec<u32>)> = Vec::new();
            for &(t, _) in incident.around(v as usize) {
                let f = firm(t).expect("every kept tet has a firm vertex");
                match sides.iter_mut().find(|(r, _)| *r == f || !apart(*r, pos[f as usize], d(f))) {
                    Some(side) => side.1.push(t),
                    None => sides.push((f, vec![t])),
                }
            }
            // Just outside the cutter at the closest point: on a side's side, or across.
            let p = pos[v as usize];
            let closest = cutter.closest_point(p);
            let outside = closest + 1e-3 * (closest - p);
            let outside_distance = cutter.signed_distance(outside);
            let sides: Vec<Side> = sides
                .into_iter()
                .map(|(f, tets)| {
                    let across = outside_distance >= 0.0 || apart(f, outside, outside_distance);
                    (tets, across.then(|| entry_point(cutter, pos[f as usize], p)))
                })
                .collect();
            (sides.len() > 1 || sides[0].1.is_some()).then_some((v, sides))
        })
        .collect();
    let mut anchor = vec![None; pos.len()];
    for (v, sides) in split {
        for (k, (side, aim)) in sides.into_iter().enumerate() {
            let copy = if k == 0 {
                v
            } else {
                pos.push(pos[v as usize]);
                kept_vertex.push(kept_vertex[v as usize]);
                anchor.push(None);
                let copy = (pos.len() - 1) as u32;
                for t in side {
                    for w in &mut tets[t as usize] {
                        if *w == v {
                            *w = copy;
                        }
                    }
                }
                copy
            };
            anchor[copy as usize] = aim;
        }
    }
    anchor
}

/// A point of the cut surface on the segment from `from` (kept side, `d < 0`) to `to` (removed
/// side, `d ≥ 0`), by bisection of the signed distance to rounding.
fn entry_point(cutter: &Prepared<'_>, from: DVec3, to: DVec3) -> DVec3 {
    let (mut kept, mut removed) = (from, to);
    for _ in 0..60 {
        let m = 0.5 * (kept + removed);
        if m == kept || m == removed {
            break;
        }
        if cutter.signed_distance(m) >= 0.0 {
            removed = m;
        } else {
            kept = m;
        }
    }
    cutter.closest_point(0.5 * (kept + removed))
}

/// Where a cut vertex at `p` should go. Inside the mesh: the closest point of the cut surface.
/// On the input's boundary (outward normal `boundary` ≠ 0) the vertex slides in the boundary's
/// tangent plane instead, along the cutter normal `n_c` projected onto it,
/// `t = n_c − (n_c·n̂_b) n̂_b`, by `−d / (t·n_c)` (exact for a plane cutter and a locally flat
/// boundary), so the rim of the cross-section stays on the object's surface instead of being
/// pulled inside it; when the cutter meets the boundary at less than 30° (`|t|² < ¼`) it falls
/// back to the closest point.
fn snap_target(cutter: &Prepared<'_>, p: DVec3, boundary: DVec3) -> DVec3 {
    let closest = cutter.closest_point(p);
    let nb = boundary.normalize_or_zero();
    if nb == DVec3::ZERO {
        return closest;
    }
    let d = cutter.signed_distance(p);
    let offset = p - closest;
    if d == 0.0 || offset.length_squared() == 0.0 {
        return closest;
    }
    let nc = offset.normalize() * d.signum();
    let t = nc - nc.dot(nb) * nb;
    if t.length_squared() < 0.25 {
        return closest;
    }
    p - (d / t.dot(nc)) * t
}

/// Moves vertex `v` towards `target`: the whole way if `valid(v, target, pos)` accepts it, else
/// the largest accepted fraction found by [`BISECTIONS`] halvings. Returns (moved, reached).
fn step_towards(pos: &mut [DVec3], v: usize, target: DVec3, valid: &impl Fn(usize, DVec3, &[DVec3]) -> bool) -> (bool, bool) {
    let from = pos[v];
    if target == from {
        return (false, true);
    }
    if valid(v, target, pos) {
        pos[v] = target;
        return (true, true);
    }
    let (mut good, mut bad) = (0.0, 1.0);
    for _ in 0..BISECTIONS {
        let mid = 0.5 * (good + bad);
        if valid(v, from + mid * (target - from), pos) {
            good = mid;
        } else {
            bad = mid;
        }
    }
    if good > 0.0 {
        pos[v] = from + good * (target - from);
    }
    (good > 0.0, false)
}

/// Smallest dihedral angle of a tet, radians.
fn min_dihedral(p: [DVec3; 4]) -> f64 {
    dihedral_angles(p).into_iter().fold(f64::INFINITY, f64::min)
}

/// Whether moving vertex `v` to `p` keeps every tet of `ring` positively oriented (volume above
/// `min_volume`) with a minimum dihedral angle of at least `bound` radians.
fn ring_is_valid(ring: &[(u32, u8)], tets: &[[u32; 4]], pos: &[DVec3], v: usize, p: DVec3, bound: f64, min_volume: f64) -> bool {
    ring.iter().all(|&(t, _)| {
        let corners = tets[t as usize].map(|w| if w as usize == v { p } else { pos[w as usize] });
        tet_volume(corners) > min_volume && min_dihedral(corners) >= bound
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn invalid_options_are_named() {
        let opts = CutOptions { min_dihedral_degrees: f64::NAN, ..CutOptions::default() };
        assert!(matches!(opts.validate(), Err(EditError::InvalidOptions(_))));
    }
}
