//! The polycube a polygrid is built on (Wang et al. 2008 §5.1): unit cubes on an integer
//! lattice, scaled and placed in scene space, whose union has a 2-manifold surface.
//!
//! The paper assembles the polycube by hand; [`Polycube::voxelize`] makes it from the user's
//! surface without hand work (the cells whose centre has winding number ≥ ½, then the
//! critical configurations repaired and the topology compared with the surface's).
//! [`Polycube::block`] and [`Polycube::from_cells`] (the paper's hand-made route, as cell lists)
//! give it directly.

use std::collections::HashSet;

use glam::DVec3;
use rayon::prelude::*;

use super::error::PolygridError;
use crate::mesh::{TriMesh, TriangleBvh};
use crate::mesher::WindingNumber;

/// The most cubes a polycube may hold.
pub const MAX_CUBES: usize = 1 << 20;

/// A polycube: the unit cubes `cells` of an integer lattice, cube `c` covering
/// `origin + cube · [c, c + 1]` in scene space. Its surface is a closed 2-manifold (checked
/// when it is made).
#[derive(Debug, Clone, PartialEq)]
pub struct Polycube {
    origin: DVec3,
    cube: f64,
    cells: Vec<[i32; 3]>,
}

impl Polycube {
    /// A polycube from a list of cubes (the paper's hand-made route), sorted.
    ///
    /// # Errors
    /// [`PolygridError::Empty`], [`PolygridError::InvalidCube`],
    /// [`PolygridError::DuplicateCube`], [`PolygridError::TooLarge`] for more than
    /// [`MAX_CUBES`] cubes, and [`PolygridError::NonManifold`] naming the first lattice point
    /// where cubes touch along an edge or at a corner only.
    pub fn from_cells(origin: DVec3, cube: f64, mut cells: Vec<[i32; 3]>) -> Result<Self, PolygridError> {
        if !(cube.is_finite() && cube > 0.0 && origin.is_finite()) {
            return Err(PolygridError::InvalidCube { cube });
        }
        if cells.is_empty() {
            return Err(PolygridError::Empty("the cell list is empty".into()));
        }
        if cells.len() > MAX_CUBES {
            return Err(PolygridError::TooLarge { nodes: cells.len() as u64, limit: MAX_CUBES as u64 });
        }
        cells.sort_unstable_by_key(|c| (c[2], c[1], c[0]));
        if let Some(w) = cells.windows(2).find(|w| w[0] == w[1]) {
            return Err(PolygridError::DuplicateCube { cell: w[0] });
        }
        let set: HashSet<[i32; 3]> = cells.iter().copied().collect();
        if let Some((at, reason)) = first_critical(&set) {
            return Err(PolygridError::NonManifold { at, reason });
        }
        Ok(Self { origin, cube, cells })
    }

    /// A block of `dims` cubes with its lowest corner at `origin`.
    ///
    /// # Errors
    /// As [`Polycube::from_cells`] (a zero dimension is [`PolygridError::Empty`]).
    pub fn block(origin: DVec3, cube: f64, dims: [u32; 3]) -> Result<Self, PolygridError> {
        if dims.iter().map(|&d| d as u64).product::<u64>() > MAX_CUBES as u64 {
            return Err(PolygridError::TooLarge { nodes: dims.iter().map(|&d| d as u64).product(), limit: MAX_CUBES as u64 });
        }
        let mut cells = Vec::new();
        for z in 0..dims[2] as i32 {
            for y in 0..dims[1] as i32 {
                for x in 0..dims[0] as i32 {
                    cells.push([x, y, z]);
                }
            }
        }
        Self::from_cells(origin, cube, cells)
    }

