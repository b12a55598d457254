//! Sparse linear algebra for the diffusion solvers: CSR matrices with one pattern shared by the
//! three colour channels, a parallel SpMV, preconditioned CG, BiCGSTAB and preconditioners, and
//! BiCGSTAB on operators given by their action ([`LinearOperator`]).
//!
//! # Layout (designed for memory bandwidth)
//!
//! The diffusion system `M φ = b` is assembled per colour channel, with one mesh and thus one
//! sparsity pattern, but different values (the medium differs per channel). So:
//!
//! * a [`CsrPattern`] (`row_ptr: usize`, `col_idx: u32`, diagonal always stored) is shared
//!   through an `Arc` by every matrix on the mesh;
//! * a [`CsrMatrix3`] stores the values interleaved per nonzero as `[f64; 3]`;
//! * vectors are `&[[f64; 3]]`, one entry per row;
//! * the SpMV streams the pattern once for all three channels, and the solvers iterate the three
//!   channels in one pass, each with its own scalars (α, β, …) and its own convergence: a
//!   converged channel stops changing while the others go on;
//! * vector updates are fused with the reductions that follow them (`x += αp`, `r −= αq` and
//!   `‖r‖²` in one pass; `q = Ap` and `pᵀq` in one pass);
//! * a [`Preconditioner`] keeps the Jacobi-scaled matrix `D^-½ A D^-½` in `f32` (16 bytes per
//!   nonzero with its column, against 28), which the default mixed-precision PCG iterates on
//!   while checking residuals in `f64` ([`Precision`]).
//!
//! # Determinism
//!
//! Every reduction is summed per fixed block of rows and the block sums are added in order
//! (see [`dot3`]); every SpMV row is summed in column order. Results are bit-identical run to
//! run and for any number of rayon threads.
//!
//! # Choosing a preconditioner
//!
//! The iteration is bound by memory traffic, so a preconditioner pays off only where it saves
//! more traffic in iterations than it adds per iteration:
//!
//! * [`Jacobi`] (the default) streams the least per iteration: the scaled operator and the
//!   vectors, the preconditioner itself folded into the scaling.
//! * [`Chebyshev`] of degree `d` adds `d` passes of the `f32` operator per iteration (each
//!   fused with its vector updates) and removes iterations at about the rate it adds passes.
//! * [`Ssor`] takes far fewer iterations than Jacobi, but each costs about two Jacobi
//!   iterations (its sweeps are sequential within each part of the ordering: a row waits on
//!   the row just computed), and its setup (a level-set ordering and the reordered triangles)
//!   costs more than Jacobi's: it pays off most where one matrix is solved repeatedly.
//!
//! Rounding the matrix itself to `f32` would leave a residual floor near the `f32` resolution
//! of the system, which is why `f32` is only used inside the iteration, with `f64` residuals
//! (see [`Precision`]). The measurements behind these choices are collected in
//! `docs/benchmarks.md`.
//!
//! # Errors
//!
//! Every fallible call returns [`SparseError`], naming the channel, row or iteration at fault.

mod bicgstab;
mod colour_ordered;
mod csr;
mod eisenstat_cg;
mod error;
#[cfg(test)]
mod fixtures;
pub mod hierarchy;
mod mm;
mod operator;
mod ops;
mod ordering;
mod pcg;
mod precond;
pub mod relax;
mod scaled;
mod ssor;

pub use bicgstab::bicgstab;
pub use csr::{CsrMatrix, CsrMatrix3, CsrPattern, Entry, Triplet};
pub use error::{SparseError, CHANNEL_NAMES};
pub use mm::{
    read_array_matrix_market, write_array_matrix_market, write_vector3_matrix_market, write_vector_matrix_market, MmArray,
};
pub use operator::{bicgstab_operator, LinearOperator, OperatorSolve};
pub use ops::{dot3, interleave_channels, norm3, split_channels};
pub use pcg::pcg;
pub use precond::{Chebyshev, Jacobi, Preconditioner, PreconditionerKind};
pub use ssor::Ssor;

