//! The polygrid moved onto the object (Wang et al. 2008 §5.1, steps 4–6): the boundary nodes
//! onto the surface, evenly spread; the interior nodes relaxed after them; then every cell
//! checked for folds (a turned Kuhn tet is [`PolygridError::Fold`], never a wrong picture).
//!
//! The paper maps the polycube's surface by PolyCube-Map or cross-parameterisation, then spreads
//! the boundary nodes (Turk 1992) and minimises the variance of the interior edge lengths. Here a
//! voxel polycube lies within a cube of the surface, so the closest point is a good start once
//! the staircase is smoothed (Taubin's λ|μ, which does not shrink): the boundary nodes are
//! projected, then untangled and evened out on the surface ([`super::untangle`]); the
//! interior takes the boundary's displacement by harmonic relaxation of the displacement field
//! (the deep interior keeps its lattice places). With a pillow ([`Polygrid::with_pillow`]) the
//! lattice's surface starts one spacing under the surface nodes and every lattice node is then
//! smoothed among the cells' edges, which rounds the polycube's convex corners inwards instead
//! of flattening their cells; last, the Kuhn tets left turned or distorted are untangled.
//! The cubed sphere ([`map_to_sphere`]) has a closed form.

use std::sync::Arc;

use glam::DVec3;
use rayon::prelude::*;

use super::domain::Polycube;
use super::error::PolygridError;
use super::grid::{Polygrid, NONE};
use super::untangle::{untangle_surface, untangle_volume};
use crate::mesh::TriangleBvh;

/// How boundary and interior nodes are placed by [`map_to_surface`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapOptions {
    /// Rounds of Taubin's λ|μ smoothing of the polycube's surface before the projection.
    pub taubin_rounds: usize,
    /// Jacobi sweeps of the interior displacement field.
    pub interior_sweeps: usize,
    /// With a pillow ([`Polygrid::with_pillow`]): Jacobi sweeps of Laplacian smoothing of
    /// every lattice node's position among the cells' edges, the surface fixed.
    pub pillow_sweeps: usize,
    /// Sweeps of untangling and smoothing ([`super::untangle`]) of the surface quads, then of
    /// the cells' Kuhn tets; 0 leaves the map as projected and smoothed.
    pub untangle_sweeps: usize,
}

impl Default for MapOptions {
    fn default() -> Self {
        Self { taubin_rounds: 5, interior_sweeps: 64, pillow_sweeps: 24, untangle_sweeps: 160 }
    }
}

/// [`map_to_surface`] gives up after the surface pass when more than one quad corner in this
/// many is still turned: the volume pass, which keeps the surface fixed, has never mended
/// that many (the bunny: 5 of 140 000 at two cells per cube are mended, 151 at four are not),
/// and a smaller cube is cheaper than trying.
pub const SURFACE_FOLD_LIMIT: usize = 2000;

/// What [`check_cells`] measured: the smallest and the mean scaled Jacobian over every cell
/// corner (1 for a cube, → 0 for a flat cell).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CellQuality {
    /// Can be slightly below 0 at a cell on a convex polycube corner ([`check_cells`]).
    pub min_scaled_jacobian: f64,
    pub mean_scaled_jacobian: f64,
}

/// A one-cube polygrid mapped onto the ball of `radius` around `centre`: the cube's surface by
/// the equal-angle cubed-sphere map (each face's coordinates u, v to the direction
/// (1, tan(πu/4), tan(πv/4)) normalised), and each inner shell of Chebyshev radius r blended
/// from the cube towards the sphere, x = c + R((1 − r) p + r² d(p)) for the cube point p ∈
/// [−1, 1]³ (|p|∞ = r) with direction d(p): cube-like cells inside, the sphere at r = 1, and the
/// 60°/120° skew of the cubed sphere's corners only near the surface.
///
/// # Errors
/// [`PolygridError::InvalidCube`] for a grid of more than one cube or a radius that is not
/// finite and > 0; [`PolygridError::Fold`] from the check.
pub fn map_to_sphere(grid: &mut Polygrid, centre: DVec3, radius: f64) -> Result<CellQuality, PolygridError> {
    if grid.polycube().cells().len() != 1 || !(radius.is_finite() && radius > 0.0) || !centre.is_finite() {
        return Err(PolygridError::InvalidCube { cube: radius });
    }
    let r = grid.resolution() as f64;
    let base = grid.polycube().cells()[0].map(|c| c as f64 * r);
    let positions = grid
        .lattice()
        .par_iter()
        .map(|l| {
            let p = DVec3::new(l[0] as f64 - base[0], l[1] as f64 - base[1], l[2] as f64 - base[2]) * (2.0 / r) - 1.0;
            centre + radius * cube_to_ball(p)
        })
        .collect();
    grid.set_positions(positions);
    check_cells(grid, "the cubed-sphere map is fold-free by construction; report this as a bug")
}

