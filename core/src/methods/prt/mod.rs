//! Precomputed translucent transfer (R. Wang et al. 2008) behind the method contract: the dipole
//! of a homogeneous medium in a PCA basis, its transfer from surface samples to the vertices
//! precomputed once ([`crate::prt`]), so that a material edit is a K-term re-weighting per
//! vertex and a relight one sparse product per vertex.
//!
//! - `check`: one homogeneous medium (the basis is of the half-space dipole of one medium) that
//!   the basis represents (projection residual ≤ [`MAX_RESIDUAL`] in every channel) and the
//!   samples resolve (σ′t h ≤ [`MAX_RESOLUTION`], h the sample spacing in mm), each refused by
//!   name, never baked as a wrong picture;
//! - `prepare`: the samples and the compressed transfer over the world surface in millimetres;
//! - `solve`: q at the samples along their interpolated normals (shadows by every object), its
//!   Haar transform, the transfer's product and Lo = C(η) Σₖ sₖ vₖ at the user's vertices
//!   (C(η) = T(η, 0)/(π η² (1 − Fdr)), ARCHITECTURE.md "What a bake returns").
//!
//! What the method models: the same as the hierarchical dipole (Euclidean distances, light
//! crossing air gaps, a closed object's trapped light missing: 0.90 of TransCut on the 10 mm
//! marble sphere), plus the basis's truncation (≤ 9e-4 for the presets with K = 16) and the
//! compression's (the dropped energy is in the statistics).

mod device;
mod live;

pub use live::{PrtLive, PrtUndo};

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use glam::DVec3;
use rayon::prelude::*;

use super::{BakedState, Lighting, ObjectStats, Stage, SubsurfaceMethod, Target};
use crate::light::{Light, LightError};
use crate::mesh::TriMesh;
use crate::optics::{fdr, ft_out, Medium};
use crate::progress::ms;
use crate::prt::{
    cells, haar_irradiance, io, BasisSize, PrecomputeFileError, PrecomputeKey, PrtCache, PrtError, PrtOptions, RdBasis,
    SurfaceSamples, Transfer, TransferStats,
};
use crate::scene::SceneError;

/// The method's name.
pub const NAME: &str = "prt";

/// The largest relative residual of a medium's projection onto the basis (per channel) that a
/// bake or an edit accepts.
pub const MAX_RESIDUAL: f64 = 0.05;

/// The largest σ′t h (h the sample spacing in mm) a bake or an edit accepts: beyond it the
/// samples no longer resolve the profile's z_r-wide peak even with the near-field correction
/// (design/prt.md §1.3: h ≤ 3 z_r keeps the error ≲ 0.5%).
pub const MAX_RESOLUTION: f64 = 3.0;

/// The PRT method ([`SubsurfaceMethod`]).
pub struct Prt;

/// What a PRT bake keeps of one object ([`super::ObjectBake::state`]).
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct PrtState {
    /// The compressed transfer from the samples to the receivers (shared by copies of the
    /// state: it depends on the geometry alone).
    pub transfer: Arc<Transfer>,
    /// The irradiance samples (millimetres).
    pub samples: Arc<SurfaceSamples>,
    /// The object's surface in world space (scene units), for its own shadows in updates.
    pub surface: Arc<TriMesh>,
    /// The object's medium.
    pub medium: Medium,
    /// Millimetres per scene unit the transfer was computed at.
    pub transfer_mm_per_unit: f64,
    /// Millimetres per scene unit now (a change is the edit σ → σ s of the transfer's medium).
    pub mm_per_unit: f64,
    /// The basis weights sₖ per channel of the medium at the current scale.
    pub(crate) weights: [Vec<f64>; 3],
    /// The projection's residual per channel.
    pub residual: [f64; 3],
    /// q at the samples under the last lights.
    pub(crate) irradiance: Vec<[f64; 3]>,
    /// (Tₖ^w q^w) per receiver, basis function and channel.
    pub(crate) gathered: Vec<f64>,
    /// Per output vertex, the receiver whose radiance it takes (`None`: inside a tet mesh, 0).
    pub(crate) output: Vec<Option<u32>>,
    /// The environment lights' per-sample SH transfer ([`crate::prt::env`]): made on the first
    /// gather under an environment, for the occluder that gather is given (and made again when
    /// another is given); a copy of the state starts with the transfer made so far.
    pub env_sh: crate::prt::env::EnvShCache,
    /// What the transfer depends on, hashed: the name of its saved file.
    pub key: PrecomputeKey,
    /// The options the transfer was computed with (without a cache).
    pub options: PrtOptions,
    /// Where the transfer's product runs ([`device`]).
    pub(crate) device: device::PrtDevice,
}

