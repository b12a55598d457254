//! The stencils of isosurface stuffing (Labelle & Shewchuk 2007, §3 and Fig. 3): how one BCC
//! tetrahedron, given the labels of its vertices (inside `+`, on the surface `0`, outside `−`)
//! after warping, is filled with output tetrahedra.
//!
//! Output polyhedra are single tets, square pyramids or triangular prisms. Their quadrilateral
//! faces that lie in a face of the BCC tet are shared with the neighbouring BCC tet, so their
//! diagonal must be a property of the face alone; [`Diagonal`] rules give it:
//! * the quad's `++` edge is long (black): the **parity rule** of §3.3;
//! * the quad's `++` edge is short (red): the diagonal ends at the cut point on the long edge.
//!
//! Quads inside the BCC tet (the cut surface) are free; the split with the better minimum
//! dihedral angle is taken.

use glam::DVec3;

use crate::mesh::dihedral_angles;

/// An output vertex: a lattice vertex, or the cut point on the lattice edge `{a, b}`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Vert {
    Lattice(u32),
    Cut(u32, u32),
}

/// What the stencils need to know about the lattice.
pub(crate) trait StencilContext {
    /// Whether lattice vertex `v` is a corner (else a centre).
    fn is_corner(&self, v: u32) -> bool;
    /// Position of an output vertex (warped lattice vertex or cut point).
    fn position(&self, v: Vert) -> DVec3;
    /// Lattice position of `v` before warping.
    fn lattice_position(&self, v: u32) -> DVec3;
}

/// Fills one BCC tet. `ids` are its lattice vertices with `(0, 1)` and `(2, 3)` the two long
/// edges, `labels` their signs (+1 in, 0 on, −1 out). Output tets may be of either orientation.
/// `all_on_inside` decides the tet whose four vertices are all on the surface (is its centroid
/// inside?).
pub(crate) fn fill(
    ctx: &impl StencilContext,
    ids: [u32; 4],
    labels: [i8; 4],
    all_on_inside: impl FnOnce() -> bool,
    out: &mut Vec<[Vert; 4]>,
) {
    let count = |s: i8| labels.iter().filter(|&&l| l == s).count();
    let (n_in, n_on, n_out) = (count(1), count(0), count(-1));
    let lat = |i: usize| Vert::Lattice(ids[i]);
    let cut = |i: usize, j: usize| Vert::Cut(ids[i], ids[j]);
    let find = |s: i8| (0..4).find(|&i| labels[i] == s).unwrap_or(0);

    if n_in == 0 {
        return;
    }
    if n_out == 0 {
        if n_on < 4 || all_on_inside() {
            out.push([lat(0), lat(1), lat(2), lat(3)]);
        }
        return;
    }
    if n_in == 1 {
        let p = find(1);
        out.push(std::array::from_fn(|i| if labels[i] == -1 { cut(i, p) } else { lat(i) }));
        return;
    }
    match (n_in, n_on, n_out) {
        (2, 1, 1) => {
            // A square pyramid: apex at the 0 vertex, base the quad in the face (p, q, m).
            let z = find(0);
            let m = find(-1);
            let (p, q) = {
                let mut it = (0..4).filter(|&i| labels[i] == 1);
                (it.next().unwrap_or(0), it.next().unwrap_or(0))
            };
            let quad = face_quad(ctx, ids, p, q, m);
            pyramid(lat(z), quad, out);
        }
        (3, 0, 1) => {
            // A prism between the + triangle and the triangle of three cut points.
            let m = find(-1);
            let a: Vec<usize> = (0..4).filter(|&i| i != m).collect();
            let caps = ([lat(a[0]), lat(a[1]), lat(a[2])], [cut(a[0], m), cut(a[1], m), cut(a[2], m)]);
            let diag = std::array::from_fn(|k| {
                let (i, j) = (a[k], a[(k + 1) % 3]);
                Some(diagonal_from_first(ctx, ids[i], ids[j], ids[m]))
            });
            prism(ctx, caps, diag, out);
        }
        (2, 0, 2) => {
            // A prism between the two + vertices' triangles of cut points.
            let p = find(1);
            let q = (0..4).find(|&i| i != p && labels[i] == 1).unwrap_or(0);
            let m0 = find(-1);
            let m1 = (0..4).find(|&i| i != m0 && labels[i] == -1).unwrap_or(0);
            // Caps: (p, cut(p, m0), cut(p, m1)) and (q, cut(q, m0), cut(q, m1)).
            let caps = ([lat(p), cut(p, m0), cut(p, m1)], [lat(q), cut(q, m0), cut(q, m1)]);
            // Quads: 0 = (p, c_p0 | q, c_q0) lies in face (p, q, m0); 1 = cut surface; 2 = face (p, q, m1).
            let d0 = diagonal_from_first(ctx, ids[p], ids[q], ids[m0]);
            let d2 = !diagonal_from_first(ctx, ids[p], ids[q], ids[m1]);
            prism(ctx, caps, [Some(d0), None, Some(d2)], out);
        }
        _ => {}
    }
}

