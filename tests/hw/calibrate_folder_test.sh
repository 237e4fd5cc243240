#!/usr/bin/env bash
# `parallax calibrate --camera folder:DIR` as an installer runs it, on the simulated demo display
# (seed 7, 640x360 camera, every 6th camera pixel decoded): live, the tool shows each pattern
# through the link and names the picture to take; an "operator" (the loop below) waits until
# parallax-simhw's camera feed has the screen as it is now (a new picture, then none for 0.4 s), then saves
# that picture under the name asked for. Then offline, with no display, from the folder. Both
# must calibrate, with the ray error of the link path on the same display (within 1.5x + 0.05 px).
# Not in CTest: it goes at an operator's pace (390 pictures, about 7 minutes on the shared
# 2-core machine), too long for CI; the gtest FolderCameraEndToEnd checks the same in process on
# a small display. Run by hand for the figures in README.md's installer section:
#   calibrate_folder_test.sh PARALLAX PARALLAX_SIMHW [STATIONS]
set -euo pipefail
parallax=$1
simhw=$2
stations=${3:-}
operator=
before_cleanup() { if [ -n "$operator" ]; then kill "$operator" 2>/dev/null || true; fi; }
source "$(dirname "${BASH_SOURCE[0]}")/simulated_display.sh"
simulate_display "$parallax"
start_simhw "$simhw" --camera-feed "$dir/camera.png" --camera-feed-station "$dir/station"

common=(--camera-metadata "$dir/camera.json" --nominal "$dir/nominal.json" --truth "$dir/ground_truth.json"
        --pixel-step 6)
[ -z "$stations" ] || common+=(--stations "$stations")

"$parallax" calibrate --link "simhw:$sock" --camera link --out "$dir/link.json" "${common[@]}" > "$dir/link.txt" 2>&1 ||
  { cat "$dir/link.txt"; echo "FAIL: the link path did not calibrate"; exit 1; }

# The operator: for each picture asked for, the feed's picture once it is quiet, saved whole.
: > "$dir/folder.txt"
(
  copied=""
  tail -n +1 -F "$dir/folder.txt" 2>/dev/null | while IFS= read -r line; do
    case "$line" in
      *"save it as "*)
        target=${line##*save it as }
        # A new screen since the last picture, and no newer one for 0.4 s (the feed renders
        # every module's change: the first writes may show the screen half changed).
        while [ "$(stat -c %y "$dir/camera.png")" = "$copied" ]; do sleep 0.05; done
        last=""
        while :; do
          now=$(stat -c %y "$dir/camera.png")
          [ "$now" = "$last" ] && break
          last=$now
          sleep 0.4
        done
        cp "$dir/camera.png" "$target.part" && mv "$target.part" "$target"
        copied=$now
        ;;
    esac
  done
) &
operator=$!
"$parallax" calibrate --link "simhw:$sock" --camera "folder:$dir/pictures" \
  --station-command "echo {station} > $dir/station" --out "$dir/folder.json" "${common[@]}" >> "$dir/folder.txt" 2>&1 ||
  { grep -av "save it as" "$dir/folder.txt" | tail -20; echo "FAIL: the live folder path did not calibrate"; exit 1; }
kill "$operator" 2>/dev/null || true
operator=
"$parallax" calibrate --camera "folder:$dir/pictures" --out "$dir/offline.json" "${common[@]}" > "$dir/offline.txt" 2>&1 ||
  { cat "$dir/offline.txt"; echo "FAIL: the offline folder path did not calibrate"; exit 1; }
grep -ah "pictures in" "$dir/link.txt" "$dir/folder.txt" "$dir/offline.txt"
link=$(rms_of "$dir/link.txt")
live=$(rms_of "$dir/folder.txt")
offline=$(rms_of "$dir/offline.txt")
echo "ray error: link $link px RMS, folder (live) $live px RMS, folder (offline) $offline px RMS"
[ -n "$link" ] && [ -n "$live" ] && [ -n "$offline" ] || { echo "FAIL: no ray error line"; exit 1; }
[ "$live" = "$offline" ] || { echo "FAIL: the same pictures offline gave another calibration"; exit 1; }
awk -v l="$link" -v o="$live" 'BEGIN { exit !(o <= 1.5 * l + 0.05) }' ||
  { echo "FAIL: the folder path's ray error $live px is far above the link path's $link px"; exit 1; }
echo "ok"
