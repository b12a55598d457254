//! Radial scattering profiles R(r) for the profile matrix S of translucent radiosity (Sheng et
//! al. 2014 §4, papers/002; design/radiosity.md §1.5): the exitance per unit area at distance r
//! (mm) from a unit of power transmitted into the surface, in mm⁻², one channel each.
//!
//! Four kinds ([`Profile`]):
//!
//! - **Dipole** (Jensen et al. 2001), [`Dipole::rd`], with its closed-form disc integral.
//! - **Half-space** ([`HalfSpace`], the default): the Green's function of TransCut's own
//!   boundary-value problem on a half-space, so that a flat surface lit by a profile matrix
//!   returns what TransCut's diffusion solve returns (derived in [`HalfSpace`]).
//! - **Tabulated** ([`Tabulated`]): a measured table R(rₖ) (Sheng et al. Fig. 13), linear between
//!   the radii and 0 past the last.
//! - **Exponentials** ([`Exponentials`]): Σₖ aₖ e^{−bₖ r} (the paper's rose).
//!
//! Each has its value, its integral over a disc C(ρ) = ∫₀^ρ R(r) 2πr dr, a local term δ (a Dirac
//! at r = 0, only the half-space's is non-zero), its total C(∞) + δ (the exitance of a uniformly
//! lit plane per unit transmitted irradiance) and the cutoff radius beyond which a given fraction
//! of the total is left. The profiles are normalised per unit of *transmitted* power (design
//! §1.2): a non-absorbing medium's total is 1.

use std::f64::consts::PI;
use std::sync::OnceLock;

use crate::optics::{fdr, Dipole, Medium};

use super::error::RadiosityError;

/// Points of the half-space profile's table (cubic interpolation on a logarithmic grid).
const TABLE_POINTS: usize = 1024;

/// Gauss–Legendre nodes and weights on [−1, 1] of order `n`, by Newton's iteration on the
/// Legendre recurrence (Golub–Welsch would do; this is the classical `gauleg`, Numerical Recipes
/// §4.5): exact for polynomials of degree ≤ 2n − 1.
pub(crate) fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = vec![(0.0, 0.0); n];
    for i in 0..n.div_ceil(2) {
        let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, 0.0);
            for j in 0..n {
                let p2 = p1;
                p1 = p0;
                p0 = ((2 * j + 1) as f64 * x * p1 - j as f64 * p2) / (j + 1) as f64;
            }
            dp = n as f64 * (x * p0 - p1) / (x * x - 1.0);
            let dx = p0 / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        out[i] = (-x, w);
        out[n - 1 - i] = (x, w);
    }
    out
}

/// The 16-point Gauss–Legendre rule, computed once.
pub(crate) fn gl16() -> &'static [(f64, f64)] {
    static NODES: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    NODES.get_or_init(|| gauss_legendre(16))
}

/// ∫ₐᵇ f by the 16-point Gauss–Legendre rule.
fn gl16_panel(f: &impl Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    let (m, h) = (0.5 * (a + b), 0.5 * (b - a));
    gl16().iter().map(|&(x, w)| w * f(m + h * x)).sum::<f64>() * h
}

/// ∫₀^∞ f on geometric panels [0, h₀], [h₀, 2h₀], [2h₀, 4h₀], … until the lower end passes
/// `end`, 16 Gauss–Legendre points per panel: for integrands smooth on each panel and negligible
/// past `end`.
fn integrate_geometric(f: &impl Fn(f64) -> f64, h0: f64, end: f64) -> f64 {
    let (mut lo, mut hi, mut sum) = (0.0, h0, 0.0);
    while lo < end {
        sum += gl16_panel(f, lo, hi);
        lo = hi;
        hi *= 2.0;
    }
    sum
}

/// One channel's radial profile (module documentation).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Profile {
    Dipole(Dipole),
    HalfSpace(HalfSpace),
    Tabulated(Tabulated),
    Exponentials(Exponentials),
}

