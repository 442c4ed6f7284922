#!/usr/bin/env bash
# test_safety.sh — "safety and integrity": every refusal and every
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

# --- 3. budget guards: estimated before seeding, refused with the estimate ------------
if run_case budget; then
    # each of these hung with no output (within their documented bounds); the hours are
    # particles x substeps x 2 frames / (2e6 per core x the cores kerf sees) / 3600
    sed 's|^  jelly: {preset: jello}|  jelly: {preset: jello, E: 1e30}|' small.yaml > stiff.yaml
    sed 's|cfl: 0.4}|cfl: 1e-9}|' small.yaml > tiny_cfl.yaml
    sed 's|cfl: 0.4}|cfl: 0.4, dt_fixed: 1e-12}|' small.yaml > fixed.yaml
    sed 's|dx: 0.1,|dx: 0.002,|; s|size: 0.3,|size: 0.9,|' small.yaml > fine.yaml
    for cmd in check info run; do
        refused $cmd stiff.yaml \
            "stiff.yaml:6:29: error: about 3.82e+13 substeps per frame (dt 1.09e-15 s: material jelly's wave speed 3.67e+13 m/s at sim.cfl 0.4), over the budget of 1000000: 3 frames of about 216 particles would take about 1.1e+06 hours on $(nproc) cores (--force to run anyway)" \
            "    6 |   jelly: {preset: jello, E: 1e30}"
        refused $cmd tiny_cfl.yaml \
            "tiny_cfl.yaml:3:29: error: about 2.16G substeps per frame (dt 1.93e-11 s from sim.cfl 1e-09), over the budget of 1000000: 3 frames of about 216 particles would take about 65 hours on $(nproc) cores (--force to run anyway)" \
            "    3 | sim: {dx: 0.1, ppc: 8, cfl: 1e-9}"
        refused $cmd fixed.yaml \
            "fixed.yaml:3:44: error: about 41.7G substeps per frame (sim.dt_fixed 1e-12 s), over the budget of 1000000: 3 frames of about 216 particles would take about 1.2e+03 hours on $(nproc) cores (--force to run anyway)" \
            "    3 | sim: {dx: 0.1, ppc: 8, cfl: 0.4, dt_fixed: 1e-12}"
        "$kerf" $cmd fine.yaml > refused.out 2> refused.err; rc=$?
        check "fine.yaml ($cmd): exit 2 (got $rc)" test $rc -eq 2
        check "fine.yaml ($cmd): the estimate at sim.dx" grep -qxE \
            "fine.yaml:3:11: error: sim.dx 0.002 m gives about 729M particles needing about 130.4 GB, more than this machine's [0-9.]+ GB \(a larger dx, or --quality preview: 8x fewer; --force to try anyway\)" refused.err
    done
    # --force goes past the guard: a fixed step of 1 ms is fine, 1e-12 s is forced
    "$kerf" info fixed.yaml --force > forced.txt 2>&1; rc=$?
    check "kerf info --force on the over-budget shot exits 0 (got $rc)" test $rc -eq 0
    # kerf info honours sim.dt_fixed (it showed the CFL step)
    check "kerf info shows sim.dt_fixed's substeps" has forced.txt "substeps  41666666667 per frame (sim.dt_fixed 1e-12 s)"
    check "kerf info shows the estimate" has forced.txt \
        "estimate  before seeding: about 216 particles, 0 MB, 41666666667 substeps per frame, 1.2e+03 hours for frames 1001-1003 on $(nproc) cores"
    sed 's|cfl: 0.4}|cfl: 0.4, dt_fixed: 1e-3}|' small.yaml > fixed_ok.yaml
    "$kerf" info fixed_ok.yaml > fixed_ok.txt 2>&1
    check "a normal fixed step passes and is what info shows" has fixed_ok.txt "substeps  42 per frame (sim.dt_fixed 0.001 s)"
fi

