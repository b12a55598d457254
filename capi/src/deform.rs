//! Deforming a baked object: new vertex positions, the same topology (an animated mesh, frame
//! by frame), for methods that can (`TC_METHOD_HIERARCHICAL_DIPOLE`).

use super::handle::{update, with_scene, TcScene};
use super::ptr;
use super::status::{run, Failure, TcStatus, TC_NOT_BAKED};

/// Moves the vertices of a baked object to `xyz` (3 floats per vertex, object space, the
/// vertices in the order the object was given, `vertex_count` = `tc_object_vertex_count`; the
/// triangles stay) and updates its radiance under the scene's lights: the incremental
/// counterpart of a new bake for each frame of an animation. The object's transform stays.
/// Afterwards `tc_object_radiance` returns the new radiance, `tc_object_edit_stats` what the
/// update did and `tc_object_dipole_stats` the hierarchy's split. The scene's progress
/// callback (`tc_scene_set_progress`) is called and may cancel.
///
/// Errors: `TC_NOT_BAKED`, `TC_NULL_POINTER`, `TC_INVALID_HANDLE` (no such object),
/// `TC_INVALID_ARGUMENT` (a vertex count other than the object's, non-finite coordinates),
/// `TC_UNSUPPORTED` (the object's method cannot deform: TransCut), `TC_CANCELLED`. Nothing
/// changes on failure.
#[no_mangle]
pub unsafe extern "C" fn tc_object_set_positions(
    scene: *mut TcScene,
    object: u32,
    xyz: *const f32,
    vertex_count: usize,
) -> TcStatus {
    run("tc_object_set_positions", || {
        let floats = ptr::times(vertex_count, 3, "vertex_count")?;
        check_not_null!(xyz);
        // SAFETY: the caller's contract (3 × vertex_count readable floats).
        let values = unsafe { ptr::slice(xyz, floats, "xyz")? };
        let positions: Vec<[f64; 3]> = values.chunks_exact(3).map(|p| [p[0], p[1], p[2]].map(f64::from)).collect();
        // SAFETY: the caller's contract.
        unsafe { update(scene, object, |session, i, p| session.set_positions(i, &positions, p).map(|_| ())) }
    })
}

/// What the hierarchical dipole's last update of an object did (`tc_object_dipole_stats`).
/// Set `size = sizeof(TcDipoleStats)` first.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcDipoleStats {
    /// The bytes of the struct the caller has (set it to `sizeof(TcDipoleStats)`).
    pub size: u32,
    /// Emitting triangles.
    pub triangles: u64,
    /// Receiving points.
    pub receivers: u64,
    /// Nodes of both cluster trees.
    pub nodes: u64,
    /// Links the update used (far and near).
    pub links: u64,
    /// Of them, leaf pairs with a form factor over the triangle (analytic, or the 7-point rule).
    pub near_links: u64,
    /// Links the update made, near ones with their form factor evaluated (0 for a relight with
    /// links kept).
    pub form_factors: u64,
    /// Receiver subtrees still linked to an older pose (incremental mode with a budget).
    pub stale_tasks: u64,
    /// Refitting the trees after the deformation.
    pub refit_ms: f64,
    /// Traversing the trees and evaluating form factors.
    pub link_ms: f64,
    /// Pulling the irradiance and gathering over the links.
    pub gather_ms: f64,
    /// Pushing down the receiver tree.
    pub push_ms: f64,
}

/// Writes what the hierarchical dipole's last update (the bake, a relight or
/// `tc_object_set_positions`) of an object did into `*out`; set `out->size =
/// sizeof(TcDipoleStats)` first (another size is `TC_INVALID_ARGUMENT`).
///
/// Errors: `TC_NULL_POINTER`, `TC_INVALID_HANDLE`, `TC_NOT_BAKED` (before a bake), and
/// `TC_UNSUPPORTED` for an object another method baked.
#[no_mangle]
pub unsafe extern "C" fn tc_object_dipole_stats(scene: *const TcScene, object: u32, out: *mut TcDipoleStats) -> TcStatus {
    run("tc_object_dipole_stats", || {
        check_not_null!(out);
        if !out.is_aligned() {
            return Err(Failure::invalid("`out` is not aligned for TcDipoleStats"));
        }
        // SAFETY: checked; `size` is the first field.
        let size = unsafe { out.cast::<u32>().read() } as usize;
        let ours = size_of::<TcDipoleStats>();
        if size != ours {
            return Err(Failure::invalid(format!("out->size = {size}, expected sizeof(TcDipoleStats) = {ours}")));
        }
        // SAFETY: the caller's contract.
        let stats = unsafe {
            with_scene(scene, |s| {
                let i = s.object_index(object)?;
                let session = s.session()?;
                let failure = |e: transcut_core::SessionError| Failure::new(TC_NOT_BAKED, e.to_string());
                let st = match (session.dipole(i).map_err(failure)?, session.baked(i).map_err(failure)?) {
                    (Some(live), _) => live.state().stats,
                    (None, Some(bake)) => match bake.dipole() {
                        Some(state) => state.stats,
                        None => {
                            return Err(Failure::new(
                                super::status::TC_UNSUPPORTED,
                                format!("object {object} was baked by the {} method, not hierarchical-dipole", bake.method()),
                            ))
                        }
                    },
                    (None, None) => {
                        return Err(Failure::new(
                            super::status::TC_UNSUPPORTED,
                            format!("object {object} was not baked by the hierarchical-dipole method"),
                        ))
                    }
                };
                let n = |x: usize| x as u64;
                Ok(TcDipoleStats {
                    size: ours as u32,
                    triangles: n(st.triangles),
                    receivers: n(st.receivers),
                    nodes: n(st.nodes),
                    links: n(st.links),
                    near_links: n(st.near_links),
                    form_factors: n(st.form_factors),
                    stale_tasks: n(st.stale_tasks),
                    refit_ms: st.refit_ms,
                    link_ms: st.link_ms,
                    gather_ms: st.gather_ms,
                    push_ms: st.push_ms,
                })
            })?
        };
        // SAFETY: checked non-NULL and aligned; the caller's struct has `size` = ours bytes.
        unsafe { ptr::write(out, stats) };
        Ok(())
    })
}
