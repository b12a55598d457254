//! The polygrid's nodes and cells (Wang et al. 2008 §5.1, Fig. 4): every cube of a
//! [`Polycube`] cut into `resolution³` hex cells of one lattice, so that cubes sharing a face
//! share its nodes; each node 6-connected along the cells' edges.
//!
//! Nodes carry their lattice coordinates (cube · resolution + local), so the paper's
//! hierarchy is exact ([`Polygrid::coarsened`]: the nodes of even coordinates, with the
//! trilinear prolongation) and a colouring for Gauss–Seidel is the coordinates' parity.

use std::sync::Arc;

use glam::DVec3;
use rayon::prelude::*;

use super::domain::Polycube;
use super::error::PolygridError;
use crate::sparse::CsrPattern;

/// The most cells per cube edge.
pub const MAX_RESOLUTION: u32 = 256;

/// The most nodes a polygrid may have.
pub const MAX_NODES: u64 = 1 << 26;

/// No neighbour in that direction (the node is on the surface there).
pub const NONE: u32 = u32::MAX;

/// The six lattice directions, in the order of [`Polygrid::neighbours`]: −x, +x, −y, +y, −z, +z.
pub const DIRECTIONS: [[i32; 3]; 6] = [[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0], [0, 0, -1], [0, 0, 1]];

/// A polygrid: the hex cells of a polycube's cubes at a resolution, their nodes (positions in
/// scene units, moved onto the object by [`super::map`]) and the boundary quads.
///
/// Cell corners are in lattice order: corner k at offset (k & 1, k >> 1 & 1, k >> 2 & 1).
#[derive(Debug, Clone)]
pub struct Polygrid {
    polycube: Arc<Polycube>,
    resolution: u32,
    /// Lattice coordinates of every node, in z, y, x scan order.
    lattice: Vec<[i32; 3]>,
    positions: Vec<DVec3>,
    cells: Vec<[u32; 8]>,
    /// Lowest-corner lattice coordinates of every cell.
    cell_lattice: Vec<[i32; 3]>,
    neighbours: Vec<[u32; 6]>,
    /// Boundary quads, corners counter-clockwise seen from outside.
    quads: Vec<[u32; 4]>,
    on_boundary: Vec<bool>,
    /// Nodes below this id are lattice nodes; those from it on are the pillow's surface
    /// nodes (none without a pillow).
    lattice_nodes: usize,
    /// Per pillow surface node (id − `lattice_nodes`), the lattice node below it.
    base: Vec<u32>,
    /// Per lattice boundary node, its pillow surface node ([`NONE`] without a pillow).
    surface_of: Vec<u32>,
    /// Cells below this index are lattice cells; those from it on are pillow cells.
    lattice_cells: usize,
    /// Per pillow cell, the lattice direction (index into [`DIRECTIONS`]) its quad faces.
    pillow_dir: Vec<u8>,
    /// Node id per lattice point of the box `[lo, hi]` (x fastest), [`NONE`] where none.
    index: Vec<u32>,
    lo: [i32; 3],
    dims: [usize; 3],
}

impl Polygrid {
    /// The polygrid of `polycube` with `resolution` cells per cube edge, nodes at their lattice
    /// positions (the polycube itself).
    ///
    /// # Errors
    /// [`PolygridError::InvalidResolution`] outside 1..=[`MAX_RESOLUTION`];
    /// [`PolygridError::TooLarge`] beyond [`MAX_NODES`] nodes.
    pub fn new(polycube: Arc<Polycube>, resolution: u32) -> Result<Self, PolygridError> {
        Self::build(polycube, resolution, false)
    }

    /// [`Polygrid::new`] with a pillow: one layer of cells over the whole surface, between
    /// every boundary quad of the lattice and a copy of it (new surface nodes, one per lattice
    /// boundary node), so that every cell touching the surface does so by one face. The
    /// lattice's own boundary nodes then lie inside and can round the polycube's convex
    /// corners and edges, whose cells would otherwise have two or three faces mapped onto a
    /// smooth surface and flatten there (the paper's "edge and corner fix", §5.1, and its
    /// boundary layer, each boundary node linked to one interior node). A pillow cell's
    /// corners are in lattice order with the face's two lattice axes and the outward direction
    /// as axes (swapped for faces towards −axis, so every cell is right-handed): its Kuhn split
    /// conforms to the lattice cells' and to its neighbours'.
    ///
    /// # Errors
    /// As [`Polygrid::new`].
    pub fn with_pillow(polycube: Arc<Polycube>, resolution: u32) -> Result<Self, PolygridError> {
        Self::build(polycube, resolution, true)
    }

