//! The transmitted source q(x) = ∫ Li(x, ω) (n·ω)⁺ T(η, ω) dω and the irradiance
//! E(x) = ∫ Li(x, ω) (n·ω)⁺ dω at surface points, with optional shadows.

use crate::input::{fmt_num, fmt_vec};
use std::f64::consts::PI;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use glam::DVec3;
use rayon::prelude::*;

use super::environment::{Environment, EquirectMap};
use super::error::LightError;
use super::polygon::polygon_irradiance;
use super::sampling::{concentric_disc, cosine_hemisphere, hash_combine, orthonormal_basis, Pattern};
use super::sh::{cosine_lobe, fresnel_cosine_lobe, sh9_convolve};
use super::shaft::Shaft;
use super::{validate_lights, Light};
use crate::mesh::TriangleBvh;
use crate::optics::{fresnel_transmittance, ETA_MAX, ETA_MIN};
use crate::progress::Cancelled;

/// A progress check: called with the fraction of the points done, `Err` stops the work.
pub type Poll<'a> = &'a (dyn Fn(f64) -> Result<(), Cancelled> + Sync);

/// Samples drawn between two looks at the stop flag and the clock inside one point's estimate,
/// so that a point of a million samples is interrupted too.
const SAMPLES_PER_CHECK: usize = 1024;

/// The least time between two calls of the progress check: often enough that a cancel is seen
/// well within 0.1 s, seldom enough that the callback costs nothing next to the sampling.
const POLL_EVERY: Duration = Duration::from_millis(10);

/// Points per work item and per progress count: the shared counter and the clock are touched
/// once per chunk, not per point (per point, two threads contending for them cost more than a
/// shadow ray).
const POINTS_PER_TICK: usize = 64;

/// Shadow rays towards a light at a finite distance stop this fraction short of it, so that
/// geometry coinciding with the light's own surface does not shadow it.
const SHADOW_END: f64 = 1.0 - 1e-6;

/// How an environment map is integrated where nothing can shadow it (no occluder).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[non_exhaustive]
pub enum EnvironmentMethod {
    /// Convolve the map's SH9 projection with the (Fresnel-weighted) cosine lobe: smooth,
    /// noise-free and cheap, exact for the l ≤ 2 content of the map and for any constant map;
    /// detail of higher frequency (a small bright sun in the map) is blurred
    /// ([`super::sh`] and the notes on [`transmitted_source`]).
    #[default]
    Sh9,
    /// Importance-sample the map as in the shadowed case (`environment_samples` per point),
    /// just without shadow rays: unbiased for any map, at the cost of noise.
    Sampled,
}

/// Sampling and shadowing parameters of [`transmitted_source`] and [`irradiance`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SourceOptions {
    /// Samples per point for each area light and each sun with a non-zero angular diameter
    /// (≥ 1 when there are such lights), at most [`SourceOptions::MAX_SAMPLES`].
    pub area_samples: usize,
    /// Samples per point for each environment that is sampled: every environment when there is
    /// an occluder, equirect maps also with [`EnvironmentMethod::Sampled`] (≥ 1 then), at most
    /// [`SourceOptions::MAX_SAMPLES`].
    pub environment_samples: usize,
    /// Offset of the shadow-ray origins along the normal, as a fraction of the occluder's
    /// bounding-box diagonal (finite, ≥ 0).
    pub shadow_bias: f64,
    /// Seed of every sample pattern; the same seed gives the same result.
    pub seed: u64,
    /// How equirect environments are integrated when there is no occluder.
    pub unshadowed_environment: EnvironmentMethod,
}

impl Default for SourceOptions {
    /// 64 area samples, 256 environment samples, bias 10⁻⁴ of the diagonal, seed 0, SH9 for
    /// unshadowed environment maps.
    fn default() -> Self {
        Self {
            area_samples: 64,
            environment_samples: 256,
            shadow_bias: 1e-4,
            seed: 0,
            unshadowed_environment: EnvironmentMethod::Sh9,
        }
    }
}

impl SourceOptions {
    /// The most area or environment samples per point: 2²⁰. The noise of N stratified samples
    /// falls like 1/N or faster, so a million is far past visible noise, and a bake of 100k
    /// boundary points at this count is already hours of shadow rays.
    pub const MAX_SAMPLES: usize = 1 << 20;

    /// Checks what does not depend on the lights: a finite bias ≥ 0 and sample counts at most
    /// [`Self::MAX_SAMPLES`].
    ///
    /// # Errors
    /// [`LightError::InvalidOption`] naming the option, its value and the bound.
    pub fn validate(&self) -> Result<(), LightError> {
        if !(self.shadow_bias.is_finite() && self.shadow_bias >= 0.0) {
            return Err(LightError::InvalidOption {
                field: "shadow_bias",
                value: fmt_num(self.shadow_bias),
                requirement: "must be finite and ≥ 0".into(),
            });
        }
        for (field, value) in [("area_samples", self.area_samples), ("environment_samples", self.environment_samples)] {
            if value > Self::MAX_SAMPLES {
                return Err(LightError::InvalidOption {
                    field,
                    value: value.to_string(),
                    requirement: format!("must be at most {} (2^20)", Self::MAX_SAMPLES),
                });
            }
        }
        Ok(())
    }
}

