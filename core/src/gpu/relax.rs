//! Relaxation on the device, the twin of [`crate::sparse::relax`]: the smoothers of the
//! polygrid diffusion's coarse-to-fine relaxation (J. Wang et al. 2008, §5.2–5.3), in f32.
//!
//! A [`GpuRelaxation`] uploads a matrix, a right-hand side and a start vector once, then runs
//! sweeps entirely on the device — weighted Jacobi (`relax_jacobi.wgsl`, from one of two
//! vectors into the other) or coloured Gauss–Seidel (`relax_gs.wgsl`, one dispatch per colour
//! over that colour's active rows, in place) — with frozen rows, and reads the solution back
//! only when asked. Between the levels of a hierarchy, [`GpuTransfer`] holds a rectangular
//! operator `P` (fine × coarse, one f32 weight per entry) and its transpose, built on the host
//! so that both `x_fine += P x_coarse` and `b_coarse = Pᵀ b_fine` are gathers (no atomics, a
//! fixed summation order): the multigrid's transfer kernels (`mg_prolong.wgsl`,
//! `mg_restrict.wgsl`), which apply any such operator, move vectors between two
//! `GpuRelaxation`s without leaving the device. For one transfer on its own, see
//! [`super::prolong_add`] and [`super::restrict`].
//!
//! A coarse-to-fine pass:
//!
//! ```no_run
//! # use transcut::gpu::{GpuContext, GpuRelaxation, GpuTransfer};
//! # use transcut::sparse::{hierarchy::Prolongation, relax::Colouring, CsrMatrix3};
//! # fn demo(ctx: &GpuContext, coarse: &CsrMatrix3, fine: &CsrMatrix3, p: &Prolongation,
//! #         b_coarse: &[[f64; 3]], b_fine: &[[f64; 3]]) -> Result<(), transcut::gpu::GpuError> {
//! let mut c = GpuRelaxation::new(ctx, coarse, b_coarse, &vec![[0.0; 3]; coarse.n()])?;
//! c.set_colouring(&Colouring::greedy(coarse.pattern()))?;
//! c.gauss_seidel(50, false)?;
//! let mut f = GpuRelaxation::new(ctx, fine, b_fine, &vec![[0.0; 3]; fine.n()])?;
//! f.set_colouring(&Colouring::greedy(fine.pattern()))?;
//! f.prolong_add_from(&c, &GpuTransfer::upload(ctx, p)?)?; // x_fine = P x_coarse
//! f.gauss_seidel(50, false)?;
//! let x = f.solution()?;
//! # let _ = x; Ok(()) }
//! ```
//!
//! The arithmetic is the CPU twin's in f32 (the matrix, vectors and ω rounded to f32): each row
//! is summed in column order, a Gauss–Seidel colour is updated from the values the colours
//! before it left, and frozen rows keep their f32 value bit for bit.

use std::sync::Arc;

use bytemuck::{Pod, Zeroable};

use super::context::{dispatch, GpuContext};
use super::error::GpuError;
use super::layout::{from_vec4, to_vec4, Params};
use super::multigrid::DeviceTransfer;
use super::pool::Lease;
use super::shaders::Kernel;
use crate::diffusion::DiffusionError;
use crate::sparse::hierarchy::Prolongation;
use crate::sparse::relax::{usable_diagonal, Colouring};
use crate::sparse::{CsrMatrix3, CsrPattern, SparseError};

/// Sweeps recorded per command buffer (a submission; a very long run is split so that no
/// command buffer grows without bound).
const SWEEPS_PER_SUBMIT: usize = 256;

/// `Relax` of `relax_jacobi.wgsl` and `relax_gs.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, Pod, Zeroable)]
struct RelaxParams {
    n: u32,
    offset: u32,
    omega: f32,
    pad: u32,
}

fn to_u32(v: usize, what: &'static str) -> Result<u32, GpuError> {
    u32::try_from(v).map_err(|_| GpuError::TooLarge { what, needed: v as u64, limit: u64::from(u32::MAX), device: String::new() })
}

fn check_len(what: &'static str, expected: usize, found: usize) -> Result<(), GpuError> {
    if expected == found {
        Ok(())
    } else {
        Err(DiffusionError::LengthMismatch { what, expected, found }.into())
    }
}

fn sparse(e: SparseError) -> GpuError {
    DiffusionError::Sparse(e).into()
}

