//! Consistent orientation of a triangle mesh: every shell wound the same way, closed shells
//! outwards.
//!
//! Meshes exported by other tools, meshes with flipped normals and objects with a negative scale
//! arrive with some or all triangles wound the wrong way. Every method reads the winding (the
//! outward normal of the boundary, the sign of the winding number), so [`orient`] fixes it once,
//! when a [`super::TriMesh`] is built:
//!
//! 1. **Patches.** Triangles are joined across *manifold* edges (edges used by exactly two
//!    triangles). A breadth-first walk from the lowest unvisited triangle decides, for each
//!    triangle it reaches, whether it must be reversed so that the two triangles at every such
//!    edge traverse it in opposite directions. Edges used by three or more triangles
//!    (non-manifold: two cubes sharing an edge, a fin on a surface) do not propagate, since there
//!    is no single neighbour to agree with; each side is oriented on its own. A walk that returns
//!    to a triangle with the opposite decision proves the surface non-orientable (a Möbius strip,
//!    a Klein bottle): [`Unorientable`].
//! 2. **Outwards.** A closed patch (no edge used by a single triangle) is reversed as a whole when
//!    its own signed volume is negative, so each closed shell faces outwards by itself — also a
//!    shell nested inside another (a cavity modelled as a second outward shell stays outward; the
//!    mesher's winding number then decides what nesting means). An open patch keeps the winding
//!    of the larger part of its area, so a consistently wound open scan is never changed.
//!
//! Reversing a triangle swaps its last two corners (`[a, b, c]` → `[a, c, b]`), an involution: a
//! mesh whose triangles were reversed this way is restored exactly, and a consistent, outward
//! mesh comes out unchanged.

use glam::DVec3;

/// Where a walk over the surface contradicted itself: the surface cannot be oriented.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Unorientable {
    /// The triangle reached a second time with the opposite winding.
    pub triangle: usize,
    /// The triangle it was reached from.
    pub other: usize,
    /// The two ends of the edge they share.
    pub edge: [DVec3; 2],
}

/// Which triangles [`orient`] reverses.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Orientation {
    /// `true` for every triangle to reverse.
    pub reverse: Vec<bool>,
    /// How many are `true`.
    pub count: usize,
}

/// The directed edge of corner `k` of `tri`: from corner `k` to the next.
fn edge_of(tri: [u32; 3], k: usize) -> (u32, u32) {
    (tri[k], tri[(k + 1) % 3])
}

/// Every triangle edge as (undirected key, triangle, corner where it starts), sorted by key.
pub(super) fn sorted_edges(triangles: &[[u32; 3]]) -> Vec<(u64, u32, u8)> {
    let mut edges = Vec::with_capacity(3 * triangles.len());
    for (t, tri) in triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = edge_of(*tri, k);
            let key = (u64::from(a.min(b)) << 32) | u64::from(a.max(b));
            edges.push((key, t as u32, k as u8));
        }
    }
    edges.sort_unstable();
    edges
}

/// The neighbours of every triangle across its manifold edges, as a CSR list of (neighbour,
/// whether the two traverse the edge in the same direction), and for every triangle whether one
/// of its edges is used by it alone (an open border).
fn adjacency(triangles: &[[u32; 3]]) -> (Vec<usize>, Vec<(u32, bool)>, Vec<bool>) {
    let edges = sorted_edges(triangles);
    let mut pairs: Vec<(u32, u32, bool)> = Vec::new();
    let mut border = vec![false; triangles.len()];
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j].0 == edges[i].0 {
            j += 1;
        }
        match j - i {
            1 => border[edges[i].1 as usize] = true,
            2 => {
                let (_, s, ks) = edges[i];
                let (_, t, kt) = edges[i + 1];
                let same = edge_of(triangles[s as usize], ks as usize) == edge_of(triangles[t as usize], kt as usize);
                pairs.push((s, t, same));
                pairs.push((t, s, same));
            }
            _ => {} // non-manifold: no single neighbour to agree with
        }
        i = j;
    }
    pairs.sort_unstable_by_key(|p| (p.0, p.1));
    let mut offsets = vec![0usize; triangles.len() + 1];
    for p in &pairs {
        offsets[p.0 as usize + 1] += 1;
    }
    for t in 0..triangles.len() {
        offsets[t + 1] += offsets[t];
    }
    let neighbours = pairs.into_iter().map(|(_, n, same)| (n, same)).collect();
    (offsets, neighbours, border)
}

/// Twice the area of triangle `tri` and the signed volume of the tet it spans with `origin`.
fn area_and_volume(positions: &[DVec3], tri: [u32; 3], origin: DVec3) -> (f64, f64) {
    let [a, b, c] = tri.map(|v| positions[v as usize] - origin);
    ((b - a).cross(c - a).length(), a.dot(b.cross(c)) / 6.0)
}

