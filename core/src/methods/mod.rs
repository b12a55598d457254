//! The subsurface methods, siblings behind one contract: a scene object in, the radiance
//! Lo(x, n) at its vertices out (ARCHITECTURE.md, "What a bake returns").
//!
//! A method implements the crate-private [`SubsurfaceMethod`] trait in three steps, so the
//! light-independent work is done once and kept ([`ObjectBake::state`]):
//!
//! 1. `check`: can the method bake this object with these options? If not, an error that names
//!    the method and the reason ([`crate::scene::SceneError::Unsupported`]), before any work;
//! 2. `prepare`: the light-independent part (TransCut: the tet mesh, its media and the matrix
//!    M of eqs. 10–14);
//! 3. `solve`: the radiance under a [`Lighting`] (TransCut: the source q, the solve of
//!    M φ = b, eq. 3 at the user's vertices).
//!
//! What only some methods can do after a bake is a capability trait of their state
//! ([`capability`]): [`capability::Relight`], [`capability::EditMedium`], [`capability::Cut`],
//! [`capability::Deform`]. [`crate::session::Session`] offers them for every method and answers
//! with [`crate::session::SessionError::Unsupported`], naming the method, where one lacks it.
//!
//! The driver above ([`crate::bake()`]) validates, builds the shared [`Lighting`], runs the
//! steps per object with progress, and collects the statistics.
//!
//! # How a method joins
//!
//! 1. a variant of [`crate::scene::Method`] with its options struct, a name in
//!    [`crate::scene::Method::NAMES`];
//! 2. a folder `methods/<name>/` whose `mod.rs` implements [`SubsurfaceMethod`] (and the
//!    capability traits it offers), and a variant of [`BakedState`] for its state;
//! 3. one arm in the driver's dispatch (`bake.rs`) and in the session's ([`crate::session`]);
//! 4. one line in the conformance suite `core/tests/integration/methods.rs`.

pub mod capability;
pub mod hierarchical_dipole;
mod lighting;
pub mod polygrid;
pub mod prt;
pub mod radiosity;
mod result;
pub mod transcut;

pub use hierarchical_dipole::{DipoleState, HierarchicalDipole};
pub use lighting::Lighting;
pub use polygrid::{PolygridMethod, PolygridStats};
pub use prt::{Prt, PrtLive, PrtState};
pub use radiosity::{RadiosityObject, RadiositySession, RadiosityStats, RadiosityUpdate};
pub use result::{interpolate_vertices, BakedState, ObjectBake, ObjectStats};
pub(crate) use transcut::Reuse;
pub use transcut::{Meshed, TransCut, TransCutState};

use std::sync::{Arc, Mutex};
use std::time::Instant;

use crate::mesh::TriMesh;
use crate::optics::Medium;
use crate::progress::{ms, Cancelled, Progress};
use crate::scene::{MediumSource, Object, Scene, SceneError, Shape};

/// The object a method bakes: its place in the scene (for error messages) and its surface in
/// world space.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Target<'a> {
    /// The object's index in the scene.
    pub index: usize,
    pub object: &'a Object,
    /// The object's surface in world space ([`Object::world_surface`]).
    pub world: &'a TriMesh,
    /// Whether a tet mesh made before may be taken instead of meshing, and whether to keep the
    /// mesh used (TransCut; the other methods mesh nothing).
    pub reuse: Reuse<'a>,
}

