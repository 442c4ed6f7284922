#!/usr/bin/env bash
# test.sh — set up, build, and run the whole test suite with ctest.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
"$here/tools/setup.sh"
cd "$here/build"
ctest --output-on-failure -j 2 --timeout 900
