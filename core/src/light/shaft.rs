//! Shaft culling for area lights (Haines & Wallace 1994, "Shaft culling for efficient ray-cast
//! radiosity"): the shaft from a point to a planar convex light is the convex hull of the two.
//! Where no triangle of the scene meets it, no shadow ray from the point to the light can be
//! blocked, so the light is seen whole and needs no rays; where one does, the rays decide.
//!
//! A sun of finite angular size is a cone of directions reaching to infinity; the square
//! pyramid around it ([`Shaft::around_cone`]), out past every occluder, plays the same part.
//!
//! The test is conservative in one direction only: [`Shaft::meets_box`] may say a box meets the
//! shaft when it does not (the traversal then looks inside), [`Shaft::meets_triangle`] is the
//! separating-axis theorem for two convex polytopes (exact, ties counted as meeting), so a shaft
//! declared clear is clear.

use glam::DVec3;

use crate::mesh::TriangleBvh;

/// The convex hull of an apex and a planar convex quadrilateral (a pyramid).
#[derive(Debug, Clone)]
pub(super) struct Shaft {
    /// The apex, then the base's corners in order.
    vertices: [DVec3; 5],
    /// Outward face planes (n, d): inside is n·x ≤ d.
    planes: [(DVec3, f64); 5],
    /// The directions of the eight edges (four from the apex, four around the base).
    edges: [DVec3; 8],
    lo: DVec3,
    hi: DVec3,
    /// Separation below this is not trusted to rounding (a touch counts as meeting).
    slack: f64,
}

impl Shaft {
    /// The shaft from `apex` to the quadrilateral `base` (corners in order around it), or
    /// `None` when the apex lies in the base's plane (no volume: the caller's light is edge-on).
    pub(super) fn new(apex: DVec3, base: [DVec3; 4]) -> Option<Self> {
        let vertices = [apex, base[0], base[1], base[2], base[3]];
        let (lo, hi) = vertices
            .iter()
            .fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
        let scale = (hi - lo).max_element().max(f64::MIN_POSITIVE);
        let centroid = vertices.iter().copied().sum::<DVec3>() / 5.0;
        let base_normal = (base[2] - base[0]).cross(base[3] - base[1]);
        if base_normal.dot(apex - base[0]).abs() <= 1e-12 * base_normal.length() * scale {
            return None;
        }
        let outward = |n: DVec3, on: DVec3| {
            let n = n.normalize();
            let n = if n.dot(centroid - on) > 0.0 { -n } else { n };
            (n, n.dot(on))
        };
        let mut planes = [(DVec3::ZERO, 0.0); 5];
        planes[0] = outward(base_normal, base[0]);
        let mut edges = [DVec3::ZERO; 8];
        for k in 0..4 {
            let (a, b) = (base[k], base[(k + 1) % 4]);
            planes[k + 1] = outward((a - apex).cross(b - apex), apex);
            edges[k] = a - apex;
            edges[k + 4] = b - a;
        }
        Some(Self { vertices, planes, edges, lo, hi, slack: 1e-9 * scale })
    }

    /// The square pyramid from `apex` around the cone of directions within the half-angle
    /// α (`sin_alpha`) of the unit `axis` (`t`, `b`: unit vectors completing it to an
    /// orthonormal frame), out to the axial distance `reach`: it holds every point of the cone
    /// whose distance along the axis is at most `reach` (its cross-section there, a disc of
    /// radius `reach · tan α`, is inscribed in the square base). `None` for a cone of half-angle
    /// 90° or more, or no reach.
    pub(super) fn around_cone(apex: DVec3, axis: DVec3, t: DVec3, b: DVec3, sin_alpha: f64, reach: f64) -> Option<Self> {
        let cos_alpha = (1.0 - sin_alpha * sin_alpha).max(0.0).sqrt();
        if !(cos_alpha > 0.0 && reach > 0.0) {
            return None;
        }
        // The disc's radius, widened by a relative 1e-9 so that rounding keeps it inside.
        let half = reach * sin_alpha / cos_alpha * (1.0 + 1e-9);
        let c = apex + reach * axis;
        Self::new(apex, [c - half * t - half * b, c + half * t - half * b, c + half * t + half * b, c - half * t + half * b])
    }

