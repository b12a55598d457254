//! Baking: the options' defaults, `tc_scene_bake`, and reading the results back.

use std::ffi::{c_char, c_void};

use transcut_core::{bake_reusing, ObjectStats, Session};

use super::convert::scene_failure;
use super::handle::{with_scene, TcScene};
use super::options::{
    backend_used, default_bake_options, default_dipole_options, default_polygrid_options, default_prt_options,
    default_radiosity_options, default_transcut_options, init, read_bake_options, TcBakeOptions, TcDipoleOptions,
    TcPolygridOptions, TcPrtOptions, TcRadiosityOptions, TcTransCutOptions, BAKE_OPTIONS_SIZE_V1, RADIOSITY_OPTIONS_SIZE_V1,
    TRANSCUT_OPTIONS_SIZE_V1,
};
use super::progress::{Callback, TcProgressFn};
use super::ptr;
use super::status::{run, Failure, TcStatus, TC_BUFFER_TOO_SHORT, TC_UNSUPPORTED};

/// Statistics of one object's last bake (`tc_object_stats`). The caller sets `size` to
/// `sizeof(TcBakeStats)` before the call.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcBakeStats {
    /// Set by the caller to `sizeof(TcBakeStats)`; the library writes the fields it knows that
    /// fit, and sets `size` to the number of bytes it wrote.
    pub size: u32,
    /// Tetrahedra solved on.
    pub tets: u64,
    /// Vertices of the tet mesh.
    pub vertices: u64,
    /// Solver iterations per channel (R, G, B).
    pub iterations: [u32; 3],
    /// Wall time of meshing, in milliseconds.
    pub meshing_ms: f64,
    /// Wall time of the assembly of the diffusion system.
    pub assembly_ms: f64,
    /// Wall time of the light transmitted into the surface (with shadows).
    pub source_ms: f64,
    /// Wall time of the solve and radiance evaluation.
    pub solve_ms: f64,
    /// Wall time of the whole object.
    pub total_ms: f64,
    /// The caller's vertices whose radiance the clamp at 0 changed: interpolated from a surface
    /// node whose diffusion radiance came out negative (very absorbing media on coarse meshes).
    pub clamped_vertices: u64,
    /// Where the solve ran: `TC_BACKEND_CPU` (1) or `TC_BACKEND_GPU` (2). See
    /// `tc_object_device` for the GPU's name and `tc_object_backend_fallback` for why
    /// `TC_BACKEND_AUTO` chose the CPU. (Appended: a caller passing the older size, 88, gets the
    /// fields before this one and `size` = 88.)
    pub backend_used: u32,
    /// Triangles of the object's mesh whose winding the library reversed to orient every shell
    /// consistently and every closed one outwards (0 for a well-wound mesh). (Appended: a
    /// caller passing the older size, 96, gets the fields before this one and `size` = 96.)
    pub flipped_faces: u64,
    /// How well the method resolves the medium, per channel (R, G, B): TransCut's σtr·h at the
    /// surface (transport coefficient × mean boundary edge length in mm); a bake above the
    /// method's bound fails with `TC_UNRESOLVED` instead. 0 where a method has no such measure.
    pub resolution: [f64; 3],
    /// 1 when the object's tetrahedra were kept from the scene's previous bake instead of meshed
    /// again (TransCut: its surface, transform, scale and tet budget unchanged; see
    /// `tc_scene_bake`), else 0. (Appended: a caller passing the older size, 128, gets the
    /// fields before this one and `size` = 136.)
    pub mesh_reused: u32,
}

/// The size of `TcBakeStats` before `backend_used` was appended: callers built against it
/// still get the fields they know.
const BAKE_STATS_SIZE_V1: usize = std::mem::offset_of!(TcBakeStats, backend_used);

/// The size of `TcBakeStats` before `flipped_faces` and `resolution` were appended.
const BAKE_STATS_SIZE_V2: usize = std::mem::offset_of!(TcBakeStats, flipped_faces);

