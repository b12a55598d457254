//! A multigrid V-cycle on the TransCut hierarchy (or on a smoothed aggregation,
//! [`Hierarchy::aggregated`], whose `P` takes the place of eq. 16's), used as the preconditioner
//! of CG.
//!
//! The paper (§4.2) keeps to its one-way cascade and remarks that its interpolation could
//! serve a full multigrid solver; this is that solver in its symmetric form. With `P` the
//! eq.-16 interpolation of each level, the coarse operators are the Galerkin products
//! `A^{l+1} = Pᵀ A^l P` ([`galerkin`]), which stay symmetric positive definite. One V-cycle
//! `z = B r`, per level `l` above the coarsest (`Ã^l` the level's operator rounded to `f32`,
//! see below):
//!
//! 1. pre-smooth from `z = 0` with a degree-`d` Chebyshev polynomial in `D⁻¹Ã` over
//!    `[λmax / ratio, λmax]` (`λmax` the Gershgorin bound `max_i Σ_j |ã_ij| / a_ii` of the
//!    spectrum of `D⁻¹Ã`, see [`Smoother`]): the first step
//!    is `z = D⁻¹ r / θ` (no product), each further step `res = r − Ã z`,
//!    `d = ρ_k ρ_{k−1} d + (2ρ_k/δ) D⁻¹ res`, `z += d` in one fused pass;
//! 2. restrict the residual `r_c = Pᵀ (r − Ã z)`, recurse (dense Cholesky at the coarsest);
//! 3. correct `z += P z_c`, post-smooth with the same polynomial (`d` steps, each one fused
//!    residual-and-update pass).
//!
//! That is `2d` products with `Ã^l` per level and V-cycle, the fewest a degree-`d` smoother
//! needs (each step needs the residual of the previous iterate, and the restriction that of the
//! last pre-smoothing iterate).
//!
//! **Precision.** The operators inside the V-cycle are stored in `f32` (12 + 4 bytes per
//! nonzero instead of 24 + 4; the products accumulate in `f64`, vectors stay `f64`): the level-0
//! matrix given to [`Multigrid::new`] is symmetrised `(a_ij + a_ji)/2` before rounding and the
//! Galerkin operators are exactly symmetric already, so each `Ã^l` is exactly symmetric. The
//! V-cycle is therefore the symmetric two-sided smoother `M = q(D⁻¹Ã)D⁻¹` around a symmetric
//! coarse correction: with `C = P B_c Pᵀ` (`B_c` the next level's cycle, symmetric by
//! induction, the exact inverse at the coarsest), `B = 2M − MÃM + (I − MÃ) C (I − ÃM)`, a
//! fixed symmetric linear operator, positive definite since the smoother contracts (`λmax`
//! is a true upper bound of the spectrum of `D⁻¹Ã`, computed from the rounded entries
//! themselves). Plain CG on the exact `f64` level-0 matrix stays valid ([`mg_pcg`]); `B` only
//! approximates `A⁻¹` less well by the rounding, far below what one V-cycle leaves anyway.
//!
//! **Memory.** Every vector a V-cycle and [`mg_pcg`] use lives in a workspace allocated (and
//! touched) by [`Multigrid::new`] and reused, so a solve allocates nothing; two threads using
//! the same [`Multigrid`] at once get the second a temporary workspace (same results).
//!
//! Every kernel is a fixed-order parallel loop (each row summed in column order, reductions in
//! fixed blocks), so results are bit-identical for any thread count.

use std::sync::{Arc, Mutex, TryLockError};

use glam::DVec3;
#[cfg(feature = "gpu")]
use nalgebra::DMatrix;
use nalgebra::{Cholesky, Dyn};
use rayon::prelude::*;

use super::coarse::{galerkin, galerkin_rows};
use super::{Hierarchy, HierarchyOptions};
use crate::sparse::ops::{dot3, norm3, row_mul, CHUNK};
use crate::sparse::pcg::{spmv_dot, update};
use crate::sparse::precond::{inverse_diagonal, positive_diagonal};
use crate::sparse::{CsrMatrix3, CsrPattern, SolveOptions, SolveStats, SparseError};

/// Rows per parallel task of the V-cycle kernels (fixed: per-row results do not depend on it).
const ROWS: usize = CHUNK / 4;

/// Options of [`Multigrid::new`].
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct MultigridOptions {
    /// Degree of the Chebyshev smoother (matrix products per smoothing). Default 1 (damped
    /// Jacobi `z += D⁻¹ res / θ`, θ the interval's centre), which reaches a given error in the
    /// least time (see the module documentation of [`crate::sparse::hierarchy`]).
    pub smoothing_degree: usize,
    /// The smoothing interval is `[λmax / ratio, λmax]`. Default 4 (30, the value of earlier
    /// versions, damped too little: 10 iterations to 1e-6 instead of 7 on the 500k-tet bunny).
    pub smoothing_ratio: f64,
    /// Largest coarsest level factored densely; coarser hierarchies beyond it are an error.
    /// Default 4000.
    pub max_direct: usize,
}

impl Default for MultigridOptions {
    fn default() -> Self {
        Self { smoothing_degree: 1, smoothing_ratio: 4.0, max_direct: 4000 }
    }
}

/// One Chebyshev step `d = keep d + gain D⁻¹ res` (per channel; `keep` is 0 in the first step).
#[derive(Debug, Clone, Copy)]
struct Step {
    keep: [f64; 3],
    gain: [f64; 3],
}

/// The steps of a degree-`degree` Chebyshev smoothing over `[λmax/ratio, λmax]` of `D⁻¹A`
/// (θ, δ the interval's centre and half-width, σ = θ/δ): step 0 `d = D⁻¹ res / θ`; step
/// `k > 0` with `ρ_0 = 1/σ`, `ρ_k = 1/(2σ − ρ_{k−1})`: `d = ρ_k ρ_{k−1} d + (2ρ_k/δ) D⁻¹ res`.
fn chebyshev_steps(lambda_max: [f64; 3], degree: usize, ratio: f64) -> Vec<Step> {
    let theta = lambda_max.map(|h| 0.5 * (h + h / ratio));
    let delta = lambda_max.map(|h| 0.5 * (h - h / ratio));
    let sigma = [0, 1, 2].map(|c| theta[c] / delta[c]);
    let mut rho = sigma.map(|s| 1.0 / s);
    let mut steps = vec![Step { keep: [0.0; 3], gain: theta.map(|t| 1.0 / t) }];
    for _ in 1..degree {
        let rho_new = [0, 1, 2].map(|c| 1.0 / (2.0 * sigma[c] - rho[c]));
        steps.push(Step { keep: [0, 1, 2].map(|c| rho_new[c] * rho[c]), gain: [0, 1, 2].map(|c| 2.0 * rho_new[c] / delta[c]) });
        rho = rho_new;
    }
    steps
}

