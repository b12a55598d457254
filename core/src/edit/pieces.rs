//! Pieces of a cut mesh: connected components (fracture), extracting a sub-mesh, checking that a
//! piece transform is rigid, and welding two pieces whose boundaries touch again (recombine).

use std::collections::HashMap;

use glam::{DMat4, DVec3};

use super::EditError;
use crate::mesh::TetMesh;

/// Tets grouped by connectivity through shared vertices (two tets touching only at a vertex are in
/// the same component, as they share a row of the diffusion matrix); components in order of their
/// smallest tet id, tet ids increasing inside each. Union–find with path halving over vertices.
#[must_use]
pub fn connected_components(mesh: &TetMesh) -> Vec<Vec<u32>> {
    let mut parent: Vec<u32> = (0..mesh.vertex_count() as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            parent[x as usize] = parent[parent[x as usize] as usize];
            x = parent[x as usize];
        }
        x
    }
    for t in mesh.tets() {
        let r = find(&mut parent, t[0]);
        for &v in &t[1..] {
            let s = find(&mut parent, v);
            if s != r {
                // Attach to the smaller root so the result does not depend on the visiting order.
                let (lo, hi) = if s < r { (s, r) } else { (r, s) };
                parent[hi as usize] = lo;
            }
        }
    }
    let mut component_of_root: HashMap<u32, usize> = HashMap::new();
    let mut components: Vec<Vec<u32>> = Vec::new();
    for (ti, t) in mesh.tets().iter().enumerate() {
        let root = find(&mut parent, t[0]);
        let c = *component_of_root.entry(root).or_insert_with(|| {
            components.push(Vec::new());
            components.len() - 1
        });
        components[c].push(ti as u32);
    }
    components
}

/// The sub-mesh made of `tets` (in the given order), its vertices compacted in increasing old id,
/// materials carried over, with the original ids of those tets.
///
/// # Errors
/// [`EditError::InvalidOptions`] for an `original_tet` of the wrong length, an empty `tets`, a tet
/// index out of range or repeated; [`EditError::Mesh`] if the sub-mesh is invalid (not expected).
pub fn extract(mesh: &TetMesh, original_tet: &[u32], tets: &[u32]) -> Result<(TetMesh, Vec<u32>), EditError> {
    if original_tet.len() != mesh.tet_count() {
        return Err(EditError::InvalidOptions(format!(
            "original_tet has {} entries for {} tets",
            original_tet.len(),
            mesh.tet_count()
        )));
    }
    if tets.is_empty() {
        return Err(EditError::InvalidOptions("no tets to extract".into()));
    }
    let mut seen = vec![false; mesh.tet_count()];
    for &t in tets {
        let Some(s) = seen.get_mut(t as usize) else {
            return Err(EditError::InvalidOptions(format!("tet {t} does not exist (there are {})", mesh.tet_count())));
        };
        if *s {
            return Err(EditError::InvalidOptions(format!("tet {t} is listed twice")));
        }
        *s = true;
    }
    let mut new_index = vec![u32::MAX; mesh.vertex_count()];
    for &t in tets {
        for &v in &mesh.tets()[t as usize] {
            new_index[v as usize] = 0;
        }
    }
    let mut positions = Vec::new();
    for (v, slot) in new_index.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = positions.len() as u32;
            positions.push(mesh.positions()[v]);
        }
    }
    let sub: Vec<[u32; 4]> = tets.iter().map(|&t| mesh.tets()[t as usize].map(|v| new_index[v as usize])).collect();
    let materials = tets.iter().map(|&t| mesh.materials()[t as usize]).collect();
    let original = tets.iter().map(|&t| original_tet[t as usize]).collect();
    Ok((TetMesh::new(positions, sub, materials)?, original))
}

/// Tolerance of [`check_rigid`].
pub const RIGID_TOLERANCE: f64 = 1e-9;

/// Checks that `m` is a rigid motion `x ↦ R x + t`: finite, affine (last row `0 0 0 1`),
/// orthonormal `RᵀR = I` (each entry within [`RIGID_TOLERANCE`]) and `det R = +1`.
///
/// # Errors
/// [`EditError::NotRigid`] naming the problem: a non-finite entry, a projective last row, a
/// scaling (column lengths), a shear (non-perpendicular columns) or a reflection.
pub fn check_rigid(m: &DMat4) -> Result<(), EditError> {
    if !m.is_finite() {
        return Err(EditError::NotRigid("the matrix has a NaN or infinite entry".into()));
    }
    let row = m.row(3);
    if (row - glam::DVec4::new(0.0, 0.0, 0.0, 1.0)).abs().max_element() > RIGID_TOLERANCE {
        return Err(EditError::NotRigid(format!("last row is {row}, not (0, 0, 0, 1)")));
    }
    let cols = [m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate()];
    let lengths = cols.map(|c| c.length_squared());
    if lengths.iter().any(|l| (l - 1.0).abs() > RIGID_TOLERANCE) {
        return Err(EditError::NotRigid(format!(
            "scaling: the columns of the 3×3 part have lengths {}, {}, {}",
            lengths[0].sqrt(),
            lengths[1].sqrt(),
            lengths[2].sqrt()
        )));
    }
    for (i, j) in [(0, 1), (0, 2), (1, 2)] {
        let d = cols[i].dot(cols[j]);
        if d.abs() > RIGID_TOLERANCE {
            return Err(EditError::NotRigid(format!("shear: columns {i} and {j} have dot product {d:e}")));
        }
    }
    let det = cols[0].dot(cols[1].cross(cols[2]));
    if det < 0.0 {
        return Err(EditError::NotRigid(format!("reflection: the determinant is {det}")));
    }
    Ok(())
}

