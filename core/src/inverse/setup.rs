//! The acquisition setup (Wang et al. 2008 §4.1): a block on a node grid, lit on its top face
//! (z = max) by M patterns at normal incidence, observed on the same face (front-lit, lit
//! pixels masked with a margin) or on the bottom face (back-lit). Images are node-aligned:
//! pixel (i, j) of an image is the outgoing radiance Lo(x, n) of ARCHITECTURE.md at face node
//! (i, j), x fastest.

use super::error::InverseError;

/// Which face the camera sees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Observation {
    /// The lit face (z = max), as for thick samples; pixels within `margin_mm` of any pixel
    /// with light on it are left out of the fit (design note P13: about 2/σ′t).
    FrontLit {
        /// The margin around lit pixels, mm (≥ 0).
        margin_mm: f64,
    },
    /// The opposite face (z = 0), as for thin samples: every pixel is multiple scattering.
    BackLit,
}

/// A light pattern on the lit face: the transmitted source q (ARCHITECTURE.md's
/// q = ∫ Li (n·ωi) Ft dωi, per channel) as a function on the face.
#[derive(Debug, Clone, PartialEq)]
pub enum Pattern {
    /// q = `q` inside the rectangle [x0, x1] × [y0, y1] (mm, face coordinates from the
    /// block's corner), 0 outside; each node gets the mean over its dual cell, so the same
    /// pattern is the same light on any grid.
    Rect {
        /// [x0, x1, y0, y1], mm.
        rect: [f64; 4],
        /// q inside, per channel.
        q: [f64; 3],
    },
    /// q per lit-face node (x fastest), as a caller's projector image resampled to the nodes.
    Nodes(Vec<[f64; 3]>),
}

impl Pattern {
    /// Region (i, j) of an n × n split of a face of `size_mm` = [width, height], lit with `q`:
    /// the paper's 4 × 4 regions for n = 4.
    #[must_use]
    pub fn grid(n: usize, i: usize, j: usize, size_mm: [f64; 2], q: [f64; 3]) -> Self {
        let n = n.max(1) as f64;
        let (w, h) = (size_mm[0] / n, size_mm[1] / n);
        Self::Rect { rect: [i as f64 * w, (i as f64 + 1.0) * w, j as f64 * h, (j as f64 + 1.0) * h], q }
    }

    /// All n² regions of [`Pattern::grid`], row by row.
    #[must_use]
    pub fn grid_all(n: usize, size_mm: [f64; 2], q: [f64; 3]) -> Vec<Self> {
        (0..n).flat_map(|j| (0..n).map(move |i| Self::grid(n, i, j, size_mm, q))).collect()
    }

    /// q at each node of an `nx` × `ny` face at spacing `h` mm: the dual-cell mean of a
    /// rectangle (exact overlap fraction) or the caller's values.
    ///
    /// # Errors
    /// [`InverseError::WrongImageSize`] for a node list of the wrong length,
    /// [`InverseError::BadPixel`] for a value that is not finite or is negative
    /// (`index` is the pattern's, given by the caller).
    pub fn node_values(&self, index: usize, nx: usize, ny: usize, h: f64) -> Result<Vec<[f64; 3]>, InverseError> {
        match self {
            Self::Rect { rect, q } => {
                check_pixels("pattern", index, std::slice::from_ref(q), true)?;
                if rect.iter().any(|x| !x.is_finite()) {
                    return Err(InverseError::InvalidSetting {
                        what: "pattern rectangle",
                        value: rect.iter().copied().find(|x| !x.is_finite()).unwrap_or(f64::NAN),
                        expected: "finite",
                    });
                }
                let overlap = |i: usize, n: usize, lo: f64, hi: f64| {
                    let a = (i as f64 - 0.5).max(0.0) * h;
                    let b = (i as f64 + 0.5).min((n - 1) as f64) * h;
                    ((hi.min(b) - lo.max(a)).max(0.0)) / (b - a)
                };
                Ok((0..nx * ny)
                    .map(|p| {
                        let f = overlap(p % nx, nx, rect[0], rect[1]) * overlap(p / nx, ny, rect[2], rect[3]);
                        q.map(|q| q * f)
                    })
                    .collect())
            }
            Self::Nodes(v) => {
                if v.len() != nx * ny {
                    return Err(InverseError::WrongImageSize {
                        what: "pattern",
                        index,
                        expected: nx * ny,
                        found: v.len(),
                        nx,
                        ny,
                    });
                }
                check_pixels("pattern", index, v, true)?;
                Ok(v.clone())
            }
        }
    }
}

