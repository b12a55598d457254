"""Bake Animation, ``bpy.ops.transcut.bake_animation()``, and the frame handler that plays it back.

**Bake Animation** bakes the selected translucent mesh (the active object, or the one selected
mesh) with the hierarchical dipole (the panel's dipole options; Incremental relinks only
what moved) at every frame of the scene's frame range (Frame Start to End by Frame Step): for each
frame it sets the frame (``scene.frame_set``), takes the evaluated mesh (armature, shape keys,
modifiers: ``obj.evaluated_get(depsgraph).to_mesh()``) and sends its positions to the library
(:class:`animation_native.AnimationBaker`, ``tc_object_set_positions``; a new bake when the vertex
count or the triangles change). The lights are gathered again at every frame (their transforms,
strength and colour as animated there, by keyframes, drivers or parents), and so is the world
when it is animated (else it is read once, when the operator starts); a frame whose lights differ
from the frame before relights the bake (``tc_scene_relight``) before its vertices move, so each
frame is lit by its own lights. The medium is taken as it is when the operator starts; the
object's own motion is followed (a frame's world matrix is folded into its positions). The
per-frame radiance (float16, (frames, vertices, 3)) goes to a cache file next to the .blend,
``//transcut_cache/<object>.npz``, or in a temporary folder of this session while the file is
unsaved (:func:`cache_path`); the object's custom property ``transcut_animation`` names the file
and the attribute. At the end the frame is set back to where it was and that frame's radiance
is written into the attribute.

Run from the UI (``invoke``) it is modal like the bake: each frame is evaluated on the main thread
and computed by the library on a worker thread, the progress shows in the cursor and the status
bar, ESC cancels (between frames and inside a frame's library call). From a script or in
background mode (``execute``) it runs on the main thread. A failure or a cancel leaves the mesh
untouched (the attribute is not written). Over an earlier Bake Animation of the object (its
property names a cache that can be read) it also leaves that cache and the property exactly as
they were, discarding the frames of the run that stopped ("cancelled …; previous cache kept"):
the cache never mixes the frames of two runs, and a re-bake replaces it only once it has baked
every frame (written whole to a temporary file, then renamed over it). Without an earlier cache
the frames baked until then are kept (written to the cache, where the handler finds them); when
no frame was baked nothing changes at all. The operator registers with undo (the attribute and
the custom property; the cache file stays).

**The handler** :func:`transcut_frame_change` (``frame_change_post``, persistent across file
loads, appended at register and removed at unregister) writes, for every object of the scene
with a ``transcut_animation`` property, the current frame's radiance from its cache into its
FLOAT_COLOR point attribute (the one the bake operator writes; created if missing), as the
timeline plays. Frames the cache does not hold, and frames whose vertex count is not the mesh's
(modifiers that change the topology), leave the attribute as it is.
"""

from __future__ import annotations

import os
import tempfile
import threading

import bpy
import numpy as np
from bpy.app.handlers import persistent

from . import animation_native, bake, edit_native, library, preferences, transcut
from .lights import scene_lights, world_lights
from .mesh_export import BakeError, evaluated_triangles, world_matrix
from .operators import RunnerOperator

#: The object's custom property naming its cache: {"cache", "attribute", "frame_start",
#: "frame_end", "frames"} ("cache" relative to the .blend, "//…", once the file is saved).
CACHE_PROPERTY = "transcut_animation"
#: The cache folder beside the .blend.
CACHE_FOLDER = "transcut_cache"

# Objects whose attribute the handler leaves alone: the one being baked (its frames are set by
# the bake, and a failed bake must leave its mesh as it was).
_suspended: set = set()
# Cache files read by the handler: absolute path → ((mtime_ns, size), Cache or None).
_memo: dict = {}
# The folder of the caches of unsaved files (one per session, made on first use).
_temp_folder: str | None = None


def cache_path(obj) -> tuple:
    """(absolute path, path to store) of ``obj``'s cache file: ``//transcut_cache/<name>.npz``
    beside a saved .blend, else in this session's temporary folder (both the same path)."""
    global _temp_folder
    name = bpy.path.clean_name(obj.name) + ".npz"
    if bpy.data.filepath:
        stored = f"//{CACHE_FOLDER}/{name}"
        return bpy.path.abspath(stored), stored
    if _temp_folder is None or not os.path.isdir(_temp_folder):
        _temp_folder = tempfile.mkdtemp(prefix="transcut_cache-")
    path = os.path.join(_temp_folder, name)
    return path, path


