"""What Live Translucency runs in the library (no ``bpy``): one PRT bake kept open, and the
updates that follow the scene without a new precompute.

:class:`LiveSession` bakes the job's meshes with the PRT method once (the precompute, read from
the cache folder when it holds it) and keeps the library's scene. :meth:`LiveSession.apply`
then brings it to a new state: a changed medium is a re-weighting of the object's basis
(``tc_object_prt_set_medium_artist`` / ``_set_medium``), a changed unit scale a scale change
(``tc_object_prt_set_scale``), changed lights or world one relight (``tc_scene_relight``); an
unchanged part costs nothing. Each result equals a fresh PRT bake of the same state.

:class:`LiveWorker` runs :meth:`LiveSession.apply` on a thread and coalesces bursts: while one
update runs, the requests that arrive are reduced to the newest, which runs next, so dragging a
slider never queues work behind the pointer.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from . import transcut
from .bake import PRT, BakeJob, build_scene
from .mesh_export import BakeError


def canonical(value):
    """A comparable form of a light's or medium's keyword arguments (arrays as nested tuples)."""
    if isinstance(value, dict):
        return tuple(sorted((k, canonical(v)) for k, v in value.items()))
    if isinstance(value, np.ndarray):
        return canonical(value.tolist())
    if isinstance(value, (list, tuple)):
        return tuple(canonical(v) for v in value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    return value


def lights_key(lights: list) -> tuple:
    """A comparable form of a ``lights.LightSpec`` list."""
    return tuple((light.method, canonical(light.kwargs)) for light in lights)


def medium_key(medium) -> tuple:
    """A comparable form of a ``mesh_export.MediumSpec``."""
    return medium.method, canonical(medium.kwargs), medium.surface


@dataclass(frozen=True)
class LiveState:
    """What the radiance depends on beyond the precompute: the lights (``lights.LightSpec``
    list), each object's medium (``mesh_export.MediumSpec``, in the job's object order) and the
    scene's millimetres per unit."""

    lights: list
    media: list
    mm_per_unit: float

    def key(self) -> tuple:
        return lights_key(self.lights), tuple(medium_key(m) for m in self.media), float(self.mm_per_unit)


