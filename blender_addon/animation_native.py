"""The library side of Bake Animation (no ``bpy``): one object's hierarchical-dipole bake carried
from frame to frame, and the cache file of its per-frame radiance.

:class:`AnimationBaker` bakes the first frame exactly as the bake operator bakes one object
(:func:`bake.build_scene`, the job's lights, medium and options), then moves the vertices of that
bake to each later frame's positions (``tc_object_set_positions``, through
:meth:`transcut.Scene.set_positions`): in the dipole's incremental mode the cluster trees are
refitted and only what moved is relinked. A frame whose vertex count or triangles differ from the
bake's (a modifier that changes the topology) is baked afresh instead. Positions are in the
object space of the job's world matrix; a later frame's other world matrix is folded into its
positions by the caller. Each frame may come with its own lights (animated lights): when they
differ from those the bake is lit by, the library's scene gets them and is relit
(``tc_scene_relight``) before the vertices move, so the frame is lit as a fresh bake under its
lights would be. A failed frame (an error, a cancel) leaves the bake at the last frame that
succeeded (the library changes nothing on failure).

The cache (:func:`write_cache`, :func:`read_cache`) is a NumPy ``.npz`` file: ``frames``
(int32, F), ``vertex_counts`` (int32, F), ``radiance`` (float16, (F, V, 3), V the largest count,
frames with fewer vertices zero-padded), ``object`` and ``attribute`` (the names it was baked
for). It is written whole or not at all (a temporary file, then a rename).
"""

from __future__ import annotations

import dataclasses
import os
import tempfile
import time
from collections.abc import Callable

import numpy as np

from . import bake, transcut

#: The C functions Bake Animation needs besides a bake (a library without them cannot deform).
ANIMATION_FUNCTIONS = ("tc_object_set_positions", "tc_dipole_options_init", "tc_scene_set_progress")

#: The largest radiance float16 holds (the cache's type).
FLOAT16_MAX = float(np.finfo(np.float16).max)


def _same_value(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b))
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same_value(x, y) for x, y in zip(a, b, strict=True))
    return a == b


def _part(progress: Callable[[str, float], bool] | None, start: float, width: float):
    """``progress`` for a part of a call that reports from ``start`` over ``width`` of it."""
    if progress is None:
        return None
    return lambda stage, fraction: progress(stage, start + width * fraction)


def same_lights(a: list | None, b: list | None) -> bool:
    """Whether two lists of :class:`lights.LightSpec` send the library the same lights (their
    methods and arguments equal, in order; the sources they came from do not matter)."""
    if a is None or b is None:
        return a is b
    return len(a) == len(b) and all(
        x.method == y.method
        and x.kwargs.keys() == y.kwargs.keys()
        and all(_same_value(x.kwargs[k], y.kwargs[k]) for k in x.kwargs)
        for x, y in zip(a, b, strict=True)
    )


