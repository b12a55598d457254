//! The PRT method's own calls (`TC_METHOD_PRT`, R. Wang et al. 2008): after one bake, a new
//! medium, artist parameters or scale cost a K-term re-weighting per vertex (no new precompute),
//! and the precompute can be saved for later sessions (`TcPrtOptions.cache_dir` reads it back).
//!
//! Unlike `tc_object_set_medium*` and `tc_object_set_scale`, which describe the scene for the
//! next bake and discard the last one, these update the baked object in place and keep the
//! scene's description in step, so a later `tc_scene_bake` gives the same picture.

use std::ffi::c_char;

use transcut_core::edit::{MediumEdit, MediumOp, Region};
use transcut_core::methods::PrtState;
use transcut_core::optics::Medium;
use transcut_core::{MediumSource, Session, SessionError};

use super::convert::{artist_medium, medium_from, session_failure, TcArtistMedium};
use super::handle::{with_scene, SceneState, TcScene};
use super::progress::Callback;
use super::ptr;
use super::status::{run, Failure, TcStatus, TC_IO_ERROR, TC_NOT_BAKED, TC_UNSUPPORTED};
use super::TcMedium;

/// What the PRT precompute of an object holds and what its medium is now
/// (`tc_object_prt_stats`). The caller sets `size` to `sizeof(TcPrtStats)` before the call.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcPrtStats {
    /// `sizeof(TcPrtStats)`.
    pub size: u32,
    /// The basis functions K of the transfer's rows (12 or 16).
    pub basis_terms: u32,
    /// log₂ of the irradiance samples.
    pub samples_log2: u32,
    /// 1 when the bake read the transfer from a saved precompute (`TcPrtOptions.cache_dir`),
    /// 0 when it computed it.
    pub precompute_loaded: u32,
    /// Receiver vertices of the transfer.
    pub vertices: u64,
    /// Haar coefficients kept over all receivers.
    pub terms: u64,
    /// Bytes of the compressed transfer.
    pub bytes: u64,
    /// The weighted coefficient energy the compression dropped, relative: mean over the
    /// receivers and the largest.
    pub dropped_mean: f64,
    pub dropped_max: f64,
    /// The relative residual of the medium's projection onto the basis, per channel (a medium
    /// above 5% is refused).
    pub residual: [f64; 3],
    /// Millimetres per scene unit the transfer was computed at, and now.
    pub transfer_mm_per_unit: f64,
    pub mm_per_unit: f64,
    /// The medium now (mm⁻¹; the scale change is not folded in).
    pub medium: TcMedium,
    /// The 128-bit key of the precompute (the name of its file in a cache folder), as two
    /// 64-bit halves, high first.
    pub key: [u64; 2],
}

/// Writes what the PRT precompute of an object holds into `*out` (set `out->size =
/// sizeof(TcPrtStats)` first; another size is `TC_INVALID_ARGUMENT`).
///
/// Errors: `TC_NULL_POINTER`, `TC_INVALID_HANDLE`, `TC_NOT_BAKED` (before a bake), and
/// `TC_UNSUPPORTED` for an object another method baked.
#[no_mangle]
pub unsafe extern "C" fn tc_object_prt_stats(scene: *const TcScene, object: u32, out: *mut TcPrtStats) -> TcStatus {
    run("tc_object_prt_stats", || {
        check_not_null!(out);
        if !out.is_aligned() {
            return Err(Failure::invalid("`out` is not aligned for TcPrtStats"));
        }
        // SAFETY: checked; `size` is the first field.
        let size = unsafe { out.cast::<u32>().read() } as usize;
        let ours = size_of::<TcPrtStats>();
        if size != ours {
            return Err(Failure::invalid(format!("out->size = {size}, expected sizeof(TcPrtStats) = {ours}")));
        }
        // SAFETY: the caller's contract.
        let stats = unsafe {
            with_scene(scene.cast_mut(), |s| {
                let i = s.object_index(object)?;
                let session = s.session()?;
                let bake = session.bake_stats(i).map_err(|e| session_failure(&e))?;
                let loaded = bake.precompute_loaded;
                let state = prt_state(session, i)?;
                Ok(stats_of(state, loaded))
            })?
        };
        // SAFETY: checked above.
        unsafe { ptr::write(out, stats) };
        Ok(())
    })
}

