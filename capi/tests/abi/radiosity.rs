//! Translucent radiosity through the ABI: diffuse objects added and set, the method's options
//! struct, the scene's statistics, a marble ball inside an emissive room against the room's
//! exact radiance, the coupled session's updates (relight, albedo, emission, medium) against
//! fresh bakes, and every misuse named with nothing changed.

use std::ptr;

use super::abi::*;
use super::common::*;

/// A closed axis-aligned cube of half-side `h` centred at the origin: 8 corners, 12 triangles
/// wound counter-clockwise from outside.
fn cube(h: f32) -> Mesh {
    let mut positions = Vec::new();
    for i in 0..8u32 {
        positions.extend([i & 1, (i >> 1) & 1, (i >> 2) & 1].map(|b| if b == 1 { h } else { -h }));
    }
    #[rustfmt::skip]
    let indices = vec![
        0, 2, 3, 0, 3, 1, // z = -h, normal -z
        4, 5, 7, 4, 7, 6, // z = +h
        0, 1, 5, 0, 5, 4, // y = -h
        2, 6, 7, 2, 7, 3, // y = +h
        0, 4, 6, 0, 6, 2, // x = -h
        1, 3, 7, 1, 7, 5, // x = +h
    ];
    Mesh { positions, indices }
}

/// Adds `mesh` as a diffuse object of `albedo`.
fn add_diffuse(scene: *mut TcScene, mesh: &Mesh, albedo: [f64; 3]) -> u32 {
    let mut object = u32::MAX;
    // SAFETY: arrays of the given lengths.
    let status = unsafe {
        tc_scene_add_diffuse_mesh(
            scene,
            mesh.positions.as_ptr(),
            mesh.vertex_count(),
            mesh.indices.as_ptr(),
            mesh.indices.len(),
            albedo.as_ptr(),
            &mut object,
        )
    };
    ok(status, "tc_scene_add_diffuse_mesh");
    object
}

/// Radiosity's defaults from the library.
fn radiosity_defaults() -> TcRadiosityOptions {
    // SAFETY: an all-zero struct is a valid value to overwrite.
    let mut r: TcRadiosityOptions = unsafe { std::mem::zeroed() };
    // SAFETY: a valid pointer and its size.
    ok(unsafe { tc_radiosity_options_init(&mut r, size_of::<TcRadiosityOptions>()) }, "tc_radiosity_options_init");
    r
}

/// A fast radiosity bake: `tets` per translucent object, 12 mm patches, 256 rays, on the CPU.
fn fast(tets: u64) -> (TcBakeOptions, TcRadiosityOptions) {
    let mut o = options(tets);
    o.method = TC_METHOD_RADIOSITY;
    o.backend = TC_BACKEND_CPU;
    let r = TcRadiosityOptions { patch_size_mm: 12.0, rays_per_patch: 256, tolerance: 1e-4, ..radiosity_defaults() };
    (o, r)
}

/// Bakes `scene` with `o` and the radiosity options `r`.
fn bake_with(scene: *mut TcScene, mut o: TcBakeOptions, r: &TcRadiosityOptions) -> TcStatus {
    o.method_options = ptr::from_ref(r).cast();
    // SAFETY: valid pointers that outlive the call.
    unsafe { tc_scene_bake(scene, &o, None, ptr::null_mut()) }
}

/// A marble ball (R = 10 mm) inside a closed room (a 60 mm cube reflecting inwards) of albedo
/// 0 emitting `emission`, no lights: the ball's index, the room's.
fn ball_in_room(emission: [f64; 3]) -> (*mut TcScene, u32, u32) {
    let s = scene();
    let ball = add(s, &Mesh::uv_sphere(10.0, 16, 8));
    let room = add_diffuse(s, &cube(30.0), [0.0; 3]);
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_object_set_medium_preset(s, ball, cstr(c"marble")), "preset");
        ok(tc_object_set_sides(s, room, TC_SIDES_BACK), "sides");
        ok(tc_object_set_emission(s, room, emission.as_ptr()), "emission");
    }
    (s, ball, room)
}

