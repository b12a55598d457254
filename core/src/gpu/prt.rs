//! The PRT relight on the device (design/prt.md §4 "GPU"): a compressed [`Transfer`] uploaded
//! once (per entry its sample index decoded and its 16-bit value, the row starts and the
//! quantisation steps), then per relight the
//! Haar-transformed irradiance in and the product (Tₖ^w q^w)[v] out (`prt_relight.wgsl`, R. Wang
//! et al. 2008 eqs. 7–8), and per output vertex Lo = C(η) Σₖ sₖ (Tₖ^w q^w)[v] clamped at 0
//! (`prt_combine.wgsl`). CPU twins: [`Transfer::apply`] and the `radiance` function of
//! [`crate::methods::prt`]. Both run in f32: the products equal the CPU's, the sums run in
//! another order (64 strided partial sums per row and a tree), so the two agree to f32 rounding,
//! not bit for bit; the device's own results do not depend on the run.

use std::sync::Mutex;

use bytemuck::{Pod, Zeroable};

use super::context::{dispatch, GpuContext};
use super::error::GpuError;
use super::pool::Lease;
use super::shaders::Kernel;
use crate::prt::Transfer;

/// Invocations per receiver vertex in `prt_relight.wgsl` (four vertices per workgroup of 256).
pub const LANES_PER_VERTEX: usize = 64;

/// `PrtParams` of `prt_relight.wgsl` and `prt_combine.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default, Pod, Zeroable)]
struct PrtParams {
    vertices: u32,
    rows_per_vertex: u32,
    samples: u32,
    outputs: u32,
}

/// A [`Transfer`] on the device, with the irradiance and product buffers of its relights (kept
/// across calls: a relight allocates nothing on the device but its read-back staging, which the
/// pool reuses).
pub struct GpuPrt<'c> {
    ctx: &'c GpuContext,
    vertices: usize,
    rows_per_vertex: usize,
    samples: usize,
    relight_grid: (u32, u32),
    _params: Lease<'c>,
    _row_start: Lease<'c>,
    _indices: Lease<'c>,
    _values: Lease<'c>,
    _steps: Lease<'c>,
    q_haar: Lease<'c>,
    gathered: Lease<'c>,
    relight: wgpu::BindGroup,
    /// Whether `gathered` holds a product ([`GpuPrt::combine`] needs one); the lock also keeps
    /// two calls from writing the irradiance at once.
    applied: Mutex<bool>,
}

impl std::fmt::Debug for GpuPrt<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuPrt")
            .field("device", &self.ctx.device_name())
            .field("vertices", &self.vertices)
            .field("rows_per_vertex", &self.rows_per_vertex)
            .field("samples", &self.samples)
            .finish_non_exhaustive()
    }
}

/// The buffers of one combine: the weights, the output map, Lo (bound to `prt_combine.wgsl`).
struct Combine<'c> {
    outputs: usize,
    _params: Lease<'c>,
    _weights: Lease<'c>,
    _output_map: Lease<'c>,
    radiance: Lease<'c>,
    bind: wgpu::BindGroup,
    grid: (u32, u32),
}

