//! The refined ladder: the saddle gap g_s (and the channel's width and length, for υ and χ) at
//! reduced loads down to |l| = 1e-5 on a composite
//! discretisation that resolves one saddle 2^k times finer than the periodic base grid
//! ([`contact::refinement`], blockwise operator, two-level preconditioner).
//!
//! # The discretisation D and its p_c
//! D = (model, base grid 2^n, levels k, window of w × w base cells centred on the model's axis
//! saddle ([`crate::ladder::axis_saddle`] on the base grid), margin m base cells of the
//! blockwise operator). Every D is its own discrete problem: its saddle node (fine node
//! (2^k i, 2^k j) of the base node (i, j) of the saddle) closes at its own load, **p_c(D)**, the
//! load at which D's saddle node first carries pressure (gap exactly 0 in the Polonsky–Keer
//! solution). p_c(D) differs from the uniform fine grid's by the far-field error of the coarse
//! representation outside the window (see `contact::refinement`, ~1e-7 … 1e-5 relative), and
//! from the continuum's by more; the ladder's reduced loads l = p/p_c(D) − 1 are measured from
//! D's own p_c, so that a p_c shift common to all rungs does not masquerade as a change of the
//! exponent (docs/near-critical.md, "L_c: each grid's bisected L_c"). Only the axis saddle is
//! refined: in the
//! hexagonal and triangular cells the other critical saddles stay on the coarse base grid, so
//! the percolation load of the whole cell is not p_c(D); p_c(D) is the closing load of the
//! refined saddle alone (by symmetry every saddle closes at the same load in the continuum).
//!
//! # The p_c search ([`find_closing_load`])
//! Near p_c, g_s ≈ A (p_c − p)^a, so y = g_s^(1/a) is linear in p and the zero of the line
//! through the two open probes nearest p_c (secant) is p_c. The exponent a is not 1.2 there:
//! on a discretisation the contact set stops changing close enough to p_c, and on a fixed
//! contact set the hard-wall solution is affine in the load, so g_s turns linear (a = 1) below
//! some δ = 1 − p/p_c (on 64² k = 2 already at δ ~ 1e-4: ζ_eff = 1.0000 there; on 256², k = 3,
//! 4 between 1e-7 and 1e-6: the local exponent of the probes rose 1.19 → 1.30 and fell to 1.0).
//! With a ≥ the true local exponent's lower bound the secant undershoots (g convex in p) and
//! lands open; with a too large it overshoots into the closed side, where g = 0 gives no value.
//! Two open probes use a = `zeta0` (default 1: never overshoots a convex law); three use the
//! a ∈ [1, 3] that makes them collinear in g^(1/a) (exact for a pure power law and for the
//! affine regime). Probes closer than 4 tol to each other are not paired (their gaps differ by
//! solver noise).
//!
//! [`Search::Aimed`] (the default since 2026-11-26) aims each probe below the zero `est` by
//! min(θ d, 2u) (d = est − lo, θ = `aim_below` = 0.02, u = the change of `est` since the last
//! step: once the law is resolved the zeros stop moving and the probe lands just below p_c)
//! and closes the bracket with one probe at lo (1 + 0.9 tol) once est + u is within the
//! tolerance of lo, or with a probe 2 resolutions above est once est is within 4 resolutions
//! (resolution = 0.45 tol). A fitted zero at or above a closed probe is an overshoot: then the
//! straight secant (a = 1, a lower bound for a convex law), every second time the midpoint of
//! [straight zero, closed probe], or, when the straight zero reaches the closed probe too,
//! steps down from it by 2, 4, 8 … resolutions. The search starts from the warm-up solve
//! [`Refinement::critical_load`] does 1 % below the guess anyway (a seed: an open probe for
//! free), probes guess (1 − width) and, if closed, steps down by widths growing 8× (the old
//! search halved the load: 9 probes to climb back on a 64² base whose base-grid guess was
//! 3e-4 off). Safeguards: a bracket within 8 resolutions, or a zero that is not finite or not
//! above lo, bisects; and a probe budget: from the first bracket on, at most 4 probes more than
//! bisection of that bracket (`BUDGET_SPARE`; bisection from there when spent). Result: [lo,
//! hi] with hi/lo − 1 ≤ tol (default 1e-11), lo open, hi closed, p_c the midpoint.
//! [`Search::Secant`] (the search until 2026-11-26: always θ d below, no seed, bisection after
//! two probes that do not halve the bracket) and [`Search::Bisection`] stay for comparison.
//!
//! Where the probes went (`REFINED_PC_TRACE=1` of `examples/refined_ladder.rs`; square, 256²
//! base, window 16, margin 8, tol_gap 1e-12; old = `Secant` with the next D's width 2e-5,
//! new = `Aimed` with 2e-6): D(3) from the periodic base guess (3e-5 off, width 2e-4): old 11
//! probes — 4 secant steps from δ = 1.7e-4 to 7e-7 (each 2–25× closer: a = 1 on a law with
//! local exponent 1.2–1.3), 4 alternating open/closed around 1e-7…1e-8, 3 to close — new 10
//! (3 to δ = 2e-7, 3 overshoots to −3e-9…−3e-11, then closing at the tolerance). D(4) from
//! D(3)'s p_c: old 11 (δ = 2e-5 → 2e-6 → 2e-7 → 8e-9, two overshoots, 3 to close), new 8 (first
//! probe at δ = 1.5e-6, 2 to 3e-8, two overshoots, a probe at 4.5e-12 below p_c from the
//! straight secant through two affine-regime probes, one closing). Cost per probe (iterations,
//! warm-started from the last probe; Δ = relative distance from it): the first probe after the
//! warm-up 57–102, Δ ~ 1e-4 … 1e-6: 33–46, Δ ~ 1e-7: 22–28, Δ ~ 1e-8 … 1e-9: 13–26, Δ ≤ 1e-10:
//! 5–15: the far probes cost 3–8× the closing ones, so a tighter start saves more than its
//! count. Search wall (load 8–12 on 2 cores, one run each, back to back): D(3) 19.7 s → 9.6 s,
//! D(4) 79.1 s → 52.3 s (of which the warm-up solve ~17 s).
//!
//! Old → new, one run each, back to back (`REFINED_PC_TRACE=1 REFINED_COMPARE=levels
//! refined_ladder <model> 8 <k> <w> 8 -1e-3,-1e-4,-1e-5`, the old binary built at 833e17e):
//! probes, iterations (including the warm-up solve), search wall:
//!
//! | D (256² base)                           | probes  | iterations | search s     |
//! |-----------------------------------------|---------|------------|--------------|
//! | square k = 2, w 32, from base (1e-13)   | 13 → 8  | 443 → 324  | 11.3 → 13.1  |
//! | square k = 3, w 32, from k = 2          | 11 → 5  | 469 → 259  | 20.1 → 21.4  |
//! | square k = 3, w 16, from base (1e-12)   | 11 → 10 | 337 → 310  | 19.7 → 9.6   |
//! | square k = 4, w 16, from k = 3          | 11 → 8  | 462 → 365  | 79.1 → 52.3  |
//! | triangular k = 3, w 16, from base (5e-12)| 19 → 11 | 454 → 414 | 15.1 → 18.5  |
//! | triangular k = 4, w 16, from k = 3      | 15 → 7  | 661 → 391  | 89.4 → 57.5  |
//!
//! (tol_gap in brackets; triangular max_iter 400.) In all 80 → 49 probes, 2826 → 2063
//! iterations; wall times are noisy at load 8–12 (the whole k = 4 runs: square 142 → 94 s,
//! triangular 144 → 119 s). p_c(D) agreed within the brackets (≤ 1.6e-12 relative) but for the
//! triangular D's at tol_gap 5e-12 (+2.8e-11 and −1.1e-11: the floor below), and the running
//! ζ_eff of every D by ≤ 5.5e-8 (square) and ≤ 1.7e-6 (triangular, −1e-4 → −1e-5).
//! 1024² base, square D(3) (window 32, margin 12, tol_gap 5e-12) from D(4)'s p_c (4.2e-8 below
//! its own; `REFINED_COMPARE=none REFINED_PC_GUESS=0.2286048431383601 … square 10 3 32 12`):
//! 14 → 8 probes, 351 → 259 iterations, search 215 → 101 s (load 11–12). The two p_c's differ
//! by 2.8e-11, beyond their brackets: the new search found closed a load 4.6e-12 below one
//! the old search found open; at tol_gap 5e-12 the open/closed answer there depends on the
//! warm start (the floor below).
//!
//! Widths: the next D's p_c lies 5.5e-7 (square) and 5.8e-7 (triangular) from the previous
//! D's on 256² bases (paper run, k = 3 → 4; margin 12 → 16: 5e-9 … 5e-8), 2.7e-8 … 4.2e-8 on
//! 1024² bases; the refined_ladder kind now starts the next D with width 2e-6 (was 2e-5; a miss
//! costs a probe or two: the search steps down 8× or extends up). The first D keeps 2e-4 from
//! the periodic base grid's p_c (3e-5 off on 256², 3e-4 on 64²).
//!
//! Precision: ζ_eff between rungs l₁ = −2e-5 and l₂ = −1e-5 moves by ζ ε (1/|l₂| − 1/|l₁|) /
//! ln 2 = 7.2e4 ζ ε for a relative p_c error ε; unchanged to 1e-5 needs ε ≤ 1.2e-10, i.e. a
//! bracket rel_tol ≤ 2e-10 (midpoint error ≤ half of it). The default 1e-11 is 20× inside that
//! and kept (not measured looser; at the end the aimed search spends 1–2 probes on the last
//! decade, the cheapest ones: 5–15 iterations each).
//!
//! A bracket tied to the ladder's smallest |l| instead (session #21, tried, not kept): a 1-2-5
//! pair moves by at most 0.72 x ε/|l_min| (the factor-2 pairs), so with x ≤ 3.5 (β) a bracket
//! of 5e-6 |l_min| keeps every running exponent within 6.4e-6 (checked on pure power laws:
//! 6.3e-6 at the deepest pair). On the paper preset's hexagonal D(4) (1024² base, window 32,
//! margin 12, tol_gap 5e-12, from D(3)'s p_c, one thread each, side by side:
//! `REFINED_COMPARE=none REFINED_PC_TRACE=1 REFINED_TOL_GAP=5e-12 REFINED_REL_TOL=…
//! REFINED_PC_GUESS=0.031722753378181666 refined_ladder hexagonal 10 4 32 12 -1e-4`) it pays:
//! rel_tol 1e-11 took 22 probes, 367 iterations, 119.3 s, of which the last 13 probes bisect
//! within the solver's floor (open at gaps of 1e-12 … 9e-11 h0 between closed probes 2e-10
//! above); 1e-9 took 9 probes, 288 iterations, 87.6 s; the p_c's 1.3e-10 apart. Through the
//! whole paper study it does not: two cold runs of `saddleflow run --params params/paper.toml
//! --only near_critical -j 2` (HEAD 6deb0cf against the rule in `refined_ladder` and
//! `refined_window`), 30 min 45 s and 30 min 46 s wall, 3431 and 3435 CPU-s; per stage
//! refined_deep_hexagonal 317 → 287 CPU-s (−9 %), every other stage within ±5 % (noise; the
//! square and triangular deep ladders reach 1e-5, where the rule gives 5e-11, and the early,
//! far probes cost most). Every running exponent of the draft moved by ≤ 6e-6 with it. Not worth
//! changing every refined result for.
//!
//! The floor: near p_c, dg_s/dδ ≈ 0.1 h0 (square model, affine regime), so a solver tolerance
//! tol_gap resolves δ ≈ 10 tol_gap: 1e-12 at tol_gap 1e-13, 5e-11 at 5e-12. Below that the
//! open/closed answer itself is noise and the search ends by bisection (k = 5 at 5e-12: 21
//! probes). At |l| = 1e-5 a p_c error of 5e-11 shifts l by 5e-6 of itself: negligible. This
//! estimate is pessimistic for warm-started probes: at tol_gap 1e-12 (256², k = 4) the gaps of
//! the last probes followed the affine law to ~1e-14 (g = 4.0e-13 at 2.1e-12 below p_c,
//! closed 1.4e-12 above), so [`Search::Aimed`] does not widen its resolution by tol_gap.
//!
//! Solver floor: the composite solve does not reach tol_gap = 1e-13 everywhere (k = 4 square
//! and k = 3 triangular near p_c stagnated at violations of 1–3e-12 after 3000 iterations);
//! the runs below use 1e-13 (k ≤ 3 square), 1e-12 (k = 4 square) and 5e-12 (k = 5 square,
//! triangular), each far below the smallest saddle gap (~6e-7 h0 at l = −1e-5).
//!
//! # The ladder ([`Refinement::ladder`])
//! Rungs at l < 0 (the 1-2-5 sequence by default, [`default_ls`]), solved in ascending
//! load from the previous rung's solution. Each rung records the saddle gap, iterations, wall
//! time and the contact lines on the window's edge ([`contact::refinement::EdgeRuns`]); a rung
//! whose window is too small — no or fewer than four contact-line crossings (the neck's two
//! contact patches must both cross the edge), or a run of open or contact nodes on the edge
//! shorter than `min_edge_cells` base cells — is flagged ([`RungFlag`]) and so is every pair
//! that uses it. Each rung's [`Refined`] is handed to a callback (the window flux can be wired
//! in there).
//!
//! # The window check
//! "Too small" means that the neck's structure reaches the window's edge: the open channel or
//! the contact bridge crosses it narrower than `min_edge_cells` = 2 base cells (its width there
//! is not yet the far channel's), or the edge crosses no contact line or only one patch (fewer
//! than 4 crossings: the contact lines bounding the neck lie outside, on the coarse grid). The
//! edge is read on the region's second ring of fine nodes, and runs of 1–2 fine nodes are
//! merged into their neighbours first ([`contact::refinement::SLIVER_NODES`]): the outermost
//! ring's base nodes carry the coarse hats, and their hat-mean contact state made one-node
//! runs wherever a contact line met the edge beside one (the triangular flags below, which
//! were 12 crossings and runs of 1/2^k base cells). A run of ≤ 2 fine nodes is below the
//! lattice's resolution of a contact line; a real structure of that width on the edge is
//! merged away, which leaves fewer than 4 crossings and flags the window all the same, and
//! one of 3 nodes up to 2 base cells stays a narrow run (tests: `contact::refinement`,
//! `a_grazing_contact_line_is_not_a_window_too_small` and `a_too_small_window_is_flagged` in
//! tests/refined.rs).
//!
//! # Running ζ ([`running_zeta`])
//! ζ_eff = Δ ln g_s / Δ ln |l| between neighbouring rungs of the finest D; its grid error is the
//! larger of the changes from D with k − 1 levels and from D with another margin (the far-field
//! interpolation error acts as a shift of l by ~1e-7 … 1e-6, which matters at |l| = 1e-5). A
//! pair is flagged if either change exceeds the bound, is unknown, or a rung is flagged, and
//! also if the window's contact set is the same at both rungs ([`PairFlag::Frozen`]): on a fixed
//! contact set the solution is affine in the load and the slope is the discretisation's (→ 1).
//! Each rung also records `neck_nodes`, the open fine nodes across the channel through the
//! saddle: the neck's resolution (square, k = 5: 19 at l = −1e-5). `fit_error` is the
//! propagated solver tolerance only (σ_g = tol_gap: the saddle gap is a node value, not a fit,
//! so its only measurement error is how well the solve fixes it, relative to g_s).
//!
//! # Refined υ and χ ([`Refinement::saddle_window`], [`running_exponent`])
//! Every rung also cuts a [`crate::ladder::Window`] out of the fine region around the saddle
//! (fine spacing, channel frame, the largest node-centred rectangle inside the region without
//! its outermost ring of fine nodes) and measures on it what the uniform ladders measure on
//! theirs: below p_c(D) the open channel's half-width r_c ([`open_half_width`], square-root
//! onset across the channel), above it the blocked channel's half-length a
//! ([`blocked_half_length`], Hertz fit along the channel; `ls` may hold l > 0 for this: those
//! rungs are not flagged for a closed saddle). A failed fit leaves the rung out of that
//! exponent (its pair widens; [`RefinedRung::edge_note`] says why), and so does an onset fit
//! whose range ((1 + span) r_c) reaches beyond the fine window, where the uniform windows would
//! have fitted more nodes (draft, 128² base, window 16: r_c ≈ 0.046 λ at l = −0.02 against a
//! window half-width of 0.061 λ). υ_eff and χ_eff have the
//! same level and margin errors and flags as ζ_eff; their `fit_error` propagates the fits' 1σ.
//! The fine window is `window` base cells wide, so r_c and a must stay well inside half of it:
//! this bounds the ladder's largest useful |l| (a 16-cell window on a 128² base is 0.125 λ).
//! Test (32² base, k = 2, window 8 against uniform 128², each at its own p_c, |l| = 0.01 …
//! 0.05): r_c and a within 0.7 %, the running υ and χ within 3.7e-3.
//!
//! # The combined ladder ([`combined_ladder`])
//! For the asymptotic fits the refined ladder continues a uniform one: the uniform finest grid's
//! rungs from the largest |l| down to its first flagged pair, then the refined finest D's
//! rungs from that rung (the junction, a rung of both) down to its first flagged pair, the
//! refined values multiplied by y_uniform/y_refined at the junction. The rescaling keeps the
//! refined local slopes and makes the ladder continuous: the two discretisations' prefactors
//! differ by their discretisation errors (~1e-3 in g_s), which a direct fit of y would read as
//! a step. Stopping at the first flagged pair on either side is the uniform ladders' rule
//! ([`analysis::grid_converged_rungs`]): grid errors grow towards p_c.
//!
//! A chain of refined ladders ([`chained_ladder`]; e.g. 256², k = 3, 4, then a finer base with
//! a small window for the deepest rungs, whose window check flags the larger |l|), ordered by
//! depth, continues the same way link by link: each from the previous part's last usable rung
//! if the link has it (the junction), rescaled there, down to its own first flagged pair. A
//! link without that rung, or flagged right after it, ends the chain (with a note saying which
//! and why): the links below it would have no rung in common with the ladder.
//!
//! # Measurements (2026-11-25, `examples/refined_ladder.rs`)
//! Square model, 256² base (2^8), margin 8, comparison margin 12; triangular likewise. Commands
//! (in a scratch directory; `REFINED_*` see the example's docs):
//! - k = 3: `refined_ladder square 8 3 32 8` (D(2), D(3), D(3, margin 12); tol_gap 1e-13,
//!   max_iter 20000: the defaults then); the k = 3, window 16 rows came from the same binary
//!   as D(k − 1) of a first k = 4 run (`… square 8 4 16 8`, tol_gap 1e-13), whose D(4) p_c
//!   search then stagnated on its cold first probe at p_c (the warm-up solve 1 % below the
//!   guess was added after that);
//! - k = 4: `REFINED_TOL_GAP=1e-12 REFINED_MAX_ITER=3000 REFINED_COMPARE=margin
//!   REFINED_COARSER_CSV=<k = 3, window 16 rows> refined_ladder square 8 4 16 8`;
//! - k = 5: `REFINED_TOL_GAP=5e-12 REFINED_MAX_ITER=400 REFINED_COMPARE=none
//!   REFINED_PC_GUESS=0.22860517 refined_ladder square 8 5 16 8`, the margin-12 ladder the same
//!   with `… 16 12 -2e-3,…,-1e-5`, combined with `REFINED_{COARSER,FINE,MARGIN}_CSV`;
//! - triangular: `REFINED_TOL_GAP=5e-12 REFINED_MAX_ITER=400 refined_ladder triangular 8 k w 8`
//!   for (k, w) = (3, 32), (4, 16).
//!
//! 2 cores shared with another engineer's runs (load average 3.5–8 throughout): wall times are
//! inflated 2–4× against a quiet machine.
//!
//! p_c(D)/p_fc, square: base grid alone 0.2286119976; k = 2 (window 32) 0.2286055217; k = 3
//! 0.2286050840 (window 32; the bench's bisection gave 0.2286050840; uniform 2048² 0.2286049877)
//! and 0.2286052912 (window 16); k = 4 0.2286051698 (margin 12: 0.2286051645, −2.3e-8); k = 5
//! 0.2286051596 (margin 12: 0.2286051323, −1.2e-7). Triangular: base 0.7119860195; k = 3
//! 0.7119650659 (w 32), 0.7119661607 (w 16); k = 4 0.7119658889 (margin 12: −1.9e-7).
//!
//! Running ζ_eff (square; `*` = flagged: a rung of the pair flagged, or a grid error above
//! 0.005 or unknown; values shown anyway. Δk = |change from k − 1|, Δm = |change from margin
//! 12| (in the "Δk, Δm (12)" column: k − 1 at margin 12, and margin 16), same window; the grid
//! error is the larger):
//!
//! | pair | uniform 2048² (docs/near-critical.md) | k = 3, w 32 | Δk, Δm | k = 4, w 16 | Δk, Δm | k = 5, w 16 | Δk, Δm | k = 5, margin 12 | Δk, Δm (12) | k = 5, margin 16 | neck (k = 5) |
//! |---|---|---|---|---|---|---|---|---|---|---|---|
//! | 0.05→0.02 | 1.2240 | 1.2240* | – | 1.2237* | – | 1.2237* | – | – | – | – | 513→513 |
//! | 0.02→0.01 | 1.2063 | 1.2069 | 1.5e-4, 1e-7 | 1.2075* | – | 1.2075* | – | – | – | – | |
//! | 0.01→0.005 | 1.1955 | 1.1960 | 1.4e-4, 2e-7 | 1.1958* | – | 1.1958* | – | – | – | – | |
//! | 0.005→0.002 | 1.1858 | 1.1849 | 6.1e-4, 4e-7 | 1.1867* | – | 1.1867* | – | – | – | – | 383→249 |
//! | 0.002→0.001 | 1.1781 | 1.1776 | 2.1e-3, 9e-7 | 1.1760 | 4.2e-4, 1.6e-5 | 1.1760 | 2.6e-5, 8.4e-5 | 1.1759* | 9.5e-5, – | – | 249→179 |
//! | 0.001→5e-4 | 1.1726 | 1.1727 | 3.4e-3, 1.7e-6 | 1.1724 | 7.4e-4, 3.0e-5 | 1.1723 | 8.9e-5, 1.6e-4 | 1.1721* | 2.2e-4, – | – | 179→129 |
//! | 5e-4→2e-4 | 1.1684* | 1.1688* | 6.3e-3, 3.8e-6 | 1.1663 | 1.7e-3, 6.5e-5 | 1.1662 | 8.7e-5, 3.6e-4 | 1.1658 | 3.8e-4, 9.1e-5 | 1.1657 | 129→83 |
//! | 2e-4→1e-4 | 1.1647* | 1.1646* | 9.4e-3, 7.9e-6 | 1.1625 | 1.8e-3, 1.4e-4 | 1.1622 | 3.3e-4, 7.6e-4 | 1.1614 | 9.5e-4, 1.9e-4 | 1.1612 | 83→61 |
//! | 1e-4→5e-5 | – | 1.1689* | 3.1e-2, 1.5e-5 | 1.1595* | 9.2e-3, 2.6e-4 | 1.1590 | 5.2e-4, 1.5e-3 | 1.1575 | 1.7e-3, 3.7e-4 | 1.1572 | 61→43 |
//! | 5e-5→2e-5 | – | 1.1719* | 3.9e-2, 3.0e-5 | 1.1603* | 1.1e-2, 5.4e-4 | 1.1584 | 1.9e-3, 3.1e-3 | 1.1553 | 4.5e-3, 7.9e-4 | 1.1546 | 43→27 |
//! | 2e-5→1e-5 | – | 1.1808* | 0.15, 6.1e-5 | 1.1667* | 1.4e-2, 1.1e-3 | 1.1618* | 4.9e-3, 6.6e-3 | 1.1552* | 1.0e-2, 1.7e-3 | 1.1535 | 27→19 |
//!
//! (neck = open fine nodes across the channel through the saddle at the two rungs; at k = 4 it
//! is 29→21→13→9 over the last four rungs (the k = 3 runs predate the column). The k = 5 margin-12
//! ladder (rungs −2e-3 … −1e-5 only) has p_c/p_fc 0.2286051323, reproduced to 7.7e-11 by a
//! rerun of its search: the search's floor at tol_gap 5e-12. Δk at margin 12 is against k = 4
//! at margin 12; the margin-16 ladder has rungs −5e-4 … −1e-5, p_c/p_fc 0.2286051253. Costs of
//! the k = 5 margin 12 and 16 runs: 693 and 979 CPU-s, 363 and 469 MB peak.) Check against uniform 2048² (same fine spacing as k = 3): k = 3 (window 32) is
//! within 9e-4 of it at every pair 0.02→0.01 … 2e-4→1e-4 (+6e-4, +4.5e-4, −9e-4, −5e-4,
//! +1.2e-4, +3.6e-4, −1.4e-4), and its grid error against k = 2 (1024²) reproduces the uniform
//! 1024²-vs-2048² grid errors of docs/near-critical.md (6.3e-3 vs 7.0e-3 at 5e-4→2e-4, 9.4e-3
//! vs 9.5e-3 at 2e-4→1e-4).
//! The window: at k = 3, window 16 differs from window 32 by ≤ 1.2e-4 from 0.001→5e-4 down,
//! by 2e-3 at 0.005→0.002 (the window's edge then lies 8 base cells from the saddle, near the
//! contact lines). Windows of 16 base cells are flagged above |l| ≈ 5e-3 (no contact line
//! crosses the edge: the window lies inside the open channel), as they should be.
//!
//! Costs per rung (warm-started from the previous rung): square k = 3: 3–8 s, 48–92 iterations;
//! k = 4: 4–14 s, 40–80; k = 5: 29–94 s, 45–125 (peak RSS 276 MB). The p_c searches: k = 3
//! 29 s (11 probes, 403 iterations), k = 4 46 s (11, 435), k = 5 287 s (21 probes, 738
//! iterations, including the cold warm-up at l ≈ −1e-2, 46 s, and the first jump to p_c, 245
//! iterations, 102 s). Whole runs (CPU): k = 3 with k = 2 and margin 12: 129 s; k = 4 with
//! margin 12: 205 s; k = 5 alone: 622 s CPU, 14.6 min wall at load ~6.
//!
//! Triangular (axis saddle (λ/√3, 0), channel along y; only this saddle is refined: the other
//! critical saddles of the cell stay on the coarse hats, so p_c(D) is the closing load of the
//! refined saddle, not the cell's percolation load; on the base grid alone those saddles close
//! at 0.7119860 p_fc, 2.8e-5 above p_c(D), so they are open at every rung, and their coarse
//! contact lines enter the refined gap only through the far field, like the margin error):
//!
//! | pair | uniform 2048² (docs/near-critical.md) | k = 3, w 32 | k = 4, w 16 | Δk, Δm (k = 4) |
//! |---|---|---|---|---|
//! | 0.05→0.02 | 1.3117 | 1.3120* | 1.3121* | – |
//! | 0.02→0.01 | 1.2848 | 1.2836* | 1.2844 | 2.4e-6, 1.6e-5 |
//! | 0.01→0.005 | 1.2668 | 1.2678 | 1.2669 | 1.6e-4, 3.0e-5 |
//! | 0.005→0.002 | 1.2493 | 1.2511* | 1.2521 | 1.2e-4, 6.5e-5 |
//! | 0.002→0.001 | 1.2338* | 1.2354* | 1.2339 | 2.4e-4, 1.3e-4 |
//! | 0.001→5e-4 | 1.2214* | 1.2246* | 1.2232 | 8.2e-4, 2.6e-4 |
//! | 5e-4→2e-4 | 1.2053* | 1.2136* | 1.2132 | 1.5e-4, 5.4e-4 |
//! | 2e-4→1e-4 | 1.1953* | 1.2126* | 1.2032* | 9.2e-3, 1.1e-3 |
//! | 1e-4→5e-5 | – | 1.2089* | 1.2022* | 6.5e-3, 2.0e-3 |
//! | 5e-5→2e-5 | – | 1.2089* | 1.1993* | 9.4e-3, 4.4e-3 |
//! | 2e-5→1e-5 | – | 1.2783* | 1.2033* | (k = 3 frozen), 8.1e-3 |
//!
//! Triangular flags: the window of 32 base cells at k = 3 and the last three rungs at k = 4
//! show 12 edge crossings with runs of one fine node (0.125, 0.0625 base cells) besides the four
//! real crossings. They were the contact line meeting the edge next to a base node, whose
//! unknown also carries the coarse hats (2026-11-26, `REFINED_EDGE_DUMP`; 256² base, k = 4,
//! window 16, l = −5e-5: base node (16, 256) of the region open with hat-mean gap 4.2e-4 h0
//! between fine nodes in contact, the fine node beside it in contact with p = 1.8e-4, then the
//! open channel; the same at all four ends of the two channel crossings; 128² base, k = 3,
//! window 16, l ≤ −2e-4 likewise). The check now reads the region's second ring (no base
//! node on it) and merges runs of 1–2 fine nodes ([`contact::refinement::EdgeRuns`]): those
//! rungs show the neck's 4 crossings and no sliver (below, "The window check"). k = 3 and k = 4 are within 1–3e-3 of uniform 2048² from 0.02→0.01 to
//! 0.002→0.001 (uniform's own grid errors there 0.5–5e-3; the square agreed to 9e-4), and the neck is 3–7 fine nodes wide below 1e-4 at k = 3 (frozen at the
//! last pair: ζ_eff = 1.278 is the discretisation's). Triangular k = 5 (window 16, from the
//! k = 4 rows) was not measured: its cold warm-up solve at l ≈ −1e-2 stopped at the 400-iteration
//! cap with violation 0.28, and the first probe at p_c failed warm, continued and cold (last
//! violation 9.7e-7 after 400 cold iterations); a larger cap (≥ 2000, the library default) was
//! not tried for lack of time.
//!
//! # What the data say
//! - Square: ζ_eff keeps falling below the uniform grids' reach. Best ladder (k = 5, margin
//!   12; grid error = max(Δk against k = 4 at margin 12, Δm against margin 16)): 1.1658
//!   (5e-4→2e-4, ±3.8e-4), 1.1614 (2e-4→1e-4, ±9.5e-4), 1.1575 (1e-4→5e-5, ±1.7e-3), 1.1553
//!   (5e-5→2e-5, ±4.5e-3), 1.1552 (2e-5→1e-5, ±1.0e-2: NOT converged). Margin 16 gives
//!   1.1657, 1.1612, 1.1572, 1.1546, 1.1535; the margin error falls ~4× from 8 → 12 to
//!   12 → 16 (6.6e-3, 1.7e-3 at the last pair), so the far field is under control at margin
//!   16, and what is left at 2e-5→1e-5 is the level error (k = 4 → 5: 1.0e-2 at margin 12,
//!   4.9e-3 at margin 8; the neck is 19–27 fine nodes wide there at k = 5). The margin-8
//!   ladder's upturn at the last pair (1.1584 → 1.1618) was far-field error.
//!   So: ζ_eff is still falling at 1e-4 (by ~0.004 per factor 2 in |l|) and is still falling,
//!   more slowly (−0.001 to −0.002 per pair at margin 16), at 5e-5→2e-5 — the last
//!   grid-converged pair (1.155 ± 0.005). At 2e-5→1e-5 it is 1.154 ± 0.010: k = 6 is needed
//!   there. It does not approach 6/5 from above: it went through 1.2 near 0.02→0.01 and lies
//!   0.045 below it at 5e-5→2e-5.
//! - Triangular: ζ_eff falls monotonically, 1.3121 → 1.2132 (5e-4→2e-4, converged, grid error
//!   5.4e-4) → 1.2032 (2e-4→1e-4, grid error 9.2e-3) → ~1.20 at 1e-5 (flagged, grid errors
//!   4–9e-3): it reaches 1.2 near 1e-4 and is still falling there.
//! - The two models approach each other: 0.088 apart at 0.05→0.02, 0.047 at 5e-4→2e-4, ~0.04
//!   at 2e-4→1e-4 (triangular not converged there). Neither has a plateau at 6/5; on this
//!   256² base the square one stays 0.035–0.045 below it from 2e-4 to 1e-5 (the deep ladders,
//!   1024² base, docs/near-critical.md §5b: 0.051 below at 2e-5→1e-5, converged).
//! - Hexagonal (2026-11-26, window 16; docs/near-critical.md, "Refined ladders on a 256²
//!   base"): the ladder runs (4 crossings at every rung, margin changes ≤ 3.4e-4) but the
//!   neck is narrow (at k = 4: 29, 21, 13, 9 fine nodes at l = −1e-3, −5e-4, −2e-4, −1e-4, the
//!   square's at ten times smaller |l|), so k = 3 vs 4 on 256² differ by 3.4e-3, 7.5e-3,
//!   1.6e-2, 2.2e-2, 4.0e-2 from 5e-3→2e-3 to 2e-4→1e-4 (ζ_eff at k = 4: 1.1554, 1.1528,
//!   1.1522, 1.1566, 1.1679): it needs k ≥ 5.
//! - The far-field (margin) error grows like 1/|l| as the module doc of `contact::refinement`
//!   predicted, and with k at a fixed window (the fine window sees the same coarse far field
//!   at a finer scale): square margin 8 → 12 at 2e-5→1e-5: 6e-5 (k = 3, window 32), 1.1e-3
//!   (k = 4, window 16), 6.6e-3 (k = 5; margin 12 → 16: 1.7e-3), i.e. an unabsorbed shift of
//!   l by ~1e-8 … 8e-8; triangular k = 4: 8.1e-3 (~1e-7). Use margin ≥ 12 at k ≥ 4 (16 for
//!   |l| ≤ 2e-5), and compare levels at the same margin.
//!
//! # Zoom discretisations (2026-11-26, session #7; docs/near-critical.md)
//! A finer base with a small window: 1024² base (2^10), k = 3, 4, window 16 or 32 base cells,
//! margin 12; box (w + 26)·2^k fine nodes per side (336–928) against 1344 for 256², k = 5.
//! Square, `REFINED_TOL_GAP=5e-12` (commands in docs/near-critical.md):
//! - the margin error vanishes on this base: margin 12 → 16 changes ζ_eff by 3.8e-7 … 3.3e-6
//!   (k = 3, window 16; 256², k = 5: 1.9e-4 … 1.7e-3), so the far-field error is a base
//!   resolution effect;
//! - a **window error** that neither Δk nor Δmargin sees (the contact lines outside the window
//!   are the base grid's in all three D's): window 16 → 32 at k = 3 changes ζ_eff by 9.9e-4,
//!   5.4e-3, 2.0e-3, 6.2e-4 (2e-4→1e-4 … 2e-5→1e-5), although window 16 passes the window
//!   check from −2e-4 on. The example measures it with `REFINED_DWINDOW`; the grid error of
//!   [`running_zeta`] does not include it;
//! - window 32 agrees with 256², k = 5 (margin 12) within 8e-4, 9e-4, 1.3e-3 down to
//!   5e-5→2e-5; p_c(D)/p_fc 0.2286048 against 0.2286051;
//! - k = 4, window 32 (the fine spacing of 16384²): ζ_eff 1.1604, 1.1559, 1.1522, 1.1491 for
//!   2e-4→1e-4 … 2e-5→1e-5, Δk (k = 3 → 4) 1.6e-4, 7.1e-4, 1.8e-3, 3.4e-3: level-converged
//!   to 1e-5, still falling. Cost 429 CPU-s (setup 63 s wall: the alias sums scale with the
//!   fine lattice, f² N_base; p_c search 590 s wall, 14 probes; rungs 50–77 s at load ~9), 505 MB.
//!
use crate::CriticalError;
use crate::ladder::{SaddleFrame, Window as SaddleWindow, axis_saddle};
use crate::scaling::{EdgeOptions, blocked_half_length, open_half_width};
use analysis::{ScalingPoint, same_load};
use contact::SolverOptions;
use contact::refinement::{EdgeRuns, RefineOptions, Refined, RefinedModel, Window};
use std::time::Instant;
use surface::{Lattice, Surface};

