#!/usr/bin/env bash
# Packs a release build of this checkout for a GPU machine that reaches no package registry
# (tools/gpu_check.sh pack calls it after building). BUNDLE (default .gpu/, git-ignored) gets:
# proj.tar.xz (every release binary and integration-test binary, stripped, plus the folders the
# tests read at run time), root.txt (this checkout's absolute path: test binaries compile it in,
# so check.sh unpacks them at that same path), debs/ (the Vulkan loader, the Khronos validation
# layer and libglvnd, without which the NVIDIA ICD fails to load: "Could not get
# 'vkCreateInstance' via 'vk_icdGetInstanceProcAddr' for ICD libGLX_nvidia.so.0") and check.sh.
# xz -9e's 64 MiB window stores the shared code of ~40 binaries once: ~200 MB packs to 15-35 MB.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
BUNDLE=${1:-$ROOT/.gpu}
REL=${CARGO_TARGET_DIR:-$ROOT/target}/release
mkdir -p "$BUNDLE/debs"
STAGE=$(mktemp -d)
trap 'rm -rf "$STAGE"' EXIT
mkdir -p "$STAGE/target/release/deps"
for f in "$REL"/*; do [ -f "$f" ] && [ -x "$f" ] && cp "$f" "$STAGE/target/release/"; done
n_tests=0
for t in "$ROOT"/tests/*.rs "$ROOT"/demos/tests/*.rs; do
  n=$(basename "$t" .rs)
  # The newest build of each test binary (older hashes may linger in deps/).
  exe=$(ls -t "$REL"/deps/"$n"-* 2>/dev/null | grep -v '\.d$' | head -1 || true)
  if [ -n "$exe" ]; then cp "$exe" "$STAGE/target/release/deps/"; n_tests=$((n_tests + 1)); fi
done
[ "$n_tests" -gt 0 ] || { echo "pack.sh: no release test binaries in $REL/deps (run tools/gpu_check.sh pack)" >&2; exit 1; }
strip "$STAGE"/target/release/* "$STAGE"/target/release/deps/* 2>/dev/null || true
# What tests and benchmarks read at run time (shader sources: the SIMD-width test; docs: the
# settings tables; results: device_limits' reference; tests/golden: the goldens).
for d in tests demos/tests shaders_glsl docs results/device_limits; do
  [ -d "$ROOT/$d" ] && mkdir -p "$STAGE/$(dirname "$d")" && cp -r "$ROOT/$d" "$STAGE/$d"
done
tar -C "$STAGE" -cf - . | xz -9e -T1 > "$BUNDLE/proj.tar.xz"
echo "$ROOT" > "$BUNDLE/root.txt"
git -C "$ROOT" rev-parse HEAD > "$BUNDLE/commit.txt" 2>/dev/null || echo unknown > "$BUNDLE/commit.txt"
cp "$ROOT/tools/gpu/check.sh" "$BUNDLE/check.sh"
for deb in libvulkan1 vulkan-validationlayers libglvnd0 libglx0 libgl1 libegl1 libgles2 libopengl0; do
  ls "$BUNDLE/debs/${deb}_"*.deb >/dev/null 2>&1 || (cd "$BUNDLE/debs" && apt-get download "$deb" >/dev/null 2>&1) \
    || { echo "pack.sh: could not download $deb (run apt-get update first)" >&2; exit 1; }
done
echo "pack.sh: $n_tests test binaries; $(du -sh "$BUNDLE" | cut -f1) in $BUNDLE ($(du -h "$BUNDLE/proj.tar.xz" | cut -f1) proj.tar.xz)"
# vpt's scene for the headline Monte Carlo comparison (shared/ does not travel to the GPU machine).
SHARED=$ROOT/../shared/peers/vpt/harness/make_volume.py
if [ ! -f "$BUNDLE/cloud128.raw" ] && [ -f "$SHARED" ]; then
  python3 -c "import numpy" 2>/dev/null || pip install -q numpy >/dev/null 2>&1 || true
  python3 "$SHARED" "$BUNDLE/cloud128.raw" >/dev/null || echo "pack.sh: could not make vpt's cloud (numpy?); the vpt benchmark will be skipped" >&2
fi
