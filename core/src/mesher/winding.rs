//! Generalised winding numbers with the hierarchical far-field evaluation of Barill, Dickson,
//! Schmidt, Levin and Jacobson, *Fast Winding Numbers for Soups and Clouds* (SIGGRAPH 2018).
//!
//! `w(q) = (1/4π) Σ_t Ω_t(q)`, the solid angles of the triangles seen from `q`: 1 inside a closed,
//! outward-oriented surface, 0 outside, and a smooth in-between value across holes, so
//! `w ≥ ½` gives a sensible solid for open scans and overlapping shells alike.
//!
//! Each BVH node stores the moments of its triangles (treated as points at their centroids):
//! `N = Σ aₜ nₜ` (area-weighted normal), the area-weighted centre `p̃` and
//! `C = Σ aₜ nₜ (cₜ − p̃)ᵀ`. Far from the node (`|q − p̃| > β r`, `r` the node radius) its
//! contribution is the second-order expansion of `∫ n · ∇G(x − q) dA` with
//! `∇G(r) = r / (4π|r|³)`:
//! `w ≈ N · ∇G(p̃ − q) + Σᵢⱼ Hᵢⱼ(p̃ − q) Cᵢⱼ`, `H(r) = (I/|r|³ − 3 r rᵀ/|r|⁵) / 4π` (Barill eq. 11
//! truncated at order 2); near it, the children are visited and leaves sum exact solid angles
//! (Van Oosterom & Strackee 1983).

use glam::{DMat3, DVec3};

use crate::mesh::TriangleBvh;

/// Accuracy parameter: a node is expanded unless `|q − p̃| > β r` (Barill et al.'s β = 2). The
/// expansion starts at the dipole term, so a node's relative error is O((r/d)²) ≈ β⁻²: the worst
/// case, the centre of a sphere where every node sits at its acceptance limit, is off by 0.045.
/// The mesher re-evaluates values within 0.05 of ½ with β = 5 (error below 0.01), so labels do
/// not depend on the far-field error.
pub const BETA: f64 = 2.0;

/// Per-node moments for the far-field expansion, parallel to the BVH nodes.
#[derive(Debug, Clone, Copy)]
struct Moments {
    center: DVec3,
    radius: f64,
    normal: DVec3,
    /// `C = Σ aₜ nₜ (cₜ − p̃)ᵀ` stored column-major: `C.col(j)[i] = Cᵢⱼ`.
    second: DMat3,
}

/// A triangle soup prepared for fast winding-number queries.
#[derive(Debug, Clone)]
pub struct WindingNumber {
    bvh: TriangleBvh,
    moments: Vec<Moments>,
    cycle: bool,
}

impl WindingNumber {
    /// Prepares the hierarchy for the triangles of `bvh`.
    #[must_use]
    pub fn new(bvh: TriangleBvh) -> Self {
        let mut moments =
            vec![Moments { center: DVec3::ZERO, radius: 0.0, normal: DVec3::ZERO, second: DMat3::ZERO }; bvh.nodes.len()];
        if !bvh.nodes.is_empty() {
            fill_moments(&bvh, 0, &mut moments);
        }
        Self { bvh, moments, cycle: false }
    }

    /// Prepares the hierarchy for an indexed surface, noting whether it is a cycle
    /// ([`WindingNumber::is_cycle`]).
    #[must_use]
    pub fn of_surface(positions: &[DVec3], triangles: &[[u32; 3]]) -> Self {
        Self { cycle: is_cycle(triangles), ..Self::new(TriangleBvh::from_indexed(positions, triangles)) }
    }

    /// Whether the surface is known to be a cycle: every edge used as often from a to b as from
    /// b to a (closed, consistently oriented shells, overlapping or not). Then the winding number
    /// is an integer, constant on every region no triangle crosses. False for a bare BVH
    /// ([`WindingNumber::new`]).
    #[must_use]
    pub fn is_cycle(&self) -> bool {
        self.cycle
    }

    /// The BVH the evaluation walks (also usable for rays and closest points).
    #[must_use]
    pub fn bvh(&self) -> &TriangleBvh {
        &self.bvh
    }

