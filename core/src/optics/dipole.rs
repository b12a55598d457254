//! The classical dipole diffusion model of Jensen, Marschner, Levoy & Hanrahan, "A Practical
//! Model for Subsurface Light Transport" (SIGGRAPH 2001), restated in R. Wang et al. 2008 §3
//! (papers/001): the diffuse reflectance profile Rd(r) of a semi-infinite homogeneous medium,
//! its integral over the plane (the total diffuse reflectance), and the inverse of that integral.
//!
//! Notation: α′ = σ′s/σ′t reduced albedo, σtr = √(3σaσ′t), z_r = 1/σ′t (depth of the real
//! source), z_v = z_r(1 + 4A/3) (height of the virtual source), A from [`a_coefficient`].
//! The dimensionless ratio s = σtr z_r = √(3(1 − α′)) carries all the α′ dependence of the
//! total reflectance.

use super::error::OpticsError;
use super::fresnel::a_coefficient;
use super::medium::check_eta;

/// Most Newton/bisection steps of [`reduced_albedo_from_rd`]; bisection alone halves a bracket
/// of width √3 below 1e-16 in 55 steps, Newton converges in under 10.
const MAX_INVERSION_STEPS: usize = 200;

/// Effective transport coefficient σtr = √(3σa(σa + σ′s)) (mm⁻¹) (Jensen et al. 2001).
#[must_use]
pub fn sigma_tr(sigma_a: f64, sigma_s_prime: f64) -> f64 {
    (3.0 * sigma_a * (sigma_a + sigma_s_prime)).sqrt()
}

/// The classical dipole for one channel of a medium: the quantities of Jensen et al. 2001's Rd(r).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dipole {
    /// Reduced albedo α′ = σ′s/σ′t.
    pub alpha_prime: f64,
    /// Effective transport coefficient σtr = √(3σaσ′t) (mm⁻¹).
    pub sigma_tr: f64,
    /// Depth of the real source below the surface, z_r = 1/σ′t (mm).
    pub z_r: f64,
    /// Height of the virtual (negative) source above the surface, z_v = z_r + 4AD =
    /// z_r(1 + 4A/3), D = 1/(3σ′t) (mm).
    pub z_v: f64,
}

impl Dipole {
    /// The dipole of a medium with absorption `sigma_a`, reduced scattering `sigma_s_prime`
    /// (mm⁻¹, σa + σ′s > 0) and refractive index `eta` relative to air.
    #[must_use]
    pub fn new(sigma_a: f64, sigma_s_prime: f64, eta: f64) -> Dipole {
        let sigma_t_prime = sigma_a + sigma_s_prime;
        let z_r = 1.0 / sigma_t_prime;
        Dipole {
            alpha_prime: sigma_s_prime / sigma_t_prime,
            sigma_tr: sigma_tr(sigma_a, sigma_s_prime),
            z_r,
            z_v: z_r * (1.0 + 4.0 * a_coefficient(eta) / 3.0),
        }
    }

    /// Diffuse reflectance profile (mm⁻²) at distance `r` (mm) from the point of incidence,
    /// Jensen et al. 2001, as restated in papers/001 §3 (the equation after eq. 2):
    ///
    /// Rd(r) = α′/(4π) [ z_r (σtr + 1/d_r) e^{−σtr d_r}/d_r² + z_v (σtr + 1/d_v) e^{−σtr d_v}/d_v² ],
    /// d_r = √(r² + z_r²), d_v = √(r² + z_v²).
    #[must_use]
    pub fn rd(&self, r: f64) -> f64 {
        let term = |z: f64| {
            let d = (r * r + z * z).sqrt();
            z * (self.sigma_tr + 1.0 / d) * (-self.sigma_tr * d).exp() / (d * d)
        };
        self.alpha_prime / (4.0 * std::f64::consts::PI) * (term(self.z_r) + term(self.z_v))
    }

