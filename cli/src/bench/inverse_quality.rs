//! How good an acquisition is, for `transcut bench inverse`: the recovered κ and μ (= σa)
//! against the truth by depth, the appearance under held-out lighting, the recovered grid
//! rendered by TransCut against the truth, and the noise added to the images of the noisy
//! repeat.
//!
//! The truth on a cell is the mean of σa and σ′s over the 2 × 2 × 2 finer cells the images
//! were synthesised on ([`truth_on_cells`]), so a cell the vein's edge crosses is held to what
//! the data could show, not to the value at its centre.

use glam::DVec3;
use transcut::gpu::Backend;
use transcut::inverse::{model::kappa, to_voxel_grid, Acquisition, BlockGrid, CellMedia, Pattern, Setup};
use transcut::light::Light;
use transcut::mesh::gridded_box;
use transcut::volume::{Coefficients, VoxelGrid};
use transcut::{bake, BakeOptions, MediumSource, Object, Scene, Shape, TransCutOptions};

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

/// The lights of the rendered comparison on a block of `size` mm lit on its top face: a sun
/// straight down (the whole face), and a spot from twice the face's width above, aimed at
/// (0.5, 0.7) of the face with a cone a quarter of the width across there (light that spreads
/// sideways under the face, across the vein).
pub fn lit_face_lights(size: DVec3) -> [(&'static str, Light); 2] {
    let height = 2.0 * size.x;
    [
        ("sun", Light::Directional { direction: DVec3::NEG_Z, irradiance: [1.0; 3], angular_diameter_deg: 0.0 }),
        (
            "spot",
            Light::Spot {
                position: DVec3::new(0.5 * size.x, 0.7 * size.y, size.z + height),
                direction: DVec3::NEG_Z,
                intensity: [1.0; 3],
                cone_half_angle_deg: (0.125 * size.x / height).atan().to_degrees(),
                blend: 0.2,
            },
        ),
    ]
}

/// Lo at the top-face vertices of the box [0, `size`] mm (faces gridded at `divisions`) filled
/// with `grid` (η `eta`, g 0) under `light`: TransCut's bake of the scene with `tets` tets on
/// the CPU, solves to 1e-10.
///
/// # Errors
/// The bake's (a grid or setting the scene refuses, a failed solve).
fn lit_face_radiance(
    size: DVec3,
    divisions: [usize; 3],
    grid: VoxelGrid,
    eta: f64,
    light: Light,
    tets: usize,
) -> anyhow::Result<Vec<[f64; 3]>> {
    let mesh = gridded_box(size, divisions);
    let top: Vec<bool> =
        mesh.user_to_internal().iter().map(|&v| (mesh.positions()[v as usize].z - size.z).abs() < 1e-9 * size.z).collect();
    let object = Object::with_shape("block", Shape::Surface(mesh), MediumSource::Voxels { grid, eta, g: 0.0 }, 1.0);
    let options = BakeOptions::with_method(TransCutOptions {
        tets,
        tolerance: 1e-10,
        backend: Some(Backend::Cpu),
        ..TransCutOptions::default()
    });
    let baked = bake(&Scene { objects: vec![object], lights: vec![light] }, &options)?;
    Ok(baked.objects[0].radiance.iter().zip(&top).filter(|(_, &t)| t).map(|(l, _)| *l).collect())
}

/// The truth `truth(p)` as a voxel grid on the 2×-finer cells of `setup`'s block (the cells the
/// images were synthesised on), corner at the origin, mm.
///
/// # Errors
/// Values the voxel grid refuses.
pub fn fine_truth_voxels(setup: &Setup, truth: &(dyn Fn(DVec3) -> ([f64; 3], [f64; 3]) + Sync)) -> anyhow::Result<VoxelGrid> {
    let cells = setup.dims.map(|d| 2 * (d as u32 - 1));
    Ok(VoxelGrid::from_fn(cells, DVec3::ZERO, DVec3::splat(0.5 * setup.spacing_mm), |p| {
        let (a, s) = truth(p);
        Coefficients::new(a, s)
    })?)
}

/// Relative RMS, over all channels, of TransCut's Lo over the lit face of `setup`'s block
/// filled with `media` on the fit's cells against the same block filled with `truth` (see
/// [`fine_truth_voxels`]); one per light of [`lit_face_lights`], named.
///
/// # Errors
/// The bakes'.
pub fn rendered_errors(
    setup: &Setup,
    truth: &VoxelGrid,
    media: &CellMedia,
    tets: usize,
) -> anyhow::Result<Vec<(&'static str, f64)>> {
    let grid = BlockGrid::new(setup.dims, setup.spacing_mm)?;
    let cells = grid.cell_dims();
    let size = DVec3::from(cells.map(|c| c as f64 * setup.spacing_mm));
    let recovered = to_voxel_grid(&grid, media, DVec3::ZERO, 1.0)?;
    lit_face_lights(size)
        .into_iter()
        .map(|(name, light)| {
            let want = lit_face_radiance(size, cells, truth.clone(), setup.eta, light.clone(), tets)?;
            let got = lit_face_radiance(size, cells, recovered.clone(), setup.eta, light, tets)?;
            let (num, den) = got
                .iter()
                .zip(&want)
                .flat_map(|(g, w)| (0..3).map(move |c| ((g[c] - w[c]).powi(2), w[c] * w[c])))
                .fold((0.0, 0.0), |(n, d), (a, b)| (n + a, d + b));
            Ok((name, (num / den).sqrt()))
        })
        .collect()
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
