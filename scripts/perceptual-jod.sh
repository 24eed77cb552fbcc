#!/usr/bin/env bash
# Foveated JOD (FovVideoVDP, the metric of Liu et al.) and ꟻLIP of foveated frames against a
# supersampled full-resolution frame of the same shading, not denoised, with the optional
# evaluator beside the repository (../shared/tools/perceptual, installed as its README says
# into ~/.venvs/perceptual; never part of CI). Renders each scene at each gaze on a headset
# preset, once per VARIANT, and prints one Markdown row per frame.
# Usage: scripts/perceptual-jod.sh FOVEA HEADSET FOV_H_DEG "GAZE GAZE ..." SCENE... -- VARIANT...
#   e.g. scripts/perceptual-jod.sh target/release/fovea vive-pro-eye 104.2 "720,800 981,800 100,100" \
#          builtin classroom -- "--method vafr" "--method vafr --periphery-rays 1"
# (no VARIANT after "--": only the noise floor's rows, with REF_FLOOR=1)
# A VARIANT is extra `fovea render` options, quoted ("" = the defaults), or
# "sequence N OPTIONS": a still view (camera and gaze held) of N frames of `fovea sequence`
# with OPTIONS (accumulation on by default), scored at frame 0 and at frame N-1.
# Environment:
#   REF_SAMPLES  the reference's primary rays per pixel (--pixel-samples; default 16)
#   REF_FLOOR=1  the reference is frame 0 of a 2-frame still `fovea sequence --temporal off`
#                and its twin frame 1, identical but for the seed of the shading's random
#                numbers (the frame index); the twin is scored against the reference at every
#                gaze (a "reference, seed 1" row): the reference's noise floor
#   OUT          folder for the images and scores (default: a new temporary one); references
#                and frames already there are reused (delete them to render again)
#   FOVEA_SHARED the shared folder with scenes/ and tools/perceptual (default ../shared)
#   PERCEPTUAL_PYTHON  the evaluator's Python (default ~/.venvs/perceptual/bin/python)
#   STAGE        refs: render the references only; frames: the variants' frames only (both
#                can run at the same time, e.g. in two shells); score: render nothing, score
#                the pairs whose frames are there; default: render what is missing, then score
# The full-resolution reference does not depend on the gaze, so each scene's reference (and
# twin) is rendered once and shared by its gazes.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=$1 headset=$2 fov_h=$3 gazes=$4
shift 4
scenes=()
while [ "$1" != "--" ]; do scenes+=("$1"); shift; done
shift
SHARED=${FOVEA_SHARED:-../shared}
P=${PERCEPTUAL_PYTHON:-$HOME/.venvs/perceptual/bin/python}
EVAL=$SHARED/tools/perceptual/perceptual_eval.py
[ -x "$P" ] || { echo "perceptual-jod: no evaluator Python at $P (see $EVAL's README)" >&2; exit 2; }
ref_samples=${REF_SAMPLES:-16}
S=$SHARED/scenes
scene_args() {
  case $1 in
    builtin) ;;
    classroom) echo "--scene $S/japanese-classroom/scene.xml --lights 4" ;;
    classroom-close) echo "--scene $S/japanese-classroom/scene.xml --camera-pos=-1.4,1.05,4.0 --look-at=-1.0,0.7,0.0 --lights 4" ;;
    chess) echo "--scene $S/chess-board/chess-board.plain.glb --scene-scale 0.002 --camera-pos 0,0.25,0.36 --look-at 0,0.03,0.0 --lights 4" ;;
    # No lights in the file (4 generated ones); exposure pinned so that every frame is
    # encoded alike whatever the lights' units.
    flight-helmet) echo "--scene $S/flight-helmet/FlightHelmet.gltf --camera-pos 0,0.4,0.5 --look-at 0,0.36,0 --exposure 0" ;;
    *) echo "perceptual-jod: unknown scene $1" >&2; exit 2 ;;
  esac
}
# A still gaze for `fovea sequence --gaze-csv` (one row per second is enough: it is held).
still_csv() {
  local f=$out/still-$1.csv
  [ -s "$f" ] || printf 't,x,y\n0,%s,%s\n1000,%s,%s\n' "${1%,*}" "${1#*,}" "${1%,*}" "${1#*,}" > "$f"
  echo "$f"
}
out=${OUT:-$(mktemp -d)}
mkdir -p "$out"
# One pair list and one score file per run, so that runs can share a folder.
pairs=$out/pairs.$$.txt
scores=$out/scores.$$.jsonl
: > "$pairs"
rows=()
add_pair() { # REF IMG GAZE ROW
  [ "$stage" != score ] || { [ -s "$1" ] && [ -s "$2" ]; } || return 0
  echo "$1 $2 ${3%,*} ${3#*,}" >> "$pairs"
  rows+=("$4")
}
stage=${STAGE:-all}
# The reference of scene $1 (and its twin): sets ref and twin.
ref_paths() {
  ref=$out/$1-ref$ref_samples.png
  twin=
  if [ "${REF_FLOOR:-0}" = 1 ]; then
    ref=$out/$1-ref$ref_samples-seq/frame_00000.png
    twin=$out/$1-ref$ref_samples-seq/frame_00001.png
  fi
}
for sc in "${scenes[@]}"; do
  [ "$stage" != frames ] && [ "$stage" != score ] || break
  ref_paths "$sc"
  if [ -n "$twin" ]; then
    dir=${ref%/*}
    if ! [ -s "$twin" ]; then
      t0=$(date +%s)
      # shellcheck disable=SC2046
      "$bin" sequence --headset "$headset" --method full --pixel-samples "$ref_samples" \
        --denoise off --temporal off --frames 2 --gaze-csv "$(still_csv 720,800)" --video off \
        $(scene_args "$sc") -q --out "$dir" >/dev/null
      echo "reference $sc ($ref_samples rays, and its twin): $(($(date +%s) - t0)) s wall" >&2
    fi
  elif ! [ -s "$ref" ]; then
    t0=$(date +%s)
    # shellcheck disable=SC2046
    "$bin" render --headset "$headset" --method full --pixel-samples "$ref_samples" --denoise off \
      $(scene_args "$sc") -q --out "$ref" >/dev/null
    echo "reference $sc ($ref_samples rays): $(($(date +%s) - t0)) s wall" >&2
  fi
done
[ "$stage" != refs ] || exit 0
for sc in "${scenes[@]}"; do
  ref_paths "$sc"
  for g in $gazes; do
    [ -z "$twin" ] || add_pair "$ref" "$twin" "$g" "$sc|$g|reference, seed 1 (noise floor)|$ref_samples/px"
    k=0
    for v in "$@"; do
      k=$((k + 1))
      if [ "${v%% *}" = sequence ]; then
        rest=${v#sequence }
        n=${rest%% *}
        opts=${rest#"$n"}
        dir=$out/$sc-$g-v$k-seq
        last=$(printf '%s/frame_%05d.png' "$dir" $((n - 1)))
        if [ "$stage" != score ] && ! [ -s "$last" ]; then
          # shellcheck disable=SC2046,SC2086
          "$bin" sequence --headset "$headset" --frames "$n" --gaze-csv "$(still_csv "$g")" \
            --video off $(scene_args "$sc") $opts -q --out "$dir" >/dev/null
        fi
        add_pair "$ref" "$dir/frame_00000.png" "$g" "$sc|$g|sequence$opts, frame 0|?"
        add_pair "$ref" "$last" "$g" "$sc|$g|sequence$opts, frame $((n - 1))|?"
      else
        img=$out/$sc-$g-v$k.png
        # A full-resolution frame does not depend on the gaze: rendered once, scored at each.
        case " $v " in *" --method full "*) img=$out/$sc-v$k.png ;; esac
        # shellcheck disable=SC2046,SC2086
        [ -s "$img" ] || [ "$stage" = score ] || "$bin" render --headset "$headset" --gaze "$g" $(scene_args "$sc") $v -q \
          --out "$img" >/dev/null
        rays=$(python3 -c "import json,sys; s=json.load(open(sys.argv[1])); print(s['frame']['rays_primary'])" "${img%.png}.json" 2>/dev/null || echo "?")
        add_pair "$ref" "$img" "$g" "$sc|$g|${v:-defaults}|$rays"
      fi
      [ "$stage" = score ] || echo "rendered $sc $g variant $k" >&2
    done
  done
done
[ "$stage" != frames ] || exit 0
"$P" "$EVAL" --batch "$pairs" --fov-h "$fov_h" --metrics fvvdp_foveated,flip > "$scores" ||
  echo "perceptual-jod: the evaluator reported an error (its line in $scores)" >&2
echo "| scene | gaze | options | primary rays | FovVideoVDP foveated JOD | ꟻLIP |"
echo "|---|---|---|---:|---:|---:|"
i=0
while IFS= read -r line; do
  IFS='|' read -r sc g v rays <<< "${rows[$i]}"
  python3 -c "import json,sys; d=json.loads(sys.argv[1]); print(f\"| {sys.argv[2]} | {sys.argv[3]} | \`{sys.argv[4]}\` | {sys.argv[5]} | {d.get('fvvdp_jod_foveated', float('nan')):.3f} | {d.get('flip_mean', float('nan')):.4f} |\")" "$line" "$sc" "$g" "$v" "$rays"
  i=$((i + 1))
done < "$scores"
echo "(frames in $out, scores in $scores)" >&2
