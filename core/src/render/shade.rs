//! Surface shading: the Fresnel view factor of the baked radiance, specular highlights and the
//! reflected environment.

use std::f64::consts::PI;

use glam::DVec3;

use crate::optics::{fresnel_reflectance, ft_out};

/// The factor that turns the baked radiance along the normal into the radiance towards a viewer
/// at cos θo = n·ωo: Ft(η, ωo)/Ft(η, n) = T(η, θo)/T(η, 0), with T the exact unpolarised Fresnel
/// transmittance out of the medium ([`ft_out`]; the 1/η² cancels). It is 1 head-on and falls to
/// 0 at grazing view. `cos_o` is clamped to [0, 1].
#[must_use]
pub fn view_factor(eta: f64, cos_o: f64) -> f64 {
    ft_out(eta, cos_o) / ft_out(eta, 1.0)
}

/// The GGX (Trowbridge–Reitz) normal distribution D(h) = α² / (π ((n·h)² (α² − 1) + 1)²).
#[must_use]
pub fn ggx_distribution(cos_h: f64, alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    let d = cos_h * cos_h * (a2 - 1.0) + 1.0;
    a2 / (PI * d * d)
}

/// Smith's GGX masking term divided by the cosine, G₁(c)/c = 2 / (c + √(α² + (1 − α²) c²)),
/// finite at c = 0 (where the masking G₁ = 2c/(c + √(α² + (1 − α²)c²)) itself vanishes).
#[must_use]
fn smith_g1_over_cos(cos: f64, alpha: f64) -> f64 {
    let a2 = alpha * alpha;
    2.0 / (cos + (a2 + (1.0 - a2) * cos * cos).sqrt())
}

/// Radiance reflected towards the viewer by a smooth-to-rough dielectric surface from a parallel
/// light of irradiance `irradiance` (normal to the light): the Cook–Torrance GGX lobe
///
/// Lr = f · E (n·l),  f = D(h) G₁(n·l) G₁(n·v) R(η, h·v) / (4 (n·l)(n·v)),
///
/// so Lr = D · [G₁(n·l)/(n·l)] · [G₁(n·v)/(n·v)] · R · E (n·l)/4, with the separable Smith
/// masking, h = normalize(l + v) and R the exact unpolarised Fresnel reflectance
/// ([`fresnel_reflectance`]) at the microfacet. `n`, `l`, `v` are unit vectors; zero when the
/// light or the viewer is below the surface.
#[must_use]
pub fn ggx_specular(n: DVec3, v: DVec3, l: DVec3, alpha: f64, eta: f64) -> f64 {
    let (nl, nv) = (n.dot(l), n.dot(v));
    if nl <= 0.0 || nv < 0.0 {
        return 0.0;
    }
    let Some(h) = (l + v).try_normalize() else {
        return 0.0;
    };
    let d = ggx_distribution(n.dot(h).max(0.0), alpha);
    let f = fresnel_reflectance(v.dot(h), eta);
    0.25 * d * smith_g1_over_cos(nl, alpha) * smith_g1_over_cos(nv, alpha) * f * nl
}

/// Per-render shading inputs shared by all samples.
#[derive(Debug, Clone)]
pub(crate) struct Lighting {
    /// Unit directions to the lights and their irradiances.
    pub lights: Vec<(DVec3, DVec3)>,
    /// Constant environment radiance, reflected with weight R(η, θo).
    pub environment: Option<DVec3>,
    /// GGX α = roughness².
    pub alpha: f64,
}

