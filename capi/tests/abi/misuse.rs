//! Misuse: every wrong argument gives a status and a message naming it, and leaves the caller's
//! memory and the scene as they were.

use std::ptr;

use super::abi::*;
use super::common::*;

fn tetrahedron_surface() -> Mesh {
    Mesh {
        positions: vec![0.0, 0.0, 0.0, 10.0, 0.0, 0.0, 0.0, 10.0, 0.0, 0.0, 0.0, 10.0],
        indices: vec![0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3],
    }
}

/// NULL scene handles: every function says `scene` is NULL.
#[test]
fn null_scene_handles() {
    let null = ptr::null_mut::<TcScene>();
    let mut n = 0u32;
    let mut z = 0usize;
    let mut object = 7u32;
    let mut rgb = [0.5f32; 3];
    let mesh = tetrahedron_surface();
    let v = [1.0f64; 3];
    // SAFETY: every other pointer is valid; the scene is NULL on purpose.
    unsafe {
        let calls: Vec<(&str, TcStatus)> = vec![
            ("object_count", tc_scene_object_count(null, &mut n)),
            ("light_count", tc_scene_light_count(null, &mut n)),
            ("add_mesh", tc_scene_add_mesh(null, mesh.positions.as_ptr(), 4, mesh.indices.as_ptr(), 12, &mut object)),
            ("vertex_count", tc_object_vertex_count(null, 0, &mut z)),
            ("set_scale", tc_object_set_scale(null, 0, 1.0)),
            ("set_preset", tc_object_set_medium_preset(null, 0, cstr(c"marble"))),
            ("sun", tc_scene_add_sun(null, v.as_ptr(), v.as_ptr(), 0.0)),
            ("environment", tc_scene_add_environment(null, v.as_ptr())),
            ("clear_lights", tc_scene_clear_lights(null)),
            ("bake", tc_scene_bake(null, ptr::null(), None, ptr::null_mut())),
            ("radiance", tc_object_radiance(null, 0, rgb.as_mut_ptr(), 3)),
            // The scene is checked before any data or file is read.
            ("voxel_file", tc_object_set_medium_voxel_file(null, 0, cstr(c"/no/such/grid.tcvox"), 1.3, 0.0)),
            ("voxels", tc_object_set_medium_voxels(null, 0, ptr::null(), ptr::null(), ptr::null(), ptr::null(), 0, 1.3, 0.0)),
            ("per_tet", tc_object_set_media_per_tet(null, 0, ptr::null(), ptr::null(), 7, 1.3, 0.0)),
            ("media_table", tc_object_set_media_table(null, 0, ptr::null(), 3)),
            (
                "add_diffuse_mesh",
                tc_scene_add_diffuse_mesh(
                    null,
                    mesh.positions.as_ptr(),
                    4,
                    mesh.indices.as_ptr(),
                    12,
                    [0.5; 3].as_ptr(),
                    &mut object,
                ),
            ),
            ("set_albedo", tc_object_set_albedo(null, 0, [0.5; 3].as_ptr())),
            ("set_emission", tc_object_set_emission(null, 0, v.as_ptr())),
            ("set_sides", tc_object_set_sides(null, 0, TC_SIDES_BACK)),
            ("material", tc_object_material(null, 0, &mut n)),
        ];
        for (what, status) in calls {
            assert_eq!(status, TC_NULL_POINTER, "{what}");
        }
        fails(tc_object_radiance(null, 0, rgb.as_mut_ptr(), 3), TC_NULL_POINTER, &["tc_object_radiance", "`scene` is NULL"]);
    }
    assert_eq!((n, z, object, rgb), (0, 0, 7, [0.5; 3]), "outputs untouched");
}

