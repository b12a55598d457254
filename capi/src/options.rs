//! What `tc_scene_bake` is asked for: the options structs, their defaults, and their reading
//! into the core's [`BakeOptions`].
//!
//! `TcBakeOptions` holds what every method shares (and the options of TransCut that predate
//! the method choice); `method_options` points to the chosen method's own size-prefixed
//! struct, `TcTransCutOptions` for `TC_METHOD_TRANSCUT`, `TcDipoleOptions` for
//! `TC_METHOD_HIERARCHICAL_DIPOLE`, `TcRadiosityOptions` for `TC_METHOD_RADIOSITY`,
//! `TcPrtOptions` for `TC_METHOD_PRT`, `TcPolygridOptions` for `TC_METHOD_POLYGRID` (NULL: its
//! defaults).

use std::ffi::{c_char, c_void};

use transcut_core::diffusion::{Discretization, SolverKind};
use transcut_core::gpu::Backend;
use transcut_core::hierarchy::{DipoleOptions, DipoleRadiance, EvalMode, Oracle, Receivers};
use transcut_core::light::SourceOptions;
use transcut_core::mesher::Grading;
use transcut_core::optics::{DipoleGeometry, EdgeRule};
use transcut_core::prt::{BasisSize, PrtCache, PrtOptions};
use transcut_core::radiosity::{FormFactorOptions, Iteration, SolveOptions};
use transcut_core::{BakeOptions, GradingChoice, Method, PolygridOptions, RadiosityOptions, Stencil, TransCutOptions};

use super::ptr;
use super::status::Failure;

/// The TransCut method (Li et al. 2012): the diffusion equation on a tetrahedral mesh.
/// `tc_method_count`, `tc_method_name` and `tc_method_from_name` list and name the methods;
/// new ones are appended.
pub const TC_METHOD_TRANSCUT: u32 = 0;
/// The hierarchical dipole (Mertens et al. 2003): the dipole of a homogeneous medium integrated
/// over the surface through cluster trees; no volume, no solve. Relight and
/// `tc_object_set_positions` (a deforming mesh, frame by frame); `TcDipoleOptions` in
/// `TcBakeOptions.method_options`. Heterogeneous media are refused with `TC_UNSUPPORTED`.
pub const TC_METHOD_HIERARCHICAL_DIPOLE: u32 = 1;
/// Translucent radiosity (Sheng et al. 2014): every object's surface in patches exchanging light
/// through form factors with visibility, so objects light each other (inter-reflection, colour
/// bleeding, emissive surfaces). The one method that bakes opaque diffuse objects
/// (`tc_scene_add_diffuse_mesh`) besides translucent ones, which scatter the light they get
/// through their TransCut diffusion solve (`TcBakeOptions.tets`, `tolerance`, `max_iterations`
/// and `backend` apply to them as to `TC_METHOD_TRANSCUT`). `TcRadiosityOptions` in
/// `TcBakeOptions.method_options`; `tc_scene_radiosity_stats` after the bake. Its objects are
/// coupled, so the bake's session offers no per-object update (relight, edits, cuts:
/// `TC_UNSUPPORTED`): change the scene and bake again.
pub const TC_METHOD_RADIOSITY: u32 = 2;
/// Precomputed translucent transfer (R. Wang et al. 2008): the dipole of a homogeneous medium
/// in a PCA basis, its transfer from 2ⁿ surface samples to the vertices precomputed and
/// compressed once, so that a relight (`tc_scene_relight`) and a whole-object medium edit
/// (`tc_object_edit_medium` with `TC_REGION_ALL`) need no new precompute. `TcPrtOptions` in
/// `TcBakeOptions.method_options`. Heterogeneous media, media the basis does not represent and
/// media too dense for the samples are refused with `TC_UNSUPPORTED`; other regions, paint and
/// cuts with `TC_UNSUPPORTED` or `TC_INVALID_ARGUMENT`, naming the method.
pub const TC_METHOD_PRT: u32 = 3;
/// Polygrid diffusion (Wang et al. 2008 §5): the diffusion equation on a grid of regular
/// connectivity cut from a voxel polycube of each object's surface and mapped onto it
/// (`TcPolygridOptions` in `TcBakeOptions.method_options`; `tc_object_polygrid_stats` after the
/// bake). `TcBakeOptions.tolerance`, `max_iterations` and `backend` apply to its solves as to
/// `TC_METHOD_TRANSCUT`'s; `tets` does not. Heterogeneous media; with the default stencil
/// (`TC_POLYGRID_STENCIL_FEM`) the bake's session relights and edits as TransCut's does, on the
/// grid's tets. An object whose grid folds at every cube size tried fails the bake with
/// `TC_MESHING_FAILED` naming it; a ready tet mesh (`tc_scene_add_tet_mesh`) is
/// `TC_UNSUPPORTED`.
pub const TC_METHOD_POLYGRID: u32 = 4;

/// `TcPolygridOptions.stencil`: P1 finite elements on the cells' Kuhn split with TransCut's
/// assembly (default): second order on skewed cells; the session relights and edits.
pub const TC_POLYGRID_STENCIL_FEM: u32 = 0;
/// `TcPolygridOptions.stencil`: node-centred finite volumes with two-point fluxes: exactly
/// conservative, second order on orthogonal cells only; SSOR-PCG on the CPU or Jacobi PCG on
/// the GPU (by `TcBakeOptions.backend`) whatever the solver; the session takes no updates
/// (`TC_UNSUPPORTED`).
pub const TC_POLYGRID_STENCIL_FINITE_VOLUME: u32 = 1;
/// `TcPolygridOptions.stencil`: the paper's own (Wang et al. 2008 eq. 9, App. B): least-squares
/// weights with the cross terms dropped, Stam's ψ = κφ form, for reproduction and comparison
/// (not conservative at κ interfaces, not consistent on skewed cells); Jacobi-BiCGSTAB on the
/// CPU whatever the solver and backend; the session takes no updates (`TC_UNSUPPORTED`).
pub const TC_POLYGRID_STENCIL_PAPER_LSQ: u32 = 2;
/// The largest `TcPolygridOptions.nodes` (above it: `TC_INVALID_ARGUMENT`).
pub const TC_MAX_POLYGRID_NODES: u64 = 4_000_000;
/// The largest `TcPolygridOptions.resolution` (above it: `TC_INVALID_ARGUMENT`).
pub const TC_MAX_POLYGRID_RESOLUTION: u32 = 256;

/// `TcPrtOptions.basis_terms`: the 16-function basis (default).
pub const TC_PRT_BASIS_16: u32 = 16;
/// `TcPrtOptions.basis_terms`: the paper's 12-function basis.
pub const TC_PRT_BASIS_12: u32 = 12;

/// `TcRadiosityOptions.iteration`: Jacobi, every patch from the last sweep (the paper's; sweep
/// k adds bounce k + 1; the default, and the one `bounces` needs).
pub const TC_RADIOSITY_JACOBI: u32 = 0;
/// `TcRadiosityOptions.iteration`: Gauss–Seidel, opaque patches from the values already updated
/// in the sweep (about half the sweeps, and half the translucent objects' diffusion solves, of
/// Jacobi).
pub const TC_RADIOSITY_GAUSS_SEIDEL: u32 = 1;
/// `TcRadiosityOptions.iteration`: BiCGSTAB on the coupled system (two diffusion solves of each
/// translucent object an iteration, few iterations), stopped by a bound on the error in power.
pub const TC_RADIOSITY_BICGSTAB: u32 = 2;
/// The most rays per patch `TcRadiosityOptions.rays_per_patch` may ask for, 2^24.
pub const TC_MAX_RAYS_PER_PATCH: u32 = 1 << 24;
/// The largest `TcRadiosityOptions.max_iterations` and `bounces`: a radiosity that has not
/// converged in ten thousand sweeps has an albedo too close to 1 to be meant.
pub const TC_MAX_RADIOSITY_ITERATIONS: u32 = 10_000;

/// `TcDipoleOptions.oracle`: accept a link when the clusters' radii sum to less than `theta`
/// times their distance (the default).
pub const TC_DIPOLE_ORACLE_OPENING_ANGLE: u32 = 0;
/// `TcDipoleOptions.oracle`: the paper's solid-angle oracle with `eps1` and `eps2`.
pub const TC_DIPOLE_ORACLE_PAPER: u32 = 1;
/// `TcDipoleOptions.rule`: the near field's edge integral by 3-point Gauss–Legendre (default).
pub const TC_DIPOLE_RULE_GAUSS_LEGENDRE: u32 = 0;
/// `TcDipoleOptions.rule`: the paper's midpoint rule (3–17% off away from the receiver).
pub const TC_DIPOLE_RULE_PAPER: u32 = 1;
/// `TcDipoleOptions.receivers`: the radiance evaluated at the vertices (default).
pub const TC_DIPOLE_RECEIVERS_VERTICES: u32 = 0;
/// `TcDipoleOptions.receivers`: at the triangles' centroids, averaged onto the vertices.
pub const TC_DIPOLE_RECEIVERS_FACES: u32 = 1;
/// `TcDipoleOptions.mode`: every update traverses the trees afresh, storing no links (default).
pub const TC_DIPOLE_MODE_ON_THE_FLY: u32 = 0;
/// `TcDipoleOptions.mode`: links kept while the geometry stays (a relight only gathers).
pub const TC_DIPOLE_MODE_RENDER: u32 = 1;
/// `TcDipoleOptions.mode`: links kept, relinked after a deformation only where it moved
/// geometry, at most `budget` links per update when `budget` is non-zero.
pub const TC_DIPOLE_MODE_INCREMENTAL: u32 = 2;
/// `TcDipoleOptions.geometry`: Rd of the distance between the points (default, reciprocal).
pub const TC_DIPOLE_GEOMETRY_DISTANCE: u32 = 0;
/// `TcDipoleOptions.geometry`: the paper's sources on the receiver's normal.
pub const TC_DIPOLE_GEOMETRY_PAPER: u32 = 1;
/// `TcDipoleOptions.radiance`: Lo = Ft B/(π(1 − Fdr)), the quantity TransCut returns (default).
pub const TC_DIPOLE_RADIANCE_TRANSCUT: u32 = 0;
/// `TcDipoleOptions.radiance`: Lo = T B/π (Jensen et al. 2001, the paper's eq. 3).
pub const TC_DIPOLE_RADIANCE_JENSEN: u32 = 1;

