#!/usr/bin/env python3
"""An independent check of the asymptotic exponents in `exponents.csv` (docs/near-critical.md §5p).

Reads `running_exponents.csv`, builds one model's chain of running exponents (per pair of
neighbouring rungs the value of the finest ladder whose pair is not flagged: deep refined, then
refined, then uniform; the chain stops at the first pair, going down in |l|, that none of them
has unflagged) and fits three forms of corrections to scaling to it, at the pairs' geometric
mean |l| = L, with every fit range that drops 0 … 4 of the largest-|l| pairs:

  one correction      y = x + c L^ω                 (ω scanned)
  two, (ω, 2ω)        y = x + c1 L^ω + c2 L^(2ω)    (ω scanned)
  two, (ω1, ω2)       y = x + c1 L^ω1 + c2 L^ω2     (ω1 < ω2 scanned)

Unweighted least squares (equal weight per pair, as `kinds::exponents::asymptotic` since
session #16), ω on a grid of 0.01 (one and two (ω, 2ω)) or 0.05 (both free). Prints the
asymptote x, the best ω and the rms misfit of each fit. Written in plain Python (no numpy on
the reference machine): the fits are two- and three-column linear least squares, solved by
modified Gram–Schmidt.

Usage: scripts/asymptote_check.py results/tables/running_exponents.csv triangular zeta
"""

import csv
import math
import sys

ORDER = {"deep": 0, "refined": 1, "uniform": 2}


def chain(path, model, exponent, measure=None):
    """(L, value, l_hi, l_lo, method) of the chain, largest |l| first."""
    best = {}
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            if r["model"] != model or r["exponent"] != exponent:
                continue
            if measure is not None and r["measure"] != measure:
                continue
            if r["flag"].strip():
                continue
            method = r["method"]
            rank = min((v for k, v in ORDER.items() if method.startswith(k)), default=3)
            pair = (float(r["l_hi"]), float(r["l_lo"]))
            if pair not in best or rank < best[pair][0]:
                best[pair] = (rank, float(r["value"]), method)
    pairs = sorted(best, key=lambda p: -abs(p[0]))
    out = []
    for p in pairs:
        # the chain stops at a gap: the next pair must start where this one ends
        if out and abs(out[-1][3] - p[0]) > 1e-15 * abs(p[0]):
            break
        _, value, method = best[p]
        out.append((math.sqrt(abs(p[0] * p[1])), value, p[0], p[1], method))
    return out


def lstsq(columns, y):
    """Least squares of y on the columns (lists); returns (coefficients, rms misfit)."""
    q, rr = [], []
    for a in columns:
        v = list(a)
        coeffs = []
        for u in q:
            d = sum(ui * vi for ui, vi in zip(u, v))
            coeffs.append(d)
            v = [vi - d * ui for ui, vi in zip(u, v)]
        norm = math.sqrt(sum(vi * vi for vi in v))
        if norm == 0.0 or not math.isfinite(norm):
            return None, math.inf
        q.append([vi / norm for vi in v])
        rr.append(coeffs + [norm])
    qty = [sum(ui * yi for ui, yi in zip(u, y)) for u in q]
    k = len(q)
    x = [0.0] * k
    for i in range(k - 1, -1, -1):
        s = qty[i] - sum(rr[j][i] * x[j] for j in range(i + 1, k))
        x[i] = s / rr[i][i]
    fit = [sum(x[j] * columns[j][i] for j in range(k)) for i in range(len(y))]
    rms = math.sqrt(sum((a - b) ** 2 for a, b in zip(fit, y)) / len(y))
    return x, rms


def scan(ls, ys, exps_list):
    """The best fit over the exponent tuples: (rms, x, exps)."""
    best = (math.inf, math.nan, None)
    ones = [1.0] * len(ys)
    for exps in exps_list:
        cols = [ones] + [[l**w for l in ls] for w in exps]
        coef, rms = lstsq(cols, ys)
        if coef is not None and rms < best[0]:
            best = (rms, coef[0], exps)
    return best


def grid(lo, hi, step):
    n = int(round((hi - lo) / step))
    return [lo + i * step for i in range(n + 1)]


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    path, model, exponent = sys.argv[1:4]
    measure = sys.argv[4] if len(sys.argv) > 4 else None
    try:
        c = chain(path, model, exponent, measure)
    except OSError as e:
        sys.exit(f"{path}: cannot read: {e.strerror}")
    except (KeyError, ValueError) as e:
        sys.exit(f"{path}: not a running_exponents.csv (column or value {e})")
    if len(c) < 4:
        sys.exit(f"{path}: {model} {exponent}: {len(c)} chain pairs, at least 4 needed")
    print(f"{model} {exponent}: {len(c)} pairs, {c[0][2]:g}→{c[0][3]:g} … {c[-1][2]:g}→{c[-1][3]:g}")
    for _, v, hi, lo, m in c:
        print(f"  {hi:>9g} → {lo:<9g} {v:.5f}  {m}")
    one = [(w,) for w in grid(0.02, 2.0, 0.01)]
    two = [(w, 2 * w) for w in grid(0.02, 1.5, 0.01)]
    free = [(a, b) for a in grid(0.05, 1.5, 0.05) for b in grid(0.1, 3.0, 0.05) if b > a + 1e-9]
    print("drop  one correction (x, ω, rms)        two (ω, 2ω)                 two (ω1, ω2)")
    for drop in range(5):
        d = c[drop:]
        ls, ys = [p[0] for p in d], [p[1] for p in d]
        row = [f"{drop:>4}"]
        for exps, need in ((one, 4), (two, 5), (free, 5)):
            if len(d) < need:
                row.append(f"{'–':<27}")
                continue
            rms, x, e = scan(ls, ys, exps)
            w = ",".join(f"{v:.2f}" for v in e)
            row.append(f"{x:.4f} (ω {w}, {rms:.1e})".ljust(27))
        print("  ".join(row))


if __name__ == "__main__":
    main()
