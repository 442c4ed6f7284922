#!/usr/bin/env bash
# test_cli_rigid.sh — a cutting shot end to end: a kinematic thin plate goes
# through a small jello block; the run writes its checkpoints, surfaces and
# images, logs where the plate is after every frame (where its keys put it),
# keeps every particle, and draws the plate in the images in its colour.
#   usage: test_cli_rigid.sh <kerf binary> <tests dir>
set -u
kerf=$1
tests=$2
work=$(mktemp -d /tmp/kerf_cli_rigid.XXXXXX)
trap 'rm -rf "$work"' EXIT
fails=0
check() { # check <description> <command...>
    local what=$1; shift
    if "$@"; then echo "ok    $what"; else echo "FAIL  $what"; fails=$((fails + 1)); fi
}
cp "$tests/cli/cut.yaml" "$work/"
cd "$work"

"$kerf" info cut.yaml > info.txt 2>&1
check "kerf info lists the plate" grep -qE '^  blade +thin kinematic box, [1-9][0-9]* seeds' info.txt

"$kerf" run cut.yaml --out o > run.log 2>&1
check "the run exits 0" test $? -eq 0
check "three checkpoints" test "$(ls o/checkpoints/*.kfc 2>/dev/null | wc -l)" -eq 3
check "three surfaces (.vdb)" test "$(ls o/surface/*.vdb 2>/dev/null | wc -l)" -eq 3
check "three images (.png)" test "$(ls o/images/*.png 2>/dev/null | wc -l)" -eq 3
check "the images are 320x180 PNGs" bash -c "file o/images/cut.1003.png | grep -q 'PNG image data, 320 x 180'"
# the plate's pivot follows its keys: 0.6 - 0.2 t / (2 frames) in y
check "the frame log shows the plate after frame 1002" grep -qF "  rigid blade: at [0.500, 0.500, 0.500] m, v [0.000, -2.400, 0.000] m/s" run.log
check "the frame log shows the plate after frame 1003" grep -qF "  rigid blade: at [0.500, 0.400, 0.500] m" run.log
n0=$(sed -n 's/^kerf [^:]*: cut v001, \([0-9]*\) particles.*/\1/p' run.log)
check "no particle is deleted by the cut ($n0 at the start)" \
    test "$(grep -cE "^frame 100[23]: $n0 particles" run.log)" -eq 2

# the plate is in the picture: recoloured, the image changes without re-simulating
cp o/images/cut.1003.png blue.png
"$kerf" run cut.yaml --out o --set 'rigids.blade.color=[0.9, 0.1, 0.1]' > re.log 2>&1
check "a recoloured body re-renders without re-simulating" \
    bash -c "grep -q 'nothing to simulate' re.log && grep -q '3 images made' re.log"
check "the plate is drawn: its colour changes the image" bash -c "! cmp -s blue.png o/images/cut.1003.png"
check "no temporaries left" test -z "$(find o -name '*.tmp-*')"

# solids whose mesh intersects itself (sand_stir's bowl leaked through its
# bottom): refused at each mesh: key with the mesh, two triangles and a point, the
# line echoed, every one in one pass, exit 2 and nothing written
mkdir -p shots meshes
cp "$tests/shots/bad_solid.yaml" shots/
cp "$tests/meshes/cubes_crossed.obj" "$tests/meshes/cube.obj" meshes/
where="shots/../meshes/cubes_crossed.obj: intersects itself: triangles 3 and 18 meet at (1, 0.25, 1) (file coordinates); 14 pairs of triangles intersect"
for cmd in check run; do
    "$kerf" $cmd shots/bad_solid.yaml --out bad > bad.out 2> bad.err; rc=$?
    check "kerf $cmd refuses self-intersecting solids with exit 2 (got $rc)" test $rc -eq 2
    check "kerf $cmd: the static rigid, at its mesh" grep -qxF \
        "shots/bad_solid.yaml:13:36: error: rigid cup: a static solid must not intersect itself: $where" bad.err
    check "kerf $cmd: its line echoed" grep -qxF \
        "   13 |   - {name: cup, shape: mesh, mesh: ../meshes/cubes_crossed.obj, scale: 0.1, center: [0.5, 0.7, 0.5]}" bad.err
    check "kerf $cmd: the dynamic rigid" grep -qxF \
        "shots/bad_solid.yaml:14:36: error: rigid lid: a dynamic solid must not intersect itself: $where" bad.err
    check "kerf $cmd: the object" grep -qxF "shots/bad_solid.yaml:11:37: error: object 'lump': $where" bad.err
    check "kerf $cmd: three errors in all" test "$(grep -c ': error: ' bad.err)" -eq 3
    check "kerf $cmd: nothing written" test ! -e bad
done

echo "$fails failed"
exit $((fails > 0))