    /// Rd′(r)/r (mm⁻⁴), the profile's slope over the distance: the gradient of Rd(‖x − y‖)
    /// in x is Rd′(r)/r · (x − y). From ∂/∂d[(1 + σd)e^{−σd}/d³] = −e^{−σd}(σ²d² + 3σd + 3)/d⁴
    /// and ∂d/∂r = r/d:
    ///
    /// Rd′(r)/r = −α′/(4π) Σ_j z_j e^{−σtr d_j}(σtr² d_j² + 3σtr d_j + 3)/d_j⁵.
    #[must_use]
    pub fn rd_slope_over_r(&self, r: f64) -> f64 {
        let term = |z: f64| {
            let d = (r * r + z * z).sqrt();
            let sd = self.sigma_tr * d;
            z * (-sd).exp() * (sd * sd + 3.0 * sd + 3.0) / d.powi(5)
        };
        -self.alpha_prime / (4.0 * std::f64::consts::PI) * (term(self.z_r) + term(self.z_v))
    }

    /// (d/dr)[Rd′(r)/r] / r (mm⁻⁶): with k = [`Dipole::rd_slope_over_r`], the Hessian of
    /// Rd(‖x − y‖) in x is k I + this · (x − y)(x − y)ᵀ. Differentiating k once more:
    ///
    /// α′/(4π) Σ_j z_j e^{−σtr d_j}(σtr³d_j³ + 6σtr²d_j² + 15σtr d_j + 15)/d_j⁷.
    #[must_use]
    pub fn rd_curvature(&self, r: f64) -> f64 {
        let term = |z: f64| {
            let d = (r * r + z * z).sqrt();
            let sd = self.sigma_tr * d;
            z * (-sd).exp() * (((sd + 6.0) * sd + 15.0) * sd + 15.0) / d.powi(7)
        };
        self.alpha_prime / (4.0 * std::f64::consts::PI) * (term(self.z_r) + term(self.z_v))
    }

    /// [`Dipole::rd`], [`Dipole::rd_slope_over_r`] and [`Dipole::rd_curvature`] at `r` at
    /// once, sharing each source's exponential (a third of the work of the three calls).
    #[must_use]
    pub fn rd_with_derivatives(&self, r: f64) -> [f64; 3] {
        let mut out = [0.0; 3];
        for z in [self.z_r, self.z_v] {
            let d = (r * r + z * z).sqrt();
            let sd = self.sigma_tr * d;
            let (inv, e) = (1.0 / d, z * (-sd).exp());
            let (inv2, inv3) = (inv * inv, inv * inv * inv);
            out[0] += e * (1.0 + sd) * inv3;
            out[1] -= e * ((sd + 3.0) * sd + 3.0) * inv3 * inv2;
            out[2] += e * (((sd + 6.0) * sd + 15.0) * sd + 15.0) * inv3 * inv2 * inv2;
        }
        out.map(|x| self.alpha_prime / (4.0 * std::f64::consts::PI) * x)
    }

    /// Total diffuse reflectance ∫₀^∞ Rd(r) 2πr dr = (α′/2)(e^{−σtr z_r} + e^{−σtr z_v})
    /// (Jensen et al. 2001's Rd(r) integrated in closed form; equals
    /// [`total_diffuse_reflectance`] of α′).
    #[must_use]
    pub fn total(&self) -> f64 {
        0.5 * self.alpha_prime * ((-self.sigma_tr * self.z_r).exp() + (-self.sigma_tr * self.z_v).exp())
    }
}

/// Rd(r) of [`Dipole::rd`] for one channel given by its coefficients (mm⁻¹) and η.
#[must_use]
pub fn rd_profile(sigma_a: f64, sigma_s_prime: f64, eta: f64, r: f64) -> f64 {
    Dipole::new(sigma_a, sigma_s_prime, eta).rd(r)
}

/// Total diffuse reflectance of the classical dipole as a function of the reduced albedo
/// (Jensen et al. 2001; Jensen & Buhler 2002):
///
/// Rd = (α′/2) (1 + e^{−(4/3) A √(3(1−α′))}) e^{−√(3(1−α′))},
///
/// with A = [`a_coefficient`]`(eta)`. Increasing in α′ from Rd(0) = 0 to Rd(1) = 1.
/// `alpha_prime` is clamped to [0, 1]. Near α′ = 1 the subtraction 1 − α′ costs digits;
/// [`Medium::total_diffuse_reflectance`](super::Medium::total_diffuse_reflectance) works from
/// σa/σ′t instead and keeps them.
#[must_use]
pub fn total_diffuse_reflectance(alpha_prime: f64, eta: f64) -> f64 {
    let alpha_prime = alpha_prime.clamp(0.0, 1.0);
    rd_closed_form(alpha_prime, (3.0 * (1.0 - alpha_prime)).sqrt(), eta)
}

