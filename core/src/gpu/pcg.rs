//! The diffusion solve on the device: Jacobi-preconditioned CG in f32 with the whole iteration
//! on the GPU, inside a mixed-precision iterative refinement that makes the result as accurate
//! as the CPU's f64 solve.
//!
//! **Inner solve (device, f32).** CG on the Jacobi-scaled system Â ŷ = S f (Â = S M S,
//! S = D^-½, d = S ŷ), the three channels at once, each with its own α, β and stopping test (a
//! stopped channel gets α = 0), as in [`crate::sparse::pcg`]. One iteration is five dispatches
//! in one compute pass, all scalars staying on the device: `spmv_dot` (q = Â p and partial pᵀq),
//! `reduce_alpha`, `cg_update` (ŷ, r̂ and partial norms), `reduce_beta`, `cg_direction`. Every
//! [`REPLACE_EVERY`] iterations the residual is recomputed from ŷ (`cg_residual`, residual
//! replacement), so f32 drift in the recursive residual cannot fake convergence. The host reads
//! back only the 128-byte scalar block, every [`CHECK_EVERY`] iterations.
//!
//! **Outer refinement (host, f64).** f32 cannot resolve a relative residual much below 1e-6 on
//! these systems, and the device matrix is the f32 one. So the host computes the true residual
//! r = b − M x in f64 from the system's (CPU, f64) matrix, stops when every channel meets the
//! tolerance — the same test, on the same matrix, as the CPU solver, so
//! [`SolveStats::relative_residual`] means the same thing — and otherwise solves M d = r on the
//! device (to a relative [`INNER_TOLERANCE`] or what the tolerance needs) and sets x += d
//! (Wilkinson's iterative refinement, as in Buttari et al. 2007 and Göddeke et al. 2007 for FEM
//! on GPUs). Each round gains about five digits, so a 1e-6 solve takes two rounds.
//!
//! **Multigrid preconditioning** ([`GpuSolver::with_multigrid`]). The inner solve is then CG on
//! the unscaled system preconditioned by one V-cycle of a [`Multigrid`] per iteration, all on
//! the device (see `multigrid.rs`): the Jacobi kernels run with S = 1, and an iteration is
//! `spmv_dot`, `reduce_alpha`, `cg_update` (and `cg_residual` every [`REPLACE_EVERY`]),
//! `mg_reduce_norm` (‖r‖², stopping test), the V-cycle z = B r, `dot` and `mg_reduce_rz`
//! (β = rᵀz/ρ), `cg_direction` with z. Iterations are about ten times dearer and ten times fewer,
//! so the scalars are read back every [`MG_CHECK_EVERY`] iterations. The outer refinement is
//! the same.

use std::time::Instant;

use rayon::prelude::*;

use super::context::{dispatch, GpuContext};
use super::error::GpuError;
use super::layout::{from_vec4, to_vec4, Params, Scalars};
use super::matrix::DeviceMatrix;
use super::multigrid::DeviceMultigrid;
use super::shaders::Kernel;
use crate::diffusion::{start_vector, DiffusionError, DiffusionSystem, Solution};
use crate::sparse::hierarchy::Multigrid;
use crate::sparse::{CsrMatrix3, SolveOptions, SolveStats, SparseError};

/// Iterations between two read-backs of the scalars (convergence checks).
pub const CHECK_EVERY: usize = 16;
/// Iterations between two read-backs with the multigrid preconditioner (a V-cycle costs about
/// ten SpMVs and MG-PCG converges in about ten iterations, so fewer wasted iterations matter
/// more than fewer read-backs).
pub const MG_CHECK_EVERY: usize = 4;
/// Iterations between two residual replacements on the device.
pub const REPLACE_EVERY: usize = 64;
/// The relative residual an inner f32 solve aims at (well above f32's floor).
pub const INNER_TOLERANCE: f64 = 1e-5;
/// Refinement rounds before giving up.
const MAX_ROUNDS: usize = 10;
/// Read-backs without a 1% gain in any active channel's residual before an inner solve is ended
/// (its f32 floor reached); the refinement continues from there.
const STALL_CHECKS: usize = 8;