impl<'a> Target<'a> {
    /// The object's translucent medium, or [`SceneError::Unsupported`] naming `method` for an
    /// opaque diffuse object: a method that bakes each object alone would return it lit by the
    /// lights only, without the light it exchanges with the rest of the scene, so it refuses
    /// instead of returning that wrong picture (only radiosity couples objects).
    pub(crate) fn medium(&self, method: &'static str) -> Result<&'a MediumSource, SceneError> {
        self.object.medium().ok_or_else(|| SceneError::Unsupported {
            index: self.index,
            name: self.object.name.clone(),
            method,
            reason: "it is an opaque diffuse surface, and only the radiosity method bakes those (it couples them with the \
                     translucent objects); choose method \"radiosity\", or leave the object out"
                .into(),
        })
    }

    /// [`SceneError::InvalidObject`] for this object.
    pub(crate) fn invalid(&self, message: impl Into<String>) -> SceneError {
        SceneError::InvalidObject { index: self.index, name: self.object.name.clone(), message: message.into() }
    }
}

/// Every object's surface in world space ([`Object::world_surface`]), each checked against the
/// size bounds ([`Object::check_size`]): the methods bake them, and together they shadow.
///
/// # Errors
/// [`SceneError::InvalidObject`] naming the object.
pub(crate) fn world_surfaces(scene: &Scene) -> Result<Vec<TriMesh>, SceneError> {
    scene
        .objects
        .iter()
        .enumerate()
        .map(|(index, o)| {
            let invalid = |message| SceneError::InvalidObject { index, name: o.name.clone(), message };
            let world = o.world_surface().map_err(|e| invalid(e.to_string()))?;
            o.check_size(&world).map_err(invalid)?;
            Ok(world)
        })
        .collect()
}

/// The scene's objects as targets, with their world surfaces; `kept`: `None` for a bake that
/// keeps no meshes, else the meshes an earlier bake kept, by object index (taken where they
/// were made from the object's surface).
pub(crate) fn targets<'a>(scene: &'a Scene, world: &'a [TriMesh], kept: Option<&'a [Option<Arc<Meshed>>]>) -> Vec<Target<'a>> {
    scene
        .objects
        .iter()
        .zip(world)
        .enumerate()
        .map(|(index, (object, world))| {
            let reuse = kept.map_or(Reuse::Nothing, |k| Reuse::Keep(k.get(index).and_then(Option::as_ref)));
            Target { index, object, world, reuse }
        })
        .collect()
}

/// The object's medium when it is one medium everywhere (a surface's table has every tet at
/// id 0); why not otherwise.
pub(crate) fn homogeneous_medium(object: &Object) -> Result<Medium, String> {
    let Some(medium) = object.medium() else {
        return Err("it is an opaque diffuse surface, not a translucent medium".into());
    };
    match (medium, &object.shape) {
        (MediumSource::Homogeneous(m), _) => Ok(*m),
        (MediumSource::Table(t), Shape::Surface(_)) if !t.is_empty() => Ok(t[0]),
        (MediumSource::Table(t), Shape::Tetrahedra(mesh)) if !t.is_empty() => {
            let ids: std::collections::BTreeSet<u32> = mesh.materials().iter().copied().collect();
            match ids.iter().map(|&i| t.get(i as usize)).collect::<Option<Vec<_>>>() {
                Some(media) if media.windows(2).all(|w| w[0] == w[1]) => Ok(*media[0]),
                Some(_) => Err("its tets hold different media; the dipole needs one homogeneous medium".into()),
                None => Err("a tet's material id is beyond the media table".into()),
            }
        }
        (MediumSource::Table(_), _) => Err("the media table is empty".into()),
        _ => Err("its medium is heterogeneous (voxels, layers, veins or per-tet media); the dipole is the solution for one \
                  homogeneous medium (use transcut)"
            .into()),
    }
}

/// Per output vertex, the surface vertex it takes its radiance from: through the user's vertex
/// map for a surface; at the boundary vertices of a tet mesh (`None` inside).
pub(crate) fn output_map(object: &Object, surface: &TriMesh) -> Vec<Option<u32>> {
    let on_surface = |v: usize| Some(surface.user_to_internal()[v]);
    match &object.shape {
        Shape::Surface(_) => (0..surface.user_vertex_count()).map(on_surface).collect(),
        Shape::Tetrahedra(mesh) => {
            let mut boundary = vec![false; mesh.vertex_count()];
            for f in mesh.boundary_faces() {
                for v in f.vertices {
                    boundary[v as usize] = true;
                }
            }
            (0..mesh.vertex_count()).map(|v| if boundary[v] { on_surface(v) } else { None }).collect()
        }
    }
}

/// Reports a stage of one object's bake: a stage name and the fraction of the object done, in
/// [0, 1]; `Err(Cancelled)` when the caller asked to stop.
pub(crate) type Stage<'a> = &'a (dyn Fn(&str, f64) -> Result<(), Cancelled> + Sync);

/// The contract of every subsurface method (see the module documentation).
pub(crate) trait SubsurfaceMethod {
    /// The method's options ([`crate::scene::Method`]'s variant).
    type Options;
    /// What `prepare` computes and `solve` keeps: everything later solves and edits start from.
    type State: Send;

