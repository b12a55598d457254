//! The TOML scene format of `transcut render`.
//!
//! ```toml
//! [camera]                  # required
//! position = [0, 0, 150]    # scene units
//! target = [0, 0, 0]
//! up = [0, 1, 0]            # optional (default +Y)
//! fov_deg = 35              # vertical field of view
//! width = 800
//! height = 600
//!
//! [render]                  # optional
//! exposure_ev = 0           # stops
//! samples = 3               # n × n supersamples per pixel, n in 1..=8 (1 = none)
//! ground = true             # a grey floor under the objects (radiosity: a diffuse object, below)
//! background = [0, 0, 0]    # linear RGB
//! specular = true           # GGX highlights of the sun, point and spot lights
//! roughness = 0.3           # perceptual roughness of the highlights
//!
//! [bake]                    # optional
//! method = "transcut"       # the subsurface method (`transcut bake --method help`)
//! tets = 50000              # transcut: target tetrahedra per object
//! # grading = 0             # transcut, radiosity: "auto" (default), 0 uniform, N cubes per size graded
//! # discretization = "transcut"  # transcut, radiosity: fitted-layer (default), fitted, transcut or consistent-fem
//! tolerance = 1e-6          # solver relative residual (transcut, radiosity, polygrid)
//! solver = "ssor-pcg"       # transcut, radiosity, polygrid: the bake's solver (pcg, ssor-pcg, cascade, mg-pcg, sa-pcg)
//! # theta = 0.4             # hierarchical-dipole: the opening angle, in (0, 1]
//! # oracle = "opening-angle"  # hierarchical-dipole: opening-angle (theta) or paper (eps1, eps2)
//! # eps1 = 0.05             # hierarchical-dipole, oracle "paper": its thresholds (default 0.05)
//! # eps2 = 0.05
//! # rule = "gl3"            # hierarchical-dipole: the near field's edge rule, gl3 or paper
//! # receivers = "vertices"  # hierarchical-dipole: vertices or faces (centroids, the paper's)
//! # mode = "on-the-fly"     # hierarchical-dipole: on-the-fly, render or incremental
//! # budget = 5000           # hierarchical-dipole, mode "incremental": most links per update
//! # patch_size = 4          # radiosity: longest patch edge on diffuse objects, mm (default: diagonal/80)
//! # rays = 512              # radiosity: form-factor rays per patch
//! # iteration = "jacobi"    # radiosity: jacobi, gauss-seidel or bicgstab
//! # radiosity_tolerance = 1e-3  # radiosity: estimated relative error in power to stop at
//! # bounces = 3             # radiosity: exactly this many bounces (jacobi), whatever the tolerance
//! # scattering = "diffusion"  # radiosity: translucent objects' S: diffusion (their TransCut solve), half-space or dipole (a profile)
//! # profile_distance = "chord"  # radiosity, with a profile: chord or interior (the shortest path inside)
//! # profile_het = "consistent"  # radiosity, with a profile, heterogeneous media: consistent or sheng2014 (eq. 16)
//! # polygrid_nodes = 200000  # polygrid: target grid nodes per object
//! # polygrid_cube = 2.5     # polygrid: the polycube's cube edge, mm (default: from polygrid_nodes)
//! # polygrid_resolution = 8  # polygrid: grid cells per cube edge, 1 to 256
//! # polygrid_stencil = "fem"  # polygrid: fem, finite-volume or paper-lsq
//!
//! [[object]]                # one or more
//! mesh = "bunny.obj"        # OBJ or PLY, relative to the scene file
//! name = "bunny"            # optional (default: the mesh file's stem)
//! medium = "marble"         # a preset (`transcut bake --medium help`), or a table:
//! # medium = { sigma_a = [0.0021, 0.0041, 0.0071], sigma_s = [2.19, 2.62, 3.00], eta = 1.3, g = 0 }  (mm⁻¹)
//! # medium = { albedo = [0.8, 0.6, 0.5], radius = [1.0, 0.5, 0.3], scale = 1, ior = 1.4, g = 0 }  (artist)
//! # heterogeneous (each `medium` inside is again a preset name or a table as above):
//! # medium = { layers = [{ depth_mm = 1.5, medium = "skin1" }, { medium = "skin2" }], blend_mm = 0.3 }
//! #   layers from the surface in; each ends at depth_mm below the surface (the last one: nowhere)
//! # medium = { base = "marble", vein = { sigma_a = [...], sigma_s = [...], eta = 1.5 }, seed = 7,
//! #            period = 10, direction = [1, 0, 0], turbulence = 4, noise_scale = 10, octaves = 5,
//! #            sharpness = 3 }   marble veins, in the mesh's own units (they move with the object)
//! # medium = { voxels = "block.tcvox", eta = 1.3, g = 0 }   a voxel grid file (core/src/volume/VOXEL_FORMAT.md)
//! #   placed in the mesh's own units, relative to the scene file
//! # kind = "diffuse"        # an opaque Lambertian surface instead (walls, floors; may be open),
//! # albedo = [0.73, 0.73, 0.73]  # baked by method "radiosity" only; its keys instead of medium:
//! # emission = 0            #   albedo in [0, 1), emitted exitance (radiance emission/π),
//! # sides = "both"          #   the sides that reflect: both, front (the normals' side), back
//! mm_per_unit = 1           # millimetres per scene unit (default 1)
//! fit_size_mm = 60          # optional: centre the mesh and scale it to this bounding-box diagonal
//! scale = 1.0               # optional uniform scale (not with fit_size_mm)
//! rotate_deg = [0, 0, 0]    # optional rotation about X, then Y, then Z
//! translate = [0, 0, 0]     # optional
//!
//! [[light]]                 # zero or more (none: a white sky of radiance 1)
//! kind = "sun"              # sun | point | spot | env | rect | disc
//! dir = [0, 0, -1]          # the direction the light travels
//! irradiance = 3            # a number or [r, g, b]
//!
//! [[edit]]                  # zero or more, applied in order after the bake (every kind
//! kind = "cut_plane"        # and key: `edits`)
//! point = [0, 0, 0]
//! normal = [0, 0, 1]
//! ```
//!
//! Light keys per kind: `sun`: `dir`, `irradiance`, `angle_deg`; `point`: `pos`, `intensity`;
//! `spot`: `pos`, `dir`, `intensity`, `angle_deg` (half-angle, default 30), `blend` (0.15);
//! `env`: `radiance`, or `file` (an equirectangular .hdr/.exr, relative to the scene file) and
//! `strength` (1); `rect`: `center`, `half_u`, `half_v`, `radiance`, `two_sided`; `disc`:
//! `center`, `normal`, `radius`, `radiance`, `two_sided`.
//!
//! The `[bake]` keys are the names and values of `transcut render`'s flags (`--tets`,
//! `--theta`, `--oracle`, …; the same checks), and a flag overrides its key; a key that belongs
//! to a choice a flag overrode goes with it (`theta` under `--oracle paper`, `eps1`/`eps2` under
//! `--oracle opening-angle` or `--theta`, `budget` under another `--mode` than incremental). A
//! file whose method is not the one a key belongs to is refused naming the key.
//!
//! With `method = "radiosity"`, `ground = true` adds the renderer's ground plane to the scene as
//! a real diffuse object before the bake, named `ground`: a square of 3 × the objects'
//! bounding-box diagonal on a side (the renderer's own plane is 100 ×), centred under them on
//! the plane through their lowest point along the camera's `up`, of the renderer's grey
//! (albedo 0.5), reflecting on its upper side. It takes part in the inter-reflection: it is
//! lit and shadowed by the lights and the objects, lights them from below and takes their
//! colour bleeding, and it is drawn with its radiosity instead of the renderer's plane (beyond
//! it, the background). Its patches are of the bake's `patch_size`, and it counts in the
//! default one (the scene's diagonal / 80).
//!
//! The object transform is `translate · rotate · scale`, applied after the centring and fitting
//! of `fit_size_mm`. Every key not listed here is an error that names it; every error names the
//! scene file.

