//! An exponentially fitted variant of TransCut's discretisation: TransCut's rows with each
//! edge's stiffness part scaled by the fitting factor of the boundary layer along that edge, and
//! the boundary rows' absorption taken from the layer's profile.
//!
//! Light in a strongly absorbing channel lives in a layer of thickness 1/σtr under the lit
//! surface; where the spacing is not small against it (σtr h ≳ 1) the piecewise-linear fluence
//! of TransCut's scheme (4 × P1 with lumped mass, [`super::transcut`]) lets too much flux into
//! the layer and the surface fluence comes out low. In 1D, the Il'in–Allen–Southwell fitting
//! scales the element stiffness κ/l by `f(x) = x / sinh x` (x = σtr l, σtr = √(μ/κ)), which with
//! the lumped mass scaled by `2 tanh(x/2)/x` makes the scheme exact for e^(−σtr s).
//!
//! On tets the edges are oblique to the layer, and the full 1D fitting over-corrects: on the
//! R = 10 mm sphere at 200k tets (uniform) it leaves skin1's blue surface fluence 1.8% high on
//! average, its Lo 8.8% off (RMS). Two parts of it carry over, the first alone in
//! [`super::Discretization::ExponentiallyFitted`], both in [`super::Discretization::FittedLayer`]:
//!
//! - **Stiffness.** Each edge's part w_ijt is scaled by f(σtr,t |ij|). An edge's factor depends
//!   on the edge alone, so the matrix stays symmetric, and x → 0 gives TransCut's rows back.
//! - **Boundary rows** (`FittedLayer`). What remains after the stiffness fitting is not a bias but scatter from
//!   vertex to vertex: lumping puts a boundary vertex's whole control volume's absorption at the
//!   surface fluence, the layer's largest, so it over-absorbs in proportion to the control
//!   volume's thickness, which varies across a stuffed surface (on the R = 10 mm sphere at 300k
//!   graded tets, skin1's blue Lo error against V_i/S_i correlates at −0.97). [`layer_mass`]
//!   instead chooses the absorption that makes the boundary row exact for the local layer
//!   ([`super::layer`]: the decaying solution under a surface of the vertex's normal and mean
//!   curvature), so it is first-order consistent on curved surfaces and tends to the lumped
//!   absorption as h → 0. Only the diagonal changes: the matrix stays symmetric, and with the
//!   absorption kept non-negative it is the fitted stiffness plus the Robin term plus a
//!   non-negative diagonal, positive definite wherever the fitted rows are.
//!   Rows keep the zero-sum Laplacian structure, so the energy balance
//!   ([`super::energy_balance`]) holds with the rows' own absorption.
//!
//! Measured (`transcut bench sphere`, R = 10 mm, 300k tets, graded with one cube per size,
//! every preset): the worst channel whose closed form is positive, skin1's blue, 3.75% → 0.84%
//! RMS; every other channel ≤ 0.24%. The layer's absorption is a difference of two fluxes of
//! the row, each O(h²) against it, so it carries the stiffness's own pointwise error at O(1)
//! relative to the lumped absorption; its error falls more slowly than h² on fine meshes
//! (skin1 blue 0.84, 0.66, 0.59, 0.50% at 0.3, 1, 2, 4M graded tets, where the stiffness
//! fitting alone falls from 3.75 to 1.31, 0.70, 0.375%), which is why both stay selectable.

use super::layer;
use super::structure::{fill_rows, Coefficients, Structure, EDGE_INDEX, INTERIOR, OTHERS};
use super::transcut::scaled_row;
use crate::optics::BoundaryTerms;

/// `f(x) = x / sinh x`, the stiffness factor of an edge with x = σtr |ij|: below 1/8 its series
/// 1 − x²/6 + 7x⁴/360 − 31x⁶/15120 + 127x⁸/604800 − 73x¹⁰/3421440 (the next term is below
/// 4·10⁻¹⁷ there), above it 2x e⁻ˣ/(1 − e⁻²ˣ) (one `exp`, where `sinh` costs an `expm1` and more;
/// 1 − e⁻²ˣ ≥ 0.22 loses at most a few ulps), 0 past the largest x whose sinh is finite.
#[must_use]
pub(crate) fn stiffness_factor(x: f64) -> f64 {
    if x < 0.125 {
        let y = x * x;
        1.0 + y * (-1.0 / 6.0 + y * (7.0 / 360.0 + y * (-31.0 / 15120.0 + y * (127.0 / 604_800.0 - y * 73.0 / 3_421_440.0))))
    } else if x > 700.0 {
        0.0
    } else {
        let e = (-x).exp();
        2.0 * x * e / (1.0 - e * e)
    }
}

/// The fitted rows ([`fitted_row`] for every row), with the layer's absorption on boundary rows
/// when `layer` ([`super::Discretization::FittedLayer`]).
pub(crate) fn fill_fitted(s: &Structure, c: &Coefficients, terms: &BoundaryTerms, values: &mut [[f64; 3]], layer: bool) {
    fill_rows(values, s.pattern.row_ptr(), |i, row| fitted_row(s, c, terms, i, row, layer));
}

