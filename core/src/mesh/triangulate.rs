//! Polygon triangulation.
//!
//! Triangles keep the polygon's winding. Quads are split along the diagonal that lies inside the
//! quad and gives the better-shaped pair of triangles; convex polygons are fanned from the corner
//! that gives the best worst triangle; non-convex polygons are ear-clipped in the plane of their
//! Newell normal, so every triangle lies inside the polygon and the area is preserved.

use glam::{DVec2, DVec3};

/// Polygons with more corners than this are fanned from their first corner when convex instead
/// of searching for the best apex (which costs O(n²)).
const BEST_APEX_MAX_CORNERS: usize = 256;

/// Appends the triangles of polygon `poly` (indices into `pos`, at least 3, no two consecutive
/// corners equal) to `out`. Emits `poly.len() - 2` triangles. Triangles of a polygon whose
/// corners are collinear (or that has zero area) may have zero area; the caller drops those.
pub(crate) fn triangulate(pos: &[DVec3], poly: &[u32], out: &mut Vec<[u32; 3]>) {
    let n = poly.len();
    debug_assert!(n >= 3);
    if n == 3 {
        out.push([poly[0], poly[1], poly[2]]);
        return;
    }
    let p = |i: usize| pos[poly[i] as usize];
    let centroid = (0..n).map(p).sum::<DVec3>() / n as f64;
    let normal = newell_normal((0..n).map(|i| p(i) - centroid));
    let scale2 = (0..n).map(|i| (p(i) - centroid).length_squared()).fold(0.0, f64::max);
    let has_plane = normal.length() > 1e-12 * scale2; // false for NaN too
    if !has_plane {
        // No well-defined plane (collinear corners, or a figure-eight with no net area): any
        // triangulation is as good as another, and zero-area triangles are dropped later.
        fan(poly, 0, out);
        return;
    }
    if n == 4 {
        quad(pos, poly, normal, out);
        return;
    }
    // Project onto the plane: (u, v, normal) is right-handed, so the polygon winds
    // counter-clockwise in (u, v).
    let nn = normal.normalize();
    let u = nn.any_orthonormal_vector();
    let v = nn.cross(u);
    let pts: Vec<DVec2> = (0..n)
        .map(|i| {
            let d = p(i) - centroid;
            DVec2::new(d.dot(u), d.dot(v))
        })
        .collect();
    if is_convex(&pts) {
        let apex = if n <= BEST_APEX_MAX_CORNERS { best_fan_apex(pos, poly) } else { 0 };
        fan(poly, apex, out);
    } else {
        ear_clip(&pts, poly, out);
    }
}

/// Newell's normal of a closed polygon: twice its vector area.
fn newell_normal(points: impl Iterator<Item = DVec3> + Clone) -> DVec3 {
    let first = points.clone().next().unwrap_or(DVec3::ZERO);
    let mut sum = DVec3::ZERO;
    let mut prev: Option<DVec3> = None;
    for q in points {
        if let Some(pp) = prev {
            sum += pp.cross(q);
        }
        prev = Some(q);
    }
    if let Some(last) = prev {
        sum += last.cross(first);
    }
    sum
}

/// Shape quality of a triangle in [0, 1]: 1 for equilateral, 0 for degenerate.
fn quality(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let l2 = (b - a).length_squared() + (c - b).length_squared() + (a - c).length_squared();
    if l2 > 0.0 {
        2.0 * 3f64.sqrt() * (b - a).cross(c - a).length() / l2
    } else {
        0.0
    }
}

fn fan(poly: &[u32], apex: usize, out: &mut Vec<[u32; 3]>) {
    let n = poly.len();
    for k in 1..n - 1 {
        out.push([poly[apex], poly[(apex + k) % n], poly[(apex + k + 1) % n]]);
    }
}

fn best_fan_apex(pos: &[DVec3], poly: &[u32]) -> usize {
    let n = poly.len();
    let p = |i: usize| pos[poly[i % n] as usize];
    let mut best = (0, f64::NEG_INFINITY);
    for apex in 0..n {
        let worst = (1..n - 1).map(|k| quality(p(apex), p(apex + k), p(apex + k + 1))).fold(f64::INFINITY, f64::min);
        if worst > best.1 {
            best = (apex, worst);
        }
    }
    best.0
}