/// The size of `TcBakeStats` before `mesh_reused` was appended.
const BAKE_STATS_SIZE_V3: usize = std::mem::offset_of!(TcBakeStats, mesh_reused);

/// How many bytes of `TcBakeStats` to write for a caller whose struct has `size` bytes: the
/// largest version that fits (`None` below the first).
fn stats_bytes(size: usize) -> Option<usize> {
    [size_of::<TcBakeStats>(), BAKE_STATS_SIZE_V3, BAKE_STATS_SIZE_V2, BAKE_STATS_SIZE_V1].into_iter().find(|&v| v <= size)
}

/// Fills `*options` with the defaults of the first version of `TcBakeOptions`: its first 48
/// bytes (every field before `method_options`, which is not written) and `size` = 48, what a
/// program built against that version allocates. Does nothing when `options` is NULL. A program
/// that sets `method_options` fills the whole struct with
/// `tc_bake_options_init(&options, sizeof options)` instead.
#[no_mangle]
pub unsafe extern "C" fn tc_bake_options_default(options: *mut TcBakeOptions) {
    let _ = run("tc_bake_options_default", || {
        if options.is_null() {
            return Ok(());
        }
        // SAFETY: the caller's contract: at least the first version's bytes.
        unsafe { init(options, BAKE_OPTIONS_SIZE_V1, BAKE_OPTIONS_SIZE_V1, default_bake_options()) }
    });
}

/// Fills the first `size` bytes of `*options` with the defaults (at most
/// `sizeof(TcBakeOptions)` of this library, the fields it knows) and sets `options->size` to
/// the number of bytes written. Pass `sizeof(TcBakeOptions)` of the header the program was
/// built with: the library never writes past it, and a newer header's fields beyond what this
/// library knows are left as they are (zero them first). `TC_NULL_POINTER` for NULL,
/// `TC_INVALID_ARGUMENT` for a size below the first version's 48 bytes; nothing is written on
/// failure.
#[no_mangle]
pub unsafe extern "C" fn tc_bake_options_init(options: *mut TcBakeOptions, size: usize) -> TcStatus {
    run("tc_bake_options_init", || {
        // SAFETY: the caller's contract: `size` writable bytes.
        unsafe { init(options, size, BAKE_OPTIONS_SIZE_V1, default_bake_options()) }
    })
}

/// Fills the first `size` bytes of `*options` with TransCut's defaults (`TC_SOLVER_DEFAULT`
/// for both solvers, uniform tets), as `tc_bake_options_init` fills its struct; pass
/// `sizeof(TcTransCutOptions)`. `TC_NULL_POINTER` for NULL, `TC_INVALID_ARGUMENT` for a size
/// below 12 bytes (the first version's); nothing is written on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_transcut_options_init(options: *mut TcTransCutOptions, size: usize) -> TcStatus {
    run("tc_transcut_options_init", || {
        let first = TRANSCUT_OPTIONS_SIZE_V1;
        // SAFETY: the caller's contract: `size` writable bytes.
        unsafe { init(options, size, first, default_transcut_options()) }
    })
}

/// Fills the first `size` bytes of `*options` with the hierarchical dipole's defaults (the
/// opening-angle oracle at θ = 0.4, Gauss–Legendre edges, vertex receivers, on-the-fly, the
/// distance geometry, TransCut's radiance), as `tc_bake_options_init` fills its struct; pass
/// `sizeof(TcDipoleOptions)`. `TC_NULL_POINTER` for NULL, `TC_INVALID_ARGUMENT` for a size
/// below `sizeof(TcDipoleOptions)`; nothing is written on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_dipole_options_init(options: *mut TcDipoleOptions, size: usize) -> TcStatus {
    run("tc_dipole_options_init", || {
        let first = size_of::<TcDipoleOptions>();
        // SAFETY: the caller's contract: `size` writable bytes.
        unsafe { init(options, size, first, default_dipole_options()) }
    })
}

