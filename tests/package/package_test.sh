#!/usr/bin/env bash
# The package as a user gets it (issue 20): `cmake --install` to another prefix builds an
# integrator's program against the CMake package config; `cpack -G DEB` builds parallax and
# parallax-dev, lintian finds no errors in them, the unpacked parallax package holds every
# file where Debian 12 wants it, its parallaxd runs with its own installed config (paths moved
# into the temporary root) against the simulator it starts until `status` says playing, finds
# the installed scene library, and stops cleanly on SIGTERM; systemd-analyze verifies the unit.
#   package_test.sh BUILD_DIR SOURCE_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
source=$(cd "$2" && pwd)
work=$(mktemp -d /tmp/plxpkg.XXXXXX)
daemon_pid=""
cleanup() {
  if [ -n "$daemon_pid" ]; then kill -TERM "$daemon_pid" 2>/dev/null || true; wait "$daemon_pid" 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
step() { echo "--- $*"; }

step "cmake --install to another prefix"
prefix=$work/opt/parallax
cmake --install "$build" --prefix "$prefix" >/dev/null
for f in bin/parallax bin/parallax-tools bin/parallaxd bin/parallax-simhw share/parallax/scenes/cornell.lua \
         share/parallax/API.md etc/parallax/parallax.toml lib/systemd/system/parallaxd.service \
         lib/sysusers.d/parallax.conf lib/udev/rules.d/60-parallax.rules \
         lib/cmake/Parallax/ParallaxConfig.cmake include/parallax/calibration/display/display_model.h; do
  [ -e "$prefix/$f" ] || fail "cmake --install --prefix: $f missing"
done
grep -qx "ExecStart=$prefix/bin/parallaxd --config $prefix/etc/parallax/parallax.toml" \
  "$prefix/lib/systemd/system/parallaxd.service" || fail "the unit's ExecStart does not follow the prefix"

step "an integrator's program: find_package(Parallax) from that prefix"
cmake -S "$source/tests/package/consumer" -B "$work/consumer" -G Ninja -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" >"$work/consumer.log" 2>&1 || { cat "$work/consumer.log"; fail "configure"; }
cmake --build "$work/consumer" >>"$work/consumer.log" 2>&1 || { cat "$work/consumer.log"; fail "build"; }
"$work/consumer/consumer" | grep -q "demo display: 16 modules" || fail "the consumer program"

step "cpack -G DEB"
(cd "$work" && cpack --config "$build/CPackConfig.cmake" -G DEB -B "$work/deb" >"$work/cpack.log" 2>&1) ||
  { cat "$work/cpack.log"; fail "cpack"; }
deb=$(ls "$work"/deb/parallax_*.deb)
dev=$(ls "$work"/deb/parallax-dev_*.deb)

step "lintian (no errors; warnings printed)"
for p in "$deb" "$dev"; do
  lintian --fail-on error --tag-display-limit 0 "$p" || fail "lintian: errors in $(basename "$p")"
done

step "the package's files"
root=$work/root
dpkg-deb -x "$deb" "$root"
dpkg-deb -c "$deb" | awk '{print $6}'
for f in usr/bin/parallax usr/bin/parallax-tools usr/bin/parallaxd usr/bin/parallax-simhw \
         usr/share/parallax/scenes/cornell.lua usr/share/parallax/scenes/lib/paper.lua \
         usr/share/parallax/API.md etc/parallax/parallax.toml \
         lib/systemd/system/parallaxd.service usr/lib/sysusers.d/parallax.conf \
         lib/udev/rules.d/60-parallax.rules usr/share/doc/parallax/copyright; do
  [ -e "$root/$f" ] || fail "the package lacks /$f"
done
dpkg-deb -f "$deb" Depends | grep -q "libc6" || fail "no shared-library dependencies computed"
# Manual pages (help2man at build time), when the build had it.
if command -v help2man >/dev/null; then
  for p in parallax parallax-tools parallaxd parallax-simhw; do
    [ -s "$root/usr/share/man/man1/$p.1.gz" ] || fail "the package lacks the manual page of $p"
  done
fi
# The light front answers --version itself and runs parallax-tools beside it for the rest.
"$root/usr/bin/parallax" --version | grep -q "^parallax [0-9]" || fail "parallax --version"
"$root/usr/bin/parallax-tools" --version | grep -q "^parallax [0-9]" || fail "parallax-tools --version"
"$root/usr/bin/parallaxd" --version | grep -q "^parallaxd [0-9]" || fail "parallaxd --version"
env -u PARALLAX_SCENE_LIBRARY "$root/usr/bin/parallax" display --preset demo >/dev/null \
  || fail "the installed parallax does not run the parallax-tools beside it"
dpkg-deb -I "$deb" conffiles | grep -qx /etc/parallax/parallax.toml || fail "parallax.toml is not a conffile"
unit=$root/lib/systemd/system/parallaxd.service
grep -qx "ExecStart=/usr/bin/parallaxd --config /etc/parallax/parallax.toml" "$unit" || fail "ExecStart"
for key in User=parallax StateDirectory=parallax CacheDirectory=parallax RuntimeDirectory=parallax; do
  grep -qx "$key" "$unit" || fail "the unit lacks $key"
done
config=$root/etc/parallax/parallax.toml
for path in /var/lib/parallax/ /var/cache/parallax /run/parallax/; do
  grep -q "\"$path" "$config" || fail "the installed config does not use $path"
done

if command -v systemd-analyze >/dev/null; then
  step "systemd-analyze verify"
  # Against this machine's units (an unpacked package has no sysinit.target), with ExecStart
  # pointing at the unpacked binary; any message (an unknown key is only a warning) fails.
  mkdir -p "$work/verify"
  sed "s|^ExecStart=/usr/bin/parallaxd|ExecStart=$root/usr/bin/parallaxd|" "$unit" >"$work/verify/parallaxd.service"
  verify_out=$(systemd-analyze verify "$work/verify/parallaxd.service" 2>&1) ||
    { echo "$verify_out"; fail "systemd-analyze verify"; }
  [ -z "$verify_out" ] || { echo "$verify_out"; fail "systemd-analyze verify has remarks"; }
fi

step "the installed parallaxd, installed config, simulator, until playing"
# The service's folders, moved into the temporary root (a test cannot write /var or /run).
sed -e "s|\"/var/lib/parallax/|\"$root/var/lib/parallax/|" -e "s|\"/var/cache/parallax|\"$root/var/cache/parallax|" \
    -e "s|\"/run/parallax/|\"$root/run/parallax/|" -e "s|^port = 8470|port = 0|" "$config" >"$work/parallax.toml"
mkdir -p "$root/var/lib/parallax" "$root/var/cache/parallax"
socket=$root/run/parallax/parallaxd.sock
env -u PARALLAX_SCENE_LIBRARY -u NOTIFY_SOCKET "$root/usr/bin/parallaxd" --config "$work/parallax.toml" \
  >"$work/parallaxd.log" 2>&1 &
daemon_pid=$!
ctl() { env -u PARALLAX_SCENE_LIBRARY "$root/usr/bin/parallax" ctl --socket "$socket" "$@"; }
state=""
for _ in $(seq 1 600); do
  kill -0 "$daemon_pid" 2>/dev/null || { cat "$work/parallaxd.log"; fail "parallaxd exited"; }
  state=$(ctl status 2>/dev/null | sed -nE 's/.*"state": "([a-z_]+)".*/\1/p' | head -1) || true
  [ "$state" = playing ] && break
  sleep 1
done
[ "$state" = playing ] || { tail -40 "$work/parallaxd.log"; fail "not playing after 600 s (state: $state)"; }
ctl status
[ -s "$root/var/lib/parallax/calibration.json" ] || fail "no calibration installed in the state folder"
# A scene only the installed library has: the programs find /usr/share/parallax/scenes.
cp "$root/usr/share/parallax/scenes/shapes.lua" "$root/usr/share/parallax/scenes/packaged_only.lua"
ctl load packaged_only || fail "the installed parallaxd does not find the installed scene library"
step "the control panel: its URL, its token in the state folder (0600)"
url=$(ctl panel) || fail "no control panel"
[[ $url == http://127.0.0.1:*/?token=* ]] || fail "parallax ctl panel printed \"$url\""
[ "$(stat -c %a "$root/var/lib/parallax/panel.token")" = 600 ] || fail "panel.token is not 0600"

step "SIGTERM"
kill -TERM "$daemon_pid"
status=0
wait "$daemon_pid" || status=$?
daemon_pid=""
[ "$status" -eq 0 ] || { tail -20 "$work/parallaxd.log"; fail "parallaxd exited $status on SIGTERM"; }
[ ! -e "$socket" ] || fail "the control socket was left behind"
echo "package test: passed"
