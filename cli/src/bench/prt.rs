//! `transcut bench prt`: the PRT method (R. Wang et al. 2008) on `--input` (60 mm across,
//! marble, one shadowed sun), at `--prt-samples` (log₂, default 2¹⁶) with the default 3072
//! terms per vertex, through the bake and its session:
//!
//! - the precompute (samples and compressed transfer) and the first light, with the transfer's
//!   bytes, terms, dropped coefficient energy and the process's peak memory;
//! - a relight after turning the sun 5° (q at the samples with shadows, Haar, the product), a
//!   whole-object material edit (marble ↔ marble with twice its σa: projection and K-term sums) and a scale
//!   change, each the median of `--runs`;
//! - the same material edit by the TransCut editor on the same object at `--tets` (its first
//!   value), in the same run: the speed-up of PRT's edit against it;
//! - on the `--backend`'s GPU (`auto`: any adapter, software ones included; skipped with the
//!   reason without one), the session's transfer uploaded ([`GpuPrt`]) and the relight's
//!   product timed against the CPU's on the same irradiance (read back as the method reads it),
//!   with the product and the combine in one submission, and their agreement.

use std::time::Instant;

use anyhow::Context;
use serde::Serialize;
use transcut::edit::{MediumEdit, MediumOp, Region};
use transcut::gpu::{Backend, GpuContext, GpuPrt};
use transcut::light::Light;
use transcut::mesh;
use transcut::methods::prt::radiance_per_exitance;
use transcut::methods::PrtState;
use transcut::optics::Medium;
use transcut::prt::{haar_irradiance, PrtOptions, RdBasis};
use transcut::{BakeOptions, DVec3, Object, Progress, Scene, Session, TransCutOptions};

use super::args::BenchArgs;
use super::stats::{median, ms, peak_rss_mib, relative_error};

/// The sun `degrees` from its starting direction, turned about the vertical.
fn sun(degrees: f64) -> Light {
    let (s, c) = degrees.to_radians().sin_cos();
    Light::Directional { direction: DVec3::new(s, -1.0, -c), irradiance: [3.0; 3], angular_diameter_deg: 0.0 }
}

#[derive(Debug, Serialize)]
struct Timed {
    median_ms: f64,
    runs_ms: Vec<f64>,
}

impl Timed {
    fn new(runs: Vec<f64>) -> Self {
        Self { median_ms: median(runs.clone()), runs_ms: runs }
    }
}

/// The relight's product on a GPU against the CPU's ([`gpu_relight`]).
#[derive(Debug, Serialize)]
struct GpuRelight {
    device: String,
    upload_ms: f64,
    /// The product on the device, read back (as the method's relight does).
    product: Timed,
    /// The product and the combine into Lo in one submission, Lo alone read back.
    product_and_combine: Timed,
    /// `Transfer::apply` on the same irradiance.
    cpu_product: Timed,
    cpu_to_gpu: f64,
    /// Of the device's product against the CPU's (worst channel's relative RMS).
    relative_rms: f64,
}