/// One composite discretisation D (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Discretisation {
    /// Model.
    pub lattice: Lattice,
    /// Base grid 2^base_log2 × 2^base_log2.
    pub base_log2: u32,
    /// Refinement levels k (1..=6).
    pub levels: u32,
    /// Window side in base cells (square, centred on the axis saddle).
    pub window: usize,
    /// Margin of the blockwise operator in base cells.
    pub margin: usize,
}

impl Discretisation {
    /// The same D with `levels` replaced.
    pub fn with_levels(self, levels: u32) -> Self {
        Discretisation { levels, ..self }
    }
    /// The same D with `margin` replaced.
    pub fn with_margin(self, margin: usize) -> Self {
        Discretisation { margin, ..self }
    }
    /// The same D with `window` replaced (the window check's comparison: the contact lines
    /// outside the window are the base grid's, which neither k nor the margin changes).
    pub fn with_window(self, window: usize) -> Self {
        Discretisation { window, ..self }
    }
    /// Fine spacing (λ along x).
    pub fn spacing(&self) -> f64 {
        self.lattice.cell().0 / ((1usize << (self.base_log2 + self.levels)) as f64)
    }
}

/// How [`find_closing_load`] searches.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Search {
    /// Secant on g^(1/a) (a fitted to three open probes), aimed below the zero by the change of
    /// the zero between steps; seeded with solves done before the search; bisection within a
    /// probe budget (module docs, "The p_c search").
    #[default]
    Aimed,
    /// The first secant search (until 2026-11-26): aimed a fixed fraction `aim_below` of the
    /// predicted distance below the zero; ignores seeds.
    Secant,
    /// Plain bisection of the bracket.
    Bisection,
}

