//! Inverse diffusion through the ABI (J. Wang et al. 2008 §4): a heterogeneous material volume
//! measured from the caller's images in memory, returned as the voxel data that
//! `tc_object_set_medium_voxels` takes and, when asked, written as a TCVOX1 file that
//! `tc_object_set_medium_voxel_file` reads. Every input is checked before the first solve, and
//! nothing of the caller's is written unless the whole fit succeeds.

use std::ffi::{c_char, c_void};

use glam::DVec3;
use transcut_core::inverse::{
    acquire, to_voxel_grid, AcquireOptions, Acquisition, Channels, InverseError, Lambda, Method, Observation, Pattern, Setup,
    SolveSettings,
};
use transcut_core::volume::VolumeError;

use super::options::{init, read_sized, Layout, Sized};
use super::progress::{Callback, TcProgressFn};
use super::ptr;
use super::status::{
    run, run_on_workers, Failure, TcStatus, TC_BUFFER_TOO_SHORT, TC_CANCELLED, TC_INVALID_ARGUMENT, TC_IO_ERROR, TC_SOLVE_FAILED,
};

/// `TcAcquireOptions.observe`: the camera sees the face opposite the light (thin samples; the
/// default).
pub const TC_ACQUIRE_BACK_LIT: u32 = 0;
/// `TcAcquireOptions.observe`: the camera sees the lit face (thick samples); pixels within
/// `margin_mm` of light are not fitted.
pub const TC_ACQUIRE_FRONT_LIT: u32 = 1;
/// `TcAcquireOptions.method`: L-BFGS (the default).
pub const TC_ACQUIRE_LBFGS: u32 = 0;
/// `TcAcquireOptions.method`: the paper's Polak–Ribière CG with golden-section search.
pub const TC_ACQUIRE_PAPER_CG: u32 = 1;
/// `TcAcquireOptions.channels`: R, G and B fitted each on its own (the default).
pub const TC_ACQUIRE_RGB: u32 = 0;
/// `TcAcquireOptions.channels`: grey images (the same value in every channel): the first
/// channel fitted and its media copied to the other two, a third of the iterations.
pub const TC_ACQUIRE_GREY: u32 = 1;
/// The largest grid `tc_acquire` takes, in nodes (the paper's marble is 1.3 million).
pub const TC_MAX_ACQUIRE_NODES: u64 = 4_000_000;

/// What `tc_acquire` measures and how. Fill it with `tc_acquire_options_init(&options,
/// sizeof options)` (which also sets `size`), then set `nodes` and `spacing_mm` at least.
///
/// The block: `nodes` grid nodes along x, y, z at `spacing_mm`; light patterns on its top face
/// (z = max); images of the observed face, node-aligned: pixel (i, j) is face node (i, j), x
/// fastest, `nodes[0]` × `nodes[1]` pixels of 3 floats (linear RGB radiance).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcAcquireOptions {
    /// The bytes of the struct the caller has, set by `tc_acquire_options_init`.
    pub size: u32,
    /// `TC_ACQUIRE_BACK_LIT` (default) or `TC_ACQUIRE_FRONT_LIT`.
    pub observe: u32,
    /// Grid nodes along x, y, z: at least 2 each, at most `TC_MAX_ACQUIRE_NODES` in all
    /// (default 0: must be set).
    pub nodes: [u32; 3],
    /// `TC_ACQUIRE_LBFGS` (default) or `TC_ACQUIRE_PAPER_CG`.
    pub method: u32,
    /// Node spacing in mm, > 0 (default 0: must be set).
    pub spacing_mm: f64,
    /// The sample's refractive index, in [1, 4) (default 1.3).
    pub eta: f64,
    /// Front-lit only: the margin around lit pixels, mm (default 1).
    pub margin_mm: f64,
    /// With `patterns` NULL: the patterns are the n × n regions of the lit face, row by row, lit
    /// with q = 1 (the paper's n = 4, the default); the image count must be n².
    pub pattern_grid: u32,
    /// Iterations at most per channel of the per-cell fit (default 200; 0: the homogeneous fit
    /// only).
    pub max_iterations: u32,
    /// Iterations at most per channel of the homogeneous fit (default 60).
    pub homogeneous_iterations: u32,
    /// The regularisation weight λ ≥ 0, unit-free (default 1e-4).
    pub lambda: f64,
    /// Stop when every channel's RMS relative misfit is at most this (default 0: never; the
    /// paper's rule is 0.01).
    pub target_misfit_rms: f64,
    /// The linear solves' relative residual, in (0, 1) (default 1e-10).
    pub solve_tolerance: f64,
    /// The homogeneous fit's starting σa, mm⁻¹ (default 0.01 each).
    pub initial_sigma_a: [f64; 3],
    /// The homogeneous fit's starting σ′s, mm⁻¹ (default 1 each).
    pub initial_sigma_s_prime: [f64; 3],
    /// The voxel grid's corner in object space (default 0, 0, 0).
    pub origin: [f64; 3],
    /// Scene units per mm of the voxel grid (default 1).
    pub units_per_mm: f64,
    /// `TC_ACQUIRE_RGB` (default) or `TC_ACQUIRE_GREY`.
    pub channels: u32,
    /// Coarse to fine: with N ≥ 1 the per-cell fit is preceded by fits on blocks of 2^N cells
    /// a side, then 2^(N−1), …, 2, each capped at `max_iterations` (default 0: per cell
    /// straight from the homogeneous fit, as the paper does; at most 8).
    pub coarse_levels: u32,
    /// σa is fitted on blocks this many times wider than σ′s (default 1: the same grid; ≥ 1).
    pub absorption_coarsening: u32,
}