    /// The polycube of a closed surface at cube size `cube` (scene units): the cubes of a
    /// lattice aligned with the surface's bounding box whose centre has generalised winding
    /// number ≥ ½, then every critical configuration (cubes touching along an edge or at a
    /// corner only, or the same of the empty cubes) repaired by adding the empty cube of the
    /// configuration with the largest winding number, until none is left. When the surface is
    /// a closed manifold, the polycube's Euler characteristic must equal the surface's.
    ///
    /// # Errors
    /// [`PolygridError::InvalidCube`]; [`PolygridError::Empty`] when no cube centre is inside
    /// (an open sheet, or a cube larger than the object); [`PolygridError::TooLarge`];
    /// [`PolygridError::TopologyChanged`].
    pub fn voxelize(surface: &TriMesh, cube: f64) -> Result<Self, PolygridError> {
        if !(cube.is_finite() && cube > 0.0) {
            return Err(PolygridError::InvalidCube { cube });
        }
        let (lo, hi) = surface.bounds();
        let extent = hi - lo;
        let dims = (extent / cube).ceil().as_ivec3().max(glam::IVec3::ONE) + 2;
        let count = dims.x as u64 * dims.y as u64 * dims.z as u64;
        if count > 64 * MAX_CUBES as u64 {
            return Err(PolygridError::TooLarge { nodes: count, limit: 64 * MAX_CUBES as u64 });
        }
        // Centre the lattice on the box, one empty layer of cubes around it.
        let origin = (lo + hi) * 0.5 - dims.as_dvec3() * cube * 0.5;
        let winding = WindingNumber::new(TriangleBvh::from_indexed(surface.positions(), surface.triangles()));
        let (nx, ny) = (dims.x as usize, dims.y as usize);
        let centre = |i: usize| {
            let c = DVec3::new((i % nx) as f64, ((i / nx) % ny) as f64, (i / (nx * ny)) as f64);
            origin + (c + 0.5) * cube
        };
        let w: Vec<f64> = (0..count as usize).into_par_iter().map(|i| winding.at(centre(i))).collect();
        let cell = |i: usize| [(i % nx) as i32, ((i / nx) % ny) as i32, (i / (nx * ny)) as i32];
        let mut set: HashSet<[i32; 3]> = (0..w.len()).filter(|&i| w[i] >= 0.5).map(cell).collect();
        if set.is_empty() {
            return Err(PolygridError::Empty(format!(
                "no cube centre at cube size {cube} is inside the surface (an open sheet, or a cube larger than the object)"
            )));
        }
        if set.len() > MAX_CUBES {
            return Err(PolygridError::TooLarge { nodes: set.len() as u64, limit: MAX_CUBES as u64 });
        }
        let index = |c: [i32; 3]| (c[0] as usize) + nx * (c[1] as usize + ny * c[2] as usize);
        let inside_box = |c: [i32; 3]| c.iter().zip([dims.x, dims.y, dims.z]).all(|(&x, d)| (0..d).contains(&x));
        remove_bumps_and_pits(&mut set, &inside_box);
        // Repair: each round fills, for every critical configuration, its best empty cube.
        for _ in 0..4 * MAX_CUBES {
            let fills: HashSet<[i32; 3]> = critical_points(&set)
                .into_iter()
                .filter_map(|p| {
                    block_cells(p)
                        .into_iter()
                        .filter(|c| !set.contains(c) && inside_box(*c))
                        .max_by(|a, b| w[index(*a)].total_cmp(&w[index(*b)]))
                })
                .collect();
            if fills.is_empty() {
                break;
            }
            set.extend(fills);
        }
        let polycube = Self::from_cells(origin, cube, set.into_iter().collect())?;
        if surface.is_closed() {
            let surface_chi = euler_characteristic_of(surface);
            let chi = polycube.euler_characteristic();
            if surface_chi != chi {
                return Err(PolygridError::TopologyChanged { surface: surface_chi, polycube: chi, cube });
            }
        }
        Ok(polycube)
    }

    /// Scene position of lattice point 0.
    #[must_use]
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// The cube edge length in scene units.
    #[must_use]
    pub fn cube(&self) -> f64 {
        self.cube
    }