# --- 4. partial re-runs: later frames from other inputs do not stay -----------------
if run_case partial; then
    pv=(--quality preview)
    "$kerf" run tiny.yaml --out part "${pv[@]}" --quiet
    cp part/checkpoints/tiny.1008.kfc old1008.kfc
    # the same inputs over part of the range: nothing simulated, nothing removed
    "$kerf" run tiny.yaml --out part "${pv[@]}" --frames 1001-1004 > /dev/null 2> same.err
    check "a partial re-run with the same inputs removes nothing" bash -c "! grep -q removed same.err && test \$(ls part/checkpoints | wc -l) -eq 12"
    # --force with the same inputs re-simulates 1001-1004; 1005+ still follow from them
    "$kerf" run tiny.yaml --out part "${pv[@]}" --frames 1001-1004 --force > /dev/null 2> forced.err
    check "so does a forced one" bash -c "! grep -q removed forced.err && cmp -s old1008.kfc part/checkpoints/tiny.1008.kfc"
    # changed physics over 1001-1004: 1005-1012 were made from the old settings
    # (in the shot file: another --set value would be another experiment, refused in this version)
    sed 's/jelly: {preset: jello}/jelly: {preset: jello, E: 3e4}/' tiny.yaml > tiny_e.yaml
    "$kerf" run tiny_e.yaml --out part "${pv[@]}" --frames 1001-1004 > /dev/null 2> changed.err
    check "a partial re-run after a physics change names the frames it removes (8 x checkpoint, particles, surface, image)" has changed.err \
        "kerf: tiny: removed frames 1005-1012 (32 files): made from other inputs than this run's, they would not follow from frame 1004"
    check "no checkpoint, particles, surface or image of 1005-1012 is left" \
        bash -c "test -z \"\$(find part -name 'tiny.10[01][0-9].*' | grep -vE 'tiny.100[1-4]\.')\""
    check "frames 1001-1004 are there" test "$(ls part/checkpoints part/particles part/surface part/images | grep -c 'tiny.100[1-4]')" -eq 16
    # and a later run of the whole range simulates them again from the new settings
    "$kerf" run tiny_e.yaml --out part "${pv[@]}" > /dev/null 2> whole.err
    check "the whole range after it makes all twelve again" test "$(ls part/checkpoints | wc -l)" -eq 12
fi

# --- 5. one run per output directory --------------------------------------------
# listing: every file under a directory with its checksum (what a refused run must not change)
listing() { (cd "$1" && find . -type f ! -name .kerf.lock | sort | xargs -r md5sum); }
if run_case lock; then
    # the first run: stopped (SIGSTOP) while it holds the directory, so the
    # second one meets it for certain, then killed hard as a crash would
    "$kerf" run tiny.yaml --out lock > first.log 2>&1 &
    first=$!
    for _ in $(seq 1 1000); do [ -s lock/.kerf.lock ] && break; sleep 0.01; done
    kill -STOP $first
    read -r held started_day started_time < lock/.kerf.lock
    check "the lock file names the first run's pid" test "$held" = "$first"
    listing lock > before.txt
    "$kerf" run tiny.yaml --out lock > second.out 2> second.err; rc=$?
    check "a second run on the directory exits 1 (got $rc)" test $rc -eq 1
    check "it names the first run's pid" has second.err \
        "kerf: lock/ is in use by another kerf run (pid $first, started $started_day $started_time); wait for it to end or stop it (kill $first)"
    listing lock > after.txt
    check "the refused run wrote nothing" cmp -s before.txt after.txt
    "$kerf" render tiny.yaml --out lock > render.out 2> render.err; rc=$?
    check "kerf render on it exits 1 too (got $rc)" test $rc -eq 1
    check "kerf render on it names the pid" has render.err \
        "kerf: lock/ is in use by another kerf run (pid $first, started $started_day $started_time); wait for it to end or stop it (kill $first)"
    kill -KILL $first; kill -CONT $first 2> /dev/null; wait $first 2> /dev/null
    # the crash left its pid in the lock file, but no lock: the next run says so and goes on
    "$kerf" run tiny.yaml --out lock --frames 1001-1002 --set output.images=false --set output.surface=false \
        > third.out 2> third.err; rc=$?
    check "the run after the crash exits 0 (got $rc)" test $rc -eq 0
    check "it reports the stale lock and its pid" has third.err \
        "kerf: lock/: the run before (pid $first, started $started_day $started_time) ended without releasing its lock (killed or crashed); taking the lock over"
    check "a run that ends empties the lock file" test ! -s lock/.kerf.lock
    "$kerf" run small.yaml --out lock > fourth.out 2> fourth.err
    check "so the next run finds no stale lock" bash -c "! grep -q 'without releasing' fourth.err"
fi

