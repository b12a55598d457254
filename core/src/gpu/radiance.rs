//! TransCut eq. 3 on the device: the exitant radiance along the normal at every boundary vertex.

use super::context::{dispatch, GpuContext};
use super::error::GpuError;
use super::layout::{from_vec4, to_vec4};
use super::matrix::params_for;
use super::shaders::Kernel;
use crate::diffusion::{DiffusionError, DiffusionSystem};

/// Lo(x, n) = Ft(n)/(4π) · [(1 + 1/A) φ(x) − 4q(x)/(1 + Fdr)] at every boundary vertex (in the
/// order of [`DiffusionSystem::boundary`]), with the system's source q, computed by
/// `radiance.wgsl` in f32. CPU twin: [`crate::diffusion::surface_radiance`].
///
/// # Errors
/// [`GpuError::Diffusion`] with [`DiffusionError::LengthMismatch`] unless `phi` has one entry per
/// vertex, [`DiffusionError::NonFinite`] naming the first boundary vertex with a non-finite φ;
/// device errors.
pub fn surface_radiance(ctx: &GpuContext, system: &DiffusionSystem, phi: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, GpuError> {
    let n = system.vertex_count();
    if phi.len() != n {
        return Err(
            DiffusionError::LengthMismatch { what: "fluence phi (one entry per vertex)", expected: n, found: phi.len() }.into()
        );
    }
    let ids = &system.boundary().ids;
    for &v in ids {
        let p = phi[v as usize];
        if let Some(channel) = p.iter().position(|x| !x.is_finite()) {
            return Err(DiffusionError::NonFinite { what: "fluence", vertex: v as usize, channel, value: p[channel] }.into());
        }
    }
    let nb = ids.len();
    let (gx, gy, _) = ctx.grid(nb)?;
    let params = ctx.uniform(&params_for(system), "params");
    let ids_buf = ctx.upload(ids, "boundary ids")?;
    let phi_buf = ctx.upload(&to_vec4(phi), "phi")?;
    let q_buf = ctx.upload(&to_vec4(system.source()), "source q")?;
    let out = ctx.storage(16 * nb as u64, "radiance")?;
    let bind = ctx.bind(Kernel::Radiance, &[&params, &ids_buf, &phi_buf, &q_buf, &out]);
    let mut encoder = ctx.encoder();
    {
        let mut pass =
            encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("radiance"), timestamp_writes: None });
        dispatch(&mut pass, ctx, Kernel::Radiance, &bind, (gx, gy));
    }
    Ok(from_vec4(&ctx.read_back(encoder, &out, 16 * nb as u64, "radiance read-back")?, nb))
}
