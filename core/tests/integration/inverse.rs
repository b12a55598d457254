//! Inverse diffusion: the adjoint gradient against central differences and a Taylor test, the
//! block model against the polygrid system's independent code, a homogeneous fit to images from
//! a 2× finer independent grid, a heterogeneous fit that never goes uphill and predicts
//! held-out lighting, and every named input error.
//!
//! The slow tier (`#[ignore]`d, named `slow_*`: `cargo test -p transcut --test integration --
//! --ignored inverse::slow_`) holds the cases that take minutes: L-BFGS against paper mode's forward
//! solves, and the full-size round trip.

use std::sync::OnceLock;

use glam::DVec3;
use transcut::inverse::{
    acquire, check_gradient, random_patterns, synthesize, to_voxel_grid, uniform_sequence, with_noise, AcquireOptions, Acquired,
    Acquisition, CellMedia, Channels, InverseError, IterationRecord, Lambda, Method, Observation, Pattern, Setup, SolveSettings,
    StopReason, SynthOptions,
};
use transcut::lit_face::{fine_truth_voxels, rendered_errors};
use transcut::progress::Progress;
use transcut::volume::VoxelGrid;

const SKIM: ([f64; 3], [f64; 3]) = ([0.07, 0.12, 0.2], [1.0, 1.3, 1.6]);

/// √(Σ(a − b)²/Σb²) over pixels and channels of masked images.
fn rms_relative(a: &[Vec<[f64; 3]>], b: &[Vec<[f64; 3]>], masks: Option<&[Vec<bool>]>) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (m, (x, y)) in a.iter().zip(b).enumerate() {
        for (p, (x, y)) in x.iter().zip(y).enumerate() {
            if masks.is_none_or(|w| w[m][p]) {
                for c in 0..3 {
                    num += (x[c] - y[c]).powi(2);
                    den += y[c] * y[c];
                }
            }
        }
    }
    (num / den).sqrt()
}

/// Whether the objective never rises within each fit (stage, channel, λ) of a history.
fn never_increases(history: &[IterationRecord]) -> bool {
    history.windows(2).all(|w| {
        let same = w[0].stage == w[1].stage && w[0].channel == w[1].channel && w[0].lambda == w[1].lambda && w[1].iteration > 0;
        !same || w[1].sample.value <= w[0].sample.value
    })
}

/// A small model with images of a heterogeneous medium, for the gradient checks.
fn small_model(observation: Observation, dims: [usize; 3]) -> (Acquisition, Vec<f64>) {
    let setup = Setup { dims, spacing_mm: 0.5, eta: 1.3, observation };
    let patterns = vec![
        Pattern::Rect { rect: [0.0, 0.6, 0.0, 0.6], q: [1.0, 0.9, 0.8] },
        Pattern::Rect { rect: [0.9, 1.5, 0.4, 1.5], q: [0.7, 1.0, 1.2] },
    ];
    let truth = |p: DVec3| ([0.05 + 0.04 * p.x, 0.1, 0.2 + 0.1 * p.y], [1.0 + 0.5 * p.z, 1.5, 2.0 - 0.3 * p.x]);
    let images = synthesize(&setup, &patterns, &truth, SynthOptions { refine: 1, tolerance: 1e-13 }).unwrap();
    let mut model = Acquisition::new(setup, &patterns, images, None).unwrap();
    model.set_solve_settings(SolveSettings { tolerance: 1e-13, max_iterations: 10_000 }).unwrap();
    model.set_lambda(0.01).unwrap();
    model.set_kappa_reference([0.3; 3]);
    let cells = model.grid().cell_count();
    let mut r = uniform_sequence(7);
    let x: Vec<f64> = (0..6 * cells).map(|i| if i % 6 < 3 { (0.03 + 0.1 * r()).ln() } else { (0.8 + 1.5 * r()).ln() }).collect();
    (model, x)
}

#[test]
fn every_gradient_component_matches_central_differences() {
    // 4 × 4 × 3 nodes (18 cells, 108 parameters), M = 2, solves to 1e-13, λ = 0.01; back-lit
    // and front-lit (margin 0.5 mm). Fourth-order differences at ε = 3e-3: at 1e-3 and 3e-4
    // the solves' rounding (≈ 1e-13/ε) already shows (front-lit 2e-6 and 1.3e-5).
    for (name, obs) in [("back-lit", Observation::BackLit), ("front-lit", Observation::FrontLit { margin_mm: 1.0 })] {
        let (mut model, x) = small_model(obs, [4, 4, 3]);
        let all: Vec<usize> = (0..x.len()).collect();
        let check = check_gradient(&mut model, &x, &all, 3e-3).unwrap();
        let largest = check.iter().fold(0.0f64, |m, c| m.max(c.central.abs()));
        let worst = check.iter().map(|c| c.relative_error(0.0)).fold(0.0f64, f64::max);
        let worst_floored = check.iter().map(|c| c.relative_error(1e-6 * largest)).fold(0.0f64, f64::max);
        eprintln!("{name}: {} components, largest |∂f| {largest:.3e}, worst relative error {worst:.2e} ({worst_floored:.2e} with a 1e-6·max floor)", check.len());
        assert!(worst_floored <= 1e-6, "{name}: {worst_floored:.3e}");
    }
}

