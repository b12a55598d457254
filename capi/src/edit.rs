//! Interactive editing of a baked scene (TransCut §5): relight, material edits, paint, cuts,
//! fracture, piece placement and recombination, each wrapping `transcut::edit::Editor`.
//!
//! `tc_scene_bake` keeps every object's bake (its tet mesh, media and fluence) with the lights
//! it was solved under (an [`EditSession`]). The first edit of an object starts its editor from
//! that bake (`Editor::from_bake`, warm-started from the bake's fluence) with the bake's options.
//! A failed call changes nothing: the editor leaves itself unchanged on error and a fresh editor
//! is kept only when the edit succeeded. A relight relights the objects' editors in place, one
//! after the other, keeping each one's undo (`Editor::relight_with_undo`, no copy of an editor),
//! and on a failure or cancellation undoes those already relit, last first.

use std::ffi::c_void;

use glam::{DMat4, DVec3};
use transcut_core::edit::cut::{Cutter, SweptStroke};
use transcut_core::edit::{
    EditError, EditOptions, Editor, MediumEdit, MediumOp, PaintStroke, Piece, Region, RelightUndo, UpdateStats,
};
use transcut_core::light::Light;
use transcut_core::mesh::TriMesh;
use transcut_core::optics::Medium;
use transcut_core::scene::{BakeOptions, ObjectBake, ObjectStats, Scene};

use super::bake::{bake_failure, Callback, TcProgressFn};
use super::guard::{run, Failure};
use super::handle::{with_scene, ObjectResult, SceneState, TcScene};
use super::medium::{medium_from, TcMedium};
use super::ptr;
use super::status::{
    TcStatus, TC_BUFFER_TOO_SHORT, TC_CANCELLED, TC_GPU_UNAVAILABLE, TC_INVALID_ARGUMENT, TC_INVALID_HANDLE, TC_INVALID_MESH,
    TC_NOTHING_LEFT, TC_NOT_BAKED, TC_SOLVE_FAILED,
};

/// `TcMediumEdit.region`: every tet of the object.
pub const TC_REGION_ALL: u32 = 0;
/// `TcMediumEdit.region`: the tets whose centroid lies in the sphere `center`, `radius` (world
/// space at the placement the object was baked in, scene units).
pub const TC_REGION_SPHERE: u32 = 1;
/// `TcMediumEdit.region`: the tets whose centroid lies between `min_mm` and `max_mm` (inclusive)
/// below the object's surface as baked (distance to the closest surface triangle, millimetres).
pub const TC_REGION_DEPTH: u32 = 2;
/// `TcMediumEdit.region`: the tets `t` with `mask[t] != 0`, one byte per tetrahedron of the
/// object as baked (`mask_len` = `tc_object_tet_count`), also tets a cut has removed.
pub const TC_REGION_MASK: u32 = 3;

/// `TcMediumEdit.op`: σa and σ′s become `sigma_a`, `sigma_s_prime` (mm⁻¹); η and g stay the
/// object's.
pub const TC_MEDIUM_ASSIGN: u32 = 0;
/// `TcMediumEdit.op`: σa and σ′s are multiplied by `sigma_a`, `sigma_s_prime` per channel
/// (finite, ≥ 0; the result must stay a valid medium).
pub const TC_MEDIUM_SCALE: u32 = 1;
/// `TcMediumEdit.op`: `sigma_a`, `sigma_s_prime` (mm⁻¹, finite, may be negative) are added per
/// channel; the result must stay a valid medium.
pub const TC_MEDIUM_ADD: u32 = 2;

/// A material edit for `tc_object_edit_medium`: an operation (`op`) applied to the tetrahedra of
/// a region (`region`); only the fields of the chosen region and operation are read. Set `size`
/// to `sizeof(TcMediumEdit)`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcMediumEdit {
    /// `sizeof(TcMediumEdit)`.
    pub size: u32,
    /// `TC_REGION_ALL`, `TC_REGION_SPHERE`, `TC_REGION_DEPTH` or `TC_REGION_MASK`.
    pub region: u32,
    /// `TC_REGION_SPHERE`: the centre (world space at the bake's placement, scene units).
    pub center: [f64; 3],
    /// `TC_REGION_SPHERE`: the radius, scene units, finite and ≥ 0.
    pub radius: f64,
    /// `TC_REGION_DEPTH`: the depth range below the surface, millimetres (0 ≤ min ≤ max).
    pub min_mm: f64,
    /// `TC_REGION_DEPTH`: see `min_mm`.
    pub max_mm: f64,
    /// `TC_REGION_MASK`: one byte per tetrahedron of the baked object, non-zero = selected.
    pub mask: *const u8,
    /// `TC_REGION_MASK`: the length of `mask` (= `tc_object_tet_count`).
    pub mask_len: usize,
    /// `TC_MEDIUM_ASSIGN`, `TC_MEDIUM_SCALE` or `TC_MEDIUM_ADD`.
    pub op: u32,
    /// New values (mm⁻¹), factors or increments of σa per channel, as `op` says.
    pub sigma_a: [f64; 3],
    /// New values (mm⁻¹), factors or increments of σ′s per channel, as `op` says.
    pub sigma_s_prime: [f64; 3],
}