    /// The generalised winding number at `q`.
    #[must_use]
    pub fn at(&self, q: DVec3) -> f64 {
        self.at_with_accuracy(q, BETA)
    }

    /// The winding number at `q` with acceptance parameter `beta` (≥ 1): larger is more accurate
    /// and slower (relative error O(β⁻²)).
    #[must_use]
    pub fn at_with_accuracy(&self, q: DVec3, beta: f64) -> f64 {
        if self.bvh.nodes.is_empty() {
            return 0.0;
        }
        let mut sum = 0.0;
        let mut stack: [u32; 64] = [0; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let ni = stack[top];
            let node = &self.bvh.nodes[ni as usize];
            let m = &self.moments[ni as usize];
            let r = m.center - q;
            let d2 = r.length_squared();
            if d2 > (beta * m.radius).powi(2) {
                sum += far_field(m, r, d2);
            } else if node.count > 0 {
                for &t in &self.bvh.order[node.start_or_right as usize..(node.start_or_right + node.count) as usize] {
                    sum += solid_angle(self.bvh.corners[t as usize], q);
                }
            } else if top + 2 <= stack.len() {
                stack[top] = node.start_or_right;
                stack[top + 1] = ni + 1;
                top += 2;
            } else {
                // Degenerate, extremely deep tree: finish this subtree exactly.
                sum += self.exact_subtree(ni, q);
            }
        }
        sum / (4.0 * std::f64::consts::PI)
    }

    /// Exact sum of solid angles of every triangle under node `ni`.
    fn exact_subtree(&self, ni: u32, q: DVec3) -> f64 {
        let node = &self.bvh.nodes[ni as usize];
        if node.count > 0 {
            self.bvh.order[node.start_or_right as usize..(node.start_or_right + node.count) as usize]
                .iter()
                .map(|&t| solid_angle(self.bvh.corners[t as usize], q))
                .sum()
        } else {
            self.exact_subtree(ni + 1, q) + self.exact_subtree(node.start_or_right, q)
        }
    }
}

/// Whether `triangles` form a cycle ([`WindingNumber::is_cycle`]).
fn is_cycle(triangles: &[[u32; 3]]) -> bool {
    let mut edges: Vec<(u64, i32)> = triangles
        .iter()
        .flat_map(|t| {
            (0..3).map(move |k| {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                ((u64::from(a.min(b)) << 32) | u64::from(a.max(b)), if a < b { 1 } else { -1 })
            })
        })
        .collect();
    edges.sort_unstable_by_key(|e| e.0);
    edges.chunk_by(|x, y| x.0 == y.0).all(|same| same.iter().map(|e| e.1).sum::<i32>() == 0)
}

/// Second-order far-field contribution (times 4π) of a node seen from `q`, with `r = p̃ − q`.
fn far_field(m: &Moments, r: DVec3, d2: f64) -> f64 {
    let d = d2.sqrt();
    let inv3 = 1.0 / (d2 * d);
    let inv5 = inv3 / d2;
    // 4π (N · ∇G) = N · r / |r|³
    let first = m.normal.dot(r) * inv3;
    // 4π Σ Hᵢⱼ Cᵢⱼ = tr(C)/|r|³ − 3 rᵀ C r/|r|⁵
    let trace = m.second.x_axis.x + m.second.y_axis.y + m.second.z_axis.z;
    let rcr = r.dot(m.second * r);
    first + trace * inv3 - 3.0 * rcr * inv5
}

/// Signed solid angle of triangle `abc` seen from `q` (Van Oosterom & Strackee 1983):
/// `Ω = 2 atan2(a·(b×c), |a||b||c| + (a·b)|c| + (b·c)|a| + (c·a)|b|)` with corners relative to `q`.
/// Positive when `q` is behind the counter-clockwise face (inside).
#[must_use]
pub fn solid_angle(tri: [DVec3; 3], q: DVec3) -> f64 {
    let [a, b, c] = tri.map(|p| p - q);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let det = a.dot(b.cross(c));
    let div = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    2.0 * det.atan2(div)
}

