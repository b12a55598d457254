//! Surface → quality tetrahedra.
//!
//! [`tetrahedralize`] fills the solid bounded by a triangle mesh with tetrahedra by **isosurface
//! stuffing** on a body-centred cubic lattice (Labelle & Shewchuk, *Isosurface Stuffing: Fast
//! Tetrahedral Meshes with Good Dihedral Angles*, SIGGRAPH 2007). Inside and outside come from the
//! **generalised winding number** (Barill et al. 2018), so open scans and overlapping shells still
//! give a sensible solid. Every output tet has dihedral angles within about [10.7°, 164.8°];
//! boundary vertices lie on the input surface (cut points are exact ray/surface crossings).
//!
//! ```text
//! TriMesh ──► winding-number tree ──► BCC lattice labels ──► cut points ──► warp ──► stencils
//!        └──────────────────────────────────────────────────────────────► TetMesh + surface map
//! ```
//!
//! Size control: a target tet count (the spacing follows from the enclosed volume and the
//! surface area; one pass for closed surfaces, a second from the measured tet volume where the
//! signed volume misleads) or a lattice spacing.

mod frame;
mod lattice;
mod manifold;
mod octree;
mod stencil;
mod stuffing;
mod winding;

use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use crate::mesh::{QualityReport, SurfacePoint, TetMesh, TetMeshError, TriMesh, TriangleBvh};
use crate::progress::{ms, Cancelled, Progress};
use lattice::Lattice;
pub use stuffing::PhaseTimings;
pub use winding::{solid_angle, WindingNumber};

/// How fine the mesh should be.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MeshSize {
    /// About this many tetrahedra (the result is within ±10% when reachable, ±30% guaranteed
    /// by the tests).
    Tets(usize),
    /// Lattice spacing `h` in the mesh's units: the long (axis-aligned) lattice edge length; the
    /// short edges are `√3 h / 2`. Interior tets have volume `h³/12`.
    Spacing(f64),
}

/// How tet sizes vary through the solid.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Grading {
    /// One lattice spacing everywhere.
    Uniform,
    /// The finest spacing within two spacings of the surface; inwards, cube sizes double after
    /// `layers` cubes of each size (at least 1). The interior of a thick object then costs
    /// little, so a tet budget buys a finer surface.
    Graded { layers: u32 },
}

impl Grading {
    /// The grading of a layer count as the command line, scene files and the C ABI give it:
    /// 0 is [`Grading::Uniform`], N ≥ 1 is [`Grading::Graded`] with N cubes of each size.
    #[must_use]
    pub const fn from_layers(layers: u32) -> Self {
        match layers {
            0 => Grading::Uniform,
            layers => Grading::Graded { layers },
        }
    }
}

/// Options of [`tetrahedralize`].
#[derive(Debug, Clone, PartialEq)]
pub struct MesherOptions {
    /// Target size. With [`Grading::Graded`], a spacing is the finest (surface) spacing and a
    /// tet count the total.
    pub size: MeshSize,
    /// How sizes vary inside.
    pub grading: Grading,
    /// Largest lattice (vertex count) the mesher will allocate; protects against a spacing that
    /// is far too small for the object.
    pub max_lattice_vertices: usize,
}

impl Default for MesherOptions {
    fn default() -> Self {
        Self { size: MeshSize::Tets(200_000), grading: Grading::Uniform, max_lattice_vertices: 200_000_000 }
    }
}

impl MesherOptions {
    /// Options for about `tets` tetrahedra.
    #[must_use]
    pub fn with_tets(tets: usize) -> Self {
        Self { size: MeshSize::Tets(tets), ..Self::default() }
    }
}

