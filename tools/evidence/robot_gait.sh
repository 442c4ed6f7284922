#!/usr/bin/env bash
# robot_gait.sh — the legged robot on sand (shots/robot_sand.yaml) at several
# gait frequencies, and reversed at the same rates (shots/robot_sand_reverse.yaml,
# its motors' frequency negated): the body's position along x, its height and
# speed each frame and the motors' torque peaks, from kerf's frame log; the
# speed averaged over a gait cycle; then robot_gait.gp plots them
# (dir/robot_gait.png) and gait_speed.dat sums them up.
#   tools/evidence/robot_gait.sh <kerf> <outdir> [dx m] [last frame] [frequencies...]
# REVERSE (environment) lists the reversed rates, default "1"; a rate f runs
# robot_sand_reverse.yaml at -f Hz.
# Each run: simulation only (no surfaces or images), one thread; runs whose
# data is in outdir already are kept (delete gait_*.dat to redo them).
set -eu
kerf=$1 out=$2 dx=${3:-0.015} last=${4:-1036}
shift $(( $# < 4 ? $# : 4 ))
freqs=${*:-1 1.5 2 3}
reverse=${REVERSE:-1}
root=${KERF_ROOT:-$(cd "$(dirname "$0")/../.." && pwd)}
mkdir -p "$out"
joints="fl fr ml mr rl rr"
quiet="--set output.surface=false --set output.images=false --set output.particles=false --set output.checkpoints=false"
run() { # run <shot> <frequency> <tag>; a run whose data is there already is not redone
    [ -s "$out/gait_$3.dat" ] && return 0
    local sets=""
    for j in $joints; do sets="$sets --set joints.hip_$j.frequency=$2"; done
    OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE "$kerf" run "$root/shots/$1.yaml" --set sim.dx="$dx" $quiet $sets \
        --frames 1001-"$last" --out "$out/run_$3" --threads 1 --force > "$out/$3.log" 2>&1
    # per frame: time (s), body x (m), body v_x (m/s), the largest motor
    # torque peak (N m), its limit, the body's height (m)
    awk -v fps=24 '
        /^frame [0-9]+: [0-9]+ particles/ { f = $2 + 0 }
        /^  rigid body: at/ { gsub(/[\[\],]/, " "); x[f] = $4; y[f] = $5; vx[f] = $9 }
        /^  motor hip_/ { p = $8 + 0; if (p > peak[f]) peak[f] = p; lim = $10 }
        END { print "t x vx peak limit y"; for (k = 1002; k in x; k++) printf "%.4f %.5f %.5f %.4f %s %.5f\n", (k - 1001) / fps, x[k], vx[k], peak[k], lim, y[k] }
    ' "$out/$3.log" > "$out/gait_$3.dat"
}
# the speed over one gait cycle centred on each frame: (x(t + T/2) - x(t - T/2)) / T
cycle_speed() { # cycle_speed <frequency> <data file>
    awk -v f="$1" 'function abs(v) { return v < 0 ? -v : v }
        NR > 1 { n++; t[n] = $1; x[n] = $2 }
        END { h = 0.5 / abs(f); print "t speed"
              for (i = 1; i <= n; i++) { a = b = 0
                  for (k = 1; k <= n; k++) { if (t[k] <= t[i] - h + 1e-9) a = k; if (t[k] <= t[i] + h + 1e-9) b = k }
                  if (a && t[b] >= t[i] + h - 0.5 / 24) printf "%.4f %.5f\n", t[i], (x[b] - x[a]) / (t[b] - t[a]) } }' "$2"
}
# the mean speed over the last whole gait cycles after the first 0.4 s
# (the start-up), the largest torque peak against its limit, and the body's
# lowest and highest point over those cycles (its bob and how far it sank)
summary() { # summary <frequency> <data file>
    awk -v f="$1" 'function abs(v) { return v < 0 ? -v : v }
        NR > 1 { n++; t[n] = $1; x[n] = $2; y[n] = $6; if ($4 / $5 > w) w = $4 / $5 }
        END { T = int((t[n] - 0.4) * abs(f) + 1e-9) / abs(f)
              for (k = 1; k <= n && t[k] < t[n] - T - 1e-9; k++);
              lo = hi = y[k]; for (i = k; i <= n; i++) { if (y[i] < lo) lo = y[i]; if (y[i] > hi) hi = y[i] }
              if (T > 0 && k < n) printf "%s %.5f %.4f %.3f %.4f %.4f\n", f, (x[n] - x[k]) / (t[n] - t[k]), w, t[n] - t[k], lo, hi }' "$2"
}
echo "frequency speed torque_peak_over_limit seconds_averaged body_y_low body_y_high" > "$out/gait_speed.dat"
for f in $freqs; do
    run robot_sand "$f" "$f"
    cycle_speed "$f" "$out/gait_$f.dat" > "$out/speed_$f.dat"
    summary "$f" "$out/gait_$f.dat" >> "$out/gait_speed.dat"
done
for f in $reverse; do
    run robot_sand_reverse "-$f" "-$f"
    cycle_speed "-$f" "$out/gait_-$f.dat" > "$out/speed_-$f.dat"
    summary "-$f" "$out/gait_-$f.dat" >> "$out/gait_speed.dat"
done
{ head -1 "$out/gait_speed.dat"; tail -n +2 "$out/gait_speed.dat" | sort -g; } > "$out/gait_speed.tmp"
mv "$out/gait_speed.tmp" "$out/gait_speed.dat"
gnuplot -e "dir='$out'" -e "freqs='$freqs'" -e "reverse='$reverse'" "$root/tools/evidence/robot_gait.gp"
