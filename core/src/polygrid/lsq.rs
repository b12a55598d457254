//! The paper's least-squares Laplacian weights (Wang et al. 2008, Appendix B) for one node, and
//! what they tell about the node: the conditioning of the fit, negative weights, and where
//! the node's links cannot carry the fit at all.
//!
//! Appendix B expands f to second order from the node x₀ to its six lattice neighbours,
//! drops the cross terms and solves the 6 × 6 system W·[f_x, f_xx, f_y, f_yy, f_z, f_zz]ᵀ =
//! [f(x_j) − f(x₀)]_j, W's row j = [Δx_j, Δx_j²/2, Δy_j, Δy_j²/2, Δz_j, Δz_j²/2] in a local
//! frame aligned with the grid; the Laplacian's weights are w_j = (W⁻¹)_{2j} + (W⁻¹)_{4j} +
//! (W⁻¹)_{6j}, so that ∇²f(x₀) ≈ Σ_j w_j (f(x_j) − f(x₀)). Equivalently, w is the solution of
//! Wᵀw = e, e = (0, 1, 0, 1, 0, 1): the stencil is exact on the six monomials x, x²/2, … of
//! the local frame. That form also serves nodes with more or fewer than six links (a
//! concave-edge node of a pillowed grid has seven, a convex-edge one five): w is its
//! minimum-norm least-squares solution (the pseudo-inverse), and the residual ‖Wᵀw − e‖
//! says how far the node is from being consistent (0 for six or more independent links).
//!
//! With cross terms dropped the stencil is consistent only where the links follow the frame's
//! axes; on skewed cells (a cubed sphere's corners) it carries an O(1) truncation error and
//! its weights can turn negative (design note P4). Those are reported, not hidden.

use glam::{DMat3, DVec3};
use nalgebra::{Matrix3, SMatrix};

/// A node's App. B weights are not used when the scaled fit's condition number exceeds this
/// (design note P4: such weights are noise); the paper's system puts P1's in their place.
pub const MAX_CONDITION: f64 = 1e8;

/// One node's Laplacian weights ([`laplacian_weights`]).
#[derive(Debug, Clone, PartialEq)]
pub struct NodeWeights {
    /// w_j per link, in the links' order, mm⁻².
    pub weights: Vec<f64>,
    /// The condition number σ_max/σ_min of the fitted system with Δ scaled by the mean link
    /// length (so it has no units): about 3 for a regular node, ∞ for links that leave a
    /// monomial unseen.
    pub condition: f64,
    /// ‖Wᵀw − e‖/‖e‖: 0 where the links determine the Laplacian of the six monomials, > 0
    /// where fewer than six links cannot (the stencil then is not consistent there).
    pub defect: f64,
}

/// The rotation nearest to `axes` (polar decomposition A = R·S, R = U Vᵀ of A's SVD): the
/// local frame "aligned with the grid" of App. B, the columns of `axes` being the node's
/// lattice directions (x₊ − x₋ per axis). Symmetric in the three axes, unlike
/// Gram–Schmidt. `None` when `axes` is singular or turned (det ≤ 0: the links are folded).
#[must_use]
pub fn grid_frame(axes: DMat3) -> Option<DMat3> {
    if !(axes.determinant() > 0.0) {
        return None;
    }
    let c = axes.to_cols_array();
    let m = Matrix3::from_column_slice(&c);
    let svd = m.svd(true, true);
    let r = svd.u? * svd.v_t?;
    Some(DMat3::from_cols_array(&std::array::from_fn(|k| r[(k % 3, k / 3)])))
}

/// App. B's weights for links `deltas` = x_j − x₀ (mm) given in the local frame (see the
/// module documentation): w with Wᵀw = e, by the pseudo-inverse of W after scaling Δ by the
/// mean link length s (w then scales by 1/s²).
///
/// With fewer than six links (a pillowed polycube's convex edge has five, a corner four; the
/// paper deletes those nodes, §5.1, and leaves the rule unspecified, design note P6) the six
/// monomials are determined only for symmetric links; otherwise `defect` > 0 and the weights
/// are the minimum-norm fit, no Laplacian. Six links skewed far from the frame's axes can give
/// weights summing below zero (the dropped cross terms dominate, P4).
/// [`NodeWeights::is_laplacian`] tells both apart from a usable row.
///
/// # Panics
/// Never for finite input; `deltas` must not be empty.
#[must_use]
pub fn laplacian_weights(deltas: &[DVec3]) -> NodeWeights {
    const E: [f64; 6] = [0.0, 1.0, 0.0, 1.0, 0.0, 1.0];
    let k = deltas.len();
    assert!(k > 0, "a stencil needs links");
    let s = deltas.iter().map(|d| d.length()).sum::<f64>() / k as f64;
    let scaled: Vec<DVec3> = deltas.iter().map(|d| *d / s).collect();
    // Wᵀ (6 × k) for the scaled links, in the paper's monomials.
    let wt = nalgebra::DMatrix::<f64>::from_fn(6, k, |r, j| {
        let x = scaled[j][r / 2];
        if r % 2 == 0 {
            x
        } else {
            x * x / 2.0
        }
    });
    let e = nalgebra::DVector::from_column_slice(&E);
    let svd = wt.clone().svd(true, true);
    let sv = &svd.singular_values;
    let (largest, smallest) = (sv.max(), sv.min());
    let tiny = largest * 1e-13;
    let condition = if smallest > tiny { largest / smallest } else { f64::INFINITY };
    let w = svd.solve(&e, tiny).expect("the SVD was computed with U and Vᵀ");
    let defect = (&wt * &w - &e).norm() / e.norm();
    NodeWeights { weights: w.iter().map(|x| x / (s * s)).collect(), condition, defect }
}

