//! A translucent-radiosity bake kept for interactive work (design/radiosity.md §1.6), the
//! counterpart of TransCut's editor for a scene whose objects exchange light: the patches, the
//! form factors F and every translucent object's assembled diffusion system stay, so a change
//! of lights, of a light's colour or brightness, of an albedo, an emission or a medium costs
//! solves only, never F again.
//!
//! - Every solve is warm-started: the radiosity from the last one ([`crate::radiosity::solve_coupled`]'s
//!   `initial`), each diffusion solve from its object's last fluence.
//! - Light transport is linear, so the session keeps the solution of each light at unit
//!   strength ([`Light::split_strength`]) and of the emission: lights that differ from the last
//!   ones only in colour or brightness are a weighted sum of those, with no solve; moving one
//!   light of several solves that light only (from its last solution). A scene baked under one
//!   light (or emission only) has its one response from the bake; one baked under several lights
//!   solves each on its first relight.
//! - A change of albedo, emission or medium changes every response: it solves the scene under
//!   its lights once, from the last solution, and the responses are solved again when the lights
//!   next change.
//! - A failed or cancelled call changes nothing.
//!
//! Updates run on the caller's rayon pool; lights shadow every object, as in the bake. The
//! iteration's gathers F B run on the GPU that [`RadiosityOptions::backend`] resolves to
//! (`SweepDevice`: F uploaded once per session, at the first solve that gathers on it).

use std::time::Instant;

use glam::DVec3;

use super::profile_media::check_medium;
use super::profile_object::ProfileObject;
use super::responses::{warm_start, Field, Response, Source};
use super::scatterer::{Operator, Scatterer};
use super::scattering::DiffusionScattering;
use super::surfaces::{patch_surface, PatchSurface};
use super::{common_scale, fill_covered, object_stats, scene_diagonal, surface_patches, RadiosityObject, RadiosityStats, NAME};
use crate::gpu::{self, Backend, DeviceChoice};
use crate::light::{self, Light};
use crate::mesh::{TriMesh, TriangleBvh};
use crate::methods::transcut::{Reuse, TransCut};
use crate::methods::{
    check_radiance, targets, world_surfaces, BakedState, Lighting, ObjectBake, ObjectStats, SubsurfaceMethod, Target,
};
use crate::optics::fresnel::f_ext;
use crate::progress::{ms, Cancelled, Progress};
use crate::radiosity::{
    solve_coupled_with, FormFactors, Gather, Iteration, Opaque, PatchSet, RadiosityError, Solution, SolveOptions, Translucent,
};
use crate::scene::{BakeOptions, Diffuse, MediumSource, Object, RadiosityOptions, Scene, SceneError, TranslucentScattering};

/// The direct light of a set of lights: E_d per patch (0 on translucent patches) and the
/// transmitted q_d per translucent object (in its patch order).
struct Direct {
    opaque: Vec<[f64; 3]>,
    transmitted: Vec<Option<Vec<[f64; 3]>>>,
}

/// What one object shows: its radiance at the user's vertices and on its patch surface.
#[derive(Debug, Clone)]
struct Output {
    radiance: Vec<[f64; 3]>,
    patch_radiance: Vec<[f64; 3]>,
    back_radiance: Option<Vec<[f64; 3]>>,
}

/// What one update of a [`RadiositySession`] did.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RadiosityUpdate {
    /// Coupled solves made (0 when the lights were a weighted sum of known responses).
    pub solves: usize,
    /// Sweeps of the iteration, summed over the solves.
    pub iterations: usize,
    /// Diffusion solves per translucent object, summed over the solves.
    pub scatterings: usize,
    /// The largest a-posteriori error estimate of the solves (0 when none was made).
    pub estimated_error: f64,
    /// The largest energy defect of the solves.
    pub energy_defect: f64,
    /// The direct light on the patches.
    pub direct_ms: f64,
    /// The coupled solves.
    pub solve_ms: f64,
    /// Everything, the radiance at the user's vertices included.
    pub total_ms: f64,
    /// The GPU that computed the gathers F B of the last solve; `None`: the CPU.
    pub device: Option<String>,
    /// Why the last solve's gathers ran on the CPU although the backend was `gpu` or `auto`.
    pub device_fallback: Option<String>,
}

/// Where the coupled solves' gathers E = F B run: the GPU [`RadiosityOptions::backend`]
/// resolves to ([`gpu::choose_device`]: `auto` never takes a software adapter), F uploaded at
/// the first solve that gathers there and kept; else the CPU, with the reason. F too large for
/// the device ([`gpu::GpuError::TooLarge`]) and the Gauss–Seidel iteration (sequential sweeps)
/// stay on the CPU and say so.
#[derive(Default)]
struct SweepDevice {
    #[cfg(feature = "gpu")]
    context: Option<&'static gpu::GpuContext>,
    #[cfg(feature = "gpu")]
    uploaded: Option<Box<gpu::GpuRadiosity<'static>>>,
    /// The backend asked for (`auto` falls back on any failure to upload F, `gpu` only when F
    /// is too large).
    requested: Option<Backend>,
    /// Why the gathers run on the CPU, when a GPU was asked for or looked for and none is used.
    fallback: Option<String>,
}

impl Clone for SweepDevice {
    /// The same device; the copy uploads its own F at its first solve.
    fn clone(&self) -> Self {
        Self {
            #[cfg(feature = "gpu")]
            context: self.context,
            #[cfg(feature = "gpu")]
            uploaded: None,
            requested: self.requested,
            fallback: self.fallback.clone(),
        }
    }
}

