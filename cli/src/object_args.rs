//! What `bake` and `animate` share about the object they bake: its medium, its size
//! (millimetres per mesh unit) and the lights, and the help text of their forms.

use std::path::Path;

use anyhow::{bail, Context};
use clap::Args;
use transcut::light::{Environment, Light};
use transcut::mesh::TriMesh;
use transcut::Scene;

use crate::method_args::{method_help, MethodArgs};
use crate::spec;

/// The forms of `--light`, `--method` and `--medium`, for a command's help.
pub const FORMS_HELP: &str = "Light forms (repeat --light for several):
  sun:dir=X,Y,Z,irradiance=E[,angle=DEG]     direction the light travels; E or R,G,B
  point:pos=X,Y,Z,intensity=I                 W/sr; I or R,G,B
  spot:pos=X,Y,Z,dir=X,Y,Z,intensity=I[,angle=DEG][,blend=B]
  env:radiance=R,G,B                          constant sky
  env:file=sky.hdr[,strength=S]               equirectangular .hdr or .exr

Methods: `--method help` lists them.

Medium forms:
  marble | skin1 | … (see `--medium help`)    measured presets (Jensen et al. 2001)
  sigma_a=R,G,B:sigma_s=R,G,B:eta=E[:g=G]     mm⁻¹; sigma_s is the reduced σ′s";

/// The medium, size and lights of the object a command bakes.
#[derive(Args)]
pub struct ObjectArgs {
    /// The medium: a preset name or coefficients (see below).
    #[arg(long, default_value = "marble")]
    pub medium: String,
    /// Millimetres per mesh unit (media are in mm⁻¹, so this sets how translucent the object is).
    #[arg(long, default_value_t = 1.0)]
    pub scale: f64,
    /// A light (repeatable; see below). Without one, a white sky of radiance 1 is used.
    #[arg(long = "light")]
    pub lights: Vec<String>,
}

impl ObjectArgs {
    /// Prints what `--medium help` or `--method help` asks for; whether either was asked.
    pub fn print_help(&self, method: &MethodArgs) -> bool {
        if self.medium == "help" {
            println!("presets: {}", transcut::optics::PRESET_NAMES.join(", "));
        } else if method.wants_help() {
            print!("{}", method_help());
        } else {
            return false;
        }
        true
    }

    /// The scene of the mesh file `input` ([`ObjectArgs::scene`], named after the file), and the
    /// mesh.
    ///
    /// # Errors
    /// A file that cannot be loaded, naming it; those of [`ObjectArgs::scene`].
    pub fn load_scene(&self, input: &Path) -> anyhow::Result<(Scene, TriMesh)> {
        let mesh = transcut::mesh::load(input).with_context(|| format!("loading {}", input.display()))?;
        Ok((self.scene(object_name(input), mesh.clone())?, mesh))
    }

    /// The scene of one object, `mesh` named `name` in the medium at the scale, under the
    /// lights (a white sky without any).
    ///
    /// # Errors
    /// A bad medium or light spec, a scale that is not a positive number.
    pub fn scene(&self, name: String, mesh: TriMesh) -> anyhow::Result<Scene> {
        let medium = spec::medium(&self.medium)?;
        let mut lights = self.lights.iter().map(|s| spec::light(s)).collect::<anyhow::Result<Vec<_>>>()?;
        if lights.is_empty() {
            lights.push(Light::Environment(Environment::Constant([1.0; 3])));
        }
        if !(self.scale.is_finite() && self.scale > 0.0) {
            bail!("--scale must be a positive number of millimetres per unit, got {}", transcut::input::fmt_num(self.scale));
        }
        Ok(Scene { objects: vec![transcut::Object::new(name, mesh, medium, self.scale)], lights })
    }
}

/// The name of the object a mesh file holds: its file name without the extension.
pub fn object_name(path: &Path) -> String {
    path.file_stem().map_or_else(|| "object".into(), |s| s.to_string_lossy().into_owned())
}
