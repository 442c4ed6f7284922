#!/usr/bin/env bash
# run.sh — the main job: set up, build, simulate the default shot.
#   usage: tools/run.sh [kerf run options]   e.g. --frames 48 --res 96
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
"$here/tools/setup.sh"
cd "$here"
./build/kerf run --out out/demo "$@"
echo "frames (PLY point clouds): $here/out/demo/"
