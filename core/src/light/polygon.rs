//! The irradiance of a uniform planar polygon in closed form (Lambert 1760; the form factor of a
//! differential area to a polygon, e.g. Baum, Rushmeier & Winget 1989 eq. 5): at a point p with
//! unit normal n, a polygon of radiance 1 with vertices v_k gives
//!
//!   E = ∫ (n·ω)⁺ dω = ½ |Σ_k θ_k n·û_k|,  θ_k = ∠(v_k − p, v_{k+1} − p),
//!   û_k = (v_k − p) × (v_{k+1} − p) / |…|,
//!
//! once the polygon is clipped to the half-space n·(x − p) ≥ 0 the point sees (the clamp of the
//! cosine). It is what an area light's Monte Carlo estimate converges to where nothing blocks the
//! light, without its noise.

use glam::DVec3;

/// E = ∫ (n·ω)⁺ dω over the solid angle of the convex planar polygon `vertices` (in order) seen
/// from `p` with unit normal `n`: the irradiance of the polygon at radiance 1 (module
/// documentation). Either winding; 0 for a polygon wholly below the horizon.
///
/// # Panics
/// For more than 7 vertices.
#[must_use]
pub fn polygon_irradiance(p: DVec3, n: DVec3, vertices: &[DVec3]) -> f64 {
    assert!(vertices.len() <= 7, "a polygon of at most 7 vertices");
    // Sutherland–Hodgman against n·d ≥ 0, d relative to p: a convex polygon gains at most one
    // vertex.
    let mut clipped: [DVec3; 8] = [DVec3::ZERO; 8];
    let mut count = 0;
    let k = vertices.len();
    for i in 0..k {
        let (a, b) = (vertices[i] - p, vertices[(i + 1) % k] - p);
        let (ha, hb) = (n.dot(a), n.dot(b));
        if ha >= 0.0 {
            clipped[count] = a;
            count += 1;
        }
        if (ha >= 0.0) != (hb >= 0.0) {
            clipped[count] = a + (b - a) * (ha / (ha - hb));
            count += 1;
        }
    }
    let mut sum = 0.0;
    for i in 0..count {
        let (a, b) = (clipped[i], clipped[(i + 1) % count]);
        let cross = a.cross(b);
        let length = cross.length();
        if length > 0.0 {
            // θ by atan2 of |a × b| and a·b: accurate at every angle, unlike acos.
            sum += length.atan2(a.dot(b)) * n.dot(cross) / length;
        }
    }
    0.5 * sum.abs()
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::*;

    /// ∫ (n·ω)⁺ dω over the parallelogram c + s·u + t·v (s, t ∈ [−1, 1]) by the midpoint rule on a
    /// `k` × `k` grid: ∫ (n·d)⁺ (−m·d)/|d|⁴ dA, m the rectangle's normal facing p.
    fn brute(p: DVec3, n: DVec3, c: DVec3, u: DVec3, v: DVec3, k: usize) -> f64 {
        let m = u.cross(v).normalize();
        let m = if m.dot(p - c) > 0.0 { m } else { -m };
        let da = 4.0 * u.cross(v).length() / (k * k) as f64;
        let mut sum = 0.0;
        for i in 0..k {
            for j in 0..k {
                let (s, t) = ((i as f64 + 0.5) / k as f64 * 2.0 - 1.0, (j as f64 + 0.5) / k as f64 * 2.0 - 1.0);
                let d = c + s * u + t * v - p;
                let r2 = d.length_squared();
                sum += n.dot(d).max(0.0) * m.dot(-d).max(0.0) / (r2 * r2) * da;
            }
        }
        sum
    }

    fn corners(c: DVec3, u: DVec3, v: DVec3) -> [DVec3; 4] {
        [c - u - v, c + u - v, c + u + v, c - u + v]
    }

    #[test]
    fn a_parallel_rectangle_gives_the_corner_formula() {
        // A 2a × 2b rectangle at height h centred over the point: four corner rectangles,
        // F = (1/2π)[A/√(1+A²) atan(B/√(1+A²)) + B/√(1+B²) atan(A/√(1+B²))], A = a/h, B = b/h.
        let (a, b, h) = (0.7, 0.3, 0.5);
        let corner = |x: f64, y: f64| {
            let (sa, sb) = ((1.0 + x * x).sqrt(), (1.0 + y * y).sqrt());
            (x / sa * (y / sa).atan() + y / sb * (x / sb).atan()) / (2.0 * PI)
        };
        let want = PI * 4.0 * corner(a / h, b / h);
        let c = DVec3::new(0.0, 0.0, h);
        let got = polygon_irradiance(DVec3::ZERO, DVec3::Z, &corners(c, DVec3::X * a, DVec3::Y * b));
        assert!((got - want).abs() < 1e-13, "{got} against {want}");
        // Either winding.
        let mut reversed = corners(c, DVec3::X * a, DVec3::Y * b);
        reversed.reverse();
        assert!((polygon_irradiance(DVec3::ZERO, DVec3::Z, &reversed) - want).abs() < 1e-13);
    }

    #[test]
    fn tilted_and_horizon_straddling_rectangles_match_quadrature() {
        let p = DVec3::new(0.1, -0.2, 0.0);
        for (c, u, v, n) in [
            // Perpendicular to the point's plane, wholly above it.
            (DVec3::new(1.0, 0.0, 0.6), DVec3::new(0.0, 0.4, 0.0), DVec3::new(0.0, 0.0, 0.5), DVec3::Z),
            // A tilted parallelogram crossing the horizon: the part below it is clipped.
            (DVec3::new(0.8, 0.3, 0.1), DVec3::new(0.1, 0.5, 0.0), DVec3::new(-0.2, 0.0, 0.6), DVec3::Z),
            // A tilted normal.
            (
                DVec3::new(0.0, 0.0, 1.0),
                DVec3::new(0.5, 0.0, 0.0),
                DVec3::new(0.0, 0.4, 0.2),
                DVec3::new(0.3, 0.0, 1.0).normalize(),
            ),
        ] {
            let got = polygon_irradiance(p, n, &corners(c, u, v));
            let want = brute(p, n, c, u, v, 1200);
            assert!((got - want).abs() < 2e-5 * want.max(1e-3), "{got} against {want}");
        }
        // Wholly below the horizon.
        let below = corners(DVec3::new(0.0, 0.0, -1.0), DVec3::X, DVec3::Y);
        assert_eq!(polygon_irradiance(DVec3::ZERO, DVec3::Z, &below), 0.0);
    }

    #[test]
    fn a_huge_rectangle_fills_the_hemisphere() {
        // ∫ (n·ω)⁺ dω over the whole hemisphere is π.
        let got = polygon_irradiance(DVec3::ZERO, DVec3::Z, &corners(DVec3::new(0.0, 0.0, 1.0), DVec3::X * 1e6, DVec3::Y * 1e6));
        assert!((got - PI).abs() < 1e-5, "{got}");
    }
}
