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
//!
//! # Any order
//!
//! The same real basis to any order n ≤ [`MAX_ORDER`] (bands l < n, n² coefficients, index
//! l(l + 1) + m, [`sh_index`]): with z = cos θ and x + iy = sin θ e^{iφ},
//!
//! Y_l0 = K_l0 P_l(z), Y_lm = √2 K_lm P̃_l^m(z) Re (x + iy)^m, Y_l,−m = √2 K_lm P̃_l^m(z) Im (x + iy)^m
//! (m > 0), K_lm = √((2l + 1)/4π · (l − m)!/(l + m)!),
//!
//! P̃_l^m = P_l^m / sin^m θ the associated Legendre function without the Condon–Shortley phase
//! and without its sin^m θ (a polynomial in z: P̃_m^m = (2m − 1)!!, P̃_{m+1}^m = (2m + 1) z P̃_m^m,
//! (l − m) P̃_l^m = (2l − 1) z P̃_{l−1}^m − (l + m − 1) P̃_{l−2}^m). For l ≤ 2 these are exactly the
//! nine functions above ([`sh_basis`] and [`sh9_basis`] agree). [`sh_patch_integrals`] integrates
//! them over a spherical rectangle (an equirect texel), [`ShRotation`] turns coefficients with
//! the environment, [`fresnel_cosine_lobe_bands`] gives the lobe's Â_l to any band.

use std::f64::consts::PI;
use std::sync::LazyLock;

use glam::{DMat3, DVec3};

use super::sampling::{gauss_legendre, integrate};
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

/// The highest order (bands l < 8, 64 coefficients) of the general-order functions.
pub const MAX_ORDER: usize = 8;

/// The index of (l, m), |m| ≤ l, among the coefficients: l(l + 1) + m.
#[must_use]
pub const fn sh_index(l: usize, m: isize) -> usize {
    (l * (l + 1)).wrapping_add_signed(m)
}

/// Index of (l, m ≥ 0) in the triangular tables of the Legendre factors: l(l + 1)/2 + m.
const fn tri(l: usize, m: usize) -> usize {
    l * (l + 1) / 2 + m
}

/// The entries of a triangular table of [`MAX_ORDER`] bands.
const TRI: usize = MAX_ORDER * (MAX_ORDER + 1) / 2;

/// N_lm = K_lm (m = 0) or √2 K_lm (m > 0) of the module docs, in the triangular order.
static NORMS: LazyLock<[f64; TRI]> = LazyLock::new(|| {
    let mut out = [0.0; TRI];
    for l in 0..MAX_ORDER {
        for m in 0..=l {
            // (l − m)!/(l + m)! as a product of l+m … l−m+1 reciprocals.
            let ratio: f64 = ((l - m + 1)..=(l + m)).map(|k| 1.0 / k as f64).product();
            let k = ((2 * l + 1) as f64 / (4.0 * PI) * ratio).sqrt();
            out[tri(l, m)] = if m == 0 { k } else { std::f64::consts::SQRT_2 * k };
        }
    }
    out
});

/// N_lm P̃_l^m(z) for l < `order`, 0 ≤ m ≤ l, in the triangular order (module docs' recurrence).
fn legendre(order: usize, z: f64) -> [f64; TRI] {
    let norms = &*NORMS;
    let mut out = [0.0; TRI];
    let mut pmm = 1.0; // (2m − 1)!!
    for m in 0..order {
        if m > 0 {
            pmm *= (2 * m - 1) as f64;
        }
        let (mut older, mut old) = (0.0, pmm);
        out[tri(m, m)] = norms[tri(m, m)] * pmm;
        for l in m + 1..order {
            let p = if l == m + 1 {
                (2 * m + 1) as f64 * z * pmm
            } else {
                ((2 * l - 1) as f64 * z * old - (l + m - 1) as f64 * older) / (l - m) as f64
            };
            (older, old) = (old, p);
            out[tri(l, m)] = norms[tri(l, m)] * p;
        }
    }
    out
}