/// Why meshing failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MesherError {
    /// The options are invalid.
    #[error("invalid mesher options: {0}")]
    InvalidOptions(String),
    /// The surface encloses no volume: no lattice point has a winding number of magnitude ½ or
    /// more (an open sheet, a flat surface, or a solid thinner than the lattice); `detail` says
    /// which was measured.
    #[error("the surface encloses no volume{detail}: no point has a winding number of magnitude 1/2 or more")]
    NoInterior { detail: String },
    /// The requested size needs a lattice larger than `max_lattice_vertices`.
    #[error("a lattice of {vertices} vertices would be needed (limit {limit}); ask for fewer tets or a larger spacing")]
    TooLarge { vertices: usize, limit: usize },
    /// The tets did not form a valid mesh (an internal error: please report it).
    #[error("internal meshing error: {0}")]
    Topology(#[from] TetMeshError),
    /// Cancelled through the progress callback.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// Two-sided Hausdorff distance between the tet boundary and the input surface, measured at
/// vertices (tet boundary vertices to the input triangles, input vertices to the boundary
/// triangles).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Hausdorff {
    /// Largest distance from a boundary vertex to the input surface.
    pub boundary_to_input: f64,
    /// Largest distance from an input vertex to the tet boundary.
    pub input_to_boundary: f64,
    /// The larger of the two.
    pub max: f64,
}

/// Milliseconds spent in each stage.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct MesherTimings {
    /// Building the winding-number hierarchy.
    pub winding_tree_ms: f64,
    /// Stuffing passes (labels, cuts, warping, stencils), all size passes together.
    pub stuffing_ms: f64,
    /// The phases of the pass that produced the mesh.
    pub final_pass: PhaseTimings,
    /// Building the tet topology.
    pub topology_ms: f64,
    /// Mapping user vertices to the boundary and measuring Hausdorff distances.
    pub mapping_ms: f64,
    /// Everything.
    pub total_ms: f64,
}

/// What [`tetrahedralize_with`] measured.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct MesherStats {
    /// Lattice spacing used (the finest, at the surface).
    pub spacing: f64,
    /// The grading asked for.
    pub grading: Grading,
    /// Cubes of side `2ᵏ · spacing` for k = 0, 1, … in the final octree: the size distribution.
    pub cubes_per_level: Vec<usize>,
    /// Stuffing passes run to reach the target count.
    pub passes: usize,
    /// Lattice vertices of the final pass (winding numbers evaluated).
    pub lattice_vertices: usize,
    /// Octrees the final pass built: 1, plus one per refinement where a coarse tet of a graded
    /// octree straddled the surface (through a hole of an open input); a refinement evaluates
    /// the winding numbers of its new vertices only.
    pub octree_rounds: usize,
    /// Vertices, tets and boundary triangles of the result.
    pub vertices: usize,
    pub tets: usize,
    pub boundary_faces: usize,
    /// Dihedral angles.
    pub quality: QualityReport,
    /// Distance between the tet boundary and the input.
    pub hausdorff: Hausdorff,
    /// Cut points placed by winding-number bisection because no surface crossed the edge (holes
    /// of open scans); these are not on the input surface.
    pub bisected_cuts: usize,
    /// Vertices duplicated to separate lobes of the solid that touched only along an edge or at
    /// a point (see `split_pinched_vertices`); the geometry is unchanged.
    pub split_vertices: usize,
    /// Tets added to close the gap where two lobes met along an edge (all their vertices are on
    /// the surface; each within the dihedral bounds).
    pub filled_tets: usize,
    /// Tets removed where two lobes met along an edge or at a vertex and splitting could not
    /// separate them (a few, on features thinner than the lattice).
    pub removed_tets: usize,
    /// Vertices exposed by those removals and moved onto the input surface.
    pub projected_vertices: usize,
    /// Vertices exposed by those removals that could not be moved onto the input surface
    /// within the dihedral bounds (the mesh of another lattice offset is taken when it has
    /// fewer).
    pub off_surface_vertices: usize,
    /// Stage timings.
    pub timings: MesherTimings,
}

