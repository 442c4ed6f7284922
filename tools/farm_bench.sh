#!/usr/bin/env bash
# farm_bench.sh — submit-to-last-PNG of a shot on a throwaway one-node Slurm
# (tools/slurm_local.sh) against a local `kerf run` of the same shot, with
# the timeline that shows surfacing overlapping the sim, and the scheduling
# delay per task (from a frame's input on disk to its task's first line).
#   usage: tools/farm_bench.sh <kerf> <shot.yaml> <sim threads on the farm> <repeats> [kerf options...]
#   e.g.   tools/farm_bench.sh build/kerf tests/cli/tiny.yaml 1 3 --set frames.end=1024
#   FARM_OPTS="--chunk 4" adds options to the submit only
# Prints markdown (tables) on stdout; runs locally first, then on the farm,
# alternating when repeated, so both see the same load.
set -u
kerf=$(readlink -f "$1")
shot=$(readlink -f "$2")
threads=${3:-1}
repeats=${4:-1}
shift 4
extra=("$@")
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d /tmp/kerf_farm_bench.XXXXXX)
trap '"$here/slurm_local.sh" stop "$work/cluster"; rm -rf "$work"' EXIT
eval "$("$here/slurm_local.sh" start "$work/cluster")" || exit 1
cd "$work"
export OMP_WAIT_POLICY=PASSIVE
unset OMP_NUM_THREADS
now() { date +%s.%N; }
mtime() { stat -c %.9Y "$1"; }
name=$(sed -n 's/^shot: *\([A-Za-z0-9_]*\).*/\1/p' "$shot" | head -1)
[ -n "$name" ] || name=$(basename "$shot" .yaml)

# Slurm's own cost on this cluster: 20 array tasks that do nothing, on an idle node
t0=$(now)
empty=$(sbatch --parsable -o /dev/null --array=0-19 --wrap true)
while squeue -h -o %F | grep -qxF "$empty"; do sleep 0.02; done
empty_s=$(echo "$(now) - $t0" | bc)

for r in $(seq "$repeats"); do
    # local: simulate, then surface and render every frame, all cores
    t0=$(now)
    "$kerf" run "$shot" --quality preview "${extra[@]}" --out "local$r" --quiet || exit 1
    local_s=$(echo "$(now) - $t0" | bc)
    n=$(ls "local$r"/images/*.png | wc -l)
    # farm: submit, then wait for the last PNG
    t0=$(now)
    "$kerf" farm submit "$shot" --quality preview "${extra[@]}" --out "farm$r" --threads "$threads" ${FARM_OPTS:-} --quiet || exit 1
    sub_s=$(echo "$(now) - $t0" | bc)
    ids=$(grep -v '^#' "farm$r/farm/jobs.txt" | cut -f1)
    until [ "$(ls "farm$r"/images/*.png 2> /dev/null | wc -l)" -ge "$n" ]; do
        squeue -h -o %F | grep -qxF "$ids" || { echo "the farm stopped before its last image" >&2; exit 1; }
        sleep 0.05
    done
    last=0
    for f in "farm$r"/images/*.png; do
        m=$(mtime "$f")
        [ "$(echo "$m > $last" | bc)" = 1 ] && last=$m
    done
    farm_s=$(echo "$last - $t0" | bc)
    while squeue -h -o %F | grep -qxF "$ids"; do sleep 0.1; done
    printf '| %d | %d | %.1f | %.2f | %.1f |\n' "$r" "$n" "$local_s" "$sub_s" "$farm_s" >> runs.md

    # the timeline of the last repeat: per frame, seconds after submit
    : > timeline.md
    for c in "farm$r"/checkpoints/*.kfc; do
        b=$(basename "$c" .kfc)
        printf '| %s | %.1f | %.1f | %.1f |\n' "${b##*.}" "$(echo "$(mtime "$c") - $t0" | bc)" \
            "$(echo "$(mtime "farm$r/surface/$b.vdb") - $t0" | bc)" \
            "$(echo "$(mtime "farm$r/images/$b.png") - $t0" | bc)" >> timeline.md
    done
    # scheduling delay: a surface task from its checkpoint on disk to its first line,
    # a render task from its .vdb on disk to its first line; the task's own time
    : > delays.txt
    for step in surface render; do
        for log in "farm$r"/farm/logs/"${name}"_w00_"$step".*_*.log; do
            start=$(sed -n 's/.* started at \([0-9.]*\)$/\1/p' "$log" | head -1)
            hi=$(sed -n 's/.*(frames [0-9]*-\([0-9]*\)).*/\1/p' "$log" | head -1)
            [ -n "$start" ] && [ -n "$hi" ] || continue
            b="$name.$hi" # a chunk waits for its last frame, and ends with it
            if [ "$step" = surface ]; then ready=$(mtime "farm$r/checkpoints/$b.kfc"); out=$(mtime "farm$r/surface/$b.vdb")
            else ready=$(mtime "farm$r/surface/$b.vdb"); out=$(mtime "farm$r/images/$b.png"); fi
            echo "$step $(echo "$start - $ready" | bc) $(echo "$out - $start" | bc)" >> delays.txt
        done
    done
done

echo "| run | frames | local kerf run (s) | farm submit (s) | farm submit to last PNG (s) |"
echo "|---|---|---|---|---|"
cat runs.md
echo
echo "Farm timeline of the last run (seconds after submit; sim on $threads core(s), tasks 1 core each):"
echo
echo "| frame | checkpoint | surface (.vdb) | image (.png) |"
echo "|---|---|---|---|"
cat timeline.md
echo
printf '20 empty array tasks (`true`) on the idle %s-CPU node: %.1f s from sbatch to the last one gone, %.2f s a task per CPU.\n\n' \
    "$(getconf _NPROCESSORS_ONLN)" "$empty_s" "$(echo "$empty_s * $(getconf _NPROCESSORS_ONLN) / 20" | bc -l)"
echo "Per task, seconds (median / max): the wait from its input on disk (a chunk: its last frame's) to its first line, and its run time to its last output"
echo
echo "| step | tasks | wait median | wait max | run median | run max |"
echo "|---|---|---|---|---|---|"
for step in surface render; do
    grep "^$step " delays.txt | awk '{print $2}' | sort -g > w.txt
    grep "^$step " delays.txt | awk '{print $3}' | sort -g > t.txt
    k=$(wc -l < w.txt)
    [ "$k" -gt 0 ] || continue
    printf '| %s | %d | %.2f | %.2f | %.2f | %.2f |\n' "$step" "$k" "$(sed -n "$(((k + 1) / 2))p" w.txt)" \
        "$(tail -1 w.txt)" "$(sed -n "$(((k + 1) / 2))p" t.txt)" "$(tail -1 t.txt)"
done
