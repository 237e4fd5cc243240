# Sourced by the calibrate_*_test.sh scripts: the seeded simulated display they calibrate (demo,
# seed 7, 640x360 camera) in a fresh folder, and parallax-simhw photographing it.
#   simulate_display PARALLAX     the truth files, camera.json and nominal.json into $dir
#   start_simhw SIMHW [OPTIONS]   parallax-simhw on $sock with that truth (and OPTIONS); returns
#                                 once it listens and, with --camera-feed F, F holds a picture
#   rms_of LOG                    the "ray error X module px RMS" a calibrate run printed
# On exit the simulator is stopped and $dir removed; a script with more to stop defines
# before_cleanup().
dir=$(mktemp -d)
sock=$dir/simhw.sock
simhw_pid=
cleanup() {
  if declare -F before_cleanup > /dev/null; then before_cleanup; fi
  if [ -n "$simhw_pid" ]; then kill "$simhw_pid" 2>/dev/null || true; wait "$simhw_pid" 2>/dev/null || true; fi
  rm -rf "$dir"
}
trap cleanup EXIT

simulate_display() {
  # Only the truth files and camera.json are needed: --synthetic skips rendering pictures here.
  "$1" simulate --display demo --seed 7 --out "$dir" --camera-resolution 640x360 --synthetic > /dev/null
}

start_simhw() {
  local simhw=$1 feed= previous= option
  shift
  for option in "$@"; do
    [ "$previous" = --camera-feed ] && feed=$option
    previous=$option
  done
  "$simhw" --socket "$sock" --truth "$dir/ground_truth.json" --camera "$dir/camera_truth.json" "$@" &
  simhw_pid=$!
  # The socket appears only once it listens (listenPrivately), so seeing it is enough.
  for _ in $(seq 1 600); do
    [ -S "$sock" ] && { [ -z "$feed" ] || [ -f "$feed" ]; } && return 0
    kill -0 "$simhw_pid" 2>/dev/null || { echo "FAIL: parallax-simhw exited"; exit 1; }
    sleep 0.1
  done
  echo "FAIL: parallax-simhw never listened on $sock${feed:+ or wrote $feed}"
  exit 1
}

rms_of() { sed -n 's/.*ray error \([0-9.]*\) module px RMS.*/\1/p' "$1"; }
