//! The recovered material as a voxel grid: one voxel per cell of the block (the cells carry
//! the media in the model, so nothing is resampled), TCVOX1 when written
//! ([`crate::volume::VoxelGrid::write`]), which `transcut bake`/`render`, the C ABI and the
//! add-on load as a medium.

use glam::DVec3;

use crate::volume::VoxelGrid;

use super::block::BlockGrid;
use super::error::InverseError;
use super::model::CellMedia;

/// The voxel grid of `media` on `grid`'s cells, with the block's lowest corner at `origin`
/// and voxels of `h`·`units_per_mm` scene units (1 for a scene in mm).
///
/// # Errors
/// [`InverseError::InvalidParameters`] for media of the wrong size; [`InverseError::Volume`]
/// for values the grid refuses (not finite, negative, or too large for `f32`).
pub fn to_voxel_grid(grid: &BlockGrid, media: &CellMedia, origin: DVec3, units_per_mm: f64) -> Result<VoxelGrid, InverseError> {
    let cells = grid.cell_count();
    if media.sigma_a.len() != cells || media.sigma_s_prime.len() != cells {
        return Err(InverseError::InvalidParameters(format!(
            "{} σa and {} σ′s values for {cells} cells",
            media.sigma_a.len(),
            media.sigma_s_prime.len()
        )));
    }
    if !(units_per_mm.is_finite() && units_per_mm > 0.0) {
        return Err(InverseError::InvalidSetting { what: "scene units per mm", value: units_per_mm, expected: "finite and > 0" });
    }
    let data: Vec<f32> = media
        .sigma_a
        .iter()
        .zip(&media.sigma_s_prime)
        .flat_map(|(a, s)| [a[0], a[1], a[2], s[0], s[1], s[2]].map(|v| v as f32))
        .collect();
    let dims = grid.cell_dims().map(|d| d as u32);
    Ok(VoxelGrid::new(dims, origin, DVec3::splat(grid.spacing() * units_per_mm), data)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_cell_is_a_voxel_at_its_centre() {
        let g = BlockGrid::new([4, 3, 3], 0.5).unwrap();
        let mut m = CellMedia::uniform(g.cell_count(), [0.01, 0.02, 0.03], [1.0, 2.0, 3.0]);
        m.sigma_a[5] = [0.5, 0.5, 0.5];
        let v = to_voxel_grid(&g, &m, DVec3::ZERO, 1.0).unwrap();
        assert_eq!(v.dims(), [3, 2, 2]);
        let c = g.cell_centre(5);
        let s = v.sample(DVec3::new(c[0], c[1], c[2]));
        assert!((s.sigma_a[0] - 0.5).abs() < 1e-6, "{s:?}");
        let bytes = v.to_bytes();
        assert_eq!(bytes.len(), 72 + 24 * 12);
    }
}