/// Splits a quad along the diagonal inside it; if both are inside (convex or non-planar), along
/// the one giving the better worst triangle.
fn quad(pos: &[DVec3], poly: &[u32], normal: DVec3, out: &mut Vec<[u32; 3]>) {
    let [a, b, c, d] = [0, 1, 2, 3].map(|i| pos[poly[i] as usize]);
    let positive = |x: DVec3, y: DVec3, z: DVec3| (y - x).cross(z - x).dot(normal) > 0.0;
    // Diagonal a–c: (a, b, c), (a, c, d). Diagonal b–d: (a, b, d), (b, c, d).
    let ac_inside = positive(a, b, c) && positive(a, c, d);
    let bd_inside = positive(a, b, d) && positive(b, c, d);
    let use_ac = match (ac_inside, bd_inside) {
        (true, false) => true,
        (false, true) => false,
        _ => quality(a, b, c).min(quality(a, c, d)) >= quality(a, b, d).min(quality(b, c, d)),
    };
    let [i0, i1, i2, i3] = [poly[0], poly[1], poly[2], poly[3]];
    if use_ac {
        out.push([i0, i1, i2]);
        out.push([i0, i2, i3]);
    } else {
        out.push([i0, i1, i3]);
        out.push([i1, i2, i3]);
    }
}

