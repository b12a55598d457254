"""TransCut subsurface bake: a thin Blender extension over libtranscut's C ABI.

Bakes the subsurface scattering of the selected meshes (their Principled BSDF subsurface
settings, or a preset / coefficients) under the scene's lights and world into a FLOAT_COLOR
point attribute, bakes the animation of a deforming mesh frame by frame (the hierarchical
dipole), and cuts or paints baked meshes. See ARCHITECTURE.md, "The Blender add-on",
and the modules:

- ``preferences``: registered first and always; the library path, and where the library was
  looked for;
- ``properties``: ``Scene.transcut`` (the method, from the loaded library, and the bake settings)
  and ``Object.transcut`` (medium);
- ``kept`` / ``kept_native``: the library scenes of the last bakes, kept so that a rebake after a
  light or world change only relights (freed with their objects, the file, the add-on);
- ``operators``: ``object.transcut_bake`` and the run every operator shares (modal with progress
  and ESC, or synchronous);
- ``edit_ops``: ``transcut.cut_with_object`` and ``transcut.paint_medium`` (bake, then cut or
  paint through ``edit_native``);
- ``animation_ops``: ``transcut.bake_animation`` (every frame of the range through
  ``animation_native``, into a cache file) and the ``frame_change_post`` handler that writes the
  current frame's radiance into the attribute;
- ``texture_ops``: ``object.transcut_bake_texture`` (the bake into image textures through each
  object's UV map);
- ``preview``: ``transcut.preview_bake`` and ``transcut.restore_materials`` (preview materials
  that show the bake as rendered, and the originals back);
- ``live``: Live Translucency (``transcut.live_start`` / ``live_stop``): one PRT precompute, then
  the attribute follows lights, world and material edits through ``live_native``;
- ``ui``: the sidebar tab and the Object menu entries;
- ``mesh_export`` / ``lights``: Blender data and units → library arrays; ``bake``: gather, run
  and write;
- ``library``: the loaded library, or why it did not load (no ``bpy``);
- ``transcut``: the ctypes binding of ``include/transcut.h`` (no ``bpy``), also shipped as the
  ``transcut`` wheel.
"""

from . import animation_ops, edit_ops, kept, library, live, operators, preferences, preview, properties, texture_ops, ui

# Preferences first, so the add-on can always show why the library did not load.
_modules = (preferences, properties, kept, operators, texture_ops, edit_ops, animation_ops, live, preview, ui)


def register():
    for module in _modules:
        module.register()
    # Never fatal: a failure is recorded in library.state and shown in the preferences.
    library.load(preferences.library_path())


def unregister():
    for module in reversed(_modules):
        module.unregister()
    library.state.reset()
