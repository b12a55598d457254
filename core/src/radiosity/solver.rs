//! Translucent radiosity on the patches (Sheng et al. 2014 eqs. 13–14; design/radiosity.md
//! §1.2, §1.6): B = S(q_d + t F B) on the patches of each translucent object, S its subsurface
//! scattering ([`Scattering`]) and t = 1 − F_ext(η) the part of the diffuse indirect light that
//! enters it, and B = ρ ⊙ (E_d + F B) + M on opaque patches (eq. 2, S = diag ρ). Jacobi, as the
//! paper iterates (bounce k of the light after k − 1 sweeps), or block Gauss–Seidel (opaque
//! patches in place, Gauss–Seidel inside two interleaved sets of patches and Jacobi between
//! them, so that they run in parallel; then each translucent object
//! from the values already updated), stopped by an a-posteriori estimate of the remaining
//! error, with the energy balance of the result.
//!
//! The gather E = F B of a whole radiosity vector, the product that dominates a sweep, goes
//! through [`Gather`] ([`solve_coupled_with`]): [`FormFactors`] computes it on the CPU, and a
//! device can (`crate::gpu::GpuRadiosity`, which this module cannot name: the device layer
//! depends on this one). Jacobi sweeps, a warm start's first gather and BiCGSTAB's operator
//! applications use it; Gauss–Seidel reads F row by row from values updated within the sweep,
//! which is sequential by nature, so its sweeps always run on the CPU.
//!
//! The estimate: with δ_k the area-weighted change of power between sweeps relative to the
//! power, and ρ̂ = δ_k/δ_{k−1} the observed contraction, the error left is about
//! δ_k ρ̂/(1 − ρ̂) (the tail of a geometric series).

use rayon::prelude::*;

use super::error::RadiosityError;
use super::form_factor::FormFactors;
use crate::sparse::{bicgstab_operator, LinearOperator};

/// The interleaved sets of opaque patches a Gauss–Seidel sweep updates in parallel: each set
/// sees its own new values only, so more sets converge more like Jacobi (at 25k patches of the
/// Cornell box: 6 sweeps for one set, 8 for two, 9 for four, 10 for Jacobi). Two, whatever the
/// number of threads, so the result does not depend on the machine; where more cores are
/// there, Jacobi or BiCGSTAB use them all.
const GAUSS_SEIDEL_SETS: usize = 2;

/// The iteration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Iteration {
    /// Every patch from the last sweep (the paper's; parallel): sweep k adds bounce k + 1.
    #[default]
    Jacobi,
    /// Opaque patches one after the other from the values already updated in this sweep, in
    /// two interleaved sets in parallel (each from its own new values and the other's at the
    /// sweep's start), then each translucent object from them: fewer
    /// sweeps than Jacobi and fewer scattering solves.
    GaussSeidel,
    /// BiCGSTAB on (I − K) B = B₁, K the light's one bounce and B₁ the first bounce
    /// ([`crate::sparse::bicgstab_operator`]; two applications of K, so two scatterings, per
    /// iteration), stopped when the residual bounds the error in power below the tolerance,
    /// then one Jacobi sweep that leaves every scattering in the state of the answer.
    BiCgStab,
}

impl Iteration {
    /// Every name, in the order front ends list them.
    pub const NAMES: [&'static str; 3] = ["jacobi", "gauss-seidel", "bicgstab"];

    /// The name front ends use.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Jacobi => "jacobi",
            Self::GaussSeidel => "gauss-seidel",
            Self::BiCgStab => "bicgstab",
        }
    }

    /// The iteration called `name` (any case), or `None`.
    #[must_use]
    pub fn from_name(name: &str) -> Option<Self> {
        match name.trim().to_ascii_lowercase().as_str() {
            "jacobi" => Some(Self::Jacobi),
            "gauss-seidel" => Some(Self::GaussSeidel),
            "bicgstab" => Some(Self::BiCgStab),
            _ => None,
        }
    }
}