/// Which triangles to reverse so that every patch is consistently wound and every closed patch
/// faces outwards (see the module documentation).
///
/// # Errors
/// [`Unorientable`] where a walk over manifold edges contradicts itself.
pub(crate) fn orient(positions: &[DVec3], triangles: &[[u32; 3]]) -> Result<Orientation, Unorientable> {
    let (offsets, neighbours, border) = adjacency(triangles);
    let mut reverse = vec![false; triangles.len()];
    let mut seen = vec![false; triangles.len()];
    let mut patch: Vec<u32> = Vec::new();
    for seed in 0..triangles.len() {
        if seen[seed] {
            continue;
        }
        seen[seed] = true;
        patch.clear();
        patch.push(seed as u32);
        let mut head = 0;
        while head < patch.len() {
            let t = patch[head] as usize;
            head += 1;
            for &(n, same) in &neighbours[offsets[t]..offsets[t + 1]] {
                let wanted = reverse[t] ^ same;
                let n = n as usize;
                if !seen[n] {
                    seen[n] = true;
                    reverse[n] = wanted;
                    patch.push(n as u32);
                } else if reverse[n] != wanted {
                    let (a, b) = shared_edge(triangles[t], triangles[n]);
                    return Err(Unorientable { triangle: n, other: t, edge: [positions[a as usize], positions[b as usize]] });
                }
            }
        }
        if turn_over(positions, triangles, &patch, &reverse, &border) {
            for &t in &patch {
                reverse[t as usize] = !reverse[t as usize];
            }
        }
    }
    let count = reverse.iter().filter(|&&r| r).count();
    Ok(Orientation { reverse, count })
}

/// Whether a consistently wound patch (`reverse` applied) must be reversed as a whole: a closed
/// one when its signed volume is negative, an open one when the reversed triangles cover more
/// area than the others.
fn turn_over(positions: &[DVec3], triangles: &[[u32; 3]], patch: &[u32], reverse: &[bool], border: &[bool]) -> bool {
    let closed = patch.iter().all(|&t| !border[t as usize]);
    if closed {
        // The patch's own vertex centroid as the origin keeps the sum well conditioned far from
        // the coordinate origin (the volume of a closed patch does not depend on it).
        let corners = patch.iter().flat_map(|&t| triangles[t as usize]);
        let origin = corners.clone().map(|v| positions[v as usize]).sum::<DVec3>() / (3 * patch.len()) as f64;
        let volume: f64 = patch
            .iter()
            .map(|&t| {
                let (_, v) = area_and_volume(positions, triangles[t as usize], origin);
                if reverse[t as usize] {
                    -v
                } else {
                    v
                }
            })
            .sum();
        volume < 0.0
    } else {
        let (mut kept, mut reversed) = (0.0, 0.0);
        for &t in patch {
            let (area, _) = area_and_volume(positions, triangles[t as usize], DVec3::ZERO);
            if reverse[t as usize] {
                reversed += area;
            } else {
                kept += area;
            }
        }
        reversed > kept
    }
}

/// The two vertices triangles `s` and `t` share (they share an edge).
fn shared_edge(s: [u32; 3], t: [u32; 3]) -> (u32, u32) {
    let mut common = s.into_iter().filter(|v| t.contains(v));
    let a = common.next().unwrap_or(s[0]);
    (a, common.next().unwrap_or(s[1]))
}