#[test]
fn the_options_defaults_are_the_cores_and_the_struct_is_filled_as_far_as_its_size() {
    let r = radiosity_defaults();
    assert_eq!(r.size as usize, size_of::<TcRadiosityOptions>());
    assert_eq!((r.iteration, r.patch_size_mm, r.rays_per_patch, r.max_iterations), (TC_RADIOSITY_JACOBI, 0.0, 512, 200));
    assert_eq!((r.tolerance, r.covered_fraction, r.bounces, r.solver), (1e-3, 0.1, 0, TC_SOLVER_DEFAULT));
    assert_eq!((r.grading, r.discretization), (TC_GRADING_AUTO, TC_DISCRETIZATION_FITTED_LAYER));
    let mut count = 0u32;
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_method_from_name(cstr(c"radiosity"), &mut count), "from name");
        assert_eq!(count, TC_METHOD_RADIOSITY);
        let mut t = TcRadiosityOptions { size: 3, ..r };
        fails(tc_radiosity_options_init(&mut t, 16), TC_INVALID_ARGUMENT, &["size = 16"]);
        assert_eq!(t, TcRadiosityOptions { size: 3, ..r }, "untouched on failure");
        // A caller of the first version (56 bytes, no grading or discretization) is served.
        let mut v1 = TcRadiosityOptions { grading: 7, discretization: 7, ..r };
        ok(tc_radiosity_options_init(&mut v1, 56), "tc_radiosity_options_init, 56 bytes");
        assert_eq!(v1, TcRadiosityOptions { size: 56, grading: 7, discretization: 7, ..r });
        fails(tc_radiosity_options_init(ptr::null_mut(), size_of::<TcRadiosityOptions>()), TC_NULL_POINTER, &["options"]);
    }
}

/// The room reflects nothing, so its radiance is its emission over π at every vertex, exactly;
/// the ball, lit only by the room, is bright everywhere; the statistics are the scene's.
#[test]
fn a_ball_in_an_emissive_room_bakes_and_the_room_has_its_exact_radiance() {
    let emission = [1.0, 0.5, 0.25];
    let (s, ball, room) = ball_in_room(emission);
    let (o, r) = fast(2_000);
    ok(bake_with(s, o, &r), "radiosity bake");
    let lo = radiance(s, room);
    assert_eq!(lo.len(), 3 * 8);
    for v in lo.chunks_exact(3) {
        for c in 0..3 {
            let want = (emission[c] / std::f64::consts::PI) as f32;
            assert!((v[c] - want).abs() <= 1e-6 * want, "room: {v:?}, want {want} in channel {c}");
        }
    }
    let lo = radiance(s, ball);
    assert!(lo.iter().all(|x| x.is_finite() && *x > 0.0), "ball: {lo:?}");
    let mut stats: TcRadiosityStats = unsafe { std::mem::zeroed() };
    stats.size = size_of::<TcRadiosityStats>() as u32;
    let mut kind = 9u32;
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_scene_radiosity_stats(s, &mut stats), "stats");
        ok(tc_object_material(s, room, &mut kind), "material");
        assert_eq!(kind, TC_MATERIAL_DIFFUSE);
        ok(tc_object_material(s, ball, &mut kind), "material");
        assert_eq!(kind, TC_MATERIAL_TRANSLUCENT);
    }
    assert_eq!(stats.size as usize, size_of::<TcRadiosityStats>());
    assert!(stats.patches > stats.translucent_patches && stats.translucent_patches > 0, "{stats:?}");
    assert!(stats.nonzeros > 0 && stats.form_factor_bytes == 8 * stats.nonzeros, "{stats:?}");
    assert_eq!(stats.patch_size_mm, 12.0);
    assert!(stats.iterations >= 1 && stats.scatterings >= 1, "{stats:?}");
    assert!(stats.estimated_error < 1e-4 && stats.energy_defect < 1e-2, "{stats:?}");
    assert!(stats.form_factor_ms >= 0.0 && stats.solve_ms > 0.0, "{stats:?}");
    destroy(s);
}

