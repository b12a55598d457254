//! The boundary layer under a boundary vertex: the local profile of the fluence and the flux it
//! carries into the object, for the boundary rows of `Discretization::FittedLayer`
//! ([`super::fitted`]).
//!
//! Under a lit surface the fluence decays into the object over 1/σtr. Near a boundary vertex x_i
//! with outward normal n and mean curvature H, the local solution of ∇·(κ∇φ) = μφ that decays
//! inwards is, to first order in the curvature, that of a sphere of radius R = 1/H tangent to the
//! surface at x_i (inside a sphere for H > 0, outside one for H < 0, a half-space for H = 0):
//!
//! - H > 0: φ ∝ sinh(σ r)/r, r the distance from the centre x_i − R n;
//! - H < 0: φ ∝ e^(−σ r)/r, r the distance from the centre x_i + R n;
//! - H = 0: φ ∝ e^(σ (x − x_i)·n).
//!
//! [`profile`] is that φ divided by its value at x_i, and [`inward_flux`] is (∂φ/∂n)/φ at x_i:
//! the diffusive flux −κ∇φ into the object per unit κ and φ. Curvature enters both at first
//! order and cancels between them to that order in a consistent row; without it a row sees its
//! neighbours on a curved surface as deeper or shallower than they are.

use glam::DVec3;

/// ψ(d) = φ(x_i + d)/φ(x_i) for the layer of inverse thickness `sigma` (mm⁻¹) under a surface
/// of mean curvature `curvature` (mm⁻¹, positive where convex) with outward normal `n`.
#[must_use]
pub(crate) fn profile(sigma: f64, curvature: f64, n: DVec3, d: DVec3) -> f64 {
    let along = d.dot(n);
    if curvature == 0.0 {
        return (sigma * along).exp();
    }
    let radius = 1.0 / curvature.abs();
    // r − R from the offset, without the cancellation of |d ± R n| − R when R is large:
    // r² − R² = |d|² ± 2R d·n.
    let sign = curvature.signum();
    let r2_minus_radius2 = d.length_squared() + 2.0 * sign * radius * along;
    let r = (radius * radius + r2_minus_radius2).max(0.0).sqrt();
    let excess = r2_minus_radius2 / (r + radius);
    if sign > 0.0 {
        // (R/r) sinh(σr)/sinh(σR) = (R/r) e^(σ(r − R)) (1 − e^(−2σr))/(1 − e^(−2σR)).
        if sigma == 0.0 {
            return 1.0;
        }
        (radius / r) * (sigma * excess).exp() * ((-2.0 * sigma * r).exp_m1() / (-2.0 * sigma * radius).exp_m1())
    } else {
        // (R/r) e^(−σ(r − R)): the solid lies outside the sphere.
        (radius / r) * (-sigma * excess).exp()
    }
}

/// (∂φ/∂n)/φ at the vertex for [`profile`] (n outward): σ coth(σR) − 1/R where convex, σ + 1/R
/// where concave, σ on a plane; the flux −κ∇φ·(−n) into the object per unit κ and φ.
#[must_use]
pub(crate) fn inward_flux(sigma: f64, curvature: f64) -> f64 {
    if curvature > 0.0 {
        let radius = 1.0 / curvature;
        let x = sigma * radius;
        if x < 1e-2 {
            // (x coth x − 1)/R = (x²/3 − x⁴/45 + 2x⁶/945)/R.
            let y = x * x;
            y * (1.0 / 3.0 - y * (1.0 / 45.0 - y * 2.0 / 945.0)) / radius
        } else {
            sigma / x.tanh() - curvature
        }
    } else {
        sigma - curvature
    }
}

/// The mean curvature (mm⁻¹, positive where convex) at a surface vertex with outward unit
/// normal `n`, from the offsets `d` of its neighbours: the least-squares osculating quadric
/// z = a x² + b xy + c y² in a frame of the tangent plane (x, y) and the normal (z), H = −(a + c).
/// None where the neighbourhood is not a height field over the tangent plane within 45° (an edge
/// or a corner of the surface), or its directions do not determine the quadric, or the surface
/// bends by more than half a radian across it (curvature the mesh does not resolve).
#[must_use]
pub(crate) fn mean_curvature(n: DVec3, offsets: &[DVec3]) -> Option<f64> {
    let (u, v) = n.any_orthonormal_pair();
    let mut normal = [[0.0; 3]; 3];
    let mut rhs = [0.0; 3];
    let mut reach: f64 = 0.0;
    for d in offsets {
        let (x, y, z) = (d.dot(u), d.dot(v), d.dot(n));
        let planar = x * x + y * y;
        if z * z > planar {
            return None;
        }
        reach = reach.max(planar.sqrt());
        let row = [x * x, x * y, y * y];
        for a in 0..3 {
            rhs[a] += row[a] * z;
            for b in 0..3 {
                normal[a][b] += row[a] * row[b];
            }
        }
    }
    let [a, _, c] = solve3(normal, rhs)?;
    let h = -(a + c);
    (h.abs() * reach <= 0.5).then_some(h)
}

