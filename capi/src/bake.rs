//! Baking: options, the progress callback, and reading results back.

use std::ffi::{c_char, c_void, CString};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

use transcut_core::gpu::Backend;
use transcut_core::light::SourceOptions;
use transcut_core::scene::{bake_with, BakeOptions, SceneError};
use transcut_core::Progress;

use super::edit::EditSession;
use super::guard::{run, Failure};
use super::handle::{with_scene, ObjectResult, TcScene};
use super::ptr;
use super::status::{
    TcStatus, TC_BUFFER_TOO_SHORT, TC_CANCELLED, TC_GPU_UNAVAILABLE, TC_INVALID_ARGUMENT, TC_MESHING_FAILED, TC_SOLVE_FAILED,
};

/// The TransCut finite-element diffusion solver on a tetrahedral mesh (the only method so far).
pub const TC_METHOD_TRANSCUT: u32 = 0;

/// `TcBakeOptions.backend`: as the environment variable `TRANSCUT_BACKEND` says (`cpu`, `gpu`,
/// `auto`; an unknown value fails the bake with `TC_INVALID_ARGUMENT`), `TC_BACKEND_AUTO` when
/// it is unset or empty. The default.
pub const TC_BACKEND_DEFAULT: u32 = 0;
/// `TcBakeOptions.backend`: solve on the CPU (always available).
pub const TC_BACKEND_CPU: u32 = 1;
/// `TcBakeOptions.backend`: solve on the GPU (wgpu: Vulkan, Metal or DX12), also on a software
/// adapter such as Mesa's lavapipe; `tc_scene_bake` returns `TC_GPU_UNAVAILABLE` when no
/// adapter can be used. `TRANSCUT_GPU_ADAPTER=substring` restricts the adapters to those whose
/// name contains it.
pub const TC_BACKEND_GPU: u32 = 2;
/// `TcBakeOptions.backend`: the GPU when a hardware adapter exists, else the CPU (a software
/// adapter is slower than the CPU path and is not used); `tc_object_backend_fallback` says why
/// the CPU ran.
pub const TC_BACKEND_AUTO: u32 = 3;

/// How to bake. Fill it with `tc_bake_options_default` (which also sets `size`), then change
/// fields. `size` lets later versions append fields: a library reads only the fields that it
/// and the caller both know.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcBakeOptions {
    /// `sizeof(TcBakeOptions)`, set by `tc_bake_options_default`.
    pub size: u32,
    /// `TC_METHOD_TRANSCUT`.
    pub method: u32,
    /// Target number of tetrahedra per surface object (default 200 000).
    pub tets: u64,
    /// Relative residual ‖b − Mφ‖/‖b‖ at which the solver stops, in (0, 1) (default 1e-6).
    pub tolerance: f64,
    /// Iteration cap of the solver, ≥ 1 (default 10 000).
    pub max_iterations: u32,
    /// Worker threads; 0 = one per core (default).
    pub threads: u32,
    /// Non-zero: objects shadow themselves and each other (default 1).
    pub shadows: u32,
    /// Samples per point for area lights and suns with a non-zero diameter (default 64).
    pub area_samples: u32,
    /// Samples per point for shadowed environments (default 256).
    pub environment_samples: u32,
    /// Where the diffusion solve runs: `TC_BACKEND_DEFAULT` (default), `TC_BACKEND_CPU`,
    /// `TC_BACKEND_GPU` or `TC_BACKEND_AUTO`; another value fails with `TC_INVALID_ARGUMENT`.
    /// (This field occupies what was the struct's tail padding before it existed, so
    /// `sizeof(TcBakeOptions)` is still 48: fill the struct with `tc_bake_options_default`.)
    /// `tc_object_stats` says which backend ran (`TcBakeStats.backend_used`).
    pub backend: u32,
}

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
    /// Surface vertices whose diffusion radiance came out negative and was clamped to 0 (very
    /// absorbing media on coarse meshes).
    pub clamped_vertices: u64,
    /// Where the solve ran: `TC_BACKEND_CPU` (1) or `TC_BACKEND_GPU` (2). See
    /// `tc_object_device` for the GPU's name and `tc_object_backend_fallback` for why
    /// `TC_BACKEND_AUTO` chose the CPU. (Appended: a caller passing the older size, 88, gets the
    /// fields before this one and `size` = 88.)
    pub backend_used: u32,
}