/// Fills the first `size` bytes of `*options` with the PRT method's defaults (2¹⁶ samples, the
/// 16-function basis, 1024 terms per vertex, the near-field correction over 8 sample spacings,
/// seed 0), as `tc_bake_options_init` fills its struct; pass `sizeof(TcPrtOptions)`.
/// `TC_NULL_POINTER` for NULL, `TC_INVALID_ARGUMENT` for a size below `sizeof(TcPrtOptions)`;
/// nothing is written on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_prt_options_init(options: *mut TcPrtOptions, size: usize) -> TcStatus {
    run("tc_prt_options_init", || {
        let first = size_of::<TcPrtOptions>();
        // SAFETY: the caller's contract: `size` writable bytes.
        unsafe { init(options, size, first, default_prt_options()) }
    })
}

/// Fills the first `size` bytes of `*options` with translucent radiosity's defaults (Jacobi,
/// the default patch size (0: the scene's diagonal / 80), 512 rays per patch, tolerance 1e-3,
/// at most 200 sweeps, covered fraction 0.1, every bounce, the default solver, uniform tets and
/// the fitted assembly for the translucent objects), as `tc_bake_options_init` fills its
/// struct; pass `sizeof(TcRadiosityOptions)`. `TC_NULL_POINTER` for NULL,
/// `TC_INVALID_ARGUMENT` for a size below 56 bytes (the first version's); nothing is written
/// on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_radiosity_options_init(options: *mut TcRadiosityOptions, size: usize) -> TcStatus {
    run("tc_radiosity_options_init", || {
        let first = RADIOSITY_OPTIONS_SIZE_V1;
        // SAFETY: the caller's contract: `size` writable bytes.
        unsafe { init(options, size, first, default_radiosity_options()) }
    })
}

/// Fills the first `size` bytes of `*options` with the polygrid method's defaults (8 cells per
/// cube edge, 200 000 target nodes, the cube size from them (`cube_mm` = 0), the FEM stencil,
/// the default solvers), as `tc_bake_options_init` fills its struct; pass
/// `sizeof(TcPolygridOptions)`. `TC_NULL_POINTER` for NULL, `TC_INVALID_ARGUMENT` for a size
/// below `sizeof(TcPolygridOptions)`; nothing is written on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_polygrid_options_init(options: *mut TcPolygridOptions, size: usize) -> TcStatus {
    run("tc_polygrid_options_init", || {
        let first = size_of::<TcPolygridOptions>();
        // SAFETY: the caller's contract: `size` writable bytes.
        unsafe { init(options, size, first, default_polygrid_options()) }
    })
}

/// What the polygrid method built for an object in the last bake (`tc_object_polygrid_stats`):
/// its polycube and grid. The solve's own statistics (iterations, times, backend) are in
/// `tc_object_stats`, whose `tets` and `vertices` are the grid's Kuhn tets and nodes. Set `size`
/// to `sizeof(TcPolygridStats)` first.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcPolygridStats {
    /// Set by the caller to `sizeof(TcPolygridStats)`; the library sets it to the number of
    /// bytes it wrote.
    pub size: u32,
    /// Grid cells per cube edge.
    pub resolution: u32,
    /// Cubes of the polycube.
    pub cubes: u64,
    /// The cube edge in mm (after any reduction where the grid would have folded).
    pub cube_mm: f64,
    /// Nodes of the grid (the unknowns of the solve).
    pub nodes: u64,
    /// Cells of the grid.
    pub cells: u64,
    /// The cells' smallest scaled Jacobian after the map onto the surface (1: a cube, ≤ 0:
    /// folded, never baked).
    pub min_scaled_jacobian: f64,
    /// The cells' mean scaled Jacobian.
    pub mean_scaled_jacobian: f64,
}

