#!/usr/bin/env bash
# VaFR's quality by eccentricity band at three gazes on three scenes, against a 16-ray
# supersampled full frame (issue 17): `fovea report --sections quality` per scene and gaze,
# on the Vive Pro Eye's 1440×1600 panel with square pixels and a 110° vertical field of view
# (given explicitly so an older revision renders the same display), then one Markdown table:
# VaFR's ꟻLIP per band with this binary and, optionally, an older one (e.g. the previous
# main, built with `git worktree add ../prev REV && cd ../prev && cargo build --release`),
# KFR's and the one-ray full frame's, and VaFR's sample count.
# Usage: scripts/quality-by-gaze.sh NEW_FOVEA [OLD_FOVEA]   (needs ../shared/scenes)
set -euo pipefail
cd "$(dirname "$0")/.."
new=$1
old=${2:-}
out=$(mktemp -d)
S=../shared/scenes
scene_args() {
  case $1 in
    builtin) ;;
    classroom) echo "--scene $S/japanese-classroom/scene.xml --camera-pos=-1.4,1.05,4.0 --look-at=-1.0,0.7,0.0 --lights 4" ;;
    chess) echo "--scene $S/chess-board/chess-board.plain.glb --scene-scale 0.002 --camera-pos 0,0.25,0.36 --look-at 0,0.03,0.0 --lights 4" ;;
  esac
}
for label in new old; do
  bin=${!label}
  [ -z "$bin" ] && continue
  for sc in builtin classroom chess; do
    # Centre, 25° right of it (tan 25° × 560.2 px of focal length), near the top-left corner.
    for g in 720,800 981,800 100,100; do
      # shellcheck disable=SC2046
      "$bin" report --sections quality --res 1440x1600 --vfov 110 --reference-pixel-samples 16 \
        --gaze "$g" $(scene_args $sc) -q --out "$out/$label-$sc-$g" >/dev/null
      echo "done: $label $sc $g" >&2
    done
  done
done
python3 - "$out" <<'PY'
import json, os, sys
out = sys.argv[1]
def load(label, sc, g):
    p = f"{out}/{label}-{sc}-{g}/report.json"
    if not os.path.exists(p):
        return None
    s = [x for x in json.load(open(p))["sections"] if x["id"] == "quality"][0]
    return {m["method"]: m for m in s["data"]["methods"]}
names = {"720,800": "centre (720,800)", "981,800": "25° right (981,800)", "100,100": "near corner (100,100)"}
f = lambda x: "—" if x is None else f"{x:.4f}"
print("| scene | gaze | band | VaFR ꟻLIP, old | VaFR ꟻLIP, new | KFR ꟻLIP, new | one-ray full ꟻLIP | VaFR samples, old → new |")
print("|---|---|---|---|---|---|---|---|")
for sc in ["builtin", "classroom", "chess"]:
    for g in names:
        new, old = load("new", sc, g), load("old", sc, g)
        ob = old["vafr"]["bands"] if old else None
        for i, b in enumerate(new["vafr"]["bands"]):
            band = f"{b['lo_deg']:g}–{b['hi_deg']:g}°" if b["hi_deg"] is not None else f"> {b['lo_deg']:g}°"
            full = new["full"]["bands"][i]["flip"] if "full" in new else None
            count = f"{old['vafr']['samples']:,} → " if old else ""
            count = f"{count}{new['vafr']['samples']:,}" if i == 0 else ""
            print(f"| {sc if i == 0 else ''} | {names[g] if i == 0 else ''} | {band} | "
                  f"{f(ob[i]['flip'] if ob else None)} | {f(b['flip'])} | "
                  f"{f(new['kfr']['bands'][i]['flip'])} | {f(full)} | {count} |")
PY
rm -rf "$out"
