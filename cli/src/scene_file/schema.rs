//! The serde types of the scene file: one struct per table, unknown keys refused.

use std::path::{Path, PathBuf};
use transcut::input::{clip, quote};

use anyhow::{anyhow, bail, Context};
use serde::Deserialize;
use transcut::light::{Environment, EquirectMap, Light};
use transcut::DVec3;

use crate::method_args::{BakeTable, MethodDefaults};

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

/// `[bake] grading` as written: a layer count or a name (`"auto"`).
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum GradingSpec {
    Layers(u32),
    Name(String),
}

impl GradingSpec {
    /// The value as `--grading` takes it.
    fn text(&self) -> String {
        match self {
            Self::Layers(n) => n.to_string(),
            Self::Name(name) => name.clone(),
        }
    }
}

/// The `[bake]` table.
#[derive(Debug, Clone, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BakeSpec {
    /// The subsurface method's name (default `transcut`).
    pub method: Option<String>,
    pub tets: Option<u64>,
    /// transcut, radiosity: `"auto"` or cubes of each size before the next doubling
    /// (`--grading`; 0 uniform).
    pub grading: Option<GradingSpec>,
    /// transcut, radiosity: the assembly's name (`--discretization`).
    pub discretization: Option<String>,
    pub tolerance: Option<f64>,
    /// The solver's name ([`transcut::diffusion::SolverKind::name`]).
    pub solver: Option<String>,
    /// hierarchical-dipole: the opening angle of its oracle (`--theta`).
    pub theta: Option<f64>,
    /// hierarchical-dipole: the refinement oracle (`opening-angle`, `paper`; `--oracle`).
    pub oracle: Option<String>,
    /// hierarchical-dipole, oracle `paper`: its ε₁ (`--eps1`).
    pub eps1: Option<f64>,
    /// hierarchical-dipole, oracle `paper`: its ε₂ (`--eps2`).
    pub eps2: Option<f64>,
    /// hierarchical-dipole: the near field's edge rule (`gl3`, `paper`; `--rule`).
    pub rule: Option<String>,
    /// hierarchical-dipole: where the radiance is evaluated (`vertices`, `faces`; `--receivers`).
    pub receivers: Option<String>,
    /// hierarchical-dipole: when links are made (`on-the-fly`, `render`, `incremental`; `--mode`).
    pub mode: Option<String>,
    /// hierarchical-dipole, mode `incremental`: the most links per update (`--budget`).
    pub budget: Option<u64>,
    /// radiosity: the longest patch edge on opaque objects, mm (`--patch-size`).
    pub patch_size: Option<f64>,
    /// radiosity: form-factor rays per patch (`--rays`).
    pub rays: Option<u64>,
    /// radiosity: `jacobi` or `gauss-seidel` (`--iteration`).
    pub iteration: Option<String>,
    /// radiosity: the estimated relative error in power to stop at (`--radiosity-tolerance`).
    pub radiosity_tolerance: Option<f64>,
    /// radiosity: exactly this many bounces of light (`--bounces`).
    pub bounces: Option<u64>,
    /// radiosity: the translucent objects' scattering S, `diffusion`, `half-space` or `dipole`
    /// (`--scattering`).
    pub scattering: Option<String>,
    /// radiosity, a profile scattering: `chord` or `interior` (`--profile-distance`).
    pub profile_distance: Option<String>,
    /// radiosity, a profile scattering of a heterogeneous medium: `consistent` or `sheng2014`
    /// (`--profile-het`).
    pub profile_het: Option<String>,
    /// prt: log₂ of the irradiance samples (`--prt-samples`).
    pub prt_samples: Option<u32>,
    /// prt: Haar coefficients kept per vertex (`--prt-terms`).
    pub prt_terms: Option<u64>,
    /// prt: the basis, 12 or 16 functions (`--prt-basis`).
    pub prt_basis: Option<u32>,
    /// prt: a folder of saved precomputes, relative to the scene file (`--prt-cache`).
    pub prt_cache: Option<PathBuf>,
    /// polygrid: target grid nodes per object (`--polygrid-nodes`).
    pub polygrid_nodes: Option<u64>,
    /// polygrid: the polycube's cube edge, mm (`--polygrid-cube`).
    pub polygrid_cube: Option<f64>,
    /// polygrid: grid cells per cube edge (`--polygrid-resolution`).
    pub polygrid_resolution: Option<u32>,
    /// polygrid: `fem`, `finite-volume` or `paper-lsq` (`--polygrid-stencil`).
    pub polygrid_stencil: Option<String>,
}