/// The first version of `TcAcquireOptions`: up to `channels`, whose trailing padding
/// `coarse_levels` now fills.
const ACQUIRE_OPTIONS_V1: Layout = Layout {
    size: std::mem::offset_of!(TcAcquireOptions, coarse_levels).next_multiple_of(8),
    fields: std::mem::offset_of!(TcAcquireOptions, coarse_levels),
};

fn default_acquire_options() -> TcAcquireOptions {
    let core = AcquireOptions::default();
    let lambda = match core.lambda {
        Lambda::Given(l) => l,
        Lambda::Discrepancy { start, .. } => start,
    };
    TcAcquireOptions {
        size: size_of::<TcAcquireOptions>() as u32,
        observe: TC_ACQUIRE_BACK_LIT,
        nodes: [0; 3],
        method: TC_ACQUIRE_LBFGS,
        spacing_mm: 0.0,
        eta: 1.3,
        margin_mm: 1.0,
        pattern_grid: 4,
        max_iterations: u32::try_from(core.max_iterations).unwrap_or(u32::MAX),
        homogeneous_iterations: u32::try_from(core.homogeneous_iterations).unwrap_or(u32::MAX),
        lambda,
        target_misfit_rms: core.target_misfit_rms,
        solve_tolerance: core.solve.tolerance,
        initial_sigma_a: core.initial.0,
        initial_sigma_s_prime: core.initial.1,
        origin: [0.0; 3],
        units_per_mm: 1.0,
        channels: TC_ACQUIRE_RGB,
        coarse_levels: u32::try_from(core.coarse_levels).unwrap_or(u32::MAX),
        absorption_coarsening: u32::try_from(core.absorption_coarsening).unwrap_or(u32::MAX),
    }
}

/// What `tc_acquire` found. Set `size` to `sizeof(TcAcquireStats)` first.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcAcquireStats {
    /// Set by the caller to `sizeof(TcAcquireStats)`; the library sets it to the number of
    /// bytes it wrote.
    pub size: u32,
    /// Iterations of all fits (homogeneous and per-cell, all channels).
    pub iterations: u32,
    /// Voxels along x, y, z (the grid's cells: `nodes` − 1 each).
    pub dims: [u32; 3],
    /// Forward solves (one per image per evaluation, three channels each).
    pub forward_solves: u64,
    /// Adjoint solves (one per image per gradient).
    pub adjoint_solves: u64,
    /// The RMS relative misfit per channel at the result.
    pub misfit_rms: [f64; 3],
    /// The homogeneous fit's σa, mm⁻¹.
    pub homogeneous_sigma_a: [f64; 3],
    /// The homogeneous fit's σ′s, mm⁻¹.
    pub homogeneous_sigma_s_prime: [f64; 3],
    /// The voxels' edge in object space (spacing × units per mm).
    pub voxel_size: f64,
}

