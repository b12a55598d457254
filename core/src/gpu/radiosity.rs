//! Translucent radiosity's iteration on the device (design/radiosity.md §1.6, A12): the form
//! factors F uploaded once (scalar CSR, f32 values) with the opaque patches' ρ and
//! ρ ⊙ E_d + M, and Jacobi sweeps by `rad_sweep.wgsl`. A sweep returns the gathered F B with
//! the opaque update, so that the host scatters the translucent patches' share
//! ([`GpuRadiosity::sweep`]); a scene without translucent objects runs every sweep on the device
//! with no read-back between them ([`GpuRadiosity::jacobi`]). As a [`Gather`]
//! ([`GpuRadiosity::for_gather`]) it computes E = F B alone for
//! [`crate::radiosity::solve_coupled_with`], which keeps the opaque update and the scattering on
//! the host (so that the direct light and the materials can change without an upload). CPU
//! twins: [`crate::radiosity::FormFactors::apply`] and [`crate::radiosity::solve`].

use std::sync::Mutex;

use super::context::{dispatch, GpuContext};
use super::error::GpuError;
use super::layout::{from_vec4, to_vec4, Params};
use super::pool::Lease;
use super::shaders::Kernel;
use crate::radiosity::{FormFactors, Gather, Opaque, RadiosityError};

/// F and the opaque side of a scene on the device (module documentation).
pub struct GpuRadiosity<'c> {
    ctx: &'c GpuContext,
    n: usize,
    grid: (u32, u32),
    params: Lease<'c>,
    row_start: Lease<'c>,
    columns: Lease<'c>,
    values: Lease<'c>,
    albedo: Lease<'c>,
    base: Lease<'c>,
    /// The buffers and bind group of [`Gather::gather`], made at its first call and kept; the
    /// lock also keeps two gathers from writing them at once.
    gather: Mutex<Option<GatherBuffers<'c>>>,
}

/// B in, B' out (unread), E = F B out, bound to the sweep kernel.
struct GatherBuffers<'c> {
    b_in: Lease<'c>,
    gathered: Lease<'c>,
    bind: wgpu::BindGroup,
    _b_out: Lease<'c>,
}

/// One sweep's result: B' (ρ(E_d + F B) + M on opaque patches, 0 on translucent ones) and the
/// gathered irradiance F B on every patch.
#[derive(Debug, Clone, PartialEq)]
pub struct Sweep {
    pub radiosity: Vec<[f64; 3]>,
    pub gathered: Vec<[f64; 3]>,
}