/// `TcBakeOptions.backend`: as the environment variable `TRANSCUT_BACKEND` says (`cpu`, `gpu`,
/// `auto`; an unknown value fails the bake with `TC_INVALID_ARGUMENT`), `TC_BACKEND_AUTO` when
/// it is unset or empty. The default.
pub const TC_BACKEND_DEFAULT: u32 = 0;
/// `TcBakeOptions.backend`: solve on the CPU (always available).
pub const TC_BACKEND_CPU: u32 = 1;
/// `TcBakeOptions.backend`: solve on the GPU (wgpu: Vulkan, Metal or DX12), also on a software
/// adapter such as Mesa's lavapipe; `tc_scene_bake` returns `TC_GPU_UNAVAILABLE` when no
/// adapter can be used. `TRANSCUT_GPU_ADAPTER=substring` restricts the adapters to those whose
/// name contains it.
pub const TC_BACKEND_GPU: u32 = 2;
/// `TcBakeOptions.backend`: the GPU when a hardware adapter exists, else the CPU (a software
/// adapter is slower than the CPU path and is not used); `tc_object_backend_fallback` says why
/// the CPU ran.
pub const TC_BACKEND_AUTO: u32 = 3;

/// `TcTransCutOptions.solver` and `.edit_solver`: the method's default (SSOR-PCG for the bake,
/// the smoothed-aggregation V-cycle for edits).
pub const TC_SOLVER_DEFAULT: u32 = 0;
/// CG with the Jacobi preconditioner (mixed precision).
pub const TC_SOLVER_PCG: u32 = 1;
/// CG with the SSOR preconditioner.
pub const TC_SOLVER_SSOR_PCG: u32 = 2;
/// TransCut §4.2's coarse-to-fine cascade (CPU only).
pub const TC_SOLVER_CASCADE: u32 = 3;
/// CG preconditioned by a V-cycle on TransCut's §4.1 hierarchy.
pub const TC_SOLVER_MG_PCG: u32 = 4;
/// CG preconditioned by a V-cycle on a smoothed-aggregation hierarchy.
pub const TC_SOLVER_SA_PCG: u32 = 5;

/// The most worker threads `TcBakeOptions.threads` may ask for (above it:
/// `TC_INVALID_ARGUMENT`).
pub const TC_MAX_THREADS: u32 = 256;
/// The most samples per point `TcBakeOptions.area_samples` and `environment_samples` may ask
/// for, 2^20 (above it: `TC_INVALID_ARGUMENT`).
pub const TC_MAX_SAMPLES: u32 = 1 << 20;
/// The largest `TcBakeOptions.tets` (above it: `TC_INVALID_ARGUMENT`).
pub const TC_MAX_TETS: u64 = 20_000_000;
/// The largest `TcBakeOptions.max_iterations` (above it: `TC_INVALID_ARGUMENT`).
pub const TC_MAX_ITERATIONS: u32 = 1_000_000;

/// How to bake. Fill it with `tc_bake_options_init(&options, sizeof options)` (which also sets
/// `size`), then change fields. `size` lets later versions append fields: a library reads and
/// writes only the fields that it and the caller both know.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcBakeOptions {
    /// The bytes of the struct the caller has, set by `tc_bake_options_init`.
    pub size: u32,
    /// The subsurface method: `TC_METHOD_TRANSCUT` (default), `TC_METHOD_HIERARCHICAL_DIPOLE`,
    /// `TC_METHOD_RADIOSITY`, `TC_METHOD_PRT` or `TC_METHOD_POLYGRID`.
    pub method: u32,
    /// TransCut (and radiosity's translucent objects): target number of tetrahedra per surface
    /// object, 1 to `TC_MAX_TETS` (default 200 000).
    pub tets: u64,
    /// Relative residual ‖b − Mφ‖/‖b‖ at which the solver stops, in (0, 1) (default 1e-6).
    pub tolerance: f64,
    /// Iteration cap of the solver, 1 to `TC_MAX_ITERATIONS` (default 10 000).
    pub max_iterations: u32,
    /// Worker threads, at most `TC_MAX_THREADS`; 0 = one per core (default). The threads are
    /// started for each call that uses them and have ended when it returns.
    pub threads: u32,
    /// Non-zero: objects shadow themselves and each other (default 1).
    pub shadows: u32,
    /// Samples per point for area lights and suns with a non-zero diameter, at most
    /// `TC_MAX_SAMPLES` (default 64).
    pub area_samples: u32,
    /// Samples per point for shadowed environments, at most `TC_MAX_SAMPLES` (default 256).
    pub environment_samples: u32,
    /// Where the solve runs: `TC_BACKEND_DEFAULT` (default), `TC_BACKEND_CPU`,
    /// `TC_BACKEND_GPU` or `TC_BACKEND_AUTO`; another value fails with `TC_INVALID_ARGUMENT`.
    /// `tc_object_stats` says which backend ran (`TcBakeStats.backend_used`).
    pub backend: u32,
    /// NULL (the default: the method's own defaults), or the chosen method's options: for
    /// `TC_METHOD_TRANSCUT` a `const TcTransCutOptions *` (filled by
    /// `tc_transcut_options_init`), for `TC_METHOD_HIERARCHICAL_DIPOLE` a
    /// `const TcDipoleOptions *` (filled by `tc_dipole_options_init`), for
    /// `TC_METHOD_RADIOSITY` a `const TcRadiosityOptions *` (filled by
    /// `tc_radiosity_options_init`), for `TC_METHOD_PRT` a `const TcPrtOptions *` (filled by
    /// `tc_prt_options_init`), for `TC_METHOD_POLYGRID` a `const TcPolygridOptions *` (filled
    /// by `tc_polygrid_options_init`). Read during `tc_scene_bake` only, and only when `size`
    /// covers it (a struct of the first version, 48 bytes, has no such field).
    pub method_options: *const c_void,
}

/// TransCut's own options (`TcBakeOptions.method_options` with `TC_METHOD_TRANSCUT`). Fill it
/// with `tc_transcut_options_init(&options, sizeof options)`, which sets `size`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TcTransCutOptions {
    /// The bytes of the struct the caller has, set by `tc_transcut_options_init`.
    pub size: u32,
    /// The bake's solver on the CPU: `TC_SOLVER_DEFAULT` (SSOR-PCG) or a `TC_SOLVER_*` (on the
    /// GPU the single-level solvers run Jacobi PCG).
    pub solver: u32,
    /// The solver of edits after the bake (relight, material edits, cuts):
    /// `TC_SOLVER_DEFAULT` (the smoothed-aggregation V-cycle) or a `TC_SOLVER_*`.
    pub edit_solver: u32,
    /// `TC_GRADING_AUTO` (what `tc_transcut_options_init` writes, the library's default): graded
    /// (1) where the object's medium has a boundary layer thinner than two uniform lattice
    /// spacings at `TcBakeOptions.tets`, uniform elsewhere. 0: one tet size everywhere.
    /// N in 1 to `TC_MAX_GRADING_LAYERS`: graded tets, the finest near the surface, cube sizes
    /// doubling inwards after N cubes of each size, so that `TcBakeOptions.tets` buys a finer
    /// surface layer (1 is more accurate than uniform tets for every preset medium at the same
    /// count, but a cut exposes the coarser interior as new surface). Another value fails with
    /// `TC_INVALID_ARGUMENT`. Read only when `size` covers it (a struct of the first version,
    /// 12 bytes, has no such field and gets the default).
    pub grading: u32,
    /// The assembly: `TC_DISCRETIZATION_FITTED_LAYER` (what `tc_transcut_options_init` writes,
    /// the library's default), `TC_DISCRETIZATION_FITTED`, `TC_DISCRETIZATION_TRANSCUT` or
    /// `TC_DISCRETIZATION_CONSISTENT_FEM`; another value fails with `TC_INVALID_ARGUMENT`. Read
    /// only when `size` covers it.
    pub discretization: u32,
}

