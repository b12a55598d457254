#!/usr/bin/env bash
# GPU benchmark: the Stanford bunny at 500k and 1M tets, diffusion solve on the CPU and
# on the GPU (upload, assembly on the device, solve with read-back) with Jacobi PCG ("gpu") and
# with multigrid-preconditioned CG, the V-cycle on the device ("gpu_multigrid", its CPU setup
# timed apart), JSON on stdout with the device name. Run on a machine with a GPU; on one without, install lavapipe first
# (scripts/install-lavapipe.sh) and the numbers are software-Vulkan ones.
#   usage: scripts/bench-gpu.sh [TETS (comma-separated)] [RUNS]
set -euo pipefail
cd "$(dirname "$0")/.."
tets="${1:-500000,1000000}"
runs="${2:-3}"
cargo build --release --locked -p transcut-cli >&2
exec "${CARGO_TARGET_DIR:-target}/release/transcut" bench solve --backend gpu \
    --input assets/meshes/stanford-bunny.obj --tets "$tets" --runs "$runs"
