//! TransCut (Li et al. 2012, §3) behind the method contract: each object's surface filled with
//! quality tetrahedra, the diffusion system M φ = b of eqs. 10–14 assembled on them, solved on
//! the CPU or the GPU, and eq. 3 read at the user's vertices.
//!
//! - `prepare`: tetrahedralise a surface ([`crate::mesher`]; a ready tet mesh is only moved to
//!   world space), put the medium on the tets ([`crate::scene::MediumSource`]) and assemble M
//!   ([`crate::diffusion::assemble`]), after checking the method's validity limit: the mesh
//!   must resolve the medium's diffusion length at the surface ([`MAX_RESOLUTION`], twice it
//!   for the default assembly: [`crate::diffusion::max_resolution`]);
//! - `solve`: q at the boundary vertices ([`super::Lighting`]), the solve
//!   ([`crate::gpu::solve_on`] with [`TransCutOptions::solver`]), Lo(x, n) at the boundary
//!   ([`crate::diffusion::surface_radiance`]), clamped at 0 and interpolated at the user's
//!   vertices through the tet mesh's surface map.
//!
//! The state kept after the bake ([`TransCutState`]) is what the editor
//! ([`crate::edit::Editor::from_bake`]) starts from: the tet mesh, its media and the fluence.
//! The capabilities (relight, medium edits and paint, cuts) are the editor's (TransCut §5,
//! [`capabilities`]).

mod capabilities;
mod editor;
mod meshed;

pub use meshed::Meshed;
pub(crate) use meshed::Reuse;

pub use crate::diffusion::MAX_RESOLUTION;

use std::sync::Arc;
use std::time::Instant;

use super::{BakedState, Lighting, ObjectStats, Stage, SubsurfaceMethod, Target};
use crate::diffusion::{self, resolution, DiffusionError, DiffusionSystem, Discretization};
use crate::gpu::{self, Backend, GpuError, SolveWith};
use crate::mesh::{TetMesh, TetMeshError};
use crate::mesher::{self, MesherError, MesherOptions};
use crate::optics::Medium;
use crate::progress::{ms, solve_fraction, Cancelled, Progress};
use crate::scene::{MediumSource, SceneError, Shape, TransCutOptions};
use crate::sparse::{SolveOptions, SparseError};

/// The TransCut method ([`SubsurfaceMethod`]).
pub struct TransCut;

/// What a TransCut bake keeps of one object ([`super::ObjectBake::state`]).
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct TransCutState {
    /// The tet mesh the object was solved on (world space), its material ids indexing `media`.
    pub tet_mesh: TetMesh,
    /// The media table the system was assembled with (`diffusion::assemble(&tet_mesh, &media,
    /// mm_per_unit)` rebuilds it).
    pub media: Vec<Medium>,
    /// Millimetres per scene unit of the object.
    pub mm_per_unit: f64,
    /// The refractive index at the surface.
    pub eta: f64,
    /// The fluence φ at every tet-mesh vertex (a warm start for later solves).
    pub fluence: Vec<[f64; 3]>,
    /// Lo(x, n) of eq. 3, clamped at 0, at every tet-mesh vertex (0 inside): the field the
    /// user's vertices, and a texture's texels, are sampled from.
    pub radiance: Vec<[f64; 3]>,
    /// The tet mesh as the mesher made it, kept for later bakes of the same surface when the
    /// bake was asked to keep its meshes ([`crate::bake::bake_reusing`]); `None` otherwise and
    /// for a ready tet mesh.
    pub meshed: Option<Arc<Meshed>>,
}

/// TransCut between `prepare` and the end of the bake: the state and the assembled system.
#[derive(Debug, Clone)]
pub(crate) struct Prepared {
    tet_mesh: TetMesh,
    media: Vec<Medium>,
    system: DiffusionSystem,
    fluence: Vec<[f64; 3]>,
    meshed: Option<Arc<Meshed>>,
}

impl Prepared {
    /// The assembled system (its boundary vertices in [`DiffusionSystem::boundary`] order).
    pub(crate) fn system(&self) -> &DiffusionSystem {
        &self.system
    }

    /// The tet mesh solved on (world space).
    pub(crate) fn tet_mesh(&self) -> &TetMesh {
        &self.tet_mesh
    }