/// Smooth edge of a spot light's cone, as Blender's spot blend: with cos ψ the cosine of the
/// angle between the spot's axis and the direction to the lit point, γ the cone half-angle and
/// b the blend,
///
/// s = 0 for cos ψ ≤ cos γ; s = smoothstep(t), t = (cos ψ − cos γ) / (b (1 − cos γ)) clamped to
/// [0, 1], smoothstep(t) = t²(3 − 2t), inside the cone (s = 1 everywhere inside when b = 0).
#[must_use]
pub fn spot_falloff(cos_psi: f64, cos_half_angle: f64, blend: f64) -> f64 {
    if cos_psi <= cos_half_angle {
        return 0.0;
    }
    let band = blend * (1.0 - cos_half_angle);
    if band <= 0.0 {
        return 1.0;
    }
    let t = ((cos_psi - cos_half_angle) / band).min(1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The transmitted source q(x) = ∫ Li(x, ω) (n·ω)⁺ T(η, ω) dω (per RGB channel) at every
/// point, the boundary source of the diffusion equation (ARCHITECTURE.md).
///
/// `points[i]` has the outward normal `normals[i]` (normalised here). T = 1 − R is the exact
/// unpolarised Fresnel transmittance of light entering the medium of index `eta` from air at
/// incidence cos θ = n·ω ([`fresnel_transmittance`]`(n·ω, eta)`). With an `occluder`, shadow
/// rays leave from x + b·n, b = `options.shadow_bias` × the occluder's bounding-box diagonal,
/// towards the light (to infinity for suns and environments); a blocked ray contributes 0.
///
/// Per light:
/// - delta directional, point, spot: exact (one shadow ray);
/// - a sun of angular diameter 2α: `area_samples` stratified directions in its cone, drawn in
///   proportion to the solid angle projected on the cone's axis (radiance E/(π sin²α)), so a
///   surface facing an unshadowed sun gets E·T exactly when T is constant;
/// - rectangle and disc lights: `area_samples` stratified points, uniform by area, estimator
///   L (n·ω)⁺ T cos θ_l A / d² (cos θ_l at the light; |cos θ_l| when two-sided). Where no
///   occluder triangle meets the shaft from the point to the light (the convex hull of the two;
///   for a disc, of its circumscribed square) no shadow ray is cast, and the irradiance of a
///   rectangle seen whole is exact instead, Lambert's polygon formula clipped to the horizon
///   ([`super::polygon`]): the estimate's limit without its noise;
/// - constant environment L: unshadowed, exactly π L (1 − F_ext(η)) (∫(n·ω)⁺T dω =
///   π(1 − F_ext)); shadowed, `environment_samples` stratified cosine-weighted directions,
///   estimator π L T(n·ω) V;
/// - equirect map, shadowed (or [`EnvironmentMethod::Sampled`]): ⌈N/2⌉ directions drawn from the
///   map (density ∝ luminance) and ⌊N/2⌋ cosine-weighted, combined by multiple importance
///   sampling with the balance heuristic (Veach 1997): Σ f(ω)/(n_map p_map(ω) + n_cos p_cos(ω)),
///   unbiased;
/// - equirect map, unshadowed with [`EnvironmentMethod::Sh9`]: Σ_lm Â_l(η) L_lm Y_lm(n), with
///   L_lm the map's exact SH9 projection and Â_l(η) the zonal coefficients of the lobe
///   μ⁺T(η, μ) ([`super::sh::fresnel_cosine_lobe`]). This drops the map's bands l ≥ 3. For the
///   plain cosine the neglected lobe energy is below 1% of Â₀ (Ramamoorthi & Hanrahan 2001),
///   and Fresnel weighting changes that little (it only trims grazing incidence); maps with a
///   small intense source are blurred, and SH ringing could make a channel slightly negative,
///   which is clamped to 0.
///
/// Samples are Owen-scrambled Sobol points keyed by (seed, light index, point index): the result
/// is deterministic and independent of the number of threads. Points are processed in parallel.
///
/// # Errors
/// [`LightError::InvalidEta`] unless η ∈ [ETA_MIN, ETA_MAX); [`LightError::LengthMismatch`];
/// [`LightError::InvalidPoint`] for a non-finite position or a zero / non-finite normal;
/// [`LightError::InvalidLight`] ([`Light::validate`]); [`LightError::InvalidOption`] for a
/// negative or non-finite bias or zero sample counts where samples are needed.
pub fn transmitted_source(
    lights: &[Light],
    points: &[DVec3],
    normals: &[DVec3],
    eta: f64,
    occluder: Option<&TriangleBvh>,
    options: &SourceOptions,
) -> Result<Vec<[f64; 3]>, LightError> {
    transmitted_source_with(lights, points, normals, eta, occluder, options, &|_| Ok(()))
}

/// [`transmitted_source`] with a progress check: `poll` is called with the fraction of the
/// points done, at most every 10 ms and at least that often while the work goes on (also inside
/// one point's samples); when it returns `Err` the work stops within a few thousand samples per
/// thread and the call returns [`LightError::Cancelled`].
///
/// # Errors
/// As [`transmitted_source`], plus [`LightError::Cancelled`].
pub fn transmitted_source_with(
    lights: &[Light],
    points: &[DVec3],
    normals: &[DVec3],
    eta: f64,
    occluder: Option<&TriangleBvh>,
    options: &SourceOptions,
    poll: Poll<'_>,
) -> Result<Vec<[f64; 3]>, LightError> {
    check_eta(eta)?;
    evaluate(lights, points, normals, Response::Transmitted(eta), occluder, options, poll)
}

/// [`LightError::InvalidEta`] unless η ∈ [ETA_MIN, ETA_MAX).
pub(crate) fn check_eta(eta: f64) -> Result<(), LightError> {
    if (ETA_MIN..ETA_MAX).contains(&eta) {
        Ok(())
    } else {
        Err(LightError::InvalidEta { value: eta, min: ETA_MIN, max: ETA_MAX })
    }
}

/// Per point and channel, a light's value with the occluder's shadows and without them.
pub type ShadowedAndUnshadowed = (Vec<[f64; 3]>, Vec<[f64; 3]>);

/// [`transmitted_source_with`] with the occluder's shadows and without them, (shadowed,
/// unshadowed), in one pass where every light is a delta light ([`Light::is_delta`]: each
/// light's value is computed once and its one shadow ray decides whether the shadowed sum takes
/// it; both equal the two calls' values bit for bit), in two calls otherwise.
///
/// # Errors
/// As [`transmitted_source_with`].
pub fn transmitted_source_and_unshadowed(
    lights: &[Light],
    points: &[DVec3],
    normals: &[DVec3],
    eta: f64,
    occluder: Option<&TriangleBvh>,
    options: &SourceOptions,
    poll: Poll<'_>,
) -> Result<ShadowedAndUnshadowed, LightError> {
    if !lights.iter().all(Light::is_delta) {
        let shadowed = transmitted_source_with(lights, points, normals, eta, occluder, options, &|f| poll(0.5 * f))?;
        let unshadowed = transmitted_source_with(lights, points, normals, eta, None, options, &|f| poll(0.5 + 0.5 * f))?;
        return Ok((shadowed, unshadowed));
    }
    check_eta(eta)?;
    evaluate_with(lights, points, normals, Response::Transmitted(eta), occluder, options, poll, true)
}

/// The irradiance E(x) = ∫ Li(x, ω) (n·ω)⁺ dω (per RGB channel) at every point: exactly
/// [`transmitted_source`] without the Fresnel factor (a constant environment gives π L; the SH9
/// path uses the clamped-cosine lobe (π, 2π/3, π/4)).
///
/// # Errors
/// As [`transmitted_source`], except for η.
pub fn irradiance(
    lights: &[Light],
    points: &[DVec3],
    normals: &[DVec3],
    occluder: Option<&TriangleBvh>,
    options: &SourceOptions,
) -> Result<Vec<[f64; 3]>, LightError> {
    evaluate(lights, points, normals, Response::Irradiance, occluder, options, &|_| Ok(()))
}

/// Adds the irradiance of more lights, `more`, to `q` (both per point and channel).
///
/// # Panics
/// If the two have other lengths.
pub fn add_irradiance(q: &mut [[f64; 3]], more: &[[f64; 3]]) {
    assert_eq!(q.len(), more.len(), "one irradiance per point");
    for (a, b) in q.iter_mut().zip(more) {
        for (ac, bc) in a.iter_mut().zip(b) {
            *ac += bc;
        }
    }
}

/// What is integrated against the incident radiance.
#[derive(Debug, Clone, Copy)]
enum Response {
    /// (n·ω)⁺.
    Irradiance,
    /// (n·ω)⁺ T(η, n·ω).
    Transmitted(f64),
}

impl Response {
    /// The factor T(η, cos θ) (1 for irradiance) at incidence cos θ > 0.
    fn transmittance(self, cos: f64) -> f64 {
        match self {
            Response::Irradiance => 1.0,
            Response::Transmitted(eta) => fresnel_transmittance(cos, eta),
        }
    }

    /// The lobe (n·ω)⁺ T(η, n·ω).
    fn weight(self, cos: f64) -> f64 {
        if cos > 0.0 {
            cos * self.transmittance(cos)
        } else {
            0.0
        }
    }

    /// Zonal SH coefficients Â₀..Â₂ of the lobe.
    fn lobe(self) -> [f64; 3] {
        match self {
            Response::Irradiance => cosine_lobe(),
            Response::Transmitted(eta) => fresnel_cosine_lobe(eta),
        }
    }
}

/// A light with its derived quantities, ready to evaluate at many points.
enum Prepared<'a> {
    Delta { to_light: DVec3, e: [f64; 3] },
    Sun { axis: DVec3, t: DVec3, b: DVec3, sin_alpha: f64, e: [f64; 3] },
    Point { position: DVec3, i: [f64; 3] },
    Spot { position: DVec3, axis: DVec3, i: [f64; 3], cos_half: f64, blend: f64 },
    Rect { center: DVec3, half_u: DVec3, half_v: DVec3, normal: DVec3, area: f64, l: [f64; 3], two_sided: bool },
    Disc { center: DVec3, normal: DVec3, t: DVec3, b: DVec3, radius: f64, area: f64, l: [f64; 3], two_sided: bool },
    ConstantEnv { l: [f64; 3], unshadowed: [f64; 3] },
    MapEnv { map: &'a EquirectMap, sh: [[f64; 9]; 3] },
}

impl<'a> Prepared<'a> {
    fn new(light: &'a Light, lobe: [f64; 3]) -> Self {
        match light {
            Light::Directional { direction, irradiance, angular_diameter_deg } => {
                let axis = -direction.normalize();
                if *angular_diameter_deg == 0.0 {
                    Prepared::Delta { to_light: axis, e: *irradiance }
                } else {
                    let (t, b) = orthonormal_basis(axis);
                    let sin_alpha = (0.5 * angular_diameter_deg).to_radians().sin();
                    Prepared::Sun { axis, t, b, sin_alpha, e: *irradiance }
                }
            }
            Light::Point { position, intensity } => Prepared::Point { position: *position, i: *intensity },
            Light::Spot { position, direction, intensity, cone_half_angle_deg, blend } => Prepared::Spot {
                position: *position,
                axis: direction.normalize(),
                i: *intensity,
                cos_half: cone_half_angle_deg.to_radians().cos(),
                blend: *blend,
            },
            Light::RectArea { center, half_u, half_v, radiance, two_sided } => {
                let n = half_u.cross(*half_v);
                Prepared::Rect {
                    center: *center,
                    half_u: *half_u,
                    half_v: *half_v,
                    normal: n.normalize(),
                    area: 4.0 * n.length(),
                    l: *radiance,
                    two_sided: *two_sided,
                }
            }
            Light::DiscArea { center, normal, radius, radiance, two_sided } => {
                let normal = normal.normalize();
                let (t, b) = orthonormal_basis(normal);
                Prepared::Disc {
                    center: *center,
                    normal,
                    t,
                    b,
                    radius: *radius,
                    area: PI * radius * radius,
                    l: *radiance,
                    two_sided: *two_sided,
                }
            }
            Light::Environment(Environment::Constant(l)) => Prepared::ConstantEnv { l: *l, unshadowed: l.map(|c| lobe[0] * c) },
            Light::Environment(Environment::Equirect(map)) => Prepared::MapEnv { map, sh: map.sh9() },
        }
    }

    fn needs_area_samples(&self) -> bool {
        matches!(self, Prepared::Sun { .. } | Prepared::Rect { .. } | Prepared::Disc { .. })
    }

    fn needs_environment_samples(&self, shadowed: bool, method: EnvironmentMethod) -> bool {
        match self {
            Prepared::ConstantEnv { .. } => shadowed,
            Prepared::MapEnv { map, .. } => !map.is_black() && (shadowed || method == EnvironmentMethod::Sampled),
            _ => false,
        }
    }
}

/// The progress of one call shared by its threads: points done, when the check was last
/// called, and whether it asked to stop.
struct Ticker<'a> {
    poll: Poll<'a>,
    points: usize,
    done: AtomicUsize,
    last: Mutex<Instant>,
    stop: AtomicBool,
}

impl<'a> Ticker<'a> {
    fn new(poll: Poll<'a>, points: usize) -> Self {
        Self {
            poll,
            points: points.max(1),
            done: AtomicUsize::new(0),
            last: Mutex::new(Instant::now()),
            stop: AtomicBool::new(false),
        }
    }

    /// Counts `points` more points done and calls the check when it is due; `false` once the
    /// check asked to stop. The fraction is read under the lock, so it never goes back.
    fn tick(&self, points: usize) -> bool {
        if self.stop.load(Ordering::Relaxed) {
            return false;
        }
        self.done.fetch_add(points, Ordering::Relaxed);
        if let Ok(mut last) = self.last.try_lock() {
            if last.elapsed() >= POLL_EVERY {
                *last = Instant::now();
                #[allow(clippy::cast_precision_loss)]
                let fraction = self.done.load(Ordering::Relaxed) as f64 / self.points as f64;
                if (self.poll)(fraction).is_err() {
                    self.stop.store(true, Ordering::Relaxed);
                    return false;
                }
            }
        }
        true
    }

    /// Inside a point's samples: whether to go on after sample `k` (looks every
    /// [`SAMPLES_PER_CHECK`] samples).
    fn keep_sampling(&self, k: usize) -> bool {
        !(k + 1).is_multiple_of(SAMPLES_PER_CHECK) || self.tick(0)
    }

    fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }
}

