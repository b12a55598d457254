//! Translucent radiosity (Sheng et al. 2014) as a method: the whole scene baked at once, since
//! it is the one method in which objects exchange light (design/radiosity.md).
//!
//! 1. every translucent object is prepared as TransCut prepares it (tets, media, the matrix M),
//!    and its patches are its tet mesh's boundary vertices, so its scattering S is its own
//!    diffusion solve ([`scattering::DiffusionScattering`]: q → φ → B = (φ − 2q)/(2A));
//! 2. every opaque diffuse object's surface is refined to the patch size, keeping its vertices;
//! 3. the form factors between all patches, with visibility ([`crate::radiosity::FormFactors`]);
//! 4. the direct light: q_d transmitted into translucent patches exactly as TransCut computes
//!    it, the irradiance E_d on opaque ones, both shadowed by every object;
//! 5. B = S(q_d + tFB) on translucent patches, B = ρ(E_d + FB) + M on opaque ones
//!    ([`crate::radiosity::solve_coupled`]);
//! 6. the radiance: a translucent object's is TransCut's eq. 3 from its last solve (the one
//!    whose exitance is in B), so with one bounce it is its TransCut bake; an opaque object's
//!    is Lo = B/π at its vertices (design §1.2).

mod scattering;
mod surfaces;

use std::sync::Mutex;
use std::time::Instant;

use glam::DVec3;

use super::transcut::{Prepared, TransCut};
use super::{
    check_radiance, targets, world_surfaces, BakedState, Lighting, ObjectBake, ObjectStats, SubsurfaceMethod, Target,
    TransCutState,
};
use crate::light;
use crate::optics::fresnel::f_ext;
use crate::progress::{ms, Progress};
use crate::radiosity::{solve_coupled, FormFactors, Opaque, PatchSet, Translucent};
use crate::scene::{BakeOptions, Diffuse, RadiosityOptions, Scene, SceneError};

use scattering::DiffusionScattering;
use surfaces::{patch_surface, PatchSurface};

/// The method's name.
const NAME: &str = "radiosity";

/// What the radiosity method measured of the whole scene ([`crate::Bake::radiosity`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RadiosityStats {
    /// Patches in all (a two-sided surface has two per vertex).
    pub patches: usize,
    /// Of them, on translucent objects.
    pub translucent_patches: usize,
    /// Patches whose rays mostly hit the back of one-sided surfaces (inside geometry): they
    /// exchange nothing and take their radiance from their neighbours.
    pub covered_patches: usize,
    /// Nonzero form factors.
    pub nonzeros: usize,
    /// Memory of the form factors (8 B value + 4 B column per nonzero).
    pub form_factor_bytes: usize,
    /// The patch size used on opaque objects, in mm.
    pub patch_size_mm: f64,
    /// Preparing the translucent objects (tets, assembly).
    pub prepare_ms: f64,
    /// Building the patches (refinement, dual cells, the BVH).
    pub patches_ms: f64,
    /// Casting and symmetrising the form factors.
    pub form_factor_ms: f64,
    /// The direct light on every patch.
    pub direct_ms: f64,
    /// The coupled solve (its scatterings included).
    pub solve_ms: f64,
    /// Sweeps of the iteration.
    pub iterations: usize,
    /// Diffusion solves per translucent object.
    pub scatterings: usize,
    /// The a-posteriori estimate of the relative error in power.
    pub estimated_error: f64,
    /// |in − out|/in of the energy balance, worst channel.
    pub energy_defect: f64,
}

/// What the radiosity method keeps of one object ([`BakedState::Radiosity`]).
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct RadiosityObject {
    /// The translucent object's TransCut state (tet mesh, media, fluence of its last solve);
    /// `None` for an opaque one.
    pub transcut: Option<TransCutState>,
    /// The opaque surface; `None` for a translucent object.
    pub diffuse: Option<Diffuse>,
    /// The surface the patches are on, world space: the refined mesh of an opaque object, the
    /// tet mesh's boundary of a translucent one (so that a renderer can draw a two-triangle wall
    /// with its colour bleeding).
    pub patch_positions: Vec<DVec3>,
    pub patch_triangles: Vec<[u32; 3]>,
    /// Lo(x, n) at each vertex of the patch surface, its front side.
    pub patch_radiance: Vec<[f64; 3]>,
    /// Lo at each vertex of the patch surface, its back side, for a two-sided opaque surface.
    pub back_radiance: Option<Vec<[f64; 3]>>,
    /// The refractive index at the surface (1 for an opaque surface, which renders Lambertian).
    pub eta: f64,
}

