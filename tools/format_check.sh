#!/usr/bin/env bash
# Checks that every tracked C++ file is formatted as .clang-format says (clang-format 14, from
# Debian's clang-format package). Prints the files that are not and exits 1; fix with
#   git ls-files '*.h' '*.cpp' | xargs clang-format -i
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$root"
mapfile -t files < <(git ls-files '*.h' '*.cpp')
if ! report=$(clang-format --dry-run --Werror "${files[@]}" 2>&1); then
  echo "format: these files differ from .clang-format (run clang-format -i on them):"
  grep -oE '^[^: ]+\.(h|cpp)' <<<"$report" | sort -u | sed 's/^/  /'
  exit 1
fi
echo "format: ${#files[@]} C++ files follow .clang-format"
