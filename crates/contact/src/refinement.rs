//! Local refinement of the hard-wall contact at a saddle: one composite discretisation, 2^k
//! times finer than the periodic base grid in a window and coarse outside, solved as one
//! symmetric positive problem.
//!
//! # Discretisation
//! Reference: the uniform solve on the fine lattice (base grid refined by f = 2^k, base node
//! (i, j) = fine node (f i, f j)) minimises Π(p) = ½ pᵀ G_f p − pᵀ h over p ≥ 0 with mean p̄,
//! G_f the fine lattice's periodic Green's function ([`ElasticKernel`]). The composite solve
//! minimises the same Π over a subspace p = P q:
//! - inside the region R (the fine nodes of the closed rectangle of base nodes i0 ..= i0 + wx,
//!   j0 ..= j0 + wy, see [`Window`]) p is the fine unknown of the node;
//! - outside R, p is the bilinear interpolant of nodal values on the base nodes (hat
//!   functions on the base cells); a base node on R's edge takes the fine unknown there.
//!
//! q ≥ 0 gives p ≥ 0 (the hats are positive). The optimality conditions are
//! Pᵀ(G_f P q − h − δ) ≥ 0 ⊥ q ≥ 0: inside R each fine node's own gap, outside the hat-weighted
//! mean gap of each coarse node. In force variables r = W q (W = diag Pᵀ1, the number of fine
//! pixels an unknown covers: 1 inside R, f² for a coarse hat) the operator
//! A' = W⁻¹ Pᵀ G_f P W⁻¹ is symmetric and positive on zero-mean fields, the load is Σ r = N_f p̄,
//! and the crate's preconditioned Polonsky–Keer iteration solves it unchanged (through
//! [`FreeKernel::composite`]; preconditioner: see "Preconditioner" below). There is no outer
//! iteration and no coupling tolerance: `solver.tol_gap` bounds the
//! violation of the composite conditions (fine gaps in R, hat-mean gaps outside), as it bounds
//! the fine gaps of a uniform solve.
//!
//! Exact: the elastic interaction of every pair of unknowns (the fine–fine, fine–coarse and
//! coarse–coarse blocks all come from the same G_f, so the method is a Ritz approximation of the
//! fine problem; a region covering the cell is the uniform fine solve, tested to 1e-11 h0), the
//! heights (the analytic profile at the fine nodes, hat-averaged outside R) and force balance.
//! Approximated: outside R the pressure is piecewise bilinear on the base cells and its contact
//! condition holds for hat means only; that error reaches the saddle through the long-ranged
//! elastic response. With an empty region this is not the base grid's own (band-limited nodal)
//! discretisation, so "base alone" below is a different scheme.
//!
//! Judge it at a fixed reduced load l = p/p_c − 1 with p_c from the same discretisation: a
//! far-field error acts mostly as a shift of p_c, so comparisons at a fixed load measure the
//! shift, not the neck.
//!
//! # Diagnosis of the first design ([`coupled`])
//! The domain decomposition solved the window with G_f and the outside on the base grid,
//! reading the base pressure p_O as band-limited (its trigonometric interpolant T p_O on the
//! fine lattice). T p_O does not vanish on the window: cut at the window's edge (p_O = 0 on the
//! window's base nodes) the interpolant rings into it, and the window felt that pressure on top
//! of its own. Measured (square model, 128² base, k = 2, window 32², at its p_c): the spilled
//! pressure reaches 0.32 of the window's largest pressure (Σ|spill| = 7.3e-4 of the outside
//! load, net 9e-5). Cutting it (the window sees C T p_O, C zero on the window's fine nodes,
//! [`coupled::Interface::Cut`]) and nothing else moves the refined p_c from +3.7e-4 to −2.6e-5
//! relative to the uniform 512² one (base alone +1.0e-4), and the saddle gap at
//! l = −1e-2, −3e-3, −1e-3, −3e-4 (own p_c) from −4.4 %, −14 %, −36 %, −36 % to +6.6e-4,
//! +5.3e-4, +4.6e-4, +8.7e-4 relative (base alone −1.4e-2, −4.1e-2, −0.14, −0.13). So the
//! p_c shift was the spill, i.e. an inconsistent interface. The cut coupling is still not one
//! energy (the outside sees its own uncut interpolant through the base kernel), needs ~50 outer
//! iterations, and at a fixed load is not always better than the base grid (see its tests):
//! the composite discretisation replaces it.
//!
//! # Measurements (square model, saddle (1/2, 0), tol_gap 1e-13 h0; benches/refinement.rs)
//! At a fixed reduced load from each discretisation's own p_c, saddle gap relative to the
//! uniform fine solve:
//! - 64² base, k = 2, against 256² (the test below): p_c +6.1e-6 (window 16²), +1.7e-5 (32²),
//!   base alone +3.0e-4; gap at l = −1e-2, −3e-3, −1e-3: window 16² +2.9e-3, +1.2e-3, +1.7e-3;
//!   32² +2.7e-3, +1.8e-3, +1.9e-3; base alone −5.1e-2, −0.19, −3.5e-2.
//! - 128² base, k = 2, window 32², against 512² (`REFINE_CRITICAL=1`): p_c/p_fc 0.2286087523
//!   against 0.228606867 (+8.2e-6; base alone +1.0e-4); gap at l = −1e-2, −3e-3, −1e-3, −3e-4:
//!   +7.7e-4, +1.0e-3, +1.7e-3, +1.4e-3 (base alone −1.4e-2, −4.1e-2, −0.14, −0.13).
//!   The local slope d ln g_s/d ln|l| between neighbouring loads thus differs from the
//!   uniform one by at most 6.4e-4 (base alone up to 0.1).
//! - 256² base, k = 2, window 64², against 1024² (`REFINE_BASE=8 REFINE_WINDOW=64`, 1447 s;
//!   the uniform and base values from the first design's run, the uniform gaps known to 4
//!   digits only, so ±2e-4 on each ratio): p_c/p_fc 0.2286057870 against 0.228605358
//!   (+1.9e-6; base alone +2.9e-5); gap at l = −1e-2, −3e-3, −1e-3, −3e-4: −6.8e-4, −8.7e-4,
//!   −6.5e-4, −8.0e-4 (base alone −3.1e-3, −9.9e-3, −3.8e-2, −7.6e-2).
//!
//! At a fixed load (0.227 p_fc, saddle gap 2.08e-3 h0, uniform 2048² the reference):
//! - 512² base, k = 2, window 64²: −8.2e-6 relative (base alone −6.4e-5).
//! - 128² base, k = 4, window 32²: +2.4e-3 (base alone −7.2e-4), contact area 0.3944 against
//!   0.3976.
//! - the cut domain decomposition ([`coupled`]), 512² base, k = 2, window 64²: −1.8e-3
//!   (contact area 0.3980), 51 outer iterations, 194 s against 72 s for the uniform solve in
//!   the same run (`REFINE_METHOD=coupled`; load average ~20).
//!
//! Near percolation a fixed-load error is a shift of p_c (d ln g_s/d ln p ≈ ζ/|l| ≈ 170 at this
//! load): +2.4e-3 is a p_c shift of 1.4e-5, and says nothing about the neck; the comparison at a
//! fixed reduced load on a 2048² fine lattice was not run (time).
//!
//! The floor of ~1e-3 at a fixed reduced load does not fall with the window (16² vs 32² above):
//! it is set by the coarse representation outside R (hat-mean contact conditions on the
//! contact lines of the rest of the cell), not by the neck. 1e-6 in the saddle gap is not
//! reached; the uniform 2048² and 4096² solves agree to 7.7e-7 at a fixed load.
//!
//! # Cost of the full application
//! Measured (`REFINE_BASE=9 REFINE_LEVELS=2 REFINE_WINDOWS=64` and `REFINE_BASE=7
//! REFINE_LEVELS=4 REFINE_WINDOWS=32`, 2 cores shared with other jobs, load average ~15):
//! composite 230 s, 153 iterations (k = 2) and 439 s, 308 iterations (k = 4) against 20 s and
//! 30 s, 40 iterations, for the uniform 2048² solve in the same runs.
//! Every iteration of [`RefinedModel::new`]'s operator applies G_f and K_f on the whole fine
//! lattice (two FFT pairs of f² N_base nodes) plus the prolongation and restriction passes, and
//! needs 4–8× the uniform solve's iterations: slower than the uniform solve, and it allocates
//! the fine lattice. It is kept as the reference of the blockwise application.
//!
//! # Blockwise application ([`RefinedModel::blockwise`], [`blocks`])
//! The same discrete problem (same unknowns, weights, heights W⁻¹Pᵀh and preconditioner)
//! with A' applied without the fine lattice. Write p = H v + d (H v the bilinear
//! interpolant of nodal values on every base node, d the fine remainder on R, zero at R's base
//! nodes). Then, with E the base nodes within `margin` cells of R and F the rest:
//! - hats–hats: C = Hᵀ G_f H is a base-grid circulant; its spectrum is an alias sum over the f²
//!   fine modes of each base mode (exact; setup work f² N_base, memory N_base; computed once
//!   and shared with the preconditioner, see "Cost at a 1024² base");
//! - everything supported near R (d and the hats of E): one zero-padded FFT on a box of
//!   ((w + 2 margin + 2) f)² fine nodes with the real-space table of G_f, computed by two
//!   passes of 1-D transforms (memory (F/2) × box side, never F²) (exact);
//! - d against the hats of F: their field is exact at base nodes (the circulant C' =
//!   (G_f ∗ hat) on the base lattice, alias sum) and interpolated onto R's fine nodes by
//!   [`ORDER`]-point Lagrange per axis; the transposed block uses the adjoint interpolation, so
//!   A' stays symmetric (one energy, PK unchanged, no outer iteration). This is the only
//!   approximation. It bounds the field of hats at least `margin` cells away; tested on
//!   operators (32² base): max |A'x − A'_full x| / max |A'_full x| = 6.4e-6 (margin 5, f = 2),
//!   3.9e-6 (5, f = 4), 2.8e-7 (8), 5.1e-8 (12); symmetric to 1e-14.
//!
//! Heights: Pᵀh streamed over the fine lattice by fine rows (each fine node evaluated once, a
//! row at a time with per-axis tables: [`blocks::FineRows`]).
//!
//! C v_F (the hats of F at E's base nodes) is formed on E only, as C v − C v_E with C v_E a
//! zero-padded convolution on E's (w + 2 margin + 1)² base nodes: the application costs four
//! base-grid FFT pairs (C v, C' v_F, C' Sᵀ Πᵀ d, and the preconditioner's C⁻¹), not five.
//!
//! Measured against the full composite (same discretisation; the difference is the
//! approximation above):
//! - 32² base, k = 2, window 8², margin 6, at 0.215 p_fc: saddle gap −1.6e-5 relative, window
//!   gaps within 4.5e-7 h0, same contact area and the same 118 iterations (test).
//! - 64² base, k = 2, window 16², margin 12, fixed reduced load (own p_c, test): p_c −4.0e-7
//!   (margin 8: −7.0e-7); saddle gap blockwise/composite +3.5e-5, +1.0e-4, +2.9e-4 at l = −1e-2,
//!   −3e-3, −1e-3 (margin 8: +6.1e-5, +1.8e-4 at the first two). The difference grows like
//!   1/|l|, i.e. it acts as an unabsorbed shift of the reduced load by ~3e-7, and falls only
//!   slowly with the margin (8 → 12: ×1.8, while the operator error falls ×5). By margin on a
//!   32² base, k = 2, window 8² (`blockwise_error_by_margin`, ignored test): p_c −4.0e-6,
//!   −2.9e-6, −1.5e-6, −2.9e-7 and saddle gap at l = −1e-3 +2.6e-3, +1.8e-3, +9.6e-4, +1.9e-4
//!   for margins 5, 7, 9, 11 (at l = −1e-2: +3.2e-4 … +2.3e-5; at l = −1e-4 within 5e-6, so it
//!   is not a monotonic function of l). So the far field's interpolation is the error, and on
//!   coarse bases it is not small: the contact patches' pressure lies a few base cells from the
//!   window and the 8-point stencil (7 cells wide) sees them at a distance of the order of its
//!   width. On the 128² base below (window 32², margin 8) the blockwise p_c is within 1.1e-7
//!   of the composite one. Rule: margin ≥ 8 and a base grid fine enough that the window's
//!   surroundings are smooth on the base scale; check by changing the margin. Against the uniform 256² solve the blockwise errors are +2.9e-3, +1.3e-3,
//!   +1.9e-3 (composite +2.9e-3, +1.2e-3, +1.7e-3; base alone −5.1e-2, −0.19, −3.5e-2).
//! - 128² base, k = 2, window 32², margin 8, against uniform 512² (`REFINE_METHOD=blockwise
//!   REFINE_CRITICAL=1`): p_c/p_fc 0.2286087270 (composite 0.2286087523, uniform 0.2286068670,
//!   base 0.2286302437); saddle gap at l = −1e-2, −3e-3, −1e-3, −3e-4, −1e-4: +7.9e-4, +1.0e-3,
//!   +1.8e-3, +1.7e-3, +1.9e-3 relative to uniform (composite +7.7e-4, +1.0e-3, +1.7e-3, +1.4e-3;
//!   base alone −1.4e-2, −4.1e-2, −0.14, −0.13, +0.11).
//!
//! Cost with the Galerkin preconditioner (superseded: see "Cost with the two-level
//! preconditioner"; 2 cores shared with ~5 other builds and solves, load average 13: wall
//! times are indicative; setup included; square model at 0.227 p_fc, saddle (1/2, 0), margin 8):
//! - 256² base, k = 3, window 32² (fine spacing of 2048²): 23 s, 200 iterations, against
//!   18 s, 40 iterations for the uniform 2048² solve in the same run; saddle gap −5.7e-4 from
//!   uniform at this fixed load (base alone +2.6e-4: at a fixed load near p_c the comparison
//!   measures the p_c shift, see above).
//! - 256² base, k = 4 (fine spacing of 4096², never allocated), window 16²
//!   (`REFINE_SKIP_REFERENCE=1`): 57 s, 203 iterations, peak resident memory 238 MiB.
//! - k = 5 (256² base, window 16²) and k = 6 (128² base, window 8², margin 6; box 2814²
//!   padded, resident 1.15 GB; k = 5 resident 0.9 GB) had not finished after 18 and 12
//!   CPU-minutes (50 and 26 min wall, load average ~12 on 2 cores) when the session ended: not
//!   measured, and clearly not yet comparable to a uniform 2048² solve (the iteration count at
//!   these k is unknown; the composite's grew from 153 at k = 2 to 308 at k = 4).
//!
//! # Preconditioner ([`Preconditioner`], [`twolevel`])
//! The solver needs M ≈ A'⁻¹ = W (Pᵀ G_f P)⁻¹ W (force variables). The first design used
//! M = Pᵀ K_f P ([`Preconditioner::Galerkin`]): exact for R covering the cell, but on a hat it
//! is the alias sum Σ φ² K_f, not the inverse of the hats' own block W⁻¹ C W⁻¹ (C = Hᵀ G_f H,
//! Σ φ² G_f): the two differ at every base mode above the smoothest, and near R's edge it
//! couples the fine nodes to the hats' stiffness. The default ([`Preconditioner::Additive`]) is
//! an additive two-level (overlapping Schwarz) one, M = W Π (J_c C⁻¹ J_cᵀ + J_r S K_R S J_rᵀ) Πᵀ W:
//! - coarse space: the bilinear fields H v of all base nodes, solved exactly by C⁻¹ (C is a
//!   base-grid circulant, so C⁻¹ is diagonal in Fourier: one base FFT pair);
//! - fine space: every node of R with K_R, the fine stiffness's real-space table restricted to R
//!   (zero-padded FFT on 2 rx × 2 ry; no margin, no box). R's edge base nodes (weight w > 1: their
//!   basis also carries the coarse hats next to R) enter scaled by S = 1/w; unscaled they get
//!   w² K_f(0), up to f⁴/4 too stiff, and left out the iterations grew with the window (k = 1,
//!   window 16² of a 32² base: 113 iterations against 36 scaled);
//! - Π = I − w 1ᵀ/Σw: a uniform gap (the rigid approach the solver estimates) gives no force and
//!   the output's net force is removed as a uniform pressure (the solver then removes its mean on
//!   the free set as a uniform force, which on unknowns of unequal area is a pressure step).
//!   Measured: 81 → 76 iterations (k = 3 below), a small effect. Making the solver's own mean
//!   removal weighted on one side only (tried in polonsky_keer, reverted) broke the symmetry and
//!   the solve did not converge.
//!
//! [`Preconditioner::Hierarchical`] (the same with the fine space restricted to R's non-base
//! nodes: the block-diagonal inverse in the blockwise operator's (v, d) basis) is worse, as
//! hierarchical bases are: 104 and 346–402 iterations below. Neither two-level preconditioner
//! needs the margin box for K, so each iteration applies one box FFT pair (G) instead of two.
//!
//! Iterations (square model at 0.215 p_fc, tol_gap 1e-13, 32² base, window 8²; ignored test
//! `iterations_by_preconditioner`; the solution is the same to 1e-11 h0 in the window gaps,
//! test `the_two_level_preconditioner_needs_few_iterations`):
//!
//! | k | uniform fine | Galerkin | additive | hierarchical |
//! |---|---|---|---|---|
//! | 2 (128²) | 36 | 118 | 50 | 104 |
//! | 3 (256²) | 26 | 169–170 | 73 | 346–402 |
//!
//! By window (ignored test `iterations_by_window`, full operator, additive / Galerkin): k = 1:
//! 31/66, 49/63, 36/71, 36/75, 30/45 for windows 1, 4, 8, 16, 32 (the whole cell); k = 2:
//! 40/120, 38/93, 50/118, 49/114, 34/36; k = 3: 43/110, 82/101, 73/170, 75/159, 30/26 (the base
//! grid alone: 20). So the additive preconditioner is as good as the uniform one when R is the
//! cell and when R is nearly empty, and 1.5–3× the uniform count for partial windows; what is
//! left is the interface (K_R truncated at R's edge, and the free set cutting the coarse
//! corrections there). Weighting the fine space by 0.5, 2 or 4 changed the counts within their
//! scatter (±30 %), no trend. Replacing K_R by the inverse of G_f|R's circulant embedding (as
//! [`FreeKernel`] does for free boundaries) gave 45 and 67 at windows 8² (k = 2, 3), but did not
//! converge (> 4000) for windows of half the cell, where the embedded table is not positive:
//! not used.
//!
//! # Cost with the two-level preconditioner
//! `cargo bench -p contact --bench refinement` with `REFINE_METHOD=blockwise` (margin 8) and
//! the variables below; square model at 0.227 p_fc (saddle gap 2.08e-3 h0), saddle (1/2, 0),
//! tol_gap 1e-13, cold start. The machine was shared (load average 7–13 on 2 cores: wall times
//! inflated 2–4×; CPU times from `/usr/bin/time -v`):
//!
//! | k | base, window | fine spacing | wall (setup) | CPU | iterations | peak RSS |
//! |---|---|---|---|---|---|---|
//! | 3 | 256², 32² | 2048² | 10.0 s (0.9 s) | – | 108 | 326 MiB (with the uniform) |
//! | 3, Galerkin | 256², 32² | 2048² | 21.6 s (0.9 s) | – | 200 | 105 MiB |
//! | 4 | 256², 16² | 4096² | 20.8 s (3.2 s) | 9.6 s | 109 | 208 MiB |
//! | 5 | 256², 16² | 8192² | 208 s (14 s) | 91 s | 207 | 774 MiB |
//! | 6 | 256², 8² | 16384² | 278 s (78 s) | 86 s | 76 | 502 MiB |
//! | 6, rerun at load average 3–4 | 256², 8² | 16384² | 97 s (31 s) | 85 s | 76 | 502 MiB |
//!
//! After the heights were streamed once per fine node (same heights, same solutions to the
//! last digit), on a quieter machine (load average 0.7–2.6):
//!
//! | k | base, window | wall (setup) | CPU | iterations | peak RSS |
//! |---|---|---|---|---|---|
//! | 3 | 256², 32² | 4.8 s (0.3 s); uniform 2048²: 7.4 s, 40 iterations | – | 108 | 326 MiB (with the uniform) |
//! | 4 | 256², 16² | 9.3 s (1.0 s) | – | 109 | 80 MiB |
//! | 5 | 256², 16² | 60 s (4.2 s) | 90 s | 207 | 256 MiB |
//! | 6 | 256², 8² | 82 s (17.5 s) | 78 s | 76 | 472 MiB |
//!
//! At a fixed reduced load (own p_c, bisection to 1e-9; `REFINE_CRITICAL=1 REFINE_METHOD=blockwise
//! REFINE_BASE=8 REFINE_LEVELS=3 REFINE_WINDOW=32`, load average 5–14), 256² base, k = 3,
//! window 32², against the uniform 2048² solve: p_c/p_fc 0.2286050840 against 0.2286049877
//! (+4.2e-7; base alone 0.2286119883, +3.1e-5); saddle gap at l = −1e-2, −3e-3, −1e-3, −3e-4,
//! −1e-4: −3.6e-4, −5.2e-4, +5.1e-4, +3.5e-4, +1.9e-4 relative (base alone −3.1e-3, −1.1e-2,
//! −4.0e-2, −8.1e-2, −0.21); local slopes d ln g_s/d ln|l| between neighbours (uniform 1.1923,
//! 1.1800, 1.1712, 1.1656) within 9.3e-4 (+1.3e-4, −9.3e-4, +1.3e-4, +1.4e-4; base alone up to
//! 0.13). The whole bisection and ladder took 85 s refined (38 warm-started solves) against 788 s
//! uniform in the same run. So at l = −1e-3 the refined saddle gap is within 5.1e-4 of the
//! uniform one: the ~1e-3 floor of the composite discretisation (see "Measurements"), not the
//! issue's 1e-6.
//!
//! The uniform 2048² solve in the k = 3 run: 15.2 s wall, 40 iterations; the refined saddle gap
//! −5.65e-4 from it at this fixed load (the p_c shift, as above), the Galerkin and additive
//! solves equal to 8e-12 relative (`REFINE_BASE=8 REFINE_LEVELS=3 REFINE_WINDOWS=32`,
//! `REFINE_PRECONDITIONER=galerkin` for the second row, `REFINE_SKIP_REFERENCE=1` for k ≥ 4).
//! So at k = 3 a solve now costs 0.65 of the uniform 2048² one (was 1.3×), k = 4 about 1.3
//! uniform 2048² solves (was 3×), and k = 5, 6 finish (did not before) in 60–82 s wall, 78–91
//! CPU-seconds, about 8–11 uniform 2048² solves: not yet "comparable to a uniform
//! 1024²–2048² solve", and one cold k = 6 solve alone is over the issue's minute per rung.
//! Where it goes at k = 5, 6: the box of (w + 2 margin + 2) 2^k fine nodes per side (1088²
//! and 1664², FFT on twice that), 100–200 iterations of one box FFT pair each, and at k = 6
//! the setup (17.5 s: Pᵀh over the 16384² fine lattice, which took 16 of 24 s when each node
//! was evaluated twice (timed once, load average ~3.5; not re-timed since), the real-space
//! tables by 1-D transforms over the 16384-node period and the alias sums over f² = 4096 fine
//! modes per base mode, ~8 s then). The iteration count depends on where R's edge cuts the contact lines (207 at k = 5 with window 16², 76 at
//! k = 6 with 8²), not only on k.
//!
//! # Cost at a 1024² base (2026-11-26 #9)
//! The paper preset's deep ladders: 1024² base, window 32², margin 12 (`REFINE_METHOD=blockwise
//! REFINE_MARGIN=12 REFINE_BASE=10 REFINE_LEVELS=k REFINE_WINDOWS=32 REFINE_SKIP_REFERENCE=1
//! cargo bench -p contact --bench refinement`, `REFINE_MAX_ITER=20` at k = 5; square model at
//! 0.227 p_fc, cold start, tol_gap 1e-13; the bench prints CPU seconds of the setup and per
//! iteration). The machine was shared (load average 7–13 on 2 cores, wall times 2–3× the CPU
//! times), so CPU-seconds (all threads, user + system) are the figures; the setup's parts from
//! the ignored test `blocks::cost::setup_parts` (`SETUP_K=k`).
//!
//! | k (fine spacing) | setup CPU-s before → after | CPU-s per iteration | iterations | peak RSS |
//! |---|---|---|---|---|
//! | 3 (8192²) | 4.0 → 1.3 | 0.27 → 0.16 | 88, 88 | 275 → 331 MiB |
//! | 4 (16384²) | 15.9 → 5.1 | 0.59 → 0.27 | 97, 97 | 419 → 480 MiB |
//! | 5 (32768²) | 65.7 → 21.0 | 1.84 → 0.82 | –, 162 | 939 (20 iterations) → 1104 MiB |
//!
//! A whole cold solve: 28.0 → 15.5 CPU-s (k = 3), 72.7 → 31.6 (k = 4), 154 CPU-s after at
//! k = 5 (5.5 min wall on the loaded machine; before: 20 iterations capped, i.e. ~360 CPU-s
//! for the 162 iterations, estimated). (k = 3's peak after is from before the pool's best
//! fit, which took k = 4 from 498 to 480 MiB.) Before, the setup's
//! parts at k = 4 were: alias sums 1.6 CPU-s, computed twice (the blockwise operator's C and
//! the preconditioner's C⁻¹), the tables of G on the box and K on R 2.3 and 2.1 (1-D FFTs over
//! the 16384-node period), and Pᵀh over the 16384² fine lattice 8.2 (three cosines per fine
//! node through `TrigSurface::height`); after: alias sums 0.9 once, tables 1.3 and 1.1,
//! Pᵀh 1.7 (square model: no cosine per node). What changed:
//! - setup, bit for bit the old values (tests `the_fast_setup_is_bitwise_the_direct_one`,
//!   `fine_rows_are_the_profile_bit_for_bit`; same saddle gap to the 16 digits printed and
//!   the same iterations in the bench): the alias sums once; wave numbers per axis; the base
//!   modes a and n_x − a share their aliases' eigenvalues (one hypot and one division per two
//!   terms); table rows mirrored; the fine heights by rows with per-axis tables
//!   ([`blocks::FineRows`]: axis-aligned waves tabulated, the triangular and hexagonal
//!   profiles' oblique waves still one cosine per node each); hat weights tabulated;
//! - per application, bit for bit: work arrays pooled (a fresh base-grid array per term cost
//!   5.5 s of system time, page faults, in a 28 CPU-s solve at k = 3), the one-window gradient
//!   without per-node bookkeeping, bilinear stencils per row and column;
//! - per application, to rounding (saddle gap +5e-12 relative at k = 3, +7e-12 at k = 4, same
//!   iterations and contact area): C v_F on E only (four base FFT pairs, not five; test
//!   `the_local_far_field_is_the_base_transform`, 1e-14), and the box's and R's zero-padded
//!   convolutions on 2^a 3^b 5^c sides ([`blocks::Padded`]): their natural doubled sides were
//!   2·463, 2·927 (2·3²·103), 2·1855 (2·5·7·53), 2·257, 2·513 — large primes, transformed by
//!   Rader's algorithm.
//!
//! Peak memory grew by the pooled arrays and the padded blocks' buffers (~60 MiB at k = 4,
//! more at k = 5). Left: at k = 5 the box (1855² fine nodes, transformed on 3750²) is most of
//! an iteration; the tables are bound by their 1-D FFTs and the alias sums by hypot; the
//! triangular and hexagonal Pᵀh still costs two cosines per fine node (1.1e9 nodes at k = 5).
//! Faster still but not bit for bit: Pᵀh in closed form (the hat filter of each cosine wave,
//! O(N_base) per wave), the table rows by real or cosine transforms, the alias sums with
//! sqrt(x² + y²) for hypot.
//!
//! # Fit to drive the near-critical ladder?
//! Not yet below |l| ~ 1e-4. What holds: the discretisation is the composite one (local slopes
//! within 6.4e-4 of the uniform ones at fixed l), the fine lattice is never allocated, at k = 3
//! one solve costs less than a uniform 2048² solve and at k = 4 about 1.3 of them, and k = 5, 6
//! run (60–82 s wall, 78–91 CPU-seconds per cold solve, 0.26–0.47 GB). What does not: (i) the far-field
//! interpolation adds an error that acts like a shift of the reduced load by ~1e-7 … 1e-6
//! (falling with the margin and the base resolution, see above), which at |l| = 1e-5 would be
//! 1–10 % of the saddle gap unless the margin and base grid are chosen to push it below ~1e-9
//! (to be measured: vary the margin at the rung); (ii) 2–5× the uniform iterations (interface,
//! see "Preconditioner"); (iii) the box grows like 2^k, so k = 6 needs a window of a few base
//! cells, and a rung also needs p_c of the refined discretisation (~30 warm-started solves of
//! the bisection); (iv) no flow on the composite gap.
//!
//! # Several windows ([`RefinedModel::multi`], [`flow_saddles`])
//! The flow passes through every critical saddle of the cell: two per cell for the square model
//! (one per flow direction) and twelve for the triangular and hexagonal cells 4λ/√3 × 2λ, four
//! per channel orientation, the orientations at 0° and ±60° to one grid axis
//! ([`saddles`]; [`flow_saddles`] returns every saddle at the profile's one saddle height).
//! [`RefinedModel::multi`] refines a list of windows (same k, each its own rectangle of base
//! cells) in one composite discretisation: the unknowns are the fine nodes of every region (in
//! the windows' order), then the base nodes outside all of them; one energy, one PK solve, no
//! outer iteration, as for one window. One window is the special case: [`RefinedModel::new`],
//! [`RefinedModel::blockwise`] and [`RefinedModel::with_preconditioner`] call it with a list of
//! one (every printed value of this module's tests unchanged to the digits printed, 10 in the
//! saddle gaps; the blockwise sums keep the one-window order of operations).
//!
//! What is exact: as for one window, the discretisation (a Ritz subspace of the fine problem;
//! the full operator, `margin` None, applies it exactly for any number of windows that share no
//! base node), the weights, heights and force balance. With the blockwise operator each window
//! has its own near-field box (its fine remainder d_w and the hats of its E_w, exact), the hats
//! of every base node see d_w exactly if they lie in E_w and through the interpolated far field
//! otherwise (as for one window), and several windows' E may overlap (a base node in two E's
//! takes both exact terms; the bookkeeping is in [`blocks`]).
//!
//! What is approximated, beyond the one-window far field: the remainders of two windows,
//! d_A against d_B, interact through the far field on both sides, Π_A C'' Π_Bᵀ (C'' the fine
//! kernel sampled on the base lattice, an alias sum like C and C', tested against the real-space
//! table to 1e-10; Π the windows' Lagrange interpolations). Symmetric (one energy). Windows must
//! therefore lie apart by more than `margin` + ORDER/2 base cells along x or y (so that neither
//! window's interpolation stencil reaches into the other's charges; nearer windows are refused
//! with an error naming both). Measured on operators (64 × 32 base, windows 4²; test
//! `the_blockwise_operator_of_several_windows_is_the_composite_one`): max |A'x − A'_full x| / max |A'_full x| = 3.1e-4 (f = 2) and 3.3e-3
//! (f = 4) for two windows 10 cells apart at margin 5, 2.6e-3 at margin 7, against 5.6e-5 and
//! 7.8e-5 for one window; with the cross term switched off (a temporary edit, not kept) 3.4e-2, so it carries ~99 % of the cross
//! interaction. That error does not fall with the windows' distance (1.2e-3 at 34 cells, f = 4)
//! nor with ORDER (4 → 12 leaves it at ~1e-4, f = 2), because the fine lattice's kernel is not
//! smooth on the fine scale: its spectrum 2/|q| is cut off sharply at the fine Nyquist
//! frequency, which leaves a component alternating from fine node to fine node, (−1)^i, that
//! decays like the kernel itself (second differences along x at 40–60 fine nodes alternate in
//! sign, ±1.3e-6 where the kernel is 3.3e-6; ignored test `blocks::ringing`). Sampled on the base
//! lattice it is a constant offset per residue class, which no interpolation from base nodes
//! represents. The hats' far field does not have it (the hat's spectrum vanishes at those
//! aliases), so one window is unaffected; between two windows' point-like remainders it is lost,
//! a relative error of ~1e-3 of their (small) interaction. An exact treatment needs the kernel per
//! fine residue class (f² base convolutions per window, or (2f − 1)² by differences): not done.
//! It is a lattice artefact: the uniform fine solve has it, the continuum does not. In solves it shows: triangular, 64² base, k = 2, twelve
//! windows of 6², p_c −3.7e-4 from uniform 256² blockwise (margins 5 and 8 alike) against
//! −2.8e-4 with the full operator; for one window the two agree to 7e-6. So with many windows
//! the full operator (where the fine lattice fits) or larger margins are the reference.
//!
//! Measured (tests/refinement_multi.rs, 2.3 s; triangular, 64² base, k = 1, windows 10² at all
//! twelve saddles, full operator, against uniform 128², each at its own p_c = the load at which
//! the first of the twelve saddles closes): p_c −1.3e-4 (one window at the axis saddle −1.1e-5,
//! decided by a coarse saddle; base grid alone +2.9e-4); the largest saddle-gap error over the
//! twelve at l = −2e-2, −1e-2, −5e-3, −2e-3: 1.1e-2, 2.2e-2, 4.1e-2, 7.5e-2 (one window 3.8e-2,
//! 3.2e-2, 0.25, 1.6; base alone 8.8e-2, 7.9e-2, 9.1e-2, 0.12); max/min − 1 of the twelve
//! gaps (0 in the continuum): 1.3e-2, 1.3e-3, 5.0e-2, 3.1e-2 (uniform 1.3e-2, 6.4e-3, 2.8e-2,
//! 2.4e-2; one window 4.6e-2, 3.8e-2, 0.22, 1.6). Exploration (the ignored `explore`, 64²
//! base, k = 2, against 256²): windows of 6², 10², 14² give p_c −2.8e-4, −8.3e-5, −1.5e-5
//! (full operator) and saddle gaps within 0.28, 6.7e-2, 8.6e-3 at l = −2e-3; 128² base, k = 1,
//! windows 16² blockwise margin 8: p_c −3.9e-5 (base alone +1.9e-6, one window +8.5e-5),
//! gaps within 3.6e-3, 6.6e-3, 1.2e-2, 2.4e-2.
//!
//! So for the triangular model the composite's floor is far above the square model's ~1e-3:
//! its contact patches cover two thirds of the cell and their contact lines run everywhere
//! outside the windows, where the coarse hats' contact conditions (hat means) shift the load;
//! the floor falls as the windows cover more of the cell (6² → 14² of 64²), and it is worst at
//! the saddles whose channels run at ±60° to the grid. The gaps of the ±60° saddles are the
//! worse ones at every load. Refining every saddle does make the twelve saddle gaps nearly
//! equal (as they are in the continuum) and far closer to the uniform fine ones than one window
//! does; it does not beat the base grid's p_c on these small bases.
//!
//! # Every saddle refined near p_c (example `critical/examples/multi_window.rs`)
//! Triangular model, 256² base, k = 2 (fine spacing of 1024²), windows of 16² base cells at
//! all twelve saddles, blockwise margin 8, tol_gap 1e-13, each discretisation at its own p_c
//! (first saddle to close, bisection to 1e-9) (`nice cargo run --release -p critical --example
//! multi_window -- n=8 k=2 region=16 margin=8`; 2 cores shared with two other sessions, load
//! average ~8, the job got 57 % of a core: 106 CPU-s, 3 min 17 s wall, 256 MB peak):
//! - p_c/p_fc 0.7119563267 against uniform 1024² 0.7119590886 (−3.9e-6; base grid alone
//!   −5.5e-5 from uniform, one window at the axis saddle +1.2e-5);
//! - mean saddle gap per channel orientation (30°, 90°, 150°) against uniform 1024² at
//!   l = −1e-3, −5e-4, −2e-4, −1e-4: 30° and 150° +1.7e-3, −1.1e-3, −1.8e-3, −1.5e-3; 90° (the
//!   orientation along a grid axis) +7.6e-3, +1.4e-2, +3.6e-2, +6.0e-2. The growth like 1/|l|
//!   is a load shift: the 90° saddles of this composite close ~4e-6 (relative) after the
//!   others, those of the uniform grid ~1e-6 before them. max/min − 1 of the twelve gaps
//!   7.1e-3, 1.6e-2, 2.3e-2, 5.0e-2 (uniform 1024²: 1.2e-3, 5.1e-4, 1.5e-2, 1.1e-2). One window
//!   at the axis saddle instead (`one=1`): the twelve gaps differ by 6.9e-2, 7.3e-2, 5.2e-3,
//!   0.18 and the coarse saddles' gaps are 10–90 % off;
//! - cost: 4.6 s and 36 iterations per warm-started solve (12 windows; one window 0.38 s and
//!   37 iterations; uniform 1024² 2.6 s per solve in the same run), setup 0.2 s, the flow
//!   (Kx and Ky, critical::window_flow) 0.4 s per load. Each iteration applies 12 box FFT pairs
//!   (272²) and ~50 base-grid convolutions (four per window then: C' v_F, C v_F, C' w, C'' w);
//!   the latter dominate (C v_F is now formed on E, see "Blockwise application": three per
//!   window; merging the far terms would cut more).
//!
//! Hexagonal model, the same set-up (`lattice=hexagonal`; 103 CPU-s with the uniform
//! reference, 262 MB): p_c/p_fc 0.0317204494 against uniform 1024² 0.0317213933 (−3.0e-5; base
//! alone −2.6e-4 from uniform); saddle gaps of the 60° and 120° groups +1.2e-3, +1.4e-3,
//! +1.4e-3, +1.8e-3 from uniform at l = −1e-3 … −1e-4 (the group that closes first in both),
//! of the 0° group (channel along x) −2.7e-2, −4.6e-2, −8.9e-2, −0.15; max/min − 1 of the
//! twelve 2.8e-2, 3.2e-2, 2.7e-2, 0.17 against the uniform 1024² grid's own 3.9e-4, 1.7e-2,
//! 0.13, 0.37. So on the uniform grid the 0° saddles stay open well after the ±60° ones close
//! (by 37 % in the gap at l = −1e-4, a split of the closing loads of ~3e-5), and the composite
//! splits them less (17 %), but the two discretisations of the same fine spacing disagree on the
//! 0° saddles by up to 15 %: the coarse region, not the spacing, decides this split, so neither
//! number is the continuum's (0). 3.1 s and 30 iterations per solve, flow 0.6 s per load.
//!
//! Triangular, k = 3 (2048² spacing), twelve windows of 16², no uniform reference: stopped
//! after 14 min 43 s CPU (25 min wall) inside the p_c bisection; not measured. With twelve
//! boxes of 544² per iteration this is well over the issue's cost target.
//!
//! Kx/Ky from the refined composite (critical::window_flow::refined_multi_flow) and its
//! comparison with uniform 1024² are in critical::window_flow's docs.
//!
//! # What is left
//! - Nested windows (not done). Level m = 0..k refines by 2 a window R_m of a fixed number c of
//!   its own cells (sized to the neck: |l|^χ along the channel, |l|^υ across, with margin),
//!   R_{m+1} inside R_m. The space stays one of bilinear hats: level-m hats on the nodes of
//!   R_m outside R_{m+1} (as base hats outside R now), fine nodes in R_k; one energy with G_f,
//!   so PK needs no outer loop, and the unknowns grow like N_base + k c². The operator as the
//!   blockwise one applied per level: the level-m hats' mutual table is translation invariant
//!   on the level-m lattice (alias sums, as C now), the near field of each level on a box of
//!   (c + 2 margin) level-m cells (fixed size, so the work is linear in k instead of the
//!   single box's 4^k), coarser levels reaching finer ones through the two-scale relation of
//!   bilinear hats (a level-m hat is 9 level-(m+1) hats, exact) near the window and through the
//!   adjoint interpolation of the far field (the one approximation, as now). Preconditioner: the
//!   additive one extended level by level (C⁻¹ on the base, K restricted to each R_m on its
//!   lattice's hats). Tables per level need the fine spectrum's alias sums over 4^(k−m) modes
//!   per level-m mode: at k = 6 the setup is already 17.5 of 82 s, so they should come
//!   from the continuum kernel plus a lattice correction, or from level m + 1's table.
//! - Iterations at partial windows (1.5–3× the uniform count at k ≤ 3, more at k = 5): the
//!   interface; a multiplicative (symmetrised) coarse correction or the free set's restriction
//!   taken into the coarse solve are the candidates.
//! - The flow on the composite gap: `critical::window_flow` (series replacement for one
//!   window, a rescaled base cell for several); [`Refined::windows`] holds each region's fine
//!   gap, [`Refined::base_gap`] every base node's.
//! - Several windows: the cross-window far-field error above (the fine kernel's grid-scale
//!   component), and the coarse
//!   region's floor for the triangular model (larger windows, or nested ones).
//! - [`EdgeRuns`] reports a window that is too small (no contact line crossing its edge, or a
//!   run of open or contact nodes on the edge shorter than a given number of base cells), read
//!   on the region's second ring of fine nodes (the edge's base nodes carry the coarse hats)
//!   with slivers of 1–2 nodes merged ([`SLIVER_NODES`]).