/// NULL pointer arguments other than the scene are named in the message.
#[test]
fn null_arguments_are_named() {
    let s = scene();
    let mesh = tetrahedron_surface();
    let mut object = 99u32;
    // SAFETY: NULLs on purpose, everything else valid.
    unsafe {
        fails(tc_scene_create(ptr::null_mut()), TC_NULL_POINTER, &["`out`"]);
        fails(
            tc_scene_add_mesh(s, ptr::null(), 4, mesh.indices.as_ptr(), 12, &mut object),
            TC_NULL_POINTER,
            &["`positions`", "length is 12"],
        );
        fails(tc_scene_add_mesh(s, mesh.positions.as_ptr(), 4, ptr::null(), 12, &mut object), TC_NULL_POINTER, &["`indices`"]);
        fails(
            tc_scene_add_mesh(s, mesh.positions.as_ptr(), 4, mesh.indices.as_ptr(), 12, ptr::null_mut()),
            TC_NULL_POINTER,
            &["`out_object`"],
        );
        fails(tc_scene_add_sun(s, ptr::null(), [1.0; 3].as_ptr(), 0.0), TC_NULL_POINTER, &["`direction`"]);
        fails(tc_scene_add_point(s, [0.0; 3].as_ptr(), ptr::null()), TC_NULL_POINTER, &["`intensity`"]);
        fails(tc_medium_preset(ptr::null(), &mut std::mem::zeroed()), TC_NULL_POINTER, &["`name`"]);
        fails(tc_medium_preset(cstr(c"marble"), ptr::null_mut()), TC_NULL_POINTER, &["`out`"]);
        fails(tc_scene_add_mesh_file(s, ptr::null(), &mut object), TC_NULL_POINTER, &["`path`"]);
        fails(tc_object_stats(s, 0, ptr::null_mut()), TC_NULL_POINTER, &["`out`"]);
        let mut n = 0;
        ok(tc_scene_object_count(s, &mut n), "count");
        assert_eq!(n, 0, "nothing was added");
    }
    assert_eq!(object, 99);
    destroy(s);
}

/// Invalid meshes: NaN and infinite coordinates, indices out of range, index counts that are not
/// a multiple of 3, empty meshes, a misaligned array; the scene stays empty.
#[test]
fn invalid_meshes_are_rejected_without_changing_the_scene() {
    let s = scene();
    let good = tetrahedron_surface();
    let add_raw = |positions: &[f32], indices: &[u32]| {
        let mut object = 42u32;
        // SAFETY: arrays of the given lengths.
        let status = unsafe {
            tc_scene_add_mesh(s, positions.as_ptr(), positions.len() / 3, indices.as_ptr(), indices.len(), &mut object)
        };
        if status != TC_OK {
            assert_eq!(object, 42, "out_object untouched on failure");
        }
        status
    };
    let mut nan = good.positions.clone();
    nan[4] = f32::NAN;
    fails(add_raw(&nan, &good.indices), TC_INVALID_MESH, &["vertex 1", "non-finite"]);
    let mut inf = good.positions.clone();
    inf[9] = f32::INFINITY;
    fails(add_raw(&inf, &good.indices), TC_INVALID_MESH, &["vertex 3"]);
    let mut out_of_range = good.indices.clone();
    out_of_range[5] = 4;
    fails(add_raw(&good.positions, &out_of_range), TC_INVALID_MESH, &["vertex 4", "4 vertices"]);
    fails(add_raw(&good.positions, &good.indices[..11]), TC_INVALID_MESH, &["multiple of 3"]);
    fails(add_raw(&[], &[]), TC_INVALID_MESH, &["empty"]);
    // A float array that is not 4-byte aligned: one byte into an array of u32.
    let words = [0u32; 13];
    let misaligned = words.as_ptr().cast::<u8>().wrapping_add(1).cast::<f32>();
    let mut object = 42u32;
    // SAFETY: 48 readable bytes at `misaligned`; the library must refuse before reading them.
    let status = unsafe { tc_scene_add_mesh(s, misaligned, 4, good.indices.as_ptr(), 12, &mut object) };
    fails(status, TC_INVALID_ARGUMENT, &["`positions`", "aligned"]);
    let mut n = 1;
    // SAFETY: valid pointers.
    ok(unsafe { tc_scene_object_count(s, &mut n) }, "count");
    assert_eq!(n, 0);
    assert_eq!(add_raw(&good.positions, &good.indices), TC_OK);
    destroy(s);
}

