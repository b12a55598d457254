//! Editing through the ABI: relight and material edits against fresh bakes, a plane cut against
//! the core's own editor, pieces (split, fracture, move, recombine), and misuse (bad inputs
//! named, buffers and state untouched on error).

use std::ptr;

use glam::{DMat4, DVec3};
use transcut_core::edit::Cutter;
use transcut_core::edit::{EditOptions, Editor};
use transcut_core::gpu::Backend;
use transcut_core::light::{Light, SourceOptions};
use transcut_core::mesh::TriMesh;
use transcut_core::optics::Medium;
use transcut_core::{bake, BakeOptions, Object, Scene, TransCutOptions};

use super::abi::*;
use super::common::*;

const TETS: u64 = 4_000;
const TOL: f64 = 1e-9;

/// A baked marble sphere of radius 10 (mm) under a sun from `sun` (no shadows: an edit's
/// occluder is the tet-mesh boundary, a bake's the user's surface), on the CPU.
fn baked(mesh: &Mesh, sun: [f64; 3]) -> *mut TcScene {
    let s = scene();
    let ball = add(s, mesh);
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_object_set_medium_preset(s, ball, cstr(c"marble")), "preset");
        ok(tc_scene_add_sun(s, sun.as_ptr(), [3.0, 2.5, 2.0].as_ptr(), 0.0), "sun");
        ok(tc_scene_bake(s, &bake_options(), None, ptr::null_mut()), "bake");
    }
    s
}

fn bake_options() -> TcBakeOptions {
    let mut o = options(TETS);
    o.shadows = 0;
    o.tolerance = TOL;
    o.backend = TC_BACKEND_CPU;
    o
}

/// Asserts `|a − b| ≤ tol · max|b|` everywhere and returns the largest relative difference.
#[track_caller]
fn assert_close(a: &[f32], b: &[f32], tol: f64) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().fold(0.0f64, |m, &x| m.max(f64::from(x.abs())));
    let worst = a.iter().zip(b).map(|(x, y)| f64::from((x - y).abs())).fold(0.0, f64::max) / scale;
    assert!(worst <= tol, "largest difference {worst:.3e} (relative to {scale:.3e}) > {tol}");
    worst
}

fn edit_stats(s: *mut TcScene, object: u32) -> TcEditStats {
    // SAFETY: an all-zero struct is a valid value to overwrite.
    let mut st: TcEditStats = unsafe { std::mem::zeroed() };
    st.size = size_of::<TcEditStats>() as u32;
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_edit_stats(s, object, &mut st) }, "edit stats");
    st
}

/// A piece's surface: positions, triangles, radiance.
fn piece(s: *mut TcScene, object: u32, piece: u32) -> (Vec<f32>, Vec<u32>, Vec<f32>) {
    let (mut nv, mut nt) = (0usize, 0usize);
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_piece_sizes(s, object, piece, &mut nv, &mut nt) }, "piece sizes");
    let (mut p, mut t, mut r) = (vec![f32::NAN; 3 * nv], vec![u32::MAX; 3 * nt], vec![f32::NAN; 3 * nv]);
    // SAFETY: buffers of the given lengths.
    let status = unsafe {
        tc_object_piece_mesh(s, object, piece, p.as_mut_ptr(), p.len(), t.as_mut_ptr(), t.len(), r.as_mut_ptr(), r.len())
    };
    ok(status, "piece mesh");
    (p, t, r)
}

fn piece_count(s: *mut TcScene, object: u32) -> u32 {
    let mut n = 0;
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_piece_count(s, object, &mut n) }, "piece count");
    n
}

