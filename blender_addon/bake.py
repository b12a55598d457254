"""A bake in three steps: gather (main thread, bpy), run (any thread, no bpy), write (main thread).

:func:`prepare_job` gathers everything a bake needs from Blender into a :class:`BakeJob` and
checks it, for the bake and the editing operators alike. :func:`run_job` only touches the library
and NumPy, so the modal operator runs it on a worker thread while Blender stays responsive;
:class:`BakeRunner` carries the progress the library reports and the cancel request (ESC) back
the other way. :func:`write_results` is the only step that changes Blender data, and it runs only
after every object baked.

With the radiosity method the job also holds the surroundings (``BakeJob.diffuse``,
:func:`mesh_export.surroundings`): the visible meshes that are not selected, sent as opaque
diffuse objects that the selected translucent ones light and are lit by. The library returns
Lo per vertex for them too (Lo = B/π, the side their face normals point to); those it is safe
to write (``DiffuseJob.write``) get it in the same colour attribute, so the floor shows the
marble's shadow and the colour it bleeds, as a light bake of the surroundings would.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from . import transcut
from .lights import scene_lights, world_lights
from .mesh_export import BakeError, gather, mm_per_unit, surroundings

#: The hierarchical dipole's method name (``tc_method_name``): no tetrahedra, homogeneous media,
#: deforming meshes (Bake Animation).
DIPOLE = "hierarchical-dipole"
#: Translucent radiosity's method name: the selected translucent meshes and the visible opaque
#: ones around them light each other (inter-reflection, colour bleeding, emissive surfaces).
RADIOSITY = "radiosity"
#: The PRT method's name: homogeneous media, a precompute per mesh, then material edits and
#: relights without a new bake (Live Translucency).
PRT = "prt"
#: The polygrid method's name: the diffusion equation on a grid cut from a polycube of each object
#: (heterogeneous media; relight and edits with the FEM stencil).
POLYGRID = "polygrid"


def prt_cache_folder() -> str:
    """Where PRT precomputes are kept: ``transcut_cache/prt`` next to the saved .blend file, else
    a folder in the system's temporary directory."""
    import tempfile

    import bpy

    if bpy.data.filepath:
        return bpy.path.abspath("//transcut_cache/prt")
    return os.path.join(tempfile.gettempdir(), "transcut_cache", "prt")


@dataclass
class BakeJob:
    """Everything a bake needs, as plain data."""

    meshes: list  # [mesh_export.MeshJob]
    lights: list  # [lights.LightSpec]
    options: dict  # transcut.Scene.bake keywords (method name, TcBakeOptions fields)
    attribute_name: str
    warnings: list = field(default_factory=list)
    diffuse: list = field(default_factory=list)  # [mesh_export.DiffuseJob]: radiosity's surroundings


def _name(item: str) -> str:
    """The binding's name of an enumeration item of the settings (``OPENING_ANGLE`` → ``opening-angle``)."""
    return item.lower().replace("_", "-")


def _grading(settings):
    """The binding's ``grading`` of the settings: ``"auto"``, 0 (uniform) or the cubes per size."""
    return {"AUTO": "auto", "UNIFORM": 0}.get(settings.grading, settings.grading_layers)