/// `TcTransCutOptions.discretization`: TransCut's assembly (eqs. 10–14).
pub const TC_DISCRETIZATION_TRANSCUT: u32 = 0;
/// `TcTransCutOptions.discretization`: TransCut's assembly with each edge's stiffness
/// exponentially fitted to the boundary layer (more accurate where the tets are coarse against
/// the diffusion length; second order in the spacing).
pub const TC_DISCRETIZATION_FITTED: u32 = 1;
/// `TcTransCutOptions.discretization`: the consistent P1 finite elements (the reference).
pub const TC_DISCRETIZATION_CONSISTENT_FEM: u32 = 2;
/// `TcTransCutOptions.discretization`: the fitted assembly with each boundary row's absorption
/// taken from the boundary layer under it (the most accurate at practical sizes; the default).
pub const TC_DISCRETIZATION_FITTED_LAYER: u32 = 3;

/// The first version's `sizeof(TcTransCutOptions)` (no `grading`, no `discretization`).
pub(crate) const TRANSCUT_OPTIONS_SIZE_V1: usize = 12;
/// The most cubes of one size `TcTransCutOptions.grading` may ask for (above it:
/// `TC_INVALID_ARGUMENT`).
pub const TC_MAX_GRADING_LAYERS: u32 = 64;
/// `TcTransCutOptions.grading`, `TcRadiosityOptions.grading`: chosen per object from its medium
/// and the tet budget.
pub const TC_GRADING_AUTO: u32 = u32::MAX;

/// The hierarchical dipole's own options (`TcBakeOptions.method_options` with
/// `TC_METHOD_HIERARCHICAL_DIPOLE`). Fill it with `tc_dipole_options_init(&options, sizeof
/// options)`, which sets `size`. `TcBakeOptions.tets`, `tolerance`, `max_iterations` and
/// `backend` do not apply to this method.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcDipoleOptions {
    /// The bytes of the struct the caller has, set by `tc_dipole_options_init`.
    pub size: u32,
    /// `TC_DIPOLE_ORACLE_OPENING_ANGLE` (default) or `TC_DIPOLE_ORACLE_PAPER`.
    pub oracle: u32,
    /// The opening angle, in (0, 1] (default 0.4; 0.6 fast, 0.3 accurate).
    pub theta: f64,
    /// The paper oracle's receiver threshold, > 0 (default 0.05).
    pub eps1: f64,
    /// The paper oracle's emitter threshold, > 0 (default 0.05).
    pub eps2: f64,
    /// `TC_DIPOLE_RULE_GAUSS_LEGENDRE` (default) or `TC_DIPOLE_RULE_PAPER`.
    pub rule: u32,
    /// `TC_DIPOLE_RECEIVERS_VERTICES` (default) or `TC_DIPOLE_RECEIVERS_FACES`.
    pub receivers: u32,
    /// `TC_DIPOLE_MODE_ON_THE_FLY` (default), `TC_DIPOLE_MODE_RENDER` or
    /// `TC_DIPOLE_MODE_INCREMENTAL`.
    pub mode: u32,
    /// `TC_DIPOLE_GEOMETRY_DISTANCE` (default) or `TC_DIPOLE_GEOMETRY_PAPER`.
    pub geometry: u32,
    /// Incremental mode: the most links evaluated per update; 0 = no limit (default).
    pub budget: u64,
    /// `TC_DIPOLE_RADIANCE_TRANSCUT` (default) or `TC_DIPOLE_RADIANCE_JENSEN`.
    pub radiance: u32,
}

/// The PRT method's own options (`TcBakeOptions.method_options` with `TC_METHOD_PRT`). Fill it
/// with `tc_prt_options_init(&options, sizeof options)`, which sets `size`, then change fields.
/// `TcBakeOptions.tets`, `tolerance`, `max_iterations` and `backend` do not apply to this method.
/// A value out of range fails the bake with `TC_INVALID_ARGUMENT` naming the field.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcPrtOptions {
    /// The bytes of the struct the caller has, set by `tc_prt_options_init`.
    pub size: u32,
    /// log₂ of the irradiance samples, 4 to 18 (default 16: 65536 samples).
    pub samples_log2: u32,
    /// `TC_PRT_BASIS_16` (default) or `TC_PRT_BASIS_12` (the paper's).
    pub basis_terms: u32,
    /// Haar coefficients kept per vertex over all its basis rows, from `basis_terms` to 2²⁰
    /// (default 1024; the transfer takes about 3 bytes each).
    pub terms_per_vertex: u32,
    /// 1 (default): the near-field correction of the transfer rows; 0: none.
    pub near_field: u32,
    /// The near field's radius in sample spacings, in [1, 64] (default 8).
    pub near_radius: f64,
    /// The seed of the samples' systematic offset.
    pub seed: u64,
    /// A folder of saved precomputes (UTF-8 path; NULL, the default: none). A bake reads the
    /// transfer of an object from `<folder>/<key>.tcprt` when it is there, made for the same
    /// surface, placement, scale and options, and otherwise precomputes it and writes that file
    /// (creating the folder), replacing a damaged or outdated one. The library reads the string
    /// during `tc_scene_bake` only.
    pub cache_dir: *const c_char,
}

/// The polygrid method's own options (`TcBakeOptions.method_options` with
/// `TC_METHOD_POLYGRID`). Fill it with `tc_polygrid_options_init(&options, sizeof options)`,
/// which sets `size`, then change fields. Its solves take `TcBakeOptions.tolerance`,
/// `max_iterations` and `backend` (as TransCut's); `TcBakeOptions.tets` does not apply. A value
/// out of range fails the bake with `TC_INVALID_ARGUMENT` naming the field
/// (`options->method_options->…`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcPolygridOptions {
    /// The bytes of the struct the caller has, set by `tc_polygrid_options_init`.
    pub size: u32,
    /// Grid cells per cube edge of the polycube, 1 to `TC_MAX_POLYGRID_RESOLUTION` (default 8;
    /// the paper uses 12 to 32).
    pub resolution: u32,
    /// Target grid nodes per object, 8 to `TC_MAX_POLYGRID_NODES` (default 200 000): with
    /// `resolution` it sets the cube size when `cube_mm` is 0.
    pub nodes: u64,
    /// The polycube's cube edge in mm: finite and > 0, or 0 (the default) for the size from
    /// `nodes` (the object's volume over the node budget). A cube at which the polycube changes
    /// the surface's topology or the grid folds is made smaller, at the same node spacing.
    pub cube_mm: f64,
    /// `TC_POLYGRID_STENCIL_FEM` (default), `TC_POLYGRID_STENCIL_FINITE_VOLUME` or
    /// `TC_POLYGRID_STENCIL_PAPER_LSQ`.
    pub stencil: u32,
    /// The bake's solver on the CPU with the FEM stencil: `TC_SOLVER_DEFAULT` (SSOR-PCG) or a
    /// `TC_SOLVER_*`, as `TcTransCutOptions.solver`.
    pub solver: u32,
    /// The solver of the session's updates (relight, material edits, cuts):
    /// `TC_SOLVER_DEFAULT` (the smoothed-aggregation V-cycle) or a `TC_SOLVER_*`.
    pub edit_solver: u32,
}

/// Translucent radiosity's own options (`TcBakeOptions.method_options` with
/// `TC_METHOD_RADIOSITY`). Fill it with `tc_radiosity_options_init(&options, sizeof options)`,
/// which sets `size`, then change fields. The translucent objects are meshed and solved as
/// TransCut does, with `TcBakeOptions.tets`, `tolerance`, `max_iterations` and `backend` (one
/// place for them whatever the method, as on the command line); the fields here are the
/// radiosity's own. A value out of range fails the bake with `TC_INVALID_ARGUMENT` naming the
/// field (`options->method_options->…`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcRadiosityOptions {
    /// The bytes of the struct the caller has, set by `tc_radiosity_options_init`.
    pub size: u32,
    /// `TC_RADIOSITY_JACOBI` (default), `TC_RADIOSITY_GAUSS_SEIDEL` or `TC_RADIOSITY_BICGSTAB`.
    pub iteration: u32,
    /// The longest patch edge on opaque objects, in mm (their meshes are refined to it, keeping
    /// their vertices): finite and > 0, or 0 for the default, the scene's bounding-box diagonal
    /// / 80 (about 4.3 mm in a 200 mm box). Translucent objects' patches are the boundary
    /// vertices of their tets. Smaller patches resolve shadows and colour bleeding better; each
    /// casts `rays_per_patch` rays, and the form factors' memory grows with their number.
    pub patch_size_mm: f64,
    /// Rays cast from each patch for the form factors, 1 to `TC_MAX_RAYS_PER_PATCH` (default
    /// 512; the noise of a factor F is about √(F(1 − F)/N)).
    pub rays_per_patch: u32,
    /// Sweeps of the iteration at most, 1 to `TC_MAX_RADIOSITY_ITERATIONS` (default 200).
    pub max_iterations: u32,
    /// The seed of the rays: the same seed gives the same form factors on any number of threads.
    pub seed: u64,
    /// The estimated relative error in power at which the iteration stops, in (0, 1) (default
    /// 1e-3). (`TcBakeOptions.tolerance` is the translucent objects' diffusion solve's.)
    pub tolerance: f64,
    /// A patch whose rays hit the back of one-sided surfaces more often than this fraction lies
    /// inside geometry: it exchanges nothing and takes its radiance from its neighbours. In
    /// (0, 1] (default 0.1).
    pub covered_fraction: f64,
    /// Exactly this many bounces of light (1: the direct light and the emission only), whatever
    /// the tolerance, 1 to `TC_MAX_RADIOSITY_ITERATIONS`, with `TC_RADIOSITY_JACOBI` only; 0 (the
    /// default): until the tolerance.
    pub bounces: u32,
    /// The translucent objects' diffusion solver on the CPU: `TC_SOLVER_DEFAULT` (SSOR-PCG) or a
    /// `TC_SOLVER_*`, as `TcTransCutOptions.solver`.
    pub solver: u32,
    /// The translucent objects' tets: `TC_GRADING_AUTO` (default), 0 uniform, N in 1 to
    /// `TC_MAX_GRADING_LAYERS` graded, as `TcTransCutOptions.grading`. Read only when `size` covers it (a struct of the
    /// first version, 56 bytes, has no such field and gets the default).
    pub grading: u32,
    /// The translucent objects' assembly, as `TcTransCutOptions.discretization` (default
    /// `TC_DISCRETIZATION_FITTED_LAYER`). Read only when `size` covers it.
    pub discretization: u32,
}

