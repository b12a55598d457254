"""The bake operator, ``bpy.ops.object.transcut_bake()``, and the run every operator shares.

Run from the UI (``invoke``) an operator is modal: the library works on a thread, a
window-manager timer shows its progress (progress cursor and status bar), ESC cancels through the
library's progress callback. Called from a script or in background mode (``execute``) it runs
synchronously on the main thread between ``progress_begin`` and ``progress_end``. Either way
nothing changes unless every selected object was done; errors are reported with ``self.report``
(a script sees them as bpy's RuntimeError) and the operator returns CANCELLED. Registered with
undo.
"""

from __future__ import annotations

import threading

import bpy

from . import bake, kept_native, library, preferences


class RunnerOperator:
    """What the bake and the editing operators share: a runner (:class:`bake.BakeRunner`) that
    works in the library, started by ``invoke`` on a worker thread with a progress timer, or by
    ``execute`` on the main thread; ``modal`` shows the progress in the status bar and ESC
    cancels; ``cancel`` stops the library when Blender closes the operator.

    A subclass sets ``what`` (the word in its messages) and defines ``_runner_for(context)``
    (the runner for the selection; it raises ``BakeError`` saying what to select, or
    ``LibraryNotFound``) and ``_write(context, runner)`` (writes the results into Blender and
    returns the report's summary)."""

    bl_options = {"REGISTER", "UNDO"}
    what = "run"

    _runner = None
    _timer = None

    def _start(self, context):
        """The runner, or None after reporting why not."""
        try:
            runner = self._runner_for(context)
        except Exception as exc:  # BakeError, LibraryNotFound, TranscutError
            self.report({"ERROR"}, bake.error_message(exc, self.what))
            return None
        for w in runner.job.warnings:
            self.report({"WARNING"}, w)
        return runner

    def _finish(self, context, runner) -> set:
        """Writes the results of a run that succeeded; reports the outcome."""
        summary = ""
        if runner.error is None:
            try:
                summary = self._write(context, runner)
            except Exception as exc:
                runner.error = exc
        if runner.error is not None:
            self.report({"ERROR"}, bake.error_message(runner.error, self.what))
            return {"CANCELLED"}
        self.report({"INFO"}, summary)
        return {"FINISHED"}

    def execute(self, context):
        runner = self._start(context)
        if runner is None:
            return {"CANCELLED"}
        wm = context.window_manager
        wm.progress_begin(0, 100)
        record = runner.progress
        main = threading.main_thread()

        def progress(stage: str, fraction: float) -> bool:
            # The library reports from its worker threads too; only the main thread may touch wm.
            if threading.current_thread() is main:
                wm.progress_update(int(min(max(fraction, 0.0), 1.0) * 100))
            return record(stage, fraction)

        runner.progress = progress
        try:
            runner.run_here()
            wm.progress_update(100)
        finally:
            wm.progress_end()
        return self._finish(context, runner)

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
            runner.step(context)  # the runner's main-thread work between its library calls
            stage, fraction = runner.snapshot()
            context.window_manager.progress_update(int(fraction * 100))
            if context.workspace is not None:
                note = "cancelling…" if runner.cancelled else "ESC to cancel"
                context.workspace.status_text_set(f"TransCut {self.what}: {stage} {fraction * 100:.0f}% ({note})")
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


class OBJECT_OT_transcut_bake(RunnerOperator, bpy.types.Operator):
    """Bake subsurface scattering of the selected meshes into a colour attribute"""

    bl_idname = "object.transcut_bake"
    bl_label = "Bake Subsurface (TransCut)"
    what = "bake"

    @classmethod
    def poll(cls, context):
        return context.mode == "OBJECT"

    def _runner_for(self, context):
        lib = library.get(preferences.library_path(context))  # first: the Method menu lists its methods
        job = bake.prepare_job(context)
        settings = context.scene.transcut
        kept = None
        # A bake that takes no relight is not kept (a light change would fail instead of baking).
        if settings.keep_bakes and bake.relights(job.options):
            kept = kept_native.STORE
            kept.budget_tets = settings.kept_tets
        return bake.BakeRunner(lib, job, kept)

    def _write(self, context, runner) -> str:
        job = runner.job
        bake.write_results(context, job, runner.results)
        bake.record_bake(job, runner)
        total = sum(m.vertex_count for m in job.meshes)
        how = {
            "baked": "baked",
            "rebaked": "baked the kept scene of",
            "relit": "relit the kept bake of",
            "kept": "nothing changed since the kept bake of",
        }[runner.outcome]
        meshed = ""
        if runner.outcome == "rebaked":
            meshed = f"; tetrahedralised again: {', '.join(runner.kept.meshed) or 'none (the tets were kept)'}"
        return (
            f"{how} {len(job.meshes)} object(s), {total} vertices, into '{job.attribute_name}'"
            f" ({bake.backend_summary(runner.backends)}){bake.radiosity_summary(job, runner.radiosity)}{meshed}"
        )


register, unregister = bpy.utils.register_classes_factory((OBJECT_OT_transcut_bake,))
