//! The triangle rasteriser: clipping, fixed-point triangle setup, binning to tiles, and the
//! per-tile z-buffered coverage of the supersamples.
//!
//! Screen positions are snapped to 1/256 pixel ([`SUBPIXEL_BITS`]) and the edge functions
//! E_ab(p) = (b.x − a.x)(p.y − a.y) − (b.y − a.y)(p.x − a.x) are evaluated in exact `i64`
//! arithmetic, so a sample on an edge shared by two triangles is decided the same way for both:
//! the top-left rule gives it to exactly one of them (no cracks, no double hits). Depth is
//! 1/w (w the view depth), which is affine in screen space; the nearest surface has the largest
//! 1/w, and ties keep the triangle drawn first, so the output does not depend on scheduling.

use glam::DVec3;

use super::camera::CameraFrame;

/// Sub-pixel precision of the snapped vertex positions and sample offsets: 2⁻⁸ pixel.
pub(crate) const SUBPIXEL_BITS: u32 = 8;

/// One pixel in fixed-point units.
pub(crate) const ONE: i64 = 1 << SUBPIXEL_BITS;

/// Half-width of the clip region in normalised device coordinates: triangles are clipped to
/// |x/w|, |y/w| ≤ `GUARD_BAND`, i.e. pixel coordinates in [−W, 2W] × [−H, 2H]. With images up to
/// 2¹⁴ pixels the fixed-point coordinates stay below 2²³ and edge functions below 2⁵⁰, exact in
/// both `i64` and `f64`.
const GUARD_BAND: f64 = 3.0;

/// Side of a square tile in pixels.
pub(crate) const TILE: i32 = 32;

/// Most samples per pixel the rasteriser takes (an 8 × 8 grid).
pub(crate) const MAX_SAMPLES: usize = 64;

/// Marks "no triangle" in the primitive buffer.
pub(crate) const NO_PRIM: u32 = u32::MAX;

/// Object index of the ground plane's triangles.
pub(crate) const GROUND: u32 = u32::MAX;

/// A triangle ready to rasterise: snapped, oriented with a positive area, with the data that
/// shading needs to get back to the original mesh triangle.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ScreenTri {
    /// Fixed-point pixel coordinates of the corners.
    pub x: [i64; 3],
    pub y: [i64; 3],
    /// Twice the signed area in fixed-point units², > 0.
    pub area: i64,
    /// 1/w at the corners.
    pub inv_w: [f64; 3],
    /// Barycentric coordinates, in the original mesh triangle, of each corner (the unit vectors
    /// unless the triangle was clipped).
    pub bary: [DVec3; 3],
    /// Index of the object ([`GROUND`] for the ground plane) and of its triangle.
    pub object: u32,
    pub triangle: u32,
    /// Inclusive pixel bounds [x0, y0, x1, y1], clamped to the rasterised region.
    pub bounds: [i32; 4],
}

impl ScreenTri {
    /// The three edge functions at a fixed-point point, edge k opposite corner k:
    /// E₀ = E_{12}, E₁ = E_{20}, E₂ = E_{01}. At corner k, E_k = area; their sum is the area.
    #[inline]
    pub fn edges_at(&self, px: i64, py: i64) -> [i64; 3] {
        let e = |a: usize, b: usize| (self.x[b] - self.x[a]) * (py - self.y[a]) - (self.y[b] - self.y[a]) * (px - self.x[a]);
        [e(1, 2), e(2, 0), e(0, 1)]
    }

    /// Perspective-correct barycentric coordinates in the *original* triangle at a point given
    /// in fixed-point units (not necessarily on the integer grid): screen weights
    /// b_k = E_k / area, corrected to b_k (1/w_k) / Σ_j b_j (1/w_j), then mapped through the
    /// corners' barycentrics. The edge functions are evaluated in `f64` here (exactly, for points
    /// on the grid: every term is an integer below 2⁵⁰).
    #[inline]
    pub fn barycentric_at(&self, px: f64, py: f64) -> DVec3 {
        let x = self.x.map(|v| v as f64);
        let y = self.y.map(|v| v as f64);
        let e = |a: usize, b: usize| (x[b] - x[a]) * (py - y[a]) - (y[b] - y[a]) * (px - x[a]);
        let q = [e(1, 2) * self.inv_w[0], e(2, 0) * self.inv_w[1], e(0, 1) * self.inv_w[2]];
        let s = q[0] + q[1] + q[2];
        if s.is_nan() || s <= 0.0 {
            // Degenerate (cannot happen inside the triangle); fall back to the centroid.
            return (self.bary[0] + self.bary[1] + self.bary[2]) / 3.0;
        }
        (self.bary[0] * q[0] + self.bary[1] * q[1] + self.bary[2] * q[2]) / s
    }
}

