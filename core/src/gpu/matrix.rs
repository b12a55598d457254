//! The matrix on the device: the CSR pattern, the values of M (f32, three per nonzero) — either
//! assembled by the kernels from the mesh (TransCut eqs. 10–14: `tet_geometry.wgsl` then the
//! row-wise gather `assemble.wgsl`) or uploaded from a CPU matrix — and its Jacobi scaling
//! Â = S M S, S = D^-½ (`jacobi_diag.wgsl`, `jacobi_scale.wgsl`), the operator of the PCG.
//!
//! Why a row-wise gather instead of a per-tet scatter: WGSL has no floating-point atomics, and a
//! gather over the tets around each vertex (the incidence lists of the CPU structure, with the
//! value slot of every tet edge precomputed) needs none, sums each row in a fixed order (so the
//! result is deterministic and M exactly symmetric, as on the CPU) and reads each tet's
//! coefficients, computed once per tet, at most four times.

use std::time::Instant;

use rayon::prelude::*;

use super::context::{dispatch, GpuContext};
use super::error::GpuError;
use super::layout::{Incidence, Params, RowInfo};
use super::pool::Lease;
use super::shaders::Kernel;
use crate::diffusion::{layer_excess, Coefficients, DiffusionError, DiffusionSystem, Discretization};
use crate::sparse::{CsrMatrix3, CsrPattern};

/// A matrix on the device with its Jacobi scaling.
pub(crate) struct DeviceMatrix<'c> {
    pub n: usize,
    pub nnz: usize,
    pub row_ptr: Lease<'c>,
    pub col_idx: Lease<'c>,
    /// M, three f32 per nonzero.
    pub values: Lease<'c>,
    /// Â = S M S.
    pub scaled: Lease<'c>,
    /// S = D^-½ per row (vec4).
    pub sdiag: Lease<'c>,
    /// `Params` with the row counts.
    pub params: Lease<'c>,
    /// The row-kernel grid and its workgroup count.
    pub grid: (u32, u32),
    pub n_groups: u32,
    /// Whether the values were assembled on the device.
    pub assembled_on_device: bool,
    /// Seconds spent uploading and assembling (device time included).
    pub upload_s: f64,
    pub assembly_s: f64,
}

fn to_u32(v: usize, what: &'static str) -> Result<u32, GpuError> {
    u32::try_from(v).map_err(|_| GpuError::TooLarge { what, needed: v as u64, limit: u64::from(u32::MAX), device: String::new() })
}