/// The size of `TcBakeStats` before `backend_used` was appended: callers built against it
/// still get the fields they know.
const BAKE_STATS_SIZE_V1: usize = std::mem::offset_of!(TcBakeStats, backend_used);

/// Progress callback: `stage` is a short UTF-8 description (valid during the call only),
/// `fraction` in [0, 1] the part of the whole bake done (never decreasing from one call to the
/// next). Return 0 to continue, non-zero to
/// cancel the bake (`tc_scene_bake` then returns `TC_CANCELLED` soon after). It is called from
/// the baking thread or a worker thread, never from two threads at once, and not again after
/// it asked to cancel. It must not call functions on the scene being baked (they return
/// `TC_BUSY`).
pub type TcProgressFn = Option<unsafe extern "C" fn(user: *mut c_void, stage: *const c_char, fraction: f64) -> i32>;

fn default_options() -> TcBakeOptions {
    let core = BakeOptions::default();
    let source = SourceOptions::default();
    TcBakeOptions {
        size: std::mem::size_of::<TcBakeOptions>() as u32,
        method: TC_METHOD_TRANSCUT,
        tets: core.tets as u64,
        tolerance: core.tolerance,
        max_iterations: u32::try_from(core.max_iterations).unwrap_or(u32::MAX),
        threads: u32::try_from(core.threads).unwrap_or(0),
        shadows: u32::from(core.shadows),
        area_samples: u32::try_from(source.area_samples).unwrap_or(u32::MAX),
        environment_samples: u32::try_from(source.environment_samples).unwrap_or(u32::MAX),
        backend: TC_BACKEND_DEFAULT,
    }
}

/// The core's backend choice for `TcBakeOptions.backend` (`None`: the environment decides).
pub(crate) fn backend_from(value: u32, what: &str) -> Result<Option<Backend>, Failure> {
    match value {
        TC_BACKEND_DEFAULT => Ok(None),
        TC_BACKEND_CPU => Ok(Some(Backend::Cpu)),
        TC_BACKEND_GPU => Ok(Some(Backend::Gpu)),
        TC_BACKEND_AUTO => Ok(Some(Backend::Auto)),
        other => Err(Failure::invalid(format!(
            "{what} = {other}: unknown backend (TC_BACKEND_DEFAULT = 0, TC_BACKEND_CPU = 1, TC_BACKEND_GPU = 2, TC_BACKEND_AUTO = 3)"
        ))),
    }
}

/// `TC_BACKEND_CPU` or `TC_BACKEND_GPU` for the backend that ran.
pub(crate) fn backend_used(b: Backend) -> u32 {
    match b {
        Backend::Gpu => TC_BACKEND_GPU,
        Backend::Cpu | Backend::Auto => TC_BACKEND_CPU,
    }
}

/// Fills `*options` with the defaults and sets `options->size`. Does nothing when `options` is
/// NULL.
#[no_mangle]
pub unsafe extern "C" fn tc_bake_options_default(options: *mut TcBakeOptions) {
    let _ = run("tc_bake_options_default", || {
        if options.is_null() {
            return Ok(());
        }
        check_not_null!(options);
        // SAFETY: checked; the caller's contract.
        unsafe { ptr::write(options, default_options()) };
        Ok(())
    });
}

/// The caller's options (NULL = defaults), checked and converted.
///
/// # Safety
/// A non-NULL `options` must point to at least `options->size` readable bytes.
unsafe fn read_options(options: *const TcBakeOptions) -> Result<BakeOptions, Failure> {
    let o = if options.is_null() {
        default_options()
    } else {
        check_not_null!(options);
        // SAFETY: the caller's contract; `size` is the first field.
        let size = unsafe { options.cast::<u32>().read() } as usize;
        let ours = std::mem::size_of::<TcBakeOptions>();
        if size < ours {
            return Err(Failure::invalid(format!(
                "options->size = {size}, expected sizeof(TcBakeOptions) = {ours} (fill the struct with tc_bake_options_default)"
            )));
        }
        // SAFETY: at least `ours` bytes are readable (size ≥ ours); later fields are ignored.
        unsafe { options.read() }
    };
    if o.method != TC_METHOD_TRANSCUT {
        return Err(Failure::invalid(format!("options->method = {}: unknown method (TC_METHOD_TRANSCUT = 0)", o.method)));
    }
    let source = SourceOptions {
        area_samples: o.area_samples as usize,
        environment_samples: o.environment_samples as usize,
        ..SourceOptions::default()
    };
    Ok(BakeOptions {
        tets: usize::try_from(o.tets).map_err(|_| Failure::invalid(format!("options->tets = {} is too large", o.tets)))?,
        tolerance: o.tolerance,
        max_iterations: o.max_iterations as usize,
        threads: o.threads as usize,
        source,
        shadows: o.shadows != 0,
        backend: backend_from(o.backend, "options->backend")?,
    })
}

