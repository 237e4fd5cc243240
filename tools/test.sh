#!/usr/bin/env bash
# The test command: installs what is missing, builds (Release, warnings on), checks the
# formatting, runs every CTest suite, then builds the libFuzzer targets with clang and runs each
# for a fixed time.
#   tools/test.sh          everything (what CI runs)
#   tools/test.sh --fast   the edit-test loop: build, then only the tests labelled `fast`
#                          (unit suites, well under two minutes), no fuzzing
# Labels: fast (unit), slow (processes, image pipelines, soak), e2e (the daemon end to end),
# fuzz (the libFuzzer runs, here); `ctest --test-dir build -L LABEL` runs one group.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
fuzz_seconds=${PARALLAX_FUZZ_SECONDS:-60}
ctest_args=()
if [ "${1:-}" = "--fast" ]; then
  ctest_args=(-L fast)
  fuzz_seconds=0
elif [ -n "${1:-}" ]; then
  echo "usage: tools/test.sh [--fast]" >&2
  exit 2
fi

"$root/tools/setup.sh"
"$root/tools/format_check.sh"
ctest_log=$root/build/ctest.log
ctest --test-dir "$root/build" --output-on-failure --timeout 900 -j "$(nproc)" "${ctest_args[@]}" |
  tee "$ctest_log"
ctest_passed=$(sed -nE 's/.*tests passed, ([0-9]+) tests failed out of ([0-9]+).*/\2 \1/p' "$ctest_log" |
  awk '{print $1 - $2}')
fuzz_passed=0

if [ "$fuzz_seconds" -gt 0 ]; then
  # The fuzz targets need clang's libFuzzer and sanitizers: their own build, their own ctest.
  fuzz_dir=$root/build-fuzz
  CC=clang-14 CXX=clang++-14 cmake -S "$root" -B "$fuzz_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DPARALLAX_BUILD_FUZZ=ON -DPARALLAX_BUILD_TESTS=OFF -DPARALLAX_BUILD_BENCH=OFF \
    -DPARALLAX_FUZZ_SECONDS="$fuzz_seconds" >/dev/null
  cmake --build "$fuzz_dir" --target fuzz_targets --parallel "$(nproc)"
  fuzz_log=$fuzz_dir/ctest.log
  # One per core: each fuzzer is single-threaded and runs for its whole time.
  status=0
  ctest --test-dir "$fuzz_dir" -L fuzz --output-on-failure -V -j "$(nproc)" >"$fuzz_log" 2>&1 || status=$?
  grep -E "Test +#|stat::number_of_executed_runs|Done [0-9]|tests passed|FAILED" "$fuzz_log" || true
  if [ "$status" -ne 0 ]; then
    tail -n 80 "$fuzz_log"
    echo "fuzz: a target FAILED (log: $fuzz_log)"
    exit 1
  fi
  fuzz_passed=$(sed -nE 's/.*tests passed, ([0-9]+) tests failed out of ([0-9]+).*/\2 \1/p' "$fuzz_log" |
    awk '{print $1 - $2}')
fi
# One closing line for the whole run (CTest cases + fuzz targets); any failure exited above.
echo "tests: $((ctest_passed + fuzz_passed)) passed, 0 failed"