/// The gather of one solve: the device's, or `None` for the CPU's, and where it ran.
struct SweepsOn<'g> {
    gather: Option<&'g dyn Gather>,
    placed: Placed,
}

/// Where one solve's gathers ran: the device's name, or why the CPU.
#[derive(Debug, Clone, Default)]
struct Placed {
    device: Option<String>,
    fallback: Option<String>,
}

impl SweepDevice {
    /// The device `options.backend` (else `TRANSCUT_BACKEND`, else `auto`) picks.
    ///
    /// # Errors
    /// [`SceneError::InvalidOptions`] for an unknown `TRANSCUT_BACKEND`;
    /// [`SceneError::Radiosity`] ([`RadiosityError::Device`]) when `gpu` was asked for and no
    /// device can be had.
    fn choose(options: &RadiosityOptions) -> Result<Self, SceneError> {
        let backend = match options.backend {
            Some(b) => b,
            None => Backend::from_env_or(Backend::Auto).map_err(|e| SceneError::InvalidOptions(format!("{NAME}: {e}")))?,
        };
        let (choice, fallback) = gpu::choose_device(backend).map_err(|e| RadiosityError::Device(e.to_string()))?;
        Ok(match choice {
            DeviceChoice::Cpu => Self {
                #[cfg(feature = "gpu")]
                context: None,
                #[cfg(feature = "gpu")]
                uploaded: None,
                requested: Some(backend),
                fallback,
            },
            #[cfg(feature = "gpu")]
            DeviceChoice::Gpu(context) => Self { context: Some(context), requested: Some(backend), ..Self::default() },
        })
    }

    /// The gather of a solve by `iteration` of `factors`: the device's (F uploaded on first
    /// use), or `None` for the CPU's, with where it runs.
    ///
    /// # Errors
    /// [`SceneError::Radiosity`] when `gpu` was asked for and F could not be uploaded for
    /// another reason than its size.
    fn gather(&mut self, factors: &FormFactors, iteration: Iteration) -> Result<SweepsOn<'_>, SceneError> {
        let on_cpu = |fallback: Option<String>| SweepsOn { gather: None, placed: Placed { device: None, fallback } };
        if iteration == Iteration::GaussSeidel {
            // Why there is no GPU, when there is none; else why Gauss–Seidel does not use it.
            let asked = self.requested.is_some_and(|b| b != Backend::Cpu);
            return Ok(on_cpu(self.fallback.clone().or_else(|| {
                asked.then(|| {
                    "Gauss–Seidel sweeps run on the CPU (each patch gathers from values updated within the sweep); \
                     jacobi and bicgstab gather on the GPU"
                        .to_owned()
                })
            })));
        }
        #[cfg(feature = "gpu")]
        if let Some(context) = self.context {
            if self.uploaded.is_none() {
                match gpu::GpuRadiosity::for_gather(context, factors) {
                    Ok(device) => self.uploaded = Some(Box::new(device)),
                    Err(e) if matches!(e, gpu::GpuError::TooLarge { .. }) || self.requested == Some(Backend::Auto) => {
                        self.context = None;
                        self.fallback = Some(format!("the form factors stay on the CPU: {e}"));
                    }
                    Err(e) => return Err(RadiosityError::Device(e.to_string()).into()),
                }
            }
            if let Some(device) = &self.uploaded {
                let name = device.device_name().to_owned();
                return Ok(SweepsOn { gather: Some(&**device), placed: Placed { device: Some(name), fallback: None } });
            }
        }
        #[cfg(not(feature = "gpu"))]
        let _ = factors;
        Ok(on_cpu(self.fallback.clone()))
    }
}

/// What does not change in a session: the scene's geometry, the patches and the form factors.
#[derive(Clone)]
struct Fixed {
    objects: Vec<Object>,
    world: Vec<TriMesh>,
    /// Every object's world surface, when shadows are on.
    occluder: Option<TriangleBvh>,
    options: BakeOptions,
    radiosity: RadiosityOptions,
    surfaces: Vec<PatchSurface>,
    patches: PatchSet,
    factors: FormFactors,
    /// Where the gathers F B run.
    device: SweepDevice,
}

/// A radiosity bake being edited (module documentation).
#[derive(Clone)]
pub struct RadiositySession {
    fixed: Fixed,
    /// Each translucent object's tets and assembled system (`None` for an opaque object); its
    /// source and fluence are scratch, set before each use.
    scatterers: Vec<Option<Scatterer>>,
    object_stats: Vec<ObjectStats>,
    /// ρ and M per patch (0 on translucent patches).
    albedo: Vec<[f64; 3]>,
    emission: Vec<[f64; 3]>,
    lights: Vec<Light>,
    /// The solution under `lights`.
    current: Response,
    /// Solutions of single sources under the current materials.
    responses: Vec<(Source, Response)>,
    outputs: Vec<Output>,
    stats: RadiosityStats,
}

impl std::fmt::Debug for RadiositySession {
    /// Counts, not the matrices.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RadiositySession")
            .field("objects", &self.fixed.objects.len())
            .field("patches", &self.fixed.patches.len())
            .field("lights", &self.lights.len())
            .field("responses", &self.responses.len())
            .field("stats", &self.stats)
            .finish_non_exhaustive()
    }
}