use std::fmt;

/// A monitor called after every iteration with the iteration number (1-based) and the current
/// relative residual estimate of each channel; it returns `false` to stop the solve with
/// [`SparseError::Cancelled`]. Called on the solving thread; keep it cheap.
pub type Monitor<'a> = &'a (dyn Fn(usize, [f64; 3]) -> bool + Sync);

/// Options of the iterative solvers.
#[derive(Clone, Copy)]
#[non_exhaustive]
pub struct SolveOptions<'a> {
    /// Stop a channel when its relative residual `‖b − Ax‖ / ‖b‖` is at most this.
    /// Default 1e-6.
    pub tolerance: f64,
    /// Give up after this many iterations (the result then has `converged == false`).
    /// Default 10 000.
    pub max_iterations: usize,
    /// Optional progress/cancellation hook, see [`Monitor`].
    pub monitor: Option<Monitor<'a>>,
    /// Arithmetic of the PCG iteration (BiCGSTAB always uses `f64`). Default
    /// [`Precision::Mixed`].
    pub precision: Precision,
}

/// Arithmetic of the PCG matrix–vector products.
///
/// Either way the tolerance is met on the `f64` system: convergence is only declared on a
/// residual `b − Ax` recomputed in `f64` from the original matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum Precision {
    /// CG on the Jacobi-scaled matrix `S A S` (`S = D^-½`) stored in `f32`, vectors and scalars
    /// in `f64`, with the residual recomputed in `f64` from `A` whenever it has dropped 100-fold
    /// ("reliable updates") and before a channel is declared converged; continues in `f64` by
    /// itself if the `f32` operator stops resolving the residual. Streams fewer bytes per
    /// iteration (the operator in 16 instead of 28 bytes per nonzero) for about the same
    /// iteration count. With [`Preconditioner::Identity`] the solve runs in
    /// [`Precision::Double`].
    #[default]
    Mixed,
    /// Everything in `f64` on the original matrix.
    Double,
}

impl Default for SolveOptions<'_> {
    fn default() -> Self {
        Self { tolerance: 1e-6, max_iterations: 10_000, monitor: None, precision: Precision::Mixed }
    }
}

impl<'a> SolveOptions<'a> {
    /// Sets the tolerance.
    #[must_use]
    pub fn with_tolerance(mut self, tolerance: f64) -> Self {
        self.tolerance = tolerance;
        self
    }

    /// Sets the iteration limit.
    #[must_use]
    pub fn with_max_iterations(mut self, max_iterations: usize) -> Self {
        self.max_iterations = max_iterations;
        self
    }

    /// Sets the precision.
    #[must_use]
    pub fn with_precision(mut self, precision: Precision) -> Self {
        self.precision = precision;
        self
    }

    /// Sets the monitor.
    #[must_use]
    pub fn with_monitor(mut self, monitor: Monitor<'a>) -> Self {
        self.monitor = Some(monitor);
        self
    }

    /// Calls the monitor, if any, after iteration `it` with the relative residuals `rel`.
    ///
    /// # Errors
    /// [`SparseError::Cancelled`] when it returns `false`.
    fn report(&self, it: usize, rel: [f64; 3]) -> Result<(), SparseError> {
        match self.monitor {
            Some(m) if !m(it, rel) => Err(SparseError::Cancelled { iteration: it }),
            _ => Ok(()),
        }
    }

    fn validate(&self) -> Result<(), SparseError> {
        if !(self.tolerance.is_finite() && self.tolerance >= 0.0) {
            return Err(SparseError::InvalidOption(format!("tolerance {} must be finite and non-negative", self.tolerance)));
        }
        Ok(())
    }
}

impl fmt::Debug for SolveOptions<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SolveOptions")
            .field("tolerance", &self.tolerance)
            .field("max_iterations", &self.max_iterations)
            .field("monitor", &self.monitor.is_some())
            .field("precision", &self.precision)
            .finish()
    }
}

