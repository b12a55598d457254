//! The backend option (`TcBakeOptions.backend`) and what the stats say about it: CPU and AUTO
//! agree, GPU runs on whatever adapter exists (lavapipe in CI: scripts/install-lavapipe.sh) and
//! matches the CPU, an unknown value is refused naming the field, the older `TcBakeStats` size
//! still works. Without any adapter these tests FAIL, unless `TRANSCUT_GPU_TESTS=skip` (then
//! the GPU part is skipped, loudly). The no-adapter behaviour is `capi/tests/gpu_missing.rs`.

use std::ffi::CStr;
use std::ptr;

use super::abi::*;
use super::common::*;

/// A skin sphere lit by a sun, baked with `backend`; returns the status and, on success, the
/// radiance and stats.
fn bake_with_backend(backend: u32) -> (*mut TcScene, TcStatus) {
    let s = scene();
    let ball = add(s, &Mesh::uv_sphere(12.0, 32, 16));
    // SAFETY: valid pointers.
    unsafe {
        // Marble: resolved at 4k tets (skin's blue on this sphere would need 100k).
        ok(tc_object_set_medium_preset(s, ball, cstr(c"marble")), "preset");
        ok(tc_scene_add_sun(s, [0.3, 0.2, -1.0].as_ptr(), [2.0; 3].as_ptr(), 0.0), "sun");
        ok(tc_scene_add_environment(s, [0.2, 0.3, 0.4].as_ptr()), "sky");
    }
    let mut o = options(4_000);
    o.backend = backend;
    o.tolerance = 1e-8;
    // SAFETY: valid pointers.
    let status = unsafe { tc_scene_bake(s, &o, None, ptr::null_mut()) };
    (s, status)
}

/// The stats of object 0.
fn stats(s: *mut TcScene) -> TcBakeStats {
    // SAFETY: an all-zero struct is a valid value to overwrite.
    let mut st: TcBakeStats = unsafe { std::mem::zeroed() };
    st.size = size_of::<TcBakeStats>() as u32;
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_stats(s, 0, &mut st) }, "stats");
    st
}

/// `tc_object_device` or `tc_object_backend_fallback` of object 0, through the size query.
fn text(
    s: *mut TcScene,
    f: unsafe extern "C" fn(*const TcScene, u32, *mut std::ffi::c_char, usize, *mut usize) -> TcStatus,
) -> String {
    let mut needed = 0usize;
    // SAFETY: the documented size query (NULL, 0).
    ok(unsafe { f(s, 0, ptr::null_mut(), 0, &mut needed) }, "size query");
    assert!(needed >= 1);
    let mut buf = vec![0x55u8; needed];
    let mut again = 0usize;
    // SAFETY: a buffer of `needed` bytes.
    ok(unsafe { f(s, 0, buf.as_mut_ptr().cast(), needed, &mut again) }, "text");
    assert_eq!(again, needed);
    CStr::from_bytes_with_nul(&buf).expect("NUL-terminated, no interior NUL").to_str().unwrap().to_owned()
}

/// Whether the GPU part must run (no `TRANSCUT_GPU_TESTS=skip`).
fn gpu_tests_wanted() -> bool {
    if std::env::var("TRANSCUT_GPU_TESTS").is_ok_and(|v| v == "skip") {
        eprintln!("\n**** TRANSCUT_GPU_TESTS=skip: GPU TEST SKIPPED, THE GPU PATH OF THE C ABI IS NOT TESTED ****\n");
        return false;
    }
    true
}

/// CPU is the CPU path and says so (no device, no fallback); AUTO gives the same radiance,
/// bit for bit when it solved on the CPU (no hardware adapter: it says why), within the GPU's
/// accuracy (1e-5 relative to the largest value) when a hardware GPU ran.
#[test]
fn cpu_and_auto_agree_and_the_stats_say_where_it_ran() {
    let (cpu, status) = bake_with_backend(TC_BACKEND_CPU);
    ok(status, "bake on the CPU");
    let st = stats(cpu);
    assert_eq!(st.backend_used, TC_BACKEND_CPU);
    assert_eq!(text(cpu, tc_object_device), "");
    assert_eq!(text(cpu, tc_object_backend_fallback), "");
    let reference = radiance(cpu, 0);

    let (auto, status) = bake_with_backend(TC_BACKEND_AUTO);
    ok(status, "bake with auto");
    let st = stats(auto);
    let lo = radiance(auto, 0);
    match st.backend_used {
        TC_BACKEND_CPU => {
            let why = text(auto, tc_object_backend_fallback);
            eprintln!("auto solved on the CPU: {why}");
            assert!(!why.is_empty(), "auto on the CPU must say why");
            assert_eq!(text(auto, tc_object_device), "");
            assert_eq!(lo, reference, "auto on the CPU is the CPU path");
        }
        TC_BACKEND_GPU => {
            let device = text(auto, tc_object_device);
            eprintln!("auto solved on the GPU {device}");
            assert!(!device.is_empty());
            assert_eq!(text(auto, tc_object_backend_fallback), "");
            assert_close(&lo, &reference, 1e-5);
        }
        other => panic!("backend_used = {other}"),
    }
    // Whichever text is not empty: a buffer one byte short is refused naming the size needed,
    // and left as it was.
    let f = if st.backend_used == TC_BACKEND_CPU { tc_object_backend_fallback } else { tc_object_device };
    let full = text(auto, f);
    let mut buf = vec![0x55u8; full.len()];
    let mut needed = 0usize;
    // SAFETY: a buffer of the given length.
    let status = unsafe { f(auto, 0, buf.as_mut_ptr().cast(), buf.len(), &mut needed) };
    fails(status, TC_BUFFER_TOO_SHORT, &[&format!("needs {}", full.len() + 1)]);
    assert!(buf.iter().all(|&b| b == 0x55) && needed == 0, "written on failure");
    destroy(cpu);
    destroy(auto);
}

