//! `transcut bench prt`: the PRT method (R. Wang et al. 2008) on `--input` (60 mm across,
//! marble, one shadowed sun), at `--prt-samples` (log₂, default 2¹⁶) with `--prt-terms` per
//! vertex (default the library's), through the bake and its session:
//!
//! - the precompute (samples and compressed transfer) and the first light, with the transfer's
//!   bytes, terms, dropped coefficient energy and the process's peak memory;
//! - a relight after turning the sun 5° (q at the samples with shadows; then Haar, the product
//!   and the combine: `relight_light_ms` and `relight_product_ms` split it), a
//!   whole-object material edit (marble ↔ marble with twice its σa: projection and K-term sums) and a scale
//!   change, each the median of `--runs`;
//! - the same material edit by the TransCut editor on the same object at `--tets` (its first
//!   value), in the same run: the speed-up of PRT's edit against it;
//! - on the `--backend`'s GPU (`auto`: any adapter, software ones included; skipped with the
//!   reason without one), the session's transfer uploaded ([`GpuPrt`]) and the relight's
//!   product timed against the CPU's on the same irradiance (read back as the method reads it),
//!   with the product and the combine in one submission, and their agreement;
//! - an environment (a 512 × 256 sky with a sun lobe) shadowed by the object: the samples' SH
//!   transfer made once (its shadow rays), then q at every sample for a turned environment
//!   (the coefficients rotated and summed against each sample's vector) against the sampled
//!   path's q (`transmitted_source`, shadow rays at every sample, as every relight paid before),
//!   their agreement, and the session's whole relight under the turned environment.

use std::time::Instant;

use anyhow::Context;
use glam::DMat3;
use serde::Serialize;
use transcut::edit::{MediumEdit, MediumOp, Region};
use transcut::gpu::{Backend, GpuContext, GpuPrt};
use transcut::light::sh::ShRotation;
use transcut::light::{transmitted_source, Environment, EquirectMap, Light, SourceOptions};
use transcut::mesh::{self, TriangleBvh};
use transcut::methods::prt::radiance_per_exitance;
use transcut::methods::PrtState;
use transcut::optics::Medium;
use transcut::prt::env::environment_coefficients;
use transcut::prt::{haar_irradiance, PrtCache, PrtOptions, RdBasis};
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
    let (weights, _) = RdBasis::get(state.basis()).project_medium(&state.medium);
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

/// The bench's environment: a sky brighter at the zenith with a sun lobe, turned `degrees` about
/// the vertical.
fn sky(degrees: f64) -> anyhow::Result<Light> {
    let (s, c) = degrees.to_radians().sin_cos();
    let sun = DVec3::new(0.6 * c, 0.6 * s, 0.8);
    let map = EquirectMap::from_fn(512, 256, 1.0, |d| {
        let lobe = 20.0 * (8.0 * (d.dot(sun) - 1.0)).exp();
        [0.2 + 0.6 * d.z.max(0.0) + lobe, 0.3 + 0.6 * d.z.max(0.0) + 0.9 * lobe, 0.5 + 0.5 * d.z.max(0.0) + 0.7 * lobe]
    })?;
    Ok(Light::Environment(Environment::Equirect(map)))
}

/// The environment through the samples' SH transfer against the sampled path ([`env_relight`]).
#[derive(Debug, Serialize)]
struct EnvRelight {
    order: usize,
    transfer_mib: f64,
    /// Making the transfer: `environment_samples` shadow rays per sample, once.
    transfer_ms: f64,
    /// The sky's projection to the order (once per image).
    projection_ms: f64,
    /// q at every sample for a turned sky: the rotation of its coefficients and one dot
    /// product per sample and channel.
    sh_source: Timed,
    /// q at every sample by the sampled path (`environment_samples` shadow rays per sample).
    sampled_source_ms: f64,
    sampled_to_sh: f64,
    /// Of the SH path's q against the sampled path's (worst channel's relative RMS).
    relative_rms: f64,
}

