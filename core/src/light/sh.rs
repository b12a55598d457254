//! Real spherical harmonics of bands 0–2 (nine coefficients, "SH9") and their use for
//! unshadowed environment lighting (Ramamoorthi & Hanrahan 2001, *An Efficient Representation
//! for Irradiance Environment Maps*).
//!
//! Coefficient order: (l, m) = (0, 0), (1, −1), (1, 0), (1, 1), (2, −2), (2, −1), (2, 0), (2, 1),
//! (2, 2), with the real basis
//!
//! Y₀₀ = ½√(1/π); Y₁₋₁ = √(3/4π) y, Y₁₀ = √(3/4π) z, Y₁₁ = √(3/4π) x;
//! Y₂₋₂ = ½√(15/π) xy, Y₂₋₁ = ½√(15/π) yz, Y₂₀ = ¼√(5/π)(3z² − 1), Y₂₁ = ½√(15/π) xz,
//! Y₂₂ = ¼√(15/π)(x² − y²).
//!
//! A radiance field L(ω) = Σ L_lm Y_lm(ω) seen through a rotationally symmetric lobe k(n·ω)
//! gives (Funk–Hecke) ∫ L(ω) k(n·ω) dω = Σ Â_l L_lm Y_lm(n), Â_l = 2π ∫₋₁¹ k(μ) P_l(μ) dμ.
//! For the clamped cosine k = μ⁺: Â = (π, 2π/3, π/4). For the transmitted source
//! k = μ⁺ T(η, μ) ([`fresnel_cosine_lobe`]); Â₀ = π(1 − F_ext(η)) exactly.

use std::f64::consts::PI;

use glam::DVec3;

use super::sampling::integrate;
use crate::optics::{f_ext, fresnel_transmittance};

/// Band of each of the nine coefficients.
pub const SH9_BAND: [usize; 9] = [0, 1, 1, 1, 2, 2, 2, 2, 2];

const C0: f64 = 0.282_094_791_773_878_14; // ½√(1/π)
const C1: f64 = 0.488_602_511_902_919_9; // √(3/4π)
const C2: f64 = 1.092_548_430_592_079_2; // ½√(15/π)
const C20: f64 = 0.315_391_565_252_520_05; // ¼√(5/π)
const C22: f64 = 0.546_274_215_296_039_6; // ¼√(15/π)

/// The nine real SH basis functions at the unit direction `d` (order in the module docs).
#[must_use]
pub fn sh9_basis(d: DVec3) -> [f64; 9] {
    let (x, y, z) = (d.x, d.y, d.z);
    [C0, C1 * y, C1 * z, C1 * x, C2 * x * y, C2 * y * z, C20 * (3.0 * z * z - 1.0), C2 * x * z, C22 * (x * x - y * y)]
}

/// Exact integrals ∫ Y_i dω of the nine basis functions over the spherical rectangle
/// θ ∈ [θ₀, θ₁] (polar angle from +z), φ ∈ [φ₀, φ₁] (azimuth from +x towards +y), with
/// x = sin θ cos φ, y = sin θ sin φ, z = cos θ, dω = sin θ dθ dφ. Each basis function is a
/// product f(θ) g(φ), so the integral separates into closed-form one-dimensional factors
/// ([`PolarFactors`], [`AzimuthFactors`]).
#[must_use]
pub fn sh9_patch_integrals(theta0: f64, theta1: f64, phi0: f64, phi1: f64) -> [f64; 9] {
    PolarFactors::new(theta0, theta1).patch(&AzimuthFactors::new(phi0, phi1))
}

/// The θ integrals over [θ₀, θ₁] that the SH9 patch integrals need (each including the sin θ
/// of dω): ∫sin θ, ∫cos θ sin θ, ∫cos²θ sin θ, ∫sin²θ, ∫sin²θ cos θ, ∫sin³θ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolarFactors([f64; 6]);

