//! What a PRT object can do after its bake, each unchanged on failure:
//!
//! - relight: q at the samples under the new lights, its Haar transform and one sparse product
//!   per vertex (the transfer kept);
//! - a medium edit of the whole object ([`crate::edit::Region::All`]): the new medium's basis
//!   weights and a K-term sum per vertex, nothing else;
//! - a new scale (millimetres per scene unit): the edit σ → σ s of the same transfer.
//!
//! Each result equals, bit for bit, a fresh bake of the same state: the transfer does not depend
//! on the medium and every sum runs in a fixed order.

use std::time::Instant;

use super::PrtState;
use crate::edit::{EditError, MediumEdit, MediumOp, PaintStroke, Region, UpdateStats};
use crate::light::{Light, SourceOptions};
use crate::mesh::{TriMesh, TriangleBvh};
use crate::methods::capability::{EditMedium, Relight};
use crate::methods::Lighting;
use crate::optics::Medium;
use crate::progress::{ms, Progress};
use crate::volume::Coefficients;

/// A PRT object being updated: its state, the lights it is lit by (with its own shadows, as
/// every session object) and its radiance at the output vertices.
#[derive(Debug, Clone)]
pub struct PrtLive {
    state: PrtState,
    lights: Vec<Light>,
    occluder: Option<TriangleBvh>,
    source: SourceOptions,
    radiance: Vec<[f64; 3]>,
    clamped: usize,
}

/// What a relight replaced. The transfer's product under the old irradiance is not kept (the
/// relight writes the new one over its buffer): an undo computes it again, the same bit for bit.
#[derive(Debug)]
pub struct PrtUndo {
    lights: Vec<Light>,
    irradiance: Vec<[f64; 3]>,
    radiance: Vec<[f64; 3]>,
    clamped: usize,
}

impl PrtLive {
    /// The live state of a bake: `state` solved under `lights` to `radiance`, `surface` the
    /// object's world surface (its own shadows).
    #[must_use]
    pub(crate) fn new(
        state: PrtState,
        lights: &[Light],
        radiance: Vec<[f64; 3]>,
        surface: Option<&TriMesh>,
        source: SourceOptions,
    ) -> Self {
        let occluder = surface.map(|s| TriangleBvh::from_indexed(s.positions(), s.triangles()));
        let (_, clamped) = state.radiance();
        Self { state, lights: lights.to_vec(), occluder, source, radiance, clamped }
    }

    #[must_use]
    pub fn state(&self) -> &PrtState {
        &self.state
    }

    /// The radiance at the output vertices after the last update.
    #[must_use]
    pub fn radiance(&self) -> &[[f64; 3]] {
        &self.radiance
    }

    /// The output vertices the last update's clamp at zero changed.
    #[must_use]
    pub fn clamped_vertices(&self) -> usize {
        self.clamped
    }

    /// The object's medium becomes `medium` (η and g as the object's: the samples' irradiance
    /// depends on η); only the basis weights and the per-vertex sums change.
    ///
    /// # Errors
    /// [`EditError::InvalidOptions`] for another η or g, [`EditError::Prt`] for a medium the
    /// transfer cannot take; the state is then unchanged.
    pub fn set_medium(&mut self, medium: Medium) -> Result<UpdateStats, EditError> {
        MediumOp::Assign(medium).validate(self.state.medium.eta, self.state.medium.g)?;
        self.reweight(medium, self.state.mm_per_unit)
    }

    /// The object's scale becomes `mm_per_unit` millimetres per scene unit: for the transfer,
    /// the medium's coefficients scaled by the ratio to the scale it was computed at
    /// (Rd(s r; σ) s² = Rd(r; s σ)).
    ///
    /// # Errors
    /// [`EditError::InvalidOptions`] for a scale that is not finite and > 0, [`EditError::Prt`]
    /// for a scaled medium the transfer cannot take; the state is then unchanged.
    pub fn set_mm_per_unit(&mut self, mm_per_unit: f64) -> Result<UpdateStats, EditError> {
        if !(mm_per_unit.is_finite() && mm_per_unit > 0.0) {
            return Err(EditError::InvalidOptions(format!("mm_per_unit {mm_per_unit} must be finite and > 0")));
        }
        self.reweight(self.state.medium, mm_per_unit)
    }