/// The first version's size of `TcAcquireStats`.
const ACQUIRE_STATS_SIZE_V1: usize = size_of::<TcAcquireStats>();

/// Fills the first `size` bytes of `*options` with the defaults (back-lit, L-BFGS, the paper's
/// 4 × 4 patterns, η 1.3, λ 1e-4, 200 per-cell iterations; `nodes` and `spacing_mm` 0, to be
/// set; no coarse-to-fine levels) and sets `options->size`; pass `sizeof(TcAcquireOptions)`.
/// `TC_NULL_POINTER` for NULL, `TC_INVALID_ARGUMENT` for a size below the first version's
/// (the struct up to `channels`); nothing is written on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_acquire_options_init(options: *mut TcAcquireOptions, size: usize) -> TcStatus {
    run("tc_acquire_options_init", || {
        // SAFETY: the caller's contract: `size` writable bytes.
        unsafe { init(options, size, ACQUIRE_OPTIONS_V1.size, default_acquire_options()) }
    })
}

/// The status of an acquisition's error.
fn failure(e: &InverseError) -> Failure {
    let status = match e {
        InverseError::Cancelled(_) => TC_CANCELLED,
        InverseError::Solve { .. } | InverseError::NotConverged { .. } | InverseError::Sparse(_) => TC_SOLVE_FAILED,
        InverseError::Volume(VolumeError::Io { .. }) => TC_IO_ERROR,
        _ => TC_INVALID_ARGUMENT,
    };
    Failure::new(status, e.to_string())
}

/// `count` pixels of 3 floats as the core's per-pixel values.
fn pixels(v: &[f32]) -> Vec<[f64; 3]> {
    v.chunks_exact(3).map(|p| [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])]).collect()
}

