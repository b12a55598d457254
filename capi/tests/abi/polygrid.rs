//! The polygrid method through the ABI: its options struct filled and read, a bake equal to the
//! Rust API's bit for bit with its statistics, a relight through the session, and bad options
//! refused by name with nothing baked.

use std::ptr;

use glam::DVec3;
use transcut_core::gpu::Backend;
use transcut_core::light::Light;
use transcut_core::mesh::TriMesh;
use transcut_core::optics::Medium;
use transcut_core::{bake, BakeOptions, Object, PolygridOptions, Scene, TransCutOptions};

use super::abi::*;
use super::common::*;

const NODES: u64 = 20_000;
const TOL: f64 = 1e-9;
const SUN: [f64; 3] = [0.2, -0.3, -1.0];
const IRRADIANCE: [f64; 3] = [3.0, 2.5, 2.0];

/// A fine sphere of radius 10 mm (a coarse faceted one may fold the grid's corner cells).
fn ball() -> Mesh {
    Mesh::uv_sphere(10.0, 96, 48)
}

fn polygrid_options() -> TcPolygridOptions {
    // SAFETY: an all-zero struct is a valid value to overwrite.
    let mut p: TcPolygridOptions = unsafe { std::mem::zeroed() };
    // SAFETY: a valid pointer and its size.
    ok(unsafe { tc_polygrid_options_init(&mut p, size_of::<TcPolygridOptions>()) }, "polygrid options");
    p.nodes = NODES;
    p
}

/// Bake options of the polygrid with `polygrid` (which must outlive their use), on the CPU.
fn bake_options(polygrid: &TcPolygridOptions, shadows: bool) -> TcBakeOptions {
    let mut o = options(0);
    o.method = TC_METHOD_POLYGRID;
    o.method_options = (polygrid as *const TcPolygridOptions).cast();
    o.tolerance = TOL;
    o.backend = TC_BACKEND_CPU;
    o.shadows = u32::from(shadows);
    o
}

/// A marble `mesh` under the sun `sun`, baked with `options`; the scene, or the failure.
fn baked(mesh: &Mesh, sun: [f64; 3], options: &TcBakeOptions) -> Result<*mut TcScene, (TcStatus, String)> {
    let s = scene();
    let object = add(s, mesh);
    // SAFETY: valid pointers.
    let status = unsafe {
        ok(tc_object_set_medium_preset(s, object, cstr(c"marble")), "preset");
        ok(tc_scene_add_sun(s, sun.as_ptr(), IRRADIANCE.as_ptr(), 0.0), "sun");
        tc_scene_bake(s, options, None, ptr::null_mut())
    };
    if status == TC_OK {
        Ok(s)
    } else {
        let failure = (status, message());
        destroy(s);
        Err(failure)
    }
}

fn polygrid_stats(s: *mut TcScene, object: u32) -> Result<TcPolygridStats, TcStatus> {
    // SAFETY: an all-zero struct is a valid value to overwrite.
    let mut st: TcPolygridStats = unsafe { std::mem::zeroed() };
    st.size = size_of::<TcPolygridStats>() as u32;
    // SAFETY: valid pointers.
    let status = unsafe { tc_object_polygrid_stats(s, object, &mut st) };
    if status == TC_OK {
        Ok(st)
    } else {
        Err(status)
    }
}

#[test]
fn the_method_is_listed_and_its_options_are_the_cores_defaults() {
    assert!(tc_method_count() > TC_METHOD_POLYGRID);
    let mut out = u32::MAX;
    // SAFETY: valid pointers.
    ok(unsafe { tc_method_from_name(cstr(c"polygrid"), &mut out) }, "from name");
    assert_eq!(out, TC_METHOD_POLYGRID);
    let p = polygrid_options();
    let d = PolygridOptions::default();
    assert_eq!(p.size as usize, size_of::<TcPolygridOptions>());
    assert_eq!((p.resolution, p.cube_mm, p.stencil), (d.resolution, 0.0, TC_POLYGRID_STENCIL_FEM));
    assert_eq!((p.solver, p.edit_solver), (TC_SOLVER_DEFAULT, TC_SOLVER_DEFAULT));
    // SAFETY: NULL and short sizes are refused with nothing written.
    unsafe {
        fails(tc_polygrid_options_init(ptr::null_mut(), size_of::<TcPolygridOptions>()), TC_NULL_POINTER, &["options"]);
        let mut q = p;
        q.resolution = 99;
        fails(tc_polygrid_options_init(&mut q, 16), TC_INVALID_ARGUMENT, &["size = 16"]);
        assert_eq!(q.resolution, 99, "untouched on failure");
    }
}