impl PolarFactors {
    /// Closed forms over [θ₀, θ₁].
    #[must_use]
    pub fn new(theta0: f64, theta1: f64) -> Self {
        let (c0, c1) = (theta0.cos(), theta1.cos());
        let (s0, s1) = (theta0.sin(), theta1.sin());
        let one = c0 - c1;
        let zz = (c0 * c0 * c0 - c1 * c1 * c1) / 3.0;
        Self([
            one,
            0.5 * (c0 * c0 - c1 * c1),
            zz,
            0.5 * (theta1 - theta0) - 0.25 * ((2.0 * theta1).sin() - (2.0 * theta0).sin()),
            (s1 * s1 * s1 - s0 * s0 * s0) / 3.0,
            one - zz, // sin³θ = (1 − cos²θ) sin θ
        ])
    }

    /// The nine integrals ∫ Y_i dω over this θ band times the φ interval of `phi`.
    #[must_use]
    pub fn patch(&self, phi: &AzimuthFactors) -> [f64; 9] {
        let [t_one, t_z, t_zz, t_s, t_sz, t_ss] = self.0;
        let [p_one, p_c1, p_s1, p_c2, p_s2] = phi.0;
        [
            C0 * t_one * p_one,
            C1 * t_s * p_s1,
            C1 * t_z * p_one,
            C1 * t_s * p_c1,
            C2 * t_ss * 0.5 * p_s2, // xy = sin²θ · ½ sin 2φ
            C2 * t_sz * p_s1,
            C20 * (3.0 * t_zz - t_one) * p_one,
            C2 * t_sz * p_c1,
            C22 * t_ss * p_c2, // x² − y² = sin²θ cos 2φ
        ]
    }
}

/// The φ integrals over [φ₀, φ₁] that the SH9 patch integrals need:
/// ∫1, ∫cos φ, ∫sin φ, ∫cos 2φ, ∫sin 2φ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AzimuthFactors([f64; 5]);

impl AzimuthFactors {
    /// Closed forms over [φ₀, φ₁].
    #[must_use]
    pub fn new(phi0: f64, phi1: f64) -> Self {
        Self([
            phi1 - phi0,
            phi1.sin() - phi0.sin(),
            phi0.cos() - phi1.cos(),
            0.5 * ((2.0 * phi1).sin() - (2.0 * phi0).sin()),
            0.5 * ((2.0 * phi0).cos() - (2.0 * phi1).cos()),
        ])
    }
}

/// Zonal coefficients Â₀, Â₁, Â₂ of the clamped cosine lobe μ⁺ (irradiance):
/// Â_l = 2π∫₀¹ μ P_l(μ) dμ = (π, 2π/3, π/4).
#[must_use]
pub fn cosine_lobe() -> [f64; 3] {
    [PI, 2.0 * PI / 3.0, PI / 4.0]
}

/// Zonal coefficients of the Fresnel-weighted cosine lobe k(μ) = μ⁺ T(η, μ), T = 1 − R the
/// exact dielectric transmittance into a medium of index `eta` from air:
/// Â_l = 2π∫₀¹ μ T(η, μ) P_l(μ) dμ, l = 0, 1, 2.
///
/// Â₀ = π(1 − F_ext(η)) in closed form (so a constant environment is exact); Â₁ and Â₂ by
/// composite Gauss–Legendre quadrature (T is smooth on [0, 1] for η ≥ 1), accurate to ~1e-13.
#[must_use]
pub fn fresnel_cosine_lobe(eta: f64) -> [f64; 3] {
    let moment = |l: usize| {
        2.0 * PI
            * integrate(
                |mu| {
                    let p = match l {
                        1 => mu,
                        _ => 0.5 * (3.0 * mu * mu - 1.0),
                    };
                    mu * fresnel_transmittance(mu, eta) * p
                },
                0.0,
                1.0,
                32,
            )
    };
    [PI * (1.0 - f_ext(eta)), moment(1), moment(2)]
}

