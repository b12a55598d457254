//! The smoothness regulariser on κ (Wang et al. 2008 §4.2: λ Σ_x ‖∇κ(x)‖²), made unit-free.
//!
//! The paper's λ Σ‖∇κ‖² has units (mm⁻² · mm² summed over nodes) and its λ = 1e-5 only means
//! something at its own grid and data scale (design note P9). Here, per channel,
//!
//! R(κ) = (ℓ² / (κ_ref² V)) ∫_V ‖∇κ‖² dV ≈ (ℓ² h / (κ_ref² V)) Σ_{a∼b} (κ_a − κ_b)²,
//!
//! the sum over face-adjacent cell pairs (the two-point gradient (κ_a − κ_b)/h on the dual
//! face h², times the volume h³ it stands for), ℓ = 1 mm and V the block's volume: the volume
//! mean of the squared relative κ gradient per mm, the same for any grid and brightness. κ_ref
//! is the homogeneous fit's κ, held fixed while the heterogeneous fit runs.

use super::block::BlockGrid;

/// The unit-free ‖∇κ‖² regulariser on a block (module documentation).
#[derive(Debug, Clone)]
pub struct Smoothness {
    pairs: Vec<[u32; 2]>,
    /// ℓ² h / V; divided by κ_ref² per channel.
    geometric: f64,
    kappa_ref: [f64; 3],
}

impl Smoothness {
    /// The regulariser of `grid` with κ_ref = 1 mm until [`Smoothness::set_reference`].
    #[must_use]
    pub fn new(grid: &BlockGrid) -> Self {
        let h = grid.spacing();
        let volume = grid.cell_count() as f64 * h.powi(3);
        Self { pairs: grid.cell_neighbours(), geometric: h / volume, kappa_ref: [1.0; 3] }
    }

    /// Sets κ_ref per channel (non-positive or non-finite entries are ignored).
    pub fn set_reference(&mut self, kappa: [f64; 3]) {
        for (r, &k) in self.kappa_ref.iter_mut().zip(&kappa) {
            if k.is_finite() && k > 0.0 {
                *r = k;
            }
        }
    }

    /// The weight w_ch = ℓ² h / (κ_ref² V) of each squared difference.
    fn weight(&self) -> [f64; 3] {
        self.kappa_ref.map(|k| self.geometric / (k * k))
    }

    /// R(κ) per channel: w Σ_{a∼b} (κ_a − κ_b)².
    #[must_use]
    pub fn value(&self, kappa: &[[f64; 3]]) -> [f64; 3] {
        let w = self.weight();
        let mut r = [0.0; 3];
        for &[a, b] in &self.pairs {
            for c in 0..3 {
                r[c] += (kappa[a as usize][c] - kappa[b as usize][c]).powi(2);
            }
        }
        std::array::from_fn(|c| w[c] * r[c])
    }

    /// ∂R/∂κ_a = 2w Σ_{b∼a} (κ_a − κ_b) per cell and channel (the discrete −2w h² Δκ of eq. 7).
    #[must_use]
    pub fn gradient(&self, kappa: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let w = self.weight();
        let mut g = vec![[0.0; 3]; kappa.len()];
        for &[a, b] in &self.pairs {
            for c in 0..3 {
                let d = 2.0 * w[c] * (kappa[a as usize][c] - kappa[b as usize][c]);
                g[a as usize][c] += d;
                g[b as usize][c] -= d;
            }
        }
        g
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_linear_kappa_gives_its_squared_gradient() {
        // κ = κ_ref (1 + 0.1 x/mm) along x on a 5 × 3 × 2-cell block at h = 0.5: R = (0.1)²
        // × the fraction of pairs along x carrying it, here the x pairs over every dual face:
        // exactly (nx − 1)/nx of the volume's gradient for a cell-centred field.
        let g = BlockGrid::new([6, 4, 3], 0.5).unwrap();
        let mut s = Smoothness::new(&g);
        s.set_reference([2.0; 3]);
        let kappa: Vec<[f64; 3]> = (0..g.cell_count()).map(|c| [2.0 * (1.0 + 0.1 * g.cell_centre(c)[0]); 3]).collect();
        let r = s.value(&kappa);
        assert!((r[0] - 0.01 * 4.0 / 5.0).abs() < 1e-12, "{}", r[0]);
    }

    #[test]
    fn the_gradient_matches_differences() {
        let g = BlockGrid::new([4, 3, 3], 0.7).unwrap();
        let mut s = Smoothness::new(&g);
        s.set_reference([0.3, 0.5, 1.0]);
        let k: Vec<[f64; 3]> = (0..g.cell_count()).map(|c| [0.3 + 0.01 * (c as f64).sin(), 0.5, 1.0 + 0.1 * c as f64]).collect();
        let grad = s.gradient(&k);
        for c in 0..g.cell_count() {
            for ch in 0..3 {
                let e = 1e-6;
                let (mut kp, mut km) = (k.clone(), k.clone());
                kp[c][ch] += e;
                km[c][ch] -= e;
                let fd = (s.value(&kp)[ch] - s.value(&km)[ch]) / (2.0 * e);
                assert!((fd - grad[c][ch]).abs() < 1e-7 * (1.0 + fd.abs()), "{fd} vs {}", grad[c][ch]);
            }
        }
    }
}
