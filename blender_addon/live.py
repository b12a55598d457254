"""Live Translucency: after one bake of the selected meshes with the panel's method
(``transcut.live_start``: progress, ESC cancels, undo), changing a Principled BSDF's subsurface
inputs (or the object's preset or coefficients), moving or editing a light, the world, or the
unit scale updates the colour attribute in the viewport with no button pressed, until
``transcut.live_stop``, ESC or another file is loaded.

A ``depsgraph_update_post`` handler reads the scene's state after every change and, when it
differs from the last one asked for, hands it to the worker (:class:`live_native.LiveWorker`),
which applies only what changed and keeps one update in flight, the newest request next. A
timer writes each result into the attribute on the main thread; the status bar shows what
happened. In background mode (scripts, tests) the handler applies the change at once, before it
returns.

With PRT (:class:`live_native.LiveSession`) the state is the lights, media and scale: a
material edit re-weights the precomputed basis (microseconds per thousand vertices), a light
change is one relight; the precompute belongs to the meshes as they were, so when one moves or
changes shape Live Translucency stops and says so. With the other methods
(:class:`kept_native.KeptLive`) the state is a whole bake job: a light change relights the kept
scene, a medium change re-assembles without meshing, and a moved or reshaped object is meshed
again alone. Geometry is read again only in Object Mode, for objects the depsgraph updated, so
strokes in Edit or Sculpt Mode cost nothing until the mode is left.
"""

from __future__ import annotations

import dataclasses

import bpy
import numpy as np
from bpy.app.handlers import persistent

from . import bake, library, preferences
from .kept_native import KeptLive, object_key
from .lights import scene_lights, world_lights
from .live_native import LiveSession, LiveState, LiveWorker, lights_key
from .mesh_export import BakeError, gather_mesh, mm_per_unit, object_medium, world_matrix
from .operators import RunnerOperator

#: Seconds between the timer's looks at the worker.
POLL_SECONDS = 0.02


class PrecomputeInvalid(BakeError):
    """A live object was removed, moved or reshaped: its precompute no longer describes it."""


