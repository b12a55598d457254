//! One connected piece of an edited object: its rest-space tet mesh, the ids of its tets in the
//! original mesh, its rigid placement, its diffusion system and solver, and its last solution.
//! The functions here build, light and solve one piece; [`super::Editor`] composes them.

use std::sync::Arc;
use std::time::Instant;

use glam::{DMat3, DMat4, DVec3};
use rayon::prelude::*;

use super::error::EditError;
use crate::diffusion::system::SourceState;
use crate::diffusion::{self, DiffusionError, DiffusionSystem, Discretization, Solution, Solver, SolverKind};
use crate::gpu::{self, Backend, GpuError, SolveWith};
use crate::light::{self, Light, SourceOptions};
use crate::mesh::{TetMesh, TriMesh, TriangleBvh};
use crate::optics::Medium;
use crate::progress::{ms, solve_fraction, Cancelled, Progress};
use crate::sparse::hierarchy::HierarchyOptions;
use crate::sparse::{SolveOptions, SparseError};
use crate::volume::PerTetMedia;

/// One connected piece: its tets (with ids in the original mesh), rest-space mesh, rigid
/// transform rest → world, system, solver state and current results.
#[derive(Debug, Clone)]
pub struct Piece {
    pub(crate) mesh: Arc<TetMesh>,
    pub(crate) original_tets: Arc<[u32]>,
    pub(crate) transform: DMat4,
    pub(crate) system: DiffusionSystem,
    pub(crate) solver: Solver,
    pub(crate) fluence: Vec<[f64; 3]>,
    pub(crate) radiance: Vec<[f64; 3]>,
}

impl Piece {
    /// The tet mesh in rest space (where the object was baked). Its material ids are the local
    /// tet indices: tet t's medium is the original tet `original_tets()[t]`'s.
    #[must_use]
    pub fn mesh(&self) -> &TetMesh {
        &self.mesh
    }

    /// Per tet of [`Self::mesh`]: its id in the ORIGINAL (uncut) mesh.
    #[must_use]
    pub fn original_tets(&self) -> &[u32] {
        &self.original_tets
    }

    /// The rigid transform rest → world.
    #[must_use]
    pub fn transform(&self) -> DMat4 {
        self.transform
    }

    /// The fluence φ per tet-mesh vertex.
    #[must_use]
    pub fn fluence(&self) -> &[[f64; 3]] {
        &self.fluence
    }

    /// Lo(x, n) per tet-mesh vertex (0 inside, clamped ≥ 0), as a bake returns it.
    #[must_use]
    pub fn radiance(&self) -> &[[f64; 3]] {
        &self.radiance
    }

    /// The diffusion system (matrix, source, right-hand side) of the piece.
    #[must_use]
    pub fn system(&self) -> &DiffusionSystem {
        &self.system
    }

    /// The boundary triangles in WORLD space; its user vertices are the tet-mesh vertices
    /// (interior ones unreferenced), so [`Self::radiance`] indexes it directly.
    ///
    /// # Panics
    /// Never for a piece built by the editor (its boundary has triangles of non-zero area).
    #[must_use]
    pub fn surface(&self) -> TriMesh {
        let m = self.transform;
        let positions: Vec<[f64; 3]> = self.mesh.positions().iter().map(|&p| m.transform_point3(p).to_array()).collect();
        let indices: Vec<u32> = self.mesh.boundary_faces().iter().flat_map(|f| f.vertices).collect();
        TriMesh::from_triangles(&positions, &indices).expect("a tet mesh's boundary has triangles of non-zero area")
    }

    /// The boundary vertices (in [`DiffusionSystem::boundary`] order) and their outward
    /// normals (rotated, normalised by [`light::transmitted_source`]), in world space.
    fn world_boundary(&self) -> (Vec<DVec3>, Vec<DVec3>) {
        let b = self.system.boundary();
        let m = self.transform;
        let rotation = DMat3::from_mat4(m);
        let points = b.ids.par_iter().map(|&v| m.transform_point3(self.mesh.positions()[v as usize])).collect();
        let normals = b.normal.par_iter().map(|&n| rotation * n).collect();
        (points, normals)
    }

