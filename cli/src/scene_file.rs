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
//! samples = 3               # n × n supersamples per pixel (1 = none)
//! ground = true             # a grey floor under the objects
//! background = [0, 0, 0]    # linear RGB
//! specular = true           # GGX highlights of the sun, point and spot lights
//! roughness = 0.3           # perceptual roughness of the highlights
//!
//! [bake]                    # optional
//! tets = 50000              # target tetrahedra per object
//! tolerance = 1e-6          # solver relative residual
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
//! kind = "cut_plane"        # and key: `crate::scene_edits`)
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
//! The object transform is `translate · rotate · scale`, applied after the centring and fitting
//! of `fit_size_mm`. Every key not listed here is an error that names it; every error names the
//! scene file.

use std::path::{Path, PathBuf};

use anyhow::{anyhow, bail, Context};
use glam::DMat4;
use serde::Deserialize;
use transcut::light::{Environment, EquirectMap, Light};
use transcut::mesh::TriMesh;
use transcut::optics::{ArtistParams, Medium};
use transcut::scene::{MediumSource, Object, Shape};
use transcut::volume::{Layers, VeinParams, Veins, VoxelGrid};

use crate::scene_edits::EditStep;
use transcut::DVec3;

/// A colour: one number for grey or three for RGB.
#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(untagged)]
pub enum Rgb {
    Grey(f64),
    Rgb([f64; 3]),
}

impl Rgb {
    pub fn get(self) -> [f64; 3] {
        match self {
            Rgb::Grey(v) => [v; 3],
            Rgb::Rgb(c) => c,
        }
    }
}

/// The `[camera]` table.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    pub position: [f64; 3],
    pub target: [f64; 3],
    #[serde(default = "default_up")]
    pub up: [f64; 3],
    pub fov_deg: f64,
    pub width: u32,
    pub height: u32,
}

fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}

/// The `[render]` table.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RenderSpec {
    pub exposure_ev: f64,
    pub samples: u32,
    pub ground: bool,
    pub background: Rgb,
    pub specular: bool,
    pub roughness: f64,
}

impl Default for RenderSpec {
    fn default() -> Self {
        Self { exposure_ev: 0.0, samples: 3, ground: true, background: Rgb::Grey(0.0), specular: true, roughness: 0.3 }
    }
}

/// The `[bake]` table.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BakeSpec {
    pub tets: Option<u64>,
    pub tolerance: Option<f64>,
}

/// One `[[object]]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    pub mesh: PathBuf,
    pub name: Option<String>,
    pub medium: toml::Value,
    #[serde(default = "one")]
    pub mm_per_unit: f64,
    pub fit_size_mm: Option<f64>,
    pub scale: Option<f64>,
    #[serde(default)]
    pub rotate_deg: [f64; 3],
    #[serde(default)]
    pub translate: [f64; 3],
}

fn one() -> f64 {
    1.0
}

/// One `[[light]]`: every key of every kind; [`LightSpec::to_light`] checks which apply.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    pub kind: String,
    pub dir: Option<[f64; 3]>,
    pub pos: Option<[f64; 3]>,
    pub irradiance: Option<Rgb>,
    pub intensity: Option<Rgb>,
    pub radiance: Option<Rgb>,
    pub angle_deg: Option<f64>,
    pub blend: Option<f64>,
    pub file: Option<PathBuf>,
    pub strength: Option<f64>,
    pub center: Option<[f64; 3]>,
    pub half_u: Option<[f64; 3]>,
    pub half_v: Option<[f64; 3]>,
    pub normal: Option<[f64; 3]>,
    pub radius: Option<f64>,
    pub two_sided: Option<bool>,
}