/// Object indices out of range are TC_INVALID_HANDLE, naming the index and the count.
#[test]
fn object_indices_out_of_range() {
    let s = scene();
    add(s, &tetrahedron_surface());
    let mut z = 5usize;
    let mut rgb = [3.0f32; 12];
    let m = TcMedium { sigma_a: [0.01; 3], sigma_s_prime: [1.0; 3], eta: 1.3, g: 0.0 };
    // SAFETY: valid pointers; index 1 does not exist.
    unsafe {
        fails(tc_object_vertex_count(s, 1, &mut z), TC_INVALID_HANDLE, &["object 1", "1 objects"]);
        fails(tc_object_set_medium(s, 1, &m), TC_INVALID_HANDLE, &["object 1"]);
        fails(tc_object_set_scale(s, u32::MAX, 2.0), TC_INVALID_HANDLE, &["4294967295"]);
        fails(tc_object_set_name(s, 3, cstr(c"x")), TC_INVALID_HANDLE, &["object 3"]);
        fails(tc_object_radiance(s, 1, rgb.as_mut_ptr(), 12), TC_INVALID_HANDLE, &["object 1"]);
        // The object index is checked before the file or the data: a missing file, NULL data.
        fails(tc_object_set_medium_voxel_file(s, 1, cstr(c"/no/such/grid.tcvox"), 1.3, 0.0), TC_INVALID_HANDLE, &["object 1"]);
        fails(tc_object_set_media_per_tet(s, 1, ptr::null(), ptr::null(), 7, 1.3, 0.0), TC_INVALID_HANDLE, &["object 1"]);
        fails(tc_object_set_media_table(s, 1, ptr::null(), 3), TC_INVALID_HANDLE, &["object 1"]);
        let f = [1.0f32; 6];
        let (dims, v3) = ([1u32; 3], [1.0f64; 3]);
        let voxels = tc_object_set_medium_voxels(s, 1, dims.as_ptr(), v3.as_ptr(), v3.as_ptr(), f.as_ptr(), 6, 1.3, 0.0);
        fails(voxels, TC_INVALID_HANDLE, &["object 1"]);
        // With a valid object, the file is read: a missing one is TC_NOT_FOUND.
        fails(tc_object_set_medium_voxel_file(s, 0, cstr(c"/no/such/grid.tcvox"), 1.3, 0.0), TC_NOT_FOUND, &["grid.tcvox"]);
    }
    assert_eq!((z, rgb), (5, [3.0; 12]));
    destroy(s);
}