/// The cubed sphere: one cube of `resolution` cells per edge mapped by [`map_to_sphere`] onto
/// the ball of `radius` mm around `centre`. The polygrid domain with a closed-form answer (the
/// uniformly lit sphere), used by the tests and benchmarks.
///
/// # Errors
/// As [`Polygrid::new`] and [`map_to_sphere`].
pub fn cubed_sphere(resolution: u32, centre: DVec3, radius: f64) -> Result<Polygrid, PolygridError> {
    let cube = Arc::new(Polycube::block(DVec3::ZERO, 1.0, [1, 1, 1])?);
    let mut grid = Polygrid::new(cube, resolution)?;
    map_to_sphere(&mut grid, centre, radius)?;
    Ok(grid)
}

/// The blended equal-angle cubed-sphere map of a point of [−1, 1]³ into the unit ball
/// ([`map_to_sphere`]).
fn cube_to_ball(p: DVec3) -> DVec3 {
    let a = p.abs();
    let r = a.max_element();
    if r == 0.0 {
        return DVec3::ZERO;
    }
    let s = p / r;
    let t = |x: f64| (std::f64::consts::FRAC_PI_4 * x).tan();
    let d = if a.x >= a.y && a.x >= a.z {
        DVec3::new(s.x.signum(), t(s.y), t(s.z))
    } else if a.y >= a.z {
        DVec3::new(t(s.x), s.y.signum(), t(s.z))
    } else {
        DVec3::new(t(s.x), t(s.y), s.z.signum())
    };
    (1.0 - r) * p + r * r * d.normalize()
}

