#!/usr/bin/env bash
# Issue 18's device check: the GPU tests and timings of fovea-gpu, run on a machine with a
# real GPU from prebuilt binaries (no Rust toolchain needed there), in one call.
#
#   scripts/gpu-bench.sh build [--with-classroom]
#                                     # here: builds and strips everything into gpu-bench/
#   scripts/gpu-bench.sh run [OUT]    # there (or here, on lavapipe): runs it, writes OUT/gpu-bench.md
#
# `build` compiles, in release with the `gpu` feature, the `fovea` binary, the timing examples
# (`reconstruct_timing`, `trace_timing`) and the fovea-gpu test binaries that need an adapter
# (not `shaders`: naga's validation needs no GPU and reads the source tree), and copies them,
# stripped, to gpu-bench/bin (ignored by git; about 50 MB: with the repository's
# tracked files (8.5 MB), under the 64 MiB the device tool carries).
# `run` needs only those binaries and a Vulkan loader and driver:
#
#   * the GPU tests with FOVEA_REQUIRE_GPU=1 (no adapter is a failure, not a skip);
#   * reconstruct_timing at the Vive Pro Eye, 2K and 8K presets;
#   * trace_timing on the built-in scene at the Vive Pro Eye and 8K presets;
#   * `fovea render --backend gpu` against `--backend cpu`, VaFR, Vive Pro Eye and 8K, with
#     each frame's stage times and backend JSON;
#   * binocular_frame (issue 37's resident frame, both eyes in one submission, against the
#     staged path at the Vive Pro Eye and 4K, and beside the same frame with issue 38's
#     denoiser: its per-pass GPU ms) at the Vive Pro Eye, 4K, 8K and retinal;
#   * `fovea bench --backend gpu` at the Vive Pro Eye, 4K and 8K, then issue 18's headline:
#     both eyes (`--eyes both`), VaFR at 8K per eye and retinal, 1 light and 12, on the
#     classroom when the bundle holds it (`build --with-classroom` copies
#     ../shared/scenes/japanese-classroom, 14 MB, into gpu-bench/scenes: mind the 64 MiB the
#     device tool carries), else on the built-in scene.
#
# Everything prints to stdout and goes to OUT/gpu-bench.md (default $OUT, else ./gpu-bench-out);
# record what it printed in docs/gpu-measurements.md. No step asserts a time.
#
# On the lent NVIDIA machine (see the device tool's README): carry `gpu-bench` and `.gl` (the
# Vulkan loader packages downloaded once here) and begin the command with
#   for f in .gl/*.deb; do dpkg -x $f /; done; ldconfig;
# and, if no driver is found,
#   export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
set -euo pipefail
cd "$(dirname "$0")/.."

mode="${1:-}"
bundle=gpu-bench
target="${CARGO_TARGET_DIR:-target}"

