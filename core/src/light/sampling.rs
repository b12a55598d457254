//! Deterministic sample patterns and the warps that turn them into directions and points.
//!
//! Every Monte Carlo estimate in [`super::source`] uses the first N points of the
//! two-dimensional Sobol sequence, Owen-scrambled with a hash of (user seed, light, surface
//! point) (Burley 2020, *Practical Hash-based Owen Scrambling*, JCGT 9(4)). The pattern is
//! stratified (every elementary interval of a power-of-two prefix holds exactly one point), each
//! point is uniformly distributed (so estimates are unbiased), and it depends only on the seeds,
//! never on thread scheduling.

use glam::DVec3;

/// 2⁻³², mapping a 32-bit integer to [0, 1).
const INV_2_32: f64 = 1.0 / 4_294_967_296.0;

/// SplitMix64 finaliser (Steele, Lea & Flood 2014): a bijective 64-bit mixer.
#[must_use]
pub(crate) fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Combines a running hash with one more value (order-dependent).
#[must_use]
pub(crate) fn hash_combine(h: u64, v: u64) -> u64 {
    mix64(h ^ mix64(v))
}

/// Sobol's second dimension: the generator matrix of the primitive polynomial x + 1, direction
/// numbers v₀ = 2³¹, v_k = v_{k−1} ⊕ (v_{k−1} ≫ 1) (Pascal's triangle mod 2).
const SOBOL_DIM1: [u32; 32] = {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    let mut k = 1;
    while k < 32 {
        v[k] = v[k - 1] ^ (v[k - 1] >> 1);
        k += 1;
    }
    v
};

/// The `index`-th point of the two-dimensional Sobol sequence as 32-bit fixed-point fractions:
/// the first coordinate is the base-2 radical inverse (van der Corput), the second uses
/// [`SOBOL_DIM1`].
#[must_use]
fn sobol_2d(index: u32) -> (u32, u32) {
    let x = index.reverse_bits();
    let mut y = 0u32;
    let mut i = index;
    let mut bit = 0;
    while i != 0 {
        if i & 1 != 0 {
            y ^= SOBOL_DIM1[bit];
        }
        i >>= 1;
        bit += 1;
    }
    (x, y)
}

/// Laine–Karras style hash permutation with Burley's (2020) constants: each output bit depends
/// only on the same and lower input bits, so applied to bit-reversed values it is a nested
/// uniform (Owen) scramble.
#[must_use]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Nested uniform (Owen) scrambling of a 32-bit fixed-point fraction.
#[must_use]
fn owen_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// A seeded, Owen-scrambled two-dimensional Sobol pattern.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pattern {
    seed_x: u32,
    seed_y: u32,
}

impl Pattern {
    /// The pattern for a 64-bit key (a hash of user seed, light and point).
    #[must_use]
    pub(crate) fn new(key: u64) -> Self {
        let h = mix64(key);
        Self { seed_x: h as u32, seed_y: (h >> 32) as u32 }
    }

    /// Sample `index` in [0, 1)².
    #[must_use]
    pub(crate) fn get(&self, index: usize) -> [f64; 2] {
        // Sample counts beyond 2³² wrap; no caller asks for that many per point.
        let (x, y) = sobol_2d(index as u32);
        let x = owen_scramble(x, self.seed_x);
        let y = owen_scramble(y, self.seed_y);
        [f64::from(x) * INV_2_32, f64::from(y) * INV_2_32]
    }
}

/// Shirley–Chiu concentric map of the unit square onto the unit disc (area-preserving, low
/// distortion, so stratification survives).
#[must_use]
pub(crate) fn concentric_disc([u, v]: [f64; 2]) -> (f64, f64) {
    let a = 2.0 * u - 1.0;
    let b = 2.0 * v - 1.0;
    if a == 0.0 && b == 0.0 {
        return (0.0, 0.0);
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, std::f64::consts::FRAC_PI_4 * (b / a))
    } else {
        (b, std::f64::consts::FRAC_PI_2 - std::f64::consts::FRAC_PI_4 * (a / b))
    };
    (r * phi.cos(), r * phi.sin())
}

/// Cosine-weighted direction on the hemisphere around +z (Malley's method: a uniform disc point
/// lifted to the hemisphere), pdf(ω) = cos θ / π.
#[must_use]
pub(crate) fn cosine_hemisphere(u: [f64; 2]) -> DVec3 {
    let (x, y) = concentric_disc(u);
    let z = (1.0 - x * x - y * y).max(0.0).sqrt();
    DVec3::new(x, y, z)
}