    /// Whether the box [lo, hi] may meet the shaft: false only when it is outside the shaft's
    /// bounding box or wholly outside one of its face planes.
    pub(super) fn meets_box(&self, lo: DVec3, hi: DVec3) -> bool {
        if (lo - self.slack).cmpgt(self.hi).any() || (hi + self.slack).cmplt(self.lo).any() {
            return false;
        }
        self.planes.iter().all(|&(n, d)| {
            // The box corner furthest against n.
            let near = DVec3::select(n.cmpge(DVec3::ZERO), lo, hi);
            n.dot(near) <= d + self.slack
        })
    }

    /// Whether the triangle meets the shaft (separating-axis theorem: the face normals of both,
    /// and the cross products of their edges).
    pub(super) fn meets_triangle(&self, t: &[DVec3; 3]) -> bool {
        let separated = |axis: DVec3| -> bool {
            let length = axis.length();
            if length <= 1e-300 {
                return false;
            }
            let axis = axis / length;
            let (s0, s1) = self.vertices.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                let x = axis.dot(*v);
                (a.min(x), b.max(x))
            });
            let (t0, t1) = t.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                let x = axis.dot(*v);
                (a.min(x), b.max(x))
            });
            t1 < s0 - self.slack || t0 > s1 + self.slack
        };
        if self.planes.iter().any(|&(n, _)| separated(n)) {
            return false;
        }
        let sides = [t[1] - t[0], t[2] - t[1], t[0] - t[2]];
        if separated(sides[0].cross(sides[1])) {
            return false;
        }
        !sides.iter().any(|s| self.edges.iter().any(|e| separated(s.cross(*e))))
    }

    /// Whether any triangle of `bvh` meets the shaft.
    pub(super) fn blocked_in(&self, bvh: &TriangleBvh) -> bool {
        bvh.any_triangle(|lo, hi| self.meets_box(lo, hi), |t| self.meets_triangle(t))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every point of the cone up to the reach is inside the pyramid's planes; a point just
    /// beyond the cone's rim near the base is outside one of them.
    #[test]
    fn the_pyramid_around_a_cone_holds_the_cone() {
        let axis = DVec3::new(0.3, -0.2, 0.9).normalize();
        let t = axis.any_orthonormal_vector();
        let b = axis.cross(t);
        let (apex, sin_alpha, reach) = (DVec3::new(1.0, 2.0, 3.0), (2.5f64).to_radians().sin(), 40.0);
        let shaft = Shaft::around_cone(apex, axis, t, b, sin_alpha, reach).unwrap();
        let inside = |x: DVec3| shaft.planes.iter().all(|&(n, d)| n.dot(x) <= d + 1e-9);
        let cos_alpha = (1.0 - sin_alpha * sin_alpha).sqrt();
        for i in 0..=16 {
            let phi = std::f64::consts::TAU * f64::from(i) / 16.0;
            for &(s, along) in &[(1.0, 1.0), (1.0, 0.5), (0.5, 0.999), (0.0, 0.3)] {
                // A direction at s·α from the axis, followed to `along` of the reach axially.
                let (sa, ca) = (s * sin_alpha, (1.0 - s * s * sin_alpha * sin_alpha).sqrt());
                let dir = ca * axis + sa * (phi.cos() * t + phi.sin() * b);
                assert!(inside(apex + dir * (along * reach / ca)), "φ = {phi}, s = {s}");
            }
            // Beyond the rim, at the base: outside (the square's corners aside, at 45°).
            let rim = axis + 1.5 * sin_alpha / cos_alpha * (phi.cos() * t + phi.sin() * b);
            if i % 4 == 0 {
                assert!(!inside(apex + rim * (0.99 * reach)), "φ = {phi}");
            }
        }
        assert!(Shaft::around_cone(apex, axis, t, b, 1.0, reach).is_none());
        assert!(Shaft::around_cone(apex, axis, t, b, sin_alpha, 0.0).is_none());
    }

    fn unit_light() -> [DVec3; 4] {
        [DVec3::new(-0.5, -0.5, 2.0), DVec3::new(0.5, -0.5, 2.0), DVec3::new(0.5, 0.5, 2.0), DVec3::new(-0.5, 0.5, 2.0)]
    }

    /// A triangle of size `size` centred at `c` in the plane z = c.z.
    fn flat(c: DVec3, size: f64) -> [DVec3; 3] {
        [c + DVec3::new(-size, -size, 0.0), c + DVec3::new(size, -size, 0.0), c + DVec3::new(0.0, size, 0.0)]
    }

    #[test]
    fn triangles_inside_across_and_beside_the_shaft() {
        let shaft = Shaft::new(DVec3::ZERO, unit_light()).unwrap();
        // Small, in the middle of the shaft; large, crossing it; beside it; behind the apex;
        // beyond the light.
        assert!(shaft.meets_triangle(&flat(DVec3::new(0.0, 0.0, 1.0), 0.01)));
        assert!(shaft.meets_triangle(&flat(DVec3::new(0.0, 0.0, 1.0), 10.0)));
        assert!(!shaft.meets_triangle(&flat(DVec3::new(0.6, 0.0, 1.0), 0.05)));
        assert!(!shaft.meets_triangle(&flat(DVec3::new(0.0, 0.0, -0.1), 10.0)));
        assert!(!shaft.meets_triangle(&flat(DVec3::new(0.0, 0.0, 2.1), 10.0)));
        // At height 1 the shaft is the square |x|, |y| ≤ 0.25: a triangle whose edge from
        // (0.2, 0.3 + e) to (0.3 + e, 0.2) passes just outside its corner (e > 0; no face plane
        // separates it, an edge-cross axis does) or just inside it (e < 0).
        let corner = |e: f64| [DVec3::new(0.2, 0.3 + e, 1.0), DVec3::new(0.3 + e, 0.2, 1.0), DVec3::new(0.4, 0.4, 1.0)];
        assert!(!shaft.meets_triangle(&corner(0.02)));
        assert!(shaft.meets_triangle(&corner(-0.02)));
        // A vertical sheet beside the shaft, parallel to a side face, and one cutting it.
        let sheet = |x: f64| [DVec3::new(x, -5.0, -1.0), DVec3::new(x, 5.0, -1.0), DVec3::new(x, 0.0, 5.0)];
        assert!(!shaft.meets_triangle(&sheet(0.55)));
        assert!(shaft.meets_triangle(&sheet(0.3)));
    }

    #[test]
    fn boxes_are_culled_conservatively() {
        let shaft = Shaft::new(DVec3::ZERO, unit_light()).unwrap();
        assert!(shaft.meets_box(DVec3::new(-0.1, -0.1, 0.9), DVec3::new(0.1, 0.1, 1.1)));
        assert!(!shaft.meets_box(DVec3::new(3.0, 3.0, 0.0), DVec3::new(4.0, 4.0, 1.0)));
        // Inside the shaft's bounding box, outside its side plane x ≤ z/4.
        assert!(!shaft.meets_box(DVec3::new(0.4, -0.1, 0.2), DVec3::new(0.5, 0.1, 0.4)));
        // Every box that holds a triangle meeting the shaft meets it.
        let mut seed = 7u64;
        let mut next = || {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..2000 {
            let c = DVec3::new(2.0 * next() - 1.0, 2.0 * next() - 1.0, 2.5 * next() - 0.25);
            let t = [c, c + 0.3 * DVec3::new(next(), next(), next()), c - 0.3 * DVec3::new(next(), next(), next())];
            let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
            if shaft.meets_triangle(&t) {
                assert!(shaft.meets_box(lo, hi), "{t:?}");
            }
        }
    }

    #[test]
    fn an_edge_on_light_has_no_shaft() {
        assert!(Shaft::new(DVec3::new(3.0, 0.0, 2.0), unit_light()).is_none());
    }
}