/// A whole scene file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    pub camera: CameraSpec,
    #[serde(default)]
    pub render: RenderSpec,
    #[serde(default)]
    pub bake: BakeSpec,
    #[serde(default, rename = "object")]
    pub objects: Vec<ObjectSpec>,
    #[serde(default, rename = "light")]
    pub lights: Vec<LightSpec>,
    /// `[[edit]]` tables, checked by [`crate::scene_edits::resolve`] (so errors name the edit).
    #[serde(default, rename = "edit")]
    pub edits: Vec<toml::Table>,
}

/// A scene file read and resolved: objects with their meshes and media, lights.
pub struct LoadedScene {
    pub file: SceneFile,
    pub objects: Vec<Object>,
    pub lights: Vec<Light>,
    /// The `[[edit]]` list, in file order.
    pub edits: Vec<EditStep>,
}

impl SceneFile {
    /// Parses TOML text (no file access).
    ///
    /// # Errors
    /// The TOML error, which names the key and shows the line.
    pub fn parse(text: &str) -> anyhow::Result<SceneFile> {
        toml::from_str(text).map_err(|e| {
            // Name the table the offending key is in: the last header before the error.
            let table = e.span().and_then(|span| {
                text[..span.start.min(text.len())].lines().rev().map(str::trim).find(|l| l.starts_with('[')).map(str::to_string)
            });
            match table {
                Some(t) => anyhow!("in table {t}: {}", e.to_string().trim_end()),
                None => anyhow!("at the top level: {}", e.to_string().trim_end()),
            }
        })
    }
}

/// Reads, parses and resolves a scene file. Every error names `path`.
pub fn load(path: &Path) -> anyhow::Result<LoadedScene> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading scene file {}", path.display()))?;
    let file = SceneFile::parse(&text).with_context(|| format!("scene file {}", path.display()))?;
    resolve(file, path).with_context(|| format!("scene file {}", path.display()))
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
    let edits = crate::scene_edits::resolve(&file.edits, &names, &mm_per_unit, base)?;
    Ok(LoadedScene { file, objects, lights, edits })
}

fn object(spec: &ObjectSpec, base: &Path) -> anyhow::Result<Object> {
    let mesh_path = base.join(&spec.mesh);
    if !mesh_path.exists() {
        bail!("mesh file {} not found", mesh_path.display());
    }
    let mesh = transcut::mesh::load(&mesh_path).with_context(|| format!("loading {}", mesh_path.display()))?;
    if !(spec.mm_per_unit.is_finite() && spec.mm_per_unit > 0.0) {
        bail!("mm_per_unit must be a positive number, got {}", spec.mm_per_unit);
    }
    let medium = object_medium(&spec.medium, spec.mm_per_unit, base).context("medium")?;
    let transform = transform(spec, &mesh)?;
    let name = spec
        .name
        .clone()
        .unwrap_or_else(|| spec.mesh.file_stem().map_or_else(|| "object".into(), |s| s.to_string_lossy().into_owned()));
    let mut object = Object::with_shape(name, Shape::Surface(mesh), medium, spec.mm_per_unit);
    object.transform = transform;
    Ok(object)
}

fn transform(spec: &ObjectSpec, mesh: &TriMesh) -> anyhow::Result<DMat4> {
    let mut pre = DMat4::IDENTITY;
    if let Some(size) = spec.fit_size_mm {
        if spec.scale.is_some() {
            bail!("give fit_size_mm or scale, not both");
        }
        if !(size.is_finite() && size > 0.0) {
            bail!("fit_size_mm must be a positive number, got {size}");
        }
        let (lo, hi) = mesh.bounds();
        let diagonal = (hi - lo).length();
        if !(diagonal > 0.0) {
            bail!("the mesh is empty or flat: cannot fit it to {size} mm");
        }
        let s = size / spec.mm_per_unit / diagonal;
        pre = DMat4::from_scale(DVec3::splat(s)) * DMat4::from_translation(-0.5 * (lo + hi));
    }
    let scale = spec.scale.unwrap_or(1.0);
    if !(scale.is_finite() && scale > 0.0) {
        bail!("scale must be a positive number, got {scale}");
    }
    let [rx, ry, rz] = spec.rotate_deg.map(f64::to_radians);
    let rotation = DMat4::from_rotation_z(rz) * DMat4::from_rotation_y(ry) * DMat4::from_rotation_x(rx);
    let m = DMat4::from_translation(DVec3::from(spec.translate)) * rotation * DMat4::from_scale(DVec3::splat(scale)) * pre;
    if !m.is_finite() {
        bail!("the transform is not finite");
    }
    Ok(m)
}

