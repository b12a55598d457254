//! The background mesh of isosurface stuffing: BCC tetrahedra on a balanced octree of cubes
//! (Labelle & Shewchuk 2007, §5, graded stuffing).
//!
//! Every leaf cube contributes its corners (the black vertices) and its centre (a red vertex).
//! Tets are formed face by face, as in the uniform BCC lattice, with two transition stencils:
//!
//! * **same-size neighbour** — the four BCC tets `(r, r′, e₀, e₁)` spanned by the two centres and
//!   each edge of the shared face; an edge whose midpoint is a vertex (a smaller cube touches it)
//!   is bisected there: `(r, r′, e₀, m)`, `(r, r′, m, e₁)`;
//! * **four half-size neighbours** — the big cube's pyramid over the face is split into eight
//!   orthoschemes `(r, f, e₀, m)`, `(r, f, m, e₁)` around the face centre `f`, and each small cube's
//!   pyramid over its quarter face into two half pyramids along the diagonal from `f`. Both sides
//!   triangulate the face with the same fan around `f`, so the mesh is conforming.
//!
//! The octree is **strongly balanced**: cubes that touch (across a face, an edge or a vertex)
//! differ in size by at most 2, so face edges have at most one midpoint and the three cases above
//! are all there are. The transition tets are of three shapes, none with a dihedral angle below 45°
//! or above 120° (see the tests), far inside the BCC tet's bounds; the stencils that cut tets at
//! the surface only ever see the uniform BCC tets of the finest level, because every cube within
//! two spacings of the surface, and every cube touching one of those, is of the finest level.
//!
//! Sizes: level-k cubes have side `2ᵏ h`. Away from the surface each size is kept for at least
//! `layers` cubes before the next doubling.

use glam::DVec3;
use rayon::prelude::*;

use super::lattice::Lattice;
use super::stuffing::{accurate_winding, inside};
use super::winding::WindingNumber;
use crate::mesh::closest_point_on_triangle;

/// The coarsest level allowed: cubes of side `32 h`.
const MAX_LEVEL: usize = 5;

/// Distance from the surface, in finest spacings, within which cubes are of the finest level.
/// Vertices within one spacing of the surface can end a cut edge (and be warped); a cube holding
/// such a vertex has its centre within `(1 + √3/2) h < 2 h` of the surface.
const BAND: f64 = 2.0;

/// The balanced octree of BCC cubes over a lattice's box.
pub(crate) struct Octree {
    /// The finest cubes (level 0): origin, side `h`, and their counts, multiples of `2^levels`.
    pub fine: Lattice,
    /// Level of the coarsest cubes.
    pub levels: usize,
    /// `split[k][c]`: whether cube `c` of level `k` is divided into eight (empty for `k = 0`).
    split: Vec<Vec<bool>>,
}

/// The tets of an octree before stuffing.
pub(crate) struct Background {
    /// Vertex positions: cube corners first, then cube centres.
    pub positions: Vec<DVec3>,
    /// Number of corner vertices.
    pub corners: usize,
    /// Tets; the uniform BCC tets have their two long edges at `(0, 1)` and `(2, 3)`.
    pub tets: Vec<[u32; 4]>,
    /// Whether each tet is a BCC tet between two finest-level cubes (the only ones the cutting
    /// stencils may see).
    pub standard: Vec<bool>,
    /// Leaf cubes per level.
    pub leaves_per_level: Vec<usize>,
}

impl Background {
    /// Whether vertex `v` is a cube corner (else a centre).
    pub fn is_corner(&self, v: u32) -> bool {
        (v as usize) < self.corners
    }
}

/// The finest lattice padded on its upper side to whole coarsest cubes, and the number of levels:
/// the largest (up to [`MAX_LEVEL`]) whose cubes fit four times along the shortest side, so that
/// padding adds at most a quarter per axis.
pub(crate) fn padded(lattice: &Lattice, coarsen: bool) -> (Lattice, usize) {
    let shortest = *lattice.n.iter().min().expect("three axes");
    let mut levels = 0;
    while coarsen && levels < MAX_LEVEL && (4usize << (levels + 1)) <= shortest {
        levels += 1;
    }
    let unit = 1usize << levels;
    let n = lattice.n.map(|c| c.div_ceil(unit) * unit);
    (Lattice { n, ..*lattice }, levels)
}

fn dims(fine: &Lattice, level: usize) -> [usize; 3] {
    fine.n.map(|c| c >> level)
}