fn cross2(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Convex and simple: every turn is to the left (or straight on) and the boundary turns once.
fn is_convex(pts: &[DVec2]) -> bool {
    let n = pts.len();
    let mut turning = 0.0;
    for i in 0..n {
        let e0 = pts[i] - pts[(i + n - 1) % n];
        let e1 = pts[(i + 1) % n] - pts[i];
        let (c, d) = (cross2(e0, e1), e0.dot(e1));
        if c < 0.0 || (c == 0.0 && d <= 0.0) {
            return false;
        }
        turning += c.atan2(d);
    }
    (turning - std::f64::consts::TAU).abs() < 1e-6
}

/// Ear clipping of a counter-clockwise polygon given by its projected corners `pts`.
///
/// Only corners that are not strictly convex can lie inside an ear, and a convex corner never
/// becomes reflex as ears are clipped, so the candidates that may block an ear are the initially
/// reflex corners; a grid over them makes each ear test look only near the ear. Large polygons
/// then take O(n) tests per clip at worst, and far fewer in practice.
fn ear_clip(pts: &[DVec2], poly: &[u32], out: &mut Vec<[u32; 3]>) {
    let n = pts.len();
    let mut next: Vec<usize> = (0..n).map(|i| (i + 1) % n).collect();
    let mut prev: Vec<usize> = (0..n).map(|i| (i + n - 1) % n).collect();
    let mut removed = vec![false; n];
    let turn = |prev: &[usize], next: &[usize], i: usize| cross2(pts[i] - pts[prev[i]], pts[next[i]] - pts[i]);
    let reflex: Vec<usize> = (0..n).filter(|&i| turn(&prev, &next, i) <= 0.0).collect();
    let grid = PointGrid::new(pts, &reflex);
    let mut remaining = n;
    let mut i = 0;
    let mut misses = 0;
    while remaining > 3 {
        let (a, c) = (prev[i], next[i]);
        let ear =
            turn(&prev, &next, i) > 0.0 && !grid.any_in_triangle(pts, a, i, c, |j| !removed[j] && turn(&prev, &next, j) <= 0.0);
        let clip = if ear {
            Some(i)
        } else {
            misses += 1;
            if misses > remaining {
                // No ear: the polygon intersects itself (or is numerically degenerate). Clip the
                // most convex corner so that the loop ends; no correct answer exists anyway.
                let mut best = (i, f64::NEG_INFINITY);
                let mut j = i;
                for _ in 0..remaining {
                    let t = turn(&prev, &next, j);
                    if t > best.1 {
                        best = (j, t);
                    }
                    j = next[j];
                }
                Some(best.0)
            } else {
                None
            }
        };
        match clip {
            Some(k) => {
                let (a, c) = (prev[k], next[k]);
                out.push([poly[a], poly[k], poly[c]]);
                next[a] = c;
                prev[c] = a;
                removed[k] = true;
                remaining -= 1;
                misses = 0;
                // Go on two corners ahead (as earcut does): clipping corners alternately makes
                // better-shaped triangles than fanning around one corner, and keeps ears small.
                i = next[c];
            }
            None => i = next[i],
        }
    }
    out.push([poly[prev[i]], poly[i], poly[next[i]]]);
}

/// A uniform grid over a subset of the polygon's corners.
struct PointGrid {
    lo: DVec2,
    inv_cell: f64,
    nx: usize,
    ny: usize,
    cells: Vec<Vec<u32>>,
}

impl PointGrid {
    fn new(pts: &[DVec2], members: &[usize]) -> PointGrid {
        let lo = members.iter().fold(DVec2::splat(f64::INFINITY), |m, &j| m.min(pts[j]));
        let hi = members.iter().fold(DVec2::splat(f64::NEG_INFINITY), |m, &j| m.max(pts[j]));
        let extent = (hi - lo).max_element();
        let side = (members.len() as f64).sqrt().ceil().clamp(1.0, 1024.0) as usize;
        let has_extent = extent > 0.0; // false for NaN too
        if members.is_empty() || !has_extent {
            // One cell holds everything.
            let cells = vec![members.iter().map(|&j| j as u32).collect()];
            return PointGrid { lo: DVec2::ZERO, inv_cell: 0.0, nx: 1, ny: 1, cells };
        }
        let inv_cell = side as f64 / extent;
        let mut grid = PointGrid { lo, inv_cell, nx: side, ny: side, cells: vec![Vec::new(); side * side] };
        for &j in members {
            let (cx, cy) = grid.cell(pts[j]);
            grid.cells[cy * grid.nx + cx].push(j as u32);
        }
        grid
    }

    fn cell(&self, p: DVec2) -> (usize, usize) {
        let f = (p - self.lo) * self.inv_cell;
        // Saturating float-to-int casts put outside points in the border cells.
        let cx = (f.x.max(0.0) as usize).min(self.nx - 1);
        let cy = (f.y.max(0.0) as usize).min(self.ny - 1);
        (cx, cy)
    }

    /// Whether any grid member `j` accepted by `active` lies in the triangle `a b c` (inclusive
    /// of its boundary; members at the same place as a corner do not count, so that polygons
    /// touching themselves, as when a hole is bridged to the outline, can still be clipped).
    fn any_in_triangle(&self, pts: &[DVec2], a: usize, b: usize, c: usize, active: impl Fn(usize) -> bool) -> bool {
        let (pa, pb, pc) = (pts[a], pts[b], pts[c]);
        let (x0, y0) = self.cell(pa.min(pb).min(pc));
        let (x1, y1) = self.cell(pa.max(pb).max(pc));
        for cy in y0..=y1 {
            for cx in x0..=x1 {
                for &j in &self.cells[cy * self.nx + cx] {
                    let j = j as usize;
                    if j == a || j == b || j == c || !active(j) {
                        continue;
                    }
                    let q = pts[j];
                    if q != pa && q != pb && q != pc && point_in_triangle(pa, pb, pc, q) {
                        return true;
                    }
                }
            }
        }
        false
    }
}

/// `q` inside or on the boundary of the counter-clockwise triangle `a b c`.
fn point_in_triangle(a: DVec2, b: DVec2, c: DVec2, q: DVec2) -> bool {
    cross2(b - a, q - a) >= 0.0 && cross2(c - b, q - b) >= 0.0 && cross2(a - c, q - c) >= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(points2: &[(f64, f64)]) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        let pos: Vec<DVec3> = points2.iter().map(|&(x, y)| DVec3::new(x, y, 0.0)).collect();
        let poly: Vec<u32> = (0..pos.len() as u32).collect();
        let mut out = Vec::new();
        triangulate(&pos, &poly, &mut out);
        (pos, out)
    }

    fn polygon_area(points2: &[(f64, f64)]) -> f64 {
        let n = points2.len();
        0.5 * (0..n)
            .map(|i| {
                let (a, b) = (points2[i], points2[(i + 1) % n]);
                a.0 * b.1 - a.1 * b.0
            })
            .sum::<f64>()
    }

    /// Even-odd point-in-polygon test.
    fn inside(points2: &[(f64, f64)], q: (f64, f64)) -> bool {
        let n = points2.len();
        let mut c = false;
        for i in 0..n {
            let (a, b) = (points2[i], points2[(i + 1) % n]);
            if (a.1 > q.1) != (b.1 > q.1) && q.0 < (b.0 - a.0) * (q.1 - a.1) / (b.1 - a.1) + a.0 {
                c = !c;
            }
        }
        c
    }

    /// n − 2 triangles, all counter-clockwise (same winding as the polygon), with centroids
    /// inside the polygon, summing to the polygon's area.
    fn check(points2: &[(f64, f64)]) -> Vec<[u32; 3]> {
        let (pos, out) = tri(points2);
        assert_eq!(out.len(), points2.len() - 2);
        let mut area = 0.0;
        for t in &out {
            let [a, b, c] = t.map(|i| pos[i as usize]);
            let z = (b - a).cross(c - a).z;
            assert!(z > 0.0, "triangle {t:?} is not counter-clockwise");
            area += 0.5 * z;
            let g = (a + b + c) / 3.0;
            assert!(inside(points2, (g.x, g.y)), "triangle {t:?} lies outside the polygon");
        }
        let expected = polygon_area(points2);
        assert!((area - expected).abs() <= 1e-12 * expected, "area {area} vs {expected}");
        out
    }

    #[test]
    fn triangle_passes_through() {
        assert_eq!(tri(&[(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)]).1, vec![[0, 1, 2]]);
    }

    #[test]
    fn convex_quad_uses_better_diagonal() {
        // A kite long along x: the short diagonal (1–3) gives better triangles.
        let out = check(&[(0.0, 0.0), (2.0, -0.5), (4.0, 0.0), (2.0, 0.5)]);
        assert_eq!(out, vec![[0, 1, 3], [1, 2, 3]]);
    }

    #[test]
    fn non_convex_quad_uses_inner_diagonal() {
        // Dart: corner 3 is reflex; only diagonal 1–3 lies inside.
        check(&[(0.0, 0.0), (2.0, 1.0), (0.0, 2.0), (0.5, 1.0)]);
        check(&[(0.5, 1.0), (0.0, 0.0), (2.0, 1.0), (0.0, 2.0)]);
    }

    #[test]
    fn l_shaped_hexagon() {
        check(&[(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)]);
        // Every rotation of the corner order.
        let l = [(0.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 1.0), (1.0, 2.0), (0.0, 2.0)];
        for r in 0..6 {
            let mut v = l.to_vec();
            v.rotate_left(r);
            check(&v);
        }
    }

    #[test]
    fn star_polygon() {
        for points in [5, 7, 12] {
            let star: Vec<(f64, f64)> = (0..2 * points)
                .map(|k| {
                    let angle = std::f64::consts::PI * k as f64 / points as f64;
                    let r = if k % 2 == 0 { 1.0 } else { 0.35 };
                    (r * angle.cos(), r * angle.sin())
                })
                .collect();
            check(&star);
        }
    }

    #[test]
    fn comb_and_spiral() {
        // A comb with 5 teeth pointing up (x in [2k, 2k+1], y up to 3) on a base 0 <= y <= 1.
        let mut comb = vec![(0.0, 0.0), (9.0, 0.0)];
        for k in (0..5).rev() {
            let x = f64::from(2 * k + 1);
            comb.extend([(x, 3.0), (x - 1.0, 3.0)]);
            if k > 0 {
                comb.extend([(x - 1.0, 1.0), (x - 2.0, 1.0)]);
            }
        }
        check(&comb);
        // A rectangular spiral.
        let spiral = [
            (0.0, 0.0),
            (6.0, 0.0),
            (6.0, 6.0),
            (1.0, 6.0),
            (1.0, 2.0),
            (4.0, 2.0),
            (4.0, 4.0),
            (3.0, 4.0),
            (3.0, 3.0),
            (2.0, 3.0),
            (2.0, 5.0),
            (5.0, 5.0),
            (5.0, 1.0),
            (0.0, 1.0),
        ];
        check(&spiral);
    }

    #[test]
    fn convex_hexagon_with_collinear_corner_avoids_zero_area() {
        // Corner 1 lies on the edge 0–2; a fan from 0 or 2 would make a zero-area triangle.
        let (pos, out) = tri(&[(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (2.0, 1.0), (1.0, 2.0), (0.0, 1.0)]);
        assert_eq!(out.len(), 4);
        for t in &out {
            let [a, b, c] = t.map(|i| pos[i as usize]);
            assert!((b - a).cross(c - a).z > 1e-9);
        }
    }

    #[test]
    fn tilted_non_convex_polygon_in_3d() {
        // The L-shape rotated out of the xy-plane and reversed (clockwise seen from +z).
        let l = [(0.0, 0.0), (0.0, 2.0), (1.0, 2.0), (1.0, 1.0), (2.0, 1.0), (2.0, 0.0)];
        let rot = glam::DQuat::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 1.1);
        let pos: Vec<DVec3> = l.iter().map(|&(x, y)| rot * DVec3::new(x, y, 0.0) + DVec3::splat(5.0)).collect();
        let poly: Vec<u32> = (0..6).collect();
        let mut out = Vec::new();
        triangulate(&pos, &poly, &mut out);
        assert_eq!(out.len(), 4);
        let normal = rot * DVec3::NEG_Z;
        let mut area = 0.0;
        for t in &out {
            let [a, b, c] = t.map(|i| pos[i as usize]);
            let cr = (b - a).cross(c - a);
            assert!(cr.dot(normal) > 0.0, "winding must follow the polygon");
            area += 0.5 * cr.length();
        }
        assert!((area - 3.0).abs() < 1e-12);
    }

    #[test]
    fn collinear_polygon_gives_n_minus_2_triangles() {
        let (_, out) = tri(&[(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (3.0, 0.0), (4.0, 0.0)]);
        assert_eq!(out.len(), 3);
    }

    #[test]
    fn self_intersecting_polygon_terminates() {
        // A pentagram drawn as five corners (each edge crosses two others).
        let pts: Vec<(f64, f64)> = (0..5)
            .map(|k| {
                let a = std::f64::consts::TAU * (2 * k) as f64 / 5.0;
                (a.cos(), a.sin())
            })
            .collect();
        let (_, out) = tri(&pts);
        assert_eq!(out.len(), 3);
    }
}
