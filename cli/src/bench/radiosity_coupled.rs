//! The coupled half of `transcut bench radiosity`: translucent radiosity on a scene file
//! (default `examples/cornell_marble.toml`, a marble block in a Cornell box) through the whole
//! bake and its [`RadiositySession`], at each patch size: the bake's stages (the translucent
//! objects' preparation, which is S through the diffusion solve; the patches; F; the direct
//! light; the solve), the memory, Jacobi against Gauss–Seidel from nothing on the same F, and
//! the interactive updates: a relight after the light moved by 5° about the centre, a change of the light's colour
//! (a weighted sum of the kept response), a change of translucency and of an albedo; and beside
//! them the same scene with the half-space profile matrix as S (no tets): its build (time,
//! memory, nonzeros), its solve from nothing, the relight after 5° and the translucency change
//! (S re-indexed from its samples).

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use anyhow::{anyhow, Context};
use glam::DMat3;
use serde::Serialize;
use transcut::light::Light;
use transcut::radiosity::{Iteration, SolveOptions};
use transcut::{
    bake, BakeOptions, DVec3, MediumSource, Method, ProfileKind, Progress, RadiosityOptions, RadiositySession, RadiosityUpdate,
    Scene, TranslucentScattering,
};

use super::stats::{median, ms, peak_rss_mib, reset_peak_rss, rss_mib};
use crate::method_args::MethodArgs;
use crate::scene_file;

/// One patch size's measurements (times: medians of the runs, ms).
#[derive(Serialize)]
pub struct Entry {
    patch_size_mm: f64,
    patches: usize,
    translucent_patches: usize,
    tets: usize,
    nonzeros: usize,
    form_factor_mib: f64,
    /// Resident memory when this configuration started, and its peak while it ran (`None`
    /// where the peak cannot be started again, so it would be an earlier configuration's).
    start_rss_mib: Option<f64>,
    peak_rss_mib: Option<f64>,
    median_bake_ms: f64,
    median_prepare_ms: f64,
    median_form_factor_ms: f64,
    median_direct_ms: f64,
    /// The bake's own solve (its iteration and tolerance, from nothing).
    median_solve_ms: f64,
    solve_sweeps: usize,
    median_jacobi_ms: f64,
    jacobi_sweeps: usize,
    median_gauss_seidel_ms: f64,
    gauss_seidel_sweeps: usize,
    jacobi_to_gauss_seidel: f64,
    energy_defect: f64,
    /// The light moved by turning it 5° about the box's centre ([`turned`]): a warm-started solve.
    median_relight_ms: f64,
    relight_fps: f64,
    relight_sweeps: usize,
    /// The relight's direct light (shadow rays to every patch) and its coupled solve.
    median_relight_direct_ms: f64,
    median_relight_solve_ms: f64,
    /// The same light in another colour: the kept response scaled, no solve.
    median_recolour_ms: f64,
    /// The translucent object's σ′s scaled by 1.25: assembly and a warm-started solve.
    median_medium_ms: f64,
    medium_fps: f64,
    /// The first diffuse object's albedo scaled by 0.9.
    median_albedo_ms: f64,
    /// The same patch size with the half-space profile matrix as S.
    profile: ProfileEntry,
}

/// One patch size's measurements with the profile S (half-space, chord distances; medians, ms).
#[derive(Serialize)]
pub struct ProfileEntry {
    patches: usize,
    translucent_patches: usize,
    /// Nonzero entries of the translucent objects' profile matrices.
    nonzeros: usize,
    /// The matrices and their re-indexing samples.
    matrix_mib: f64,
    /// As [`Entry`]'s, for this configuration.
    start_rss_mib: Option<f64>,
    peak_rss_mib: Option<f64>,
    median_bake_ms: f64,
    /// Building S (distances, samples, values).
    median_build_ms: f64,
    median_form_factor_ms: f64,
    /// The bake's solve, from nothing.
    median_solve_ms: f64,
    solve_sweeps: usize,
    /// The light moved 5° ([`turned`]): a warm-started solve.
    median_relight_ms: f64,
    relight_fps: f64,
    relight_sweeps: usize,
    /// The relight's direct light and its coupled solve.
    median_relight_direct_ms: f64,
    median_relight_solve_ms: f64,
    /// σ′s scaled by 1.25: S re-indexed (or rebuilt) and a warm-started solve.
    median_medium_ms: f64,
    energy_defect: f64,
}

