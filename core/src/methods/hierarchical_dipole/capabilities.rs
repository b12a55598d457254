//! What a hierarchical-dipole object can do after its bake: relight (the trees and, in render
//! and incremental modes, the links kept; only the irradiance is new) and deform (new vertex
//! positions, the trees refitted and relinked as the mode says). Each is unchanged on failure.

use std::time::Instant;

use glam::DVec3;

use super::{surface_irradiance, DipoleState};
use crate::edit::{EditError, UpdateStats};
use crate::light::{Light, SourceOptions};
use crate::mesh::TriangleBvh;
use crate::methods::capability::{Deform, Relight};
use crate::methods::Lighting;
use crate::progress::{ms, Progress};

/// A hierarchical-dipole object being updated: its state, the lights it is lit by (with its
/// own shadows, as every session object) and its radiance at the output vertices.
#[derive(Debug, Clone)]
pub struct DipoleLive {
    state: DipoleState,
    lights: Vec<Light>,
    /// The surface where it is now, in scene units, when it shadows itself; rebuilt when the
    /// vertices move, kept across relights.
    occluder: Option<TriangleBvh>,
    source: SourceOptions,
    radiance: Vec<[f64; 3]>,
}

/// What a relight replaced.
#[derive(Debug)]
pub struct DipoleUndo {
    lights: Vec<Light>,
    irradiance: Vec<[f64; 3]>,
    radiance: Vec<[f64; 3]>,
    /// The positions the relight saw, to check that the undo fits.
    positions: Vec<DVec3>,
}

impl DipoleLive {
    /// The live state of a bake: `state` solved under `lights` to `radiance`.
    #[must_use]
    pub(crate) fn new(
        state: DipoleState,
        lights: &[Light],
        radiance: Vec<[f64; 3]>,
        shadows: bool,
        source: SourceOptions,
    ) -> Self {
        let occluder = shadows.then(|| occluder_of(&state));
        Self { state, lights: lights.to_vec(), occluder, source, radiance }
    }

    #[must_use]
    pub fn state(&self) -> &DipoleState {
        &self.state
    }

    /// The radiance at the output vertices after the last update.
    #[must_use]
    pub fn radiance(&self) -> &[[f64; 3]] {
        &self.radiance
    }

    /// q at the surface's current vertices under `lights`, shadowed by the surface itself.
    fn irradiance(&self, lights: &[Light], progress: Progress) -> Result<Vec<[f64; 3]>, EditError> {
        let lighting = Lighting { lights, occluder: self.occluder.as_ref(), source: &self.source };
        let (h, mm) = (&self.state.hierarchy, self.state.mm_per_unit);
        surface_irradiance(h, &lighting, self.state.medium.eta, mm, &|f| progress.report("light", 0.5 * f))
            .map_err(EditError::from)
    }

    /// The hierarchy's update under `q`, reported as the second half of `progress`.
    fn gather(&mut self, q: &[[f64; 3]], progress: Progress) -> Result<(Vec<[f64; 3]>, f64, f64), EditError> {
        progress.report("gather", 0.5)?;
        let t = Instant::now();
        let keep_going = || progress.report("gather", 0.5).is_ok();
        let (b, stats) = self.state.evaluate(q, &keep_going)?;
        self.state.stats = stats;
        Ok((b, stats.refit_ms + stats.link_ms, ms(t)))
    }
}

/// The surface of `state` where it is now (scene units), as the occluder of its own shadows.
fn occluder_of(state: &DipoleState) -> TriangleBvh {
    let h = &state.hierarchy;
    let world: Vec<DVec3> = h.positions().iter().map(|p| *p / state.mm_per_unit).collect();
    TriangleBvh::from_indexed(&world, h.triangles())
}

/// The statistics of an update that took `source_ms` for the light, `link_ms` for refitting
/// and linking and `solve_ms` for the whole hierarchy update.
fn update_stats(source_ms: f64, link_ms: f64, solve_ms: f64, start: Instant) -> UpdateStats {
    UpdateStats {
        pieces_solved: 1,
        iterations: [0; 3],
        rows_rebuilt: 0,
        tets_changed: 0,
        select_ms: 0.0,
        source_ms,
        assembly_ms: link_ms,
        hierarchy_ms: 0.0,
        solve_ms,
        total_ms: ms(start),
        cut: None,
    }
}