impl NodeWeights {
    /// Whether the weights make a Laplacian row: exact on the six monomials and summing above
    /// zero (a positive diagonal).
    #[must_use]
    pub fn is_laplacian(&self) -> bool {
        self.defect <= CONSISTENT && self.weights.iter().sum::<f64>() > 0.0
    }
}

/// A fit whose defect is below this is exact on the paper's six monomials.
pub const CONSISTENT: f64 = 1e-9;

/// A 6 × 6 App. B matrix W for six links (rows [Δx, Δx²/2, …]), for tests and diagnostics.
#[must_use]
pub fn app_b_matrix(deltas: &[DVec3; 6]) -> SMatrix<f64, 6, 6> {
    SMatrix::from_fn(|j, c| {
        let x = deltas[j][c / 2];
        if c % 2 == 0 {
            x
        } else {
            x * x / 2.0
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_regular_node_gets_one_over_h_squared() {
        let h = 0.3;
        let links = [DVec3::X, -DVec3::X, DVec3::Y, -DVec3::Y, DVec3::Z, -DVec3::Z].map(|d| d * h);
        let w = laplacian_weights(&links);
        for x in &w.weights {
            assert!((x - 1.0 / (h * h)).abs() < 1e-9 / (h * h), "{w:?}");
        }
        assert!(w.defect < 1e-12 && w.condition < 2.0, "{w:?}");
    }

    #[test]
    fn six_links_reproduce_the_papers_inverse_rows() {
        // Uneven, slightly skewed links: w_j = (W⁻¹)_{2j} + (W⁻¹)_{4j} + (W⁻¹)_{6j} (1-based).
        let links = [
            DVec3::new(0.9, 0.05, -0.02),
            DVec3::new(-0.1, 0.01, 0.03),
            DVec3::new(0.04, 1.2, 0.0),
            DVec3::new(-0.02, -0.8, 0.05),
            DVec3::new(0.03, -0.04, 1.0),
            DVec3::new(0.0, 0.02, -1.1),
        ];
        let inverse = app_b_matrix(&links).try_inverse().unwrap();
        let w = laplacian_weights(&links);
        for j in 0..6 {
            let paper = inverse[(1, j)] + inverse[(3, j)] + inverse[(5, j)];
            assert!((w.weights[j] - paper).abs() < 1e-9 * paper.abs().max(1.0), "{j}: {} vs {paper}", w.weights[j]);
        }
        assert!(w.defect < 1e-12);
    }

    #[test]
    fn the_weights_are_exact_on_quadratics_without_cross_terms_and_not_with_them() {
        let links = [
            DVec3::new(1.0, 0.1, 0.0),
            DVec3::new(-0.7, 0.0, 0.1),
            DVec3::new(0.1, 0.9, 0.0),
            DVec3::new(0.0, -1.1, -0.1),
            DVec3::new(0.0, 0.1, 1.0),
            DVec3::new(-0.1, 0.0, -0.6),
        ];
        let w = laplacian_weights(&links).weights;
        let apply = |f: &dyn Fn(DVec3) -> f64| links.iter().zip(&w).map(|(d, w)| w * (f(*d) - f(DVec3::ZERO))).sum::<f64>();
        // f = 2x + x² − y²/2 + 3z²: ∇²f = 2 − 1 + 6.
        let lap = apply(&|p| 2.0 * p.x + p.x * p.x - 0.5 * p.y * p.y + 3.0 * p.z * p.z);
        assert!((lap - 7.0).abs() < 1e-9, "{lap}");
        // f = xy has ∇²f = 0, but the skewed links see it (the cross terms dropped, P4).
        let lap = apply(&|p| 10.0 * p.x * p.y);
        assert!(lap.abs() > 0.05, "{lap}");
    }

    #[test]
    fn fewer_links_report_a_defect_unless_symmetric() {
        // A convex edge of a pillowed grid: −x, −y, ±z and one link out along (x + y)/√2.
        let out = DVec3::new(1.0, 1.0, 0.0).normalize() * 0.5;
        let links = [-DVec3::X, -DVec3::Y, DVec3::Z, -DVec3::Z, out];
        let w = laplacian_weights(&links);
        assert!(w.is_laplacian(), "symmetric: the Laplacian is determined ({w:?})");
        let lap: f64 = links.iter().zip(&w.weights).map(|(d, w)| w * d.length_squared()).sum();
        assert!((lap - 6.0).abs() < 1e-9, "exact on x² + y² + z²: {lap}");
        // Tilt the outer link: the six monomials are no longer determined.
        let mut tilted = links;
        tilted[4] = DVec3::new(1.0, 0.3, 0.2).normalize() * 0.5;
        let w = laplacian_weights(&tilted);
        assert!(w.defect > 1e-3 && !w.is_laplacian(), "{w:?}");
    }

    #[test]
    fn coplanar_links_are_infinitely_ill_conditioned() {
        let links = [DVec3::X, -DVec3::X, DVec3::Y, -DVec3::Y, DVec3::new(1.0, 1.0, 0.0), DVec3::new(-1.0, 1.0, 0.0)];
        assert!(laplacian_weights(&links).condition > MAX_CONDITION);
    }

    #[test]
    fn the_frame_is_the_nearest_rotation() {
        let r = DMat3::from_rotation_z(0.3) * DMat3::from_rotation_x(-0.2);
        let stretched = r * DMat3::from_diagonal(DVec3::new(2.0, 0.5, 1.0));
        let f = grid_frame(stretched).unwrap();
        assert!((f - r).to_cols_array().iter().all(|x| x.abs() < 1e-12), "{f:?}");
        assert!(grid_frame(DMat3::from_diagonal(DVec3::new(1.0, 1.0, -1.0))).is_none());
    }
}
