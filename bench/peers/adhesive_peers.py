"""Peer of the adhesive benchmark (crates/contact/benches/adhesive.rs): tamaas 2.9's gap-primal
solver (`PolonskyKeerRey(model, h, tol, gap, gap)` with an `ExponentialAdhesionFunctional`,
Rey, Anciaux & Molinari 2017) on the square model, γ0 = 0.2, ρ = 0.04.

  python adhesive_peers.py tamaas DIR N MEAN_GAP   # solve, write DIR/tamaas_g_nN.f64 + case
  python adhesive_peers.py metric DIR N OURS.txt   # one metric for both codes' gap fields,
                                                   # CPU ratios from our bench's RESULT lines
  python adhesive_peers.py pairs DIR PAIRS.txt     # before/after table of adhesive_pair.sh

tamaas runs at an imposed mean gap; its mean traction is then the load at which ours solves
(bench/peers/adhesive.sh). The common metric is computed by one routine, `metric`, from each
code's gap field g (ours: u − h clipped at 0 from our displacement; tamaas: its gap field):
u = h + g, σ = K u (q E*/2 in Fourier space), and the force residual of our `residuals()`:
|σ + p̄ + γ'(g)| where g > 0, max(0, −(σ + p̄ + γ'(0))) where g = 0, with p̄ the load ours was
solved at; plus the mean gap and the contact area. E* = 1 (tamaas: E = 1, ν = 0).
"""

import json
import sys
import time

import numpy as np

from contact_peers import Capture

GAMMA0, RHO = 0.2, 0.04


def metric(g, h, pressure):
    n, m = h.shape
    qx = 2 * np.pi * np.fft.fftfreq(n, d=1.0 / n)
    qy = 2 * np.pi * np.fft.rfftfreq(m, d=1.0 / m)
    k = 0.5 * np.hypot(qx[:, None], qy[None, :])
    u = h + g
    sigma = np.fft.irfft2(np.fft.rfft2(u) * k, s=(n, m))
    wall = sigma + pressure + GAMMA0 / RHO * np.exp(-g / RHO)
    contact = g <= 0.0
    res = max(np.abs(wall[~contact]).max(initial=0.0), (-wall[contact]).max(initial=0.0))
    return res, g.mean(), contact.mean()


def run_tamaas(d, n, mean_gap):
    import tamaas as tm

    h = np.fromfile(f"{d}/heights_n{n}.f64", dtype="<f8").reshape(n, n)
    model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [1.0, 1.0], [n, n])
    model.E, model.nu = 1.0, 0.0
    solver = tm.PolonskyKeerRey(
        model, np.ascontiguousarray(h), 1e-10, tm.PolonskyKeerRey.gap, tm.PolonskyKeerRey.gap
    )
    adh = tm.ExponentialAdhesionFunctional(np.ascontiguousarray(h))
    adh.parameters = {"rho": RHO, "surface_energy": GAMMA0}
    solver.addFunctionalTerm(adh)
    solver.max_iter = 100000
    solver.dump_freq = 1
    c0, w0 = time.process_time(), time.perf_counter()
    with Capture() as cap:
        solver.solve(mean_gap)
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    its = max([int(l.split()[0]) for l in cap.text.splitlines() if l.split() and l.split()[0].isdigit()] or [0])
    # tamaas's displacement includes the rigid approach: its gap is u − h (checked: mean = target)
    g = np.array(model.displacement).reshape(n, n) - h
    print(f"tamaas gap: min {g.min():.3e} mean {g.mean():.12f} (target {mean_gap})", file=sys.stderr)
    g = np.maximum(g, 0.0)
    p = float(np.array(model.traction).mean())
    res = metric(g, h, p)[0]  # the accuracy tamaas reached, by the common metric
    g.astype("<f8").tofile(f"{d}/tamaas_g_n{n}.f64")
    json.dump(
        {"pressure": p, "cpu": cpu, "wall": wall, "iterations": its, "residual": res},
        open(f"{d}/tamaas_n{n}.json", "w"),
    )
    print(
        f"RESULT solver=tamaas n={n} gap={mean_gap} cpu_s={cpu:.6f} wall_s={wall:.6f} iterations={its} pressure={p!r} residual={res:.3e}",
        file=sys.stderr,
    )
    print(p, f"{res:.3e}")  # the load and the accuracy reached, for adhesive.sh


