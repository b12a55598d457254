//! [`Veins`]: marble-like veins from seeded gradient noise with fractal turbulence.
//!
//! The classic marble texture (Perlin, *An Image Synthesizer*, SIGGRAPH 1985): a sine of a
//! distance along a direction, its phase perturbed by turbulence,
//!
//! ```text
//! φ(x) = 2π (d̂·x)/period + turbulence · T(x / noise_scale),
//! T(p) = Σ_{o<octaves} 2^{−o} |n(2^o p)|          (n: seeded improved Perlin noise)
//! w(x) = ((1 + sin φ(x)) / 2)^sharpness ∈ [0, 1]
//! σ(x) = (1 − w) σ_base + w σ_vein                 (σa and σ′s, per channel)
//! ```
//!
//! so veins are the crests of the sine (thinner for a larger `sharpness`), one every `period`
//! along `direction` before the turbulence bends them. Positions are in the mesh's scene
//! units. The same seed and parameters give bit-identical media on every run and thread count.

use glam::DVec3;

use super::error::VolumeError;
use super::field::{Coefficients, MediumField, TetSampling};
use super::noise::PerlinNoise;
use super::per_tet::PerTetMedia;
use crate::mesh::TetMesh;
use crate::optics::Medium;

/// Shape parameters of [`Veins`]; lengths in scene units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VeinParams {
    /// Direction across the (unperturbed) veins; any finite non-zero length.
    pub direction: DVec3,
    /// Distance between veins along `direction` (scene units), finite and > 0.
    pub period: f64,
    /// Amplitude of the turbulence added to the phase (radians), finite and ≥ 0; 0 gives
    /// straight parallel bands.
    pub turbulence: f64,
    /// Size of the coarsest turbulence feature (scene units), finite and > 0.
    pub noise_scale: f64,
    /// Octaves of the turbulence sum, at most 24.
    pub octaves: u32,
    /// Exponent of the vein weight, finite and > 0: 1 gives soft bands, larger values thin veins.
    pub sharpness: f64,
}

impl Default for VeinParams {
    /// Veins across x, one per scene unit, bent by five octaves of turbulence of amplitude 4
    /// radians at the scale of the period, sharpness 3.
    fn default() -> Self {
        Self { direction: DVec3::X, period: 1.0, turbulence: 4.0, noise_scale: 1.0, octaves: 5, sharpness: 3.0 }
    }
}

/// Marble-like veins between a base and a vein medium (see the module documentation).
///
/// η and g of the object: the base and vein media must have the same η (both reach the
/// surface; one η per object, see [`PerTetMedia`]); g is the base medium's.
#[derive(Debug, Clone, PartialEq)]
pub struct Veins {
    base: Medium,
    vein: Medium,
    params: VeinParams,
    /// `direction` normalised and divided by `period`, times 2π.
    wave: DVec3,
    noise: PerlinNoise,
}

impl Veins {
    /// Veins of `vein` in `base`, the noise seeded by `seed`.
    ///
    /// # Errors
    /// [`VolumeError::InvalidMedium`] (`"vein medium"`, 0 = base, 1 = vein) for an invalid
    /// medium; [`VolumeError::MixedObjectParameter`] when their η differ;
    /// [`VolumeError::InvalidParameter`] naming a parameter out of range.
    pub fn new(base: Medium, vein: Medium, seed: u64, params: VeinParams) -> Result<Self, VolumeError> {
        for (index, m) in [base, vein].iter().enumerate() {
            m.validate().map_err(|source| VolumeError::InvalidMedium { what: "vein medium", index, source })?;
        }
        if base.eta != vein.eta {
            return Err(VolumeError::MixedObjectParameter {
                field: "eta",
                what: "vein medium",
                first: 0,
                first_value: base.eta,
                other: 1,
                other_value: vein.eta,
            });
        }
        let p = params;
        let len = p.direction.length();
        if !(len.is_finite() && len > 0.0) {
            return Err(VolumeError::InvalidParameter {
                field: "direction",
                value: len,
                requirement: "the direction's length must be finite and > 0",
            });
        }
        positive("period", p.period)?;
        positive("noise_scale", p.noise_scale)?;
        positive("sharpness", p.sharpness)?;
        if !(p.turbulence.is_finite() && p.turbulence >= 0.0) {
            return Err(VolumeError::InvalidParameter {
                field: "turbulence",
                value: p.turbulence,
                requirement: "must be finite and >= 0 (radians)",
            });
        }
        if p.octaves > 24 {
            return Err(VolumeError::InvalidParameter {
                field: "octaves",
                value: f64::from(p.octaves),
                requirement: "must be at most 24",
            });
        }
        let wave = p.direction / len * (2.0 * std::f64::consts::PI / p.period);
        Ok(Self { base, vein, params, wave, noise: PerlinNoise::new(seed) })
    }

    /// The base medium.
    #[must_use]
    pub fn base(&self) -> &Medium {
        &self.base
    }

    /// The vein medium.
    #[must_use]
    pub fn vein(&self) -> &Medium {
        &self.vein
    }

    /// The shape parameters.
    #[must_use]
    pub fn params(&self) -> &VeinParams {
        &self.params
    }

