#!/usr/bin/env bash
# Quick start: installs system packages if missing, then renders the main demo headless: the
# Monte Carlo path tracer (multiple scattering, sun and environment light, bounded work per frame)
# on the built-in 128³ cloud, framed close and lit from the side → out/volume.png with a JSON
# report beside it (about 15 s of rendering on 2 CPU cores with lavapipe). Arguments replace
# those defaults (see --help), e.g. `tools/demo.sh --renderer eam --frames 4`.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh
if [ $# -eq 0 ]; then
    set -- --renderer mcm --size 320x320 --frames 12 --set distance=1.3 --set density=3 --set env=0.08 \
        --set yaw=2.2 --set pitch=0.2 --set bounces=16 --set exposure=1.6 --set mc_budget=2048
fi
exec cargo run --locked --release --bin volume -- --headless --out out/volume.png --report out/volume.json "$@"