/// Options of the refined solves and searches.
#[derive(Clone, Debug, PartialEq)]
pub struct RefinedOptions {
    /// Constraint violation bound of the composite solve (h0).
    pub tol_gap: f64,
    /// Iteration cap per solve attempt (a warm solve near p_c needs 3–250; one that stagnates
    /// at the solver's floor would otherwise run for the stagnation window of 3000).
    pub max_iter: usize,
    /// Relative width of the final p_c bracket (hi/lo − 1).
    pub rel_tol: f64,
    /// Exponent that linearises g_s near p_c in the secant search.
    pub zeta0: f64,
    /// Fraction of the predicted remaining distance the secant aims below its zero.
    pub aim_below: f64,
    /// Search method.
    pub search: Search,
    /// Shortest run of open or contact nodes on the window's edge (base cells) for a rung not
    /// to be flagged.
    pub min_edge_cells: f64,
}

impl Default for RefinedOptions {
    fn default() -> Self {
        RefinedOptions {
            tol_gap: 1e-13,
            max_iter: 2_000,
            rel_tol: 1e-11,
            zeta0: 1.0,
            aim_below: 0.02,
            search: Search::Aimed,
            min_edge_cells: 2.0,
        }
    }
}

impl RefinedOptions {
    fn validate(&self) -> Result<(), CriticalError> {
        let checks: [(&'static str, f64, bool, &'static str); 5] = [
            (
                "tol_gap",
                self.tol_gap,
                self.tol_gap > 0.0 && self.tol_gap <= contact::TOL_GAP_MAX,
                "0 < tol_gap ≤ 1e-3 (h0)",
            ),
            (
                "rel_tol",
                self.rel_tol,
                self.rel_tol >= 1e-15 && self.rel_tol < 0.1,
                "1e-15 ≤ rel_tol < 0.1",
            ),
            (
                "zeta0",
                self.zeta0,
                self.zeta0 > 0.2 && self.zeta0 < 5.0,
                "0.2 < zeta0 < 5",
            ),
            (
                "aim_below",
                self.aim_below,
                self.aim_below >= 0.0 && self.aim_below < 0.9,
                "0 ≤ aim_below < 0.9",
            ),
            (
                "min_edge_cells",
                self.min_edge_cells,
                self.min_edge_cells >= 0.0 && self.min_edge_cells.is_finite(),
                "finite and ≥ 0 (base cells)",
            ),
        ];
        for (name, v, ok, allowed) in checks {
            if !ok || v.is_nan() {
                return Err(CriticalError::param(name, v, allowed));
            }
        }
        Ok(())
    }
}

