//! Objects given as ready tet meshes, and heterogeneous media through the scene API: each form
//! agrees with an equivalent one (a uniform voxel grid or identical layers equal a homogeneous
//! medium; a ready tet mesh equals the bake that meshed it), object-space fields move with
//! the object, and misuse is named.

use crate::common;

use glam::{DMat4, DVec3};
use transcut::light::Light;
use transcut::optics::Medium;
use transcut::volume::{Coefficients, Layers, PerTetMedia, VeinParams, Veins, VoxelGrid};
use transcut::{bake, Bake, BakeOptions, MediumSource, Object, Scene, SceneError, Shape, TransCutOptions};

fn marble() -> Medium {
    Medium::preset("marble").unwrap()
}

fn sun() -> Light {
    Light::Directional { direction: DVec3::new(0.3, -0.2, -1.0), irradiance: [1.0, 2.0, 3.0], angular_diameter_deg: 0.0 }
}

fn options() -> BakeOptions {
    BakeOptions::with_method(TransCutOptions { tets: 20_000, tolerance: 1e-10, ..TransCutOptions::default() })
}

/// The tet mesh a TransCut bake solved on.
fn tets_of(bake: &transcut::ObjectBake) -> &transcut::mesh::TetMesh {
    &bake.transcut().expect("a TransCut bake").tet_mesh
}

fn bake_one(object: Object) -> Bake {
    bake(&Scene { objects: vec![object], lights: vec![sun()] }, &options()).unwrap()
}

fn sphere_object(medium: MediumSource) -> Object {
    Object::with_shape("sphere", Shape::Surface(common::uv_sphere(10.0, 48, 24)), medium, 1.0)
}

/// Largest |a − b| / max(|b|, floor) over all vertices and channels.
fn max_relative_difference(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    assert_eq!(a.len(), b.len());
    let floor = 1e-3 * b.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
    a.iter().flatten().zip(b.iter().flatten()).map(|(x, y)| (x - y).abs() / y.abs().max(floor)).fold(0.0, f64::max)
}

#[test]
fn a_ready_tet_mesh_bakes_like_the_surface_it_was_meshed_from() {
    // Without shadows: the occluder of a surface object is the user's surface, that of a tet
    // mesh its boundary, and the two differ slightly near the terminator.
    let unshadowed = |object: Object| {
        bake(&Scene { objects: vec![object], lights: vec![sun()] }, &BakeOptions { shadows: false, ..options() }).unwrap()
    };
    let surface = unshadowed(sphere_object(marble().into()));
    let o = &surface.objects[0];
    let tets = unshadowed(Object::from_tets("tets", tets_of(o).clone(), marble().into(), 1.0));
    let t = &tets.objects[0];
    assert_eq!(t.radiance.len(), tets_of(o).vertex_count());
    assert!(t.stats.meshing.is_none() && o.stats.meshing.is_some());
    // Interior vertices have no outgoing radiance; boundary ones do.
    for (v, l) in t.radiance.iter().enumerate() {
        if !tets_of(o).is_boundary_vertex(v) {
            assert_eq!(*l, [0.0; 3]);
        }
    }
    let at_user = tets_of(o).sample_at_user_vertices(&t.radiance);
    let d = max_relative_difference(&at_user, &o.radiance);
    assert!(d < 1e-9, "ready tet mesh vs surface bake: {d:e}");
}

#[test]
fn uniform_voxels_and_identical_layers_equal_the_homogeneous_medium() {
    let m = marble();
    let reference = bake_one(sphere_object(m.into()));
    let c = Coefficients::new(m.sigma_a, m.sigma_s_prime);
    let grid = VoxelGrid::from_fn([4, 4, 4], DVec3::splat(-12.0), DVec3::splat(6.0), |_| c).unwrap();
    let voxels = bake_one(sphere_object(MediumSource::Voxels { grid, eta: m.eta, g: m.g }));
    let layers = Layers::new(&[(2.0, m), (f64::INFINITY, m)], 0.5).unwrap();
    let layered = bake_one(sphere_object(MediumSource::Layers(layers)));
    // Voxels store f32 (relative rounding 6e-8 of each coefficient); layers keep f64.
    for (what, b, tolerance) in [("voxels", &voxels, 1e-6), ("layers", &layered, 1e-9)] {
        let d = max_relative_difference(&b.objects[0].radiance, &reference.objects[0].radiance);
        assert!(d < tolerance, "{what} vs homogeneous: {d:e}");
        assert_eq!(b.objects[0].eta(), m.eta);
    }
}

