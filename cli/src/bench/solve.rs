//! `transcut bench solve`: the diffusion solve on the CPU and on the chosen backend (GPU:
//! upload, assembly on the device, solve with read-back) on one mesh, timed in one process so
//! the ratio is meaningful, with the GPU's device name and its agreement with the CPU solution.
//! On the GPU both Jacobi PCG and multigrid-preconditioned CG (the V-cycle on the device, its
//! hierarchy and Galerkin operators built on the CPU once per mesh, timed apart) are run.

use std::time::Instant;

use anyhow::Context;
use serde::Serialize;
use transcut::diffusion::{assemble, solve, DiffusionSystem, Solution, Solver, SolverKind};
use transcut::gpu::Backend;
use transcut::mesh;
use transcut::mesher::{tetrahedralize, MesherOptions};
use transcut::optics::Medium;
use transcut::sparse::hierarchy::{HierarchyOptions, Multigrid};
use transcut::sparse::SolveOptions;

use super::args::BenchArgs;
use super::stats::median;

#[derive(Serialize)]
struct GpuEntry {
    device: String,
    median_upload_ms: f64,
    median_assembly_ms: f64,
    median_solve_ms: f64,
    median_total_ms: f64,
    iterations: [usize; 3],
    rounds: usize,
    readbacks: usize,
    relative_residual: [f64; 3],
    relative_rms_vs_cpu: [f64; 3],
    speedup_vs_cpu: f64,
}

#[derive(Serialize)]
struct GpuMultigridEntry {
    /// The hierarchy, Galerkin operators, smoothers and coarsest factor on the CPU (once per
    /// mesh and media; not in the device times).
    cpu_setup_ms: f64,
    levels: Vec<usize>,
    /// CPU MG-PCG iterations for comparison with the device's.
    cpu_mg_pcg_iterations: [usize; 3],
    /// Upload (matrix, operators, transfers, coarsest inverse), assembly and MG-PCG solve on the
    /// device; `speedup_vs_cpu` against the CPU's assembly + solve (the bake's SSOR-PCG).
    device: GpuEntry,
}

#[derive(Serialize)]
struct SolveEntry {
    target_tets: usize,
    tets: usize,
    vertices: usize,
    nonzeros: usize,
    cpu_median_assembly_ms: f64,
    cpu_median_solve_ms: f64,
    cpu_iterations: [usize; 3],
    gpu: Option<GpuEntry>,
    gpu_multigrid: Option<GpuMultigridEntry>,
    gpu_fallback: Option<String>,
}

/// An unshadowed sun from (0, 1, 1): q = 3 max(0, n·l) per boundary vertex.
fn light(system: &mut DiffusionSystem) -> anyhow::Result<()> {
    let l = transcut::DVec3::new(0.0, 1.0, 1.0).normalize();
    let q: Vec<[f64; 3]> = system.boundary().normal.iter().map(|n| [3.0 * n.dot(l).max(0.0); 3]).collect();
    system.set_source(&q)?;
    Ok(())
}

fn rel_rms(a: &[[f64; 3]], b: &[[f64; 3]]) -> [f64; 3] {
    [0, 1, 2].map(|c| {
        let num: f64 = a.iter().zip(b).map(|(x, y)| (x[c] - y[c]).powi(2)).sum();
        let den: f64 = b.iter().map(|y| y[c] * y[c]).sum();
        if den > 0.0 {
            (num / den).sqrt()
        } else {
            0.0
        }
    })
}

