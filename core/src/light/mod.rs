//! Lights, environment lighting, and the transmitted source at surface points.
//!
//! The diffusion solver needs, at every boundary point x with outward unit normal n, the power
//! per unit area that crosses the surface into the medium (ARCHITECTURE.md, "The equations"):
//!
//! q(x) = ∫ Li(x, ω) (n·ω)⁺ T(η, ω) dω,
//!
//! Li the radiance arriving from direction ω (unit vector from x towards the light), and
//! T(η, ω) = 1 − R(cos θ, η) the exact dielectric Fresnel transmittance for light entering the
//! medium of index η from air at incidence cos θ = n·ω ([`crate::optics::fresnel_transmittance`]
//! with relative index η). [`transmitted_source`] evaluates it per RGB channel for any mix of
//! [`Light`]s, optionally with shadows cast by a [`TriangleBvh`](crate::mesh::TriangleBvh);
//! [`irradiance`] is the same integral without T.
//!
//! | light | q(x) |
//! |---|---|
//! | directional, delta | E (n·ω)⁺ T(η, n·ω) V, ω = −direction |
//! | directional, a sun disc of angular diameter 2α | ∫ over the cone of L = E/(π sin²α) |
//! | point | I (n·ω)⁺ T V / d² |
//! | spot | I s(cos ψ) (n·ω)⁺ T V / d², s the cone falloff ([`spot_falloff`]) |
//! | rectangle, disc | ∫_A L (n·ω)⁺ T V cos θ_l / d² dA |
//! | constant environment, unshadowed | π L (1 − F_ext(η)) exactly |
//! | equirect environment, unshadowed | SH9 convolution with the lobe μ⁺T(η, μ) ([`sh`]) |
//! | environment, shadowed | cosine-weighted / map importance samples with shadow rays |
//!
//! V ∈ {0, 1} is the visibility of the light from x + b n (b the shadow bias) along ω.
//! Delta lights are exact; everything sampled uses stratified, seeded, Owen-scrambled Sobol
//! points keyed by (seed, light, point), so results do not depend on the number of threads.
//!
//! # Example
//!
//! A white sky of radiance 1 and an overhead sun of irradiance 2 on a horizontal surface at
//! η = 1.3: q = π(1 − F_ext) + 2·T(η, 0°) = 2.9495 + 2 × 0.98299.
//!
//! ```
//! use transcut::light::{transmitted_source, Environment, Light, SourceOptions};
//! use transcut::DVec3;
//!
//! let lights = [
//!     Light::Environment(Environment::Constant([1.0; 3])),
//!     Light::Directional { direction: DVec3::NEG_Z, irradiance: [2.0; 3], angular_diameter_deg: 0.0 },
//! ];
//! let q = transmitted_source(&lights, &[DVec3::ZERO], &[DVec3::Z], 1.3, None, &SourceOptions::default())?;
//! let t0 = 1.0 - (0.3f64 / 2.3).powi(2); // normal-incidence transmittance
//! assert!((q[0][0] - (2.9495 + 2.0 * t0)).abs() < 1e-4);
//! # Ok::<(), transcut::light::LightError>(())
//! ```

mod environment;
mod error;
mod polygon;
pub(crate) mod sampling;
pub mod sh;
mod shaft;
mod source;

use glam::DVec3;

use crate::input::{fmt_num, fmt_vec};

pub use environment::{direction_to_equirect, equirect_to_direction, luminance, EnvSample, Environment, EquirectMap, LUMINANCE};
pub use error::LightError;
pub use source::{
    add_irradiance, irradiance, spot_falloff, transmitted_source, transmitted_source_and_unshadowed, transmitted_source_with,
    EnvironmentMethod, Poll, ShadowedAndUnshadowed, SourceOptions,
};
pub(crate) use source::{bounding_diagonal, check_eta, check_inputs};

