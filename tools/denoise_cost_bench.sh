#!/bin/bash
# The denoiser's cost against the Monte Carlo frame: MCM at 512² on the default cloud with
# denoise=on, three frames of one view, GPU time per pass from the frame graph's timestamps
# (`--profile`). Builds OLD and NEW (two release builds of the volume demo; NEW alone if OLD is
# unset) alternate, ROUNDS rounds. Writes CSV to stdout (results/volume_bench/denoise_cost.csv):
# per run the MCM frame without the denoiser (mcm + mc accumulate + mc tiles + tonemap), the
# once-per-view feature pass, and per denoised frame the blend, the five à-trous iterations summed
# and the shrink toward the mean (a headless run denoises only its last frame).
# SETS: extra settings, space separated (`SETS="mc_budget=0"`: one whole
# path a frame instead of the default's choice), also written to the CSV's `sets` column.
NEW=${NEW:-target/release/volume}; ROUNDS=${ROUNDS:-3}; SIZE=${SIZE:-512x512}; SETS=${SETS:-}
EXTRA=(); for kv in $SETS; do EXTRA+=(--set "$kv"); done
BUILDS="new"; [ -n "$OLD" ] && BUILDS="old new"
DIR=$(mktemp -d)
echo "round,build,sets,size,mcm_frame_ms,features_ms,blend_ms,atrous_ms,shrink_ms,denoiser_share_per_frame,features_share,features_plus_denoiser_share"
for round in $(seq 1 "$ROUNDS"); do
 for b in $BUILDS; do
  B=$NEW; [ $b = old ] && B=$OLD
  rm -rf "$DIR/p"
  "$B" --renderer mcm --size "$SIZE" --frames 3 --set denoise=on "${EXTRA[@]}" --out "$DIR/out.png" --profile "$DIR/p" >/dev/null 2>&1 || { echo "$b failed" >&2; exit 1; }
  python3 - "$DIR/p/profile.json" "$round" "$b" "$SIZE" "${SETS:-default}" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
frames = d["frames"]
# Per-frame mean of each pass (a pass run k times a frame counts k times). The denoiser's passes
# per denoised frame: a headless run denoises only its last frame (the blend runs once in each).
per = {p["name"]: sum(p["samples_ms"]) / frames for p in d["passes"]}
once = {p["name"]: sum(p["samples_ms"]) for p in d["passes"]}
denoised = max(1, len(next((p["samples_ms"] for p in d["passes"] if p["name"] == "denoise blend"), [])))
frame = sum(per.get(n, 0.0) for n in ("mcm", "mc accumulate", "mc tiles", "tonemap"))
feat = once.get("features", 0.0)
blend, atrous, shrink = (once.get(n, 0.0) / denoised for n in ("denoise blend", "denoise a-trous", "denoise shrink"))
den = blend + atrous + shrink
print(f"{sys.argv[2]},{sys.argv[3]},{sys.argv[5]},{sys.argv[4]},{frame:.1f},{feat:.1f},{blend:.1f},{atrous:.1f},{shrink:.1f},{den/frame:.4f},{feat/frame:.4f},{(den+feat)/frame:.4f}")
PY
 done
done
rm -rf "$DIR"
