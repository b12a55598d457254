//! Relighting a baked scene: every object re-solved for the scene's current lights.

use std::ffi::c_void;

use super::convert::session_failure;
use super::handle::{with_scene, TcScene};
use super::progress::{Callback, Sink, TcProgressFn};
use super::status::{run, TcStatus};

/// Re-solves every object for the scene's CURRENT lights (after `tc_scene_clear_lights` /
/// `tc_scene_add_*`), warm-started from its last solution, without meshing or assembling again:
/// the interactive counterpart of `tc_scene_bake` after a change of lights. The matrices, media,
/// cuts and pieces stay; afterwards `tc_object_radiance` returns the new radiance (of objects
/// not cut or moved) and `tc_object_edit_stats` what each object's update did.
///
/// Each object is lit by the scene's lights with its own shadows (the pieces of that object);
/// unlike `tc_scene_bake`, other objects cast no shadows on it. A `TC_METHOD_RADIOSITY` bake
/// is the exception: its objects are coupled, so the whole scene is re-solved as the bake
/// solved it, every object shadowing and lighting every other (warm-started from the last
/// solution; lights that differ from the last ones only in colour or brightness need no solve),
/// and `tc_scene_radiosity_stats` then describes that solve. `progress` (nullable) is called
/// with `user` as objects finish, as for `tc_scene_bake`; a non-zero return cancels
/// (`TC_CANCELLED`). On any failure no object changes.
///
/// Errors: `TC_NOT_BAKED` before a bake (or after a change other than lights), `TC_INVALID_ARGUMENT`
/// (an invalid light), `TC_SOLVE_FAILED`, `TC_GPU_UNAVAILABLE`, `TC_CANCELLED`.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_relight(scene: *mut TcScene, progress: TcProgressFn, user: *mut c_void) -> TcStatus {
    run("tc_scene_relight", || {
        // SAFETY: the caller's contract.
        let sink = unsafe { with_scene(scene, |s| Ok(s.progress))? };
        let (progress, user) = if progress.is_some() { (progress, user) } else { (sink.function, sink.user) };
        Callback::with(progress, user, |progress| {
            // SAFETY: the caller's contract.
            unsafe {
                with_scene(scene, |s| {
                    let lights = s.scene.lights.clone();
                    s.session_mut()?.relight(&lights, progress).map_err(|e| session_failure(&e))?;
                    s.current = true;
                    s.coupled_updated(None);
                    Ok(())
                })
            }
        })
    })
}

/// Sets the progress callback of every edit call on `scene` (`tc_object_edit_medium`,
/// `tc_object_paint`, the `tc_object_cut_*` calls, `tc_object_split_*`, `tc_object_fracture`,
/// `tc_object_set_piece_transform`, `tc_object_recombine`) and of `tc_scene_relight` when its
/// own `progress` is NULL; NULL clears it. The callback is called as `TcProgressFn` documents,
/// with stages named "<object>: <stage>" (light, solve, cut, assembly, …) and the fraction of
/// the one call; a non-zero return cancels the call, which then returns `TC_CANCELLED` with
/// nothing changed. `user` is passed back to it unchanged and must stay valid until the
/// callback is replaced or cleared or the scene is freed.
///
/// Errors: `TC_NULL_POINTER`, `TC_INVALID_HANDLE`, `TC_BUSY`.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_set_progress(scene: *mut TcScene, progress: TcProgressFn, user: *mut c_void) -> TcStatus {
    run("tc_scene_set_progress", || {
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                s.progress = Sink { function: progress, user: if progress.is_some() { user } else { std::ptr::null_mut() } };
                Ok(())
            })
        }
    })
}