/// The polygrid moved onto the surface held by `bvh` (see the module documentation).
///
/// # Errors
/// [`PolygridError::SurfaceFold`] when the surface pass leaves more than one quad corner in
/// [`SURFACE_FOLD_LIMIT`] turned (the volume pass keeps the surface fixed and cannot mend it);
/// [`PolygridError::Fold`] naming the first folded cell.
pub fn map_to_surface(grid: &mut Polygrid, bvh: &TriangleBvh, options: &MapOptions) -> Result<CellQuality, PolygridError> {
    let n = grid.node_count();
    let on_boundary = grid.on_boundary().to_vec();
    let boundary: Vec<u32> = (0..n as u32).filter(|&i| on_boundary[i as usize]).collect();
    // The quad-edge neighbours of every boundary node.
    let mut ring: Vec<Vec<u32>> = vec![Vec::new(); n];
    for q in grid.quads() {
        for k in 0..4 {
            let (a, b) = (q[k], q[(k + 1) % 4]);
            ring[a as usize].push(b);
            ring[b as usize].push(a);
        }
    }
    for r in &mut ring {
        r.sort_unstable();
        r.dedup();
    }
    let mut x = grid.positions().to_vec();
    let lattice = x.clone();
    // Taubin's λ|μ smoothing of the polycube's surface (λ = 0.5, μ = −0.53: smooth without
    // shrinking): the staircase becomes a smooth surface near the object's, whose
    // closest-point projection is nearly one-to-one.
    for round in 0..2 * options.taubin_rounds {
        let factor = if round % 2 == 0 { 0.5 } else { -0.53 };
        let moved: Vec<DVec3> = boundary
            .par_iter()
            .map(|&i| {
                let r = &ring[i as usize];
                let mean = r.iter().map(|&j| x[j as usize]).sum::<DVec3>() / r.len() as f64;
                x[i as usize] + factor * (mean - x[i as usize])
            })
            .collect();
        for (&i, p) in boundary.iter().zip(moved) {
            x[i as usize] = p;
        }
    }
    let project = |p: DVec3| match bvh.closest_point(p) {
        Some(s) => (s.point, bvh.triangle_normal(s.triangle)),
        None => (p, DVec3::Z),
    };
    let projected: Vec<DVec3> = boundary.par_iter().map(|&i| project(x[i as usize]).0).collect();
    for (&i, p) in boundary.iter().zip(projected) {
        x[i as usize] = p;
    }
    let h = grid.lattice_spacing();
    let colours = grid.parity_colours();
    let surface = untangle_surface(&mut x, &lattice, grid.quads(), &colours, h, options.untangle_sweeps, &project);
    let corners = 4 * grid.quads().len();
    if surface.turned_after * SURFACE_FOLD_LIMIT > corners {
        return Err(PolygridError::SurfaceFold { turned: surface.turned_after, corners });
    }
    // A pillow's lattice boundary nodes start one lattice spacing under their surface node.
    let pillow = grid.lattice_node_count();
    let mut fixed = on_boundary.clone();
    if grid.has_pillow() {
        let mut normal = vec![DVec3::ZERO; n];
        for q in grid.quads() {
            let [a, b, c, e] = q.map(|i| x[i as usize]);
            let area = (c - a).cross(e - b);
            for &i in q {
                normal[i as usize] += area;
            }
        }
        for (k, &b) in grid.pillow_base().iter().enumerate() {
            let s = pillow + k;
            x[b as usize] = x[s] - h * normal[s].normalize_or_zero();
            fixed[b as usize] = true;
        }
    }
    // The interior follows: harmonic relaxation of the displacement from the lattice.
    let neighbours = grid.neighbours();
    let mut d: Vec<DVec3> = x.iter().zip(&lattice).map(|(a, b)| *a - *b).collect();
    let interior: Vec<u32> = (0..n as u32).filter(|&i| !fixed[i as usize]).collect();
    for _ in 0..options.interior_sweeps {
        let next: Vec<DVec3> = interior
            .par_iter()
            .map(|&i| {
                let (sum, count) = neighbours[i as usize]
                    .iter()
                    .filter(|&&j| j != NONE)
                    .fold((DVec3::ZERO, 0.0), |(s, c), &j| (s + d[j as usize], c + 1.0));
                sum / count
            })
            .collect();
        for (&i, v) in interior.iter().zip(next) {
            d[i as usize] = v;
        }
    }
    let mut positions: Vec<DVec3> = lattice.iter().zip(&d).map(|(a, b)| *a + *b).collect();
    if grid.has_pillow() {
        // Laplacian smoothing of every lattice node (the pillow's base nodes too) among the
        // cells' edges, the surface fixed: rounds the polycube's convex corners and edges
        // inwards, so that no cell is flattened against the surface.
        let pattern = grid.edge_pattern()?;
        let lattice_ids: Vec<u32> = (0..pillow as u32).collect();
        for _ in 0..options.pillow_sweeps {
            let next: Vec<DVec3> = lattice_ids
                .par_iter()
                .map(|&i| {
                    let row = pattern.row(i as usize);
                    let others = row.iter().filter(|&&j| j != i);
                    let (sum, count) = others.fold((DVec3::ZERO, 0.0), |(s, c), &j| (s + positions[j as usize], c + 1.0));
                    sum / count
                })
                .collect();
            positions[..pillow].copy_from_slice(&next);
        }
    }
    untangle_volume(&mut positions, &grid.kuhn_tets(), &on_boundary, &colours, h, options.untangle_sweeps);
    grid.set_positions(positions);
    check_cells(grid, "the surface's features are finer than the cubes: choose a smaller cube or a higher resolution")
}

