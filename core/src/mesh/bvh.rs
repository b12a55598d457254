//! A bounding-volume hierarchy over triangles: closest-point queries, nearest ray hits, shadow
//! rays and all crossings of a segment.
//!
//! Built top-down with binned surface-area splits; nodes are stored depth-first (left child right
//! after its parent), leaves hold at most [`LEAF_SIZE`] triangles. The tree is also the skeleton of
//! the fast winding-number evaluation in `mesher`, which reads [`TriangleBvh::nodes`].

use glam::DVec3;

const LEAF_SIZE: usize = 4;
const BINS: usize = 12;
/// Traversal stack entries kept off the heap ([`NodeStack`]).
const STACK_INLINE: usize = 64;

/// A point on a triangle mesh: the triangle, its barycentric weights and the point itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Triangle index (in the numbering of the triangles the BVH was built from).
    pub triangle: u32,
    /// Barycentric weights of the triangle's three corners (sum 1, each ≥ 0).
    pub bary: [f64; 3],
    /// The point.
    pub point: DVec3,
    /// Distance from the query point.
    pub distance: f64,
}

/// The nearest intersection of a ray with the triangles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayHit {
    /// Ray parameter: the hit is at `origin + t · direction`.
    pub t: f64,
    /// Triangle index.
    pub triangle: u32,
    /// Barycentric weights of the hit point.
    pub bary: [f64; 3],
}

/// One node of the hierarchy.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Node {
    pub lo: DVec3,
    pub hi: DVec3,
    /// Leaf: first index into `order`; inner: index of the right child (left child is `self + 1`).
    pub start_or_right: u32,
    /// Leaf: number of triangles (> 0); inner: 0.
    pub count: u32,
}

/// A BVH over a fixed set of triangles (positions are copied in).
#[derive(Debug, Clone)]
pub struct TriangleBvh {
    pub(crate) nodes: Vec<Node>,
    /// Triangle ids in leaf order.
    pub(crate) order: Vec<u32>,
    /// Corner positions, indexed by triangle id.
    pub(crate) corners: Vec<[DVec3; 3]>,
}

/// What a ray traversal calls for every triangle it hits: (distance, triangle, barycentrics,
/// the current far limit, which it may lower) → keep going?
type HitVisitor<'a> = dyn FnMut(f64, u32, [f64; 3], &mut f64) -> bool + 'a;

impl TriangleBvh {
    /// Builds the hierarchy over triangles given by corner positions. An empty input gives an
    /// empty tree whose queries find nothing.
    #[must_use]
    pub fn new(corners: Vec<[DVec3; 3]>) -> Self {
        let mut order: Vec<u32> = (0..corners.len() as u32).collect();
        let centroids: Vec<DVec3> = corners.iter().map(|c| (c[0] + c[1] + c[2]) / 3.0).collect();
        let mut nodes = Vec::with_capacity(2 * corners.len() / LEAF_SIZE + 1);
        if !corners.is_empty() {
            build(&corners, &centroids, &mut order, 0, &mut nodes);
        }
        Self { nodes, order, corners }
    }

    /// Builds the hierarchy over indexed triangles.
    #[must_use]
    pub fn from_indexed(positions: &[DVec3], triangles: &[[u32; 3]]) -> Self {
        Self::new(triangles.iter().map(|t| t.map(|i| positions[i as usize])).collect())
    }

    /// The unit normal of triangle `t` (counter-clockwise corners; zero for a degenerate one).
    #[must_use]
    pub fn triangle_normal(&self, t: u32) -> DVec3 {
        let [a, b, c] = self.corners[t as usize];
        (b - a).cross(c - a).normalize_or_zero()
    }

    /// Number of triangles.
    #[must_use]
    pub fn len(&self) -> usize {
        self.corners.len()
    }