    /// The world-space boundary triangles, for shadows.
    fn world_triangles(&self) -> Vec<[DVec3; 3]> {
        let m = self.transform;
        let p = self.mesh.positions();
        self.mesh.boundary_faces().iter().map(|f| f.vertices.map(|v| m.transform_point3(p[v as usize]))).collect()
    }
}

/// Times of one update's stages (ms), summed over pieces.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Timings {
    pub select_ms: f64,
    pub source_ms: f64,
    pub assembly_ms: f64,
    pub hierarchy_ms: f64,
    pub solve_ms: f64,
    pub iterations: [usize; 3],
    pub pieces_solved: usize,
}

/// How pieces are solved: the editor's options, resolved.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SolveSetup {
    pub tolerance: f64,
    pub max_iterations: usize,
    pub solver: SolverKind,
    pub backend: Backend,
    pub mm_per_unit: f64,
    pub discretization: Discretization,
}

/// Where one step of an update reports: the sink and the part `[lo, hi]` of the whole update
/// that the step covers, so that the fraction a caller sees grows through the steps.
#[derive(Clone, Copy)]
pub(crate) struct Span<'p, 'a> {
    pub progress: &'p Progress<'a>,
    pub lo: f64,
    pub hi: f64,
}

impl<'p, 'a> Span<'p, 'a> {
    /// The whole update `[0, 1]` reporting to `progress`.
    pub(crate) fn whole(progress: &'p Progress<'a>) -> Self {
        Self { progress, lo: 0.0, hi: 1.0 }
    }

    /// The part `[a, b]` (fractions of this span) of this span.
    pub(crate) fn part(self, a: f64, b: f64) -> Self {
        Self { progress: self.progress, lo: self.at(a), hi: self.at(b) }
    }

    /// Item `i` of `n` equal parts of this span.
    #[allow(clippy::cast_precision_loss)]
    pub(crate) fn item(self, i: usize, n: usize) -> Self {
        let n = n.max(1) as f64;
        self.part(i as f64 / n, (i as f64 + 1.0) / n)
    }

    /// The fraction of the whole update at `f` of this span.
    pub(crate) fn at(self, f: f64) -> f64 {
        self.lo + (self.hi - self.lo) * f.clamp(0.0, 1.0)
    }

    /// Reports `stage` at `f` of this span.
    ///
    /// # Errors
    /// [`Cancelled`] when the callback asked to stop.
    pub(crate) fn report(self, stage: &str, f: f64) -> Result<(), Cancelled> {
        self.progress.report(stage, self.at(f))
    }
}

/// The media table of a piece: per local tet, the medium of its original tet
/// ([`crate::volume::TableLayout::PerTet`]-style: material id = local tet index).
pub(crate) fn local_table(media: &PerTetMedia, original_tets: &[u32]) -> Vec<Medium> {
    original_tets.par_iter().map(|&t| media.medium(t as usize)).collect()
}