impl RadiositySession {
    /// Bakes `scene` by translucent radiosity (the module documentation of
    /// [`super`]), keeping what later updates start from.
    ///
    /// # Errors
    /// [`SceneError`] naming the object at fault; [`SceneError::InvalidOptions`] when the
    /// objects have different `mm_per_unit` or the radiosity stage refuses its input.
    pub(crate) fn bake(
        scene: &Scene,
        options: &BakeOptions,
        radiosity: &RadiosityOptions,
        progress: Progress,
    ) -> Result<Self, SceneError> {
        let world = world_surfaces(scene)?;
        let targets = targets(scene, &world, None);
        let mm_per_unit = common_scale(&targets)?;
        let profile = match radiosity.scattering {
            TranslucentScattering::Profile(p) => Some(p),
            _ => None,
        };
        for target in targets.iter().filter(|t| t.object.medium().is_some()) {
            match profile {
                None => TransCut::check(target, &radiosity.transcut)?,
                Some(_) => check_medium(target, target.object.medium())?,
            }
        }
        let device = SweepDevice::choose(radiosity)?;
        let furthest = std::sync::Mutex::new(0.0f64);
        let report = |stage: &str, fraction: f64| super::report(&progress, &furthest, stage, fraction);

        // 1. The translucent objects of the diffusion S, prepared as TransCut prepares them.
        let t = Instant::now();
        let mut object_stats: Vec<ObjectStats> = targets.iter().map(object_stats).collect();
        let mut scatterers: Vec<Option<Scatterer>> = Vec::with_capacity(targets.len());
        for (target, stats) in targets.iter().zip(&mut object_stats) {
            scatterers.push(match (target.object.medium(), profile) {
                (Some(_), None) => {
                    let stage = |s: &str, f: f64| report(&format!("{}: {s}", target.object.name), 0.3 * f);
                    let t = Instant::now();
                    let p = TransCut::prepare(target, &radiosity.transcut, stats, &stage)?;
                    stats.total_ms += ms(t);
                    Some(Scatterer::Diffusion(p))
                }
                _ => None,
            });
        }
        let prepare_ms = ms(t);

        // 2. The patches.
        report("radiosity: patches", 0.3)?;
        let t = Instant::now();
        let patch_size_mm = radiosity.patch_size_mm.unwrap_or_else(|| scene_diagonal(&world) * mm_per_unit / 80.0);
        let surfaces: Vec<PatchSurface> = targets
            .iter()
            .zip(&scatterers)
            .map(|(target, p)| patch_surface(target, p.as_ref().and_then(Scatterer::prepared), patch_size_mm / mm_per_unit))
            .collect::<Result<_, _>>()?;
        let patches = PatchSet::new(&surfaces.iter().map(PatchSurface::as_surface).collect::<Vec<_>>())?;
        let patches_ms = ms(t);

        // 2b. The profile matrices of the translucent objects of the profile S, on those patches.
        let t = Instant::now();
        if let Some(profile) = profile {
            for ((target, surface), (slot, stats)) in
                targets.iter().zip(&surfaces).zip(scatterers.iter_mut().zip(&mut object_stats))
            {
                if target.object.medium().is_some() {
                    report(&format!("{}: profile matrix", target.object.name), 0.3)?;
                    let t = Instant::now();
                    *slot = Some(Scatterer::Profile(ProfileObject::build(target, surface, mm_per_unit, &profile)?));
                    stats.total_ms += ms(t);
                }
            }
        }
        let scattering_ms = ms(t);
        let profiles: Vec<&ProfileObject> = scatterers.iter().flatten().filter_map(Scatterer::profile).collect();
        let (scattering_nonzeros, scattering_bytes) =
            (profiles.iter().map(|o| o.nonzeros()).sum(), profiles.iter().map(|o| o.bytes()).sum());

        // 3. The form factors.
        let t = Instant::now();
        let counter = std::sync::Mutex::new(0usize);
        let keep_going = || {
            let mut done = counter.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            *done += 1;
            report("radiosity: form factors", 0.3 + 0.3 * *done as f64 / patches.len() as f64).is_ok()
        };
        let factors = FormFactors::gather(&patches, &radiosity.form_factors, &keep_going)?;
        let form_factor_ms = ms(t);

        let n = patches.len();
        let (mut albedo, mut emission) = (vec![[0.0; 3]; n], vec![[0.0; 3]; n]);
        for (s, target) in targets.iter().enumerate() {
            if let Some(d) = target.object.material.diffuse() {
                for i in surface_patches(&patches, s, surfaces[s].vertex_count()) {
                    albedo[i] = d.albedo;
                    emission[i] = d.emission;
                }
            }
        }
        let translucent_patches =
            targets.iter().zip(&surfaces).filter(|(t, _)| t.object.medium().is_some()).map(|(_, s)| s.vertex_count()).sum();
        let stats = RadiosityStats {
            patches: n,
            translucent_patches,
            covered_patches: factors.covered().iter().filter(|&&c| c).count(),
            nonzeros: factors.nonzeros(),
            form_factor_bytes: factors.bytes(),
            patch_size_mm,
            prepare_ms,
            patches_ms,
            scattering_ms,
            scattering_nonzeros,
            scattering_bytes,
            form_factor_ms,
            direct_ms: 0.0,
            solve_ms: 0.0,
            iterations: 0,
            scatterings: 0,
            estimated_error: 0.0,
            energy_defect: 0.0,
            device: None,
            device_fallback: None,
        };
        drop(targets);
        let occluder = options.shadows.then(|| Lighting::occluder_of(&world));
        let mut fixed = Fixed {
            objects: scene.objects.clone(),
            world,
            occluder,
            options: options.clone(),
            radiosity: radiosity.clone(),
            surfaces,
            patches,
            factors,
            device,
        };

        // 4. The direct light and 5. the coupled solve, 6. the radiance.
        report("radiosity: light", 0.6)?;
        let t = Instant::now();
        let direct = fixed.direct(&scatterers, &scene.lights)?;
        let direct_ms = ms(t);
        let t = Instant::now();
        let poll = |f: f64| report("radiosity: solve", 0.65 + 0.33 * f);
        let (current, solution, placed) =
            fixed.solve(&mut scatterers, &mut object_stats, &albedo, &emission, &direct, None, &poll)?;
        let solve_ms = ms(t);
        let mut session = Self {
            fixed,
            scatterers,
            object_stats,
            albedo,
            emission,
            lights: scene.lights.clone(),
            current,
            responses: Vec::new(),
            outputs: Vec::new(),
            stats,
        };
        let mut update = RadiosityUpdate { direct_ms, solve_ms, ..RadiosityUpdate::new() };
        update.add(&solution, placed);
        session.record_update(&update);
        session.cache_single_source();
        session.outputs = session.outputs()?;
        report("radiosity: done", 1.0)?;
        Ok(session)
    }