impl PrtState {
    /// The refractive index at the surface.
    #[must_use]
    pub fn eta(&self) -> f64 {
        self.medium.eta
    }

    /// The basis of the transfer's rows (its options').
    #[must_use]
    pub fn basis(&self) -> BasisSize {
        self.options.basis
    }

    /// What the precompute measured.
    #[must_use]
    pub fn transfer_stats(&self) -> &TransferStats {
        self.transfer.stats()
    }

    /// Saves the precomputed transfer to `path` (a `.tcprt` file, [`crate::prt::io`]), for a
    /// later bake of the same surface and options to read ([`crate::prt::PrtCache`]).
    ///
    /// # Errors
    /// [`PrtError::File`] when the file cannot be written.
    pub fn save(&self, path: &Path) -> Result<(), PrtError> {
        Ok(io::write(path, self.key, &self.options, self.transfer_mm_per_unit, &self.transfer)?)
    }

    /// The medium the transfer sees at the current scale: σ multiplied by mm_per_unit over the
    /// transfer's.
    fn scaled_medium(medium: &Medium, scale: f64) -> Medium {
        Medium { sigma_a: medium.sigma_a.map(|s| s * scale), sigma_s_prime: medium.sigma_s_prime.map(|s| s * scale), ..*medium }
    }

    /// The weights of `medium` at `mm_per_unit` (the projection onto the basis, step 3 of the
    /// paper's §3.3), or why the transfer cannot take it.
    pub(crate) fn weights_of(&self, medium: &Medium, mm_per_unit: f64) -> Result<([Vec<f64>; 3], [f64; 3]), PrtError> {
        weights_of(&self.samples, self.basis(), medium, mm_per_unit / self.transfer_mm_per_unit)
    }

    /// Lo at the output vertices from the state's weights and gathered products, clamped at 0,
    /// with the number of output vertices the clamp changed.
    pub(crate) fn radiance(&self) -> (Vec<[f64; 3]>, usize) {
        radiance(&self.gathered, &self.weights, self.medium.eta, &self.output)
    }

    /// q at the samples under `lighting` (scene units: the samples' millimetres over the
    /// transfer's scale): delta lights (hard shadows) as their samples' pieces' means where a
    /// shadow's edge crosses them ([`cells`]), environments through the samples' SH transfer
    /// ([`crate::prt::env`]), every other light by [`crate::light::transmitted_source`].
    pub(crate) fn irradiance(
        &self,
        lighting: &Lighting<'_>,
        eta: f64,
        poll: crate::light::Poll<'_>,
    ) -> Result<Vec<[f64; 3]>, LightError> {
        let points: Vec<DVec3> = self.samples.positions.iter().map(|p| *p / self.transfer_mm_per_unit).collect();
        let (lights, normals, occluder) = (lighting.lights, &self.samples.normals, lighting.occluder);
        let (hard, smooth): (Vec<Light>, Vec<Light>) = lights.iter().cloned().partition(Light::is_delta);
        if occluder.is_none() || hard.is_empty() {
            return self.env_sh.transmitted_source(lights, &points, normals, eta, occluder, lighting.source, poll);
        }
        let (surface, source) = (&self.surface, lighting.source);
        let mut q = cells::cell_irradiance(
            &self.samples,
            surface.positions(),
            surface.triangles(),
            &points,
            &hard,
            eta,
            occluder,
            source,
            &|f| poll(if smooth.is_empty() { f } else { 0.5 * f }),
        )?;
        if !smooth.is_empty() {
            let rest =
                self.env_sh.transmitted_source(&smooth, &points, normals, eta, occluder, source, &|f| poll(0.5 + 0.5 * f))?;
            crate::light::add_irradiance(&mut q, &rest);
        }
        Ok(q)
    }

