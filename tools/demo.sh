#!/usr/bin/env bash
# The main job: installs and builds what is missing, then runs the daemon end to end on the
# simulated `demo` display (16 modules of 512×384):
#   1. starts parallaxd, which starts its own simulated display (parallax-simhw with a seeded
#      ground truth) and knows only the nominal model;
#   2. lets it calibrate through the link and the camera (when this build can: see the
#      calibration report), regenerate the ray textures and play scripts/scenes/cornell.lua;
#   3. asks it, over its control socket (`parallax ctl`), for every module's frame, for what
#      viewers at x = -0.5, 0 and 0.5 m see, and for its status and timings;
#   4. calibrates the modules' colours too (`parallax ctl calibrate --photometric only`: the
#      simulated modules differ in response, colour, brightness and vignetting) and asks for the
#      frames again: a viewer's before/after pair (geometric only, geometric + photometric), and
#      the video of a viewer walking the observer line (sweep.mp4);
#   5. shuts it down; the simulator saves what its modules actually received.
# While it runs, its browser control panel is up: the demo prints the URL (with its token) as
# soon as the daemon plays. PARALLAX_DEMO_KEEP=1 keeps the daemon and its panel running after
# step 4, until Enter or Ctrl-C.
# Pass an output folder as the first argument (default: out/demo).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
out=$(realpath -m "${1:-$root/out/demo}")
build=$root/build
parallax=$build/daemon/parallax
parallaxd=$build/daemon/parallaxd

"$root/tools/setup.sh"
rm -rf "$out"
mkdir -p "$out/frames" "$out/frames_geometric_only" "$out/shown"
run=$(mktemp -d /tmp/parallax-demo.XXXXXX)
socket=$run/parallaxd.sock
ctl() { "$parallax" ctl --socket "$socket" "$@"; }
cache=${XDG_CACHE_HOME:-$HOME/.cache}/parallax

cat >"$out/parallax.toml" <<EOC
# The configuration this demo ran parallaxd with.
[display]
preset = "demo"
[hardware]
kind = "sim"
seed = 7
dump = "$out/shown"
photometric_variation = true
[calibration]
file = "$out/calibration.json"
auto = true
# Geometry first; the colours in step 4, so that the demo shows the difference they make.
photometric = "off"
[scene]
script = "cornell"
[daemon]
socket = "$socket"
cache_dir = "$cache"
EOC

echo "== 1. parallaxd on the simulated demo display (log: $out/parallaxd.log)"
"$parallaxd" --config "$out/parallax.toml" 2>"$out/parallaxd.log" &
daemon=$!
cleanup() {
  kill "$daemon" 2>/dev/null || true
  wait "$daemon" 2>/dev/null || true
  rm -rf "$run"
}
trap cleanup EXIT

echo "== 2. calibrate, regenerate, load cornell.lua, play"
for _ in $(seq 1 1800); do
  if ctl stats 2>/dev/null | grep -qE '"display_frames": [1-9]'; then break; fi
  kill -0 "$daemon" 2>/dev/null || { cat "$out/parallaxd.log"; exit 1; }
  sleep 0.5
done
ctl status | tee "$out/status.json"
ctl status | grep -q '"state": "playing"' || { echo "demo: the daemon is not playing"; exit 1; }
# The simulator's truth files (a folder per display and seed, in the daemon's cache).
simulated=$(sed -n 's/^ *"simulated_display": "\(.*\)",\{0,1\}$/\1/p' "$out/status.json")
# The browser control panel (a convenience: a taken port does not stop the demo).
if panel_url=$(ctl panel 2>&1); then
  echo "== control panel, while the demo runs: $panel_url"
else
  echo "== no control panel: $panel_url"
fi
# The calibration report: what the fit found, or why there is no calibration.
if [ -f "$out/calibration.json.report.txt" ]; then
  mv "$out/calibration.json.report.txt" "$out/calibration_report.txt"
