#!/usr/bin/env python3
"""bowl_leak.py — does sand_stir's sand pass through its bowl (a solid body)?

Reads a sand_stir run's particle files (kerf run shots/sand_stir.yaml --out DIR:
DIR/particles/*.ply) and measures each frame's sand against the bowl's exact
geometry. The bowl (assets/bowl.obj, placed as the shot places it) is a solid
of revolution, so its cross-section through the axis (the mesh cut by the
plane z = 0.5, x >= 0.5) is a closed polygon in (r, y): a particle is inside
the solid when its (r, y) is inside that polygon, and its depth is its
distance to the polygon's edges. Per frame:
  - inside: particles inside the solid, and how many are deeper than
    --allow cells (kerf's guard allows min(0.5, 0.4 t / dx) cells, t the
    bowl's thinnest part, 0.018 m: 0.30 cells at preview's dx 0.024);
  - deepest: the deepest particle, in cells;
  - under: particles under the bowl's outer wall (outside the solid, below
    its underside), where sand can only arrive from outside, over the rim.
At the end it splits the last frame's "under" group by whether the particle
ever rose within 5 cm of the rim (y >= 0.25 m): sand that never did came
through the bowl.

    python3 tools/evidence/bowl_leak.py DIR [--dx 0.024] [--allow 0.30]
"""
import argparse
import glob
import math
import os
import struct

AXIS = (0.5, 0.5)      # the bowl's axis (x, z), shots/sand_stir.yaml
CENTER = (0.5, 0.3, 0.5)
SCALE = 0.6
NEAR_RIM = 0.25        # the rim is at y = 0.3 m
RECORD = struct.Struct('<6fHI3f')  # x y z, v, material, id, von_mises, J, plastic_strain
MESH = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'assets', 'bowl.obj')


def frames(run_dir):
    for path in sorted(glob.glob(run_dir + '/particles/*.ply')):
        data = open(path, 'rb').read()
        start = data.index(b'end_header\n') + len(b'end_header\n')
        yield path, [RECORD.unpack_from(data, off) for off in range(start, len(data), RECORD.size)]


def section():
    """the bowl's cross-section: segments ((r0, y0), (r1, y1)) where the mesh
    meets the plane z = 0.5 on the side x >= 0.5"""
    vert, segs = [], []
    faces = []
    for line in open(MESH):
        t = line.split()
        if t and t[0] == 'v':
            vert.append([float(a) * SCALE + c for a, c in zip(t[1:4], CENTER)])
        elif t and t[0] == 'f':
            idx = [int(a.split('/')[0]) - 1 for a in t[1:]]
            faces += [(idx[0], idx[k], idx[k + 1]) for k in range(1, len(idx) - 1)]
    z0 = AXIS[1] + 1e-7  # off the vertices' own plane
    for f in faces:
        pts = []
        for a, b in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0])):
            pa, pb = vert[a], vert[b]
            if (pa[2] - z0) * (pb[2] - z0) < 0:
                s = (z0 - pa[2]) / (pb[2] - pa[2])
                pts.append([pa[k] + s * (pb[k] - pa[k]) for k in range(3)])
        if len(pts) == 2 and pts[0][0] >= AXIS[0] and pts[1][0] >= AXIS[0]:
            segs.append(((pts[0][0] - AXIS[0], pts[0][1]), (pts[1][0] - AXIS[0], pts[1][1])))
    return segs


def inside(segs, r, y):
    """even-odd test of (r, y) against the section, mirrored about the axis"""
    crossings = 0
    for (r0, y0), (r1, y1) in segs:
        if (y0 > y) != (y1 > y) and r < r0 + (y - y0) * (r1 - r0) / (y1 - y0):
            crossings += 1
    return crossings % 2 == 1


def distance(segs, r, y):
    best = 1e9
    for (r0, y0), (r1, y1) in segs:
        dr, dy = r1 - r0, y1 - y0
        L = dr * dr + dy * dy
        s = 0 if L == 0 else max(0.0, min(1.0, ((r - r0) * dr + (y - y0) * dy) / L))
        best = min(best, math.hypot(r - r0 - s * dr, y - y0 - s * dy))
    return best


def underside(segs, r):
    """the lowest height of the bowl's surface above radius r (its underside), or None"""
    ys = []
    for (r0, y0), (r1, y1) in segs:
        if min(r0, r1) <= r <= max(r0, r1) and r0 != r1:
            ys.append(y0 + (r - r0) * (y1 - y0) / (r1 - r0))
    return min(ys) if ys else None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('run_dir')
    ap.add_argument('--dx', type=float, default=0.024, help="the run's cell size, m (preview: 0.024)")
    ap.add_argument('--allow', type=float, default=0.30, help="the guard's allowance, cells")
    a = ap.parse_args()
    segs = section()
    highest, last = {}, {}
    for path, particles in frames(a.run_dir):
        n_in = n_deep = n_under = 0
        deepest = 0.0
        for p in particles:
            x, y, z, pid = p[0], p[1], p[2], p[7]
            highest[pid] = max(highest.get(pid, -1e9), y)
            r = math.hypot(x - AXIS[0], z - AXIS[1])
            last[pid] = (r, y)
            if r > 0.31 or y > 0.31:
                continue
            if inside(segs, r, y):
                d = distance(segs, r, y) / a.dx
                n_in += 1
                n_deep += d > a.allow + 0.01
                deepest = max(deepest, d)
            else:
                u = underside(segs, r)
                n_under += u is not None and y < u and r > 0.13
        print('%s: inside the bowl %d, deeper than %.2f cells %d (deepest %.2f cells), under its wall %d'
              % (os.path.basename(path), n_in, a.allow, n_deep, deepest, n_under))
    under = [i for i, (r, y) in last.items()
             if r > 0.13 and r < 0.31 and underside(segs, r) is not None and y < underside(segs, r)
             and not inside(segs, r, y)]
    never = sum(highest[i] < NEAR_RIM for i in under)
    print('last frame: %d under the wall, %d of them never within 5 cm of the rim' % (len(under), never))


if __name__ == '__main__':
    main()
