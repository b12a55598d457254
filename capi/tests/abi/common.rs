//! Helpers a C program would write for itself: meshes as flat arrays, status checks.

use std::ffi::{c_char, CStr};
use std::ptr;

use super::abi::*;

/// The library's message for the last call on this thread.
pub fn message() -> String {
    // SAFETY: never NULL, valid until the next call on this thread; copied at once.
    unsafe { CStr::from_ptr(tc_last_error_message()) }.to_string_lossy().into_owned()
}

/// Panics with the call, status name and message unless `status` is `TC_OK`.
#[track_caller]
pub fn ok(status: TcStatus, what: &str) {
    if status != TC_OK {
        panic!("{what}: {} ({}): {}", status.0, name(status), message());
    }
}

/// The status's name from the library.
pub fn name(status: TcStatus) -> String {
    // SAFETY: a static string.
    unsafe { CStr::from_ptr(tc_status_name(status)) }.to_string_lossy().into_owned()
}

/// Asserts `status == expected` and that the message is non-empty and contains every `needle`.
#[track_caller]
pub fn fails(status: TcStatus, expected: TcStatus, needles: &[&str]) {
    let msg = message();
    assert_eq!(status, expected, "expected {}, got {} ({msg})", name(expected), name(status));
    assert!(!msg.is_empty(), "a failure without a message");
    for n in needles {
        assert!(msg.contains(n), "message {msg:?} does not mention {n:?}");
    }
}

/// A C string literal as a pointer.
pub fn cstr(s: &CStr) -> *const c_char {
    s.as_ptr()
}

/// A closed UV sphere centred at the origin as flat arrays (x, y, z per vertex; 3 indices per
/// triangle, counter-clockwise from outside): vertex 0 is the north pole (+z), the last the
/// south pole.
pub struct Mesh {
    pub positions: Vec<f32>,
    pub indices: Vec<u32>,
}

impl Mesh {
    pub fn vertex_count(&self) -> usize {
        self.positions.len() / 3
    }

    pub fn uv_sphere(radius: f32, segments: u32, rings: u32) -> Self {
        let mut positions = vec![0.0, 0.0, radius];
        for j in 1..rings {
            let theta = std::f32::consts::PI * j as f32 / rings as f32;
            for k in 0..segments {
                let phi = std::f32::consts::TAU * k as f32 / segments as f32;
                positions.extend([radius * theta.sin() * phi.cos(), radius * theta.sin() * phi.sin(), radius * theta.cos()]);
            }
        }
        positions.extend([0.0, 0.0, -radius]);
        let south = (positions.len() / 3 - 1) as u32;
        let v = |j: u32, k: u32| 1 + (j - 1) * segments + k % segments;
        let mut indices = Vec::new();
        for k in 0..segments {
            indices.extend([0, v(1, k), v(1, k + 1)]);
            for j in 1..rings - 1 {
                indices.extend([v(j, k), v(j + 1, k), v(j + 1, k + 1)]);
                indices.extend([v(j, k), v(j + 1, k + 1), v(j, k + 1)]);
            }
            indices.extend([v(rings - 1, k), south, v(rings - 1, k + 1)]);
        }
        Self { positions, indices }
    }
}

/// A new scene (panics on failure).
pub fn scene() -> *mut TcScene {
    let mut s = ptr::null_mut();
    // SAFETY: a valid out pointer.
    ok(unsafe { tc_scene_create(&mut s) }, "tc_scene_create");
    assert!(!s.is_null());
    s
}

/// Adds `mesh` to `scene`, returning the object index.
pub fn add(scene: *mut TcScene, mesh: &Mesh) -> u32 {
    let mut object = u32::MAX;
    // SAFETY: arrays of the given lengths.
    let status = unsafe {
        tc_scene_add_mesh(
            scene,
            mesh.positions.as_ptr(),
            mesh.vertex_count(),
            mesh.indices.as_ptr(),
            mesh.indices.len(),
            &mut object,
        )
    };
    ok(status, "tc_scene_add_mesh");
    object
}

/// Default options with `tets` target tetrahedra.
pub fn options(tets: u64) -> TcBakeOptions {
    // SAFETY: an all-zero struct is a valid value to overwrite.
    let mut o: TcBakeOptions = unsafe { std::mem::zeroed() };
    // SAFETY: a valid pointer and its size.
    ok(unsafe { tc_bake_options_init(&mut o, size_of::<TcBakeOptions>()) }, "options");
    o.tets = tets;
    o
}

/// The radiance of `object` (3 floats per vertex).
pub fn radiance(scene: *mut TcScene, object: u32) -> Vec<f32> {
    let mut n = 0usize;
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_vertex_count(scene, object, &mut n) }, "tc_object_vertex_count");
    let mut out = vec![f32::NAN; 3 * n];
    // SAFETY: a buffer of the given length.
    ok(unsafe { tc_object_radiance(scene, object, out.as_mut_ptr(), out.len()) }, "tc_object_radiance");
    out
}

/// Frees a scene through the documented pattern.
pub fn destroy(mut scene: *mut TcScene) {
    // SAFETY: the address of a handle variable.
    unsafe { tc_scene_destroy(&mut scene) };
    assert!(scene.is_null());
}
