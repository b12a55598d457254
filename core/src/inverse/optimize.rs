//! The optimisers (Wang et al. 2008 Table I and design note P10/P11) and the acquisition
//! driver [`acquire`]: a homogeneous fit first (as the paper does), then the per-cell fit, with
//! λ given or chosen by the discrepancy principle.
//!
//! - [`Method::Lbfgs`] (default): limited-memory BFGS on the log parameters with a
//!   backtracking line search on the Armijo condition, each trial step the minimiser of the
//!   quadratic through f(0), f′(0) and f(α) (clamped to [0.1α, 0.5α]); on the first
//!   iteration, when the scale of the step is unknown, a step that already decreases f is
//!   doubled while f keeps falling (bracketing). Usually 1–2 evaluations per iteration.
//! - [`Method::PaperCg`] ("paper mode"): Polak–Ribière nonlinear CG with automatic reset
//!   (β = max(β_PR, 0), and steepest descent whenever the direction is not downhill) and a
//!   golden-section line search in a bracket grown by the golden ratio (Table I; the paper
//!   gives no bracket rule or tolerance: here the interval is cut to 2% of the step or 16
//!   evaluations).
//!
//! Both only ever accept a step that lowers f, so the objective never increases. They stop at
//! the paper's misfit rule (every channel's RMS relative misfit ≤ the target; 1% in the paper,
//! which is the noise floor of real data, P11), a relative decrease of f below a threshold over
//! an iteration, a small gradient, an iteration cap, or a line search that finds no decrease.

use crate::progress::Progress;

use super::error::InverseError;
use super::model::{Acquisition, CellMedia, Evaluation, SolveSettings, WorkCounts};
use super::parameters::ParameterGrid;

/// The optimiser.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// L-BFGS with `memory` pairs (default 8) and a quadratic backtracking line search.
    Lbfgs {
        /// Correction pairs kept (≥ 1).
        memory: usize,
    },
    /// The paper's Polak–Ribière CG with golden-section search.
    PaperCg,
}

impl Default for Method {
    fn default() -> Self {
        Self::Lbfgs { memory: 8 }
    }
}

/// How λ is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Lambda {
    /// This λ (≥ 0; unit-free, see [`super::regularize`]).
    Given(f64),
    /// Morozov's discrepancy principle: from `start`, λ is divided by 10 (each fit warm-started
    /// from the last) until every channel's RMS misfit is at most `tau` × `noise_rms`; the
    /// largest such λ is kept (at most 8 trials; the last one otherwise).
    Discrepancy {
        /// The images' noise, RMS relative to the signal (0.01 for 1%).
        noise_rms: f64,
        /// The safety factor τ ≥ 1 (1.1 is usual).
        tau: f64,
        /// The first λ tried.
        start: f64,
    },
}

/// Which colour channels are fitted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Channels {
    /// Each of R, G and B on its own (default).
    #[default]
    Rgb,
    /// Grey images (the same value in every channel, as from a monochrome camera): the first
    /// channel is fitted and its media are copied to the other two, a third of the optimiser's
    /// iterations.
    Grey,
}

/// What an acquisition does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AcquireOptions {
    /// The optimiser.
    pub method: Method,
    /// λ.
    pub lambda: Lambda,
    /// The starting medium (σa, σ′s), mm⁻¹, for the homogeneous fit.
    pub initial: ([f64; 3], [f64; 3]),
    /// Iterations at most for the homogeneous fit.
    pub homogeneous_iterations: usize,
    /// Iterations at most for the per-cell fit (0: the homogeneous fit only).
    pub max_iterations: usize,
    /// Stop when every channel's RMS relative misfit is at most this (0: never; the paper's
    /// rule is 0.01).
    pub target_misfit_rms: f64,
    /// Stop when an iteration lowers f by less than this fraction of f.
    pub relative_decrease: f64,
    /// Stop when ‖∇f‖∞ is at most this.
    pub gradient_tolerance: f64,
    /// The linear solves.
    pub solve: SolveSettings,
    /// The channels fitted.
    pub channels: Channels,
    /// Coarse-to-fine: with L ≥ 1 the per-cell fit is preceded by fits on blocks of 2^L cells a
    /// side, then 2^(L−1), …, 2 (the last block of an axis shorter), each started from the
    /// last and capped at `max_iterations` (0: per cell straight from the homogeneous fit, as
    /// the paper does; at most 8). A level that meets the target misfit leaves the finer ones
    /// nothing to do: the result is then the coarsest blocks that explain the images.
    pub coarse_levels: usize,
    /// σa is fitted on blocks this many times wider than σ′s at every level (1: the same grid;
    /// one face's images constrain σa per cell far less than σ′s).
    pub absorption_coarsening: usize,
}