/// Relighting through the ABI equals a fresh bake under the new lights (same mesh, same
/// system, both solved to 1e-9), and says what it did; results are NOT_BAKED between the change
/// of lights and the relight.
#[test]
fn relight_equals_a_fresh_bake_with_the_new_lights() {
    let mesh = Mesh::uv_sphere(10.0, 32, 16);
    let new_sun = [0.6, -0.3, -0.74];
    let s = baked(&mesh, [0.0, 0.0, -1.0]);
    let before = radiance(s, 0);
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_scene_clear_lights(s), "clear");
        ok(tc_scene_add_sun(s, new_sun.as_ptr(), [3.0, 2.5, 2.0].as_ptr(), 0.0), "new sun");
        let mut out = vec![0f32; 3 * mesh.vertex_count()];
        fails(tc_object_radiance(s, 0, out.as_mut_ptr(), out.len()), TC_NOT_BAKED, &["tc_scene_relight"]);
        ok(tc_scene_relight(s, None, ptr::null_mut()), "relight");
    }
    let relit = radiance(s, 0);
    let fresh = baked(&mesh, new_sun);
    let worst = assert_close(&relit, &radiance(fresh, 0), 1e-6);
    eprintln!("relight vs fresh bake: {worst:.2e}");
    assert!(assert_close(&before, &relit, 1.0) > 0.05, "the new sun changed the radiance");
    let st = edit_stats(s, 0);
    assert_eq!(st.size as usize, size_of::<TcEditStats>());
    assert_eq!((st.pieces_solved, st.rows_rebuilt, st.cut), (1, 0, 0));
    assert!(st.iterations.iter().all(|&i| i > 0) && st.total_ms > 0.0);
    // A relight under the same lights is a warm start at the solution: at most one iteration.
    // SAFETY: valid pointers.
    ok(unsafe { tc_scene_relight(s, None, ptr::null_mut()) }, "relight again");
    assert!(edit_stats(s, 0).iterations.iter().all(|&i| i <= 1), "{:?}", edit_stats(s, 0).iterations);
    assert_eq!(piece_count(s, 0), 1);
    destroy(s);
    destroy(fresh);
}

/// Assigning a medium everywhere equals a fresh bake with that medium; a sphere-region scale
/// touches only some tets and rebuilds only their rows; painting a stroke changes the radiance
/// near it.
#[test]
fn medium_edits_and_paint() {
    let mesh = Mesh::uv_sphere(10.0, 32, 16);
    let s = baked(&mesh, [0.0, 0.0, -1.0]);
    let mut tets = 0usize;
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_tet_count(s, 0, &mut tets) }, "tet count");
    assert!(tets > 1000);
    let potato = Medium::preset("potato").unwrap();
    // SAFETY: an all-zero struct, then the fields used.
    let mut edit: TcMediumEdit = unsafe { std::mem::zeroed() };
    edit.size = size_of::<TcMediumEdit>() as u32;
    edit.region = TC_REGION_ALL;
    edit.op = TC_MEDIUM_ASSIGN;
    edit.sigma_a = potato.sigma_a;
    edit.sigma_s_prime = potato.sigma_s_prime;
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_edit_medium(s, 0, &edit) }, "assign");
    let st = edit_stats(s, 0);
    assert_eq!(st.tets_changed as usize, tets);
    let assigned = radiance(s, 0);
    // The fresh bake: potato coefficients with marble's η and g (the edit keeps the object's).
    let fresh = scene();
    add(fresh, &mesh);
    let mut marble = TcMedium { sigma_a: [0.0; 3], sigma_s_prime: [0.0; 3], eta: 0.0, g: 0.0 };
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_medium_preset(cstr(c"marble"), &mut marble), "marble");
        let m = TcMedium { sigma_a: potato.sigma_a, sigma_s_prime: potato.sigma_s_prime, eta: marble.eta, g: marble.g };
        ok(tc_object_set_medium(fresh, 0, &m), "medium");
        ok(tc_scene_add_sun(fresh, [0.0, 0.0, -1.0].as_ptr(), [3.0, 2.5, 2.0].as_ptr(), 0.0), "sun");
        ok(tc_scene_bake(fresh, &bake_options(), None, ptr::null_mut()), "bake");
    }
    eprintln!("assign vs fresh bake: {:.2e}", assert_close(&assigned, &radiance(fresh, 0), 1e-6));
    destroy(fresh);

    edit.region = TC_REGION_SPHERE;
    edit.center = [0.0, 0.0, 10.0];
    edit.radius = 4.0;
    edit.op = TC_MEDIUM_SCALE;
    // Red 20 and green 5 times as absorbing: still resolved at the surface (σtr·h about a fifth
    // of its bound); a denser medium is refused (TC_UNRESOLVED, tested below).
    edit.sigma_a = [20.0, 5.0, 1.0];
    edit.sigma_s_prime = [1.0; 3];
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_edit_medium(s, 0, &edit) }, "scale in a sphere");
    let st = edit_stats(s, 0);
    assert!(st.tets_changed > 0 && (st.tets_changed as usize) < tets / 4, "{} of {tets}", st.tets_changed);
    assert!(st.rows_rebuilt > 0, "rows rebuilt");
    let scaled = radiance(s, 0);
    assert!(scaled[0] < 0.9 * assigned[0], "the north pole (vertex 0) darkened: {} vs {}", scaled[0], assigned[0]);

    let ink = TcMedium { sigma_a: [0.1, 0.1, 0.01], sigma_s_prime: potato.sigma_s_prime, eta: marble.eta, g: marble.g };
    let stroke = [10.0, 0.0, 0.0, 7.07, 7.07, 0.0];
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_paint(s, 0, stroke.as_ptr(), 2, 1.5, &ink, 1.0) }, "paint");
    let st = edit_stats(s, 0);
    assert!(st.rows_rebuilt > 0 && st.tets_changed > 0 && (st.tets_changed as usize) < tets / 4);

    // An ink the mesh cannot resolve at the surface (σtr·h several times its bound): refused,
    // naming the channel, and nothing changes.
    let before = radiance(s, 0);
    let dark = TcMedium { sigma_a: [2.0, 0.01, 0.01], ..ink }; // only red is dense
                                                               // SAFETY: valid pointers.
    let status = unsafe { tc_object_paint(s, 0, stroke.as_ptr(), 2, 1.5, &dark, 1.0) };
    fails(status, TC_UNRESOLVED, &["too dense for the mesh", "red", "σtr·h"]);
    assert_eq!(edit_stats(s, 0), st, "a refused paint changed the statistics");
    assert_eq!(radiance(s, 0), before, "a refused paint changed the radiance");
    destroy(s);
}

