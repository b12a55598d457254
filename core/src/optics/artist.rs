//! Artist parameters, as Blender's Principled BSDF exposes subsurface scattering, and their
//! conversion to and from physical coefficients.
//!
//! The mapping (inverse diffuse-albedo relation of the classical dipole, Jensen et al. 2001;
//! the same idea as Jensen & Buhler 2002, who set translucency from a diffuse albedo and a mean
//! free path):
//!
//! 1. α′ = Rd⁻¹(albedo; η): the reduced albedo whose total diffuse reflectance
//!    Rd = (α′/2)(1 + e^{−(4/3)A√(3(1−α′))}) e^{−√(3(1−α′))} equals the subsurface colour
//!    ([`reduced_albedo_from_rd`](super::reduced_albedo_from_rd));
//! 2. ℓ = radius · scale · mm_per_unit (mm), read as the **reduced mean free path**
//!    ℓ = 1/σ′t, so σ′t = 1/ℓ;
//! 3. σ′s = α′ σ′t and σa = (1 − α′) σ′t.
//!
//! So a flat, thick slab of the resulting medium reflects exactly `albedo` of the diffuse light
//! entering it (in the dipole model), and light travels on average `radius` scene units between
//! (reduced) interactions. Blender's Cycles random-walk SSS uses its own albedo fit and reads
//! the radius somewhat differently, so the same inputs give a similar but not identical look.

use super::dipole::albedo_from_rd;
use super::error::OpticsError;
use super::medium::{check_eta, per_channel, Medium};

/// Subsurface settings as an artist sets them (Blender Principled BSDF names in brackets).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArtistParams {
    /// Subsurface colour ("Base Color" in Blender 4): the total diffuse reflectance Rd per
    /// channel, each in the open interval (0, 1).
    pub albedo: [f64; 3],
    /// Per-channel distance light travels in the medium ("Subsurface Radius"), in scene units,
    /// > 0; read as the reduced mean free path 1/σ′t once multiplied by `scale`.
    pub radius: [f64; 3],
    /// Multiplier of `radius` ("Subsurface Scale"), > 0.
    pub scale: f64,
    /// Millimetres per scene unit (1000 for a scene in metres), > 0.
    pub mm_per_unit: f64,
    /// Refractive index ("IOR"), in [1, 4).
    pub eta: f64,
    /// Scattering anisotropy g ("Subsurface Anisotropy"), in (−1, 1). It does not enter σ′s:
    /// the radius already describes the reduced (isotropic-equivalent) medium.
    pub g: f64,
}

impl ArtistParams {
    /// Checks every field.
    ///
    /// # Errors
    /// [`OpticsError::InvalidChannel`] naming `albedo` (not finite or outside (0, 1)) or
    /// `radius` (not finite or ≤ 0, or radius · scale · mm_per_unit not a representable
    /// positive length) and the channel; [`OpticsError::InvalidScalar`] naming `scale`,
    /// `mm_per_unit` (not finite or ≤ 0), `eta` (not in [1, 4)) or `g` (not in (−1, 1)).
    pub fn validate(&self) -> Result<(), OpticsError> {
        check_positive("scale", self.scale)?;
        check_positive("mm_per_unit", self.mm_per_unit)?;
        check_eta(self.eta)?;
        if !(self.g > -1.0 && self.g < 1.0) {
            return Err(OpticsError::InvalidScalar { field: "g", value: self.g, requirement: "must be finite and in (-1, 1)" });
        }
        for c in 0..3 {
            let a = self.albedo[c];
            if !(a > 0.0 && a < 1.0) {
                return Err(OpticsError::InvalidChannel {
                    field: "albedo",
                    channel: c,
                    value: a,
                    requirement: "must be in the open interval (0, 1)",
                });
            }
            let r = self.radius[c];
            if !(r.is_finite() && r > 0.0) {
                return Err(OpticsError::InvalidChannel {
                    field: "radius",
                    channel: c,
                    value: r,
                    requirement: "must be finite and > 0",
                });
            }
            let sigma_t_prime = 1.0 / (r * self.scale * self.mm_per_unit);
            if !(sigma_t_prime.is_finite() && sigma_t_prime > 0.0) {
                return Err(OpticsError::InvalidChannel {
                    field: "radius",
                    channel: c,
                    value: r,
                    requirement: "radius * scale * mm_per_unit must be a finite length > 0 \
                                  whose inverse is finite",
                });
            }
        }
        Ok(())
    }

