#!/usr/bin/env bash
# Two fovea binaries side by side in one run: `fovea bench` with the same arguments, A and B
# alternating ROUNDS times (so a burst of other work on the machine hits both), then each
# binary's frames: per method and resolution the median wall and CPU milliseconds of its
# rounds, the CPU share, and B's CPU-time speedup over A.
#
#   scripts/ab-bench.sh A B ROUNDS [fovea bench options…]
#   e.g. scripts/ab-bench.sh /tmp/fovea-old target/release/fovea 3 \
#          --scene ../shared/scenes/japanese-classroom/scene.xml --lights 12 --res 2k --bvh-rays 0
set -euo pipefail
[ $# -ge 3 ] || { sed -n 2,9p "$0" >&2; exit 2; }
A="$1"; B="$2"; ROUNDS="$3"; shift 3
OUT="$(mktemp -d)"
for r in $(seq 1 "$ROUNDS"); do
  for who in A B; do
    bin="$A"; [ "$who" = B ] && bin="$B"
    "$bin" bench "$@" --json -q > "$OUT/$who-$r.json"
  done
done
python3 - "$OUT" "$ROUNDS" <<'PY'
import json, statistics, sys
out, rounds = sys.argv[1], int(sys.argv[2])
rows = {}
for who in "AB":
    for r in range(1, rounds + 1):
        for run in json.load(open(f"{out}/{who}-{r}.json"))["runs"]:
            key = (f'{run["width"]}x{run["height"]}', run["method"])
            rows.setdefault(key, {}).setdefault(who, []).append(run)
print(f"{'display':>11} {'method':>8} | {'A wall ms':>9} {'A cpu ms':>9} {'A cpu%':>6} | {'B wall ms':>9} {'B cpu ms':>9} {'B cpu%':>6} | B/A cpu speedup")
for (disp, method), by in rows.items():
    med = lambda runs, k: statistics.median(x[k] for x in runs)
    a, b = by["A"], by["B"]
    print(f"{disp:>11} {method:>8} | {med(a,'total_ms'):9.0f} {med(a,'cpu_ms'):9.0f} {100*med(a,'cpu_share'):5.0f}% | "
          f"{med(b,'total_ms'):9.0f} {med(b,'cpu_ms'):9.0f} {100*med(b,'cpu_share'):5.0f}% | {med(a,'cpu_ms')/med(b,'cpu_ms'):.2f}x")
    for k in ("trace", "shade"):
        print(f"{'':>11} {k:>8} | {statistics.median(x['stages_cpu_ms'][k] for x in a):9.0f} cpu ms {'':>10} | "
              f"{statistics.median(x['stages_cpu_ms'][k] for x in b):9.0f} cpu ms {'':>10} | "
              f"{statistics.median(x['stages_cpu_ms'][k] for x in a)/max(1e-9,statistics.median(x['stages_cpu_ms'][k] for x in b)):.2f}x")
PY