/// The paper's first interior layer (§5.1 step 5): every node off the boundary linked to
/// nodes under the boundary condition (a lattice link, or a pillow's base below its surface
/// node) moved to the mean of those boundary nodes less `fraction` × their mean spacing (the
/// mean length of their quads' edges) along their mean unit normal; the paper takes 0.1, so
/// that its one-sided boundary relation ([`super::PolygridSystem::paper_lsq`]) is accurate.
/// Deeper nodes stay. `robin` as in [`super::PolygridSystem::finite_volume`]: a mirror face
/// is not a boundary here (its nodes slide along it). Where a move would turn a Kuhn tet (a
/// pillowed polycube's convex edges and corners, rounded inwards by the map), the corners of
/// that cell keep their places, until no cell is turned.
///
/// # Errors
/// [`PolygridError::LengthMismatch`] for a mask of the wrong length; [`PolygridError::InvalidCube`]
/// for a `fraction` outside (0, 1); [`PolygridError::Fold`] if the grid was folded before.
pub fn place_first_layer(grid: &mut Polygrid, fraction: f64, robin: Option<&[bool]>) -> Result<FirstLayer, PolygridError> {
    if let Some(r) = robin {
        if r.len() != grid.quads().len() {
            return Err(PolygridError::LengthMismatch { what: "Robin quad mask", expected: grid.quads().len(), found: r.len() });
        }
    }
    if !(fraction > 0.0 && fraction < 1.0) {
        return Err(PolygridError::InvalidCube { cube: fraction });
    }
    let n = grid.node_count();
    let x = grid.positions();
    let (mut on_robin, mut normal, mut spacing, mut edges) = (vec![false; n], vec![DVec3::ZERO; n], vec![0.0; n], vec![0.0; n]);
    for (qi, q) in grid.quads().iter().enumerate() {
        if robin.is_some_and(|r| !r[qi]) {
            continue;
        }
        let [a, b, c, d] = q.map(|i| x[i as usize]);
        let area = (c - a).cross(d - b);
        for k in 0..4 {
            let (i, j) = (q[k] as usize, q[(k + 1) % 4] as usize);
            on_robin[i] = true;
            normal[i] += area;
            let l = (x[j] - x[i]).length();
            spacing[i] += l;
            spacing[j] += l;
            edges[i] += 1.0;
            edges[j] += 1.0;
        }
    }
    let target: Vec<Option<DVec3>> = (0..n)
        .into_par_iter()
        .map(|i| {
            if on_robin[i] {
                return None;
            }
            let partners = grid.links(i as u32).filter(|&j| on_robin[j as usize]);
            let (mut at, mut nsum, mut s, mut count) = (DVec3::ZERO, DVec3::ZERO, 0.0, 0.0);
            for j in partners {
                let j = j as usize;
                at += x[j];
                nsum += normal[j].normalize_or_zero();
                s += spacing[j] / edges[j];
                count += 1.0;
            }
            (count > 0.0).then(|| at / count - fraction * (s / count) * nsum.normalize_or_zero())
        })
        .collect();
    let old = x.to_vec();
    let mut positions = old.clone();
    let mut moved = vec![false; n];
    for (i, t) in target.iter().enumerate() {
        if let Some(t) = t {
            positions[i] = *t;
            moved[i] = true;
        }
    }
    // Keep the corners of turned cells where they were, until none is turned.
    loop {
        let turned: Vec<usize> = grid
            .cells()
            .par_iter()
            .enumerate()
            .filter(|(_, c)| c.iter().any(|&v| moved[v as usize]) && cell_turned(&c.map(|v| positions[v as usize])))
            .map(|(k, _)| k)
            .collect();
        let mut reverted = false;
        for k in turned {
            for &v in &grid.cells()[k] {
                if moved[v as usize] {
                    moved[v as usize] = false;
                    positions[v as usize] = old[v as usize];
                    reverted = true;
                }
            }
        }
        if !reverted {
            break;
        }
    }
    let candidates = target.iter().filter(|t| t.is_some()).count();
    let placed = moved.iter().filter(|&&m| m).count();
    grid.set_positions(positions);
    match check_cells(grid, "the grid was folded before its first layer was placed") {
        Ok(quality) => Ok(FirstLayer { placed, kept: candidates - placed, quality }),
        Err(e) => {
            grid.set_positions(old);
            Err(e)
        }
    }
}

/// What [`place_first_layer`] did.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FirstLayer {
    /// Nodes moved to the paper's depth.
    pub placed: usize,
    /// Nodes of the layer kept where they were (their move would turn a cell).
    pub kept: usize,
    /// The cells' shape afterwards.
    pub quality: CellQuality,
}

