//! Bakes through the ABI: the uniform sphere against its closed form, a sun, the caller's vertex
//! order, statistics, progress and cancellation.

use std::ffi::{c_char, c_void, CStr};
use std::ptr;

use transcut_core::optics::{f_ext, Medium, UniformSphere};

use super::abi::*;
use super::common::*;

/// A marble sphere of radius 10 mm (η = 1.3) under a constant sky of radiance 1 returns the
/// closed form Lo = (0.9394, 0.9072, 0.8709) (ARCHITECTURE.md's worked numbers). At 20k tets
/// on a 64 × 32 UV sphere the solver (second order in the tet size, core/tests/integration/diffusion.rs)
/// lands within 2% on average, 4% at every vertex.
#[test]
fn uniform_sphere_under_a_constant_sky_matches_the_closed_form() {
    let mesh = Mesh::uv_sphere(10.0, 64, 32);
    let s = scene();
    let ball = add(s, &mesh);
    let mut marble = TcMedium { sigma_a: [0.0; 3], sigma_s_prime: [0.0; 3], eta: 0.0, g: 0.0 };
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_medium_preset(cstr(c"Marble"), &mut marble), "preset");
        marble.eta = 1.3;
        ok(tc_object_set_medium(s, ball, &marble), "set medium");
        ok(tc_scene_add_environment(s, [1.0; 3].as_ptr()), "sky");
    }
    let mut o = options(20_000);
    o.shadows = 0;
    // SAFETY: valid pointers; no callback.
    ok(unsafe { tc_scene_bake(s, &o, None, ptr::null_mut()) }, "bake");
    let lo = radiance(s, ball);
    assert_eq!(lo.len(), 3 * mesh.vertex_count());

    let medium = Medium::new(marble.sigma_a, marble.sigma_s_prime, 1.3, 0.0).unwrap();
    let q = std::f64::consts::PI * (1.0 - f_ext(1.3));
    let exact = UniformSphere::new(medium, 10.0, [q; 3]).unwrap().surface_radiance(1.0);
    for c in 0..3 {
        assert!((exact[c] - [0.9394, 0.9072, 0.8709][c]).abs() < 1e-3);
        let values: Vec<f64> = lo.iter().skip(c).step_by(3).map(|&x| f64::from(x)).collect();
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        let worst = values.iter().map(|x| (x / exact[c] - 1.0).abs()).fold(0.0, f64::max);
        eprintln!("channel {c}: exact {:.4}, mean {mean:.4}, worst {:.2}%", exact[c], 100.0 * worst);
        assert!((mean / exact[c] - 1.0).abs() < 0.02, "channel {c}: mean {mean} vs {}", exact[c]);
        assert!(worst < 0.04, "channel {c}: worst relative error {worst}");
    }
    let mut stats: TcBakeStats = unsafe { std::mem::zeroed() };
    stats.size = size_of::<TcBakeStats>() as u32;
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_stats(s, ball, &mut stats) }, "stats");
    assert!((10_000..40_000).contains(&stats.tets), "{} tets", stats.tets);
    assert!(stats.vertices > 0 && stats.iterations.iter().all(|&i| i > 0) && stats.total_ms > 0.0);
    assert_eq!(stats.clamped_vertices, 0);
    assert_eq!(stats.size as usize, size_of::<TcBakeStats>());
    destroy(s);
}