/// Builds a piece (not yet lit or solved: φ = `warm`, radiance 0) from its rest-space mesh:
/// material ids set to the local tet indices, the system assembled with the original tets'
/// media (TransCut eqs. 10–14), the solver's hierarchy built (§4.1).
///
/// # Errors
/// [`EditError::Mesh`] for a mesh whose ids cannot be set; [`EditError::Diffusion`] from the
/// assembly or the hierarchy; [`EditError::InvalidOptions`] for a warm start of the wrong length.
#[allow(clippy::too_many_arguments)]
pub(crate) fn build(
    mut mesh: TetMesh,
    original_tets: Vec<u32>,
    transform: DMat4,
    media: &PerTetMedia,
    setup: &SolveSetup,
    warm: Option<Vec<[f64; 3]>>,
    timings: &mut Timings,
    span: Span<'_, '_>,
) -> Result<Piece, EditError> {
    span.report("assembly", 0.0)?;
    let t = Instant::now();
    mesh.set_materials((0..mesh.tet_count() as u32).collect())?;
    let table = local_table(media, &original_tets);
    let keep_going = || span.report("assembly", 0.25).is_ok();
    let mut system = DiffusionSystem::new_with(&mesh, &table, setup.mm_per_unit, setup.discretization, &keep_going)
        .map_err(diffusion_error)?;
    span.report("assembly", 0.4)?;
    system.keep_coefficients();
    timings.assembly_ms += ms(t);
    span.report("hierarchy", 0.5)?;
    let t = Instant::now();
    let keep_going = || span.report("hierarchy", 0.5).is_ok();
    let solver = Solver::new_with(&system, setup.solver, &HierarchyOptions::default(), &keep_going).map_err(diffusion_error)?;
    timings.hierarchy_ms += ms(t);
    span.report("hierarchy", 1.0)?;
    let n = mesh.vertex_count();
    let fluence = match warm {
        Some(w) if w.len() != n => {
            return Err(EditError::InvalidOptions(format!("warm start has {} entries for {n} vertices", w.len())))
        }
        Some(w) => w,
        None => vec![[0.0; 3]; n],
    };
    Ok(Piece {
        mesh: Arc::new(mesh),
        original_tets: original_tets.into(),
        transform,
        system,
        solver,
        fluence,
        radiance: vec![[0.0; 3]; n],
    })
}

/// The occluder of every piece's world-space boundary (for shadows), `None` without shadows.
/// The editor builds it once per placement of its pieces (bake, cut, split, fracture, move,
/// recombine) and reuses it for every relight.
pub(crate) fn occluder(pieces: &[Piece], shadows: bool) -> Option<Arc<TriangleBvh>> {
    shadows.then(|| Arc::new(TriangleBvh::new(pieces.iter().flat_map(Piece::world_triangles).collect())))
}

/// Every piece's transmitted source q (eq. 12's q) at its world-space boundary points under
/// `lights`, shadowed by `occluder` (all pieces' world boundaries, see [`occluder`]); the pieces
/// are not changed.
///
/// Reports the stage `"light"` over `span` while it works ([`light::transmitted_source_with`]).
///
/// # Errors
/// [`EditError::Light`] from the source; [`EditError::Cancelled`].
pub(crate) fn sources(
    pieces: &[Piece],
    lights: &[Light],
    source: &SourceOptions,
    occluder: Option<&TriangleBvh>,
    timings: &mut Timings,
    span: Span<'_, '_>,
) -> Result<Vec<Vec<[f64; 3]>>, EditError> {
    let t = Instant::now();
    span.report("light", 0.0)?;
    let n = pieces.len();
    let q = pieces
        .iter()
        .enumerate()
        .map(|(i, piece)| {
            let (points, normals) = piece.world_boundary();
            let eta = piece.system.boundary_terms().eta;
            let part = span.item(i, n);
            let poll = |f: f64| part.report("light", f);
            light::transmitted_source_with(lights, &points, &normals, eta, occluder, source, &poll).map_err(EditError::from)
        })
        .collect::<Result<Vec<_>, _>>()?;
    span.report("light", 1.0)?;
    timings.source_ms += ms(t);
    Ok(q)
}

/// Sets every piece's source to its q of `q` ([`sources`]) and solves it from its last φ; on
/// success the pieces take the new φ and radiance, and what they held before comes back per
/// piece (moved out, not copied; [`Replaced::restore`] puts it back). On error every piece is as
/// before (the sources already replaced are put back; φ and radiance are only written at the
/// end).
///
/// The solves report over `span`, piece after piece.
///
/// # Errors
/// [`EditError::Diffusion`] for an invalid q; those of [`solution`].
pub(crate) fn relight_all(
    pieces: &mut [Piece],
    q: Vec<Vec<[f64; 3]>>,
    setup: &SolveSetup,
    timings: &mut Timings,
    span: Span<'_, '_>,
) -> Result<Vec<Replaced>, EditError> {
    let n = pieces.len();
    let mut replaced = Vec::with_capacity(n);
    let mut solved = Vec::with_capacity(n);
    let mut failure = None;
    for (i, (piece, q)) in pieces.iter_mut().zip(q).enumerate() {
        match piece.system.replace_source(q) {
            Ok(old) => replaced.push(old),
            Err(e) => {
                failure = Some(e.into());
                break;
            }
        }
        match solution(&piece.system, &piece.solver, &piece.fluence, setup, timings, span.item(i, n)) {
            Ok(s) => solved.push(s),
            Err(e) => {
                failure = Some(e);
                break;
            }
        }
    }
    if let Some(e) = failure {
        for (piece, old) in pieces.iter_mut().zip(replaced) {
            piece.system.restore_source(old);
        }
        return Err(e);
    }
    Ok(pieces
        .iter_mut()
        .zip(replaced.into_iter().zip(solved))
        .map(|(piece, (source, s))| Replaced { source, solution: s.store(piece) })
        .collect())
}