/// An object's medium: homogeneous ([`medium`]), or layered, veined or from a voxel file (see
/// the module documentation), told apart by the keys `layers`, `base` and `voxels`.
pub fn object_medium(value: &toml::Value, mm_per_unit: f64, base_dir: &Path) -> anyhow::Result<MediumSource> {
    let Some(table) = value.as_table() else { return medium(value, mm_per_unit).map(MediumSource::Homogeneous) };
    let check_keys = |what: &str, known: &[&str]| -> anyhow::Result<()> {
        match table.keys().find(|k| !known.contains(&k.as_str())) {
            Some(k) => bail!("unknown key '{k}' in the {what} medium (its keys: {})", known.join(", ")),
            None => Ok(()),
        }
    };
    let number = |key: &str, default: f64| table_number(table, key, Some(default));
    let inner = |key: &str| -> anyhow::Result<Medium> {
        let v = table.get(key).ok_or_else(|| anyhow!("missing key '{key}'"))?;
        medium(v, mm_per_unit).with_context(|| format!("'{key}'"))
    };
    if let Some(layers) = table.get("layers") {
        check_keys("layered", &["layers", "blend_mm"])?;
        let list = layers.as_array().ok_or_else(|| anyhow!("'layers' must be an array of tables"))?;
        let mut parsed = Vec::with_capacity(list.len());
        for (i, layer) in list.iter().enumerate() {
            let layer = layer.as_table().ok_or_else(|| anyhow!("layer {}: expected a table", i + 1))?;
            if let Some(k) = layer.keys().find(|k| !["depth_mm", "medium"].contains(&k.as_str())) {
                bail!("layer {}: unknown key '{k}' (its keys: depth_mm, medium)", i + 1);
            }
            let depth = match layer.get("depth_mm") {
                None if i + 1 == list.len() => f64::INFINITY,
                None => bail!("layer {}: missing key 'depth_mm' (only the innermost layer may omit it)", i + 1),
                Some(_) => table_number(layer, "depth_mm", None).with_context(|| format!("layer {}", i + 1))?,
            };
            let m = layer.get("medium").ok_or_else(|| anyhow!("layer {}: missing key 'medium'", i + 1))?;
            parsed.push((depth, medium(m, mm_per_unit).with_context(|| format!("layer {}", i + 1))?));
        }
        return Ok(MediumSource::Layers(Layers::new(&parsed, number("blend_mm", 0.0)?).map_err(|e| anyhow!("{e}"))?));
    }
    if table.contains_key("base") {
        check_keys(
            "veined",
            &["base", "vein", "seed", "period", "direction", "turbulence", "noise_scale", "octaves", "sharpness"],
        )?;
        let d = VeinParams::default();
        let direction = match table.get("direction") {
            None => d.direction,
            Some(v) => DVec3::from(<[f64; 3]>::deserialize(v.clone()).map_err(|_| anyhow!("'direction' must be [x, y, z]"))?),
        };
        let integer = |key: &str, default: i64| -> anyhow::Result<i64> {
            match table.get(key) {
                None => Ok(default),
                Some(v) => v.as_integer().filter(|x| *x >= 0).ok_or_else(|| anyhow!("'{key}' must be a non-negative integer")),
            }
        };
        let params = VeinParams {
            direction,
            period: number("period", d.period)?,
            turbulence: number("turbulence", d.turbulence)?,
            noise_scale: number("noise_scale", d.noise_scale)?,
            octaves: u32::try_from(integer("octaves", i64::from(d.octaves))?).map_err(|_| anyhow!("'octaves' is too large"))?,
            sharpness: number("sharpness", d.sharpness)?,
        };
        let veins = Veins::new(inner("base")?, inner("vein")?, integer("seed", 0)? as u64, params).map_err(|e| anyhow!("{e}"))?;
        return Ok(MediumSource::Veins(veins));
    }
    if let Some(file) = table.get("voxels") {
        check_keys("voxel", &["voxels", "eta", "g"])?;
        let file = file.as_str().ok_or_else(|| anyhow!("'voxels' must be a file name"))?;
        let path = base_dir.join(file);
        let grid = VoxelGrid::read(&path).map_err(|e| anyhow!("{e}"))?;
        return Ok(MediumSource::Voxels { grid, eta: number("eta", 1.3)?, g: number("g", 0.0)? });
    }
    medium(value, mm_per_unit).map(MediumSource::Homogeneous)
}