/// The ABI's bake of a fine sphere is the Rust API's bit for bit; its statistics are the core's;
/// the session relights it (the FEM stencil's state is TransCut's) as a fresh bake does.
#[test]
fn a_bake_equals_the_rust_apis_and_relights() {
    let mesh = ball();
    let p = polygrid_options();
    let s = baked(&mesh, SUN, &bake_options(&p, true)).unwrap();
    let ours = radiance(s, 0);

    // The core, by hand: the same scene and options.
    let xyz: Vec<[f32; 3]> = mesh.positions.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
    let surface = TriMesh::from_triangles(&xyz, &mesh.indices).unwrap();
    let object = Object::new("object 0", surface, Medium::preset("marble").unwrap(), 1.0);
    let sun = Light::Directional { direction: DVec3::from(SUN), irradiance: IRRADIANCE, angular_diameter_deg: 0.0 };
    let scene = Scene { objects: vec![object], lights: vec![sun] };
    let solve = TransCutOptions { tolerance: TOL, backend: Some(Backend::Cpu), ..TransCutOptions::default() };
    let polygrid = PolygridOptions { nodes: NODES as usize, solve, ..PolygridOptions::default() };
    let core = bake(&scene, &BakeOptions::with_method(polygrid)).unwrap();
    let theirs: Vec<f32> = core.objects[0].radiance.iter().flat_map(|l| l.map(|x| x as f32)).collect();
    assert_eq!(ours.len(), 3 * mesh.vertex_count());
    assert!(ours == theirs, "the ABI's bake differs from the Rust API's");
    assert!(ours.iter().all(|x| x.is_finite() && *x >= 0.0) && ours.iter().any(|x| *x > 0.0));

    let st = polygrid_stats(s, 0).unwrap();
    let want = core.objects[0].stats.polygrid.unwrap();
    assert_eq!(st.size as usize, size_of::<TcPolygridStats>());
    assert_eq!((st.resolution, st.cubes, st.nodes, st.cells), (8, want.cubes as u64, want.nodes as u64, want.cells as u64));
    assert_eq!((st.cube_mm, st.min_scaled_jacobian), (want.cube_mm, want.quality.min_scaled_jacobian));
    assert_eq!(st.mean_scaled_jacobian, want.quality.mean_scaled_jacobian);
    assert!(st.cells >= st.cubes && st.nodes > st.cubes && st.min_scaled_jacobian > 0.0);
    // SAFETY: an all-zero struct is a valid value to overwrite.
    let mut bake_stats: TcBakeStats = unsafe { std::mem::zeroed() };
    bake_stats.size = size_of::<TcBakeStats>() as u32;
    // SAFETY: valid pointers.
    ok(unsafe { tc_object_stats(s, 0, &mut bake_stats) }, "stats");
    assert_eq!(bake_stats.vertices, st.nodes, "the solve's unknowns are the grid's nodes");
    assert_eq!(bake_stats.backend_used, TC_BACKEND_CPU);
    // Misuse of the statistics call, nothing written.
    // SAFETY: valid pointers except where NULL is the point.
    unsafe {
        let mut short = st;
        short.size = 8;
        fails(tc_object_polygrid_stats(s, 0, &mut short), TC_INVALID_ARGUMENT, &["sizeof(TcPolygridStats)"]);
        assert_eq!(short.cubes, st.cubes);
        fails(tc_object_polygrid_stats(s, 0, ptr::null_mut()), TC_NULL_POINTER, &["out"]);
        let mut any = st;
        fails(tc_object_polygrid_stats(s, 1, &mut any), TC_INVALID_HANDLE, &["object 1"]);
    }
    destroy(s);

    // A relight (the sun elsewhere) equals a fresh bake under that sun, to the solves'
    // tolerance; without shadows, whose occluders differ between a bake and an edit.
    let unshadowed = bake_options(&p, false);
    let s = baked(&mesh, SUN, &unshadowed).unwrap();
    let other = [-0.5, 0.4, -0.6];
    // SAFETY: valid pointers.
    unsafe {
        ok(tc_scene_clear_lights(s), "clear");
        ok(tc_scene_add_sun(s, other.as_ptr(), IRRADIANCE.as_ptr(), 0.0), "sun");
        ok(tc_scene_relight(s, None, ptr::null_mut()), "relight");
    }
    let relit = radiance(s, 0);
    let fresh = baked(&mesh, other, &unshadowed).unwrap();
    let want = radiance(fresh, 0);
    let scale = want.iter().fold(0.0f32, |m, x| m.max(x.abs()));
    let worst = relit.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max);
    assert!(worst <= 1e-5 * scale, "relight {worst} of {scale}");
    destroy(fresh);
    destroy(s);
}

