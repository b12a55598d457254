//! Gathering form factors with visibility by ray casting (design/radiosity.md §1.4): from each
//! patch, N cosine-weighted directions (Owen-scrambled Sobol) from origins stratified over its
//! dual cell, traced through the scene's BVH. A ray that hits a triangle's lit side at
//! barycentrics b adds 1/N to F_{i→v_k} for one of the patches at its corners, corner k picked
//! with probability b_k: in expectation b_k/N to each, so with the radiosity interpolated
//! linearly between patches E_i = Σ_j F_ij B_j is the irradiance the ray estimator sees. The
//! design note adds b_k/N to all three; one corner makes rows 2.2× sparser (880 against 1,930
//! nonzeros a patch in a closed sphere at 512 rays) for 1.8× the variance of E (worst vertex of
//! the closed-sphere check 1.2–1.3% against 0.88%), which is the better trade where memory, not
//! rays, bounds the scene. A hit on the back of a one-sided surface is absorbed; a patch whose rays do so
//! more than [`FormFactorOptions::covered_fraction`] of the time lies inside geometry (a leak)
//! and is marked covered, its row left empty.
//!
//! The raw factors are reciprocal only on average. They are symmetrised by weighting each side's
//! estimate of the exchange G_ij = AᵢF_ij = AⱼF_ji by the inverse of its variance: with N rays
//! from every patch, Var(AᵢF̂_ij) ≈ AᵢG_ij/N, so G_ij = AᵢAⱼ(F_ij + F_ji)/(Aᵢ + Aⱼ). For equal
//! areas that is the design note's plain mean ½(AᵢF_ij + AⱼF_ji) (halving the variance); for a
//! small patch facing a large one it keeps the small patch's own estimate, where the plain mean
//! halves it (the large patch's rays almost never find the small one: a 1 mm² patch under a disc
//! got half its closed-form factor). The rows of patches all of whose rays hit something (a closed
//! scene, or the closed part of one) are balanced to sum to exactly 1 by the symmetric scaling
//! x_i G_ij x_j (symmetric Sinkhorn–Knopp, the others kept); and a row still above 1 is scaled
//! down pairwise (by min(cᵢ, cⱼ), cᵢ = 1/rowᵢ). What is stored is the exchange
//! G′_ij = G_ij (x_i x_j) min(cᵢ, cⱼ), symmetric bit for bit (each product is formed the same
//! way from both ends), rounded down to f32, with 1/Aᵢ per row: F_ij = G′_ij/Aᵢ is reciprocal
//! to the rounding of that division, every row sum ≤ 1 and a closed row's within 2⁻²³ of 1, so
//! the energy balance closes to that. f32
//! because a sweep of the solver reads every stored factor and is bound by memory bandwidth:
//! 8 bytes a factor instead of 12, and a relative rounding of 1.2·10⁻⁷ against the solver's
//! tolerance of 10⁻³ and the rays' noise of 10⁻².

use rayon::prelude::*;

use crate::light::sampling::{cosine_hemisphere, hash_combine, mix64, orthonormal_basis, Pattern};
use crate::progress::Cancelled;

use super::error::RadiosityError;
use super::patches::PatchSet;

/// How the form factors are cast.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FormFactorOptions {
    /// Rays from each patch (design default 512: σ ≈ √(F(1 − F)/N) per raw factor).
    pub rays_per_patch: usize,
    /// The seed of the scrambles: the same seed gives the same factors on any number of threads.
    pub seed: u64,
    /// A patch whose rays hit the back of one-sided surfaces more often than this lies inside
    /// geometry (design note §1.4: 10%).
    pub covered_fraction: f64,
}

impl Default for FormFactorOptions {
    fn default() -> Self {
        Self { rays_per_patch: 512, seed: 0x7261_6469_6f73_6974, covered_fraction: 0.1 }
    }
}

