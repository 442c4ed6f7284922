#!/usr/bin/env bash
# format.sh — format every C, C++ and header file of the repository with the
# committed .clang-format (LLVM base, indent 4, 120 columns; it reproduces
# src/mpm/grid.c exactly). Run once over the tree, then on changed files;
# --check lists the files that would change and exits 1 if any would.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"
cf=$(command -v clang-format || command -v clang-format-14 || true)
if [ -z "$cf" ]; then
  echo "format.sh: clang-format not found (apt-get install -y clang-format)" >&2
  exit 2
fi
mapfile -t files < <(git ls-files '*.c' '*.h' '*.cpp')
if [ "${1:-}" = "--check" ]; then
  bad=0
  for f in "${files[@]}"; do
    if ! "$cf" "$f" | cmp -s - "$f"; then
      echo "$f"
      bad=1
    fi
  done
  exit $bad
fi
"$cf" -i "${files[@]}"
echo "formatted ${#files[@]} files"
