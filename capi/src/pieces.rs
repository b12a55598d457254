//! The pieces of an edited object: their count, placement and surfaces with radiance.

use transcut_core::edit::{Editor, Piece};

use super::handle::{with_scene, TcScene};
use super::ptr;
use super::status::{run, run_on_workers, Failure, TcStatus, TC_BUFFER_TOO_SHORT, TC_INVALID_HANDLE};

/// Piece `piece` of an editor, checked.
fn piece_of(editor: &Editor, piece: u32) -> Result<&Piece, Failure> {
    let pieces = editor.pieces();
    pieces.get(piece as usize).ok_or_else(|| {
        Failure::new(TC_INVALID_HANDLE, format!("piece {piece} does not exist (the object has {} pieces)", pieces.len()))
    })
}

/// The number of pieces of an edited object, in `*out` (1 until a split or fracture).
/// `TC_NOT_BAKED` before the object's first edit (or `tc_scene_relight`).
#[no_mangle]
pub unsafe extern "C" fn tc_object_piece_count(scene: *const TcScene, object: u32, out: *mut u32) -> TcStatus {
    run("tc_object_piece_count", || {
        check_not_null!(out);
        // SAFETY: the caller's contract.
        let n = unsafe { with_scene(scene, |s| Ok(s.editor(object)?.pieces().len() as u32))? };
        // SAFETY: checked above.
        unsafe { ptr::write(out, n) };
        Ok(())
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
        let m = unsafe { with_scene(scene, |s| Ok(piece_of(s.editor(object)?, piece)?.transform()))? };
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
    run_on_workers("tc_object_piece_sizes", || {
        check_not_null!(out_vertex_count, out_triangle_count);
        // SAFETY: the caller's contract.
        let (v, t) = unsafe {
            with_scene(scene, |s| {
                let surface = PieceSurface::of(piece_of(s.editor(object)?, piece)?);
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
    run_on_workers("tc_object_piece_mesh", || {
        check_not_null!(positions, triangles, radiance);
        // SAFETY: the caller's contract.
        unsafe {
            with_scene(scene, |s| {
                let p = piece_of(s.editor(object)?, piece)?;
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
