//! Cutting a tetrahedral mesh (TransCut §5.1): the cutters (a plane, a screen-space stroke swept
//! along the view rays, a closed solid) and [`cut`], which removes the cutter's positive side and
//! moves the kept vertices near the cut onto the cut surface without letting any tet fall below a
//! quality bound.
//!
//! # The cut, step by step
//!
//! With `d(x)` the cutter's signed distance ([`Cutter::signed_distance`], `> 0` on the removed
//! side) and `h_v` the mean length of the edges at vertex `v`:
//!
//! 1. **Classify.** A vertex is a *cut vertex* when `d_v ≥ −β h_v` ([`SNAP_BAND`] `β = 0.25`):
//!    on the removed side, or on the kept side but so close to the cut surface that a tet
//!    between it and the surface would be a sliver. Every other vertex is *firm*.
//! 2. **Delete.** A tet is kept when at least one of its vertices is firm; tets whose four vertices
//!    are all cut vertices (entirely on the removed side, or in the thin band that will collapse
//!    onto the cut surface) are deleted. Vertices no kept tet uses are removed. Kept tets keep
//!    their id in the ORIGINAL mesh (`original_tet`), vertices are compacted in increasing old id.
//! 3. **Snap.** Every kept cut vertex is moved onto the cut surface, to
//!    [`Cutter::closest_point`], in up to `relax_iterations` Gauss–Seidel sweeps in increasing
//!    vertex order (deterministic). A move is accepted only if every kept tet of the vertex's one
//!    ring stays positively oriented (volume above `1e-12 ×` the bounding-box diagonal³) and keeps
//!    its minimum dihedral angle at or above the bound; otherwise the largest accepted fraction of
//!    the step is found by bisection ([`BISECTIONS`] halvings) and the vertex tries again in the
//!    next sweep. Sweeps stop early when a sweep moves nothing.
//! 4. **Rim.** Snapping a vertex of the object's surface along the cutter normal pulls the rim
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

use glam::DVec3;
use rayon::prelude::*;

use super::EditError;
use crate::mesh::{dihedral_angles, tet_volume, TetMesh, TriMesh, TriangleBvh};
use crate::mesher::WindingNumber;

/// Cut vertices: `d ≥ −SNAP_BAND · h` (with `h` the mean length of the vertex's edges).
pub const SNAP_BAND: f64 = 0.25;

/// Halvings of a rejected step in the bisection for the largest acceptable part-way move.
pub const BISECTIONS: usize = 10;

/// What cuts. Signed distance `> 0` on the side that is REMOVED.
#[derive(Debug, Clone)]
pub enum Cutter {
    /// Removes the half-space the normal points into: `{x : (x − point)·normal > 0}`. The normal
    /// need not be a unit vector.
    Plane { point: DVec3, normal: DVec3 },
    /// A screen-space stroke swept along the view rays (TransCut §5.1); see [`SweptStroke`].
    Stroke(SweptStroke),
    /// A closed triangle mesh (world space). An outward-oriented mesh (positive signed volume)
    /// removes what lies inside it (generalised winding number `w > ½`); an inward-oriented one
    /// (what [`Cutter::flipped`] makes) removes what lies outside (`w > −½`).
    Solid(TriMesh),
}

impl Cutter {
    /// Checks that the cutter is usable: finite numbers, a non-zero plane normal, a solid with
    /// at least one triangle and finite vertices (strokes are checked by [`SweptStroke::new`]).
    /// Nothing is normalised.
    ///
    /// # Errors
    /// [`EditError::InvalidCutter`] naming the field that is wrong.
    pub fn validate(&self) -> Result<(), EditError> {
        match self {
            Cutter::Plane { point, normal } => {
                if !point.is_finite() {
                    return Err(EditError::InvalidCutter(format!("plane point {point} is not finite")));
                }
                if !normal.is_finite() || !(normal.length_squared() > 0.0) || !normal.length().is_finite() {
                    return Err(EditError::InvalidCutter(format!("plane normal {normal} is zero or not finite")));
                }
                Ok(())
            }
            Cutter::Stroke(s) => SweptStroke::new(s.origins.clone(), s.directions.clone()).map(|_| ()),
            Cutter::Solid(m) => {
                if m.triangles().is_empty() {
                    return Err(EditError::InvalidCutter("solid cutter mesh has no triangles".into()));
                }
                if let Some(v) = m.positions().iter().position(|p| !p.is_finite()) {
                    return Err(EditError::InvalidCutter(format!("solid cutter vertex {v} is not finite")));
                }
                Ok(())
            }
        }
    }

