//! The gradient of the objective by the discrete adjoint (design note §1.4, P7): one forward
//! and one adjoint solve per image, whatever the number of parameters.
//!
//! With A(p)φ_m = b_m (b independent of the media), L_m = sφ_m − t q_m and
//! r_m = W_m(L_m − L̂_m), the data term Σ_m ‖r_m‖²/D has, for each parameter p_k,
//!
//! ∂f/∂p_k = −Σ_m ψ_mᵀ (∂A/∂p_k) φ_m,   Aᵀψ_m = 2 s W_m r_m / D   (A symmetric),
//!
//! and since A is linear in the cells' κ and σa (see [`super::block`]),
//!
//! ∂f/∂κ_c = −Σ_m ψ_mᵀ T_c φ_m + λ ∂R/∂κ_c,   ∂f/∂σa_c|_κ = −Σ_m ψ_mᵀ V_c φ_m,
//!
//! then by κ = 1/(3(σa + σ′s)) and the log parameters
//! ∂f/∂ln σa = σa (∂f/∂σa|_κ − 3κ² ∂f/∂κ),  ∂f/∂ln σ′s = −3κ² σ′s ∂f/∂κ.
//!
//! This is the discretisation's exact gradient, Robin term included: the paper's continuous
//! adjoint (eqs. 5–7) leaves out the κ dependence of the boundary flux and is only the limit
//! of this one (P7). [`check_gradient`] compares it with central differences.

use super::error::InverseError;
use super::model::{dkappa, Acquisition, Evaluation};

impl Acquisition {
    /// The objective and its gradient at `x` (log parameters, [`super::CellMedia::to_log_vector`]
    /// layout): M forward solves (none if `x` was just evaluated) and M adjoint solves.
    ///
    /// # Errors
    /// [`InverseError::InvalidParameters`]; a solver error.
    pub fn gradient(&mut self, x: &[f64]) -> Result<(Evaluation, Vec<f64>), InverseError> {
        let media = self.forward(x)?;
        let pred = self.predicted();
        let eval = self.evaluation(&media, &pred);
        let (s, _) = self.query();
        let n = self.grid.node_count();
        // The adjoint sources 2 s W r / D on the observed face.
        let rhs: Vec<Vec<[f64; 3]>> = (0..self.image_count())
            .map(|m| {
                let mut b = vec![[0.0; 3]; n];
                for (p, &i) in self.observed_nodes.iter().enumerate() {
                    if self.masks[m][p] {
                        b[i] = std::array::from_fn(|c| 2.0 * s * (pred[m][p][c] - self.data[m][p][c]) / self.norm[c]);
                    }
                }
                b
            })
            .collect();
        let a = self.matrix(&media);
        let mut psi = std::mem::take(&mut self.psi);
        let r = self.solve_all(&a, &rhs, &mut psi, "adjoint");
        self.psi = psi;
        r?;
        let kappa = media.kappa();
        let cells = self.grid.cell_count();
        let mut g_kappa = self.smoothness.gradient(&kappa);
        for g in &mut g_kappa {
            *g = g.map(|v| self.lambda * v);
        }
        let mut g_sigma = vec![[0.0; 3]; cells];
        for m in 0..self.image_count() {
            let stiff = self.grid.stiffness_products(&self.psi[m], &self.phi[m]);
            let mass = self.grid.mass_products(&self.psi[m], &self.phi[m]);
            for c in 0..cells {
                for ch in 0..3 {
                    g_kappa[c][ch] -= stiff[c][ch];
                    g_sigma[c][ch] -= mass[c][ch];
                }
            }
        }
        let grad = log_gradient(&media.sigma_a, &media.sigma_s_prime, &kappa, &g_kappa, &g_sigma);
        Ok((eval, grad))
    }
}

/// The gradient in log parameters from ∂f/∂κ and ∂f/∂σa at fixed κ (module documentation):
/// per cell [σa(g_σ − 3κ²g_κ) per channel, −3κ²σ′s g_κ per channel].
#[must_use]
pub fn log_gradient(
    sigma_a: &[[f64; 3]],
    sigma_s_prime: &[[f64; 3]],
    kappa: &[[f64; 3]],
    g_kappa: &[[f64; 3]],
    g_sigma_a: &[[f64; 3]],
) -> Vec<f64> {
    let mut g = Vec::with_capacity(6 * kappa.len());
    for c in 0..kappa.len() {
        let dk = kappa[c].map(dkappa);
        for ch in 0..3 {
            g.push(sigma_a[c][ch] * (g_sigma_a[c][ch] + dk[ch] * g_kappa[c][ch]));
        }
        for ch in 0..3 {
            g.push(sigma_s_prime[c][ch] * dk[ch] * g_kappa[c][ch]);
        }
    }
    g
}

/// One component of a gradient check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GradientComponent {
    /// The parameter's index in the log vector.
    pub index: usize,
    /// The adjoint gradient's component.
    pub adjoint: f64,
    /// The fourth-order central difference ([`central_difference`]).
    pub central: f64,
}

