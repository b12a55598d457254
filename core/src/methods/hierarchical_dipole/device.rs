//! Where a hierarchical-dipole object's updates run: the CPU hierarchy, or in on-the-fly mode
//! its twin on a GPU ([`crate::gpu::GpuDipole`]), chosen by `TRANSCUT_BACKEND` (`auto` by
//! default: a hardware GPU when one exists, as for TransCut's solves). Render and incremental
//! modes keep their links on the CPU, and the paper's source geometry has no device kernels:
//! `gpu` refuses them by name, `auto` says why it stayed on the CPU.

use crate::edit::EditError;
use crate::gpu::{self, Backend, DeviceChoice, GpuError};
use crate::hierarchy::{DipoleHierarchy, DipoleStats, EvalMode, HierarchyError};
use crate::optics::DipoleGeometry;

/// Why an update failed: the hierarchy's input, or the device.
#[derive(Debug)]
pub(crate) enum UpdateError {
    Hierarchy(HierarchyError),
    Gpu(GpuError),
}

impl From<GpuError> for UpdateError {
    fn from(e: GpuError) -> Self {
        match e {
            GpuError::Hierarchy(e) => Self::Hierarchy(e),
            e => Self::Gpu(e),
        }
    }
}

impl From<UpdateError> for EditError {
    fn from(e: UpdateError) -> Self {
        match e {
            UpdateError::Hierarchy(e) => e.into(),
            UpdateError::Gpu(e) => EditError::Gpu(e),
        }
    }
}

/// The device of one object's updates; none: the CPU.
#[derive(Debug, Default)]
pub(crate) struct OnDevice {
    #[cfg(feature = "gpu")]
    context: Option<&'static gpu::GpuContext>,
    /// The hierarchy on the device and the [`DipoleHierarchy::topology`] it was uploaded
    /// from; made (again) by the next update when missing or stale.
    #[cfg(feature = "gpu")]
    uploaded: Option<(Box<gpu::GpuDipole<'static>>, u64)>,
}

impl Clone for OnDevice {
    /// The same device; the copy uploads its own hierarchy at its first update.
    fn clone(&self) -> Self {
        Self {
            #[cfg(feature = "gpu")]
            context: self.context,
            #[cfg(feature = "gpu")]
            uploaded: None,
        }
    }
}

impl OnDevice {
    /// The device `TRANSCUT_BACKEND` picks for `hierarchy` (module documentation), and for
    /// `auto` on the CPU why. A device cuts `hierarchy`'s receivers for it
    /// ([`gpu::GpuDipole::for_device`]).
    ///
    /// # Errors
    /// An unknown backend; for `gpu`, a mode or geometry the device does not run, or no device.
    pub(crate) fn choose(hierarchy: &mut DipoleHierarchy) -> Result<(Self, Option<String>), GpuError> {
        let backend = Backend::from_env_or(Backend::Auto)?;
        let options = hierarchy.options();
        let unsupported = if options.mode != EvalMode::OnTheFly {
            Some("the hierarchical dipole's render and incremental modes on the GPU (they keep their links on the CPU; the on-the-fly mode runs there)")
        } else if options.geometry != DipoleGeometry::Distance {
            Some("the hierarchical dipole's paper source geometry (DipoleGeometry::PaperSources) on the GPU")
        } else {
            None
        };
        if let Some(what) = unsupported {
            return match backend {
                Backend::Cpu => Ok((Self::default(), None)),
                Backend::Auto => Ok((Self::default(), Some(format!("{what} is not supported")))),
                Backend::Gpu => Err(GpuError::Unsupported { what }),
            };
        }
        match gpu::choose_device(backend)? {
            (DeviceChoice::Cpu, fallback) => Ok((Self::default(), fallback)),
            #[cfg(feature = "gpu")]
            (DeviceChoice::Gpu(context), _) => {
                let device = gpu::GpuDipole::for_device(context, hierarchy)?;
                Ok((Self { context: Some(context), uploaded: Some((Box::new(device), hierarchy.topology())) }, None))
            }
        }
    }

    /// The GPU's name, when the updates run on one.
    pub(crate) fn name(&self) -> Option<String> {
        #[cfg(feature = "gpu")]
        if let Some(context) = self.context {
            return Some(context.device_name().to_owned());
        }
        None
    }

    /// B per vertex of `hierarchy` under `q`: on the device (its trees refitted to the
    /// hierarchy's positions first when they moved, uploaded again when the hierarchy has new
    /// trees), else [`DipoleHierarchy::update`]. `keep_going` is asked before the device runs
    /// (its kernels are not interrupted).
    pub(crate) fn update(
        &mut self,
        hierarchy: &mut DipoleHierarchy,
        q: &[[f64; 3]],
        keep_going: &(dyn Fn() -> bool + Sync),
    ) -> Result<(Vec<[f64; 3]>, DipoleStats), UpdateError> {
        #[cfg(feature = "gpu")]
        if let Some(context) = self.context {
            let topology = hierarchy.topology();
            let device = match &mut self.uploaded {
                Some((device, at)) if *at == topology => device,
                slot => &mut slot.insert((Box::new(gpu::GpuDipole::new(context, hierarchy)?), topology)).0,
            };
            if device.positions() != hierarchy.positions() {
                device.set_positions(hierarchy.positions())?;
            }
            if !keep_going() {
                return Err(UpdateError::Hierarchy(HierarchyError::Cancelled(crate::progress::Cancelled)));
            }
            let (b, s) = device.update(q)?;
            let (emitters, receivers) = (hierarchy.emitter_tree(), hierarchy.receiver_tree());
            let stats = DipoleStats {
                triangles: emitters.item_count(),
                receivers: receivers.item_count(),
                nodes: emitters.nodes().len() + receivers.nodes().len(),
                links: s.links,
                near_links: s.near_links,
                form_factors: s.links,
                stale_tasks: 0,
                refit_ms: s.refit_ms,
                link_ms: s.traverse_ms,
                gather_ms: s.pull_ms,
                push_ms: s.push_ms,
            };
            return Ok((b, stats));
        }
        hierarchy.update(q, keep_going).map_err(UpdateError::Hierarchy)
    }
}
