#!/usr/bin/env bash
# Runs every test of libtranscut. This is the README's test command; CI (.ci/run) calls it.
# It installs what the tests need when it is missing, so it works on a fresh machine.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v cargo >/dev/null 2>&1; then
    echo "scripts/test.sh: cargo is required (https://rustup.rs)" >&2
    exit 1
fi

# The GPU tests (core/tests/gpu*.rs) need a Vulkan adapter: install Mesa's lavapipe (software
# Vulkan, Debian mesa-vulkan-drivers) when missing, so the GPU path is tested on every machine.
bash scripts/install-lavapipe.sh

# Tests run optimised (profile.test has opt-level 2): the mesher and solver tests work at
# real sizes (up to 1M tets).
cargo test --workspace --all-targets --locked
cargo test --workspace --doc --locked

# --- C ABI (issue 4) ---------------------------------------------------------------------------
# libtranscut.so / .a built by cargo, include/transcut.h compiled as C99 and C++17, and the C
# program tests/c/marble_sphere.c run under valgrind against both (tests/c/run.sh installs gcc,
# g++, pkg-config and valgrind when missing). The Rust ABI tests (capi/tests) ran above.
bash tests/c/run.sh

# The Blender add-on (tests/blender): creates .venv with bpy 4.5 from PyPI (and the Debian
# libraries it needs), builds the C ABI library, runs the bpy tests headless with pytest.
# It calls the library tests/c/run.sh has just built (test profile, target/debug).
TRANSCUT_LIB="${TRANSCUT_LIB:-$(cd "${CARGO_TARGET_DIR:-target}/debug" && pwd)/libtranscut.so}" bash tests/blender/run.sh