/// One `[[object]]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectSpec {
    pub mesh: PathBuf,
    pub name: Option<String>,
    /// `translucent` (default: a `medium` fills it) or `diffuse` (an opaque surface with
    /// `albedo`, `emission` and `sides`; the radiosity method bakes it).
    pub kind: Option<String>,
    pub medium: Option<toml::Value>,
    /// diffuse: the reflectance, each channel in [0, 1) (default 0.73, the Cornell box's white).
    pub albedo: Option<Rgb>,
    /// diffuse: the emitted exitance (default 0; radiance M/π).
    pub emission: Option<Rgb>,
    /// diffuse: which sides reflect: `both` (default), `front` or `back`.
    pub sides: Option<String>,
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
    /// `[[edit]]` tables, checked by [`super::edits::resolve`] (so errors name the edit).
    #[serde(default, rename = "edit")]
    pub edits: Vec<toml::Table>,
}

impl SceneFile {
    /// Parses TOML text (no file access).
    ///
    /// # Errors
    /// The TOML error with the table, line and column it is at (the offending text quoted
    /// short, see [`transcut::input::quote`]); a `[render]` table with `samples` outside
    /// 1..=[`transcut::render::MAX_GRID`] (refused here, before the bake, rather than by the
    /// renderer after it).
    pub fn parse(text: &str) -> anyhow::Result<SceneFile> {
        let file: SceneFile = toml::from_str(text).map_err(|e| toml_error(text, &e))?;
        let (samples, max) = (file.render.samples, transcut::render::MAX_GRID);
        if !(1..=max).contains(&samples) {
            bail!(
                "in table [render]: samples = {samples}: the supersampling grid is n × n with n in 1..={max} (1 = one \
                 sample per pixel)"
            );
        }
        Ok(file)
    }
}

/// A TOML error as one short line: the table the offending key is in (the last header before
/// the error), the line and column, and the parser's message without its excerpt of the file.
fn toml_error(text: &str, e: &toml::de::Error) -> anyhow::Error {
    let at = e.span().map(|span| span.start.min(text.len()));
    let before = at.map_or("", |i| &text[..floor_char_boundary(text, i)]);
    let table = at.and_then(|_| before.lines().rev().map(str::trim).find(|l| l.starts_with('[')));
    let place = match at {
        Some(_) => {
            let line = before.matches('\n').count() + 1;
            let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
            format!("line {line}, column {column}: ")
        }
        None => String::new(),
    };
    let message = clip(e.message().trim_end());
    match table {
        Some(t) => anyhow!("in table {}: {place}{message}", clip(t)),
        None => anyhow!("at the top level: {place}{message}"),
    }
}

