//! Krylov solves of operators given only by their action: y = A x on three colour channels,
//! where A is no stored matrix (translucent radiosity's I − S F, whose S is a diffusion solve).
//!
//! [`bicgstab_operator`] is van der Vorst's BiCGSTAB (1992, Algorithm "BiCGSTAB"), per channel
//! with its own scalars, unpreconditioned (the operators here are I minus a contraction, already
//! well conditioned), stopped by a norm the caller chooses, so that the stopping rule can be a
//! bound on the error in that norm.

/// A linear operator on vectors of `[f64; 3]` (one entry per unknown, three channels that do
/// not mix), applied by a computation that may fail.
pub trait LinearOperator {
    /// Why an application failed.
    type Error;

    /// The number of unknowns.
    fn len(&self) -> usize;

    /// Whether there are no unknowns.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// y = A x.
    ///
    /// # Errors
    /// The operator's own.
    fn apply(&mut self, x: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, Self::Error>;
}

/// How [`bicgstab_operator`] ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OperatorSolve {
    /// Iterations (each applies the operator twice).
    pub iterations: usize,
    /// Applications of the operator, the one for the initial residual included.
    pub applications: usize,
    /// ‖b − A x‖ / ‖b‖ per channel in the caller's norm, of the residual the iteration carries
    /// (0 for a zero right-hand side).
    pub relative_residual: [f64; 3],
    /// Whether every channel reached the tolerance (else the iterations ran out or the method
    /// broke down, and `x` is the best iterate it had).
    pub converged: bool,
}

