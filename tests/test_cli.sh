#!/usr/bin/env bash
# test_cli.sh — the kerf command end to end: a bad shot is refused with every
# problem at file:line:col and nothing written; a run writes its frames; a run
# killed mid-way and resumed ends bit for bit where an uninterrupted run ends.
#   usage: test_cli.sh <kerf binary> <tests dir>
set -u
kerf=$1
tests=$2
work=$(mktemp -d /tmp/kerf_cli.XXXXXX)
trap 'rm -rf "$work"' EXIT
fails=0
check() { # check <description> <command...>
    local what=$1; shift
    if "$@"; then echo "ok    $what"; else echo "FAIL  $what"; fails=$((fails + 1)); fi
}

cp "$tests/cli/tiny.yaml" "$tests/cli/broken.yaml" "$work/"
cd "$work"

# --- bad input: exit 2, all errors with locations, nothing written -----------
"$kerf" run broken.yaml > out.txt 2> err.txt
rc=$?
check "bad shot exits 2 (got $rc)" test $rc -eq 2
check "dx error at its line:col" grep -q "^broken.yaml:5:[0-9]*: error: .*dx" err.txt
check "undefined material at its line:col, with a suggestion" grep -q "^broken.yaml:9:[0-9]*: error: .*jely.*jelly" err.txt
check "the offending line is echoed" grep -q "material: jely" err.txt
check "nothing written for a bad shot" test ! -e broken
"$kerf" check broken.yaml > /dev/null 2>&1
check "kerf check exits 2 on the same shot" test $? -eq 2
"$kerf" run tiny.yaml --set sim.cfl=abc > /dev/null 2> err.txt
check "a bad --set exits 2 and names the override" bash -c "grep -q -- '--set' err.txt && ! test -e tiny"
"$kerf" run > /dev/null 2>&1
check "no shot is a usage error (2)" test $? -eq 2

