//! `transcut bake`: per-vertex subsurface radiance of a mesh, written with the mesh.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use clap::Args;
use transcut::mesh;
use transcut::render::ToneMap;
use transcut::texture::{self, TextureOptions};
use transcut::{bake_with, diffusion, BakeOptions, Method, ObjectBake, Progress, Scene};

use crate::method_args::{MethodArgs, MethodDefaults};
use crate::object_args::{ObjectArgs, FORMS_HELP};
use crate::progress::StageBar;

/// Arguments of `transcut bake`.
#[derive(Args)]
#[command(after_help = format!("{FORMS_HELP}

Example:
  transcut bake bunny.obj --medium marble --scale 40 --light sun:dir=0,-1,-1,irradiance=3 -o bunny.ply
  transcut bake bunny.obj --scale 40 --method hierarchical-dipole --theta 0.3 -o bunny.npy
  transcut bake bunny.obj --scale 40 --method polygrid --polygrid-resolution 12 -o bunny.ply
  transcut bake head.obj --scale 1 --medium skin1 --uv-texture 2048 -o head_sss.exr"))]
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
    /// .raw (float32 RGB, N×3, little-endian). Rows follow the input's vertex order. With
    /// --uv-texture, the texture: .exr (linear float RGBA) or .png (8-bit sRGB, clamped).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Bake a SIZE×SIZE texture through the input OBJ's UV map (its `vt` and `f v/t`) instead
    /// of per-vertex values: each texel gets the radiance at its surface point (TransCut
    /// samples the solution there, not a blend of the vertex colours), each UV island padded
    /// by --texture-margin texels. Needs -o with .exr or .png.
    #[arg(long, value_name = "SIZE", help_heading = "Texture")]
    pub uv_texture: Option<u32>,
    /// Texels of padding around each UV island of --uv-texture (default SIZE/64, at least 1).
    #[arg(long, value_name = "TEXELS", requires = "uv_texture", help_heading = "Texture")]
    pub texture_margin: Option<u32>,
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
    let texture = args.uv_texture.map(|size| texture_request(args, size)).transpose()?;
    let (scene, input) = args.object.load_scene(&args.input)?;
    let options = BakeOptions { method, threads: args.threads, ..BakeOptions::default() };
    let bar = StageBar::new(args.json);
    let callback = |stage: &str, f: f64| bar.update(stage, f);
    let result = bake_with(&scene, &options, Progress::new(&callback));
    bar.finish();
    let baked = result?;
    let object = &baked.objects[0];
    let texels = match (&texture, &args.output) {
        (Some(request), Some(path)) => Some(write_texture(request, object, path)?),
        (None, Some(path)) => {
            crate::output::write_radiance(path, &input, &object.radiance)
                .with_context(|| format!("writing {}", path.display()))?;
            None
        }
        _ => None,
    };
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
            "texture": texture.map(|t| serde_json::json!({
                "width": t.options.width, "height": t.options.height, "margin": t.options.margin,
                "triangles": t.map.triangles.len(), "covered_texels": texels,
            })),
        });
        crate::output::print_json(&report)?;
        return Ok(());
    }
    let s = &object.stats;
    println!("{}: {} vertices baked by {}", args.input.display(), object.radiance.len(), s.method);
    if let (Some(t), Some(covered)) = (&texture, texels) {
        let o = t.options;
        println!("texture {}×{} ({covered} texels on the surface, margin {})", o.width, o.height, o.margin);
    }
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
        if let Some(p) = &s.polygrid {
            println!(
                "polygrid {} cubes of {:.3} mm, {} cells per edge: {} nodes, {} cells (scaled Jacobian min {:.3}, mean {:.3})",
                p.cubes, p.cube_mm, p.resolution, p.nodes, p.cells, p.quality.min_scaled_jacobian, p.quality.mean_scaled_jacobian
            );
            if let Some(l) = &p.lsq {
                println!(
                    "the paper's stencil: {} nodes, {} with negative weights (most negative {:.2} of the largest), condition \
                     median {:.1}, max {:.1}; {} on P1's weights (no Laplacian from App. B), {} boundary nodes tied to their cells",
                    l.stencil_nodes,
                    l.negative_weight_nodes,
                    l.most_negative_ratio,
                    l.median_condition,
                    l.max_condition,
                    l.p1_nodes,
                    l.cell_linked_boundary_nodes
                );
            }
        }
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

/// A texture bake asked for on the command line: the input's UV map and the image's size.
struct TextureRequest {
    map: mesh::UvMap,
    options: TextureOptions,
}

/// The UV map of the input (an OBJ with texture coordinates) and the options of
/// `--uv-texture size`; refuses an output that is not .exr or .png before the bake.
fn texture_request(args: &BakeArgs, size: u32) -> anyhow::Result<TextureRequest> {
    let Some(out) = &args.output else { bail!("--uv-texture needs -o with the image to write (.exr or .png)") };
    if !matches!(extension(out).as_deref(), Some("exr" | "png")) {
        bail!("--uv-texture writes an image: -o must end in .exr (linear float) or .png (8-bit sRGB), not {}", out.display());
    }
    if extension(&args.input).as_deref() != Some("obj") {
        bail!("--uv-texture reads the UV map of an OBJ file (vt and f v/t), and {} is not one", args.input.display());
    }
    let map = mesh::load_obj_uv_map(&args.input).with_context(|| format!("reading the UV map of {}", args.input.display()))?;
    let options = TextureOptions {
        margin: args.texture_margin.unwrap_or(TextureOptions::square(size).margin),
        ..TextureOptions::square(size)
    };
    Ok(TextureRequest { map, options })
}

/// The lower-case extension of `path`.
fn extension(path: &Path) -> Option<String> {
    path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase())
}

/// Bakes and writes the texture of `request`; returns the texels on the surface.
fn write_texture(request: &TextureRequest, object: &ObjectBake, path: &Path) -> anyhow::Result<usize> {
    let TextureRequest { map, options } = request;
    texture::check(&map.triangles, &map.uvs, object.radiance.len(), options).context("the texture bake")?;
    let mut covered = 0;
    let image = texture::bake_image(&map.triangles, &map.uvs, options, |texels| {
        covered = texels.len();
        let points: Vec<([u32; 3], [f64; 3])> = texels.iter().map(|t| (t.vertices, t.bary)).collect();
        Ok::<_, anyhow::Error>(object.radiance_on_surface(&points))
    })?;
    let written =
        if extension(path).as_deref() == Some("png") { image.save_png_with(path, ToneMap::Clamp) } else { image.save_exr(path) };
    written.with_context(|| format!("writing {}", path.display()))?;
    Ok(covered)
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