/// `tri` reversed by swapping its last two corners.
pub(crate) fn reversed(tri: [u32; 3]) -> [u32; 3] {
    [tri[0], tri[2], tri[1]]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An outward unit cube as 12 triangles over its 8 corners.
    fn cube(offset: DVec3, scale: f64) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let positions = (0..8)
            .map(|i| offset + scale * DVec3::new(f64::from(i & 1), f64::from((i >> 1) & 1), f64::from((i >> 2) & 1)))
            .collect();
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let triangles = quads.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]).collect();
        (positions, triangles)
    }

    fn signed_volume(positions: &[DVec3], triangles: &[[u32; 3]]) -> f64 {
        triangles.iter().map(|&t| area_and_volume(positions, t, DVec3::ZERO).1).sum()
    }

    fn apply(triangles: &[[u32; 3]], o: &Orientation) -> Vec<[u32; 3]> {
        triangles.iter().zip(&o.reverse).map(|(&t, &r)| if r { reversed(t) } else { t }).collect()
    }

    #[test]
    fn the_cube_is_outward_with_volume_one() {
        let (p, t) = cube(DVec3::ZERO, 1.0);
        assert!((signed_volume(&p, &t) - 1.0).abs() < 1e-15);
        let o = orient(&p, &t).unwrap();
        assert_eq!(o.count, 0);
        assert_eq!(apply(&t, &o), t);
    }

    #[test]
    fn every_subset_of_reversed_cube_triangles_is_restored_exactly() {
        let (p, t) = cube(DVec3::new(3.0, -2.0, 7.0), 0.5);
        for mask in 0u32..(1 << 12) {
            let bad: Vec<[u32; 3]> =
                t.iter().enumerate().map(|(i, &x)| if mask >> i & 1 == 1 { reversed(x) } else { x }).collect();
            let o = orient(&p, &bad).unwrap();
            assert_eq!(o.count, mask.count_ones() as usize, "mask {mask:#x}");
            assert_eq!(apply(&bad, &o), t, "mask {mask:#x}");
        }
    }

    #[test]
    fn a_nested_inward_cavity_is_made_outward_by_its_own_volume() {
        let (mut p, mut t) = cube(DVec3::ZERO, 3.0);
        let (inner_p, inner_t) = cube(DVec3::ONE, 1.0);
        let base = p.len() as u32;
        p.extend(inner_p);
        // The cavity as a modeller would write it: wound inwards.
        t.extend(inner_t.iter().map(|&x| reversed(x.map(|v| v + base))));
        let o = orient(&p, &t).unwrap();
        assert_eq!(o.count, 12);
        assert!(o.reverse[12..].iter().all(|&r| r));
        let fixed = apply(&t, &o);
        assert!((signed_volume(&p, &fixed[..12]) - 27.0).abs() < 1e-12);
        assert!((signed_volume(&p, &fixed[12..]) - 1.0).abs() < 1e-12);
    }

    /// A strip of `n` quads along a band; `twist` joins its ends with a half turn (a Möbius
    /// strip), otherwise as a plain ring.
    fn band(n: usize, twist: bool) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        for i in 0..n {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            let half = if twist { 0.5 * a } else { 0.0 };
            let radial = DVec3::new(a.cos(), a.sin(), 0.0);
            let across = 0.3 * (half.cos() * radial + half.sin() * DVec3::Z);
            p.push(3.0 * radial + across);
            p.push(3.0 * radial - across);
        }
        let mut t = Vec::new();
        for i in 0..n {
            let (a, b) = (2 * i as u32, 2 * i as u32 + 1);
            let j = (i + 1) % n;
            // The last quad of the twisted band joins its top to the bottom of the first.
            let (c, d) = if twist && j == 0 { (1, 0) } else { (2 * j as u32, 2 * j as u32 + 1) };
            t.push([a, b, d]);
            t.push([a, d, c]);
        }
        (p, t)
    }

    #[test]
    fn a_moebius_strip_is_unorientable_and_a_ring_is_not() {
        let (p, t) = band(24, true);
        let e = orient(&p, &t).unwrap_err();
        assert_ne!(e.triangle, e.other);
        assert!(e.edge[0] != e.edge[1]);
        let (p, mut t) = band(24, false);
        assert_eq!(orient(&p, &t).unwrap().count, 0);
        // Open: the larger part keeps its winding, whichever part that is.
        for x in &mut t[..10] {
            *x = reversed(*x);
        }
        let o = orient(&p, &t).unwrap();
        assert_eq!(o.count, 10);
        assert!(o.reverse[..10].iter().all(|&r| r));
        // Reversing every triangle makes the first ten (with the seed, triangle 0) the
        // well-wound minority: the other 38 keep their winding and the ten are reversed.
        for x in &mut t {
            *x = reversed(*x);
        }
        let o = orient(&p, &t).unwrap();
        assert_eq!(o.count, 10);
        assert!(o.reverse[..10].iter().all(|&r| r));
    }

    #[test]
    fn cubes_sharing_an_edge_are_oriented_separately() {
        // Two unit cubes meeting along the edge x = y = 1 (four triangles there: non-manifold),
        // the second wound inwards.
        let (mut p, mut t) = cube(DVec3::ZERO, 1.0);
        let (q, u) = cube(DVec3::new(1.0, 1.0, 0.0), 1.0);
        let mut map = Vec::new();
        for x in q {
            match p.iter().position(|&y| (y - x).length() < 1e-12) {
                Some(i) => map.push(i as u32),
                None => {
                    map.push(p.len() as u32);
                    p.push(x);
                }
            }
        }
        assert_eq!(p.len(), 14, "two corners shared");
        t.extend(u.iter().map(|tri| reversed(tri.map(|v| map[v as usize]))));
        let o = orient(&p, &t).unwrap();
        assert_eq!(o.count, 12);
        assert!(o.reverse[12..].iter().all(|&r| r));
        assert!((signed_volume(&p, &apply(&t, &o)) - 2.0).abs() < 1e-12);
    }
}
