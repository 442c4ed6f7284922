#!/usr/bin/env python3
"""bowl_leak.py — does sand_stir's sand pass through its bowl (a solid body)?

Reads a sand_stir run's particle files (kerf run shots/sand_stir.yaml --out DIR:
DIR/particles/*.ply) and counts, per frame, the sand below y = 0.015 m that lies
  - inside the bowl's solid base (within 0.12 m of its axis: the base is solid
    from the floor to the inside's bottom at y = 0.018 m out to r = 0.127 m), or
  - under the bowl's outer wall (0.13 m <= r < 0.28 m), where sand can only
    arrive from outside, over the rim.
At the end it splits each group by whether the particle ever rose within 5 cm
of the rim (y >= 0.25 m): sand that never did came through the bowl.

    python3 tools/evidence/bowl_leak.py DIR
"""
import glob
import math
import struct
import sys

AXIS = (0.5, 0.5)      # the bowl's axis (x, z), shots/sand_stir.yaml
LOW = 0.015            # below the inside's bottom (0.018 m)
NEAR_RIM = 0.25        # the rim is at y = 0.3 m
RECORD = struct.Struct('<6fHI3f')  # x y z, v, material, id, von_mises, J, plastic_strain


def frames(run_dir):
    for path in sorted(glob.glob(run_dir + '/particles/*.ply')):
        data = open(path, 'rb').read()
        start = data.index(b'end_header\n') + len(b'end_header\n')
        yield path, [RECORD.unpack_from(data, off) for off in range(start, len(data), RECORD.size)]


def where(x, y, z):
    """'base', 'under' or None for a particle at (x, y, z)"""
    r = math.hypot(x - AXIS[0], z - AXIS[1])
    if y >= LOW:
        return None
    if r < 0.12:
        return 'base'
    if 0.13 <= r < 0.28:
        return 'under'
    return None


def main(run_dir):
    highest, last = {}, {}
    for path, particles in frames(run_dir):
        count = {'base': 0, 'under': 0}
        for p in particles:
            x, y, z, pid = p[0], p[1], p[2], p[7]
            highest[pid] = max(highest.get(pid, -1e9), y)
            last[pid] = (x, y, z)
            w = where(x, y, z)
            if w:
                count[w] += 1
        print('%s: in the base %d, under the outer wall %d' % (path.split('/')[-1], count['base'], count['under']))
    for group in ('base', 'under'):
        ids = [i for i, pos in last.items() if where(*pos) == group]
        never = sum(highest[i] < NEAR_RIM for i in ids)
        print('last frame, %s: %d particles, %d never within 5 cm of the rim' % (group, len(ids), never))


if __name__ == '__main__':
    if len(sys.argv) != 2:
        sys.exit('usage: bowl_leak.py RUN_DIR (the --out of a sand_stir run)')
    main(sys.argv[1])