/// A sun from +z lights the north pole (vertex 0) far more than the south pole; moving the
/// object with a transform moves the result with it (same values at the same user vertices).
#[test]
fn sun_lights_the_facing_side_and_results_follow_the_callers_vertices() {
    // Skin's blue channel needs the mesh to resolve 0.7 mm: a 10 mm radius at 60k tets does
    // (a 20 mm radius at 8k is refused as TC_UNRESOLVED).
    let mesh = Mesh::uv_sphere(10.0, 48, 24);
    let bake = |matrix: Option<[f32; 16]>| {
        let s = scene();
        let ball = add(s, &mesh);
        // SAFETY: valid pointers.
        unsafe {
            ok(tc_object_set_medium_preset(s, ball, cstr(c"skin1")), "preset");
            if let Some(m) = matrix {
                ok(tc_object_set_transform(s, ball, m.as_ptr()), "transform");
            }
            ok(tc_scene_add_sun(s, [0.0, 0.0, -1.0].as_ptr(), [3.0; 3].as_ptr(), 0.0), "sun");
            ok(tc_scene_bake(s, &options(60_000), None, ptr::null_mut()), "bake");
        }
        let lo = radiance(s, ball);
        destroy(s);
        lo
    };
    let lo = bake(None);
    let n = mesh.vertex_count();
    for c in 0..3 {
        let (top, bottom) = (lo[c], lo[3 * (n - 1) + c]);
        assert!(top > 10.0 * bottom, "channel {c}: top {top}, bottom {bottom}");
    }
    assert!(lo.iter().all(|x| x.is_finite() && *x >= 0.0));
    // Column-major translation by (100, -5, 3).
    let mut m = [0.0f32; 16];
    m[0] = 1.0;
    m[5] = 1.0;
    m[10] = 1.0;
    m[15] = 1.0;
    m[12..15].copy_from_slice(&[100.0, -5.0, 3.0]);
    let moved = bake(Some(m));
    for (a, b) in lo.iter().zip(&moved) {
        assert!((a - b).abs() <= 1e-4 * a.abs().max(1e-3), "{a} vs {b}");
    }
}

/// A marble sphere modelled in metres (radius 1, `mm_per_unit` 1000) at 5,000 tets cannot be
/// resolved: `TC_UNRESOLVED`, naming the channel and what would resolve it, and no results. The
/// same sphere in millimetres with a tenth of its triangles wound the other way bakes, and the
/// statistics say how many were reversed and how well each channel is resolved.
#[test]
fn an_unresolved_bake_fails_and_the_stats_report_flips_and_resolution() {
    let metres = Mesh::uv_sphere(1.0, 32, 16);
    let s = scene();
    let ball = add(s, &metres);
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_object_set_medium_preset(s, ball, cstr(c"marble")), "preset");
        ok(tc_object_set_scale(s, ball, 1000.0), "scale");
        ok(tc_scene_add_sun(s, [0.0, 0.0, -1.0].as_ptr(), [3.0; 3].as_ptr(), 0.0), "sun");
        fails(tc_scene_bake(s, &options(5_000), None, ptr::null_mut()), TC_UNRESOLVED, &["blue", "σtr·h", "mm", "tets"]);
        let mut stats: TcBakeStats = std::mem::zeroed();
        stats.size = size_of::<TcBakeStats>() as u32;
        fails(tc_object_stats(s, ball, &mut stats), TC_NOT_BAKED, &[]);
    }
    assert_eq!(name(TC_UNRESOLVED), "TC_UNRESOLVED");
    destroy(s);

    let mut mesh = Mesh::uv_sphere(10.0, 32, 16);
    let triangles = mesh.indices.len() / 3;
    for t in (0..triangles).step_by(10) {
        mesh.indices.swap(3 * t + 1, 3 * t + 2);
    }
    let s = scene();
    let ball = add(s, &mesh);
    // SAFETY: valid pointers.
    let stats = unsafe {
        ok(tc_object_set_medium_preset(s, ball, cstr(c"marble")), "preset");
        ok(tc_scene_add_sun(s, [0.0, 0.0, -1.0].as_ptr(), [3.0; 3].as_ptr(), 0.0), "sun");
        ok(tc_scene_bake(s, &options(5_000), None, ptr::null_mut()), "bake");
        let mut stats: TcBakeStats = std::mem::zeroed();
        stats.size = size_of::<TcBakeStats>() as u32;
        ok(tc_object_stats(s, ball, &mut stats), "stats");
        stats
    };
    assert_eq!(stats.flipped_faces as usize, triangles.div_ceil(10));
    // Marble's σtr grows from red to blue (0.118, 0.180, 0.253 mm⁻¹), and so does σtr·h; the
    // ratios are the σtr ratios whatever h is.
    let r = stats.resolution;
    assert!(r[0] > 0.0 && r[0] < r[1] && r[1] < r[2] && r[2] < 1.0, "{r:?}");
    assert!((r[2] / r[0] - 0.253_083 / 0.117_517).abs() < 1e-4, "{r:?}");
    let lo = radiance(s, ball);
    assert!(lo[0] > 10.0 * lo[lo.len() - 3], "the lit pole is the bright one");
    destroy(s);
}