pub mod apply;
pub mod edits;
pub mod media;
pub mod schema;

use std::path::Path;
use transcut::input::fmt_num;
use transcut::input::{BoundedFile, Limits};

use anyhow::{anyhow, bail, Context};
use glam::DMat4;
use transcut::input::quote;
use transcut::light::{Environment, Light};
use transcut::mesh::TriMesh;
use transcut::{DVec3, Diffuse, Material, Object, Shape, Sides};

use edits::EditStep;
use media::object_medium;
use schema::{ObjectSpec, SceneFile};

/// A scene file read and resolved: objects with their meshes and media, lights.
pub struct LoadedScene {
    pub file: SceneFile,
    pub objects: Vec<Object>,
    pub lights: Vec<Light>,
    /// The `[[edit]]` list, in file order.
    pub edits: Vec<EditStep>,
}

/// The largest scene file read, in bytes (16 MiB).
pub const MAX_SCENE_FILE_BYTES: u64 = 16 << 20;

/// The longest line of a scene file, in bytes (64 KiB).
pub const MAX_SCENE_LINE_BYTES: usize = 64 << 10;

/// Reads, parses and resolves a scene file. Every error names `path`.
///
/// The file is read through [`transcut::input`]: only a regular file of at most
/// [`MAX_SCENE_FILE_BYTES`] with lines of at most [`MAX_SCENE_LINE_BYTES`].
pub fn load(path: &Path) -> anyhow::Result<LoadedScene> {
    let text = read_text(path).with_context(|| format!("reading scene file {}", path.display()))?;
    let file = SceneFile::parse(&text).with_context(|| format!("scene file {}", path.display()))?;
    resolve(file, path).with_context(|| format!("scene file {}", path.display()))
}