def bake_options(settings, method: str, mm_per_unit: float = 1.0) -> dict:
    """The :meth:`transcut.Scene.bake` keywords of ``method`` from the TransCut settings: for
    TransCut its resolution, grading, assembly, tolerance and backend; for the hierarchical dipole its oracle with
    its θ (opening angle) or ε₁ and ε₂ (paper), edge rule, receivers and mode with its budget
    (incremental); for radiosity TransCut's five (for the translucent objects) and its own
    patch size (the setting is a length in scene units, sent in mm: × ``mm_per_unit``; 0 = the
    library's default), rays, iteration, bounces and tolerance (the options of the other
    methods, and of the oracle or mode not chosen, are left out: the binding refuses the
    first); for PRT its samples, terms, basis and the cache folder (``Keep Precomputes``); for
    the polygrid TransCut's tolerance and backend (not its tets) and its own nodes, cube size (a
    length in scene units, sent in mm: × ``mm_per_unit``; 0 = from the nodes), resolution and
    stencil."""
    options = dict(method=method, shadows=1 if settings.shadows else 0)
    if method == DIPOLE:
        options.update(oracle=_name(settings.dipole_oracle))
        if settings.dipole_oracle == "PAPER":
            options.update(eps1=settings.dipole_eps1, eps2=settings.dipole_eps2)
        else:
            options.update(theta=settings.dipole_theta)
        options.update(
            rule=_name(settings.dipole_rule),
            receivers=_name(settings.dipole_receivers),
            mode=_name(settings.dipole_mode),
        )
        if settings.dipole_mode == "INCREMENTAL":
            options.update(budget=settings.dipole_budget)
    elif method == PRT:
        options.update(
            prt_samples=settings.prt_samples, prt_terms=settings.prt_terms, prt_basis=int(settings.prt_basis)
        )
        if settings.prt_keep:
            options.update(prt_cache=prt_cache_folder())
    elif method == POLYGRID:
        options.update(
            tolerance=settings.tolerance,
            backend=settings.backend.lower(),
            polygrid_nodes=settings.polygrid_nodes,
            polygrid_cube=float(settings.polygrid_cube) * mm_per_unit,
            polygrid_resolution=settings.polygrid_resolution,
            polygrid_stencil=_name(settings.polygrid_stencil),
        )
    else:
        options.update(tets=settings.tets, tolerance=settings.tolerance, backend=settings.backend.lower())
    if method in ("transcut", RADIOSITY):
        options.update(grading=_grading(settings), discretization=_name(settings.discretization))
    if method == RADIOSITY:
        options.update(
            patch_size=float(settings.radiosity_patch_size) * mm_per_unit,
            rays=settings.radiosity_rays,
            iteration=_name(settings.radiosity_iteration),
            bounces=settings.radiosity_bounces if settings.radiosity_iteration == "JACOBI" else 0,
            radiosity_tolerance=settings.radiosity_tolerance,
        )
    return options


def check_editable(context, what: str) -> None:
    """BakeError when the Method chosen cannot be edited after its bake (radiosity: its objects
    light each other, so the library offers no per-object edit; the polygrid's finite-volume
    and paper stencils: their bakes take no updates), before any work."""
    settings = context.scene.transcut
    if settings.method == RADIOSITY:
        raise BakeError(
            f"{what} cannot edit a radiosity bake (its objects light each other, so the library has no "
            "per-object edits for it yet); choose TransCut in the Method menu"
        )
    if settings.method == POLYGRID and settings.polygrid_stencil != "FEM":
        raise BakeError(
            f"{what} cannot edit a {_name(settings.polygrid_stencil)} polygrid bake (the library has no updates for "
            "it); choose the FEM stencil or TransCut"
        )


def relights(options: dict) -> bool:
    """Whether a bake with these :meth:`transcut.Scene.bake` keywords takes a relight
    (``tc_scene_relight``): every method's does but the polygrid's finite-volume and paper
    stencils'."""
    return not (options.get("method") == POLYGRID and options.get("polygrid_stencil") in ("finite-volume", "paper-lsq"))


def prepare_job(context, objects: list | None = None, method: str | None = None, animated: bool = False) -> BakeJob:
    """The bake job for ``objects`` (default: the selected meshes), the scene's lights and world
    and its TransCut settings (the method by name, default the panel's: the menu's items are the
    loaded library's methods, so load it first); raises BakeError before any work when something
    is wrong. ``animated``: the meshes are the first pose of an animation (Bake Animation), whose
    modifiers are not applied (see :func:`mesh_export.gather_mesh`)."""
    warnings: list = []
    meshes = gather(context, warnings, objects=objects, animated=animated)
    depsgraph = context.evaluated_depsgraph_get()
    lights = scene_lights(depsgraph, warnings) + world_lights(context.scene.world, warnings)
    settings = context.scene.transcut
    method = method or settings.method
    if not method:
        raise BakeError(
            "the Method chosen in the TransCut panel is not one the loaded libtranscut has; choose one of its methods"
        )
    diffuse = []
    if method == RADIOSITY:
        import bpy

        diffuse = surroundings(context, [bpy.data.objects[m.object_name] for m in meshes], warnings)
    if not lights and not any(any(d.emission) for d in diffuse):
        raise BakeError(
            "the scene has no lights (and the world is black"
            + (", and nothing around the selection emits" if method == RADIOSITY else "")
            + "); add a light to bake"
        )
    options = bake_options(settings, method, mm_per_unit(context.scene))
    return BakeJob(meshes, lights, options, settings.attribute_name, warnings, diffuse)