impl<'c> GpuPrt<'c> {
    /// Uploads `transfer`. The row starts go to the device as u32: a transfer of more than
    /// 2³² − 1 terms is refused, not split (its terms alone would be 16 GiB, beyond one storage
    /// binding of any device).
    ///
    /// # Errors
    /// [`GpuError::TooLarge`] for more than 2³² − 1 terms or arrays beyond the device's buffer
    /// limits; [`GpuError::Unsupported`] for row starts that do not rise to the number of terms
    /// (a damaged transfer).
    pub fn new(ctx: &'c GpuContext, transfer: &Transfer) -> Result<Self, GpuError> {
        let (vertices, rows_per_vertex, samples) = (transfer.vertices(), transfer.basis_terms(), transfer.samples());
        let (row_start, entries, steps) = (transfer.row_start(), transfer.gaps().len(), transfer.steps());
        let rows = vertices * rows_per_vertex;
        if row_start.len() != rows + 1
            || steps.len() != rows
            || row_start.first() != Some(&0)
            || row_start.last() != Some(&(entries as u64))
            || row_start.windows(2).any(|w| w[0] > w[1])
        {
            return Err(GpuError::Unsupported { what: "a PRT transfer whose row starts do not rise to its number of entries" });
        }
        let too_large = |what, needed: u64| GpuError::TooLarge {
            what,
            needed,
            limit: u64::from(u32::MAX),
            device: ctx.device_name().to_owned(),
        };
        let starts: Vec<u32> = row_start
            .iter()
            .map(|&s| u32::try_from(s).map_err(|_| too_large("PRT transfer (entries)", entries as u64)))
            .collect::<Result<_, _>>()?;
        let vertices32 = u32::try_from(vertices).map_err(|_| too_large("PRT receiver vertices", vertices as u64))?;
        let samples32 = u32::try_from(samples).map_err(|_| too_large("PRT samples", samples as u64))?;
        let (gx, gy, _) = ctx.grid(vertices * LANES_PER_VERTEX)?;
        let params = PrtParams { vertices: vertices32, rows_per_vertex: rows_per_vertex as u32, samples: samples32, outputs: 0 };
        let params = ctx.uniform(&params, "prt params");
        let row_start = ctx.upload(&starts, "prt row starts")?;
        let (indices, values) = upload_entries(ctx, transfer)?;
        let steps = ctx.upload(steps, "prt steps")?;
        let q_haar = ctx.storage(16 * samples as u64, "prt haar irradiance")?;
        let gathered = ctx.storage(4 * 3 * rows as u64, "prt gathered")?;
        let relight = ctx.bind(Kernel::PrtRelight, &[&params, &row_start, &indices, &values, &steps, &q_haar, &gathered]);
        Ok(Self {
            ctx,
            vertices,
            rows_per_vertex,
            samples,
            relight_grid: (gx, gy),
            _params: params,
            _row_start: row_start,
            _indices: indices,
            _values: values,
            _steps: steps,
            q_haar,
            gathered,
            relight,
            applied: Mutex::new(false),
        })
    }

    /// The name of the device the kernels run on.
    #[must_use]
    pub fn device_name(&self) -> &str {
        self.ctx.device_name()
    }

    /// The number of receiver vertices of the uploaded transfer.
    #[must_use]
    pub fn vertices(&self) -> usize {
        self.vertices
    }

    /// (Tₖ^w q^w)[v] per receiver v, basis function k and channel c at `(v K + k) 3 + c`, from the
    /// Haar-transformed irradiance `q_haar` ([`crate::prt::haar_irradiance`]), as
    /// [`Transfer::apply`] writes it. The product stays on the device for [`GpuPrt::combine`].
    ///
    /// # Errors
    /// [`GpuError::Unsupported`] for a `q_haar` of another length than the samples; device
    /// errors.
    pub fn apply(&self, q_haar: &[[f32; 4]]) -> Result<Vec<f64>, GpuError> {
        let mut applied = self.lock();
        let encoder = self.record_apply(q_haar)?;
        *applied = false;
        let bytes = 4 * 3 * (self.vertices * self.rows_per_vertex) as u64;
        let raw = self.ctx.read_back(encoder, &self.gathered, bytes, "PRT relight read-back")?;
        *applied = true;
        Ok(floats(&raw).map(f64::from).collect())
    }