/// The rasterised region and the fixed clipping parameters.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Viewport {
    pub width: i32,
    pub height: i32,
    /// Pixels rasterised beyond each image border (the reconstruction filter's reach).
    pub apron: i32,
    /// Near clipping distance (view depth).
    pub near: f64,
    pub cull_back_faces: bool,
}

/// A polygon vertex during clipping: clip coordinates and barycentrics in the original triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ClipVertex {
    c: DVec3,
    b: DVec3,
}

/// Signed distances of a clip-space point to the five clip planes (≥ 0 inside): the near plane
/// w ≥ near and the guard band |x|, |y| ≤ G w.
#[inline]
fn plane_distances(c: DVec3, near: f64) -> [f64; 5] {
    let gw = GUARD_BAND * c.z;
    [c.z - near, gw - c.x, gw + c.x, gw - c.y, gw + c.y]
}

#[inline]
fn outcode(c: DVec3, near: f64) -> u8 {
    plane_distances(c, near).iter().enumerate().fold(0, |m, (k, d)| if *d < 0.0 { m | (1 << k) } else { m })
}

/// The point where the segment a–b crosses plane `k`, computed from the endpoints in a canonical
/// order so that the two triangles sharing an edge get bit-identical points.
fn intersect(a: ClipVertex, b: ClipVertex, k: usize, near: f64) -> ClipVertex {
    let key = |v: &ClipVertex| v.c.to_array();
    let (a, b) = if key(&a) <= key(&b) { (a, b) } else { (b, a) };
    let da = plane_distances(a.c, near)[k];
    let db = plane_distances(b.c, near)[k];
    let t = da / (da - db);
    ClipVertex { c: a.c + (b.c - a.c) * t, b: a.b + (b.b - a.b) * t }
}

/// Sutherland–Hodgman clipping of a convex polygon (at most 3 + 5 vertices) against plane `k`.
fn clip_polygon(poly: &[ClipVertex], k: usize, near: f64, out: &mut Vec<ClipVertex>) {
    out.clear();
    let Some(&last) = poly.last() else { return };
    let mut prev = last;
    let mut prev_in = plane_distances(prev.c, near)[k] >= 0.0;
    for &cur in poly {
        let cur_in = plane_distances(cur.c, near)[k] >= 0.0;
        if cur_in != prev_in {
            out.push(intersect(prev, cur, k, near));
        }
        if cur_in {
            out.push(cur);
        }
        prev = cur;
        prev_in = cur_in;
    }
}

/// Clips, projects and snaps one mesh triangle (clip coordinates of its corners), appending
/// 0 to 6 screen triangles to `out`.
pub(crate) fn setup_triangle(
    clip: [DVec3; 3],
    object: u32,
    triangle: u32,
    frame: &CameraFrame,
    vp: &Viewport,
    out: &mut Vec<ScreenTri>,
) {
    let codes = clip.map(|c| outcode(c, vp.near));
    if codes[0] & codes[1] & codes[2] != 0 {
        return; // all three corners outside one plane
    }
    let corners = [DVec3::X, DVec3::Y, DVec3::Z];
    if codes[0] | codes[1] | codes[2] == 0 {
        emit(clip, corners, object, triangle, frame, vp, out);
        return;
    }
    let mut poly: Vec<ClipVertex> = (0..3).map(|k| ClipVertex { c: clip[k], b: corners[k] }).collect();
    let mut scratch = Vec::with_capacity(9);
    let crossed = codes[0] | codes[1] | codes[2];
    for k in 0..5 {
        if crossed & (1 << k) != 0 {
            clip_polygon(&poly, k, vp.near, &mut scratch);
            std::mem::swap(&mut poly, &mut scratch);
            if poly.len() < 3 {
                return;
            }
        }
    }
    for i in 1..poly.len() - 1 {
        let (a, b, c) = (poly[0], poly[i], poly[i + 1]);
        emit([a.c, b.c, c.c], [a.b, b.b, c.b], object, triangle, frame, vp, out);
    }
}