    /// Whether there are no triangles.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.corners.is_empty()
    }

    /// The axis-aligned box (lo, hi) around every triangle (the root's), `None` for an empty
    /// tree.
    #[must_use]
    pub fn bounds(&self) -> Option<(DVec3, DVec3)> {
        self.nodes.first().map(|root| (root.lo, root.hi))
    }

    /// The closest point on any triangle to `p`, or `None` for an empty tree.
    #[must_use]
    pub fn closest_point(&self, p: DVec3) -> Option<SurfacePoint> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut best: Option<SurfacePoint> = None;
        let mut best_d2 = f64::INFINITY;
        let mut stack = NodeStack::new((0u32, 0.0f64));
        while let Some((ni, d2)) = stack.pop() {
            if d2 >= best_d2 {
                continue;
            }
            let node = &self.nodes[ni as usize];
            if node.count > 0 {
                for &t in &self.order[node.start_or_right as usize..(node.start_or_right + node.count) as usize] {
                    let (q, bary) = closest_point_on_triangle(p, self.corners[t as usize]);
                    let d2 = (q - p).length_squared();
                    if d2 < best_d2 {
                        best_d2 = d2;
                        best = Some(SurfacePoint { triangle: t, bary, point: q, distance: 0.0 });
                    }
                }
            } else {
                let (l, r) = (ni + 1, node.start_or_right);
                let (dl, dr) = (self.box_distance2(l, p), self.box_distance2(r, p));
                // Visit the nearer child first (pushed last).
                if dl < dr {
                    stack.push((r, dr));
                    stack.push((l, dl));
                } else {
                    stack.push((l, dl));
                    stack.push((r, dr));
                }
            }
        }
        best.map(|mut b| {
            b.distance = best_d2.sqrt();
            b
        })
    }

    /// The nearest hit of the ray `origin + t · dir`, `t ∈ (t_min, t_max)`.
    #[must_use]
    pub fn intersect(&self, origin: DVec3, dir: DVec3, t_min: f64, t_max: f64) -> Option<RayHit> {
        let mut best: Option<RayHit> = None;
        let mut t_far = t_max;
        self.traverse_ray(origin, dir, t_min, &mut t_far, &mut |t, tri, bary, t_far| {
            *t_far = t;
            best = Some(RayHit { t, triangle: tri, bary });
            false
        });
        best
    }

    /// Whether anything blocks the ray `origin + t · dir` for `t ∈ (t_min, t_max)` (shadow rays).
    #[must_use]
    pub fn occluded(&self, origin: DVec3, dir: DVec3, t_min: f64, t_max: f64) -> bool {
        let mut hit = false;
        let mut t_far = t_max;
        self.traverse_ray(origin, dir, t_min, &mut t_far, &mut |_, _, _, _| {
            hit = true;
            true
        });
        hit
    }

    /// Every crossing of the segment `a → b` (parameter `t ∈ [0, 1]`, end points included), sorted
    /// by `t`, appended to `out` as `(t, triangle)`.
    pub fn segment_hits(&self, a: DVec3, b: DVec3, out: &mut Vec<(f64, u32)>) {
        let start = out.len();
        let mut t_far = 1.0 + 1e-12;
        self.traverse_ray(a, b - a, -1e-12, &mut t_far, &mut |t, tri, _, _| {
            out.push((t, tri));
            false
        });
        out[start..].sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
    }

    /// Whether any triangle passes `triangle`, visiting only the nodes whose boxes (lo, hi) pass
    /// `node`: a query for any convex region, `node` conservative (true wherever the region may
    /// meet the box) and `triangle` exact.
    pub fn any_triangle(&self, node: impl Fn(DVec3, DVec3) -> bool, triangle: impl Fn(&[DVec3; 3]) -> bool) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let mut stack = NodeStack::new(0u32);
        while let Some(ni) = stack.pop() {
            let n = &self.nodes[ni as usize];
            if !node(n.lo, n.hi) {
                continue;
            }
            if n.count > 0 {
                let leaf = &self.order[n.start_or_right as usize..(n.start_or_right + n.count) as usize];
                if leaf.iter().any(|&t| triangle(&self.corners[t as usize])) {
                    return true;
                }
            } else {
                stack.push(n.start_or_right);
                stack.push(ni + 1);
            }
        }
        false
    }

    /// Visits triangles hit by the ray within `(t_min, *t_far)`; `visit(t, tri, bary, t_far)`
    /// returns `true` to stop. The visitor may shrink `t_far`.
    fn traverse_ray(&self, origin: DVec3, dir: DVec3, t_min: f64, t_far: &mut f64, visit: &mut HitVisitor<'_>) {
        if self.nodes.is_empty() {
            return;
        }
        let inv = DVec3::ONE / dir;
        let mut stack = NodeStack::new(0u32);
        while let Some(ni) = stack.pop() {
            let node = &self.nodes[ni as usize];
            if !ray_box(origin, inv, node.lo, node.hi, t_min, *t_far) {
                continue;
            }
            if node.count > 0 {
                for &t in &self.order[node.start_or_right as usize..(node.start_or_right + node.count) as usize] {
                    if let Some((tt, bary)) = ray_triangle(origin, dir, self.corners[t as usize]) {
                        if tt > t_min && tt < *t_far && visit(tt, t, bary, t_far) {
                            return;
                        }
                    }
                }
            } else {
                stack.push(node.start_or_right);
                stack.push(ni + 1);
            }
        }
    }

    fn box_distance2(&self, ni: u32, p: DVec3) -> f64 {
        let n = &self.nodes[ni as usize];
        let d = (n.lo - p).max(p - n.hi).max(DVec3::ZERO);
        d.length_squared()
    }
}

