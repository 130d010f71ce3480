#!/usr/bin/env python3
"""Peers of the hard-wall contact benchmark (crates/contact/benches/hardwall.rs): tamaas and
ContactMechanics on the same problems, judged by the same accuracy metric.

Reads, per grid size N, what `HARDWALL_DUMP=DIR cargo bench -p contact --bench hardwall` wrote:
DIR/heights_n{N}.f64 (the sampled square model, raw little-endian f64, row-major (N, N), first
index x), DIR/pressure_n{N}.f64 (our pressure) and DIR/case_n{N}.json (cell, mean pressure).

Problem: flat elastic half-space (E* = 1) on the rigid periodic surface h, mean pressure
0.3 p_fc, hard wall. Both peers use the same kernel as ours, sigma(q) = q E*/2 u(q):
- tamaas 2.9: `ModelFactory.createModel(model_type.basic_2d, [Lx, Ly], [N, N])` with E = 1,
  nu = 0 (so E* = E/(1 - nu^2) = 1), `PolonskyKeerRey(model, h, tol).solve(mean pressure)`;
  the traction field is the pressure. Single-threaded: OMP_NUM_THREADS=1 (set by contact.sh).
- ContactMechanics: `PeriodicFFTElasticHalfSpace((N, N), 1.0, physical_sizes=(Lx, Ly))`
  (young = contact modulus for poisson = 0; its stiffness pi E* |q| with q in 1/length is
  q E*/2 with q in rad/length) and `constrained_conjugate_gradients(substrate, h,
  external_force = p * Lx * Ly, pentol=tol)`; pressure = jac / area per pixel.
Before timing anything the script checks that each peer's contact area and mean gap agree with
ours (they must, to the accuracy).

One accuracy metric for everybody (ours included): from a pressure field p, u = G p with numpy
FFTs and the kernel 2/(|q| E*) (zero mean), d = u - h, S = {p > 0}, the rigid approach
delta = mean_S d, g = d - delta, and

    violation = max( max_S |g|, max_{not S} (-g) )

(the largest gap where the wall pushes and the largest penetration where it does not: the
`max_violation` our solver stops on). Each peer's own tolerance is tightened (a ladder of cold
solves) until the violation is <= the target (1e-10), or the script reports that it could not.

Prints a table and one `RESULT solver=... n=... cpu_s=... wall_s=... iterations=...
violation=... tol=... reached=...` line per peer and size, plus `RESULT solver=ours-metric` with
the metric of our own pressure.

Usage: contact_peers.py DIR N [N ...]   (N = grid points per side, e.g. 1024)
Environment: CONTACT_TARGET (default 1e-10), CONTACT_LADDER (default "1e-10,1e-11,1e-12":
tolerances to try in turn; tamaas's and ContactMechanics' own criteria differ from ours),
CONTACT_PEERS (default "tamaas,contactmechanics"), CONTACT_PEER_MAX_CPU (default 600: skip
further ladder steps once one solve has cost this many CPU seconds).
"""
import contextlib
import io
import json
import os
import sys
import tempfile
import time
import warnings

import numpy as np

TARGET = float(os.environ.get("CONTACT_TARGET", "1e-10"))
LADDER = [float(x) for x in os.environ.get("CONTACT_LADDER", "1e-10,1e-11,1e-12").split(",")]
PEERS = os.environ.get("CONTACT_PEERS", "tamaas,contactmechanics").split(",")
MAX_CPU = float(os.environ.get("CONTACT_PEER_MAX_CPU", "600"))


def load(d, n):
    meta = json.load(open(f"{d}/case_n{n}.json"))
    h = np.fromfile(f"{d}/heights_n{n}.f64", dtype="<f8").reshape(n, n)
    p = np.fromfile(f"{d}/pressure_n{n}.f64", dtype="<f8").reshape(n, n)
    return meta, h, p


def metric(p, h, lx, ly):
    """Our max_violation, contact area and mean gap of a pressure field."""
    n, m = h.shape
    qx = 2 * np.pi * np.fft.fftfreq(n, d=lx / n)
    qy = 2 * np.pi * np.fft.rfftfreq(m, d=ly / m)
    k = 0.5 * np.hypot(qx[:, None], qy[None, :])
    k[0, 0] = np.inf
    u = np.fft.irfft2(np.fft.rfft2(p) / k, s=(n, m))
    d = u - h
    s = p > 0
    g = d - d[s].mean()
    off = (-g[~s]).max() if (~s).any() else 0.0
    return max(np.abs(g[s]).max(), off), s.mean(), np.maximum(g, 0.0).mean()


