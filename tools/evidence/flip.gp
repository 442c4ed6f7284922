# flip.gp — the flip transfer's figures from what kf_evid_flip wrote.
#   gnuplot -e "dir='OUT'" tools/evidence/flip.gp
# Writes dir/flip_energy.png (energy kept by the ringing bar and cube) and
# dir/flip_wp.png (error against CPU time, APIC and flip).
if (!exists("dir")) dir = "."
set terminal pngcairo size 1800,520 font "sans,11"
set datafile separator whitespace
set key autotitle columnhead
set grid
set style data lines
set output dir."/flip_energy.png"
set multiplot layout 1,3 title "Total energy (kinetic + elastic) / initial over 10 periods: APIC, flip (ratio 0.95, 0.99, 1) and PIC"
set xlabel "t (s)"
set ylabel "E / E_0"
set yrange [0:1.05]
set key bottom left font ",9"
set title "jelly bar 4 cells thick ringing (dx 2 cm), CFL 0.4"
plot for [c=2:6] dir."/flip_bar.dat" using 1:c lw 2
set title "the same bar, CFL 0.1 (4x the transfers)"
plot for [c=2:6] dir."/flip_bar_cfl01.dat" using 1:c lw 2
set title "V7 stretched cube, 16 cells across, CFL 0.4"
plot for [c=2:6] dir."/flip_energy.dat" using 1:c lw 2
unset multiplot

set output dir."/flip_wp.png"
set multiplot layout 1,3 title "Error against cost (process CPU s inside the step, 1 thread; accuracy.c's dx sweeps at CFL 0.3, quad-mls-8)"
set logscale xy
set autoscale
set format y "%.0e"
set xlabel "CPU seconds"
set ylabel "relative error"
set key top right font ",9"
set style data linespoints
do for [p in "bar mms sphere"] {
  set title (p eq "bar" ? "V4 axial bar: period error" : (p eq "mms" ? "V5 manufactured solution: RMS error / A" : "V6 breathing sphere: frequency error"))
  plot dir."/flip_wp_".p.".dat" index 0 using 1:2 lw 1.5 pt 7 title "APIC", \
       "" index 1 using 1:2 lw 1.5 pt 5 title "flip 0.95"
}
unset multiplot
