//! Shape measures of tetrahedra: signed volume and dihedral angles.

use glam::DVec3;

/// Local vertex pairs of the six edges of a tetrahedron `[0, 1, 2, 3]`.
pub(crate) const TET_EDGES: [[usize; 2]; 6] = [[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]];

/// The four faces of a positively oriented tetrahedron, each counter-clockwise seen from outside;
/// face `i` is opposite local vertex `i`.
pub(crate) const TET_FACES: [[usize; 3]; 4] = [[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]];

/// Signed volume `(b − a) · ((c − a) × (d − a)) / 6`; positive when `d` lies on the side of
/// triangle `abc` that its counter-clockwise normal points to.
#[must_use]
pub fn tet_volume(p: [DVec3; 4]) -> f64 {
    (p[1] - p[0]).dot((p[2] - p[0]).cross(p[3] - p[0])) / 6.0
}

/// Interior dihedral angles (radians) at the six edges, in the order of [`TET_EDGES`]:
/// `(0,1), (0,2), (0,3), (1,2), (1,3), (2,3)`.
///
/// The angle at edge `(i, j)` is the angle between the two faces that share it (those opposite
/// the other two vertices `k`, `l`): `cos θ_ij = −n_k · n_l` with `n` the unit outward normals.
/// This is the θ of the cotangent weights (TransCut eq. 10), where the weight of edge `ij` uses
/// the angle at the opposite edge `kl`.
#[must_use]
pub fn dihedral_angles(p: [DVec3; 4]) -> [f64; 6] {
    let normals = face_normals(p);
    let mut out = [0.0; 6];
    for (e, [i, j]) in TET_EDGES.iter().enumerate() {
        let (k, l) = other_two(*i, *j);
        let c = (-normals[k].dot(normals[l])).clamp(-1.0, 1.0);
        out[e] = c.acos();
    }
    out
}

/// Cotangents of the dihedral angles, in the order of [`TET_EDGES`], computed without `acos`:
/// `cot θ = cos θ / sin θ` with `sin θ = |n_k × n_l|`.
#[must_use]
pub fn dihedral_cotangents(p: [DVec3; 4]) -> [f64; 6] {
    let normals = face_normals(p);
    let mut out = [0.0; 6];
    for (e, [i, j]) in TET_EDGES.iter().enumerate() {
        let (k, l) = other_two(*i, *j);
        let c = -normals[k].dot(normals[l]);
        let s = normals[k].cross(normals[l]).length();
        out[e] = c / s;
    }
    out
}

/// Unit outward normals of the faces opposite each vertex (for a positively oriented tet).
fn face_normals(p: [DVec3; 4]) -> [DVec3; 4] {
    TET_FACES.map(|[a, b, c]| (p[b] - p[a]).cross(p[c] - p[a]).normalize_or_zero())
}

/// The two local vertices of a tetrahedron that are not `i` or `j`.
pub(crate) fn other_two(i: usize, j: usize) -> (usize, usize) {
    let mut rest = (0..4).filter(|&v| v != i && v != j);
    (rest.next().unwrap_or(0), rest.next().unwrap_or(0))
}

/// Summary of the dihedral angles of a tetrahedral mesh.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct QualityReport {
    /// Smallest dihedral angle over all tets, degrees.
    pub min_dihedral_deg: f64,
    /// Largest dihedral angle over all tets, degrees.
    pub max_dihedral_deg: f64,
    /// Histogram of every tet's minimum dihedral angle in 10° bins: `[0,10), [10,20), …, [80,90]`.
    pub min_angle_histogram: [usize; 9],
    /// Histogram of every tet's maximum dihedral angle in 10° bins: `[90,100), …, [170,180]`.
    pub max_angle_histogram: [usize; 9],
    /// Smallest tet volume.
    pub min_volume: f64,
}
