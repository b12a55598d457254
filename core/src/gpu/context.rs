//! The headless wgpu device: adapter choice, device and queue, the compiled kernels, the buffer
//! pool and the read-back path.
//!
//! Adapter choice: every adapter of the enabled backends (`WGPU_BACKEND`, e.g. `vulkan`, narrows
//! them) is listed; `TRANSCUT_GPU_ADAPTER=substring` keeps those whose name contains it (case
//! insensitive, e.g. `llvmpipe` for lavapipe); of the rest a discrete GPU is preferred, then an
//! integrated one, a virtual one, and last a CPU (software) device such as lavapipe.

use std::sync::{Arc, Mutex, OnceLock};

use super::error::GpuError;
use super::pool::{BufferPool, Lease};
use super::shaders::Kernel;

/// Environment variable that restricts the adapter by a substring of its name.
pub const ADAPTER_ENV: &str = "TRANSCUT_GPU_ADAPTER";

/// The device nodes through which a hardware GPU driver shows itself on Linux: DRM render nodes
/// (`/dev/dri/renderD*`: Mesa, AMDGPU, Intel, NVIDIA's DRM module), NVIDIA's proprietary
/// driver (`/dev/nvidia0`) and WSL 2's GPU (`/dev/dxg`).
const GPU_NODES: &str = "/dev/dri/renderD*, /dev/nvidia0, /dev/dxg";

/// Whether any hardware GPU device node is among `dri` (the names in `/dev/dri`) and the
/// files `exists` knows of: without one, a Vulkan driver can offer only a software adapter.
fn has_gpu_node(dri: impl IntoIterator<Item = String>, exists: impl Fn(&str) -> bool) -> bool {
    dri.into_iter().any(|name| name.starts_with("renderD")) || exists("/dev/nvidia0") || exists("/dev/dxg")
}

/// Why this machine cannot have a hardware GPU, or `None` when it may have one. On Linux a
/// hardware GPU needs a device node ([`GPU_NODES`]); without any, [`super::Backend::Auto`]
/// solves on the CPU without loading the drivers (which would only find a software adapter and
/// may print to the host's stderr). Elsewhere `None`: the drivers are asked.
#[must_use]
pub fn no_hardware_gpu() -> Option<String> {
    #[cfg(target_os = "linux")]
    {
        let dri = std::fs::read_dir("/dev/dri")
            .map(|d| d.flatten().map(|e| e.file_name().to_string_lossy().into_owned()).collect::<Vec<_>>())
            .unwrap_or_default();
        if !has_gpu_node(dri, |p| std::path::Path::new(p).exists()) {
            return Some(format!(
                "no GPU adapter found: this machine has no GPU device node ({GPU_NODES}), so the \
                 drivers were not asked; TRANSCUT_BACKEND=gpu asks them anyway"
            ));
        }
    }
    None
}

/// Workgroup size of every kernel (`WG` in `shaders/common.wgsl`).
pub(crate) const WORKGROUP: u32 = 256;

/// The largest workgroup count of one grid dimension.
const MAX_GROUPS_PER_DIM: u32 = 65_535;

/// A headless GPU device with the kernels of `shaders/` and a buffer pool. Create one with
/// [`GpuContext::new`] or use the process-wide [`GpuContext::shared`]; it is `Send + Sync`, and
/// solves on one context are serialised by the queue.
pub struct GpuContext {
    device: wgpu::Device,
    queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    limits: wgpu::Limits,
    pipelines: [OnceLock<wgpu::ComputePipeline>; Kernel::ALL.len()],
    pool: BufferPool,
    /// The first uncaptured device error since it was last taken.
    error: Arc<Mutex<Option<String>>>,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext").field("adapter", &self.info.name).field("backend", &self.info.backend).finish()
    }
}

