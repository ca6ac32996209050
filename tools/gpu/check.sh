#!/usr/bin/env bash
# Runs on the GPU machine, from the folder above BUNDLE (tools/gpu_check.sh run calls it): the
# golden configurations against lavapipe's goldens with per-renderer tolerances (the golden test
# binary's system-device test), every integration test on the system device under the validation
# layer, the bounded-work checks, then the headline benchmarks with validation off and the GPU
# warmed up first. Writes one report, report.md, beside the logs in $OUT/gpu-check/ (and a
# tarball of them split at 15 MiB, $OUT/gpu-check.tgz.*; rejoin with cat).
# Usage: bash BUNDLE/check.sh [BUNDLE] [SECONDS] [--local]
#   SECONDS: the whole run's budget (default 480); steps that would not fit are skipped and say so.
#   --local: use the checkout and installed packages as they are (a dry run on the build machine).
set -u
B0=${1:-.gpu}; BUDGET=${2:-480}; LOCAL=${3:-}
T0=$(date +%s)
left() { echo $(( BUDGET - ($(date +%s) - T0) )); }
R=${OUT:-/tmp}/gpu-check; rm -rf "$R"; mkdir -p "$R/tests" "$R/bench"
log() { echo "$*" | tee -a "$R/steps.txt"; }
if [ "$LOCAL" != "--local" ]; then
  # The machine reaches no registry: Debian's loader, validation layer and libglvnd from the bundle.
  for f in "$B0"/debs/*.deb; do dpkg -x "$f" /; done; ldconfig
  ROOT=$(cat "$B0/root.txt"); mkdir -p "$ROOT" && tar -C "$ROOT" -xJf "$B0/proj.tar.xz"
  icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json; [ -f $icd ] && export VK_DRIVER_FILES=$icd
else
  ROOT=$(cat "$B0/root.txt")
fi
B=$ROOT/target/release; cd "$ROOT" || exit 1
# Image sizes and frame counts of the benchmarks: a GPU's, or a CPU driver's for the dry run.
if [ "$LOCAL" = "--local" ]; then BIG=128; MID=128; FRAMES=16; PEER=64; else BIG=1024; MID=512; FRAMES=256; PEER=1024; fi
export XDG_RUNTIME_DIR=/tmp/xdg; mkdir -p $XDG_RUNTIME_DIR
if command -v nvidia-smi >/dev/null; then nvidia-smi > "$R/nvidia-smi.txt" 2>&1; else : > "$R/nvidia-smi.txt"; fi
# step NAME SECONDS CMD...: runs CMD with at most SECONDS (less if the budget is short), logs rc/time.
step() {
  local name=$1 t=$2 l; shift 2; l=$(left)
  if [ "$l" -lt 15 ]; then log "$name: skipped (budget spent)"; return 1; fi
  [ "$t" -gt "$l" ] && t=$l
  local s=$(date +%s); timeout "$t" "$@" > "$R/$name.log" 2>&1; local rc=$?
  log "$name: rc=$rc $(( $(date +%s) - s )) s"; return $rc
}
log "commit $(cat "$B0/commit.txt" 2>/dev/null)"
# 1. Which device, and its limits (the tolerances derive from subTexelPrecisionBits).
step bench/device 60 "$B/device_limits" --quick --out "$R/bench/limits"
# 2. Every integration test on the system device, validation required (the golden binary holds
#    the per-renderer comparison; tests pinned to lavapipe skip themselves and say why).
export VKENGINE_VALIDATION=required VKENGINE_TEST_DEVICE=system
for t in "$ROOT"/tests/*.rs "$ROOT"/demos/tests/*.rs; do
  n=$(basename "$t" .rs)
  # The newest build of each integration test (a local target folder also holds older hashes
  # and every dependency).
  exe=$(ls -t "$B"/deps/"$n"-* 2>/dev/null | grep -v '\.d$' | head -1)
  [ -n "$exe" ] && [ -x "$exe" ] || { log "tests/$n: no binary"; continue; }
  step "tests/$n" 150 "$exe" --test-threads 4
  grep -h '^test result' "$R/tests/$n.log" 2>/dev/null | tail -1 | sed "s/^/$n: /" >> "$R/tests/summary.txt"
  grep -h -A4 'panicked' "$R/tests/$n.log" 2>/dev/null | sed "s/^/$n: /" >> "$R/tests/panics.txt"
  grep -h 'skipped on the system device' "$R/tests/$n.log" 2>/dev/null | sort -u | sed "s/^/$n: /" >> "$R/tests/skipped.txt"
done
# 3. Bounded work: ×1e6 with the defaults (mc_budget=auto) at 1024², every MC dispatch under
#    mc_dispatch_ms (100), and an explicit mc_budget=0 there refused with exit 2.
step bench/dense-auto 120 "$B/volume" --headless --renderer mcm --size ${BIG}x$BIG --frames 8 --set density=1000000 \
  --out "$R/bench/dense-auto.exr" --report "$R/bench/dense-auto.json"
step bench/dense-classic 60 "$B/volume" --headless --renderer mcm --size ${BIG}x$BIG --frames 1 --set density=1000000 \
  --set mc_budget=0 --out "$R/bench/dense-classic.exr"
unset VKENGINE_VALIDATION VKENGINE_TEST_DEVICE
# 4. Headline benchmarks, validation off, after a warm-up (an idle GPU clocks down: one pass
#    measured 0.64 ms in one configuration and 2.0 ms in the next).
step bench/warmup 40 "$B/volume" --headless --renderer mcm --size ${BIG}x$BIG --warmup 0 --frames $FRAMES --out "$R/bench/warmup.png"
step bench/mcm512 60 "$B/volume" --headless --renderer mcm --size ${MID}x$MID --warmup 64 --frames $FRAMES \
  --out "$R/bench/mcm512.png" --report "$R/bench/mcm512.json"
if [ -f "$B0/cloud128.raw" ]; then
  step bench/vpt 200 "$B/volume_bench" --peer-scene vpt --peer-volume "$B0/cloud128.raw" --size $MID \
    --peer-frames $PEER --peer-reference-frames $((4 * PEER)) --out "$R/bench/vpt"
fi
step bench/lpv-thesis 150 "$B/lpv_bench" --sweep thesis-config --quick --out "$R/bench/lpv"
step bench/mesh 60 "$B/mesh_bench" --out "$R/bench/mesh"
# Issue 39/40: the LPV dispatch layouts and the sparse volume layout as this GPU runs them.
step bench/volume-layout 90 "$B/volume_bench" --layout --size $MID --out "$R/bench/layout"
# 5. One report.
# The per-pass [name, GPU ms] list of a demo's --report.
passes() { tr -d '\n ' < "$1" 2>/dev/null | sed -n 's/.*"passes":\(\[\[[^}]*\]\]\).*/\1/p'; }
grep -h "vulkan validation" "$R"/tests/*.log "$R"/bench/*.log 2>/dev/null | sort | uniq -c > "$R/validation.txt"
{
  echo "# GPU check: $(cat "$B0/commit.txt" 2>/dev/null)"
  echo; echo "Device: $(grep -m1 -h '"name"' "$R/bench/limits/limits.json" 2>/dev/null | sed 's/^ *//')"
  head -12 "$R/nvidia-smi.txt" | sed 's/^/    /'
  echo; echo "## Steps"; sed 's/^/- /' "$R/steps.txt"
  echo; echo "## Tests (system device, validation required)"; sed 's/^/- /' "$R/tests/summary.txt"
  echo; echo "Validation messages: $(awk '{s += $1} END {print s + 0}' "$R/validation.txt")"
  echo; echo "### Skipped: pinned to lavapipe on purpose"; sed 's/^/- /' "$R/tests/skipped.txt" 2>/dev/null
  echo; echo "### Failures"; echo '```'; head -150 "$R/tests/panics.txt" 2>/dev/null; echo '```'
  echo; echo "## Golden configurations (per-renderer tolerance)"; echo '```'
  grep -h -E "\((Exact|Noise)\)" "$R"/tests/golden.log 2>/dev/null; echo '```'
  echo; echo "## Bounded work at density 1e6"
  echo "- auto, ${BIG}², per-pass GPU ms: $(passes "$R/bench/dense-auto.json")"
  echo "- mc_budget=0: $(grep -m1 -i 'mc_budget' "$R/bench/dense-classic.log" 2>/dev/null)"
  echo; echo "## Benchmarks"
  echo "- MCM ${MID}², per-pass GPU ms: $(passes "$R/bench/mcm512.json")"
  echo; echo '```'; tail -25 "$R/bench/vpt.log" 2>/dev/null; echo '```'
  echo; echo '```'; grep -h '^LPV:' "$R/bench/lpv-thesis.log" 2>/dev/null; tail -25 "$R/bench/lpv-thesis.log" 2>/dev/null; echo '```'
  echo; echo "### Volume layout, sparse against dense"; echo '```'; cat "$R/bench/layout/layout.csv" 2>/dev/null; echo '```'
} > "$R/report.md"
tar -C "$(dirname "$R")" -czf - "$(basename "$R")" | split -b 15M - "${OUT:-/tmp}/gpu-check.tgz."
cat "$R/report.md" | head -80
