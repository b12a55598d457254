//! `transcut bench`: benchmarks with JSON output. Times are medians of several runs measured in
//! one process, so ratios between entries are meaningful on a noisy machine.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use clap::{Args, ValueEnum};
use serde::Serialize;
use transcut::mesh;
use transcut::mesher::{tetrahedralize_with, MesherOptions};
use transcut::Progress;

/// Which benchmark to run.
#[derive(Clone, Copy, ValueEnum)]
pub enum Suite {
    /// Tetrahedralise a mesh at several sizes: time and quality.
    Mesh,
    /// Bake a mesh (60 mm across, marble, one sun) at several sizes: meshing, assembly, light,
    /// solve (iterations), total and peak memory.
    Bake,
    /// The diffusion solve alone (60 mm, marble, one sun) on the CPU and on the `--backend`
    /// (GPU: upload, assembly, solve with read-back), their agreement and the device name.
    Solve,
    /// TransCut Fig. 7: relative error against time for the single-level solvers (Jacobi PCG,
    /// SSOR-PCG), the multiresolution cascade and multigrid-preconditioned CG (on the paper's
    /// hierarchy and on a smoothed aggregation), and the warm start after moving the sun 5°.
    Multires,
    /// Interactive edits (TransCut §5) on the bunny: the cold bake, a relight after moving the
    /// sun 5° (warm start against a cold solve of the same system), a paint stroke, and the
    /// Fig. 7 curve with its time-to-1% ratio.
    Edit,
}

/// Arguments of `transcut bench`.
#[derive(Args)]
pub struct BenchArgs {
    /// The benchmark suite.
    #[arg(value_enum, default_value = "mesh")]
    pub suite: Suite,
    /// Input surface mesh (default: the shared Stanford bunny).
    #[arg(long, default_value = "assets/meshes/stanford-bunny.obj")]
    pub input: PathBuf,
    /// Target tet counts, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [100_000usize, 500_000, 1_000_000])]
    pub tets: Vec<usize>,
    /// Runs per size; the median is reported.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=100))]
    pub runs: u32,
    /// Backend of the `solve` suite: cpu, gpu (fails without an adapter) or auto.
    #[arg(long, default_value = "auto")]
    pub backend: transcut::gpu::Backend,
    /// Solver of the `edit` suite's updates (default: the editor's own, sa-pcg).
    #[arg(long, value_enum)]
    pub method: Option<SolverMethod>,
}

/// A diffusion solver, as `--method` names it.
#[derive(Clone, Copy, ValueEnum)]
pub enum SolverMethod {
    /// Single-level Jacobi PCG.
    Pcg,
    /// Single-level SSOR-PCG.
    SsorPcg,
    /// The TransCut §4.2 cascade.
    Cascade,
    /// CG preconditioned by a V-cycle on the TransCut hierarchy.
    MgPcg,
    /// CG preconditioned by a V-cycle on a smoothed-aggregation hierarchy.
    SaPcg,
}

impl From<SolverMethod> for transcut::diffusion::Method {
    fn from(m: SolverMethod) -> Self {
        match m {
            SolverMethod::Pcg => Self::Pcg,
            SolverMethod::SsorPcg => Self::SsorPcg,
            SolverMethod::Cascade => Self::Cascade,
            SolverMethod::MgPcg => Self::MultigridPcg,
            SolverMethod::SaPcg => Self::AggregationPcg,
        }
    }
}

#[derive(Serialize)]
struct MeshEntry {
    target_tets: usize,
    tets: usize,
    vertices: usize,
    min_dihedral_deg: f64,
    max_dihedral_deg: f64,
    tets_below_10_deg: usize,
    passes: usize,
    lattice_vertices: usize,
    hausdorff: f64,
    median_ms: f64,
    runs_ms: Vec<f64>,
    median_stage_ms: transcut::mesher::MesherTimings,
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    match args.suite {
        Suite::Mesh => bench_mesh(args),
        Suite::Bake => bench_bake(args),
        Suite::Solve => crate::bench_solve::run(args),
        Suite::Multires => crate::bench_multires::run(args),
        Suite::Edit => crate::bench_edit::run(args),
    }
}