# --- 6. atomic outputs: a full disk, damaged outputs, leftover temporaries -------
if run_case atomic; then
    "$kerf" run tiny.yaml --out base --frames 1001-1002 --set output.surface=false --set output.images=false --quiet
    # a real full disk: a small tmpfs in a private mount namespace, filled
    # but for 64 KB (less than a surface or an image needs)
    cat > full_disk.sh << 'SCRIPT'
set -u
kerf=$1
mount -t tmpfs -o size=16m tmpfs full || exit 3
cp -a base/. full/
fill() { dd if=/dev/zero of=full/filler bs=64k status=none 2> /dev/null; truncate -s -$1 full/filler; }
fill 64K
"$kerf" surface tiny.yaml --out full --frames 1001-1002 > /dev/null 2> surface_full.err; echo $? > surface_full.rc
ls full/surface > surface_full.ls 2>&1; find full -name '*.tmp-*' > surface_full.tmp
rm full/filler
"$kerf" surface tiny.yaml --out full --frames 1001-1002 > /dev/null 2> surface_room.err; echo $? > surface_room.rc
fill 16K
"$kerf" render tiny.yaml --out full --frames 1001-1002 > /dev/null 2> render_full.err; echo $? > render_full.rc
ls full/images > render_full.ls 2>&1; find full -name '*.tmp-*' > render_full.tmp
SCRIPT
    mkdir -p full
    if unshare -rm true 2> /dev/null; then
        unshare -rm bash full_disk.sh "$kerf"
        check "surfacing on a full disk exits 1 (got $(cat surface_full.rc))" test "$(cat surface_full.rc)" = 1
        check "it says no space left" has surface_full.err \
            "kerf: frame 1001: surface: vdb: write: cannot write 'full/surface/tiny.1001.vdb': no space left on the device (disk full)"
        check "no surface left under its final name" test ! -s surface_full.ls
        check "no temporary left" test ! -s surface_full.tmp
        check "with room again, surfacing succeeds" test "$(cat surface_room.rc)" = 0
        check "rendering on a full disk exits 1 (got $(cat render_full.rc))" test "$(cat render_full.rc)" = 1
        check "it says no space left" has render_full.err \
            "kerf: frame 1001: render: full/images/tiny.1001.png: no space left on the device (disk full)"
        check "no image left under its final name" test ! -s render_full.ls
        check "no temporary left" test ! -s render_full.tmp
    else
        echo "skip  full disk: this machine gives no user namespace to mount a small tmpfs in"
    fi

    # damaged outputs under their final names are made again, not fatal
    cp -a base dmg
    "$kerf" run tiny.yaml --out dmg --frames 1001-1002 --quiet
    # a surface cut short after its image was made (as a full disk under an older kerf left it): the render reads it
    head -c 5000 dmg/surface/tiny.1002.vdb > cut && cat cut > dmg/surface/tiny.1002.vdb
    # an image cut short, still newer than its surface
    head -c 3000 dmg/images/tiny.1001.png > cut && cat cut > dmg/images/tiny.1001.png
    "$kerf" render tiny.yaml --out dmg --frames 1001-1002 > /dev/null 2> dmg.err; rc=$?
    check "a render over damaged outputs exits 0 (got $rc)" test $rc -eq 0
    check "a cut-short image is named and made again" has dmg.err \
        "kerf: frame 1001: dmg/images/tiny.1001.png is damaged (cut short); rendering it again"
    check "a damaged surface is named and made again from its checkpoint" grep -qxE \
        "kerf: frame 1002: dmg/surface/tiny.1002.vdb is damaged \(vdb: .*\); surfacing it again from dmg/checkpoints/tiny.1002.kfc" dmg.err
    check "both images are whole again" bash -c "tail -c 8 dmg/images/tiny.1001.png | grep -q IEND && tail -c 8 dmg/images/tiny.1002.png | grep -q IEND"
    check "the summary counts them" has dmg.err "kerf: tiny: 1 surfaces, 2 images made, 0 current outputs kept; images in dmg/images/"
    # kerf surface alone finds a damaged surface that is newer than its checkpoint
    cat cut > dmg/surface/tiny.1001.vdb
    "$kerf" surface tiny.yaml --out dmg --frames 1001-1002 > /dev/null 2> dmgs.err; rc=$?
    check "kerf surface over a damaged surface exits 0 (got $rc)" test $rc -eq 0
    check "it names the damaged surface and makes it again" grep -qxE \
        "kerf: frame 1001: dmg/surface/tiny.1001.vdb is damaged \(vdb: .*\); surfacing it again from dmg/checkpoints/tiny.1001.kfc" dmgs.err
    check "and keeps the good one" has dmgs.err "kerf: tiny: 1 surfaces, 0 images made, 1 current outputs kept; images in dmg/images/"

    # a particle file cut short comes back from its checkpoint, byte for byte
    cp dmg/particles/tiny.1002.ply good1002.ply
    head -c 2000 good1002.ply > dmg/particles/tiny.1002.ply
    "$kerf" run tiny.yaml --out dmg --frames 1001-1002 > /dev/null 2> dmgp.err
    check "a cut-short PLY is named and written again" has dmgp.err \
        "kerf: frame 1002: dmg/particles/tiny.1002.ply is damaged (cut short); writing it again from dmg/checkpoints/tiny.1002.kfc"
    check "without simulating" has dmgp.err \
        "kerf: tiny: frames 1001-1002 are cached from the same inputs; nothing to simulate (--force to simulate anyway)"
    check "byte for byte the original" cmp -s good1002.ply dmg/particles/tiny.1002.ply

    # a killed write's temporary (what kill -9 between open and rename leaves) is swept by the next run
    cp base/checkpoints/tiny.1002.kfc base/checkpoints/tiny.1002.kfc.tmp-4242
    "$kerf" run tiny.yaml --out base --frames 1001-1002 --resume --set output.surface=false --set output.images=false \
        > /dev/null 2> sweep.err
    check "--resume removes the stale temporary and says so" has sweep.err \
        "kerf: base/: removed 1 temporary file left by an interrupted write (base/checkpoints/tiny.1002.kfc.tmp-4242)"
    check "it is gone" test ! -e base/checkpoints/tiny.1002.kfc.tmp-4242
