//! Dielectric Fresnel terms at the boundary of a medium of refractive index η in air.
//!
//! Conventions: `eta` in [`fresnel_reflectance`] is the *relative* index n_t/n_i of the side the
//! light goes into over the side it comes from (η > 1 entering the medium from air, 1/η leaving
//! it). Everywhere else `eta` is the medium's index relative to the surrounding air (η ≥ 1), and
//! the functions say which way the light travels.

use super::quadrature::integrate;

/// Absolute tolerance of the hemispherical averages; far below the 1e-12 the tests ask for.
const HEMISPHERE_TOL: f64 = 1e-14;

/// Exact unpolarised Fresnel reflectance of a smooth dielectric interface (the Fresnel
/// formulae, Born & Wolf, *Principles of Optics*, averaged over the two polarisations):
///
/// R = ½ (r_s² + r_p²),  r_s = (cos θi − η cos θt)/(cos θi + η cos θt),
/// r_p = (η cos θi − cos θt)/(η cos θi + cos θt),  sin θt = sin θi / η,
///
/// for light arriving at angle θi (`cos_i` = cos θi, measured on the incident side) on an
/// interface whose relative index is `eta` = n_t/n_i. Beyond the critical angle (η < 1,
/// sin θi > η) the reflection is total and R = 1. `cos_i` is clamped to [0, 1]; η = 1 (no
/// interface) gives 0 at every angle.
#[must_use]
pub fn fresnel_reflectance(cos_i: f64, eta: f64) -> f64 {
    if eta == 1.0 {
        return 0.0;
    }
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (r_s * r_s + r_p * r_p)
}

/// Fresnel transmittance T = 1 − R (energy conservation at a non-absorbing interface) for the
/// same arguments as [`fresnel_reflectance`].
#[must_use]
pub fn fresnel_transmittance(cos_i: f64, eta: f64) -> f64 {
    1.0 - fresnel_reflectance(cos_i, eta)
}

/// Cosine of the critical angle for light arriving on an interface of relative index `eta`
/// (n_t/n_i): cos θc = √(1 − η²) when η < 1 (total internal reflection for cos θi < cos θc),
/// `None` when η ≥ 1 (no total internal reflection).
#[must_use]
pub fn critical_cosine(eta: f64) -> Option<f64> {
    (eta < 1.0).then(|| (1.0 - eta * eta).sqrt())
}

/// Fresnel transmittance T(η, θo) for light *leaving* a medium of index `eta` (relative to air)
/// into air along a direction at angle θo to the outward normal, `cos_o` = cos θo measured on
/// the air side.
///
/// Inside, the light travelled at θi with sin θi = sin θo / η (always below the critical angle,
/// since θo ≤ 90°). The Fresnel reflectance is the same for the pair (θi inside, θo outside)
/// whichever way the light goes (Stokes relations), so this equals the transmittance of light
/// entering from air at θo: 1 − [`fresnel_reflectance`]`(cos_o, eta)`.
#[must_use]
pub fn transmittance_out(eta: f64, cos_o: f64) -> f64 {
    fresnel_transmittance(cos_o, eta)
}

/// The exitant Fresnel factor Ft(ωo) = T(η, θo)/η² of ARCHITECTURE.md ("The equations"):
/// [`transmittance_out`] divided by η², because radiance leaving the denser medium spreads over
/// a solid angle η² times larger (the n²-law of radiance, L/n² invariant).
#[must_use]
pub fn ft_out(eta: f64, cos_o: f64) -> f64 {
    transmittance_out(eta, cos_o) / (eta * eta)
}

/// Diffuse Fresnel reflectance Fdr(η) = −1.440/η² + 0.710/η + 0.668 + 0.0636η: Egan & Hilgeman's
/// (1979) polynomial fit, as used by Jensen et al. 2001 and TransCut. It approximates the
/// cosine-weighted hemispherical reflectance of light inside a medium of index `eta` meeting its
/// boundary with air ([`fdr_exact`]) to within 2e-3 for 1 ≤ η ≤ 2. The fit is not exactly 0 at
/// η = 1 (it gives 0.0016).
#[must_use]
pub fn fdr(eta: f64) -> f64 {
    -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta
}

