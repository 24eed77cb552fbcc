#!/usr/bin/env bash
# The hostile-input suite (issue 21): runs the `fovea` release binary on hostile files and
# command lines, each case under a memory cap (`ulimit -v`) and a timeout, and prints a
# table: case, exit code, expected exit code, first stderr line. Every case must exit 0 (with
# its documented fallback: a `warning:` or `note:` line where one is expected) or 2 with
# exactly one `error:` line: never 101 (panic), 134 (abort), 137 (killed), 124 (timeout) or
# another code. Cases that name a file outside the scene folder must not print its content.
# Files are generated here, in a temporary folder; nothing is committed.
#
#   scripts/hostile-suite.sh            # after `cargo build --release`
#   FOVEA_BIN=path/to/fovea HOSTILE_MEM_MB=4096 HOSTILE_TIMEOUT_S=60 scripts/hostile-suite.sh
#
# Exits 1 when any case fails; the table is also written to $HOSTILE_TABLE when set.
set -uo pipefail
cd "$(dirname "$0")/.."

bin="${FOVEA_BIN:-${CARGO_TARGET_DIR:-target}/release/fovea}"
mem_mb="${HOSTILE_MEM_MB:-4096}"
timeout_s="${HOSTILE_TIMEOUT_S:-60}"
if [ ! -x "$bin" ]; then
  echo "hostile-suite: no fovea binary at $bin (run cargo build --release first)" >&2
  exit 1
fi
bin="$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
scenes="$work/scenes"
out="$work/out"
mkdir -p "$scenes" "$out" "$work/logs"

n=0
failed=0
table="| case | exit | expected | first stderr line (\$TMP: the suite's temporary folder) |
|---|---|---|---|"
start=$(date +%s)

# case NAME EXPECT [CHECK] -- ARGS...: runs `fovea ARGS` under the cap and the timeout.
# EXPECT: 0, 2 or any (0 or 2). CHECK (optional, a grep -E pattern prefixed with + or !):
# +PAT: stderr must match PAT; =PAT: stdout must match PAT; !PAT: stdout and stderr must not
# match PAT.
case_() {
  local name="$1" expect="$2" check=""
  shift 2
  if [ "$1" != "--" ]; then check="$1"; shift; fi
  shift
  n=$((n + 1))
  local log="$work/logs/$n"
  (
    ulimit -v $((mem_mb * 1024))
    if [ -n "${rss_limit_mb:-}" ]; then
      exec python3 "$work/rss.py" "$log.rss" timeout -k 5 "$timeout_s" "$bin" "$@"
    fi
    exec timeout -k 5 "$timeout_s" "$bin" "$@"
  ) >"$log.out" 2>"$log.err" </dev/null
  local rc=$?
  # With rss_limit_mb set: the command's peak resident memory, in the case's name and
  # checked against the limit.
  local rss_why=""
  if [ -n "${rss_limit_mb:-}" ]; then
    local rss_mb
    rss_mb=$(($(cat "$log.rss" 2>/dev/null || echo 0) / 1024))
    name="$name (max RSS $rss_mb MiB)"
    echo "hostile-suite: $name" >&2
    if [ "$rss_mb" -gt "$rss_limit_mb" ]; then rss_why="max RSS $rss_mb MiB over $rss_limit_mb MiB"; fi
  fi
  local first lines why=""
  first="$(head -n 1 "$log.err" | sed "s|$work|\$TMP|g; s/|/\\\\|/g")"
  lines="$(grep -c '' "$log.err")"
  case "$rc" in
    0 | 2) ;;
    101) why="panic" ;;
    134) why="abort" ;;
    137) why="killed" ;;
    124) why="timeout after ${timeout_s} s" ;;
    *) why="exit code $rc" ;;
  esac
  if [ -z "$why" ] && [ "$expect" != any ] && [ "$rc" != "$expect" ]; then
    why="expected exit $expect"
  fi
  if [ -z "$why" ] && [ "$rc" = 2 ]; then
    if [ "$lines" != 1 ] || ! grep -q '^error: ' "$log.err"; then
      why="exit 2 with $lines stderr lines (want one error: line)"
    fi
  fi
  if [ -z "$why" ] && [ -n "$check" ]; then
    local pat="${check:1}"
    case "$check" in
      +*) grep -Eq -- "$pat" "$log.err" || why="stderr lacks /$pat/" ;;
      =*) grep -Eq -- "$pat" "$log.out" || why="stdout lacks /$pat/" ;;
      !*) cat "$log.out" "$log.err" | grep -Eq -- "$pat" && why="output matches /$pat/" ;;
    esac
  fi
  if [ -z "$why" ] && [ -n "$rss_why" ]; then why="$rss_why"; fi
  local status="$rc"
  if [ -n "$why" ]; then
    failed=$((failed + 1))
    status="$rc FAIL: $why"
    echo "FAIL $name: $why" >&2
    sed 's/^/    /' "$log.err" | head -n 20 >&2
  fi
  table+=$'\n'"| $name | $status | $expect | ${first:-(none)} |"
}

