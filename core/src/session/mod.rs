//! A baked scene kept for interactive work: every object's bake and, from its first update on,
//! its method's live state, with the lights they were solved under. The C ABI, the CLI and the
//! tests all edit through it, so they share one behaviour:
//!
//! - every update of an object starts from its last solution (TransCut §4.2's warm start);
//! - a failed update changes nothing (each capability leaves its state unchanged on error, and
//!   a live state made for a failed update is not kept);
//! - [`Session::relight`] relights every object or none: the objects relit before a failure or
//!   a cancellation are undone, last first;
//! - every call reports its stages as `"<object>: <stage>"` to a [`Progress`] and a cancel
//!   through it is [`SessionError::Cancelled`], with nothing changed, like any other failure;
//! - a capability an object's method lacks is refused with [`SessionError::Unsupported`],
//!   naming the method ([`crate::methods::capability`]).
//!
//! Each object is lit by the session's lights with its own shadows: unlike a bake, other
//! objects cast none on it in updates. A bake by translucent radiosity is the exception: its
//! objects exchange light, so the whole scene is one live state ([`RadiositySession`]) that
//! relights, and changes albedos, emissions and media, as a whole, with every object's
//! shadows; it offers no per-object edits (regions, paint, cuts, deformation).

use std::sync::Arc;

use glam::DMat4;

use crate::bake::{bake_with, with_threads, Bake};
use crate::edit::{Cutter, EditError, EditOptions, Editor, MediumEdit, PaintStroke, RelightUndo, UpdateStats};
use crate::light::Light;
use crate::mesh::TriangleBvh;
use crate::methods::capability::{Cut, Deform, EditMedium, Relight};
use crate::methods::hierarchical_dipole::{DipoleLive, DipoleUndo};
use crate::methods::prt::{PrtLive, PrtState, PrtUndo};
use crate::methods::{interpolate_vertices, BakedState, ObjectBake, ObjectStats, RadiositySession, RadiosityUpdate};
use crate::progress::{Cancelled, Progress};
use crate::render::Image;
use crate::scene::{BakeOptions, MediumSource, Method, Scene, SceneError, Stencil, TransCutOptions};
use crate::texture::{self, TexelSample, TextureError, TextureOptions};

/// Why a session call failed. Nothing changed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SessionError {
    /// An object index is out of range.
    #[error("object {index} does not exist (the session has {count} objects)")]
    NoSuchObject { index: usize, count: usize },
    /// The object's method cannot do what was asked.
    #[error("object {index} ({name}): the {method} method cannot {capability}")]
    Unsupported { index: usize, name: String, method: &'static str, capability: &'static str },
    /// The update of an object failed.
    #[error("object {index} ({name}): {source}")]
    Edit {
        index: usize,
        name: String,
        #[source]
        source: Box<EditError>,
    },
    /// An update of a radiosity bake failed (the error names the object at fault).
    #[error("{0}")]
    Coupled(Box<SceneError>),
    /// The worker threads could not be started.
    #[error("invalid session option: {0}")]
    InvalidOptions(String),
    /// Cancelled through the progress callback.
    #[error("{0}; nothing changed")]
    Cancelled(#[from] Cancelled),
    /// A texture bake's input is invalid.
    #[error("object {index} ({name}): texture bake: {source}")]
    Texture {
        index: usize,
        name: String,
        #[source]
        source: TextureError,
    },
}

/// A method's live state, made from its bake at the object's first update.
#[derive(Debug)]
enum Live {
    TransCut(Box<Editor>),
    HierarchicalDipole(Box<DipoleLive>),
    Prt(Box<PrtLive>),
}

/// What a relight of a live state replaced, per method.
enum LiveUndo {
    TransCut(RelightUndo),
    HierarchicalDipole(DipoleUndo),
    Prt(PrtUndo),
}