impl Pattern {
    /// q at each node of the face of an `nx` × `ny` node grid at spacing `h` refined `refine`
    /// times (((nx − 1)·refine + 1) × ((ny − 1)·refine + 1) nodes at h/refine), as the same
    /// light: a rectangle by its exact overlaps on the fine grid, and per-node values as the
    /// piecewise-constant q on the coarse dual cells they stand for, averaged over each fine
    /// dual cell (the same power on both grids).
    ///
    /// # Errors
    /// As [`Pattern::node_values`] on the coarse grid.
    pub fn refined_node_values(
        &self,
        index: usize,
        nx: usize,
        ny: usize,
        h: f64,
        refine: usize,
    ) -> Result<Vec<[f64; 3]>, InverseError> {
        let (fx, fy) = ((nx - 1) * refine + 1, (ny - 1) * refine + 1);
        match self {
            Self::Rect { .. } => self.node_values(index, fx, fy, h / refine as f64),
            Self::Nodes(_) => {
                let coarse = self.node_values(index, nx, ny, h)?;
                let (wx, wy) = (dual_overlaps(nx, refine), dual_overlaps(ny, refine));
                Ok((0..fx * fy)
                    .map(|p| {
                        let mut q = [0.0; 3];
                        for &(k, a) in &wx[p % fx] {
                            for &(l, b) in &wy[p / fx] {
                                for (q, c) in q.iter_mut().zip(coarse[k + nx * l]) {
                                    *q += a * b * c;
                                }
                            }
                        }
                        q
                    })
                    .collect())
            }
        }
    }
}

/// Along one axis of `n` coarse nodes refined `refine` times: for each fine node, the coarse
/// dual cells its own dual cell overlaps and the fraction of it in each (one or two cells,
/// fractions summing to 1). Dual cells are clipped to the face, in units of the fine spacing:
/// fine node i covers [i − ½, i + ½], coarse node k covers [(k − ½)·refine, (k + ½)·refine].
fn dual_overlaps(n: usize, refine: usize) -> Vec<Vec<(usize, f64)>> {
    let last = ((n - 1) * refine) as f64;
    let r = refine as f64;
    (0..=(n - 1) * refine)
        .map(|i| {
            let (a, b) = ((i as f64 - 0.5).max(0.0), (i as f64 + 0.5).min(last));
            (0..n)
                .filter_map(|k| {
                    let (lo, hi) = (((k as f64 - 0.5) * r).max(0.0), ((k as f64 + 0.5) * r).min(last));
                    let overlap = b.min(hi) - a.max(lo);
                    (overlap > 0.0).then(|| (k, overlap / (b - a)))
                })
                .collect()
        })
        .collect()
}

/// An error naming the first pixel that is not finite (or negative, with `nonnegative`).
pub(crate) fn check_pixels(what: &'static str, index: usize, v: &[[f64; 3]], nonnegative: bool) -> Result<(), InverseError> {
    for (pixel, p) in v.iter().enumerate() {
        for (channel, &value) in p.iter().enumerate() {
            if !value.is_finite() || (nonnegative && value < 0.0) {
                return Err(InverseError::BadPixel { what, index, pixel, channel, value });
            }
        }
    }
    Ok(())
}

