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

use std::time::Instant;

use anyhow::{bail, Context};
use transcut::inverse::{
    acquire, synthesize, AcquireOptions, Acquired, Acquisition, Lambda, Method, Observation, Pattern, Setup, StopReason,
    SynthOptions, VeinedBlock,
};
use transcut::Progress;

use super::args::BenchArgs;

/// The paper's marble acquisition: nodes and hours (J. Wang et al. 2008 §6).
const MARBLE_NODES: [usize; 3] = [256, 256, 20];
const MARBLE_PAPER_HOURS: f64 = 11.0;
/// The paper's stopping rule, RMS relative misfit per channel.
const TARGET_MISFIT: f64 = 0.01;

struct Run {
    name: &'static str,
    fit: Acquired,
    seconds: f64,
}

fn measure(
    setup: &Setup,
    patterns: &[Pattern],
    images: &[Vec<[f64; 3]>],
    method: Method,
    cap: usize,
) -> anyhow::Result<Acquired> {
    let mut model = Acquisition::new(setup.clone(), patterns, images.to_vec(), None)?;
    let options = AcquireOptions {
        method,
        lambda: Lambda::Given(1e-4),
        initial: ([0.005; 3], [2.0; 3]),
        homogeneous_iterations: 100,
        max_iterations: cap,
        target_misfit_rms: TARGET_MISFIT,
        ..AcquireOptions::default()
    };
    Ok(acquire(&mut model, &options, &Progress::none())?)
}

fn method_report(r: &Run) -> serde_json::Value {
    let f = &r.fit;
    let iterations = f.history.iter().filter(|h| h.iteration > 0).count();
    let heterogeneous = f.history.iter().filter(|h| h.iteration > 0 && h.stage == "heterogeneous").count();
    let solves = f.counts.forward_solves + f.counts.adjoint_solves;
    serde_json::json!({
        "method": r.name,
        "seconds": r.seconds,
        "iterations": iterations,
        "heterogeneous_iterations": heterogeneous,
        "forward_solves": f.counts.forward_solves,
        "adjoint_solves": f.counts.adjoint_solves,
        "pcg_iterations": f.counts.pcg_iterations,
        "seconds_per_iteration": r.seconds / iterations.max(1) as f64,
        "seconds_per_solve": r.seconds / solves.max(1) as f64,
        "misfit_rms": f.evaluation.misfit_rms(),
        "reached_target": f.stop.iter().all(|s| *s == StopReason::Misfit),
        "stop": f.stop.map(|s| format!("{s:?}")),
    })
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let nodes: [usize; 3] = args.inverse_nodes.as_slice().try_into().context("--inverse-nodes takes three counts")?;
    if nodes.iter().any(|&n| n < 4) {
        bail!("--inverse-nodes {nodes:?}: at least 4 nodes per axis (the 4 × 4 patterns need a face to split)");
    }
    let cap = usize::try_from(args.inverse_iterations)?;
    let setup = Setup { dims: nodes, spacing_mm: 0.5, eta: 1.3, observation: Observation::BackLit };
    let truth = VeinedBlock::marble(&setup);
    let patterns = Pattern::grid_all(4, setup.face_size_mm(), [1.0; 3]);
    let t = Instant::now();
    let images = synthesize(&setup, &patterns, &|p| truth.medium(p), SynthOptions::default())?;
    let synthesis_s = t.elapsed().as_secs_f64();
    let mut runs = Vec::new();
    for (name, method) in [("lbfgs", Method::default()), ("paper", Method::PaperCg)] {
        let t = Instant::now();
        let fit = measure(&setup, &patterns, &images, method, cap)?;
        runs.push(Run { name, fit, seconds: t.elapsed().as_secs_f64() });
    }
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
        "sample": "marble block with a diagonal vein of 5x sigma_a and a 1 mm skin of 1.5x sigma_s', back-lit",
        "nodes": nodes,
        "spacing_mm": setup.spacing_mm,
        "cells": (nodes[0] - 1) * (nodes[1] - 1) * (nodes[2] - 1),
        "images": patterns.len(),
        "channels": 3,
        "threads": rayon::current_num_threads(),
        "lambda": 1e-4,
        "target_misfit_rms": TARGET_MISFIT,
        "iteration_cap_per_channel": cap,
        "synthesis_seconds": synthesis_s,
        "methods": runs.iter().map(method_report).collect::<Vec<_>>(),
        "forward_solves_default_over_paper": ratio,
        "goals": { "default_seconds_at_most": 180.0, "forward_solve_ratio_at_most": 1.0 / 3.0 },
        "marble_estimate": {
            "nodes": MARBLE_NODES,
            "model": "the default run's solves x its seconds per solve x (marble nodes / nodes) x (marble longest axis / longest axis)",
            "seconds": estimate_s,
            "hours": estimate_s / 3600.0,
            "linear_in_nodes_hours": solves as f64 * per_solve * node_factor / 3600.0,
            "paper_hours": MARBLE_PAPER_HOURS,
            "warm_start_bytes": 48 * patterns.len() * count(MARBLE_NODES) as usize,
        },
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
