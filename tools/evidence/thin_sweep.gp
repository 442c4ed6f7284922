# thin_sweep.gp — issue 17: particles across a zero-thickness sheet against its
# speed (cells per substep), per material, before the crossing guard (dashed,
# the old defaults: penalty and push off) and after (solid, the defaults now).
# Left: particles that were ever more than 0.1 cell behind the sheet; right:
# the deepest any particle was behind it at a substep's end (cells). Points
# missing on a line are runs that stopped on numerical trouble (see the
# tables; after.txt has three more columns, the CFL number the fixed step
# reached, the smallest J and the particles stiffness-limited, before the
# trouble). Third panel: the smallest volume ratio J of any particle at any
# substep's end, after. Run from the repository root:
#   gnuplot -e "dir='tools/evidence/thin_results'" tools/evidence/thin_sweep.gp
if (!exists("dir")) dir = "."
set terminal pngcairo size 2200,650 font "sans,11"
set output dir."/thin_sweep.png"
set multiplot layout 1,3
set xlabel "sheet speed (cells per substep)"
set key top left font ",9"
set grid
set logscale x
set xrange [0.04:1.2]
mats = "sand goo water jello snow"
set ylabel "particles ever > 0.1 cell behind the sheet"
set title "sheet sweeping a bed along x, then stopping dead: crossings"
plot for [i=1:words(mats)] "< awk '$1==\"".word(mats,i)."\" && $2==\"sweep\" && $13==\"\" {print $3, $7}' ".dir."/before.txt" u 1:2 w lp dt 2 pt 6 lc i title word(mats,i)." before", \
     for [i=1:words(mats)] "< awk '$1==\"".word(mats,i)."\" && $2==\"sweep\" && $16==\"\" {print $3, $7}' ".dir."/after.txt" u 1:2 w lp pt 7 lc i title word(mats,i)." after"
set ylabel "deepest behind the sheet (cells)"
set title "sheet sweeping a bed along x, then stopping dead: deepest"
plot for [i=1:words(mats)] "< awk '$1==\"".word(mats,i)."\" && $2==\"sweep\" && $13==\"\" {print $3, $8}' ".dir."/before.txt" u 1:2 w lp dt 2 pt 6 lc i title word(mats,i)." before", \
     for [i=1:words(mats)] "< awk '$1==\"".word(mats,i)."\" && $2==\"sweep\" && $16==\"\" {print $3, $8}' ".dir."/after.txt" u 1:2 w lp pt 7 lc i title word(mats,i)." after"
set ylabel "smallest J of any particle at a substep's end"
set title "sheet sweeping a bed along x, then stopping dead: compression (after)"
set logscale y
set key bottom left font ",9"
plot for [i=1:words(mats)] "< awk '$1==\"".word(mats,i)."\" && $2==\"sweep\" && $16==\"\" {print $3, $14}' ".dir."/after.txt" u 1:2 w lp pt 7 lc i title word(mats,i)." after"
unset multiplot
