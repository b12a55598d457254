//! Media: presets, coefficients, artist parameters (homogeneous objects).

use std::ffi::c_char;

use transcut_core::optics::{Medium, OpticsError};
use transcut_core::MediumSource;

use super::convert::{artist_medium, medium_from, TcArtistMedium, TcMedium};
use super::handle::{with_scene, SceneState, TcScene};
use super::ptr;
use super::status::{run, Failure, TcStatus, TC_NOT_FOUND};

/// A preset by name; `TC_NOT_FOUND` listing the valid names.
fn preset(name: &str) -> Result<Medium, Failure> {
    Medium::preset(name).map_err(|e| match e {
        OpticsError::UnknownPreset { .. } => Failure::new(TC_NOT_FOUND, e.to_string()),
        e => Failure::invalid(e.to_string()),
    })
}

/// Replaces object `object`'s medium by a homogeneous one.
fn set_homogeneous(state: &mut SceneState, object: u32, medium: Medium) -> Result<(), Failure> {
    state.set_medium(object, MediumSource::Homogeneous(medium))
}

/// Writes the named preset medium into `*out`. Names (case-insensitive): apple, chicken1,
/// chicken2, cream, ketchup, marble, potato, skimmilk, skin1, skin2, wholemilk (measured by
/// Jensen et al. 2001, g = 0) and jade. The measured presets have Jensen's η = 1.3, except
/// marble, whose η is 1.5 (Jensen's value for it); jade's is 1.66. The worked example of
/// docs/ARCHITECTURE.md (and tests/c/marble_sphere.c) uses marble's coefficients with
/// η = 1.3 set explicitly. `TC_NOT_FOUND` (listing the valid names) for any other name; `*out`
/// is then unchanged.
#[no_mangle]
pub unsafe extern "C" fn tc_medium_preset(name: *const c_char, out: *mut TcMedium) -> TcStatus {
    run("tc_medium_preset", || {
        check_not_null!(out);
        // SAFETY: the caller's contract.
        let medium = preset(unsafe { ptr::utf8(name, "name")? })?;
        // SAFETY: checked above.
        unsafe { ptr::write(out, medium.into()) };
        Ok(())
    })
}

/// Converts artist parameters to coefficients in `*out`, for a scene of `mm_per_unit`
/// millimetres per unit (the radius is in scene units). `TC_INVALID_ARGUMENT` naming the field
/// and channel that are out of range; `*out` is then unchanged.
#[no_mangle]
pub unsafe extern "C" fn tc_medium_from_artist(artist: *const TcArtistMedium, mm_per_unit: f64, out: *mut TcMedium) -> TcStatus {
    run("tc_medium_from_artist", || {
        check_not_null!(artist, out);
        // SAFETY: checked; the caller's contract.
        let medium = artist_medium(unsafe { &*artist }, mm_per_unit)?;
        // SAFETY: checked above.
        unsafe { ptr::write(out, medium.into()) };
        Ok(())
    })
}

/// Fills an object with a homogeneous medium. `TC_INVALID_ARGUMENT` naming the field (and
/// channel) when a value is out of range (see `TcMedium`); the object is then unchanged.
/// Every `tc_object_set_medium*` call refuses a diffuse object (`tc_scene_add_diffuse_mesh`)
/// with `TC_INVALID_ARGUMENT` naming it: an object keeps the kind it was added with (a
/// diffuse surface may be open, a medium fills a closed solid), so add the mesh again with
/// `tc_scene_add_mesh` to make it translucent.
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_medium(scene: *mut TcScene, object: u32, medium: *const TcMedium) -> TcStatus {
    run("tc_object_set_medium", || {
        check_not_null!(medium);
        // SAFETY: checked; the caller's contract.
        let m = medium_from(unsafe { &*medium }, "medium")?;
        // SAFETY: the caller's contract.
        unsafe { with_scene(scene, |s| set_homogeneous(s, object, m)) }
    })
}

/// Fills an object with a named preset (see `tc_medium_preset`); `TC_NOT_FOUND` for an unknown
/// name.
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_medium_preset(scene: *mut TcScene, object: u32, name: *const c_char) -> TcStatus {
    run("tc_object_set_medium_preset", || {
        // SAFETY: the caller's contract.
        let m = preset(unsafe { ptr::utf8(name, "name")? })?;
        // SAFETY: the caller's contract.
        unsafe { with_scene(scene, |s| set_homogeneous(s, object, m)) }
    })
}

/// Fills an object with a medium given by artist parameters. The radius is in scene units and
/// converted with the object's millimetres per unit at the time of this call, so call
/// `tc_object_set_scale` first.
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_medium_artist(
    scene: *mut TcScene,
    object: u32,
    artist: *const TcArtistMedium,
) -> TcStatus {
    run("tc_object_set_medium_artist", || {
        check_not_null!(artist);
        // SAFETY: checked; the caller's contract.
        let artist = unsafe { *artist };
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                let i = s.object_index(object)?;
                let m = artist_medium(&artist, s.scene.objects[i].mm_per_unit)?;
                set_homogeneous(s, object, m)
            })
        }
    })
}
