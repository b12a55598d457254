//! What the last update of an object did.

use transcut_core::edit::UpdateStats;

use super::convert::session_failure;
use super::handle::{with_scene, TcScene};
use super::ptr;
use super::status::{run, Failure, TcStatus, TC_NOT_BAKED};

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

/// What the last update of an object did (relight, material edit, paint, cut, fracture, move,
/// recombine), into `*out`. Set `out->size = sizeof(TcEditStats)` first; it is set to the
/// number of bytes written. `TC_NOT_BAKED` before the object's first update.
#[no_mangle]
pub unsafe extern "C" fn tc_object_edit_stats(scene: *const TcScene, object: u32, out: *mut TcEditStats) -> TcStatus {
    run("tc_object_edit_stats", || {
        check_not_null!(out);
        // SAFETY: checked; `size` is the first field.
        let size = unsafe { out.cast::<u32>().read() } as usize;
        let ours = size_of::<TcEditStats>();
        if size < ours {
            return Err(Failure::invalid(format!("out->size = {size}, expected sizeof(TcEditStats) = {ours}")));
        }
        // SAFETY: the caller's contract.
        let stats = unsafe {
            with_scene(scene, |s| {
                let i = s.object_index(object)?;
                let last = s.session()?.last_update(i).map_err(|e| session_failure(&e))?;
                let st = last
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
        size: size_of::<TcEditStats>() as u32,
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
