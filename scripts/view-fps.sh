#!/usr/bin/env bash
# fovea view's frame rate, headless, side by side in one run: VaFR on the CPU path at full
# and half scale and on the GPU backend (primary rays + reconstruction on wgpu; lavapipe where
# there is no hardware GPU), and full resolution on the CPU at both scales, at a headset
# preset, under Xvfb when no display is set. Prints each run's frames per second (frames over
# the whole run, window start-up included), the mean milliseconds of a frame's rendering, the
# fps ratio to VaFR on the CPU at full scale, and the process's CPU time and share.
#
#   scripts/view-fps.sh [HEADSET] [FRAMES]      (defaults: vive-pro-eye 6)
#
# Needs a fovea built with `--features view` (target/release/fovea, or $FOVEA) and, without a
# display, xvfb-run (Debian: xvfb).
set -euo pipefail
cd "$(dirname "$0")/.."
HEADSET="${1:-vive-pro-eye}"
FRAMES="${2:-6}"
FOVEA="${FOVEA:-target/release/fovea}"
[ -x "$FOVEA" ] || { echo "no $FOVEA: cargo build --release --features view" >&2; exit 2; }
WRAP=()
if [ -z "${DISPLAY:-}" ] && [ -z "${WAYLAND_DISPLAY:-}" ]; then
  command -v xvfb-run >/dev/null || { echo "no display and no xvfb-run (apt-get install xvfb)" >&2; exit 2; }
  WRAP=(xvfb-run -a -s "-screen 0 1920x1080x24")
fi
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
OUT="$(mktemp -d)"
printf 't,x,y\n0,500,700\n0.05,900,800\n' > "$OUT/gaze.csv"
echo "fovea view --headset $HEADSET --frames $FRAMES, gaze CSV, $(nproc) cores; $(date -u +%FT%TZ)"
printf '%-28s %8s %10s %8s %10s %7s\n' run fps ms/frame ratio cpu_s cpu%
base=""
for run in "vafr cpu 1" "vafr cpu 0.5" "vafr gpu 1" "full cpu 1" "full cpu 0.5"; do
  set -- $run
  log="$OUT/$1-$2-$3.log"
  /usr/bin/time -f "%U %S %P" -o "$OUT/time" "${WRAP[@]}" "$FOVEA" view --headset "$HEADSET" \
    --frames "$FRAMES" --gaze-csv "$OUT/gaze.csv" --method "$1" --backend "$2" --scale "$3" -q \
    > "$log" 2>&1 || { echo "$1 $2 scale $3 failed:"; tail -3 "$log"; continue; }
  fps=$(sed -n 's/.*s: \([0-9.]*\) fps, \([0-9]*\) ms a frame.*/\1/p' "$log")
  ms=$(sed -n 's/.*fps, \([0-9]*\) ms a frame.*/\1/p' "$log")
  read -r u s p < "$OUT/time"
  [ -z "$base" ] && base="$fps"
  ratio=$(awk -v a="$fps" -v b="$base" 'BEGIN { printf "%.2f", a / b }')
  cpu=$(awk -v u="$u" -v s="$s" 'BEGIN { printf "%.1f", u + s }')
  printf '%-28s %8s %10s %8s %10s %7s\n' "$1, $2, scale $3" "$fps" "$ms" "${ratio}x" "$cpu" "$p"
  grep -o 'window: [^|]*' "$log" | head -1 | sed 's/^/    /'
done
