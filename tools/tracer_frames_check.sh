#!/usr/bin/env bash
# Renders the paper's three scenes on one module of a display as float EXR and compares them
# with a reference folder made the same way (before a tracer change): prints the largest
# per-channel difference of each scene (oiiotool --diff). A performance change must leave the frames
# equal up to float noise.
#   tools/tracer_frames_check.sh BUILD_DIR OUT_DIR [REFERENCE_DIR]
# Without REFERENCE_DIR it only renders (make the reference first, on the old build).
set -euo pipefail
build=${1:?build folder}
out=${2:?output folder}
reference=${3:-}
display=${PARALLAX_CHECK_DISPLAY:-default}
module=${PARALLAX_CHECK_MODULE:-36}
for scene in cornell shapes statue; do
  mkdir -p "$out/$scene"
  "$build/daemon/parallax" render --display "$display" --module "$module" --scene "$scene" --float \
    --out "$out/$scene" >/dev/null
  if [ -n "$reference" ]; then
    frame=$(cd "$out/$scene" && ls ./*.exr | head -n 1)
    echo "== $scene ($frame)"
    # Mean and largest absolute difference, and how many pixels differ at all (PASS: none).
    { oiiotool "$reference/$scene/$frame" "$out/$scene/$frame" --fail 0 --warn 0 --diff || true; } |
      grep -E "Mean error|Max error|pixels|PASS" | sort -u
  fi
done