def build_scene(lib: transcut.Library, job: BakeJob) -> tuple:
    """A :class:`transcut.Scene` holding the job's objects and lights; returns (scene, object
    indices): the translucent objects' (``job.meshes``), then the diffuse ones' (``job.diffuse``,
    two-sided; the radiosity method's surroundings, none for the other methods)."""
    scene = lib.scene()
    try:
        indices = []
        for mesh in job.meshes:
            idx = add_object(scene, mesh, lambda mesh=mesh: scene.add_mesh(mesh.positions, mesh.triangles))
            indices.append(idx)
        for d in job.diffuse:
            emission = d.emission if any(d.emission) else None
            idx = add_object(
                scene,
                d,
                lambda d=d, emission=emission: scene.add_diffuse_mesh(
                    d.positions, d.triangles, d.albedo, emission=emission, sides=transcut.TC_SIDES_BOTH
                ),
            )
            indices.append(idx)
        add_lights(scene, job.lights)
        return scene, indices
    except BaseException:
        scene.close()
        raise


def add_object(scene: transcut.Scene, item, add: Callable[[], int]) -> int:
    """Adds one object of a job (``add()`` adds its mesh and returns the index), then
    :func:`place_object`; BakeError naming the object on failure."""
    try:
        idx = add()
    except (transcut.TranscutError, ValueError) as exc:
        raise BakeError(f"'{item.object_name}' ({_source(item)}): {_text(exc)}") from exc
    place_object(scene, idx, item)
    return idx


def place_object(scene: transcut.Scene, idx: int, item) -> None:
    """Gives library object ``idx`` the name, placement, scale and material of ``item`` (a
    ``mesh_export.MeshJob``, or a ``DiffuseJob``'s albedo and emission); BakeError naming it."""
    lib = scene.lib
    try:
        if lib.has("tc_object_set_name"):
            scene.set_name(idx, item.object_name)
        scene.set_transform(idx, item.matrix_world)
        # A medium in artist terms converts its radius at the scale of this moment: scale first.
        scene.set_scale(idx, item.mm_per_unit)
        if hasattr(item, "medium"):
            getattr(scene, item.medium.method)(idx, **item.medium.kwargs)
        else:
            scene.set_albedo(idx, item.albedo)
            scene.set_emission(idx, item.emission)
    except (transcut.TranscutError, ValueError) as exc:
        raise BakeError(f"'{item.object_name}' ({_source(item)}): {_text(exc)}") from exc


def _source(item) -> str:
    """Where a job item's material comes from, for messages."""
    return item.medium.source if hasattr(item, "medium") else f"{item.source}, diffuse surroundings"


def _text(exc: BaseException) -> str:
    if isinstance(exc, transcut.TranscutError):
        return exc.message or exc.status_name
    return str(exc)


def add_lights(scene: transcut.Scene, lights: list) -> None:
    """Adds ``lights`` (:class:`lights.LightSpec`) to ``scene``; BakeError naming the light the
    library refuses."""
    for light in lights:
        try:
            getattr(scene, light.method)(**light.kwargs)
        except transcut.TranscutError as exc:
            raise BakeError(f"light '{light.source}': {_text(exc)}") from exc


@dataclass
class TextureRequest:
    """A texture bake of ``job.meshes[mesh]``: the loop triangles over its baked vertices, the
    active UV map's UV per corner (float32 (m, 3, 2)), the image's size and margin; ``image``
    is the result, float32 (height, width, 4) with rows from the top, through the material's
    surface layer (:meth:`mesh_export.MediumSpec.seen`)."""

    mesh: int
    triangles: np.ndarray
    uvs: np.ndarray
    width: int
    height: int
    margin: int
    image: np.ndarray | None = None


