//! Interactive editing of a baked object (TransCut §5): relight, edit or paint the medium, cut,
//! split, fracture, move and recombine pieces; every update warm-starts from the last solution.
//!
//! # Data model
//!
//! An [`Editor`] starts from one TransCut bake of one scene object ([`Editor::new`] bakes it,
//! [`Editor::from_bake`] takes a finished [`crate::methods::ObjectBake`]; both are TransCut's
//! and live with it in [`crate::methods::transcut`]). It keeps:
//!
//! - the **original tet mesh** as baked (world space at bake time = the *rest* space of every
//!   piece), and the **medium per ORIGINAL tet** (a [`crate::volume::PerTetMedia`]). Material
//!   edits and paint (TransCut §5.2) change this table, also for tets that a cut has removed,
//!   so a later recombine or a region defined on the original object sees them. Regions and
//!   paint strokes are evaluated on the original tets' centroids at rest placement; depths are
//!   measured below the ORIGINAL surface;
//! - the **pieces** ([`Piece`]): each a rest-space tet mesh whose tets carry their original ids,
//!   a rigid transform rest → world, its own diffusion system (TransCut eqs. 10–14, assembled
//!   with the per-tet table of its tets: material id = local tet index), its solver
//!   ([`crate::diffusion::Solver`], its hierarchy built once per piece mesh) and its
//!   last fluence φ and radiance Lo per tet-mesh vertex.
//!
//! # Updates
//!
//! - [`Editor::relight`]: q is recomputed at every piece's world-space boundary points, with
//!   shadows from all pieces' world surfaces; the matrices do not change;
//! - [`Editor::edit_medium`] and [`Editor::paint`]: the per-tet table changes, and only the
//!   matrix rows of the vertices of the affected tets are refilled
//!   ([`crate::diffusion::DiffusionSystem::update_media_rows`], TransCut §5.2), and the solver
//!   follows those rows ([`crate::diffusion::Solver::refresh_rows`], see "Solver");
//! - cuts, splits, fracture, moves and recombination rebuild the affected pieces' meshes,
//!   systems and hierarchies (TransCut §5.1) and re-light every piece (the shadows change).
//!   [`Editor::cut`] deletes the cutter's positive side and snaps the cut surface onto it
//!   ([`cut::cut`]); [`Editor::split`] partitions the tets by the side of their centroid and
//!   moves nothing, so the parts fit together exactly and [`Editor::recombine`] restores them;
//!   [`Editor::fracture`] separates connected components; pieces move rigidly
//!   ([`Editor::set_piece_transform`]) and each is solved with its own boundary.
//!
//! # Solver
//!
//! Updates solve with CG preconditioned by a multigrid V-cycle on a smoothed-aggregation
//! hierarchy ([`SolverKind::AggregationPcg`], the default of [`EditOptions::solver`];
//! [`crate::sparse::hierarchy::Hierarchy::aggregated`]): the aggregation shrinks each level
//! about 20-fold, so its coarse operators add little to the level-0 matrix and a V-cycle costs
//! about two matrix products, while CG needs about half the iterations of SSOR-PCG. Its setup
//! (aggregation, the smoothed prolongation and the Galerkin products) is paid at the editor's
//! start and after every cut, split, fracture and recombination; a paint refreshes the Galerkin
//! rows the refilled rows reach ([`crate::sparse::hierarchy::Multigrid::refresh`]) and keeps the
//! prolongation, smoothed with the matrix before the paint (still a valid V-cycle, a little
//! weaker). The V-cycle on the paper's §4 hierarchy ([`SolverKind::MultigridPcg`]) needs fewer
//! iterations but a much longer setup per piece mesh, and SSOR-PCG no hierarchy at all; both
//! stay available through [`EditOptions::solver`]. `transcut bench edit --solver …` measures
//! them against each other (`docs/benchmarks.md`).
//!
//! Every solve is **warm-started** from the previous φ (TransCut §4.2; after a cut φ is carried
//! over through the kept vertices). Every method returns [`UpdateStats`] with the stage timings.
//!
//! **A failed call leaves the editor exactly as it was**, without copying the multi-megabyte
//! state of the pieces on the way: a relight computes every q aside, swaps it in (the previous q
//! and b kept) and solves into fresh vectors, storing φ and radiance only when every solve
//! succeeded and putting q and b back otherwise ([`Editor::relight_with_undo`] hands the
//! replaced q, b, φ, radiance and lights back, so that a caller can undo a successful relight
//! with [`Editor::undo_relight`]); a paint or medium edit refills the touched rows
//! in place, keeping their previous values and media entries, refreshes the solvers in place
//! and solves aside, and if anything failed restores those rows and refreshes the solvers back
//! (bit for bit, see "Solver"); a move sets the transform in place and
//! restores it on failure; cuts, splits, fractures and recombinations build new pieces aside.
//! The shadow occluder (the pieces' world-space boundary in a BVH) is built once per placement
//! of the pieces (bake, cut, split, fracture, move, recombine) and reused by every relight.
//!
//! Shadows come from the occluder the bake shadowed with (every object's world surface, handed
//! over by the session), so relights equal a fresh bake under the new lights; once the pieces'
//! placement changes (a cut, split, fracture, move or recombine) they come from the pieces'
//! own tet-mesh boundaries.