    /// The cubes, sorted by z, then y, then x.
    #[must_use]
    pub fn cells(&self) -> &[[i32; 3]] {
        &self.cells
    }

    /// The Euler characteristic V − E + F of the polycube's surface (2 for a sphere, 0 for a
    /// torus, 2 − 2g with g handles, summed over shells).
    #[must_use]
    pub fn euler_characteristic(&self) -> i64 {
        let set: HashSet<[i32; 3]> = self.cells.iter().copied().collect();
        let mut faces = 0i64;
        let mut edges: HashSet<([i32; 3], usize)> = HashSet::new();
        let mut vertices: HashSet<[i32; 3]> = HashSet::new();
        for &c in &self.cells {
            for axis in 0..3 {
                for side in [0, 1] {
                    let mut n = c;
                    n[axis] += if side == 1 { 1 } else { -1 };
                    if set.contains(&n) {
                        continue;
                    }
                    faces += 1;
                    // The face's corners and edges, as lattice points.
                    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                    let mut base = c;
                    base[axis] += side;
                    for (du, dv) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let mut p = base;
                        p[u] += du;
                        p[v] += dv;
                        vertices.insert(p);
                    }
                    for (dir, other, d) in [(u, v, 0), (u, v, 1), (v, u, 0), (v, u, 1)] {
                        let mut p = base;
                        p[other] += d;
                        edges.insert((p, dir));
                    }
                }
            }
        }
        vertices.len() as i64 - edges.len() as i64 + faces
    }
}

/// V − E + F of a closed surface (its welded vertices, edges and triangles).
/// The six face neighbours of a cube.
fn face_neighbours(c: [i32; 3]) -> [[i32; 3]; 6] {
    let [x, y, z] = c;
    [[x - 1, y, z], [x + 1, y, z], [x, y - 1, z], [x, y + 1, z], [x, y, z - 1], [x, y, z + 1]]
}

/// Removes every cube with five exposed faces (a bump on a face: it touches the rest by one
/// face) and fills every empty cube with five full neighbours (a pit), until none is left;
/// both keep the topology. Their winding numbers put them in or out by a hair (their centre
/// is near the surface), but projected onto the surface a bump's side faces fall onto its
/// footprint's rim and a pit's onto its mouth's: cells of no area that no later relaxation
/// undoes.
fn remove_bumps_and_pits(set: &mut HashSet<[i32; 3]>, inside_box: &dyn Fn([i32; 3]) -> bool) {
    loop {
        let full = |c: &[i32; 3]| set.contains(c);
        let bumps: Vec<[i32; 3]> =
            set.iter().copied().filter(|&c| face_neighbours(c).iter().filter(|n| full(n)).count() == 1).collect();
        let candidates: HashSet<[i32; 3]> =
            set.iter().flat_map(|&c| face_neighbours(c)).filter(|n| !full(n) && inside_box(*n)).collect();
        let pits: Vec<[i32; 3]> =
            candidates.into_iter().filter(|&c| face_neighbours(c).iter().filter(|n| full(n)).count() == 5).collect();
        if bumps.is_empty() && pits.is_empty() {
            return;
        }
        for c in bumps {
            set.remove(&c);
        }
        set.extend(pits);
    }
}

fn euler_characteristic_of(surface: &TriMesh) -> i64 {
    let mut edges = HashSet::new();
    for t in surface.triangles() {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.insert((a.min(b), a.max(b)));
        }
    }
    surface.positions().len() as i64 - edges.len() as i64 + surface.triangles().len() as i64
}

/// The 8 cubes around lattice point `p` (the 2×2×2 block with `p` at its centre), in the
/// order x fastest.
fn block_cells(p: [i32; 3]) -> [[i32; 3]; 8] {
    std::array::from_fn(|k| [p[0] - 1 + (k & 1) as i32, p[1] - 1 + ((k >> 1) & 1) as i32, p[2] - 1 + ((k >> 2) & 1) as i32])
}