class Capture:
    """Captures tamaas's iteration log, whether it goes through Python's sys.stdout or straight
    to file descriptor 1 or 2."""

    def __enter__(self):
        sys.stdout.flush()
        sys.stderr.flush()
        self.saved = (os.dup(1), os.dup(2))
        self.tmp = tempfile.TemporaryFile()
        os.dup2(self.tmp.fileno(), 1)
        os.dup2(self.tmp.fileno(), 2)
        self.buf = io.StringIO()
        self.redirect = contextlib.redirect_stdout(self.buf)
        self.redirect.__enter__()
        return self

    def __exit__(self, *exc):
        self.redirect.__exit__(*exc)
        sys.stdout.flush()
        sys.stderr.flush()
        for fd, saved in zip((1, 2), self.saved):
            os.dup2(saved, fd)
            os.close(saved)
        self.tmp.seek(0)
        self.text = self.tmp.read().decode(errors="replace") + self.buf.getvalue()
        self.tmp.close()


def solve_tamaas(h, lx, ly, pressure, tol):
    import tamaas as tm

    n, m = h.shape
    model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [lx, ly], [n, m])
    model.E = 1.0
    model.nu = 0.0
    solver = tm.PolonskyKeerRey(model, np.ascontiguousarray(h), tol)
    solver.max_iter = 100000
    solver.dump_freq = 1
    c0, w0 = time.process_time(), time.perf_counter()
    with Capture() as cap:
        solver.solve(pressure)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    its = 0
    for line in cap.text.splitlines():
        parts = line.split()
        if parts and parts[0].isdigit():
            its = max(its, int(parts[0]))
    return np.array(model.traction).reshape(n, m).copy(), cpu, wall, its


def solve_cm(h, lx, ly, pressure, tol):
    from ContactMechanics import PeriodicFFTElasticHalfSpace
    from ContactMechanics.Optimization import constrained_conjugate_gradients

    n, m = h.shape
    sub = PeriodicFFTElasticHalfSpace((n, m), 1.0, physical_sizes=(lx, ly))
    c0, w0 = time.process_time(), time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # forcetol bounds the tensile force it zeroes anyway; the penetration tolerance pentol is
        # the criterion comparable to ours.
        res = constrained_conjugate_gradients(
            sub, h, external_force=pressure * lx * ly, pentol=tol, forcetol=1e-30, maxiter=100000
        )
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    if not res.success:
        raise RuntimeError(f"ContactMechanics did not converge: {res.message}")
    return np.asarray(res.jac) / sub.area_per_pt, cpu, wall, int(res.nit)


SOLVERS = {"tamaas": solve_tamaas, "contactmechanics": solve_cm}


def version(name):
    import importlib.metadata as md

    return md.version({"tamaas": "tamaas", "contactmechanics": "ContactMechanics"}[name])


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    d = sys.argv[1]
    for n in map(int, sys.argv[2:]):
        meta, h, p_ours = load(d, n)
        lx, ly, pressure = meta["lx"], meta["ly"], meta["pressure"]
        v, a, gm = metric(p_ours, h, lx, ly)
        print(f"n={n}: ours (metric of our pressure) violation={v:.3e} area={a:.8f} mean_gap={gm:.10e}")
        print(f"RESULT solver=ours-metric n={n} violation={v:.3e} contact_area={a:.10f} mean_gap={gm:.12e}")
        for name in PEERS:
            solve = SOLVERS[name]
            best = None
            for tol in LADDER:
                p, cpu, wall, its = solve(h, lx, ly, pressure, tol)
                pv, pa, pg = metric(p, h, lx, ly)
                # Same problem? Contact areas and mean gaps must agree to the accuracy.
                same = abs(pa - a) <= 2.0 / (n * n) and abs(pg - gm) <= 1e-8
                print(
                    f"n={n}: {name} {version(name)} tol={tol:.0e} cpu={cpu:.2f}s wall={wall:.2f}s "
                    f"it={its} violation={pv:.3e} area={pa:.8f} mean_gap={pg:.10e} "
                    f"|p - p_ours|max={np.abs(p - p_ours).max():.2e} same_problem={same}",
                    flush=True,
                )
                if not same:
                    sys.exit(f"{name} solves a different problem (area {pa} vs {a}, mean gap {pg} vs {gm})")
                best = (tol, p, cpu, wall, its, pv)
                if pv <= TARGET or cpu > MAX_CPU:
                    break
            tol, p, cpu, wall, its, pv = best
            print(
                f"RESULT solver={name} n={n} cpu_s={cpu:.4f} wall_s={wall:.4f} iterations={its} "
                f"violation={pv:.3e} tol={tol:.0e} reached={pv <= TARGET}",
                flush=True,
            )


if __name__ == "__main__":
    main()
