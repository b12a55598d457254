"""The C ABI of ``include/transcut.h`` as ctypes declarations: constants, structs, prototypes.

Only declarations, no behaviour: the values and layouts mirror the header one for one
(``tests/blender/test_native_header.py`` compares them with it), and :mod:`.scene` binds the
prototypes to a loaded library. ``TcStatus`` is a transparent ``int32_t``.
"""

from __future__ import annotations

from ctypes import (
    CFUNCTYPE,
    POINTER,
    Structure,
    c_char_p,
    c_double,
    c_float,
    c_int32,
    c_size_t,
    c_uint8,
    c_uint32,
    c_uint64,
    c_void_p,
)

#: The ABI major version this binding mirrors: it loads a library whose ``tc_version() >> 16`` is this.
ABI_MAJOR = 0

# Status codes (values fixed by the C ABI; only ever appended).
TC_OK = 0
TC_NULL_POINTER = 1
TC_INVALID_ARGUMENT = 2
TC_INVALID_HANDLE = 3
TC_BUFFER_TOO_SHORT = 4
TC_INVALID_MESH = 5
TC_MESHING_FAILED = 6
TC_SOLVE_FAILED = 7
TC_NOT_FOUND = 8
TC_IO_ERROR = 9
TC_CANCELLED = 10
TC_NOT_BAKED = 11
TC_INTERNAL_ERROR = 12
TC_BUSY = 13
TC_GPU_UNAVAILABLE = 14
TC_NOTHING_LEFT = 15
TC_UNSUPPORTED = 16
TC_UNRESOLVED = 17

STATUS_NAMES = {
    TC_OK: "TC_OK",
    TC_NULL_POINTER: "TC_NULL_POINTER",
    TC_INVALID_ARGUMENT: "TC_INVALID_ARGUMENT",
    TC_INVALID_HANDLE: "TC_INVALID_HANDLE",
    TC_BUFFER_TOO_SHORT: "TC_BUFFER_TOO_SHORT",
    TC_INVALID_MESH: "TC_INVALID_MESH",
    TC_MESHING_FAILED: "TC_MESHING_FAILED",
    TC_SOLVE_FAILED: "TC_SOLVE_FAILED",
    TC_NOT_FOUND: "TC_NOT_FOUND",
    TC_IO_ERROR: "TC_IO_ERROR",
    TC_CANCELLED: "TC_CANCELLED",
    TC_NOT_BAKED: "TC_NOT_BAKED",
    TC_INTERNAL_ERROR: "TC_INTERNAL_ERROR",
    TC_BUSY: "TC_BUSY",
    TC_GPU_UNAVAILABLE: "TC_GPU_UNAVAILABLE",
    TC_NOTHING_LEFT: "TC_NOTHING_LEFT",
    TC_UNSUPPORTED: "TC_UNSUPPORTED",
    TC_UNRESOLVED: "TC_UNRESOLVED",
}

# TcBakeOptions.method: the subsurface method (tc_method_count, tc_method_name list them; new
# ones are appended).
TC_METHOD_TRANSCUT = 0
TC_METHOD_HIERARCHICAL_DIPOLE = 1  # homogeneous media only; relight and tc_object_set_positions
TC_METHOD_RADIOSITY = 2  # translucent radiosity: translucent and diffuse objects lighting each other
TC_METHOD_PRT = 3  # precomputed translucent transfer: homogeneous media, edits and relights without a new precompute
TC_METHOD_POLYGRID = 4  # polygrid diffusion: the diffusion equation on a polycube grid; relight and edits (FEM)

# TcPolygridOptions.stencil: the discretisation on the grid.
TC_POLYGRID_STENCIL_FEM = 0  # P1 on the cells' tets, TransCut's assembly (default; the session edits)
TC_POLYGRID_STENCIL_FINITE_VOLUME = 1  # two-point fluxes, exactly conservative; no edits after the bake
TC_POLYGRID_STENCIL_PAPER_LSQ = 2  # the paper's App. B weights, for comparison; no edits after the bake
TC_MAX_POLYGRID_NODES = 4_000_000  # TcPolygridOptions.nodes at most
TC_MAX_POLYGRID_RESOLUTION = 256  # TcPolygridOptions.resolution (cells per cube edge) at most

#: ``polygrid_stencil`` names accepted by :meth:`Scene.bake` (besides the integer values; the
#: CLI's names, any case).
POLYGRID_STENCILS = {
    "fem": TC_POLYGRID_STENCIL_FEM,
    "finite-volume": TC_POLYGRID_STENCIL_FINITE_VOLUME,
    "paper-lsq": TC_POLYGRID_STENCIL_PAPER_LSQ,
}

