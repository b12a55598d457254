"""The library side of the editing operators: bake, then cut or paint, then read back (no ``bpy``).

Like :mod:`bake`, an edit runs in three steps: gather (main thread, ``bpy``: ``edit_ops``), run
(here: only the library and NumPy, so it may run on a worker thread), write (main thread). The C
functions are those of ``include/transcut.h``, "Editing", bound by :mod:`transcut`
(``tc_object_cut_plane`` / ``_mesh``, ``tc_object_fracture``, ``tc_object_paint``,
``tc_object_piece_*``, ``tc_object_edit_stats``); this module adds what the operators need on
top: the object's medium as coefficients (``tc_object_paint`` needs the painted medium to share
the object's η and g, ``tc_medium_from_artist`` gives them for artist parameters), and one
:func:`run_edit` that bakes the job's objects exactly as the bake operator does
(:func:`bake.build_scene`) and applies the edit.

Progress: the bake reports fractions in [0, :data:`BAKE_SHARE`], each object's edit an equal
part of the rest, through the scene's edit callback (:meth:`transcut.Scene.set_progress`), so a
cancel (the callback returning True) is honoured during the bake, inside each cut or paint call
(at its next report, within about a tenth of a second) and between objects; a cancelled run
raises ``TranscutError(TC_CANCELLED)`` and nothing is written.

Which side a plane cut removes: the library removes the half-space the normal points into;
:func:`plane_of_points` gives the plane of a flat cutter with its normal along the cutter's face
normals (a Blender Plane: its local +Z in world space), so the side the cutter's faces point to
is removed (``flip``: the other side).
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from . import bake, transcut
from .mesh_export import BakeError, MediumSpec

#: Share of the progress bar given to the bake; the edits of the objects share the rest.
BAKE_SHARE = 0.8

#: The C functions an edit needs (a library without them cannot cut or paint).
CUT_FUNCTIONS = (
    "tc_object_cut_plane",
    "tc_object_fracture",
    "tc_object_cut_mesh",
    "tc_object_piece_count",
    "tc_object_piece_sizes",
    "tc_object_piece_mesh",
    "tc_object_edit_stats",
)
PAINT_FUNCTIONS = ("tc_object_paint", "tc_object_edit_stats", "tc_medium_from_artist")


def require(lib: transcut.Library, names, what: str) -> None:
    """Raises BakeError naming the library and the functions in ``names`` that it lacks."""
    missing = [n for n in names if not lib.has(n)]
    if missing:
        raise BakeError(
            f"{what} needs a libtranscut with the editing functions; {lib.path} "
            f"({lib.version_string}) lacks {', '.join(missing)}"
        )


# -- what to do ------------------------------------------------------------------------------


class _Cut:
    """The run of a cut: the library cut (a subclass's ``_cut``, which honours ``keep_both``),
    the cut's ``tc_object_edit_stats``, then with ``separate`` every connected part made its own
    piece (``tc_object_fracture``)."""

    def apply(self, scene: transcut.Scene, idx: int) -> dict:
        """Cuts (then fractures); returns the cut's ``tc_object_edit_stats``."""
        self._cut(scene, idx)
        stats = scene.edit_stats(idx)
        if self.separate:
            scene.fracture(idx)
        return stats


@dataclass
class PlaneCut(_Cut):
    """A cut by the plane through ``point`` with normal ``normal`` (world space): the side the
    normal points into is removed, or with ``keep_both`` both sides become pieces."""

    point: tuple
    normal: tuple
    keep_both: bool = False
    separate: bool = False

    def _cut(self, scene: transcut.Scene, idx: int) -> None:
        scene.cut_plane(idx, self.point, self.normal, self.keep_both)


@dataclass
class MeshCut(_Cut):
    """A cut by a closed triangle mesh (world space, CCW from outside): its inside is removed,
    or with ``keep_both`` kept as a separate piece."""

    positions: np.ndarray  # float32 (n, 3), world space
    triangles: np.ndarray  # uint32 (m, 3)
    keep_both: bool = False
    separate: bool = False

    def _cut(self, scene: transcut.Scene, idx: int) -> None:
        scene.cut_mesh(idx, self.positions, self.triangles, self.keep_both)


@dataclass
class Paint:
    """A stroke of ``medium`` (σa, σ′s in mm⁻¹) along world-space ``points``: each tet at
    distance d from the stroke is blended with weight strength·exp(−d²/(2 radius²)) (the
    library's ``tc_object_paint``). The medium takes each object's own η and g."""

    points: np.ndarray  # float64 (k, 3), world space
    radius: float  # scene units
    sigma_a: tuple
    sigma_s_prime: tuple
    strength: float = 1.0

    def apply(self, scene: transcut.Scene, idx: int, eta: float, g: float) -> dict:
        """Paints; returns the paint's ``tc_object_edit_stats``."""
        medium = transcut.medium(self.sigma_a, self.sigma_s_prime, eta, g)
        scene.paint(idx, self.points, self.radius, medium, self.strength)
        return scene.edit_stats(idx)


# -- results ---------------------------------------------------------------------------------


@dataclass
class PieceMesh:
    """One piece of a cut object: its surface (world space) and radiance per vertex."""

    positions: np.ndarray  # float32 (n, 3), world space
    triangles: np.ndarray  # uint32 (m, 3), CCW from outside
    radiance: np.ndarray  # float32 (n, 3), linear RGB


@dataclass
class EditResult:
    """What one object's edit produced: pieces (a cut) or per-user-vertex radiance (a paint),
    the radiance before the edit, and the timings and statistics the library reported."""

    object_name: str
    pieces: list = field(default_factory=list)  # [PieceMesh] (cut)
    radiance: np.ndarray | None = None  # float32 (vertex_count, 3) (paint)
    baked: np.ndarray | None = None  # float32 (vertex_count, 3), before the edit
    stats: dict = field(default_factory=dict)  # tc_object_edit_stats
    edit_ms: float = 0.0  # wall time of the edit call, milliseconds


@dataclass
class EditRun:
    """Every object's result and the bake's wall time."""

    results: list  # [EditResult]
    bake_ms: float


# -- library helpers -------------------------------------------------------------------------


def medium_coefficients(lib: transcut.Library, spec: MediumSpec, mm_per_unit: float) -> transcut.TcMedium:
    """The coefficients the library gives an object set by ``spec`` (the η and g a paint must
    match): a preset through ``tc_medium_preset``, artist parameters through
    ``tc_medium_from_artist`` at ``mm_per_unit``, coefficients as they are."""
    kw = spec.kwargs
    if spec.method == "set_medium_preset":
        return lib.medium_preset(kw["name"])
    if spec.method == "set_medium":
        return transcut.medium(**kw)
    if spec.method == "set_medium_artist":
        return lib.medium_from_artist(mm_per_unit, **kw)
    raise BakeError(f"{spec.source}: no coefficients for a medium set by {spec.method}")


def read_pieces(scene: transcut.Scene, idx: int) -> list:
    """Every piece of an edited object, in the library's order."""
    return [PieceMesh(*scene.piece_mesh(idx, p)) for p in range(scene.piece_count(idx))]


def plane_of_points(positions: np.ndarray, face_normals: np.ndarray, flip: bool = False) -> tuple:
    """(point, normal) of a flat cutter in world space: the centroid of its vertices and the unit
    normal of their best-fit plane (the last right singular vector of the centred points),
    oriented along the sum of its face normals (for Blender's Plane: its local +Z mapped to
    world space), reversed with ``flip``. The library removes the side the normal points into."""
    p = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    point = p.mean(axis=0)
    normal = np.linalg.svd(p - point, full_matrices=False)[2][2]
    facing = np.nansum(np.asarray(face_normals, dtype=np.float64).reshape(-1, 3), axis=0)
    if float(np.dot(normal, facing)) < 0.0:
        normal = -normal
    if flip:
        normal = -normal
    return tuple(float(x) for x in point), tuple(float(x) for x in normal)


def is_planar(positions: np.ndarray, rel_tol: float = 1e-6) -> bool:
    """Whether every point lies on one plane (the smallest singular value of the centred points
    at most ``rel_tol`` × the largest): a plane cutter rather than a solid one."""
    p = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    if len(p) < 3:
        return False
    s = np.linalg.svd(p - p.mean(axis=0), full_matrices=False, compute_uv=False)
    return bool(s[0] > 0.0 and s[2] <= rel_tol * s[0])


def resample_polyline(points: np.ndarray, spacing: float) -> np.ndarray:
    """The polyline through ``points`` (k, 3) with points added so that consecutive points are
    at most ``spacing`` apart (the original points kept, in order)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(p) < 2 or spacing <= 0.0:
        return p
    out = [p[:1]]
    for a, b in itertools.pairwise(p):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / spacing)))
        t = np.arange(1, n + 1, dtype=np.float64)[:, None] / n
        out.append(a + t * (b - a))
    return np.concatenate(out)


# -- the run ---------------------------------------------------------------------------------


def _cancelled() -> transcut.TranscutError:
    return transcut.TranscutError(transcut.TC_CANCELLED, "edit", "cancelled")


def run_edit(
    lib: transcut.Library,
    job: bake.BakeJob,
    edit,
    progress: Callable[[str, float], bool] | None = None,
    media: list | None = None,
) -> EditRun:
    """Bakes the job's objects (as the bake operator does), applies ``edit`` (a
    :class:`PlaneCut`, :class:`MeshCut` or :class:`Paint`) to each, and reads the results.

    ``media`` (paint only): one :class:`transcut.TcMedium` per object, whose η and g the painted
    medium takes. Raises :class:`transcut.TranscutError` (the library's status and message, e.g.
    ``TC_NOTHING_LEFT``, ``TC_CANCELLED``) or :class:`BakeError`.
    """
    is_paint = isinstance(edit, Paint)
    if is_paint and (media is None or len(media) != len(job.meshes)):
        raise BakeError("a paint needs the medium of every object")

    def report(stage: str, fraction: float) -> bool:
        return bool(progress(stage, fraction)) if progress is not None else False

    scene, indices = bake.build_scene(lib, job)
    try:
        start = time.perf_counter()
        scene.bake(progress=(lambda s, f: report(s, f * BAKE_SHARE)), **job.options)
        bake_ms = (time.perf_counter() - start) * 1e3
        results = []
        count = len(indices)
        share = (1 - BAKE_SHARE) / count
        for k, (mesh, idx) in enumerate(zip(job.meshes, indices, strict=True)):
            name = mesh.object_name
            label, base = f"{'paint' if is_paint else 'cut'} '{name}'", BAKE_SHARE + share * k
            if report(label, base):
                raise _cancelled()
            scene.set_progress(lambda s, f, label=label, base=base: report(f"{label}: {s}", base + share * f))
            baked = mesh.medium.seen(scene.radiance(idx))
            start = time.perf_counter()
            try:
                stats = edit.apply(scene, idx, media[k].eta, media[k].g) if is_paint else edit.apply(scene, idx)
            except transcut.TranscutError as exc:
                exc.message = f"'{name}': {exc.message or exc.status_name}"
                raise
            result = EditResult(name, baked=baked, stats=stats, edit_ms=(time.perf_counter() - start) * 1e3)
            if is_paint:
                result.radiance = mesh.medium.seen(scene.radiance(idx))
            else:
                result.pieces = [replace(p, radiance=mesh.medium.seen(p.radiance)) for p in read_pieces(scene, idx)]
            results.append(result)
        report("done", 1.0)
        return EditRun(results, bake_ms)
    finally:
        scene.close()


class EditRunner(bake.BakeRunner):
    """:class:`bake.BakeRunner` for an edit: the same progress, cancel and threading; the
    result is an :class:`EditRun` in ``results``."""

    def __init__(self, lib: transcut.Library, job: bake.BakeJob, edit, media: list | None = None):
        super().__init__(lib, job)
        self.edit = edit
        self.media = media

    def _run(self) -> None:
        try:
            self.results = run_edit(self.lib, self.job, self.edit, self.progress, self.media)
        except BaseException as exc:  # reported by the main thread
            self.error = exc
