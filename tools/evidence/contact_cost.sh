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
            "$kerf" run "$root/shots/$shot.yaml" --quality "$quality" --frames "$frames" --threads 1 --force \
                --out "$work/$shot.$mode" --set sim.contact=$mode --set output.surface=false \
                --set output.images=false 2>&1 |
                awk -v skip="$first" '/^frame [0-9]+: [0-9]+ particles/ {
                    f = $2; sub(":", "", f); if (f == skip) next
                    for (i = 1; i <= NF; i++) { if ($(i+1) == "substeps,") n = $i; if ($(i+1) == "ms") ms = $i }
                    sub(/\(/, "", ms); print ms / n }' >> "$work/$shot.$mode.ms"
        done
    done
done
median() { sort -g "$1" | awk '{a[NR] = $1} END {print (NR % 2 ? a[(NR + 1) / 2] : (a[NR / 2] + a[NR / 2 + 1]) / 2), NR}'; }
printf "%-12s %14s %14s %8s %s\n" shot "off ms/substep" "on ms/substep" "on/off" "samples"
for shot in "${shots[@]}"; do
    read -r off n < <(median "$work/$shot.off.ms")
    read -r on m < <(median "$work/$shot.on.ms")
    printf "%-12s %14.3f %14.3f %8.3f %s\n" "$shot" "$off" "$on" "$(echo "$on / $off" | bc -l)" "$n/$m"
done
