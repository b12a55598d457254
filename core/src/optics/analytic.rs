//! Closed-form reference solutions of the diffusion problem, used to validate the solvers.
//!
//! Uniformly lit homogeneous sphere (ARCHITECTURE.md, "Validation that needs no other
//! program"): with q constant on the surface of a sphere of radius R, the fluence is radial,
//! κ(φ″ + 2φ′/r) = σa φ, so φ(r) = C sinh(σtr r)/r, σtr = √(σa/κ), and the Robin condition
//! φ(R) + 2Aκ φ′(R) = Q, Q = 4q/(1 − Fdr), fixes
//! C = Q / (sinh(σtr R)/R + 2Aκ(σtr cosh(σtr R)/R − sinh(σtr R)/R²)).
//!
//! Dividing through by sinh(σtr R)/R gives the overflow-free form used here:
//! φ(R) = Q / (1 + 2Aκ (x coth x − 1)/R), x = σtr R, and
//! φ(r) = φ(R) · [sinh(σtr r)/(σtr r)] / [sinh(x)/x].

use super::boundary::BoundaryTerms;
use super::error::OpticsError;
use super::medium::{per_channel, Medium};

/// Below this argument the series expansions are used (their first omitted term is < 1e-24).
const SERIES_LIMIT: f64 = 1e-3;

/// The uniformly lit homogeneous sphere: a medium, a radius and a constant transmitted source.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UniformSphere {
    /// The medium filling the sphere.
    pub medium: Medium,
    /// Sphere radius R (mm).
    pub radius_mm: f64,
    /// Transmitted source q on the surface, per channel (e.g. π(1 − F_ext) for a constant
    /// environment of radiance 1, [`f_ext`](super::f_ext)).
    pub q: [f64; 3],
}

impl UniformSphere {
    /// A validated sphere.
    ///
    /// # Errors
    /// [`OpticsError::InvalidScalar`] naming `radius_mm` unless finite and > 0;
    /// [`OpticsError::InvalidChannel`] naming `q` unless finite; the errors of
    /// [`Medium::validate`].
    pub fn new(medium: Medium, radius_mm: f64, q: [f64; 3]) -> Result<UniformSphere, OpticsError> {
        medium.validate()?;
        if !(radius_mm.is_finite() && radius_mm > 0.0) {
            return Err(OpticsError::InvalidScalar {
                field: "radius_mm",
                value: radius_mm,
                requirement: "must be finite and > 0",
            });
        }
        if let Some(c) = (0..3).find(|&c| !q[c].is_finite()) {
            return Err(OpticsError::InvalidChannel { field: "q", channel: c, value: q[c], requirement: "must be finite" });
        }
        Ok(UniformSphere { medium, radius_mm, q })
    }

    /// The boundary constants of the medium's η.
    fn boundary(&self) -> BoundaryTerms {
        BoundaryTerms::new(self.medium.eta).expect("a validated medium has a valid refractive index")
    }

    /// Fluence at the surface, φ(R) = Q / (1 + 2Aκ(x coth x − 1)/R), x = σtr R, per channel.
    #[must_use]
    pub fn surface_fluence(&self) -> [f64; 3] {
        let b = self.boundary();
        let (kappa, tr) = (self.medium.diffusion_coefficient(), self.medium.sigma_tr());
        let r = self.radius_mm;
        per_channel(|c| {
            let slope = x_coth_x_minus_one(tr[c] * r) / r; // φ′(R)/φ(R)
            b.fluence_source(self.q[c]) / (1.0 + b.extrapolation_length(kappa[c]) * slope)
        })
    }

    /// Fluence at distance `r` (mm, 0 ≤ r ≤ R) from the centre:
    /// φ(r) = φ(R) · sinhc(σtr r)/sinhc(σtr R), sinhc(x) = sinh(x)/x.
    #[must_use]
    pub fn fluence(&self, r: f64) -> [f64; 3] {
        let tr = self.medium.sigma_tr();
        let surface = self.surface_fluence();
        per_channel(|c| surface[c] * (ln_sinhc(tr[c] * r) - ln_sinhc(tr[c] * self.radius_mm)).exp())
    }

