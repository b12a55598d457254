//! `transcut bench dipole`: the hierarchical dipole (Mertens et al. 2003) on geodesic spheres
//! (R = 25 mm, marble at η = 1.3, one unshadowed sun), at module level
//! ([`transcut::hierarchy::DipoleHierarchy`], the light computed outside the timings):
//!
//! - scaling (`--subdivisions`, 20·4ⁿ triangles): on-the-fly, render (a relight with the links
//!   kept) and incremental after a deformation of the whole mesh by Perlin noise, each the
//!   median of `--runs`, with the split (refit, link, gather, push) and the links;
//! - accuracy against the O(n²) sum ([`reference_quadratic`]) up to `--reference-triangles`
//!   for θ = 0.6, 0.4, 0.3 and the paper's oracle at 0.05/0.05;
//! - the paper's 98,304-leaf case (Table 3) on the nearest icosphere, 81,920 triangles, with
//!   the paper's oracle and θ = 0.4 (design/hierarchical-dipole.md §7);
//! - on the `--backend`'s GPU ([`transcut::gpu::GpuDipole`]) at every size: on-the-fly and a
//!   deformed frame (refit included) with their split, the agreement with the CPU's update of
//!   the same hierarchy, and the speed against it and against the CPU's default cut.

use std::time::Instant;

use anyhow::Context;
use serde::Serialize;
use transcut::gpu::{Backend, GpuContext, GpuDipole, GpuDipoleStats};
use transcut::hierarchy::{reference_quadratic, vertex_normals, DipoleHierarchy, DipoleOptions, DipoleStats, EvalMode, Oracle};
use transcut::light::{transmitted_source, Light, SourceOptions};
use transcut::mesh::{icosphere, TriMesh};
use transcut::optics::Medium;
use transcut::volume::noise::PerlinNoise;
use transcut::DVec3;

use super::args::BenchArgs;
use super::stats::{median, ms, peak_rss_mib};

/// The spheres' radius in mm.
const RADIUS_MM: f64 = 25.0;
/// The refractive index (the design note's sphere material: marble at η = 1.3).
const ETA: f64 = 1.3;
/// The subdivisions of the paper's case: 81,920 triangles, the icosphere nearest its 98,304.
const PAPER_SUBDIVISIONS: u32 = 6;
/// The paper's oracle thresholds (none published; pbrt-v2's and Blender's defaults).
const PAPER_EPS: f64 = 0.05;

/// One mode at one size: medians of the runs.
#[derive(Debug, Clone, Serialize)]
struct ModeEntry {
    median_ms: f64,
    runs_ms: Vec<f64>,
    median_refit_ms: f64,
    median_link_ms: f64,
    median_gather_ms: f64,
    median_push_ms: f64,
    links: usize,
    links_per_triangle: f64,
    near_links: usize,
    form_factors: usize,
}

impl ModeEntry {
    /// The entry of `runs` (wall time of each, its statistics).
    fn new(runs: &[(f64, DipoleStats)]) -> Self {
        let pick = |f: fn(&DipoleStats) -> f64| median(runs.iter().map(|(_, s)| f(s)).collect());
        let last = runs.last().map(|r| r.1).unwrap_or_default();
        Self {
            median_ms: median(runs.iter().map(|r| r.0).collect()),
            runs_ms: runs.iter().map(|r| r.0).collect(),
            median_refit_ms: pick(|s| s.refit_ms),
            median_link_ms: pick(|s| s.link_ms),
            median_gather_ms: pick(|s| s.gather_ms),
            median_push_ms: pick(|s| s.push_ms),
            links: last.links,
            links_per_triangle: last.links as f64 / last.triangles.max(1) as f64,
            near_links: last.near_links,
            form_factors: last.form_factors,
        }
    }
}

/// The three modes on one mesh with one oracle.
#[derive(Debug, Clone, Serialize)]
struct Modes {
    /// Building the cluster trees (median).
    build_ms: f64,
    on_the_fly: ModeEntry,
    /// The first update of render mode, which makes the links (median).
    render_first_update_ms: f64,
    /// Later updates under a sun turned 5°: the links kept.
    render: ModeEntry,
    /// The memory of render mode's stored links, in bytes and per link.
    render_link_bytes: usize,
    render_bytes_per_link: f64,
    /// Each run one more frame of the Perlin deformation (every vertex moved), from the links
    /// of the one before.
    incremental: ModeEntry,
}