class Live:
    """The running Live Translucency: its worker, the objects it writes and what they were."""

    def __init__(self, context, worker: LiveWorker):
        session = worker.session
        self.worker = worker
        self.scene_name = context.scene.name
        self.attribute = session.job.attribute_name
        self.names = session.names
        self.vertex_counts = [m.original_vertex_count for m in session.job.meshes]
        self.matrices = [m.matrix_world for m in session.job.meshes]
        self.last_key = self.key(session.state)
        self.message = f"live: {len(self.names)} object(s)"
        self.writing = False
        self.object_mode = True

    def key(self, state) -> tuple:
        """A comparable form of a state (:meth:`state`)."""
        if isinstance(state, LiveState):
            return state.key()
        return lights_key(state.lights), tuple(object_key(m) for m in state.meshes)

    def state(self, scene, depsgraph):
        """The scene's state now: a :class:`LiveState` for PRT, a bake job for the other
        methods. Raises :class:`PrecomputeInvalid` when a live object is gone (or, for PRT,
        moved or reshaped), BakeError for what the user can fix in place."""
        if isinstance(self.worker.session, KeptLive):
            return self._job(scene, depsgraph)
        warnings: list = []
        media = []
        for name, count, matrix in zip(self.names, self.vertex_counts, self.matrices, strict=True):
            obj = bpy.data.objects.get(name)
            if obj is None or obj.type != "MESH":
                raise PrecomputeInvalid(f"'{name}' was removed")
            if len(obj.data.vertices) != count or not np.allclose(world_matrix(obj), matrix, rtol=0.0, atol=1e-9):
                raise PrecomputeInvalid(
                    f"'{name}' moved or changed shape; start Live Translucency again for a new precompute"
                )
            media.append(object_medium(obj, warnings))
        lights = scene_lights(depsgraph, warnings) + world_lights(scene.world, warnings)
        if not lights:
            raise BakeError("the scene has no lights and the world is black; add a light")
        return LiveState(lights, media, mm_per_unit(scene))

    def _job(self, scene, depsgraph):
        """The bake job of the live objects now: the last one with each object's placement,
        scale and medium read again, and the geometry of those the depsgraph updated (in Object
        Mode only: an edit counts when its mode is left)."""
        job = self.worker.session.state
        updated = {u.id.original.name for u in depsgraph.updates if isinstance(u.id, bpy.types.Object)}
        object_mode = bpy.context.mode == "OBJECT"
        warnings: list = []
        meshes = []
        for mesh in job.meshes:
            obj = bpy.data.objects.get(mesh.object_name)
            if obj is None or obj.type != "MESH":
                raise PrecomputeInvalid(f"'{mesh.object_name}' was removed")
            if object_mode and (obj.name in updated or not self.object_mode):
                fresh = gather_mesh(obj, depsgraph, scene, scene.transcut, warnings)
                if fresh.replace_mesh:
                    raise BakeError(f"'{obj.name}': its modifiers change the vertex count; live needs its own mesh")
                meshes.append(fresh)
            else:
                meshes.append(
                    dataclasses.replace(
                        mesh,
                        matrix_world=world_matrix(obj),
                        mm_per_unit=mm_per_unit(scene),
                        medium=object_medium(obj, warnings),
                    )
                )
        self.object_mode = object_mode
        lights = scene_lights(depsgraph, warnings) + world_lights(scene.world, warnings)
        if not lights:
            raise BakeError("the scene has no lights and the world is black; add a light")
        options = bake.bake_options(scene.transcut, job.options.get("method", "transcut"), mm_per_unit(scene))
        return dataclasses.replace(job, meshes=meshes, lights=lights, options=options, warnings=warnings)

    def write(self, results: list) -> None:
        """Each object's radiance into its attribute (objects gone since are skipped)."""
        self.writing = True
        try:
            for name, rgb in zip(self.names, results, strict=True):
                obj = bpy.data.objects.get(name)
                if obj is None or obj.type != "MESH" or len(obj.data.vertices) != rgb.shape[0]:
                    continue
                mesh = obj.data
                attr = mesh.color_attributes.get(self.attribute)
                if attr is None:
                    attr = mesh.color_attributes.new(self.attribute, "FLOAT_COLOR", "POINT")
                rgba = np.ones((rgb.shape[0], 4), dtype=np.float32)
                rgba[:, :3] = rgb
                attr.data.foreach_set("color", rgba.reshape(-1))
                mesh.update()
        finally:
            self.writing = False
        session = self.worker.session
        last = f", last {session.outcome}" if isinstance(session, KeptLive) else ""
        self.message = f"live: {session.updates} update(s){last}"


#: The running Live Translucency, or None.
_live: Live | None = None
#: Why Live Translucency last stopped by itself ("" when it did not), for the panel.
_stopped_because = ""


def active() -> bool:
    return _live is not None


def status() -> str:
    """The panel's line about Live Translucency: what it did last, or why it stopped."""
    return _live.message if _live is not None else _stopped_because


def start(context, session: LiveSession) -> None:
    """Keeps ``session`` live: its objects follow the scene from now on."""
    global _live
    stop()
    _live = Live(context, LiveWorker(session))
    if not bpy.app.background and not bpy.app.timers.is_registered(_poll):
        bpy.app.timers.register(_poll, first_interval=POLL_SECONDS)


def stop(message: str = "") -> None:
    """Ends Live Translucency (waits for the update in flight, frees the library's scene)."""
    global _live, _stopped_because
    live, _live = _live, None
    _stopped_because = f"stopped: {message}" if message else ""
    if bpy.app.timers.is_registered(_poll):
        bpy.app.timers.unregister(_poll)
    if live is not None:
        live.worker.close()


def _poll():
    """The timer: writes the worker's newest result, shows its error."""
    live = _live
    if live is None:
        return None
    results, error = live.worker.take()
    if results is not None:
        live.write(results)
    if error is not None:
        live.message = bake.error_message(error, "live update")
    return POLL_SECONDS


@persistent
def _on_depsgraph(scene, depsgraph) -> None:
    live = _live
    if live is None or live.writing or scene.name != live.scene_name:
        return
    try:
        state = live.state(scene, depsgraph)
    except PrecomputeInvalid as exc:
        stop(str(exc))
        return
    except BakeError as exc:
        live.message = str(exc)
        return
    key = live.key(state)
    if key == live.last_key:
        return
    live.last_key = key
    if bpy.app.background:
        # No event loop to run a timer: apply now, as a script expects.
        try:
            live.write(live.worker.session.apply(state))
        except BakeError as exc:
            live.message = str(exc)
    else:
        live.worker.submit(state)
        live.message = "live: updating…"