    /// The seed of the noise.
    #[must_use]
    pub fn seed(&self) -> u64 {
        self.noise.seed()
    }

    /// The vein weight w(x) = ((1 + sin φ(x))/2)^sharpness ∈ [0, 1] at `p` (scene units):
    /// 0 = base, 1 = vein.
    #[must_use]
    pub fn weight(&self, p: DVec3) -> f64 {
        let t = self.noise.turbulence(p / self.params.noise_scale, self.params.octaves);
        let phase = self.wave.dot(p) + self.params.turbulence * t;
        (0.5 * (1.0 + phase.sin())).clamp(0.0, 1.0).powf(self.params.sharpness)
    }

    /// The per-tet media of `mesh` with the rule `sampling`; η of the two media, g of the base.
    ///
    /// # Errors
    /// Never for veins built by [`Veins::new`], which checks the media and parameters (every
    /// sample is a convex combination of the two valid media); the `Result` matches the other
    /// sources.
    pub fn per_tet(&self, mesh: &TetMesh, sampling: TetSampling) -> Result<PerTetMedia, VolumeError> {
        PerTetMedia::from_field(mesh, self, self.base.eta, self.base.g, sampling)
    }
}

impl MediumField for Veins {
    fn coefficients(&self, p: DVec3) -> Coefficients {
        Coefficients::from(&self.base).lerp(&Coefficients::from(&self.vein), self.weight(p))
    }
}

fn positive(field: &'static str, value: f64) -> Result<(), VolumeError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(VolumeError::InvalidParameter { field, value, requirement: "must be finite and > 0" })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn media() -> (Medium, Medium) {
        let base = Medium::preset("marble").unwrap();
        let vein = Medium { sigma_a: [0.2, 0.25, 0.3], sigma_s_prime: [1.0, 1.1, 1.2], ..base };
        (base, vein)
    }

    #[test]
    fn without_turbulence_veins_are_the_sine_crests() {
        let (base, vein) = media();
        let params = VeinParams { turbulence: 0.0, period: 2.0, sharpness: 1.0, ..VeinParams::default() };
        let v = Veins::new(base, vein, 1, params).unwrap();
        // φ = 2π x / 2: crest (w = 1) at x = 0.5, trough (w = 0) at x = 1.5, w = 1/2 at x = 0.
        assert!((v.weight(DVec3::new(0.5, 3.0, -1.0)) - 1.0).abs() < 1e-15);
        assert!(v.weight(DVec3::new(1.5, 0.0, 0.0)).abs() < 1e-15);
        assert!((v.weight(DVec3::ZERO) - 0.5).abs() < 1e-15);
        assert_eq!(v.coefficients(DVec3::new(1.5, 0.0, 0.0)), Coefficients::from(&base));
        let c = v.coefficients(DVec3::new(0.5, 0.0, 0.0));
        for ch in 0..3 {
            assert!((c.sigma_a[ch] - vein.sigma_a[ch]).abs() < 1e-15);
        }
    }

    #[test]
    fn weights_are_deterministic_in_range_and_seed_dependent() {
        let (base, vein) = media();
        let a = Veins::new(base, vein, 5, VeinParams::default()).unwrap();
        let b = Veins::new(base, vein, 5, VeinParams::default()).unwrap();
        let c = Veins::new(base, vein, 6, VeinParams::default()).unwrap();
        let mut differ = 0;
        for i in 0..200 {
            let p = DVec3::new(i as f64 * 0.037, (i as f64 * 0.61).sin(), (i % 13) as f64 * 0.11);
            let w = a.weight(p);
            assert!((0.0..=1.0).contains(&w));
            assert_eq!(w, b.weight(p));
            differ += usize::from(w != c.weight(p));
        }
        assert!(differ > 150, "{differ}");
    }

    #[test]
    fn invalid_parameters_are_named() {
        let (base, vein) = media();
        let other_eta = Medium { eta: base.eta + 0.1, ..vein };
        assert!(matches!(
            Veins::new(base, other_eta, 0, VeinParams::default()),
            Err(VolumeError::MixedObjectParameter { field: "eta", .. })
        ));
        let bad = Medium { sigma_a: [f64::NAN; 3], ..vein };
        assert!(matches!(Veins::new(base, bad, 0, VeinParams::default()), Err(VolumeError::InvalidMedium { index: 1, .. })));
        for (params, field) in [
            (VeinParams { direction: DVec3::ZERO, ..VeinParams::default() }, "direction"),
            (VeinParams { period: 0.0, ..VeinParams::default() }, "period"),
            (VeinParams { noise_scale: f64::INFINITY, ..VeinParams::default() }, "noise_scale"),
            (VeinParams { sharpness: -1.0, ..VeinParams::default() }, "sharpness"),
            (VeinParams { turbulence: f64::NAN, ..VeinParams::default() }, "turbulence"),
            (VeinParams { octaves: 40, ..VeinParams::default() }, "octaves"),
        ] {
            let e = Veins::new(base, vein, 0, params).unwrap_err();
            assert!(matches!(e, VolumeError::InvalidParameter { field: f, .. } if f == field), "{e}");
        }
    }
}
