//! `transcut bake`: per-vertex subsurface radiance of a mesh, written with the mesh.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use clap::Args;
use transcut::mesh;
use transcut::{bake_with, diffusion, BakeOptions, Method, ObjectBake, Progress, Scene};

use crate::method_args::{MethodArgs, MethodDefaults};
use crate::object_args::{ObjectArgs, FORMS_HELP};
use crate::progress::StageBar;

/// Arguments of `transcut bake`.
#[derive(Args)]
#[command(after_help = format!("{FORMS_HELP}

Example:
  transcut bake bunny.obj --medium marble --scale 40 --light sun:dir=0,-1,-1,irradiance=3 -o bunny.ply
  transcut bake bunny.obj --scale 40 --method hierarchical-dipole --theta 0.3 -o bunny.npy"))]
pub struct BakeArgs {
    /// Input surface mesh (.obj or .ply).
    pub input: PathBuf,
    #[command(flatten)]
    pub object: ObjectArgs,
    #[command(flatten)]
    pub method: MethodArgs,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Output: .ply (the mesh with float red, green, blue per vertex), .npy (float32 N×3) or
    /// .raw (float32 RGB, N×3, little-endian). Rows follow the input's vertex order.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// transcut: write the diffusion system (M per channel, b) as Matrix Market files in this
    /// folder, so any external solver can be timed on exactly the same system.
    #[arg(long, help_heading = "TransCut options")]
    pub export_system: Option<PathBuf>,
    /// Print statistics as JSON on stdout (no progress bar).
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &BakeArgs) -> anyhow::Result<()> {
    if args.object.print_help(&args.method) {
        return Ok(());
    }
    let method = args.method.method(&MethodDefaults::default())?;
    if args.export_system.is_some() && !matches!(method, Method::TransCut(_)) {
        bail!("--export-system writes TransCut's system, an option of the transcut method, not of {}", method.name());
    }
    let (scene, input) = args.object.load_scene(&args.input)?;
    let options = BakeOptions { method, threads: args.threads, ..BakeOptions::default() };
    let bar = StageBar::new(args.json);
    let callback = |stage: &str, f: f64| bar.update(stage, f);
    let result = bake_with(&scene, &options, Progress::new(&callback));
    bar.finish();
    let baked = result?;
    let object = &baked.objects[0];
    if let Some(path) = &args.output {
        crate::output::write_radiance(path, &input, &object.radiance).with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(dir) = &args.export_system {
        export_system(dir, &scene, object).with_context(|| format!("exporting the system to {}", dir.display()))?;
    }
    let dipole = object.dipole().map(|d| d.stats);
    if args.json {
        let report = serde_json::json!({
            "input": args.input.display().to_string(),
            "output": args.output.as_ref().map(|p| p.display().to_string()),
            "total_ms": baked.total_ms,
            "stats": object.stats,
            "dipole": dipole,
        });
        crate::output::print_json(&report)?;
        return Ok(());
    }
    let s = &object.stats;
    println!("{}: {} vertices baked by {}", args.input.display(), object.radiance.len(), s.method);
    if let Some(d) = dipole {
        println!(
            "{} triangles, {} receivers, {} links ({} near, {:.1} per triangle)",
            d.triangles,
            d.receivers,
            d.links,
            d.near_links,
            d.links as f64 / d.triangles.max(1) as f64
        );
        println!(
            "time {:.0} ms (trees {:.0}, light {:.0}, links {:.0}, gather {:.0}, push {:.0})",
            baked.total_ms, s.meshing_ms, s.source_ms, d.link_ms, d.gather_ms, d.push_ms
        );
    } else {
        println!("tets {} ({} vertices, {} on the surface)", s.tets, s.vertices, s.boundary_vertices);
        let residual = s.relative_residual.iter().copied().fold(0.0, f64::max);
        println!("solver iterations {:?}, relative residual {residual:.1e}", s.iterations);
        println!(
            "time {:.0} ms (mesh {:.0}, assembly {:.0}, light {:.0}, solve {:.0})",
            baked.total_ms, s.meshing_ms, s.assembly_ms, s.source_ms, s.solve_ms
        );
        match (&s.device, &s.backend_fallback) {
            (Some(device), _) => println!("solved on the GPU: {device}"),
            (None, Some(why)) => println!("solved on the CPU ({why})"),
            (None, None) => println!("solved on the CPU"),
        }
        println!(
            "resolution σtr·h {:.3} {:.3} {:.3} (R G B; the method refuses more than it can resolve)",
            s.resolution[0], s.resolution[1], s.resolution[2]
        );
    }
    if s.flipped_faces > 0 {
        println!("note: {} triangles were wound inwards or inconsistently and were reversed", s.flipped_faces);
    }
    if s.clamped_vertices > 0 {
        println!("note: {} of your vertices had a negative diffusion radiance, clamped to 0", s.clamped_vertices);
    }
    Ok(())
}

/// Writes `M_red.mtx`, `M_green.mtx`, `M_blue.mtx` (coordinate, symmetric general) and `b.mtx`
/// (array, n × 3) of the object's TransCut system.
fn export_system(dir: &Path, scene: &Scene, object: &ObjectBake) -> anyhow::Result<()> {
    let Some(state) = object.transcut() else {
        bail!("--export-system writes TransCut's system; the {} method has none", object.method())
    };
    std::fs::create_dir_all(dir)?;
    let o = &scene.objects[0];
    let mut system = diffusion::assemble(&state.tet_mesh, &state.media, o.mm_per_unit)?;
    let boundary = system.boundary();
    let points: Vec<_> = boundary.ids.iter().map(|&v| state.tet_mesh.positions()[v as usize]).collect();
    let surface = o.world_surface()?;
    let bvh = mesh::TriangleBvh::from_indexed(surface.positions(), surface.triangles());
    let q = transcut::light::transmitted_source(
        &scene.lights,
        &points,
        &boundary.normal,
        system.boundary_terms().eta,
        Some(&bvh),
        &transcut::light::SourceOptions::default(),
    )?;
    system.set_source(&q)?;
    for (c, name) in ["red", "green", "blue"].iter().enumerate() {
        system.matrix().write_matrix_market(dir.join(format!("M_{name}.mtx")), c)?;
    }
    transcut::sparse::write_vector3_matrix_market(dir.join("b.mtx"), system.rhs())?;
    Ok(())
}