/// The boundary mismatch coefficient A = (1 + Fdr)/(1 − Fdr) (Jensen et al. 2001;
/// TransCut boundary condition), with Fdr from [`fdr`].
#[must_use]
pub fn a_coefficient(eta: f64) -> f64 {
    let f = fdr(eta);
    (1.0 + f) / (1.0 - f)
}

/// Cosine-weighted hemispherical average of the Fresnel reflectance,
/// 2∫₀¹ R(μ, η) μ dμ, for light arriving diffusely (uniform radiance) on an interface of
/// relative index `eta` = n_t/n_i. Integrated by adaptive Simpson to 1e-14, split at the critical
/// cosine when η < 1 (where R has a kink).
#[must_use]
pub fn hemispherical_reflectance(eta: f64) -> f64 {
    let f = |mu: f64| 2.0 * fresnel_reflectance(mu, eta) * mu;
    match critical_cosine(eta) {
        // Below the critical cosine R = 1 exactly: 2∫₀^μc μ dμ = μc².
        Some(mu_c) => mu_c * mu_c + integrate(&f, mu_c, 1.0, HEMISPHERE_TOL),
        None => integrate(&f, 0.0, 1.0, HEMISPHERE_TOL),
    }
}

/// F_ext(η): the cosine-weighted hemispherical mean external reflectance 2∫₀¹ R(μ) μ dμ for
/// diffuse light entering a medium of index `eta` from air; F_ext(1.3) = 0.061132. Under a
/// constant environment of radiance L the transmitted source is q = π L (1 − F_ext)
/// (ARCHITECTURE.md, uniform sphere example).
#[must_use]
pub fn f_ext(eta: f64) -> f64 {
    hemispherical_reflectance(eta)
}

/// The exact internal diffuse reflectance 2∫₀¹ R(μ, 1/η) μ dμ for diffuse light inside a medium
/// of index `eta` meeting its boundary with air, including total internal reflection; the
/// quantity the [`fdr`] fit approximates (e.g. 0.444457 at η = 1.3, against the fit's 0.444763).
#[must_use]
pub fn fdr_exact(eta: f64) -> f64 {
    hemispherical_reflectance(1.0 / eta)
}

#[cfg(test)]
mod tests {
    use super::*;

    const ETAS: [f64; 6] = [1.0, 1.1, 1.3, 1.5, 2.0, 2.5];

    #[test]
    fn no_interface_reflects_nothing() {
        for i in 0..=20 {
            let c = i as f64 / 20.0;
            assert_eq!(fresnel_reflectance(c, 1.0), 0.0);
            assert_eq!(transmittance_out(1.0, c), 1.0);
            assert_eq!(ft_out(1.0, c), 1.0);
        }
        assert!(fdr(1.0).abs() < 0.01, "fdr(1) = {}", fdr(1.0));
        assert!((fdr(1.0) - 0.0016).abs() < 1e-12);
        assert!(fdr_exact(1.0).abs() < 1e-14);
        assert!(f_ext(1.0).abs() < 1e-14);
    }

    #[test]
    fn normal_incidence_matches_closed_form() {
        for eta in ETAS {
            let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
            assert!((fresnel_reflectance(1.0, eta) - r0).abs() < 1e-15);
            // Same from the other side.
            assert!((fresnel_reflectance(1.0, 1.0 / eta) - r0).abs() < 1e-15);
        }
        assert!((fresnel_reflectance(1.0, 1.5) - 0.04).abs() < 1e-15);
    }

