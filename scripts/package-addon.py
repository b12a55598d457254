#!/usr/bin/env python3
"""Builds the release library and packages the Blender extension for this platform.

    python3 scripts/package-addon.py [--lib PATH] [--out DIR]

Produces, in DIR (default ``dist/``):

- ``transcut-VERSION-py3-none-PLATFORM.whl``: the ``transcut`` Python package, i.e. the ctypes
  binding (the package ``blender_addon/transcut/``) and the shared library beside it. It needs
  only NumPy and works with a plain ``pip install`` outside Blender:
  ``import transcut; lib = transcut.load()``.
- ``transcut-VERSION-BLENDERPLATFORM.zip``: the installable extension (Blender: Edit ▸
  Preferences ▸ Get Extensions ▸ ▾ ▸ Install from Disk). It carries the add-on's Python files
  (its ``transcut`` package included) and the wheel under ``wheels/``; its manifest lists the
  wheel under ``wheels`` and sets ``platforms`` (the extension holds native code, so it installs
  only where the library runs). The add-on's copy of the package finds the library in the
  installed wheel.

Without ``--lib`` it runs ``cargo build --release -p transcut-capi`` and packages that library;
``--lib`` packages an existing one (the tests use the library they already built).
Only the standard library is used.
"""

from __future__ import annotations

import argparse
import base64
import hashlib
import json
import platform
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ADDON = ROOT / "blender_addon"
BINDING = ADDON / "transcut"

# Python's (sys.platform, machine) → (wheel platform tag, Blender extension platform).
PLATFORMS = {
    ("linux", "x86_64"): ("linux_x86_64", "linux-x64"),
    ("linux", "aarch64"): ("linux_aarch64", "linux-arm64"),
    ("darwin", "x86_64"): ("macosx_10_12_x86_64", "macos-x64"),
    ("darwin", "arm64"): ("macosx_11_0_arm64", "macos-arm64"),
    ("win32", "amd64"): ("win_amd64", "windows-x64"),
    ("win32", "arm64"): ("win_arm64", "windows-arm64"),
}
LIBRARY_NAMES = {"linux": "libtranscut.so", "darwin": "libtranscut.dylib", "win32": "transcut.dll"}


def this_platform() -> tuple[str, str, str]:
    """(wheel tag, Blender platform, library file name) of the running system."""
    key = (sys.platform, platform.machine().lower())
    if key not in PLATFORMS:
        sys.exit(f"package-addon: no wheel tag known for {key}")
    wheel_tag, blender_platform = PLATFORMS[key]
    return wheel_tag, blender_platform, LIBRARY_NAMES[sys.platform]


def build_release_library() -> Path:
    """``cargo build --release -p transcut-capi``; the path of the cdylib cargo reports."""
    cmd = [
        "cargo",
        "build",
        "--release",
        "-p",
        "transcut-capi",
        "--lib",
        "--locked",
        "--message-format=json-render-diagnostics",
    ]
    print("package-addon:", " ".join(cmd), file=sys.stderr)
    proc = subprocess.run(cmd, cwd=ROOT, stdout=subprocess.PIPE, text=True, check=True)
    found = []
    for line in proc.stdout.splitlines():
        msg = json.loads(line)
        if msg.get("reason") == "compiler-artifact" and "cdylib" in msg["target"]["crate_types"]:
            found += [f for f in msg["filenames"] if f.endswith((".so", ".dylib", ".dll"))]
    if not found:
        sys.exit("package-addon: cargo built no transcut-capi shared library")
    return Path(found[-1])


def record_line(name: str, data: bytes) -> str:
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(data)}"


def python_files(folder: Path, prefix: str = "") -> list[tuple[str, bytes, int]]:
    """Zip entries for the ``.py`` files of ``folder`` (not its subfolders), named ``prefix`` + name."""
    return [(prefix + src.name, src.read_bytes(), 0o644) for src in sorted(folder.glob("*.py"))]