/// A tet mesh with its statistics.
#[derive(Debug, Clone)]
pub struct Tetrahedralization {
    pub mesh: TetMesh,
    pub stats: MesherStats,
}

/// Fills the solid bounded by `surface` with quality tetrahedra; see the module docs.
///
/// # Errors
/// [`MesherError`] for invalid options, a surface that encloses nothing, or a lattice too large.
pub fn tetrahedralize(surface: &TriMesh, options: &MesherOptions) -> Result<TetMesh, MesherError> {
    tetrahedralize_with(surface, options, Progress::none()).map(|t| t.mesh)
}

/// [`tetrahedralize`] with progress reporting, cancellation and statistics.
///
/// # Errors
/// As [`tetrahedralize`], plus [`MesherError::Cancelled`].
pub fn tetrahedralize_with(
    surface: &TriMesh,
    options: &MesherOptions,
    progress: Progress,
) -> Result<Tetrahedralization, MesherError> {
    let start = Instant::now();
    let mut timings = MesherTimings::default();
    let user_surface = surface;
    let frame = frame::principal_frame(user_surface);
    let local = user_surface.transformed(&frame.world_to_local());
    let surface = &local;
    let (lo, hi) = surface.bounds();
    let extent = hi - lo;
    let diagonal = extent.length();
    if surface.triangles().is_empty() || !(diagonal > 0.0) {
        return Err(MesherError::NoInterior { detail: " (it has no area)".into() });
    }
    if extent.min_element() <= 1e-9 * diagonal {
        return Err(MesherError::NoInterior {
            detail: format!(" (it is flat: {:.3e} thick across a diagonal of {diagonal:.3e})", extent.min_element()),
        });
    }

    let t = Instant::now();
    let winding = WindingNumber::of_surface(surface.positions(), surface.triangles());
    timings.winding_tree_ms = ms(t);

    let t = Instant::now();
    let (stuffed, spacing, mut passes) = match options.size {
        MeshSize::Spacing(h) => {
            if !(h.is_finite() && h > 0.0) {
                return Err(MesherError::InvalidOptions(format!("spacing must be positive and finite, got {h}")));
            }
            (run_pass(&winding, lo, hi, h, 0, options, &progress)?, h, 1)
        }
        MeshSize::Tets(target) => {
            if target < 1 {
                return Err(MesherError::InvalidOptions("the target tet count must be at least 1".into()));
            }
            size_to_count(&winding, surface, lo, hi, target, options, &progress)?
        }
    };
    timings.stuffing_ms = ms(t);
    if stuffed.tets.is_empty() {
        return Err(MesherError::NoInterior {
            detail: format!(" at the lattice spacing {spacing:.3e} (an open sheet or thinner than that)"),
        });
    }

    // The manifold repair. Where it had to remove tets and could not move every vertex that
    // exposed onto the surface, even after removing the tets that blocked them (a closed input,
    // `manifold::repaired`), up to three other lattice offsets at the same spacing are tried
    // (one often needs no removal) and the mesh with the fewest such vertices, then the fewest
    // removals, is kept; not for an open input (cut points bisected across its holes), whose
    // boundary is off the input wherever the solid closes a hole. Trying offsets whenever a tet
    // was removed cost up to three more stuffings for no better quality (docs/benchmarks.md,
    // "Mesher: linear topology, cheap repair rounds").
    let t = Instant::now();
    let open = stuffed.bisected_cuts > 0;
    let mut best: Option<(TetMesh, manifold::Repair, PassFacts)> = None;
    let mut next = Some(stuffed);
    for variant in 0..=3u32 {
        let pass = match next.take() {
            Some(first) => first,
            None => {
                passes += 1;
                run_pass(&winding, lo, hi, spacing, variant, options, &progress)?
            }
        };
        let facts = PassFacts {
            bisected_cuts: pass.bisected_cuts,
            lattice_vertices: pass.lattice_vertices,
            octree_rounds: pass.octree_rounds,
            cubes_per_level: pass.leaves_per_level,
            timings: pass.timings,
        };
        let (mesh, repair) = manifold::repaired(pass.positions, pass.tets, pass.on_surface, winding.bvh(), !open)?;
        let rank = |r: &manifold::Repair| (r.off_surface_vertices, r.removed_tets);
        let clean = repair.off_surface_vertices == 0;
        if best.as_ref().is_none_or(|(_, kept, _)| rank(&repair) < rank(kept)) {
            best = Some((mesh, repair, facts));
        }
        if clean || open {
            break;
        }
    }
    let (mut mesh, repair, facts) = best.expect("the first offset is always repaired");
    timings.topology_ms = ms(t);
    progress.report("topology", 1.0)?;

    // Back to the user's coordinates (a rigid motion: shapes and quality are unchanged).
    let t = Instant::now();
    mesh = mesh.map_positions(|p| frame.to_world(p))?;
    let world_winding_bvh = TriangleBvh::from_indexed(user_surface.positions(), user_surface.triangles());
    let (map, hausdorff) = map_user_vertices(user_surface, &mesh, &world_winding_bvh);
    mesh.set_surface_map(map);
    timings.mapping_ms = ms(t);
    progress.report("surface map", 1.0)?;

    let quality = mesh.quality();
    timings.total_ms = ms(start);
    timings.final_pass = facts.timings;
    let stats = MesherStats {
        spacing,
        grading: options.grading,
        cubes_per_level: facts.cubes_per_level,
        passes,
        lattice_vertices: facts.lattice_vertices,
        octree_rounds: facts.octree_rounds,
        vertices: mesh.vertex_count(),
        tets: mesh.tet_count(),
        boundary_faces: mesh.boundary_faces().len(),
        quality,
        hausdorff,
        bisected_cuts: facts.bisected_cuts,
        split_vertices: repair.split_vertices,
        filled_tets: repair.filled_tets,
        removed_tets: repair.removed_tets,
        projected_vertices: repair.projected_vertices,
        off_surface_vertices: repair.off_surface_vertices,
        timings,
    };
    Ok(Tetrahedralization { mesh, stats })
}

