//! The precomputed transfer (R. Wang et al. 2008 §3.2, eqs. 5–8): per receiver vertex v and
//! basis function k, the row Tₖ[v, j] = aⱼ bₖ(‖x_v − xⱼ‖) over the irradiance samples, so that
//! the exitance of any medium under any irradiance q is
//!
//! B(v) = Σₖ sₖ Σⱼ Tₖ[v, j] qⱼ = Σₖ sₖ (Tₖ^w q^w)[v]  (eq. 7, in the Haar basis eq. 8),
//!
//! with the near-field correction of [`super::near`] in every row. The rows are kept compressed:
//! per vertex the `terms_per_vertex` Haar coefficients of largest |c|·σₖ/σ₁ over all its K rows
//! together (σₖ the basis's singular values: a high-order row oscillates and carries a small
//! sₖ, so it gets fewer terms; 2–4× less error than the paper's fixed 256 per row at the same
//! bytes, design/prt.md §1.4), every row's coefficient 0 always among them (so uniform light is
//! exact). Each kept coefficient is stored in 3 bytes where the paper packs 4: its value in 16
//! bits against one scale per row (the paper's precision), and its sample index as the gap from
//! the previous one in the row in 8 bits. A row's coefficients cluster where the Haar levels
//! meet the vertex's own patch of surface (on the bunny 96% of the gaps are below 255), and a
//! longer gap is bridged by an escape entry that only advances the index (4% more entries), so
//! the transfer takes 0.78 of the paper's bytes and a relight streams that much less.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use glam::DVec3;
use rayon::prelude::*;

use crate::progress::Cancelled;

use super::basis::{locate, RdBasis, MAX_TERMS};
use super::haar;
use super::near::{triangle_integral, TriangleGrid};
use super::samples::SurfaceSamples;
use super::{PrtError, PrtOptions};

/// What a precompute measured.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct TransferStats {
    /// Terms kept over all vertices.
    pub terms: usize,
    /// Entries stored: the kept terms and the escapes that bridge long gaps between their
    /// sample indices ([`ESCAPE`]).
    pub entries: usize,
    /// Bytes of the compressed transfer.
    pub bytes: usize,
    /// The weighted coefficient energy dropped by the compression, √(Σ dropped (c σₖ)²/Σ (c σₖ)²),
    /// as the mean over the vertices and the largest one.
    pub dropped_mean: f64,
    pub dropped_max: f64,
    /// The near-field radius used (mm): the triangles within it were integrated exactly.
    pub near_radius: f64,
}

/// The gap byte of an escape entry: it contributes nothing and advances the sample index by
/// its value field read as u16 (a real entry's gap is below it).
pub const ESCAPE: u8 = u8::MAX;

/// The compressed transfer of one surface.
#[derive(Debug, Clone)]
pub struct Transfer {
    pub(super) terms_per_row: usize,
    pub(super) vertices: usize,
    pub(super) samples: usize,
    /// Per (vertex, k), its entries: `gaps[row_start[v K + k]..row_start[v K + k + 1]]`, and the
    /// same range of `values`.
    pub(super) row_start: Vec<u64>,
    /// Per entry, how far its sample index lies past the previous entry's in the row (the
    /// first's: past 0), or [`ESCAPE`].
    pub(super) gaps: Vec<u8>,
    /// Per entry, its quantised value (in steps of its row), or an escape's advance (as u16).
    pub(super) values: Vec<i16>,
    /// Per (vertex, k), the value of one quantisation step.
    pub(super) steps: Vec<f32>,
    pub(super) stats: TransferStats,
}

/// One vertex's rows compressed ([`compress`]).
struct Compressed {
    /// Per row, its number of entries (escapes included) and its quantisation step.
    counts: [u32; MAX_TERMS],
    steps: [f32; MAX_TERMS],
    /// The dropped weighted energy's relative norm.
    dropped: f64,
    /// The vertex's entries, row after row.
    gaps: Vec<u8>,
    values: Vec<i16>,
}

/// The per-thread work space of the precompute. A vertex's K rows are stored interleaved,
/// sample-major (`rows[j K + k]`): the basis's K values at a distance are written as one
/// contiguous run, the Haar transform runs over K channels at once, and compression scans one
/// array.
struct Scratch {
    rows: Vec<f32>,
    haar: Vec<f32>,
    keys: Vec<f32>,
    kept: Vec<(u32, f32)>,
    near: Vec<u32>,
}

