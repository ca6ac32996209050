#!/usr/bin/env bash
# The GPU check in one command (issue 38; docs/testing.md#on-a-gpu).
#   tools/gpu_check.sh pack        on the build machine: release build of every binary and test,
#                                  packed with the Vulkan loader, validation layer and libglvnd
#                                  into .gpu/ (git-ignored) for a machine that reaches no registry
#   tools/gpu_check.sh run [S]     on the GPU machine, in the checkout the bundle came with
#                                  (the device tool: carry .gpu): tools/gpu/check.sh .gpu S
#   tools/gpu_check.sh local [S]   the same run here, against whatever device the loader finds
#                                  (lavapipe on the build machine): a dry run of the whole check
# The run writes report.md and its logs to $OUT/gpu-check (default /tmp/gpu-check).
set -euo pipefail
cd "$(dirname "$0")/.."
case "${1:-pack}" in
  pack)
    tools/setup.sh
    # CARGO_INCREMENTAL=0 keeps the release target small; tests are built, not run.
    CARGO_INCREMENTAL=0 cargo build --release --locked --workspace --bins
    CARGO_INCREMENTAL=0 cargo test --release --locked --workspace --no-run
    tools/gpu/pack.sh .gpu
    echo "gpu_check: bundle in .gpu/; on the GPU machine: tools/gpu_check.sh run"
    ;;
  run) exec bash tools/gpu/check.sh .gpu "${2:-480}" ;;
  local)
    mkdir -p .gpu && pwd > .gpu/root.txt && git rev-parse HEAD > .gpu/commit.txt
    exec bash tools/gpu/check.sh .gpu "${2:-900}" --local
    ;;
  *) echo "usage: tools/gpu_check.sh pack | run [SECONDS] | local [SECONDS]" >&2; exit 2 ;;
esac