    /// Sets `gathered` to the transfer's product with the irradiance `q` at the samples: (Tₖ q)[v]
    /// per receiver, basis function and channel, written over the buffer already there (a
    /// relight touches no fresh memory: on the bunny, 14 MB of page faults).
    pub(crate) fn set_product(&mut self, q: &[[f64; 3]]) {
        self.gathered.resize(self.transfer.vertices() * self.transfer.basis_terms() * 3, 0.0);
        self.device.apply(&self.transfer, &haar_irradiance(q), &mut self.gathered);
    }
}

/// The basis weights of `medium` with its coefficients scaled by `scale`, checked against the
/// basis ([`MAX_RESIDUAL`]) and the samples ([`MAX_RESOLUTION`]).
fn weights_of(
    samples: &SurfaceSamples,
    basis: BasisSize,
    medium: &Medium,
    scale: f64,
) -> Result<([Vec<f64>; 3], [f64; 3]), PrtError> {
    weights_for(basis, &PrtState::scaled_medium(medium, scale), samples.spacing(), samples.len())
}

/// The basis weights of `medium` for `count` samples `spacing` mm apart, or why the transfer
/// cannot take it: σ′t h above [`MAX_RESOLUTION`], a projection residual above [`MAX_RESIDUAL`].
fn weights_for(basis: BasisSize, medium: &Medium, spacing: f64, count: usize) -> Result<([Vec<f64>; 3], [f64; 3]), PrtError> {
    medium.validate().map_err(|e| PrtError::Medium(e.to_string()))?;
    for c in 0..3 {
        let sigma_t = medium.sigma_a[c] + medium.sigma_s_prime[c];
        if sigma_t * spacing > MAX_RESOLUTION {
            return Err(PrtError::Medium(format!(
                "channel {c}: σ′t = {sigma_t:.3}/mm is too dense for {count} samples {spacing:.3} mm apart (σ′t h = {:.2} > \
                 {MAX_RESOLUTION}): bake with more samples (samples_log2) or use transcut",
                sigma_t * spacing
            )));
        }
    }
    let basis = RdBasis::get(basis);
    let (weights, residual) = basis.project_medium(medium);
    for (c, r) in residual.iter().enumerate() {
        if !(*r <= MAX_RESIDUAL) {
            return Err(PrtError::Medium(format!(
                "channel {c}: the {}-term basis represents this medium's profile only to {:.1}% (at most {:.0}%): σa = {:.3e}, \
                 σ′s = {:.3e}/mm are outside the media it was trained on",
                basis.terms(),
                100.0 * r,
                100.0 * MAX_RESIDUAL,
                medium.sigma_a[c],
                medium.sigma_s_prime[c]
            )));
        }
    }
    Ok((weights, residual))
}

/// The transfer of `key` from `cache` when it holds it (and whether it did), else `compute`d and
/// written there. For [`PrtCache::File`] an existing file must be this transfer's (its absence
/// alone means "precompute"); in a [`PrtCache::Folder`] an unreadable entry (another version, a
/// damaged file) is replaced.
fn cached_transfer(
    cache: Option<&PrtCache>,
    key: PrecomputeKey,
    options: &PrtOptions,
    mm_per_unit: f64,
    compute: impl FnOnce() -> Result<Transfer, PrtError>,
) -> Result<(Transfer, bool), PrtError> {
    let Some(cache) = cache else { return Ok((compute()?, false)) };
    let path = match cache {
        PrtCache::Folder(dir) => dir.join(format!("{key}.tcprt")),
        PrtCache::File(path) => path.clone(),
    };
    match io::read(&path, key) {
        Ok(transfer) => return Ok((transfer, true)),
        Err(PrecomputeFileError::Io { source, .. }) if source.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) if matches!(cache, PrtCache::File(_)) => return Err(e.into()),
        Err(_) => {}
    }
    let transfer = compute()?;
    if let PrtCache::Folder(dir) = cache {
        std::fs::create_dir_all(dir).map_err(|source| PrtError::File(PrecomputeFileError::Io { path: dir.clone(), source }))?;
    }
    io::write(&path, key, options, mm_per_unit, &transfer)?;
    Ok((transfer, false))
}

