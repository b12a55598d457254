//! Preconditioners for the three-channel Krylov solvers.
//!
//! * [`Jacobi`]: diagonal scaling, `M = D`. In mixed precision (the default) PCG runs plain CG
//!   on the scaled matrix `Â = S A S`, `S = D^-½` (unit diagonal, equivalent to Jacobi-PCG in
//!   exact arithmetic), so the preconditioner costs nothing inside the iteration; in `f64`
//!   (`Precision::Double`) `z = D⁻¹ r` is fused into the vector update.
//! * [`Chebyshev`]: a Chebyshev polynomial over Jacobi, `z = S p(Â) S r`, with `p` of degree
//!   `degree`: `degree` extra matrix–vector products per application (with `f32` values), each
//!   fused with its vector updates into one parallel pass. The interval is
//!   `[λmax/RATIO, λmax]`, `λmax` a Gershgorin bound of `Â`, so that `p > 0` on the whole
//!   spectrum and the preconditioner is SPD. Fully parallel.
//! * [`Ssor`]: symmetric SOR in a level-set ordering whose parts are swept in parallel, applied
//!   with Eisenstat's trick (modules `ssor` and `eisenstat_cg`).
//!
//! Jacobi and Chebyshev keep the scaled operator `Â` in `f32` (16 bytes per nonzero with its
//! column index), built in one parallel pass. Which to use is discussed in the [module
//! documentation](super); in short, Jacobi: each Chebyshev degree cuts the iterations about as
//! much as it adds matrix passes, and the iteration is bound by memory traffic.

use rayon::prelude::*;

use super::csr::CsrMatrix3;
use super::error::SparseError;
use super::ops::{row_mul, sum_partials, CHUNK};
use super::scaled::ScaledOperator;
use super::ssor::Ssor;

/// Which preconditioner to build (a plain, copyable choice for options, the CLI and the C ABI).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum PreconditionerKind {
    /// No preconditioning (`z = r`).
    Identity,
    /// Diagonal scaling. The default (the module documentation says why).
    #[default]
    Jacobi,
    /// A Chebyshev polynomial of degree `degree` (≥ 1) over Jacobi: `degree` extra
    /// matrix–vector products per iteration.
    Chebyshev {
        /// Polynomial degree, 1 to [`Chebyshev::MAX_DEGREE`].
        degree: usize,
    },
    /// Symmetric successive over-relaxation ([`Ssor`], ω = [`Ssor::DEFAULT_OMEGA`]) in a
    /// level-set ordering swept in parallel, applied with Eisenstat's trick: far fewer
    /// iterations than Jacobi, each costing about two of Jacobi's, after a longer setup (see
    /// [`Ssor`]). With [`crate::sparse::Precision::Double`] it is applied as `z = M⁻¹ r` (two
    /// sweeps) in plain PCG.
    Ssor,
}

/// Diagonal (Jacobi) preconditioner: the inverse diagonal, per channel.
#[derive(Debug, Clone, PartialEq)]
pub struct Jacobi {
    inv_diag: Vec<[f64; 3]>,
    op: ScaledOperator,
}

/// The diagonal entry of row `row` of `a`, checked positive and finite on every channel.
///
/// # Errors
/// [`SparseError::NonPositiveDiagonal`] naming the first bad channel.
pub(crate) fn positive_diagonal(a: &CsrMatrix3, row: usize) -> Result<[f64; 3], SparseError> {
    let v = a.values()[a.pattern().diagonal_positions()[row]];
    match (0..3).find(|&c| !(v[c] > 0.0 && v[c].is_finite())) {
        Some(channel) => Err(SparseError::NonPositiveDiagonal { row, channel, value: v[channel] }),
        None => Ok(v),
    }
}

