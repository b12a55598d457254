//! The TransCut editor ([`Editor`], TransCut §5) started from a TransCut bake.

use std::sync::Arc;

use crate::edit::{EditError, EditOptions, Editor};
use crate::light::Light;
use crate::mesh::TriangleBvh;
use crate::methods::{bake_object, object_stage, Lighting, ObjectBake, Reuse, SubsurfaceMethod, Target, TransCut};
use crate::progress::Progress;
use crate::scene::{Object, Scene, SceneError};

impl Editor {
    /// Meshes (if a surface) and bakes `object` alone under `lights` with TransCut and the
    /// editor's options ([`EditOptions::bake_options`]); the starting state.
    ///
    /// # Errors
    /// [`EditError::InvalidOptions`]; [`EditError::Scene`] from the bake; those of
    /// [`Editor::from_bake`].
    pub fn new(object: &Object, lights: &[Light], options: &EditOptions) -> Result<Self, EditError> {
        Self::with_progress(object, lights, options, Progress::none())
    }

    /// [`Editor::new`] with progress reporting and cancellation of the bake (stages named
    /// `"<object>: <stage>"`, as [`crate::bake_with`] names them).
    ///
    /// # Errors
    /// As [`Editor::new`], plus [`EditError::Cancelled`].
    pub fn with_progress(
        object: &Object,
        lights: &[Light],
        options: &EditOptions,
        progress: Progress,
    ) -> Result<Self, EditError> {
        options.validate()?;
        let bake_options = options.bake_options();
        let transcut = &options.transcut_options();
        let scene = Scene { objects: vec![object.clone()], lights: lights.to_vec() };
        let scene_error = |e| match e {
            SceneError::Cancelled(c) => EditError::Cancelled(c),
            other => EditError::Scene(other),
        };
        scene.validate(&bake_options).map_err(scene_error)?;
        let world = object.world_surface().map_err(|e| {
            scene_error(SceneError::InvalidObject { index: 0, name: object.name.clone(), message: e.to_string() })
        })?;
        let target = Target { index: 0, object, world: &world, reuse: Reuse::Nothing };
        TransCut::check(&target, transcut).map_err(scene_error)?;
        let occluder = bake_options.shadows.then(|| Arc::new(Lighting::occluder_of(std::slice::from_ref(&world))));
        let lighting = Lighting { lights, occluder: occluder.as_deref(), source: &bake_options.source };
        let furthest = std::sync::Mutex::new(0.0);
        let stage = object_stage(&progress, &furthest, &target, 1);
        let bake = bake_object::<TransCut>(&target, transcut, bake_options.method.name(), &lighting, &stage)
            .and_then(|b| stage("done", 1.0).map(|()| b).map_err(SceneError::from))
            .map_err(scene_error)?;
        Self::from_bake_shadowed_by(&bake, lights, options, occluder, progress)
    }

    /// From a finished TransCut bake of a scene object: the original mesh is the bake's
    /// world-space tet mesh, its media become one entry per tet. The solve starts from the
    /// bake's φ: when the editor's source equals the bake's (e.g. shadows off), it takes no
    /// iteration.
    ///
    /// # Errors
    /// [`EditError::InvalidOptions`] for bad options, a bake of another method, or a bake whose
    /// fluence does not match its mesh; [`EditError::Volume`] for media that disagree on η at
    /// the surface; [`EditError::Light`], [`EditError::Diffusion`], [`EditError::Gpu`] from the
    /// first solve.
    pub fn from_bake(bake: &ObjectBake, lights: &[Light], options: &EditOptions) -> Result<Self, EditError> {
        Self::from_bake_with_progress(bake, lights, options, Progress::none())
    }

    /// [`Editor::from_bake`] reporting the stages of its first solve (`"assembly"`,
    /// `"hierarchy"`, `"occluder"`, `"light"`, `"solve"`) to `progress`, which can cancel it.
    ///
    /// # Errors
    /// As [`Editor::from_bake`], plus [`EditError::Cancelled`].
    pub fn from_bake_with_progress(
        bake: &ObjectBake,
        lights: &[Light],
        options: &EditOptions,
        progress: Progress,
    ) -> Result<Self, EditError> {
        Self::from_bake_shadowed_by(bake, lights, options, None, progress)
    }

    /// [`Editor::from_bake_with_progress`] shadowing with `occluder` (the bake's,
    /// [`crate::Bake::occluder`]: every object's world surface) instead of its own boundary,
    /// until its pieces' placement changes: its first update and relights then equal a fresh
    /// bake of the scene, other objects' shadows included.
    ///
    /// # Errors
    /// As [`Editor::from_bake_with_progress`].
    pub fn from_bake_shadowed_by(
        bake: &ObjectBake,
        lights: &[Light],
        options: &EditOptions,
        occluder: Option<Arc<TriangleBvh>>,
        progress: Progress,
    ) -> Result<Self, EditError> {
        let state = bake.transcut().ok_or_else(|| {
            EditError::InvalidOptions(format!("the editor edits TransCut bakes, not one of the {} method", bake.method()))
        })?;
        let map = state.tet_mesh.surface_map().len();
        let user_surface = map > 0 && bake.radiance.len() == map;
        Self::from_tets(
            state.tet_mesh.clone(),
            &state.media,
            state.fluence.clone(),
            user_surface,
            state.mm_per_unit,
            lights,
            options,
            occluder,
            progress,
        )
    }
}
