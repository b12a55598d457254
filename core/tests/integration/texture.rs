//! Texture bakes of a session's objects (`Session::radiance_on_surface`, `Session::bake_texture`):
//! a texel at a vertex is the vertex's radiance, baked and after a relight; a uniformly lit
//! sphere textures to its closed form over the whole image; between the vertices of a coarse
//! surface TransCut's texels follow the tet solution, closer to a bake of the same surface
//! subdivided than the vertex colours' blend is; bad input is named; a cut object refuses.

use std::collections::HashMap;

use glam::DVec3;
use transcut::edit::Cutter;
use transcut::gpu::Backend;
use transcut::light::{Environment, Light};
use transcut::mesh::TriMesh;
use transcut::optics::{f_ext, Medium, UniformSphere};
use transcut::texture::{TexelSample, TextureError, TextureOptions};
use transcut::{BakeOptions, Object, Progress, Scene, Session, SessionError, TransCutOptions};

use crate::common;
use common::uv_sphere;

const SEGMENTS: usize = 48;
const RINGS: usize = 24;

fn marble() -> Medium {
    Medium { eta: 1.3, ..Medium::preset("marble").unwrap() }
}

fn sun() -> Light {
    Light::Directional { direction: DVec3::new(0.3, 0.2, -1.0).normalize(), irradiance: [3.0; 3], angular_diameter_deg: 0.0 }
}

fn session(mesh: TriMesh, lights: Vec<Light>, tets: usize) -> Session {
    let scene = Scene { objects: vec![Object::new("ball", mesh, marble(), 1.0)], lights };
    let options = BakeOptions::with_method(TransCutOptions {
        tets,
        backend: Some(Backend::Cpu),
        tolerance: 1e-9,
        ..TransCutOptions::default()
    });
    Session::bake(&scene, &options, Progress::none()).unwrap()
}

/// The UV sphere's triangles (its own layout, `common::uv_sphere`) with an equirectangular UV
/// map: u = k/segments, v = 1 − j/rings at ring j, segment k (the seam's corners at u = 1).
fn equirect(segments: usize, rings: usize) -> (Vec<[u32; 3]>, Vec<[f64; 2]>) {
    let south = (1 + (rings - 1) * segments) as u32;
    let v = |j: usize, k: usize| (1 + (j - 1) * segments + k % segments) as u32;
    let uv = |j: usize, k: f64| [k / segments as f64, 1.0 - j as f64 / rings as f64];
    let (mut tris, mut uvs) = (Vec::new(), Vec::new());
    for k in 0..segments {
        let kf = k as f64;
        tris.push([0, v(1, k), v(1, k + 1)]);
        uvs.extend([uv(0, kf + 0.5), uv(1, kf), uv(1, kf + 1.0)]);
        for j in 1..rings - 1 {
            tris.push([v(j, k), v(j + 1, k), v(j + 1, k + 1)]);
            uvs.extend([uv(j, kf), uv(j + 1, kf), uv(j + 1, kf + 1.0)]);
            tris.push([v(j, k), v(j + 1, k + 1), v(j, k + 1)]);
            uvs.extend([uv(j, kf), uv(j + 1, kf + 1.0), uv(j, kf + 1.0)]);
        }
        tris.push([v(rings - 1, k), south, v(rings - 1, k + 1)]);
        uvs.extend([uv(rings - 1, kf), uv(rings, kf + 0.5), uv(rings - 1, kf + 1.0)]);
    }
    (tris, uvs)
}

fn at(vertices: [u32; 3], bary: [f64; 3]) -> TexelSample {
    TexelSample { texel: 0, triangle: 0, vertices, bary }
}

#[test]
fn a_texel_at_a_vertex_is_the_vertex_radiance_baked_and_relit_and_a_cut_refuses() {
    let mut s = session(uv_sphere(10.0, 32, 16), vec![sun()], 8_000);
    let check = |s: &Session| {
        let vertices = s.radiance(0).unwrap().unwrap();
        let n = vertices.len() as u32;
        let samples: Vec<TexelSample> = (0..n).map(|v| at([v, (v + 1) % n, (v + 2) % n], [1.0, 0.0, 0.0])).collect();
        let texels = s.radiance_on_surface(0, &samples).unwrap().unwrap();
        for (v, (a, b)) in vertices.iter().zip(&texels).enumerate() {
            for c in 0..3 {
                assert!((a[c] - b[c]).abs() <= 1e-12 * a[c].abs().max(1e-3), "vertex {v} channel {c}: {a:?} vs {b:?}");
            }
        }
        vertices
    };
    let baked = check(&s);
    // Relit (the live editor's field): the same identity, with the new radiance.
    let other = Light::Directional {
        direction: DVec3::new(-0.5, 0.0, -1.0).normalize(),
        irradiance: [2.0; 3],
        angular_diameter_deg: 0.0,
    };
    s.relight(&[other], Progress::none()).unwrap();
    assert_ne!(check(&s), baked);
    // Cut: the surface is no longer the one the UV map covers.
    s.cut(0, &Cutter::Plane { point: DVec3::ZERO, normal: DVec3::X }, Progress::none()).unwrap();
    assert_eq!(s.radiance_on_surface(0, &[at([0, 1, 2], [1.0, 0.0, 0.0])]).unwrap(), None);
    let (tris, uvs) = equirect(32, 16);
    let e = s.bake_texture(0, &tris, &uvs, &TextureOptions::square(16)).unwrap_err();
    assert!(matches!(e, SessionError::Unsupported { .. }), "{e}");
}