/// The `order`² real SH basis functions (module docs, order n: bands l < n) at the unit
/// direction `d`, written to `out[..order²]`.
///
/// # Panics
/// If `order` exceeds [`MAX_ORDER`] or `out` is shorter than `order`².
pub fn sh_basis(order: usize, d: DVec3, out: &mut [f64]) {
    assert!(order <= MAX_ORDER && out.len() >= order * order, "order {order} with {} outputs", out.len());
    let p = legendre(order, d.z);
    // (c_m, s_m) = (Re, Im) (x + iy)^m.
    let (mut c, mut s) = (1.0, 0.0);
    for m in 0..order {
        if m > 0 {
            (c, s) = (c * d.x - s * d.y, s * d.x + c * d.y);
        }
        for l in m..order {
            let v = p[tri(l, m)];
            if m == 0 {
                out[sh_index(l, 0)] = v;
            } else {
                out[sh_index(l, m as isize)] = v * c;
                out[sh_index(l, -(m as isize))] = v * s;
            }
        }
    }
}

/// The θ factors of the order-`order` patch integrals over θ ∈ [θ₀, θ₁]:
/// Θ_lm = ∫ N_lm P̃_l^m(cos θ) sin^m θ · sin θ dθ (0 ≤ m ≤ l < order, triangular order), so that
/// ∫ Y_l,±m dω over θ ∈ [θ₀, θ₁], φ ∈ [φ₀, φ₁] is Θ_lm ∫ (cos, sin)(mφ) dφ ([`sh_patch_integrals`]).
///
/// Gauss–Legendre in θ, eight nodes on each of ⌈32 (θ₁ − θ₀)/π⌉ equal pieces: the integrand is
/// a trigonometric polynomial of degree ≤ l + 1 ≤ 8 in θ, so on pieces of π/32 the rule's error
/// (≈ (8 · π/64)^16/16!) is far below rounding.
#[must_use]
pub fn sh_polar_factors(order: usize, theta0: f64, theta1: f64) -> Vec<f64> {
    let order = order.min(MAX_ORDER);
    let pieces = ((32.0 * (theta1 - theta0).abs() / PI).ceil() as usize).max(1);
    let h = (theta1 - theta0) / pieces as f64;
    let mut out = vec![0.0; order * (order + 1) / 2];
    for piece in 0..pieces {
        let mid = theta0 + (piece as f64 + 0.5) * h;
        for &(x, w) in GAUSS8.iter() {
            let theta = mid + 0.5 * h * x;
            let (sin_t, cos_t) = theta.sin_cos();
            let p = legendre(order, cos_t);
            let weight = 0.5 * h * w * sin_t;
            let mut sin_m = 1.0;
            for m in 0..order {
                for l in m..order {
                    out[tri(l, m)] += weight * p[tri(l, m)] * sin_m;
                }
                sin_m *= sin_t;
            }
        }
    }
    out
}

/// The eight-point Gauss–Legendre rule on [−1, 1].
static GAUSS8: LazyLock<Vec<(f64, f64)>> = LazyLock::new(|| gauss_legendre(8));

/// The φ factors of the order-`order` patch integrals over [φ₀, φ₁]: (∫cos mφ dφ, ∫sin mφ dφ)
/// for m < order in closed form.
#[must_use]
pub fn sh_azimuth_factors(order: usize, phi0: f64, phi1: f64) -> Vec<(f64, f64)> {
    (0..order.min(MAX_ORDER))
        .map(|m| {
            if m == 0 {
                (phi1 - phi0, 0.0)
            } else {
                let k = m as f64;
                (((k * phi1).sin() - (k * phi0).sin()) / k, ((k * phi0).cos() - (k * phi1).cos()) / k)
            }
        })
        .collect()
}

/// The coefficient-wise product of θ factors ([`sh_polar_factors`]) and φ factors
/// ([`sh_azimuth_factors`]) of the same order: the `order`² integrals ∫ Y_lm dω over the patch.
#[must_use]
pub fn sh_patch_from_factors(polar: &[f64], azimuth: &[(f64, f64)]) -> Vec<f64> {
    let order = azimuth.len();
    let mut out = vec![0.0; order * order];
    for m in 0..order {
        let (c, s) = azimuth[m];
        for l in m..order {
            let t = polar[tri(l, m)];
            if m == 0 {
                out[sh_index(l, 0)] = t * c;
            } else {
                out[sh_index(l, m as isize)] = t * c;
                out[sh_index(l, -(m as isize))] = t * s;
            }
        }
    }
    out
}

/// ∫ Y_lm dω over θ ∈ [θ₀, θ₁], φ ∈ [φ₀, φ₁] for the `order`² (order ≤ [`MAX_ORDER`]) basis
/// functions: the general-order [`sh9_patch_integrals`] (θ by quadrature, φ in closed form).
#[must_use]
pub fn sh_patch_integrals(order: usize, theta0: f64, theta1: f64, phi0: f64, phi1: f64) -> Vec<f64> {
    sh_patch_from_factors(&sh_polar_factors(order, theta0, theta1), &sh_azimuth_factors(order, phi0, phi1))
}

