# implicit_sweep.gp — CPU time per frame against error, explicit against
# implicit, one colour per stiffness (issue 7): the clamped cantilever and
# the tumbling bar side by side. Run:
# gnuplot -e "dir='tools/evidence/implicit_results'" tools/evidence/implicit_sweep.gp
if (!exists("dir")) dir = "."
set terminal pngcairo size 1600,700 font "sans,11"
set output dir."/implicit_sweep.png"
set multiplot layout 1,2
set logscale xy
set xlabel "CPU seconds per frame (1 thread)"
set ylabel "RMS position error vs explicit CFL 0.025 (m)"
set key top right font ",8"
set grid
Es = "1e+06 3e+06 1e+07 3e+07"
do for [p=1:2] {
    prefix = p == 1 ? "implicit" : "implicit_tumble"
    set title (p == 1 ? "Clamped cantilever (explicit does not converge against its own refinement: see implicit\\_sweep.md)" : "Tumbling bar")."\nexplicit CFL 0.8 ... 0.05 (filled), backward Euler multigrid (squares) and Jacobi (crosses),\nmidpoint (circles): 5, 10, 20, 50 x the explicit step"
    plot for [i=1:words(Es)] dir."/".prefix."_".word(Es,i)."_explicit.dat" u 1:2 w lp pt 7 ps 1.2 lc i title "E ".word(Es,i)." explicit", \
         for [i=1:words(Es)] dir."/".prefix."_".word(Es,i)."_implicit.dat" u 1:2 w lp pt 4 ps 1.2 lc i dt 2 title "E ".word(Es,i)." backward Euler", \
         for [i=1:words(Es)] dir."/".prefix."_".word(Es,i)."_jacobi.dat" u 1:2 w lp pt 2 ps 1.0 lc i dt 3 notitle, \
         for [i=1:words(Es)] dir."/".prefix."_".word(Es,i)."_midpoint.dat" u 1:2 w lp pt 6 ps 1.2 lc i dt 4 title "E ".word(Es,i)." midpoint"
}
unset multiplot