/// The methods that bake objects alone refuse a diffuse object, naming radiosity; the
/// statistics exist only after a radiosity bake and while it describes the scene.
#[test]
fn other_methods_refuse_diffuse_objects_and_the_statistics_need_a_radiosity_bake() {
    let (s, _, room) = ball_in_room([1.0; 3]);
    let mut stats: TcRadiosityStats = unsafe { std::mem::zeroed() };
    stats.size = size_of::<TcRadiosityStats>() as u32;
    // SAFETY: valid pointers.
    unsafe {
        fails(tc_scene_radiosity_stats(s, &mut stats), TC_NOT_BAKED, &["tc_scene_bake"]);
        let mut o = options(2_000);
        o.backend = TC_BACKEND_CPU;
        fails(tc_scene_bake(s, &o, None, ptr::null_mut()), TC_UNSUPPORTED, &["transcut", "radiosity"]);
        o.method = TC_METHOD_HIERARCHICAL_DIPOLE;
        fails(tc_scene_bake(s, &o, None, ptr::null_mut()), TC_UNSUPPORTED, &["hierarchical-dipole", "radiosity"]);
        let (o, r) = fast(2_000);
        ok(bake_with(s, o, &r), "radiosity bake");
        stats.size = 8;
        fails(tc_scene_radiosity_stats(s, &mut stats), TC_INVALID_ARGUMENT, &["sizeof(TcRadiosityStats)"]);
        assert_eq!(stats.patches, 0, "nothing written on failure");
        stats.size = size_of::<TcRadiosityStats>() as u32;
        ok(tc_scene_radiosity_stats(s, &mut stats), "stats");
        ok(tc_object_set_emission(s, room, [2.0; 3].as_ptr()), "a change");
        fails(tc_scene_radiosity_stats(s, &mut stats), TC_NOT_BAKED, &["tc_scene_bake"]);
        fails(tc_scene_radiosity_stats(s, ptr::null_mut()), TC_NULL_POINTER, &["out"]);
    }
    destroy(s);
    // A TransCut bake has no radiosity statistics.
    let s = scene();
    add(s, &Mesh::uv_sphere(10.0, 16, 8));
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_scene_add_sun(s, [0.0, 0.0, -1.0].as_ptr(), [1.0; 3].as_ptr(), 0.0), "sun");
        let mut o = options(2_000);
        o.backend = TC_BACKEND_CPU;
        ok(tc_scene_bake(s, &o, None, ptr::null_mut()), "transcut bake");
        fails(tc_scene_radiosity_stats(s, &mut stats), TC_UNSUPPORTED, &["transcut", "radiosity"]);
    }
    destroy(s);
}