/// A traversal's stack of nodes to visit: the first [`STACK_INLINE`] entries on the call
/// stack, deeper ones (only in a degenerate, very deep tree) on the heap, so that a query
/// allocates nothing (a shadow ray is a few hundred nanoseconds; an allocation per ray made the
/// threads queue on the allocator's lock).
struct NodeStack<T: Copy> {
    inline: [T; STACK_INLINE],
    len: usize,
    spill: Vec<T>,
}

impl<T: Copy> NodeStack<T> {
    /// A stack holding `first`.
    fn new(first: T) -> Self {
        Self { inline: [first; STACK_INLINE], len: 1, spill: Vec::new() }
    }

    fn push(&mut self, value: T) {
        if self.len < STACK_INLINE {
            self.inline[self.len] = value;
            self.len += 1;
        } else {
            self.spill.push(value);
        }
    }

    fn pop(&mut self) -> Option<T> {
        if let Some(value) = self.spill.pop() {
            return Some(value);
        }
        self.len = self.len.checked_sub(1)?;
        Some(self.inline[self.len])
    }
}

/// Recursive binned-SAH build over `order[..]`, whose entries start at global offset `offset`.
fn build(corners: &[[DVec3; 3]], centroids: &[DVec3], order: &mut [u32], offset: usize, nodes: &mut Vec<Node>) -> u32 {
    let (lo, hi) = order.iter().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), &t| {
        let c = corners[t as usize];
        (lo.min(c[0]).min(c[1]).min(c[2]), hi.max(c[0]).max(c[1]).max(c[2]))
    });
    let index = nodes.len() as u32;
    nodes.push(Node { lo, hi, start_or_right: offset as u32, count: order.len() as u32 });
    if order.len() <= LEAF_SIZE {
        return index;
    }
    let (clo, chi) = order.iter().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), &t| {
        (lo.min(centroids[t as usize]), hi.max(centroids[t as usize]))
    });
    let extent = chi - clo;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = if extent[axis] <= 0.0 {
        order.len() / 2
    } else {
        sah_partition(corners, centroids, order, axis, clo[axis], extent[axis])
    };
    let (left, right) = order.split_at_mut(mid);
    build(corners, centroids, left, offset, nodes);
    let r = build(corners, centroids, right, offset + mid, nodes);
    nodes[index as usize].start_or_right = r;
    nodes[index as usize].count = 0;
    index
}

