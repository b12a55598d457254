//! Baking a scene: every object meshed, lit, solved and sampled at its user's vertices.

use std::time::Instant;

use super::{Object, Scene, Shape};
use crate::diffusion::{self, DiffusionError};
use crate::gpu::{self, Backend, GpuError};
use crate::light::{self, LightError, SourceOptions};
use crate::mesh::{TetMesh, TetMeshError, TriangleBvh};
use crate::mesher::{self, MesherError, MesherOptions, MesherStats};
use crate::optics::Medium;
use crate::progress::{Cancelled, Progress};
use crate::sparse::{SolveOptions, SparseError};
use crate::volume::VolumeError;

/// How to bake.
#[derive(Debug, Clone, PartialEq)]
pub struct BakeOptions {
    /// Target tetrahedra per object.
    pub tets: usize,
    /// Relative residual ‖b − Mφ‖/‖b‖ at which the solve stops.
    pub tolerance: f64,
    /// Iteration cap of the solver.
    pub max_iterations: usize,
    /// Worker threads (0 = all cores).
    pub threads: usize,
    /// Sampling of area and environment lights and shadow rays.
    pub source: SourceOptions,
    /// Whether objects shadow themselves and each other.
    pub shadows: bool,
    /// Where the solve runs; `None`: as `TRANSCUT_BACKEND` says (cpu, gpu, auto), else
    /// [`Backend::Auto`] (the GPU when a hardware adapter exists, else the CPU; the statistics
    /// say which ran and why).
    pub backend: Option<Backend>,
}

impl Default for BakeOptions {
    fn default() -> Self {
        Self {
            tets: 200_000,
            tolerance: 1e-6,
            max_iterations: 10_000,
            threads: 0,
            source: SourceOptions::default(),
            shadows: true,
            backend: None,
        }
    }
}

/// Why a bake failed. Every variant names the object (index and name) where one is at fault.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneError {
    /// The scene has no objects.
    #[error("the scene has no objects")]
    NoObjects,
    /// A bake option is out of range.
    #[error("invalid bake option: {0}")]
    InvalidOptions(String),
    /// An object's own parameters are invalid.
    #[error("object {index} ({name}): {message}")]
    InvalidObject { index: usize, name: String, message: String },
    /// An object's heterogeneous medium could not be put on its tets.
    #[error("object {index} ({name}): medium: {source}")]
    Medium {
        index: usize,
        name: String,
        #[source]
        source: VolumeError,
    },
    /// Meshing an object failed.
    #[error("object {index} ({name}): meshing failed: {source}")]
    Mesher {
        index: usize,
        name: String,
        #[source]
        source: MesherError,
    },
    /// A light is invalid or the source could not be computed.
    #[error("lights: {0}")]
    Light(#[from] LightError),
    /// Assembly or solve failed for an object.
    #[error("object {index} ({name}): {source}")]
    Diffusion {
        index: usize,
        name: String,
        #[source]
        source: DiffusionError,
    },
    /// The GPU was required (`Backend::Gpu`) and could not be used, or failed.
    #[error("object {index} ({name}): GPU backend: {source}")]
    Gpu {
        index: usize,
        name: String,
        #[source]
        source: GpuError,
    },
    /// Cancelled through the progress callback.
    #[error(transparent)]
    Cancelled(#[from] Cancelled),
}

/// What was measured for one object.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ObjectStats {
    pub tets: usize,
    pub vertices: usize,
    pub boundary_vertices: usize,
    /// Solver iterations per channel.
    pub iterations: [usize; 3],
    /// Final relative residual per channel.
    pub relative_residual: [f64; 3],
    /// Vertices whose diffusion radiance was negative and clamped to zero.
    pub clamped_vertices: usize,
    pub meshing_ms: f64,
    pub assembly_ms: f64,
    pub source_ms: f64,
    pub solve_ms: f64,
    pub total_ms: f64,
    /// The backend the solve ran on (`cpu` or `gpu`).
    pub backend: Backend,
    /// The GPU adapter's name when the GPU ran.
    pub device: Option<String>,
    /// Why `auto` solved on the CPU, when it did.
    pub backend_fallback: Option<String>,
    /// The mesher's own statistics (`None` for an object given as a ready tet mesh).
    pub meshing: Option<MesherStats>,
}