impl FormFactorOptions {
    /// # Errors
    /// A message naming the option out of range.
    pub fn validate(&self) -> Result<(), String> {
        if self.rays_per_patch == 0 || self.rays_per_patch > 1 << 24 {
            return Err(format!("rays_per_patch must be in 1..=16777216, got {}", self.rays_per_patch));
        }
        if !(self.covered_fraction > 0.0 && self.covered_fraction <= 1.0) {
            return Err(format!("covered_fraction must be in (0, 1], got {}", self.covered_fraction));
        }
        Ok(())
    }
}

/// Sweeps of the balancing at most, and the row-sum error (relative to the area) it stops at.
const BALANCE_SWEEPS: usize = 500;
const BALANCE_TOLERANCE: f64 = 1e-14;

/// Keys the random numbers that pick a hit's corner apart from the other streams.
const CORNER_STREAM: u64 = 0x636f_726e_6572;

/// Rows symmetrised at a time (their raw entries freed after).
const SYMMETRISE_BLOCK: usize = 4096;

/// A ray's start is this fraction of the scene's diagonal past its origin (no self-hit).
const RAY_EPSILON: f64 = 1e-9;

/// The gathering form factors between the patches of a [`PatchSet`] (module documentation):
/// sparse rows, F_ij the fraction of the light arriving at i that leaves j.
#[derive(Debug, Clone)]
pub struct FormFactors {
    row_start: Vec<usize>,
    columns: Vec<u32>,
    /// The exchange G′_ij = AᵢF_ij = AⱼF_ji (module documentation).
    exchange: Vec<f32>,
    /// 1/Aᵢ (0 for a patch of no area, whose row is empty).
    inverse_area: Vec<f64>,
    covered: Vec<bool>,
    hit_fraction: Vec<f64>,
}

/// One patch's raw row: its entries sorted by column (the rays that gave their hit to that
/// patch: exact counts, 8 bytes an entry, F_ij = count/N), the fraction of its rays that hit a
/// lit side, whether every ray did (a closed row) and whether it is covered.
struct RawRow {
    entries: Vec<(u32, u32)>,
    hit: f64,
    closed: bool,
    covered: bool,
}

impl FormFactors {
    /// Casts, symmetrises and balances the form factors of `patches`; `keep_going` is asked
    /// between patches.
    ///
    /// # Errors
    /// [`RadiosityError::InvalidOptions`], or [`RadiosityError::Cancelled`].
    pub fn gather(
        patches: &PatchSet,
        options: &FormFactorOptions,
        keep_going: &(dyn Fn() -> bool + Sync),
    ) -> Result<Self, RadiosityError> {
        options.validate().map_err(RadiosityError::InvalidOptions)?;
        let mut raw: Vec<RawRow> = (0..patches.len())
            .into_par_iter()
            .map(|i| if keep_going() { Ok(cast_row(patches, options, i)) } else { Err(Cancelled) })
            .collect::<Result<_, _>>()?;
        let areas = patches.areas();
        let closed: Vec<bool> = raw.iter().map(|r| r.closed).collect();
        let covered = raw.iter().map(|r| r.covered).collect();
        let hit_fraction = raw.iter().map(|r| r.hit).collect();
        let symmetric = symmetrise(&mut raw, areas, 1.0 / options.rays_per_patch as f64);
        drop(raw);
        let x = balance(&symmetric, areas, &closed);
        let (row_start, columns, mut values) = symmetric;
        // Every product formed in the same order from both ends (x_i x_j commutes exactly), so
        // G′ stays symmetric bit for bit.
        for i in 0..areas.len() {
            for k in row_start[i]..row_start[i + 1] {
                values[k] *= x[i] * x[columns[k] as usize];
            }
        }
        // Rows above 1 scaled down pairwise, which keeps AᵢF_ij = AⱼF_ji.
        let c: Vec<f64> =
            (0..areas.len()).map(|i| (areas[i] / values[row_start[i]..row_start[i + 1]].iter().sum::<f64>()).min(1.0)).collect();
        let exchange = (0..areas.len())
            .flat_map(|i| (row_start[i]..row_start[i + 1]).map(move |k| (i, k)))
            .map(|(i, k)| round_down(values[k] * c[i].min(c[columns[k] as usize])))
            .collect();
        let inverse_area = areas.iter().map(|&a| if a > 0.0 { 1.0 / a } else { 0.0 }).collect();
        Ok(Self { row_start, columns, exchange, inverse_area, covered, hit_fraction })
    }