/// The Chebyshev smoother of one level: `D⁻¹` of the level's operator `A` and the upper end
/// `λmax` of the interval, the Gershgorin bound `max_i Σ_j |ã_ij| / a_ii` of the spectrum of
/// `D⁻¹Ã` (`Ã` the `f32` operator the smoothing multiplies by). A true bound, so the smoother
/// contracts and the V-cycle is SPD with no safety factor, and a per-row one, so a change of
/// some rows updates it exactly ([`Multigrid::refresh`]). On the 500k-tet bunny it lies 15% (level
/// 0) to 45% (level 1) above the power-iteration estimate earlier versions used (×1.1), so it
/// damps a little less: the error after 2 MG-PCG iterations went from 0.27% to 0.37%, with the
/// same iteration counts (7 to 1e-6 cold, 6 after a 5° relight, 2 to 1% error). Widening the
/// interval to make up for it (ratio 8, 16, 64 instead of 4) gained no iteration.
#[derive(Debug, Clone)]
struct Smoother {
    inv_diag: Vec<[f64; 3]>,
    /// `Σ_j |ã_ij| / a_ii` per row.
    row_bounds: Vec<[f64; 3]>,
    lambda_max: [f64; 3],
    steps: Vec<Step>,
}

/// A level operator inside the V-cycle: exactly symmetric, rounded to `f32`.
#[derive(Debug, Clone)]
struct Operator32 {
    pattern: Arc<CsrPattern>,
    values: Vec<[f32; 3]>,
    /// Whether entries are symmetrised before rounding (level 0).
    symmetrise: bool,
}

/// Entry `k` (in row `i`) of `values` rounded to `f32`, as the mean with its mirror when
/// `symmetrise`.
#[inline]
fn rounded(p: &CsrPattern, values: &[[f64; 3]], symmetrise: bool, i: usize, k: usize) -> [f32; 3] {
    let mirror = if symmetrise { p.position(p.col_idx()[k] as usize, i) } else { None };
    rounded_with_mirror(values, k, mirror)
}

/// Entry `k` of `values` rounded to `f32`, as the mean with entry `mirror` when that is
/// another entry.
#[inline]
fn rounded_with_mirror(v: &[[f64; 3]], k: usize, mirror: Option<usize>) -> [f32; 3] {
    let s = match mirror {
        Some(t) if t != k => [0, 1, 2].map(|c| 0.5 * (v[k][c] + v[t][c])),
        _ => v[k],
    };
    #[allow(clippy::cast_possible_truncation)]
    s.map(|x| x as f32)
}

impl Operator32 {
    /// `a` rounded to `f32`; with `symmetrise`, each entry is `(a_ij + a_ji)/2` first (an entry
    /// whose mirror is not in the pattern is rounded as it is), for a matrix that is symmetric
    /// only up to rounding. (For an exactly symmetric one the mean is the entry itself.)
    fn new(a: &CsrMatrix3, symmetrise: bool) -> Self {
        let p = a.pattern();
        // The mirrors in one pass rather than a search per entry.
        let mirror = if symmetrise { p.mirror_positions() } else { Vec::new() };
        let values: Vec<[f32; 3]> = (0..a.nnz())
            .into_par_iter()
            .with_min_len(CHUNK)
            .map(|k| rounded_with_mirror(a.values(), k, mirror.get(k).copied().filter(|&t| t != usize::MAX)))
            .collect();
        Self { pattern: Arc::clone(p), values, symmetrise }
    }

    /// Re-rounds from `a` (this operator's pattern) the entries of `rows`, as [`Self::new`]
    /// does: after a symmetric change of `a` confined to those rows (and so to their columns),
    /// the result equals `Operator32::new(a, ..)` bit for bit.
    fn refresh_rows(&mut self, a: &CsrMatrix3, rows: &[u32]) {
        let p = Arc::clone(&self.pattern);
        for &i in rows {
            let i = i as usize;
            for k in p.row_ptr()[i]..p.row_ptr()[i + 1] {
                self.values[k] = rounded(&p, a.values(), self.symmetrise, i, k);
            }
        }
    }

    /// Row `i`'s Gershgorin bound `Σ_j |ã_ij| / a_ii` (`inv` = `1 / a_ii`).
    fn row_bound(&self, i: usize, inv: [f64; 3]) -> [f64; 3] {
        let rp = self.pattern.row_ptr();
        let mut s = [0.0f64; 3];
        for v in &self.values[rp[i]..rp[i + 1]] {
            for c in 0..3 {
                s[c] += f64::from(v[c].abs());
            }
        }
        [0, 1, 2].map(|c| s[c] * inv[c])
    }

    /// `(Ã x)_i`.
    #[inline(always)]
    fn row(&self, i: usize, x: &[[f64; 3]]) -> [f64; 3] {
        let rp = self.pattern.row_ptr();
        let (s, e) = (rp[i], rp[i + 1]);
        row_mul(&self.pattern.col_idx()[s..e], &self.values[s..e], x)
    }
}

/// The dense Cholesky factors `L` of the coarsest operator, the three channels interleaved,
/// lower triangle packed row by row (row `i` starts at `i(i+1)/2`).
#[derive(Debug, Clone)]
struct CoarseFactor {
    n: usize,
    l: Vec<[f64; 3]>,
}

impl CoarseFactor {
    fn new(factors: &[Cholesky<f64, Dyn>; 3]) -> Self {
        let n = factors[0].l_dirty().nrows();
        let mut l = Vec::with_capacity(n * (n + 1) / 2);
        for i in 0..n {
            for j in 0..=i {
                l.push([0, 1, 2].map(|c| factors[c].l_dirty()[(i, j)]));
            }
        }
        Self { n, l }
    }

    /// `x ← (L Lᵀ)⁻¹ x`: forward substitution by rows, back substitution by columns (both
    /// walk the packed rows of `L` contiguously).
    fn solve_in_place(&self, x: &mut [[f64; 3]]) {
        for i in 0..self.n {
            let row = &self.l[i * (i + 1) / 2..][..=i];
            let mut s = x[i];
            for (lij, xj) in row[..i].iter().zip(&x[..i]) {
                for c in 0..3 {
                    s[c] -= lij[c] * xj[c];
                }
            }
            x[i] = [0, 1, 2].map(|c| s[c] / row[i][c]);
        }
        for i in (0..self.n).rev() {
            let row = &self.l[i * (i + 1) / 2..][..=i];
            let xi = [0, 1, 2].map(|c| x[i][c] / row[i][c]);
            x[i] = xi;
            for (lij, xj) in row[..i].iter().zip(&mut x[..i]) {
                for c in 0..3 {
                    xj[c] -= lij[c] * xi[c];
                }
            }
        }
    }

    /// The dense `L` of channel `c`.
    #[cfg(feature = "gpu")]
    fn dense(&self, c: usize) -> DMatrix<f64> {
        DMatrix::from_fn(self.n, self.n, |i, j| if j <= i { self.l[i * (i + 1) / 2 + j][c] } else { 0.0 })
    }
}

/// A vector of `n` zeros whose pages are touched now (not at first use inside a solve).
fn touched(n: usize) -> Vec<[f64; 3]> {
    let mut v = Vec::with_capacity(n);
    v.resize(n, [0.0; 3]);
    v
}

/// The vectors of one level: `r`, `z` the level's right-hand side and solution (not used at
/// level 0, whose are the caller's), `alt` the second buffer of `z`, `d` the Chebyshev
/// direction, `res` the residual (only above the coarsest).
#[derive(Default)]
struct LevelWork {
    r: Vec<[f64; 3]>,
    z: Vec<[f64; 3]>,
    alt: Vec<[f64; 3]>,
    d: Vec<[f64; 3]>,
    res: Vec<[f64; 3]>,
}