/// How the radiosity is solved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveOptions {
    pub iteration: Iteration,
    /// The estimated relative error in power to stop at, in (0, 1).
    pub tolerance: f64,
    /// Sweeps at most, ≥ 1.
    pub max_iterations: usize,
    /// `Some(k)`: exactly k bounces of light (the first, S q_d and ρE_d + M, then k − 1 Jacobi
    /// sweeps), whatever the tolerance; `None`: until the tolerance.
    pub bounces: Option<usize>,
}

impl Default for SolveOptions {
    fn default() -> Self {
        Self { iteration: Iteration::Jacobi, tolerance: 1e-3, max_iterations: 200, bounces: None }
    }
}

impl SolveOptions {
    /// The largest `max_iterations` and `bounces`: a radiosity that has not converged in ten
    /// thousand sweeps has an albedo too close to 1 to be meant.
    pub const MAX_ITERATIONS: usize = 10_000;

    /// # Errors
    /// A message naming the option out of range.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.tolerance > 0.0 && self.tolerance < 1.0) {
            return Err(format!("the radiosity tolerance must lie in (0, 1), got {}", self.tolerance));
        }
        if self.max_iterations == 0 || self.max_iterations > Self::MAX_ITERATIONS {
            return Err(format!("max_iterations must be in 1..={}, got {}", Self::MAX_ITERATIONS, self.max_iterations));
        }
        match self.bounces {
            Some(0) => Err("bounces must be at least 1 (the direct light's)".into()),
            Some(b) if b > Self::MAX_ITERATIONS => Err(format!("bounces must be at most {}, got {b}", Self::MAX_ITERATIONS)),
            Some(_) if self.iteration != Iteration::Jacobi => {
                Err("a count of bounces needs the Jacobi iteration (a Gauss–Seidel sweep mixes bounces)".into())
            }
            _ => Ok(()),
        }
    }
}

/// Where the light went, per channel, in power (irradiance × area): what the direct light and
/// the emission put in (for translucent patches the transmitted direct light q_d), what the
/// patches absorbed, what the translucent surfaces reflected specularly (the part F_ext of the
/// indirect light they get, which diffuse transport leaves to the renderer) and what left the
/// scene.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EnergyBalance {
    pub direct: [f64; 3],
    pub emitted: [f64; 3],
    pub absorbed: [f64; 3],
    pub specular: [f64; 3],
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
                    (input - self.absorbed[c] - self.specular[c] - self.escaped[c]).abs() / input
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
    /// Sweeps made (bounces − 1 under Jacobi).
    pub iterations: usize,
    /// Applications of each translucent object's scattering (sweeps + 1).
    pub scatterings: usize,
    /// The a-posteriori estimate of the relative error in power when it stopped (0 after one
    /// bounce only, which is exact for what it is).
    pub estimated_error: f64,
    pub energy: EnergyBalance,
}

/// The gather E = F B of a whole radiosity vector B for one F (module documentation):
/// [`FormFactors`] on the CPU, or a device's copy of the same F.
pub trait Gather {
    /// The number of patches of F (B's and E's length).
    fn patches(&self) -> usize;

    /// E_i = Σ_j F_ij B_j for every patch i, `b` and the result in patch order.
    ///
    /// # Errors
    /// [`RadiosityError::WrongLength`] for a `b` of another length than F's;
    /// [`RadiosityError::Device`] when a device failed.
    fn gather(&self, b: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, RadiosityError>;
}

/// The CPU's gather ([`FormFactors::apply`], rows in parallel).
impl Gather for FormFactors {
    fn patches(&self) -> usize {
        self.len()
    }