pub mod blocks;
pub mod coupled;
pub mod saddles;
pub mod twolevel;

pub use saddles::{FlowSaddle, flow_saddles};

/// The preconditioner of the composite solve (see the module docs, "Preconditioner").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Preconditioner {
    /// Pᵀ K_f P, the fine stiffness seen through the composite basis (the first design).
    Galerkin,
    /// Exact coarse solve C⁻¹ on the base grid plus K_f on R's fine nodes, added
    /// ([`twolevel`]).
    #[default]
    Additive,
    /// The same with the fine space restricted to R's non-base nodes (hierarchical basis).
    Hierarchical,
}

/// Points per axis of the far field's Lagrange interpolation in the blockwise operator.
pub const ORDER: usize = 8;

use crate::compliance::Compliance;
use crate::elastic::ElasticKernel;
use crate::free_kernel::{FreeKernel, rows};
use crate::spectral::RowSums;
use crate::{ContactError, Interaction, Model, Solution, SolveStats, SolverOptions};
use ndarray::Array2;
use rayon::prelude::*;
use surface::{Grid, Surface};

/// The refined region: base cells [i0, i0 + wx) × [j0, j0 + wy) (periodic indices), i.e. the
/// closed rectangle of base nodes i0 ..= i0 + wx, j0 ..= j0 + wy; `wx = nx` (`wy = ny`) refines
/// the whole period along x (y).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    /// First base node along x.
    pub i0: usize,
    /// First base node along y.
    pub j0: usize,
    /// Base cells along x.
    pub wx: usize,
    /// Base cells along y.
    pub wy: usize,
}