/// Bad diffuse input is named and changes nothing: the room still reflects nothing after every
/// refused call (its radiance is still its emission over π), and the ball keeps its medium.
#[test]
fn bad_diffuse_input_is_named_and_changes_nothing() {
    let (s, ball, room) = ball_in_room([1.0; 3]);
    let cube = cube(30.0);
    let mut object = 77u32;
    // SAFETY: valid pointers unless NULL on purpose.
    unsafe {
        let add = |albedo: *const f64, object: &mut u32| {
            tc_scene_add_diffuse_mesh(
                s,
                cube.positions.as_ptr(),
                cube.vertex_count(),
                cube.indices.as_ptr(),
                cube.indices.len(),
                albedo,
                object,
            )
        };
        fails(add([1.0, 0.5, 0.5].as_ptr(), &mut object), TC_INVALID_ARGUMENT, &["albedo"]);
        fails(add([f64::NAN, 0.5, 0.5].as_ptr(), &mut object), TC_INVALID_ARGUMENT, &["albedo"]);
        fails(add(ptr::null(), &mut object), TC_NULL_POINTER, &["`albedo`"]);
        fails(
            tc_scene_add_diffuse_mesh(s, cube.positions.as_ptr(), 8, cube.indices.as_ptr(), 7, [0.5; 3].as_ptr(), &mut object),
            TC_INVALID_MESH,
            &["multiple of 3"],
        );
        assert_eq!(object, 77, "untouched on failure");
        let mut n = 0u32;
        ok(tc_scene_object_count(s, &mut n), "count");
        assert_eq!(n, 2, "no object added");

        let room_name = format!("object {room}");
        fails(tc_object_set_albedo(s, room, [0.5, 1.0, 0.5].as_ptr()), TC_INVALID_ARGUMENT, &[&room_name, "albedo"]);
        fails(tc_object_set_albedo(s, room, [0.5, -0.1, 0.5].as_ptr()), TC_INVALID_ARGUMENT, &["albedo"]);
        fails(tc_object_set_emission(s, room, [0.0, -1.0, 0.0].as_ptr()), TC_INVALID_ARGUMENT, &[&room_name, "emission"]);
        fails(tc_object_set_emission(s, room, [f64::INFINITY, 0.0, 0.0].as_ptr()), TC_INVALID_ARGUMENT, &["emission"]);
        fails(tc_object_set_emission(s, room, ptr::null()), TC_NULL_POINTER, &["`emission`"]);
        fails(tc_object_set_sides(s, room, 3), TC_INVALID_ARGUMENT, &["sides = 3", "TC_SIDES_BACK = 2"]);
        fails(tc_object_set_albedo(s, 9, [0.5; 3].as_ptr()), TC_INVALID_HANDLE, &["object 9"]);
        let ball_name = format!("object {ball}");
        for status in [
            tc_object_set_albedo(s, ball, [0.5; 3].as_ptr()),
            tc_object_set_emission(s, ball, [0.5; 3].as_ptr()),
            tc_object_set_sides(s, ball, TC_SIDES_FRONT),
        ] {
            fails(status, TC_INVALID_ARGUMENT, &[&ball_name, "translucent"]);
        }
        fails(tc_object_set_medium_preset(s, room, cstr(c"marble")), TC_INVALID_ARGUMENT, &[&room_name, "diffuse"]);
        let medium = TcMedium { sigma_a: [0.01; 3], sigma_s_prime: [1.0; 3], eta: 1.3, g: 0.0 };
        fails(tc_object_set_medium(s, room, &medium), TC_INVALID_ARGUMENT, &["diffuse", "tc_scene_add_mesh"]);
        let mut kind = 9u32;
        ok(tc_object_material(s, room, &mut kind), "material");
        assert_eq!(kind, TC_MATERIAL_DIFFUSE);
        fails(tc_object_material(s, room, ptr::null_mut()), TC_NULL_POINTER, &["out"]);
    }
    let (o, r) = fast(2_000);
    ok(bake_with(s, o, &r), "the scene still bakes");
    let want = (1.0 / std::f64::consts::PI) as f32;
    assert!(radiance(s, room).iter().all(|x| (x - want).abs() <= 1e-6 * want), "the room was changed");
    destroy(s);
}

