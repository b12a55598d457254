//! The object's own frame: the lattice is laid out along the principal axes of the surface, so
//! that rotating, moving or scaling the input moves the lattice with it and the mesh (count,
//! quality) does not change.
//!
//! Symmetric objects (spheres, cubes, boxes, anything with a mirror plane) have no unique
//! principal frame: repeated eigenvalues leave the axes free within their eigenspace, and a
//! vanishing third moment leaves an axis' sign free. Left to the eigen-solver, those choices
//! come from rounding noise, so moving such an object changed its lattice. [`principal_frame`]
//! resolves them deterministically from the world axes instead, so that a translated copy gets
//! exactly the same mesh (moved) and an axis-aligned symmetric object gets an axis-aligned one.

use glam::{DMat3, DMat4, DVec3};

use crate::mesh::TriMesh;

/// Two eigenvalues of the second moment whose difference is at most this fraction of the
/// largest are treated as equal (their eigenvectors are not determined by the shape). Rounding
/// noise is ~10⁻¹³ relative even for objects far from the origin; real shapes that differ from
/// a symmetric one by less than this are meshed as if they were symmetric, which is harmless.
const DEGENERATE_EIGENVALUE_TOL: f64 = 1e-6;

/// A third moment `∫ (x·u)³ dA` smaller than this fraction of `∫ |x·u|³ dA` does not decide the
/// sign of the axis `u` (it vanishes for a shape symmetric under `u → −u`).
const THIRD_MOMENT_TOL: f64 = 1e-6;

/// Components (or projections) that differ by less than this are treated as tied; the lower world
/// axis index wins.
const TIE_TOL: f64 = 1e-9;

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
    pub fn to_world(self, p: DVec3) -> DVec3 {
        self.rotation * p + self.origin
    }
}

/// The principal frame of a surface.
///
/// * Origin: the area-weighted centroid `c = (1/A) ∫ x dA`.
/// * Axes: the eigenvectors of the second moment `M = ∫ (x − c)(x − c)ᵀ dA`, largest eigenvalue
///   first. Eigenvalues within [`DEGENERATE_EIGENVALUE_TOL`] (relative to the largest) form one
///   eigenspace, whose basis is snapped to the world axes: the world axes are projected onto it
///   and orthonormalised (Gram–Schmidt), taking at each step the world axis with the largest
///   remaining projection (ties to the lower index). A fully degenerate `M` (sphere, cube) gives
///   the world axes themselves.
/// * Signs: each axis `u` points where the third moment `T(u) = ∫ ((x − c)·u)³ dA` is positive
///   when `|T(u)|` exceeds [`THIRD_MOMENT_TOL`] of `∫ |(x − c)·u|³ dA`; otherwise the axis' largest
///   world component (ties to the lower index) is made positive.
/// * Handedness: if the three axes are left-handed, the axis whose sign was least determined (a
///   world-alignment choice before a third-moment one, the last before the first, then the
///   smallest relative third moment) is flipped.
///
/// Every choice depends on the shape and on the world axes only, never on rounding noise, so the
/// frame follows a translation exactly and a rotation wherever the shape determines its axes.
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
    let lambda = order.map(|k| eig.eigenvalues[k]);
    let vectors = order.map(|k| {
        let v = eig.eigenvectors.column(k);
        DVec3::new(v[0], v[1], v[2]).normalize()
    });
    let axes = snap_degenerate_axes(lambda, vectors);

    // Signs, then handedness.
    let mut axes = axes;
    let mut confidence = [0.0; 3];
    for (k, u) in axes.iter_mut().enumerate() {
        let (t, scale) = third_moment(surface, centroid, *u);
        if t.abs() > THIRD_MOMENT_TOL * scale {
            confidence[k] = t.abs() / scale;
            if t < 0.0 {
                *u = -*u;
            }
        } else if !largest_component_is_positive(*u) {
            *u = -*u;
        }
    }
    if axes[0].cross(axes[1]).dot(axes[2]) < 0.0 {
        // The least determined sign gives way; among equals, the last axis.
        let mut k = 2;
        for j in (0..2).rev() {
            if confidence[j] < confidence[k] {
                k = j;
            }
        }
        axes[k] = -axes[k];
    }
    // Exactly orthonormal and right-handed.
    let x = axes[0].normalize();
    let y = (axes[1] - x * x.dot(axes[1])).normalize();
    let z = x.cross(y);
    debug_assert!(z.dot(axes[2]) > 0.999);
    Frame { origin: centroid, rotation: DMat3::from_cols(x, y, z) }
}

