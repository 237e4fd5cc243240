#!/usr/bin/env bash
# The main job (until the daemon lands): installs and builds what is missing, then on the
# simulated display
#   1. makes the `default` display (72 modules) and writes its constant ray textures,
#   2. ray traces the paper's Cornell box from its Lua scene script on every module of `demo`,
#   3. assembles what three viewers on the observer line see from those frames, beside the
#      same views traced directly (with the PSNR between them),
# and says where everything is. Pass an output folder as the first argument.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=$(realpath -m "${1:-$root/parallax-output}")
parallax=$root/build/daemon/parallax

"$root/tools/setup.sh"
mkdir -p "$out"

echo "== 1. the default display and its ray textures"
"$parallax" display --preset default --out "$out/default_display.json"
"$parallax" raytex --display "$out/default_display.json" --out "$out/raytex"
if command -v oiiotool >/dev/null; then
  tex=$out/raytex
  oiiotool "$tex/module_000_mask.exr" --ch R=0,G=0,B=0 -o "$out/.mask.png" &&
    oiiotool "$tex/module_000_origins.exr" --addc 1.5,0,0 --mulc 0.33,1,0.3 -o "$out/.origins.png" &&
    oiiotool "$tex/module_000_directions.exr" --addc 1 --mulc 0.5 -o "$out/.directions.png" &&
    oiiotool "$out/.mask.png" "$out/.origins.png" "$out/.directions.png" --mosaic 3x1 \
      -o "$out/raytex_module_000_preview.png"
  rm -f "$out"/.mask.png "$out"/.origins.png "$out"/.directions.png
fi

echo "== 2. the Cornell box (scripts/scenes/cornell.lua) on the 16 modules of the demo display"
"$parallax" render --display demo --scene "$root/scripts/scenes/cornell.lua" --module all \
  --out "$out/frames" --explain

echo "== 3. what viewers on the observer line see"
for x in -0.5 0 0.5; do
  "$parallax" view --display demo --frames "$out/frames" --x "$x" --out "$out/view_x$x.png" \
    --traced-scene "$root/scripts/scenes/cornell.lua"
done

cat <<EON

Everything is in $out:
  default_display.json              the nominal 72-module display model
  raytex/module_NNN_*.exr           its ray textures (origins, directions, mask; open in any EXR viewer)
  raytex_module_000_preview.png     module 0's mask | origins | directions
  frames/module_NNN.png             the Cornell box as each demo module shows it
  view_x*.png, view_x*_traced.png   three observer views from the frames, and traced directly
EON