    /// Signed distance from `p` to the cut surface, `> 0` on the removed side. For a solid this
    /// builds the cutter's search trees on every call; [`cut`] builds them once.
    #[must_use]
    pub fn signed_distance(&self, p: DVec3) -> f64 {
        self.prepare().signed_distance(p)
    }

    /// The point of the cut surface closest to `p`.
    #[must_use]
    pub fn closest_point(&self, p: DVec3) -> DVec3 {
        self.prepare().closest_point(p)
    }

    /// The cutter that removes the other side (a split keeps both): the plane with the opposite
    /// normal, the stroke drawn backwards, the solid with its triangles reversed.
    #[must_use]
    pub fn flipped(&self) -> Cutter {
        match self {
            Cutter::Plane { point, normal } => Cutter::Plane { point: *point, normal: -*normal },
            Cutter::Stroke(s) => {
                let mut origins = s.origins.clone();
                let mut directions = s.directions.clone();
                origins.reverse();
                directions.reverse();
                Cutter::Stroke(SweptStroke::build(origins, directions))
            }
            Cutter::Solid(m) => Cutter::Solid(TriMesh {
                positions: m.positions.clone(),
                triangles: m.triangles.iter().map(|&[a, b, c]| [a, c, b]).collect(),
                user_to_internal: m.user_to_internal.clone(),
            }),
        }
    }

    /// The cutter with its search structures built (solid: BVH and winding-number tree).
    fn prepare(&self) -> Prepared<'_> {
        match self {
            Cutter::Plane { point, normal } => Prepared::Plane { point: *point, normal: *normal },
            Cutter::Stroke(s) => Prepared::Stroke(s),
            Cutter::Solid(m) => {
                let bvh = TriangleBvh::from_indexed(m.positions(), m.triangles());
                let threshold = if m.signed_volume() >= 0.0 { 0.5 } else { -0.5 };
                Prepared::Solid { winding: WindingNumber::new(bvh), threshold }
            }
        }
    }
}

/// Signed distance to the plane through `point` with (not necessarily unit) `normal`:
/// `(x − point)·normal / |normal|`. Shared by planes and stroke quads so that a stroke with one
/// quad gives bit-for-bit the distances of the equivalent plane.
fn plane_distance(x: DVec3, point: DVec3, normal: DVec3) -> f64 {
    (x - point).dot(normal) / normal.length()
}

/// Orthogonal projection of `x` onto the plane (see [`plane_distance`]).
fn plane_project(x: DVec3, point: DVec3, normal: DVec3) -> DVec3 {
    x - plane_distance(x, point, normal) * (normal / normal.length())
}

/// A cutter ready for many queries.
enum Prepared<'a> {
    Plane { point: DVec3, normal: DVec3 },
    Stroke(&'a SweptStroke),
    Solid { winding: WindingNumber, threshold: f64 },
}

impl Prepared<'_> {
    fn signed_distance(&self, p: DVec3) -> f64 {
        match self {
            Prepared::Plane { point, normal } => plane_distance(p, *point, *normal),
            Prepared::Stroke(s) => s.query(p).0,
            Prepared::Solid { winding, threshold } => {
                let Some(sp) = winding.bvh().closest_point(p) else {
                    return f64::NEG_INFINITY;
                };
                if solid_removes(winding, *threshold, p) {
                    sp.distance
                } else {
                    -sp.distance
                }
            }
        }
    }

    fn closest_point(&self, p: DVec3) -> DVec3 {
        match self {
            Prepared::Plane { point, normal } => plane_project(p, *point, *normal),
            Prepared::Stroke(s) => s.query(p).1,
            Prepared::Solid { winding, .. } => winding.bvh().closest_point(p).map_or(p, |sp| sp.point),
        }
    }
}

