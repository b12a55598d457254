//! Welding: merging vertices whose positions lie within a tolerance of each other.
//!
//! A hash grid with cells as wide as the tolerance finds candidates: a point can only be within
//! the tolerance of points in the cells its tolerance box touches (at most 2 per axis, so 8
//! cells). Points are visited in user order and each joins the lowest-numbered representative
//! within the tolerance, or becomes a representative itself. Distances are measured to
//! representatives, never to other members, so welding does not creep along chains of close
//! points, and the result depends only on the input order.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use glam::DVec3;

/// The outcome of welding: the distinct positions and, for each input point, its welded vertex.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Welded {
    /// Positions of the welded vertices, in order of their representatives' input index.
    pub positions: Vec<DVec3>,
    /// For each input point, the welded vertex that stands for it.
    pub map: Vec<u32>,
}

/// Merges points closer than `tolerance` (absolute distance). `tolerance == 0`, or a tolerance
/// below 1e-15 of the points' extent (finer than `f64` can resolve there), merges only identical
/// positions (with `-0.0 == 0.0`). The lowest input index of a group is its
/// representative, and the welded position is the representative's position.
///
/// Points must be finite and `tolerance` finite and non-negative (checked by the caller).
pub(crate) fn weld(points: &[DVec3], tolerance: f64) -> Welded {
    debug_assert!(tolerance.is_finite() && tolerance >= 0.0);
    debug_assert!(u32::try_from(points.len()).is_ok());
    let mut positions = Vec::with_capacity(points.len());
    let mut map = Vec::with_capacity(points.len());

    if points.is_empty() {
        return Welded { positions, map };
    }

    let lo = points.iter().fold(DVec3::splat(f64::INFINITY), |a, p| a.min(*p));
    let hi = points.iter().fold(DVec3::splat(f64::NEG_INFINITY), |a, p| a.max(*p));
    // Cells must not be so small that cell coordinates overflow or lose meaning.
    let extent = (hi - lo).max_element();
    let tolerance_usable = tolerance > 0.0 && extent / tolerance < 1e15;

    if !tolerance_usable {
        // Exact welding: identical coordinates only.
        let mut seen: FastMap<[u64; 3], u32> = FastMap::default();
        seen.reserve(points.len());
        for p in points {
            let key = [bits(p.x), bits(p.y), bits(p.z)];
            let next = positions.len() as u32;
            let id = *seen.entry(key).or_insert(next);
            if id == next {
                positions.push(*p);
            }
            map.push(id);
        }
        return Welded { positions, map };
    }

    let inv = 1.0 / tolerance;
    let tol2 = tolerance * tolerance;
    let cell_of = |x: f64, o: f64| -> i64 { ((x - o) * inv).floor() as i64 };
    // Each cell lists the welded vertices whose representative lies in it, in increasing order.
    let mut grid: FastMap<[i64; 3], Vec<u32>> = FastMap::default();
    grid.reserve(points.len());
    for p in points {
        let mut best: Option<u32> = None;
        let (x0, x1) = (cell_of(p.x - tolerance, lo.x), cell_of(p.x + tolerance, lo.x));
        let (y0, y1) = (cell_of(p.y - tolerance, lo.y), cell_of(p.y + tolerance, lo.y));
        let (z0, z1) = (cell_of(p.z - tolerance, lo.z), cell_of(p.z + tolerance, lo.z));
        for cx in x0..=x1 {
            for cy in y0..=y1 {
                for cz in z0..=z1 {
                    let Some(ids) = grid.get(&[cx, cy, cz]) else {
                        continue;
                    };
                    for &id in ids {
                        if best.is_some_and(|b| b <= id) {
                            break; // ids are increasing within a cell
                        }
                        if positions[id as usize].distance_squared(*p) <= tol2 {
                            best = Some(id);
                            break;
                        }
                    }
                }
            }
        }
        let id = match best {
            Some(id) => id,
            None => {
                let id = positions.len() as u32;
                positions.push(*p);
                let cell = [cell_of(p.x, lo.x), cell_of(p.y, lo.y), cell_of(p.z, lo.z)];
                grid.entry(cell).or_default().push(id);
                id
            }
        };
        map.push(id);
    }
    Welded { positions, map }
}

/// Bit pattern of a coordinate with `-0.0` folded onto `0.0`.
fn bits(x: f64) -> u64 {
    if x == 0.0 {
        0
    } else {
        x.to_bits()
    }
}

