//! The irradiance samples xⱼ of the transfer (R. Wang et al. 2008 §3.2: "uniformly distributed
//! surface sample points"), N = 2ⁿ of them so the Haar transform of [`super::haar`] applies, in
//! the leaf order of a balanced k-d tree so that every dyadic block of the order is a compact
//! patch of surface (what the paper's quadtree textures give, without an m-way partition).
//!
//! Each triangle gets its share of the samples by systematic sampling of the cumulative area
//! (counts within one of N·Aₜ/A), each sample at the centroid of its own piece of the triangle
//! (the triangle cut into nₜ pieces of equal area, [`split_into`]: the midpoint rule, second
//! order), weighing aⱼ = Aₜ/nₜ, so every triangle's area is carried exactly; a triangle too small
//! for a sample gives its area to the nearer sample-bearing neighbour in the cumulative order,
//! so Σ aⱼ = A always.

use glam::DVec3;
use rayon::prelude::*;

use crate::light::sampling::hash_combine;
use crate::mesh::area_weighted_normals;

use super::PrtError;

/// The most samples: 2¹⁸ (the precompute's per-thread rows hold K · N values).
pub const MAX_SAMPLES_LOG2: u32 = 18;

/// The irradiance samples of one surface, in k-d tree leaf order.
#[derive(Debug, Clone)]
pub struct SurfaceSamples {
    /// Positions (the surface's units).
    pub positions: Vec<DVec3>,
    /// Unit normals, interpolated from the area-weighted vertex normals (the triangle's normal
    /// where those cancel).
    pub normals: Vec<DVec3>,
    /// The area each sample stands for (the surface's units squared).
    pub areas: Vec<f64>,
    /// The triangle each sample lies on.
    pub triangles: Vec<u32>,
    /// Per triangle, its samples: `by_triangle[start[t]..start[t + 1]]`.
    pub triangle_start: Vec<u32>,
    pub by_triangle: Vec<u32>,
    /// Per triangle, the triangle whose samples carry its area (itself when it has samples).
    pub owner: Vec<u32>,
    /// Per triangle with samples, the triangles whose area its samples carry (its cell: itself
    /// and the sample-less triangles that gave it their area): `cells[cell_start[t]..cell_start[t + 1]]`.
    pub cell_start: Vec<u32>,
    pub cells: Vec<u32>,
    /// Per sample, the corners of its piece of its triangle, barycentric ([`split_into`]).
    pub pieces: Vec<[[f64; 3]; 3]>,
    /// The surface's area-weighted vertex normals (the samples' normals are interpolated
    /// from them).
    pub vertex_normals: Vec<DVec3>,
    /// Per sample, up to [`NEIGHBOURS`] nearest other samples within [`NEIGHBOUR_RADIUS`]
    /// spacings: `neighbours[neighbour_start[j]..neighbour_start[j + 1]]`.
    pub neighbour_start: Vec<u32>,
    pub neighbours: Vec<u32>,
}

/// The most neighbours kept per sample.
pub const NEIGHBOURS: usize = 8;

/// How far a neighbour may lie, in sample spacings √(A/N).
pub const NEIGHBOUR_RADIUS: f64 = 2.0;