/// Legendre polynomials P_0..P_{n−1} at μ (Bonnet's recurrence).
fn legendre_polynomials(n: usize, mu: f64) -> Vec<f64> {
    let mut p = Vec::with_capacity(n);
    for l in 0..n {
        let v = match l {
            0 => 1.0,
            1 => mu,
            _ => ((2 * l - 1) as f64 * mu * p[l - 1] - (l - 1) as f64 * p[l - 2]) / l as f64,
        };
        p.push(v);
    }
    p
}

/// Zonal coefficients Â_l = 2π∫₀¹ μ T(η, μ) P_l(μ) dμ, l < `order`, of the Fresnel-weighted
/// cosine lobe ([`fresnel_cosine_lobe`] to any band; η = 1 gives the clamped cosine:
/// π, 2π/3, π/4, 0, −π/24, …). Â₀ = π(1 − F_ext(η)) in closed form, the others by composite
/// Gauss–Legendre quadrature (32 panels of 10 nodes, accurate to ~1e-13).
#[must_use]
pub fn fresnel_cosine_lobe_bands(eta: f64, order: usize) -> Vec<f64> {
    (0..order)
        .map(|l| {
            if l == 0 {
                PI * (1.0 - f_ext(eta))
            } else {
                2.0 * PI * integrate(|mu| mu * fresnel_transmittance(mu, eta) * legendre_polynomials(l + 1, mu)[l], 0.0, 1.0, 32)
            }
        })
        .collect()
}

/// The rotation of SH coefficients that turns an environment with a rotation R: the environment
/// L′(ω) = L(Rᵀω) (light that came from ω comes from Rω) has, band by band, L′_l = D^l L_l with
/// D^l_{m′m} = ∫ Y_lm′(ω) Y_lm(Rᵀω) dω.
///
/// Each D^l is computed by a product quadrature on the sphere exact for the polynomials of
/// degree ≤ 2(n − 1) that the integrands are (Gauss–Legendre in z with n nodes, 2n equally
/// spaced azimuths), so it is exact to rounding; applying it costs Σ (2l + 1)² per channel,
/// nothing that depends on the surface.
#[derive(Debug, Clone, PartialEq)]
pub struct ShRotation {
    order: usize,
    /// Per band l, D^l row-major ((2l + 1)², rows m′, columns m, each from −l).
    blocks: Vec<Vec<f64>>,
}

impl ShRotation {
    /// The rotation of order-`order` coefficients (clamped to [`MAX_ORDER`]) by the rotation
    /// matrix `rotation` (orthonormal, determinant 1; it is used as given).
    #[must_use]
    pub fn new(order: usize, rotation: DMat3) -> Self {
        let order = order.clamp(1, MAX_ORDER);
        let n_phi = 2 * order;
        let inverse = rotation.transpose();
        let mut blocks: Vec<Vec<f64>> = (0..order).map(|l| vec![0.0; (2 * l + 1) * (2 * l + 1)]).collect();
        let (mut y, mut y_turned) = ([0.0; MAX_ORDER * MAX_ORDER], [0.0; MAX_ORDER * MAX_ORDER]);
        for (z, wz) in gauss_legendre(order) {
            let r = (1.0 - z * z).max(0.0).sqrt();
            for k in 0..n_phi {
                let phi = 2.0 * PI * k as f64 / n_phi as f64;
                let w = wz * 2.0 * PI / n_phi as f64;
                let omega = DVec3::new(r * phi.cos(), r * phi.sin(), z);
                sh_basis(order, omega, &mut y);
                sh_basis(order, inverse * omega, &mut y_turned);
                for (l, block) in blocks.iter_mut().enumerate() {
                    let (base, width) = (l * l, 2 * l + 1);
                    for a in 0..width {
                        for b in 0..width {
                            block[a * width + b] += w * y[base + a] * y_turned[base + b];
                        }
                    }
                }
            }
        }
        Self { order, blocks }
    }

    /// The order it rotates.
    #[must_use]
    pub fn order(&self) -> usize {
        self.order
    }