    fn gather(&self, b: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, RadiosityError> {
        if b.len() != self.len() {
            return Err(RadiosityError::WrongLength { what: "radiosity to gather", expected: self.len(), got: b.len() });
        }
        Ok(self.apply(b))
    }
}

/// `gather`'s E = F B, checked to have one value per patch (a device's read-back included).
fn gather_checked(gather: &dyn Gather, b: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, RadiosityError> {
    let e = gather.gather(b)?;
    if e.len() != b.len() {
        return Err(RadiosityError::WrongLength { what: "gathered irradiance", expected: b.len(), got: e.len() });
    }
    Ok(e)
}

/// The subsurface scattering of one translucent object, S: the light transmitted into each of
/// its patches (irradiance, after Fresnel) to the exitance B leaving each (design/radiosity.md
/// §1.2). It is linear and keeps what its next application starts from (a warm start).
pub trait Scattering {
    /// Why an application failed.
    type Error;

    /// B per patch for the transmitted irradiance `q` per patch (both in the object's patch
    /// order).
    ///
    /// # Errors
    /// The operator's own (a solve that failed, a cancellation).
    fn scatter(&mut self, q: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, Self::Error>;
}

/// The opaque side of the scene, per patch (translucent patches' entries are not read).
#[derive(Debug, Clone, Copy)]
pub struct Opaque<'a> {
    /// ρ per patch and channel, in [0, 1).
    pub albedo: &'a [[f64; 3]],
    /// The direct irradiance E_d, finite and ≥ 0.
    pub direct: &'a [[f64; 3]],
    /// The emitted exitance M, finite and ≥ 0.
    pub emission: &'a [[f64; 3]],
}

/// One translucent object's patches: `direct.len()` consecutive patches from `first`.
pub struct Translucent<'a, E> {
    pub first: usize,
    /// t = 1 − F_ext(η): the part of diffuse indirect light that enters the object.
    pub transmittance: f64,
    /// The transmitted direct light q_d per patch of the object, finite and ≥ 0.
    pub direct: &'a [[f64; 3]],
    pub scattering: &'a mut dyn Scattering<Error = E>,
}

impl<E> Translucent<'_, E> {
    fn range(&self) -> std::ops::Range<usize> {
        self.first..self.first + self.direct.len()
    }

