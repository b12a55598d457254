//! The acquisition model: the block's forward problem per light pattern, the predicted images,
//! and the objective (design note §1.3 and §1.4, with the choices of P1, P9 and P13).
//!
//! Per image m, A(p) φ_m = b_m ([`super::block::BlockGrid::matrix`]), b_m = S_i^lit Q_i/(2A)
//! at the lit-face nodes (Q = 4q/(1 − Fdr), S^lit the node's dual area on the lit face), and
//! the predicted image is ARCHITECTURE.md's query along the normal,
//!
//! L_m = s φ_m − t q_m on the observed face, s = Ft/(4π)(1 + 1/A), t = Ft/(4π)·4/(1 + Fdr),
//!
//! (q_m = 0 on a back-lit camera's face). The objective per channel is the misfit normalised
//! by the data's energy plus λ times the smoothness of κ:
//!
//! f = Σ_ch [ Σ_m ‖W_m (L_m − L̂_m)‖² / D_ch + λ R_ch(κ) ],   D_ch = Σ_m ‖W_m L̂_m‖²,
//!
//! so √(data term) is the RMS relative misfit (design note P16: 1% RMS is 1e-4) and λ has no
//! units (P9). The parameters are per-cell ln σa and ln σ′s (so both stay positive, P10).

use rayon::prelude::*;

use crate::optics::BoundaryTerms;
use crate::sparse::{pcg, CsrMatrix3, Precision, Preconditioner, PreconditionerKind, SolveOptions};

use super::block::{face_areas, BlockGrid};
use super::error::InverseError;
use super::regularize::Smoothness;
use super::setup::{check_pixels, front_mask, Observation, Pattern};

/// What is known about the sample and the camera before any fit.
#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    /// Nodes along x, y, z (≥ 2 each); the lit face is z = max.
    pub dims: [usize; 3],
    /// Node spacing, mm.
    pub spacing_mm: f64,
    /// The sample's refractive index (one for the whole sample).
    pub eta: f64,
    /// Which face the camera sees.
    pub observation: Observation,
}

impl Setup {
    /// The lit face's size, mm: [(nx − 1)h, (ny − 1)h].
    #[must_use]
    pub fn face_size_mm(&self) -> [f64; 2] {
        [(self.dims[0] - 1) as f64 * self.spacing_mm, (self.dims[1] - 1) as f64 * self.spacing_mm]
    }
}

/// Per-cell media: σa and σ′s per channel, mm⁻¹ (the cells of [`BlockGrid`], x fastest).
#[derive(Debug, Clone, PartialEq)]
pub struct CellMedia {
    /// σa per cell and channel.
    pub sigma_a: Vec<[f64; 3]>,
    /// σ′s per cell and channel.
    pub sigma_s_prime: Vec<[f64; 3]>,
}

impl CellMedia {
    /// `cells` copies of one medium.
    #[must_use]
    pub fn uniform(cells: usize, sigma_a: [f64; 3], sigma_s_prime: [f64; 3]) -> Self {
        Self { sigma_a: vec![sigma_a; cells], sigma_s_prime: vec![sigma_s_prime; cells] }
    }

    /// The optimiser's vector: per cell, ln σa (3 channels) then ln σ′s (3 channels).
    #[must_use]
    pub fn to_log_vector(&self) -> Vec<f64> {
        self.sigma_a
            .iter()
            .zip(&self.sigma_s_prime)
            .flat_map(|(a, s)| [a[0].ln(), a[1].ln(), a[2].ln(), s[0].ln(), s[1].ln(), s[2].ln()])
            .collect()
    }

    /// The media of an optimiser's vector ([`CellMedia::to_log_vector`]'s layout).
    ///
    /// # Errors
    /// [`InverseError::InvalidParameters`] for a length not a multiple of 6 or an entry that
    /// is not finite.
    pub fn from_log_vector(x: &[f64]) -> Result<Self, InverseError> {
        if !x.len().is_multiple_of(6) {
            return Err(InverseError::InvalidParameters(format!("{} entries, not 6 per cell", x.len())));
        }
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            return Err(InverseError::InvalidParameters(format!("entry {i} is {}", x[i])));
        }
        let (sigma_a, sigma_s_prime) =
            x.chunks_exact(6).map(|c| ([c[0].exp(), c[1].exp(), c[2].exp()], [c[3].exp(), c[4].exp(), c[5].exp()])).unzip();
        Ok(Self { sigma_a, sigma_s_prime })
    }

    /// κ = 1/(3(σa + σ′s)) per cell and channel.
    #[must_use]
    pub fn kappa(&self) -> Vec<[f64; 3]> {
        self.sigma_a.iter().zip(&self.sigma_s_prime).map(|(a, s)| std::array::from_fn(|c| kappa(a[c], s[c]))).collect()
    }
}

