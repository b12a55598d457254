//! The body-centred cubic (BCC) lattice of isosurface stuffing (Labelle & Shewchuk 2007, §2).
//!
//! Two interleaved cubic grids of spacing `h`: *corners* at `origin + h (i, j, k)` and *centres*
//! at `origin + h (i + ½, j + ½, k + ½)`. Lattice edges are *long* (axis-aligned, length `h`,
//! joining two vertices of the same grid; the paper's black edges) or *short* (length `√3 h / 2`,
//! joining a centre to one of its 8 cube corners; red edges). Every BCC tetrahedron has two
//! opposite long edges (centre–centre and corner–corner) and four short ones; there are 12 tets
//! per cube, each of volume `h³/12`.
//!
//! Vertex ids: corners first (`(nx+1)(ny+1)(nz+1)` of them), then centres (`nx·ny·nz`).

use glam::DVec3;

/// A BCC lattice over `n` cubes of side `h` starting at `origin`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Lattice {
    pub origin: DVec3,
    pub h: f64,
    /// Number of cubes (= centres) along each axis.
    pub n: [usize; 3],
}

impl Lattice {
    /// Number of corner vertices.
    pub fn corner_count(&self) -> usize {
        (self.n[0] + 1) * (self.n[1] + 1) * (self.n[2] + 1)
    }

    /// Number of lattice vertices (corners and centres).
    pub fn vertex_count(&self) -> usize {
        self.corner_count() + self.n[0] * self.n[1] * self.n[2]
    }

    /// Id of corner `(i, j, k)`.
    pub fn corner(&self, [i, j, k]: [usize; 3]) -> u32 {
        (i + (self.n[0] + 1) * (j + (self.n[1] + 1) * k)) as u32
    }

    /// Id of centre `(i, j, k)`.
    pub fn center(&self, [i, j, k]: [usize; 3]) -> u32 {
        (self.corner_count() + i + self.n[0] * (j + self.n[1] * k)) as u32
    }

    /// Whether vertex `v` is a corner (else a centre).
    pub fn is_corner(&self, v: u32) -> bool {
        (v as usize) < self.corner_count()
    }

    /// Integer coordinates of vertex `v` and whether it is a corner.
    pub fn coords(&self, v: u32) -> ([usize; 3], bool) {
        let v = v as usize;
        let nc = self.corner_count();
        if v < nc {
            let (sx, sy) = (self.n[0] + 1, self.n[1] + 1);
            ([v % sx, (v / sx) % sy, v / (sx * sy)], true)
        } else {
            let v = v - nc;
            let (sx, sy) = (self.n[0], self.n[1]);
            ([v % sx, (v / sx) % sy, v / (sx * sy)], false)
        }
    }

    /// Position of vertex `v`.
    pub fn position(&self, v: u32) -> DVec3 {
        let ([i, j, k], corner) = self.coords(v);
        let off = if corner { 0.0 } else { 0.5 };
        self.origin + self.h * DVec3::new(i as f64 + off, j as f64 + off, k as f64 + off)
    }

    /// The lattice neighbours of `v` (up to 6 long, then up to 8 short), with `true` for long
    /// edges. Returns the number written.
    pub fn neighbours(&self, v: u32, out: &mut [(u32, bool); 14]) -> usize {
        let ([i, j, k], corner) = self.coords(v);
        let c = [i as isize, j as isize, k as isize];
        let mut count = 0;
        let limit = |axis: usize| {
            if corner {
                self.n[axis] as isize
            } else {
                self.n[axis] as isize - 1
            }
        };
        for axis in 0..3 {
            for step in [-1isize, 1] {
                let mut d = c;
                d[axis] += step;
                if d[axis] >= 0 && d[axis] <= limit(axis) {
                    let d = [d[0] as usize, d[1] as usize, d[2] as usize];
                    out[count] = (if corner { self.corner(d) } else { self.center(d) }, true);
                    count += 1;
                }
            }
        }
        for dz in 0..2isize {
            for dy in 0..2isize {
                for dx in 0..2isize {
                    if corner {
                        // Centres (i−dx, j−dy, k−dz) have this corner among theirs.
                        let d = [c[0] - dx, c[1] - dy, c[2] - dz];
                        if (0..3).all(|a| d[a] >= 0 && d[a] < self.n[a] as isize) {
                            out[count] = (self.center([d[0] as usize, d[1] as usize, d[2] as usize]), false);
                            count += 1;
                        }
                    } else {
                        let d = [i + dx as usize, j + dy as usize, k + dz as usize];
                        out[count] = (self.corner(d), false);
                        count += 1;
                    }
                }
            }
        }
        count
    }

    /// Calls `f` with the four lattice vertices of every BCC tet whose centre–centre edge starts
    /// at centre `(i, j, k)` (towards +x, +y, +z). Vertex order: the two centres (a long edge),
    /// then two corners (the opposite long edge).
    pub fn tets_at(&self, c: [usize; 3], mut f: impl FnMut([u32; 4])) {
        let a = self.center(c);
        for axis in 0..3 {
            if c[axis] + 1 >= self.n[axis] {
                continue;
            }
            let mut cb = c;
            cb[axis] += 1;
            let b = self.center(cb);
            // The shared cube face lies at corner coordinate c[axis] + 1; its four corners in
            // cyclic order over the two other axes.
            let (u, w) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |du: usize, dw: usize| {
                let mut k = c;
                k[axis] += 1;
                k[u] += du;
                k[w] += dw;
                self.corner(k)
            };
            let ring = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
            for q in 0..4 {
                f([a, b, ring[q], ring[(q + 1) % 4]]);
            }
        }
    }
}

/// Key of the undirected lattice edge `{a, b}`.
pub(crate) fn edge_key(a: u32, b: u32) -> u64 {
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    (u64::from(lo) << 32) | u64::from(hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::tet_volume;

    #[test]
    fn bcc_tets_tile_space_with_volume_h3_over_12() {
        let l = Lattice { origin: DVec3::ZERO, h: 2.0, n: [4, 4, 4] };
        let mut count = 0;
        l.tets_at([1, 1, 1], |t| {
            let v = tet_volume(t.map(|v| l.position(v))).abs();
            assert!((v - 8.0 / 12.0).abs() < 1e-12);
            // Two long edges of length h, four short ones of length √3 h / 2.
            let d = |a: usize, b: usize| (l.position(t[a]) - l.position(t[b])).length();
            assert!((d(0, 1) - 2.0).abs() < 1e-12 && (d(2, 3) - 2.0).abs() < 1e-12);
            for (a, b) in [(0, 2), (0, 3), (1, 2), (1, 3)] {
                assert!((d(a, b) - 3f64.sqrt()).abs() < 1e-12);
            }
            count += 1;
        });
        assert_eq!(count, 12);
    }

    #[test]
    fn neighbours_are_symmetric() {
        let l = Lattice { origin: DVec3::ZERO, h: 1.0, n: [3, 2, 4] };
        let mut buf = [(0, false); 14];
        let mut buf2 = [(0, false); 14];
        for v in 0..l.vertex_count() as u32 {
            let n = l.neighbours(v, &mut buf);
            for &(u, long) in &buf[..n] {
                let expect = if long { 1.0 } else { 3f64.sqrt() / 2.0 };
                assert!(((l.position(u) - l.position(v)).length() - expect).abs() < 1e-12);
                let m = l.neighbours(u, &mut buf2);
                assert!(buf2[..m].iter().any(|&(w, _)| w == v));
            }
        }
    }
}
