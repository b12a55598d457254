//! The hierarchical dipole (Mertens et al. 2003) behind the method contract: the dipole of a
//! homogeneous medium integrated over the object's surface by [`crate::hierarchy`], with no
//! volume and no solve, fast enough to redo for every frame of a deforming mesh.
//!
//! - `check`: the medium must be homogeneous (the dipole is the half-space solution of one
//!   medium): anything else is refused by name, never baked as a wrong picture;
//! - `prepare`: the cluster trees over the world surface in millimetres (and, in render and
//!   incremental modes, nothing else until the first solve links them);
//! - `solve`: q at the surface's vertices along their area-weighted normals
//!   ([`super::Lighting`], shadows by every object), B from the hierarchy, and
//!   Lo = B · [`crate::hierarchy::DipoleRadiance::per_exitance`] at the user's vertices.
//!
//! What the method models differently from TransCut (design/hierarchical-dipole.md §3.3): the
//! dipole is the half-space solution reused with Euclidean distances, so light crosses air gaps
//! and a closed object's trapped light is missing (on the R = 10 mm marble sphere, 0.90 of
//! TransCut's radiance); on an open scan B falls near the holes, which emit nothing.
//!
//! The capabilities ([`capabilities`]) are relighting and deformation (new vertex positions,
//! the same topology).
//!
//! In on-the-fly mode the updates run on the GPU `TRANSCUT_BACKEND` picks (`auto`: a hardware
//! GPU when one exists; [`device`]), the same hierarchy's twin in f32; the statistics name the
//! device, or why `auto` stayed on the CPU.

mod capabilities;
mod device;

pub use capabilities::{DipoleLive, DipoleUndo};

use std::time::Instant;

use super::{BakedState, Lighting, ObjectStats, Stage, SubsurfaceMethod, Target};
use glam::DMat4;

use crate::gpu::Backend;
use crate::hierarchy::{DipoleHierarchy, DipoleOptions, DipoleStats, HierarchyError};
use crate::light::LightError;
use crate::optics::{Dipole, Medium};
use crate::progress::ms;
use crate::scene::SceneError;

/// The hierarchical dipole method ([`SubsurfaceMethod`]).
pub struct HierarchicalDipole;

/// The method's name.
pub const NAME: &str = "hierarchical-dipole";

/// What a hierarchical-dipole bake keeps of one object ([`super::ObjectBake::state`]).
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct DipoleState {
    /// The cluster trees and links over the world surface (millimetres).
    pub hierarchy: Box<DipoleHierarchy>,
    /// The object's homogeneous medium.
    pub medium: Medium,
    /// Millimetres per scene unit of the object.
    pub mm_per_unit: f64,
    /// The irradiance q per surface vertex of the last solve.
    pub irradiance: Vec<[f64; 3]>,
    /// What the last solve measured.
    pub stats: DipoleStats,
    /// Per output vertex ([`crate::scene::Shape::output_vertex_count`]), the surface vertex
    /// whose radiance it takes (`None`: inside a tet mesh, 0).
    pub(crate) output: Vec<Option<u32>>,
    /// Per surface vertex, the first output vertex that stands for it (where new positions are
    /// read).
    pub(crate) first_output: Vec<u32>,
    /// The object's transform (object → world).
    pub(crate) transform: DMat4,
    /// Lo per unit B ([`crate::hierarchy::DipoleRadiance::per_exitance`] at the medium's η).
    pub(crate) per_exitance: f64,
    /// Where the updates run.
    pub(crate) device: device::OnDevice,
}

impl DipoleState {
    /// The refractive index at the surface.
    #[must_use]
    pub fn eta(&self) -> f64 {
        self.medium.eta
    }
}

/// The dipole of `medium` per channel.
pub(crate) fn dipoles(medium: &Medium) -> [Dipole; 3] {
    [0, 1, 2].map(|c| medium.dipole(c))
}

/// The light entering at every vertex of `hierarchy` along its area-weighted normal; 0 at a
/// vertex on no triangle of positive area (a tet mesh's interior vertices, which its boundary
/// surface keeps), which has no normal and emits nothing.
pub(crate) fn surface_irradiance(
    hierarchy: &DipoleHierarchy,
    lighting: &Lighting<'_>,
    eta: f64,
    mm_per_unit: f64,
    poll: crate::light::Poll<'_>,
) -> Result<Vec<[f64; 3]>, LightError> {
    let normals = hierarchy.vertex_normals();
    let on_surface: Vec<usize> = (0..normals.len()).filter(|&v| normals[v] != glam::DVec3::ZERO).collect();
    // The lights live in scene units: the points go back from millimetres.
    let points: Vec<_> = on_surface.iter().map(|&v| hierarchy.positions()[v] / mm_per_unit).collect();
    let normals_on: Vec<_> = on_surface.iter().map(|&v| normals[v]).collect();
    let q_on = lighting.transmitted_source_with(&points, &normals_on, eta, poll)?;
    let mut q = vec![[0.0; 3]; normals.len()];
    for (&v, value) in on_surface.iter().zip(q_on) {
        q[v] = value;
    }
    Ok(q)
}