/// Writes what the polygrid method built for `object` in the last bake into `*out`; set
/// `out->size = sizeof(TcPolygridStats)` first (another size is `TC_INVALID_ARGUMENT`).
///
/// Errors: `TC_NULL_POINTER`, `TC_INVALID_HANDLE`, `TC_NOT_BAKED` (before a successful bake or
/// after the scene changed), and `TC_UNSUPPORTED` for an object another method baked. Nothing is
/// written on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_object_polygrid_stats(scene: *const TcScene, object: u32, out: *mut TcPolygridStats) -> TcStatus {
    run("tc_object_polygrid_stats", || {
        check_not_null!(out);
        if !out.is_aligned() {
            return Err(Failure::invalid("`out` is not aligned for TcPolygridStats"));
        }
        // SAFETY: checked; `size` is the first field.
        let size = unsafe { out.cast::<u32>().read() } as usize;
        let ours = size_of::<TcPolygridStats>();
        if size != ours {
            return Err(Failure::invalid(format!("out->size = {size}, expected sizeof(TcPolygridStats) = {ours}")));
        }
        // SAFETY: the caller's contract.
        let stats = unsafe {
            with_scene(scene, |s| {
                let st = s.bake_stats(object)?;
                let Some(p) = st.polygrid else {
                    return Err(Failure::new(
                        TC_UNSUPPORTED,
                        format!("object {object} was baked by the {} method, not polygrid", st.method),
                    ));
                };
                Ok(TcPolygridStats {
                    size: ours as u32,
                    resolution: p.resolution,
                    cubes: p.cubes as u64,
                    cube_mm: p.cube_mm,
                    nodes: p.nodes as u64,
                    cells: p.cells as u64,
                    min_scaled_jacobian: p.quality.min_scaled_jacobian,
                    mean_scaled_jacobian: p.quality.mean_scaled_jacobian,
                })
            })?
        };
        // SAFETY: checked non-NULL and aligned; the caller's struct has `size` = ours bytes.
        unsafe { ptr::write(out, stats) };
        Ok(())
    })
}

/// What translucent radiosity measured of the whole scene in the last bake
/// (`tc_scene_radiosity_stats`): it bakes every object together, so these are the scene's;
/// each object's own (its tets and solves, for a translucent one) are in `tc_object_stats`.
/// Set `size` to `sizeof(TcRadiosityStats)` first.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcRadiosityStats {
    /// Set by the caller to `sizeof(TcRadiosityStats)`; the library sets it to the number of
    /// bytes it wrote.
    pub size: u32,
    /// Patches in all (a two-sided surface has two per vertex of its refined mesh).
    pub patches: u64,
    /// Of them, on translucent objects (their tets' boundary vertices).
    pub translucent_patches: u64,
    /// Patches inside geometry (their rays mostly hit the back of one-sided surfaces): they
    /// exchange nothing and take their radiance from their neighbours.
    pub covered_patches: u64,
    /// Nonzero form factors.
    pub nonzeros: u64,
    /// Memory of the form factors, in bytes (8 per nonzero).
    pub form_factor_bytes: u64,
    /// The patch size used on opaque objects, in mm (the default resolved, when 0 was asked).
    pub patch_size_mm: f64,
    /// Wall time of preparing the translucent objects (tets, assembly), in milliseconds.
    pub prepare_ms: f64,
    /// Wall time of building the patches (refinement, dual cells, the ray-casting hierarchy).
    pub patches_ms: f64,
    /// Wall time of casting and symmetrising the form factors.
    pub form_factor_ms: f64,
    /// Wall time of the direct light on every patch (with shadows).
    pub direct_ms: f64,
    /// Wall time of the coupled solve, the translucent objects' diffusion solves included.
    pub solve_ms: f64,
    /// Sweeps of the iteration.
    pub iterations: u32,
    /// Diffusion solves per translucent object (its scattering of the light it got).
    pub scatterings: u32,
    /// The a-posteriori estimate of the relative error in power at the end (below
    /// `TcRadiosityOptions.tolerance` unless the sweeps or bounces ran out).
    pub estimated_error: f64,
    /// |in − out| / in of the energy balance (light put in by the lights and the emission
    /// against light absorbed, reflected specularly and escaped), the worst channel.
    pub energy_defect: f64,
}