/// One object's result.
#[derive(Debug, Clone)]
pub struct ObjectBake {
    /// Lo(x, n), linear RGB, one per vertex of the object's input mesh, in the user's order
    /// (for a ready tet mesh: one per tet-mesh vertex, 0 inside).
    pub radiance: Vec<[f64; 3]>,
    /// The tet mesh the object was solved on (world space), its material ids indexing `media`.
    pub tet_mesh: TetMesh,
    /// The media table the system was assembled with (`diffusion::assemble(&tet_mesh, &media,
    /// mm_per_unit)` rebuilds it).
    pub media: Vec<Medium>,
    /// Refractive index at the object's surface (one per object), for renderers' specular.
    pub eta: f64,
    /// The fluence φ at every tet-mesh vertex (a warm start for later solves).
    pub fluence: Vec<[f64; 3]>,
    pub stats: ObjectStats,
}

/// The result of [`bake`]: one entry per object, in scene order.
#[derive(Debug, Clone)]
pub struct Bake {
    pub objects: Vec<ObjectBake>,
    /// Wall time of the whole bake.
    pub total_ms: f64,
}

/// Bakes per-vertex radiance for every object of `scene`.
///
/// # Errors
/// [`SceneError`] naming the object or light at fault.
pub fn bake(scene: &Scene, options: &BakeOptions) -> Result<Bake, SceneError> {
    bake_with(scene, options, Progress::none())
}

/// [`bake`] with progress reporting and cancellation: stages named `"<object>: <stage>"`,
/// fractions of the whole bake that never decrease and end at 1; the callback returning
/// `false` cancels at the next check (during meshing, between stages, or at a solver
/// iteration).
///
/// # Errors
/// As [`bake`], plus [`SceneError::Cancelled`].
pub fn bake_with(scene: &Scene, options: &BakeOptions, progress: Progress) -> Result<Bake, SceneError> {
    validate(scene, options)?;
    let backend = match options.backend {
        Some(b) => b,
        None => Backend::from_env_or(Backend::Auto).map_err(|e| SceneError::InvalidOptions(e.to_string()))?,
    };
    let options = &BakeOptions { backend: Some(backend), ..options.clone() };
    if options.threads > 0 {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(options.threads)
            .build()
            .map_err(|e| SceneError::InvalidOptions(format!("cannot start {} threads: {e}", options.threads)))?;
        pool.install(|| bake_all(scene, options, progress))
    } else {
        bake_all(scene, options, progress)
    }
}

fn validate(scene: &Scene, options: &BakeOptions) -> Result<(), SceneError> {
    if scene.objects.is_empty() {
        return Err(SceneError::NoObjects);
    }
    if options.tets == 0 {
        return Err(SceneError::InvalidOptions("tets must be at least 1".into()));
    }
    if !(options.tolerance > 0.0 && options.tolerance < 1.0) {
        return Err(SceneError::InvalidOptions(format!("tolerance must lie in (0, 1), got {}", options.tolerance)));
    }
    if options.max_iterations == 0 {
        return Err(SceneError::InvalidOptions("max_iterations must be at least 1".into()));
    }
    for (index, o) in scene.objects.iter().enumerate() {
        let bad = |message: String| SceneError::InvalidObject { index, name: o.name.clone(), message };
        if !(o.mm_per_unit.is_finite() && o.mm_per_unit > 0.0) {
            return Err(bad(format!("mm_per_unit must be positive and finite, got {}", o.mm_per_unit)));
        }
        if !o.transform.is_finite() || o.transform.determinant().abs() < 1e-300 {
            return Err(bad("the transform is singular or not finite".into()));
        }
        o.medium.validate(&o.shape).map_err(bad)?;
    }
    light::validate_lights(&scene.lights)?;
    Ok(())
}

