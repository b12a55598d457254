//! The consistent P1 Galerkin discretisation: the reference the TransCut system is checked
//! against (the "FEM of Arbree et al." TransCut §3.2.4 compares with, without its numerical
//! quadrature, which P1 elements do not need).
//!
//! # Weak form
//!
//! Multiply ∇·(κ∇φ) − μφ = 0 by a hat function β_i and integrate by parts:
//! −∫ κ∇φ·∇β_i dV + ∫_∂Ω κ (∇φ·n) β_i dS − ∫ μ φ β_i dV = 0. The boundary condition
//! φ + 2Aκ(∇φ·n) = Q, Q = 4q/(1 − Fdr), gives κ(∇φ·n) = (Q − φ)/(2A), so
//!
//! ∫ κ∇φ·∇β_i dV + ∫ μ φ β_i dV + (1/(2A)) ∫_∂Ω φ β_i dS = (1/(2A)) ∫_∂Ω Q β_i dS.
//!
//! With φ = Σ φ_j β_j and q interpolated linearly on the surface, and **scaled by 4** like TransCut
//! eqs. 12–14 (which multiply the vertex equation by −V_i = −4|Υ|):
//!
//! - M_ij = 4 (K_ij + C_ij + B_ij/(2A)), b_i = 4 Σ_j B_ij Q_j / (2A);
//! - stiffness K^t_ij = κ_t V_t ∇β_i·∇β_j;
//! - consistent mass C^t_ij = μ_t V_t (1 + δ_ij)/20 (V/10 on the diagonal, V/20 off it);
//! - consistent boundary mass B^f_ij = area_f (1 + δ_ij)/12 (area/6, area/12).
//!
//! # Relation to TransCut
//!
//! TransCut §3.3 shows that its edge weight is the stiffness entry, w_ijt = −(1/6)κ_t|kl| cot θ_kl
//! = κ_t V_t ∇β_i·∇β_j = K^t_ij, and K_ii = −Σ_j K_ij. Lumping the two mass matrices to their
//! row sums, Σ_j C^t_ij = μ_t V_t/4 and Σ_j B^f_ij = area_f/3, turns 4·(this system) into
//! eqs. 12–14 exactly: 4 Σ_t μ_t V_t/4 = Σ_t V_t μ_t, 4 (S_i/3)/(2A) = 2S_i/(3A), and
//! 4 (S_i/3) Q_i/(2A) = 8 S_i q_i/(3A(1 − Fdr)). Mass lumping perturbs the solution by O(h²),
//! the order of the P1 error itself, so both converge to the same φ at second order; for a
//! constant q the two right-hand sides are identical.

use super::structure::{fill_rows, hat_gradients, Coefficients, Structure, INTERIOR, OTHERS};
use crate::optics::BoundaryTerms;

/// Fills 4(K + C + B/(2A)) row by row (each row sums its tets, then its boundary triangles, in
/// increasing order, so the matrix is bit-for-bit symmetric).
pub(crate) fn fill_consistent(s: &Structure, c: &Coefficients, terms: &BoundaryTerms, values: &mut [[f64; 3]]) {
    fill_rows(values, s.pattern.row_ptr(), |i, row| consistent_row(s, c, terms, i, row));
}

/// Row `i` of 4(K + C + B/(2A)) (see [`fill_consistent`]).
pub(crate) fn consistent_row(s: &Structure, c: &Coefficients, terms: &BoundaryTerms, i: usize, row: &mut [[f64; 3]]) {
    let row_ptr = s.pattern.row_ptr();
    let diag = s.pattern.diagonal_positions();
    row.fill([0.0; 3]);
    let d = diag[i] - row_ptr[i];
    for inc in s.tets_of(i) {
        let t = inc.tet as usize;
        let m = s.materials[t] as usize;
        let (kappa, mu) = (c.kappa[m], c.mu[m]);
        let tet = s.tets[t];
        let g = hat_gradients(tet.map(|v| s.positions_mm[v as usize]));
        let v = s.volume[t];
        let a = inc.local as usize;
        for (k, &b) in OTHERS[a].iter().enumerate() {
            let stiffness = v * g[a].dot(g[b]);
            let x = &mut row[inc.slots[k] as usize];
            for ch in 0..3 {
                x[ch] += 4.0 * (kappa[ch] * stiffness + mu[ch] * v / 20.0);
            }
        }
        let stiffness = v * g[a].dot(g[a]);
        for ch in 0..3 {
            row[d][ch] += 4.0 * (kappa[ch] * stiffness + mu[ch] * v / 10.0);
        }
    }
    let b = s.boundary_index[i];
    if b != INTERIOR {
        for f in s.faces_of(b as usize) {
            let area = s.face_area[f.face as usize];
            // 4 · area (1 + δ_ij)/12 / (2A).
            let (on, off) = (area / (3.0 * terms.a), area / (6.0 * terms.a));
            for x in &mut row[d] {
                *x += on;
            }
            for &slot in &f.slots {
                for x in &mut row[slot as usize] {
                    *x += off;
                }
            }
        }
    }
}

