# robot_gait.gp — the legged robot's forward speed over time at each gait
# frequency, and its mean speed against the frequency (robot_gait.sh's data).
#   gnuplot -e "dir='OUT'" -e "freqs='1 1.5 2 3'" tools/evidence/robot_gait.gp
# Writes dir/robot_gait.png.
if (!exists("dir")) dir = "."
if (!exists("freqs")) freqs = "1 1.5 2 3"
set terminal pngcairo size 1100,420 font "sans,10"
set output dir."/robot_gait.png"
set grid
set termoption noenhanced
set multiplot layout 1,2 title "Hexapod on sand (robot_sand.yaml, Table 3 sand, dx 15 mm): the body's speed along x"
set xlabel "time (s)"
set ylabel "speed over one gait cycle (m/s)"
set key bottom right font ",9"
set xzeroaxis lt -1
plot for [f in freqs] dir."/speed_".f.".dat" every ::1 using 1:2 with lines lw 2 title f." Hz", \
     dir."/speed_reverse.dat" every ::1 using 1:2 with lines lw 2 dt 2 lc rgb "black" title "-1 Hz (gait reversed)"
set xlabel "gait frequency (Hz; negative: reversed)"
set ylabel "mean speed over whole cycles after 0.4 s (m/s)"
set yzeroaxis lt -1
unset key
plot dir."/gait_speed.dat" every ::1 using 1:2 with linespoints lw 2 pt 7 ps 1.2
unset multiplot