fn bake_all(scene: &Scene, options: &BakeOptions, progress: Progress) -> Result<Bake, SceneError> {
    let start = Instant::now();
    let n = scene.objects.len() as f64;
    // World-space surfaces: they are meshed, and together they shadow.
    let world = scene
        .objects
        .iter()
        .enumerate()
        .map(|(index, o)| {
            o.world_surface().map_err(|e| SceneError::InvalidObject { index, name: o.name.clone(), message: e.to_string() })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let occluder = options.shadows.then(|| {
        let corners = world.iter().flat_map(|m| (0..m.triangles().len()).map(move |t| m.triangle(t))).collect();
        TriangleBvh::new(corners)
    });
    let mut objects = Vec::with_capacity(scene.objects.len());
    // The furthest fraction reported, held while reporting so that reports from parallel tasks
    // reach the callback in increasing order.
    let furthest = std::sync::Mutex::new(0.0f64);
    for (index, (object, surface)) in scene.objects.iter().zip(&world).enumerate() {
        let name = || object.name.clone();
        let t0 = Instant::now();
        // Reported fractions never decrease (a second mesher pass, a CG residual going up).
        let stage = |s: &str, f: f64| {
            let f = ((index as f64 + f) / n).clamp(0.0, 1.0);
            let mut furthest = furthest.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            *furthest = furthest.max(f);
            progress.report(&format!("{}: {s}", object.name), *furthest)
        };
        let (mut tet_mesh, meshing) = world_tets(object, surface, options, &stage).map_err(|e| e.at(index, name()))?;
        let meshing_ms = ms(t0);
        stage("assembly", 0.6)?;

        let t = Instant::now();
        let to_object = object.transform.inverse();
        let media = object.medium.apply(&mut tet_mesh, &to_object, object.mm_per_unit).map_err(|source| SceneError::Medium {
            index,
            name: name(),
            source,
        })?;
        let diffusion_error = |source| SceneError::Diffusion { index, name: name(), source };
        let mut system = diffusion::assemble(&tet_mesh, &media, object.mm_per_unit).map_err(diffusion_error)?;
        let assembly_ms = ms(t);
        stage("light", 0.7)?;

        let t = Instant::now();
        let boundary = system.boundary();
        let points: Vec<_> = boundary.ids.iter().map(|&v| tet_mesh.positions()[v as usize]).collect();
        let eta = system.boundary_terms().eta;
        let q = light::transmitted_source(&scene.lights, &points, &boundary.normal, eta, occluder.as_ref(), &options.source)?;
        system.set_source(&q).map_err(diffusion_error)?;
        let source_ms = ms(t);
        stage("solve", 0.8)?;

        let t = Instant::now();
        // Progress through the solve: the residual's way from 1 down to the tolerance, in decades.
        let decades = -options.tolerance.log10();
        let monitor = |_: usize, residual: [f64; 3]| {
            let worst = residual.iter().fold(0.0f64, |m, &r| m.max(r)).max(options.tolerance);
            stage("solve", 0.8 + 0.19 * (-worst.log10() / decades).clamp(0.0, 1.0)).is_ok()
        };
        let solve_options =
            SolveOptions { tolerance: options.tolerance, max_iterations: options.max_iterations, ..SolveOptions::default() }
                .with_monitor(&monitor);
        let (solution, report) =
            gpu::solve_on(options.backend.unwrap_or_default(), &system, None, &solve_options).map_err(|e| match e {
                GpuError::Diffusion(DiffusionError::Sparse(SparseError::Cancelled { .. })) => SceneError::Cancelled(Cancelled),
                GpuError::Diffusion(source) => diffusion_error(source),
                source => SceneError::Gpu { index, name: name(), source },
            })?;
        let lo = diffusion::surface_radiance(&system, &solution.phi).map_err(diffusion_error)?;
        let solve_ms = ms(t);

        // Per tet-mesh vertex (boundary entries only), clamped, then at the user's vertices.
        let mut per_vertex = vec![[0.0; 3]; tet_mesh.vertex_count()];
        let mut clamped = 0;
        for (&v, l) in system.boundary().ids.iter().zip(&lo) {
            if l.iter().any(|&x| x < 0.0) {
                clamped += 1;
            }
            per_vertex[v as usize] = l.map(|x| x.max(0.0));
        }
        let radiance = match object.shape {
            Shape::Surface(_) => tet_mesh.sample_at_user_vertices(&per_vertex),
            Shape::Tetrahedra(_) => per_vertex,
        };
        let stats = ObjectStats {
            tets: tet_mesh.tet_count(),
            vertices: tet_mesh.vertex_count(),
            boundary_vertices: system.boundary().len(),
            iterations: solution.stats.iterations,
            relative_residual: solution.stats.relative_residual,
            clamped_vertices: clamped,
            meshing_ms,
            assembly_ms,
            source_ms,
            solve_ms,
            total_ms: ms(t0),
            backend: report.used,
            device: report.device,
            backend_fallback: report.fallback,
            meshing,
        };
        objects.push(ObjectBake { radiance, tet_mesh, media, eta, fluence: solution.phi, stats });
        stage("done", 1.0)?;
    }
    Ok(Bake { objects, total_ms: ms(start) })
}

/// Why an object's world-space tet mesh could not be made (the object is named by the caller).
enum TetsError {
    Mesher(MesherError),
    Transform(TetMeshError),
}

impl TetsError {
    fn at(self, index: usize, name: String) -> SceneError {
        match self {
            Self::Mesher(MesherError::Cancelled(c)) => SceneError::Cancelled(c),
            Self::Mesher(source) => SceneError::Mesher { index, name, source },
            Self::Transform(e) => {
                SceneError::InvalidObject { index, name, message: format!("the transformed tet mesh is invalid: {e}") }
            }
        }
    }
}

/// How far the meshing is when mesher stage `stage` is `f` done: the stages' shares of the time
/// measured on the shared meshes (winding numbers about half, stencils a quarter).
fn mesher_fraction(stage: &str, f: f64) -> f64 {
    let (start, end) = match stage {
        "winding numbers" => (0.0, 0.5),
        "cut points" => (0.5, 0.6),
        "warping" => (0.6, 0.65),
        "stencils" => (0.65, 0.9),
        "topology" => (0.9, 0.95),
        _ => (0.95, 1.0),
    };
    start + (end - start) * f.clamp(0.0, 1.0)
}

/// The object's tets in world space: its surface meshed (progress 0 → 0.6 of the object), or its
/// ready tet mesh transformed.
fn world_tets(
    object: &Object,
    surface: &crate::mesh::TriMesh,
    options: &BakeOptions,
    stage: &(dyn Fn(&str, f64) -> Result<(), crate::progress::Cancelled> + Sync),
) -> Result<(TetMesh, Option<MesherStats>), TetsError> {
    match &object.shape {
        Shape::Surface(_) => {
            // The mesher reports each of its stages from 0 to 1: one fraction of the meshing.
            let mesh_progress = |s: &str, f: f64| stage(s, 0.6 * mesher_fraction(s, f)).is_ok();
            let meshed =
                mesher::tetrahedralize_with(surface, &MesherOptions::with_tets(options.tets), Progress::new(&mesh_progress))
                    .map_err(TetsError::Mesher)?;
            Ok((meshed.mesh, Some(meshed.stats)))
        }
        Shape::Tetrahedra(mesh) => {
            let m = object.transform;
            let world = mesh.clone().map_positions(move |p| m.transform_point3(p)).map_err(TetsError::Transform)?;
            Ok((world, None))
        }
    }
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}