fi

# --- 7. geometry mistakes ------------------------------------------------------------
if run_case geometry; then
    sed 's|center: \[0.5, 0.5, 0.5\]|center: [3.5, 0.5, 0.5]|' small.yaml > outside.yaml
    for cmd in check run; do
        refused $cmd outside.yaml \
            "outside.yaml:8:5: error: object 'cube' lies entirely outside the domain [0, 0, 0]-[1, 1, 1]: it spans [3.35, 0.35, 0.35]-[3.65, 0.65, 0.65]" \
            "    8 |   - {name: cube, shape: box, center: [3.5, 0.5, 0.5], size: 0.3, material: jelly}"
    done
    # half outside is allowed, and counted
    sed 's|center: \[0.5, 0.5, 0.5\]|center: [1.0, 0.5, 0.5]|' small.yaml > partly.yaml
    "$kerf" check partly.yaml > partly.out 2> partly.err; rc=$?
    check "an object half outside the domain passes check (got $rc)" test $rc -eq 0
    check "with a warning counting its particles outside" has partly.err \
        "partly.yaml:8:5: warning: object 'cube': 108 of its 216 particles start outside the domain [0, 0, 0]-[1, 1, 1]"
    # a static solid rigid with an open mesh (a dynamic one was already refused)
    cp small.yaml open_static.yaml
    printf '%s\n' 'rigids:' \
        '  - {name: cup, shape: mesh, mesh: meshes/cube_open.obj, scale: 0.2, center: [0.5, 0.2, 0.5]}' >> open_static.yaml
    refused check open_static.yaml \
        "open_static.yaml:11:36: error: rigid cup: a static solid must be a closed mesh (or make it thin: true): meshes/cube_open.obj: not closed: 4 boundary edges" \
        "   11 |   - {name: cup, shape: mesh, mesh: meshes/cube_open.obj, scale: 0.2, center: [0.5, 0.2, 0.5]}"
    # the same mesh as a thin shell is fine
    sed 's|center: \[0.5, 0.2, 0.5\]}|center: [0.5, 0.2, 0.5], thin: true}|' open_static.yaml > open_thin.yaml
    "$kerf" check open_thin.yaml > /dev/null 2>&1
    check "an open static mesh that is thin passes check" test $? -eq 0
fi

