//! Classical radiosity on the patches, B = ρ ⊙ (E + F B) + M per channel (Sheng et al. 2014
//! eq. 2, S = diag(ρ); design/radiosity.md §1.6): Jacobi, as the paper iterates, or Gauss–Seidel
//! in place, stopped by an a-posteriori estimate of the remaining error, with the energy
//! balance of the result.
//!
//! The estimate: with δ_k the area-weighted change of power between sweeps relative to the
//! power, and ρ̂ = δ_k/δ_{k−1} the observed contraction, the error left is about
//! δ_k ρ̂/(1 − ρ̂) (the tail of a geometric series).

use rayon::prelude::*;

use super::error::RadiosityError;
use super::form_factor::FormFactors;

/// The iteration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Iteration {
    /// B_{k+1} = ρ(E + F B_k) + M, every patch from the last sweep (the paper's; parallel).
    #[default]
    Jacobi,
    /// Each patch from the values already updated in this sweep (sequential, about half the
    /// sweeps of Jacobi).
    GaussSeidel,
}

/// How the radiosity is solved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveOptions {
    pub iteration: Iteration,
    /// The estimated relative error in power to stop at.
    pub tolerance: f64,
    /// Sweeps at most.
    pub max_iterations: usize,
}

impl Default for SolveOptions {
    fn default() -> Self {
        Self { iteration: Iteration::Jacobi, tolerance: 1e-3, max_iterations: 200 }
    }
}

/// Where the light went, per channel, in power (irradiance × area): what the direct light and
/// the emission put in, what the patches absorbed and what left the scene.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EnergyBalance {
    pub direct: [f64; 3],
    pub emitted: [f64; 3],
    pub absorbed: [f64; 3],
    pub escaped: [f64; 3],
}

impl EnergyBalance {
    /// |in − out| / in, the worst channel (0 where nothing comes in).
    #[must_use]
    pub fn defect(&self) -> f64 {
        (0..3)
            .map(|c| {
                let input = self.direct[c] + self.emitted[c];
                if input > 0.0 {
                    (input - self.absorbed[c] - self.escaped[c]).abs() / input
                } else {
                    0.0
                }
            })
            .fold(0.0, f64::max)
    }
}

/// The solved radiosity.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// B per patch and channel (exitance, the units of the irradiance).
    pub radiosity: Vec<[f64; 3]>,
    /// Sweeps made.
    pub iterations: usize,
    /// The a-posteriori estimate of the relative error in power when it stopped.
    pub estimated_error: f64,
    pub energy: EnergyBalance,
}

/// Solves B = ρ ⊙ (E + F B) + M for the albedo `albedo` (each in [0, 1)), the direct
/// irradiance `direct` and the emission `emission` (each ≥ 0) per patch; `keep_going` is asked
/// between sweeps.
///
/// # Errors
/// [`RadiosityError::WrongLength`], [`RadiosityError::InvalidValue`] naming the patch and the
/// field, [`RadiosityError::InvalidOptions`] or [`RadiosityError::Cancelled`].
pub fn solve(
    factors: &FormFactors,
    areas: &[f64],
    albedo: &[[f64; 3]],
    direct: &[[f64; 3]],
    emission: &[[f64; 3]],
    options: &SolveOptions,
    keep_going: &(dyn Fn() -> bool + Sync),
) -> Result<Solution, RadiosityError> {
    let n = factors.len();
    for (what, values) in
        [("areas", areas.len()), ("albedo", albedo.len()), ("direct", direct.len()), ("emission", emission.len())]
    {
        if values != n {
            return Err(RadiosityError::WrongLength { what, expected: n, got: values });
        }
    }
    check("albedo", albedo, |x| (0.0..1.0).contains(&x))?;
    check("direct", direct, |x| x >= 0.0 && x.is_finite())?;
    check("emission", emission, |x| x >= 0.0 && x.is_finite())?;
    if !(options.tolerance > 0.0 && options.tolerance.is_finite()) || options.max_iterations == 0 {
        return Err(RadiosityError::InvalidOptions(format!(
            "the tolerance must be finite and > 0 and max_iterations ≥ 1, got {} and {}",
            options.tolerance, options.max_iterations
        )));
    }
    let update =
        |i: usize, e: [f64; 3]| -> [f64; 3] { std::array::from_fn(|c| albedo[i][c] * (direct[i][c] + e[c]) + emission[i][c]) };
    let mut b: Vec<[f64; 3]> = (0..n).map(|i| update(i, [0.0; 3])).collect();
    let power = |b: &[[f64; 3]]| -> f64 { b.iter().zip(areas).map(|(x, a)| a * (x[0] + x[1] + x[2])).sum() };
    let (mut previous, mut estimated, mut iterations) = (f64::NAN, f64::INFINITY, 0);
    while iterations < options.max_iterations {
        if !keep_going() {
            return Err(RadiosityError::Cancelled(crate::progress::Cancelled));
        }
        let change = match options.iteration {
            Iteration::Jacobi => {
                let next: Vec<[f64; 3]> = factors.apply(&b).into_par_iter().enumerate().map(|(i, e)| update(i, e)).collect();
                let change =
                    next.iter().zip(&b).zip(areas).map(|((x, y), a)| a * (0..3).map(|c| (x[c] - y[c]).abs()).sum::<f64>()).sum();
                b = next;
                change
            }
            Iteration::GaussSeidel => {
                let mut change = 0.0;
                for i in 0..n {
                    let x = update(i, factors.apply_row(i, &b));
                    change += areas[i] * (0..3).map(|c| (x[c] - b[i][c]).abs()).sum::<f64>();
                    b[i] = x;
                }
                change
            }
        };
        iterations += 1;
        let total = power(&b);
        let delta = if total > 0.0 { change / total } else { 0.0 };
        let rate = delta / previous;
        estimated = if delta == 0.0 {
            0.0
        } else if rate.is_finite() && rate < 1.0 {
            delta * rate / (1.0 - rate)
        } else {
            f64::INFINITY
        };
        previous = delta;
        if estimated <= options.tolerance {
            break;
        }
    }
    let energy = balance(factors, areas, albedo, direct, emission, &b);
    Ok(Solution { radiosity: b, iterations, estimated_error: estimated, energy })
}

/// The energy balance of `b` (module documentation of [`EnergyBalance`]).
fn balance(
    factors: &FormFactors,
    areas: &[f64],
    albedo: &[[f64; 3]],
    direct: &[[f64; 3]],
    emission: &[[f64; 3]],
    b: &[[f64; 3]],
) -> EnergyBalance {
    let indirect = factors.apply(b);
    let mut out = EnergyBalance::default();
    for i in 0..b.len() {
        let escape = 1.0 - factors.row_sum(i);
        for c in 0..3 {
            out.direct[c] += areas[i] * direct[i][c];
            out.emitted[c] += areas[i] * emission[i][c];
            out.absorbed[c] += areas[i] * (1.0 - albedo[i][c]) * (direct[i][c] + indirect[i][c]);
            out.escaped[c] += areas[i] * b[i][c] * escape;
        }
    }
    out
}

/// Every value of `values` passes `ok`, or the error names the first that does not.
fn check(what: &'static str, values: &[[f64; 3]], ok: impl Fn(f64) -> bool) -> Result<(), RadiosityError> {
    match values.iter().position(|v| !v.iter().all(|&x| ok(x))) {
        Some(patch) => Err(RadiosityError::InvalidValue { what, patch, value: values[patch] }),
        None => Ok(()),
    }
}
