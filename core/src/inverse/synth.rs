//! Synthetic images from an independent discretisation: the polygrid finite-volume system
//! ([`PolygridSystem::finite_volume`], general mapped-hex code) on the block refined `refine`
//! times, so a fit is never checked against its own forward model (design note P12, the
//! "inverse crime"). Pixel (i, j) is the fine grid's Lo at the node that coincides with the
//! coarse face node (i, j).

use std::collections::HashMap;
use std::sync::Arc;

use glam::DVec3;
use rayon::prelude::*;

use crate::optics::Medium;
use crate::polygrid::{Polycube, Polygrid, PolygridSystem};
use crate::sparse::{pcg, Precision, Preconditioner, PreconditionerKind, SolveOptions};

use super::block::face_areas;
use super::error::InverseError;
use super::model::Setup;
use super::setup::{Observation, Pattern};

/// How the synthetic images are rendered.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SynthOptions {
    /// Fine cells per coarse cell edge (default 2; 1 is the same grid, through other code).
    pub refine: u32,
    /// The solves' relative residual (default 1e-11).
    pub tolerance: f64,
}

impl Default for SynthOptions {
    fn default() -> Self {
        Self { refine: 2, tolerance: 1e-11 }
    }
}

/// The images of `setup` lit by `patterns`, for the medium `medium(p)` = (σa, σ′s) at each
/// point p (mm, from the block's corner), sampled at the fine cells' centres.
///
/// # Errors
/// [`InverseError::InvalidSetting`] for `refine` 0; [`InverseError::NoPatterns`]; pattern
/// errors; [`InverseError::Polygrid`] for a medium the system refuses; a solver error.
pub fn synthesize(
    setup: &Setup,
    patterns: &[Pattern],
    medium: &(dyn Fn(DVec3) -> ([f64; 3], [f64; 3]) + Sync),
    options: SynthOptions,
) -> Result<Vec<Vec<[f64; 3]>>, InverseError> {
    if options.refine == 0 {
        return Err(InverseError::InvalidSetting { what: "refinement", value: 0.0, expected: "≥ 1" });
    }
    if patterns.is_empty() {
        return Err(InverseError::NoPatterns);
    }
    let h = setup.spacing_mm;
    let r = options.refine as usize;
    let cells = setup.dims.map(|d| d.saturating_sub(1) as u32);
    if cells.contains(&0) {
        return Err(InverseError::InvalidGrid { dims: setup.dims, reason: "at least 2 nodes per axis" });
    }
    let cube = Arc::new(Polycube::block(DVec3::ZERO, h, cells)?);
    let grid = Polygrid::new(cube, options.refine)?;
    let media: Vec<Medium> = grid
        .cells()
        .iter()
        .map(|c| {
            let centre = c.iter().map(|&i| grid.positions()[i as usize]).sum::<DVec3>() / 8.0;
            let (a, s) = medium(centre);
            Medium::new(a, s, setup.eta, 0.0)
        })
        .collect::<Result<_, _>>()
        .map_err(|e| InverseError::InvalidParameters(format!("the synthetic medium: {e}")))?;
    let mut system = PolygridSystem::finite_volume(&grid, &media, 1.0, None)?;
    let hf = h / r as f64;
    let fdims = setup.dims.map(|d| (d - 1) * r + 1);
    let lattice = |p: DVec3| [p.x, p.y, p.z].map(|v| (v / hf).round() as usize);
    let by_lattice: HashMap<[usize; 3], usize> = grid.positions().iter().enumerate().map(|(i, &p)| (lattice(p), i)).collect();
    let boundary = system.boundary().clone();
    let terms = *system.boundary_terms();
    let top = fdims[2] - 1;
    let observed_k = match setup.observation {
        Observation::FrontLit { .. } => top,
        Observation::BackLit => 0,
    };
    let [nx, ny, _] = setup.dims;
    let mut images = Vec::with_capacity(patterns.len());
    // The sources: q on the top face only (a node on its rim carries q on its top quarter
    // only, not on the side faces PolygridSystem would also light).
    let mut rhs = Vec::with_capacity(patterns.len());
    let mut fine_q = Vec::with_capacity(patterns.len());
    for (m, p) in patterns.iter().enumerate() {
        let q = p.refined_node_values(m, nx, ny, h, r)?;
        let source: Vec<[f64; 3]> = boundary
            .ids
            .iter()
            .zip(&boundary.area_mm2)
            .map(|(&i, &s)| {
                let ijk = lattice(grid.positions()[i as usize]);
                if ijk[2] != top {
                    return [0.0; 3];
                }
                let lit = face_areas(ijk, fdims, hf)[5];
                q[ijk[0] + fdims[0] * ijk[1]].map(|q| q * lit / s)
            })
            .collect();
        system.set_source(&source)?;
        rhs.push(system.rhs().to_vec());
        fine_q.push(q);
    }
    let a = system.matrix();
    let pre = Preconditioner::new(a, PreconditionerKind::Jacobi)?;
    let opts =
        SolveOptions::default().with_tolerance(options.tolerance).with_max_iterations(100_000).with_precision(Precision::Double);
    let phis: Vec<Result<Vec<[f64; 3]>, InverseError>> = rhs
        .par_iter()
        .enumerate()
        .map(|(image, b)| {
            let mut x = vec![[0.0; 3]; a.n()];
            let stats =
                pcg(a, b, &mut x, &pre, &opts).map_err(|source| InverseError::Solve { what: "synthetic", image, source })?;
            if !stats.converged {
                let residual = stats.relative_residual.iter().fold(0.0f64, |m, &r| m.max(r));
                return Err(InverseError::NotConverged { what: "synthetic", image, residual });
            }
            Ok(x)
        })
        .collect();
    for (m, phi) in phis.into_iter().enumerate() {
        let phi = phi?;
        let img = (0..nx * ny)
            .map(|p| {
                let ijk = [(p % nx) * r, (p / nx) * r, observed_k];
                let node = by_lattice[&ijk];
                let q = if observed_k == top { fine_q[m][ijk[0] + fdims[0] * ijk[1]] } else { [0.0; 3] };
                std::array::from_fn(|c| terms.radiance_normal(phi[node][c], q[c]))
            })
            .collect();
        images.push(img);
    }
    Ok(images)
}