case "$mode" in
build)
  mkdir -p "$bundle/bin"
  cargo build --release --locked -p fovea-cli --features gpu
  cargo build --release --locked -p fovea-gpu --examples
  cp "$target/release/fovea" "$target/release/examples/reconstruct_timing" \
    "$target/release/examples/trace_timing" "$target/release/examples/binocular_frame" \
    "$bundle/bin/"
  # The test binaries' paths, from cargo's JSON messages.
  cargo test --release --locked -p fovea-gpu --no-run --message-format=json 2>/dev/null |
    grep -o '"executable":"[^"]*"' | sed 's/"executable":"//; s/"$//' |
    while read -r exe; do
      name="$(basename "$exe" | sed 's/-[0-9a-f]*$//')"
      # Only the tests that need an adapter: not tests/shaders.rs (naga's validation, which
      # reads the source tree), the crate's unit tests or the examples built as tests.
      case "$name" in
        shaders | fovea_gpu | *_timing | *_frame) ;;
        *) cp "$exe" "$bundle/bin/test-$name" ;;
      esac
    done
  strip "$bundle"/bin/* 2>/dev/null || true
  if [ "${2:-}" = --with-classroom ]; then
    mkdir -p "$bundle/scenes"
    cp -r ../shared/scenes/japanese-classroom "$bundle/scenes/"
  fi
  du -sh "$bundle"
  ls "$bundle/bin"
  ;;
run)
  bin="$bundle/bin"
  [ -x "$bin/fovea" ] || { echo "error: $bin/fovea is missing: run 'scripts/gpu-bench.sh build' first" >&2; exit 2; }
  out="${2:-${OUT:-gpu-bench-out}}"
  mkdir -p "$out"
  report="$out/gpu-bench.md"
  export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-$(mktemp -d)}"
  export FOVEA_REQUIRE_GPU=1
  failed=0
  step() {
    # step TITLE -- COMMAND...: runs it, copies its output to the report, notes a failure.
    local title="$1"; shift; shift
    echo "## $title" | tee -a "$report"
    echo '```' >>"$report"
    local t0 rc
    t0=$(date +%s%N)
    set +e
    "$@" 2>&1 | grep -v 'XDG_RUNTIME_DIR' | tee -a "$report"
    rc="${PIPESTATUS[0]}"
    set -e
    echo '```' >>"$report"
    echo "exit $rc, $(( ($(date +%s%N) - t0) / 1000000 )) ms" | tee -a "$report"
    echo >>"$report"
    [ "$rc" = 0 ] || failed=$((failed + 1))
  }
  : >"$report"
  {
    echo "# scripts/gpu-bench.sh run, $(date -u +%FT%TZ)"
    echo
    echo "host: $(uname -srm); CPUs: $(nproc)"
    command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
    echo
  } | tee -a "$report"
  for t in "$bin"/test-*; do
    step "test: $(basename "$t")" -- "$t" --test-threads 1
  done
  step "reconstruct timing" -- "$bin/reconstruct_timing" vive-pro-eye,2k,8k footprint 5
  step "trace timing, Vive Pro Eye" -- "$bin/trace_timing" depth-range vive-pro-eye 5
  step "trace timing, 8K" -- "$bin/trace_timing" depth-range 8k 3
  for preset in vive-pro-eye 8k; do
    for backend in cpu gpu; do
      # The image stays in /tmp (an 8K frame is larger than what comes back); its stats come back.
      step "render vafr $preset --backend $backend" -- "$bin/fovea" render --method vafr \
        --headset "$preset" --lights 4 --backend "$backend" -q \
        --out "/tmp/gpu-bench-$preset-$backend.png" --stats "$out/render-$preset-$backend.json"
    done
  done
  # Issue 18's table: per-pass GPU ms from timestamps, fps, rays and the speedup against the
  # full-resolution frame of the same run (the CPU's), at the Vive Pro Eye, 4K and 8K.
  step "bench --backend gpu" -- "$bin/fovea" bench --backend gpu --res vive-pro-eye,4k,8k \
    --methods vafr,kfr --lights 1 --bvh-rays 0 --json
  # Both eyes on the GPU, VaFR at 8K per eye and retinal, against full resolution in the same
  # run, 1 light with shadows and 12.
  scene="$bundle/scenes/japanese-classroom/scene.xml"
  scene_args=(--scene "$scene")
  [ -f "$scene" ] || { echo "(no classroom in the bundle: the built-in scene instead)"; scene_args=(); }
  for lights in 1 12; do
    step "bench both eyes, $lights light(s)" -- "$bin/fovea" bench --backend gpu "${scene_args[@]}" \
      --eyes both --stereo-reps 2 --lights "$lights" --res 8k,retinal --methods vafr \
      --bvh-rays 0 --lockstep on --json
  done
  # Both eyes in one submission against the eyes in turn (`--lockstep`), side by side.
  for lockstep in off on; do
    step "bench both eyes, 1 light, --lockstep $lockstep" -- "$bin/fovea" bench --backend gpu \
      "${scene_args[@]}" --eyes both --stereo-reps 3 --lights 1 --res 8k --methods vafr \
      --bvh-rays 0 --lockstep "$lockstep" --json
  done
  # Issue 37: the whole binocular frame resident on the device (one submission, nothing read
  # back) against the staged --backend gpu path, VaFR, 1 light, per-pass GPU ms; the staged
  # path only where it finishes in reasonable time (the Vive Pro Eye and 4K).
  for preset in vive-pro-eye 4k 8k retinal; do
    staged=on
    case "$preset" in 8k | retinal) staged=off ;; esac
    step "resident binocular frame, vafr $preset (staged $staged)" -- \
      "$bin/binocular_frame" 6 vafr "$preset" 1 "$staged" eq3-any-gaze on both
    step "resident binocular frame, full $preset" -- \
      "$bin/binocular_frame" 4 full "$preset" 1 off eq3-any-gaze on both
  done
  echo "gpu-bench: $failed step(s) failed; report in $report" | tee -a "$report"
  [ "$failed" = 0 ]
  ;;
*)
  echo "usage: scripts/gpu-bench.sh build | run [OUT]" >&2
  exit 2
  ;;
esac