/// Every radiosity option out of range names its field; so does a short or misaligned struct.
#[test]
fn bad_radiosity_options_name_the_field() {
    let (s, _, _) = ball_in_room([1.0; 3]);
    let (o, good) = fast(2_000);
    let cases: Vec<(TcRadiosityOptions, &[&str])> = vec![
        (TcRadiosityOptions { iteration: 3, ..good }, &["method_options->iteration = 3", "TC_RADIOSITY_BICGSTAB = 2"]),
        (TcRadiosityOptions { patch_size_mm: -1.0, ..good }, &["method_options->patch_size_mm = -1"]),
        (TcRadiosityOptions { patch_size_mm: f64::NAN, ..good }, &["patch_size_mm = NaN"]),
        (TcRadiosityOptions { rays_per_patch: 0, ..good }, &["rays_per_patch = 0"]),
        (TcRadiosityOptions { rays_per_patch: TC_MAX_RAYS_PER_PATCH + 1, ..good }, &["rays_per_patch = 16777217"]),
        (TcRadiosityOptions { max_iterations: 0, ..good }, &["max_iterations = 0"]),
        (TcRadiosityOptions { tolerance: 1.0, ..good }, &["method_options->tolerance = 1"]),
        (TcRadiosityOptions { covered_fraction: 0.0, ..good }, &["covered_fraction = 0"]),
        (TcRadiosityOptions { bounces: TC_MAX_RADIOSITY_ITERATIONS + 1, ..good }, &["bounces = 10001"]),
        (TcRadiosityOptions { bounces: 2, iteration: TC_RADIOSITY_GAUSS_SEIDEL, ..good }, &["bounces = 2", "JACOBI"]),
        (TcRadiosityOptions { solver: 99, ..good }, &["method_options->solver = 99"]),
        (TcRadiosityOptions { size: 8, ..good }, &["sizeof(TcRadiosityOptions)", "tc_radiosity_options_init"]),
    ];
    for (r, needles) in cases {
        let status = bake_with(s, o, &r);
        fails(status, TC_INVALID_ARGUMENT, needles);
    }
    let mut bad_tets = o;
    bad_tets.tets = 0;
    fails(bake_with(s, bad_tets, &good), TC_INVALID_ARGUMENT, &["tets"]);
    let bytes = [0u64; 16];
    let mut misaligned = o;
    misaligned.method_options = bytes.as_ptr().cast::<u8>().wrapping_add(1).cast();
    // SAFETY: valid pointers; the misaligned one is refused before it is read.
    fails(unsafe { tc_scene_bake(s, &misaligned, None, ptr::null_mut()) }, TC_INVALID_ARGUMENT, &["not aligned"]);
    // One exact bounce with Jacobi is fine, and NULL method options are the defaults (not run
    // here: the default patch size is fine-grained).
    ok(bake_with(s, o, &TcRadiosityOptions { bounces: 1, ..good }), "one bounce");
    destroy(s);
}

/// An open diffuse surface (a floor) is accepted, and TC_SIDES_FRONT with it.
#[test]
fn an_open_diffuse_surface_is_accepted() {
    let s = scene();
    let floor = Mesh {
        positions: vec![-50.0, -50.0, 0.0, 50.0, -50.0, 0.0, 50.0, 50.0, 0.0, -50.0, 50.0, 0.0],
        indices: vec![0, 1, 2, 0, 2, 3],
    };
    let f = add_diffuse(s, &floor, [0.5; 3]);
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_object_set_sides(s, f, TC_SIDES_FRONT), "front");
        ok(tc_scene_add_point(s, [0.0, 0.0, 40.0].as_ptr(), [1000.0; 3].as_ptr()), "light");
    }
    let (o, r) = fast(2_000);
    ok(bake_with(s, o, &TcRadiosityOptions { patch_size_mm: 25.0, ..r }), "floor");
    let lo = radiance(s, f);
    assert!(lo.iter().all(|x| x.is_finite() && *x > 0.0), "{lo:?}");
    destroy(s);
}

/// The ball in a grey room (albedo 0.5, emitting 0.5) that reflects inwards, baked: the scene,
/// the ball, the room.
fn grey_room() -> (*mut TcScene, u32, u32) {
    let (s, ball, room) = ball_in_room([0.5; 3]);
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_set_albedo(s, room, [0.5; 3].as_ptr()) }, "albedo");
    (s, ball, room)
}

/// Bakes `s` with the fast options.
fn bake_fast(s: *mut TcScene) {
    let (o, r) = fast(2_000);
    ok(bake_with(s, o, &r), "radiosity bake");
}

/// Every object's radiance.
fn radiances(s: *mut TcScene, objects: &[u32]) -> Vec<Vec<f32>> {
    objects.iter().map(|&o| radiance(s, o)).collect()
}

/// The largest difference of `a` and `b` relative to the largest value of `b`.
fn relative_difference(a: &[Vec<f32>], b: &[Vec<f32>]) -> f64 {
    let max = b.iter().flatten().fold(0.0f32, |m, &x| m.max(x.abs()));
    let diff = a.iter().flatten().zip(b.iter().flatten()).fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
    assert!(a.iter().map(Vec::len).eq(b.iter().map(Vec::len)), "different vertex counts");
    f64::from(diff / max)
}

