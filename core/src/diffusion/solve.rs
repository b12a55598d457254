//! The solved fluence and what is read from it.
//!
//! - [`solve`]: the cold solve of a bake, CG with the SSOR preconditioner on the three channels
//!   at once (M is symmetric positive definite, TransCut §3.2.3), relative residual
//!   ‖b − Mφ‖/‖b‖ ≤ 1e-6 by default; shorthand for a [`Solver`] of [`SolverKind::SsorPcg`];
//! - [`surface_radiance`]: TransCut eq. 3 along the normal, the per-vertex value a bake returns
//!   (ARCHITECTURE.md "What a bake returns"): Lo(x, n) = Ft(n)/(4π) · [(1 + 1/A) φ − 4q/(1 + Fdr)].
//! - [`energy_balance`]: absorbed, exitant and incident power of a solution.

use super::error::DiffusionError;
use super::fitted::layer_excess;
use super::solver::{Solver, SolverKind};
use super::structure::Coefficients;
use super::system::{DiffusionSystem, Discretization};
use crate::sparse::hierarchy::HierarchyOptions;
use crate::sparse::{SolveOptions, SolveStats};

/// A solved fluence.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// The fluence φ at every vertex, per channel.
    pub phi: Vec<[f64; 3]>,
    /// What the solver did.
    pub stats: SolveStats,
}

impl Solution {
    /// The solution of a solve that ended with `stats`, or [`DiffusionError::NotConverged`]
    /// when a channel missed `tolerance`.
    ///
    /// # Errors
    /// [`DiffusionError::NotConverged`] unless `stats.converged`.
    pub(crate) fn converged(phi: Vec<[f64; 3]>, stats: SolveStats, tolerance: f64) -> Result<Self, DiffusionError> {
        if stats.converged {
            Ok(Self { phi, stats })
        } else {
            Err(DiffusionError::NotConverged { iterations: stats.iterations, residual: stats.relative_residual, tolerance })
        }
    }
}

/// Solves M φ = b for the three channels with CG preconditioned by SSOR
/// ([`crate::sparse::Ssor`]) from `warm_start` (one entry per vertex) or from zero: the cold
/// solve of a bake on the CPU. The same as `Solver::new(system, SolverKind::SsorPcg,
/// &HierarchyOptions::default())?.solve(system, warm_start, options)`; keep a [`Solver`] to
/// solve again after the source changed. SSOR's setup (a level-set ordering and the reordered
/// triangles) costs a few Jacobi iterations and CG then needs about a quarter of Jacobi's
/// iterations, so it is the fastest single solve; the multigrid kinds iterate faster still but
/// their setup outweighs that in one solve (`docs/benchmarks.md`).
///
/// # Errors
/// [`DiffusionError::LengthMismatch`] for a warm start of the wrong length;
/// [`DiffusionError::NotConverged`] when a channel misses the tolerance within
/// `options.max_iterations`; [`DiffusionError::Sparse`] for the solver's own errors (a
/// non-finite warm start, a breakdown, cancellation).
pub fn solve(
    system: &DiffusionSystem,
    warm_start: Option<&[[f64; 3]]>,
    options: &SolveOptions<'_>,
) -> Result<Solution, DiffusionError> {
    Solver::new(system, SolverKind::SsorPcg, &HierarchyOptions::default())?.solve(system, warm_start, options)
}

