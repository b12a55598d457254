//! `transcut bench mesh`: the mesher at several sizes, time and quality.

use std::time::Instant;

use anyhow::Context;
use serde::Serialize;
use transcut::mesh;
use transcut::mesher::{tetrahedralize_with, Grading, MesherOptions};
use transcut::Progress;

use super::args::BenchArgs;
use super::stats::median;

#[derive(Serialize)]
struct MeshEntry {
    target_tets: usize,
    grading: Grading,
    tets: usize,
    vertices: usize,
    min_dihedral_deg: f64,
    max_dihedral_deg: f64,
    tets_below_10_deg: usize,
    /// Whether the boundary is a closed 2-manifold (every tet is positively oriented and above
    /// the degeneracy bound by construction: `TetMesh::new` refuses any other).
    closed_manifold_boundary: bool,
    /// Cut points bisected across holes (nonzero: an open input).
    bisected_cuts: usize,
    /// Tets the manifold repair removed, and the vertices that left off the input surface.
    removed_tets: usize,
    off_surface_vertices: usize,
    passes: usize,
    lattice_vertices: usize,
    /// Octrees the final pass built (more than 1: a graded octree refined through a hole).
    octree_rounds: usize,
    cubes_per_level: Vec<usize>,
    spacing: f64,
    hausdorff: f64,
    median_ms: f64,
    runs_ms: Vec<f64>,
    median_stage_ms: transcut::mesher::MesherTimings,
}

pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    let load_start = Instant::now();
    let input = mesh::load(&args.input).with_context(|| format!("loading {}", args.input.display()))?;
    let load_ms = load_start.elapsed().as_secs_f64() * 1e3;
    let mut entries = Vec::new();
    let gradings = args.gradings_or(&[0]);
    for (&target, layers) in args.tets.iter().flat_map(|t| gradings.iter().map(move |&g| (t, g))) {
        let grading = Grading::from_layers(layers);
        let mut runs = Vec::new();
        let mut stages = Vec::new();
        let mut last = None;
        for _ in 0..args.runs {
            let start = Instant::now();
            let t =
                tetrahedralize_with(&input, &MesherOptions { grading, ..MesherOptions::with_tets(target) }, Progress::none())?;
            runs.push(start.elapsed().as_secs_f64() * 1e3);
            stages.push(t.stats.timings);
            last = Some(t);
        }
        let t = last.context("at least one run")?;
        let q = &t.stats.quality;
        let pick = |f: fn(&transcut::mesher::MesherTimings) -> f64| median(stages.iter().map(f).collect());
        entries.push(MeshEntry {
            target_tets: target,
            grading,
            tets: t.stats.tets,
            vertices: t.stats.vertices,
            min_dihedral_deg: q.min_dihedral_deg,
            max_dihedral_deg: q.max_dihedral_deg,
            tets_below_10_deg: q.min_angle_histogram[0],
            closed_manifold_boundary: t.mesh.boundary_topology().is_closed_manifold(),
            bisected_cuts: t.stats.bisected_cuts,
            removed_tets: t.stats.removed_tets,
            off_surface_vertices: t.stats.off_surface_vertices,
            passes: t.stats.passes,
            lattice_vertices: t.stats.lattice_vertices,
            octree_rounds: t.stats.octree_rounds,
            cubes_per_level: t.stats.cubes_per_level.clone(),
            spacing: t.stats.spacing,
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