/// `1 / a_ii` per row and channel; the error names the first row whose diagonal is not positive
/// ([`positive_diagonal`]).
pub(crate) fn inverse_diagonal(a: &CsrMatrix3) -> Result<Vec<[f64; 3]>, SparseError> {
    if let Some(row) = (0..a.n()).into_par_iter().position_first(|i| positive_diagonal(a, i).is_err()) {
        positive_diagonal(a, row)?;
    }
    let vals = a.values();
    Ok(a.pattern().diagonal_positions().par_iter().map(|&k| vals[k].map(|x| 1.0 / x)).collect())
}

impl Jacobi {
    /// Inverts the diagonal of `a` and builds the scaled operator `S A S` in `f32`
    /// (`S = D^-½`) that the mixed-precision PCG iterates on.
    ///
    /// # Errors
    /// [`SparseError::NonPositiveDiagonal`] naming the first row and channel whose diagonal is
    /// not positive and finite (an SPD matrix has a positive diagonal).
    pub fn new(a: &CsrMatrix3) -> Result<Self, SparseError> {
        let inv_diag = inverse_diagonal(a)?;
        let op = ScaledOperator::from_inverse_diagonal(a, &inv_diag);
        Ok(Self { inv_diag, op })
    }

    /// The inverse diagonal.
    #[must_use]
    pub fn inv_diag(&self) -> &[[f64; 3]] {
        &self.inv_diag
    }

    pub(crate) fn operator(&self) -> &ScaledOperator {
        &self.op
    }
}

/// Chebyshev polynomial preconditioner over Jacobi (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct Chebyshev {
    op: ScaledOperator,
    degree: usize,
    lambda_max: [f64; 3],
    lambda_min: [f64; 3],
}

/// Scratch vectors for one application of a preconditioner.
#[derive(Debug, Default)]
pub(crate) struct PrecondWork {
    d0: Vec<[f64; 3]>,
    d1: Vec<[f64; 3]>,
    res: Vec<[f64; 3]>,
}

impl PrecondWork {
    fn ensure(&mut self, n: usize) {
        for v in [&mut self.d0, &mut self.d1, &mut self.res] {
            if v.len() != n {
                *v = vec![[0.0; 3]; n];
            }
        }
    }
}

impl Chebyshev {
    /// The largest supported degree.
    pub const MAX_DEGREE: usize = 16;
    /// The interval is `[λmax / RATIO, λmax]`, chosen on iteration counts: a narrower one
    /// leaves the low end of the spectrum undamped, a much wider one spreads the polynomial's
    /// damping too thin.
    pub const RATIO: f64 = 60.0;

    /// Builds the preconditioner for `a`: the scaled operator `S A S` in `f32` (`S = D^-½`) and a
    /// Gershgorin bound of its spectrum.
    ///
    /// # Errors
    /// [`SparseError::NonPositiveDiagonal`] as for [`Jacobi::new`];
    /// [`SparseError::InvalidOption`] if `degree` is 0 or above [`Self::MAX_DEGREE`].
    pub fn new(a: &CsrMatrix3, degree: usize) -> Result<Self, SparseError> {
        if degree == 0 || degree > Self::MAX_DEGREE {
            return Err(SparseError::InvalidOption(format!("Chebyshev degree {degree}: must be 1 to {}", Self::MAX_DEGREE)));
        }
        let op = ScaledOperator::new(a)?;
        let lambda_max = op.lambda_max;
        let lambda_min = lambda_max.map(|l| l / Self::RATIO);
        Ok(Self { op, degree, lambda_max, lambda_min })
    }

    /// The polynomial degree (extra matrix–vector products per application).
    #[must_use]
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// The interval `[λmin, λmax]` of `D⁻¹A` the polynomial is built for, per channel.
    #[must_use]
    pub fn interval(&self) -> [[f64; 2]; 3] {
        [0, 1, 2].map(|c| [self.lambda_min[c], self.lambda_max[c]])
    }

    pub(crate) fn operator(&self) -> &ScaledOperator {
        &self.op
    }

