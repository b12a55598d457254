//! Public-API tests of `transcut::optics` against published numbers: the Jensen et al. 2001
//! preset table, the uniform-sphere worked example of ARCHITECTURE.md, and round trips.

use proptest::prelude::*;
use transcut::optics::{
    f_ext, fdr, fresnel_reflectance, reduced_albedo_from_rd, total_diffuse_reflectance, transmittance_out,
    uniform_sphere_fluence, ArtistMapping, ArtistParams, BoundaryTerms, Medium, OpticsError, UniformSphere, PRESET_NAMES,
};

/// A published value and the number of decimals it was printed with.
#[derive(Clone, Copy, Debug)]
struct Published {
    value: f64,
    decimals: i32,
}

const fn p(value: f64, decimals: i32) -> Published {
    Published { value, decimals }
}

/// Number of significant digits of a published value.
fn significant_digits(v: Published) -> i32 {
    v.decimals + v.value.abs().log10().floor() as i32 + 1
}

/// The computed value agrees with the published one: within 1% relative; or, for a value
/// printed with at most two significant digits (where 1% is finer than the table's own
/// resolution, e.g. ketchup's 0.006), by rounding to exactly the printed digits.
fn agrees(computed: f64, published: Published) -> bool {
    let relative = (computed / published.value - 1.0).abs();
    if relative <= 0.01 {
        return true;
    }
    let unit = 10f64.powi(-published.decimals);
    significant_digits(published) <= 2 && ((computed / unit).round() - published.value / unit).abs() < 1e-9
}

/// Jensen et al. 2001 (and the RenderMan tables copied from it): name, Rd, ℓd (mm).
fn published_table() -> Vec<(&'static str, [Published; 3], [Published; 3])> {
    vec![
        ("marble", [p(0.830, 3), p(0.791, 3), p(0.753, 3)], [p(8.51, 2), p(5.57, 2), p(3.95, 2)]),
        ("skin2", [p(0.623, 3), p(0.433, 3), p(0.343, 3)], [p(4.82, 2), p(1.69, 2), p(1.09, 2)]),
        ("ketchup", [p(0.164, 3), p(0.006, 3), p(0.002, 3)], [p(4.76, 2), p(0.575, 3), p(0.39, 2)]),
        ("cream", [p(0.976, 3), p(0.900, 3), p(0.725, 3)], [p(15.03, 2), p(4.66, 2), p(2.54, 2)]),
    ]
}

#[test]
fn presets_reproduce_the_published_rd_and_diffuse_mean_free_path() {
    for (name, rd, ld) in published_table() {
        let m = Medium::preset(name).unwrap();
        let (got_rd, got_ld) = (m.total_diffuse_reflectance(), m.diffuse_mean_free_path());
        for c in 0..3 {
            assert!(agrees(got_rd[c], rd[c]), "{name} Rd[{c}] = {} vs {:?}", got_rd[c], rd[c]);
            assert!(agrees(got_ld[c], ld[c]), "{name} ld[{c}] = {} vs {:?}", got_ld[c], ld[c]);
        }
    }
}

#[test]
fn published_values_needing_the_rounding_rule_are_only_the_two_digit_ones() {
    // Documents exactly where the 1% rule is replaced by agreement to the printed digits:
    // ketchup Rd green 0.0063 → "0.006", blue 0.0018 → "0.002", ℓd blue 0.394 → "0.39".
    let mut rounded = Vec::new();
    for (name, rd, ld) in published_table() {
        let m = Medium::preset(name).unwrap();
        for (got, published, what) in [(m.total_diffuse_reflectance(), rd, "Rd"), (m.diffuse_mean_free_path(), ld, "ld")] {
            for c in 0..3 {
                if (got[c] / published[c].value - 1.0).abs() > 0.01 {
                    assert!(significant_digits(published[c]) <= 2);
                    rounded.push(format!("{name} {what}[{c}]"));
                }
            }
        }
    }
    assert_eq!(rounded, ["ketchup Rd[1]", "ketchup Rd[2]", "ketchup ld[2]"]);
}

