#!/usr/bin/env bash
# banana_cpic.sh — what cutting costs in the banana shot (the paper's §7: 131.9 s
# per frame without the cutter, 140.5 s with it, 6%). shots/banana.yaml is run
# as it is and with its knife removed (the board stays), over the frames the
# knife spends in the banana, simulation only, one thread; the runs alternate
# (with, without, with, ...) so both see the same machine load, and the
# seconds per frame are the median over runs of each run's mean.
#   tools/evidence/banana_cpic.sh <kerf> <outdir> [dx m] [runs] [frames A-B]
set -eu
kerf=$1 out=$2 dx=${3:-0.0075} runs=${4:-3} frames=${5:-1007-1022}
root=${KERF_ROOT:-$(cd "$(dirname "$0")/../.." && pwd)}
mkdir -p "$out"
# the shot without its knife: the rigid entry from "- name: knife" to the next top-level key
awk '/^  - name: knife/ { skip = 1; next } skip && /^[^ ]/ { skip = 0 } !skip' "$root/shots/banana.yaml" \
    | sed 's|\.\./assets/|'"$root"'/assets/|' > "$out/banana_noknife.yaml"
quiet="--set output.surface=false --set output.images=false --set output.particles=false --set output.checkpoints=false"
first=${frames%-*} last=${frames#*-}
one() { # one <shot> <tag> <run>
    OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE "$kerf" run "$1" --set sim.dx="$dx" $quiet --frames 1001-"$last" \
        --out "$out/run_$2_$3" --threads 1 --force > "$out/$2_$3.log" 2>&1
    # mean ms per frame over frames first..last, with the particle count and substeps
    awk -v a="$first" '/^frame [0-9]+: [0-9]+ particles/ { f = $2 + 0; if (f >= a) { n++
        match($0, /, [0-9.]+ ms \(/); ms += substr($0, RSTART + 2, RLENGTH - 7) + 0; sub_ += $7 + 0; p = $3 } }
        END { printf "%.1f %d %.0f\n", ms / n, p, sub_ / n }' "$out/$2_$3.log"
}
echo "run with_ms_per_frame without_ms_per_frame particles substeps_per_frame" > "$out/banana_cpic.dat"
for r in $(seq 1 "$runs"); do
    w=$(one "$root/shots/banana.yaml" with "$r")
    wo=$(one "$out/banana_noknife.yaml" without "$r")
    echo "$r ${w%% *} ${wo%% *} $(echo "$w" | cut -d' ' -f2-3)" >> "$out/banana_cpic.dat"
done
awk 'NR > 1 { w[NR - 1] = $2; o[NR - 1] = $3; n = NR - 1 }
     function med(a, n,   i, j, t) { for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (a[j] < a[i]) { t = a[i]; a[i] = a[j]; a[j] = t }
                                    return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2 }
     END { mw = med(w, n); mo = med(o, n); printf "median s/frame: with the knife %.3f, without %.3f, overhead %+.1f%%\n", mw / 1e3, mo / 1e3, 100 * (mw / mo - 1) }' \
    "$out/banana_cpic.dat" | tee "$out/banana_cpic.txt"