/// A red point light inside the room, above the ball.
fn add_lamp(s: *mut TcScene) {
    // SAFETY: valid pointers.
    ok(unsafe { tc_scene_add_point(s, [0.0, 20.0, 0.0].as_ptr(), [300.0, 100.0, 50.0].as_ptr()) }, "point light");
}

/// `tc_scene_relight` of a radiosity bake re-solves the whole coupled scene under the new lights:
/// within the solve's tolerance of a fresh bake under them, the statistics those of the solve.
#[test]
fn a_relit_radiosity_bake_equals_a_fresh_bake_under_the_new_lights() {
    let (s, ball, room) = grey_room();
    bake_fast(s);
    let before = radiances(s, &[ball, room]);
    add_lamp(s);
    let mut stats: TcRadiosityStats = unsafe { std::mem::zeroed() };
    stats.size = size_of::<TcRadiosityStats>() as u32;
    // SAFETY: valid pointers.
    unsafe {
        fails(tc_object_radiance(s, ball, [0.0f32; 3].as_mut_ptr(), 3), TC_NOT_BAKED, &["tc_scene_relight"]);
        ok(tc_scene_relight(s, None, ptr::null_mut()), "relight");
        ok(tc_scene_radiosity_stats(s, &mut stats), "stats after the relight");
    }
    let relit = radiances(s, &[ball, room]);
    assert!(stats.iterations >= 1 && stats.estimated_error < 1e-4, "{stats:?}");
    let (fresh, fresh_ball, fresh_room) = grey_room();
    add_lamp(fresh);
    bake_fast(fresh);
    let want = radiances(fresh, &[fresh_ball, fresh_room]);
    let (d, change) = (relative_difference(&relit, &want), relative_difference(&before, &want));
    eprintln!("relight: {d:.2e} from a fresh bake (the lamp changed the radiance by {change:.2})");
    assert!(d < 1e-3, "relit vs fresh bake: {d:.2e}");
    assert!(change > 0.1, "the lamp changed the radiance by {change:.2e} only");
    destroy(s);
    destroy(fresh);
}

/// `tc_object_edit_albedo` and `tc_object_edit_emission` re-solve the baked scene with the new
/// value: within the solve's tolerance of a fresh bake with it, the results kept, and the
/// scene's description changed too, so baking again gives the same.
#[test]
fn edit_albedo_and_emission_equal_fresh_bakes_with_the_new_values() {
    let (s, ball, room) = grey_room();
    bake_fast(s);
    let before = radiances(s, &[ball, room]);
    let albedo = [0.7, 0.3, 0.1];
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_edit_albedo(s, room, albedo.as_ptr()) }, "edit albedo");
    let edited = radiances(s, &[ball, room]);
    let (fresh, fresh_ball, fresh_room) = grey_room();
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_set_albedo(fresh, fresh_room, albedo.as_ptr()) }, "albedo");
    bake_fast(fresh);
    let want = radiances(fresh, &[fresh_ball, fresh_room]);
    let (d, change) = (relative_difference(&edited, &want), relative_difference(&before, &want));
    eprintln!("edit albedo: {d:.2e} from a fresh bake (the albedo changed the radiance by {change:.2})");
    assert!(d < 1e-3 && change > 0.1, "edited vs fresh bake: {d:.2e}, change {change:.2e}");
    // The scene's description has the albedo: a bake of it now is the fresh bake.
    bake_fast(s);
    let rebaked = radiances(s, &[ball, room]);
    assert!(relative_difference(&rebaked, &want) < 1e-6, "a rebake after the edit differs from the fresh bake");

    let emission = [2.0, 1.0, 0.5];
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_edit_emission(s, room, emission.as_ptr()) }, "edit emission");
    let edited = radiances(s, &[ball, room]);
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_set_emission(fresh, fresh_room, emission.as_ptr()) }, "emission");
    bake_fast(fresh);
    let want = radiances(fresh, &[fresh_ball, fresh_room]);
    let d = relative_difference(&edited, &want);
    eprintln!("edit emission: {d:.2e} from a fresh bake");
    assert!(d < 1e-3, "edited vs fresh bake: {d:.2e}");
    destroy(s);
    destroy(fresh);
}