/// Projects and snaps a triangle inside the clip region; drops it when it is degenerate after
/// snapping, back-facing and culled, or outside the rasterised region.
fn emit(
    clip: [DVec3; 3],
    bary: [DVec3; 3],
    object: u32,
    triangle: u32,
    frame: &CameraFrame,
    vp: &Viewport,
    out: &mut Vec<ScreenTri>,
) {
    let snap = |v: f64| (v * ONE as f64).round() as i64;
    let mut x = [0i64; 3];
    let mut y = [0i64; 3];
    let mut inv_w = [0f64; 3];
    for k in 0..3 {
        let p = frame.clip_to_pixel(clip[k]);
        x[k] = snap(p.x);
        y[k] = snap(p.y);
        inv_w[k] = 1.0 / clip[k].z;
    }
    let mut bary = bary;
    let mut area = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]);
    if area == 0 {
        return;
    }
    // Pixel y points down, so a triangle that is counter-clockwise seen from the camera (a front
    // face) has a negative area here. Reorder every triangle to a positive area.
    let front = area < 0;
    if front {
        x.swap(1, 2);
        y.swap(1, 2);
        inv_w.swap(1, 2);
        bary.swap(1, 2);
        area = -area;
    }
    if vp.cull_back_faces && !front && object != GROUND {
        return;
    }
    let lo = |v: &[i64; 3]| v.iter().copied().min().unwrap_or(0).div_euclid(ONE);
    let hi = |v: &[i64; 3]| v.iter().copied().max().unwrap_or(0).div_euclid(ONE);
    let (x0, y0) = (lo(&x).max(-i64::from(vp.apron)), lo(&y).max(-i64::from(vp.apron)));
    let x1 = hi(&x).min(i64::from(vp.width - 1 + vp.apron));
    let y1 = hi(&y).min(i64::from(vp.height - 1 + vp.apron));
    if x0 > x1 || y0 > y1 {
        return;
    }
    out.push(ScreenTri {
        x,
        y,
        area,
        inv_w,
        bary,
        object,
        triangle,
        // Within [−apron, dimension + apron), far inside i32.
        bounds: [x0 as i32, y0 as i32, x1 as i32, y1 as i32],
    });
}

/// Sample positions inside a pixel in fixed-point units, [0, [`ONE`]).
pub(crate) fn fixed_offsets(offsets: &[[f64; 2]]) -> Vec<[i64; 2]> {
    offsets.iter().map(|o| o.map(|v| ((v * ONE as f64).round() as i64).clamp(0, ONE - 1))).collect()
}

/// A rectangle of sample storage: pixels [x0, x0 + w) × [y0, y0 + h), `samples` each, with a
/// z-buffer of 1/w and the index of the nearest screen triangle.
#[derive(Debug, Default)]
pub(crate) struct SampleBuffer {
    pub x0: i32,
    pub y0: i32,
    pub w: i32,
    pub h: i32,
    pub samples: usize,
    pub depth: Vec<f64>,
    pub prim: Vec<u32>,
}

impl SampleBuffer {
    /// Resets to an empty region of the given placement.
    pub fn reset(&mut self, x0: i32, y0: i32, w: i32, h: i32, samples: usize) {
        let n = (w * h) as usize * samples;
        self.x0 = x0;
        self.y0 = y0;
        self.w = w;
        self.h = h;
        self.samples = samples;
        self.depth.clear();
        self.depth.resize(n, 0.0);
        self.prim.clear();
        self.prim.resize(n, NO_PRIM);
    }

    /// Index of sample `s` of pixel (px, py) (in image pixel coordinates).
    #[inline]
    pub fn index(&self, px: i32, py: i32, s: usize) -> usize {
        ((py - self.y0) * self.w + (px - self.x0)) as usize * self.samples + s
    }