else
  { echo "No calibration installed; the daemon plays on the nominal model. From the daemon's status:";
    grep -A3 '"last_error"' "$out/status.json" || echo "(no error recorded)"; } >"$out/calibration_report.txt"
fi

echo "== 3. the module frames and three observer views, from the daemon"
for m in $(seq 0 15); do
  ctl frame "$m" --path "$out/frames/$(printf 'module_%03d.png' "$m")" >/dev/null
done
for x in -0.5 0 0.5; do
  ctl view "$x" --path "$out/view_x$x.png" | grep '"path"'
done
ctl stats | tee "$out/timings.json" | grep '"summary"'

echo "== 4. the modules' colours: photometric calibration, then the frames again"
for m in $(seq 0 15); do
  cp "$out/frames/$(printf 'module_%03d.png' "$m")" "$out/frames_geometric_only/"
done
ctl calibrate --photometric only | tee "$out/photometric_calibration.json" | grep -E '"(delta_e_mean|non_uniformity)"' | head -2
ctl status >"$out/status.json"
mv "$out/calibration.json.report.txt" "$out/photometric_report.txt"
for m in $(seq 0 15); do
  ctl frame "$m" --path "$out/frames/$(printf 'module_%03d.png' "$m")" >/dev/null
done
# What a viewer of this simulated display sees: the frames' codes through its modules' true
# response, colours and vignetting, on its true geometry.
for x in -0.5 0 0.5; do
  for kind in geometric_only photometric; do
    frames=$out/frames
    [ "$kind" = geometric_only ] && frames=$out/frames_geometric_only
    "$parallax" view --display "$simulated/ground_truth.json" --frames "$frames" --x "$x" \
      --photometric-truth "$simulated/photometric_truth.json" --out "$out/seen_x${x}_$kind.png" >/dev/null
  done
done

# A viewer walking the observer line from x = -0.6 to 0.6 m, as a video (3 s, H.264).
"$parallax" view --display "$simulated/ground_truth.json" --frames "$out/frames" \
  --photometric-truth "$simulated/photometric_truth.json" --sweep -0.6:0.6 --sweep-frames 90 \
  --fps 30 --out "$out/sweep.mp4" --quiet | tail -1

if [ "${PARALLAX_DEMO_KEEP:-0}" = 1 ]; then
  echo "== the daemon keeps playing; its control panel: $panel_url"
  read -r -p "   press Enter to shut it down " _ || true
fi

echo "== 5. shut down"
ctl shutdown >/dev/null
wait "$daemon"
trap - EXIT
rm -rf "$run"

cat <<EON

Everything is in $out:
  frames/module_NNN.png        what parallaxd pushed to each of the 16 modules (cornell.lua)
  shown/module_NNN.png         what the simulated modules actually showed when it stopped
  view_x-0.5.png view_x0.png view_x0.5.png   what viewers on the observer line see (the daemon's
                               view, before the colours were calibrated)
  seen_x*_geometric_only.png   the before/after pair: what viewers at x = -0.5, 0, 0.5 m see on
  seen_x*_photometric.png      the simulated display (its modules' true colours), geometric
                               calibration only / geometric + photometric
  sweep.mp4                    a viewer walking the observer line from x = -0.6 to 0.6 m (3 s)
  frames_geometric_only/       the module frames before the photometric calibration
  photometric_calibration.json the photometric calibration's reply (per module scale, ΔE)
  calibration_report.txt       the calibration (or why the nominal model was used)
  photometric_report.txt       the photometric calibration: per module gamma, white, black,
                               falloff, reach; what is left (CIEDE2000, non-uniformity)
  timings.json                 render / encode / push / end-to-end timings and frame counts
  status.json, parallaxd.log, parallax.toml   the daemon's state (photometry included), its log
                               and its configuration
  panel.token                  the control panel's token (0600; kept beside the calibration)
EON
