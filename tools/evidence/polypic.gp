# polypic.gp — the polypic transfer's work–precision figure from what
# `kf_evid_flip --polypic --no-energy` wrote.
#   gnuplot -e "dir='OUT'" tools/evidence/polypic.gp
# Writes dir/polypic_wp.png (error against CPU time, APIC and polypic).
if (!exists("dir")) dir = "."
set terminal pngcairo size 1800,520 font "sans,11"
set datafile separator whitespace
set grid
set output dir."/polypic_wp.png"
set multiplot layout 1,3 title "Error against cost (process CPU s inside the step, 1 thread; accuracy.c's dx sweeps at CFL 0.3, quad-mls-8): APIC and polypic"
set logscale xy
set format y "%.0e"
set xlabel "CPU seconds"
set ylabel "relative error"
set key top right font ",9"
set style data linespoints
do for [p in "bar mms sphere"] {
  set title (p eq "bar" ? "V4 axial bar: period error" : (p eq "mms" ? "V5 manufactured solution: RMS error / A" : "V6 breathing sphere: frequency error"))
  plot dir."/polypic_wp_".p.".dat" index 0 using 1:2 lw 1.5 pt 7 title "APIC", \
       "" index 1 using 1:2 lw 1.5 pt 5 title "polypic"
}
unset multiplot