impl Default for AcquireOptions {
    fn default() -> Self {
        Self {
            method: Method::default(),
            lambda: Lambda::Given(1e-4),
            initial: ([0.01; 3], [1.0; 3]),
            homogeneous_iterations: 60,
            max_iterations: 200,
            target_misfit_rms: 0.0,
            relative_decrease: 1e-7,
            gradient_tolerance: 1e-12,
            solve: SolveSettings::default(),
            channels: Channels::Rgb,
            coarse_levels: 0,
            absorption_coarsening: 1,
        }
    }
}

/// Why a fit stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopReason {
    /// Every channel's misfit reached the target.
    Misfit,
    /// An iteration lowered f by less than the relative threshold.
    RelativeDecrease,
    /// The gradient is below the tolerance.
    Gradient,
    /// The iteration cap.
    IterationCap,
    /// The line search found no lower f along a downhill direction (f at its floor for the
    /// solves' accuracy).
    LineSearch,
}

/// One iteration of a fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IterationRecord {
    /// "homogeneous", "coarse" (σ′s on blocks of cells, [`AcquireOptions::coarse_levels`]) or
    /// "heterogeneous" (σ′s per cell).
    pub stage: &'static str,
    /// Cells per block side of the σa and the σ′s unknowns (0 for the homogeneous fit).
    pub block_cells: [usize; 2],
    /// The colour channel fitted.
    pub channel: usize,
    /// λ during it.
    pub lambda: f64,
    /// The iteration (0: the start).
    pub iteration: usize,
    /// The channel's objective and misfit after it.
    pub sample: Sample,
    /// Objective evaluations in its line search.
    pub line_evaluations: usize,
    /// Forward solves so far (all stages).
    pub forward_solves: usize,
}

/// The result of [`acquire`].
#[derive(Debug, Clone)]
pub struct Acquired {
    /// The recovered per-cell media.
    pub media: CellMedia,
    /// The homogeneous fit (σa, σ′s).
    pub homogeneous: ([f64; 3], [f64; 3]),
    /// The λ of each channel's per-cell fit (the discrepancy principle's choice per channel).
    pub lambda: [f64; 3],
    /// The objective at the result.
    pub evaluation: Evaluation,
    /// Every iteration, in order.
    pub history: Vec<IterationRecord>,
    /// Why each channel's last fit stopped.
    pub stop: [StopReason; 3],
    /// The work done.
    pub counts: WorkCounts,
}

/// A point's objective as the optimisers see it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// The objective of the fitted channel: misfit + λR.
    pub value: f64,
    /// Its RMS relative misfit.
    pub misfit_rms: f64,
}

/// What the optimisers minimise.
trait Problem {
    fn value(&mut self, x: &[f64]) -> Result<Sample, InverseError>;
    fn gradient(&mut self, x: &[f64]) -> Result<(Sample, Vec<f64>), InverseError>;
    fn forward_solves(&self) -> usize;
}

/// One channel's fit with the other two held: the channels are independent problems (each
/// channel's images depend on its own σa and σ′s only), and fitting them jointly ties them to
/// one line search, where one channel can run off while the others descend (a channel whose
/// start is far too bright lowers its misfit towards 1 by absorbing everything). The solves
/// still carry all three channels; the held ones are warm-started at their solution and cost
/// a residual check. The unknowns are ln σa and ln σ′s on `parameters`' blocks of cells (one
/// block each for the homogeneous fit), the gradient summed over each block's cells.
struct ChannelView<'a> {
    model: &'a mut Acquisition,
    channel: usize,
    base: Vec<f64>,
    parameters: ParameterGrid,
}