    fn build(polycube: Arc<Polycube>, resolution: u32, pillow: bool) -> Result<Self, PolygridError> {
        if resolution == 0 || resolution > MAX_RESOLUTION {
            return Err(PolygridError::InvalidResolution {
                resolution,
                reason: format!("it must be 1 to {MAX_RESOLUTION} cells per cube edge"),
            });
        }
        let r = resolution as i32;
        let cubes = polycube.cells();
        let estimate = cubes.len() as u64 * (resolution as u64 + 1).pow(3);
        if estimate > 4 * MAX_NODES {
            return Err(PolygridError::TooLarge { nodes: estimate, limit: MAX_NODES });
        }
        let cube_lo = cubes.iter().fold([i32::MAX; 3], |a, c| std::array::from_fn(|k| a[k].min(c[k])));
        let cube_hi = cubes.iter().fold([i32::MIN; 3], |a, c| std::array::from_fn(|k| a[k].max(c[k])));
        let lo: [i32; 3] = std::array::from_fn(|k| cube_lo[k] * r);
        let dims: [usize; 3] = std::array::from_fn(|k| ((cube_hi[k] - cube_lo[k] + 1) * r + 1) as usize);
        let box_points = dims.iter().map(|&d| d as u64).product::<u64>();
        if box_points > 8 * MAX_NODES {
            return Err(PolygridError::TooLarge { nodes: box_points, limit: MAX_NODES });
        }
        // Which cubes exist, on the cube box.
        let cube_dims: [usize; 3] = std::array::from_fn(|k| (cube_hi[k] - cube_lo[k] + 1) as usize);
        let mut cube_exists = vec![false; cube_dims.iter().product()];
        for c in cubes {
            cube_exists[flat(c, &cube_lo, &cube_dims).expect("inside the cube box")] = true;
        }
        let has_cube = |c: [i32; 3]| flat(&c, &cube_lo, &cube_dims).is_some_and(|i| cube_exists[i]);
        let has_cell = |l: [i32; 3]| has_cube(l.map(|x| x.div_euclid(r)));

        // Nodes: the corners of the cells, numbered in scan order.
        let mut index = vec![NONE; box_points as usize];
        for c in cubes {
            for z in 0..=r {
                for y in 0..=r {
                    for x in 0..=r {
                        let l = [c[0] * r + x, c[1] * r + y, c[2] * r + z];
                        index[flat(&l, &lo, &dims).expect("inside the box")] = 0;
                    }
                }
            }
        }
        let mut lattice = Vec::new();
        for (i, slot) in index.iter_mut().enumerate() {
            if *slot == 0 {
                *slot = lattice.len() as u32;
                lattice.push(unflat(i, &lo, &dims));
            }
        }
        if lattice.len() as u64 > MAX_NODES {
            return Err(PolygridError::TooLarge { nodes: lattice.len() as u64, limit: MAX_NODES });
        }
        let node = |l: [i32; 3]| flat(&l, &lo, &dims).map_or(NONE, |i| index[i]);

        // Cells, cube by cube.
        let mut cells = Vec::with_capacity(cubes.len() * (r * r * r) as usize);
        let mut cell_lattice = Vec::with_capacity(cells.capacity());
        for c in cubes {
            for z in 0..r {
                for y in 0..r {
                    for x in 0..r {
                        let l = [c[0] * r + x, c[1] * r + y, c[2] * r + z];
                        cells.push(std::array::from_fn(|k| {
                            node([l[0] + (k & 1) as i32, l[1] + ((k >> 1) & 1) as i32, l[2] + ((k >> 2) & 1) as i32])
                        }));
                        cell_lattice.push(l);
                    }
                }
            }
        }

        // Neighbours along cell edges: the edge from l to l + d belongs to a cell when one of
        // the four cells around it exists.
        let neighbours: Vec<[u32; 6]> = lattice
            .par_iter()
            .map(|&l| {
                std::array::from_fn(|dir| {
                    let d = DIRECTIONS[dir];
                    let axis = dir / 2;
                    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                    let mut base = l;
                    if d[axis] < 0 {
                        base[axis] -= 1;
                    }
                    let edge_in_cell = [(0, 0), (1, 0), (0, 1), (1, 1)].iter().any(|&(du, dv)| {
                        let mut c = base;
                        c[u] -= du;
                        c[v] -= dv;
                        has_cell(c)
                    });
                    if edge_in_cell {
                        node([l[0] + d[0], l[1] + d[1], l[2] + d[2]])
                    } else {
                        NONE
                    }
                })
            })
            .collect();

        // Boundary quads: the fine faces of every cube face with no cube beyond it, with their
        // corners in the lattice order of a pillow cell's bottom (see `with_pillow`).
        let mut quads = Vec::new();
        let mut quad_cells: Vec<([u32; 4], u8)> = Vec::new();
        for c in cubes {
            for (dir, d) in DIRECTIONS.iter().enumerate() {
                if has_cube([c[0] + d[0], c[1] + d[1], c[2] + d[2]]) {
                    continue;
                }
                let axis = dir / 2;
                let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                let plane = c[axis] * r + if d[axis] > 0 { r } else { 0 };
                for j in 0..r {
                    for i in 0..r {
                        let at = |a: i32, b: i32| {
                            let mut l = [0; 3];
                            l[axis] = plane;
                            l[u] = c[u] * r + i + a;
                            l[v] = c[v] * r + j + b;
                            node(l)
                        };
                        // (u, v, axis) is right-handed: counter-clockwise in (u, v) faces +axis.
                        let quad = [at(0, 0), at(1, 0), at(1, 1), at(0, 1)];
                        quads.push(if d[axis] > 0 { quad } else { [quad[0], quad[3], quad[2], quad[1]] });
                        // Lattice order (bit 0 along the first in-face axis, bit 1 the second):
                        // (u, v, out) right-handed towards +axis, (v, u, out) towards −axis.
                        let bottom = if d[axis] > 0 {
                            [at(0, 0), at(1, 0), at(0, 1), at(1, 1)]
                        } else {
                            [at(0, 0), at(0, 1), at(1, 0), at(1, 1)]
                        };
                        quad_cells.push((bottom, dir as u8));
                    }
                }
            }
        }
        let lattice_nodes = lattice.len();
        let lattice_cells = cells.len();
        let mut on_boundary = vec![false; lattice_nodes];
        for q in &quads {
            for &v in q {
                on_boundary[v as usize] = true;
            }
        }
        let mut surface_of = vec![NONE; lattice_nodes];
        let mut base = Vec::new();
        let mut pillow_dir = Vec::new();
        let mut neighbours = neighbours;
        if pillow {
            for (i, b) in on_boundary.iter_mut().enumerate() {
                if *b {
                    surface_of[i] = (lattice_nodes + base.len()) as u32;
                    base.push(i as u32);
                    *b = false;
                }
            }
            for (bottom, dir) in &quad_cells {
                let top = bottom.map(|b| surface_of[b as usize]);
                cells.push([bottom[0], bottom[1], bottom[2], bottom[3], top[0], top[1], top[2], top[3]]);
                cell_lattice.push(lattice[bottom[0] as usize]);
                pillow_dir.push(*dir);
            }
            for q in &mut quads {
                *q = q.map(|b| surface_of[b as usize]);
            }
            on_boundary.resize(lattice_nodes + base.len(), true);
            for &b in &base {
                lattice.push(lattice[b as usize]);
            }
            neighbours.resize(lattice.len(), [NONE; 6]);
        }
        let spacing = polycube.cube() / resolution as f64;
        let origin = polycube.origin();
        let positions =
            lattice.par_iter().map(|l| origin + DVec3::new(l[0] as f64, l[1] as f64, l[2] as f64) * spacing).collect();
        Ok(Self {
            polycube,
            resolution,
            lattice,
            positions,
            cells,
            cell_lattice,
            neighbours,
            quads,
            on_boundary,
            lattice_nodes,
            base,
            surface_of,
            lattice_cells,
            pillow_dir,
            index,
            lo,
            dims,
        })
    }