/// Cutting by a plane through the ABI gives, piece by piece, what the core's editor gives for
/// the same bake and cut; the cut surface lies on the plane; the object's radiance moves to
/// its pieces.
#[test]
fn plane_cut_equals_the_cores_result() {
    let mesh = Mesh::uv_sphere(10.0, 32, 16);
    let s = baked(&mesh, [0.3, 0.2, -1.0]);
    // Remove z > 2.
    let (point, normal) = ([0.0, 0.0, 2.0], [0.0, 0.0, 1.0]);
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_cut_plane(s, 0, point.as_ptr(), normal.as_ptr(), 0) }, "cut");
    assert_eq!(piece_count(s, 0), 1);
    let st = edit_stats(s, 0);
    assert_eq!(st.cut, 1);
    assert!(st.cut_removed_tets > 0 && st.cut_surface_vertices > 0);
    assert!(st.cut_min_dihedral_degrees >= st.cut_bound_degrees && st.cut_bound_degrees > 0.0);
    let (p, t, r) = piece(s, 0, 0);
    let top = p.iter().skip(2).step_by(3).fold(f32::MIN, |m, &z| m.max(z));
    assert!(f64::from(top) <= 2.0 + st.cut_max_distance + 1e-5, "highest vertex {top}");
    assert!(f64::from(top) >= 2.0 - 1e-3, "the cut surface lies on the plane (highest vertex {top})");
    let mut out = vec![0f32; 3 * mesh.vertex_count()];
    // SAFETY: valid pointers.
    fails(unsafe { tc_object_radiance(s, 0, out.as_mut_ptr(), out.len()) }, TC_NOT_BAKED, &["tc_object_piece_mesh"]);

    // The core, by hand: the same scene baked, the editor from the bake, the same cut.
    let xyz: Vec<[f32; 3]> = mesh.positions.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
    let surface = TriMesh::from_triangles(&xyz, &mesh.indices).unwrap();
    let object = Object::new("object 0", surface, Medium::preset("marble").unwrap(), 1.0);
    let sun =
        Light::Directional { direction: DVec3::new(0.3, 0.2, -1.0), irradiance: [3.0, 2.5, 2.0], angular_diameter_deg: 0.0 };
    let scene = Scene { objects: vec![object], lights: vec![sun.clone()] };
    let transcut =
        TransCutOptions { tets: TETS as usize, tolerance: TOL, backend: Some(Backend::Cpu), ..TransCutOptions::default() };
    let options = BakeOptions { shadows: false, ..BakeOptions::with_method(transcut.clone()) };
    let baked = bake(&scene, &options).unwrap();
    let edit_options = EditOptions {
        tets: transcut.tets,
        tolerance: TOL,
        max_iterations: transcut.max_iterations,
        backend: Some(Backend::Cpu),
        source: SourceOptions::default(),
        shadows: false,
        ..EditOptions::default()
    };
    let mut editor = Editor::from_bake(&baked.objects[0], &[sun], &edit_options).unwrap();
    editor.cut(&Cutter::Plane { point: DVec3::new(0.0, 0.0, 2.0), normal: DVec3::Z }).unwrap();
    assert_eq!(editor.pieces().len(), 1);
    let core = &editor.pieces()[0];
    let m = core.mesh();
    let mut boundary: Vec<u32> = m.boundary_faces().iter().flat_map(|f| f.vertices).collect();
    boundary.sort_unstable();
    boundary.dedup();
    assert_eq!(p.len(), 3 * boundary.len());
    assert_eq!(t.len(), 3 * m.boundary_faces().len());
    for (k, &v) in boundary.iter().enumerate() {
        let x = m.positions()[v as usize];
        assert_eq!(&p[3 * k..3 * k + 3], &[x.x as f32, x.y as f32, x.z as f32], "vertex {k}");
        let l = core.radiance()[v as usize];
        assert_eq!(&r[3 * k..3 * k + 3], &[l[0] as f32, l[1] as f32, l[2] as f32], "radiance {k}");
    }
    for (k, f) in m.boundary_faces().iter().enumerate() {
        let ours: Vec<u32> = t[3 * k..3 * k + 3].iter().map(|&i| boundary[i as usize]).collect();
        assert_eq!(ours, f.vertices, "triangle {k}");
    }
    assert!(r.iter().all(|x| x.is_finite() && *x >= 0.0));
    destroy(s);
}