impl ChannelView<'_> {
    /// The full per-cell vector (every channel) with this channel's cells set from `x`.
    fn expand(&self, x: &[f64]) -> Vec<f64> {
        let mut full = self.base.clone();
        for (cell, (a, s)) in full.chunks_exact_mut(6).zip(self.parameters.prolong(x)) {
            cell[self.channel] = a;
            cell[3 + self.channel] = s;
        }
        full
    }

    /// This channel's per-cell (σa, σ′s) entries of a full vector.
    fn channel_cells<'b>(&self, full: &'b [f64]) -> impl Iterator<Item = (f64, f64)> + 'b {
        let c = self.channel;
        full.chunks_exact(6).map(move |cell| (cell[c], cell[3 + c]))
    }

    /// The gradient with respect to the block parameters of a full per-cell gradient.
    fn reduce(&self, full: &[f64]) -> Vec<f64> {
        self.parameters.sum(self.channel_cells(full))
    }

    /// The block parameters that start a fit from the full vector `full` (block averages).
    fn start(&self, full: &[f64]) -> Vec<f64> {
        self.parameters.average(self.channel_cells(full))
    }

    fn sample(&self, e: &Evaluation) -> Sample {
        let c = self.channel;
        Sample { value: e.misfit[c] + self.model.lambda() * e.regulariser[c], misfit_rms: e.misfit[c].sqrt() }
    }
}

impl Problem for ChannelView<'_> {
    fn value(&mut self, x: &[f64]) -> Result<Sample, InverseError> {
        let full = self.expand(x);
        let e = self.model.evaluate(&full)?;
        Ok(self.sample(&e))
    }
    fn gradient(&mut self, x: &[f64]) -> Result<(Sample, Vec<f64>), InverseError> {
        let full = self.expand(x);
        let (e, g) = self.model.gradient(&full)?;
        Ok((self.sample(&e), self.reduce(&g)))
    }
    fn forward_solves(&self) -> usize {
        self.model.counts().forward_solves
    }
}

/// The stopping rules of one fit.
#[derive(Debug, Clone, Copy)]
struct Stop {
    max_iterations: usize,
    target_misfit_rms: f64,
    relative_decrease: f64,
    gradient_tolerance: f64,
}

/// Most coarse-to-fine levels (blocks of 256 cells a side).
const MAX_COARSE_LEVELS: usize = 8;

/// The Armijo constant c₁ of the sufficient-decrease test f(α) ≤ f(0) + c₁ α f′(0).
const ARMIJO: f64 = 1e-4;
/// The curvature constant c₂ of the Wolfe condition ∇f(x + αd)·d ≥ c₂ ∇f(x)·d.
const CURVATURE: f64 = 0.9;
/// The first step's largest change of any log parameter (10%).
const FIRST_STEP: f64 = 0.1;
/// The longest step: no log parameter changes by more than this (a factor e² ≈ 7.4) in one
/// iteration, so a line search cannot leap to where the images are black or saturated and
/// the gradient vanishes.
const MAX_STEP: f64 = 2.0;
/// Objective evaluations at most per line search.
const LINE_EVALUATIONS: usize = 16;

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn max_abs(a: &[f64]) -> f64 {
    a.iter().fold(0.0f64, |m, &v| m.max(v.abs()))
}

fn axpy(x: &[f64], alpha: f64, d: &[f64]) -> Vec<f64> {
    x.iter().zip(d).map(|(x, d)| x + alpha * d).collect()
}

/// The minimiser of the quadratic through f(0) = `f0`, f′(0) = `slope` < 0 and f(α) = `fa`:
/// α* = −slope α² / (2 (fa − f0 − slope α)) (Nocedal & Wright eq. 3.57), clamped to
/// [0.1α, 0.5α] (the safeguard of a backtracking search).
#[must_use]
pub fn quadratic_step(f0: f64, slope: f64, alpha: f64, fa: f64) -> f64 {
    let curvature = fa - f0 - slope * alpha;
    let step = if curvature > 0.0 { -slope * alpha * alpha / (2.0 * curvature) } else { 0.5 * alpha };
    step.clamp(0.1 * alpha, 0.5 * alpha)
}

/// The L-BFGS direction −H∇f by the two-loop recursion (Nocedal & Wright Alg. 7.4) over the
/// pairs (s, y), oldest first, with H₀ = (sᵀy / yᵀy) I from the newest pair.
#[must_use]
pub fn lbfgs_direction(g: &[f64], pairs: &[(Vec<f64>, Vec<f64>)]) -> Vec<f64> {
    let mut q = g.to_vec();
    let mut alphas = Vec::with_capacity(pairs.len());
    for (s, y) in pairs.iter().rev() {
        let rho = 1.0 / dot(y, s);
        let a = rho * dot(s, &q);
        for (q, y) in q.iter_mut().zip(y) {
            *q -= a * y;
        }
        alphas.push((a, rho));
    }
    if let Some((s, y)) = pairs.last() {
        let gamma = dot(s, y) / dot(y, y);
        for q in &mut q {
            *q *= gamma;
        }
    }
    for ((s, y), (a, rho)) in pairs.iter().zip(alphas.into_iter().rev()) {
        let b = rho * dot(y, &q);
        for (q, s) in q.iter_mut().zip(s) {
            *q += (a - b) * s;
        }
    }
    q.iter().map(|v| -v).collect()
}