/// Per-call state shared by all points.
struct Context<'a> {
    response: Response,
    lobe: [f64; 3],
    occluder: Option<&'a TriangleBvh>,
    /// Absolute shadow-ray offset along the normal.
    bias: f64,
    options: SourceOptions,
    ticker: Ticker<'a>,
}

impl Context<'_> {
    /// Whether nothing blocks origin + t·dir for t ∈ (0, t_max).
    fn visible(&self, origin: DVec3, dir: DVec3, t_max: f64) -> bool {
        match self.occluder {
            None => true,
            Some(bvh) => !bvh.occluded(origin, dir, 0.0, t_max),
        }
    }

    /// Contribution of one light at point `p` with unit normal `n` (shadow origin `origin`);
    /// `key` seeds its samples.
    fn evaluate(&self, light: &Prepared<'_>, p: DVec3, n: DVec3, origin: DVec3, key: u64) -> [f64; 3] {
        let r = self.response;
        match *light {
            Prepared::Delta { .. } | Prepared::Point { .. } | Prepared::Spot { .. } => {
                let (c, visible) = self.delta(light, p, n, origin);
                if visible {
                    c
                } else {
                    [0.0; 3]
                }
            }
            Prepared::Sun { axis, t, b, sin_alpha, e } => {
                // Directions with density cos θ_a / (π sin²α) over the cone: f/pdf = E w / cos θ_a.
                // Where nothing meets the cone, no ray is cast (the same sum, without the rays).
                let clear = self.cone_clear(origin, axis, t, b, sin_alpha);
                let pattern = Pattern::new(key);
                let count = self.options.area_samples;
                let mut sum = 0.0;
                for k in 0..count {
                    let (x, y) = concentric_disc(pattern.get(k));
                    let (x, y) = (x * sin_alpha, y * sin_alpha);
                    let cos_a = (1.0 - x * x - y * y).max(0.0).sqrt();
                    let omega = x * t + y * b + cos_a * axis;
                    let w = r.weight(n.dot(omega));
                    if w > 0.0 && cos_a > 0.0 && (clear || self.visible(origin, omega, f64::INFINITY)) {
                        sum += w / cos_a;
                    }
                    if !self.ticker.keep_sampling(k) {
                        break;
                    }
                }
                scale(e, sum / count as f64)
            }
            Prepared::Rect { center, half_u, half_v, normal, area, l, two_sided } => {
                let facing = normal.dot(p - center);
                if facing == 0.0 || (facing < 0.0 && !two_sided) {
                    return [0.0; 3];
                }
                let corners =
                    [center - half_u - half_v, center + half_u - half_v, center + half_u + half_v, center - half_u + half_v];
                let clear = self.clear(origin, corners);
                if clear && matches!(r, Response::Irradiance) {
                    return scale(l, polygon_irradiance(p, n, &corners));
                }
                self.area_light(p, n, origin, key, l, area, normal, two_sided, clear, |[u, v]| {
                    center + (2.0 * u - 1.0) * half_u + (2.0 * v - 1.0) * half_v
                })
            }
            Prepared::Disc { center, normal, t, b, radius, area, l, two_sided } => {
                let facing = normal.dot(p - center);
                if facing == 0.0 || (facing < 0.0 && !two_sided) {
                    return [0.0; 3];
                }
                // The circumscribed square's shaft holds the disc's.
                let (t_r, b_r) = (radius * t, radius * b);
                let clear = self.clear(origin, [center - t_r - b_r, center + t_r - b_r, center + t_r + b_r, center - t_r + b_r]);
                self.area_light(p, n, origin, key, l, area, normal, two_sided, clear, |u| {
                    let (x, y) = concentric_disc(u);
                    center + radius * (x * t + y * b)
                })
            }
            Prepared::ConstantEnv { l, unshadowed } => {
                if self.occluder.is_none() {
                    return unshadowed;
                }
                // Cosine-weighted directions, pdf cos/π: f/pdf = π L T V.
                let (t, b) = orthonormal_basis(n);
                let pattern = Pattern::new(key);
                let count = self.options.environment_samples;
                let mut sum = 0.0;
                for k in 0..count {
                    if !self.ticker.keep_sampling(k) {
                        break;
                    }
                    let local = cosine_hemisphere(pattern.get(k));
                    if local.z <= 0.0 {
                        continue;
                    }
                    let omega = local.x * t + local.y * b + local.z * n;
                    if self.visible(origin, omega, f64::INFINITY) {
                        sum += r.transmittance(local.z);
                    }
                }
                scale(l, PI * sum / count as f64)
            }
            Prepared::MapEnv { map, ref sh } => {
                if map.is_black() {
                    return [0.0; 3];
                }
                if self.occluder.is_none() && self.options.unshadowed_environment == EnvironmentMethod::Sh9 {
                    return sh9_convolve(sh, self.lobe, n).map(|c| c.max(0.0));
                }
                self.map_mis(map, n, origin, key)
            }
        }
    }

    /// A delta light's ([`Light::is_delta`]) value at `p` (unit normal `n`) were nothing in the
    /// way, and whether its one shadow ray from `origin` is clear (not traced where the value
    /// is 0). A sun of no size: E (n·ω)⁺ T. A point-like emitter of intensity I at a position,
    /// times a spot's falloff s(ω) (ω from the point towards the light): I s (n·ω)⁺ T / d².
    fn delta(&self, light: &Prepared<'_>, p: DVec3, n: DVec3, origin: DVec3) -> ([f64; 3], bool) {
        let (position, i, falloff) = match *light {
            Prepared::Delta { to_light, e } => {
                let w = self.response.weight(n.dot(to_light));
                return if w > 0.0 { (scale(e, w), self.visible(origin, to_light, f64::INFINITY)) } else { ([0.0; 3], false) };
            }
            Prepared::Point { position, i } => (position, i, None),
            Prepared::Spot { position, axis, i, cos_half, blend } => (position, i, Some((axis, cos_half, blend))),
            _ => unreachable!("delta is called for delta lights only"),
        };
        let d = position - p;
        let d2 = d.length_squared();
        if d2 == 0.0 {
            return ([0.0; 3], false);
        }
        let omega = d / d2.sqrt();
        let s = falloff.map_or(1.0, |(axis, cos_half, blend)| spot_falloff(-omega.dot(axis), cos_half, blend));
        let w = r_weight(self.response, n, omega) * s;
        if w > 0.0 {
            (scale(i, w / d2), self.visible(origin, position - origin, SHADOW_END))
        } else {
            ([0.0; 3], false)
        }
    }

    /// Whether nothing can block a shadow ray from `origin` to the planar convex light inside
    /// `corners` ([`Shaft`]); without shadows, always.
    /// Whether no shadow ray from `origin` in the sun's cone (half-angle α about `axis`) can
    /// be blocked: the pyramid around the cone, out past the occluder's bounds, meets no
    /// triangle ([`Shaft::around_cone`]).
    fn cone_clear(&self, origin: DVec3, axis: DVec3, t: DVec3, b: DVec3, sin_alpha: f64) -> bool {
        let Some(bvh) = self.occluder else { return true };
        let Some((lo, hi)) = bvh.bounds() else { return true };
        // No point of the bounds is further along the axis than its furthest corner.
        let reach = (origin - lo).abs().max((origin - hi).abs()).length() * (1.0 + 1e-9);
        Shaft::around_cone(origin, axis, t, b, sin_alpha, reach).is_some_and(|shaft| !shaft.blocked_in(bvh))
    }

    fn clear(&self, origin: DVec3, corners: [DVec3; 4]) -> bool {
        match self.occluder {
            None => true,
            Some(bvh) => Shaft::new(origin, corners).is_some_and(|shaft| !shaft.blocked_in(bvh)),
        }
    }

    /// An emitter of radiance `l` and area `area` whose points `at(u)` are uniform by area for
    /// u uniform in [0, 1)²: estimator (A/N) Σ L (n·ω)⁺ T cos θ_l / d²; `clear`: no shadow ray
    /// can be blocked (none is cast).
    #[allow(clippy::too_many_arguments)]
    fn area_light(
        &self,
        p: DVec3,
        n: DVec3,
        origin: DVec3,
        key: u64,
        l: [f64; 3],
        area: f64,
        light_normal: DVec3,
        two_sided: bool,
        clear: bool,
        at: impl Fn([f64; 2]) -> DVec3,
    ) -> [f64; 3] {
        let pattern = Pattern::new(key);
        let count = self.options.area_samples;
        let mut sum = 0.0;
        for k in 0..count {
            if !self.ticker.keep_sampling(k) {
                break;
            }
            let y = at(pattern.get(k));
            let d = y - p;
            let d2 = d.length_squared();
            if d2 == 0.0 {
                continue;
            }
            let omega = d / d2.sqrt();
            let cos_l = -omega.dot(light_normal);
            let cos_l = if two_sided { cos_l.abs() } else { cos_l };
            if cos_l <= 0.0 {
                continue;
            }
            let w = r_weight(self.response, n, omega);
            if w > 0.0 && (clear || self.visible(origin, y - origin, SHADOW_END)) {
                sum += w * cos_l / d2;
            }
        }
        scale(l, sum * area / count as f64)
    }

    /// Multiple importance sampling of an equirect map: ⌈N/2⌉ map samples and ⌊N/2⌋
    /// cosine-weighted samples, balance heuristic.
    fn map_mis(&self, map: &EquirectMap, n: DVec3, origin: DVec3, key: u64) -> [f64; 3] {
        let count = self.options.environment_samples;
        let n_map = count.div_ceil(2);
        let n_cos = count - n_map;
        let (fm, fc) = (n_map as f64, n_cos as f64);
        let (t, b) = orthonormal_basis(n);
        let mut sum = [0.0; 3];
        let mut add = |omega: DVec3, cos: f64, pdf_map: f64| {
            let w = self.response.weight(cos);
            if w <= 0.0 {
                return;
            }
            let denominator = fm * pdf_map + fc * cos / PI;
            if denominator > 0.0 && self.visible(origin, omega, f64::INFINITY) {
                let li = map.radiance(omega);
                for (s, c) in sum.iter_mut().zip(li) {
                    *s += c * w / denominator;
                }
            }
        };
        let map_pattern = Pattern::new(hash_combine(key, 1));
        for k in 0..n_map {
            if !self.ticker.keep_sampling(k) {
                break;
            }
            if let Some(s) = map.sample(map_pattern.get(k)) {
                add(s.direction, n.dot(s.direction), s.pdf);
            }
        }
        let cos_pattern = Pattern::new(hash_combine(key, 2));
        for k in 0..n_cos {
            if !self.ticker.keep_sampling(k) {
                break;
            }
            let local = cosine_hemisphere(cos_pattern.get(k));
            let omega = local.x * t + local.y * b + local.z * n;
            add(omega, local.z, map.pdf(omega));
        }
        sum
    }
}

