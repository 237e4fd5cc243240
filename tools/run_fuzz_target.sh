#!/usr/bin/env bash
# Runs one libFuzzer target for a fixed time on its growing corpus and its checked-in seeds
# (the CTest test of each fuzz target, label `fuzz`). On a crash prints the log's tail.
#   tools/run_fuzz_target.sh TARGET SECONDS CORPUS_DIR [SEED_DIR ...]
set -euo pipefail
target=${1:?fuzz target} seconds=${2:?seconds} corpus=${3:?corpus folder}
shift 3
name=$(basename "$target")
mkdir -p "$corpus"
seeds=()
for d in "$@"; do [ -d "$d" ] && seeds+=("$d"); done
# The scene library is the script loader's best seed corpus; read it in place, not copied.
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
[ "$name" = fuzz_scene_script ] && seeds+=("$root/scripts/scenes")
log=$(dirname "$corpus")/$name.log
if ! "$target" -max_total_time="$seconds" -print_final_stats=1 -rss_limit_mb=4096 \
  "$corpus" "${seeds[@]}" >"$log" 2>&1; then
  tail -n 60 "$log"
  echo "fuzz: $name FAILED"
  exit 1
fi
grep -E "stat::number_of_executed_runs|Done" "$log" | tail -n 2