/// The closed form Rd = ½ α′ (1 + e^{−4As/3}) e^{−s} with s = σtr z_r = √(3(1 − α′)) given
/// separately, so that callers holding σa/σ′t (= 1 − α′) keep full precision as α′ → 1.
pub(super) fn rd_closed_form(alpha_prime: f64, s: f64, eta: f64) -> f64 {
    let k = 4.0 * a_coefficient(eta) / 3.0;
    0.5 * alpha_prime * (1.0 + (-k * s).exp()) * (-s).exp()
}

/// A reduced albedo held as the pair (α′, 1 − α′), each to full relative precision.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct AlbedoPair {
    /// α′ = σ′s/σ′t.
    pub alpha_prime: f64,
    /// 1 − α′ = σa/σ′t.
    pub one_minus_alpha_prime: f64,
}

/// Inverts the total diffuse reflectance: the reduced albedo, as an [`AlbedoPair`], whose
/// [`rd_closed_form`] equals `rd` ∈ [0, 1] at index `eta`.
///
/// Rd is strictly increasing in α′ (and strictly decreasing in s = √(3(1 − α′)): each factor
/// of the s-form ½(1 − s²/3)(1 + e^{−ks})e^{−s} is positive and decreasing). For Rd ≤ ½ the
/// root is sought in α′ (well away from α′ = 1, where dRd/dα′ is unbounded); above, in s, which
/// resolves 1 − α′ = s²/3 to full precision as Rd → 1. Both use [`safeguarded_newton`].
pub(super) fn albedo_from_rd(rd: f64, eta: f64) -> AlbedoPair {
    let k = 4.0 * a_coefficient(eta) / 3.0;
    if rd <= 0.0 {
        return AlbedoPair { alpha_prime: 0.0, one_minus_alpha_prime: 1.0 };
    }
    if rd >= 1.0 {
        return AlbedoPair { alpha_prime: 1.0, one_minus_alpha_prime: 0.0 };
    }
    if rd <= 0.5 {
        let residual = |a: f64| {
            let s = (3.0 * (1.0 - a)).sqrt();
            let (v, w) = (1.0 + (-k * s).exp(), (-s).exp());
            // d/dα′ [½α′ v(s) w(s)] with ds/dα′ = −3/(2s).
            let dvw_ds = -k * (-k * s).exp() * w - v * w;
            let d = 0.5 * v * w + 0.5 * a * dvw_ds * (-1.5 / s);
            (0.5 * a * v * w - rd, d)
        };
        let a = safeguarded_newton(residual, 0.0, 1.0, rd);
        AlbedoPair { alpha_prime: a, one_minus_alpha_prime: 1.0 - a }
    } else {
        let residual = |s: f64| {
            let (u, du) = (1.0 - s * s / 3.0, -2.0 * s / 3.0);
            let (v, dv) = (1.0 + (-k * s).exp(), -k * (-k * s).exp());
            let (w, dw) = ((-s).exp(), -(-s).exp());
            (0.5 * u * v * w - rd, 0.5 * (du * v * w + u * dv * w + u * v * dw))
        };
        // First-order start: Rd ≈ 1 − (1 + k/2) s near s = 0.
        let s = safeguarded_newton(residual, 0.0, 3.0_f64.sqrt(), (1.0 - rd) / (1.0 + 0.5 * k));
        AlbedoPair { alpha_prime: 1.0 - s * s / 3.0, one_minus_alpha_prime: s * s / 3.0 }
    }
}

/// Root of a strictly monotone function on [lo, hi] whose values at the ends have opposite
/// signs: Newton steps from `x0`, replaced by bisection whenever a step would leave the current
/// bracket (Press et al., *Numerical Recipes* §9.4, `rtsafe`). `f` returns (value, derivative).
/// Stops when the bracket or the step reaches the last bits of x, so the result is the root to
/// machine precision.
fn safeguarded_newton(f: impl Fn(f64) -> (f64, f64), lo: f64, hi: f64, x0: f64) -> f64 {
    let increasing = f(hi).0 > f(lo).0;
    let (mut lo, mut hi) = (lo, hi);
    let mut x = x0.clamp(lo, hi);
    for _ in 0..MAX_INVERSION_STEPS {
        let (value, slope) = f(x);
        if value == 0.0 {
            return x;
        }
        if (value < 0.0) == increasing {
            lo = x;
        } else {
            hi = x;
        }
        let newton = x - value / slope;
        let next = if newton > lo && newton < hi { newton } else { 0.5 * (lo + hi) };
        let step = (next - x).abs();
        x = next;
        if step <= 2.0 * f64::EPSILON * x.abs() || hi - lo <= 2.0 * f64::EPSILON * x.abs() {
            break;
        }
    }
    x
}

