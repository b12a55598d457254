//! Single GPU kernels run on their own, the twins of CPU operations, for tests and for callers
//! that want one operation on the device: SpMV with the fused pᵀAp ([`spmv_dot`]) and the dot
//! product with its two-level tree reduction ([`dot`]).

use super::context::{dispatch, GpuContext};
use super::error::GpuError;
use super::layout::{from_vec4, to_vec4, Params};
use super::matrix::DeviceMatrix;
use super::shaders::Kernel;
use crate::diffusion::DiffusionError;
use crate::sparse::CsrMatrix3;

fn check_len(what: &'static str, expected: usize, found: usize) -> Result<(), GpuError> {
    if expected == found {
        Ok(())
    } else {
        Err(DiffusionError::LengthMismatch { what, expected, found }.into())
    }
}

/// `y = A x` and `xᵀA x` per channel on the device (`spmv_dot.wgsl` then `reduce_sum.wgsl`), with
/// the matrix and `x` rounded to f32. CPU twins: [`CsrMatrix3::spmv`] and [`crate::sparse::dot3`].
///
/// # Errors
/// [`GpuError::Diffusion`] with a length mismatch unless `x` has `A.n()` entries; device errors.
pub fn spmv_dot(ctx: &GpuContext, a: &CsrMatrix3, x: &[[f64; 3]]) -> Result<(Vec<[f64; 3]>, [f64; 3]), GpuError> {
    check_len("x (one entry per matrix row)", a.n(), x.len())?;
    let m = DeviceMatrix::upload(ctx, a, Params::default())?;
    let n = a.n();
    let p = ctx.upload(&to_vec4(x), "x")?;
    let q = ctx.storage(16 * n as u64, "A x")?;
    let partials = ctx.storage(16 * u64::from(m.n_groups), "partial sums")?;
    let total = ctx.storage(16, "sum")?;
    let bind = ctx.bind(Kernel::SpmvDot, &[&m.params, &m.row_ptr, &m.col_idx, &m.values, &p, &q, &partials]);
    let bind_sum = ctx.bind(Kernel::ReduceSum, &[&m.params, &partials, &total]);
    let mut encoder = ctx.encoder();
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("spmv"), timestamp_writes: None });
        dispatch(&mut pass, ctx, Kernel::SpmvDot, &bind, m.grid);
        dispatch(&mut pass, ctx, Kernel::ReduceSum, &bind_sum, (1, 1));
    }
    let sum = from_vec4(&ctx.read_back(encoder, &total, 16, "spmv")?, 1)[0];
    let y = from_vec4(&ctx.read_back(ctx.encoder(), &q, 16 * n as u64, "spmv read-back")?, n);
    Ok((y, sum))
}

/// `aᵀb` per channel on the device (`dot.wgsl`: per-workgroup tree reductions, then
/// `reduce_sum.wgsl` over the partial sums), with the inputs rounded to f32.
/// CPU twin: [`crate::sparse::dot3`].
///
/// # Errors
/// [`GpuError::Diffusion`] with a length mismatch unless `a` and `b` have the same length; device
/// errors.
pub fn dot(ctx: &GpuContext, a: &[[f64; 3]], b: &[[f64; 3]]) -> Result<[f64; 3], GpuError> {
    check_len("second vector of a dot product", a.len(), b.len())?;
    let n = a.len();
    let (gx, gy, n_groups) = ctx.grid(n)?;
    let params = Params { n: u32::try_from(n).unwrap_or(u32::MAX), n_groups, ..Params::default() };
    let params = ctx.uniform(&params, "params");
    let ab = ctx.upload(&to_vec4(a), "a")?;
    let bb = ctx.upload(&to_vec4(b), "b")?;
    let partials = ctx.storage(16 * u64::from(n_groups), "partial sums")?;
    let total = ctx.storage(16, "sum")?;
    let bind = ctx.bind(Kernel::Dot, &[&params, &ab, &bb, &partials]);
    let bind_sum = ctx.bind(Kernel::ReduceSum, &[&params, &partials, &total]);
    let mut encoder = ctx.encoder();
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("dot"), timestamp_writes: None });
        dispatch(&mut pass, ctx, Kernel::Dot, &bind, (gx, gy));
        dispatch(&mut pass, ctx, Kernel::ReduceSum, &bind_sum, (1, 1));
    }
    Ok(from_vec4(&ctx.read_back(encoder, &total, 16, "dot")?, 1)[0])
}