impl Window {
    /// The window of `wx × wy` base cells centred (to a node) on the point (x, y) of `grid`.
    pub fn centred(grid: &Grid, x: f64, y: f64, wx: usize, wy: usize) -> Window {
        let ci = (x / grid.dx() - grid.shift.0).round() as isize;
        let cj = (y / grid.dy() - grid.shift.1).round() as isize;
        Window {
            i0: (ci - wx as isize / 2).rem_euclid(grid.nx as isize) as usize,
            j0: (cj - wy as isize / 2).rem_euclid(grid.ny as isize) as usize,
            wx,
            wy,
        }
    }
}

/// Options of a refined solve.
#[derive(Debug, Clone)]
pub struct RefineOptions {
    /// Refinement levels k (fine spacing = base spacing / 2^k), 1..=6.
    pub levels: u32,
    /// The refined window.
    pub window: Window,
    /// Options of the composite solve (hard wall, Polonsky–Keer); `tol_gap` bounds the
    /// violation of the composite constraints (see the module docs).
    pub solver: SolverOptions,
}

/// A refined solution.
#[derive(Debug, Clone)]
pub struct Refined {
    /// Grid of the fine region: its nodes are fine-lattice nodes `origin + (a, b)` (periodic),
    /// spacing that of the fine lattice.
    pub window_grid: Grid,
    /// Fine-lattice index of the region's first node (periodic).
    pub origin: (usize, usize),
    /// Shape of the fine lattice (base shape × 2^k).
    pub lattice: (usize, usize),
    /// Pressure on the fine region (E* h0/λ).
    pub window_pressure: Array2<f64>,
    /// Gap on the fine region (h0): the fine node's gap, exactly 0 at contact, except on the
    /// base nodes of the region's edge, whose unknown also carries the hats of the coarse cells
    /// next to it (there it is the hat-weighted mean gap).
    pub window_gap: Array2<f64>,
    /// Nodal pressure of the coarse hats on every base node (nx × ny; inside the region the
    /// fine pressure at that node).
    pub base_pressure: Array2<f64>,
    /// Gap on every base node (nx × ny; h0): inside a region the fine gap at that node,
    /// outside the coarse unknown's (hat-weighted mean) gap, the quantity its contact
    /// condition holds for.
    pub base_gap: Array2<f64>,
    /// Rigid approach δ (h0).
    pub approach: f64,
    /// Fraction of the cell in contact: Σ over unknowns in contact of their weight (fine pixels
    /// covered, see the module docs) over the fine lattice's node count.
    pub contact_area: f64,
    /// Statistics of the composite solve.
    pub stats: SolveStats,
    /// The composite solution (unknowns packed row by row; the warm start of the next solve).
    pub composite: Solution,
    /// Contact lines on the region's edge (the window-size check).
    pub edge: EdgeRuns,
    /// Every refined window's fine solution, in the order of the windows (the fields above
    /// are the first one's).
    pub windows: Vec<WindowSolution>,
}