@persistent
def _on_load(*_args) -> None:
    stop()


class LiveRunner(bake.BakeRunner):
    """The first bake of Live Translucency, whose library scene is kept: PRT's precompute
    (:class:`live_native.LiveSession`) or a kept bake (:class:`kept_native.KeptLive`)."""

    session: LiveSession | KeptLive | None = None

    def _run(self) -> None:
        try:
            kind = LiveSession if self.job.options.get("method") == bake.PRT else KeptLive
            self.session = kind(self.lib, self.job, self.progress)
            self.results = self.session.radiance
        except BaseException as exc:  # reported by the main thread
            self.error = exc


class TRANSCUT_OT_live_start(RunnerOperator, bpy.types.Operator):
    """Bake the selected meshes with the panel's method, then update their colour attribute
    whenever a light, the world, their subsurface material or (except with PRT) their placement
    or shape changes (until stopped or ESC)"""

    bl_idname = "transcut.live_start"
    bl_label = "Live Translucency"
    what = "live translucency"

    @classmethod
    def poll(cls, context):
        return context.mode == "OBJECT"

    def _runner_for(self, context):
        stop()
        lib = library.get(preferences.library_path(context))  # first: the Method menu lists its methods
        job = bake.prepare_job(context)
        if not bake.relights(job.options):
            raise BakeError(
                "Live Translucency relights its bake, and a finite-volume or paper-stencil polygrid bake takes no "
                "relight; choose the FEM stencil"
            )
        changed = [m.object_name for m in job.meshes if m.replace_mesh]
        if changed:
            raise BakeError(
                f"'{changed[0]}': its modifiers change the vertex count, and Live Translucency writes on the "
                "object's own mesh; apply or disable them"
            )
        return LiveRunner(lib, job)

    def _write(self, context, runner) -> str:
        session = runner.session
        try:
            bake.write_results(context, runner.job, runner.results)
        except BaseException:
            session.close()
            raise
        start(context, session)
        if not bpy.app.background:
            bpy.ops.transcut.live_watch("INVOKE_DEFAULT")
        total = sum(m.vertex_count for m in runner.job.meshes)
        return (
            f"live translucency on for {len(runner.job.meshes)} object(s), {total} vertices: change a light, the "
            "world or the subsurface inputs to update; ESC or Stop Live to end"
        )

    def _finish(self, context, runner) -> set:
        result = super()._finish(context, runner)
        # A run that failed after the precompute (nothing written) frees its scene.
        if runner.session is not None and not active():
            runner.session.close()
        return result


class TRANSCUT_OT_live_stop(bpy.types.Operator):
    """Stop Live Translucency (the colour attribute keeps its last values)"""

    bl_idname = "transcut.live_stop"
    bl_label = "Stop Live"

    @classmethod
    def poll(cls, _context):
        return active()

    def execute(self, _context):
        stop()
        self.report({"INFO"}, "live translucency stopped")
        return {"FINISHED"}


class TRANSCUT_OT_live_watch(bpy.types.Operator):
    """Stops Live Translucency on ESC in the viewport; passes every other event on"""

    bl_idname = "transcut.live_watch"
    bl_label = "Live Translucency (ESC to stop)"
    bl_options = {"INTERNAL"}

    def invoke(self, context, _event):
        context.window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if not active():
            return {"FINISHED"}
        if event.type == "ESC" and event.value == "PRESS":
            stop()
            self.report({"INFO"}, "live translucency stopped")
            return {"FINISHED"}
        if context.workspace is not None and event.type == "TIMER":
            context.workspace.status_text_set(f"TransCut {status()} (ESC to stop)")
        return {"PASS_THROUGH"}


_classes = (TRANSCUT_OT_live_start, TRANSCUT_OT_live_stop, TRANSCUT_OT_live_watch)
_register_classes, _unregister_classes = bpy.utils.register_classes_factory(_classes)


def register():
    _register_classes()
    bpy.app.handlers.depsgraph_update_post.append(_on_depsgraph)
    bpy.app.handlers.load_pre.append(_on_load)


def unregister():
    stop()
    for handlers, fn in (
        (bpy.app.handlers.depsgraph_update_post, _on_depsgraph),
        (bpy.app.handlers.load_pre, _on_load),
    ):
        if fn in handlers:
            handlers.remove(fn)
    _unregister_classes()
