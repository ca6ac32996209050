#!/usr/bin/env bash
# The test suite: installs system packages if missing, then runs every test on lavapipe under the
# Khronos validation layer (with synchronization validation) inside a virtual X server, so the
# windowed-path test runs too; then the Python package's tests (pytest). Extra arguments go to
# `cargo test`.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh --python
# Both make a missing piece a failure, not a skip: the validation layer, and (since everything
# runs inside Xvfb) the display of the window tests.
export VKENGINE_VALIDATION=required
export VKENGINE_REQUIRE_DISPLAY=1
# mc_budget=auto's device measurement is kept between processes (engine/volume/render/mc_calibrate.rs):
# a fresh store per run, so the suite measures once and depends on nothing kept from earlier runs.
export VKENGINE_CACHE_DIR="${VKENGINE_CACHE_DIR:-$(mktemp -d)}"
xvfb-run -a -s "-screen 0 1024x768x24" cargo test --workspace --locked "$@"
# The Python package: built into .venv (dev profile, sharing cargo test's build), then its tests,
# which compare with the `volume` and `cornell` binaries cargo test built and start a local 2-worker Dask cluster.
cargo build --locked --bin volume --bin cornell
VIRTUAL_ENV="$PWD/.venv" .venv/bin/maturin develop --locked -q -m python/Cargo.toml
.venv/bin/python -m pytest -q python/tests
