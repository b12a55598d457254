//! A scene bakes again after a change without meshing what did not change (`tc_scene_bake`
//! keeps each object's tetrahedra; `TcBakeStats.mesh_reused`), with a new scene's answer bit
//! for bit (with `TC_GRADING_AUTO`, a medium change that changes the grading meshes that object
//! again); `tc_object_set_mesh` replaces one object's mesh (and only that one is meshed
//! again); its misuse is named and changes nothing.

use std::ptr;

use super::abi::*;
use super::common::*;

fn mesh_reused(s: *mut TcScene, object: u32) -> u32 {
    // SAFETY: an all-zero struct is a valid value to overwrite.
    let mut st: TcBakeStats = unsafe { std::mem::zeroed() };
    st.size = size_of::<TcBakeStats>() as u32;
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_stats(s, object, &mut st) }, "stats");
    st.mesh_reused
}

/// An absorbing wax: σtr h ≈ 1.1 in blue at the uniform spacing of 5k tets on the R = 8 ball,
/// so the automatic grading grades it.
const WAX: TcMedium = TcMedium { sigma_a: [0.02, 0.01, 0.05], sigma_s_prime: [2.19, 2.62, 3.00], eta: 1.3, g: 0.0 };
/// A pale one: σtr h ≈ 0.27 at most, uniform tets as for the default medium.
const PALE: TcMedium = TcMedium { sigma_a: [0.001, 0.002, 0.003], sigma_s_prime: [2.19, 2.62, 3.00], eta: 1.3, g: 0.0 };

/// Two spheres (`a` above `b`) under a sun, `b` of mesh `b_mesh` with medium `b_medium`
/// (None: the default), baked in a new scene: the radiance of each.
fn fresh(b_mesh: &Mesh, b_medium: Option<&TcMedium>) -> [Vec<f32>; 2] {
    let s = two_spheres(b_mesh);
    if let Some(m) = b_medium {
        // SAFETY: valid pointers.
        ok(unsafe { tc_object_set_medium(s, 1, m) }, "medium");
    }
    bake(s);
    let r = [radiance(s, 0), radiance(s, 1)];
    destroy(s);
    r
}

fn two_spheres(b_mesh: &Mesh) -> *mut TcScene {
    let s = scene();
    let a = add(s, &Mesh::uv_sphere(10.0, 24, 12));
    add(s, b_mesh);
    let up: [f32; 16] = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 2.0, 0.0, 25.0, 1.0];
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_object_set_transform(s, a, up.as_ptr()), "transform");
        ok(tc_scene_add_sun(s, [0.2, 0.0, -1.0].as_ptr(), [3.0; 3].as_ptr(), 0.0), "sun");
    }
    s
}

/// Bakes with the automatic grading (`TC_GRADING_AUTO`), so that a medium change can change
/// the tets.
fn bake(s: *mut TcScene) {
    let mut transcut = TcTransCutOptions { size: 0, solver: 0, edit_solver: 0, grading: 0, discretization: 0 };
    // SAFETY: a valid pointer and its size.
    ok(unsafe { tc_transcut_options_init(&mut transcut, size_of::<TcTransCutOptions>()) }, "init");
    transcut.grading = TC_GRADING_AUTO;
    let mut o = options(5_000);
    o.backend = TC_BACKEND_CPU;
    o.method = TC_METHOD_TRANSCUT;
    o.method_options = (&raw const transcut).cast();
    // SAFETY: valid pointers.
    ok(unsafe { tc_scene_bake(s, &o, None, ptr::null_mut()) }, "bake");
}

#[test]
fn a_rebake_meshes_only_what_changed_and_equals_a_new_scene() {
    let ball = Mesh::uv_sphere(8.0, 20, 10);
    let s = two_spheres(&ball);
    bake(s);
    assert_eq!((mesh_reused(s, 0), mesh_reused(s, 1)), (0, 0));

    // A medium change that keeps the grading: no object meshed again, a new scene's radiance.
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_set_medium(s, 1, &PALE) }, "medium");
    bake(s);
    assert_eq!((mesh_reused(s, 0), mesh_reused(s, 1)), (1, 1));
    assert_eq!([radiance(s, 0), radiance(s, 1)], fresh(&ball, Some(&PALE)), "bit for bit");
    // One whose boundary layer the automatic grading grades: that object alone meshed again.
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_set_medium(s, 1, &WAX) }, "medium");
    bake(s);
    assert_eq!((mesh_reused(s, 0), mesh_reused(s, 1)), (1, 0));
    assert_eq!([radiance(s, 0), radiance(s, 1)], fresh(&ball, Some(&WAX)), "bit for bit");

    // b's mesh replaced by a finer sphere: b alone meshed again.
    let finer = Mesh::uv_sphere(8.0, 32, 16);
    // SAFETY: arrays of the given lengths.
    let set = |s, m: &Mesh| unsafe {
        tc_object_set_mesh(s, 1, m.positions.as_ptr(), m.vertex_count(), m.indices.as_ptr(), m.indices.len())
    };
    ok(set(s, &finer), "tc_object_set_mesh");
    fails(
        // SAFETY: valid pointers.
        unsafe { tc_object_radiance(s, 1, [0.0f32; 3].as_mut_ptr(), 3) },
        TC_NOT_BAKED,
        &["tc_scene_bake"],
    );
    bake(s);
    assert_eq!((mesh_reused(s, 0), mesh_reused(s, 1)), (1, 0));
    let result = [radiance(s, 0), radiance(s, 1)];
    assert_eq!(result[1].len(), 3 * finer.vertex_count(), "radiance for the new vertices");
    assert_eq!(result, fresh(&finer, Some(&WAX)), "bit for bit");

    // Misuse: named, and the scene keeps its results.
    let mut broken = Mesh::uv_sphere(8.0, 20, 10);
    broken.indices[5] = 10_000;
    fails(set(s, &broken), TC_INVALID_MESH, &["10000"]);
    broken.positions[4] = f32::NAN;
    broken.indices[5] = 0;
    fails(set(s, &broken), TC_INVALID_MESH, &["NaN"]);
    // SAFETY: a NULL array with a non-zero count.
    let null = unsafe { tc_object_set_mesh(s, 1, ptr::null(), 3, finer.indices.as_ptr(), 3) };
    fails(null, TC_NULL_POINTER, &["positions"]);
    // SAFETY: valid arrays; object 7 does not exist.
    let missing = unsafe {
        tc_object_set_mesh(s, 7, finer.positions.as_ptr(), finer.vertex_count(), finer.indices.as_ptr(), finer.indices.len())
    };
    fails(missing, TC_INVALID_HANDLE, &["object 7"]);
    assert_eq!([radiance(s, 0), radiance(s, 1)], result, "a failed call changes nothing");
    destroy(s);
}

#[test]
fn an_object_given_as_tets_keeps_them() {
    let s = scene();
    let positions: [f32; 12] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
    let mut object = u32::MAX;
    let ball = Mesh::uv_sphere(8.0, 20, 10);
    // SAFETY: arrays of the given lengths.
    unsafe {
        ok(tc_scene_add_tet_mesh(s, positions.as_ptr(), 4, [0u32, 1, 2, 3].as_ptr(), 1, ptr::null(), &mut object), "tets");
        let status = tc_object_set_mesh(
            s,
            object,
            ball.positions.as_ptr(),
            ball.vertex_count(),
            ball.indices.as_ptr(),
            ball.indices.len(),
        );
        fails(status, TC_UNSUPPORTED, &["tetrahedral mesh", "new object"]);
    }
    destroy(s);
}