/// The vectors of the outer CG of [`mg_pcg`].
struct Outer {
    x: Vec<[f64; 3]>,
    r: Vec<[f64; 3]>,
    z: Vec<[f64; 3]>,
    p: Vec<[f64; 3]>,
    q: Vec<[f64; 3]>,
}

struct Workspace {
    levels: Vec<LevelWork>,
    outer: Outer,
}

impl Workspace {
    fn new(h: &Hierarchy) -> Self {
        let count = h.levels();
        let levels = (0..count)
            .map(|l| {
                let n = h.level(l).graph.n();
                let (nr, ns) = (if l == 0 { 0 } else { n }, if l + 1 < count { n } else { 0 });
                LevelWork { r: touched(nr), z: touched(nr), alt: touched(ns), d: touched(ns), res: touched(ns) }
            })
            .collect();
        let n = h.level(0).graph.n();
        Self { levels, outer: Outer { x: touched(n), r: touched(n), z: touched(n), p: touched(n), q: touched(n) } }
    }
}

/// The reusable workspace (a clone starts without one and allocates it on first use).
struct WorkCell(Mutex<Option<Workspace>>);

impl Clone for WorkCell {
    fn clone(&self) -> Self {
        Self(Mutex::new(None))
    }
}

impl std::fmt::Debug for WorkCell {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("WorkCell")
    }
}

/// The Galerkin hierarchy, smoothers and coarsest factorisation for one matrix.
#[derive(Debug, Clone)]
pub struct Multigrid {
    hierarchy: Arc<Hierarchy>,
    /// `operators[l - 1]` is `A^l`, `l ≥ 1`.
    operators: Vec<CsrMatrix3>,
    /// `ops32[l]` is `Ã^l` for the levels above the coarsest (level 0 included).
    ops32: Vec<Operator32>,
    smoothers: Vec<Smoother>,
    coarsest: Option<CoarseFactor>,
    options: MultigridOptions,
    work: WorkCell,
}

/// `r = b − A x`.
fn residual(a: &CsrMatrix3, b: &[[f64; 3]], x: &[[f64; 3]], r: &mut [[f64; 3]]) {
    let p = a.pattern();
    let v = a.values();
    r.par_iter_mut().enumerate().with_min_len(CHUNK / 4).for_each(|(i, ri)| {
        let (s, e) = (p.row_ptr()[i], p.row_ptr()[i + 1]);
        let ax = row_mul(&p.col_idx()[s..e], &v[s..e], x);
        *ri = [0, 1, 2].map(|c| b[i][c] - ax[c]);
    });
}

/// Checks the smoothing degree (1 to 16) and ratio (above 1).
fn validate(options: &MultigridOptions) -> Result<(), SparseError> {
    if options.smoothing_degree == 0 || options.smoothing_degree > 16 || !(options.smoothing_ratio > 1.0) {
        return Err(SparseError::InvalidOption(format!(
            "multigrid smoothing degree {} must be 1 to 16 and ratio {} above 1",
            options.smoothing_degree, options.smoothing_ratio
        )));
    }
    Ok(())
}

/// The dense Cholesky factors of the coarsest operator `m`, per channel.
fn coarse_factor(m: &CsrMatrix3) -> Result<CoarseFactor, SparseError> {
    let factor = |c: usize| -> Result<Cholesky<f64, Dyn>, SparseError> {
        Cholesky::new(m.to_dense(c)).ok_or_else(|| {
            SparseError::InvalidOption(format!("the coarsest Galerkin operator is not positive definite on channel {c}"))
        })
    };
    let ((f0, f1), f2) = rayon::join(|| rayon::join(|| factor(0), || factor(1)), || factor(2));
    Ok(CoarseFactor::new(&[f0?, f1?, f2?]))
}

/// The diagonal of `a` on `rows`, checked positive ([`positive_diagonal`]).
fn diagonal_rows(a: &CsrMatrix3, rows: &[u32]) -> Result<Vec<[f64; 3]>, SparseError> {
    rows.iter().map(|&i| positive_diagonal(a, i as usize)).collect()
}

/// The per-channel maximum of `bounds`.
fn max_bound(bounds: &[[f64; 3]]) -> [f64; 3] {
    bounds.par_iter().copied().reduce(|| [0.0; 3], |x, y| [0, 1, 2].map(|c| x[c].max(y[c])))
}

impl Smoother {
    /// The smoother of the level whose operator is `a`, rounded to `op`.
    fn new(a: &CsrMatrix3, op: &Operator32, options: &MultigridOptions) -> Result<Self, SparseError> {
        let inv_diag = inverse_diagonal(a)?;
        let row_bounds: Vec<[f64; 3]> = inv_diag.par_iter().enumerate().map(|(i, &d)| op.row_bound(i, d)).collect();
        let lambda_max = max_bound(&row_bounds);
        let steps = chebyshev_steps(lambda_max, options.smoothing_degree, options.smoothing_ratio);
        Ok(Self { inv_diag, row_bounds, lambda_max, steps })
    }

    /// Follows a change of `a` (already rounded into `op`) confined to `rows`, whose diagonal
    /// `diagonal` is checked positive: equal to [`Self::new`]`(a, op)` afterwards.
    fn refresh(&mut self, op: &Operator32, rows: &[u32], diagonal: &[[f64; 3]], options: &MultigridOptions) {
        for (&i, d) in rows.iter().zip(diagonal) {
            let i = i as usize;
            self.inv_diag[i] = d.map(|x| 1.0 / x);
            self.row_bounds[i] = op.row_bound(i, self.inv_diag[i]);
        }
        self.lambda_max = max_bound(&self.row_bounds);
        self.steps = chebyshev_steps(self.lambda_max, options.smoothing_degree, options.smoothing_ratio);
    }

    /// The first step from `z = 0`: `d = D⁻¹ r / θ`, `z = d` (no product; `d` is only written
    /// when a further step needs it).
    fn first_from_zero(&self, r: &[[f64; 3]], z: &mut [[f64; 3]], d: &mut [[f64; 3]]) {
        let g = self.steps[0].gain;
        let kernel = |z: &mut [[f64; 3]], r: &[[f64; 3]], inv: &[[f64; 3]], mut d: Option<&mut [[f64; 3]]>| {
            for (t, ((zi, ri), ii)) in z.iter_mut().zip(r).zip(inv).enumerate() {
                let v = [0, 1, 2].map(|c| g[c] * ri[c] * ii[c]);
                *zi = v;
                if let Some(d) = d.as_deref_mut() {
                    d[t] = v;
                }
            }
        };
        let inv = &self.inv_diag;
        if self.steps.len() == 1 {
            (z.par_chunks_mut(ROWS), r.par_chunks(ROWS), inv.par_chunks(ROWS))
                .into_par_iter()
                .for_each(|(z, r, inv)| kernel(z, r, inv, None));
        } else {
            (z.par_chunks_mut(ROWS), d.par_chunks_mut(ROWS), r.par_chunks(ROWS), inv.par_chunks(ROWS))
                .into_par_iter()
                .for_each(|(z, d, r, inv)| kernel(z, r, inv, Some(d)));
        }
    }