    /// Solves M φ = b for the source `q` per boundary vertex, warm-started from the last φ,
    /// keeping φ: the diffusion solve of TransCut's bake alone, shared with the radiosity
    /// method's scattering (whose Krylov iteration scatters sources of either sign). Fills the solve's statistics into `stats`.
    ///
    /// # Errors
    /// [`SceneError`] naming the object; [`SceneError::Cancelled`] through `stage`.
    pub(crate) fn solve_fluence(
        &mut self,
        target: &Target<'_>,
        q: &[[f64; 3]],
        options: &TransCutOptions,
        stats: &mut ObjectStats,
        stage: Stage<'_>,
    ) -> Result<(), SceneError> {
        let (index, name) = (target.index, || target.object.name.clone());
        let diffusion_error = |source| SceneError::Diffusion { index, name: name(), source };
        self.system.set_signed_source(q).map_err(diffusion_error)?;
        stage("solve", 0.8)?;
        // Progress through the solve: the residual's way from 1 down to the tolerance, in decades.
        let monitor =
            |_: usize, residual: [f64; 3]| stage("solve", 0.8 + 0.19 * solve_fraction(residual, options.tolerance)).is_ok();
        let solve_options =
            SolveOptions { tolerance: options.tolerance, max_iterations: options.max_iterations, ..SolveOptions::default() }
                .with_monitor(&monitor);
        let backend = backend(options).map_err(|e| target.invalid(e.to_string()))?;
        let warm = self.fluence.iter().any(|p| p.iter().any(|&x| x != 0.0)).then_some(self.fluence.as_slice());
        let (solution, report) = gpu::solve_on(backend, SolveWith::Kind(options.solver), &self.system, warm, &solve_options)
            .map_err(|e| match e {
                GpuError::Diffusion(DiffusionError::Sparse(SparseError::Cancelled { .. })) => SceneError::Cancelled(Cancelled),
                GpuError::Diffusion(source) => diffusion_error(source),
                source => SceneError::Gpu { index, name: name(), source },
            })?;
        stats.iterations = solution.stats.iterations;
        stats.relative_residual = solution.stats.relative_residual;
        stats.backend = report.used;
        stats.device = report.device;
        stats.backend_fallback = report.fallback;
        self.fluence = solution.phi;
        Ok(())
    }

    /// TransCut's eq. 3 along the normal at every boundary vertex, from the last solve, not
    /// clamped ([`crate::diffusion::surface_radiance`]).
    ///
    /// # Errors
    /// [`SceneError::Diffusion`] for a non-finite fluence.
    pub(crate) fn boundary_radiance(&self, target: &Target<'_>) -> Result<Vec<[f64; 3]>, SceneError> {
        diffusion::surface_radiance(&self.system, &self.fluence).map_err(|source| SceneError::Diffusion {
            index: target.index,
            name: target.object.name.clone(),
            source,
        })
    }

    /// The fluence φ of the last solve (zero before the first).
    pub(crate) fn fluence(&self) -> &[[f64; 3]] {
        &self.fluence
    }

    /// Puts back a solution: the source `q` per boundary vertex and its fluence φ per vertex
    /// (a sum of solutions is one: the system is linear). `q` may be negative in places: the
    /// exitance B = (φ − 2q)/(2A) that the radiosity gathers is, where a strongly absorbing
    /// channel is lit (as TransCut's eq. 3 there).
    ///
    /// # Errors
    /// [`DiffusionError`] for a `q` of another length or not finite; nothing changed.
    pub(crate) fn set_solution(&mut self, q: &[[f64; 3]], fluence: Vec<[f64; 3]>) -> Result<(), DiffusionError> {
        if fluence.len() != self.fluence.len() {
            return Err(DiffusionError::LengthMismatch { what: "fluence", expected: self.fluence.len(), found: fluence.len() });
        }
        self.system.set_signed_source(q)?;
        self.fluence = fluence;
        Ok(())
    }