impl Transfer {
    /// The transfer from `samples` to `receivers` (mm) over the surface (`positions` in mm,
    /// `triangles`) with `basis`, compressed as `options` says; `poll` gets the fraction done
    /// and stops the work when it returns `Err`.
    ///
    /// # Errors
    /// [`PrtError::Cancelled`] through `poll`.
    pub fn precompute(
        receivers: &[DVec3],
        positions: &[DVec3],
        triangles: &[[u32; 3]],
        samples: &SurfaceSamples,
        basis: &RdBasis,
        options: &PrtOptions,
        poll: &(dyn Fn(f64) -> Result<(), Cancelled> + Sync),
    ) -> Result<Transfer, PrtError> {
        let k = basis.terms();
        let n = samples.len();
        let budget = options.terms_per_vertex.min(k * n).max(k);
        let near_radius = options.near_radius * samples.spacing();
        let grid = options.near_field.then(|| TriangleGrid::new(positions, triangles, near_radius.max(1e-9)));
        let weights: Vec<f32> = basis.singular_values().iter().map(|s| (s / basis.singular_values()[0]) as f32).collect();
        let done = AtomicUsize::new(0);
        let stop = AtomicBool::new(false);
        // The vertices in chunks, each chunk's rows appended in vertex order: the arrays grow
        // to their final size only (reserved for the gaps expected, virtual until written)
        // instead of a per-vertex copy of everything beside them.
        let reserve = receivers.len() * (budget + budget / 16);
        let (mut gaps, mut values) = (Vec::with_capacity(reserve), Vec::with_capacity(reserve));
        let mut row_start = Vec::with_capacity(receivers.len() * k + 1);
        row_start.push(0u64);
        let mut steps = Vec::with_capacity(receivers.len() * k);
        let (mut dropped_sum, mut dropped_max) = (0.0, 0.0f64);
        for chunk in receivers.chunks(VERTICES_PER_CHUNK) {
            let compressed: Vec<Option<Compressed>> = chunk
                .par_iter()
                .map_init(
                    || Scratch {
                        rows: vec![0.0; k * n],
                        haar: vec![0.0; k * n],
                        keys: Vec::new(),
                        kept: Vec::new(),
                        near: Vec::new(),
                    },
                    |scratch, &x| {
                        if stop.load(Ordering::Relaxed) {
                            return None;
                        }
                        fill_rows(basis, samples, x, &mut scratch.rows);
                        if let Some(grid) = &grid {
                            correct_near(basis, samples, positions, triangles, grid, x, near_radius, scratch);
                        }
                        haar::forward_interleaved(&mut scratch.rows, k, &mut scratch.haar);
                        let kept = compress(&scratch.rows, &weights, budget, &mut scratch.keys, &mut scratch.kept);
                        let finished = done.fetch_add(1, Ordering::Relaxed) + 1;
                        if finished.is_multiple_of(64) && poll(finished as f64 / receivers.len() as f64).is_err() {
                            stop.store(true, Ordering::Relaxed);
                        }
                        Some(kept)
                    },
                )
                .collect();
            if stop.load(Ordering::Relaxed) {
                return Err(PrtError::Cancelled(Cancelled));
            }
            for c in compressed.into_iter().flatten() {
                for j in 0..k {
                    row_start.push(row_start.last().unwrap() + u64::from(c.counts[j]));
                    steps.push(c.steps[j]);
                }
                gaps.extend_from_slice(&c.gaps);
                values.extend_from_slice(&c.values);
                dropped_sum += c.dropped;
                dropped_max = dropped_max.max(c.dropped);
            }
        }
        let bytes = gaps.len() + 2 * values.len() + row_start.len() * 8 + steps.len() * 4;
        let stats = TransferStats {
            terms: receivers.len() * budget,
            entries: gaps.len(),
            bytes,
            dropped_mean: dropped_sum / receivers.len().max(1) as f64,
            dropped_max,
            near_radius: if options.near_field { near_radius } else { 0.0 },
        };
        Ok(Transfer { terms_per_row: k, vertices: receivers.len(), samples: n, row_start, gaps, values, steps, stats })
    }

    /// The number of basis functions K of the rows.
    #[must_use]
    pub fn basis_terms(&self) -> usize {
        self.terms_per_row
    }

    /// The number of receiver vertices.
    #[must_use]
    pub fn vertices(&self) -> usize {
        self.vertices
    }

    /// The number of irradiance samples N.
    #[must_use]
    pub fn samples(&self) -> usize {
        self.samples
    }

    /// What the precompute measured.
    #[must_use]
    pub fn stats(&self) -> &TransferStats {
        &self.stats
    }

    /// Per row (vertex v, basis function k at v K + k), where its entries start in
    /// [`Transfer::gaps`] and [`Transfer::values`]; one more entry than rows, the last the
    /// number of entries.
    #[must_use]
    pub fn row_start(&self) -> &[u64] {
        &self.row_start
    }

    /// Per entry, the gap from the previous entry's sample index in its row, or [`ESCAPE`].
    #[must_use]
    pub fn gaps(&self) -> &[u8] {
        &self.gaps
    }

    /// Per entry, its value in steps of its row, or an escape's advance (as u16).
    #[must_use]
    pub fn values(&self) -> &[i16] {
        &self.values
    }

    /// Per row, the value of one quantisation step.
    #[must_use]
    pub fn steps(&self) -> &[f32] {
        &self.steps
    }

    /// Row `row`'s entries decoded: (sample index, value in steps), an escape's value 0, as
    /// [`Transfer::apply`] sums them.
    ///
    /// # Panics
    /// If `row` is not a row of the transfer.
    pub fn row_entries(&self, row: usize) -> impl Iterator<Item = (u32, f32)> + '_ {
        let range = self.row_start[row] as usize..self.row_start[row + 1] as usize;
        let last = (self.samples - 1) as u32;
        self.gaps[range.clone()].iter().zip(&self.values[range]).scan(0u32, move |index, (&g, &v)| {
            let (advance, value) = decode(g, v);
            *index = index.saturating_add(advance).min(last);
            Some((*index, value))
        })
    }

    /// The first row whose entries name a sample beyond the last (a damaged transfer), if any.
    pub(super) fn row_beyond_samples(&self) -> Option<usize> {
        (0..self.row_start.len() - 1).find(|&row| {
            let range = self.row_start[row] as usize..self.row_start[row + 1] as usize;
            let reach: u64 =
                self.gaps[range.clone()].iter().zip(&self.values[range]).map(|(&g, &v)| u64::from(decode(g, v).0)).sum();
            reach >= self.samples as u64
        })
    }

    /// Per vertex v, basis function k and channel c, (Tₖ^w q^w)[v] into `out[(v K + k) 3 + c]`,
    /// from the Haar-transformed irradiance `q_haar` ([`haar_irradiance`]): each row summed in
    /// one fixed order ([`row_sum`]), so the result depends neither on the thread count nor on
    /// whether the CPU's vector path runs.
    ///
    /// # Panics
    /// If `q_haar` has another length than the samples or `out` than 3 K per vertex.
    pub fn apply(&self, q_haar: &[[f32; 4]], out: &mut [f64]) {
        let k = self.terms_per_row;
        assert_eq!(q_haar.len(), self.samples, "one irradiance per sample");
        assert_eq!(out.len(), self.vertices * k * 3, "3 K values per vertex");
        let sum = RowSum::new(q_haar);
        out.par_chunks_mut(k * 3).enumerate().for_each(|(v, o)| {
            let mut sums = [[0.0f32; 4]; MAX_TERMS];
            sum.rows(&self.gaps, &self.values, &self.row_start[v * k..=v * k + k], &mut sums[..k]);
            for (j, (acc, &step)) in sums.iter().zip(&self.steps[v * k..v * k + k]).enumerate() {
                for c in 0..3 {
                    o[j * 3 + c] = f64::from(acc[c]) * f64::from(step);
                }
            }
        });
    }
}

/// Vertices precomputed between two appends to the transfer's arrays.
const VERTICES_PER_CHUNK: usize = 1024;

/// An entry's (advance of the sample index, value): an escape advances by its value field read
/// as u16 and adds nothing.
#[inline(always)]
fn decode(gap: u8, value: i16) -> (u32, f32) {
    if gap == ESCAPE {
        (u32::from(value as u16), 0.0)
    } else {
        (u32::from(gap), f32::from(value))
    }
}

