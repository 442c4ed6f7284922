# implicit_crossover.gp — the cheapest run of each integrator that meets an
# error budget, against stiffness (issue 7), for the clamped cantilever and
# the tumbling bar; data from kf_evid_implicit_sweep --crossover [--tumble].
# Run: gnuplot -e "dir='tools/evidence/implicit_results'" tools/evidence/implicit_crossover.gp
# A missing point: no run of that integrator met the budget, or the budget
# was above the whole motion (the cantilever at high stiffness).
if (!exists("dir")) dir = "."
set terminal pngcairo size 1400,600 font "sans,11"
set output dir."/implicit_crossover.png"
set multiplot layout 1,2
set logscale xy
set grid
set xlabel "Young's modulus E (Pa)"
set ylabel "CPU seconds per frame (1 thread)"
set key top left font ",9"
budgets = "0.1 0.02 0.004 0.001"
do for [p=1:2] {
    name = p == 1 ? "implicit_crossover" : "implicit_crossover_tumble"
    set title (p == 1 ? "Clamped cantilever sagging (motion = its swing, shrinks as 1/E)" : "Bar thrown up, tumbling (motion ~0.1 m at every E)")."\ncheapest run within each error budget: explicit solid, implicit dashed"
    plot for [b=0:3] dir."/".name."_".b.".dat" u 1:2 w lp pt 7 lw 2 lc b+1 title "explicit, error <= ".word(budgets,b+1)." dx", \
         for [b=0:3] dir."/".name."_".b.".dat" u 1:3 w lp pt 4 lw 2 dt 2 lc b+1 title "implicit, error <= ".word(budgets,b+1)." dx"
}
unset multiplot
