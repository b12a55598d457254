//! How good an acquisition is, for `transcut bench inverse`: the recovered κ and μ (= σa)
//! against the truth by depth and the appearance under held-out lighting (the rendered
//! comparison is the core's [`transcut::lit_face`]).
//!
//! The truth on a cell is the mean of σa and σ′s over the 2 × 2 × 2 finer cells the images
//! were synthesised on ([`truth_on_cells`]), so a cell the vein's edge crosses is held to what
//! the data could show, not to the value at its centre.

use glam::DVec3;
use transcut::inverse::{model::kappa, Acquisition, BlockGrid, CellMedia, Pattern, Setup};

/// The media `truth(p)` on `grid`'s cells: per cell, the mean σa and mean σ′s over its eight
/// half-size sub-cells (the synthesis's 2×-finer cells), each sampled at its centre.
pub fn truth_on_cells(grid: &BlockGrid, truth: &dyn Fn(DVec3) -> ([f64; 3], [f64; 3])) -> CellMedia {
    let h = grid.spacing();
    let (sigma_a, sigma_s_prime) = (0..grid.cell_count())
        .map(|c| {
            let centre = DVec3::from(grid.cell_centre(c));
            let (mut a, mut s) = ([0.0; 3], [0.0; 3]);
            for corner in 0..8 {
                let offset = DVec3::new((corner & 1) as f64, ((corner >> 1) & 1) as f64, (corner >> 2) as f64) - 0.5;
                let (ta, ts) = truth(centre + 0.5 * h * offset);
                for ch in 0..3 {
                    a[ch] += ta[ch] / 8.0;
                    s[ch] += ts[ch] / 8.0;
                }
            }
            (a, s)
        })
        .unzip();
    CellMedia { sigma_a, sigma_s_prime }
}

/// The relative RMS error per channel of `got` against `want`, √(Σ(g − w)²/Σw²) over the
/// pairs: 0 for an empty set.
fn relative_rms<'a>(pairs: impl Iterator<Item = (&'a [f64; 3], &'a [f64; 3])>) -> [f64; 3] {
    let (mut num, mut den) = ([0.0; 3], [0.0; 3]);
    for (g, w) in pairs {
        for c in 0..3 {
            num[c] += (g[c] - w[c]).powi(2);
            den[c] += w[c] * w[c];
        }
    }
    std::array::from_fn(|c| if den[c] > 0.0 { (num[c] / den[c]).sqrt() } else { 0.0 })
}

/// The errors of one layer of cells (or of several, for [`top_errors`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthError {
    /// Depth of the layer's cell centres below the lit face (z = max), mm.
    pub depth_mm: f64,
    /// Relative RMS error of κ = 1/(3(σa + σ′s)) per channel.
    pub kappa: [f64; 3],
    /// Relative RMS error of μ = σa per channel.
    pub mu: [f64; 3],
}

/// κ and μ per cell of `media`.
fn kappa_mu(media: &CellMedia) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let k = media.sigma_a.iter().zip(&media.sigma_s_prime).map(|(a, s)| std::array::from_fn(|c| kappa(a[c], s[c]))).collect();
    (k, media.sigma_a.clone())
}

/// The errors over the cells `chosen` (by index) of `got` against `want`.
fn errors_over(got: &CellMedia, want: &CellMedia, chosen: &[usize], depth_mm: f64) -> DepthError {
    let ((kg, mg), (kw, mw)) = (kappa_mu(got), kappa_mu(want));
    DepthError {
        depth_mm,
        kappa: relative_rms(chosen.iter().map(|&c| (&kg[c], &kw[c]))),
        mu: relative_rms(chosen.iter().map(|&c| (&mg[c], &mw[c]))),
    }
}

/// The cells of layer `k` (from the lit face: 0 is the top layer) of `grid`.
fn layer_cells(grid: &BlockGrid, k: usize) -> Vec<usize> {
    let [cx, cy, cz] = grid.cell_dims();
    let z = cz - 1 - k;
    (0..cx * cy).map(|p| p + cx * cy * z).collect()
}

/// κ and μ errors of `got` against `want` per layer of cells, from the lit face down.
pub fn depth_errors(grid: &BlockGrid, got: &CellMedia, want: &CellMedia) -> Vec<DepthError> {
    let h = grid.spacing();
    (0..grid.cell_dims()[2]).map(|k| errors_over(got, want, &layer_cells(grid, k), (k as f64 + 0.5) * h)).collect()
}

/// κ and μ errors of `got` against `want` over the cells whose centres lie within
/// `depth_mm` of the lit face (at least the top layer); `depth_mm` in the result is the
/// deepest centre taken.
pub fn top_errors(grid: &BlockGrid, got: &CellMedia, want: &CellMedia, depth_mm: f64) -> DepthError {
    let h = grid.spacing();
    let layers = (((depth_mm / h) + 0.5).floor() as usize).clamp(1, grid.cell_dims()[2]);
    let cells: Vec<usize> = (0..layers).flat_map(|k| layer_cells(grid, k)).collect();
    errors_over(got, want, &cells, (layers as f64 - 0.5) * h)
}

