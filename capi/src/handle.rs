//! The opaque `TcScene` handle: a core [`Scene`] plus the [`Session`] of its last bake, guarded
//! so that one call at a time uses it.
//!
//! A handle is a `Box::into_raw` pointer from `tc_scene_create`, freed by `tc_scene_destroy`.
//! Every call that takes a scene goes through [`with_scene`]: it checks the pointer (NULL, a
//! magic number that catches pointers to something else), then claims the scene's `busy` flag
//! for the duration of the call. The flag turns what would be a data race in the caller (two
//! threads on one scene, or a progress callback calling back into the scene it is baking) into
//! `TC_BUSY` instead of undefined behaviour: the state lives in an `UnsafeCell` that is only
//! borrowed mutably while the flag is held.

use std::cell::UnsafeCell;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

use transcut_core::edit::Editor;
use transcut_core::methods::{Meshed, RadiosityStats};
use transcut_core::{Diffuse, Material, MediumSource, ObjectStats, Scene, Session, SessionError};

use super::convert::session_failure;
use super::progress::{Callback, Sink};
use super::status::{Failure, TC_BUSY, TC_INVALID_HANDLE, TC_NOT_BAKED, TC_NULL_POINTER, TC_UNSUPPORTED};

/// Marks a live `TcScene` ("TCSCENE\0" as little-endian bytes); zeroed when it is destroyed.
pub(crate) const MAGIC: u64 = u64::from_le_bytes(*b"TCSCENE\0");

/// A scene: objects (each a mesh, a medium, a transform), lights, and the results of the last
/// bake. Created by `tc_scene_create`, freed by `tc_scene_destroy`. Opaque: only pointers to it
/// are used. A scene may move between threads but serves one call at a time (`TC_BUSY`).
pub struct TcScene {
    magic: u64,
    busy: AtomicBool,
    state: UnsafeCell<SceneState>,
}

/// What a scene holds.
#[derive(Default)]
pub(crate) struct SceneState {
    pub scene: Scene,
    /// What edits start from: each object's bake or live state and the lights they were solved
    /// under. Kept when only the lights change (`tc_scene_relight` applies them); `None` before a
    /// bake or after any other change.
    pub session: Option<Session>,
    /// Whether the session's results describe the scene's current lights: false after a change
    /// of lights until `tc_scene_relight`.
    pub current: bool,
    /// The callback of every edit call (and of `tc_scene_relight` when it is given none).
    pub progress: Sink,
    /// What the radiosity method measured of the whole scene in the session's bake (`None`
    /// when another method baked it, or with no session): the core's session keeps only the
    /// objects' bakes, so the scene keeps this beside it.
    pub radiosity: Option<RadiosityStats>,
    /// The tet meshes of the last bake, by object index, kept across changes: the next bake
    /// takes an object's when its surface, placement and tet budget are unchanged
    /// ([`transcut_core::bake_reusing`]), so a change of medium, lights or one object meshes
    /// only what changed.
    pub meshes: Vec<Option<Arc<Meshed>>>,
}

impl SceneState {
    /// Discards the session: it no longer describes the scene (the kept tet meshes stay: the
    /// next bake takes those that still fit).
    pub(crate) fn changed(&mut self) {
        self.session = None;
        self.radiosity = None;
        self.current = false;
    }

    /// Marks the results stale after a change of lights; edits go on under the lights of the
    /// last bake or relight until `tc_scene_relight`.
    pub(crate) fn lights_changed(&mut self) {
        self.current = false;
    }

    /// Index `object` checked against the object count.
    pub(crate) fn object_index(&self, object: u32) -> Result<usize, Failure> {
        let n = self.scene.objects.len();
        let i = object as usize;
        if i < n {
            Ok(i)
        } else {
            Err(Failure::new(TC_INVALID_HANDLE, format!("object {object} does not exist (the scene has {n} objects)")))
        }
    }

    /// The session of the last bake, to edit.
    pub(crate) fn session_mut(&mut self) -> Result<&mut Session, Failure> {
        self.session.as_mut().ok_or_else(not_baked)
    }

    /// The session of the last bake.
    pub(crate) fn session(&self) -> Result<&Session, Failure> {
        self.session.as_ref().ok_or_else(not_baked)
    }

    /// The session, while its results describe the scene (not after a change of lights).
    fn results(&self) -> Result<&Session, Failure> {
        match &self.session {
            Some(session) if self.current => Ok(session),
            _ => Err(Failure::new(
                TC_NOT_BAKED,
                "the scene has no results: call tc_scene_bake first (any change to the scene discards them; \
                 after a change of lights, tc_scene_relight also brings them back)",
            )),
        }
    }

