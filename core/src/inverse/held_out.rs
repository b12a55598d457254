//! Held-out lighting and measurement noise for judging an acquisition: random rectangle
//! patterns, single-node sources and Gaussian image noise, each reproducible from a seed (the
//! sequence is xorshift64*, so no random-number dependency is needed and every platform draws
//! the same numbers).

use super::setup::Pattern;

/// A pseudo-random sequence in [0, 1) from `seed` (xorshift64*, Vigna 2016; 53 bits per draw).
pub fn uniform_sequence(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed.max(1);
    move || {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        (s.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `n` patterns on a face of `size` mm: each a random rectangle (20–50% of the face per axis,
/// inside it) of random colour (each channel in [0.5, 1.5)).
#[must_use]
pub fn random_patterns(n: usize, size: [f64; 2], seed: u64) -> Vec<Pattern> {
    let mut r = uniform_sequence(seed);
    (0..n)
        .map(|_| {
            let (x0, y0) = (r() * size[0] * 0.7, r() * size[1] * 0.7);
            let (w, h) = (0.2 * size[0] + r() * 0.3 * size[0], 0.2 * size[1] + r() * 0.3 * size[1]);
            Pattern::Rect { rect: [x0, (x0 + w).min(size[0]), y0, (y0 + h).min(size[1])], q: [0.5 + r(), 0.5 + r(), 0.5 + r()] }
        })
        .collect()
}

/// `n` × `n` single-node sources on an `nx` × `ny` lit face at spacing `h` mm: q = 1 over one
/// node's dual cell each (a rectangle, so a finer synthesis grid gets the same light), the
/// nodes spread evenly over the face ((a + ½)/n of each axis).
#[must_use]
pub fn single_node_patterns(n: usize, nx: usize, ny: usize, h: f64) -> Vec<Pattern> {
    let at = |a: usize, count: usize| (((a as f64 + 0.5) / n as f64) * (count - 1) as f64).round();
    let dual = |i: f64, count: usize| [((i - 0.5) * h).max(0.0), ((i + 0.5) * h).min((count - 1) as f64 * h)];
    (0..n * n)
        .map(|p| {
            let ([x0, x1], [y0, y1]) = (dual(at(p % n, nx), nx), dual(at(p / n, ny), ny));
            Pattern::Rect { rect: [x0, x1, y0, y1], q: [1.0; 3] }
        })
        .collect()
}

/// `images` with Gaussian noise of relative RMS `rms` on every pixel and channel
/// (v ← v (1 + rms g), g standard normal by Box–Muller on [`uniform_sequence`]).
#[must_use]
pub fn with_noise(images: &[Vec<[f64; 3]>], rms: f64, seed: u64) -> Vec<Vec<[f64; 3]>> {
    let mut r = uniform_sequence(seed);
    let mut gauss = move || {
        let (u, v) = (r().max(1e-300), r());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    };
    images.iter().map(|img| img.iter().map(|p| p.map(|v| v * (1.0 + rms * gauss()))).collect()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sequence stays in [0, 1), repeats from its seed, and its mean and variance over
    /// 10⁵ draws are those of the uniform distribution (½ and 1/12) within 1%.
    #[test]
    fn the_sequence_is_uniform_and_reproducible() {
        let draws: Vec<f64> = std::iter::repeat_with(uniform_sequence(42)).take(100_000).collect();
        assert!(draws.iter().all(|x| (0.0..1.0).contains(x)));
        assert_eq!(draws[..10], std::iter::repeat_with(uniform_sequence(42)).take(10).collect::<Vec<_>>()[..]);
        let mean = draws.iter().sum::<f64>() / draws.len() as f64;
        let var = draws.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / draws.len() as f64;
        assert!((mean - 0.5).abs() < 5e-3 && (var * 12.0 - 1.0).abs() < 1e-2, "{mean} {var}");
    }

    /// Random rectangles lie on the face, span 20–50% of it per axis (less where clipped at
    /// its far edge) and have colours in [0.5, 1.5).
    #[test]
    fn random_patterns_lie_on_the_face() {
        let size = [3.0, 2.0];
        for p in random_patterns(50, size, 5) {
            let Pattern::Rect { rect: [x0, x1, y0, y1], q } = p else { panic!("a rectangle") };
            assert!(0.0 <= x0 && x0 < x1 && x1 <= size[0] && 0.0 <= y0 && y0 < y1 && y1 <= size[1]);
            assert!(x1 - x0 <= 0.5 * size[0] + 1e-12 && y1 - y0 <= 0.5 * size[1] + 1e-12);
            assert!(q.iter().all(|c| (0.5..1.5).contains(c)));
        }
    }

    /// Single-node sources cover one dual cell each (half a cell at the face's rim), at the
    /// nodes (a + ½)/n of the way across.
    #[test]
    fn single_node_sources_cover_one_dual_cell_each() {
        let (nx, ny, h) = (11, 7, 0.5);
        let patterns = single_node_patterns(2, nx, ny, h);
        assert_eq!(patterns.len(), 4);
        // Nodes round((a + ½)/2 · 10) = 3, 8 across and round((a + ½)/2 · 6) = 2, 5 down.
        let expect = [[1.25, 1.75, 0.75, 1.25], [3.75, 4.25, 0.75, 1.25], [1.25, 1.75, 2.25, 2.75], [3.75, 4.25, 2.25, 2.75]];
        for (p, want) in patterns.iter().zip(expect) {
            assert_eq!(*p, Pattern::Rect { rect: want, q: [1.0; 3] });
        }
        let Pattern::Rect { rect, .. } = &single_node_patterns(1, 3, 3, 1.0)[0] else { panic!() };
        assert_eq!(*rect, [0.5, 1.5, 0.5, 1.5]);
    }

    /// Noise of relative RMS 1% has that RMS over 3 × 10⁴ samples (within 2%), a mean within
    /// its standard error, and repeats from its seed.
    #[test]
    fn noise_has_the_relative_rms_asked_for() {
        let images = vec![vec![[2.0, 1.0, 0.5]; 10_000]];
        let noisy = with_noise(&images, 0.01, 3);
        let rel: Vec<f64> = noisy[0].iter().zip(&images[0]).flat_map(|(a, b)| (0..3).map(move |c| a[c] / b[c] - 1.0)).collect();
        let rms = (rel.iter().map(|x| x * x).sum::<f64>() / rel.len() as f64).sqrt();
        let mean = rel.iter().sum::<f64>() / rel.len() as f64;
        assert!((rms / 0.01 - 1.0).abs() < 0.02 && mean.abs() < 3.0 * 0.01 / (rel.len() as f64).sqrt(), "{rms} {mean}");
        assert_eq!(noisy, with_noise(&images, 0.01, 3));
    }
}
