//! `transcut bench inverse`: the synthetic acquisition (J. Wang et al. 2008 §4: a veined, skinned marble block) by
//! the default optimiser (L-BFGS) and by paper mode (Polak–Ribière CG with golden-section
//! search), both to the paper's stopping rule (every channel's RMS relative misfit ≤ 1%), and
//! the marble-scale time that the measured cost per solve implies.
//!
//! The images come from the independent 2×-finer discretisation ([`synthesize`]) of a veined,
//! skinned marble block ([`VeinedBlock::marble`]), back-lit, under the paper's 4 × 4 patterns.
//!
//! The marble-scale estimate scales the measured time per solve (forward or adjoint, three
//! channels, warm-started) by the node count and by the longest axis (Jacobi-PCG's iterations
//! grow with the grid's linear size), for the same number of solves as the measured run: the
//! paper's case (256 × 256 × 20 nodes) against its 11 hours.
//!
//! Every fit is also judged against the truth ([`inverse_quality`]): κ and μ by depth (each
//! layer of cells, and the top 1 mm against the goals κ ≤ 10% and μ ≤ 25% RMS), and the
//! appearance under held-out lighting (8 random rectangles and 64 single-node sources, rendered
//! by the independent synthesis). The default run's grid and its homogeneous fit are also
//! rendered by TransCut (the block meshed with --inverse-render-tets, a sun and a spot) against
//! the truth on the synthesis's fine cells: relative RMS of Lo over the lit face, goal 5%. With `--inverse-sweep` the default optimiser is also run on
//! M = 1, 4, 9, 16, 25 and 64 patterns (n × n regions; 16 is the comparison's run), and on the
//! 16 images with 1% Gaussian noise, λ by the discrepancy principle (goal: held-out ≤ 5%).

use std::time::Instant;

use anyhow::{bail, Context};
use transcut::inverse::{
    acquire, random_patterns, single_node_patterns, synthesize, with_noise, AcquireOptions, Acquired, Acquisition, BlockGrid,
    CellMedia, Lambda, Method, Observation, Pattern, Setup, StopReason, SynthOptions, VeinedBlock,
};
use transcut::Progress;

use super::args::BenchArgs;
use super::inverse_quality::{appearance_error, depth_errors, top_errors, truth_on_cells, DepthError};
use transcut::lit_face::{fine_truth_voxels, rendered_errors};

/// The paper's marble acquisition: nodes and hours (J. Wang et al. 2008 §6).
const MARBLE_NODES: [usize; 3] = [256, 256, 20];
const MARBLE_PAPER_HOURS: f64 = 11.0;
/// The paper's stopping rule, RMS relative misfit per channel.
const TARGET_MISFIT: f64 = 0.01;
/// λ of the noise-free fits.
const LAMBDA: f64 = 1e-4;
/// The depth the κ and μ goals hold over, mm, and the goals (relative RMS).
const TOP_MM: f64 = 1.0;
const KAPPA_GOAL: f64 = 0.10;
const MU_GOAL: f64 = 0.25;
/// The sweep's pattern grids: n × n regions, M = n².
const SWEEP_GRIDS: [usize; 6] = [1, 2, 3, 4, 5, 8];
/// The noisy repeat's relative noise, the discrepancy principle's τ and first λ.
const NOISE_RMS: f64 = 0.01;
const NOISE_TAU: f64 = 1.1;
const NOISE_LAMBDA_START: f64 = 1e-2;

struct Run {
    name: &'static str,
    fit: Acquired,
    seconds: f64,
}

/// How the suite's fits run: the per-cell fit's optimiser, its iteration cap per channel (per
/// level when coarse to fine) and its parameter grids.
#[derive(Clone, Copy)]
struct Plan {
    method: Method,
    cap: usize,
    coarse_levels: usize,
    absorption_coarsening: usize,
}