impl Live {
    /// The live state of `bake`, solved under `lights` (the lights the bake was solved under);
    /// TransCut shadows with `occluder`, the bake's (every object's world surface).
    fn start(
        bake: &ObjectBake,
        lights: &[Light],
        options: &BakeOptions,
        occluder: Option<&Arc<TriangleBvh>>,
        progress: Progress,
    ) -> Result<Self, EditError> {
        match (&bake.state, &options.method) {
            (BakedState::TransCut(_), Method::TransCut(transcut)) => {
                let edit = EditOptions::from_bake_options(options, transcut);
                Ok(Self::TransCut(Box::new(Editor::from_bake_shadowed_by(bake, lights, &edit, occluder.cloned(), progress)?)))
            }
            // The bake is the solution under `lights`: nothing to solve again.
            // The FEM polygrid's state is TransCut's on the polygrid's nodes: TransCut's editor.
            (BakedState::TransCut(_), Method::Polygrid(polygrid)) if polygrid.stencil == Stencil::Fem => {
                // Cut pieces are meshed by TransCut at the polygrid's node budget.
                let solve = TransCutOptions { tets: polygrid.nodes, ..polygrid.solve.clone() };
                let edit = EditOptions::from_bake_options(options, &solve);
                Ok(Self::TransCut(Box::new(Editor::from_bake_shadowed_by(bake, lights, &edit, occluder.cloned(), progress)?)))
            }
            (BakedState::TransCut(_), Method::Polygrid(_)) => Err(EditError::InvalidOptions(
                "updates after a finite-volume polygrid bake are not built (its editor would solve P1 instead); bake with \
                 the polygrid's fem stencil, or bake again"
                    .into(),
            )),
            (BakedState::HierarchicalDipole(state), Method::HierarchicalDipole(_)) => Ok(Self::HierarchicalDipole(Box::new(
                DipoleLive::new(state.clone(), lights, bake.radiance.clone(), options.shadows, options.source),
            ))),
            (BakedState::Prt(state), Method::Prt(_)) => {
                let surface = options.shadows.then_some(state.surface.as_ref());
                Ok(Self::Prt(Box::new(PrtLive::new(state.clone(), lights, bake.radiance.clone(), surface, options.source))))
            }
            (state, method) => Err(EditError::InvalidOptions(format!(
                "the object was baked by another method than the session's {} ({state:?} is not its state)",
                method.name()
            ))),
        }
    }

    fn relight(&mut self, lights: &[Light], progress: Progress) -> Result<(UpdateStats, LiveUndo), EditError> {
        match self {
            Self::TransCut(e) => Relight::relight(e.as_mut(), lights, progress).map(|(s, u)| (s, LiveUndo::TransCut(u))),
            Self::HierarchicalDipole(d) => {
                Relight::relight(d.as_mut(), lights, progress).map(|(s, u)| (s, LiveUndo::HierarchicalDipole(u)))
            }
            Self::Prt(p) => Relight::relight(p.as_mut(), lights, progress).map(|(s, u)| (s, LiveUndo::Prt(u))),
        }
    }

    fn undo_relight(&mut self, undo: LiveUndo) -> Result<(), EditError> {
        match (self, undo) {
            (Self::TransCut(e), LiveUndo::TransCut(u)) => Relight::undo_relight(e.as_mut(), u),
            (Self::HierarchicalDipole(d), LiveUndo::HierarchicalDipole(u)) => Relight::undo_relight(d.as_mut(), u),
            (Self::Prt(p), LiveUndo::Prt(u)) => Relight::undo_relight(p.as_mut(), u),
            _ => Err(EditError::InvalidOptions("the undo is of another method's relight".into())),
        }
    }

    fn user_radiance(&self) -> Option<Vec<[f64; 3]>> {
        match self {
            Self::TransCut(e) => Relight::user_radiance(e.as_ref()),
            Self::HierarchicalDipole(d) => Relight::user_radiance(d.as_ref()),
            Self::Prt(p) => Relight::user_radiance(p.as_ref()),
        }
    }

    fn edit_medium(&mut self) -> Option<&mut dyn EditMedium> {
        match self {
            Self::TransCut(e) => Some(e.as_mut()),
            Self::Prt(p) => Some(p.as_mut()),
            Self::HierarchicalDipole(_) => None,
        }
    }

    fn cut(&mut self) -> Option<&mut dyn Cut> {
        match self {
            Self::TransCut(e) => Some(e.as_mut()),
            Self::HierarchicalDipole(_) | Self::Prt(_) => None,
        }
    }

    fn deform(&mut self) -> Option<&mut dyn Deform> {
        match self {
            Self::TransCut(_) | Self::Prt(_) => None,
            Self::HierarchicalDipole(d) => Some(d.as_mut()),
        }
    }
}

/// One object of a session.
#[derive(Debug)]
struct Slot {
    name: String,
    method: &'static str,
    state: State,
    /// The bake's statistics.
    bake_stats: ObjectStats,
    /// The last update's.
    last: Option<UpdateStats>,
}

/// What an object holds: its bake until its first update, then its method's live state (which
/// holds all the bake had).
#[derive(Debug)]
enum State {
    Baked(Box<ObjectBake>),
    Live(Live),
}

/// What [`Session::relight`] did to one object, to undo it when a later object fails.
enum Relit {
    /// The object's live state was relit in place; this puts it back.
    Existing(LiveUndo),
    /// The object had no live state: one was made from its bake and relit; this is the state
    /// it had (the bake).
    Created(State),
}