/// The fluence at the boundary vertices, in the order of [`DiffusionSystem::boundary`].
///
/// # Errors
/// [`DiffusionError::LengthMismatch`] unless `phi` has one entry per vertex.
pub fn surface_fluence(system: &DiffusionSystem, phi: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, DiffusionError> {
    check_phi(system, phi)?;
    Ok(system.boundary().ids.iter().map(|&v| phi[v as usize]).collect())
}

/// The exitant radiance along the outward normal at every boundary vertex (in the order of
/// [`DiffusionSystem::boundary`]): TransCut eq. 3 with ωo = n,
/// Lo(x, n) = Ft(n)/(4π) · [(1 + 1/A) φ(x) − 4q(x)/(1 + Fdr)], Ft(n) = T(η, 0)/η²
/// ([`crate::optics::BoundaryTerms::radiance_normal`]), with the system's source q. Other view
/// directions scale by Ft(ωo)/Ft(n).
///
/// # Errors
/// [`DiffusionError::LengthMismatch`] unless `phi` has one entry per vertex;
/// [`DiffusionError::NonFinite`] naming the first boundary vertex with a non-finite φ.
pub fn surface_radiance(system: &DiffusionSystem, phi: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, DiffusionError> {
    check_phi(system, phi)?;
    let terms = system.boundary_terms();
    let q = system.source();
    system
        .boundary()
        .ids
        .iter()
        .enumerate()
        .map(|(k, &v)| {
            let p = phi[v as usize];
            if let Some(channel) = p.iter().position(|x| !x.is_finite()) {
                return Err(DiffusionError::NonFinite { what: "fluence", vertex: v as usize, channel, value: p[channel] });
            }
            Ok([0, 1, 2].map(|c| terms.radiance_normal(p[c], q[k][c])))
        })
        .collect()
}

/// Where the power of a solution goes, per channel (in the units of q × mm²).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct EnergyBalance {
    /// Absorbed in the volume, ∫ μ φ dV = Σ_t μ_t V_t φ̄_t (φ̄_t the mean of φ over the tet's
    /// vertices: the exact integral of the piecewise-linear φ, and the row sums of the lumped
    /// mass of TransCut eq. 13); for [`Discretization::FittedLayer`] with its boundary rows'
    /// absorption in place of the lumped one.
    pub absorbed: [f64; 3],
    /// Leaving through the surface: the exitance ∫ Lo cos θo dωo integrated over the surface.
    /// With ∫ Ft(ωo) cos θo dωo = π(1 − Fdr) and (1 + 1/A) = 2/(1 + Fdr), eq. 3 gives the
    /// exitance (φ − 2q)/(2A), integrated exactly for piecewise-linear φ and q.
    pub exitant: [f64; 3],
    /// Transmitted into the object, ∫ q dS.
    pub incident: [f64; 3],
}

impl EnergyBalance {
    /// (absorbed + exitant) / incident − 1 per channel (0 for a channel without light).
    #[must_use]
    pub fn relative_defect(&self) -> [f64; 3] {
        [0, 1, 2].map(
            |c| {
                if self.incident[c] > 0.0 {
                    (self.absorbed[c] + self.exitant[c]) / self.incident[c] - 1.0
                } else {
                    0.0
                }
            },
        )
    }
}

/// The power balance of a solution φ of `system` (see [`EnergyBalance`]).
///
/// Summing the rows of M φ = b (4× the weak form, [`super::fem`]) with test function 1: the
/// stiffness rows sum to zero, so ∫ μ φ dV + (1/(2A)) ∫ φ dS = (1/(2A)) ∫ Q dS, Q = 4q/(1 − Fdr):
/// the absorbed power equals the net inward flux. Adding the exitance (φ − 2q)/(2A):
/// absorbed + exitant = ∫ (Q − 2q)/(2A) dS = ∫ q dS, since (4/(1 − Fdr) − 2)/(2A) = 1. So a
/// converged solution balances to the solver's tolerance, for every discretisation, with the
/// absorption each one solves with: [`Discretization::FittedLayer`]'s boundary rows absorb by
/// the layer's profile ([`super::fitted`]), not at the surface fluence.
///
/// # Errors
/// [`DiffusionError::LengthMismatch`] unless `phi` has one entry per vertex.
pub fn energy_balance(system: &DiffusionSystem, phi: &[[f64; 3]]) -> Result<EnergyBalance, DiffusionError> {
    check_phi(system, phi)?;
    let s = system.structure();
    let terms = system.boundary_terms();
    let mut absorbed = [0.0; 3];
    for (t, tet) in s.tets.iter().enumerate() {
        let mu = system.media()[s.materials[t] as usize].sigma_a;
        for c in 0..3 {
            let mean = tet.iter().map(|&v| phi[v as usize][c]).sum::<f64>() / 4.0;
            absorbed[c] += mu[c] * s.volume[t] * mean;
        }
    }
    if system.discretization() == Discretization::FittedLayer {
        // The boundary rows' layer absorption over the lumped one (M is 4 × the weak form).
        let coefficients = Coefficients::of(system.media());
        for &v in &s.boundary.ids {
            let excess = layer_excess(s, &coefficients, v as usize);
            for c in 0..3 {
                absorbed[c] += excess[c] * phi[v as usize][c] / 4.0;
            }
        }
    }
    let (mut exitant, mut incident) = ([0.0; 3], [0.0; 3]);
    let q = system.source();
    for (k, &v) in s.boundary.ids.iter().enumerate() {
        let share = s.boundary.area_mm2[k] / 3.0;
        for c in 0..3 {
            exitant[c] += share * (phi[v as usize][c] - 2.0 * q[k][c]) / (2.0 * terms.a);
            incident[c] += share * q[k][c];
        }
    }
    Ok(EnergyBalance { absorbed, exitant, incident })
}

fn check_phi(system: &DiffusionSystem, phi: &[[f64; 3]]) -> Result<(), DiffusionError> {
    if phi.len() == system.vertex_count() {
        Ok(())
    } else {
        Err(DiffusionError::LengthMismatch {
            what: "fluence phi (one entry per vertex)",
            expected: system.vertex_count(),
            found: phi.len(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::system::tests::cube_mesh;
    use super::super::{assemble, assemble_consistent};
    use super::*;
    use crate::optics::Medium;

    fn solved(consistent: bool) -> (DiffusionSystem, Solution) {
        let mesh = cube_mesh(5, 1.0);
        let m = Medium::preset("skin1").unwrap();
        let mut sys =
            if consistent { assemble_consistent(&mesh, &[m], 1.0).unwrap() } else { assemble(&mesh, &[m], 1.0).unwrap() };
        let q: Vec<[f64; 3]> = sys.boundary().normal.iter().map(|n| [1.0 + n.x.max(0.0), 1.0, 0.2 + n.z.abs()]).collect();
        sys.set_source(&q).unwrap();
        let sol = solve(&sys, None, &SolveOptions::default().with_tolerance(1e-10)).unwrap();
        (sys, sol)
    }

    #[test]
    fn solution_satisfies_the_system_and_balances_energy() {
        for consistent in [false, true] {
            let (sys, sol) = solved(consistent);
            assert!(sol.stats.converged);
            let r = sys.matrix().mul_vec(&sol.phi).unwrap();
            let bn: f64 = sys.rhs().iter().map(|b| b[0] * b[0]).sum::<f64>().sqrt();
            let rn: f64 = r.iter().zip(sys.rhs()).map(|(x, b)| (x[0] - b[0]).powi(2)).sum::<f64>().sqrt();
            assert!(rn <= 1.01e-10 * bn, "{rn} {bn}");
            let e = energy_balance(&sys, &sol.phi).unwrap();
            for d in e.relative_defect() {
                assert!(d.abs() < 1e-8, "{consistent}: {e:?}");
            }
            // φ is positive and Lo is positive for a positive source.
            assert!(sol.phi.iter().flatten().all(|&x| x > 0.0));
            assert!(surface_radiance(&sys, &sol.phi).unwrap().iter().flatten().all(|&x| x > 0.0));
        }
    }

    #[test]
    fn warm_start_from_the_solution_takes_no_iterations() {
        let (sys, sol) = solved(false);
        let options = SolveOptions::default().with_tolerance(1e-8);
        let again = solve(&sys, Some(&sol.phi), &options).unwrap();
        assert_eq!(again.stats.iterations, [0; 3]);
        assert!(sol.stats.iterations.iter().all(|&k| k > 0));
        assert!(matches!(solve(&sys, Some(&sol.phi[1..]), &options), Err(DiffusionError::LengthMismatch { .. })));
        let capped = SolveOptions::default().with_tolerance(1e-12).with_max_iterations(2);
        assert!(matches!(solve(&sys, None, &capped), Err(DiffusionError::NotConverged { .. })));
    }

    #[test]
    fn radiance_is_equation_3_along_the_normal() {
        let (sys, sol) = solved(false);
        let lo = surface_radiance(&sys, &sol.phi).unwrap();
        let phi_s = surface_fluence(&sys, &sol.phi).unwrap();
        let t = sys.boundary_terms();
        for k in 0..lo.len() {
            for c in 0..3 {
                let q = sys.source()[k][c];
                let expect = crate::optics::radiance_from_fluence(phi_s[k][c], q, t.eta, 1.0);
                assert!((lo[k][c] - expect).abs() < 1e-13 * expect.abs().max(1.0));
            }
        }
        let mut bad = sol.phi.clone();
        bad[sys.boundary().ids[3] as usize][2] = f64::NAN;
        assert!(matches!(surface_radiance(&sys, &bad), Err(DiffusionError::NonFinite { channel: 2, .. })));
    }
}
