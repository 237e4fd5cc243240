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
dir=$(mktemp -d)
sock=$dir/simhw.sock
pid=
cleanup() {
  if [ -n "$pid" ]; then kill "$pid" 2>/dev/null || true; wait "$pid" 2>/dev/null || true; fi
  rm -rf "$dir"
}
trap cleanup EXIT

"$parallax" simulate --display demo --seed 7 --out "$dir" --camera-resolution 640x360 --synthetic > /dev/null
"$simhw" --socket "$sock" --truth "$dir/ground_truth.json" --camera "$dir/camera_truth.json" \
  --camera-feed "$dir/camera.png" --camera-feed-station "$dir/station" --camera-feed-auto-exposure &
pid=$!
for _ in $(seq 1 600); do
  [ -S "$sock" ] && [ -f "$dir/camera.png" ] && break
  kill -0 "$pid" 2>/dev/null || { echo "FAIL: parallax-simhw exited"; exit 1; }
  sleep 0.1
done

rms_of() { sed -n 's/.*ray error \([0-9.]*\) module px RMS.*/\1/p' "$1"; }
# The gate's limits doubled: this compares rays against the truth, and the gate's prediction for
# the noisier auto-exposed pictures can refuse one edge module (4.6 px predicted, 0.7 px true).
common=(--camera-metadata "$dir/camera.json" --nominal "$dir/nominal.json" --truth "$dir/ground_truth.json"
        --pixel-step 6 --max-error-px 6 --max-observer-mm 30)

"$parallax" calibrate --link "simhw:$sock" --camera link --out "$dir/link.json" "${common[@]}" > "$dir/link.txt" 2>&1 ||
  { cat "$dir/link.txt"; echo "FAIL: the link path did not calibrate"; exit 1; }
pipeline="multifilesrc location=$dir/camera.png loop=true caps=image/png,framerate=30/1 ! pngdec ! videoconvert ! queue max-size-buffers=2 ! appsink"
"$parallax" calibrate --link "simhw:$sock" --camera "opencv:$pipeline" --allow-auto-exposure \
  --station-command "echo {station} > $dir/station" --out "$dir/opencv.json" "${common[@]}" > "$dir/opencv.txt" 2>&1 ||
  { cat "$dir/opencv.txt"; echo "FAIL: the opencv path did not calibrate"; exit 1; }
grep -a "pictures in" "$dir/link.txt" "$dir/opencv.txt"
link=$(rms_of "$dir/link.txt")
opencv=$(rms_of "$dir/opencv.txt")
retaken=$(sed -n 's/.*; \([0-9]*\) late or torn pictures retaken.*/\1/p' "$dir/opencv.txt")
echo "ray error: link $link px RMS, opencv $opencv px RMS; $retaken late pictures retaken"
[ -n "$link" ] && [ -n "$opencv" ] || { echo "FAIL: no ray error line"; exit 1; }
[ "${retaken:-0}" -gt 0 ] || { echo "FAIL: no late picture was seen: the latency was not exercised"; exit 1; }
awk -v l="$link" -v o="$opencv" 'BEGIN { exit !(o <= 1.5 * l + 0.05) }' ||
  { echo "FAIL: the opencv path's ray error $opencv px is far above the link path's $link px"; exit 1; }
echo "ok"