/// The solution of the symmetric positive semi-definite 3×3 system `m x = r` by Cramer's rule;
/// None when `det m` is not above 10⁻⁸ × the product of the diagonal (its Hadamard bound): a
/// near-singular system.
fn solve3(m: [[f64; 3]; 3], r: [f64; 3]) -> Option<[f64; 3]> {
    let det3 = |c0: [f64; 3], c1: [f64; 3], c2: [f64; 3]| {
        c0[0] * (c1[1] * c2[2] - c1[2] * c2[1]) - c1[0] * (c0[1] * c2[2] - c0[2] * c2[1])
            + c2[0] * (c0[1] * c1[2] - c0[2] * c1[1])
    };
    let det = det3(m[0], m[1], m[2]);
    if !(det > 1e-8 * m[0][0] * m[1][1] * m[2][2]) {
        return None;
    }
    Some([det3(r, m[1], m[2]) / det, det3(m[0], r, m[2]) / det, det3(m[0], m[1], r) / det])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The profiles solve κ∇²φ = μφ (φ'' + (2/r)φ' = σ²φ for the spheres) and are 1 at the
    /// vertex; their outward normal derivative there is inward_flux.
    #[test]
    fn profiles_solve_the_diffusion_equation_and_carry_their_flux() {
        let n = DVec3::new(0.0, 0.6, 0.8);
        for sigma in [0.0, 0.05, 0.7, 3.0] {
            for curvature in [0.0, 0.1, -0.1, 1e-7, -1e-7] {
                let p = |d: DVec3| profile(sigma, curvature, n, d);
                assert!((p(DVec3::ZERO) - 1.0).abs() < 1e-12);
                let e = 1e-4;
                let slope = (p(e * n) - p(-e * n)) / (2.0 * e);
                let g = inward_flux(sigma, curvature);
                assert!((slope - g).abs() < 1e-6 * (1.0 + g), "σ {sigma} H {curvature}: ∂ψ/∂n {slope}, flux {g}");
                // The Laplacian by central differences at a point 0.3 mm inside.
                let x = -0.3 * n + DVec3::new(0.1, -0.05, 0.02);
                let h = 1e-3;
                let lap: f64 =
                    [DVec3::X, DVec3::Y, DVec3::Z].iter().map(|&a| (p(x + h * a) - 2.0 * p(x) + p(x - h * a)) / (h * h)).sum();
                assert!((lap - sigma * sigma * p(x)).abs() < 1e-5 * (1.0 + sigma * sigma), "σ {sigma} H {curvature}: ∇²ψ {lap}");
            }
        }
    }

    /// The convex flux σ coth(σR) − 1/R on both sides of its series switch, and its limits:
    /// σ on a plane, σ²R/3 for a small sphere's slow decay, σ − 1/R for a thin layer.
    #[test]
    fn inward_flux_is_the_spheres() {
        let exact = |s: f64, r: f64| s / (s * r).tanh() - 1.0 / r;
        for (s, r) in [(0.0011, 9.0), (0.0009, 11.0), (0.5, 10.0), (3.0, 2.0)] {
            assert!((inward_flux(s, 1.0 / r) / exact(s, r) - 1.0).abs() < 1e-9, "σ {s} R {r}");
        }
        assert_eq!(inward_flux(0.0, 0.2), 0.0);
        assert!((inward_flux(1e-4, 0.1) / (1e-8 * 10.0 / 3.0) - 1.0).abs() < 1e-6);
        assert_eq!(inward_flux(2.0, 0.0), 2.0);
        assert!((inward_flux(2.0, -0.1) - 2.1).abs() < 1e-15);
        assert!((inward_flux(50.0, 0.1) - 49.9).abs() < 1e-12);
    }

    /// The quadric fit recovers a sphere's and a cylinder's mean curvature from a ring of
    /// neighbours, with either sign, and refuses an edge of a cube and a degenerate ring.
    #[test]
    fn mean_curvature_of_spheres_cylinders_and_edges() {
        let n = DVec3::new(1.0, 2.0, 2.0) / 3.0;
        let (u, v) = n.any_orthonormal_pair();
        let ring = |z: &dyn Fn(f64, f64) -> f64| -> Vec<DVec3> {
            (0..6)
                .map(|k| {
                    let a = f64::from(k) * std::f64::consts::TAU / 6.0 + 0.3;
                    let (x, y) = (0.4 * a.cos(), 0.4 * a.sin() * 1.2);
                    x * u + y * v + z(x, y) * n
                })
                .collect()
        };
        for radius in [10.0, -10.0, 2.0] {
            // The sphere through the vertex with centre −R n: z = −R + √(R² − x² − y²) for R > 0.
            let sphere = ring(&|x, y| {
                let r: f64 = radius;
                -r.signum() * (r.abs() - (r * r - x * x - y * y).sqrt())
            });
            let h = mean_curvature(n, &sphere).unwrap();
            // The quadric misses the sphere's quartic term, (ρ/R)²/4 of H relative.
            assert!((h * radius - 1.0).abs() < 0.5 * (0.48 / radius).powi(2), "R {radius}: H {h}");
        }
        let cylinder = ring(&|x, _| -(5.0 - (25.0 - x * x).sqrt()));
        assert!((mean_curvature(n, &cylinder).unwrap() - 0.1).abs() < 5e-4);
        let plane = ring(&|_, _| 0.0);
        assert!(mean_curvature(n, &plane).unwrap().abs() < 1e-12);
        // A cube's edge: half the ring folds down at 90°.
        let edge: Vec<DVec3> =
            ring(&|_, _| 0.0).into_iter().map(|d| if d.dot(u) > 0.0 { -d.dot(u) * n + d.dot(v) * v } else { d }).collect();
        assert_eq!(mean_curvature(n, &edge), None);
        // Collinear neighbours do not determine a quadric.
        assert_eq!(mean_curvature(n, &[u, -u, 2.0 * u]), None);
        // A crease sharper than the ring resolves.
        let tight = ring(&|x, y| -2.0 * (x * x + y * y));
        assert_eq!(mean_curvature(n, &tight), None);
    }
}