    /// The polycube the grid was cut from.
    #[must_use]
    pub fn polycube(&self) -> &Arc<Polycube> {
        &self.polycube
    }

    /// Cells per cube edge.
    #[must_use]
    pub fn resolution(&self) -> u32 {
        self.resolution
    }

    /// The lattice spacing before mapping (cube size / resolution), scene units.
    #[must_use]
    pub fn lattice_spacing(&self) -> f64 {
        self.polycube.cube() / self.resolution as f64
    }

    /// Number of nodes.
    #[must_use]
    pub fn node_count(&self) -> usize {
        self.lattice.len()
    }

    /// Lattice coordinates of every node (a pillow's surface node has those of the lattice node
    /// below it).
    #[must_use]
    pub fn lattice(&self) -> &[[i32; 3]] {
        &self.lattice
    }

    /// Whether the grid has a pillow ([`Polygrid::with_pillow`]).
    #[must_use]
    pub fn has_pillow(&self) -> bool {
        self.lattice_nodes < self.lattice.len()
    }

    /// Number of lattice nodes: node ids below it are lattice nodes, those from it on the
    /// pillow's surface nodes.
    #[must_use]
    pub fn lattice_node_count(&self) -> usize {
        self.lattice_nodes
    }

    /// Number of lattice cells: cells below it are lattice cells, those from it on the
    /// pillow's cells.
    #[must_use]
    pub fn lattice_cell_count(&self) -> usize {
        self.lattice_cells
    }

