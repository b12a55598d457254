//! TransCut Fig. 7 — relative error against time with and without the multiresolution
//! scheme — plus the warm start after moving the sun by 5°, on one system.
//!
//! A reference φ* is solved to a tight tolerance. For each solver (single-level Jacobi PCG and
//! SSOR-PCG, the paper's cascade, multigrid-preconditioned CG on the paper's hierarchy and on a
//! smoothed-aggregation one) the setup (hierarchy and coarse operators, or the single-level
//! preconditioner) is timed, then cold solves to the tolerances 10^(−k/2), k = 2..12, each
//! giving one point (solve ms, ‖φ − φ*‖/‖φ*‖, worst channel) of the error–time curve; runs are
//! interleaved solver by solver and the medians reported, so ratios between solvers are measured
//! back to back. Time to 1% is the fastest tolerance whose error is ≤ 1%; the figure of merit
//! is the ratio of the faster multiresolution solver's to the faster single-level solver's.

use std::sync::Arc;
use std::time::Instant;

use anyhow::Context;
use serde::Serialize;
use transcut::diffusion::solver::hierarchy;
use transcut::diffusion::{DiffusionSystem, Solver, SolverKind};
use transcut::sparse::hierarchy::{HierarchyKind, HierarchyOptions};
use transcut::sparse::SolveOptions;
use transcut::DVec3;

use super::stats::{median, ms, relative_error};

#[derive(Serialize)]
struct CurvePoint {
    tolerance: f64,
    median_solve_ms: f64,
    iterations: [usize; 3],
    relative_error: f64,
}

#[derive(Serialize)]
struct MethodEntry {
    method: String,
    median_setup_ms: f64,
    setup_runs_ms: Vec<f64>,
    median_solve_1e6_ms: f64,
    solve_1e6_runs_ms: Vec<f64>,
    iterations_1e6: [usize; 3],
    error_1e6: f64,
    time_to_1pct_ms: Option<f64>,
    curve: Vec<CurvePoint>,
    warm_start_5deg: WarmEntry,
}

#[derive(Serialize)]
struct WarmEntry {
    cold_iterations: [usize; 3],
    warm_iterations: [usize; 3],
    median_cold_ms: f64,
    median_warm_ms: f64,
}

/// TransCut Fig. 7 on one assembled system: the hierarchy, every method's setup, solve, curve
/// and warm start, and the time-to-1% ratios.
#[derive(Serialize)]
pub(crate) struct Fig7 {
    /// Vertices per level of the hierarchy (level 0 first).
    levels: Vec<usize>,
    median_hierarchy_ms: f64,
    /// Tolerance of the reference solve φ*.
    reference_tolerance: f64,
    methods: Vec<MethodEntry>,
    time_to_1pct_ratio_cascade_vs_pcg: Option<f64>,
    time_to_1pct_ratio_mg_vs_pcg: Option<f64>,
    time_to_1pct_ratio_ssor_vs_pcg: Option<f64>,
    time_to_1pct_ratio_sa_vs_pcg: Option<f64>,
    /// The faster multiresolution method's time to 1% over the faster single-level solver's
    /// (Jacobi PCG or SSOR-PCG), TransCut Fig. 7's figure of merit. Setups are not included
    /// (each solver's is reported on its own).
    pub(crate) time_to_1pct_ratio_best_multires_vs_best_single_level: Option<f64>,
    solve_1e6_ratio_cascade_vs_pcg: f64,
    solve_1e6_ratio_mg_vs_pcg: f64,
    solve_1e6_ratio_ssor_vs_pcg: f64,
    solve_1e6_ratio_sa_vs_pcg: f64,
}

/// An unshadowed sun from `dir` (towards the light), irradiance 3: q = 3 max(n·l, 0).
pub(crate) fn light(system: &mut DiffusionSystem, dir: DVec3) -> anyhow::Result<()> {
    let l = dir.normalize();
    let q: Vec<[f64; 3]> = system.boundary().normal.iter().map(|n| [3.0 * n.dot(l).max(0.0); 3]).collect();
    system.set_source(&q)?;
    Ok(())
}

