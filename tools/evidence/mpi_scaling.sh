#!/usr/bin/env bash
# mpi_scaling.sh — strong scaling at 2 ranks, in one command, for a quiet
# machine with at least 2 free cores (on a shared one the times measure the
# other load). The 8M cube (kerf_bench's cube as a shot: 100³ cells of 8
# particles in a 125³ grid, dx 0.008, walls, no gravity, 1 ms frames) and a
# moving scene (the same cube thrown into a corner under gravity, so
# particles migrate between ranks every substep), each run as
#   A: 1 rank x 1 thread, B: 1 rank x 2 threads, C: 2 ranks x 1 thread,
# interleaved A B C A B C ..., outputs off. Prints one table: the median
# over runs of the mean frame time of frames 1003..last (frame 1002 holds
# the first sort), and the efficiencies C against B (the target: 85% or
# more) and against A (T_A / (2 T_C)).
#   usage: tools/evidence/mpi_scaling.sh [kerf binary] [runs per config] [dx]
# dx 0.008 is the 8M cube (about 1.3 GB per run); dx 0.016 (1M) checks the
# script in minutes. Open MPI's mpirun (as root it is allowed).
set -eu
kerf=$(realpath "${1:-build/kerf}")
runs=${2:-3}
dx=${3:-0.008}
last=1006
work=$(mktemp -d /tmp/kerf_mpi_scaling.XXXXXX)
trap 'rm -rf "$work"' EXIT
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=PASSIVE
cd "$work"
shot() { # shot <name> <gravity> <velocity>
    cat > $1.yaml <<SHOT
shot: $1
frames: {start: 1001, end: $last, fps: 1000}
sim: {dx: $dx, ppc: 8, cfl: 0.4, gravity: $2}
domain: {min: [0, 0, 0], max: [1, 1, 1], walls: separate}
materials:
  jelly: {preset: jello}
objects:
  - {name: cube, shape: box, center: [0.5, 0.5, 0.5], size: 0.8, material: jelly, velocity: $3}
output: {dir: "{shot}", particles: false, checkpoints: false, surface: false, images: false}
SHOT
}
shot cube "[0, 0, 0]" "[0, 0, 0]"
shot moving "[0, -9.81, 0]" "[2, -1, 0]"
# the mean frame time (ms) of frames 1003..last in a run's log
frame_ms() {
    awk '/^frame [0-9]+: [0-9]+ particles/ && $2 + 0 >= 1003 {
            for (i = 2; i < NF; i++) if ($i == "ms" && $(i + 1) == "(sort") { s += $(i - 1); n++ } }
         END { printf "%.0f", n ? s / n : -1 }' "$1"
}
median() { tr ' ' '\n' | grep -v '^$' | sort -n | awk '{ v[NR] = $1 } END { print (NR % 2) ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
echo "| scene | particles | 1 rank x 1 thread, ms/frame | 1 rank x 2 threads | 2 ranks x 1 thread | C vs B: T_B / T_C | C vs A: T_A / (2 T_C) |"
echo "|---|---|---|---|---|---|---|"
for s in cube moving; do
    a="" b="" c=""
    for r in $(seq "$runs"); do
        OMP_NUM_THREADS=1 "$kerf" run $s.yaml --threads 1 --force > a.log 2>&1
        a="$a $(frame_ms a.log)"
        OMP_NUM_THREADS=2 "$kerf" run $s.yaml --threads 2 --force > b.log 2>&1
        b="$b $(frame_ms b.log)"
        OMP_NUM_THREADS=1 mpirun -np 2 "$kerf" run $s.yaml --threads 1 --force > c.log 2>&1
        c="$c $(frame_ms c.log)"
        echo "run $r of $s: A$a / B$b / C$c ms" >&2
    done
    n=$(sed -n "s/^kerf .*: $s v[0-9]*, \([0-9]*\) particles.*/\1/p" a.log)
    ta=$(echo $a | median) tb=$(echo $b | median) tc=$(echo $c | median)
    echo "| $s | $n | $ta | $tb | $tc | $(awk -v b=$tb -v c=$tc 'BEGIN { printf "%.0f%%", 100 * b / c }') | $(awk -v a=$ta -v c=$tc 'BEGIN { printf "%.0f%%", 100 * a / (2 * c) }') |"
done
grep -E "^frame $last: 2 ranks" c.log >&2 || true
