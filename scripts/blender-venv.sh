#!/usr/bin/env bash
# Creates (or reuses) the Python virtual environment the Blender add-on tests and the Python lint
# (scripts/lint-python.sh) run in: bpy 4.5.x from PyPI (Blender as a Python module; needs Python
# 3.11), pytest, NumPy and ruff at the exact version below (a newer ruff may lint differently).
# Installs the few Debian shared libraries `import bpy` needs headless when they are missing.
# Usage: bash scripts/blender-venv.sh [VENV_DIR]   (default: .venv at the repository root)
# Prints nothing but progress; the venv's python is VENV_DIR/bin/python.
set -euo pipefail
cd "$(dirname "$0")/.."

VENV="${1:-.venv}"
BPY_SPEC="bpy==4.5.*"
RUFF_VERSION="0.17.6"
PYTHON="${PYTHON311:-python3.11}"

# Shared libraries that bpy's Blender module links against even in background mode (from
# `ldd bpy/__init__.so`; libgl1 brings libglx0 and libglvnd's dispatcher, libx11-6 brings xcb).
need_debs=()
if command -v dpkg-query >/dev/null 2>&1; then
    for deb in libx11-6 libxrender1 libxfixes3 libxi6 libxkbcommon0 libxext6 libsm6 libice6 \
               libgl1; do
        if ! dpkg-query -W -f='${Status}' "$deb" 2>/dev/null | grep -q "install ok installed"; then
            need_debs+=("$deb")
        fi
    done
fi
if [ "${#need_debs[@]}" -gt 0 ]; then
    echo "blender-venv: installing Debian packages: ${need_debs[*]}"
    SUDO=""
    if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${need_debs[@]}"
fi

if ! command -v "$PYTHON" >/dev/null 2>&1; then
    echo "blender-venv: $PYTHON is required (bpy 4.5 is built for Python 3.11)" >&2
    exit 1
fi

ruff_ok() {
    [ "$("$VENV/bin/ruff" --version 2>/dev/null)" = "ruff $RUFF_VERSION" ]
}

if [ -x "$VENV/bin/python" ] && "$VENV/bin/python" -c 'import bpy, pytest, numpy; assert bpy.app.version[:2] == (4, 5)' >/dev/null 2>&1; then
    if ! ruff_ok; then
        echo "blender-venv: installing ruff==$RUFF_VERSION into $VENV"
        "$VENV/bin/python" -m pip install -q --disable-pip-version-check --force-reinstall "ruff==$RUFF_VERSION"
    fi
    exit 0
fi

echo "blender-venv: creating $VENV with $BPY_SPEC (about 400 MB to download on a fresh machine)"
"$PYTHON" -m venv "$VENV"
"$VENV/bin/python" -m pip install -q --disable-pip-version-check --upgrade pip
"$VENV/bin/python" -m pip install -q --disable-pip-version-check "$BPY_SPEC" pytest numpy "ruff==$RUFF_VERSION"
"$VENV/bin/python" -c 'import bpy; print("blender-venv: bpy", bpy.app.version_string)'
