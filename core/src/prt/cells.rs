//! The irradiance of lights with hard shadows over the samples' cells. A sample stands for its
//! piece of surface (its weight aⱼ is the piece's area), so the transfer wants the piece's mean
//! irradiance; the value at its centre is that mean to second order where the light is smooth,
//! but a shadow's edge across the piece makes it all or nothing. On the self-shadowed spot at
//! 2¹⁶ samples those pieces alone put the uncompressed transfer 2.5e-3 off the exact dipole
//! where every piece's mean gives 1.2e-3 (`core/tests/integration/prt.rs`).
//!
//! So q is first taken at every sample's centre, with shadows and, in the same pass, without
//! (the shadow ray decides between them). A sample whose shadowed share differs from a
//! neighbour's ([`super::SurfaceSamples::neighbours_of`]) by more than [`EDGE`] has a shadow's
//! edge nearby, and its value is replaced by the mean over the centres of its piece's four
//! midpoint sub-triangles (the midpoint rule on each quarter; the middle one's centre is the
//! sample's, so three more rays per sample). Lights without hard shadows (area lights, a sun
//! of finite size, environments) are smooth at the pieces' scale and are left to the
//! centre value. [`Light::is_delta`] says which lights have hard shadows.

use glam::DVec3;
use rayon::prelude::*;

use super::SurfaceSamples;
use crate::light::{self, Light, LightError, Poll, SourceOptions};
use crate::mesh::TriangleBvh;

/// The difference in shadowed share between neighbouring samples that marks a shadow's edge
/// (a delta light's share is 0 or 1; a smooth mix of several lights changes by much less than
/// this over one sample spacing).
pub const EDGE: f64 = 0.02;

/// q at the samples under `lights` (the transmitted irradiance of
/// [`light::transmitted_source`]), each sample's value the mean over its piece where a shadow's
/// edge crosses it. `positions` are the surface's vertices and `points` the samples, both in
/// the units of the lights and the occluder; `triangles` the surface's.
///
/// # Errors
/// As [`light::transmitted_source_with`].
#[allow(clippy::too_many_arguments)]
pub fn cell_irradiance(
    samples: &SurfaceSamples,
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    points: &[DVec3],
    lights: &[Light],
    eta: f64,
    occluder: Option<&TriangleBvh>,
    options: &SourceOptions,
    poll: Poll<'_>,
) -> Result<Vec<[f64; 3]>, LightError> {
    let normals = &samples.normals;
    if occluder.is_none() {
        return light::transmitted_source_with(lights, points, normals, eta, None, options, poll);
    }
    let (mut q, free) =
        light::transmitted_source_and_unshadowed(lights, points, normals, eta, occluder, options, &|f| poll(0.7 * f))?;
    let share: Vec<Option<f64>> = q
        .par_iter()
        .zip(&free)
        .map(|(s, f)| {
            let f: f64 = f.iter().sum();
            (f > 0.0).then(|| s.iter().sum::<f64>() / f)
        })
        .collect();
    let edges: Vec<usize> = (0..samples.len())
        .into_par_iter()
        .filter(|&j| {
            share[j].is_some_and(|s| {
                samples.neighbours_of(j).iter().any(|&n| share[n as usize].is_some_and(|t| (s - t).abs() > EDGE))
            })
        })
        .collect();
    if edges.is_empty() {
        return Ok(q);
    }
    let (mut sub_points, mut sub_normals) = (Vec::with_capacity(3 * edges.len()), Vec::with_capacity(3 * edges.len()));
    for &j in &edges {
        let tri = triangles[samples.triangles[j] as usize];
        let corners = tri.map(|v| positions[v as usize]);
        let corner_normals = tri.map(|v| samples.vertex_normals[v as usize]);
        // The middle quarter's centroid is the piece's, the sample itself: its value is q[j].
        for l in &quarter_centroids(samples.pieces[j])[..3] {
            sub_points.push(corners[0] * l[0] + corners[1] * l[1] + corners[2] * l[2]);
            let n = corner_normals[0] * l[0] + corner_normals[1] * l[1] + corner_normals[2] * l[2];
            sub_normals.push(n.try_normalize().unwrap_or(samples.normals[j]));
        }
    }
    let sub =
        light::transmitted_source_with(lights, &sub_points, &sub_normals, eta, occluder, options, &|f| poll(0.7 + 0.3 * f))?;
    for (&j, outer) in edges.iter().zip(sub.chunks_exact(3)) {
        q[j] = [0, 1, 2].map(|c| (outer[0][c] + outer[1][c] + outer[2][c] + q[j][c]) / 4.0);
    }
    Ok(q)
}

