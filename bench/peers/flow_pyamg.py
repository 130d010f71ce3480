#!/usr/bin/env python3
"""PyAMG peer of the reynolds flow benchmark (crates/reynolds/benches/flow.rs).

Loads gap fields written by `FLOW_DUMP=DIR cargo bench -p reynolds --bench flow` (raw
little-endian f64, row-major (n, n), first index x, unit cell), builds the same finite-volume
system as the reynolds crate and solves it with PyAMG-preconditioned CG:

- face conductance: harmonic mean of g^3 of the two nodes, zero if either has g <= 0;
  coupling c * dy/dx on x-faces and c * dx/dy on y-faces;
- fluid pools not part of a cluster that winds around the cell along x are removed. Winding is
  detected on the two-fold cover of the torus along x: a cluster winds along x iff the two
  copies of its nodes are connected there (exact when the x-windings of the cluster are not all
  even, which holds for every field of the benchmark);
- a unit pressure drop along x, entering the right-hand side on the faces of the x-face column
  with the least total conductance (the same cut as the crate);
- the constant null space (one per flowing cluster) is removed by holding the cluster's node of
  largest gap at zero (Dirichlet), which leaves an SPD system for PyAMG.

Solvers: smoothed aggregation (`smoothed_aggregation_solver`) and classical Ruge-Stueben
(`ruge_stuben_solver`), both with default options, as preconditioners of CG (`accel='cg'`),
relative residual 1e-10 (PyAMG's criterion ||r|| <= tol ||b||). The flux is computed from the
dissipation, sum_faces s (dp)^2 / dP, as in the crate.

Prints a table and one `RESULT solver=... n=... eps=... setup_s=... solve_s=... wall_s=...`
line per solve. Usage: flow_pyamg.py FILE... (names gap_n{N}_eps{E}.f64).
"""
import os
import re
import sys
import time

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components
import pyamg


def load(path):
    m = re.search(r"gap_n(\d+)_eps([^/]+)\.f64$", path)
    if not m:
        sys.exit(f"{path}: expected a name gap_n<N>_eps<E>.f64")
    n = int(m.group(1))
    g = np.fromfile(path, dtype="<f8")
    if g.size != n * n:
        sys.exit(f"{path}: {g.size} values, expected {n}x{n}")
    return n, m.group(2), g.reshape(n, n)


def harmonic(a, b):
    out = np.zeros_like(a)
    ok = (a > 0) & (b > 0)
    out[ok] = 2.0 * a[ok] * (b[ok] / (a[ok] + b[ok]))
    return out


def winding_mask(fluid):
    """Nodes of 4-connected fluid clusters that wind along x (axis 0) on the torus."""
    nx, ny = fluid.shape
    f2 = np.concatenate([fluid, fluid], axis=0)  # two-fold cover along x
    n2 = 2 * nx * ny
    idx = np.arange(n2).reshape(2 * nx, ny)
    rows, cols = [], []
    for shift_axis in (0, 1):
        nb = np.roll(idx, -1, axis=shift_axis)
        ok = f2 & np.roll(f2, -1, axis=shift_axis)
        rows.append(idx[ok])
        cols.append(nb[ok])
    r = np.concatenate(rows)
    c = np.concatenate(cols)
    graph = sp.coo_matrix((np.ones(r.size, dtype=np.int8), (r, c)), shape=(n2, n2)).tocsr()
    _, labels = connected_components(graph, directed=False)
    labels = labels.reshape(2 * nx, ny)
    return fluid & (labels[:nx] == labels[nx:])