#[test]
fn the_taylor_remainder_falls_at_second_order() {
    // r(ε) = |f(x + εd) − f(x) − ε ∇f·d| = O(ε²) for a random d: slope 2 ± 0.05.
    let (mut model, x) = small_model(Observation::BackLit, [5, 5, 3]);
    let (e0, g) = model.gradient(&x).unwrap();
    let mut r = uniform_sequence(11);
    let d: Vec<f64> = (0..x.len()).map(|_| 2.0 * r() - 1.0).collect();
    let slope: f64 = g.iter().zip(&d).map(|(a, b)| a * b).sum();
    let eps: Vec<f64> = (0..5).map(|k| 0.05 / 2f64.powi(k)).collect();
    let rem: Vec<f64> = eps
        .iter()
        .map(|&e| {
            let xe: Vec<f64> = x.iter().zip(&d).map(|(x, d)| x + e * d).collect();
            (model.evaluate(&xe).unwrap().value - e0.value - e * slope).abs()
        })
        .collect();
    let slopes: Vec<f64> = rem.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
    eprintln!("Taylor remainders {rem:?}, slopes {slopes:.4?}");
    for s in slopes {
        assert!((s - 2.0).abs() <= 0.05, "slope {s}");
    }
}

#[test]
fn the_block_model_equals_the_polygrid_system_on_the_same_grid() {
    // The inversion's assembly (block.rs) against PolygridSystem::finite_volume (general
    // mapped hexes) at refine = 1: the same discretisation by different code.
    let setup = Setup { dims: [7, 6, 4], spacing_mm: 0.5, eta: 1.3, observation: Observation::FrontLit { margin_mm: 0.5 } };
    let patterns = Pattern::grid_all(2, setup.face_size_mm(), [1.0, 0.5, 0.25]);
    let truth = |p: DVec3| ([0.02 + 0.1 * p.x, 0.05, 0.3], [1.0 + p.y, 2.0, 0.7 + 0.2 * p.z]);
    let images = synthesize(&setup, &patterns, &truth, SynthOptions { refine: 1, tolerance: 1e-13 }).unwrap();
    let mut model = Acquisition::new(setup, &patterns, images.clone(), None).unwrap();
    model.set_solve_settings(SolveSettings { tolerance: 1e-13, max_iterations: 10_000 }).unwrap();
    let g = model.grid().clone();
    let media = CellMedia {
        sigma_a: (0..g.cell_count()).map(|c| truth(DVec3::from(g.cell_centre(c))).0).collect(),
        sigma_s_prime: (0..g.cell_count()).map(|c| truth(DVec3::from(g.cell_centre(c))).1).collect(),
    };
    let pred = model.predict(&media).unwrap();
    let err = rms_relative(&pred, &images, None);
    eprintln!("block model vs polygrid system: {err:.2e} RMS relative");
    assert!(err < 1e-9, "{err}");
}

/// A medium whose κ (0.55, 0.44, 0.37 mm) the 0.25 mm grid resolves, so the model's own
/// discretisation error, O((σ′t h)²), stays well under the 1% the fit is held to (at
/// h = 0.5 mm and skim milk's σ′t ≈ 1.1 mm⁻¹ the two grids' images differ by 2% RMS and σa
/// comes out 1.5% high), and whose diffusion length 1/σtr (1.6, 1.3, 1.1 mm) is short
/// against the 4 mm block, so front-lit pixels beyond the margin still tell σa from σ′s
/// (with 1/σtr ≈ 4 mm, longer than the block, a front-lit fit's σa came out 6% high).
const HOMOGENEOUS: ([f64; 3], [f64; 3]) = ([0.1, 0.15, 0.2], [0.5, 0.6, 0.7]);

/// The homogeneous case: a 4 × 4 × 2 mm block at h = 0.25 mm, 16 images of the paper's 4 × 4
/// regions from the 2× finer independent grid.
fn homogeneous_case(observation: Observation, method: Method) -> (Acquired, Acquisition) {
    let setup = Setup { dims: [17, 17, 9], spacing_mm: 0.25, eta: 1.3, observation };
    let patterns = Pattern::grid_all(4, setup.face_size_mm(), [1.0; 3]);
    let t = std::time::Instant::now();
    let images = synthesize(&setup, &patterns, &|_| HOMOGENEOUS, SynthOptions::default()).unwrap();
    eprintln!("synthesis: {:.2} s", t.elapsed().as_secs_f64());
    let mut model = Acquisition::new(setup, &patterns, images, None).unwrap();
    let options = AcquireOptions { method, max_iterations: 0, homogeneous_iterations: 100, ..AcquireOptions::default() };
    let fit = acquire(&mut model, &options, &Progress::none()).unwrap();
    (fit, model)
}