    /// The rotated coefficients of `coeffs` (per coefficient, per channel): the first
    /// min(len, order²) are rotated band by band, the rest (whole higher bands, which it does
    /// not know) are returned as zero.
    #[must_use]
    pub fn apply(&self, coeffs: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut out = vec![[0.0; 3]; coeffs.len()];
        for (l, block) in self.blocks.iter().enumerate() {
            let (base, width) = (l * l, 2 * l + 1);
            if base + width > coeffs.len() {
                break;
            }
            for a in 0..width {
                let mut acc = [0.0; 3];
                for b in 0..width {
                    for (o, c) in acc.iter_mut().zip(coeffs[base + b]) {
                        *o += block[a * width + b] * c;
                    }
                }
                out[base + a] = acc;
            }
        }
        out
    }
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

    /// The sphere's exact product rule for polynomials of degree ≤ 2n − 1: Gauss–Legendre in z,
    /// 2n equally spaced azimuths. (direction, weight) pairs.
    fn exact_rule(n: usize) -> Vec<(DVec3, f64)> {
        let mut out = Vec::new();
        for (z, wz) in gauss_legendre(n) {
            let r = (1.0 - z * z).sqrt();
            for k in 0..2 * n {
                let phi = PI * k as f64 / n as f64 + 0.1;
                out.push((DVec3::new(r * phi.cos(), r * phi.sin(), z), wz * PI / n as f64));
            }
        }
        out
    }

    fn basis(order: usize, d: DVec3) -> Vec<f64> {
        let mut y = vec![0.0; order * order];
        sh_basis(order, d, &mut y);
        y
    }

    #[test]
    fn general_basis_extends_sh9() {
        for d in sphere_dirs(64) {
            let (a, b) = (basis(3, d), sh9_basis(d));
            for i in 0..9 {
                assert!((a[i] - b[i]).abs() < 1e-15, "{i}: {} vs {}", a[i], b[i]);
            }
            // The low bands do not depend on the order asked.
            assert_eq!(basis(8, d)[..25], basis(5, d)[..]);
        }
    }

    #[test]
    fn general_basis_is_orthonormal_to_rounding() {
        let n = MAX_ORDER;
        let mut gram = vec![0.0; n.pow(4)];
        for (d, w) in exact_rule(n) {
            let y = basis(n, d);
            for i in 0..n * n {
                for j in 0..n * n {
                    gram[i * n * n + j] += w * y[i] * y[j];
                }
            }
        }
        for i in 0..n * n {
            for j in 0..n * n {
                let expect = if i == j { 1.0 } else { 0.0 };
                assert!((gram[i * n * n + j] - expect).abs() < 1e-12, "({i},{j}) = {}", gram[i * n * n + j]);
            }
        }
    }

    #[test]
    fn general_basis_known_values_and_addition_theorem() {
        let d = DVec3::new(0.3, -0.5, 0.7).normalize();
        let (x, y, z) = (d.x, d.y, d.z);
        let v = basis(5, d);
        let known = [
            (sh_index(3, 0), 0.25 * (7.0 / PI).sqrt() * (5.0 * z * z * z - 3.0 * z)),
            (sh_index(3, 3), 0.25 * (35.0 / (2.0 * PI)).sqrt() * (x * x * x - 3.0 * x * y * y)),
            (sh_index(3, -2), 0.5 * (105.0 / PI).sqrt() * x * y * z),
            (sh_index(4, 0), 3.0 / 16.0 * (1.0 / PI).sqrt() * (35.0 * z.powi(4) - 30.0 * z * z + 3.0)),
            (sh_index(4, -4), 0.75 * (35.0 / PI).sqrt() * x * y * (x * x - y * y)),
        ];
        for (i, expect) in known {
            assert!((v[i] - expect).abs() < 1e-14, "{i}: {} vs {expect}", v[i]);
        }
        // Σ_m Y_lm(a) Y_lm(b) = (2l + 1)/4π P_l(a·b).
        let dirs = sphere_dirs(20);
        for pair in dirs.windows(2) {
            let (ya, yb) = (basis(MAX_ORDER, pair[0]), basis(MAX_ORDER, pair[1]));
            let p = legendre_polynomials(MAX_ORDER, pair[0].dot(pair[1]));
            for (l, p_l) in p.iter().enumerate() {
                let sum: f64 = (l * l..(l + 1) * (l + 1)).map(|i| ya[i] * yb[i]).sum();
                let expect = (2 * l + 1) as f64 / (4.0 * PI) * p_l;
                assert!((sum - expect).abs() < 1e-13, "l = {l}: {sum} vs {expect}");
            }
        }
    }

