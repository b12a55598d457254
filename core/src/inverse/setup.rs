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
    fn bad_patterns_are_named() {
        let p = Pattern::Nodes(vec![[0.0; 3]; 5]);
        assert!(matches!(p.node_values(3, 2, 2, 1.0), Err(InverseError::WrongImageSize { index: 3, found: 5, .. })));
        let p = Pattern::Nodes(vec![[0.0, f64::NAN, 0.0]; 4]);
        assert!(matches!(p.node_values(0, 2, 2, 1.0), Err(InverseError::BadPixel { channel: 1, .. })));
    }
}
