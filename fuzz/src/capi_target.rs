//! The body of the `capi_mesh` fuzz target: the C ABI's mesh entry points
//! (`tc_scene_add_mesh`, `tc_scene_add_tet_mesh`) called with arrays decoded from the bytes, as a
//! C caller would. The ABI sources are the module `super::abi` wherever this file is included.
//! A panic (none may cross the ABI, so it would come from a check here) is a finding.
//!
//! Shared by the `cargo fuzz` target and the C ABI's smoke test of the corpus
//! (`capi/tests/abi/fuzz_corpus.rs`), which includes this file as a module.
//!
//! Byte layout: byte 0 is the vertex count n (0..=255); then 3n little-endian `f32`
//! coordinates (missing bytes read as 0); every remaining 4 bytes are one `u32` index. The
//! triangle call gets all indices, the tet call the whole multiples of 4.

use std::ffi::CStr;

use super::abi::*;

/// The longest error message the ABI may give, in bytes.
pub const MAX_MESSAGE_BYTES: usize = 1024;

/// The arrays the bytes stand for: positions (3 per vertex) and indices.
pub fn decode(data: &[u8]) -> (Vec<f32>, Vec<u32>) {
    let n = data.first().copied().unwrap_or(0) as usize;
    let rest = data.get(1..).unwrap_or(&[]);
    let word = |k: usize| -> [u8; 4] {
        let mut b = [0u8; 4];
        for (i, v) in b.iter_mut().enumerate() {
            *v = rest.get(4 * k + i).copied().unwrap_or(0);
        }
        b
    };
    let positions: Vec<f32> = (0..3 * n).map(|k| f32::from_le_bytes(word(k))).collect();
    let start = (12 * n).min(rest.len());
    let indices = rest[start..].chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    (positions, indices)
}

/// Calls both mesh entry points on a fresh scene; returns their statuses (`TC_OK` or the
/// failure), after checking that a failed call left the scene's object count as it was and
/// set a message of at most [`MAX_MESSAGE_BYTES`].
///
/// # Panics
/// When one of those checks fails: that is a finding.
pub fn capi_mesh(data: &[u8]) -> [TcStatus; 2] {
    let (positions, indices) = decode(data);
    let n = positions.len() / 3;
    let mut scene: *mut TcScene = std::ptr::null_mut();
    // SAFETY: a valid out-pointer.
    assert_eq!(unsafe { tc_scene_create(&mut scene) }, TC_OK);
    let count = |scene: *mut TcScene| {
        let mut c = u32::MAX;
        // SAFETY: a live scene and a valid out-pointer.
        assert_eq!(unsafe { tc_scene_object_count(scene, &mut c) }, TC_OK);
        c
    };
    let check = |status: TcStatus, before: u32, scene: *mut TcScene| {
        if status == TC_OK {
            assert_eq!(count(scene), before + 1);
        } else {
            // The message first: the next call (the count) replaces it.
            // SAFETY: never NULL; copied at once.
            let message = unsafe { CStr::from_ptr(tc_last_error_message()) }.to_string_lossy().into_owned();
            assert!(!message.is_empty(), "status {status:?} without a message");
            assert!(message.len() <= MAX_MESSAGE_BYTES, "a message of {} bytes", message.len());
            assert_eq!(count(scene), before, "a failed call added an object");
        }
    };
    let mut object = u32::MAX;
    let before = count(scene);
    // SAFETY: the arrays have exactly the lengths passed.
    let tri = unsafe { tc_scene_add_mesh(scene, positions.as_ptr(), n, indices.as_ptr(), indices.len(), &mut object) };
    check(tri, before, scene);
    let before = count(scene);
    let tets = indices.len() / 4;
    // SAFETY: as above; no per-tet media.
    let tet =
        unsafe { tc_scene_add_tet_mesh(scene, positions.as_ptr(), n, indices.as_ptr(), tets, std::ptr::null(), &mut object) };
    check(tet, before, scene);
    // SAFETY: the scene made above.
    unsafe { tc_scene_destroy(&mut scene) };
    [tri, tet]
}