/// What the mesh statistics keep of the stuffing pass that produced the mesh.
struct PassFacts {
    bisected_cuts: usize,
    lattice_vertices: usize,
    octree_rounds: usize,
    cubes_per_level: Vec<usize>,
    timings: PhaseTimings,
}

/// The BCC lattice of spacing `h` covering `[lo, hi]` with at least one and a half cells of
/// margin, so that every lattice vertex on the rim is outside. The origin is shifted by an
/// irrational fraction of `h` so that lattice planes do not coincide with the axis-aligned faces
/// of CAD models (a lattice vertex exactly on the surface has an ill-defined label).
///
/// `variant` picks another irrational shift, tried when the manifold repair of a lattice left
/// a boundary vertex off the surface.
fn lattice_for(lo: DVec3, hi: DVec3, h: f64, variant: u32) -> Lattice {
    const SHIFT: [f64; 3] = [0.118_033_988_749_895, 0.141_421_356_237_31, 0.173_205_080_756_89];
    const GOLDEN: f64 = 0.618_033_988_749_895;
    let shift = DVec3::from_array(SHIFT.map(|s| (s + f64::from(variant) * GOLDEN).fract()));
    let origin = lo - DVec3::splat(1.5 * h) - shift * h;
    let cells = ((hi - origin) / h + 1.5).ceil();
    Lattice { origin, h, n: [cells.x as usize, cells.y as usize, cells.z as usize] }
}