    fn reweight(&mut self, medium: Medium, mm_per_unit: f64) -> Result<UpdateStats, EditError> {
        let start = Instant::now();
        let (weights, residual) = self.state.weights_of(&medium, mm_per_unit).map_err(EditError::from)?;
        let select_ms = ms(start);
        let t = Instant::now();
        self.state.medium = medium;
        self.state.mm_per_unit = mm_per_unit;
        self.state.weights = weights;
        self.state.residual = residual;
        (self.radiance, self.clamped) = self.state.radiance();
        Ok(update_stats(select_ms, 0.0, ms(t), start))
    }
}

/// The statistics of an update: finding the new weights, the light, the per-vertex sums.
fn update_stats(select_ms: f64, source_ms: f64, solve_ms: f64, start: Instant) -> UpdateStats {
    UpdateStats {
        pieces_solved: 1,
        iterations: [0; 3],
        rows_rebuilt: 0,
        tets_changed: 0,
        select_ms,
        source_ms,
        assembly_ms: 0.0,
        hierarchy_ms: 0.0,
        solve_ms,
        total_ms: ms(start),
        cut: None,
    }
}

impl Relight for PrtLive {
    type Undo = PrtUndo;

    fn relight(&mut self, lights: &[Light], progress: Progress) -> Result<(UpdateStats, PrtUndo), EditError> {
        let start = Instant::now();
        let lighting = Lighting { lights, occluder: self.occluder.as_ref(), source: &self.source };
        let q = self.state.irradiance(&lighting, self.state.medium.eta, &|f| progress.report("light", 0.8 * f))?;
        let source_ms = ms(start);
        progress.report("product", 0.8)?;
        let t = Instant::now();
        self.state.set_product(&q);
        let irradiance = std::mem::replace(&mut self.state.irradiance, q);
        let (radiance, clamped) = self.state.radiance();
        let undo = PrtUndo {
            lights: std::mem::replace(&mut self.lights, lights.to_vec()),
            irradiance,
            radiance: std::mem::replace(&mut self.radiance, radiance),
            clamped: std::mem::replace(&mut self.clamped, clamped),
        };
        Ok((update_stats(0.0, source_ms, ms(t), start), undo))
    }

    fn undo_relight(&mut self, undo: PrtUndo) -> Result<(), EditError> {
        if undo.irradiance.len() != self.state.irradiance.len() || undo.radiance.len() != self.radiance.len() {
            return Err(EditError::InvalidOptions("the undo is of another object's relight".into()));
        }
        self.state.set_product(&undo.irradiance);
        self.lights = undo.lights;
        self.state.irradiance = undo.irradiance;
        self.radiance = undo.radiance;
        self.clamped = undo.clamped;
        Ok(())
    }

    fn user_radiance(&self) -> Option<Vec<[f64; 3]>> {
        Some(self.radiance.clone())
    }
}

impl EditMedium for PrtLive {
    fn edit_medium(&mut self, edit: &MediumEdit, progress: Progress) -> Result<UpdateStats, EditError> {
        if edit.region != Region::All {
            return Err(EditError::InvalidRegion(
                "the prt method edits the medium of the whole object only (one homogeneous medium): use the whole-object \
                 region, or transcut for regions"
                    .into(),
            ));
        }
        let m = self.state.medium;
        edit.op.validate(m.eta, m.g)?;
        let new = edit.op.apply(&Coefficients::new(m.sigma_a, m.sigma_s_prime));
        progress.report("medium", 0.0)?;
        self.set_medium(Medium { sigma_a: new.sigma_a, sigma_s_prime: new.sigma_s_prime, ..m })
    }

    fn paint(&mut self, _stroke: &PaintStroke, _progress: Progress) -> Result<UpdateStats, EditError> {
        Err(EditError::InvalidStroke(
            "the prt method holds one homogeneous medium per object and cannot paint; use transcut to paint media".into(),
        ))
    }
}