/// A light source, in scene units. Radiometric quantities are linear RGB.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Light {
    /// Parallel light from infinitely far away (a sun).
    Directional {
        /// The direction the light travels (from the sun towards the scene); need not be unit.
        direction: DVec3,
        /// Irradiance E on a surface facing the light (W/m² per channel, or any consistent unit).
        irradiance: [f64; 3],
        /// Apparent angular diameter in degrees, in [0, 180): 0 is a delta light with hard
        /// shadows; larger values make a disc-shaped sun of uniform radiance E/(π sin²α),
        /// α = half the diameter, sampled with `area_samples` stratified directions (soft
        /// shadows). Blender's sun "angle" is this diameter.
        angular_diameter_deg: f64,
    },
    /// An isotropic point light: irradiance I cos θ / d².
    Point {
        /// Position.
        position: DVec3,
        /// Radiant intensity I (W/sr per channel).
        intensity: [f64; 3],
    },
    /// A point light restricted to a cone with a smooth edge.
    Spot {
        /// Position.
        position: DVec3,
        /// Axis of the cone (the direction the light shines in); need not be unit.
        direction: DVec3,
        /// Radiant intensity I along the axis (W/sr per channel).
        intensity: [f64; 3],
        /// Half-angle of the cone in degrees, in (0, 90] (Blender's spot size is twice this).
        cone_half_angle_deg: f64,
        /// Fraction of the cone, in [0, 1], over which the intensity falls smoothly to zero
        /// (Blender's spot blend; [`spot_falloff`]).
        blend: f64,
    },
    /// A parallelogram (normally a rectangle) of uniform radiance.
    RectArea {
        /// Centre.
        center: DVec3,
        /// Half of one side, as a vector from the centre.
        half_u: DVec3,
        /// Half of the other side.
        half_v: DVec3,
        /// Emitted radiance L (per channel).
        radiance: [f64; 3],
        /// Whether it emits from both faces; otherwise only along half_u × half_v.
        two_sided: bool,
    },
    /// A disc of uniform radiance.
    DiscArea {
        /// Centre.
        center: DVec3,
        /// The side it emits towards (need not be unit).
        normal: DVec3,
        /// Radius.
        radius: f64,
        /// Emitted radiance L (per channel).
        radiance: [f64; 3],
        /// Whether it emits from both faces; otherwise only along `normal`.
        two_sided: bool,
    },
    /// Distant light from every direction.
    Environment(Environment),
}

/// Checks every light of a list ([`Light::validate`] with the light's index).
///
/// # Errors
/// The first [`LightError::InvalidLight`] found.
pub fn validate_lights(lights: &[Light]) -> Result<(), LightError> {
    lights.iter().enumerate().try_for_each(|(i, l)| l.validate(i))
}

impl Light {
    /// Whether the light reaches a point from a single direction (a point, a spot, a sun of no
    /// size): its shadows are hard, all or nothing at each point.
    #[must_use]
    pub fn is_delta(&self) -> bool {
        match self {
            Light::Directional { angular_diameter_deg, .. } => *angular_diameter_deg == 0.0,
            Light::Point { .. } | Light::Spot { .. } => true,
            Light::RectArea { .. } | Light::DiscArea { .. } | Light::Environment(_) => false,
        }
    }

    /// The light as its strength per channel times the same light at unit strength (intensity,
    /// irradiance or radiance 1 in every channel; an equirectangular map at multiplier 1, its
    /// strength the multiplier in each channel): `(unit, strength)`. Light transport is linear
    /// in each channel, so what `self` lights is `strength ⊙` what `unit` lights, and two lights
    /// of the same `unit` differ in colour and brightness only (a radiosity session reuses
    /// their solution).
    #[must_use]
    pub fn split_strength(&self) -> (Light, [f64; 3]) {
        let mut unit = self.clone();
        let strength = match &mut unit {
            Light::Directional { irradiance: s, .. }
            | Light::Point { intensity: s, .. }
            | Light::Spot { intensity: s, .. }
            | Light::RectArea { radiance: s, .. }
            | Light::DiscArea { radiance: s, .. }
            | Light::Environment(Environment::Constant(s)) => std::mem::replace(s, [1.0; 3]),
            Light::Environment(Environment::Equirect(map)) => {
                let m = map.intensity();
                map.set_intensity(1.0).expect("1 is a valid multiplier");
                [m; 3]
            }
        };
        (unit, strength)
    }

