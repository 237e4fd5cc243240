#!/usr/bin/env bash
# The main job: installs and builds what is missing, then makes the `default` display, writes
# its constant ray textures, and says where. (When the daemon lands, this runs it on the
# simulated display instead.)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=${1:-$root/parallax-output}

"$root/tools/setup.sh"
mkdir -p "$out"
"$root/build/daemon/parallax" display --preset default --out "$out/default_display.json"
"$root/build/daemon/parallax" raytex --display "$out/default_display.json" --out "$out/raytex"
# A preview a person can glance at: module 0's mask, origins and directions side by side.
if command -v oiiotool >/dev/null; then
  tex=$out/raytex
  oiiotool "$tex/module_000_mask.exr" --ch R=0,G=0,B=0 -o "$out/.mask.png" &&
    oiiotool "$tex/module_000_origins.exr" --addc 1.5,0,0 --mulc 0.33,1,0.3 -o "$out/.origins.png" &&
    oiiotool "$tex/module_000_directions.exr" --addc 1 --mulc 0.5 -o "$out/.directions.png" &&
    oiiotool "$out/.mask.png" "$out/.origins.png" "$out/.directions.png" --mosaic 3x1 \
      -o "$out/module_000_preview.png" && rm -f "$out"/.mask.png "$out"/.origins.png "$out"/.directions.png &&
    echo "preview of module 0 (mask | origins | directions): $out/module_000_preview.png"
fi
echo "display model: $out/default_display.json"
echo "ray textures:  $out/raytex/ (72 modules x origins, directions, mask EXR)"