/// Lo per output vertex: C(η) Σₖ sₖ,c (Tₖ q)[v, c], clamped at 0; how many the clamp changed.
fn radiance(gathered: &[f64], weights: &[Vec<f64>; 3], eta: f64, output: &[Option<u32>]) -> (Vec<[f64; 3]>, usize) {
    let k = weights[0].len();
    let per_exitance = radiance_per_exitance(eta);
    let per_vertex: Vec<([f64; 3], bool)> = output
        .par_iter()
        .map(|v| {
            let Some(v) = v else { return ([0.0; 3], false) };
            let g = &gathered[*v as usize * k * 3..(*v as usize + 1) * k * 3];
            let lo: [f64; 3] = [0, 1, 2].map(|c| per_exitance * (0..k).map(|j| weights[c][j] * g[j * 3 + c]).sum::<f64>());
            (lo.map(|x| x.max(0.0)), lo.iter().any(|x| *x < 0.0))
        })
        .collect();
    let clamped = per_vertex.iter().filter(|(_, negative)| *negative).count();
    (per_vertex.into_iter().map(|(lo, _)| lo).collect(), clamped)
}

/// Lo(x, n) per unit exitance B at index `eta`: C(η) = T(η, 0)/(π η² (1 − Fdr)), the
/// energy-consistent constant of the dipole methods (ARCHITECTURE.md; 0.33345 at η = 1.3).
#[must_use]
pub fn radiance_per_exitance(eta: f64) -> f64 {
    ft_out(eta, 1.0) / (std::f64::consts::PI * (1.0 - fdr(eta)))
}

/// The scene error of a PRT error of object `target`.
pub(crate) fn scene_error(target: &Target<'_>, e: PrtError) -> SceneError {
    match e {
        PrtError::Cancelled(c) => SceneError::Cancelled(c),
        PrtError::Medium(reason) => {
            SceneError::Unsupported { index: target.index, name: target.object.name.clone(), method: NAME, reason }
        }
        e => target.invalid(e.to_string()),
    }
}

impl SubsurfaceMethod for Prt {
    type Options = PrtOptions;
    type State = PrtState;

    fn check(target: &Target<'_>, options: &PrtOptions) -> Result<(), SceneError> {
        options.validate().map_err(SceneError::InvalidOptions)?;
        target.medium(NAME)?;
        let unsupported =
            |reason| SceneError::Unsupported { index: target.index, name: target.object.name.clone(), method: NAME, reason };
        let medium = super::homogeneous_medium(target.object).map_err(unsupported)?;
        // The samples' spacing √(A/N) of the world surface in millimetres, before they exist.
        let mm = target.object.mm_per_unit;
        let count = 1usize << options.samples_log2;
        let h = (target.world.area() * mm * mm / count as f64).sqrt();
        weights_for(options.basis, &medium, h, count).map_err(|e| scene_error(target, e))?;
        Ok(())
    }