/// `tc_object_edit_medium` on a radiosity bake puts a whole new medium (σa, σ′s of the edit,
/// the object's η and g) on a translucent object: a fresh bake with that medium.
#[test]
fn a_whole_medium_edit_of_a_radiosity_bake_equals_a_fresh_bake() {
    let (s, ball, room) = grey_room();
    bake_fast(s);
    let before = radiances(s, &[ball, room]);
    let milky = TcMedium { sigma_a: [0.05, 0.01, 0.02], sigma_s_prime: [0.8, 1.0, 1.2], eta: 1.5, g: 0.0 };
    let mut edit: TcMediumEdit = unsafe { std::mem::zeroed() };
    edit.size = size_of::<TcMediumEdit>() as u32;
    edit.region = TC_REGION_ALL;
    edit.op = TC_MEDIUM_ASSIGN;
    edit.sigma_a = milky.sigma_a;
    edit.sigma_s_prime = milky.sigma_s_prime;
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_edit_medium(s, ball, &edit) }, "edit medium");
    let edited = radiances(s, &[ball, room]);
    let (fresh, fresh_ball, fresh_room) = grey_room();
    // The edit keeps the object's η and g: marble's 1.5 and 0.
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_set_medium(fresh, fresh_ball, &milky) }, "medium");
    bake_fast(fresh);
    let want = radiances(fresh, &[fresh_ball, fresh_room]);
    let (d, change) = (relative_difference(&edited, &want), relative_difference(&before, &want));
    eprintln!("edit medium: {d:.2e} from a fresh bake (the medium changed the radiance by {change:.2})");
    assert!(d < 1e-3 && change > 0.1, "edited vs fresh bake: {d:.2e}, change {change:.2e}");
    destroy(s);
    destroy(fresh);
}