    /// Step `k` from `z_in` in one pass: `res = r − Ã z_in`, `d = keep d + gain D⁻¹ res`,
    /// `z_out = z_in + d` (step 0 does not read `d`, the last step does not write it).
    fn step(&self, op: &Operator32, k: usize, r: &[[f64; 3]], z_in: &[[f64; 3]], z_out: &mut [[f64; 3]], d: &mut [[f64; 3]]) {
        let Step { keep, gain } = self.steps[k];
        let inv = &self.inv_diag;
        let last = k + 1 == self.steps.len();
        (z_out.par_chunks_mut(ROWS), d.par_chunks_mut(ROWS)).into_par_iter().enumerate().for_each(|(b, (zo, dc))| {
            for (t, (zo, di)) in zo.iter_mut().zip(dc.iter_mut()).enumerate() {
                let i = b * ROWS + t;
                let ax = op.row(i, z_in);
                let (ri, ii, zi) = (r[i], inv[i], z_in[i]);
                let mut dn = [0.0; 3];
                for c in 0..3 {
                    let g = gain[c] * (ri[c] - ax[c]) * ii[c];
                    dn[c] = if k == 0 { g } else { keep[c] * di[c] + g };
                    zo[c] = zi[c] + dn[c];
                }
                if !last {
                    *di = dn;
                }
            }
        });
    }
}

/// `res = r − Ã z`.
fn residual32(op: &Operator32, r: &[[f64; 3]], z: &[[f64; 3]], res: &mut [[f64; 3]]) {
    res.par_chunks_mut(ROWS).enumerate().for_each(|(b, rc)| {
        for (t, ri) in rc.iter_mut().enumerate() {
            let i = b * ROWS + t;
            let ax = op.row(i, z);
            *ri = [0, 1, 2].map(|c| r[i][c] - ax[c]);
        }
    });
}

impl Multigrid {
    /// Builds the Galerkin operators of `hierarchy` for `a` (SPD, on the level-0 graph), their
    /// `f32` copies (and `a`'s) for the V-cycle, the smoothers of every level but the coarsest,
    /// the dense Cholesky factors of the coarsest and the workspace of the V-cycle and
    /// [`mg_pcg`].
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `a` is not the level-0 size;
    /// [`SparseError::NonPositiveDiagonal`] for a non-positive diagonal;
    /// [`SparseError::InvalidOption`] for bad options, a coarsest level above
    /// `options.max_direct`, or a coarsest operator that is not positive definite.
    pub fn new(hierarchy: Arc<Hierarchy>, a: &CsrMatrix3, options: MultigridOptions) -> Result<Self, SparseError> {
        validate(&options)?;
        let n0 = hierarchy.level(0).graph.n();
        if a.n() != n0 {
            return Err(SparseError::DimensionMismatch { what: "multigrid matrix rows", expected: n0, found: a.n() });
        }
        let mut operators: Vec<CsrMatrix3> = Vec::new();
        for l in 1..hierarchy.levels() {
            let g = galerkin(if l == 1 { a } else { &operators[l - 2] }, hierarchy.prolongation(l - 1))?;
            operators.push(g);
        }
        Self::with_operators(hierarchy, a, operators, options)
    }

    /// [`Self::new`] on a smoothed-aggregation hierarchy of `a` ([`Hierarchy::aggregated`]),
    /// whose Galerkin operators are computed once, while building it.
    ///
    /// # Errors
    /// Those of [`Hierarchy::aggregated`] and [`Self::new`].
    pub fn aggregated(
        a: &CsrMatrix3,
        positions: &[DVec3],
        hierarchy: &HierarchyOptions,
        options: MultigridOptions,
    ) -> Result<Self, SparseError> {
        validate(&options)?;
        let (h, operators) = Hierarchy::aggregated(a, positions, hierarchy)?;
        Self::with_operators(Arc::new(h), a, operators, options)
    }

    /// The multigrid of `hierarchy` whose Galerkin operators are `operators` (`A^1, A^2, …`).
    fn with_operators(
        hierarchy: Arc<Hierarchy>,
        a: &CsrMatrix3,
        operators: Vec<CsrMatrix3>,
        options: MultigridOptions,
    ) -> Result<Self, SparseError> {
        let levels = hierarchy.levels();
        let level_op = |l: usize| if l == 0 { a } else { &operators[l - 1] };
        let mut smoothers = Vec::new();
        let mut ops32 = Vec::new();
        for l in 0..levels.saturating_sub(1) {
            // Level 0 is symmetrised before rounding; the Galerkin operators are exactly symmetric.
            let op = Operator32::new(level_op(l), l == 0);
            smoothers.push(Smoother::new(level_op(l), &op, &options)?);
            ops32.push(op);
        }
        let coarsest = if levels > 1 {
            let m = &operators[levels - 2];
            if m.n() > options.max_direct {
                return Err(SparseError::InvalidOption(format!(
                    "the coarsest level has {} vertices, above the direct-solve limit {}; build the hierarchy deeper",
                    m.n(),
                    options.max_direct
                )));
            }
            Some(coarse_factor(m)?)
        } else {
            None
        };
        let work = WorkCell(Mutex::new(Some(Workspace::new(&hierarchy))));
        Ok(Self { hierarchy, operators, ops32, smoothers, coarsest, options, work })
    }