pub mod cut;
pub mod cutter;
mod error;
pub mod paint;
mod piece;
pub mod pieces;
pub mod region;
mod topology;

use std::sync::Arc;
use std::time::Instant;

use glam::{DMat4, DVec3};
use rayon::prelude::*;

pub use cut::{CutOptions, CutResult, CutStats};
pub use cutter::{Cutter, SweptStroke};
pub use error::EditError;
pub use paint::PaintStroke;
pub use piece::Piece;
pub use region::{MediumEdit, MediumOp, Region};

use crate::diffusion::resolution;
use crate::diffusion::system::MediaUndo;
use crate::diffusion::{Discretization, SolverKind};
use crate::gpu::Backend;
use crate::light::{self, Light, SourceOptions};
use crate::mesh::{TetMesh, TriangleBvh};
use crate::optics::Medium;
use crate::progress::{ms, Progress};
use crate::scene::{BakeOptions, GradingChoice, TransCutOptions};
use crate::volume::{Coefficients, PerTetMedia};
use piece::{SolveSetup, Span, Timings};

/// How the editor solves and lights.
#[derive(Debug, Clone, PartialEq)]
pub struct EditOptions {
    /// Target tetrahedra when [`Editor::new`] meshes a surface (as [`TransCutOptions::tets`]).
    pub tets: usize,
    /// Their grading (as [`TransCutOptions::grading`]).
    pub grading: GradingChoice,
    /// The assembly of every piece's system (as [`TransCutOptions::discretization`]).
    pub discretization: Discretization,
    /// Relative residual at which every solve stops (as [`TransCutOptions::tolerance`]).
    pub tolerance: f64,
    /// Iteration cap of every solve.
    pub max_iterations: usize,
    /// The solver of the updates (default [`SolverKind::AggregationPcg`], the fastest for
    /// relights and paints: see the module documentation's "Solver" section).
    pub solver: SolverKind,
    /// Where [`SolverKind::Pcg`] solves run (as [`TransCutOptions::backend`]; `None`:
    /// `TRANSCUT_BACKEND`, else auto). The other kinds run on the CPU.
    pub backend: Option<Backend>,
    /// Sampling of area and environment lights and shadow rays.
    pub source: SourceOptions,
    /// Whether pieces shadow themselves and each other.
    pub shadows: bool,
    /// How [`Editor::cut`] relaxes the cut surface and which quality bound it keeps.
    pub cut: CutOptions,
    /// Distance (scene units, world space) within which boundary faces of two pieces count as
    /// touching in [`Editor::recombine`].
    pub weld_tolerance: f64,
}

impl Default for EditOptions {
    fn default() -> Self {
        Self::from_bake_options(&BakeOptions::default(), &TransCutOptions::default())
    }
}

impl EditOptions {
    /// The options of an editor that continues a bake made with `bake` and TransCut's options
    /// `transcut`: the same tolerance, iteration cap, backend, sampling and shadows, the update
    /// solver [`TransCutOptions::edit_solver`].
    #[must_use]
    pub fn from_bake_options(bake: &BakeOptions, transcut: &TransCutOptions) -> Self {
        Self {
            tets: transcut.tets,
            grading: transcut.grading,
            discretization: transcut.discretization,
            tolerance: transcut.tolerance,
            max_iterations: transcut.max_iterations,
            solver: transcut.edit_solver,
            backend: transcut.backend,
            source: bake.source,
            shadows: bake.shadows,
            cut: CutOptions::default(),
            weld_tolerance: 1e-6,
        }
    }
}

