# robot_gait.gp — the legged robot's forward speed over time at each gait
# frequency, its mean speed against the frequency (forward and reversed), and
# the body's height over time against what the legs' shape alone makes of it
# (robot_gait.sh's data).
#   gnuplot -e "dir='OUT'" -e "freqs='1 1.5 2 3'" -e "reverse='1'" tools/evidence/robot_gait.gp
# Writes dir/robot_gait.png.
if (!exists("dir")) dir = "."
if (!exists("freqs")) freqs = "1 1.5 2 3"
if (!exists("reverse")) reverse = "1"
set terminal pngcairo size 1500,420 font "sans,10"
set output dir."/robot_gait.png"
set grid
set termoption noenhanced
set multiplot layout 1,3 title "Hexapod on sand (robot_sand.yaml: 0.73 kg body, 0.15 N m motors; Table 3 sand, dx 15 mm)"
set xlabel "time (s)"
set ylabel "speed along x over one gait cycle (m/s)"
set key bottom left font ",8" maxrows 5
set xzeroaxis lt -1
plot for [f in freqs] dir."/speed_".f.".dat" every ::1 using 1:2 with lines lw 2 title f." Hz", \
     for [f in reverse] dir."/speed_-".f.".dat" every ::1 using 1:2 with lines lw 2 dt 2 title "-".f." Hz (reversed)"
set xlabel "gait frequency (Hz; negative: the gait reversed)"
set ylabel "mean speed over whole cycles after 0.4 s (m/s)"
set yzeroaxis lt -1
unset key
# forward and reversed apart: nothing was run at 0 Hz to join them through
plot dir."/gait_speed.dat" every ::1 using 1:($1 > 0 ? $2 : 1/0) with linespoints lw 2 pt 7 ps 1.2, \
     dir."/gait_speed.dat" every ::1 using 1:($1 < 0 ? $2 : 1/0) with linespoints lw 2 dt 2 pt 6 ps 1.2
# The body's height if the legs turned exactly on command over rigid ground at
# the sand's surface (y 0.05 m): the lowest point of a C-leg (centre line a
# half ring of radius 35 mm, 12 mm thick) turned a from pointing down is
# 35 (1 + cos a) mm below the hip for a in [0, 180] degrees, 70 cos a for a in
# [270, 360], and the hip itself otherwise; the lower of the two tripods (half
# a turn apart) carries the body, whose centre is 5 mm above the hips. Reversed,
# the legs turn the other way: the same with the angle negated.
wrap(a) = a - 2 * pi * floor(a / (2 * pi))
depth(a) = a <= pi ? 0.035 * (1 + cos(a)) : a >= 1.5 * pi ? 0.07 * cos(a) : 0
d(a) = depth(wrap(a))
h(a) = 0.05 + 0.006 + 0.005 + (d(a) > d(a + pi) ? d(a) : d(a + pi))
set xlabel "time (s)"
set ylabel "body centre height (m)"
set key bottom right font ",8"
unset yzeroaxis
set samples 500
plot [0:2] dir."/gait_1.dat" every ::1 using 1:6 with linespoints lw 2 pt 7 ps 0.6 title "1 Hz on sand", \
     dir."/gait_-1.dat" every ::1 using 1:6 with linespoints lw 2 dt 2 pt 6 ps 0.6 title "-1 Hz on sand", \
     h(2 * pi * x) with lines lc rgb "gray40" lw 1 title "legs on command at 1 Hz, rigid ground at the sand's top", \
     h(-2 * pi * x) with lines lc rgb "gray60" lw 1 dt 2 title "the same at -1 Hz"
unset multiplot