/// The number under `key` (an integer is read as a float), or `default` when the key is absent.
fn table_number(table: &toml::Table, key: &str, default: Option<f64>) -> anyhow::Result<f64> {
    match table.get(key) {
        None => default.ok_or_else(|| anyhow!("missing key '{key}'")),
        Some(toml::Value::Float(v)) => Ok(*v),
        Some(toml::Value::Integer(v)) => Ok(*v as f64),
        Some(other) => bail!("'{key}' must be a number, got {}", other.type_str()),
    }
}

/// A medium from a preset name or a table of coefficients or artist parameters.
pub fn medium(value: &toml::Value, mm_per_unit: f64) -> anyhow::Result<Medium> {
    let table = match value {
        toml::Value::String(name) => return Medium::preset(name).map_err(|e| anyhow!("{e}")),
        toml::Value::Table(t) => t,
        other => bail!("expected a preset name or a table, got {}", other.type_str()),
    };
    let number = |key: &str, default: Option<f64>| table_number(table, key, default);
    let rgb = |key: &str| -> anyhow::Result<[f64; 3]> {
        match table.get(key) {
            None => bail!("missing key '{key}'"),
            Some(v) => Rgb::deserialize(v.clone()).map(Rgb::get).map_err(|_| anyhow!("'{key}' must be a number or [r, g, b]")),
        }
    };
    let artist = table.contains_key("albedo") || table.contains_key("radius");
    let known: &[&str] = if artist { &["albedo", "radius", "scale", "ior", "g"] } else { &["sigma_a", "sigma_s", "eta", "g"] };
    if let Some(k) = table.keys().find(|k| !known.contains(&k.as_str())) {
        bail!(
            "unknown key '{k}' in the medium table ({} medium keys: {})",
            if artist { "artist" } else { "coefficient" },
            known.join(", ")
        );
    }
    if artist {
        let params = ArtistParams {
            albedo: rgb("albedo")?,
            radius: rgb("radius")?,
            scale: number("scale", Some(1.0))?,
            mm_per_unit,
            eta: number("ior", Some(1.4))?,
            g: number("g", Some(0.0))?,
        };
        params.to_medium().map_err(|e| anyhow!("{e}"))
    } else {
        Medium::new(rgb("sigma_a")?, rgb("sigma_s")?, number("eta", Some(1.3))?, number("g", Some(0.0))?)
            .map_err(|e| anyhow!("{e}"))
    }
}