def load_cache(path: str) -> animation_native.Cache | None:
    """The cache file at ``path``, read once per version of the file; None when it is missing or
    not a cache."""
    try:
        st = os.stat(path)
    except OSError:
        _memo.pop(path, None)
        return None
    stamp = (st.st_mtime_ns, st.st_size)
    hit = _memo.get(path)
    if hit is not None and hit[0] == stamp:
        return hit[1]
    try:
        cache = animation_native.read_cache(path)
    except (OSError, ValueError, KeyError):
        cache = None
    _memo[path] = (stamp, cache)
    return cache


def cache_info(obj) -> tuple | None:
    """(absolute cache path, attribute name) of an object baked by Bake Animation, else None."""
    info = obj.get(CACHE_PROPERTY)
    if info is None:
        return None
    try:
        return bpy.path.abspath(str(info["cache"])), str(info["attribute"])
    except (KeyError, TypeError):
        return None


def write_radiance(mesh, name: str, rgb: np.ndarray) -> bool:
    """Writes ``rgb`` (vertex_count, 3) into the mesh's FLOAT_COLOR point attribute ``name``
    (made, and made active, when missing); False, writing nothing, when ``name`` is another kind
    of attribute."""
    attr = mesh.color_attributes.get(name)
    if attr is None:
        if mesh.attributes.get(name) is not None:
            return False
        attr = mesh.color_attributes.new(name, "FLOAT_COLOR", "POINT")
        mesh.color_attributes.active_color = attr
        mesh.color_attributes.render_color_index = mesh.color_attributes.active_color_index
    elif attr.data_type != "FLOAT_COLOR" or attr.domain != "POINT":
        return False
    rgba = np.ones((rgb.shape[0], 4), dtype=np.float32)
    rgba[:, :3] = rgb
    attr.data.foreach_set("color", rgba.reshape(-1))
    mesh.update()
    return True


def apply_frame(obj, frame: int) -> bool:
    """Writes frame ``frame``'s radiance from ``obj``'s cache into its attribute; False when
    there is nothing to write (no cache, a frame it does not hold, another vertex count)."""
    if obj.type != "MESH":
        return False
    info = cache_info(obj)
    if info is None:
        return False
    path, attribute = info
    cache = load_cache(path)
    rgb = None if cache is None else cache.frame(frame)
    if rgb is None or rgb.shape[0] != len(obj.data.vertices):
        return False
    return write_radiance(obj.data, attribute, rgb)


@persistent
def transcut_frame_change(scene, _depsgraph=None) -> None:
    """``frame_change_post``: every baked animation of ``scene`` shows its current frame."""
    for obj in scene.objects:
        if obj.name in _suspended or obj.get(CACHE_PROPERTY) is None:
            continue
        try:
            apply_frame(obj, scene.frame_current)
        except Exception as exc:  # never into Blender's frame change
            print(f"TransCut: '{obj.name}' at frame {scene.frame_current}: {type(exc).__name__}: {exc}")


def previous_cache(obj) -> tuple | None:
    """(absolute path, :class:`animation_native.Cache`) of the cache an earlier Bake Animation
    of ``obj`` left (its property names it and it reads as a cache), else None."""
    info = cache_info(obj)
    if info is None:
        return None
    cache = load_cache(info[0])
    return None if cache is None else (info[0], cache)


def frame_range(frames: list) -> str:
    """``frames 1–4 (4)`` for the frames of a run."""
    return f"frames {frames[0]}–{frames[-1]} ({len(frames)})" if frames else "no frames"


def animation_target(context):
    """The mesh Bake Animation bakes: the active object when it is a selected mesh, else the one
    selected mesh; BakeError saying what to select otherwise."""
    active = context.active_object
    if active is not None and active.type == "MESH" and active.select_get():
        return active
    meshes = [o for o in context.selected_objects if o.type == "MESH"]
    if len(meshes) == 1:
        return meshes[0]
    if not meshes:
        raise BakeError("select the translucent mesh object to bake the animation of")
    raise BakeError(f"{len(meshes)} meshes are selected and none is active; make the one to bake the active object")


def _animated(data) -> bool:
    """Whether ``data`` (an ID, or None) has an action or drivers."""
    anim = getattr(data, "animation_data", None)
    return anim is not None and (anim.action is not None or len(anim.drivers) > 0)