/// The fit of `images` by `plan` from a marble-like start, stopped at `target` RMS misfit per
/// channel.
fn measure(
    setup: &Setup,
    patterns: &[Pattern],
    images: &[Vec<[f64; 3]>],
    plan: Plan,
    lambda: Lambda,
    target: f64,
) -> anyhow::Result<Acquired> {
    let mut model = Acquisition::new(setup.clone(), patterns, images.to_vec(), None)?;
    let options = AcquireOptions {
        method: plan.method,
        lambda,
        initial: ([0.005; 3], [2.0; 3]),
        homogeneous_iterations: 100,
        max_iterations: plan.cap,
        target_misfit_rms: target,
        coarse_levels: plan.coarse_levels,
        absorption_coarsening: plan.absorption_coarsening,
        ..AcquireOptions::default()
    };
    Ok(acquire(&mut model, &options, &Progress::none())?)
}

/// What a fit is judged against: the truth on the fit's cells and the held-out lighting
/// (patterns and the independent synthesis's images of the truth under them).
struct Reference {
    truth: CellMedia,
    random: (Vec<Pattern>, Vec<Vec<[f64; 3]>>),
    points: (Vec<Pattern>, Vec<Vec<[f64; 3]>>),
}

impl Reference {
    /// The reference of `truth` on `setup`: 8 random rectangles and 8 × 8 single-node sources.
    fn new(setup: &Setup, truth: &VeinedBlock) -> anyhow::Result<Self> {
        let grid = BlockGrid::new(setup.dims, setup.spacing_mm)?;
        let medium = |p| truth.medium(p);
        let render = |patterns: Vec<Pattern>| -> anyhow::Result<_> {
            let images = synthesize(setup, &patterns, &medium, SynthOptions::default())?;
            Ok((patterns, images))
        };
        Ok(Self {
            truth: truth_on_cells(&grid, &medium),
            random: render(random_patterns(8, setup.face_size_mm(), 5))?,
            points: render(single_node_patterns(8, setup.dims[0], setup.dims[1], setup.spacing_mm))?,
        })
    }

    /// `media`'s κ and μ errors by depth and over the top [`TOP_MM`], and its held-out
    /// appearance errors, as JSON.
    fn judge(&self, setup: &Setup, media: &CellMedia) -> anyhow::Result<serde_json::Value> {
        let grid = BlockGrid::new(setup.dims, setup.spacing_mm)?;
        let top = top_errors(&grid, media, &self.truth, TOP_MM);
        let random = appearance_error(setup, &self.random.0, &self.random.1, media)?;
        let points = appearance_error(setup, &self.points.0, &self.points.1, media)?;
        Ok(serde_json::json!({
            "held_out_random_rms": random,
            "held_out_point_rms": points,
            "top_1mm": depth_report(&top),
            "top_1mm_within_goals": top.kappa.iter().all(|&e| e <= KAPPA_GOAL) && top.mu.iter().all(|&e| e <= MU_GOAL),
            "depth": depth_errors(&grid, media, &self.truth).iter().map(depth_report).collect::<Vec<_>>(),
        }))
    }
}

/// One [`DepthError`] as JSON.
fn depth_report(e: &DepthError) -> serde_json::Value {
    serde_json::json!({ "depth_mm": e.depth_mm, "kappa_rms": e.kappa, "mu_rms": e.mu })
}

