"""The "TransCut" tab of the 3D viewport's sidebar (N panel): bake settings, the active object's
medium, the bake button, and the library status when it is not loaded."""

from __future__ import annotations

import bpy

from . import library
from .edit_ops import TRANSCUT_OT_cut_with_object, TRANSCUT_OT_paint_medium
from .operators import OBJECT_OT_transcut_bake
from .preferences import draw_library_status


class VIEW3D_PT_transcut(bpy.types.Panel):
    bl_label = "Subsurface Bake"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "TransCut"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        layout.use_property_decorate = False
        settings = context.scene.transcut
        col = layout.column()
        col.prop(settings, "attribute_name")
        col.prop(settings, "tets")
        col.prop(settings, "tolerance")
        col.prop(settings, "shadows")
        col.prop(settings, "backend")
        col.prop(settings, "apply_modifiers")

        obj = context.object
        if obj is not None and obj.type == "MESH":
            box = layout.box()
            box.label(text=f"Medium of '{obj.name}'", icon="MATERIAL")
            box.prop(obj.transcut, "medium_source")
            if obj.transcut.medium_source == "PRESET":
                box.prop(obj.transcut, "preset")
            elif obj.transcut.medium_source == "COEFFICIENTS":
                box.prop(obj.transcut, "sigma_a")
                box.prop(obj.transcut, "sigma_s_prime")
                box.prop(obj.transcut, "eta")
                box.prop(obj.transcut, "g")
            else:
                box.label(text="Principled BSDF subsurface inputs")

        layout.operator(OBJECT_OT_transcut_bake.bl_idname, icon="SHADING_RENDERED")
        row = layout.row(align=True)
        row.operator(TRANSCUT_OT_cut_with_object.bl_idname, icon="MOD_BOOLEAN")
        row.operator(TRANSCUT_OT_paint_medium.bl_idname, icon="BRUSH_DATA")
        if library.state.lib is None:
            draw_library_status(layout)


classes = (VIEW3D_PT_transcut,)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