    fn prepare(
        target: &Target<'_>,
        options: &PrtOptions,
        stats: &mut ObjectStats,
        stage: Stage<'_>,
    ) -> Result<PrtState, SceneError> {
        stage("samples", 0.0)?;
        let t = Instant::now();
        let medium = super::homogeneous_medium(target.object).map_err(|reason| target.invalid(reason))?;
        medium.validate().map_err(|e| target.invalid(format!("medium: {e}")))?;
        let mm = target.object.mm_per_unit;
        let surface = target.world;
        let positions: Vec<DVec3> = surface.positions().iter().map(|p| *p * mm).collect();
        let samples = SurfaceSamples::new(&positions, surface.triangles(), options.samples_log2, options.seed)
            .map_err(|e| scene_error(target, e))?;
        let output = super::output_map(target.object, surface);
        // The receivers: the surface vertices some output vertex takes its radiance from.
        let mut receiver_of = vec![u32::MAX; positions.len()];
        let mut receivers = Vec::new();
        for v in output.iter().flatten() {
            if receiver_of[*v as usize] == u32::MAX {
                receiver_of[*v as usize] = receivers.len() as u32;
                receivers.push(positions[*v as usize]);
            }
        }
        let output: Vec<Option<u32>> = output.iter().map(|v| v.map(|v| receiver_of[v as usize])).collect();
        stats.meshing_ms = ms(t);
        stage("transfer", 0.05)?;
        let t = Instant::now();
        let basis = RdBasis::get(options.basis);
        let key = PrecomputeKey::new(&positions, surface.triangles(), &receivers, options);
        let uncached = PrtOptions { cache: None, ..options.clone() };
        let (transfer, loaded) = cached_transfer(options.cache.as_ref(), key, &uncached, mm, || {
            Transfer::precompute(&receivers, &positions, surface.triangles(), &samples, basis, options, &|f| {
                stage("transfer", 0.05 + 0.85 * f)
            })
        })
        .map_err(|e| scene_error(target, e))?;
        stats.precompute_loaded = loaded;
        stats.assembly_ms = ms(t);
        stats.vertices = receivers.len();
        stats.boundary_vertices = receivers.len();
        let (weights, residual) = weights_of(&samples, options.basis, &medium, 1.0).map_err(|e| scene_error(target, e))?;
        let h = samples.spacing();
        stats.resolution = [0, 1, 2].map(|c| (medium.sigma_a[c] + medium.sigma_s_prime[c]) * h);
        let (device, fallback) = device::PrtDevice::choose(&transfer).map_err(|source| SceneError::Gpu {
            index: target.index,
            name: target.object.name.clone(),
            source,
        })?;
        if let Some(name) = device.name() {
            stats.backend = crate::gpu::Backend::Gpu;
            stats.device = Some(name);
        }
        stats.backend_fallback = fallback;
        Ok(PrtState {
            transfer: Arc::new(transfer),
            samples: Arc::new(samples),
            surface: Arc::new(surface.clone()),
            medium,
            transfer_mm_per_unit: mm,
            mm_per_unit: mm,
            weights,
            residual,
            irradiance: Vec::new(),
            gathered: Vec::new(),
            output,
            env_sh: crate::prt::env::EnvShCache::default(),
            key,
            options: uncached,
            device,
        })
    }

    fn solve(
        _target: &Target<'_>,
        state: &mut PrtState,
        lighting: &Lighting<'_>,
        _options: &PrtOptions,
        stats: &mut ObjectStats,
        stage: Stage<'_>,
    ) -> Result<Vec<[f64; 3]>, SceneError> {
        stage("light", 0.9)?;
        let t = Instant::now();
        let q = state.irradiance(lighting, state.medium.eta, &|f| stage("light", 0.9 + 0.09 * f))?;
        stats.source_ms = ms(t);
        let t = Instant::now();
        state.set_product(&q);
        state.irradiance = q;
        if let Some(why) = state.device.failure() {
            (stats.backend, stats.device, stats.backend_fallback) = (crate::gpu::Backend::Cpu, None, Some(why));
        }
        let (radiance, clamped) = state.radiance();
        stats.solve_ms = ms(t);
        stats.clamped_vertices = clamped;
        Ok(radiance)
    }

    fn into_baked(state: PrtState) -> BakedState {
        BakedState::Prt(state)
    }
}
