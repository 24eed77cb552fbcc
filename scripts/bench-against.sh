#!/usr/bin/env bash
# Times `fovea bench` of this checkout against another git revision, side by side in one run:
# both binaries run alternately, ROUNDS times, with the same arguments; prints each run's
# per-stage wall and CPU milliseconds, the process's CPU share, and the ratios (other / this).
#
#   scripts/bench-against.sh REV [ROUNDS] -- BENCH_ARGS...
#   scripts/bench-against.sh bf68780 2 -- --res 8k --methods vafr --bvh-rays 0 --lights 1
#
# REV is built once in a git worktree under ${TMPDIR:-/tmp} (a cold release build: minutes).
set -euo pipefail
cd "$(dirname "$0")/.."
rev=${1:?usage: scripts/bench-against.sh REV [ROUNDS] -- BENCH_ARGS...}
shift
rounds=1
if [ "${1:-}" != "--" ] && [ -n "${1:-}" ]; then rounds=$1; shift; fi
[ "${1:-}" = "--" ] && shift
tmp=${TMPDIR:-/tmp}
short=$(git rev-parse --short "$rev")
tree="$tmp/fovea-rev-$short"
if [ ! -x "$tree/target/release/fovea" ]; then
  [ -d "$tree" ] || git worktree add --detach "$tree" "$rev" >/dev/null
  (cd "$tree" && cargo build --release --locked -q)
fi
cargo build --release --locked -q
other="$tree/target/release/fovea"
this="target/release/fovea"
out=$(mktemp -d)
for r in $(seq 1 "$rounds"); do
  for who in other this; do
    bin=$other; [ $who = this ] && bin=$this
    /usr/bin/time -f "%e %U %S" -o "$out/$who-$r.time" "$bin" bench "$@" -q --json >"$out/$who-$r.json"
  done
done
python3 - "$out" "$rounds" "$short" <<'PY'
import json, sys
out, rounds, short = sys.argv[1], int(sys.argv[2]), sys.argv[3]
stages = ["plan", "trace", "shade", "aa", "reconstruct"]
rows = {}
for who in ["other", "this"]:
    for r in range(1, rounds + 1):
        d = json.load(open(f"{out}/{who}-{r}.json"))
        wall, user, sys_ = map(float, open(f"{out}/{who}-{r}.time").read().split())
        share = (user + sys_) / wall / d.get("threads", 1)
        for run in d["runs"]:
            key = (run["method"], run["width"], run["height"])
            rows.setdefault(key, {}).setdefault(who, []).append((run, share))
label = {"other": short, "this": "this"}
for (m, w, h), by in rows.items():
    print(f"{m} {w}x{h}")
    for who in ["other", "this"]:
        for run, share in by.get(who, []):
            st = " ".join(f"{s} {run['stages_ms'].get(s, 0):.0f}/{run['stages_cpu_ms'].get(s, 0):.0f}" for s in stages)
            print(f"  {label[who]:>8}: wall/cpu ms: {st} | total {run['total_ms']:.0f}/{run['cpu_ms']:.0f} | process cpu share {share:.0%}")
    if "other" in by and "this" in by:
        med = lambda xs: sorted(xs)[len(xs) // 2]
        for s in ["reconstruct", "aa", "trace", "shade"]:
            o = med([r["stages_cpu_ms"].get(s, 0) for r, _ in by["other"]])
            t = med([r["stages_cpu_ms"].get(s, 0) for r, _ in by["this"]])
            if o > 0 and t > 0:
                print(f"  {s}: {short} / this = {o / t:.2f}x (CPU time, median of {rounds})")
        o = med([r["cpu_ms"] for r, _ in by["other"]]); t = med([r["cpu_ms"] for r, _ in by["this"]])
        print(f"  frame: {short} / this = {o / t:.2f}x (CPU time)")
PY
