//! Spatially varying coefficients: the [`Coefficients`] of a point, fields that give them
//! ([`MediumField`]) and how a field is reduced to one value per tet ([`TetSampling`]).

use glam::DVec3;

use crate::optics::{Medium, OpticsError};

/// The spatially varying part of a medium at one point: absorption σa and reduced scattering
/// σ′s = (1 − g)σs, per RGB channel, in mm⁻¹ (as in [`Medium`]). The refractive index η and
/// the anisotropy g are properties of the whole object (see [`super::PerTetMedia`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Coefficients {
    /// Absorption coefficient σa (mm⁻¹) per channel.
    pub sigma_a: [f64; 3],
    /// Reduced scattering coefficient σ′s (mm⁻¹) per channel.
    pub sigma_s_prime: [f64; 3],
}

impl Coefficients {
    /// The coefficients (not validated; see [`Coefficients::validate`]).
    #[must_use]
    pub const fn new(sigma_a: [f64; 3], sigma_s_prime: [f64; 3]) -> Self {
        Self { sigma_a, sigma_s_prime }
    }

    /// The six values in voxel-channel order: σa R, G, B, σ′s R, G, B.
    #[must_use]
    pub fn to_array(&self) -> [f64; 6] {
        let [a0, a1, a2] = self.sigma_a;
        let [s0, s1, s2] = self.sigma_s_prime;
        [a0, a1, a2, s0, s1, s2]
    }

    /// From six values in voxel-channel order: σa R, G, B, σ′s R, G, B.
    #[must_use]
    pub fn from_array(v: [f64; 6]) -> Self {
        Self { sigma_a: [v[0], v[1], v[2]], sigma_s_prime: [v[3], v[4], v[5]] }
    }

    /// Linear interpolation (1 − t)·self + t·other, per coefficient (exactly `self` at t = 0
    /// and `other` at t = 1). For t ∈ [0, 1] and two valid sets of coefficients the result is
    /// valid (a convex combination).
    #[must_use]
    pub fn lerp(&self, other: &Coefficients, t: f64) -> Coefficients {
        let f = |a: [f64; 3], b: [f64; 3]| [0, 1, 2].map(|c| (1.0 - t) * a[c] + t * b[c]);
        Coefficients { sigma_a: f(self.sigma_a, other.sigma_a), sigma_s_prime: f(self.sigma_s_prime, other.sigma_s_prime) }
    }

    /// The medium with these coefficients and the object's η and g (not validated).
    #[must_use]
    pub fn with_eta_g(&self, eta: f64, g: f64) -> Medium {
        Medium { sigma_a: self.sigma_a, sigma_s_prime: self.sigma_s_prime, eta, g }
    }

    /// Checks that every coefficient is finite and ≥ 0 and that σa + σ′s > 0 in every channel
    /// (the rules of [`Medium::validate`] for the coefficients).
    ///
    /// # Errors
    /// [`OpticsError::InvalidChannel`] naming `sigma_a`, `sigma_s_prime` or
    /// `sigma_a + sigma_s_prime` and the channel.
    pub fn validate(&self) -> Result<(), OpticsError> {
        // η = 1 and g = 0 are valid, so only the coefficients can fail.
        self.with_eta_g(1.0, 0.0).validate()
    }
}

impl From<Medium> for Coefficients {
    fn from(m: Medium) -> Self {
        Self { sigma_a: m.sigma_a, sigma_s_prime: m.sigma_s_prime }
    }
}

impl From<&Medium> for Coefficients {
    fn from(m: &Medium) -> Self {
        Self::from(*m)
    }
}

/// A heterogeneous medium as a function of position: σa and σ′s at a point given in the tet
/// mesh's scene units.
///
/// Implemented by [`super::VoxelGrid`] (trilinear sampling), [`super::Veins`], the depth
/// profile of [`super::Layers`] bound to a mesh ([`super::LayeredField`]), and every closure
/// `Fn(DVec3) -> Coefficients + Sync`.
pub trait MediumField: Sync {
    /// The coefficients at `p` (scene units).
    fn coefficients(&self, p: DVec3) -> Coefficients;
}

impl<F: Fn(DVec3) -> Coefficients + Sync> MediumField for F {
    fn coefficients(&self, p: DVec3) -> Coefficients {
        self(p)
    }
}

/// How a field is reduced to one (constant) value per tet, as the diffusion assembly needs.
///
/// Both rules average σa and σ′s (not κ): the absorption term of the assembly, ∫ μ β_i, is
/// then the integral of the sampled σa, and κ_t = 1/(3(σ̄a + σ̄′s)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum TetSampling {
    /// The value at the centroid (v₀ + v₁ + v₂ + v₃)/4.
    Centroid,
    /// The mean of five samples, weight 1/5 each: the centroid and the four points of the
    /// degree-2 Keast/Hammer rule, barycentric (a, b, b, b) and permutations with
    /// a = (5 + 3√5)/20, b = (5 − √5)/20. Exact for fields linear over the tet (the volume
    /// mean), and for a field that varies within a tet (a voxel grid finer than the mesh, thin
    /// layers) a better volume average than one sample.
    #[default]
    FivePoint,
}

