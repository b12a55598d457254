//! Meshes made from nothing: the test and benchmark shapes every method is checked on.

use std::collections::HashMap;

use glam::DVec3;

use super::trimesh::TriMesh;

/// A geodesic sphere of `radius` centred at the origin: the icosahedron split `subdivisions`
/// times 4-to-1, the new vertices pushed out onto the sphere (20·4ⁿ triangles, 10·4ⁿ + 2
/// vertices; the paper's subdivision (S) cluster type, Mertens et al. 2003 §5.1). Wound
/// counter-clockwise seen from outside.
///
/// # Panics
/// When `subdivisions` > 10 (21 million triangles) or `radius` is not finite and > 0.
#[must_use]
pub fn icosphere(radius: f64, subdivisions: u32) -> TriMesh {
    assert!(subdivisions <= 10, "at most 10 subdivisions");
    assert!(radius.is_finite() && radius > 0.0, "a finite radius > 0");
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let mut positions: Vec<DVec3> = [
        [-1.0, phi, 0.0],
        [1.0, phi, 0.0],
        [-1.0, -phi, 0.0],
        [1.0, -phi, 0.0],
        [0.0, -1.0, phi],
        [0.0, 1.0, phi],
        [0.0, -1.0, -phi],
        [0.0, 1.0, -phi],
        [phi, 0.0, -1.0],
        [phi, 0.0, 1.0],
        [-phi, 0.0, -1.0],
        [-phi, 0.0, 1.0],
    ]
    .iter()
    .map(|p| DVec3::from_array(*p).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<DVec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push((positions[a as usize] + positions[b as usize]).normalize());
                (positions.len() - 1) as u32
            })
        };
        triangles = triangles
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) =
                    (midpoint(a, b, &mut positions), midpoint(b, c, &mut positions), midpoint(c, a, &mut positions));
                [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
            })
            .collect();
    }
    let positions: Vec<[f64; 3]> = positions.iter().map(|p| (*p * radius).to_array()).collect();
    let indices: Vec<u32> = triangles.iter().flatten().copied().collect();
    TriMesh::from_triangles(&positions, &indices).expect("an icosphere is a valid mesh")
}

/// The closed box [0, `size`] with each face split into a grid of quads (two triangles each),
/// `divisions` along x, y and z, wound counter-clockwise seen from outside: a block whose
/// per-vertex bake resolves that spacing on every face (a bake's radiance lives on the input
/// mesh's vertices). Vertex (i, j, k) of the surface lattice is at `size` × (i, j, k) /
/// `divisions`.
///
/// # Panics
/// When a division is 0 or a side of `size` is not finite and > 0.
#[must_use]
pub fn gridded_box(size: DVec3, divisions: [usize; 3]) -> TriMesh {
    assert!(divisions.iter().all(|&d| d > 0), "at least one division per axis");
    assert!(size.is_finite() && size.min_element() > 0.0, "finite sides > 0");
    let mut index: HashMap<[usize; 3], u32> = HashMap::new();
    let mut positions: Vec<[f64; 3]> = Vec::new();
    let mut vertex = |l: [usize; 3]| {
        *index.entry(l).or_insert_with(|| {
            positions.push(std::array::from_fn(|a| size[a] * l[a] as f64 / divisions[a] as f64));
            (positions.len() - 1) as u32
        })
    };
    let mut indices = Vec::new();
    for axis in 0..3 {
        // (u, v, axis) is right-handed, so (0, 0), (1, 0), (1, 1), (0, 1) in (u, v) faces +axis.
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        for side in [0, divisions[axis]] {
            for i in 0..divisions[u] {
                for j in 0..divisions[v] {
                    let mut quad = [(0, 0), (1, 0), (1, 1), (0, 1)].map(|(di, dj)| {
                        let mut l = [0; 3];
                        (l[axis], l[u], l[v]) = (side, i + di, j + dj);
                        vertex(l)
                    });
                    if side == 0 {
                        quad.reverse();
                    }
                    indices.extend([quad[0], quad[1], quad[2], quad[0], quad[2], quad[3]]);
                }
            }
        }
    }
    TriMesh::from_triangles(&positions, &indices).expect("a gridded box is a valid mesh")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn icosphere_counts_area_and_volume() {
        for n in 0..4 {
            let m = icosphere(2.0, n);
            assert_eq!(m.triangles().len(), 20 * 4usize.pow(n));
            assert_eq!(m.positions().len(), 10 * 4usize.pow(n) + 2);
            assert!(m.is_closed());
            assert_eq!(m.flipped_faces(), 0);
            assert!(m.positions().iter().all(|p| (p.length() - 2.0).abs() < 1e-12));
            // Inscribed: below the sphere's area and volume, approaching them.
            let (area, volume) = (m.area(), m.signed_volume());
            assert!(area < 16.0 * std::f64::consts::PI && volume > 0.0 && volume < 32.0 / 3.0 * std::f64::consts::PI);
        }
        let fine = icosphere(1.0, 5);
        assert!((fine.area() / (4.0 * std::f64::consts::PI) - 1.0).abs() < 2e-3);
    }
}