/// What the last update of one object did (`tc_object_edit_stats`). The caller sets `size` to
/// `sizeof(TcEditStats)` before the call; the library sets it to the number of bytes written.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcEditStats {
    /// `sizeof(TcEditStats)`.
    pub size: u32,
    /// Pieces re-solved.
    pub pieces_solved: u32,
    /// Solver iterations per channel (R, G, B), summed over the pieces solved.
    pub iterations: [u32; 3],
    /// 1 when the update was a cut or split (the `cut_*` fields are set), else 0.
    pub cut: u32,
    /// Matrix rows refilled by a paint or material edit (0 for a relight).
    pub rows_rebuilt: u64,
    /// Tetrahedra whose medium changed, or tetrahedra of rebuilt pieces.
    pub tets_changed: u64,
    /// Wall time of the light transmitted into the pieces (with shadows), milliseconds.
    pub source_ms: f64,
    /// Wall time of matrix assembly or row refill.
    pub assembly_ms: f64,
    /// Wall time of the solver's preparation (multiresolution hierarchy, operators).
    pub hierarchy_ms: f64,
    /// Wall time of the solves.
    pub solve_ms: f64,
    /// Wall time of the whole update.
    pub total_ms: f64,
    /// Cut: tetrahedra deleted.
    pub cut_removed_tets: u64,
    /// Cut: vertices deleted.
    pub cut_removed_vertices: u64,
    /// Cut: kept vertices whose position changed (relaxed onto the cut surface).
    pub cut_moved_vertices: u64,
    /// Cut: kept vertices snapped onto the cut surface.
    pub cut_surface_vertices: u64,
    /// Cut: the largest distance of those vertices from the cutter (scene units).
    pub cut_max_distance: f64,
    /// Cut: the worst minimum dihedral angle of any tetrahedron after the cut, degrees.
    pub cut_min_dihedral_degrees: f64,
    /// Cut: the dihedral-angle bound the cut enforced, degrees.
    pub cut_bound_degrees: f64,
}

/// What edits start from: the lights of the last bake or relight, the options, and per object
/// its bake (until its editor exists) and editor.
pub(crate) struct EditSession {
    lights: Vec<Light>,
    options: EditOptions,
    /// Worker threads of the bake (0 = the global pool).
    threads: usize,
    objects: Vec<EditSlot>,
}

/// One object's editing state.
struct EditSlot {
    /// The bake the editor starts from; dropped once the editor exists.
    bake: Option<Box<ObjectBake>>,
    editor: Option<Box<Editor>>,
    mm_per_unit: f64,
    /// The bake's statistics (what `tc_object_stats` reports, also after a relight).
    bake_stats: ObjectStats,
    /// The last update.
    last: Option<UpdateStats>,
}

impl EditSession {
    /// The session after a successful bake of `scene` with `options`.
    pub(crate) fn new(scene: &Scene, bakes: Vec<ObjectBake>, options: &BakeOptions) -> Self {
        let edit = EditOptions {
            tets: options.tets,
            tolerance: options.tolerance,
            max_iterations: options.max_iterations,
            backend: options.backend,
            source: options.source,
            shadows: options.shadows,
            ..EditOptions::default()
        };
        let objects = bakes
            .into_iter()
            .zip(&scene.objects)
            .map(|(bake, object)| EditSlot {
                bake_stats: bake.stats.clone(),
                bake: Some(Box::new(bake)),
                editor: None,
                mm_per_unit: object.mm_per_unit,
                last: None,
            })
            .collect();
        Self { lights: scene.lights.clone(), options: edit, threads: options.threads, objects }
    }
}

/// What `tc_scene_relight` did to one object, to undo it when a later object fails.
enum Relit {
    /// The object's editor was relit in place; this puts it back.
    Existing(RelightUndo),
    /// The object had no editor: one was made from its bake (which the slot keeps until the
    /// relight of every object succeeded) and relit.
    Created,
}

impl EditSlot {
    /// A new editor from the object's bake (not stored), solved under `lights` (the lights the
    /// bake was solved under).
    fn new_editor(&self, lights: &[Light], options: &EditOptions) -> Result<Editor, Failure> {
        let bake = self
            .bake
            .as_deref()
            .ok_or_else(|| Failure::new(super::status::TC_INTERNAL_ERROR, "an object with neither bake nor editor"))?;
        Editor::from_bake(bake, self.mm_per_unit, lights, options).map_err(|e| edit_failure(&e))
    }

    /// Relights the object's editor in place under `lights`, or makes one from its bake (solved
    /// under `baked`, the session's lights), relights it and stores it; the bake and the last
    /// statistics stay. Unchanged on error; [`EditSlot::undo_relight`] undoes a success.
    fn relight(&mut self, baked: &[Light], lights: &[Light], options: &EditOptions) -> Result<(UpdateStats, Relit), Failure> {
        if let Some(editor) = self.editor.as_deref_mut() {
            let (stats, undo) = editor.relight_with_undo(lights).map_err(|e| edit_failure(&e))?;
            return Ok((stats, Relit::Existing(undo)));
        }
        let mut editor = self.new_editor(baked, options)?;
        let stats = editor.relight(lights).map_err(|e| edit_failure(&e))?;
        self.editor = Some(Box::new(editor));
        Ok((stats, Relit::Created))
    }

    /// Undoes [`EditSlot::relight`]: the editor as before it, or no editor (the bake was kept).
    fn undo_relight(&mut self, relit: Relit) {
        match relit {
            Relit::Existing(undo) => {
                if let Some(editor) = self.editor.as_deref_mut() {
                    editor.undo_relight(undo);
                }
            }
            Relit::Created => self.editor = None,
        }
    }
}