#[test]
fn marble_rd_needs_its_own_index_of_refraction() {
    // The published marble Rd is reproduced at η = 1.5 and not at the 1.3 of the other media.
    let marble = Medium::preset("marble").unwrap();
    assert_eq!(marble.eta, 1.5);
    let at_1_3 = Medium { eta: 1.3, ..marble }.total_diffuse_reflectance();
    assert!((at_1_3[0] / 0.830 - 1.0).abs() > 0.04, "{at_1_3:?}");
}

#[test]
fn every_preset_is_valid_and_consistent() {
    for name in PRESET_NAMES {
        let m = Medium::preset(name).unwrap();
        m.validate().unwrap();
        let (rd, ld, tr) = (m.total_diffuse_reflectance(), m.diffuse_mean_free_path(), m.sigma_tr());
        for c in 0..3 {
            assert!(rd[c] > 0.0 && rd[c] < 1.0, "{name}");
            assert!((ld[c] * tr[c] - 1.0).abs() < 1e-14, "{name}");
            let via_albedo = total_diffuse_reflectance(m.reduced_albedo()[c], m.eta);
            assert!((rd[c] - via_albedo).abs() < 1e-12, "{name}");
        }
    }
    assert!(matches!(Medium::preset("granite"), Err(OpticsError::UnknownPreset { .. })));
    assert_eq!(Medium::preset("SkimMilk").unwrap(), Medium::preset("skimmilk").unwrap());
}

/// ∫ₐᵇ f by composite Simpson on `n` (even) panels.
fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let inner: f64 = (1..n).map(|i| f(a + h * i as f64) * if i % 2 == 1 { 4.0 } else { 2.0 }).sum();
    h / 3.0 * (f(a) + inner + f(b))
}

#[test]
fn dipole_profile_integrates_to_the_total_for_every_preset() {
    for name in PRESET_NAMES {
        let m = Medium::preset(name).unwrap();
        let (total, at_0_7) = (m.total_diffuse_reflectance(), m.rd_profile(0.7));
        for (c, total) in total.into_iter().enumerate() {
            let d = m.dipole(c);
            // Integrate in u = ln(r + z_r) so that the peak near 0 and the long tail are both
            // resolved; e^{-σtr r} is below 1e-20 of its scale at the upper end.
            let r_max = 50.0 / d.sigma_tr + 50.0 * d.z_v;
            let f = |u: f64| {
                let r = u.exp() - d.z_r;
                d.rd(r) * 2.0 * std::f64::consts::PI * r * u.exp()
            };
            let numeric = simpson(f, d.z_r.ln(), (r_max + d.z_r).ln(), 20_000);
            assert!((numeric / total - 1.0).abs() < 1e-3, "{name}[{c}]: {numeric} vs {total}");
            assert_eq!(at_0_7[c], d.rd(0.7));
        }
    }
}

#[test]
fn fresnel_reference_values() {
    assert!((f_ext(1.3) - 0.0611).abs() < 1e-3);
    assert_eq!(fresnel_reflectance(0.7, 1.0), 0.0);
    assert_eq!(transmittance_out(1.0, 0.7), 1.0);
    assert!(fdr(1.0).abs() < 0.01);
    assert!((fresnel_reflectance(1.0, 1.5) - 0.04).abs() < 1e-15);
    // Total internal reflection from inside glass beyond 41.8°.
    let cos_45 = std::f64::consts::FRAC_1_SQRT_2;
    assert_eq!(fresnel_reflectance(cos_45, 1.0 / 1.5), 1.0);
}