/// Appends the entries of one kept coefficient at `index` (after `previous`, the row's last
/// index so far, 0 before its first) with quantised value `value`: escapes while the gap is
/// [`ESCAPE`] or more, then the entry itself.
fn push_entry(gaps: &mut Vec<u8>, values: &mut Vec<i16>, previous: u32, index: u32, value: i16) -> u32 {
    let mut gap = index - previous;
    while gap >= u32::from(ESCAPE) {
        let advance = gap.min(u32::from(u16::MAX));
        gaps.push(ESCAPE);
        values.push(advance as u16 as i16);
        gap -= advance;
    }
    gaps.push(gap as u8);
    values.push(value);
    index
}

/// The accumulators of a row's sum: entry i adds into lane i mod `LANES`, and the lanes are
/// added pairwise at the end ([`reduce_lanes`]). Independent lanes keep the adds from waiting
/// on each other, and the fixed order makes the scalar and the vector paths agree bit for bit
/// (f32 products and sums, never fused).
const LANES: usize = 8;

/// The sums Σ value · q_haar[index] of rows ([`Transfer::apply`]'s inner loop), with the vector
/// path chosen once. Every sample index is clamped to the last sample, so no entry reads
/// outside `q_haar` whatever the arrays hold (a loaded file is also checked when read).
struct RowSum<'a> {
    q_haar: &'a [[f32; 4]],
    #[cfg(target_arch = "x86_64")]
    avx2: bool,
}

impl<'a> RowSum<'a> {
    /// # Panics
    /// If `q_haar` is empty or holds more than 2³¹ entries (the vector path's indices are u32).
    fn new(q_haar: &'a [[f32; 4]]) -> Self {
        assert!((1..=1 << 31).contains(&q_haar.len()), "1 to 2³¹ samples");
        RowSum {
            q_haar,
            #[cfg(target_arch = "x86_64")]
            avx2: std::arch::is_x86_feature_detected!("avx2"),
        }
    }

    /// Per row j of consecutive rows (entries `bounds[j]..bounds[j + 1]` of `gaps` and
    /// `values`), Σ value · q_haar[index] into `out[j]` (channels 0–2; lane 3 is the padding's).
    fn rows(&self, gaps: &[u8], values: &[i16], bounds: &[u64], out: &mut [[f32; 4]]) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: the CPU has AVX2 (detected in `new`), and q_haar is not empty.
            unsafe { avx2::rows(gaps, values, bounds, self.q_haar, out) };
            return;
        }
        for (o, b) in out.iter_mut().zip(bounds.windows(2)) {
            let range = b[0] as usize..b[1] as usize;
            *o = row_sum(&gaps[range.clone()], &values[range], self.q_haar);
        }
    }
}

/// Adds `value · e` into `lane`.
#[inline(always)]
fn accumulate(lane: &mut [f32; 4], value: f32, e: &[f32; 4]) {
    for c in 0..4 {
        lane[c] += value * e[c];
    }
}

/// The lanes summed pairwise: ((l₀ + l₁) + (l₂ + l₃)) + ((l₄ + l₅) + (l₆ + l₇)).
#[inline(always)]
fn reduce_lanes(lanes: &[[f32; 4]; LANES]) -> [f32; 4] {
    let pair = |a: &[f32; 4], b: &[f32; 4]| [0, 1, 2, 3].map(|c| a[c] + b[c]);
    pair(
        &pair(&pair(&lanes[0], &lanes[1]), &pair(&lanes[2], &lanes[3])),
        &pair(&pair(&lanes[4], &lanes[5]), &pair(&lanes[6], &lanes[7])),
    )
}

/// One row of [`RowSum::rows`] without vector instructions: the reference every path follows.
/// The index is min(Σ advances, last sample) after each entry.
fn row_sum(gaps: &[u8], values: &[i16], q_haar: &[[f32; 4]]) -> [f32; 4] {
    let last = (q_haar.len() - 1) as u32;
    let mut lanes = [[0.0f32; 4]; LANES];
    let mut index = 0u32;
    for (i, (&g, &v)) in gaps.iter().zip(values).enumerate() {
        let (advance, value) = decode(g, v);
        index = index.saturating_add(advance).min(last);
        accumulate(&mut lanes[i % LANES], value, &q_haar[index as usize]);
    }
    reduce_lanes(&lanes)
}