/// The statistics of `state`.
fn stats_of(state: &PrtState, loaded: bool) -> TcPrtStats {
    let t = state.transfer_stats();
    TcPrtStats {
        size: size_of::<TcPrtStats>() as u32,
        basis_terms: state.basis().terms() as u32,
        samples_log2: state.options.samples_log2,
        precompute_loaded: u32::from(loaded),
        vertices: state.transfer.vertices() as u64,
        terms: t.terms as u64,
        bytes: t.bytes as u64,
        dropped_mean: t.dropped_mean,
        dropped_max: t.dropped_max,
        residual: state.residual,
        transfer_mm_per_unit: state.transfer_mm_per_unit,
        mm_per_unit: state.mm_per_unit,
        medium: state.medium.into(),
        key: state.key.0,
    }
}

/// The PRT state of object `i` of the session, or why there is none.
fn prt_state(session: &Session, i: usize) -> Result<&PrtState, Failure> {
    match session.prt_state(i).map_err(|e| session_failure(&e))? {
        Some(state) => Ok(state),
        None => Err(Failure::new(
            TC_UNSUPPORTED,
            format!("object {i} was baked by the {} method, not prt", session.bake_stats(i).map_or("another", |s| s.method)),
        )),
    }
}

/// Saves the precomputed transfer of a PRT object to the file `path` (a `.tcprt` file,
/// written whole through a temporary file beside it). A later bake of the same surface,
/// placement, scale and PRT options with `TcPrtOptions.cache_dir` naming the folder of a file
/// called `<key>.tcprt` (`TcPrtStats.key` in hexadecimal) reads it instead of precomputing;
/// `transcut prt eval` reads it by name.
///
/// Errors: `TC_NULL_POINTER`, `TC_INVALID_HANDLE`, `TC_NOT_BAKED`, `TC_UNSUPPORTED` (another method), `TC_IO_ERROR` (the
/// file cannot be written; no partial file is left).
#[no_mangle]
pub unsafe extern "C" fn tc_object_prt_save(scene: *const TcScene, object: u32, path: *const c_char) -> TcStatus {
    run("tc_object_prt_save", || {
        // SAFETY: the caller's contract.
        let path = unsafe { ptr::path(path, "path")? };
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene.cast_mut(), |s| {
                let i = s.object_index(object)?;
                let session = s.session()?;
                let state = prt_state(session, i)?;
                state.save(path).map_err(|e| Failure::new(TC_IO_ERROR, e.to_string()))
            })
        }
    })
}

/// Gives a PRT object a new homogeneous medium without a new bake: the basis weights of the
/// medium and one K-term sum per vertex (microseconds per thousand vertices). `medium` must
/// have the object's η and g (they shape the transmitted light the precompute holds); the
/// basis must represent it (projection residual ≤ 5%) and the samples resolve it (σ′t h ≤ 3).
/// The scene's description takes the new medium, so a later bake agrees. `tc_object_radiance`
/// then returns the new radiance.
///
/// Errors: `TC_NULL_POINTER`, `TC_INVALID_HANDLE`, `TC_NOT_BAKED`, `TC_UNSUPPORTED` (another
/// method), `TC_INVALID_ARGUMENT` (an invalid medium, another η or g, a medium the transfer
/// cannot represent: the message says which). Nothing changes on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_object_prt_set_medium(scene: *mut TcScene, object: u32, medium: *const TcMedium) -> TcStatus {
    run("tc_object_prt_set_medium", || {
        check_not_null!(medium);
        // SAFETY: checked; the caller's contract.
        let m = medium_from(unsafe { &*medium }, "medium")?;
        // SAFETY: the caller's contract.
        unsafe { with_scene(scene, |s| set_medium(s, object, |_| Ok(m))) }
    })
}

