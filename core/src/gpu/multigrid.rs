//! The multigrid V-cycle of [`crate::sparse::hierarchy`] on the device, the preconditioner of
//! the device MG-PCG ([`super::GpuSolver::with_multigrid`]); the hierarchy, the Galerkin
//! operators `A^{l+1} = Pᵀ A^l P`, the smoothers' `λmax` and the coarsest factorisation are built
//! on the CPU ([`Multigrid::new`]) and uploaded once, in f32.
//!
//! One V-cycle `z = B r` is a fixed list of dispatches, recorded into the same compute pass as
//! the CG iteration (no read-back, no host work), per level `l` above the coarsest:
//!
//! 1. pre-smoothing from `z = 0`: `degree` Chebyshev–Jacobi steps (`mg_smooth.wgsl`, each
//!    `d = a d + b D⁻¹(r − A z)`, `z' = z + d`, into the other of two `z` buffers);
//! 2. `res = r − A z` (`mg_residual.wgsl`), `r_{l+1} = Pᵀ res` (`mg_restrict.wgsl`, `Pᵀ` stored
//!    as CSR: a gather per coarse vertex);
//! 3. the cycle of level `l + 1`, then `z += P z_{l+1}` (`mg_prolong.wgsl`, TransCut eq. 16);
//! 4. post-smoothing: the same `degree` steps from the current `z`.
//!
//! At the coarsest level `z = A_c⁻¹ r` (`mg_coarse.wgsl`): the CPU applies its dense Cholesky
//! factor by forward and back substitution; on the device that would be 2 n_c dependent steps
//! (n_c up to 600 by default) in a single workgroup, one SM of a GPU working through ~1200
//! barriers, so the device applies the same map as a dense product with `A_c⁻¹` (computed once in
//! f64 from the Cholesky factor, column by column in parallel and exactly symmetric, rounded to
//! f32; n_c² × 12 bytes, 4.3 MB at
//! 600), one invocation per row reading row i as column i (symmetry), so neighbouring invocations
//! read neighbouring entries, every row in parallel and without barriers (one workgroup per row
//! with a tree reduction is no faster: the coarsest solve is not where a V-cycle's time goes). The rounding of `A_c⁻¹` (relative 6e-8 per
//! entry) is far below the f32 V-cycle's own rounding, and `B` stays symmetric up to rounding, as
//! CG needs. A fixed number of Jacobi-CG steps instead would make `B` depend on `r` nonlinearly
//! (CG is not a linear map), which breaks the symmetry CG needs of its preconditioner.
//!
//! P and Pᵀ hold one f32 weight per nonzero, shared by the three channels (the existing SpMV
//! kernel reads three values per nonzero and fuses a dot product nobody needs here, so the
//! transfers have their own gather kernels).

use bytemuck::{Pod, Zeroable};

use super::context::{dispatch, GpuContext};
use super::error::GpuError;
use super::layout::{from_vec4, to_vec4, Params};
use super::matrix::DeviceMatrix;
use super::pool::Lease;
use super::shaders::Kernel;
use crate::diffusion::DiffusionError;
use crate::sparse::hierarchy::{Multigrid, Prolongation};
use crate::sparse::CsrMatrix3;

/// `Cheb` of `mg_smooth.wgsl`: the coefficients of one Chebyshev step.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, Pod, Zeroable)]
struct Cheb {
    a: [f32; 4],
    b: [f32; 4],
    from_zero: u32,
    first: u32,
    pad: [u32; 2],
}