# TcAcquireOptions (tc_acquire: a heterogeneous medium measured from images of a lit block).
TC_ACQUIRE_BACK_LIT = 0  # observe: the face opposite the lit one (default)
TC_ACQUIRE_FRONT_LIT = 1  # observe: the lit face, lit pixels masked with a margin
TC_ACQUIRE_LBFGS = 0  # method: L-BFGS on log-parameters (default)
TC_ACQUIRE_PAPER_CG = 1  # method: the paper's Polak–Ribière CG with golden-section search
TC_ACQUIRE_RGB = 0  # channels: each fitted (default)
TC_ACQUIRE_GREY = 1  # channels: the first fitted, copied to the others
TC_MAX_ACQUIRE_NODES = 4_000_000  # TcAcquireOptions.nodes' product at most

# TcPrtOptions.basis_terms: the PCA basis of the dipole profile.
TC_PRT_BASIS_16 = 16  # default
TC_PRT_BASIS_12 = 12  # the paper's

# TcBakeOptions.backend: where the diffusion solve runs; TcBakeStats.backend_used: 1 or 2.
TC_BACKEND_DEFAULT = 0  # TRANSCUT_BACKEND (cpu, gpu, auto), else auto
TC_BACKEND_CPU = 1
TC_BACKEND_GPU = 2  # TC_GPU_UNAVAILABLE when no adapter can be used
TC_BACKEND_AUTO = 3  # a hardware GPU if there is one, else the CPU (tc_object_backend_fallback says why)

#: ``backend`` option names accepted by :meth:`Scene.bake` (besides the integer values).
BACKENDS = {"default": TC_BACKEND_DEFAULT, "cpu": TC_BACKEND_CPU, "gpu": TC_BACKEND_GPU, "auto": TC_BACKEND_AUTO}

# TcTransCutOptions.solver and .edit_solver.
TC_SOLVER_DEFAULT = 0  # SSOR-PCG for the bake, the smoothed-aggregation V-cycle for edits
TC_SOLVER_PCG = 1  # Jacobi-preconditioned CG (mixed precision)
TC_SOLVER_SSOR_PCG = 2
TC_SOLVER_CASCADE = 3  # TransCut §4.2's coarse-to-fine cascade (CPU only)
TC_SOLVER_MG_PCG = 4  # CG preconditioned by a V-cycle on TransCut's §4.1 hierarchy
TC_SOLVER_SA_PCG = 5  # CG preconditioned by a smoothed-aggregation V-cycle

# TcTransCutOptions.discretization.
TC_DISCRETIZATION_TRANSCUT = 0  # TransCut eqs. 10-14
TC_DISCRETIZATION_FITTED = 1  # each edge's stiffness exponentially fitted to the boundary layer
TC_DISCRETIZATION_CONSISTENT_FEM = 2  # the consistent P1 reference
TC_DISCRETIZATION_FITTED_LAYER = 3  # fitted, boundary rows' absorption from the layer (default)

# TcDipoleOptions (the hierarchical dipole's options; tc_dipole_options_init gives the defaults,
# the first of each pair).
TC_DIPOLE_ORACLE_OPENING_ANGLE = 0  # link when the clusters' radii sum below theta × their distance
TC_DIPOLE_ORACLE_PAPER = 1  # Mertens et al.'s solid-angle oracle with eps1, eps2
TC_DIPOLE_RULE_GAUSS_LEGENDRE = 0  # the near field's edge integral, 3-point Gauss–Legendre
TC_DIPOLE_RULE_PAPER = 1  # the paper's midpoint rule
TC_DIPOLE_RECEIVERS_VERTICES = 0  # radiance at the vertices
TC_DIPOLE_RECEIVERS_FACES = 1  # at the triangles' centroids, averaged onto the vertices
TC_DIPOLE_MODE_ON_THE_FLY = 0  # every update traverses the trees afresh, no links stored
TC_DIPOLE_MODE_RENDER = 1  # links kept while the geometry stays
TC_DIPOLE_MODE_INCREMENTAL = 2  # links kept, relinked after a deformation where it moved
TC_DIPOLE_GEOMETRY_DISTANCE = 0  # Rd of the distance between the points
TC_DIPOLE_GEOMETRY_PAPER = 1  # the paper's sources on the receiver's normal
TC_DIPOLE_RADIANCE_TRANSCUT = 0  # Lo = Ft B/(π(1 − Fdr)), what TransCut returns
TC_DIPOLE_RADIANCE_JENSEN = 1  # Lo = T B/π (Jensen et al. 2001)

# TcRadiosityOptions.iteration (tc_radiosity_options_init gives Jacobi).
TC_RADIOSITY_JACOBI = 0  # every patch from the last sweep (the paper's)
TC_RADIOSITY_GAUSS_SEIDEL = 1  # opaque patches from the values already updated in the sweep
TC_RADIOSITY_BICGSTAB = 2  # BiCGSTAB on the coupled system, stopped by a bound on the error
TC_MAX_RAYS_PER_PATCH = 1 << 24  # TcRadiosityOptions.rays_per_patch at most
TC_MAX_RADIOSITY_ITERATIONS = 10_000  # TcRadiosityOptions.max_iterations and bounces at most