class AnimationRunner(bake.BakeRunner):
    """Bake Animation's run: per frame, the evaluation on the main thread (``frame_set``, the
    evaluated mesh) and the library's update (:class:`animation_native.AnimationBaker`), either
    all on the calling thread (:meth:`run_here`) or driven by the modal operator's timer
    (:meth:`step`), the library's part on a worker thread. Progress and cancel as
    :class:`bake.BakeRunner`. Each frame is lit by the lights of that frame (:meth:`_lights`).
    ``baked_frames`` / ``radiance`` (float16) hold the frames done; after a failure ``error``
    and ``failed_frame`` say what stopped it."""

    def __init__(self, lib: transcut.Library, job: bake.BakeJob, frames: list, original_frame: tuple):
        super().__init__(lib, job)
        self.frames = list(frames)
        self.original_frame = original_frame  # (frame, subframe) to go back to
        mesh = job.meshes[0]
        self.object_name = mesh.object_name
        self.matrix = mesh.matrix_world
        self._to_object = np.linalg.inv(self.matrix)
        self.baker = animation_native.AnimationBaker(lib, job)
        # The world's part of the job's lights (only the world makes environments), for the
        # frames of a world that is not animated.
        self._world = [light for light in job.lights if light.method.startswith("add_environment")]
        self.baked_frames: list = []
        self.radiance: list = []
        self.frame_ms: list = []
        self.failed_frame: int | None = None
        self._worker: threading.Thread | None = None
        self._pending: tuple | None = None
        self._finished = False

    # -- the parts of a frame --------------------------------------------------------------

    def _begin(self, k: int, frame: int) -> None:
        """Reports the frame's start; raises the cancel asked for (ESC, or a progress callback)."""
        if self.progress(f"frame {frame} ({k + 1}/{len(self.frames)})", k / len(self.frames)) or self.cancelled:
            raise transcut.TranscutError(transcut.TC_CANCELLED, "bake animation", f"cancelled at frame {frame}")

    def _lights(self, context) -> list:
        """The lights of the frame the scene is at (main thread): the light objects as evaluated
        there, and the world, read again only when it is animated (its environment image may be
        large). Their warnings were reported for the frame the operator started at."""
        specs = scene_lights(context.evaluated_depsgraph_get(), [])
        world = context.scene.world
        if world is not None and (_animated(world) or _animated(world.node_tree)):
            return specs + world_lights(world, [])
        return specs + self._world

    def _evaluate(self, context, frame: int) -> tuple:
        """Frame ``frame``'s evaluated mesh and lights (main thread): float32 positions in the
        object space of the first frame's world matrix, uint32 triangles, the frame's lights
        (:class:`lights.LightSpec` list)."""
        context.scene.frame_set(frame)
        obj = bpy.data.objects.get(self.object_name)
        if obj is None or obj.type != "MESH":
            raise BakeError(f"'{self.object_name}' was removed during the animation bake")
        positions, triangles, _ = evaluated_triangles(obj, context.evaluated_depsgraph_get())
        if triangles.size == 0:
            raise BakeError(f"'{obj.name}' has no faces at frame {frame}")
        if not np.all(np.isfinite(positions)):
            raise BakeError(f"'{obj.name}' has non-finite vertex coordinates at frame {frame}")
        m = world_matrix(obj)
        if not np.array_equal(m, self.matrix):  # the object moved: into the bake's object space
            to_first = self._to_object @ m
            positions = (positions.astype(np.float64) @ to_first[:3, :3].T + to_first[:3, 3]).astype(np.float32)
        return positions, triangles, self._lights(context)

    def _solve(
        self, k: int, frame: int, positions: np.ndarray, triangles: np.ndarray, lights: list | None = None
    ) -> np.ndarray:
        """The library's part of a frame (any thread), under ``lights`` (None: the job's)."""
        count = len(self.frames)
        label = f"frame {frame} ({k + 1}/{count})"

        def report(stage: str, fraction: float) -> bool:
            return self.progress(f"{label}: {stage}", (k + min(max(fraction, 0.0), 1.0)) / count)

        rgb = self.baker.frame(positions, triangles, report, lights)
        if not np.all(np.isfinite(rgb)):
            raise BakeError(f"'{self.object_name}': the library returned non-finite radiance at frame {frame}")
        if rgb.size and float(np.abs(rgb).max()) > animation_native.FLOAT16_MAX:
            raise BakeError(
                f"'{self.object_name}': radiance {float(np.abs(rgb).max()):.4g} at frame {frame} is beyond the "
                "cache's float16 range; lower the lights' strength"
            )
        return rgb

    def _record(self, frame: int, rgb: np.ndarray) -> None:
        self.baked_frames.append(frame)
        self.radiance.append(rgb.astype(np.float16))
        self.frame_ms.append(self.baker.last_ms)

    def _fail(self, exc: BaseException, frame: int) -> None:
        self.error = exc
        self.failed_frame = frame
        self._finished = True

    # -- the two ways to run -----------------------------------------------------------------

    def run_here(self) -> None:
        """Every frame on the calling thread (the main thread: execute, background mode)."""
        for k, frame in enumerate(self.frames):
            try:
                self._begin(k, frame)
                self._record(frame, self._solve(k, frame, *self._evaluate(bpy.context, frame)))
            except BaseException as exc:  # reported by the operator
                self._fail(exc, frame)
                return
        self.progress("done", 1.0)
        self._finished = True

    def start(self) -> None:
        """Modal: nothing to start; :meth:`step` starts each frame at the timer's ticks."""

    def step(self, context) -> None:
        """One tick of the modal operator's timer (main thread): collects the frame the worker
        finished, then evaluates the next frame and starts its library part on a worker."""
        if self._finished:
            return
        if self._worker is not None:
            if self._worker.is_alive():
                return
            self._worker = None
            frame, out = self._pending
            if "error" in out:
                self._fail(out["error"], frame)
                return
            self._record(frame, out["rgb"])
        k = len(self.baked_frames)
        if k == len(self.frames):
            self.progress("done", 1.0)
            self._finished = True
            return
        frame = self.frames[k]
        try:
            self._begin(k, frame)
            evaluated = self._evaluate(context, frame)
        except BaseException as exc:
            self._fail(exc, frame)
            return
        out: dict = {}

        def work() -> None:
            try:
                out["rgb"] = self._solve(k, frame, *evaluated)
            except BaseException as exc:  # collected by the next step
                out["error"] = exc

        self._pending = (frame, out)
        self._worker = threading.Thread(target=work, name="transcut-animation", daemon=True)
        self._worker.start()

    def done(self) -> bool:
        return self._finished

    def wait(self, timeout: float | None = None) -> bool:
        if self._worker is not None:
            self._worker.join(timeout)
        return self._worker is None or not self._worker.is_alive()

    def close(self) -> None:
        """Frees the library's scene."""
        self.baker.close()