/// The barycentric centroids of the four midpoint sub-triangles of the triangle `piece`
/// (barycentric corners): equal areas, so their mean value is the midpoint rule on each quarter.
/// The last, the middle quarter's, is the piece's own centroid.
#[must_use]
pub fn quarter_centroids(piece: [[f64; 3]; 3]) -> [[f64; 3]; 4] {
    let mid = |a: [f64; 3], b: [f64; 3]| [0, 1, 2].map(|i| 0.5 * (a[i] + b[i]));
    let [a, b, c] = piece;
    let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
    let centroid = |p: [f64; 3], q: [f64; 3], r: [f64; 3]| [0, 1, 2].map(|i| (p[i] + q[i] + r[i]) / 3.0);
    [centroid(a, ab, ca), centroid(ab, b, bc), centroid(ca, bc, c), centroid(ab, bc, ca)]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The four quarters' centroids average to the piece's centroid and lie inside it; the last
    /// is the centroid.
    #[test]
    fn quarters_cover_the_piece() {
        let piece = [[0.7, 0.2, 0.1], [0.1, 0.8, 0.1], [0.2, 0.2, 0.6]];
        let quarters = quarter_centroids(piece);
        for i in 0..3 {
            let mean = quarters.iter().map(|q| q[i]).sum::<f64>() / 4.0;
            let centroid = (piece[0][i] + piece[1][i] + piece[2][i]) / 3.0;
            assert!((mean - centroid).abs() < 1e-15);
        }
        for q in quarters {
            assert!((q.iter().sum::<f64>() - 1.0).abs() < 1e-15 && q.iter().all(|x| *x > 0.0));
        }
        // The middle quarter's centroid is the piece's (its value is the sample's own).
        for i in 0..3 {
            assert!((quarters[3][i] - (piece[0][i] + piece[1][i] + piece[2][i]) / 3.0).abs() < 1e-15);
        }
    }

    /// A flat 20 × 20 square under a sun straight above, half of it shadowed by a wall's edge
    /// at x = 0.3 at an angle: the pieces the edge crosses get their lit fraction (to the
    /// quarters' resolution), the others keep their exact point values, and the total Σ aⱼ qⱼ
    /// is closer to the exact E T A_lit than the point values' (the shadow's area is the
    /// transfer's input).
    #[test]
    fn pieces_under_a_shadow_edge_get_their_mean() {
        let positions = [
            DVec3::new(-10.0, -10.0, 0.0),
            DVec3::new(10.0, -10.0, 0.0),
            DVec3::new(10.0, 10.0, 0.0),
            DVec3::new(-10.0, 10.0, 0.0),
        ];
        let triangles = [[0, 1, 2], [0, 2, 3]];
        let samples = SurfaceSamples::new(&positions, &triangles, 10, 3).unwrap();
        // A blocker above everything with x > 0.3 + 0.2 y (a slanted edge).
        let h = 5.0;
        let blocker = vec![
            [DVec3::new(0.3 - 4.0, -20.0, h), DVec3::new(30.0, -20.0, h), DVec3::new(0.3 + 4.0, 20.0, h)],
            [DVec3::new(30.0, -20.0, h), DVec3::new(30.0, 20.0, h), DVec3::new(0.3 + 4.0, 20.0, h)],
        ];
        let bvh = TriangleBvh::new(blocker);
        let sun = [Light::Directional { direction: -DVec3::Z, irradiance: [1.0; 3], angular_diameter_deg: 0.0 }];
        let eta = 1.3;
        let options = SourceOptions::default();
        let none: Poll<'_> = &|_| Ok(());
        let point = light::transmitted_source(&sun, &samples.positions, &samples.normals, eta, Some(&bvh), &options).unwrap();
        let cell =
            cell_irradiance(&samples, &positions, &triangles, &samples.positions, &sun, eta, Some(&bvh), &options, none).unwrap();
        let full = point.iter().map(|q| q[0]).fold(0.0, f64::max);
        let changed = point.iter().zip(&cell).filter(|(a, b)| a[0] != b[0]).count();
        assert!(changed > 10 && changed < samples.len() / 8, "{changed} of {} samples refined", samples.len());
        for (p, c) in point.iter().zip(&cell) {
            assert!(c[0] >= 0.0 && c[0] <= full + 1e-12);
            if p[0] != c[0] {
                assert!([0.0, 0.25, 0.5, 0.75, 1.0].iter().any(|f| (c[0] - f * full).abs() < 1e-12), "{} of {full}", c[0]);
            }
        }
        // Lit: x < 0.3 + 0.2 y over [-10, 10]²: 10.3 × 20 (the edge's mean x is 0.3).
        let exact = full * 10.3 * 20.0;
        let total = |q: &[[f64; 3]]| q.iter().zip(&samples.areas).map(|(q, a)| q[0] * a).sum::<f64>();
        let (point_error, cell_error) = ((total(&point) - exact).abs(), (total(&cell) - exact).abs());
        assert!(cell_error < 0.5 * point_error, "cell {cell_error:.3e}, point {point_error:.3e} of {exact}");
    }
}
