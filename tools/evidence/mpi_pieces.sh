#!/usr/bin/env bash
# mpi_pieces.sh — what labelling the pieces a thin blade cuts sends between
# ranks, per substep, against the classes it labels. Runs tests/mpi's blade
# shot (the ranks' cuts cross the blade and the block) and apart shot (a
# blade cuts a block far from the 2-rank cut) at the given dx on 2, 3 and 4
# ranks (oversubscribed: counts and bytes, not times) and prints a
# markdown table from the rank-0 frame log: the mean over frames 1002..end
# of the pieces' bytes per substep, all ranks' sends summed; the classes
# labelled per substep; what a table of every rank's classes gathered on
# every rank sends (40-byte entries, each to the N - 1 other ranks); and
# the P2G halo's bytes per substep for scale.
#   usage: tools/evidence/mpi_pieces.sh [kerf binary] [dx, default the shots' 0.025] [last frame]
set -eu
kerf=$(realpath "${1:-build/kerf}")
dx=${2:-0.025}
last=${3:-1005}
here=$(cd "$(dirname "$0")/../.." && pwd)
work=$(mktemp -d /tmp/kerf_mpi_pieces.XXXXXX)
trap 'rm -rf "$work"' EXIT
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE
mkdir -p "$work/tests/mpi"
cp "$here"/tests/mpi/{blade,apart}.yaml "$work/tests/mpi/"
ln -s "$here/assets" "$work/assets"
cd "$work/tests/mpi"
echo "| shot | dx | ranks | particles | classes / substep | gathered table B / substep | pieces B / substep | ratio | halo B / substep |"
echo "|---|---|---|---|---|---|---|---|---|"
for shot in blade apart; do
    for n in 2 3 4; do
        mpirun -np $n "$kerf" run $shot.yaml --out o --set sim.dx=$dx --frames 1001-$last --set output.particles=false \
            > log 2>&1
        awk -v shot=$shot -v dx=$dx -v n=$n '
            /^frame [0-9]+: [0-9]+ particles,/ { np = $3 }
            /^frame [0-9]+: [0-9]+ ranks:/ { if (match($0, /\([0-9]+ per substep\)/)) halo += substr($0, RSTART + 1, RLENGTH - 14) }
            /^frame [0-9]+: pieces:/ { bytes += $4; cls += $11; k++ }
            END { if (!k) exit 1
                  t = 40 * (n - 1) * cls / k
                  printf "| %s | %s | %d | %d | %.0f | %.0f | %.0f | %.4f | %.0f |\n", shot, dx, n, np, cls / k, t, bytes / k,
                         bytes / k / t, halo / k }' log
        rm -rf o
    done
done
