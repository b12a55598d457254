"""Kept bakes: the library scene of the last bake of each set of objects, kept for the next.

Pressing Bake again after moving a light or changing the world should not re-mesh anything: the
library relights a baked scene in a fraction of the time (``tc_scene_relight``, warm started
from the last solution). :class:`KeptBakes` keeps, per set of baked objects, the library scene
of their last bake together with the key of everything it depends on: the bake's options, and
per object its evaluated geometry, world matrix, unit scale and medium (or a radiosity
surrounding's albedo and emission). When only the lights differ, the kept scene is relit (or
its radiance read when nothing changed). When objects changed, only they are updated in the kept
scene (``tc_object_set_mesh`` for new geometry, then placement, scale and medium) and the scene
is baked again: the library keeps the tetrahedra of every object whose surface, placement and
scale are unchanged, so a medium change re-assembles without meshing and a modifier toggled on
one object meshes that object only. Other options bake a new scene. After a TransCut bake a
thread relights the kept scene under the same lights (:meth:`KeptBake.warm_up`), paying the
editors' setup while the user looks at the result, so the first light change costs what the
later ones do. A bake that fails or is cancelled drops its kept scene (the next bake starts
afresh). Memory is bounded by a total of tetrahedra (least recently used scenes closed first);
:meth:`KeptBakes.drop_missing` closes the scenes of objects that are gone and
:meth:`KeptBakes.clear` all of them (new file, unregister). No ``bpy``: ``kept.py`` wires it in.
"""

from __future__ import annotations

import hashlib
import threading
from collections.abc import Callable
from dataclasses import dataclass

from . import transcut
from .bake import BakeJob, add_lights, backend_info, bake_open, bake_scene, place_object, read_results
from .live_native import canonical, lights_key, medium_key
from .mesh_export import BakeError

#: The default bound of the kept scenes' total tetrahedra (about 1 KB each, so ~2 GB).
DEFAULT_BUDGET_TETS = 2_000_000
#: The solver of a kept TransCut scene's relights: SSOR-PCG warm-started from the last solution
#: (the bunny at 200k tets, runs alternated on one machine: 54-60 ms a relight against 67 ms for
#: the aggregation V-cycle the editor uses by default, and a cheaper setup at the first; the
#: V-cycle pays off for cuts and paint). Measured in docs/benchmarks.md, "Kept bakes".
RELIGHT_SOLVER = "ssor-pcg"


def _digest(array) -> str:
    return hashlib.blake2b(memoryview(array).cast("B"), digest_size=16).hexdigest()


def object_key(item) -> tuple:
    """What a kept object depends on: its geometry, placement and scale, and its medium (a
    ``mesh_export.MeshJob``) or albedo and emission (a ``DiffuseJob``)."""
    material = (
        medium_key(item.medium) if hasattr(item, "medium") else (canonical(item.albedo), canonical(item.emission))
    )
    return geometry_key(item), item.matrix_world.tobytes(), item.mm_per_unit, material


def geometry_key(item) -> tuple:
    """A job item's mesh, as digests of its arrays."""
    return _digest(item.positions), _digest(item.triangles)


@dataclass
class KeptBake:
    """One kept library scene: the bake options and each object's key it was last baked with,
    the lights it was last solved for, its object indices, its size in tetrahedra and when it
    was last used."""

    options: tuple
    objects: list
    lights: tuple
    scene: transcut.Scene
    indices: list
    tets: int
    used: int = 0
    warming: threading.Thread | None = None

    def warm_up(self) -> None:
        """Pays the editors' setup (piece systems, the source's occluder: ~0.15 s on the bunny at
        200k tets) on a thread now, by a relight under the same lights (warm-started from the
        bake, a few iterations), so that the next light change costs only its solve. Whoever
        uses the scene next waits for it (:meth:`settle`)."""
        self.warming = threading.Thread(target=_relight_quietly, args=(self.scene,), name="transcut-warm", daemon=True)
        self.warming.start()

    def settle(self) -> None:
        """Waits for :meth:`warm_up`."""
        if self.warming is not None:
            self.warming.join()
            self.warming = None

    def close(self) -> None:
        self.settle()
        self.scene.close()