# tc_object_set_sides: which sides of a diffuse object reflect and emit.
TC_ARTIST_RANDOM_WALK = 0  # Cycles' Random Walk: radius/4π, index-matched (the default)
TC_ARTIST_RANDOM_WALK_SKIN = 1  # Cycles' Random Walk (Skin): the radius as a diffusion length
TC_ARTIST_DIPOLE = 2  # the classical dipole's inversion at the IOR
TC_SIDES_BOTH = 0  # each side with its own radiosity (the default)
TC_SIDES_FRONT = 1  # the outside of a closed surface
TC_SIDES_BACK = 2  # the inside of a closed surface (a room seen from within)

# tc_object_material: what an object is made of.
TC_MATERIAL_TRANSLUCENT = 0  # a medium under its surface (every method)
TC_MATERIAL_DIFFUSE = 1  # an opaque diffuse surface (tc_scene_add_diffuse_mesh; TC_METHOD_RADIOSITY)

#: The names :meth:`Scene.bake` accepts for the hierarchical dipole's options (besides the
#: integer values; the CLI's names, any case), per ``TcDipoleOptions`` field.
DIPOLE_CHOICES = {
    "oracle": {"opening-angle": TC_DIPOLE_ORACLE_OPENING_ANGLE, "paper": TC_DIPOLE_ORACLE_PAPER},
    "rule": {
        "gl3": TC_DIPOLE_RULE_GAUSS_LEGENDRE,
        "gauss-legendre": TC_DIPOLE_RULE_GAUSS_LEGENDRE,
        "paper": TC_DIPOLE_RULE_PAPER,
    },
    "receivers": {"vertices": TC_DIPOLE_RECEIVERS_VERTICES, "faces": TC_DIPOLE_RECEIVERS_FACES},
    "mode": {
        "on-the-fly": TC_DIPOLE_MODE_ON_THE_FLY,
        "render": TC_DIPOLE_MODE_RENDER,
        "incremental": TC_DIPOLE_MODE_INCREMENTAL,
    },
    "geometry": {"distance": TC_DIPOLE_GEOMETRY_DISTANCE, "paper": TC_DIPOLE_GEOMETRY_PAPER},
    "radiance": {"transcut": TC_DIPOLE_RADIANCE_TRANSCUT, "jensen": TC_DIPOLE_RADIANCE_JENSEN},
}

#: The names :meth:`Scene.bake` accepts for translucent radiosity's ``iteration`` (besides the
#: ``TC_RADIOSITY_*`` values; the CLI's ``--iteration`` names, any case).
RADIOSITY_ITERATIONS = {
    "jacobi": TC_RADIOSITY_JACOBI,
    "gauss-seidel": TC_RADIOSITY_GAUSS_SEIDEL,
    "bicgstab": TC_RADIOSITY_BICGSTAB,
}

#: The names :meth:`Scene.add_diffuse_mesh` and :meth:`Scene.set_sides` accept (besides the
#: ``TC_SIDES_*`` values; the scene file's ``sides`` names, any case).
SIDES = {"both": TC_SIDES_BOTH, "front": TC_SIDES_FRONT, "back": TC_SIDES_BACK}
#: ``TcArtistMedium.mapping`` by name (the command line's and scene files' names).
ARTIST_MAPPINGS = {
    "random-walk": TC_ARTIST_RANDOM_WALK,
    "random-walk-skin": TC_ARTIST_RANDOM_WALK_SKIN,
    "dipole": TC_ARTIST_DIPOLE,
}

#: What :meth:`Scene.material` returns for each ``TC_MATERIAL_*`` value.
MATERIAL_NAMES = {TC_MATERIAL_TRANSLUCENT: "translucent", TC_MATERIAL_DIFFUSE: "diffuse"}

# Upper bounds of TcBakeOptions (TC_INVALID_ARGUMENT above them).
TC_MAX_THREADS = 256
TC_MAX_SAMPLES = 1 << 20  # area_samples and environment_samples
TC_MAX_TETS = 20_000_000
#: The most cubes of one size ``TcTransCutOptions.grading`` may ask for.
TC_MAX_GRADING_LAYERS = 64
#: ``TcTransCutOptions.grading``: chosen per object from its medium and the tet budget.
TC_GRADING_AUTO = 0xFFFF_FFFF
TC_MAX_TEXTURE_SIZE = 16_384  # the largest width or height of tc_object_bake_texture
TC_MAX_ITERATIONS = 1_000_000

