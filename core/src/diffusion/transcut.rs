//! TransCut's discretisation (TransCut §3.2, eqs. 10–14, as restated in ARCHITECTURE.md "The
//! equations"): the row kernel the [`super::DiffusionSystem`] is filled with.
//!
//! Per tet t (κ_t, μ_t constant, per channel, lengths in mm):
//!
//! - κ_t = 1/(3(μ_t + σ′s_t)), μ_t = σa_t ([`crate::optics::Medium::diffusion_coefficient`]);
//! - eq. 10: w_ij = −Σ_{t ∋ ij} (1/6) κ_t |kl| cot θ_kl (k, l the other two vertices of t,
//!   θ_kl the dihedral angle at edge kl);
//! - eq. 14: M_ij = 4 w_ij;
//! - eq. 13: M_ii = −4 Σ_j w_ij + Σ_{t ∋ i} V_t μ_t (+ 2 S_i/(3A) on the boundary), S_i the
//!   area of the boundary triangles around i;
//! - eq. 12: b_i = 8 S_i q_i / (3A(1 − Fdr)) on the boundary, 0 inside.
//!
//! This is 4 × the P1 finite-element system of the weak form (see [`super::fem`]) with the volume
//! mass and the boundary mass lumped to the diagonal: the edge weight is the P1 stiffness
//! entry, w_ijt = κ_t V_t ∇β_i·∇β_j (TransCut §3.3), the lumped mass is ∫ μ β_i = Σ V_t μ_t / 4,
//! and the lumped boundary mass is ∫ β_i dS = S_i/3.

use super::structure::{fill_rows, Coefficients, Structure, EDGE_INDEX, INTERIOR, OTHERS};
use crate::optics::BoundaryTerms;

/// TransCut eqs. 10, 13 and 14, row by row ([`transcut_row`] for every row).
pub(crate) fn fill_transcut(s: &Structure, c: &Coefficients, terms: &BoundaryTerms, values: &mut [[f64; 3]]) {
    fill_rows(values, s.pattern.row_ptr(), |i, row| transcut_row(s, c, terms, i, row));
}

/// Row `i` of TransCut eqs. 10, 13 and 14: for every tet t around vertex i and every other
/// vertex j of t, the tet's part of the edge weight w_ijt = −(1/6)κ_t|kl| cot θ_kl (eq. 10) goes
/// to M_ij as 4w_ijt (eq. 14) and to M_ii as −4w_ijt; V_t μ_t goes to M_ii (eq. 13, lumped
/// absorption), and on boundary vertices 2S_i/(3A) ([`BoundaryTerms::matrix_diagonal`]). The
/// tets are summed in increasing order, so a row refilled alone ([`DiffusionSystem::update_media_rows`])
/// is bit-identical to the same row of a full fill.
pub(crate) fn transcut_row(s: &Structure, c: &Coefficients, terms: &BoundaryTerms, i: usize, row: &mut [[f64; 3]]) {
    scaled_row(s, c, terms, i, row, |_, _, _| [1.0; 3]);
}

/// Row `i` of TransCut's scheme with each tet's part of each edge weight, w_ijt, scaled per
/// channel by `factor(t, a, b)` (tet `t`, the local indices `a` of vertex i and `b` of vertex j):
/// 1 for TransCut itself (exactly: ×1 changes no bit), the fitting factor for
/// [`super::fitted`].
pub(crate) fn scaled_row(
    s: &Structure,
    c: &Coefficients,
    terms: &BoundaryTerms,
    i: usize,
    row: &mut [[f64; 3]],
    factor: impl Fn(usize, usize, usize) -> [f64; 3],
) {
    let row_ptr = s.pattern.row_ptr();
    let diag = s.pattern.diagonal_positions();
    row.fill([0.0; 3]);
    let mut d = [0.0; 3];
    for inc in s.tets_of(i) {
        let t = inc.tet as usize;
        let m = s.materials[t] as usize;
        let (kappa, mu) = (c.kappa[m], c.mu[m]);
        let a = inc.local as usize;
        for (k, &b) in OTHERS[a].iter().enumerate() {
            let coef = s.edge_coef[t][EDGE_INDEX[a][b]];
            let f = factor(t, a, b);
            let v = &mut row[inc.slots[k] as usize];
            for ch in 0..3 {
                let w4 = -4.0 * kappa[ch] * coef * f[ch];
                v[ch] += w4;
                d[ch] -= w4;
            }
        }
        for ch in 0..3 {
            d[ch] += s.volume[t] * mu[ch];
        }
    }
    let b = s.boundary_index[i];
    if b != INTERIOR {
        let x = terms.matrix_diagonal(s.boundary.area_mm2[b as usize]);
        for dc in &mut d {
            *dc += x;
        }
    }
    row[diag[i] - row_ptr[i]] = d;
}

/// TransCut eq. 12: b_i = 8 S_i q_i / (3A(1 − Fdr)) on boundary vertices
/// ([`BoundaryTerms::rhs`]), 0 inside.
pub(crate) fn rhs_transcut(s: &Structure, terms: &BoundaryTerms, q: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let mut b = vec![[0.0; 3]; s.n()];
    for (k, &v) in s.boundary.ids.iter().enumerate() {
        let area = s.boundary.area_mm2[k];
        b[v as usize] = q[k].map(|qc| terms.rhs(area, qc));
    }
    b
}