/// `runs` device solves of `system` (Jacobi PCG, or MG-PCG with `mg`), medians.
fn gpu_entry(
    ctx: &transcut::gpu::GpuContext,
    system: &DiffusionSystem,
    mg: Option<&Multigrid>,
    runs: u32,
    cpu: &Solution,
    cpu_ms: f64,
    options: &SolveOptions<'_>,
) -> anyhow::Result<GpuEntry> {
    let (mut up, mut asm, mut sol, mut total) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut last = None;
    for _ in 0..runs {
        let start = Instant::now();
        let solver = match mg {
            Some(mg) => transcut::gpu::GpuSolver::with_multigrid(ctx, system, mg)?,
            None => transcut::gpu::GpuSolver::new(ctx, system)?,
        };
        let g = solver.solve(system, None, options)?;
        total.push(1e3 * start.elapsed().as_secs_f64());
        up.push(g.stats.upload_ms);
        asm.push(g.stats.assembly_ms);
        sol.push(g.stats.solve_ms);
        last = Some(g);
    }
    let g = last.context("at least one run")?;
    let total_ms = median(total);
    Ok(GpuEntry {
        device: g.stats.device.clone(),
        median_upload_ms: median(up),
        median_assembly_ms: median(asm),
        median_solve_ms: median(sol),
        median_total_ms: total_ms,
        iterations: g.solution.stats.iterations,
        rounds: g.stats.rounds,
        readbacks: g.stats.readbacks,
        relative_residual: g.solution.stats.relative_residual,
        relative_rms_vs_cpu: rel_rms(&g.solution.phi, &cpu.phi),
        speedup_vs_cpu: cpu_ms / total_ms,
    })
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let input = mesh::load(&args.input).with_context(|| format!("loading {}", args.input.display()))?;
    let (lo, hi) = input.bounds();
    let mm_per_unit = 60.0 / (hi - lo).max_element();
    let medium = Medium::preset("marble")?;
    let options = SolveOptions::default();
    let context = match args.backend {
        Backend::Cpu => Err("backend cpu: the GPU was not asked for".to_owned()),
        Backend::Gpu => Ok(transcut::gpu::GpuContext::shared()?),
        Backend::Auto => transcut::gpu::GpuContext::shared().map_err(|e| e.to_string()),
    };
    let mut entries = Vec::new();
    for &target in &args.tets {
        let tet_mesh = tetrahedralize(&input, &MesherOptions::with_tets(target))?;
        let mut assembly = Vec::new();
        let mut solves = Vec::new();
        let mut cpu = None;
        let mut system = None;
        for _ in 0..args.runs {
            let start = Instant::now();
            let mut s = assemble(&tet_mesh, &[medium], mm_per_unit)?;
            assembly.push(1e3 * start.elapsed().as_secs_f64());
            light(&mut s)?;
            let start = Instant::now();
            let sol = solve(&s, None, &options)?;
            solves.push(1e3 * start.elapsed().as_secs_f64());
            cpu = Some(sol);
            system = Some(s);
        }
        let cpu = cpu.context("at least one run")?;
        let system = system.context("at least one run")?;
        let cpu_ms = median(assembly.clone()) + median(solves.clone());
        let (gpu, gpu_multigrid, gpu_fallback) = match &context {
            Err(reason) => (None, None, Some(reason.clone())),
            Ok(ctx) => {
                let jacobi = gpu_entry(ctx, &system, None, args.runs, &cpu, cpu_ms, &options)?;
                let start = Instant::now();
                let multires = Solver::new(&system, SolverKind::MultigridPcg, &HierarchyOptions::default())?;
                let cpu_setup_ms = 1e3 * start.elapsed().as_secs_f64();
                let mg = multires.multigrid().context("a multigrid solver has its multigrid")?;
                let cpu_mg = multires.solve(&system, None, &options)?;
                let device = gpu_entry(ctx, &system, Some(mg), args.runs, &cpu, cpu_ms, &options)?;
                let entry = GpuMultigridEntry {
                    cpu_setup_ms,
                    levels: multires.hierarchy().map(|h| h.vertex_counts()).unwrap_or_default(),
                    cpu_mg_pcg_iterations: cpu_mg.stats.iterations,
                    device,
                };
                (Some(jacobi), Some(entry), None)
            }
        };
        entries.push(SolveEntry {
            target_tets: target,
            tets: tet_mesh.tet_count(),
            vertices: system.vertex_count(),
            nonzeros: system.pattern().nnz(),
            cpu_median_assembly_ms: median(assembly),
            cpu_median_solve_ms: median(solves),
            cpu_iterations: cpu.stats.iterations,
            gpu,
            gpu_multigrid,
            gpu_fallback,
        });
    }
    let report = serde_json::json!({
        "suite": "solve",
        "input": args.input.display().to_string(),
        "mm_per_unit": mm_per_unit,
        "medium": "marble",
        "backend": args.backend,
        "tolerance": options.tolerance,
        "threads": rayon::current_num_threads(),
        "notes": "cpu assembly includes the mesh structure (pattern, incidences), which the GPU path reuses from it; \
                  gpu total = upload + assembly on the device + solve (iterations, read-backs, host f64 residual checks); \
                  gpu_multigrid: MG-PCG with the V-cycle on the device, its CPU setup (hierarchy, Galerkin operators) apart",
        "entries": entries,
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