/// The coupled edits name what is wrong and change nothing: NULL, before a bake, after a bake
/// by another method, a value out of range, the wrong kind of object, a medium edit of a
/// region or by an operation the coupled scene cannot take.
#[test]
fn bad_coupled_edits_are_named_and_change_nothing() {
    let (s, ball, room) = grey_room();
    let mut edit: TcMediumEdit = unsafe { std::mem::zeroed() };
    edit.size = size_of::<TcMediumEdit>() as u32;
    edit.sigma_a = [0.01; 3];
    edit.sigma_s_prime = [1.0; 3];
    let room_name = format!("object {room}");
    // SAFETY: valid pointers unless NULL on purpose.
    unsafe {
        fails(tc_object_edit_albedo(s, room, [0.3; 3].as_ptr()), TC_NOT_BAKED, &["tc_scene_bake"]);
        fails(tc_object_edit_emission(s, room, [0.3; 3].as_ptr()), TC_NOT_BAKED, &["tc_scene_bake"]);
    }
    bake_fast(s);
    let before = radiances(s, &[ball, room]);
    let mut stats: TcRadiosityStats = unsafe { std::mem::zeroed() };
    stats.size = size_of::<TcRadiosityStats>() as u32;
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_scene_radiosity_stats(s, &mut stats), "stats");
        fails(tc_object_edit_albedo(s, room, ptr::null()), TC_NULL_POINTER, &["`albedo`"]);
        fails(tc_object_edit_emission(s, room, ptr::null()), TC_NULL_POINTER, &["`emission`"]);
        fails(tc_object_edit_albedo(s, room, [0.5, 1.0, 0.5].as_ptr()), TC_INVALID_ARGUMENT, &[&room_name, "albedo", "[0, 1)"]);
        fails(tc_object_edit_albedo(s, room, [f64::NAN, 0.5, 0.5].as_ptr()), TC_INVALID_ARGUMENT, &[&room_name, "albedo"]);
        fails(tc_object_edit_emission(s, room, [0.0, -1.0, 0.0].as_ptr()), TC_INVALID_ARGUMENT, &[&room_name, "emission"]);
        fails(tc_object_edit_emission(s, room, [f64::INFINITY, 0.0, 0.0].as_ptr()), TC_INVALID_ARGUMENT, &["emission"]);
        fails(
            tc_object_edit_albedo(s, ball, [0.5; 3].as_ptr()),
            TC_INVALID_ARGUMENT,
            &[&format!("object {ball}"), "translucent"],
        );
        fails(tc_object_edit_albedo(s, 9, [0.5; 3].as_ptr()), TC_INVALID_HANDLE, &["object 9"]);
        edit.region = TC_REGION_SPHERE;
        edit.radius = 5.0;
        fails(tc_object_edit_medium(s, ball, &edit), TC_UNSUPPORTED, &["radiosity", "TC_REGION_ALL", "TC_MEDIUM_ASSIGN"]);
        edit.region = TC_REGION_ALL;
        edit.op = TC_MEDIUM_SCALE;
        fails(tc_object_edit_medium(s, ball, &edit), TC_UNSUPPORTED, &["radiosity", "TC_MEDIUM_ASSIGN"]);
        edit.op = TC_MEDIUM_ASSIGN;
        fails(tc_object_edit_medium(s, room, &edit), TC_INVALID_ARGUMENT, &[&room_name, "diffuse", "tc_object_edit_albedo"]);
        edit.sigma_a = [-1.0; 3];
        fails(tc_object_edit_medium(s, ball, &edit), TC_INVALID_ARGUMENT, &["sigma_a"]);
        for (object, what) in [(ball, "paint"), (room, "paint")] {
            let marble = TcMedium { sigma_a: [0.01; 3], sigma_s_prime: [1.0; 3], eta: 1.3, g: 0.0 };
            let status = tc_object_paint(s, object, [0.0, 0.0, 10.0].as_ptr(), 1, 2.0, &marble, 1.0);
            fails(status, TC_UNSUPPORTED, &["radiosity", what]);
        }
        let mut after: TcRadiosityStats = std::mem::zeroed();
        after.size = size_of::<TcRadiosityStats>() as u32;
        ok(tc_scene_radiosity_stats(s, &mut after), "stats");
        assert_eq!(after, stats, "the statistics changed on a refused edit");
        let mut kind = 9u32;
        ok(tc_object_material(s, room, &mut kind), "material");
        assert_eq!(kind, TC_MATERIAL_DIFFUSE);
    }
    assert_eq!(radiances(s, &[ball, room]), before, "a refused edit changed the radiance");
    // A cancelled edit changes nothing either.
    unsafe extern "C" fn cancel(_: *mut std::ffi::c_void, _: *const std::ffi::c_char, _: f64) -> i32 {
        1
    }
    // SAFETY: valid pointers; the callback needs no user data.
    unsafe {
        ok(tc_scene_set_progress(s, Some(cancel), ptr::null_mut()), "progress");
        fails(tc_object_edit_albedo(s, room, [0.2; 3].as_ptr()), TC_CANCELLED, &[]);
        ok(tc_scene_set_progress(s, None, ptr::null_mut()), "no progress");
    }
    assert_eq!(radiances(s, &[ball, room]), before, "a cancelled edit changed the radiance");
    // The description was not changed either: a rebake gives the bake's radiance.
    bake_fast(s);
    assert!(relative_difference(&radiances(s, &[ball, room]), &before) < 1e-6, "a refused edit changed the scene");
    destroy(s);

    // A TransCut bake has no coupled edits.
    let s = scene();
    let ball = add(s, &Mesh::uv_sphere(10.0, 16, 8));
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_scene_add_sun(s, [0.0, 0.0, -1.0].as_ptr(), [1.0; 3].as_ptr(), 0.0), "sun");
        let mut o = options(2_000);
        o.backend = TC_BACKEND_CPU;
        ok(tc_scene_bake(s, &o, None, ptr::null_mut()), "transcut bake");
        fails(tc_object_edit_albedo(s, ball, [0.5; 3].as_ptr()), TC_UNSUPPORTED, &["transcut", "albedo"]);
        fails(tc_object_edit_emission(s, ball, [0.5; 3].as_ptr()), TC_UNSUPPORTED, &["transcut", "emission"]);
    }
    destroy(s);
}