#: ``solver`` / ``edit_solver`` names accepted by :meth:`Scene.bake` (the CLI's ``--solver`` names).
SOLVERS = {
    "default": TC_SOLVER_DEFAULT,
    "pcg": TC_SOLVER_PCG,
    "ssor-pcg": TC_SOLVER_SSOR_PCG,
    "cascade": TC_SOLVER_CASCADE,
    "mg-pcg": TC_SOLVER_MG_PCG,
    "sa-pcg": TC_SOLVER_SA_PCG,
}

#: ``discretization`` names accepted by :meth:`Scene.bake` (the CLI's ``--discretization`` names).
DISCRETIZATIONS = {
    "transcut": TC_DISCRETIZATION_TRANSCUT,
    "fitted": TC_DISCRETIZATION_FITTED,
    "consistent-fem": TC_DISCRETIZATION_CONSISTENT_FEM,
    "fitted-layer": TC_DISCRETIZATION_FITTED_LAYER,
}

# TcMediumEdit.region and .op (tc_object_edit_medium).
TC_REGION_ALL = 0
TC_REGION_SPHERE = 1
TC_REGION_DEPTH = 2
TC_REGION_MASK = 3
TC_MEDIUM_ASSIGN = 0
TC_MEDIUM_SCALE = 1
TC_MEDIUM_ADD = 2


class TcMedium(Structure):
    """``TcMedium``: physical coefficients in mm⁻¹ per RGB channel, relative index η, anisotropy g."""

    _fields_ = [
        ("sigma_a", c_double * 3),
        ("sigma_s_prime", c_double * 3),
        ("eta", c_double),
        ("g", c_double),
    ]


class TcArtistMedium(Structure):
    """``TcArtistMedium``: Principled-BSDF style parameters (radius in scene units)."""

    _fields_ = [
        ("albedo", c_double * 3),
        ("radius", c_double * 3),
        ("scale", c_double),
        ("ior", c_double),
        ("anisotropy", c_double),
        ("mapping", c_uint32),
    ]


class TcBakeOptions(Structure):
    """``TcBakeOptions`` (starts with its own ``size``; filled by ``tc_bake_options_init``)."""

    _fields_ = [
        ("size", c_uint32),
        ("method", c_uint32),
        ("tets", c_uint64),
        ("tolerance", c_double),
        ("max_iterations", c_uint32),
        ("threads", c_uint32),
        ("shadows", c_uint32),
        ("area_samples", c_uint32),
        ("environment_samples", c_uint32),
        ("backend", c_uint32),
        # NULL, or the chosen method's options (TcTransCutOptions *, TcDipoleOptions *, ...)
        ("method_options", c_void_p),
    ]


class TcTransCutOptions(Structure):
    """``TcTransCutOptions``: TransCut's own options, pointed to by ``TcBakeOptions.method_options``
    (filled by ``tc_transcut_options_init``)."""

    _fields_ = [
        ("size", c_uint32),
        ("solver", c_uint32),
        ("edit_solver", c_uint32),
        # 0: one tet size everywhere; N: graded, N cubes of each size before the next doubling
        ("grading", c_uint32),
        ("discretization", c_uint32),  # TC_DISCRETIZATION_*
    ]


class TcDipoleOptions(Structure):
    """``TcDipoleOptions``: the hierarchical dipole's own options, pointed to by
    ``TcBakeOptions.method_options`` (filled by ``tc_dipole_options_init``)."""

    _fields_ = [
        ("size", c_uint32),
        ("oracle", c_uint32),
        ("theta", c_double),
        ("eps1", c_double),
        ("eps2", c_double),
        ("rule", c_uint32),
        ("receivers", c_uint32),
        ("mode", c_uint32),
        ("geometry", c_uint32),
        ("budget", c_uint64),  # incremental mode: the most links per update; 0 = no limit
        ("radiance", c_uint32),
    ]


class TcPrtOptions(Structure):
    """``TcPrtOptions``: the PRT method's own options, pointed to by ``TcBakeOptions.method_options``
    (filled by ``tc_prt_options_init``)."""

    _fields_ = [
        ("size", c_uint32),
        ("samples_log2", c_uint32),  # log2 of the irradiance samples, 4 to 18 (default 16)
        ("basis_terms", c_uint32),  # TC_PRT_BASIS_16 or TC_PRT_BASIS_12
        ("terms_per_vertex", c_uint32),  # Haar coefficients kept per vertex (default 1024)
        ("near_field", c_uint32),  # 1: the near-field correction of the rows (default)
        ("near_radius", c_double),  # in sample spacings (default 8)
        ("seed", c_uint64),
        ("cache_dir", c_char_p),  # a folder of saved precomputes (None: none)
    ]