    /// `ẑ = p(Â) r̂` on the scaled system; with `scale = Some(S)`, in unscaled terms
    /// `z = S p(Â) S r`. Returns `r·z` per channel (deterministic).
    pub(crate) fn apply_scaled(
        &self,
        r: &[[f64; 3]],
        z: &mut [[f64; 3]],
        scale: Option<&[[f64; 3]]>,
        w: &mut PrecondWork,
    ) -> [f64; 3] {
        let n = r.len();
        w.ensure(n);
        let theta: [f64; 3] = std::array::from_fn(|c| 0.5 * (self.lambda_max[c] + self.lambda_min[c]));
        let delta: [f64; 3] = std::array::from_fn(|c| 0.5 * (self.lambda_max[c] - self.lambda_min[c]));
        let sigma: [f64; 3] = std::array::from_fn(|c| theta[c] / delta[c]);
        let mut rho: [f64; 3] = std::array::from_fn(|c| 1.0 / sigma[c]);
        let inv_theta = theta.map(|t| 1.0 / t);
        let sc = |i: usize| scale.map_or([1.0; 3], |s| s[i]);
        // Step 1: d0 = r̂ / θ (ẑ = d0, implicit).
        w.d0.par_chunks_mut(CHUNK).enumerate().for_each(|(k, d)| {
            let r0 = k * CHUNK;
            for (li, d) in d.iter_mut().enumerate() {
                let (ri, si) = (r[r0 + li], sc(r0 + li));
                *d = [0, 1, 2].map(|c| si[c] * ri[c] * inv_theta[c]);
            }
        });
        let p = &*self.op.pattern;
        let vals = &self.op.values;
        for step in 2..=self.degree + 1 {
            let first = step == 2;
            let last = step == self.degree + 1;
            let mut c1 = [0.0; 3];
            let mut c2 = [0.0; 3];
            for c in 0..3 {
                let rn = 1.0 / (2.0 * sigma[c] - rho[c]);
                c1[c] = rn * rho[c];
                c2[c] = 2.0 * rn / delta[c];
                rho[c] = rn;
            }
            let (d_old, d_new) = (&w.d0, &mut w.d1);
            let res = &mut w.res;
            let parts: Vec<[f64; 3]> = (d_new.par_chunks_mut(CHUNK), res.par_chunks_mut(CHUNK), z.par_chunks_mut(CHUNK))
                .into_par_iter()
                .enumerate()
                .map(|(ci, (dn, rs, zc))| {
                    let r0 = ci * CHUNK;
                    let mut dot = [0.0; 3];
                    for li in 0..dn.len() {
                        let i = r0 + li;
                        let (s, e) = (p.row_ptr()[i], p.row_ptr()[i + 1]);
                        let ad = row_mul(&p.col_idx()[s..e], &vals[s..e], d_old);
                        let si = sc(i);
                        let res_in = if first { [0, 1, 2].map(|c| si[c] * r[i][c]) } else { rs[li] };
                        let dold = d_old[i];
                        let mut zi = if first { dold } else { zc[li] };
                        let mut resi = [0.0; 3];
                        let mut dni = [0.0; 3];
                        for c in 0..3 {
                            resi[c] = res_in[c] - ad[c];
                            dni[c] = c1[c] * dold[c] + c2[c] * resi[c];
                            zi[c] += dni[c];
                        }
                        if last {
                            let ri = r[i];
                            for c in 0..3 {
                                zi[c] *= si[c];
                                dot[c] += ri[c] * zi[c];
                            }
                        } else {
                            rs[li] = resi;
                            dn[li] = dni;
                        }
                        zc[li] = zi;
                    }
                    dot
                })
                .collect();
            if last {
                return sum_partials(&parts);
            }
            std::mem::swap(&mut w.d0, &mut w.d1);
        }
        unreachable!("degree ≥ 1 always reaches the last step")
    }
}

/// A built preconditioner for three-channel systems.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Preconditioner {
    /// No preconditioning.
    Identity,
    /// Diagonal scaling.
    Jacobi(Jacobi),
    /// Chebyshev polynomial over Jacobi.
    Chebyshev(Chebyshev),
    /// SSOR with Eisenstat's trick.
    Ssor(Ssor),
}