/// Whether a solid cutter removes `p`: winding number above the threshold, re-evaluated with the
/// accurate far field (β = 5, as the mesher does) within 0.05 of it.
fn solid_removes(winding: &WindingNumber, threshold: f64, p: DVec3) -> bool {
    let mut w = winding.at(p);
    if (w - threshold).abs() < 0.05 {
        w = winding.at_with_accuracy(p, 5.0);
    }
    w > threshold
}

/// A stroke drawn on screen, swept along the camera rays: ray `k` is `origins[k] + t·directions[k]`,
/// `t ≥ 0`. Consecutive rays span a planar quad of the cut surface (a half-strip for an
/// orthographic camera, a wedge from the eye for a perspective one); the first and last quads are
/// extended to infinity beyond the first and last ray, so the surface separates the space in
/// front of the stroke.
///
/// **Side convention.** Quad `k` has the normal
/// `m_k = (o_{k+1} − o_k) × d_k + d_{k+1} × d_k = (p_{k+1} − p_k) × d_k` with `p_k = o_k + d_k`
/// the points at `t = 1`, and the side `m_k` points to is REMOVED. Seen by a viewer looking along
/// the rays (screen x right, y up), that is the LEFT of the stroke's drawing direction, as in
/// TransCut §5.1 ("tetrahedra … on the left side of the stroke are deleted"): drawing from left to
/// right removes what is above the stroke. (This is `−(d_k × (p_{k+1} − p_k))`; the contract's
/// first draft wrote the cross product the other way round, which is the right-hand side.)
///
/// The signed distance of a point is its distance to the nearest quad, with the sign of that
/// quad's side; where the nearest point lies on a ray shared by two quads, the sign is taken
/// against the sum of the two unit normals (the edge pseudo-normal, exact for a polyhedral
/// surface). Points behind the stroke's origins (`t < 0`) get a well-defined but arbitrary side:
/// objects are expected in front of the camera.
#[derive(Debug, Clone)]
pub struct SweptStroke {
    origins: Vec<DVec3>,
    directions: Vec<DVec3>,
    quads: Vec<Quad>,
}

/// One planar piece of a swept stroke: the region `{q in the plane : (q − line.point)·line.inward
/// ≥ 0 for every line}` (rays k and k + 1 and the origin edge, minus those removed at the ends).
#[derive(Debug, Clone)]
struct Quad {
    anchor: DVec3,
    normal: DVec3,
    unit: DVec3,
    lines: Vec<Line>,
}

/// A boundary line of a quad; `neighbour` is the quad on its other side (a shared ray).
#[derive(Debug, Clone)]
struct Line {
    point: DVec3,
    dir: DVec3,
    inward: DVec3,
    neighbour: Option<usize>,
}

