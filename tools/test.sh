#!/usr/bin/env bash
# The test suite: installs system packages if missing, then runs every test on lavapipe under the
# Khronos validation layer (with synchronization validation) inside a virtual X server, so the
# windowed-path test runs too. Extra arguments go to `cargo test`.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
# Both make a missing piece a failure, not a skip: the validation layer, and (since everything
# runs inside Xvfb) the display of the window tests.
export VKENGINE_VALIDATION=required
export VKENGINE_REQUIRE_DISPLAY=1
exec xvfb-run -a -s "-screen 0 1024x768x24" cargo test --workspace --locked "$@"
