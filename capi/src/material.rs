//! Material edits of a baked object (TransCut §5.2): a region's medium changed, or a stroke
//! painted; only the matrix rows of the affected vertices are rebuilt. A radiosity bake's
//! edits re-solve the whole coupled scene: a diffuse object's albedo or emission, a translucent
//! object's whole medium.

use glam::DVec3;
use transcut_core::edit::{MediumEdit, MediumOp, PaintStroke, Region};
use transcut_core::optics::Medium;
use transcut_core::{MediumSource, Session, SessionError};

use super::convert::{medium_from, session_failure, TcMedium};
use super::handle::{update, with_scene, SceneState, TcScene};
use super::progress::Callback;
use super::ptr;
use super::status::{run, Failure, TcStatus, TC_UNSUPPORTED};

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
                let session = s.session()?;
                let baked = session.baked(i).map_err(|e| session_failure(&e))?;
                let editor = session.editor(i).map_err(|e| session_failure(&e))?;
                match (editor, baked.and_then(|b| b.transcut())) {
                    (Some(e), _) => Ok(e.original_mesh().tet_count()),
                    (None, Some(b)) => Ok(b.tet_mesh.tet_count()),
                    (None, None) => Err(Failure::new(TC_UNSUPPORTED, format!("object {object}: its method has no tetrahedra"))),
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
/// A `TC_METHOD_RADIOSITY` bake couples its objects, so it changes a translucent object's
/// medium as a whole: `TC_REGION_ALL` with `TC_MEDIUM_ASSIGN` only (the other regions and
/// operations are `TC_UNSUPPORTED`, saying so), the object becoming homogeneous with σa and σ′s
/// of the edit and its η and g, on its tets as baked; the whole scene is then re-solved (as
/// `tc_scene_relight` does), the scene's description takes the new medium (a later bake
/// agrees) and `tc_scene_radiosity_stats` describes the solve. A diffuse object has no medium
/// (`TC_INVALID_ARGUMENT`; `tc_object_edit_albedo`, `tc_object_edit_emission`).
///
/// Errors: `TC_NOT_BAKED`, `TC_INVALID_ARGUMENT` (unknown region or operation, a mask of the
/// wrong length, a negative radius, a result that is not a valid medium: the message names the
/// field or tetrahedron), `TC_UNSUPPORTED`, `TC_SOLVE_FAILED`, `TC_GPU_UNAVAILABLE`,
/// `TC_CANCELLED`. Nothing changes on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_object_edit_medium(scene: *mut TcScene, object: u32, edit: *const TcMediumEdit) -> TcStatus {
    run("tc_object_edit_medium", || {
        check_not_null!(edit);
        // SAFETY: checked; `size` is the first field.
        let size = unsafe { edit.cast::<u32>().read() } as usize;
        let ours = size_of::<TcMediumEdit>();
        if size < ours {
            return Err(Failure::invalid(format!("edit->size = {size}, expected sizeof(TcMediumEdit) = {ours}")));
        }
        // SAFETY: checked; the caller's contract.
        let (region, op, sigma_a, sigma_s) = unsafe { medium_edit(&*edit)? };
        // SAFETY: the caller's contract.
        let radiosity = unsafe { with_scene(scene, |s| Ok(s.session.as_ref().and_then(Session::radiosity).is_some()))? };
        if radiosity {
            if !matches!(region, Region::All) || op != TC_MEDIUM_ASSIGN {
                return Err(Failure::new(
                    TC_UNSUPPORTED,
                    "a radiosity bake couples its objects, so it changes a translucent object's medium as a whole: \
                     edit->region = TC_REGION_ALL with edit->op = TC_MEDIUM_ASSIGN",
                ));
            }
            // SAFETY: the caller's contract.
            return unsafe {
                coupled(scene, object, |s, i| {
                    let medium = whole_medium(s, object, i, sigma_a, sigma_s)?;
                    Ok(move |session: &mut Session, p: transcut_core::Progress<'_>| session.set_medium(i, medium, p).map(|_| ()))
                })
            };
        }
        let op = match op {
            TC_MEDIUM_ASSIGN => MediumOp::Set { sigma_a, sigma_s },
            TC_MEDIUM_SCALE => MediumOp::Scale { sigma_a, sigma_s },
            _ => MediumOp::Add { sigma_a, sigma_s },
        };
        let edit = MediumEdit { region, op };
        // SAFETY: the caller's contract.
        unsafe { update(scene, object, |session, i, p| session.edit_medium(i, &edit, p).map(|_| ())) }
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
        let points = unsafe { ptr::points(points_xyz, point_count, "points_xyz")? };
        // SAFETY: checked; the caller's contract.
        let medium = medium_from(unsafe { &*medium }, "medium")?;
        let stroke = PaintStroke { points, radius, medium, strength };
        // SAFETY: the caller's contract.
        unsafe { update(scene, object, |session, i, p| session.paint(i, &stroke, p).map(|_| ())) }
    })
}

/// Object `i`'s new medium of a radiosity medium edit: homogeneous, σa and σ′s of the edit, η
/// and g of its medium in the scene description (of its first layer, table entry or base).
fn whole_medium(s: &SceneState, object: u32, i: usize, sigma_a: [f64; 3], sigma_s: [f64; 3]) -> Result<MediumSource, Failure> {
    let o = &s.scene.objects[i];
    let Some(source) = o.medium() else {
        return Err(Failure::invalid(format!(
            "object {object} ({}) is diffuse: it has no medium (tc_object_edit_albedo, tc_object_edit_emission)",
            o.name
        )));
    };
    let (eta, g) = source.eta_and_g().ok_or_else(|| {
        Failure::new(TC_UNSUPPORTED, format!("object {object} ({}): its medium has no entries to take η and g from", o.name))
    })?;
    let medium =
        Medium::new(sigma_a, sigma_s, eta, g).map_err(|e| Failure::invalid(format!("edit->sigma_a, sigma_s_prime: {e}")))?;
    Ok(MediumSource::Homogeneous(medium))
}

/// Runs an update of a radiosity bake's coupled session on object `object` with the scene's
/// progress callback: `make` checks the input against the scene and gives the update; after
/// a success the scene's description and statistics follow the session
/// (`SceneState::coupled_updated`). `TC_NOT_BAKED` before a bake; the session's
/// `TC_UNSUPPORTED` for a bake of another method. Nothing changes on failure.
///
/// # Safety
/// `scene` as for every call.
unsafe fn coupled<F>(
    scene: *mut TcScene,
    object: u32,
    make: impl FnOnce(&SceneState, usize) -> Result<F, Failure>,
) -> Result<(), Failure>
where
    F: FnOnce(&mut Session, transcut_core::Progress<'_>) -> Result<(), SessionError>,
{
    // SAFETY: forwarded.
    unsafe {
        with_scene(scene, |s| {
            let i = s.object_index(object)?;
            s.session()?;
            let op = make(s, i)?;
            let sink = s.progress;
            Callback::with(sink.function, sink.user, |p| op(s.session_mut()?, p).map_err(|e| session_failure(&e)))?;
            s.coupled_updated(Some(i));
            Ok(())
        })
    }
}

/// Sets a diffuse object's albedo (3 doubles, linear RGB, each in [0, 1)) after a
/// `TC_METHOD_RADIOSITY` bake and re-solves the whole coupled scene from the last solution,
/// without new form factors: afterwards every object's `tc_object_radiance` is that of the
/// scene with the new albedo (as a fresh bake would give it, within the solve's tolerance),
/// the scene's description has the albedo too (a later bake agrees; unlike
/// `tc_object_set_albedo`, the results are kept) and `tc_scene_radiosity_stats` describes the
/// solve. The scene's progress callback (`tc_scene_set_progress`) sees the solve and may cancel
/// it. The caller keeps ownership of `albedo`.
///
/// Errors: `TC_NULL_POINTER`; `TC_NOT_BAKED` before a bake; `TC_UNSUPPORTED` after a bake by
/// another method (its objects are not coupled: change the albedo with `tc_object_set_albedo`
/// and bake again); `TC_INVALID_ARGUMENT` naming the object and the value for an albedo out of
/// range or NaN, or a translucent object; `TC_INVALID_HANDLE`, `TC_SOLVE_FAILED`,
/// `TC_CANCELLED`. Nothing changes on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_object_edit_albedo(scene: *mut TcScene, object: u32, albedo: *const f64) -> TcStatus {
    run("tc_object_edit_albedo", || {
        // SAFETY: the caller's contract (3 doubles).
        let albedo = unsafe { ptr::vec3(albedo, "albedo")? };
        // SAFETY: the caller's contract.
        unsafe {
            coupled(scene, object, |_, i| {
                Ok(move |session: &mut Session, p: transcut_core::Progress<'_>| session.set_albedo(i, albedo, p).map(|_| ()))
            })
        }
    })
}

/// Sets the exitance a diffuse object emits (3 doubles, linear RGB, each finite and ≥ 0; see
/// `tc_object_set_emission`) after a `TC_METHOD_RADIOSITY` bake and re-solves the whole
/// coupled scene, as `tc_object_edit_albedo` does (the same errors, for an emission negative,
/// NaN or infinite). Nothing changes on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_object_edit_emission(scene: *mut TcScene, object: u32, emission: *const f64) -> TcStatus {
    run("tc_object_edit_emission", || {
        // SAFETY: the caller's contract (3 doubles).
        let emission = unsafe { ptr::vec3(emission, "emission")? };
        // SAFETY: the caller's contract.
        unsafe {
            coupled(scene, object, |_, i| {
                Ok(move |session: &mut Session, p: transcut_core::Progress<'_>| session.set_emission(i, emission, p).map(|_| ()))
            })
        }
    })
}