/// The closing load found by [`find_closing_load`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosingLoad {
    /// Largest load probed with the saddle open.
    pub lo: f64,
    /// Smallest load probed with the saddle closed.
    pub hi: f64,
    /// Probes (solves).
    pub probes: usize,
}

impl ClosingLoad {
    /// The estimate: the bracket's midpoint.
    pub fn p_c(&self) -> f64 {
        0.5 * (self.lo + self.hi)
    }
}

/// The error when no load above 1e-3 of the guess leaves the saddle open.
fn no_open_load(guess: f64) -> CriticalError {
    CriticalError::param(
        "guess",
        guess,
        "a load with the saddle open above 1e-3 of it",
    )
}

/// The load at which a saddle gap g(p) (> 0 open, ≤ 0 closed, decreasing in p) closes, to
/// `opts.rel_tol`, from a guess and a relative width (module docs, "The p_c search"). `probe`
/// returns the saddle gap at a load. Errors if no open load is found above 1e-3 `guess` or no
/// closed one below 2 `guess`, or after 200 probes.
pub fn find_closing_load(
    probe: &mut dyn FnMut(f64) -> Result<f64, CriticalError>,
    guess: f64,
    width: f64,
    opts: &RefinedOptions,
) -> Result<ClosingLoad, CriticalError> {
    find_closing_load_seeded(probe, guess, width, &[], opts)
}

/// [`find_closing_load`] with `seed`, loads solved before the search and their gaps (p, g)
/// (e.g. the warm-up solve below the bracket): [`Search::Aimed`] uses them as probes (not
/// counted in `probes`); the other searches ignore them.
pub fn find_closing_load_seeded(
    probe: &mut dyn FnMut(f64) -> Result<f64, CriticalError>,
    guess: f64,
    width: f64,
    seed: &[(f64, f64)],
    opts: &RefinedOptions,
) -> Result<ClosingLoad, CriticalError> {
    opts.validate()?;
    if !(guess.is_finite() && guess > 0.0) {
        return Err(CriticalError::param("guess", guess, "finite and > 0"));
    }
    if !(width.is_finite() && width > 0.0 && width < 0.5) {
        return Err(CriticalError::param("width", width, "0 < width < 0.5"));
    }
    if opts.search == Search::Aimed {
        return search_aimed(probe, guess, width, seed, opts);
    }
    let mut probes = 0usize;
    let mut open: Vec<(f64, f64)> = Vec::new(); // (p, g), ascending p
    let mut hi: Option<f64> = None;
    let mut run = |p: f64, open: &mut Vec<(f64, f64)>, hi: &mut Option<f64>| {
        probes += 1;
        let g = probe(p)?;
        if g > 0.0 {
            open.push((p, g));
            open.sort_by(|a, b| a.0.total_cmp(&b.0));
        } else {
            *hi = Some(hi.map_or(p, |h: f64| h.min(p)));
        }
        Ok::<(), CriticalError>(())
    };
    // an open load below the guess (halving the load while the saddle is closed)
    let w = width;
    let mut p = guess * (1.0 - w);
    loop {
        run(p, &mut open, &mut hi)?;
        if !open.is_empty() {
            break;
        }
        if p < 1e-3 * guess {
            return Err(no_open_load(guess));
        }
        p *= 0.5;
    }
    // consecutive probes that did not halve a known bracket: two force a bisection
    let mut slow = 0;
    for _ in 0..200 {
        let lo = open.last().expect("one open").0;
        let width_before = hi.map(|h| h - lo);
        if let Some(h) = hi
            && h / lo - 1.0 <= opts.rel_tol
        {
            return Ok(ClosingLoad { lo, hi: h, probes });
        }
        let bisect = |hi: Option<f64>| match hi {
            Some(h) => 0.5 * (lo + h),
            None => lo * (1.0 + w),
        };
        let q = match (opts.search, open.len()) {
            (Search::Bisection, _) => {
                if hi.is_none() && lo * (1.0 + w) > 2.0 * guess {
                    return Err(CriticalError::param(
                        "guess",
                        guess,
                        "a load with the saddle closed within a factor 2 above it",
                    ));
                }
                bisect(hi)
            }
            (_, 1) => match hi {
                Some(h) => 0.5 * (lo + h),
                None => lo * (1.0 + 0.5 * w),
            },
            (_, _) if slow >= 2 => {
                slow = 0;
                bisect(hi)
            }
            (_, n) => {
                let (p2, g2) = open[n - 1];
                // the open probes nearest p_c, each at least 4 rel_tol below the next: probes
                // closer than that differ by the solver's noise in g, not by the law
                let mut spaced = vec![open[n - 1]];
                for &o in open[..n - 1].iter().rev() {
                    if spaced.len() < 3
                        && spaced[spaced.len() - 1].0 - o.0 >= 4.0 * opts.rel_tol * p2
                    {
                        spaced.push(o);
                    }
                }
                // the exponent: ζ0 from two open probes, fitted to three (module docs)
                let a = match spaced.len() {
                    3 => fit_exponent(spaced[2], spaced[1], spaced[0]),
                    _ => opts.zeta0,
                };
                let est = match spaced.len() {
                    1 => f64::NAN,
                    _ => secant_zero(spaced[1], spaced[0], a),
                };
                let d = est - p2;
                let inside = g2 > 0.0 && d > 0.0 && hi.is_none_or(|h| est < h);
                if !inside {
                    bisect(hi)
                } else if d <= 0.5 * opts.rel_tol * lo {
                    // close the bracket just above the estimate
                    let q = lo * (1.0 + 0.9 * opts.rel_tol);
                    match hi {
                        Some(h) if q >= h => 0.5 * (lo + h),
                        _ => q,
                    }
                } else {
                    // aim below the zero, but never closer to lo than the closing step
                    let q = est - opts.aim_below * d;
                    q.max(lo * (1.0 + 0.5 * opts.rel_tol))
                }
            }
        };
        if !q.is_finite() || q > 2.0 * guess {
            return Err(CriticalError::param(
                "guess",
                guess,
                "a load with the saddle closed within a factor 2 above it",
            ));
        }
        run(q, &mut open, &mut hi)?;
        if let (Some(before), Some(h)) = (width_before, hi) {
            let after = h - open.last().expect("one open").0;
            slow = if after > 0.5 * before { slow + 1 } else { 0 };
        }
    }
    Err(CriticalError::Solver {
        load: open.last().map_or(guess, |o| o.0),
        detail: format!(
            "closing-load search: no bracket of relative width {:e} after 200 probes",
            opts.rel_tol
        ),
    })
}

/// The closing-load error for a load that is not below 2 `guess`.
fn above_twice(guess: f64) -> CriticalError {
    CriticalError::param(
        "guess",
        guess,
        "a load with the saddle closed within a factor 2 above it",
    )
}

/// Probes [`Search::Aimed`] may take beyond bisection's count from its first bracket: its
/// model steps shrink the distance from below by orders of magnitude while the closed end stays
/// put until the closing probe (a far first closed probe: 3 steps and the closing probe).
const BUDGET_SPARE: usize = 4;

/// Bisection steps from the bracket [lo, hi] to a relative width `tol`.
fn bisections(lo: f64, hi: f64, tol: f64) -> usize {
    ((hi - lo) / (tol * lo)).log2().ceil().max(0.0) as usize
}

