#!/usr/bin/env python3
"""How much of the deep running ζ's (and β's, υ's) change can a shift of the load origin absorb?
(docs/near-critical.md §5t, issue 13.)

Each ladder's reduced load is l = p/p_c(D) − 1, with p_c(D) the load at which the refined
saddle closes. If the gap's power law has its own origin a little off p_c(D), g = A (|l| + δ)^ζ,
then ζ_eff over a pair reads ζ (1 − δ (1/l_lo − 1/l_hi)/ln(l_hi/l_lo)) for small δ: a correction
that grows as 1/|l|, the way the deep running ζ keep falling. This script fits A, ζ, δ to the
deepest 4, 5, 6 rungs of each ladder (least squares in ln g; δ by a fine scan, A and ζ by linear
regression at each δ), from the running ζ_eff the docs print (the rungs' gaps are rebuilt up to
a constant factor, which the fit does not see: ln g_i − ln g_{i−1} = ζ_eff ln(l_i/l_{i−1})).

Plain Python (no numpy), values in the script:
- square, k = 6, window 32 (`params/deeper.toml`, §5p table "Square to 5e-6→2e-6");
- triangular, k = 5 and 6, window 32, tol_gap 1e-10 (§5r: session #20's refined_deep_triangular
  stage of `params/deeper.toml`; ζ_eff to five digits from the rungs' saddle gaps in its cache,
  whose direct fit gives the same values to the printed digits);
- hexagonal, k = 5 (§5n, four digits) and 6, window 32 (§5n), and k = 6, window 64 (§5t), the
  same loads.
The square ladder at k = 5 is not here: §5p prints its k = 6 values and the size of the level
change only.
"""
import math

from asymptote_check import lstsq  # this directory's linear least squares (plain Python)

# the loads of the deep ladders: `params/deeper.toml` (square, triangular) and `params/deep.toml`
# (hexagonal; its rungs from −5e-4 down)
DEEPER = [5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5, 5e-6, 2e-6]
HEX = DEEPER[:6]

LADDERS = {
    "square k=6 w32 (§5p)": (
        DEEPER,
        [1.1665, 1.1603, 1.1556, 1.1517, 1.1479, 1.1450, 1.1422],
    ),
    "triangular k=5 w32 (§5r)": (
        DEEPER,
        [1.21136, 1.20102, 1.19334, 1.18538, 1.17834, 1.17317, 1.16823],
    ),
    "triangular k=6 w32 (§5r)": (
        DEEPER,
        [1.21140, 1.20108, 1.19342, 1.18557, 1.17882, 1.17410, 1.17003],
    ),
    "hexagonal k=5 w32 (§5n)": (
        HEX,
        [1.1433, 1.1405, 1.1384, 1.1372, 1.1379],
    ),
    "hexagonal k=6 w32 (§5n)": (
        HEX,
        [1.14314, 1.14016, 1.13762, 1.13543, 1.13410],
    ),
    "hexagonal k=6 w64 (§5t)": (
        HEX,
        [1.14329, 1.14007, 1.13732, 1.13469, 1.13251],
    ),
    # the neck conductance's β_eff (the flux K in place of g): k = 5 from §5n's k = 6 values
    # minus their level change (four digits), k = 6 windows 32 and 64 from the example's pair rows
    "hexagonal β k=5 w32 (§5n)": (
        HEX,
        [3.33795, 3.33177, 3.32734, 3.32616, 3.33650],
    ),
    "hexagonal β k=6 w32 (§5n)": (
        HEX,
        [3.33744, 3.33087, 3.32524, 3.32096, 3.31950],
    ),
    "hexagonal β k=6 w64 (§5t)": (
        HEX,
        [3.33781, 3.33047, 3.32411, 3.31816, 3.31329],
    ),
    # υ from the neck's rms width W_2: k = 5 as β above (§5n's level changes), k = 6 from the
    # example's pair rows
    "hexagonal υ k=5 w32 (§5n)": (HEX, [0.477644, 0.47890, 0.48002, 0.48176, 0.48329]),
    "hexagonal υ k=6 w32 (§5n)": (HEX, [0.47757, 0.47877, 0.47968, 0.48092, 0.48244]),
    "hexagonal υ k=6 w64 (§5t)": (HEX, [0.47762, 0.47871, 0.47951, 0.48050, 0.48153]),
}


def rebuild(ls, zetas):
    """ln g at every rung, up to a constant, from the running exponents."""
    lng = [0.0]
    for (hi, lo), z in zip(zip(ls, ls[1:]), zetas):
        lng.append(lng[-1] + z * math.log(lo / hi))
    return lng


def power_law(ls, lng, delta=0.0):
    """(ζ, rms misfit) of ln g = ln A + ζ ln(|l| + δ) at a given origin shift δ."""
    (_, z), rms = lstsq([[1.0] * len(ls), [math.log(l + delta) for l in ls]], lng)
    return z, rms


def fit(ls, lng, steps=40000):
    """ζ, δ and rms misfit of ln g = ln A + ζ ln(|l| + δ), δ scanned over ±|l|_min / 2."""
    lmin = min(ls)
    best = None
    for i in range(-steps, steps + 1):
        d = 0.5 * lmin * i / steps
        z, rms = power_law(ls, lng, d)
        if best is None or rms < best[2]:
            best = (z, d, rms)
    return best


def fixed(ls, lng):
    """ζ of the plain power law (δ = 0) over the same rungs."""
    return power_law(ls, lng)[0]


def selftest():
    """The fit recovers a known origin and exponent (synthetic rungs at the hexagonal loads,
    g = 2 (|l| + 3e-8)^1.15 exactly; δ is scanned in steps of |l|_min / 80000 = 1.25e-10) and
    gives δ = 0 back for a plain power law."""
    ls = HEX[2:]
    for delta in (3e-8, 0.0):
        lng = [math.log(2.0) + 1.15 * math.log(l + delta) for l in ls]
        z, d, rms = fit(ls, lng)
        assert abs(d - delta) <= 1.3e-10 and abs(z - 1.15) < 2e-5 and rms < 1e-5, (delta, z, d)


if __name__ == "__main__":
    selftest()
    print("| ladder | rungs | exponent, origin at p_c(D) | origin free | δ (p_c) | rms of ln y |")
    print("|---|---|---|---|---|---|")
    for name, (ls, zetas) in LADDERS.items():
        lng = rebuild(ls, zetas)
        for n in (4, 5, 6):
            if len(ls) < n:
                continue
            sl, sg = ls[-n:], lng[-n:]
            z, d, rms = fit(sl, sg)
            print(
                f"| {name} | {n}: {sl[0]:g} … {sl[-1]:g} | {fixed(sl, sg):.4f} | {z:.4f} "
                f"| {d:.2e} | {rms:.1e} |"
            )