fn method_report(r: &Run, quality: serde_json::Value) -> serde_json::Value {
    let f = &r.fit;
    let iterations = f.history.iter().filter(|h| h.iteration > 0).count();
    let heterogeneous = f.history.iter().filter(|h| h.iteration > 0 && h.stage == "heterogeneous").count();
    let coarse = f.history.iter().filter(|h| h.iteration > 0 && h.stage == "coarse").count();
    let solves = f.counts.forward_solves + f.counts.adjoint_solves;
    serde_json::json!({
        "method": r.name,
        "seconds": r.seconds,
        "iterations": iterations,
        "heterogeneous_iterations": heterogeneous,
        "coarse_iterations": coarse,
        "forward_solves": f.counts.forward_solves,
        "adjoint_solves": f.counts.adjoint_solves,
        "pcg_iterations": f.counts.pcg_iterations,
        "seconds_per_iteration": r.seconds / iterations.max(1) as f64,
        "seconds_per_solve": r.seconds / solves.max(1) as f64,
        "misfit_rms": f.evaluation.misfit_rms(),
        "reached_target": f.stop.iter().all(|s| *s == StopReason::Misfit),
        "stop": f.stop.map(|s| format!("{s:?}")),
        "lambda": f.lambda,
        "quality": quality,
    })
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let nodes: [usize; 3] = args.inverse_nodes.as_slice().try_into().context("--inverse-nodes takes three counts")?;
    if nodes.iter().any(|&n| n < 4) {
        bail!("--inverse-nodes {nodes:?}: at least 4 nodes per axis (the 4 × 4 patterns need a face to split)");
    }
    let cap = usize::try_from(args.inverse_iterations)?;
    let plan = Plan {
        method: Method::default(),
        cap,
        coarse_levels: args.inverse_coarse_levels as usize,
        absorption_coarsening: args.inverse_absorption_coarsening as usize,
    };
    let observation = args.inverse_front_lit.map_or(Observation::BackLit, |margin_mm| Observation::FrontLit { margin_mm });
    let setup = Setup { dims: nodes, spacing_mm: 0.5, eta: 1.3, observation };
    let truth = VeinedBlock::marble(&setup);
    let patterns = Pattern::grid_all(4, setup.face_size_mm(), [1.0; 3]);
    let t = Instant::now();
    let images = synthesize(&setup, &patterns, &|p| truth.medium(p), SynthOptions::default())?;
    let synthesis_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let reference = Reference::new(&setup, &truth)?;
    let reference_s = t.elapsed().as_secs_f64();
    let mut runs = Vec::new();
    for (name, method) in [("lbfgs", Method::default()), ("paper", Method::PaperCg)] {
        let t = Instant::now();
        let fit = measure(&setup, &patterns, &images, Plan { method, ..plan }, Lambda::Given(LAMBDA), TARGET_MISFIT)?;
        runs.push(Run { name, fit, seconds: t.elapsed().as_secs_f64() });
    }
    let methods =
        runs.iter().map(|r| Ok(method_report(r, reference.judge(&setup, &r.fit.media)?))).collect::<anyhow::Result<Vec<_>>>()?;
    let t = Instant::now();
    let truth_voxels = fine_truth_voxels(&setup, &|p| truth.medium(p))?;
    let tets = usize::try_from(args.inverse_render_tets)?;
    let named = |errors: Vec<(&str, f64)>| {
        errors.into_iter().map(|(n, e)| (n.to_owned(), serde_json::json!(e))).collect::<serde_json::Map<_, _>>()
    };
    let fit = &runs[0].fit;
    let homogeneous = CellMedia::uniform(fit.media.sigma_a.len(), fit.homogeneous.0, fit.homogeneous.1);
    let rendered = serde_json::json!({
        "tets": tets,
        "recovered": named(rendered_errors(&setup, &truth_voxels, &fit.media, tets)?),
        "homogeneous": named(rendered_errors(&setup, &truth_voxels, &homogeneous, tets)?),
        "seconds": t.elapsed().as_secs_f64(),
    });
    let sweep = if args.inverse_sweep { Some(sweep(&setup, &truth, &reference, &runs[0], &images, plan)?) } else { None };
    let (default, paper) = (&runs[0], &runs[1]);
    let ratio = default.fit.counts.forward_solves as f64 / paper.fit.counts.forward_solves.max(1) as f64;
    let solves = default.fit.counts.forward_solves + default.fit.counts.adjoint_solves;
    let per_solve = default.seconds / solves.max(1) as f64;
    let count = |n: [usize; 3]| n.iter().product::<usize>() as f64;
    let longest = |n: [usize; 3]| n.iter().copied().max().unwrap_or(1) as f64;
    let node_factor = count(MARBLE_NODES) / count(nodes);
    let axis_factor = longest(MARBLE_NODES) / longest(nodes);
    let estimate_s = solves as f64 * per_solve * node_factor * axis_factor;
    let report = serde_json::json!({
        "suite": "inverse",
        "sample": "marble block with a diagonal vein of 5x sigma_a and a 1 mm skin of 1.5x sigma_s'",
        "observation": match observation {
            Observation::BackLit => serde_json::json!("back-lit"),
            Observation::FrontLit { margin_mm } => serde_json::json!({ "front-lit": { "margin_mm": margin_mm } }),
        },
        "nodes": nodes,
        "spacing_mm": setup.spacing_mm,
        "cells": (nodes[0] - 1) * (nodes[1] - 1) * (nodes[2] - 1),
        "images": patterns.len(),
        "channels": 3,
        "threads": rayon::current_num_threads(),
        "lambda": LAMBDA,
        "target_misfit_rms": TARGET_MISFIT,
        "iteration_cap_per_channel": cap,
        "coarse_levels": plan.coarse_levels,
        "absorption_coarsening": plan.absorption_coarsening,
        "synthesis_seconds": synthesis_s,
        "held_out_synthesis_seconds": reference_s,
        "methods": methods,
        "forward_solves_default_over_paper": ratio,
        "rendered_lit_face_rms": rendered,
        "goals": {
            "default_seconds_at_most": 180.0,
            "forward_solve_ratio_at_most": 1.0 / 3.0,
            "top_1mm_kappa_rms_at_most": KAPPA_GOAL,
            "top_1mm_mu_rms_at_most": MU_GOAL,
            "held_out_rms_at_most": 0.03,
            "noisy_held_out_rms_at_most": 0.05,
            "rendered_lit_face_rms_at_most": 0.05,
        },
        "marble_estimate": {
            "nodes": MARBLE_NODES,
            "model": "the default run's solves x its seconds per solve x (marble nodes / nodes) x (marble longest axis / longest axis)",
            "seconds": estimate_s,
            "hours": estimate_s / 3600.0,
            "linear_in_nodes_hours": solves as f64 * per_solve * node_factor / 3600.0,
            "paper_hours": MARBLE_PAPER_HOURS,
            "warm_start_bytes": 48 * patterns.len() * count(MARBLE_NODES) as usize,
        },
        "sweep": sweep,
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}

/// The default optimiser on M = n² patterns for n in [`SWEEP_GRIDS`] (the 16-pattern entry is
/// `default`, the comparison's run), and on `images` (the 16 patterns') with [`NOISE_RMS`]
/// Gaussian noise, λ by the discrepancy principle; each judged by `reference`.
fn sweep(
    setup: &Setup,
    truth: &VeinedBlock,
    reference: &Reference,
    default: &Run,
    images: &[Vec<[f64; 3]>],
    plan: Plan,
) -> anyhow::Result<serde_json::Value> {
    let entry = |m: usize, fit: &Acquired, seconds: f64| -> anyhow::Result<serde_json::Value> {
        Ok(serde_json::json!({
            "images": m,
            "seconds": seconds,
            "forward_solves": fit.counts.forward_solves,
            "adjoint_solves": fit.counts.adjoint_solves,
            "misfit_rms": fit.evaluation.misfit_rms(),
            "lambda": fit.lambda,
            "stop": fit.stop.map(|s| format!("{s:?}")),
            "quality": reference.judge(setup, &fit.media)?,
        }))
    };
    let mut patterns_sweep = Vec::new();
    for n in SWEEP_GRIDS {
        if n == 4 {
            patterns_sweep.push(entry(16, &default.fit, default.seconds)?);
            continue;
        }
        let patterns = Pattern::grid_all(n, setup.face_size_mm(), [1.0; 3]);
        let images = synthesize(setup, &patterns, &|p| truth.medium(p), SynthOptions::default())?;
        let t = Instant::now();
        let fit = measure(setup, &patterns, &images, plan, Lambda::Given(LAMBDA), TARGET_MISFIT)?;
        patterns_sweep.push(entry(n * n, &fit, t.elapsed().as_secs_f64())?);
    }
    let patterns = Pattern::grid_all(4, setup.face_size_mm(), [1.0; 3]);
    let noisy = with_noise(images, NOISE_RMS, 99);
    let lambda = Lambda::Discrepancy { noise_rms: NOISE_RMS, tau: NOISE_TAU, start: NOISE_LAMBDA_START };
    let t = Instant::now();
    // The target is the principle's own: each λ's fit stops at τ × the noise.
    let fit = measure(setup, &patterns, &noisy, plan, lambda, NOISE_TAU * NOISE_RMS)?;
    let mut noisy_entry = entry(16, &fit, t.elapsed().as_secs_f64())?;
    noisy_entry["noise_rms"] = serde_json::json!(NOISE_RMS);
    noisy_entry["discrepancy"] = serde_json::json!({ "tau": NOISE_TAU, "first_lambda": NOISE_LAMBDA_START });
    Ok(serde_json::json!({ "patterns": patterns_sweep, "noisy": noisy_entry }))
}