    /// The radiosity statistics of the last bake, while its results describe the scene;
    /// `TC_UNSUPPORTED` when another method baked it.
    pub(crate) fn radiosity_stats(&self) -> Result<&RadiosityStats, Failure> {
        let session = self.results()?;
        self.radiosity.as_ref().ok_or_else(|| {
            let method = session.options().method.name();
            Failure::new(
                TC_UNSUPPORTED,
                format!("the last bake was by the {method} method, not radiosity: it has no radiosity statistics"),
            )
        })
    }

    /// The statistics of object `object`'s last bake (checked).
    pub(crate) fn bake_stats(&self, object: u32) -> Result<&ObjectStats, Failure> {
        let i = self.object_index(object)?;
        self.results()?.bake_stats(i).map_err(|e| session_failure(&e))
    }

    /// The radiance at the user's vertices of object `object` (checked).
    pub(crate) fn radiance(&self, object: u32) -> Result<Vec<[f64; 3]>, Failure> {
        let i = self.object_index(object)?;
        self.results()?.radiance(i).map_err(|e| session_failure(&e))?.ok_or_else(|| {
            Failure::new(
                TC_NOT_BAKED,
                format!(
                    "object {object} was cut, split or had a piece moved: its radiance is per piece \
                     (tc_object_piece_count, tc_object_piece_mesh)"
                ),
            )
        })
    }

    /// Object `object`'s radiance as a texture ([`Session::bake_texture`]); `TC_NOT_BAKED` as
    /// [`SceneState::radiance`] once its surface is not the one it was baked with.
    pub(crate) fn texture(
        &self,
        object: u32,
        triangles: &[[u32; 3]],
        uvs: &[[f64; 2]],
        options: &transcut_core::texture::TextureOptions,
    ) -> Result<transcut_core::render::Image, Failure> {
        self.radiance(object)?;
        let i = self.object_index(object)?;
        self.results()?.bake_texture(i, triangles, uvs, options).map_err(|e| session_failure(&e))
    }

    /// The editor of object `object`, which must have been edited.
    pub(crate) fn editor(&self, object: u32) -> Result<&Editor, Failure> {
        let i = self.object_index(object)?;
        self.session()?.editor(i).map_err(|e| session_failure(&e))?.ok_or_else(|| {
            Failure::new(
                TC_NOT_BAKED,
                format!("object {object} has not been edited since the bake: its pieces exist from its first edit (or tc_scene_relight) on"),
            )
        })
    }

    /// After a successful update of a radiosity bake's coupled session (a relight, an albedo,
    /// an emission or a medium): object `index`'s material in the scene description becomes
    /// the session's, so a later bake agrees with the edit, and the scene's radiosity
    /// statistics become those of the update's solve. The results stay as current as they were.
    pub(crate) fn coupled_updated(&mut self, index: Option<usize>) {
        let Some(coupled) = self.session.as_ref().and_then(Session::radiosity) else { return };
        if let (Some(i), Some(o)) = (index, index.and_then(|i| coupled.objects().get(i))) {
            self.scene.objects[i].material = o.material.clone();
        }
        self.radiosity = Some(coupled.stats().clone());
    }

    /// Replaces an object's medium after checking it against the object's shape (a per-tet
    /// array must match the tet count, table ids must be in range, …); the object is unchanged
    /// on error. A diffuse object is refused: its kind is fixed when it is added (its surface
    /// may be open, and a medium fills a closed solid), so a caller that wants it translucent
    /// adds it again with `tc_scene_add_mesh`.
    pub(crate) fn set_medium(&mut self, object: u32, medium: MediumSource) -> Result<(), Failure> {
        let i = self.object_index(object)?;
        let o = &mut self.scene.objects[i];
        if o.material.diffuse().is_some() {
            return Err(Failure::invalid(format!(
                "object {object} ({}) is diffuse (an opaque surface added by tc_scene_add_diffuse_mesh): it has no medium; \
                 set its albedo, emission and sides instead, or add the mesh with tc_scene_add_mesh to make it translucent",
                o.name
            )));
        }
        medium.validate(&o.shape).map_err(|e| Failure::invalid(format!("object {object} ({}): {e}", o.name)))?;
        o.material = medium.into();
        self.changed();
        Ok(())
    }

    /// Changes a diffuse object's surface with `change`, checked with [`Diffuse::validate`]; a
    /// translucent object is refused by name. The object is unchanged on error.
    pub(crate) fn set_diffuse(&mut self, object: u32, change: impl FnOnce(&mut Diffuse)) -> Result<(), Failure> {
        let i = self.object_index(object)?;
        let o = &mut self.scene.objects[i];
        let Material::Diffuse(current) = &o.material else {
            return Err(Failure::invalid(format!(
                "object {object} ({}) is translucent (it has a medium): albedo, emission and sides belong to diffuse objects \
                 (tc_scene_add_diffuse_mesh)",
                o.name
            )));
        };
        let mut diffuse = *current;
        change(&mut diffuse);
        diffuse.validate().map_err(|e| Failure::invalid(format!("object {object} ({}): {e}", o.name)))?;
        o.material = Material::Diffuse(diffuse);
        self.changed();
        Ok(())
    }
}