/// Why the 2×2×2 occupancy `mask` (bit k: cube k of [`block_cells`]) makes the surface
/// non-manifold at its centre, if it does: the union of cubes has a 2-manifold surface exactly
/// where, in every 2×2×2 block, the full cubes are face-connected and so are the empty ones
/// (Latecki's well-composed sets).
fn critical(mask: u8) -> Option<&'static str> {
    if mask == 0 || mask == 0xff {
        return None;
    }
    if !face_connected(mask) {
        Some("cubes touch along an edge or at a corner only")
    } else if !face_connected(!mask) {
        Some("empty cubes touch along an edge or at a corner only (the surface pinches)")
    } else {
        None
    }
}

/// Whether the cubes of `mask` in a 2×2×2 block are connected through shared faces (two cubes
/// of the block share a face when their indices differ in one bit).
fn face_connected(mask: u8) -> bool {
    let start = mask.trailing_zeros();
    let mut seen = 1u8 << start;
    let mut stack = vec![start];
    while let Some(k) = stack.pop() {
        for bit in [1, 2, 4] {
            let n = k ^ bit;
            if mask & (1 << n) != 0 && seen & (1 << n) == 0 {
                seen |= 1 << n;
                stack.push(n);
            }
        }
    }
    seen == mask
}

/// The occupancy mask of the block around lattice point `p`.
fn mask_at(set: &HashSet<[i32; 3]>, p: [i32; 3]) -> u8 {
    block_cells(p).iter().enumerate().fold(0, |m, (k, c)| if set.contains(c) { m | 1 << k } else { m })
}

/// Every lattice point touched by a cube, once.
fn lattice_points(set: &HashSet<[i32; 3]>) -> HashSet<[i32; 3]> {
    set.iter().flat_map(|c| (0..8).map(move |k| [c[0] + (k & 1), c[1] + ((k >> 1) & 1), c[2] + ((k >> 2) & 1)])).collect()
}

/// The lattice points where the surface is not a manifold, sorted.
fn critical_points(set: &HashSet<[i32; 3]>) -> Vec<[i32; 3]> {
    let mut points: Vec<[i32; 3]> = lattice_points(set).into_iter().filter(|&p| critical(mask_at(set, p)).is_some()).collect();
    points.sort_unstable_by_key(|c| (c[2], c[1], c[0]));
    points
}