/// The first version's `sizeof(TcRadiosityOptions)` (no `grading`, no `discretization`).
pub(crate) const RADIOSITY_OPTIONS_SIZE_V1: usize = 56;

/// The defaults, as `tc_radiosity_options_init` writes them.
pub(crate) fn default_radiosity_options() -> TcRadiosityOptions {
    let d = RadiosityOptions::default();
    TcRadiosityOptions {
        size: size_of::<TcRadiosityOptions>() as u32,
        iteration: match d.solve.iteration {
            Iteration::GaussSeidel => TC_RADIOSITY_GAUSS_SEIDEL,
            Iteration::Jacobi => TC_RADIOSITY_JACOBI,
            Iteration::BiCgStab => TC_RADIOSITY_BICGSTAB,
        },
        patch_size_mm: d.patch_size_mm.unwrap_or(0.0),
        rays_per_patch: u32::try_from(d.form_factors.rays_per_patch).unwrap_or(u32::MAX),
        max_iterations: u32::try_from(d.solve.max_iterations).unwrap_or(u32::MAX),
        seed: d.form_factors.seed,
        tolerance: d.solve.tolerance,
        covered_fraction: d.form_factors.covered_fraction,
        bounces: d.solve.bounces.map_or(0, |b| u32::try_from(b).unwrap_or(u32::MAX)),
        solver: TC_SOLVER_DEFAULT,
        grading: grading_code(d.transcut.grading),
        discretization: TC_DISCRETIZATION_FITTED_LAYER,
    }
}

/// The core's options from the caller's struct, with `transcut` the translucent objects' bake
/// (from `TcBakeOptions`; its solver is replaced by `o.solver` unless that is the default).
fn radiosity_options(o: &TcRadiosityOptions, transcut: TransCutOptions) -> Result<RadiosityOptions, Failure> {
    let field = |name: &str, message: String| Failure::invalid(format!("options->method_options->{name} = {message}"));
    let iteration = match o.iteration {
        TC_RADIOSITY_JACOBI => Iteration::Jacobi,
        TC_RADIOSITY_GAUSS_SEIDEL => Iteration::GaussSeidel,
        TC_RADIOSITY_BICGSTAB => Iteration::BiCgStab,
        other => {
            return Err(field(
                "iteration",
                format!(
                "{other}: unknown iteration (TC_RADIOSITY_JACOBI = 0, TC_RADIOSITY_GAUSS_SEIDEL = 1, TC_RADIOSITY_BICGSTAB = 2)"
            ),
            ))
        }
    };
    let h = o.patch_size_mm;
    let patch_size_mm = if h == 0.0 {
        None
    } else if h.is_finite() && h > 0.0 {
        Some(h)
    } else {
        return Err(field("patch_size_mm", format!("{h}: must be 0 (the default) or finite and > 0 (mm)")));
    };
    let bounded = [
        ("rays_per_patch", o.rays_per_patch, TC_MAX_RAYS_PER_PATCH),
        ("max_iterations", o.max_iterations, TC_MAX_RADIOSITY_ITERATIONS),
    ];
    for (name, value, max) in bounded {
        if value == 0 || value > max {
            return Err(field(name, format!("{value}: must be in 1..={max}")));
        }
    }
    if !(o.tolerance > 0.0 && o.tolerance < 1.0) {
        return Err(field("tolerance", format!("{}: must lie in (0, 1)", o.tolerance)));
    }
    if !(o.covered_fraction > 0.0 && o.covered_fraction <= 1.0) {
        return Err(field("covered_fraction", format!("{}: must lie in (0, 1]", o.covered_fraction)));
    }
    let bounces = match o.bounces {
        0 => None,
        b if b > TC_MAX_RADIOSITY_ITERATIONS => {
            return Err(field("bounces", format!("{b}: must be at most {TC_MAX_RADIOSITY_ITERATIONS} (0: until the tolerance)")))
        }
        _ if iteration != Iteration::Jacobi => {
            return Err(field(
                "bounces",
                format!("{}: a count of bounces needs TC_RADIOSITY_JACOBI (Gauss–Seidel and BiCGSTAB mix bounces)", o.bounces),
            ))
        }
        b => Some(b as usize),
    };
    let solver = solver_from(o.solver, "options->method_options->solver")?.unwrap_or(transcut.solver);
    let grading = grading_from(o.grading)?;
    let discretization = discretization_from(o.discretization)?;
    let options = RadiosityOptions {
        patch_size_mm,
        form_factors: FormFactorOptions {
            rays_per_patch: o.rays_per_patch as usize,
            seed: o.seed,
            covered_fraction: o.covered_fraction,
        },
        solve: SolveOptions { iteration, tolerance: o.tolerance, max_iterations: o.max_iterations as usize, bounces },
        backend: transcut.backend,
        transcut: TransCutOptions { solver, grading, discretization, ..transcut },
        ..RadiosityOptions::default()
    };
    // What the checks above do not cover (the core's own bounds, should they tighten).
    let own = RadiosityOptions { transcut: TransCutOptions::default(), ..options.clone() };
    own.validate().map_err(|e| Failure::invalid(format!("options->method_options: {e}")))?;
    Ok(options)
}

/// The defaults, as `tc_polygrid_options_init` writes them.
pub(crate) fn default_polygrid_options() -> TcPolygridOptions {
    let d = PolygridOptions::default();
    TcPolygridOptions {
        size: size_of::<TcPolygridOptions>() as u32,
        resolution: d.resolution,
        nodes: d.nodes as u64,
        cube_mm: d.cube_mm.unwrap_or(0.0),
        stencil: match d.stencil {
            Stencil::FiniteVolume => TC_POLYGRID_STENCIL_FINITE_VOLUME,
            Stencil::PaperLsq => TC_POLYGRID_STENCIL_PAPER_LSQ,
            _ => TC_POLYGRID_STENCIL_FEM,
        },
        solver: TC_SOLVER_DEFAULT,
        edit_solver: TC_SOLVER_DEFAULT,
    }
}

/// The core's options from the caller's struct, with `transcut` the solves' tolerance,
/// iterations and backend (from `TcBakeOptions`; its solvers replaced by `o.solver` and
/// `o.edit_solver` unless those are the default).
fn polygrid_options(o: &TcPolygridOptions, transcut: TransCutOptions) -> Result<PolygridOptions, Failure> {
    let field = |name: &str, message: String| Failure::invalid(format!("options->method_options->{name} = {message}"));
    let stencil = match o.stencil {
        TC_POLYGRID_STENCIL_FEM => Stencil::Fem,
        TC_POLYGRID_STENCIL_FINITE_VOLUME => Stencil::FiniteVolume,
        TC_POLYGRID_STENCIL_PAPER_LSQ => Stencil::PaperLsq,
        other => {
            return Err(field(
                "stencil",
                format!(
                    "{other}: unknown stencil (TC_POLYGRID_STENCIL_FEM = 0, TC_POLYGRID_STENCIL_FINITE_VOLUME = 1, \
                     TC_POLYGRID_STENCIL_PAPER_LSQ = 2)"
                ),
            ))
        }
    };
    if o.resolution == 0 || o.resolution > TC_MAX_POLYGRID_RESOLUTION {
        return Err(field(
            "resolution",
            format!("{}: must be in 1..={TC_MAX_POLYGRID_RESOLUTION} cells per cube edge", o.resolution),
        ));
    }
    if !(8..=TC_MAX_POLYGRID_NODES).contains(&o.nodes) {
        return Err(field("nodes", format!("{}: must be in 8..={TC_MAX_POLYGRID_NODES}", o.nodes)));
    }
    let h = o.cube_mm;
    let cube_mm = if h == 0.0 {
        None
    } else if h.is_finite() && h > 0.0 {
        Some(h)
    } else {
        return Err(field("cube_mm", format!("{h}: must be 0 (the default: from nodes) or finite and > 0 (mm)")));
    };
    let solver = solver_from(o.solver, "options->method_options->solver")?.unwrap_or(transcut.solver);
    let edit_solver = solver_from(o.edit_solver, "options->method_options->edit_solver")?.unwrap_or(transcut.edit_solver);
    let options = PolygridOptions {
        nodes: usize::try_from(o.nodes).unwrap_or(usize::MAX),
        cube_mm,
        resolution: o.resolution,
        stencil,
        // `TcBakeOptions.tets` is not the polygrid's (a caller may leave it 0): the core's
        // default, which the session's editor is given.
        solve: TransCutOptions { solver, edit_solver, tets: PolygridOptions::default().solve.tets, ..transcut },
    };
    // What the checks above do not cover (the core's own bounds, should they tighten).
    options.validate().map_err(|e| Failure::invalid(format!("options->method_options: {e}")))?;
    Ok(options)
}