/// The synthetic sample of the round-trip tests and `transcut bench inverse`: a block of one medium with a diagonal vein of 5× σa (the
/// slab |x − 0.6y − x₀| < 1 mm through the depth, x₀ = 0.3 × the face's width) and a 1 mm skin
/// of 1.5× σ′s under the lit face (z > thickness − 1 mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VeinedBlock {
    /// The block's medium outside the vein and skin: (σa, σ′s), mm⁻¹.
    pub base: ([f64; 3], [f64; 3]),
    /// The face's width along x, mm.
    pub width_mm: f64,
    /// The block's thickness along z, mm.
    pub thickness_mm: f64,
}

impl VeinedBlock {
    /// Marble (Jensen et al. 2001's σa, σ′s) with the vein and skin, on `setup`'s block.
    #[must_use]
    pub fn marble(setup: &Setup) -> Self {
        let h = setup.spacing_mm;
        Self {
            base: ([0.0021, 0.0041, 0.0071], [2.19, 2.62, 3.0]),
            width_mm: (setup.dims[0].max(1) - 1) as f64 * h,
            thickness_mm: (setup.dims[2].max(1) - 1) as f64 * h,
        }
    }

    /// (σa, σ′s) at `p` (mm from the block's corner).
    #[must_use]
    pub fn medium(&self, p: DVec3) -> ([f64; 3], [f64; 3]) {
        let (mut a, mut s) = self.base;
        if ((p.x - 0.6 * p.y) - 0.3 * self.width_mm).abs() < 1.0 {
            a = a.map(|v| 5.0 * v);
        }
        if p.z > self.thickness_mm - 1.0 {
            s = s.map(|v| 1.5 * v);
        }
        (a, s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_veined_block_has_its_vein_and_skin_where_stated() {
        // 20.5 × 20.5 × 5.5 mm: the vein is |x − 0.6y − 6.15| < 1, the skin z > 4.5.
        let setup = Setup { dims: [42, 42, 12], spacing_mm: 0.5, eta: 1.3, observation: Observation::BackLit };
        let v = VeinedBlock::marble(&setup);
        let (a, s) = v.medium(DVec3::new(6.15 + 0.6 * 10.0 + 0.9, 10.0, 1.0));
        assert_eq!((a[1], s[1]), (5.0 * 0.0041, 2.62));
        let (a, s) = v.medium(DVec3::new(6.15 + 0.6 * 10.0 + 1.1, 10.0, 4.6));
        assert_eq!((a[1], s[1]), (0.0041, 1.5 * 2.62));
    }

    #[test]
    fn per_node_light_renders_on_the_finer_grid_as_the_rectangle_it_equals() {
        // Node (2, 2)'s dual cell lit by a rectangle, and the same light as per-node values of
        // the (coarse) setup grid: the same images from the 2×-finer synthesis.
        let setup = Setup { dims: [5, 5, 3], spacing_mm: 0.5, eta: 1.3, observation: Observation::BackLit };
        let rect = Pattern::Rect { rect: [0.75, 1.25, 0.75, 1.25], q: [1.0, 2.0, 3.0] };
        let nodes = Pattern::Nodes(rect.node_values(0, 5, 5, 0.5).unwrap());
        let medium = |_: DVec3| ([0.01, 0.02, 0.03], [1.0, 1.5, 2.0]);
        let options = SynthOptions::default();
        let by_rect = synthesize(&setup, &[rect], &medium, options).unwrap();
        let by_nodes = synthesize(&setup, &[nodes], &medium, options).unwrap();
        for (a, b) in by_rect[0].iter().zip(&by_nodes[0]) {
            assert!((0..3).all(|c| (a[c] - b[c]).abs() <= 1e-9 * a[c].abs().max(1e-30)), "{a:?} against {b:?}");
        }
        assert!(by_rect[0].iter().all(|p| p[0] > 0.0), "the light reaches the back face");
    }
}