#[derive(Serialize)]
struct ScalingEntry {
    subdivisions: u32,
    triangles: usize,
    receivers: usize,
    nodes: usize,
    #[serde(flatten)]
    modes: Modes,
    peak_rss_mib: Option<f64>,
}

/// Growth from one size to the next (4× the triangles).
#[derive(Serialize)]
struct Growth {
    from_triangles: usize,
    to_triangles: usize,
    on_the_fly_ms: f64,
    render_ms: f64,
    incremental_ms: f64,
    links_per_triangle: f64,
}

#[derive(Serialize)]
struct OracleAccuracy {
    oracle: String,
    links: usize,
    links_per_triangle: f64,
    near_links: usize,
    median_ms: f64,
    /// Worst channel of the RMS over the vertices of (B − B_ref)/max B_ref.
    peak_relative_rms: f64,
    /// Worst channel and vertex of |B − B_ref|/max B_ref.
    peak_relative_max: f64,
    /// The same over the vertices the sun lights.
    lit_peak_relative_max: f64,
}

#[derive(Serialize)]
struct AccuracyEntry {
    subdivisions: u32,
    triangles: usize,
    reference_ms: f64,
    oracles: Vec<OracleAccuracy>,
}

#[derive(Serialize)]
struct PaperOracle {
    oracle: String,
    #[serde(flatten)]
    modes: Modes,
}

/// One sun of irradiance 3 along `direction`.
fn sun(direction: DVec3) -> [Light; 1] {
    [Light::Directional { direction, irradiance: [3.0; 3], angular_diameter_deg: 0.0 }]
}

/// q at `positions` (mm) under `lights`, along the area-weighted vertex normals, unshadowed
/// (a sphere does not shadow itself; the deformed one slightly, ignored here).
fn irradiance(lights: &[Light], positions: &[DVec3], triangles: &[[u32; 3]]) -> anyhow::Result<Vec<[f64; 3]>> {
    Ok(transmitted_source(lights, positions, &vertex_normals(positions, triangles), ETA, None, &SourceOptions::default())?)
}

/// The sphere's rest positions displaced along the radius by Perlin noise drifting with
/// `frame` (features about a fifth of the radius, at most about 8% of it).
fn displaced(rest: &[DVec3], noise: &PerlinNoise, frame: usize) -> Vec<DVec3> {
    let drift = DVec3::new(0.0, 0.0, 0.3 * frame as f64);
    rest.iter().map(|&p| p * (1.0 + 0.08 * noise.noise(p * (5.0 / RADIUS_MM) + drift))).collect()
}

fn never_cancel() -> bool {
    true
}

/// The three modes on `mesh` with `oracle`, `runs` each.
fn modes(mesh: &TriMesh, medium: &Medium, oracle: Oracle, runs: usize) -> anyhow::Result<(Modes, DipoleStats)> {
    let dipoles = [0, 1, 2].map(|c| medium.dipole(c));
    let (rest, triangles) = (mesh.positions(), mesh.triangles());
    let build = |mode| -> anyhow::Result<(f64, DipoleHierarchy)> {
        let t = Instant::now();
        let options = DipoleOptions { oracle, mode, ..DipoleOptions::default() };
        let h = DipoleHierarchy::new(rest.to_vec(), triangles.to_vec(), dipoles, options)?;
        Ok((ms(t), h))
    };
    let lit = sun(DVec3::new(0.0, -1.0, -1.0).normalize());
    let q = irradiance(&lit, rest, triangles)?;
    let turned = sun(glam::DMat3::from_rotation_x(5f64.to_radians()) * DVec3::new(0.0, -1.0, -1.0).normalize());
    let q_turned = irradiance(&turned, rest, triangles)?;
    let mut build_ms = Vec::new();

    let (t, mut h) = build(EvalMode::OnTheFly)?;
    build_ms.push(t);
    let mut on_the_fly = Vec::new();
    for _ in 0..runs {
        let t = Instant::now();
        let (_, stats) = h.update(&q, &never_cancel)?;
        on_the_fly.push((ms(t), stats));
    }
    let shape = on_the_fly[0].1;
    drop(h);

    let (t, mut h) = build(EvalMode::Render)?;
    build_ms.push(t);
    let t = Instant::now();
    h.update(&q, &never_cancel)?;
    let first_ms = ms(t);
    let mut render = Vec::new();
    for _ in 0..runs {
        let t = Instant::now();
        let (_, stats) = h.update(&q_turned, &never_cancel)?;
        render.push((ms(t), stats));
    }
    let render_link_bytes = h.link_bytes();
    drop(h);

    let (t, mut h) = build(EvalMode::Incremental { budget: None })?;
    build_ms.push(t);
    h.update(&q, &never_cancel)?;
    let noise = PerlinNoise::new(2003);
    let mut incremental = Vec::new();
    for frame in 1..=runs {
        let positions = displaced(rest, &noise, frame);
        let q = irradiance(&lit, &positions, triangles)?;
        let t = Instant::now();
        h.set_positions(&positions)?;
        let (_, stats) = h.update(&q, &never_cancel)?;
        incremental.push((ms(t), stats));
    }
    let modes = Modes {
        build_ms: median(build_ms),
        on_the_fly: ModeEntry::new(&on_the_fly),
        render_first_update_ms: first_ms,
        render_bytes_per_link: render_link_bytes as f64 / render.last().map_or(0, |r| r.1.links).max(1) as f64,
        render: ModeEntry::new(&render),
        render_link_bytes,
        incremental: ModeEntry::new(&incremental),
    };
    Ok((modes, shape))
}