/// A rectangular operator `P` (fine × coarse) and its transpose on the device, one f32 weight
/// per entry shared by the three channels: the transfers of a hierarchy (see
/// [`GpuRelaxation::prolong_add_from`] and [`GpuRelaxation::restrict_rhs_from`]). Build `P` on
/// the host with [`Prolongation::from_csr`] (any sparse operator) or take a multigrid
/// hierarchy's.
pub struct GpuTransfer<'c> {
    inner: DeviceTransfer<'c>,
    n_fine: usize,
    n_coarse: usize,
}

impl std::fmt::Debug for GpuTransfer<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuTransfer").field("n_fine", &self.n_fine).field("n_coarse", &self.n_coarse).finish()
    }
}

impl<'c> GpuTransfer<'c> {
    /// Uploads `P` and `Pᵀ` (weights rounded to f32).
    ///
    /// # Errors
    /// Device errors ([`GpuError::TooLarge`] for an operator too large for one buffer).
    pub fn upload(ctx: &'c GpuContext, p: &Prolongation) -> Result<Self, GpuError> {
        Ok(Self { inner: DeviceTransfer::upload(ctx, p)?, n_fine: p.n_fine(), n_coarse: p.n_coarse() })
    }

    /// Rows of `P` (fine vertices).
    #[must_use]
    pub fn n_fine(&self) -> usize {
        self.n_fine
    }

    /// Columns of `P` (coarse vertices).
    #[must_use]
    pub fn n_coarse(&self) -> usize {
        self.n_coarse
    }
}

/// The active rows of a colouring on the device: one list, colour after colour, and one
/// dispatch per colour that has any.
struct DeviceColours<'c> {
    /// Kept so that it outlives the bind groups made from it.
    rows: Lease<'c>,
    /// Per colour with an active row, in colour order: its `Relax` uniform (count, offset), its
    /// grid and its count.
    passes: Vec<(Lease<'c>, (u32, u32), usize)>,
}

/// A system `A x = b` on the device for relaxation sweeps (see the module documentation):
/// `A` as CSR with three f32 values per entry, `b`, two vectors for `x` (Jacobi alternates
/// them), the diagonal with an active flag per row and, once set, a colouring's row lists.
pub struct GpuRelaxation<'c> {
    ctx: &'c GpuContext,
    n: usize,
    pattern: Arc<CsrPattern>,
    /// The diagonal in f64 (for the checks of the active rows).
    diagonal: Vec<[f64; 3]>,
    /// Whether the active rows' diagonal has been checked since the mask last changed.
    checked: bool,
    /// `Params` with `n` (the transfer kernels' uniform).
    params: Lease<'c>,
    grid: (u32, u32),
    row_ptr: Lease<'c>,
    col_idx: Lease<'c>,
    values: Lease<'c>,
    b: Lease<'c>,
    /// `a_ii` per channel, w = 1 for an active row, 0 for a frozen one.
    diag: Lease<'c>,
    x: [Lease<'c>; 2],
    /// `x` lives in `x[cur]`.
    cur: usize,
    active: Option<Vec<bool>>,
    active_count: usize,
    colouring: Option<Colouring>,
    colours: Option<DeviceColours<'c>>,
}

impl std::fmt::Debug for GpuRelaxation<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuRelaxation")
            .field("n", &self.n)
            .field("active", &self.active_count)
            .field("colours", &self.colouring.as_ref().map(Colouring::count))
            .finish()
    }
}

impl<'c> GpuRelaxation<'c> {
    /// Uploads `matrix`, `b` and the start vector `x0` (rounded to f32), every row active and
    /// no colouring.
    ///
    /// # Errors
    /// [`GpuError::Diffusion`] with a length mismatch unless `b` and `x0` have one entry per
    /// row; [`GpuError::TooLarge`] and device errors.
    pub fn new(ctx: &'c GpuContext, matrix: &CsrMatrix3, b: &[[f64; 3]], x0: &[[f64; 3]]) -> Result<Self, GpuError> {
        let n = matrix.n();
        check_len("right-hand side (one entry per matrix row)", n, b.len())?;
        check_len("start vector (one entry per matrix row)", n, x0.len())?;
        let pattern = Arc::clone(matrix.pattern());
        let nnz = to_u32(pattern.nnz(), "matrix nonzeros")?;
        let row_ptr: Vec<u32> = pattern.row_ptr().iter().map(|&p| p as u32).collect();
        let values: Vec<f32> = matrix.values().iter().flat_map(|v| v.map(|x| x as f32)).collect();
        let diagonal = matrix.diagonal();
        let (gx, gy, n_groups) = ctx.grid(n)?;
        let params = Params { n: to_u32(n, "matrix rows")?, nnz, n_groups, ..Params::default() };
        let xv = to_vec4(x0);
        let relax = Self {
            ctx,
            n,
            diagonal,
            checked: false,
            params: ctx.uniform(&params, "relaxation params"),
            grid: (gx, gy),
            row_ptr: ctx.upload(&row_ptr, "relaxation row_ptr")?,
            col_idx: ctx.upload(pattern.col_idx(), "relaxation col_idx")?,
            values: ctx.upload(&values, "relaxation matrix values")?,
            b: ctx.upload(&to_vec4(b), "relaxation rhs")?,
            diag: ctx.storage(16 * n as u64, "relaxation diagonal")?,
            x: [ctx.upload(&xv, "relaxation x")?, ctx.upload(&xv, "relaxation x'")?],
            cur: 0,
            pattern,
            active: None,
            active_count: n,
            colouring: None,
            colours: None,
        };
        relax.write_diagonal();
        Ok(relax)
    }