    /// The statistics of the bake, with those of the last solve.
    #[must_use]
    pub fn stats(&self) -> &RadiosityStats {
        &self.stats
    }

    /// The lights the scene is solved under.
    #[must_use]
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// The number of objects.
    #[must_use]
    pub fn len(&self) -> usize {
        self.fixed.objects.len()
    }

    /// Whether the session has no objects (never, for a session made by a bake).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.fixed.objects.is_empty()
    }

    /// The objects as the session has them (with the albedos, emissions and media set since).
    #[must_use]
    pub fn objects(&self) -> &[Object] {
        &self.fixed.objects
    }

    /// The refractive index at object `index`'s surface (after any `set_medium`; 1 for an
    /// opaque object, which renders Lambertian), `None` for an index out of range.
    #[must_use]
    pub fn eta(&self, index: usize) -> Option<f64> {
        self.scatterers.get(index).map(|s| s.as_ref().map_or(1.0, Scatterer::eta))
    }

    /// Object `index`'s statistics: the bake's, with its last diffusion solve's iterations and
    /// residual (and its assembly after a new medium).
    #[must_use]
    pub fn object_stats(&self, index: usize) -> Option<&ObjectStats> {
        self.object_stats.get(index)
    }

    /// Object `index`'s radiance at its user's vertices (as [`ObjectBake::radiance`]), `None`
    /// for an index out of range.
    #[must_use]
    pub fn radiance(&self, index: usize) -> Option<&[[f64; 3]]> {
        self.outputs.get(index).map(|o| o.radiance.as_slice())
    }

    /// Object `index`'s radiance on its patch surface's vertices, the front side (as
    /// [`RadiosityObject::patch_radiance`]).
    #[must_use]
    pub fn patch_radiance(&self, index: usize) -> Option<&[[f64; 3]]> {
        self.outputs.get(index).map(|o| o.patch_radiance.as_slice())
    }

    /// Object `index`'s radiance on its patch surface's back side, for a two-sided surface.
    #[must_use]
    pub fn back_radiance(&self, index: usize) -> Option<&[[f64; 3]]> {
        self.outputs.get(index).and_then(|o| o.back_radiance.as_deref())
    }

    /// Every object's bake as it stands now (the bake's, updated by the calls since).
    ///
    /// # Errors
    /// [`SceneError::Diffusion`] for a non-finite fluence (cannot happen after a successful
    /// update).
    pub fn object_bakes(&self) -> Result<Vec<ObjectBake>, SceneError> {
        let mut out = Vec::with_capacity(self.len());
        for (s, ((p, output), stats)) in self.scatterers.iter().zip(&self.outputs).zip(&self.object_stats).enumerate() {
            let surface = &self.fixed.surfaces[s];
            let state = RadiosityObject {
                patch_positions: surface.positions.clone(),
                patch_triangles: surface.triangles.clone(),
                patch_radiance: output.patch_radiance.clone(),
                back_radiance: output.back_radiance.clone(),
                eta: p.as_ref().map_or(1.0, Scatterer::eta),
                diffuse: self.fixed.objects[s].material.diffuse().copied(),
                transcut: match (p.as_ref().and_then(Scatterer::prepared), &self.current.fields[s]) {
                    (Some(p), Some(field)) => {
                        let mut p = p.clone();
                        p.set_solution(&field.source, field.fluence.clone()).map_err(|e| self.diffusion_error(s, e))?;
                        Some(p.into_state())
                    }
                    _ => None,
                },
            };
            out.push(ObjectBake {
                radiance: output.radiance.clone(),
                stats: stats.clone(),
                state: BakedState::Radiosity(Box::new(state)),
            });
        }
        Ok(out)
    }

    /// Re-solves the scene under `lights` (module documentation: a weighted sum of known
    /// responses where the lights differ only in strength, a warm-started solve of each new
    /// light otherwise). Nothing changes on failure.
    ///
    /// # Errors
    /// [`SceneError::Light`] for an invalid light; a solve's error; [`SceneError::Cancelled`].
    pub fn relight(&mut self, lights: &[Light], progress: Progress) -> Result<RadiosityUpdate, SceneError> {
        let start = Instant::now();
        light::validate_lights(lights).map_err(SceneError::from)?;
        let split: Vec<(Light, [f64; 3])> = lights.iter().map(Light::split_strength).collect();
        let mut sources: Vec<Source> = Vec::new();
        for (unit, _) in &split {
            let source = Source::Light(unit.clone());
            if !sources.contains(&source) {
                sources.push(source);
            }
        }
        if self.emits() {
            sources.push(Source::Emission);
        }
        let missing: Vec<&Source> = sources.iter().filter(|s| !self.responses.iter().any(|(c, _)| c == *s)).collect();
        let mut update = RadiosityUpdate::new();
        let mut fresh: Vec<(Source, Response)> = Vec::new();
        let mut stats = self.object_stats.clone();
        let count = missing.len();
        for (k, &source) in missing.iter().enumerate() {
            let poll = |f: f64| progress.report("radiosity: solve", (k as f64 + f) / count as f64);
            let t = Instant::now();
            let direct = match source {
                Source::Light(unit) => self.fixed.direct(&self.scatterers, std::slice::from_ref(unit))?,
                Source::Emission => self.fixed.no_direct(&self.scatterers),
            };
            update.direct_ms += ms(t);
            let emission = match source {
                Source::Light(_) => vec![[0.0; 3]; self.albedo.len()],
                Source::Emission => self.emission.clone(),
            };
            let bounces = self.fixed.radiosity.solve.bounces;
            let initial = warm_start(&self.responses, &self.lights, bounces, source, lights);
            let t = Instant::now();
            let (response, solution, placed) =
                self.fixed.solve(&mut self.scatterers, &mut stats, &self.albedo, &emission, &direct, initial, &poll)?;
            update.solve_ms += ms(t);
            update.add(&solution, placed);
            fresh.push((source.clone(), response));
        }
        let find = |source: &Source| -> &Response {
            fresh
                .iter()
                .chain(&self.responses)
                .find(|(s, _)| s == source)
                .map(|(_, r)| r)
                .expect("every source was solved or cached")
        };
        let mut current = Response::zero_like(&self.current);
        for (unit, strength) in &split {
            current.add_scaled(*strength, find(&Source::Light(unit.clone())));
        }
        if self.emits() {
            current.add_scaled([1.0; 3], find(&Source::Emission));
        }
        let outputs = self.fixed.outputs(&mut self.scatterers, &current, &mut stats)?;
        progress.report("radiosity: done", 1.0)?;
        // Commit: keep the responses the new lights use.
        let kept: Vec<(Source, Response)> =
            std::mem::take(&mut self.responses).into_iter().filter(|(s, _)| sources.contains(s)).collect();
        self.responses = fresh;
        self.responses.extend(kept);
        self.object_stats = stats;
        self.lights = lights.to_vec();
        self.current = current;
        self.outputs = outputs;
        update.total_ms = ms(start);
        self.record_update(&update);
        Ok(update)
    }

    /// Sets diffuse object `index`'s albedo and re-solves (module documentation).
    ///
    /// # Errors
    /// [`SceneError::InvalidObject`] for a translucent object or an albedo outside [0, 1);
    /// [`SceneError::NoSuchObject`]; a solve's error; [`SceneError::Cancelled`].
    pub fn set_albedo(&mut self, index: usize, albedo: [f64; 3], progress: Progress) -> Result<RadiosityUpdate, SceneError> {
        let mut diffuse = self.diffuse(index, "an albedo")?;
        diffuse.albedo = albedo;
        self.set_diffuse(index, diffuse, progress)
    }

    /// Sets diffuse object `index`'s emitted exitance and re-solves.
    ///
    /// # Errors
    /// As [`RadiositySession::set_albedo`], for an emission not finite and ≥ 0.
    pub fn set_emission(&mut self, index: usize, emission: [f64; 3], progress: Progress) -> Result<RadiosityUpdate, SceneError> {
        let mut diffuse = self.diffuse(index, "an emission")?;
        diffuse.emission = emission;
        self.set_diffuse(index, diffuse, progress)
    }

    /// Puts `medium` on translucent object `index` and re-solves: on its tets (the mesh kept),
    /// its system assembled again, with the diffusion S; its profiles with a profile S (S
    /// re-indexed from its samples from one homogeneous medium to another, built afresh on the
    /// same patches when the profiles reach further or either medium is heterogeneous; η and
    /// Fresnel with them).
    ///
    /// # Errors
    /// [`SceneError::InvalidObject`] for an opaque object; the medium's, the resolution check's
    /// or a solve's error naming the object; [`SceneError::Cancelled`].
    pub fn set_medium(&mut self, index: usize, medium: MediumSource, progress: Progress) -> Result<RadiosityUpdate, SceneError> {
        let start = Instant::now();
        let target = self.target(index)?;
        let mut stats = self.object_stats.clone();
        let changed = match &self.scatterers[index] {
            Some(Scatterer::Diffusion(p)) => Scatterer::Diffusion(p.with_medium(&target, &medium, &mut stats[index])?),
            Some(Scatterer::Profile(o)) => Scatterer::Profile(o.with_medium(&target, &medium)?),
            None => return Err(target.invalid("it is an opaque diffuse surface: set its albedo or emission, not a medium")),
        };
        let mut objects = self.fixed.objects.clone();
        objects[index].material = medium.into();
        let change = Change { scatterers: Some((index, changed)), albedo: None, emission: None, objects: Some(objects) };
        self.resolve(change, stats, true, start, progress)
    }

    /// Solves the scene again from nothing with `solve` (another iteration, tolerance, sweep
    /// limit or count of bounces) and keeps it for later updates: what a bake with these
    /// options gives, without the form factors again.
    ///
    /// # Errors
    /// [`SceneError::InvalidOptions`] for options out of range; a solve's error;
    /// [`SceneError::Cancelled`]. Nothing changes on failure.
    pub fn set_solve_options(&mut self, solve: SolveOptions, progress: Progress) -> Result<RadiosityUpdate, SceneError> {
        let start = Instant::now();
        solve.validate().map_err(|e| SceneError::InvalidOptions(format!("{NAME}: {e}")))?;
        let old = std::mem::replace(&mut self.fixed.radiosity.solve, solve);
        let result = self.resolve(Change::default(), self.object_stats.clone(), false, start, progress);
        if result.is_err() {
            self.fixed.radiosity.solve = old;
        }
        result
    }

    /// The options the scene is solved with.
    #[must_use]
    pub fn solve_options(&self) -> &SolveOptions {
        &self.fixed.radiosity.solve
    }

    /// Object `index`'s diffuse material, or an error naming `what` could not be set.
    fn diffuse(&self, index: usize, what: &str) -> Result<Diffuse, SceneError> {
        let target = self.target(index)?;
        target
            .object
            .material
            .diffuse()
            .copied()
            .ok_or_else(|| target.invalid(format!("it is translucent: its colour comes from its medium, so it takes no {what}")))
    }

    /// Replaces diffuse object `index`'s material by `diffuse` and re-solves.
    fn set_diffuse(&mut self, index: usize, diffuse: Diffuse, progress: Progress) -> Result<RadiosityUpdate, SceneError> {
        let start = Instant::now();
        diffuse.validate().map_err(|e| self.target(index).map_or_else(|e| e, |t| t.invalid(e)))?;
        let (mut albedo, mut emission) = (self.albedo.clone(), self.emission.clone());
        let patches = &self.fixed.patches;
        for i in surface_patches(patches, index, self.fixed.surfaces[index].vertex_count()) {
            albedo[i] = diffuse.albedo;
            emission[i] = diffuse.emission;
        }
        let mut objects = self.fixed.objects.clone();
        objects[index].material = diffuse.into();
        let change = Change { scatterers: None, albedo: Some(albedo), emission: Some(emission), objects: Some(objects) };
        self.resolve(change, self.object_stats.clone(), true, start, progress)
    }

    /// Solves the scene under its lights with `change` made, warm-started from the current
    /// solution when `warm`, and commits it: the responses are dropped (they were of the old
    /// materials) and kept again when there is one source. On failure the change is undone.
    fn resolve(
        &mut self,
        mut change: Change,
        mut stats: Vec<ObjectStats>,
        warm: bool,
        start: Instant,
        progress: Progress,
    ) -> Result<RadiosityUpdate, SceneError> {
        // The new system in place, the old one kept to put back on failure.
        let replaced = change.scatterers.take().map(|(index, p)| (index, self.scatterers[index].replace(p)));
        let result = self.resolve_changed(&change, &mut stats, warm, progress);
        match result {
            Ok((current, outputs, mut update)) => {
                if let Some(albedo) = change.albedo {
                    self.albedo = albedo;
                }
                if let Some(emission) = change.emission {
                    self.emission = emission;
                }
                if let Some(objects) = change.objects {
                    self.fixed.objects = objects;
                }
                self.object_stats = stats;
                self.current = current;
                self.outputs = outputs;
                self.responses.clear();
                self.cache_single_source();
                update.total_ms = ms(start);
                self.record_update(&update);
                Ok(update)
            }
            Err(e) => {
                if let Some((index, old)) = replaced {
                    self.scatterers[index] = old;
                }
                Err(e)
            }
        }
    }

    /// The solve of [`RadiositySession::resolve`], with the new system already in place.
    fn resolve_changed(
        &mut self,
        change: &Change,
        stats: &mut [ObjectStats],
        warm: bool,
        progress: Progress,
    ) -> Result<(Response, Vec<Output>, RadiosityUpdate), SceneError> {
        let albedo = change.albedo.as_ref().unwrap_or(&self.albedo);
        let emission = change.emission.as_ref().unwrap_or(&self.emission);
        let mut update = RadiosityUpdate::new();
        let t = Instant::now();
        let direct = self.fixed.direct(&self.scatterers, &self.lights)?;
        update.direct_ms = ms(t);
        let poll = |f: f64| progress.report("radiosity: solve", f);
        let t = Instant::now();
        let initial = (warm && self.fixed.radiosity.solve.bounces.is_none()).then_some(&self.current);
        let (current, solution, placed) =
            self.fixed.solve(&mut self.scatterers, stats, albedo, emission, &direct, initial, &poll)?;
        update.solve_ms = ms(t);
        update.add(&solution, placed);
        let outputs = self.fixed.outputs(&mut self.scatterers, &current, stats)?;
        progress.report("radiosity: done", 1.0)?;
        Ok((current, outputs, update))
    }

    /// Keeps the current solution as the one response when the scene has a single source
    /// (one light of strength > 0 in every channel and no emission, or emission and no light).
    fn cache_single_source(&mut self) {
        match (self.lights.as_slice(), self.emits()) {
            ([light], false) => {
                let (unit, strength) = light.split_strength();
                if strength.iter().all(|&s| s > 0.0) {
                    self.responses = vec![(Source::Light(unit), self.current.divided(strength))];
                }
            }
            ([], true) => self.responses = vec![(Source::Emission, self.current.clone())],
            _ => {}
        }
    }

    /// Whether any diffuse patch emits.
    fn emits(&self) -> bool {
        self.emission.iter().any(|e| e.iter().any(|&x| x > 0.0))
    }

    /// Object `index` as a target.
    fn target(&self, index: usize) -> Result<Target<'_>, SceneError> {
        let count = self.len();
        match (self.fixed.objects.get(index), self.fixed.world.get(index)) {
            (Some(object), Some(world)) => Ok(Target { index, object, world, reuse: Reuse::Nothing }),
            _ => Err(SceneError::InvalidOptions(format!("object {index} does not exist (the scene has {count} objects)"))),
        }
    }

    fn diffusion_error(&self, index: usize, source: crate::diffusion::DiffusionError) -> SceneError {
        SceneError::Diffusion { index, name: self.fixed.objects[index].name.clone(), source }
    }

    /// The outputs of the current solution.
    fn outputs(&mut self) -> Result<Vec<Output>, SceneError> {
        self.fixed.outputs(&mut self.scatterers, &self.current, &mut self.object_stats)
    }

    /// The statistics of the last update, when it solved.
    fn record_update(&mut self, update: &RadiosityUpdate) {
        if update.solves > 0 {
            self.stats.direct_ms = update.direct_ms;
            self.stats.solve_ms = update.solve_ms;
            self.stats.iterations = update.iterations;
            self.stats.scatterings = update.scatterings;
            self.stats.estimated_error = update.estimated_error;
            self.stats.energy_defect = update.energy_defect;
            self.stats.device.clone_from(&update.device);
            self.stats.device_fallback.clone_from(&update.device_fallback);
        }
    }
}

