//! `tc_acquire` (inverse diffusion, J. Wang et al. 2008 §4) on a tiny block: the voxels equal
//! the Rust API's fit of the same images, the file holds the same voxels and loads as a medium,
//! and bad input is refused by name with nothing of the caller's written.

use std::ffi::{c_char, c_void, CString};
use std::ptr;

use transcut_core::inverse::{
    acquire, synthesize, AcquireOptions, Acquired, Acquisition, Lambda, Observation, Pattern, Setup, SolveSettings, SynthOptions,
    VeinedBlock,
};
use transcut_core::volume::VoxelGrid;
use transcut_core::Progress;

use super::abi::*;
use super::common::*;

const NODES: [u32; 3] = [6, 6, 4];
const CELLS: usize = 5 * 5 * 3;

fn setup() -> Setup {
    Setup { dims: NODES.map(|n| n as usize), spacing_mm: 0.5, eta: 1.3, observation: Observation::BackLit }
}

/// The 16 images of the veined block under the 4 × 4 patterns, flattened as the ABI takes them.
fn images() -> Vec<f32> {
    let s = setup();
    let truth = VeinedBlock::marble(&s);
    let patterns = Pattern::grid_all(4, s.face_size_mm(), [1.0; 3]);
    let images = synthesize(&s, &patterns, &|p| truth.medium(p), SynthOptions::default()).unwrap();
    images.iter().flatten().flat_map(|p| p.map(|c| c as f32)).collect()
}

fn options() -> TcAcquireOptions {
    // SAFETY: an all-zero struct is a valid value to overwrite.
    let mut o: TcAcquireOptions = unsafe { std::mem::zeroed() };
    // SAFETY: a valid pointer and its size.
    ok(unsafe { tc_acquire_options_init(&mut o, size_of::<TcAcquireOptions>()) }, "acquire options");
    o.nodes = NODES;
    o.spacing_mm = 0.5;
    o.max_iterations = 3;
    o
}

/// `tc_acquire` on 16 grid-pattern images (no per-node patterns) at `images`, into `out`.
#[allow(clippy::too_many_arguments)] // the C call's own arguments, less the fixed ones
fn call(
    o: &TcAcquireOptions,
    images: *const f32,
    images_len: usize,
    progress: TcProgressFn,
    user: *mut c_void,
    out: &mut [f32],
    path: *const c_char,
    stats: *mut TcAcquireStats,
) -> TcStatus {
    // SAFETY: every pointer is valid for its length or NULL (which the call must refuse by name);
    // `user` is what `progress` expects.
    unsafe { tc_acquire(o, images, images_len, 16, ptr::null(), 0, progress, user, out.as_mut_ptr(), out.len(), path, stats) }
}

/// Runs `tc_acquire` on `images` (16 of them, grid patterns) into a buffer of NaN.
fn run(o: &TcAcquireOptions, images: &[f32], path: *const c_char) -> (TcStatus, Vec<f32>, TcAcquireStats) {
    let mut out = vec![f32::NAN; 6 * CELLS];
    // SAFETY: an all-zero struct is valid; its size set as the header asks.
    let mut stats: TcAcquireStats = unsafe { std::mem::zeroed() };
    stats.size = size_of::<TcAcquireStats>() as u32;
    let status = call(o, images.as_ptr(), images.len(), None, ptr::null_mut(), &mut out, path, &mut stats);
    (status, out, stats)
}

/// The Rust API's fit of the ABI's `images` with the options `options()` sets (3 per-cell
/// iterations, λ 1e-4) over `base`, and its voxels as `tc_acquire` returns them.
fn rust_fit(images: &[f32], base: AcquireOptions) -> (Acquired, Vec<f32>) {
    let s = setup();
    let patterns = Pattern::grid_all(4, s.face_size_mm(), [1.0; 3]);
    let per_image = 36;
    let imgs: Vec<Vec<[f64; 3]>> = images
        .chunks_exact(3 * per_image)
        .map(|im| im.chunks_exact(3).map(|p| [p[0], p[1], p[2]].map(f64::from)).collect())
        .collect();
    let mut model = Acquisition::new(s, &patterns, imgs, None).unwrap();
    let options = AcquireOptions { max_iterations: 3, lambda: Lambda::Given(1e-4), solve: SolveSettings::default(), ..base };
    let fit = acquire(&mut model, &options, &Progress::none()).unwrap();
    let voxels = fit
        .media
        .sigma_a
        .iter()
        .zip(&fit.media.sigma_s_prime)
        .flat_map(|(a, s)| [a[0], a[1], a[2], s[0], s[1], s[2]].map(|v| v as f32))
        .collect();
    (fit, voxels)
}

#[test]
fn coarse_to_fine_reaches_the_fit_and_a_first_version_struct_keeps_one_fit_per_cell() {
    let data = images();
    let mut o = options();
    (o.coarse_levels, o.absorption_coarsening) = (1, 2);
    let (status, voxels, _) = run(&o, &data, ptr::null());
    ok(status, "tc_acquire coarse to fine");
    let (_, expected) =
        rust_fit(&data, AcquireOptions { coarse_levels: 1, absorption_coarsening: 2, ..AcquireOptions::default() });
    assert_eq!(voxels, expected);
    let (_, per_cell) = rust_fit(&data, AcquireOptions::default());
    assert_ne!(voxels, per_cell, "the coarse fit is another fit");
    // A caller built against the first header: its struct ends at `channels` (and padding),
    // whatever bytes follow are not read, and the fit is the paper's, per cell.
    o.size = std::mem::offset_of!(TcAcquireOptions, coarse_levels).next_multiple_of(8) as u32;
    (o.coarse_levels, o.absorption_coarsening) = (u32::MAX, 0);
    let (status, voxels, _) = run(&o, &data, ptr::null());
    ok(status, "tc_acquire, first-version struct");
    assert_eq!(voxels, per_cell);
}