# one file per mistake (tests/cli/bad/EXPECT): exit 2, the error at its exact
# line:col with the line echoed under it, and no output directory
# (the same tree shape as tests/, so the shots' relative mesh paths hold)
mkdir -p t/cli/bad t/meshes && cp "$tests"/cli/bad/*.yaml t/cli/bad/
cp "$tests"/meshes/cube_open.obj "$tests"/meshes/empty.obj t/meshes/
ln -s t/cli/bad bad
while IFS='|' read -r file loc fragment; do
    case "$file" in ''|'#'*) continue ;; esac
    (cd bad && "$kerf" run "$file" --out "out_$file" > /dev/null 2> "$file.err")
    rc=$?
    first=$(grep -m1 ': error: ' "bad/$file.err")
    check "$file: exit 2 (got $rc)" test $rc -eq 2
    check "$file: error at $loc" test "${first%%: error: *}" = "$file:$loc"
    check "$file: says '$fragment'" grep -qF -- "$fragment" "bad/$file.err"
    check "$file: echoes the line" grep -qE '^ +[0-9]+ \| ' "bad/$file.err"
    check "$file: writes nothing" test ! -e "bad/out_$file"
done < "$tests/cli/bad/EXPECT"
"$kerf" frobnicate > /dev/null 2>&1
check "unknown command is a usage error (2)" test $? -eq 2
"$kerf" help shot | grep -q "sim.dx"
check "kerf help shot lists the keys" test $? -eq 0
"$kerf" check tiny.yaml > check.txt 2>&1
rc=$?
check "kerf check accepts a good shot: exit 0 (got $rc), its one line exactly" \
    bash -c "test $rc -eq 0 && test \"\$(grep -c . check.txt)\" -eq 1 && \
             grep -qxF 'tiny.yaml: ok (tiny, 9192 particles, frames 1001-1012)' check.txt"

# --- a run that fails: exit 1 with the reason, no frame after the last good one ---
# a fixed step of 0.04 s moves the falling cube a cell a substep: a fixed step
# is never changed, so that is fatal; with sim.retry_fixed the frame is
# retried at 0.02 s and passes
"$kerf" run tiny.yaml --out trouble --frames 1001-1002 --set sim.dt_fixed=0.04 > trouble.log 2> trouble.err
rc=$?
check "numerical trouble exits 1 (got $rc)" test $rc -eq 1
check "it names the frame, the trouble, the particle and the material" grep -qE "^kerf: frame 1002: numerical \
trouble: CFL violated \(cells moved per substep\) \(value [0-9.]+\) at substep [0-9]+, particle [0-9]+, material 0 \
'jelly', at the fixed step sim.dt_fixed = 0.04 s" trouble.err
check "no checkpoint after the last good frame" bash -c "test -e trouble/checkpoints/tiny.1001.kfc && ! test -e trouble/checkpoints/tiny.1002.kfc"
"$kerf" run tiny.yaml --out retried --frames 1001-1002 --set sim.dt_fixed=0.04 --set sim.retry_fixed=true \
    --set output.surface=false --set output.images=false > retried.log 2>&1
rc=$?
check "with sim.retry_fixed the frame is retried at half the step and the run exits 0 (got $rc)" \
    bash -c "test $rc -eq 0 && grep -qE '^frame 1002: .* 1 retries, 1 warnings' retried.log && \
             grep -qF 'frame 1002: retried at a fixed step of 0.02 s' retried.log && test -e retried/checkpoints/tiny.1002.kfc"

# --- a full run ---------------------------------------------------------------
"$kerf" run tiny.yaml --out full > run.log 2>&1
check "full run exits 0" test $? -eq 0
check "twelve particle frames" test "$(ls full/particles/*.ply 2>/dev/null | wc -l)" -eq 12
check "twelve checkpoints" test "$(ls full/checkpoints/*.kfc 2>/dev/null | wc -l)" -eq 12
check "frame log line per frame (not a terminal)" test "$(grep -cE '^frame 10[0-9]+: [0-9]+ particles' run.log)" -eq 11
check "twelve surfaces (.vdb)" test "$(ls full/surface/*.vdb 2>/dev/null | wc -l)" -eq 12
check "twelve images (.png)" test "$(ls full/images/*.png 2>/dev/null | wc -l)" -eq 12
check "surfacing and rendering print a progress line per frame, with a bar and ETA" \
    bash -c "test \$(grep -cE '^\[#* *\] render frame 10[0-9]{2} \([0-9]+/12\)  surface [0-9]+ ms, render [0-9]+ ms a frame  ETA [0-9]+m[0-9]{2}s$' run.log) -eq 12 && \
             grep -qxE '\[#{20}\] render frame 1012 \(12/12\)  surface [0-9]+ ms, render [0-9]+ ms a frame  ETA 0m00s' run.log"
check "the particle PLY names velocity v_x v_y v_z and carries von_mises, J, plastic_strain" \
    bash -c "head -c 1000 full/particles/tiny.1012.ply | grep -a -c -E '^property (float v_[xyz]|float von_mises|float J|float plastic_strain)$' | grep -qx 6"

# the implicit midpoint scheme from the command line: the frame log names it
"$kerf" run tiny.yaml --out mid --frames 1001-1003 --set sim.integrator=implicit \
    --set sim.implicit_scheme=midpoint > mid.log 2>&1
check "an implicit midpoint run exits 0" test $? -eq 0
check "its frame log names the scheme and the iterations" \
    test "$(grep -cE '^frame 100[23]: implicit \(midpoint\): [0-9]+ Newton, [0-9]+ Krylov iterations' mid.log)" -eq 2
"$kerf" info tiny.yaml --set sim.integrator=implicit --set sim.implicit_scheme=midpoint > midinfo.txt 2>&1
check "kerf info names the integrator, its scheme and its solver settings" \
    grep -q "^time      implicit, midpoint; substeps by advection alone; Newton tol 0.001 (at most 20)" midinfo.txt
# ... and a resume continues it exactly (the solve's start reads the stress planes a checkpoint restores)
"$kerf" run tiny.yaml --out mid --frames 1001-1006 --resume --set sim.integrator=implicit \
    --set sim.implicit_scheme=midpoint > midr.log 2>&1
"$kerf" run tiny.yaml --out midfull --frames 1001-1006 --set sim.integrator=implicit \
    --set sim.implicit_scheme=midpoint > midfull.log 2>&1
check "an implicit run resumed after frame 1003 ends bit for bit where an uninterrupted one ends" \
    bash -c "grep -q 'resuming after frame 1003' midr.log && cmp -s mid/checkpoints/tiny.1006.kfc midfull/checkpoints/tiny.1006.kfc"
check "the images are 1280x720 PNGs" bash -c "file full/images/tiny.1012.png | grep -q 'PNG image data, 1280 x 720'"
# what the frames show (kf_png_probe, built beside kerf: counts and centroids of
# clearly red and green pixels): the red jello cube and the green goo slab in
# every frame; at 1001 the cube above the slab (measured 162 px higher) and
# centred over it (3 px); at 1012 it has fallen (135 px lower); the renderer's
# background gradient alone is a fifth of a frame (measured 21%), never all of it
probe="$(dirname "$kerf")/kf_png_probe"
seen=0
for f in full/images/tiny.10*.png; do
    "$probe" "$f" > probe.txt || break
    awk '$1 == "red" { r = $2 } $1 == "green" { g = $2 } $1 == "background" { b = $2 }
         END { exit !(r > 0.005 * 921600 && g > 0.03 * 921600 && b < 0.5 * 921600) }' probe.txt && seen=$((seen + 1))
done
check "every image shows the cube and the slab, not only background ($seen of 12)" test $seen -eq 12
"$probe" full/images/tiny.1001.png > p1001.txt
"$probe" full/images/tiny.1012.png > p1012.txt
at() { awk -v k="$2" -v i="$3" '$1 == k { print $i }' "$1"; }
check "frame 1001: the cube above the slab (red y $(at p1001.txt red 4), green y $(at p1001.txt green 4))" \
    awk -v r="$(at p1001.txt red 4)" -v g="$(at p1001.txt green 4)" 'BEGIN { exit !(r > 0 && r < g - 72) }'
check "frame 1001: the cube centred over the slab (red x $(at p1001.txt red 3), green x $(at p1001.txt green 3))" \
    awk -v r="$(at p1001.txt red 3)" -v g="$(at p1001.txt green 3)" 'BEGIN { d = r - g; exit !(r > 0 && d * d < 38 * 38) }'
check "frame 1012: the cube has fallen (red y $(at p1001.txt red 4) -> $(at p1012.txt red 4))" \
    awk -v a="$(at p1001.txt red 4)" -v b="$(at p1012.txt red 4)" 'BEGIN { exit !(a > 0 && b > a + 72) }'
check "the PNG carries the shot and frame" bash -c "grep -a -q 'shot' full/images/tiny.1012.png && grep -a -q '1012' full/images/tiny.1012.png"
"$kerf" render tiny.yaml --out full > render.log 2>&1
check "kerf render keeps current images" grep -q "0 images made, 12 current outputs kept" render.log
touch full/surface/tiny.1005.vdb
"$kerf" render tiny.yaml --out full > render.log 2>&1
check "a newer surface is rendered again, alone" grep -q "1 images made, 11 current outputs kept" render.log
"$kerf" run tiny.yaml --out full --set render.width=320 --set render.height=180 > rs.log 2>&1
check "changed render settings do not re-simulate" grep -q "nothing to simulate" rs.log
check "changed render settings re-render every frame" grep -q "12 images made" rs.log
check "at the new size" bash -c "file full/images/tiny.1012.png | grep -q 'PNG image data, 320 x 180'"
"$kerf" run tiny.yaml --out full --set render.width=320 --set render.height=180 --set materials.goo.color=[0,1,0] > rc.log 2>&1
check "a recoloured material re-renders without re-simulating" bash -c "grep -q 'nothing to simulate' rc.log && grep -q '12 images made' rc.log"
"$kerf" run tiny.yaml --out full --set render.width=320 --set render.height=180 --set materials.goo.color=[0,1,0] \
    --set materials.goo.specular=0.9 --set materials.goo.roughness=0.1 > rsp.log 2>&1
check "a reshaded material (specular, roughness) re-renders without re-simulating" \
    bash -c "grep -q 'nothing to simulate' rsp.log && grep -q '0 surfaces, 12 images made' rsp.log"
"$kerf" run tiny.yaml --out full --set render.width=320 --set render.height=180 --set materials.goo.color=[0,1,0] \
    --set surface.voxel=1 --set surface.radius=1.5 > sv.log 2>&1
check "changed surface settings re-surface and re-render, without re-simulating" \
    bash -c "grep -q 'nothing to simulate' sv.log && grep -q '12 surfaces, 12 images made' sv.log"
"$kerf" run tiny.yaml --out full --frames 1012 --set surface.group=object > sg.log 2>&1
check "surface.group=object re-surfaces without re-simulating" \
    bash -c "grep -q 'nothing to simulate' sg.log && grep -q '1 surfaces, 1 images made' sg.log"
# EXR beside the PNG: a new format re-renders (no re-simulation), is kept when current, a missing
# EXR is made again alone (test_exr checks what the files hold)
exr_sets="--set render.width=320 --set render.height=180 --set materials.goo.color=[0,1,0] --set surface.voxel=1"
exr_sets="$exr_sets --set surface.radius=1.5 --set surface.group=object --set render.format=both"
"$kerf" run tiny.yaml --out full $exr_sets --frames 1011-1012 > exr.log 2>&1
check "render.format=both writes an EXR beside each PNG, without re-simulating" \
    bash -c "grep -q 'nothing to simulate' exr.log && grep -q '2 images made' exr.log && test -s full/images/tiny.1012.exr && test -s full/images/tiny.1012.png"
check "the EXR is OpenEXR" bash -c "head -c 4 full/images/tiny.1012.exr | od -An -tx1 | grep -q '76 2f 31 01'"
"$kerf" run tiny.yaml --out full $exr_sets --frames 1011-1012 > exr.log 2>&1
check "current EXRs are kept" grep -q "0 images made, 4 current outputs kept" exr.log
rm full/images/tiny.1011.exr
"$kerf" render tiny.yaml --out full $exr_sets --frames 1011-1012 > exr.log 2>&1
check "a missing EXR is rendered again, alone" grep -q "1 images made, 1 current outputs kept" exr.log
"$kerf" run tiny.yaml --out pts --quality preview --frames 1001-1002 --set output.points=true --set output.images=false > pts.log 2>&1
check "output.points writes OpenVDB points per frame" test "$(ls pts/points/*.vdb 2>/dev/null | wc -l)" -eq 2
check "output.images=false renders nothing" test ! -e pts/images
"$kerf" turntable tiny.yaml --out full --frame 1006 --frames 4 --quality preview > tt.log 2>&1
check "kerf turntable writes its views" test "$(ls full/turntable/*.png 2>/dev/null | wc -l)" -eq 4
check "turntable views are numbered like shot frames, 1001-1004" \
    test "$(cd full/turntable && ls *.png | tr '\n' ' ')" = "tiny.f1006.1001.png tiny.f1006.1002.png tiny.f1006.1003.png tiny.f1006.1004.png "
"$kerf" turntable tiny.yaml --out full --frame 999 --frames 4 > tt.log 2>&1
check "a turntable frame outside the shot is a usage error" test $? -eq 2
check "no temporaries left" test -z "$(find full -name '*.tmp-*')"

# --- the cache: same inputs are not simulated again ----------------------------
cp full/checkpoints/tiny.1012.kfc last.kfc
"$kerf" run tiny.yaml --out full > again.log 2>&1
check "a current cache exits 0" test $? -eq 0
check "a current cache is reused and says so" grep -q "nothing to simulate" again.log
check "a current cache is not rewritten" cmp -s last.kfc full/checkpoints/tiny.1012.kfc
# the executable's bytes are a cache input: the same kerf reuses a copy of the
# cache, the same program with one byte more (a rebuilt kerf) simulates again
for who in same rebuilt; do
    rm -rf "exe_$who" && cp -r full "exe_$who" && rm -f "exe_$who/.kerf.lock"
done
cp "$kerf" kerf_rebuilt && printf 'x' >> kerf_rebuilt && chmod +x kerf_rebuilt
"$kerf" run tiny.yaml --out exe_same --frames 1001-1003 --set output.surface=false --set output.images=false > exe_same.log 2>&1
./kerf_rebuilt run tiny.yaml --out exe_rebuilt --frames 1001-1003 --set output.surface=false --set output.images=false \
    > exe_rebuilt.log 2>&1
check "the same executable reuses the cache" grep -q "nothing to simulate" exe_same.log
check "an executable with other bytes simulates again" \
    bash -c "! grep -q 'nothing to simulate' exe_rebuilt.log && grep -qE '^frame 1003: [0-9]+ particles' exe_rebuilt.log"
rm full/particles/tiny.1007.ply
"$kerf" run tiny.yaml --out full > again.log 2>&1
check "a missing particle frame comes back from its checkpoint" test -e full/particles/tiny.1007.ply
# the shot file's own values changed (not a --set experiment): the cache simulates again
sed 's/cfl: 0.4/cfl: 0.3/' tiny.yaml > tiny_cfl.yaml
"$kerf" run tiny_cfl.yaml --out full > changed.log 2>&1
check "a changed sim value in the shot file simulates again" grep -q "^frame 1012" changed.log
# a mesh's bytes are an input: the same geometry with an edited file re-simulates
mkdir -p m && cp "$tests"/meshes/cube.obj m/ && cp "$tests"/cli/mesh.yaml m/
(cd m && "$kerf" run mesh.yaml --out o --quiet && "$kerf" run mesh.yaml --out o > same.log 2>&1 &&
    echo "# edited" >> cube.obj && "$kerf" run mesh.yaml --out o > edited.log 2>&1)
check "an unchanged mesh reuses the cache" grep -q "nothing to simulate" m/same.log
check "an edited mesh file simulates again" bash -c "! grep -q 'nothing to simulate' m/edited.log && grep -q 'frame 1003' m/edited.log"
"$kerf" run tiny.yaml --out full --set sim.cfl=0.4 --force > forced.log 2>&1
check "--force simulates a current cache" grep -q "^frame 1012" forced.log

# --- killed and resumed -------------------------------------------------------
"$kerf" run tiny.yaml --out killed > kill.log 2>&1 &
pid=$!
for _ in $(seq 1 600); do # wait for frame 1003's checkpoint, then kill hard
    [ -e killed/checkpoints/tiny.1003.kfc ] && break
    sleep 0.05
done
kill -9 $pid 2> /dev/null
wait $pid 2> /dev/null
check "the killed run left frame 1003" test -e killed/checkpoints/tiny.1003.kfc
check "the kill came before the end" test ! -e killed/checkpoints/tiny.1012.kfc
"$kerf" run tiny.yaml --out killed --resume > resume.log 2>&1
check "resume exits 0" test $? -eq 0
check "resume says where it continues" grep -q "resuming after frame" resume.log
check "resumed final frame equals the uninterrupted one, bit for bit" \
    cmp -s full/particles/tiny.1012.ply killed/particles/tiny.1012.ply
check "resumed final checkpoint equals the uninterrupted one" \
    cmp -s full/checkpoints/tiny.1012.kfc killed/checkpoints/tiny.1012.kfc

# --- a resume refuses checkpoints made from other settings --------------------
"$kerf" run tiny_cfl.yaml --out full --resume > other.log 2>&1
check "changed settings are not resumed from" grep -q "different shot settings" other.log

# --- a version holds one experiment: another --set value does not replace it -----
"$kerf" run tiny.yaml --frames 1001-1002 --set materials.jelly.E=1e3 --set output.images=false --quiet
cp tiny/v001/checkpoints/tiny.1002.kfc first.kfc
"$kerf" run tiny.yaml --frames 1001-1002 --set materials.jelly.E=4e3 --set output.images=false > second.log 2>&1
rc=$?
check "a second --set run into the same version exits 2 (got $rc)" test $rc -eq 2
check "... names what the version holds and the next free version" \
    bash -c "grep -qF 'kerf: tiny/v001/ holds tiny simulated with other values (--set materials.jelly.E=1e3); this run (--set materials.jelly.E=4e3) would replace it, so nothing was written' second.log &&
             grep -qF 'kerf: keep both: --set version=2 (the next free version); replace it: --force' second.log"
check "... and the first run's frames are untouched" cmp -s first.kfc tiny/v001/checkpoints/tiny.1002.kfc
"$kerf" run tiny.yaml --frames 1001-1002 --set materials.jelly.E=4e3 --set output.images=false --set version=2 --quiet
check "--set version=2 keeps both" bash -c "test -e tiny/v002/checkpoints/tiny.1002.kfc && cmp -s first.kfc tiny/v001/checkpoints/tiny.1002.kfc"
"$kerf" run tiny.yaml --frames 1001-1002 --set materials.jelly.E=1e3 --set output.images=false --set render.width=64 \
    > same.log 2>&1
check "the same experiment again (a render value aside) reuses its version" grep -q "nothing to simulate" same.log
rm -rf tiny

echo "$fails failed"
exit $((fails > 0))