/// The scene file's text, read within the scene file limits.
fn read_text(path: &Path) -> anyhow::Result<String> {
    let limits = Limits { max_bytes: MAX_SCENE_FILE_BYTES, max_line: Some(MAX_SCENE_LINE_BYTES) };
    let bytes = BoundedFile::open(path, limits)?.read_all()?;
    String::from_utf8(bytes).map_err(|e| anyhow!("it is not UTF-8 text (byte {} is not)", e.utf8_error().valid_up_to()))
}

fn resolve(file: SceneFile, path: &Path) -> anyhow::Result<LoadedScene> {
    let base = path.parent().unwrap_or(Path::new("."));
    if file.objects.is_empty() {
        bail!("no [[object]] given");
    }
    let mut objects = Vec::new();
    for (i, spec) in file.objects.iter().enumerate() {
        objects.push(object(spec, base).with_context(|| format!("object {} ({})", i + 1, spec.mesh.display()))?);
    }
    let mut lights = Vec::new();
    for (i, spec) in file.lights.iter().enumerate() {
        let light = spec.to_light(base).with_context(|| format!("light {} (kind = \"{}\")", i + 1, spec.kind))?;
        light.validate(i).map_err(|e| anyhow!("light {} (kind = \"{}\"): {e}", i + 1, spec.kind))?;
        lights.push(light);
    }
    if lights.is_empty() {
        lights.push(Light::Environment(Environment::Constant([1.0; 3])));
    }
    let names: Vec<String> = objects.iter().map(|o| o.name.clone()).collect();
    let mm_per_unit: Vec<f64> = objects.iter().map(|o| o.mm_per_unit).collect();
    let edits = edits::resolve(&file.edits, &names, &mm_per_unit, base)?;
    Ok(LoadedScene { file, objects, lights, edits })
}

fn object(spec: &ObjectSpec, base: &Path) -> anyhow::Result<Object> {
    let mesh_path = base.join(&spec.mesh);
    if !mesh_path.exists() {
        bail!("mesh file {} not found", mesh_path.display());
    }
    let mesh = transcut::mesh::load(&mesh_path).with_context(|| format!("loading {}", mesh_path.display()))?;
    if !(spec.mm_per_unit.is_finite() && spec.mm_per_unit > 0.0) {
        bail!("mm_per_unit must be a positive number, got {}", fmt_num(spec.mm_per_unit));
    }
    let material = material(spec, base)?;
    let transform = transform(spec, &mesh)?;
    let name = spec
        .name
        .clone()
        .unwrap_or_else(|| spec.mesh.file_stem().map_or_else(|| "object".into(), |s| s.to_string_lossy().into_owned()));
    let mut object = Object::with_shape(name, Shape::Surface(mesh), material, spec.mm_per_unit);
    object.transform = transform;
    Ok(object)
}

/// The object's material from its `kind` and the keys of that kind (a key of the other kind is
/// an error naming it).
fn material(spec: &ObjectSpec, base: &Path) -> anyhow::Result<Material> {
    let diffuse_keys =
        [("albedo", spec.albedo.is_some()), ("emission", spec.emission.is_some()), ("sides", spec.sides.is_some())];
    match spec.kind.as_deref().map(|k| k.trim().to_ascii_lowercase()).as_deref() {
        None | Some("translucent") => {
            if let Some((key, _)) = diffuse_keys.iter().find(|(_, given)| *given) {
                bail!("{key} is a key of kind = \"diffuse\" objects; a translucent object takes a medium");
            }
            let medium = spec.medium.as_ref().ok_or_else(|| anyhow!("no medium given (or give kind = \"diffuse\")"))?;
            Ok(object_medium(medium, spec.mm_per_unit, base).context("medium")?.into())
        }
        Some("diffuse") => {
            if spec.medium.is_some() {
                bail!("medium is a key of translucent objects; a kind = \"diffuse\" object takes albedo, emission and sides");
            }
            let sides = match spec.sides.as_deref() {
                None => Sides::default(),
                Some(name) => Sides::from_name(name)
                    .ok_or_else(|| anyhow!("sides: unknown sides {} (they are: {})", quote(name), Sides::NAMES.join(", ")))?,
            };
            let diffuse = Diffuse {
                albedo: spec.albedo.map_or(Diffuse::default().albedo, schema::Rgb::get),
                emission: spec.emission.map_or([0.0; 3], schema::Rgb::get),
                sides,
            };
            diffuse.validate().map_err(|e| anyhow!(e))?;
            Ok(diffuse.into())
        }
        Some(other) => bail!("kind: unknown object kind {} (the kinds are: translucent, diffuse)", quote(other)),
    }
}