/// [`Search::Aimed`] (module docs, "The p_c search").
fn search_aimed(
    probe: &mut dyn FnMut(f64) -> Result<f64, CriticalError>,
    guess: f64,
    width: f64,
    seed: &[(f64, f64)],
    opts: &RefinedOptions,
) -> Result<ClosingLoad, CriticalError> {
    let tol = opts.rel_tol;
    let mut probes = 0usize;
    let mut open: Vec<(f64, f64)> = Vec::new(); // (p, g), ascending p
    let mut hi: Option<f64> = None;
    let add = |p: f64, g: f64, open: &mut Vec<(f64, f64)>, hi: &mut Option<f64>| {
        if g > 0.0 {
            open.push((p, g));
            open.sort_by(|a, b| a.0.total_cmp(&b.0));
        } else {
            *hi = Some(hi.map_or(p, |h: f64| h.min(p)));
        }
    };
    for &(p, g) in seed {
        if p.is_finite() && p > 0.0 && !g.is_nan() {
            add(p, g, &mut open, &mut hi);
        }
    }
    // an open seed above a closed one is noise at the floor: keep only the consistent ones
    if let Some(h) = hi {
        open.retain(|o| o.0 < h);
    }
    let mut run = |p: f64, open: &mut Vec<(f64, f64)>, hi: &mut Option<f64>, n: &mut usize| {
        *n += 1;
        let g = probe(p)?;
        add(p, g, open, hi);
        Ok::<(), CriticalError>(())
    };
    // an open load at guess (1 − width); while closed, step down by widths growing 8× (then by
    // halving the load), or to the highest open seed
    let mut step = width;
    let mut p = guess * (1.0 - width);
    loop {
        if open.last().is_some_and(|o| o.0 >= p * (1.0 - 1e-12)) {
            break;
        }
        if hi.is_some_and(|h| p >= h) {
            // a closed seed below the first probe: step down at once
        } else {
            run(p, &mut open, &mut hi, &mut probes)?;
            if hi != Some(p) {
                break;
            }
        }
        if p < 1e-3 * guess {
            return Err(no_open_load(guess));
        }
        step *= 8.0;
        p = if step < 0.5 {
            guess * (1.0 - step)
        } else {
            0.5 * p
        };
    }
    let mut state = AimState::default();
    // the probe budget: at most BUDGET_SPARE more than bisection from the first bracket
    let mut budget: Option<usize> = None;
    for _ in 0..200 {
        let lo = open.last().expect("one open").0;
        if let Some(h) = hi {
            if h / lo - 1.0 <= tol {
                return Ok(ClosingLoad { lo, hi: h, probes });
            }
            let left = bisections(lo, h, tol);
            let b = *budget.get_or_insert(probes + left + BUDGET_SPARE);
            if probes + left >= b {
                // the budget is spent: bisection from here keeps to it
                let q = 0.5 * (lo + h);
                run(q, &mut open, &mut hi, &mut probes)?;
                continue;
            }
        }
        let q = aimed_step(&open, lo, hi, width, &mut state, opts);
        if !q.is_finite() || q > 2.0 * guess {
            return Err(above_twice(guess));
        }
        run(q, &mut open, &mut hi, &mut probes)?;
    }
    Err(CriticalError::Solver {
        load: open.last().map_or(guess, |o| o.0),
        detail: format!(
            "closing-load search: no bracket of relative width {:e} after 200 probes",
            tol
        ),
    })
}

/// What [`aimed_step`] carries from one step to the next.
#[derive(Default)]
struct AimState {
    /// The last step's zero.
    last_est: Option<f64>,
    /// Steps in a row whose fitted zero lay at or above the closed end.
    overshoots: usize,
}

/// The next load of [`Search::Aimed`]: the zero `est` of g^(1/a) through the two open probes
/// nearest p_c (a fitted to three), its uncertainty u = the change of the zero since the last
/// step (at least the solver's floor 2 tol_gap / |dg/dp|), and the probe est − min(θ d, 2u)
/// (d = est − lo), or just above lo once est + u lies within the tolerance of lo.
fn aimed_step(
    open: &[(f64, f64)],
    lo: f64,
    hi: Option<f64>,
    width: f64,
    state: &mut AimState,
    opts: &RefinedOptions,
) -> f64 {
    let tol = opts.rel_tol;
    let midpoint = match hi {
        Some(h) => 0.5 * (lo + h),
        None => lo * (1.0 + 0.5 * width),
    };
    // the open probes nearest p_c, each at least 4 tol below the next (closer ones differ by
    // the solver's noise in g, not by the law)
    let mut spaced = vec![open[open.len() - 1]];
    for &o in open[..open.len() - 1].iter().rev() {
        if spaced.len() < 3 && spaced[spaced.len() - 1].0 - o.0 >= 4.0 * tol * lo {
            spaced.push(o);
        }
    }
    if spaced.len() < 2 {
        return midpoint;
    }
    let a = match spaced.len() {
        3 => fit_exponent(spaced[2], spaced[1], spaced[0]),
        _ => opts.zeta0,
    };
    let est = secant_zero(spaced[1], spaced[0], a);
    let d = est - lo;
    if !(d > 0.0 && est.is_finite()) {
        state.last_est = None;
        return midpoint;
    }
    // the model's resolution: the tolerance (the solver's floor, 2 tol_gap / |dg/dp|, was
    // 4e-11 relative at tol_gap 1e-12 on 256², k = 4, but the gaps there followed the affine
    // law to ~1e-14: tol_gap bounds the constraint violation, not the saddle gap's error)
    let res = 0.45 * tol * lo;
    if let Some(h) = hi
        && h - lo <= 8.0 * res
    {
        // a bracket at the model's resolution: its open/closed answers are noise
        return midpoint;
    }
    if let Some(h) = hi
        && est >= h
    {
        // the fitted law overshoots a closed probe: the straight secant (a = 1), below p_c for
        // a convex law, or an expanding step down from the closed probe
        let est1 = secant_zero(spaced[1], spaced[0], 1.0);
        state.last_est = Some(est1);
        state.overshoots += 1;
        let n = state.overshoots as i32;
        return if est1 > lo && est1 < h - 2.0 * res {
            // every second overshoot in a row (the fitted exponent keeps overshooting, the
            // straight secant creeps up from below): halve [est1, h], the bracket for a convex law
            if n % 2 == 0 { 0.5 * (est1 + h) } else { est1 }
        } else {
            // the straight secant reaches the closed probe too: p_c within a few resolutions
            // below it (g concave at the solver's floor)
            (h - 2.0 * res * 2f64.powi(n - 1)).max(midpoint)
        };
    }
    let u = state.last_est.map_or(d, |e| (est - e).abs());
    state.last_est = Some(est);
    state.overshoots = 0;
    let q = if est + u <= lo * (1.0 + 0.9 * tol) {
        // p_c within the tolerance above lo: close the bracket
        lo * (1.0 + 0.9 * tol)
    } else if d <= 4.0 * res && hi.is_none_or(|h| h > est + 2.0 * res) {
        // p_c within the resolution above lo: a closed probe just above it, then bisection
        est + 2.0 * res
    } else {
        let back = (opts.aim_below * d).min((2.0 * u).max(0.45 * tol * lo));
        (est - back).max(lo * (1.0 + 0.5 * tol))
    };
    match hi {
        Some(h) if q >= h => midpoint,
        _ => q,
    }
}

/// The first guess of p_c(D): the closing load of D's axis saddle on the periodic base grid
/// alone, to 1e-7 relative ([`periodic_closing_load`]), with the base grid's p_fc. Builds only
/// the base surface, not D's refined model.
pub fn base_guess(
    d: Discretisation,
    opts: &RefinedOptions,
) -> Result<(ClosingLoad, f64), CriticalError> {
    opts.validate()?;
    let surface =
        Surface::new(d.lattice, d.base_log2).map_err(|e| CriticalError::Surface(e.to_string()))?;
    let frame = axis_saddle(&surface)?;
    let base = periodic_closing_load(
        &surface,
        &frame,
        None,
        &RefinedOptions {
            rel_tol: 1e-7,
            ..opts.clone()
        },
    )?;
    Ok((base, surface.p_fc_grid()))
}

/// The closing load of the saddle `frame` on the periodic base grid alone (the uniform solve of
/// `surface`), to `opts.rel_tol`: a cheap guess for p_c(D), and, on a fine surface, the uniform
/// reference. Warm-started from the last solve.
pub fn periodic_closing_load(
    surface: &Surface,
    frame: &SaddleFrame,
    guess: Option<(f64, f64)>,
    opts: &RefinedOptions,
) -> Result<ClosingLoad, CriticalError> {
    let mut model = contact::Model::new(surface).map_err(|e| CriticalError::Solver {
        load: f64::NAN,
        detail: e.to_string(),
    })?;
    let sopts = SolverOptions {
        tol_gap: opts.tol_gap,
        max_iter: opts.max_iter,
        ..Default::default()
    };
    let mut warm: Option<contact::Solution> = None;
    let (g, w) = guess.unwrap_or((0.5 * surface.p_fc_grid(), 0.45));
    find_closing_load(
        &mut |p| {
            let sol = model
                .solve(contact::Interaction::HardWall, p, &sopts, warm.as_ref())
                .map_err(|e| CriticalError::Solver {
                    load: p,
                    detail: e.to_string(),
                })?;
            if !sol.stats.converged {
                return Err(CriticalError::Solver {
                    load: p,
                    detail: format!("not converged: {:?}", sol.stats.reason),
                });
            }
            let gap = sol.gap[[frame.node.0, frame.node.1]];
            warm = Some(sol);
            Ok(gap)
        },
        g,
        w,
        opts,
    )
}

/// Zero of the line through two open probes (p, g) in y = g^(1/a) (NaN if y does not fall).
fn secant_zero((p1, g1): (f64, f64), (p2, g2): (f64, f64), a: f64) -> f64 {
    let (y1, y2) = (g1.powf(1.0 / a), g2.powf(1.0 / a));
    if y1 > y2 {
        p2 + y2 * (p2 - p1) / (y1 - y2)
    } else {
        f64::NAN
    }
}

/// The exponent a ∈ [1, 3] for which three open probes (ascending p) are collinear in g^(1/a),
/// i.e. g = A (p_c − p)^a through all three: the two secant zeros agree. Their difference grows
/// with a (below the true exponent both secants undershoot, the farther pair more), so it is
/// bisected; clamped to [1, 3] (g is affine in p once the contact set is frozen: a = 1).
fn fit_exponent(a0: (f64, f64), a1: (f64, f64), a2: (f64, f64)) -> f64 {
    let diff = |a: f64| secant_zero(a0, a1, a) - secant_zero(a1, a2, a);
    let (mut lo, mut hi) = (1.0, 3.0);
    match (diff(lo), diff(hi)) {
        (d, _) if !d.is_finite() || d >= 0.0 => return lo,
        (_, d) if !d.is_finite() || d <= 0.0 => return hi,
        _ => {}
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if diff(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Why a rung must not be used silently.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RungFlag {
    /// The window is too small for the neck (module docs); the edge's runs.
    Window(EdgeRuns),
    /// The solve did not converge.
    NotConverged,
    /// The saddle node is closed at this load (l too close to p_c(D) for the solver floor).
    Closed,
}

impl std::fmt::Display for RungFlag {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RungFlag::Window(e) => write!(
                f,
                "window too small: {} crossings ({} before merging {} slivers), narrowest open {:?}, contact {:?} base cells",
                e.crossings, e.raw_crossings, e.slivers, e.narrowest_open, e.narrowest_contact
            ),
            RungFlag::NotConverged => write!(f, "solve not converged"),
            RungFlag::Closed => write!(f, "saddle closed"),
        }
    }
}

/// One rung of the refined ladder.
#[derive(Clone, Debug, PartialEq)]
pub struct RefinedRung {
    /// Reduced load p/p_c(D) − 1.
    pub l: f64,
    /// Load (E* h0/λ).
    pub load: f64,
    /// Gap at the saddle node (h0).
    pub saddle_gap: f64,
    /// Contact area fraction.
    pub contact_area: f64,
    /// Polonsky–Keer iterations (all attempts).
    pub iterations: usize,
    /// Wall time (s).
    pub wall_s: f64,
    /// Contact lines on the window's edge.
    pub edge: EdgeRuns,
    /// Fine nodes of the window in contact.
    pub window_contact: usize,
    /// Open fine nodes on the line through the saddle across the channel (contiguous with the
    /// saddle node; 0 if it is closed): the neck's width in fine cells, i.e. its resolution.
    pub neck_nodes: usize,
    /// Hash of the window's contact set (equal sets, equal hashes).
    pub contact_hash: u64,
    /// Why the rung must not be used silently, if so.
    pub flag: Option<RungFlag>,
    /// l < 0: the open channel's half-width r_c (λ) and its fit's 1σ, measured on the fine
    /// window ([`Refinement::saddle_window`], [`open_half_width`]); NaN if not measured or the
    /// fit failed (`edge_note` says why).
    pub half_width: (f64, f64),
    /// l > 0: the blocked channel's half-length a (λ) and its fit's 1σ
    /// ([`blocked_half_length`]); NaN likewise.
    pub half_length: (f64, f64),
    /// Why the edge measurement of this rung failed, if it did.
    pub edge_note: Option<String>,
    /// l < 0: the conductance along the channel through the composite gap and its 1σ
    /// ([`crate::refined_flow`], filled by [`crate::refined_flow::ladder_with_flux`]); NaN if
    /// not measured.
    pub flux: (f64, f64),
    /// l < 0: the neck's lengths from its gap field on the fine window
    /// ([`crate::neck_moments`], default options): rms half-width W_2 and level half-width
    /// (g = g_s/2) across the channel (υ), rise length along it (g = 2 g_s; χ from below),
    /// λ; NaN where not measured or the estimator has no value (too few nodes, window too
    /// small).
    pub neck: NeckRecord,
}

/// A rung's neck lengths ([`RefinedRung::neck`]; λ, NaN where not measured).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeckRecord {
    /// [`crate::neck_moments::across_rms`] with p = 2.
    pub width_rms: f64,
    /// [`crate::neck_moments::across_level_width`] at g_s/2 (both sides' mean).
    pub width_level: f64,
    /// [`crate::neck_moments::along_rise_length`] to 2 g_s (both sides' mean).
    pub rise_length: f64,
}