/// Runs of fewer fine nodes than this on the window's edge ring are slivers: merged into their
/// neighbours before the contact lines are counted ([`EdgeRuns::of`]). A contact line's position
/// on a lattice is known to one node: where it grazes the ring (runs nearly parallel to it, or
/// crosses it at a shallow angle) its staircase alternates the state over runs of 1–2 nodes
/// (measured: triangular, 128² base, k = 3, window 16, l ≤ −2e-4, one-node runs beside each
/// of the four real crossings), so a run of ≤ 2 nodes is below what the lattice resolves. Any
/// structure the window check accepts is at least `min_cells` base cells, i.e. ≥ 2^k ≥ 2 fine
/// nodes per base cell, wide (the kind's default min_cells 2: ≥ 4 fine nodes); a real
/// channel or bridge of ≤ 2 nodes on the ring is merged away, so the ring then shows fewer
/// crossings, which flags the window just as a narrow run would (test
/// `a_too_small_window_is_reported`).
pub const SLIVER_NODES: usize = 3;

/// The contact state along the region's edge ring (once around): the runs of open and of
/// contact nodes between the points where a contact line crosses it, after merging slivers.
///
/// The ring is the region's second ring of fine nodes (one node inside its edge), not the
/// edge itself: the edge's base nodes are unknowns that also carry the coarse hats outside the
/// region, so their contact state is that of a hat-weighted mean gap, not of the node. Where a
/// contact line meets the edge next to a base node that node's state differs from its fine
/// neighbours' (measured: open with a hat-mean gap of 1.7e-3 h0 between fine nodes in contact;
/// a one-node contact tongue beside it), which made one-node runs and eight extra crossings.
/// The second ring holds no base node (for 2^k ≥ 2 its index 1 is not a multiple of 2^k).
/// Slivers (runs shorter than [`SLIVER_NODES`]) are then merged, shortest first, into the
/// state around them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EdgeRuns {
    /// Contact lines crossing the ring after merging slivers (state changes once around; even).
    pub crossings: usize,
    /// Shortest run of open nodes between two crossings, in base cells (None without
    /// crossings), after merging slivers.
    pub narrowest_open: Option<f64>,
    /// Shortest run of contact nodes between two crossings, in base cells, likewise.
    pub narrowest_contact: Option<f64>,
    /// Whether the whole ring is in contact (meaningful without crossings).
    pub all_contact: bool,
    /// State changes on the ring before merging slivers.
    pub raw_crossings: usize,
    /// Slivers merged.
    pub slivers: usize,
}

impl EdgeRuns {
    /// Runs of `contact` (rx × ry, row-major) around the region's second ring (its edge ring if
    /// rx or ry < 3); `f` fine nodes per base cell (struct docs).
    pub fn of(contact: &[bool], rx: usize, ry: usize, f: usize) -> EdgeRuns {
        let inset = usize::from(rx >= 3 && ry >= 3);
        let (x0, x1, y0, y1) = (inset, rx - 1 - inset, inset, ry - 1 - inset);
        let at = |a: usize, b: usize| contact[a * ry + b];
        let mut ring: Vec<bool> = Vec::with_capacity(2 * (rx + ry));
        ring.extend((y0..=y1).map(|b| at(x0, b)));
        ring.extend((x0 + 1..=x1).map(|a| at(a, y1)));
        if x1 > x0 {
            ring.extend((y0..y1).rev().map(|b| at(x1, b)));
        }
        if y1 > y0 {
            ring.extend((x0 + 1..x1).rev().map(|a| at(a, y0)));
        }
        Self::of_ring(&ring, f)
    }

    /// Runs of a closed ring of contact states (`f` nodes per base cell), slivers merged.
    pub fn of_ring(ring: &[bool], f: usize) -> EdgeRuns {
        let n = ring.len();
        let starts: Vec<usize> = (0..n)
            .filter(|&k| ring[k] != ring[(k + n - 1) % n])
            .collect();
        // runs once around: (state, nodes)
        let mut runs: Vec<(bool, usize)> = starts
            .iter()
            .enumerate()
            .map(|(i, &k)| {
                let next = starts[(i + 1) % starts.len()];
                let len = (next + n - k) % n;
                (ring[k], if len == 0 { n } else { len })
            })
            .collect();
        let raw_crossings = runs.len();
        let mut slivers = 0;
        // merge the shortest sliver into its two neighbours (same state) until none is left
        while runs.len() > 2 {
            let (i, &(_, len)) = runs
                .iter()
                .enumerate()
                .min_by_key(|(_, r)| r.1)
                .expect("runs");
            if len >= SLIVER_NODES {
                break;
            }
            let m = runs.len();
            let (prev, next) = ((i + m - 1) % m, (i + 1) % m);
            let merged = (runs[prev].0, runs[prev].1 + len + runs[next].1);
            // remove i and next, put the merged run at prev (indices shift if they wrap)
            let mut keep: Vec<(bool, usize)> = Vec::with_capacity(m - 2);
            for (j, &r) in runs.iter().enumerate() {
                if j == prev {
                    keep.push(merged);
                } else if j != i && j != next {
                    keep.push(r);
                }
            }
            runs = keep;
            slivers += 1;
        }
        // two runs left with a sliver among them: the ring is one state
        if runs.len() == 2 && runs.iter().any(|r| r.1 < SLIVER_NODES) {
            let big = *runs.iter().max_by_key(|r| r.1).expect("two runs");
            runs = vec![(big.0, n)];
            slivers += 1;
        }
        let crossings = if runs.len() > 1 { runs.len() } else { 0 };
        let (mut open, mut touch) = (None::<f64>, None::<f64>);
        if crossings > 0 {
            for &(state, len) in &runs {
                let len = len as f64 / f as f64;
                let slot = if state { &mut touch } else { &mut open };
                *slot = Some(slot.map_or(len, |v: f64| v.min(len)));
            }
        }
        EdgeRuns {
            crossings,
            narrowest_open: open,
            narrowest_contact: touch,
            all_contact: if crossings == 0 {
                runs.first().is_some_and(|r| r.0) || (runs.is_empty() && ring.iter().all(|&c| c))
            } else {
                false
            },
            raw_crossings,
            slivers,
        }
    }

    /// The window is too small for the neck if no contact line crosses its ring (it lies inside
    /// the open channel or inside a contact patch: the contact lines that bound the neck are
    /// left to the coarse grid), or if a run of either state on the ring is shorter than
    /// `min_cells` base cells (the narrow part of the channel or of the contact bridge reaches
    /// the edge). Slivers were merged before (struct docs). A caller that knows the neck's
    /// topology also checks the count (`critical::refined`: a channel through the saddle
    /// crosses the ring at both ends, with both sides: at least 4).
    pub fn too_small(&self, min_cells: f64) -> bool {
        self.crossings == 0
            || self.narrowest_open.is_some_and(|w| w < min_cells)
            || self.narrowest_contact.is_some_and(|w| w < min_cells)
    }
}

impl Refined {
    /// Gap at fine-lattice node (i, j), if it lies in a refined region.
    pub fn fine_gap(&self, i: usize, j: usize) -> Option<f64> {
        self.windows
            .iter()
            .find_map(|w| w.fine_gap(self.lattice, i, j))
    }
}

/// One refined region of the composite operator.
struct Region {
    /// Origin on the fine lattice and extent (fine nodes).
    origin: (usize, usize),
    rx: usize,
    ry: usize,
    /// Index of its first fine unknown.
    offset: usize,
    /// Fine-lattice rows (columns) inside the region.
    in_x: Vec<bool>,
    in_y: Vec<bool>,
}

/// The composite operator (see the module docs): unknowns are the fine nodes of each region in
/// order (index offset + a·ry + b), then the coarse base nodes outside every region, then
/// padding up to `rows × cols`.
pub struct Composite {
    /// The fine lattice's kernel (the full application), or None (blockwise, [`blocks`]).
    fine: Option<ElasticKernel>,
    /// Blockwise operators: compliance and (Galerkin preconditioner only) stiffness.
    blocks: Option<Box<[Option<blocks::Blocks>; 2]>>,
    /// The two-level preconditioner, if chosen.
    twolevel: Option<Box<twolevel::TwoLevel>>,
    /// Whether each base node lies on a region.
    on_r: Vec<bool>,
    parallel: bool,
    point: f64,
    nx: usize,
    ny: usize,
    f: usize,
    fnx: usize,
    fny: usize,
    /// The refined regions.
    regions: Vec<Region>,
    /// Fine unknowns of all regions.
    nf: usize,
    /// Composite index of every base node (a region's fine unknown where it lies inside).
    base_index: Vec<usize>,
    /// Unknowns (without padding) and the packed shape.
    n: usize,
    rows: usize,
    cols: usize,
    /// w = Pᵀ1: fine pixels each unknown covers.
    weight: Vec<f64>,
    /// Compliance given to the padding unknowns (they never carry load).
    pad_compliance: f64,
    /// Fine-lattice work field and the packed result.
    buf: Vec<f64>,
    hat: Vec<f64>,
    out: Vec<f64>,
}

