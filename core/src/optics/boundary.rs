//! The boundary terms of the TransCut diffusion solver (ARCHITECTURE.md, "The equations"),
//! per channel: the Robin boundary condition, its finite-element matrix and right-hand-side
//! contributions, and the exitant radiance from the fluence.
//!
//! Boundary condition (n outward): φ + 2Aκ (∇φ·n) = Q, Q = 4q/(1 − Fdr), A = (1 + Fdr)/(1 − Fdr).
//! Exitant radiance: Lo(ωo) = Ft(ωo)/(4π) · [(1 + 1/A) φ − 4q/(1 + Fdr)], Ft = T(η, θo)/η².

use super::error::OpticsError;
use super::fresnel::{a_coefficient, fdr, ft_out};
use super::medium::check_eta;

/// The η-dependent constants of the boundary, computed once per medium.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoundaryTerms {
    /// Refractive index of the medium relative to air.
    pub eta: f64,
    /// Diffuse Fresnel reflectance Fdr (Egan–Hilgeman fit, [`fdr`]).
    pub fdr: f64,
    /// A = (1 + Fdr)/(1 − Fdr) ([`a_coefficient`]).
    pub a: f64,
    /// Ft along the normal, T(η, 0)/η² = (1 − ((η − 1)/(η + 1))²)/η² ([`ft_out`] at cos θo = 1).
    pub ft_normal: f64,
}

impl BoundaryTerms {
    /// The boundary constants of a medium of index `eta`.
    ///
    /// # Errors
    /// [`OpticsError::InvalidScalar`] naming `eta` unless it is in [1, 4).
    pub fn new(eta: f64) -> Result<BoundaryTerms, OpticsError> {
        check_eta(eta)?;
        Ok(BoundaryTerms { eta, fdr: fdr(eta), a: a_coefficient(eta), ft_normal: ft_out(eta, 1.0) })
    }

    /// Right-hand side of the Robin condition, Q = 4q/(1 − Fdr), for the transmitted source
    /// `q` (TransCut boundary condition, ARCHITECTURE.md).
    #[must_use]
    pub fn fluence_source(&self, q: f64) -> f64 {
        4.0 * q / (1.0 - self.fdr)
    }

    /// The extrapolation length 2Aκ (mm) of the Robin condition for diffusion coefficient
    /// `kappa` (mm): φ + 2Aκ ∂φ/∂n = Q.
    #[must_use]
    pub fn extrapolation_length(&self, kappa: f64) -> f64 {
        2.0 * self.a * kappa
    }

    /// Boundary contribution to the diagonal of the system matrix at a vertex whose boundary
    /// triangles have total area `area` (mm²): 2S_i/(3A) (ARCHITECTURE.md, "Matrix").
    #[must_use]
    pub fn matrix_diagonal(&self, area: f64) -> f64 {
        2.0 * area / (3.0 * self.a)
    }

    /// Right-hand side at a boundary vertex with boundary area `area` (mm²) and transmitted
    /// source `q`: b_i = 8 S_i q_i / (3A(1 − Fdr)) (ARCHITECTURE.md, "Matrix").
    #[must_use]
    pub fn rhs(&self, area: f64, q: f64) -> f64 {
        8.0 * area * q / (3.0 * self.a * (1.0 - self.fdr))
    }

    /// Exitant multiple-scattering radiance Lo(x, ωo) = Ft(ωo)/(4π) · [(1 + 1/A) φ −
    /// 4q/(1 + Fdr)] (TransCut eq. 3 as restated in ARCHITECTURE.md), from the fluence `phi`
    /// and transmitted source `q` at a surface point, for a view direction at cos θo = `cos_o`
    /// to the outward normal.
    #[must_use]
    pub fn radiance_from_fluence(&self, phi: f64, q: f64, cos_o: f64) -> f64 {
        self.radiance_with_ft(phi, q, ft_out(self.eta, cos_o))
    }