# A small render; cases add their flags.
R=(render --res 64x72 --lights 1 -q --out "$out/r.png")

# --- files -------------------------------------------------------------------------------
tri_b64="AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA="
# gltf BUFFER_URI [IMAGE_URI] [EXTRA_TOP_LEVEL_JSON]: a one-triangle glTF.
gltf() {
  local images="" material="" extra="${3:-}"
  if [ -n "${2:-}" ]; then
    images=",\"images\":[{\"uri\":\"$2\"}],\"textures\":[{\"source\":0}],\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}]"
    material=",\"material\":0"
  fi
  cat <<EOF
{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1$material}]}],
"buffers":[{"byteLength":44,"uri":"$1"}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":8}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}]$images$extra}
EOF
}
data_uri="data:application/octet-stream;base64,$tri_b64"
d="$scenes/a/b/c"
mkdir -p "$d"
mkfifo "$d/fifo.bin"
ln -s /dev/zero "$d/zero.bin"
ln -s /dev/zero "$d/zero.glb"
gltf /dev/zero >"$d/buffer-dev-zero.gltf"
gltf zero.bin >"$d/buffer-zero-link.gltf"
gltf fifo.bin >"$d/buffer-fifo.gltf"
gltf "$data_uri" /dev/zero >"$d/texture-dev-zero.gltf"
gltf "$data_uri" fifo.bin >"$d/texture-fifo.gltf"
gltf ../../../../../../etc/passwd >"$d/buffer-passwd.gltf"
gltf "$data_uri" "" ',"extensionsUsed":["KHR_lights_punctual"],"extensions":{"KHR_lights_punctual":{"lights":[{"type":"directional","intensity":6830}]}}' \
  | sed 's/"nodes":\[{"mesh":0}\]/"nodes":[{"mesh":0},{"extensions":{"KHR_lights_punctual":{"light":0}},"rotation":[-0.5,0,0,0.866]}]/; s/"scenes":\[{"nodes":\[0\]}\]/"scenes":[{"nodes":[0,1]}]/' \
  >"$d/sun.gltf"
printf 'mtllib ../../../../../../etc/passwd\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' >"$d/mtllib-passwd.obj"
cat >"$d/filename-passwd.xml" <<'EOF'
<scene version="0.6.0"><shape type="obj"><string name="filename" value="../../../../../../etc/passwd"/></shape></scene>
EOF
printf 'v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n' >"$scenes/quad.obj"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n' | iconv -f UTF-8 -t UTF-16 >"$scenes/utf16.obj"
printf 'v -3e38 0 0\nv 3e38 0 0\nv 0 3e38 0\nf 1 2 3\n' >"$scenes/huge.obj"
{
  printf '<scene version="0.6.0"><shape type="cube">'
  for _ in $(seq 20000); do printf '<a>'; done
  for _ in $(seq 20000); do printf '</a>'; done
  printf '</shape></scene>\n'
} >"$scenes/deep.xml"
{
  echo '<scene version="0.6.0"><bsdf type="diffuse" id="grey"/>'
  for i in $(seq 0 7999); do
    echo "<shape type=\"cube\"><transform name=\"toWorld\"><scale value=\"0.5\"/><translate x=\"$((i % 100 * 3))\" z=\"$((i / 100 * 3))\"/></transform><ref id=\"grey\"/></shape>"
  done
  echo '</scene>'
} >"$scenes/shapes-8000.xml"
mkfifo "$scenes/gaze.fifo"
# rss.py LOG COMMAND...: runs COMMAND, writes its peak resident memory (KiB, the largest of
# the processes it waited for) to LOG and exits with its code.
cat >"$work/rss.py" <<'EOF'
import resource, subprocess, sys
rc = subprocess.call(sys.argv[2:])
open(sys.argv[1], "w").write(str(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss))
sys.exit(rc if rc >= 0 else 128 - rc)
EOF