fn run_pass(
    winding: &WindingNumber,
    lo: DVec3,
    hi: DVec3,
    h: f64,
    variant: u32,
    options: &MesherOptions,
    progress: &Progress,
) -> Result<stuffing::Stuffed, MesherError> {
    let cells = ((hi - lo) / h + 4.0).ceil();
    let vertices = 2.0 * cells.x * cells.y * cells.z;
    if !(vertices <= options.max_lattice_vertices as f64) || vertices >= u32::MAX as f64 / 2.0 {
        return Err(MesherError::TooLarge { vertices: vertices as usize, limit: options.max_lattice_vertices });
    }
    let grading = match options.grading {
        Grading::Uniform => None,
        Grading::Graded { layers } => Some(layers.max(1) as usize),
    };
    Ok(stuffing::stuff(winding, &lattice_for(lo, hi, h, variant), grading, progress)?)
}

/// Extra tets that the boundary stencils add per `area / h²` of surface, measured on the closed
/// shared meshes at 30k–1M tets (1.6–2.3, mean 1.85).
const BOUNDARY_TETS_PER_AREA: f64 = 1.85;

/// The lattice spacing `h` at which a solid of volume `volume` and surface area `area` gives
/// about `target` tets: the root of `12 V / h³ + c A / h² = N` (interior tets have volume h³/12;
/// the boundary adds `c A / h²`), by Newton's method from the interior-only guess.
fn spacing_for_count(volume: f64, area: f64, target: f64) -> f64 {
    let mut h = (12.0 * volume / target).cbrt();
    for _ in 0..50 {
        let f = 12.0 * volume / h.powi(3) + BOUNDARY_TETS_PER_AREA * area / (h * h) - target;
        let df = -36.0 * volume / h.powi(4) - 2.0 * BOUNDARY_TETS_PER_AREA * area / h.powi(3);
        let next = (h - f / df).clamp(0.5 * h, 2.0 * h);
        if (next - h).abs() <= 1e-12 * h {
            break;
        }
        h = next;
    }
    h
}

/// How a graded octree's count exceeds the shell estimate as the spacing falls below the solid's
/// mean thickness `L = V / A`: `n h² / A ∝ (L / h)^p`, because the coarser levels reach less
/// deep than the geometric series assumes and every level's band is aligned to its own grid.
/// Fitted on the eight shared meshes at 100k–1M tets, graded with one cube per size (47 passes:
/// 7% RMS, most of it a per-mesh offset that the secant steps of [`size_to_count`] remove).
const GRADED_EXCESS_POWER: f64 = 0.435;
/// The thickness fraction `ρ` of that fit: `n = shell · (ρ L / h)^p`.
const GRADED_EXCESS_SCALE: f64 = 0.189;

/// The finest spacing at which a graded octree (`layers` cubes per size) over a solid of surface
/// area `area` and volume `volume` gives about `target` tets. The shell near the surface: cubes
/// within two spacings of it and `layers` more are finest (about `(2 + layers) h` of them inside),
/// each coarser level adds `layers` cubes whose tets are 8× fewer per volume for twice the
/// thickness (a geometric series summing to `layers / 3`), twelve tets per cube, plus the
/// boundary stencils'; times the measured excess `(ρ L / h)^p` ([`GRADED_EXCESS_POWER`]), so
/// `h^(2+p) = shell · A (ρ L)^p / n`.
fn graded_spacing_for_count(area: f64, volume: f64, layers: f64, target: f64) -> f64 {
    let per_area = 12.0 * (2.0 + layers + layers / 3.0) + BOUNDARY_TETS_PER_AREA;
    let thickness = volume / area;
    (per_area * area * (GRADED_EXCESS_SCALE * thickness).powf(GRADED_EXCESS_POWER) / target)
        .powf(1.0 / (2.0 + GRADED_EXCESS_POWER))
}

/// The volume a spacing estimate counts on: the surface's enclosed (signed) volume, or, where
/// that is under a thousandth of the box `[lo, hi]` (open sheets, inside-out halves), 0.3 of
/// the box.
fn solid_volume(surface: &TriMesh, lo: DVec3, hi: DVec3) -> f64 {
    let extent = hi - lo;
    let box_volume = extent.x * extent.y * extent.z;
    let volume = surface.signed_volume().abs();
    if volume > 1e-3 * box_volume {
        volume
    } else {
        0.3 * box_volume
    }
}