#[test]
fn an_acquisition_equals_the_rust_apis_and_writes_a_loadable_grid() {
    let data = images();
    let dir = std::env::temp_dir().join(format!("transcut-abi-acquire-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("material.tcvox");
    let c_path = CString::new(file.to_str().unwrap()).unwrap();
    let o = options();
    let (status, voxels, stats) = run(&o, &data, c_path.as_ptr());
    ok(status, "tc_acquire");

    // The Rust API on the same images and options.
    let (fit, expected) = rust_fit(&data, AcquireOptions::default());
    assert_eq!(voxels, expected);
    assert_eq!(stats.dims, [5, 5, 3]);
    assert_eq!(stats.forward_solves, fit.counts.forward_solves as u64);
    assert_eq!(stats.adjoint_solves, fit.counts.adjoint_solves as u64);
    assert_eq!(stats.misfit_rms, fit.evaluation.misfit_rms());
    assert_eq!(stats.voxel_size, 0.5);
    assert_eq!(stats.size as usize, size_of::<TcAcquireStats>());

    // The file holds the same voxels, and an object takes it as its medium.
    let grid = VoxelGrid::read(&file).unwrap();
    assert_eq!(grid.dims(), [5, 5, 3]);
    for (c, v) in voxels.chunks_exact(6).enumerate() {
        let ijk = [c % 5, (c / 5) % 5, c / 25].map(|i| i as u32);
        let got = grid.voxel(ijk).unwrap().to_array();
        assert!(got.iter().zip(v).all(|(g, v)| *g == f64::from(*v)), "voxel {c}");
    }
    let sc = scene();
    let object = add(sc, &Mesh::uv_sphere(1.0, 12, 6));
    // SAFETY: a live scene and a valid path.
    ok(unsafe { tc_object_set_medium_voxel_file(sc, object, c_path.as_ptr(), 1.3, 0.0) }, "load the acquired grid");
    destroy(sc);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_input_is_named_and_nothing_is_written() {
    let data = images();
    let dir = std::env::temp_dir().join(format!("transcut-abi-acquire-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("never.tcvox");
    let c_path = CString::new(file.to_str().unwrap()).unwrap();
    let untouched = |out: &[f32], stats: &TcAcquireStats| {
        assert!(out.iter().all(|v| v.is_nan()), "the voxels were written");
        assert_eq!(stats.forward_solves, 0, "the statistics were written");
        assert!(!file.exists(), "the file was written");
    };

    // Options that cannot describe these images.
    type Change = fn(&mut TcAcquireOptions);
    let bad_options: [(Change, &[&str]); 6] = [
        (|o| o.lambda = -0.5, &["λ", "-0.5"]),
        (|o| o.coarse_levels = 9, &["coarse-to-fine levels", "at most 8"]),
        (|o| o.absorption_coarsening = 0, &["absorption coarsening"]),
        (|o| o.pattern_grid = 3, &["16 images for 9 light patterns"]),
        (|o| o.channels = 7, &["options->channels = 7"]),
        (|o| o.nodes = [6, 6, 1], &["options->nodes"]),
    ];
    for (change, words) in bad_options {
        let mut o = options();
        change(&mut o);
        let (status, out, stats) = run(&o, &data, c_path.as_ptr());
        fails(status, TC_INVALID_ARGUMENT, words);
        untouched(&out, &stats);
    }

    // Images that cannot be fitted.
    let mut nan = data.clone();
    nan[3 * (2 * 36 + 7) + 1] = f32::NAN; // image 2, pixel 7, green
    let black = vec![0.0f32; data.len()];
    let bad_images: [(&[f32], &[&str]); 3] = [
        (&nan, &["image 2: pixel 7 channel 1 is NaN"]),
        (&data[..data.len() - 3], &["images_len", "16 images of 6 × 6 pixels"]),
        (&black, &["nothing to fit"]),
    ];
    for (images, words) in bad_images {
        let (status, out, stats) = run(&options(), images, c_path.as_ptr());
        fails(status, TC_INVALID_ARGUMENT, words);
        untouched(&out, &stats);
    }

    // A short output buffer is refused before any work.
    let mut short = vec![f32::NAN; 6 * CELLS - 1];
    let (none, no_stats) = (ptr::null_mut(), ptr::null_mut());
    let status = call(&options(), data.as_ptr(), data.len(), None, none, &mut short, ptr::null(), no_stats);
    fails(status, TC_BUFFER_TOO_SHORT, &["450 floats"]);
    assert!(short.iter().all(|v| v.is_nan()));

    // A NULL image pointer is named.
    let status = call(&options(), ptr::null(), data.len(), None, none, &mut short, ptr::null(), no_stats);
    fails(status, TC_NULL_POINTER, &["images"]);

    // A cancel from the progress callback stops the fit; nothing is written.
    let mut out = vec![f32::NAN; 6 * CELLS];
    let mut calls = 0u32;
    let user = (&raw mut calls).cast();
    let status = call(&options(), data.as_ptr(), data.len(), Some(cancel_at_third), user, &mut out, c_path.as_ptr(), no_stats);
    fails(status, TC_CANCELLED, &[]);
    assert_eq!(calls, 3);
    assert!(out.iter().all(|v| v.is_nan()) && !file.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// Counts its calls in `*user` and cancels on the third.
unsafe extern "C" fn cancel_at_third(user: *mut c_void, _stage: *const c_char, _fraction: f64) -> i32 {
    // SAFETY: the test passes a live `u32`.
    let calls = unsafe { &mut *user.cast::<u32>() };
    *calls += 1;
    i32::from(*calls >= 3)
}