/// The status of a failed edit (`EditError` variants; new ones default to `TC_SOLVE_FAILED`).
fn edit_failure(e: &EditError) -> Failure {
    let status = match e {
        EditError::InvalidCutter(_)
        | EditError::InvalidStroke(_)
        | EditError::InvalidRegion(_)
        | EditError::InvalidOptions(_)
        | EditError::NotRigid(_)
        | EditError::Medium(_)
        | EditError::Volume(_)
        | EditError::Light(_) => TC_INVALID_ARGUMENT,
        EditError::NothingLeft { .. } => TC_NOTHING_LEFT,
        EditError::NoSuchPiece { .. } => TC_INVALID_HANDLE,
        EditError::Mesh(_) => TC_INVALID_MESH,
        EditError::Gpu(_) => TC_GPU_UNAVAILABLE,
        EditError::Cancelled(_) => TC_CANCELLED,
        EditError::Scene(s) => return bake_failure(s),
        _ => TC_SOLVE_FAILED,
    };
    Failure::new(status, e.to_string())
}

/// `TC_NOT_BAKED`: nothing to edit.
fn not_baked() -> Failure {
    Failure::new(
        TC_NOT_BAKED,
        "the scene has not been baked (or an object, medium, transform or scale changed since): call tc_scene_bake first",
    )
}

/// Runs `f` on `threads` worker threads (0: the global pool).
fn with_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> Result<R, Failure> {
    if threads == 0 {
        return Ok(f());
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Failure::invalid(format!("cannot start {threads} threads: {e}")))?;
    Ok(pool.install(f))
}

/// Applies `op` to object `object`'s editor (started from its bake if needed), keeps the new
/// state and the update's statistics, and refreshes the object's radiance at the user's
/// vertices; returns the object's piece count. Nothing changes when `op` fails.
fn edit_object(
    state: &mut SceneState,
    object: u32,
    op: impl FnOnce(&mut Editor) -> Result<UpdateStats, EditError> + Send,
) -> Result<usize, Failure> {
    let i = state.object_index(object)?;
    let session = state.session.as_mut().ok_or_else(not_baked)?;
    let (lights, options, threads) = (&session.lights, &session.options, session.threads);
    let slot = &mut session.objects[i];
    let (editor, stats) = with_threads(threads, || -> Result<_, Failure> {
        let mut editor = match slot.editor.take() {
            Some(e) => e,
            None => Box::new(slot.new_editor(lights, options)?),
        };
        match op(&mut editor) {
            Ok(stats) => Ok((editor, stats)),
            Err(e) => {
                // Unchanged by the failed edit: keep an editor that existed before.
                if slot.bake.is_none() {
                    slot.editor = Some(editor);
                }
                Err(edit_failure(&e))
            }
        }
    })??;
    let radiance = editor.user_radiance();
    let pieces = editor.pieces().len();
    slot.editor = Some(editor);
    slot.bake = None;
    slot.last = Some(stats);
    if let Some(results) = state.results.as_mut() {
        results[i].radiance = radiance;
    }
    Ok(pieces)
}

/// The editor of object `object` (which must have been edited) for reading.
fn edited(state: &SceneState, object: u32) -> Result<&Editor, Failure> {
    let i = state.object_index(object)?;
    let session = state.session.as_ref().ok_or_else(not_baked)?;
    session.objects[i].editor.as_deref().ok_or_else(|| {
        Failure::new(
            TC_NOT_BAKED,
            format!("object {object} has not been edited since the bake: its pieces exist from its first edit (or tc_scene_relight) on"),
        )
    })
}

/// Piece `piece` of an editor, checked.
fn piece_of(editor: &Editor, piece: u32) -> Result<&Piece, Failure> {
    let pieces = editor.pieces();
    pieces.get(piece as usize).ok_or_else(|| {
        Failure::new(TC_INVALID_HANDLE, format!("piece {piece} does not exist (the object has {} pieces)", pieces.len()))
    })
}

/// Three-vectors from the caller's `xyz` array of `count` points, each finite.
///
/// # Safety
/// `ptr` must point to `3 × count` readable doubles when `count > 0`.
unsafe fn points(ptr: *const f64, count: usize, name: &str) -> Result<Vec<DVec3>, Failure> {
    let len = ptr::times(count, 3, name)?;
    // SAFETY: forwarded.
    let xyz = unsafe { ptr::slice(ptr, len, name)? };
    Ok(xyz.chunks_exact(3).map(|p| DVec3::new(p[0], p[1], p[2])).collect())
}

/// A flag argument: 0 or 1.
fn flag(value: i32, name: &str) -> Result<bool, Failure> {
    match value {
        0 => Ok(false),
        1 => Ok(true),
        v => Err(Failure::invalid(format!("{name} = {v}: must be 0 or 1"))),
    }
}

/// Cuts (or, with `keep_both`, splits) an object with `cutter`.
///
/// # Safety
/// As `with_scene`.
unsafe fn cut_with(scene: *mut TcScene, object: u32, cutter: Cutter, keep_both: bool) -> Result<(), Failure> {
    // SAFETY: forwarded.
    unsafe {
        with_scene(scene, |s| {
            edit_object(s, object, |e| if keep_both { e.split(&cutter) } else { e.cut(&cutter) })?;
            Ok(())
        })
    }
}

