# scene_table.gp — where the time goes in the paper's scenes, from kerf_bench's scene table.
#   build/kerf_bench --only scenes --substeps 30 --threads 2 | grep -v '^paper\|^s/frame' | sed 's/~/ /' > DIR/scene_table.tsv
#   gnuplot -e "dir='DIR'" tools/evidence/scene_table.gp
# Writes dir/scene_table.png: left, each scene's frame split by stage (share of the
# stages' sum); right, core-seconds per frame per million particles, kerf against
# Table 3 (4 cores of an i7-7700K at 4.2 GHz).
if (!exists("dir")) dir = "."
if (!exists("label")) label = "1 frame at the paper's resolution"
set terminal pngcairo size 1800,640 font "sans,11" noenhanced
set datafile separator whitespace
data = dir."/scene_table.tsv"
# columns: 1 scene, 8-14 ms per frame: sort p2g grid g2p stress cdf rigid; 18 kerf c-s, 19 paper c-s
stages = "sort p2g grid g2p stress cdf rigid"
total(i) = column(8) + column(9) + column(10) + column(11) + column(12) + column(13) + column(14)
set output dir."/scene_table.png"
set multiplot layout 1,2 title "kerf's scene table: ".label
set style data histograms
set style histogram rowstacked
set style fill solid 0.85 border -1
set boxwidth 0.75
set xtics rotate by -35 font ",10" nomirror
set grid ytics
set title "share of the frame per stage (ms per frame from the stage timers)"
set ylabel "% of the frame"
set yrange [0:100]
set key outside right top font ",10"
plot for [k=8:14] data using (100.0 * column(k) / total(0)):xtic(1) every ::1 title word(stages, k - 7)
set title "core-seconds per frame per million particles (lower is better)"
set ylabel "core-s / frame / M particles"
set yrange [*:*]
set logscale y
set style histogram clustered gap 1
plot data using 18:xtic(1) every ::1 title "kerf (wall x threads)", \
     data using 19 every ::1 title "paper, Table 3 (wall x 4 cores)"
unset multiplot
