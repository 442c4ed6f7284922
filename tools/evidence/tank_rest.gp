# tank_rest.gp — water at rest in a 0.4 m tank (48 cells/m, walls 0.2 cells
# short of a node, slip, 0.17 m deep, kappa 1e4): its level over 10 s before
# and after the walls were put at their planes (src/mpm/wall_ghost.c), with
# the level the particles' J claims and the hydrostatic level. Data from
# kf_evid_tank_rest (tools/evidence/tank_rest.c). Run from the repository root:
#   gnuplot -e "dir='tools/evidence/fluid_results'" tools/evidence/tank_rest.gp
if (!exists("dir")) dir = "."
set terminal pngcairo size 1100,600 font "sans,11"
set output dir."/tank_rest.png"
set xlabel "time (s)"
set ylabel "level (m)"
set key bottom left font ",10"
set grid
set yrange [0.160:0.178]
# hydrostatic: ((1 + a H0)^(1-1/g) - 1) / (a (1 - 1/g)), a = rho g / kappa
a = 1000 * 9.81 / 1e4; g = 7.0; H0 = 0.17
H = ((1 + a * H0)**(1 - 1.0 / g) - 1) / (a * (1 - 1.0 / g))
set title "water at rest in a tank: level (top particles + 1/4 cell) and the volume J claims"
plot dir."/before.dat" u 1:2 w l lw 2 lc rgb "#c03020" title "level, before", \
     dir."/before.dat" u 1:3 w l dt 2 lc rgb "#c03020" title "J's level, before", \
     dir."/after.dat" u 1:2 w l lw 2 lc rgb "#2060c0" title "level, after", \
     dir."/after.dat" u 1:3 w l dt 2 lc rgb "#2060c0" title "J's level, after", \
     H w l dt 3 lc rgb "black" title sprintf("hydrostatic level %.4f m", H)