pub(crate) fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn bench_mesh(args: &BenchArgs) -> anyhow::Result<()> {
    let load_start = Instant::now();
    let input = mesh::load(&args.input).with_context(|| format!("loading {}", args.input.display()))?;
    let load_ms = load_start.elapsed().as_secs_f64() * 1e3;
    let mut entries = Vec::new();
    for &target in &args.tets {
        let mut runs = Vec::new();
        let mut stages = Vec::new();
        let mut last = None;
        for _ in 0..args.runs {
            let start = Instant::now();
            let t = tetrahedralize_with(&input, &MesherOptions::with_tets(target), Progress::none())?;
            runs.push(start.elapsed().as_secs_f64() * 1e3);
            stages.push(t.stats.timings);
            last = Some(t);
        }
        let t = last.context("at least one run")?;
        let q = &t.stats.quality;
        let pick = |f: fn(&transcut::mesher::MesherTimings) -> f64| median(stages.iter().map(f).collect());
        entries.push(MeshEntry {
            target_tets: target,
            tets: t.stats.tets,
            vertices: t.stats.vertices,
            min_dihedral_deg: q.min_dihedral_deg,
            max_dihedral_deg: q.max_dihedral_deg,
            tets_below_10_deg: q.min_angle_histogram[0],
            passes: t.stats.passes,
            lattice_vertices: t.stats.lattice_vertices,
            hausdorff: t.stats.hausdorff.max,
            median_ms: median(runs.clone()),
            runs_ms: runs,
            median_stage_ms: transcut::mesher::MesherTimings {
                winding_tree_ms: pick(|s| s.winding_tree_ms),
                stuffing_ms: pick(|s| s.stuffing_ms),
                topology_ms: pick(|s| s.topology_ms),
                mapping_ms: pick(|s| s.mapping_ms),
                total_ms: pick(|s| s.total_ms),
                final_pass: transcut::mesher::PhaseTimings {
                    labels_ms: pick(|s| s.final_pass.labels_ms),
                    cuts_ms: pick(|s| s.final_pass.cuts_ms),
                    warp_ms: pick(|s| s.final_pass.warp_ms),
                    stencils_ms: pick(|s| s.final_pass.stencils_ms),
                },
            },
        });
    }
    let report = serde_json::json!({
        "suite": "mesh",
        "input": args.input.display().to_string(),
        "load_ms": load_ms,
        "threads": rayon::current_num_threads(),
        "entries": entries,
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}

#[derive(Serialize)]
struct BakeEntry {
    target_tets: usize,
    tets: usize,
    vertices: usize,
    iterations: [usize; 3],
    median_ms: f64,
    runs_ms: Vec<f64>,
    median_meshing_ms: f64,
    median_assembly_ms: f64,
    median_source_ms: f64,
    median_solve_ms: f64,
    peak_rss_mib: Option<f64>,
}

/// Peak resident memory of this process so far (Linux `VmHWM`), MiB.
fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib / 1024.0)
}

fn bench_bake(args: &BenchArgs) -> anyhow::Result<()> {
    use transcut::light::Light;
    use transcut::optics::Medium;
    use transcut::scene::{bake, BakeOptions, Object, Scene};

    let input = mesh::load(&args.input).with_context(|| format!("loading {}", args.input.display()))?;
    let (lo, hi) = input.bounds();
    let mm_per_unit = 60.0 / (hi - lo).max_element();
    let scene = Scene {
        objects: vec![Object::new("bench", input, Medium::preset("marble")?, mm_per_unit)],
        lights: vec![Light::Directional {
            direction: transcut::DVec3::new(0.0, -1.0, -1.0),
            irradiance: [3.0; 3],
            angular_diameter_deg: 0.0,
        }],
    };
    let mut entries = Vec::new();
    for &target in &args.tets {
        let mut runs = Vec::new();
        let mut stats = Vec::new();
        for _ in 0..args.runs {
            let start = Instant::now();
            let b = bake(&scene, &BakeOptions { tets: target, ..BakeOptions::default() })?;
            runs.push(start.elapsed().as_secs_f64() * 1e3);
            stats.push(b.objects[0].stats.clone());
        }
        let last = stats.last().context("at least one run")?.clone();
        let pick = |f: fn(&transcut::scene::ObjectStats) -> f64| median(stats.iter().map(f).collect());
        entries.push(BakeEntry {
            target_tets: target,
            tets: last.tets,
            vertices: last.vertices,
            iterations: last.iterations,
            median_ms: median(runs.clone()),
            runs_ms: runs,
            median_meshing_ms: pick(|s| s.meshing_ms),
            median_assembly_ms: pick(|s| s.assembly_ms),
            median_source_ms: pick(|s| s.source_ms),
            median_solve_ms: pick(|s| s.solve_ms),
            peak_rss_mib: peak_rss_mib(),
        });
    }
    let report = serde_json::json!({
        "suite": "bake",
        "input": args.input.display().to_string(),
        "mm_per_unit": mm_per_unit,
        "medium": "marble",
        "threads": rayon::current_num_threads(),
        "entries": entries,
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