/// The largest char boundary of `text` at or before `i`.
fn floor_char_boundary(text: &str, mut i: usize) -> usize {
    while !text.is_char_boundary(i) {
        i -= 1;
    }
    i
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
            other => bail!("unknown light kind {other} (sun, point, spot, env, rect, disc)", other = quote(other)),
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
                bail!("key {key} does not apply to this kind of light (its keys: {})", allowed.join(", "), key = quote(key));
            }
        }
        fn need<T: Copy>(v: Option<T>, key: &str) -> anyhow::Result<T> {
            v.ok_or_else(|| anyhow!("missing key {key}", key = quote(key)))
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

impl BakeSpec {
    /// The method defaults of this `[bake]` ([`MethodDefaults::from_bake_table`] of its
    /// [`BakeSpec::table`], with its `scattering`, `profile_distance` and `profile_het`).
    ///
    /// # Errors
    /// An unknown name or a value out of range, naming the key.
    pub fn method_defaults(&self) -> anyhow::Result<MethodDefaults> {
        MethodDefaults::from_bake_table(self.table())?
            .with_scattering(self.scattering.as_deref(), self.profile_distance.as_deref())?
            .with_profile_het(self.profile_het.as_deref())
    }

    /// The table of a parsed scene file's `[bake]`.
    #[must_use]
    pub fn table(&self) -> BakeTable {
        let b = self;
        BakeTable {
            method: b.method.clone(),
            tets: b.tets,
            grading: b.grading.as_ref().map(GradingSpec::text),
            discretization: b.discretization.clone(),
            tolerance: b.tolerance,
            solver: b.solver.clone(),
            theta: b.theta,
            oracle: b.oracle.clone(),
            eps1: b.eps1,
            eps2: b.eps2,
            rule: b.rule.clone(),
            receivers: b.receivers.clone(),
            mode: b.mode.clone(),
            budget: b.budget,
            patch_size: b.patch_size,
            rays: b.rays,
            iteration: b.iteration.clone(),
            radiosity_tolerance: b.radiosity_tolerance,
            bounces: b.bounces,
            prt_samples: b.prt_samples,
            prt_terms: b.prt_terms,
            prt_basis: b.prt_basis,
            prt_cache: b.prt_cache.clone(),
            polygrid_nodes: b.polygrid_nodes,
            polygrid_cube: b.polygrid_cube,
            polygrid_resolution: b.polygrid_resolution,
            polygrid_stencil: b.polygrid_stencil.clone(),
        }
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

    /// The polygrid's `[bake]` keys reach its options, as its flags do.
    #[test]
    fn polygrid_keys_reach_the_method() {
        let bake = "[bake]\nmethod = \"polygrid\"\npolygrid_nodes = 20000\npolygrid_cube = 2.5\npolygrid_resolution = 6\n\
                    polygrid_stencil = \"Finite-Volume\"\ntolerance = 1e-7\n";
        let f = SceneFile::parse(&format!("{MINIMAL}{bake}[[object]]\nmesh = \"a.obj\"\nmedium = \"marble\"\n")).unwrap();
        let method = crate::method_args::MethodArgs::default().method(&f.bake.method_defaults().unwrap()).unwrap();
        let transcut::Method::Polygrid(o) = method else { panic!("{method:?}") };
        assert_eq!((o.nodes, o.cube_mm, o.resolution), (20_000, Some(2.5), 6));
        assert_eq!((o.stencil, o.solve.tolerance), (transcut::Stencil::FiniteVolume, 1e-7));
        let f = SceneFile::parse(&format!(
            "{MINIMAL}[bake]\npolygrid_stencil = \"lsq\"\n[[object]]\nmesh = \"a.obj\"\nmedium = \"marble\"\n"
        ))
        .unwrap();
        let e = f.bake.method_defaults().unwrap_err().to_string();
        assert!(e.contains("[bake] polygrid_stencil") && e.contains("fem, finite-volume"), "{e}");
    }

    #[test]
    fn unknown_keys_are_named() {
        let err = SceneFile::parse(&format!("{MINIMAL}[render]\nexposure = 1\n")).unwrap_err().to_string();
        assert!(err.contains("exposure") && err.contains("render"), "{err}");
        let err = SceneFile::parse(&MINIMAL.replace("fov_deg", "fov")).unwrap_err().to_string();
        assert!(err.contains("fov"), "{err}");
    }

    #[test]
    fn samples_outside_the_grid_sizes_are_refused() {
        let text = format!("{MINIMAL}[render]\nsamples = 0\n[[object]]\nmesh = \"a.obj\"\nmedium = \"marble\"\n");
        let err = SceneFile::parse(&text).unwrap_err().to_string();
        assert!(err.contains("samples = 0") && err.contains("[render]"), "{err}");
        assert_eq!(SceneFile::parse(&text.replace("samples = 0", "samples = 1")).unwrap().render.samples, 1);
        // The renderer's largest grid is 8 × 8.
        assert_eq!(SceneFile::parse(&text.replace("samples = 0", "samples = 8")).unwrap().render.samples, 8);
        let err = SceneFile::parse(&text.replace("samples = 0", "samples = 9")).unwrap_err().to_string();
        assert!(err.contains("samples = 9") && err.contains("1..=8"), "{err}");
        let err = SceneFile::parse(&text.replace("samples = 0", "samples = 4000000000")).unwrap_err().to_string();
        assert!(err.contains("samples = 4000000000"), "{err}");
    }

    #[test]
    fn errors_on_long_lines_are_short_and_placed() {
        // A 100 000-byte bad value on line 8: the message names the line, not the whole text.
        let text = format!("{MINIMAL}[render]\nexposure_ev = {}\n", "x".repeat(100_000));
        let err = SceneFile::parse(&text).unwrap_err().to_string();
        assert!(err.len() < 300, "{} bytes: {}", err.len(), &err[..300]);
        assert!(err.starts_with("in table [render]: line 8, column 15: "), "{err}");
        let key = "k".repeat(5000);
        let err = SceneFile::parse(&format!("{MINIMAL}{key} = 1\n")).unwrap_err().to_string();
        assert!(err.len() < 400, "{} bytes", err.len());
    }
}