    /// The number of patches (rows).
    #[must_use]
    pub fn len(&self) -> usize {
        self.covered.len()
    }

    /// Whether there are no rows.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.covered.is_empty()
    }

    /// Stored nonzeros.
    #[must_use]
    pub fn nonzeros(&self) -> usize {
        self.exchange.len()
    }

    /// The bytes of the stored factors (a column and an f32 exchange each).
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.nonzeros() * (size_of::<u32>() + size_of::<f32>())
    }

    /// Row `i`: the patches j it gathers from, by increasing j, with F_ij.
    pub fn row(&self, i: usize) -> impl ExactSizeIterator<Item = (usize, f64)> + '_ {
        let (columns, exchange) = self.exchange_row(i);
        let inverse = self.inverse_area[i];
        columns.iter().zip(exchange).map(move |(&j, &g)| (j as usize, f64::from(g) * inverse))
    }

    /// Row `i` of the exchange G′_ij = AᵢF_ij = AⱼF_ji (symmetric): the columns, by increasing
    /// patch, and the values.
    #[must_use]
    pub fn exchange_row(&self, i: usize) -> (&[u32], &[f32]) {
        let r = self.row_start[i]..self.row_start[i + 1];
        (&self.columns[r.clone()], &self.exchange[r])
    }

    /// F_ij (0 where not stored).
    #[must_use]
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (columns, exchange) = self.exchange_row(i);
        columns.binary_search(&(j as u32)).map_or(0.0, |k| f64::from(exchange[k]) * self.inverse_area[i])
    }

    /// Σ_j F_ij: the fraction of the light arriving at i that comes from the scene (1 − the
    /// fraction that escapes).
    #[must_use]
    pub fn row_sum(&self, i: usize) -> f64 {
        self.exchange_row(i).1.iter().map(|&g| f64::from(g)).sum::<f64>() * self.inverse_area[i]
    }

    /// The fraction of patch i's rays that hit a lit side (before symmetrising: the raw row sum).
    #[must_use]
    pub fn hit_fraction(&self, i: usize) -> f64 {
        self.hit_fraction[i]
    }

    /// The exchange as CSR: row i's entries are `columns[row_start[i]..row_start[i + 1]]` (in
    /// increasing order) with G′_ij in `exchange` at the same places, and 1/Aᵢ per row, so
    /// F_ij = G′_ij/Aᵢ (for the device's copy).
    #[must_use]
    pub fn csr(&self) -> (&[usize], &[u32], &[f32], &[f64]) {
        (&self.row_start, &self.columns, &self.exchange, &self.inverse_area)
    }

    /// Whether each patch lies inside geometry (its rays mostly hit back faces; its row is empty).
    #[must_use]
    pub fn covered(&self) -> &[bool] {
        &self.covered
    }

    /// E = F B: the irradiance at every patch from the radiosity `b` of every patch, per channel.
    ///
    /// # Panics
    /// If `b` does not have one value per patch.
    #[must_use]
    pub fn apply(&self, b: &[[f64; 3]]) -> Vec<[f64; 3]> {
        assert_eq!(b.len(), self.len(), "one radiosity per patch");
        (0..self.len()).into_par_iter().map(|i| self.apply_row(i, b)).collect()
    }

    /// (F B)ᵢ: the irradiance at patch `i` from the radiosity `b` of every patch.
    #[must_use]
    pub fn apply_row(&self, i: usize, b: &[[f64; 3]]) -> [f64; 3] {
        self.apply_row_with(i, |j| &b[j])
    }

    /// (F B)ᵢ with patch j's radiosity `b(j)` (a Gauss–Seidel sweep reads a block's own
    /// patches from their new values and the others' from the sweep's start).
    #[inline]
    pub fn apply_row_with<'b>(&self, i: usize, b: impl Fn(usize) -> &'b [f64; 3]) -> [f64; 3] {
        let (columns, exchange) = self.exchange_row(i);
        let mut e = [0.0; 3];
        for (&j, &g) in columns.iter().zip(exchange) {
            let (g, b) = (f64::from(g), b(j as usize));
            for c in 0..3 {
                e[c] += g * b[c];
            }
        }
        e.map(|x| x * self.inverse_area[i])
    }
}

