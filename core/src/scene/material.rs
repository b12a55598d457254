//! What an object's surface does with light: a translucent medium under it (every subsurface
//! method), or an opaque Lambertian surface that reflects, absorbs and may emit (the
//! surroundings that only translucent radiosity couples with the translucent objects,
//! design/radiosity.md "Scene growth").

use super::object::MediumSource;
use super::Shape;
use crate::optics::Medium;

/// What an object is made of.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum Material {
    /// A translucent volume: light enters, scatters inside and leaves elsewhere.
    Translucent(MediumSource),
    /// An opaque Lambertian surface (walls, floors, other objects): surface only, no volume, so
    /// it may be open (a plane, a scan).
    Diffuse(Diffuse),
}

impl From<MediumSource> for Material {
    fn from(medium: MediumSource) -> Self {
        Self::Translucent(medium)
    }
}

impl From<Medium> for Material {
    fn from(medium: Medium) -> Self {
        Self::Translucent(MediumSource::Homogeneous(medium))
    }
}

impl From<Diffuse> for Material {
    fn from(diffuse: Diffuse) -> Self {
        Self::Diffuse(diffuse)
    }
}

impl Material {
    /// The translucent medium, or `None` for an opaque surface.
    #[must_use]
    pub fn medium(&self) -> Option<&MediumSource> {
        match self {
            Self::Translucent(m) => Some(m),
            Self::Diffuse(_) => None,
        }
    }

    /// The opaque surface, or `None` for a translucent medium.
    #[must_use]
    pub fn diffuse(&self) -> Option<&Diffuse> {
        match self {
            Self::Diffuse(d) => Some(d),
            Self::Translucent(_) => None,
        }
    }

    /// `translucent` or `diffuse`, the scene files' `kind`.
    #[must_use]
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Translucent(_) => "translucent",
            Self::Diffuse(_) => "diffuse",
        }
    }

    /// Checks what can be checked without meshing ([`MediumSource::validate`],
    /// [`Diffuse::validate`]).
    ///
    /// # Errors
    /// A message naming the invalid value.
    pub fn validate(&self, shape: &Shape) -> Result<(), String> {
        match self {
            Self::Translucent(m) => m.validate(shape),
            Self::Diffuse(d) => d.validate(),
        }
    }
}

/// Which sides of an opaque surface reflect light: the others absorb whatever reaches them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Sides {
    /// Both sides, each with its own radiosity (a wall seen from either side, as renderers draw
    /// diffuse surfaces).
    #[default]
    Both,
    /// The side the surface's normals point to: the outside of a closed shell (shells are
    /// oriented outwards when the mesh is built), the side of the winding of most of the area
    /// of an open one.
    Front,
    /// The other side: the inside of a closed shell (a room modelled as a box, an enclosure).
    Back,
}

impl Sides {
    /// Every name, in the order front ends list them.
    pub const NAMES: [&'static str; 3] = ["both", "front", "back"];

    /// The name front ends use.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Both => "both",
            Self::Front => "front",
            Self::Back => "back",
        }
    }

    /// The sides called `name` (any case), or `None`.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        match name.trim().to_ascii_lowercase().as_str() {
            "both" => Some(Self::Both),
            "front" => Some(Self::Front),
            "back" => Some(Self::Back),
            _ => None,
        }
    }
}

/// An opaque Lambertian surface: it reflects the fraction `albedo` of the irradiance E it gets,
/// uniformly in every direction, and emits `emission`, so its radiosity is B = ρE + M and its
/// radiance B/π (Sheng et al. 2014 eq. 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Diffuse {
    /// The reflectance ρ per channel, linear RGB, each in [0, 1) (1 would reflect everything
    /// and a closed room of it would never converge).
    pub albedo: [f64; 3],
    /// The emitted exitance M per channel, in the units of the lights' irradiance (a surface
    /// emitting M alone has radiance M/π), each finite and ≥ 0.
    pub emission: [f64; 3],
    /// Which sides reflect (and emit).
    pub sides: Sides,
}

impl Default for Diffuse {
    /// A white wall of the Cornell box (albedo 0.73), not emitting, both sides.
    fn default() -> Self {
        Self::new([0.73; 3])
    }
}

impl Diffuse {
    /// A surface of `albedo`, not emitting, reflecting on both sides.
    #[must_use]
    pub fn new(albedo: [f64; 3]) -> Self {
        Self { albedo, emission: [0.0; 3], sides: Sides::Both }
    }

    /// Checks the albedo and the emission.
    ///
    /// # Errors
    /// A message naming the value out of range.
    pub fn validate(&self) -> Result<(), String> {
        if !self.albedo.iter().all(|a| (0.0..1.0).contains(a)) {
            return Err(format!("the albedo must lie in [0, 1) in every channel, got {:?}", self.albedo));
        }
        if !self.emission.iter().all(|m| m.is_finite() && *m >= 0.0) {
            return Err(format!("the emission must be finite and ≥ 0 in every channel, got {:?}", self.emission));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn albedo_and_emission_out_of_range_are_named() {
        assert_eq!(Diffuse::default().validate(), Ok(()));
        let with = |albedo, emission| Diffuse { albedo, emission, sides: Sides::Both }.validate();
        assert!(with([1.0, 0.5, 0.5], [0.0; 3]).unwrap_err().contains("albedo"));
        assert!(with([f64::NAN, 0.5, 0.5], [0.0; 3]).unwrap_err().contains("albedo"));
        assert!(with([-0.1, 0.5, 0.5], [0.0; 3]).unwrap_err().contains("albedo"));
        assert!(with([0.5; 3], [0.0, -1.0, 0.0]).unwrap_err().contains("emission"));
        assert!(with([0.5; 3], [f64::INFINITY, 0.0, 0.0]).unwrap_err().contains("emission"));
        assert_eq!(with([0.0; 3], [3.0; 3]), Ok(()));
    }

    #[test]
    fn side_names_round_trip() {
        for name in Sides::NAMES {
            assert_eq!(Sides::from_name(&name.to_uppercase()).map(Sides::name), Some(name));
        }
        assert_eq!(Sides::from_name("inside"), None);
    }
}