#[test]
fn a_homogeneous_block_is_recovered_within_one_percent() {
    // Back-lit (the check): images from the 2× finer independent grid, σa and σ′s
    // within 1%. Front-lit, only pixels beyond a 1 mm margin: the same images constrain the
    // σa/σ′s split far less (reflectance away from the source depends mostly on σtr), so the
    // two grids' 0.7% RMS difference moves the fit by about 4%; held to 5%.
    for (name, obs, bound) in
        [("back-lit", Observation::BackLit, 0.01), ("front-lit", Observation::FrontLit { margin_mm: 1.0 }, 0.05)]
    {
        let t = std::time::Instant::now();
        let (fit, _) = homogeneous_case(obs, Method::default());
        let (a, s) = fit.homogeneous;
        let ea: [f64; 3] = std::array::from_fn(|c| a[c] / HOMOGENEOUS.0[c] - 1.0);
        let es: [f64; 3] = std::array::from_fn(|c| s[c] / HOMOGENEOUS.1[c] - 1.0);
        eprintln!(
            "{name}: σa {a:.5?} ({ea:+.4?}), σ′s {s:.5?} ({es:+.4?}), misfit {:.2e} RMS, {} iterations, {} forward + {} adjoint solves, {:?}, {:.1} s",
            fit.evaluation.misfit_rms().iter().fold(0.0f64, |m, &v| m.max(v)),
            fit.history.len() - 3,
            fit.counts.forward_solves,
            fit.counts.adjoint_solves,
            fit.stop,
            t.elapsed().as_secs_f64()
        );
        for c in 0..3 {
            assert!(ea[c].abs() <= bound && es[c].abs() <= bound, "{name} channel {c}: σa {:+.4}, σ′s {:+.4}", ea[c], es[c]);
        }
        assert!(never_increases(&fit.history));
    }
}

#[test]
fn the_homogeneous_fit_is_exact_on_its_own_discretisation() {
    // Images from the same grid (refine = 1, through the polygrid code): the two-parameter
    // fit must land on the truth up to the solves' accuracy (design note A11), front-lit.
    let setup = Setup { dims: [11, 11, 6], spacing_mm: 0.25, eta: 1.3, observation: Observation::FrontLit { margin_mm: 0.5 } };
    let patterns = Pattern::grid_all(4, setup.face_size_mm(), [1.0; 3]);
    let images = synthesize(&setup, &patterns, &|_| HOMOGENEOUS, SynthOptions { refine: 1, tolerance: 1e-12 }).unwrap();
    let mut model = Acquisition::new(setup, &patterns, images, None).unwrap();
    let options =
        AcquireOptions { max_iterations: 0, homogeneous_iterations: 100, relative_decrease: 0.0, ..AcquireOptions::default() };
    let fit = acquire(&mut model, &options, &Progress::none()).unwrap();
    let (a, s) = fit.homogeneous;
    let worst =
        (0..3).map(|c| (a[c] / HOMOGENEOUS.0[c] - 1.0).abs().max((s[c] / HOMOGENEOUS.1[c] - 1.0).abs())).fold(0.0, f64::max);
    eprintln!(
        "own discretisation: worst relative error {worst:.2e}, misfit {:.2e}, {:?}",
        fit.evaluation.misfit_rms()[0],
        fit.stop
    );
    assert!(worst < 1e-5, "{worst}");
}

/// The heterogeneous truth: the homogeneous medium with a vein of 3× σa (a slab 0.75 mm
/// wide along y, through the depth) and a 0.5 mm skin of 1.5× σ′s under the lit face.
fn veined(thickness: f64) -> impl Fn(DVec3) -> ([f64; 3], [f64; 3]) + Sync {
    move |p: DVec3| {
        let (mut a, mut s) = HOMOGENEOUS;
        if (p.x - 1.6).abs() < 0.375 {
            a = a.map(|v| 3.0 * v);
        }
        if p.z > thickness - 0.5 {
            s = s.map(|v| 1.5 * v);
        }
        (a, s)
    }
}

/// The veined block's acquisition: 3 × 3 × 1.5 mm at h = 0.25 mm (13 × 13 × 7 nodes, 864
/// cells, 5,184 parameters), back-lit, 16 images from the 2× finer independent grid; L-BFGS,
/// λ = 1e-4, 25 iterations per channel. Fitted once and shared by the tests that check it
/// (with the fit's seconds).
fn veined_fit() -> &'static (Setup, Acquired, f64) {
    static FIT: OnceLock<(Setup, Acquired, f64)> = OnceLock::new();
    FIT.get_or_init(|| {
        let setup = Setup { dims: [13, 13, 7], spacing_mm: 0.25, eta: 1.3, observation: Observation::BackLit };
        let patterns = Pattern::grid_all(4, setup.face_size_mm(), [1.0; 3]);
        let images = synthesize(&setup, &patterns, &veined(1.5), SynthOptions::default()).unwrap();
        let mut model = Acquisition::new(setup.clone(), &patterns, images, None).unwrap();
        let options = AcquireOptions { max_iterations: 25, lambda: Lambda::Given(1e-4), ..AcquireOptions::default() };
        let t = std::time::Instant::now();
        let fit = acquire(&mut model, &options, &Progress::none()).unwrap();
        (setup, fit, t.elapsed().as_secs_f64())
    })
}