/// What the GPU did in a solve, with timings (wall-clock seconds converted to milliseconds; the
/// device is waited on at the end of each phase, so the phases add up).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
#[non_exhaustive]
pub struct GpuStats {
    /// The adapter's name.
    pub device: String,
    /// Whether the matrix was assembled on the device (TransCut) or uploaded (other
    /// discretisations).
    pub assembled_on_device: bool,
    /// Uploading the mesh structure (or matrix) to the device, and with a multigrid
    /// preconditioner its operators, transfers and coarsest inverse.
    pub upload_ms: f64,
    /// Assembly on the device (per-tet geometry, gather, Jacobi scaling).
    pub assembly_ms: f64,
    /// The refinement loop: device iterations, read-backs and host residuals.
    pub solve_ms: f64,
    /// Of `solve_ms`, the host's f64 residuals.
    pub host_residual_ms: f64,
    /// Refinement rounds (inner device solves).
    pub rounds: usize,
    /// Read-backs of the device scalars or vectors.
    pub readbacks: usize,
    /// Iterations dispatched on the device (the per-channel counts are in the solve stats).
    pub dispatched_iterations: usize,
    /// Levels of the multigrid preconditioner on the device; 0 for Jacobi PCG.
    pub multigrid_levels: usize,
}

/// A GPU solve: the solution (with the same [`SolveStats`] as the CPU path) and what the GPU did.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct GpuSolution {
    /// φ at every vertex and the solver statistics.
    pub solution: Solution,
    /// Device, timings, rounds.
    pub stats: GpuStats,
}

/// A diffusion system's matrix resident on the device, for repeated solves (relighting: only b
/// changes). Buffers come from the context's pool and return to it on drop.
pub struct GpuSolver<'c> {
    ctx: &'c GpuContext,
    matrix: DeviceMatrix<'c>,
    /// The V-cycle preconditioner; `None`: Jacobi.
    multigrid: Option<DeviceMultigrid<'c>>,
}

impl std::fmt::Debug for GpuSolver<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuSolver")
            .field("n", &self.matrix.n)
            .field("nnz", &self.matrix.nnz)
            .field("multigrid_levels", &self.multigrid.as_ref().map_or(0, DeviceMultigrid::levels))
            .finish()
    }
}

/// Solves M φ = b of `system` on the GPU of `ctx` (assembling M there for the TransCut
/// discretisation), starting from `warm_start` or zero, to `options.tolerance` in the relative
/// residual ‖b − Mφ‖/‖b‖ of the f64 system, like [`crate::diffusion::solve`].
///
/// # Errors
/// The errors of [`crate::diffusion::solve`] (as [`GpuError::Diffusion`]): a warm start of the
/// wrong length or not finite, [`DiffusionError::NotConverged`], a breakdown, cancellation by the
/// monitor; device errors ([`GpuError::Device`], [`GpuError::TooLarge`]).
pub fn solve(
    ctx: &GpuContext,
    system: &DiffusionSystem,
    warm_start: Option<&[[f64; 3]]>,
    options: &SolveOptions<'_>,
) -> Result<GpuSolution, GpuError> {
    GpuSolver::new(ctx, system)?.solve(system, warm_start, options)
}