    /// Follows a change of the level-0 matrix confined to `rows` (every row in which it
    /// changed; the matrix being symmetric, it changed in no other column either): `a` is the
    /// new matrix, with the pattern of the one given to [`Self::new`]. Every level is brought up
    /// to date by recomputing only what the change reaches: the level-0 rows of the `f32`
    /// operator and the inverse diagonal, the Galerkin rows each changed row interpolates to
    /// ([`galerkin_rows`]), and so on down the levels; each touched smoother's `λmax` and, when
    /// the change reaches it, the coarsest factorisation are recomputed. The result equals
    /// [`Self::new`]`(hierarchy, a, options)` bit for bit, at a fraction of its cost for a local
    /// change (painting: TransCut §5.2 refills only the rows of the painted tets' vertices).
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] / [`SparseError::PatternMismatch`] if `a` has another
    /// size or pattern; [`SparseError::IndexOutOfRange`] for a row outside it;
    /// [`SparseError::NonPositiveDiagonal`] for a non-positive diagonal in a changed row: on
    /// these the multigrid is unchanged. [`SparseError::InvalidOption`] for a coarsest operator
    /// that is not positive definite (`a` was not): the multigrid is then partly updated, and a
    /// refresh with an SPD matrix on the same rows repairs it.
    pub fn refresh(&mut self, a: &CsrMatrix3, rows: &[u32]) -> Result<(), SparseError> {
        let n0 = self.hierarchy.level(0).graph.n();
        if a.n() != n0 {
            return Err(SparseError::DimensionMismatch { what: "multigrid matrix rows", expected: n0, found: a.n() });
        }
        if let Some(&r) = rows.iter().find(|&&r| r as usize >= n0) {
            return Err(SparseError::IndexOutOfRange { what: "changed row".into(), index: u64::from(r), n: n0 });
        }
        let levels = self.hierarchy.levels();
        if levels == 1 {
            // A one-level hierarchy: the V-cycle is the identity, nothing depends on `a`.
            return Ok(());
        }
        if !(Arc::ptr_eq(a.pattern(), &self.ops32[0].pattern) || **a.pattern() == *self.ops32[0].pattern) {
            return Err(SparseError::PatternMismatch(
                "the refreshed level-0 matrix has another pattern than the multigrid's".into(),
            ));
        }
        let mut changed = rows.to_vec();
        changed.sort_unstable();
        changed.dedup();
        for l in 0..levels - 1 {
            let (fine, rest) = self.operators.split_at_mut(l);
            let fine = if l == 0 { a } else { &fine[l - 1] };
            // At level 0 this is the first change made; below it cannot fail (SPD operators).
            let diagonal = diagonal_rows(fine, &changed)?;
            self.ops32[l].refresh_rows(fine, &changed);
            self.smoothers[l].refresh(&self.ops32[l], &changed, &diagonal, &self.options);
            changed = galerkin_rows(fine, self.hierarchy.prolongation(l), &mut rest[0], &changed)?;
            if changed.is_empty() {
                return Ok(());
            }
        }
        self.coarsest = Some(coarse_factor(&self.operators[levels - 2])?);
        Ok(())
    }

    /// The Galerkin operator of level `l ≥ 1`.
    ///
    /// # Panics
    /// If `l` is 0 or not below the level count.
    #[must_use]
    pub fn operator(&self, l: usize) -> &CsrMatrix3 {
        &self.operators[l - 1]
    }

    /// The hierarchy the V-cycle runs on.
    #[must_use]
    pub fn hierarchy(&self) -> &Arc<Hierarchy> {
        &self.hierarchy
    }

    /// The options it was built with.
    #[must_use]
    pub fn options(&self) -> MultigridOptions {
        self.options
    }

    /// The smoother of level `l` (below the coarsest): `D⁻¹` of the level's operator and the
    /// `λmax` estimate of `D⁻¹A` (×1.1), for the GPU twin of the V-cycle.
    #[cfg(feature = "gpu")]
    pub(crate) fn smoother(&self, l: usize) -> (&[[f64; 3]], [f64; 3]) {
        (&self.smoothers[l].inv_diag, self.smoothers[l].lambda_max)
    }

    /// `A_c⁻¹` of the coarsest level per channel (dense, from its Cholesky factor, exactly
    /// symmetrised), `None` for a one-level hierarchy; for the GPU twin of the coarse solve.
    #[cfg(feature = "gpu")]
    pub(crate) fn coarsest_inverse(&self) -> Option<[DMatrix<f64>; 3]> {
        self.coarsest.as_ref().map(|f| {
            [0, 1, 2].map(|c| {
                let inv = Cholesky::pack_dirty(f.dense(c)).inverse();
                (&inv + inv.transpose()) * 0.5
            })
        })
    }

    /// Runs `f` with the workspace: the stored one, or a fresh one while another thread holds it.
    fn with_workspace<T>(&self, f: impl FnOnce(&mut Workspace) -> T) -> T {
        let guard = match self.work.0.try_lock() {
            Ok(g) => Some(g),
            // Every vector is written before it is read, so a panic elsewhere left nothing stale.
            Err(TryLockError::Poisoned(p)) => Some(p.into_inner()),
            Err(TryLockError::WouldBlock) => None,
        };
        match guard {
            Some(mut g) => f(g.get_or_insert_with(|| Workspace::new(&self.hierarchy))),
            None => f(&mut Workspace::new(&self.hierarchy)),
        }
    }

    /// One V-cycle `z = B r` (the preconditioner of [`mg_pcg`]) on level 0. `B` is the V-cycle
    /// of the matrix the multigrid was built for (its level-0 smoothing uses the `f32` copy made
    /// by [`Multigrid::new`]); `a` is checked for its size only.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] unless `a`, `r` and `z` have the level-0 size.
    pub fn vcycle(&self, a: &CsrMatrix3, r: &[[f64; 3]], z: &mut [[f64; 3]]) -> Result<(), SparseError> {
        let n = self.hierarchy.level(0).graph.n();
        for (what, len) in [("matrix rows", a.n()), ("residual length", r.len()), ("output length", z.len())] {
            if len != n {
                return Err(SparseError::DimensionMismatch { what, expected: n, found: len });
            }
        }
        self.with_workspace(|w| self.cycle(0, r, z, &mut w.levels));
        Ok(())
    }

    /// `z = B_l r` on level `l`; `work[0]` is level `l`'s workspace, `work[1..]` the coarser
    /// levels'.
    fn cycle(&self, l: usize, r: &[[f64; 3]], z: &mut [[f64; 3]], work: &mut [LevelWork]) {
        if l + 1 == self.hierarchy.levels() {
            z.copy_from_slice(r);
            // A one-level hierarchy has no coarse factor (and no smoother): the identity.
            if let Some(f) = &self.coarsest {
                f.solve_in_place(z);
            }
            return;
        }
        let (here, coarser) = work.split_first_mut().expect("a workspace per level");
        let LevelWork { alt, d, res, .. } = here;
        let (op, sm) = (&self.ops32[l], &self.smoothers[l]);
        let degree = sm.steps.len();
        // The iterate alternates between `alt` and `z`, one switch per step after the first:
        // 2·degree − 1 switches, so starting in `alt` ends in `z`.
        let mut in_alt = true;
        sm.first_from_zero(r, alt, d);
        for k in 1..degree {
            if in_alt {
                sm.step(op, k, r, alt, z, d);
            } else {
                sm.step(op, k, r, z, alt, d);
            }
            in_alt = !in_alt;
        }
        let p = self.hierarchy.prolongation(l);
        {
            let cur: &mut [[f64; 3]] = if in_alt { alt } else { z };
            residual32(op, r, cur, res);
            let next = &mut coarser[0];
            let (mut rc, mut zc) = (std::mem::take(&mut next.r), std::mem::take(&mut next.z));
            p.restrict(res, &mut rc);
            self.cycle(l + 1, &rc, &mut zc, coarser);
            p.prolong_add(&zc, cur);
            (coarser[0].r, coarser[0].z) = (rc, zc);
        }
        for k in 0..degree {
            if in_alt {
                sm.step(op, k, r, alt, z, d);
            } else {
                sm.step(op, k, r, z, alt, d);
            }
            in_alt = !in_alt;
        }
        debug_assert!(!in_alt, "the V-cycle ends in z");
    }
}

