//! How an acquired material looks: TransCut's rendering of an acquisition's block, filled with
//! the recovered cells, against the same block filled with the truth (J. Wang et al. 2008 §4
//! judge an acquisition by its renderings; the goal is 5% RMS over the lit face).
//!
//! The block is [0, size] mm, its faces gridded at the fit's cells, lit on its top face
//! (z = max) by [`lit_face_lights`]; Lo is compared at the top face's vertices. It sits above
//! both [`crate::inverse`] (the cells) and [`crate::bake()`] (the rendering), which is why it is
//! not part of `inverse`.

use glam::DVec3;

use crate::bake::bake;
use crate::gpu::Backend;
use crate::inverse::{to_voxel_grid, BlockGrid, CellMedia, InverseError, Setup};
use crate::light::Light;
use crate::mesh::gridded_box;
use crate::scene::{BakeOptions, MediumSource, Object, Scene, SceneError, Shape, TransCutOptions};
use crate::volume::{Coefficients, VolumeError, VoxelGrid};

/// Why a rendered comparison failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LitFaceError {
    /// The acquisition's grid or cells.
    #[error(transparent)]
    Inverse(#[from] InverseError),
    /// A voxel grid refused the values.
    #[error(transparent)]
    Volume(#[from] VolumeError),
    /// The bake.
    #[error(transparent)]
    Scene(#[from] SceneError),
}

/// The two lights of the comparison on a block of `size` mm lit on its top face: a sun
/// straight down (the whole face), and a spot from twice the face's width above, aimed
/// straight down at (0.5, 0.7) of the face with a cone a quarter of the width across there
/// (light that spreads sideways under the face).
#[must_use]
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

/// Lo at the top-face vertices of the box [0, `size`] mm (faces gridded at `divisions`)
/// filled with `grid` (η `eta`, g 0) under `light`: TransCut's bake with `tets` tets on the
/// CPU, solved to 1e-10.
///
/// # Errors
/// The bake's (a grid or setting the scene refuses, a failed solve).
pub fn lit_face_radiance(
    size: DVec3,
    divisions: [usize; 3],
    grid: VoxelGrid,
    eta: f64,
    light: Light,
    tets: usize,
) -> Result<Vec<[f64; 3]>, SceneError> {
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

/// The truth `truth(p)` (p in mm from the block's corner) as a voxel grid on the 2×-finer
/// cells of `setup`'s block, the cells `inverse::synthesize` renders the images on.
///
/// # Errors
/// Values the voxel grid refuses.
pub fn fine_truth_voxels(
    setup: &Setup,
    truth: &(dyn Fn(DVec3) -> ([f64; 3], [f64; 3]) + Sync),
) -> Result<VoxelGrid, VolumeError> {
    let cells = setup.dims.map(|d| 2 * (d.saturating_sub(1) as u32));
    VoxelGrid::from_fn(cells, DVec3::ZERO, DVec3::splat(0.5 * setup.spacing_mm), |p| {
        let (a, s) = truth(p);
        Coefficients::new(a, s)
    })
}

/// Relative RMS, over the lit face's vertices and all channels, of TransCut's Lo for `setup`'s
/// block filled with `media` on the fit's cells against the block filled with `truth` (for
/// example [`fine_truth_voxels`]); one per light of [`lit_face_lights`], named.
///
/// # Errors
/// [`LitFaceError`] for a grid or cells the acquisition refuses, or a failed bake.
pub fn rendered_errors(
    setup: &Setup,
    truth: &VoxelGrid,
    media: &CellMedia,
    tets: usize,
) -> Result<Vec<(&'static str, f64)>, LitFaceError> {
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