impl SurfaceSamples {
    /// 2^`log2` samples of the surface (`positions`, `triangles`), seeded by `seed`.
    ///
    /// # Errors
    /// [`PrtError::Samples`] for `log2` above [`MAX_SAMPLES_LOG2`] or a surface without area.
    pub fn new(positions: &[DVec3], triangles: &[[u32; 3]], log2: u32, seed: u64) -> Result<SurfaceSamples, PrtError> {
        if log2 > MAX_SAMPLES_LOG2 {
            return Err(PrtError::Samples(format!("2^{log2} samples: at most 2^{MAX_SAMPLES_LOG2}")));
        }
        let n = 1usize << log2;
        let tri_area = |t: &[u32; 3]| {
            let [a, b, c] = t.map(|v| positions[v as usize]);
            0.5 * (b - a).cross(c - a).length()
        };
        let areas: Vec<f64> = triangles.iter().map(tri_area).collect();
        let total: f64 = areas.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return Err(PrtError::Samples(format!("the surface's area is {total}: nothing to sample")));
        }
        // Systematic sampling: sample j at cumulative area (j + ξ) A/N.
        let xi = (hash_combine(seed, 0x5EED) >> 11) as f64 / (1u64 << 53) as f64;
        let mut counts = vec![0u32; triangles.len()];
        let mut cumulative = 0.0;
        for (t, &a) in areas.iter().enumerate() {
            let before = (cumulative * n as f64 / total - xi).ceil().max(0.0) as usize;
            cumulative += a;
            let after =
                if t + 1 == areas.len() { n } else { ((cumulative * n as f64 / total - xi).ceil().max(0.0) as usize).min(n) };
            counts[t] = (after - before.min(after)) as u32;
        }
        // The area of each sample: Aₜ/nₜ, plus the area of sample-less triangles next to it.
        let mut extra = vec![0.0; triangles.len()];
        let mut owner: Vec<u32> = (0..triangles.len() as u32).collect();
        let centroid = |t: usize| triangles[t].iter().map(|&v| positions[v as usize]).sum::<DVec3>() / 3.0;
        let bearing: Vec<usize> = (0..triangles.len()).filter(|&t| counts[t] > 0).collect();
        for t in (0..triangles.len()).filter(|&t| counts[t] == 0) {
            let after = bearing.partition_point(|&b| b < t);
            let candidates = [after.checked_sub(1).map(|i| bearing[i]), bearing.get(after).copied()];
            let c = centroid(t);
            let target = candidates
                .into_iter()
                .flatten()
                .min_by(|&a, &b| centroid(a).distance_squared(c).total_cmp(&centroid(b).distance_squared(c)))
                .expect("a sample exists");
            extra[target] += areas[t];
            owner[t] = target as u32;
        }
        let mut cell_start = vec![0u32; triangles.len() + 1];
        for &o in &owner {
            cell_start[o as usize + 1] += 1;
        }
        for t in 0..triangles.len() {
            cell_start[t + 1] += cell_start[t];
        }
        let mut fill = cell_start.clone();
        let mut cells = vec![0u32; triangles.len()];
        for (t, &o) in owner.iter().enumerate() {
            cells[fill[o as usize] as usize] = t as u32;
            fill[o as usize] += 1;
        }
        let vertex_normals = area_weighted_normals(positions, triangles);
        let mut samples = Vec::with_capacity(n);
        for (t, tri) in triangles.iter().enumerate() {
            let count = counts[t] as usize;
            if count == 0 {
                continue;
            }
            let [a, b, c] = tri.map(|v| positions[v as usize]);
            let face = (b - a).cross(c - a).normalize_or_zero();
            let [na, nb, nc] = tri.map(|v| vertex_normals[v as usize]);
            let weight = (areas[t] + extra[t]) / count as f64;
            let mut pieces = Vec::with_capacity(count);
            split_into(count, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [a, b, c], &mut pieces);
            for piece in pieces {
                let [w0, w1, w2] = [0, 1, 2].map(|i| (piece[0][i] + piece[1][i] + piece[2][i]) / 3.0);
                let p = a * w0 + b * w1 + c * w2;
                let normal = (na * w0 + nb * w1 + nc * w2).try_normalize().unwrap_or(face);
                samples.push(Sample { position: p, normal, area: weight, triangle: t as u32, piece });
            }
        }
        debug_assert_eq!(samples.len(), n);
        kd_order(&mut samples);
        let mut triangle_start = vec![0u32; triangles.len() + 1];
        for s in &samples {
            triangle_start[s.triangle as usize + 1] += 1;
        }
        for t in 0..triangles.len() {
            triangle_start[t + 1] += triangle_start[t];
        }
        let mut fill = triangle_start.clone();
        let mut by_triangle = vec![0u32; n];
        for (j, s) in samples.iter().enumerate() {
            let slot = &mut fill[s.triangle as usize];
            by_triangle[*slot as usize] = j as u32;
            *slot += 1;
        }
        let positions: Vec<DVec3> = samples.iter().map(|s| s.position).collect();
        let spacing = (total / n as f64).sqrt();
        let (neighbour_start, neighbours) = nearest_neighbours(&positions, NEIGHBOUR_RADIUS * spacing, NEIGHBOURS);
        Ok(SurfaceSamples {
            positions,
            normals: samples.iter().map(|s| s.normal).collect(),
            areas: samples.iter().map(|s| s.area).collect(),
            triangles: samples.iter().map(|s| s.triangle).collect(),
            triangle_start,
            by_triangle,
            owner,
            cell_start,
            cells,
            pieces: samples.iter().map(|s| s.piece).collect(),
            vertex_normals,
            neighbour_start,
            neighbours,
        })
    }

    /// The number of samples N.
    #[must_use]
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there are none (never: N ≥ 1).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// The samples near sample `j` (up to [`NEIGHBOURS`] within [`NEIGHBOUR_RADIUS`] spacings,
    /// nearest first).
    #[must_use]
    pub fn neighbours_of(&self, j: usize) -> &[u32] {
        &self.neighbours[self.neighbour_start[j] as usize..self.neighbour_start[j + 1] as usize]
    }

    /// The samples on triangle `t`.
    #[must_use]
    pub fn on_triangle(&self, t: usize) -> &[u32] {
        &self.by_triangle[self.triangle_start[t] as usize..self.triangle_start[t + 1] as usize]
    }

    /// The triangles whose area the samples of triangle `t` carry (empty for a triangle without
    /// samples).
    #[must_use]
    pub fn cell(&self, t: usize) -> &[u32] {
        &self.cells[self.cell_start[t] as usize..self.cell_start[t + 1] as usize]
    }

    /// The mean spacing h = √(A/N) (the surface's units).
    #[must_use]
    pub fn spacing(&self) -> f64 {
        (self.areas.iter().sum::<f64>() / self.len() as f64).sqrt()
    }
}