    #[test]
    fn reflectance_plus_transmittance_is_one_and_bounded() {
        for eta in [0.4, 0.77, 1.0, 1.3, 1.5, 2.4] {
            for i in 0..=100 {
                let c = i as f64 / 100.0;
                let r = fresnel_reflectance(c, eta);
                assert!((0.0..=1.0).contains(&r), "R({c}, {eta}) = {r}");
                assert!((r + fresnel_transmittance(c, eta) - 1.0).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn grazing_incidence_reflects_everything() {
        for eta in [1.3, 1.5, 1.0 / 1.3] {
            assert_eq!(fresnel_reflectance(0.0, eta), 1.0);
        }
    }

    #[test]
    fn total_internal_reflection_beyond_the_critical_angle() {
        let eta = 1.0 / 1.5;
        let c_crit = critical_cosine(eta).unwrap();
        // sin θc = 1/1.5.
        assert!((c_crit - (1.0 - 1.0 / 2.25f64).sqrt()).abs() < 1e-15);
        for k in 0..=50 {
            let c = c_crit * k as f64 / 50.0;
            assert_eq!(fresnel_reflectance(c, eta), 1.0);
        }
        assert!(fresnel_reflectance(c_crit + 1e-3, eta) < 1.0);
        assert!(critical_cosine(1.3).is_none());
    }

    #[test]
    fn reflectance_is_reciprocal_across_the_interface() {
        // R(θi, η) = R(θt, 1/η) for the refracted pair (Stokes relations).
        // (Grazing exit, i = 0, maps to exactly the critical angle inside, where the rounding of
        // the computed cosine decides between total and near-total reflection.)
        for eta in [1.2, 1.5, 2.0] {
            for i in 1..=20 {
                let c_out = i as f64 / 20.0;
                let sin_in = (1.0 - c_out * c_out).sqrt() / eta;
                let c_in = (1.0 - sin_in * sin_in).sqrt();
                let a = fresnel_reflectance(c_out, eta);
                let b = fresnel_reflectance(c_in, 1.0 / eta);
                assert!((a - b).abs() < 1e-13, "{eta} {c_out}: {a} vs {b}");
            }
        }
    }

    #[test]
    fn exit_transmittance_and_ft() {
        let eta: f64 = 1.3;
        let t0 = 1.0 - ((eta - 1.0) / (eta + 1.0)).powi(2);
        assert!((transmittance_out(eta, 1.0) - t0).abs() < 1e-15);
        assert!((ft_out(eta, 1.0) - t0 / 1.69).abs() < 1e-15);
        assert_eq!(transmittance_out(eta, 0.0), 0.0);
        // T falls monotonically towards grazing exit.
        let mut last = f64::INFINITY;
        for i in (0..=20).rev() {
            let t = transmittance_out(eta, i as f64 / 20.0);
            assert!(t <= last);
            last = t;
        }
    }

    #[test]
    fn external_diffuse_reflectance_at_1_3() {
        let f = f_ext(1.3);
        assert!((f - 0.0611).abs() < 1e-3, "{f}");
        assert!((f - 0.061_131_825).abs() < 1e-8, "{f}");
    }

    #[test]
    fn fit_tracks_the_exact_internal_diffuse_reflectance() {
        for k in 0..=20 {
            let eta = 1.0 + k as f64 * 0.05;
            let (fit, exact) = (fdr(eta), fdr_exact(eta));
            assert!((fit - exact).abs() < 2e-3, "eta {eta}: fit {fit}, exact {exact}");
        }
        assert!((fdr_exact(1.3) - 0.444_457).abs() < 1e-5);
    }

    #[test]
    fn diffuse_energy_balance_across_the_interface() {
        // Reciprocity of diffuse transmission: (1 − F_ext(η)) = η² (1 − F_int(η)).
        for eta in [1.1, 1.3, 1.5, 2.0] {
            let lhs = 1.0 - f_ext(eta);
            let rhs = eta * eta * (1.0 - fdr_exact(eta));
            assert!((lhs - rhs).abs() < 1e-10, "{eta}: {lhs} vs {rhs}");
        }
    }

    #[test]
    fn a_coefficient_at_1_3() {
        let f = fdr(1.3);
        assert!((f - 0.444_762_840_236_686).abs() < 1e-12);
        assert!((a_coefficient(1.3) - (1.0 + f) / (1.0 - f)).abs() < 1e-15);
        assert!((a_coefficient(1.3) - 2.602_064_387_86).abs() < 1e-9);
    }
}
