//! `transcut bake`: per-vertex subsurface radiance of a mesh, written with the mesh.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use clap::Args;
use transcut::mesh::{self, TriMesh};
use transcut::{bake_with, diffusion, BakeOptions, Object, ObjectBake, Progress, Scene};

use crate::method_args::{method_help, MethodArgs, MethodDefaults};
use crate::progress::StageBar;
use crate::spec;

/// Arguments of `transcut bake`.
#[derive(Args)]
#[command(after_help = "Light forms (repeat --light for several):
  sun:dir=X,Y,Z,irradiance=E[,angle=DEG]     direction the light travels; E or R,G,B
  point:pos=X,Y,Z,intensity=I                 W/sr; I or R,G,B
  spot:pos=X,Y,Z,dir=X,Y,Z,intensity=I[,angle=DEG][,blend=B]
  env:radiance=R,G,B                          constant sky
  env:file=sky.hdr[,strength=S]               equirectangular .hdr or .exr

Methods: `--method help` lists them (default transcut).

Medium forms:
  marble | skin1 | … (see `--medium help`)    measured presets (Jensen et al. 2001)
  sigma_a=R,G,B:sigma_s=R,G,B:eta=E[:g=G]     mm⁻¹; sigma_s is the reduced σ′s

Example:
  transcut bake bunny.obj --medium marble --scale 40 --light sun:dir=0,-1,-1,irradiance=3 -o bunny.ply")]
pub struct BakeArgs {
    /// Input surface mesh (.obj or .ply).
    pub input: PathBuf,
    /// The medium: a preset name or coefficients (see below).
    #[arg(long, default_value = "marble")]
    pub medium: String,
    /// Millimetres per mesh unit (media are in mm⁻¹, so this sets how translucent the object is).
    #[arg(long, default_value_t = 1.0)]
    pub scale: f64,
    /// A light (repeatable; see below). Without one, a white sky of radiance 1 is used.
    #[arg(long = "light")]
    pub lights: Vec<String>,
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
    #[arg(long)]
    pub export_system: Option<PathBuf>,
    /// Print statistics as JSON on stdout (no progress bar).
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &BakeArgs) -> anyhow::Result<()> {
    if args.medium == "help" {
        println!("presets: {}", transcut::optics::PRESET_NAMES.join(", "));
        return Ok(());
    }
    if args.method.wants_help() {
        print!("{}", method_help());
        return Ok(());
    }
    let method = args.method.method(&MethodDefaults::default())?;
    let input = mesh::load(&args.input).with_context(|| format!("loading {}", args.input.display()))?;
    let medium = spec::medium(&args.medium)?;
    let mut lights = args.lights.iter().map(|s| spec::light(s)).collect::<anyhow::Result<Vec<_>>>()?;
    if lights.is_empty() {
        lights.push(transcut::light::Light::Environment(transcut::light::Environment::Constant([1.0; 3])));
    }
    if !(args.scale.is_finite() && args.scale > 0.0) {
        bail!("--scale must be a positive number of millimetres per unit, got {}", transcut::input::fmt_num(args.scale));
    }
    let name = args.input.file_stem().map_or_else(|| "object".into(), |s| s.to_string_lossy().into_owned());
    let scene = Scene { objects: vec![Object::new(name, input.clone(), medium, args.scale)], lights };
    let options = BakeOptions { method, threads: args.threads, ..BakeOptions::default() };
    let bar = StageBar::new(args.json);
    let callback = |stage: &str, f: f64| bar.update(stage, f);
    let result = bake_with(&scene, &options, Progress::new(&callback));
    bar.finish();
    let baked = result?;
    let object = &baked.objects[0];
    if let Some(path) = &args.output {
        write_radiance(path, &input, &object.radiance).with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(dir) = &args.export_system {
        export_system(dir, &scene, object).with_context(|| format!("exporting the system to {}", dir.display()))?;
    }
    if args.json {
        let report = serde_json::json!({
            "input": args.input.display().to_string(),
            "output": args.output.as_ref().map(|p| p.display().to_string()),
            "total_ms": baked.total_ms,
            "stats": object.stats,
        });
        crate::output::print_json(&report)?;
    } else {
        let s = &object.stats;
        println!("{}: {} vertices baked by {}", args.input.display(), object.radiance.len(), s.method);
        println!("tets {} ({} vertices, {} on the surface)", s.tets, s.vertices, s.boundary_vertices);
        println!(
            "solver iterations {:?}, relative residual {:.1e}",
            s.iterations,
            s.relative_residual.iter().copied().fold(0.0, f64::max)
        );
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
        if s.flipped_faces > 0 {
            println!("note: {} triangles were wound inwards or inconsistently and were reversed", s.flipped_faces);
        }
        if s.clamped_vertices > 0 {
            println!("note: {} of your vertices had a negative diffusion radiance, clamped to 0", s.clamped_vertices);
        }
    }
    Ok(())
}

/// Writes per-user-vertex radiance in the format the extension names.
fn write_radiance(path: &Path, mesh: &TriMesh, radiance: &[[f64; 3]]) -> anyhow::Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("ply" | "npy" | "raw")) {
        bail!("unknown output format (use .ply, .npy or .raw)");
    }
    transcut::output::write_atomically(path, |out| match ext.as_deref() {
        Some("ply") => write_ply(out, mesh, radiance),
        Some("npy") => {
            // NumPy format 1.0: magic, version, little-endian header length, a dict, padding.
            let dict = format!("{{'descr': '<f4', 'fortran_order': False, 'shape': ({}, 3), }}", radiance.len());
            let mut header = dict.into_bytes();
            let total = 10 + header.len() + 1;
            header.extend(std::iter::repeat_n(b' ', (64 - total % 64) % 64));
            header.push(b'\n');
            out.write_all(b"\x93NUMPY\x01\x00")?;
            out.write_all(&(header.len() as u16).to_le_bytes())?;
            out.write_all(&header)?;
            write_f32(out, radiance)
        }
        _ => write_f32(out, radiance),
    })?;
    Ok(())
}

