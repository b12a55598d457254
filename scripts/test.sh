#!/usr/bin/env bash
# Runs every test of libtranscut. This is the README's test command; CI (.ci/run) calls it.
# It installs what the tests need when it is missing, so it works on a fresh machine.
#
#   bash scripts/test.sh          formatting, lints, every test (about 15 minutes cold on 2 cores)
#   bash scripts/test.sh --slow   also the slow tier: the tests named slow_* (meshing every test
#                                 mesh at 500k and 1M tets), minutes more
set -euo pipefail
cd "$(dirname "$0")/.."

slow=0
for arg in "$@"; do
    case "$arg" in
        --slow) slow=1 ;;
        *) echo "usage: bash scripts/test.sh [--slow]" >&2; exit 2 ;;
    esac
done

if ! command -v cargo >/dev/null 2>&1; then
    echo "scripts/test.sh: cargo is required (https://rustup.rs)" >&2
    exit 1
fi
# rustfmt and clippy come with rustup's default profile; add them where a minimal one left them out.
if ! cargo fmt --version >/dev/null 2>&1 || ! cargo clippy --version >/dev/null 2>&1; then
    rustup component add rustfmt clippy
fi

# Formatting and lints first: they fail in seconds, not after the tests.
cargo fmt --all --check
cargo clippy --workspace --all-targets --locked -- -D warnings
# The core without its GPU backend (how fuzz/ builds it) must build clean too.
cargo clippy -p transcut --lib --no-default-features --locked -- -D warnings

# The GPU tests (core/tests/integration/gpu*.rs, core/tests/gpu_*.rs) need a Vulkan adapter:
# install Mesa's lavapipe (software Vulkan, Debian mesa-vulkan-drivers) when missing, so the GPU
# path is tested on every machine.
bash scripts/install-lavapipe.sh

# Tests run optimised (profile.test has opt-level 2): the mesher and solver tests work at
# real sizes. The slow tier is #[ignore]d and named slow_*.
cargo test --workspace --all-targets --locked
cargo test --workspace --doc --locked
if [ "$slow" = 1 ]; then
    cargo test --workspace --all-targets --locked -- --ignored slow_
fi

# --- C ABI ---------------------------------------------------------------------------------------
# libtranscut.so / .a built by cargo, include/transcut.h compiled as C99 and C++17, and the C
# programs tests/c/marble_sphere.c and tests/c/radiosity_room.c run against both, the shared one under valgrind (tests/c/run.sh installs gcc,
# g++, pkg-config and valgrind when missing). The Rust ABI tests (capi/tests) ran above.
bash tests/c/run.sh

# The Blender add-on (tests/blender): creates .venv with bpy 4.5 from PyPI (and the Debian
# libraries it needs), builds the C ABI library, runs the bpy tests headless with pytest.
# It calls the library tests/c/run.sh has just built (test profile, target/debug).
TRANSCUT_LIB="${TRANSCUT_LIB:-$(cd "${CARGO_TARGET_DIR:-target}/debug" && pwd)/libtranscut.so}" bash tests/blender/run.sh

# Python lint and format (ruff, pinned in the same .venv by scripts/blender-venv.sh): the add-on,
# its tests and scripts/*.py.
bash scripts/lint-python.sh