/// The first (in z, y, x order) lattice point where the surface is not a manifold, and why.
fn first_critical(set: &HashSet<[i32; 3]>) -> Option<([i32; 3], &'static str)> {
    critical_points(set).first().map(|&p| (p, critical(mask_at(set, p)).expect("a critical point")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_block_has_the_euler_characteristic_of_a_sphere() {
        let p = Polycube::block(DVec3::ZERO, 1.0, [3, 2, 4]).unwrap();
        assert_eq!(p.cells().len(), 24);
        assert_eq!(p.euler_characteristic(), 2);
    }

    #[test]
    fn a_ring_of_cubes_is_a_torus() {
        // A 3×3 ring (the centre missing): one handle, χ = 0.
        let cells = (0..3).flat_map(|y| (0..3).map(move |x| [x, y, 0])).filter(|&c| c != [1, 1, 0]).collect();
        let p = Polycube::from_cells(DVec3::ZERO, 2.0, cells).unwrap();
        assert_eq!(p.euler_characteristic(), 0);
    }

    #[test]
    fn cubes_touching_along_an_edge_or_a_corner_are_refused() {
        let edge = Polycube::from_cells(DVec3::ZERO, 1.0, vec![[0, 0, 0], [1, 1, 0]]);
        assert!(matches!(edge, Err(PolygridError::NonManifold { at: [1, 1, _], .. })), "{edge:?}");
        let corner = Polycube::from_cells(DVec3::ZERO, 1.0, vec![[0, 0, 0], [1, 1, 1]]);
        assert!(matches!(corner, Err(PolygridError::NonManifold { at: [1, 1, 1], .. })), "{corner:?}");
        // Seven cubes of a 2×2×2 block with the eighth's opposite missing as well: the empty
        // cubes touch at the centre only.
        let cells = (0..8).filter(|&k| k != 0 && k != 7).map(|k| [k & 1, (k >> 1) & 1, (k >> 2) & 1]).collect();
        let pinch = Polycube::from_cells(DVec3::ZERO, 1.0, cells);
        assert!(matches!(pinch, Err(PolygridError::NonManifold { at: [1, 1, 1], .. })), "{pinch:?}");
    }

    #[test]
    fn bad_lists_are_named() {
        assert!(matches!(Polycube::from_cells(DVec3::ZERO, 1.0, vec![]), Err(PolygridError::Empty(_))));
        assert!(matches!(Polycube::from_cells(DVec3::ZERO, f64::NAN, vec![[0; 3]]), Err(PolygridError::InvalidCube { .. })));
        assert!(matches!(Polycube::from_cells(DVec3::ZERO, -1.0, vec![[0; 3]]), Err(PolygridError::InvalidCube { .. })));
        assert!(matches!(
            Polycube::from_cells(DVec3::ZERO, 1.0, vec![[0; 3], [0; 3]]),
            Err(PolygridError::DuplicateCube { cell: [0, 0, 0] })
        ));
        assert!(matches!(Polycube::block(DVec3::ZERO, 1.0, [0, 3, 3]), Err(PolygridError::Empty(_))));
    }

    #[test]
    fn only_the_two_critical_kinds_of_the_256_blocks_are_critical() {
        // Brute force over all 2×2×2 occupancies: a block is critical exactly when two of its
        // full (or empty) cubes share only an edge or a corner and no face path joins them.
        let critical_count = (0..=255u8).filter(|&m| critical(m).is_some()).count();
        // Counted independently: 256 − (full-connected and empty-connected blocks).
        let ok = (0..=255u8)
            .filter(|&m| {
                let conn = |mask: u8| {
                    let cells: Vec<u8> = (0..8).filter(|k| mask & (1 << k) != 0).collect();
                    cells.is_empty() || {
                        // Union-find by repeated relaxation of labels.
                        let mut label: Vec<u8> = cells.clone();
                        for _ in 0..8 {
                            for (i, &a) in cells.iter().enumerate() {
                                for (j, &b) in cells.iter().enumerate() {
                                    if (a ^ b).count_ones() == 1 {
                                        let l = label[i].min(label[j]);
                                        label[i] = l;
                                        label[j] = l;
                                    }
                                }
                            }
                        }
                        label.iter().all(|&l| l == label[0])
                    }
                };
                conn(m) && conn(!m)
            })
            .count();
        assert_eq!(critical_count, 256 - ok);
        assert!(critical_count > 0);
    }

    #[test]
    fn a_voxelized_sphere_is_a_closed_manifold_of_genus_0() {
        let sphere = crate::mesh::icosphere(10.0, 4);
        let p = Polycube::voxelize(&sphere, 3.0).unwrap();
        assert_eq!(p.euler_characteristic(), 2);
        // Every cube centre inside the sphere is a cube; the volume within 20% of the ball's.
        let volume = p.cells().len() as f64 * 27.0;
        let ball = 4.0 / 3.0 * std::f64::consts::PI * 1000.0;
        assert!((volume / ball - 1.0).abs() < 0.2, "{volume} vs {ball}");
        // An open sheet (tilted, so that no cube centre lies on it) encloses nothing.
        let open = TriMesh::from_triangles(&[[0.0f64, 0.0, 0.3], [10.0, 0.0, 1.3], [0.0, 10.0, 0.3]], &[0, 1, 2]).unwrap();
        assert!(matches!(Polycube::voxelize(&open, 1.0), Err(PolygridError::Empty(_))));
    }
}