#[test]
fn a_uniformly_lit_sphere_textures_to_its_closed_form_everywhere() {
    let s = session(uv_sphere(10.0, SEGMENTS, RINGS), vec![Light::Environment(Environment::Constant([1.0; 3]))], 60_000);
    let (tris, uvs) = equirect(SEGMENTS, RINGS);
    let image = s.bake_texture(0, &tris, &uvs, &TextureOptions { width: 128, height: 64, margin: 2 }).unwrap();
    let q = std::f64::consts::PI * (1.0 - f_ext(1.3));
    let expect = UniformSphere::new(marble(), 10.0, [q; 3]).unwrap().surface_radiance(1.0);
    let mut worst = 0.0_f64;
    for p in &image.rgba {
        assert_eq!(p[3], 1.0, "the equirectangular map covers every texel");
        for c in 0..3 {
            worst = worst.max((f64::from(p[c]) / expect[c] - 1.0).abs());
        }
    }
    println!("uniform sphere: worst texel {worst:.4} from the closed form {expect:?}");
    // The inscribed polyhedron's tet mesh and 60k tets: the vertices are within 1.5% too.
    assert!(worst < 0.015, "{worst}");
}

/// Every triangle split in four at its edge midpoints: the same surface, with a vertex at each
/// midpoint (numbered after the original vertices); returns the midpoint of each edge too.
fn subdivide(mesh: &TriMesh) -> (TriMesh, HashMap<(u32, u32), u32>) {
    let mut positions = mesh.positions().to_vec();
    let mut mid = HashMap::new();
    let mut polygons = Vec::new();
    for t in mesh.triangles() {
        let m: Vec<u32> = (0..3)
            .map(|k| {
                let (a, b) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
                *mid.entry((a, b)).or_insert_with(|| {
                    positions.push(0.5 * (positions[a as usize] + positions[b as usize]));
                    (positions.len() - 1) as u32
                })
            })
            .collect();
        polygons.extend([vec![t[0], m[0], m[2]], vec![t[1], m[1], m[0]], vec![t[2], m[2], m[1]], vec![m[0], m[1], m[2]]]);
    }
    (TriMesh::from_polygons(positions, &polygons, &Default::default()).unwrap(), mid)
}

#[test]
fn between_coarse_vertices_texels_follow_the_solution_not_the_vertex_blend() {
    let coarse = uv_sphere(10.0, 8, 4);
    let (fine, mid) = subdivide(&coarse);
    let s = session(coarse.clone(), vec![sun()], 40_000);
    let reference = session(fine, vec![sun()], 40_000).radiance(0).unwrap().unwrap();
    let vertices = s.radiance(0).unwrap().unwrap();
    let edges: Vec<((u32, u32), u32)> = mid.into_iter().collect();
    let samples: Vec<TexelSample> = edges.iter().map(|&((a, b), _)| at([a, b, a], [0.5, 0.5, 0.0])).collect();
    let texels = s.radiance_on_surface(0, &samples).unwrap().unwrap();
    let (mut sampled, mut blended) = (0.0, 0.0);
    for (((a, b), m), t) in edges.iter().zip(&texels) {
        let truth = reference[*m as usize];
        for c in 0..3 {
            let blend = 0.5 * (vertices[*a as usize][c] + vertices[*b as usize][c]);
            sampled += (t[c] - truth[c]).powi(2);
            blended += (blend - truth[c]).powi(2);
        }
    }
    let (sampled, blended) = (sampled.sqrt(), blended.sqrt());
    println!("edge midpoints against the subdivided bake: sampled {sampled:.4}, vertex blend {blended:.4}");
    assert!(sampled < 0.5 * blended, "sampled {sampled} vs blend {blended}");
}

#[test]
fn texture_input_errors_are_named() {
    let s = session(uv_sphere(10.0, 16, 8), vec![sun()], 4_000);
    let (tris, uvs) = equirect(16, 8);
    let ok = TextureOptions::square(32);
    assert!(s.bake_texture(0, &tris, &uvs, &ok).is_ok());
    let texture_error = |e: SessionError| match e {
        SessionError::Texture { source, .. } => source,
        other => panic!("{other}"),
    };
    let e = texture_error(s.bake_texture(0, &tris, &uvs[1..], &ok).unwrap_err());
    assert!(matches!(e, TextureError::UvCount { .. }));
    let mut nan = uvs.clone();
    nan[7] = [f64::NAN, 0.0];
    assert!(matches!(
        texture_error(s.bake_texture(0, &tris, &nan, &ok).unwrap_err()),
        TextureError::NonFiniteUv { triangle: 2, corner: 1, .. }
    ));
    let mut far = tris.clone();
    far[3][2] = 10_000;
    let e = texture_error(s.bake_texture(0, &far, &uvs, &ok).unwrap_err());
    assert!(matches!(e, TextureError::VertexOutOfRange { triangle: 3, vertex: 10_000, .. }), "{e}");
    let e = texture_error(s.bake_texture(0, &tris, &uvs, &TextureOptions { width: 0, ..ok }).unwrap_err());
    assert!(matches!(e, TextureError::InvalidSize { .. }));
    assert!(matches!(s.bake_texture(3, &tris, &uvs, &ok), Err(SessionError::NoSuchObject { index: 3, .. })));
}