impl GpuContext {
    /// Opens the preferred adapter (see the module documentation) and creates a device with the
    /// adapter's own limits (large buffers for large meshes).
    ///
    /// # Errors
    /// [`GpuError::NoAdapter`] when no adapter exists or none matches `TRANSCUT_GPU_ADAPTER`;
    /// [`GpuError::DeviceRequest`] when the adapter cannot create a device.
    pub fn new() -> Result<GpuContext, GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
        let instance = wgpu::Instance::new(desc);
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
        let seen: Vec<String> =
            adapters.iter().map(|a| a.get_info()).map(|i| format!("{} ({:?}, {:?})", i.name, i.backend, i.device_type)).collect();
        let filter = std::env::var(ADAPTER_ENV).ok().filter(|f| !f.trim().is_empty());
        let rank = |t: wgpu::DeviceType| match t {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Other => 3,
            wgpu::DeviceType::Cpu => 4,
        };
        let adapter = adapters
            .into_iter()
            .filter(|a| filter.as_ref().is_none_or(|f| a.get_info().name.to_lowercase().contains(&f.trim().to_lowercase())))
            .min_by_key(|a| rank(a.get_info().device_type))
            .ok_or_else(|| GpuError::NoAdapter {
                detail: match (&filter, seen.is_empty()) {
                    (_, true) => {
                        format!("no adapter on backends {:?}", wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY))
                    }
                    (Some(f), false) => {
                        format!("none of [{}] matches {ADAPTER_ENV}={f:?}", seen.join(", "))
                    }
                    (None, false) => format!("adapters seen: {}", seen.join(", ")),
                },
            })?;
        let info = adapter.get_info();
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("transcut"),
            required_features: wgpu::Features::empty(),
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| GpuError::DeviceRequest { adapter: info.name.clone(), message: e.to_string() })?;
        let error = Arc::new(Mutex::new(None::<String>));
        let sink = Arc::clone(&error);
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let mut slot = sink.lock().unwrap_or_else(|p| p.into_inner());
            if slot.is_none() {
                *slot = Some(e.to_string());
            }
        }));
        let sink = Arc::clone(&error);
        device.set_device_lost_callback(move |reason, message| {
            let mut slot = sink.lock().unwrap_or_else(|p| p.into_inner());
            if slot.is_none() {
                *slot = Some(format!("device lost ({reason:?}): {message}"));
            }
        });
        Ok(GpuContext {
            device,
            queue,
            info,
            limits,
            pipelines: std::array::from_fn(|_| OnceLock::new()),
            pool: BufferPool::default(),
            error,
        })
    }

    /// The process-wide context, created on first use; a failure is remembered (the same error
    /// is returned on every call) so that `Auto` does not retry a missing driver per bake.
    ///
    /// # Errors
    /// Those of [`GpuContext::new`].
    pub fn shared() -> Result<&'static GpuContext, GpuError> {
        static SHARED: OnceLock<Result<GpuContext, (bool, String, String)>> = OnceLock::new();
        let slot = SHARED.get_or_init(|| {
            GpuContext::new().map_err(|e| match e {
                GpuError::DeviceRequest { adapter, message } => (true, adapter, message),
                // The detail alone: the error is rebuilt around it on every call.
                GpuError::NoAdapter { detail } => (false, String::new(), detail),
                other => (false, String::new(), other.to_string()),
            })
        });
        match slot {
            Ok(c) => Ok(c),
            Err((true, adapter, message)) => Err(GpuError::DeviceRequest { adapter: adapter.clone(), message: message.clone() }),
            Err((false, _, message)) => Err(GpuError::NoAdapter { detail: message.clone() }),
        }
    }

    /// The adapter's name (e.g. "NVIDIA GeForce RTX 4090", "llvmpipe (LLVM 19.1.7, 256 bits)").
    #[must_use]
    pub fn device_name(&self) -> &str {
        &self.info.name
    }

    /// The adapter's description (backend, device type, driver).
    #[must_use]
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.info
    }

    /// Whether the adapter is a software rasteriser running on the CPU (e.g. Mesa's lavapipe,
    /// "llvmpipe"): correct, but slower than the CPU path.
    #[must_use]
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// Number of device buffers the pool has created (buffers are reused across solves).
    #[must_use]
    pub fn buffers_created(&self) -> u64 {
        self.pool.created()
    }

    /// Releases the pooled buffers (device memory) not in use.
    pub fn release_buffers(&self) {
        self.pool.clear();
    }

    pub(crate) fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// The compiled pipeline of a kernel (compiled on first use).
    pub(crate) fn pipeline(&self, kernel: Kernel) -> &wgpu::ComputePipeline {
        let index = Kernel::ALL.iter().position(|&k| k == kernel).expect("every kernel is in Kernel::ALL");
        self.pipelines[index].get_or_init(|| {
            let module = self.device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(kernel.file()),
                source: wgpu::ShaderSource::Wgsl(kernel.source().into()),
            });
            self.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(kernel.file()),
                layout: None,
                module: &module,
                entry_point: Some("main"),
                compilation_options: wgpu::PipelineCompilationOptions::default(),
                cache: None,
            })
        })
    }

    /// A bind group of `kernel` with `buffers` at bindings 0, 1, … in order.
    pub(crate) fn bind(&self, kernel: Kernel, buffers: &[&wgpu::Buffer]) -> wgpu::BindGroup {
        let layout = self.pipeline(kernel).get_bind_group_layout(0);
        let entries: Vec<wgpu::BindGroupEntry<'_>> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(kernel.file()),
            layout: &layout,
            entries: &entries,
        })
    }

    /// Leases a storage buffer of at least `bytes` (also a copy source and destination).
    pub(crate) fn storage(&self, bytes: u64, label: &'static str) -> Result<Lease<'_>, GpuError> {
        self.check_size(bytes, label)?;
        Ok(self.pool.lease(
            &self.device,
            bytes,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            label,
        ))
    }

    /// Leases a storage buffer and fills it with `data`.
    pub(crate) fn upload<T: bytemuck::Pod>(&self, data: &[T], label: &'static str) -> Result<Lease<'_>, GpuError> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let buffer = self.storage(bytes.len() as u64, label)?;
        if !bytes.is_empty() {
            self.queue.write_buffer(&buffer, 0, bytes);
        }
        Ok(buffer)
    }

    /// Leases a uniform buffer holding `value`.
    pub(crate) fn uniform<T: bytemuck::Pod>(&self, value: &T, label: &'static str) -> Lease<'_> {
        let buffer = self.pool.lease(&self.device, 256, wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST, label);
        self.queue.write_buffer(&buffer, 0, bytemuck::bytes_of(value));
        buffer
    }

    fn check_size(&self, bytes: u64, what: &'static str) -> Result<(), GpuError> {
        let limit = self.limits.max_storage_buffer_binding_size.min(self.limits.max_buffer_size);
        if super::pool::size_class(bytes) > limit {
            return Err(GpuError::TooLarge { what, needed: bytes, limit, device: self.info.name.clone() });
        }
        Ok(())
    }

    /// The workgroup grid for `items` invocations: (x, y) with x ≤ 65535 (a 2D grid beyond that;
    /// the kernels flatten it), and the total number of workgroups x·y.
    pub(crate) fn grid(&self, items: usize) -> Result<(u32, u32, u32), GpuError> {
        let groups = items.div_ceil(WORKGROUP as usize).max(1);
        let x = groups.min(MAX_GROUPS_PER_DIM as usize);
        let y = groups.div_ceil(x);
        if y > MAX_GROUPS_PER_DIM as usize {
            return Err(GpuError::TooLarge {
                what: "workgroups of one dispatch",
                needed: groups as u64,
                limit: u64::from(MAX_GROUPS_PER_DIM) * u64::from(MAX_GROUPS_PER_DIM),
                device: self.info.name.clone(),
            });
        }
        Ok((x as u32, y as u32, (x * y) as u32))
    }

    /// Submits `encoder`, waits for the device and reports any device error raised since the
    /// last check.
    pub(crate) fn submit_wait(&self, encoder: wgpu::CommandEncoder, during: &'static str) -> Result<(), GpuError> {
        self.queue.submit([encoder.finish()]);
        self.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::Device { during, message: e.to_string() })?;
        self.take_error(during)
    }

    /// The device error raised since the last check, if any.
    pub(crate) fn take_error(&self, during: &'static str) -> Result<(), GpuError> {
        match self.error.lock().unwrap_or_else(|p| p.into_inner()).take() {
            Some(message) => Err(GpuError::Device { during, message }),
            None => Ok(()),
        }
    }

    /// Copies the first `bytes` of `source` to a staging buffer (appended to `encoder`), submits,
    /// waits and returns them.
    pub(crate) fn read_back(
        &self,
        mut encoder: wgpu::CommandEncoder,
        source: &wgpu::Buffer,
        bytes: u64,
        during: &'static str,
    ) -> Result<Vec<u8>, GpuError> {
        let size = bytes.div_ceil(4) * 4;
        let staging = self.pool.lease(&self.device, size, wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST, "staging");
        if size > 0 {
            encoder.copy_buffer_to_buffer(source, 0, &staging, 0, size);
        }
        self.submit_wait(encoder, during)?;
        if size == 0 {
            return Ok(Vec::new());
        }
        let slice = staging.slice(0..size);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| GpuError::Device { during, message: e.to_string() })?;
        rx.recv()
            .map_err(|e| GpuError::Device { during, message: e.to_string() })?
            .map_err(|e| GpuError::Device { during, message: e.to_string() })?;
        let out = slice.get_mapped_range().map_err(|e| GpuError::Device { during, message: e.to_string() })?.to_vec();
        staging.unmap();
        self.take_error(during)?;
        Ok(out)
    }

    /// A new command encoder.
    pub(crate) fn encoder(&self) -> wgpu::CommandEncoder {
        self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("transcut") })
    }
}

/// Records one dispatch of `kernel` over a (x, y) grid into `pass`.
pub(crate) fn dispatch(
    pass: &mut wgpu::ComputePass<'_>,
    ctx: &GpuContext,
    kernel: Kernel,
    bind: &wgpu::BindGroup,
    grid: (u32, u32),
) {
    pass.set_pipeline(ctx.pipeline(kernel));
    pass.set_bind_group(0, bind, &[]);
    pass.dispatch_workgroups(grid.0, grid.1, 1);
}

#[cfg(test)]
mod tests {
    use super::has_gpu_node;

    #[test]
    fn a_render_node_or_a_vendor_node_is_a_gpu_node() {
        let none = |_: &str| false;
        assert!(!has_gpu_node(Vec::new(), none));
        assert!(!has_gpu_node(vec!["card0".into(), "by-path".into()], none));
        assert!(has_gpu_node(vec!["card0".into(), "renderD128".into()], none));
        assert!(has_gpu_node(Vec::new(), |p| p == "/dev/nvidia0"));
        assert!(has_gpu_node(Vec::new(), |p| p == "/dev/dxg"));
    }
}