fn write_f32(out: &mut impl Write, radiance: &[[f64; 3]]) -> std::io::Result<()> {
    for l in radiance {
        for c in l {
            out.write_all(&(*c as f32).to_le_bytes())?;
        }
    }
    Ok(())
}

/// The user's mesh as binary PLY: vertices in the user's order with float `red green blue`;
/// faces are the welded triangles written with, for each welded vertex, its first user vertex.
fn write_ply(out: &mut impl Write, mesh: &TriMesh, radiance: &[[f64; 3]]) -> std::io::Result<()> {
    let map = mesh.user_to_internal();
    let mut representative = vec![u32::MAX; mesh.positions().len()];
    for (user, &internal) in map.iter().enumerate().rev() {
        representative[internal as usize] = user as u32;
    }
    writeln!(out, "ply\nformat binary_little_endian 1.0\ncomment libtranscut bake: radiance Lo(x, n), linear RGB")?;
    writeln!(out, "element vertex {}", map.len())?;
    writeln!(out, "property float x\nproperty float y\nproperty float z")?;
    writeln!(out, "property float red\nproperty float green\nproperty float blue")?;
    writeln!(out, "element face {}", mesh.triangles().len())?;
    writeln!(out, "property list uchar uint vertex_indices\nend_header")?;
    for (user, &internal) in map.iter().enumerate() {
        let p = mesh.positions()[internal as usize];
        for c in [p.x, p.y, p.z].into_iter().chain(radiance[user]) {
            out.write_all(&(c as f32).to_le_bytes())?;
        }
    }
    for t in mesh.triangles() {
        out.write_all(&[3u8])?;
        for &v in t {
            out.write_all(&representative[v as usize].to_le_bytes())?;
        }
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
