//! What a bake is asked for: a [`Scene`] (objects with a shape, a medium and a transform;
//! lights), the [`Method`] that bakes it and the [`BakeOptions`] every method shares. The bake
//! itself is [`crate::bake()`] (every object, one method) and its result a
//! [`crate::methods::ObjectBake`] per object: the multiple-scattering radiance leaving along the
//! surface normal, Lo(x, n), linear RGB, in the units of the lights' radiance, at the user's
//! vertices in their order (ARCHITECTURE.md, "What a bake returns").

mod error;
mod material;
mod method;
mod object;
mod options;
mod scattering;

pub use error::SceneError;
pub use material::{Diffuse, Material, Sides};
pub use method::{GradingChoice, Method, PolygridOptions, RadiosityOptions, Stencil, TransCutOptions};
pub use object::{MediumSource, Object, Shape};
pub use options::BakeOptions;
pub use scattering::{HetRule, OpticalDistance, ProfileKind, ProfileScatteringOptions, TranslucentScattering};

use crate::light::{self, Light};

/// Objects and the lights that shine on them.
#[derive(Debug, Clone, Default)]
pub struct Scene {
    pub objects: Vec<Object>,
    pub lights: Vec<Light>,
}

impl Scene {
    /// Checks what every method needs before any work: at least one object, the method's
    /// options, the thread count and sample counts (each at most its documented maximum),
    /// each object's scale, transform and medium, and the lights.
    ///
    /// # Errors
    /// [`SceneError`] naming the option, object or light at fault.
    pub fn validate(&self, options: &BakeOptions) -> Result<(), SceneError> {
        if self.objects.is_empty() {
            return Err(SceneError::NoObjects);
        }
        options.method.validate().map_err(SceneError::InvalidOptions)?;
        crate::workers::thread_count(options.threads).map_err(|e| SceneError::InvalidOptions(e.to_string()))?;
        options.source.validate()?;
        for (index, o) in self.objects.iter().enumerate() {
            o.validate().map_err(|message| SceneError::InvalidObject { index, name: o.name.clone(), message })?;
        }
        light::validate_lights(&self.lights)?;
        Ok(())
    }
}
