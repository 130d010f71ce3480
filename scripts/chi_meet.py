#!/usr/bin/env python3
"""Do χ from above and χ from below extrapolate to one limit? (docs/near-critical.md §5s)

The square model's two measurements of χ (grid-converged pairs only, each with its grid error):
from above, the running exponent of the blocked bridge's Hertz half-length (l > 0); from below,
that of the open neck's rise length (l < 0). Values: uniform 1024²/2048² and refined 256²-base
pairs of the paper preset (results/tables/running_exponents.csv, session #21's paper run) for
|l| ≥ 2e-3, the deep ladders at k = 5, 6 (`params/deeper.toml`, §5p) below. Both sequences are
fitted, at the pairs' geometric mean |l| = L, by y = x + c L^ω:

  separate   one limit per side (x_a, x_b), amplitudes c_a, c_b, one ω (scanned)
  shared     one limit x for both sides, amplitudes c_a, c_b, one ω (scanned)

weighted by 1/max(grid error, floor); Δχ² = χ²(shared) − χ²(separate) says how much a common
limit costs (one parameter: Δχ² = 1, 4 is 1σ, 2σ), and χ² with the limit fixed at 3/5 what
the conjecture costs. Repeated for error floors 2e-4 … 1e-3 and
fit ranges that drop the largest-|l| pairs. Plain Python (no numpy on the reference machine):
the fits are three- and four-column linear least squares by the normal equations.

Usage: scripts/chi_meet.py
"""

import math

# (l_hi, l_lo, value, grid error): |l|, positive
ABOVE = [
    (0.05, 0.02, 0.6195, 0.0038), (0.02, 0.01, 0.6187, 0.0025),
    (0.01, 0.005, 0.6149, 0.0042), (0.005, 0.002, 0.6124, 0.0048),
    (2e-3, 1e-3, 0.6047, 0.0008), (5e-4, 2e-4, 0.6002, 0.0019),
    (2e-4, 1e-4, 0.5966, 0.0021), (1e-4, 5e-5, 0.5957, 0.0012),
]
BELOW = [
    (0.005, 0.002, 0.5798, 0.0001), (2e-3, 1e-3, 0.5771, 0.0002),
    (1e-3, 5e-4, 0.5771, 0.0004), (5e-4, 2e-4, 0.5759, 0.0000),
    (2e-4, 1e-4, 0.5741, 0.0000), (1e-4, 5e-5, 0.5728, 0.0000),
    (5e-5, 2e-5, 0.5717, 0.0000), (2e-5, 1e-5, 0.5705, 0.0001),
    (1e-5, 5e-6, 0.5695, 0.0002), (5e-6, 2e-6, 0.5686, 0.0004),
]


def solve(a, b):
    """Least squares min |A p − b| by the normal equations (Gaussian elimination)."""
    m = len(a[0])
    n = [[sum(r[i] * r[j] for r in a) for j in range(m)] for i in range(m)]
    y = [sum(r[i] * v for r, v in zip(a, b)) for i in range(m)]
    for c in range(m):
        p = max(range(c, m), key=lambda r: abs(n[r][c]))
        n[c], n[p], y[c], y[p] = n[p], n[c], y[p], y[c]
        for r in range(c + 1, m):
            f = n[r][c] / n[c][c]
            n[r] = [x - f * z for x, z in zip(n[r], n[c])]
            y[r] -= f * y[c]
    p = [0.0] * m
    for c in reversed(range(m)):
        p[c] = (y[c] - sum(n[c][j] * p[j] for j in range(c + 1, m))) / n[c][c]
    chi2 = sum((sum(x * q for x, q in zip(r, p)) - v) ** 2 for r, v in zip(a, b))
    return p, chi2


def fit(above, below, shared, floor, fixed=None):
    """Best ω on a grid of 0.01 in [0.02, 1.5]: (χ², ω, parameters); `fixed`: the shared limit
    given (parameters then the two amplitudes)."""
    best = None
    for k in range(2, 151):
        w = k / 100
        rows, rhs = [], []
        for side, data in ((0, above), (1, below)):
            for hi, lo, v, e in data:
                s = 1 / max(e, floor)
                lw = math.sqrt(hi * lo) ** w
                if fixed is not None:
                    row = [lw if side == 0 else 0, lw if side == 1 else 0]
                    v -= fixed
                elif shared:
                    row = [1, lw if side == 0 else 0, lw if side == 1 else 0]
                else:
                    row = [1 - side, side, lw if side == 0 else 0, lw if side == 1 else 0]
                rows.append([x * s for x in row])
                rhs.append(v * s)
        p, chi2 = solve(rows, rhs)
        if best is None or chi2 < best[0]:
            best = (chi2, w, p)
    return best


def main():
    print("floor   drop(above,below)  separate: ω  χ²/dof  x_above  x_below | shared: ω  χ²  x | Δχ² | x = 3/5: χ²")
    for floor in (2e-4, 5e-4, 1e-3):
        for da, db in ((0, 0), (2, 0), (0, 3), (2, 3), (4, 5)):
            a, b = ABOVE[da:], BELOW[db:]
            cs, ws, ps = fit(a, b, False, floor)
            ch, wh, ph = fit(a, b, True, floor)
            c35 = fit(a, b, True, floor, fixed=0.6)[0]
            dof = len(a) + len(b) - 5
            print(
                f"{floor:.0e}  {da},{db}   {ws:.2f}  {cs:5.1f}/{dof:2d}  {ps[0]:.4f}  {ps[1]:.4f} | "
                f"{wh:.2f}  {ch:5.1f}  {ph[0]:.4f} | {ch - cs:4.1f} | {c35:7.1f}"
            )


if __name__ == "__main__":
    main()