impl<'c> GpuRadiosity<'c> {
    /// Uploads `factors` and the opaque values of `opaque` (`translucent[i]`: patch i belongs to
    /// a translucent object, whose ρ and base are 0 on the device).
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] when F does not fit a buffer of the device (or has more than
    /// 2³² nonzeros); [`GpuError::Unsupported`] for inputs of another length than F's.
    pub fn new(ctx: &'c GpuContext, factors: &FormFactors, opaque: &Opaque<'_>, translucent: &[bool]) -> Result<Self, GpuError> {
        let n = factors.len();
        if [opaque.albedo.len(), opaque.direct.len(), opaque.emission.len(), translucent.len()].iter().any(|&l| l != n) {
            return Err(GpuError::Unsupported { what: "radiosity with opaque values or flags of another length than F" });
        }
        let albedo: Vec<[f64; 3]> = (0..n).map(|i| if translucent[i] { [0.0; 3] } else { opaque.albedo[i] }).collect();
        let base: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                if translucent[i] {
                    [0.0; 3]
                } else {
                    std::array::from_fn(|c| opaque.albedo[i][c] * opaque.direct[i][c] + opaque.emission[i][c])
                }
            })
            .collect();
        Self::upload(ctx, factors, &albedo, &base)
    }

    /// Uploads `factors` alone, for [`Gather::gather`] (ρ and the base 0 on the device: the
    /// caller makes the update from the gathered E).
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] when F does not fit a buffer of the device (or has more than
    /// 2³² nonzeros).
    pub fn for_gather(ctx: &'c GpuContext, factors: &FormFactors) -> Result<Self, GpuError> {
        let zero = vec![[0.0; 3]; factors.len()];
        Self::upload(ctx, factors, &zero, &zero)
    }

    /// The name of the device the kernels run on.
    #[must_use]
    pub fn device_name(&self) -> &str {
        self.ctx.device_name()
    }

    /// Uploads F (f32 F_ij) with ρ and ρ ⊙ E_d + M per patch.
    fn upload(ctx: &'c GpuContext, factors: &FormFactors, albedo: &[[f64; 3]], base: &[[f64; 3]]) -> Result<Self, GpuError> {
        let n = factors.len();
        let (row_start, columns, exchange, inverse_area) = factors.csr();
        let too_large = || GpuError::TooLarge {
            what: "form factors (nonzeros)",
            needed: exchange.len() as u64,
            limit: u64::from(u32::MAX),
            device: ctx.device_name().to_owned(),
        };
        let starts: Vec<u32> = row_start.iter().map(|&s| u32::try_from(s).map_err(|_| too_large())).collect::<Result<_, _>>()?;
        // F_ij = G′_ij/Aᵢ, rounded to f32 once.
        let values32: Vec<f32> = (0..n)
            .flat_map(|i| (row_start[i]..row_start[i + 1]).map(move |k| (f64::from(exchange[k]) * inverse_area[i]) as f32))
            .collect();
        let (gx, gy, _) = ctx.grid(n)?;
        let params = Params { n: n as u32, nnz: values32.len() as u32, ..Params::default() };
        Ok(Self {
            ctx,
            n,
            grid: (gx, gy),
            params: ctx.uniform(&params, "radiosity params"),
            row_start: ctx.upload(&starts, "form factor rows")?,
            columns: ctx.upload(columns, "form factor columns")?,
            values: ctx.upload(&values32, "form factor values")?,
            albedo: ctx.upload(&to_vec4(albedo), "albedo")?,
            base: ctx.upload(&to_vec4(base), "rho E_d + M")?,
            gather: Mutex::new(None),
        })
    }

    /// The bind group of one sweep from `b_in` into `b_out`, gathering into `gathered`.
    fn bind(&self, b_in: &wgpu::Buffer, b_out: &wgpu::Buffer, gathered: &wgpu::Buffer) -> wgpu::BindGroup {
        self.ctx.bind(
            Kernel::RadSweep,
            &[&self.params, &self.row_start, &self.columns, &self.values, &self.albedo, &self.base, b_in, b_out, gathered],
        )
    }

    /// One Jacobi sweep from `b` ([`Sweep`]).
    ///
    /// # Errors
    /// [`GpuError::Unsupported`] for a `b` of another length; device errors.
    pub fn sweep(&self, b: &[[f64; 3]]) -> Result<Sweep, GpuError> {
        self.check(b)?;
        let bytes = 16 * self.n as u64;
        let b_in = self.ctx.upload(&to_vec4(b), "radiosity in")?;
        let b_out = self.ctx.storage(bytes, "radiosity out")?;
        let gathered = self.ctx.storage(bytes, "gathered")?;
        let bind = self.bind(&b_in, &b_out, &gathered);
        let mut encoder = self.ctx.encoder();
        {
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("rad_sweep"), timestamp_writes: None });
            dispatch(&mut pass, self.ctx, Kernel::RadSweep, &bind, self.grid);
        }
        encoder.copy_buffer_to_buffer(&b_out, 0, &b_in, 0, bytes);
        let gathered = from_vec4(&self.ctx.read_back(encoder, &gathered, bytes, "gathered read-back")?, self.n);
        let radiosity = from_vec4(&self.ctx.read_back(self.ctx.encoder(), &b_in, bytes, "radiosity read-back")?, self.n);
        Ok(Sweep { radiosity, gathered })
    }

    /// `sweeps` Jacobi sweeps from `b` on the device, for a scene without translucent objects
    /// (every patch's B' is the device's), read back once at the end.
    ///
    /// # Errors
    /// As [`GpuRadiosity::sweep`].
    pub fn jacobi(&self, b: &[[f64; 3]], sweeps: usize) -> Result<Vec<[f64; 3]>, GpuError> {
        self.check(b)?;
        let bytes = 16 * self.n as u64;
        let ping = self.ctx.upload(&to_vec4(b), "radiosity ping")?;
        let pong = self.ctx.storage(bytes, "radiosity pong")?;
        let gathered = self.ctx.storage(bytes, "gathered")?;
        let binds = [self.bind(&ping, &pong, &gathered), self.bind(&pong, &ping, &gathered)];
        let mut encoder = self.ctx.encoder();
        {
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("rad_jacobi"), timestamp_writes: None });
            for k in 0..sweeps {
                dispatch(&mut pass, self.ctx, Kernel::RadSweep, &binds[k % 2], self.grid);
            }
        }
        let last = if sweeps % 2 == 1 { &pong } else { &ping };
        Ok(from_vec4(&self.ctx.read_back(encoder, last, bytes, "radiosity read-back")?, self.n))
    }

    /// E = F B from `b` on the device, in the buffers kept for it ([`GatherBuffers`]).
    fn gather_on_device(&self, b: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, GpuError> {
        self.check(b)?;
        let bytes = 16 * self.n as u64;
        let mut slot = self.gather.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let buffers = match &mut *slot {
            Some(buffers) => buffers,
            none => {
                let b_in = self.ctx.storage(bytes, "gather in")?;
                let b_out = self.ctx.storage(bytes, "gather update (unread)")?;
                let gathered = self.ctx.storage(bytes, "gathered")?;
                let bind = self.bind(&b_in, &b_out, &gathered);
                none.insert(GatherBuffers { b_in, gathered, bind, _b_out: b_out })
            }
        };
        if self.n > 0 {
            self.ctx.queue().write_buffer(&buffers.b_in, 0, bytemuck::cast_slice(&to_vec4(b)));
        }
        let mut encoder = self.ctx.encoder();
        {
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("rad_gather"), timestamp_writes: None });
            dispatch(&mut pass, self.ctx, Kernel::RadSweep, &buffers.bind, self.grid);
        }
        Ok(from_vec4(&self.ctx.read_back(encoder, &buffers.gathered, bytes, "radiosity gather read-back")?, self.n))
    }

    fn check(&self, b: &[[f64; 3]]) -> Result<(), GpuError> {
        if b.len() == self.n {
            Ok(())
        } else {
            Err(GpuError::Unsupported { what: "a radiosity of another length than F" })
        }
    }
}

/// The device's gather: B uploaded as f32, one dispatch of `rad_sweep.wgsl`, E read back (its
/// CPU twin [`FormFactors::apply`]; f32 on the device, about 1e-7 relative per value).
impl Gather for GpuRadiosity<'_> {
    fn patches(&self) -> usize {
        self.n
    }

    fn gather(&self, b: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, RadiosityError> {
        if b.len() != self.n {
            return Err(RadiosityError::WrongLength { what: "radiosity to gather", expected: self.n, got: b.len() });
        }
        self.gather_on_device(b).map_err(|e| RadiosityError::Device(e.to_string()))
    }
}
