//! `transcut mesh`: surface → tetrahedra, with statistics.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use transcut::mesh;
use transcut::mesher::{tetrahedralize_with, Grading, MeshSize, MesherOptions, MesherStats};
use transcut::Progress;

use crate::progress::StageBar;

/// Arguments of `transcut mesh`.
#[derive(Args)]
#[command(after_help = "Example:\n  transcut mesh assets/meshes/stanford-bunny.obj --tets 500000 -o bunny.vtk")]
pub struct MeshArgs {
    /// Input surface mesh (.obj or .ply). Open scans and overlapping shells are fine: inside is
    /// decided by the generalised winding number.
    pub input: PathBuf,
    /// Target number of tetrahedra (the result lands within about ±10%).
    #[arg(long, default_value_t = 200_000, value_parser = clap::value_parser!(u64).range(1..=50_000_000), conflicts_with = "spacing")]
    pub tets: u64,
    /// Lattice spacing in the mesh's units instead of a tet count (interior tets have volume
    /// spacing³/12). With --grading it is the spacing at the surface.
    #[arg(long, visible_alias = "surface-spacing")]
    pub spacing: Option<f64>,
    /// Grade the mesh: the finest spacing near the surface, cube sizes doubling inwards after
    /// this many cubes of each size (1 grades fastest). 0 keeps one spacing everywhere.
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=64))]
    pub grading: u32,
    /// Write the tets as a legacy-VTK unstructured grid (binary; see --ascii).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Write the VTK file as ASCII text instead of binary.
    #[arg(long)]
    pub ascii: bool,
    /// Print the statistics as JSON on stdout (no progress bar).
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &MeshArgs) -> anyhow::Result<()> {
    let input = mesh::load(&args.input).with_context(|| format!("loading {}", args.input.display()))?;
    let size = match args.spacing {
        Some(h) => MeshSize::Spacing(h),
        None => MeshSize::Tets(args.tets as usize),
    };
    let options = MesherOptions { size, grading: Grading::from_layers(args.grading), ..MesherOptions::default() };
    let bar = StageBar::new(args.json);
    let callback = |stage: &str, f: f64| bar.update(stage, f);
    let result = tetrahedralize_with(&input, &options, Progress::new(&callback));
    bar.finish();
    let meshed = result.with_context(|| format!("meshing {}", args.input.display()))?;
    if let Some(path) = &args.output {
        transcut::output::write_atomically(path, |out| mesh::write_vtk(&meshed.mesh, out, !args.ascii))
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if args.json {
        let report = serde_json::json!({
            "input": args.input.display().to_string(),
            "input_vertices": input.user_vertex_count(),
            "input_triangles": input.triangles().len(),
            "output": args.output.as_ref().map(|p| p.display().to_string()),
            "stats": meshed.stats,
        });
        crate::output::print_json(&report)?;
    } else {
        print_human(&args.input, &input, &meshed.stats, args.output.as_ref());
    }
    Ok(())
}

fn print_human(path: &std::path::Path, input: &mesh::TriMesh, s: &MesherStats, output: Option<&PathBuf>) {
    println!("{}: {} vertices, {} triangles", path.display(), input.user_vertex_count(), input.triangles().len());
    println!("tets        {:>10}   vertices {:>9}   boundary triangles {:>9}", s.tets, s.vertices, s.boundary_faces);
    println!("spacing     {:>10.4e}   passes {:>11}", s.spacing, s.passes);
    if s.cubes_per_level.len() > 1 {
        println!("cubes of side 2^k·spacing, k = 0, 1, …: {:?}", s.cubes_per_level);
    }
    println!("dihedral    min {:>6.2}°   max {:>6.2}°", s.quality.min_dihedral_deg, s.quality.max_dihedral_deg);
    println!("  per-tet minimum angle (10° bins from 0°):   {:?}", s.quality.min_angle_histogram);
    println!("  per-tet maximum angle (10° bins from 90°):  {:?}", s.quality.max_angle_histogram);
    println!(
        "hausdorff   {:.4e} (boundary→input {:.4e}, input→boundary {:.4e})",
        s.hausdorff.max, s.hausdorff.boundary_to_input, s.hausdorff.input_to_boundary
    );
    if s.bisected_cuts + s.split_vertices + s.removed_tets > 0 {
        println!(
            "repairs     {} cuts across holes, {} pinched vertices split, {} tets removed",
            s.bisected_cuts, s.split_vertices, s.removed_tets
        );
    }
    let t = &s.timings;
    println!(
        "time        {:.0} ms (winding tree {:.0}, stuffing {:.0}, topology {:.0}, mapping {:.0})",
        t.total_ms, t.winding_tree_ms, t.stuffing_ms, t.topology_ms, t.mapping_ms
    );
    if let Some(o) = output {
        println!("wrote       {}", o.display());
    }
}