/// What a material change replaces: one translucent object's system, the albedo and emission
/// per patch, the objects as described.
#[derive(Default)]
struct Change {
    scatterers: Option<(usize, Scatterer)>,
    albedo: Option<Vec<[f64; 3]>>,
    emission: Option<Vec<[f64; 3]>>,
    objects: Option<Vec<Object>>,
}

impl RadiosityUpdate {
    fn new() -> Self {
        Self {
            solves: 0,
            iterations: 0,
            scatterings: 0,
            estimated_error: 0.0,
            energy_defect: 0.0,
            direct_ms: 0.0,
            solve_ms: 0.0,
            total_ms: 0.0,
            device: None,
            device_fallback: None,
        }
    }

    /// Counts one solve, whose gathers ran as `placed` says.
    fn add(&mut self, solution: &Solution, placed: Placed) {
        self.device = placed.device;
        self.device_fallback = placed.fallback;
        self.solves += 1;
        self.iterations += solution.iterations;
        self.scatterings += solution.scatterings;
        self.estimated_error = self.estimated_error.max(solution.estimated_error);
        self.energy_defect = self.energy_defect.max(solution.energy.defect());
    }
}

impl Fixed {
    /// Every object's radiance for the solution `response` (set into `scatterers` to read the
    /// translucent objects'), checked as a bake's (clamped vertices counted into `stats`).
    fn outputs(
        &self,
        scatterers: &mut [Option<Scatterer>],
        response: &Response,
        stats: &mut [ObjectStats],
    ) -> Result<Vec<Output>, SceneError> {
        let fixed = self;
        let b = fill_covered(&fixed.patches, &fixed.surfaces, fixed.factors.covered(), &response.radiosity);
        let mut out = Vec::with_capacity(fixed.objects.len());
        for (s, (p, stats)) in scatterers.iter_mut().zip(stats.iter_mut()).enumerate() {
            let target = Target { index: s, object: &fixed.objects[s], world: &fixed.world[s], reuse: Reuse::Nothing };
            let surface = &fixed.surfaces[s];
            let side = |back: bool| -> Option<Vec<[f64; 3]>> {
                (0..surface.vertex_count()).map(|v| fixed.patches.patch_of(s, v, back).map(|i| b[i])).collect()
            };
            let front = side(false).expect("front patches");
            let output = match (p.as_mut(), &response.fields[s]) {
                (Some(Scatterer::Diffusion(p)), Some(field)) => {
                    p.set_solution(&field.source, field.fluence.clone()).map_err(|source| SceneError::Diffusion {
                        index: s,
                        name: target.object.name.clone(),
                        source,
                    })?;
                    let radiance = p.user_radiance(&target, stats)?;
                    let lo = p.boundary_radiance(&target)?.into_iter().map(|l| l.map(|x| x.max(0.0))).collect();
                    Output { radiance, patch_radiance: lo, back_radiance: None }
                }
                (Some(Scatterer::Profile(o)), _) => {
                    let (front, clamped) = o.radiance(&front);
                    stats.clamped_vertices = target.world.user_to_internal().iter().filter(|&&v| clamped[v as usize]).count();
                    surface_output(&target, surface, front, None, stats)
                }
                _ => {
                    let to_radiance = |b: Vec<[f64; 3]>| -> Vec<[f64; 3]> {
                        b.into_iter().map(|x| x.map(|x| (x / std::f64::consts::PI).max(0.0))).collect()
                    };
                    surface_output(&target, surface, to_radiance(front), side(true).map(to_radiance), stats)
                }
            };
            check_radiance(&target, NAME, &output.radiance)?;
            out.push(output);
        }
        Ok(out)
    }