/// Split by a plane keeps both sides as pieces, one on each side; a piece moves rigidly
/// (its surface moves with it, the transform reads back) and welds back when moved home.
#[test]
fn split_move_and_recombine() {
    let mesh = Mesh::uv_sphere(10.0, 32, 16);
    let s = baked(&mesh, [0.0, 0.0, -1.0]);
    let (point, normal) = ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_cut_plane(s, 0, point.as_ptr(), normal.as_ptr(), 1) }, "split");
    assert_eq!(piece_count(s, 0), 2);
    let mut count = 0;
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_fracture(s, 0, &mut count) }, "fracture");
    assert_eq!(count, 2, "two halves, each connected");
    let side = |p: &[f32]| {
        let zs: Vec<f32> = p.iter().skip(2).step_by(3).copied().collect();
        (zs.iter().fold(f32::MAX, |m, &z| m.min(z)), zs.iter().fold(f32::MIN, |m, &z| m.max(z)))
    };
    let (a, _, _) = piece(s, 0, 0);
    let (b, _, _) = piece(s, 0, 1);
    let (ra, rb) = (side(&a), side(&b));
    // The split goes along tet faces (by centroid, no snapping): within a tet's size (~2.5 here).
    let (low, high) = if ra.0 < rb.0 { (ra, rb) } else { (rb, ra) };
    assert!(low.0 < -9.0 && low.1 < 2.5 && high.0 > -2.5 && high.1 > 9.0, "{ra:?} {rb:?}");

    let lift = DMat4::from_translation(DVec3::new(0.0, 0.0, 5.0)).to_cols_array();
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_set_piece_transform(s, 0, 1, lift.as_ptr()) }, "move");
    let mut back = [0.0f64; 16];
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_piece_transform(s, 0, 1, back.as_mut_ptr()) }, "transform");
    assert_eq!(back, lift);
    let (moved, _, _) = piece(s, 0, 1);
    for (m, o) in moved.chunks(3).zip(b.chunks(3)) {
        assert!((m[0] - o[0]).abs() < 1e-5 && (m[1] - o[1]).abs() < 1e-5 && (m[2] - o[2] - 5.0).abs() < 1e-5);
    }
    let home = DMat4::IDENTITY.to_cols_array();
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_object_set_piece_transform(s, 0, 1, home.as_ptr()), "move home");
        ok(tc_object_recombine(s, 0, &mut count), "recombine");
    }
    assert_eq!(count, 1, "the halves touch again and weld");
    destroy(s);
}