/// The largest f32 ≤ `x` (x ≥ 0): a row of rounded factors never sums above the row it was
/// rounded from, so no row exceeds 1 and a closed row stays within 2⁻²³ below it.
fn round_down(x: f64) -> f32 {
    let r = x as f32;
    if f64::from(r) > x {
        r.next_down()
    } else {
        r
    }
}

/// Patch i's raw row (module documentation).
fn cast_row(patches: &PatchSet, options: &FormFactorOptions, i: usize) -> RawRow {
    let n = options.rays_per_patch;
    if patches.areas()[i] <= 0.0 {
        return RawRow { entries: Vec::new(), hit: 0.0, closed: false, covered: false };
    }
    let origins = Pattern::new(hash_combine(options.seed, 2 * i as u64));
    let directions = Pattern::new(hash_combine(options.seed, 2 * i as u64 + 1));
    // Two Owen scrambles of one Sobol sequence agree in their leading bits up to a flip: with the
    // same index, the direction would depend on which piece of the cell the origin is in (a
    // patch's factors came out up to 12% off). The directions are taken in a shuffled order.
    let order = shuffled(n, hash_combine(options.seed, !(i as u64)));
    let t_min = RAY_EPSILON * patches.diagonal();
    let weight = 1.0 / n as f64;
    let mut entries: Vec<u32> = Vec::with_capacity(n);
    let (mut hits, mut absorbed) = (0usize, 0usize);
    for (r, &shuffled_r) in order.iter().enumerate() {
        let Some((origin, normal)) = patches.sample_cell(i, origins.get(r)) else { break };
        let (t, b) = orthonormal_basis(normal);
        let local = cosine_hemisphere(directions.get(shuffled_r));
        let direction = t * local.x + b * local.y + normal * local.z;
        let Some(hit) = patches.bvh().intersect(origin, direction, t_min, f64::INFINITY) else { continue };
        match patches.hit_side(hit.triangle, direction) {
            Some(corners) => {
                hits += 1;
                // One corner, picked with probability bₖ (module documentation).
                let u = unit(mix64(hash_combine(options.seed ^ CORNER_STREAM, ((i as u64) << 24) | r as u64)));
                let k = if u < hit.bary[0] {
                    0
                } else if u < hit.bary[0] + hit.bary[1] {
                    1
                } else {
                    2
                };
                entries.push(corners[k]);
            }
            None => absorbed += 1,
        }
    }
    if absorbed as f64 > options.covered_fraction * n as f64 {
        return RawRow { entries: Vec::new(), hit: 0.0, closed: false, covered: true };
    }
    entries.sort_unstable();
    let mut merged: Vec<(u32, u32)> = Vec::new();
    for j in entries {
        match merged.last_mut() {
            Some(last) if last.0 == j => last.1 += 1,
            _ => merged.push((j, 1)),
        }
    }
    merged.shrink_to_fit();
    RawRow { entries: merged, hit: hits as f64 * weight, closed: hits == n, covered: false }
}

