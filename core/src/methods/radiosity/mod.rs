//! Translucent radiosity (Sheng et al. 2014) as a method: the whole scene baked at once, since
//! it is the one method in which objects exchange light (design/radiosity.md).
//!
//! 1. every translucent object is prepared as TransCut prepares it (tets, media, the matrix M),
//!    and its patches are its tet mesh's boundary vertices, so its scattering S is its own
//!    diffusion solve ([`scattering::DiffusionScattering`]: q → φ → B = (φ − 2q)/(2A)); or, with
//!    [`crate::TranslucentScattering::Profile`], its surface is refined to the patch size as an
//!    opaque one's and S is a profile matrix on it ([`profile_object`], eq. 8: no tets);
//! 2. every opaque diffuse object's surface is refined to the patch size, keeping its vertices;
//! 3. the form factors between all patches, with visibility ([`crate::radiosity::FormFactors`]);
//! 4. the direct light: q_d transmitted into translucent patches exactly as TransCut computes
//!    it, the irradiance E_d on opaque ones, both shadowed by every object;
//! 5. B = S(q_d + tFB) on translucent patches, B = ρ(E_d + FB) + M on opaque ones
//!    ([`crate::radiosity::solve_coupled`]);
//! 6. the radiance: a translucent object's is TransCut's eq. 3 from its last solve (the one
//!    whose exitance is in B), so with one bounce it is its TransCut bake; a profile object's
//!    is Lo = T(η, 0)/(π η² (1 − Fdr))·B, an opaque object's Lo = B/π, at their vertices
//!    (design §1.2).

mod profile_media;
mod profile_object;
mod responses;
mod scatterer;
mod scattering;
mod session;
mod surfaces;

pub use session::{RadiositySession, RadiosityUpdate};

use std::sync::Mutex;

use glam::DVec3;

use super::{ObjectBake, ObjectStats, Target, TransCutState};
use crate::progress::Progress;
use crate::radiosity::PatchSet;
use crate::scene::{BakeOptions, Diffuse, RadiosityOptions, Scene, SceneError};

use surfaces::PatchSurface;

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
    /// Memory of the form factors (a 4 B f32 exchange and a 4 B column per nonzero).
    pub form_factor_bytes: usize,
    /// The patch size used on opaque objects, in mm.
    pub patch_size_mm: f64,
    /// Preparing the translucent objects (tets, assembly).
    pub prepare_ms: f64,
    /// Building the patches (refinement, dual cells, the BVH).
    pub patches_ms: f64,
    /// Building the profile matrices (distances, samples, values); 0 with the diffusion S.
    pub scattering_ms: f64,
    /// Nonzero entries of the profile matrices (0 with the diffusion S).
    pub scattering_nonzeros: usize,
    /// Memory of the profile matrices and their re-indexing samples.
    pub scattering_bytes: usize,
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
    /// The GPU that computed the last solve's gathers F B ([`crate::RadiosityOptions::backend`]);
    /// `None`: the CPU.
    pub device: Option<String>,
    /// Why the last solve's gathers ran on the CPU although the backend was `gpu` or `auto`
    /// (no hardware GPU, only a software adapter, F too large for the device, Gauss–Seidel);
    /// `None` when they ran where asked.
    pub device_fallback: Option<String>,
}

/// What the radiosity method keeps of one object ([`BakedState::Radiosity`]).
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct RadiosityObject {
    /// The translucent object's TransCut state (tet mesh, media, fluence of its last solve);
    /// `None` for an opaque one and for one scattered by a profile matrix (it has no tets).
    pub transcut: Option<TransCutState>,
    /// The opaque surface; `None` for a translucent object.
    pub diffuse: Option<Diffuse>,
    /// The surface the patches are on, world space: the refined mesh of an opaque object, the
    /// tet mesh's boundary of a translucent one (its refined surface with a profile S), so that a
    /// renderer can draw a two-triangle wall with its colour bleeding.
    pub patch_positions: Vec<DVec3>,
    pub patch_triangles: Vec<[u32; 3]>,
    /// Lo(x, n) at each vertex of the patch surface, its front side.
    pub patch_radiance: Vec<[f64; 3]>,
    /// Lo at each vertex of the patch surface, its back side, for a two-sided opaque surface.
    pub back_radiance: Option<Vec<[f64; 3]>>,
    /// The refractive index at the surface (1 for an opaque surface, which renders Lambertian).
    pub eta: f64,
}

/// Bakes `scene` by translucent radiosity (module documentation): every object's bake, the
/// scene's statistics and the session later updates start from.
///
/// # Errors
/// [`SceneError`] naming the object at fault; [`SceneError::InvalidOptions`] when the objects
/// have different `mm_per_unit` or the radiosity stage refuses its input.
pub(crate) fn bake_scene(
    scene: &Scene,
    options: &BakeOptions,
    radiosity: &RadiosityOptions,
    progress: Progress,
) -> Result<(Vec<ObjectBake>, RadiosityStats, RadiositySession), SceneError> {
    let session = RadiositySession::bake(scene, options, radiosity, progress)?;
    Ok((session.object_bakes()?, session.stats().clone(), session))
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