    /// Lo per output vertex from the product of the last [`GpuPrt::apply`] or
    /// [`GpuPrt::relight`] on the device: C(η) Σₖ sₖ,c (Tₖ q)[v, c] with `per_exitance` = C(η) and
    /// `weights[c][k]` = sₖ,c, clamped at 0, and how many output vertices the clamp changed;
    /// `output[o]` is the receiver of output vertex o (`None`: 0). The clamp runs on the device,
    /// which flags each clamped vertex in Lo's fourth lane; the host counts the flags as it reads
    /// Lo back.
    ///
    /// # Errors
    /// [`GpuError::Unsupported`] before any product, for weights of another length than K or a
    /// receiver beyond the transfer's; device errors.
    pub fn combine(
        &self,
        weights: &[Vec<f64>; 3],
        per_exitance: f64,
        output: &[Option<u32>],
    ) -> Result<(Vec<[f64; 3]>, usize), GpuError> {
        let applied = self.lock();
        if !*applied {
            return Err(GpuError::Unsupported { what: "a PRT combine before the transfer's product" });
        }
        let combine = self.prepare_combine(weights, per_exitance, output)?;
        let mut encoder = self.ctx.encoder();
        {
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("prt_combine"), timestamp_writes: None });
            dispatch(&mut pass, self.ctx, Kernel::PrtCombine, &combine.bind, combine.grid);
        }
        self.read_radiance(encoder, &combine)
    }

    /// [`GpuPrt::apply`] and [`GpuPrt::combine`] in one submission, reading back Lo alone (the
    /// product stays on the device).
    ///
    /// # Errors
    /// Those of [`GpuPrt::apply`] and [`GpuPrt::combine`].
    pub fn relight(
        &self,
        q_haar: &[[f32; 4]],
        weights: &[Vec<f64>; 3],
        per_exitance: f64,
        output: &[Option<u32>],
    ) -> Result<(Vec<[f64; 3]>, usize), GpuError> {
        let mut applied = self.lock();
        let combine = self.prepare_combine(weights, per_exitance, output)?;
        let mut encoder = self.record_apply(q_haar)?;
        *applied = false;
        {
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("prt_combine"), timestamp_writes: None });
            dispatch(&mut pass, self.ctx, Kernel::PrtCombine, &combine.bind, combine.grid);
        }
        let out = self.read_radiance(encoder, &combine)?;
        *applied = true;
        Ok(out)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, bool> {
        self.applied.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Writes `q_haar` to the device and records the relight kernel into a new encoder.
    fn record_apply(&self, q_haar: &[[f32; 4]]) -> Result<wgpu::CommandEncoder, GpuError> {
        if q_haar.len() != self.samples {
            return Err(GpuError::Unsupported { what: "a PRT irradiance of another length than the transfer's samples" });
        }
        if !q_haar.is_empty() {
            self.ctx.queue().write_buffer(&self.q_haar, 0, bytemuck::cast_slice(q_haar));
        }
        let mut encoder = self.ctx.encoder();
        {
            let mut pass =
                encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("prt_relight"), timestamp_writes: None });
            dispatch(&mut pass, self.ctx, Kernel::PrtRelight, &self.relight, self.relight_grid);
        }
        Ok(encoder)
    }

    /// Checks and uploads a combine's inputs: the weights premultiplied by C(η) (one vec4 per
    /// basis function, channels in xyz), the output map (`u32::MAX` for `None`).
    fn prepare_combine(
        &self,
        weights: &[Vec<f64>; 3],
        per_exitance: f64,
        output: &[Option<u32>],
    ) -> Result<Combine<'c>, GpuError> {
        let k = self.rows_per_vertex;
        if weights.iter().any(|w| w.len() != k) {
            return Err(GpuError::Unsupported { what: "PRT weights of another length than the transfer's basis" });
        }
        if output.iter().flatten().any(|&v| v as usize >= self.vertices) {
            return Err(GpuError::Unsupported { what: "a PRT output vertex whose receiver is beyond the transfer's" });
        }
        let outputs = u32::try_from(output.len()).map_err(|_| GpuError::TooLarge {
            what: "PRT output vertices",
            needed: output.len() as u64,
            limit: u64::from(u32::MAX),
            device: self.ctx.device_name().to_owned(),
        })?;
        let w: Vec<[f32; 4]> = (0..k)
            .map(|j| {
                [
                    (per_exitance * weights[0][j]) as f32,
                    (per_exitance * weights[1][j]) as f32,
                    (per_exitance * weights[2][j]) as f32,
                    0.0,
                ]
            })
            .collect();
        let map: Vec<u32> = output.iter().map(|v| v.unwrap_or(u32::MAX)).collect();
        let params =
            PrtParams { vertices: self.vertices as u32, rows_per_vertex: k as u32, samples: self.samples as u32, outputs };
        let params = self.ctx.uniform(&params, "prt combine params");
        let weights = self.ctx.upload(&w, "prt weights")?;
        let output_map = self.ctx.upload(&map, "prt output map")?;
        let radiance = self.ctx.storage(16 * output.len() as u64, "prt radiance")?;
        let bind = self.ctx.bind(Kernel::PrtCombine, &[&params, &weights, &output_map, &self.gathered, &radiance]);
        let (gx, gy, _) = self.ctx.grid(output.len())?;
        Ok(Combine {
            outputs: output.len(),
            _params: params,
            _weights: weights,
            _output_map: output_map,
            radiance,
            bind,
            grid: (gx, gy),
        })
    }

    /// Submits `encoder`, reads Lo back and counts the clamp's flags.
    fn read_radiance(&self, encoder: wgpu::CommandEncoder, combine: &Combine<'_>) -> Result<(Vec<[f64; 3]>, usize), GpuError> {
        let raw = self.ctx.read_back(encoder, &combine.radiance, 16 * combine.outputs as u64, "PRT combine read-back")?;
        let lo: Vec<f32> = floats(&raw).collect();
        let clamped = lo.chunks_exact(4).filter(|x| x[3] > 0.0).count();
        Ok((lo.chunks_exact(4).map(|x| [f64::from(x[0]), f64::from(x[1]), f64::from(x[2])]).collect(), clamped))
    }
}