class LiveSession:
    """A PRT bake of ``job`` kept for updates (see the module documentation)."""

    def __init__(self, lib: transcut.Library, job: BakeJob, progress: Callable[[str, float], bool] | None = None):
        if job.options.get("method") != PRT:
            raise BakeError("Live Translucency runs the PRT method")
        self.lib = lib
        self.job = job
        self.names = [m.object_name for m in job.meshes]
        self.scene, self.indices = build_scene(lib, job)
        self.state = LiveState(list(job.lights), [m.medium for m in job.meshes], job.meshes[0].mm_per_unit)
        try:
            self.scene.bake(progress=progress, **job.options)
            self.radiance = [self._radiance(i) for i in range(len(self.names))]
        except BaseException:
            self.scene.close()
            raise
        self.updates = 0

    def _radiance(self, i: int) -> np.ndarray:
        rgb = self.scene.radiance(self.indices[i])
        if rgb.shape[0] != self.job.meshes[i].vertex_count or not np.all(np.isfinite(rgb)):
            raise BakeError(f"'{self.names[i]}': the library returned {rgb.shape[0]} values or non-finite radiance")
        return self.state.media[i].seen(rgb)

    def _set_medium(self, i: int, medium) -> None:
        idx = self.indices[i]
        where = f"'{self.names[i]}' ({medium.source})"
        try:
            if medium.method == "set_medium_artist":
                self.scene.prt_set_medium_artist(idx, **medium.kwargs)
            elif medium.method == "set_medium_preset":
                m = self.lib.medium_preset(medium.kwargs["name"])
                self.scene.prt_set_medium(idx, list(m.sigma_a), list(m.sigma_s_prime), m.eta, m.g)
            else:
                self.scene.prt_set_medium(idx, **medium.kwargs)
        except transcut.TranscutError as exc:
            raise BakeError(f"{where}: {exc.message or exc.status_name}") from exc

    def apply(self, state: LiveState) -> list:
        """Brings the scene to ``state``; returns the radiance per object (float32 (n, 3)).
        Raises :class:`BakeError` naming the object or light at fault; what was applied before
        the failure stays (the next request starts from it)."""
        old = self.state
        rescaled = state.mm_per_unit != old.mm_per_unit
        if rescaled:
            for idx in self.indices:
                self.scene.prt_set_scale(idx, state.mm_per_unit)
            self.state = LiveState(old.lights, old.media, state.mm_per_unit)
        media = list(self.state.media)
        for i, (new, now) in enumerate(zip(state.media, media, strict=True)):
            # An artist radius is in scene units: a new scale is a new medium in mm⁻¹ too.
            if medium_key(new) != medium_key(now) or (rescaled and new.method == "set_medium_artist"):
                self._set_medium(i, new)
                media[i] = new
                self.state = LiveState(self.state.lights, list(media), self.state.mm_per_unit)
        if lights_key(state.lights) != lights_key(self.state.lights):
            self.scene.clear_lights()
            try:
                for light in state.lights:
                    getattr(self.scene, light.method)(**light.kwargs)
                self.scene.relight()
            except transcut.TranscutError as exc:
                # The scene's lights are the new ones but unsolved: put the old ones back.
                self.scene.clear_lights()
                for light in self.state.lights:
                    getattr(self.scene, light.method)(**light.kwargs)
                raise BakeError(f"relight: {exc.message or exc.status_name}") from exc
            self.state = LiveState(list(state.lights), self.state.media, self.state.mm_per_unit)
        self.radiance = [self._radiance(i) for i in range(len(self.names))]
        self.updates += 1
        return self.radiance

    def close(self) -> None:
        self.scene.close()


class LiveWorker:
    """Applies the newest requested :class:`LiveState` to a :class:`LiveSession` on a worker
    thread, one update in flight; the main thread collects the results with :meth:`take`."""

    def __init__(self, session: LiveSession):
        self.session = session
        self._lock = threading.Lock()
        self._pending: LiveState | None = None
        self._thread: threading.Thread | None = None
        self._result: list | None = None
        self._error: BaseException | None = None
        self.requested = 0
        self.applied = 0

    def submit(self, state: LiveState) -> None:
        """Asks for ``state``; replaces a request not yet started."""
        with self._lock:
            self._pending = state
            self.requested += 1
            if self._thread is None or not self._thread.is_alive():
                self._thread = threading.Thread(target=self._loop, name="transcut-live", daemon=True)
                self._thread.start()

    def _loop(self) -> None:
        while True:
            with self._lock:
                state, self._pending = self._pending, None
                if state is None:
                    return
            try:
                result = self.session.apply(state)
                with self._lock:
                    self._result, self._error = result, None
                    self.applied += 1
            except BaseException as exc:  # shown by the main thread
                with self._lock:
                    self._error = exc

    def busy(self) -> bool:
        with self._lock:
            return self._pending is not None or (self._thread is not None and self._thread.is_alive())

    def wait(self, timeout: float | None = None) -> bool:
        """Waits until no update runs or is asked for (at most ``timeout`` seconds); returns
        whether the worker is idle."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.busy():
            with self._lock:
                thread = self._thread
            if thread is not None:
                left = None if deadline is None else max(deadline - time.monotonic(), 0.0)
                thread.join(left)
            if deadline is not None and time.monotonic() >= deadline:
                return not self.busy()
        return True

    def take(self) -> tuple:
        """(the newest radiance not yet taken or None, the last error or None)."""
        with self._lock:
            result, self._result = self._result, None
            error, self._error = self._error, None
            return result, error

    def close(self, timeout: float | None = None) -> None:
        """Waits for the update in flight, then frees the library's scene."""
        with self._lock:
            self._pending = None
            thread = self._thread
        if thread is not None:
            thread.join(timeout)
        self.session.close()
