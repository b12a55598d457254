//! Where a PRT object's transfer product runs: on the CPU ([`Transfer::apply`]) or its twin on a
//! GPU ([`crate::gpu::GpuPrt`], the transfer uploaded once at the bake), chosen by
//! `TRANSCUT_BACKEND` (`auto` by default: a hardware GPU when one exists, never a software
//! adapter), as for the hierarchical dipole. With `auto`, a transfer the device cannot hold stays
//! on the CPU and the statistics say why; `gpu` makes that an error.
//!
//! The combine into radiance stays on the CPU in f64 on either path: medium edits and scale
//! changes re-weight the same product, and the scale identity Rd(s r; σ) s² = Rd(r; s σ) holds
//! to 1e-12 only in f64 (the device's `prt_combine.wgsl` is f32). The device's product differs
//! from the CPU's by f32 rounding (≤ 1e-5 relative, `core/tests/gpu_prt.rs`) and does not depend
//! on the run, so a relight still equals a fresh bake on the same device bit for bit. A device
//! error during a relight falls back to the CPU's product for that relight and every later one;
//! [`PrtDevice::failure`] keeps the reason.

use std::sync::{Arc, Mutex};

use crate::gpu::{self, Backend, DeviceChoice, GpuError};
use crate::prt::Transfer;

/// The device of one object's transfer product; none: the CPU.
#[derive(Clone, Default)]
pub(crate) struct PrtDevice {
    /// The transfer on the device, shared by copies of the state (it is the same transfer).
    #[cfg(feature = "gpu")]
    uploaded: Option<Arc<gpu::GpuPrt<'static>>>,
    /// Why the device was given up after the bake, if it was.
    failure: Arc<Mutex<Option<String>>>,
}

impl std::fmt::Debug for PrtDevice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PrtDevice").field("device", &self.name()).field("failure", &self.failure()).finish()
    }
}

impl PrtDevice {
    /// The device `TRANSCUT_BACKEND` picks for `transfer`, with it uploaded, and for `auto` on
    /// the CPU why.
    ///
    /// # Errors
    /// An unknown backend; for `gpu`, no device or a transfer it cannot hold.
    pub(crate) fn choose(transfer: &Transfer) -> Result<(Self, Option<String>), GpuError> {
        let backend = Backend::from_env_or(Backend::Auto)?;
        #[cfg(not(feature = "gpu"))]
        let _ = transfer;
        match gpu::choose_device(backend)? {
            (DeviceChoice::Cpu, fallback) => Ok((Self::default(), fallback)),
            #[cfg(feature = "gpu")]
            (DeviceChoice::Gpu(context), _) => match gpu::GpuPrt::new(context, transfer) {
                Ok(device) => Ok((Self { uploaded: Some(Arc::new(device)), failure: Arc::default() }, None)),
                Err(e) if backend == Backend::Auto => {
                    Ok((Self::default(), Some(format!("the PRT transfer stays on the CPU: {e}"))))
                }
                Err(e) => Err(e),
            },
        }
    }

    /// The GPU's name, when the product runs on one.
    pub(crate) fn name(&self) -> Option<String> {
        #[cfg(feature = "gpu")]
        if let Some(device) = &self.uploaded {
            if self.failure().is_none() {
                return Some(device.device_name().to_owned());
            }
        }
        None
    }

    /// Why the device was given up after the bake (a device error during a relight), if it was.
    pub(crate) fn failure(&self) -> Option<String> {
        self.failure.lock().unwrap_or_else(std::sync::PoisonError::into_inner).clone()
    }

    /// (Tₖ^w q^w)[v] into `out` as [`Transfer::apply`] writes it: on the device when the object
    /// has one (and it has not failed), else on the CPU.
    pub(crate) fn apply(&self, transfer: &Transfer, q_haar: &[[f32; 4]], out: &mut [f64]) {
        #[cfg(feature = "gpu")]
        if let Some(device) = self.uploaded.as_ref().filter(|_| self.failure().is_none()) {
            match device.apply(q_haar) {
                Ok(product) if product.len() == out.len() => {
                    out.copy_from_slice(&product);
                    return;
                }
                Ok(_) => self.fail("the device's PRT product has another length than the transfer's".into()),
                Err(e) => self.fail(e.to_string()),
            }
        }
        transfer.apply(q_haar, out);
    }

    #[cfg(feature = "gpu")]
    fn fail(&self, why: String) {
        *self.failure.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = Some(why);
    }
}
