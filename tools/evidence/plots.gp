# plots.gp — the evidence figures from the data kf_evid_* wrote.
#   gnuplot -e "dir='OUT'" tools/evidence/plots.gp
# Writes dir/{pareto,convergence,cfl,stability_map,energy}.png.
if (!exists("dir")) dir = "."
set terminal pngcairo size 1800,560 font "sans,11"
set datafile separator whitespace
set key autotitle columnhead
set grid
probs = "bar mms sphere"
ptitle(p) = p eq "bar" ? "V4 axial bar: period error" : (p eq "mms" ? "V5 manufactured solution: RMS error / A" : "V6 breathing sphere: frequency error")

# error against CPU time, one line per variant, the Pareto front in black
set output dir."/pareto.png"
set multiplot layout 1,3 title "Error against cost (process CPU seconds inside the solver step, 1 thread; Δx sweep at CFL 0.3, plus the CFL sweep)"
set logscale xy
set offsets graph 0.05, graph 0.05, graph 0.08, graph 0.08
set autoscale xfix
set autoscale yfix
set format y "%.0e"
set xlabel "CPU seconds"
set ylabel "relative error"
set key top right font ",9"
do for [p in probs] {
  set title ptitle(p)
  files = system("ls ".dir."/cost_".p."_*.dat")
  plot for [f in files] f using 1:2 with linespoints lw 1.5 pt 7 ps 0.8, \
       dir."/pareto_".p.".dat" using 1:2 with steps lw 3 lc rgb "black" title "Pareto front", \
       dir."/pareto_".p.".dat" using 1:2 with points pt 6 ps 2 lc rgb "black" notitle
}
unset multiplot

# error against Δx with the fitted order
set output dir."/convergence.png"
set multiplot layout 1,3 title "Error against grid spacing (CFL 0.3); dashed: least-squares power law, order in the key"
set xlabel "Δx"
do for [p in probs] {
  set title ptitle(p)
  files = system("ls ".dir."/dx_".p."_*.dat")
  fits = system("ls ".dir."/fit_".p."_*.dat")
  plot for [i=1:words(files)] word(files,i) using 1:2 with points pt 7 ps 1.2 lc i, \
       for [i=1:words(fits)] word(fits,i) using 1:2 with lines dt 2 lw 1.5 lc i notitle
}
unset multiplot

# error against CFL number
set output dir."/cfl.png"
set multiplot layout 1,3 title "Error against the CFL number at a fixed Δx (MLS force, 8 particles per cell)"
set xlabel "CFL number C = Δt (c + |v|) / Δx"
# linear axes: each curve spans less than a factor of 3
unset logscale
set format y "%.1e"
do for [p in probs] {
  set title ptitle(p)
  files = system("ls ".dir."/cfl_".p."_*.dat")
  plot for [f in files] f using 1:2 with linespoints lw 1.5 pt 7
}
unset multiplot

# the stability map: largest stable CFL per material and variant
set terminal pngcairo size 1400,600 font "sans,11"
set offsets 0, 0, 0, 0
set autoscale

set output dir."/stability_map.png"
set termoption noenhanced
unset logscale
set format y "%g"
set title "Largest stable CFL number (free block, bisection) against the default"
set style data histograms
set style histogram clustered gap 1
set style fill solid 0.8 border -1
set ylabel "CFL number"
set xlabel ""
set yrange [0:*]
set key top left
default = system("awk -F, 'NR==2{print $5}' ".dir."/stability.csv")
plot for [c=2:5] dir."/stability_map.dat" using c:xtic(1), default+0 with lines lw 3 lc rgb "red" title "default sim.cfl"

# Fig. 17: energy curves
set terminal pngcairo size 1400,520 font "sans,11"
set output dir."/energy.png"
set termoption enhanced
set style data lines
set yrange [*:*]
set multiplot layout 1,2 title "Total energy (kinetic + elastic) / initial, MLS-MPM against MPM with the classic force (paper Fig. 17)"
set xlabel "t (s)"
set ylabel "E / E_0"
set key top right
set title "oscillating stretched cube (F_0 = 1.1 I, 16 cells across)"
plot dir."/energy_cube.dat" using 1:2 lw 2, "" using 1:3 lw 2 dt 2
set title "colliding balls (R/Δx = 10, 2 m/s each)"
plot dir."/energy_balls.dat" using 1:2 lw 2, "" using 1:3 lw 2 dt 2
unset multiplot