/// What a solve did, per channel.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
#[must_use]
pub struct SolveStats {
    /// Iterations each channel took (0 when the initial guess already met the tolerance or the
    /// right-hand side is zero).
    pub iterations: [usize; 3],
    /// The true final relative residual `‖b − Ax‖ / ‖b‖` per channel, recomputed from `x`
    /// (0 for a zero right-hand side).
    pub relative_residual: [f64; 3],
    /// Whether each channel met the tolerance.
    pub converged_channels: [bool; 3],
    /// Whether all three channels met the tolerance.
    pub converged: bool,
}

/// Checks the common inputs of a three-channel solve; returns the per-channel ‖b‖.
fn check_inputs(
    a: &CsrMatrix3,
    b: &[[f64; 3]],
    x: &[[f64; 3]],
    precond: &Preconditioner,
    options: &SolveOptions<'_>,
) -> Result<[f64; 3], SparseError> {
    options.validate()?;
    let n = a.n();
    if b.len() != n {
        return Err(SparseError::DimensionMismatch { what: "right-hand side length", expected: n, found: b.len() });
    }
    if x.len() != n {
        return Err(SparseError::DimensionMismatch { what: "initial guess length", expected: n, found: x.len() });
    }
    precond.check_matrix(a)?;
    if let Some((row, channel, value)) = ops::first_non_finite(b) {
        return Err(SparseError::NonFinite { what: "right-hand side", row, channel, value });
    }
    if let Some((row, channel, value)) = ops::first_non_finite(x) {
        return Err(SparseError::NonFinite { what: "initial guess", row, channel, value });
    }
    a.check_finite()?;
    let bn = norm3(b);
    if let Some(c) = bn.iter().position(|v| !v.is_finite()) {
        return Err(SparseError::InvalidOption(format!(
            "the right-hand side norm overflows on channel {} ({}); rescale the system",
            c, CHANNEL_NAMES[c]
        )));
    }
    Ok(bn)
}

/// `r = b − A x`; returns `‖r‖²` per channel.
fn residual(a: &CsrMatrix3, b: &[[f64; 3]], x: &[[f64; 3]], r: &mut [[f64; 3]]) -> [f64; 3] {
    ops::spmv_fold(a.pattern(), a.values(), x, r, |i, ax, ri| {
        let bi = b[i];
        *ri = [bi[0] - ax[0], bi[1] - ax[1], bi[2] - ax[2]];
        [ri[0] * ri[0], ri[1] * ri[1], ri[2] * ri[2]]
    })
}

/// `‖r‖ / ‖b‖` per channel, 0 where `b = 0`.
fn relative(rr: [f64; 3], bn: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|c| if bn[c] > 0.0 { rr[c].sqrt() / bn[c] } else { 0.0 })
}

/// The channels whose relative residual `rel` misses the tolerance (never one whose
/// right-hand side is zero: `‖b‖ = bn = 0`).
fn unconverged(rel: [f64; 3], bn: [f64; 3], tol: f64) -> [bool; 3] {
    [0, 1, 2].map(|c| bn[c] > 0.0 && rel[c] > tol)
}

/// How often a solve may restart channels after checking its true residual.
const MAX_RESTARTS: usize = 3;

/// After a check of the true residuals `rel` (once the recursive ones met the tolerance): the
/// channels to restart from it, those that miss the tolerance, or `None` when none does or the
/// solve has restarted [`MAX_RESTARTS`] times already (`restarts`, counted here).
fn restart(rel: [f64; 3], bn: [f64; 3], tol: f64, restarts: &mut usize) -> Option<[bool; 3]> {
    let again = unconverged(rel, bn, tol);
    if !again.iter().any(|&t| t) || *restarts == MAX_RESTARTS {
        return None;
    }
    *restarts += 1;
    Some(again)
}