/// The consistent boundary load b_i = 4 Σ_j B_ij Q_j/(2A) = (2/A) Σ_{f ∋ i} area_f (Q_i/6 +
/// (Q_j + Q_k)/12), Q = 4q/(1 − Fdr), for q given per boundary vertex.
pub(crate) fn rhs_consistent(s: &Structure, terms: &BoundaryTerms, q: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let mut out = vec![[0.0; 3]; s.n()];
    let big_q = |v: u32| q[s.boundary_index[v as usize] as usize].map(|x| terms.fluence_source(x));
    for (k, &v) in s.boundary.ids.iter().enumerate() {
        let qi = q[k].map(|x| terms.fluence_source(x));
        let mut b = [0.0; 3];
        for f in s.faces_of(k) {
            let area = s.face_area[f.face as usize];
            let (qj, qk) = (big_q(f.others[0]), big_q(f.others[1]));
            for ch in 0..3 {
                b[ch] += 2.0 / terms.a * area * (qi[ch] / 6.0 + (qj[ch] + qk[ch]) / 12.0);
            }
        }
        out[v as usize] = b;
    }
    out
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // per-channel loops read best indexed
mod tests {
    use super::super::{assemble, assemble_consistent};
    use super::*;
    use crate::mesh::TetMesh;
    use crate::optics::Medium;
    use glam::DVec3;

    fn two_tets() -> TetMesh {
        let p = vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.1, 0.0),
            DVec3::new(0.2, 1.1, 0.1),
            DVec3::new(0.3, 0.2, 0.9),
            DVec3::new(0.9, 0.8, 0.7),
        ];
        TetMesh::new(p, vec![[0, 1, 2, 3], [1, 2, 3, 4]], Vec::new()).unwrap()
    }

    #[test]
    fn lumping_the_consistent_masses_gives_transcut() {
        let mesh = two_tets();
        let m = Medium::preset("skin2").unwrap();
        let fem = assemble_consistent(&mesh, &[m], 3.0).unwrap();
        let tc = assemble(&mesh, &[m], 3.0).unwrap();
        let n = mesh.vertex_count();
        let s = fem.structure();
        let a = fem.boundary_terms().a;
        for i in 0..n {
            // Row-lump the mass parts of the FEM row: move μV/20 and area/(6A) off-diagonals
            // to the diagonal.
            let mut lumped = vec![[0.0; 3]; n];
            for j in 0..n {
                lumped[j] = fem.matrix().get(i, j).unwrap_or([0.0; 3]);
            }
            for inc in s.tets_of(i) {
                let t = inc.tet as usize;
                let v = s.volume[t];
                for &b in &OTHERS[inc.local as usize] {
                    let j = s.tets[t][b] as usize;
                    for c in 0..3 {
                        let x = 4.0 * m.sigma_a[c] * v / 20.0;
                        lumped[j][c] -= x;
                        lumped[i][c] += x;
                    }
                }
            }
            if s.boundary_index[i] != INTERIOR {
                for f in s.faces_of(s.boundary_index[i] as usize) {
                    let x = s.face_area[f.face as usize] / (6.0 * a);
                    for &j in &f.others {
                        for c in 0..3 {
                            lumped[j as usize][c] -= x;
                            lumped[i][c] += x;
                        }
                    }
                }
            }
            for j in 0..n {
                let want = tc.matrix().get(i, j).unwrap_or([0.0; 3]);
                for c in 0..3 {
                    assert!((lumped[j][c] - want[c]).abs() < 1e-12 * tc.matrix().get(i, i).unwrap()[c], "({i}, {j})");
                }
            }
        }
    }

    #[test]
    fn consistent_load_equals_lumped_load_for_constant_q_and_integrates_linear_q() {
        let mesh = two_tets();
        let m = Medium::preset("marble").unwrap();
        let mut fem = assemble_consistent(&mesh, &[m], 1.0).unwrap();
        let mut tc = assemble(&mesh, &[m], 1.0).unwrap();
        let nb = fem.boundary().len();
        let q = vec![[1.0, 2.0, 3.0]; nb];
        fem.set_source(&q).unwrap();
        tc.set_source(&q).unwrap();
        for (x, y) in fem.rhs().iter().zip(tc.rhs()) {
            for c in 0..3 {
                assert!((x[c] - y[c]).abs() < 1e-13 * (1.0 + y[c]));
            }
        }
        // Σ_i b_i = 4/(2A) ∫ Q dS exactly for a linear q: here q = x, ∫ over the surface.
        let q: Vec<[f64; 3]> = fem.boundary().ids.iter().map(|&v| [mesh.positions()[v as usize].x; 3]).collect();
        fem.set_source(&q).unwrap();
        let t = fem.boundary_terms();
        let mut integral = 0.0;
        for (f, face) in mesh.boundary_faces().iter().enumerate() {
            let mean: f64 = face.vertices.iter().map(|&v| mesh.positions()[v as usize].x).sum::<f64>() / 3.0;
            integral += mesh.boundary_area(f) * mean;
        }
        let total: f64 = fem.rhs().iter().map(|b| b[0]).sum();
        let expect = 4.0 / (2.0 * t.a) * t.fluence_source(integral);
        assert!((total - expect).abs() < 1e-13 * expect);
    }

    #[test]
    fn consistent_matrix_is_symmetric_and_its_stiffness_rows_sum_to_zero() {
        let mesh = two_tets();
        let m = Medium::new([0.0; 3], [1.0; 3], 1.0, 0.0).unwrap(); // no absorption
        let fem = assemble_consistent(&mesh, &[m], 1.0).unwrap();
        assert!(fem.matrix().is_symmetric(0.0));
        // With μ = 0 the row sums are the boundary mass row sums 4 (S_i/3)/(2A).
        let s = fem.structure();
        for i in 0..mesh.vertex_count() {
            let p = fem.pattern();
            let sum: f64 = (p.row_ptr()[i]..p.row_ptr()[i + 1]).map(|k| fem.matrix().values()[k][0]).sum();
            let b = s.boundary_index[i] as usize;
            let expect = 4.0 * s.boundary.area_mm2[b] / 3.0 / (2.0 * fem.boundary_terms().a);
            assert!((sum - expect).abs() < 1e-12, "{sum} {expect}");
        }
    }
}