/// A baked scene being edited (see the module documentation).
#[derive(Debug)]
pub struct Session {
    /// The lights every object is solved under (of the bake, or of the last relight).
    lights: Vec<Light>,
    options: BakeOptions,
    objects: Vec<Slot>,
    /// The whole scene's live state of a radiosity bake.
    coupled: Option<Box<RadiositySession>>,
    /// The occluder the bake shadowed with ([`Bake::occluder`]), which TransCut's live states
    /// shadow with too (until their pieces move), so relights equal fresh bakes.
    occluder: Option<Arc<TriangleBvh>>,
}

impl Session {
    /// Bakes `scene` ([`bake_with`]) and keeps the result for editing.
    ///
    /// # Errors
    /// Those of [`bake_with`].
    pub fn bake(scene: &Scene, options: &BakeOptions, progress: Progress) -> Result<Self, SceneError> {
        let bake = bake_with(scene, options, progress)?;
        Ok(Self::new(scene, bake, options))
    }

    /// The session of a finished bake of `scene` with `options`.
    #[must_use]
    pub fn new(scene: &Scene, bake: Bake, options: &BakeOptions) -> Self {
        let objects = bake
            .objects
            .into_iter()
            .zip(&scene.objects)
            .map(|(b, object)| Slot {
                name: object.name.clone(),
                method: b.method(),
                bake_stats: b.stats.clone(),
                state: State::Baked(Box::new(b)),
                last: None,
            })
            .collect();
        let coupled = bake.coupled.map(|c| Box::new(Arc::try_unwrap(c).unwrap_or_else(|c| (*c).clone())));
        Self { lights: scene.lights.clone(), options: options.clone(), objects, coupled, occluder: bake.occluder }
    }

    /// The number of objects.
    #[must_use]
    pub fn len(&self) -> usize {
        self.objects.len()
    }