/// What [`relight_all`] replaced in one piece: its q and b, φ and radiance.
#[derive(Debug)]
pub(crate) struct Replaced {
    source: SourceState,
    solution: Solved,
}

impl Replaced {
    /// Puts the piece's previous q, b, φ and radiance back (bit for bit; the piece must be the
    /// one [`relight_all`] replaced them in, unchanged since).
    pub(crate) fn restore(self, piece: &mut Piece) {
        piece.system.restore_source(self.source);
        // The returned vectors are the relight's, dropped.
        self.solution.store(piece);
    }
}

/// What shadows the lights of [`light_and_solve`].
pub(crate) enum Shadowing {
    /// No shadows.
    Off,
    /// The pieces' own world-space boundaries ([`occluder`]).
    Pieces,
    /// A given occluder (e.g. every object's surface of the baked scene).
    Shared(Arc<TriangleBvh>),
}

impl Shadowing {
    /// `shared` when shadows are on and it is given, else the pieces' own (or none).
    pub(crate) fn new(shadows: bool, shared: Option<Arc<TriangleBvh>>) -> Self {
        match (shadows, shared) {
            (false, _) => Shadowing::Off,
            (true, Some(shared)) => Shadowing::Shared(shared),
            (true, None) => Shadowing::Pieces,
        }
    }
}

/// Recomputes every piece's q shadowed as `shadowing` says and solves them ([`relight_all`]);
/// returns the occluder used. On error every piece is as before.
///
/// The light stage reports over the first half of `span`, the solves over the second.
///
/// # Errors
/// Those of [`sources`] and [`relight_all`].
pub(crate) fn light_and_solve(
    pieces: &mut [Piece],
    lights: &[Light],
    source: &SourceOptions,
    shadowing: Shadowing,
    setup: &SolveSetup,
    timings: &mut Timings,
    span: Span<'_, '_>,
) -> Result<Option<Arc<TriangleBvh>>, EditError> {
    span.report("occluder", 0.0)?;
    let t = Instant::now();
    let occluder = match shadowing {
        Shadowing::Off => None,
        Shadowing::Pieces => occluder(pieces, true),
        Shadowing::Shared(shared) => Some(shared),
    };
    timings.source_ms += ms(t);
    let q = sources(pieces, lights, source, occluder.as_deref(), timings, span.part(0.0, 0.5))?;
    relight_all(pieces, q, setup, timings, span.part(0.5, 1.0))?;
    Ok(occluder)
}

/// A solve's result for one piece, not yet stored in it (or, from [`Solved::store`], the one it
/// replaced).
#[derive(Debug)]
pub(crate) struct Solved {
    fluence: Vec<[f64; 3]>,
    radiance: Vec<[f64; 3]>,
}

impl Solved {
    /// Makes this the piece's φ and radiance; returns the ones it replaced (moved, not copied).
    pub(crate) fn store(self, piece: &mut Piece) -> Solved {
        Solved {
            fluence: std::mem::replace(&mut piece.fluence, self.fluence),
            radiance: std::mem::replace(&mut piece.radiance, self.radiance),
        }
    }
}

