#!/usr/bin/env bash
# The cost of covering the whole screen (issue 17): VaFR's default buffer (out to the farthest
# screen corner from the gaze) against the paper's fixed 60° buffer (--vafr-emax 60), the same
# binary, alternating, three rounds, at three gazes on the Vive Pro Eye (built-in scene).
# Prints round, buffer, gaze, samples, rays, wall ms, CPU ms and CPU share per frame.
# Usage: scripts/coverage-cost.sh [HEADSET]   (after cargo build --release)
set -euo pipefail
cd "$(dirname "$0")/.."
headset="${1:-vive-pro-eye}"
bin=target/release/fovea
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "round buffer gaze samples rays wall_ms cpu_ms cpu_share"
for round in 1 2 3; do
  for buffer in screen paper; do
    extra=()
    [ "$buffer" = paper ] && extra=(--vafr-emax 60)
    for gaze in 720,800 1100,1200 0,0; do
      "$bin" render --headset "$headset" --method vafr --gaze "$gaze" "${extra[@]}" -q \
        --out "$out/f.png" >/dev/null 2>&1
      python3 - "$out/f.json" "$round" "$buffer" "$gaze" <<'PY'
import json, sys
f = json.load(open(sys.argv[1]))["frame"]
print(*sys.argv[2:5], f["samples"], f["rays"], round(f["total_ms"]), round(f["total_cpu_ms"]),
      f"{f['total_cpu_ms'] / f['total_ms']:.2f}")
PY
    done
  done
done