impl<'c> DeviceMatrix<'c> {
    /// The system's matrix on the device: assembled there for TransCut's discretisation and
    /// its fitted variant, uploaded from the CPU values for the consistent FEM; then scaled.
    pub(crate) fn from_system(ctx: &'c GpuContext, system: &DiffusionSystem) -> Result<DeviceMatrix<'c>, GpuError> {
        match system.discretization() {
            Discretization::TransCut | Discretization::ExponentiallyFitted | Discretization::FittedLayer => {
                Self::assemble(ctx, system)
            }
            Discretization::ConsistentFem => Self::upload(ctx, system.matrix(), params_for(system)),
        }
    }

    /// Uploads a CPU matrix (values rounded to f32) and scales it.
    pub(crate) fn upload(ctx: &'c GpuContext, matrix: &CsrMatrix3, params: Params) -> Result<DeviceMatrix<'c>, GpuError> {
        let start = Instant::now();
        let values: Vec<f32> = matrix.values().iter().flat_map(|v| v.map(|x| x as f32)).collect();
        let mut m = Self::pattern(ctx, matrix.pattern(), params)?;
        m.values = ctx.upload(&values, "matrix values")?;
        m.upload_s = start.elapsed().as_secs_f64();
        m.scale(ctx)?;
        Ok(m)
    }

    /// The pattern buffers and empty value buffers.
    fn pattern(ctx: &'c GpuContext, pattern: &CsrPattern, mut params: Params) -> Result<DeviceMatrix<'c>, GpuError> {
        let n = pattern.n();
        let nnz = pattern.nnz();
        to_u32(nnz, "nonzeros")?;
        let row_ptr: Vec<u32> = pattern.row_ptr().iter().map(|&p| p as u32).collect();
        let (gx, gy, n_groups) = ctx.grid(n)?;
        params.n = to_u32(n, "rows")?;
        params.nnz = nnz as u32;
        params.n_groups = n_groups;
        Ok(DeviceMatrix {
            n,
            nnz,
            row_ptr: ctx.upload(&row_ptr, "row_ptr")?,
            col_idx: ctx.upload(pattern.col_idx(), "col_idx")?,
            values: ctx.storage(12 * nnz as u64, "matrix values")?,
            scaled: ctx.storage(12 * nnz as u64, "scaled matrix values")?,
            sdiag: ctx.storage(16 * n as u64, "jacobi scaling")?,
            params: ctx.uniform(&params, "params"),
            grid: (gx, gy),
            n_groups,
            assembled_on_device: false,
            upload_s: 0.0,
            assembly_s: 0.0,
        })
    }

    /// TransCut's assembly, or its fitted variant, on the device from the system's mesh
    /// structure and media.
    fn assemble(ctx: &'c GpuContext, system: &DiffusionSystem) -> Result<DeviceMatrix<'c>, GpuError> {
        let start = Instant::now();
        let s = system.structure();
        let params = params_for(system);
        let mut m = Self::pattern(ctx, &s.pattern, params)?;
        // Positions relative to the centre of the bounding box, so f32 keeps the digits that
        // the edge vectors need.
        let (lo, hi) = s
            .positions_mm
            .iter()
            .fold((glam::DVec3::INFINITY, glam::DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let centre = 0.5 * (lo + hi);
        let positions: Vec<[f32; 4]> = s
            .positions_mm
            .iter()
            .map(|p| {
                let d = *p - centre;
                [d.x as f32, d.y as f32, d.z as f32, 0.0]
            })
            .collect();
        let tets: Vec<[u32; 4]> = s.tets.clone();
        let row_ptr = s.pattern.row_ptr();
        let diag = s.pattern.diagonal_positions();
        let terms = system.boundary_terms();
        // κ, μ and the fitting's σtr per medium, as the CPU assembly derives them (σtr = 0 for
        // TransCut's own scheme: f(0) = 1).
        let fitted = matches!(system.discretization(), Discretization::ExponentiallyFitted | Discretization::FittedLayer);
        let layer = system.discretization() == Discretization::FittedLayer;
        let c = Coefficients::of(system.media());
        let rows: Vec<RowInfo> = (0..s.n())
            .into_par_iter()
            .map(|i| {
                let b = s.boundary_index[i];
                let boundary = if b == u32::MAX {
                    // diffusion's INTERIOR marker: an interior vertex
                    [0.0; 3]
                } else {
                    let robin = terms.matrix_diagonal(s.boundary.area_mm2[b as usize]);
                    let excess = if layer { layer_excess(s, &c, i) } else { [0.0; 3] };
                    excess.map(|x| (robin + x) as f32)
                };
                RowInfo {
                    value_start: row_ptr[i] as u32,
                    value_end: row_ptr[i + 1] as u32,
                    inc_start: s.tet_inc_offsets[i] as u32,
                    inc_end: s.tet_inc_offsets[i + 1] as u32,
                    diag: diag[i] as u32,
                    boundary,
                }
            })
            .collect();
        to_u32(s.tet_inc.len(), "tet incidences")?;
        let incidences: Vec<Incidence> =
            s.tet_inc.iter().map(|inc| Incidence { tet: inc.tet, local: inc.local, slots: inc.slots }).collect();
        let f32x4 = |v: [f64; 3]| [v[0] as f32, v[1] as f32, v[2] as f32, 0.0];
        let media: Vec<[f32; 4]> = (0..c.kappa.len())
            .flat_map(|m| [f32x4(c.kappa[m]), f32x4(c.mu[m]), if fitted { f32x4(c.sigma_tr[m]) } else { [0.0; 4] }])
            .collect();
        let mut tet_params = params;
        tet_params.n_tets = to_u32(s.tets.len(), "tets")?;
        tet_params.n = m.n as u32;
        tet_params.nnz = m.nnz as u32;
        tet_params.n_groups = m.n_groups;
        let tet_params = ctx.uniform(&tet_params, "params (tets)");
        let positions = ctx.upload(&positions, "positions")?;
        let tets_buf = ctx.upload(&tets, "tets")?;
        let materials = ctx.upload(&s.materials, "materials")?;
        let rows = ctx.upload(&rows, "rows")?;
        let incidences = ctx.upload(&incidences, "incidences")?;
        let media = ctx.upload(&media, "media")?;
        let geometry = ctx.storage(32 * s.tets.len() as u64, "tet geometry")?;
        // Uploads are complete once the queue has run them.
        ctx.submit_wait(ctx.encoder(), "upload")?;
        m.upload_s = start.elapsed().as_secs_f64();

        let start = Instant::now();
        let tet_grid = ctx.grid(s.tets.len())?;
        let geo_bind = ctx.bind(Kernel::TetGeometry, &[&tet_params, &positions, &tets_buf, &materials, &geometry]);
        let asm_bind =
            ctx.bind(Kernel::Assemble, &[&m.params, &rows, &incidences, &geometry, &media, &m.values, &positions, &tets_buf]);
        let mut encoder = ctx.encoder();
        {
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("assembly"), timestamp_writes: None });
            dispatch(&mut pass, ctx, Kernel::TetGeometry, &geo_bind, (tet_grid.0, tet_grid.1));
            dispatch(&mut pass, ctx, Kernel::Assemble, &asm_bind, m.grid);
        }
        ctx.submit_wait(encoder, "assembly")?;
        m.assembled_on_device = true;
        m.assembly_s = start.elapsed().as_secs_f64();
        m.scale(ctx)?;
        Ok(m)
    }

    /// Â = S M S with S = D^-½ (on the device).
    fn scale(&mut self, ctx: &'c GpuContext) -> Result<(), GpuError> {
        let start = Instant::now();
        let diag_bind = ctx.bind(Kernel::JacobiDiag, &[&self.params, &self.row_ptr, &self.col_idx, &self.values, &self.sdiag]);
        let scale_bind =
            ctx.bind(Kernel::JacobiScale, &[&self.params, &self.row_ptr, &self.col_idx, &self.values, &self.sdiag, &self.scaled]);
        let mut encoder = ctx.encoder();
        {
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("jacobi"), timestamp_writes: None });
            dispatch(&mut pass, ctx, Kernel::JacobiDiag, &diag_bind, self.grid);
            dispatch(&mut pass, ctx, Kernel::JacobiScale, &scale_bind, self.grid);
        }
        ctx.submit_wait(encoder, "Jacobi scaling")?;
        self.assembly_s += start.elapsed().as_secs_f64();
        Ok(())
    }

    /// The values of M read back (f32 widened to f64).
    pub(crate) fn read_values(&self, ctx: &GpuContext) -> Result<Vec<[f64; 3]>, GpuError> {
        let bytes = ctx.read_back(ctx.encoder(), &self.values, 12 * self.nnz as u64, "matrix read-back")?;
        let v: &[f32] = bytemuck::cast_slice(&bytes);
        Ok(v.chunks_exact(3).map(|c| [f64::from(c[0]), f64::from(c[1]), f64::from(c[2])]).collect())
    }
}

/// `Params` of a system: sizes and the radiance coefficients of TransCut eq. 3 along the normal,
/// Lo = Ft(n)/(4π)·[(1 + 1/A) φ − 4q/(1 + Fdr)].
pub(crate) fn params_for(system: &DiffusionSystem) -> Params {
    let t = system.boundary_terms();
    let f = t.ft_normal / (4.0 * std::f64::consts::PI);
    Params {
        n: system.vertex_count() as u32,
        nnz: system.pattern().nnz() as u32,
        n_tets: 0,
        n_boundary: system.boundary().len() as u32,
        n_groups: 0,
        pad: [0; 3],
        rad_phi: (f * (1.0 + 1.0 / t.a)) as f32,
        rad_q: (f * 4.0 / (1.0 + t.fdr)) as f32,
        pad_f: [0.0; 2],
    }
}

/// The matrix of `system` assembled on the device (TransCut eqs. 10–14, or their fitted
/// variant, f32), read back: the GPU twin of [`crate::diffusion::assemble`]'s and
/// [`crate::diffusion::assemble_fitted`]'s matrices, for comparison entry by entry.
///
/// # Errors
/// [`GpuError::Unsupported`] for the consistent FEM (assembled on the CPU only); device errors.
pub fn assemble(ctx: &GpuContext, system: &DiffusionSystem) -> Result<CsrMatrix3, GpuError> {
    if system.discretization() == Discretization::ConsistentFem {
        return Err(GpuError::Unsupported { what: "GPU assembly of the consistent FEM" });
    }
    let m = DeviceMatrix::assemble(ctx, system)?;
    let values = m.read_values(ctx)?;
    CsrMatrix3::new(std::sync::Arc::clone(system.pattern()), values).map_err(|e| GpuError::Diffusion(DiffusionError::Sparse(e)))
}
