#!/usr/bin/env bash
# banana_cpic.sh — what cutting costs in the banana shot (the paper's §7: 131.9 s
# per frame without the cutter, 140.5 s with it, 6%). shots/banana.yaml is run
# as it is and with its knife removed (the board stays), over the frames the
# knife spends in the banana, simulation only, one thread; the runs alternate
# (with, without, with, ...) so both see the same machine load. Reported:
# wall seconds per frame over frames A-B (the knife in the banana), and the
# process's CPU seconds per frame over the whole run (1001-B, the honest
# figure on a shared machine), medians over the runs.
#   tools/evidence/banana_cpic.sh <kerf> <outdir> [dx m] [runs] [frames A-B]
set -eu
kerf=$1 out=$2 dx=${3:-0.01} runs=${4:-3} frames=${5:-1008-1018}
root=${KERF_ROOT:-$(cd "$(dirname "$0")/../.." && pwd)}
mkdir -p "$out"
# the shot without its knife: the rigid entry from "- name: knife" to the next top-level key
awk '/^  - name: knife/ { skip = 1; next } skip && /^[^ ]/ { skip = 0 } !skip' "$root/shots/banana.yaml" \
    | sed 's|\.\./assets/|'"$root"'/assets/|' > "$out/banana_noknife.yaml"
quiet="--set output.surface=false --set output.images=false --set output.particles=false --set output.checkpoints=false"
first=${frames%-*} last=${frames#*-}
one() { # one <shot> <tag> <run>: wall ms per frame over frames first..last, process CPU s per frame, particles, substeps
    /usr/bin/time -f "%U %S" -o "$out/$2_$3.cpu" env OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE "$kerf" run "$1" \
        --set sim.dx="$dx" $quiet --frames 1001-"$last" --out "$out/run_$2_$3" --threads 1 --force > "$out/$2_$3.log" 2>&1
    awk -v a="$first" -v frames="$((last - 1000))" -v cpu="$(awk '{ print $1 + $2 }' "$out/$2_$3.cpu")" '
        /^frame [0-9]+: [0-9]+ particles/ { f = $2 + 0; if (f >= a) { n++
            match($0, /, [0-9.]+ ms \(/); ms += substr($0, RSTART + 2, RLENGTH - 7) + 0; sub_ += $7 + 0; p = $3 } }
        END { printf "%.1f %.3f %d %.0f\n", ms / n, cpu / frames, p, sub_ / n }' "$out/$2_$3.log"
}
echo "run with_wall_ms without_wall_ms with_cpu_s without_cpu_s particles substeps_per_frame" > "$out/banana_cpic.dat"
for r in $(seq 1 "$runs"); do
    set -- $(one "$root/shots/banana.yaml" with "$r")
    w_ms=$1 w_cpu=$2 np=$3 ns=$4
    set -- $(one "$out/banana_noknife.yaml" without "$r")
    echo "$r $w_ms $1 $w_cpu $2 $np $ns" >> "$out/banana_cpic.dat"
done
awk 'function med(a, n,   i, j, t) { for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (a[j] < a[i]) { t = a[i]; a[i] = a[j]; a[j] = t }
                                    return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2 }
     NR > 1 { n++; w[n] = $2; o[n] = $3; wc[n] = $4; oc[n] = $5; np = $6; ns = $7 }
     END { mw = med(w, n); mo = med(o, n); cw = med(wc, n); co = med(oc, n)
           printf "%d particles, %d substeps per frame, %d runs each (medians)\n", np, ns, n
           printf "wall s per frame while the knife is in the banana: with %.3f, without %.3f, %+.1f%%\n", mw / 1e3, mo / 1e3, 100 * (mw / mo - 1)
           printf "process CPU s per frame over the whole run: with %.3f, without %.3f, %+.1f%%\n", cw, co, 100 * (cw / co - 1) }' \
    "$out/banana_cpic.dat" | tee "$out/banana_cpic.txt"