/// κ = 1/(3(σa + σ′s)) (ARCHITECTURE.md, "The equations").
#[must_use]
pub fn kappa(sigma_a: f64, sigma_s_prime: f64) -> f64 {
    1.0 / (3.0 * (sigma_a + sigma_s_prime))
}

/// ∂κ/∂σa = ∂κ/∂σ′s = −3κ² (the derivative of [`kappa`] with respect to either coefficient).
#[must_use]
pub fn dkappa(kappa: f64) -> f64 {
    -3.0 * kappa * kappa
}

/// The linear solves' settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveSettings {
    /// Relative residual ‖b − Aφ‖/‖b‖ to reach (default 1e-10; 1e-12 for gradient checks).
    pub tolerance: f64,
    /// Iterations at most per solve (default 20 000).
    pub max_iterations: usize,
}

impl Default for SolveSettings {
    fn default() -> Self {
        Self { tolerance: 1e-10, max_iterations: 20_000 }
    }
}

/// The parts of an objective value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Evaluation {
    /// f = Σ_ch (misfit_ch + λ R_ch).
    pub value: f64,
    /// Σ_m ‖W(L − L̂)‖²/D per channel: the squared RMS relative misfit.
    pub misfit: [f64; 3],
    /// R(κ) per channel (unweighted).
    pub regulariser: [f64; 3],
}

impl Evaluation {
    /// √misfit per channel: the RMS relative misfit (0.01 is the paper's stopping level).
    #[must_use]
    pub fn misfit_rms(&self) -> [f64; 3] {
        self.misfit.map(f64::sqrt)
    }
}

/// Counts of the work done.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WorkCounts {
    /// Forward solves (one per image per evaluation; three channels each).
    pub forward_solves: usize,
    /// Adjoint solves (one per image per gradient).
    pub adjoint_solves: usize,
    /// PCG iterations of all solves (the largest channel's count per solve).
    pub pcg_iterations: usize,
}

/// The acquisition model: setup, light, images and masks, with warm-started solves.
#[derive(Debug)]
pub struct Acquisition {
    pub(super) setup: Setup,
    pub(super) grid: BlockGrid,
    pub(super) terms: BoundaryTerms,
    /// q per lit-face node, per image.
    pub(super) face_q: Vec<Vec<[f64; 3]>>,
    /// Node ids of the lit face and of the observed face (x fastest).
    pub(super) lit_nodes: Vec<usize>,
    pub(super) observed_nodes: Vec<usize>,
    /// S_i^lit per lit-face node.
    pub(super) lit_area: Vec<f64>,
    pub(super) data: Vec<Vec<[f64; 3]>>,
    pub(super) masks: Vec<Vec<bool>>,
    pub(super) norm: [f64; 3],
    pub(super) smoothness: Smoothness,
    pub(super) lambda: f64,
    pub(super) solve: SolveSettings,
    /// The last forward solutions (warm starts) and the parameters they belong to.
    pub(super) phi: Vec<Vec<[f64; 3]>>,
    pub(super) phi_at: Option<Vec<f64>>,
    pub(super) psi: Vec<Vec<[f64; 3]>>,
    pub(super) counts: WorkCounts,
}