fn index(d: [usize; 3], c: [usize; 3]) -> usize {
    c[0] + d[0] * (c[1] + d[1] * c[2])
}

fn coords(d: [usize; 3], i: usize) -> [usize; 3] {
    [i % d[0], (i / d[0]) % d[1], i / (d[0] * d[1])]
}

/// Whether any triangle of `surface` comes within `r` of `p`.
fn near(surface: &WindingNumber, p: DVec3, r: f64) -> bool {
    let r2 = r * r;
    surface.bvh().any_triangle(
        |lo, hi| (p.clamp(lo, hi) - p).length_squared() <= r2,
        |t| (closest_point_on_triangle(p, *t).0 - p).length_squared() <= r2,
    )
}

/// The finest cubes that must stay finest: those whose centre is within [`BAND`] spacings of the
/// surface, and with `fill_inside` (the uniform mesh) also every cube inside the solid. Found top
/// down from the coarsest cubes, so far-away space costs one query per coarse cube.
///
/// Where the surface is a cycle, the cubes that no triangle comes near (inside or outside, also
/// those a graded octree leaves coarse) are returned as [`Known`] with their coarse cube's centre
/// winding number, so their vertices cost no evaluation; otherwise nothing is known.
pub(crate) fn band(surface: &WindingNumber, fine: &Lattice, levels: usize, fill_inside: bool) -> (Vec<bool>, Known) {
    let d0 = dims(fine, 0);
    let roots = dims(fine, levels);
    let h = fine.h;
    let cycle = surface.is_cycle();
    // Per root: the finest cubes needed near the surface, and the coarse cubes away from it
    // (level, coordinates, centre winding number, filled) whose winding number was evaluated.
    type Away = (usize, [usize; 3], f64, bool);
    let lists: Vec<(Vec<u32>, Vec<Away>)> = (0..roots.iter().product::<usize>())
        .into_par_iter()
        .map(|r| {
            let mut out = Vec::new();
            let mut away = Vec::new();
            let mut stack = vec![(levels, coords(roots, r))];
            while let Some((k, c)) = stack.pop() {
                let side = (1usize << k) as f64 * h;
                let centre = fine.origin + side * (DVec3::from_array(c.map(|x| x as f64)) + 0.5);
                // The finest centres inside this cube are within √3/2 (side − h) of its centre.
                let reach = BAND * h + 0.5 * 3f64.sqrt() * (side - h);
                if near(surface, centre, reach) {
                    if k == 0 {
                        out.push(index(d0, c) as u32);
                    } else {
                        for child in 0..8 {
                            stack.push((k - 1, std::array::from_fn(|a| 2 * c[a] + ((child >> a) & 1))));
                        }
                    }
                } else if fill_inside || cycle {
                    let w = accurate_winding(surface, centre);
                    let fill = fill_inside && inside(w);
                    if fill || cycle {
                        away.push((k, c, w, fill));
                    }
                }
            }
            (out, away)
        })
        .collect();
    let mut needed = vec![false; d0.iter().product()];
    let mut known = Known { fine: *fine, winding: vec![f64::NAN; if cycle { needed.len() } else { 0 }] };
    for (out, away) in lists {
        for i in out {
            needed[i as usize] = true;
        }
        for (k, c, w, fill) in away {
            let s = 1usize << k;
            for z in 0..s {
                for y in 0..s {
                    for x in 0..s {
                        let i = index(d0, [c[0] * s + x, c[1] * s + y, c[2] * s + z]);
                        needed[i] |= fill;
                        if cycle {
                            known.winding[i] = w;
                        }
                    }
                }
            }
        }
    }
    (needed, known)
}

/// Finest cubes whose winding number is known without evaluating it at their vertices: cubes
/// [`band`] found no triangle within [`BAND`] − √3/2 spacings of, each with the winding number
/// at the centre of the coarse cube it tested. Where the surface is a
/// cycle (every edge as often in one direction as in the other: closed, consistently oriented
/// shells, overlapping or not) the winding number is an integer constant on any region free of
/// triangles, so it is exact at every point of such a cube; elsewhere nothing is kept.
pub(crate) struct Known {
    fine: Lattice,
    /// Per finest cube, in grid order; NaN where unknown (empty when none is known).
    winding: Vec<f64>,
}