    /// Per pillow surface node (node id − [`Polygrid::lattice_node_count`]), the lattice node
    /// below it.
    #[must_use]
    pub fn pillow_base(&self) -> &[u32] {
        &self.base
    }

    /// The node linked to node `i` through the pillow: a lattice boundary node's surface node,
    /// a surface node's base; [`NONE`] for every other node and without a pillow.
    #[must_use]
    pub fn pillow_partner(&self, i: u32) -> u32 {
        let i = i as usize;
        match i.checked_sub(self.lattice_nodes) {
            None => self.surface_of[i],
            Some(k) => self.base[k],
        }
    }

    /// Node `i`'s links as the paper's stencil sees them: its lattice neighbours
    /// ([`Polygrid::neighbours`]) and its [`Polygrid::pillow_partner`] (the only link of a
    /// pillow's surface node).
    pub fn links(&self, i: u32) -> impl Iterator<Item = u32> + '_ {
        let lattice = self.neighbours[i as usize].into_iter();
        lattice.chain([self.pillow_partner(i)]).filter(|&j| j != NONE)
    }

    /// The node at lattice point `l`, if any (a lattice node).
    #[must_use]
    pub fn node_at(&self, l: [i32; 3]) -> Option<u32> {
        flat(&l, &self.lo, &self.dims).map(|i| self.index[i]).filter(|&n| n != NONE)
    }

    /// Node positions in scene units.
    #[must_use]
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// Replaces the node positions (the map onto the object, [`super::map`]).
    ///
    /// # Panics
    /// When `positions` has another length (a bug of the caller, inside the crate).
    pub(crate) fn set_positions(&mut self, positions: Vec<DVec3>) {
        assert_eq!(positions.len(), self.positions.len());
        self.positions = positions;
    }

    /// The hex cells (8 node ids each, lattice order).
    #[must_use]
    pub fn cells(&self) -> &[[u32; 8]] {
        &self.cells
    }

    /// Lowest-corner lattice coordinates of every cell.
    #[must_use]
    pub fn cell_lattice(&self) -> &[[i32; 3]] {
        &self.cell_lattice
    }

    /// Per node its neighbour along each of [`DIRECTIONS`], [`NONE`] where the node has none
    /// (lattice links only: a pillow's links are its cells' edges, [`Polygrid::edge_pattern`]).
    #[must_use]
    pub fn neighbours(&self) -> &[[u32; 6]] {
        &self.neighbours
    }

    /// The boundary quads, counter-clockwise seen from outside.
    #[must_use]
    pub fn quads(&self) -> &[[u32; 4]] {
        &self.quads
    }

    /// Whether each node lies on the surface.
    #[must_use]
    pub fn on_boundary(&self) -> &[bool] {
        &self.on_boundary
    }

    /// The cells split into tets by Kuhn's rule (Freudenthal): per cell the six paths from
    /// corner 0 to corner 7 through the lattice directions, tets 6c … 6c + 5 of cell c. The
    /// split of a shared face is its diagonal from the lower to the higher lattice corner in
    /// both cells, so the tets are conforming; every edge joins lattice points that differ by
    /// a vector of {0, 1}³, so [`Polygrid::parity_colours`] separates them.
    #[must_use]
    pub fn kuhn_tets(&self) -> Vec<[u32; 4]> {
        const PATHS: [[usize; 2]; 6] = [[1, 2], [1, 4], [2, 1], [2, 4], [4, 1], [4, 2]];
        self.cells.iter().flat_map(|c| PATHS.map(|[a, b]| [c[0], c[a], c[a | b], c[7]])).collect()
    }

    /// The graph of the cells' edges (lattice nodes 6-connected, pillow links too) as a CSR
    /// pattern with diagonal.
    ///
    /// # Errors
    /// Only for a grid beyond the pattern's index range.
    pub fn edge_pattern(&self) -> Result<CsrPattern, PolygridError> {
        const EDGES: [[usize; 2]; 12] =
            [[0, 1], [2, 3], [4, 5], [6, 7], [0, 2], [1, 3], [4, 6], [5, 7], [0, 4], [1, 5], [2, 6], [3, 7]];
        let edges: Vec<[u32; 2]> = self.cells.iter().flat_map(|c| EDGES.map(|[a, b]| [c[a], c[b]])).collect();
        Ok(CsrPattern::from_edges(self.node_count(), &edges)?)
    }

    /// The 8-colouring of the nodes by the parity of their lattice coordinates
    /// (x&1 + 2(y&1) + 4(z&1)): no two nodes of a cell share a colour, so any stencil on the
    /// cells (the 7-point stencils, the Kuhn-split FEM's 15) is Gauss–Seidel-parallel per colour.
    /// With a pillow, its surface nodes take their base's colour + 8 (16 colours).
    #[must_use]
    pub fn parity_colours(&self) -> Vec<u8> {
        let pillow = self.lattice_nodes;
        self.lattice
            .iter()
            .enumerate()
            .map(|(i, l)| ((l[0] & 1) + 2 * (l[1] & 1) + 4 * (l[2] & 1)) as u8 + if i >= pillow { 8 } else { 0 })
            .collect()
    }

    /// The red-black colouring (x + y + z) & 1, flipped on a pillow's surface nodes: valid for
    /// the stencils on the cells' edges (finite volumes), not for the Kuhn split.
    #[must_use]
    pub fn red_black(&self) -> Vec<u8> {
        let pillow = self.lattice_nodes;
        self.lattice
            .iter()
            .enumerate()
            .map(|(i, l)| (((l[0] + l[1] + l[2]) & 1) as usize ^ usize::from(i >= pillow)) as u8)
            .collect()
    }

    /// The next coarser level of the paper's hierarchy (§5.3): the same polycube at half the
    /// resolution, its nodes those of even lattice coordinates, at their positions here (so the
    /// coarse surface nodes stay on the surface), and the trilinear prolongation from it: per
    /// fine node, its coarse parents and weights (each a product of ½ per odd coordinate).
    ///
    /// # Errors
    /// [`PolygridError::InvalidResolution`] for an odd resolution.
    pub fn coarsened(&self) -> Result<(Polygrid, Prolongation), PolygridError> {
        if !self.resolution.is_multiple_of(2) {
            return Err(PolygridError::InvalidResolution {
                resolution: self.resolution,
                reason: "a hierarchy level halves it, so it must be even".into(),
            });
        }
        let mut coarse = Polygrid::build(Arc::clone(&self.polycube), self.resolution / 2, self.has_pillow())?;
        let fine_lattice_node =
            |l: [i32; 3]| self.node_at(l.map(|x| 2 * x)).expect("an even lattice point of a cell corner is a node");
        let fine_of: Vec<u32> = (0..coarse.node_count())
            .map(|c| {
                let f = fine_lattice_node(coarse.lattice[c]);
                if c >= coarse.lattice_nodes {
                    self.surface_of[f as usize]
                } else {
                    f
                }
            })
            .collect();
        coarse.positions = fine_of.iter().map(|&f| self.positions[f as usize]).collect();
        let rows: Vec<Vec<(u32, f64)>> = (0..self.node_count())
            .into_par_iter()
            .map(|i| {
                let l = self.lattice[i];
                let mut parents = vec![([0i32; 3], 1.0)];
                for k in 0..3 {
                    if l[k] % 2 == 0 {
                        for p in &mut parents {
                            p.0[k] = l[k] / 2;
                        }
                    } else {
                        parents = parents
                            .into_iter()
                            .flat_map(|(p, w)| {
                                let (mut a, mut b) = (p, p);
                                a[k] = l[k].div_euclid(2);
                                b[k] = l[k].div_euclid(2) + 1;
                                [(a, 0.5 * w), (b, 0.5 * w)]
                            })
                            .collect();
                    }
                }
                // A pillow node's parents are the pillow nodes over its base's parents (on the
                // same cube faces, so on the surface too).
                let pillow = i >= self.lattice_nodes;
                parents
                    .into_iter()
                    .map(|(p, w)| {
                        let c = coarse.node_at(p).expect("the corners of a coarse cell are nodes");
                        (if pillow { coarse.surface_of[c as usize] } else { c }, w)
                    })
                    .collect()
            })
            .collect();
        let mut row_ptr = Vec::with_capacity(rows.len() + 1);
        row_ptr.push(0);
        let (mut cols, mut weights) = (Vec::new(), Vec::new());
        for r in rows {
            for (c, w) in r {
                cols.push(c);
                weights.push(w);
            }
            row_ptr.push(cols.len());
        }
        // Per fine cell, the coarse cell holding it.
        let cubes = self.polycube.cells();
        let rc = coarse.resolution as i32;
        let coarse_lattice_cell = |l: [i32; 3]| {
            let l = l.map(|x| x.div_euclid(2));
            let cube = l.map(|x| x.div_euclid(rc));
            let k =
                cubes.binary_search_by_key(&(cube[2], cube[1], cube[0]), |c| (c[2], c[1], c[0])).expect("a cube of the polycube");
            let local = [0, 1, 2].map(|a| (l[a] - cube[a] * rc) as usize);
            let rc = rc as usize;
            (k * rc * rc * rc + (local[2] * rc + local[1]) * rc + local[0]) as u32
        };
        let pillow_index: std::collections::HashMap<([i32; 3], u8), u32> = (coarse.lattice_cells..coarse.cells.len())
            .map(|c| ((coarse.cell_lattice[c], coarse.pillow_dir[c - coarse.lattice_cells]), c as u32))
            .collect();
        let cell_parent = (0..self.cells.len())
            .map(|c| {
                let l = self.cell_lattice[c];
                if c < self.lattice_cells {
                    coarse_lattice_cell(l)
                } else {
                    let dir = self.pillow_dir[c - self.lattice_cells];
                    pillow_index[&(l.map(|x| x.div_euclid(2)), dir)]
                }
            })
            .collect();
        Ok((coarse, Prolongation { coarse_count: fine_of.len(), row_ptr, cols, weights, fine_of, cell_parent }))
    }
}