/// (peak-relative RMS, peak-relative max, the max over `lit` vertices) of `b` against
/// `reference`, each the worst channel.
fn errors(b: &[[f64; 3]], reference: &[[f64; 3]], lit: &[bool]) -> (f64, f64, f64) {
    let (mut rms, mut max, mut lit_max) = (0.0f64, 0.0f64, 0.0f64);
    for c in 0..3 {
        let peak = reference.iter().map(|r| r[c]).fold(0.0, f64::max).max(f64::MIN_POSITIVE);
        let d: Vec<f64> = b.iter().zip(reference).map(|(x, r)| ((x[c] - r[c]) / peak).abs()).collect();
        rms = rms.max((d.iter().map(|x| x * x).sum::<f64>() / d.len().max(1) as f64).sqrt());
        max = max.max(d.iter().copied().fold(0.0, f64::max));
        lit_max = lit_max.max(d.iter().zip(lit).filter(|(_, &l)| l).map(|(x, _)| *x).fold(0.0, f64::max));
    }
    (rms, max, lit_max)
}

fn oracle_name(oracle: Oracle) -> String {
    match oracle {
        Oracle::OpeningAngle { theta } => format!("opening-angle θ {theta}"),
        Oracle::Paper { eps1, eps2 } => format!("paper ε₁ {eps1}, ε₂ {eps2}"),
    }
}

/// The accuracy of the oracles on `mesh` against the O(n²) sum (on-the-fly, `runs` each).
fn accuracy(subdivisions: u32, mesh: &TriMesh, medium: &Medium, runs: usize) -> anyhow::Result<AccuracyEntry> {
    let dipoles = [0, 1, 2].map(|c| medium.dipole(c));
    let (positions, triangles) = (mesh.positions(), mesh.triangles());
    let q = irradiance(&sun(DVec3::new(0.0, -1.0, -1.0).normalize()), positions, triangles)?;
    let lit: Vec<bool> = q.iter().map(|e| e.iter().any(|&x| x > 0.0)).collect();
    let hierarchy = |oracle| {
        let options = DipoleOptions { oracle, ..DipoleOptions::default() };
        DipoleHierarchy::new(positions.to_vec(), triangles.to_vec(), dipoles, options)
    };
    let t = Instant::now();
    let reference = reference_quadratic(&hierarchy(Oracle::default())?, &q)?;
    let reference_ms = ms(t);
    let oracles = [0.6, 0.4, 0.3].map(|theta| Oracle::OpeningAngle { theta });
    let mut entries = Vec::new();
    for oracle in oracles.into_iter().chain([Oracle::Paper { eps1: PAPER_EPS, eps2: PAPER_EPS }]) {
        let mut h = hierarchy(oracle)?;
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..runs {
            let t = Instant::now();
            let result = h.update(&q, &never_cancel)?;
            times.push(ms(t));
            last = Some(result);
        }
        let (b, stats) = last.context("at least one run")?;
        let (rms, max, lit_max) = errors(&b, &reference, &lit);
        entries.push(OracleAccuracy {
            oracle: oracle_name(oracle),
            links: stats.links,
            links_per_triangle: stats.links as f64 / stats.triangles as f64,
            near_links: stats.near_links,
            median_ms: median(times),
            peak_relative_rms: rms,
            peak_relative_max: max,
            lit_peak_relative_max: lit_max,
        });
    }
    Ok(AccuracyEntry { subdivisions, triangles: triangles.len(), reference_ms, oracles: entries })
}