/// Solves `system` from the warm start `warm` (the piece's last φ) and derives the radiance:
/// with `solver` (prepared for `system`'s matrix): [`SolverKind::Pcg`] on the editor's backend
/// ([`gpu::solve_on`]), the other kinds on the CPU.
///
/// Reports the stage `"solve"` over `span` after every iteration, the residual's way down to
/// the tolerance as the fraction ([`solve_fraction`]).
///
/// # Errors
/// [`EditError::Diffusion`] (not converged, …); [`EditError::Gpu`] when the GPU was required
/// and failed; [`EditError::Cancelled`].
pub(crate) fn solution(
    system: &DiffusionSystem,
    solver: &Solver,
    warm: &[[f64; 3]],
    setup: &SolveSetup,
    timings: &mut Timings,
    span: Span<'_, '_>,
) -> Result<Solved, EditError> {
    span.report("solve", 0.0)?;
    let t = Instant::now();
    let tolerance = setup.tolerance;
    let monitor = |_: usize, residual: [f64; 3]| span.report("solve", solve_fraction(residual, tolerance)).is_ok();
    let options =
        SolveOptions { tolerance, max_iterations: setup.max_iterations, ..SolveOptions::default() }.with_monitor(&monitor);
    let solution: Solution = if solver.kind() == SolverKind::Pcg && setup.backend != Backend::Cpu {
        gpu::solve_on(setup.backend, SolveWith::Solver(solver), system, Some(warm), &options)
            .map_err(|e| match e {
                GpuError::Diffusion(d) => diffusion_error(d),
                other => EditError::Gpu(other),
            })?
            .0
    } else {
        solver.solve(system, Some(warm), &options).map_err(diffusion_error)?
    };
    let radiance = per_vertex_radiance(system, &solution.phi)?;
    timings.solve_ms += ms(t);
    for (sum, i) in timings.iterations.iter_mut().zip(solution.stats.iterations) {
        *sum += i;
    }
    timings.pieces_solved += 1;
    Ok(Solved { fluence: solution.phi, radiance })
}

/// A solver's error as the editor's: a cancel by the monitor is [`EditError::Cancelled`].
fn diffusion_error(e: DiffusionError) -> EditError {
    match e {
        DiffusionError::Sparse(SparseError::Cancelled { .. }) | DiffusionError::Cancelled => EditError::Cancelled(Cancelled),
        e => EditError::Diffusion(e),
    }
}

/// Lo(x, n) per tet-mesh vertex: eq. 3 on the boundary ([`diffusion::surface_radiance`]),
/// clamped ≥ 0 as a bake does, 0 inside.
fn per_vertex_radiance(system: &DiffusionSystem, phi: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, DiffusionError> {
    let lo = diffusion::surface_radiance(system, phi)?;
    let mut out = vec![[0.0; 3]; system.vertex_count()];
    for (&v, l) in system.boundary().ids.iter().zip(&lo) {
        out[v as usize] = l.map(|x| x.max(0.0));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_nest_and_items_tile_their_span() {
        let none = Progress::none();
        let half = Span::whole(&none).part(0.5, 1.0);
        assert_eq!(half.at(0.0), 0.5);
        assert_eq!(half.at(0.5), 0.75);
        assert_eq!(half.at(2.0), 1.0);
        let third = half.item(1, 4);
        assert_eq!((third.lo, third.hi), (0.625, 0.75));
        assert_eq!(Span::whole(&none).item(0, 0).hi, 1.0);
    }

    #[test]
    fn a_span_reports_the_whole_fraction_and_passes_a_cancel_on() {
        let seen = std::sync::Mutex::new(Vec::new());
        let cb = |s: &str, f: f64| {
            seen.lock().unwrap().push((s.to_owned(), f));
            f < 0.7
        };
        let p = Progress::new(&cb);
        let span = Span::whole(&p).part(0.2, 0.8);
        assert!(span.report("light", 0.5).is_ok());
        assert_eq!(span.report("solve", 1.0), Err(Cancelled));
        assert_eq!(*seen.lock().unwrap(), vec![("light".to_owned(), 0.5), ("solve".to_owned(), 0.8)]);
    }
}
