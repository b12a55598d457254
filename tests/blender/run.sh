#!/usr/bin/env bash
# Runs the Blender add-on tests (tests/blender, pytest) headless with bpy 4.5 from PyPI.
# Creates or reuses the venv (scripts/blender-venv.sh), finds or builds the C ABI library they
# call (the transcut-capi cdylib, test profile) and points TRANSCUT_LIB at it (a TRANSCUT_LIB
# already set is used as it is). Extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/../.."

VENV="${TRANSCUT_BLENDER_VENV:-.venv}"
bash scripts/blender-venv.sh "$VENV"

# The transcut-capi shared library, wherever CARGO_TARGET_DIR puts it: cargo names it in its
# JSON messages. First the workspace test build (the units scripts/test.sh has just built, so
# nothing is compiled again; cargo test builds the cdylib for capi's integration tests), then a
# build of the library alone.
cdylib_of() {
    "$VENV/bin/python" -c '
import json, sys
libs = []
for line in sys.stdin:
    try:
        msg = json.loads(line)
    except ValueError:
        continue
    if (msg.get("reason") == "compiler-artifact" and msg["target"]["name"] == "transcut"
            and "cdylib" in msg["target"]["crate_types"]):
        libs += [f for f in msg["filenames"] if f.endswith((".so", ".dylib", ".dll"))]
print(libs[-1] if libs else "")
'
}
if [ -z "${TRANSCUT_LIB:-}" ]; then
    TRANSCUT_LIB="$(cargo test --workspace --all-targets --no-run --locked \
        --message-format=json-render-diagnostics | cdylib_of)"
fi
if [ -z "${TRANSCUT_LIB:-}" ]; then
    TRANSCUT_LIB="$(cargo build -p transcut-capi --lib --profile test --locked \
        --message-format=json-render-diagnostics | cdylib_of)"
fi
if [ -z "$TRANSCUT_LIB" ]; then
    echo "tests/blender/run.sh: cargo built no transcut-capi shared library" >&2
    exit 1
fi
export TRANSCUT_LIB
export TRANSCUT_REQUIRE_LIB=1
echo "tests/blender/run.sh: TRANSCUT_LIB=$TRANSCUT_LIB"
exec "$VENV/bin/python" -m pytest -q -p no:cacheprovider tests/blender "$@"