/// The coefficients of the `degree` steps of a Chebyshev smoothing over `[λmax/ratio, λmax]`
/// of `D⁻¹A`, per channel, as `chebyshev_steps` of the CPU V-cycle (`sparse/hierarchy/multigrid/smoother.rs`)
/// computes them: step 0 `d = D⁻¹ res / θ`; step `k > 0` `ρ_k = 1/(2σ − ρ_{k−1})`, `d = ρ_k ρ_{k−1} d + 2ρ_k/δ D⁻¹ res`
/// (θ, δ the interval's centre and half-width, σ = θ/δ, ρ_0 = 1/σ). `pre`: the first step starts
/// from `z = 0`.
fn chebyshev(lambda_max: [f64; 3], degree: usize, ratio: f64, pre: bool) -> Vec<Cheb> {
    let theta = lambda_max.map(|h| 0.5 * (h + h / ratio));
    let delta = lambda_max.map(|h| 0.5 * (h - h / ratio));
    let sigma = [0, 1, 2].map(|c| theta[c] / delta[c]);
    let mut rho = sigma.map(|s| 1.0 / s);
    let v = |x: [f64; 3]| [x[0] as f32, x[1] as f32, x[2] as f32, 0.0];
    (0..degree)
        .map(|k| {
            if k == 0 {
                Cheb { a: [0.0; 4], b: v(theta.map(|t| 1.0 / t)), from_zero: u32::from(pre), first: 1, pad: [0; 2] }
            } else {
                let rho_new = [0, 1, 2].map(|c| 1.0 / (2.0 * sigma[c] - rho[c]));
                let a = [0, 1, 2].map(|c| rho_new[c] * rho[c]);
                let b = [0, 1, 2].map(|c| 2.0 * rho_new[c] / delta[c]);
                rho = rho_new;
                Cheb { a: v(a), b: v(b), from_zero: 0, first: 0, pad: [0; 2] }
            }
        })
        .collect()
}

fn to_u32(v: usize, what: &'static str) -> Result<u32, GpuError> {
    u32::try_from(v).map_err(|_| GpuError::TooLarge { what, needed: v as u64, limit: u64::from(u32::MAX), device: String::new() })
}

/// `Params` (n, workgroups) and the row grid of a level with `n` vertices.
fn level_params<'c>(ctx: &'c GpuContext, n: usize) -> Result<(Lease<'c>, (u32, u32)), GpuError> {
    let (gx, gy, groups) = ctx.grid(n)?;
    let params = Params { n: to_u32(n, "multigrid level vertices")?, n_groups: groups, ..Params::default() };
    Ok((ctx.uniform(&params, "multigrid level params"), (gx, gy)))
}

/// P (rows: fine vertices) and Pᵀ (rows: coarse vertices) of one level as CSR, f32 weights.
/// (Also the transfers of [`super::GpuTransfer`].)
pub(crate) struct DeviceTransfer<'c> {
    pub(crate) p_ptr: Lease<'c>,
    pub(crate) p_cols: Lease<'c>,
    pub(crate) p_weights: Lease<'c>,
    pub(crate) t_ptr: Lease<'c>,
    pub(crate) t_rows: Lease<'c>,
    pub(crate) t_weights: Lease<'c>,
}

impl<'c> DeviceTransfer<'c> {
    pub(crate) fn upload(ctx: &'c GpuContext, p: &Prolongation) -> Result<Self, GpuError> {
        let (mut p_ptr, mut p_cols, mut p_weights) = (vec![0u32], Vec::new(), Vec::new());
        for i in 0..p.n_fine() {
            let (cols, w) = p.row(i);
            p_cols.extend_from_slice(cols);
            p_weights.extend(w.iter().map(|&x| x as f32));
            p_ptr.push(to_u32(p_cols.len(), "interpolation nonzeros")?);
        }
        let (mut t_ptr, mut t_rows, mut t_weights) = (vec![0u32], Vec::new(), Vec::new());
        for c in 0..p.n_coarse() {
            let (rows, w) = p.column(c);
            t_rows.extend_from_slice(rows);
            t_weights.extend(w.iter().map(|&x| x as f32));
            t_ptr.push(t_rows.len() as u32);
        }
        Ok(Self {
            p_ptr: ctx.upload(&p_ptr, "P row_ptr")?,
            p_cols: ctx.upload(&p_cols, "P columns")?,
            p_weights: ctx.upload(&p_weights, "P weights")?,
            t_ptr: ctx.upload(&t_ptr, "Pᵀ row_ptr")?,
            t_rows: ctx.upload(&t_rows, "Pᵀ columns")?,
            t_weights: ctx.upload(&t_weights, "Pᵀ weights")?,
        })
    }
}

