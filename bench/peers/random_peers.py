#!/usr/bin/env python3
"""tamaas beside the contact crate on a self-affine random surface (bench/peers/random.sh).

Reads DIR/surface_n{N}.npy (the surface `saddleflow surface generate` wrote: H = 0.8, q_r = 2,
q_s = 64 in units of 2pi/L, rms slope 1, exact amplitudes, seed 1, L = 1) and what
`RANDOM_DUMP=DIR cargo bench -p contact --bench random_surface` wrote for the same parameters:
DIR/random_heights_n{E}.f64 (E = log2 N; the bench's own realisation: it must equal the .npy
bit for bit, checked), DIR/random_pressure_n{E}.f64 (our pressure) and
DIR/random_case_n{E}.json (mean pressure). tamaas 2.9 (PolonskyKeerRey, basic_2d, E = 1,
nu = 0 so E* = 1, OMP_NUM_THREADS=1) solves the same hard-wall problem at the same mean
pressure; its tolerance is tightened along a ladder until the common metric of
contact_peers.py (our `max_violation` computed from a pressure field) is <= 1e-10, as in the
lattice benchmark.

Prints the contact areas (raw fraction of nodes with p > 0) and CPU seconds of both, their
difference and ratio, and one `RESULT solver=... n=...` line each.

Usage: random_peers.py DIR N   (N = grid points per side)
Environment: RANDOM_TARGET (1e-10), RANDOM_LADDER ("1e-10,1e-11,1e-12"), RANDOM_OURS_CPU (our
CPU seconds from the bench's RESULT line, printed in the ratio).
"""
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from contact_peers import metric, solve_tamaas, version  # noqa: E402

TARGET = float(os.environ.get("RANDOM_TARGET", "1e-10"))
LADDER = [float(x) for x in os.environ.get("RANDOM_LADDER", "1e-10,1e-11,1e-12").split(",")]


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    d, n = sys.argv[1], int(sys.argv[2])
    h = np.load(f"{d}/surface_n{n}.npy")
    if h.shape != (n, n):
        sys.exit(f"{d}/surface_n{n}.npy: shape {h.shape}, expected ({n}, {n})")
    e = n.bit_length() - 1  # the bench names its files by the grid exponent
    if n != 1 << e:
        sys.exit(f"N = {n}: allowed a power of two")
    h_bench = np.fromfile(f"{d}/random_heights_n{e}.f64", dtype="<f8").reshape(n, n)
    diff = np.abs(h - h_bench).max()
    print(f"n={n}: surface .npy vs the bench's realisation: max |difference| = {diff:.3e}")
    if diff != 0.0:
        sys.exit("the .npy is not the surface the bench solved (different generator parameters?)")
    case = json.load(open(f"{d}/random_case_n{e}.json"))
    pressure, lx, ly = case["pressure"], 1.0, 1.0
    p_ours = np.fromfile(f"{d}/random_pressure_n{e}.f64", dtype="<f8").reshape(n, n)
    v, a, g = metric(p_ours, h, lx, ly)
    print(f"n={n}: ours: violation={v:.3e} area={a:.8f} mean_gap={g:.10e} (load {pressure:.6e})")
    best = None
    for tol in LADDER:
        p, cpu, wall, its = solve_tamaas(h, lx, ly, pressure, tol)
        pv, pa, pg = metric(p, h, lx, ly)
        print(
            f"n={n}: tamaas {version('tamaas')} tol={tol:.0e} cpu={cpu:.2f}s wall={wall:.2f}s "
            f"it={its} violation={pv:.3e} area={pa:.8f} mean_gap={pg:.10e} "
            f"|p - p_ours|max={np.abs(p - p_ours).max():.2e}",
            flush=True,
        )
        best = (tol, cpu, wall, its, pv, pa, pg)
        if pv <= TARGET:
            break
    tol, cpu, wall, its, pv, pa, pg = best
    print(
        f"RESULT solver=tamaas n={n} cpu_s={cpu:.4f} wall_s={wall:.4f} iterations={its} "
        f"violation={pv:.3e} area={pa:.10f} mean_gap={pg:.12e} tol={tol:.0e} reached={pv <= TARGET}"
    )
    print(f"RESULT solver=ours-metric n={n} violation={v:.3e} area={a:.10f} mean_gap={g:.12e}")
    ours_cpu = os.environ.get("RANDOM_OURS_CPU")
    ratio = f"{cpu / float(ours_cpu):.2f}" if ours_cpu else "-"
    print(
        f"== n={n}: contact area ours {a:.8f}, tamaas {pa:.8f} (difference {pa - a:+.2e}, "
        f"{abs(pa - a) * n * n:.0f} nodes); mean gap difference {pg - g:+.2e}; CPU ours "
        f"{ours_cpu or '-'} s, tamaas {cpu:.2f} s, ratio tamaas/ours {ratio}"
    )


if __name__ == "__main__":
    main()
