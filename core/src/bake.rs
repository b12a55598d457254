//! The bake driver: every object of a scene baked by one method.
//!
//! ```text
//! Scene ──► validate (options, objects, lights) ──► every object: check (can the method bake it?)
//!      └──► world surfaces ──► occluder BVH ──► Lighting
//!      └──► per object: prepare (light-independent) ──► solve (Lighting) ──► Lo(x, n) at the
//!           user's vertices, statistics, the method's state
//! ```
//!
//! Radiosity couples the objects, so it bakes the scene as a whole
//! ([`crate::methods::radiosity`]) from the same world surfaces and lighting.
//!
//! The driver owns what every method shares: validation, the worker threads, progress (stages
//! named `"<object>: <stage>"`, fractions of the whole bake that never decrease), the check that
//! a method's radiance is finite, non-negative and one value per output vertex, and the
//! timings. The methods are in [`crate::methods`].

use std::sync::{Arc, Mutex};
use std::time::Instant;

use crate::mesh::TriangleBvh;
use crate::methods::{
    bake_object, object_stage, radiosity, targets, world_surfaces, BakedState, HierarchicalDipole, Lighting, Meshed, ObjectBake,
    PolygridMethod, Prt, RadiositySession, RadiosityStats, SubsurfaceMethod, TransCut,
};
use crate::progress::{ms, Progress};
use crate::scene::{BakeOptions, Method, Scene, SceneError};
use crate::workers::with_workers;

/// The result of [`bake`]: one entry per object, in scene order.
#[derive(Debug, Clone)]
pub struct Bake {
    pub objects: Vec<ObjectBake>,
    /// What the radiosity method measured of the whole scene (it bakes all objects together);
    /// `None` for the other methods.
    pub radiosity: Option<RadiosityStats>,
    /// The radiosity method's whole-scene state (patches, form factors, every translucent
    /// object's system), which [`crate::Session::new`] edits without computing them again;
    /// `None` for the other methods.
    pub coupled: Option<Arc<RadiositySession>>,
    /// The occluder the objects were shadowed with (every object's world surface; `None`
    /// without shadows or for radiosity), which a [`crate::Session`]'s relights shadow with
    /// too, so that they equal a fresh bake under the new lights.
    pub occluder: Option<Arc<TriangleBvh>>,
    /// Wall time of the whole bake.
    pub total_ms: f64,
}

impl Bake {
    /// The tet mesh each object's bake kept, by object index ([`bake_reusing`]: pass them to
    /// the next bake of the scene); `None` for an object with none (another method, a ready tet
    /// mesh, a bake by [`bake_with`]).
    #[must_use]
    pub fn meshes(&self) -> Vec<Option<Arc<Meshed>>> {
        self.objects
            .iter()
            .map(|o| match &o.state {
                BakedState::TransCut(state) => state.meshed.clone(),
                _ => None,
            })
            .collect()
    }
}

/// Bakes per-vertex radiance for every object of `scene` with `options.method`.
///
/// # Errors
/// [`SceneError`] naming the object or light at fault; [`SceneError::Unsupported`] when the
/// method cannot bake an object.
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
    bake_kept(scene, options, None, progress)
}

/// [`bake_with`] for a host that bakes the same scene again after changing part of it: the
/// bake keeps each TransCut object's tet mesh ([`Bake::meshes`]), and takes object `i`'s from
/// `kept[i]` (the meshes of an earlier bake of this scene) instead of meshing again when it
/// was made from the same world-space surface at the same tet budget. Meshing is deterministic,
/// so the result equals [`bake_with`]'s bit for bit; [`crate::ObjectStats::mesh_reused`] says which
/// objects were not meshed. The kept meshes cost memory (about the tets' own once more), which
/// is why [`bake_with`] keeps none. The radiosity method meshes its objects afresh.
///
/// # Errors
/// As [`bake_with`].
pub fn bake_reusing(
    scene: &Scene,
    options: &BakeOptions,
    kept: &[Option<Arc<Meshed>>],
    progress: Progress,
) -> Result<Bake, SceneError> {
    bake_kept(scene, options, Some(kept), progress)
}

fn bake_kept(
    scene: &Scene,
    options: &BakeOptions,
    kept: Option<&[Option<Arc<Meshed>>]>,
    progress: Progress,
) -> Result<Bake, SceneError> {
    scene.validate(options)?;
    with_threads(options.threads, || match &options.method {
        Method::TransCut(o) => bake_all::<TransCut>(scene, options, o, kept, progress),
        Method::HierarchicalDipole(o) => bake_all::<HierarchicalDipole>(scene, options, o, kept, progress),
        Method::Prt(o) => bake_all::<Prt>(scene, options, o, kept, progress),
        Method::Polygrid(o) => bake_all::<PolygridMethod>(scene, options, o, kept, progress),
        Method::Radiosity(o) => {
            let start = Instant::now();
            radiosity::bake_scene(scene, options, o, progress).map(|(objects, stats, session)| Bake {
                occluder: None,
                objects,
                radiosity: Some(stats),
                coupled: Some(Arc::new(session)),
                total_ms: ms(start),
            })
        }
    })
    .map_err(SceneError::InvalidOptions)?
}

/// Runs `f` on `threads` worker threads (0: one per core), started for the call and joined
/// before it returns ([`crate::workers`]).
///
/// # Errors
/// A message when the count is above [`crate::workers::MAX_THREADS`] or the threads cannot be
/// started.
pub(crate) fn with_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> Result<R, String> {
    with_workers(threads, f).map_err(|e| e.to_string())
}

/// Every object of `scene` through method `M`: all checked first, then each prepared and solved
/// under the scene's lighting.
fn bake_all<M: SubsurfaceMethod>(
    scene: &Scene,
    options: &BakeOptions,
    method: &M::Options,
    kept: Option<&[Option<Arc<Meshed>>]>,
    progress: Progress,
) -> Result<Bake, SceneError> {
    let start = Instant::now();
    let world = world_surfaces(scene)?;
    let targets = targets(scene, &world, kept);
    for target in &targets {
        M::check(target, method)?;
    }
    let occluder = options.shadows.then(|| Arc::new(Lighting::occluder_of(&world)));
    let lighting = Lighting { lights: &scene.lights, occluder: occluder.as_deref(), source: &options.source };
    let name = options.method.name();
    let furthest = Mutex::new(0.0f64);
    let mut objects = Vec::with_capacity(targets.len());
    for target in &targets {
        let stage = object_stage(&progress, &furthest, target, scene.objects.len());
        objects.push(bake_object::<M>(target, method, name, &lighting, &stage)?);
        stage("done", 1.0)?;
    }
    Ok(Bake { objects, radiosity: None, coupled: None, occluder, total_ms: ms(start) })
}