/// Solves `a x = b` (three SPD channels) by CG preconditioned with one V-cycle of `mg` per
/// iteration, from the given `x` (a warm start; zeros for a cold one). Conventions as for
/// [`crate::sparse::pcg`]: per-channel scalars and stopping tests, a channel is declared
/// converged on its recomputed residual `‖b − Ax‖/‖b‖ ≤ tolerance`, `x` unchanged on error.
/// Uses `mg`'s workspace (no allocation); a cold start costs no product.
///
/// # Errors
/// [`SparseError::DimensionMismatch`] for sizes that do not match `mg`;
/// [`SparseError::NonFinite`] for non-finite `b` or `x`; [`SparseError::Breakdown`] if
/// `pᵀAp` or `rᵀBr` is not positive; [`SparseError::Cancelled`] when the monitor says so.
pub fn mg_pcg(
    a: &CsrMatrix3,
    b: &[[f64; 3]],
    x: &mut [[f64; 3]],
    mg: &Multigrid,
    options: &SolveOptions<'_>,
) -> Result<SolveStats, SparseError> {
    let n = mg.hierarchy.level(0).graph.n();
    for (what, len) in [("matrix rows", a.n()), ("right-hand side length", b.len()), ("initial guess length", x.len())] {
        if len != n {
            return Err(SparseError::DimensionMismatch { what, expected: n, found: len });
        }
    }
    options.validate()?;
    for (what, v) in [("right-hand side", &*b), ("initial guess", &*x)] {
        if let Some((row, channel, value)) = crate::sparse::ops::first_non_finite(v) {
            return Err(SparseError::NonFinite { what, row, channel, value });
        }
    }
    mg.with_workspace(|w| mg_pcg_in(a, b, x, mg, options, w))
}

fn mg_pcg_in(
    a: &CsrMatrix3,
    b: &[[f64; 3]],
    x: &mut [[f64; 3]],
    mg: &Multigrid,
    options: &SolveOptions<'_>,
    work: &mut Workspace,
) -> Result<SolveStats, SparseError> {
    let Workspace { levels, outer } = work;
    let Outer { x: xw, r, z, p, q } = outer;
    let tol = options.tolerance;
    let bn = norm3(b);
    xw.copy_from_slice(x);
    for c in 0..3 {
        if bn[c] == 0.0 {
            xw.par_iter_mut().for_each(|v| v[c] = 0.0);
        }
    }
    let rel = |rr: [f64; 3]| [0, 1, 2].map(|c| if bn[c] > 0.0 { rr[c].sqrt() / bn[c] } else { 0.0 });
    // `b − A·0` is `b` bit for bit (each row's product sums to +0).
    if xw.par_iter().all(|v| v.iter().all(|&t| t == 0.0)) {
        r.copy_from_slice(b);
    } else {
        residual(a, b, xw, r);
    }
    let mut relres = rel(dot3(r, r));
    let mut active = [0, 1, 2].map(|c| bn[c] > 0.0 && relres[c] > tol);
    let mut iterations = [0usize; 3];
    let mut it = 0;
    let mut restarts = 0;
    'outer: while active.iter().any(|&t| t) && it < options.max_iterations {
        mg.cycle(0, r, z, levels);
        let mut rz = dot3(r, z);
        p.copy_from_slice(z);
        while it < options.max_iterations {
            it += 1;
            for c in 0..3 {
                if active[c] && !(rz[c] > 0.0 && rz[c].is_finite()) {
                    return Err(SparseError::Breakdown {
                        method: "MG-PCG",
                        channel: c,
                        iteration: it,
                        reason: format!("rᵀBr = {:e}", rz[c]),
                    });
                }
            }
            let pq = spmv_dot(a, p, q);
            let mut alpha = [0.0; 3];
            for c in 0..3 {
                if active[c] {
                    if !(pq[c] > 0.0 && pq[c].is_finite()) {
                        return Err(SparseError::Breakdown {
                            method: "MG-PCG",
                            channel: c,
                            iteration: it,
                            reason: format!("pᵀAp = {:e}", pq[c]),
                        });
                    }
                    alpha[c] = rz[c] / pq[c];
                    iterations[c] += 1;
                }
            }
            relres = rel(update(xw, r, p, q, alpha));
            if let Some(m) = options.monitor {
                if !m(it, relres) {
                    return Err(SparseError::Cancelled { iteration: it });
                }
            }
            for c in 0..3 {
                if active[c] && relres[c] <= tol {
                    active[c] = false;
                }
            }
            if !active.iter().any(|&t| t) {
                break;
            }
            mg.cycle(0, r, z, levels);
            let rz_new = dot3(r, z);
            let beta = [0, 1, 2].map(|c| if active[c] { rz_new[c] / rz[c] } else { 0.0 });
            rz = rz_new;
            p.par_iter_mut().zip(&**z).with_min_len(ROWS).for_each(|(pi, zi)| {
                for c in 0..3 {
                    pi[c] = if active[c] { zi[c] + beta[c] * pi[c] } else { 0.0 };
                }
            });
        }
        // Confirm on the true residual; restart the channels that drifted.
        residual(a, b, xw, r);
        relres = rel(dot3(r, r));
        active = [0, 1, 2].map(|c| bn[c] > 0.0 && relres[c] > tol);
        if !active.iter().any(|&t| t) {
            break 'outer;
        }
        restarts += 1;
        if restarts > 3 {
            break;
        }
    }
    // `r` holds the true residual of `xw` here (the initial one, or the last confirmation).
    let relative_residual = relres;
    let converged_channels = [0, 1, 2].map(|c| bn[c] == 0.0 || relative_residual[c] <= tol);
    x.copy_from_slice(xw);
    Ok(SolveStats { iterations, relative_residual, converged_channels, converged: converged_channels.iter().all(|&t| t) })
}

#[cfg(test)]
mod tests {
    use glam::DVec3;
    use nalgebra::{DMatrix, DVector};

    use super::*;
    use crate::sparse::hierarchy::HierarchyOptions;
    use crate::sparse::Triplet;

    /// A reproducible value in [0, 1) from an integer.
    fn hash01(k: u64) -> f64 {
        let mut x = k.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03;
        x ^= x >> 31;
        x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x ^= x >> 29;
        (x >> 11) as f64 / (1u64 << 53) as f64
    }

    fn random_vector(n: usize, seed: u64) -> Vec<[f64; 3]> {
        (0..n).map(|i| [0, 1, 2].map(|c| hash01(seed * 1_000_003 + 3 * i as u64 + c) - 0.5)).collect()
    }