/// The trilinear prolongation from a coarse level to the fine one ([`Polygrid::coarsened`]):
/// per fine node its coarse parents (1, 2, 4 or 8) and weights summing to 1.
#[derive(Debug, Clone, PartialEq)]
pub struct Prolongation {
    coarse_count: usize,
    row_ptr: Vec<usize>,
    cols: Vec<u32>,
    weights: Vec<f64>,
    /// Per coarse node, the fine node at the same lattice point.
    fine_of: Vec<u32>,
    /// Per fine cell, the coarse cell holding it.
    cell_parent: Vec<u32>,
}

impl Prolongation {
    /// Number of fine nodes (rows).
    #[must_use]
    pub fn fine_count(&self) -> usize {
        self.row_ptr.len() - 1
    }

    /// Number of coarse nodes (columns).
    #[must_use]
    pub fn coarse_count(&self) -> usize {
        self.coarse_count
    }

    /// Fine node `i`'s coarse parents and their weights.
    #[must_use]
    pub fn row(&self, i: usize) -> (&[u32], &[f64]) {
        let r = self.row_ptr[i]..self.row_ptr[i + 1];
        (&self.cols[r.clone()], &self.weights[r])
    }

    /// Per coarse node, the fine node at its lattice point.
    #[must_use]
    pub fn fine_of(&self) -> &[u32] {
        &self.fine_of
    }