/// The reduced albedo α′ whose total diffuse reflectance ([`total_diffuse_reflectance`]) is
/// `rd`, at refractive index `eta`: the inverse of Jensen et al. 2001's Rd(α′), solved by
/// safeguarded Newton iteration to machine precision (α′ to ~1e-16, far inside 1e-12).
///
/// # Errors
/// [`OpticsError::InvalidScalar`] naming `rd` unless it is finite and in [0, 1], or `eta`
/// unless it is in [1, 4).
pub fn reduced_albedo_from_rd(rd: f64, eta: f64) -> Result<f64, OpticsError> {
    if !(0.0..=1.0).contains(&rd) {
        return Err(OpticsError::InvalidScalar {
            field: "rd",
            value: rd,
            requirement: "total diffuse reflectance must be in [0, 1]",
        });
    }
    check_eta(eta)?;
    Ok(albedo_from_rd(rd, eta).alpha_prime)
}

#[cfg(test)]
mod tests {
    use super::super::quadrature::integrate;
    use super::*;

    /// (σa, σ′s, η) spanning low and high albedo, short and long diffusion lengths.
    const CASES: [(f64, f64, f64); 7] = [
        (0.0021, 2.19, 1.5), // marble red, ℓd 8.5 mm
        (0.0002, 7.38, 1.3), // cream red, ℓd 15 mm
        (1.45, 0.03, 1.3),   // ketchup blue, α′ 0.02
        (0.07, 1.59, 1.3),   // skin2 green
        (0.5, 0.5, 1.0),     // no interface
        (0.01, 1.0, 2.4),    // diamond-like index
        (0.3, 0.0, 1.3),     // pure absorber: Rd ≡ 0
    ];

    /// ∫₀^∞ Rd(r) 2πr dr by adaptive Simpson over geometrically growing panels.
    fn integrate_profile(d: &Dipole) -> f64 {
        let f = |r: f64| d.rd(r) * 2.0 * std::f64::consts::PI * r;
        // Beyond r_max the integrand is below e^{-40} of its scale.
        let r_max = 40.0 / d.sigma_tr + 40.0 * d.z_v;
        let mut total = 0.0;
        let (mut lo, mut hi) = (0.0, d.z_r);
        while lo < r_max {
            total += integrate(&f, lo, hi, 1e-14);
            lo = hi;
            hi *= 2.0;
        }
        total
    }

    #[test]
    fn profile_integrates_to_the_closed_form_total() {
        for (sa, ss, eta) in CASES {
            let d = Dipole::new(sa, ss, eta);
            let numeric = integrate_profile(&d);
            let closed = total_diffuse_reflectance(ss / (sa + ss), eta);
            // 1 − α′ computed from α′ loses digits as α′ → 1 (cream: 1 − α′ = 2.7e-5).
            assert!((d.total() - closed).abs() < 1e-13, "{sa} {ss}");
            let err = (numeric - closed).abs();
            assert!(err <= 1e-3 * closed && err < 1e-9, "{sa} {ss} {eta}: {numeric} vs {closed}");
        }
    }

    #[test]
    fn profile_is_positive_and_decreasing() {
        let d = Dipole::new(0.0021, 2.19, 1.5);
        let mut last = f64::INFINITY;
        for i in 0..200 {
            let r = 0.1 * i as f64;
            let v = d.rd(r);
            assert!(v > 0.0 && v < last, "r {r}: {v}");
            last = v;
        }
        assert_eq!(rd_profile(0.0021, 2.19, 1.5, 1.0), d.rd(1.0));
    }