impl Composite {
    #[allow(clippy::too_many_arguments)]
    /// The operator for a base grid of `nx × ny` nodes on `lx × ly`, refined `f` times in
    /// each of `windows` (already checked: inside the grid, and apart as
    /// [`check_windows`] asks).
    fn new(
        nx: usize,
        ny: usize,
        lx: f64,
        ly: f64,
        f: usize,
        windows: &[Window],
        margin: Option<usize>,
        pre: Preconditioner,
    ) -> Self {
        let (fnx, fny) = (nx * f, ny * f);
        let geometries: Vec<blocks::Geometry> = windows
            .iter()
            .map(|w| blocks::Geometry {
                nx,
                ny,
                lx,
                ly,
                f,
                i0: w.i0,
                j0: w.j0,
                wx: w.wx,
                wy: w.wy,
                margin: margin.unwrap_or(0),
                order: ORDER,
            })
            .collect();
        // the hats' compliance spectrum: the blockwise operator's and the two-level
        // preconditioner's (computed once)
        let alias = (margin.is_some() || pre != Preconditioner::Galerkin)
            .then(|| blocks::alias_spectra(&geometries[0], blocks::Kernel::Compliance));
        let (fine, blocks) = match margin {
            None => {
                let fine_grid = Grid {
                    nx: fnx,
                    ny: fny,
                    lx,
                    ly,
                    shift: (0.0, 0.0),
                };
                (Some(ElasticKernel::new(&fine_grid, 1.0)), None)
            }
            Some(_) => {
                let compliance = alias.as_ref().expect("alias sums");
                let pair = [
                    Some(blocks::Blocks::new(
                        &geometries,
                        blocks::Kernel::Compliance,
                        compliance,
                    )),
                    (pre == Preconditioner::Galerkin).then(|| {
                        let stiffness =
                            blocks::alias_spectra(&geometries[0], blocks::Kernel::Stiffness);
                        blocks::Blocks::new(&geometries, blocks::Kernel::Stiffness, &stiffness)
                    }),
                ];
                (None, Some(Box::new(pair)))
            }
        };
        let (parallel, point) = match (&fine, &blocks) {
            (Some(k), _) => (k.parallel(), k.point_compliance()),
            (None, Some(b)) => (
                rayon::current_num_threads() > 1,
                b[0].as_ref().expect("compliance").point,
            ),
            _ => unreachable!(),
        };
        let mut regions = Vec::with_capacity(windows.len());
        let mut offset = 0;
        for w in windows {
            let origin = (w.i0 * f, w.j0 * f);
            let rx = (w.wx * f + 1).min(fnx);
            let ry = (w.wy * f + 1).min(fny);
            regions.push(Region {
                origin,
                rx,
                ry,
                offset,
                in_x: (0..fnx).map(|i| (i + fnx - origin.0) % fnx < rx).collect(),
                in_y: (0..fny).map(|j| (j + fny - origin.1) % fny < ry).collect(),
            });
            offset += rx * ry;
        }
        let n_fine = offset;
        let mut base_index = vec![0; nx * ny];
        let mut next = n_fine;
        for i in 0..nx {
            for j in 0..ny {
                let inside = regions.iter().find_map(|r| {
                    let (a, b) = (
                        (f * i + fnx - r.origin.0) % fnx,
                        (f * j + fny - r.origin.1) % fny,
                    );
                    (a < r.rx && b < r.ry).then_some(r.offset + a * r.ry + b)
                });
                base_index[i * ny + j] = match inside {
                    Some(k) => k,
                    None => {
                        next += 1;
                        next - 1
                    }
                };
            }
        }
        let n = next;
        let on_r: Vec<bool> = base_index.iter().map(|&k| k < n_fine).collect();
        let ry0 = regions[0].ry;
        let cols = ry0 + ry0 % 2;
        let rows = n.div_ceil(cols);
        let rows = rows + rows % 2;
        let full = fine.is_some();
        let mut c = Composite {
            pad_compliance: point,
            fine,
            blocks,
            twolevel: None,
            on_r,
            parallel,
            point,
            nx,
            ny,
            f,
            fnx,
            fny,
            regions,
            nf: n_fine,
            base_index,
            n,
            rows,
            cols,
            weight: Vec::new(),
            buf: if full {
                vec![0.0; fnx * fny]
            } else {
                Vec::new()
            },
            hat: vec![0.0; nx * ny],
            out: vec![0.0; rows * cols],
        };
        if full {
            let ones = vec![1.0; n];
            c.prolong(&ones, None);
            c.restrict();
            c.weight = c.out[..n].to_vec();
        } else {
            let mut weight = Vec::with_capacity(n);
            let mut wc = 0.0;
            for g in &geometries {
                let (wr, w_coarse) = blocks::weights(g);
                weight.extend(wr);
                wc = w_coarse;
            }
            weight.resize(n, wc);
            c.weight = weight;
        }
        if pre != Preconditioner::Galerkin {
            let shapes: Vec<(usize, usize)> = c.regions.iter().map(|r| (r.rx, r.ry)).collect();
            let weights: Vec<&[f64]> = c
                .regions
                .iter()
                .map(|r| &c.weight[r.offset..r.offset + r.rx * r.ry])
                .collect();
            c.twolevel = Some(Box::new(twolevel::TwoLevel::new(
                &geometries,
                &shapes,
                &weights,
                pre == Preconditioner::Hierarchical,
                &alias.as_ref().expect("alias sums").c,
            )));
        }
        c
    }

    /// Whether the operator is applied blockwise ([`blocks`]).
    pub fn blockwise(&self) -> bool {
        self.blocks.is_some()
    }

    /// out = A' x or M x, blockwise.
    fn apply_blocks(&mut self, stiffness: bool, x: &[f64]) {
        let (n, nf) = (self.n, self.nf);
        let q: Vec<f64> = if stiffness {
            x[..n].to_vec()
        } else {
            x[..n]
                .iter()
                .zip(&self.weight)
                .map(|(a, w)| a / w)
                .collect()
        };
        let v: Vec<f64> = self.base_index.iter().map(|&k| q[k]).collect();
        let b = self.blocks.as_mut().expect("blockwise")[usize::from(stiffness)]
            .as_mut()
            .expect("blocks of this kernel");
        let (gf, gv) = b.apply(&q[..nf], &v);
        self.out[..nf].copy_from_slice(&gf);
        for (k, &idx) in self.base_index.iter().enumerate() {
            if idx >= nf {
                self.out[idx] = gv[k];
            }
        }
        b.recycle(gv);
        if !stiffness {
            for (o, w) in self.out[..n].iter_mut().zip(&self.weight) {
                *o /= w;
            }
        }
        let c = self.pad_compliance;
        for k in n..self.out.len() {
            self.out[k] = if stiffness { x[k] / c } else { x[k] * c };
        }
    }

    /// out = W B' W x, the two-level preconditioner ([`twolevel`]), padding diagonal.
    fn apply_twolevel(&mut self, x: &[f64]) {
        let (n, nf) = (self.n, self.nf);
        // B' = Π B Πᵀ with Π = I − w 1ᵀ/Σw: a uniform gap (the solver's rigid approach)
        // gives no force, and the output's net force is removed as a uniform pressure, not as
        // the uniform force the solver's mean removal would take from it
        let wsum: f64 = self.weight.iter().sum();
        let shift = x[..n]
            .iter()
            .zip(&self.weight)
            .map(|(a, w)| a * w)
            .sum::<f64>()
            / wsum;
        let y: Vec<f64> = x[..n]
            .iter()
            .zip(&self.weight)
            .map(|(a, w)| (a - shift) * w)
            .collect();
        let y_out: Vec<f64> = self
            .base_index
            .iter()
            .map(|&k| if k >= nf { y[k] } else { 0.0 })
            .collect();
        let t = self.twolevel.as_mut().expect("two-level");
        let (z_r, z_v) = t.apply(&y[..nf], &y_out, &self.on_r);
        self.out[..nf].copy_from_slice(&z_r);
        for (k, &idx) in self.base_index.iter().enumerate() {
            if idx >= nf {
                self.out[idx] = z_v[k];
            }
        }
        for (o, w) in self.out[..n].iter_mut().zip(&self.weight) {
            *o *= w;
        }
        let m = self.out[..n].iter().sum::<f64>() / wsum;
        for (o, w) in self.out[..n].iter_mut().zip(&self.weight) {
            *o -= m * w;
        }
        let c = self.pad_compliance;
        for k in n..self.out.len() {
            self.out[k] = x[k] / c;
        }
    }

    /// Fine-region unknown of fine node (i, j), if inside a region.
    fn region(&self, i: usize, j: usize) -> Option<usize> {
        self.regions.iter().find_map(|r| {
            (r.in_x[i] && r.in_y[j]).then(|| {
                r.offset
                    + ((i + self.fnx - r.origin.0) % self.fnx) * r.ry
                    + (j + self.fny - r.origin.1) % self.fny
            })
        })
    }

    /// buf = P (q / w) (`weight` Some) or P q: the fine region's values, bilinear hats on the
    /// base cells outside it.
    fn prolong(&mut self, q: &[f64], weight: Option<&[f64]>) {
        let (f, nx, ny, fny) = (self.f, self.nx, self.ny, self.fny);
        let value = |k: usize| match weight {
            Some(w) => q[k] / w[k],
            None => q[k],
        };
        let mut buf = std::mem::take(&mut self.buf);
        let this = &*self;
        let fill = |(i, row): (usize, &mut [f64])| {
            let (bi, a) = (i / f, i % f);
            let bi1 = (bi + 1) % nx;
            let wa = a as f64 / f as f64;
            for (j, v) in row.iter_mut().enumerate() {
                if let Some(k) = this.region(i, j) {
                    *v = value(k);
                    continue;
                }
                let (bj, b) = (j / f, j % f);
                let bj1 = (bj + 1) % ny;
                let wb = b as f64 / f as f64;
                let idx = |p: usize, q: usize| this.base_index[p * ny + q];
                *v = (1.0 - wa) * ((1.0 - wb) * value(idx(bi, bj)) + wb * value(idx(bi, bj1)))
                    + wa * ((1.0 - wb) * value(idx(bi1, bj)) + wb * value(idx(bi1, bj1)));
            }
        };
        if self.parallel {
            buf.par_chunks_mut(fny).enumerate().for_each(fill);
        } else {
            buf.chunks_mut(fny).enumerate().for_each(fill);
        }
        self.buf = buf;
    }

    /// out[..n] = Pᵀ buf (the adjoint of [`Composite::prolong`] without the weights).
    fn restrict(&mut self) {
        let (f, ny, fnx, fny) = (self.f, self.ny, self.fnx, self.fny);
        let mut hat = std::mem::take(&mut self.hat);
        let this = &*self;
        let gather = |(i, row): (usize, &mut [f64])| {
            for (j, h) in row.iter_mut().enumerate() {
                let mut s = 0.0;
                for a in 1 - f as isize..f as isize {
                    let fi = (f as isize * i as isize + a).rem_euclid(fnx as isize) as usize;
                    let wa = 1.0 - a.unsigned_abs() as f64 / f as f64;
                    let line = &this.buf[fi * fny..(fi + 1) * fny];
                    let mut sa = 0.0;
                    for b in 1 - f as isize..f as isize {
                        let fj = (f as isize * j as isize + b).rem_euclid(fny as isize) as usize;
                        if this.regions.iter().any(|r| r.in_x[fi] && r.in_y[fj]) {
                            continue;
                        }
                        sa += (1.0 - b.unsigned_abs() as f64 / f as f64) * line[fj];
                    }
                    s += wa * sa;
                }
                *h = s;
            }
        };
        if self.parallel {
            hat.par_chunks_mut(ny).enumerate().for_each(gather);
        } else {
            hat.chunks_mut(ny).enumerate().for_each(gather);
        }
        let mut out = std::mem::take(&mut self.out);
        out.iter_mut().for_each(|v| *v = 0.0);
        for r in &self.regions {
            for a in 0..r.rx {
                let i = (r.origin.0 + a) % fnx;
                for b in 0..r.ry {
                    let j = (r.origin.1 + b) % fny;
                    out[r.offset + a * r.ry + b] = self.buf[i * fny + j];
                }
            }
        }
        for (k, h) in hat.iter().enumerate() {
            out[self.base_index[k]] += h;
        }
        self.hat = hat;
        self.out = out;
    }

    /// out = A' x (compliance: W⁻¹ Pᵀ G P W⁻¹) or M x (stiffness: Pᵀ K P), padding diagonal.
    fn apply(&mut self, stiffness: bool, x: &[f64]) {
        if stiffness && self.twolevel.is_some() {
            return self.apply_twolevel(x);
        }
        if self.blocks.is_some() {
            return self.apply_blocks(stiffness, x);
        }
        let n = self.n;
        let weight = std::mem::take(&mut self.weight);
        self.prolong(x, (!stiffness).then_some(&weight[..]));
        let mut buf = std::mem::take(&mut self.buf);
        self.fine.as_mut().expect("full operator").apply_fused(
            stiffness,
            &mut buf,
            |_, _| [0.0; 4],
            None,
            |_, _, _| [0.0; 4],
        );
        self.buf = buf;
        self.restrict();
        if !stiffness {
            for (o, w) in self.out[..n].iter_mut().zip(&weight) {
                *o /= w;
            }
        }
        let c = self.pad_compliance;
        for k in n..self.out.len() {
            self.out[k] = if stiffness { x[k] / c } else { x[k] * c };
        }
        self.weight = weight;
    }
}

impl Compliance for Composite {
    fn shape(&self) -> (usize, usize) {
        (self.rows, self.cols)
    }

    fn parallel(&self) -> bool {
        self.parallel
    }

    fn point_compliance(&self) -> f64 {
        self.point
    }

    fn displacement(&mut self, p: &[f64], u: &mut [f64]) {
        self.apply(false, p);
        u.copy_from_slice(&self.out);
    }

    fn apply_fused<P, F>(
        &mut self,
        stiffness: bool,
        input: &mut [f64],
        prepare: P,
        output: Option<&mut [f64]>,
        finish: F,
    ) -> (RowSums, f64, RowSums)
    where
        P: Fn(usize, &mut [f64]) -> RowSums + Sync,
        F: Fn(usize, &[f64], &mut [f64]) -> RowSums + Sync,
    {
        let (cols, parallel) = (self.cols, self.parallel());
        let before = rows(parallel, input, cols, &prepare);
        self.apply(stiffness, input);
        let out = &self.out;
        let quadratic: f64 = input
            .chunks(cols)
            .zip(out.chunks(cols))
            .map(|(a, b)| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>())
            .sum();
        let after = match output {
            Some(o) => {
                let inp: &[f64] = input;
                rows(parallel, o, cols, |i, row| {
                    row.copy_from_slice(&out[i * cols..(i + 1) * cols]);
                    finish(i, &inp[i * cols..(i + 1) * cols], row)
                })
            }
            None => rows(parallel, input, cols, |i, row| {
                row.copy_from_slice(&out[i * cols..(i + 1) * cols]);
                finish(i, &[], row)
            }),
        };
        (before, quadratic, after)
    }

    fn weights(&self) -> Option<&[f64]> {
        Some(&self.weight)
    }

    fn add_point_displacements(&mut self, sources: &[(usize, f64)], u: &mut [f64]) {
        let mut c = vec![0.0; u.len()];
        for &(k, v) in sources {
            c[k] += v;
        }
        self.apply(false, &c);
        for (ui, o) in u.iter_mut().zip(&self.out) {
            *ui += o;
        }
    }
}

fn check(surface: &Surface, pressure: f64, o: &RefineOptions) -> Result<(), ContactError> {
    check_windows(surface, o.levels, &[o.window], None)?;
    if !(pressure.is_finite() && pressure > 0.0) {
        return Err(ContactError::parameter(
            "pressure",
            pressure,
            "finite and > 0",
        ));
    }
    Ok(())
}