/// The cells' shape: the scaled Jacobian of every cell corner (the determinant of the three
/// unit edge vectors leaving the corner along +x, +y, +z of the lattice: 1 for a cube, ≤ 0 at
/// a corner pushed through), and the fold check on the elements the stencils integrate over,
/// the six Kuhn tets of each cell ([`Polygrid::kuhn_tets`]): each must keep the orientation it
/// has in the lattice. A cell at a convex polycube corner has its three boundary faces mapped
/// onto a smooth surface, so its corner there is nearly flat and may dent slightly inwards
/// while all its tets stay positive: that cell is valid; a tet turned over is a fold.
///
/// # Errors
/// [`PolygridError::Fold`] naming the first cell with a tet of non-positive volume (and that
/// cell's smallest corner Jacobian), with `hint` saying what to change.
pub fn check_cells(grid: &Polygrid, hint: &'static str) -> Result<CellQuality, PolygridError> {
    let p = grid.positions();
    let per_cell: Vec<(f64, f64, bool)> = grid
        .cells()
        .par_iter()
        .map(|c| {
            let x = c.map(|i| p[i as usize]);
            let mut min = f64::INFINITY;
            let mut sum = 0.0;
            for k in 0..8 {
                // Edges towards the corners differing in one bit, signed along +axis.
                let e: [DVec3; 3] = std::array::from_fn(|axis| {
                    let bit = 1 << axis;
                    let edge = x[k ^ bit] - x[k];
                    if k & bit == 0 {
                        edge
                    } else {
                        -edge
                    }
                });
                let lengths = e[0].length() * e[1].length() * e[2].length();
                let j = if lengths > 0.0 { e[0].dot(e[1].cross(e[2])) / lengths } else { 0.0 };
                min = min.min(j);
                sum += j;
            }
            (min, sum / 8.0, cell_turned(&x))
        })
        .collect();
    if let Some(cell) = per_cell.iter().position(|c| c.2) {
        return Err(PolygridError::Fold { cell, scaled_jacobian: per_cell[cell].0, hint });
    }
    let min = per_cell.iter().map(|c| c.0).fold(f64::INFINITY, f64::min);
    let mean = per_cell.iter().map(|c| c.1).sum::<f64>() / per_cell.len().max(1) as f64;
    Ok(CellQuality { min_scaled_jacobian: min, mean_scaled_jacobian: mean })
}

