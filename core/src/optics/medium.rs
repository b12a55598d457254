//! A homogeneous scattering medium: absorption, reduced scattering, refractive index and
//! anisotropy, per RGB channel, in inverse millimetres.

use super::dipole::{self, Dipole};
use super::error::OpticsError;

/// Smallest accepted refractive index (relative to the surrounding air).
pub const ETA_MIN: f64 = 1.0;
/// Accepted refractive indices are strictly below this (diamond is 2.42; the Fdr fit is only
/// meaningful for ordinary dielectrics).
pub const ETA_MAX: f64 = 4.0;

/// A homogeneous participating medium in the diffusion approximation (Jensen et al. 2001).
///
/// Coefficients are per RGB channel in mm⁻¹; lengths everywhere in this module are millimetres.
/// The reduced scattering coefficient σ′s = (1 − g) σs is stored, since it is all the diffusion
/// approximation sees; `g` is kept for methods that need the phase function
/// ([`Medium::sigma_s`]).
///
/// Fields are public for convenience; a `Medium` built from [`Medium::new`], a preset or artist
/// parameters is valid, one assembled by hand can be checked with [`Medium::validate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Medium {
    /// Absorption coefficient σa (mm⁻¹), ≥ 0.
    pub sigma_a: [f64; 3],
    /// Reduced scattering coefficient σ′s = (1 − g) σs (mm⁻¹), ≥ 0.
    pub sigma_s_prime: [f64; 3],
    /// Refractive index relative to the surrounding air, in [1, 4).
    pub eta: f64,
    /// Mean cosine of the scattering angle (Henyey–Greenstein anisotropy), in (−1, 1).
    pub g: f64,
}

impl Medium {
    /// A validated medium.
    ///
    /// # Errors
    /// [`OpticsError::InvalidChannel`] naming `sigma_a` / `sigma_s_prime` and the channel when a
    /// coefficient is not finite, negative, or when σa + σ′s = 0 (nothing interacts: the
    /// diffusion coefficient is infinite); [`OpticsError::InvalidScalar`] naming `eta` (not in
    /// [1, 4)) or `g` (not in (−1, 1)).
    pub fn new(sigma_a: [f64; 3], sigma_s_prime: [f64; 3], eta: f64, g: f64) -> Result<Medium, OpticsError> {
        let m = Medium { sigma_a, sigma_s_prime, eta, g };
        m.validate()?;
        Ok(m)
    }

    /// Checks every field, with the errors of [`Medium::new`].
    ///
    /// # Errors
    /// See [`Medium::new`].
    pub fn validate(&self) -> Result<(), OpticsError> {
        for c in 0..3 {
            check_coefficient("sigma_a", c, self.sigma_a[c])?;
            check_coefficient("sigma_s_prime", c, self.sigma_s_prime[c])?;
            if self.sigma_a[c] + self.sigma_s_prime[c] <= 0.0 {
                return Err(OpticsError::InvalidChannel {
                    field: "sigma_a + sigma_s_prime",
                    channel: c,
                    value: self.sigma_a[c] + self.sigma_s_prime[c],
                    requirement: "must be > 0 (a medium must absorb or scatter)",
                });
            }
        }
        check_eta(self.eta)?;
        if !(self.g > -1.0 && self.g < 1.0) {
            return Err(OpticsError::InvalidScalar { field: "g", value: self.g, requirement: "must be finite and in (-1, 1)" });
        }
        Ok(())
    }

    /// Reduced extinction coefficient σ′t = σa + σ′s (mm⁻¹) (Jensen et al. 2001).
    #[must_use]
    pub fn sigma_t_prime(&self) -> [f64; 3] {
        per_channel(|c| self.sigma_a[c] + self.sigma_s_prime[c])
    }

    /// Scattering coefficient σs = σ′s/(1 − g) (mm⁻¹), from the definition σ′s = (1 − g)σs.
    #[must_use]
    pub fn sigma_s(&self) -> [f64; 3] {
        per_channel(|c| self.sigma_s_prime[c] / (1.0 - self.g))
    }

    /// Reduced albedo α′ = σ′s/σ′t (Jensen et al. 2001), in [0, 1].
    #[must_use]
    pub fn reduced_albedo(&self) -> [f64; 3] {
        per_channel(|c| self.sigma_s_prime[c] / (self.sigma_a[c] + self.sigma_s_prime[c]))
    }

    /// Diffusion coefficient κ = 1/(3σ′t) = 1/(3(σa + σ′s)) (mm), the κ of the TransCut
    /// diffusion equation ∇·(κ∇φ) − σa φ = 0 (ARCHITECTURE.md, "The equations").
    #[must_use]
    pub fn diffusion_coefficient(&self) -> [f64; 3] {
        per_channel(|c| 1.0 / (3.0 * (self.sigma_a[c] + self.sigma_s_prime[c])))
    }