    /// The constant C of φ(r) = C sinh(σtr r)/r: C = φ(R) R / sinh(σtr R), per channel; for
    /// σtr = 0 (no absorption) the solution is the constant φ(R) and C is returned as +∞.
    /// Underflows to 0 when σtr R exceeds about 709; use [`UniformSphere::fluence`] instead.
    #[must_use]
    pub fn coefficient(&self) -> [f64; 3] {
        let tr = self.medium.sigma_tr();
        let surface = self.surface_fluence();
        per_channel(|c| surface[c] * self.radius_mm / (tr[c] * self.radius_mm).sinh())
    }

    /// Exitant radiance on the surface at cos θo = `cos_o` from the normal,
    /// Lo = Ft/(4π)[(1 + 1/A) φ(R) − 4q/(1 + Fdr)] ([`BoundaryTerms::radiance_from_fluence`]).
    #[must_use]
    pub fn surface_radiance(&self, cos_o: f64) -> [f64; 3] {
        let b = self.boundary();
        let phi = self.surface_fluence();
        per_channel(|c| b.radiance_from_fluence(phi[c], self.q[c], cos_o))
    }
}

/// Surface fluence φ(R) of a sphere of radius `radius_mm` filled with `medium` and lit so that
/// the transmitted source is the constant `q` in every channel ([`UniformSphere`], the
/// closed form C sinh(σtr R)/R of ARCHITECTURE.md). For a radius that is not finite and > 0,
/// or a non-finite q, every channel is NaN.
#[must_use]
pub fn uniform_sphere_fluence(medium: &Medium, radius_mm: f64, q: f64) -> [f64; 3] {
    UniformSphere::new(*medium, radius_mm, [q; 3]).map_or([f64::NAN; 3], |s| s.surface_fluence())
}

/// x coth x − 1 for x ≥ 0, which is R φ′(R)/φ(R) for φ(r) = sinh(σtr r)/r and x = σtr R;
/// by its Taylor series x²/3 − x⁴/45 below [`SERIES_LIMIT`].
fn x_coth_x_minus_one(x: f64) -> f64 {
    if x < SERIES_LIMIT {
        let x2 = x * x;
        x2 / 3.0 - x2 * x2 / 45.0
    } else {
        x / x.tanh() - 1.0
    }
}

/// ln(sinh(x)/x) for x ≥ 0 without overflow: Taylor series x²/6 − x⁴/180 below
/// [`SERIES_LIMIT`], x − ln(2x) + ln(1 − e^{−2x}) above 20, the direct form in between.
fn ln_sinhc(x: f64) -> f64 {
    if x < SERIES_LIMIT {
        let x2 = x * x;
        x2 / 6.0 - x2 * x2 / 180.0
    } else if x < 20.0 {
        (x.sinh() / x).ln()
    } else {
        x - (2.0 * x).ln() + (-(-2.0 * x).exp()).ln_1p()
    }
}

#[cfg(test)]
mod tests {
    use super::super::fresnel::f_ext;
    use super::*;

    fn marble_at_1_3() -> Medium {
        Medium::new([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.00], 1.3, 0.0).unwrap()
    }

    #[test]
    fn worked_example_of_the_architecture() {
        let q = std::f64::consts::PI * (1.0 - f_ext(1.3));
        assert!((q - 2.9495).abs() < 1e-4, "{q}");
        let s = UniformSphere::new(marble_at_1_3(), 10.0, [q; 3]).unwrap();
        let phi = s.surface_fluence();
        let lo = s.surface_radiance(1.0);
        for (got, want) in phi.iter().zip([20.561, 20.058, 19.491]) {
            assert!((got / want - 1.0).abs() < 1e-4, "phi {phi:?}");
        }
        for (got, want) in lo.iter().zip([0.9394, 0.9072, 0.8709]) {
            assert!((got / want - 1.0).abs() < 1e-4, "Lo {lo:?}");
        }
        for (got, want) in s.coefficient().iter().zip([140.35, 68.42, 31.23]) {
            assert!((got / want - 1.0).abs() < 1e-3, "C {:?}", s.coefficient());
        }
        assert_eq!(uniform_sphere_fluence(&marble_at_1_3(), 10.0, q), phi);
    }

