//! Without a usable GPU adapter: `TC_BACKEND_GPU` (and `TRANSCUT_BACKEND=gpu` with
//! `TC_BACKEND_DEFAULT`) fails with `TC_GPU_UNAVAILABLE` saying what was searched, and
//! `TC_BACKEND_AUTO` solves on the CPU and says why. No adapter is simulated by a name filter
//! that matches none (`TRANSCUT_GPU_ADAPTER`), set before the process-wide GPU context is
//! first created; one test in this binary, so nothing else races on the environment.

#[allow(dead_code, unused_imports)]
#[path = "../src/lib.rs"]
mod abi;

use std::ffi::CStr;
use std::ptr;

use abi::*;

fn message() -> String {
    // SAFETY: never NULL, copied at once.
    unsafe { CStr::from_ptr(tc_last_error_message()) }.to_string_lossy().into_owned()
}

#[test]
fn gpu_required_fails_clearly_and_auto_falls_back_without_an_adapter() {
    std::env::set_var("TRANSCUT_GPU_ADAPTER", "no-such-adapter-anywhere");
    std::env::remove_var("TRANSCUT_BACKEND");
    // A closed octahedron, 10 mm across, under a sky.
    let positions: [f32; 18] = [5., 0., 0., -5., 0., 0., 0., 5., 0., 0., -5., 0., 0., 0., 5., 0., 0., -5.];
    let indices: [u32; 24] = [0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5];
    let mut s = ptr::null_mut();
    let mut object = 0u32;
    // SAFETY: valid pointers throughout; the scene is destroyed at the end.
    unsafe {
        assert_eq!(tc_scene_create(&mut s), TC_OK);
        assert_eq!(tc_scene_add_mesh(s, positions.as_ptr(), 6, indices.as_ptr(), 24, &mut object), TC_OK);
        assert_eq!(tc_scene_add_environment(s, [1.0; 3].as_ptr()), TC_OK);
        let mut o: TcBakeOptions = std::mem::zeroed();
        tc_bake_options_default(&mut o);
        o.tets = 2_000;

        o.backend = TC_BACKEND_CPU;
        assert_eq!(tc_scene_bake(s, &o, None, ptr::null_mut()), TC_OK, "{}", message());
        let mut cpu = vec![0f32; 18];
        assert_eq!(tc_object_radiance(s, object, cpu.as_mut_ptr(), cpu.len()), TC_OK);

        o.backend = TC_BACKEND_GPU;
        let status = tc_scene_bake(s, &o, None, ptr::null_mut());
        let m = message();
        assert_eq!(status, TC_GPU_UNAVAILABLE, "{m}");
        assert!(m.contains("no GPU adapter") && m.contains("no-such-adapter-anywhere") && m.contains("object 0"), "{m}");
        assert_eq!(m.matches("no GPU adapter found").count(), 1, "said once: {m}");
        assert_eq!(m.matches("install a Vulkan driver").count(), 1, "said once: {m}");
        // A failed bake of an unchanged scene keeps the previous results.
        let mut kept = vec![0f32; 18];
        assert_eq!(tc_object_radiance(s, object, kept.as_mut_ptr(), kept.len()), TC_OK);
        assert_eq!(kept, cpu);

        std::env::set_var("TRANSCUT_BACKEND", "gpu");
        o.backend = TC_BACKEND_DEFAULT;
        assert_eq!(tc_scene_bake(s, &o, None, ptr::null_mut()), TC_GPU_UNAVAILABLE, "{}", message());
        std::env::set_var("TRANSCUT_BACKEND", "quantum");
        assert_eq!(tc_scene_bake(s, &o, None, ptr::null_mut()), TC_INVALID_ARGUMENT);
        assert!(message().contains("quantum"), "{}", message());
        std::env::set_var("TRANSCUT_BACKEND", "auto");
        assert_eq!(tc_scene_bake(s, &o, None, ptr::null_mut()), TC_OK, "{}", message());
        std::env::remove_var("TRANSCUT_BACKEND");

        o.backend = TC_BACKEND_AUTO;
        assert_eq!(tc_scene_bake(s, &o, None, ptr::null_mut()), TC_OK, "{}", message());
        let mut stats: TcBakeStats = std::mem::zeroed();
        stats.size = size_of::<TcBakeStats>() as u32;
        assert_eq!(tc_object_stats(s, object, &mut stats), TC_OK);
        assert_eq!(stats.backend_used, TC_BACKEND_CPU);
        let mut auto = vec![0f32; 18];
        assert_eq!(tc_object_radiance(s, object, auto.as_mut_ptr(), auto.len()), TC_OK);
        assert_eq!(auto, cpu, "auto on the CPU is the CPU path");
        let mut why = [0u8; 1024];
        let mut needed = 0usize;
        assert_eq!(tc_object_backend_fallback(s, object, why.as_mut_ptr().cast(), why.len(), &mut needed), TC_OK);
        let why = CStr::from_bytes_until_nul(&why).unwrap().to_str().unwrap();
        assert_eq!(needed, why.len() + 1);
        assert!(why.contains("no GPU adapter"), "{why}");
        assert_eq!(why.matches("no GPU adapter found").count(), 1, "said once: {why}");
        let mut device = [0x55u8; 8];
        assert_eq!(tc_object_device(s, object, device.as_mut_ptr().cast(), device.len(), ptr::null_mut()), TC_OK);
        assert_eq!(device[0], 0, "no device ran");
        tc_scene_destroy(&mut s);
    }
}
