#!/usr/bin/env bash
# Installs lavapipe (Mesa's software Vulkan driver, Debian `mesa-vulkan-drivers`) and the Vulkan
# loader (`libvulkan1`) so that the GPU tests (core/tests/integration/gpu*.rs,
# core/tests/gpu_*.rs) find a Vulkan adapter on a machine without a GPU. Does nothing when a
# Vulkan loader and the lavapipe ICD are present. Uses sudo only when not root. Called from
# scripts/test.sh.
set -euo pipefail

have_loader() { ldconfig -p 2>/dev/null | grep -q 'libvulkan\.so\.1'; }
have_lavapipe() { ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1; }

if have_loader && have_lavapipe; then
    exit 0
fi
if ! command -v apt-get >/dev/null 2>&1; then
    echo "scripts/install-lavapipe.sh: apt-get not found; install Mesa's lavapipe Vulkan driver" \
         "and the Vulkan loader by hand (Debian: mesa-vulkan-drivers libvulkan1)" >&2
    exit 1
fi
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
    SUDO="sudo"
fi
echo "scripts/install-lavapipe.sh: installing mesa-vulkan-drivers libvulkan1 (software Vulkan for the GPU tests)"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends mesa-vulkan-drivers libvulkan1 >/dev/null
if ! (have_loader && have_lavapipe); then
    echo "scripts/install-lavapipe.sh: mesa-vulkan-drivers installed but no lavapipe ICD found" \
         "in /usr/share/vulkan/icd.d" >&2
    exit 1
fi