fn r_weight(response: Response, n: DVec3, omega: DVec3) -> f64 {
    response.weight(n.dot(omega))
}

fn scale(c: [f64; 3], s: f64) -> [f64; 3] {
    c.map(|v| v * s)
}

/// Diagonal of the axis-aligned box around the occluder's triangles (0 when empty).
pub(crate) fn bounding_diagonal(bvh: &TriangleBvh) -> f64 {
    bvh.bounds().map_or(0.0, |(lo, hi)| (hi - lo).length())
}

/// The points' checks of [`transmitted_source`] ([`LightError::LengthMismatch`],
/// [`LightError::InvalidPoint`]) and the unit normals.
pub(crate) fn check_inputs(points: &[DVec3], normals: &[DVec3]) -> Result<Vec<DVec3>, LightError> {
    if points.len() != normals.len() {
        return Err(LightError::LengthMismatch { points: points.len(), normals: normals.len() });
    }
    if let Some(index) = points.par_iter().position_first(|p| !p.is_finite()) {
        return Err(LightError::InvalidPoint {
            index,
            field: "position",
            value: fmt_vec(&points[index].to_array()),
            requirement: "must be finite",
        });
    }
    // One pass over the normals (NaN marks one that cannot be made a unit vector), then the
    // first such.
    let unit: Vec<DVec3> = normals
        .par_iter()
        .map(|n| {
            let len = n.length();
            if n.is_finite() && len > 0.0 && len.is_finite() {
                *n / len
            } else {
                DVec3::NAN
            }
        })
        .collect();
    if let Some(index) = unit.par_iter().position_first(|n| n.x.is_nan()) {
        return Err(LightError::InvalidPoint {
            index,
            field: "normal",
            value: fmt_vec(&normals[index].to_array()),
            requirement: "must be finite and non-zero",
        });
    }
    Ok(unit)
}