    /// Effective transport coefficient σtr = √(σa/κ) = √(3σa σ′t) (mm⁻¹) (Jensen et al.
    /// 2001): the decay rate of the fluence far from sources, φ ∝ e^{−σtr r}/r.
    #[must_use]
    pub fn sigma_tr(&self) -> [f64; 3] {
        per_channel(|c| dipole::sigma_tr(self.sigma_a[c], self.sigma_s_prime[c]))
    }

    /// Diffuse mean free path ℓd = 1/σtr (mm), the length tabulated by Jensen et al. 2001
    /// (its table of measured materials). Infinite in a channel that does not absorb (σa = 0).
    #[must_use]
    pub fn diffuse_mean_free_path(&self) -> [f64; 3] {
        per_channel(|c| 1.0 / self.sigma_tr()[c])
    }

    /// Total diffuse reflectance Rd per channel of the classical dipole (Jensen et al. 2001,
    /// Rd(r) integrated over the plane; see [`dipole::total_diffuse_reflectance`]): the
    /// fraction of light entering a semi-infinite slab of this medium that diffuses back out.
    #[must_use]
    pub fn total_diffuse_reflectance(&self) -> [f64; 3] {
        per_channel(|c| self.dipole(c).total())
    }

    /// The dipole diffuse reflectance profile Rd(r) per channel (mm⁻²) at distance `r_mm` from
    /// the point of incidence (Jensen et al. 2001; see [`Dipole::rd`]).
    #[must_use]
    pub fn rd_profile(&self, r_mm: f64) -> [f64; 3] {
        per_channel(|c| self.dipole(c).rd(r_mm))
    }

    /// The classical dipole of channel `channel` (0 = red, 1 = green, 2 = blue).
    ///
    /// # Panics
    /// If `channel` > 2.
    #[must_use]
    pub fn dipole(&self, channel: usize) -> Dipole {
        Dipole::new(self.sigma_a[channel], self.sigma_s_prime[channel], self.eta)
    }

    /// The same material with lengths rescaled by `f`: every coefficient (σa, σ′s, in inverse
    /// length) is divided by `f`; η and g are dimensionless and unchanged.
    ///
    /// Two equivalent readings:
    /// - *change of unit*: if a length measured as ℓ in the current unit measures f·ℓ in the new
    ///   one (mm → cm is f = 0.1, mm → m is f = 0.001), the coefficients in the new unit are the
    ///   returned ones (σ in cm⁻¹ = 10 × σ in mm⁻¹);
    /// - *change of size*: an object enlarged f times and filled with the returned medium looks
    ///   exactly like the original object filled with `self`, because every optical thickness
    ///   σ·L is unchanged.
    ///
    /// # Errors
    /// [`OpticsError::InvalidScalar`] naming `f` unless it is finite and > 0.
    pub fn scaled(&self, f: f64) -> Result<Medium, OpticsError> {
        if !(f.is_finite() && f > 0.0) {
            return Err(OpticsError::InvalidScalar {
                field: "f",
                value: f,
                requirement: "length scale factor must be finite and > 0",
            });
        }
        Medium::new(per_channel(|c| self.sigma_a[c] / f), per_channel(|c| self.sigma_s_prime[c] / f), self.eta, self.g)
    }
}

/// Applies `f` to the channel indices 0, 1, 2.
pub(crate) fn per_channel(f: impl Fn(usize) -> f64) -> [f64; 3] {
    [f(0), f(1), f(2)]
}

/// A coefficient must be finite and ≥ 0.
fn check_coefficient(field: &'static str, channel: usize, value: f64) -> Result<(), OpticsError> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(OpticsError::InvalidChannel { field, channel, value, requirement: "must be finite and >= 0 (mm^-1)" })
    }
}