/// The lattice spacing (the surface's units) at which a uniform mesh of `surface` has about
/// `tets` tets, as the first pass of [`tetrahedralize`] estimates it from the enclosed volume
/// and the area (within about 10% of the spacing it settles on for closed surfaces): what a
/// caller choosing the grading before meshing compares with the medium's diffusion length.
#[must_use]
pub fn uniform_spacing_estimate(surface: &TriMesh, tets: usize) -> f64 {
    let (lo, hi) = surface.bounds();
    spacing_for_count(solid_volume(surface, lo, hi), surface.area(), tets.max(1) as f64)
}

/// Chooses the lattice spacing for about `target` tets from similarity invariants only — the
/// enclosed volume and the surface area — so that rotating, moving or scaling the input does not
/// change the spacing relative to the object (the count then varies only with the lattice's
/// alignment, about 1%). The signed volume is exact for closed surfaces; when the first pass
/// misses the target by more than 10% (open scans, overlapping shells: the winding-number solid
/// differs from the signed volume) the volume is re-measured from that pass's tets and the
/// spacing recomputed once more from the same formula (tet volume hardly depends on alignment).
///
/// A graded octree starts from the smaller of the uniform spacing and the shell estimate
/// ([`graded_spacing_for_count`]) and corrects it by the count's measured power law in `h`
/// (secant steps in log–log, from the estimate's `h^−(2+p)`).
fn size_to_count(
    winding: &WindingNumber,
    surface: &TriMesh,
    lo: DVec3,
    hi: DVec3,
    target: usize,
    options: &MesherOptions,
    progress: &Progress,
) -> Result<(stuffing::Stuffed, f64, usize), MesherError> {
    let area = surface.area();
    let volume = solid_volume(surface, lo, hi);
    let n = target as f64;
    let mut h = spacing_for_count(volume, area, n);
    let graded = matches!(options.grading, Grading::Graded { .. });
    if let Grading::Graded { layers } = options.grading {
        h = h.min(graded_spacing_for_count(area, volume, f64::from(layers.max(1)), n));
    }
    let mut previous: Option<(f64, f64)> = None;
    let mut passes = 0;
    loop {
        passes += 1;
        let stuffed = run_pass(winding, lo, hi, h, 0, options, progress)?;
        let count = stuffed.tets.len();
        if count == 0 {
            if passes >= 2 {
                return Err(MesherError::NoInterior {
                    detail: format!(" at the lattice spacing {h:.3e} (an open sheet or thinner than that)"),
                });
            }
            h *= 0.25;
            continue;
        }
        let max_passes = if graded { 4 } else { 3 };
        if (count as f64 / n - 1.0).abs() <= 0.1 || passes >= max_passes {
            return Ok((stuffed, h, passes));
        }
        if graded {
            let c = count as f64;
            let power = previous
                .map(|(h0, c0)| ((c / c0).ln() / (h0 / h).ln()).clamp(1.5, 3.0))
                .filter(|p| p.is_finite())
                .unwrap_or(2.0 + GRADED_EXCESS_POWER);
            previous = Some((h, c));
            h *= (c / n).powf(1.0 / power);
            continue;
        }
        // Summed in tet order, not by rayon's `sum` (whose grouping follows the work stealing):
        // the next spacing, and so the whole mesh, must not depend on the thread schedule.
        let volumes: Vec<f64> =
            stuffed.tets.par_iter().map(|t| crate::mesh::tet_volume(t.map(|v| stuffed.positions[v as usize])).abs()).collect();
        let measured: f64 = volumes.iter().sum();
        h = spacing_for_count(measured, area, n);
    }
}