/// A hash map with a fast, non-cryptographic hasher for small integer keys.
pub(crate) type FastMap<K, V> = HashMap<K, V, BuildHasherDefault<FastHasher>>;

/// Multiply-rotate hasher (as in rustc's FxHash): fast for integer keys, not DoS-resistant,
/// which is fine for geometry keys.
#[derive(Default, Clone, Copy)]
pub(crate) struct FastHasher(u64);

impl FastHasher {
    const K: u64 = 0x517c_c1b7_2722_0a95;
    #[inline]
    fn add(&mut self, word: u64) {
        self.0 = (self.0.rotate_left(5) ^ word).wrapping_mul(Self::K);
    }
}

impl Hasher for FastHasher {
    #[inline]
    fn finish(&self) -> u64 {
        // Final avalanche so that the low bits used by the table depend on every input bit.
        let mut h = self.0;
        h ^= h >> 33;
        h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^= h >> 33;
        h
    }
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut w = [0u8; 8];
            w[..chunk.len()].copy_from_slice(chunk);
            self.add(u64::from_le_bytes(w));
        }
    }
    #[inline]
    fn write_u32(&mut self, i: u32) {
        self.add(u64::from(i));
    }
    #[inline]
    fn write_u64(&mut self, i: u64) {
        self.add(i);
    }
    #[inline]
    fn write_i64(&mut self, i: i64) {
        self.add(i as u64);
    }
    #[inline]
    fn write_usize(&mut self, i: usize) {
        self.add(i as u64);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_duplicates_merge_to_lowest_index() {
        let p = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), DVec3::new(-0.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0)];
        let w = weld(&p, 0.0);
        assert_eq!(w.positions.len(), 2);
        assert_eq!(w.map, vec![0, 1, 0, 1]);
    }

    #[test]
    fn close_points_merge_within_tolerance_only() {
        let p = [
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 1.0),
            DVec3::new(0.4e-3, 0.0, 0.0),
            DVec3::new(2.0e-3, 0.0, 0.0),
            DVec3::new(1.0, 1.0, 1.0 + 0.9e-3),
        ];
        let w = weld(&p, 1e-3);
        assert_eq!(w.map, vec![0, 1, 0, 2, 1]);
        assert_eq!(w.positions[0], p[0]);
        assert_eq!(w.positions[2], p[3]);
    }

    #[test]
    fn no_creep_along_chains() {
        // Points 0.6 tol apart: each is within tol of its neighbour but the chain is 3 tol long.
        let p: Vec<DVec3> = (0..6).map(|i| DVec3::new(0.6 * f64::from(i), 0.0, 0.0)).collect();
        let w = weld(&p, 1.0);
        // 0 represents 0,1 (0.6); 2 at 1.2 is too far from 0 -> new; 3 at 1.8 joins 2; ...
        assert_eq!(w.map, vec![0, 0, 1, 1, 2, 2]);
    }

    #[test]
    fn lowest_index_wins_across_cells() {
        // Point 2 is within tolerance of both 0 and 1 (which are not within tolerance of each
        // other); it must join 0, the lower index, whatever cell it is in.
        let p = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(1.5, 0.0, 0.0), DVec3::new(0.75, 0.0, 0.0)];
        let w = weld(&p, 1.0);
        assert_eq!(w.map, vec![0, 1, 0]);
        let q = [DVec3::new(1.5, 0.0, 0.0), DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.75, 0.0, 0.0)];
        assert_eq!(weld(&q, 1.0).map, vec![0, 1, 0]);
    }

    #[test]
    fn matches_brute_force_on_random_cloud() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let base: Vec<DVec3> = (0..300).map(|_| DVec3::new(rng.random(), rng.random(), rng.random()) * 10.0).collect();
        let mut pts = base.clone();
        for _ in 0..600 {
            let b = base[rng.random_range(0..base.len())];
            let jitter = DVec3::new(rng.random(), rng.random(), rng.random()) - 0.5;
            pts.push(b + jitter * 1e-3);
        }
        let tol = 1e-3;
        let w = weld(&pts, tol);
        // Brute force with the same rule.
        let mut reps: Vec<DVec3> = Vec::new();
        let mut map = Vec::new();
        for p in &pts {
            match reps.iter().position(|r| r.distance_squared(*p) <= tol * tol) {
                Some(i) => map.push(i as u32),
                None => {
                    map.push(reps.len() as u32);
                    reps.push(*p);
                }
            }
        }
        assert_eq!(w.map, map);
        assert_eq!(w.positions, reps);
    }
}
