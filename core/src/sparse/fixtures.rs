//! Test fixtures shared by the unit tests of the sparse module.

use super::csr::{CsrMatrix3, Triplet};

/// A 3-D grid Laplacian (7-point) with a per-channel absorption, like a diffusion matrix:
/// SPD, unit-free, with a spread diagonal.
pub(crate) fn grid(nx: usize) -> CsrMatrix3 {
    let id = |x: usize, y: usize, z: usize| ((z * nx + y) * nx + x) as u32;
    let mut t = Vec::new();
    for z in 0..nx {
        for y in 0..nx {
            for x in 0..nx {
                let i = id(x, y, z);
                let mut deg = 0.0;
                for (dx, dy, dz) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                    let (u, v, w) = (x + dx, y + dy, z + dz);
                    if u < nx && v < nx && w < nx {
                        let k = 1.0 + 0.5 * ((x + 2 * y + 3 * z) % 5) as f64;
                        t.push(Triplet::new(i, id(u, v, w), [-k, -0.7 * k, -1.3 * k]));
                        t.push(Triplet::new(id(u, v, w), i, [-k, -0.7 * k, -1.3 * k]));
                        t.push(Triplet::new(id(u, v, w), id(u, v, w), [k, 0.7 * k, 1.3 * k]));
                        deg += k;
                    }
                }
                t.push(Triplet::new(i, i, [deg + 0.01, 0.7 * deg + 0.05, 1.3 * deg + 0.2]));
            }
        }
    }
    CsrMatrix3::from_triplets(nx * nx * nx, &t).unwrap()
}

pub(crate) fn rhs(n: usize) -> Vec<[f64; 3]> {
    (0..n).map(|i| [((i * 7) % 11) as f64 - 3.0, (i % 5) as f64, 1.0 + (i % 3) as f64]).collect()
}