    /// The direct light of `lights` on every patch, shadowed by every object when shadows are on.
    fn direct(&self, scatterers: &[Option<Scatterer>], lights: &[Light]) -> Result<Direct, SceneError> {
        let lighting = Lighting { lights, occluder: self.occluder.as_ref(), source: &self.options.source };
        let n = self.patches.len();
        let mut opaque_patches = Vec::new();
        let mut transmitted = Vec::with_capacity(scatterers.len());
        for (s, p) in scatterers.iter().enumerate() {
            match p {
                None => {
                    opaque_patches.extend(surface_patches(&self.patches, s, self.surfaces[s].vertex_count()));
                    transmitted.push(None);
                }
                Some(Scatterer::Diffusion(p)) => {
                    let boundary = p.system().boundary();
                    let points: Vec<DVec3> = boundary.ids.iter().map(|&v| p.tet_mesh().positions()[v as usize]).collect();
                    transmitted.push(Some(lighting.transmitted_source(
                        &points,
                        &boundary.normal,
                        p.system().boundary_terms().eta,
                    )?));
                }
                Some(Scatterer::Profile(o)) => {
                    let range = self.patches.front_range(s);
                    let (points, normals) = (&self.patches.positions()[range.clone()], &self.patches.normals()[range]);
                    transmitted.push(Some(lighting.transmitted_source(points, normals, o.eta())?));
                }
            }
        }
        let points: Vec<DVec3> = opaque_patches.iter().map(|&i| self.patches.positions()[i]).collect();
        let normals: Vec<DVec3> = opaque_patches.iter().map(|&i| self.patches.normals()[i]).collect();
        let irradiance = light::irradiance(lights, &points, &normals, lighting.occluder, lighting.source)?;
        let mut opaque = vec![[0.0; 3]; n];
        for (&i, e) in opaque_patches.iter().zip(irradiance) {
            opaque[i] = e;
        }
        Ok(Direct { opaque, transmitted })
    }

