#!/usr/bin/env bash
# Idempotent system setup for Debian 12: Vulkan loader + lavapipe + Khronos validation layer,
# the static glslang/SPIRV-Tools/shaderc libraries the shader build links, and Xvfb for the
# windowed test. Fast (one dpkg query) when everything is already present.
set -euo pipefail
PKGS=(
  mesa-vulkan-drivers      # lavapipe (CPU Vulkan 1.3 driver)
  vulkan-validationlayers  # VK_LAYER_KHRONOS_validation
  libvulkan-dev            # loader (libvulkan.so)
  vulkan-tools             # vulkaninfo, for diagnosing a device
  libshaderc-dev glslang-dev spirv-tools  # static libs linked by build.rs (see docs/architecture.md)
  xvfb xauth               # windowed-path test under a virtual display
  libxkbcommon-x11-0 libx11-xcb1 libxcursor1 libxi6 libxrandr2  # winit's X11 backend (dlopen'd)
  pkg-config cmake         # shaderc-sys build script probes
)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
if [ "$(id -u)" -ne 0 ]; then SUDO=sudo; else SUDO=; fi
echo "setup: installing ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
