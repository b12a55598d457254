#!/usr/bin/env bash
# Runs the Blender add-on tests (tests/blender, pytest) headless with bpy 4.5 from PyPI.
# Creates or reuses the venv (scripts/blender-venv.sh), builds the C ABI library they call
# (the transcut-capi cdylib, test profile: shares the optimised dependencies `cargo test`
# builds), and points TRANSCUT_LIB at it. Extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/../.."

VENV="${TRANSCUT_BLENDER_VENV:-.venv}"
bash scripts/blender-venv.sh "$VENV"

if [ -z "${TRANSCUT_LIB:-}" ]; then
    # The exact artifact path, whatever CARGO_TARGET_DIR is: ask cargo.
    TRANSCUT_LIB="$(cargo build -p transcut-capi --lib --profile test --locked --message-format=json-render-diagnostics \
        | "$VENV/bin/python" -c '
import json, sys
libs = []
for line in sys.stdin:
    msg = json.loads(line)
    if msg.get("reason") == "compiler-artifact" and "cdylib" in msg["target"]["crate_types"]:
        libs += [f for f in msg["filenames"] if f.endswith((".so", ".dylib", ".dll"))]
print(libs[-1] if libs else "")
')"
    if [ -z "$TRANSCUT_LIB" ]; then
        echo "tests/blender/run.sh: cargo built no transcut-capi shared library" >&2
        exit 1
    fi
fi
export TRANSCUT_LIB
export TRANSCUT_REQUIRE_LIB=1
echo "tests/blender/run.sh: TRANSCUT_LIB=$TRANSCUT_LIB"
exec "$VENV/bin/python" -m pytest -q -p no:cacheprovider tests/blender "$@"