    /// Rows.
    #[must_use]
    pub fn n(&self) -> usize {
        self.n
    }

    /// Rows that sweeps update (not frozen).
    #[must_use]
    pub fn active_rows(&self) -> usize {
        self.active_count
    }

    /// Writes the diagonal with the active flags.
    fn write_diagonal(&self) {
        let d: Vec<[f32; 4]> = self
            .diagonal
            .iter()
            .enumerate()
            .map(|(i, d)| {
                let on = self.active.as_ref().is_none_or(|a| a[i]);
                [d[0] as f32, d[1] as f32, d[2] as f32, if on { 1.0 } else { 0.0 }]
            })
            .collect();
        self.ctx.queue().write_buffer(&self.diag, 0, bytemuck::cast_slice(&d));
    }

    /// Freezes the rows whose flag is `false` (they keep their value; the others read them as
    /// fixed), or with `None` makes every row active again.
    ///
    /// # Errors
    /// [`GpuError::Diffusion`] with a length mismatch unless `active` has one flag per row.
    pub fn set_active(&mut self, active: Option<&[bool]>) -> Result<(), GpuError> {
        if let Some(a) = active {
            check_len("active flags (one per row)", self.n, a.len())?;
        }
        self.active = active.map(<[bool]>::to_vec);
        self.active_count = active.map_or(self.n, |a| a.iter().filter(|&&f| f).count());
        self.checked = false;
        self.write_diagonal();
        self.upload_colours()
    }

    /// Sets the colouring of the Gauss–Seidel sweeps.
    ///
    /// # Errors
    /// [`GpuError::Diffusion`] with [`SparseError::DimensionMismatch`] or
    /// [`SparseError::ColouringConflict`] if the colouring does not fit the matrix
    /// ([`Colouring::check`]); device errors.
    pub fn set_colouring(&mut self, colouring: &Colouring) -> Result<(), GpuError> {
        colouring.check(&self.pattern).map_err(sparse)?;
        self.colouring = Some(colouring.clone());
        self.upload_colours()
    }

    /// The active rows of each colour, on the device.
    fn upload_colours(&mut self) -> Result<(), GpuError> {
        let Some(colouring) = &self.colouring else { return Ok(()) };
        let active = self.active.as_deref();
        let mut rows: Vec<u32> = Vec::with_capacity(self.active_count);
        let mut passes = Vec::new();
        for (c, count) in colouring.active_passes(active) {
            let offset = rows.len();
            rows.extend(colouring.rows(c).iter().filter(|&&i| active.is_none_or(|a| a[i as usize])));
            let uniform = RelaxParams { n: count as u32, offset: offset as u32, ..RelaxParams::default() };
            let (gx, gy, _) = self.ctx.grid(count)?;
            passes.push((self.ctx.uniform(&uniform, "colour"), (gx, gy), count));
        }
        // A buffer is never empty (the pool's smallest is 256 bytes).
        let rows = self.ctx.upload(&rows, "colour rows")?;
        self.colours = Some(DeviceColours { rows, passes });
        Ok(())
    }

    /// Checks, once per mask, that the active rows' diagonal is usable, in f64 as the CPU twin
    /// does and in f32 as the device computes.
    fn check_diagonal(&mut self) -> Result<(), GpuError> {
        if self.checked {
            return Ok(());
        }
        for (i, d) in self.diagonal.iter().enumerate() {
            if self.active.as_ref().is_some_and(|a| !a[i]) {
                continue;
            }
            if let Some(channel) = (0..3).find(|&c| !usable_diagonal(d[c])) {
                return Err(sparse(SparseError::UnusableDiagonal { row: i, channel, value: d[channel] }));
            }
            if (0..3).any(|c| !usable_diagonal(f64::from(d[c] as f32))) {
                return Err(GpuError::Unsupported {
                    what: "a diagonal entry that f32 rounds to zero or infinity (the device relaxes in f32)",
                });
            }
        }
        self.checked = true;
        Ok(())
    }

