//! The texels of a UV map: which triangle's UV image holds each texel centre, and where.

use rayon::prelude::*;

/// A covered texel: its index in the image (row-major from the top-left) and the surface point
/// at its centre, as the triangle's three vertices and the barycentric weights of the point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TexelSample {
    /// Index of the texel, `y × width + x` (row 0 at the top).
    pub texel: usize,
    /// The index of the triangle in the list given.
    pub triangle: u32,
    /// The triangle's vertices (the object's vertex numbering).
    pub vertices: [u32; 3],
    /// Barycentric weights of the texel centre in the triangle's UV image (each ≥ 0, sum 1):
    /// the same weights locate the surface point, the map being linear on each triangle.
    pub bary: [f64; 3],
}

/// Every texel whose centre lies in the UV image of a triangle, in texel order: texel (x, y)
/// samples u = (x + ½)/`width`, v = 1 − (y + ½)/`height`. A centre on an edge shared by two
/// triangles (or under overlapping islands) goes to the lowest-numbered triangle; triangles of
/// zero UV area cover nothing; UVs outside [0, 1]² are clipped, not wrapped. `uvs` holds the
/// three corners of each triangle in turn.
#[must_use]
pub fn rasterize(triangles: &[[u32; 3]], uvs: &[[f64; 2]], width: u32, height: u32) -> Vec<TexelSample> {
    let (w, h) = (f64::from(width), f64::from(height));
    // The triangles crossing each row, in triangle order (row y samples v = 1 − (y + ½)/h).
    let mut crossing: Vec<Vec<u32>> = vec![Vec::new(); height as usize];
    for t in 0..triangles.len() {
        let vs = [uvs[3 * t][1], uvs[3 * t + 1][1], uvs[3 * t + 2][1]];
        let (lo, hi) = (vs.iter().copied().fold(f64::INFINITY, f64::min), vs.iter().copied().fold(f64::NEG_INFINITY, f64::max));
        // lo ≤ v ≤ hi ⇔ h(1 − hi) − ½ ≤ y ≤ h(1 − lo) − ½.
        let first = (h * (1.0 - hi) - 0.5).ceil().max(0.0);
        let last = (h * (1.0 - lo) - 0.5).floor().min(h - 1.0);
        if first <= last {
            for row in &mut crossing[first as usize..=last as usize] {
                row.push(t as u32);
            }
        }
    }
    // Each row on its own thread.
    let rows: Vec<Vec<TexelSample>> = crossing
        .into_par_iter()
        .enumerate()
        .map(|(y, crossing)| {
            let v = 1.0 - (y as f64 + 0.5) / h;
            let mut row: Vec<Option<TexelSample>> = vec![None; width as usize];
            for t in crossing {
                let (t, tri) = (t as usize, &triangles[t as usize]);
                let c = [uvs[3 * t], uvs[3 * t + 1], uvs[3 * t + 2]];
                let area = edge(c[0], c[1], c[2]);
                if area == 0.0 {
                    continue;
                }
                let (u0, u1) = (
                    c.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min),
                    c.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max),
                );
                let x0 = ((u0 * w - 0.5).ceil().max(0.0)) as u32;
                let x1 = ((u1 * w - 0.5).floor().min(w - 1.0)).max(-1.0);
                if x1 < 0.0 {
                    continue;
                }
                for x in x0..=x1 as u32 {
                    if row[x as usize].is_some() {
                        continue;
                    }
                    let p = [(f64::from(x) + 0.5) / w, v];
                    let b = [edge(c[1], c[2], p) / area, edge(c[2], c[0], p) / area, edge(c[0], c[1], p) / area];
                    if b.iter().all(|&x| x >= -1e-12) {
                        let b = b.map(|x| x.max(0.0));
                        let sum: f64 = b.iter().sum();
                        row[x as usize] = Some(TexelSample {
                            texel: y * width as usize + x as usize,
                            triangle: t as u32,
                            vertices: *tri,
                            bary: b.map(|x| x / sum),
                        });
                    }
                }
            }
            row.into_iter().flatten().collect()
        })
        .collect();
    rows.into_iter().flatten().collect()
}

/// Twice the signed area of (a, b, p): the edge function of a → b at p.
fn edge(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_triangle_covers_its_area_and_shared_edges_once() {
        // Two triangles splitting [0.1, 0.9]² along its diagonal: together they cover the
        // texels whose centres lie in the square, each once.
        let tris = [[0, 1, 2], [0, 2, 3]];
        let uvs = [[0.1, 0.1], [0.9, 0.1], [0.9, 0.9], [0.1, 0.1], [0.9, 0.9], [0.1, 0.9]];
        let n = 200;
        let texels = rasterize(&tris, &uvs, n, n);
        let inside = |i: u32| {
            let c = (f64::from(i) + 0.5) / f64::from(n);
            (0.1..=0.9).contains(&c)
        };
        let expect = (0..n).filter(|&i| inside(i)).count().pow(2);
        assert_eq!(texels.len(), expect);
        let mut seen = std::collections::HashSet::new();
        assert!(texels.iter().all(|t| seen.insert(t.texel)), "a texel was covered twice");
        // One triangle alone: about half the square, within a row of texels.
        let half = rasterize(&tris[..1], &uvs[..3], n, n).len() as f64;
        assert!((half - expect as f64 / 2.0).abs() <= f64::from(n), "{half} vs {}", expect / 2);
    }

    #[test]
    fn weights_locate_the_texel_centre_and_rows_run_from_the_top() {
        let tris = [[5, 6, 7]];
        let uvs = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        let texels = rasterize(&tris, &uvs, 4, 4);
        for t in &texels {
            let (x, y) = ((t.texel % 4) as f64, (t.texel / 4) as f64);
            let p = [(x + 0.5) / 4.0, 1.0 - (y + 0.5) / 4.0];
            let q: [f64; 2] = std::array::from_fn(|c| (0..3).map(|k| t.bary[k] * uvs[k][c]).sum());
            assert!((p[0] - q[0]).abs() < 1e-12 && (p[1] - q[1]).abs() < 1e-12, "{t:?}");
            assert_eq!(t.vertices, [5, 6, 7]);
        }
        // The lower-left half: the bottom row (y = 3) has texels 0..=2, the top row (y = 0) only 0.
        let rows: Vec<usize> = (0..4).map(|y| texels.iter().filter(|t| t.texel / 4 == y).count()).collect();
        assert_eq!(rows, [1, 2, 3, 4]);
    }

    #[test]
    fn degenerate_and_outside_triangles_cover_nothing() {
        let tris = [[0, 1, 2], [0, 1, 2]];
        let uvs = [[0.2, 0.2], [0.4, 0.4], [0.6, 0.6], [2.0, 2.0], [3.0, 2.0], [2.0, 3.0]];
        assert!(rasterize(&tris, &uvs, 32, 32).is_empty());
    }
}