#[test]
fn a_darker_outer_layer_darkens_the_surface_and_a_material_table_matches_per_tet_media() {
    let m = marble();
    let dark = Medium { sigma_a: [0.05, 0.08, 0.1], ..m };
    let reference = bake_one(sphere_object(m.into()));
    let layered = bake_one(sphere_object(MediumSource::Layers(Layers::new(&[(1.0, dark), (f64::INFINITY, m)], 0.2).unwrap())));
    let mean = |b: &Bake, c: usize| b.objects[0].radiance.iter().map(|l| l[c]).sum::<f64>();
    for c in 0..3 {
        assert!(mean(&layered, c) < 0.9 * mean(&reference, c), "channel {c}");
    }

    // The same two-material split as a table (ids on the tet mesh) and as per-tet values.
    let mut mesh = tets_of(&reference.objects[0]).clone();
    let ids: Vec<u32> = (0..mesh.tet_count()).map(|t| u32::from(mesh.tet_positions(t)[0].x > 0.0)).collect();
    mesh.set_materials(ids.clone()).unwrap();
    let table = bake_one(Object::from_tets("table", mesh.clone(), MediumSource::Table(vec![m, dark]), 1.0));
    let coefficients = ids
        .iter()
        .map(|&id| {
            let x = [m, dark][id as usize];
            Coefficients::new(x.sigma_a, x.sigma_s_prime)
        })
        .collect();
    let per_tet = PerTetMedia::new(coefficients, m.eta, m.g).unwrap();
    let values = bake_one(Object::from_tets("per tet", mesh, MediumSource::PerTet(per_tet), 1.0));
    let d = max_relative_difference(&values.objects[0].radiance, &table.objects[0].radiance);
    assert!(d < 1e-12, "per-tet vs table: {d:e}");
}

#[test]
fn object_space_veins_move_with_the_object() {
    let m = marble();
    let vein = Medium { sigma_a: [0.08, 0.1, 0.12], ..m };
    let veins = Veins::new(m, vein, 3, VeinParams { period: 4.0, ..VeinParams::default() }).unwrap();
    // One tet mesh, placed at the origin and translated, so only the medium can differ.
    let mesh = tets_of(&bake_one(sphere_object(m.into())).objects[0]).clone();
    let at_origin = bake_one(Object::from_tets("veined", mesh.clone(), MediumSource::Veins(veins.clone()), 1.0));
    let mut moved = Object::from_tets("veined", mesh.clone(), MediumSource::Veins(veins), 1.0);
    moved.transform = DMat4::from_translation(DVec3::new(7.25, -3.5, 11.0));
    let moved = bake_one(moved);
    // A sun is invariant under translation, so the veins (and the radiance) must travel along.
    let d = max_relative_difference(&moved.objects[0].radiance, &at_origin.objects[0].radiance);
    assert!(d < 1e-6, "translated veined sphere: {d:e}");
    // And the veins are really there: the radiance differs from plain marble.
    let plain = bake_one(Object::from_tets("plain", mesh, m.into(), 1.0));
    assert!(max_relative_difference(&at_origin.objects[0].radiance, &plain.objects[0].radiance) > 0.05);
}

#[test]
fn misused_media_are_named() {
    let m = marble();
    let per_tet = PerTetMedia::new(vec![Coefficients::new(m.sigma_a, m.sigma_s_prime); 10], m.eta, m.g).unwrap();
    let expect_invalid = |object: Object, needle: &str| {
        let err = bake(&Scene { objects: vec![object], lights: vec![sun()] }, &options()).unwrap_err();
        assert!(matches!(err, SceneError::InvalidObject { index: 0, .. }), "{err}");
        assert!(err.to_string().contains(needle), "{err}");
    };
    expect_invalid(sphere_object(MediumSource::PerTet(per_tet.clone())), "ready tet mesh");
    expect_invalid(sphere_object(MediumSource::Table(vec![])), "empty");
    let mesh = tets_of(&bake_one(sphere_object(m.into())).objects[0]).clone();
    let n = mesh.tet_count();
    expect_invalid(
        Object::from_tets("t", mesh.clone(), MediumSource::PerTet(per_tet), 1.0),
        &format!("10 tets but the tet mesh has {n}"),
    );
    let mut two = mesh;
    two.set_materials(vec![1; n]).unwrap();
    expect_invalid(Object::from_tets("t", two, MediumSource::Table(vec![m]), 1.0), "material id 1 but the table has 1 entries");
    let bad = Medium { sigma_a: [-1.0, 0.0, 0.0], ..m };
    expect_invalid(sphere_object(MediumSource::Table(vec![m, bad])), "material table entry 1");
}

#[test]
fn bake_progress_never_goes_back_and_ends_at_one() {
    use std::sync::Mutex;
    let seen = Mutex::new(Vec::new());
    let callback = |_: &str, f: f64| {
        seen.lock().unwrap().push(f);
        true
    };
    let scene = Scene { objects: vec![sphere_object(marble().into())], lights: vec![sun()] };
    transcut::bake_with(&scene, &options(), transcut::Progress::new(&callback)).unwrap();
    let seen = seen.into_inner().unwrap();
    assert!(seen.len() > 10, "{} reports", seen.len());
    assert!(seen.windows(2).all(|w| w[1] >= w[0]), "{seen:?}");
    assert_eq!(*seen.last().unwrap(), 1.0);
    // Meshing takes the first 60%, and its stages spread over it.
    assert!(seen.iter().any(|&f| f > 0.2 && f < 0.5), "{seen:?}");
}