/// Which diagonal splits the quad `(p, q, cut(q, m), cut(p, m))` lying in the lattice face
/// `(p, q, m)`, with `p`, `q` inside and `m` outside: `true` for `(p, cut(q, m))`, `false` for
/// `(q, cut(p, m))`. A function of the face alone, so both BCC tets sharing it agree.
pub(crate) fn diagonal_from_first(ctx: &impl StencilContext, p: u32, q: u32, m: u32) -> bool {
    let (cp, cq, cm) = (ctx.is_corner(p), ctx.is_corner(q), ctx.is_corner(m));
    if cp == cq {
        // Long (black) ++ edge: the parity rule (Labelle & Shewchuk §3.3). With A = p and
        // C = cut(q, m), count the axes where A > C; the diagonal is AC exactly when that parity
        // equals "the ++ edge joins two corners". Swapping p and q flips the parity, so the rule
        // picks the same diagonal from either side.
        let a = ctx.lattice_position(p);
        let c = ctx.position(Vert::Cut(q, m));
        let odd = ((a.x > c.x) as u8 + (a.y > c.y) as u8 + (a.z > c.z) as u8) & 1 == 1;
        cp == odd
    } else {
        // Short (red) ++ edge: exactly one of (p, m), (q, m) is long; the diagonal ends at the
        // cut point on that long edge.
        cq == cm
    }
}

/// The quad of face `(p, q, m)` as `[p, q, cut(q, m), cut(p, m)]` and its diagonal.
fn face_quad(ctx: &impl StencilContext, ids: [u32; 4], p: usize, q: usize, m: usize) -> ([Vert; 4], bool) {
    let quad = [Vert::Lattice(ids[p]), Vert::Lattice(ids[q]), Vert::Cut(ids[q], ids[m]), Vert::Cut(ids[p], ids[m])];
    (quad, diagonal_from_first(ctx, ids[p], ids[q], ids[m]))
}

/// Splits the pyramid `apex` over quad `[v0, v1, v2, v3]` along diagonal `v0–v2` (`true`) or
/// `v1–v3` (`false`).
fn pyramid(apex: Vert, (q, diag02): ([Vert; 4], bool), out: &mut Vec<[Vert; 4]>) {
    if diag02 {
        out.push([apex, q[0], q[1], q[2]]);
        out.push([apex, q[0], q[2], q[3]]);
    } else {
        out.push([apex, q[0], q[1], q[3]]);
        out.push([apex, q[1], q[2], q[3]]);
    }
}