impl SweptStroke {
    /// A stroke from one ray per stroke point.
    ///
    /// # Errors
    /// [`EditError::InvalidStroke`] when there are fewer than 2 rays, the lengths differ, a value
    /// is not finite, a direction is zero, two consecutive rays span no quad (parallel and on one
    /// line, or both through the same origin in the same direction), or two consecutive rays are
    /// skew (their quad would not be planar; a perspective or an orthographic camera never gives
    /// that).
    pub fn new(origins: Vec<DVec3>, directions: Vec<DVec3>) -> Result<Self, EditError> {
        if origins.len() != directions.len() {
            return Err(EditError::InvalidStroke(format!("{} origins but {} directions", origins.len(), directions.len())));
        }
        if origins.len() < 2 {
            return Err(EditError::InvalidStroke(format!("a swept stroke needs at least 2 rays, got {}", origins.len())));
        }
        if let Some(k) = origins.iter().position(|o| !o.is_finite()) {
            return Err(EditError::InvalidStroke(format!("origin {k} is not finite")));
        }
        if let Some(k) = directions.iter().position(|d| !d.is_finite() || !(d.length_squared() > 0.0)) {
            return Err(EditError::InvalidStroke(format!("direction {k} is zero or not finite")));
        }
        for k in 0..origins.len() - 1 {
            let (o0, o1, d0, d1) = (origins[k], origins[k + 1], directions[k], directions[k + 1]);
            let m = quad_normal(o0, o1, d0, d1);
            let scale = ((o1 - o0).length() + d0.length()) * ((o1 - o0).length() + d1.length());
            if !(m.length() > 1e-12 * scale) {
                return Err(EditError::InvalidStroke(format!("rays {k} and {} span no quad (parallel or coincident)", k + 1)));
            }
            let skew = (o1 - o0).dot(d0.cross(d1)).abs();
            if skew > 1e-9 * (o1 - o0).length() * d0.length() * d1.length() {
                return Err(EditError::InvalidStroke(format!(
                    "rays {k} and {} are skew (their quad is not planar); use one eye or one direction",
                    k + 1
                )));
            }
        }
        Ok(Self::build(origins, directions))
    }

    /// A perspective stroke: every ray starts at `eye`.
    ///
    /// # Errors
    /// As [`SweptStroke::new`] (also for a non-finite eye).
    pub fn perspective(eye: DVec3, directions: Vec<DVec3>) -> Result<Self, EditError> {
        Self::new(vec![eye; directions.len()], directions)
    }

    /// Ray origins.
    #[must_use]
    pub fn origins(&self) -> &[DVec3] {
        &self.origins
    }

    /// Ray directions.
    #[must_use]
    pub fn directions(&self) -> &[DVec3] {
        &self.directions
    }

    /// Builds the quads of already validated rays.
    fn build(origins: Vec<DVec3>, directions: Vec<DVec3>) -> Self {
        let n = origins.len();
        let quads = (0..n - 1)
            .map(|k| {
                let (o0, o1, d0, d1) = (origins[k], origins[k + 1], directions[k], directions[k + 1]);
                let normal = quad_normal(o0, o1, d0, d1);
                let unit = normal / normal.length();
                let in_plane = |dir: DVec3, towards: DVec3| {
                    let e = unit.cross(dir).normalize_or_zero();
                    if e.dot(towards) < 0.0 {
                        -e
                    } else {
                        e
                    }
                };
                let mut lines = Vec::with_capacity(3);
                if k > 0 {
                    lines.push(Line { point: o0, dir: d0, inward: in_plane(d0, o1 + d1 - o0), neighbour: Some(k - 1) });
                }
                if k + 2 < n {
                    lines.push(Line { point: o1, dir: d1, inward: in_plane(d1, o0 + d0 - o1), neighbour: Some(k + 1) });
                }
                let edge = o1 - o0;
                if edge.length_squared() > 0.0 {
                    lines.push(Line { point: o0, dir: edge, inward: in_plane(edge, d0 + d1), neighbour: None });
                }
                Quad { anchor: o0, normal, unit, lines }
            })
            .collect();
        Self { origins, directions, quads }
    }

    /// Signed distance and closest point on the swept surface.
    fn query(&self, x: DVec3) -> (f64, DVec3) {
        let mut best: Option<(f64, f64, DVec3)> = None; // (distance², signed distance, point)
        for q in &self.quads {
            let (d2, signed, c) = q.query(x, &self.quads);
            if best.is_none_or(|b| d2 < b.0) {
                best = Some((d2, signed, c));
            }
        }
        best.map_or((0.0, x), |(_, s, c)| (s, c))
    }
}

/// `(o1 − o0) × d0 + d1 × d0`: the normal of the quad between two rays; for an orthographic pair
/// (`d1 = d0`) the second term is exactly zero, for a perspective pair (`o1 = o0`) the first is.
fn quad_normal(o0: DVec3, o1: DVec3, d0: DVec3, d1: DVec3) -> DVec3 {
    (o1 - o0).cross(d0) + d1.cross(d0)
}

