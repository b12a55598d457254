//! `transcut render`: bake a TOML scene (see [`crate::scene_file`]) and render it to PNG or EXR.
//!
//! Every object is baked (tetrahedralised, lit, solved), the scene's `[[edit]]` list applied in
//! order ([`crate::edit_apply`]: relight, medium edits, paint, cuts, fracture, moved and
//! recombined pieces, each warm-started), then every piece of every object drawn by the core's rasteriser
//! (`transcut::render`) with its per-vertex radiance Lo(x, n) seen through the Fresnel boundary,
//! GGX highlights of the sun, point and spot lights, the mean radiance of the environment
//! reflected, and an optional grey ground plane. A radiosity bake's translucent objects are
//! drawn on the user's mesh as any translucent object, its opaque ones on their refined patch
//! surface (which carries their colour bleeding), both with the session's radiance (after the
//! edits); its ground plane is a diffuse object of the scene ([`crate::scene_file`]). `.png` is
//! tone-mapped (ACES) sRGB with alpha = object coverage; `.exr` is linear 32-bit float RGBA.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{bail, Context};
use clap::Args;
use transcut::light::{Environment, Light};
use transcut::mesh::TriMesh;
use transcut::render::{render, Camera, GroundPlane, RenderObject, RenderOptions, RenderScene, SamplePattern, SpecularLight};
use transcut::{bake_with, BakeOptions, DVec3, Diffuse, MediumSource, Method, Object, Progress, Scene, Session, Sides};

use crate::method_args::{method_help, MethodArgs};
use crate::progress::StageBar;
use crate::scene_file::{self, apply, schema::CameraSpec};

/// Arguments of `transcut render`.
#[derive(Args)]
#[command(after_help = "The scene file format is described in README.md (\"Scene files\").

Example:
  transcut render examples/bunny_marble.toml -o bunny.png")]
pub struct RenderArgs {
    /// The scene file (.toml).
    pub scene: PathBuf,
    /// Output image: .png (tone-mapped sRGB) or .exr (linear float).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Override the camera's image width.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub width: Option<u32>,
    /// Override the camera's image height.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=16384))]
    pub height: Option<u32>,
    /// The method and its options (they override the scene file's [bake] table).
    #[command(flatten)]
    pub method: MethodArgs,
    /// Worker threads for the bake and the edits (0 = all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Print statistics as JSON on stdout (no progress bar).
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    if args.method.wants_help() {
        print!("{}", method_help());
        return Ok(());
    }
    let ext = args.output.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    if ext != "png" && ext != "exr" {
        bail!("output {}: the extension must be .png or .exr", args.output.display());
    }
    let start = Instant::now();
    let loaded = scene_file::load(&args.scene)?;
    let file = &loaded.file;
    let mut camera_spec = file.camera.clone();
    if let Some(w) = args.width {
        camera_spec.width = w;
    }
    if let Some(h) = args.height {
        camera_spec.height = h;
    }
    let in_file = || format!("scene file {}", args.scene.display());
    let mut defaults = file.bake.method_defaults().with_context(in_file)?;
    // A relative cache folder is the scene file's, as its meshes are.
    if let Some(cache) = &mut defaults.prt_cache {
        if cache.is_relative() {
            *cache = args.scene.parent().unwrap_or(std::path::Path::new("")).join(&*cache);
        }
    }
    let method = args.method.method(&defaults).with_context(in_file)?;
    let options = BakeOptions { method, threads: args.threads, ..BakeOptions::default() };
    let mut scene = Scene { objects: loaded.objects, lights: loaded.lights };
    let up = DVec3::from(camera_spec.up);
    // Radiosity makes the ground a diffuse object of the scene, lit and shadowed with it.
    let file_objects = scene.objects.len();
    let radiosity_ground = matches!(options.method, Method::Radiosity(_)) && file.render.ground;
    if radiosity_ground {
        let ground = ground_object(&scene.objects, up).with_context(in_file)?;
        scene.objects.push(ground);
    }
    let load_ms = start.elapsed().as_secs_f64() * 1e3;

    let bar = StageBar::new(args.json);
    let callback = |stage: &str, f: f64| bar.update(stage, f);
    let result = bake_with(&scene, &options, Progress::new(&callback));
    bar.finish();
    let baked = result.with_context(|| format!("baking {}", args.scene.display()))?;
    let (bake_ms, bake_stats): (f64, Vec<_>) = (baked.total_ms, baked.objects.iter().map(|o| o.stats.clone()).collect());
    let mut session = Session::new(&scene, baked, &options);