    /// Per fine cell, the coarse cell holding it (8 lattice cells, or 4 pillow cells, per
    /// coarse cell): for averaging cell media, σa and σ′s, never κ.
    #[must_use]
    pub fn cell_parent(&self) -> &[u32] {
        &self.cell_parent
    }

    /// `fine = P coarse` (trilinear interpolation).
    ///
    /// # Panics
    /// On vectors of the wrong length.
    pub fn prolong(&self, coarse: &[[f64; 3]], fine: &mut [[f64; 3]]) {
        assert_eq!((coarse.len(), fine.len()), (self.coarse_count, self.fine_count()));
        fine.par_iter_mut().enumerate().for_each(|(i, f)| {
            let (cols, w) = self.row(i);
            *f = cols.iter().zip(w).fold([0.0; 3], |acc, (&c, &w)| std::array::from_fn(|k| acc[k] + w * coarse[c as usize][k]));
        });
    }

    /// The fine-to-coarse average of a per-node quantity: each coarse node the weighted mean
    /// of the fine nodes whose parent it is (Pᵀ x normalised by Pᵀ 1): full weighting.
    #[must_use]
    pub fn average<const N: usize>(&self, fine: &[[f64; N]]) -> Vec<[f64; N]> {
        let mut sum = vec![[0.0; N]; self.coarse_count];
        let mut weight = vec![0.0; self.coarse_count];
        for (i, f) in fine.iter().enumerate() {
            let (cols, w) = self.row(i);
            for (&c, &w) in cols.iter().zip(w) {
                weight[c as usize] += w;
                for k in 0..N {
                    sum[c as usize][k] += w * f[k];
                }
            }
        }
        sum.iter().zip(&weight).map(|(s, &w)| s.map(|x| x / w)).collect()
    }

    /// The weights as a CSR pattern and values (fine × coarse), for sparse transfer kernels.
    #[must_use]
    pub fn csr(&self) -> (&[usize], &[u32], &[f64]) {
        (&self.row_ptr, &self.cols, &self.weights)
    }
}