# --- cases -------------------------------------------------------------------------------
case_ "glTF buffer URI /dev/zero" 2 '+outside the scene' -- "${R[@]}" --scene "$d/buffer-dev-zero.gltf"
case_ "glTF buffer: link to /dev/zero" 2 -- "${R[@]}" --scene "$d/buffer-zero-link.gltf"
case_ "glTF file: link to /dev/zero" 2 '+character device' -- "${R[@]}" --scene "$d/zero.glb"
case_ "glTF buffer URI: a FIFO" 2 '+FIFO' -- "${R[@]}" --scene "$d/buffer-fifo.gltf"
case_ "glTF texture URI /dev/zero" 0 '+warning: .*texture' -- "${R[@]}" --scene "$d/texture-dev-zero.gltf"
case_ "glTF texture URI: a FIFO" 0 '+warning: .*texture' -- "${R[@]}" --scene "$d/texture-fifo.gltf"
case_ "glTF buffer URI ../../../etc/passwd" 2 '!root:' -- "${R[@]}" --scene "$d/buffer-passwd.gltf"
case_ "OBJ mtllib ../../../etc/passwd" 0 '!root:' -- "${R[@]}" --scene "$d/mtllib-passwd.obj"
case_ "Mitsuba filename ../../../etc/passwd" 2 '!root:' -- "${R[@]}" --scene "$d/filename-passwd.xml"
for m in full vafr kfr lafr visual-polar guenter inset weier liu-hybrid; do
  for r in 1x1 2x2 8x8 16x9 100x1 64x4 64x8; do
    case_ "--method $m --res $r" any -- render --method "$m" --res "$r" --lights 1 -q --out "$out/r.png"
  done
done
case_ "--eyes both --res 9x9" any -- render --eyes both --res 9x9 --lights 1 -q --out "$out/r.png"
case_ "Mitsuba XML nested 20,000 deep" 2 '+nest' -- "${R[@]}" --scene "$scenes/deep.xml"
case_ "Mitsuba, 8,000 shapes" 0 -- "${R[@]}" --scene "$scenes/shapes-8000.xml" --method full
case_ "glTF sun of 6,830 lx" 0 "+note: the scene.s lights are photometric" -- "${R[@]}" --scene "$d/sun.gltf" --method full
for e in nan inf -1e9; do
  case_ "--exposure $e" 2 -- "${R[@]}" --exposure "$e"
done
case_ "planar scene (one quad)" 0 -- "${R[@]}" --scene "$scenes/quad.obj" --method full
seq_args=(sequence --res 120x90 --lights 1 --frames 3 --video off -q --out "$out/seq")
case_ "sequence (before resume)" 0 -- "${seq_args[@]}"
if [ -s "$out/seq/frame_00001.png" ]; then
  size=$(stat -c %s "$out/seq/frame_00001.png")
  truncate -s $((size / 2)) "$out/seq/frame_00001.png"