impl Quad {
    /// `(distance², signed distance, closest point)` of `x` to this quad's region.
    fn query(&self, x: DVec3, quads: &[Quad]) -> (f64, f64, DVec3) {
        let signed = plane_distance(x, self.anchor, self.normal);
        let q = x - signed * self.unit;
        if self.lines.iter().all(|l| (q - l.point).dot(l.inward) >= 0.0) {
            return (signed * signed, signed, q);
        }
        // Outside: the nearest point lies on a boundary line, within the other lines' half-planes.
        let mut best: Option<(f64, DVec3, Option<usize>)> = None;
        for (i, l) in self.lines.iter().enumerate() {
            let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
            for (j, m) in self.lines.iter().enumerate() {
                if i == j {
                    continue;
                }
                // (l.point + u l.dir − m.point)·m.inward ≥ 0
                let a = l.dir.dot(m.inward);
                let b = (m.point - l.point).dot(m.inward);
                if a.abs() < 1e-300 {
                    if b > 0.0 {
                        lo = f64::INFINITY;
                    }
                } else if a > 0.0 {
                    lo = lo.max(b / a);
                } else {
                    hi = hi.min(b / a);
                }
            }
            if lo > hi {
                continue;
            }
            let u = ((q - l.point).dot(l.dir) / l.dir.length_squared()).clamp(lo, hi);
            let c = l.point + u * l.dir;
            let d2 = (x - c).length_squared();
            if best.is_none_or(|b| d2 < b.0) {
                best = Some((d2, c, l.neighbour));
            }
        }
        let Some((d2, c, neighbour)) = best else {
            return (signed * signed, signed, q);
        };
        let pseudo = match neighbour {
            Some(nb) => self.unit + quads[nb].unit,
            None => self.unit,
        };
        let side = (x - c).dot(pseudo);
        let dist = d2.sqrt();
        (
            d2,
            if side > 0.0 {
                dist
            } else if side < 0.0 {
                -dist
            } else {
                0.0
            },
            c,
        )
    }
}

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
    cutter.validate()?;
    options.validate()?;
    if original_tet.len() != mesh.tet_count() {
        return Err(EditError::InvalidOptions(format!(
            "original_tet has {} entries for {} tets",
            original_tet.len(),
            mesh.tet_count()
        )));
    }
    let prepared = cutter.prepare();
    let positions = mesh.positions();
    let distance: Vec<f64> = positions.par_iter().map(|&p| prepared.signed_distance(p)).collect();
    let is_cut: Vec<bool> = (0..positions.len())
        .into_par_iter()
        .map(|v| {
            let ring = mesh.one_ring(v);
            let h = if ring.is_empty() {
                0.0
            } else {
                ring.iter().map(|&w| (positions[w as usize] - positions[v]).length()).sum::<f64>() / ring.len() as f64
            };
            distance[v] >= -SNAP_BAND * h
        })
        .collect();

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
    let tets: Vec<[u32; 4]> = kept.iter().map(|&t| mesh.tets()[t as usize].map(|v| new_index[v as usize])).collect();
    let mut pos: Vec<DVec3> = kept_vertex.iter().map(|&v| positions[v as usize]).collect();
    let materials: Vec<u32> = kept.iter().map(|&t| mesh.materials()[t as usize]).collect();
    let original: Vec<u32> = kept.iter().map(|&t| original_tet[t as usize]).collect();

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

    // Snap.
    let incident = incident_tets(pos.len(), &tets);
    let movable: Vec<u32> = (0..pos.len() as u32).filter(|&v| is_cut[kept_vertex[v as usize] as usize]).collect();
    let mut done = vec![false; movable.len()];
    for _ in 0..options.relax_iterations {
        let mut any = false;
        for (i, &v) in movable.iter().enumerate() {
            if done[i] {
                continue;
            }
            let v = v as usize;
            let from = pos[v];
            let target = prepared.closest_point(from);
            if target == from {
                done[i] = true;
                continue;
            }
            let ring = &incident.1[incident.0[v] as usize..incident.0[v + 1] as usize];
            let ok = |p: DVec3, pos: &[DVec3]| ring_is_valid(ring, &tets, pos, v, p, bound, min_volume);
            if ok(target, &pos) {
                pos[v] = target;
                done[i] = true;
                any = true;
                continue;
            }
            let (mut good, mut bad) = (0.0, 1.0);
            for _ in 0..BISECTIONS {
                let mid = 0.5 * (good + bad);
                if ok(from + mid * (target - from), &pos) {
                    good = mid;
                } else {
                    bad = mid;
                }
            }
            if good > 0.0 {
                pos[v] = from + good * (target - from);
                any = true;
            }
        }
        if !any {
            break;
        }
    }

    // Rim: vertices of the object's surface that reached the cutter slide along it back to
    // where the cutter meets the surface's tangent plane (one pass, full moves only, same guard),
    // so the cross-section's rim is not pulled inside the object.
    if options.relax_iterations > 0 {
        for (i, &v) in movable.iter().enumerate() {
            let v = v as usize;
            if !done[i] || boundary_normal[v] == DVec3::ZERO {
                continue;
            }
            let start = positions[kept_vertex[v] as usize];
            let slide = snap_target(&prepared, start, boundary_normal[v]);
            let target = prepared.closest_point(slide);
            if target == pos[v] || (target - slide).length() > 0.5 * (slide - start).length() {
                continue;
            }
            let ring = &incident.1[incident.0[v] as usize..incident.0[v + 1] as usize];
            if ring_is_valid(ring, &tets, &pos, v, target, bound, min_volume) {
                pos[v] = target;
            }
        }
    }

    let max_cut_distance = movable.par_iter().map(|&v| prepared.signed_distance(pos[v as usize]).abs()).reduce(|| 0.0, f64::max);
    let moved_vertices = (0..pos.len()).filter(|&v| pos[v] != positions[kept_vertex[v] as usize]).count();
    let min_after = tets.par_iter().map(|t| min_dihedral(t.map(|v| pos[v as usize]))).reduce(|| f64::INFINITY, f64::min);
    let stats = CutStats {
        removed_tets: mesh.tet_count() - tets.len(),
        removed_vertices: positions.len() - pos.len(),
        moved_vertices,
        cut_surface_vertices: movable.len(),
        max_cut_distance,
        min_dihedral_degrees: min_after.to_degrees(),
        bound_degrees,
    };
    let mesh = TetMesh::new(pos, tets, materials)?;
    Ok(CutResult { mesh, original_tet: original, kept_vertex, stats })
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