#[test]
fn a_veined_block_is_fitted_without_going_uphill_and_predicts_held_out_light() {
    // [`veined_fit`]; held out: 8 random patterns, rendered by the fine grid. The issue's
    // bounds: training misfit ≤ 1% RMS, held-out appearance ≤ 3% RMS.
    let (setup, fit, seconds) = veined_fit();
    let size = setup.face_size_mm();
    let held = random_patterns(8, size, 5);
    let held_images = synthesize(setup, &held, &veined(1.5), SynthOptions::default()).unwrap();
    assert!(never_increases(&fit.history), "the objective rose");
    // Training misfit: the homogeneous fit's against the per-cell fit's.
    let last =
        |stage: &str, c: usize| fit.history.iter().rev().find(|r| r.stage == stage && r.channel == c).unwrap().sample.misfit_rms;
    let hom: [f64; 3] = std::array::from_fn(|c| last("homogeneous", c));
    let het = fit.evaluation.misfit_rms();
    // Held-out appearance: the recovered and the homogeneous media, each through the coarse
    // model, against the fine grid's images of the truth.
    let mut held_model = Acquisition::new(setup.clone(), &held, held_images.clone(), None).unwrap();
    let cells = held_model.grid().cell_count();
    let pred = held_model.predict(&fit.media).unwrap();
    let pred_hom = held_model.predict(&CellMedia::uniform(cells, fit.homogeneous.0, fit.homogeneous.1)).unwrap();
    let e_het = rms_relative(&pred, &held_images, None);
    let e_hom = rms_relative(&pred_hom, &held_images, None);
    eprintln!(
        "veined: training misfit homogeneous {hom:.4?} → per-cell {het:.4?} RMS; held-out {e_hom:.4} → {e_het:.4} RMS; {} forward + {} adjoint solves, {seconds:.1} s, {:?}",
        fit.counts.forward_solves, fit.counts.adjoint_solves, fit.stop
    );
    for c in 0..3 {
        assert!(het[c] <= 0.01, "channel {c}: training misfit {:.4} RMS against the homogeneous {:.4}", het[c], hom[c]);
    }
    assert!(e_het <= 0.03, "held-out appearance {e_het:.4} RMS");
    assert!(e_het < e_hom, "held-out: per-cell {e_het:.4} against homogeneous {e_hom:.4}");
}

/// [`rendered_errors`] of `media` against `truth` on the synthesis's fine cells.
fn rendered_lit_face_errors(
    setup: &Setup,
    truth: &(dyn Fn(DVec3) -> ([f64; 3], [f64; 3]) + Sync),
    media: &CellMedia,
    tets: usize,
) -> Vec<(&'static str, f64)> {
    rendered_errors(setup, &fine_truth_voxels(setup, truth).unwrap(), media, tets).unwrap()
}

#[test]
fn the_recovered_block_renders_closer_to_the_truth_than_the_homogeneous_fit() {
    // [`veined_fit`]'s cells, its homogeneous fit, and the truth on the fit's cells (sampled at
    // their centres), each as the medium of the block meshed with 30k tets and baked by
    // TransCut under a sun and a spot, against the truth on the synthesis's fine cells:
    // relative RMS of Lo over the lit face. The comparison resolves far less than the 5% the
    // recovered grid is to be held to: the truth on the coarse cells is within 1%. Here the
    // recovered grid renders closer than the homogeneous fit under each light, but not within
    // 5% under the sun (measured 37%): back-lit images are transmission, the same for a
    // medium mirrored in depth (reciprocity), so the fit cannot place the skin under the lit
    // face (its σ′s rises at both faces) and the lit face's albedo comes out low. On the
    // full-size block (`slow_the_round_trip_at_full_size`'s fit, 60k tets) even the ordering
    // fails: recovered 8.3% (sun) and 18.2% (spot), homogeneous 8.2% and 17.0%.
    let (setup, fit, _) = veined_fit();
    let t = std::time::Instant::now();
    let truth = veined(1.5);
    let grid = transcut::inverse::BlockGrid::new(setup.dims, setup.spacing_mm).unwrap();
    let centres: Vec<([f64; 3], [f64; 3])> = (0..grid.cell_count()).map(|c| truth(DVec3::from(grid.cell_centre(c)))).collect();
    let coarse =
        CellMedia { sigma_a: centres.iter().map(|m| m.0).collect(), sigma_s_prime: centres.iter().map(|m| m.1).collect() };
    let cells = grid.cell_count();
    let het = rendered_lit_face_errors(setup, &truth, &fit.media, 30_000);
    let hom = rendered_lit_face_errors(setup, &truth, &CellMedia::uniform(cells, fit.homogeneous.0, fit.homogeneous.1), 30_000);
    let own = rendered_lit_face_errors(setup, &truth, &coarse, 30_000);
    eprintln!(
        "rendered lit face, relative RMS: recovered {het:.4?}, homogeneous {hom:.4?}, truth on the cells {own:.4?} (goal for the recovered: 0.05); {:.1} s",
        t.elapsed().as_secs_f64()
    );
    for ((name, e_het), ((_, e_hom), (_, e_own))) in het.iter().zip(hom.iter().zip(&own)) {
        assert!(*e_own <= 0.01, "{name}: the truth on the fit's cells renders {e_own:.4} from the fine truth");
        assert!(e_het < e_hom, "{name}: recovered {e_het:.4} against homogeneous {e_hom:.4}");
    }
}