/// The defaults, as `tc_prt_options_init` writes them.
pub(crate) fn default_prt_options() -> TcPrtOptions {
    let d = PrtOptions::default();
    TcPrtOptions {
        size: size_of::<TcPrtOptions>() as u32,
        samples_log2: d.samples_log2,
        basis_terms: d.basis.terms() as u32,
        terms_per_vertex: d.terms_per_vertex as u32,
        near_field: u32::from(d.near_field),
        near_radius: d.near_radius,
        seed: d.seed,
        cache_dir: std::ptr::null(),
    }
}

/// The core's options from the caller's struct (the ranges are checked by the bake, naming the
/// field).
fn prt_options(o: &TcPrtOptions) -> Result<PrtOptions, Failure> {
    let basis = match o.basis_terms {
        TC_PRT_BASIS_16 => BasisSize::K16,
        TC_PRT_BASIS_12 => BasisSize::K12,
        other => {
            return Err(Failure::invalid(format!("options->method_options->basis_terms = {other}: must be 12 or 16")));
        }
    };
    let near_field = match o.near_field {
        0 => false,
        1 => true,
        other => return Err(Failure::invalid(format!("options->method_options->near_field = {other}: must be 0 or 1"))),
    };
    let options = PrtOptions {
        samples_log2: o.samples_log2,
        basis,
        terms_per_vertex: o.terms_per_vertex as usize,
        near_field,
        near_radius: o.near_radius,
        seed: o.seed,
        // SAFETY: the caller's contract (a NUL-terminated string or NULL).
        cache: unsafe { ptr::optional_path(o.cache_dir, "options->method_options->cache_dir")? }
            .map(|dir| PrtCache::Folder(dir.to_path_buf())),
    };
    options.validate().map_err(|e| Failure::invalid(format!("options->method_options: {e}")))?;
    Ok(options)
}

/// The defaults, as `tc_dipole_options_init` writes them.
pub(crate) fn default_dipole_options() -> TcDipoleOptions {
    let (theta, eps) = (0.4, 0.05);
    debug_assert_eq!(DipoleOptions::default().oracle, Oracle::OpeningAngle { theta });
    TcDipoleOptions {
        size: size_of::<TcDipoleOptions>() as u32,
        oracle: TC_DIPOLE_ORACLE_OPENING_ANGLE,
        theta,
        eps1: eps,
        eps2: eps,
        rule: TC_DIPOLE_RULE_GAUSS_LEGENDRE,
        receivers: TC_DIPOLE_RECEIVERS_VERTICES,
        mode: TC_DIPOLE_MODE_ON_THE_FLY,
        geometry: TC_DIPOLE_GEOMETRY_DISTANCE,
        budget: 0,
        radiance: TC_DIPOLE_RADIANCE_TRANSCUT,
    }
}

/// The core's options from the caller's struct.
fn dipole_options(o: &TcDipoleOptions) -> Result<DipoleOptions, Failure> {
    let pick = |value: u32, field: &str, choices: usize| {
        if (value as usize) < choices {
            Ok(value)
        } else {
            Err(Failure::invalid(format!("options->method_options->{field} = {value}: must be below {choices}")))
        }
    };
    let options = DipoleOptions {
        oracle: match pick(o.oracle, "oracle", 2)? {
            TC_DIPOLE_ORACLE_OPENING_ANGLE => Oracle::OpeningAngle { theta: o.theta },
            _ => Oracle::Paper { eps1: o.eps1, eps2: o.eps2 },
        },
        rule: match pick(o.rule, "rule", 2)? {
            TC_DIPOLE_RULE_GAUSS_LEGENDRE => EdgeRule::default(),
            _ => EdgeRule::PAPER,
        },
        receivers: match pick(o.receivers, "receivers", 2)? {
            TC_DIPOLE_RECEIVERS_VERTICES => Receivers::Vertices,
            _ => Receivers::FaceCentroids,
        },
        mode: match pick(o.mode, "mode", 3)? {
            TC_DIPOLE_MODE_ON_THE_FLY => EvalMode::OnTheFly,
            TC_DIPOLE_MODE_RENDER => EvalMode::Render,
            _ => EvalMode::Incremental {
                budget: match o.budget {
                    0 => None,
                    b => Some(usize::try_from(b).unwrap_or(usize::MAX)),
                },
            },
        },
        geometry: match pick(o.geometry, "geometry", 2)? {
            TC_DIPOLE_GEOMETRY_DISTANCE => DipoleGeometry::Distance,
            _ => DipoleGeometry::PaperSources,
        },
        radiance: match pick(o.radiance, "radiance", 2)? {
            TC_DIPOLE_RADIANCE_TRANSCUT => DipoleRadiance::MatchTransCut,
            _ => DipoleRadiance::Jensen2001,
        },
    };
    options.validate().map_err(|e| Failure::invalid(format!("options->method_options: {e}")))?;
    Ok(options)
}

/// The size of `TcBakeOptions` before `method_options` was appended.
pub(crate) const BAKE_OPTIONS_SIZE_V1: usize = std::mem::offset_of!(TcBakeOptions, method_options);

/// The defaults, as `tc_bake_options_init` writes them.
pub(crate) fn default_bake_options() -> TcBakeOptions {
    let core = BakeOptions::default();
    let transcut = TransCutOptions::default();
    let source = SourceOptions::default();
    TcBakeOptions {
        size: size_of::<TcBakeOptions>() as u32,
        method: TC_METHOD_TRANSCUT,
        tets: transcut.tets as u64,
        tolerance: transcut.tolerance,
        max_iterations: u32::try_from(transcut.max_iterations).unwrap_or(u32::MAX),
        threads: u32::try_from(core.threads).unwrap_or(0),
        shadows: u32::from(core.shadows),
        area_samples: u32::try_from(source.area_samples).unwrap_or(u32::MAX),
        environment_samples: u32::try_from(source.environment_samples).unwrap_or(u32::MAX),
        backend: TC_BACKEND_DEFAULT,
        method_options: std::ptr::null(),
    }
}

/// The defaults, as `tc_transcut_options_init` writes them.
pub(crate) fn default_transcut_options() -> TcTransCutOptions {
    TcTransCutOptions {
        size: size_of::<TcTransCutOptions>() as u32,
        solver: TC_SOLVER_DEFAULT,
        edit_solver: TC_SOLVER_DEFAULT,
        grading: grading_code(TransCutOptions::default().grading),
        discretization: TC_DISCRETIZATION_FITTED_LAYER,
    }
}

/// `method_options->grading` for the core's grading (the inverse of [`grading_from`]).
fn grading_code(grading: GradingChoice) -> u32 {
    match grading {
        GradingChoice::Auto => TC_GRADING_AUTO,
        GradingChoice::Fixed(Grading::Uniform) => 0,
        GradingChoice::Fixed(Grading::Graded { layers }) => layers,
    }
}

/// The core's grading for `method_options->grading` (`TcTransCutOptions`, `TcRadiosityOptions`).
fn grading_from(layers: u32) -> Result<GradingChoice, Failure> {
    if layers == TC_GRADING_AUTO {
        Ok(GradingChoice::Auto)
    } else if layers <= TC_MAX_GRADING_LAYERS {
        Ok(Grading::from_layers(layers).into())
    } else {
        Err(Failure::invalid(format!(
            "options->method_options->grading = {layers}: TC_GRADING_AUTO, 0 (uniform) or 1 to TC_MAX_GRADING_LAYERS = {TC_MAX_GRADING_LAYERS} cubes per size"
        )))
    }
}

/// The core's assembly for `method_options->discretization` (`TcTransCutOptions`,
/// `TcRadiosityOptions`).
fn discretization_from(value: u32) -> Result<Discretization, Failure> {
    match value {
        TC_DISCRETIZATION_TRANSCUT => Ok(Discretization::TransCut),
        TC_DISCRETIZATION_FITTED => Ok(Discretization::ExponentiallyFitted),
        TC_DISCRETIZATION_CONSISTENT_FEM => Ok(Discretization::ConsistentFem),
        TC_DISCRETIZATION_FITTED_LAYER => Ok(Discretization::FittedLayer),
        other => Err(Failure::invalid(format!(
            "options->method_options->discretization = {other}: TC_DISCRETIZATION_TRANSCUT 0, _FITTED 1, _CONSISTENT_FEM 2 \
             or _FITTED_LAYER 3"
        ))),
    }
}

/// The core's backend choice for `TcBakeOptions.backend` (`None`: the environment decides).
pub(crate) fn backend_from(value: u32, what: &str) -> Result<Option<Backend>, Failure> {
    match value {
        TC_BACKEND_DEFAULT => Ok(None),
        TC_BACKEND_CPU => Ok(Some(Backend::Cpu)),
        TC_BACKEND_GPU => Ok(Some(Backend::Gpu)),
        TC_BACKEND_AUTO => Ok(Some(Backend::Auto)),
        other => Err(Failure::invalid(format!(
            "{what} = {other}: unknown backend (TC_BACKEND_DEFAULT = 0, TC_BACKEND_CPU = 1, TC_BACKEND_GPU = 2, TC_BACKEND_AUTO = 3)"
        ))),
    }
}

