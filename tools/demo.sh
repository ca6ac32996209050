#!/usr/bin/env bash
# Quick start: installs system packages if missing, then renders the default demo headless to
# out/hello.png with a JSON report beside it. Extra arguments go to the demo (see --help).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
exec cargo run --locked --release --bin hello -- --headless --out out/hello.png --report out/hello.json "$@"
