"""Fixtures for the Blender add-on tests (bpy 4.5 from PyPI, headless).

The extension is registered from the source folder the way a developer installs it: a local
extension repository (a temporary folder holding a link ``transcut`` → ``blender_addon/``) and
``addon_utils.enable("bl_ext.transcut_dev.transcut")``.

The native library comes from ``TRANSCUT_LIB`` (tests/blender/run.sh builds it and sets it).
Tests that need it are skipped when it is missing, unless ``TRANSCUT_REQUIRE_LIB=1`` (set by
run.sh), which turns a missing library into a failure.
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
from pathlib import Path

import pytest

bpy = pytest.importorskip("bpy")
import addon_utils  # noqa: E402  (bpy's own module path)

REPO = Path(__file__).resolve().parents[2]
ADDON_SRC = REPO / "blender_addon"
REPO_MODULE = "transcut_dev"
ADDON_MODULE = f"bl_ext.{REPO_MODULE}.transcut"

sys.path.insert(0, str(Path(__file__).resolve().parent))


def library_path():
    path = os.environ.get("TRANSCUT_LIB", "")
    return path if path and os.path.isfile(path) else None


def require_library():
    if library_path() is None:
        if os.environ.get("TRANSCUT_REQUIRE_LIB") == "1":
            pytest.fail(f"TRANSCUT_LIB={os.environ.get('TRANSCUT_LIB')!r} is not a file")
        pytest.skip("libtranscut not built (set TRANSCUT_LIB, or run tests/blender/run.sh)")


@pytest.fixture(scope="session")
def extension_repo():
    """A local extension repository holding the source folder as the extension 'transcut'."""
    tmp = tempfile.mkdtemp(prefix="transcut-ext-")
    os.symlink(ADDON_SRC, os.path.join(tmp, "transcut"), target_is_directory=True)
    prefs = bpy.context.preferences
    repo = prefs.extensions.repos.new(name="transcut dev", module=REPO_MODULE, custom_directory=tmp, source="USER")
    yield repo
    prefs.extensions.repos.remove(repo)
    shutil.rmtree(tmp, ignore_errors=True)


def enable():
    mod = addon_utils.enable(ADDON_MODULE, default_set=True, handle_error=_raise)
    assert mod is not None, "the extension did not enable"
    return mod


def disable():
    addon_utils.disable(ADDON_MODULE, default_set=True, handle_error=_raise)


def _raise(exc):
    raise exc


@pytest.fixture
def addon(extension_repo):
    """The enabled extension's module (enabled afresh per test, disabled after)."""
    mod = enable()
    yield mod
    if ADDON_MODULE in bpy.context.preferences.addons:
        disable()


def clear_scene():
    """An empty scene: no objects, meshes, lights, materials, worlds or images; unit scale 1."""
    for coll in (
        bpy.data.objects,
        bpy.data.meshes,
        bpy.data.lights,
        bpy.data.materials,
        bpy.data.images,
        bpy.data.cameras,
    ):
        for item in list(coll):
            coll.remove(item)
    scene = bpy.context.scene
    scene.world = None
    for w in list(bpy.data.worlds):
        bpy.data.worlds.remove(w)
    scene.unit_settings.scale_length = 1.0


@pytest.fixture
def scene(addon):
    clear_scene()
    s = bpy.context.scene
    s.transcut.tets = 15_000
    s.transcut.tolerance = 1e-6
    yield s
    clear_scene()


@pytest.fixture
def lib():
    require_library()
    import capi_direct

    return capi_direct.Direct(library_path())