/// `count` pieces of equal area (barycentric corners) of the triangle `piece` (barycentric
/// corners) of the triangle `corners`: the piece is cut from the corner opposite its longest
/// edge at the fraction ⌊count/2⌋/count of that edge, and each part split again. Each sample
/// sits at its piece's centroid, the midpoint rule of its own piece (second order for a smooth
/// integrand, where a random point in the piece is first order).
fn split_into(count: usize, piece: [[f64; 3]; 3], corners: [DVec3; 3], out: &mut Vec<[[f64; 3]; 3]>) {
    if count == 1 {
        out.push(piece);
        return;
    }
    let at = |l: [f64; 3]| corners[0] * l[0] + corners[1] * l[1] + corners[2] * l[2];
    let length = |e: usize| at(piece[(e + 1) % 3]).distance_squared(at(piece[(e + 2) % 3]));
    // The longest edge is opposite corner `o`.
    let o = (0..3).max_by(|&i, &j| length(i).total_cmp(&length(j))).unwrap_or(0);
    let (p, q) = (piece[(o + 1) % 3], piece[(o + 2) % 3]);
    let first = count / 2;
    let f = first as f64 / count as f64;
    let cut = [0, 1, 2].map(|i| p[i] + f * (q[i] - p[i]));
    split_into(first, [piece[o], p, cut], corners, out);
    split_into(count - first, [piece[o], cut, q], corners, out);
}

#[derive(Debug, Clone, Copy)]
struct Sample {
    position: DVec3,
    normal: DVec3,
    area: f64,
    triangle: u32,
    piece: [[f64; 3]; 3],
}

/// Per point, up to `most` nearest other points within `radius`, nearest first, through a
/// uniform grid of cells `radius` wide: (starts, lists) as [`SurfaceSamples::neighbours`].
fn nearest_neighbours(points: &[DVec3], radius: f64, most: usize) -> (Vec<u32>, Vec<u32>) {
    use std::collections::HashMap;
    let cell = |p: DVec3| (p / radius).floor().as_ivec3();
    let mut grid: HashMap<glam::IVec3, Vec<u32>> = HashMap::new();
    for (j, p) in points.iter().enumerate() {
        grid.entry(cell(*p)).or_default().push(j as u32);
    }
    let found: Vec<Vec<u32>> = points
        .par_iter()
        .enumerate()
        .map(|(j, p)| {
            let c = cell(*p);
            let mut near: Vec<(f64, u32)> = Vec::new();
            for dz in -1..=1 {
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        for &i in grid.get(&(c + glam::IVec3::new(dx, dy, dz))).into_iter().flatten() {
                            let d = points[i as usize].distance_squared(*p);
                            if i as usize != j && d <= radius * radius {
                                near.push((d, i));
                            }
                        }
                    }
                }
            }
            near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            near.iter().take(most).map(|n| n.1).collect()
        })
        .collect();
    let mut starts = Vec::with_capacity(points.len() + 1);
    starts.push(0u32);
    let mut lists = Vec::new();
    for f in found {
        lists.extend_from_slice(&f);
        starts.push(lists.len() as u32);
    }
    (starts, lists)
}