def build(g, lx=1.0, ly=1.0, dp=1.0):
    nx, ny = g.shape
    dx, dy = lx / nx, ly / ny
    g3 = np.where(g > 0, g ** 3, 0.0)
    keep = winding_mask(g3 > 0)
    g3k = np.where(keep, g3, 0.0)
    se = harmonic(g3k, np.roll(g3k, -1, axis=0)) * (dy / dx)  # (i,j)-(i+1,j)
    sn = harmonic(g3k, np.roll(g3k, -1, axis=1)) * (dx / dy)  # (i,j)-(i,j+1)
    cut = int(np.argmin(se.sum(axis=1)))
    idx = np.arange(nx * ny).reshape(nx, ny)
    i_e, i_n = np.roll(idx, -1, axis=0), np.roll(idx, -1, axis=1)
    a = np.concatenate([idx[se > 0], idx[sn > 0]])
    b = np.concatenate([i_e[se > 0], i_n[sn > 0]])
    s = np.concatenate([se[se > 0], sn[sn > 0]])
    N = nx * ny
    off = sp.coo_matrix((s, (a, b)), shape=(N, N))
    off = (off + off.T).tocsr()
    diag = np.asarray(off.sum(axis=1)).ravel()
    A = (sp.diags(diag) - off).tocsr()
    rhs = np.zeros(N)
    cp = (cut + 1) % nx
    rhs[idx[cut]] -= se[cut] * dp
    rhs[idx[cp]] += se[cut] * dp
    # Unknowns: flowing nodes minus one pin per flowing cluster (largest gap).
    flowing = (diag > 0)
    ncomp, comp = connected_components(off, directed=False)
    comp = comp.reshape(-1)
    gflat = g.reshape(-1)
    pins = []
    fl_comps = np.unique(comp[flowing])
    order = np.lexsort((-gflat, comp))  # by component, largest gap first
    first = np.ones(order.size, dtype=bool)
    first[1:] = comp[order[1:]] != comp[order[:-1]]
    for v in order[first]:
        if flowing[v]:
            pins.append(v)
    unknown = flowing.copy()
    unknown[pins] = False
    sel = np.flatnonzero(unknown)
    Ar = A[sel][:, sel].tocsr()
    br = rhs[sel]
    return dict(A=Ar, b=br, sel=sel, N=N, se=se, sn=sn, cut=cut, shape=(nx, ny), dp=dp,
                flowing=int(flowing.sum()), ncomp=len(fl_comps))


def flux_from(sys_, x):
    nx, ny = sys_["shape"]
    u = np.zeros(sys_["N"])
    u[sys_["sel"]] = x
    u = u.reshape(nx, ny)
    drop_x = u - np.roll(u, -1, axis=0)
    drop_x[sys_["cut"]] += sys_["dp"]
    drop_y = u - np.roll(u, -1, axis=1)
    diss = (sys_["se"] * drop_x ** 2).sum() + (sys_["sn"] * drop_y ** 2).sum()
    q = diss / sys_["dp"]
    cols = (sys_["se"] * drop_x).sum(axis=1)
    cons = np.max(np.abs(cols - q)) / q if q > 0 else float("inf")
    return q, cons


def run(name, make, sys_, tol):
    A, b = sys_["A"], sys_["b"]
    t0 = time.perf_counter()
    c0 = time.process_time()
    ml = make(A)
    t1 = time.perf_counter()
    res = []
    x = ml.solve(b, tol=tol, accel="cg", maxiter=500, residuals=res)
    t2 = time.perf_counter()
    cpu = time.process_time() - c0
    rel = np.linalg.norm(b - A @ x) / np.linalg.norm(b)
    q, cons = flux_from(sys_, x)
    return dict(solver=name, setup=t1 - t0, solve=t2 - t1, wall=t2 - t0, cpu=cpu,
                iters=len(res) - 1, rel=rel, flux=q, cons=cons)


def main():
    files = sys.argv[1:]
    if not files:
        sys.exit(__doc__)
    tol = float(os.environ.get("FLOW_TOL", "1e-10"))
    solvers = os.environ.get("PYAMG_SOLVERS", "sa,rs").split(",")
    makers = {
        "sa": ("pyamg-sa-cg", lambda A: pyamg.smoothed_aggregation_solver(A, symmetry="symmetric")),
        "rs": ("pyamg-rs-cg", lambda A: pyamg.ruge_stuben_solver(A)),
    }
    print(f"{'solver':>12} {'n':>5} {'eps':>7} {'build_s':>8} {'setup_s':>8} {'solve_s':>8} "
          f"{'total_s':>8} {'cpu_s':>7} {'iter':>5} {'residual':>9} {'conserv':>9} {'K':>13}")
    for path in files:
        n, eps, g = load(path)
        t0 = time.perf_counter()
        s = build(g)
        tb = time.perf_counter() - t0
        for key in solvers:
            name, make = makers[key]
            r = run(name, make, s, tol)
            print(f"{name:>12} {n:>5} {float(eps):>7.0e} {tb:>8.3f} {r['setup']:>8.3f} "
                  f"{r['solve']:>8.3f} {r['wall']:>8.3f} {r['cpu']:>7.2f} {r['iters']:>5} "
                  f"{r['rel']:>9.2e} {r['cons']:>9.2e} {r['flux']:>13.6e}", flush=True)
            print(f"RESULT solver={name} n={n} eps={float(eps):e} threads=1 build_s={tb} "
                  f"setup_s={r['setup']} solve_s={r['solve']} wall_s={r['wall']} cpu_s={r['cpu']} "
                  f"iterations={r['iters']} residual={r['rel']:e} conservation={r['cons']:e} "
                  f"flux={float(r['flux'])!r}", flush=True)


if __name__ == "__main__":
    main()