/// Entries decoded and written to the device per this many (an even number: two values share
/// a word), so the host never holds a decoded copy of the whole transfer.
const ENTRIES_PER_WRITE: usize = 1 << 20;

/// The transfer's entries on the device: per entry its sample index (u32) and its value (16
/// bits, two per word, an escape's 0), as [`Transfer::row_entries`] decodes them.
fn upload_entries<'c>(ctx: &'c GpuContext, transfer: &Transfer) -> Result<(Lease<'c>, Lease<'c>), GpuError> {
    let entries = transfer.gaps().len();
    let indices = ctx.storage(4 * entries.max(1) as u64, "prt indices")?;
    let values = ctx.storage(4 * entries.div_ceil(2).max(1) as u64, "prt values")?;
    let (mut index, mut value) = (Vec::with_capacity(ENTRIES_PER_WRITE + 1), Vec::with_capacity(ENTRIES_PER_WRITE + 1));
    let mut written = 0u64;
    let mut flush = |index: &mut Vec<u32>, value: &mut Vec<f32>, last: bool| {
        if value.len() % 2 == 1 && last {
            value.push(0.0);
        }
        let words: Vec<u32> =
            value.chunks_exact(2).map(|p| u32::from(p[0] as i16 as u16) | (u32::from(p[1] as i16 as u16) << 16)).collect();
        ctx.queue().write_buffer(&indices, 4 * written, bytemuck::cast_slice(&index[..]));
        ctx.queue().write_buffer(&values, 2 * written, bytemuck::cast_slice(&words));
        written += index.len() as u64;
        index.clear();
        value.clear();
    };
    for row in 0..transfer.steps().len() {
        for (i, v) in transfer.row_entries(row) {
            index.push(i);
            value.push(v);
            if index.len() == ENTRIES_PER_WRITE {
                flush(&mut index, &mut value, false);
            }
        }
    }
    if !index.is_empty() {
        flush(&mut index, &mut value, true);
    }
    Ok((indices, values))
}

/// The f32 values of read-back bytes (the staging copy need not be aligned for f32).
fn floats(bytes: &[u8]) -> impl Iterator<Item = f32> + '_ {
    bytes.chunks_exact(4).map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
}