def run_job(
    lib: transcut.Library,
    job: BakeJob,
    progress: Callable[[str, float], bool] | None = None,
    backends: list | None = None,
    radiosity: dict | None = None,
    textures: list | None = None,
) -> list:
    """Bakes the job; returns one float32 (vertex_count, 3) radiance array per mesh
    (``job.meshes``, then ``job.diffuse``).

    When ``backends`` is a list, one :class:`BackendInfo` per translucent mesh is appended to it
    (where its solve ran); when ``radiosity`` is a dict and the method is radiosity, it is
    updated with the scene's :meth:`transcut.Scene.radiosity_stats`. Raises
    :class:`transcut.TranscutError` (``TC_CANCELLED`` after a cancel, or ``TC_GPU_UNAVAILABLE``
    when the GPU backend was asked for and there is none) or :class:`BakeError`.
    """
    scene, indices, results = bake_open(lib, job, progress, backends, radiosity)
    try:
        for request in textures or []:
            if progress is not None and progress(f"texture '{job.meshes[request.mesh].object_name}'", 1.0):
                raise transcut.TranscutError(
                    transcut.TC_CANCELLED, "tc_object_bake_texture", "cancelled before the texture"
                )
            rgba = scene.bake_texture(
                indices[request.mesh], request.triangles, request.uvs, request.width, request.height, request.margin
            )
            rgba[..., :3] = job.meshes[request.mesh].medium.seen(rgba[..., :3])
            request.image = rgba
        return results
    finally:
        scene.close()


def bake_open(
    lib: transcut.Library,
    job: BakeJob,
    progress: Callable[[str, float], bool] | None = None,
    backends: list | None = None,
    radiosity: dict | None = None,
    options: dict | None = None,
) -> tuple:
    """Bakes the job as :func:`run_job` describes (``options``: the bake's keywords, default
    ``job.options``) and returns the scene still open, its object indices and the radiance per
    mesh; the caller closes the scene. On failure the scene is closed."""
    scene, indices = build_scene(lib, job)
    try:
        return scene, indices, bake_scene(scene, indices, job, progress, backends, radiosity, options)
    except BaseException:
        scene.close()
        raise


def bake_scene(
    scene: transcut.Scene,
    indices: list,
    job: BakeJob,
    progress: Callable[[str, float], bool] | None = None,
    backends: list | None = None,
    radiosity: dict | None = None,
    options: dict | None = None,
) -> list:
    """Bakes ``scene`` (the job's objects at ``indices``, as :func:`build_scene` made it) and
    returns the radiance per mesh; ``backends`` and ``radiosity`` as :func:`run_job`."""
    scene.bake(progress=progress, **(job.options if options is None else options))
    if backends is not None:
        backends.extend(backend_info(scene, idx) for idx in indices[: len(job.meshes)])
    if radiosity is not None and job.options.get("method") == RADIOSITY:
        radiosity.update(scene.radiosity_stats())
    return read_results(scene, indices, job)


def read_results(scene: transcut.Scene, indices: list, job: BakeJob) -> list:
    """The radiance of every mesh of ``job`` after a bake or relight of ``scene`` (the
    translucent ones through their surface layer), checked against the vertex counts."""
    results = []
    for mesh, idx in zip([*job.meshes, *job.diffuse], indices, strict=True):
        rgb = scene.radiance(idx)
        if hasattr(mesh, "medium"):
            rgb = mesh.medium.seen(rgb)
        if rgb.shape[0] != mesh.vertex_count:
            raise BakeError(
                f"'{mesh.object_name}': the library returned {rgb.shape[0]} values for {mesh.vertex_count} vertices"
            )
        results.append(rgb)
    return results


@dataclass
class BackendInfo:
    """Where and how one object's solve ran: ``"cpu"`` or ``"gpu"``, the GPU's name, why auto
    chose the CPU; the tetrahedra, the last solve's iterations per channel (the relight's after
    a relight), the vertices whose radiance was clamped at 0, whether the tets were kept from
    the previous bake (0 where the method has none of these)."""

    backend: str
    device: str = ""
    fallback: str = ""
    tets: int = 0
    iterations: tuple = (0, 0, 0)
    clamped_vertices: int = 0
    mesh_reused: bool = False


def backend_info(scene: transcut.Scene, idx: int, relit: bool = False) -> BackendInfo:
    """Object ``idx``'s :class:`BackendInfo` after a bake, or after a relight (``relit``: the
    iterations of the relight's solve); ``"cpu"`` and zeros where the library cannot say."""
    lib = scene.lib
    if not lib.has("tc_object_stats"):
        return BackendInfo("cpu")
    stats = scene.stats(idx)
    iterations = tuple(stats["iterations"])
    if relit and lib.has("tc_object_edit_stats"):
        try:
            iterations = tuple(scene.edit_stats(idx)["iterations"])
        except transcut.TranscutError:
            pass  # a method without an editor (its bake's statistics stand)
    counts = {
        "tets": int(stats["tets"]),
        "iterations": iterations,
        "clamped_vertices": int(stats["clamped_vertices"]),
        "mesh_reused": bool(stats.get("mesh_reused", 0)),
    }
    if not (lib.has("tc_object_device") and lib.has("tc_object_backend_fallback")):
        return BackendInfo("cpu", **counts)
    backend = "gpu" if stats.get("backend_used", transcut.TC_BACKEND_CPU) == transcut.TC_BACKEND_GPU else "cpu"
    return BackendInfo(backend, scene.device(idx), scene.backend_fallback(idx), **counts)