impl Known {
    /// The winding number at `p` if `p` lies in (or on the boundary of) a known cube.
    pub fn at(&self, p: DVec3) -> Option<f64> {
        if self.winding.is_empty() {
            return None;
        }
        let d = dims(&self.fine, 0);
        let q = (p - self.fine.origin) / self.fine.h;
        // The cubes whose closed box holds p: one per axis, two where p is on a grid plane.
        let span = |a: usize| {
            let r = q[a].round();
            if (q[a] - r).abs() < 1e-9 {
                (r - 1.0, r)
            } else {
                (q[a].floor(), q[a].floor())
            }
        };
        let (x, y, z) = (span(0), span(1), span(2));
        for cz in [z.0, z.1] {
            for cy in [y.0, y.1] {
                for cx in [x.0, x.1] {
                    let c = [cx, cy, cz];
                    if c.iter().zip(d).all(|(&v, n)| v >= 0.0 && (v as usize) < n) {
                        let w = self.winding[index(d, c.map(|v| v as usize))];
                        if !w.is_nan() {
                            return Some(w);
                        }
                    }
                }
            }
        }
        None
    }
}

/// Marks as needed every finest cube that meets one of `boxes` grown by one spacing.
pub(crate) fn mark_boxes(needed: &mut [bool], fine: &Lattice, boxes: &[(DVec3, DVec3)]) {
    let d0 = dims(fine, 0);
    for &(lo, hi) in boxes {
        let first = ((lo - fine.origin) / fine.h - 1.0).floor().max(DVec3::ZERO);
        let last = ((hi - fine.origin) / fine.h + 1.0).floor();
        let range = |a: usize| first[a] as usize..=(last[a] as usize).min(d0[a] - 1);
        for z in range(2) {
            for y in range(1) {
                for x in range(0) {
                    needed[index(d0, [x, y, z])] = true;
                }
            }
        }
    }
}

/// Cells within Chebyshev distance `r` of a marked cell of the grid `d` (separable max filter).
fn dilate(grid: &[bool], d: [usize; 3], r: usize) -> Vec<bool> {
    let mut cur = grid.to_vec();
    for axis in 0..3 {
        let stride = [1, d[0], d[0] * d[1]][axis];
        let len = d[axis];
        cur = (0..cur.len())
            .into_par_iter()
            .map(|i| {
                let x = (i / stride) % len;
                let base = i - x * stride;
                (x.saturating_sub(r)..=(x + r).min(len - 1)).any(|y| cur[base + y * stride])
            })
            .collect();
    }
    cur
}

/// The parent grid (half the size per axis) marked where any child is.
fn coarsen(grid: &[bool], d: [usize; 3]) -> Vec<bool> {
    let p = d.map(|c| c / 2);
    (0..p.iter().product::<usize>())
        .into_par_iter()
        .map(|i| {
            let c = coords(p, i);
            (0..8).any(|child| grid[index(d, std::array::from_fn(|a| 2 * c[a] + ((child >> a) & 1)))])
        })
        .collect()
}

impl Octree {
    /// The coarsest balanced octree over `fine` whose finest level holds the `needed` cubes and
    /// their neighbours, with at least `layers` cubes of each size between a size and the next.
    ///
    /// A cube of level `k ≥ 1` is split when a split cube (or, at level 0, a needed cube) of the
    /// level below lies within `layers` cubes of one of its children. Then every split cube's 26
    /// neighbours of its own size exist, which is the strong 2:1 balance: a leaf next to a cube
    /// split twice would have to be split itself.
    pub fn new(fine: Lattice, levels: usize, needed: &[bool], layers: usize) -> Self {
        let layers = layers.max(1);
        let mut split: Vec<Vec<bool>> = vec![Vec::new()];
        for k in 0..levels {
            let d = dims(&fine, k);
            let below = if k == 0 { needed } else { &split[k] };
            let next = coarsen(&dilate(below, d, layers), d);
            split.push(next);
        }
        Self { fine, levels, split }
    }

    fn is_split(&self, k: usize, c: [usize; 3]) -> bool {
        k > 0 && self.split[k][index(dims(&self.fine, k), c)]
    }

    fn exists(&self, k: usize, c: [usize; 3]) -> bool {
        k == self.levels || self.split[k + 1][index(dims(&self.fine, k + 1), c.map(|x| x / 2))]
    }

    /// The neighbour of cube `c` (level `k`) one step along `axis` in direction `step`, if inside
    /// the domain.
    fn step(&self, k: usize, c: [usize; 3], axis: usize, step: isize) -> Option<[usize; 3]> {
        let mut n = c;
        let x = c[axis] as isize + step;
        (x >= 0 && (x as usize) < dims(&self.fine, k)[axis]).then(|| {
            n[axis] = x as usize;
            n
        })
    }

