//! Seeded 3D gradient noise (Perlin's *improved noise*, SIGGRAPH 2002) and its fractal sums.
//!
//! - [`PerlinNoise::noise`]: n(p) = trilinear blend, with the quintic fade
//!   f(t) = 6t⁵ − 15t⁴ + 10t³, of the dot products g·(p − corner) at the 8 lattice corners
//!   around p, the gradients g picked among the 12 cube-edge directions (±1, ±1, 0) … by a
//!   seeded permutation of 0..256. n = 0 at every lattice point, values in about [−1, 1],
//!   period 256 along each axis.
//! - [`PerlinNoise::fbm`]: fractal Brownian motion Σ_{o<octaves} 2^{−o} n(2^o p).
//! - [`PerlinNoise::turbulence`]: Perlin's turbulence Σ_{o<octaves} 2^{−o} |n(2^o p)|.
//!
//! The permutation is a Fisher–Yates shuffle driven by SplitMix64 from the seed, so a seed
//! gives the same noise on every run and thread count (no global random state).

use glam::DVec3;

/// Seeded Perlin gradient noise.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PerlinNoise {
    /// The permutation, repeated twice so that `perm[perm[x] + y]` needs no wrap.
    perm: Box<[u8; 512]>,
    seed: u64,
}

impl PerlinNoise {
    /// The noise of `seed`.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        let mut p: [u8; 256] = std::array::from_fn(|i| i as u8);
        let mut state = seed;
        for i in (1..256usize).rev() {
            // Lemire's multiply-shift: a uniform index in 0..=i from the top 32 bits.
            let j = (((splitmix64(&mut state) >> 32) * (i as u64 + 1)) >> 32) as usize;
            p.swap(i, j);
        }
        let mut perm = Box::new([0u8; 512]);
        perm[..256].copy_from_slice(&p);
        perm[256..].copy_from_slice(&p);
        Self { perm, seed }
    }

    /// The seed this noise was built from.
    #[must_use]
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Improved Perlin noise at `p`, in about [−1, 1]. Non-finite coordinates give 0.
    #[must_use]
    pub fn noise(&self, p: DVec3) -> f64 {
        if !p.is_finite() {
            return 0.0;
        }
        let cell = p.floor();
        let f = p - cell;
        // Lattice coordinates modulo 256 (rem_euclid keeps negative cells in range).
        let [x, y, z] = cell.to_array().map(|c| c.rem_euclid(256.0) as usize);
        let (u, v, w) = (fade(f.x), fade(f.y), fade(f.z));
        let perm = &self.perm;
        let a = perm[x] as usize + y;
        let (aa, ab) = (perm[a] as usize + z, perm[a + 1] as usize + z);
        let b = perm[x + 1] as usize + y;
        let (ba, bb) = (perm[b] as usize + z, perm[b + 1] as usize + z);
        let g = |h: usize, dx: f64, dy: f64, dz: f64| grad(perm[h], f.x - dx, f.y - dy, f.z - dz);
        lerp(
            w,
            lerp(v, lerp(u, g(aa, 0.0, 0.0, 0.0), g(ba, 1.0, 0.0, 0.0)), lerp(u, g(ab, 0.0, 1.0, 0.0), g(bb, 1.0, 1.0, 0.0))),
            lerp(
                v,
                lerp(u, g(aa + 1, 0.0, 0.0, 1.0), g(ba + 1, 1.0, 0.0, 1.0)),
                lerp(u, g(ab + 1, 0.0, 1.0, 1.0), g(bb + 1, 1.0, 1.0, 1.0)),
            ),
        )
    }

    /// Fractal Brownian motion Σ_{o<octaves} 2^{−o} n(2^o p) (0 for no octaves).
    #[must_use]
    pub fn fbm(&self, p: DVec3, octaves: u32) -> f64 {
        self.octave_sum(p, octaves, |n| n)
    }

    /// Perlin turbulence Σ_{o<octaves} 2^{−o} |n(2^o p)|, in [0, 2) (0 for no octaves).
    #[must_use]
    pub fn turbulence(&self, p: DVec3, octaves: u32) -> f64 {
        self.octave_sum(p, octaves, f64::abs)
    }

    fn octave_sum(&self, p: DVec3, octaves: u32, shape: impl Fn(f64) -> f64) -> f64 {
        let mut sum = 0.0;
        let mut scale = 1.0;
        for _ in 0..octaves {
            sum += shape(self.noise(p * scale)) / scale;
            scale *= 2.0;
        }
        sum
    }
}

