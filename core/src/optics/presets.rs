//! Named media: the measured materials of Jensen, Marschner, Levoy & Hanrahan, "A Practical
//! Model for Subsurface Light Transport" (SIGGRAPH 2001), their table of measured materials, plus one artistic preset
//! (jade).
//!
//! Jensen et al. list σ′s and σa in mm⁻¹ for R, G, B, measured at η = 1.3 (marble: 1.5), and
//! with them the total diffuse reflectance Rd and the diffuse mean free path ℓd = 1/σtr. The
//! coefficients below are theirs; the derived Rd and ℓd are reproduced within 1% (or to the
//! digits published) by [`Medium::total_diffuse_reflectance`] and
//! [`Medium::diffuse_mean_free_path`] (tested in `core/tests/integration/optics.rs`).

use super::error::OpticsError;
use super::medium::Medium;

/// One named medium: coefficients in mm⁻¹ (R, G, B) and refractive index; g = 0 for all.
struct Preset {
    name: &'static str,
    sigma_s_prime: [f64; 3],
    sigma_a: [f64; 3],
    eta: f64,
}

/// Index of refraction Jensen et al. 2001 use for every measured material but marble.
const ETA_ORGANIC: f64 = 1.3;

/// The presets, in the order of [`PRESET_NAMES`].
const PRESETS: [Preset; 12] = [
    Preset { name: "apple", sigma_s_prime: [2.29, 2.39, 1.97], sigma_a: [0.0030, 0.0034, 0.046], eta: ETA_ORGANIC },
    Preset { name: "chicken1", sigma_s_prime: [0.15, 0.21, 0.38], sigma_a: [0.015, 0.077, 0.19], eta: ETA_ORGANIC },
    Preset { name: "chicken2", sigma_s_prime: [0.19, 0.25, 0.32], sigma_a: [0.018, 0.088, 0.20], eta: ETA_ORGANIC },
    Preset { name: "cream", sigma_s_prime: [7.38, 5.47, 3.15], sigma_a: [0.0002, 0.0028, 0.0163], eta: ETA_ORGANIC },
    Preset { name: "ketchup", sigma_s_prime: [0.18, 0.07, 0.03], sigma_a: [0.061, 0.97, 1.45], eta: ETA_ORGANIC },
    Preset { name: "marble", sigma_s_prime: [2.19, 2.62, 3.00], sigma_a: [0.0021, 0.0041, 0.0071], eta: 1.5 },
    Preset { name: "potato", sigma_s_prime: [0.68, 0.70, 0.55], sigma_a: [0.0024, 0.0090, 0.12], eta: ETA_ORGANIC },
    Preset { name: "skimmilk", sigma_s_prime: [0.70, 1.22, 1.90], sigma_a: [0.0014, 0.0025, 0.0142], eta: ETA_ORGANIC },
    Preset { name: "skin1", sigma_s_prime: [0.74, 0.88, 1.01], sigma_a: [0.032, 0.17, 0.48], eta: ETA_ORGANIC },
    Preset { name: "skin2", sigma_s_prime: [1.09, 1.59, 1.79], sigma_a: [0.013, 0.070, 0.145], eta: ETA_ORGANIC },
    Preset { name: "wholemilk", sigma_s_prime: [2.55, 3.21, 3.77], sigma_a: [0.0011, 0.0024, 0.014], eta: ETA_ORGANIC },
    // Jade: an *artistic* preset, not a measurement. η = 1.66 is the gemmological refractive
    // index of jadeite (nephrite: 1.61–1.63). The coefficients were chosen by hand for a pale
    // green stone that is translucent over a few millimetres: Rd ≈ (0.443, 0.676, 0.493) and
    // ℓd ≈ (2.1, 4.7, 2.5) mm, the green channel absorbing least.
    Preset { name: "jade", sigma_s_prime: [1.80, 2.10, 1.90], sigma_a: [0.040, 0.007, 0.028], eta: 1.66 },
];

/// Names accepted by [`Medium::preset`] (compared case-insensitively). All but `jade` are the
/// measured materials of Jensen et al. 2001.
pub const PRESET_NAMES: [&str; 12] =
    ["apple", "chicken1", "chicken2", "cream", "ketchup", "marble", "potato", "skimmilk", "skin1", "skin2", "wholemilk", "jade"];

impl Medium {
    /// The named preset (see [`PRESET_NAMES`]; case-insensitive, surrounding spaces ignored),
    /// with g = 0.
    ///
    /// # Errors
    /// [`OpticsError::UnknownPreset`], listing the valid names, when no preset has this name.
    pub fn preset(name: &str) -> Result<Medium, OpticsError> {
        let wanted = name.trim();
        let p = PRESETS
            .iter()
            .find(|p| p.name.eq_ignore_ascii_case(wanted))
            .ok_or_else(|| OpticsError::UnknownPreset { name: name.to_owned(), valid: PRESET_NAMES.join(", ") })?;
        Medium::new(p.sigma_a, p.sigma_s_prime, p.eta, 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_match_the_table_and_every_preset_is_valid() {
        for (p, name) in PRESETS.iter().zip(PRESET_NAMES) {
            assert_eq!(p.name, name);
            let m = Medium::preset(name).unwrap();
            assert_eq!(m.sigma_a, p.sigma_a);
            assert_eq!(m.sigma_s_prime, p.sigma_s_prime);
            assert_eq!(m.g, 0.0);
        }
    }

    #[test]
    fn lookup_is_case_insensitive() {
        let a = Medium::preset("Marble").unwrap();
        let b = Medium::preset(" MARBLE ").unwrap();
        assert_eq!(a, b);
        assert_eq!(a.eta, 1.5);
        assert_eq!(Medium::preset("skin2").unwrap().eta, 1.3);
    }

    #[test]
    fn unknown_name_lists_the_valid_ones() {
        let e = Medium::preset("granite").unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("\"granite\""), "{msg}");
        for name in PRESET_NAMES {
            assert!(msg.contains(name), "{msg}");
        }
    }

    #[test]
    fn jade_is_green_tinted() {
        let rd = Medium::preset("jade").unwrap().total_diffuse_reflectance();
        assert!(rd[1] > rd[0] && rd[1] > rd[2], "{rd:?}");
        assert!((rd[0] - 0.443).abs() < 5e-4 && (rd[1] - 0.676).abs() < 5e-4, "{rd:?}");
    }
}