/// The top 53 bits of `bits` as a number in [0, 1).
fn unit(bits: u64) -> f64 {
    (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// 0..n in an order shuffled by `key` (Fisher–Yates on a SplitMix64 stream).
fn shuffled(n: usize, key: u64) -> Vec<usize> {
    let mut order: Vec<usize> = (0..n).collect();
    let mut state = key;
    for k in (1..n).rev() {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let j = ((u128::from(mix64(state)) * (k as u128 + 1)) >> 64) as usize;
        order.swap(k, j);
    }
    order
}

/// A square sparse matrix by rows: row starts, columns (increasing in each row), values.
type Csr = (Vec<usize>, Vec<u32>, Vec<f64>);

/// G_ij = AᵢAⱼ(F_ij + F_ji)/(Aᵢ + Aⱼ) on the union of the two patterns (module documentation):
/// row i of F merged with column i, F_ij = count/N with `weight` = 1/N. The raw rows are
/// consumed block by block, so the memory peaks at the result and the transpose (both of
/// counts, 8 bytes an entry).
fn symmetrise(raw: &mut [RawRow], areas: &[f64], weight: f64) -> Csr {
    let n = raw.len();
    // The transpose by counting: for each column, the rows that have it, in increasing order.
    let mut count = vec![0usize; n + 1];
    for row in raw.iter() {
        for &(j, _) in &row.entries {
            count[j as usize + 1] += 1;
        }
    }
    for j in 0..n {
        count[j + 1] += count[j];
    }
    let mut next = count.clone();
    let mut transposed = vec![(0u32, 0u32); count[n]];
    for (i, row) in raw.iter().enumerate() {
        for &(j, f) in &row.entries {
            transposed[next[j as usize]] = (i as u32, f);
            next[j as usize] += 1;
        }
    }
    drop(next);
    let mut row_start = Vec::with_capacity(n + 1);
    let (mut columns, mut values) = (Vec::new(), Vec::new());
    for block in (0..n).step_by(SYMMETRISE_BLOCK) {
        let end = (block + SYMMETRISE_BLOCK).min(n);
        let rows: Vec<Vec<(u32, f64)>> = raw[block..end]
            .par_iter_mut()
            .enumerate()
            .map(|(k, row)| {
                let i = block + k;
                let a = std::mem::take(&mut row.entries);
                let b = &transposed[count[i]..count[i + 1]];
                let mut out = Vec::with_capacity(a.len() + b.len());
                let (mut p, mut q) = (0, 0);
                while p < a.len() || q < b.len() {
                    let ja = a.get(p).map_or(u32::MAX, |e| e.0);
                    let jb = b.get(q).map_or(u32::MAX, |e| e.0);
                    let j = ja.min(jb);
                    let mut hits = 0u32;
                    if ja == j {
                        hits += a[p].1;
                        p += 1;
                    }
                    if jb == j {
                        hits += b[q].1;
                        q += 1;
                    }
                    let (ai, aj) = (areas[i], areas[j as usize]);
                    out.push((j, ai * aj / (ai + aj) * (f64::from(hits) * weight)));
                }
                out
            })
            .collect();
        for row in rows {
            row_start.push(columns.len());
            for (j, v) in row {
                columns.push(j);
                values.push(v);
            }
        }
    }
    row_start.push(columns.len());
    columns.shrink_to_fit();
    values.shrink_to_fit();
    (row_start, columns, values)
}

/// The symmetric scaling x with Σ_j x_i G_ij x_j = Aᵢ for the `closed` rows (symmetric
/// Sinkhorn–Knopp, x ← √(x ⊙ A/(Gx)) on them), the others kept at 1. Where the sweeps do not
/// reach [`BALANCE_TOLERANCE`] (a pattern that admits no such scaling), the last iterate: still
/// symmetric, and the pairwise bound after it keeps every row ≤ 1.
fn balance((row_start, columns, values): &Csr, areas: &[f64], closed: &[bool]) -> Vec<f64> {
    let n = areas.len();
    let mut x = vec![1.0f64; n];
    if !closed.iter().any(|&c| c) {
        return x;
    }
    for _ in 0..BALANCE_SWEEPS {
        let gx: Vec<f64> =
            (0..n)
                .into_par_iter()
                .map(|i| {
                    if closed[i] {
                        (row_start[i]..row_start[i + 1]).map(|k| values[k] * x[columns[k] as usize]).sum()
                    } else {
                        0.0
                    }
                })
                .collect();
        let worst = (0..n).filter(|&i| closed[i]).map(|i| ((x[i] * gx[i] - areas[i]) / areas[i]).abs()).fold(0.0, f64::max);
        if worst <= BALANCE_TOLERANCE {
            break;
        }
        for i in (0..n).filter(|&i| closed[i] && gx[i] > 0.0) {
            x[i] = (x[i] * areas[i] / gx[i]).sqrt();
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::super::patches::Surface;
    use super::*;

    /// Two unit squares facing each other at distance 1, 8 × 8 quads each.
    type Mesh = (Vec<DVec3>, Vec<[u32; 3]>);

    fn facing_squares() -> (Mesh, Mesh) {
        let grid = |z: f64, up: bool| {
            let n = 8;
            let p: Vec<DVec3> =
                (0..=n).flat_map(|j| (0..=n).map(move |i| DVec3::new(i as f64 / n as f64, j as f64 / n as f64, z))).collect();
            let mut t = Vec::new();
            for j in 0..n {
                for i in 0..n {
                    let v = (j * (n + 1) + i) as u32;
                    let (a, b, c, d) = (v, v + 1, v + n as u32 + 2, v + n as u32 + 1);
                    if up {
                        t.extend([[a, b, c], [a, c, d]]);
                    } else {
                        t.extend([[a, c, b], [a, d, c]]);
                    }
                }
            }
            (p, t)
        };
        (grid(0.0, true), grid(1.0, false))
    }

    #[test]
    fn round_down_never_rounds_up() {
        for x in [0.0, 1e-30, 0.1, 1.0 / 3.0, 0.7, 1.0, 123.456] {
            let r = round_down(x);
            assert!(f64::from(r) <= x && f64::from(r.next_up()) > x, "{x} -> {r}");
        }
        assert_eq!(round_down(0.5), 0.5);
    }

    #[test]
    fn facing_squares_are_reciprocal_and_give_the_closed_form() {
        let ((p0, t0), (p1, t1)) = facing_squares();
        let surfaces = [
            Surface { positions: &p0, triangles: &t0, two_sided: false },
            Surface { positions: &p1, triangles: &t1, two_sided: false },
        ];
        let patches = PatchSet::new(&surfaces).unwrap();
        let f =
            FormFactors::gather(&patches, &FormFactorOptions { rays_per_patch: 256, ..Default::default() }, &|| true).unwrap();
        let a = patches.areas();
        let mut worst = 0.0f64;
        for i in 0..f.len() {
            for (j, v) in f.row(i) {
                let back = f.get(j, i);
                worst = worst.max((a[i] * v - a[j] * back).abs());
            }
            // The stored exchange is symmetric bit for bit.
            let (columns, exchange) = f.exchange_row(i);
            for (&j, &g) in columns.iter().zip(exchange) {
                let (back_columns, back) = f.exchange_row(j as usize);
                let k = back_columns.binary_search(&(i as u32)).expect("the pattern is symmetric");
                assert_eq!(g.to_bits(), back[k].to_bits(), "G′_{i},{j} = {g}, G′_{j},{i} = {}", back[k]);
            }
            assert!(f.row_sum(i) <= 1.0 + 1e-12, "row {i}: {}", f.row_sum(i));
        }
        assert!(worst < 1e-15, "reciprocity off by {worst}");
        // Square to square: Σᵢ Aᵢ Σ_j F_ij over the first square's patches, the second's.
        let total: f64 = (0..81).map(|i| a[i] * (81..162).map(|j| f.get(i, j)).sum::<f64>()).sum();
        let want = super::super::analytic::parallel_rectangles(1.0, 1.0, 1.0);
        assert!((total - want).abs() < 0.01 * want, "{total} against {want}");
        assert!(f.covered().iter().all(|&c| !c));
        // The same factors again with the same seed.
        let again =
            FormFactors::gather(&patches, &FormFactorOptions { rays_per_patch: 256, ..Default::default() }, &|| true).unwrap();
        assert_eq!(again.exchange, f.exchange);
        assert!(matches!(
            FormFactors::gather(&patches, &FormFactorOptions { rays_per_patch: 0, ..Default::default() }, &|| true),
            Err(RadiosityError::InvalidOptions(_))
        ));
        assert!(matches!(
            FormFactors::gather(&patches, &FormFactorOptions::default(), &|| false),
            Err(RadiosityError::Cancelled(_))
        ));
    }
}