    /// Whether the session has no objects.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty()
    }

    /// The lights the objects are solved under.
    #[must_use]
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// The options of the bake.
    #[must_use]
    pub fn options(&self) -> &BakeOptions {
        &self.options
    }

    /// [`SessionError::Unsupported`] for an object baked by translucent radiosity: its objects
    /// are coupled through the whole scene's form factors, so it has only the scene-wide
    /// updates of [`RadiositySession`] (relight, albedo, emission, medium).
    fn refuse_coupled(&self, index: usize, capability: &'static str) -> Result<(), SessionError> {
        let slot = self.slot(index)?;
        match &slot.state {
            State::Baked(b) if matches!(b.state, BakedState::Radiosity(_)) => {
                Err(SessionError::Unsupported { index, name: slot.name.clone(), method: slot.method, capability })
            }
            _ => Ok(()),
        }
    }

    /// The radiosity bake's live state (`None` for the other methods).
    #[must_use]
    pub fn radiosity(&self) -> Option<&RadiositySession> {
        self.coupled.as_deref()
    }

    /// Runs a scene-wide update of a radiosity bake on the session's threads, then records
    /// each object's statistics; [`SessionError::Unsupported`] naming `capability` when the
    /// bake is of another method.
    fn update_coupled(
        &mut self,
        index: Option<usize>,
        capability: &'static str,
        op: impl FnOnce(&mut RadiositySession) -> Result<RadiosityUpdate, SceneError> + Send,
    ) -> Result<Vec<UpdateStats>, SessionError> {
        if let Some(index) = index {
            self.slot(index)?;
        }
        let threads = self.options.threads;
        let Some(coupled) = self.coupled.as_deref_mut() else {
            let index = index.unwrap_or(0);
            let slot = self.slot(index)?;
            return Err(SessionError::Unsupported { index, name: slot.name.clone(), method: slot.method, capability });
        };
        let update = with_threads(threads, || op(coupled)).map_err(SessionError::InvalidOptions)?.map_err(|e| match e {
            SceneError::Cancelled(c) => SessionError::Cancelled(c),
            e => SessionError::Coupled(Box::new(e)),
        })?;
        let stats: Vec<UpdateStats> = (0..self.objects.len()).map(|i| coupled_stats(&update, coupled.object_stats(i))).collect();
        for (slot, s) in self.objects.iter_mut().zip(&stats) {
            slot.last = Some(s.clone());
        }
        Ok(stats)
    }

    /// Sets diffuse object `index`'s albedo in a radiosity bake and re-solves the scene
    /// ([`RadiositySession::set_albedo`]); returns the object's update statistics.
    ///
    /// # Errors
    /// [`SessionError::Unsupported`] for a bake of another method; [`SessionError::Coupled`]
    /// (a translucent object, an albedo outside [0, 1)); [`SessionError::Cancelled`].
    pub fn set_albedo(&mut self, index: usize, albedo: [f64; 3], progress: Progress) -> Result<&UpdateStats, SessionError> {
        self.update_coupled(Some(index), "set an albedo", |c| c.set_albedo(index, albedo, progress))?;
        Ok(self.objects[index].last.as_ref().expect("an update that succeeded stored its statistics"))
    }

    /// Sets diffuse object `index`'s emitted exitance in a radiosity bake and re-solves.
    ///
    /// # Errors
    /// As [`Session::set_albedo`].
    pub fn set_emission(&mut self, index: usize, emission: [f64; 3], progress: Progress) -> Result<&UpdateStats, SessionError> {
        self.update_coupled(Some(index), "set an emission", |c| c.set_emission(index, emission, progress))?;
        Ok(self.objects[index].last.as_ref().expect("an update that succeeded stored its statistics"))
    }

    /// Puts `medium` on translucent object `index` of a radiosity bake (its tets kept) and
    /// re-solves the scene ([`RadiositySession::set_medium`]). For TransCut,
    /// [`Session::edit_medium`] changes a medium in place.
    ///
    /// # Errors
    /// As [`Session::set_albedo`] (an opaque object, a medium the mesh does not resolve).
    pub fn set_medium(&mut self, index: usize, medium: MediumSource, progress: Progress) -> Result<&UpdateStats, SessionError> {
        self.update_coupled(Some(index), "set the whole medium", |c| c.set_medium(index, medium, progress))?;
        Ok(self.objects[index].last.as_ref().expect("an update that succeeded stored its statistics"))
    }

    fn slot(&self, index: usize) -> Result<&Slot, SessionError> {
        let count = self.objects.len();
        self.objects.get(index).ok_or(SessionError::NoSuchObject { index, count })
    }

    /// The statistics of object `index`'s bake.
    ///
    /// # Errors
    /// [`SessionError::NoSuchObject`].
    pub fn bake_stats(&self, index: usize) -> Result<&ObjectStats, SessionError> {
        Ok(&self.slot(index)?.bake_stats)
    }

    /// What the last update of object `index` did (`None` before its first).
    ///
    /// # Errors
    /// [`SessionError::NoSuchObject`].
    pub fn last_update(&self, index: usize) -> Result<Option<&UpdateStats>, SessionError> {
        Ok(self.slot(index)?.last.as_ref())
    }

    /// Object `index`'s bake, until its first update (then its live state holds what it had).
    ///
    /// # Errors
    /// [`SessionError::NoSuchObject`].
    pub fn baked(&self, index: usize) -> Result<Option<&ObjectBake>, SessionError> {
        Ok(match &self.slot(index)?.state {
            State::Baked(b) => Some(b),
            State::Live(_) => None,
        })
    }

    /// The TransCut editor of object `index`, from its first update on.
    ///
    /// # Errors
    /// [`SessionError::NoSuchObject`].
    pub fn editor(&self, index: usize) -> Result<Option<&Editor>, SessionError> {
        Ok(match &self.slot(index)?.state {
            State::Live(Live::TransCut(e)) => Some(e),
            State::Live(Live::HierarchicalDipole(_) | Live::Prt(_)) | State::Baked(_) => None,
        })
    }

    /// The refractive index at object `index`'s surface, for renderers.
    ///
    /// # Errors
    /// [`SessionError::NoSuchObject`].
    pub fn eta(&self, index: usize) -> Result<f64, SessionError> {
        let slot = self.slot(index)?;
        if let Some(eta) = self.coupled.as_ref().and_then(|c| c.eta(index)) {
            return Ok(eta);
        }
        Ok(match &slot.state {
            State::Live(Live::TransCut(e)) => e.media().eta(),
            State::Live(Live::HierarchicalDipole(d)) => d.state().eta(),
            State::Live(Live::Prt(p)) => p.state().eta(),
            State::Baked(b) => b.eta(),
        })
    }

    /// Object `index`'s radiance at its user's vertices: the bake's, or the last update's while
    /// the object still has them (`None` once it was cut or a piece moved).
    ///
    /// # Errors
    /// [`SessionError::NoSuchObject`].
    pub fn radiance(&self, index: usize) -> Result<Option<Vec<[f64; 3]>>, SessionError> {
        let slot = self.slot(index)?;
        if let Some(c) = &self.coupled {
            return Ok(c.radiance(index).map(<[[f64; 3]]>::to_vec));
        }
        Ok(match &slot.state {
            State::Live(live) => live.user_radiance(),
            State::Baked(b) => Some(b.radiance.clone()),
        })
    }

    /// Object `index`'s radiance at points of its user surface (each a triangle of its user
    /// vertices and barycentric weights, e.g. a texture's [`TexelSample`]s), while it still has
    /// that surface (`None` once it was cut or a piece moved). TransCut samples its tet mesh's
    /// boundary solution at the points ([`crate::mesh::TetMesh::sample_at_user_points`]), so a
    /// texel between vertices gets the solution there, not a blend of the vertices' values;
    /// the other methods, whose radiance lives at the vertices, interpolate it.
    ///
    /// # Errors
    /// [`SessionError::NoSuchObject`]; [`SessionError::Texture`] for a vertex index beyond the
    /// object's vertices.
    pub fn radiance_on_surface(&self, index: usize, samples: &[TexelSample]) -> Result<Option<Vec<[f64; 3]>>, SessionError> {
        let Some(vertex_radiance) = self.radiance(index)? else { return Ok(None) };
        let slot = self.slot(index)?;
        if let Some(t) = samples.iter().position(|s| s.vertices.iter().any(|&v| v as usize >= vertex_radiance.len())) {
            let vertex = samples[t].vertices.into_iter().max().unwrap_or(0);
            let source =
                TextureError::VertexOutOfRange { triangle: samples[t].triangle as usize, vertex, count: vertex_radiance.len() };
            return Err(SessionError::Texture { index, name: slot.name.clone(), source });
        }
        let points: Vec<([u32; 3], [f64; 3])> = samples.iter().map(|s| (s.vertices, s.bary)).collect();
        Ok(Some(match &slot.state {
            _ if self.coupled.is_some() => interpolate_vertices(&vertex_radiance, &points),
            State::Baked(b) => b.radiance_on_surface(&points),
            State::Live(Live::TransCut(e)) => match e.surface_field() {
                Some((mesh, values)) => mesh.sample_at_user_points(&points, values),
                None => interpolate_vertices(&vertex_radiance, &points),
            },
            State::Live(_) => interpolate_vertices(&vertex_radiance, &points),
        }))
    }

    /// Object `index`'s radiance as a texture through a UV map ([`crate::texture`]):
    /// `triangles` in its user vertex numbering (the bake's triangles or any others over its
    /// vertices, e.g. split at UV seams) with one UV per corner in `uvs` (3 per triangle).
    ///
    /// # Errors
    /// [`SessionError::NoSuchObject`]; [`SessionError::Texture`] naming a bad size, UV or
    /// vertex; [`SessionError::Unsupported`] once the object was cut or a piece moved (its
    /// surface is no longer the one the UV map covers).
    pub fn bake_texture(
        &self,
        index: usize,
        triangles: &[[u32; 3]],
        uvs: &[[f64; 2]],
        options: &TextureOptions,
    ) -> Result<Image, SessionError> {
        let slot = self.slot(index)?;
        let unsupported = || SessionError::Unsupported {
            index,
            name: slot.name.clone(),
            method: slot.method,
            capability: "bake a texture of a cut object or one whose pieces moved (its surface is not the UV map's)",
        };
        let vertex_count = self.radiance(index)?.ok_or_else(unsupported)?.len();
        texture::check(triangles, uvs, vertex_count, options).map_err(|source| SessionError::Texture {
            index,
            name: slot.name.clone(),
            source,
        })?;
        texture::bake_image(triangles, uvs, options, |texels| self.radiance_on_surface(index, texels)?.ok_or_else(unsupported))
    }

    /// Makes object `index`'s live state from its bake now (a solve under the session's
    /// lights), as its first update would; nothing to do when it exists.
    ///
    /// # Errors
    /// [`SessionError::NoSuchObject`]; [`SessionError::Edit`] when the live state cannot be made;
    /// [`SessionError::Cancelled`].
    pub fn start(&mut self, index: usize, progress: Progress) -> Result<(), SessionError> {
        if self.coupled.is_some() {
            return self.slot(index).map(|_| ()); // live since the bake
        }
        self.update_with(index, progress, |_, _| Ok(None)).map(|_| ())
    }

    /// Re-solves every object under `lights`, warm-started, without meshing or assembling
    /// again; `progress` is called before each object, through its light and solve stages
    /// (`"<object>: light"`, `"<object>: solve"`, the fraction of all objects) and at the end.
    /// All or nothing: on a
    /// failure (naming the object) or a cancellation the objects relit so far are undone, last
    /// first. Returns each object's update statistics.
    ///
    /// # Errors
    /// [`SessionError::Edit`] naming the object that failed; [`SessionError::Cancelled`].
    pub fn relight(&mut self, lights: &[Light], progress: Progress) -> Result<Vec<UpdateStats>, SessionError> {
        if self.coupled.is_some() {
            let stats = self.update_coupled(None, "relight", |c| c.relight(lights, progress))?;
            self.lights = lights.to_vec();
            return Ok(stats);
        }
        let threads = self.options.threads;
        let Self { lights: baked, options, objects, occluder, .. } = self;
        let n = objects.len();
        let stats = with_threads(threads, || -> Result<Vec<UpdateStats>, SessionError> {
            let mut done: Vec<(UpdateStats, Relit)> = Vec::with_capacity(n);
            let mut failure = None;
            for (index, slot) in objects.iter_mut().enumerate() {
                if let Err(c) = progress.report(&format!("{}: relight", slot.name), index as f64 / n as f64) {
                    failure = Some(SessionError::Cancelled(c));
                    break;
                }
                let name = slot.name.clone();
                let within =
                    |stage: &str, f: f64| progress.report(&format!("{name}: {stage}"), (index as f64 + f) / n as f64).is_ok();
                match relight_slot(slot, baked, lights, options, occluder.as_ref(), Progress::new(&within)) {
                    Ok(r) => done.push(r),
                    Err(EditError::Cancelled(c)) => {
                        failure = Some(SessionError::Cancelled(c));
                        break;
                    }
                    Err(source) => {
                        failure = Some(SessionError::Edit { index, name: slot.name.clone(), source: Box::new(source) });
                        break;
                    }
                }
            }
            if failure.is_none() {
                if let Err(c) = progress.report("relight: done", 1.0) {
                    failure = Some(SessionError::Cancelled(c));
                }
            }
            if let Some(f) = failure {
                for (slot, (_, relit)) in objects.iter_mut().zip(done).rev() {
                    undo_relight(slot, relit);
                }
                return Err(f);
            }
            Ok(objects
                .iter_mut()
                .zip(done)
                .map(|(slot, (stats, _))| {
                    slot.last = Some(stats.clone());
                    stats
                })
                .collect())
        })
        .map_err(SessionError::InvalidOptions)??;
        *baked = lights.to_vec();
        Ok(stats)
    }

    /// Applies a material edit to object `index` ([`EditMedium::edit_medium`]).
    ///
    /// # Errors
    /// [`SessionError::Unsupported`]; [`SessionError::Edit`]; [`SessionError::Cancelled`].
    pub fn edit_medium(&mut self, index: usize, edit: &MediumEdit, progress: Progress) -> Result<&UpdateStats, SessionError> {
        self.update(index, "edit the medium", progress, |live, p| live.edit_medium().map(|c| c.edit_medium(edit, p)))
    }

    /// Paints a stroke into object `index` ([`EditMedium::paint`]).
    ///
    /// # Errors
    /// [`SessionError::Unsupported`]; [`SessionError::Edit`]; [`SessionError::Cancelled`].
    pub fn paint(&mut self, index: usize, stroke: &PaintStroke, progress: Progress) -> Result<&UpdateStats, SessionError> {
        self.update(index, "paint the medium", progress, |live, p| live.edit_medium().map(|c| c.paint(stroke, p)))
    }

    /// Cuts object `index` ([`Cut::cut`]): what lies on the cutter's positive side goes.
    ///
    /// # Errors
    /// [`SessionError::Unsupported`]; [`SessionError::Edit`]; [`SessionError::Cancelled`].
    pub fn cut(&mut self, index: usize, cutter: &Cutter, progress: Progress) -> Result<&UpdateStats, SessionError> {
        self.update(index, "cut", progress, |live, p| live.cut().map(|c| c.cut(cutter, p)))
    }

    /// Splits object `index` by a cutter ([`Cut::split`]).
    ///
    /// # Errors
    /// [`SessionError::Unsupported`]; [`SessionError::Edit`]; [`SessionError::Cancelled`].
    pub fn split(&mut self, index: usize, cutter: &Cutter, progress: Progress) -> Result<&UpdateStats, SessionError> {
        self.update(index, "split", progress, |live, p| live.cut().map(|c| c.split(cutter, p)))
    }

    /// Separates object `index` into its connected parts ([`Cut::fracture`]).
    ///
    /// # Errors
    /// [`SessionError::Unsupported`]; [`SessionError::Edit`]; [`SessionError::Cancelled`].
    pub fn fracture(&mut self, index: usize, progress: Progress) -> Result<&UpdateStats, SessionError> {
        self.update(index, "fracture", progress, |live, p| live.cut().map(|c| c.fracture(p)))
    }

    /// Places piece `piece` of object `index` ([`Cut::set_piece_transform`]).
    ///
    /// # Errors
    /// [`SessionError::Unsupported`]; [`SessionError::Edit`]; [`SessionError::Cancelled`].
    pub fn set_piece_transform(
        &mut self,
        index: usize,
        piece: usize,
        transform: DMat4,
        progress: Progress,
    ) -> Result<&UpdateStats, SessionError> {
        self.update(index, "move pieces", progress, |live, p| live.cut().map(|c| c.set_piece_transform(piece, transform, p)))
    }

    /// Moves the vertices of object `index` to `positions` (object space, one per vertex of
    /// the mesh it was baked from, in its order; the topology kept) and updates its radiance
    /// ([`Deform::set_positions`]).
    ///
    /// # Errors
    /// [`SessionError::Unsupported`]; [`SessionError::Edit`] for positions of another count or
    /// not finite; [`SessionError::Cancelled`].
    pub fn set_positions(
        &mut self,
        index: usize,
        positions: &[[f64; 3]],
        progress: Progress,
    ) -> Result<&UpdateStats, SessionError> {
        self.update(index, "deform the mesh", progress, |live, p| live.deform().map(|c| c.set_positions(positions, p)))
    }

    /// The hierarchical dipole's live state of object `index`, from its first update on.
    ///
    /// # Errors
    /// [`SessionError::NoSuchObject`].
    pub fn dipole(&self, index: usize) -> Result<Option<&DipoleLive>, SessionError> {
        Ok(match &self.slot(index)?.state {
            State::Live(Live::HierarchicalDipole(d)) => Some(d),
            State::Live(Live::TransCut(_) | Live::Prt(_)) | State::Baked(_) => None,
        })
    }

    /// The PRT live state of object `index`, from its first update on.
    ///
    /// # Errors
    /// [`SessionError::NoSuchObject`].
    pub fn prt(&self, index: usize) -> Result<Option<&PrtLive>, SessionError> {
        Ok(match &self.slot(index)?.state {
            State::Live(Live::Prt(p)) => Some(p),
            State::Live(Live::TransCut(_) | Live::HierarchicalDipole(_)) | State::Baked(_) => None,
        })
    }

    /// The PRT state of object `index`: its live state's from its first update on, else its
    /// bake's; `None` for an object another method baked.
    ///
    /// # Errors
    /// [`SessionError::NoSuchObject`].
    pub fn prt_state(&self, index: usize) -> Result<Option<&PrtState>, SessionError> {
        Ok(match &self.slot(index)?.state {
            State::Live(Live::Prt(p)) => Some(p.state()),
            State::Live(_) => None,
            State::Baked(bake) => bake.prt(),
        })
    }

    /// Saves object `index`'s precomputed transfer to `path` ([`PrtState::save`]), for a later
    /// bake of the same surface and options to read instead of precomputing.
    ///
    /// # Errors
    /// [`SessionError::Unsupported`] for an object another method baked;
    /// [`SessionError::Edit`] with the file's error.
    pub fn save_prt(&self, index: usize, path: &std::path::Path) -> Result<(), SessionError> {
        let slot = self.slot(index)?;
        let state = self.prt_state(index)?.ok_or_else(|| SessionError::Unsupported {
            index,
            name: slot.name.clone(),
            method: slot.method,
            capability: "save a precomputed transfer",
        })?;
        state.save(path).map_err(|e| SessionError::Edit { index, name: slot.name.clone(), source: Box::new(EditError::from(e)) })
    }

    /// Object `index` at a new scale, `mm_per_unit` millimetres per scene unit, without a new
    /// bake: for PRT the material edit σ → σ s of its transfer ([`PrtLive::set_mm_per_unit`]).
    ///
    /// # Errors
    /// [`SessionError::Unsupported`] for other methods; [`SessionError::Edit`].
    pub fn set_mm_per_unit(&mut self, index: usize, mm_per_unit: f64, progress: Progress) -> Result<&UpdateStats, SessionError> {
        self.update(index, "change the scale without a new bake", progress, |live, _| match live {
            Live::Prt(p) => Some(p.set_mm_per_unit(mm_per_unit)),
            _ => None,
        })
    }

    /// Welds the pieces of object `index` whose faces touch again ([`Cut::recombine`]).
    ///
    /// # Errors
    /// [`SessionError::Unsupported`]; [`SessionError::Edit`]; [`SessionError::Cancelled`].
    pub fn recombine(&mut self, index: usize, progress: Progress) -> Result<&UpdateStats, SessionError> {
        self.update(index, "recombine pieces", progress, |live, p| live.cut().map(|c| c.recombine(p)))
    }

    /// Runs `op` on object `index`'s live state (made from its bake if needed) on the session's
    /// threads; keeps the new state and the update's statistics. `op` returns `None` when the
    /// method lacks `capability`. Nothing changes when it fails.
    fn update(
        &mut self,
        index: usize,
        capability: &'static str,
        progress: Progress,
        op: impl FnOnce(&mut Live, Progress) -> Option<Result<UpdateStats, EditError>> + Send,
    ) -> Result<&UpdateStats, SessionError> {
        self.refuse_coupled(index, capability)?;
        self.update_with(index, progress, |live, p| match op(live, p) {
            Some(result) => result.map(Some).map_err(Failed::Edit),
            None => Err(Failed::Unsupported(capability)),
        })?;
        Ok(self.objects[index].last.as_ref().expect("an update that succeeded stored its statistics"))
    }

    /// Runs `op` on object `index`'s live state, made from its bake first if needed (and then
    /// kept only if `op` succeeds); stores the statistics `op` returns. Both report to
    /// `progress` with the object's name before the stage (the start over the first half of
    /// the fraction when it is needed, `op` over the rest).
    fn update_with(
        &mut self,
        index: usize,
        progress: Progress,
        op: impl FnOnce(&mut Live, Progress) -> Result<Option<UpdateStats>, Failed> + Send,
    ) -> Result<(), SessionError> {
        let count = self.objects.len();
        let threads = self.options.threads;
        let Self { lights, options, objects, occluder, .. } = self;
        let slot = objects.get_mut(index).ok_or(SessionError::NoSuchObject { index, count })?;
        let name = slot.name.clone();
        let outcome = with_threads(threads, || -> Result<Option<UpdateStats>, Failed> {
            let name = name.as_str();
            let named = |lo: f64, hi: f64| {
                move |stage: &str, f: f64| progress.report(&format!("{name}: {stage}"), lo + (hi - lo) * f).is_ok()
            };
            match &mut slot.state {
                State::Live(live) => {
                    let all = named(0.0, 1.0);
                    op(live, Progress::new(&all))
                }
                State::Baked(bake) => {
                    let (first, rest) = (named(0.0, 0.5), named(0.5, 1.0));
                    let mut live =
                        Live::start(bake, lights, options, occluder.as_ref(), Progress::new(&first)).map_err(Failed::Edit)?;
                    let stats = op(&mut live, Progress::new(&rest))?;
                    slot.state = State::Live(live);
                    Ok(stats)
                }
            }
        })
        .map_err(SessionError::InvalidOptions)?;
        match outcome {
            Ok(stats) => {
                if stats.is_some() {
                    slot.last = stats;
                }
                Ok(())
            }
            Err(Failed::Edit(EditError::Cancelled(c))) => Err(SessionError::Cancelled(c)),
            Err(Failed::Edit(source)) => Err(SessionError::Edit { index, name: slot.name.clone(), source: Box::new(source) }),
            Err(Failed::Unsupported(capability)) => {
                Err(SessionError::Unsupported { index, name: slot.name.clone(), method: slot.method, capability })
            }
        }
    }
}

