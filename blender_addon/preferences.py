"""Add-on preferences: where the native library is, and whether it loaded.

Registered first and always (fail soft, as mitsuba-blender does): when the library cannot be
loaded the add-on still enables and this panel shows every path tried with its error.
"""

from __future__ import annotations

import bpy
from bpy.props import StringProperty

from . import library

ADDON_ID = __package__


def get(context=None):
    """The add-on's preferences, or None when the add-on was registered without ``addon_utils``."""
    context = context or bpy.context
    addon = context.preferences.addons.get(ADDON_ID)
    return addon.preferences if addon is not None else None


def library_path(context=None) -> str:
    """The library path set in the preferences, made absolute ('' when unset or not registered):
    what :func:`library.load` and :func:`library.get` take."""
    prefs = get(context)
    return bpy.path.abspath(prefs.library_path) if prefs is not None and prefs.library_path else ""


def _on_path_changed(_self, context):
    library.load(library_path(context))


class TRANSCUT_OT_reload_library(bpy.types.Operator):
    """Load the native library again (after building it or changing its path)"""

    bl_idname = "preferences.transcut_reload_library"
    bl_label = "Reload Library"
    bl_options = {"INTERNAL"}

    def execute(self, context):
        lib = library.load(library_path(context))
        if lib is None:
            self.report({"ERROR"}, library.state.error)
            return {"CANCELLED"}
        self.report({"INFO"}, f"libtranscut {lib.version_string} loaded from {lib.path}")
        return {"FINISHED"}


class TranscutPreferences(bpy.types.AddonPreferences):
    bl_idname = ADDON_ID

    library_path: StringProperty(
        name="Library Path",
        description=(
            "Full path of the libtranscut shared library; empty: the copy bundled with the extension, or TRANSCUT_LIB"
        ),
        subtype="FILE_PATH",
        default="",
        update=_on_path_changed,
    )

    def draw(self, context):
        layout = self.layout
        layout.prop(self, "library_path")
        draw_library_status(layout)
        layout.operator(TRANSCUT_OT_reload_library.bl_idname, icon="FILE_REFRESH")


def draw_library_status(layout) -> None:
    """Shows the loaded library, or each path tried and its error."""
    state = library.state
    box = layout.box()
    if state.lib is not None:
        box.label(text=f"libtranscut {state.lib.version_string}", icon="CHECKMARK")
        box.label(text=state.lib.path)
        return
    box.label(text="The native library is not loaded; baking is unavailable.", icon="ERROR")
    if not state.tried:
        box.label(text="No load attempted yet.")
    for path, why in state.tried:
        col = box.column(align=True)
        col.label(text=f"Tried: {path}")
        col.label(text=f"    {why}")


register, unregister = bpy.utils.register_classes_factory((TRANSCUT_OT_reload_library, TranscutPreferences))