    /// The leaves, vertices and tets.
    pub fn background(&self) -> Background {
        let fine = &self.fine;
        let d0 = dims(fine, 0);
        // Leaves, finest first; a leaf's centre is vertex `corners + leaf`.
        let mut leaves: Vec<(usize, [usize; 3])> = Vec::new();
        let mut leaf_id: Vec<Vec<u32>> = Vec::with_capacity(self.levels + 1);
        let mut leaves_per_level = Vec::with_capacity(self.levels + 1);
        for k in 0..=self.levels {
            let d = dims(fine, k);
            let mut ids = vec![u32::MAX; d.iter().product()];
            let before = leaves.len();
            for (i, id) in ids.iter_mut().enumerate() {
                let c = coords(d, i);
                if self.exists(k, c) && !self.is_split(k, c) {
                    *id = leaves.len() as u32;
                    leaves.push((k, c));
                }
            }
            leaves_per_level.push(leaves.len() - before);
            leaf_id.push(ids);
        }
        // Corner vertices on the finest grid of corners, numbered in grid order.
        let cd = d0.map(|c| c + 1);
        let mut corner_id = vec![u32::MAX; cd.iter().product()];
        for &(k, c) in &leaves {
            let s = 1usize << k;
            for corner in 0..8 {
                corner_id[index(cd, std::array::from_fn(|a| (c[a] + ((corner >> a) & 1)) * s))] = 0;
            }
        }
        let mut positions = Vec::new();
        for (i, id) in corner_id.iter_mut().enumerate() {
            if *id == 0 {
                *id = positions.len() as u32;
                let q = coords(cd, i);
                positions.push(fine.origin + fine.h * DVec3::from_array(q.map(|x| x as f64)));
            }
        }
        let corners = positions.len();
        for &(k, c) in &leaves {
            let side = (1usize << k) as f64 * fine.h;
            positions.push(fine.origin + side * (DVec3::from_array(c.map(|x| x as f64)) + 0.5));
        }

        // Corner `q` of level `k` (in that level's corner coordinates); `half` adds half a cube
        // along the axes it names (midpoints and face centres, which are finer corners).
        let corner = |k: usize, q: [usize; 3], half: [bool; 3]| -> u32 {
            let s = 1usize << k;
            let id = corner_id[index(cd, std::array::from_fn(|a| q[a] * s + if half[a] { s / 2 } else { 0 }))];
            debug_assert!(id != u32::MAX, "a transition vertex is a corner of a finer leaf");
            id
        };
        let centre = |k: usize, c: [usize; 3]| corners as u32 + leaf_id[k][index(dims(fine, k), c)];

        let per_leaf: Vec<Vec<([u32; 4], bool)>> = leaves
            .par_iter()
            .map(|&(k, c)| {
                let mut out = Vec::new();
                let r = centre(k, c);
                for axis in 0..3 {
                    let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
                    for side in [-1isize, 1] {
                        let Some(n) = self.step(k, c, axis, side) else { continue };
                        // The face's plane, in corner coordinates of level k.
                        let plane = if side > 0 { c[axis] + 1 } else { c[axis] };
                        let at = |du: usize, dw: usize| {
                            let mut q = c;
                            q[axis] = plane;
                            q[u] += du;
                            q[w] += dw;
                            q
                        };
                        // The face's corners in cyclic order, and for each edge (ring[i],
                        // ring[i+1]) the offset (axis, direction) towards the cubes beyond it.
                        let ring = [at(0, 0), at(1, 0), at(1, 1), at(0, 1)];
                        let beyond = [(w, -1isize), (u, 1), (w, 1), (u, -1)];
                        // Edge e's two ends, and its midpoint (half a cube along the edge from its
                        // lower end).
                        let ends = |e: usize| (corner(k, ring[e], [false; 3]), corner(k, ring[(e + 1) % 4], [false; 3]));
                        let midpoint = |e: usize| {
                            let mut half = [false; 3];
                            half[if e.is_multiple_of(2) { u } else { w }] = true;
                            corner(k, if e < 2 { ring[e] } else { ring[(e + 1) % 4] }, half)
                        };
                        if self.exists(k, n) && !self.is_split(k, n) {
                            // Same-size neighbour: BCC tets, once per face (from the − side).
                            if side < 0 {
                                continue;
                            }
                            let rn = centre(k, n);
                            for (e, &(ba, bs)) in beyond.iter().enumerate() {
                                let (e0, e1) = ends(e);
                                let split_edge =
                                    [c, n].iter().any(|&x| self.step(k, x, ba, bs).is_some_and(|y| self.is_split(k, y)));
                                if split_edge {
                                    let m = midpoint(e);
                                    out.push(([r, rn, e0, m], false));
                                    out.push(([r, rn, m, e1], false));
                                } else {
                                    out.push(([r, rn, e0, e1], k == 0));
                                }
                            }
                        } else if self.exists(k, n) {
                            // Four half-size neighbours: eight orthoschemes around the face centre.
                            let mut fh = [true; 3];
                            fh[axis] = false;
                            let f = corner(k, ring[0], fh);
                            for e in 0..4 {
                                let (e0, e1) = ends(e);
                                let m = midpoint(e);
                                out.push(([r, f, e0, m], false));
                                out.push(([r, f, m, e1], false));
                            }
                        } else {
                            // A twice larger neighbour: two half pyramids along the diagonal from
                            // the big face's centre f to its corner opposite.
                            let mid = |a: usize| 2 * (c[a] / 2) + 1;
                            let far = |a: usize| if mid(a) == c[a] { c[a] + 1 } else { c[a] };
                            let q = |iu: usize, iw: usize| {
                                let mut q = c;
                                q[axis] = plane;
                                q[u] = iu;
                                q[w] = iw;
                                corner(k, q, [false; 3])
                            };
                            let (f, opposite) = (q(mid(u), mid(w)), q(far(u), far(w)));
                            out.push(([r, f, opposite, q(mid(u), far(w))], false));
                            out.push(([r, f, opposite, q(far(u), mid(w))], false));
                        }
                    }
                }
                out
            })
            .collect();
        let (tets, standard) = per_leaf.into_iter().flatten().unzip();
        Background { positions, corners, tets, standard, leaves_per_level }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{dihedral_angles, tet_volume, TetMesh};

    /// An octree over 16³ finest cubes with a block of needed cubes and a lone one, so that all
    /// three levels and every transition case appear.
    fn tree(layers: usize) -> Octree {
        let fine = Lattice { origin: DVec3::new(0.3, -0.2, 0.1), h: 0.5, n: [16, 16, 16] };
        let (fine, levels) = padded(&fine, true);
        assert_eq!(levels, 2);
        let d0 = dims(&fine, 0);
        // A block of needed cubes and a lone one.
        let needed: Vec<bool> = (0..d0.iter().product())
            .map(|i| {
                let c = coords(d0, i);
                c.iter().all(|&x| (2..=4).contains(&x)) || c == [12, 5, 9]
            })
            .collect();
        Octree::new(fine, levels, &needed, layers)
    }

    #[test]
    fn transition_tets_fill_the_domain_conformingly_with_bounded_angles() {
        for layers in [1, 2] {
            let t = tree(layers);
            let bg = t.background();
            assert!(bg.leaves_per_level.iter().all(|&n| n > 0), "{:?}", bg.leaves_per_level);
            // The tets fill every leaf cube except, at the rim, the pyramids from a leaf's
            // centre over its faces on the domain's boundary (volume s³/6 each).
            let mut expected = t.fine.n.iter().map(|&n| n as f64 * t.fine.h).product::<f64>();
            for k in 0..=t.levels {
                let d = dims(&t.fine, k);
                let side = (1usize << k) as f64 * t.fine.h;
                for i in 0..d.iter().product::<usize>() {
                    let c = coords(d, i);
                    if t.exists(k, c) && !t.is_split(k, c) {
                        let rim = (0..3).flat_map(|a| [-1, 1].map(|s| t.step(k, c, a, s).is_none())).filter(|&x| x).count();
                        expected -= rim as f64 * side.powi(3) / 6.0;
                    }
                }
            }
            let volume: f64 = bg.tets.iter().map(|tet| tet_volume(tet.map(|v| bg.positions[v as usize])).abs()).sum();
            assert!((volume / expected - 1.0).abs() < 1e-12, "{volume} vs {expected}");
            // Conforming: a valid mesh whose every boundary triangle is the side of such a rim
            // pyramid, with two vertices on one face of the domain's box. A hanging vertex or an
            // overlap would leave boundary triangles inside.
            let mesh = TetMesh::new(bg.positions.clone(), bg.tets.clone(), vec![0; bg.tets.len()]).unwrap();
            let lo = t.fine.origin;
            let hi = lo + DVec3::from_array(t.fine.n.map(|n| n as f64)) * t.fine.h;
            for f in mesh.boundary_faces() {
                let p = f.vertices.map(|v| mesh.positions()[v as usize]);
                let on = |a: usize, x: f64| p.iter().filter(|q| (q[a] - x).abs() < 1e-9).count() >= 2;
                assert!((0..3).any(|a| on(a, lo[a]) || on(a, hi[a])), "a boundary face inside the domain: {p:?}");
            }
            // Dihedral angles: the BCC tet has 60° and 90°; its bisection, the orthoscheme and
            // the half pyramid (the three transition shapes) lie within [45°, 120°].
            for (tet, &standard) in bg.tets.iter().zip(&bg.standard) {
                let angles = dihedral_angles(tet.map(|v| bg.positions[v as usize]));
                let (lo, hi) =
                    angles.iter().fold((180.0f64, 0.0f64), |(a, b), &x| (a.min(x.to_degrees()), b.max(x.to_degrees())));
                if standard {
                    assert!((lo - 60.0).abs() < 1e-9 && (hi - 90.0).abs() < 1e-9, "{lo} {hi}");
                } else {
                    assert!(lo >= 45.0 - 1e-9 && hi <= 120.0 + 1e-9, "{lo} {hi}");
                }
            }
        }
    }

    #[test]
    fn neighbouring_leaves_differ_by_at_most_one_level() {
        let t = tree(1);
        // Every leaf's 26 neighbourhood, sampled at the finest level, holds leaves of adjacent
        // levels only.
        let d0 = dims(&t.fine, 0);
        let level_at =
            |c: [usize; 3]| (0..=t.levels).find(|&k| t.exists(k, c.map(|x| x >> k)) && !t.is_split(k, c.map(|x| x >> k)));
        for i in 0..d0.iter().product::<usize>() {
            let c = coords(d0, i);
            let k = level_at(c).unwrap();
            for dz in -1isize..=1 {
                for dy in -1isize..=1 {
                    for dx in -1isize..=1 {
                        let n = [c[0] as isize + dx, c[1] as isize + dy, c[2] as isize + dz];
                        if (0..3).all(|a| n[a] >= 0 && (n[a] as usize) < d0[a]) {
                            let m = level_at(n.map(|x| x as usize)).unwrap();
                            assert!(k.abs_diff(m) <= 1, "levels {k} and {m} touch at {c:?}");
                        }
                    }
                }
            }
        }
    }

    /// Every vertex of a background over a sphere, uniform or graded, that [`Known`] answers for
    /// gets the winding number evaluated there (an integer for a closed sphere: 1 inside, 0
    /// outside), corners on cube faces included, and lies away from the surface; and the known
    /// ones are a real share of the interior and of the exterior.
    #[test]
    fn known_cubes_give_the_winding_number_of_their_points() {
        let sphere = crate::mesh::icosphere(1.0, 3);
        let surface = WindingNumber::of_surface(sphere.positions(), sphere.triangles());
        assert!(surface.is_cycle());
        let fine = Lattice { origin: DVec3::splat(-1.37), h: 0.09, n: [31, 31, 31] };
        let (fine, levels) = padded(&fine, true);
        for fill_inside in [true, false] {
            let (needed, known) = band(&surface, &fine, levels, fill_inside);
            let bg = Octree::new(fine, levels, &needed, 1).background();
            let inside = bg.positions.iter().filter(|p| p.length() < 1.0).count();
            let (mut answered_inside, mut answered_outside) = (0, 0);
            for &p in &bg.positions {
                if let Some(w) = known.at(p) {
                    let exact = if p.length() < 1.0 { 1.0 } else { 0.0 };
                    assert!((w - exact).abs() < 0.05 && (surface.at_with_accuracy(p, 5.0) - exact).abs() < 0.01, "{p}: {w}");
                    assert!((p.length() - 1.0).abs() > 1.1 * fine.h, "{p} is too near the surface to be known");
                    if exact == 1.0 {
                        answered_inside += 1;
                    } else {
                        answered_outside += 1;
                    }
                }
            }
            let outside = bg.positions.len() - inside;
            assert!(answered_inside > inside / 10 && answered_inside < inside, "{answered_inside} known of {inside} inside");
            assert!(
                answered_outside > outside / 10 && answered_outside < outside,
                "{answered_outside} known of {outside} outside"
            );
        }
    }
}
