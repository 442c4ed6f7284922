#!/usr/bin/env bash
# test.sh — set up, build, and run the whole test suite with ctest.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
"$here/tools/setup.sh"
cd "$here/build"
# one test at a time: each test already runs two OpenMP threads
ctest --output-on-failure --timeout 900