/// Runs a piece-count-changing edit and writes the count to the caller's optional `out`.
///
/// # Safety
/// As `with_scene`; `out` NULL or writable (checked for alignment here, before any work).
unsafe fn counted(
    scene: *mut TcScene,
    object: u32,
    out: *mut u32,
    op: impl FnOnce(&mut Editor) -> Result<UpdateStats, EditError> + Send,
) -> Result<(), Failure> {
    if !out.is_null() && !out.is_aligned() {
        return Err(Failure::invalid("`out_piece_count` is not aligned for its type"));
    }
    // SAFETY: forwarded.
    let n = unsafe { with_scene(scene, |s| edit_object(s, object, op))? };
    if !out.is_null() {
        // SAFETY: checked above.
        unsafe { ptr::write(out, u32::try_from(n).unwrap_or(u32::MAX)) };
    }
    Ok(())
}

/// Re-solves every object for the scene's CURRENT lights (after `tc_scene_clear_lights` /
/// `tc_scene_add_*`), warm-started from its last solution, without meshing or assembling again:
/// the interactive counterpart of `tc_scene_bake` after a change of lights. The matrices, media,
/// cuts and pieces stay; afterwards `tc_object_radiance` returns the new radiance (of objects
/// not cut or moved) and `tc_object_edit_stats` what each object's update did.
///
/// Each object is lit by the scene's lights with its own shadows (the pieces of that object);
/// unlike `tc_scene_bake`, other objects cast no shadows on it. `progress` (nullable) is called
/// with `user` as objects finish, as for `tc_scene_bake`; a non-zero return cancels
/// (`TC_CANCELLED`). On any failure no object changes.
///
/// Errors: `TC_NOT_BAKED` before a bake (or after a change other than lights), `TC_INVALID_ARGUMENT`
/// (an invalid light), `TC_SOLVE_FAILED`, `TC_GPU_UNAVAILABLE`, `TC_CANCELLED`.
#[no_mangle]
pub unsafe extern "C" fn tc_scene_relight(scene: *mut TcScene, progress: TcProgressFn, user: *mut c_void) -> TcStatus {
    run("tc_scene_relight", || {
        let callback = Callback::new(progress, user);
        let report = |stage: &str, fraction: f64| callback.as_ref().is_none_or(|c| c.report(stage, fraction));
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                let lights = s.scene.lights.clone();
                let names: Vec<String> = s.scene.objects.iter().map(|o| o.name.clone()).collect();
                let EditSession { lights: baked, options, threads, objects } = s.session.as_mut().ok_or_else(not_baked)?;
                let stats = with_threads(*threads, || relight_objects(objects, baked, &lights, options, &names, report))??;
                let mut results = Vec::with_capacity(objects.len());
                for (slot, stats) in objects.iter_mut().zip(stats) {
                    let radiance = slot.editor.as_deref().and_then(Editor::user_radiance);
                    results.push(ObjectResult { radiance, stats: slot.bake_stats.clone() });
                    slot.bake = None;
                    slot.last = Some(stats);
                }
                *baked = lights;
                s.results = Some(results);
                Ok(())
            })
        }
    })
}

/// Relights every object in place under `lights` ([`EditSlot::relight`]), reporting progress
/// before each and once at the end; returns each object's statistics. On a failure (named after
/// the object) or a cancellation, the objects relit so far are undone, last first, so that every
/// object is as before.
fn relight_objects(
    objects: &mut [EditSlot],
    baked: &[Light],
    lights: &[Light],
    options: &EditOptions,
    names: &[String],
    report: impl Fn(&str, f64) -> bool,
) -> Result<Vec<UpdateStats>, Failure> {
    let n = objects.len();
    let cancelled = || Failure::new(TC_CANCELLED, "cancelled by the progress callback; nothing changed");
    let mut done = Vec::with_capacity(n);
    let mut failure = None;
    for (i, slot) in objects.iter_mut().enumerate() {
        if !report(&format!("{}: relight", names[i]), i as f64 / n as f64) {
            failure = Some(cancelled());
            break;
        }
        match slot.relight(baked, lights, options) {
            Ok(r) => done.push(r),
            Err(f) => {
                failure = Some(Failure::new(f.status, format!("object {i} ({}): {}", names[i], f.message)));
                break;
            }
        }
    }
    if failure.is_none() && !report("relight: done", 1.0) {
        failure = Some(cancelled());
    }
    if let Some(f) = failure {
        for (slot, (_, relit)) in objects.iter_mut().zip(done).rev() {
            slot.undo_relight(relit);
        }
        return Err(f);
    }
    Ok(done.into_iter().map(|(stats, _)| stats).collect())
}

/// The number of tetrahedra of the object as baked, in `*out` (the length of a
/// `TC_REGION_MASK` mask; cuts do not change it). `TC_NOT_BAKED` before a bake.
#[no_mangle]
pub unsafe extern "C" fn tc_object_tet_count(scene: *const TcScene, object: u32, out: *mut usize) -> TcStatus {
    run("tc_object_tet_count", || {
        check_not_null!(out);
        // SAFETY: the caller's contract.
        let n = unsafe {
            with_scene(scene, |s| {
                let i = s.object_index(object)?;
                let slot = &s.session.as_ref().ok_or_else(not_baked)?.objects[i];
                match (&slot.editor, &slot.bake) {
                    (Some(e), _) => Ok(e.original_mesh().tet_count()),
                    (None, Some(b)) => Ok(b.tet_mesh.tet_count()),
                    (None, None) => Err(not_baked()),
                }
            })?
        };
        // SAFETY: checked above.
        unsafe { ptr::write(out, n) };
        Ok(())
    })
}