/// The AVX2 row sums: eight entries decoded at once (the escapes' advances and zero values
/// blended in, the sample indices a prefix sum of the advances clamped to the last sample),
/// then each entry's value broadcast against its 128-bit irradiance entry into its own lane's
/// accumulator (lane i mod 8 as in [`row_sum`]), the row's arrays prefetched a few kilobytes
/// ahead.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::{
        __m128, __m256i, _mm256_add_epi32, _mm256_andnot_si256, _mm256_blendv_epi8, _mm256_cmpeq_epi32, _mm256_cvtepi16_epi32,
        _mm256_cvtepi32_ps, _mm256_cvtepu16_epi32, _mm256_cvtepu8_epi32, _mm256_min_epu32, _mm256_permute2x128_si256,
        _mm256_permutevar8x32_epi32, _mm256_set1_epi32, _mm256_setzero_si256, _mm256_shuffle_epi32, _mm256_slli_si256,
        _mm256_storeu_ps, _mm256_storeu_si256, _mm_add_ps, _mm_broadcast_ss, _mm_loadl_epi64, _mm_loadu_ps, _mm_loadu_si128,
        _mm_mul_ps, _mm_prefetch, _mm_setzero_ps, _mm_storeu_ps, _MM_HINT_T0,
    };

    use super::{accumulate, decode, reduce_lanes, LANES};

    /// How many entries ahead of the block being decoded its row's arrays are prefetched.
    const PREFETCH_AHEAD: usize = 1024;

    /// Blocks decoded into a small buffer before their entries are summed: the index chain
    /// and the irradiance loads kept apart, and the buffer small (a larger one was slower).
    const BATCH: usize = 8;

    /// [`super::RowSum::rows`] with AVX2.
    ///
    /// # Safety
    /// The CPU must have AVX2, and `q_haar` must not be empty.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn rows(gaps: &[u8], values: &[i16], bounds: &[u64], q_haar: &[[f32; 4]], out: &mut [[f32; 4]]) {
        for (o, b) in out.iter_mut().zip(bounds.windows(2)) {
            let range = b[0] as usize..b[1] as usize;
            // SAFETY: as this function's.
            *o = unsafe { row_sum(&gaps[range.clone()], &values[range], q_haar) };
        }
    }

    /// The inclusive prefix sum of eight u32 lanes.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn prefix_sum(x: __m256i) -> __m256i {
        let x = _mm256_add_epi32(x, _mm256_slli_si256::<4>(x));
        let x = _mm256_add_epi32(x, _mm256_slli_si256::<8>(x));
        // Each 128-bit half is summed; the low half's total goes to every lane of the high one.
        let low_total = _mm256_permute2x128_si256::<0x08>(_mm256_shuffle_epi32::<0xFF>(x), _mm256_shuffle_epi32::<0xFF>(x));
        _mm256_add_epi32(x, low_total)
    }

    /// [`super::row_sum`] with AVX2.
    ///
    /// # Safety
    /// As [`rows`].
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn row_sum(gaps: &[u8], values: &[i16], q_haar: &[[f32; 4]]) -> [f32; 4] {
        let last = (q_haar.len() - 1) as u32;
        let last_lanes = _mm256_set1_epi32(last as i32);
        let escape = _mm256_set1_epi32(i32::from(super::ESCAPE));
        let mut acc: [__m128; LANES] = [_mm_setzero_ps(); LANES];
        let mut carry = _mm256_setzero_si256();
        let (mut index, mut value) = ([[0u32; LANES]; BATCH], [[0.0f32; LANES]; BATCH]);
        let mut last_index = 0u32;
        let (gap_blocks, value_blocks) = (gaps.chunks_exact(LANES), values.chunks_exact(LANES));
        let (gap_tail, value_tail) = (gap_blocks.remainder(), value_blocks.remainder());
        let mut blocks = gap_blocks.zip(value_blocks);
        let q = q_haar.as_ptr().cast::<f32>();
        loop {
            let mut decoded = 0;
            for (g, v) in blocks.by_ref().take(BATCH) {
                // A prefetch never faults, wherever it points.
                _mm_prefetch::<_MM_HINT_T0>(g.as_ptr().wrapping_add(PREFETCH_AHEAD).cast());
                _mm_prefetch::<_MM_HINT_T0>(v.as_ptr().wrapping_add(PREFETCH_AHEAD).cast());
                // SAFETY: `g` holds 8 bytes, `v` 8 i16.
                let (g, v) =
                    unsafe { (_mm256_cvtepu8_epi32(_mm_loadl_epi64(g.as_ptr().cast())), _mm_loadu_si128(v.as_ptr().cast())) };
                let is_escape = _mm256_cmpeq_epi32(g, escape);
                let advance = _mm256_blendv_epi8(g, _mm256_cvtepu16_epi32(v), is_escape);
                let prefix = prefix_sum(advance);
                // min(carry + prefix, last): the carry is at most `last` and eight advances at
                // most 8 · 65535, so nothing wraps. The next carry comes from this block's total
                // (its last lane broadcast), so the chain from block to block is an add and a min.
                let at = _mm256_min_epu32(_mm256_add_epi32(carry, prefix), last_lanes);
                carry = _mm256_min_epu32(
                    _mm256_add_epi32(carry, _mm256_permutevar8x32_epi32(prefix, _mm256_set1_epi32(7))),
                    last_lanes,
                );
                // SAFETY: `index[decoded]` and `value[decoded]` hold 8 values each.
                unsafe {
                    _mm256_storeu_si256(index[decoded].as_mut_ptr().cast(), at);
                    _mm256_storeu_ps(
                        value[decoded].as_mut_ptr(),
                        _mm256_cvtepi32_ps(_mm256_andnot_si256(is_escape, _mm256_cvtepi16_epi32(v))),
                    );
                }
                decoded += 1;
            }
            if decoded == 0 {
                break;
            }
            for (index, value) in index.iter().zip(&value).take(decoded) {
                for l in 0..LANES {
                    // SAFETY: every index is at most `last`, and each entry is 4 f32.
                    let e = unsafe { _mm_loadu_ps(q.add(4 * index[l] as usize)) };
                    acc[l] = _mm_add_ps(acc[l], _mm_mul_ps(_mm_broadcast_ss(&value[l]), e));
                }
            }
            last_index = index[decoded - 1][LANES - 1];
        }
        let mut lanes = [[0.0f32; 4]; LANES];
        for (lane, a) in lanes.iter_mut().zip(acc) {
            // SAFETY: `lane` holds 4 f32.
            unsafe { _mm_storeu_ps(lane.as_mut_ptr(), a) };
        }
        let mut at = last_index;
        for (i, (&g, &v)) in gap_tail.iter().zip(value_tail).enumerate() {
            let (advance, value) = decode(g, v);
            at = at.saturating_add(advance).min(last);
            accumulate(&mut lanes[i], value, &q_haar[at as usize]);
        }
        reduce_lanes(&lanes)
    }
}

/// The Haar transform of the irradiance at the samples (one transform per channel), as the
/// f32 vectors [`Transfer::apply`] reads (the fourth lane is padding).
#[must_use]
pub fn haar_irradiance(q: &[[f64; 3]]) -> Vec<[f32; 4]> {
    let n = q.len();
    let mut channels: Vec<Vec<f64>> = (0..3).map(|c| q.iter().map(|v| v[c]).collect()).collect();
    channels.par_iter_mut().for_each(|ch| {
        let mut scratch = vec![0.0; n];
        haar::forward(ch, &mut scratch);
    });
    (0..n).map(|j| [channels[0][j] as f32, channels[1][j] as f32, channels[2][j] as f32, 0.0]).collect()
}

/// Every row Tₖ[v, ·] = aⱼ bₖ(‖x − xⱼ‖) into `rows`, interleaved (`rows[j K + k]`).
fn fill_rows(basis: &RdBasis, samples: &SurfaceSamples, x: DVec3, rows: &mut [f32]) {
    let k = basis.terms();
    for ((p, &a), row) in samples.positions.iter().zip(&samples.areas).zip(rows.chunks_exact_mut(k)) {
        match locate(p.distance(x)) {
            Some((i, t)) => {
                let (lo, hi) = basis.rows_f32(i);
                let (a, t) = (a as f32, t as f32);
                for ((r, l), h) in row.iter_mut().zip(&lo[..k]).zip(&hi[..k]) {
                    *r = a * (l + t * (h - l));
                }
            }
            None => row.fill(0.0),
        }
    }
}