/// Solves A x = b from the initial `x` by BiCGSTAB until `norm(r)[c] ≤ tolerance · norm(b)[c]`
/// in every channel (`norm` gives one value per channel, e.g. an area-weighted L1 norm), at
/// most `max_iterations`; `keep_going` is asked before each iteration (an `Err` stops it).
///
/// A channel whose r̂ᵀr, r̂ᵀv or ω vanishes stops where it is (reported by `converged`); a
/// channel of zero right-hand side returns zero.
///
/// # Errors
/// The operator's error, or `keep_going`'s; `x` is then the last iterate.
pub fn bicgstab_operator<O: LinearOperator>(
    op: &mut O,
    b: &[[f64; 3]],
    x: &mut [[f64; 3]],
    tolerance: f64,
    max_iterations: usize,
    norm: &dyn Fn(&[[f64; 3]]) -> [f64; 3],
    keep_going: &mut dyn FnMut() -> Result<(), O::Error>,
) -> Result<OperatorSolve, O::Error> {
    let n = op.len();
    assert!(b.len() == n && x.len() == n, "bicgstab_operator: b and x must have the operator's {n} entries");
    let bn = norm(b);
    for (xi, _) in x.iter_mut().zip(b) {
        for c in 0..3 {
            if bn[c] == 0.0 {
                xi[c] = 0.0;
            }
        }
    }
    let dot = |u: &[[f64; 3]], v: &[[f64; 3]]| -> [f64; 3] {
        let mut s = [0.0; 3];
        for (a, b) in u.iter().zip(v) {
            for c in 0..3 {
                s[c] += a[c] * b[c];
            }
        }
        s
    };
    let relative = |r: &[[f64; 3]]| -> [f64; 3] {
        let rn = norm(r);
        std::array::from_fn(|c| if bn[c] > 0.0 { rn[c] / bn[c] } else { 0.0 })
    };
    let ax = op.apply(x)?;
    let mut applications = 1;
    let mut r: Vec<[f64; 3]> = b.iter().zip(&ax).map(|(b, a)| std::array::from_fn(|c| b[c] - a[c])).collect();
    let mut rel = relative(&r);
    let mut active: [bool; 3] = std::array::from_fn(|c| bn[c] > 0.0 && rel[c] > tolerance);
    let rhat = r.clone();
    let zeros = || vec![[0.0; 3]; n];
    let (mut p, mut v) = (zeros(), zeros());
    let (mut rho, mut alpha, mut omega) = ([1.0; 3], [1.0; 3], [1.0; 3]);
    let mut iterations = 0;
    let mut broke = false;
    while active.iter().any(|&a| a) && iterations < max_iterations {
        keep_going()?;
        iterations += 1;
        let rho_new = dot(&rhat, &r);
        let mut beta = [0.0; 3];
        for c in 0..3 {
            if active[c] && !(rho_new[c] != 0.0 && rho_new[c].is_finite()) {
                active[c] = false;
                broke = true;
            }
            if active[c] {
                beta[c] = (rho_new[c] / rho[c]) * (alpha[c] / omega[c]);
                rho[c] = rho_new[c];
            }
        }
        for ((p, r), v) in p.iter_mut().zip(&r).zip(&v) {
            for c in 0..3 {
                p[c] = if active[c] { r[c] + beta[c] * (p[c] - omega[c] * v[c]) } else { 0.0 };
            }
        }
        v = op.apply(&p)?;
        applications += 1;
        let rv = dot(&rhat, &v);
        for c in 0..3 {
            alpha[c] = 0.0;
            if active[c] {
                if rv[c] != 0.0 && rv[c].is_finite() {
                    alpha[c] = rho[c] / rv[c];
                } else {
                    active[c] = false;
                    broke = true;
                }
            }
        }
        // s = r − α v, in r.
        for (r, v) in r.iter_mut().zip(&v) {
            for c in 0..3 {
                r[c] -= alpha[c] * v[c];
            }
        }
        for (x, p) in x.iter_mut().zip(&p) {
            for c in 0..3 {
                x[c] += alpha[c] * p[c];
            }
        }
        let half = relative(&r);
        let t = op.apply(&r)?;
        applications += 1;
        let (ts, tt) = (dot(&t, &r), dot(&t, &t));
        for c in 0..3 {
            omega[c] = 0.0;
            if active[c] && half[c] > tolerance {
                if tt[c] > 0.0 && tt[c].is_finite() && ts[c] != 0.0 {
                    omega[c] = ts[c] / tt[c];
                } else {
                    active[c] = false;
                    broke = true;
                }
            }
        }
        for ((x, r), t) in x.iter_mut().zip(r.iter_mut()).zip(&t) {
            for c in 0..3 {
                x[c] += omega[c] * r[c];
                r[c] -= omega[c] * t[c];
            }
        }
        rel = relative(&r);
        for c in 0..3 {
            active[c] &= rel[c] > tolerance;
        }
    }
    let converged = !broke && (0..3).all(|c| bn[c] == 0.0 || rel[c] <= tolerance);
    Ok(OperatorSolve { iterations, applications, relative_residual: rel, converged })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A dense 3-channel matrix, one n × n matrix per channel.
    struct Dense {
        a: Vec<[Vec<f64>; 3]>,
    }

    impl LinearOperator for Dense {
        type Error = &'static str;

        fn len(&self) -> usize {
            self.a.len()
        }

        fn apply(&mut self, x: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, &'static str> {
            Ok(self.a.iter().map(|row| std::array::from_fn(|c| row[c].iter().zip(x).map(|(a, x)| a * x[c]).sum())).collect())
        }
    }

    fn l2(v: &[[f64; 3]]) -> [f64; 3] {
        std::array::from_fn(|c| v.iter().map(|x| x[c] * x[c]).sum::<f64>().sqrt())
    }

    /// I − K with K a nonsymmetric contraction (row sums 0.6 to 0.9, like a gathering F times
    /// an albedo): BiCGSTAB reaches x with A x = b to the tolerance, which the product checks.
    #[test]
    fn solves_a_nonsymmetric_contraction() {
        let n = 40;
        let mut a = Vec::new();
        for i in 0..n {
            let row = |c: usize| -> Vec<f64> {
                let weights: Vec<f64> = (0..n).map(|j| ((i * 7 + j * 3 + c) % 11) as f64 + 1.0).collect();
                let total: f64 = weights.iter().sum();
                let rho = 0.6 + 0.1 * c as f64 + 0.1 * (i % 2) as f64;
                (0..n).map(|j| f64::from(u8::from(i == j)) - rho * weights[j] / total).collect()
            };
            a.push([row(0), row(1), row(2)]);
        }
        let mut op = Dense { a };
        let b: Vec<[f64; 3]> = (0..n).map(|i| [1.0 + i as f64, (i % 5) as f64, 0.0]).collect();
        let mut x = vec![[0.0; 3]; n];
        let s = bicgstab_operator(&mut op, &b, &mut x, 1e-12, 100, &l2, &mut || Ok(())).unwrap();
        assert!(s.converged, "{s:?}");
        assert!(s.iterations < 20, "{s:?}");
        let ax = op.apply(&x).unwrap();
        let r: Vec<[f64; 3]> = b.iter().zip(&ax).map(|(b, a)| std::array::from_fn(|c| b[c] - a[c])).collect();
        let (rn, bn) = (l2(&r), l2(&b));
        for c in 0..2 {
            assert!(rn[c] <= 1e-11 * bn[c], "channel {c}: {} of {}", rn[c], bn[c]);
        }
        assert!(x.iter().all(|x| x[2] == 0.0), "a zero right-hand side gives zero");
        x.fill([0.0; 3]);
        let mut stop = || Err("cancelled");
        assert_eq!(bicgstab_operator(&mut op, &b, &mut x, 1e-12, 100, &l2, &mut stop), Err("cancelled"));
    }
}
