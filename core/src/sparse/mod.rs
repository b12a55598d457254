//! Sparse linear algebra for the diffusion solvers: CSR matrices with one pattern shared by the
//! three colour channels, a parallel SpMV, preconditioned CG, BiCGSTAB and preconditioners.
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
//! # Choosing a preconditioner (measured)
//!
//! Proxy: the vertex graph of a Kuhn-tetrahedralised 44³ grid (n = 85 184, 14.5 nonzeros per
//! row, like a tet mesh), the TransCut matrix shape (edge weights ∝ κ h, lumped σa V mass,
//! Robin term on the boundary) with marble's per-channel σa, σ′s on a 20 mm cube, `b` nonzero on
//! the boundary only; cold start, tolerance 1e-6, release build (`cargo test --release -p
//! transcut --test sparse -- --ignored --nocapture bench_`). The machine was shared with other
//! builds (load 4–8 on 2 cores), so the stable figure is the CPU time of a one-thread solve
//! (per-thread accounting, min of 3–7 interleaved rounds; the range over the runs, whose
//! ranking never changed; Chebyshev with its interval ratio 60, tuned on iteration counts, see
//! [`Chebyshev::RATIO`]):
//!
//! | preconditioner | iterations R/G/B | Mixed: 1-thread CPU ms | Double: 1-thread CPU ms |
//! |----------------|------------------|------------------------|-------------------------|
//! | Jacobi         | 117/112/106      | **246–281**            | 288–352                 |
//! | Chebyshev 1    | 70/67/64         | 305–310                | 360–362                 |
//! | Chebyshev 2    | 47/45/43         | 317–318                | 337–381                 |
//! | Chebyshev 3    | 36/34/33         | 311–345                | 332–351                 |
//! | Chebyshev 4    | 29/28/27         | 306–333                | 319–351                 |
//!
//! Every solve met 1e-6 on the `f64` residual; mixed and double iteration counts agree to ±1.
//! **Jacobi is the default**: a Chebyshev step removes iterations at about the rate it adds
//! matrix passes (`degree` passes of the `f32` operator per iteration, each with its vector
//! updates), the iteration is bound by memory traffic, and Jacobi does the fewest flops. By
//! bytes streamed per solve (the model below) Chebyshev 4 would be about 5% ahead of Jacobi
//! (≈ 5.2 against 5.5 GB), within the noise of these measurements; worth re-measuring on a quiet
//! machine, 2 threads. The traffic per Jacobi iteration is 43.8 MB mixed (f32 operator
//! 16 B/nonzero: 20.4 MB; vectors 23.4 MB) against 61.8 MB in `f64`; a three-channel f64 SpMV
//! alone streams 39 MB and took 0.90–1.0 ms on 2 threads (≈ 40 GB/s) in the quietest moments,
//! 2.0 ms on one. A quiet 2-core cold solve should thus take about 5.5 GB / 40 GB/s ≈ 135 ms
//! (mixed, Jacobi, including ~9 `f64` residual recomputations), above the 100 ms goal; wall times
//! measured under the load were 280–400 ms. Preconditioner setup (inverse diagonal and the
//! `f32` scaled copy) takes 8–35 ms and is reused while the matrix values do not change.
//! Rounding the matrix itself to `f32` leaves a residual floor of 1e-6 to 2.2e-6 on this system,
//! which is why `f32` is only used inside the iteration, with `f64` residuals (see
//! [`Precision`]).
//!
//! **SSOR** ([`Ssor`], added later and measured on the real 500k-tet bunny system rather than
//! this proxy) takes a quarter of Jacobi's iterations, but each costs about two Jacobi
//! iterations (its sweeps wait on the row just computed) and its setup (a level-set ordering
//! and the reordered triangles) about 90 ms: its solve takes 0.66 of Jacobi's time, a cold
//! bake's setup and solve together only ~6% less. Jacobi stays the default.
//!
//! # Errors
//!
//! Every fallible call returns [`SparseError`], naming the channel, row or iteration at fault.

mod bicgstab;
mod csr;
mod eisenstat_cg;
mod error;
#[cfg(test)]
mod fixtures;
pub mod hierarchy;
mod mm;
mod ops;
mod ordering;
mod pcg;
mod precond;
mod scaled;
mod ssor;

pub use bicgstab::bicgstab;
pub use csr::{CsrMatrix, CsrMatrix3, CsrPattern, Entry, Triplet};
pub use error::{SparseError, CHANNEL_NAMES};
pub use mm::{
    read_array_matrix_market, write_array_matrix_market, write_vector3_matrix_market, write_vector_matrix_market, MmArray,
};
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
    /// itself if the `f32` operator stops resolving the residual. Streams about 30% fewer bytes
    /// per iteration for the same iteration count, 15–30% less time (see the module
    /// documentation). With [`Preconditioner::Identity`] the solve runs in
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
