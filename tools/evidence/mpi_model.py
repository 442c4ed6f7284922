#!/usr/bin/env python3
"""mpi_model.py - projected efficiency of kerf over MPI ranks (tools/evidence/mpi_results.md).

Per substep a rank computes its particles and sends the P2G cache of every
owner block within reach of another rank. t = compute + halo / bandwidth +
latency; efficiency = compute / t (no overlap of compute and messages).
"""
import math

PARTICLE_BYTES = 148          # float build: 34 kf_real planes + id, colour, material, object
PPB = 512                     # particles per full 4^3 block at ppc 8
RECORD = {"whole cache (8^3 nodes)": (1 + 512) * 16, "touched part, as sent (at most 6^3)": (1 + 216) * 16}
RATE_CORE = 4.0e6             # particle-steps/s per core: measured 8.0 M/s on 2 threads (contended, see md)
CORES = 16                    # per rank (one node)
LATENCY = 10 * 20e-6          # ~10 collectives a substep at ~20 us each, times log2 N below


def halo_blocks(P, N, layout, reach=1):
    """owner blocks one rank sends per substep"""
    L = (P / PPB) ** (1 / 3)          # blocks along an edge of a cube of material
    if layout == "slabs":
        # a slab has two faces of L^2 blocks (ranks at the ends one); reach layers each
        if N > L:
            return float("nan")       # thinner than a block layer: slabs stop here
        return 2 * reach * L * L
    side = L / N ** (1 / 3)           # space-filling curve: near-cubic pieces
    return 6 * reach * side * side


def efficiency(P, N, gbit, layout, record):
    comp = P / N / (RATE_CORE * CORES)
    halo = halo_blocks(P, N, layout) * record
    comm = halo / (gbit * 1e9 / 8) + LATENCY * max(1, math.log2(N))
    return comp / (comp + comm), halo / (P / N * PARTICLE_BYTES)


def main():
    for rname, rec in RECORD.items():
        for layout in ("slabs", "sfc"):
            print(f"\n{layout}, halo record {rname}: efficiency (halo bytes / particle bytes per rank)")
            print("| particles | ranks | 10 Gbit/s | 25 Gbit/s | 100 Gbit/s |")
            print("|---|---|---|---|---|")
            for P in (100e6, 1e9):
                for N in (8, 64, 512):
                    row = []
                    for g in (10, 25, 100):
                        e, frac = efficiency(P, N, g, layout, rec)
                        row.append("n/a" if e != e else f"{100 * e:.0f}% ({100 * frac:.1f}%)")
                    print(f"| {P:.0e} | {N} | " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