    /// Records `sweeps` sweeps, `record(pass, k)` each, in command buffers of
    /// [`SWEEPS_PER_SUBMIT`]; waits for the last.
    fn run(
        &self,
        sweeps: usize,
        label: &'static str,
        mut record: impl FnMut(&mut wgpu::ComputePass<'_>, usize),
    ) -> Result<(), GpuError> {
        let mut done = 0;
        while done < sweeps {
            let batch = (sweeps - done).min(SWEEPS_PER_SUBMIT);
            let mut encoder = self.ctx.encoder();
            {
                let mut pass =
                    encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: None });
                for k in done..done + batch {
                    record(&mut pass, k);
                }
            }
            done += batch;
            if done < sweeps {
                self.ctx.queue().submit([encoder.finish()]);
            } else {
                self.ctx.submit_wait(encoder, label)?;
            }
        }
        Ok(())
    }

    /// `sweeps` weighted Jacobi sweeps `x ← x + ω D⁻¹ (b − A x)` on the device, no read-back
    /// (`relax_jacobi.wgsl`). CPU twin: [`crate::sparse::relax::jacobi_sweep`].
    ///
    /// Returns the number of row updates: `sweeps` times the active rows.
    ///
    /// # Errors
    /// [`GpuError::Diffusion`] with [`SparseError::InvalidOption`] unless `ω` is finite and
    /// positive, or [`SparseError::UnusableDiagonal`] naming the first active row whose
    /// diagonal is zero or not finite; [`GpuError::Unsupported`] for a diagonal that f32 cannot
    /// hold; device errors.
    pub fn jacobi(&mut self, sweeps: usize, omega: f64) -> Result<usize, GpuError> {
        if !(omega.is_finite() && omega > 0.0) {
            return Err(sparse(SparseError::InvalidOption(format!("Jacobi damping ω = {omega} must be finite and positive"))));
        }
        self.check_diagonal()?;
        let uniform = RelaxParams { n: self.n as u32, offset: 0, omega: omega as f32, pad: 0 };
        let uniform = self.ctx.uniform(&uniform, "jacobi");
        let bind = |from: usize| {
            self.ctx.bind(
                Kernel::RelaxJacobi,
                &[&uniform, &self.row_ptr, &self.col_idx, &self.values, &self.b, &self.diag, &self.x[from], &self.x[1 - from]],
            )
        };
        let binds = [bind(0), bind(1)];
        let cur = self.cur;
        self.run(sweeps, "Jacobi sweeps", |pass, k| {
            dispatch(pass, self.ctx, Kernel::RelaxJacobi, &binds[(cur + k) % 2], self.grid);
        })?;
        self.cur = (cur + sweeps) % 2;
        Ok(sweeps * self.active_count)
    }

    /// `sweeps` coloured Gauss–Seidel sweeps on the device, no read-back (`relax_gs.wgsl`, one
    /// dispatch per colour with an active row, in colour order; with `symmetric` back again
    /// without the last colour, as the CPU twin
    /// [`crate::sparse::relax::coloured_gauss_seidel_sweep`] does).
    ///
    /// Returns the number of row updates.
    ///
    /// # Errors
    /// [`GpuError::Unsupported`] before [`Self::set_colouring`]; [`GpuError::Diffusion`] with
    /// [`SparseError::UnusableDiagonal`] naming the first active row whose diagonal is zero or
    /// not finite; [`GpuError::Unsupported`] for a diagonal that f32 cannot hold; device errors.
    pub fn gauss_seidel(&mut self, sweeps: usize, symmetric: bool) -> Result<usize, GpuError> {
        if self.colours.is_none() {
            return Err(GpuError::Unsupported {
                what: "a Gauss–Seidel sweep without a colouring (GpuRelaxation::set_colouring)",
            });
        }
        self.check_diagonal()?;
        let Some(colours) = &self.colours else { unreachable!("checked above") };
        let x = &self.x[self.cur];
        let binds: Vec<wgpu::BindGroup> = colours
            .passes
            .iter()
            .map(|(uniform, _, _)| {
                self.ctx.bind(
                    Kernel::RelaxGaussSeidel,
                    &[uniform, &self.row_ptr, &self.col_idx, &self.values, &self.b, &self.diag, &colours.rows, x],
                )
            })
            .collect();
        let mut order: Vec<usize> = (0..colours.passes.len()).collect();
        if symmetric {
            order.extend((0..colours.passes.len()).rev().skip(1));
        }
        let per_sweep: usize = order.iter().map(|&p| colours.passes[p].2).sum();
        self.run(sweeps, "Gauss–Seidel sweeps", |pass, _| {
            for &p in &order {
                dispatch(pass, self.ctx, Kernel::RelaxGaussSeidel, &binds[p], colours.passes[p].1);
            }
        })?;
        Ok(sweeps * per_sweep)
    }

    /// Replaces `x` (rounded to f32).
    ///
    /// # Errors
    /// [`GpuError::Diffusion`] with a length mismatch unless `x` has one entry per row.
    pub fn set_solution(&mut self, x: &[[f64; 3]]) -> Result<(), GpuError> {
        check_len("solution (one entry per matrix row)", self.n, x.len())?;
        self.ctx.queue().write_buffer(&self.x[self.cur], 0, bytemuck::cast_slice(&to_vec4(x)));
        Ok(())
    }

    /// Replaces `b` (rounded to f32).
    ///
    /// # Errors
    /// [`GpuError::Diffusion`] with a length mismatch unless `b` has one entry per row.
    pub fn set_rhs(&mut self, b: &[[f64; 3]]) -> Result<(), GpuError> {
        check_len("right-hand side (one entry per matrix row)", self.n, b.len())?;
        self.ctx.queue().write_buffer(&self.b, 0, bytemuck::cast_slice(&to_vec4(b)));
        Ok(())
    }

    /// `x += P x_coarse` on the device (`mg_prolong.wgsl`), `x_coarse` the solution of
    /// `coarse`: the coarse-to-fine step (on a zero `x`, the interpolated start). Frozen rows
    /// are updated too: the transfer is the caller's to shape. CPU twin:
    /// [`Prolongation::prolong_add`].
    ///
    /// # Errors
    /// [`GpuError::Diffusion`] with a length mismatch unless this system has `p.n_fine()` rows
    /// and `coarse` `p.n_coarse()`; device errors.
    pub fn prolong_add_from(&mut self, coarse: &GpuRelaxation<'_>, p: &GpuTransfer<'_>) -> Result<(), GpuError> {
        check_len("fine rows (rows of P)", p.n_fine, self.n)?;
        check_len("coarse rows (columns of P)", p.n_coarse, coarse.n)?;
        let t = &p.inner;
        let bind = self.ctx.bind(
            Kernel::MgProlong,
            &[&self.params, &t.p_ptr, &t.p_cols, &t.p_weights, &coarse.x[coarse.cur], &self.x[self.cur]],
        );
        self.run(1, "prolongation", |pass, _| dispatch(pass, self.ctx, Kernel::MgProlong, &bind, self.grid))
    }

    /// `b = Pᵀ b_fine` on the device (`mg_restrict.wgsl`), `b_fine` the right-hand side of
    /// `fine`. CPU twin: [`Prolongation::restrict`].
    ///
    /// # Errors
    /// [`GpuError::Diffusion`] with a length mismatch unless this system has `p.n_coarse()`
    /// rows and `fine` `p.n_fine()`; device errors.
    pub fn restrict_rhs_from(&mut self, fine: &GpuRelaxation<'_>, p: &GpuTransfer<'_>) -> Result<(), GpuError> {
        check_len("coarse rows (columns of P)", p.n_coarse, self.n)?;
        check_len("fine rows (rows of P)", p.n_fine, fine.n)?;
        let t = &p.inner;
        let bind = self.ctx.bind(Kernel::MgRestrict, &[&self.params, &t.t_ptr, &t.t_rows, &t.t_weights, &fine.b, &self.b]);
        self.run(1, "restriction", |pass, _| dispatch(pass, self.ctx, Kernel::MgRestrict, &bind, self.grid))
    }

    /// Reads `x` back (f32 widened to f64).
    ///
    /// # Errors
    /// Device errors.
    pub fn solution(&self) -> Result<Vec<[f64; 3]>, GpuError> {
        let bytes = self.ctx.read_back(self.ctx.encoder(), &self.x[self.cur], 16 * self.n as u64, "relaxation read-back")?;
        Ok(from_vec4(&bytes, self.n))
    }

    /// Reads `b` back (f32 widened to f64), e.g. after [`Self::restrict_rhs_from`].
    ///
    /// # Errors
    /// Device errors.
    pub fn rhs(&self) -> Result<Vec<[f64; 3]>, GpuError> {
        let bytes = self.ctx.read_back(self.ctx.encoder(), &self.b, 16 * self.n as u64, "relaxation rhs read-back")?;
        Ok(from_vec4(&bytes, self.n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relax_params_match_the_wgsl_layout() {
        // WGSL Relax: u32, u32, f32, u32.
        assert_eq!(size_of::<RelaxParams>(), 16);
    }
}