/// Whether a cell with corners `x` (lattice order) has a Kuhn tet turned over or flat: tet
/// [0, a, a|b, 7] of the path a, b, 7 ^ a ^ b is positive in the lattice when the path's axes
/// are an even permutation of x, y, z.
fn cell_turned(x: &[DVec3; 8]) -> bool {
    const PATHS: [[usize; 2]; 6] = [[1, 2], [1, 4], [2, 1], [2, 4], [4, 1], [4, 2]];
    let diagonal = (x[7] - x[0]).length();
    let scale = diagonal * diagonal * diagonal;
    PATHS.iter().any(|&[a, b]| {
        let sign = if matches!((a, b), (1, 2) | (2, 4) | (4, 1)) { 1.0 } else { -1.0 };
        let v = (x[a] - x[0]).dot((x[a | b] - x[0]).cross(x[7] - x[0]));
        !(sign * v > 1e-12 * scale)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cubed_sphere_puts_the_surface_on_the_sphere_and_folds_nothing() {
        let cube = Arc::new(Polycube::block(DVec3::ZERO, 1.0, [1, 1, 1]).unwrap());
        let mut g = Polygrid::new(cube, 8).unwrap();
        let centre = DVec3::new(1.0, -2.0, 0.5);
        let q = map_to_sphere(&mut g, centre, 10.0).unwrap();
        // The cube's corners meet the sphere at 120°: the corner cells are the flattest.
        assert!(q.min_scaled_jacobian > 0.0 && q.mean_scaled_jacobian > 0.8, "{q:?}");

        for (x, &b) in g.positions().iter().zip(g.on_boundary()) {
            let r = (*x - centre).length();
            if b {
                assert!((r - 10.0).abs() < 1e-12);
            } else {
                assert!(r < 10.0 - 1e-9);
            }
        }
        // The quads' enclosed volume approaches the ball's (inscribed polyhedron: below it).
        let p = g.positions();
        let volume: f64 = g
            .quads()
            .iter()
            .map(|q| {
                let [a, b, c, d] = q.map(|i| p[i as usize] - centre);
                (a.dot((b - a).cross(c - a)) + a.dot((c - a).cross(d - a))) / 6.0
            })
            .sum();
        let ball = 4.0 / 3.0 * std::f64::consts::PI * 1000.0;
        assert!(volume < ball && volume > 0.97 * ball, "{volume} vs {ball}");
    }

    #[test]
    fn the_lattice_itself_is_fold_free_and_every_kuhn_tet_positive() {
        let cube = Arc::new(Polycube::block(DVec3::ZERO, 2.0, [2, 1, 3]).unwrap());
        let g = Polygrid::new(cube, 3).unwrap();
        let q = check_cells(&g, "test").unwrap();
        assert!((q.min_scaled_jacobian - 1.0).abs() < 1e-12);
        // The orientation table of check_cells against the tets' own volumes.
        let p = g.positions();
        for t in g.kuhn_tets().iter().take(6) {
            let [a, b, c, d] = t.map(|i| p[i as usize]);
            let v = (b - a).dot((c - a).cross(d - a)).abs() / 6.0;
            assert!((v - (2.0f64 / 3.0).powi(3) / 6.0).abs() < 1e-12, "each Kuhn tet is a sixth of the cell");
        }
    }

    #[test]
    fn a_flat_cell_is_a_named_fold() {
        let cube = Arc::new(Polycube::block(DVec3::ZERO, 1.0, [2, 1, 1]).unwrap());
        let mut g = Polygrid::new(cube, 1).unwrap();
        let mut p = g.positions().to_vec();
        // Push the middle face's nodes past the far face: the first cube turns inside out.
        for (i, l) in g.lattice().to_vec().iter().enumerate() {
            if l[0] == 1 {
                p[i].x = -0.5;
            }
        }
        g.set_positions(p);
        assert!(matches!(check_cells(&g, "test"), Err(PolygridError::Fold { cell: 0, .. })));
    }

    #[test]
    fn a_pillowed_voxel_polycube_maps_a_coarse_faceted_sphere_without_folds() {
        // A 48 × 24 UV sphere of radius 12 at 4 mm cubes: without the pillow, the cells on the
        // polycube's corners have three faces on flat facets.
        let sphere = crate::mesher::tests::uv_sphere(12.0, 48, 24);
        let bvh = TriangleBvh::from_indexed(sphere.positions(), sphere.triangles());
        let cube = Arc::new(Polycube::voxelize(&sphere, 4.0).unwrap());
        let mut plain = Polygrid::new(Arc::clone(&cube), 4).unwrap();
        let plain = map_to_surface(&mut plain, &bvh, &MapOptions::default());
        let mut g = Polygrid::with_pillow(cube, 4).unwrap();
        let q = map_to_surface(&mut g, &bvh, &MapOptions::default()).unwrap();
        // Every cell corner positive (the untangling pass optimises the Kuhn tets, not the
        // corners, which may come close to flat but not turn).
        assert!(q.min_scaled_jacobian > 0.0 && q.mean_scaled_jacobian > 0.9, "pillowed {q:?}; without the pillow {plain:?}");
        let tets = crate::mesh::TetMesh::new(g.positions().to_vec(), g.kuhn_tets(), vec![]).unwrap();
        assert!(tets.boundary_topology().is_closed_manifold());
        assert_eq!(tets.boundary_faces().len(), 2 * g.quads().len());
    }

    #[test]
    fn a_voxelized_sphere_maps_onto_its_surface() {
        let sphere = crate::mesh::icosphere(10.0, 4);
        let cube = Arc::new(Polycube::voxelize(&sphere, 4.0).unwrap());
        let mut g = Polygrid::with_pillow(cube, 4).unwrap();
        let bvh = TriangleBvh::from_indexed(sphere.positions(), sphere.triangles());
        let q = map_to_surface(&mut g, &bvh, &MapOptions::default()).unwrap();
        assert!(q.mean_scaled_jacobian > 0.5, "{q:?}");
        for (x, &b) in g.positions().iter().zip(g.on_boundary()) {
            if b {
                assert!(bvh.closest_point(*x).unwrap().distance < 1e-9);
            }
        }
    }
}
