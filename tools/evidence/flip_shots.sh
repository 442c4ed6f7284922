#!/usr/bin/env bash
# flip_shots.sh — every shipped shot under the flip transfer: its first two
# frames simulated at preview quality and the shot's own frame rate with
# --set sim.transfer=flip (surfaces and images off), against the same two
# frames with the default apic. Prints one table row per shot and transfer:
# exit code, substeps, retries and warnings (summed over the frames' log
# lines), and wall seconds.
#   usage: flip_shots.sh <kerf binary> <repository root> [ratio] [shot names...]
set -u
kerf=$1
root=$2
ratio=${3:-0.95}
shift $(($# < 3 ? $# : 3))
work=$(mktemp -d /tmp/kerf_flip_shots.XXXXXX)
trap 'rm -rf "$work"' EXIT
shots=("$@")
if [ ${#shots[@]} -eq 0 ]; then
    for f in "$root"/shots/*.yaml; do shots+=("$(basename "$f" .yaml)"); done
fi
echo "| shot | transfer | exit | substeps | retries | warnings | wall s |"
echo "|---|---|---|---|---|---|---|"
fails=0
for name in "${shots[@]}"; do
    shot="$root/shots/$name.yaml"
    start=$("$kerf" check "$shot" 2>/dev/null | sed -nE 's/.*frames ([0-9]+)-.*/\1/p')
    [ -n "$start" ] || start=1001
    next=$((start + 2))
    for transfer in apic flip; do
        out="$work/$name.$transfer"
        t0=$(date +%s.%N)
        "$kerf" run "$shot" --quality preview --frames "$start-$next" --out "$out" --set sim.transfer=$transfer \
            --set sim.flip_ratio="$ratio" --set output.surface=false --set output.images=false > "$out.log" 2>&1
        rc=$?
        t1=$(date +%s.%N)
        substeps=$(grep -oE '[0-9]+ substeps' "$out.log" | awk '{s += $1} END {print s + 0}')
        retries=$(grep -oE '[0-9]+ retries' "$out.log" | awk '{s += $1} END {print s + 0}')
        warnings=$(grep -oE '[0-9]+ warnings' "$out.log" | awk '{s += $1} END {print s + 0}')
        printf '| %s | %s | %d | %s | %s | %s | %.1f |\n' "$name" "$transfer" "$rc" "$substeps" "$retries" "$warnings" \
            "$(echo "$t1 - $t0" | bc)"
        if [ $rc -ne 0 ]; then
            fails=$((fails + 1))
            tail -3 "$out.log" | sed 's/^/      /' >&2
        fi
    done
done
echo "$fails runs failed"
exit $((fails > 0))