    #[test]
    fn profile_slope_and_curvature_match_central_differences() {
        for (sa, ss, eta) in CASES.into_iter().filter(|c| c.1 > 0.0) {
            let d = Dipole::new(sa, ss, eta);
            for r in [0.01f64, 0.3, 2.0, 15.0] {
                let h = 1e-5 * r.max(0.1);
                let numeric = (d.rd(r + h) - d.rd(r - h)) / (2.0 * h) / r;
                let slope = d.rd_slope_over_r(r);
                assert!((slope / numeric - 1.0).abs() < 1e-6, "{sa} {ss} r {r}: {slope} vs {numeric}");
                let k = |r: f64| d.rd_slope_over_r(r);
                let numeric = (k(r + h) - k(r - h)) / (2.0 * h) / r;
                let curvature = d.rd_curvature(r);
                assert!((curvature / numeric - 1.0).abs() < 1e-5, "{sa} {ss} r {r}: {curvature} vs {numeric}");
                let [f, k, l] = d.rd_with_derivatives(r);
                for (a, b) in [(f, d.rd(r)), (k, slope), (l, curvature)] {
                    assert!((a / b - 1.0).abs() < 1e-13, "{sa} {ss} r {r}: {a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn dipole_geometry() {
        let d = Dipole::new(0.013, 1.09, 1.3);
        assert!((d.z_r - 1.0 / 1.103).abs() < 1e-15);
        assert!((d.z_v - d.z_r * (1.0 + 4.0 * a_coefficient(1.3) / 3.0)).abs() < 1e-15);
        assert!((d.sigma_tr - (3.0f64 * 0.013 * 1.103).sqrt()).abs() < 1e-15);
    }

    #[test]
    fn total_reflectance_end_points_and_monotonicity() {
        for eta in [1.0, 1.3, 1.5, 2.0] {
            assert_eq!(total_diffuse_reflectance(0.0, eta), 0.0);
            assert_eq!(total_diffuse_reflectance(1.0, eta), 1.0);
            let mut last = -1.0;
            for i in 0..=1000 {
                let v = total_diffuse_reflectance(i as f64 / 1000.0, eta);
                assert!(v > last);
                last = v;
            }
        }
        // A larger index traps more light: less reflectance at the same albedo.
        assert!(total_diffuse_reflectance(0.9, 1.5) < total_diffuse_reflectance(0.9, 1.3));
    }

    #[test]
    fn inversion_recovers_the_albedo() {
        for eta in [1.0, 1.3, 1.5, 2.5] {
            for i in 0..=2000 {
                let alpha = i as f64 / 2000.0;
                let rd = total_diffuse_reflectance(alpha, eta);
                let back = reduced_albedo_from_rd(rd, eta).unwrap();
                assert!((back - alpha).abs() < 1e-12, "{eta} {alpha}: {back}");
                let again = total_diffuse_reflectance(back, eta);
                assert!((again - rd).abs() < 2e-15, "{eta} {alpha}: {again} vs {rd}");
            }
        }
    }

    #[test]
    fn inversion_near_the_ends() {
        let tiny = [1e-300, 1e-12, 1e-6, 0.5, 0.5 + 1e-12];
        let near_one = [1.0 - 1e-6, 1.0 - 1e-12, 1.0 - f64::EPSILON];
        for rd in tiny.into_iter().chain(near_one) {
            let p = albedo_from_rd(rd, 1.3);
            assert!((p.alpha_prime + p.one_minus_alpha_prime - 1.0).abs() <= f64::EPSILON);
            let back = rd_closed_form(p.alpha_prime, (3.0 * p.one_minus_alpha_prime).sqrt(), 1.3);
            assert!((back - rd).abs() <= 1e-15 * rd, "{rd}: {back}");
        }
        assert_eq!(reduced_albedo_from_rd(0.0, 1.3).unwrap(), 0.0);
        assert_eq!(reduced_albedo_from_rd(1.0, 1.3).unwrap(), 1.0);
    }

    #[test]
    fn inversion_rejects_bad_input() {
        for rd in [-0.1, 1.1, f64::NAN, f64::INFINITY] {
            assert!(matches!(reduced_albedo_from_rd(rd, 1.3), Err(OpticsError::InvalidScalar { field: "rd", .. })));
        }
        assert!(matches!(reduced_albedo_from_rd(0.5, 0.5), Err(OpticsError::InvalidScalar { field: "eta", .. })));
    }
}