#[test]
fn bad_input_is_named() {
    let setup = Setup { dims: [5, 5, 3], spacing_mm: 0.5, eta: 1.3, observation: Observation::BackLit };
    let patterns = Pattern::grid_all(2, setup.face_size_mm(), [1.0; 3]);
    let good = vec![vec![[0.1; 3]; 25]; 4];
    let err = |r: Result<Acquisition, InverseError>| r.expect_err("an error");
    // Wrong image size.
    let mut imgs = good.clone();
    imgs[2].pop();
    assert!(matches!(
        err(Acquisition::new(setup.clone(), &patterns, imgs, None)),
        InverseError::WrongImageSize { index: 2, found: 24, .. }
    ));
    // NaN pixel.
    let mut imgs = good.clone();
    imgs[1][7][2] = f64::NAN;
    assert!(matches!(
        err(Acquisition::new(setup.clone(), &patterns, imgs, None)),
        InverseError::BadPixel { what: "image", index: 1, pixel: 7, channel: 2, .. }
    ));
    // Pattern count mismatch.
    assert!(matches!(
        err(Acquisition::new(setup.clone(), &patterns[..3], good.clone(), None)),
        InverseError::PatternCountMismatch { images: 4, patterns: 3 }
    ));
    // Empty mask: every pixel masked by the caller, or by a front-lit margin wider than the face.
    let none = Some(vec![vec![false; 25]; 4]);
    assert!(matches!(err(Acquisition::new(setup.clone(), &patterns, good.clone(), none)), InverseError::EmptyMask { .. }));
    let front = Setup { observation: Observation::FrontLit { margin_mm: 10.0 }, ..setup.clone() };
    assert!(matches!(err(Acquisition::new(front, &patterns, good.clone(), None)), InverseError::EmptyMask { .. }));
    // λ < 0, given or set.
    let mut model = Acquisition::new(setup.clone(), &patterns, good.clone(), None).unwrap();
    assert!(matches!(model.set_lambda(-1.0), Err(InverseError::NegativeLambda(_))));
    let options = AcquireOptions { lambda: Lambda::Given(-1e-3), ..AcquireOptions::default() };
    assert!(matches!(acquire(&mut model, &options, &Progress::none()), Err(InverseError::NegativeLambda(_))));
    assert_eq!(model.counts().forward_solves, 0, "no solve before the options are checked");
    // No patterns; a bad grid.
    assert!(matches!(err(Acquisition::new(setup.clone(), &[], vec![], None)), InverseError::NoPatterns));
    let flat = Setup { dims: [5, 5, 1], ..setup.clone() };
    assert!(matches!(err(Acquisition::new(flat, &patterns, good.clone(), None)), InverseError::InvalidGrid { .. }));
    // Cancel: the callback's refusal stops the fit with Cancelled and no result.
    let stop = |_: &str, _: f64| false;
    let r = acquire(&mut model, &AcquireOptions::default(), &Progress::new(&stop));
    assert!(matches!(r, Err(InverseError::Cancelled(_))));
    // Progress: one report per iteration, naming the fit and its misfit, fractions in order.
    let seen = std::sync::Mutex::new(Vec::new());
    let record = |stage: &str, f: f64| {
        seen.lock().unwrap().push((stage.to_owned(), f));
        true
    };
    let options = AcquireOptions { max_iterations: 2, homogeneous_iterations: 2, ..AcquireOptions::default() };
    acquire(&mut model, &options, &Progress::new(&record)).unwrap();
    let seen = seen.into_inner().unwrap();
    assert!(seen.iter().any(|(s, _)| s.contains("heterogeneous fit, blue channel") && s.contains("% RMS")), "{seen:?}");
    assert!(seen.windows(2).all(|w| w[1].1 >= w[0].1), "{seen:?}");
}

