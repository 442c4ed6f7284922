# implicit_crossover.gp — the cheapest run of each integrator that meets an
# error budget, against stiffness (issue 7), for the clamped cantilever and
# the tumbling bar; data from kf_evid_implicit_sweep --crossover [--tumble].
# Run: gnuplot -e "dir='tools/evidence/implicit_results'" tools/evidence/implicit_crossover.gp
# A missing point: no run of that integrator met the budget, or the budget
# was above the whole motion (the cantilever at high stiffness). The grey
# lines are each integrator's cheapest run whatever its error: explicit at
# CFL 0.8, implicit (backward Euler) at its fewest steps per frame (1, or 4 for
# the tumbling bar). Implicit: backward Euler dashed (open squares), the
# midpoint scheme dotted (open circles).
if (!exists("dir")) dir = "."
set terminal pngcairo size 1500,650 font "sans,11"
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
    fewest = p == 1 ? 1 : 4
    set title (p == 1 ? "Clamped cantilever sagging (the motion is its swing: shrinks as 1/E)" : "Bar thrown up and tumbling (motion about 0.1 m at every E)")."\ncheapest run per error budget: explicit solid, backward Euler dashed, midpoint dotted"
    f = dir."/".name.".csv"
    ex = "< awk -F, '$2 == \"explicit\" && $3 == 0.8 && $5 == 1 {print $1, $6}' ".f
    im = sprintf("< awk -F, '$2 == \"backward Euler\" && $4 == %d && $5 == 1 {print $1, $6}' ", fewest).f
    plot ex u 1:2 w l lw 1 lc rgb "#999999" title "explicit CFL 0.8, any error", \
         im u 1:2 w l lw 1 dt 2 lc rgb "#999999" title sprintf("backward Euler %d step(s) / frame, any error", fewest), \
         for [b=0:3] dir."/".name."_".b.".dat" u 1:2 w lp pt 7 lw 2 lc b+1 title "explicit, error <= ".word(budgets,b+1)." dx", \
         for [b=0:3] dir."/".name."_".b.".dat" u 1:3 w lp pt 4 lw 2 dt 2 lc b+1 title "backward Euler, error <= ".word(budgets,b+1)." dx", \
         for [b=0:3] dir."/".name."_".b.".dat" u 1:4 w lp pt 6 lw 2 dt 3 lc b+1 title "midpoint, error <= ".word(budgets,b+1)." dx"
}
unset multiplot