/// The samples of the linear interpolation at x ([`interpolation_weights`]).
const STENCIL: usize = 6;

/// Adds the near-field correction ([`super::near`]) to the rows: its total over the near cells,
/// C = Σ_cells [∫_cell bₖ − Σ_{j in cell} aⱼ bₖ(‖x − xⱼ‖)], put on the samples around x with
/// weights that interpolate linear functions at x, so the corrected rows integrate
/// ∫_near bₖ q ≈ Σ aⱼ bₖ qⱼ + C q(x): exact for uniform q, and the correction, which is
/// concentrated where the profile peaks, meets the irradiance there.
///
/// Two other placements measured worse under a sun on the 60 mm spot at 2¹⁴ samples (relative
/// L² against brute force): shared among each cell's own samples, a cell's exact integral meets
/// the irradiance where its samples happen to lie, not where the profile weighs it (2.3e-2,
/// against 1.3e-2 this way); and with weights that also cancel the point rule's tangential first
/// moment (exact for linear q on a symmetric neighbourhood), the asymmetry of real surfaces over
/// the near field puts large weights on the stencil (6.8e-2).
#[allow(clippy::too_many_arguments)]
fn correct_near(
    basis: &RdBasis,
    samples: &SurfaceSamples,
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    grid: &TriangleGrid,
    x: DVec3,
    radius: f64,
    scratch: &mut Scratch,
) {
    let k = basis.terms();
    let mut row = [0.0f64; MAX_TERMS];
    let mut correction = [0.0f64; MAX_TERMS];
    // The near triangles' cells whole: the samples of a cell carry the area of all of its
    // triangles, so the exact integral replaces exactly what those samples stood for.
    grid.near(x, radius, &mut scratch.near);
    for t in scratch.near.iter_mut() {
        *t = samples.owner[*t as usize];
    }
    scratch.near.sort_unstable();
    scratch.near.dedup();
    let mut stencil = [(f64::INFINITY, 0u32); STENCIL];
    for &o in &scratch.near {
        for &t in samples.cell(o as usize) {
            let corners = triangles[t as usize].map(|v| positions[v as usize]);
            triangle_integral(basis, corners, x, &mut correction[..k]);
        }
        for &j in samples.on_triangle(o as usize) {
            let d = samples.positions[j as usize].distance(x);
            basis.eval(d, &mut row[..k]);
            for (c, b) in correction[..k].iter_mut().zip(&row[..k]) {
                *c -= samples.areas[j as usize] * b;
            }
            if d < stencil[STENCIL - 1].0 {
                stencil[STENCIL - 1] = (d, j);
                stencil.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
            }
        }
    }
    let stencil: Vec<u32> = stencil.iter().filter(|s| s.0.is_finite()).map(|s| s.1).collect();
    if stencil.is_empty() {
        return;
    }
    for (j, w) in interpolation_weights(samples, &stencil, x) {
        for (kk, c) in correction[..k].iter().enumerate() {
            scratch.rows[j as usize * k + kk] += (c * w) as f32;
        }
    }
}

/// Weights wⱼ over the samples `stencil` (nearest first) with Σ wⱼ f(xⱼ) = f(x) for every f
/// linear on the tangent plane at x (the nearest sample's normal): weighted least squares,
/// θⱼ = 1/(dⱼ² + d₀²), d₀ the nearest distance; where those weights are not all positive, the
/// θ-weighted mean instead (negative weights amplified the Monte Carlo noise of a sampled
/// environment's irradiance to 2.9% on a uniformly lit sphere); the nearest sample alone where
/// the stencil does not span the plane.
fn interpolation_weights(samples: &SurfaceSamples, stencil: &[u32], x: DVec3) -> Vec<(u32, f64)> {
    let nearest = stencil[0];
    let (t, b) = tangent_frame(samples.normals[nearest as usize]);
    let d0 = samples.positions[nearest as usize].distance_squared(x).max(1e-24);
    let points: Vec<(u32, DVec3, f64)> = stencil
        .iter()
        .map(|&j| {
            let d = samples.positions[j as usize] - x;
            (j, DVec3::new(1.0, d.dot(t), d.dot(b)), 1.0 / (d.length_squared() + d0))
        })
        .collect();
    let a = points
        .iter()
        .fold(glam::DMat3::ZERO, |m, (_, p, w)| m + glam::DMat3::from_cols(*p * p.x * *w, *p * p.y * *w, *p * p.z * *w));
    // The stencil must span the plane (scale-free: the moment matrix normalised by its size).
    let spread = points.iter().map(|(_, p, _)| p.y * p.y + p.z * p.z).fold(0.0, f64::max).max(1e-24).sqrt();
    let unit = glam::DMat3::from_diagonal(DVec3::new(1.0, 1.0 / spread, 1.0 / spread));
    let det = (unit * a * unit).determinant() / a.x_axis.x.powi(3);
    if points.len() < 3 || !(det.abs() > 1e-6) {
        return vec![(nearest, 1.0)];
    }
    let row = a.inverse().row(0);
    let linear: Vec<(u32, f64)> = points.iter().map(|(j, p, w)| (*j, w * row.dot(*p))).collect();
    // Negative weights would amplify the noise of a sampled irradiance (an environment's Monte
    // Carlo estimate at each sample): then the θ-weighted mean, a convex combination.
    if linear.iter().any(|(_, w)| *w < 0.0) {
        let total: f64 = points.iter().map(|(_, _, w)| w).sum();
        return points.iter().map(|(j, _, w)| (*j, w / total)).collect();
    }
    linear
}

/// Two unit vectors completing `n` to an orthonormal frame.
fn tangent_frame(n: DVec3) -> (DVec3, DVec3) {
    let t = n.any_orthonormal_vector();
    (t, n.cross(t))
}

/// The bits of a key's prefix: keys are counted per prefix to find the threshold's bucket.
const PREFIX_BITS: u32 = 12;

/// The prefix of a non-negative key: non-negative floats order as their bit patterns.
fn prefix(key: f32) -> usize {
    (key.to_bits() >> (32 - PREFIX_BITS)) as usize
}