    /// The object with a new medium on the same tets: `medium` put on the tet mesh and the
    /// system assembled again (the fluence kept as a warm start), after the resolution check of
    /// a bake, filling `stats`' resolution and assembly time.
    ///
    /// # Errors
    /// [`SceneError::Medium`], [`SceneError::Unresolved`] or [`SceneError::Diffusion`] naming
    /// the object; `self` is not changed.
    pub(crate) fn with_medium(
        &self,
        target: &Target<'_>,
        medium: &MediumSource,
        stats: &mut ObjectStats,
    ) -> Result<Self, SceneError> {
        let (index, object) = (target.index, target.object);
        let name = || object.name.clone();
        let t = Instant::now();
        let mut tet_mesh = self.tet_mesh.clone();
        let media = medium
            .apply(&mut tet_mesh, &object.transform.inverse(), object.mm_per_unit)
            .map_err(|source| SceneError::Medium { index, name: name(), source })?;
        let discretization = self.system.discretization();
        let (checked, verdict) =
            resolution::surface_resolution(&tet_mesh, &media, object.mm_per_unit, resolution::max_resolution(discretization));
        verdict.map_err(|u| SceneError::unresolved(index, name(), u))?;
        let mut system = DiffusionSystem::new(&tet_mesh, &media, object.mm_per_unit, discretization)
            .map_err(|source| SceneError::Diffusion { index, name: name(), source })?;
        system.set_signed_source(self.system.source()).map_err(|source| SceneError::Diffusion { index, name: name(), source })?;
        stats.resolution = checked;
        stats.assembly_ms = ms(t);
        Ok(Self { tet_mesh, media, system, fluence: self.fluence.clone(), meshed: self.meshed.clone() })
    }

    /// The object's medium put on `tet_mesh` (world space) and M assembled, after the
    /// method's resolution check, filling `stats`' resolution, assembly time and counts: the
    /// light-independent part of TransCut on any tet mesh (the polygrid's Kuhn split too).
    ///
    /// # Errors
    /// [`SceneError::Medium`], [`SceneError::Unresolved`] or [`SceneError::Diffusion`] naming
    /// the object.
    pub(crate) fn from_tets(
        target: &Target<'_>,
        mut tet_mesh: TetMesh,
        meshed: Option<Arc<Meshed>>,
        discretization: Discretization,
        stats: &mut ObjectStats,
    ) -> Result<Self, SceneError> {
        let (index, object) = (target.index, target.object);
        let name = || object.name.clone();
        let t = Instant::now();
        let to_object = object.transform.inverse();
        let media = target
            .medium(stats.method)?
            .apply(&mut tet_mesh, &to_object, object.mm_per_unit)
            .map_err(|source| SceneError::Medium { index, name: name(), source })?;
        let (measured, verdict) =
            resolution::surface_resolution(&tet_mesh, &media, object.mm_per_unit, resolution::max_resolution(discretization));
        stats.resolution = measured;
        verdict.map_err(|u| SceneError::unresolved(index, name(), u))?;
        let system = DiffusionSystem::new(&tet_mesh, &media, object.mm_per_unit, discretization)
            .map_err(|source| SceneError::Diffusion { index, name: name(), source })?;
        stats.assembly_ms = ms(t);
        stats.tets = tet_mesh.tet_count();
        stats.vertices = tet_mesh.vertex_count();
        stats.boundary_vertices = system.boundary().len();
        let fluence = vec![[0.0; 3]; tet_mesh.vertex_count()];
        Ok(Prepared { tet_mesh, media, system, fluence, meshed })
    }

    /// The source q under `lighting` at the boundary vertices, then [`Prepared::solve_source`]:
    /// TransCut's solve step (the polygrid's FEM path too), timing the source into `stats`.
    ///
    /// # Errors
    /// As [`Prepared::solve_source`]; [`SceneError::Cancelled`] through `stage`.
    pub(crate) fn solve_lit(
        &mut self,
        target: &Target<'_>,
        lighting: &Lighting<'_>,
        options: &TransCutOptions,
        stats: &mut ObjectStats,
        stage: Stage<'_>,
    ) -> Result<Vec<[f64; 3]>, SceneError> {
        stage("light", 0.7)?;
        let t = Instant::now();
        let q = {
            let Prepared { tet_mesh, system, .. } = &*self;
            let boundary = system.boundary();
            let points: Vec<_> = boundary.ids.iter().map(|&v| tet_mesh.positions()[v as usize]).collect();
            lighting.transmitted_source_with(&points, &boundary.normal, system.boundary_terms().eta, &|f| {
                stage("light", 0.7 + 0.1 * f)
            })?
        };
        stats.source_ms = ms(t);
        let radiance = self.solve_source(target, &q, options, stats, stage)?;
        Ok(radiance)
    }