impl Acquisition {
    /// The model of `setup` lit by `patterns`, with one image per pattern (pixels on the
    /// observed face, x fastest) and optional per-image masks of usable pixels (`true`: fit
    /// it), combined with the front-lit margin.
    ///
    /// # Errors
    /// Named input errors ([`InverseError`]): the grid, spacing or η out of range; no
    /// patterns; a pattern count that differs from the image count; images, patterns or
    /// masks of the wrong size; NaN or infinite pixels (negative ones in patterns); a channel
    /// with nothing to fit after masking.
    pub fn new(
        setup: Setup,
        patterns: &[Pattern],
        images: Vec<Vec<[f64; 3]>>,
        masks: Option<Vec<Vec<bool>>>,
    ) -> Result<Self, InverseError> {
        let grid = BlockGrid::new(setup.dims, setup.spacing_mm)?;
        let terms = BoundaryTerms::new(setup.eta).map_err(|_| InverseError::InvalidSetting {
            what: "η",
            value: setup.eta,
            expected: "in [1, 4)",
        })?;
        if patterns.is_empty() {
            return Err(InverseError::NoPatterns);
        }
        if images.len() != patterns.len() {
            return Err(InverseError::PatternCountMismatch { images: images.len(), patterns: patterns.len() });
        }
        let [nx, ny, nz] = setup.dims;
        let h = setup.spacing_mm;
        let face = |k: usize| (0..nx * ny).map(|p| grid.node(p % nx, p / nx, k)).collect::<Vec<_>>();
        let lit_nodes = face(nz - 1);
        let observed_nodes = match setup.observation {
            Observation::FrontLit { margin_mm } => {
                if !(margin_mm.is_finite() && margin_mm >= 0.0) {
                    return Err(InverseError::InvalidSetting {
                        what: "front-lit margin (mm)",
                        value: margin_mm,
                        expected: "finite and ≥ 0",
                    });
                }
                lit_nodes.clone()
            }
            Observation::BackLit => face(0),
        };
        let lit_area = (0..nx * ny).map(|p| face_areas([p % nx, p / nx, nz - 1], setup.dims, h)[5]).collect();
        let face_q = patterns.iter().enumerate().map(|(m, p)| p.node_values(m, nx, ny, h)).collect::<Result<Vec<_>, _>>()?;
        for (m, img) in images.iter().enumerate() {
            if img.len() != nx * ny {
                return Err(InverseError::WrongImageSize {
                    what: "image",
                    index: m,
                    expected: nx * ny,
                    found: img.len(),
                    nx,
                    ny,
                });
            }
            check_pixels("image", m, img, false)?;
        }
        let mut combined = Vec::with_capacity(images.len());
        for m in 0..images.len() {
            let mut w = match &masks {
                Some(ms) => {
                    if ms.len() != images.len() {
                        return Err(InverseError::PatternCountMismatch { images: images.len(), patterns: ms.len() });
                    }
                    if ms[m].len() != nx * ny {
                        return Err(InverseError::WrongImageSize {
                            what: "mask",
                            index: m,
                            expected: nx * ny,
                            found: ms[m].len(),
                            nx,
                            ny,
                        });
                    }
                    ms[m].clone()
                }
                None => vec![true; nx * ny],
            };
            if let Observation::FrontLit { margin_mm } = setup.observation {
                for (w, keep) in w.iter_mut().zip(front_mask(&face_q[m], nx, ny, h, margin_mm)) {
                    *w &= keep;
                }
            }
            combined.push(w);
        }
        let norm = data_norm(&images, &combined);
        for (channel, &d) in norm.iter().enumerate() {
            if combined.iter().all(|w| w.iter().all(|&k| !k)) {
                return Err(InverseError::EmptyMask { channel, reason: "every pixel of every image is masked" });
            }
            if !(d > 0.0) {
                return Err(InverseError::EmptyMask { channel, reason: "the unmasked pixels are all zero" });
            }
        }
        let m = images.len();
        let n = grid.node_count();
        let smoothness = Smoothness::new(&grid);
        Ok(Self {
            setup,
            grid,
            terms,
            face_q,
            lit_nodes,
            observed_nodes,
            lit_area,
            data: images,
            masks: combined,
            norm,
            smoothness,
            lambda: 0.0,
            solve: SolveSettings::default(),
            phi: vec![vec![[0.0; 3]; n]; m],
            phi_at: None,
            psi: vec![vec![[0.0; 3]; n]; m],
            counts: WorkCounts::default(),
        })
    }

    /// The setup.
    #[must_use]
    pub fn setup(&self) -> &Setup {
        &self.setup
    }

    /// The node grid.
    #[must_use]
    pub fn grid(&self) -> &BlockGrid {
        &self.grid
    }

    /// The number of images M.
    #[must_use]
    pub fn image_count(&self) -> usize {
        self.data.len()
    }

    /// The fitted pixels of each image (the masks after the front-lit margin).
    #[must_use]
    pub fn masks(&self) -> &[Vec<bool>] {
        &self.masks
    }

    /// D per channel: Σ_m ‖W_m L̂_m‖².
    #[must_use]
    pub fn data_norm(&self) -> [f64; 3] {
        self.norm
    }

    /// The work done so far.
    #[must_use]
    pub fn counts(&self) -> WorkCounts {
        self.counts
    }

    /// The regularisation weight λ.
    #[must_use]
    pub fn lambda(&self) -> f64 {
        self.lambda
    }

    /// Sets λ.
    ///
    /// # Errors
    /// [`InverseError::NegativeLambda`] unless finite and ≥ 0.
    pub fn set_lambda(&mut self, lambda: f64) -> Result<(), InverseError> {
        if !(lambda.is_finite() && lambda >= 0.0) {
            return Err(InverseError::NegativeLambda(lambda));
        }
        self.lambda = lambda;
        Ok(())
    }