impl NeckRecord {
    /// Not measured (l > 0, or a ladder before the neck lengths).
    pub const NONE: NeckRecord = NeckRecord {
        width_rms: f64::NAN,
        width_level: f64::NAN,
        rise_length: f64::NAN,
    };

    /// The lengths of one window ([`crate::neck_moments::neck_lengths`], default options).
    pub fn of(w: &SaddleWindow) -> Self {
        let n = crate::neck_moments::neck_lengths(w, &crate::neck_moments::NeckOptions::default());
        NeckRecord {
            width_rms: n.across_rms.unwrap_or(f64::NAN),
            width_level: n.across_level.map_or(f64::NAN, |t| t.value),
            rise_length: n.along_rise.map_or(f64::NAN, |t| t.value),
        }
    }
}

/// The default reduced loads below p_c: −{5e-2, 2e-2, 1e-2, …, 2e-5, 1e-5}.
pub fn default_ls() -> Vec<f64> {
    let mut v = Vec::new();
    for d in [1e-2, 1e-3, 1e-4, 1e-5] {
        v.extend([-5.0 * d, -2.0 * d, -d]);
    }
    v
}

/// An unconverged attempt whose violation ended within this factor of `tol_gap` stopped at the
/// composite solve's rounding floor. Measured (docs/near-critical.md §5q): the triangular D(6)
/// (1024² base, window 32, margin 12) at tol_gap 1e-11 held its contact set fixed from its
/// 118th iteration on, with the rms gap on it at 2-6e-13 h0 and the largest violation between
/// 1.5e-11 and 9e-11, rising at each exact recomputation of the displacement; it would have run
/// 2000 iterations (2 h) per attempt, three attempts per probe. Since session #20 the solver
/// itself stops such a solve as stagnant (`contact::polonsky_keer`'s floor rule, the same band
/// of 100 × tol_gap): on that probe, after 336 iterations. The solver's band, so the two agree.
const FLOOR_FACTOR: f64 = contact::polonsky_keer::FLOOR_BAND;

/// The attempt ran out of iterations or stagnated with its violation within [`FLOOR_FACTOR`]
/// of `tol_gap`: continuing or restarting cold ends at the same floor, so it is not retried.
fn at_rounding_floor(stats: &contact::SolveStats, tol_gap: f64) -> bool {
    !stats.converged
        && matches!(
            stats.reason,
            Some(contact::StopReason::IterationCap | contact::StopReason::Stagnation)
        )
        && stats.max_violation <= FLOOR_FACTOR * tol_gap
}

/// The error of a probe of the p_c search whose solve did not converge; at the rounding floor it
/// says so and names the key to raise. Otherwise [`Refinement::solve`] tried every start: each
/// probe of the search follows a solve of the same D (the warm-up solve or an earlier probe),
/// so it starts warm, and only an attempt at the floor ends the retries early.
fn not_converged(load: f64, stats: &contact::SolveStats, tol_gap: f64) -> CriticalError {
    let detail = if at_rounding_floor(stats, tol_gap) {
        format!(
            "not converged: {:?} after {} iterations with the violation {:.3e} within {FLOOR_FACTOR} × \
             tol_gap {:.1e}: the composite solve is at its rounding floor (a retry ends there too); \
             raise tol_gap to at least {:.0e}",
            stats.reason,
            stats.iterations,
            stats.max_violation,
            tol_gap,
            2.0 * stats.max_violation
        )
    } else {
        format!(
            "not converged (started warm, continued and cold): {:?}, violation {:.3e} > tol_gap {:.1e}",
            stats.reason, stats.max_violation, tol_gap
        )
    };
    CriticalError::Solver { load, detail }
}

/// One solve of a p_c search ([`Refinement::critical_load_traced`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Probe {
    /// 0 for the warm-up solve below the bracket (the search's seed if it converged), then
    /// 1, 2, … for the search's probes.
    pub index: usize,
    /// Load (E* h0/λ).
    pub load: f64,
    /// Gap at the refined saddle node (h0).
    pub saddle_gap: f64,
    /// Polonsky–Keer iterations of every attempt.
    pub iterations: usize,
    /// The last attempt converged.
    pub converged: bool,
    /// Wall time of the probe (s).
    pub wall_s: f64,
}

/// A callback on every solve: (load, iterations, converged, max violation, wall s).
pub type SolveHook = Box<dyn FnMut(f64, usize, bool, f64, f64)>;

/// A refined discretisation ready to solve, warm-starting each solve from the last.
pub struct Refinement {
    /// The discretisation.
    pub disc: Discretisation,
    /// The base surface.
    pub surface: Surface,
    /// The refined saddle.
    pub frame: SaddleFrame,
    /// Options.
    pub opts: RefinedOptions,
    model: RefinedModel,
    warm: Option<Refined>,
    /// Solves so far.
    pub solves: usize,
    /// Polonsky–Keer iterations so far.
    pub iterations: usize,
    /// Called after every solve with (load, iterations, converged, max violation, wall s).
    pub on_solve: Option<SolveHook>,
}

impl Refinement {
    /// Builds D (module docs). Errors name the bad parameter (levels, window, margin).
    pub fn new(disc: Discretisation, opts: &RefinedOptions) -> Result<Self, CriticalError> {
        opts.validate()?;
        let surface = Surface::new(disc.lattice, disc.base_log2)
            .map_err(|e| CriticalError::Surface(e.to_string()))?;
        let frame = axis_saddle(&surface)?;
        let ropts = RefineOptions {
            levels: disc.levels,
            window: Window::centred(&surface.grid, frame.x, frame.y, disc.window, disc.window),
            solver: SolverOptions {
                tol_gap: opts.tol_gap,
                max_iter: opts.max_iter,
                ..Default::default()
            },
        };
        let model = RefinedModel::blockwise(&surface, &ropts, disc.margin).map_err(|e| {
            CriticalError::Solver {
                load: f64::NAN,
                detail: format!("refined model {disc:?}: {e}"),
            }
        })?;
        Ok(Refinement {
            disc,
            surface,
            frame,
            opts: opts.clone(),
            model,
            warm: None,
            solves: 0,
            iterations: 0,
            on_solve: None,
        })
    }

    /// Full-contact pressure of the base surface (E* h0/λ).
    pub fn p_fc(&self) -> f64 {
        self.surface.p_fc_grid()
    }

    /// Solves at `load` from the last solution; if that does not converge, again from the
    /// unconverged result and then cold, unless the attempt stopped at the composite solve's
    /// rounding floor ([`at_rounding_floor`]: a retry ends there too). Returns the solution and
    /// the iterations of all attempts (the solution's `stats` say whether the last attempt
    /// converged).
    pub fn solve(&mut self, load: f64) -> Result<(Refined, usize), CriticalError> {
        let mut iterations = 0;
        let mut last: Option<Refined> = None;
        for attempt in 0..3 {
            let start = match attempt {
                0 => self.warm.take(),
                1 => last.take(),
                _ => None,
            };
            if attempt < 2 && start.is_none() {
                continue;
            }
            let t = Instant::now();
            let r = self
                .model
                .solve(load, start.as_ref())
                .map_err(|e| CriticalError::Solver {
                    load,
                    detail: e.to_string(),
                })?;
            if let Some(f) = self.on_solve.as_mut() {
                f(
                    load,
                    r.stats.iterations,
                    r.stats.converged,
                    r.stats.max_violation,
                    t.elapsed().as_secs_f64(),
                );
            }
            self.solves += 1;
            iterations += r.stats.iterations;
            let done = r.stats.converged || at_rounding_floor(&r.stats, self.opts.tol_gap);
            last = Some(r);
            if done {
                break;
            }
        }
        let r = last.expect("one attempt");
        self.iterations += iterations;
        self.warm = Some(r.clone());
        Ok((r, iterations))
    }

    /// Gap at the refined saddle node of a solution (h0).
    pub fn saddle_gap(&self, r: &Refined) -> f64 {
        let f = 1usize << self.disc.levels;
        let (i, j) = self.frame.node;
        r.fine_gap(f * i, f * j)
            .expect("the window is centred on the saddle")
    }

    /// The saddle's indices in the fine region's arrays ([`Refined::window_gap`]); outside the
    /// region's shape if the region does not contain it.
    fn saddle_in_region(&self, r: &Refined) -> (usize, usize) {
        let f = 1usize << self.disc.levels;
        let (fnx, fny) = r.lattice;
        let (i, j) = self.frame.node;
        (
            (f * i + fnx - r.origin.0) % fnx,
            (f * j + fny - r.origin.1) % fny,
        )
    }

    /// Open fine nodes across the channel through the saddle ([`RefinedRung::neck_nodes`]).
    pub fn neck_nodes(&self, r: &Refined) -> usize {
        let (a, b) = self.saddle_in_region(r);
        let (rx, ry) = r.window_gap.dim();
        let open = |a: usize, b: usize| r.window_gap[[a, b]] > 0.0;
        if a >= rx || b >= ry || !open(a, b) {
            return 0;
        }
        // across the channel: along y if the channel runs along x, else along x
        let (len, at): (usize, Box<dyn Fn(usize) -> bool>) = if self.frame.channel_axis == 0 {
            (ry, Box::new(move |t| open(a, t)))
        } else {
            (rx, Box::new(move |t| open(t, b)))
        };
        let c = if self.frame.channel_axis == 0 { b } else { a };
        let up = (c + 1..len).take_while(|&t| at(t)).count();
        let down = (0..c).rev().take_while(|&t| at(t)).count();
        1 + up + down
    }

    /// The fields of the fine region around the refined saddle as a [`SaddleWindow`] in the
    /// saddle's frame (first index along the channel, saddle at the centre, fine spacing): the
    /// largest node-centred rectangle inside the region without its outermost ring of fine
    /// nodes (whose base nodes carry the coarse hats too, [`Refined::window_gap`]). This is
    /// what [`open_half_width`] and [`blocked_half_length`] measure, as on a uniform grid's
    /// window ([`crate::ladder::extract_window`]).
    pub fn saddle_window(&self, r: &Refined) -> SaddleWindow {
        let (a, b) = self.saddle_in_region(r);
        let (rx, ry) = r.window_gap.dim();
        let kx = a.min(rx.saturating_sub(a + 1)).saturating_sub(1);
        let ky = b.min(ry.saturating_sub(b + 1)).saturating_sub(1);
        let (dx, dy) = (r.window_grid.dx(), r.window_grid.dy());
        let along_x = self.frame.channel_axis == 0;
        let (k_par, k_perp, d_par, d_perp) = if along_x {
            (kx, ky, dx, dy)
        } else {
            (ky, kx, dy, dx)
        };
        let at = |field: &ndarray::Array2<f64>, p: usize, q: usize| {
            let (u, v) = if along_x { (p, q) } else { (q, p) };
            let (du, dv) = if along_x {
                (k_par, k_perp)
            } else {
                (k_perp, k_par)
            };
            field[[a + u - du, b + v - dv]]
        };
        let shape = (2 * k_par + 1, 2 * k_perp + 1);
        SaddleWindow {
            d_par,
            d_perp,
            gap: ndarray::Array2::from_shape_fn(shape, |(p, q)| at(&r.window_gap, p, q)),
            pressure: ndarray::Array2::from_shape_fn(shape, |(p, q)| at(&r.window_pressure, p, q)),
        }
    }

    /// p_c(D) (module docs) from a guess and a relative width (e.g. another D's p_c and 2e-6;
    /// without a guess, 0.5 p_fc and 0.45). A fresh D is first solved 1 % below the guess (a
    /// cold start at p_c can stagnate), and that solve is the search's seed. Errors if a solve
    /// does not converge.
    pub fn critical_load(
        &mut self,
        guess: Option<f64>,
        width: f64,
    ) -> Result<ClosingLoad, CriticalError> {
        self.critical_load_traced(guess, width, &mut |_| {})
    }