/// Replaces the eigenvectors of every group of equal eigenvalues (`lambda` sorted, largest first)
/// by the world axes projected onto their eigenspace and orthonormalised; see [`principal_frame`].
fn snap_degenerate_axes(lambda: [f64; 3], vectors: [DVec3; 3]) -> [DVec3; 3] {
    let tol = DEGENERATE_EIGENVALUE_TOL * lambda[0].abs();
    let mut axes = vectors;
    let mut start = 0;
    while start < 3 {
        let mut end = start + 1;
        while end < 3 && lambda[end - 1] - lambda[end] <= tol {
            end += 1;
        }
        if end - start == 3 {
            return [DVec3::X, DVec3::Y, DVec3::Z];
        }
        if end - start > 1 {
            let basis = &vectors[start..end];
            let project = |v: DVec3| basis.iter().map(|b| *b * b.dot(v)).sum::<DVec3>();
            let mut used = [false; 3];
            for slot in start..end {
                let mut best: Option<(usize, DVec3)> = None;
                for (i, e) in [DVec3::X, DVec3::Y, DVec3::Z].into_iter().enumerate() {
                    if used[i] {
                        continue;
                    }
                    let mut r = project(e);
                    for chosen in &axes[start..slot] {
                        r -= *chosen * chosen.dot(r);
                    }
                    if best.is_none_or(|(_, b)| r.length() > b.length() + TIE_TOL) {
                        best = Some((i, r));
                    }
                }
                // The remaining projections of the three world axes have squared lengths summing
                // to the remaining dimension (≥ 1), so the best is at least 1/√3 long.
                let (i, r) = best.expect("three world axes, at most two used");
                used[i] = true;
                axes[slot] = r.normalize();
            }
        }
        start = end;
    }
    axes
}

/// `(∫ (x·u)³ dA, ∫ |x·u|³ dA)` over the surface, `x` relative to `centroid`. For a linear
/// function `f` with corner values `a, b, c` on a triangle of area `A`,
/// `∫ f³ dA = (A/10) h₃(a, b, c)`, `h₃` the sum of all ten cubic monomials; the same formula on
/// `|a|, |b|, |c|` bounds `∫ |f|³ dA` from above and serves as the scale.
fn third_moment(surface: &TriMesh, centroid: DVec3, u: DVec3) -> (f64, f64) {
    let h3 = |a: f64, b: f64, c: f64| {
        a * a * a + b * b * b + c * c * c + a * a * (b + c) + b * b * (a + c) + c * c * (a + b) + a * b * c
    };
    let mut sum = 0.0;
    let mut scale = 0.0;
    for t in 0..surface.triangles().len() {
        let [p, q, r] = surface.triangle(t);
        let w = 0.5 * (q - p).cross(r - p).length() / 10.0;
        let [a, b, c] = [p, q, r].map(|v| (v - centroid).dot(u));
        sum += w * h3(a, b, c);
        scale += w * h3(a.abs(), b.abs(), c.abs());
    }
    (sum, scale)
}