impl Relight for DipoleLive {
    type Undo = DipoleUndo;

    fn relight(&mut self, lights: &[Light], progress: Progress) -> Result<(UpdateStats, DipoleUndo), EditError> {
        let start = Instant::now();
        let q = self.irradiance(lights, progress)?;
        let source_ms = ms(start);
        let (b, link_ms, solve_ms) = self.gather(&q, progress)?;
        let undo = DipoleUndo {
            lights: std::mem::replace(&mut self.lights, lights.to_vec()),
            irradiance: std::mem::replace(&mut self.state.irradiance, q),
            radiance: std::mem::replace(&mut self.radiance, self.state.radiance(&b)),
            positions: self.state.hierarchy.positions().to_vec(),
        };
        Ok((update_stats(source_ms, link_ms, solve_ms, start), undo))
    }

    fn undo_relight(&mut self, undo: DipoleUndo) -> Result<(), EditError> {
        if undo.positions != self.state.hierarchy.positions() {
            return Err(EditError::InvalidOptions("the object moved since the relight that is to be undone".into()));
        }
        self.lights = undo.lights;
        self.state.irradiance = undo.irradiance;
        self.radiance = undo.radiance;
        Ok(())
    }

    fn user_radiance(&self) -> Option<Vec<[f64; 3]>> {
        Some(self.radiance.clone())
    }
}

impl Deform for DipoleLive {
    fn set_positions(&mut self, positions: &[[f64; 3]], progress: Progress) -> Result<UpdateStats, EditError> {
        let start = Instant::now();
        let state = &self.state;
        if positions.len() != state.output.len() {
            return Err(EditError::Hierarchy(crate::hierarchy::HierarchyError::WrongLength {
                what: "positions",
                expected: state.output.len(),
                got: positions.len(),
            }));
        }
        if let Some(vertex) = positions.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
            return Err(EditError::Hierarchy(crate::hierarchy::HierarchyError::NonFinite { vertex, value: positions[vertex] }));
        }
        // Object space → world → millimetres, read at each surface vertex's first output vertex
        // (welded duplicates move as one).
        let mm = state.mm_per_unit;
        let old = state.hierarchy.positions().to_vec();
        let moved: Vec<DVec3> = state
            .first_output
            .iter()
            .zip(&old)
            .map(|(&o, &p)| match positions.get(o as usize) {
                Some(x) => state.transform.transform_point3(DVec3::from_array(*x)) * mm,
                None => p,
            })
            .collect();
        if let Some(vertex) = moved.iter().position(|p| !p.is_finite()) {
            return Err(EditError::Hierarchy(crate::hierarchy::HierarchyError::NonFinite {
                vertex,
                value: moved[vertex].to_array(),
            }));
        }
        self.state.hierarchy.set_positions(&moved)?;
        // The light stage's time includes the shadow occluder's rebuild.
        let t = Instant::now();
        let moved_occluder = self.occluder.as_ref().map(|_| occluder_of(&self.state));
        let old_occluder = std::mem::replace(&mut self.occluder, moved_occluder);
        let outcome = self.irradiance(&self.lights.clone(), progress).and_then(|q| {
            let source_ms = ms(t);
            self.gather(&q, progress).map(|g| (q, source_ms, g))
        });
        match outcome {
            Ok((q, source_ms, (b, link_ms, solve_ms))) => {
                self.state.irradiance = q;
                self.radiance = self.state.radiance(&b);
                Ok(update_stats(source_ms, link_ms, solve_ms, start))
            }
            Err(e) => {
                // Back where it was: the same positions give the same trees, and links made
                // again from them the same form factors.
                self.state.hierarchy.set_positions(&old).expect("the positions it had are valid");
                self.occluder = old_occluder;
                Err(e)
            }
        }
    }
}
