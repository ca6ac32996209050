#!/usr/bin/env bash
# The test suite: installs system packages if missing, then runs every test on lavapipe under the
# Khronos validation layer (with synchronization validation) inside a virtual X server, so the
# windowed-path test runs too. Extra arguments go to `cargo test`.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
export VKENGINE_VALIDATION=required
exec xvfb-run -a -s "-screen 0 1024x768x24" cargo test --workspace --locked "$@"