# --- 8. true messages ---------------------------------------------------------------
if run_case messages; then
    # a NUL byte in the YAML said "frames is missing"
    { printf 'shot: nul\nframes: {start: 1001, end: 1003}\nsim: {dx: 0.1'; printf '\0'; printf '}\n'; } > nul.yaml
    for cmd in check run; do
        refused $cmd nul.yaml \
            "nul.yaml:3:14: error: a NUL byte (byte 57 of 59): a shot file is text; is this file damaged or not a shot?" \
            "    3 | sim: {dx: 0.1" --out refused_out
    done
    # a mesh path that is a directory said "not found"
    mkdir -p meshes/folder.obj
    sed 's|^  - {name: cube, .*|  - {name: cube, shape: mesh, mesh: meshes/folder.obj, material: jelly}|' small.yaml > dir_mesh.yaml
    refused check dir_mesh.yaml \
        "dir_mesh.yaml:8:37: error: objects[0]: mesh path 'meshes/folder.obj' is a directory, not a mesh file (meshes/folder.obj)" \
        "    8 |   - {name: cube, shape: mesh, mesh: meshes/folder.obj, material: jelly}"

    # a damaged last checkpoint said "frames are cached", then simulated everything again;
    # its damaged version field said "written by a single-precision build, this is single precision"
    quick=(--set output.surface=false --set output.images=false)
    "$kerf" run tiny.yaml --out dmgck --frames 1001-1004 "${quick[@]}" --quiet
    cp dmgck/checkpoints/tiny.1004.kfc good1004.kfc
    printf 'Z' | dd of=dmgck/checkpoints/tiny.1004.kfc bs=1 seek=8 conv=notrunc status=none # the version field
    "$kerf" run tiny.yaml --out dmgck --frames 1001-1004 "${quick[@]}" > /dev/null 2> dmgck.err; rc=$?
    check "a run over a damaged last checkpoint exits 0 (got $rc)" test $rc -eq 0
    check "it calls the damage damage" has dmgck.err \
        "kerf: cache: dmgck/checkpoints/tiny.1004.kfc: checkpoint checksum mismatch (file damaged)"
    check "it keeps the good frames" has dmgck.err \
        "kerf: tiny: frames 1001-1003 are cached from the same inputs; simulating again after frame 1003"
    check "and simulates only the damaged one" bash -c "grep -c '^frame 100[0-9]: [0-9]* particles' dmgck.err | grep -qx 1"
    check "the summary says which" grep -qxE \
        "kerf: tiny: simulated frame 1004 \(resumed after frame 1003\) in dmgck/ \([0-9.]+ s\)" dmgck.err
    check "the remade checkpoint is the original, bit for bit" cmp -s good1004.kfc dmgck/checkpoints/tiny.1004.kfc

    # a forged particle count (offset 16 = 0x7fffffffffffffff) in the last checkpoint: a heap
    # overflow before, blamed on "different shot settings"; now damage, and the frame before is used
    mkdir forged && cp -a good1004.kfc dmgck/checkpoints/tiny.1004.kfc && cp -a dmgck/. forged/
    printf '\377\377\377\377\377\377\377\177' | dd of=forged/checkpoints/tiny.1004.kfc bs=1 seek=16 conv=notrunc status=none
    size=$(stat -c %s forged/checkpoints/tiny.1004.kfc)
    "$kerf" run tiny.yaml --out forged --frames 1001-1004 --resume "${quick[@]}" > /dev/null 2> forged.err; rc=$?
    check "a resume over a forged particle count exits 0 (got $rc)" test $rc -eq 0
    check "it names the forged count as damage" has forged.err \
        "kerf: resume: skipping forged/checkpoints/tiny.1004.kfc: checkpoint checksum mismatch (file damaged: its header claims 9223372036854775807 particles, which $size bytes do not hold)"
    check "and resumes from the frame before" has forged.err "kerf: resuming after frame 1003"
    check "making frame 1004 again, bit for bit" cmp -s good1004.kfc forged/checkpoints/tiny.1004.kfc

    # after a resume the summary said "simulated frames 1001-1012"
    mkdir resumed && cp -a dmgck/. resumed/ # frames 1001-1004, as a run killed after 1004 leaves them
    "$kerf" run tiny.yaml --out resumed --frames 1001-1006 --resume "${quick[@]}" > /dev/null 2> resumed.err
    check "a resume names where it continues" has resumed.err "kerf: resuming after frame 1004"
    check "its summary names the frames it simulated" grep -qxE \
        "kerf: tiny: simulated frames 1005-1006 \(resumed after frame 1004\) in resumed/ \([0-9.]+ s\)" resumed.err
fi

echo "$fails failed"
exit $((fails > 0))
