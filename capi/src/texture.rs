//! Texture bakes: an object's baked radiance into the caller's image through a UV map.

use transcut_core::texture::{TextureOptions, MAX_TEXTURE_SIZE};

use super::handle::{with_scene, TcScene};
use super::ptr;
use super::status::{run_on_workers, Failure, TcStatus, TC_BUFFER_TOO_SHORT};

/// Bakes object `object`'s radiance into a `width × height` texture through a UV map, as
/// game and film pipelines use it: every texel whose centre lies in a triangle's UV image gets
/// the radiance at that surface point (TransCut samples its tet mesh's boundary solution
/// there, not a blend of the vertex colours; the other methods interpolate their vertices),
/// then each UV island is padded by `margin` texels (each ring the mean of its filled
/// neighbours), as bakers do at seams.
///
/// `triangles`: `triangle_count` × 3 vertex indices in the object's vertex order (the
/// triangles it was added with, or any others over its vertices, e.g. split at UV seams);
/// `uvs`: 6 floats per triangle, (u, v) of each corner in the triangles' order, UV (0, 0) at
/// the image's bottom-left; `uv_len` is their count in floats. `out_rgba`: the caller's
/// `width × height × 4` floats (`out_len` of them), written row by row from the TOP row, each
/// texel linear R, G, B and alpha (1 where the surface or its padding is, else 0 with RGB 0).
/// Width and height are in 1..=`TC_MAX_TEXTURE_SIZE`.
///
/// Errors: `TC_NOT_BAKED` (before a bake, after the lights changed without
/// `tc_scene_relight`, or once the object was cut or a piece moved: its surface is no longer
/// the UV map's), `TC_NULL_POINTER`, `TC_INVALID_HANDLE`, `TC_INVALID_ARGUMENT` (a size out of
/// range, `uv_len` ≠ 6 × `triangle_count`, a UV that is not finite, a vertex index beyond the
/// object's, naming it), `TC_BUFFER_TOO_SHORT` (naming both lengths). Nothing is written on
/// failure.
#[no_mangle]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn tc_object_bake_texture(
    scene: *const TcScene,
    object: u32,
    triangles: *const u32,
    triangle_count: usize,
    uvs: *const f32,
    uv_len: usize,
    width: u32,
    height: u32,
    margin: u32,
    out_rgba: *mut f32,
    out_len: usize,
) -> TcStatus {
    run_on_workers("tc_object_bake_texture", || {
        check_not_null!(out_rgba);
        // SAFETY: the caller's contract.
        let (tris, uv) = unsafe {
            (
                ptr::slice(triangles, ptr::times(triangle_count, 3, "triangle_count")?, "triangles")?,
                ptr::slice(uvs, uv_len, "uvs")?,
            )
        };
        if !(1..=MAX_TEXTURE_SIZE).contains(&width) || !(1..=MAX_TEXTURE_SIZE).contains(&height) {
            return Err(Failure::invalid(format!(
                "texture size {width}×{height}: width and height must both be in 1..={MAX_TEXTURE_SIZE}"
            )));
        }
        let needed = 4 * width as usize * height as usize;
        if out_len < needed {
            return Err(Failure::new(
                TC_BUFFER_TOO_SHORT,
                format!("out_len = {out_len} floats, but a {width}×{height} texture needs {needed} (4 per texel)"),
            ));
        }
        if uv_len != 2 * tris.len() {
            return Err(Failure::invalid(format!(
                "uv_len = {uv_len} floats for {triangle_count} triangles: 6 per triangle (u, v of each corner) are needed"
            )));
        }
        let tris: Vec<[u32; 3]> = tris.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        let uv: Vec<[f64; 2]> = uv.chunks_exact(2).map(|p| [f64::from(p[0]), f64::from(p[1])]).collect();
        let options = TextureOptions { width, height, margin };
        // SAFETY: the caller's contract.
        let image = unsafe { with_scene(scene, |s| s.texture(object, &tris, &uv, &options))? };
        // SAFETY: checked pointer, `out_len ≥ needed` floats writable (caller's contract).
        let out = unsafe { std::slice::from_raw_parts_mut(out_rgba, needed) };
        for (o, p) in out.chunks_exact_mut(4).zip(&image.rgba) {
            o.copy_from_slice(p);
        }
        Ok(())
    })
}

/// The largest width or height of `tc_object_bake_texture`.
pub const TC_MAX_TEXTURE_SIZE: u32 = 16_384;
const _: () = assert!(TC_MAX_TEXTURE_SIZE == MAX_TEXTURE_SIZE, "the ABI's bound is the core's");