/// Misuse: every bad input is refused naming it, and nothing changes (state, buffers).
#[test]
fn bad_edits_are_refused_naming_the_argument_and_change_nothing() {
    let mesh = Mesh::uv_sphere(10.0, 24, 12);
    // Before a bake.
    let s = scene();
    add(s, &mesh);
    let (point, normal) = ([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
    // SAFETY: valid pointers.
    unsafe {
        fails(tc_object_cut_plane(s, 0, point.as_ptr(), normal.as_ptr(), 0), TC_NOT_BAKED, &["tc_scene_bake"]);
        fails(tc_scene_relight(s, None, ptr::null_mut()), TC_NOT_BAKED, &[]);
    }
    destroy(s);

    let s = baked(&mesh, [0.0, 0.0, -1.0]);
    let before = radiance(s, 0);
    let mut n = 0u32;
    // SAFETY: deliberately bad arguments.
    unsafe {
        // Pieces exist from the first edit on.
        fails(tc_object_piece_count(s, 0, &mut n), TC_NOT_BAKED, &["not been edited"]);
        fails(tc_object_edit_stats(s, 0, &mut std::mem::zeroed()), TC_INVALID_ARGUMENT, &["out->size = 0"]);
        fails(tc_object_cut_plane(s, 0, ptr::null(), normal.as_ptr(), 0), TC_NULL_POINTER, &["`point`"]);
        fails(tc_object_cut_plane(s, 0, point.as_ptr(), [0.0; 3].as_ptr(), 0), TC_INVALID_ARGUMENT, &["normal"]);
        fails(tc_object_cut_plane(s, 0, point.as_ptr(), normal.as_ptr(), 2), TC_INVALID_ARGUMENT, &["keep_both = 2"]);
        fails(tc_object_cut_plane(s, 3, point.as_ptr(), normal.as_ptr(), 0), TC_INVALID_HANDLE, &["object 3"]);
        // Everything lies above z = -100: nothing would be left.
        fails(tc_object_cut_plane(s, 0, [0.0, 0.0, -100.0].as_ptr(), normal.as_ptr(), 0), TC_NOTHING_LEFT, &[]);
        let one = [0.0, 0.0, 30.0];
        fails(tc_object_cut_stroke(s, 0, one.as_ptr(), [0.0, 0.0, -1.0].as_ptr(), 1, 0), TC_INVALID_ARGUMENT, &["stroke"]);
        fails(
            tc_object_cut_mesh(s, 0, [0.0f32; 9].as_ptr(), 3, [0u32, 1, 2, 0].as_ptr(), 4, 0),
            TC_INVALID_MESH,
            &["index_count = 4"],
        );

        let mut edit: TcMediumEdit = std::mem::zeroed();
        edit.size = size_of::<TcMediumEdit>() as u32;
        edit.region = 9;
        fails(tc_object_edit_medium(s, 0, &edit), TC_INVALID_ARGUMENT, &["edit->region = 9"]);
        edit.region = TC_REGION_MASK;
        let mask = [1u8; 10];
        edit.mask = mask.as_ptr();
        edit.mask_len = mask.len();
        edit.op = TC_MEDIUM_SCALE;
        edit.sigma_a = [1.0; 3];
        edit.sigma_s_prime = [1.0; 3];
        fails(tc_object_edit_medium(s, 0, &edit), TC_INVALID_ARGUMENT, &["mask"]);
        edit.region = TC_REGION_ALL;
        edit.op = 5;
        fails(tc_object_edit_medium(s, 0, &edit), TC_INVALID_ARGUMENT, &["edit->op = 5"]);
        edit.op = TC_MEDIUM_SCALE;
        edit.sigma_a = [-1.0; 3];
        fails(tc_object_edit_medium(s, 0, &edit), TC_INVALID_ARGUMENT, &[]);
        edit.size = 8;
        fails(tc_object_edit_medium(s, 0, &edit), TC_INVALID_ARGUMENT, &["edit->size = 8"]);

        let mut ink = TcMedium { sigma_a: [1.0; 3], sigma_s_prime: [1.0; 3], eta: 1.9, g: 0.0 };
        let stroke = [10.0, 0.0, 0.0];
        fails(tc_object_paint(s, 0, stroke.as_ptr(), 1, 1.0, &ink, 1.0), TC_INVALID_ARGUMENT, &["eta"]);
        ink.eta = 1.5; // marble's: the remaining failures are the other arguments'
        fails(tc_object_paint(s, 0, ptr::null(), 1, 1.0, &ink, 1.0), TC_NULL_POINTER, &["points_xyz"]);
        fails(tc_object_paint(s, 0, stroke.as_ptr(), 1, -1.0, &ink, 1.0), TC_INVALID_ARGUMENT, &["radius"]);
        fails(tc_object_paint(s, 0, stroke.as_ptr(), 1, 1.0, ptr::null(), 1.0), TC_NULL_POINTER, &["medium"]);
    }
    // None of that changed the object (and none of it started an editing session).
    assert_eq!(radiance(s, 0), before);
    // SAFETY: valid pointers.
    fails(unsafe { tc_object_piece_count(s, 0, &mut n) }, TC_NOT_BAKED, &[]);

    // A real cut, then misuse of the pieces.
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_cut_plane(s, 0, [0.0, 0.0, 3.0].as_ptr(), normal.as_ptr(), 0) }, "cut");
    let (p, t, r) = piece(s, 0, 0);
    let (mut pb, mut tb, mut rb) = (vec![-7.0f32; p.len()], vec![7u32; t.len()], vec![-7.0f32; r.len() - 1]);
    // SAFETY: buffers of the given lengths; the radiance one is one short.
    unsafe {
        let status =
            tc_object_piece_mesh(s, 0, 0, pb.as_mut_ptr(), pb.len(), tb.as_mut_ptr(), tb.len(), rb.as_mut_ptr(), rb.len());
        fails(status, TC_BUFFER_TOO_SHORT, &["radiance_len"]);
        let status =
            tc_object_piece_mesh(s, 0, 5, pb.as_mut_ptr(), pb.len(), tb.as_mut_ptr(), tb.len(), rb.as_mut_ptr(), rb.len());
        fails(status, TC_INVALID_HANDLE, &["piece 5"]);
    }
    assert!(pb.iter().all(|&x| x == -7.0) && tb.iter().all(|&x| x == 7) && rb.iter().all(|&x| x == -7.0), "written on failure");
    let scale = DMat4::from_scale(DVec3::splat(2.0)).to_cols_array();
    let mut shear = DMat4::IDENTITY.to_cols_array();
    shear[4] = 0.5;
    // SAFETY: valid pointers.
    unsafe {
        fails(tc_object_set_piece_transform(s, 0, 0, scale.as_ptr()), TC_INVALID_ARGUMENT, &["rigid"]);
        fails(tc_object_set_piece_transform(s, 0, 0, shear.as_ptr()), TC_INVALID_ARGUMENT, &["rigid"]);
        fails(tc_object_set_piece_transform(s, 0, 4, DMat4::IDENTITY.to_cols_array().as_ptr()), TC_INVALID_HANDLE, &["4"]);
        fails(tc_object_cut_plane(s, 0, [0.0, 0.0, -100.0].as_ptr(), normal.as_ptr(), 0), TC_NOTHING_LEFT, &[]);
    }
    assert_eq!(piece(s, 0, 0), (p, t, r), "failed edits left the pieces as they were");
    assert_eq!(edit_stats(s, 0).cut, 1, "the stats are still the cut's");
    // A change of the object ends the editing session.
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_set_medium_preset(s, 0, cstr(c"skin1")) }, "medium");
    fails(unsafe { tc_object_piece_count(s, 0, &mut n) }, TC_NOT_BAKED, &["tc_scene_bake"]);
    destroy(s);
}