    // The file's camera (before --width/--height): cut strokes are in its pixels.
    let file_camera = camera(&file.camera);
    let names: Vec<String> = scene.objects.iter().map(|o| o.name.clone()).collect();
    let t_edit = Instant::now();
    let edit_bar = StageBar::new(args.json);
    let edit_progress = |stage: &str, f: f64| edit_bar.update(stage, f);
    let reports = apply::apply(&loaded.edits, &mut session, &names, &file_camera, &edit_progress, |r| {
        if !args.json {
            let s = &r.stats;
            edit_bar.suspend(|| {
                eprintln!(
                    "edit {} ({}) {}: {} piece{}, iterations {:?}, {:.0} ms",
                    r.edit,
                    r.kind,
                    r.object,
                    r.pieces,
                    if r.pieces == 1 { "" } else { "s" },
                    s.iterations,
                    s.total_ms
                );
            });
        }
    });
    edit_bar.finish();
    let reports = reports.with_context(|| format!("editing {}", args.scene.display()))?;
    let edit_ms = t_edit.elapsed().as_secs_f64() * 1e3;

    let t_render = Instant::now();
    // World-space meshes over their welded vertices with the radiance of those vertices, and
    // the object's η: an edited object's pieces, else the baked surface.
    let radiosity = session.radiosity();
    let mut meshes: Vec<(TriMesh, Vec<[f64; 3]>, f64)> = Vec::new();
    // The meshes before the ground's: the objects' bounds place the highlights' lights.
    let mut object_meshes = 0;
    for (i, object) in scene.objects.iter().enumerate() {
        if i == file_objects {
            object_meshes = meshes.len();
        }
        if let Some(editor) = session.editor(i)? {
            let eta = session.eta(i)?;
            meshes.extend(apply::piece_meshes(editor).into_iter().map(|(m, r)| (m, r, eta)));
            continue;
        }
        // An opaque object of a radiosity bake: its patch surface (the refined wall carries
        // its colour bleeding) with the session's radiance, updated by the edits.
        if let (Some(coupled), None) = (radiosity, object.medium()) {
            let r = session.baked(i)?.and_then(transcut::ObjectBake::radiosity).context("internal: no patch surface")?;
            let patch_radiance = coupled.patch_radiance(i).context("internal: no patch radiance")?;
            let positions: Vec<[f64; 3]> = r.patch_positions.iter().map(|p| p.to_array()).collect();
            let indices: Vec<u32> = r.patch_triangles.iter().flatten().copied().collect();
            let mesh = TriMesh::from_triangles(&positions, &indices)?;
            let mut radiance = vec![[0.0; 3]; mesh.positions().len()];
            for (v, &internal) in mesh.user_to_internal().iter().enumerate() {
                radiance[internal as usize] = patch_radiance[v];
            }
            meshes.push((mesh, radiance, 1.0));
            continue;
        }
        // A translucent object (of any method): the user's mesh, so a box keeps its corners.
        let eta = match radiosity.and_then(|c| c.objects()[i].medium()) {
            // A medium edit of a radiosity bake replaces the whole medium, η included.
            Some(MediumSource::Homogeneous(m)) => m.eta,
            _ => session.eta(i)?,
        };
        let mesh = object.world_surface()?;
        let radiance = session.radiance(i)?.context("internal: an unedited object without radiance")?;
        let mut r = vec![[0.0; 3]; mesh.positions().len()];
        for (user, &internal) in mesh.user_to_internal().iter().enumerate() {
            r[internal as usize] = radiance[user];
        }
        meshes.push((mesh, r, eta));
    }
    if !radiosity_ground {
        object_meshes = meshes.len();
    }
    let objects: Vec<RenderObject<'_>> = meshes
        .iter()
        .map(|(mesh, r, eta)| RenderObject {
            positions: mesh.positions(),
            triangles: mesh.triangles(),
            radiance: r,
            normals: None,
            eta: *eta,
        })
        .collect();
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for (mesh, _, _) in &meshes[..object_meshes] {
        let (a, b) = mesh.bounds();
        lo = lo.min(a);
        hi = hi.max(b);
    }
    let centre = 0.5 * (lo + hi);
    let r = &file.render;
    let mut specular = Vec::new();
    let mut environment = [0.0; 3];
    for light in session.lights() {
        match light {
            Light::Directional { direction, irradiance, .. } => {
                specular.push(SpecularLight { direction_to_light: -*direction, irradiance: *irradiance });
            }
            Light::Point { position, intensity } | Light::Spot { position, intensity, .. } => {
                let d = *position - centre;
                let d2 = d.length_squared().max(1e-12);
                specular.push(SpecularLight { direction_to_light: d, irradiance: intensity.map(|i| i / d2) });
            }
            Light::Environment(Environment::Constant(l)) => (0..3).for_each(|c| environment[c] += l[c]),
            Light::Environment(Environment::Equirect(map)) => {
                // The mean radiance: L00 / (2√π).
                let sh = map.sh9();
                (0..3).for_each(|c| environment[c] += sh[c][0] / (2.0 * std::f64::consts::PI.sqrt()));
            }
            _ => {}
        }
    }
    if !r.specular {
        specular.clear();
    }
    let render_scene = RenderScene {
        camera: camera(&camera_spec),
        objects,
        lights: specular,
        environment: (environment != [0.0; 3]).then_some(environment),
        // A radiosity bake's ground is an object of the scene, drawn above.
        ground: (r.ground && !radiosity_ground).then(|| GroundPlane::below(lo, hi, up)),
    };
    let render_options = RenderOptions {
        exposure_ev: r.exposure_ev,
        background: r.background.get(),
        samples: if r.samples <= 1 { SamplePattern::Centre } else { SamplePattern::Grid(r.samples) },
        specular_roughness: r.roughness,
        ..RenderOptions::default()
    };
    let image = render(&render_scene, &render_options).with_context(|| format!("rendering {}", args.scene.display()))?;
    let render_ms = t_render.elapsed().as_secs_f64() * 1e3;
    let t_save = Instant::now();
    // The error names the file already.
    if ext == "png" { image.save_png(&args.output) } else { image.save_exr(&args.output) }?;
    let save_ms = t_save.elapsed().as_secs_f64() * 1e3;
    let total_ms = start.elapsed().as_secs_f64() * 1e3;