/// Times q at `state`'s samples under the bench's sky shadowed by the object's own surface (the
/// session's occluder), through the SH transfer (made here, so the session's relights reuse it)
/// and through the sampled path.
fn env_relight(state: &PrtState, runs: u32) -> anyhow::Result<EnvRelight> {
    let source = SourceOptions::default();
    let occluder = TriangleBvh::from_indexed(state.surface.positions(), state.surface.triangles());
    let points: Vec<DVec3> = state.samples.positions.iter().map(|p| *p / state.transfer_mm_per_unit).collect();
    let normals = &state.samples.normals;
    let eta = state.eta();
    let t = Instant::now();
    let (transfer, _) = state.env_sh.transfer(&points, normals, eta, Some(&occluder), &source, &|_| Ok(()))?;
    let transfer_ms = ms(t);
    let order = transfer.order();
    let light = sky(0.0)?;
    let t = Instant::now();
    let coefficients = environment_coefficients(std::slice::from_ref(&light), order)?.context("the sky's coefficients")?;
    let projection_ms = ms(t);
    let mut timed = Vec::new();
    let mut q = Vec::new();
    for run in 0..runs.max(1) {
        let angle = if run % 2 == 0 { 0.0 } else { 15f64.to_radians() };
        let t = Instant::now();
        let turned = ShRotation::new(order, DMat3::from_rotation_z(angle)).apply(&coefficients);
        let q_run = transfer.source(&turned);
        timed.push(ms(t));
        if run == 0 {
            q = q_run;
        }
    }
    let t = Instant::now();
    let sampled = transmitted_source(std::slice::from_ref(&light), &points, normals, eta, Some(&occluder), &source)?;
    let sampled_source_ms = ms(t);
    let sh_source = Timed::new(timed);
    Ok(EnvRelight {
        order,
        transfer_mib: transfer.bytes() as f64 / f64::from(1 << 20),
        transfer_ms,
        projection_ms,
        sampled_to_sh: sampled_source_ms / sh_source.median_ms,
        sh_source,
        sampled_source_ms,
        relative_rms: relative_error(&q, &sampled),
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
    let prt = PrtOptions {
        samples_log2: args.prt_samples,
        terms_per_vertex: args.prt_terms.map_or(PrtOptions::default().terms_per_vertex, |t| t as usize),
        cache: args.prt_cache.clone().map(PrtCache::Folder),
        ..PrtOptions::default()
    };
    let options = BakeOptions::with_method(prt.clone());

    let start = Instant::now();
    let mut session = Session::bake(&scene, &options, Progress::none())?;
    let bake_ms = ms(start);
    let stats = session.bake_stats(0)?.clone();
    let (mut relight, mut edit, mut scale) = (Vec::new(), Vec::new(), Vec::new());
    let (mut relight_light, mut relight_product) = (Vec::new(), Vec::new());
    for run in 0..args.runs {
        let angle = if run % 2 == 0 { 5.0 } else { 0.0 };
        let t = Instant::now();
        let update = session.relight(&[sun(angle)], Progress::none())?;
        relight.push(ms(t));
        relight_light.push(update[0].source_ms);
        relight_product.push(update[0].solve_ms);
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
    let env = env_relight(live.state(), args.runs)?;
    // The session's whole relight under the sky turned in turn (the transfer made above).
    let mut env_session = Vec::new();
    for run in 0..args.runs {
        let light = sky(if run % 2 == 0 { 15.0 } else { 0.0 })?;
        let t = Instant::now();
        session.relight(&[light], Progress::none())?;
        env_session.push(ms(t));
    }

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
        "precompute_loaded": stats.precompute_loaded,
        "first_light_ms": stats.source_ms,
        "backend": stats.backend,
        "device": stats.device,
        "transfer": transfer,
        "peak_rss_mib": peak,
        "relight_5deg": Timed::new(relight),
        "relight_light_ms": median(relight_light),
        "relight_product_ms": median(relight_product),
        "material_edit": edit,
        "scale_change": Timed::new(scale),
        "transcut_tets": tets,
        "transcut_material_edit": transcut_edit,
        "edit_speedup_vs_transcut": transcut_edit.median_ms / edit.median_ms,
        "gpu_relight": gpu,
        "gpu_relight_skipped": gpu_skipped,
        "env_relight": env,
        "env_relight_ms": env.sh_source.median_ms,
        "env_session_relight": Timed::new(env_session),
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