/// Out-of-range values name the field; the object keeps its previous medium, transform and
/// scale (a bake afterwards succeeds).
#[test]
fn invalid_values_name_the_field() {
    let s = scene();
    let ball = add(s, &Mesh::uv_sphere(10.0, 16, 8));
    let v = [1.0f64; 3];
    // SAFETY: valid pointers.
    unsafe {
        let bad = TcMedium { sigma_a: [0.01, -0.5, 0.01], sigma_s_prime: [1.0; 3], eta: 1.3, g: 0.0 };
        fails(tc_object_set_medium(s, ball, &bad), TC_INVALID_ARGUMENT, &["sigma_a[1]", "-0.5"]);
        let bad = TcMedium { sigma_a: [0.01; 3], sigma_s_prime: [1.0; 3], eta: f64::NAN, g: 0.0 };
        fails(tc_object_set_medium(s, ball, &bad), TC_INVALID_ARGUMENT, &["eta"]);
        fails(tc_object_set_medium_preset(s, ball, cstr(c"unobtainium")), TC_NOT_FOUND, &["unobtainium", "marble", "skin1"]);
        let artist =
            TcArtistMedium { albedo: [0.8, 1.5, 0.5], radius: [1.0; 3], scale: 1.0, ior: 1.4, anisotropy: 0.0, mapping: 0 };
        fails(tc_object_set_medium_artist(s, ball, &artist), TC_INVALID_ARGUMENT, &["albedo[1]"]);
        let artist = TcArtistMedium { albedo: [0.8; 3], mapping: 3, ..artist };
        fails(tc_object_set_medium_artist(s, ball, &artist), TC_INVALID_ARGUMENT, &["mapping 3", "TC_ARTIST_DIPOLE"]);
        fails(tc_object_set_scale(s, ball, -1.0), TC_INVALID_ARGUMENT, &["mm_per_unit"]);
        fails(tc_object_set_scale(s, ball, f64::INFINITY), TC_INVALID_ARGUMENT, &["mm_per_unit"]);
        let mut singular = [0.0f32; 16];
        singular[15] = 1.0;
        fails(tc_object_set_transform(s, ball, singular.as_ptr()), TC_INVALID_ARGUMENT, &["singular"]);
        let mut nan = [0.0f32; 16];
        nan[0] = f32::NAN;
        fails(tc_object_set_transform(s, ball, nan.as_ptr()), TC_INVALID_ARGUMENT, &["NaN"]);
        let mut projective = [0.0f32; 16];
        for i in [0, 5, 10, 15] {
            projective[i] = 1.0;
        }
        projective[3] = 0.5; // last row, first column
        fails(tc_object_set_transform(s, ball, projective.as_ptr()), TC_INVALID_ARGUMENT, &["affine"]);
        // Lights.
        fails(tc_scene_add_sun(s, [0.0; 3].as_ptr(), v.as_ptr(), 0.0), TC_INVALID_ARGUMENT, &["direction", "non-zero"]);
        fails(
            tc_scene_add_sun(s, [0.0, 0.0, -1.0].as_ptr(), [1.0, f64::NAN, 1.0].as_ptr(), 0.0),
            TC_INVALID_ARGUMENT,
            &["irradiance"],
        );
        fails(tc_scene_add_sun(s, [0.0, 0.0, -1.0].as_ptr(), v.as_ptr(), 200.0), TC_INVALID_ARGUMENT, &["angular_diameter"]);
        fails(tc_scene_add_point(s, [f64::NAN, 0.0, 0.0].as_ptr(), v.as_ptr()), TC_INVALID_ARGUMENT, &["position"]);
        fails(
            tc_scene_add_spot(s, [0.0, 0.0, 50.0].as_ptr(), [0.0, 0.0, -1.0].as_ptr(), v.as_ptr(), 120.0, 0.1),
            TC_INVALID_ARGUMENT,
            &["cone"],
        );
        fails(
            tc_scene_add_disc(s, [0.0; 3].as_ptr(), [0.0, 0.0, 1.0].as_ptr(), -1.0, v.as_ptr(), 0),
            TC_INVALID_ARGUMENT,
            &["radius"],
        );
        fails(tc_scene_add_environment(s, [-1.0, 1.0, 1.0].as_ptr()), TC_INVALID_ARGUMENT, &["radiance"]);
        let mut image = [1.0f32; 3 * 8 * 4];
        fails(tc_scene_add_environment_image(s, image.as_ptr(), 0, 4, 1.0), TC_INVALID_ARGUMENT, &["at least 1"]);
        fails(tc_scene_add_environment_image(s, image.as_ptr(), 8, 4, -2.0), TC_INVALID_ARGUMENT, &["intensity"]);
        fails(tc_scene_add_environment_image(s, ptr::null(), 8, 4, 1.0), TC_NULL_POINTER, &["`rgb`"]);
        fails(tc_scene_add_environment_image(s, image.as_ptr(), usize::MAX, 4, 1.0), TC_INVALID_ARGUMENT, &["too large"]);
        image[3 * 9 + 1] = f32::NAN;
        fails(tc_scene_add_environment_image(s, image.as_ptr(), 8, 4, 1.0), TC_INVALID_ARGUMENT, &["column 1, row 1"]);
        image[3 * 9 + 1] = 1.0;
        let mut lights = 9;
        ok(tc_scene_light_count(s, &mut lights), "light count");
        assert_eq!(lights, 0, "no invalid light was added");
        ok(tc_scene_add_environment_image(s, image.as_ptr(), 8, 4, 1.0), "a valid image");
        ok(tc_scene_bake(s, &options(2_000), None, ptr::null_mut()), "the object is still valid");
    }
    destroy(s);
}

