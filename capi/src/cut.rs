//! Topology edits of a baked object (TransCut §5.1): cuts by a plane, a swept stroke or a
//! solid, splits, fracture, rigid moves of pieces and recombination.

use glam::{DMat4, DVec3};
use transcut_core::edit::{Cutter, SweptStroke};
use transcut_core::mesh::TriMesh;
use transcut_core::{Session, SessionError};

use super::convert::edit_failure;
use super::handle::{update, with_scene, TcScene};
use super::ptr;
use super::status::{run, Failure, TcStatus, TC_INVALID_MESH};

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
        update(scene, object, |session, i, p| {
            if keep_both { session.split(i, &cutter, p) } else { session.cut(i, &cutter, p) }.map(|_| ())
        })
    }
}

/// Runs a piece-count-changing update and writes the count to the caller's optional `out`.
///
/// # Safety
/// As `with_scene`; `out` NULL or writable (checked for alignment here, before any work).
unsafe fn counted(
    scene: *mut TcScene,
    object: u32,
    out: *mut u32,
    op: impl FnOnce(&mut Session, usize, transcut_core::Progress) -> Result<(), SessionError>,
) -> Result<(), Failure> {
    if !out.is_null() && !out.is_aligned() {
        return Err(Failure::invalid("`out_piece_count` is not aligned for its type"));
    }
    // SAFETY: forwarded.
    unsafe { update(scene, object, op)? };
    // SAFETY: forwarded.
    let n = unsafe { with_scene(scene, |s| Ok(s.editor(object)?.pieces().len()))? };
    if !out.is_null() {
        // SAFETY: checked above.
        unsafe { ptr::write(out, u32::try_from(n).unwrap_or(u32::MAX)) };
    }
    Ok(())
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
        let (origins, directions) = unsafe {
            (ptr::points(origins_xyz, ray_count, "origins_xyz")?, ptr::points(directions_xyz, ray_count, "directions_xyz")?)
        };
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
        unsafe { counted(scene, object, out_piece_count, |session, i, p| session.fracture(i, p).map(|_| ())) }
    })
}

/// Welds the pieces of an object whose boundaries touch again (faces coinciding within 1e-6
/// scene units, where the pieces are now) into one piece each and re-solves them; the new
/// piece count goes to `*out_piece_count` (nullable). Errors as `tc_object_fracture`.
#[no_mangle]
pub unsafe extern "C" fn tc_object_recombine(scene: *mut TcScene, object: u32, out_piece_count: *mut u32) -> TcStatus {
    run("tc_object_recombine", || {
        // SAFETY: the caller's contract.
        unsafe { counted(scene, object, out_piece_count, |session, i, p| session.recombine(i, p).map(|_| ())) }
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
        unsafe { update(scene, object, |session, i, p| session.set_piece_transform(i, piece as usize, m, p).map(|_| ())) }
    })
}
