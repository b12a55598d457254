//! Choosing the subsurface method through the ABI: the methods listed and named, the method's
//! own options struct, an older options struct, and every misuse named.

use std::ffi::CStr;
use std::ptr;

use super::abi::*;
use super::common::*;

/// The name or description of method `m` through the two-call text protocol.
fn text(f: unsafe extern "C" fn(u32, *mut std::ffi::c_char, usize, *mut usize) -> TcStatus, m: u32) -> String {
    let mut needed = 0usize;
    // SAFETY: valid pointers; NULL with length 0 asks for the size.
    ok(unsafe { f(m, ptr::null_mut(), 0, &mut needed) }, "size");
    let mut buf = vec![0u8; needed];
    // SAFETY: a buffer of the size asked for.
    ok(unsafe { f(m, buf.as_mut_ptr().cast(), buf.len(), ptr::null_mut()) }, "text");
    CStr::from_bytes_with_nul(&buf).unwrap().to_str().unwrap().to_owned()
}

#[test]
fn methods_are_listed_and_named_both_ways() {
    let count = tc_method_count();
    assert!(count >= 1);
    assert_eq!(text(tc_method_name, TC_METHOD_TRANSCUT), "transcut");
    assert!(text(tc_method_description, TC_METHOD_TRANSCUT).contains("TransCut"));
    for m in 0..count {
        let name = std::ffi::CString::new(text(tc_method_name, m)).unwrap();
        let mut back = u32::MAX;
        // SAFETY: valid pointers.
        ok(unsafe { tc_method_from_name(name.as_ptr(), &mut back) }, "from name");
        assert_eq!(back, m);
    }
    let mut out = 77u32;
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_method_from_name(cstr(c"TransCut"), &mut out), "any case");
        assert_eq!(out, TC_METHOD_TRANSCUT);
        out = 77;
        fails(tc_method_from_name(cstr(c"nonsense"), &mut out), TC_NOT_FOUND, &["nonsense", "transcut"]);
        assert_eq!(out, 77, "untouched on failure");
        fails(tc_method_from_name(ptr::null(), &mut out), TC_NULL_POINTER, &["name"]);
        fails(tc_method_name(count, ptr::null_mut(), 0, ptr::null_mut()), TC_NOT_FOUND, &[&count.to_string()]);
        let mut small = [0u8; 3];
        fails(
            tc_method_name(TC_METHOD_TRANSCUT, small.as_mut_ptr().cast(), small.len(), ptr::null_mut()),
            TC_BUFFER_TOO_SHORT,
            &["9"],
        );
        assert_eq!(small, [0; 3], "nothing written on failure");
    }
}

/// A marble ball baked with `options`, its radiance.
fn bake_ball(options: *const TcBakeOptions) -> Result<Vec<f32>, (TcStatus, String)> {
    let s = scene();
    let ball = add(s, &Mesh::uv_sphere(10.0, 24, 12));
    // SAFETY: valid pointers.
    let status = unsafe {
        ok(tc_object_set_medium_preset(s, ball, cstr(c"marble")), "preset");
        ok(tc_scene_add_sun(s, [0.2, -0.3, -1.0].as_ptr(), [3.0; 3].as_ptr(), 0.0), "sun");
        tc_scene_bake(s, options, None, ptr::null_mut())
    };
    let out = if status == TC_OK { Ok(radiance(s, ball)) } else { Err((status, message())) };
    destroy(s);
    out
}

fn cpu_options() -> TcBakeOptions {
    let mut o = options(4_000);
    o.backend = TC_BACKEND_CPU;
    o.tolerance = 1e-10;
    o
}

#[test]
fn the_method_options_choose_the_solver_and_an_older_struct_bakes_as_before() {
    let reference = bake_ball(&cpu_options()).unwrap();
    // A caller built against the 48-byte struct (no `method_options`): the same bake, bit for bit.
    let mut older = cpu_options();
    older.size = 48;
    older.method_options = 8 as *const std::ffi::c_void; // past its size: never read
    assert_eq!(bake_ball(&older).unwrap(), reference);
    // TransCut's options with another solver: the same answer to the solver's tolerance.
    let mut transcut = TcTransCutOptions { size: 0, solver: 7, edit_solver: 7, grading: 7, discretization: 7 };
    // SAFETY: a valid pointer and its size.
    ok(unsafe { tc_transcut_options_init(&mut transcut, size_of::<TcTransCutOptions>()) }, "init");
    assert_eq!(
        (transcut.size as usize, transcut.solver, transcut.edit_solver, transcut.grading, transcut.discretization),
        (size_of::<TcTransCutOptions>(), 0, 0, TC_GRADING_AUTO, TC_DISCRETIZATION_FITTED_LAYER)
    );
    for solver in [TC_SOLVER_PCG, TC_SOLVER_MG_PCG, TC_SOLVER_SA_PCG, TC_SOLVER_CASCADE] {
        transcut.solver = solver;
        let mut o = cpu_options();
        o.method_options = (&raw const transcut).cast();
        let other = bake_ball(&o).unwrap();
        let scale = reference.iter().fold(0.0f32, |m, x| m.max(x.abs()));
        let worst = other.iter().zip(&reference).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
        assert!(worst <= 1e-5 * scale, "solver {solver}: {worst} of {scale}");
    }
}