/// Device runs at one size: medians.
#[derive(Serialize)]
struct GpuTimes {
    median_ms: f64,
    runs_ms: Vec<f64>,
    median_refit_ms: f64,
    median_pull_ms: f64,
    median_traverse_ms: f64,
    median_push_ms: f64,
    links: usize,
    near_links: usize,
}

impl GpuTimes {
    fn new(runs: &[(f64, GpuDipoleStats)]) -> Self {
        let pick = |f: fn(&GpuDipoleStats) -> f64| median(runs.iter().map(|(_, s)| f(s)).collect());
        let last = runs.last().map(|r| r.1).unwrap_or_default();
        Self {
            median_ms: median(runs.iter().map(|r| r.0).collect()),
            runs_ms: runs.iter().map(|r| r.0).collect(),
            median_refit_ms: pick(|s| s.refit_ms),
            median_pull_ms: pick(|s| s.pull_ms),
            median_traverse_ms: pick(|s| s.traverse_ms),
            median_push_ms: pick(|s| s.push_ms),
            links: last.links,
            near_links: last.near_links,
        }
    }
}

/// The GPU at one size, θ = 0.4.
#[derive(Serialize)]
struct GpuEntry {
    subdivisions: u32,
    triangles: usize,
    /// Receiver subtrees, one invocation each (the CPU's default cut has 256).
    tasks: usize,
    /// A relight: pull, traversal, push and read-back.
    on_the_fly: GpuTimes,
    /// Each run one more frame of the Perlin deformation: upload, refit and the update.
    deformed_frame: GpuTimes,
    /// The CPU's on-the-fly update of the same hierarchy (the same subtrees), median.
    cpu_same_cut_ms: f64,
    /// The CPU's on-the-fly update with its default cut (the scaling table's).
    cpu_default_ms: f64,
    speedup_vs_cpu_default: f64,
    peak_relative_rms_vs_cpu: f64,
    peak_relative_max_vs_cpu: f64,
}

