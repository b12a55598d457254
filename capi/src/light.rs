//! Lights: every kind the core supports. All radiometric values are linear RGB `double[3]`;
//! positions and vectors are in world space, scene units.
//!
//! Each light is checked when it is added (`TC_INVALID_ARGUMENT` naming the field, and the
//! light is not added). Lights are numbered in the order they are added; they shine on every
//! object and objects shadow each other (unless the bake turns shadows off).

use std::ffi::c_char;

use glam::DVec3;
use transcut_core::light::{Environment, EquirectMap, Light, LightError};

use super::handle::{with_scene, TcScene};
use super::ptr;
use super::status::{run, Failure, TcStatus, TC_IO_ERROR, TC_NOT_FOUND};

/// Validates `light` as the scene's next light and adds it.
///
/// # Safety
/// As `with_scene`.
unsafe fn add(scene: *mut TcScene, light: Light) -> Result<(), Failure> {
    // SAFETY: forwarded.
    unsafe {
        with_scene(scene, |s| {
            light.validate(s.scene.lights.len()).map_err(|e| Failure::invalid(e.to_string()))?;
            s.scene.lights.push(light);
            s.lights_changed();
            Ok(())
        })
    }
}

fn vec(v: [f64; 3]) -> DVec3 {
    DVec3::from_array(v)
}

/// Adds a sun: parallel light travelling along `direction` (from the sun towards the scene;
/// need not be unit), with `irradiance` on a surface facing it. `angular_diameter_deg` in
/// [0, 180): 0 is a point-like sun with hard shadows; larger values a disc of that apparent
/// diameter (Blender's sun "angle"), sampled with the bake's `area_samples`.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_add_sun(
    scene: *mut TcScene,
    direction: *const f64,
    irradiance: *const f64,
    angular_diameter_deg: f64,
) -> TcStatus {
    run("tc_scene_add_sun", || {
        // SAFETY: the caller's contract (3 doubles each).
        let (direction, irradiance) = unsafe { (ptr::vec3(direction, "direction")?, ptr::vec3(irradiance, "irradiance")?) };
        let light = Light::Directional { direction: vec(direction), irradiance, angular_diameter_deg };
        // SAFETY: the caller's contract.
        unsafe { add(scene, light) }
    })
}

/// Adds an isotropic point light of radiant `intensity` (irradiance I cos θ / d²).
#[no_mangle]
pub unsafe extern "C" fn tc_scene_add_point(scene: *mut TcScene, position: *const f64, intensity: *const f64) -> TcStatus {
    run("tc_scene_add_point", || {
        // SAFETY: the caller's contract (3 doubles each).
        let (position, intensity) = unsafe { (ptr::vec3(position, "position")?, ptr::vec3(intensity, "intensity")?) };
        // SAFETY: the caller's contract.
        unsafe { add(scene, Light::Point { position: vec(position), intensity }) }
    })
}

/// Adds a spot light at `position` shining along `direction`, with `intensity` on its axis, a
/// cone of half-angle `cone_half_angle_deg` in (0, 90] (Blender's spot size is twice this) and
/// a smooth edge over the fraction `blend` in [0, 1] of the cone (Blender's spot blend).
#[no_mangle]
pub unsafe extern "C" fn tc_scene_add_spot(
    scene: *mut TcScene,
    position: *const f64,
    direction: *const f64,
    intensity: *const f64,
    cone_half_angle_deg: f64,
    blend: f64,
) -> TcStatus {
    run("tc_scene_add_spot", || {
        // SAFETY: the caller's contract (3 doubles each).
        let (position, direction, intensity) =
            unsafe { (ptr::vec3(position, "position")?, ptr::vec3(direction, "direction")?, ptr::vec3(intensity, "intensity")?) };
        let light = Light::Spot { position: vec(position), direction: vec(direction), intensity, cone_half_angle_deg, blend };
        // SAFETY: the caller's contract.
        unsafe { add(scene, light) }
    })
}

/// Adds a rectangular (parallelogram) area light of uniform `radiance`, centred at `center`
/// with half-sides `half_u` and `half_v` (vectors from the centre). It emits along
/// `half_u × half_v`, or from both faces when `two_sided` is non-zero.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_add_rect(
    scene: *mut TcScene,
    center: *const f64,
    half_u: *const f64,
    half_v: *const f64,
    radiance: *const f64,
    two_sided: i32,
) -> TcStatus {
    run("tc_scene_add_rect", || {
        // SAFETY: the caller's contract (3 doubles each).
        let (center, half_u, half_v, radiance) = unsafe {
            (
                ptr::vec3(center, "center")?,
                ptr::vec3(half_u, "half_u")?,
                ptr::vec3(half_v, "half_v")?,
                ptr::vec3(radiance, "radiance")?,
            )
        };
        let light = Light::RectArea {
            center: vec(center),
            half_u: vec(half_u),
            half_v: vec(half_v),
            radiance,
            two_sided: two_sided != 0,
        };
        // SAFETY: the caller's contract.
        unsafe { add(scene, light) }
    })
}