def _relight_quietly(scene: transcut.Scene) -> None:
    try:
        scene.relight()
    except transcut.TranscutError:
        pass  # the next relight sets the editors up itself


class KeptBakes:
    """The kept scenes, by the names of their objects (module documentation). What :meth:`run`
    did is counted: ``bakes`` (a new library scene), ``rebakes`` (a kept scene baked again
    after its objects changed), ``relights``; ``meshed`` names the objects the last run
    tetrahedralised (the library keeps the tets of the others)."""

    def __init__(self, budget_tets: int = DEFAULT_BUDGET_TETS):
        self.budget_tets = budget_tets
        self._bakes: dict = {}
        self._lock = threading.Lock()
        self._tick = 0
        self.bakes = 0
        self.rebakes = 0
        self.relights = 0
        self.meshed: tuple = ()

    def __len__(self) -> int:
        with self._lock:
            return len(self._bakes)

    def _take(self, names: tuple):
        with self._lock:
            kept = self._bakes.pop(names, None)
        if kept is not None:
            kept.settle()
        return kept

    def _put(self, names: tuple, kept: KeptBake) -> None:
        with self._lock:
            self._tick += 1
            kept.used = self._tick
            self._bakes[names] = kept
            # Least recently used first, never the one just kept.
            while sum(k.tets for k in self._bakes.values()) > self.budget_tets and len(self._bakes) > 1:
                oldest = min((n for n in self._bakes if n != names), key=lambda n: self._bakes[n].used)
                self._bakes.pop(oldest).close()

    def run(
        self,
        lib: transcut.Library,
        job: BakeJob,
        progress: Callable[[str, float], bool] | None = None,
        backends: list | None = None,
        radiosity: dict | None = None,
    ) -> tuple:
        """Bakes ``job`` as :func:`bake.run_job` does, reusing the kept scene of its objects:
        returns (radiance per mesh, what was done: ``"relit"`` when only the lights changed,
        ``"kept"`` when nothing did, ``"rebaked"`` when objects changed (the changed ones are
        updated in the kept scene, and the library meshes only those whose geometry, placement
        or scale changed), ``"baked"`` for a new scene). Raises as :func:`bake.run_job`; a
        failure drops the kept scene."""
        items = [*job.meshes, *job.diffuse]
        names = tuple(m.object_name for m in items)
        options = dict(job.options)
        if options.get("method", "transcut") == "transcut":
            options.setdefault("edit_solver", RELIGHT_SOLVER)
        options_key, objects, lights = canonical(options), [object_key(m) for m in items], lights_key(job.lights)
        kept = self._take(names)
        if kept is not None and (
            kept.options != options_key or kept.scene.lib is not lib or not lib.has("tc_object_set_mesh")
        ):
            kept.close()
            kept = None
        if kept is None:
            scene, indices, results = bake_open(lib, job, progress, backends, radiosity, options)
            try:
                tets = self._tets(scene, indices[: len(job.meshes)])
            except BaseException:
                scene.close()
                raise
            self.bakes += 1
            self.meshed = tuple(m.object_name for m in job.meshes)
            kept, what = KeptBake(options_key, objects, lights, scene, indices, tets), "baked"
        else:
            try:
                results, what = self._update(kept, job, items, objects, lights, options, progress, backends, radiosity)
            except BaseException:
                kept.close()
                raise
            kept.objects, kept.lights = objects, lights
        if what in ("baked", "rebaked") and "edit_solver" in options and lib.has("tc_scene_relight"):
            kept.warm_up()
        self._put(names, kept)
        return results, what

    def _update(self, kept, job, items, objects, lights, options, progress, backends, radiosity) -> tuple:
        """Brings ``kept`` to the job's state and solves it (see :meth:`run`)."""
        scene = kept.scene
        changed = [i for i, (old, new) in enumerate(zip(kept.objects, objects, strict=True)) if old != new]
        for i in changed:
            item, idx = items[i], kept.indices[i]
            if kept.objects[i][0] != objects[i][0]:
                try:
                    scene.set_mesh(idx, item.positions, item.triangles)
                except transcut.TranscutError as exc:
                    raise BakeError(f"'{item.object_name}': {exc.message or exc.status_name}") from exc
            place_object(scene, idx, item)
        if kept.lights != lights:
            scene.clear_lights()
            add_lights(scene, job.lights)
        if changed:
            results = bake_scene(scene, kept.indices, job, progress, backends, radiosity, options)
            meshes = kept.indices[: len(job.meshes)]
            self.meshed = tuple(
                m.object_name for m, idx in zip(job.meshes, meshes, strict=True) if not scene.stats(idx)["mesh_reused"]
            )
            kept.tets = self._tets(scene, meshes)
            self.rebakes += 1
            return results, "rebaked"
        what = "kept"
        if kept.lights != lights:
            scene.relight(progress)
            self.relights += 1
            what = "relit"
        if backends is not None:
            backends.extend(backend_info(scene, idx, what == "relit") for idx in kept.indices[: len(job.meshes)])
        self.meshed = ()
        return read_results(scene, kept.indices, job), what

    @staticmethod
    def _tets(scene: transcut.Scene, indices: list) -> int:
        if not scene.lib.has("tc_object_stats"):
            return 0
        return sum(int(scene.stats(idx).get("tets", 0)) for idx in indices)

    def settle(self) -> None:
        """Waits for every kept scene's warm-up (:meth:`KeptBake.warm_up`)."""
        with self._lock:
            kept = list(self._bakes.values())
        for k in kept:
            k.settle()

    def drop_missing(self, exists: Callable[[str], bool]) -> int:
        """Closes the kept scenes with an object for which ``exists(name)`` is false; returns
        how many."""
        with self._lock:
            gone = [n for n in self._bakes if not all(exists(name) for name in n)]
            for n in gone:
                self._bakes.pop(n).close()
        return len(gone)

    def clear(self) -> None:
        """Closes every kept scene."""
        with self._lock:
            for kept in self._bakes.values():
                kept.close()
            self._bakes.clear()