    if args.json {
        let report = serde_json::json!({
            "scene": args.scene.display().to_string(),
            "output": args.output.display().to_string(),
            "width": camera_spec.width,
            "height": camera_spec.height,
            "load_ms": load_ms,
            "bake_ms": bake_ms,
            "edit_ms": edit_ms,
            "render_ms": render_ms,
            "save_ms": save_ms,
            "total_ms": total_ms,
            "objects": scene.objects.iter().zip(&bake_stats).map(|(o, s)| serde_json::json!({"name": o.name, "stats": s})).collect::<Vec<_>>(),
            "edits": reports,
        });
        crate::output::print_json(&report)?;
    } else {
        for (o, s) in scene.objects.iter().zip(&bake_stats) {
            if let Some(p) = &s.polygrid {
                println!(
                    "{}: {} ({} nodes on {} cubes of {:.3} mm), solve iterations {:?}, {:.0} ms",
                    o.name, s.method, p.nodes, p.cubes, p.cube_mm, s.iterations, s.total_ms
                );
            } else if s.tets > 0 {
                println!("{}: {} ({} tets), solve iterations {:?}, {:.0} ms", o.name, s.method, s.tets, s.iterations, s.total_ms);
            } else {
                println!("{}: {} ({} surface vertices), {:.0} ms", o.name, s.method, s.vertices, s.total_ms);
            }
        }
        println!(
            "{}: {}×{} in {:.0} ms (load {:.0}, bake {:.0}, edits {:.0}, render {:.0}, save {:.0})",
            args.output.display(),
            camera_spec.width,
            camera_spec.height,
            total_ms,
            load_ms,
            bake_ms,
            edit_ms,
            render_ms,
            save_ms
        );
    }
    Ok(())
}

/// The render camera of a `[camera]` table.
fn camera(spec: &CameraSpec) -> Camera {
    Camera {
        position: DVec3::from(spec.position),
        target: DVec3::from(spec.target),
        up: DVec3::from(spec.up),
        vertical_fov_deg: spec.fov_deg,
        width: spec.width,
        height: spec.height,
    }
}

/// The ground of a radiosity bake, on a side, as a multiple of the objects' bounding-box
/// diagonal: large enough for their shadows and colour bleeding under light from above, small
/// enough that its patches stay few at the default patch size (the scene's diagonal / 80).
pub const GROUND_SIDE_PER_DIAGONAL: f64 = 3.0;

/// The renderer's ground plane ([`GroundPlane::below`] the objects along `up`: its plane,
/// normal and albedo) as an opaque diffuse object for a radiosity bake: a square of
/// [`GROUND_SIDE_PER_DIAGONAL`] × the objects' diagonal on a side, reflecting on its upper side,
/// at the objects' `mm_per_unit`.
fn ground_object(objects: &[Object], up: DVec3) -> anyhow::Result<Object> {
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for object in objects {
        let (a, b) = object.world_surface().with_context(|| format!("object {}", object.name))?.bounds();
        lo = lo.min(a);
        hi = hi.max(b);
    }
    let plane = GroundPlane::below(lo, hi, up);
    let half = 0.5 * GROUND_SIDE_PER_DIAGONAL * (hi - lo).length().max(1e-9);
    let n = plane.normal.normalize();
    let t = n.any_orthonormal_vector() * half;
    let b = n.cross(t);
    let c = plane.point;
    // t × b points along n: the corners run counter-clockwise seen from above.
    let corners = [c - t - b, c + t - b, c + t + b, c - t + b].map(|p| p.to_array());
    let mesh = TriMesh::from_triangles(&corners, &[0, 1, 2, 0, 2, 3])?;
    let diffuse = Diffuse { albedo: plane.albedo, emission: [0.0; 3], sides: Sides::Front };
    let mm_per_unit = objects.first().map_or(1.0, |o| o.mm_per_unit);
    Ok(Object::diffuse("ground", mesh, diffuse, mm_per_unit))
}