/// Partitions `order` along `axis` at the cheapest of the binned surface-area split planes and
/// returns the split position (never 0 or `len`).
fn sah_partition(corners: &[[DVec3; 3]], centroids: &[DVec3], order: &mut [u32], axis: usize, c0: f64, extent: f64) -> usize {
    let bin_of = |t: u32| (((centroids[t as usize][axis] - c0) / extent * BINS as f64) as usize).min(BINS - 1);
    let mut bin_box = [(DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)); BINS];
    let mut bin_count = [0usize; BINS];
    for &t in order.iter() {
        let b = bin_of(t);
        let c = corners[t as usize];
        bin_count[b] += 1;
        bin_box[b].0 = bin_box[b].0.min(c[0]).min(c[1]).min(c[2]);
        bin_box[b].1 = bin_box[b].1.max(c[0]).max(c[1]).max(c[2]);
    }
    let area = |(lo, hi): (DVec3, DVec3)| {
        let d = (hi - lo).max(DVec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    };
    let merge = |a: (DVec3, DVec3), b: (DVec3, DVec3)| (a.0.min(b.0), a.1.max(b.1));
    let empty = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    let mut right_cost = [0.0; BINS];
    let (mut acc, mut n) = (empty, 0);
    for b in (1..BINS).rev() {
        acc = merge(acc, bin_box[b]);
        n += bin_count[b];
        right_cost[b] = if n > 0 { area(acc) * n as f64 } else { 0.0 };
    }
    let (mut best, mut best_cost) = (BINS / 2, f64::INFINITY);
    let (mut acc, mut n) = (empty, 0);
    for b in 1..BINS {
        acc = merge(acc, bin_box[b - 1]);
        n += bin_count[b - 1];
        let cost = if n > 0 { area(acc) * n as f64 } else { 0.0 } + right_cost[b];
        if n > 0 && n < order.len() && cost < best_cost {
            best_cost = cost;
            best = b;
        }
    }
    let mut mid = 0;
    for i in 0..order.len() {
        if bin_of(order[i]) < best {
            order.swap(i, mid);
            mid += 1;
        }
    }
    if mid == 0 || mid == order.len() {
        order.len() / 2
    } else {
        mid
    }
}

/// Slab test of a ray against a box within `(t_min, t_max)`.
fn ray_box(origin: DVec3, inv: DVec3, lo: DVec3, hi: DVec3, t_min: f64, t_max: f64) -> bool {
    let a = (lo - origin) * inv;
    let b = (hi - origin) * inv;
    // NaN (0 · ∞ for a ray in a box face plane) is treated as "inside the slab" by min/max order.
    let t0 = a.min(b).max_element().max(t_min);
    let t1 = a.max(b).min_element().min(t_max);
    t0 <= t1 * (1.0 + 4.0 * f64::EPSILON) + 1e-300
}

/// Möller–Trumbore ray/triangle intersection (two-sided): `(t, barycentrics)`.
pub(crate) fn ray_triangle(origin: DVec3, dir: DVec3, c: [DVec3; 3]) -> Option<(f64, [f64; 3])> {
    let e1 = c[1] - c[0];
    let e2 = c[2] - c[0];
    let pv = dir.cross(e2);
    let det = e1.dot(pv);
    if det.abs() < 1e-300 {
        return None;
    }
    let inv = 1.0 / det;
    let tv = origin - c[0];
    let u = tv.dot(pv) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qv = tv.cross(e1);
    let v = dir.dot(qv) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some((e2.dot(qv) * inv, [1.0 - u - v, u, v]))
}