/// What the progress callback saw.
#[derive(Default)]
struct Seen {
    calls: u32,
    cancel_at: u32,
    fractions: Vec<f64>,
    stages: Vec<String>,
}

unsafe extern "C" fn on_progress(user: *mut c_void, stage: *const c_char, fraction: f64) -> i32 {
    // SAFETY: `user` is the `Seen` passed to tc_scene_bake; `stage` is valid during the call.
    let seen = unsafe { &mut *user.cast::<Seen>() };
    seen.calls += 1;
    seen.fractions.push(fraction);
    seen.stages.push(unsafe { CStr::from_ptr(stage) }.to_string_lossy().into_owned());
    i32::from(seen.cancel_at != 0 && seen.calls >= seen.cancel_at)
}

/// Progress is reported in order up to 1 with the object's name; a non-zero return cancels
/// with TC_CANCELLED, no report follows the cancel, and the scene bakes again afterwards to
/// the same result as an uncancelled bake. A cancelled bake keeps the previous results. A
/// bake again of the unchanged scene keeps the tets (fewer reports: no meshing stages) and is
/// cancelled the same way; so is a first bake while it meshes.
#[test]
fn cancelling_mid_bake_then_baking_again() {
    let mesh = Mesh::uv_sphere(15.0, 32, 16);
    let new_scene = || {
        let s = scene();
        let ball = add(s, &mesh);
        // SAFETY: valid pointers.
        unsafe {
            ok(tc_object_set_name(s, ball, cstr(c"pebble")), "name");
            ok(tc_scene_add_point(s, [0.0, 0.0, 60.0].as_ptr(), [5000.0; 3].as_ptr()), "point");
        }
        (s, ball)
    };
    let (s, ball) = new_scene();
    let o = options(6_000);
    let bake = |s, seen: &mut Seen| {
        // SAFETY: valid pointers; `seen` outlives the call.
        unsafe { tc_scene_bake(s, &o, Some(on_progress), ptr::from_mut(seen).cast()) }
    };
    let mut seen = Seen::default();
    ok(bake(s, &mut seen), "bake");
    assert!(seen.calls >= 4, "{} reports", seen.calls);
    assert!(seen.fractions.windows(2).all(|w| w[0] <= w[1]), "{:?}", seen.fractions);
    assert_eq!(*seen.fractions.last().unwrap(), 1.0);
    assert!(seen.stages.iter().all(|s| s.contains("pebble")), "{:?}", seen.stages);
    let first = radiance(s, ball);

    let mut again = Seen::default();
    ok(bake(s, &mut again), "bake again");
    assert!(again.stages.iter().any(|s| s.contains("tetrahedra kept")), "{:?}", again.stages);
    assert!(again.calls < seen.calls && again.calls >= 3, "{} of {} reports", again.calls, seen.calls);
    assert_eq!(*again.fractions.last().unwrap(), 1.0);
    assert_eq!(radiance(s, ball), first);

    for cancel_at in [1, 3, again.calls] {
        let mut cancel = Seen { cancel_at, ..Seen::default() };
        fails(bake(s, &mut cancel), TC_CANCELLED, &["cancel"]);
        assert_eq!(cancel.calls, cancel_at, "reports after the cancel");
        // The previous results are still there (the scene did not change).
        assert_eq!(radiance(s, ball), first);
    }
    // SAFETY: valid pointers.
    ok(unsafe { tc_scene_bake(s, &o, None, ptr::null_mut()) }, "bake after cancelling");
    assert_eq!(radiance(s, ball), first, "a bake after a cancel gives the same result");
    destroy(s);

    // A first bake cancelled while it meshes, then baked.
    let (s, ball) = new_scene();
    let mut cancel = Seen { cancel_at: 3, ..Seen::default() };
    fails(bake(s, &mut cancel), TC_CANCELLED, &["cancel"]);
    assert!(!cancel.stages.iter().any(|s| s.contains("tetrahedra kept")), "{:?}", cancel.stages);
    ok(bake(s, &mut Seen::default()), "bake after cancelling the first");
    assert_eq!(radiance(s, ball), first);
    destroy(s);
}

