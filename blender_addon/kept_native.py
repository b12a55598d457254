"""Kept bakes: the library scene of the last bake of each set of objects, kept for the next.

Pressing Bake again after moving a light or changing the world should not re-mesh anything: the
library relights a baked scene in a fraction of the time (``tc_scene_relight``, warm started
from the last solution). :class:`KeptBakes` keeps, per set of baked objects, the library scene
of their last bake together with the key of everything its tet meshes and systems depend on
(each object's evaluated geometry and world matrix, the unit scale, the media, the method and
its options, the surroundings of a radiosity bake). A bake whose key matches only relights when
the lights differ (or reads the kept radiance when nothing changed); any other change bakes
afresh and replaces the kept scene. A bake that fails or is cancelled drops its kept scene (the
next bake starts afresh). Memory is bounded by a total of tetrahedra (least recently used scenes
closed first); :meth:`KeptBakes.drop_missing` closes the scenes of objects that are gone and
:meth:`KeptBakes.clear` all of them (new file, unregister). No ``bpy``: ``kept.py`` wires it in.
"""

from __future__ import annotations

import hashlib
import threading
from collections.abc import Callable
from dataclasses import dataclass

from . import transcut
from .bake import BakeJob, add_lights, backend_info, bake_open, read_results
from .live_native import canonical, lights_key, medium_key

#: The default bound of the kept scenes' total tetrahedra (about 1 KB each, so ~2 GB).
DEFAULT_BUDGET_TETS = 2_000_000
#: The solver of a kept TransCut scene's relights: SSOR-PCG warm-started from the last solution
#: (the bunny at 200k tets, runs alternated on one machine: 54-60 ms a relight against 67 ms for
#: the aggregation V-cycle the editor uses by default, and a cheaper setup at the first; the
#: V-cycle pays off for cuts and paint). Measured in docs/benchmarks.md, "Kept bakes".
RELIGHT_SOLVER = "ssor-pcg"


def _digest(array) -> str:
    return hashlib.blake2b(memoryview(array).cast("B"), digest_size=16).hexdigest()


def bake_key(job: BakeJob) -> tuple:
    """Everything a kept scene's tet meshes and systems depend on: each object's geometry,
    placement and scale, its medium, the surroundings, the method and options."""
    meshes = tuple(
        (
            m.object_name,
            _digest(m.positions),
            _digest(m.triangles),
            m.matrix_world.tobytes(),
            m.mm_per_unit,
            medium_key(m.medium),
        )
        for m in job.meshes
    )
    diffuse = tuple(
        (
            d.object_name,
            _digest(d.positions),
            _digest(d.triangles),
            d.matrix_world.tobytes(),
            canonical(d.albedo),
            canonical(d.emission),
        )
        for d in job.diffuse
    )
    return meshes, diffuse, canonical(job.options)


@dataclass
class KeptBake:
    """One kept library scene: its key, the lights it was last solved for, its object indices,
    its size in tetrahedra and when it was last used."""

    key: tuple
    lights: tuple
    scene: transcut.Scene
    indices: list
    tets: int
    used: int = 0


class KeptBakes:
    """The kept scenes, by the names of their objects (module documentation). ``bakes`` and
    ``relights`` count what :meth:`run` did (a relight re-meshes nothing)."""

    def __init__(self, budget_tets: int = DEFAULT_BUDGET_TETS):
        self.budget_tets = budget_tets
        self._bakes: dict = {}
        self._lock = threading.Lock()
        self._tick = 0
        self.bakes = 0
        self.relights = 0

    def __len__(self) -> int:
        with self._lock:
            return len(self._bakes)

    def _take(self, names: tuple):
        with self._lock:
            return self._bakes.pop(names, None)

    def _put(self, names: tuple, kept: KeptBake) -> None:
        with self._lock:
            self._tick += 1
            kept.used = self._tick
            self._bakes[names] = kept
            # Least recently used first, never the one just kept.
            while sum(k.tets for k in self._bakes.values()) > self.budget_tets and len(self._bakes) > 1:
                oldest = min((n for n in self._bakes if n != names), key=lambda n: self._bakes[n].used)
                self._bakes.pop(oldest).scene.close()

    def run(
        self,
        lib: transcut.Library,
        job: BakeJob,
        progress: Callable[[str, float], bool] | None = None,
        backends: list | None = None,
        radiosity: dict | None = None,
    ) -> tuple:
        """Bakes ``job`` as :func:`bake.run_job` does, reusing the kept scene of its objects
        when only the lights changed; returns (radiance per mesh, ``"relit"``, ``"kept"`` or
        ``"baked"``). Raises as :func:`bake.run_job`; a failure drops the kept scene."""
        names = tuple(m.object_name for m in [*job.meshes, *job.diffuse])
        key, lights = bake_key(job), lights_key(job.lights)
        kept = self._take(names)
        if kept is not None and (kept.key != key or kept.scene.lib is not lib):
            kept.scene.close()
            kept = None
        if kept is not None:
            try:
                what = "kept"
                if kept.lights != lights:
                    kept.scene.clear_lights()
                    add_lights(kept.scene, job.lights)
                    kept.scene.relight(progress)
                    what = "relit"
                if backends is not None:
                    backends.extend(backend_info(kept.scene, idx) for idx in kept.indices[: len(job.meshes)])
                results = read_results(kept.scene, kept.indices, job)
            except BaseException:
                kept.scene.close()
                raise
            if what == "relit":
                self.relights += 1
            kept.lights = lights
            self._put(names, kept)
            return results, what
        options = dict(job.options)
        if options.get("method", "transcut") == "transcut":
            options.setdefault("edit_solver", RELIGHT_SOLVER)
        scene, indices, results = bake_open(lib, job, progress, backends, radiosity, options)
        try:
            tets = (
                sum(int(scene.stats(idx).get("tets", 0)) for idx in indices[: len(job.meshes)])
                if lib.has("tc_object_stats")
                else 0
            )
        except BaseException:
            scene.close()
            raise
        self.bakes += 1
        self._put(names, KeptBake(key, lights, scene, indices, tets))
        return results, "baked"

    def drop_missing(self, exists: Callable[[str], bool]) -> int:
        """Closes the kept scenes with an object for which ``exists(name)`` is false; returns
        how many."""
        with self._lock:
            gone = [n for n in self._bakes if not all(exists(name) for name in n)]
            for n in gone:
                self._bakes.pop(n).scene.close()
        return len(gone)

    def clear(self) -> None:
        """Closes every kept scene."""
        with self._lock:
            for kept in self._bakes.values():
                kept.scene.close()
            self._bakes.clear()


#: The add-on's kept bakes.
STORE = KeptBakes()