    /// A jittered `nx × ny × nz` grid with its 6 axis neighbours and one diagonal per cell (as a
    /// tetrahedral mesh's graph has), and an SPD diffusion-like matrix on it: per channel
    /// `A_ij = −κ_c w_ij`, `A_ii = Σ_j κ_c w_ij + σ_c`, edge weights `w_ij` in [0.5, 1.5).
    fn grid_system(nx: usize, ny: usize, nz: usize) -> (Hierarchy, CsrMatrix3) {
        let id = |x: usize, y: usize, z: usize| (x + nx * (y + ny * z)) as u32;
        let mut positions = Vec::new();
        let mut edges = Vec::new();
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    let i = u64::from(id(x, y, z));
                    let j = [0, 1, 2].map(|c| 0.3 * (hash01(7 * i + c) - 0.5));
                    positions.push(DVec3::new(x as f64 + j[0], y as f64 + j[1], z as f64 + j[2]));
                    if x + 1 < nx {
                        edges.push([id(x, y, z), id(x + 1, y, z)]);
                    }
                    if y + 1 < ny {
                        edges.push([id(x, y, z), id(x, y + 1, z)]);
                    }
                    if z + 1 < nz {
                        edges.push([id(x, y, z), id(x, y, z + 1)]);
                    }
                    if x + 1 < nx && y + 1 < ny && z + 1 < nz {
                        edges.push([id(x, y, z), id(x + 1, y + 1, z + 1)]);
                    }
                }
            }
        }
        let n = nx * ny * nz;
        let graph = Arc::new(CsrPattern::from_edges(n, &edges).unwrap());
        let (kappa, sigma) = ([1.0, 0.4, 0.1], [0.02, 0.05, 0.2]);
        let mut trips = Vec::new();
        for (e, &[i, j]) in edges.iter().enumerate() {
            let w = 0.5 + hash01(1_000_000 + e as u64);
            let v = kappa.map(|k| -k * w);
            trips.push(Triplet::new(i, j, v));
            trips.push(Triplet::new(j, i, v));
            trips.push(Triplet::new(i, i, v.map(|t| -t)));
            trips.push(Triplet::new(j, j, v.map(|t| -t)));
        }
        for i in 0..n as u32 {
            trips.push(Triplet::new(i, i, sigma));
        }
        let a = CsrMatrix3::from_triplets_with_pattern(Arc::clone(&graph), &trips).unwrap();
        let h = Hierarchy::build(&graph, &positions, &HierarchyOptions::default().with_min_vertices(150)).unwrap();
        (h, a)
    }

    fn system() -> &'static (Arc<Hierarchy>, CsrMatrix3) {
        static CELL: std::sync::OnceLock<(Arc<Hierarchy>, CsrMatrix3)> = std::sync::OnceLock::new();
        CELL.get_or_init(|| {
            let (h, a) = grid_system(15, 14, 13);
            assert!(h.levels() >= 3, "{:?}", h.vertex_counts());
            (Arc::new(h), a)
        })
    }

    fn with_degree(degree: usize) -> MultigridOptions {
        MultigridOptions { smoothing_degree: degree, ..MultigridOptions::default() }
    }

    fn vcycle(mg: &Multigrid, a: &CsrMatrix3, r: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let mut z = vec![[0.0; 3]; r.len()];
        mg.vcycle(a, r, &mut z).unwrap();
        z
    }

    /// The V-cycle written plainly: f64 operators, Chebyshev steps with full residuals, fresh
    /// vectors, nalgebra's Cholesky solve at the coarsest.
    fn reference_cycle(mg: &Multigrid, l: usize, a: &CsrMatrix3, r: &[[f64; 3]]) -> Vec<[f64; 3]> {
        let n = r.len();
        if l + 1 == mg.hierarchy.levels() {
            let mut z = vec![[0.0; 3]; n];
            for c in 0..3 {
                let f = Cholesky::new(a.to_dense(c)).unwrap();
                let x = f.solve(&DVector::from_iterator(n, r.iter().map(|v| v[c])));
                for (zi, xi) in z.iter_mut().zip(x.iter()) {
                    zi[c] = *xi;
                }
            }
            return z;
        }
        let sm = &mg.smoothers[l];
        let smooth = |z: &mut Vec<[f64; 3]>, from_zero: bool| {
            let mut d = vec![[0.0; 3]; n];
            for (k, st) in sm.steps.iter().enumerate() {
                let res: Vec<[f64; 3]> = if k == 0 && from_zero {
                    r.to_vec()
                } else {
                    let az = a.mul_vec(z).unwrap();
                    (0..n).map(|i| [0, 1, 2].map(|c| r[i][c] - az[i][c])).collect()
                };
                for i in 0..n {
                    for c in 0..3 {
                        d[i][c] = st.keep[c] * d[i][c] + st.gain[c] * res[i][c] * sm.inv_diag[i][c];
                        z[i][c] += d[i][c];
                    }
                }
            }
        };
        let mut z = vec![[0.0; 3]; n];
        smooth(&mut z, true);
        let az = a.mul_vec(&z).unwrap();
        let res: Vec<[f64; 3]> = (0..n).map(|i| [0, 1, 2].map(|c| r[i][c] - az[i][c])).collect();
        let p = mg.hierarchy.prolongation(l);
        let mut rc = vec![[0.0; 3]; p.n_coarse()];
        p.restrict(&res, &mut rc);
        let zc = reference_cycle(mg, l + 1, mg.operator(l + 1), &rc);
        p.prolong_add(&zc, &mut z);
        smooth(&mut z, false);
        z
    }

    fn rel_diff(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
        let num: f64 = a.iter().zip(b).map(|(x, y)| (0..3).map(|c| (x[c] - y[c]).powi(2)).sum::<f64>()).sum();
        let den: f64 = b.iter().map(|y| (0..3).map(|c| y[c] * y[c]).sum::<f64>()).sum();
        (num / den).sqrt()
    }

    #[test]
    fn fused_f32_vcycle_equals_the_plain_f64_vcycle() {
        let (h, a) = system();
        for degree in [1, 2, 3] {
            let mg = Multigrid::new(Arc::clone(h), a, with_degree(degree)).unwrap();
            for seed in 0..2 {
                let r = random_vector(a.n(), seed);
                let z = vcycle(&mg, a, &r);
                let e = rel_diff(&z, &reference_cycle(&mg, 0, a, &r));
                // Only the f32 rounding of the operators separates the two.
                assert!(e < 1e-5, "degree {degree}: {e:e}");
                // Not the identity or a scaled copy of r: the cycle did something.
                assert!(rel_diff(&z, &r) > 1e-2);
            }
        }
    }

    #[test]
    fn vcycle_is_symmetric_positive_definite_and_contracts() {
        let (h, a) = system();
        for degree in [1, 2] {
            let mg = Multigrid::new(Arc::clone(h), a, with_degree(degree)).unwrap();
            for seed in 0..4 {
                let (u, v) = (random_vector(a.n(), 10 + seed), random_vector(a.n(), 20 + seed));
                let (bu, bv) = (vcycle(&mg, a, &u), vcycle(&mg, a, &v));
                let (ubv, vbu, ubu) = (dot3(&u, &bv), dot3(&v, &bu), dot3(&u, &bu));
                let scale = (dot3(&u, &u)[0] * dot3(&bv, &bv)[0]).sqrt();
                for c in 0..3 {
                    // B is exactly symmetric as a map of the rounded operators: only the
                    // rounding of the f64 arithmetic remains.
                    assert!((ubv[c] - vbu[c]).abs() <= 1e-10 * scale, "degree {degree} channel {c}: {} vs {}", ubv[c], vbu[c]);
                    assert!(ubu[c] > 0.0, "degree {degree} channel {c}: uᵀBu = {}", ubu[c]);
                }
                // The two-level error propagator I − BA contracts in the A-norm (multigrid
                // convergence): ‖(I − BA) x‖_A ≤ 0.5 ‖x‖_A.
                let ax = a.mul_vec(&u).unwrap();
                let bax = vcycle(&mg, a, &ax);
                let e: Vec<[f64; 3]> = u.iter().zip(&bax).map(|(x, y)| [0, 1, 2].map(|c| x[c] - y[c])).collect();
                let (ee, xx) = (dot3(&e, &a.mul_vec(&e).unwrap()), dot3(&u, &ax));
                for c in 0..3 {
                    assert!(
                        ee[c].sqrt() <= 0.5 * xx[c].sqrt(),
                        "degree {degree} channel {c}: {} of {}",
                        ee[c].sqrt(),
                        xx[c].sqrt()
                    );
                }
            }
        }
    }

    #[test]
    fn coarse_factor_solves_like_nalgebra() {
        let (_, a) = system();
        let m = 40;
        let dense: [DMatrix<f64>; 3] = [0, 1, 2].map(|c| {
            let d = a.to_dense(c);
            d.view((0, 0), (m, m)).into_owned()
        });
        let factors = dense.clone().map(|d| Cholesky::new(d).unwrap());
        let f = CoarseFactor::new(&factors);
        let r = random_vector(m, 3);
        let mut x = r.clone();
        f.solve_in_place(&mut x);
        for c in 0..3 {
            let ax = &dense[c] * DVector::from_iterator(m, x.iter().map(|v| v[c]));
            for i in 0..m {
                assert!((ax[i] - r[i][c]).abs() < 1e-12, "channel {c} row {i}: {} vs {}", ax[i], r[i][c]);
            }
        }
    }

    #[test]
    fn mg_pcg_solves_and_is_reproducible_across_threads_clones_and_reuse() {
        let (h, a) = system();
        let mg = Multigrid::new(Arc::clone(h), a, MultigridOptions::default()).unwrap();
        let b = random_vector(a.n(), 7);
        let solve = |mg: &Multigrid| {
            let mut x = vec![[0.0; 3]; a.n()];
            let s = mg_pcg(a, &b, &mut x, mg, &SolveOptions::default().with_tolerance(1e-10)).unwrap();
            (x, s)
        };
        let (x, stats) = solve(&mg);
        assert!(stats.converged, "{stats:?}");
        assert!(stats.iterations.iter().all(|&k| k <= 20), "{stats:?}");
        let ax = a.mul_vec(&x).unwrap();
        assert!(rel_diff(&ax, &b) <= 1e-10 * 1.01);
        assert_eq!(stats.relative_residual, {
            let mut r = vec![[0.0; 3]; a.n()];
            residual(a, &b, &x, &mut r);
            let (rr, bb) = (dot3(&r, &r), dot3(&b, &b));
            [0, 1, 2].map(|c| rr[c].sqrt() / bb[c].sqrt())
        });
        // Bit-identical: again (reused workspace), on a clone (fresh workspace), on one and on
        // two threads, and from two threads sharing the multigrid at once.
        assert_eq!(solve(&mg).0, x);
        assert_eq!(solve(&mg.clone()).0, x);
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            assert_eq!(pool.install(|| solve(&mg)).0, x);
        }
        let (x1, x2) = std::thread::scope(|s| {
            let t = s.spawn(|| solve(&mg).0);
            (solve(&mg).0, t.join().unwrap())
        });
        assert_eq!((x1, x2), (x.clone(), x.clone()));
        // A warm start from the solution stops at once; a wrong size is an error.
        let mut xw = x.clone();
        let s = mg_pcg(a, &b, &mut xw, &mg, &SolveOptions::default().with_tolerance(1e-10)).unwrap();
        assert_eq!((s.iterations, xw), ([0; 3], x));
        let mut short = vec![[0.0; 3]; 3];
        assert!(matches!(mg.vcycle(a, &b, &mut short), Err(SparseError::DimensionMismatch { .. })));
    }
    #[test]
    fn a_refresh_after_a_local_change_equals_a_fresh_build() {
        let (h, a) = system();
        let mg = Multigrid::new(Arc::clone(h), a, MultigridOptions::default()).unwrap();
        // A local change: 40 rows get 30 more absorption and 3× their couplings among
        // themselves (symmetric, still diagonally dominant, so SPD).
        let rows: Vec<u32> = (1000..1040).collect();
        let inside = |v: usize| (1000..1040).contains(&v);
        let mut changed = a.clone();
        let p = Arc::clone(a.pattern());
        for &i in &rows {
            let i = i as usize;
            for k in p.row_ptr()[i]..p.row_ptr()[i + 1] {
                let j = p.col_idx()[k] as usize;
                let v = &mut changed.values_mut()[k];
                if j == i {
                    *v = v.map(|t| t + 30.0);
                } else if inside(j) {
                    *v = v.map(|t| 3.0 * t);
                }
            }
        }
        let mut refreshed = mg.clone();
        refreshed.refresh(&changed, &rows).unwrap();
        let fresh = Multigrid::new(Arc::clone(h), &changed, MultigridOptions::default()).unwrap();
        let same = |x: &Multigrid, y: &Multigrid| {
            for l in 0..h.levels() {
                if l > 0 {
                    assert_eq!(x.operator(l).values(), y.operator(l).values(), "operator {l}");
                }
                if l + 1 < h.levels() {
                    assert_eq!(x.ops32[l].values, y.ops32[l].values, "f32 operator {l}");
                    assert_eq!(x.smoothers[l].inv_diag, y.smoothers[l].inv_diag, "smoother {l}");
                    assert_eq!(x.smoothers[l].lambda_max, y.smoothers[l].lambda_max, "λmax {l}");
                }
            }
            assert_eq!(x.coarsest.as_ref().unwrap().l, y.coarsest.as_ref().unwrap().l);
        };
        same(&refreshed, &fresh);
        // The change did reach the coarse levels (so the comparison above tested them).
        assert_ne!(mg.operator(1).values(), fresh.operator(1).values());
        // Refreshing back on the same rows restores the original bit for bit.
        let mut back = refreshed.clone();
        back.refresh(a, &rows).unwrap();
        same(&back, &mg);
        // Bad input leaves it unchanged.
        let mut bad_diag = changed.clone();
        let d = bad_diag.pattern().diagonal_positions()[1010];
        bad_diag.values_mut()[d][1] = -1.0;
        for result in [
            refreshed.refresh(&changed, &[a.n() as u32]),
            refreshed.refresh(&bad_diag, &rows),
            refreshed.refresh(&grid_system(6, 5, 4).1, &[0]),
        ] {
            assert!(result.is_err());
        }
        same(&refreshed, &fresh);
    }
    #[test]
    fn smoother_bound_lies_above_the_spectrum_and_close_to_it() {
        let (h, a) = grid_system(9, 8, 7);
        let mg = Multigrid::new(Arc::new(h), &a, MultigridOptions::default()).unwrap();
        for l in 0..mg.hierarchy.levels() - 1 {
            let (op, sm) = (&mg.ops32[l], &mg.smoothers[l]);
            let n = sm.inv_diag.len();
            for c in 0..3 {
                // D^-½ Ã D^-½ has the spectrum of D⁻¹Ã.
                let mut m = DMatrix::<f64>::zeros(n, n);
                for i in 0..n {
                    for k in op.pattern.row_ptr()[i]..op.pattern.row_ptr()[i + 1] {
                        let j = op.pattern.col_idx()[k] as usize;
                        m[(i, j)] = f64::from(op.values[k][c]) * (sm.inv_diag[i][c] * sm.inv_diag[j][c]).sqrt();
                    }
                }
                let top = m.symmetric_eigenvalues().max();
                let bound = sm.lambda_max[c];
                assert!(bound >= top && bound <= 1.6 * top, "level {l} channel {c}: bound {bound}, λmax {top}");
            }
        }
    }
}