def write_zip(path: Path, files: list[tuple[str, bytes, int]]) -> None:
    """A deterministic zip: sorted-as-given entries, fixed timestamps, mode bits kept."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name, data, mode in files:
            info = zipfile.ZipInfo(name, date_time=(2024, 1, 1, 0, 0, 0))
            info.external_attr = (0o100000 | mode) << 16
            info.compress_type = zipfile.ZIP_DEFLATED
            zf.writestr(info, data)


def build_wheel(lib: Path, version: str, wheel_tag: str, lib_name: str, out: Path) -> Path:
    """The ``transcut`` wheel: binding + shared library + dist-info (PEP 427)."""
    dist_info = f"transcut-{version}.dist-info"
    metadata = "\n".join(
        [
            "Metadata-Version: 2.1",
            "Name: transcut",
            f"Version: {version}",
            "Summary: libtranscut (subsurface scattering bakes) through its C ABI, with the shared library",
            "License: MIT OR Apache-2.0",
            "Requires-Python: >=3.9",
            "Requires-Dist: numpy",
            "",
        ]
    ).encode()
    wheel_meta = "\n".join(
        [
            "Wheel-Version: 1.0",
            "Generator: libtranscut scripts/package-addon.py",
            "Root-Is-Purelib: false",
            f"Tag: py3-none-{wheel_tag}",
            "",
        ]
    ).encode()
    files = [
        *python_files(BINDING, "transcut/"),
        (f"transcut/{lib_name}", lib.read_bytes(), 0o755),
        (f"{dist_info}/METADATA", metadata, 0o644),
        (f"{dist_info}/WHEEL", wheel_meta, 0o644),
    ]
    record = "\n".join([record_line(n, d) for n, d, _ in files] + [f"{dist_info}/RECORD,,", ""]).encode()
    files.append((f"{dist_info}/RECORD", record, 0o644))
    path = out / f"transcut-{version}-py3-none-{wheel_tag}.whl"
    write_zip(path, files)
    return path


def packaged_manifest(blender_platform: str, wheel_name: str) -> bytes:
    """The source manifest with ``platforms`` and ``wheels`` added before its first table."""
    text = (ADDON / "blender_manifest.toml").read_text()
    lines = text.splitlines(keepends=True)
    first_table = next((i for i, line in enumerate(lines) if line.lstrip().startswith("[")), len(lines))
    extra = f'platforms = ["{blender_platform}"]\nwheels = ["./wheels/{wheel_name}"]\n\n'
    result = "".join(lines[:first_table]) + extra + "".join(lines[first_table:])
    parsed = tomllib.loads(result)
    assert parsed["platforms"] == [blender_platform] and parsed["wheels"] == [f"./wheels/{wheel_name}"]
    return result.encode()


def build_extension(wheel: Path, version: str, blender_platform: str, out: Path) -> Path:
    """The extension zip: manifest at the root, the add-on's modules and package, ``wheels/``."""
    files = [
        ("blender_manifest.toml", packaged_manifest(blender_platform, wheel.name), 0o644),
        *python_files(ADDON),
        *python_files(BINDING, "transcut/"),
        (f"wheels/{wheel.name}", wheel.read_bytes(), 0o644),
    ]
    path = out / f"transcut-{version}-{blender_platform}.zip"
    write_zip(path, files)
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--lib", type=Path, help="package this shared library instead of building the release one")
    parser.add_argument("--out", type=Path, default=ROOT / "dist", help="output folder (default: dist/)")
    args = parser.parse_args(argv)

    wheel_tag, blender_platform, lib_name = this_platform()
    version = tomllib.loads((ADDON / "blender_manifest.toml").read_text())["version"]
    lib = args.lib.resolve() if args.lib else build_release_library()
    if not lib.is_file():
        sys.exit(f"package-addon: {lib} is not a file")
    args.out.mkdir(parents=True, exist_ok=True)
    wheel = build_wheel(lib, version, wheel_tag, lib_name, args.out)
    ext = build_extension(wheel, version, blender_platform, args.out)
    print(wheel)
    print(ext)
    return 0


if __name__ == "__main__":
    sys.exit(main())