#[test]
fn the_recovered_cells_are_a_voxel_grid_that_reads_back() {
    let g = transcut::inverse::BlockGrid::new([5, 4, 3], 0.5).unwrap();
    let media = CellMedia::uniform(g.cell_count(), SKIM.0, SKIM.1);
    let v = to_voxel_grid(&g, &media, DVec3::ZERO, 1.0).unwrap();
    let back = VoxelGrid::from_bytes(&v.to_bytes()).unwrap();
    assert_eq!(back.dims(), [4, 3, 2]);
    let s = back.sample(DVec3::new(1.0, 0.7, 0.5));
    assert!((s.sigma_s_prime[1] - 1.3).abs() < 1e-6);
    let _ = StopReason::Misfit;
}

#[test]
#[ignore = "slow tier: minutes; run with --ignored slow_"]
fn slow_lbfgs_needs_fewer_forward_solves_than_paper_mode() {
    // The veined block to 3% RMS training misfit per channel by each optimiser (design note
    // P10: the default should need at most a third of paper mode's solves).
    let setup = Setup { dims: [13, 13, 7], spacing_mm: 0.25, eta: 1.3, observation: Observation::BackLit };
    let patterns = Pattern::grid_all(4, setup.face_size_mm(), [1.0; 3]);
    let images = synthesize(&setup, &patterns, &veined(1.5), SynthOptions::default()).unwrap();
    let mut solves = Vec::new();
    for method in [Method::default(), Method::PaperCg] {
        let mut model = Acquisition::new(setup.clone(), &patterns, images.clone(), None).unwrap();
        let options = AcquireOptions {
            method,
            max_iterations: 400,
            lambda: Lambda::Given(1e-4),
            target_misfit_rms: 0.03,
            homogeneous_iterations: 100,
            ..AcquireOptions::default()
        };
        let t = std::time::Instant::now();
        let fit = acquire(&mut model, &options, &Progress::none()).unwrap();
        assert!(never_increases(&fit.history), "{method:?}: the objective rose");

        let heterogeneous = fit.history.iter().filter(|r| r.stage == "heterogeneous" && r.iteration > 0).count();
        eprintln!(
            "{method:?}: misfit {:.4?}, {heterogeneous} per-cell iterations, {} forward + {} adjoint solves, {:.1} s, {:?}",
            fit.evaluation.misfit_rms(),
            fit.counts.forward_solves,
            fit.counts.adjoint_solves,
            t.elapsed().as_secs_f64(),
            fit.stop
        );
        assert_eq!(fit.stop, [StopReason::Misfit; 3], "{method:?}");
        solves.push(fit.counts.forward_solves);
    }
    eprintln!("forward solves: L-BFGS / paper = {:.3}", solves[0] as f64 / solves[1] as f64);
    assert!(3 * solves[0] <= solves[1], "{solves:?}");
}

#[test]
fn with_one_percent_noise_the_discrepancy_principle_picks_lambda_and_held_out_light_stays_within_five_percent() {
    // The veined block of the test above with 1% Gaussian noise on every training pixel; λ
    // from 1e-2 down by decades until each channel's misfit is ≤ 1.1 × 1%. The bound
    // on held-out appearance with noise: 5% RMS (against the noise-free fine-grid images).
    let setup = Setup { dims: [13, 13, 7], spacing_mm: 0.25, eta: 1.3, observation: Observation::BackLit };
    let size = setup.face_size_mm();
    let patterns = Pattern::grid_all(4, size, [1.0; 3]);
    let truth = veined(1.5);
    let clean = synthesize(&setup, &patterns, &truth, SynthOptions::default()).unwrap();
    let noisy = with_noise(&clean, 0.01, 99);
    let measured_noise = rms_relative(&noisy, &clean, None);
    let held = random_patterns(8, size, 5);
    let held_images = synthesize(&setup, &held, &truth, SynthOptions::default()).unwrap();
    let mut model = Acquisition::new(setup.clone(), &patterns, noisy, None).unwrap();
    let options = AcquireOptions {
        max_iterations: 25,
        lambda: Lambda::Discrepancy { noise_rms: 0.01, tau: 1.1, start: 1e-2 },
        ..AcquireOptions::default()
    };
    let t = std::time::Instant::now();
    let fit = acquire(&mut model, &options, &Progress::none()).unwrap();
    assert!(never_increases(&fit.history), "the objective rose");
    let mut held_model = Acquisition::new(setup, &held, held_images.clone(), None).unwrap();
    let e = rms_relative(&held_model.predict(&fit.media).unwrap(), &held_images, None);
    eprintln!(
        "noisy ({measured_noise:.4} RMS): λ {:?}, training misfit {:.4?}, held-out {e:.4} RMS, {} forward solves, {:.1} s, {:?}",
        fit.lambda,
        fit.evaluation.misfit_rms(),
        fit.counts.forward_solves,
        t.elapsed().as_secs_f64(),
        fit.stop
    );
    assert!(e <= 0.05, "held-out {e:.4}");
}