/// The scene file's scene and bake options, the translucent objects at `tets` when given.
fn load(path: &Path, tets: Option<u64>) -> anyhow::Result<(Scene, BakeOptions)> {
    let loaded = scene_file::load(path)?;
    let defaults = loaded.file.bake.method_defaults()?;
    let Method::Radiosity(mut radiosity) = MethodArgs::default().method(&defaults)? else {
        return Err(anyhow!("its [bake] method is not radiosity"));
    };
    if let Some(tets) = tets {
        radiosity.transcut.tets = usize::try_from(tets)?;
    }
    let scene = Scene { objects: loaded.objects, lights: loaded.lights };
    Ok((scene, BakeOptions::with_method(Method::Radiosity(radiosity))))
}

/// `light` moved by turning its position `degrees` about the axis through `centre` along +z:
/// an area light keeps its orientation (it slides, as a light dragged in a viewport does; tilted
/// with the turn, the example's light under the ceiling would pass through the ceiling), a
/// directional light turns.
fn turned(light: &Light, centre: DVec3, degrees: f64) -> Light {
    let r = DMat3::from_rotation_z(degrees.to_radians());
    let mut out = light.clone();
    match &mut out {
        Light::Point { position, .. } | Light::Spot { position, .. } => *position = centre + r * (*position - centre),
        Light::RectArea { center, .. } | Light::DiscArea { center, .. } => *center = centre + r * (*center - centre),
        Light::Directional { direction, .. } => *direction = r * *direction,
        _ => {}
    }
    out
}

