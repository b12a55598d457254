"""The "TransCut" tab of the 3D viewport's sidebar (N panel): the method and the bake settings
(TransCut's Resolution, Tolerance and Backend while TransCut is the method, the hierarchical
dipole's Oracle with its Opening Angle or Epsilon 1 and 2, Edge Rule, Receivers, and Mode with
the incremental mode's Budget while it is, radiosity's Patch Size, Rays per Patch, Iteration,
Bounces (Jacobi only), Radiosity Tolerance and Write Surroundings after TransCut's three, the
polygrid's Grid Nodes, Cube Size, Cells per Cube and Stencil after TransCut's Tolerance and
Backend), the active object's medium and its last bake (time, what was done, tets, iterations,
clamped vertices), the bake, its preview, Bake Animation and editing buttons, and the library status
when it is not loaded; the same operators in the Object menu."""

from __future__ import annotations

import bpy

from . import library, live
from .animation_ops import TRANSCUT_OT_bake_animation
from .bake import DIPOLE, POLYGRID, PRT, RADIOSITY
from .edit_ops import TRANSCUT_OT_cut_with_object, TRANSCUT_OT_paint_medium
from .live import TRANSCUT_OT_live_start, TRANSCUT_OT_live_stop
from .operators import OBJECT_OT_transcut_bake
from .preferences import draw_library_status
from .preview import TRANSCUT_OT_preview_bake, TRANSCUT_OT_restore_materials
from .properties import draw_medium
from .texture_ops import OBJECT_OT_transcut_bake_texture


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
        col.prop(settings, "method")
        col.prop(settings, "attribute_name")
        if settings.method == DIPOLE:
            col.prop(settings, "dipole_oracle")
            if settings.dipole_oracle == "PAPER":
                col.prop(settings, "dipole_eps1")
                col.prop(settings, "dipole_eps2")
            else:
                col.prop(settings, "dipole_theta")
            col.prop(settings, "dipole_rule")
            col.prop(settings, "dipole_receivers")
            col.prop(settings, "dipole_mode")
            if settings.dipole_mode == "INCREMENTAL":
                col.prop(settings, "dipole_budget")
        elif settings.method == PRT:
            col.prop(settings, "prt_samples")
            col.prop(settings, "prt_terms")
            col.prop(settings, "prt_basis")
            col.prop(settings, "prt_keep")
        else:
            if settings.method in ("transcut", RADIOSITY):
                col.prop(settings, "tets")
            if settings.method in ("transcut", RADIOSITY):
                col.prop(settings, "grading")
                if settings.grading == "GRADED":
                    col.prop(settings, "grading_layers")
                col.prop(settings, "discretization")
            col.prop(settings, "tolerance")
            col.prop(settings, "backend")
        if settings.method == POLYGRID:
            col.prop(settings, "polygrid_nodes")
            col.prop(settings, "polygrid_cube")
            col.prop(settings, "polygrid_resolution")
            col.prop(settings, "polygrid_stencil")
        if settings.method == RADIOSITY:
            col.prop(settings, "radiosity_patch_size")
            col.prop(settings, "radiosity_rays")
            col.prop(settings, "radiosity_iteration")
            if settings.radiosity_iteration == "JACOBI":
                col.prop(settings, "radiosity_bounces")
            col.prop(settings, "radiosity_tolerance")
            col.prop(settings, "radiosity_write_surroundings")
        col.prop(settings, "shadows")
        col.prop(settings, "keep_bakes")
        col.prop(settings, "apply_modifiers")

        obj = context.object
        if obj is not None and obj.type == "MESH":
            box = layout.box()
            box.label(text=f"Medium of '{obj.name}'", icon="MATERIAL")
            draw_medium(box, obj.transcut, ("sigma_a", "sigma_s_prime", "eta", "g"))
            draw_last_bake(box, obj.transcut.last_bake)

        layout.operator(OBJECT_OT_transcut_bake.bl_idname, icon="SHADING_RENDERED")
        layout.operator(OBJECT_OT_transcut_bake_texture.bl_idname, icon="TEXTURE")
        row = layout.row(align=True)
        row.operator(TRANSCUT_OT_preview_bake.bl_idname, icon="MATERIAL")
        row.operator(TRANSCUT_OT_restore_materials.bl_idname, icon="LOOP_BACK")
        if live.active():
            layout.operator(TRANSCUT_OT_live_stop.bl_idname, icon="PAUSE")
        else:
            layout.operator(TRANSCUT_OT_live_start.bl_idname, icon="PLAY")
        if live.status():
            layout.label(text=live.status(), icon="INFO")
        layout.operator(TRANSCUT_OT_bake_animation.bl_idname, icon="RENDER_ANIMATION")
        row = layout.row(align=True)
        row.operator(TRANSCUT_OT_cut_with_object.bl_idname, icon="MOD_BOOLEAN")
        row.operator(TRANSCUT_OT_paint_medium.bl_idname, icon="BRUSH_DATA")
        if library.state.lib is None:
            draw_library_status(layout)


def draw_last_bake(layout, report) -> None:
    """The object's last bake: time, what was done, tets, iterations, clamped vertices."""
    if not report.valid:
        return
    col = layout.column(align=True)
    kept = ", tets kept" if report.mesh_reused and report.outcome == "rebaked" else ""
    col.label(text=f"Last bake: {report.seconds:.2f} s, {report.outcome} ({report.method}{kept})", icon="TIME")
    if report.tets:
        col.label(text=f"{report.tets:,} tets, iterations {'/'.join(str(i) for i in report.iterations)}")
    if report.clamped_vertices:
        col.label(text=f"{report.clamped_vertices:,} vertices clamped at 0: raise Resolution", icon="ERROR")


def menu_func(self, _context):
    """The operators at the end of the 3D view's Object menu."""
    self.layout.separator()
    self.layout.operator(OBJECT_OT_transcut_bake.bl_idname, icon="SHADING_RENDERED")
    self.layout.operator(OBJECT_OT_transcut_bake_texture.bl_idname, icon="TEXTURE")
    self.layout.operator(TRANSCUT_OT_preview_bake.bl_idname, icon="MATERIAL")
    self.layout.operator(TRANSCUT_OT_bake_animation.bl_idname, icon="RENDER_ANIMATION")
    self.layout.operator(TRANSCUT_OT_cut_with_object.bl_idname, icon="MOD_BOOLEAN")
    self.layout.operator(TRANSCUT_OT_paint_medium.bl_idname, icon="BRUSH_DATA")


_register_classes, _unregister_classes = bpy.utils.register_classes_factory((VIEW3D_PT_transcut,))


def register():
    _register_classes()
    bpy.types.VIEW3D_MT_object.append(menu_func)


def unregister():
    bpy.types.VIEW3D_MT_object.remove(menu_func)
    _unregister_classes()