/// Short output buffers: TC_BUFFER_TOO_SHORT naming both lengths, and not one float written.
/// Results before a bake, and after a change, are TC_NOT_BAKED.
#[test]
fn short_buffers_and_missing_results() {
    let s = scene();
    let mesh = Mesh::uv_sphere(10.0, 16, 8);
    let ball = add(s, &mesh);
    let n = mesh.vertex_count();
    let mut rgb = vec![-3.0f32; 3 * n];
    // SAFETY: buffers of the given lengths.
    unsafe {
        fails(tc_object_radiance(s, ball, rgb.as_mut_ptr(), rgb.len()), TC_NOT_BAKED, &["tc_scene_bake"]);
        ok(tc_scene_add_environment(s, [1.0; 3].as_ptr()), "sky");
        ok(tc_scene_bake(s, &options(2_000), None, ptr::null_mut()), "bake");
        let needed = format!("needs {}", 3 * n);
        fails(
            tc_object_radiance(s, ball, rgb.as_mut_ptr(), 3 * n - 1),
            TC_BUFFER_TOO_SHORT,
            &[&needed, &format!("{}", 3 * n - 1)],
        );
        fails(tc_object_radiance(s, ball, rgb.as_mut_ptr(), 0), TC_BUFFER_TOO_SHORT, &[&needed]);
        assert!(rgb.iter().all(|&x| x == -3.0), "the buffer was written on failure");
        // Stats with a size that is too small: refused, untouched.
        let mut stats: TcBakeStats = std::mem::zeroed();
        stats.size = 16;
        stats.tets = 12345;
        fails(tc_object_stats(s, ball, &mut stats), TC_INVALID_ARGUMENT, &["size"]);
        assert_eq!((stats.size, stats.tets), (16, 12345));
        // A longer buffer is fine, the tail untouched.
        let mut long = vec![-3.0f32; 3 * n + 5];
        ok(tc_object_radiance(s, ball, long.as_mut_ptr(), long.len()), "radiance");
        assert!(long[..3 * n].iter().all(|&x| x > 0.0) && long[3 * n..].iter().all(|&x| x == -3.0));
        // Any change discards the results.
        ok(tc_object_set_scale(s, ball, 2.0), "scale");
        fails(tc_object_radiance(s, ball, long.as_mut_ptr(), long.len()), TC_NOT_BAKED, &[]);
        stats.size = size_of::<TcBakeStats>() as u32;
        fails(tc_object_stats(s, ball, &mut stats), TC_NOT_BAKED, &[]);
    }
    destroy(s);
}

/// Destroying: the documented pattern (`tc_scene_destroy(&scene)`) NULLs the handle, so a second
/// destroy is a no-op, as is destroying NULL; a pointer that is not a scene is refused by
/// later calls.
#[test]
fn destroying_twice_and_foreign_pointers() {
    let mut s = scene();
    // SAFETY: the documented pattern.
    unsafe {
        tc_scene_destroy(&mut s);
        assert!(s.is_null());
        tc_scene_destroy(&mut s);
        tc_scene_destroy(ptr::null_mut());
    }
    assert!(s.is_null());
    // Something that is not a scene (a well-aligned block of zeros, big enough).
    let fake = vec![0u64; 64];
    let mut n = 0;
    // SAFETY: readable memory of the right alignment; the magic check refuses it.
    let status = unsafe { tc_scene_object_count(fake.as_ptr().cast(), &mut n) };
    fails(status, TC_INVALID_HANDLE, &["not a TcScene"]);
}