/// The Polak–Ribière β with automatic reset, max(gᵀ(g − g_prev)/(g_prevᵀ g_prev), 0)
/// (Table I step 2).
#[must_use]
pub fn polak_ribiere(g: &[f64], g_prev: &[f64]) -> f64 {
    let num: f64 = g.iter().zip(g_prev).map(|(a, b)| a * (a - b)).sum();
    let den = dot(g_prev, g_prev);
    if den > 0.0 {
        (num / den).max(0.0)
    } else {
        0.0
    }
}

/// The outcome of a line search: the step, its evaluation and the evaluations spent.
struct LineResult {
    alpha: f64,
    eval: Sample,
    evaluations: usize,
}

/// Backtracking on the Armijo condition with quadratic steps; with `expand`, a first step
/// that passes is doubled while f keeps falling. `None` if no step lowered f.
fn line_quadratic<P: Problem>(
    p: &mut P,
    x: &[f64],
    d: &[f64],
    f0: f64,
    slope: f64,
    alpha0: f64,
    expand: bool,
) -> Result<Option<LineResult>, InverseError> {
    let mut alpha = alpha0;
    let mut best: Option<(f64, Sample)> = None;
    for k in 0..LINE_EVALUATIONS {
        let e = p.value(&axpy(x, alpha, d))?;
        let armijo = e.value <= f0 + ARMIJO * alpha * slope;
        if e.value < f0 && best.is_none_or(|(_, b)| e.value < b.value) {
            best = Some((alpha, e));
        }
        if armijo {
            if expand && k == 0 {
                let mut evaluations = 1;
                let (mut a, mut fa) = (alpha, e);
                let longest = MAX_STEP / max_abs(d).max(f64::MIN_POSITIVE);
                while evaluations < LINE_EVALUATIONS && 2.0 * a <= longest {
                    let e2 = p.value(&axpy(x, 2.0 * a, d))?;
                    evaluations += 1;
                    if e2.value < fa.value {
                        (a, fa) = (2.0 * a, e2);
                    } else {
                        break;
                    }
                }
                return Ok(Some(LineResult { alpha: a, eval: fa, evaluations }));
            }
            return Ok(Some(LineResult { alpha, eval: e, evaluations: k + 1 }));
        }
        if !e.value.is_finite() {
            alpha *= 0.1;
            continue;
        }
        alpha = quadratic_step(f0, slope, alpha, e.value);
    }
    Ok(best.map(|(alpha, eval)| LineResult { alpha, eval, evaluations: LINE_EVALUATIONS }))
}

/// The golden ratio's conjugate, (√5 − 1)/2.
const GOLDEN: f64 = 0.618_033_988_749_894_8;

/// The paper's line search: a bracket [a, c] around a point b with f(b) < f(a), f(c), grown or
/// shrunk by the golden ratio from `alpha0`, then golden-section search until the interval is
/// 2% of the best step or the evaluations run out. `None` if no step lowered f.
fn line_golden<P: Problem>(p: &mut P, x: &[f64], d: &[f64], f0: f64, alpha0: f64) -> Result<Option<LineResult>, InverseError> {
    let mut evaluations = 0;
    let mut f = |alpha: f64, evaluations: &mut usize| -> Result<Sample, InverseError> {
        *evaluations += 1;
        p.value(&axpy(x, alpha, d))
    };
    let mut best: Option<(f64, Sample)> = None;
    let note = |alpha: f64, e: Sample, best: &mut Option<(f64, Sample)>| {
        if e.value < f0 && best.is_none_or(|(_, b)| e.value < b.value) {
            *best = Some((alpha, e));
        }
    };
    // Bracket.
    let (mut a, mut b) = (0.0, alpha0);
    let mut fb = f(b, &mut evaluations)?;
    note(b, fb, &mut best);
    let mut c;
    if fb.value < f0 {
        loop {
            c = b + (b - a) / GOLDEN;
            let fc = f(c, &mut evaluations)?;
            note(c, fc, &mut best);
            if fc.value >= fb.value || evaluations >= LINE_EVALUATIONS {
                break;
            }
            (a, b, fb) = (b, c, fc);
        }
    } else {
        c = b;
        loop {
            b = c * GOLDEN * GOLDEN;
            fb = f(b, &mut evaluations)?;
            note(b, fb, &mut best);
            if fb.value < f0 || evaluations >= LINE_EVALUATIONS {
                break;
            }
            c = b;
        }
    }
    // Golden section on [a, c] with b inside.
    while evaluations < LINE_EVALUATIONS && best.is_some() && (c - a) > 0.02 * best.map_or(0.0, |(s, _)| s) {
        // The new point at 0.382 of the larger segment, measured from b.
        let t = if b - a > c - b { b - (1.0 - GOLDEN) * (b - a) } else { b + (1.0 - GOLDEN) * (c - b) };
        let ft = f(t, &mut evaluations)?;
        note(t, ft, &mut best);
        if ft.value < fb.value {
            if t < b {
                c = b;
            } else {
                a = b;
            }
            (b, fb) = (t, ft);
        } else if t < b {
            a = t;
        } else {
            c = t;
        }
    }
    Ok(best.map(|(alpha, eval)| LineResult { alpha, eval, evaluations }))
}

