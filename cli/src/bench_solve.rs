//! `transcut bench solve`: the diffusion solve on the CPU and on the chosen backend (GPU:
//! upload, assembly on the device, solve with read-back) on one mesh, timed in one process so
//! the ratio is meaningful, with the GPU's device name and its agreement with the CPU solution.

use std::time::Instant;

use anyhow::Context;
use serde::Serialize;
use transcut::diffusion::{assemble, solve, DiffusionSystem};
use transcut::gpu::Backend;
use transcut::mesh;
use transcut::mesher::{tetrahedralize, MesherOptions};
use transcut::optics::Medium;
use transcut::sparse::SolveOptions;

use crate::bench::{BenchArgs, median};

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
struct SolveEntry {
    target_tets: usize,
    tets: usize,
    vertices: usize,
    nonzeros: usize,
    cpu_median_assembly_ms: f64,
    cpu_median_solve_ms: f64,
    cpu_iterations: [usize; 3],
    gpu: Option<GpuEntry>,
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
        let (gpu, gpu_fallback) = match &context {
            Err(reason) => (None, Some(reason.clone())),
            Ok(ctx) => {
                let (mut up, mut asm, mut sol, mut total) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
                let mut last = None;
                for _ in 0..args.runs {
                    let start = Instant::now();
                    let g = transcut::gpu::solve(ctx, &system, None, &options)?;
                    total.push(1e3 * start.elapsed().as_secs_f64());
                    up.push(g.stats.upload_ms);
                    asm.push(g.stats.assembly_ms);
                    sol.push(g.stats.solve_ms);
                    last = Some(g);
                }
                let g = last.context("at least one run")?;
                let total_ms = median(total.clone());
                (
                    Some(GpuEntry {
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
                    }),
                    None,
                )
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
                  gpu total = upload + assembly on the device + solve (iterations, read-backs, host f64 residual checks)",
        "entries": entries,
    });
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