class TcPolygridOptions(Structure):
    """``TcPolygridOptions``: the polygrid method's own options, pointed to by
    ``TcBakeOptions.method_options`` (filled by ``tc_polygrid_options_init``)."""

    _fields_ = [
        ("size", c_uint32),
        ("resolution", c_uint32),  # grid cells per cube edge, 1 to 256 (default 8)
        ("nodes", c_uint64),  # target grid nodes per object (default 200 000)
        ("cube_mm", c_double),  # the polycube's cube edge in mm; 0: from nodes (default)
        ("stencil", c_uint32),  # TC_POLYGRID_STENCIL_*
        ("solver", c_uint32),  # TC_SOLVER_* of the bake (FEM stencil)
        ("edit_solver", c_uint32),  # TC_SOLVER_* of the session's updates
    ]


class TcPolygridStats(Structure):
    """``TcPolygridStats`` (``tc_object_polygrid_stats``; the caller sets ``size``)."""

    _fields_ = [
        ("size", c_uint32),
        ("resolution", c_uint32),
        ("cubes", c_uint64),
        ("cube_mm", c_double),
        ("nodes", c_uint64),
        ("cells", c_uint64),
        ("min_scaled_jacobian", c_double),
        ("mean_scaled_jacobian", c_double),
    ]


class TcPrtStats(Structure):
    """``TcPrtStats`` (``tc_object_prt_stats``; the caller sets ``size``)."""

    _fields_ = [
        ("size", c_uint32),
        ("basis_terms", c_uint32),
        ("samples_log2", c_uint32),
        ("precompute_loaded", c_uint32),  # 1: read from the cache folder
        ("vertices", c_uint64),
        ("terms", c_uint64),
        ("bytes", c_uint64),
        ("dropped_mean", c_double),
        ("dropped_max", c_double),
        ("residual", c_double * 3),
        ("transfer_mm_per_unit", c_double),
        ("mm_per_unit", c_double),
        ("medium", TcMedium),
        ("key", c_uint64 * 2),
    ]


class TcRadiosityOptions(Structure):
    """``TcRadiosityOptions``: translucent radiosity's own options, pointed to by
    ``TcBakeOptions.method_options`` (filled by ``tc_radiosity_options_init``)."""

    _fields_ = [
        ("size", c_uint32),
        ("iteration", c_uint32),
        ("patch_size_mm", c_double),  # 0: the scene's bounding diagonal / 80
        ("rays_per_patch", c_uint32),
        ("max_iterations", c_uint32),
        ("seed", c_uint64),
        ("tolerance", c_double),
        ("covered_fraction", c_double),
        ("bounces", c_uint32),  # 0: until the tolerance
        ("solver", c_uint32),  # the translucent objects' TC_SOLVER_*
        ("grading", c_uint32),  # the translucent objects' tets, as TcTransCutOptions.grading
        ("discretization", c_uint32),  # their assembly, a TC_DISCRETIZATION_*
    ]


class TcBakeStats(Structure):
    """``TcBakeStats`` (the caller sets ``size`` before ``tc_object_stats``)."""

    _fields_ = [
        ("size", c_uint32),
        ("tets", c_uint64),
        ("vertices", c_uint64),
        ("iterations", c_uint32 * 3),
        ("meshing_ms", c_double),
        ("assembly_ms", c_double),
        ("source_ms", c_double),
        ("solve_ms", c_double),
        ("total_ms", c_double),
        ("clamped_vertices", c_uint64),
        ("backend_used", c_uint32),
        ("flipped_faces", c_uint64),
        ("resolution", c_double * 3),
        ("mesh_reused", c_uint32),  # 1: the tets were kept from the scene's previous bake
    ]


class TcRadiosityStats(Structure):
    """``TcRadiosityStats`` (``tc_scene_radiosity_stats``; the caller sets ``size``)."""

    _fields_ = [
        ("size", c_uint32),
        ("patches", c_uint64),
        ("translucent_patches", c_uint64),
        ("covered_patches", c_uint64),
        ("nonzeros", c_uint64),
        ("form_factor_bytes", c_uint64),
        ("patch_size_mm", c_double),
        ("prepare_ms", c_double),
        ("patches_ms", c_double),
        ("form_factor_ms", c_double),
        ("direct_ms", c_double),
        ("solve_ms", c_double),
        ("iterations", c_uint32),
        ("scatterings", c_uint32),
        ("estimated_error", c_double),
        ("energy_defect", c_double),
    ]


class TcDipoleStats(Structure):
    """``TcDipoleStats`` (``tc_object_dipole_stats``; the caller sets ``size``)."""

    _fields_ = [
        ("size", c_uint32),
        ("triangles", c_uint64),
        ("receivers", c_uint64),
        ("nodes", c_uint64),
        ("links", c_uint64),
        ("near_links", c_uint64),
        ("form_factors", c_uint64),
        ("stale_tasks", c_uint64),
        ("refit_ms", c_double),
        ("link_ms", c_double),
        ("gather_ms", c_double),
        ("push_ms", c_double),
    ]