fi
case_ "truncated PNG on sequence resume" 0 '=1 rendered, 2 already there' -- "${seq_args[@]}"
case_ "--vafr-emax 0.001 (an empty buffer)" 2 '+vafr samples' -- "${R[@]}" --vafr-emax 0.001
case_ "--vafr-pivots 0:0.001,60:0.001" 2 '+vafr samples' -- "${R[@]}" --vafr-pivots 0:0.001,60:0.001
case_ "--vafr-pivots 0:1e300,60:4" 2 '+pivots' -- "${R[@]}" --vafr-pivots 0:1e300,60:4
case_ "--vafr-rings sideways" 2 '+vafr-rings' -- "${R[@]}" --vafr-rings sideways
case_ "--vafr-rings eq3 with --method kfr" 0 '+warning: --vafr-rings applies' -- "${R[@]}" --method kfr --vafr-rings eq3
case_ "--vafr-emax 89 from a corner (exact rings stop at the screen)" 0 -- "${R[@]}" --vafr-emax 89 --gaze 0,0
case_ "--gaze -3,-3 (just off the screen, exact rings)" 0 -- "${R[@]}" --gaze -3,-3
case_ "fidelity --bands 30,10" 2 '+bands' -- fidelity --res 64x72 --bands 30,10
case_ "fidelity --res 32768x32768" 0 -- fidelity --res 32768x32768 --methods full --stride 1
case_ "--weier with --method kfr" 0 '+warning: --weier applies' -- "${R[@]}" --method kfr --weier 10,20,0.2
case_ "--camera-index 99 (built-in scene)" any -- "${R[@]}" --camera-index 99
case_ "--camera-index 99 (scene without cameras)" 2 -- "${R[@]}" --scene "$scenes/quad.obj" --camera-index 99
case_ "--gaze -100,-100" 2 -- "${R[@]}" --gaze=-100,-100
case_ "--gaze nan,nan" 2 -- "${R[@]}" --gaze nan,nan
case_ "UTF-16 OBJ" 2 '+UTF-16' -- "${R[@]}" --scene "$scenes/utf16.obj"
case_ "huge coordinates (3e38)" 2 '+too large' -- "${R[@]}" --scene "$scenes/huge.obj"
case_ "--max-memory 1KiB" 2 -- "${R[@]}" --max-memory 1KiB
case_ "--max-memory 0" 2 -- "${R[@]}" --max-memory 0
case_ "--max-memory 1e30 (more than any machine)" any -- "${R[@]}" --max-memory 1e30
case_ "gaze CSV /dev/zero" 2 '+not a regular file' -- sequence --res 64x72 --frames 2 --video off -q --gaze-csv /dev/zero --out "$out/gz"
case_ "gaze CSV: a FIFO" 2 '+not a regular file' -- sequence --res 64x72 --frames 2 --video off -q --gaze-csv "$scenes/gaze.fifo" --out "$out/gf"
case_ "camera path /dev/zero" 2 '+not a regular file' -- sequence --res 64x72 --frames 2 --video off -q --camera-path /dev/zero --out "$out/cp"

# --- issue 39: geometry, lights, ranges, memory -----------------------------------------------
# Degenerate geometry (BVH build time from the JSON stats, in this log), a 1M-deep glTF node
# chain, 10,000 file lights, values outside their physical ranges, and memory: an 8192x4096
# run-length .hdr under --max-memory 256M and a 10M-row gaze CSV, each with its peak RSS.
i39="$scenes/i39"
mkdir -p "$i39"
{ printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\n'; yes 'f 1 2 3' | head -n 100000; } >"$i39/dup-100k.obj"
{
  echo '<scene version="0.6.0">'
  yes '<shape type="cube"/>' | head -n 16000
  echo '</scene>'
} >"$i39/cubes-16000.xml"
python3 - "$i39" <<'EOF'
import base64, struct, sys
d = sys.argv[1]
tri = base64.b64encode(struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)).decode()
def gltf(nodes, roots, extra=""):
    return ('{"asset":{"version":"2.0"},"extensionsUsed":["KHR_lights_punctual"],"scene":0,'
            '"scenes":[{"nodes":[%s]}],"nodes":[%s],'
            '"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],'
            '"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,%s"}],'
            '"bufferViews":[{"buffer":0,"byteLength":36}],'
            '"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",'
            '"min":[0,0,0],"max":[1,1,0]}]%s}' % (roots, nodes, tri, extra))
n = 1_000_000
with open(f"{d}/chain-1M.gltf", "w") as f:
    f.write(gltf(",".join('{"children":[%d]}' % (k + 1) for k in range(n - 1)) + ',{"mesh":0}', "0"))