impl Lighting {
    /// Radiance towards the eye from a surface point with baked radiance `baked` along its unit
    /// normal `n`, viewed along the unit vector `v` (towards the eye), in a medium of index
    /// `eta` with view normalisation `inv_ft_normal` = 1/Ft(η, n):
    ///
    /// L = baked · Ft(η, ωo)/Ft(η, n) + R(η, θo) L_env + Σ_l GGX_l.
    ///
    /// A back face (n·v < 0) is shaded as its front: n is flipped towards the viewer.
    pub fn shade(&self, baked: DVec3, n: DVec3, v: DVec3, eta: f64, inv_ft_normal: f64) -> DVec3 {
        let mut n = n;
        let mut cos_o = n.dot(v);
        if cos_o < 0.0 {
            n = -n;
            cos_o = -cos_o;
        }
        let cos_o = cos_o.min(1.0);
        let mut out = baked * (ft_out(eta, cos_o) * inv_ft_normal);
        if let Some(env) = self.environment {
            out += env * fresnel_reflectance(cos_o, eta);
        }
        for &(l, e) in &self.lights {
            let s = ggx_specular(n, v, l, self.alpha, eta);
            if s > 0.0 {
                out += e * s;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::fresnel_transmittance;

    #[test]
    fn view_factor_is_one_head_on_and_zero_at_grazing() {
        for eta in [1.0, 1.3, 1.5, 2.4] {
            assert!((view_factor(eta, 1.0) - 1.0).abs() < 1e-15);
            assert_eq!(view_factor(eta, 0.0), if eta == 1.0 { 1.0 } else { 0.0 });
        }
        let eta = 1.3;
        let c: f64 = 60f64.to_radians().cos();
        let expect = fresnel_transmittance(c, eta) / fresnel_transmittance(1.0, eta);
        assert!((view_factor(eta, c) - expect).abs() < 1e-15);
    }

    #[test]
    fn ggx_distribution_is_normalised() {
        // ∫ D(h) (n·h) dω_h = 1 over the hemisphere: 2π ∫₀¹ D(μ) μ dμ.
        for alpha in [0.05, 0.3, 1.0] {
            let n = 200_000;
            let mut s = 0.0;
            for i in 0..n {
                let mu = (i as f64 + 0.5) / n as f64;
                s += ggx_distribution(mu, alpha) * mu;
            }
            s *= 2.0 * PI / n as f64;
            assert!((s - 1.0).abs() < 1e-3, "alpha {alpha}: {s}");
        }
        // α = 1 is uniform: D = 1/π.
        assert!((ggx_distribution(0.3, 1.0) - 1.0 / PI).abs() < 1e-15);
    }

    #[test]
    fn specular_peak_at_the_mirror_direction() {
        let n = DVec3::Z;
        let l = DVec3::new(0.5, 0.0, 1.0).normalize();
        let mirror = DVec3::new(-l.x, 0.0, l.z);
        let off = DVec3::new(-0.2, 0.3, 1.0).normalize();
        let at_mirror = ggx_specular(n, mirror, l, 0.1, 1.5);
        assert!(at_mirror > 10.0 * ggx_specular(n, off, l, 0.1, 1.5));
        // At the mirror direction h = n: D(1) = 1/(π α²), both G₁ ≈ 1 for small α.
        let nl = l.z;
        let expect = 0.25 / (PI * 0.01) * fresnel_reflectance(nl, 1.5) / (nl * nl) * nl;
        assert!((at_mirror / expect - 1.0).abs() < 0.02, "{at_mirror} vs {expect}");
        assert_eq!(ggx_specular(n, mirror, -l, 0.1, 1.5), 0.0);
        // No interface, no reflection.
        assert_eq!(ggx_specular(n, mirror, l, 0.1, 1.0), 0.0);
    }

    #[test]
    fn shade_combines_the_terms() {
        let lighting = Lighting { lights: vec![], environment: Some(DVec3::splat(2.0)), alpha: 0.09 };
        let eta = 1.3;
        let inv = 1.0 / ft_out(eta, 1.0);
        let v = DVec3::new(0.6, 0.0, 0.8);
        let l = lighting.shade(DVec3::ONE, DVec3::Z, v, eta, inv);
        let expect = view_factor(eta, 0.8) + 2.0 * fresnel_reflectance(0.8, eta);
        assert!((l.x - expect).abs() < 1e-14);
        // A back face is shaded like its front.
        let back = lighting.shade(DVec3::ONE, -DVec3::Z, v, eta, inv);
        assert_eq!(back, l);
    }
}