impl EditOptions {
    pub(crate) fn validate(&self) -> Result<(), EditError> {
        let bad = |s: String| Err(EditError::InvalidOptions(s));
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            return bad(format!("tolerance {}: must lie in (0, 1)", self.tolerance));
        }
        if self.max_iterations == 0 {
            return bad("max_iterations must be at least 1".into());
        }
        if self.tets == 0 {
            return bad("tets must be at least 1".into());
        }
        if !(self.weld_tolerance.is_finite() && self.weld_tolerance > 0.0) {
            return bad(format!("weld_tolerance {}: must be finite and > 0", self.weld_tolerance));
        }
        self.cut.validate()
    }

    /// The options of the bake an editor starts from ([`Editor::new`]): TransCut with this
    /// editor's tets, tolerance, iteration cap and backend.
    #[must_use]
    pub fn bake_options(&self) -> BakeOptions {
        BakeOptions { method: self.transcut_options().into(), threads: 0, source: self.source, shadows: self.shadows }
    }

    /// The TransCut options of [`EditOptions::bake_options`].
    #[must_use]
    pub fn transcut_options(&self) -> TransCutOptions {
        TransCutOptions {
            tets: self.tets,
            grading: self.grading,
            discretization: self.discretization,
            tolerance: self.tolerance,
            max_iterations: self.max_iterations,
            edit_solver: self.solver,
            backend: self.backend,
            ..TransCutOptions::default()
        }
    }
}

/// What one update did.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct UpdateStats {
    /// Pieces re-solved.
    pub pieces_solved: usize,
    /// Solver iterations per channel, summed over the pieces solved.
    pub iterations: [usize; 3],
    /// Matrix rows refilled by a paint or medium edit (0 for relight).
    pub rows_rebuilt: usize,
    /// Original tets whose medium changed (paint, medium edit) or tets of rebuilt pieces.
    pub tets_changed: usize,
    /// Finding what a paint or medium edit touches: the region's or stroke's tets, their new
    /// coefficients and the pieces holding them (0 for other updates).
    pub select_ms: f64,
    /// Transmitted source q (lights and shadows; with the shadow occluder's rebuild after a
    /// cut, split, fracture, move or recombination).
    pub source_ms: f64,
    /// Matrix assembly or row refill.
    pub assembly_ms: f64,
    /// Solver preparation: hierarchy (new meshes) and matrix-dependent operators.
    pub hierarchy_ms: f64,
    pub solve_ms: f64,
    pub total_ms: f64,
    /// What a cut did (summed over the pieces cut), for [`Editor::cut`].
    pub cut: Option<CutStats>,
}

impl UpdateStats {
    fn new(t: &Timings, rows_rebuilt: usize, tets_changed: usize, start: Instant) -> Self {
        Self {
            pieces_solved: t.pieces_solved,
            iterations: t.iterations,
            rows_rebuilt,
            tets_changed,
            select_ms: t.select_ms,
            source_ms: t.source_ms,
            assembly_ms: t.assembly_ms,
            hierarchy_ms: t.hierarchy_ms,
            solve_ms: t.solve_ms,
            total_ms: ms(start),
            cut: None,
        }
    }
}

/// What [`Editor::relight_with_undo`] replaced, for [`Editor::undo_relight`]: per piece the
/// previous transmitted source q and right-hand side b, fluence φ and radiance, and the previous
/// lights, all moved out of the editor (no copy is made). Dropping it keeps the relight.
#[derive(Debug)]
#[must_use = "a relight's undo does nothing unless given to Editor::undo_relight"]
pub struct RelightUndo {
    pieces: Vec<piece::Replaced>,
    /// The pieces' meshes the relight saw, to check that the undo fits the editor.
    meshes: Vec<Arc<TetMesh>>,
    lights: Vec<Light>,
}