/// `TC_BACKEND_CPU` or `TC_BACKEND_GPU` for the backend that ran.
pub(crate) fn backend_used(b: Backend) -> u32 {
    match b {
        Backend::Gpu => TC_BACKEND_GPU,
        Backend::Cpu | Backend::Auto => TC_BACKEND_CPU,
    }
}

/// The solver of a `TC_SOLVER_*` value (`None`: the default).
fn solver_from(value: u32, what: &str) -> Result<Option<SolverKind>, Failure> {
    Ok(Some(match value {
        TC_SOLVER_DEFAULT => return Ok(None),
        TC_SOLVER_PCG => SolverKind::Pcg,
        TC_SOLVER_SSOR_PCG => SolverKind::SsorPcg,
        TC_SOLVER_CASCADE => SolverKind::Cascade,
        TC_SOLVER_MG_PCG => SolverKind::MultigridPcg,
        TC_SOLVER_SA_PCG => SolverKind::AggregationPcg,
        other => {
            return Err(Failure::invalid(format!(
                "{what} = {other}: unknown solver (TC_SOLVER_DEFAULT 0, PCG 1, SSOR_PCG 2, CASCADE 3, MG_PCG 4, SA_PCG 5)"
            )))
        }
    }))
}

/// A size-prefixed options struct: its C name and the function that fills its defaults.
pub(crate) struct Sized {
    pub(crate) what: &'static str,
    pub(crate) type_name: &'static str,
    pub(crate) filler: &'static str,
}

/// An earlier released layout of a size-prefixed struct: its `sizeof`, and the bytes its
/// fields take. These are fewer where it ends in padding that a later version's first new
/// field fills, and those bytes must not be read from a struct of that version.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Layout {
    pub(crate) size: usize,
    pub(crate) fields: usize,
}

impl Layout {
    /// A layout whose fields fill its `sizeof`.
    pub(crate) const fn whole(size: usize) -> Self {
        Self { size, fields: size }
    }
}

/// Reads a size-prefixed struct whose current layout is `T` and whose earlier layouts are
/// `older` (oldest first): `size` must be at least the oldest one's (`T`'s without any); a
/// struct of an earlier layout is read up to the end of that layout's fields (a size between two
/// layouts as the smaller), the rest taken from `defaults`; a larger one (a later version) up to
/// `T`'s end.
///
/// # Safety
/// `ptr` must be non-NULL, aligned, and point to at least `*ptr.size` readable bytes.
pub(crate) unsafe fn read_sized<T: Copy>(ptr: *const T, older: &[Layout], defaults: T, s: &Sized) -> Result<T, Failure> {
    // SAFETY: the caller's contract; `size` is the first field of every such struct.
    let size = unsafe { ptr.cast::<u32>().read() } as usize;
    let ours = size_of::<T>();
    let min = older.first().map_or(ours, |l| l.size);
    if size < min {
        return Err(Failure::invalid(format!(
            "{}->size = {size}, expected sizeof({}) = {ours} (fill the struct with {})",
            s.what, s.type_name, s.filler
        )));
    }
    let mut value = defaults;
    let known = if size >= ours { ours } else { older.iter().rev().find(|l| l.size <= size).map_or(size, |l| l.fields) };
    // SAFETY: `known` bytes are readable (≤ size) and writable in `value` (≤ size_of::<T>); a
    // byte copy of a prefix of a plain `repr(C)` struct whose later fields keep their defaults.
    unsafe { std::ptr::copy_nonoverlapping(ptr.cast::<u8>(), std::ptr::from_mut(&mut value).cast::<u8>(), known) };
    Ok(value)
}

/// Writes the first `min(size, size_of::<T>())` bytes of `defaults` over `*out` with its leading
/// `size` field set to that count; `size` must be at least `min`.
///
/// # Safety
/// A non-NULL `out` must have `size` writable bytes; `T` starts with a `u32` size.
pub(crate) unsafe fn init<T>(out: *mut T, size: usize, min: usize, mut defaults: T) -> Result<(), Failure> {
    check_not_null!(out);
    if size < min {
        return Err(Failure::invalid(format!("size = {size}: the struct has at least {min} bytes (pass its sizeof)")));
    }
    let written = size.min(size_of::<T>());
    // SAFETY: `T` starts with its `u32` size (every options struct does); `written` fits a u32.
    unsafe { std::ptr::from_mut(&mut defaults).cast::<u32>().write(written as u32) };
    // SAFETY: `written` ≤ size writable bytes (caller's contract) and ≤ size_of::<T>().
    unsafe { ptr::write_prefix(out, &defaults, written) };
    Ok(())
}

/// The chosen method's struct at `ptr` as [`read_sized`] reads it, `defaults` for NULL.
///
/// # Safety
/// A non-NULL `ptr` must point to at least `ptr->size` readable bytes.
unsafe fn method_options<T: Copy>(
    ptr: *const c_void,
    older: &[Layout],
    defaults: T,
    type_name: &'static str,
    filler: &'static str,
) -> Result<T, Failure> {
    if ptr.is_null() {
        return Ok(defaults);
    }
    let p = ptr.cast::<T>();
    if !p.is_aligned() {
        return Err(Failure::invalid(format!("`options->method_options` is not aligned for {type_name}")));
    }
    // SAFETY: the caller's contract, checked for NULL and alignment.
    unsafe { read_sized(p, older, defaults, &Sized { what: "options->method_options", type_name, filler }) }
}