/// The region, operation and values of the caller's material edit (the operation becomes a
/// core `MediumOp` once the object's η and g are known).
///
/// # Safety
/// A `TC_REGION_MASK` edit's `mask` must point to `mask_len` readable bytes.
unsafe fn medium_edit(e: &TcMediumEdit) -> Result<(Region, u32, [f64; 3], [f64; 3]), Failure> {
    let region = match e.region {
        TC_REGION_ALL => Region::All,
        TC_REGION_SPHERE => Region::Sphere { center: DVec3::from_array(e.center), radius: e.radius },
        TC_REGION_DEPTH => Region::Depth { min_mm: e.min_mm, max_mm: e.max_mm },
        TC_REGION_MASK => {
            // SAFETY: the caller's contract.
            let mask = unsafe { ptr::slice(e.mask, e.mask_len, "edit->mask")? };
            Region::Mask(mask.iter().map(|&b| b != 0).collect())
        }
        other => {
            return Err(Failure::invalid(format!(
                "edit->region = {other}: unknown region (TC_REGION_ALL 0, SPHERE 1, DEPTH 2, MASK 3)"
            )))
        }
    };
    if !matches!(e.op, TC_MEDIUM_ASSIGN | TC_MEDIUM_SCALE | TC_MEDIUM_ADD) {
        return Err(Failure::invalid(format!("edit->op = {}: unknown operation (TC_MEDIUM_ASSIGN 0, SCALE 1, ADD 2)", e.op)));
    }
    Ok((region, e.op, e.sigma_a, e.sigma_s_prime))
}

/// Changes the medium of an object's tetrahedra inside a region (`TcMediumEdit`), then re-solves
/// the pieces that hold any of them, warm-started; only the matrix rows of the affected
/// vertices are rebuilt (TransCut §5.2). Regions are evaluated on the object as baked (also
/// parts a cut removed, so a later recombine sees them).
///
/// Errors: `TC_NOT_BAKED`, `TC_INVALID_ARGUMENT` (unknown region or operation, a mask of the
/// wrong length, a negative radius, a result that is not a valid medium: the message names the
/// field or tetrahedron), `TC_SOLVE_FAILED`, `TC_GPU_UNAVAILABLE`. Nothing changes on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_object_edit_medium(scene: *mut TcScene, object: u32, edit: *const TcMediumEdit) -> TcStatus {
    run("tc_object_edit_medium", || {
        check_not_null!(edit);
        // SAFETY: checked; `size` is the first field.
        let size = unsafe { edit.cast::<u32>().read() } as usize;
        let ours = std::mem::size_of::<TcMediumEdit>();
        if size < ours {
            return Err(Failure::invalid(format!("edit->size = {size}, expected sizeof(TcMediumEdit) = {ours}")));
        }
        // SAFETY: checked; the caller's contract.
        let (region, op, sigma_a, sigma_s) = unsafe { medium_edit(&*edit)? };
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                edit_object(s, object, move |e| {
                    let op = match op {
                        TC_MEDIUM_ASSIGN => MediumOp::Assign(Medium::new(sigma_a, sigma_s, e.media().eta(), e.media().g())?),
                        TC_MEDIUM_SCALE => MediumOp::Scale { sigma_a, sigma_s },
                        _ => MediumOp::Add { sigma_a, sigma_s },
                    };
                    e.edit_medium(&MediumEdit { region, op })
                })?;
                Ok(())
            })
        }
    })
}

/// Paints a medium along a 3D stroke (TransCut §5.2): `points_xyz` holds `point_count` points
/// (x, y, z; world space at the bake's placement, e.g. on the surface or a cross-section);
/// every tetrahedron whose centroid lies at distance d from the closest point gets the weight
/// w = strength · exp(−d² / (2 radius²)) and its σa, σ′s become (1 − w)·old + w·medium
/// (w < 1e-3: untouched). `radius` in scene units (> 0), `strength` in [0, 1]; `medium` must
/// have the object's η and g. Only the matrix rows of the affected vertices are rebuilt; the
/// solve warm-starts.
///
/// Errors: `TC_NOT_BAKED`, `TC_NULL_POINTER`, `TC_INVALID_ARGUMENT` (naming the fault: no
/// points, a non-finite point, radius, strength, an invalid medium or one whose η or g differs
/// from the object's), `TC_SOLVE_FAILED`. Nothing changes on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_object_paint(
    scene: *mut TcScene,
    object: u32,
    points_xyz: *const f64,
    point_count: usize,
    radius: f64,
    medium: *const TcMedium,
    strength: f64,
) -> TcStatus {
    run("tc_object_paint", || {
        check_not_null!(medium);
        // SAFETY: the caller's contract.
        let points = unsafe { points(points_xyz, point_count, "points_xyz")? };
        // SAFETY: checked; the caller's contract.
        let medium = medium_from(unsafe { &*medium }, "medium")?;
        let stroke = PaintStroke { points, radius, medium, strength };
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                edit_object(s, object, |e| e.paint(&stroke))?;
                Ok(())
            })
        }
    })
}