/// Writes what translucent radiosity measured of the whole scene in the last bake into
/// `*out`. Set `out->size = sizeof(TcRadiosityStats)` first (a smaller size is
/// `TC_INVALID_ARGUMENT`); on return it holds the number of bytes written.
///
/// Errors: `TC_NULL_POINTER`, `TC_NOT_BAKED` (before a successful bake, after a change to the
/// scene or its lights), `TC_UNSUPPORTED` when the last bake was by another method. Nothing is
/// written on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_radiosity_stats(scene: *const TcScene, out: *mut TcRadiosityStats) -> TcStatus {
    run("tc_scene_radiosity_stats", || {
        check_not_null!(out);
        // SAFETY: checked; `size` is the first field.
        let size = unsafe { out.cast::<u32>().read() } as usize;
        let ours = size_of::<TcRadiosityStats>();
        if size < ours {
            return Err(Failure::invalid(format!("out->size = {size}, expected sizeof(TcRadiosityStats) = {ours}")));
        }
        // SAFETY: the caller's contract.
        let stats = unsafe {
            with_scene(scene, |s| {
                let r = s.radiosity_stats()?;
                let count = |n: usize| n as u64;
                let small = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
                Ok(TcRadiosityStats {
                    size: ours as u32,
                    patches: count(r.patches),
                    translucent_patches: count(r.translucent_patches),
                    covered_patches: count(r.covered_patches),
                    nonzeros: count(r.nonzeros),
                    form_factor_bytes: count(r.form_factor_bytes),
                    patch_size_mm: r.patch_size_mm,
                    prepare_ms: r.prepare_ms,
                    patches_ms: r.patches_ms,
                    form_factor_ms: r.form_factor_ms,
                    direct_ms: r.direct_ms,
                    solve_ms: r.solve_ms,
                    iterations: small(r.iterations),
                    scatterings: small(r.scatterings),
                    estimated_error: r.estimated_error,
                    energy_defect: r.energy_defect,
                })
            })?
        };
        // SAFETY: checked above; the caller's struct has at least `ours` bytes.
        unsafe { ptr::write(out, stats) };
        Ok(())
    })
}

