#!/usr/bin/env bash
# run.sh — the main job: set up (packages, build), then simulate the default
# shot. Extra arguments go to `kerf run`, e.g. --quality preview, --frames 1001-1010.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
"$here/tools/setup.sh"
cd "$here"
./build/kerf run shots/demo.yaml "$@"
echo "images: $here/out/demo/v001/images/ (PNG); surface/ (.vdb), particles/ (.ply) and checkpoints/ beside them"