#: The add-on's kept bakes.
STORE = KeptBakes()


class KeptLive:
    """Live Translucency for the methods other than PRT: the job baked once into a kept library
    scene, then each new state (a :class:`bake.BakeJob` of the same objects) brought in as Keep
    Bakes brings a rebake (:meth:`KeptBakes.run`): a light or world change relights, a medium
    change re-assembles without meshing, a moved or reshaped object is meshed again alone. The
    interface of ``live_native.LiveSession``: ``names``, ``job``, ``state``, ``radiance``,
    ``updates``, :meth:`apply`, :meth:`close`."""

    def __init__(self, lib: transcut.Library, job: BakeJob, progress: Callable[[str, float], bool] | None = None):
        self.lib = lib
        self.job = job
        self.names = [m.object_name for m in job.meshes]
        self.store = KeptBakes(budget_tets=2**62)
        self.radiance, self.outcome = self.store.run(lib, job, progress)
        # Live starts once its first change will be fast: the editors' setup done now.
        self.store.settle()
        self.state = job
        self.updates = 0

    def apply(self, job: BakeJob) -> list:
        """Brings the kept scene to ``job``; returns the radiance per object. Raises as
        :meth:`KeptBakes.run` (the kept scene is then dropped, and the next update bakes anew)."""
        self.radiance, self.outcome = self.store.run(self.lib, job)
        self.state = job
        self.updates += 1
        return self.radiance

    def close(self) -> None:
        self.store.clear()