class AnimationBaker:
    """The bake of one object (``job.meshes[0]``, whose positions and triangles are replaced by
    each frame's), frame after frame. ``bakes`` counts full bakes (1 after the first frame, one
    more per change of topology), ``relights`` the frames whose other lights relit the bake;
    ``lights`` are those the bake is lit by now; ``last_ms`` is the last frame's wall time in the
    library."""

    def __init__(self, lib: transcut.Library, job: bake.BakeJob):
        if len(job.meshes) != 1:
            raise ValueError("an animation bake is of one object")
        self.lib = lib
        self.job = job
        self.scene: transcut.Scene | None = None
        self.index = 0
        self.triangles: np.ndarray | None = None
        self.bakes = 0
        self.relights = 0
        self.lights: list | None = None
        # Whether the library scene's light list is not the one its bake is lit by (a relight
        # that failed after replacing it): its results are stale until a relight succeeds.
        self._stale = False
        self.last_ms = 0.0

    @property
    def vertex_count(self) -> int:
        return -1 if self.scene is None else self.scene.vertex_count(self.index)

    def frame(
        self,
        positions: np.ndarray,
        triangles: np.ndarray,
        progress: Callable[[str, float], bool] | None = None,
        lights: list | None = None,
    ) -> np.ndarray:
        """The radiance (float32 (n, 3)) of the object with these ``positions`` (float32 (n, 3))
        and ``triangles`` (uint32 (m, 3)) under ``lights`` (:class:`lights.LightSpec` list;
        None: the job's): a bake for the first frame and after a change of topology, else the
        bake relit when the lights differ from its own, then its vertices moved.
        ``progress(stage, fraction)`` as for :meth:`transcut.Scene.bake`; True cancels
        (``TranscutError(TC_CANCELLED)``)."""
        start = time.perf_counter()
        lights = list(self.job.lights if lights is None else lights)
        positions = np.ascontiguousarray(positions, dtype=np.float32).reshape(-1, 3)
        triangles = np.ascontiguousarray(triangles, dtype=np.uint32).reshape(-1, 3)
        same = (
            self.scene is not None
            and positions.shape[0] == self.vertex_count
            and self.triangles is not None
            and np.array_equal(triangles, self.triangles)
        )
        if same:
            relight = self._stale or not same_lights(lights, self.lights)
            # Of the frame's progress, a relight reports the first half and the move the rest.
            share = 0.5 if relight else 0.0
            if relight:
                self._relight(lights, _part(progress, 0.0, share))
            self.scene.set_progress(_part(progress, share, 1.0 - share))
            try:
                self.scene.set_positions(self.index, positions)
            finally:
                self.scene.set_progress(None)
        else:
            self._bake(positions, triangles, progress, lights)
        rgb = self.job.meshes[0].medium.seen(self.scene.radiance(self.index))
        self.last_ms = (time.perf_counter() - start) * 1e3
        return rgb

    def _relight(self, lights: list, progress) -> None:
        """The bake's scene under ``lights``: they replace its lights and it is relit. On failure
        the bake stays lit as it was (the library's relight changes nothing), but the library
        holds its results back until a relight succeeds (the scene's light list has changed), so
        the next frame relights whatever its lights."""
        scene = self.scene
        self._stale = True
        scene.clear_lights()
        bake.add_lights(scene, lights)
        scene.relight(progress)
        self.lights, self._stale = lights, False
        self.relights += 1

    def _bake(self, positions: np.ndarray, triangles: np.ndarray, progress, lights: list) -> None:
        mesh = dataclasses.replace(self.job.meshes[0], positions=positions, triangles=triangles)
        job = dataclasses.replace(self.job, meshes=[mesh], lights=lights)
        scene, (index,) = bake.build_scene(self.lib, job)
        try:
            scene.bake(progress=progress, **job.options)
        except BaseException:
            scene.close()
            raise
        if self.scene is not None:
            self.scene.close()
        self.scene, self.index, self.triangles, self.lights = scene, index, triangles, lights
        self._stale = False
        self.bakes += 1

    def close(self) -> None:
        """Frees the library's scene (a later :meth:`frame` bakes again)."""
        if self.scene is not None:
            self.scene.close()
        self.scene, self.triangles, self.lights = None, None, None


# -- the cache file ---------------------------------------------------------------------------


@dataclasses.dataclass
class Cache:
    """A cache file's content: per frame its radiance, as the handler reads it."""

    frames: np.ndarray  # int32 (F,)
    vertex_counts: np.ndarray  # int32 (F,)
    radiance: np.ndarray  # float16 (F, V, 3)
    object_name: str = ""
    attribute: str = ""

    def frame(self, frame: int) -> np.ndarray | None:
        """Frame ``frame``'s radiance as float32 (vertex_count, 3), or None when it was not baked."""
        hits = np.flatnonzero(self.frames == int(frame))
        if hits.size == 0:
            return None
        k = int(hits[0])
        return self.radiance[k, : int(self.vertex_counts[k])].astype(np.float32)


def pack(frames: list, radiance: list) -> tuple:
    """(frames int32 (F,), vertex counts int32 (F,), float16 (F, V, 3)) of per-frame float
    radiance arrays of possibly different lengths (zero-padded to the longest)."""
    counts = np.array([len(r) for r in radiance], dtype=np.int32)
    out = np.zeros((len(radiance), int(counts.max()) if len(counts) else 0, 3), dtype=np.float16)
    for k, rgb in enumerate(radiance):
        out[k, : len(rgb)] = rgb
    return np.asarray(frames, dtype=np.int32), counts, out


def write_cache(path: str, frames: list, radiance: list, object_name: str, attribute: str) -> None:
    """Writes the cache file at ``path`` (its folder created), whole or not at all."""
    frames_arr, counts, packed = pack(frames, radiance)
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".transcut-", suffix=".npz.tmp", dir=folder)
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez(
                f,
                frames=frames_arr,
                vertex_counts=counts,
                radiance=packed,
                object=np.array(object_name),
                attribute=np.array(attribute),
            )
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def read_cache(path: str) -> Cache:
    """The cache file at ``path`` (OSError / ValueError / KeyError when it is missing or not one)."""
    with np.load(path, allow_pickle=False) as data:
        cache = Cache(
            frames=np.asarray(data["frames"], dtype=np.int32),
            vertex_counts=np.asarray(data["vertex_counts"], dtype=np.int32),
            radiance=np.asarray(data["radiance"], dtype=np.float16),
            object_name=str(data["object"]) if "object" in data else "",
            attribute=str(data["attribute"]) if "attribute" in data else "",
        )
    f = len(cache.frames)
    shape = cache.radiance.shape
    if cache.vertex_counts.shape != (f,) or len(shape) != 3 or shape[0] != f or shape[2] != 3:
        raise ValueError(f"{path} is not a TransCut animation cache (frames, vertex_counts, radiance disagree)")
    return cache
