"""TransCut subsurface bake: a thin Blender extension over libtranscut's C ABI.

Bakes the subsurface scattering of the selected meshes (their Principled BSDF subsurface
settings, or a preset / coefficients) under the scene's lights and world into a FLOAT_COLOR
point attribute. See ARCHITECTURE.md, "The Blender add-on", and the modules:

- ``preferences``: registered first and always; shows where the native library was looked for;
- ``properties``: ``Scene.transcut`` (bake settings) and ``Object.transcut`` (medium);
- ``operators``: ``object.transcut_bake`` (modal with progress and ESC, or synchronous);
- ``edit_ops``: ``transcut.cut_with_object`` and ``transcut.paint_medium`` (bake, then cut or
  paint through ``edit_native``);
- ``ui``: the sidebar tab; ``native``: the ctypes mirror of ``include/transcut.h``;
- ``mesh_export`` / ``lights``: Blender data and units → library arrays; ``bake``: run and write.
"""

from . import edit_ops, library, operators, preferences, properties, ui

# Preferences first, so the add-on can always show why the library did not load.
_modules = (preferences, properties, operators, edit_ops, ui)


def register():
    for module in _modules:
        module.register()
    # Never fatal: a failure is recorded in library.state and shown in the preferences.
    library.load()


def unregister():
    for module in reversed(_modules):
        module.unregister()
    library.state.reset()