/// Bakes `scene` by translucent radiosity (module documentation): every object's bake, and
/// the scene's statistics.
///
/// # Errors
/// [`SceneError`] naming the object at fault; [`SceneError::InvalidOptions`] when the objects
/// have different `mm_per_unit` or the radiosity stage refuses its input.
pub(crate) fn bake_scene(
    scene: &Scene,
    options: &BakeOptions,
    radiosity: &RadiosityOptions,
    progress: Progress,
) -> Result<(Vec<ObjectBake>, RadiosityStats), SceneError> {
    let world = world_surfaces(scene)?;
    let targets = targets(scene, &world);
    let mm_per_unit = common_scale(&targets)?;
    for target in &targets {
        if target.object.medium().is_some() {
            TransCut::check(target, &radiosity.transcut)?;
        }
    }

    // 1. The translucent objects, prepared as TransCut prepares them.
    let t = Instant::now();
    let count = targets.len();
    let furthest = Mutex::new(0.0f64);
    let mut stats: Vec<ObjectStats> = targets.iter().map(|t| object_stats(t)).collect();
    let mut prepared: Vec<Option<Prepared>> = Vec::with_capacity(count);
    for (target, stats) in targets.iter().zip(&mut stats) {
        prepared.push(match target.object.medium() {
            Some(_) => {
                let stage = |s: &str, f: f64| report(&progress, &furthest, &format!("{}: {s}", target.object.name), 0.3 * f);
                let t = Instant::now();
                let p = TransCut::prepare(target, &radiosity.transcut, stats, &stage)?;
                stats.total_ms += ms(t);
                Some(p)
            }
            None => None,
        });
    }
    let prepare_ms = ms(t);

    // 2. The patches.
    report(&progress, &furthest, "radiosity: patches", 0.3)?;
    let t = Instant::now();
    let patch_size_mm = radiosity.patch_size_mm.unwrap_or_else(|| scene_diagonal(&world) * mm_per_unit / 80.0);
    let surfaces: Vec<PatchSurface> = targets
        .iter()
        .zip(&prepared)
        .map(|(target, p)| patch_surface(target, p.as_ref(), patch_size_mm / mm_per_unit))
        .collect::<Result<_, _>>()?;
    let patches = PatchSet::new(&surfaces.iter().map(PatchSurface::as_surface).collect::<Vec<_>>())?;
    let patches_ms = ms(t);

    // 3. The form factors.
    let t = Instant::now();
    let counter = Mutex::new(0usize);
    let keep_going = || {
        let mut done = counter.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        *done += 1;
        let f = *done as f64 / patches.len() as f64;
        report(&progress, &furthest, "radiosity: form factors", 0.3 + 0.3 * f).is_ok()
    };
    let factors = FormFactors::gather(&patches, &radiosity.form_factors, &keep_going)?;
    let form_factor_ms = ms(t);

    // 4. The direct light.
    report(&progress, &furthest, "radiosity: light", 0.6)?;
    let t = Instant::now();
    let occluder = options.shadows.then(|| Lighting::occluder_of(&world));
    let lighting = Lighting { lights: &scene.lights, occluder: occluder.as_ref(), source: &options.source };
    let n = patches.len();
    let (mut albedo, mut emission) = (vec![[0.0; 3]; n], vec![[0.0; 3]; n]);
    let mut opaque_patches = Vec::new();
    let mut transmitted: Vec<Option<Vec<[f64; 3]>>> = Vec::with_capacity(count);
    for (s, (target, p)) in targets.iter().zip(&prepared).enumerate() {
        match (target.object.material.diffuse(), p) {
            (Some(d), _) => {
                for i in surface_patches(&patches, s, surfaces[s].vertex_count()) {
                    albedo[i] = d.albedo;
                    emission[i] = d.emission;
                    opaque_patches.push(i);
                }
                transmitted.push(None);
            }
            (None, Some(p)) => {
                let boundary = p.system().boundary();
                let points: Vec<DVec3> = boundary.ids.iter().map(|&v| p.tet_mesh().positions()[v as usize]).collect();
                transmitted.push(Some(lighting.transmitted_source(
                    &points,
                    &boundary.normal,
                    p.system().boundary_terms().eta,
                )?));
            }
            (None, None) => unreachable!("every translucent object was prepared"),
        }
    }
    let points: Vec<DVec3> = opaque_patches.iter().map(|&i| patches.positions()[i]).collect();
    let normals: Vec<DVec3> = opaque_patches.iter().map(|&i| patches.normals()[i]).collect();
    let irradiance = light::irradiance(lighting.lights, &points, &normals, lighting.occluder, lighting.source)?;
    let mut direct = vec![[0.0; 3]; n];
    for (&i, e) in opaque_patches.iter().zip(irradiance) {
        direct[i] = e;
    }
    let direct_ms = ms(t);

    // 5. The coupled solve.
    let t = Instant::now();
    let solve_stage = |f: f64| report(&progress, &furthest, "radiosity: solve", 0.65 + 0.33 * f);
    let mut operators: Vec<(usize, DiffusionScattering<'_>)> = Vec::new();
    for (s, ((target, p), stats)) in targets.iter().zip(prepared.iter_mut()).zip(stats.iter_mut()).enumerate() {
        if let Some(p) = p.as_mut() {
            operators.push((s, DiffusionScattering::new(p, target, &radiosity.transcut, stats, &solve_stage)));
        }
    }
    let mut blocks: Vec<Translucent<'_, SceneError>> = operators
        .iter_mut()
        .map(|(s, op)| Translucent {
            first: patches.patch_of(*s, 0, false).expect("every surface has front patches"),
            transmittance: 1.0 - f_ext(op.eta()),
            direct: transmitted[*s].as_deref().expect("a translucent object's q_d"),
            scattering: op,
        })
        .collect();
    let opaque = Opaque { albedo: &albedo, direct: &direct, emission: &emission };
    let sweeps = Mutex::new(0usize);
    let keep_going = || {
        let mut k = sweeps.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        *k += 1;
        solve_stage(1.0 - 0.5f64.powi(*k as i32)).is_ok()
    };
    let solution = solve_coupled(&factors, patches.areas(), &opaque, &mut blocks, &radiosity.solve, &keep_going)?;
    drop(blocks);
    drop(operators);
    let solve_ms = ms(t);

    // 6. The radiance of every object.
    let covered = factors.covered();
    let b = fill_covered(&patches, &surfaces, covered, &solution.radiosity);
    let mut objects = Vec::with_capacity(count);
    for (s, ((target, p), mut stats)) in targets.iter().zip(prepared).zip(stats).enumerate() {
        let surface = &surfaces[s];
        let side = |back: bool| -> Option<Vec<[f64; 3]>> {
            (0..surface.vertex_count()).map(|v| patches.patch_of(s, v, back).map(|i| b[i])).collect::<Option<Vec<_>>>()
        };
        let (radiance, state) = match p {
            Some(p) => {
                let radiance = p.user_radiance(target, &mut stats)?;
                let lo = p.boundary_radiance(target)?.into_iter().map(|l| l.map(|x| x.max(0.0))).collect();
                let state = RadiosityObject {
                    patch_positions: surface.positions.clone(),
                    patch_triangles: surface.triangles.clone(),
                    patch_radiance: lo,
                    back_radiance: None,
                    eta: p.system().boundary_terms().eta,
                    diffuse: None,
                    transcut: Some(p.into_state()),
                };
                (radiance, state)
            }
            None => {
                let d = *target.object.material.diffuse().expect("an opaque object");
                let to_radiance = |b: Vec<[f64; 3]>| -> Vec<[f64; 3]> {
                    b.into_iter().map(|x| x.map(|x| (x / std::f64::consts::PI).max(0.0))).collect()
                };
                let front = to_radiance(side(false).expect("front patches"));
                let back = side(true).map(to_radiance);
                let user = target.world.user_to_internal().iter().map(|&v| front[v as usize]).collect();
                let state = RadiosityObject {
                    patch_positions: surface.positions.clone(),
                    patch_triangles: surface.triangles.clone(),
                    patch_radiance: front,
                    back_radiance: back,
                    eta: 1.0,
                    diffuse: Some(d),
                    transcut: None,
                };
                stats.boundary_vertices = surface.vertex_count();
                stats.vertices = surface.vertex_count();
                (user, state)
            }
        };
        check_radiance(target, NAME, &radiance)?;
        objects.push(ObjectBake { radiance, stats, state: BakedState::Radiosity(Box::new(state)) });
    }
    report(&progress, &furthest, "radiosity: done", 1.0)?;
    let radiosity = RadiosityStats {
        patches: n,
        translucent_patches: targets
            .iter()
            .zip(&surfaces)
            .filter(|(t, _)| t.object.medium().is_some())
            .map(|(_, s)| s.vertex_count())
            .sum(),
        covered_patches: covered.iter().filter(|&&c| c).count(),
        nonzeros: factors.nonzeros(),
        form_factor_bytes: factors.nonzeros() * 12,
        patch_size_mm,
        prepare_ms,
        patches_ms,
        form_factor_ms,
        direct_ms,
        solve_ms,
        iterations: solution.iterations,
        scatterings: solution.scatterings,
        estimated_error: solution.estimated_error,
        energy_defect: solution.energy.defect(),
    };
    Ok((objects, radiosity))
}

/// The one `mm_per_unit` of every object: the patches share one space, so the objects must
/// share one scale.
fn common_scale(targets: &[Target<'_>]) -> Result<f64, SceneError> {
    let first = targets.first().ok_or(SceneError::NoObjects)?;
    let mm = first.object.mm_per_unit;
    match targets.iter().find(|t| t.object.mm_per_unit != mm) {
        Some(other) => Err(SceneError::InvalidOptions(format!(
            "{NAME}: every object must have the same mm_per_unit (the patches share one space), but object 0 ({}) has {} \
             and object {} ({}) has {}",
            first.object.name, mm, other.index, other.object.name, other.object.mm_per_unit
        ))),
        None => Ok(mm),
    }
}

/// Reports `stage` at `fraction` of the whole bake, never going back ([`super::object_stage`]).
fn report(progress: &Progress<'_>, furthest: &Mutex<f64>, stage: &str, fraction: f64) -> Result<(), crate::progress::Cancelled> {
    let mut furthest = furthest.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    *furthest = furthest.max(fraction.clamp(0.0, 1.0));
    progress.report(stage, *furthest)
}

/// Empty statistics of the object, with its surface's flipped faces.
fn object_stats(target: &Target<'_>) -> ObjectStats {
    let mut stats = ObjectStats::new(NAME);
    stats.flipped_faces = target.world.flipped_faces();
    stats
}

/// The bounding-box diagonal of all world surfaces (scene units).
fn scene_diagonal(world: &[crate::mesh::TriMesh]) -> f64 {
    let (lo, hi) = world
        .iter()
        .map(crate::mesh::TriMesh::bounds)
        .fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(lo, hi), (a, b)| (lo.min(a), hi.max(b)));
    (hi - lo).length()
}

/// Every patch of surface `s` (`vertices` vertices): its front patches, then its back ones.
fn surface_patches(patches: &PatchSet, s: usize, vertices: usize) -> impl Iterator<Item = usize> + '_ {
    [false, true].into_iter().flat_map(move |back| (0..vertices).filter_map(move |v| patches.patch_of(s, v, back)))
}

