#!/usr/bin/env bash
# Where a tracer frame's time goes, by a sampling profiler: renders each scene's frames
# (`parallax bench tracer --render-only`) under `perf record` and prints the share of samples in
# Embree, in our code and elsewhere, and our share divided by Embree's. This VM's speed drifts by
# ±20–30% from minute to minute, so two ms figures taken a minute apart cannot show a 5% change;
# this split can (±0.02 between runs), because both sides are sampled over the same seconds.
# The samples include the set-up (scene build, ray textures): compare builds, not absolutes.
#   tools/profile_tracer.sh [BUILD_DIR] [SCENE ...]      (FRAMES=N, default 60)
# Needs perf (Debian: linux-perf) and permission to use it (kernel.perf_event_paranoid ≤ 2).
set -euo pipefail
build=${1:-build}
shift || true
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(cornell shapes statue)
frames=${FRAMES:-60}
command -v perf >/dev/null || { echo "profile_tracer.sh: needs perf (apt-get install linux-perf)" >&2; exit 1; }
data=$(mktemp)
trap 'rm -f "$data"' EXIT
printf '%-8s %8s %8s %8s %12s\n' scene embree ours other ours/embree
for scene in "${scenes[@]}"; do
  perf record -q -o "$data" -- "$build/daemon/parallax" bench tracer --render-only --frames "$frames" \
    --scenes "$scene" >/dev/null 2>&1
  # One line per shared object: "<percent>% <object>"; ours is the executable (`parallax` runs
  # the whole tool as parallax-tools, so the samples are in that one).
  perf report -i "$data" --no-children --sort dso --stdio 2>/dev/null | grep '%' |
    awk -v scene="$scene" '{ gsub("%", "", $1); if ($2 ~ /embree/) e += $1; else if ($2 == "parallax" || $2 == "parallax-tools") o += $1; else r += $1 }
      END { printf "%-8s %7.1f%% %7.1f%% %7.1f%% %12.3f\n", scene, e, o, r, (e > 0 ? o / e : 0) }'
done