/// Unknown files: TC_NOT_FOUND naming the path; unreadable content: TC_INVALID_MESH /
/// TC_IO_ERROR.
#[test]
fn missing_and_broken_files() {
    let s = scene();
    let dir = std::env::temp_dir().join(format!("transcut-capi-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let broken_obj = dir.join("broken.obj");
    std::fs::write(&broken_obj, "v 0 0 0\nv 1 0 0\nf 1 2 9\n").unwrap();
    let broken_hdr = dir.join("broken.hdr");
    std::fs::write(&broken_hdr, "not an image").unwrap();
    let c = |p: &std::path::Path| std::ffi::CString::new(p.to_str().unwrap()).unwrap();
    let mut object = 5u32;
    // SAFETY: valid pointers.
    unsafe {
        fails(tc_scene_add_mesh_file(s, cstr(c"/nonexistent/ball.obj"), &mut object), TC_NOT_FOUND, &["/nonexistent/ball.obj"]);
        fails(tc_scene_add_mesh_file(s, c(&broken_obj).as_ptr(), &mut object), TC_INVALID_MESH, &["broken.obj", "9"]);
        fails(tc_scene_add_environment_file(s, cstr(c"/nonexistent/sky.hdr"), 1.0), TC_NOT_FOUND, &["sky.hdr"]);
        fails(tc_scene_add_environment_file(s, c(&broken_hdr).as_ptr(), 1.0), TC_IO_ERROR, &["broken.hdr"]);
    }
    assert_eq!(object, 5);
    std::fs::remove_dir_all(&dir).unwrap();
    destroy(s);
}

/// A panic inside the library comes back as TC_INTERNAL_ERROR with a message (no unwinding into
/// the caller, no abort), and the next call works normally.
#[test]
fn an_internal_panic_is_an_error_status() {
    let status = tc_debug_panic();
    fails(status, TC_INTERNAL_ERROR, &["tc_debug_panic", "internal error", "deliberate panic"]);
    let s = scene();
    assert_eq!(message(), "", "a success clears the message");
    destroy(s);
}

/// A panic inside the guard prints nothing on the host's stderr: its message and location go
/// into the last error instead. Checked in a child process (this test binary, running only
/// this test with `TRANSCUT_TEST_PANIC_CHILD` set), whose stderr is captured.
#[test]
fn a_panic_prints_nothing_on_stderr() {
    if std::env::var_os("TRANSCUT_TEST_PANIC_CHILD").is_some() {
        let status = tc_debug_panic();
        assert_eq!(status, TC_INTERNAL_ERROR);
        let m = message();
        assert!(m.contains("deliberate panic") && m.contains("test_hooks.rs:"), "{m}");
        println!("child: {m}");
        // A panic outside the guard still reaches the previous hook (the default one prints).
        let outside = std::panic::catch_unwind(|| panic!("a host panic, outside the library"));
        assert!(outside.is_err());
        return;
    }
    let exe = std::env::current_exe().unwrap();
    let out = std::process::Command::new(exe)
        .args(["--exact", "misuse::a_panic_prints_nothing_on_stderr", "--nocapture", "--test-threads=1"])
        .env("TRANSCUT_TEST_PANIC_CHILD", "1")
        .env("RUST_BACKTRACE", "1")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "child failed:\n{stdout}\n{stderr}");
    assert!(stdout.contains("child: tc_debug_panic: internal error (a bug in libtranscut): deliberate panic"), "{stdout}");
    assert!(!stderr.contains("deliberate panic"), "the library's panic reached stderr:\n{stderr}");
    // Everything before the host's own panic (which prints, with its backtrace) is silent.
    let (before, host) = stderr.split_once("a host panic, outside the library").expect("the host's own panics still print");
    assert!(!before.contains("stack backtrace") && !before.contains("test_hooks.rs"), "the library printed:\n{stderr}");
    assert!(host.contains("stack backtrace"), "the previous hook still runs for the host's panics:\n{stderr}");
}

/// Threads, samples, tets and iterations above their documented bounds are refused with
/// `TC_INVALID_ARGUMENT`, naming the field, the value and the bound; at the bound they pass
/// the check.
#[test]
fn bake_options_above_their_bounds_are_refused() {
    let s = scene();
    add(s, &tetrahedron_surface());
    type Set = fn(&mut TcBakeOptions);
    let cases: [(Set, &str); 6] = [
        (|o| o.threads = 1000, "options->threads = 1000 is above the maximum of 256"),
        (|o| o.threads = TC_MAX_THREADS + 1, "options->threads = 257"),
        (|o| o.area_samples = u32::MAX, "options->area_samples = 4294967295 is above the maximum of 1048576"),
        (|o| o.environment_samples = TC_MAX_SAMPLES + 1, "options->environment_samples = 1048577"),
        (|o| o.tets = TC_MAX_TETS + 1, "options->tets = 20000001 is above the maximum of 20000000"),
        (|o| o.max_iterations = TC_MAX_ITERATIONS + 1, "options->max_iterations = 1000001"),
    ];
    for (set, needle) in cases {
        let mut o = options(500);
        set(&mut o);
        // SAFETY: valid pointers.
        fails(unsafe { tc_scene_bake(s, &o, None, ptr::null_mut()) }, TC_INVALID_ARGUMENT, &["tc_scene_bake", needle]);
    }
    destroy(s);
}

/// Status names, the message lifetime rule (empty after a success), UTF-8 checks.
#[test]
fn status_names_and_messages() {
    assert_eq!(name(TC_OK), "TC_OK");
    assert_eq!(name(TC_BUFFER_TOO_SHORT), "TC_BUFFER_TOO_SHORT");
    assert_eq!(name(TC_BUSY), "TC_BUSY");
    assert_eq!(name(TcStatus(999)), "unknown status");
    let s = scene();
    let ball = add(s, &tetrahedron_surface());
    let not_utf8 = [0xffu8, 0xfe, 0];
    // SAFETY: a NUL-terminated byte string.
    unsafe {
        fails(tc_object_set_name(s, ball, not_utf8.as_ptr().cast()), TC_INVALID_ARGUMENT, &["UTF-8"]);
        ok(tc_object_set_name(s, ball, cstr(c"crystal")), "name");
    }
    assert_eq!(message(), "");
    destroy(s);
}

/// No thread of the library outlives a call: after a bake, a relight and the scene's
/// destruction the process has the threads it had before (rayon's global pool, which is never
/// joined, is not used). In a child process (this test alone), so that no other test's threads
/// are counted.
#[cfg(target_os = "linux")]
#[test]
fn no_library_thread_outlives_a_call() {
    let threads = || std::fs::read_dir("/proc/self/task").unwrap().count();
    if std::env::var_os("TRANSCUT_TEST_THREADS_CHILD").is_some() {
        let before = threads();
        let s = scene();
        add(s, &Mesh::uv_sphere(5.0, 16, 8));
        let sun = ([0.0f64, 0.0, -1.0], [2.0f64; 3]);
        // SAFETY: valid pointers.
        unsafe {
            ok(tc_scene_add_sun(s, sun.0.as_ptr(), sun.1.as_ptr(), 0.0), "sun");
            let mut o = options(2_000);
            o.backend = TC_BACKEND_CPU;
            ok(tc_scene_bake(s, &o, None, ptr::null_mut()), "bake");
            o.threads = 3;
            ok(tc_scene_bake(s, &o, None, ptr::null_mut()), "bake on 3 threads");
            assert_eq!(threads(), before, "after the bakes");
            ok(tc_scene_relight(s, None, ptr::null_mut()), "relight");
        }
        let _ = radiance(s, 0);
        destroy(s);
        assert_eq!(threads(), before, "after the relight and the destruction");
        println!("child: {before} threads before and after");
        return;
    }
    let exe = std::env::current_exe().unwrap();
    let out = std::process::Command::new(exe)
        .args(["--exact", "misuse::no_library_thread_outlives_a_call", "--nocapture", "--test-threads=1"])
        .env("TRANSCUT_TEST_THREADS_CHILD", "1")
        .env("TRANSCUT_BACKEND", "cpu")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "child failed:\n{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("threads before and after"), "{stdout}");
}
