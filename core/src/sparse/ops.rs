//! Deterministic parallel vector kernels on three-channel vectors (`[f64; 3]` per row).
//!
//! Every reduction is computed as one partial sum per fixed block of [`CHUNK`] rows (summed in
//! row order inside the block), and the block partials are then added in block order on one
//! thread. The result depends only on the data, never on the number of threads or on how rayon
//! schedules the blocks: runs are bit-identical.

use rayon::prelude::*;

use super::CsrPattern;

/// Rows per parallel task and per reduction block. Fixed (not derived from the thread count) so
/// that reductions are reproducible.
pub(crate) const CHUNK: usize = 2048;

/// Adds per-block partial sums in block order.
#[inline]
pub(crate) fn sum_partials<const K: usize>(parts: &[[f64; K]]) -> [f64; K] {
    let mut s = [0.0; K];
    for p in parts {
        for (a, b) in s.iter_mut().zip(p) {
            *a += *b;
        }
    }
    s
}

/// A matrix entry type that the kernels can read as three channels.
pub(crate) trait Load3: Copy + Send + Sync {
    fn load(self) -> [f64; 3];
}

impl Load3 for [f64; 3] {
    #[inline(always)]
    fn load(self) -> [f64; 3] {
        self
    }
}

impl Load3 for [f32; 3] {
    #[inline(always)]
    fn load(self) -> [f64; 3] {
        [f64::from(self[0]), f64::from(self[1]), f64::from(self[2])]
    }
}

/// `Σ_k vals[k] * x[cols[k]]`, channel by channel, in column order.
#[inline(always)]
pub(crate) fn row_mul<E: Load3>(cols: &[u32], vals: &[E], x: &[[f64; 3]]) -> [f64; 3] {
    let (mut a0, mut a1, mut a2) = (0.0, 0.0, 0.0);
    for (&j, v) in cols.iter().zip(vals) {
        let v = v.load();
        let xj = x[j as usize];
        a0 += v[0] * xj[0];
        a1 += v[1] * xj[1];
        a2 += v[2] * xj[2];
    }
    [a0, a1, a2]
}

/// One parallel pass over the rows of the matrix `(pat, vals)` fused with `K` reductions: for
/// every row `i`, `row(i, (A x)_i, &mut out[i])` writes `out[i]` and returns the row's terms of
/// the `K` sums, which are added per fixed block of [`CHUNK`] rows and then block by block
/// (deterministic). The SpMVs with dot products and the residuals of the solvers are all this
/// pass, each with its own `row` compiled into it.
pub(crate) fn spmv_fold<E: Load3, const K: usize>(
    pat: &CsrPattern,
    vals: &[E],
    x: &[[f64; 3]],
    out: &mut [[f64; 3]],
    row: impl Fn(usize, [f64; 3], &mut [f64; 3]) -> [f64; K] + Sync,
) -> [f64; K] {
    let (rp, ci) = (pat.row_ptr(), pat.col_idx());
    let parts: Vec<[f64; K]> = out
        .par_chunks_mut(CHUNK)
        .enumerate()
        .map(|(k, oc)| {
            let r0 = k * CHUNK;
            let mut s = [0.0; K];
            for (li, oi) in oc.iter_mut().enumerate() {
                let i = r0 + li;
                let (s0, e0) = (rp[i], rp[i + 1]);
                let terms = row(i, row_mul(&ci[s0..e0], &vals[s0..e0], x), oi);
                for (a, t) in s.iter_mut().zip(terms) {
                    *a += t;
                }
            }
            s
        })
        .collect();
    sum_partials(&parts)
}

/// `y = A x` on the matrix `(pat, vals)`; returns `wᵀy` per channel (`pᵀAp` for `w = x = p`).
pub(crate) fn spmv_dot<E: Load3>(pat: &CsrPattern, vals: &[E], x: &[[f64; 3]], y: &mut [[f64; 3]], w: &[[f64; 3]]) -> [f64; 3] {
    spmv_fold(pat, vals, x, y, |i, v, yi| {
        *yi = v;
        let wi = w[i];
        [wi[0] * v[0], wi[1] * v[1], wi[2] * v[2]]
    })
}

/// Per-channel dot product `Σ_i a_i · b_i`, deterministic.
///
/// # Panics
/// If the two vectors differ in length.
#[must_use]
pub fn dot3(a: &[[f64; 3]], b: &[[f64; 3]]) -> [f64; 3] {
    assert_eq!(a.len(), b.len(), "dot3: vectors differ in length");
    let parts: Vec<[f64; 3]> = a
        .par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(a, b)| {
            let mut s = [0.0; 3];
            for (x, y) in a.iter().zip(b) {
                s[0] += x[0] * y[0];
                s[1] += x[1] * y[1];
                s[2] += x[2] * y[2];
            }
            s
        })
        .collect();
    sum_partials(&parts)
}

/// Per-channel Euclidean norm, deterministic.
#[must_use]
pub fn norm3(a: &[[f64; 3]]) -> [f64; 3] {
    dot3(a, a).map(f64::sqrt)
}

/// Splits a three-channel vector into its channels.
#[must_use]
pub fn split_channels(v: &[[f64; 3]]) -> [Vec<f64>; 3] {
    [0, 1, 2].map(|c| v.iter().map(|x| x[c]).collect())
}

/// Interleaves three channel vectors of equal length into one three-channel vector.
///
/// # Panics
/// If the channels differ in length.
#[must_use]
pub fn interleave_channels(r: &[f64], g: &[f64], b: &[f64]) -> Vec<[f64; 3]> {
    assert!(r.len() == g.len() && g.len() == b.len(), "interleave_channels: lengths differ");
    r.iter().zip(g).zip(b).map(|((&r, &g), &b)| [r, g, b]).collect()
}

/// The first non-finite value of a three-channel vector, as `(row, channel, value)`.
pub(crate) fn first_non_finite(v: &[[f64; 3]]) -> Option<(usize, usize, f64)> {
    // Blocks are searched in parallel; the first bad block (in order) wins.
    let bad: Option<usize> =
        v.par_chunks(CHUNK).position_first(|c| c.iter().any(|x| !(x[0].is_finite() && x[1].is_finite() && x[2].is_finite())));
    let b = bad?;
    let start = b * CHUNK;
    v[start..].iter().enumerate().find_map(|(i, x)| x.iter().position(|t| !t.is_finite()).map(|c| (start + i, c, x[c])))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dot_is_exact_on_small_integers_and_checks_finite() {
        let a: Vec<[f64; 3]> = (0..10_000).map(|i| [i as f64, 1.0, -(i as f64)]).collect();
        let d = dot3(&a, &a);
        let s: f64 = (0..10_000).map(|i| (i * i) as f64).sum();
        assert_eq!(d, [s, 10_000.0, s]);
        assert!(first_non_finite(&a).is_none());
        let mut b = a.clone();
        b[5000][2] = f64::NAN;
        b[7000][0] = f64::INFINITY;
        let (row, ch, v) = first_non_finite(&b).unwrap();
        assert_eq!((row, ch), (5000, 2));
        assert!(v.is_nan());
        let [r, g, bl] = split_channels(&a);
        assert_eq!(interleave_channels(&r, &g, &bl), a);
    }
}