def record_bake(job: BakeJob, runner) -> None:
    """Keeps what the last bake did in each translucent object's ``transcut.last_bake`` (the
    panel shows it): the bake's wall time, what was done, the method, tets, iterations and
    clamped vertices."""
    import bpy

    method = job.options.get("method", "transcut")
    for mesh, info in zip(job.meshes, runner.backends, strict=False):
        obj = bpy.data.objects.get(mesh.object_name)
        if obj is None:
            continue
        report = obj.transcut.last_bake
        report.valid = True
        report.seconds = runner.seconds
        report.outcome = runner.outcome
        report.method = method
        report.tets = min(info.tets, 2**31 - 1)
        report.iterations = [min(i, 2**31 - 1) for i in info.iterations]
        report.clamped_vertices = min(info.clamped_vertices, 2**31 - 1)
        report.mesh_reused = info.mesh_reused


def backend_summary(backends: list) -> str:
    """One line for the user: where the solves ran."""
    if not backends:
        return "backend unknown"
    gpus = sorted({b.device for b in backends if b.backend == "gpu"})
    falls = sorted({b.fallback for b in backends if b.fallback})
    if gpus and len(gpus) == 1 and all(b.backend == "gpu" for b in backends):
        return f"GPU: {gpus[0]}"
    text = "CPU" if not gpus else f"CPU and GPU ({', '.join(gpus)})"
    return text + (f"; {falls[0]}" if falls else "")


class BakeRunner:
    """Runs :func:`run_job` on a worker thread; progress and cancel cross threads under a lock."""

    def __init__(self, lib: transcut.Library, job: BakeJob, kept=None):
        self.lib = lib
        self.job = job
        self.kept = kept  # a kept_native.KeptBakes to reuse and keep library scenes, or None
        self.outcome = "baked"  # or, with ``kept``: "rebaked", "relit", "kept" (KeptBakes.run)
        self._lock = threading.Lock()
        self._cancel = False
        self.stage = ""
        self.fraction = 0.0
        self.results: list | None = None
        self.backends: list = []
        self.radiosity: dict = {}  # radiosity bakes: the scene's Scene.radiosity_stats
        self.seconds = 0.0  # the wall time of the library's work
        self.error: BaseException | None = None
        self._thread: threading.Thread | None = None

    def progress(self, stage: str, fraction: float) -> bool:
        """The library's progress callback (any thread): records progress, returns cancel."""
        with self._lock:
            self.stage = stage
            self.fraction = min(max(fraction, 0.0), 1.0)
            return self._cancel

    def cancel(self) -> None:
        """Asks the library to stop at its next progress report."""
        with self._lock:
            self._cancel = True

    @property
    def cancelled(self) -> bool:
        with self._lock:
            return self._cancel

    def snapshot(self) -> tuple:
        with self._lock:
            return self.stage, self.fraction

    def step(self, context) -> None:
        """Main-thread work between library calls, at each tick of the modal operator's timer
        (none here: one library call on one thread; Bake Animation's runner evaluates each frame
        here)."""

    def _run(self) -> None:
        start = time.perf_counter()
        try:
            if self.kept is not None:
                self.results, self.outcome = self.kept.run(
                    self.lib, self.job, self.progress, self.backends, self.radiosity
                )
            else:
                self.results = run_job(self.lib, self.job, self.progress, self.backends, self.radiosity)
        except BaseException as exc:  # reported by the main thread
            self.error = exc
        self.seconds = time.perf_counter() - start

    def start(self) -> None:
        self._thread = threading.Thread(target=self._run, name="transcut-bake", daemon=True)
        self._thread.start()

    def run_here(self) -> None:
        """Runs on the calling thread (background mode, tests)."""
        self._run()

    def done(self) -> bool:
        return self._thread is None or not self._thread.is_alive()

    def wait(self, timeout: float | None = None) -> bool:
        if self._thread is not None:
            self._thread.join(timeout)
        return self.done()