/// The status of a failed bake.
pub(crate) fn bake_failure(e: &SceneError) -> Failure {
    let status = match e {
        SceneError::Cancelled(_) => TC_CANCELLED,
        SceneError::Mesher { .. } => TC_MESHING_FAILED,
        SceneError::Diffusion { .. } => TC_SOLVE_FAILED,
        SceneError::Gpu { .. } => TC_GPU_UNAVAILABLE,
        SceneError::NoObjects | SceneError::InvalidOptions(_) | SceneError::InvalidObject { .. } | SceneError::Light(_) => {
            TC_INVALID_ARGUMENT
        }
        _ => TC_SOLVE_FAILED,
    };
    Failure::new(status, e.to_string())
}

/// The caller's callback, made callable from the core's (possibly parallel) progress reports:
/// one call at a time, none after a cancel.
pub(crate) struct Callback {
    function: unsafe extern "C" fn(*mut c_void, *const c_char, f64) -> i32,
    user: *mut c_void,
    /// Held during a call; holds the largest fraction reported so far.
    lock: Mutex<f64>,
    cancelled: AtomicBool,
}

// SAFETY: the user pointer is only passed back to the caller's function, under the lock; the
// header tells the caller the callback may run on a worker thread.
unsafe impl Sync for Callback {}

impl Callback {
    /// The caller's function, if any, wrapped.
    pub(crate) fn new(progress: TcProgressFn, user: *mut c_void) -> Option<Self> {
        progress.map(|function| Callback { function, user, lock: Mutex::new(0.0), cancelled: AtomicBool::new(false) })
    }

    pub(crate) fn report(&self, stage: &str, fraction: f64) -> bool {
        if self.cancelled.load(Ordering::Acquire) {
            return false;
        }
        let mut done = self.lock.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if self.cancelled.load(Ordering::Acquire) {
            return false;
        }
        // The stages' own fractions can step back (a stage restarting a sub-step); a caller's
        // progress bar should not.
        *done = done.max(fraction);
        let stage = CString::new(stage.replace('\0', "?")).unwrap_or_default();
        // SAFETY: the caller's function and pointer, as the header documents.
        let keep_going = unsafe { (self.function)(self.user, stage.as_ptr(), *done) } == 0;
        if !keep_going {
            self.cancelled.store(true, Ordering::Release);
        }
        keep_going
    }
}