/// Smallest dihedral angle of a tet, radians.
fn min_dihedral(p: [DVec3; 4]) -> f64 {
    dihedral_angles(p).into_iter().fold(f64::INFINITY, f64::min)
}

/// Vertex → incident tets in CSR form `(offsets, tets)`, tets in increasing order.
fn incident_tets(vertices: usize, tets: &[[u32; 4]]) -> (Vec<u32>, Vec<u32>) {
    let mut offsets = vec![0u32; vertices + 1];
    for t in tets {
        for &v in t {
            offsets[v as usize + 1] += 1;
        }
    }
    for v in 0..vertices {
        offsets[v + 1] += offsets[v];
    }
    let mut fill = offsets.clone();
    let mut list = vec![0u32; offsets[vertices] as usize];
    for (ti, t) in tets.iter().enumerate() {
        for &v in t {
            list[fill[v as usize] as usize] = ti as u32;
            fill[v as usize] += 1;
        }
    }
    (offsets, list)
}

/// Whether moving vertex `v` to `p` keeps every tet of `ring` positively oriented (volume above
/// `min_volume`) with a minimum dihedral angle of at least `bound` radians.
fn ring_is_valid(ring: &[u32], tets: &[[u32; 4]], pos: &[DVec3], v: usize, p: DVec3, bound: f64, min_volume: f64) -> bool {
    ring.iter().all(|&t| {
        let corners = tets[t as usize].map(|w| if w as usize == v { p } else { pos[w as usize] });
        tet_volume(corners) > min_volume && min_dihedral(corners) >= bound
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bent_orthographic_stroke_signs_both_legs_and_the_corner() {
        // Looking along −z, drawn right along +x then up along +y: an "L" whose left side is the
        // upper-left region {y > 0 and x < 1}.
        let d = DVec3::new(0.0, 0.0, -1.0);
        let o = [DVec3::new(-1.0, 0.0, 5.0), DVec3::new(1.0, 0.0, 5.0), DVec3::new(1.0, 2.0, 5.0)];
        let c = Cutter::Stroke(SweptStroke::new(o.to_vec(), vec![d; 3]).unwrap());
        let at = |x: f64, y: f64| c.signed_distance(DVec3::new(x, y, 0.0));
        assert!((at(0.0, 0.5) - 0.5).abs() < 1e-12);
        assert!((at(0.0, -0.5) + 0.5).abs() < 1e-12);
        assert!((at(0.5, 1.0) - 0.5).abs() < 1e-12);
        assert!((at(1.5, 1.0) + 0.5).abs() < 1e-12);
        // Beyond the corner (x > 1, y < 0) the nearest point is the shared ray; the point is right
        // of both legs, so kept (signed by the edge pseudo-normal), at the distance to that ray.
        assert!((at(1.3, -0.4) + 0.5).abs() < 1e-12);
        // Extended ends: far left along the first leg, far up along the last.
        assert!((at(-10.0, 0.25) - 0.25).abs() < 1e-12);
        assert!((at(1.75, 10.0) + 0.75).abs() < 1e-12);
        assert!((c.closest_point(DVec3::new(1.3, -0.4, 0.0)) - DVec3::new(1.0, 0.0, 0.0)).length() < 1e-12);
        assert!((c.flipped().signed_distance(DVec3::new(0.5, 1.0, 0.0)) + 0.5).abs() < 1e-12);
    }

    #[test]
    fn invalid_cutters_and_strokes_name_the_problem() {
        let bad = Cutter::Plane { point: DVec3::ZERO, normal: DVec3::ZERO };
        assert!(matches!(bad.validate(), Err(EditError::InvalidCutter(m)) if m.contains("normal")));
        let nan = Cutter::Plane { point: DVec3::new(f64::NAN, 0.0, 0.0), normal: DVec3::Z };
        assert!(matches!(nan.validate(), Err(EditError::InvalidCutter(m)) if m.contains("point")));
        let d = DVec3::NEG_Z;
        let err = |r: Result<SweptStroke, EditError>| match r {
            Err(EditError::InvalidStroke(m)) => m,
            other => panic!("{other:?}"),
        };
        assert!(err(SweptStroke::new(vec![DVec3::ZERO], vec![d])).contains("at least 2"));
        assert!(err(SweptStroke::new(vec![DVec3::ZERO; 2], vec![d])).contains("directions"));
        assert!(err(SweptStroke::new(vec![DVec3::ZERO, DVec3::X], vec![d, DVec3::ZERO])).contains("direction 1"));
        assert!(err(SweptStroke::new(vec![DVec3::ZERO, DVec3::Z], vec![d, d])).contains("span no quad"));
        assert!(err(SweptStroke::new(vec![DVec3::ZERO, DVec3::X], vec![d, DVec3::new(0.0, 1.0, -1.0)])).contains("skew"));
        assert!(err(SweptStroke::perspective(DVec3::ZERO, vec![d, 2.0 * d])).contains("span no quad"));
        let opts = CutOptions { min_dihedral_degrees: f64::NAN, ..CutOptions::default() };
        assert!(matches!(opts.validate(), Err(EditError::InvalidOptions(_))));
    }
}