    /// The reference κ that makes the regulariser unit-free (see [`Smoothness`]).
    pub fn set_kappa_reference(&mut self, kappa: [f64; 3]) {
        self.smoothness.set_reference(kappa);
    }

    /// The solves' settings.
    ///
    /// # Errors
    /// [`InverseError::InvalidSetting`] for a tolerance not in (0, 1) or a zero iteration cap.
    pub fn set_solve_settings(&mut self, s: SolveSettings) -> Result<(), InverseError> {
        if !(s.tolerance > 0.0 && s.tolerance < 1.0) {
            return Err(InverseError::InvalidSetting { what: "solve tolerance", value: s.tolerance, expected: "in (0, 1)" });
        }
        if s.max_iterations == 0 {
            return Err(InverseError::InvalidSetting { what: "solve iteration cap", value: 0.0, expected: "≥ 1" });
        }
        self.solve = s;
        Ok(())
    }

    /// The right-hand side of image m: S_i^lit Q_i/(2A) at the lit-face nodes.
    pub(super) fn rhs(&self, m: usize) -> Vec<[f64; 3]> {
        let mut b = vec![[0.0; 3]; self.grid.node_count()];
        for ((&i, &s), q) in self.lit_nodes.iter().zip(&self.lit_area).zip(&self.face_q[m]) {
            b[i] = q.map(|q| s * self.terms.fluence_source(q) / (2.0 * self.terms.a));
        }
        b
    }

    /// The query's factors (s, t): L = s φ − t q.
    pub(super) fn query(&self) -> (f64, f64) {
        let f = self.terms.ft_normal / (4.0 * std::f64::consts::PI);
        (f * (1.0 + 1.0 / self.terms.a), f * 4.0 / (1.0 + self.terms.fdr))
    }

    /// q on the observed face of image m (0 for a back-lit camera).
    fn observed_q(&self, m: usize, pixel: usize) -> [f64; 3] {
        match self.setup.observation {
            Observation::FrontLit { .. } => self.face_q[m][pixel],
            Observation::BackLit => [0.0; 3],
        }
    }

    /// The system matrix of `media`.
    pub(super) fn matrix(&self, media: &CellMedia) -> CsrMatrix3 {
        self.grid.matrix(&media.kappa(), &media.sigma_a, self.terms.a)
    }

    /// Solves A x_m = b_m for every image in parallel from the given starts.
    pub(super) fn solve_all(
        &mut self,
        a: &CsrMatrix3,
        rhs: &[Vec<[f64; 3]>],
        x: &mut [Vec<[f64; 3]>],
        what: &'static str,
    ) -> Result<(), InverseError> {
        let pre = Preconditioner::new(a, PreconditionerKind::Jacobi)?;
        let precision = if self.solve.tolerance < 1e-7 { Precision::Double } else { Precision::Mixed };
        let options = SolveOptions::default()
            .with_tolerance(self.solve.tolerance)
            .with_max_iterations(self.solve.max_iterations)
            .with_precision(precision);
        let results: Vec<Result<usize, InverseError>> = x
            .par_iter_mut()
            .zip(rhs.par_iter())
            .enumerate()
            .map(|(image, (x, b))| {
                let stats = pcg(a, b, x, &pre, &options).map_err(|source| InverseError::Solve { what, image, source })?;
                if !stats.converged {
                    let residual = stats.relative_residual.iter().fold(0.0f64, |m, &r| m.max(r));
                    return Err(InverseError::NotConverged { what, image, residual });
                }
                Ok(stats.iterations.into_iter().max().unwrap_or(0))
            })
            .collect();
        for r in results {
            self.counts.pcg_iterations += r?;
        }
        if what == "forward" {
            self.counts.forward_solves += rhs.len();
        } else {
            self.counts.adjoint_solves += rhs.len();
        }
        Ok(())
    }

    /// The forward solutions φ_m at `x` (log parameters), warm-started from the last ones;
    /// reused as they are when `x` is where they were computed.
    pub(super) fn forward(&mut self, x: &[f64]) -> Result<CellMedia, InverseError> {
        let media = self.media_of(x)?;
        if self.phi_at.as_deref() == Some(x) {
            return Ok(media);
        }
        let a = self.matrix(&media);
        let rhs: Vec<_> = (0..self.image_count()).map(|m| self.rhs(m)).collect();
        let mut phi = std::mem::take(&mut self.phi);
        self.phi_at = None;
        let r = self.solve_all(&a, &rhs, &mut phi, "forward");
        self.phi = phi;
        r?;
        self.phi_at = Some(x.to_vec());
        Ok(media)
    }

