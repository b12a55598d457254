//! Threads: several scenes baked at once give the results of baking them one after another; the
//! last-error message is per thread; one scene used from two threads at once is refused
//! (TC_BUSY), not raced.

use std::ffi::{c_char, c_void};
use std::ptr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Barrier;

use super::abi::*;
use super::common::*;

/// A raw pointer that may cross threads (the ABI allows a scene to move between threads).
#[derive(Clone, Copy)]
struct Handle(*mut TcScene);
// SAFETY: the library guards each scene; see handle.rs.
unsafe impl Send for Handle {}
unsafe impl Sync for Handle {}

/// Scene `k`: a sphere of its own size, medium and light direction.
fn build(k: usize) -> (*mut TcScene, u32) {
    let s = scene();
    let ball = add(s, &Mesh::uv_sphere(8.0 + 2.0 * k as f32, 24, 12));
    // Media the 4k-tet mesh resolves (skin or ketchup would be refused as TC_UNRESOLVED).
    let preset = [c"marble", c"skimmilk", c"apple", c"wholemilk"][k % 4];
    let dir = [[0.0, 0.0, -1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [-1.0, -1.0, -1.0]][k % 4];
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_object_set_medium_preset(s, ball, cstr(preset)), "preset");
        ok(tc_scene_add_sun(s, dir.as_ptr(), [2.0; 3].as_ptr(), 0.0), "sun");
    }
    (s, ball)
}

fn bake(s: *mut TcScene, ball: u32) -> Vec<f32> {
    // SAFETY: valid pointers.
    ok(unsafe { tc_scene_bake(s, &options(4_000), None, ptr::null_mut()) }, "bake");
    radiance(s, ball)
}

#[test]
fn several_threads_bake_different_scenes_at_once() {
    const N: usize = 4;
    let sequential: Vec<Vec<f32>> = (0..N)
        .map(|k| {
            let (s, ball) = build(k);
            let lo = bake(s, ball);
            destroy(s);
            lo
        })
        .collect();
    let barrier = Barrier::new(N);
    let parallel: Vec<Vec<f32>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..N)
            .map(|k| {
                let barrier = &barrier;
                scope.spawn(move || {
                    let (s, ball) = build(k);
                    barrier.wait();
                    let lo = bake(s, ball);
                    destroy(s);
                    lo
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for k in 0..N {
        assert_eq!(parallel[k], sequential[k], "scene {k} differs when baked concurrently");
    }
}

#[test]
fn the_last_error_is_per_thread() {
    // SAFETY: NULL on purpose.
    let status = unsafe { tc_scene_create(ptr::null_mut()) };
    assert_eq!(status, TC_NULL_POINTER);
    let here = message();
    let there = std::thread::spawn(|| {
        let s = scene();
        let m = message();
        destroy(s);
        m
    })
    .join()
    .unwrap();
    assert_eq!(there, "");
    assert_eq!(message(), here, "another thread's success does not clear this thread's message");
}

struct Gate {
    started: AtomicBool,
    release: AtomicBool,
}

unsafe extern "C" fn hold(user: *mut c_void, _stage: *const c_char, _fraction: f64) -> i32 {
    // SAFETY: `user` is the `Gate`.
    let gate = unsafe { &*user.cast::<Gate>() };
    gate.started.store(true, Ordering::SeqCst);
    while !gate.release.load(Ordering::SeqCst) {
        std::thread::yield_now();
    }
    0
}

#[test]
fn one_scene_from_two_threads_at_once_is_refused() {
    let (s, ball) = build(0);
    let h = Handle(s);
    let gate = Gate { started: AtomicBool::new(false), release: AtomicBool::new(false) };
    std::thread::scope(|scope| {
        let gate = &gate;
        let baker = scope.spawn(move || {
            let h = h;
            // SAFETY: valid pointers; the gate outlives the bake.
            unsafe { tc_scene_bake(h.0, &options(2_000), Some(hold), ptr::from_ref(gate).cast_mut().cast()) }
        });
        while !gate.started.load(Ordering::SeqCst) {
            std::thread::yield_now();
        }
        let mut n = 0;
        let mut handle = h.0;
        // SAFETY: a live scene, busy in the other thread.
        unsafe {
            fails(tc_scene_object_count(h.0, &mut n), TC_BUSY, &["in use"]);
            fails(tc_scene_bake(h.0, ptr::null(), None, ptr::null_mut()), TC_BUSY, &["in use"]);
            tc_scene_destroy(&mut handle);
        }
        assert_eq!(handle, h.0, "a busy scene is not destroyed");
        gate.release.store(true, Ordering::SeqCst);
        assert_eq!(baker.join().unwrap(), TC_OK);
    });
    assert!(radiance(s, ball).iter().all(|x| x.is_finite()));
    destroy(s);
}