def error_message(exc: BaseException, what: str = "bake") -> str:
    """A one-line message for the user about ``exc``, raised by a ``what`` ("bake", "cut", …)."""
    if isinstance(exc, transcut.TranscutError):
        if exc.status == transcut.TC_CANCELLED:
            return f"{what} cancelled; nothing was changed"
        return f"libtranscut: {exc.message or exc.status_name} ({exc.status_name})"
    if isinstance(exc, (transcut.LibraryNotFound, BakeError)):
        return str(exc)
    return f"{type(exc).__name__}: {exc}"


def _replace_with_evaluated(obj, depsgraph, expected_vertices: int):
    """The object's evaluated mesh as a new mesh datablock (modifiers applied)."""
    import bpy

    ob_eval = obj.evaluated_get(depsgraph)
    mesh = bpy.data.meshes.new_from_object(ob_eval, preserve_all_data_layers=True, depsgraph=depsgraph)
    if len(mesh.vertices) != expected_vertices:
        bpy.data.meshes.remove(mesh)
        raise BakeError(f"'{obj.name}' changed during the bake; bake again")
    return mesh


def radiosity_summary(job: BakeJob, stats: dict) -> str:
    """The report's words on a radiosity bake: the surroundings, the patches, sweeps and error."""
    if not stats:
        return ""
    written = sum(1 for d in job.diffuse if d.write)
    return (
        f"; radiosity: {len(job.diffuse)} surrounding object(s) ({written} written), {stats['patches']} patches "
        f"({stats['translucent_patches']} translucent) of {stats['patch_size_mm']:.3g} mm, {stats['iterations']} "
        f"sweep(s), estimated error {stats['estimated_error']:.2g}, energy defect {stats['energy_defect']:.2g}"
    )


def write_results(context, job: BakeJob, results: list) -> None:
    """Writes each object's radiance to its FLOAT_COLOR point attribute and makes it active:
    the translucent objects' (``results[:len(job.meshes)]``), then those of the surroundings
    that are to be written (``DiffuseJob.write``; their meshes are never replaced).

    Checks everything first (objects still exist, vertex counts unchanged); only then changes
    data, so an error leaves every object as it was.
    """
    import bpy

    depsgraph = context.evaluated_depsgraph_get()
    targets = []
    diffuse = [(d, rgb) for d, rgb in zip(job.diffuse, results[len(job.meshes) :], strict=True) if d.write]
    for mesh_job, rgb in [*zip(job.meshes, results[: len(job.meshes)], strict=True), *diffuse]:
        obj = bpy.data.objects.get(mesh_job.object_name)
        if obj is None or obj.type != "MESH":
            raise BakeError(f"'{mesh_job.object_name}' was removed during the bake")
        if len(obj.data.vertices) != mesh_job.original_vertex_count:
            raise BakeError(f"'{obj.name}' changed during the bake; bake again")
        if not np.all(np.isfinite(rgb)):
            raise BakeError(f"'{obj.name}': the library returned non-finite radiance")
        targets.append((obj, mesh_job, rgb))
    new_meshes = []
    try:
        for obj, mesh_job, _ in targets:
            replace = getattr(mesh_job, "replace_mesh", False)
            new_meshes.append(_replace_with_evaluated(obj, depsgraph, mesh_job.vertex_count) if replace else None)
    except BaseException:
        for m in new_meshes:
            if m is not None:
                bpy.data.meshes.remove(m)
        raise
    name = job.attribute_name
    for (obj, _, rgb), new_mesh in zip(targets, new_meshes, strict=True):
        if new_mesh is not None:
            obj.modifiers.clear()
            obj.data = new_mesh
        mesh = obj.data
        attr = mesh.color_attributes.get(name)
        if attr is None:
            attr = mesh.color_attributes.new(name, "FLOAT_COLOR", "POINT")
        rgba = np.ones((rgb.shape[0], 4), dtype=np.float32)
        rgba[:, :3] = rgb
        attr.data.foreach_set("color", rgba.reshape(-1))
        mesh.color_attributes.active_color = attr
        mesh.color_attributes.render_color_index = mesh.color_attributes.active_color_index
        mesh.update()
