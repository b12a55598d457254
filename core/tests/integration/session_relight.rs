//! A session's relight equals a fresh bake under the new lights, shadows included: the live
//! states shadow with the bake's occluder (every object's surface), not only their own tets, so
//! one object's shadow on another is the same after a relight as in a bake.

use glam::{DMat4, DVec3};
use transcut::diffusion::Discretization;
use transcut::gpu::Backend;
use transcut::light::Light;
use transcut::mesher::Grading;
use transcut::optics::Medium;
use transcut::{BakeOptions, Object, Progress, Scene, Session, TransCutOptions};

use crate::common;
use common::uv_sphere;

fn sun(direction: DVec3) -> Light {
    Light::Directional { direction: direction.normalize(), irradiance: [3.0; 3], angular_diameter_deg: 0.0 }
}

fn scene(light: Light) -> Scene {
    let marble = Medium::preset("marble").unwrap();
    let mut a = Object::new("a", uv_sphere(10.0, 24, 12), marble, 1.0);
    let mut b = Object::new("b", uv_sphere(10.0, 24, 12), marble, 1.0);
    a.transform = DMat4::from_translation(DVec3::new(0.0, 0.0, 25.0));
    b.transform = DMat4::from_translation(DVec3::new(3.0, 0.0, 0.0));
    Scene { objects: vec![a, b], lights: vec![light] }
}

/// Also with graded tets and the fitted assembly: the session's updates assemble their systems
/// as the bake did (a relight on TransCut's system after a fitted bake would differ by the
/// discretisation: 3.5e-3 of the peak here).
#[test]
fn a_relight_equals_a_fresh_bake_with_one_object_shadowing_another() {
    let paper = TransCutOptions { tets: 6_000, tolerance: 1e-10, backend: Some(Backend::Cpu), ..TransCutOptions::default() };
    let graded_fitted = TransCutOptions {
        grading: Grading::Graded { layers: 1 }.into(),
        discretization: Discretization::ExponentiallyFitted,
        ..paper.clone()
    };
    for transcut in [paper, graded_fitted] {
        relight_equals_a_fresh_bake(&BakeOptions::with_method(transcut));
    }
}

fn relight_equals_a_fresh_bake(options: &BakeOptions) {
    let options = options.clone();
    assert!(options.shadows);
    let first = sun(DVec3::new(0.2, 0.0, -1.0));
    let second = sun(DVec3::new(-0.1, 0.1, -1.0)); // a sits between it and b's top
    let mut session = Session::bake(&scene(first), &options, Progress::none()).unwrap();
    session.relight(std::slice::from_ref(&second), Progress::none()).unwrap();
    let fresh = Session::bake(&scene(second), &options, Progress::none()).unwrap();
    for index in 0..2 {
        let relit = session.radiance(index).unwrap().unwrap();
        let expect = fresh.radiance(index).unwrap().unwrap();
        let peak = expect.iter().flatten().copied().fold(0.0, f64::max);
        let worst = relit.iter().flatten().zip(expect.iter().flatten()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        println!("object {index}: relit vs fresh bake, worst {:.2e} of the peak {peak:.3}", worst / peak);
        assert!(worst <= 1e-6 * peak, "object {index}: {worst} of {peak}");
    }
    // b is in a's shadow: its top is darker than a's.
    let top = |r: &[[f64; 3]]| r[0][0];
    assert!(top(&fresh.radiance(1).unwrap().unwrap()) < 0.5 * top(&fresh.radiance(0).unwrap().unwrap()));
}