    /// A short name of the kind of light, as used in error messages.
    #[must_use]
    pub fn kind(&self) -> &'static str {
        match self {
            Light::Directional { .. } => "directional",
            Light::Point { .. } => "point",
            Light::Spot { .. } => "spot",
            Light::RectArea { .. } => "rect area",
            Light::DiscArea { .. } => "disc area",
            Light::Environment(Environment::Constant(_)) => "constant environment",
            Light::Environment(Environment::Equirect(_)) => "equirect environment",
        }
    }

    /// Checks the light's fields; `index` is its position in the caller's list and is quoted in
    /// the error.
    ///
    /// Rejected: NaN or infinite values anywhere, negative radiance / irradiance / intensity,
    /// zero directions and normals, a spot cone half-angle outside (0°, 90°] or blend outside
    /// [0, 1], a sun diameter outside [0°, 180°), a non-positive disc radius, a rectangle with a
    /// zero side or zero area. (An [`EquirectMap`] checks its size, buffer length, texels and
    /// multiplier when it is built.)
    ///
    /// # Errors
    /// [`LightError::InvalidLight`] naming the index, kind and field.
    pub fn validate(&self, index: usize) -> Result<(), LightError> {
        let kind = self.kind();
        let err = |field: &'static str, value: String, requirement: &'static str| LightError::InvalidLight {
            index,
            kind,
            field,
            value,
            requirement,
        };
        let finite_point = |field: &'static str, p: DVec3| {
            if p.is_finite() {
                Ok(())
            } else {
                Err(err(field, fmt_vec(&p.to_array()), "must be finite"))
            }
        };
        let direction = |field: &'static str, d: DVec3| {
            if !d.is_finite() {
                Err(err(field, fmt_vec(&d.to_array()), "must be finite"))
            } else if d.length_squared() < f64::MIN_POSITIVE {
                Err(err(field, fmt_vec(&d.to_array()), "must be a non-zero vector"))
            } else {
                Ok(())
            }
        };
        let colour = |field: &'static str, c: [f64; 3]| {
            if c.iter().all(|v| v.is_finite() && *v >= 0.0) {
                Ok(())
            } else {
                Err(err(field, format!("{c:?}"), "every channel must be finite and ≥ 0"))
            }
        };
        match self {
            Light::Directional { direction: d, irradiance, angular_diameter_deg } => {
                direction("direction", *d)?;
                colour("irradiance", *irradiance)?;
                if !(0.0..180.0).contains(angular_diameter_deg) {
                    return Err(err("angular_diameter_deg", fmt_num(*angular_diameter_deg), "must be in [0, 180) degrees"));
                }
            }
            Light::Point { position, intensity } => {
                finite_point("position", *position)?;
                colour("intensity", *intensity)?;
            }
            Light::Spot { position, direction: d, intensity, cone_half_angle_deg, blend } => {
                finite_point("position", *position)?;
                direction("direction", *d)?;
                colour("intensity", *intensity)?;
                if !(*cone_half_angle_deg > 0.0 && *cone_half_angle_deg <= 90.0) {
                    return Err(err("cone_half_angle_deg", fmt_num(*cone_half_angle_deg), "must be in (0, 90] degrees"));
                }
                if !(0.0..=1.0).contains(blend) {
                    return Err(err("blend", fmt_num(*blend), "must be in [0, 1]"));
                }
            }
            Light::RectArea { center, half_u, half_v, radiance, .. } => {
                finite_point("center", *center)?;
                direction("half_u", *half_u)?;
                direction("half_v", *half_v)?;
                let has_area = half_u.cross(*half_v).length() > 1e-12 * half_u.length() * half_v.length();
                if !has_area {
                    return Err(err(
                        "half_v",
                        fmt_vec(&half_v.to_array()),
                        "must not be parallel to half_u (the rectangle has zero area)",
                    ));
                }
                colour("radiance", *radiance)?;
            }
            Light::DiscArea { center, normal, radius, radiance, .. } => {
                finite_point("center", *center)?;
                direction("normal", *normal)?;
                if !(radius.is_finite() && *radius > 0.0) {
                    return Err(err("radius", fmt_num(*radius), "must be finite and > 0"));
                }
                colour("radiance", *radiance)?;
            }
            Light::Environment(Environment::Constant(l)) => colour("radiance", *l)?,
            // Checked on construction; nothing can be wrong with a built map.
            Light::Environment(Environment::Equirect(_)) => {}
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field_of(r: Result<(), LightError>) -> &'static str {
        match r {
            Err(LightError::InvalidLight { field, .. }) => field,
            other => panic!("expected InvalidLight, got {other:?}"),
        }
    }

    #[test]
    fn a_light_is_its_strength_times_its_unit_light() {
        let lights = [
            Light::Point { position: DVec3::new(0.3, -0.2, 2.0), intensity: [0.5, 2.0, 0.0] },
            Light::RectArea {
                center: DVec3::new(0.0, 0.0, 1.5),
                half_u: DVec3::X * 0.4,
                half_v: DVec3::Y * 0.3,
                radiance: [3.0, 1.0, 0.25],
                two_sided: true,
            },
            Light::Environment(Environment::Constant([0.2, 0.4, 0.8])),
        ];
        let points = [DVec3::ZERO, DVec3::new(0.5, 0.1, 0.0)];
        let normals = [DVec3::Z, DVec3::new(0.0, 0.6, 0.8)];
        let options = SourceOptions::default();
        for light in &lights {
            let (unit, strength) = light.split_strength();
            let (again, ones) = unit.split_strength();
            assert_eq!((again, ones), (unit.clone(), [1.0; 3]), "a unit light is its own unit");
            let whole = irradiance(std::slice::from_ref(light), &points, &normals, None, &options).unwrap();
            let part = irradiance(std::slice::from_ref(&unit), &points, &normals, None, &options).unwrap();
            for (w, p) in whole.iter().zip(&part) {
                for c in 0..3 {
                    assert!(
                        (w[c] - strength[c] * p[c]).abs() <= 1e-12 * w[c].abs().max(1e-300),
                        "{}: {w:?} vs {p:?}",
                        light.kind()
                    );
                }
            }
            assert!(part.iter().all(|p| p.iter().all(|&x| x > 0.0)), "{}: the points are lit", light.kind());
        }
    }

    #[test]
    fn good_lights_pass() {
        let lights = [
            Light::Directional { direction: DVec3::NEG_Z, irradiance: [1.0; 3], angular_diameter_deg: 0.5 },
            Light::Point { position: DVec3::ONE, intensity: [0.0, 1.0, 2.0] },
            Light::Spot {
                position: DVec3::ZERO,
                direction: DVec3::X,
                intensity: [1.0; 3],
                cone_half_angle_deg: 90.0,
                blend: 1.0,
            },
            Light::RectArea {
                center: DVec3::ZERO,
                half_u: DVec3::X,
                half_v: DVec3::new(0.5, 1.0, 0.0),
                radiance: [1.0; 3],
                two_sided: false,
            },
            Light::DiscArea { center: DVec3::ZERO, normal: DVec3::Z, radius: 0.1, radiance: [1.0; 3], two_sided: true },
            Light::Environment(Environment::Constant([0.2; 3])),
        ];
        validate_lights(&lights).unwrap();
    }

    #[test]
    fn bad_fields_are_named() {
        let sun = |d: DVec3, e: [f64; 3], a: f64| Light::Directional { direction: d, irradiance: e, angular_diameter_deg: a };
        assert_eq!(field_of(sun(DVec3::ZERO, [1.0; 3], 0.0).validate(0)), "direction");
        assert_eq!(field_of(sun(DVec3::new(f64::NAN, 0.0, 1.0), [1.0; 3], 0.0).validate(0)), "direction");
        assert_eq!(field_of(sun(DVec3::Z, [1.0, -1.0, 0.0], 0.0).validate(0)), "irradiance");
        assert_eq!(field_of(sun(DVec3::Z, [1.0; 3], 180.0).validate(0)), "angular_diameter_deg");
        assert_eq!(field_of(sun(DVec3::Z, [1.0; 3], f64::NAN).validate(0)), "angular_diameter_deg");
        let spot = |half: f64, blend: f64| Light::Spot {
            position: DVec3::ZERO,
            direction: DVec3::X,
            intensity: [1.0; 3],
            cone_half_angle_deg: half,
            blend,
        };
        assert_eq!(field_of(spot(0.0, 0.5).validate(0)), "cone_half_angle_deg");
        assert_eq!(field_of(spot(90.5, 0.5).validate(0)), "cone_half_angle_deg");
        assert_eq!(field_of(spot(30.0, 1.5).validate(0)), "blend");
        let disc = Light::DiscArea { center: DVec3::ZERO, normal: DVec3::Z, radius: 0.0, radiance: [1.0; 3], two_sided: false };
        assert_eq!(field_of(disc.validate(0)), "radius");
        let rect = Light::RectArea {
            center: DVec3::ZERO,
            half_u: DVec3::X,
            half_v: DVec3::X * 2.0,
            radiance: [1.0; 3],
            two_sided: false,
        };
        assert_eq!(field_of(rect.validate(0)), "half_v");
        let point = Light::Point { position: DVec3::new(0.0, f64::INFINITY, 0.0), intensity: [1.0; 3] };
        assert_eq!(field_of(point.validate(0)), "position");
        assert_eq!(field_of(Light::Environment(Environment::Constant([f64::NAN; 3])).validate(0)), "radiance");
    }

    #[test]
    fn the_index_is_reported() {
        let lights = [
            Light::Point { position: DVec3::ZERO, intensity: [1.0; 3] },
            Light::Point { position: DVec3::ZERO, intensity: [-1.0; 3] },
        ];
        match validate_lights(&lights) {
            Err(e @ LightError::InvalidLight { index: 1, kind: "point", field: "intensity", .. }) => {
                assert!(e.to_string().starts_with("light 1 (point): intensity"), "{e}");
            }
            other => panic!("{other:?}"),
        }
    }
}