/// Out-of-range options fail the bake with `TC_INVALID_ARGUMENT` and a message naming the
/// field; so do a short or misaligned struct, and the statistics of another method's object.
#[test]
fn bad_polygrid_options_are_named() {
    let mesh = Mesh::uv_sphere(10.0, 24, 12);
    let d = polygrid_options();
    let cases: [(TcPolygridOptions, &[&str]); 6] = [
        (TcPolygridOptions { resolution: 0, ..d }, &["options->method_options->resolution = 0", "1..=256"]),
        (TcPolygridOptions { resolution: 300, ..d }, &["resolution = 300"]),
        (TcPolygridOptions { cube_mm: f64::NAN, ..d }, &["options->method_options->cube_mm = NaN", "finite"]),
        (TcPolygridOptions { nodes: 4, ..d }, &["options->method_options->nodes = 4"]),
        (TcPolygridOptions { stencil: 7, ..d }, &["stencil = 7", "TC_POLYGRID_STENCIL_FEM"]),
        (TcPolygridOptions { edit_solver: 42, ..d }, &["edit_solver = 42"]),
    ];
    for (p, words) in cases {
        let (status, msg) = baked(&mesh, SUN, &bake_options(&p, true)).unwrap_err();
        assert_eq!(status, TC_INVALID_ARGUMENT, "{msg}");
        assert!(words.iter().all(|w| msg.contains(w)), "{msg}");
    }
    let short = TcPolygridOptions { size: 4, ..d };
    let (status, msg) = baked(&mesh, SUN, &bake_options(&short, true)).unwrap_err();
    assert_eq!(status, TC_INVALID_ARGUMENT);
    assert!(msg.contains("sizeof(TcPolygridOptions)") && msg.contains("tc_polygrid_options_init"), "{msg}");
    let mut o = bake_options(&d, true);
    let bytes = [0u64; 8];
    o.method_options = bytes.as_ptr().cast::<u8>().wrapping_add(4).cast();
    let (status, msg) = baked(&mesh, SUN, &o).unwrap_err();
    assert_eq!(status, TC_INVALID_ARGUMENT);
    assert!(msg.contains("not aligned for TcPolygridOptions"), "{msg}");
    let mut tolerance = bake_options(&d, true);
    tolerance.tolerance = 0.0;
    let (status, msg) = baked(&mesh, SUN, &tolerance).unwrap_err();
    assert_eq!(status, TC_INVALID_ARGUMENT);
    assert!(msg.contains("tolerance"), "{msg}");

    // Another method's object has no polygrid statistics; an unbaked scene none at all.
    let mut transcut = options(2_000);
    transcut.backend = TC_BACKEND_CPU;
    let s = baked(&mesh, SUN, &transcut).unwrap();
    assert_eq!(polygrid_stats(s, 0), Err(TC_UNSUPPORTED));
    assert!(message().contains("transcut method, not polygrid"), "{}", message());
    destroy(s);
    let s = scene();
    add(s, &mesh);
    assert_eq!(polygrid_stats(s, 0), Err(TC_NOT_BAKED));
    destroy(s);
}