    /// Whether the method can bake `target` with `options`.
    ///
    /// # Errors
    /// [`SceneError::Unsupported`] naming the method and the reason, or
    /// [`SceneError::InvalidObject`] for an object the method finds invalid.
    fn check(target: &Target<'_>, options: &Self::Options) -> Result<(), SceneError>;

    /// The light-independent part of the bake, filling its statistics into `stats`.
    ///
    /// # Errors
    /// [`SceneError`] naming the object; [`SceneError::Cancelled`] through `stage`.
    fn prepare(
        target: &Target<'_>,
        options: &Self::Options,
        stats: &mut ObjectStats,
        stage: Stage<'_>,
    ) -> Result<Self::State, SceneError>;

    /// The radiance Lo(x, n) under `lighting` at every vertex the object returns radiance for
    /// ([`crate::scene::Shape::output_vertex_count`], finite and ≥ 0), keeping in `state` what
    /// a later solve starts from; fills its statistics into `stats`.
    ///
    /// # Errors
    /// [`SceneError`] naming the object; [`SceneError::Cancelled`] through `stage`.
    fn solve(
        target: &Target<'_>,
        state: &mut Self::State,
        lighting: &Lighting<'_>,
        options: &Self::Options,
        stats: &mut ObjectStats,
        stage: Stage<'_>,
    ) -> Result<Vec<[f64; 3]>, SceneError>;

    /// The state as kept in an [`ObjectBake`].
    fn into_baked(state: Self::State) -> BakedState;
}

/// The stage reporter of `target`'s bake, one of `count` objects: its fractions mapped onto the
/// whole bake, reported under `furthest` (the furthest fraction so far, held while the callback
/// runs) so that reports from parallel tasks reach the callback in increasing order and a
/// fraction never goes back (a second mesher pass, a CG residual going up).
pub(crate) fn object_stage<'a>(
    progress: &'a Progress<'a>,
    furthest: &'a Mutex<f64>,
    target: &'a Target<'a>,
    count: usize,
) -> impl Fn(&str, f64) -> Result<(), Cancelled> + Sync + 'a {
    move |s: &str, f: f64| {
        let f = ((target.index as f64 + f) / count as f64).clamp(0.0, 1.0);
        let mut furthest = furthest.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        *furthest = furthest.max(f);
        progress.report(&format!("{}: {s}", target.object.name), *furthest)
    }
}

/// The contract's check of a method's radiance: one finite, non-negative value per output vertex.
///
/// # Errors
/// [`SceneError::InvalidObject`] naming the method and what is wrong.
pub(crate) fn check_radiance(target: &Target<'_>, name: &str, radiance: &[[f64; 3]]) -> Result<(), SceneError> {
    let expected = target.object.shape.output_vertex_count();
    if radiance.len() != expected {
        return Err(target
            .invalid(format!("the {name} method returned {} radiance values for {expected} output vertices", radiance.len())));
    }
    if let Some(v) = radiance.iter().position(|l| l.iter().any(|x| !(x.is_finite() && *x >= 0.0))) {
        return Err(target.invalid(format!("the {name} method returned the radiance {:?} at vertex {v}", radiance[v])));
    }
    Ok(())
}

/// One object through method `M` (named `name`): prepare, solve, and the check that the
/// radiance is one finite, non-negative value per output vertex.
///
/// # Errors
/// The method's; [`SceneError::InvalidObject`] when its radiance breaks the contract.
pub(crate) fn bake_object<M: SubsurfaceMethod>(
    target: &Target<'_>,
    options: &M::Options,
    name: &'static str,
    lighting: &Lighting<'_>,
    stage: Stage<'_>,
) -> Result<ObjectBake, SceneError> {
    let t0 = Instant::now();
    let mut stats = ObjectStats::new(name);
    stats.flipped_faces = target.world.flipped_faces();
    let mut state = M::prepare(target, options, &mut stats, stage)?;
    let radiance = M::solve(target, &mut state, lighting, options, &mut stats, stage)?;
    check_radiance(target, name, &radiance)?;
    stats.total_ms = ms(t0);
    Ok(ObjectBake { radiance, stats, state: M::into_baked(state) })
}
