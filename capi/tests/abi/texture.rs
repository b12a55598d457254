//! `tc_object_bake_texture`: a uniformly lit sphere's texture is its closed form, rows from the
//! top; the pole's texels at the pole; every misuse is named and writes nothing.

use std::ptr;

use transcut_core::optics::{f_ext, Medium, UniformSphere};

use super::abi::*;
use super::common::*;

const SEGMENTS: u32 = 32;
const RINGS: u32 = 16;

/// The UV of each corner of `Mesh::uv_sphere`'s triangles (its order): u = k/segments,
/// v = 1 − j/rings.
fn equirect() -> Vec<f32> {
    let uv = |j: u32, k: f32| [k / SEGMENTS as f32, 1.0 - j as f32 / RINGS as f32];
    let mut uvs = Vec::new();
    for k in 0..SEGMENTS {
        let k = k as f32;
        uvs.extend([uv(0, k + 0.5), uv(1, k), uv(1, k + 1.0)].concat());
        for j in 1..RINGS - 1 {
            uvs.extend([uv(j, k), uv(j + 1, k), uv(j + 1, k + 1.0)].concat());
            uvs.extend([uv(j, k), uv(j + 1, k + 1.0), uv(j, k + 1.0)].concat());
        }
        uvs.extend([uv(RINGS - 1, k), uv(RINGS, k + 0.5), uv(RINGS - 1, k + 1.0)].concat());
    }
    uvs
}

#[test]
fn a_uniformly_lit_sphere_bakes_to_its_closed_form_texture() {
    let mesh = Mesh::uv_sphere(10.0, SEGMENTS, RINGS);
    let s = scene();
    let ball = add(s, &mesh);
    let marble = TcMedium { sigma_a: [0.0021, 0.0041, 0.0071], sigma_s_prime: [2.19, 2.62, 3.00], eta: 1.3, g: 0.0 };
    let uvs = equirect();
    let triangles = mesh.indices.len() / 3;
    let (w, h) = (64u32, 32u32);
    let mut out = vec![-1.0f32; 4 * (w * h) as usize];
    // SAFETY: valid pointers and lengths.
    unsafe {
        ok(tc_object_set_medium(s, ball, &marble), "medium");
        ok(tc_scene_add_environment(s, [1.0; 3].as_ptr()), "sky");
        let texture = |out: &mut [f32]| {
            tc_object_bake_texture(
                s,
                ball,
                mesh.indices.as_ptr(),
                triangles,
                uvs.as_ptr(),
                uvs.len(),
                w,
                h,
                2,
                out.as_mut_ptr(),
                out.len(),
            )
        };
        fails(texture(&mut out), TC_NOT_BAKED, &["tc_scene_bake"]);
        ok(tc_scene_bake(s, &options(30_000), None, ptr::null_mut()), "bake");
        ok(texture(&mut out), "texture");
    }
    let q = std::f64::consts::PI * (1.0 - f_ext(1.3));
    let medium = Medium::new(marble.sigma_a, marble.sigma_s_prime, 1.3, 0.0).unwrap();
    let expect = UniformSphere::new(medium, 10.0, [q; 3]).unwrap().surface_radiance(1.0);
    for (i, texel) in out.chunks_exact(4).enumerate() {
        assert_eq!(texel[3], 1.0, "texel {i}: the equirectangular map covers the image");
        for c in 0..3 {
            let e = (f64::from(texel[c]) / expect[c] - 1.0).abs();
            assert!(e < 0.02, "texel {i} channel {c}: {} vs {}", texel[c], expect[c]);
        }
    }
    destroy(s);
}

#[test]
fn texture_misuse_is_named_and_writes_nothing() {
    let mesh = Mesh::uv_sphere(10.0, SEGMENTS, RINGS);
    let s = scene();
    let ball = add(s, &mesh);
    let uvs = equirect();
    let n = mesh.indices.len() / 3;
    let mut out = vec![-1.0f32; 4 * 16 * 16];
    // SAFETY: valid pointers, except where a test passes NULL on purpose.
    unsafe {
        ok(tc_object_set_medium_preset(s, ball, cstr(c"marble")), "preset");
        ok(tc_scene_add_sun(s, [0.0, 0.0, -1.0].as_ptr(), [3.0; 3].as_ptr(), 0.0), "sun");
        ok(tc_scene_bake(s, &options(4_000), None, ptr::null_mut()), "bake");
        let idx = mesh.indices.as_ptr();
        let bake = |tris: *const u32, n: usize, uv: *const f32, uv_len: usize, w: u32, out: *mut f32, out_len: usize| {
            tc_object_bake_texture(s, ball, tris, n, uv, uv_len, w, 16, 1, out, out_len)
        };
        let o = out.as_mut_ptr();
        fails(bake(idx, n, uvs.as_ptr(), uvs.len(), 16, ptr::null_mut(), 1024), TC_NULL_POINTER, &["out_rgba"]);
        fails(bake(ptr::null(), n, uvs.as_ptr(), uvs.len(), 16, o, 1024), TC_NULL_POINTER, &["triangles"]);
        fails(bake(idx, n, uvs.as_ptr(), uvs.len(), 16, o, 1023), TC_BUFFER_TOO_SHORT, &["1023", "1024"]);
        fails(bake(idx, n, uvs.as_ptr(), uvs.len() - 2, 16, o, 1024), TC_INVALID_ARGUMENT, &["uv_len", "6 per triangle"]);
        fails(bake(idx, n, uvs.as_ptr(), uvs.len(), 0, o, 1024), TC_INVALID_ARGUMENT, &["texture size 0×16"]);
        let mut nan = uvs.clone();
        nan[9] = f32::NAN;
        fails(bake(idx, n, nan.as_ptr(), nan.len(), 16, o, 1024), TC_INVALID_ARGUMENT, &["UV of triangle 1 corner 1"]);
        let mut far = mesh.indices.clone();
        far[5] = 9_999;
        fails(bake(far.as_ptr(), n, uvs.as_ptr(), uvs.len(), 16, o, 1024), TC_INVALID_ARGUMENT, &["vertex 9999"]);
        fails(
            tc_object_bake_texture(s, 7, idx, n, uvs.as_ptr(), uvs.len(), 16, 16, 1, o, 1024),
            TC_INVALID_HANDLE,
            &["object 7"],
        );
        assert!(out.iter().all(|&x| x == -1.0), "a failed call wrote into the buffer");
        ok(bake(idx, n, uvs.as_ptr(), uvs.len(), 16, o, 1024), "texture");
        assert!(out.iter().all(|&x| x >= 0.0));
        // A cut object's surface is not the UV map's.
        ok(tc_object_cut_plane(s, ball, [0.0; 3].as_ptr(), [1.0, 0.0, 0.0].as_ptr(), 0), "cut");
        fails(bake(idx, n, uvs.as_ptr(), uvs.len(), 16, o, 1024), TC_NOT_BAKED, &["cut"]);
    }
    destroy(s);
}