/// Closest point on a triangle to `p` (Ericson, Real-Time Collision Detection §5.1.5) and its
/// barycentric weights.
pub(crate) fn closest_point_on_triangle(p: DVec3, [a, b, c]: [DVec3; 3]) -> (DVec3, [f64; 3]) {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + v * ab, [1.0 - v, v, 0.0]);
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + w * ac, [1.0 - w, 0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + w * (c - b), [0.0, 1.0 - w, w]);
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    (a + ab * v + ac * w, [1.0 - v - w, v, w])
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn random_soup(n: usize, seed: u64) -> Vec<[DVec3; 3]> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut r = || DVec3::new(rng.random(), rng.random(), rng.random());
        (0..n)
            .map(|_| {
                let c = r() * 10.0;
                [c, c + r() - 0.5, c + r() - 0.5]
            })
            .collect()
    }

    #[test]
    fn node_stack_is_last_in_first_out_past_its_inline_part() {
        let mut stack = NodeStack::new(0u32);
        for v in 1..200 {
            stack.push(v);
        }
        for v in (0..200).rev() {
            assert_eq!(stack.pop(), Some(v));
        }
        assert_eq!(stack.pop(), None);
        stack.push(7);
        assert_eq!((stack.pop(), stack.pop()), (Some(7), None));
    }

    #[test]
    fn closest_point_matches_brute_force() {
        let tris = random_soup(500, 1);
        let bvh = TriangleBvh::new(tris.clone());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        for _ in 0..200 {
            let p = DVec3::new(rng.random(), rng.random(), rng.random()) * 12.0 - 1.0;
            let brute = tris.iter().map(|&t| (closest_point_on_triangle(p, t).0 - p).length()).fold(f64::INFINITY, f64::min);
            let got = bvh.closest_point(p).unwrap();
            assert!((got.distance - brute).abs() < 1e-12);
            let [a, b, c] = tris[got.triangle as usize];
            let q = a * got.bary[0] + b * got.bary[1] + c * got.bary[2];
            assert!((q - got.point).length() < 1e-9);
        }
    }

    #[test]
    fn any_triangle_matches_brute_force() {
        let tris = random_soup(400, 5);
        let bvh = TriangleBvh::new(tris.clone());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(6);
        let (mut some, mut none) = (0, 0);
        for _ in 0..300 {
            // A ball: boxes within its radius, triangles with a corner inside it.
            let (c, r) = (DVec3::new(rng.random(), rng.random(), rng.random()) * 12.0 - 1.0, 0.6);
            let near_box = |lo: DVec3, hi: DVec3| (c.clamp(lo, hi) - c).length() <= r;
            let inside = |t: &[DVec3; 3]| t.iter().any(|v| (*v - c).length() <= r);
            let want = tris.iter().any(inside);
            assert_eq!(bvh.any_triangle(near_box, inside), want);
            if want {
                some += 1;
            } else {
                none += 1;
            }
        }
        assert!(some > 20 && none > 20, "{some} balls with a corner, {none} without");
    }

    #[test]
    fn rays_match_brute_force() {
        let tris = random_soup(400, 3);
        let bvh = TriangleBvh::new(tris.clone());
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        for _ in 0..200 {
            let o = DVec3::new(rng.random(), rng.random(), rng.random()) * 10.0;
            let d = DVec3::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
            let brute = tris
                .iter()
                .filter_map(|&t| ray_triangle(o, d, t).map(|h| h.0))
                .filter(|&t| t > 0.0 && t < 5.0)
                .fold(f64::INFINITY, f64::min);
            let hit = bvh.intersect(o, d, 0.0, 5.0);
            assert_eq!(hit.is_some(), brute.is_finite());
            if let Some(h) = hit {
                assert!((h.t - brute).abs() < 1e-12);
            }
            assert_eq!(bvh.occluded(o, d, 0.0, 5.0), brute.is_finite());
            let mut all = Vec::new();
            bvh.segment_hits(o, o + d * 5.0, &mut all);
            let n = tris.iter().filter_map(|&t| ray_triangle(o, d * 5.0, t)).filter(|h| (0.0..=1.0).contains(&h.0)).count();
            assert_eq!(all.len(), n);
            assert!(all.windows(2).all(|w| w[0].0 <= w[1].0));
        }
    }
}