/// Cuts an object by the plane through `point` with normal `normal` (world space, scene units;
/// the normal need not be unit length): the half-space the normal points into is removed
/// (TransCut §5.1) — tetrahedra there are deleted, vertices left without a tetrahedron removed,
/// kept vertices near the cut relaxed onto the plane as far as the quality bound allows (see
/// `TcEditStats.cut_*`), and every piece's topology, hierarchy and matrix rebuilt and re-solved.
/// With `keep_both` = 1 nothing is removed: every piece is split in two along the plane (pieces
/// numbered as the core orders them). Applies to every piece of the object, where it is now.
///
/// Errors: `TC_NOT_BAKED`, `TC_NULL_POINTER`, `TC_INVALID_ARGUMENT` (non-finite numbers, a zero
/// normal, `keep_both` not 0 or 1), `TC_NOTHING_LEFT` (the cut would remove everything),
/// `TC_SOLVE_FAILED`. Nothing changes on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_object_cut_plane(
    scene: *mut TcScene,
    object: u32,
    point: *const f64,
    normal: *const f64,
    keep_both: i32,
) -> TcStatus {
    run("tc_object_cut_plane", || {
        // SAFETY: the caller's contract (three doubles each).
        let (point, normal) = unsafe { (ptr::vec3(point, "point")?, ptr::vec3(normal, "normal")?) };
        let keep_both = flag(keep_both, "keep_both")?;
        let cutter = Cutter::Plane { point: DVec3::from_array(point), normal: DVec3::from_array(normal) };
        // SAFETY: the caller's contract.
        unsafe { cut_with(scene, object, cutter, keep_both) }
    })
}

/// Cuts an object by a stroke drawn on screen and swept along the camera rays (TransCut §5.1):
/// ray k starts at `origins_xyz[3k..3k+3]` and goes along `directions_xyz[3k..3k+3]` (world
/// space; `ray_count` ≥ 2 rays; a perspective camera repeats its eye as every origin, an
/// orthographic one repeats its direction). Consecutive rays span the cut surface, extended
/// beyond the first and last ray so it separates space; the side to the LEFT of the stroke as
/// seen along the rays (direction × (next point − point)) is removed, or with `keep_both` = 1
/// both sides are kept as separate pieces. Otherwise as `tc_object_cut_plane`.
#[no_mangle]
pub unsafe extern "C" fn tc_object_cut_stroke(
    scene: *mut TcScene,
    object: u32,
    origins_xyz: *const f64,
    directions_xyz: *const f64,
    ray_count: usize,
    keep_both: i32,
) -> TcStatus {
    run("tc_object_cut_stroke", || {
        // SAFETY: the caller's contract.
        let (origins, directions) =
            unsafe { (points(origins_xyz, ray_count, "origins_xyz")?, points(directions_xyz, ray_count, "directions_xyz")?) };
        let keep_both = flag(keep_both, "keep_both")?;
        let stroke = SweptStroke::new(origins, directions).map_err(|e| edit_failure(&e))?;
        // SAFETY: the caller's contract.
        unsafe { cut_with(scene, object, Cutter::Stroke(stroke), keep_both) }
    })
}

/// Cuts an object with a closed triangle mesh (world space, scene units; the layout of
/// `tc_scene_add_mesh`: 3 floats per vertex, `index_count` indices, 3 per triangle,
/// counter-clockwise seen from outside): what lies inside the cutter is removed, or with
/// `keep_both` = 1 kept as separate pieces. Otherwise as `tc_object_cut_plane`;
/// `TC_INVALID_MESH` for an invalid cutter mesh.
#[no_mangle]
pub unsafe extern "C" fn tc_object_cut_mesh(
    scene: *mut TcScene,
    object: u32,
    positions: *const f32,
    vertex_count: usize,
    indices: *const u32,
    index_count: usize,
    keep_both: i32,
) -> TcStatus {
    run("tc_object_cut_mesh", || {
        let floats = ptr::times(vertex_count, 3, "vertex_count")?;
        // SAFETY: the caller's contract (arrays of the given lengths).
        let (positions, indices) =
            unsafe { (ptr::slice(positions, floats, "positions")?, ptr::slice(indices, index_count, "indices")?) };
        if !index_count.is_multiple_of(3) {
            return Err(Failure::new(TC_INVALID_MESH, format!("index_count = {index_count} is not a multiple of 3")));
        }
        let keep_both = flag(keep_both, "keep_both")?;
        let xyz: Vec<[f32; 3]> = positions.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
        let mesh =
            TriMesh::from_triangles(&xyz, indices).map_err(|e| Failure::new(TC_INVALID_MESH, format!("cutter mesh: {e}")))?;
        // SAFETY: the caller's contract.
        unsafe { cut_with(scene, object, Cutter::Solid(mesh), keep_both) }
    })
}

/// Splits every piece of an object into its connected components (after cuts), each solved with
/// its own boundary; the new piece count goes to `*out_piece_count` (nullable).
/// Errors: `TC_NOT_BAKED`, `TC_SOLVE_FAILED`; nothing changes on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_object_fracture(scene: *mut TcScene, object: u32, out_piece_count: *mut u32) -> TcStatus {
    run("tc_object_fracture", || {
        // SAFETY: the caller's contract.
        unsafe { counted(scene, object, out_piece_count, Editor::fracture) }
    })
}

/// Welds the pieces of an object whose boundaries touch again (faces coinciding within 1e-6
/// scene units, where the pieces are now) into one piece each and re-solves them; the new
/// piece count goes to `*out_piece_count` (nullable). Errors as `tc_object_fracture`.
#[no_mangle]
pub unsafe extern "C" fn tc_object_recombine(scene: *mut TcScene, object: u32, out_piece_count: *mut u32) -> TcStatus {
    run("tc_object_recombine", || {
        // SAFETY: the caller's contract.
        unsafe { counted(scene, object, out_piece_count, Editor::recombine) }
    })
}