/// Whether every channel's misfit meets the target.
fn misfit_met(e: &Sample, target: f64) -> bool {
    target > 0.0 && e.misfit_rms <= target
}

/// What a fit is, for its records.
#[derive(Debug, Clone, Copy)]
struct Label {
    /// The share of the whole acquisition this fit covers, as (start, width) in [0, 1]: the
    /// homogeneous R, G, B fits a sixth each, then the per-cell R, G, B fits (split among the
    /// coarse-to-fine stages); the reported fraction is start + width · iteration/cap, so it
    /// never goes back.
    span: (f64, f64),
    stage: &'static str,
    block_cells: [usize; 2],
    channel: usize,
    lambda: f64,
}

/// Minimises `p` from `x` (updated in place) by `method`; records every iteration.
fn minimise<P: Problem>(
    p: &mut P,
    x: &mut Vec<f64>,
    method: Method,
    stop: Stop,
    label: Label,
    history: &mut Vec<IterationRecord>,
    progress: &Progress<'_>,
) -> Result<(Sample, StopReason), InverseError> {
    let Label { span, stage, block_cells, channel, lambda } = label;
    let (mut e, mut g) = p.gradient(x)?;
    history.push(IterationRecord {
        stage,
        block_cells,
        channel,
        lambda,
        iteration: 0,
        sample: e,
        line_evaluations: 0,
        forward_solves: p.forward_solves(),
    });
    let mut pairs: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    let mut d_prev: Option<Vec<f64>> = None;
    let mut g_prev: Option<Vec<f64>> = None;
    let mut alpha_prev: Option<f64> = None;
    // Whether the last step failed the curvature condition ∇f(x + αd)·d ≥ c₂ ∇f(x)·d: the
    // line was still falling nearly as steeply where the search stopped (Armijo alone accepts
    // such short steps, and L-BFGS then crawls along a curved valley, as the homogeneous fit's
    // σa–σ′s valley showed: 90 iterations against paper mode's 7). The next search then
    // doubles a step that passes while f keeps falling.
    let mut short = false;
    for it in 1..=stop.max_iterations {
        if misfit_met(&e, stop.target_misfit_rms) {
            return Ok((e, StopReason::Misfit));
        }
        if max_abs(&g) <= stop.gradient_tolerance {
            return Ok((e, StopReason::Gradient));
        }
        let blocks = if stage == "coarse" { format!(" (blocks of {} cells)", block_cells[1]) } else { String::new() };
        progress.report(
            &format!(
                "{stage} fit{blocks}, {} channel: iteration {it}, misfit {:.3}% RMS",
                ["red", "green", "blue"][channel],
                100.0 * e.misfit_rms
            ),
            span.0 + span.1 * (it - 1) as f64 / stop.max_iterations as f64,
        )?;
        let (mut d, fresh) = match method {
            Method::Lbfgs { .. } => (lbfgs_direction(&g, &pairs), pairs.is_empty()),
            Method::PaperCg => match (&d_prev, &g_prev) {
                (Some(dp), Some(gp)) => {
                    let beta = polak_ribiere(&g, gp);
                    (g.iter().zip(dp).map(|(g, d)| -g + beta * d).collect(), beta == 0.0)
                }
                _ => (g.iter().map(|v| -v).collect(), true),
            },
        };
        let mut slope = dot(&g, &d);
        let mut fresh = fresh;
        if !(slope < 0.0) {
            pairs.clear();
            d = g.iter().map(|v| -v).collect();
            slope = dot(&g, &d);
            fresh = true;
        }
        let first = FIRST_STEP / max_abs(&d).max(f64::MIN_POSITIVE);
        let longest = MAX_STEP / max_abs(&d).max(f64::MIN_POSITIVE);
        let line = match method {
            Method::Lbfgs { .. } => {
                let alpha0 = if fresh { first } else { longest.min(1.0) };
                line_quadratic(p, x, &d, e.value, slope, alpha0, fresh || short)?
            }
            Method::PaperCg => {
                // The last step, rescaled to this direction (Toast's choice), or the first.
                let alpha0 = alpha_prev.map_or(first, |a| a.min(first * 10.0)).min(longest);
                line_golden(p, x, &d, e.value, alpha0)?
            }
        };
        let Some(line) = line else {
            return Ok((e, StopReason::LineSearch));
        };
        let x_new = axpy(x, line.alpha, &d);
        let (e_new, g_new) = p.gradient(&x_new)?;
        if e_new.value >= e.value {
            // The gradient's solve at the accepted point (warm-started from another point)
            // lands within the solve tolerance of the line search's value; where that is
            // not below f, the decrease was at the solves' noise floor: keep x.
            debug_assert!((e_new.value - line.eval.value).abs() <= 1e-6 * e.value.abs());
            return Ok((e, StopReason::LineSearch));
        }
        let decrease = (e.value - e_new.value) / e.value.abs().max(f64::MIN_POSITIVE);
        short = dot(&g_new, &d) < CURVATURE * slope;
        if let Method::Lbfgs { memory } = method {
            let s: Vec<f64> = x_new.iter().zip(x.iter()).map(|(a, b)| a - b).collect();
            let y: Vec<f64> = g_new.iter().zip(&g).map(|(a, b)| a - b).collect();
            let sy = dot(&s, &y);
            if sy > 1e-12 * dot(&s, &s).sqrt() * dot(&y, &y).sqrt() {
                pairs.push((s, y));
                if pairs.len() > memory.max(1) {
                    pairs.remove(0);
                }
            }
        }
        g_prev = Some(std::mem::replace(&mut g, g_new));
        d_prev = Some(d);
        alpha_prev = Some(line.alpha);
        *x = x_new;
        e = e_new;
        history.push(IterationRecord {
            stage,
            block_cells,
            channel,
            lambda,
            iteration: it,
            sample: e,
            line_evaluations: line.evaluations,
            forward_solves: p.forward_solves(),
        });
        if decrease < stop.relative_decrease {
            return Ok((e, StopReason::RelativeDecrease));
        }
    }
    if misfit_met(&e, stop.target_misfit_rms) {
        return Ok((e, StopReason::Misfit));
    }
    Ok((e, StopReason::IterationCap))
}