/// Relative RMS over all pixels and channels of `media`'s images under `patterns` (the
/// acquisition model of `setup`) against `images`, the independent synthesis of the truth.
///
/// # Errors
/// The model's errors (bad images or patterns, a failed solve).
pub fn appearance_error(setup: &Setup, patterns: &[Pattern], images: &[Vec<[f64; 3]>], media: &CellMedia) -> anyhow::Result<f64> {
    let mut model = Acquisition::new(setup.clone(), patterns, images.to_vec(), None)?;
    let predicted = model.predict(media)?;
    let (mut num, mut den) = (0.0, 0.0);
    for (p, w) in predicted.iter().flatten().zip(images.iter().flatten()) {
        for c in 0..3 {
            num += (p[c] - w[c]).powi(2);
            den += w[c] * w[c];
        }
    }
    Ok((num / den).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use transcut::inverse::{single_node_patterns, with_noise};

    #[test]
    fn a_cell_crossed_by_an_edge_gets_the_mean_of_its_halves() {
        // σa = 1 for x < 0.5, 3 beyond: the cell [0, 1] (h = 1) straddles the edge.
        let grid = BlockGrid::new([3, 2, 2], 1.0).unwrap();
        let m = truth_on_cells(&grid, &|p| ([if p.x < 0.5 { 1.0 } else { 3.0 }; 3], [2.0; 3]));
        assert_eq!(m.sigma_a[0], [2.0; 3]);
        assert_eq!(m.sigma_a[1], [3.0; 3]);
        assert_eq!(m.sigma_s_prime[1], [2.0; 3]);
    }

    #[test]
    fn errors_are_per_layer_from_the_lit_face() {
        // 2 × 1 × 3 cells at h = 0.5; μ 10% high in the top layer only, κ exact in the bottom.
        let grid = BlockGrid::new([3, 2, 4], 0.5).unwrap();
        let want = CellMedia::uniform(grid.cell_count(), [0.1; 3], [1.0; 3]);
        let mut got = want.clone();
        for c in [4, 5] {
            got.sigma_a[c] = [0.11; 3];
        }
        let layers = depth_errors(&grid, &got, &want);
        assert_eq!(layers.len(), 3);
        assert!((layers[0].depth_mm - 0.25).abs() < 1e-12 && (layers[2].depth_mm - 1.25).abs() < 1e-12);
        assert!((layers[0].mu[0] - 0.1).abs() < 1e-12, "{layers:?}");
        // κ = 1/(3 · 1.11) against 1/(3 · 1.1): 1/1.11 · 1.1 − 1.
        assert!((layers[0].kappa[1] - (1.0 - 1.1 / 1.11)).abs() < 1e-12, "{layers:?}");
        assert_eq!((layers[1].mu, layers[2].kappa), ([0.0; 3], [0.0; 3]));
        // The top 1 mm: two layers of equal weight, √(0.1²/2).
        let top = top_errors(&grid, &got, &want, 1.0);
        assert!((top.mu[2] - 0.1 / 2f64.sqrt()).abs() < 1e-12 && (top.depth_mm - 0.75).abs() < 1e-12, "{top:?}");
    }

    #[test]
    fn point_sources_are_single_nodes_spread_over_the_face() {
        let (nx, ny, h) = (5, 3, 0.5);
        let patterns = single_node_patterns(2, nx, ny, h);
        assert_eq!(patterns.len(), 4);
        let lit: Vec<Vec<usize>> = patterns
            .iter()
            .enumerate()
            .map(|(m, p)| {
                let q = p.node_values(m, nx, ny, h).unwrap();
                q.iter()
                    .enumerate()
                    .filter(|(_, v)| v[0] > 0.0)
                    .map(|(i, v)| (i, v[0]))
                    .inspect(|(_, v)| assert!((v - 1.0).abs() < 1e-12))
                    .map(|(i, _)| i)
                    .collect()
            })
            .collect();
        // Columns round(0.25 · 4) = 1 and round(0.75 · 4) = 3; rows round(0.5) = 1 (half away
        // from zero) and round(1.5) = 2: one node each, fully lit.
        assert_eq!(lit, vec![vec![1 + 5], vec![3 + 5], vec![1 + 10], vec![3 + 10]]);
    }

    #[test]
    fn noise_has_the_asked_relative_rms() {
        let images = vec![vec![[2.0, 1.0, 0.5]; 20_000]];
        let noisy = with_noise(&images, 0.01, 3);
        let rms = (noisy[0].iter().flat_map(|p| [p[0] / 2.0 - 1.0, p[1] - 1.0, p[2] / 0.5 - 1.0]).map(|e| e * e).sum::<f64>()
            / 60_000.0)
            .sqrt();
        assert!((rms - 0.01).abs() < 2e-4, "{rms}");
    }
}