/// The number of pieces of an edited object, in `*out` (1 until a split or fracture).
/// `TC_NOT_BAKED` before the object's first edit (or `tc_scene_relight`).
#[no_mangle]
pub unsafe extern "C" fn tc_object_piece_count(scene: *const TcScene, object: u32, out: *mut u32) -> TcStatus {
    run("tc_object_piece_count", || {
        check_not_null!(out);
        // SAFETY: the caller's contract.
        let n = unsafe { with_scene(scene, |s| Ok(edited(s, object)?.pieces().len() as u32))? };
        // SAFETY: checked above.
        unsafe { ptr::write(out, n) };
        Ok(())
    })
}

/// A rigid transform from 16 doubles, column-major (checked by the core: rotation + translation).
///
/// # Safety
/// `matrix` must point to 16 readable doubles.
unsafe fn matrix16(matrix: *const f64) -> Result<DMat4, Failure> {
    // SAFETY: forwarded.
    let m = unsafe { ptr::slice(matrix, 16, "matrix")? };
    let mut cols = [0.0f64; 16];
    cols.copy_from_slice(m);
    Ok(DMat4::from_cols_array(&cols))
}

/// Places piece `piece` of an object: `matrix` (16 doubles, column-major, like
/// `tc_object_set_transform`) maps the piece from where the object was baked to where it is
/// now; it must be rigid (a rotation and a translation: orthonormal within 1e-9, determinant
/// +1, last row 0 0 0 1 — hence doubles). Every piece is re-lit (shadows change) and re-solved.
/// Errors: `TC_NOT_BAKED`, `TC_NULL_POINTER`, `TC_INVALID_HANDLE` (no such piece),
/// `TC_INVALID_ARGUMENT` (not rigid, naming why), `TC_SOLVE_FAILED`; nothing changes on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_piece_transform(
    scene: *mut TcScene,
    object: u32,
    piece: u32,
    matrix: *const f64,
) -> TcStatus {
    run("tc_object_set_piece_transform", || {
        check_not_null!(matrix);
        // SAFETY: the caller's contract.
        let m = unsafe { matrix16(matrix)? };
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                edit_object(s, object, |e| e.set_piece_transform(piece as usize, m))?;
                Ok(())
            })
        }
    })
}

/// The placement of piece `piece` (16 doubles, column-major, from where the object was baked
/// to where the piece is now) into `out_matrix`.
#[no_mangle]
pub unsafe extern "C" fn tc_object_piece_transform(
    scene: *const TcScene,
    object: u32,
    piece: u32,
    out_matrix: *mut f64,
) -> TcStatus {
    run("tc_object_piece_transform", || {
        check_not_null!(out_matrix);
        // SAFETY: the caller's contract.
        let m = unsafe { with_scene(scene, |s| Ok(piece_of(edited(s, object)?, piece)?.transform()))? };
        // SAFETY: checked; 16 writable doubles (the caller's contract).
        unsafe { std::slice::from_raw_parts_mut(out_matrix, 16).copy_from_slice(&m.to_cols_array()) };
        Ok(())
    })
}

/// The surface of a piece as the C caller gets it: the boundary vertices of its tet mesh in
/// increasing index order, renumbered; the boundary faces (outward); the radiance per vertex.
struct PieceSurface {
    /// Tet-mesh vertex of each output vertex.
    vertices: Vec<u32>,
    /// Output triangles.
    triangles: Vec<[u32; 3]>,
}

impl PieceSurface {
    fn of(piece: &Piece) -> Self {
        let mesh = piece.mesh();
        let mut index = vec![u32::MAX; mesh.vertex_count()];
        for f in mesh.boundary_faces() {
            for &v in &f.vertices {
                index[v as usize] = 0;
            }
        }
        let mut vertices = Vec::new();
        for (v, slot) in index.iter_mut().enumerate() {
            if *slot == 0 {
                *slot = vertices.len() as u32;
                vertices.push(v as u32);
            }
        }
        let triangles = mesh.boundary_faces().iter().map(|f| f.vertices.map(|v| index[v as usize])).collect();
        Self { vertices, triangles }
    }
}

/// The sizes of piece `piece`'s surface mesh: `*out_vertex_count` vertices and
/// `*out_triangle_count` triangles (buffers for `tc_object_piece_mesh` need 3 of each).
#[no_mangle]
pub unsafe extern "C" fn tc_object_piece_sizes(
    scene: *const TcScene,
    object: u32,
    piece: u32,
    out_vertex_count: *mut usize,
    out_triangle_count: *mut usize,
) -> TcStatus {
    run("tc_object_piece_sizes", || {
        check_not_null!(out_vertex_count, out_triangle_count);
        // SAFETY: the caller's contract.
        let (v, t) = unsafe {
            with_scene(scene, |s| {
                let surface = PieceSurface::of(piece_of(edited(s, object)?, piece)?);
                Ok((surface.vertices.len(), surface.triangles.len()))
            })?
        };
        // SAFETY: checked above.
        unsafe {
            ptr::write(out_vertex_count, v);
            ptr::write(out_triangle_count, t);
        }
        Ok(())
    })
}