/// From the count of keys per prefix, the prefix holding the `budget`-th largest key and how
/// many keys lie in higher prefixes.
fn threshold_bucket(histogram: &[usize], budget: usize) -> (usize, usize) {
    let mut above = 0;
    for b in (0..histogram.len()).rev() {
        if above + histogram[b] >= budget {
            return (b, above);
        }
        above += histogram[b];
    }
    (0, above)
}

/// The `rank`-th largest (from 0) of `keys` (the keys of one bucket), and how many of them are
/// larger.
fn select_in_bucket(keys: &mut [f32], rank: usize) -> (f32, usize) {
    let (_, t, _) = keys.select_nth_unstable_by(rank, |a, b| b.total_cmp(a));
    let t = *t;
    (t, keys.iter().filter(|&&x| x > t).count())
}

/// The selection weight of the Haar coefficient at index j ≥ 1, a detail at level ℓ = ⌊log₂ j⌋:
/// 2^(−ℓ/2), the size of the irradiance's coefficient it will meet. A row's coefficient c adds
/// c · q̂ⱼ to the product, and the irradiance is piecewise smooth with jumps at shadows' edges:
/// an orthonormal Haar detail over m = N/2^ℓ samples straddling a jump Δ is at most Δ √m / 2,
/// so |q̂ⱼ| ∝ 2^(−ℓ/2) (smooth parts fall faster, as 2^(−ℓ) on a surface). Keeping the largest
/// |c| alone spends the budget on fine details the light barely excites. Measured on the sun-
/// and spot-lit 60 mm cow against brute force (`shadowed_object_matches_brute_force`), relative
/// L² at 3072 and 1536 terms: 1.0e-2 and 1.9e-2 by |c| alone; 3.7e-3 and 8.0e-3 with 2^(−ℓ/4);
/// 3.3e-3 and 6.0e-3 with 2^(−ℓ/2); 6.0e-3 and 1.5e-2 with 2^(−ℓ).
fn level_weights() -> [f32; 64] {
    std::array::from_fn(|level| (-0.5 * level as f32).exp2())
}

/// One vertex's rows (Haar coefficients, interleaved `rows[j K + k]`) compressed: its `budget`
/// coefficients of largest key |c| wₖ 2^(−ℓ/2) (the basis function's singular value over the
/// first and the coefficient's level, [`level_weights`]; every row's coefficient 0 first),
/// quantised per row and
/// stored per row in index order ([`push_entry`]). The budget-th largest key is found in three
/// scans of the coefficients without storing the keys: the keys counted per 12-bit prefix (and
/// the weighted energy summed, one accumulator per row so the sums do not wait on each other),
/// the keys of the threshold's prefix collected and selected among, then the kept coefficients
/// gathered.
fn compress(rows: &[f32], weights: &[f32], budget: usize, keys: &mut Vec<f32>, kept: &mut Vec<(u32, f32)>) -> Compressed {
    let k = weights.len();
    let n = rows.len() / k;
    // The coefficient 0 of every row is always kept: its key is infinite.
    let levels = level_weights();
    let key = |j: usize, kk: usize, c: f32| {
        if j == 0 {
            f32::INFINITY
        } else {
            c.abs() * weights[kk] * levels[j.ilog2() as usize]
        }
    };
    let mut all = [0.0f64; MAX_TERMS];
    let (threshold, above) = if budget >= k * n {
        for row in rows.chunks_exact(k) {
            for ((e, &c), &w) in all.iter_mut().zip(row).zip(weights) {
                *e += f64::from(c * w) * f64::from(c * w);
            }
        }
        (f32::NEG_INFINITY, k * n)
    } else {
        let mut histogram = vec![0usize; 1 << PREFIX_BITS];
        histogram[prefix(f32::INFINITY)] += k;
        for (j, row) in rows.chunks_exact(k).enumerate() {
            for (kk, ((e, &c), &w)) in all.iter_mut().zip(row).zip(weights).enumerate() {
                *e += f64::from(c * w) * f64::from(c * w);
                if j > 0 {
                    histogram[prefix(key(j, kk, c))] += 1;
                }
            }
        }
        let (bucket, above) = threshold_bucket(&histogram, budget);
        keys.clear();
        for (j, row) in rows.chunks_exact(k).enumerate() {
            for (kk, &c) in row.iter().enumerate() {
                let key = key(j, kk, c);
                if prefix(key) == bucket {
                    keys.push(key);
                }
            }
        }
        let (t, larger) = select_in_bucket(keys, budget - above - 1);
        (t, above + larger)
    };
    // The kept coefficients in sample order (so each row's come out in index order), then per row.
    let mut ties = budget.saturating_sub(above);
    kept.clear();
    let mut counts = [0u32; MAX_TERMS];
    let mut kept_energy = [0.0f64; MAX_TERMS];
    for (j, row) in rows.chunks_exact(k).enumerate() {
        for (kk, &c) in row.iter().enumerate() {
            let kv = key(j, kk, c);
            let keep = kv > threshold
                || (kv == threshold && ties > 0 && {
                    ties -= 1;
                    true
                });
            if keep {
                kept.push(((j * k + kk) as u32, c));
                counts[kk] += 1;
                kept_energy[kk] += f64::from(c * weights[kk]) * f64::from(c * weights[kk]);
            }
        }
    }
    debug_assert_eq!(kept.len(), budget);
    let qmax = f32::from(i16::MAX);
    let mut steps = [0.0f32; MAX_TERMS];
    let mut largest = [0.0f32; MAX_TERMS];
    for &(at, c) in kept.iter() {
        let kk = at as usize % k;
        largest[kk] = largest[kk].max(c.abs());
    }
    for kk in 0..k {
        steps[kk] = if largest[kk] > 0.0 { largest[kk] / qmax } else { 1.0 };
    }
    // The kept coefficients grouped by row (each row's in sample order), then each row encoded.
    let mut next = [0usize; MAX_TERMS];
    for kk in 1..k {
        next[kk] = next[kk - 1] + counts[kk - 1] as usize;
    }
    let mut by_row = vec![(0u32, 0i16); kept.len()];
    for &(at, c) in kept.iter() {
        let (j, kk) = (at as usize / k, at as usize % k);
        by_row[next[kk]] = (j as u32, (c / steps[kk]).round() as i16);
        next[kk] += 1;
    }
    let (mut gaps, mut values) = (Vec::with_capacity(budget + budget / 16), Vec::with_capacity(budget + budget / 16));
    let mut start = 0;
    for count in counts.iter_mut().take(k) {
        let before = gaps.len();
        let mut previous = 0;
        for &(j, value) in &by_row[start..start + *count as usize] {
            previous = push_entry(&mut gaps, &mut values, previous, j, value);
        }
        start += *count as usize;
        *count = (gaps.len() - before) as u32;
    }
    // What the compression dropped: the sums over all minus over the kept, per row, in the same
    // order, so nothing is dropped exactly when every coefficient is kept.
    let total: f64 = all[..k].iter().sum();
    let dropped: f64 = all[..k].iter().zip(&kept_energy[..k]).map(|(a, b)| (a - b).max(0.0)).sum();
    let dropped = if total > 0.0 { (dropped / total).sqrt() } else { 0.0 };
    Compressed { counts, steps, dropped, gaps, values }
}