fn transform(spec: &ObjectSpec, mesh: &TriMesh) -> anyhow::Result<DMat4> {
    let mut pre = DMat4::IDENTITY;
    if let Some(size) = spec.fit_size_mm {
        if spec.scale.is_some() {
            bail!("give fit_size_mm or scale, not both");
        }
        if !(size.is_finite() && size > 0.0) {
            bail!("fit_size_mm must be a positive number, got {}", fmt_num(size));
        }
        let (lo, hi) = mesh.bounds();
        let diagonal = (hi - lo).length();
        if !(diagonal > 0.0) {
            bail!("the mesh is empty or flat: cannot fit it to {} mm", fmt_num(size));
        }
        let s = size / spec.mm_per_unit / diagonal;
        pre = DMat4::from_scale(DVec3::splat(s)) * DMat4::from_translation(-0.5 * (lo + hi));
    }
    let scale = spec.scale.unwrap_or(1.0);
    if !(scale.is_finite() && scale > 0.0) {
        bail!("scale must be a positive number, got {}", fmt_num(scale));
    }
    let [rx, ry, rz] = spec.rotate_deg.map(f64::to_radians);
    let rotation = DMat4::from_rotation_z(rz) * DMat4::from_rotation_y(ry) * DMat4::from_rotation_x(rx);
    let m = DMat4::from_translation(DVec3::from(spec.translate)) * rotation * DMat4::from_scale(DVec3::splat(scale)) * pre;
    if !m.is_finite() {
        bail!("the transform is not finite");
    }
    Ok(m)
}

/// The body of the `scene_toml` fuzz target, which the tests run on the fuzz corpus.
#[cfg(test)]
#[allow(dead_code)]
#[path = "../../../fuzz/src/scene_target.rs"]
mod fuzz_scene;

/// The stable-Rust fuzzer of the fuzz corpus.
#[cfg(test)]
#[allow(dead_code)]
#[path = "../../../fuzz/src/mutate.rs"]
mod mutate;

#[cfg(test)]
mod tests {
    use super::*;

    /// The `scene_toml` fuzz corpus through the fuzz target's body: no panic, every message at
    /// most 1 KiB, `ok_*` seeds parsed (with at least one object), `bad_*` seeds refused.
    #[test]
    fn every_scene_corpus_file_gets_its_answer() {
        let (mut ok, mut bad) = (0, 0);
        for (path, bytes) in mutate::corpus("scene_toml") {
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            let answer = fuzz_scene::scene_toml(&bytes);
            if name.starts_with("ok_") {
                assert!(matches!(answer, Ok(n) if n >= 1), "{name}: {answer:?}");
                ok += 1;
            } else {
                assert!(name.starts_with("bad_"), "{name}: name it ok_* or bad_*");
                let message = answer.expect_err(&name);
                assert!(message.len() <= 1024, "{name}: {} bytes", message.len());
                bad += 1;
            }
        }
        assert!(ok >= 2 && bad >= 3, "{ok} ok and {bad} bad seeds");
    }

    /// Mutates the corpus at random for `TRANSCUT_FUZZ_SECONDS` (default 60).
    #[test]
    #[ignore = "a fuzzing run: TRANSCUT_FUZZ_SECONDS (default 60)"]
    fn fuzz_scene_mutations() {
        let out = std::env::temp_dir().join("transcut-fuzz-findings");
        let runs = mutate::run("scene_toml", mutate::seconds(), &out, fuzz_scene::scene_toml);
        println!("scene_toml: {runs} inputs, no finding");
    }

    /// A scene path that is a device, a FIFO or a directory is refused before it is opened.
    #[cfg(unix)]
    #[test]
    fn scene_files_that_are_not_regular_files_are_refused() {
        for p in ["/dev/zero", "/"] {
            let e = format!("{:#}", load(Path::new(p)).err().unwrap());
            assert!(e.starts_with(&format!("reading scene file {p}: it is a ")), "{e}");
            assert!(e.len() < 200, "{e}");
        }
    }
}