/// Progress reports of a relight: (calls so far, cancel at this call, fractions).
struct Relight {
    calls: u32,
    cancel_at: u32,
    fractions: Vec<f64>,
}

unsafe extern "C" fn on_relight(user: *mut std::ffi::c_void, _stage: *const std::ffi::c_char, fraction: f64) -> i32 {
    // SAFETY: `user` is the `Relight` passed to tc_scene_relight.
    let r = unsafe { &mut *user.cast::<Relight>() };
    r.calls += 1;
    r.fractions.push(fraction);
    i32::from(r.cancel_at != 0 && r.calls >= r.cancel_at)
}

/// A relight reports progress up to 1; cancelled (at the first or the last report) it returns
/// TC_CANCELLED and changes nothing: the objects keep their last update (a paint here) and
/// results stay NOT_BAKED until a relight succeeds.
#[test]
fn relight_progress_and_cancel_change_nothing() {
    let mesh = Mesh::uv_sphere(10.0, 24, 12);
    let s = baked(&mesh, [0.0, 0.0, -1.0]);
    let ink = TcMedium { sigma_a: [0.1, 0.1, 0.01], sigma_s_prime: [2.0; 3], eta: 1.5, g: 0.0 }; // marble: eta 1.5
                                                                                                 // SAFETY: valid pointers.
    ok(unsafe { tc_object_paint(s, 0, [10.0, 0.0, 0.0].as_ptr(), 1, 2.0, &ink, 1.0) }, "paint");
    let painted = edit_stats(s, 0);
    assert!(painted.rows_rebuilt > 0);
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_scene_clear_lights(s), "clear");
        ok(tc_scene_add_environment(s, [0.5; 3].as_ptr()), "sky");
    }
    for cancel_at in [1, 2] {
        let mut r = Relight { calls: 0, cancel_at, fractions: Vec::new() };
        // SAFETY: valid pointers; `r` outlives the call.
        let status = unsafe { tc_scene_relight(s, Some(on_relight), (&raw mut r).cast()) };
        fails(status, TC_CANCELLED, &["nothing changed"]);
        assert_eq!(r.calls, cancel_at);
        assert_eq!(edit_stats(s, 0), painted, "a cancelled relight changed the object");
        let mut out = vec![0f32; 3 * mesh.vertex_count()];
        // SAFETY: valid pointers.
        fails(unsafe { tc_object_radiance(s, 0, out.as_mut_ptr(), out.len()) }, TC_NOT_BAKED, &[]);
    }
    let mut r = Relight { calls: 0, cancel_at: 0, fractions: Vec::new() };
    // SAFETY: as above.
    ok(unsafe { tc_scene_relight(s, Some(on_relight), (&raw mut r).cast()) }, "relight");
    // Before the object, through its light and solve stages, and at the end.
    assert!(r.fractions.len() > 2, "{:?}", r.fractions);
    assert_eq!((r.fractions[0], *r.fractions.last().unwrap()), (0.0, 1.0));
    assert!(r.fractions.windows(2).all(|w| w[1] >= w[0]), "{:?}", r.fractions);
    let st = edit_stats(s, 0);
    assert_eq!(st.rows_rebuilt, 0);
    assert!(radiance(s, 0).iter().all(|x| x.is_finite() && *x > 0.0), "lit by the sky everywhere");
    destroy(s);
}