/// A level above the coarsest: its operator (level 0's is the solver's), smoother, vectors and
/// the transfers to and from level `l + 1`.
struct SmoothedLevel<'c> {
    params: Lease<'c>,
    grid: (u32, u32),
    /// The Galerkin operator; `None` at level 0 (the matrix passed to [`DeviceMultigrid::plan`]).
    matrix: Option<DeviceMatrix<'c>>,
    inv_diag: Lease<'c>,
    pre: Vec<Lease<'c>>,
    post: Vec<Lease<'c>>,
    /// The restricted residual (the level's right-hand side); `None` at level 0.
    r: Option<Lease<'c>>,
    z: [Lease<'c>; 2],
    d: Lease<'c>,
    res: Lease<'c>,
    transfer: DeviceTransfer<'c>,
}

/// The coarsest level: `A_c⁻¹` and its vectors.
struct CoarsestLevel<'c> {
    params: Lease<'c>,
    /// One invocation per vertex.
    row_grid: (u32, u32),
    inverse: Lease<'c>,
    r: Lease<'c>,
    z: Lease<'c>,
}

/// A [`Multigrid`] on the device.
pub(crate) struct DeviceMultigrid<'c> {
    n: usize,
    levels: Vec<SmoothedLevel<'c>>,
    coarsest: Option<CoarsestLevel<'c>>,
    /// vec4(1, 1, 1, 0) per level-0 row: the identity scaling S = 1 with which the Jacobi-PCG
    /// kernels (`cg_init`, `cg_update`, `cg_residual`, `cg_unscale`) run on the unscaled system.
    pub ones: Lease<'c>,
    /// Seconds spent uploading.
    pub upload_s: f64,
}

/// The dispatches of one V-cycle, and the buffer that holds `z` after it.
pub(crate) struct VCyclePlan<'a> {
    steps: Vec<(Kernel, wgpu::BindGroup, (u32, u32))>,
    /// `z = B r` (the input `r` itself for a one-level hierarchy, where `B = I` as on the CPU).
    pub output: &'a wgpu::Buffer,
}

impl VCyclePlan<'_> {
    /// Records the V-cycle into `pass`.
    pub(crate) fn record(&self, pass: &mut wgpu::ComputePass<'_>, ctx: &GpuContext) {
        for (kernel, bind, grid) in &self.steps {
            dispatch(pass, ctx, *kernel, bind, *grid);
        }
    }
}