/// An object being edited: the original mesh and its per-tet media, the pieces, the lights.
/// See the module documentation for the data model.
#[derive(Debug, Clone)]
pub struct Editor {
    original: TetMesh,
    centroids: Vec<DVec3>,
    media: PerTetMedia,
    pieces: Vec<Piece>,
    /// The shadow occluder of the pieces' current placement (`None` without shadows), rebuilt
    /// whenever a piece is rebuilt or moved and reused by every relight.
    occluder: Option<Arc<TriangleBvh>>,
    /// Per original tet: (piece, local tet) holding it, or `None` once it was cut away
    /// ([`locate`], rebuilt with the pieces).
    located: Vec<Option<(u32, u32)>>,
    lights: Vec<Light>,
    options: EditOptions,
    setup: SolveSetup,
    /// Whether the one piece is still the whole original mesh (no cut, split or weld).
    uncut: bool,
    /// Whether the bake returned radiance at the user's surface vertices (through the original
    /// mesh's surface map) rather than at every tet-mesh vertex.
    user_surface: bool,
}

impl Editor {
    /// The editor of a tet mesh baked by TransCut: `original` (world space) with the media
    /// table its material ids index, the bake's fluence (one per vertex) and whether the bake
    /// returned radiance at the user's surface vertices. The solve starts from `fluence`: when
    /// the editor's source equals the bake's (shadows off, or shadows from `shared`, the
    /// bake's own occluder), it takes no iteration. `shared` shadows the relights until the
    /// pieces' placement changes (a cut, split, fracture, move or recombine), which shadows with
    /// the pieces' own boundaries.
    ///
    /// # Errors
    /// [`EditError::InvalidOptions`] for bad options or a fluence that does not match the mesh;
    /// [`EditError::Volume`] for media that disagree on η at the surface; [`EditError::Light`],
    /// [`EditError::Diffusion`], [`EditError::Gpu`] from the first solve.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn from_tets(
        original: TetMesh,
        table: &[Medium],
        fluence: Vec<[f64; 3]>,
        user_surface: bool,
        mm_per_unit: f64,
        lights: &[Light],
        options: &EditOptions,
        shared: Option<Arc<TriangleBvh>>,
        progress: Progress,
    ) -> Result<Self, EditError> {
        options.validate()?;
        light::validate_lights(lights)?;
        if fluence.len() != original.vertex_count() {
            return Err(EditError::InvalidOptions(format!(
                "the bake has {} fluence values for {} tet-mesh vertices",
                fluence.len(),
                original.vertex_count()
            )));
        }
        let media = PerTetMedia::from_materials(&original, table)?;
        let backend = match options.backend {
            Some(b) => b,
            None => Backend::from_env_or(Backend::Auto)?,
        };
        let setup = SolveSetup {
            tolerance: options.tolerance,
            max_iterations: options.max_iterations,
            solver: options.solver,
            backend,
            mm_per_unit,
            discretization: options.discretization,
        };
        let centroids = centroids(&original);
        let mut timings = Timings::default();
        let all: Vec<u32> = (0..original.tet_count() as u32).collect();
        let whole = Span::whole(&progress);
        let piece = piece::build(
            original.clone(),
            all,
            DMat4::IDENTITY,
            &media,
            &setup,
            Some(fluence),
            &mut timings,
            whole.part(0.0, 0.3),
        )?;
        let mut pieces = vec![piece];
        let occluder = piece::light_and_solve(
            &mut pieces,
            lights,
            &options.source,
            piece::Shadowing::new(options.shadows, shared),
            &setup,
            &mut timings,
            whole.part(0.3, 1.0),
        )?;
        let located = locate(original.tet_count(), &pieces);
        Ok(Self {
            original,
            centroids,
            media,
            pieces,
            occluder,
            located,
            lights: lights.to_vec(),
            options: options.clone(),
            setup,
            uncut: true,
            user_surface,
        })
    }

    /// The pieces (one until a split or fracture).
    #[must_use]
    pub fn pieces(&self) -> &[Piece] {
        &self.pieces
    }

    /// The current lights.
    #[must_use]
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> &EditOptions {
        &self.options
    }

    /// The original tet mesh (rest space).
    #[must_use]
    pub fn original_mesh(&self) -> &TetMesh {
        &self.original
    }

    /// The medium per ORIGINAL tet.
    #[must_use]
    pub fn media(&self) -> &PerTetMedia {
        &self.media
    }

    /// Radiance at the user's vertices while the object is uncut and unmoved, in the order the
    /// bake returned it (through the original mesh's surface map for a surface object; per
    /// tet-mesh vertex for an object given as a tet mesh), else `None`.
    #[must_use]
    pub fn user_radiance(&self) -> Option<Vec<[f64; 3]>> {
        let p = match self.pieces.as_slice() {
            [p] if self.uncut && p.transform == DMat4::IDENTITY => p,
            _ => return None,
        };
        Some(if self.user_surface { self.original.sample_at_user_vertices(&p.radiance) } else { p.radiance.clone() })
    }

    /// The radiance field the user's surface is sampled from while the object is uncut and
    /// unmoved and was given as a surface: the original tet mesh (with its surface map) and Lo
    /// per vertex of it; else `None`.
    #[must_use]
    pub fn surface_field(&self) -> Option<(&TetMesh, &[[f64; 3]])> {
        match self.pieces.as_slice() {
            [p] if self.uncut && self.user_surface && p.transform == DMat4::IDENTITY => Some((&self.original, &p.radiance)),
            _ => None,
        }
    }

    /// New lights: q recomputed on every piece (matrices unchanged), every piece re-solved from
    /// its last φ. ([`Editor::relight_with_undo`] without the undo.)
    ///
    /// # Errors
    /// [`EditError::Light`] for an invalid light; [`EditError::Diffusion`] / [`EditError::Gpu`]
    /// from a solve. The editor is unchanged on error.
    pub fn relight(&mut self, lights: &[Light]) -> Result<UpdateStats, EditError> {
        self.relight_with_progress(lights, Progress::none())
    }

    /// [`Editor::relight`] reporting the stages `"light"` and `"solve"` to `progress`, which
    /// can cancel it.
    ///
    /// # Errors
    /// As [`Editor::relight`], plus [`EditError::Cancelled`]; the editor is unchanged on error.
    pub fn relight_with_progress(&mut self, lights: &[Light], progress: Progress) -> Result<UpdateStats, EditError> {
        self.relight_with_undo(lights, progress).map(|(stats, _)| stats)
    }

    /// [`Editor::relight`], also returning what it replaced, so that [`Editor::undo_relight`]
    /// can put the editor back as it was before, bit for bit, without a copy of the editor
    /// (for a caller that relights several editors and must undo them all when a later one
    /// fails).
    ///
    /// # Errors
    /// As [`Editor::relight_with_progress`]; the editor is unchanged on error.
    pub fn relight_with_undo(&mut self, lights: &[Light], progress: Progress) -> Result<(UpdateStats, RelightUndo), EditError> {
        let start = Instant::now();
        light::validate_lights(lights)?;
        let mut timings = Timings::default();
        let whole = Span::whole(&progress);
        let q = piece::sources(
            &self.pieces,
            lights,
            &self.options.source,
            self.occluder.as_deref(),
            &mut timings,
            whole.part(0.0, 0.5),
        )?;
        let pieces = piece::relight_all(&mut self.pieces, q, &self.setup, &mut timings, whole.part(0.5, 1.0))?;
        let meshes = self.pieces.iter().map(|p| Arc::clone(&p.mesh)).collect();
        let lights = std::mem::replace(&mut self.lights, lights.to_vec());
        Ok((UpdateStats::new(&timings, 0, 0, start), RelightUndo { pieces, meshes, lights }))
    }

    /// Undoes the relight that returned `undo`: every piece gets back its q, b, φ and radiance,
    /// the editor its lights, bit for bit as before that relight. `undo` must come from this
    /// editor's last update (after another update the pieces' φ would not match their media or
    /// meshes).
    ///
    /// # Errors
    /// [`EditError::InvalidOptions`] when the pieces are not those the relight saw (their
    /// number or meshes changed since); the editor is then unchanged.
    pub fn undo_relight(&mut self, undo: RelightUndo) -> Result<(), EditError> {
        let same =
            undo.meshes.len() == self.pieces.len() && undo.meshes.iter().zip(&self.pieces).all(|(m, p)| Arc::ptr_eq(m, &p.mesh));
        if !same {
            return Err(EditError::InvalidOptions(
                "undo_relight: the editor's pieces changed since the relight that made this undo".into(),
            ));
        }
        for (piece, replaced) in self.pieces.iter_mut().zip(undo.pieces) {
            replaced.restore(piece);
        }
        self.lights = undo.lights;
        Ok(())
    }

    /// Applies a material edit to the original tets of its region ([`Region::select`]) and
    /// re-solves the pieces that hold any of them.
    ///
    /// # Errors
    /// [`EditError::InvalidRegion`], [`EditError::InvalidOptions`] (an operation that does not
    /// fit the object), [`EditError::Medium`], [`EditError::Volume`] (a result that is not a
    /// valid medium, naming the tet); solve errors. The editor is unchanged on error.
    pub fn edit_medium(&mut self, edit: &MediumEdit) -> Result<UpdateStats, EditError> {
        self.edit_medium_with_progress(edit, Progress::none())
    }

    /// [`Editor::edit_medium`] reporting the stages `"select"`, `"assembly"`, `"hierarchy"` and
    /// `"solve"` to `progress`, which can cancel it.
    ///
    /// # Errors
    /// As [`Editor::edit_medium`], plus [`EditError::Cancelled`]; the editor is unchanged on error.
    pub fn edit_medium_with_progress(&mut self, edit: &MediumEdit, progress: Progress) -> Result<UpdateStats, EditError> {
        let start = Instant::now();
        progress.report("select", 0.0)?;
        edit.op.validate(self.media.eta(), self.media.g())?;
        let tets = edit.region.select(&self.original, &self.centroids, self.setup.mm_per_unit)?;
        let changes = region::changes(&self.media, &tets, &edit.op)?;
        self.apply_changes(&changes, start, Span::whole(&progress))
    }

    /// Paints a stroke (TransCut §5.2): blends its medium into the original tets near it
    /// ([`PaintStroke::changes`]), refills only the matrix rows of their vertices and re-solves
    /// the pieces that hold any of them from their last φ.
    ///
    /// # Errors
    /// [`EditError::InvalidStroke`]; solve errors. The editor is unchanged on error.
    pub fn paint(&mut self, stroke: &PaintStroke) -> Result<UpdateStats, EditError> {
        self.paint_with_progress(stroke, Progress::none())
    }

    /// [`Editor::paint`] reporting as [`Editor::edit_medium_with_progress`] does.
    ///
    /// # Errors
    /// As [`Editor::paint`], plus [`EditError::Cancelled`]; the editor is unchanged on error.
    pub fn paint_with_progress(&mut self, stroke: &PaintStroke, progress: Progress) -> Result<UpdateStats, EditError> {
        let start = Instant::now();
        progress.report("select", 0.0)?;
        stroke.validate(self.media.eta(), self.media.g())?;
        let changes = stroke.changes(&self.media, &self.centroids);
        self.apply_changes(&changes, start, Span::whole(&progress))
    }

    /// Sets the new coefficients of original tets, refills the rows of their vertices in the
    /// pieces that hold them ([`crate::diffusion::DiffusionSystem`]'s row-local refill of single
    /// media entries), prepares those pieces' solvers for the new matrices and re-solves them.
    /// Nothing is copied whole: the refills are undone if anything fails, and the new solvers,
    /// φ, radiance and media are stored only once everything succeeded.
    fn apply_changes(&mut self, changes: &[(u32, Coefficients)], start: Instant, span: Span) -> Result<UpdateStats, EditError> {
        check_changes(&self.media, changes)?;
        let (eta, g) = (self.media.eta(), self.media.g());
        let mut per_piece: Vec<Vec<(u32, Medium)>> = vec![Vec::new(); self.pieces.len()];
        for &(t, c) in changes {
            if let Some((p, local)) = self.located[t as usize] {
                per_piece[p as usize].push((local, c.with_eta_g(eta, g)));
            }
        }
        self.check_resolution(&per_piece)?;
        let mut timings = Timings { select_ms: ms(start), ..Timings::default() };
        let mut undo = Vec::new();
        let mut solved = Vec::new();
        let mut failure = None;
        let touched = per_piece.iter().filter(|e| !e.is_empty()).count();
        let steps = per_piece.iter().enumerate().filter(|(_, e)| !e.is_empty()).enumerate();
        for (step, (index, entries)) in steps {
            match self.refill_and_solve(index, entries, &mut undo, &mut timings, span.item(step, touched)) {
                Ok(s) => solved.push((index, s)),
                Err(e) => {
                    failure = Some(e);
                    break;
                }
            }
        }
        if let Some(e) = failure {
            for (index, u) in undo.into_iter().rev() {
                let p = &mut self.pieces[index];
                let rows = u.row_ids().to_vec();
                p.system.undo_media_entries(u);
                // The same refresh on the restored matrix gives back the solver bit for bit.
                p.solver
                    .refresh_rows(&p.system, &rows)
                    .expect("a solver refreshes on the rows of a matrix it was prepared for before");
            }
            return Err(e);
        }
        let rows = undo.iter().map(|(_, u)| u.row_ids().len()).sum();
        for &(t, c) in changes {
            // Cannot fail: check_changes made the checks of PerTetMedia::set.
            self.media.set(t as usize, c)?;
        }
        for (index, s) in solved {
            s.store(&mut self.pieces[index]);
        }
        Ok(UpdateStats::new(&timings, rows, changes.len(), start))
    }

    /// Refuses new media (per piece: local tet, medium) that would sit at a piece's surface where
    /// its mesh does not resolve them: the bake's check ([`resolution::check`]) on the changed
    /// tets that own a boundary face, with the piece's surface spacing, so that an edit cannot
    /// make the radiance the bake would have refused.
    fn check_resolution(&self, per_piece: &[Vec<(u32, Medium)>]) -> Result<(), EditError> {
        for (p, entries) in self.pieces.iter().zip(per_piece).filter(|(_, e)| !e.is_empty()) {
            let at_surface = resolution::surface_tets(&p.mesh);
            let media: Vec<&Medium> = entries.iter().filter(|(t, _)| at_surface[*t as usize]).map(|(_, m)| m).collect();
            if !media.is_empty() {
                let spacing = resolution::surface_spacing_mm(&p.mesh, self.setup.mm_per_unit);
                let max = resolution::max_resolution(self.setup.discretization);
                resolution::check(&media, spacing, self.original.tet_count(), max).map_err(EditError::Unresolved)?;
            }
        }
        Ok(())
    }

    /// Refills piece `index`'s rows for `entries` (local tet, new medium) in place, pushing the
    /// undo record onto `undo` first thing, refreshes the solver in place for the new matrix
    /// ([`crate::diffusion::Solver::refresh_rows`]: SSOR rescales its triangles, MG-PCG
    /// recomputes only what the rows reach) and solves; the piece's φ and radiance are left as they were.
    fn refill_and_solve(
        &mut self,
        index: usize,
        entries: &[(u32, Medium)],
        undo: &mut Vec<(usize, MediaUndo)>,
        timings: &mut Timings,
        span: Span,
    ) -> Result<piece::Solved, EditError> {
        span.report("assembly", 0.0)?;
        let p = &mut self.pieces[index];
        let t = Instant::now();
        let record = p.system.update_media_entries(entries)?;
        let rows = record.row_ids().to_vec();
        undo.push((index, record));
        timings.assembly_ms += ms(t);
        let t = Instant::now();
        p.solver.refresh_rows(&p.system, &rows)?;
        timings.hierarchy_ms += ms(t);
        piece::solution(&p.system, &p.solver, &p.fluence, &self.setup, timings, span.part(0.2, 1.0))
    }
}

/// The checks [`PerTetMedia::set`] makes, for every change before any is applied.
fn check_changes(media: &PerTetMedia, changes: &[(u32, Coefficients)]) -> Result<(), EditError> {
    for &(t, c) in changes {
        media.check(t as usize, c)?;
    }
    Ok(())
}

/// Per original tet (of `tet_count`): (piece, local tet) holding it, or `None` once it was cut
/// away.
fn locate(tet_count: usize, pieces: &[Piece]) -> Vec<Option<(u32, u32)>> {
    let mut out = vec![None; tet_count];
    for (p, piece) in pieces.iter().enumerate() {
        for (l, &t) in piece.original_tets.iter().enumerate() {
            out[t as usize] = Some((p as u32, l as u32));
        }
    }
    out
}

/// Centroids of a mesh's tets.
fn centroids(mesh: &TetMesh) -> Vec<DVec3> {
    (0..mesh.tet_count()).into_par_iter().map(|t| mesh.tet_positions(t).iter().sum::<DVec3>() / 4.0).collect()
}