/// Why an update of one object failed, before the object is named.
enum Failed {
    Edit(EditError),
    Unsupported(&'static str),
}

/// Relights `slot` in place under `lights`, or makes its live state from its bake (solved under
/// `baked`, the lights the bake was solved under) and relights that. Unchanged on error;
/// [`undo_relight`] undoes a success.
fn relight_slot(
    slot: &mut Slot,
    baked: &[Light],
    lights: &[Light],
    options: &BakeOptions,
    occluder: Option<&Arc<TriangleBvh>>,
    progress: Progress,
) -> Result<(UpdateStats, Relit), EditError> {
    match &mut slot.state {
        State::Live(live) => {
            let (stats, undo) = live.relight(lights, progress)?;
            Ok((stats, Relit::Existing(undo)))
        }
        State::Baked(bake) => {
            let half = |lo: f64| move |stage: &str, f: f64| progress.report(stage, lo + 0.5 * f).is_ok();
            let (first, rest) = (half(0.0), half(0.5));
            let mut live = Live::start(bake, baked, options, occluder, Progress::new(&first))?;
            let (stats, _) = live.relight(lights, Progress::new(&rest))?;
            let before = std::mem::replace(&mut slot.state, State::Live(live));
            Ok((stats, Relit::Created(before)))
        }
    }
}

/// Undoes [`relight_slot`]: the live state as before it, or the bake back.
fn undo_relight(slot: &mut Slot, relit: Relit) {
    match relit {
        Relit::Existing(undo) => {
            if let State::Live(live) = &mut slot.state {
                // Cannot fail: the state is the one the relight changed, untouched since.
                let undone = live.undo_relight(undo);
                debug_assert!(undone.is_ok(), "{undone:?}");
            }
        }
        Relit::Created(before) => slot.state = before,
    }
}

/// One object's statistics of a radiosity update: the scene's solve times, and the object's
/// diffusion iterations of its last solve (`stats`, zero for an opaque object).
fn coupled_stats(update: &RadiosityUpdate, stats: Option<&ObjectStats>) -> UpdateStats {
    let translucent = stats.is_some_and(|s| s.tets > 0);
    UpdateStats {
        pieces_solved: usize::from(translucent && update.solves > 0),
        iterations: stats.filter(|_| translucent).map_or([0; 3], |s| s.iterations),
        rows_rebuilt: 0,
        tets_changed: 0,
        select_ms: 0.0,
        source_ms: update.direct_ms,
        assembly_ms: 0.0,
        hierarchy_ms: 0.0,
        solve_ms: update.solve_ms,
        total_ms: update.total_ms,
        cut: None,
    }
}