/// The radiosity with each covered patch (inside geometry: its rays mostly hit the back of
/// one-sided surfaces, so it exchanged nothing) replaced by the mean of its uncovered
/// neighbours on the same side of the same surface, spreading inwards until every covered
/// patch with an uncovered patch in its connected piece is filled (Enlighten's ray-origin
/// rejection; design/radiosity.md §1.4).
fn fill_covered(patches: &PatchSet, surfaces: &[PatchSurface], covered: &[bool], b: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let mut out = b.to_vec();
    if !covered.iter().any(|&c| c) {
        return out;
    }
    let mut known: Vec<bool> = covered.iter().map(|&c| !c).collect();
    for (s, surface) in surfaces.iter().enumerate() {
        let mut neighbours = vec![Vec::new(); surface.vertex_count()];
        for t in &surface.triangles {
            for k in 0..3 {
                let (a, c) = (t[k] as usize, t[(k + 1) % 3] as usize);
                neighbours[a].push(c);
                neighbours[c].push(a);
            }
        }
        for back in [false, true] {
            let patch = |v: usize| patches.patch_of(s, v, back);
            loop {
                let fills: Vec<(usize, [f64; 3])> = (0..surface.vertex_count())
                    .filter_map(|v| {
                        let i = patch(v).filter(|&i| !known[i])?;
                        let around: Vec<usize> = neighbours[v].iter().filter_map(|&u| patch(u)).filter(|&j| known[j]).collect();
                        (!around.is_empty()).then(|| {
                            let sum = around.iter().fold([0.0; 3], |acc, &j| std::array::from_fn(|c| acc[c] + out[j][c]));
                            (i, sum.map(|x| x / around.len() as f64))
                        })
                    })
                    .collect();
                if fills.is_empty() {
                    break;
                }
                for (i, value) in fills {
                    out[i] = value;
                    known[i] = true;
                }
            }
        }
    }
    out
}