impl DipoleState {
    /// B at the surface's vertices under `q`, on the object's device ([`device`]).
    pub(crate) fn evaluate(
        &mut self,
        q: &[[f64; 3]],
        keep_going: &(dyn Fn() -> bool + Sync),
    ) -> Result<(Vec<[f64; 3]>, DipoleStats), device::UpdateError> {
        self.device.update(&mut self.hierarchy, q, keep_going)
    }

    /// The GPU the updates run on, when they do.
    #[must_use]
    pub fn device_name(&self) -> Option<String> {
        self.device.name()
    }

    /// Lo at the output vertices from B at the surface's vertices, clamped at 0 (B ≥ 0 up to
    /// the expansion's rounding).
    pub(crate) fn radiance(&self, b: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.output.iter().map(|v| v.map_or([0.0; 3], |v| b[v as usize].map(|x| (x * self.per_exitance).max(0.0)))).collect()
    }
}

/// The scene error of a hierarchy error of object `target`.
pub(crate) fn scene_error(target: &Target<'_>, e: HierarchyError) -> SceneError {
    match e {
        HierarchyError::Cancelled(c) => SceneError::Cancelled(c),
        e => target.invalid(e.to_string()),
    }
}

impl SubsurfaceMethod for HierarchicalDipole {
    type Options = DipoleOptions;
    type State = DipoleState;

    fn check(target: &Target<'_>, options: &DipoleOptions) -> Result<(), SceneError> {
        options.validate().map_err(SceneError::InvalidOptions)?;
        target.medium(NAME)?;
        super::homogeneous_medium(target.object).map(|_| ()).map_err(|reason| SceneError::Unsupported {
            index: target.index,
            name: target.object.name.clone(),
            method: NAME,
            reason,
        })
    }

    fn prepare(
        target: &Target<'_>,
        options: &DipoleOptions,
        stats: &mut ObjectStats,
        stage: Stage<'_>,
    ) -> Result<DipoleState, SceneError> {
        stage("hierarchy", 0.0)?;
        let t = Instant::now();
        let medium = super::homogeneous_medium(target.object).map_err(|reason| target.invalid(reason))?;
        medium.validate().map_err(|e| target.invalid(format!("medium: {e}")))?;
        let mm = target.object.mm_per_unit;
        let surface = target.world;
        let positions = surface.positions().iter().map(|p| *p * mm).collect();
        let mut hierarchy = Box::new(
            DipoleHierarchy::new(positions, surface.triangles().to_vec(), dipoles(&medium), *options)
                .map_err(|e| scene_error(target, e))?,
        );
        let (device, fallback) = device::OnDevice::choose(&mut hierarchy).map_err(|source| SceneError::Gpu {
            index: target.index,
            name: target.object.name.clone(),
            source,
        })?;
        if let Some(name) = device.name() {
            stats.backend = Backend::Gpu;
            stats.device = Some(name);
        }
        stats.backend_fallback = fallback;
        let output = super::output_map(target.object, surface);
        let mut first_output = vec![u32::MAX; surface.positions().len()];
        for (o, v) in output.iter().enumerate().rev() {
            if let Some(v) = v {
                first_output[*v as usize] = o as u32;
            }
        }
        stats.meshing_ms = ms(t);
        stats.vertices = surface.positions().len();
        stats.boundary_vertices = surface.positions().len();
        Ok(DipoleState {
            hierarchy,
            medium,
            mm_per_unit: mm,
            irradiance: Vec::new(),
            stats: DipoleStats::default(),
            output,
            first_output,
            transform: target.object.transform,
            per_exitance: options.radiance.per_exitance(medium.eta),
            device,
        })
    }

    fn solve(
        target: &Target<'_>,
        state: &mut DipoleState,
        lighting: &Lighting<'_>,
        _options: &DipoleOptions,
        stats: &mut ObjectStats,
        stage: Stage<'_>,
    ) -> Result<Vec<[f64; 3]>, SceneError> {
        stage("light", 0.1)?;
        let t = Instant::now();
        let q = surface_irradiance(&state.hierarchy, lighting, state.medium.eta, state.mm_per_unit, &|f| {
            stage("light", 0.1 + 0.4 * f)
        })?;
        stats.source_ms = ms(t);
        stage("gather", 0.5)?;
        let t = Instant::now();
        let keep_going = || stage("gather", 0.5).is_ok();
        let (b, dipole_stats) = state.evaluate(&q, &keep_going).map_err(|e| match e {
            device::UpdateError::Hierarchy(e) => scene_error(target, e),
            device::UpdateError::Gpu(source) => SceneError::Gpu { index: target.index, name: target.object.name.clone(), source },
        })?;
        stats.assembly_ms = dipole_stats.link_ms;
        stats.solve_ms = ms(t);
        state.irradiance = q;
        state.stats = dipole_stats;
        Ok(state.radiance(&b))
    }

    fn into_baked(state: DipoleState) -> BakedState {
        BakedState::HierarchicalDipole(state)
    }
}