/// Barycentric a of the degree-2 four-point rule: (5 + 3√5)/20.
pub(crate) const KEAST_A: f64 = 0.585_410_196_624_968_5;
/// Barycentric b of the degree-2 four-point rule: (5 − √5)/20.
pub(crate) const KEAST_B: f64 = 0.138_196_601_125_010_5;

impl TetSampling {
    /// The sample points of the tet with corners `p`, all with equal weight. Unused entries
    /// of the array repeat the centroid; the first `count` are the points.
    #[must_use]
    pub fn points(self, p: [DVec3; 4]) -> ([DVec3; 5], usize) {
        let centroid = (p[0] + p[1] + p[2] + p[3]) * 0.25;
        match self {
            TetSampling::Centroid => ([centroid; 5], 1),
            TetSampling::FivePoint => {
                let q = |i: usize| {
                    let mut x = DVec3::ZERO;
                    for (k, &pk) in p.iter().enumerate() {
                        x += pk * if k == i { KEAST_A } else { KEAST_B };
                    }
                    x
                };
                ([centroid, q(0), q(1), q(2), q(3)], 5)
            }
        }
    }

    /// The mean of `field` over the sample points of the tet with corners `p`, summed in a
    /// fixed order (deterministic).
    #[must_use]
    pub fn average(self, field: &(impl MediumField + ?Sized), p: [DVec3; 4]) -> Coefficients {
        let (points, count) = self.points(p);
        let mut sum = [0.0; 6];
        for &x in &points[..count] {
            let v = field.coefficients(x).to_array();
            for (s, v) in sum.iter_mut().zip(v) {
                *s += v;
            }
        }
        let inv = 1.0 / count as f64;
        Coefficients::from_array(sum.map(|s| s * inv))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn corners() -> [DVec3; 4] {
        [DVec3::new(0.1, 0.2, 0.3), DVec3::new(2.0, 0.0, 0.5), DVec3::new(0.3, 1.7, 0.0), DVec3::new(0.4, 0.6, 2.2)]
    }

    #[test]
    fn keast_constants_are_the_closed_forms() {
        let s5 = 5f64.sqrt();
        assert!((KEAST_A - (5.0 + 3.0 * s5) / 20.0).abs() < 1e-16);
        assert!((KEAST_B - (5.0 - s5) / 20.0).abs() < 1e-16);
        assert!((KEAST_A + 3.0 * KEAST_B - 1.0).abs() < 1e-15);
    }

    #[test]
    fn both_rules_are_exact_for_linear_fields() {
        let p = corners();
        let field = |x: DVec3| {
            let v = 1.0 + x.x - 0.5 * x.y + 0.25 * x.z;
            Coefficients::new([v, 2.0 * v, 3.0], [v + 1.0, 0.5, v])
        };
        let c = (p[0] + p[1] + p[2] + p[3]) / 4.0;
        let exact = field(c);
        for rule in [TetSampling::Centroid, TetSampling::FivePoint] {
            let got = rule.average(&field, p).to_array();
            for (g, e) in got.iter().zip(exact.to_array()) {
                assert!((g - e).abs() < 1e-14, "{rule:?}: {g} vs {e}");
            }
        }
    }

    #[test]
    fn five_point_rule_integrates_quadratics_better_than_the_centroid() {
        // ∫ x² over the unit right tet / volume = 1/10 (exact); centroid gives 1/16; the four-point
        // rule alone is exact, so the five-point mean is (4/5)(1/10) + (1/5)(1/16).
        let p = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        let field = |x: DVec3| Coefficients::new([x.x * x.x; 3], [1.0; 3]);
        let five = TetSampling::FivePoint.average(&field, p).sigma_a[0];
        assert!((five - (0.8 * 0.1 + 0.2 / 16.0)).abs() < 1e-15);
        let centroid = TetSampling::Centroid.average(&field, p).sigma_a[0];
        assert!((centroid - 1.0 / 16.0).abs() < 1e-15);
        assert!((five - 0.1).abs() < (centroid - 0.1).abs());
    }

    #[test]
    fn coefficients_convert_and_validate() {
        let m = Medium::preset("marble").unwrap();
        let c = Coefficients::from(&m);
        assert_eq!(c.with_eta_g(m.eta, m.g), m);
        assert_eq!(Coefficients::from_array(c.to_array()), c);
        assert!(c.validate().is_ok());
        let bad = Coefficients::new([0.0, -1.0, 0.0], [1.0; 3]);
        assert!(matches!(bad.validate(), Err(OpticsError::InvalidChannel { field: "sigma_a", channel: 1, .. })));
        let none = Coefficients::new([0.0; 3], [1.0, 0.0, 1.0]);
        assert!(matches!(none.validate(), Err(OpticsError::InvalidChannel { channel: 1, .. })));
        let mid = c.lerp(&Coefficients::new([1.0; 3], [3.0; 3]), 0.5);
        assert!((mid.sigma_a[0] - (m.sigma_a[0] + 1.0) / 2.0).abs() < 1e-15);
    }
}