/// Two marble spheres baked under a sun (object 0 then painted, so it has an editor; object 1
/// only its bake), then lit by a sky instead: the state a relight starts from.
fn painted_and_baked_pair(mesh: &Mesh) -> *mut TcScene {
    let s = scene();
    let ink = TcMedium { sigma_a: [0.1, 0.1, 0.01], sigma_s_prime: [2.0; 3], eta: 1.5, g: 0.0 }; // marble: eta 1.5
                                                                                                 // SAFETY: valid pointers.
    unsafe {
        for _ in 0..2 {
            let ball = add(s, mesh);
            ok(tc_object_set_medium_preset(s, ball, cstr(c"marble")), "preset");
        }
        ok(tc_scene_add_sun(s, [0.0, 0.0, -1.0].as_ptr(), [3.0, 2.5, 2.0].as_ptr(), 0.0), "sun");
        ok(tc_scene_bake(s, &bake_options(), None, ptr::null_mut()), "bake");
        ok(tc_object_paint(s, 0, [10.0, 0.0, 0.0].as_ptr(), 1, 2.0, &ink, 1.0), "paint");
        ok(tc_scene_clear_lights(s), "clear");
        ok(tc_scene_add_environment(s, [0.5; 3].as_ptr()), "sky");
    }
    s
}

