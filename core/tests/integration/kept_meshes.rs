//! A bake that keeps its tet meshes (`bake_reusing`) re-meshes only the objects whose surface
//! changed, and equals a fresh bake bit for bit: after a medium change no object is meshed
//! again; after one object moved, only that one.

use glam::{DMat4, DVec3};
use transcut::gpu::Backend;
use transcut::light::Light;
use transcut::optics::Medium;
use transcut::{bake_reusing, bake_with, Bake, BakeOptions, MediumSource, Object, Progress, Scene, TransCutOptions};

use crate::common;
use common::uv_sphere;

fn scene() -> Scene {
    let marble = Medium::preset("marble").unwrap();
    let mut a = Object::new("a", uv_sphere(10.0, 24, 12), marble, 1.0);
    let mut b = Object::new("b", uv_sphere(8.0, 20, 10), marble, 1.0);
    a.transform = DMat4::from_translation(DVec3::new(0.0, 0.0, 25.0));
    b.transform = DMat4::from_translation(DVec3::new(3.0, 0.0, 0.0));
    let sun =
        Light::Directional { direction: DVec3::new(0.2, 0.0, -1.0).normalize(), irradiance: [3.0; 3], angular_diameter_deg: 0.0 };
    Scene { objects: vec![a, b], lights: vec![sun] }
}

fn options(tets: usize) -> BakeOptions {
    BakeOptions::with_method(TransCutOptions { tets, backend: Some(Backend::Cpu), ..TransCutOptions::default() })
}

fn reused(bake: &Bake) -> Vec<bool> {
    bake.objects.iter().map(|o| o.stats.mesh_reused).collect()
}

/// The radiance of every object, and the tets each was solved on.
fn answer(bake: &Bake) -> Vec<(Vec<[f64; 3]>, usize)> {
    bake.objects.iter().map(|o| (o.radiance.clone(), o.stats.tets)).collect()
}

#[test]
fn only_changed_surfaces_are_meshed_again_and_the_result_is_a_fresh_bakes() {
    let mut scene = scene();
    let first = bake_reusing(&scene, &options(5_000), &[], Progress::none()).unwrap();
    assert_eq!(reused(&first), [false, false]);
    assert!(first.meshes().iter().all(Option::is_some), "TransCut keeps a mesh per object");
    assert_eq!(answer(&first), answer(&bake_with(&scene, &options(5_000), Progress::none()).unwrap()));
    assert!(bake_with(&scene, &options(5_000), Progress::none()).unwrap().meshes().iter().all(Option::is_none));

    // A medium change: both meshes kept, the new medium assembled on them.
    let mut wax = Medium::preset("marble").unwrap();
    wax.sigma_a = [0.02, 0.01, 0.05];
    scene.objects[0].material = MediumSource::Homogeneous(wax).into();
    let medium = bake_reusing(&scene, &options(5_000), &first.meshes(), Progress::none()).unwrap();
    assert_eq!(reused(&medium), [true, true]);
    let fresh = bake_with(&scene, &options(5_000), Progress::none()).unwrap();
    assert_eq!(answer(&medium), answer(&fresh), "a kept mesh gives a fresh bake's radiance bit for bit");
    assert_ne!(medium.objects[0].radiance, first.objects[0].radiance, "the medium changed the radiance");
    let meshing = |b: &Bake| b.objects[0].stats.meshing.as_ref().map(|m| (m.tets, m.vertices, m.spacing, m.quality.clone()));
    assert_eq!(meshing(&medium), meshing(&fresh), "the statistics of the meshing that made it");

    // b moves: b alone is meshed again (a's shadow on it changes, a's own surface does not).
    scene.objects[1].transform = DMat4::from_translation(DVec3::new(5.0, 0.0, 0.0));
    let moved = bake_reusing(&scene, &options(5_000), &medium.meshes(), Progress::none()).unwrap();
    assert_eq!(reused(&moved), [true, false]);
    assert_eq!(answer(&moved), answer(&bake_with(&scene, &options(5_000), Progress::none()).unwrap()));

    // Another tet budget meshes everything again.
    assert_eq!(reused(&bake_reusing(&scene, &options(6_000), &moved.meshes(), Progress::none()).unwrap()), [false, false]);
}