#[cfg(test)]
mod tests {
    use super::super::basis::BasisSize;
    use super::*;
    use crate::mesh::icosphere;

    fn sphere_transfer(terms_per_vertex: usize, near_field: bool) -> (Transfer, SurfaceSamples, crate::mesh::TriMesh) {
        let sphere = icosphere(10.0, 3);
        let samples = SurfaceSamples::new(sphere.positions(), sphere.triangles(), 10, 3).unwrap();
        let options = PrtOptions { samples_log2: 10, terms_per_vertex, near_field, ..PrtOptions::default() };
        let basis = RdBasis::get(BasisSize::K16);
        let t =
            Transfer::precompute(sphere.positions(), sphere.positions(), sphere.triangles(), &samples, basis, &options, &|_| {
                Ok(())
            })
            .unwrap();
        (t, samples, sphere)
    }

    /// The budget-th largest key and the count above it, by prefix bucket and selection in it,
    /// against a full sort (ties, infinities and zeros included).
    #[test]
    fn the_threshold_is_the_sorted_one() {
        let mut keys: Vec<f32> = (0..5000u32).map(|i| ((i.wrapping_mul(2_654_435_761) >> 8) % 1000) as f32 * 1e-3).collect();
        keys.extend([f32::INFINITY; 7]);
        keys.extend([0.0; 50]);
        let mut sorted = keys.clone();
        sorted.sort_by(|a, b| b.total_cmp(a));
        let mut histogram = vec![0usize; 1 << PREFIX_BITS];
        for &x in &keys {
            histogram[prefix(x)] += 1;
        }
        for budget in [1, 7, 8, 100, 2500, 5006, 5057] {
            let (bucket, above) = threshold_bucket(&histogram, budget);
            let mut in_bucket: Vec<f32> = keys.iter().copied().filter(|&x| prefix(x) == bucket).collect();
            let (t, larger) = select_in_bucket(&mut in_bucket, budget - above - 1);
            assert_eq!(t, sorted[budget - 1], "budget {budget}");
            assert_eq!(above + larger, sorted.iter().filter(|&&x| x > t).count(), "budget {budget}");
        }
    }

    /// A vertex's compressed rows keep exactly the budget coefficients of largest
    /// |c| wₖ 2^(−ℓ/2) (computed here in f64 from the level ⌊log₂ j⌋), every row's coefficient 0
    /// among them, each value within half its row's step: random rows of 4 basis functions
    /// over 512 samples, with equal magnitudes placed at a coarse and a fine level so the level
    /// decides between them.
    #[test]
    fn compression_keeps_the_largest_level_weighted_coefficients() {
        let (k, n, budget) = (4, 512, 300);
        let weights = [1.0f32, 0.5, 0.25, 0.125];
        let mut rows: Vec<f32> =
            (0..k * n).map(|i| (((i as u32).wrapping_mul(2_654_435_761) >> 8) % 100_000) as f32 * 1e-5 - 0.5).collect();
        // The same |c| on basis function 0 at level 2 (j = 5) and level 8 (j = 300).
        rows[5 * k] = 0.3;
        rows[300 * k] = -0.3;
        let key = |j: usize, kk: usize| {
            if j == 0 {
                f64::INFINITY
            } else {
                f64::from(rows[j * k + kk].abs()) * f64::from(weights[kk]) / f64::from(1u32 << j.ilog2()).sqrt()
            }
        };
        let mut sorted: Vec<f64> = (0..n).flat_map(|j| (0..k).map(move |kk| (j, kk))).map(|(j, kk)| key(j, kk)).collect();
        sorted.sort_by(|a, b| b.total_cmp(a));
        let threshold = sorted[budget - 1];
        let c = compress(&rows, &weights, budget, &mut Vec::new(), &mut Vec::new());
        let mut kept = vec![false; k * n];
        let mut at = 0;
        for kk in 0..k {
            let mut index = 0;
            for (&g, &v) in c.gaps[at..at + c.counts[kk] as usize].iter().zip(&c.values[at..]) {
                let (advance, value) = decode(g, v);
                index += advance as usize;
                if g != ESCAPE {
                    kept[index * k + kk] = true;
                    let original = rows[index * k + kk];
                    assert!((value * c.steps[kk] - original).abs() <= 0.5 * c.steps[kk] * 1.0001, "row {kk}, sample {index}");
                }
            }
            at += c.counts[kk] as usize;
        }
        assert_eq!(kept.iter().filter(|&&x| x).count(), budget);
        for j in 0..n {
            for kk in 0..k {
                let x = key(j, kk);
                if kept[j * k + kk] {
                    assert!(x >= threshold * (1.0 - 1e-6), "kept row {kk}, sample {j}: key {x:.4e} < {threshold:.4e}");
                } else {
                    assert!(x <= threshold * (1.0 + 1e-6), "dropped row {kk}, sample {j}: key {x:.4e} > {threshold:.4e}");
                }
            }
        }
        assert!((0..k).all(|kk| kept[kk]), "every row keeps its coefficient 0");
        assert!(kept[5 * k] && !kept[300 * k], "the coarse detail is kept, the fine one of the same size dropped");
    }