/// The methods, single-level first: Jacobi PCG (the baseline), SSOR-PCG, then the three
/// multiresolution methods.
const SOLVERS: [(SolverKind, &str); 5] = [
    (SolverKind::Pcg, "pcg"),
    (SolverKind::SsorPcg, "ssor_pcg"),
    (SolverKind::Cascade, "cascade"),
    (SolverKind::MultigridPcg, "mg_pcg"),
    (SolverKind::AggregationPcg, "sa_pcg"),
];

/// `sun` rotated by `degrees` about the x axis.
pub(crate) fn rotate_about_x(sun: DVec3, degrees: f64) -> DVec3 {
    let rot = degrees.to_radians();
    DVec3::new(sun.x, sun.y * rot.cos() - sun.z * rot.sin(), sun.y * rot.sin() + sun.z * rot.cos())
}

/// Fig. 7 on `system` lit by an unshadowed sun from `sun` ([`light`]): a reference solved to
/// `reference_tolerance`, then per run every method back to back (setup, a 1e-6 solve, the
/// error–time curve over the tolerances 10^(−k/2), k = 2..12, and the cold and warm solves after
/// the sun moves 5° about x); medians over `runs`. Leaves `system` lit by the moved sun.
pub(crate) fn fig7(system: &mut DiffusionSystem, sun: DVec3, runs: usize, reference_tolerance: f64) -> anyhow::Result<Fig7> {
    // 5° about the x axis (the sun lies in the yz plane).
    let sun5 = rotate_about_x(sun, 5.0);
    let tolerances: Vec<f64> = (2..=12).map(|k| 10f64.powf(-(k as f64) / 2.0)).collect();
    let runs = runs.max(1);
    light(system, sun)?;
    let reference = Solver::new(system, SolverKind::Pcg, &HierarchyOptions::default())?.solve(
        system,
        None,
        &SolveOptions::default().with_tolerance(reference_tolerance),
    )?;
    let mut hierarchy_ms = Vec::new();
    let mut h = None;
    for _ in 0..runs {
        let t = Instant::now();
        h = Some(Arc::new(hierarchy(system, &HierarchyOptions::default())?));
        hierarchy_ms.push(ms(t));
    }
    let h = h.context("at least one run")?;
    // Interleaved runs: per run, every method back to back.
    let mut setup = vec![Vec::new(); SOLVERS.len()];
    let mut solve6 = vec![Vec::new(); SOLVERS.len()];
    let mut its6 = [[0; 3]; SOLVERS.len()];
    let mut err6 = [0.0; SOLVERS.len()];
    let mut curve_ms = vec![vec![Vec::new(); tolerances.len()]; SOLVERS.len()];
    let mut curve_its = vec![vec![[0; 3]; tolerances.len()]; SOLVERS.len()];
    let mut curve_err = vec![vec![0.0; tolerances.len()]; SOLVERS.len()];
    let mut warm_cold_ms = vec![Vec::new(); SOLVERS.len()];
    let mut warm_ms = vec![Vec::new(); SOLVERS.len()];
    let mut warm_its = vec![([0; 3], [0; 3]); SOLVERS.len()];
    for _ in 0..runs {
        for (m, &(kind, _)) in SOLVERS.iter().enumerate() {
            light(system, sun)?;
            let t = Instant::now();
            let solver = if kind.hierarchy_kind() != Some(HierarchyKind::IndependentSets) {
                // Single level, or the aggregation built from the matrix (timed whole).
                Solver::new(system, kind, &HierarchyOptions::default())?
            } else {
                // The hierarchy is timed with the setup (its own median is reported too).
                let hh = Arc::new(hierarchy(system, &HierarchyOptions::default())?);
                Solver::with_hierarchy(system, hh, kind)?
            };
            setup[m].push(ms(t));
            let t = Instant::now();
            let sol = solver.solve(system, None, &SolveOptions::default())?;
            solve6[m].push(ms(t));
            its6[m] = sol.stats.iterations;
            err6[m] = relative_error(&sol.phi, &reference.phi);
            for (k, &tol) in tolerances.iter().enumerate() {
                let t = Instant::now();
                let s = solver.solve(system, None, &SolveOptions::default().with_tolerance(tol))?;
                curve_ms[m][k].push(ms(t));
                curve_its[m][k] = s.stats.iterations;
                curve_err[m][k] = relative_error(&s.phi, &reference.phi);
            }
            light(system, sun5)?;
            let t = Instant::now();
            let cold = solver.solve(system, None, &SolveOptions::default())?;
            warm_cold_ms[m].push(ms(t));
            let t = Instant::now();
            let warm = solver.solve(system, Some(&sol.phi), &SolveOptions::default())?;
            warm_ms[m].push(ms(t));
            warm_its[m] = (cold.stats.iterations, warm.stats.iterations);
        }
    }
    let mut methods = Vec::new();
    for (m, &(_, name)) in SOLVERS.iter().enumerate() {
        let curve: Vec<CurvePoint> = tolerances
            .iter()
            .enumerate()
            .map(|(k, &tolerance)| CurvePoint {
                tolerance,
                median_solve_ms: median(curve_ms[m][k].clone()),
                iterations: curve_its[m][k],
                relative_error: curve_err[m][k],
            })
            .collect();
        let time_to_1pct = curve.iter().filter(|p| p.relative_error <= 0.01).map(|p| p.median_solve_ms).reduce(f64::min);
        methods.push(MethodEntry {
            method: name.to_owned(),
            median_setup_ms: median(setup[m].clone()),
            setup_runs_ms: setup[m].clone(),
            median_solve_1e6_ms: median(solve6[m].clone()),
            solve_1e6_runs_ms: solve6[m].clone(),
            iterations_1e6: its6[m],
            error_1e6: err6[m],
            time_to_1pct_ms: time_to_1pct,
            curve,
            warm_start_5deg: WarmEntry {
                cold_iterations: warm_its[m].0,
                warm_iterations: warm_its[m].1,
                median_cold_ms: median(warm_cold_ms[m].clone()),
                median_warm_ms: median(warm_ms[m].clone()),
            },
        });
    }
    let ratio = |a: Option<f64>, b: Option<f64>| Some(a? / b?);
    let best = |of: &[usize]| of.iter().filter_map(|&m| methods[m].time_to_1pct_ms).reduce(f64::min);
    let (pcg, ssor, cascade, mg, sa) = (0, 1, 2, 3, 4);
    Ok(Fig7 {
        levels: h.vertex_counts(),
        median_hierarchy_ms: median(hierarchy_ms),
        reference_tolerance,
        time_to_1pct_ratio_cascade_vs_pcg: ratio(methods[cascade].time_to_1pct_ms, methods[pcg].time_to_1pct_ms),
        time_to_1pct_ratio_mg_vs_pcg: ratio(methods[mg].time_to_1pct_ms, methods[pcg].time_to_1pct_ms),
        time_to_1pct_ratio_ssor_vs_pcg: ratio(methods[ssor].time_to_1pct_ms, methods[pcg].time_to_1pct_ms),
        time_to_1pct_ratio_sa_vs_pcg: ratio(methods[sa].time_to_1pct_ms, methods[pcg].time_to_1pct_ms),
        time_to_1pct_ratio_best_multires_vs_best_single_level: ratio(best(&[cascade, mg, sa]), best(&[pcg, ssor])),
        solve_1e6_ratio_cascade_vs_pcg: methods[cascade].median_solve_1e6_ms / methods[pcg].median_solve_1e6_ms,
        solve_1e6_ratio_mg_vs_pcg: methods[mg].median_solve_1e6_ms / methods[pcg].median_solve_1e6_ms,
        solve_1e6_ratio_ssor_vs_pcg: methods[ssor].median_solve_1e6_ms / methods[pcg].median_solve_1e6_ms,
        solve_1e6_ratio_sa_vs_pcg: methods[sa].median_solve_1e6_ms / methods[pcg].median_solve_1e6_ms,
        methods,
    })
}
