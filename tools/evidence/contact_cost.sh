#!/usr/bin/env bash
# contact_cost.sh — the cost per substep of contact between objects
# (sim.contact), A/B interleaved: each round runs every shot with contact off,
# then on, and the medians over rounds of (frame ms / substeps) are printed.
#   usage: tools/evidence/contact_cost.sh <kerf> [rounds] [frames] [quality] [shot...]
# Defaults: 5 rounds, frames 1001-1003 (the first frame is left out: setup),
# preview quality, 1 thread, goo_blocks bunny_split demo.
set -u
kerf=$1
rounds=${2:-5}
frames=${3:-1001-1003}
quality=${4:-preview}
shift $(($# < 4 ? $# : 4))
shots=("$@")
[ ${#shots[@]} -gt 0 ] || shots=(goo_blocks bunny_split demo)
root=$(cd "$(dirname "$0")/../.." && pwd)
work=$(mktemp -d /tmp/kerf_contact_cost.XXXXXX)
trap 'rm -rf "$work"' EXIT
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE
first=${frames%-*}
for r in $(seq 1 "$rounds"); do
    for shot in "${shots[@]}"; do
        for mode in off on; do
            # wall ms per substep of each frame after the first (the frame log), and the
            # whole run's CPU seconds per substep (less sensitive to other processes)
            /usr/bin/time -f "%U %S" -o "$work/cpu" "$kerf" run "$root/shots/$shot.yaml" --quality "$quality" \
                --frames "$frames" --threads 1 --force --out "$work/$shot.$mode" --set sim.contact=$mode \
                --set output.surface=false --set output.images=false > "$work/log" 2>&1
            awk -v skip="$first" '/^frame [0-9]+: [0-9]+ particles/ {
                f = $2; sub(":", "", f); if (f == skip) next
                for (i = 1; i <= NF; i++) { if ($(i+1) == "substeps,") n = $i; if ($(i+1) == "ms") ms = $i }
                sub(/\(/, "", ms); print ms / n }' "$work/log" >> "$work/$shot.$mode.ms"
            steps=$(awk '/^frame [0-9]+: [0-9]+ particles/ { for (i = 1; i <= NF; i++) if ($(i+1) == "substeps,") n += $i }
                         END { print n }' "$work/log")
            awk -v n="$steps" '{ print 1000 * ($1 + $2) / n }' "$work/cpu" >> "$work/$shot.$mode.cpu"
        done
    done
done
median() { sort -g "$1" | awk '{a[NR] = $1} END {print (NR % 2 ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2), NR}'; }
printf "%-12s %10s %10s %7s %8s | %10s %10s %7s %s\n" shot "wall off" "wall on" "on/off" "frames" "cpu off" \
    "cpu on" "on/off" "runs"
for shot in "${shots[@]}"; do
    read -r off n < <(median "$work/$shot.off.ms")
    read -r on m < <(median "$work/$shot.on.ms")
    read -r coff k < <(median "$work/$shot.off.cpu")
    read -r con l < <(median "$work/$shot.on.cpu")
    printf "%-12s %10.3f %10.3f %7.3f %8s | %10.3f %10.3f %7.3f %s\n" "$shot" "$off" "$on" \
        "$(echo "$on / $off" | bc -l)" "$n/$m" "$coff" "$con" "$(echo "$con / $coff" | bc -l)" "$k/$l"
done
echo "ms per substep: wall from the frame log (frames after the first), cpu = the whole run's user+sys / substeps"
