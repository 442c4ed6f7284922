#!/usr/bin/env bash
# mpi_memory.sh — peak resident size of each MPI rank, on 1, 2 and 4 ranks:
# a jelly cube falling in a closed box (about 1.7M particles at dx 0.01),
# one frame stepped, once with every output off and once writing checkpoints and
# particle files; then a resume from the second frame's checkpoint (written
# once, on one rank) that steps nothing: the peak of reading the checkpoint
# (what a resume adds before it steps). Prints a markdown table (MB, from
# /usr/bin/time's %M).
#   usage: tools/evidence/mpi_memory.sh [kerf binary] [dx] [rows: "off on resume"]
# Open MPI (as root it is allowed; ranks oversubscribed). Each run's files
# and logs go to a temporary directory, removed at the end.
set -eu
kerf=$(realpath "${1:-build/kerf}")
dx=${2:-0.01}
rows=${3:-off on resume}
work=$(mktemp -d /tmp/kerf_mpi_mem.XXXXXX)
trap 'rm -rf "$work"' EXIT
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE
cd "$work"
cat > cube.yaml <<SHOT
shot: cube
frames: {start: 1001, end: 1002, fps: 24}
sim: {dx: $dx, ppc: 8, cfl: 0.4}
domain: {min: [0, 0, 0], max: [1, 1, 1], walls: separate}
materials:
  jelly: {preset: jello}
objects:
  - {name: cube, shape: box, center: [0.5, 0.45, 0.5], size: 0.6, material: jelly, velocity: [0.5, -1, 0]}
output: {dir: "{shot}", particles: false, checkpoints: false, surface: false, images: false}
SHOT
echo "| outputs | ranks | particles | peak RSS per rank, MB (rank 0, 1, ...) | sum over ranks, MB |"
echo "|---|---|---|---|---|"
for outputs in $rows; do
    sets=() run=(--force)
    [ $outputs = on ] && sets=(--set output.checkpoints=true --set output.particles=true)
    if [ $outputs = resume ]; then
        # the second frame's checkpoint, once; each resume reads it, with nothing to step
        sets=(--set output.checkpoints=true) run=(--resume)
        rm -rf cube
        "$kerf" run cube.yaml "${sets[@]}" --force > log.ck 2>&1 || { cat log.ck; exit 1; }
    fi
    for n in 1 2 4; do
        [ $outputs = resume ] || rm -rf cube
        rm -f rss.*
        mpirun -np $n --oversubscribe sh -c \
            '/usr/bin/time -f %M -o rss.$OMPI_COMM_WORLD_RANK "$0" "$@"' "$kerf" run cube.yaml "${sets[@]}" "${run[@]}" \
            > log.$n 2>&1 || { cat log.$n; exit 1; }
        [ $outputs = resume ] && ! grep -q "resuming after frame 1002" log.$n && { cat log.$n; exit 1; }
        np=$(sed -n 's/^kerf .*: cube v[0-9]*, \([0-9]*\) particles.*/\1/p' log.$n)
        row="" sum=0
        for r in $(seq 0 $((n - 1))); do
            kb=$(tail -1 rss.$r)
            row="$row$((kb / 1024)), "
            sum=$((sum + kb / 1024))
        done
        echo "| $outputs | $n | $np | ${row%, } | $sum |"
    done
done