/// Asserts `|a − b| ≤ tol · max|b|` everywhere.
fn assert_close(a: &[f32], b: &[f32], tol: f64) {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().fold(0.0f64, |m, &x| m.max(f64::from(x.abs())));
    let worst = a.iter().zip(b).map(|(x, y)| f64::from((x - y).abs())).fold(0.0, f64::max);
    eprintln!("largest difference {worst:.3e} of {scale:.3e} ({:.2e} relative)", worst / scale);
    assert!(worst <= tol * scale, "largest difference {worst} > {tol} × {scale}");
}

/// GPU runs on the adapter there is (lavapipe on a machine without a GPU), names it, and
/// matches the CPU: the f32 device solve sits inside an f64 refinement to the same tolerance.
#[test]
fn gpu_runs_on_the_adapter_there_is_and_matches_the_cpu() {
    if !gpu_tests_wanted() {
        return;
    }
    let (gpu, status) = bake_with_backend(TC_BACKEND_GPU);
    if status != TC_OK {
        panic!(
            "a bake with TC_BACKEND_GPU failed ({}): {}\nRun scripts/install-lavapipe.sh (Mesa's software Vulkan) \
             or set TRANSCUT_GPU_TESTS=skip to skip this test explicitly.",
            name(status),
            message()
        );
    }
    let st = stats(gpu);
    assert_eq!(st.backend_used, TC_BACKEND_GPU);
    let device = text(gpu, tc_object_device);
    eprintln!("GPU bake on {device}");
    assert!(!device.is_empty());
    assert_eq!(text(gpu, tc_object_backend_fallback), "");
    let (cpu, status) = bake_with_backend(TC_BACKEND_CPU);
    ok(status, "bake on the CPU");
    assert_close(&radiance(gpu, 0), &radiance(cpu, 0), 1e-5);
    destroy(gpu);
    destroy(cpu);
}

/// An unknown backend value is TC_INVALID_ARGUMENT naming the field and the valid values;
/// the previous results stay.
#[test]
fn an_unknown_backend_is_refused_naming_it() {
    let (s, status) = bake_with_backend(TC_BACKEND_CPU);
    ok(status, "bake");
    let before = radiance(s, 0);
    let mut o = options(4_000);
    for bad in [4, 7, u32::MAX] {
        o.backend = bad;
        // SAFETY: valid pointers.
        let status = unsafe { tc_scene_bake(s, &o, None, ptr::null_mut()) };
        fails(status, TC_INVALID_ARGUMENT, &["options->backend", &bad.to_string(), "TC_BACKEND_CPU = 1"]);
        assert_eq!(radiance(s, 0), before);
    }
    destroy(s);
}