class TcMediumEdit(Structure):
    """``TcMediumEdit`` (``tc_object_edit_medium``; set ``size``)."""

    _fields_ = [
        ("size", c_uint32),
        ("region", c_uint32),
        ("center", c_double * 3),
        ("radius", c_double),
        ("min_mm", c_double),
        ("max_mm", c_double),
        ("mask", POINTER(c_uint8)),
        ("mask_len", c_size_t),
        ("op", c_uint32),
        ("sigma_a", c_double * 3),
        ("sigma_s_prime", c_double * 3),
    ]


class TcEditStats(Structure):
    """``TcEditStats`` (``tc_object_edit_stats``; the caller sets ``size``)."""

    _fields_ = [
        ("size", c_uint32),
        ("pieces_solved", c_uint32),
        ("iterations", c_uint32 * 3),
        ("cut", c_uint32),
        ("rows_rebuilt", c_uint64),
        ("tets_changed", c_uint64),
        ("source_ms", c_double),
        ("assembly_ms", c_double),
        ("hierarchy_ms", c_double),
        ("solve_ms", c_double),
        ("total_ms", c_double),
        ("cut_removed_tets", c_uint64),
        ("cut_removed_vertices", c_uint64),
        ("cut_moved_vertices", c_uint64),
        ("cut_surface_vertices", c_uint64),
        ("cut_max_distance", c_double),
        ("cut_min_dihedral_degrees", c_double),
        ("cut_bound_degrees", c_double),
    ]


class TcAcquireOptions(Structure):
    """``TcAcquireOptions`` (``tc_acquire_options_init`` fills it and ``size``)."""

    _fields_ = [
        ("size", c_uint32),
        ("observe", c_uint32),
        ("nodes", c_uint32 * 3),
        ("method", c_uint32),
        ("spacing_mm", c_double),
        ("eta", c_double),
        ("margin_mm", c_double),
        ("pattern_grid", c_uint32),
        ("max_iterations", c_uint32),
        ("homogeneous_iterations", c_uint32),
        ("lambda", c_double),  # a Python keyword: getattr(options, "lambda")
        ("target_misfit_rms", c_double),
        ("solve_tolerance", c_double),
        ("initial_sigma_a", c_double * 3),
        ("initial_sigma_s_prime", c_double * 3),
        ("origin", c_double * 3),
        ("units_per_mm", c_double),
        ("channels", c_uint32),
        ("coarse_levels", c_uint32),
        ("absorption_coarsening", c_uint32),
    ]


class TcAcquireStats(Structure):
    """``TcAcquireStats`` (``tc_acquire``; the caller sets ``size``)."""

    _fields_ = [
        ("size", c_uint32),
        ("iterations", c_uint32),
        ("dims", c_uint32 * 3),
        ("forward_solves", c_uint64),
        ("adjoint_solves", c_uint64),
        ("misfit_rms", c_double * 3),
        ("homogeneous_sigma_a", c_double * 3),
        ("homogeneous_sigma_s_prime", c_double * 3),
        ("voxel_size", c_double),
    ]


class TcScene(Structure):
    """Opaque ``TcScene``."""


ScenePtr = POINTER(TcScene)

#: ``typedef int32_t (*TcProgressFn)(void *user, const char *stage, double fraction)``;
#: a non-zero return cancels the call that reports (``tc_scene_bake``, ``tc_scene_relight``, and the
#: edit calls once ``tc_scene_set_progress`` set it).
TcProgressFn = CFUNCTYPE(c_int32, c_void_p, c_char_p, c_double)

c_double_p = POINTER(c_double)
c_float_p = POINTER(c_float)
c_uint32_p = POINTER(c_uint32)

