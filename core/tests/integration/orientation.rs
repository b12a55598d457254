//! Inconsistently wound input: a mesh with some or all triangles reversed bakes exactly like the
//! well-wound one (every `TriMesh` is oriented when it is built), the bake says how many it
//! reversed, and a surface that cannot be oriented is refused by name.

use glam::{DMat4, DVec3};
use transcut::light::Light;
use transcut::mesh::{MeshError, TriMesh};
use transcut::optics::Medium;
use transcut::{bake, BakeOptions, Object, Scene, TransCutOptions};

use crate::common;
use common::uv_sphere;

/// The indices `0..n` in an order fixed by a small xorshift generator (Fisher–Yates).
fn shuffled(n: usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..n).collect();
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    for i in (1..n).rev() {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        order.swap(i, (state % (i as u64 + 1)) as usize);
    }
    order
}

/// `mesh` rebuilt from flat arrays with the triangles at `reverse` wound the other way (the
/// last two corners swapped, the way a flipped normal is exported).
fn with_reversed(mesh: &TriMesh, reverse: &[usize]) -> TriMesh {
    let mut triangles = mesh.triangles().to_vec();
    for &t in reverse {
        triangles[t].swap(1, 2);
    }
    let positions: Vec<[f64; 3]> = mesh.positions().iter().map(|p| p.to_array()).collect();
    TriMesh::from_triangles(&positions, &triangles.concat()).unwrap()
}

fn sun_lit(mesh: TriMesh) -> Scene {
    let marble = Medium::preset("marble").unwrap();
    Scene {
        objects: vec![Object::new("sphere", mesh, marble, 1.0)],
        lights: vec![Light::Directional {
            direction: DVec3::new(0.3, -0.2, -1.0),
            irradiance: [3.0; 3],
            angular_diameter_deg: 0.0,
        }],
    }
}

fn options() -> BakeOptions {
    BakeOptions {
        method: TransCutOptions { tets: 6_000, tolerance: 1e-10, ..TransCutOptions::default() }.into(),
        ..BakeOptions::default()
    }
}

#[test]
fn partly_and_fully_reversed_spheres_bake_to_the_well_wound_radiance() {
    let good = with_reversed(&uv_sphere(10.0, 48, 24), &[]);
    assert_eq!(good.flipped_faces(), 0);
    let count = good.triangles().len();
    let reference = bake(&sun_lit(good.clone()), &options()).unwrap();
    let reference = &reference.objects[0];
    assert_eq!(reference.stats.flipped_faces, 0);
    let scale = reference.radiance.iter().flatten().fold(0.0f64, |m, &x| m.max(x));
    assert!(scale > 0.1, "the lit side is lit: {scale}");
    let order = shuffled(count);
    for percent in [2, 20, 33, 50, 100] {
        let reversed = count * percent / 100;
        let bad = with_reversed(&good, &order[..reversed]);
        assert_eq!(bad.flipped_faces(), reversed, "{percent}%");
        assert_eq!(bad.triangles(), good.triangles(), "{percent}%: the winding is restored exactly");
        let baked = bake(&sun_lit(bad), &options()).unwrap();
        let baked = &baked.objects[0];
        assert_eq!(baked.stats.flipped_faces, reversed);
        let (a, b) = (baked.transcut().unwrap(), reference.transcut().unwrap());
        assert_eq!(a.tet_mesh.tets(), b.tet_mesh.tets(), "{percent}%: the same tets");
        assert_eq!(a.tet_mesh.positions(), b.tet_mesh.positions(), "{percent}%: the same tets");
        let worst = baked
            .radiance
            .iter()
            .zip(&reference.radiance)
            .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).abs()))
            .fold(0.0, f64::max);
        assert!(worst <= 1e-9 * scale, "{percent}% reversed: radiance differs by {worst:e}");
    }
}

#[test]
fn a_mirrored_object_keeps_its_flipped_count_and_bakes_like_the_original() {
    // A negative scale reverses every triangle in world space; the transform itself rewinds them,
    // so the count is the mesh's own.
    let good = with_reversed(&uv_sphere(10.0, 48, 24), &[]);
    let bad = with_reversed(&good, &shuffled(good.triangles().len())[..100]);
    let mirror = DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0));
    let world = bad.transformed(&mirror);
    assert_eq!(world.flipped_faces(), 100);
    assert!(world.signed_volume() > 0.0);
}

/// A Möbius strip of `n` quads: a band whose ends are joined with a half twist.
fn moebius(n: usize) -> (Vec<[f64; 3]>, Vec<u32>) {
    let mut positions = Vec::new();
    for i in 0..n {
        let a = std::f64::consts::TAU * i as f64 / n as f64;
        let radial = DVec3::new(a.cos(), a.sin(), 0.0);
        let across = 0.3 * ((0.5 * a).cos() * radial + (0.5 * a).sin() * DVec3::Z);
        positions.push((3.0 * radial + across).to_array());
        positions.push((3.0 * radial - across).to_array());
    }
    let mut indices = Vec::new();
    for i in 0..n as u32 {
        let (a, b) = (2 * i, 2 * i + 1);
        // After a full turn the band's top edge meets the bottom of the first quad.
        let (c, d) = if i + 1 == n as u32 { (1, 0) } else { (2 * i + 2, 2 * i + 3) };
        indices.extend([a, b, d, a, d, c]);
    }
    (positions, indices)
}

#[test]
fn a_moebius_strip_is_refused_as_not_orientable() {
    let (positions, indices) = moebius(40);
    let err = TriMesh::from_triangles(&positions, &indices).unwrap_err();
    assert!(matches!(err, MeshError::NonOrientable { .. }), "{err}");
    let text = err.to_string();
    assert!(text.contains("not orientable") && text.contains("Möbius"), "{text}");
    // The edge it names is an edge of the strip: both ends are strip vertices.
    let MeshError::NonOrientable { from, to, .. } = err else { unreachable!() };
    for end in [from, to] {
        assert!(positions.iter().any(|p| DVec3::from_array(*p).distance(DVec3::from_array(end)) < 1e-12), "{end:?}");
    }
    // The same band without the twist is an open ring and is accepted unchanged.
    let (mut positions, mut indices) = moebius(40);
    let last = indices.len() - 6;
    indices[last..].copy_from_slice(&[78, 79, 1, 78, 1, 0]);
    positions.truncate(80);
    let ring = TriMesh::from_triangles(&positions, &indices).unwrap();
    assert_eq!(ring.flipped_faces(), 0);
}

/// The test meshes are wound consistently (closed ones outwards) already: orientation reverses
/// nothing, so every bake of them is exactly what it was before meshes were oriented.
#[test]
fn the_test_meshes_need_no_flips() {
    let dir = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes");
    let mut names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().path()).collect();
    names.retain(|p| p.extension().is_some_and(|x| x == "obj"));
    names.sort();
    assert!(names.len() >= 8, "{names:?}");
    for path in names {
        let mesh = transcut::mesh::load(&path).unwrap();
        assert_eq!(mesh.flipped_faces(), 0, "{}", path.display());
    }
}