/// The lit mask of a front-lit image: `true` where a pixel may be fitted, i.e. no node with
/// q > 0 lies within `margin_mm` (Euclidean, on the face) of it.
#[must_use]
pub fn front_mask(q: &[[f64; 3]], nx: usize, ny: usize, h: f64, margin_mm: f64) -> Vec<bool> {
    let r = (margin_mm / h).floor() as isize;
    let r2 = (margin_mm / h) * (margin_mm / h) + 1e-9;
    let mut keep = vec![true; nx * ny];
    for (p, v) in q.iter().enumerate() {
        if v.iter().all(|&x| x <= 0.0) {
            continue;
        }
        let (i, j) = ((p % nx) as isize, (p / nx) as isize);
        for dj in -r..=r {
            for di in -r..=r {
                let (x, y) = (i + di, j + dj);
                if ((di * di + dj * dj) as f64) <= r2 && x >= 0 && y >= 0 && (x as usize) < nx && (y as usize) < ny {
                    keep[x as usize + nx * y as usize] = false;
                }
            }
        }
    }
    keep
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rectangle_on_dual_cells_conserves_its_power() {
        // Σ q_i S_i = q × the rectangle's area when it lies inside the face.
        let (nx, ny, h) = (9, 7, 0.5);
        let p = Pattern::Rect { rect: [0.3, 2.2, 1.0, 2.75], q: [2.0, 1.0, 0.0] };
        let v = p.node_values(0, nx, ny, h).unwrap();
        let mut power = 0.0;
        for (k, q) in v.iter().enumerate() {
            let (i, j) = (k % nx, k / nx);
            let s = h * h * if i == 0 || i == nx - 1 { 0.5 } else { 1.0 } * if j == 0 || j == ny - 1 { 0.5 } else { 1.0 };
            power += q[0] * s;
        }
        assert!((power - 2.0 * 1.9 * 1.75).abs() < 1e-12, "{power}");
    }

    #[test]
    fn grid_patterns_tile_the_face() {
        let (nx, ny, h) = (9, 9, 0.5);
        let all = Pattern::grid_all(4, [4.0, 4.0], [1.0; 3]);
        assert_eq!(all.len(), 16);
        let mut sum = vec![0.0; nx * ny];
        for (m, p) in all.iter().enumerate() {
            for (s, q) in sum.iter_mut().zip(p.node_values(m, nx, ny, h).unwrap()) {
                *s += q[0];
            }
        }
        assert!(sum.iter().all(|&s| (s - 1.0).abs() < 1e-12));
    }

    #[test]
    fn the_mask_keeps_pixels_beyond_the_margin() {
        let (nx, ny) = (7, 1);
        let mut q = vec![[0.0; 3]; 7];
        q[0] = [1.0, 0.0, 0.0];
        let m = front_mask(&q, nx, ny, 0.5, 1.0);
        assert_eq!(m, vec![false, false, false, true, true, true, true]);
    }

    #[test]
    fn per_node_light_refined_keeps_its_power_and_a_dual_cell_rectangle() {
        // A rectangle that is exactly coarse node (3, 2)'s dual cell lights that node alone on
        // the coarse grid; as per-node values refined it must be the same rectangle on the
        // fine grid, whose fine node values come from exact overlaps.
        let (nx, ny, h) = (7, 5, 0.5);
        let rect = Pattern::Rect { rect: [1.25, 1.75, 0.75, 1.25], q: [2.0, 1.0, 0.5] };
        let nodes = Pattern::Nodes(rect.node_values(0, nx, ny, h).unwrap());
        assert_eq!(nodes.node_values(0, nx, ny, h).unwrap().iter().filter(|q| q[0] > 0.0).count(), 1);
        for refine in [1, 2, 3, 4] {
            let want = rect.refined_node_values(0, nx, ny, h, refine).unwrap();
            let got = nodes.refined_node_values(0, nx, ny, h, refine).unwrap();
            assert_eq!(got.len(), ((nx - 1) * refine + 1) * ((ny - 1) * refine + 1));
            for (g, w) in got.iter().zip(&want) {
                assert!((0..3).all(|c| (g[c] - w[c]).abs() < 1e-12), "refine {refine}: {g:?} against {w:?}");
            }
        }
        // Arbitrary per-node light: Σ q S over the face is the same on both grids.
        let power = |q: &[[f64; 3]], nx: usize, ny: usize, h: f64| -> f64 {
            q.iter()
                .enumerate()
                .map(|(k, q)| {
                    let (i, j) = (k % nx, k / nx);
                    let half = |i: usize, n: usize| if i == 0 || i == n - 1 { 0.5 } else { 1.0 };
                    q[1] * h * h * half(i, nx) * half(j, ny)
                })
                .sum()
        };
        let values: Vec<[f64; 3]> = (0..nx * ny).map(|k| [0.0, ((k * 7919) % 13) as f64, 0.0]).collect();
        let coarse = power(&values, nx, ny, h);
        for refine in [2, 3] {
            let fine = Pattern::Nodes(values.clone()).refined_node_values(0, nx, ny, h, refine).unwrap();
            let (fx, fy) = ((nx - 1) * refine + 1, (ny - 1) * refine + 1);
            let p = power(&fine, fx, fy, h / refine as f64);
            assert!((p - coarse).abs() < 1e-12 * coarse, "refine {refine}: {p} against {coarse}");
        }
    }

    #[test]
    fn bad_patterns_are_named() {
        let p = Pattern::Nodes(vec![[0.0; 3]; 5]);
        assert!(matches!(p.node_values(3, 2, 2, 1.0), Err(InverseError::WrongImageSize { index: 3, found: 5, .. })));
        let p = Pattern::Nodes(vec![[0.0, f64::NAN, 0.0]; 4]);
        assert!(matches!(p.node_values(0, 2, 2, 1.0), Err(InverseError::BadPixel { channel: 1, .. })));
    }
}