    /// [`Refinement::critical_load`], with `on_probe` seeing every solve of the search as it
    /// ends (the warm-up solve as probe 0), before an unconverged one ends the search.
    pub fn critical_load_traced(
        &mut self,
        guess: Option<f64>,
        width: f64,
        on_probe: &mut dyn FnMut(&Probe),
    ) -> Result<ClosingLoad, CriticalError> {
        let opts = self.opts.clone();
        let (g, w) = match guess {
            Some(g) => (g, width),
            None => (0.5 * self.p_fc(), 0.45),
        };
        // probe 0 is the warm-up solve of a fresh D
        let fresh = self.warm.is_none();
        let mut index = usize::from(!fresh);
        let mut probe = |this: &mut Self, p: f64| {
            let t = Instant::now();
            let (r, iterations) = this.solve(p)?;
            let saddle_gap = this.saddle_gap(&r);
            on_probe(&Probe {
                index,
                load: p,
                saddle_gap,
                iterations,
                converged: r.stats.converged,
                wall_s: t.elapsed().as_secs_f64(),
            });
            index += 1;
            Ok::<_, CriticalError>((r, saddle_gap))
        };
        let mut seed = Vec::new();
        if fresh {
            // a cold start right at p_c can stagnate (k = 4): start 1 % below it (an open probe
            // for the search if converged)
            let p0 = g * (1.0 - w.max(1e-2));
            let (r, gap) = probe(self, p0)?;
            if r.stats.converged {
                seed.push((p0, gap));
            }
        }
        find_closing_load_seeded(
            &mut |p| {
                let (r, gap) = probe(self, p)?;
                if !r.stats.converged {
                    return Err(not_converged(p, &r.stats, self.opts.tol_gap));
                }
                Ok(gap)
            },
            g,
            w,
            &seed,
            &opts,
        )
    }

    /// The ladder at loads p_c (1 + l) for every l of `ls` (< 0, any order, solved ascending),
    /// each rung checked and flagged (module docs); `on_rung` sees each rung with its solution
    /// and the fine window around the saddle ([`Refinement::saddle_window`]) it was measured on.
    pub fn ladder(
        &mut self,
        p_c: f64,
        ls: &[f64],
        on_rung: &mut dyn FnMut(&RefinedRung, &Refined, &SaddleWindow),
    ) -> Result<Vec<RefinedRung>, CriticalError> {
        if !(p_c.is_finite() && p_c > 0.0) {
            return Err(CriticalError::param("p_c", p_c, "finite and > 0 (E* h0/λ)"));
        }
        if let Some(&l) = ls
            .iter()
            .find(|l| !(l.is_finite() && **l != 0.0 && l.abs() < 1.0))
        {
            return Err(CriticalError::param(
                "ls",
                l,
                "reduced loads in (−1, 0) (ζ, υ) or (0, 1) (χ)",
            ));
        }
        let mut ls = ls.to_vec();
        ls.sort_by(f64::total_cmp);
        let mut rungs = Vec::with_capacity(ls.len());
        for l in ls {
            let t = Instant::now();
            let load = p_c * (1.0 + l);
            let (r, iterations) = self.solve(load)?;
            let g = self.saddle_gap(&r);
            let edge = r.edge;
            let flag = if !r.stats.converged {
                Some(RungFlag::NotConverged)
            } else if l < 0.0 && g <= 0.0 {
                Some(RungFlag::Closed)
            } else if edge.crossings < 4 || edge.too_small(self.opts.min_edge_cells) {
                Some(RungFlag::Window(edge))
            } else {
                None
            };
            // FNV-1a over the contact mask of the window
            let mut contact_hash = 0xcbf29ce484222325u64;
            let mut window_contact = 0;
            for &p in r.window_pressure.iter() {
                let c = p > 0.0;
                window_contact += usize::from(c);
                contact_hash = (contact_hash ^ u64::from(c)).wrapping_mul(0x100000001b3);
            }
            let neck_nodes = self.neck_nodes(&r);
            // υ below p_c(D), χ above, on the fine window (module docs, "Refined υ and χ")
            let w = self.saddle_window(&r);
            let eo = EdgeOptions::default();
            let fit = if l < 0.0 {
                // the onset fit takes the loaded nodes out to (1 + span) r_c; a window that ends
                // before that cuts the fit short (unlike the uniform ladders' windows): no value
                let edge = w.r_perp(2 * w.k_perp());
                open_half_width(&w, &eo).and_then(|e| {
                    if e.r * (1.0 + eo.span) > edge {
                        Err(format!(
                            "the onset fit reaches {:.3e} λ, beyond the fine window's {edge:.3e} λ: enlarge `window`",
                            e.r * (1.0 + eo.span)
                        ))
                    } else {
                        Ok(e)
                    }
                })
            } else {
                blocked_half_length(&w)
            };
            let (edge_fit, edge_note) = match fit {
                Ok(e) => ((e.r, e.r_error), None),
                Err(e) => ((f64::NAN, f64::NAN), Some(e)),
            };
            let nan = (f64::NAN, f64::NAN);
            let (half_width, half_length) = if l < 0.0 {
                (edge_fit, nan)
            } else {
                (nan, edge_fit)
            };
            let rung = RefinedRung {
                l,
                load,
                saddle_gap: g,
                contact_area: r.contact_area,
                iterations,
                wall_s: t.elapsed().as_secs_f64(),
                edge,
                window_contact,
                neck_nodes,
                contact_hash,
                flag,
                half_width,
                half_length,
                edge_note,
                flux: (f64::NAN, f64::NAN),
                neck: if l < 0.0 {
                    NeckRecord::of(&w)
                } else {
                    NeckRecord::NONE
                },
            };
            on_rung(&rung, &r, &w);
            rungs.push(rung);
        }
        Ok(rungs)
    }
}

/// Why a running exponent must not be used silently.
#[derive(Clone, Debug, PartialEq)]
pub enum PairFlag {
    /// A rung of the pair is flagged.
    Rung(f64, RungFlag),
    /// The grid error exceeds the bound.
    GridError {
        /// The larger of the two changes.
        error: f64,
        /// The bound.
        bound: f64,
    },
    /// A comparison D did not measure this pair (or flagged it): grid error unknown.
    Unknown,
    /// The window's contact set is the same at both rungs: on a fixed contact set the hard-wall
    /// solution is affine in the load, so the slope is that of the discretisation (→ 1), not
    /// of the neck: the neck is not resolved between these loads.
    Frozen,
}

impl PairFlag {
    /// The flag a pair's grid error earns against `bound`: unknown (NaN), above the bound, or
    /// none.
    pub fn grid(grid_error: f64, bound: f64) -> Option<PairFlag> {
        if grid_error.is_nan() {
            Some(PairFlag::Unknown)
        } else if grid_error > bound {
            Some(PairFlag::GridError {
                error: grid_error,
                bound,
            })
        } else {
            None
        }
    }
}

impl std::fmt::Display for PairFlag {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PairFlag::Rung(l, r) => write!(f, "rung l = {l:e}: {r}"),
            PairFlag::GridError { error, bound } => {
                write!(f, "grid error {error:.2e} > {bound:.2e}")
            }
            PairFlag::Unknown => write!(f, "grid error unknown"),
            PairFlag::Frozen => write!(f, "window contact set unchanged (neck unresolved)"),
        }
    }
}

/// A running exponent (ζ, υ or χ) between two neighbouring rungs.
#[derive(Clone, Debug, PartialEq)]
pub struct RunningPair {
    /// The rung farther from p_c (signed).
    pub l_hi: f64,
    /// The rung nearer p_c (signed).
    pub l_lo: f64,
    /// Δ ln y / Δ ln |l| on the finest D (y = g_s, r_c or a).
    pub value: f64,
    /// |value − value on D with k − 1| (NaN if not measured).
    pub error_levels: f64,
    /// |value − value on D with another margin| (NaN if not measured).
    pub error_margin: f64,
    /// The grid error: the larger of the two (NaN if either is unknown).
    pub grid_error: f64,
    /// 1σ of the measurements: ζ from the solver tolerance on both gaps, υ and χ from the
    /// edge fits.
    pub fit_error: f64,
    /// Why it must not be used silently, if so.
    pub flag: Option<PairFlag>,
}

/// What a refined running exponent measures on each rung.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Measured {
    /// ζ: the saddle gap (l < 0); 1σ the solver tolerance.
    SaddleGap,
    /// υ: the open half-width r_c (l < 0); 1σ its fit's.
    OpenHalfWidth,
    /// χ: the blocked half-length a (l > 0); 1σ its fit's.
    BlockedHalfLength,
    /// β: the conductance along the channel (l < 0, [`crate::refined_flow`]); 1σ the solver
    /// tolerance propagated.
    Flux,
}

impl Measured {
    /// All four, in table order (ζ, υ, χ, β).
    pub const ALL: [Measured; 4] = [
        Measured::SaddleGap,
        Measured::OpenHalfWidth,
        Measured::BlockedHalfLength,
        Measured::Flux,
    ];

    /// The exponent's table name.
    pub fn name(self) -> &'static str {
        match self {
            Measured::SaddleGap => "zeta",
            Measured::OpenHalfWidth => "upsilon",
            Measured::BlockedHalfLength => "chi",
            Measured::Flux => "beta",
        }
    }

    /// Whether it is measured above p_c(D).
    pub fn above_critical(self) -> bool {
        self == Measured::BlockedHalfLength
    }

    /// The rung's value and 1σ (`sigma_gap`: the saddle gap's), if this rung measures it. ζ
    /// takes every rung below p_c(D) (a closed one is flagged); υ and χ only those whose edge
    /// fit succeeded (a failed fit widens the pair, as on the uniform ladders).
    pub fn point(self, r: &RefinedRung, sigma_gap: f64) -> Option<ScalingPoint> {
        self.select(
            r.l,
            (r.saddle_gap, sigma_gap),
            r.half_width,
            r.half_length,
            r.flux,
        )
    }

    /// [`Measured::point`] from a rung's stored values (value, 1σ each; `saddle_gap`'s σ is the
    /// solver tolerance): for readers of a stored ladder, which has no [`RefinedRung`].
    pub fn select(
        self,
        l: f64,
        saddle_gap: (f64, f64),
        half_width: (f64, f64),
        half_length: (f64, f64),
        flux: (f64, f64),
    ) -> Option<ScalingPoint> {
        let (y, s) = match self {
            Measured::SaddleGap if l < 0.0 => saddle_gap,
            Measured::OpenHalfWidth if l < 0.0 => half_width,
            Measured::BlockedHalfLength if l > 0.0 => half_length,
            Measured::Flux if l < 0.0 => flux,
            _ => return None,
        };
        if self != Measured::SaddleGap && !(y.is_finite() && y > 0.0) {
            return None;
        }
        // a fit with no degree of freedom has no error: σ = 0 (as critical::running::measure)
        Some(ScalingPoint::new(l, y, if s.is_finite() { s } else { 0.0 }))
    }
}

/// (l_hi, l_lo, value, fit error, flag) of the neighbouring rungs measuring `m`.
fn slopes(
    rungs: &[RefinedRung],
    m: Measured,
    sigma_gap: f64,
) -> Vec<(f64, f64, f64, f64, Option<PairFlag>)> {
    let mut r: Vec<(&RefinedRung, ScalingPoint)> = rungs
        .iter()
        .filter_map(|r| m.point(r, sigma_gap).map(|p| (r, p)))
        .collect();
    r.sort_by(|a, b| b.0.l.abs().total_cmp(&a.0.l.abs()));
    r.windows(2)
        .map(|w| {
            let ((a, pa), (b, pb)) = (w[0], w[1]);
            let d = (a.l.abs() / b.l.abs()).ln();
            let v = (pa.y / pb.y).ln() / d;
            let fit_error = (pa.sigma / pa.y).hypot(pb.sigma / pb.y) / d;
            let flag = [a, b]
                .iter()
                .find_map(|x| x.flag.map(|f| PairFlag::Rung(x.l, f)))
                .or((a.contact_hash == b.contact_hash).then_some(PairFlag::Frozen));
            (a.l, b.l, v, fit_error, flag)
        })
        .collect()
}

/// Running ζ of the finest D's rungs with grid errors from D with k − 1 levels (`coarser`) and
/// from D with another margin (`margin`) (module docs); flagged above `bound`. `sigma`: 1σ of a
/// saddle gap (the solver tolerance). Same as [`running_exponent`] of [`Measured::SaddleGap`].
pub fn running_zeta(
    fine: &[RefinedRung],
    coarser: Option<&[RefinedRung]>,
    margin: Option<&[RefinedRung]>,
    bound: f64,
    sigma: f64,
) -> Vec<RunningPair> {
    running_exponent(Measured::SaddleGap, fine, coarser, margin, bound, sigma)
}

