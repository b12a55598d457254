//! Baking through the scene API: the uniform sphere against its closed form, lighting direction,
//! user vertex order, and bad input.

use glam::{DMat4, DVec3};
use transcut::light::{Environment, Light};
use transcut::optics::{f_ext, Medium, UniformSphere};
use transcut::{bake, BakeOptions, Object, Scene, SceneError, TransCutOptions};

use crate::common;
use common::uv_sphere;

fn marble_eta_13() -> Medium {
    Medium::new([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.00], 1.3, 0.0).unwrap()
}

/// ARCHITECTURE.md's worked example: R = 10 mm marble (η = 1.3) under a constant environment of
/// radiance 1 gives Lo(x, n) = (0.9394, 0.9072, 0.8709) at every surface point.
#[test]
fn uniform_sphere_under_a_constant_sky_matches_the_closed_form() {
    let medium = marble_eta_13();
    let mesh = uv_sphere(10.0, 192, 96);
    let scene = Scene {
        objects: vec![Object::new("sphere", mesh.clone(), medium, 1.0)],
        lights: vec![Light::Environment(Environment::Constant([1.0; 3]))],
    };
    let result = bake(&scene, &BakeOptions::with_method(TransCutOptions { tets: 60_000, ..Default::default() })).unwrap();
    let o = &result.objects[0];
    assert_eq!(o.radiance.len(), scene.objects[0].shape.output_vertex_count());
    let q = std::f64::consts::PI * (1.0 - f_ext(1.3));
    let exact = UniformSphere::new(medium, 10.0, [q; 3]).unwrap().surface_radiance(1.0);
    for c in 0..3 {
        assert!((exact[c] - [0.9394, 0.9072, 0.8709][c]).abs() < 1e-3);
        let mean = o.radiance.iter().map(|l| l[c]).sum::<f64>() / o.radiance.len() as f64;
        let worst = o.radiance.iter().map(|l| (l[c] / exact[c] - 1.0).abs()).fold(0.0, f64::max);
        eprintln!("channel {c}: exact {:.4}, mean {mean:.4}, worst relative error {worst:.2e}", exact[c]);
        assert!(worst < 0.01, "channel {c}: worst relative error {worst}");
    }
    assert_eq!(o.stats.clamped_vertices, 0);
}

#[test]
fn the_lit_side_is_brighter_and_results_follow_the_users_vertex_order() {
    // Radius 10 mm at 60k tets resolves skin's blue channel (at 20 mm and 20k TransCut refuses it).
    let mesh = uv_sphere(10.0, 64, 32);
    let sun = Light::Directional { direction: DVec3::new(0.0, 0.0, -1.0), irradiance: [3.0; 3], angular_diameter_deg: 0.0 };
    let scene =
        Scene { objects: vec![Object::new("ball", mesh.clone(), Medium::preset("skin1").unwrap(), 1.0)], lights: vec![sun] };
    let r = bake(&scene, &BakeOptions::with_method(TransCutOptions { tets: 60_000, ..Default::default() })).unwrap();
    let lo = &r.objects[0].radiance;
    let top = lo[0]; // north pole faces the sun
    let bottom = lo[mesh.user_vertex_count() - 1];
    assert!(top.iter().zip(bottom).all(|(t, b)| *t > 10.0 * b), "top {top:?}, bottom {bottom:?}");
    // Moving the object moves the result with it: vertex i keeps its value.
    let mut moved = scene.clone();
    moved.objects[0].transform = DMat4::from_translation(DVec3::new(100.0, -5.0, 3.0));
    let r2 = bake(&moved, &BakeOptions::with_method(TransCutOptions { tets: 60_000, ..Default::default() })).unwrap();
    for (a, b) in lo.iter().zip(&r2.objects[0].radiance) {
        for c in 0..3 {
            assert!((a[c] - b[c]).abs() <= 1e-6 * a[c].abs().max(1e-3), "{a:?} vs {b:?}");
        }
    }
}

#[test]
fn bad_scenes_are_rejected_with_the_culprit_named() {
    let ball = Object::new("ball", uv_sphere(5.0, 16, 8), Medium::preset("marble").unwrap(), 1.0);
    let err = bake(&Scene::default(), &BakeOptions::default()).unwrap_err();
    assert!(matches!(err, SceneError::NoObjects));
    // A 1e-30 mm ball: refused up front as too small, not a solver failure.
    let mut tiny = ball.clone();
    tiny.mm_per_unit = 1e-31;
    let err = bake(&Scene { objects: vec![tiny], lights: vec![] }, &BakeOptions::default()).unwrap_err();
    assert!(matches!(err, SceneError::InvalidObject { index: 0, .. }), "{err}");
    assert!(err.to_string().contains("too small to bake") && err.to_string().contains("1e-6 mm"), "{err}");
    // Threads and samples above their bounds, named with the value and the bound.
    for (options, words) in [
        (BakeOptions { threads: 1000, ..BakeOptions::default() }, ["threads = 1000", "maximum of 256"]),
        (
            BakeOptions {
                source: transcut::light::SourceOptions { area_samples: u32::MAX as usize, ..Default::default() },
                ..BakeOptions::default()
            },
            ["area_samples = 4294967295", "at most 1048576"],
        ),
        (
            BakeOptions {
                source: transcut::light::SourceOptions { environment_samples: (1 << 20) + 1, ..Default::default() },
                ..BakeOptions::default()
            },
            ["environment_samples = 1048577", "at most 1048576"],
        ),
    ] {
        let err = bake(&Scene { objects: vec![ball.clone()], lights: vec![] }, &options).unwrap_err();
        assert!(words.iter().all(|w| err.to_string().contains(w)), "{err}");
    }
    let mut bad = ball.clone();
    bad.mm_per_unit = -1.0;
    let err = bake(&Scene { objects: vec![bad], lights: vec![] }, &BakeOptions::default()).unwrap_err();
    assert!(err.to_string().contains("object 0 (ball)") && err.to_string().contains("mm_per_unit"), "{err}");
    let nan_light = Light::Point { position: DVec3::new(f64::NAN, 0.0, 0.0), intensity: [1.0; 3] };
    let err = bake(&Scene { objects: vec![ball.clone()], lights: vec![nan_light] }, &BakeOptions::default()).unwrap_err();
    assert!(matches!(err, SceneError::Light(_)), "{err}");
    let err = bake(
        &Scene { objects: vec![ball], lights: vec![] },
        &BakeOptions::with_method(TransCutOptions { tolerance: 2.0, ..Default::default() }),
    )
    .unwrap_err();
    assert!(matches!(err, SceneError::InvalidOptions(_)), "{err}");
}