/// Fits a homogeneous medium, then per-cell media, to the model's images (module
/// documentation); `progress` gets a report per iteration (stage names the fit and its
/// misfit) and may cancel.
///
/// # Errors
/// [`InverseError::NegativeLambda`], [`InverseError::InvalidSetting`] (also for more than 8
/// coarse levels or an absorption coarsening of 0) or
/// [`InverseError::InvalidParameters`] for bad options (checked before any solve);
/// [`InverseError::Cancelled`]; a solver error. Nothing is returned but a finished fit.
pub fn acquire(model: &mut Acquisition, options: &AcquireOptions, progress: &Progress<'_>) -> Result<Acquired, InverseError> {
    let (a0, s0) = options.initial;
    if a0.iter().chain(&s0).any(|v| !(v.is_finite() && *v > 0.0)) {
        return Err(InverseError::InvalidParameters("the initial σa and σ′s must be finite and > 0".into()));
    }
    match options.lambda {
        Lambda::Given(l) if !(l.is_finite() && l >= 0.0) => return Err(InverseError::NegativeLambda(l)),
        Lambda::Discrepancy { noise_rms, tau, start } => {
            if !(noise_rms.is_finite() && noise_rms > 0.0) {
                return Err(InverseError::InvalidSetting { what: "noise level", value: noise_rms, expected: "finite and > 0" });
            }
            if !(tau.is_finite() && tau >= 1.0) {
                return Err(InverseError::InvalidSetting { what: "discrepancy factor τ", value: tau, expected: "≥ 1" });
            }
            if !(start.is_finite() && start > 0.0) {
                return Err(InverseError::NegativeLambda(start));
            }
        }
        Lambda::Given(_) => {}
    }
    for (what, v) in [
        ("target misfit", options.target_misfit_rms),
        ("relative decrease", options.relative_decrease),
        ("gradient tolerance", options.gradient_tolerance),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(InverseError::InvalidSetting { what, value: v, expected: "finite and ≥ 0" });
        }
    }
    if options.coarse_levels > MAX_COARSE_LEVELS {
        return Err(InverseError::InvalidSetting {
            what: "coarse-to-fine levels",
            value: options.coarse_levels as f64,
            expected: "at most 8",
        });
    }
    if options.absorption_coarsening == 0 {
        return Err(InverseError::InvalidSetting { what: "absorption coarsening", value: 0.0, expected: "≥ 1" });
    }
    if let Method::Lbfgs { memory: 0 } = options.method {
        return Err(InverseError::InvalidSetting { what: "L-BFGS memory", value: 0.0, expected: "≥ 1" });
    }
    model.set_solve_settings(options.solve)?;
    let cells = model.grid().cell_count();
    let mut history = Vec::new();
    let stop = |max_iterations, target_misfit_rms| Stop {
        max_iterations,
        target_misfit_rms,
        relative_decrease: options.relative_decrease,
        gradient_tolerance: options.gradient_tolerance,
    };
    let mut x: Vec<f64> = (0..cells).flat_map(|_| a0.iter().chain(&s0).map(|v| v.ln())).collect();
    let mut reasons = [StopReason::IterationCap; 3];

    let fitted = match options.channels {
        Channels::Rgb => 0..3,
        Channels::Grey => 0..1,
    };

    // 1. The homogeneous fit per channel (κ constant: the regulariser is 0 whatever λ).
    model.set_lambda(0.0)?;
    for channel in fitted.clone() {
        let mut x2 = vec![x[channel], x[3 + channel]];
        let parameters = ParameterGrid::homogeneous(cells);
        let mut view = ChannelView { model: &mut *model, channel, base: x.clone(), parameters };
        let span = (channel as f64 / 6.0, 1.0 / 6.0);
        let label = Label { span, stage: "homogeneous", block_cells: [0, 0], channel, lambda: 0.0 };
        let rules = stop(options.homogeneous_iterations, options.target_misfit_rms);
        (_, reasons[channel]) = minimise(&mut view, &mut x2, options.method, rules, label, &mut history, progress)?;
        x = view.expand(&x2);
    }
    if options.channels == Channels::Grey {
        copy_first_channel(&mut x);
        reasons = [reasons[0]; 3];
    }
    let homogeneous = (std::array::from_fn(|c| x[c].exp()), std::array::from_fn(|c| x[3 + c].exp()));
    model.set_kappa_reference(std::array::from_fn(|c| super::model::kappa(homogeneous.0[c], homogeneous.1[c])));

    // 2. The per-cell fit per channel.
    let mut lambda = [0.0; 3];
    if options.max_iterations > 0 {
        for (channel, (used, reason_out)) in lambda.iter_mut().zip(reasons.iter_mut()).enumerate().take(fitted.end) {
            let (lambdas, target): (Vec<f64>, f64) = match options.lambda {
                Lambda::Given(l) => (vec![l], options.target_misfit_rms),
                Lambda::Discrepancy { noise_rms, tau, start } => {
                    ((0..8).map(|k| start * 0.1f64.powi(k)).collect(), tau * noise_rms)
                }
            };
            for (trial, &l) in lambdas.iter().enumerate() {
                *used = l;
                model.set_lambda(l)?;
                // Coarse-to-fine on the first λ only: a later λ starts from the last fit's cells.
                let levels = if trial == 0 { options.coarse_levels } else { 0 };
                let mut last = None;
                for level in (0..=levels).rev() {
                    let side = 1usize << level;
                    let blocks = [side * options.absorption_coarsening, side];
                    let parameters = ParameterGrid::blocks(model.grid(), blocks[0], blocks[1]);
                    let mut view = ChannelView { model: &mut *model, channel, base: x.clone(), parameters };
                    let mut xr = view.start(&x);
                    let width = 1.0 / (6.0 * (levels + 1) as f64);
                    let span = ((3 + channel) as f64 / 6.0 + (levels - level) as f64 * width, width);
                    let stage = if side > 1 { "coarse" } else { "heterogeneous" };
                    let label = Label { span, stage, block_cells: blocks, channel, lambda: l };
                    let rules = stop(options.max_iterations, target);
                    last = Some(minimise(&mut view, &mut xr, options.method, rules, label, &mut history, progress)?);
                    x = view.expand(&xr);
                }
                let (sample, reason) = last.expect("the per-cell level always runs");
                *reason_out = reason;
                if misfit_met(&sample, target) || matches!(options.lambda, Lambda::Given(_)) {
                    break;
                }
            }
        }
    }
    if options.channels == Channels::Grey {
        copy_first_channel(&mut x);
        reasons = [reasons[0]; 3];
        lambda = [lambda[0]; 3];
    }
    let evaluation = model.evaluate(&x)?;
    let media = CellMedia::from_log_vector(&x)?;
    Ok(Acquired { media, homogeneous, lambda, evaluation, history, stop: reasons, counts: model.counts() })
}

