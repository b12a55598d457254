"""Bake Texture: the subsurface bake into an image through each object's active UV map.

``object.transcut_bake_texture`` bakes the selected meshes as the bake operator does (the same
job: method, medium, lights, options), then asks the library for each object's texture
(``tc_object_bake_texture``: every texel whose centre lies in a UV triangle gets the radiance
at that surface point, from the solution itself rather than a blend of vertex colours, and each
UV island is padded by Margin texels) through the loop triangles of its evaluated mesh and the
active UV map's UV per corner. Each texture becomes a float Blender image named
``"<object> SSS"`` (linear, replaced when it exists), and is saved when the .blend file is
saved (or Filepath is absolute): OpenEXR keeps the linear values, PNG stores 8-bit sRGB
(Blender's Standard view, no tone curve). The
colour attribute is not touched. Modal with progress and ESC, undoable; nothing is created when
it fails.
"""

from __future__ import annotations

import os

import bpy
import numpy as np
from bpy.props import EnumProperty, IntProperty, StringProperty

from . import bake, library, preferences
from .mesh_export import BakeError
from .operators import RunnerOperator

#: Blender's file format and the extension of each choice.
FORMATS = {"OPEN_EXR": ".exr", "PNG": ".png"}


def uv_triangles(obj, depsgraph) -> tuple:
    """The loop triangles of ``obj``'s evaluated mesh (its vertex numbering, as baked) and the
    active UV map's UV of each corner: uint32 (m, 3) and float32 (m, 3, 2). BakeError when the
    mesh has no UV map."""
    ob_eval = obj.evaluated_get(depsgraph)
    mesh = ob_eval.to_mesh()
    try:
        layer = mesh.uv_layers.active
        if layer is None:
            raise BakeError(f"'{obj.name}' has no UV map: add one (UV > Unwrap or Smart UV Project) to bake a texture")
        mesh.calc_loop_triangles()
        m = len(mesh.loop_triangles)
        triangles = np.empty(m * 3, dtype=np.uint32)
        mesh.loop_triangles.foreach_get("vertices", triangles)
        loops = np.empty(m * 3, dtype=np.int64)
        mesh.loop_triangles.foreach_get("loops", loops)
        uv = np.empty(len(mesh.loops) * 2, dtype=np.float32)
        layer.uv.foreach_get("vector", uv)
    finally:
        ob_eval.to_mesh_clear()
    return triangles.reshape(-1, 3), uv.reshape(-1, 2)[loops].reshape(-1, 3, 2)


def texture_path(template: str, object_name: str, file_format: str) -> str | None:
    """Where the texture of ``object_name`` is saved: ``template`` with ``{object}`` replaced
    and the format's extension added, made absolute; None when it is relative to an unsaved
    .blend file (the image then stays in the file only)."""
    path = template.replace("{object}", bpy.path.clean_name(object_name)) + FORMATS[file_format]
    if path.startswith("//") and not bpy.data.filepath:
        return None
    return bpy.path.abspath(path)


def write_image(name: str, rgba: np.ndarray):
    """The float image ``name`` holding ``rgba`` (rows from the top), created or resized."""
    height, width = rgba.shape[:2]
    image = bpy.data.images.get(name)
    if image is not None and (tuple(image.size) != (width, height) or not image.is_float):
        bpy.data.images.remove(image)
        image = None
    if image is None:
        image = bpy.data.images.new(name, width, height, alpha=True, float_buffer=True)
    image.pixels.foreach_set(np.ascontiguousarray(rgba[::-1]).ravel())
    image.update()
    return image