impl<'c> DeviceMultigrid<'c> {
    /// Uploads the operators above level 0, the smoothers, the transfers and `A_c⁻¹` of `mg`.
    ///
    /// # Errors
    /// Device errors ([`GpuError::TooLarge`] for a coarsest level too large for one buffer).
    pub(crate) fn new(ctx: &'c GpuContext, mg: &Multigrid) -> Result<Self, GpuError> {
        let start = std::time::Instant::now();
        let h = mg.hierarchy();
        let n = h.level(0).graph.n();
        let count = h.levels();
        let opts = mg.options();
        let mut levels = Vec::with_capacity(count.saturating_sub(1));
        for l in 0..count.saturating_sub(1) {
            let nl = h.level(l).graph.n();
            let (params, grid) = level_params(ctx, nl)?;
            let matrix = if l == 0 { None } else { Some(DeviceMatrix::upload(ctx, mg.operator(l), Params::default())?) };
            let (inv_diag, lambda_max) = mg.smoother(l);
            let uniforms = |pre: bool| -> Vec<Lease<'c>> {
                chebyshev(lambda_max, opts.smoothing_degree, opts.smoothing_ratio, pre)
                    .iter()
                    .map(|c| ctx.uniform(c, "chebyshev step"))
                    .collect()
            };
            let bytes = 16 * nl as u64;
            levels.push(SmoothedLevel {
                params,
                grid,
                matrix,
                inv_diag: ctx.upload(&to_vec4(inv_diag), "multigrid inverse diagonal")?,
                pre: uniforms(true),
                post: uniforms(false),
                r: if l == 0 { None } else { Some(ctx.storage(bytes, "multigrid rhs")?) },
                z: [ctx.storage(bytes, "multigrid z")?, ctx.storage(bytes, "multigrid z'")?],
                d: ctx.storage(bytes, "chebyshev direction")?,
                res: ctx.storage(bytes, "multigrid residual")?,
                transfer: DeviceTransfer::upload(ctx, h.prolongation(l))?,
            });
        }
        let coarsest = match mg.coarsest_inverse() {
            Some((nc, inv)) => {
                let values: Vec<f32> = inv.iter().flat_map(|v| v.map(|x| x as f32)).collect();
                let (params, row_grid) = level_params(ctx, nc)?;
                Some(CoarsestLevel {
                    params,
                    row_grid,
                    inverse: ctx.upload(&values, "coarsest inverse")?,
                    r: ctx.storage(16 * nc as u64, "coarsest rhs")?,
                    z: ctx.storage(16 * nc as u64, "coarsest solution")?,
                })
            }
            None => None,
        };
        let ones = ctx.upload(&vec![[1.0f32, 1.0, 1.0, 0.0]; n], "identity scaling")?;
        ctx.submit_wait(ctx.encoder(), "multigrid upload")?;
        Ok(Self { n, levels, coarsest, ones, upload_s: start.elapsed().as_secs_f64() })
    }

    /// Level-0 vertices.
    pub(crate) fn n(&self) -> usize {
        self.n
    }

    /// Levels including the coarsest (1 for a one-level hierarchy).
    pub(crate) fn levels(&self) -> usize {
        self.levels.len() + 1
    }

    /// The dispatches of `z = B r0` with level-0 operator `a0` (unscaled values).
    pub(crate) fn plan<'a>(&'a self, ctx: &GpuContext, a0: &'a DeviceMatrix<'_>, r0: &'a wgpu::Buffer) -> VCyclePlan<'a> {
        let mut steps = Vec::new();
        let output = if self.levels.is_empty() { r0 } else { self.record(ctx, 0, a0, r0, &mut steps) };
        VCyclePlan { steps, output }
    }

    fn record<'a>(
        &'a self,
        ctx: &GpuContext,
        l: usize,
        a0: &'a DeviceMatrix<'_>,
        r: &'a wgpu::Buffer,
        steps: &mut Vec<(Kernel, wgpu::BindGroup, (u32, u32))>,
    ) -> &'a wgpu::Buffer {
        if l == self.levels.len() {
            let c = self.coarsest.as_ref().expect("a hierarchy of two or more levels has a coarsest factor");
            steps.push((Kernel::MgCoarse, ctx.bind(Kernel::MgCoarse, &[&c.params, &c.inverse, r, &c.z]), c.row_grid));
            return &c.z;
        }
        let lev = &self.levels[l];
        let (row_ptr, col_idx, vals): (&wgpu::Buffer, &wgpu::Buffer, &wgpu::Buffer) = match &lev.matrix {
            Some(m) => (&m.row_ptr, &m.col_idx, &m.values),
            None => (&a0.row_ptr, &a0.col_idx, &a0.values),
        };
        // z lives in lev.z[cur]; the first pre-smoothing step reads no z.
        let mut cur = 1;
        let smooth = |cheb: &Lease<'_>, cur: &mut usize, steps: &mut Vec<_>| {
            let out = 1 - *cur;
            let bind = ctx.bind(
                Kernel::MgSmooth,
                &[&lev.params, cheb, row_ptr, col_idx, vals, r, &lev.inv_diag, &lev.z[*cur], &lev.d, &lev.z[out]],
            );
            steps.push((Kernel::MgSmooth, bind, lev.grid));
            *cur = out;
        };
        for cheb in &lev.pre {
            smooth(cheb, &mut cur, steps);
        }
        steps.push((
            Kernel::MgResidual,
            ctx.bind(Kernel::MgResidual, &[&lev.params, row_ptr, col_idx, vals, r, &lev.z[cur], &lev.res]),
            lev.grid,
        ));
        let (coarse_params, coarse_grid, coarse_r): (&wgpu::Buffer, (u32, u32), &wgpu::Buffer) = match self.levels.get(l + 1) {
            Some(next) => (&next.params, next.grid, next.r.as_ref().expect("levels above 0 own their right-hand side")),
            None => {
                let c = self.coarsest.as_ref().expect("a hierarchy of two or more levels has a coarsest factor");
                (&c.params, c.row_grid, &c.r)
            }
        };
        let t = &lev.transfer;
        steps.push((
            Kernel::MgRestrict,
            ctx.bind(Kernel::MgRestrict, &[coarse_params, &t.t_ptr, &t.t_rows, &t.t_weights, &lev.res, coarse_r]),
            coarse_grid,
        ));
        let zc = self.record(ctx, l + 1, a0, coarse_r, steps);
        steps.push((
            Kernel::MgProlong,
            ctx.bind(Kernel::MgProlong, &[&lev.params, &t.p_ptr, &t.p_cols, &t.p_weights, zc, &lev.z[cur]]),
            lev.grid,
        ));
        for cheb in &lev.post {
            smooth(cheb, &mut cur, steps);
        }
        &lev.z[cur]
    }
}