/// Sets every cell's second and third channel (ln σa and ln σ′s) to its first.
fn copy_first_channel(x: &mut [f64]) {
    for cell in x.chunks_exact_mut(6) {
        (cell[1], cell[2], cell[4], cell[5]) = (cell[0], cell[0], cell[3], cell[3]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A convex quadratic with a known minimum, as a [`Problem`].
    struct Quad {
        scale: Vec<f64>,
        evals: usize,
    }

    impl Problem for Quad {
        fn value(&mut self, x: &[f64]) -> Result<Sample, InverseError> {
            self.evals += 1;
            let v: f64 = x.iter().zip(&self.scale).map(|(x, s)| s * (x - 1.0).powi(2)).sum();
            Ok(Sample { value: v, misfit_rms: v.sqrt() })
        }
        fn gradient(&mut self, x: &[f64]) -> Result<(Sample, Vec<f64>), InverseError> {
            let e = self.value(x)?;
            Ok((e, x.iter().zip(&self.scale).map(|(x, s)| 2.0 * s * (x - 1.0)).collect()))
        }
        fn forward_solves(&self) -> usize {
            self.evals
        }
    }

    fn run(method: Method) -> (Vec<f64>, Vec<IterationRecord>) {
        let mut q = Quad { scale: vec![1.0, 10.0, 100.0, 3.0], evals: 0 };
        let mut x = vec![0.0; 4];
        let mut h = Vec::new();
        let stop = Stop { max_iterations: 200, target_misfit_rms: 0.0, relative_decrease: 0.0, gradient_tolerance: 1e-9 };
        let label = Label { span: (0.0, 1.0), stage: "test", block_cells: [1, 1], channel: 0, lambda: 0.0 };
        minimise(&mut q, &mut x, method, stop, label, &mut h, &Progress::none()).unwrap();
        (x, h)
    }

    #[test]
    fn both_methods_find_a_quadratics_minimum_and_never_go_uphill() {
        for method in [Method::default(), Method::PaperCg] {
            let (x, h) = run(method);
            assert!(x.iter().all(|v| (v - 1.0).abs() < 1e-6), "{method:?}: {x:?}");
            assert!(h.windows(2).all(|w| w[1].sample.value <= w[0].sample.value), "{method:?}");
        }
    }

    #[test]
    fn quadratic_step_is_exact_on_a_parabola() {
        // f(α) = (α − 0.3)²: f(0) = 0.09, f′(0) = −0.6, f(1) = 0.49 → α* = 0.3.
        assert!((quadratic_step(0.09, -0.6, 1.0, 0.49) - 0.3).abs() < 1e-12);
        // Clamped to [0.1, 0.5] α.
        assert!((quadratic_step(0.09, -0.6, 0.1, 0.0) - 0.05).abs() < 1e-12);
    }

    #[test]
    fn lbfgs_with_one_pair_satisfies_the_secant_equation() {
        // H y = s for the newest pair.
        let s = vec![1.0, 2.0, -1.0];
        let y = vec![2.0, 3.0, -0.5];
        let d = lbfgs_direction(&y, &[(s.clone(), y.clone())]);
        for (d, s) in d.iter().zip(&s) {
            assert!((-d - s).abs() < 1e-12, "{d} vs {s}");
        }
    }

    #[test]
    fn polak_ribiere_resets_at_negative_beta() {
        assert_eq!(polak_ribiere(&[1.0, 0.0], &[2.0, 0.0]), 0.0);
        assert!((polak_ribiere(&[1.0, 1.0], &[1.0, 0.0]) - 1.0).abs() < 1e-15);
    }
}