/// The coupled measurements at every patch size of `sizes`, `runs` runs each.
pub fn run(path: &Path, sizes: &[f64], tets: Option<u64>, runs: u32) -> anyhow::Result<Vec<Entry>> {
    let (scene, base) = load(path, tets).with_context(|| format!("the radiosity suite's scene {}", path.display()))?;
    let translucent = scene.objects.iter().position(|o| o.medium().is_some());
    let diffuse = scene.objects.iter().position(|o| o.material.diffuse().is_some());
    let first_light = scene.lights.first().cloned().ok_or_else(|| anyhow!("the scene has no light to turn"))?;
    let (lo, hi) =
        scene.objects.iter().try_fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), o| {
            o.world_surface().map(|m| {
                let (a, b) = m.bounds();
                (lo.min(a), hi.max(b))
            })
        })?;
    let centre = 0.5 * (lo + hi);
    // The light turned 5°, alternately either way, so the runs stay near the bake's.
    let turn = |run: u32| {
        let mut lights = scene.lights.clone();
        lights[0] = turned(&first_light, centre, if run.is_multiple_of(2) { 5.0 } else { -5.0 });
        lights
    };
    let mut entries = Vec::new();
    for &size in sizes {
        let Method::Radiosity(mut radiosity) = base.method.clone() else { unreachable!("a radiosity scene") };
        radiosity.patch_size_mm = Some(size);
        let options = BakeOptions { method: Method::Radiosity(radiosity.clone()), ..base.clone() };
        let (start_rss_mib, reset) = (rss_mib(), reset_peak_rss());
        let mut t = Timings::default();
        let mut last = None;
        for run in 0..runs {
            let start = Instant::now();
            let baked = bake(&scene, &options)?;
            t.bake.push(ms(start));
            let stats = baked.radiosity.clone().expect("a radiosity bake");
            t.prepare.push(stats.prepare_ms);
            t.form_factor.push(stats.form_factor_ms);
            t.direct.push(stats.direct_ms);
            t.solve.push(stats.solve_ms);
            let tets = translucent.map_or(0, |i| baked.objects[i].stats.tets);
            let coupled = baked.coupled.expect("a radiosity bake keeps its session");
            drop(baked.objects);
            let mut session = Arc::try_unwrap(coupled).map_err(|_| anyhow!("the bake's session is shared"))?;
            let sweeps = |session: &mut RadiositySession, iteration: Iteration| -> anyhow::Result<(f64, usize, f64)> {
                let solve = SolveOptions { iteration, ..radiosity.solve };
                let start = Instant::now();
                let u = session.set_solve_options(solve, Progress::none())?;
                Ok((ms(start), u.iterations, u.energy_defect))
            };
            let (jacobi_ms, jacobi_sweeps, defect) = sweeps(&mut session, Iteration::Jacobi)?;
            let (gs_ms, gs_sweeps, _) = sweeps(&mut session, Iteration::GaussSeidel)?;
            session.set_solve_options(radiosity.solve, Progress::none())?;
            t.jacobi.push(jacobi_ms);
            t.gauss_seidel.push(gs_ms);

            let mut lights = turn(run);
            let relit = t.relight(&mut session, &lights)?;
            let (Light::RectArea { radiance, .. } | Light::DiscArea { radiance, .. }) = &mut lights[0] else {
                return Err(anyhow!("the radiosity suite recolours a rect or disc light"));
            };
            *radiance = [radiance[0] * 1.2, radiance[1], radiance[2] * 0.8];
            let start = Instant::now();
            let recoloured = session.relight(&lights, Progress::none())?;
            t.recolour.push(ms(start));
            if recoloured.solves != 0 {
                return Err(anyhow!("a recoloured light solved {} times instead of reusing its response", recoloured.solves));
            }
            if let Some(i) = translucent {
                t.thicken(&mut session, i)?;
            }
            if let Some(i) = diffuse {
                let albedo = session.objects()[i].material.diffuse().expect("diffuse").albedo.map(|a| 0.9 * a);
                let start = Instant::now();
                session.set_albedo(i, albedo, Progress::none())?;
                t.albedo.push(ms(start));
            }
            last = Some((stats, tets, jacobi_sweeps, gs_sweeps, defect, relit.iterations));
        }
        let (stats, tets, jacobi_sweeps, gauss_seidel_sweeps, energy_defect, relight_sweeps) = last.expect("runs ≥ 1");
        let peak = peak_rss_mib().filter(|_| reset);
        let profile = profile_entry(&scene, &options, runs, translucent, &turn)?;
        let (jacobi, gs, relight, medium) = (median(t.jacobi), median(t.gauss_seidel), median(t.relight), median(t.medium));
        entries.push(Entry {
            patch_size_mm: size,
            patches: stats.patches,
            translucent_patches: stats.translucent_patches,
            tets,
            nonzeros: stats.nonzeros,
            form_factor_mib: stats.form_factor_bytes as f64 / (1024.0 * 1024.0),
            start_rss_mib,
            peak_rss_mib: peak,
            median_bake_ms: median(t.bake),
            median_prepare_ms: median(t.prepare),
            median_form_factor_ms: median(t.form_factor),
            median_direct_ms: median(t.direct),
            median_solve_ms: median(t.solve),
            solve_sweeps: stats.iterations,
            median_jacobi_ms: jacobi,
            jacobi_sweeps,
            median_gauss_seidel_ms: gs,
            gauss_seidel_sweeps,
            jacobi_to_gauss_seidel: jacobi / gs,
            energy_defect,
            median_relight_ms: relight,
            relight_fps: 1e3 / relight,
            relight_sweeps,
            median_relight_direct_ms: median(t.relight_direct),
            median_relight_solve_ms: median(t.relight_solve),
            median_recolour_ms: median(t.recolour),
            median_medium_ms: medium,
            medium_fps: 1e3 / medium,
            median_albedo_ms: median(t.albedo),
            profile,
        });
    }
    Ok(entries)
}