def ratios(ours_txt, tamaas_cpu, tamaas_gap):
    """tamaas CPU / our CPU for each of our solves (cold: at tamaas's load; warm: one step of
    0.01 p_fc on from our cold solution, against tamaas's cold solve), per tolerance, and whether
    the cold solve reached tamaas's state."""
    for line in open(ours_txt):
        if not line.startswith("RESULT"):
            continue
        kv = dict(f.split("=", 1) for f in line.split()[1:])
        same = abs(float(kv["mean_gap"]) - tamaas_gap) < 1e-8 if kv["case"] == "cold" else None
        print(
            f"RATIO n={kv['n']} case={kv['case']} tol={float(kv['tol']):.1e} ours={kv['method']}"
            f" iterations={kv['iterations']} cpu_s={float(kv['cpu']):.3f}"
            f" tamaas_cpu_s={tamaas_cpu:.3f} ratio={tamaas_cpu / float(kv['cpu']):.2f}"
            + ("" if same is None else f" same_state={'yes' if same else 'NO (another metastable state)'}")
        )


def run_metric(d, n, ours_txt=None):
    h = np.fromfile(f"{d}/heights_n{n}.f64", dtype="<f8").reshape(n, n)
    case = json.load(open(f"{d}/tamaas_n{n}.json"))
    p = case["pressure"]
    u = np.fromfile(f"{d}/ours_u_n{n}.f64", dtype="<f8").reshape(n, n)
    for name, g in [("ours", np.maximum(u - h, 0.0)), ("tamaas", np.fromfile(f"{d}/tamaas_g_n{n}.f64", dtype="<f8").reshape(n, n))]:
        res, mg, a = metric(g, h, p)
        print(f"RESULT metric={name} n={n} residual={res:.3e} mean_gap={mg:.15e} area={a:.9f}")
    if ours_txt:
        tg = np.fromfile(f"{d}/tamaas_g_n{n}.f64", dtype="<f8").mean()
        ratios(ours_txt, case["cpu"], tg)


def run_pairs(d, pairs_txt):
    """The before/after table of adhesive_pair.sh: per grid and mean gap the smallest CPU time
    of each binary's repeats (cold at tamaas's accuracy and at 1e-10, warm at 1e-10), its
    iterations, CPU per iteration and the ratio tamaas CPU / ours; FIRE from its single run.
    A nested cold start (contact::nonlinear_cg, 256² and finer) reports the iterations of every
    grid it solved, the cheap coarse ones included: its CPU per iteration is per iteration of
    any grid, not per fine-grid iteration, so it is not like-for-like with a plain solve's."""
    import collections

    cpu, its = collections.defaultdict(list), {}
    for line in open(pairs_txt):
        kv = dict(f.split("=", 1) for f in line.split()[1:])
        tol = "tight" if float(kv["tol"]) == 1e-10 else "tamaas"
        k = (int(kv["n"]), kv["gap"], kv["method"], kv["case"], tol, kv["who"])
        cpu[k].append(float(kv["cpu"]))
        its[k] = int(kv["iterations"])
    print("| grid, mean gap | tamaas: CPU, iterations (residual) | before, cold, tamaas's accuracy"
          " | after, cold, tamaas's accuracy | after, cold, 1e-10 | CPU per iteration (any grid) before → after"
          " | after, warm, 1e-10 | FIRE cold, 1e-10 |")
    print("|---|---|---|---|---|---|---|---|")
    for n, gap in sorted({(k[0], k[1]) for k in cpu}):
        t = json.load(open(f"{d}/tamaas_n{n}_g{gap}.json"))

        def cell(method, case, tol, who):
            k = (n, gap, method, case, tol, who)
            if k not in cpu:
                return None, None, "–"
            c = min(cpu[k])
            return c, its[k], f"{c:.3f} s, {its[k]} it: {t['cpu'] / c:.1f}×"

        b = cell("nonlinear-cg", "cold", "tamaas", "before")
        a = cell("nonlinear-cg", "cold", "tamaas", "after")
        per = f"{1e3 * b[0] / b[1]:.2f} → {1e3 * a[0] / a[1]:.2f} ms" if b[0] and a[0] else "–"
        print(f"| {n}², {gap} | {t['cpu']:.2f} s, {t['iterations']} ({t['residual']:.1e}) | {b[2]}"
              f" | {a[2]} | {cell('nonlinear-cg', 'cold', 'tight', 'after')[2]} | {per}"
              f" | {cell('nonlinear-cg', 'warm', 'tight', 'after')[2]}"
              f" | {cell('fire', 'cold', 'tight', 'after')[2]} |")


if __name__ == "__main__":
    if sys.argv[1] == "pairs":
        run_pairs(sys.argv[2], sys.argv[3])
    elif sys.argv[1] == "tamaas":
        run_tamaas(sys.argv[2], int(sys.argv[3]), float(sys.argv[4]))
    else:
        run_metric(sys.argv[2], int(sys.argv[3]), sys.argv[4] if len(sys.argv) > 4 else None)