impl LightSpec {
    pub(crate) fn to_light(&self, base: &Path) -> anyhow::Result<Light> {
        let kind = self.kind.to_ascii_lowercase();
        let allowed: &[&str] = match kind.as_str() {
            "sun" | "directional" => &["dir", "irradiance", "angle_deg"],
            "point" => &["pos", "intensity"],
            "spot" => &["pos", "dir", "intensity", "angle_deg", "blend"],
            "env" | "environment" => &["radiance", "file", "strength"],
            "rect" => &["center", "half_u", "half_v", "radiance", "two_sided"],
            "disc" => &["center", "normal", "radius", "radiance", "two_sided"],
            other => bail!("unknown light kind '{other}' (sun, point, spot, env, rect, disc)"),
        };
        for (key, present) in [
            ("dir", self.dir.is_some()),
            ("pos", self.pos.is_some()),
            ("irradiance", self.irradiance.is_some()),
            ("intensity", self.intensity.is_some()),
            ("radiance", self.radiance.is_some()),
            ("angle_deg", self.angle_deg.is_some()),
            ("blend", self.blend.is_some()),
            ("file", self.file.is_some()),
            ("strength", self.strength.is_some()),
            ("center", self.center.is_some()),
            ("half_u", self.half_u.is_some()),
            ("half_v", self.half_v.is_some()),
            ("normal", self.normal.is_some()),
            ("radius", self.radius.is_some()),
            ("two_sided", self.two_sided.is_some()),
        ] {
            if present && !allowed.contains(&key) {
                bail!("key '{key}' does not apply to this kind of light (its keys: {})", allowed.join(", "));
            }
        }
        fn need<T: Copy>(v: Option<T>, key: &str) -> anyhow::Result<T> {
            v.ok_or_else(|| anyhow!("missing key '{key}'"))
        }
        let v3 = |v: Option<[f64; 3]>, key: &str| need(v, key).map(DVec3::from);
        let c3 = |v: Option<Rgb>, key: &str| need(v, key).map(Rgb::get);
        Ok(match kind.as_str() {
            "sun" | "directional" => Light::Directional {
                direction: v3(self.dir, "dir")?,
                irradiance: c3(self.irradiance, "irradiance")?,
                angular_diameter_deg: self.angle_deg.unwrap_or(0.0),
            },
            "point" => Light::Point { position: v3(self.pos, "pos")?, intensity: c3(self.intensity, "intensity")? },
            "spot" => Light::Spot {
                position: v3(self.pos, "pos")?,
                direction: v3(self.dir, "dir")?,
                intensity: c3(self.intensity, "intensity")?,
                cone_half_angle_deg: self.angle_deg.unwrap_or(30.0),
                blend: self.blend.unwrap_or(0.15),
            },
            "env" | "environment" => match &self.file {
                Some(file) => {
                    if self.radiance.is_some() {
                        bail!("give radiance or file, not both");
                    }
                    let path = base.join(file);
                    let map = EquirectMap::load(&path, self.strength.unwrap_or(1.0))
                        .with_context(|| format!("loading {}", path.display()))?;
                    Light::Environment(Environment::Equirect(map))
                }
                None => {
                    if self.strength.is_some() {
                        bail!("'strength' applies only with 'file'");
                    }
                    Light::Environment(Environment::Constant(c3(self.radiance, "radiance")?))
                }
            },
            "rect" => Light::RectArea {
                center: v3(self.center, "center")?,
                half_u: v3(self.half_u, "half_u")?,
                half_v: v3(self.half_v, "half_v")?,
                radiance: c3(self.radiance, "radiance")?,
                two_sided: self.two_sided.unwrap_or(false),
            },
            _ => Light::DiscArea {
                center: v3(self.center, "center")?,
                normal: v3(self.normal, "normal")?,
                radius: need(self.radius, "radius")?,
                radiance: c3(self.radiance, "radiance")?,
                two_sided: self.two_sided.unwrap_or(false),
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = "[camera]\nposition = [0, 0, 150]\ntarget = [0, 0, 0]\nfov_deg = 35\nwidth = 80\nheight = 60\n";

    #[test]
    fn parses_defaults_and_integers_as_floats() {
        let f = SceneFile::parse(&format!("{MINIMAL}[[object]]\nmesh = \"a.obj\"\nmedium = \"marble\"\n[[light]]\nkind = \"sun\"\ndir = [0,0,-1]\nirradiance = 3\n")).unwrap();
        assert_eq!(f.camera.up, [0.0, 1.0, 0.0]);
        assert_eq!(f.render.samples, 3);
        assert_eq!(f.objects[0].mm_per_unit, 1.0);
        assert!(matches!(f.lights[0].irradiance, Some(Rgb::Grey(v)) if v == 3.0));
        let l = f.lights[0].to_light(Path::new(".")).unwrap();
        assert!(matches!(l, Light::Directional { irradiance: [3.0, 3.0, 3.0], .. }));
    }

    #[test]
    fn unknown_keys_are_named() {
        let err = SceneFile::parse(&format!("{MINIMAL}[render]\nexposure = 1\n")).unwrap_err().to_string();
        assert!(err.contains("exposure") && err.contains("render"), "{err}");
        let err = SceneFile::parse(&MINIMAL.replace("fov_deg", "fov")).unwrap_err().to_string();
        assert!(err.contains("fov"), "{err}");
    }

    #[test]
    fn media_from_tables() {
        let v: toml::Value = toml::from_str("m = { sigma_a = [0.01, 0.02, 0.03], sigma_s = 1, eta = 1.3 }").unwrap();
        let m = medium(&v["m"], 1.0).unwrap();
        assert_eq!(m.sigma_a, [0.01, 0.02, 0.03]);
        let v: toml::Value = toml::from_str("m = { albedo = [0.8, 0.6, 0.5], radius = [1, 0.5, 0.3] }").unwrap();
        assert!(medium(&v["m"], 1.0).is_ok());
        let v: toml::Value = toml::from_str("m = { albedo = 0.5, radius = 1, colour = 2 }").unwrap();
        assert!(medium(&v["m"], 1.0).unwrap_err().to_string().contains("'colour'"));
        let v: toml::Value = toml::from_str("m = \"plutonium\"").unwrap();
        assert!(medium(&v["m"], 1.0).is_err());
    }

    #[test]
    fn heterogeneous_media_from_tables() {
        let parse = |text: &str| {
            let v: toml::Value = toml::from_str(text).unwrap();
            object_medium(&v["m"], 1.0, Path::new("."))
        };
        let layered =
            parse("m = { layers = [{ depth_mm = 1.5, medium = \"skin1\" }, { medium = \"skin2\" }], blend_mm = 0.3 }").unwrap();
        assert!(matches!(layered, MediumSource::Layers(_)));
        let veined =
            parse("m = { base = \"marble\", vein = { sigma_a = 0.05, sigma_s = 2, eta = 1.5 }, seed = 3, period = 8 }").unwrap();
        assert!(matches!(veined, MediumSource::Veins(_)));
        assert!(matches!(parse("m = \"marble\"").unwrap(), MediumSource::Homogeneous(_)));
        let err = |text: &str| format!("{:#}", parse(text).unwrap_err());
        let e = err("m = { layers = [{ medium = \"skin1\" }, { medium = \"skin2\" }] }");
        assert!(e.contains("layer 1: missing key 'depth_mm'"), "{e}");
        let e = err("m = { layers = [{ depth_mm = 1, medium = \"skin1\", colour = 1 }] }");
        assert!(e.contains("layer 1: unknown key 'colour'"), "{e}");
        let e = err("m = { base = \"marble\", vein = \"skin1\" }");
        assert!(e.contains("eta"), "marble (1.5) and skin1 (1.3) differ in eta: {e}");
        let e = err("m = { base = \"marble\", vein = \"marble\", octaves = -1 }");
        assert!(e.contains("'octaves'"), "{e}");
        let e = err("m = { voxels = \"missing.tcvox\" }");
        assert!(e.contains("missing.tcvox"), "{e}");
        let e = err("m = { voxels = \"a.tcvox\", sigma_a = 1 }");
        assert!(e.contains("unknown key 'sigma_a' in the voxel medium"), "{e}");
    }
}