/// SplitMix64 (Steele, Lea & Flood 2014): the next 64-bit output, advancing `state`.
pub(crate) fn splitmix64(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Perlin's quintic fade 6t⁵ − 15t⁴ + 10t³ (C² at the lattice planes).
fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

fn lerp(t: f64, a: f64, b: f64) -> f64 {
    a + t * (b - a)
}

/// The dot product of (x, y, z) with one of the 12 cube-edge gradients (Perlin 2002's table,
/// 16 entries with four repeated).
fn grad(hash: u8, x: f64, y: f64, z: f64) -> f64 {
    let h = hash & 15;
    let u = if h < 8 { x } else { y };
    let v = if h < 4 {
        y
    } else if h == 12 || h == 14 {
        x
    } else {
        z
    };
    (if h & 1 == 0 { u } else { -u }) + (if h & 2 == 0 { v } else { -v })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn permutation_is_a_permutation_and_depends_on_the_seed() {
        let a = PerlinNoise::new(1);
        let mut seen = [false; 256];
        for &v in &a.perm[..256] {
            seen[v as usize] = true;
        }
        assert!(seen.iter().all(|&s| s));
        assert_eq!(&a.perm[..256], &a.perm[256..]);
        assert_eq!(a, PerlinNoise::new(1));
        assert_ne!(a.perm, PerlinNoise::new(2).perm);
    }

    #[test]
    fn noise_vanishes_on_the_lattice_is_bounded_and_periodic() {
        let n = PerlinNoise::new(42);
        for p in [DVec3::ZERO, DVec3::new(3.0, -7.0, 12.0), DVec3::new(-300.0, 1.0, 255.0)] {
            assert_eq!(n.noise(p), 0.0);
        }
        let mut max: f64 = 0.0;
        let mut sum = 0.0;
        let mut state = 7;
        for _ in 0..20_000 {
            let mut r = || (splitmix64(&mut state) >> 11) as f64 / (1u64 << 53) as f64 * 40.0 - 20.0;
            let p = DVec3::new(r(), r(), r());
            let v = n.noise(p);
            max = max.max(v.abs());
            sum += v;
            assert!((v - n.noise(p + DVec3::new(256.0, -512.0, 0.0))).abs() < 1e-9);
        }
        assert!(max < 1.1 && max > 0.5, "max |n| = {max}");
        assert!((sum / 20_000.0).abs() < 0.02, "mean {}", sum / 20_000.0);
        assert_eq!(n.noise(DVec3::new(f64::NAN, 0.0, 0.0)), 0.0);
    }

    #[test]
    fn noise_is_continuous() {
        let n = PerlinNoise::new(3);
        let p = DVec3::new(1.999_999_9, 0.5, 0.25);
        let q = DVec3::new(2.000_000_1, 0.5, 0.25);
        assert!((n.noise(p) - n.noise(q)).abs() < 1e-5);
    }

    #[test]
    fn octave_sums() {
        let n = PerlinNoise::new(9);
        let p = DVec3::new(0.3, 1.7, -2.2);
        assert_eq!(n.fbm(p, 0), 0.0);
        assert_eq!(n.turbulence(p, 1), n.noise(p).abs());
        let expect = n.noise(p) + n.noise(2.0 * p) / 2.0 + n.noise(4.0 * p) / 4.0;
        assert!((n.fbm(p, 3) - expect).abs() < 1e-15);
        assert!(n.turbulence(p, 6) >= 0.0);
    }
}