/// An orthonormal basis (t, b) completing the unit vector `n` to a right-handed frame
/// (t × b = n), branch-free except for the sign (Duff et al. 2017, JCGT 6(1)).
#[must_use]
pub(crate) fn orthonormal_basis(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1.0_f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), DVec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// Nodes and weights of the `n`-point Gauss–Legendre rule on [−1, 1], by Newton iteration on
/// P_n from the Tricomi initial guesses (exact for polynomials of degree ≤ 2n − 1).
#[must_use]
pub(crate) fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut rule = Vec::with_capacity(n);
    for i in 0..n {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            // Three-term recurrence: (k+1)P_{k+1} = (2k+1)x P_k − k P_{k−1}.
            let (mut p0, mut p1) = (1.0, x);
            for k in 1..n {
                let p2 = ((2 * k + 1) as f64 * x * p1 - k as f64 * p0) / (k + 1) as f64;
                p0 = p1;
                p1 = p2;
            }
            // P_n'(x) = n (x P_n − P_{n−1}) / (x² − 1).
            dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        rule.push((x, 2.0 / ((1.0 - x * x) * dp * dp)));
    }
    rule
}

/// ∫ₐᵇ f by composite Gauss–Legendre: `panels` equal panels of the 10-point rule.
#[must_use]
pub(crate) fn integrate(f: impl Fn(f64) -> f64, a: f64, b: f64, panels: usize) -> f64 {
    let rule = gauss_legendre(10);
    let h = (b - a) / panels as f64;
    (0..panels)
        .map(|p| {
            let mid = a + (p as f64 + 0.5) * h;
            rule.iter().map(|&(x, w)| w * f(mid + 0.5 * h * x)).sum::<f64>() * 0.5 * h
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sobol_first_points() {
        let pts: Vec<_> = (0..4).map(sobol_2d).collect();
        let half = 1u32 << 31;
        assert_eq!(pts[0], (0, 0));
        assert_eq!(pts[1], (half, half));
        assert_eq!(pts[2], (half >> 1, 3 << 30));
        assert_eq!(pts[3], (3 << 30, half >> 1));
    }

    /// Every elementary interval of area 1/16 holds exactly one of 16 points: a (0, 4, 2)-net,
    /// with and without scrambling.
    #[test]
    fn scrambled_prefix_is_a_net() {
        for key in [0u64, 1, 12345, u64::MAX] {
            let p = Pattern::new(key);
            let pts: Vec<[f64; 2]> = (0..16).map(|i| p.get(i)).collect();
            for a in 0..=4 {
                let (nx, ny) = (1usize << a, 1usize << (4 - a));
                let mut count = vec![0; 16];
                for q in &pts {
                    assert!((0.0..1.0).contains(&q[0]) && (0.0..1.0).contains(&q[1]));
                    let cell = (q[0] * nx as f64) as usize * ny + (q[1] * ny as f64) as usize;
                    count[cell] += 1;
                }
                assert!(count.iter().all(|&c| c == 1), "key {key}, {nx}×{ny}: {count:?}");
            }
        }
    }

    #[test]
    fn scrambling_depends_on_the_key_only() {
        let (a, b) = (Pattern::new(7), Pattern::new(8));
        assert_eq!(a.get(5), Pattern::new(7).get(5));
        assert_ne!(a.get(5), b.get(5));
    }

    #[test]
    fn scrambled_points_are_uniform_on_average() {
        // Mean of u over many keys' first points → 1/2 (unbiasedness of the scramble).
        let n = 20_000;
        let mean: f64 = (0..n).map(|k| Pattern::new(k).get(0)[0]).sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
    }

    #[test]
    fn disc_and_hemisphere_maps() {
        let p = Pattern::new(3);
        for i in 0..256 {
            let (x, y) = concentric_disc(p.get(i));
            assert!(x * x + y * y <= 1.0 + 1e-15);
            let d = cosine_hemisphere(p.get(i));
            assert!((d.length() - 1.0).abs() < 1e-12 && d.z >= 0.0);
        }
        // Cosine-weighted: E[cos θ] = 2/3.
        let n = 4096;
        let m: f64 = (0..n).map(|i| cosine_hemisphere(p.get(i)).z).sum::<f64>() / n as f64;
        assert!((m - 2.0 / 3.0).abs() < 1e-3, "{m}");
    }

    #[test]
    fn basis_is_orthonormal_and_right_handed() {
        for n in [DVec3::X, DVec3::Y, DVec3::Z, -DVec3::Z, DVec3::new(1.0, -2.0, 0.3).normalize()] {
            let (t, b) = orthonormal_basis(n);
            assert!((t.length() - 1.0).abs() < 1e-14 && (b.length() - 1.0).abs() < 1e-14);
            assert!(t.dot(b).abs() < 1e-14 && t.dot(n).abs() < 1e-14 && b.dot(n).abs() < 1e-14);
            assert!((t.cross(b) - n).length() < 1e-14);
        }
    }

    #[test]
    fn gauss_legendre_is_exact_for_polynomials() {
        let rule = gauss_legendre(10);
        let w: f64 = rule.iter().map(|r| r.1).sum();
        assert!((w - 2.0).abs() < 1e-14);
        // ∫₋₁¹ x^18 = 2/19.
        let s: f64 = rule.iter().map(|&(x, w)| w * x.powi(18)).sum();
        assert!((s - 2.0 / 19.0).abs() < 1e-14);
        assert!((integrate(f64::cos, 0.0, 1.0, 4) - 1f64.sin()).abs() < 1e-15);
    }
}