    /// Rows encoded by [`push_entry`] decode to the indices and values put in; their sums on the
    /// vector path (where the CPU has one) equal the scalar reference bit for bit, and both equal
    /// the f64 sum to f32 rounding: rows of every length mod 8 (the lanes' tail), empty ones,
    /// gaps that need one escape and gaps beyond 65535 that need two, indices at both ends of
    /// the irradiance. A damaged row that advances past the last sample reads the last one on
    /// both paths.
    #[test]
    fn rows_round_trip_and_sum_alike_on_every_path() {
        let samples = 1usize << 17;
        let q: Vec<[f32; 4]> = (0..samples as u32)
            .map(|i| {
                let x = (i.wrapping_mul(2_654_435_761) >> 8) as f32 / (1u32 << 24) as f32;
                [x - 0.3, 2.0 * x, 1.0 - x, 0.0]
            })
            .collect();
        let (mut gaps, mut values, mut bounds, mut rows) = (Vec::new(), Vec::new(), vec![0u64], Vec::new());
        for len in (0..40).chain([123, 1024]) {
            let mut row: Vec<(u32, i16)> = (0..len)
                .map(|i: u32| {
                    let step = [1, 3, 254, 255, 256, 70_000][(i.wrapping_mul(7) % 6) as usize];
                    (step, ((i.wrapping_mul(97) % 4001) as i32 - 2000) as i16)
                })
                .scan(0u32, |at, (step, value)| {
                    *at = (*at + step).min(samples as u32 - 1 - len);
                    Some((*at, value))
                })
                .collect();
            row.dedup_by_key(|e| e.0);
            row.push((samples as u32 - 1, 5));
            let mut previous = 0;
            for &(index, value) in &row {
                previous = push_entry(&mut gaps, &mut values, previous, index, value);
            }
            bounds.push(gaps.len() as u64);
            rows.push(row);
        }
        assert!(gaps.iter().filter(|&&g| g == ESCAPE).count() > 100, "escapes exercised");
        let transfer = Transfer {
            terms_per_row: 1,
            vertices: rows.len(),
            samples,
            row_start: bounds.clone(),
            gaps: gaps.clone(),
            values: values.clone(),
            steps: vec![1.0; rows.len()],
            stats: TransferStats::default(),
        };
        let sum = RowSum::new(&q);
        let mut fast = vec![[0.0f32; 4]; rows.len()];
        sum.rows(&gaps, &values, &bounds, &mut fast);
        for (j, row) in rows.iter().enumerate() {
            let decoded: Vec<(u32, f32)> = transfer.row_entries(j).filter(|e| e.1 != 0.0).collect();
            let wanted: Vec<(u32, f32)> = row.iter().filter(|e| e.1 != 0).map(|&(i, v)| (i, f32::from(v))).collect();
            assert_eq!(decoded, wanted, "row {j} decodes to what was encoded");
            let range = bounds[j] as usize..bounds[j + 1] as usize;
            assert_eq!(fast[j], row_sum(&gaps[range.clone()], &values[range], &q), "row {j} of {} terms", row.len());
            let exact = [0, 1, 2].map(|c| row.iter().map(|&(i, v)| f64::from(v) * f64::from(q[i as usize][c])).sum::<f64>());
            let scale: f64 = row.iter().map(|&(_, v)| 2.0 * f64::from(v).abs()).sum();
            for c in 0..3 {
                assert!(
                    (f64::from(fast[j][c]) - exact[c]).abs() <= 1e-6 * scale,
                    "row {j} channel {c}: {} vs {}",
                    fast[j][c],
                    exact[c]
                );
            }
        }
        assert_eq!(transfer.row_beyond_samples(), None);
        // Nine full-length escapes and a value, twice over: past the end on every path.
        let (far_gaps, far_values): (Vec<u8>, Vec<i16>) =
            [(ESCAPE, -1i16); 9].into_iter().chain([(3, 7)]).cycle().take(20).unzip();
        let mut clamped = [[0.0f32; 4]; 1];
        sum.rows(&far_gaps, &far_values, &[0, 20], &mut clamped);
        assert_eq!(clamped[0], row_sum(&far_gaps, &far_values, &q));
        assert_eq!(clamped[0][0], 14.0 * q[samples - 1][0]);
    }

    /// Uncompressed (every coefficient kept), the transfer applied to q equals the direct sum
    /// Σⱼ aⱼ bₖ(r) qⱼ (no near field) to the packing's precision.
    #[test]
    fn uncompressed_transfer_is_the_direct_sum() {
        let (t, samples, sphere) = sphere_transfer(usize::MAX, false);
        let basis = RdBasis::get(BasisSize::K16);
        let q: Vec<[f64; 3]> =
            samples.positions.iter().map(|p| [1.0 + p.x.max(0.0), 2.0 - p.y * 0.1, (p.z > 3.0) as u8 as f64]).collect();
        let mut out = vec![0.0; sphere.positions().len() * 16 * 3];
        t.apply(&haar_irradiance(&q), &mut out);
        let mut row = [0.0; 16];
        for v in [0, 17, 300] {
            let x = sphere.positions()[v];
            let mut want = [[0.0f64; 3]; 16];
            for ((p, a), qj) in samples.positions.iter().zip(&samples.areas).zip(&q) {
                basis.eval(p.distance(x), &mut row);
                for kk in 0..16 {
                    for c in 0..3 {
                        want[kk][c] += a * row[kk] * qj[c];
                    }
                }
            }
            let scale = (0..16).map(|kk| want[kk][0].abs()).fold(0.0, f64::max);
            for kk in 0..16 {
                for c in 0..3 {
                    let got = out[(v * 16 + kk) * 3 + c];
                    assert!((got - want[kk][c]).abs() < 1e-4 * scale, "v {v} k {kk} c {c}: {got} vs {}", want[kk][c]);
                }
            }
        }
    }

    /// Under uniform q the rows with the near field integrate bₖ over the near triangles
    /// exactly, whatever the budget: the compressed and uncompressed transfers agree to the
    /// quantisation (coefficient 0 is always kept), and the stats count the kept terms.
    #[test]
    fn uniform_light_survives_any_compression() {
        let (full, samples, _) = sphere_transfer(usize::MAX, true);
        let (small, _, _) = sphere_transfer(48, true);
        assert_eq!(small.stats().terms, 48 * full.vertices());
        assert!(small.stats().dropped_mean > 0.0 && full.stats().dropped_max == 0.0);
        let q = vec![[1.0, 0.5, 2.0]; samples.len()];
        let qh = haar_irradiance(&q);
        let (mut a, mut b) = (vec![0.0; full.vertices() * 48], vec![0.0; full.vertices() * 48]);
        full.apply(&qh, &mut a);
        small.apply(&qh, &mut b);
        let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() < 2e-5 * scale, "{x} vs {y}");
        }
    }
}