/// Merges two meshes given in the same space if they touch: boundary faces of `a` and `b` whose
/// three vertices coincide within `tolerance` (and whose outward normals are opposite, i.e. the
/// pieces lie on both sides of the face) are glued; their vertices are merged (at `a`'s
/// positions), so those faces become interior. The result has `a`'s vertices, then `b`'s unmerged
/// vertices in order; `a`'s tets, then `b`'s; original ids `a_orig` then `b_orig`. Only vertices of
/// glued faces are merged. Matching uses a spatial hash with cells of size `tolerance`: each
/// boundary vertex of `a` takes the nearest boundary vertex of `b` within `tolerance` (ties: the
/// lower index), and a vertex of `b` claimed twice goes to the nearer (then lower) `a` vertex.
///
/// Returns `None` when no face coincides.
///
/// # Errors
/// [`EditError::InvalidOptions`] for a tolerance that is not positive and finite or id arrays of
/// the wrong length; [`EditError::Mesh`] if the glued mesh is invalid (faces shared three ways).
pub fn weld(
    a: &TetMesh,
    a_orig: &[u32],
    b: &TetMesh,
    b_orig: &[u32],
    tolerance: f64,
) -> Result<Option<(TetMesh, Vec<u32>)>, EditError> {
    if !(tolerance > 0.0 && tolerance.is_finite()) {
        return Err(EditError::InvalidOptions(format!("weld tolerance {tolerance} is not positive and finite")));
    }
    for (name, mesh, ids) in [("a", a, a_orig), ("b", b, b_orig)] {
        if ids.len() != mesh.tet_count() {
            return Err(EditError::InvalidOptions(format!(
                "original ids of {name}: {} entries for {} tets",
                ids.len(),
                mesh.tet_count()
            )));
        }
    }
    let cell = |p: DVec3| -> [i64; 3] { (p / tolerance).floor().to_array().map(|c| c as i64) };
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for (v, _) in b.boundary_flags().iter().enumerate().filter(|(_, &f)| f) {
        grid.entry(cell(b.positions()[v])).or_default().push(v as u32);
    }
    // Nearest boundary vertex of b for every boundary vertex of a.
    let mut claim: HashMap<u32, (f64, u32)> = HashMap::new(); // b vertex → (distance², a vertex)
    for (va, _) in a.boundary_flags().iter().enumerate().filter(|(_, &f)| f) {
        let p = a.positions()[va];
        let c = cell(p);
        let mut best: Option<(f64, u32)> = None;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let key = [c[0].saturating_add(dx), c[1].saturating_add(dy), c[2].saturating_add(dz)];
                    for &vb in grid.get(&key).map_or(&[][..], Vec::as_slice) {
                        let d2 = (b.positions()[vb as usize] - p).length_squared();
                        if d2 <= tolerance * tolerance && best.is_none_or(|(bd, bv)| d2 < bd || (d2 == bd && vb < bv)) {
                            best = Some((d2, vb));
                        }
                    }
                }
            }
        }
        if let Some((d2, vb)) = best {
            let entry = claim.entry(vb).or_insert((d2, va as u32));
            if d2 < entry.0 {
                *entry = (d2, va as u32);
            }
        }
    }
    let mut a_to_b: HashMap<u32, u32> = HashMap::new();
    for (&vb, &(_, va)) in &claim {
        a_to_b.insert(va, vb);
    }
    // Boundary faces of b by sorted vertex triple.
    let key = |f: [u32; 3]| {
        let mut s = f;
        s.sort_unstable();
        s
    };
    let b_faces: HashMap<[u32; 3], usize> = b.boundary_faces().iter().enumerate().map(|(i, f)| (key(f.vertices), i)).collect();
    let mut merge: Vec<Option<u32>> = vec![None; b.vertex_count()]; // b vertex → a vertex
    let mut glued = 0usize;
    for (fa, face) in a.boundary_faces().iter().enumerate() {
        let mapped: Option<Vec<u32>> = face.vertices.iter().map(|v| a_to_b.get(v).copied()).collect();
        let Some(mapped) = mapped else { continue };
        let Some(&fb) = b_faces.get(&key([mapped[0], mapped[1], mapped[2]])) else {
            continue;
        };
        if a.boundary_normal(fa).dot(b.boundary_normal(fb)) >= 0.0 {
            continue;
        }
        glued += 1;
        for (k, &va) in face.vertices.iter().enumerate() {
            merge[mapped[k] as usize] = Some(va);
        }
    }
    if glued == 0 {
        return Ok(None);
    }
    let mut positions = a.positions().to_vec();
    let mut b_index = vec![0u32; b.vertex_count()];
    for (vb, m) in merge.iter().enumerate() {
        b_index[vb] = match m {
            Some(va) => *va,
            None => {
                positions.push(b.positions()[vb]);
                (positions.len() - 1) as u32
            }
        };
    }
    let mut tets = a.tets().to_vec();
    tets.extend(b.tets().iter().map(|t| t.map(|v| b_index[v as usize])));
    let mut materials = a.materials().to_vec();
    materials.extend_from_slice(b.materials());
    let mut original = a_orig.to_vec();
    original.extend_from_slice(b_orig);
    Ok(Some((TetMesh::new(positions, tets, materials)?, original)))
}