impl Profile {
    /// The dipole of each channel of `medium`.
    #[must_use]
    pub fn dipole_rgb(medium: &Medium) -> [Profile; 3] {
        std::array::from_fn(|c| Profile::Dipole(medium.dipole(c)))
    }

    /// The TransCut-consistent half-space profile of each channel of `medium` ([`HalfSpace`]).
    #[must_use]
    pub fn half_space_rgb(medium: &Medium) -> [Profile; 3] {
        std::array::from_fn(|c| Profile::HalfSpace(HalfSpace::new(medium.sigma_a[c], medium.sigma_s_prime[c], medium.eta)))
    }

    /// The profile's short name (`dipole`, `half-space`, `tabulated`, `exponentials`).
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            Profile::Dipole(_) => "dipole",
            Profile::HalfSpace(_) => "half-space",
            Profile::Tabulated(_) => "tabulated",
            Profile::Exponentials(_) => "exponentials",
        }
    }

    /// R(r) (mm⁻²) at distance `r` ≥ 0 (mm), the regular part (without the local term).
    #[must_use]
    pub fn value(&self, r: f64) -> f64 {
        match self {
            Profile::Dipole(d) => d.rd(r),
            Profile::HalfSpace(h) => h.value(r),
            Profile::Tabulated(t) => t.value(r),
            Profile::Exponentials(e) => e.value(r),
        }
    }

    /// R(0) when it is finite (every kind but the half-space, which is ∝ 1/r at 0).
    #[must_use]
    pub fn value_at_zero(&self) -> Option<f64> {
        match self {
            Profile::HalfSpace(_) => None,
            _ => Some(self.value(0.0)),
        }
    }

    /// C(ρ) = ∫₀^ρ R(r) 2πr dr, the regular part's integral over a disc of radius `rho` (mm);
    /// `rho` = ∞ gives the regular total.
    #[must_use]
    pub fn disc_integral(&self, rho: f64) -> f64 {
        match self {
            Profile::Dipole(d) => d.disc_integral(rho),
            Profile::HalfSpace(h) => h.disc_integral(rho),
            Profile::Tabulated(t) => t.disc_integral(rho),
            Profile::Exponentials(e) => e.disc_integral(rho),
        }
    }

    /// The weight of the Dirac at r = 0 (dimensionless): the half-space's −(1 − Fdr)/(1 + Fdr),
    /// 0 for the others.
    #[must_use]
    pub fn local(&self) -> f64 {
        match self {
            Profile::HalfSpace(h) => h.local(),
            _ => 0.0,
        }
    }

    /// The total C(∞) + δ: the exitance of a uniformly lit plane per unit of transmitted
    /// irradiance.
    #[must_use]
    pub fn total(&self) -> f64 {
        self.disc_integral(f64::INFINITY) + self.local()
    }

    /// The smallest radius ρ (mm) beyond which at most `tail` of the regular total lies,
    /// C(∞) − C(ρ) ≤ tail·C(∞) (design §1.5: `tail` = 10⁻³ gives ≈ 35 mm for marble's red), found
    /// by bisection to 10⁻⁹ relative. 0 for a profile of no regular part.
    #[must_use]
    pub fn cutoff(&self, tail: f64) -> f64 {
        let total = self.disc_integral(f64::INFINITY);
        if !(total > 0.0) {
            return 0.0;
        }
        let left = |rho: f64| total - self.disc_integral(rho);
        let mut hi = 1.0;
        while left(hi) > tail * total && hi < 1e12 {
            hi *= 2.0;
        }
        let mut lo = 0.0;
        while hi - lo > 1e-9 * hi {
            let mid = 0.5 * (lo + hi);
            if left(mid) > tail * total {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        hi
    }
}

/// The half-space Green's function of TransCut's boundary-value problem (design §1.5), per unit
/// of transmitted power at the origin of the surface.
///
/// # Derivation
///
/// In the half-space z > 0 the fluence solves ∇²φ = σtr²φ with TransCut's Robin condition
/// φ − ℓ ∂φ/∂z = 4q/(1 − Fdr) at z = 0 (the outward normal is −z), ℓ = 2Aκ. Let
/// ψ = φ − ℓ ∂_zφ: it solves the same equation with the Dirichlet data Q = 4q/(1 − Fdr), so
/// ψ(x, z) = ∫ Q(y) P(|x − y|, z) dA_y with the half-space Poisson kernel
/// P(r, z) = −2∂_z[e^{−σd}/(4πd)] = z(1 + σd)e^{−σd}/(2πd³), d = √(r² + z²), σ = σtr, whose
/// integral over the plane is e^{−σz}. The decaying solution of φ − ℓφ′ = ψ is
/// φ(z) = ∫₀^∞ e^{−t} ψ(z + tℓ) dt (differentiate under the integral and integrate by parts).
/// At the surface, for a point source q = δ:
///
/// φ(r, 0) = 4/(1 − Fdr) · g(r), g(r) = ∫₀^∞ e^{−t} P(r, tℓ) dt.
///
/// TransCut's exitance is B = (φ − 2q)/(2A) (the hemispherical integral of its eq. 3), so
///
/// R_tc(r) = 2/(1 + Fdr) · g(r) − (1 − Fdr)/(1 + Fdr) · δ(r).
///
/// Its disc integral is C(ρ) = 2/(1 + Fdr) ∫₀^∞ e^{−t}[e^{−σtℓ} − tℓ e^{−σD}/D] dt,
/// D = √(ρ² + t²ℓ²) (the Poisson kernel's disc integral e^{−σz} − z e^{−σD}/D), and the total is
/// 2/((1 + Fdr)(1 + σℓ)) − (1 − Fdr)/(1 + Fdr), TransCut's uniformly lit half-space
/// (φ = Q/(1 + σℓ)); 1 without absorption. Near 0, g(r) → 1/(2πℓr), integrable.
///
/// g and C are tabulated once on 1024 points of a logarithmic grid (ln(rg) and C interpolated by
/// cubics, within 10⁻⁶ of the direct integrals, 10⁻⁴ below r = ℓ/128); past the table (60/σ), R decays as
/// R(r_max)(r_max/r)³ e^{−σ(r − r_max)}.
#[derive(Debug, Clone, PartialEq)]
pub struct HalfSpace {
    /// The effective transport coefficient σtr = √(3σaσ′t) (mm⁻¹).
    pub sigma_tr: f64,
    /// The extrapolation length ℓ = 2Aκ, κ = 1/(3σ′t) (mm).
    pub ell: f64,
    /// Fdr of [`fdr`] (the fit TransCut's boundary uses).
    pub fdr: f64,
    /// The grid r(s) = scale·(eᔆ − 1), s = k·step.
    scale: f64,
    step: f64,
    /// ln(r g(r)) and C(r)/(2/(1 + Fdr)) at the grid points.
    log_rg: Vec<f64>,
    disc: Vec<f64>,
}

impl HalfSpace {
    /// The profile of a medium with absorption `sigma_a` ≥ 0, reduced scattering
    /// `sigma_s_prime` (mm⁻¹, σa + σ′s > 0) and index `eta` (≥ 1).
    #[must_use]
    pub fn new(sigma_a: f64, sigma_s_prime: f64, eta: f64) -> HalfSpace {
        let f = fdr(eta);
        let a = (1.0 + f) / (1.0 - f);
        let sigma_t = sigma_a + sigma_s_prime;
        let ell = 2.0 * a / (3.0 * sigma_t);
        let sigma_tr = (3.0 * sigma_a * sigma_t).sqrt();
        let r_max = if sigma_tr > 0.0 { (60.0 / sigma_tr).clamp(40.0 * ell, 1e5 * ell) } else { 1e5 * ell };
        let scale = ell / 128.0;
        let step = (1.0 + r_max / scale).ln() / (TABLE_POINTS - 1) as f64;
        let mut profile = HalfSpace { sigma_tr, ell, fdr: f, scale, step, log_rg: Vec::new(), disc: Vec::new() };
        let radii: Vec<f64> = (0..TABLE_POINTS).map(|k| profile.radius(k as f64 * step)).collect();
        profile.log_rg =
            radii.iter().map(|&r| if r == 0.0 { (1.0 / (2.0 * PI * ell)).ln() } else { (r * profile.g(r)).ln() }).collect();
        profile.disc = radii.iter().map(|&r| profile.disc_direct(r)).collect();
        profile
    }

    fn radius(&self, s: f64) -> f64 {
        self.scale * s.exp_m1()
    }

    fn r_max(&self) -> f64 {
        self.radius((TABLE_POINTS - 1) as f64 * self.step)
    }

    /// 2/(1 + Fdr).
    fn gain(&self) -> f64 {
        2.0 / (1.0 + self.fdr)
    }

    /// P(r, z) = z(1 + σd)e^{−σd}/(2πd³), d = √(r² + z²): the Poisson kernel of the half-space.
    fn poisson(&self, r: f64, z: f64) -> f64 {
        let d = r.hypot(z);
        z * (1.0 + self.sigma_tr * d) * (-self.sigma_tr * d).exp() / (2.0 * PI * d * d * d)
    }

    /// g(r) = ∫₀^∞ e^{−t} P(r, tℓ) dt, by quadrature in z = tℓ (16-point Gauss–Legendre on
    /// geometric panels from min(r, ℓ)/8 to 40ℓ).
    pub(crate) fn g(&self, r: f64) -> f64 {
        let f = |z: f64| (-z / self.ell).exp() * self.poisson(r, z) / self.ell;
        integrate_geometric(&f, r.min(self.ell) / 8.0, 40.0 * self.ell)
    }

    /// ∫₀^∞ e^{−t}[e^{−σtℓ} − tℓ e^{−σD}/D] dt, D = √(ρ² + t²ℓ²), by quadrature in z = tℓ.
    pub(crate) fn disc_direct(&self, rho: f64) -> f64 {
        if rho == 0.0 {
            return 0.0;
        }
        let f = |z: f64| {
            let d = rho.hypot(z);
            (-z / self.ell).exp() * ((-self.sigma_tr * z).exp() - z * (-self.sigma_tr * d).exp() / d) / self.ell
        };
        integrate_geometric(&f, rho.min(self.ell) / 8.0, 40.0 * self.ell)
    }

    /// Cubic Lagrange interpolation of `table` at grid coordinate `x` (clamped inside).
    fn interpolate(table: &[f64], x: f64) -> f64 {
        let n = table.len();
        let i = (x.floor() as usize).clamp(1, n - 3);
        let t = x - i as f64;
        let [a, b, c, d] = [table[i - 1], table[i], table[i + 1], table[i + 2]];
        let (tm, t1, t2) = (t + 1.0, t - 1.0, t - 2.0);
        -a * t * t1 * t2 / 6.0 + b * tm * t1 * t2 / 2.0 - c * tm * t * t2 / 2.0 + d * tm * t * t1 / 6.0
    }

    /// R_tc(r) = 2/(1 + Fdr) · g(r) (mm⁻²) for r > 0 (infinite at 0).
    #[must_use]
    pub fn value(&self, r: f64) -> f64 {
        if r <= 0.0 {
            return f64::INFINITY;
        }
        let r_max = self.r_max();
        if r > r_max {
            let at = (self.log_rg[TABLE_POINTS - 1]).exp() / r_max;
            return self.gain() * at * (r_max / r).powi(3) * (-self.sigma_tr * (r - r_max)).exp();
        }
        let x = (r / self.scale).ln_1p() / self.step;
        self.gain() * Self::interpolate(&self.log_rg, x).exp() / r
    }

    /// C(ρ) = ∫₀^ρ R_tc 2πr dr.
    #[must_use]
    pub fn disc_integral(&self, rho: f64) -> f64 {
        let total = 1.0 / (1.0 + self.sigma_tr * self.ell);
        let r_max = self.r_max();
        let c = if rho <= 0.0 {
            0.0
        } else if rho >= r_max {
            // The tail of R(r_max)(r_max/r)³ past ρ, without the exponential (a bound).
            let at = (self.log_rg[TABLE_POINTS - 1]).exp() / r_max;
            let tail =
                if rho.is_finite() { 2.0 * PI * at * r_max.powi(3) / rho * (-self.sigma_tr * (rho - r_max)).exp() } else { 0.0 };
            total - tail
        } else {
            Self::interpolate(&self.disc, (rho / self.scale).ln_1p() / self.step)
        };
        self.gain() * c
    }

    /// −(1 − Fdr)/(1 + Fdr), the local term at r = 0.
    #[must_use]
    pub fn local(&self) -> f64 {
        -(1.0 - self.fdr) / (1.0 + self.fdr)
    }
}

/// A measured profile: R(rₖ) = valuesₖ (mm⁻², ≥ 0) at increasing radii rₖ ≥ 0 (mm), linear
/// between, R(r₀) below r₀ and 0 past the last radius.
#[derive(Debug, Clone, PartialEq)]
pub struct Tabulated {
    radii: Vec<f64>,
    values: Vec<f64>,
    /// C at each radius.
    cumulative: Vec<f64>,
}

impl Tabulated {
    /// The table of `radii` and `values`.
    ///
    /// # Errors
    /// [`RadiosityError::InvalidOptions`] unless there are at least two radii, as many values,
    /// the radii finite, ≥ 0 and strictly increasing and the values finite and ≥ 0.
    pub fn new(radii: Vec<f64>, values: Vec<f64>) -> Result<Tabulated, RadiosityError> {
        let bad = |why: &str| Err(RadiosityError::InvalidOptions(format!("tabulated profile: {why}")));
        if radii.len() < 2 || radii.len() != values.len() {
            return bad(&format!("needs ≥ 2 radii and one value each, got {} radii and {} values", radii.len(), values.len()));
        }
        if !(radii[0] >= 0.0) || radii.windows(2).any(|w| !(w[1] > w[0])) || !radii.iter().all(|r| r.is_finite()) {
            return bad("radii must be finite, ≥ 0 and strictly increasing");
        }
        if let Some(v) = values.iter().find(|v| !(v.is_finite() && **v >= 0.0)) {
            return bad(&format!("values must be finite and ≥ 0, got {v}"));
        }
        let mut cumulative = vec![PI * radii[0] * radii[0] * values[0]];
        for k in 1..radii.len() {
            let last = cumulative[k - 1];
            cumulative.push(last + Self::segment(radii[k - 1], values[k - 1], radii[k], values[k], radii[k]));
        }
        Ok(Tabulated { radii, values, cumulative })
    }

    /// The table of `profile` at `radii` (a measured table's stand-in, or a compact copy).
    ///
    /// # Errors
    /// As [`Tabulated::new`] (a half-space profile at r = 0 is infinite: start past 0).
    pub fn sample(profile: &Profile, radii: Vec<f64>) -> Result<Tabulated, RadiosityError> {
        let values = radii.iter().map(|&r| profile.value(r)).collect();
        Tabulated::new(radii, values)
    }

    /// ∫_{r₀}^{ρ} (linear from (r₀, v₀) to (r₁, v₁)) 2πr dr for ρ ∈ [r₀, r₁]: with
    /// R = v₀ + m(r − r₀), 2π[(v₀ − m r₀)(ρ² − r₀²)/2 + m(ρ³ − r₀³)/3].
    fn segment(r0: f64, v0: f64, r1: f64, v1: f64, rho: f64) -> f64 {
        let m = (v1 - v0) / (r1 - r0);
        2.0 * PI * ((v0 - m * r0) * (rho * rho - r0 * r0) / 2.0 + m * (rho.powi(3) - r0.powi(3)) / 3.0)
    }

    /// R(r), linear interpolation.
    #[must_use]
    pub fn value(&self, r: f64) -> f64 {
        let k = self.radii.partition_point(|&x| x <= r);
        if k == 0 {
            return self.values[0];
        }
        if k == self.radii.len() {
            return if r == self.radii[k - 1] { self.values[k - 1] } else { 0.0 };
        }
        let (r0, r1, v0, v1) = (self.radii[k - 1], self.radii[k], self.values[k - 1], self.values[k]);
        v0 + (v1 - v0) * (r - r0) / (r1 - r0)
    }

    /// C(ρ), exact for the piecewise linear profile.
    #[must_use]
    pub fn disc_integral(&self, rho: f64) -> f64 {
        let k = self.radii.partition_point(|&x| x <= rho);
        if k == 0 {
            return PI * rho * rho * self.values[0];
        }
        if k == self.radii.len() {
            return self.cumulative[k - 1];
        }
        self.cumulative[k - 1] + Self::segment(self.radii[k - 1], self.values[k - 1], self.radii[k], self.values[k], rho)
    }
}

/// A sum of exponentials R(r) = Σₖ aₖ e^{−bₖ r} (aₖ in mm⁻², bₖ > 0 in mm⁻¹).
#[derive(Debug, Clone, PartialEq)]
pub struct Exponentials {
    terms: Vec<(f64, f64)>,
}

impl Exponentials {
    /// The sum of the terms (aₖ, bₖ).
    ///
    /// # Errors
    /// [`RadiosityError::InvalidOptions`] unless there is a term, every aₖ is finite and every
    /// bₖ finite and > 0, and R(r) ≥ 0 at r = 0 (a sum of decaying terms may dip below zero
    /// elsewhere only if some aₖ < 0: the caller's responsibility).
    pub fn new(terms: Vec<(f64, f64)>) -> Result<Exponentials, RadiosityError> {
        if terms.is_empty() || terms.iter().any(|&(a, b)| !(a.is_finite() && b.is_finite() && b > 0.0)) {
            return Err(RadiosityError::InvalidOptions(format!(
                "exponential profile: needs ≥ 1 term (a finite, b finite and > 0), got {terms:?}"
            )));
        }
        Ok(Exponentials { terms })
    }

    /// The terms (aₖ, bₖ).
    #[must_use]
    pub fn terms(&self) -> &[(f64, f64)] {
        &self.terms
    }

    /// Σ aₖ e^{−bₖ r}.
    #[must_use]
    pub fn value(&self, r: f64) -> f64 {
        self.terms.iter().map(|&(a, b)| a * (-b * r).exp()).sum()
    }

    /// C(ρ) = Σ 2πaₖ/bₖ² [1 − (1 + bₖρ) e^{−bₖρ}] (∫₀^ρ e^{−br} 2πr dr in closed form).
    #[must_use]
    pub fn disc_integral(&self, rho: f64) -> f64 {
        self.terms
            .iter()
            .map(|&(a, b)| {
                let tail = if rho.is_finite() { (1.0 + b * rho) * (-b * rho).exp() } else { 0.0 };
                2.0 * PI * a / (b * b) * (1.0 - tail)
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::super::super::optics::quadrature::integrate;
    use super::*;

    fn marble13() -> Medium {
        Medium { eta: 1.3, ..Medium::preset("marble").unwrap() }
    }

    /// ∫₀^∞ f(r) 2πr dr by adaptive Simpson on doubling panels (an independent route).
    fn brute_disc(f: &impl Fn(f64) -> f64, rho: f64, first: f64) -> f64 {
        let g = |r: f64| f(r.max(1e-12)) * 2.0 * PI * r.max(1e-12);
        let (mut lo, mut hi, mut sum) = (0.0, first, 0.0);
        while lo < rho {
            let top = hi.min(rho);
            sum += integrate(&g, lo, top, 1e-13);
            lo = top;
            hi *= 2.0;
        }
        sum
    }

    #[test]
    fn gauss_legendre_is_exact_to_degree_2n_minus_1() {
        for n in [1, 2, 5, 8, 16] {
            let nodes = gauss_legendre(n);
            for k in 0..2 * n {
                let v: f64 = nodes.iter().map(|&(x, w)| w * x.powi(k as i32)).sum();
                let exact = if k % 2 == 1 { 0.0 } else { 2.0 / (k as f64 + 1.0) };
                assert!((v - exact).abs() < 1e-14, "n {n} k {k}: {v}");
            }
        }
    }

    #[test]
    fn half_space_total_is_transcuts_half_space() {
        // TransCut on a uniformly lit half-space: φ = C e^{−σz}, φ − ℓφ′ = C(1 + σℓ) = 4q/(1 − F),
        // B = (φ(0) − 2q)/(2A): per unit q, an independent 1-D solution.
        for (sa, ss, eta) in [(0.0021, 2.19, 1.3), (0.032, 0.74, 1.4), (0.5, 1.0, 1.0), (0.0, 1.0, 1.5)] {
            let h = HalfSpace::new(sa, ss, eta);
            let f = fdr(eta);
            let a = (1.0 + f) / (1.0 - f);
            let ell = 2.0 * a / (3.0 * (sa + ss));
            let sigma = (3.0 * sa * (sa + ss)).sqrt();
            let phi = 4.0 / (1.0 - f) / (1.0 + sigma * ell);
            let transcut = (phi - 2.0) / (2.0 * a);
            let p = Profile::HalfSpace(h.clone());
            assert!((p.total() - transcut).abs() < 1e-9, "{sa} {ss}: {} vs {transcut}", p.total());
            if sa == 0.0 {
                assert!((p.total() - 1.0).abs() < 1e-9);
            }
            // The value integrated independently (adaptive Simpson of R·2πr) to the same total.
            let brute = brute_disc(&|r| h.value(r), 60.0 / sigma.max(1e-3) + 50.0 * ell, ell / 64.0);
            let cont = p.disc_integral(f64::INFINITY);
            let tol = if sa == 0.0 { 2e-3 } else { 1e-5 };
            assert!((brute - cont).abs() < tol * cont, "{sa} {ss}: {brute} vs {cont}");
        }
    }

    #[test]
    fn half_space_table_matches_direct_integrals() {
        let h = HalfSpace::new(0.0021, 2.19, 1.3);
        for r in [1e-4, 0.01, 0.3, 0.77, 2.0, 9.0, 35.0, 120.0] {
            let direct = h.gain() * h.g(r);
            // Below the first cell ln(rg) has an r ln r term: 1e-4 relative there.
            let tol = if r < 1e-3 { 1e-4 } else { 1e-6 };
            assert!((h.value(r) / direct - 1.0).abs() < tol, "r {r}: {} vs {direct}", h.value(r));
            let c = h.gain() * h.disc_direct(r);
            assert!((h.disc_integral(r) - c).abs() < 1e-7, "ρ {r}: {} vs {c}", h.disc_integral(r));
        }
        // dC/dρ = 2πρ R(ρ): the table's two columns agree (central differences).
        for rho in [0.05, 1.0, 10.0] {
            let e = 1e-4 * rho;
            let slope = (h.disc_direct(rho + e) - h.disc_direct(rho - e)) / (2.0 * e);
            assert!((slope / (2.0 * PI * rho * h.g(rho)) - 1.0).abs() < 1e-6);
        }
        // Near 0, g → 1/(2πℓr).
        let r = 1e-6;
        assert!((h.g(r) * 2.0 * PI * h.ell * r - 1.0).abs() < 1e-4);
    }

    #[test]
    fn dipole_profile_matches_the_dipole() {
        let m = marble13();
        let p = Profile::dipole_rgb(&m);
        let d = m.dipole(0);
        assert_eq!(p[0].value(3.0), d.rd(3.0));
        assert_eq!(p[0].local(), 0.0);
        assert!((p[0].total() - d.total()).abs() < 1e-15);
        let brute = brute_disc(&|r| d.rd(r), 20.0, 0.1);
        assert!((p[0].disc_integral(20.0) - brute).abs() < 1e-10);
        assert_eq!(p[0].value_at_zero(), Some(d.rd(0.0)));
    }

    #[test]
    fn cutoffs_hold_the_requested_tail() {
        // design §1.5: red marble ≈ 35 mm for a 10⁻³ tail (6.8e-3 at 20 mm, 3.2e-4 at 40 mm).
        let m = marble13();
        let d = Profile::Dipole(m.dipole(0));
        let total = d.disc_integral(f64::INFINITY);
        let tail = |rho: f64| 1.0 - d.disc_integral(rho) / total;
        assert!((tail(20.0) - 6.8e-3).abs() < 0.1e-3, "{}", tail(20.0));
        assert!((tail(40.0) - 3.2e-4).abs() < 0.1e-4, "{}", tail(40.0));
        let c = d.cutoff(1e-3);
        assert!((30.0..40.0).contains(&c), "{c}");
        assert!((tail(c) - 1e-3).abs() < 1e-9);
        for p in Profile::half_space_rgb(&m) {
            let c = p.cutoff(1e-3);
            let t = p.disc_integral(f64::INFINITY);
            assert!(((t - p.disc_integral(c)) / t - 1e-3).abs() < 1e-8);
        }
    }

    #[test]
    fn tabulated_is_exact_for_piecewise_linear() {
        let t = Tabulated::new(vec![0.0, 1.0, 3.0], vec![2.0, 1.0, 0.0]).unwrap();
        assert_eq!(t.value(0.5), 1.5);
        assert_eq!(t.value(2.0), 0.5);
        assert_eq!(t.value(5.0), 0.0);
        let brute = brute_disc(&|r| t.value(r), 3.0, 1.0);
        // ∫₀¹ (2 − r)2πr dr + ∫₁³ (3 − r)/2 · 2πr dr = 2π(1 − 1/3) + π(12 − 26/3) = 4π/3 + 10π/3.
        let exact = 14.0 * PI / 3.0;
        let p = Profile::Tabulated(t);
        assert!((p.total() - exact).abs() < 1e-12 && (brute - exact).abs() < 1e-9);
        assert!((p.disc_integral(2.0) - brute_disc(&|r| p.value(r), 2.0, 1.0)).abs() < 1e-9);
        assert!(Tabulated::new(vec![1.0, 1.0], vec![1.0, 1.0]).is_err());
        assert!(Tabulated::new(vec![0.0, 1.0], vec![1.0, -1.0]).is_err());
        // A table of the dipole converges to the dipole's disc integral.
        let d = Profile::Dipole(marble13().dipole(0));
        let radii: Vec<f64> = (0..4000).map(|k| k as f64 * 0.01).collect();
        let tab = Profile::Tabulated(Tabulated::sample(&d, radii).unwrap());
        assert!((tab.disc_integral(39.99) / d.disc_integral(39.99) - 1.0).abs() < 1e-4);
    }

    #[test]
    fn exponentials_closed_forms() {
        let e = Exponentials::new(vec![(0.3, 1.5), (0.02, 0.2)]).unwrap();
        let p = Profile::Exponentials(e);
        assert!((p.value(1.0) - (0.3 * (-1.5f64).exp() + 0.02 * (-0.2f64).exp())).abs() < 1e-16);
        let total = 2.0 * PI * (0.3 / 2.25 + 0.02 / 0.04);
        assert!((p.total() - total).abs() < 1e-13);
        let brute = brute_disc(&|r| p.value(r), 7.0, 0.5);
        assert!((p.disc_integral(7.0) - brute).abs() < 1e-10);
        assert!(Exponentials::new(vec![]).is_err());
        assert!(Exponentials::new(vec![(1.0, 0.0)]).is_err());
    }
}