/// `TC_NOT_BAKED`: nothing to edit.
fn not_baked() -> Failure {
    Failure::new(
        TC_NOT_BAKED,
        "the scene has not been baked (or an object, medium, transform or scale changed since): call tc_scene_bake first",
    )
}

/// The scenes created and not yet destroyed in this process (`tc_live_scene_count`).
pub(crate) static LIVE_SCENES: AtomicUsize = AtomicUsize::new(0);

impl TcScene {
    pub(crate) fn new() -> Self {
        LIVE_SCENES.fetch_add(1, Ordering::Relaxed);
        Self { magic: MAGIC, busy: AtomicBool::new(false), state: UnsafeCell::new(SceneState::default()) }
    }
}

impl Drop for TcScene {
    fn drop(&mut self) {
        LIVE_SCENES.fetch_sub(1, Ordering::Relaxed);
    }
}

/// Releases the busy flag when a call ends, also when it panics.
struct Claim<'a>(&'a AtomicBool);

impl Drop for Claim<'_> {
    fn drop(&mut self) {
        self.0.store(false, Ordering::Release);
    }
}

/// Checks `scene` and claims it for the call.
///
/// # Safety
/// `scene` must be NULL or a pointer from `tc_scene_create` that has not been destroyed.
unsafe fn claim<'a>(scene: *const TcScene) -> Result<(&'a TcScene, Claim<'a>), Failure> {
    if scene.is_null() {
        return Err(Failure::new(TC_NULL_POINTER, "`scene` is NULL"));
    }
    if !scene.is_aligned() {
        return Err(Failure::new(TC_INVALID_HANDLE, "`scene` is not a TcScene (misaligned pointer)"));
    }
    // SAFETY: a live handle (caller's contract). Only `magic` (never written while live) and the
    // atomic are read through this shared reference; the state is reached through the cell.
    let s = unsafe { &*scene };
    if s.magic != MAGIC {
        return Err(Failure::new(TC_INVALID_HANDLE, "`scene` is not a TcScene created by tc_scene_create"));
    }
    if s.busy.compare_exchange(false, true, Ordering::Acquire, Ordering::Relaxed).is_err() {
        return Err(Failure::new(
            TC_BUSY,
            "the scene is in use by another call (from another thread, or this is a call from inside its own progress callback)",
        ));
    }
    Ok((s, Claim(&s.busy)))
}

/// Runs `f` on the scene's state with the scene claimed.
///
/// # Safety
/// As [`claim`].
pub(crate) unsafe fn with_scene<R>(
    scene: *const TcScene,
    f: impl FnOnce(&mut SceneState) -> Result<R, Failure>,
) -> Result<R, Failure> {
    // SAFETY: forwarded.
    let (s, _claim) = unsafe { claim(scene)? };
    // SAFETY: the busy flag is held, so no other reference to the state exists.
    f(unsafe { &mut *s.state.get() })
}

/// Runs the session update `op` on object `object` of `scene` (after a bake; nothing changes
/// when it fails).
///
/// # Safety
/// As [`claim`].
pub(crate) unsafe fn update(
    scene: *mut TcScene,
    object: u32,
    op: impl FnOnce(&mut Session, usize, transcut_core::Progress) -> Result<(), SessionError>,
) -> Result<(), Failure> {
    // SAFETY: forwarded.
    unsafe {
        with_scene(scene, |s| {
            let i = s.object_index(object)?;
            let sink = s.progress;
            Callback::with(sink.function, sink.user, |p| op(s.session_mut()?, i, p).map_err(|e| session_failure(&e)))
        })
    }
}

/// Frees a scene unless a call is using it.
///
/// # Safety
/// As [`claim`]; `scene` must not be used afterwards.
pub(crate) unsafe fn destroy(scene: *mut TcScene) -> Result<(), Failure> {
    // SAFETY: forwarded.
    let (_, claim) = unsafe { claim(scene)? };
    std::mem::forget(claim); // the flag stays set until the memory is gone
                             // SAFETY: from Box::into_raw in tc_scene_create, claimed, so no call is using it.
    let mut boxed = unsafe { Box::from_raw(scene) };
    // A volatile store, so that it is not optimised away before the free: a later call with this
    // dangling pointer (undefined behaviour all the same) then most likely fails the magic check.
    // SAFETY: a valid, exclusive reference.
    unsafe { std::ptr::write_volatile(&mut boxed.magic, 0) };
    drop(boxed);
    Ok(())
}