impl<'c> GpuSolver<'c> {
    /// Puts the matrix of `system` on the device (assembled there for TransCut) and scales it.
    ///
    /// # Errors
    /// Device errors ([`GpuError::Device`], [`GpuError::TooLarge`]).
    pub fn new(ctx: &'c GpuContext, system: &DiffusionSystem) -> Result<GpuSolver<'c>, GpuError> {
        Ok(GpuSolver { ctx, matrix: DeviceMatrix::from_system(ctx, system)?, multigrid: None })
    }

    /// Like [`GpuSolver::new`], with CG preconditioned by a V-cycle of `mg` (built on the CPU for
    /// the system's matrix, e.g. by [`crate::diffusion::Solver`] with
    /// [`crate::diffusion::SolverKind::MultigridPcg`]) on the device instead of Jacobi: the twin of
    /// [`crate::sparse::hierarchy::mg_pcg`] inside the same f64 refinement.
    ///
    /// # Errors
    /// [`GpuError::Diffusion`] with [`DiffusionError::LengthMismatch`] when `mg` was built for
    /// another mesh; device errors.
    pub fn with_multigrid(ctx: &'c GpuContext, system: &DiffusionSystem, mg: &Multigrid) -> Result<GpuSolver<'c>, GpuError> {
        let levels0 = mg.hierarchy().level(0).graph.n();
        if levels0 != system.vertex_count() {
            return Err(DiffusionError::LengthMismatch {
                what: "multigrid level 0 (one vertex per mesh vertex)",
                expected: system.vertex_count(),
                found: levels0,
            }
            .into());
        }
        let matrix = DeviceMatrix::from_system(ctx, system)?;
        let multigrid = DeviceMultigrid::new(ctx, mg)?;
        debug_assert_eq!(multigrid.n(), matrix.n);
        Ok(GpuSolver { ctx, matrix, multigrid: Some(multigrid) })
    }

    /// A solver for a symmetric positive definite `matrix` of one's own (the polygrid's
    /// finite-volume system, [`crate::polygrid::PolygridSystem`]): uploaded and Jacobi-scaled;
    /// solve it with [`GpuSolver::solve_matrix`].
    ///
    /// # Errors
    /// Device errors ([`GpuError::Device`], [`GpuError::TooLarge`]).
    pub fn for_matrix(ctx: &'c GpuContext, matrix: &CsrMatrix3) -> Result<GpuSolver<'c>, GpuError> {
        let params = Params { n: matrix.n() as u32, nnz: matrix.pattern().nnz() as u32, ..Params::default() };
        Ok(GpuSolver { ctx, matrix: DeviceMatrix::upload(ctx, matrix, params)?, multigrid: None })
    }

    /// Solves for the current right-hand side of `system`, which must be the system this solver
    /// was built from (or one with the same matrix, e.g. after `set_source`).
    ///
    /// # Errors
    /// Those of [`solve`]; [`GpuError::Diffusion`] with [`DiffusionError::LengthMismatch`] when
    /// `system` has another size than the solver's matrix.
    pub fn solve(
        &self,
        system: &DiffusionSystem,
        warm_start: Option<&[[f64; 3]]>,
        options: &SolveOptions<'_>,
    ) -> Result<GpuSolution, GpuError> {
        self.solve_matrix(system.matrix(), system.rhs(), warm_start, options)
    }

    /// Solves `matrix` x = `rhs` (the matrix this solver was built from: its f64 original, for
    /// the refinement's residuals), starting from `warm_start` or zero, to `options.tolerance`
    /// in the relative residual, as [`crate::sparse::pcg`] on the CPU.
    ///
    /// # Errors
    /// As [`GpuSolver::solve`], the lengths checked against `matrix`.
    pub fn solve_matrix(
        &self,
        matrix: &CsrMatrix3,
        b: &[[f64; 3]],
        warm_start: Option<&[[f64; 3]]>,
        options: &SolveOptions<'_>,
    ) -> Result<GpuSolution, GpuError> {
        let n = self.matrix.n;
        if matrix.n() != n || matrix.pattern().nnz() != self.matrix.nnz || b.len() != n {
            return Err(DiffusionError::LengthMismatch {
                what: "system solved with a GPU solver built for another matrix (rows)",
                expected: n,
                found: if b.len() == n { matrix.n() } else { b.len() },
            }
            .into());
        }
        if !(options.tolerance.is_finite() && options.tolerance >= 0.0) {
            return Err(sparse(SparseError::InvalidOption(format!(
                "tolerance {} must be finite and non-negative",
                options.tolerance
            ))));
        }
        let mut x = start_vector(n, warm_start)?;
        if let Some((row, channel, value)) = warm_start.and_then(first_non_finite) {
            return Err(sparse(SparseError::NonFinite { what: "initial guess", row, channel, value }));
        }
        let bn = norm3(b);
        for (c, &norm) in bn.iter().enumerate() {
            if norm == 0.0 {
                x.iter_mut().for_each(|v| v[c] = 0.0);
            }
        }
        let ctx = self.ctx;
        let m = &self.matrix;
        let start = Instant::now();
        let mut stats = GpuStats {
            device: ctx.device_name().to_owned(),
            assembled_on_device: m.assembled_on_device,
            upload_ms: 1e3 * (m.upload_s + self.multigrid.as_ref().map_or(0.0, |g| g.upload_s)),
            assembly_ms: 1e3 * m.assembly_s,
            solve_ms: 0.0,
            host_residual_ms: 0.0,
            rounds: 0,
            readbacks: 0,
            dispatched_iterations: 0,
            multigrid_levels: self.multigrid.as_ref().map_or(0, DeviceMultigrid::levels),
        };
        let vec_bytes = 16 * n as u64;
        let f = ctx.storage(vec_bytes, "refinement residual")?;
        let bhat = ctx.storage(vec_bytes, "scaled rhs")?;
        let r = ctx.storage(vec_bytes, "residual")?;
        let p = ctx.storage(vec_bytes, "direction")?;
        let q = ctx.storage(vec_bytes, "A p")?;
        let y = ctx.storage(vec_bytes, "iterate")?;
        let out = ctx.storage(vec_bytes, "correction")?;
        let partials = ctx.storage(32 * u64::from(m.n_groups), "partial sums")?;
        let scalars = ctx.storage(size_of::<Scalars>() as u64, "scalars")?;
        // Jacobi: the scaled system (Â, S). Multigrid: the unscaled one (M, S = 1), with z = B r.
        let mg = self.multigrid.as_ref();
        let sdiag: &wgpu::Buffer = mg.map_or(&m.sdiag, |g| &g.ones);
        let op: &wgpu::Buffer = if mg.is_some() { &m.values } else { &m.scaled };
        let plan = mg.map(|g| g.plan(ctx, m, &r));
        let z: &wgpu::Buffer = plan.as_ref().map_or(&r, |pl| pl.output);
        let check_every = if mg.is_some() { MG_CHECK_EVERY } else { CHECK_EVERY };
        let bind_init = ctx.bind(Kernel::CgInit, &[&m.params, &f, sdiag, &bhat, &r, &p, &y, &partials]);
        let bind_restart = ctx.bind(Kernel::ReduceRestart, &[&m.params, &partials, &scalars]);
        let bind_spmv = ctx.bind(Kernel::SpmvDot, &[&m.params, &m.row_ptr, &m.col_idx, op, &p, &q, &partials]);
        let bind_alpha = ctx.bind(Kernel::ReduceAlpha, &[&m.params, &partials, &scalars]);
        let bind_update = ctx.bind(Kernel::CgUpdate, &[&m.params, &scalars, &y, &r, &p, &q, sdiag, &partials]);
        let bind_beta = ctx.bind(Kernel::ReduceBeta, &[&m.params, &partials, &scalars]);
        let bind_direction = ctx.bind(Kernel::CgDirection, &[&m.params, &scalars, z, &p]);
        let bind_residual =
            ctx.bind(Kernel::CgResidual, &[&m.params, &m.row_ptr, &m.col_idx, op, &bhat, &y, sdiag, &r, &partials]);
        let bind_unscale = ctx.bind(Kernel::CgUnscale, &[&m.params, sdiag, &y, &out]);
        // MG-PCG only: ‖r‖² and the stopping test; rᵀz; β, ρ.
        let mg_binds = mg.map(|_| {
            (
                ctx.bind(Kernel::MgReduceNorm, &[&m.params, &partials, &scalars]),
                ctx.bind(Kernel::Dot, &[&m.params, &r, z, &partials]),
                ctx.bind(Kernel::MgReduceRz, &[&m.params, &partials, &scalars]),
            )
        });
        let single = (1, 1);
        // MG-PCG once r is known: z = B r, ρ = rᵀz and β, p = z + β p.
        let precondition = |pass: &mut wgpu::ComputePass<'_>| {
            if let (Some(pl), Some((_, bind_rz_dot, bind_rz))) = (&plan, &mg_binds) {
                pl.record(pass, ctx);
                dispatch(pass, ctx, Kernel::Dot, bind_rz_dot, m.grid);
                dispatch(pass, ctx, Kernel::MgReduceRz, bind_rz, single);
                dispatch(pass, ctx, Kernel::CgDirection, &bind_direction, m.grid);
            }
        };

        let mut iterations = [0usize; 3];
        let mut res = vec![[0.0; 3]; n];
        let mut rel;
        let mut previous: Option<[f64; 3]> = None;
        let mut converged;
        loop {
            let t = Instant::now();
            let rn = residual(matrix, b, &x, &mut res)?;
            stats.host_residual_ms += 1e3 * t.elapsed().as_secs_f64();
            rel = [0, 1, 2].map(|c| if bn[c] > 0.0 { rn[c] / bn[c] } else { 0.0 });
            let need = [0, 1, 2].map(|c| bn[c] > 0.0 && rel[c] > options.tolerance);
            converged = !need.iter().any(|&t| t);
            let stalled = previous.is_some_and(|prev| (0..3).all(|c| !need[c] || rel[c] > 0.5 * prev[c]));
            if converged
                || stalled
                || stats.rounds == MAX_ROUNDS
                || (0..3).any(|c| need[c] && iterations[c] >= options.max_iterations)
            {
                break;
            }
            previous = Some(rel);
            stats.rounds += 1;
            // The inner solve of M d = res, on the device.
            let mut s0 = Scalars::default();
            for c in 0..3 {
                if need[c] {
                    let inner = (0.5 * options.tolerance * bn[c] / rn[c]).clamp(INNER_TOLERANCE, 0.5);
                    s0.running[c] = 1.0;
                    s0.tol2[c] = ((inner * rn[c]).powi(2)) as f32;
                } else {
                    s0.tol2[c] = f32::MAX;
                }
            }
            ctx.queue().write_buffer(&f, 0, bytemuck::cast_slice(&to_vec4(&res)));
            ctx.queue().write_buffer(&scalars, 0, bytemuck::bytes_of(&s0));
            let mut encoder = ctx.encoder();
            {
                let mut pass =
                    encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("cg init"), timestamp_writes: None });
                dispatch(&mut pass, ctx, Kernel::CgInit, &bind_init, m.grid);
                dispatch(&mut pass, ctx, Kernel::ReduceRestart, &bind_restart, single);
            }
            if mg.is_some() {
                // p = 0, so the first p = z + β p is z.
                encoder.clear_buffer(&p, 0, None);
                let mut pass = encoder
                    .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("mg-pcg start"), timestamp_writes: None });
                precondition(&mut pass);
            }
            ctx.submit_wait(encoder, "PCG start")?;
            let round_start = iterations;
            let mut best = [f64::INFINITY; 3];
            let mut stale = 0;
            let mut k = 0usize;
            loop {
                let mut encoder = ctx.encoder();
                {
                    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: Some("cg iterations"),
                        timestamp_writes: None,
                    });
                    for _ in 0..check_every {
                        k += 1;
                        dispatch(&mut pass, ctx, Kernel::SpmvDot, &bind_spmv, m.grid);
                        dispatch(&mut pass, ctx, Kernel::ReduceAlpha, &bind_alpha, single);
                        dispatch(&mut pass, ctx, Kernel::CgUpdate, &bind_update, m.grid);
                        if let Some((bind_norm, _, _)) = &mg_binds {
                            if k.is_multiple_of(REPLACE_EVERY) {
                                dispatch(&mut pass, ctx, Kernel::CgResidual, &bind_residual, m.grid);
                            }
                            dispatch(&mut pass, ctx, Kernel::MgReduceNorm, bind_norm, single);
                            precondition(&mut pass);
                            continue;
                        }
                        dispatch(&mut pass, ctx, Kernel::ReduceBeta, &bind_beta, single);
                        if k.is_multiple_of(REPLACE_EVERY) {
                            dispatch(&mut pass, ctx, Kernel::CgResidual, &bind_residual, m.grid);
                            dispatch(&mut pass, ctx, Kernel::ReduceRestart, &bind_restart, single);
                        }
                        dispatch(&mut pass, ctx, Kernel::CgDirection, &bind_direction, m.grid);
                    }
                }
                stats.dispatched_iterations += check_every;
                let bytes = ctx.read_back(encoder, &scalars, size_of::<Scalars>() as u64, "PCG iterations")?;
                stats.readbacks += 1;
                let sc: Scalars = bytemuck::pod_read_unaligned(&bytes);
                for c in 0..3 {
                    iterations[c] = round_start[c] + sc.iterations[c] as usize;
                }
                if let Some(c) = (0..3).find(|&c| sc.breakdown[c] != 0) {
                    return Err(sparse(SparseError::Breakdown {
                        method: if mg.is_some() { "GPU MG-PCG" } else { "GPU PCG" },
                        channel: c,
                        iteration: iterations[c],
                        reason: if mg.is_some() {
                            "pᵀMp or rᵀBr ≤ 0 or not finite: the matrix or the V-cycle is not positive definite in f32".into()
                        } else {
                            "pᵀÂp ≤ 0 or not finite: the matrix is not positive definite in f32".into()
                        },
                    }));
                }
                let estimate =
                    [0, 1, 2].map(|c| if need[c] && bn[c] > 0.0 { f64::from(sc.rr[c]).max(0.0).sqrt() / bn[c] } else { rel[c] });
                if let Some(monitor) = options.monitor {
                    if !monitor(iterations.iter().copied().max().unwrap_or(0), estimate) {
                        return Err(sparse(SparseError::Cancelled { iteration: iterations.iter().copied().max().unwrap_or(0) }));
                    }
                }
                let active: Vec<usize> = (0..3).filter(|&c| sc.running[c] > 0.5).collect();
                if active.is_empty() {
                    break;
                }
                let mut gained = false;
                for &c in &active {
                    let v = f64::from(sc.rr[c]);
                    if !v.is_finite() {
                        continue;
                    }
                    if v < 0.98 * best[c] {
                        gained = true;
                    }
                    best[c] = best[c].min(v);
                }
                stale = if gained { 0 } else { stale + 1 };
                if stale >= STALL_CHECKS || active.iter().any(|&c| iterations[c] >= options.max_iterations) {
                    break;
                }
            }
            let mut encoder = ctx.encoder();
            {
                let mut pass =
                    encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("unscale"), timestamp_writes: None });
                dispatch(&mut pass, ctx, Kernel::CgUnscale, &bind_unscale, m.grid);
            }
            let bytes = ctx.read_back(encoder, &out, vec_bytes, "correction read-back")?;
            stats.readbacks += 1;
            let d = from_vec4(&bytes, n);
            x.par_iter_mut().zip(d.par_iter()).for_each(|(xi, di)| {
                for c in 0..3 {
                    if need[c] {
                        xi[c] += di[c];
                    }
                }
            });
        }
        stats.solve_ms = 1e3 * start.elapsed().as_secs_f64();
        let converged_channels = [0, 1, 2].map(|c| bn[c] == 0.0 || rel[c] <= options.tolerance);
        let solve_stats = SolveStats { iterations, relative_residual: rel, converged_channels, converged };
        if !converged {
            return Err(DiffusionError::NotConverged { iterations, residual: rel, tolerance: options.tolerance }.into());
        }
        Ok(GpuSolution { solution: Solution { phi: x, stats: solve_stats }, stats })
    }
}

fn sparse(e: SparseError) -> GpuError {
    GpuError::Diffusion(DiffusionError::Sparse(e))
}

/// ‖v‖ per channel (f64).
fn norm3(v: &[[f64; 3]]) -> [f64; 3] {
    crate::sparse::norm3(v)
}

/// `r = b − M x` in f64 from the system's matrix; returns ‖r‖ per channel.
fn residual(matrix: &CsrMatrix3, b: &[[f64; 3]], x: &[[f64; 3]], r: &mut [[f64; 3]]) -> Result<[f64; 3], GpuError> {
    matrix.spmv(x, r).map_err(sparse)?;
    r.par_iter_mut().zip(b.par_iter()).for_each(|(ri, bi)| {
        for c in 0..3 {
            ri[c] = bi[c] - ri[c];
        }
    });
    Ok(norm3(r))
}

fn first_non_finite(v: &[[f64; 3]]) -> Option<(usize, usize, f64)> {
    v.iter().enumerate().find_map(|(i, x)| x.iter().position(|c| !c.is_finite()).map(|c| (i, c, x[c])))
}
