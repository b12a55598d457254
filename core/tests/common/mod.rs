//! Helpers shared by the integration tests (each test uses some of them).
#![allow(dead_code)]

use transcut::mesh::{self, TriMesh};
use transcut::optics::Medium;
use transcut::volume::{VeinParams, Veins};
use transcut::DVec3;

/// The Stanford bunny and its scale (millimetres per unit) for 60 mm across.
pub fn bunny() -> (TriMesh, f64) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/meshes/stanford-bunny.obj");
    let surface = mesh::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let (lo, hi) = surface.bounds();
    (surface, 60.0 / (hi - lo).max_element())
}

/// Veins 12 mm apart in `marble`, bent by turbulence at a 20 mm scale: 20–30× the absorption of
/// the marble and less scattering (the veined bunny of the agreement tests).
pub fn veined(marble: Medium, mm_per_unit: f64) -> Veins {
    veined_with(marble, Medium { sigma_a: [0.06, 0.09, 0.14], sigma_s_prime: [1.5, 1.8, 2.0], ..marble }, mm_per_unit)
}

/// [`veined`]'s pattern with `vein` as the vein medium.
pub fn veined_with(marble: Medium, vein: Medium, mm_per_unit: f64) -> Veins {
    let params = VeinParams {
        direction: DVec3::new(1.0, 0.4, 0.2),
        period: 12.0 / mm_per_unit,
        noise_scale: 20.0 / mm_per_unit,
        sharpness: 2.0,
        ..VeinParams::default()
    };
    Veins::new(marble, vein, 11, params).unwrap()
}

/// A closed UV sphere centred at the origin: vertex 0 is the north pole (+z), then `rings − 1`
/// rings of `segments` vertices from north to south, then the south pole; counter-clockwise seen
/// from outside (quads, triangles at the poles).
pub fn uv_sphere(radius: f64, segments: usize, rings: usize) -> TriMesh {
    let mut positions = vec![DVec3::new(0.0, 0.0, radius)];
    for j in 1..rings {
        let theta = std::f64::consts::PI * j as f64 / rings as f64;
        for k in 0..segments {
            let phi = 2.0 * std::f64::consts::PI * k as f64 / segments as f64;
            positions.push(radius * DVec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()));
        }
    }
    positions.push(DVec3::new(0.0, 0.0, -radius));
    let south = (positions.len() - 1) as u32;
    let v = |j: usize, k: usize| (1 + (j - 1) * segments + k % segments) as u32;
    let mut polygons = Vec::new();
    for k in 0..segments {
        polygons.push(vec![0, v(1, k), v(1, k + 1)]);
        for j in 1..rings - 1 {
            polygons.push(vec![v(j, k), v(j + 1, k), v(j + 1, k + 1), v(j, k + 1)]);
        }
        polygons.push(vec![v(rings - 1, k), south, v(rings - 1, k + 1)]);
    }
    TriMesh::from_polygons(positions, &polygons, &Default::default()).unwrap()
}