/// Adds a disc area light of uniform `radiance`, centred at `center`, of `radius` (> 0),
/// emitting towards `normal`, or from both faces when `two_sided` is non-zero.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_add_disc(
    scene: *mut TcScene,
    center: *const f64,
    normal: *const f64,
    radius: f64,
    radiance: *const f64,
    two_sided: i32,
) -> TcStatus {
    run("tc_scene_add_disc", || {
        // SAFETY: the caller's contract (3 doubles each).
        let (center, normal, radiance) =
            unsafe { (ptr::vec3(center, "center")?, ptr::vec3(normal, "normal")?, ptr::vec3(radiance, "radiance")?) };
        let light = Light::DiscArea { center: vec(center), normal: vec(normal), radius, radiance, two_sided: two_sided != 0 };
        // SAFETY: the caller's contract.
        unsafe { add(scene, light) }
    })
}

/// Adds a constant environment: light of `radiance` from every direction (a uniform sky).
#[no_mangle]
pub unsafe extern "C" fn tc_scene_add_environment(scene: *mut TcScene, radiance: *const f64) -> TcStatus {
    run("tc_scene_add_environment", || {
        // SAFETY: the caller's contract (3 doubles).
        let radiance = unsafe { ptr::vec3(radiance, "radiance")? };
        // SAFETY: the caller's contract.
        unsafe { add(scene, Light::Environment(Environment::Constant(radiance))) }
    })
}

/// Adds an environment from an equirectangular (latitude-longitude) image in memory:
/// `width × height` texels of linear RGB floats (3 × width × height floats), row 0 at the top
/// (the +z pole), multiplied by `strength` (finite, ≥ 0). Texels must be finite and ≥ 0. The
/// library copies the image; the caller keeps ownership of `rgb`.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_add_environment_image(
    scene: *mut TcScene,
    rgb: *const f32,
    width: usize,
    height: usize,
    strength: f64,
) -> TcStatus {
    run("tc_scene_add_environment_image", || {
        let texels = ptr::times(width, height, "width × height")?;
        let floats = ptr::times(texels, 3, "width × height")?;
        // SAFETY: the caller's contract (an array of 3 × width × height floats).
        let rgb = unsafe { ptr::slice(rgb, floats, "rgb")? };
        let map = EquirectMap::from_rgb(width, height, rgb, strength).map_err(|e| Failure::invalid(e.to_string()))?;
        // SAFETY: the caller's contract.
        unsafe { add(scene, Light::Environment(Environment::Equirect(map))) }
    })
}

/// Adds an environment from a Radiance `.hdr` or OpenEXR file, equirectangular,
/// multiplied by `strength`. `TC_NOT_FOUND` when the file does not exist, `TC_IO_ERROR` when it
/// cannot be read or decoded.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_add_environment_file(scene: *mut TcScene, path: *const c_char, strength: f64) -> TcStatus {
    run("tc_scene_add_environment_file", || {
        // SAFETY: the caller's contract.
        let path = unsafe { ptr::path(path, "path")? };
        if !path.exists() {
            return Err(Failure::new(TC_NOT_FOUND, format!("environment map {} does not exist", path.display())));
        }
        let map = EquirectMap::load(path, strength).map_err(|e| match e {
            LightError::ImageLoad { .. } => Failure::new(TC_IO_ERROR, e.to_string()),
            e => Failure::invalid(e.to_string()),
        })?;
        // SAFETY: the caller's contract.
        unsafe { add(scene, Light::Environment(Environment::Equirect(map))) }
    })
}

/// Removes every light.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_clear_lights(scene: *mut TcScene) -> TcStatus {
    run("tc_scene_clear_lights", || {
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                s.scene.lights.clear();
                s.lights_changed();
                Ok(())
            })
        }
    })
}

/// The number of lights in the scene, in `*out`.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_light_count(scene: *const TcScene, out: *mut u32) -> TcStatus {
    run("tc_scene_light_count", || {
        check_not_null!(out);
        // SAFETY: the caller's contract.
        let n = unsafe { with_scene(scene, |s| Ok(s.scene.lights.len() as u32))? };
        // SAFETY: checked above.
        unsafe { ptr::write(out, n) };
        Ok(())
    })
}