/// Row `i`: TransCut's row ([`super::transcut::scaled_row`]) with each edge's stiffness part
/// w_ijt scaled by `f(σtr,t |ij|)` (σtr,t = √(μ_t/κ_t) of the tet's medium, per channel), and
/// with `layer`, on a boundary vertex of the smooth surface, the lumped absorption replaced by
/// [`layer_mass`].
pub(crate) fn fitted_row(s: &Structure, c: &Coefficients, terms: &BoundaryTerms, i: usize, row: &mut [[f64; 3]], layer: bool) {
    scaled_row(s, c, terms, i, row, |t, a, b| edge_factor(s, c, t, a, b));
    if !layer {
        return;
    }
    let excess = layer_excess(s, c, i);
    let diag = s.pattern.diagonal_positions()[i] - s.pattern.row_ptr()[i];
    for ch in 0..3 {
        row[diag][ch] += excess[ch];
    }
}

/// What [`layer_mass`] adds to row i's diagonal over TransCut's lumped absorption (0 where it
/// keeps it): the `FittedLayer` rows are the fitted rows with this added to the diagonal. The
/// device assembly adds it to its boundary term.
pub(crate) fn layer_excess(s: &Structure, c: &Coefficients, i: usize) -> [f64; 3] {
    layer_mass(s, c, i).map_or([0.0; 3], |(mass, lumped)| std::array::from_fn(|ch| mass[ch] - lumped[ch]))
}

/// f(σtr,t |ij|) per channel for the edge from local vertex `a` to `b` of tet `t`.
fn edge_factor(s: &Structure, c: &Coefficients, t: usize, a: usize, b: usize) -> [f64; 3] {
    let sigma_tr = c.sigma_tr[s.materials[t] as usize];
    let tet = s.tets[t];
    let l = (s.positions_mm[tet[b] as usize] - s.positions_mm[tet[a] as usize]).length();
    sigma_tr.map(|st| stiffness_factor(st * l))
}

/// The absorption of boundary vertex i's row that makes the row exact for the boundary layer
/// under it, with TransCut's lumped absorption Σ_t V_t μ_t beside it: None inside, and where
/// the surface has no curvature at i (an edge or a corner: [`layer::mean_curvature`]).
///
/// With ψ the layer's profile ([`layer::profile`], per tet's σtr, the vertex's normal and mean
/// curvature) and g its inward flux ([`layer::inward_flux`]), the fitted row applied to ψ gives
/// the exact solution's inward flux 4 ḡκ S_i/3 (M is 4 × the weak form) when the absorption is
/// m_i = 4 ḡκ S_i/3 − Σ_t Σ_j 4 κ_t c_ijt f_ijt (1 − ψ(x_j − x_i)), ḡκ the volume-weighted mean
/// of g κ over the row's tets and c_ijt the cotangent coefficient of TransCut eq. 10; m_i is
/// kept non-negative.
fn layer_mass(s: &Structure, c: &Coefficients, i: usize) -> Option<([f64; 3], [f64; 3])> {
    let b = s.boundary_index[i];
    if b == INTERIOR {
        return None;
    }
    let b = b as usize;
    let curvature = s.curvature[b]?;
    let n = s.boundary.normal[b];
    let here = s.positions_mm[i];
    let (mut flux, mut stiffness, mut lumped, mut volume) = ([0.0; 3], [0.0; 3], [0.0; 3], 0.0);
    for inc in s.tets_of(i) {
        let t = inc.tet as usize;
        let m = s.materials[t] as usize;
        let (kappa, mu, sigma_tr) = (c.kappa[m], c.mu[m], c.sigma_tr[m]);
        let a = inc.local as usize;
        for &o in &OTHERS[a] {
            let coef = s.edge_coef[t][EDGE_INDEX[a][o]];
            let f = edge_factor(s, c, t, a, o);
            let d = s.positions_mm[s.tets[t][o] as usize] - here;
            for ch in 0..3 {
                stiffness[ch] += 4.0 * kappa[ch] * coef * f[ch] * (1.0 - layer::profile(sigma_tr[ch], curvature, n, d));
            }
        }
        let v = s.volume[t];
        volume += v;
        for ch in 0..3 {
            flux[ch] += v * kappa[ch] * layer::inward_flux(sigma_tr[ch], curvature);
            lumped[ch] += v * mu[ch];
        }
    }
    let share = s.boundary.area_mm2[b] / 3.0;
    let mass = std::array::from_fn(|ch| (4.0 * share * flux[ch] / volume - stiffness[ch]).max(0.0));
    Some((mass, lumped))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// f is x / sinh x: 1 at 0, its series below the switch, decreasing, positive.
    #[test]
    fn stiffness_factor_is_x_over_sinh_x() {
        assert_eq!(stiffness_factor(0.0), 1.0);
        for x in [1e-6, 9.9e-5, 1e-4, 0.05, 0.124, 0.125, 0.126, 0.3, 0.5, 1.0, 3.0, 20.0] {
            let exact = if x == 0.0 { 1.0 } else { x / f64::sinh(x) };
            assert!((stiffness_factor(x) / exact - 1.0).abs() < 1e-15, "x {x}");
        }
        // sinh 1 = 1.1752011936438014.
        assert!((stiffness_factor(1.0) - 1.0 / 1.175_201_193_643_801_4).abs() < 1e-15);
        assert!(stiffness_factor(701.0) == 0.0 && stiffness_factor(700.0) > 0.0);
        let xs: Vec<f64> = (0..200).map(|k| f64::from(k) * 0.1).collect();
        assert!(xs.windows(2).all(|w| stiffness_factor(w[1]) < stiffness_factor(w[0])));
    }
}