/// Bakes every object with the chosen method (`TcBakeOptions.method`; TransCut meshes surfaces
/// into tetrahedra, computes the light transmitted into them, shadowed by all objects, solves
/// the diffusion system) and keeps the radiance leaving each vertex along its normal, Lo(x, n),
/// linear RGB, in the units of the lights (a sun of irradiance E on a white Lambertian plane
/// would give E/π). Read it with `tc_object_radiance` and `tc_object_stats`.
///
/// `options` may be NULL for the defaults. `progress` may be NULL; otherwise it is called with
/// `user` as the bake goes (see `TcProgressFn`); a non-zero return cancels the bake, which then
/// returns `TC_CANCELLED`. A failed or cancelled bake keeps the results of the previous
/// successful bake, if the scene has not changed since; the scene stays usable either way.
///
/// A successful bake also starts an editing session: every object can then be relit
/// (`tc_scene_relight`), edited (`tc_object_edit_medium`, `tc_object_paint`), cut
/// (`tc_object_cut_*`), fractured and its pieces moved, each update warm-started from the last
/// solution. Changing an object (mesh, medium, transform, scale) ends the session; changing the
/// lights does not (see `tc_scene_relight`).
///
/// The scene keeps the tetrahedra of its last bake, so a host that changes part of a scene and
/// bakes it again pays only for what changed: a TransCut object whose mesh, transform, scale
/// and `tets` budget are as they were is not meshed again (a new medium is assembled on its
/// tets; `TcBakeStats.mesh_reused` says so), while a changed one is (`tc_object_set_mesh`,
/// `tc_object_set_transform`, …). The result equals a bake of a new scene bit for bit. The
/// kept tetrahedra cost about the memory of the tets once more until the scene is destroyed.
///
/// `TC_METHOD_RADIOSITY` bakes the whole scene at once: translucent and diffuse objects
/// (`tc_scene_add_diffuse_mesh`) light each other, and `tc_scene_radiosity_stats` says what it
/// measured. Its objects are coupled, so its session refuses per-object updates with
/// `TC_UNSUPPORTED`; bake again after a change. The other methods refuse a scene with a diffuse
/// object with `TC_UNSUPPORTED`, naming the object and suggesting radiosity.
///
/// Errors: `TC_INVALID_ARGUMENT` (no objects, options out of range, an unknown method, an
/// invalid object or light, naming it; an unknown `TRANSCUT_BACKEND` value),
/// `TC_UNSUPPORTED` (the method cannot bake an object, naming the method and the reason),
/// `TC_MESHING_FAILED`, `TC_SOLVE_FAILED`, `TC_CANCELLED`, `TC_GPU_UNAVAILABLE` (the GPU was
/// required and cannot be used).
#[no_mangle]
pub unsafe extern "C" fn tc_scene_bake(
    scene: *mut TcScene,
    options: *const TcBakeOptions,
    progress: TcProgressFn,
    user: *mut c_void,
) -> TcStatus {
    run("tc_scene_bake", || {
        // SAFETY: the caller's contract.
        let options = unsafe { read_bake_options(options)? };
        Callback::with(progress, user, |progress| {
            // SAFETY: the caller's contract.
            unsafe {
                with_scene(scene, |s| {
                    // The bake, then its session: the session keeps each object's bake, the scene
                    // keeps the radiosity method's statistics of the whole scene beside it.
                    let bake = bake_reusing(&s.scene, &options, &s.meshes, progress).map_err(|e| scene_failure(&e))?;
                    let radiosity = bake.radiosity.clone();
                    s.meshes = bake.meshes();
                    s.session = Some(Session::new(&s.scene, bake, &options));
                    s.radiosity = radiosity;
                    s.current = true;
                    Ok(())
                })
            }
        })
    })
}

/// Copies an object's baked radiance into `out_rgb`: 3 floats (linear R, G, B) per vertex, in
/// the order the vertices were given (`tc_object_vertex_count` of them). `out_len` is the
/// length of `out_rgb` in floats and must be at least 3 × the vertex count
/// (`TC_BUFFER_TOO_SHORT` otherwise, naming both). `TC_NOT_BAKED` before a successful bake or
/// after the scene changed. On failure nothing is written.
#[no_mangle]
pub unsafe extern "C" fn tc_object_radiance(scene: *const TcScene, object: u32, out_rgb: *mut f32, out_len: usize) -> TcStatus {
    run("tc_object_radiance", || {
        check_not_null!(out_rgb);
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                let radiance = s.radiance(object)?;
                let needed = 3 * radiance.len();
                if out_len < needed {
                    return Err(Failure::new(
                        TC_BUFFER_TOO_SHORT,
                        format!("out_len = {out_len} floats, but object {object} needs {needed} (3 per vertex)"),
                    ));
                }
                // SAFETY: checked pointer, `out_len ≥ needed` floats writable (caller's contract).
                let out = std::slice::from_raw_parts_mut(out_rgb, needed);
                for (o, l) in out.chunks_exact_mut(3).zip(radiance) {
                    o[0] = l[0] as f32;
                    o[1] = l[1] as f32;
                    o[2] = l[2] as f32;
                }
                Ok(())
            })
        }
    })
}