def _restore_frame(context, runner: AnimationRunner) -> None:
    """Back to the frame the run started at (the handler still leaving the object alone), then
    the handler may write the object again."""
    try:
        frame, subframe = runner.original_frame
        context.scene.frame_set(frame, subframe=subframe)
    finally:
        _suspended.discard(runner.object_name)


class TRANSCUT_OT_bake_animation(RunnerOperator, bpy.types.Operator):
    """Bake the selected translucent mesh at every frame of the scene's frame range with the hierarchical dipole (armature, shape keys, modifiers); the timeline then plays the baked radiance in its colour attribute"""  # noqa: E501

    bl_idname = "transcut.bake_animation"
    bl_label = "Bake Animation"
    what = "animation bake"

    @classmethod
    def poll(cls, context):
        if context.mode != "OBJECT":
            cls.poll_message_set("works in Object Mode")
            return False
        return True

    def _runner_for(self, context):
        obj = animation_target(context)
        lib = library.get(preferences.library_path(context))
        edit_native.require(lib, animation_native.ANIMATION_FUNCTIONS, "Bake Animation")
        if bake.DIPOLE not in [name for name, _ in lib.methods()]:
            raise BakeError(
                f"Bake Animation needs the {bake.DIPOLE} method; {lib.path} ({lib.version_string}) does not have it"
            )
        scene = context.scene
        frames = list(range(scene.frame_start, scene.frame_end + 1, max(1, scene.frame_step)))
        job = bake.prepare_job(context, [obj], method=bake.DIPOLE, animated=True)
        runner = AnimationRunner(lib, job, frames, (scene.frame_current, scene.frame_subframe))
        _suspended.add(obj.name)  # last: nothing can fail between this and the run's end
        return runner

    def _finish(self, context, runner) -> set:
        """Writes the frames baked to the cache (all; or those before a failure or a cancel when
        the object had no cache before: an earlier cache stays as it was then), goes back to the
        first frame and, after a run that succeeded, writes its radiance; reports."""
        runner.wait()
        runner.close()
        obj = bpy.data.objects.get(runner.object_name)
        previous = None if obj is None else previous_cache(obj)
        kept, path, cache_error = "", "", None
        try:
            frames = runner.baked_frames
            # A run that stopped over an earlier cache leaves it whole rather than mix the two.
            if frames and obj is not None and (runner.error is None or previous is None):
                path, stored = cache_path(obj)
                attribute = runner.job.attribute_name
                animation_native.write_cache(path, frames, runner.radiance, obj.name, attribute)
                _memo.pop(path, None)
                obj[CACHE_PROPERTY] = {
                    "cache": stored,
                    "attribute": attribute,
                    "frame_start": frames[0],
                    "frame_end": frames[-1],
                    "frames": len(frames),
                }
                kept = f"{frame_range(frames)} kept in {path}"
        except Exception as exc:
            cache_error = exc
        finally:
            _restore_frame(context, runner)
        error = runner.error
        if error is None and cache_error is not None:
            error = BakeError(f"the animation cache could not be written: {cache_error}")
        if error is None and obj is None:
            error = BakeError(f"'{runner.object_name}' was removed during the animation bake")
        if error is not None:
            self.report({"ERROR"}, self._failure(runner, error, kept, cache_error, previous))
            return {"CANCELLED"}
        shown = apply_frame(obj, context.scene.frame_current)
        n = len(obj.data.vertices)
        other = [f for f, rgb in zip(runner.baked_frames, runner.radiance, strict=True) if len(rgb) != n]
        if other:
            self.report(
                {"WARNING"},
                f"'{obj.name}': at {len(other)} frame(s) (first {other[0]}) the evaluated mesh has another vertex "
                f"count than the mesh ({n}); their radiance is in the cache but cannot be shown in the attribute",
            )
        ms = sum(runner.frame_ms) / max(1, len(runner.frame_ms))
        self.report(
            {"INFO"},
            f"baked {len(runner.baked_frames)} frame(s) of '{obj.name}' with the hierarchical dipole into "
            f"'{runner.job.attribute_name}' ({ms:.0f} ms per frame, {runner.baker.bakes} bake(s)); cache {path}"
            + ("" if shown else f"; frame {context.scene.frame_current} is not in the cache"),
        )
        return {"FINISHED"}

    def _failure(self, runner, error, kept: str, cache_error, previous: tuple | None = None) -> str:
        what = f"frame {runner.failed_frame}" if runner.failed_frame is not None else "the end"
        if isinstance(error, transcut.TranscutError) and error.status == transcut.TC_CANCELLED:
            text = f"{self.what} cancelled at {what}"
        else:
            text = f"{bake.error_message(error, self.what)} (at {what})"
        if kept:
            text += f"; {kept}; the mesh was not changed"
        elif previous is not None:
            path, cache = previous
            text += (
                f"; previous cache kept ({frame_range(cache.frames.tolist())} in {path}); the frames of this run "
                "were discarded and the mesh was not changed"
            )
        elif cache_error is not None and runner.error is not None:
            text += f"; the frames baked could not be kept: {cache_error}"
        else:
            text += "; nothing was changed"
        return text

    def cancel(self, context):
        # Blender is closing the operator: stop the library, free it, go back to the first frame.
        runner = self._runner
        super().cancel(context)
        if runner is not None:
            runner.close()
            try:
                _restore_frame(context, runner)
            except Exception:  # the window or the file is going away
                _suspended.discard(runner.object_name)


_register_classes, _unregister_classes = bpy.utils.register_classes_factory((TRANSCUT_OT_bake_animation,))


def _remove_handler() -> None:
    """Takes this module's frame handler (also one of an earlier load of it) off the list."""
    handlers = bpy.app.handlers.frame_change_post
    for h in list(handlers):
        if getattr(h, "__name__", "") == transcut_frame_change.__name__ and getattr(h, "__module__", "") == __name__:
            handlers.remove(h)


def register():
    _register_classes()
    _remove_handler()
    bpy.app.handlers.frame_change_post.append(transcut_frame_change)


def unregister():
    global _temp_folder
    _remove_handler()
    _unregister_classes()
    _suspended.clear()
    _memo.clear()
    if _temp_folder is not None:
        try:
            os.rmdir(_temp_folder)  # only when empty: a cache there stays where its object says
            _temp_folder = None
        except OSError:
            pass