/// Fills the moments of node `ni` and its subtree bottom-up.
fn fill_moments(bvh: &TriangleBvh, ni: u32, out: &mut [Moments]) {
    let node = bvh.nodes[ni as usize];
    let tris: Vec<u32> = if node.count > 0 {
        bvh.order[node.start_or_right as usize..(node.start_or_right + node.count) as usize].to_vec()
    } else {
        fill_moments(bvh, ni + 1, out);
        fill_moments(bvh, node.start_or_right, out);
        Vec::new()
    };
    let m = if node.count > 0 {
        leaf_moments(tris.iter().map(|&t| bvh.corners[t as usize]))
    } else {
        merge_moments(&out[(ni + 1) as usize], &out[node.start_or_right as usize])
    };
    // The radius must bound every corner under the node; for inner nodes the children's spheres
    // give a bound, for leaves the corners themselves.
    let radius = if node.count > 0 {
        tris.iter().flat_map(|&t| bvh.corners[t as usize]).map(|p| (p - m.center).length()).fold(0.0, f64::max)
    } else {
        let (l, r) = (&out[(ni + 1) as usize], &out[node.start_or_right as usize]);
        ((l.center - m.center).length() + l.radius).max((r.center - m.center).length() + r.radius)
    };
    out[ni as usize] = Moments { radius, ..m };
}

/// Moments of a set of triangles (radius filled by the caller).
fn leaf_moments(tris: impl Iterator<Item = [DVec3; 3]> + Clone) -> Moments {
    let mut area = 0.0;
    let mut center = DVec3::ZERO;
    let mut normal = DVec3::ZERO;
    for [a, b, c] in tris.clone() {
        let n2 = (b - a).cross(c - a);
        let w = 0.5 * n2.length();
        area += w;
        center += w * (a + b + c) / 3.0;
        normal += 0.5 * n2;
    }
    let center = if area > 0.0 { center / area } else { tris.clone().next().map_or(DVec3::ZERO, |[a, b, c]| (a + b + c) / 3.0) };
    let mut second = DMat3::ZERO;
    for [a, b, c] in tris {
        let an = 0.5 * (b - a).cross(c - a);
        second += outer(an, (a + b + c) / 3.0 - center);
    }
    Moments { center, radius: 0.0, normal, second }
}

/// Combines two children's moments about the area-weighted centre of both.
fn merge_moments(l: &Moments, r: &Moments) -> Moments {
    // Areas are not stored; weight centres by |N| is wrong for closed shells (N ≈ 0), so we
    // re-centre at the midpoint of the children's centres and shift the second moments:
    // C about p is Σ aₜ nₜ (cₜ − p)ᵀ = C_child + N_child (p_child − p)ᵀ.
    let center = 0.5 * (l.center + r.center);
    let second = l.second + outer(l.normal, l.center - center) + r.second + outer(r.normal, r.center - center);
    Moments { center, radius: 0.0, normal: l.normal + r.normal, second }
}