impl GradientComponent {
    /// |adjoint − central| / max(|central|, `floor`).
    #[must_use]
    pub fn relative_error(&self, floor: f64) -> f64 {
        (self.adjoint - self.central).abs() / self.central.abs().max(floor)
    }
}

/// The fourth-order central difference (−f(x + 2ε) + 8f(x + ε) − 8f(x − ε) + f(x − 2ε))/(12ε):
/// its truncation error is O(ε⁴), so a step of 1e-3 keeps both it and the solves' rounding
/// (≈ tolerance/ε) under 1e-9 of the derivative; the two-point (f(x + ε) − f(x − ε))/(2ε) cannot
/// reach 1e-6 relative with solves to 1e-13 (its ε² and 1e-13/ε terms cross near 1e-6).
#[must_use]
pub fn central_difference(f1: f64, f_1: f64, f2: f64, f_2: f64, step: f64) -> f64 {
    (-f2 + 8.0 * f1 - 8.0 * f_1 + f_2) / (12.0 * step)
}

/// Compares the adjoint gradient at `x` with central differences of step `step` (in log
/// parameters; 1e-3 is a good choice) on the components `indices` (each costs 4M forward
/// solves). Use tight solves ([`super::SolveSettings`] tolerance 1e-12 or below) so the
/// differences resolve the gradient.
///
/// # Errors
/// [`InverseError::InvalidParameters`] for `x` of the wrong length, an index out of range or
/// a step not finite and > 0; a solver error.
pub fn check_gradient(
    model: &mut Acquisition,
    x: &[f64],
    indices: &[usize],
    step: f64,
) -> Result<Vec<GradientComponent>, InverseError> {
    if !(step.is_finite() && step > 0.0) {
        return Err(InverseError::InvalidParameters(format!("the difference step must be finite and > 0, got {step}")));
    }
    if let Some(&i) = indices.iter().find(|&&i| i >= x.len()) {
        return Err(InverseError::InvalidParameters(format!("component {i} of {}", x.len())));
    }
    let (_, grad) = model.gradient(x)?;
    let mut out = Vec::with_capacity(indices.len());
    for &index in indices {
        let mut at = |k: f64| -> Result<f64, InverseError> {
            let mut xp = x.to_vec();
            xp[index] += k * step;
            Ok(model.evaluate(&xp)?.value)
        };
        let (f1, f_1, f2, f_2) = (at(1.0)?, at(-1.0)?, at(2.0)?, at(-2.0)?);
        out.push(GradientComponent { index, adjoint: grad[index], central: central_difference(f1, f_1, f2, f_2, step) });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::inverse::{Observation, Pattern, Setup};

    #[test]
    fn log_gradient_applies_the_chain_rule() {
        // f = g_κ κ + g_σ σa (linear): ∂f/∂ln σa by hand.
        let (a, s) = (0.1, 2.0);
        let k = 1.0 / (3.0 * (a + s));
        let g = log_gradient(&[[a; 3]], &[[s; 3]], &[[k; 3]], &[[5.0; 3]], &[[7.0; 3]]);
        let f = |a: f64, s: f64| 5.0 / (3.0 * (a + s)) + 7.0 * a;
        let e: f64 = 1e-6;
        let d_ln_a = (f(a * e.exp(), s) - f(a * (-e).exp(), s)) / (2.0 * e);
        let d_ln_s = (f(a, s * e.exp()) - f(a, s * (-e).exp())) / (2.0 * e);
        assert!((g[0] - d_ln_a).abs() < 1e-8, "{} vs {d_ln_a}", g[0]);
        assert!((g[3] - d_ln_s).abs() < 1e-8, "{} vs {d_ln_s}", g[3]);
    }

    #[test]
    fn the_adjoint_gradient_matches_differences_on_a_tiny_block() {
        let setup = Setup { dims: [4, 4, 3], spacing_mm: 0.5, eta: 1.3, observation: Observation::BackLit };
        let patterns = Pattern::grid_all(2, setup.face_size_mm(), [1.0, 0.8, 0.6]);
        let cells = 3 * 3 * 2;
        let images = vec![vec![[0.01, 0.02, 0.03]; 16]; 4];
        let mut model = Acquisition::new(setup, &patterns, images, None).unwrap();
        model.set_solve_settings(crate::inverse::SolveSettings { tolerance: 1e-13, max_iterations: 1000 }).unwrap();
        model.set_lambda(1e-3).unwrap();
        let x: Vec<f64> = (0..6 * cells)
            .map(|i| if i % 6 < 3 { (0.05f64 + 0.01 * (i % 7) as f64).ln() } else { (1.0f64 + 0.1 * (i % 5) as f64).ln() })
            .collect();
        let all: Vec<usize> = (0..x.len()).collect();
        for c in check_gradient(&mut model, &x, &all, 1e-3).unwrap() {
            assert!(c.relative_error(1e-12) < 1e-6, "{c:?}");
        }
    }
}