    /// The state a bake keeps ([`TransCutState`]).
    pub(crate) fn into_state(self) -> TransCutState {
        // A fluence that is not finite failed the bake before its state was kept.
        let lo = diffusion::surface_radiance(&self.system, &self.fluence).unwrap_or_default();
        let radiance = if lo.is_empty() {
            vec![[0.0; 3]; self.tet_mesh.vertex_count()]
        } else {
            per_vertex_radiance(&self.tet_mesh, &self.system, &lo)
        };
        let Self { tet_mesh, media, system, fluence, meshed } = self;
        TransCutState {
            tet_mesh,
            media,
            mm_per_unit: system.mm_per_unit(),
            eta: system.boundary_terms().eta,
            fluence,
            radiance,
            meshed,
        }
    }

    /// The exitance B = (φ − 2q)/(2A) at every boundary vertex (the integral of eq. 3 over the
    /// hemisphere, [`crate::diffusion::EnergyBalance::exitant`]) of the last solve.
    pub(crate) fn exitance(&self) -> Vec<[f64; 3]> {
        let a = self.system.boundary_terms().a;
        let q = self.system.source();
        let ids = &self.system.boundary().ids;
        ids.iter().zip(q).map(|(&v, q)| std::array::from_fn(|c| (self.fluence[v as usize][c] - 2.0 * q[c]) / (2.0 * a))).collect()
    }

    /// The bake's radiance after [`Prepared::solve_fluence`]: Lo(x, n) of eq. 3 at the boundary,
    /// clamped at 0 and interpolated at the user's vertices (or per tet-mesh vertex for a ready
    /// tet mesh), counting the clamped vertices into `stats`.
    ///
    /// # Errors
    /// [`SceneError::Diffusion`] for a non-finite fluence.
    pub(crate) fn user_radiance(&self, target: &Target<'_>, stats: &mut ObjectStats) -> Result<Vec<[f64; 3]>, SceneError> {
        let lo = self.boundary_radiance(target)?;
        let Self { tet_mesh, system, .. } = self;
        // Per tet-mesh vertex (boundary entries only), clamped, then at the user's vertices.
        let per_vertex = per_vertex_radiance(tet_mesh, system, &lo);
        let mut clamped = vec![[0.0]; tet_mesh.vertex_count()];
        for (&v, l) in system.boundary().ids.iter().zip(&lo) {
            if l.iter().any(|&x| x < 0.0) {
                clamped[v as usize] = [1.0];
            }
        }
        stats.clamped_vertices = match target.object.shape {
            Shape::Surface(_) => clamped_user_vertices(tet_mesh, &clamped),
            Shape::Tetrahedra(_) => clamped.iter().filter(|c| c[0] > 0.0).count(),
        };
        Ok(match target.object.shape {
            Shape::Surface(_) => tet_mesh.sample_at_user_vertices(&per_vertex),
            Shape::Tetrahedra(_) => per_vertex,
        })
    }

    /// [`Prepared::solve_fluence`] then [`Prepared::user_radiance`], timed into `stats.solve_ms`.
    ///
    /// # Errors
    /// As the two.
    pub(crate) fn solve_source(
        &mut self,
        target: &Target<'_>,
        q: &[[f64; 3]],
        options: &TransCutOptions,
        stats: &mut ObjectStats,
        stage: Stage<'_>,
    ) -> Result<Vec<[f64; 3]>, SceneError> {
        let t = Instant::now();
        self.solve_fluence(target, q, options, stats, stage)?;
        let radiance = self.user_radiance(target, stats)?;
        stats.solve_ms = ms(t);
        Ok(radiance)
    }
}

impl SubsurfaceMethod for TransCut {
    type Options = TransCutOptions;
    type State = Prepared;

    /// TransCut bakes every shape and medium (diffuse objects are refused,
    /// [`Target::medium`]); only its options and the backend named by `TRANSCUT_BACKEND` are
    /// checked.
    fn check(target: &Target<'_>, options: &TransCutOptions) -> Result<(), SceneError> {
        target.medium("transcut")?;
        backend(options).map(|_| ()).map_err(|e| target.invalid(e.to_string()))
    }

    fn prepare(
        target: &Target<'_>,
        options: &TransCutOptions,
        stats: &mut ObjectStats,
        stage: Stage<'_>,
    ) -> Result<Prepared, SceneError> {
        let (index, object) = (target.index, target.object);
        let name = || object.name.clone();
        let t = Instant::now();
        let (tet_mesh, meshed) = world_tets(target, options, stats, stage).map_err(|e| e.at(index, name()))?;
        stats.meshing_ms = ms(t);
        stage("assembly", 0.6)?;

        Prepared::from_tets(target, tet_mesh, meshed, options.discretization, stats)
    }