/// Gives a PRT object a medium from artist parameters (Blender's Principled BSDF subsurface
/// inputs) without a new bake, as `tc_object_prt_set_medium` does; the radius is in scene
/// units, converted with the object's current millimetres per unit. `artist->ior` and
/// `artist->anisotropy` must be the object's η and g.
///
/// Errors: those of `tc_object_prt_set_medium`, and `TC_INVALID_ARGUMENT` naming an artist
/// field out of range. Nothing changes on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_object_prt_set_medium_artist(
    scene: *mut TcScene,
    object: u32,
    artist: *const TcArtistMedium,
) -> TcStatus {
    run("tc_object_prt_set_medium_artist", || {
        check_not_null!(artist);
        // SAFETY: checked; the caller's contract.
        let artist = unsafe { *artist };
        // SAFETY: the caller's contract.
        unsafe { with_scene(scene, |s| set_medium(s, object, |mm_per_unit| artist_medium(&artist, mm_per_unit))) }
    })
}

/// Changes how many millimetres one scene unit is for a PRT object without a new bake: for the
/// precompute, the object's medium with every coefficient times the ratio of the new scale to
/// the one it was computed at (the dipole's scale identity Rd(s r; σ) s² = Rd(r; s σ)). The
/// scene's description takes the new scale. Artist media set later use it.
///
/// Errors: `TC_INVALID_ARGUMENT` (not positive and finite, or a scaled medium the transfer
/// cannot represent), `TC_INVALID_HANDLE`, `TC_NOT_BAKED`, `TC_UNSUPPORTED`. Nothing changes on
/// failure.
#[no_mangle]
pub unsafe extern "C" fn tc_object_prt_set_scale(scene: *mut TcScene, object: u32, mm_per_unit: f64) -> TcStatus {
    run("tc_object_prt_set_scale", || {
        if !(mm_per_unit.is_finite() && mm_per_unit > 0.0) {
            return Err(Failure::invalid(format!("mm_per_unit = {mm_per_unit}: must be positive and finite")));
        }
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                let i = s.object_index(object)?;
                let sink = s.progress;
                let session = s.session.as_mut().ok_or_else(not_baked)?;
                prt_state(session, i)?;
                Callback::with(sink.function, sink.user, |p| {
                    session.set_mm_per_unit(i, mm_per_unit, p).map(|_| ()).map_err(|e| session_failure(&e))
                })?;
                s.scene.objects[i].mm_per_unit = mm_per_unit;
                Ok(())
            })
        }
    })
}

fn not_baked() -> Failure {
    Failure::new(TC_NOT_BAKED, "the scene has not been baked: call tc_scene_bake first")
}

/// Sets object `object`'s medium to `make(mm_per_unit)` in the session (a whole-object
/// assignment) and then in the scene's description; nothing changes on failure.
fn set_medium(s: &mut SceneState, object: u32, make: impl FnOnce(f64) -> Result<Medium, Failure>) -> Result<(), Failure> {
    let i = s.object_index(object)?;
    let sink = s.progress;
    let session = s.session.as_mut().ok_or_else(not_baked)?;
    let mm_per_unit = prt_state(session, i)?.mm_per_unit;
    let medium = make(mm_per_unit)?;
    let edit = MediumEdit { region: Region::All, op: MediumOp::Assign(medium) };
    Callback::with(sink.function, sink.user, |p| {
        session.edit_medium(i, &edit, p).map(|_| ()).map_err(|e: SessionError| session_failure(&e))
    })?;
    s.scene.objects[i].material = MediumSource::Homogeneous(medium).into();
    Ok(())
}
