//! Helpers shared by the integration tests.

use transcut::mesh::TriMesh;
use transcut::DVec3;

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