    fn solve(
        target: &Target<'_>,
        state: &mut Prepared,
        lighting: &Lighting<'_>,
        options: &TransCutOptions,
        stats: &mut ObjectStats,
        stage: Stage<'_>,
    ) -> Result<Vec<[f64; 3]>, SceneError> {
        state.solve_lit(target, lighting, options, stats, stage)
    }

    fn into_baked(state: Prepared) -> BakedState {
        BakedState::TransCut(state.into_state())
    }
}

/// Eq. 3's radiance `lo` per boundary entry of `system`, clamped at 0, per tet-mesh vertex
/// (0 inside).
fn per_vertex_radiance(tet_mesh: &TetMesh, system: &DiffusionSystem, lo: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let mut per_vertex = vec![[0.0; 3]; tet_mesh.vertex_count()];
    for (&v, l) in system.boundary().ids.iter().zip(lo) {
        per_vertex[v as usize] = l.map(|x| x.max(0.0));
    }
    per_vertex
}

/// The user's vertices interpolated (with a non-zero weight) from a tet-mesh vertex that
/// `clamped` marks with 1.
fn clamped_user_vertices(tet_mesh: &TetMesh, clamped: &[[f64; 1]]) -> usize {
    tet_mesh.sample_at_user_vertices(clamped).iter().filter(|c| c[0] > 0.0).count()
}

/// The backend the options ask for: theirs, else `TRANSCUT_BACKEND`, else [`Backend::Auto`].
pub(crate) fn backend(options: &TransCutOptions) -> Result<Backend, GpuError> {
    match options.backend {
        Some(b) => Ok(b),
        None => Backend::from_env_or(Backend::Auto),
    }
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
/// measured on the test meshes (winding numbers about half, stencils a quarter).
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

/// The object's tets in world space, and the record to keep of them ([`Reuse::Keep`]; `None`
/// for [`Reuse::Nothing`] and a ready tet mesh): the mesh an earlier bake kept when it was made
/// from this surface at this budget ([`Target::reuse`]), else the surface meshed (progress
/// 0 → 0.6 of the object); a ready tet mesh transformed.
fn world_tets(
    target: &Target<'_>,
    options: &TransCutOptions,
    stats: &mut ObjectStats,
    stage: Stage<'_>,
) -> Result<(TetMesh, Option<Arc<Meshed>>), TetsError> {
    let (object, surface) = (target.object, target.world);
    match &object.shape {
        Shape::Surface(_) => {
            let grading = options.grading.resolve(|| {
                (
                    object.medium().map_or([0.0; 3], MediumSource::max_sigma_tr),
                    mesher::uniform_spacing_estimate(surface, options.tets) * object.mm_per_unit,
                )
            });
            let mesher_options = MesherOptions { grading, ..MesherOptions::with_tets(options.tets) };
            if let Reuse::Keep(Some(kept)) = target.reuse {
                if kept.made_from(surface, &mesher_options) {
                    stage("tetrahedra kept", 0.6).map_err(|c| TetsError::Mesher(MesherError::Cancelled(c)))?;
                    stats.meshing = Some(kept.stats().clone());
                    stats.mesh_reused = true;
                    return Ok((kept.mesh().clone(), Some(Arc::clone(kept))));
                }
            }
            // The mesher reports each of its stages from 0 to 1: one fraction of the meshing.
            let mesh_progress = |s: &str, f: f64| stage(s, 0.6 * mesher_fraction(s, f)).is_ok();
            let meshed = mesher::tetrahedralize_with(surface, &mesher_options, Progress::new(&mesh_progress))
                .map_err(TetsError::Mesher)?;
            stats.meshing = Some(meshed.stats.clone());
            let record = matches!(target.reuse, Reuse::Keep(_))
                .then(|| Arc::new(Meshed::new(surface, &mesher_options, meshed.mesh.clone(), meshed.stats)));
            Ok((meshed.mesh, record))
        }
        Shape::Tetrahedra(mesh) => {
            let m = object.transform;
            let world = mesh.clone().map_positions(move |p| m.transform_point3(p)).map_err(TetsError::Transform)?;
            Ok((world, None))
        }
    }
}