    /// Rasterises one screen triangle into the buffer: every sample whose position passes the
    /// three edge tests (top-left rule) and whose 1/w is larger than the stored one takes the
    /// triangle's index `id`.
    pub fn rasterise(&mut self, tri: &ScreenTri, id: u32, offsets: &[[i64; 2]]) {
        let px0 = tri.bounds[0].max(self.x0);
        let py0 = tri.bounds[1].max(self.y0);
        let px1 = tri.bounds[2].min(self.x0 + self.w - 1);
        let py1 = tri.bounds[3].min(self.y0 + self.h - 1);
        if px0 > px1 || py0 > py1 {
            return;
        }
        // Edge k runs a → b with (a, b) = (1, 2), (2, 0), (0, 1); E_k(p + (dx, dy)) =
        // E_k(p) + ex_k dx + ey_k dy with ex = −(b.y − a.y), ey = b.x − a.x.
        const EDGES: [(usize, usize); 3] = [(1, 2), (2, 0), (0, 1)];
        let mut ex = [0i64; 3];
        let mut ey = [0i64; 3];
        let mut bias = [0i64; 3];
        for (k, &(a, b)) in EDGES.iter().enumerate() {
            let (dx, dy) = (tri.x[b] - tri.x[a], tri.y[b] - tri.y[a]);
            ex[k] = -dy;
            ey[k] = dx;
            // With positive area and y down, a top edge is horizontal running right (dy = 0,
            // dx > 0) and a left edge runs up (dy < 0). Samples exactly on an edge belong to the
            // triangle only for top and left edges: E ≥ 0 there, E > 0 (E − 1 ≥ 0) elsewhere.
            let top_left = (dy == 0 && dx > 0) || dy < 0;
            bias[k] = if top_left { 0 } else { -1 };
        }
        let ns = offsets.len();
        assert!(ns <= MAX_SAMPLES, "at most {MAX_SAMPLES} samples per pixel");
        // Per-sample offsets of the three edge functions from the pixel's corner, bias included.
        let mut so = [[0i64; 3]; MAX_SAMPLES];
        for (s, o) in offsets.iter().enumerate() {
            for k in 0..3 {
                so[s][k] = ex[k] * o[0] + ey[k] * o[1] + bias[k];
            }
        }
        let area = tri.area as f64;
        let zc = tri.inv_w.map(|iw| iw / area);
        let mut row = tri.edges_at(i64::from(px0) * ONE, i64::from(py0) * ONE);
        for py in py0..=py1 {
            let mut e = row;
            let mut idx = self.index(px0, py, 0);
            for _ in px0..=px1 {
                for so in &so[..ns] {
                    let w0 = e[0] + so[0];
                    let w1 = e[1] + so[1];
                    let w2 = e[2] + so[2];
                    if (w0 | w1 | w2) >= 0 {
                        // 1/w is affine in screen space: Σ_k (E_k/area)(1/w_k), with the
                        // unbiased edge functions.
                        let z = (w0 - bias[0]) as f64 * zc[0] + (w1 - bias[1]) as f64 * zc[1] + (w2 - bias[2]) as f64 * zc[2];
                        if z > self.depth[idx] {
                            self.depth[idx] = z;
                            self.prim[idx] = id;
                        }
                    }
                    idx += 1;
                }
                for k in 0..3 {
                    e[k] += ex[k] * ONE;
                }
            }
            for k in 0..3 {
                row[k] += ey[k] * ONE;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::Camera;

    fn frame(w: u32, h: u32) -> CameraFrame {
        Camera {
            position: DVec3::new(0.0, 0.0, 10.0),
            target: DVec3::ZERO,
            up: DVec3::Y,
            vertical_fov_deg: 60.0,
            width: w,
            height: h,
        }
        .derive()
        .unwrap()
    }

    fn vp(w: i32, h: i32) -> Viewport {
        Viewport { width: w, height: h, apron: 0, near: 1e-3, cull_back_faces: false }
    }

    fn screen(f: &CameraFrame, v: &Viewport, p: [DVec3; 3]) -> Vec<ScreenTri> {
        let mut out = Vec::new();
        setup_triangle(p.map(|q| f.view_to_clip(f.world_to_view(q))), 0, 0, f, v, &mut out);
        out
    }

    /// Number of samples covered when rasterising all `tris` into one buffer, and the largest
    /// number of triangles that claimed any single sample.
    fn coverage(tris: &[ScreenTri], w: i32, h: i32, offsets: &[[i64; 2]]) -> (usize, usize) {
        let mut hits = vec![0usize; (w * h) as usize * offsets.len()];
        for (i, t) in tris.iter().enumerate() {
            let mut buf = SampleBuffer::default();
            buf.reset(0, 0, w, h, offsets.len());
            buf.rasterise(t, i as u32, offsets);
            for (k, p) in buf.prim.iter().enumerate() {
                if *p != NO_PRIM {
                    hits[k] += 1;
                }
            }
        }
        (hits.iter().filter(|&&c| c > 0).count(), hits.iter().copied().max().unwrap_or(0))
    }

    #[test]
    fn front_faces_are_counter_clockwise_from_the_camera() {
        let f = frame(64, 64);
        let v = Viewport { cull_back_faces: true, ..vp(64, 64) };
        let ccw = [DVec3::new(-1.0, -1.0, 0.0), DVec3::new(1.0, -1.0, 0.0), DVec3::new(0.0, 1.0, 0.0)];
        assert_eq!(screen(&f, &v, ccw).len(), 1);
        assert!(screen(&f, &v, [ccw[0], ccw[2], ccw[1]]).is_empty());
        assert_eq!(screen(&f, &vp(64, 64), [ccw[0], ccw[2], ccw[1]]).len(), 1);
    }

    /// A screen triangle from fixed-point corners, oriented to a positive area.
    fn fixed_tri(p: [(i64, i64); 3], w: i32, h: i32) -> ScreenTri {
        let (mut x, mut y) = (p.map(|q| q.0), p.map(|q| q.1));
        let mut area = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]);
        assert_ne!(area, 0);
        if area < 0 {
            x.swap(1, 2);
            y.swap(1, 2);
            area = -area;
        }
        ScreenTri {
            x,
            y,
            area,
            inv_w: [1.0; 3],
            bary: [DVec3::X, DVec3::Y, DVec3::Z],
            object: 0,
            triangle: 0,
            bounds: [0, 0, w - 1, h - 1],
        }
    }

    #[test]
    fn shared_edges_are_watertight() {
        // A jittered 6 × 6 vertex lattice, every vertex exactly on a sample of the 8 × 8 grid
        // (offsets 16 + 32k in 1/256 pixel), so that many samples lie exactly on shared edges
        // and corners. Each sample of the square must be claimed by exactly one triangle.
        let offsets = fixed_offsets(&crate::render::SamplePattern::Grid(8).offsets());
        assert!(offsets.iter().all(|o| o[0] % 32 == 16 && o[1] % 32 == 16));
        let n = 6usize;
        let mut seed = 12345u64;
        let mut jitter = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((seed >> 33) % 41) as i64 - 20
        };
        let mut v = vec![(0i64, 0i64); n * n];
        for j in 0..n {
            for i in 0..n {
                let interior = i > 0 && j > 0 && i < n - 1 && j < n - 1;
                let (jx, jy) = if interior { (jitter(), jitter()) } else { (0, 0) };
                v[j * n + i] = (16 + 1280 * i as i64 + 32 * jx, 16 + 1280 * j as i64 + 32 * jy);
            }
        }
        let mut tris = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let (a, b, c, d) = (v[j * n + i], v[j * n + i + 1], v[(j + 1) * n + i], v[(j + 1) * n + i + 1]);
                if (i + j) % 2 == 0 {
                    tris.push(fixed_tri([a, b, d], 30, 30));
                    tris.push(fixed_tri([a, d, c], 30, 30));
                } else {
                    tris.push(fixed_tri([a, b, c], 30, 30));
                    tris.push(fixed_tri([b, d, c], 30, 30));
                }
            }
        }
        let (covered, max_hits) = coverage(&tris, 30, 30, &offsets);
        assert_eq!(max_hits, 1, "a sample was claimed twice");
        // The square spans [16, 6416) in both directions (top and left edges included):
        // samples 16 + 32m for m in 0..200.
        assert_eq!(covered, 200 * 200);
    }

    #[test]
    fn top_left_rule_on_pixel_aligned_square() {
        // A square with corners exactly on pixel centres (one sample per pixel, at the centre):
        // of the samples on its border only those on the top and left edges are inside.
        let c = |x: f64, y: f64| ((x * ONE as f64) as i64, (y * ONE as f64) as i64);
        let (a, b, cc, d) = (c(2.5, 2.5), c(6.5, 2.5), c(6.5, 6.5), c(2.5, 6.5));
        for tris in [
            [fixed_tri([a, b, cc], 10, 10), fixed_tri([a, cc, d], 10, 10)],
            [fixed_tri([a, b, d], 10, 10), fixed_tri([b, cc, d], 10, 10)],
        ] {
            let (covered, max_hits) = coverage(&tris, 10, 10, &fixed_offsets(&[[0.5, 0.5]]));
            assert_eq!(max_hits, 1);
            // Rows and columns 2..=5: the bottom row and right column (6.5) are outside.
            assert_eq!(covered, 16);
        }
    }

    #[test]
    fn nearer_triangle_wins_and_ties_keep_the_first() {
        // Two screen-filling triangles (split by the guard band into several pieces) at
        // different depths; piece ids 0.. for the far one, 100.. for the near one.
        let f = frame(16, 16);
        let v = vp(16, 16);
        let big = |z: f64| screen(&f, &v, [DVec3::new(-50.0, -50.0, z), DVec3::new(50.0, -50.0, z), DVec3::new(0.0, 50.0, z)]);
        let (far, near) = (big(-1.0), big(1.0));
        let offsets = fixed_offsets(&[[0.5, 0.5]]);
        let draw = |buf: &mut SampleBuffer, tris: &[ScreenTri], base: u32| {
            for (i, t) in tris.iter().enumerate() {
                buf.rasterise(t, base + i as u32, &offsets);
            }
        };
        for near_first in [false, true] {
            let mut buf = SampleBuffer::default();
            buf.reset(0, 0, 16, 16, 1);
            if near_first {
                draw(&mut buf, &near, 100);
                draw(&mut buf, &far, 0);
            } else {
                draw(&mut buf, &far, 0);
                draw(&mut buf, &near, 100);
            }
            assert!(buf.prim.iter().all(|&p| (100..100 + near.len() as u32).contains(&p)));
            // 1/w of the near plane, depth 9 from the camera.
            assert!(buf.depth.iter().all(|&z| (z - 1.0 / 9.0).abs() < 1e-12));
        }
        // Equal depth: the first drawn keeps the samples.
        let mut buf = SampleBuffer::default();
        buf.reset(0, 0, 16, 16, 1);
        draw(&mut buf, &near, 100);
        draw(&mut buf, &near, 200);
        assert!(buf.prim.iter().all(|&p| p < 200));
    }

    #[test]
    fn near_plane_clipping_keeps_the_visible_part() {
        // A long triangle reaching behind the camera: the part in front is still drawn, with
        // barycentrics that interpolate to points on the original triangle.
        let f = frame(32, 32);
        let v = vp(32, 32);
        let p = [DVec3::new(-1.0, -1.0, 0.0), DVec3::new(1.0, -1.0, 0.0), DVec3::new(0.0, -1.0, 30.0)];
        let tris = screen(&f, &v, p);
        assert!(!tris.is_empty());
        for t in &tris {
            for k in 0..3 {
                assert!((t.bary[k].element_sum() - 1.0).abs() < 1e-12);
                assert!(t.bary[k].min_element() >= -1e-12);
                assert!(t.inv_w[k] > 0.0 && t.inv_w[k] <= 1.0 / v.near * (1.0 + 1e-9));
            }
            // The barycentric of a covered sample reconstructs a point on the triangle.
            let (cx, cy) = ((t.x[0] + t.x[1] + t.x[2]) / 3, (t.y[0] + t.y[1] + t.y[2]) / 3);
            let b = t.barycentric_at(cx as f64, cy as f64);
            let q = p[0] * b.x + p[1] * b.y + p[2] * b.z;
            assert!((q.y + 1.0).abs() < 1e-9);
            // And it projects back onto the sample.
            let s = f.clip_to_pixel(f.view_to_clip(f.world_to_view(q)));
            assert!((s.x * ONE as f64 - cx as f64).abs() < 2.0 && (s.y * ONE as f64 - cy as f64).abs() < 2.0);
        }
        // Entirely behind the camera: nothing.
        let behind = p.map(|q| q + DVec3::new(0.0, 0.0, 40.0));
        assert!(screen(&f, &v, behind).is_empty());
    }

    #[test]
    fn guard_band_bounds_huge_triangles() {
        let f = frame(32, 32);
        let v = vp(32, 32);
        let s = 1e9;
        let tris = screen(&f, &v, [DVec3::new(-s, -s, 0.0), DVec3::new(s, -s, 0.0), DVec3::new(0.0, s, 0.0)]);
        assert!(!tris.is_empty());
        for t in &tris {
            for k in 0..3 {
                assert!(t.x[k].abs() <= 3 * 32 * ONE && t.y[k].abs() <= 3 * 32 * ONE);
            }
        }
        let (covered, max_hits) = coverage(&tris, 32, 32, &fixed_offsets(&[[0.5, 0.5]]));
        assert_eq!((covered, max_hits), (32 * 32, 1));
    }
}