    /// The reduced mean free path per channel, ℓ = radius · scale · mm_per_unit (mm).
    #[must_use]
    pub fn mean_free_path_mm(&self) -> [f64; 3] {
        per_channel(|c| self.radius[c] * self.scale * self.mm_per_unit)
    }

    /// The physical medium of these settings (see the module documentation):
    /// σ′t = 1/(radius · scale · mm_per_unit), σ′s = α′σ′t, σa = (1 − α′)σ′t with α′ the
    /// reduced albedo whose dipole total diffuse reflectance is `albedo`.
    ///
    /// # Errors
    /// Those of [`ArtistParams::validate`].
    pub fn to_medium(&self) -> Result<Medium, OpticsError> {
        self.validate()?;
        let mfp = self.mean_free_path_mm();
        let albedos = [0, 1, 2].map(|c| albedo_from_rd(self.albedo[c], self.eta));
        Medium::new(
            per_channel(|c| albedos[c].one_minus_alpha_prime / mfp[c]),
            per_channel(|c| albedos[c].alpha_prime / mfp[c]),
            self.eta,
            self.g,
        )
    }
}

impl Medium {
    /// The artist parameters that reproduce this medium (inverse of
    /// [`ArtistParams::to_medium`]): albedo = total diffuse reflectance Rd per channel
    /// ([`Medium::total_diffuse_reflectance`]) and radius = 1/(σ′t · scale · mm_per_unit) in
    /// scene units; η and g are the medium's own.
    ///
    /// # Errors
    /// [`OpticsError::InvalidScalar`] naming `scale` or `mm_per_unit` unless finite and > 0;
    /// [`OpticsError::NotRepresentable`] for a channel whose albedo is 0 (σ′s = 0: nothing
    /// scatters) or 1 (σa = 0: nothing absorbs), which artist albedos exclude; the errors of
    /// [`Medium::validate`] for an invalid medium.
    pub fn to_artist(&self, mm_per_unit: f64, scale: f64) -> Result<ArtistParams, OpticsError> {
        self.validate()?;
        check_positive("scale", scale)?;
        check_positive("mm_per_unit", mm_per_unit)?;
        let albedo = self.total_diffuse_reflectance();
        for (c, &a) in albedo.iter().enumerate() {
            if a <= 0.0 {
                return Err(OpticsError::NotRepresentable {
                    channel: c,
                    reason: "it does not scatter (sigma_s_prime = 0), so its albedo is 0",
                });
            }
            if a >= 1.0 {
                return Err(OpticsError::NotRepresentable {
                    channel: c,
                    reason: "it does not absorb (sigma_a = 0), so its albedo is 1",
                });
            }
        }
        let sigma_t_prime = self.sigma_t_prime();
        let params = ArtistParams {
            albedo,
            radius: per_channel(|c| 1.0 / (sigma_t_prime[c] * scale * mm_per_unit)),
            scale,
            mm_per_unit,
            eta: self.eta,
            g: self.g,
        };
        params.validate()?;
        Ok(params)
    }
}