/// Base cells between the closed node intervals [a, a + wa] and [b, b + wb] on a circle of `n`
/// nodes (0 if they share a node).
fn interval_gap(a: usize, wa: usize, b: usize, wb: usize, n: usize) -> usize {
    let (a, b, n) = (a as isize, b as isize, n as isize);
    let (wa, wb) = (wa as isize, wb as isize);
    if (b - a).rem_euclid(n) <= wa || (a - b).rem_euclid(n) <= wb {
        return 0;
    }
    (b - a - wa).rem_euclid(n).min((a - b - wb).rem_euclid(n)) as usize
}

/// Checks the levels, every window, the margin (if blockwise) and that windows lie apart: with
/// the blockwise operator no base node of one window may lie within `margin` cells of another
/// (else their fine remainders would meet inside each other's exactly treated near field, which
/// the operator does not do: see the module docs, "Several windows"); with the full operator
/// windows must not share a base node.
fn check_windows(
    surface: &Surface,
    levels: u32,
    windows: &[Window],
    margin: Option<usize>,
) -> Result<(), ContactError> {
    let g = &surface.grid;
    if !(1..=6).contains(&levels) {
        return Err(ContactError::parameter("levels", levels as f64, "1..=6"));
    }
    if windows.is_empty() {
        return Err(ContactError::Parameter {
            name: "windows",
            value: "[]".into(),
            allowed: "at least one window",
        });
    }
    for &w in windows {
        if w.wx == 0 || w.wy == 0 || w.wx > g.nx || w.wy > g.ny || w.i0 >= g.nx || w.j0 >= g.ny {
            return Err(ContactError::Parameter {
                name: "window",
                value: format!("{w:?}"),
                allowed: "1..=nx × 1..=ny base cells starting inside the grid",
            });
        }
        if windows.len() > 1 && (w.wx >= g.nx || w.wy >= g.ny) {
            return Err(ContactError::Parameter {
                name: "window",
                value: format!("{w:?} (one of {} windows)", windows.len()),
                allowed: "less than the period along both axes when there are several windows",
            });
        }
        if let Some(margin) = margin
            && (margin < ORDER / 2 + 1
                || w.wx + 2 * margin + 2 > g.nx
                || w.wy + 2 * margin + 2 > g.ny)
        {
            return Err(ContactError::Parameter {
                name: "margin",
                value: format!(
                    "{margin} base cells (window {} × {}, grid {} × {})",
                    w.wx, w.wy, g.nx, g.ny
                ),
                allowed: "ORDER/2 + 1 ..= (n − w − 2)/2 along both axes (ORDER = 8)",
            });
        }
    }
    let need = margin.map_or(1, |m| m + ORDER / 2 + 1);
    for (ia, a) in windows.iter().enumerate() {
        for (ib, b) in windows.iter().enumerate().skip(ia + 1) {
            let gx = interval_gap(a.i0, a.wx, b.i0, b.wx, g.nx);
            let gy = interval_gap(a.j0, a.wy, b.j0, b.wy, g.ny);
            if gx.max(gy) < need {
                return Err(ContactError::Parameter {
                    name: "windows",
                    value: format!(
                        "window {ia} {a:?} and window {ib} {b:?}: {gx} × {gy} base cells apart \
                         along x × y, margin {margin:?}"
                    ),
                    allowed: "windows apart by more than the margin along x or y (blockwise), \
                              without a common base node (full operator)",
                });
            }
        }
    }
    Ok(())
}

/// Options of a refined solve with several windows (one composite discretisation: fine in
/// every window, coarse outside them; see the module docs, "Several windows").
#[derive(Debug, Clone)]
pub struct MultiOptions {
    /// Refinement levels k (the same in every window), 1..=6.
    pub levels: u32,
    /// The refined windows (at least one, apart as [`RefinedModel::multi`] requires).
    pub windows: Vec<Window>,
    /// Options of the composite solve.
    pub solver: SolverOptions,
}

/// The solution on one refined window.
#[derive(Debug, Clone)]
pub struct WindowSolution {
    /// The window.
    pub window: Window,
    /// Grid of the fine region (see [`Refined::window_grid`]).
    pub grid: Grid,
    /// Fine-lattice index of the region's first node (periodic).
    pub origin: (usize, usize),
    /// Pressure on the fine region (E* h0/λ).
    pub pressure: Array2<f64>,
    /// Gap on the fine region (h0; see [`Refined::window_gap`]).
    pub gap: Array2<f64>,
    /// Contact lines on the region's edge.
    pub edge: EdgeRuns,
}

impl WindowSolution {
    /// Gap at fine-lattice node (i, j) of the lattice `lattice`, if it lies in this region.
    pub fn fine_gap(&self, lattice: (usize, usize), i: usize, j: usize) -> Option<f64> {
        let (fnx, fny) = lattice;
        let (a, b) = (
            (i % fnx + fnx - self.origin.0) % fnx,
            (j % fny + fny - self.origin.1) % fny,
        );
        (a < self.grid.nx && b < self.grid.ny).then(|| self.gap[[a, b]])
    }
}

/// A refined problem: build once, solve many loads (warm-started from a previous solution).
pub struct RefinedModel {
    model: Model,
    windows: Vec<Window>,
    lattice: (usize, usize),
    spacing: (f64, f64),
    base: (usize, usize),
    solver: SolverOptions,
}

impl RefinedModel {
    /// The composite problem of `surface` (its grid is the base grid) refined as `opts` asks.
    pub fn new(surface: &Surface, opts: &RefineOptions) -> Result<Self, ContactError> {
        Self::with_preconditioner(surface, opts, None, Preconditioner::default())
    }

    /// The same composite problem with its operator applied blockwise ([`blocks`]): the fine
    /// lattice is never allocated; the field of the hats farther than `margin` base cells from
    /// the region is interpolated onto it (cubic), the only approximation. `margin` ≥ 2 and the
    /// window plus margins must fit in the period: wx + 2 margin + 2 ≤ nx (same along y).
    pub fn blockwise(
        surface: &Surface,
        opts: &RefineOptions,
        margin: usize,
    ) -> Result<Self, ContactError> {
        Self::with_preconditioner(surface, opts, Some(margin), Preconditioner::default())
    }

    /// The composite problem with the operator applied in full (`margin` None, as
    /// [`RefinedModel::new`]) or blockwise (as [`RefinedModel::blockwise`]) and the given
    /// preconditioner.
    pub fn with_preconditioner(
        surface: &Surface,
        opts: &RefineOptions,
        margin: Option<usize>,
        pre: Preconditioner,
    ) -> Result<Self, ContactError> {
        let multi = MultiOptions {
            levels: opts.levels,
            windows: vec![opts.window],
            solver: opts.solver.clone(),
        };
        Self::multi(surface, &multi, margin, pre)
    }

    /// The composite problem refined in every window of `opts` (one window: the problems
    /// above), its operator applied in full (`margin` None) or blockwise with `margin` base
    /// cells around each window, with the preconditioner `pre`. Windows must lie apart: no
    /// base node of one within `margin` cells of another (blockwise), no common base node
    /// (full); refused naming the two windows otherwise.
    pub fn multi(
        surface: &Surface,
        opts: &MultiOptions,
        margin: Option<usize>,
        pre: Preconditioner,
    ) -> Result<Self, ContactError> {
        check_windows(surface, opts.levels, &opts.windows, margin)?;
        let g = surface.grid;
        let f = 1usize << opts.levels;
        let mut comp = Composite::new(g.nx, g.ny, g.lx, g.ly, f, &opts.windows, margin, pre);
        // Heights at the fine nodes (the analytic profile; base node i is fine node f i),
        // averaged by the unknowns' weights: b' = W⁻¹ Pᵀ h.
        let (dx, dy) = (g.dx(), g.dy());
        let (fny, profile) = (comp.fny, &surface.profile);
        let (s0, s1) = g.shift;
        let n = comp.n;
        let pth: Vec<f64> = if let Some(m) = margin {
            let height = |i: usize, j: usize| {
                profile.height(
                    (i as f64 / f as f64 + s0) * dx,
                    (j as f64 / f as f64 + s1) * dy,
                )
            };
            let geometry = |w: &Window| blocks::Geometry {
                nx: g.nx,
                ny: g.ny,
                lx: g.lx,
                ly: g.ly,
                f,
                i0: w.i0,
                j0: w.j0,
                wx: w.wx,
                wy: w.wy,
                margin: m,
                order: ORDER,
            };
            let g0 = geometry(&opts.windows[0]);
            let rows = blocks::FineRows::new(profile, &g0, (dx, dy), (s0, s1));
            let hv = blocks::hat_heights(&g0, &|i, out: &mut [f64]| rows.row(i, out));
            let mut out = vec![0.0; n];
            for (w, r) in opts.windows.iter().zip(&comp.regions) {
                let hr = blocks::window_heights(&geometry(w), &height, &hv);
                out[r.offset..r.offset + hr.len()].copy_from_slice(&hr);
            }
            for (k, &idx) in comp.base_index.iter().enumerate() {
                if idx >= comp.nf {
                    out[idx] = hv[k];
                }
            }
            out
        } else {
            let mut buf = std::mem::take(&mut comp.buf);
            buf.par_chunks_mut(fny).enumerate().for_each(|(i, row)| {
                let x = (i as f64 / f as f64 + s0) * dx;
                for (j, v) in row.iter_mut().enumerate() {
                    *v = profile.height(x, (j as f64 / f as f64 + s1) * dy);
                }
            });
            comp.buf = buf;
            comp.restrict();
            comp.out[..n].to_vec()
        };
        let mut h: Vec<f64> = pth.iter().zip(&comp.weight).map(|(s, w)| s / w).collect();
        let low = h.iter().copied().fold(f64::INFINITY, f64::min) - 1e6;
        h.resize(comp.rows * comp.cols, low);
        let packed = Grid {
            nx: comp.rows,
            ny: comp.cols,
            lx: g.lx,
            ly: g.ly,
            shift: (0.0, 0.0),
        };
        let lattice = (comp.fnx, comp.fny);
        let shape = (comp.rows, comp.cols);
        let model = Model::with_kernel(
            packed,
            Array2::from_shape_vec(shape, h).expect("shape").view(),
            FreeKernel::composite(comp),
        )?;
        Ok(RefinedModel {
            model,
            windows: opts.windows.clone(),
            lattice,
            spacing: (dx / f as f64, dy / f as f64),
            base: (g.nx, g.ny),
            solver: opts.solver.clone(),
        })
    }

    fn comp(&self) -> &Composite {
        self.model.composite().expect("composite kernel")
    }

    /// Solves under mean pressure `pressure` (over the cell), from `warm` if given, else from
    /// the uniform pressure.
    pub fn solve(
        &mut self,
        pressure: f64,
        warm: Option<&Refined>,
    ) -> Result<Refined, ContactError> {
        let c = self.comp();
        let (n, total) = (c.n, c.rows * c.cols);
        let nodes = (c.fnx * c.fny) as f64;
        let shape = (c.rows, c.cols);
        // Σ r = N_f p̄ (r the force of each unknown in fine-pixel units): the packed mean.
        let mean = pressure * nodes / total as f64;
        let start = match warm {
            Some(w) => w.composite.clone(),
            None => {
                let mut r = vec![0.0; total];
                for (v, w) in r.iter_mut().zip(&c.weight) {
                    *v = w * pressure;
                }
                let h = self.model.heights().to_vec();
                Solution {
                    grid: *self.model.grid(),
                    interaction: Interaction::HardWall,
                    mean_pressure: mean,
                    displacement: Array2::from_shape_vec(shape, h).expect("shape"),
                    gap: Array2::zeros(shape),
                    pressure: Array2::from_shape_vec(shape, r).expect("shape"),
                    contact_area: 0.0,
                    mean_gap: 0.0,
                    mean_displacement: 0.0,
                    energy: 0.0,
                    stats: SolveStats {
                        method: "start",
                        iterations: 0,
                        converged: false,
                        reason: None,
                        max_violation: f64::INFINITY,
                        force_residual: f64::INFINITY,
                        wall_s: 0.0,
                        trace: Vec::new(),
                    },
                }
            }
        };
        let sol = self
            .model
            .solve(Interaction::HardWall, mean, &self.solver, Some(&start))?;
        let r = sol.pressure.as_slice().expect("layout");
        let approach = self.model.approach(r).unwrap_or(f64::NAN);
        let c = self.comp();
        let q: Vec<f64> = r[..n].iter().zip(&c.weight).map(|(r, w)| r / w).collect();
        let gap = sol.gap.as_slice().expect("layout");
        let windows: Vec<WindowSolution> = c
            .regions
            .iter()
            .zip(&self.windows)
            .map(|(reg, &window)| {
                let (rx, ry, o) = (reg.rx, reg.ry, reg.offset);
                let pressure = Array2::from_shape_fn((rx, ry), |(a, b)| q[o + a * ry + b]);
                let gap = Array2::from_shape_fn((rx, ry), |(a, b)| gap[o + a * ry + b]);
                let contact: Vec<bool> = pressure.iter().map(|&p| p > 0.0).collect();
                WindowSolution {
                    window,
                    grid: Grid {
                        nx: rx,
                        ny: ry,
                        lx: rx as f64 * self.spacing.0,
                        ly: ry as f64 * self.spacing.1,
                        shift: (0.0, 0.0),
                    },
                    origin: reg.origin,
                    pressure,
                    gap,
                    edge: EdgeRuns::of(&contact, rx, ry, c.f),
                }
            })
            .collect();
        let (nx, ny) = self.base;
        let base_pressure = Array2::from_shape_fn((nx, ny), |(i, j)| q[c.base_index[i * ny + j]]);
        let base_gap = Array2::from_shape_fn((nx, ny), |(i, j)| gap[c.base_index[i * ny + j]]);
        let contact_area = (0..n)
            .filter(|&k| r[k] > 0.0)
            .map(|k| c.weight[k])
            .sum::<f64>()
            / nodes;
        let first = &windows[0];
        Ok(Refined {
            window_grid: first.grid,
            origin: first.origin,
            lattice: self.lattice,
            window_pressure: first.pressure.clone(),
            window_gap: first.gap.clone(),
            base_pressure,
            base_gap,
            approach,
            contact_area,
            stats: sol.stats.clone(),
            edge: first.edge,
            composite: sol,
            windows,
        })
    }