/// The device runs on `mesh` ([`GpuEntry`]).
fn gpu_entry(
    ctx: &GpuContext,
    subdivisions: u32,
    mesh: &TriMesh,
    medium: &Medium,
    runs: usize,
    cpu_default_ms: f64,
) -> anyhow::Result<GpuEntry> {
    let dipoles = [0, 1, 2].map(|c| medium.dipole(c));
    let (rest, triangles) = (mesh.positions(), mesh.triangles());
    let mut h = DipoleHierarchy::new(rest.to_vec(), triangles.to_vec(), dipoles, DipoleOptions::default())?;
    let mut device = GpuDipole::for_device(ctx, &mut h)?;
    let lit = sun(DVec3::new(0.0, -1.0, -1.0).normalize());
    let q = irradiance(&lit, rest, triangles)?;
    device.update(&q)?; // compiles the kernels
    let mut on_the_fly = Vec::new();
    let mut last = Vec::new();
    for _ in 0..runs {
        let t = Instant::now();
        let (b, stats) = device.update(&q)?;
        on_the_fly.push((ms(t), stats));
        last = b;
    }
    let mut cpu_times = Vec::new();
    let mut cpu = Vec::new();
    for _ in 0..runs {
        let t = Instant::now();
        cpu = h.update(&q, &never_cancel)?.0;
        cpu_times.push(ms(t));
    }
    let lit_vertices = vec![true; cpu.len()];
    let (rms, max, _) = errors(&last, &cpu, &lit_vertices);
    let noise = PerlinNoise::new(2003);
    let mut deformed = Vec::new();
    for frame in 1..=runs {
        let positions = displaced(rest, &noise, frame);
        let q = irradiance(&lit, &positions, triangles)?;
        let t = Instant::now();
        device.set_positions(&positions)?;
        let (_, stats) = device.update(&q)?;
        deformed.push((ms(t), stats));
    }
    let on_the_fly = GpuTimes::new(&on_the_fly);
    Ok(GpuEntry {
        subdivisions,
        triangles: triangles.len(),
        tasks: h.task_roots().len(),
        speedup_vs_cpu_default: cpu_default_ms / on_the_fly.median_ms,
        on_the_fly,
        deformed_frame: GpuTimes::new(&deformed),
        cpu_same_cut_ms: median(cpu_times),
        cpu_default_ms,
        peak_relative_rms_vs_cpu: rms,
        peak_relative_max_vs_cpu: max,
    })
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let medium = Medium { eta: ETA, ..Medium::preset("marble")? };
    let runs = args.runs as usize;
    let mut scaling: Vec<ScalingEntry> = Vec::new();
    for &s in &args.subdivisions {
        let mesh = icosphere(RADIUS_MM, s);
        let (modes, shape) = modes(&mesh, &medium, Oracle::default(), runs)?;
        scaling.push(ScalingEntry {
            subdivisions: s,
            triangles: shape.triangles,
            receivers: shape.receivers,
            nodes: shape.nodes,
            modes,
            peak_rss_mib: peak_rss_mib(),
        });
    }
    let growth: Vec<Growth> = scaling
        .windows(2)
        .map(|w| {
            let (a, b) = (&w[0].modes, &w[1].modes);
            Growth {
                from_triangles: w[0].triangles,
                to_triangles: w[1].triangles,
                on_the_fly_ms: b.on_the_fly.median_ms / a.on_the_fly.median_ms,
                render_ms: b.render.median_ms / a.render.median_ms,
                incremental_ms: b.incremental.median_ms / a.incremental.median_ms,
                links_per_triangle: b.on_the_fly.links_per_triangle / a.on_the_fly.links_per_triangle,
            }
        })
        .collect();

    let context = match args.backend {
        Backend::Cpu => Err("backend cpu: the GPU was not asked for".to_owned()),
        Backend::Gpu => Ok(GpuContext::shared()?),
        Backend::Auto => GpuContext::shared().map_err(|e| e.to_string()),
    };
    let gpu = match &context {
        Err(reason) => serde_json::json!({ "fallback": reason }),
        Ok(ctx) => {
            let mut entries = Vec::new();
            for e in &scaling {
                let mesh = icosphere(RADIUS_MM, e.subdivisions);
                entries.push(gpu_entry(ctx, e.subdivisions, &mesh, &medium, runs, e.modes.on_the_fly.median_ms)?);
            }
            serde_json::json!({
                "device": ctx.device_name(),
                "software": ctx.is_software(),
                "note": "θ = 0.4, f32; the receivers cut into one subtree per 8 points, one invocation each; \
                         wall times include the uploads and read-backs",
                "sizes": entries,
            })
        }
    };

    let mut accuracy_entries = Vec::new();
    for &s in &args.subdivisions {
        let mesh = icosphere(RADIUS_MM, s);
        if mesh.triangles().len() <= args.reference_triangles {
            accuracy_entries.push(accuracy(s, &mesh, &medium, runs)?);
        }
    }

    let paper_case = if args.no_paper_case {
        None
    } else {
        let mesh = icosphere(RADIUS_MM, PAPER_SUBDIVISIONS);
        let paper = Oracle::Paper { eps1: PAPER_EPS, eps2: PAPER_EPS };
        let mut oracles = vec![PaperOracle { oracle: oracle_name(paper), modes: modes(&mesh, &medium, paper, runs)?.0 }];
        let default = match scaling.iter().find(|e| e.subdivisions == PAPER_SUBDIVISIONS) {
            Some(e) => e.modes.clone(),
            None => modes(&mesh, &medium, Oracle::default(), runs)?.0,
        };
        oracles.push(PaperOracle { oracle: oracle_name(Oracle::default()), modes: default });
        Some(serde_json::json!({
            "note": "the paper's finest mesh has 98,304 triangles (Table 3's T = 131,040 counts every level of its subdivision \
                     hierarchy); the nearest icosphere is 20·4^6 = 81,920 triangles, reported as such",
            "triangles": mesh.triangles().len(),
            "receivers": mesh.positions().len(),
            "paper_2003": {"leaves": 98_304, "links": 6_900_000, "on_the_fly_ms": 722, "render_ms": 199, "incremental_ms": 351,
                           "machine": "dual 2.4 GHz Xeon (2002)"},
            "oracles": oracles,
        }))
    };

    let report = serde_json::json!({
        "suite": "dipole",
        "mesh": format!("icosphere, R = {RADIUS_MM} mm (20·4^n triangles); receivers at the vertices"),
        "medium": "marble, eta 1.3",
        "light": "one sun, irradiance 3, from (0, 1, 1), unshadowed; render mode relights with it turned 5°",
        "deformation": "incremental: each run one more frame of Perlin noise along the radius (every vertex moved, up to 8% of R)",
        "runs": runs,
        "threads": rayon::current_num_threads(),
        "scaling": scaling,
        "growth_per_4x": growth,
        "accuracy": accuracy_entries,
        "paper_case": paper_case,
        "gpu": gpu,
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
