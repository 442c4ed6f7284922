# implicit_sweep.gp — CPU time per frame against error, explicit against
# implicit, one colour per stiffness (issue 7). Run in the sweep's output
# directory: gnuplot -e "dir='tools/evidence/implicit_results'" tools/evidence/implicit_sweep.gp
if (!exists("dir")) dir = "."
set terminal pngcairo size 1000,700 font "sans,11"
set output dir."/implicit_sweep.png"
set logscale xy
set xlabel "CPU seconds per frame (1 thread)"
set ylabel "RMS position error vs explicit CFL 0.1 (m)"
set title "Stiff cantilever: explicit (CFL 0.8, 0.4; filled) vs implicit (5, 10, 20, 50 x the explicit step;\nmultigrid-CG open squares, Jacobi-CG crosses)"
set key outside right top
set grid
Es = "1e+06 3e+06 1e+07 3e+07"
plot for [i=1:words(Es)] dir."/implicit_".word(Es,i)."_explicit.dat" u 1:2 w lp pt 7 ps 1.3 lc i title "E ".word(Es,i)." explicit", \
     for [i=1:words(Es)] dir."/implicit_".word(Es,i)."_implicit.dat" u 1:2 w lp pt 4 ps 1.3 lc i dt 2 title "E ".word(Es,i)." implicit, multigrid", \
     for [i=1:words(Es)] dir."/implicit_".word(Es,i)."_jacobi.dat" u 1:2 w lp pt 2 ps 1.1 lc i dt 3 title "E ".word(Es,i)." implicit, Jacobi"