fn check_options(prepared: &[Prepared<'_>], options: &SourceOptions, shadowed: bool) -> Result<(), LightError> {
    options.validate()?;
    if options.area_samples == 0 {
        if let Some(i) = prepared.iter().position(Prepared::needs_area_samples) {
            return Err(LightError::InvalidOption {
                field: "area_samples",
                value: "0".into(),
                requirement: format!("light {i} is sampled and needs at least 1"),
            });
        }
    }
    if options.environment_samples == 0 {
        if let Some(i) = prepared.iter().position(|p| p.needs_environment_samples(shadowed, options.unshadowed_environment)) {
            return Err(LightError::InvalidOption {
                field: "environment_samples",
                value: "0".into(),
                requirement: format!("light {i} is sampled and needs at least 1"),
            });
        }
    }
    Ok(())
}

fn evaluate(
    lights: &[Light],
    points: &[DVec3],
    normals: &[DVec3],
    response: Response,
    occluder: Option<&TriangleBvh>,
    options: &SourceOptions,
    poll: Poll<'_>,
) -> Result<Vec<[f64; 3]>, LightError> {
    evaluate_with(lights, points, normals, response, occluder, options, poll, false).map(|(q, _)| q)
}

/// [`evaluate`], and with `unshadowed` (every light a delta light) also each point's value
/// without the occluder: each light's value is computed once and its shadow ray decides
/// whether the shadowed sum takes it.
#[allow(clippy::too_many_arguments)]
fn evaluate_with(
    lights: &[Light],
    points: &[DVec3],
    normals: &[DVec3],
    response: Response,
    occluder: Option<&TriangleBvh>,
    options: &SourceOptions,
    poll: Poll<'_>,
    unshadowed: bool,
) -> Result<ShadowedAndUnshadowed, LightError> {
    debug_assert!(!unshadowed || lights.iter().all(Light::is_delta));
    validate_lights(lights)?;
    let normals = check_inputs(points, normals)?;
    let lobe = response.lobe();
    let prepared: Vec<Prepared<'_>> = lights.iter().map(|l| Prepared::new(l, lobe)).collect();
    check_options(&prepared, options, occluder.is_some())?;
    let ctx = Context {
        response,
        lobe,
        occluder,
        bias: occluder.map_or(0.0, |b| options.shadow_bias * bounding_diagonal(b)),
        options: *options,
        ticker: Ticker::new(poll, points.len()),
    };
    let light_keys: Vec<u64> = (0..prepared.len()).map(|li| hash_combine(options.seed, li as u64)).collect();
    let mut q = vec![[0.0; 3]; points.len()];
    let mut free = vec![[0.0; 3]; if unshadowed { points.len() } else { 0 }];
    let mut free_chunks: Vec<Option<&mut [[f64; 3]]>> = if unshadowed {
        free.chunks_mut(POINTS_PER_TICK).map(Some).collect()
    } else {
        (0..points.len().div_ceil(POINTS_PER_TICK)).map(|_| None).collect()
    };
    let add = |q: &mut [f64; 3], c: [f64; 3]| {
        for (qc, cc) in q.iter_mut().zip(c) {
            *qc += cc;
        }
    };
    q.par_chunks_mut(POINTS_PER_TICK).zip(free_chunks.par_iter_mut()).enumerate().for_each(|(chunk, (out, free_out))| {
        let first = chunk * POINTS_PER_TICK;
        for (k, (i, q)) in (first..).zip(out.iter_mut()).enumerate() {
            if ctx.ticker.stopped() {
                return;
            }
            let (p, n) = (points[i], normals[i]);
            let origin = p + ctx.bias * n;
            for (light, &lk) in prepared.iter().zip(&light_keys) {
                if let Some(free_out) = free_out.as_deref_mut() {
                    let (c, visible) = ctx.delta(light, p, n, origin);
                    add(&mut free_out[k], c);
                    add(q, if visible { c } else { [0.0; 3] });
                } else {
                    add(q, ctx.evaluate(light, p, n, origin, hash_combine(lk, i as u64)));
                }
            }
        }
        ctx.ticker.tick(out.len());
    });
    // A stopped call's values are incomplete: only the cancellation is returned.
    if ctx.ticker.stopped() {
        return Err(LightError::Cancelled(Cancelled));
    }
    drop(free_chunks);
    Ok((q, free))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optics::f_ext;

    fn at_origin_facing_up() -> (Vec<DVec3>, Vec<DVec3>) {
        (vec![DVec3::ZERO], vec![DVec3::Z])
    }

    #[test]
    fn spot_falloff_shape() {
        let c = 30f64.to_radians().cos();
        assert_eq!(spot_falloff(c - 1e-9, c, 0.5), 0.0);
        assert_eq!(spot_falloff(1.0, c, 0.0), 1.0);
        assert_eq!(spot_falloff(c + 1e-9, c, 0.0), 1.0);
        assert_eq!(spot_falloff(1.0, c, 1.0), 1.0);
        // Halfway through the blend band: smoothstep(½) = ½.
        let mid = c + 0.5 * 0.4 * (1.0 - c);
        assert!((spot_falloff(mid, c, 0.4) - 0.5).abs() < 1e-12);
        // Monotone.
        let mut last = 0.0;
        for k in 0..=100 {
            let s = spot_falloff(c + (1.0 - c) * k as f64 / 100.0, c, 0.7);
            assert!(s >= last);
            last = s;
        }
    }

    #[test]
    fn delta_sun_is_e_cos_t() {
        let eta = 1.4;
        let theta = 40f64.to_radians();
        let to_light = DVec3::new(theta.sin(), 0.0, theta.cos());
        let lights = [Light::Directional { direction: -to_light, irradiance: [2.0, 1.0, 0.5], angular_diameter_deg: 0.0 }];
        let (p, n) = at_origin_facing_up();
        let q = transmitted_source(&lights, &p, &n, eta, None, &SourceOptions::default()).unwrap();
        let expect = theta.cos() * fresnel_transmittance(theta.cos(), eta);
        assert!((q[0][0] - 2.0 * expect).abs() < 1e-15 && (q[0][2] - 0.5 * expect).abs() < 1e-15);
        let e = irradiance(&lights, &p, &n, None, &SourceOptions::default()).unwrap();
        assert!((e[0][1] - theta.cos()).abs() < 1e-15);
        // From below: nothing.
        let q = transmitted_source(&lights, &p, &[-DVec3::Z], eta, None, &SourceOptions::default()).unwrap();
        assert_eq!(q[0], [0.0; 3]);
    }

    #[test]
    fn a_soft_sun_facing_the_surface_gives_e_exactly() {
        let lights = [Light::Directional { direction: -DVec3::Z, irradiance: [3.0; 3], angular_diameter_deg: 10.0 }];
        let (p, n) = at_origin_facing_up();
        let e = irradiance(&lights, &p, &n, None, &SourceOptions { area_samples: 7, ..Default::default() }).unwrap();
        assert!((e[0][0] - 3.0).abs() < 1e-12, "{}", e[0][0]);
        // A tilted surface: the soft sun converges to the delta sun as it shrinks.
        let n = [DVec3::new(0.6, 0.0, 0.8)];
        let delta = Light::Directional { direction: -DVec3::Z, irradiance: [3.0; 3], angular_diameter_deg: 0.0 };
        let tiny = Light::Directional { direction: -DVec3::Z, irradiance: [3.0; 3], angular_diameter_deg: 0.5 };
        let a = transmitted_source(&[delta], &p, &n, 1.3, None, &SourceOptions::default()).unwrap();
        let b = transmitted_source(&[tiny], &p, &n, 1.3, None, &SourceOptions::default()).unwrap();
        assert!((a[0][0] - b[0][0]).abs() < 1e-5 * a[0][0], "{a:?} {b:?}");
    }

    /// A 10° sun straight down over the edge of a half-plane occluder at height 1: fully lit
    /// points get E exactly (the cone clear, no rays), fully shadowed ones nothing, the point
    /// under the edge half of E, and the penumbra (±tan 5° ≈ ±0.087 about the edge) falls
    /// monotonically.
    #[test]
    fn a_soft_sun_over_a_half_plane_has_its_penumbra_under_the_edge() {
        let lights = [Light::Directional { direction: -DVec3::Z, irradiance: [3.0; 3], angular_diameter_deg: 10.0 }];
        let c = [DVec3::new(-100.0, -100.0, 1.0), DVec3::new(0.0, -100.0, 1.0), DVec3::new(0.0, 100.0, 1.0)];
        let d = [DVec3::new(-100.0, -100.0, 1.0), DVec3::new(0.0, 100.0, 1.0), DVec3::new(-100.0, 100.0, 1.0)];
        let bvh = TriangleBvh::new(vec![c, d]);
        let xs = [-1.0, -0.1, -0.04, 0.0, 0.04, 0.1, 1.0];
        let points: Vec<DVec3> = xs.iter().map(|&x| DVec3::new(x, 0.0, 0.0)).collect();
        let normals = vec![DVec3::Z; xs.len()];
        let e = irradiance(&lights, &points, &normals, Some(&bvh), &SourceOptions::default()).unwrap();
        let e: Vec<f64> = e.iter().map(|v| v[0]).collect();
        assert_eq!(e[0], 0.0, "under the occluder");
        assert_eq!(e[1], 0.0, "in the umbra");
        assert!((e[6] - 3.0).abs() < 1e-12 && (e[5] - 3.0).abs() < 1e-12, "lit: {e:?}");
        assert!((e[3] - 1.5).abs() < 0.1, "under the edge, half the sun: {e:?}");
        assert!(e.windows(2).all(|w| w[0] <= w[1]) && e[2] < e[3] && e[3] < e[4], "{e:?}");
    }

    #[test]
    fn constant_environment_closed_form() {
        let lights = [Light::Environment(Environment::Constant([1.0, 2.0, 0.0]))];
        let (p, n) = at_origin_facing_up();
        let q = transmitted_source(&lights, &p, &n, 1.3, None, &SourceOptions::default()).unwrap();
        let expect = PI * (1.0 - f_ext(1.3));
        assert!((q[0][0] - expect).abs() < 1e-14 && (q[0][1] - 2.0 * expect).abs() < 1e-14);
        assert!((q[0][0] - 2.9495).abs() < 1e-4);
        let e = irradiance(&lights, &p, &n, None, &SourceOptions::default()).unwrap();
        assert!((e[0][0] - PI).abs() < 1e-15);
    }

    #[test]
    fn point_light_inverse_square() {
        let lights = [Light::Point { position: DVec3::new(0.0, 0.0, 2.0), intensity: [4.0; 3] }];
        let (p, n) = at_origin_facing_up();
        let e = irradiance(&lights, &p, &n, None, &SourceOptions::default()).unwrap();
        assert!((e[0][0] - 1.0).abs() < 1e-15);
    }

    #[test]
    fn disc_light_on_axis_matches_the_closed_form() {
        // Irradiance under a one-sided disc of radius a at height h: π L a² / (a² + h²).
        let (a, h) = (0.7, 1.3);
        let lights = [Light::DiscArea {
            center: DVec3::new(0.0, 0.0, h),
            normal: -DVec3::Z,
            radius: a,
            radiance: [1.0; 3],
            two_sided: false,
        }];
        let (p, n) = at_origin_facing_up();
        let opts = SourceOptions { area_samples: 4096, ..Default::default() };
        let e = irradiance(&lights, &p, &n, None, &opts).unwrap();
        let expect = PI * a * a / (a * a + h * h);
        assert!((e[0][0] - expect).abs() < 1e-4 * expect, "{} vs {expect}", e[0][0]);
        // Facing away: nothing unless two-sided.
        let mut flipped = lights.clone();
        if let Light::DiscArea { normal, .. } = &mut flipped[0] {
            *normal = DVec3::Z;
        }
        assert_eq!(irradiance(&flipped, &p, &n, None, &opts).unwrap()[0], [0.0; 3]);
        if let Light::DiscArea { two_sided, .. } = &mut flipped[0] {
            *two_sided = true;
        }
        let e2 = irradiance(&flipped, &p, &n, None, &opts).unwrap();
        assert!((e2[0][0] - e[0][0]).abs() < 1e-12);
    }

    #[test]
    fn rectangle_light_on_axis_matches_the_closed_form() {
        // Square of side 2s at height h, centred above the point: four s×s rectangles with a
        // corner above it, each with the differential form factor
        // F = (1/2π)·2·X/√(1+X²)·atan(X/√(1+X²)), X = s/h, so E = πL·4F = 4L·(s/r)·atan(s/r),
        // r = √(h² + s²).
        let (s, h) = (0.5, 1.0);
        let lights = [Light::RectArea {
            center: DVec3::new(0.0, 0.0, h),
            half_u: DVec3::new(0.0, s, 0.0),
            half_v: DVec3::new(s, 0.0, 0.0),
            radiance: [1.0; 3],
            two_sided: false,
        }];
        let (p, n) = at_origin_facing_up();
        let r = (h * h + s * s).sqrt();
        let expect = 4.0 * (s / r) * (s / r).atan();
        // Seen whole (no occluder, or one outside the shaft): exact, whatever the sample count.
        let far = TriangleBvh::new(vec![[DVec3::new(5.0, 0.0, 0.0), DVec3::new(6.0, 0.0, 0.0), DVec3::new(5.0, 1.0, 0.5)]]);
        for occluder in [None, Some(&far)] {
            let e = irradiance(&lights, &p, &n, occluder, &SourceOptions { area_samples: 1, ..Default::default() }).unwrap();
            assert!((e[0][0] - expect).abs() < 1e-13 * expect, "{} vs {expect}", e[0][0]);
        }
        // A blocker at h/2 over x < 0 hides exactly the light's x < 0 half (a ray to (x, y, h)
        // crosses z = h/2 at x/2): by symmetry half of it, by sampled shadow rays.
        let half = TriangleBvh::new(vec![
            [DVec3::new(0.0, -5.0, 0.5 * h), DVec3::new(0.0, 5.0, 0.5 * h), DVec3::new(-5.0, 0.0, 0.5 * h)],
            [DVec3::new(0.0, -5.0, 0.5 * h), DVec3::new(-5.0, 0.0, 0.5 * h), DVec3::new(-5.0, -5.0, 0.5 * h)],
            [DVec3::new(0.0, 5.0, 0.5 * h), DVec3::new(-5.0, 5.0, 0.5 * h), DVec3::new(-5.0, 0.0, 0.5 * h)],
        ]);
        let opts = SourceOptions { area_samples: 4096, ..Default::default() };
        let e = irradiance(&lights, &p, &n, Some(&half), &opts).unwrap();
        assert!((e[0][0] - 0.5 * expect).abs() < 2e-3 * expect, "{} vs {}", e[0][0], 0.5 * expect);
        // A wedge inside the shaft, in the way of some rays only: less than whole, more than half.
        let wedge = TriangleBvh::new(vec![[
            DVec3::new(-0.6, -3.0, 0.5 * h),
            DVec3::new(-0.6, 3.0, 0.5 * h),
            DVec3::new(-1e-9, 0.0, 0.5 * h),
        ]]);
        let e = irradiance(&lights, &p, &n, Some(&wedge), &opts).unwrap();
        assert!(e[0][0] < expect && e[0][0] > 0.5 * expect, "{} vs {expect}", e[0][0]);
    }

    #[test]
    fn option_checks() {
        let area = [Light::DiscArea { center: DVec3::Z, normal: -DVec3::Z, radius: 1.0, radiance: [1.0; 3], two_sided: false }];
        let (p, n) = at_origin_facing_up();
        let zero_area = SourceOptions { area_samples: 0, ..Default::default() };
        assert!(matches!(
            irradiance(&area, &p, &n, None, &zero_area),
            Err(LightError::InvalidOption { field: "area_samples", .. })
        ));
        // Not needed by a point light: fine.
        let point = [Light::Point { position: DVec3::Z, intensity: [1.0; 3] }];
        irradiance(&point, &p, &n, None, &zero_area).unwrap();
        let env = [Light::Environment(Environment::Constant([1.0; 3]))];
        let zero_env = SourceOptions { environment_samples: 0, ..Default::default() };
        irradiance(&env, &p, &n, None, &zero_env).unwrap();
        let far_triangle = [DVec3::new(5.0, 0.0, 0.0), DVec3::new(6.0, 0.0, 0.0), DVec3::new(5.0, 1.0, 0.0)];
        let bvh = TriangleBvh::new(vec![far_triangle]);
        assert!(matches!(
            irradiance(&env, &p, &n, Some(&bvh), &zero_env),
            Err(LightError::InvalidOption { field: "environment_samples", .. })
        ));
        let bad_bias = SourceOptions { shadow_bias: -1.0, ..Default::default() };
        assert!(matches!(
            irradiance(&point, &p, &n, None, &bad_bias),
            Err(LightError::InvalidOption { field: "shadow_bias", .. })
        ));
    }

    /// The check is called while the work goes on (also inside one point's samples), sees
    /// fractions that never go back, and stops the work when it asks to; without a stop the
    /// result is the one without a check.
    #[test]
    fn progress_is_polled_and_a_stop_is_honoured() {
        let sun = [Light::Directional { direction: -DVec3::Z, irradiance: [1.0; 3], angular_diameter_deg: 5.0 }];
        let far_triangle = [DVec3::new(5.0, 0.0, 0.0), DVec3::new(6.0, 0.0, 0.0), DVec3::new(5.0, 1.0, 0.0)];
        let bvh = TriangleBvh::new(vec![far_triangle]);
        let points: Vec<DVec3> = (0..64).map(|i| DVec3::new(f64::from(i) * 0.01, 0.0, 0.0)).collect();
        let normals = vec![DVec3::Z; points.len()];
        // Enough samples that one call lasts well over the 10 ms between checks.
        let options = SourceOptions { area_samples: 1 << 16, ..Default::default() };
        let seen = Mutex::new(Vec::new());
        let record = |f: f64| {
            seen.lock().unwrap().push(f);
            Ok(())
        };
        let q = transmitted_source_with(&sun, &points, &normals, 1.3, Some(&bvh), &options, &record).unwrap();
        let plain = transmitted_source(&sun, &points, &normals, 1.3, Some(&bvh), &options).unwrap();
        assert_eq!(q, plain);
        let seen = seen.into_inner().unwrap();
        assert!(!seen.is_empty());
        assert!(seen.windows(2).all(|w| w[1] >= w[0]), "{seen:?}");
        assert!(seen.iter().all(|&f| (0.0..=1.0).contains(&f)));
        // Cancel at the first check: the call stops and says so.
        let calls = AtomicUsize::new(0);
        let cancel = |_: f64| {
            calls.fetch_add(1, Ordering::SeqCst);
            Err(Cancelled)
        };
        let result = transmitted_source_with(&sun, &points, &normals, 1.3, Some(&bvh), &options, &cancel);
        assert_eq!(result, Err(LightError::Cancelled(Cancelled)));
        assert_eq!(calls.load(Ordering::SeqCst), 1, "one check asked to stop; nothing asks again after it");
    }

    #[test]
    fn sample_counts_are_bounded() {
        let (p, n) = at_origin_facing_up();
        let point = [Light::Point { position: DVec3::Z, intensity: [1.0; 3] }];
        let at_max = SourceOptions { area_samples: 1 << 20, environment_samples: 1 << 20, ..Default::default() };
        assert_eq!(at_max.validate(), Ok(()));
        irradiance(&point, &p, &n, None, &at_max).unwrap();
        for (area, env, field, value) in
            [((1 << 20) + 1, 1, "area_samples", "1048577"), (1, u32::MAX as usize, "environment_samples", "4294967295")]
        {
            let over = SourceOptions { area_samples: area, environment_samples: env, ..Default::default() };
            let e = irradiance(&point, &p, &n, None, &over).unwrap_err();
            assert_eq!(e, over.validate().unwrap_err());
            assert_eq!(e.to_string(), format!("source option {field} = {value}: must be at most 1048576 (2^20)"));
        }
    }

    /// The one-pass shadowed and unshadowed values equal the two calls' bit for bit: delta
    /// lights (a sun, a point, a spot) over a grid of points partly under a blocker, and a list
    /// with a light of another kind (two calls inside).
    #[test]
    fn shadowed_and_unshadowed_in_one_pass_equal_two_calls() {
        let points: Vec<DVec3> = (0..400).map(|i| DVec3::new((i % 20) as f64 - 9.5, (i / 20) as f64 - 9.5, 0.0)).collect();
        let normals: Vec<DVec3> = (0..400).map(|i| DVec3::new(0.01 * (i % 7) as f64, 0.0, 1.0)).collect();
        let blocker =
            TriangleBvh::new(vec![[DVec3::new(-1.0, -5.0, 4.0), DVec3::new(5.0, -5.0, 4.0), DVec3::new(-1.0, 4.0, 4.0)]]);
        let mut lights = vec![
            Light::Directional { direction: DVec3::new(0.3, 0.1, -1.0), irradiance: [1.0, 2.0, 3.0], angular_diameter_deg: 0.0 },
            Light::Point { position: DVec3::new(-2.0, 3.0, 9.0), intensity: [50.0; 3] },
            Light::Spot {
                position: DVec3::new(4.0, -2.0, 10.0),
                direction: DVec3::new(-0.2, 0.1, -1.0),
                intensity: [80.0, 60.0, 40.0],
                cone_half_angle_deg: 30.0,
                blend: 0.3,
            },
        ];
        let options = SourceOptions::default();
        let none: Poll<'_> = &|_| Ok(());
        for _ in 0..2 {
            let (shadowed, unshadowed) =
                transmitted_source_and_unshadowed(&lights, &points, &normals, 1.4, Some(&blocker), &options, none).unwrap();
            let with = transmitted_source_with(&lights, &points, &normals, 1.4, Some(&blocker), &options, none).unwrap();
            let without = transmitted_source_with(&lights, &points, &normals, 1.4, None, &options, none).unwrap();
            assert_eq!(shadowed, with);
            assert_eq!(unshadowed, without);
            let dimmed = shadowed.iter().zip(&unshadowed).filter(|(s, u)| s[0] < u[0]).count();
            if lights.len() == 3 {
                assert!(dimmed > 40 && dimmed < 360, "{dimmed} of 400 points are shadowed by some light");
            }
            lights.push(Light::Environment(Environment::Constant([0.1; 3])));
        }
    }

    #[test]
    fn bounding_diagonal_of_a_box() {
        let bvh = TriangleBvh::new(vec![[DVec3::ZERO, DVec3::new(1.0, 2.0, 0.0), DVec3::new(0.0, 0.0, 2.0)]]);
        assert!((bounding_diagonal(&bvh) - 3.0).abs() < 1e-15);
        assert_eq!(bounding_diagonal(&TriangleBvh::new(Vec::new())), 0.0);
    }
}