/// The refractive index must be finite and in [`ETA_MIN`, `ETA_MAX`).
pub(crate) fn check_eta(eta: f64) -> Result<(), OpticsError> {
    if (ETA_MIN..ETA_MAX).contains(&eta) {
        Ok(())
    } else {
        Err(OpticsError::InvalidScalar { field: "eta", value: eta, requirement: "refractive index must be in [1, 4)" })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn marble() -> Medium {
        Medium::new([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.00], 1.5, 0.0).unwrap()
    }

    #[test]
    fn derived_quantities() {
        let m = marble();
        let st = m.sigma_t_prime();
        assert!((st[0] - 2.1921).abs() < 1e-15);
        let k = m.diffusion_coefficient();
        assert!((k[0] - 1.0 / (3.0 * 2.1921)).abs() < 1e-15);
        let tr = m.sigma_tr();
        for c in 0..3 {
            // σtr = √(σa/κ) = √(3σaσ′t).
            assert!((tr[c] - (m.sigma_a[c] / k[c]).sqrt()).abs() < 1e-14);
            assert!((m.diffuse_mean_free_path()[c] * tr[c] - 1.0).abs() < 1e-15);
            let a = m.reduced_albedo()[c];
            assert!((a - m.sigma_s_prime[c] / st[c]).abs() < 1e-15);
        }
        assert!((m.diffuse_mean_free_path()[0] - 8.51).abs() < 0.01);
    }

    #[test]
    fn sigma_s_undoes_the_reduction() {
        let m = Medium::new([0.1; 3], [1.0, 2.0, 3.0], 1.3, 0.5).unwrap();
        assert_eq!(m.sigma_s(), [2.0, 4.0, 6.0]);
    }

    #[test]
    fn non_absorbing_channel_has_infinite_diffuse_mean_free_path() {
        let m = Medium::new([0.0, 0.1, 0.1], [1.0; 3], 1.3, 0.0).unwrap();
        assert_eq!(m.sigma_tr()[0], 0.0);
        assert_eq!(m.diffuse_mean_free_path()[0], f64::INFINITY);
        assert_eq!(m.reduced_albedo()[0], 1.0);
    }

    #[test]
    fn rejects_bad_coefficients_naming_field_and_channel() {
        let e = Medium::new([0.1, -0.1, 0.1], [1.0; 3], 1.3, 0.0).unwrap_err();
        assert!(matches!(e, OpticsError::InvalidChannel { field: "sigma_a", channel: 1, .. }));
        let e = Medium::new([0.1; 3], [1.0, 1.0, f64::NAN], 1.3, 0.0).unwrap_err();
        assert!(matches!(e, OpticsError::InvalidChannel { field: "sigma_s_prime", channel: 2, .. }));
        let e = Medium::new([0.1; 3], [f64::INFINITY, 1.0, 1.0], 1.3, 0.0).unwrap_err();
        assert!(matches!(e, OpticsError::InvalidChannel { field: "sigma_s_prime", channel: 0, .. }));
        let e = Medium::new([0.1, 0.0, 0.1], [1.0, 0.0, 1.0], 1.3, 0.0).unwrap_err();
        assert!(matches!(e, OpticsError::InvalidChannel { field: "sigma_a + sigma_s_prime", channel: 1, .. }));
        assert!(e.to_string().contains("green"), "{e}");
    }

    #[test]
    fn rejects_bad_eta_and_g() {
        for eta in [0.99, 4.0, f64::NAN, f64::INFINITY, -1.3] {
            let e = Medium::new([0.1; 3], [1.0; 3], eta, 0.0).unwrap_err();
            assert!(matches!(e, OpticsError::InvalidScalar { field: "eta", .. }), "{eta}");
        }
        for g in [-1.0, 1.0, f64::NAN, 2.0] {
            let e = Medium::new([0.1; 3], [1.0; 3], 1.3, g).unwrap_err();
            assert!(matches!(e, OpticsError::InvalidScalar { field: "g", .. }), "{g}");
        }
        assert!(Medium::new([0.1; 3], [1.0; 3], 1.0, -0.9).is_ok());
        assert!(Medium::new([0.1; 3], [1.0; 3], 3.99, 0.9).is_ok());
    }

    #[test]
    fn scaling_preserves_optical_thickness_and_dimensionless_quantities() {
        let m = marble();
        // mm → cm: lengths ×0.1, coefficients ×10.
        let cm = m.scaled(0.1).unwrap();
        for c in 0..3 {
            assert!((cm.sigma_a[c] - 10.0 * m.sigma_a[c]).abs() < 1e-15);
            assert!((cm.sigma_s_prime[c] - 10.0 * m.sigma_s_prime[c]).abs() < 1e-12);
            assert!((cm.diffuse_mean_free_path()[c] - 0.1 * m.diffuse_mean_free_path()[c]).abs() < 1e-12);
            assert!((cm.reduced_albedo()[c] - m.reduced_albedo()[c]).abs() < 1e-15);
            assert!((cm.total_diffuse_reflectance()[c] - m.total_diffuse_reflectance()[c]).abs() < 1e-15);
        }
        assert_eq!(cm.eta, m.eta);
        for f in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(matches!(m.scaled(f), Err(OpticsError::InvalidScalar { field: "f", .. })));
        }
    }
}
