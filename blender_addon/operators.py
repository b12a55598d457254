"""The bake operator: ``bpy.ops.object.transcut_bake()``.

Run from the UI (``invoke``) it is modal: the library works on a thread, a window-manager timer
shows its progress (progress cursor and status bar), ESC cancels through the library's progress
callback. Called from a script or in background mode (``execute``) it bakes synchronously. Either
way nothing changes unless every selected object baked; errors are reported with
``self.report`` and the operator returns CANCELLED. Registered with undo.
"""

from __future__ import annotations

import bpy

from . import bake, library
from .lights import scene_lights, world_lights
from .mesh_export import BakeError, gather


def prepare(context) -> bake.BakeJob:
    """Gathers objects, lights and options; raises BakeError / LibraryNotFound before any work."""
    warnings: list = []
    meshes = gather(context, warnings)
    depsgraph = context.evaluated_depsgraph_get()
    lights = scene_lights(depsgraph, warnings) + world_lights(context.scene.world, warnings)
    if not lights:
        raise BakeError("the scene has no lights (and the world is black); add a light to bake")
    settings = context.scene.transcut
    options = dict(
        tets=settings.tets,
        tolerance=settings.tolerance,
        shadows=1 if settings.shadows else 0,
        backend=settings.backend.lower(),
    )
    return bake.BakeJob(meshes, lights, options, settings.attribute_name, warnings)


class RunnerModal:
    """The modal run the bake and the editing operators share: ``invoke`` (background mode:
    ``execute``) starts the runner made by ``_start`` on a worker thread with a progress timer;
    ``modal`` shows the progress in the status bar, ESC cancels, and the run ends through
    ``_finish``; ``cancel`` stops the library when Blender closes the operator. A subclass
    defines ``execute``, ``_start(context)`` (the runner, or None after reporting why not) and
    ``_finish(context, runner)`` (the operator's result), and may override ``_status_prefix``."""

    _runner = None
    _timer = None

    def _status_prefix(self) -> str:
        return "TransCut"

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        runner = self._start(context)
        if runner is None:
            return {"CANCELLED"}
        self._runner = runner
        wm = context.window_manager
        wm.progress_begin(0, 100)
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.modal_handler_add(self)
        runner.start()
        return {"RUNNING_MODAL"}

    def _end_ui(self, context) -> None:
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)

    def modal(self, context, event):
        runner = self._runner
        if event.type == "ESC" and event.value == "PRESS":
            runner.cancel()
        if event.type == "TIMER":
            stage, fraction = runner.snapshot()
            context.window_manager.progress_update(int(fraction * 100))
            if context.workspace is not None:
                note = "cancelling…" if runner.cancelled else "ESC to cancel"
                context.workspace.status_text_set(f"{self._status_prefix()}: {stage} {fraction * 100:.0f}% ({note})")
            if runner.done():
                self._end_ui(context)
                return self._finish(context, runner)
        # The scene must not change under the library: swallow everything else.
        return {"RUNNING_MODAL"}

    def cancel(self, context):
        # Blender is closing the operator (e.g. the window closed): stop the library, wait.
        if self._runner is not None:
            self._runner.cancel()
            self._runner.wait()
        self._end_ui(context)


class OBJECT_OT_transcut_bake(RunnerModal, bpy.types.Operator):
    """Bake subsurface scattering of the selected meshes into a colour attribute"""

    bl_idname = "object.transcut_bake"
    bl_label = "Bake Subsurface (TransCut)"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return context.mode == "OBJECT"

    def _start(self, context):
        """Job and library, or None after reporting why not."""
        try:
            job = prepare(context)
            lib = library.get(context)
        except Exception as exc:  # BakeError, LibraryNotFound
            self.report({"ERROR"}, bake.error_message(exc))
            return None
        for w in job.warnings:
            self.report({"WARNING"}, w)
        return bake.BakeRunner(lib, job)

    def _finish(self, context, runner) -> set:
        if runner.error is None:
            try:
                bake.write_results(context, runner.job, runner.results)
            except Exception as exc:
                runner.error = exc
        if runner.error is not None:
            self.report({"ERROR"}, bake.error_message(runner.error))
            return {"CANCELLED"}
        total = sum(m.vertex_count for m in runner.job.meshes)
        self.report(
            {"INFO"},
            f"baked {len(runner.job.meshes)} object(s), {total} vertices, into '{runner.job.attribute_name}'"
            f" ({bake.backend_summary(runner.backends)})",
        )
        return {"FINISHED"}

    def execute(self, context):
        runner = self._start(context)
        if runner is None:
            return {"CANCELLED"}
        runner.run_here()
        return self._finish(context, runner)

def menu_func(self, _context):
    self.layout.separator()
    self.layout.operator(OBJECT_OT_transcut_bake.bl_idname, icon="SHADING_RENDERED")


classes = (OBJECT_OT_transcut_bake,)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.VIEW3D_MT_object.append(menu_func)


def unregister():
    bpy.types.VIEW3D_MT_object.remove(menu_func)
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