    /// The refined window (the first one).
    pub fn window(&self) -> Window {
        self.windows[0]
    }

    /// The refined windows.
    pub fn windows(&self) -> &[Window] {
        &self.windows
    }

    /// Number of composite unknowns (fine region nodes plus coarse nodes outside them).
    pub fn unknowns(&self) -> usize {
        self.comp().n
    }
}

/// Solves the hard-wall contact of `surface` (the base grid) under mean pressure `pressure` with
/// the window `opts.window` refined `opts.levels` times (see the module docs).
pub fn solve_refined(
    surface: &Surface,
    pressure: f64,
    opts: &RefineOptions,
) -> Result<Refined, ContactError> {
    check(surface, pressure, opts)?;
    RefinedModel::new(surface, opts)?.solve(pressure, None)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Lattice;

    fn solver() -> SolverOptions {
        SolverOptions {
            tol_gap: 1e-13,
            ..Default::default()
        }
    }

    /// The operator is the Galerkin one: weights partition the fine lattice (Σ w = N_f), A' and
    /// M are symmetric, and A' is positive on zero-sum vectors.
    #[test]
    fn the_composite_operator_is_symmetric_and_conserves_area() {
        let w = Window {
            i0: 5,
            j0: 14,
            wx: 4,
            wy: 6,
        };
        let mut c = Composite::new(16, 16, 1.0, 1.0, 4, &[w], None, Preconditioner::Galerkin);
        let total: f64 = c.weight.iter().sum();
        // a sum of O(1e3) small integers and quarter-integers: exact
        assert_eq!(total, (64 * 64) as f64);
        assert!(c.weight.iter().all(|&w| w > 0.0));
        let m = c.rows * c.cols;
        let a: Vec<f64> = (0..m).map(|i| ((i * 7919) % 13) as f64 - 6.0).collect();
        let b: Vec<f64> = (0..m).map(|i| ((i * 104729) % 11) as f64 * 0.3).collect();
        let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>();
        for stiffness in [false, true] {
            c.apply(stiffness, &a);
            let aa = c.out.clone();
            c.apply(stiffness, &b);
            let ab = c.out.clone();
            let (x, y) = (dot(&a, &ab), dot(&b, &aa));
            // rounding of 64² transforms on O(10) values
            assert!((x - y).abs() < 1e-10 * x.abs().max(1.0), "{x} vs {y}");
        }
        let mean = a.iter().sum::<f64>() / m as f64;
        let z: Vec<f64> = a.iter().map(|v| v - mean).collect();
        c.apply(false, &z);
        assert!(dot(&z, &c.out) > 0.0);
    }

    /// A window that covers the cell is the uniform fine solve: same contact set, gaps and
    /// pressures to the solver tolerance.
    #[test]
    fn a_window_covering_the_cell_is_the_uniform_fine_solve() {
        let s = Surface::new(Lattice::Square, 4).unwrap();
        let fine = Surface::new(Lattice::Square, 6).unwrap();
        let load = 0.21 * s.p_fc_grid();
        let uni = Model::new(&fine)
            .unwrap()
            .solve(Interaction::HardWall, load, &solver(), None)
            .unwrap();
        let opts = RefineOptions {
            levels: 2,
            window: Window::centred(&s.grid, 0.5, 0.0, 16, 16),
            solver: solver(),
        };
        let r = solve_refined(&s, load, &opts).unwrap();
        assert!(r.stats.converged && uni.stats.converged);
        assert_eq!((r.window_grid.nx, r.window_grid.ny), (64, 64));
        let (mut dg, mut dp, mut differ) = (0.0f64, 0.0f64, 0);
        for i in 0..64 {
            for j in 0..64 {
                let (a, b) = ((i + 64 - r.origin.0) % 64, (j + 64 - r.origin.1) % 64);
                dg = dg.max((r.window_gap[[a, b]] - uni.gap[[i, j]]).abs());
                dp = dp.max((r.window_pressure[[a, b]] - uni.pressure[[i, j]]).abs());
                differ +=
                    usize::from((r.window_pressure[[a, b]] > 0.0) != (uni.pressure[[i, j]] > 0.0));
            }
        }
        // both solves meet the violation bound 1e-13 h0; rounding of the approach on top
        assert_eq!(differ, 0);
        assert!(dg < 1e-11, "gap differs by {dg}");
        assert!(dp < 1e-9, "pressure differs by {dp}");
        assert!((r.contact_area - uni.contact_area).abs() < 1e-12);
    }

    /// Saddle gap at (1/2, 0) of the square model at `frac` p_fc: the periodic solve of `s`
    /// (uniform or base alone) or the refined one (warm-started from its last solution).
    fn saddle(
        s: &Surface,
        refined: Option<&mut (RefinedModel, Option<Refined>)>,
        frac: f64,
    ) -> f64 {
        let load = frac * s.p_fc_grid();
        match refined {
            None => {
                let sol = Model::new(s)
                    .unwrap()
                    .solve(Interaction::HardWall, load, &solver(), None)
                    .unwrap();
                assert!(sol.stats.converged);
                sol.gap[[s.grid.nx / 2, 0]]
            }
            Some((m, warm)) => {
                let r = m.solve(load, warm.as_ref()).unwrap();
                assert!(r.stats.converged, "{:?}", r.stats);
                let g = r
                    .fine_gap(r.lattice.0 / 2, 0)
                    .expect("saddle in the window");
                *warm = Some(r);
                g
            }
        }
    }

    /// The load (fraction of p_fc) at which the saddle closes, to 1e-9 relative.
    fn critical(s: &Surface, mut refined: Option<&mut (RefinedModel, Option<Refined>)>) -> f64 {
        let (mut lo, mut hi) = (0.2, 0.25);
        while hi / lo - 1.0 > 1e-9 {
            let mid = 0.5 * (lo + hi);
            if saddle(s, refined.as_deref_mut(), mid) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }

    /// At a fixed reduced load l = p/p_c − 1, each p_c from its own discretisation, the refined
    /// saddle gap is closer to the uniform fine one than the base grid's (64² base, k = 2,
    /// window of 16² base cells, against the uniform 256² solve), and its p_c too. Measured:
    /// p_c +6.1e-6 relative (base +3.0e-4); gap at l = −1e-2, −3e-3, −1e-3: +2.9e-3, +1.2e-3,
    /// +1.7e-3 (base −5.1e-2, −0.19, −3.5e-2). Asserted: closer than the base grid, and within
    /// 5e-3 (the measured floor, see the module docs, with a margin of ~1.7).
    #[test]
    fn refined_saddle_gap_at_fixed_reduced_load_beats_the_base_grid() {
        let base = Surface::new(Lattice::Square, 6).unwrap();
        let fine = Surface::new(Lattice::Square, 8).unwrap();
        let pc_u = critical(&fine, None);
        let pc_b = critical(&base, None);
        // (window 32² measured too, see the module docs; one window keeps the test short)
        {
            let w = 16usize;
            let opts = RefineOptions {
                levels: 2,
                window: Window::centred(&base.grid, 0.5, 0.0, w, w),
                solver: solver(),
            };
            let mut m = (RefinedModel::new(&base, &opts).unwrap(), None);
            let pc = critical(&base, Some(&mut m));
            eprintln!(
                "window {w}: p_c rel {:+.3e} (base {:+.3e})",
                pc / pc_u - 1.0,
                pc_b / pc_u - 1.0
            );
            assert!((pc / pc_u - 1.0).abs() < (pc_b / pc_u - 1.0).abs());
            // the blockwise operator of the same discretisation (margin 12 base cells)
            let mut mb = (RefinedModel::blockwise(&base, &opts, 12).unwrap(), None);
            let pc_k = critical(&base, Some(&mut mb));
            eprintln!("  blockwise: p_c rel to composite {:+.3e}", pc_k / pc - 1.0);
            let mut rows = Vec::new();
            for l in [-1e-2, -3e-3, -1e-3] {
                let gu = saddle(&fine, None, pc_u * (1.0 + l));
                let gb = saddle(&base, None, pc_b * (1.0 + l));
                let gr = saddle(&base, Some(&mut m), pc * (1.0 + l));
                let gk = saddle(&base, Some(&mut mb), pc_k * (1.0 + l));
                let (er, eb, ek) = (gr / gu - 1.0, gb / gu - 1.0, gk / gu - 1.0);
                eprintln!(
                    "  l {l:e}: saddle gap rel {er:+.3e} (base {eb:+.3e}, blockwise {ek:+.3e}, blockwise/composite {:+.3e})",
                    gk / gr - 1.0
                );
                rows.push((l, er, eb, ek, gk / gr - 1.0));
            }
            for (l, er, eb, ek, ekr) in rows {
                assert!(
                    er.abs() < eb.abs() && ek.abs() < eb.abs(),
                    "window {w}, l {l}: {er:e}, blockwise {ek:e} vs base {eb:e}"
                );
                // the blockwise solve is the composite one up to its far-field interpolation,
                // which must stay well below the discretisation error (see the module docs for
                // the measured ratio)
                assert!(
                    ekr.abs() < 0.3 * er.abs(),
                    "l {l}: blockwise/composite {ekr:e} vs {er:e}"
                );
            }
        }
    }

    /// Applies `full` and `cheap` (same unknowns) to two fixed vectors a, b: the largest
    /// |full a − cheap a|, the largest |full a|, and ⟨a, cheap b⟩, ⟨b, cheap a⟩ (equal if cheap
    /// is symmetric).
    fn compare_operators(
        full: &mut Composite,
        cheap: &mut Composite,
        stiffness: bool,
    ) -> (f64, f64, f64, f64) {
        let m = full.rows * full.cols;
        let a: Vec<f64> = (0..m).map(|i| ((i * 7919) % 13) as f64 - 6.0).collect();
        let b: Vec<f64> = (0..m).map(|i| ((i * 104729) % 11) as f64 * 0.3).collect();
        let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>();
        full.apply(stiffness, &a);
        let fa = full.out.clone();
        cheap.apply(stiffness, &a);
        let ca = cheap.out.clone();
        cheap.apply(stiffness, &b);
        let cb = cheap.out.clone();
        let scale = fa.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        let diff = fa
            .iter()
            .zip(&ca)
            .fold(0.0f64, |s, (x, y)| s.max((x - y).abs()));
        (diff, scale, dot(&a, &cb), dot(&b, &ca))
    }

    /// The blockwise operator is the full composite operator up to the interpolated far field:
    /// compliance and stiffness applied to the same vectors agree (relative to the result's
    /// largest entry) within the bound asserted below, and both are symmetric.
    #[test]
    fn the_blockwise_operator_is_the_composite_one() {
        let w = Window {
            i0: 29,
            j0: 3,
            wx: 6,
            wy: 5,
        };
        for (f, margin) in [(2, 5), (4, 5), (4, 8), (4, 12)] {
            let mut full =
                Composite::new(32, 32, 1.0, 1.3, f, &[w], None, Preconditioner::Galerkin);
            let mut cheap = Composite::new(
                32,
                32,
                1.0,
                1.3,
                f,
                &[w],
                Some(margin),
                Preconditioner::Galerkin,
            );
            assert_eq!(full.weight, cheap.weight);
            for stiffness in [false, true] {
                let (diff, scale, x, y) = compare_operators(&mut full, &mut cheap, stiffness);
                eprintln!(
                    "f {f} margin {margin} stiffness {stiffness}: max diff {:.3e} of {scale:.3e}, asym {:.3e}",
                    diff,
                    (x - y).abs() / x.abs()
                );
                assert!((x - y).abs() < 1e-10 * x.abs().max(1.0), "{x} vs {y}");
                assert!(
                    diff < 1e-3 * scale,
                    "f {f} margin {margin}: {diff:e} of {scale:e}"
                );
            }
        }
    }

    /// Several windows: the blockwise operator is the full composite one up to the
    /// interpolated far field (now also between the windows' fine remainders), with an error
    /// of the single window's order at the same margin, and symmetric.
    #[test]
    fn the_blockwise_operator_of_several_windows_is_the_composite_one() {
        let err = |ws: &[Window], f: usize, margin: usize| -> (f64, f64) {
            let nb = ws.iter().map(|w| w.i0 + w.wx).max().unwrap().max(32) + 16;
            let nb = if nb > 32 { 64 } else { 32 };
            let mut full = Composite::new(nb, 32, 1.0, 1.3, f, ws, None, Preconditioner::Galerkin);
            let mut cheap = Composite::new(
                nb,
                32,
                1.0,
                1.3,
                f,
                ws,
                Some(margin),
                Preconditioner::Galerkin,
            );
            assert_eq!(full.weight, cheap.weight);
            let (diff, scale, x, y) = compare_operators(&mut full, &mut cheap, false);
            (diff / scale, (x - y).abs() / x.abs())
        };
        let one = Window {
            i0: 3,
            j0: 5,
            wx: 4,
            wy: 4,
        };
        for (f, margin) in [(2, 5), (4, 5), (4, 7)] {
            let (e1, _) = err(&[one], f, margin);
            // apart by the least allowed, margin + ORDER/2 + 1 cells, along x (their margins
            // overlap), and a third diagonal
            let gap = margin + ORDER / 2 + 1;
            let two = Window {
                i0: 3 + 4 + gap,
                ..one
            };
            let three = Window {
                i0: 3 + 4 + gap,
                j0: 5 + 4 + gap,
                ..one
            };
            let (e2, a2) = err(&[one, two], f, margin);
            let (e3, a3) = err(&[one, two, three], f, margin);
            eprintln!(
                "f {f} margin {margin}: one window {e1:.3e}, two {e2:.3e} (asym {a2:.1e}), three {e3:.3e} (asym {a3:.1e})"
            );
            for extra in [4, 12, 24] {
                let two = Window {
                    i0: 3 + 4 + gap + extra,
                    ..one
                };
                let (e, _) = err(&[one, two], f, margin);
                eprintln!("   two windows {} cells apart: {e:.3e}", gap + extra);
            }
            // symmetric to rounding (one energy)
            assert!(a2 < 1e-12 && a3 < 1e-12);
            // measured (64 × 32 base, relative to the largest entry): one window 5.6e-5 (f 2),
            // 7.8e-5 (f 4); two windows 3.1e-4 and 3.3e-3, three 3.9e-4 and 6.9e-3 (the
            // cross-window remainder terms; without them 3.4e-2 at f 2); bound ~2× above
            assert!(e2 < 7e-3 && e3 < 1.5e-2, "{e1:e} {e2:e} {e3:e}");
        }
    }

    /// The blockwise solve is the composite solve: same contact set, saddle gap to the
    /// interpolation error (32² base, k = 2, window 8², square model near percolation).
    #[test]
    fn the_blockwise_solve_is_the_composite_solve() {
        let s = Surface::new(Lattice::Square, 5).unwrap();
        let opts = RefineOptions {
            levels: 2,
            window: Window::centred(&s.grid, 0.5, 0.0, 8, 8),
            solver: solver(),
        };
        let load = 0.215 * s.p_fc_grid();
        let a = RefinedModel::new(&s, &opts)
            .unwrap()
            .solve(load, None)
            .unwrap();
        let mut m = RefinedModel::blockwise(&s, &opts, 6).unwrap();
        let b = m.solve(load, None).unwrap();
        assert!(a.stats.converged && b.stats.converged, "{:?}", b.stats);
        let (ga, gb) = (
            a.fine_gap(a.lattice.0 / 2, 0).unwrap(),
            b.fine_gap(b.lattice.0 / 2, 0).unwrap(),
        );
        let dg = a
            .window_gap
            .iter()
            .zip(&b.window_gap)
            .fold(0.0f64, |s, (x, y)| s.max((x - y).abs()));
        eprintln!(
            "saddle gap {ga:.10e} vs {gb:.10e} (rel {:+.3e}), max window gap diff {dg:.3e}, iterations {} vs {}, area {} vs {}",
            gb / ga - 1.0,
            a.stats.iterations,
            b.stats.iterations,
            a.contact_area,
            b.contact_area
        );
        assert!(ga > 0.0);
        assert!((gb / ga - 1.0).abs() < 1e-3);
    }

    /// A window smaller than the neck is reported: near percolation (l ≈ −0.02) a window of
    /// 2² base cells around the saddle sees no contact line cross its edge, or only a narrow
    /// channel; one of 12² sees the channel cross its edge wider than 2 base cells.
    #[test]
    fn a_too_small_window_is_reported() {
        let s = Surface::new(Lattice::Square, 5).unwrap();
        let load = 0.224 * s.p_fc_grid();
        let mut seen = Vec::new();
        for w in [2, 12] {
            let opts = RefineOptions {
                levels: 2,
                window: Window::centred(&s.grid, 0.5, 0.0, w, w),
                solver: solver(),
            };
            let r = RefinedModel::blockwise(&s, &opts, 6)
                .unwrap()
                .solve(load, None)
                .unwrap();
            assert!(r.stats.converged);
            eprintln!("window {w}: {:?}", r.edge);
            seen.push(r.edge.too_small(2.0));
        }
        assert_eq!(seen, [true, false]);
        // the run count on a hand-made region: 7 × 6 with contact on its first two rows; the
        // ring is the second ring (rows 1 ..= 5, columns 1 ..= 4: 16 nodes), whose row 1 (4
        // nodes) is in contact, the other 10 open (the ring has 14 nodes); 2 fine nodes per cell
        let mut c = vec![false; 42];
        c[..12].iter_mut().for_each(|v| *v = true);
        let e = EdgeRuns::of(&c, 7, 6, 2);
        assert_eq!((e.crossings, e.raw_crossings, e.slivers), (2, 2, 0));
        assert_eq!(
            (e.narrowest_contact, e.narrowest_open),
            (Some(2.0), Some(5.0))
        );
        // contact on the edge alone (row 0) is not seen: the edge's base nodes carry the hats
        let mut c = vec![false; 42];
        c[..6].iter_mut().for_each(|v| *v = true);
        let e = EdgeRuns::of(&c, 7, 6, 2);
        assert_eq!((e.crossings, e.all_contact), (0, false));
    }

    /// Ring of runs (state, nodes) in order.
    fn ring(runs: &[(bool, usize)]) -> Vec<bool> {
        runs.iter()
            .flat_map(|&(s, n)| std::iter::repeat_n(s, n))
            .collect()
    }

    /// Slivers (runs of 1–2 nodes, [`SLIVER_NODES`]) are merged before the crossings are
    /// counted: a contact line grazing the ring beside a real crossing (the measured triangular
    /// pattern: contact | open 1 | contact 1 | open …) gives the neck's four crossings, not
    /// eight, and is not too small; a real channel of 3 nodes (under 2 base cells at 4 nodes
    /// per cell) stays a narrow run and is too small; one of 2 nodes is merged away, and the
    /// ring then shows 2 crossings, which is too few for a channel through the window.
    #[test]
    fn edge_slivers_are_merged_but_narrow_runs_are_not() {
        let f = 4;
        // the neck: contact 40, open 50, contact 40, open 50; slivers beside two crossings
        let grazing = ring(&[
            (true, 39),
            (false, 1),
            (true, 1),
            (false, 49),
            (true, 38),
            (false, 2),
            (true, 1),
            (false, 49),
        ]);
        let e = EdgeRuns::of_ring(&grazing, f);
        assert_eq!((e.raw_crossings, e.slivers, e.crossings), (8, 2, 4));
        // shortest first, the first of equals: open 1 joins contact 39 + 1; then contact 1
        // joins open 2 + 49: runs 41, 49 (open), 38, 52 (open) nodes
        assert_eq!(e.narrowest_contact, Some(38.0 / 4.0));
        assert_eq!(e.narrowest_open, Some(49.0 / 4.0));
        assert!(!e.too_small(2.0));
        // (unmerged, its narrowest runs were 1 node = 0.25 base cells: flagged by the old rule)
        // a channel of 3 nodes reaching the ring: kept, narrower than 2 base cells
        let narrow = ring(&[(true, 80), (false, 3), (true, 40), (false, 57)]);
        let e = EdgeRuns::of_ring(&narrow, f);
        assert_eq!((e.crossings, e.slivers), (4, 0));
        assert_eq!(e.narrowest_open, Some(0.75));
        assert!(e.too_small(2.0));
        // a channel of 2 nodes: merged, two crossings left (the caller's count check)
        let thin = ring(&[(true, 80), (false, 2), (true, 40), (false, 58)]);
        let e = EdgeRuns::of_ring(&thin, f);
        assert_eq!((e.raw_crossings, e.crossings, e.slivers), (4, 2, 1));
        // one sliver in a uniform ring: no crossing at all (too small), its state the rest's
        let e = EdgeRuns::of_ring(&ring(&[(true, 2), (false, 60)]), f);
        assert_eq!((e.crossings, e.all_contact), (0, false));
        assert!(e.too_small(2.0));
        let e = EdgeRuns::of_ring(&ring(&[(true, 60), (false, 1)]), f);
        assert_eq!((e.crossings, e.all_contact), (0, true));
    }

    /// Diagnostic (ignored; `--ignored --nocapture`): the blockwise p_c and saddle gaps at fixed
    /// reduced loads against the composite ones, by margin (32² base, k = 2, window 8²).
    #[test]
    #[ignore]
    fn blockwise_error_by_margin() {
        let base = Surface::new(Lattice::Square, 5).unwrap();
        let opts = RefineOptions {
            levels: 2,
            window: Window::centred(&base.grid, 0.5, 0.0, 8, 8),
            solver: solver(),
        };
        let mut m = (RefinedModel::new(&base, &opts).unwrap(), None);
        let pc = critical(&base, Some(&mut m));
        let ls = [-1e-2, -1e-3, -1e-4];
        let gr: Vec<f64> = ls
            .iter()
            .map(|l| saddle(&base, Some(&mut m), pc * (1.0 + l)))
            .collect();
        for margin in [5, 7, 9, 11] {
            let mut mb = (RefinedModel::blockwise(&base, &opts, margin).unwrap(), None);
            let pk = critical(&base, Some(&mut mb));
            let rel: Vec<String> = ls
                .iter()
                .zip(&gr)
                .map(|(l, g)| {
                    format!(
                        "{l:e}: {:+.2e}",
                        saddle(&base, Some(&mut mb), pk * (1.0 + l)) / g - 1.0
                    )
                })
                .collect();
            eprintln!(
                "margin {margin}: p_c {:+.2e}; gap {}",
                pk / pc - 1.0,
                rel.join(", ")
            );
        }
    }

    /// The two-level preconditioner solves the same discrete problem (same saddle gap and
    /// window gaps to the solver tolerance) in at most twice the uniform fine solve's
    /// iterations, and in fewer than the Galerkin one (32² base, k = 2, window 8², margin 6,
    /// near percolation). Measured: 57 (additive) and 118 (Galerkin) against 36 uniform.
    #[test]
    fn the_two_level_preconditioner_needs_few_iterations() {
        let s = Surface::new(Lattice::Square, 5).unwrap();
        let fine = Surface::new(Lattice::Square, 7).unwrap();
        let load = 0.215 * s.p_fc_grid();
        let uni = Model::new(&fine)
            .unwrap()
            .solve(Interaction::HardWall, load, &solver(), None)
            .unwrap();
        let opts = RefineOptions {
            levels: 2,
            window: Window::centred(&s.grid, 0.5, 0.0, 8, 8),
            solver: solver(),
        };
        let solve = |pre| {
            let r = RefinedModel::with_preconditioner(&s, &opts, Some(6), pre)
                .unwrap()
                .solve(load, None)
                .unwrap();
            assert!(r.stats.converged, "{pre:?}: {:?}", r.stats);
            r
        };
        let (a, g) = (
            solve(Preconditioner::Additive),
            solve(Preconditioner::Galerkin),
        );
        eprintln!(
            "iterations: additive {}, galerkin {}, uniform {}",
            a.stats.iterations, g.stats.iterations, uni.stats.iterations
        );
        assert!(uni.stats.converged);
        assert!(a.stats.iterations <= 2 * uni.stats.iterations);
        assert!(a.stats.iterations < g.stats.iterations);
        let dg = a
            .window_gap
            .iter()
            .zip(&g.window_gap)
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        // both meet the violation bound 1e-13 h0 on the same discrete problem; the window gap
        // differs by the solver's tolerance times the conditioning, not by the discretisation
        assert!(dg < 1e-11, "window gaps differ by {dg:e}");
    }

    /// Diagnostic (ignored; `--ignored --nocapture`): iterations of the composite solve by
    /// preconditioner and operator against the uniform fine solve's, square model near
    /// percolation (32² base, window 8², k = 2 and 3).
    #[test]
    #[ignore]
    fn iterations_by_preconditioner() {
        let s = Surface::new(Lattice::Square, 5).unwrap();
        let load = 0.215 * s.p_fc_grid();
        for levels in [2u32, 3] {
            let fine = Surface::new(Lattice::Square, 5 + levels).unwrap();
            let uni = Model::new(&fine)
                .unwrap()
                .solve(Interaction::HardWall, load, &solver(), None)
                .unwrap();
            eprintln!(
                "k {levels}: uniform {} iterations, saddle gap {:.10e}",
                uni.stats.iterations,
                uni.gap[[fine.grid.nx / 2, 0]]
            );
            let opts = RefineOptions {
                levels,
                window: Window::centred(&s.grid, 0.5, 0.0, 8, 8),
                solver: solver(),
            };
            for margin in [None, Some(6)] {
                for pre in [
                    Preconditioner::Galerkin,
                    Preconditioner::Additive,
                    Preconditioner::Hierarchical,
                ] {
                    let t = std::time::Instant::now();
                    let r = RefinedModel::with_preconditioner(&s, &opts, margin, pre)
                        .unwrap()
                        .solve(load, None)
                        .unwrap();
                    eprintln!(
                        "  margin {margin:?} {pre:?}: {} iterations, converged {}, saddle gap {:.10e}, {:.2} s",
                        r.stats.iterations,
                        r.stats.converged,
                        r.fine_gap(r.lattice.0 / 2, 0).unwrap(),
                        t.elapsed().as_secs_f64()
                    );
                }
            }
        }
    }

    /// Diagnostic (ignored): iterations of the additive preconditioner by window size (32²
    /// base, full composite operator).
    #[test]
    #[ignore]
    fn iterations_by_window() {
        let s = Surface::new(Lattice::Square, 5).unwrap();
        let load = 0.215 * s.p_fc_grid();
        let base = Model::new(&s)
            .unwrap()
            .solve(Interaction::HardWall, load, &solver(), None)
            .unwrap();
        eprintln!("base alone: {} iterations", base.stats.iterations);
        for levels in [1u32, 2, 3] {
            for w in [1usize, 4, 8, 16, 32] {
                let opts = RefineOptions {
                    levels,
                    window: Window::centred(&s.grid, 0.5, 0.0, w, w),
                    solver: solver(),
                };
                let its: Vec<usize> = [Preconditioner::Additive, Preconditioner::Galerkin]
                    .into_iter()
                    .map(|pre| {
                        RefinedModel::with_preconditioner(&s, &opts, None, pre)
                            .unwrap()
                            .solve(load, None)
                            .unwrap()
                            .stats
                            .iterations
                    })
                    .collect();
                eprintln!(
                    "k {levels} window {w}: additive {}, galerkin {}",
                    its[0], its[1]
                );
            }
        }
    }

    /// Bad options are refused with the parameter named.
    #[test]
    fn bad_options_are_refused() {
        let s = Surface::new(Lattice::Square, 4).unwrap();
        let ok = RefineOptions {
            levels: 1,
            window: Window::centred(&s.grid, 0.5, 0.0, 4, 4),
            solver: SolverOptions::default(),
        };
        let name = |o: &RefineOptions, p: f64| match solve_refined(&s, p, o) {
            Err(ContactError::Parameter { name, .. }) => name,
            other => panic!("{other:?}"),
        };
        for levels in [0, 7] {
            let o = RefineOptions {
                levels,
                ..ok.clone()
            };
            assert_eq!(name(&o, 0.1), "levels");
        }
        let o = RefineOptions {
            window: Window {
                wx: 17,
                ..ok.window
            },
            ..ok.clone()
        };
        assert_eq!(name(&o, 0.1), "window");
        assert_eq!(name(&ok, -1.0), "pressure");
        // the centred window wraps around the periodic cell
        assert_eq!((ok.window.i0, ok.window.j0), (6, 14));
    }
}