/// Defaults: backend TC_BACKEND_DEFAULT; sizes: the options struct grew to 56 (the
/// `method_options` pointer; a caller of the 48-byte struct bakes with the method's defaults:
/// see `bake::an_older_options_struct_bakes_as_before`), the stats grew to 96, 128 and then
/// 136, and a caller built against an older stats struct (size 88, 96 or 128) gets exactly
/// those bytes and that size, the bytes after untouched.
#[test]
fn defaults_and_the_older_stats_size() {
    assert_eq!(size_of::<TcBakeOptions>(), 56);
    assert_eq!(size_of::<TcBakeStats>(), 136);
    assert_eq!(options(1).backend, TC_BACKEND_DEFAULT);
    let (s, status) = bake_with_backend(TC_BACKEND_CPU);
    ok(status, "bake");
    let full = stats(s);
    assert_eq!(full.size, 136);
    // The 128-byte struct (before mesh_reused): resolution, nothing after.
    #[repr(C)]
    struct Before128 {
        stats: [u64; 16],
        guard: [u64; 4],
    }
    let mut before = Before128 { stats: [0; 16], guard: [0xA5A5_A5A5_A5A5_A5A5; 4] };
    before.stats[0] = 128;
    // SAFETY: 128 writable bytes at the start, as the size says (aligned as TcBakeStats).
    ok(unsafe { tc_object_stats(s, 0, (&raw mut before).cast()) }, "stats, size 128");
    assert_eq!(before.stats[0] & 0xFFFF_FFFF, 128, "size written back");
    assert_eq!(f64::from_bits(before.stats[15]), full.resolution[2], "resolution ends at byte 128");
    assert_eq!(before.guard, [0xA5A5_A5A5_A5A5_A5A5; 4], "bytes beyond the older size were written");
    // The 96-byte struct (before flipped_faces and resolution): backend_used, nothing after.
    #[repr(C)]
    struct Before {
        stats: [u64; 12],
        guard: [u64; 4],
    }
    let mut before = Before { stats: [0; 12], guard: [0xA5A5_A5A5_A5A5_A5A5; 4] };
    before.stats[0] = 96;
    // SAFETY: 96 writable bytes at the start, as the size says (aligned as TcBakeStats).
    ok(unsafe { tc_object_stats(s, 0, (&raw mut before).cast()) }, "stats, size 96");
    assert_eq!(before.stats[0] & 0xFFFF_FFFF, 96, "size written back");
    assert_eq!(before.stats[11] & 0xFFFF_FFFF, u64::from(full.backend_used), "backend_used at byte 88");
    assert_eq!(before.guard, [0xA5A5_A5A5_A5A5_A5A5; 4], "bytes beyond the older size were written");
    // An older caller's struct: 88 bytes, then memory the library must not touch.
    #[repr(C)]
    struct Older {
        stats: [u64; 11],
        guard: [u64; 4],
    }
    let mut older = Older { stats: [0; 11], guard: [0xA5A5_A5A5_A5A5_A5A5; 4] };
    older.stats[0] = 88;
    // SAFETY: 88 writable bytes at the start, as the size says (aligned as TcBakeStats).
    ok(unsafe { tc_object_stats(s, 0, (&raw mut older).cast()) }, "stats, size 88");
    assert_eq!(older.stats[0] & 0xFFFF_FFFF, 88, "size written back");
    assert_eq!(older.guard, [0xA5A5_A5A5_A5A5_A5A5; 4], "bytes beyond the older size were written");
    // SAFETY: the first 88 bytes have TcBakeStats' layout.
    let prefix: TcBakeStats = unsafe {
        let mut st: TcBakeStats = std::mem::zeroed();
        ptr::copy_nonoverlapping((&raw const older).cast::<u8>(), (&raw mut st).cast::<u8>(), 88);
        st
    };
    assert_eq!((prefix.tets, prefix.vertices, prefix.iterations), (full.tets, full.vertices, full.iterations));
    assert_eq!(prefix.clamped_vertices, full.clamped_vertices);
    assert_eq!(prefix.backend_used, 0, "not written for the older size");
    let mut small: TcBakeStats = unsafe { std::mem::zeroed() };
    small.size = 80;
    // SAFETY: valid pointers.
    fails(unsafe { tc_object_stats(s, 0, &mut small) }, TC_INVALID_ARGUMENT, &["out->size = 80"]);
    assert_eq!(small.tets, 0);

    // The text functions: too short a buffer is refused naming the size and left untouched.
    let mut buf = [0x55u8; 1];
    let mut needed = 7usize;
    // SAFETY: valid pointers.
    unsafe {
        // The CPU ran: the device text is "" (needs 1 byte), which fits.
        ok(tc_object_device(s, 0, buf.as_mut_ptr().cast(), 1, &mut needed), "device into 1 byte");
        assert_eq!((buf[0], needed), (0, 1));
        let mut buf = [0x55u8; 4];
        fails(tc_object_device(s, 0, ptr::null_mut(), 4, ptr::null_mut()), TC_NULL_POINTER, &["out"]);
        fails(tc_object_device(s, 5, buf.as_mut_ptr().cast(), 4, ptr::null_mut()), TC_INVALID_HANDLE, &["object 5"]);
        assert_eq!(buf, [0x55; 4]);
    }
    destroy(s);
    // Before a bake: TC_NOT_BAKED.
    let s = scene();
    add(s, &Mesh::uv_sphere(5.0, 8, 4));
    let mut buf = [0x55u8; 16];
    // SAFETY: valid pointers.
    fails(unsafe { tc_object_backend_fallback(s, 0, buf.as_mut_ptr().cast(), 16, ptr::null_mut()) }, TC_NOT_BAKED, &[]);
    assert_eq!(buf, [0x55; 16]);
    destroy(s);
}