/// Bakes every object: meshes surfaces into tetrahedra, computes the light transmitted into
/// them (shadowed by all objects), solves the diffusion system and keeps the radiance leaving
/// each vertex along its normal, Lo(x, n), linear RGB, in the units of the lights (a sun of
/// irradiance E on a white Lambertian plane would give E/π). Read it with `tc_object_radiance`
/// and `tc_object_stats`.
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
/// Errors: `TC_INVALID_ARGUMENT` (no objects, options out of range, an invalid object or
/// light, naming it; an unknown `TRANSCUT_BACKEND` value), `TC_MESHING_FAILED`,
/// `TC_SOLVE_FAILED`, `TC_CANCELLED`, `TC_GPU_UNAVAILABLE` (the GPU was required and cannot be
/// used).
#[no_mangle]
pub unsafe extern "C" fn tc_scene_bake(
    scene: *mut TcScene,
    options: *const TcBakeOptions,
    progress: TcProgressFn,
    user: *mut c_void,
) -> TcStatus {
    run("tc_scene_bake", || {
        // SAFETY: the caller's contract.
        let options = unsafe { read_options(options)? };
        let callback = Callback::new(progress, user);
        let report = |stage: &str, fraction: f64| callback.as_ref().is_none_or(|c| c.report(stage, fraction));
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                let baked = bake_with(&s.scene, &options, Progress::new(&report)).map_err(|e| bake_failure(&e))?;
                let results = baked
                    .objects
                    .iter()
                    .map(|o| ObjectResult { radiance: Some(o.radiance.clone()), stats: o.stats.clone() })
                    .collect();
                s.results = Some(results);
                s.session = Some(EditSession::new(&s.scene, baked.objects, &options));
                Ok(())
            })
        }
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
/// struct, or the first 88 bytes (the fields before `backend_used`) for a caller built against
/// that older struct, whose `size` is 88. A smaller size is `TC_INVALID_ARGUMENT`.
/// `TC_NOT_BAKED` before a successful bake or after the scene changed.
#[no_mangle]
pub unsafe extern "C" fn tc_object_stats(scene: *const TcScene, object: u32, out: *mut TcBakeStats) -> TcStatus {
    run("tc_object_stats", || {
        check_not_null!(out);
        // SAFETY: checked; `size` is the first field.
        let size = unsafe { out.cast::<u32>().read() } as usize;
        let ours = std::mem::size_of::<TcBakeStats>();
        if size < BAKE_STATS_SIZE_V1 {
            return Err(Failure::invalid(format!("out->size = {size}, expected sizeof(TcBakeStats) = {ours}")));
        }
        let written = if size >= ours { ours } else { BAKE_STATS_SIZE_V1 };
        // SAFETY: the caller's contract.
        let stats = unsafe {
            with_scene(scene, |s| {
                let st = &s.result(object)?.stats;
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
                })
            })?
        };
        // SAFETY: checked above; the caller's struct has at least `written` bytes (its `size`).
        // A byte copy of a prefix (padding bytes included) of a fully built value.
        unsafe { std::ptr::copy_nonoverlapping((&raw const stats).cast::<u8>(), out.cast::<u8>(), written) };
        Ok(())
    })
}

/// Copies `text` and its NUL into the caller's `out[0..out_len]` and its size (bytes with the
/// NUL) into `*out_needed` (when not NULL). `out` may be NULL when `out_len` is 0: only the size
/// is returned. Nothing is written on failure.
///
/// # Safety
/// `out` NULL or `out_len` writable bytes; `out_needed` NULL or writable.
unsafe fn copy_text(text: &str, out: *mut c_char, out_len: usize, out_needed: *mut usize) -> Result<(), Failure> {
    if !out_needed.is_null() && !out_needed.is_aligned() {
        return Err(Failure::invalid("`out_needed` is not aligned for its type"));
    }
    let needed = text.len() + 1;
    if out.is_null() {
        if out_len != 0 {
            return Err(Failure::new(super::status::TC_NULL_POINTER, format!("`out` is NULL but out_len is {out_len}")));
        }
    } else if out_len < needed {
        return Err(Failure::new(
            TC_BUFFER_TOO_SHORT,
            format!("out_len = {out_len} bytes, but the text needs {needed} (with its NUL)"),
        ));
    } else {
        // SAFETY: `needed ≤ out_len` writable bytes (caller's contract); the text has no NUL
        // (the core's strings come from Rust, a NUL would only truncate it for C).
        unsafe {
            std::ptr::copy_nonoverlapping(text.as_ptr(), out.cast::<u8>(), text.len());
            out.add(text.len()).write(0);
        }
    }
    if !out_needed.is_null() {
        // SAFETY: checked above.
        unsafe { ptr::write(out_needed, needed) };
    }
    Ok(())
}

/// Which text of an object's stats to copy.
unsafe fn object_text(
    scene: *const TcScene,
    object: u32,
    out: *mut c_char,
    out_len: usize,
    out_needed: *mut usize,
    pick: impl FnOnce(&transcut_core::scene::ObjectStats) -> String,
) -> Result<(), Failure> {
    // SAFETY: the caller's contract.
    let text = unsafe { with_scene(scene, |s| Ok(pick(&s.result(object)?.stats)))? };
    // SAFETY: the caller's contract.
    unsafe { copy_text(&text, out, out_len, out_needed) }
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