def lights(ls):
    nodes = '{"mesh":0},' + ",".join(
        '{"translation":[%g,%g,2],"extensions":{"KHR_lights_punctual":{"light":%d}}}'
        % (k % 100 * 0.01, k // 100 * 0.01, k) for k in range(len(ls)))
    roots = ",".join(str(k) for k in range(len(ls) + 1))
    return gltf(nodes, roots, ',"extensions":{"KHR_lights_punctual":{"lights":[%s]}}' % ",".join(ls))
open(f"{d}/lights-10000.gltf", "w").write(
    lights(['{"type":"point","intensity":%d}' % (1 + k % 50) for k in range(10000)]))
open(f"{d}/light-negative.gltf", "w").write(lights(['{"type":"point","intensity":-1000}']))
open(f"{d}/light-infinite.gltf", "w").write(lights(['{"type":"point","intensity":1e39}']))
open(f"{d}/yfov-3.2.gltf", "w").write(gltf(
    '{"mesh":0},{"translation":[0.3,0.3,2],"camera":0}', "0,1",
    ',"cameras":[{"type":"perspective","perspective":{"yfov":3.2,"znear":0.1}}]'))
# An 8192 x 4096 Radiance map in 2 MB of adaptive runs (127-pixel runs of one value).
w, h = 8192, 4096
with open(f"{d}/big.hdr", "wb") as f:
    f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (h, w))
    for j in range(h):
        line = bytearray([2, 2, w >> 8, w & 255])
        for c in range(4):
            x = 0
            while x < w:
                r = min(127, w - x)
                line += bytes([128 + r, 128 + 60 * j // h if c < 3 else 129])
                x += r
        f.write(line)
EOF
cat >"$i39/big-env.xml" <<'EOF'
<scene version="0.6.0"><shape type="cube"/><emitter type="envmap"><string name="filename" value="big.hdr"/></emitter></scene>
EOF
cat >"$i39/point-negative.xml" <<'EOF'
<scene version="0.6.0"><shape type="cube"/><emitter type="point"><point name="position" x="0" y="3" z="3"/><rgb name="intensity" value="-100"/></emitter></scene>
EOF
{ echo 't,x,y'; yes '1,2,3' | head -n 10000001; } >"$i39/gaze-10M.csv"
S39=(render --res 64x64 -q --method full --out "$out/r39.png" --stats "$out/s39.json")
bvh_ms() { grep -o '"bvh_build_ms": *[0-9.e+-]*' "$out/s39.json" 2>/dev/null | sed 's/.*: *//'; }
secs() { python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.2f}')" "$1" "$(date +%s.%N)"; }
rm -f "$out/s39.json"
case_ "100k copies of one triangle (OBJ)" 0 '+warning: 99999 triangle.s. repeat' -- "${S39[@]}" --lights 1 --scene "$i39/dup-100k.obj"
echo "hostile-suite: 100k duplicate triangles: bvh_build_ms $(bvh_ms)" >&2
rm -f "$out/s39.json"
case_ "16,000 identical Mitsuba cubes" 0 '+repeat an earlier one' -- "${S39[@]}" --lights 1 --scene "$i39/cubes-16000.xml"
echo "hostile-suite: 16,000 identical cubes: bvh_build_ms $(bvh_ms)" >&2
t0=$(date +%s.%N)
case_ "glTF node chain 1,000,000 deep" 0 -- "${S39[@]}" --lights 1 --scene "$i39/chain-1M.gltf"
echo "hostile-suite: 1M-deep glTF chain: $(secs "$t0") s in all" >&2
t0=$(date +%s.%N)
case_ "10,000 glTF point lights" 0 '+kept the 256 strongest' -- "${S39[@]}" --scene "$i39/lights-10000.gltf"
echo "hostile-suite: 10,000 file lights at 64x64: $(secs "$t0") s" >&2
case_ "glTF light intensity -1000" 0 '+warning: .*negative intensity' -- "${S39[@]}" --scene "$i39/light-negative.gltf"
case_ "glTF light intensity 1e39 (infinite)" 2 '+intensity' -- "${S39[@]}" --scene "$i39/light-infinite.gltf"
case_ "Mitsuba point light intensity -100" 0 '+warning: .*negative intensity' -- "${S39[@]}" --scene "$i39/point-negative.xml"
case_ "glTF yfov 3.2 rad" 0 '+warning: .*yfov' -- "${S39[@]}" --lights 1 --scene "$i39/yfov-3.2.gltf"
rss_limit_mb=256
case_ "8192x4096 RLE .hdr, --max-memory 256M" 0 '+note: environment map' -- "${R[@]}" --method full --scene "$i39/big-env.xml" --max-memory 256M
rss_limit_mb=100
case_ "gaze CSV of 10,000,001 rows" 2 '+data rows' -- sequence --res 64x72 --frames 2 --video off -q --gaze-csv "$i39/gaze-10M.csv" --out "$out/g39"
unset rss_limit_mb
rm -f "$i39/gaze-10M.csv" "$i39/chain-1M.gltf"

# issue 39: outputs, sequences, messages ------------------------------------------------------
# check_ NAME CONDITION...: a row for a check on what the cases above left (files, bytes),
# failed when the command CONDITION fails.
check_() {
  local name="$1"
  shift
  n=$((n + 1))
  local status="ok"
  if ! "$@" >"$work/logs/$n.check" 2>&1; then
    failed=$((failed + 1))
    status="FAIL"
    echo "FAIL $name" >&2
    sed 's/^/    /' "$work/logs/$n.check" | head -n 20 >&2
  fi
  table+=$'\n'"| $name | $status | ok | (check) |"
}
# last_stderr_short MAX: the last case's stderr lines are at most MAX characters.
last_stderr_short() {
  awk -v m="$1" 'length > m { print "a line of " length " characters"; bad = 1 } END { exit bad }' \
    "$work/logs/$((n - 1)).err"
}
# no_temporaries DIR: no temporary file (`.NAME.PID-N.tmp`) in DIR.
no_temporaries() { ! ls -A "$1" | grep -E '^\..*\.[0-9]+-[0-9]+\.tmp$'; }
# only_files DIR NAMES...: DIR holds exactly these entries (no temporary or partial file).
only_files() {
  local dir="$1"
  shift
  local want have
  want="$(printf '%s\n' "$@" | sort)"
  have="$(ls -A "$dir" | sort)"
  [ "$want" = "$have" ] || { echo "in $dir: [$have], want [$want]"; return 1; }
}
# same_frames A B: the frame PNGs of two sequence folders are the same files, byte for byte.
same_frames() {
  local f k=0
  for f in "$1"/frame_*.png; do
    cmp "$f" "$2/$(basename "$f")" || return 1
    k=$((k + 1))
  done
  [ "$k" -gt 0 ] && [ "$k" = "$(ls "$2"/frame_*.png | wc -l)" ]
}

# Error messages: the file, the line or element, the real problem, one short line.
printf '{"asset":{"version":"2.0"},"nodes":[{"children":[1]},{"children":[0]}]}\n' >"$scenes/cycle.gltf"
case_ "glTF: two-node cycle, no scenes" 2 '+cycle through node' -- "${R[@]}" --scene "$scenes/cycle.gltf"
printf 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf\nf 1 2 3\n' >"$scenes/bare-f.obj"
case_ "OBJ: a bare f line" 2 '+line 4' -- "${R[@]}" --scene "$scenes/bare-f.obj"
{ seq -s, -f 'column_%g' 10000; echo '0,1,2'; } >"$scenes/wide.csv"
case_ "gaze CSV: 10,000-column header" 2 '+10000 columns' -- sequence --res 64x72 --frames 2 --video off -q --gaze-csv "$scenes/wide.csv" --out "$out/wide"
check_ "  ... its error line is under 800 characters" last_stderr_short 800
printf 't,x,y,z,look_x,look_y,look_z\n0,0,1,5,0,1,0\n1,1e30,1,5,0,1,0\n' >"$scenes/far-path.csv"
case_ "camera path: a position of 1e30" 2 '+far-path.csv.*keyframe 1 \(line 3\).*within' -- sequence --res 64x72 --frames 2 --video off -q --camera-path "$scenes/far-path.csv" --out "$out/far"
mkdir -p "$out/is-a-dir.png"
case_ "render --out onto a folder" 2 '+cannot write .*is-a-dir.png' -- render --res 64x72 --lights 1 -q --out "$out/is-a-dir.png"
check_ "  ... no temporary file left beside it" no_temporaries "$out"

# A sequence folder's frames are reused only when its sequence.json vouches for them.
vouch=(sequence --res 120x90 --lights 1 --frames 3 --video off -q --out "$out/vouch")
case_ "sequence (before its manifest is deleted)" 0 -- "${vouch[@]}"
rm -f "$out/vouch/sequence.json"
case_ "sequence folder without sequence.json" 2 '+no sequence.json.*--overwrite' -- "${vouch[@]}" --seed 2
case_ "  ... with --overwrite: rendered again" 0 '=3 rendered, 0 already there' -- "${vouch[@]}" --seed 2 --overwrite

# Full disk: a small tmpfs (we need root to mount one).
disk="$work/disk"
mkdir -p "$disk"
if mount -t tmpfs -o size=256k tmpfs "$disk" 2>"$work/mount.err"; then
  trap 'umount "$disk" 2>/dev/null; rm -rf "$work"' EXIT
  dd if=/dev/zero of="$disk/fill" bs=1k 2>/dev/null # until the disk is full
  case_ "full disk: render PNG" 2 '+cannot write .*disk/r.png.*No space' -- render --res 64x72 --lights 1 -q --out "$disk/r.png"
  check_ "  ... no file under its name, no temporary" only_files "$disk" fill
  case_ "full disk: render EXR" 2 '+cannot write .*disk/r.exr.*No space' -- render --res 64x72 --lights 1 -q --out "$disk/r.exr"
  check_ "  ... no file under its name, no temporary" only_files "$disk" fill
  rm -f "$disk/fill"
  # Room for the manifest and 2.5 frames of six (~24 KiB each): the run stops at the first
  # frame that does not fit.
  full=(sequence --res 160x120 --lights 1 --frames 6 --video off -q)
  case_ "sequence (reference, uninterrupted)" 0 -- "${full[@]}" --out "$out/full-ref"
  frame_kib=$(( $(stat -c %s "$out/full-ref/frame_00000.png") / 1024 + 1 ))
  dd if=/dev/zero of="$disk/fill" bs=1k count=$((256 - 16 - 5 * frame_kib / 2)) 2>/dev/null
  case_ "full disk: sequence stops at the frame that fails" 2 '+cannot write .*disk/seq/frame_0000[0-9].png.*No space' -- "${full[@]}" --out "$disk/seq"
  kept=$(ls "$disk/seq" | grep -c '^frame_.*\.png$')
  check_ "  ... keeps the frames before it ($kept), no temporary" sh -c "[ $kept -ge 1 ] && [ $kept -lt 6 ] && ! ls -A '$disk/seq' | grep -q tmp"
  rm -f "$disk/fill"
  case_ "  ... resumed once space is freed" 0 "=$((6 - kept)) rendered, $kept already there" -- "${full[@]}" --out "$disk/seq"
  check_ "  ... byte for byte the uninterrupted run" same_frames "$out/full-ref" "$disk/seq"
  umount "$disk"
else
  echo "hostile-suite: full-disk cases skipped: cannot mount a tmpfs ($(head -n 1 "$work/mount.err"))" >&2
  table+=$'\n'"| full-disk cases | skipped | - | cannot mount a tmpfs (needs root) |"
fi

elapsed=$(($(date +%s) - start))
echo "$table"
echo
echo "hostile-suite: $n cases, $failed failed, ${elapsed} s (memory cap ${mem_mb} MiB, timeout ${timeout_s} s per case)"
if [ -n "${HOSTILE_TABLE:-}" ]; then
  { echo "$table"; echo; echo "$n cases, $failed failed, ${elapsed} s"; } >"$HOSTILE_TABLE"
fi
[ "$failed" = 0 ]