/// Σ_i Â_{l(i)} c_i Y_i(n) for each channel: the lobe-weighted integral of the SH9 radiance
/// `coeffs` (per channel, nine coefficients) around the unit normal `n`.
#[must_use]
pub fn sh9_convolve(coeffs: &[[f64; 9]; 3], lobe: [f64; 3], n: DVec3) -> [f64; 3] {
    let y = sh9_basis(n);
    let mut out = [0.0; 3];
    for (o, c) in out.iter_mut().zip(coeffs) {
        *o = (0..9).map(|i| lobe[SH9_BAND[i]] * c[i] * y[i]).sum();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::sampling::Pattern;

    /// Uniform directions by an equal-area map of a scrambled Sobol pattern.
    fn sphere_dirs(n: usize) -> Vec<DVec3> {
        let p = Pattern::new(11);
        (0..n)
            .map(|i| {
                let [u, v] = p.get(i);
                let z = 1.0 - 2.0 * u;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = 2.0 * PI * v;
                DVec3::new(r * phi.cos(), r * phi.sin(), z)
            })
            .collect()
    }

    #[test]
    fn basis_is_orthonormal() {
        let dirs = sphere_dirs(1 << 16);
        let w = 4.0 * PI / dirs.len() as f64;
        let mut gram = [[0.0; 9]; 9];
        for d in &dirs {
            let y = sh9_basis(*d);
            for (row, yi) in gram.iter_mut().zip(y) {
                for (g, yj) in row.iter_mut().zip(y) {
                    *g += w * yi * yj;
                }
            }
        }
        for (i, row) in gram.iter().enumerate() {
            for (j, g) in row.iter().enumerate() {
                let expect = if i == j { 1.0 } else { 0.0 };
                assert!((g - expect).abs() < 2e-3, "({i},{j}) = {g}");
            }
        }
    }

    #[test]
    fn patch_integrals_match_quadrature() {
        let (t0, t1, p0, p1) = (0.3, 1.1, -0.4, 0.9);
        let exact = sh9_patch_integrals(t0, t1, p0, p1);
        let n = 200;
        let mut num = [0.0; 9];
        let (dt, dp) = ((t1 - t0) / n as f64, (p1 - p0) / n as f64);
        for i in 0..n {
            let t = t0 + (i as f64 + 0.5) * dt;
            for j in 0..n {
                let p = p0 + (j as f64 + 0.5) * dp;
                let d = DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
                let y = sh9_basis(d);
                for k in 0..9 {
                    num[k] += y[k] * t.sin() * dt * dp;
                }
            }
        }
        for k in 0..9 {
            assert!((exact[k] - num[k]).abs() < 1e-5, "{k}: {} vs {}", exact[k], num[k]);
        }
        // The whole sphere: only Y₀₀ survives, with ∫Y₀₀ = √(4π).
        let all = sh9_patch_integrals(0.0, PI, -PI, PI);
        assert!((all[0] - (4.0 * PI).sqrt()).abs() < 1e-14);
        assert!(all[1..].iter().all(|v| v.abs() < 1e-14), "{all:?}");
    }

    #[test]
    fn lobes() {
        let plain = fresnel_cosine_lobe(1.0);
        let cos = cosine_lobe();
        for l in 0..3 {
            assert!((plain[l] - cos[l]).abs() < 1e-13, "{l}: {} vs {}", plain[l], cos[l]);
        }
        // Â₀ by quadrature agrees with the closed form through F_ext.
        let eta = 1.3;
        let a0 = 2.0 * PI * integrate(|mu| mu * fresnel_transmittance(mu, eta), 0.0, 1.0, 32);
        let lobe = fresnel_cosine_lobe(eta);
        assert!((a0 - lobe[0]).abs() < 1e-12, "{a0} vs {}", lobe[0]);
        assert!((lobe[0] - PI * (1.0 - 0.061_131_825)).abs() < 1e-7);
        // Fresnel removes more at grazing incidence, so the lobe is slightly more peaked.
        assert!(lobe[1] / lobe[0] > cos[1] / cos[0]);
    }

    #[test]
    fn convolution_of_a_linear_field_is_exact() {
        // L(ω) = 1 + z: irradiance at n is π + (2π/3) n_z.
        let s = (4.0 * PI).sqrt();
        let mut c = [[0.0; 9]; 3];
        for ch in &mut c {
            ch[0] = s; // 1 = √(4π) Y₀₀
            ch[2] = 1.0 / C1; // z = Y₁₀ / C1
        }
        for n in [DVec3::Z, -DVec3::Z, DVec3::X, DVec3::new(0.3, 0.4, 0.5).normalize()] {
            let e = sh9_convolve(&c, cosine_lobe(), n);
            let expect = PI + 2.0 * PI / 3.0 * n.z;
            assert!((e[1] - expect).abs() < 1e-12, "{n}: {} vs {expect}", e[1]);
        }
    }
}
