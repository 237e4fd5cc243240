#!/usr/bin/env bash
# The test command: installs what is missing, builds (Release, warnings on), runs every CTest
# suite, then builds the libFuzzer targets with clang and runs each for a fixed time.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
fuzz_seconds=${PARALLAX_FUZZ_SECONDS:-60}

"$root/tools/setup.sh"
ctest_log=$root/build/ctest.log
ctest --test-dir "$root/build" --output-on-failure --timeout 900 -j "$(nproc)" | tee "$ctest_log"
ctest_passed=$(sed -nE 's/.*tests passed, ([0-9]+) tests failed out of ([0-9]+).*/\2 \1/p' "$ctest_log" |
  awk '{print $1 - $2}')
fuzz_passed=0

if [ "$fuzz_seconds" -gt 0 ]; then
  fuzz_dir=$root/build-fuzz
  CC=clang-14 CXX=clang++-14 cmake -S "$root" -B "$fuzz_dir" -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DPARALLAX_BUILD_FUZZ=ON -DPARALLAX_BUILD_TESTS=OFF -DPARALLAX_BUILD_BENCH=OFF >/dev/null
  cmake --build "$fuzz_dir" --target fuzz_targets --parallel "$(nproc)"
  while read -r target; do
    [ -n "$target" ] || continue
    corpus=$fuzz_dir/corpus/$target
    mkdir -p "$corpus"
    seeds=()
    [ -d "$root/tests/fuzz/seeds/$target" ] && seeds+=("$root/tests/fuzz/seeds/$target")
    # The scene library is the script loader's best seed corpus; read it in place, not copied.
    [ "$target" = fuzz_scene_script ] && seeds+=("$root/scripts/scenes")
    echo "fuzz: $target for ${fuzz_seconds}s"
    log=$fuzz_dir/$target.log
    if ! "$fuzz_dir/tests/fuzz/$target" -max_total_time="$fuzz_seconds" -print_final_stats=1 \
      -rss_limit_mb=4096 "$corpus" "${seeds[@]}" >"$log" 2>&1; then
      tail -n 60 "$log"
      echo "fuzz: $target FAILED"
      exit 1
    fi
    grep -E "stat::number_of_executed_runs|Done" "$log" | tail -n 2
    fuzz_passed=$((fuzz_passed + 1))
  done < "$fuzz_dir/fuzz_targets.txt"
fi
# One closing line for the whole run (CTest cases + fuzz targets); any failure exited above.
echo "tests: $((ctest_passed + fuzz_passed)) passed, 0 failed"