    #[test]
    fn general_patch_integrals() {
        let (t0, t1, p0, p1) = (0.3, 1.1, -0.4, 0.9);
        // Order 3 against the closed forms of SH9.
        let general = sh_patch_integrals(3, t0, t1, p0, p1);
        let closed = sh9_patch_integrals(t0, t1, p0, p1);
        for k in 0..9 {
            assert!((general[k] - closed[k]).abs() < 1e-15, "{k}: {} vs {}", general[k], closed[k]);
        }
        // Order 8 against a midpoint rule.
        let exact = sh_patch_integrals(MAX_ORDER, t0, t1, p0, p1);
        let n = 400;
        let mut num = vec![0.0; MAX_ORDER * MAX_ORDER];
        let (dt, dp) = ((t1 - t0) / n as f64, (p1 - p0) / n as f64);
        for i in 0..n {
            let t = t0 + (i as f64 + 0.5) * dt;
            for j in 0..n {
                let p = p0 + (j as f64 + 0.5) * dp;
                let y = basis(MAX_ORDER, DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos()));
                for (a, b) in num.iter_mut().zip(y) {
                    *a += b * t.sin() * dt * dp;
                }
            }
        }
        for k in 0..num.len() {
            assert!((exact[k] - num[k]).abs() < 2e-6, "{k}: {} vs {}", exact[k], num[k]);
        }
        // The whole sphere (one θ band of width π): only Y₀₀ survives.
        let all = sh_patch_integrals(MAX_ORDER, 0.0, PI, -PI, PI);
        assert!((all[0] - (4.0 * PI).sqrt()).abs() < 1e-14);
        assert!(all[1..].iter().all(|v| v.abs() < 1e-14), "{all:?}");
    }

    #[test]
    fn lobe_bands() {
        // The clamped cosine: Â_l = 2π (−1)^{l/2−1} l! / ((l + 2)(l − 1) 2^l ((l/2)!)²) for even
        // l ≥ 2, 0 for odd l ≥ 3 (Ramamoorthi & Hanrahan 2001).
        let plain = fresnel_cosine_lobe_bands(1.0, 8);
        let expect = [PI, 2.0 * PI / 3.0, PI / 4.0, 0.0, -PI / 24.0, 0.0, PI / 64.0, 0.0];
        for l in 0..8 {
            assert!((plain[l] - expect[l]).abs() < 1e-12, "{l}: {} vs {}", plain[l], expect[l]);
        }
        let eta = 1.3;
        let bands = fresnel_cosine_lobe_bands(eta, 5);
        let sh9 = fresnel_cosine_lobe(eta);
        for l in 0..3 {
            assert!((bands[l] - sh9[l]).abs() < 1e-13, "{l}");
        }
    }

    #[test]
    fn rotation_turns_band_limited_fields_exactly() {
        let order = 6;
        let coeffs: Vec<[f64; 3]> = (0..order * order)
            .map(|i| [((i * 7919) % 13) as f64 / 13.0 - 0.5, (i as f64).sin(), 1.0 / (1.0 + i as f64)])
            .collect();
        let field = |c: &[[f64; 3]], d: DVec3| {
            let y = basis(order, d);
            [0, 1, 2].map(|ch| c.iter().zip(&y).map(|(a, b)| a[ch] * b).sum::<f64>())
        };
        let rotation = DMat3::from_axis_angle(DVec3::new(0.2, -0.7, 0.4).normalize(), 1.1);
        let turned = ShRotation::new(order, rotation).apply(&coeffs);
        for d in sphere_dirs(32) {
            let (a, b) = (field(&turned, d), field(&coeffs, rotation.transpose() * d));
            for ch in 0..3 {
                assert!((a[ch] - b[ch]).abs() < 1e-12, "{d}: {a:?} vs {b:?}");
            }
        }
        // The identity changes nothing; a turn and its inverse cancel.
        let same = ShRotation::new(order, DMat3::IDENTITY).apply(&coeffs);
        let back = ShRotation::new(order, rotation.transpose()).apply(&turned);
        for ((a, b), c) in same.iter().zip(&back).zip(&coeffs) {
            for ch in 0..3 {
                assert!((a[ch] - c[ch]).abs() < 1e-13 && (b[ch] - c[ch]).abs() < 1e-12);
            }
        }
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