/// Index of lattice point `l` in the box at `lo` of `dims` points (x fastest), if inside.
fn flat(l: &[i32; 3], lo: &[i32; 3], dims: &[usize; 3]) -> Option<usize> {
    let d: [i64; 3] = std::array::from_fn(|k| l[k] as i64 - lo[k] as i64);
    if (0..3).any(|k| d[k] < 0 || d[k] >= dims[k] as i64) {
        return None;
    }
    Some(d[0] as usize + dims[0] * (d[1] as usize + dims[1] * d[2] as usize))
}

/// The lattice point of box index `i` (inverse of [`flat`]).
fn unflat(i: usize, lo: &[i32; 3], dims: &[usize; 3]) -> [i32; 3] {
    [lo[0] + (i % dims[0]) as i32, lo[1] + ((i / dims[0]) % dims[1]) as i32, lo[2] + (i / (dims[0] * dims[1])) as i32]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn l_shape(resolution: u32) -> Polygrid {
        let cubes = Polycube::from_cells(DVec3::ZERO, 2.0, vec![[0, 0, 0], [1, 0, 0], [0, 1, 0]]).unwrap();
        Polygrid::new(Arc::new(cubes), resolution).unwrap()
    }

    #[test]
    fn cubes_share_the_nodes_of_their_common_faces() {
        let r = 4u32;
        let g = l_shape(r);
        // Three cubes of (r+1)³ nodes, two shared faces of (r+1)² nodes each.
        let n = (r + 1).pow(3) as usize;
        assert_eq!(g.node_count(), 3 * n - 2 * (r + 1).pow(2) as usize);
        assert_eq!(g.cells().len(), 3 * r.pow(3) as usize);
        // The surface of the L: 14 cube faces of r² quads each.
        assert_eq!(g.quads().len(), 14 * (r * r) as usize);
        // Every cell has positive volume in lattice order, every quad faces outward: the
        // divergence theorem gives the volume 3 × 2³ from the quads.
        let p = g.positions();
        let volume: f64 = g
            .quads()
            .iter()
            .map(|q| {
                let [a, b, c, d] = q.map(|i| p[i as usize]);
                (a.dot((b - a).cross(c - a)) + a.dot((c - a).cross(d - a))) / 6.0
            })
            .sum();
        assert!((volume - 24.0).abs() < 1e-9, "{volume}");
    }

    #[test]
    fn neighbours_follow_cell_edges_only() {
        // A C of five cubes at resolution 1, open towards +x: the nodes (2,1,0) and (2,2,0)
        // across the opening are lattice neighbours, but no cell edge joins them.
        let cubes = Polycube::from_cells(DVec3::ZERO, 1.0, vec![[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 2, 0], [1, 2, 0]]).unwrap();
        let g = Polygrid::new(Arc::new(cubes), 1).unwrap();
        let a = g.node_at([2, 1, 0]).unwrap();
        let b = g.node_at([2, 2, 0]).unwrap();
        assert_eq!(g.neighbours()[a as usize][3], NONE);
        assert_eq!(g.neighbours()[b as usize][2], NONE);
        // (1,1,0)-(1,2,0) runs along cube [0,1,0]'s edge: neighbours.
        let c = g.node_at([1, 1, 0]).unwrap();
        let d = g.node_at([1, 2, 0]).unwrap();
        assert_eq!(g.neighbours()[c as usize][3], d);
        assert_eq!(g.neighbours()[c as usize][1], a);
        // Symmetry of the neighbour relation.
        for (i, n) in g.neighbours().iter().enumerate() {
            for (dir, &j) in n.iter().enumerate() {
                if j != NONE {
                    assert_eq!(g.neighbours()[j as usize][dir ^ 1], i as u32);
                }
            }
        }
    }

    fn pillowed_l(resolution: u32) -> Polygrid {
        let cubes = Polycube::from_cells(DVec3::ZERO, 2.0, vec![[0, 0, 0], [1, 0, 0], [0, 1, 0]]).unwrap();
        Polygrid::with_pillow(Arc::new(cubes), resolution).unwrap()
    }

    #[test]
    fn parity_colours_separate_every_pair_of_cell_corners() {
        for g in [l_shape(3), pillowed_l(3)] {
            let colour = g.parity_colours();
            let rb = g.red_black();
            for cell in g.cells() {
                for a in 0..8 {
                    for b in a + 1..8 {
                        assert_ne!(colour[cell[a] as usize], colour[cell[b] as usize]);
                    }
                }
                for [a, b] in crate::polygrid::CELL_EDGES {
                    assert_ne!(rb[cell[a] as usize], rb[cell[b] as usize]);
                }
            }
        }
    }

    #[test]
    fn a_pillow_covers_the_surface_with_one_layer_of_right_handed_cells() {
        let r = 2u32;
        let plain = l_shape(r);
        let g = pillowed_l(r);
        let boundary_lattice = plain.on_boundary().iter().filter(|&&b| b).count();
        assert_eq!(g.node_count(), plain.node_count() + boundary_lattice);
        assert_eq!(g.cells().len(), plain.cells().len() + plain.quads().len());
        // Surface nodes only on the surface; every lattice node inside.
        assert!(g.on_boundary()[..g.lattice_node_count()].iter().all(|&b| !b));
        assert!(g.on_boundary()[g.lattice_node_count()..].iter().all(|&b| b));
        // Push every surface node one unit out along its face normals: every pillow cell is
        // then a right-handed box (positive corner Jacobians), and the Kuhn split conforms (a
        // tet mesh with a closed manifold boundary).
        let mut normals = vec![Vec::new(); g.node_count()];
        for (q, lattice_quad) in g.quads().iter().zip(plain.quads().iter()) {
            let [a, b, c, _] = lattice_quad.map(|i| plain.positions()[i as usize]);
            let n = (b - a).cross(c - a).normalize();
            for &i in q {
                if !normals[i as usize].contains(&n) {
                    normals[i as usize].push(n);
                }
            }
        }
        let mut p = g.positions().to_vec();
        for (x, n) in p.iter_mut().zip(&normals) {
            *x += 0.25 * n.iter().sum::<DVec3>();
        }
        let mut moved = g.clone();
        moved.set_positions(p);
        crate::polygrid::map::check_cells(&moved, "test").unwrap();
        let tets = crate::mesh::TetMesh::new(moved.positions().to_vec(), moved.kuhn_tets(), vec![]).unwrap();
        assert!(tets.boundary_topology().is_closed_manifold());
        assert_eq!(tets.boundary_faces().len(), 2 * g.quads().len());
    }

    #[test]
    fn prolongation_is_exact_for_linear_functions() {
        for g in [l_shape(4), pillowed_l(4)] {
            check_prolongation(&g);
        }
        assert!(l_shape(3).coarsened().is_err());
    }

    fn check_prolongation(g: &Polygrid) {
        let (coarse, p) = g.coarsened().unwrap();
        assert_eq!(coarse.resolution(), 2);
        assert_eq!(p.coarse_count(), coarse.node_count());
        let f = |x: DVec3| [1.0 + 2.0 * x.x - x.y + 0.5 * x.z, x.x * 3.0, -x.z];
        let c: Vec<[f64; 3]> = coarse.positions().iter().map(|&x| f(x)).collect();
        let mut fine = vec![[0.0; 3]; g.node_count()];
        p.prolong(&c, &mut fine);
        for (x, v) in g.positions().iter().zip(&fine) {
            let e = f(*x);
            for k in 0..3 {
                assert!((v[k] - e[k]).abs() < 1e-12);
            }
        }
        // The average of a constant is the constant.
        let avg = p.average(&vec![[2.5]; g.node_count()]);
        assert!(avg.iter().all(|a| (a[0] - 2.5).abs() < 1e-12));
        // Each coarse cell holds 8 lattice or 4 pillow fine cells, inside it.
        let mut count = vec![0; coarse.cells().len()];
        for (c, &parent) in p.cell_parent().iter().enumerate() {
            count[parent as usize] += 1;
            let pillow_fine = c >= g.lattice_cell_count();
            assert_eq!(pillow_fine, parent as usize >= coarse.lattice_cell_count());
            let l = g.cell_lattice()[c];
            let lc = coarse.cell_lattice()[parent as usize];
            assert!((0..3).all(|k| l[k].div_euclid(2) == lc[k]), "{l:?} in {lc:?}");
        }
        for (c, n) in count.iter().enumerate() {
            assert_eq!(*n, if c < coarse.lattice_cell_count() { 8 } else { 4 });
        }
    }

    #[test]
    fn bad_resolutions_are_named() {
        let cubes = Arc::new(Polycube::block(DVec3::ZERO, 1.0, [1, 1, 1]).unwrap());
        assert!(matches!(Polygrid::new(Arc::clone(&cubes), 0), Err(PolygridError::InvalidResolution { resolution: 0, .. })));
        assert!(matches!(
            Polygrid::new(Arc::clone(&cubes), 1_000_000),
            Err(PolygridError::InvalidResolution { resolution: 1_000_000, .. })
        ));
    }
}