    #[test]
    fn closed_form_with_c_agrees_with_the_stable_form() {
        let s = UniformSphere::new(marble_at_1_3(), 10.0, [2.0; 3]).unwrap();
        let (c, tr) = (s.coefficient(), s.medium.sigma_tr());
        for r in [0.5, 3.0, 7.5, 10.0] {
            let phi = s.fluence(r);
            for ch in 0..3 {
                let direct = c[ch] * (tr[ch] * r).sinh() / r;
                assert!((phi[ch] / direct - 1.0).abs() < 1e-13);
            }
        }
    }

    #[test]
    fn solves_the_radial_equation_and_the_boundary_condition() {
        let m = Medium::preset("skin2").unwrap();
        let s = UniformSphere::new(m, 6.0, [1.0, 2.0, 3.0]).unwrap();
        let (k, b) = (m.diffusion_coefficient(), BoundaryTerms::new(m.eta).unwrap());
        let h = 1e-3;
        for r in [1.0, 3.0, 5.0] {
            let (lo, mid, hi) = (s.fluence(r - h), s.fluence(r), s.fluence(r + h));
            for c in 0..3 {
                let d2 = (hi[c] - 2.0 * mid[c] + lo[c]) / (h * h);
                let d1 = (hi[c] - lo[c]) / (2.0 * h);
                let residual = k[c] * (d2 + 2.0 * d1 / r) - m.sigma_a[c] * mid[c];
                assert!(residual.abs() < 1e-6 * m.sigma_a[c] * mid[c].abs() + 1e-9, "{r} {c}");
            }
        }
        let (lo, top) = (s.fluence(6.0 - h), s.fluence(6.0));
        let below = s.fluence(6.0 - 2.0 * h);
        for c in 0..3 {
            // Second-order one-sided derivative at R.
            let d1 = (3.0 * top[c] - 4.0 * lo[c] + below[c]) / (2.0 * h);
            let lhs = top[c] + b.extrapolation_length(k[c]) * d1;
            assert!((lhs / b.fluence_source(s.q[c]) - 1.0).abs() < 1e-6, "channel {c}");
        }
    }

    #[test]
    fn non_absorbing_sphere_fills_to_the_source() {
        let m = Medium::new([0.0; 3], [1.0; 3], 1.3, 0.0).unwrap();
        let s = UniformSphere::new(m, 5.0, [1.0; 3]).unwrap();
        let q_fluence = BoundaryTerms::new(1.3).unwrap().fluence_source(1.0);
        for r in [0.0, 2.0, 5.0] {
            assert!((s.fluence(r)[0] / q_fluence - 1.0).abs() < 1e-15);
        }
    }

    #[test]
    fn large_optical_radius_does_not_overflow() {
        let m = Medium::preset("ketchup").unwrap();
        let s = UniformSphere::new(m, 1000.0, [1.0; 3]).unwrap(); // σtr R ≈ 2500 in blue
        let phi = s.fluence(999.0);
        let surface = s.surface_fluence();
        for c in 0..3 {
            assert!(phi[c].is_finite() && phi[c] > 0.0 && phi[c] < surface[c]);
        }
        assert!(s.fluence(0.0)[2] < 1e-300);
    }

    #[test]
    fn series_and_direct_forms_meet() {
        for f in [x_coth_x_minus_one, ln_sinhc] {
            let (below, above) = (f(SERIES_LIMIT * (1.0 - 1e-12)), f(SERIES_LIMIT));
            assert!((below / above - 1.0).abs() < 1e-9);
        }
        let x = 20.0_f64;
        assert!((ln_sinhc(x * (1.0 - 1e-15)) - (x.sinh() / x).ln()).abs() < 1e-12);
    }

    #[test]
    fn invalid_spheres_are_rejected() {
        let m = marble_at_1_3();
        assert!(matches!(UniformSphere::new(m, 0.0, [1.0; 3]), Err(OpticsError::InvalidScalar { field: "radius_mm", .. })));
        assert!(matches!(
            UniformSphere::new(m, 1.0, [1.0, f64::NAN, 1.0]),
            Err(OpticsError::InvalidChannel { field: "q", channel: 1, .. })
        ));
        assert!(uniform_sphere_fluence(&m, -1.0, 1.0).iter().all(|v| v.is_nan()));
    }
}