/// Splits the prism with caps `a = [a0, a1, a2]`, `b = [b0, b1, b2]` (edges `aᵢ–bᵢ`) into three
/// tets. Quad `k` joins `aₖ, aₖ₊₁, bₖ₊₁, bₖ`; `diag[k] = Some(true)` puts its diagonal at
/// `aₖ–bₖ₊₁`, `Some(false)` at `aₖ₊₁–bₖ`, `None` leaves it free (chosen for quality).
fn prism(ctx: &impl StencilContext, (a, b): ([Vert; 3], [Vert; 3]), diag: [Option<bool>; 3], out: &mut Vec<[Vert; 4]>) {
    let free: Vec<usize> = (0..3).filter(|&k| diag[k].is_none()).collect();
    let mut best: Option<(f64, Vec<[Vert; 4]>)> = None;
    for choice in 0..(1usize << free.len()) {
        let mut d = [false; 3];
        for k in 0..3 {
            d[k] = diag[k].unwrap_or_else(|| {
                let bit = free.iter().position(|&f| f == k).unwrap_or(0);
                choice >> bit & 1 == 1
            });
        }
        if let Some(tets) = split_prism(a, b, d) {
            let quality = tets
                .iter()
                .map(|t| {
                    let p = t.map(|v| ctx.position(v));
                    dihedral_angles(p).into_iter().fold(f64::INFINITY, f64::min)
                })
                .fold(f64::INFINITY, f64::min);
            if best.as_ref().is_none_or(|(q, _)| quality > *q) {
                best = Some((quality, tets));
            }
        }
    }
    if let Some((_, tets)) = best {
        out.extend(tets);
    }
}

/// The three tets of a prism for fixed quad diagonals, or `None` when the diagonals circle the
/// prism (no split without a Steiner point).
fn split_prism(a: [Vert; 3], b: [Vert; 3], d: [bool; 3]) -> Option<Vec<[Vert; 4]>> {
    for i in 0..3 {
        let (prev, far) = ((i + 2) % 3, (i + 1) % 3);
        // aᵢ touches the diagonals of quad i (if d[i]) and quad i−1 (if !d[i−1]).
        if d[i] && !d[prev] {
            let mut tets = vec![[a[i], b[0], b[1], b[2]]];
            quad_pyramid(a[i], far, a, b, d[far], &mut tets);
            return Some(tets);
        }
        // bᵢ touches the diagonals of quad i (if !d[i]) and quad i−1 (if d[i−1]).
        if !d[i] && d[prev] {
            let mut tets = vec![[b[i], a[0], a[1], a[2]]];
            quad_pyramid(b[i], far, a, b, d[far], &mut tets);
            return Some(tets);
        }
    }
    None
}

/// The two tets of the pyramid from `apex` over prism quad `k` (`aₖ, aₖ₊₁, bₖ₊₁, bₖ`).
fn quad_pyramid(apex: Vert, k: usize, a: [Vert; 3], b: [Vert; 3], d: bool, out: &mut Vec<[Vert; 4]>) {
    let j = (k + 1) % 3;
    if d {
        // Diagonal aₖ–bⱼ.
        out.push([apex, a[k], a[j], b[j]]);
        out.push([apex, a[k], b[j], b[k]]);
    } else {
        // Diagonal aⱼ–bₖ.
        out.push([apex, a[k], a[j], b[k]]);
        out.push([apex, a[j], b[j], b[k]]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::tet_volume;

    /// A unit prism with every valid diagonal pattern splits into three tets filling its volume.
    #[test]
    fn prism_splits_fill_the_prism() {
        let pts = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.0, 1.0, 1.0),
        ];
        let a = [Vert::Lattice(0), Vert::Lattice(1), Vert::Lattice(2)];
        let b = [Vert::Lattice(3), Vert::Lattice(4), Vert::Lattice(5)];
        let mut valid = 0;
        for bits in 0..8 {
            let d = [bits & 1 == 1, bits & 2 == 2, bits & 4 == 4];
            match split_prism(a, b, d) {
                Some(tets) => {
                    valid += 1;
                    let vol: f64 = tets
                        .iter()
                        .map(|t| {
                            tet_volume(t.map(|v| if let Vert::Lattice(i) = v { pts[i as usize] } else { DVec3::ZERO })).abs()
                        })
                        .sum();
                    assert!((vol - 0.5).abs() < 1e-12, "pattern {bits}: volume {vol}");
                }
                None => assert!(bits == 0b111 || bits == 0b000, "pattern {bits} should split"),
            }
        }
        assert_eq!(valid, 6);
    }
}