    /// S(t E): what the object sends out of the indirect irradiance E alone (K's translucent
    /// rows).
    fn scatter_indirect(&mut self, gathered: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, E> {
        let t = self.transmittance;
        let q: Vec<[f64; 3]> = gathered.iter().map(|e| e.map(|x| t * x)).collect();
        self.scattering.scatter(&q)
    }

    /// Scatters the light q = q_d + t E transmitted under the gathered irradiance E of the
    /// object's patches into `b`'s entries of the object.
    fn update(&mut self, gathered: &[[f64; 3]], b: &mut [[f64; 3]]) -> Result<(), E> {
        let t = self.transmittance;
        let q: Vec<[f64; 3]> = self.direct.iter().zip(gathered).map(|(d, e)| std::array::from_fn(|c| d[c] + t * e[c])).collect();
        let out = self.scattering.scatter(&q)?;
        let range = self.range();
        b[range].copy_from_slice(&out);
        Ok(())
    }
}

/// Solves classical radiosity B = ρ ⊙ (E + F B) + M for the albedo `albedo` (each in [0, 1)),
/// the direct irradiance `direct` and the emission `emission` (each ≥ 0) per patch; `keep_going`
/// is asked between sweeps.
///
/// # Errors
/// As [`solve_coupled`].
pub fn solve(
    factors: &FormFactors,
    areas: &[f64],
    albedo: &[[f64; 3]],
    direct: &[[f64; 3]],
    emission: &[[f64; 3]],
    options: &SolveOptions,
    keep_going: &(dyn Fn() -> bool + Sync),
) -> Result<Solution, RadiosityError> {
    solve_coupled::<RadiosityError>(factors, areas, &Opaque { albedo, direct, emission }, &mut [], None, options, keep_going)
}

/// Solves translucent radiosity (module documentation): the opaque patches' `opaque` values and
/// the translucent objects `translucent` (disjoint patch ranges; the opaque values of their
/// patches are not read); `keep_going` is asked between sweeps.
///
/// `initial` warm-starts the iteration from a radiosity close to the answer (the last one, when
/// a light moved or an albedo changed): the first update gathers it instead of nothing, so
/// fewer sweeps reach the tolerance. A count of bounces starts from no light and takes none.
///
/// # Errors
/// [`RadiosityError::WrongLength`], [`RadiosityError::InvalidValue`] naming the patch and the
/// field, [`RadiosityError::InvalidOptions`] (also for overlapping translucent ranges, and for
/// `initial` with a count of bounces) or [`RadiosityError::Cancelled`]; a scattering's error.
pub fn solve_coupled<E: From<RadiosityError>>(
    factors: &FormFactors,
    areas: &[f64],
    opaque: &Opaque<'_>,
    translucent: &mut [Translucent<'_, E>],
    initial: Option<&[[f64; 3]]>,
    options: &SolveOptions,
    keep_going: &(dyn Fn() -> bool + Sync),
) -> Result<Solution, E> {
    solve_coupled_with(factors, factors, areas, opaque, translucent, initial, options, keep_going)
}

/// [`solve_coupled`] with the gather E = F B of `gather` (a device's copy of `factors`) in the
/// Jacobi sweeps, a warm start's first gather and BiCGSTAB's operator applications and closing
/// sweep. Gauss–Seidel sweeps read `factors` row by row on the CPU whatever `gather` is (each
/// patch gathers from values updated earlier in the same sweep); the energy balance uses
/// `factors` too, so that it checks the answer against the CPU's F, accumulated in f64.
///
/// # Errors
/// As [`solve_coupled`]; [`RadiosityError::WrongLength`] when `gather` has another number of
/// patches than `factors`; [`RadiosityError::Device`] when the device failed.
#[allow(clippy::too_many_arguments)] // solve_coupled's arguments and the gather
pub fn solve_coupled_with<E: From<RadiosityError>>(
    factors: &FormFactors,
    gather: &dyn Gather,
    areas: &[f64],
    opaque: &Opaque<'_>,
    translucent: &mut [Translucent<'_, E>],
    initial: Option<&[[f64; 3]]>,
    options: &SolveOptions,
    keep_going: &(dyn Fn() -> bool + Sync),
) -> Result<Solution, E> {
    let n = factors.len();
    let is_translucent = check_inputs(n, areas, opaque, translucent, options)?;
    if gather.patches() != n {
        return Err(RadiosityError::WrongLength {
            what: "patches of the gather's form factors",
            expected: n,
            got: gather.patches(),
        }
        .into());
    }
    if let Some(initial) = initial {
        if options.bounces.is_some() {
            return Err(
                RadiosityError::InvalidOptions("a count of bounces starts from no light: it takes no warm start".into()).into()
            );
        }
        if initial.len() != n {
            return Err(RadiosityError::WrongLength { what: "initial radiosity", expected: n, got: initial.len() }.into());
        }
        check("initial radiosity", initial, 0, f64::is_finite)?;
    }
    let Opaque { albedo, direct, emission } = *opaque;
    let update =
        |i: usize, e: [f64; 3]| -> [f64; 3] { std::array::from_fn(|c| albedo[i][c] * (direct[i][c] + e[c]) + emission[i][c]) };
    // BiCGSTAB starts from `initial` itself and needs the first bounce B₁ as its right-hand
    // side; the sweeps start from the update of what `initial` gathers.
    let krylov = options.iteration == Iteration::BiCgStab;
    let start = match initial {
        Some(b) if !krylov => gather_checked(gather, b)?,
        _ => vec![[0.0; 3]; n],
    };
    let mut b = jacobi_update(opaque, translucent, &is_translucent, &start)?;
    let mut scatterings = 1;
    if krylov {
        let krylov = Krylov { gather, areas, opaque, translucent, is_translucent: &is_translucent };
        let mut solution = krylov.solve(b, initial, options, keep_going)?;
        solution.energy = balance(factors, areas, opaque, translucent, &is_translucent, &solution.radiosity);
        if translucent.is_empty() {
            solution.scatterings = 0;
        }
        return Ok(solution);
    }
    let power = |b: &[[f64; 3]]| -> f64 { b.iter().zip(areas).map(|(x, a)| a * (x[0] + x[1] + x[2])).sum() };
    let change = |x: &[f64; 3], y: &[f64; 3], a: f64| a * (0..3).map(|c| (x[c] - y[c]).abs()).sum::<f64>();
    let sweeps = options.bounces.map_or(options.max_iterations, |k| k - 1);
    let (mut previous, mut estimated, mut iterations) = (f64::NAN, if sweeps == 0 { 0.0 } else { f64::INFINITY }, 0);
    while iterations < sweeps {
        if !keep_going() {
            return Err(RadiosityError::Cancelled(crate::progress::Cancelled).into());
        }
        let before = b.clone();
        match options.iteration {
            Iteration::Jacobi => b = jacobi_update(opaque, translucent, &is_translucent, &gather_checked(gather, &b)?)?,
            Iteration::BiCgStab => unreachable!("solved above"),
            Iteration::GaussSeidel => {
                // Interleaved sets, set k holding patches k, k + K, k + 2K, …: a patch gathers
                // mostly from other surfaces (a flat wall not at all from itself), so sets of
                // consecutive patches would find few of their own new values.
                let count = GAUSS_SEIDEL_SETS.min(n.max(1));
                let sets: Vec<Vec<[f64; 3]>> = (0..count)
                    .into_par_iter()
                    .map(|set| {
                        let mut local = before.clone();
                        for i in (set..n).step_by(count).filter(|&i| !is_translucent[i]) {
                            local[i] = update(i, factors.apply_row(i, &local));
                        }
                        local
                    })
                    .collect();
                for (i, x) in b.iter_mut().enumerate() {
                    *x = sets[i % count][i];
                }
                for block in translucent.iter_mut() {
                    let gathered: Vec<[f64; 3]> = block.range().into_par_iter().map(|i| factors.apply_row(i, &b)).collect();
                    block.update(&gathered, &mut b)?;
                }
            }
        }
        scatterings += 1;
        iterations += 1;
        let total = power(&b);
        let moved: f64 = b.par_iter().zip(&before).zip(areas).map(|((x, y), a)| change(x, y, *a)).sum();
        let delta = if total > 0.0 { moved / total } else { 0.0 };
        let rate = delta / previous;
        estimated = if delta == 0.0 {
            0.0
        } else if rate.is_finite() && rate < 1.0 {
            delta * rate / (1.0 - rate)
        } else {
            f64::INFINITY
        };
        previous = delta;
        if options.bounces.is_none() && estimated <= options.tolerance {
            break;
        }
    }
    let energy = balance(factors, areas, opaque, translucent, &is_translucent, &b);
    let scatterings = if translucent.is_empty() { 0 } else { scatterings };
    Ok(Solution { radiosity: b, iterations, scatterings, estimated_error: estimated, energy })
}

/// One Jacobi update from the gathered irradiance E: ρ ⊙ (E_d + E) + M on opaque patches and
/// S(q_d + t E) on each translucent object's (eqs. 13–14).
fn jacobi_update<E>(
    opaque: &Opaque<'_>,
    translucent: &mut [Translucent<'_, E>],
    is_translucent: &[bool],
    gathered: &[[f64; 3]],
) -> Result<Vec<[f64; 3]>, E> {
    let Opaque { albedo, direct, emission } = *opaque;
    let mut b: Vec<[f64; 3]> = gathered
        .par_iter()
        .enumerate()
        .map(|(i, e)| {
            if is_translucent[i] {
                [0.0; 3]
            } else {
                std::array::from_fn(|c| albedo[i][c] * (direct[i][c] + e[c]) + emission[i][c])
            }
        })
        .collect();
    for block in translucent.iter_mut() {
        block.update(&gathered[block.range()], &mut b)?;
    }
    Ok(b)
}

/// The coupled system as an operator for BiCGSTAB: (I − K) x, K x = ρ ⊙ F x on opaque patches
/// and S(t (F x)) on each translucent object's, F x by `gather`.
struct Krylov<'a, 'b, 'c, E> {
    gather: &'a dyn Gather,
    areas: &'a [f64],
    opaque: &'a Opaque<'a>,
    translucent: &'a mut [Translucent<'b, E>],
    is_translucent: &'c [bool],
}

/// [`Krylov`] counting its scatterings.
struct Counted<'k, 'a, 'b, 'c, E> {
    system: &'k mut Krylov<'a, 'b, 'c, E>,
    scatterings: usize,
}

impl<E: From<RadiosityError>> LinearOperator for Counted<'_, '_, '_, '_, E> {
    type Error = E;

    fn len(&self) -> usize {
        self.system.gather.patches()
    }

    fn apply(&mut self, x: &[[f64; 3]]) -> Result<Vec<[f64; 3]>, E> {
        let Krylov { gather, opaque, translucent, is_translucent, .. } = &mut *self.system;
        let gathered = gather_checked(*gather, x)?;
        let mut y: Vec<[f64; 3]> = x
            .par_iter()
            .enumerate()
            .map(
                |(i, x)| {
                    if is_translucent[i] {
                        *x
                    } else {
                        std::array::from_fn(|c| x[c] - opaque.albedo[i][c] * gathered[i][c])
                    }
                },
            )
            .collect();
        for block in translucent.iter_mut() {
            let range = block.range();
            let s = block.scatter_indirect(&gathered[range.clone()])?;
            for (y, s) in y[range].iter_mut().zip(s) {
                for c in 0..3 {
                    y[c] -= s[c];
                }
            }
        }
        if !translucent.is_empty() {
            self.scatterings += 1;
        }
        Ok(y)
    }
}

impl<E: From<RadiosityError>> Krylov<'_, '_, '_, E> {
    /// BiCGSTAB on (I − K) B = `rhs` (the first bounce B₁, already scattered once) from
    /// `initial` (else from B₁), stopped when the residual
    /// r bounds the relative error in power: ‖e‖ ≤ ‖r‖/(1 − κ) in the area-weighted L1 norm,
    /// where κ, the largest albedo or transmittance, bounds ‖K‖ there (F's columns carry at most
    /// a patch's power, ρ and S lose power, t passes a part of it), and ‖B‖ ≥ ‖B₁‖ as K ≥ 0.
    /// Returns B after the closing Jacobi sweep, the iterations, the scatterings and the bound
    /// (the energy balance left to the caller).
    fn solve(
        mut self,
        rhs: Vec<[f64; 3]>,
        initial: Option<&[[f64; 3]]>,
        options: &SolveOptions,
        keep_going: &(dyn Fn() -> bool + Sync),
    ) -> Result<Solution, E> {
        let mut scatterings = 1; // B₁'s
        let mut x = initial.map_or_else(|| rhs.clone(), <[[f64; 3]]>::to_vec);
        let kappa = self
            .opaque
            .albedo
            .iter()
            .zip(self.is_translucent)
            .filter(|(_, &t)| !t)
            .flat_map(|(a, _)| a.iter().copied())
            .chain(self.translucent.iter().map(|b| b.transmittance))
            .fold(0.0f64, f64::max);
        let areas = self.areas;
        let norm = |v: &[[f64; 3]]| -> [f64; 3] {
            let mut s = [0.0; 3];
            for (x, a) in v.iter().zip(areas) {
                for c in 0..3 {
                    s[c] += a * x[c].abs();
                }
            }
            s
        };
        let mut op = Counted { system: &mut self, scatterings: 0 };
        let mut poll = || if keep_going() { Ok(()) } else { Err(RadiosityError::Cancelled(crate::progress::Cancelled).into()) };
        let tolerance = options.tolerance * (1.0 - kappa);
        let solved = bicgstab_operator(&mut op, &rhs, &mut x, tolerance, options.max_iterations, &norm, &mut poll)?;
        scatterings += op.scatterings;
        let estimated = solved.relative_residual.iter().fold(0.0f64, |m, &r| m.max(r)) / (1.0 - kappa);
        // The closing sweep: B = K x + B₁, which leaves each scattering at the answer's state.
        let b = jacobi_update(self.opaque, self.translucent, self.is_translucent, &gather_checked(self.gather, &x)?)?;
        scatterings += usize::from(!self.translucent.is_empty());
        Ok(Solution {
            radiosity: b,
            iterations: solved.iterations,
            scatterings,
            estimated_error: estimated,
            energy: EnergyBalance::default(),
        })
    }
}

/// The lengths, the values and the options, and which patches are translucent.
fn check_inputs<E>(
    n: usize,
    areas: &[f64],
    opaque: &Opaque<'_>,
    translucent: &[Translucent<'_, E>],
    options: &SolveOptions,
) -> Result<Vec<bool>, RadiosityError> {
    for (what, values) in [
        ("areas", areas.len()),
        ("albedo", opaque.albedo.len()),
        ("direct", opaque.direct.len()),
        ("emission", opaque.emission.len()),
    ] {
        if values != n {
            return Err(RadiosityError::WrongLength { what, expected: n, got: values });
        }
    }
    options.validate().map_err(RadiosityError::InvalidOptions)?;
    let mut is_translucent = vec![false; n];
    for (k, block) in translucent.iter().enumerate() {
        let range = block.range();
        if range.end > n || is_translucent[range.clone()].iter().any(|&t| t) {
            return Err(RadiosityError::InvalidOptions(format!(
                "translucent object {k}: its patches {}..{} overlap another object's or lie beyond the {n} patches",
                range.start, range.end
            )));
        }
        if !(0.0..=1.0).contains(&block.transmittance) {
            return Err(RadiosityError::InvalidOptions(format!(
                "translucent object {k}: the transmittance must lie in [0, 1], got {}",
                block.transmittance
            )));
        }
        check("transmitted direct light", block.direct, block.first, |x| x >= 0.0 && x.is_finite())?;
        is_translucent[range].fill(true);
    }
    let opaque_only = |values: &[[f64; 3]]| -> Vec<[f64; 3]> {
        values.iter().zip(&is_translucent).map(|(v, &t)| if t { [0.0; 3] } else { *v }).collect()
    };
    check("albedo", &opaque_only(opaque.albedo), 0, |x| (0.0..1.0).contains(&x))?;
    check("direct", &opaque_only(opaque.direct), 0, |x| x >= 0.0 && x.is_finite())?;
    check("emission", &opaque_only(opaque.emission), 0, |x| x >= 0.0 && x.is_finite())?;
    Ok(is_translucent)
}

/// The energy balance of `b` ([`EnergyBalance`]): an opaque patch absorbs (1 − ρ)(E_d + E), a
/// translucent one q − B of the light q = q_d + tE it transmits and reflects (1 − t)E
/// specularly; every patch sends the part 1 − Σⱼ F_ij of its B out of the scene.
fn balance<E>(
    factors: &FormFactors,
    areas: &[f64],
    opaque: &Opaque<'_>,
    translucent: &[Translucent<'_, E>],
    is_translucent: &[bool],
    b: &[[f64; 3]],
) -> EnergyBalance {
    let gathered = factors.apply(b);
    let mut out = EnergyBalance::default();
    for i in 0..b.len() {
        let escape = 1.0 - factors.row_sum(i);
        for c in 0..3 {
            out.escaped[c] += areas[i] * b[i][c] * escape;
            if !is_translucent[i] {
                out.direct[c] += areas[i] * opaque.direct[i][c];
                out.emitted[c] += areas[i] * opaque.emission[i][c];
                out.absorbed[c] += areas[i] * (1.0 - opaque.albedo[i][c]) * (opaque.direct[i][c] + gathered[i][c]);
            }
        }
    }
    for block in translucent {
        let t = block.transmittance;
        for (k, i) in block.range().enumerate() {
            for c in 0..3 {
                let (q_d, e) = (block.direct[k][c], gathered[i][c]);
                out.direct[c] += areas[i] * q_d;
                out.absorbed[c] += areas[i] * (q_d + t * e - b[i][c]);
                out.specular[c] += areas[i] * (1.0 - t) * e;
            }
        }
    }
    out
}

/// Every value of `values` passes `ok`, or the error names the first that does not (as patch
/// `first` + its index).
fn check(what: &'static str, values: &[[f64; 3]], first: usize, ok: impl Fn(f64) -> bool) -> Result<(), RadiosityError> {
    match values.iter().position(|v| !v.iter().all(|&x| ok(x))) {
        Some(k) => Err(RadiosityError::InvalidValue { what, patch: first + k, value: values[k] }),
        None => Ok(()),
    }
}