/// Times the relight's product of `state`'s transfer on `ctx` and on the CPU over `runs`, under
/// the first sun unshadowed at the samples (the timing does not depend on the light).
fn gpu_relight(ctx: &'static GpuContext, state: &PrtState, runs: u32) -> anyhow::Result<GpuRelight> {
    let transfer = &state.transfer;
    let t = Instant::now();
    let device = GpuPrt::new(ctx, transfer)?;
    let upload_ms = ms(t);
    let Light::Directional { direction, irradiance, .. } = sun(0.0) else {
        anyhow::bail!("the bench's sun is a directional light")
    };
    let towards = -direction.normalize();
    let q: Vec<[f64; 3]> = state.samples.normals.iter().map(|n| irradiance.map(|e| e * n.dot(towards).max(0.0))).collect();
    let q_haar = haar_irradiance(&q);
    let (weights, _) = RdBasis::get(state.basis).project_medium(&state.medium);
    let output: Vec<Option<u32>> = (0..transfer.vertices() as u32).map(Some).collect();
    let per_exitance = radiance_per_exitance(state.medium.eta);
    let mut cpu = vec![0.0; transfer.vertices() * transfer.basis_terms() * 3];
    let (mut on_device, mut both, mut on_cpu) = (Vec::new(), Vec::new(), Vec::new());
    let mut product = Vec::new();
    for _ in 0..runs {
        let t = Instant::now();
        product = device.apply(&q_haar)?;
        on_device.push(ms(t));
        let t = Instant::now();
        device.relight(&q_haar, &weights, per_exitance, &output)?;
        both.push(ms(t));
        let t = Instant::now();
        transfer.apply(&q_haar, &mut cpu);
        on_cpu.push(ms(t));
    }
    let triples = |v: &[f64]| v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect::<Vec<_>>();
    let (product_ms, cpu_ms) = (Timed::new(on_device), Timed::new(on_cpu));
    Ok(GpuRelight {
        device: ctx.device_name().to_owned(),
        upload_ms,
        cpu_to_gpu: cpu_ms.median_ms / product_ms.median_ms,
        product: product_ms,
        product_and_combine: Timed::new(both),
        cpu_product: cpu_ms,
        relative_rms: relative_error(&triples(&product), &triples(&cpu)),
    })
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let input = mesh::load(&args.input).with_context(|| format!("loading {}", args.input.display()))?;
    let (lo, hi) = input.bounds();
    let mm_per_unit = 60.0 / (hi - lo).max_element();
    let marble = Medium::preset("marble")?;
    // The edit: marble twice as absorbing (a medium TransCut's mesh resolves as well).
    let absorbing = Medium { sigma_a: marble.sigma_a.map(|s| 2.0 * s), ..marble };
    let scene = Scene { objects: vec![Object::new("bench", input, marble, mm_per_unit)], lights: vec![sun(0.0)] };
    let prt = PrtOptions { samples_log2: args.prt_samples, ..PrtOptions::default() };
    let options = BakeOptions::with_method(prt.clone());

    let start = Instant::now();
    let mut session = Session::bake(&scene, &options, Progress::none())?;
    let bake_ms = ms(start);
    let stats = session.bake_stats(0)?.clone();
    let (mut relight, mut edit, mut scale) = (Vec::new(), Vec::new(), Vec::new());
    for run in 0..args.runs {
        let angle = if run % 2 == 0 { 5.0 } else { 0.0 };
        let t = Instant::now();
        session.relight(&[sun(angle)], Progress::none())?;
        relight.push(ms(t));
        let medium = if run % 2 == 0 { absorbing } else { marble };
        let t = Instant::now();
        session.edit_medium(0, &MediumEdit { region: Region::All, op: MediumOp::Assign(medium) }, Progress::none())?;
        edit.push(ms(t));
        let t = Instant::now();
        session.set_mm_per_unit(0, mm_per_unit * if run % 2 == 0 { 1.1 } else { 1.0 }, Progress::none())?;
        scale.push(ms(t));
    }
    let live = session.prt(0)?.context("the session's PRT state")?;
    let transfer = *live.state().transfer_stats();
    let peak = peak_rss_mib();
    let (gpu, gpu_skipped) = match args.backend {
        Backend::Cpu => (None, Some("backend cpu: the GPU was not asked for".to_owned())),
        Backend::Gpu => (Some(gpu_relight(GpuContext::shared()?, live.state(), args.runs)?), None),
        Backend::Auto => match GpuContext::shared() {
            Ok(ctx) => (Some(gpu_relight(ctx, live.state(), args.runs)?), None),
            Err(e) => (None, Some(e.to_string())),
        },
    };

    // TransCut's editor on the same object: the same whole-object edit.
    let tets = args.tets.first().copied().unwrap_or(200_000);
    let transcut = BakeOptions::with_method(TransCutOptions { tets, ..TransCutOptions::default() });
    let mut editor = Session::bake(&scene, &transcut, Progress::none())?;
    let mut transcut_edit = Vec::new();
    for run in 0..args.runs {
        let medium = if run % 2 == 0 { absorbing } else { marble };
        let t = Instant::now();
        editor.edit_medium(0, &MediumEdit { region: Region::All, op: MediumOp::Assign(medium) }, Progress::none())?;
        transcut_edit.push(ms(t));
    }
    let edit = Timed::new(edit);
    let transcut_edit = Timed::new(transcut_edit);
    let report = serde_json::json!({
        "suite": "prt",
        "input": args.input,
        "threads": rayon::current_num_threads(),
        "samples": 1u64 << args.prt_samples,
        "vertices": stats.vertices,
        "terms_per_vertex": prt.terms_per_vertex,
        "bake_ms": bake_ms,
        "samples_ms": stats.meshing_ms,
        "precompute_ms": stats.assembly_ms,
        "first_light_ms": stats.source_ms,
        "backend": stats.backend,
        "device": stats.device,
        "transfer": transfer,
        "peak_rss_mib": peak,
        "relight_5deg": Timed::new(relight),
        "material_edit": edit,
        "scale_change": Timed::new(scale),
        "transcut_tets": tets,
        "transcut_material_edit": transcut_edit,
        "edit_speedup_vs_transcut": transcut_edit.median_ms / edit.median_ms,
        "gpu_relight": gpu,
        "gpu_relight_skipped": gpu_skipped,
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