/// Copies piece `piece`'s surface into the caller's buffers: `positions` (3 floats per vertex,
/// world space where the piece is now, scene units), `triangles` (3 vertex indices per
/// triangle, counter-clockwise seen from outside: the boundary faces of the piece's tet mesh,
/// cut surfaces included) and `radiance` (3 floats per vertex, linear RGB, Lo(x, n) as
/// `tc_object_radiance`). The vertices are the boundary vertices of the piece's tet mesh in
/// increasing index order. Each `*_len` is the buffer's length in elements and must be at least
/// 3 × the count from `tc_object_piece_sizes` (`TC_BUFFER_TOO_SHORT` naming it); on failure
/// nothing is written.
#[no_mangle]
pub unsafe extern "C" fn tc_object_piece_mesh(
    scene: *const TcScene,
    object: u32,
    piece: u32,
    positions: *mut f32,
    positions_len: usize,
    triangles: *mut u32,
    triangles_len: usize,
    radiance: *mut f32,
    radiance_len: usize,
) -> TcStatus {
    run("tc_object_piece_mesh", || {
        check_not_null!(positions, triangles, radiance);
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                let p = piece_of(edited(s, object)?, piece)?;
                let surface = PieceSurface::of(p);
                let (nv, nt) = (3 * surface.vertices.len(), 3 * surface.triangles.len());
                for (name, len, needed) in [
                    ("positions_len", positions_len, nv),
                    ("triangles_len", triangles_len, nt),
                    ("radiance_len", radiance_len, nv),
                ] {
                    if len < needed {
                        return Err(Failure::new(
                            TC_BUFFER_TOO_SHORT,
                            format!("{name} = {len}, but piece {piece} of object {object} needs {needed}"),
                        ));
                    }
                }
                let m = p.transform();
                let (rest, lo) = (p.mesh().positions(), p.radiance());
                // SAFETY: checked pointers, lengths checked above (the caller's contract).
                let (pos, tri, rad) = (
                    std::slice::from_raw_parts_mut(positions, nv),
                    std::slice::from_raw_parts_mut(triangles, nt),
                    std::slice::from_raw_parts_mut(radiance, nv),
                );
                for (k, &v) in surface.vertices.iter().enumerate() {
                    let x = m.transform_point3(rest[v as usize]);
                    pos[3 * k..3 * k + 3].copy_from_slice(&[x.x as f32, x.y as f32, x.z as f32]);
                    let l = lo[v as usize];
                    rad[3 * k..3 * k + 3].copy_from_slice(&[l[0] as f32, l[1] as f32, l[2] as f32]);
                }
                for (k, t) in surface.triangles.iter().enumerate() {
                    tri[3 * k..3 * k + 3].copy_from_slice(t);
                }
                Ok(())
            })
        }
    })
}

/// What the last update of an object did (relight, material edit, paint, cut, fracture, move,
/// recombine), into `*out`. Set `out->size = sizeof(TcEditStats)` first; it is set to the
/// number of bytes written. `TC_NOT_BAKED` before the object's first update.
#[no_mangle]
pub unsafe extern "C" fn tc_object_edit_stats(scene: *const TcScene, object: u32, out: *mut TcEditStats) -> TcStatus {
    run("tc_object_edit_stats", || {
        check_not_null!(out);
        // SAFETY: checked; `size` is the first field.
        let size = unsafe { out.cast::<u32>().read() } as usize;
        let ours = std::mem::size_of::<TcEditStats>();
        if size < ours {
            return Err(Failure::invalid(format!("out->size = {size}, expected sizeof(TcEditStats) = {ours}")));
        }
        // SAFETY: the caller's contract.
        let stats = unsafe {
            with_scene(scene, |s| {
                let i = s.object_index(object)?;
                let session = s.session.as_ref().ok_or_else(not_baked)?;
                let st = session.objects[i]
                    .last
                    .as_ref()
                    .ok_or_else(|| Failure::new(TC_NOT_BAKED, format!("object {object} has not been updated since the bake")))?;
                Ok(edit_stats(st))
            })?
        };
        // SAFETY: checked above.
        unsafe { ptr::write(out, stats) };
        Ok(())
    })
}

/// The C statistics of an update.
fn edit_stats(st: &UpdateStats) -> TcEditStats {
    let count = |n: usize| n as u64;
    let cut = st.cut.as_ref();
    TcEditStats {
        size: std::mem::size_of::<TcEditStats>() as u32,
        pieces_solved: u32::try_from(st.pieces_solved).unwrap_or(u32::MAX),
        iterations: st.iterations.map(|i| u32::try_from(i).unwrap_or(u32::MAX)),
        cut: u32::from(cut.is_some()),
        rows_rebuilt: count(st.rows_rebuilt),
        tets_changed: count(st.tets_changed),
        source_ms: st.source_ms,
        assembly_ms: st.assembly_ms,
        hierarchy_ms: st.hierarchy_ms,
        solve_ms: st.solve_ms,
        total_ms: st.total_ms,
        cut_removed_tets: cut.map_or(0, |c| count(c.removed_tets)),
        cut_removed_vertices: cut.map_or(0, |c| count(c.removed_vertices)),
        cut_moved_vertices: cut.map_or(0, |c| count(c.moved_vertices)),
        cut_surface_vertices: cut.map_or(0, |c| count(c.cut_surface_vertices)),
        cut_max_distance: cut.map_or(0.0, |c| c.max_cut_distance),
        cut_min_dihedral_degrees: cut.map_or(0.0, |c| c.min_dihedral_degrees),
        cut_bound_degrees: cut.map_or(0.0, |c| c.bound_degrees),
    }
}