fn check_len(what: &'static str, expected: usize, found: usize) -> Result<(), GpuError> {
    if expected == found {
        Ok(())
    } else {
        Err(DiffusionError::LengthMismatch { what, expected, found }.into())
    }
}

/// `Pᵀ fine` on the device (`mg_restrict.wgsl`, f32), the multigrid restriction.
/// CPU twin: [`Prolongation::restrict`].
///
/// # Errors
/// [`GpuError::Diffusion`] with a length mismatch unless `fine` has `p.n_fine()` entries; device
/// errors.
pub fn restrict(ctx: &GpuContext, p: &Prolongation, fine: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, GpuError> {
    check_len("fine vector (one entry per fine vertex)", p.n_fine(), fine.len())?;
    let t = DeviceTransfer::upload(ctx, p)?;
    let (params, grid) = level_params(ctx, p.n_coarse())?;
    let f = ctx.upload(&to_vec4(fine), "fine")?;
    let c = ctx.storage(16 * p.n_coarse() as u64, "coarse")?;
    let bind = ctx.bind(Kernel::MgRestrict, &[&params, &t.t_ptr, &t.t_rows, &t.t_weights, &f, &c]);
    let mut encoder = ctx.encoder();
    {
        let mut pass =
            encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("restrict"), timestamp_writes: None });
        dispatch(&mut pass, ctx, Kernel::MgRestrict, &bind, grid);
    }
    Ok(from_vec4(&ctx.read_back(encoder, &c, 16 * p.n_coarse() as u64, "restriction read-back")?, p.n_coarse()))
}