/// A relight stopped after some objects were relit in place (cancelled at the second object's
/// report, or at the final one after both) undoes them: the edited object keeps its pieces and
/// last statistics, the object that had only its bake gets no editor; the next relight then
/// gives exactly (bit for bit) what it gives on a scene that never saw the stopped relights.
#[test]
fn a_relight_stopped_after_the_first_object_changes_no_object() {
    let mesh = Mesh::uv_sphere(10.0, 24, 12);
    let s = painted_and_baked_pair(&mesh);
    let painted = edit_stats(s, 0);
    let pieces = piece(s, 0, 0);
    // The reports of a whole relight (on a twin scene): object 1 starts at the first report at
    // 0.5, the end is the last.
    let twin = painted_and_baked_pair(&mesh);
    let mut full = Relight { calls: 0, cancel_at: 0, fractions: Vec::new() };
    // SAFETY: valid pointers; `full` outlives the call.
    ok(unsafe { tc_scene_relight(twin, Some(on_relight), (&raw mut full).cast()) }, "relight");
    destroy(twin);
    let second = full.fractions.iter().position(|&f| f >= 0.5).unwrap() as u32 + 1;
    for cancel_at in [second, full.calls] {
        let mut r = Relight { calls: 0, cancel_at, fractions: Vec::new() };
        // SAFETY: valid pointers; `r` outlives the call.
        let status = unsafe { tc_scene_relight(s, Some(on_relight), (&raw mut r).cast()) };
        fails(status, TC_CANCELLED, &["nothing changed"]);
        assert_eq!(r.calls, cancel_at);
        assert!(*r.fractions.last().unwrap() >= 0.5, "{:?}", r.fractions);
        assert_eq!(edit_stats(s, 0), painted, "cancelled at report {cancel_at}: object 0's statistics changed");
        assert!(piece(s, 0, 0) == pieces, "cancelled at report {cancel_at}: object 0's piece changed");
        let mut n = 0;
        // SAFETY: valid pointers.
        unsafe {
            fails(tc_object_piece_count(s, 1, &mut n), TC_NOT_BAKED, &["has not been edited"]);
            let mut out = vec![0f32; 3 * mesh.vertex_count()];
            fails(tc_object_radiance(s, 0, out.as_mut_ptr(), out.len()), TC_NOT_BAKED, &[]);
        }
    }
    let reference = painted_and_baked_pair(&mesh);
    for scene in [s, reference] {
        // SAFETY: valid pointers.
        ok(unsafe { tc_scene_relight(scene, None, ptr::null_mut()) }, "relight");
    }
    for object in 0..2 {
        assert!(radiance(s, object) == radiance(reference, object), "object {object} differs from the reference");
        assert!(piece(s, object, 0) == piece(reference, object, 0), "object {object}'s piece differs from the reference");
        assert_eq!(edit_stats(s, object).iterations, edit_stats(reference, object).iterations);
    }
    assert!(radiance(s, 0) != radiance(s, 1), "the paint shows");
    destroy(s);
    destroy(reference);
}

/// The scene-wide callback of `tc_scene_set_progress` reaches a cut: it reports, and a cancel
/// at its first, middle or last report returns TC_CANCELLED with the radiance and the piece
/// count as before; cleared with NULL, the cut runs to the end and is the cut the callback saw.
#[test]
fn a_cut_cancelled_through_the_scene_callback_changes_nothing() {
    let mesh = Mesh::uv_sphere(10.0, 24, 12);
    let s = baked(&mesh, [0.0, 0.0, -1.0]);
    let before = radiance(s, 0);
    let (point, normal) = ([0.0, 0.0, 3.0], [0.0, 0.0, 1.0]);
    let mut full = Relight { calls: 0, cancel_at: 0, fractions: Vec::new() };
    // A cut of a second, identical scene with the callback never cancelling: the reports.
    let t = baked(&mesh, [0.0, 0.0, -1.0]);
    // SAFETY: valid pointers; `full` outlives the calls on `t`.
    unsafe {
        ok(tc_scene_set_progress(t, Some(on_relight), (&raw mut full).cast()), "set progress");
        ok(tc_object_cut_plane(t, 0, point.as_ptr(), normal.as_ptr(), 0), "cut");
        ok(tc_scene_set_progress(t, None, ptr::null_mut()), "clear progress");
    }
    assert!(full.calls > 3, "the cut reports while it works: {:?}", full.fractions);
    assert_eq!(*full.fractions.last().unwrap(), 1.0);
    for cancel_at in [1, full.calls / 2, full.calls] {
        let mut r = Relight { calls: 0, cancel_at, fractions: Vec::new() };
        // SAFETY: valid pointers; `r` outlives the call (cleared right after it).
        unsafe {
            ok(tc_scene_set_progress(s, Some(on_relight), (&raw mut r).cast()), "set progress");
            fails(tc_object_cut_plane(s, 0, point.as_ptr(), normal.as_ptr(), 0), TC_CANCELLED, &["nothing changed"]);
            ok(tc_scene_set_progress(s, None, ptr::null_mut()), "clear progress");
        }
        assert_eq!(r.calls, cancel_at, "no report after the cancel");
        assert_eq!(radiance(s, 0), before, "a cancelled cut changed the radiance");
        let mut n = 7;
        // SAFETY: valid pointers. The object has had no update yet: no pieces to count.
        fails(unsafe { tc_object_piece_count(s, 0, &mut n) }, TC_NOT_BAKED, &[]);
        assert_eq!(n, 7);
    }
    // SAFETY: valid pointers; no callback is set.
    ok(unsafe { tc_object_cut_plane(s, 0, point.as_ptr(), normal.as_ptr(), 0) }, "cut");
    assert_eq!(piece(s, 0, 0), piece(t, 0, 0), "the cut after the cancels is the cut never cancelled");
    assert_eq!(piece_count(s, 0), 1);
    destroy(s);
    destroy(t);
}