/// Sorts `samples` (a power of two of them) into the leaf order of a balanced k-d tree: split
/// at the median of the longest axis of the bounding box, halves recursively.
fn kd_order(samples: &mut [Sample]) {
    if samples.len() <= 1 {
        return;
    }
    let (lo, hi) =
        samples.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), s| (lo.min(s.position), hi.max(s.position)));
    let extent = hi - lo;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let half = samples.len() / 2;
    samples.select_nth_unstable_by(half, |a, b| a.position[axis].total_cmp(&b.position[axis]).then(a.triangle.cmp(&b.triangle)));
    let (left, right) = samples.split_at_mut(half);
    rayon::join(|| kd_order(left), || kd_order(right));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::icosphere;

    /// 2ⁿ samples whose areas sum to the surface's exactly, every triangle's own area carried by
    /// its samples (or by a neighbour's), and each sample on its triangle.
    #[test]
    fn samples_carry_the_area() {
        let sphere = icosphere(10.0, 3);
        for log2 in [6, 10, 12] {
            let s = SurfaceSamples::new(sphere.positions(), sphere.triangles(), log2, 7).unwrap();
            assert_eq!(s.len(), 1 << log2);
            let total: f64 = s.areas.iter().sum();
            assert!((total / sphere.area() - 1.0).abs() < 1e-12, "{total} vs {}", sphere.area());
            for (j, &t) in s.triangles.iter().enumerate() {
                let [a, b, c] = sphere.triangle(t as usize);
                let n = (b - a).cross(c - a);
                assert!((s.positions[j] - a).dot(n).abs() < 1e-9 * n.length());
                assert!(s.on_triangle(t as usize).contains(&(j as u32)));
                assert!(s.normals[j].dot(n) > 0.0);
            }
            // Every triangle belongs to exactly one cell, that of a triangle with samples, whose
            // samples weigh the cell's area.
            let mut seen = vec![0; sphere.triangles().len()];
            for t in 0..sphere.triangles().len() {
                let cell = s.cell(t);
                assert_eq!(cell.is_empty(), s.on_triangle(t).is_empty());
                let area: f64 = cell.iter().map(|&c| sphere_area(&sphere, c as usize)).sum();
                let carried: f64 = s.on_triangle(t).iter().map(|&j| s.areas[j as usize]).sum();
                assert!((area - carried).abs() < 1e-12 * sphere.area());
                for &c in cell {
                    seen[c as usize] += 1;
                    assert_eq!(s.owner[c as usize] as usize, t);
                }
            }
            assert!(seen.iter().all(|&n| n == 1));
            if log2 == 12 {
                // 1280 triangles of nearly equal area, 3.2 samples each: every one has some.
                assert!((0..sphere.triangles().len()).all(|t| !s.on_triangle(t).is_empty()));
            }
        }
    }

    fn sphere_area(mesh: &crate::mesh::TriMesh, t: usize) -> f64 {
        let [a, b, c] = mesh.triangle(t);
        0.5 * (b - a).cross(c - a).length()
    }

    /// The k-d order makes dyadic blocks compact: the 8 blocks of N/8 each span less than the
    /// sphere's diameter; each of the 64 blocks of N/64 (A/64 = 19.6 mm², a disc of 5 mm
    /// across) spans less than 8 mm.
    #[test]
    fn dyadic_blocks_are_compact() {
        let sphere = icosphere(10.0, 4);
        let s = SurfaceSamples::new(sphere.positions(), sphere.triangles(), 12, 1).unwrap();
        for (blocks, bound) in [(8, 20.0), (64, 8.0)] {
            for block in s.positions.chunks(s.len() / blocks) {
                let (lo, hi) = block.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
                assert!((hi - lo).length() < bound, "{blocks} blocks: one spans {}", (hi - lo).length());
            }
        }
    }

    /// The grid's neighbours are the brute force's: the `most` nearest within the radius,
    /// nearest first, never the point itself; and the samples' lists are those of their own
    /// positions.
    #[test]
    fn neighbours_are_the_nearest_within_the_radius() {
        let points: Vec<DVec3> = (0..500u64)
            .map(|i| {
                let h = |k: u64| (hash_combine(i, k) >> 11) as f64 / (1u64 << 53) as f64;
                DVec3::new(h(1), h(2), 0.3 * h(3)) * 10.0
            })
            .collect();
        let (radius, most) = (1.2, 5);
        let (starts, lists) = nearest_neighbours(&points, radius, most);
        for (j, p) in points.iter().enumerate() {
            let mut brute: Vec<(f64, u32)> = (0..points.len() as u32)
                .filter(|&i| i as usize != j)
                .map(|i| (points[i as usize].distance_squared(*p), i))
                .filter(|(d, _)| *d <= radius * radius)
                .collect();
            brute.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let want: Vec<u32> = brute.iter().take(most).map(|b| b.1).collect();
            assert_eq!(&lists[starts[j] as usize..starts[j + 1] as usize], &want[..], "point {j}");
        }
        let sphere = icosphere(10.0, 3);
        let s = SurfaceSamples::new(sphere.positions(), sphere.triangles(), 10, 5).unwrap();
        let (starts, lists) = nearest_neighbours(&s.positions, NEIGHBOUR_RADIUS * s.spacing(), NEIGHBOURS);
        assert_eq!((starts, lists), (s.neighbour_start.clone(), s.neighbours.clone()));
        assert!((0..s.len()).all(|j| !s.neighbours_of(j).is_empty()), "every sample on a sphere has neighbours");
    }

    #[test]
    fn bad_requests_are_named() {
        let sphere = icosphere(1.0, 1);
        assert!(matches!(SurfaceSamples::new(sphere.positions(), sphere.triangles(), 19, 0), Err(PrtError::Samples(_))));
        let flat = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
        assert!(matches!(SurfaceSamples::new(&flat, &[[0, 1, 2]], 4, 0), Err(PrtError::Samples(_))));
    }
}