#: The prototypes, ``name: (restype, argtypes)``, that the Blender add-on needs: a library
#: without one of them is refused at load.
REQUIRED = {
    "tc_version": (c_uint32, []),
    "tc_version_string": (c_char_p, []),
    "tc_last_error_message": (c_char_p, []),
    "tc_scene_create": (c_int32, [POINTER(ScenePtr)]),
    "tc_scene_destroy": (None, [POINTER(ScenePtr)]),
    "tc_scene_add_mesh": (c_int32, [ScenePtr, c_float_p, c_size_t, c_uint32_p, c_size_t, c_uint32_p]),
    "tc_object_set_transform": (c_int32, [ScenePtr, c_uint32, c_float_p]),
    "tc_object_set_scale": (c_int32, [ScenePtr, c_uint32, c_double]),
    "tc_object_vertex_count": (c_int32, [ScenePtr, c_uint32, POINTER(c_size_t)]),
    "tc_medium_preset": (c_int32, [c_char_p, POINTER(TcMedium)]),
    "tc_object_set_medium": (c_int32, [ScenePtr, c_uint32, POINTER(TcMedium)]),
    "tc_object_set_medium_preset": (c_int32, [ScenePtr, c_uint32, c_char_p]),
    "tc_object_set_medium_artist": (c_int32, [ScenePtr, c_uint32, POINTER(TcArtistMedium)]),
    "tc_scene_add_sun": (c_int32, [ScenePtr, c_double_p, c_double_p, c_double]),
    "tc_scene_add_point": (c_int32, [ScenePtr, c_double_p, c_double_p]),
    "tc_scene_add_spot": (c_int32, [ScenePtr, c_double_p, c_double_p, c_double_p, c_double, c_double]),
    "tc_scene_add_rect": (c_int32, [ScenePtr, c_double_p, c_double_p, c_double_p, c_double_p, c_int32]),
    "tc_scene_add_disc": (c_int32, [ScenePtr, c_double_p, c_double_p, c_double, c_double_p, c_int32]),
    "tc_scene_add_environment": (c_int32, [ScenePtr, c_double_p]),
    "tc_scene_add_environment_image": (c_int32, [ScenePtr, c_float_p, c_size_t, c_size_t, c_double]),
    "tc_bake_options_default": (None, [POINTER(TcBakeOptions)]),
    "tc_scene_bake": (c_int32, [ScenePtr, POINTER(TcBakeOptions), TcProgressFn, c_void_p]),
    "tc_object_radiance": (c_int32, [ScenePtr, c_uint32, c_float_p, c_size_t]),
}
#: The rest of the header: bound when the library has them; calling a missing one raises.
OPTIONAL = {
    "tc_status_name": (c_char_p, [c_int32]),
    "tc_live_scene_count": (c_size_t, []),
    "tc_object_set_mesh": (c_int32, [ScenePtr, c_uint32, c_float_p, c_size_t, c_uint32_p, c_size_t]),
    "tc_scene_object_count": (c_int32, [ScenePtr, POINTER(c_uint32)]),
    "tc_scene_light_count": (c_int32, [ScenePtr, POINTER(c_uint32)]),
    "tc_object_set_name": (c_int32, [ScenePtr, c_uint32, c_char_p]),
    "tc_scene_add_mesh_file": (c_int32, [ScenePtr, c_char_p, c_uint32_p]),
    "tc_scene_add_tet_mesh": (c_int32, [ScenePtr, c_float_p, c_size_t, c_uint32_p, c_size_t, c_uint32_p, c_uint32_p]),
    "tc_medium_from_artist": (c_int32, [POINTER(TcArtistMedium), c_double, POINTER(TcMedium)]),
    "tc_object_set_media_table": (c_int32, [ScenePtr, c_uint32, POINTER(TcMedium), c_size_t]),
    "tc_object_set_media_per_tet": (c_int32, [ScenePtr, c_uint32, c_float_p, c_float_p, c_size_t, c_double, c_double]),
    "tc_object_set_medium_voxels": (
        c_int32,
        [ScenePtr, c_uint32, c_uint32_p, c_double_p, c_double_p, c_float_p, c_size_t, c_double, c_double],
    ),
    "tc_object_set_medium_voxel_file": (c_int32, [ScenePtr, c_uint32, c_char_p, c_double, c_double]),
    "tc_scene_add_environment_file": (c_int32, [ScenePtr, c_char_p, c_double]),
    "tc_scene_clear_lights": (c_int32, [ScenePtr]),
    "tc_object_stats": (c_int32, [ScenePtr, c_uint32, POINTER(TcBakeStats)]),
    "tc_object_device": (c_int32, [ScenePtr, c_uint32, c_char_p, c_size_t, POINTER(c_size_t)]),
    "tc_object_backend_fallback": (c_int32, [ScenePtr, c_uint32, c_char_p, c_size_t, POINTER(c_size_t)]),
    # The subsurface methods and their options.
    "tc_method_count": (c_uint32, []),
    "tc_method_name": (c_int32, [c_uint32, c_char_p, c_size_t, POINTER(c_size_t)]),
    "tc_method_description": (c_int32, [c_uint32, c_char_p, c_size_t, POINTER(c_size_t)]),
    "tc_method_from_name": (c_int32, [c_char_p, c_uint32_p]),
    "tc_bake_options_init": (c_int32, [POINTER(TcBakeOptions), c_size_t]),
    "tc_transcut_options_init": (c_int32, [POINTER(TcTransCutOptions), c_size_t]),
    "tc_dipole_options_init": (c_int32, [POINTER(TcDipoleOptions), c_size_t]),
    "tc_radiosity_options_init": (c_int32, [POINTER(TcRadiosityOptions), c_size_t]),
    "tc_prt_options_init": (c_int32, [POINTER(TcPrtOptions), c_size_t]),
    "tc_polygrid_options_init": (c_int32, [POINTER(TcPolygridOptions), c_size_t]),
    "tc_scene_radiosity_stats": (c_int32, [ScenePtr, POINTER(TcRadiosityStats)]),
    # Acquisition (inverse diffusion) from images in memory.
    "tc_acquire_options_init": (c_int32, [POINTER(TcAcquireOptions), c_size_t]),
    "tc_acquire": (
        c_int32,
        [
            POINTER(TcAcquireOptions),
            c_float_p,
            c_size_t,
            c_size_t,
            c_float_p,
            c_size_t,
            TcProgressFn,
            c_void_p,
            c_float_p,
            c_size_t,
            c_char_p,
            POINTER(TcAcquireStats),
        ],
    ),
    # Diffuse objects (translucent radiosity).
    "tc_scene_add_diffuse_mesh": (
        c_int32,
        [ScenePtr, c_float_p, c_size_t, c_uint32_p, c_size_t, c_double_p, c_uint32_p],
    ),
    "tc_object_set_albedo": (c_int32, [ScenePtr, c_uint32, c_double_p]),
    "tc_object_set_emission": (c_int32, [ScenePtr, c_uint32, c_double_p]),
    "tc_object_set_sides": (c_int32, [ScenePtr, c_uint32, c_uint32]),
    "tc_object_material": (c_int32, [ScenePtr, c_uint32, c_uint32_p]),
    # Editing (after a bake).
    "tc_scene_relight": (c_int32, [ScenePtr, TcProgressFn, c_void_p]),
    "tc_scene_set_progress": (c_int32, [ScenePtr, TcProgressFn, c_void_p]),
    "tc_object_tet_count": (c_int32, [ScenePtr, c_uint32, POINTER(c_size_t)]),
    "tc_object_edit_medium": (c_int32, [ScenePtr, c_uint32, POINTER(TcMediumEdit)]),
    "tc_object_edit_albedo": (c_int32, [ScenePtr, c_uint32, c_double_p]),
    "tc_object_edit_emission": (c_int32, [ScenePtr, c_uint32, c_double_p]),
    "tc_object_paint": (c_int32, [ScenePtr, c_uint32, c_double_p, c_size_t, c_double, POINTER(TcMedium), c_double]),
    "tc_object_cut_plane": (c_int32, [ScenePtr, c_uint32, c_double_p, c_double_p, c_int32]),
    "tc_object_cut_stroke": (c_int32, [ScenePtr, c_uint32, c_double_p, c_double_p, c_size_t, c_int32]),
    "tc_object_cut_mesh": (c_int32, [ScenePtr, c_uint32, c_float_p, c_size_t, c_uint32_p, c_size_t, c_int32]),
    "tc_object_fracture": (c_int32, [ScenePtr, c_uint32, c_uint32_p]),
    "tc_object_recombine": (c_int32, [ScenePtr, c_uint32, c_uint32_p]),
    "tc_object_piece_count": (c_int32, [ScenePtr, c_uint32, c_uint32_p]),
    "tc_object_set_piece_transform": (c_int32, [ScenePtr, c_uint32, c_uint32, c_double_p]),
    "tc_object_piece_transform": (c_int32, [ScenePtr, c_uint32, c_uint32, c_double_p]),
    "tc_object_piece_sizes": (c_int32, [ScenePtr, c_uint32, c_uint32, POINTER(c_size_t), POINTER(c_size_t)]),
    "tc_object_piece_mesh": (
        c_int32,
        [ScenePtr, c_uint32, c_uint32, c_float_p, c_size_t, c_uint32_p, c_size_t, c_float_p, c_size_t],
    ),
    "tc_object_edit_stats": (c_int32, [ScenePtr, c_uint32, POINTER(TcEditStats)]),
    # Texture bakes.
    "tc_object_bake_texture": (
        c_int32,
        [
            ScenePtr,
            c_uint32,
            c_uint32_p,
            c_size_t,
            c_float_p,
            c_size_t,
            c_uint32,
            c_uint32,
            c_uint32,
            c_float_p,
            c_size_t,
        ],
    ),
    # Deforming (the hierarchical dipole).
    "tc_object_set_positions": (c_int32, [ScenePtr, c_uint32, c_float_p, c_size_t]),
    "tc_object_dipole_stats": (c_int32, [ScenePtr, c_uint32, POINTER(TcDipoleStats)]),
    # The PRT method's edits without a new bake, its statistics and saved precompute.
    "tc_object_prt_stats": (c_int32, [ScenePtr, c_uint32, POINTER(TcPrtStats)]),
    "tc_object_prt_save": (c_int32, [ScenePtr, c_uint32, c_char_p]),
    "tc_object_prt_set_medium": (c_int32, [ScenePtr, c_uint32, POINTER(TcMedium)]),
    "tc_object_prt_set_medium_artist": (c_int32, [ScenePtr, c_uint32, POINTER(TcArtistMedium)]),
    "tc_object_prt_set_scale": (c_int32, [ScenePtr, c_uint32, c_double]),
    # The polygrid method's statistics.
    "tc_object_polygrid_stats": (c_int32, [ScenePtr, c_uint32, POINTER(TcPolygridStats)]),
}