impl Preconditioner {
    /// Builds the preconditioner of the given kind for `a`.
    ///
    /// # Errors
    /// [`SparseError::NonPositiveDiagonal`] (Jacobi, Chebyshev) if a diagonal entry is not
    /// positive; [`SparseError::InvalidOption`] for a bad Chebyshev degree.
    pub fn new(a: &CsrMatrix3, kind: PreconditionerKind) -> Result<Self, SparseError> {
        Ok(match kind {
            PreconditionerKind::Identity => Self::Identity,
            PreconditionerKind::Jacobi => Self::Jacobi(Jacobi::new(a)?),
            PreconditionerKind::Chebyshev { degree } => Self::Chebyshev(Chebyshev::new(a, degree)?),
            PreconditionerKind::Ssor => Self::Ssor(Ssor::new(a)?),
        })
    }

    /// The kind this preconditioner was built as.
    #[must_use]
    pub fn kind(&self) -> PreconditionerKind {
        match self {
            Self::Identity => PreconditionerKind::Identity,
            Self::Jacobi(_) => PreconditionerKind::Jacobi,
            Self::Chebyshev(c) => PreconditionerKind::Chebyshev { degree: c.degree },
            Self::Ssor(_) => PreconditionerKind::Ssor,
        }
    }

    /// The dimension it was built for (`None` for the identity, which fits any).
    #[must_use]
    pub fn n(&self) -> Option<usize> {
        match self {
            Self::Identity => None,
            Self::Jacobi(j) => Some(j.inv_diag.len()),
            Self::Chebyshev(c) => Some(c.op.s.len()),
            Self::Ssor(s) => Some(s.n()),
        }
    }

    pub(crate) fn check_dimension(&self, n: usize) -> Result<(), SparseError> {
        match self.n() {
            Some(m) if m != n => {
                Err(SparseError::DimensionMismatch { what: "preconditioner dimension (matrix rows)", expected: n, found: m })
            }
            _ => Ok(()),
        }
    }

    /// Checks that the preconditioner was built on `a`'s pattern (cheap when they share the
    /// `Arc`, one comparison pass otherwise).
    pub(crate) fn check_matrix(&self, a: &CsrMatrix3) -> Result<(), SparseError> {
        self.check_dimension(a.n())?;
        let own = match self {
            Self::Identity => return Ok(()),
            Self::Jacobi(j) => &j.op.pattern,
            Self::Chebyshev(c) => &c.op.pattern,
            Self::Ssor(s) => s.pattern(),
        };
        if std::sync::Arc::ptr_eq(own, a.pattern()) || **own == **a.pattern() {
            Ok(())
        } else {
            Err(SparseError::PatternMismatch("the preconditioner was built for another matrix".into()))
        }
    }

    /// `z = M⁻¹ r`.
    ///
    /// # Errors
    /// [`SparseError::DimensionMismatch`] if `r`, `z` and the preconditioner differ in size.
    pub fn apply(&self, r: &[[f64; 3]], z: &mut [[f64; 3]]) -> Result<(), SparseError> {
        self.check_dimension(r.len())?;
        if z.len() != r.len() {
            return Err(SparseError::DimensionMismatch { what: "z length", expected: r.len(), found: z.len() });
        }
        self.apply_dot(r, z, &mut PrecondWork::default());
        Ok(())
    }