/// What a callback that re-enters its scene saw.
struct Reentry {
    scene: *mut TcScene,
    statuses: Vec<TcStatus>,
    destroyed: bool,
}

unsafe extern "C" fn reenter(user: *mut c_void, _stage: *const c_char, _fraction: f64) -> i32 {
    // SAFETY: `user` is the `Reentry` passed to the bake.
    let r = unsafe { &mut *user.cast::<Reentry>() };
    let mut count = 0u32;
    let mut handle = r.scene;
    // SAFETY: a live scene (in use by the bake calling us).
    unsafe {
        r.statuses.push(tc_scene_object_count(r.scene, &mut count));
        r.statuses.push(tc_scene_clear_lights(r.scene));
        tc_scene_destroy(&mut handle);
    }
    r.destroyed |= handle.is_null();
    0
}

/// A progress callback that calls back into the scene being baked gets TC_BUSY (no data race,
/// no use after free), and the bake completes.
#[test]
fn calls_on_a_scene_from_its_own_progress_callback_are_refused() {
    let s = scene();
    let ball = add(s, &Mesh::uv_sphere(10.0, 16, 8));
    // SAFETY: valid pointers.
    ok(unsafe { tc_scene_add_environment(s, [1.0; 3].as_ptr()) }, "sky");
    let mut user = Reentry { scene: s, statuses: Vec::new(), destroyed: false };
    // SAFETY: valid pointers.
    ok(unsafe { tc_scene_bake(s, &options(3_000), Some(reenter), (&raw mut user).cast()) }, "bake");
    assert!(!user.statuses.is_empty() && user.statuses.iter().all(|&st| st == TC_BUSY), "{:?}", user.statuses);
    assert!(!user.destroyed, "tc_scene_destroy from the callback must not free the scene being baked");
    let mut lights = 0;
    // SAFETY: valid pointers.
    ok(unsafe { tc_scene_light_count(s, &mut lights) }, "light count");
    assert_eq!(lights, 1, "clear_lights from the callback did nothing");
    assert!(radiance(s, ball).iter().all(|x| *x > 0.0));
    destroy(s);
}

/// Options: NULL means defaults; a struct shorter than this version's is refused, a longer
/// one (a newer caller) is read up to the fields this library knows; out-of-range values name
/// the field.
#[test]
fn options_are_checked() {
    let s = scene();
    add(s, &Mesh::uv_sphere(10.0, 16, 8));
    let mut o = options(2_000);
    o.size = 8;
    // SAFETY: valid pointers.
    unsafe {
        fails(tc_scene_bake(s, &o, None, ptr::null_mut()), TC_INVALID_ARGUMENT, &["size", "tc_bake_options_init"]);
        let mut o = options(2_000);
        o.method = 7;
        fails(tc_scene_bake(s, &o, None, ptr::null_mut()), TC_INVALID_ARGUMENT, &["method"]);
        let mut o = options(2_000);
        o.tolerance = f64::NAN;
        fails(tc_scene_bake(s, &o, None, ptr::null_mut()), TC_INVALID_ARGUMENT, &["tolerance"]);
        let mut o = options(2_000);
        o.tets = 0;
        fails(tc_scene_bake(s, &o, None, ptr::null_mut()), TC_INVALID_ARGUMENT, &["tets"]);
        // A newer caller's larger struct.
        #[repr(C)]
        struct Newer {
            base: TcBakeOptions,
            future: [u64; 4],
        }
        let mut newer = Newer { base: options(2_000), future: [u64::MAX; 4] };
        newer.base.size = size_of::<Newer>() as u32;
        ok(tc_scene_bake(s, (&raw const newer).cast(), None, ptr::null_mut()), "larger options struct");
    }
    destroy(s);
}
