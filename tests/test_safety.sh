#!/usr/bin/env bash
# test_safety.sh — issue 18's "safety and integrity": every refusal and every
# recovery asserted by its exact message and location, on real files, real
# runs at tiny resolution and real kills (never timed).
#   usage: test_safety.sh <kerf binary> <tests dir> [case]
set -u
kerf=$1
tests=$2
only=${3:-}
work=$(mktemp -d /tmp/kerf_safety.XXXXXX)
trap 'rm -rf "$work"' EXIT
fails=0
check() { # check <description> <command...>
    local what=$1; shift
    if "$@"; then echo "ok    $what"; else echo "FAIL  $what"; fails=$((fails + 1)); fi
}
# has <file> <exact line>: the file holds this line, whole
has() { grep -qxF -- "$2" "$1" || { echo "      $1 lacks: $2"; echo "      it holds:"; sed 's/^/        /' "$1" | head -20; false; }; }
# a shot refused: exit 2, the exact error line, its source line echoed, nothing written
# refused <command> <shot> <exact error line> <exact echoed line> [more kerf args]
refused() {
    local cmd=$1 shot=$2 error=$3 echoed=$4; shift 4
    rm -rf refused_out
    "$kerf" "$cmd" "$shot" "$@" > refused.out 2> refused.err
    local rc=$?
    check "$shot ($cmd): exit 2 (got $rc)" test $rc -eq 2
    check "$shot ($cmd): $error" has refused.err "$error"
    check "$shot ($cmd): echoes the line" has refused.err "$echoed"
    check "$shot ($cmd): nothing written" test ! -e refused_out
}
run_case() { [ -z "$only" ] || [ "$only" = "$1" ]; }

cp "$tests/cli/tiny.yaml" "$work/"
mkdir -p "$work/meshes" && cp "$tests"/meshes/cube.obj "$tests"/meshes/cube_open.obj "$work/meshes/"
cd "$work"

# a tiny shot (about 150 particles, three frames, no surfaces or images) as a base for the cases
cat > small.yaml << 'EOF'
shot: small
frames: {start: 1001, end: 1003, fps: 24}
sim: {dx: 0.1, ppc: 8, cfl: 0.4}
domain: {min: [0, 0, 0], max: [1, 1, 1], walls: separate}
materials:
  jelly: {preset: jello}
objects:
  - {name: cube, shape: box, center: [0.5, 0.5, 0.5], size: 0.3, material: jelly}
output: {dir: refused_out, surface: false, images: false}
EOF

# --- 1. output paths ----------------------------------------------------------
if run_case outputs; then
    "$kerf" run small.yaml --out "" > /dev/null 2> err.txt; rc=$?
    check "--out '': exit 2 (got $rc)" test $rc -eq 2
    check "--out '': says why" has err.txt "kerf run: --out is empty: give a directory (relative to the current directory)"
    check "--out '': nothing written under / or here" bash -c "test ! -e /checkpoints/small.1001.kfc && test ! -e refused_out"
    sed 's|^output: .*|output: {dir: "", surface: false, images: false}|' small.yaml > empty_dir.yaml
    for cmd in check run; do
        refused $cmd empty_dir.yaml \
            "empty_dir.yaml:9:16: error: output.dir is empty: give a directory, relative to where kerf runs (e.g. out/{shot})" \
            '    9 | output: {dir: "", surface: false, images: false}'
    done
    sed 's|^output: .*|output: {dir: refused_out, name: "../../{shot}.{frame:04d}", surface: false}|' small.yaml > dotdot.yaml
    refused run dotdot.yaml \
        "dotdot.yaml:9:35: error: output.name must stay inside the output directory ('..' climbs out of it), got '../../{shot}.{frame:04d}'" \
        '    9 | output: {dir: refused_out, name: "../../{shot}.{frame:04d}", surface: false}'
    "$kerf" help shot > help.txt
    check "kerf help shot: what output.dir is relative to" \
        grep -qF "Output directory (a template), relative to the directory kerf runs in, not to the shot file" help.txt
    check "kerf help shot: what mesh paths are relative to" \
        has help.txt "paths: mesh files (objects, colliders, rigids) are relative to the shot file's directory;"
fi

echo "$fails failed"
exit $((fails > 0))
