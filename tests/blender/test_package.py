"""Packaging (scripts/package-addon.py): the `transcut` wheel works with plain pip, and the
extension zip passes Blender's own manifest validation, installs from disk and loads the library
from its bundled wheel.

Each check runs in a fresh interpreter without TRANSCUT_LIB, so the library can only come from
the package under test. The library packaged is the one the other tests use (TRANSCUT_LIB).
"""

from __future__ import annotations

import base64
import hashlib
import os
import subprocess
import sys
import tempfile
import tomllib
import zipfile
from pathlib import Path

import pytest

from conftest import REPO, bpy, library_path, require_library

BLENDER_EXT = Path(bpy.utils.system_resource("SCRIPTS")) / "addons_core" / "bl_pkg" / "cli" / "blender_ext.py"


def clean_env(**extra):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("TRANSCUT_", "PYTHONPATH", "BLENDER_USER"))}
    env.update(extra)
    return env


def run(args, **kw):
    proc = subprocess.run(args, capture_output=True, text=True, timeout=300, **kw)
    assert proc.returncode == 0, f"{args}\nstdout:\n{proc.stdout}\nstderr:\n{proc.stderr}"
    return proc.stdout


@pytest.fixture(scope="module")
def packages():
    require_library()
    # Removed at the end (not kept by pytest): each holds copies of the shared library.
    with tempfile.TemporaryDirectory(prefix="transcut-dist-") as out:
        lines = run([sys.executable, str(REPO / "scripts" / "package-addon.py"), "--lib", library_path(), "--out", out])
        wheel, ext = (Path(p) for p in lines.split())
        yield wheel, ext


@pytest.fixture
def tmp_path():
    with tempfile.TemporaryDirectory(prefix="transcut-pkg-test-") as d:
        yield Path(d)


BINDING = sorted((REPO / "blender_addon" / "transcut").glob("*.py"))


def test_wheel_layout_and_record(packages):
    wheel, _ = packages
    assert wheel.name == "transcut-0.1.0-py3-none-linux_x86_64.whl"
    with zipfile.ZipFile(wheel) as zf:
        names = set(zf.namelist())
        assert {"transcut/__init__.py", "transcut/libtranscut.so", "transcut-0.1.0.dist-info/WHEEL"} <= names
        # The package is the add-on's binding, file for file.
        assert {"transcut/_abi.py", "transcut/_loader.py", "transcut/scene.py"} <= names
        assert {n for n in names if n.endswith(".py")} == {f"transcut/{src.name}" for src in BINDING}
        for src in BINDING:
            assert zf.read(f"transcut/{src.name}") == src.read_bytes(), src.name
        record = zf.read("transcut-0.1.0.dist-info/RECORD").decode().splitlines()
        for line in record:
            name, digest, size = line.rsplit(",", 2)
            if name.endswith("RECORD"):
                continue
            data = zf.read(name)
            expected = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
            assert digest == f"sha256={expected}" and int(size) == len(data), name
        assert zf.read("transcut/libtranscut.so") == Path(library_path()).read_bytes()


def test_wheel_installs_with_pip_and_bakes(packages, tmp_path):
    wheel, _ = packages
    site = tmp_path / "site"
    run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-index", "--target", str(site), str(wheel)])
    script = """
import numpy as np, transcut
lib = transcut.load()
assert lib.path.startswith(SITE), lib.path
# An octahedron of 1 cm in marble under a white sky.
pos = np.array([[1,0,0],[-1,0,0],[0,1,0],[0,-1,0],[0,0,1],[0,0,-1]], np.float32)
tri = np.array([[0,2,4],[2,1,4],[1,3,4],[3,0,4],[2,0,5],[1,2,5],[3,1,5],[0,3,5]], np.uint32)
with lib.scene() as s:
    o = s.add_mesh(pos, tri)
    s.set_scale(o, 10.0)
    s.set_medium_preset(o, "marble")
    s.add_environment((1.0, 1.0, 1.0))
    s.bake(tets=5000)
    rgb = s.radiance(o)
assert rgb.shape == (6, 3) and np.all(np.isfinite(rgb)) and np.all(rgb > 0.1), rgb
print("ok", lib.version_string)
""".replace("SITE", repr(str(site)))
    out = run([sys.executable, "-c", script], env=clean_env(PYTHONPATH=str(site)), cwd=tmp_path)
    assert out.startswith("ok")


def test_extension_manifest_is_valid(packages):
    _, ext = packages
    assert ext.name == "transcut-0.1.0-linux-x64.zip"
    with zipfile.ZipFile(ext) as zf:
        manifest = tomllib.loads(zf.read("blender_manifest.toml").decode())
        assert manifest["platforms"] == ["linux-x64"]
        assert manifest["wheels"] == ["./wheels/transcut-0.1.0-py3-none-linux_x86_64.whl"]
        names = set(zf.namelist())
        assert "wheels/transcut-0.1.0-py3-none-linux_x86_64.whl" in names
        # The add-on's modules and its binding package, as in the source folder.
        addon_files = {src.name for src in (REPO / "blender_addon").glob("*.py")}
        assert {"__init__.py", "library.py", "operators.py"} <= addon_files
        assert {n for n in names if n.endswith(".py")} == addon_files | {f"transcut/{src.name}" for src in BINDING}
    # Blender's own validator (the code behind `blender --command extension validate`).
    run([sys.executable, str(BLENDER_EXT), "validate", str(ext)])
    run([sys.executable, str(BLENDER_EXT), "validate", str(REPO / "blender_addon")])


def test_extension_installs_from_disk_and_loads_bundled_library(packages, tmp_path):
    _, ext = packages
    script = """
import sys, bpy
r = bpy.ops.extensions.package_install_files(filepath=EXT, repo="user_default", enable_on_install=True)
assert r == {"FINISHED"}, r
assert "bl_ext.user_default.transcut" in bpy.context.preferences.addons
state = sys.modules["bl_ext.user_default.transcut.library"].state
assert state.lib is not None, state.tried
assert "/site-packages/transcut/" in state.lib.path, state.lib.path
assert "transcut_bake" in dir(bpy.ops.object)
print("ok", state.lib.path)
""".replace("EXT", repr(str(ext)))
    user = tmp_path / "blender-user"
    user.mkdir()
    out = run([sys.executable, "-c", script], env=clean_env(BLENDER_USER_RESOURCES=str(user)), cwd=tmp_path)
    assert "ok" in out