/// Running exponent of `m` (ζ, υ or χ) between neighbouring rungs of the finest D that measure
/// it, with grid errors from D with k − 1 levels (`coarser`) and from D with another margin
/// (`margin`; None: no margin comparison, the grid error is the level change alone) for the
/// same pair of loads; flagged above `bound`, when unknown, when a rung is flagged or the
/// window's contact set did not change (module docs). `sigma_gap`: 1σ of a
/// saddle gap (ζ); υ and χ take their edge fits' 1σ.
pub fn running_exponent(
    m: Measured,
    fine: &[RefinedRung],
    coarser: Option<&[RefinedRung]>,
    margin: Option<&[RefinedRung]>,
    bound: f64,
    sigma_gap: f64,
) -> Vec<RunningPair> {
    let other = |set: Option<&[RefinedRung]>, hi: f64, lo: f64| {
        set.and_then(|s| {
            slopes(s, m, sigma_gap)
                .into_iter()
                .find(|c| same_load(c.0, hi) && same_load(c.1, lo))
                .filter(|c| c.4.is_none() && c.2.is_finite())
                .map(|c| c.2)
        })
    };
    slopes(fine, m, sigma_gap)
        .into_iter()
        .map(|(hi, lo, v, fit_error, flag)| {
            let el = other(coarser, hi, lo).map_or(f64::NAN, |c| (v - c).abs());
            let em = other(margin, hi, lo).map_or(f64::NAN, |c| (v - c).abs());
            let grid_error = grid_error(el, em, margin.is_some());
            let flag = flag.or(PairFlag::grid(grid_error, bound));
            RunningPair {
                l_hi: hi,
                l_lo: lo,
                value: v,
                error_levels: el,
                error_margin: em,
                grid_error,
                fit_error,
                flag,
            }
        })
        .collect()
}

/// The grid error of a running exponent from its level change `el` (k − 1 levels) and margin
/// change `em` (NaN: not measured): their larger. No margin comparison asked for
/// (`margin_asked` false): the level change alone; asked for but missing, or no level change:
/// unknown (NaN). The one rule for ζ, υ, χ here and the neck measures (kinds::refined_neck).
pub fn grid_error(el: f64, em: f64, margin_asked: bool) -> f64 {
    if el.is_nan() || (margin_asked && em.is_nan()) {
        f64::NAN
    } else {
        el.max(if em.is_nan() { 0.0 } else { em })
    }
}

/// One neighbouring pair of a ladder as [`combined_ladder`] takes it: its two reduced loads
/// (signed) and whether it may be used (unflagged).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LadderPair {
    /// The rung farther from the critical load (signed).
    pub l_hi: f64,
    /// The rung nearer it (signed).
    pub l_lo: f64,
    /// Not flagged.
    pub usable: bool,
}

/// Which ladder a pair of the combined ladder comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    /// The uniform ladder's finest grid.
    Uniform,
    /// A refined ladder's finest discretisation (any link of [`chained_ladder`]'s chain).
    Refined,
}

impl Source {
    /// Table name (`uniform`, `refined`).
    pub fn name(self) -> &'static str {
        match self {
            Source::Uniform => "uniform",
            Source::Refined => "refined",
        }
    }
}

/// The combined ladder of [`combined_ladder`] and [`chained_ladder`].
#[derive(Clone, Debug, PartialEq)]
pub struct CombinedLadder {
    /// Its rungs by descending |l|; the refined ones rescaled (module docs).
    pub points: Vec<ScalingPoint>,
    /// The source of each neighbouring pair (one fewer than `points`).
    pub sources: Vec<Source>,
    /// Per neighbouring pair, the link of the chain it comes from (None: the uniform ladder;
    /// `Some(i)`: `links[i]` of [`chained_ladder`], 0 for [`combined_ladder`]'s refined one).
    pub links: Vec<Option<usize>>,
    /// The reduced load where the refined ladder (the chain's first link used) takes over
    /// (None: uniform only).
    pub junction: Option<f64>,
    /// Every link that extended the ladder and where it took over (signed l), in chain order.
    pub junctions: Vec<(usize, f64)>,
    /// Why the refined ladder (the chain's link `note_link`) did not extend the ladder, if one
    /// did not; it ends the chain there.
    pub note: Option<String>,
    /// The link the note is about.
    pub note_link: Option<usize>,
}

/// One link of [`chained_ladder`]: a refined ladder's points (any order) and its neighbouring
/// pairs.
#[derive(Clone, Copy, Debug)]
pub struct Link<'a> {
    /// Its rungs (signed l, the measured quantity).
    pub points: &'a [ScalingPoint],
    /// Its neighbouring pairs and whether each may be used.
    pub pairs: &'a [LadderPair],
}

/// The ladder an asymptotic fit uses, pair by pair the best grid-converged value available
/// (module docs, "The combined ladder"): the uniform ladder's finest rungs from the largest |l|
/// down to its first unusable pair, then the refined ladder's from that rung (the junction,
/// which both must have) down to its first unusable pair. The refined values are multiplied
/// by y_uniform/y_refined at the junction: their local slopes are unchanged, and the ladder
/// stays continuous (the two discretisations' prefactors differ by their discretisation
/// errors, ~1e-3, which a direct fit would otherwise read as a step). Without a usable uniform
/// pair (no uniform points, or its first pair flagged), the refined ladder alone from its first
/// usable pair. Pairs are matched by their loads to a relative 1e-9; the points of either
/// ladder in any order. [`chained_ladder`] with one link (none if `refined` is empty).
pub fn combined_ladder(
    uniform: &[ScalingPoint],
    uniform_pairs: &[LadderPair],
    refined: &[ScalingPoint],
    refined_pairs: &[LadderPair],
) -> CombinedLadder {
    let link = Link {
        points: refined,
        pairs: refined_pairs,
    };
    chained_ladder(uniform, uniform_pairs, &[link])
}

/// [`combined_ladder`] continued by a chain of refined ladders ordered by depth (module docs,
/// "The combined ladder"): the uniform ladder down to its first unusable pair, then each link
/// from the previous part's last rung (its junction: a rung of both, loads equal by
/// [`same_load`]) down to its own first unusable pair, its values multiplied by
/// y_previous/y_link at that junction (so by the product of the scales before it: each link
/// keeps its local slopes and the ladder stays continuous). A link without the junction rung,
/// or whose pair from the junction is flagged or missing, ends the chain there (`note`,
/// `note_link`): a deeper link cannot skip it, since its rungs would have no rung in common
/// with the ladder to be rescaled at. Links without points are left out (as if not given).
/// Without a usable uniform pair, the first link alone from its first usable pair, then the
/// others as above. With one link this is [`combined_ladder`] exactly (the same rungs, scales
/// and notes).
pub fn chained_ladder(
    uniform: &[ScalingPoint],
    uniform_pairs: &[LadderPair],
    links: &[Link<'_>],
) -> CombinedLadder {
    let at = |pts: &[ScalingPoint], l: f64| pts.iter().find(|p| same_load(p.l, l)).copied();
    let next = |pairs: &[LadderPair], l: f64| pairs.iter().find(|p| same_load(p.l_hi, l)).copied();
    // the links given, by their index in `links`
    let chain: Vec<(usize, &Link<'_>)> = links
        .iter()
        .enumerate()
        .filter(|(_, k)| !k.points.is_empty())
        .collect();
    // the text of a note about link i (the one-link wording is combined_ladder's)
    let about = |i: usize, what: String| {
        if links.len() > 1 {
            format!("refined link {} of {}: {what}", i + 1, links.len())
        } else {
            what
        }
    };
    let mut out = CombinedLadder {
        points: Vec::new(),
        sources: Vec::new(),
        links: Vec::new(),
        junction: None,
        junctions: Vec::new(),
        note: None,
        note_link: None,
    };
    let top = |pts: &[ScalingPoint]| {
        pts.iter()
            .copied()
            .max_by(|a, b| a.l.abs().total_cmp(&b.l.abs()))
    };
    let mut uniform_chain = Vec::new();
    if let Some(p) = top(uniform) {
        uniform_chain.push(p);
        let mut cur = p.l;
        while let Some(pair) = next(uniform_pairs, cur).filter(|p| p.usable) {
            let Some(q) = at(uniform, pair.l_lo) else {
                break;
            };
            uniform_chain.push(q);
            cur = q.l;
        }
    }
    match uniform_chain.last() {
        Some(_) if uniform_chain.len() > 1 || chain.is_empty() => {
            out.sources = vec![Source::Uniform; uniform_chain.len() - 1];
            out.links = vec![None; uniform_chain.len() - 1];
            out.points = uniform_chain;
        }
        _ => {
            // the first link only (its own values: its scale below is 1), from its first
            // usable pair
            let Some(&(_, first)) = chain.first() else {
                out.note = Some("no usable uniform or refined pair".into());
                return out;
            };
            let mut v: Vec<&LadderPair> = first.pairs.iter().filter(|p| p.usable).collect();
            v.sort_by(|a, b| b.l_hi.abs().total_cmp(&a.l_hi.abs()));
            match v.first().and_then(|p| at(first.points, p.l_hi)) {
                Some(p) => out.points.push(p),
                None => {
                    out.note = Some("no usable uniform or refined pair".into());
                    out.note_link = Some(chain[0].0);
                    out.points = uniform_chain;
                    return out;
                }
            }
        }
    };
    for &(i, link) in &chain {
        let last = *out.points.last().expect("the ladder has a rung here");
        let mut current = last.l;
        let Some(j) = at(link.points, current) else {
            out.note = Some(about(
                i,
                format!("the refined ladder has no rung at the junction l = {current:e}"),
            ));
            out.note_link = Some(i);
            break;
        };
        let scale = last.y / j.y;
        let start = out.points.len();
        while let Some(pair) = next(link.pairs, current).filter(|p| p.usable) {
            let Some(q) = at(link.points, pair.l_lo) else {
                break;
            };
            out.points
                .push(ScalingPoint::new(q.l, q.y * scale, q.sigma * scale));
            out.sources.push(Source::Refined);
            out.links.push(Some(i));
            current = q.l;
        }
        if out.points.len() > start {
            out.junctions.push((i, last.l));
            out.junction.get_or_insert(last.l);
        } else {
            out.note = Some(about(
                i,
                format!(
                    "the refined pair from l = {:e} is flagged or missing",
                    last.l
                ),
            ));
            out.note_link = Some(i);
            break;
        }
    }
    out
}

/// [`chained_ladder`], or the links alone when they cannot join the uniform part across a gap
/// and make the longer ladder: the chain reached no link (its note is about the first one),
/// its uniform part ends above the first link's first usable rung, and the links alone from
/// that rung ([`chained_ladder`] without a uniform part) have more rungs. The note then says
/// what was dropped. (The hexagonal β of `params/deep.toml`: its uniform flux is usable at
/// 5e-2 → 2e-2 only, the deep ladder starts at 5e-3; the two parts have no common rung to be
/// rescaled at, and the deeper, longer one carries more of the asymptotics.)
pub fn longest_chained_ladder(
    uniform: &[ScalingPoint],
    uniform_pairs: &[LadderPair],
    links: &[Link<'_>],
) -> CombinedLadder {
    let c = chained_ladder(uniform, uniform_pairs, links);
    let first = links.iter().position(|l| !l.points.is_empty());
    let Some(end) = c.points.last() else {
        return c;
    };
    // a link joined, there is none, or the chain ended at a later one: nothing to choose
    if c.junction.is_some() || first.is_none() || c.note_link != first {
        return c;
    }
    let mut alone = chained_ladder(&[], &[], links);
    let deeper = alone
        .points
        .first()
        .is_some_and(|p| p.l.abs() < end.l.abs());
    if !deeper || alone.points.len() <= c.points.len() {
        return c;
    }
    let why = format!(
        "{}; the uniform ladder ends there ({} rungs), above the refined ladder's first usable \
         rung l = {:e}: the refined ladder alone ({} rungs)",
        c.note.as_deref().unwrap_or_default(),
        c.points.len(),
        alone.points[0].l,
        alone.points.len()
    );
    alone.note = Some(match alone.note.take() {
        Some(n) => format!("{why}; {n}"),
        None => why,
    });
    alone.note_link = alone.note_link.or(first);
    alone
}
