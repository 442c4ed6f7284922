#!/usr/bin/env bash
# contact_sheet.sh — docs/contact_sheet.png: one frame of every shipped shot.
# Each shot runs at --quality preview up to its representative frame (40 % of
# the way through, at most 16 frames in; six slow shots only 6 frames in, to
# keep the sheet within the hour on 2 cores; the banana 13 and the robot 12),
# into out/contact/<shot>/, and that frame becomes a tile
# (tools/contact_sheet.c), row by row in the order below.
#   tools/contact_sheet.sh [shot names...]      # default: all of shots/
#   tools/contact_sheet.sh --only NAMES...      # remake these tiles, keep the others of the sheet
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"
only=0
[ "${1:-}" = --only ] && only=1 && shift
shots=("$@")
all=(demo cheese_cut bunny_split sand_paddles water_wheel dam_break goo_blocks goo_sphere
     bunny_drop sand_column goo_slump snow mesh_collider buoyancy sand_stir sand_sweep sand_wheel
     armadillo_cut banana robot_sand)
remake=" ${shots[*]} "
if [ $only -eq 1 ] || [ ${#shots[@]} -eq 0 ]; then shots=("${all[@]}"); fi
tiles=()
for n in "${shots[@]}"; do
  # --only: the other tiles stay as they are in the sheet (kf_contact_sheet's `keep`)
  if [ $only -eq 1 ] && [[ "$remake" != *" $n "* ]]; then tiles+=(keep); continue; fi
  s=shots/$n.yaml
  st=$(grep -o 'start: *[0-9]*' "$s" | head -1 | grep -o '[0-9]*$')
  en=$(grep -o 'end: *[0-9]*' "$s" | head -1 | grep -o '[0-9]*$')
  rep=$(( st + (en - st) * 4 / 10 ))
  [ $rep -gt $(( st + 16 )) ] && rep=$(( st + 16 ))
  case $n in snow|mesh_collider|buoyancy|sand_stir|sand_sweep|sand_wheel) rep=$(( st + 6 ));; esac
  # the paper's last three: the banana mid-slice, the robot half a gait cycle on
  case $n in banana) rep=$(( st + 13 ));; robot_sand) rep=$(( st + 12 ));; esac
  ./build/kerf run "$s" --quality preview --frames "$st-$rep" --out "out/contact/$n" --quiet
  tiles+=("out/contact/$n/images/$(ls out/contact/$n/images | grep "\.$rep\.png$")")
done
./build/kf_contact_sheet docs/contact_sheet.png 4 240 "${tiles[@]}"
echo "docs/contact_sheet.png: ${shots[*]}"