/// `fine + P coarse` on the device (`mg_prolong.wgsl`, f32), the coarse-grid correction with the
/// interpolation of TransCut eq. 16. CPU twin: [`Prolongation::prolong_add`].
///
/// # Errors
/// [`GpuError::Diffusion`] with a length mismatch unless `coarse` has `p.n_coarse()` and `fine`
/// `p.n_fine()` entries; device errors.
pub fn prolong_add(
    ctx: &GpuContext,
    p: &Prolongation,
    coarse: &[[f64; 3]],
    fine: &[[f64; 3]],
) -> Result<Vec<[f64; 3]>, GpuError> {
    check_len("coarse vector (one entry per coarse vertex)", p.n_coarse(), coarse.len())?;
    check_len("fine vector (one entry per fine vertex)", p.n_fine(), fine.len())?;
    let t = DeviceTransfer::upload(ctx, p)?;
    let (params, grid) = level_params(ctx, p.n_fine())?;
    let c = ctx.upload(&to_vec4(coarse), "coarse")?;
    let f = ctx.upload(&to_vec4(fine), "fine")?;
    let bind = ctx.bind(Kernel::MgProlong, &[&params, &t.p_ptr, &t.p_cols, &t.p_weights, &c, &f]);
    let mut encoder = ctx.encoder();
    {
        let mut pass =
            encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("prolong"), timestamp_writes: None });
        dispatch(&mut pass, ctx, Kernel::MgProlong, &bind, grid);
    }
    Ok(from_vec4(&ctx.read_back(encoder, &f, 16 * p.n_fine() as u64, "prolongation read-back")?, p.n_fine()))
}

/// One V-cycle `z = B r` of `mg` on the device with level-0 matrix `a` (uploaded, f32): the
/// preconditioner of the device MG-PCG, run on its own. CPU twin: [`Multigrid::vcycle`].
///
/// # Errors
/// [`GpuError::Diffusion`] with a length mismatch unless `a` and `r` have the size of the
/// multigrid's level 0; device errors.
pub fn vcycle(ctx: &GpuContext, mg: &Multigrid, a: &CsrMatrix3, r: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, GpuError> {
    let n = mg.hierarchy().level(0).graph.n();
    check_len("matrix rows (multigrid level 0)", n, a.n())?;
    check_len("residual (one entry per level-0 vertex)", n, r.len())?;
    let m = DeviceMatrix::upload(ctx, a, Params::default())?;
    let dmg = DeviceMultigrid::new(ctx, mg)?;
    let r0 = ctx.upload(&to_vec4(r), "r")?;
    let plan = dmg.plan(ctx, &m, &r0);
    let mut encoder = ctx.encoder();
    {
        let mut pass =
            encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("v-cycle"), timestamp_writes: None });
        plan.record(&mut pass, ctx);
    }
    Ok(from_vec4(&ctx.read_back(encoder, plan.output, 16 * n as u64, "v-cycle read-back")?, n))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cheb_matches_the_wgsl_layout() {
        // WGSL Cheb: two vec4<f32> and four u32.
        assert_eq!(size_of::<Cheb>(), 48);
    }

    #[test]
    fn chebyshev_coefficients_follow_the_recurrence() {
        // λmax = 2, ratio 4: θ = 1.25, δ = 0.75, σ = 5/3, ρ0 = 0.6, ρ1 = 1/(10/3 − 0.6) = 15/41.
        let c = chebyshev([2.0; 3], 3, 4.0, true);
        assert_eq!((c[0].from_zero, c[0].first, c[1].from_zero, c[1].first), (1, 1, 0, 0));
        assert!((f64::from(c[0].b[0]) - 0.8).abs() < 1e-7);
        let rho1 = 15.0 / 41.0;
        assert!((f64::from(c[1].a[1]) - rho1 * 0.6).abs() < 1e-7);
        assert!((f64::from(c[1].b[2]) - 2.0 * rho1 / 0.75).abs() < 1e-7);
        let rho2 = 1.0 / (2.0 * 5.0 / 3.0 - rho1);
        assert!((f64::from(c[2].a[0]) - rho2 * rho1).abs() < 1e-7);
        assert_eq!(chebyshev([2.0; 3], 2, 4.0, false)[0].from_zero, 0);
    }
}