/// For every user vertex, its closest point on the tet boundary; and the two-sided Hausdorff
/// distance measured at vertices.
pub(crate) fn map_user_vertices(surface: &TriMesh, mesh: &TetMesh, input: &TriangleBvh) -> (Vec<SurfacePoint>, Hausdorff) {
    let faces: Vec<[u32; 3]> = mesh.boundary_faces().iter().map(|f| f.vertices).collect();
    let boundary = TriangleBvh::from_indexed(mesh.positions(), &faces);
    let internal: Vec<SurfacePoint> =
        surface.positions().par_iter().map(|&p| boundary.closest_point(p).expect("a tet mesh has boundary faces")).collect();
    let input_to_boundary = internal.iter().map(|s| s.distance).fold(0.0, f64::max);
    let boundary_to_input = (0..mesh.vertex_count())
        .into_par_iter()
        .filter(|&v| mesh.is_boundary_vertex(v))
        .map(|v| input.closest_point(mesh.positions()[v]).map_or(0.0, |s| s.distance))
        .reduce(|| 0.0, f64::max);
    let map = surface.user_to_internal().iter().map(|&i| internal[i as usize]).collect();
    (map, Hausdorff { boundary_to_input, input_to_boundary, max: boundary_to_input.max(input_to_boundary) })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A closed, outward-oriented UV sphere as a `TriMesh` (shared with the polygrid's tests).
    pub(crate) fn uv_sphere(radius: f64, nu: usize, nv: usize) -> TriMesh {
        let mut positions = vec![DVec3::new(0.0, 0.0, radius)];
        for j in 1..nv {
            let th = std::f64::consts::PI * j as f64 / nv as f64;
            for i in 0..nu {
                let ph = 2.0 * std::f64::consts::PI * i as f64 / nu as f64;
                positions.push(radius * DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()));
            }
        }
        positions.push(DVec3::new(0.0, 0.0, -radius));
        let ring = |j: usize, i: usize| (1 + (j - 1) * nu + i % nu) as u32;
        let south = (positions.len() - 1) as u32;
        let mut triangles = Vec::new();
        for i in 0..nu {
            triangles.push([0, ring(1, i), ring(1, i + 1)]);
            triangles.push([south, ring(nv - 1, i + 1), ring(nv - 1, i)]);
        }
        for j in 1..nv - 1 {
            for i in 0..nu {
                triangles.push([ring(j, i), ring(j + 1, i), ring(j + 1, i + 1)]);
                triangles.push([ring(j, i), ring(j + 1, i + 1), ring(j, i + 1)]);
            }
        }
        let user_to_internal = (0..positions.len() as u32).collect();
        TriMesh { positions, triangles, user_to_internal, flipped_faces: 0 }
    }

    #[test]
    fn a_layer_count_of_zero_is_uniform() {
        assert_eq!(Grading::from_layers(0), Grading::Uniform);
        assert_eq!(Grading::from_layers(3), Grading::Graded { layers: 3 });
    }

    #[test]
    fn sphere_meshes_with_quality_and_fidelity() {
        let s = uv_sphere(10.0, 96, 48);
        assert!(s.signed_volume() > 0.0);
        let t = tetrahedralize_with(&s, &MesherOptions::with_tets(50_000), Progress::none()).unwrap();
        let st = &t.stats;
        eprintln!("{st:#?}");
        assert!(st.quality.min_dihedral_deg >= 10.0, "{}", st.quality.min_dihedral_deg);
        assert!(st.quality.max_dihedral_deg <= 165.0, "{}", st.quality.max_dihedral_deg);
        assert!((st.tets as f64 / 50_000.0 - 1.0).abs() < 0.3);
        assert!(st.hausdorff.boundary_to_input <= 0.01 * st.spacing);
        let v = t.mesh.volume();
        assert!((v / s.signed_volume() - 1.0).abs() < 0.02, "{v}");
    }
}
