#!/usr/bin/env bash
# test_mpi_shot.sh — one small shot of tests/mpi/ over MPI ranks:
#   blade: a thin blade cuts a block (CPIC); ranks cut the block in slabs
#          along x, so every rank boundary crosses the blade, and the
#          halves become pieces in contact (sim.contact);
#   slide: a dynamic box skids across a slab from rank to rank (two-way
#          rigid coupling);
#   dam:   a dam break, water surging along x through every rank's slab;
#   contact: two jelly blocks thrown at each other meet where the ranks are
#          cut and bounce apart (contact between objects: per-object
#          velocity fields on the nodes they share);
#   apart: a blade cuts the left of two blocks far from where 2 ranks are
#          cut: labelling its pieces sends a few records, not the blocks.
# On 2, 3 and 4 ranks (oversubscribed) the shot writes the same checkpoints
# and particle files, bit for bit, as a plain one-rank run, and the same
# rigid body and crossing lines in the frame log; runs cut short on one
# rank count resume on another and end the same.
#   usage: test_mpi_shot.sh <kerf binary> <tests dir> blade|slide|dam|contact|apart
# The launcher and the helpers: tests/mpi/common.sh (exit 77 without one).
set -u
kerf=$1
tests=$2
shot=$3
work_prefix=kerf_mpi_shot
. "$tests/mpi/common.sh"
# the shots name their meshes relative to tests/mpi/
mkdir -p "$work/tests/mpi"
cp "$tests/mpi/$shot.yaml" "$work/tests/mpi/"
ln -s "$tests/../assets" "$work/assets"
cd "$work/tests/mpi"
first=1001
last=$(sed -n 's/^frames: {start: [0-9]*, end: \([0-9]*\).*/\1/p' $shot.yaml)
same() { # same <dir a> <dir b>: every checkpoint and particle file equal
    local a=$1 b=$2 f
    for f in "$a"/checkpoints/*.kfc "$a"/particles/*.ply; do cmp -s "$f" "$b/${f#"$a"/}" || return 1; done
    test "$(ls "$a"/checkpoints | wc -l)" -eq $((last - first + 1))
}
log_lines() { grep -hE '^  rigid |crossings:' "$1"; }
export -f log_lines

"$kerf" run $shot.yaml --out ref > ref.log 2>&1
check "$shot: plain run exits 0" test $? -eq 0
for n in 2 3 4; do
    mpi "$n" run $shot.yaml --out np$n > np$n.log 2>&1
    check "$shot on $n ranks: exit 0" test $? -eq 0
    check "$shot on $n ranks: checkpoints and particles equal the one-rank run's, bit for bit" same ref np$n
    [ $shot = dam ] || [ $shot = contact ] ||
        check "$shot on $n ranks: the rigid body and crossing lines of the frame log are the one-rank run's" \
            bash -c "diff <(log_lines np$n.log) <(log_lines ref.log) > /dev/null && log_lines ref.log | grep -q crossings"
done
if [ $shot = slide ]; then
    check "slide: the box crosses rank boundaries (x from 0.2 m past 0.45 m)" \
        bash -c "grep 'rigid box' ref.log | tail -1 | grep -qE 'at \[0\.(4[5-9]|[5-9])'"
elif [ $shot = blade ]; then
    check "blade: the blade goes through the block (its edge under 1 cm)" \
        bash -c "grep 'rigid blade' ref.log | tail -1 | grep -qE 'at \[[0-9.]+, 0\.1[45]'"
    check "blade: on 2 ranks a part the blade cut off became a piece" \
        grep -qE '^frame [0-9]+: pieces: .* [1-9][0-9]* substeps made pieces' np2.log
elif [ $shot = apart ]; then
    # Gathering every rank's particle classes to every other rank (a node,
    # a field, a colour, a count and a first particle: 32 bytes or more a
    # class) would send the blocks; what links across the cut, plus a
    # record per part, must stay under half a byte per class labelled on 2
    # ranks, in every frame: under 1/64 of such a table
    check "apart: on 2 ranks a part the blade cut off became a piece" \
        grep -qE '^frame [0-9]+: pieces: .* [1-9][0-9]* substeps made pieces' np2.log
    check "apart: on 2 ranks the pieces' bytes per substep are under half a byte per class labelled" \
        bash -c "grep -E '^frame [0-9]+: pieces:' np2.log | awk '{n++; if (!(\$4 < 0.5 * \$11)) bad++} END {exit !(n >= 4 && !bad)}'"
elif [ $shot = contact ]; then
    check "contact: particles cross the cut between the 2 ranks as the blocks meet" \
        bash -c "grep -E '^frame 100[3-6]: 2 ranks' np2.log | grep -qE ' [1-9][0-9]* particles migrated'"
else
    check "dam: particles migrate between ranks as the water surges" \
        bash -c "grep -E '^frame $last: 4 ranks' np4.log | grep -qE ' [1-9][0-9]* particles migrated'"
    # a fixed step too long for the compressed water: the frame log's count of
    # particles evaluated at the limited stiffness is the sum over the ranks
    fixed=(--set sim.dt_fixed=0.0015)
    "$kerf" run $shot.yaml --out fx1 "${fixed[@]}" 2> fx1.log
    mpi 3 run $shot.yaml --out fx3 "${fixed[@]}" 2> fx3.log
    check "dam, fixed step: the stiffness-limited counts on 3 ranks are the one-rank run's, and not none" \
        bash -c "diff <(grep stiffness-limited fx1.log) <(grep stiffness-limited fx3.log) > /dev/null && grep -qE ' [1-9][0-9]* particles stiffness-limited' fx1.log"
fi

# the objects' (or pieces') own velocity fields change the result: contact is in play
if [ $shot = contact ] || [ $shot = blade ]; then
    "$kerf" run $shot.yaml --out off --set sim.contact=off --quiet
    check "$shot: contact between objects matters (with sim.contact: off the last frame differs)" \
        bash -c "! cmp -s ref/checkpoints/$shot.$last.kfc off/checkpoints/$shot.$last.kfc"
fi

# --- resume across rank counts ----------------------------------------------------
mid=$((first + 2))
mpi 4 run $shot.yaml --out r42 --frames $first-$mid --quiet
mpi 2 run $shot.yaml --out r42 --resume > r42.log 2>&1
check "$shot: 4 ranks cut short, resumed on 2: equal to the one-rank run" \
    bash -c "grep -q 'resuming after frame $mid' r42.log && cmp -s ref/checkpoints/$shot.$last.kfc r42/checkpoints/$shot.$last.kfc"
"$kerf" run $shot.yaml --out r13 --frames $first-$mid --quiet
mpi 3 run $shot.yaml --out r13 --resume > r13.log 2>&1
check "$shot: 1 rank cut short, resumed on 3: equal to the one-rank run" \
    bash -c "grep -q 'resuming after frame $mid' r13.log && cmp -s ref/checkpoints/$shot.$last.kfc r13/checkpoints/$shot.$last.kfc"

echo "$fails failure(s)"
test $fails -eq 0
