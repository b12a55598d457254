//! The orthonormal Haar transform of a signal of length 2ⁿ (R. Wang et al. 2008 eq. 8: the
//! transfer rows and the irradiance are compared in the Haar basis, where a row keeps only its
//! largest coefficients). Along the samples' k-d order ([`super::samples`]) this is the Haar
//! basis of the tree: coefficient 0 is the scaled mean (the only one uniform light excites),
//! then the details coarse to fine, level ℓ at indices [2^ℓ, 2^{ℓ+1}).
//!
//! Orthonormal, so ⟨T, E⟩ = ⟨H T, H E⟩ exactly (up to rounding) and the error of a truncated
//! row is the norm of what it dropped.

/// The forward transform of `signal` (length a power of two) in place; `scratch` as long.
pub fn forward<T: Float>(signal: &mut [T], scratch: &mut [T]) {
    let n = signal.len();
    assert!(n.is_power_of_two(), "the Haar transform needs a power of two, not {n}");
    let h = T::from_f64(std::f64::consts::FRAC_1_SQRT_2);
    let mut len = n;
    while len > 1 {
        let half = len / 2;
        for i in 0..half {
            let (a, b) = (signal[2 * i], signal[2 * i + 1]);
            scratch[i] = (a + b) * h;
            scratch[half + i] = (a - b) * h;
        }
        signal[..len].copy_from_slice(&scratch[..len]);
        len = half;
    }
}

/// [`forward`] of `channels` signals stored interleaved (sample j of signal c at
/// `data[j channels + c]`), all at once: each value goes through the same operations as in
/// [`forward`], so the result is the same bit for bit, and the inner loop runs over contiguous
/// channels. `scratch` as long as `data`.
pub fn forward_interleaved<T: Float>(data: &mut [T], channels: usize, scratch: &mut [T]) {
    assert!(channels > 0 && data.len().is_multiple_of(channels), "{} values in {channels} channels", data.len());
    let n = data.len() / channels;
    assert!(n.is_power_of_two(), "the Haar transform needs a power of two, not {n}");
    let h = T::from_f64(std::f64::consts::FRAC_1_SQRT_2);
    let mut len = n;
    while len > 1 {
        let half = len / 2;
        let (sums, details) = scratch[..len * channels].split_at_mut(half * channels);
        for ((pair, s), d) in data[..len * channels]
            .chunks_exact(2 * channels)
            .zip(sums.chunks_exact_mut(channels))
            .zip(details.chunks_exact_mut(channels))
        {
            let (a, b) = pair.split_at(channels);
            for c in 0..channels {
                s[c] = (a[c] + b[c]) * h;
                d[c] = (a[c] - b[c]) * h;
            }
        }
        data[..len * channels].copy_from_slice(&scratch[..len * channels]);
        len = half;
    }
}

/// The inverse of [`forward`], in place.
pub fn inverse<T: Float>(coefficients: &mut [T], scratch: &mut [T]) {
    let n = coefficients.len();
    assert!(n.is_power_of_two(), "the Haar transform needs a power of two, not {n}");
    let h = T::from_f64(std::f64::consts::FRAC_1_SQRT_2);
    let mut len = 2;
    while len <= n {
        let half = len / 2;
        for i in 0..half {
            let (s, d) = (coefficients[i], coefficients[half + i]);
            scratch[2 * i] = (s + d) * h;
            scratch[2 * i + 1] = (s - d) * h;
        }
        coefficients[..len].copy_from_slice(&scratch[..len]);
        len *= 2;
    }
}

/// f32 or f64.
pub trait Float: Copy + std::ops::Add<Output = Self> + std::ops::Sub<Output = Self> + std::ops::Mul<Output = Self> {
    fn from_f64(x: f64) -> Self;
}

impl Float for f32 {
    fn from_f64(x: f64) -> Self {
        x as f32
    }
}

impl Float for f64 {
    fn from_f64(x: f64) -> Self {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against the explicit basis: coefficient 0 is Σx/√N, coefficient 1 (Σ first half − Σ
    /// second half)/√N, and the finest detail of pair i is (x₂ᵢ − x₂ᵢ₊₁)/√2; the transform keeps
    /// the norm and inverts.
    #[test]
    fn matches_the_explicit_basis_and_inverts() {
        let x: Vec<f64> = (0..16).map(|i| ((i * 7919) % 13) as f64 - 4.5).collect();
        let mut c = x.clone();
        let mut scratch = vec![0.0; 16];
        forward(&mut c, &mut scratch);
        let root_n = 4.0;
        assert!((c[0] - x.iter().sum::<f64>() / root_n).abs() < 1e-12);
        assert!((c[1] - (x[..8].iter().sum::<f64>() - x[8..].iter().sum::<f64>()) / root_n).abs() < 1e-12);
        for i in 0..8 {
            assert!((c[8 + i] - (x[2 * i] - x[2 * i + 1]) / 2f64.sqrt()).abs() < 1e-12);
        }
        let norm = |v: &[f64]| v.iter().map(|a| a * a).sum::<f64>();
        assert!((norm(&c) - norm(&x)).abs() < 1e-10);
        inverse(&mut c, &mut scratch);
        for (a, b) in c.iter().zip(&x) {
            assert!((a - b).abs() < 1e-12);
        }
    }

    /// The interleaved transform is the per-signal one, bit for bit.
    #[test]
    fn interleaved_is_per_signal() {
        let (n, channels) = (64, 5);
        let data: Vec<f32> = (0..n * channels).map(|i| ((i * 7919) % 101) as f32 * 0.37 - 11.0).collect();
        let mut together = data.clone();
        forward_interleaved(&mut together, channels, &mut vec![0.0; n * channels]);
        for c in 0..channels {
            let mut alone: Vec<f32> = (0..n).map(|j| data[j * channels + c]).collect();
            forward(&mut alone, &mut vec![0.0; n]);
            for j in 0..n {
                assert_eq!(together[j * channels + c].to_bits(), alone[j].to_bits(), "signal {c}, coefficient {j}");
            }
        }
    }

    /// A constant signal has one coefficient.
    #[test]
    fn constant_is_the_mean_alone() {
        let mut c = vec![3.0f32; 64];
        let mut scratch = vec![0.0; 64];
        forward(&mut c, &mut scratch);
        assert!((c[0] - 24.0).abs() < 1e-5);
        assert!(c[1..].iter().all(|v| v.abs() < 1e-5));
    }
}