def save_image(scene, image, path: str, file_format: str) -> None:
    """Saves ``image`` to ``path`` as OpenEXR (32-bit float, the linear values as they are) or
    PNG (8-bit, the Standard view: sRGB-encoded, no tone curve). ``Image.save`` would apply the
    scene's view transform to a generated float image even for OpenEXR; ``save_render`` with
    the scene's output settings overridden for the call (and put back) writes what is asked."""
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    settings = scene.render.image_settings
    view = settings.view_settings
    kept = (settings.file_format, settings.color_depth, settings.color_management)
    kept_view = (view.view_transform, view.look, view.exposure, view.gamma)
    try:
        settings.file_format = file_format
        settings.color_depth = "32" if file_format == "OPEN_EXR" else "8"
        if file_format == "PNG":
            settings.color_management = "OVERRIDE"
            view.view_transform, view.look, view.exposure, view.gamma = "Standard", "None", 0.0, 1.0
        image.save_render(path, scene=scene)
    finally:
        settings.file_format, settings.color_depth, settings.color_management = kept
        view.view_transform, view.look, view.exposure, view.gamma = kept_view


class TextureRunner(bake.BakeRunner):
    """The bake runner that also bakes the ``textures`` (:class:`bake.TextureRequest`)."""

    def __init__(self, lib, job, textures: list):
        super().__init__(lib, job)
        self.textures = textures

    def _run(self) -> None:
        try:
            self.results = bake.run_job(
                self.lib, self.job, self.progress, self.backends, self.radiosity, textures=self.textures
            )
        except BaseException as exc:  # reported by the main thread
            self.error = exc


class OBJECT_OT_transcut_bake_texture(RunnerOperator, bpy.types.Operator):
    """Bake subsurface scattering of the selected meshes into image textures through their UV maps"""

    bl_idname = "object.transcut_bake_texture"
    bl_label = "Bake Subsurface Texture (TransCut)"
    what = "texture bake"

    resolution: IntProperty(
        name="Resolution", description="Width and height of each texture", default=1024, min=1, max=16_384
    )
    margin: IntProperty(
        name="Margin",
        description="Texels of padding around each UV island, so seams never show the background",
        default=16,
        min=0,
        max=256,
    )
    file_format: EnumProperty(
        name="Format",
        items=(
            ("OPEN_EXR", "OpenEXR", "32-bit float, linear: the radiance as it is"),
            ("PNG", "PNG", "8-bit sRGB, values above 1 clipped"),
        ),
        default="OPEN_EXR",
    )
    filepath: StringProperty(
        name="Filepath",
        description="Where each texture is saved ({object}: the object's name; the extension is the format's)",
        default="//textures/{object}_SSS",
        subtype="FILE_PATH",
    )

    @classmethod
    def poll(cls, context):
        return context.mode == "OBJECT"

    def _runner_for(self, context):
        lib = library.get(preferences.library_path(context))
        if not lib.has("tc_object_bake_texture"):
            raise BakeError(f"{lib.path} ({lib.version_string}) has no tc_object_bake_texture; update libtranscut")
        job = bake.prepare_job(context)
        depsgraph = context.evaluated_depsgraph_get()
        textures = []
        for k, mesh_job in enumerate(job.meshes):
            obj = bpy.data.objects[mesh_job.object_name]
            triangles, uvs = uv_triangles(obj, depsgraph)
            textures.append(bake.TextureRequest(k, triangles, uvs, self.resolution, self.resolution, self.margin))
        return TextureRunner(lib, job, textures)

    def _write(self, context, runner) -> str:
        saved = unsaved = 0
        for request in runner.textures:
            name = runner.job.meshes[request.mesh].object_name
            image = write_image(f"{name} SSS", request.image)
            path = texture_path(self.filepath, name, self.file_format)
            if path is None:
                unsaved += 1
            else:
                save_image(context.scene, image, path, self.file_format)
                saved += 1
        note = f"; saved {saved} file(s)" if saved else ""
        if unsaved:
            note += f"; {unsaved} not saved (save the .blend first, or give an absolute Filepath)"
        return f"baked {len(runner.textures)} texture(s) of {self.resolution}×{self.resolution}{note}"


register, unregister = bpy.utils.register_classes_factory((OBJECT_OT_transcut_bake_texture,))
