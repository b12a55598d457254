//! The body-centred cubic (BCC) lattice of isosurface stuffing (Labelle & Shewchuk 2007, §2).
//!
//! Two interleaved cubic grids of spacing `h`: *corners* at `origin + h (i, j, k)` and *centres*
//! at `origin + h (i + ½, j + ½, k + ½)`. Lattice edges are *long* (axis-aligned, length `h`,
//! joining two vertices of the same grid; the paper's black edges) or *short* (length `√3 h / 2`,
//! joining a centre to one of its 8 cube corners; red edges). Every BCC tetrahedron has two
//! opposite long edges (centre–centre and corner–corner) and four short ones; there are 12 tets
//! per cube, each of volume `h³/12`. The octree ([`super::octree`]) builds its finest level on
//! this lattice and coarser cubes from it.

use glam::DVec3;

/// A BCC lattice over `n` cubes of side `h` starting at `origin`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Lattice {
    pub origin: DVec3,
    pub h: f64,
    /// Number of cubes (= centres) along each axis.
    pub n: [usize; 3],
}

/// Key of the undirected edge `{a, b}`.
pub(crate) fn edge_key(a: u32, b: u32) -> u64 {
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    (u64::from(lo) << 32) | u64::from(hi)
}