#[test]
#[ignore = "slow tier: minutes; run with --ignored slow_"]
fn slow_the_round_trip_at_full_size() {
    // The synthetic round trip: 40 × 40 × 12 nodes at 0.5 mm, marble (η = 1.3) with a
    // vein of 5× σa and a 1 mm skin of 1.5× σ′s, 16 images back-lit from the 2× finer grid;
    // L-BFGS, λ = 1e-4, 40 iterations per channel; the bounds: training misfit ≤ 1%
    // RMS, held-out appearance (8 random patterns) ≤ 3% RMS. Measured on the shared 2-core
    // machine: training 0.09/0.13/0.19%, held-out 7.2% (homogeneous) → 1.1%, 227 s for 164
    // iterations (1.4 s each), synthesis 30 s.
    let marble = ([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.0]);
    let setup = Setup { dims: [40, 40, 12], spacing_mm: 0.5, eta: 1.3, observation: Observation::BackLit };
    let size = setup.face_size_mm();
    let thickness = 11.0 * 0.5;
    let truth = move |p: DVec3| {
        let (mut a, mut s) = marble;
        if ((p.x - 0.6 * p.y) - 6.0).abs() < 1.0 {
            a = a.map(|v| 5.0 * v);
        }
        if p.z > thickness - 1.0 {
            s = s.map(|v| 1.5 * v);
        }
        (a, s)
    };
    let patterns = Pattern::grid_all(4, size, [1.0; 3]);
    let t = std::time::Instant::now();
    let images = synthesize(&setup, &patterns, &truth, SynthOptions::default()).unwrap();
    let held = random_patterns(8, size, 5);
    let held_images = synthesize(&setup, &held, &truth, SynthOptions::default()).unwrap();
    eprintln!("full size: synthesis {:.1} s", t.elapsed().as_secs_f64());
    let mut model = Acquisition::new(setup.clone(), &patterns, images, None).unwrap();
    let options = AcquireOptions {
        max_iterations: 40,
        lambda: Lambda::Given(1e-4),
        initial: ([0.005; 3], [2.0; 3]),
        ..AcquireOptions::default()
    };
    let t = std::time::Instant::now();
    let fit = acquire(&mut model, &options, &Progress::none()).unwrap();
    let seconds = t.elapsed().as_secs_f64();
    assert!(never_increases(&fit.history), "the objective rose");
    let mut held_model = Acquisition::new(setup, &held, held_images.clone(), None).unwrap();
    let cells = held_model.grid().cell_count();
    let e_het = rms_relative(&held_model.predict(&fit.media).unwrap(), &held_images, None);
    let e_hom = rms_relative(
        &held_model.predict(&CellMedia::uniform(cells, fit.homogeneous.0, fit.homogeneous.1)).unwrap(),
        &held_images,
        None,
    );
    let iterations = fit.history.iter().filter(|r| r.iteration > 0).count();
    eprintln!(
        "full size: homogeneous σa {:.5?} σ′s {:.4?}; training misfit {:.4?} RMS; held-out {e_hom:.4} → {e_het:.4} RMS; {iterations} iterations, {} forward + {} adjoint solves, {seconds:.1} s ({:.2} s per iteration), {:?}",
        fit.homogeneous.0,
        fit.homogeneous.1,
        fit.evaluation.misfit_rms(),
        fit.counts.forward_solves,
        fit.counts.adjoint_solves,
        seconds / iterations as f64,
        fit.stop
    );
    assert!(fit.evaluation.misfit_rms().iter().all(|&m| m <= 0.01), "training misfit");
    assert!(e_het <= 0.03 && e_het < e_hom, "held-out {e_het:.4} against the homogeneous {e_hom:.4}");
}

#[test]
fn grey_images_fit_one_channel_and_copy_it() {
    // Grey images (one medium in every channel, grey light): the grey fit's media are the same
    // in every channel, equal the RGB fit's (the three channels are the same problem; the solves
    // differ only in when PCG stops on the held channels, to 1e-10), and it iterates a third as
    // often.
    let setup = Setup { dims: [7, 7, 4], spacing_mm: 0.5, eta: 1.3, observation: Observation::BackLit };
    let patterns = Pattern::grid_all(2, setup.face_size_mm(), [1.0; 3]);
    let truth = |p: DVec3| ([0.05 + 0.03 * p.x; 3], [1.2 + 0.2 * p.z; 3]);
    let images = synthesize(&setup, &patterns, &truth, SynthOptions::default()).unwrap();
    let fit = |channels| {
        let mut model = Acquisition::new(setup.clone(), &patterns, images.clone(), None).unwrap();
        let options = AcquireOptions { max_iterations: 4, channels, ..AcquireOptions::default() };
        acquire(&mut model, &options, &Progress::none()).unwrap()
    };
    let (rgb, grey) = (fit(Channels::Rgb), fit(Channels::Grey));
    for (a, s) in grey.media.sigma_a.iter().zip(&grey.media.sigma_s_prime) {
        assert!(a[1] == a[0] && a[2] == a[0] && s[1] == s[0] && s[2] == s[0], "{a:?} {s:?}");
    }
    for (g, r) in
        grey.media.sigma_a.iter().chain(&grey.media.sigma_s_prime).zip(rgb.media.sigma_a.iter().chain(&rgb.media.sigma_s_prime))
    {
        for c in 0..3 {
            assert!((g[c] / r[c] - 1.0).abs() < 1e-6, "channel {c}: grey {} against RGB {}", g[c], r[c]);
        }
    }
    assert!(grey.history.iter().all(|h| h.channel == 0));
    let iterations = |f: &Acquired| f.history.iter().filter(|h| h.iteration > 0).count();
    assert_eq!(3 * iterations(&grey), iterations(&rgb));
    // The same media give the same misfit, to the solves' accuracy (each channel's final
    // solve is warm-started from where its own fit left it).
    let m = grey.evaluation.misfit_rms();
    assert!((m[1] / m[0] - 1.0).abs() < 1e-6 && (m[2] / m[0] - 1.0).abs() < 1e-6, "{m:?}");
}

