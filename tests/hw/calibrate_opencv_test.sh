#!/usr/bin/env bash
# `parallax calibrate --camera opencv:PIPELINE` the way it runs on a real webcam: a real
# cv::VideoCapture GStreamer pipeline (multifilesrc reading parallax-simhw's camera feed, pngdec,
# videoconvert, a queue holding frames back, appsink) with the feed's auto exposure on. Every
# late picture is caught by the sync code and retaken (the count is printed and must be > 0), and
# the calibration recovers the ground truth as the link's camera does on the same simulated
# display (demo, 640x360 camera; ray error within 1.5x + 0.05 px of the link path's).
#   calibrate_opencv_test.sh PARALLAX PARALLAX_SIMHW
set -euo pipefail
parallax=$1
simhw=$2
for element in multifilesrc pngdec videoconvert queue appsink; do
  gst-inspect-1.0 "$element" > /dev/null 2>&1 ||
    { echo "FAIL: GStreamer element $element missing (tools/debian-packages.txt)"; exit 1; }
done
source "$(dirname "${BASH_SOURCE[0]}")/simulated_display.sh"
simulate_display "$parallax"
start_simhw "$simhw" --camera-feed "$dir/camera.png" --camera-feed-station "$dir/station" \
  --camera-feed-auto-exposure

# The gate's limits doubled: this compares rays against the truth, and the gate's prediction for
# the noisier auto-exposed pictures can refuse one edge module (4.6 px predicted, 0.7 px true).
common=(--camera-metadata "$dir/camera.json" --nominal "$dir/nominal.json" --truth "$dir/ground_truth.json"
        --pixel-step 6 --max-error-px 6 --max-observer-mm 30)

"$parallax" calibrate --link "simhw:$sock" --camera link --out "$dir/link.json" "${common[@]}" > "$dir/link.txt" 2>&1 ||
  { cat "$dir/link.txt"; echo "FAIL: the link path did not calibrate"; exit 1; }
pipeline="multifilesrc location=$dir/camera.png loop=true caps=image/png,framerate=30/1 ! pngdec ! videoconvert ! queue max-size-buffers=2 ! appsink"
# Auto-exposed, an end module's steep decodes can fail often enough to be left out, leaving it
# unbounded (seen from one station only, or by none): --allow-partial holds those nominal and
# names them; at most the two modules at each end may be held.
"$parallax" calibrate --link "simhw:$sock" --camera "opencv:$pipeline" --allow-auto-exposure \
  --allow-partial \
  --station-command "echo {station} > $dir/station" --out "$dir/opencv.json" "${common[@]}" > "$dir/opencv.txt" 2>&1 ||
  { cat "$dir/opencv.txt"; echo "FAIL: the opencv path did not calibrate"; exit 1; }
held=$(sed -n 's/.*partial calibration (--allow-partial): \([0-9]*\) of .*/\1/p' "$dir/opencv.txt" | head -n 1)
[ "${held:-0}" -le 4 ] ||
  { cat "$dir/opencv.txt"; echo "FAIL: $held modules held nominal: more than the display's end modules"; exit 1; }
grep -a "pictures in" "$dir/link.txt" "$dir/opencv.txt"
link=$(rms_of "$dir/link.txt")
opencv=$(rms_of "$dir/opencv.txt")
retaken=$(sed -n 's/.*; \([0-9]*\) late or torn pictures retaken.*/\1/p' "$dir/opencv.txt")
echo "ray error: link $link px RMS, opencv $opencv px RMS; $retaken late pictures retaken; ${held:-0} modules held nominal"
[ -n "$link" ] && [ -n "$opencv" ] || { echo "FAIL: no ray error line"; exit 1; }
[ "${retaken:-0}" -gt 0 ] || { echo "FAIL: no late picture was seen: the latency was not exercised"; exit 1; }
awk -v l="$link" -v o="$opencv" 'BEGIN { exit !(o <= 1.5 * l + 0.05) }' ||
  { echo "FAIL: the opencv path's ray error $opencv px is far above the link path's $link px"; exit 1; }
echo "ok"
