#!/usr/bin/env bash
# Foveated JOD (FovVideoVDP, the metric of Liu et al.) and ꟻLIP of foveated frames against a
# 16-ray supersampled full frame, with the optional evaluator beside the repository
# (../shared/tools/perceptual, installed as its README says into ~/.venvs/perceptual; never
# part of CI). Renders each scene at each gaze on a headset preset, once per VARIANT (extra
# `fovea render` options, quoted; "" = the defaults), and prints one Markdown row per frame.
# Usage: scripts/perceptual-jod.sh FOVEA HEADSET FOV_H_DEG "GAZE GAZE ..." SCENE... -- VARIANT...
#   e.g. scripts/perceptual-jod.sh target/release/fovea vive-pro-eye 104.2 "720,800 981,800 100,100" \
#          builtin classroom -- "--method vafr" "--method vafr --periphery-rays 1"
set -euo pipefail
cd "$(dirname "$0")/.."
bin=$1 headset=$2 fov_h=$3 gazes=$4
shift 4
scenes=()
while [ "$1" != "--" ]; do scenes+=("$1"); shift; done
shift
P=${PERCEPTUAL_PYTHON:-$HOME/.venvs/perceptual/bin/python}
EVAL=../shared/tools/perceptual/perceptual_eval.py
[ -x "$P" ] || { echo "perceptual-jod: no evaluator Python at $P (see $EVAL's README)" >&2; exit 2; }
S=../shared/scenes
scene_args() {
  case $1 in
    builtin) ;;
    classroom) echo "--scene $S/japanese-classroom/scene.xml --lights 4" ;;
    classroom-close) echo "--scene $S/japanese-classroom/scene.xml --camera-pos=-1.4,1.05,4.0 --look-at=-1.0,0.7,0.0 --lights 4" ;;
    chess) echo "--scene $S/chess-board/chess-board.plain.glb --scene-scale 0.002 --camera-pos 0,0.25,0.36 --look-at 0,0.03,0.0 --lights 4" ;;
    *) echo "perceptual-jod: unknown scene $1" >&2; exit 2 ;;
  esac
}
out=${OUT:-$(mktemp -d)}
pairs=$out/pairs.txt
: > "$pairs"
rows=()
for sc in "${scenes[@]}"; do
  for g in $gazes; do
    ref=$out/$sc-$g-ref.png
    # shellcheck disable=SC2046
    [ -s "$ref" ] || "$bin" render --headset "$headset" --method full --pixel-samples 16 --gaze "$g" \
      $(scene_args "$sc") -q --out "$ref" >/dev/null
    k=0
    for v in "$@"; do
      k=$((k + 1))
      img=$out/$sc-$g-v$k.png
      # shellcheck disable=SC2046,SC2086
      "$bin" render --headset "$headset" --gaze "$g" $(scene_args "$sc") $v -q --out "$img" >/dev/null
      rays=$(python3 -c "import json,sys; s=json.load(open(sys.argv[1])); print(s['frame']['rays_primary'])" "${img%.png}.json" 2>/dev/null || echo "?")
      echo "$ref $img ${g%,*} ${g#*,}" >> "$pairs"
      rows+=("$sc|$g|${v:-defaults}|$rays")
      echo "rendered $sc $g variant $k" >&2
    done
  done
done
"$P" "$EVAL" --batch "$pairs" --fov-h "$fov_h" --metrics fvvdp_foveated,flip > "$out/scores.jsonl"
echo "| scene | gaze | options | primary rays | FovVideoVDP foveated JOD | ꟻLIP |"
echo "|---|---|---|---:|---:|---:|"
i=0
while IFS= read -r line; do
  IFS='|' read -r sc g v rays <<< "${rows[$i]}"
  python3 -c "import json,sys; d=json.loads(sys.argv[1]); print(f\"| {sys.argv[2]} | {sys.argv[3]} | \`{sys.argv[4]}\` | {sys.argv[5]} | {d.get('fvvdp_jod_foveated', float('nan')):.3f} | {d.get('flip_mean', float('nan')):.4f} |\")" "$line" "$sc" "$g" "$v" "$rays"
  i=$((i + 1))
done < "$out/scores.jsonl"
echo "(frames and scores in $out)" >&2
