#!/usr/bin/env bash
# Quick start: installs system packages if missing, then renders the main demo headless: the
# volume renderer on its built-in 128³ cloud → out/volume.png with a JSON report beside it.
# Extra arguments go to the demo (see --help), e.g. `tools/demo.sh --renderer mcm --frames 32`.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
exec cargo run --locked --release --bin volume -- --headless --frames 4 --out out/volume.png --report out/volume.json "$@"