/// Whether the largest-magnitude component of `u` (the lowest index among ties) is positive.
fn largest_component_is_positive(u: DVec3) -> bool {
    let c = u.to_array();
    let mut k = 0;
    for i in 1..3 {
        if c[i].abs() > c[k].abs() + TIE_TOL {
            k = i;
        }
    }
    c[k] > 0.0
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesher::{tetrahedralize, MesherOptions};
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
            vec![0, 2, 4],
            vec![2, 1, 4],
            vec![1, 3, 4],
            vec![3, 0, 4],
            vec![2, 0, 5],
            vec![1, 2, 5],
            vec![3, 1, 5],
            vec![0, 3, 5],
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

    /// An axis-aligned box of the given full extents centred at the origin, outward quads.
    fn box_mesh(extent: DVec3) -> TriMesh {
        let h = extent / 2.0;
        let p: Vec<DVec3> = (0..8)
            .map(|i| {
                DVec3::new(
                    if i & 1 == 0 { -h.x } else { h.x },
                    if i & 2 == 0 { -h.y } else { h.y },
                    if i & 4 == 0 { -h.z } else { h.z },
                )
            })
            .collect();
        let faces: Vec<Vec<u32>> = vec![
            vec![0, 2, 3, 1],
            vec![4, 5, 7, 6], // −z, +z
            vec![0, 1, 5, 4],
            vec![2, 6, 7, 3], // −y, +y
            vec![0, 4, 6, 2],
            vec![1, 3, 7, 5], // −x, +x
        ];
        let mesh = TriMesh::from_polygons(p, &faces, &Default::default()).unwrap();
        assert!(mesh.signed_volume() > 0.0);
        mesh
    }

    const OFFSETS: [DVec3; 4] = [
        DVec3::ZERO,
        DVec3::new(1000.0, -250.0, 37.5),
        DVec3::new(-0.1234, 0.5678, -0.9012),
        DVec3::new(12_345.678, 0.0, -9_876.5),
    ];

    /// Meshes `surface` moved by each offset: the frame's rotation is the same to rounding, its
    /// origin moves with the offset, and the tet meshes are the same mesh moved (same counts, same
    /// vertices in the same order). Returns the frame and tet count of the unmoved surface.
    fn translation_invariant(name: &str, surface: &TriMesh, tets: usize) -> (Frame, usize) {
        let size = {
            let (lo, hi) = surface.bounds();
            (hi - lo).length()
        };
        let f0 = principal_frame(surface);
        let m0 = tetrahedralize(surface, &MesherOptions::with_tets(tets)).unwrap();
        for offset in OFFSETS {
            let moved = surface.transformed(&DMat4::from_translation(offset));
            let f = principal_frame(&moved);
            let rounding = 1e-12 * (1.0 + offset.length() / size);
            assert!(f.rotation.abs_diff_eq(f0.rotation, rounding), "{name} + {offset}: {:?} vs {:?}", f.rotation, f0.rotation);
            assert!((f.origin - offset - f0.origin).length() <= rounding * size, "{name} + {offset}: origin {}", f.origin);
            let m = tetrahedralize(&moved, &MesherOptions::with_tets(tets)).unwrap();
            assert_eq!((m.tet_count(), m.vertex_count()), (m0.tet_count(), m0.vertex_count()), "{name} + {offset}");
            let worst = m.positions().iter().zip(m0.positions()).map(|(a, b)| (*a - offset - *b).length()).fold(0.0, f64::max);
            assert!(worst <= 1e-9 * size * (1.0 + offset.length() / size), "{name} + {offset}: vertices differ by {worst:.3e}");
        }
        assert!((f0.rotation.determinant() - 1.0).abs() < 1e-12);
        (f0, m0.tet_count())
    }

    /// Whether every axis of the frame is a world axis (either sign).
    fn axis_aligned(f: &Frame) -> bool {
        (0..3).all(|k| f.rotation.col(k).abs().max_element() > 1.0 - 1e-12)
    }

    #[test]
    fn a_sphere_gets_an_axis_aligned_frame_that_ignores_translation() {
        let sphere = crate::mesher::tests::uv_sphere(10.0, 48, 24);
        let (f, _) = translation_invariant("sphere", &sphere, 20_000);
        assert!(axis_aligned(&f), "{:?}", f.rotation);
        // The UV sphere's pole axis is its own eigenvector; the equator plane is degenerate.
        assert!(f.rotation.col(0).z.abs() > 1.0 - 1e-12 || f.rotation.col(2).z.abs() > 1.0 - 1e-12, "{:?}", f.rotation);
    }

    #[test]
    fn a_cube_gets_the_world_frame_whatever_its_position() {
        let cube = box_mesh(DVec3::splat(7.0));
        let (f, _) = translation_invariant("cube", &cube, 20_000);
        assert_eq!(f.rotation, DMat3::IDENTITY);
    }

    #[test]
    fn an_axis_aligned_box_gets_its_own_axes_with_positive_signs() {
        let b = box_mesh(DVec3::new(2.0, 5.0, 3.0));
        let (f, _) = translation_invariant("box", &b, 20_000);
        // Largest extent first: y, then z, then x (right-handed: y × z = x).
        let expected = DMat3::from_cols(DVec3::Y, DVec3::Z, DVec3::X);
        assert!(f.rotation.abs_diff_eq(expected, 1e-12), "{:?}", f.rotation);
    }

    #[test]
    fn a_rotated_box_gets_its_rotated_frame_and_the_same_mesh() {
        let b = box_mesh(DVec3::new(2.0, 5.0, 3.0));
        let (f0, tets0) = translation_invariant("box", &b, 20_000);
        for (axis, angle) in [(DVec3::new(1.0, 2.0, 3.0), 0.7), (DVec3::new(-0.3, 0.1, 1.0), 2.9), (DVec3::X, 0.25)] {
            let q = DQuat::from_axis_angle(axis.normalize(), angle);
            let moved = b.transformed(&DMat4::from_rotation_translation(q, DVec3::new(40.0, -3.0, 8.0)));
            let f = principal_frame(&moved);
            assert!((f.rotation.determinant() - 1.0).abs() < 1e-12);
            for k in 0..3 {
                let rotated = q * f0.rotation.col(k);
                assert!(f.rotation.col(k).dot(rotated).abs() > 1.0 - 1e-12, "axis {k}: {} vs {rotated}", f.rotation.col(k));
            }
            // The box is symmetric under each axis flip, so the local surface and hence the mesh
            // are the unrotated box's.
            let m = tetrahedralize(&moved, &MesherOptions::with_tets(20_000)).unwrap();
            assert_eq!(m.tet_count(), tets0, "rotation {axis} {angle}");
        }
    }

    #[test]
    fn eigenspaces_snap_to_the_world_axes_in_order() {
        // A 2-dimensional eigenspace spanned by noisy vectors in the xz plane.
        let a = DVec3::new(0.6, 0.0, 0.8);
        let c = DVec3::new(-0.8, 0.0, 0.6);
        let axes = snap_degenerate_axes([3.0, 3.0 * (1.0 - 1e-9), 1.0], [a, c, DVec3::Y]);
        assert!(axes[0].abs_diff_eq(DVec3::X, 1e-12) && axes[1].abs_diff_eq(DVec3::Z, 1e-12), "{axes:?}");
        assert_eq!(axes[2], DVec3::Y);
        // A plane through z at 45° to x and y: z lies in it (projection 1) and comes first, then
        // x's projection (x and y tie at 1/√2; the lower index wins).
        let d = DVec3::new(1.0, 1.0, 0.0).normalize();
        let e = DVec3::new(1.0, -1.0, 0.0).normalize();
        let axes = snap_degenerate_axes([2.0, 1.0, 1.0], [e, (d + DVec3::Z).normalize(), (d - DVec3::Z).normalize()]);
        assert_eq!(axes[0], e);
        assert!(axes[1].abs_diff_eq(DVec3::Z, 1e-12) && axes[2].abs_diff_eq(d, 1e-12), "{axes:?}");
        // Distinct eigenvalues keep their eigenvectors.
        let axes = snap_degenerate_axes([3.0, 2.0, 1.0], [a, DVec3::Y, c]);
        assert_eq!(axes, [a, DVec3::Y, c]);
    }
}