/// The measurements of `options` with the half-space profile matrix as S, `runs` runs, the
/// lights of run k `turn(k)`.
fn profile_entry(
    scene: &Scene,
    options: &BakeOptions,
    runs: u32,
    translucent: Option<usize>,
    turn: &dyn Fn(u32) -> Vec<Light>,
) -> anyhow::Result<ProfileEntry> {
    let Method::Radiosity(radiosity) = &options.method else { unreachable!("a radiosity scene") };
    let radiosity = RadiosityOptions { scattering: TranslucentScattering::profile(ProfileKind::HalfSpace), ..radiosity.clone() };
    let options = BakeOptions { method: Method::Radiosity(radiosity), ..options.clone() };
    let (start_rss_mib, reset) = (rss_mib(), reset_peak_rss());
    let mut t = Timings::default();
    let (mut build, mut last) = (Vec::new(), None);
    for run in 0..runs {
        let start = Instant::now();
        let baked = bake(scene, &options).context("the profile S")?;
        t.bake.push(ms(start));
        let stats = baked.radiosity.clone().expect("a radiosity bake");
        build.push(stats.scattering_ms);
        t.form_factor.push(stats.form_factor_ms);
        t.solve.push(stats.solve_ms);
        let coupled = baked.coupled.expect("a radiosity bake keeps its session");
        drop(baked.objects);
        let mut session = Arc::try_unwrap(coupled).map_err(|_| anyhow!("the bake's session is shared"))?;
        let relit = t.relight(&mut session, &turn(run))?;
        if let Some(i) = translucent {
            t.thicken(&mut session, i)?;
        }
        last = Some((stats, relit.iterations));
    }
    let (stats, relight_sweeps) = last.expect("runs ≥ 1");
    Ok(ProfileEntry {
        patches: stats.patches,
        translucent_patches: stats.translucent_patches,
        nonzeros: stats.scattering_nonzeros,
        matrix_mib: stats.scattering_bytes as f64 / (1024.0 * 1024.0),
        start_rss_mib,
        peak_rss_mib: peak_rss_mib().filter(|_| reset),
        median_bake_ms: median(t.bake),
        median_build_ms: median(build),
        median_form_factor_ms: median(t.form_factor),
        median_solve_ms: median(t.solve),
        solve_sweeps: stats.iterations,
        median_relight_ms: median(t.relight.clone()),
        relight_fps: 1e3 / median(t.relight),
        relight_sweeps,
        median_relight_direct_ms: median(t.relight_direct),
        median_relight_solve_ms: median(t.relight_solve),
        median_medium_ms: median(t.medium),
        energy_defect: stats.energy_defect,
    })
}

/// Every run's times of one patch size.
#[derive(Default)]
struct Timings {
    bake: Vec<f64>,
    prepare: Vec<f64>,
    form_factor: Vec<f64>,
    direct: Vec<f64>,
    solve: Vec<f64>,
    jacobi: Vec<f64>,
    gauss_seidel: Vec<f64>,
    relight: Vec<f64>,
    relight_direct: Vec<f64>,
    relight_solve: Vec<f64>,
    recolour: Vec<f64>,
    medium: Vec<f64>,
    albedo: Vec<f64>,
}

impl Timings {
    /// Relights `session` with `lights`, recording the time and its direct light and solve.
    fn relight(&mut self, session: &mut RadiositySession, lights: &[Light]) -> anyhow::Result<RadiosityUpdate> {
        let start = Instant::now();
        let relit = session.relight(lights, Progress::none())?;
        self.relight.push(ms(start));
        self.relight_direct.push(relit.direct_ms);
        self.relight_solve.push(relit.solve_ms);
        Ok(relit)
    }

    /// Scales translucent object `i`'s σ′s by 1.25, recording the time.
    fn thicken(&mut self, session: &mut RadiositySession, i: usize) -> anyhow::Result<()> {
        let Some(MediumSource::Homogeneous(m)) = session.objects()[i].medium().cloned() else {
            return Err(anyhow!("the radiosity suite thickens a homogeneous medium"));
        };
        let thicker = transcut::optics::Medium { sigma_s_prime: m.sigma_s_prime.map(|s| 1.25 * s), ..m };
        let start = Instant::now();
        session.set_medium(i, MediumSource::Homogeneous(thicker), Progress::none())?;
        self.medium.push(ms(start));
        Ok(())
    }
}
