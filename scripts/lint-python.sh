#!/usr/bin/env bash
# Lints and format-checks the Python code (the Blender add-on, its tests, the scripts, the
# benchmark and example generators) with ruff,
# configured by ruff.toml at the repository root. The ruff is the exact version that
# scripts/blender-venv.sh installs into the venv the Blender tests use (created if missing).
# Exits non-zero on any lint finding or any file that `ruff format` would change.
# Usage: bash scripts/lint-python.sh   (TRANSCUT_BLENDER_VENV: the venv folder, default .venv)
set -euo pipefail
cd "$(dirname "$0")/.."

VENV="${TRANSCUT_BLENDER_VENV:-.venv}"
bash scripts/blender-venv.sh "$VENV"
RUFF="$VENV/bin/ruff"
PATHS=(blender_addon tests/blender scripts/*.py bench/*.py examples/*.py)

status=0
"$RUFF" check "${PATHS[@]}" || status=1
"$RUFF" format --check "${PATHS[@]}" || status=1
if [ "$status" -ne 0 ]; then
    echo "scripts/lint-python.sh: failed; \`$RUFF check --fix\` and \`$RUFF format\` fix most findings" >&2
fi
exit "$status"