/// A scalar must be finite and > 0.
fn check_positive(field: &'static str, value: f64) -> Result<(), OpticsError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(OpticsError::InvalidScalar { field, value, requirement: "must be finite and > 0" })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn params() -> ArtistParams {
        ArtistParams { albedo: [0.8, 0.5, 0.3], radius: [1.0, 0.5, 0.25], scale: 0.1, mm_per_unit: 1000.0, eta: 1.4, g: 0.0 }
    }

    #[test]
    fn conversion_follows_the_documented_formula() {
        let p = params();
        let m = p.to_medium().unwrap();
        for c in 0..3 {
            let mfp = p.radius[c] * 0.1 * 1000.0;
            assert!((m.sigma_t_prime()[c] * mfp - 1.0).abs() < 1e-14);
            let alpha = super::super::reduced_albedo_from_rd(p.albedo[c], 1.4).unwrap();
            assert!((m.reduced_albedo()[c] - alpha).abs() < 1e-14);
            assert!((m.total_diffuse_reflectance()[c] - p.albedo[c]).abs() < 1e-14);
        }
        assert_eq!(p.mean_free_path_mm(), [100.0, 50.0, 25.0]);
    }

    #[test]
    fn seeded_round_trip() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x7a5c_u64);
        for _ in 0..2000 {
            let p = ArtistParams {
                albedo: [0; 3].map(|_| rng.random_range(1e-4..1.0 - 1e-4)),
                radius: [0; 3].map(|_| 10f64.powf(rng.random_range(-3.0..3.0))),
                scale: 10f64.powf(rng.random_range(-2.0..1.0)),
                mm_per_unit: 10f64.powf(rng.random_range(-1.0..4.0)),
                eta: rng.random_range(1.0..2.5),
                g: rng.random_range(-0.9..0.9),
            };
            let back = p.to_medium().unwrap().to_artist(p.mm_per_unit, p.scale).unwrap();
            for c in 0..3 {
                assert!((back.albedo[c] - p.albedo[c]).abs() < 1e-12, "{p:?} -> {back:?}");
                assert!((back.radius[c] - p.radius[c]).abs() < 1e-12 * p.radius[c], "{p:?} -> {back:?}");
            }
            assert_eq!((back.eta, back.g), (p.eta, p.g));
        }
    }

    #[test]
    fn rejects_bad_parameters() {
        let mut p = params();
        for bad in [0.0, 1.0, -0.2, 1.5, f64::NAN] {
            p.albedo[2] = bad;
            let e = p.to_medium().unwrap_err();
            assert!(matches!(e, OpticsError::InvalidChannel { field: "albedo", channel: 2, .. }), "{bad}: {e}");
        }
        let mut p = params();
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            p.radius[0] = bad;
            let e = p.to_medium().unwrap_err();
            assert!(matches!(e, OpticsError::InvalidChannel { field: "radius", channel: 0, .. }));
        }
        let mut p = params();
        p.radius[1] = 1e-320;
        assert!(matches!(p.to_medium(), Err(OpticsError::InvalidChannel { field: "radius", channel: 1, .. })));
        for (field, f) in [
            ("scale", (|p: &mut ArtistParams| p.scale = 0.0) as fn(&mut ArtistParams)),
            ("mm_per_unit", |p| p.mm_per_unit = f64::NAN),
            ("eta", |p| p.eta = 0.9),
            ("g", |p| p.g = 1.0),
        ] {
            let mut p = params();
            f(&mut p);
            let e = p.to_medium().unwrap_err();
            assert!(matches!(e, OpticsError::InvalidScalar { field: x, .. } if x == field), "{e}");
        }
    }

    #[test]
    fn media_without_absorption_or_scattering_are_not_representable() {
        let m = Medium::new([0.0, 0.1, 0.1], [1.0; 3], 1.3, 0.0).unwrap();
        assert!(matches!(m.to_artist(1.0, 1.0), Err(OpticsError::NotRepresentable { channel: 0, .. })));
        let m = Medium::new([0.1; 3], [1.0, 1.0, 0.0], 1.3, 0.0).unwrap();
        assert!(matches!(m.to_artist(1.0, 1.0), Err(OpticsError::NotRepresentable { channel: 2, .. })));
        let m = Medium::preset("marble").unwrap();
        assert!(matches!(m.to_artist(0.0, 1.0), Err(OpticsError::InvalidScalar { field: "mm_per_unit", .. })));
        assert!(matches!(m.to_artist(1.0, -1.0), Err(OpticsError::InvalidScalar { field: "scale", .. })));
    }

    #[test]
    fn marble_through_artist_parameters() {
        let m = Medium::preset("marble").unwrap();
        let a = m.to_artist(1000.0, 1.0).unwrap(); // scene in metres
                                                   // Reduced mean free path of marble red: 1/2.1921 mm = 4.5618e-4 m.
        assert!((a.radius[0] - 1.0 / 2192.1).abs() < 1e-15);
        let back = a.to_medium().unwrap();
        for c in 0..3 {
            assert!((back.sigma_a[c] - m.sigma_a[c]).abs() < 1e-12);
            assert!((back.sigma_s_prime[c] - m.sigma_s_prime[c]).abs() < 1e-12);
        }
    }
}