/// Measures a heterogeneous medium from `image_count` images of a lit block (inverse
/// diffusion: a homogeneous fit, then σa and σ′s per grid cell and channel), and returns it as
/// voxels: one per cell, `(nodes[0] − 1) × (nodes[1] − 1) × (nodes[2] − 1)`, 6 floats each
/// (σa R, G, B then σ′s R, G, B, mm⁻¹), x fastest, exactly the `data` of
/// `tc_object_set_medium_voxels` with `dims` = `out_stats->dims`, `voxel_size` =
/// `out_stats->voxel_size` on each axis and `origin` = `options->origin`.
///
/// - `options`: NULL for the defaults is refused (`nodes` and `spacing_mm` must be set): fill
///   it with `tc_acquire_options_init`;
/// - `images`: `image_count` images of `nodes[0]` × `nodes[1]` pixels of 3 floats, one after
///   the other (`images_len` floats in all, which must be exactly that); NaN or infinite
///   pixels are refused, naming the image and pixel;
/// - `patterns`: NULL for `options->pattern_grid`'s n × n regions (then `image_count` must be
///   n²), or `image_count` arrays of q per lit-face node laid out as `images` (`patterns_len`
///   floats, ≥ 0);
/// - `progress`, `user`: NULL, or a callback that gets the stage (naming the fit and its
///   misfit) and the fraction done, and may cancel (`TC_CANCELLED`);
/// - `out_voxels`, `out_len`: the caller's buffer of at least 6 floats per voxel
///   (`TC_BUFFER_TOO_SHORT`, checked before any work, otherwise);
/// - `output_path`: NULL, or a TCVOX1 file to write the same voxels to (replaced only once it
///   is written whole);
/// - `out_stats`: NULL, or statistics with `size` set by the caller to
///   `sizeof(TcAcquireStats)`.
///
/// The work runs on the library's worker threads (one per core, joined before the call
/// returns); the callback may be called from one of them. The caller keeps ownership of every
/// array; the library copies what it reads. On failure
/// (`TC_INVALID_ARGUMENT` naming the input, `TC_SOLVE_FAILED`, `TC_CANCELLED`, `TC_IO_ERROR`
/// when the file cannot be written) nothing is written to `out_voxels`, `out_stats` or
/// `output_path`.
#[no_mangle]
pub unsafe extern "C" fn tc_acquire(
    options: *const TcAcquireOptions,
    images: *const f32,
    images_len: usize,
    image_count: usize,
    patterns: *const f32,
    patterns_len: usize,
    progress: TcProgressFn,
    user: *mut c_void,
    out_voxels: *mut f32,
    out_len: usize,
    output_path: *const c_char,
    out_stats: *mut TcAcquireStats,
) -> TcStatus {
    run_on_workers("tc_acquire", || {
        check_not_null!(options, images, out_voxels);
        let sized = Sized { what: "options", type_name: "TcAcquireOptions", filler: "tc_acquire_options_init" };
        // SAFETY: the caller's contract (`options->size` readable bytes).
        let o = unsafe { read_sized(options, &[ACQUIRE_OPTIONS_V1], default_acquire_options(), &sized)? };
        let nodes = o.nodes.map(|n| n as usize);
        if nodes.iter().any(|&n| n < 2) {
            return Err(Failure::invalid(format!("options->nodes = {:?}: at least 2 along each axis", o.nodes)));
        }
        let total = nodes.iter().try_fold(1u64, |t, &n| t.checked_mul(n as u64)).unwrap_or(u64::MAX);
        if total > TC_MAX_ACQUIRE_NODES {
            return Err(Failure::invalid(format!("options->nodes = {:?}: {total} nodes, above TC_MAX_ACQUIRE_NODES", o.nodes)));
        }
        let observation = match o.observe {
            TC_ACQUIRE_BACK_LIT => Observation::BackLit,
            TC_ACQUIRE_FRONT_LIT => Observation::FrontLit { margin_mm: o.margin_mm },
            v => return Err(Failure::invalid(format!("options->observe = {v}: TC_ACQUIRE_BACK_LIT or TC_ACQUIRE_FRONT_LIT"))),
        };
        let method = match o.method {
            TC_ACQUIRE_LBFGS => Method::default(),
            TC_ACQUIRE_PAPER_CG => Method::PaperCg,
            v => return Err(Failure::invalid(format!("options->method = {v}: TC_ACQUIRE_LBFGS or TC_ACQUIRE_PAPER_CG"))),
        };
        let channels = match o.channels {
            TC_ACQUIRE_RGB => Channels::Rgb,
            TC_ACQUIRE_GREY => Channels::Grey,
            v => return Err(Failure::invalid(format!("options->channels = {v}: TC_ACQUIRE_RGB or TC_ACQUIRE_GREY"))),
        };
        if !(o.spacing_mm.is_finite() && o.spacing_mm > 0.0) {
            return Err(Failure::invalid(format!("options->spacing_mm = {}: finite and > 0", o.spacing_mm)));
        }
        if !(o.lambda.is_finite() && o.lambda >= 0.0) {
            return Err(failure(&InverseError::NegativeLambda(o.lambda)));
        }
        if !(o.units_per_mm.is_finite() && o.units_per_mm > 0.0) || o.origin.iter().any(|v| !v.is_finite()) {
            return Err(Failure::invalid(format!(
                "options->units_per_mm = {} and origin = {:?}: finite, units_per_mm > 0",
                o.units_per_mm, o.origin
            )));
        }
        if !out_stats.is_null() {
            // SAFETY: the caller's contract: `out_stats->size` readable bytes.
            let size = unsafe { out_stats.cast::<u32>().read() } as usize;
            if size < ACQUIRE_STATS_SIZE_V1 {
                return Err(Failure::invalid(format!(
                    "out_stats->size = {size}, expected sizeof(TcAcquireStats) = {ACQUIRE_STATS_SIZE_V1}"
                )));
            }
        }
        let face = nodes[0] * nodes[1];
        let cells = (nodes[0] - 1) * (nodes[1] - 1) * (nodes[2] - 1);
        let needed = ptr::times(cells, 6, "voxels")?;
        if out_len < needed {
            return Err(Failure::new(
                TC_BUFFER_TOO_SHORT,
                format!("out_len = {out_len}: the {cells} voxels need {needed} floats"),
            ));
        }
        let per_image = ptr::times(face, 3, "pixels")?;
        let expected = ptr::times(per_image, image_count, "images")?;
        if image_count == 0 {
            return Err(failure(&InverseError::NoPatterns));
        }
        if images_len != expected {
            return Err(Failure::invalid(format!(
                "images_len = {images_len}: {image_count} images of {} × {} pixels × 3 floats are {expected}",
                nodes[0], nodes[1]
            )));
        }
        // SAFETY: the caller's contract (`images_len` floats).
        let data = unsafe { ptr::slice(images, images_len, "images")? };
        let image_data: Vec<Vec<[f64; 3]>> = data.chunks_exact(per_image).map(pixels).collect();
        let setup = Setup { dims: nodes, spacing_mm: o.spacing_mm, eta: o.eta, observation };
        let pattern_list = if patterns.is_null() {
            let n = o.pattern_grid as usize;
            if n == 0 {
                return Err(Failure::invalid("options->pattern_grid = 0: at least 1 region"));
            }
            if n * n != image_count {
                return Err(failure(&InverseError::PatternCountMismatch { images: image_count, patterns: n * n }));
            }
            Pattern::grid_all(n, setup.face_size_mm(), [1.0; 3])
        } else {
            if patterns_len != expected {
                return Err(Failure::invalid(format!(
                    "patterns_len = {patterns_len}: {image_count} patterns of {} × {} nodes × 3 floats are {expected}",
                    nodes[0], nodes[1]
                )));
            }
            // SAFETY: the caller's contract (`patterns_len` floats).
            let q = unsafe { ptr::slice(patterns, patterns_len, "patterns")? };
            q.chunks_exact(per_image).map(|p| Pattern::Nodes(pixels(p))).collect()
        };
        // SAFETY: the caller's contract.
        let path = unsafe { ptr::optional_path(output_path, "output_path")? };
        let core = AcquireOptions {
            method,
            lambda: Lambda::Given(o.lambda),
            initial: (o.initial_sigma_a, o.initial_sigma_s_prime),
            homogeneous_iterations: o.homogeneous_iterations as usize,
            max_iterations: o.max_iterations as usize,
            target_misfit_rms: o.target_misfit_rms,
            solve: SolveSettings { tolerance: o.solve_tolerance, ..SolveSettings::default() },
            channels,
            coarse_levels: o.coarse_levels as usize,
            absorption_coarsening: o.absorption_coarsening as usize,
            ..AcquireOptions::default()
        };
        let mut model = Acquisition::new(setup, &pattern_list, image_data, None).map_err(|e| failure(&e))?;
        let fit = Callback::with(progress, user, |p| acquire(&mut model, &core, &p)).map_err(|e| failure(&e))?;
        let grid =
            to_voxel_grid(model.grid(), &fit.media, DVec3::from_array(o.origin), o.units_per_mm).map_err(|e| failure(&e))?;
        if let Some(path) = path {
            grid.write(path).map_err(|e| Failure::new(TC_IO_ERROR, e.to_string()))?;
        }
        let voxels: Vec<f32> = fit
            .media
            .sigma_a
            .iter()
            .zip(&fit.media.sigma_s_prime)
            .flat_map(|(a, s)| [a[0], a[1], a[2], s[0], s[1], s[2]].map(|v| v as f32))
            .collect();
        // SAFETY: checked above: `out_len` ≥ `voxels.len()` writable floats.
        unsafe { std::ptr::copy_nonoverlapping(voxels.as_ptr(), out_voxels, voxels.len()) };
        if !out_stats.is_null() {
            // SAFETY: checked above: `out_stats->size` (≥ the first version's) readable and
            // writable bytes.
            let size = unsafe { out_stats.cast::<u32>().read() } as usize;
            let written = size.min(size_of::<TcAcquireStats>());
            let dims = model.grid().cell_dims().map(|d| d as u32);
            let stats = TcAcquireStats {
                size: written as u32,
                iterations: u32::try_from(fit.history.iter().filter(|r| r.iteration > 0).count()).unwrap_or(u32::MAX),
                dims,
                forward_solves: fit.counts.forward_solves as u64,
                adjoint_solves: fit.counts.adjoint_solves as u64,
                misfit_rms: fit.evaluation.misfit_rms(),
                homogeneous_sigma_a: fit.homogeneous.0,
                homogeneous_sigma_s_prime: fit.homogeneous.1,
                voxel_size: o.spacing_mm * o.units_per_mm,
            };
            // SAFETY: as above; `written` ≤ the caller's size and ≤ size_of::<TcAcquireStats>().
            unsafe { ptr::write_prefix(out_stats, &stats, written) };
        }
        Ok(())
    })
}
