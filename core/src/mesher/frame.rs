//! The object's own frame: the lattice is laid out along the principal axes of the surface, so
//! that rotating, moving or scaling the input moves the lattice with it and the mesh (count,
//! quality) does not change.

use glam::{DMat3, DMat4, DVec3};

use crate::mesh::TriMesh;

/// A rigid frame `world = rotation · local + origin`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Frame {
    pub origin: DVec3,
    pub rotation: DMat3,
}

impl Frame {
    /// The matrix taking world coordinates to the frame's local coordinates.
    pub fn world_to_local(&self) -> DMat4 {
        DMat4::from_mat3(self.rotation.transpose()) * DMat4::from_translation(-self.origin)
    }

    /// Maps a local point back to world coordinates.
    pub fn to_world(&self, p: DVec3) -> DVec3 {
        self.rotation * p + self.origin
    }
}

/// The principal frame of a surface: origin at the area-weighted centroid, axes the
/// eigenvectors of the area-weighted second moment of the triangles (largest first). Each axis'
/// sign makes the third moment along it positive (axes with a vanishing third moment keep the
/// eigen-solver's sign); the third axis completes a right-handed frame. Symmetric objects with
/// repeated eigenvalues have no unique frame; there the frame is still valid, just not unique.
pub(crate) fn principal_frame(surface: &TriMesh) -> Frame {
    let n = surface.triangles().len();
    let mut area = 0.0;
    let mut centroid = DVec3::ZERO;
    for t in 0..n {
        let [a, b, c] = surface.triangle(t);
        let w = 0.5 * (b - a).cross(c - a).length();
        area += w;
        centroid += w * (a + b + c) / 3.0;
    }
    if !(area > 0.0) {
        return Frame { origin: DVec3::ZERO, rotation: DMat3::IDENTITY };
    }
    let centroid = centroid / area;
    // Second moment of each triangle about the centroid, exact for a linear density:
    // ∫ x xᵀ dA = (A/12) (Σ vᵢ vᵢᵀ + (Σ vᵢ)(Σ vᵢ)ᵀ) with corners relative to the centroid.
    let mut m = nalgebra::Matrix3::<f64>::zeros();
    for t in 0..n {
        let [a, b, c] = surface.triangle(t).map(|p| p - centroid);
        let w = 0.5 * (b - a).cross(c - a).length();
        let s = a + b + c;
        for p in [a, b, c, s] {
            let v = nalgebra::Vector3::new(p.x, p.y, p.z);
            m += (w / 12.0) * v * v.transpose();
        }
    }
    let eig = nalgebra::SymmetricEigen::new(m);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
    let axis = |k: usize| {
        let v = eig.eigenvectors.column(order[k]);
        DVec3::new(v[0], v[1], v[2]).normalize()
    };
    let third_moment = |u: DVec3| {
        (0..n)
            .map(|t| {
                let [a, b, c] = surface.triangle(t).map(|p| (p - centroid).dot(u));
                let w = 0.5 * {
                    let [p, q, r] = surface.triangle(t);
                    (q - p).cross(r - p).length()
                };
                w * (a * a * a + b * b * b + c * c * c)
            })
            .sum::<f64>()
    };
    let signed = |u: DVec3| if third_moment(u) < 0.0 { -u } else { u };
    let x = signed(axis(0));
    let y = signed(axis(1));
    let z = x.cross(y);
    Frame { origin: centroid, rotation: DMat3::from_cols(x, y, z) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;

    #[test]
    fn frame_follows_a_rotation_of_the_surface() {
        // An asymmetric tetrahedron-like blob: a scaled, skewed octahedron.
        let p = vec![
            DVec3::new(3.0, 0.1, 0.0),
            DVec3::new(-2.0, 0.0, 0.2),
            DVec3::new(0.0, 1.5, 0.0),
            DVec3::new(0.3, -1.0, 0.0),
            DVec3::new(0.0, 0.2, 0.7),
            DVec3::new(0.1, 0.0, -0.5),
        ];
        let faces: Vec<Vec<u32>> = vec![
            vec![0, 2, 4], vec![2, 1, 4], vec![1, 3, 4], vec![3, 0, 4],
            vec![2, 0, 5], vec![1, 2, 5], vec![3, 1, 5], vec![0, 3, 5],
        ];
        let mesh = TriMesh::from_polygons(p, &faces, &Default::default()).unwrap();
        let f0 = principal_frame(&mesh);
        let q = DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 1.1);
        let moved = mesh.transformed(&DMat4::from_rotation_translation(q, DVec3::new(5.0, -2.0, 1.0)));
        let f1 = principal_frame(&moved);
        // The local coordinates of every vertex agree.
        for (a, b) in mesh.positions().iter().zip(moved.positions()) {
            let la = f0.world_to_local().transform_point3(*a);
            let lb = f1.world_to_local().transform_point3(*b);
            assert!((la - lb).length() < 1e-9, "{la:?} vs {lb:?}");
        }
        assert!((f0.rotation.determinant() - 1.0).abs() < 1e-12);
    }
}