#[test]
fn bad_method_choices_are_named() {
    let mut o = cpu_options();
    o.method = tc_method_count();
    let (status, msg) = bake_ball(&o).unwrap_err();
    assert_eq!(status, TC_INVALID_ARGUMENT);
    assert!(msg.contains("options->method") && msg.contains("0 = transcut"), "{msg}");
    let mut transcut = TcTransCutOptions { size: 0, solver: 0, edit_solver: 0, grading: 0, discretization: 0 };
    // SAFETY: a valid pointer and its size.
    ok(unsafe { tc_transcut_options_init(&mut transcut, size_of::<TcTransCutOptions>()) }, "init");
    transcut.solver = 99;
    let mut o = cpu_options();
    o.method_options = (&raw const transcut).cast();
    let (status, msg) = bake_ball(&o).unwrap_err();
    assert_eq!(status, TC_INVALID_ARGUMENT);
    assert!(msg.contains("method_options->solver = 99") && msg.contains("SSOR_PCG 2"), "{msg}");
    let short = TcTransCutOptions { size: 4, solver: 0, edit_solver: 0, grading: 0, discretization: 0 };
    o.method_options = (&raw const short).cast();
    let (status, msg) = bake_ball(&o).unwrap_err();
    assert_eq!(status, TC_INVALID_ARGUMENT);
    assert!(msg.contains("sizeof(TcTransCutOptions)") && msg.contains("tc_transcut_options_init"), "{msg}");
    let bytes = [0u8; 32];
    o.method_options = bytes.as_ptr().wrapping_add(1).cast();
    let (status, msg) = bake_ball(&o).unwrap_err();
    assert_eq!(status, TC_INVALID_ARGUMENT);
    assert!(msg.contains("not aligned"), "{msg}");
    // SAFETY: NULL and short sizes are refused.
    unsafe {
        fails(tc_transcut_options_init(ptr::null_mut(), 12), TC_NULL_POINTER, &["options"]);
        let mut t = TcTransCutOptions { size: 5, solver: 5, edit_solver: 5, grading: 5, discretization: 5 };
        fails(tc_transcut_options_init(&mut t, 8), TC_INVALID_ARGUMENT, &["size = 8"]);
        assert_eq!(
            t,
            TcTransCutOptions { size: 5, solver: 5, edit_solver: 5, grading: 5, discretization: 5 },
            "untouched on failure"
        );
    }
}

/// The first version's filler writes its 48 bytes and no more; the sized one writes what the
/// caller's size says, up to what the library knows, and refuses sizes below the first version.
#[test]
fn options_are_filled_only_as_far_as_the_callers_struct_goes() {
    #[repr(C)]
    struct Guarded {
        options: TcBakeOptions,
        after: [u64; 2],
    }
    let pattern = |g: &Guarded| -> Vec<u8> {
        // SAFETY: plain bytes of a repr(C) value.
        unsafe { std::slice::from_raw_parts((&raw const *g).cast::<u8>(), size_of::<Guarded>()).to_vec() }
    };
    // SAFETY: every byte pattern is a valid value of these plain structs except the pointer,
    // which is never dereferenced here.
    let mut g: Guarded = unsafe { std::mem::transmute([0xABu8; size_of::<Guarded>()]) };
    let before = pattern(&g);
    // SAFETY: a valid pointer with at least 48 bytes.
    unsafe { tc_bake_options_default(&mut g.options) };
    let after = pattern(&g);
    assert_eq!(g.options.size, 48);
    assert_eq!(g.options.tets, 200_000);
    assert_eq!(after[48..], before[48..], "tc_bake_options_default wrote past the first version's 48 bytes");
    // SAFETY: as above.
    ok(unsafe { tc_bake_options_init(&mut g.options, size_of::<TcBakeOptions>()) }, "init");
    assert_eq!(g.options.size as usize, size_of::<TcBakeOptions>());
    assert!(g.options.method_options.is_null());
    assert_eq!(g.after, [0xABAB_ABAB_ABAB_ABAB; 2], "nothing past the struct");
    // A newer, larger struct: only what this library knows is written.
    // SAFETY: `Guarded` has that many writable bytes.
    ok(unsafe { tc_bake_options_init(&mut g.options, size_of::<Guarded>()) }, "init larger");
    assert_eq!(g.options.size as usize, size_of::<TcBakeOptions>());
    assert_eq!(g.after, [0xABAB_ABAB_ABAB_ABAB; 2]);
    // SAFETY: valid pointers; the short size is refused before anything is written.
    unsafe {
        let snapshot = pattern(&g);
        fails(tc_bake_options_init(&mut g.options, 40), TC_INVALID_ARGUMENT, &["size = 40"]);
        assert_eq!(pattern(&g), snapshot);
        fails(tc_bake_options_init(ptr::null_mut(), 56), TC_NULL_POINTER, &["options"]);
    }
}