/// Writes an object's statistics of the last bake into `*out`. Set `out->size =
/// sizeof(TcBakeStats)` first; on return it holds the number of bytes written: all of the
/// struct, or for a caller built against an older struct its bytes: 128 (the fields before
/// `mesh_reused`), 96 (those before `flipped_faces`) or 88 (those before `backend_used`). A smaller size is
/// `TC_INVALID_ARGUMENT`.
/// `TC_NOT_BAKED` before a successful bake or after the scene changed.
#[no_mangle]
pub unsafe extern "C" fn tc_object_stats(scene: *const TcScene, object: u32, out: *mut TcBakeStats) -> TcStatus {
    run("tc_object_stats", || {
        check_not_null!(out);
        // SAFETY: checked; `size` is the first field.
        let size = unsafe { out.cast::<u32>().read() } as usize;
        let ours = size_of::<TcBakeStats>();
        let Some(written) = stats_bytes(size) else {
            return Err(Failure::invalid(format!("out->size = {size}, expected sizeof(TcBakeStats) = {ours}")));
        };
        // SAFETY: the caller's contract.
        let stats = unsafe {
            with_scene(scene, |s| {
                let st = s.bake_stats(object)?;
                let count = |n: usize| n as u64;
                let iterations = st.iterations.map(|i| u32::try_from(i).unwrap_or(u32::MAX));
                Ok(TcBakeStats {
                    size: written as u32,
                    tets: count(st.tets),
                    vertices: count(st.vertices),
                    iterations,
                    meshing_ms: st.meshing_ms,
                    assembly_ms: st.assembly_ms,
                    source_ms: st.source_ms,
                    solve_ms: st.solve_ms,
                    total_ms: st.total_ms,
                    clamped_vertices: count(st.clamped_vertices),
                    backend_used: backend_used(st.backend),
                    flipped_faces: count(st.flipped_faces),
                    resolution: st.resolution,
                    mesh_reused: u32::from(st.mesh_reused),
                })
            })?
        };
        // SAFETY: checked above; the caller's struct has at least `written` bytes (its `size`).
        unsafe { ptr::write_prefix(out, &stats, written) };
        Ok(())
    })
}

/// Which text of an object's stats to copy.
unsafe fn object_text(
    scene: *const TcScene,
    object: u32,
    out: *mut c_char,
    out_len: usize,
    out_needed: *mut usize,
    pick: impl FnOnce(&ObjectStats) -> String,
) -> Result<(), Failure> {
    // SAFETY: the caller's contract.
    let text = unsafe { with_scene(scene, |s| Ok(pick(s.bake_stats(object)?)))? };
    // SAFETY: the caller's contract.
    unsafe { ptr::copy_text(&text, out, out_len, out_needed) }
}

/// Copies the name of the GPU adapter that solved `object` in the last bake into `out` as a
/// NUL-terminated UTF-8 string (e.g. "NVIDIA GeForce RTX 4090", "llvmpipe (LLVM 15.0.6, 256
/// bits)"), or the empty string when the CPU solved it. `out_len` is the size of `out` in bytes;
/// `*out_needed` (`out_needed` may be NULL) receives the size the text needs, NUL included. Pass
/// `out` = NULL and `out_len` = 0 to ask for the size only. `TC_BUFFER_TOO_SHORT` (naming the
/// size needed) when the text does not fit; `TC_NOT_BAKED` before a successful bake. On failure
/// nothing is written.
#[no_mangle]
pub unsafe extern "C" fn tc_object_device(
    scene: *const TcScene,
    object: u32,
    out: *mut c_char,
    out_len: usize,
    out_needed: *mut usize,
) -> TcStatus {
    run("tc_object_device", || {
        // SAFETY: the caller's contract.
        unsafe { object_text(scene, object, out, out_len, out_needed, |st| st.device.clone().unwrap_or_default()) }
    })
}

/// Copies why `TC_BACKEND_AUTO` (or `TRANSCUT_BACKEND=auto`) solved `object` on the CPU in the
/// last bake (e.g. no GPU adapter, or only a software one), as `tc_object_device` copies its
/// text; the empty string when the GPU ran or the CPU was asked for.
#[no_mangle]
pub unsafe extern "C" fn tc_object_backend_fallback(
    scene: *const TcScene,
    object: u32,
    out: *mut c_char,
    out_len: usize,
    out_needed: *mut usize,
) -> TcStatus {
    run("tc_object_backend_fallback", || {
        // SAFETY: the caller's contract.
        unsafe { object_text(scene, object, out, out_len, out_needed, |st| st.backend_fallback.clone().unwrap_or_default()) }
    })
}