#[test]
fn uniform_sphere_worked_example() {
    // ARCHITECTURE.md: R = 10 mm, marble coefficients at η = 1.3, constant environment of
    // radiance 1, q = π(1 − F_ext) = 2.9495.
    let marble = Medium { eta: 1.3, ..Medium::preset("marble").unwrap() };
    let q = std::f64::consts::PI * (1.0 - f_ext(1.3));
    assert!((q / 2.9495 - 1.0).abs() < 1e-4, "{q}");
    let phi = uniform_sphere_fluence(&marble, 10.0, q);
    for (got, want) in phi.iter().zip([20.561, 20.058, 19.491]) {
        assert!((got / want - 1.0).abs() < 1e-3, "phi(R) = {phi:?}");
    }
    let b = BoundaryTerms::new(1.3).unwrap();
    let lo = phi.map(|f| b.radiance_normal(f, q));
    for (got, want) in lo.iter().zip([0.9394, 0.9072, 0.8709]) {
        assert!((got / want - 1.0).abs() < 1e-3, "Lo = {lo:?}");
    }
    let sphere = UniformSphere::new(marble, 10.0, [q; 3]).unwrap();
    assert_eq!(sphere.surface_radiance(1.0), lo);
    assert_eq!(sphere.fluence(10.0), phi);
    // The centre is darker than the surface: light is absorbed on the way in.
    let centre = sphere.fluence(0.0);
    assert!((0..3).all(|c| centre[c] < phi[c]));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn artist_round_trip(
        albedo in prop::array::uniform3(1e-3f64..0.999),
        log_radius in prop::array::uniform3(-3.0f64..3.0),
        log_scale in -2.0f64..1.0,
        log_mm in -1.0f64..4.0,
        eta in 1.0f64..2.5,
        g in -0.9f64..0.9,
    ) {
        let params = ArtistParams {
            albedo,
            radius: log_radius.map(|l| 10f64.powf(l)),
            scale: 10f64.powf(log_scale),
            mm_per_unit: 10f64.powf(log_mm),
            eta,
            g,
            mapping: ArtistMapping::Dipole,
        };
        let medium = params.to_medium().unwrap();
        let back = medium.to_artist(params.mm_per_unit, params.scale).unwrap();
        for c in 0..3 {
            prop_assert!((back.albedo[c] - params.albedo[c]).abs() < 1e-9);
            prop_assert!((back.radius[c] / params.radius[c] - 1.0).abs() < 1e-9);
        }
        prop_assert_eq!(back.eta, eta);
        prop_assert_eq!(back.g, g);
    }

    #[test]
    fn medium_round_trip_through_artist_parameters(
        sigma_a in prop::array::uniform3(1e-4f64..2.0),
        sigma_s_prime in prop::array::uniform3(1e-3f64..10.0),
        eta in 1.0f64..2.0,
    ) {
        let m = Medium::new(sigma_a, sigma_s_prime, eta, 0.0).unwrap();
        let back = m.to_artist(1.0, 1.0).unwrap().to_medium().unwrap();
        for c in 0..3 {
            prop_assert!((back.sigma_a[c] / m.sigma_a[c] - 1.0).abs() < 1e-9);
            prop_assert!((back.sigma_s_prime[c] / m.sigma_s_prime[c] - 1.0).abs() < 1e-9);
        }
    }

    #[test]
    fn albedo_inversion_round_trip(alpha in 0.0f64..=1.0, eta in 1.0f64..3.0) {
        let rd = total_diffuse_reflectance(alpha, eta);
        let back = reduced_albedo_from_rd(rd, eta).unwrap();
        prop_assert!((back - alpha).abs() < 1e-12);
    }
}

#[test]
fn artist_parameters_reject_invalid_input() {
    let ok = ArtistParams {
        albedo: [0.5; 3],
        radius: [1.0; 3],
        scale: 1.0,
        mm_per_unit: 1.0,
        eta: 1.3,
        g: 0.0,
        mapping: ArtistMapping::default(),
    };
    assert!(ok.to_medium().is_ok());
    let e = ArtistParams { albedo: [0.5, 1.0, 0.5], ..ok }.to_medium().unwrap_err();
    assert!(e.to_string().contains("albedo[1] (green)"), "{e}");
    let e = ArtistParams { radius: [1.0, 1.0, -2.0], ..ok }.to_medium().unwrap_err();
    assert!(e.to_string().contains("radius[2] (blue)"), "{e}");
    let e = ArtistParams { albedo: [f64::NAN, 0.5, 0.5], ..ok }.to_medium().unwrap_err();
    assert!(e.to_string().contains("albedo[0] (red) = NaN"), "{e}");
}