/// The caller's options (NULL = defaults), checked and converted.
///
/// # Safety
/// A non-NULL `options` must point to at least `options->size` readable bytes, and a non-NULL
/// `method_options` to the chosen method's struct of at least its `size` bytes.
pub(crate) unsafe fn read_bake_options(options: *const TcBakeOptions) -> Result<BakeOptions, Failure> {
    let o = if options.is_null() {
        default_bake_options()
    } else {
        check_not_null!(options);
        let mut defaults = default_bake_options();
        defaults.method_options = std::ptr::null();
        let sized = Sized { what: "options", type_name: "TcBakeOptions", filler: "tc_bake_options_init" };
        // SAFETY: forwarded.
        unsafe { read_sized(options, &[Layout::whole(BAKE_OPTIONS_SIZE_V1)], defaults, &sized)? }
    };
    let source = SourceOptions {
        area_samples: o.area_samples as usize,
        environment_samples: o.environment_samples as usize,
        ..SourceOptions::default()
    };
    // The TransCut bake of TC_METHOD_TRANSCUT's objects and of radiosity's translucent ones
    // (the dipole reads none of these fields).
    let transcut = || -> Result<TransCutOptions, Failure> {
        Ok(TransCutOptions {
            tets: usize::try_from(o.tets).map_err(|_| Failure::invalid(format!("options->tets = {} is too large", o.tets)))?,
            tolerance: o.tolerance,
            max_iterations: o.max_iterations as usize,
            backend: backend_from(o.backend, "options->backend")?,
            ..TransCutOptions::default()
        })
    };
    let method = match o.method {
        TC_METHOD_TRANSCUT => {
            // SAFETY: the caller's contract.
            let t = unsafe {
                method_options(
                    o.method_options,
                    &[Layout::whole(TRANSCUT_OPTIONS_SIZE_V1)],
                    default_transcut_options(),
                    "TcTransCutOptions",
                    "tc_transcut_options_init",
                )?
            };
            let d = TransCutOptions::default();
            let solver = solver_from(t.solver, "options->method_options->solver")?.unwrap_or(d.solver);
            let edit_solver = solver_from(t.edit_solver, "options->method_options->edit_solver")?.unwrap_or(d.edit_solver);
            let grading = grading_from(t.grading)?;
            let discretization = discretization_from(t.discretization)?;
            Method::TransCut(TransCutOptions { solver, edit_solver, grading, discretization, ..transcut()? })
        }
        TC_METHOD_RADIOSITY => {
            // SAFETY: the caller's contract.
            let r = unsafe {
                method_options(
                    o.method_options,
                    &[Layout::whole(RADIOSITY_OPTIONS_SIZE_V1)],
                    default_radiosity_options(),
                    "TcRadiosityOptions",
                    "tc_radiosity_options_init",
                )?
            };
            Method::Radiosity(radiosity_options(&r, transcut()?)?)
        }
        TC_METHOD_HIERARCHICAL_DIPOLE => {
            // SAFETY: the caller's contract.
            let d = unsafe {
                method_options(o.method_options, &[], default_dipole_options(), "TcDipoleOptions", "tc_dipole_options_init")?
            };
            Method::HierarchicalDipole(dipole_options(&d)?)
        }
        TC_METHOD_PRT => {
            // SAFETY: the caller's contract.
            let p =
                unsafe { method_options(o.method_options, &[], default_prt_options(), "TcPrtOptions", "tc_prt_options_init")? };
            Method::Prt(prt_options(&p)?)
        }
        TC_METHOD_POLYGRID => {
            // SAFETY: the caller's contract.
            let p = unsafe {
                method_options(
                    o.method_options,
                    &[],
                    default_polygrid_options(),
                    "TcPolygridOptions",
                    "tc_polygrid_options_init",
                )?
            };
            Method::Polygrid(polygrid_options(&p, transcut()?)?)
        }
        other => {
            return Err(Failure::invalid(format!(
                "options->method = {other}: unknown method (the methods are {})",
                Method::NAMES.iter().enumerate().map(|(i, n)| format!("{i} = {n}")).collect::<Vec<_>>().join(", ")
            )))
        }
    };
    let bounded = [
        ("threads", u64::from(o.threads), u64::from(TC_MAX_THREADS)),
        ("area_samples", u64::from(o.area_samples), u64::from(TC_MAX_SAMPLES)),
        ("environment_samples", u64::from(o.environment_samples), u64::from(TC_MAX_SAMPLES)),
        ("tets", o.tets, TC_MAX_TETS),
        ("max_iterations", u64::from(o.max_iterations), u64::from(TC_MAX_ITERATIONS)),
    ];
    if let Some((field, value, max)) = bounded.iter().find(|(_, value, max)| value > max) {
        return Err(Failure::invalid(format!("options->{field} = {value} is above the maximum of {max}")));
    }
    Ok(BakeOptions { method, threads: o.threads as usize, shadows: o.shadows != 0, source })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A struct of two versions: the first ended with `c` and 4 bytes of padding, which the
    /// second's `d` fills (before its `e`).
    #[repr(C)]
    #[derive(Debug, Clone, Copy, PartialEq)]
    struct Two {
        size: u32,
        a: u32,
        b: f64,
        c: u32,
        d: u32,
        e: u32,
    }

    const TWO_V1: Layout = Layout { size: 24, fields: std::mem::offset_of!(Two, d) };

    /// `read_sized` on a caller's struct of `size` bytes whose every byte past `size` and whose
    /// padding hold garbage (0xAB).
    fn read_two(size: u32) -> Result<Two, Failure> {
        let defaults = Two { size: 0, a: 1, b: 2.0, c: 3, d: 4, e: 5 };
        // 64 aligned bytes of garbage, the caller's first `size` bytes over them.
        let mut buffer = [0xABAB_ABAB_ABAB_ABABu64; 8];
        let given = Two { size, a: 10, b: 20.0, c: 30, d: 40, e: 50 };
        let bytes = size_of::<Two>().min(size as usize);
        // SAFETY: `bytes` ≤ 32 of both; a plain repr(C) struct's bytes.
        unsafe {
            std::ptr::copy_nonoverlapping(std::ptr::from_ref(&given).cast::<u8>(), buffer.as_mut_ptr().cast::<u8>(), bytes)
        };
        let sized = Sized { what: "options", type_name: "Two", filler: "two_init" };
        // SAFETY: 64 readable, aligned bytes, at least `size` of them for every size tested.
        unsafe { read_sized(buffer.as_ptr().cast::<Two>(), &[TWO_V1], defaults, &sized) }
    }

    #[test]
    fn a_struct_of_an_earlier_layout_is_read_to_the_end_of_its_fields() {
        assert_eq!(size_of::<Two>(), 32);
        // The first version: `d` lies in its padding, so what is there (here a 40) is not read.
        assert_eq!(read_two(24).unwrap(), Two { size: 24, a: 10, b: 20.0, c: 30, d: 4, e: 5 });
        // Between the two versions: read as the first.
        assert_eq!(read_two(28).unwrap(), Two { size: 28, a: 10, b: 20.0, c: 30, d: 4, e: 5 });
        // The current version, and a later one (its extra bytes are not ours).
        assert_eq!(read_two(32).unwrap(), Two { size: 32, a: 10, b: 20.0, c: 30, d: 40, e: 50 });
        assert_eq!(read_two(48).unwrap(), Two { size: 48, a: 10, b: 20.0, c: 30, d: 40, e: 50 });
        // Below the first version: named, with the filler.
        let e = read_two(20).unwrap_err();
        assert!(e.message.contains("options->size = 20") && e.message.contains("two_init"), "{}", e.message);
    }

    /// The dipole's defaults are the core's, every choice maps to its core value, and a value out
    /// of range is named.
    #[test]
    fn dipole_options_map_onto_the_cores() {
        assert_eq!(dipole_options(&default_dipole_options()).unwrap(), DipoleOptions::default());
        let o = TcDipoleOptions {
            oracle: TC_DIPOLE_ORACLE_PAPER,
            eps1: 0.02,
            rule: TC_DIPOLE_RULE_PAPER,
            receivers: TC_DIPOLE_RECEIVERS_FACES,
            mode: TC_DIPOLE_MODE_INCREMENTAL,
            budget: 5000,
            geometry: TC_DIPOLE_GEOMETRY_PAPER,
            radiance: TC_DIPOLE_RADIANCE_JENSEN,
            ..default_dipole_options()
        };
        let core = dipole_options(&o).unwrap();
        assert_eq!(core.oracle, Oracle::Paper { eps1: 0.02, eps2: 0.05 });
        assert_eq!(core.rule, EdgeRule::PAPER);
        assert_eq!(core.receivers, Receivers::FaceCentroids);
        assert_eq!(core.mode, EvalMode::Incremental { budget: Some(5000) });
        assert_eq!(core.geometry, DipoleGeometry::PaperSources);
        assert_eq!(core.radiance, DipoleRadiance::Jensen2001);
        let bad = |o: TcDipoleOptions| dipole_options(&o).unwrap_err().message;
        assert!(bad(TcDipoleOptions { mode: 3, ..default_dipole_options() }).contains("mode = 3"));
        assert!(bad(TcDipoleOptions { oracle: 9, ..default_dipole_options() }).contains("oracle = 9"));
        assert!(bad(TcDipoleOptions { theta: f64::NAN, ..default_dipole_options() }).contains("theta"));
    }

    /// The core's method of bake options with `method` and its own struct `options` (filled by
    /// its init, so of the size it states).
    fn read_method<T>(method: u32, options: &T) -> Result<Method, Failure> {
        let o = TcBakeOptions { method, method_options: std::ptr::from_ref(options).cast(), ..default_bake_options() };
        // SAFETY: valid pointers to structs of the sizes they state.
        unsafe { read_bake_options(&o) }.map(|b| b.method)
    }

    /// TransCut's grading and discretisation: the init defaults are the core's (automatic), 0 is
    /// uniform, N cubes per size is graded, `TC_GRADING_AUTO` is automatic, anything else is named, and a first-version struct
    /// (12 bytes) leaves the grading field unread (the core's default); each discretisation
    /// maps onto the core's, another value is named.
    #[test]
    fn transcut_grading_maps_onto_the_cores() {
        let method = |t: &TcTransCutOptions| read_method(TC_METHOD_TRANSCUT, t);
        let grading = |t: &TcTransCutOptions| match method(t).unwrap() {
            Method::TransCut(o) => o.grading,
            other => panic!("{other:?}"),
        };
        let core = TransCutOptions::default();
        assert_eq!(grading(&default_transcut_options()), core.grading);
        assert_eq!(grading(&TcTransCutOptions { grading: 0, ..default_transcut_options() }), Grading::Uniform.into());
        assert_eq!(grading(&TcTransCutOptions { grading: TC_GRADING_AUTO, ..default_transcut_options() }), GradingChoice::Auto);
        assert_eq!(
            grading(&TcTransCutOptions { grading: 3, ..default_transcut_options() }),
            Grading::Graded { layers: 3 }.into()
        );
        let older = TcTransCutOptions { size: TRANSCUT_OPTIONS_SIZE_V1 as u32, grading: 3, ..default_transcut_options() };
        assert_eq!(grading(&older), core.grading);
        match method(&default_transcut_options()).unwrap() {
            Method::TransCut(o) => assert_eq!(o.discretization, core.discretization),
            other => panic!("{other:?}"),
        }
        let e = method(&TcTransCutOptions { grading: TC_MAX_GRADING_LAYERS + 1, ..default_transcut_options() }).unwrap_err();
        assert!(e.message.contains("grading = 65"), "{}", e.message);
        let e = method(&TcTransCutOptions { grading: TC_GRADING_AUTO - 1, ..default_transcut_options() }).unwrap_err();
        assert!(e.message.contains("grading = 4294967294") && e.message.contains("TC_GRADING_AUTO"), "{}", e.message);
        let discretization = |d: u32| match method(&TcTransCutOptions { discretization: d, ..default_transcut_options() }) {
            Ok(Method::TransCut(o)) => Ok(o.discretization),
            Ok(other) => panic!("{other:?}"),
            Err(e) => Err(e.message),
        };
        assert_eq!(discretization(TC_DISCRETIZATION_TRANSCUT), Ok(Discretization::TransCut));
        assert_eq!(discretization(TC_DISCRETIZATION_FITTED), Ok(Discretization::ExponentiallyFitted));
        assert_eq!(discretization(TC_DISCRETIZATION_CONSISTENT_FEM), Ok(Discretization::ConsistentFem));
        assert_eq!(discretization(TC_DISCRETIZATION_FITTED_LAYER), Ok(Discretization::FittedLayer));
        assert!(discretization(4).unwrap_err().contains("discretization = 4"));
    }

    /// Radiosity's translucent objects take the grading and discretisation of its own struct:
    /// the init defaults are the core's, values map onto the core's, a value out of range is
    /// named, and a first-version struct (56 bytes) leaves both fields unread.
    #[test]
    fn radiosity_grading_and_discretization_map_onto_the_cores() {
        let translucent = |r: &TcRadiosityOptions| match read_method(TC_METHOD_RADIOSITY, r) {
            Ok(Method::Radiosity(o)) => Ok((o.transcut.grading, o.transcut.discretization)),
            Ok(other) => panic!("{other:?}"),
            Err(e) => Err(e.message),
        };
        let core = TransCutOptions::default();
        assert_eq!(translucent(&default_radiosity_options()), Ok((core.grading, core.discretization)));
        let set = TcRadiosityOptions { grading: 2, discretization: TC_DISCRETIZATION_TRANSCUT, ..default_radiosity_options() };
        assert_eq!(translucent(&set), Ok((Grading::Graded { layers: 2 }.into(), Discretization::TransCut)));
        let consistent = TcRadiosityOptions { discretization: TC_DISCRETIZATION_CONSISTENT_FEM, ..default_radiosity_options() };
        assert_eq!(translucent(&consistent).unwrap().1, Discretization::ConsistentFem);
        let older = TcRadiosityOptions { size: RADIOSITY_OPTIONS_SIZE_V1 as u32, ..set };
        assert_eq!(translucent(&older), Ok((core.grading, core.discretization)));
        let too_many = TcRadiosityOptions { grading: TC_MAX_GRADING_LAYERS + 1, ..default_radiosity_options() };
        assert!(translucent(&too_many).unwrap_err().contains("grading = 65"));
        let unknown = TcRadiosityOptions { discretization: 7, ..default_radiosity_options() };
        assert!(translucent(&unknown).unwrap_err().contains("discretization = 7"));
        assert_eq!(RADIOSITY_OPTIONS_SIZE_V1, std::mem::offset_of!(TcRadiosityOptions, grading));
    }

    /// Radiosity's defaults are the core's (with the translucent objects' bake as given), every
    /// field maps to its core value, and a value out of range is named.
    #[test]
    fn radiosity_options_map_onto_the_cores() {
        let transcut = TransCutOptions { tets: 5_000, tolerance: 1e-8, ..TransCutOptions::default() };
        let core = radiosity_options(&default_radiosity_options(), transcut.clone()).unwrap();
        assert_eq!(core, RadiosityOptions { transcut: transcut.clone(), ..RadiosityOptions::default() });
        let o = TcRadiosityOptions {
            iteration: TC_RADIOSITY_GAUSS_SEIDEL,
            patch_size_mm: 3.0,
            rays_per_patch: 64,
            max_iterations: 50,
            seed: 7,
            tolerance: 1e-5,
            covered_fraction: 0.2,
            solver: TC_SOLVER_PCG,
            ..default_radiosity_options()
        };
        let core = radiosity_options(&o, transcut.clone()).unwrap();
        assert_eq!(core.patch_size_mm, Some(3.0));
        assert_eq!(core.form_factors, FormFactorOptions { rays_per_patch: 64, seed: 7, covered_fraction: 0.2 });
        let solve = SolveOptions { iteration: Iteration::GaussSeidel, tolerance: 1e-5, max_iterations: 50, bounces: None };
        assert_eq!(core.solve, solve);
        assert_eq!(core.transcut, TransCutOptions { solver: SolverKind::Pcg, ..transcut.clone() });
        let three = TcRadiosityOptions { bounces: 3, ..default_radiosity_options() };
        assert_eq!(radiosity_options(&three, transcut.clone()).unwrap().solve.bounces, Some(3));
        let bad = |o: TcRadiosityOptions| radiosity_options(&o, TransCutOptions::default()).unwrap_err().message;
        let d = default_radiosity_options;
        assert!(bad(TcRadiosityOptions { iteration: 3, ..d() }).contains("iteration = 3"));
        let krylov = TcRadiosityOptions { iteration: TC_RADIOSITY_BICGSTAB, ..d() };
        assert_eq!(radiosity_options(&krylov, transcut.clone()).unwrap().solve.iteration, Iteration::BiCgStab);
        assert!(bad(TcRadiosityOptions { bounces: 2, ..krylov }).contains("needs TC_RADIOSITY_JACOBI"));
        assert!(bad(TcRadiosityOptions { patch_size_mm: f64::INFINITY, ..d() }).contains("patch_size_mm = inf"));
        assert!(bad(TcRadiosityOptions { tolerance: 0.0, ..d() }).contains("tolerance = 0"));
        assert!(bad(TcRadiosityOptions { max_iterations: 10_001, ..d() }).contains("max_iterations = 10001"));
        assert!(bad(TcRadiosityOptions { covered_fraction: 1.5, ..d() }).contains("covered_fraction = 1.5"));
    }

    /// The polygrid's defaults are the core's (with the solves as given), every field maps to
    /// its core value, and a value out of range is named.
    #[test]
    fn polygrid_options_map_onto_the_cores() {
        let transcut =
            TransCutOptions { tolerance: 1e-8, max_iterations: 500, backend: Some(Backend::Cpu), ..TransCutOptions::default() };
        let core = polygrid_options(&default_polygrid_options(), transcut.clone()).unwrap();
        assert_eq!(core, PolygridOptions { solve: transcut.clone(), ..PolygridOptions::default() });
        let no_tets = TransCutOptions { tets: 0, ..transcut.clone() };
        assert_eq!(polygrid_options(&default_polygrid_options(), no_tets).unwrap(), core, "TcBakeOptions.tets is not read");
        let o = TcPolygridOptions {
            resolution: 12,
            nodes: 30_000,
            cube_mm: 2.5,
            stencil: TC_POLYGRID_STENCIL_FINITE_VOLUME,
            solver: TC_SOLVER_PCG,
            edit_solver: TC_SOLVER_MG_PCG,
            ..default_polygrid_options()
        };
        let core = polygrid_options(&o, transcut.clone()).unwrap();
        let solve = TransCutOptions { solver: SolverKind::Pcg, edit_solver: SolverKind::MultigridPcg, ..transcut.clone() };
        assert_eq!(
            core,
            PolygridOptions { nodes: 30_000, cube_mm: Some(2.5), resolution: 12, stencil: Stencil::FiniteVolume, solve }
        );
        let bad = |o: TcPolygridOptions| polygrid_options(&o, TransCutOptions::default()).unwrap_err().message;
        let d = default_polygrid_options;
        assert!(bad(TcPolygridOptions { resolution: 0, ..d() }).contains("method_options->resolution = 0"));
        assert!(bad(TcPolygridOptions { resolution: 257, ..d() }).contains("resolution = 257: must be in 1..=256"));
        assert!(bad(TcPolygridOptions { nodes: 7, ..d() }).contains("nodes = 7"));
        assert!(bad(TcPolygridOptions { nodes: 4_000_001, ..d() }).contains("nodes = 4000001"));
        assert!(bad(TcPolygridOptions { cube_mm: f64::NAN, ..d() }).contains("cube_mm = NaN"));
        assert!(bad(TcPolygridOptions { cube_mm: -1.0, ..d() }).contains("cube_mm = -1"));
        assert!(bad(TcPolygridOptions { stencil: 3, ..d() }).contains("stencil = 3: unknown stencil"));
        let paper = TcPolygridOptions { stencil: TC_POLYGRID_STENCIL_PAPER_LSQ, ..d() };
        assert_eq!(polygrid_options(&paper, TransCutOptions::default()).unwrap().stencil, Stencil::PaperLsq);
        assert!(bad(TcPolygridOptions { solver: 9, ..d() }).contains("solver = 9"));
        let tolerance = TransCutOptions { tolerance: 2.0, ..TransCutOptions::default() };
        assert!(polygrid_options(&d(), tolerance).unwrap_err().message.contains("tolerance"));
    }

    /// The header's bounds are the core's.
    #[test]
    fn bounds_are_the_cores() {
        assert_eq!(TC_MAX_THREADS as usize, transcut_core::workers::MAX_THREADS);
        assert_eq!(TC_MAX_SAMPLES as usize, SourceOptions::MAX_SAMPLES);
        assert_eq!(TC_MAX_TETS as usize, TransCutOptions::MAX_TETS);
        assert_eq!(TC_MAX_ITERATIONS as usize, TransCutOptions::MAX_ITERATIONS);
        assert_eq!(TC_MAX_RADIOSITY_ITERATIONS as usize, SolveOptions::MAX_ITERATIONS);
        let over = FormFactorOptions { rays_per_patch: TC_MAX_RAYS_PER_PATCH as usize + 1, ..FormFactorOptions::default() };
        assert!(over.validate().is_err());
        let at = FormFactorOptions { rays_per_patch: TC_MAX_RAYS_PER_PATCH as usize, ..FormFactorOptions::default() };
        assert_eq!(at.validate(), Ok(()));
        assert_eq!(Method::NAMES[TC_METHOD_RADIOSITY as usize], "radiosity");
        assert_eq!(Method::NAMES[TC_METHOD_PRT as usize], "prt");
        assert_eq!(Method::NAMES[TC_METHOD_POLYGRID as usize], "polygrid");
        assert_eq!(TC_MAX_POLYGRID_NODES as usize, PolygridOptions::MAX_NODES);
        assert_eq!(TC_MAX_POLYGRID_RESOLUTION, transcut_core::polygrid::MAX_RESOLUTION);
    }
}