    /// The media of `x`, checked against the grid.
    pub(super) fn media_of(&self, x: &[f64]) -> Result<CellMedia, InverseError> {
        if x.len() != 6 * self.grid.cell_count() {
            return Err(InverseError::InvalidParameters(format!(
                "{} entries for {} cells (6 per cell)",
                x.len(),
                self.grid.cell_count()
            )));
        }
        CellMedia::from_log_vector(x)
    }

    /// The predicted images of the last forward solve, L_m = s φ_m − t q_m.
    pub(super) fn predicted(&self) -> Vec<Vec<[f64; 3]>> {
        let (s, t) = self.query();
        (0..self.image_count())
            .map(|m| {
                self.observed_nodes
                    .iter()
                    .enumerate()
                    .map(|(p, &i)| {
                        let q = self.observed_q(m, p);
                        std::array::from_fn(|c| s * self.phi[m][i][c] - t * q[c])
                    })
                    .collect()
            })
            .collect()
    }

    /// The predicted images of `media` (every pixel, masked or not).
    ///
    /// # Errors
    /// [`InverseError::InvalidParameters`] for media of the wrong size or invalid values; a
    /// solver error.
    pub fn predict(&mut self, media: &CellMedia) -> Result<Vec<Vec<[f64; 3]>>, InverseError> {
        let bad = media.sigma_a.iter().chain(&media.sigma_s_prime).flatten().any(|v| !(v.is_finite() && *v > 0.0));
        if bad {
            return Err(InverseError::InvalidParameters("σa and σ′s must be finite and > 0".into()));
        }
        let x = media.to_log_vector();
        self.forward(&x)?;
        Ok(self.predicted())
    }

    /// The objective at `x` (log parameters): one forward solve per image.
    ///
    /// # Errors
    /// [`InverseError::InvalidParameters`]; a solver error.
    pub fn evaluate(&mut self, x: &[f64]) -> Result<Evaluation, InverseError> {
        let media = self.forward(x)?;
        Ok(self.evaluation(&media, &self.predicted()))
    }

    /// The objective's parts for the predicted images `pred` of `media`.
    pub(super) fn evaluation(&self, media: &CellMedia, pred: &[Vec<[f64; 3]>]) -> Evaluation {
        let mut misfit = [0.0; 3];
        for ((p, d), w) in pred.iter().zip(&self.data).zip(&self.masks) {
            for ((p, d), &w) in p.iter().zip(d).zip(w) {
                if w {
                    for c in 0..3 {
                        misfit[c] += (p[c] - d[c]).powi(2);
                    }
                }
            }
        }
        let misfit: [f64; 3] = std::array::from_fn(|c| misfit[c] / self.norm[c]);
        let regulariser = self.smoothness.value(&media.kappa());
        let value = (0..3).map(|c| misfit[c] + self.lambda * regulariser[c]).sum();
        Evaluation { value, misfit, regulariser }
    }
}

/// D per channel: Σ_m Σ_pixels W L̂² (the objective's normalisation, P9).
#[must_use]
pub fn data_norm(images: &[Vec<[f64; 3]>], masks: &[Vec<bool>]) -> [f64; 3] {
    let mut d = [0.0; 3];
    for (img, w) in images.iter().zip(masks) {
        for (p, &w) in img.iter().zip(w) {
            if w {
                for c in 0..3 {
                    d[c] += p[c] * p[c];
                }
            }
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_vectors_round_trip() {
        let m = CellMedia {
            sigma_a: vec![[0.1, 0.2, 0.3], [1.0, 2.0, 3.0]],
            sigma_s_prime: vec![[4.0, 5.0, 6.0], [0.5, 0.25, 0.125]],
        };
        let back = CellMedia::from_log_vector(&m.to_log_vector()).unwrap();
        for (a, b) in back.sigma_a.iter().flatten().zip(m.sigma_a.iter().flatten()) {
            assert!((a - b).abs() < 1e-14);
        }
        assert!(CellMedia::from_log_vector(&[0.0; 5]).is_err());
        assert!(CellMedia::from_log_vector(&[f64::NAN; 6]).is_err());
    }

    #[test]
    fn dkappa_is_the_derivative_of_kappa() {
        let (a, s, e) = (0.05, 1.3, 1e-6);
        let fd = (kappa(a + e, s) - kappa(a - e, s)) / (2.0 * e);
        assert!((fd - dkappa(kappa(a, s))).abs() < 1e-8);
    }

    #[test]
    fn data_norm_counts_unmasked_pixels_only() {
        let d = data_norm(&[vec![[1.0, 2.0, 3.0], [10.0; 3]]], &[vec![true, false]]);
        assert_eq!(d, [1.0, 4.0, 9.0]);
    }
}
