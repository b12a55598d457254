//! Objects and media through the ABI: presets, artist parameters, scale, counts.

use std::ptr;

use transcut_core::optics::{ArtistMapping, ArtistParams, Medium};

use super::abi::*;
use super::common::*;

/// Presets come back with the published coefficients; artist parameters convert exactly as
/// the core's conversion (at the object's mm per unit at the time of the call).
#[test]
fn presets_and_artist_media() {
    let mut m: TcMedium = unsafe { std::mem::zeroed() };
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_medium_preset(cstr(c" SKIN1 "), &mut m), "preset");
    }
    let skin = Medium::preset("skin1").unwrap();
    assert_eq!((m.sigma_a, m.sigma_s_prime, m.eta, m.g), (skin.sigma_a, skin.sigma_s_prime, skin.eta, skin.g));

    // The dipole mapping: the radius is the reduced mean free path, η the IOR.
    let dipole = TcArtistMedium {
        albedo: [0.8, 0.6, 0.4],
        radius: [0.004, 0.002, 0.001],
        scale: 1.0,
        ior: 1.4,
        anisotropy: 0.0,
        mapping: TC_ARTIST_DIPOLE,
    };
    let params = ArtistParams {
        albedo: dipole.albedo,
        radius: dipole.radius,
        scale: 1.0,
        mm_per_unit: 1000.0,
        eta: 1.4,
        g: 0.0,
        mapping: ArtistMapping::Dipole,
    };
    let mut converted: TcMedium = unsafe { std::mem::zeroed() };
    // SAFETY: valid pointers.
    unsafe { ok(tc_medium_from_artist(&dipole, 1000.0, &mut converted), "from artist") };
    assert_eq!(converted.sigma_s_prime, params.to_medium().unwrap().sigma_s_prime);
    assert!((converted.sigma_s_prime[0] + converted.sigma_a[0] - 0.25).abs() < 1e-12, "1/(4 mm)");
    assert_eq!(converted.eta, 1.4);
    // Cycles' random walk, the default (mapping 0): the radius over 4π, index-matched.
    let walk = TcArtistMedium { mapping: TC_ARTIST_RANDOM_WALK, ..dipole };
    let mut walked: TcMedium = unsafe { std::mem::zeroed() };
    // SAFETY: valid pointers.
    unsafe { ok(tc_medium_from_artist(&walk, 1000.0, &mut walked), "from artist") };
    let expected = ArtistParams { mapping: ArtistMapping::RandomWalk, ..params }.to_medium().unwrap();
    assert_eq!(walked.sigma_s_prime, expected.sigma_s_prime);
    assert!((walked.sigma_s_prime[0] + walked.sigma_a[0] - std::f64::consts::PI).abs() < 1e-12, "4π/(4 mm)");
    assert_eq!(walked.eta, 1.0);
    let artist = dipole;

    // Through an object in metres: the same medium, so the same bake as with the coefficients.
    let mesh = Mesh::uv_sphere(0.01, 24, 12); // 10 mm in metres
    let bake = |use_artist: bool| {
        let s = scene();
        let ball = add(s, &mesh);
        // SAFETY: valid pointers.
        unsafe {
            ok(tc_object_set_scale(s, ball, 1000.0), "scale");
            if use_artist {
                ok(tc_object_set_medium_artist(s, ball, &artist), "artist");
            } else {
                ok(tc_object_set_medium(s, ball, &converted), "medium");
            }
            ok(tc_scene_add_environment(s, [1.0; 3].as_ptr()), "sky");
            ok(tc_scene_bake(s, &options(3_000), None, ptr::null_mut()), "bake");
        }
        let lo = radiance(s, ball);
        destroy(s);
        lo
    };
    assert_eq!(bake(true), bake(false));
}

/// Counts, indices in order of addition, vertex counts in the caller's numbering (also for
/// vertices no triangle uses).
#[test]
fn objects_are_numbered_and_counted() {
    let s = scene();
    let a = Mesh::uv_sphere(5.0, 12, 6);
    let mut b = Mesh::uv_sphere(3.0, 10, 5);
    for p in b.positions.chunks_exact_mut(3) {
        p[0] += 20.0;
    }
    b.positions.extend([100.0, 100.0, 100.0]); // an unused vertex keeps its slot
    assert_eq!(add(s, &a), 0);
    assert_eq!(add(s, &b), 1);
    let (mut objects, mut lights, mut n) = (0, 0, 0usize);
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_scene_object_count(s, &mut objects), "count");
        ok(tc_scene_add_environment(s, [0.5; 3].as_ptr()), "sky");
        ok(
            tc_scene_add_rect(
                s,
                [0.0, 0.0, 30.0].as_ptr(),
                [5.0, 0.0, 0.0].as_ptr(),
                [0.0, 5.0, 0.0].as_ptr(),
                [2.0; 3].as_ptr(),
                0,
            ),
            "rect",
        );
        ok(tc_scene_light_count(s, &mut lights), "lights");
        ok(tc_object_vertex_count(s, 1, &mut n), "vertex count");
    }
    assert_eq!((objects, lights, n), (2, 2, b.vertex_count()));
    // SAFETY: valid pointers.
    ok(unsafe { tc_scene_bake(s, &options(2_000), None, ptr::null_mut()) }, "bake");
    let lo = radiance(s, 1);
    assert_eq!(lo.len(), 3 * b.vertex_count());
    assert!(lo[..lo.len() - 3].iter().all(|x| *x > 0.0));
    // SAFETY: valid pointers.
    unsafe { ok(tc_scene_clear_lights(s), "clear") };
    // SAFETY: valid pointers.
    unsafe { ok(tc_scene_light_count(s, &mut lights), "lights") };
    assert_eq!(lights, 0);
    destroy(s);
}