/// `u vᵀ` as a column-major matrix: column `j` is `u · v[j]`.
fn outer(u: DVec3, v: DVec3) -> DMat3 {
    DMat3::from_cols(u * v.x, u * v.y, u * v.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An outward-oriented octahedron, the closed surface of `|x|+|y|+|z| ≤ 1`.
    fn octahedron() -> Vec<[DVec3; 3]> {
        let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
        let mut tris = Vec::new();
        for sx in [1.0, -1.0] {
            for sy in [1.0, -1.0] {
                for sz in [1.0, -1.0] {
                    let (a, b, c) = (x * sx, y * sy, z * sz);
                    // Counter-clockwise seen from outside when sx·sy·sz > 0.
                    if sx * sy * sz > 0.0 {
                        tris.push([a, b, c]);
                    } else {
                        tris.push([a, c, b]);
                    }
                }
            }
        }
        tris
    }

    fn exact(tris: &[[DVec3; 3]], q: DVec3) -> f64 {
        tris.iter().map(|&t| solid_angle(t, q)).sum::<f64>() / (4.0 * std::f64::consts::PI)
    }

    #[test]
    fn second_order_far_field_beats_first_order_and_merging_is_exact() {
        let tris = [
            [DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.3, 0.0, 0.05), DVec3::new(0.0, 0.25, 0.1)],
            [DVec3::new(0.3, 0.0, 0.05), DVec3::new(0.3, 0.3, 0.0), DVec3::new(0.0, 0.25, 0.1)],
        ];
        let m = leaf_moments(tris.iter().copied());
        let merged = merge_moments(&leaf_moments(tris[..1].iter().copied()), &leaf_moments(tris[1..].iter().copied()));
        for q in [DVec3::new(2.0, 1.0, 3.0), DVec3::new(0.5, -1.0, 1.0), DVec3::new(4.0, 4.0, -4.0)] {
            let exact: f64 = tris.iter().map(|&t| solid_angle(t, q)).sum();
            let r = m.center - q;
            let second = far_field(&m, r, r.length_squared());
            let first = m.normal.dot(r) / r.length().powi(3);
            assert!((second - exact).abs() < 0.5 * (first - exact).abs());
            assert!((second - exact).abs() < 2e-3 * exact.abs());
            let rm = merged.center - q;
            assert!((far_field(&merged, rm, rm.length_squared()) - exact).abs() < 2e-3 * exact.abs());
        }
    }

    #[test]
    fn closed_surface_gives_one_inside_zero_outside() {
        let tris = octahedron();
        assert!((exact(&tris, DVec3::new(0.1, 0.2, -0.1)) - 1.0).abs() < 1e-12);
        assert!(exact(&tris, DVec3::new(2.0, 0.0, 0.0)).abs() < 1e-12);
    }

    #[test]
    fn hierarchical_matches_exact_on_a_fine_sphere() {
        // A UV sphere with many triangles, so the far field is exercised.
        let (nu, nv) = (64, 32);
        let p = |i: usize, j: usize| {
            let th = std::f64::consts::PI * j as f64 / nv as f64;
            let ph = 2.0 * std::f64::consts::PI * i as f64 / nu as f64;
            DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos())
        };
        let mut tris = Vec::new();
        for i in 0..nu {
            for j in 0..nv {
                let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
                if j > 0 {
                    tris.push([a, c, b]);
                }
                if j + 1 < nv {
                    tris.push([a, d, c]);
                }
            }
        }
        let w = WindingNumber::new(TriangleBvh::new(tris.clone()));
        for q in
            [DVec3::ZERO, DVec3::new(0.5, 0.3, 0.1), DVec3::new(0.0, 0.0, 0.97), DVec3::new(1.5, 0.2, 0.0), DVec3::splat(5.0)]
        {
            let e = exact(&tris, q);
            // The bound the mesher's ±0.05 re-evaluation band relies on, and the strict one.
            let h = w.at(q);
            assert!((e - h).abs() < 0.05, "q={q:?}: exact {e}, tree {h}");
            let strict = w.at_with_accuracy(q, 5.0);
            assert!((e - strict).abs() < 0.01, "q={q:?}: exact {e}, strict tree {strict}");
        }
        // Far outside, every node is accepted early and the result is tiny and accurate.
        assert!(w.at(DVec3::splat(5.0)).abs() < 1e-4);
    }

    #[test]
    fn open_surface_gives_fractional_values() {
        // The upper half of the octahedron: w = ½ at the centre of the open rim's disc.
        let tris: Vec<_> = octahedron().into_iter().filter(|t| t.iter().any(|p| p.z > 0.5)).collect();
        let w = exact(&tris, DVec3::ZERO);
        assert!((w - 0.5).abs() < 1e-12, "{w}");
    }

    /// A closed, consistently oriented surface is a cycle, also as two overlapping copies; one
    /// flipped face or one missing face is not.
    #[test]
    fn cycles_are_closed_consistently_oriented_surfaces() {
        let tet = [[0u32, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];
        assert!(is_cycle(&tet));
        let twice: Vec<[u32; 3]> = tet.iter().copied().chain(tet.iter().map(|t| t.map(|v| v + 4))).collect();
        assert!(is_cycle(&twice));
        let mut flipped = tet;
        flipped[2] = [1, 3, 2];
        assert!(!is_cycle(&flipped));
        assert!(!is_cycle(&tet[..3]));
    }
}