#[test]
fn coarse_to_fine_runs_its_levels_in_order_each_starting_where_the_last_stopped() {
    // 8 × 8 × 4 cells, two coarse levels (blocks of 4 then 2 cells a side) before single
    // cells, σa on blocks twice as wide as σ′s. Per channel the history must run the levels
    // coarse to fine; each level must start at the objective its predecessor ended with (the
    // block averages of nested blocks reproduce the cells exactly); the objective never rises;
    // and the result's σa is constant on 2 × 2 × 2 blocks while σ′s varies inside them.
    let setup = Setup { dims: [9, 9, 5], spacing_mm: 0.5, eta: 1.3, observation: Observation::BackLit };
    let patterns = Pattern::grid_all(2, setup.face_size_mm(), [1.0; 3]);
    let truth = |p: DVec3| ([0.04 + 0.02 * p.x, 0.06, 0.08 + 0.02 * p.y], [1.0 + 0.4 * p.z, 1.4 - 0.1 * p.x, 1.8]);
    let images = synthesize(&setup, &patterns, &truth, SynthOptions::default()).unwrap();
    let mut model = Acquisition::new(setup.clone(), &patterns, images, None).unwrap();
    let options = AcquireOptions { max_iterations: 5, coarse_levels: 2, absorption_coarsening: 2, ..AcquireOptions::default() };
    let fit = acquire(&mut model, &options, &Progress::none()).unwrap();
    assert!(never_increases(&fit.history), "the objective rose");
    for c in 0..3 {
        let fits: Vec<&IterationRecord> = fit.history.iter().filter(|r| r.channel == c && r.stage != "homogeneous").collect();
        let starts: Vec<usize> = (0..fits.len()).filter(|&i| fits[i].iteration == 0).collect();
        let blocks: Vec<[usize; 2]> = starts.iter().map(|&i| fits[i].block_cells).collect();
        assert_eq!(blocks, [[8, 4], [4, 2], [2, 1]], "channel {c}: levels");
        let stages: Vec<&str> = starts.iter().map(|&i| fits[i].stage).collect();
        assert_eq!(stages, ["coarse", "coarse", "heterogeneous"]);
        for &i in &starts[1..] {
            let (end, start) = (fits[i - 1].sample.value, fits[i].sample.value);
            assert!((start / end - 1.0).abs() < 1e-6, "channel {c}: a level started at {start:e} after {end:e}");
        }
        // The first coarse level starts where the homogeneous fit ended.
        let homogeneous = fit.history.iter().rev().find(|r| r.channel == c && r.stage == "homogeneous").unwrap().sample;
        assert!(fits[0].sample.misfit_rms <= homogeneous.misfit_rms * (1.0 + 1e-6));
    }
    let cells = [8usize, 8, 4];
    let at = |i: usize, j: usize, k: usize| i + cells[0] * (j + cells[1] * k);
    let mut varies = false;
    for k in 0..cells[2] {
        for j in 0..cells[1] {
            for i in 0..cells[0] {
                let corner = at(i & !1, j & !1, k & !1);
                assert_eq!(fit.media.sigma_a[at(i, j, k)], fit.media.sigma_a[corner], "σa varies inside a block");
                varies |= fit.media.sigma_s_prime[at(i, j, k)] != fit.media.sigma_s_prime[corner];
            }
        }
    }
    assert!(varies, "σ′s is constant on σa's blocks");
    // Bad settings are named before any solve.
    for (bad, what) in [
        (AcquireOptions { coarse_levels: 9, ..options }, "coarse-to-fine levels"),
        (AcquireOptions { absorption_coarsening: 0, ..options }, "absorption coarsening"),
    ] {
        let e = acquire(&mut model, &bad, &Progress::none()).unwrap_err();
        assert!(matches!(e, InverseError::InvalidSetting { .. }) && e.to_string().contains(what), "{e}");
    }
}