    /// [`BoundaryTerms::radiance_from_fluence`] along the normal (cos θo = 1): the per-vertex
    /// value a bake returns (ARCHITECTURE.md, "What a bake returns").
    #[must_use]
    pub fn radiance_normal(&self, phi: f64, q: f64) -> f64 {
        self.radiance_with_ft(phi, q, self.ft_normal)
    }

    /// Ft/(4π) · [(1 + 1/A) φ − 4q/(1 + Fdr)] for a given Ft.
    fn radiance_with_ft(&self, phi: f64, q: f64, ft: f64) -> f64 {
        ft / (4.0 * std::f64::consts::PI) * ((1.0 + 1.0 / self.a) * phi - 4.0 * q / (1.0 + self.fdr))
    }
}

/// Exitant radiance Lo = Ft(η, θo)/(4π) · [(1 + 1/A) φ − 4q/(1 + Fdr)] (ARCHITECTURE.md, "The
/// equations") from fluence `phi` and transmitted source `q` at a surface point of a medium of
/// index `eta`, viewed at cos θo = `cos_o` from the outward normal. For many evaluations at one
/// η, build a [`BoundaryTerms`] once instead.
#[must_use]
pub fn radiance_from_fluence(phi: f64, q: f64, eta: f64, cos_o: f64) -> f64 {
    BoundaryTerms { eta, fdr: fdr(eta), a: a_coefficient(eta), ft_normal: ft_out(eta, 1.0) }.radiance_from_fluence(phi, q, cos_o)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constants_at_1_3() {
        let b = BoundaryTerms::new(1.3).unwrap();
        assert!((b.fdr - 0.444_762_840_236_686).abs() < 1e-12);
        assert!((b.a - (1.0 + b.fdr) / (1.0 - b.fdr)).abs() < 1e-15);
        let t0 = 1.0 - (0.3f64 / 2.3).powi(2);
        assert!((b.ft_normal - t0 / 1.69).abs() < 1e-15);
        assert!(matches!(BoundaryTerms::new(0.5), Err(OpticsError::InvalidScalar { field: "eta", .. })));
    }

    #[test]
    fn radiance_formula_and_free_function_agree() {
        let b = BoundaryTerms::new(1.3).unwrap();
        let (phi, q) = (20.0, 2.9);
        let expect = b.ft_normal / (4.0 * std::f64::consts::PI) * ((1.0 + 1.0 / b.a) * phi - 4.0 * q / (1.0 + b.fdr));
        assert!((b.radiance_normal(phi, q) - expect).abs() < 1e-15);
        assert!((b.radiance_from_fluence(phi, q, 1.0) - expect).abs() < 1e-15);
        assert!((radiance_from_fluence(phi, q, 1.3, 1.0) - expect).abs() < 1e-15);
        // Other view directions scale by Ft(ωo)/Ft(n).
        let c = 0.4;
        let ratio = ft_out(1.3, c) / ft_out(1.3, 1.0);
        assert!((b.radiance_from_fluence(phi, q, c) - ratio * expect).abs() < 1e-14);
    }

    #[test]
    fn matrix_terms_are_the_scaled_weak_form() {
        // Weak form of φ + 2Aκ∂nφ = Q with lumped boundary mass S_i/3, times 4 (the matrix scale
        // of ARCHITECTURE.md): 4·(S_i/3)/(2A) on the diagonal, 4·(S_i/3)·Q/(2A) on the right.
        let b = BoundaryTerms::new(1.5).unwrap();
        let (s, q) = (0.37, 1.9);
        assert!((b.matrix_diagonal(s) - 4.0 * (s / 3.0) / (2.0 * b.a)).abs() < 1e-15);
        let weak = 4.0 * (s / 3.0) * b.fluence_source(q) / (2.0 * b.a);
        assert!((b.rhs(s, q) - weak).abs() < 1e-14);
        assert!((b.extrapolation_length(0.1) - 0.2 * b.a).abs() < 1e-15);
    }
}