    /// No direct light (the emission's response).
    fn no_direct(&self, scatterers: &[Option<Scatterer>]) -> Direct {
        Direct {
            opaque: vec![[0.0; 3]; self.patches.len()],
            transmitted: scatterers.iter().map(|p| p.as_ref().map(|p| vec![[0.0; 3]; p.patch_count()])).collect(),
        }
    }

    /// The coupled solve for `direct`, `emission` and the materials, from `initial` (its
    /// radiosity, and each translucent object's fluence as its diffusion warm start).
    #[allow(clippy::too_many_arguments)]
    fn solve(
        &mut self,
        scatterers: &mut [Option<Scatterer>],
        stats: &mut [ObjectStats],
        albedo: &[[f64; 3]],
        emission: &[[f64; 3]],
        direct: &Direct,
        initial: Option<&Response>,
        poll: &(dyn Fn(f64) -> Result<(), Cancelled> + Sync),
    ) -> Result<(Response, Solution, Placed), SceneError> {
        let targets: Vec<Target<'_>> = (0..self.objects.len())
            .map(|s| Target { index: s, object: &self.objects[s], world: &self.world[s], reuse: Reuse::Nothing })
            .collect();
        if let Some(initial) = initial {
            for (s, (p, field)) in scatterers.iter_mut().zip(&initial.fields).enumerate() {
                if let (Some(p), Some(field)) = (p.as_mut().and_then(Scatterer::prepared_mut), field) {
                    p.set_solution(&field.source, field.fluence.clone()).map_err(|source| SceneError::Diffusion {
                        index: s,
                        name: self.objects[s].name.clone(),
                        source,
                    })?;
                }
            }
        }
        let mut operators: Vec<(usize, f64, Operator<'_>)> = Vec::new();
        for (s, ((target, p), stats)) in targets.iter().zip(scatterers.iter_mut()).zip(stats.iter_mut()).enumerate() {
            match p.as_mut() {
                Some(Scatterer::Diffusion(p)) => {
                    let op = DiffusionScattering::new(p, target, &self.radiosity.transcut, stats, poll);
                    operators.push((s, 1.0 - f_ext(op.eta()), Operator::Diffusion(op)));
                }
                Some(Scatterer::Profile(o)) => operators.push((s, o.transmittance(), Operator::Profile(o.operator()))),
                None => {}
            }
        }
        let mut blocks: Vec<Translucent<'_, SceneError>> = operators
            .iter_mut()
            .map(|(s, transmittance, op)| Translucent {
                first: self.patches.patch_of(*s, 0, false).expect("every surface has front patches"),
                transmittance: *transmittance,
                direct: direct.transmitted[*s].as_deref().expect("a translucent object's q_d"),
                scattering: op,
            })
            .collect();
        let opaque = Opaque { albedo, direct: &direct.opaque, emission };
        let sweeps = std::sync::Mutex::new(0usize);
        let keep_going = || {
            let mut k = sweeps.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            *k += 1;
            poll(1.0 - 0.5f64.powi(*k as i32)).is_ok()
        };
        let on = self.device.gather(&self.factors, self.radiosity.solve.iteration)?;
        let placed = on.placed.clone();
        let solution = solve_coupled_with(
            &self.factors,
            on.gather.unwrap_or(&self.factors),
            self.patches.areas(),
            &opaque,
            &mut blocks,
            initial.map(|r| r.radiosity.as_slice()),
            &self.radiosity.solve,
            &keep_going,
        )?;
        drop(blocks);
        drop(operators);
        let fields = scatterers
            .iter()
            .map(|p| {
                p.as_ref()
                    .and_then(Scatterer::prepared)
                    .map(|p| Field { source: p.system().source().to_vec(), fluence: p.fluence().to_vec() })
            })
            .collect();
        Ok((Response { radiosity: solution.radiosity.clone(), fields }, solution, placed))
    }
}

/// The output of an object whose patches are its refined surface: Lo per patch `front` (and
/// `back`) and, at the user's vertices (the refinement keeps them first), their front values.
fn surface_output(
    target: &Target<'_>,
    surface: &PatchSurface,
    front: Vec<[f64; 3]>,
    back: Option<Vec<[f64; 3]>>,
    stats: &mut ObjectStats,
) -> Output {
    let radiance = target.world.user_to_internal().iter().map(|&v| front[v as usize]).collect();
    stats.boundary_vertices = surface.vertex_count();
    stats.vertices = surface.vertex_count();
    Output { radiance, patch_radiance: front, back_radiance: back }
}