    /// `z = M⁻¹ r`, returning `r·z` (lengths checked by the caller).
    pub(crate) fn apply_dot(&self, r: &[[f64; 3]], z: &mut [[f64; 3]], w: &mut PrecondWork) -> [f64; 3] {
        match self {
            Self::Identity => {
                z.copy_from_slice(r);
                super::ops::dot3(r, r)
            }
            Self::Jacobi(j) => {
                let parts: Vec<[f64; 3]> = (z.par_chunks_mut(CHUNK), r.par_chunks(CHUNK), j.inv_diag.par_chunks(CHUNK))
                    .into_par_iter()
                    .map(|(z, r, d)| {
                        let mut s = [0.0; 3];
                        for ((z, r), d) in z.iter_mut().zip(r).zip(d) {
                            for c in 0..3 {
                                z[c] = d[c] * r[c];
                                s[c] += r[c] * z[c];
                            }
                        }
                        s
                    })
                    .collect();
                sum_partials(&parts)
            }
            Self::Chebyshev(c) => c.apply_scaled(r, z, Some(&c.op.s), w),
            Self::Ssor(s) => s.apply_dot(r, z),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sparse::csr::Triplet;

    fn path_laplacian(n: usize) -> CsrMatrix3 {
        let mut t = Vec::new();
        for i in 0..n {
            t.push(Triplet::new(i as u32, i as u32, [2.1, 2.5, 3.0]));
            if i + 1 < n {
                t.push(Triplet::new(i as u32, i as u32 + 1, [-1.0; 3]));
                t.push(Triplet::new(i as u32 + 1, i as u32, [-1.0; 3]));
            }
        }
        CsrMatrix3::from_triplets(n, &t).unwrap()
    }

    #[test]
    fn chebyshev_is_symmetric_positive_and_bounds_hold() {
        let a = path_laplacian(50);
        let c = Chebyshev::new(&a, 3).unwrap();
        for [lo, hi] in c.interval() {
            assert!(lo > 0.0 && hi >= lo && hi <= 2.0);
        }
        let pc = Preconditioner::Chebyshev(c.clone());
        // Columns of M⁻¹ via unit vectors: symmetric and positive definite.
        let n = a.n();
        let mut m = vec![vec![[0.0; 3]; n]; n];
        for (j, col) in m.iter_mut().enumerate() {
            let mut e = vec![[0.0; 3]; n];
            e[j] = [1.0; 3];
            pc.apply(&e, col).unwrap();
        }
        for ch in [0, 1, 2] {
            let dm = nalgebra::DMatrix::from_fn(n, n, |i, j| m[j][i][ch]);
            assert!((&dm - dm.transpose()).abs().max() < 1e-6 * dm.abs().max());
            let sym = (&dm + dm.transpose()) * 0.5;
            assert!(sym.symmetric_eigenvalues().min() > 0.0);
        }
        // The f32 copy of the matrix applies like the f64 one, to f32 accuracy.
        let x: Vec<[f64; 3]> = (0..n).map(|i| [i as f64, 1.0, -0.5 * i as f64]).collect();
        let mut y = vec![[0.0; 3]; n];
        let s = &c.op.s;
        let xs: Vec<[f64; 3]> = x.iter().zip(s).map(|(x, s)| [0, 1, 2].map(|k| x[k] / s[k])).collect();
        crate::sparse::csr::spmv3(&c.op.pattern, &c.op.values, &xs, &mut y);
        for (y, s) in y.iter_mut().zip(s) {
            for k in 0..3 {
                y[k] /= s[k];
            }
        }
        let y64 = a.mul_vec(&x).unwrap();
        for (u, v) in y.iter().zip(&y64) {
            for ch in 0..3 {
                assert!((u[ch] - v[ch]).abs() <= 1e-6 * (1.0 + v[ch].abs()));
            }
        }
    }

    #[test]
    fn bad_diagonal_and_degree_are_errors() {
        let mut a = path_laplacian(5);
        let k = a.pattern().diagonal_positions()[3];
        a.values_mut()[k][2] = -1.0;
        let e = Jacobi::new(&a).unwrap_err();
        assert!(matches!(e, SparseError::NonPositiveDiagonal { row: 3, channel: 2, .. }), "{e}");
        assert!(matches!(Chebyshev::new(&path_laplacian(5), 0), Err(SparseError::InvalidOption(_))));
    }
}
