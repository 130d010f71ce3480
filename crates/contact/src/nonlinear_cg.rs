//! Bound-constrained nonlinear conjugate gradients on the elastic surface height, preconditioned
//! by the elastic stiffness, for any interaction on top of the hard wall (adhesion, repulsion).
//!
//! Minimises the energy per area E(u) = ½⟨u, K u⟩ + p̄ ū + ⟨γ(u − h)⟩ over u ≥ h (force control:
//! the mean of u is free, the load enters through p̄ ū). The gradient (per node, times N) is
//! r = σ + p̄ + γ'(g) with σ = K u, the same unbalanced pressure FIRE drives to zero. Nodes on the
//! wall (g = 0) with r ≥ 0 are held (the wall pushes); their gradient and direction are zero.
//!
//! Each iteration:
//! 1. z = M⁻¹ r on the free nodes (M the modal stiffness k(q) = qE*/2, with k_min for the mean
//!    mode: FIRE's mass weighting, the Vollebregt idea that made Polonsky–Keer fast), restricted
//!    to the free nodes. Since r vanishes on the held set, ⟨r, z⟩ = ⟨r, M⁻¹ r⟩ > 0.
//! 2. d = −z + β d_old with β from [`Beta`] (Polak–Ribière+ by default); d = −z if d is not a
//!    descent direction.
//! 3. One transform pair gives K d. Along the ray the energy is then known without further
//!    transforms: the elastic part is the exact quadratic α⟨d, σ + p̄⟩ + ½α²⟨d, K d⟩ and the
//!    interaction is local. A safeguarded Newton iteration from α = 0 finds the *first* minimum
//!    along the ray (not the deepest): that is how a warm start stays on its metastable branch.
//! 4. u ← max(u + α d, h). Without clipping σ ← σ + α K d exactly; with clipping σ = K u is
//!    recomputed (one pair). A step that raises the energy beyond rounding is halved (strict
//!    descent: the iteration can never climb over a barrier to another branch).
//!
//! Cost: two transform pairs per iteration (M⁻¹ r and K d), three when nodes are clipped, plus a
//! few local passes for the line search. σ is recomputed from scratch every [`REFRESH`]
//! iterations and before convergence is accepted, so rounding cannot accumulate. When σ is
//! recomputed, the energy check and the next iteration's gradient share one pass (one
//! exponential per node); nodes on the wall need none. Where the time went (perf, 256² cold,
//! p̄ = 1.47, single thread, before that fusion): the exponentials and divisions of the law
//! ≈ 25 %, the transforms ≈ 30 % (a pair costs about as much as one pass of exponentials on
//! 256²), the rest streaming passes; clipping happened in 57 of 74 iterations (hundreds of
//! nodes each, so a sparse correction of σ would not pay).
//!
//! Measured again in session #12 (perf, single thread, cold, square model, p̄ = 1.47 on 256²
//! and 0.53 on 512²): clipping now happens in 4–15 of 40–60 iterations (2.1–2.3 transform pairs
//! per iteration on average); the line search took 3.4 slope passes per iteration over the
//! 35–60 % of the nodes within reach, each node a division, a libm exponential and two more
//! divisions: with libm's exp ≈ 13 % of all time, the slope loop was the largest single cost
//! (≈ 30 %). Under adhesion the slope pass is now `Ray::adhesive_sums`: γ(g + αd) = −γ0
//! e^(c + αw) with c = −g/ρ, w = −d/ρ set once per ray, so an evaluation is one
//! multiplication, one branch-free exponential (`exp_fast`) and the sums in four lanes
//! (vectorised); and the search stops at `LINE_TOL` = 1e-3 of |φ'(0)| instead of 1e-6 (1.9–2.6
//! passes per iteration). After that (512², p̄ = 0.53): transforms ≈ 34 % (a third of it the
//! column gather/scatter of `spectral`), streaming passes of the iteration ≈ 27 %, slope
//! passes ≈ 16 %, the gradient pass with libm's exponential ≈ 14 %. The gradient pass with
//! `exp_fast` in a separate vectorised pass was measured and was not faster (the extra pass
//! costs what the exponential saves).
//!
//! Convergence: the force residual of FIRE (largest unbalanced pressure off the wall, largest
//! pull at the wall) at most `tol_force`, on a freshly computed σ.
//!
//! Approximations: the line search ignores the wall (nodes that would penetrate are clipped
//! afterwards); the energy check after the step keeps the iteration a strict descent.
//!
//! Branch safeguard: a node within [`IN_RANGE`] ranges of the wall moves by at most one range ρ
//! per step. Without it the long preconditioned steps carried nodes over the interaction's
//! barriers: on a 32² square-model load path (γ0 = 0.2, ρ = 0.04) the cold start already
//! landed in a state with 8 more contact nodes than FIRE's, and loading stayed ahead of FIRE;
//! with it the two agree on all but a few lattice-trapped points (tests/nonlinear_cg.rs).
//! A cold start under adhesion (the uniform surface of `Model::solve`) has no branch to keep
//! yet and runs without it (under repulsion it saves iterations there too, and stays): there the cap bound every step of the approach (square model 256², p̄ = 1.47:
//! 53 of 74 iterations, the contact area growing by 1 % of the nodes per step), and without it
//! the cold solves of the adhesive bench take 51, 40, 39, 55 iterations instead of 74, 79, 55, 44
//! at p̄ = 1.47, 0.84, 0.53, 0, reaching the same states (mean gap within 3e-13); the draft
//! preset's Figure 2/3 paths on 128² (`ADHESIVE_PATH=7 ADHESIVE_PATH_POINTS=1`, their first
//! point cold) keep every contact area and their mean gaps within 1e-10.
//!
//! Cold starts where two states coexist may end in another state than FIRE's: square model
//! 256², p̄ = 0.8408 (tamaas's load at mean gap 0.5, where patches coalesce): FIRE and tamaas
//! reach area 0.4173, mean gap 0.5, energy 2.502394; nonlinear CG area 0.3626, mean gap
//! 0.5419, energy 2.501870 (lower). Both are minima: perturbed by random noise up to 1e-3 h0,
//! FIRE and nonlinear CG return to each. FIRE's inertia carries it further into contact; which
//! state a cold start reaches is not defined by the physics. From warm starts (paths) the two
//! agree (tests/nonlinear_cg.rs).
//!
//! Nested cold start (session #22). Where a cold adhesive solve's iterations go (above): about
//! half release the contact that the first long steps overshoot, the rest is the linear rate.
//! On grids of at least [`NESTED_MIN_NODES`] nodes (256² and up) a cold adhesive solve
//! therefore first solves the grid of every other node (heights injected: for the lattice
//! models exactly the coarser grid's own samples) to a force residual of [`NESTED_TOL`], from
//! its own cold start and itself nested down to 128², interpolates that surface bilinearly and
//! continues from it on the fine grid without the branch safeguard, as from a cold start (there
//! is no branch to keep yet). Only where the coarse grid still resolves the cohesive zone
//! ([`crate::Model::resolves_cohesive_zone`]; otherwise it could sit on another branch than the
//! fine grid's) and converges; otherwise the fine grid starts cold as before. `iterations` in
//! the statistics counts the iterations of every grid (a coarse one costs a quarter of the next
//! finer one's). Measured (`ADHESIVE_NS=8,9,10 ADHESIVE_FIRE= ADHESIVE_PRESSURE=… cargo bench
//! -p contact --bench adhesive`, the before- and after-binaries alternately, one thread, on a
//! machine with one core busy; CPU s of the cold solve to 1e-10, iterations as counted):
//!
//! | p̄     | 256²                           | 512²                           | 1024²                          |
//! |-------|--------------------------------|--------------------------------|--------------------------------|
//! | 0     | 0.115 → 0.085 (55 → 30 + 27)   | 0.495 → 0.413 (49 → 41 + 37)   | 3.46 → 1.93 (53 → 57 + 31)     |
//! | 0.84  | 0.112 → 0.119 (42 → 26 + 36)   | 0.572 → 0.456 (44 → 42 + 39)   |                                |
//! | 1.47  | 0.110 → 0.071 (50 → 22 + 21)   | 0.588 → 0.320 (59 → 32 + 27)   | 3.43 → 1.88 (67 → 44 + 32)     |
//!
//! (coarse + finest grid's iterations after the arrow). Every state the same (contact set and
//! mean gap to 2e-12; tests/nonlinear_cg.rs checks it on 256²). The finest grid still takes
//! 21–39 iterations from the interpolated start: the release phase is gone, the linear rate
//! (about three iterations per decade of residual, ten decades) is what is left; a coarse
//! tolerance of 1e-6 or 1e-9 instead of 1e-4 leaves it unchanged (256², 512²: 21–27 fine
//! iterations at 1e-9). Nesting from 64² instead of 128² saves nothing more.
//!
//! Candidates measured against each other (`ADHESIVE_CANDIDATES=8,9 cargo bench -p contact
//! --bench adhesive`: square model, γ0 = 0.2, ρ = 0.04, zero load, residual ≤ 1e-10;
//! iterations cold / warm (one 0.01 p_fc step), CPU s of the cold solve):
//!
//! | minimiser                        | 256²             | 512²             | 1024²           |
//! |----------------------------------|------------------|------------------|-----------------|
//! | PR+ (default)                    | 44 / 36, 0.11 s  | 45 / 51, 0.52 s  | 64 / 59, 3.2 s  |
//! | Fletcher–Reeves (no restart, as  | 58 / 36, 0.15 s  | 106 / 43, 1.0 s  |                 |
//! | Bugnicourt et al. 2018)          |                  |                  |                 |
//! | steepest descent, same search    | 225 / 135, 0.63 s| 280 / 117, 2.8 s |                 |
//! | L-BFGS, memory 5                 | 47 / 35, 0.16 s  | 50 / 41, 0.58 s  |                 |
//! | FIRE                             | 224 / 235, 0.36 s| 256 / 225, 1.8 s | 274 / 259, 8.3 s|
//!
//! L-BFGS ([`Beta::Lbfgs`]: the same preconditioner as initial inverse Hessian, line search and
//! held set; pairs dropped when a step clips nodes, without which it stalled on adhesion) needs
//! as many iterations as PR+ at 2m more passes per iteration; Fletcher–Reeves stalled for
//! thousands of iterations on 128² under load (before the step limits below) and is slower
//! here. PR+ is the default. Not implemented: the gap-primal scheme of Rey, Anciaux & Molinari
//! 2017 (tamaas's own; bench/peers/adhesive.sh runs tamaas beside ours).
//!
//! Warm-started paths, as the sweeps run them (`ADHESIVE_PATH=7 ADHESIVE_PATH_METHODS=
//! nonlinear-cg,fire cargo bench -p contact --bench adhesive`: the draft preset's paths on 128²,
//! tolerance 1e-8, CPU s of the whole path on a loaded machine; iterations per warm step):
//!
//! | path                                   | nonlinear CG     | FIRE              |
//! |----------------------------------------|------------------|-------------------|
//! | Figure 2 adhesion, 177 points          | 16.3 it, 2.7 s   | 122.9 it, 11.8 s  |
//! | Figure 2 repulsion, 149 points         | 109.4 it, 13.2 s | 324.3 it, 33.6 s  |
//! | Figure 3 hexagonal γ0 path, 145 points | 16.2 it, 2.1 s   | 147.9 it, 12.5 s  |
//!
//! An iteration costs 0.8–0.9 ms against FIRE's 0.55–0.7 ms (both two transform pairs; the
//! line search's local passes make the difference). Where the grid does not resolve the
//! cohesive zone the two part: on the γ0 path above they differ by 200 nodes of contact at
//! γ0 = 0.4 (0.22 spacings) and reach full contact at γ0 = 15 (nonlinear CG) and beyond 18
//! (FIRE); [`crate::Method::Auto`] therefore keeps FIRE below one spacing
//! ([`crate::NCG_MIN_ZONE_SPACINGS`]).
//!
//! Preconditioner variants tried (256², cold/warm iterations on five states: adhesion at
//! p̄ = 0, 0.53, 1.47, repulsion at 0.3, 1.5): the mean-mode mass k_min (44/37, 55/29, 74/22,
//! 84/70, 108/71) against 0.1–30 k_min (better for adhesion at zero load down to 31/26, worse
//! elsewhere, up to 343/272), and masses k(q) + c for c = 1–30 E*/λ (no consistent change).
//!
//! Where the iterations go: after the first steps the active set settles and the rest is the
//! linear rate of CG on the preconditioned Hessian I − K⁻¹|γ''|, whose smallest eigenvalues are
//! the soft modes of the interaction (repulsion 128², p̄ = 0.5: residual ÷10 per ~8 iterations
//! over the last 100). From a cold start under repulsion the first steps, whose line search
//! ignores the wall, put 3× too many nodes on the wall, and releasing them took ~40 iterations;
//! a step is therefore capped where it would put more than [`CONTACT_GROWTH`] × max(contact,
//! n/64) new nodes on the wall.
//!
//! The same holds for cold starts under adhesion (session #12, 256², p̄ = 1.47, 50
//! iterations): the contact grows 1 → 18 490 nodes in four steps, the fifth (at the growth cap)
//! puts it at 55 470 against 37 783 at the solution, and 28 iterations release the excess one
//! ring of edge nodes at a time (500–1300 per iteration: a held node is released only once it
//! is pulled, and only the edge is); then 17 iterations take the residual down 9 decades. Tried
//! against it, not kept (iterations cold, 256² at p̄ = 1.47, 0.84, 0.53, 0 and 512²; the same
//! states): a growth factor of 1 for the cold adhesive start (50, 39, 40, 55 → 28, 46, 40, 40;
//! 60, 50, 47, 56 → 35, 55, 43, 57: total CPU −5 %, not consistently), 1.5 or 0.25 (worse); a
//! hard-wall Polonsky–Keer solve to 1e-2 or 1e-4 at the same load as the start (50 → 23
//! iterations at p̄ = 1.47 on 256², 60 → 29 on 512², but 8–15 Polonsky–Keer iterations more and
//! no gain at 0.84 and 0.53).

use crate::stop_monitor::StopMonitor;
use crate::{
    ContactError, Interaction, Minimizer, Model, SolveStats, SolverOptions, State, StopReason,
};

/// How the conjugate direction mixes in the previous one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Beta {
    /// Polak–Ribière with restart on negative β (PR+): β = max(0, ⟨z, r − r_old⟩/⟨z_old, r_old⟩).
    PolakRibiere,
    /// Fletcher–Reeves: β = ⟨z, r⟩/⟨z_old, r_old⟩ (no restart, as Bugnicourt et al. 2018).
    FletcherReeves,
    /// β = 0: preconditioned steepest descent with the same line search (for comparison).
    SteepestDescent,
    /// Not a β: limited-memory BFGS (the last [`LBFGS_MEMORY`] steps) with the stiffness
    /// preconditioner as initial inverse Hessian and the same line search, steps and held set.
    Lbfgs,
}

/// Grids of at least this many nodes start a cold adhesive solve from the solution on the grid
/// of every other node ([`NonlinearCg`]'s nested start; 256² and up, so 128² is the coarsest
/// grid solved from a uniform start). Measured (module docs), CPU of the cold solve plain /
/// nested: 0.94–1.55 on 256², 1.21–1.84 on 512², 1.79–1.82 on 1024².
pub const NESTED_MIN_NODES: usize = 1 << 16;
/// Force residual (E* h0/λ) to which the coarser grids of a nested start are solved (the fine
/// solve's own tolerance where that is looser). Measured on 256²–1024²: 1e-6 and 1e-9 take the
/// fine grid as many iterations as 1e-4, at more coarse iterations.
pub const NESTED_TOL: f64 = 1e-4;

/// Step pairs an L-BFGS direction remembers.
pub const LBFGS_MEMORY: usize = 5;

/// The nonlinear conjugate-gradient minimiser.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NonlinearCg {
    /// Conjugacy formula.
    pub beta: Beta,
    /// Cold adhesive solves on grids of at least this many nodes start from the solution on
    /// the grid of every other node ([`NESTED_MIN_NODES`] by default; `usize::MAX`: never).
    pub nested_min_nodes: usize,
}

impl Default for NonlinearCg {
    fn default() -> Self {
        NonlinearCg {
            beta: Beta::PolakRibiere,
            nested_min_nodes: NESTED_MIN_NODES,
        }
    }
}

/// Iterations between recomputations of σ = K u from scratch.
pub const REFRESH: usize = 50;
/// Iterations without a 1 % improvement of the residual after which the solve is stagnant.
const STAGNATION: usize = 2000;
/// Halvings of a step that raises the energy before the direction is reset to −z.
const MAX_HALVINGS: usize = 30;
/// Nodes with a gap below this many interaction ranges are held to one range of motion per step.
pub const IN_RANGE: f64 = 3.0;
/// A step may put at most this many times max(contact, n/64) new nodes on the wall. Measured
/// (cold, square model, iterations without → with, 2 chosen): repulsion 128² p̄ = 0.5 154 → 95,
/// 256² p̄ = 0.3 98 → 84, p̄ = 1.5 130 → 108; factor 1: 114, 83, 102; factor 4: 120, 81, 103;
/// adhesion unchanged (44, 79, 74 at 256², p̄ = 0, 0.84, 1.47).
pub const CONTACT_GROWTH: f64 = 2.0;
/// The line search stops where |φ'(α)| ≤ this fraction of |φ'(0)|. Measured (cold, square
/// model, γ0 = 0.2, ρ = 0.04, p̄ = 1.47, 0.84, 0.53, 0; iterations and slope evaluations
/// (exponential passes over the ray's nodes) per solve, 1e-6 → 1e-3): 256² 50, 39, 40, 55 →
/// 50, 37, 40, 55 iterations, 172, 152, 113, 128 → 131, 83, 79, 89 evaluations; 512² 60, 50,
/// 47, 56 → 59, 46, 46, 49 iterations, 193, 265, 132, 177 → 138, 132, 87, 92 evaluations; the
/// same states (mean gaps within 1e-12). 1e-2 and 0.1 save a few more evaluations at the cost of
/// iterations in some cases (n = 512², p̄ = 0: 65 at 0.1).
const LINE_TOL: f64 = 1e-3;
/// Inner iterations of the line search.
const LINE_ITER: usize = 60;

/// The nodes of one ray, as columns (the adhesive slope loop runs over lanes of them).
#[derive(Default)]
struct RayNodes {
    /// Gap at α = 0.
    g: Vec<f64>,
    /// Direction.
    d: Vec<f64>,
    /// γ(g) at α = 0.
    e: Vec<f64>,
    /// −g/ρ and −d/ρ (adhesion only; by multiplication with 1/ρ): γ(g + αd) = −γ0 exp(c + αw)
    /// while 0 < g + αd < cutoff.
    c: Vec<f64>,
    w: Vec<f64>,
    /// Nodes on the ray: the first `len` of each column.
    len: usize,
}

impl RayNodes {
    /// Room for `n` nodes (allocated once per solve).
    fn reserve(&mut self, n: usize) {
        if self.g.len() < n {
            for v in [
                &mut self.g,
                &mut self.d,
                &mut self.e,
                &mut self.c,
                &mut self.w,
            ] {
                v.resize(n, 0.0);
            }
        }
    }

    /// Node `k`: gap g, direction d, γ(g) = e; `inv_rho` = 1/ρ (adhesion; any value otherwise).
    #[inline(always)]
    fn set(&mut self, k: usize, g: f64, d: f64, e: f64, inv_rho: f64) {
        self.g[k] = g;
        self.d[k] = d;
        self.e[k] = e;
        self.c[k] = -g * inv_rho;
        self.w[k] = -d * inv_rho;
    }

    fn len(&self) -> usize {
        self.len
    }
}

/// Lanes of the adhesive slope loop: independent partial sums, added in a fixed order at the
/// end, so the compiler may keep them in vector registers (a single running sum would have to
/// stay sequential) and the result does not depend on the instruction set.
const LANES: usize = 4;

/// e^y to about one ulp for |y| ≤ 700 (clamped beyond), without branches or calls so that a
/// loop over it vectorises: y = k ln 2 + r with |r| ≤ ln 2 / 2 (Cody–Waite, the ln 2 split of
/// fdlibm), e^r by its Taylor polynomial to degree 13 (remainder < r¹⁴/14! ≤ 4e-18), 2^k put
/// into the exponent bits. Plain IEEE operations in a fixed order (Rust does not contract them
/// into fused multiply–adds): the same bits on every target and instruction set.
#[inline(always)]
fn exp_fast(y: f64) -> f64 {
    // 1.5 · 2^52 + 1023: y log2(e) + SHIFT rounds to an integer k + 1023 + 1.5 · 2^52 whose
    // low mantissa bits are k + 1023, the biased exponent of 2^k.
    const SHIFT: f64 = 6_755_399_441_056_767.0;
    const LN2_HI: f64 = 6.931_471_803_691_238e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    let y = y.clamp(-700.0, 700.0);
    let s = y * std::f64::consts::LOG2_E + SHIFT;
    let k = s - SHIFT;
    let r = (y - k * LN2_HI) - k * LN2_LO;
    let mut p = 1.605_904_383_682_161_3e-10;
    for c in [
        2.087_675_698_786_81e-9,
        2.505_210_838_544_172e-8,
        2.755_731_922_398_589e-7,
        2.755_731_922_398_589_3e-6,
        2.480_158_730_158_73e-5,
        1.984_126_984_126_984e-4,
        1.388_888_888_888_889e-3,
        8.333_333_333_333_333e-3,
        4.166_666_666_666_666_4e-2,
        1.666_666_666_666_666_6e-1,
        0.5,
        1.0,
        1.0,
    ] {
        p = p * r + c;
    }
    p * f64::from_bits(s.to_bits() << 52)
}

/// Everything the line search needs about one ray: the nodes the interaction can reach, and the
/// elastic scalars.
struct Ray<'a> {
    /// Nodes with d ≠ 0 that are, or may come, within the interaction's cutoff.
    nodes: &'a RayNodes,
    /// Σ d (σ + p̄).
    a: f64,
    /// Σ d K d.
    b: f64,
    /// φ'(0) and φ''(0) (times N), from the gradient pass (no exponentials needed).
    start: (f64, f64),
    law: Law,
}

impl Ray<'_> {
    /// φ'(α), φ''(α) and φ(α) (times N) of the energy along the ray, the wall ignored.
    fn slope(&self, alpha: f64) -> (f64, f64, f64) {
        let (s1, s2, s0) = if matches!(self.law.interaction, Interaction::Adhesion { .. }) {
            self.adhesive_sums(alpha)
        } else {
            let (mut s1, mut s2, mut s0) = (0.0, 0.0, 0.0);
            let nd = self.nodes;
            for i in 0..nd.len() {
                let (g, d) = (nd.g[i], nd.d[i]);
                let x = (g + alpha * d).max(0.0);
                let (e, d1, d2) = self.law.eval(x);
                s0 += e - nd.e[i];
                s1 += d * d1;
                s2 += d * d * d2;
            }
            (s1, s2, s0)
        };
        (
            self.a + alpha * self.b + s1,
            self.b + s2,
            alpha * self.a + 0.5 * alpha * alpha * self.b + s0,
        )
    }

    /// Σ d γ'(x), Σ d² γ''(x), Σ (γ(x) − γ(g)) at x = max(g + αd, 0) for exponential adhesion,
    /// γ = −γ0 e^(−x/ρ): with y = −x/ρ = c + αw (c = −g/ρ, w = −d/ρ), γ(x) = −γ0 e^y,
    /// γ' = −γ/ρ, γ'' = γ/ρ², so d γ' = w γ and d² γ'' = w² γ: one multiplication in the
    /// exponent instead of a division, none in the sums, and a vectorisable exponential.
    #[inline(never)]
    fn adhesive_sums(&self, alpha: f64) -> (f64, f64, f64) {
        let nd = self.nodes;
        let n = nd.len();
        let (c, e, w) = (&nd.c[..n], &nd.e[..n], &nd.w[..n]);
        let at_zero = self.law.at_zero.0;
        let beyond = -self.law.cut * (1.0 / self.law.interaction.range());
        // one lane: the exponential always (branch-free, so the lanes vectorise), then the
        // contact value on the wall (y ≥ 0, exp(0) = 1 exactly) and zero beyond the cutoff
        let lane = |c: f64, e: f64, w: f64, s: &mut [[f64; LANES]; 3], l: usize| {
            let y = c + alpha * w;
            let t = at_zero * exp_fast(y.min(0.0));
            let ex = if y > beyond { t } else { 0.0 };
            s[0][l] += ex - e;
            s[1][l] += w * ex;
            s[2][l] += w * w * ex;
        };
        let mut s = [[0.0; LANES]; 3];
        for ((c, e), w) in c
            .chunks_exact(LANES)
            .zip(e.chunks_exact(LANES))
            .zip(w.chunks_exact(LANES))
        {
            for l in 0..LANES {
                lane(c[l], e[l], w[l], &mut s, l);
            }
        }
        let full = n / LANES * LANES;
        for i in full..n {
            lane(c[i], e[i], w[i], &mut s, 0);
        }
        let [s0, s1, s2] = s;
        let sum = |s: [f64; LANES]| (s[0] + s[1]) + (s[2] + s[3]);
        (sum(s1), sum(s2), sum(s0))
    }

    /// The first minimum of the energy along the ray: the smallest α > 0 where φ' changes sign
    /// from negative to positive, by Newton steps safeguarded with a bracket [lo, hi], never
    /// beyond `alpha_cap`. Returns α and φ(α).
    fn first_minimum(&self, alpha_cap: f64) -> (f64, f64) {
        let (mut lo, mut hi, mut phi_lo) = (0.0f64, f64::INFINITY, 0.0);
        let (mut alpha, mut phi) = (0.0, 0.0);
        let (mut s1, mut s2) = self.start;
        let tol = LINE_TOL * s1.abs();
        for _ in 0..LINE_ITER {
            if s1 < 0.0 {
                (lo, phi_lo) = (alpha, phi);
            } else {
                hi = alpha;
            }
            if s1.abs() <= tol && alpha > 0.0 {
                break;
            }
            let newton = if s2 > 0.0 { alpha - s1 / s2 } else { f64::NAN };
            let next = if newton > lo && newton < hi {
                newton.min(alpha_cap)
            } else if hi.is_finite() {
                0.5 * (lo + hi)
            } else {
                // no usable curvature: expand (the preconditioned step has scale 1), capped
                (2.0 * lo).max(1.0).min(alpha_cap)
            };
            if next == alpha || hi - lo <= 1e-14 * hi.min(alpha_cap) {
                break;
            }
            alpha = next;
            (s1, s2, phi) = self.slope(alpha);
            if alpha >= alpha_cap && s1 < 0.0 {
                return (alpha_cap, phi);
            }
        }
        if s1 > 0.0 && lo > 0.0 {
            (lo, phi_lo)
        } else {
            (alpha, phi)
        }
    }
}

/// The interaction with a cutoff beyond which its energy and derivatives are below rounding.
#[derive(Clone, Copy)]
struct Law {
    interaction: Interaction,
    /// Gap beyond which γ, γ', γ'' are below e⁻⁴⁰ ≈ 4e-18 of their scale (γ0, γ0/ρ, γ0/ρ²
    /// times at most (g/ρ)² ≤ 100): treated as zero.
    cut: f64,
    /// γ, γ', γ'' at contact (g = 0), evaluated once: nodes on the wall need no exponential.
    at_zero: (f64, f64, f64),
}

impl Law {
    fn new(interaction: Interaction) -> Self {
        let cut = match interaction {
            Interaction::HardWall => 0.0,
            Interaction::Adhesion { rho, .. } => 40.0 * rho,
            // exp(−g²/2ρ²) < e⁻⁴⁰ for g > √80 ρ ≈ 8.9ρ
            Interaction::Repulsion { rho, .. } => 10.0 * rho,
        };
        let mut law = Law {
            interaction,
            cut,
            at_zero: (0.0, 0.0, 0.0),
        };
        law.at_zero = law.formula(0.0);
        law
    }

    /// γ(x), γ'(x), γ''(x) with one exponential (none at contact or beyond the cutoff).
    #[inline]
    fn eval(&self, x: f64) -> (f64, f64, f64) {
        if x >= self.cut {
            (0.0, 0.0, 0.0)
        } else if x <= 0.0 {
            self.at_zero
        } else {
            self.formula(x)
        }
    }

    #[inline]
    fn formula(&self, x: f64) -> (f64, f64, f64) {
        match self.interaction {
            Interaction::HardWall => (0.0, 0.0, 0.0),
            // Divisions, not multiplications by 1/ρ: the latter (5 % faster) differ by rounding,
            // which moved the smoke preset's Figure 3 square path on 32² (a rounding-sensitive
            // jump: full contact at γ0 = 50 instead of area 0.94).
            Interaction::Adhesion { gamma0, rho } => {
                let e = -gamma0 * (-x / rho).exp();
                (e, -e / rho, e / (rho * rho))
            }
            Interaction::Repulsion { gamma_r, rho } => {
                let r2 = rho * rho;
                let e = gamma_r * (-0.5 * x * x / r2).exp();
                (e, -e * x / r2, e / r2 * (x * x / r2 - 1.0))
            }
        }
    }
}

/// Gradient r on the free nodes (0 on held ones), residual, contact count and smallest open gap;
/// `local` receives γ(g) and γ''(g) per node for the line search.
fn gradient(
    u: &[f64],
    h: &[f64],
    sigma: &[f64],
    law: Law,
    pressure: f64,
    r: &mut [f64],
    local: &mut [(f64, f64)],
) -> (f64, usize, f64) {
    let n = u.len();
    // equal lengths up front: no bounds checks in the loop
    let (h, sigma, r, local) = (&h[..n], &sigma[..n], &mut r[..n], &mut local[..n]);
    let mut t = Tally::START;
    for i in 0..n {
        let g = u[i] - h[i];
        let (e, d1, d2) = law.eval(g.max(0.0));
        local[i] = (e, d2);
        r[i] = t.node(g, sigma[i] + pressure + d1);
    }
    t.into()
}

/// Residual, contact count and smallest open gap of a pass over the nodes.
struct Tally {
    res: f64,
    contact: usize,
    min_gap: f64,
}

impl Tally {
    const START: Tally = Tally {
        res: 0.0,
        contact: 0,
        min_gap: f64::INFINITY,
    };

    /// Counts a node of gap `g` whose unbalanced pressure is `ri` and returns its gradient: on
    /// the wall the push (r ≥ 0) is held (0), a pull (r < 0) is unbalanced.
    #[inline(always)]
    fn node(&mut self, g: f64, ri: f64) -> f64 {
        if g <= 0.0 {
            self.contact += 1;
            self.res = self.res.max(-ri);
            ri.min(0.0)
        } else {
            self.res = self.res.max(ri.abs());
            self.min_gap = self.min_gap.min(g);
            ri
        }
    }
}

impl From<Tally> for (f64, usize, f64) {
    fn from(t: Tally) -> Self {
        (t.res, t.contact, t.min_gap)
    }
}

/// [`gradient`] and the energy per area with its rounding slack (as [`crate::fire::energy`],
/// the interaction taken from the same exponential as the gradient, zero beyond the cutoff where
/// it is below e⁻⁴⁰ γ0) in one pass; `mean_u` is the mean of `u`.
#[allow(clippy::too_many_arguments)]
fn evaluate(
    u: &[f64],
    h: &[f64],
    sigma: &[f64],
    law: Law,
    pressure: f64,
    mean_u: f64,
    r: &mut [f64],
    local: &mut [(f64, f64)],
) -> ((f64, usize, f64), (f64, f64)) {
    let n = u.len();
    // equal lengths up front: no bounds checks in the loop
    let (h, sigma, r, local) = (&h[..n], &sigma[..n], &mut r[..n], &mut local[..n]);
    let mut t = Tally::START;
    // compensated (Kahan) sum, as crate::fire::energy
    let (mut e_sum, mut c, mut abs) = (0.0f64, 0.0f64, 0.0f64);
    for i in 0..n {
        let g = u[i] - h[i];
        let (e, d1, d2) = law.eval(g.max(0.0));
        local[i] = (e, d2);
        r[i] = t.node(g, sigma[i] + pressure + d1);
        let el = 0.5 * (u[i] - mean_u) * sigma[i];
        let y = el + e - c;
        let t = e_sum + y;
        c = (t - e_sum) - y;
        e_sum = t;
        abs += el.abs() + e.abs();
    }
    let n = n as f64;
    let load = pressure * mean_u;
    (
        t.into(),
        (
            e_sum / n + load,
            64.0 * f64::EPSILON * (abs / n + load.abs()),
        ),
    )
}

/// Work buffers and the conjugacy memory of one solve.
struct Work {
    sigma: Vec<f64>,
    r: Vec<f64>,
    r_old: Vec<f64>,
    z: Vec<f64>,
    d: Vec<f64>,
    kd: Vec<f64>,
    nodes: RayNodes,
    u_prev: Vec<f64>,
    /// ⟨r, z⟩ of the previous direction; 0 forces a restart (d = −z).
    rz_old: f64,
    /// Steps since σ was computed from scratch.
    stale: usize,
    /// Energy per area and its rounding slack.
    energy: (f64, f64),
    /// L-BFGS pairs (s, y, 1/⟨s, y⟩), oldest first.
    history: std::collections::VecDeque<(Vec<f64>, Vec<f64>, f64)>,
    /// The last step clipped nodes onto the wall (the active set changed).
    clipped: bool,
    /// The branch safeguard (one range per step near the wall) is on: off only for a cold
    /// start under adhesion, which has no branch to keep.
    guard_range: bool,
    /// Steps at which free nodes moving down would reach the wall.
    hits: Vec<f64>,
    /// γ(g) and γ''(g) per node at the current state.
    local: Vec<(f64, f64)>,
    /// Residual, contact count and smallest open gap of the current state when the step
    /// evaluated them already (with `r` and `local`), fused with its energy pass.
    evaluated: Option<(f64, usize, f64)>,
}

/// The L-BFGS direction d = −H r (two-loop recursion, H0 = M⁻¹ on the free nodes); returns
/// ⟨d, r⟩. The pair of the last step enters if its curvature ⟨s, y⟩ is positive (the adhesive
/// energy is not convex: pairs across a softening region are skipped).
fn lbfgs_direction(
    w: &mut Work,
    kernel: &mut crate::elastic::ElasticKernel,
    weights: &[f64],
    u: &[f64],
    h: &[f64],
) -> f64 {
    let n = u.len();
    let held = |r: &[f64], i: usize| r[i] == 0.0 && u[i] <= h[i];
    if w.clipped {
        // the active set changed: old curvature pairs describe another problem
        w.history.clear();
    }
    if w.rz_old > 0.0 && !w.clipped {
        let (mut s, mut y) = if w.history.len() == LBFGS_MEMORY {
            let (s, y, _) = w.history.pop_front().expect("full");
            (s, y)
        } else {
            (vec![0.0; n], vec![0.0; n])
        };
        let mut sy = 0.0;
        for i in 0..n {
            let free = !held(&w.r, i);
            s[i] = if free { u[i] - w.u_prev[i] } else { 0.0 };
            y[i] = if free { w.r[i] - w.r_old[i] } else { 0.0 };
            sy += s[i] * y[i];
        }
        if sy > 0.0 {
            w.history.push_back((s, y, 1.0 / sy));
        }
    } else {
        w.history.clear();
    }
    loop {
        w.d.copy_from_slice(&w.r);
        let mut coef = Vec::with_capacity(w.history.len());
        for (s, y, rho) in w.history.iter().rev() {
            let a = rho * dot(s, &w.d);
            w.d.iter_mut().zip(y).for_each(|(q, y)| *q -= a * y);
            coef.push(a);
        }
        kernel.precondition(&w.d, weights, &mut w.z);
        for i in 0..n {
            if held(&w.r, i) {
                w.z[i] = 0.0;
            }
        }
        for ((s, y, rho), a) in w.history.iter().zip(coef.iter().rev()) {
            let b = rho * dot(y, &w.z);
            w.z.iter_mut().zip(s).for_each(|(z, s)| *z += (a - b) * s);
        }
        let mut slope = 0.0;
        for i in 0..n {
            w.d[i] = -w.z[i];
            slope += w.d[i] * w.r[i];
        }
        if slope < 0.0 || w.history.is_empty() {
            w.rz_old = 1.0;
            w.r_old.copy_from_slice(&w.r);
            return slope;
        }
        w.history.clear();
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl NonlinearCg {
    /// The nested cold start: on a grid of at least `nested_min_nodes` nodes whose sides
    /// halve to even ones, the same problem on the grid of every other node (the heights
    /// injected, the same cell, the cohesive zone still resolved, see
    /// [`Model::resolves_cohesive_zone`]) is solved from its own cold start to [`NESTED_TOL`]
    /// (itself nested where it is large enough), and its surface, interpolated bilinearly,
    /// replaces the uniform start `u`. Returns the iterations of all coarser grids, or `None`
    /// (and `u` untouched) where the grid is too small or odd or the coarse solve fails or does
    /// not converge: the fine solve then starts cold as before.
    fn nested_start(
        &self,
        model: &Model,
        interaction: Interaction,
        pressure: f64,
        opts: &SolverOptions,
        u: &mut [f64],
    ) -> Option<usize> {
        let g = *model.grid();
        let (nx, ny) = (g.nx, g.ny);
        if nx * ny < self.nested_min_nodes || nx % 4 != 0 || ny % 4 != 0 {
            return None;
        }
        let (cx, cy) = (nx / 2, ny / 2);
        let h = model.heights();
        let coarse_heights =
            ndarray::Array2::from_shape_fn((cx, cy), |(i, j)| h[2 * i * ny + 2 * j]);
        let grid = crate::Grid {
            nx: cx,
            ny: cy,
            shift: (0.5 * g.shift.0, 0.5 * g.shift.1),
            ..g
        };
        let mut coarse = Model::from_heights(grid, coarse_heights.view()).ok()?;
        if !coarse.resolves_cohesive_zone(interaction) {
            return None;
        }
        let coarse_opts = SolverOptions {
            tol_force: NESTED_TOL.max(opts.tol_force),
            trace: false,
            ..opts.clone()
        };
        let mut state = coarse.cold_start(interaction, pressure);
        let stats = self
            .relax(&mut coarse, interaction, pressure, &coarse_opts, &mut state)
            .ok()?;
        if !stats.converged {
            return None;
        }
        let c = &state.u;
        for i in 0..cx {
            let i1 = (i + 1) % cx;
            for j in 0..cy {
                let j1 = (j + 1) % cy;
                let (a, b, d, e) = (
                    c[i * cy + j],
                    c[i1 * cy + j],
                    c[i * cy + j1],
                    c[i1 * cy + j1],
                );
                u[2 * i * ny + 2 * j] = a;
                u[(2 * i + 1) * ny + 2 * j] = 0.5 * (a + b);
                u[2 * i * ny + 2 * j + 1] = 0.5 * (a + d);
                u[(2 * i + 1) * ny + 2 * j + 1] = 0.25 * (a + b + d + e);
            }
        }
        Some(stats.iterations)
    }

    /// d = −z + β d_old on the free nodes; returns ⟨d, r⟩ (< 0 for a descent direction).
    fn direction(&self, w: &mut Work, u: &[f64], h: &[f64]) -> f64 {
        let n = u.len();
        let (r, z, r_old, d, h) = (
            &w.r[..n],
            &mut w.z[..n],
            &mut w.r_old[..n],
            &mut w.d[..n],
            &h[..n],
        );
        let (mut rz, mut rz_cross) = (0.0, 0.0);
        for i in 0..n {
            if r[i] == 0.0 && u[i] <= h[i] {
                z[i] = 0.0; // held by the wall
            }
            rz += r[i] * z[i];
            rz_cross += r_old[i] * z[i];
        }
        let beta = if w.rz_old <= 0.0 {
            0.0
        } else {
            match self.beta {
                Beta::PolakRibiere => ((rz - rz_cross) / w.rz_old).max(0.0),
                Beta::FletcherReeves => rz / w.rz_old,
                Beta::SteepestDescent | Beta::Lbfgs => 0.0,
            }
        };
        let mut slope = 0.0;
        for i in 0..n {
            d[i] = beta * d[i] - z[i];
            if z[i] == 0.0 && r[i] == 0.0 {
                d[i] = 0.0;
            }
            slope += d[i] * r[i];
            r_old[i] = r[i];
        }
        if slope >= 0.0 && beta != 0.0 {
            slope = 0.0;
            for i in 0..n {
                d[i] = -z[i];
                slope += d[i] * r[i];
            }
        }
        w.rz_old = rz;
        slope
    }
}

/// The step at which the wall would hold more than [`CONTACT_GROWTH`] × max(contact, n/64) new
/// nodes, from `hits` (the steps at which the free nodes moving down reach the wall): the line
/// search ignores the wall, and a step far past the first contacts puts many nodes on it that
/// the following iterations must release one by one.
fn contact_growth_cap(hits: &mut [f64], contact: usize, n: usize) -> f64 {
    let allowed = ((CONTACT_GROWTH * contact.max(n / 64) as f64) as usize).max(1);
    if hits.len() <= allowed {
        return f64::MAX;
    }
    let (_, kth, _) = hits.select_nth_unstable_by(allowed, f64::total_cmp);
    *kth
}

/// The line search along d (with K d in `w.kd`) and the step: u ← max(u + α d, h), halved until
/// the energy does not rise beyond rounding. Returns false if no step lowered it.
fn step(
    w: &mut Work,
    kernel: &mut crate::elastic::ElasticKernel,
    u: &mut [f64],
    h: &[f64],
    law: Law,
    pressure: f64,
) -> bool {
    let n = u.len();
    let (mut a, mut b) = (0.0, 0.0);
    // the largest useful step: every node moving down has reached the wall
    let mut wall_cap = 0.0f64;
    // Branch safeguard: a node within the interaction's range moves by at most one range per
    // step, so the ray cannot carry it over a barrier of the interaction. min(range/|d|) over
    // those nodes is range / max|d| (division is monotone, also in floating point).
    let range = law.interaction.range();
    let near = IN_RANGE * range;
    let mut d_near = 0.0f64;
    let mut contact = 0usize;
    let (mut s1, mut s2) = (0.0, 0.0);
    let mut n_hits = 0;
    w.u_prev.copy_from_slice(u);
    // The line search needs only the nodes the interaction reaches for α ≤ alpha_cap: those
    // within the cutoff or moving down (a node that stays beyond the cutoff adds exact zeros).
    w.nodes.reserve(n);
    let mut n_nodes = 0;
    let inv_rho = if range > 0.0 { 1.0 / range } else { 0.0 };
    let (hh, dir, sigma, kd, r, local, hits) = (
        &h[..n],
        &w.d[..n],
        &w.sigma[..n],
        &w.kd[..n],
        &w.r[..n],
        &w.local[..n],
        &mut w.hits[..n],
    );
    for i in 0..n {
        let (g, d) = (u[i] - hh[i], dir[i]);
        a += d * (sigma[i] + pressure);
        b += d * kd[i];
        s1 += d * r[i];
        s2 += d * d * local[i].1;
        if g <= 0.0 {
            contact += 1;
        }
        if d < 0.0 {
            let hit = -g / d;
            wall_cap = wall_cap.max(hit);
            if g > 0.0 {
                hits[n_hits] = hit;
                n_hits += 1;
            }
        }
        if g < near {
            d_near = d_near.max(d.abs());
        }
        if d != 0.0 && (g < law.cut || d < 0.0) {
            w.nodes.set(n_nodes, g, d, local[i].0, inv_rho);
            n_nodes += 1;
        }
    }
    w.nodes.len = n_nodes;
    if wall_cap == 0.0 {
        wall_cap = f64::MAX;
    }
    let range_cap = if d_near > 0.0 && w.guard_range {
        range / d_near
    } else {
        f64::MAX
    };
    let growth_cap = contact_growth_cap(&mut w.hits[..n_hits], contact, n);
    let alpha_cap = wall_cap.min(range_cap).min(growth_cap);
    let ray = Ray {
        nodes: &w.nodes,
        a,
        b,
        start: (s1, b + s2),
        law,
    };
    let (mut alpha, mut phi) = ray.first_minimum(alpha_cap);
    let (e0, slack0) = w.energy;
    // σ = σ_prev + moved · K d while known that way (no clipping so far), else None
    let mut moved = Some(0.0);
    for _ in 0..=MAX_HALVINGS {
        let mut clipped = false;
        let shift = moved.map_or(0.0, |m| alpha - m);
        let (u_prev, d, kd, sigma, hh) = (
            &w.u_prev[..n],
            &w.d[..n],
            &w.kd[..n],
            &mut w.sigma[..n],
            &h[..n],
        );
        for i in 0..n {
            let x = u_prev[i] + alpha * d[i];
            clipped |= x < hh[i];
            u[i] = x.max(hh[i]);
            sigma[i] += shift * kd[i];
        }
        moved = moved.map(|_| alpha);
        w.stale += 1;
        let e_new = if clipped || moved.is_none() || w.stale >= REFRESH {
            kernel.stress(u, &mut w.sigma);
            w.stale = 0;
            moved = None;
            // the next iteration's gradient comes with the energy, from one pass
            let mean_u = u.iter().sum::<f64>() / n as f64;
            let (grad, e) = evaluate(
                u,
                h,
                &w.sigma,
                law,
                pressure,
                mean_u,
                &mut w.r,
                &mut w.local,
            );
            w.evaluated = Some(grad);
            e
        } else {
            // exact along the ray without clipping: no full pass needed
            w.evaluated = None;
            (e0 + phi / n as f64, slack0)
        };
        if e_new.0 <= e0 + slack0 {
            w.energy = e_new;
            w.clipped = clipped;
            return true;
        }
        alpha *= 0.5;
        phi = ray.slope(alpha).2;
    }
    u.copy_from_slice(&w.u_prev);
    w.evaluated = None;
    match moved {
        Some(m) => w.sigma.iter_mut().zip(&w.kd).for_each(|(s, k)| *s -= m * k),
        None => kernel.stress(u, &mut w.sigma),
    }
    w.energy = (e0, slack0);
    false
}

impl Minimizer for NonlinearCg {
    fn name(&self) -> &'static str {
        match self.beta {
            Beta::PolakRibiere => "nonlinear-cg",
            Beta::FletcherReeves => "nonlinear-cg-fr",
            Beta::SteepestDescent => "nonlinear-cg-sd",
            Beta::Lbfgs => "lbfgs",
        }
    }

    fn relax(
        &self,
        model: &mut Model,
        interaction: Interaction,
        pressure: f64,
        opts: &SolverOptions,
        state: &mut State,
    ) -> Result<SolveStats, ContactError> {
        // a uniform surface is the cold start of Model::solve (no branch to follow yet); under
        // repulsion the safeguard saves iterations there too (128², p̄ = 0.1, 0.3 p_fc: 95, 138
        // with it, 135, 222 without), so only adhesion drops it
        let cold = state.u.iter().all(|&x| x == state.u[0])
            && matches!(interaction, Interaction::Adhesion { .. });
        let coarse_iterations = if cold {
            self.nested_start(model, interaction, pressure, opts, &mut state.u)
        } else {
            None
        };
        let Model {
            heights: h, kernel, ..
        } = model;
        let n = h.len();
        let State { u, p } = state;
        let law = Law::new(interaction);
        let m0 = kernel.k_min();
        let weights = kernel.weights(|k| if k > 0.0 { k } else { m0 });
        let detach_gap = 20.0 * interaction.range().max(1e-3);
        for (ui, hi) in u.iter_mut().zip(h.iter()) {
            *ui = ui.max(*hi);
        }
        let mut w = Work {
            sigma: vec![0.0; n],
            r: vec![0.0; n],
            r_old: vec![0.0; n],
            z: vec![0.0; n],
            d: vec![0.0; n],
            kd: vec![0.0; n],
            nodes: RayNodes::default(),
            u_prev: vec![0.0; n],
            rz_old: 0.0,
            stale: 0,
            energy: (0.0, 0.0),
            history: std::collections::VecDeque::new(),
            clipped: false,
            guard_range: !cold,
            hits: vec![0.0; n],
            local: vec![(0.0, 0.0); n],
            evaluated: None,
        };
        if coarse_iterations.is_some() {
            // the interpolated start of a nested solve comes without its stress
            kernel.stress(u, &mut w.sigma);
        } else {
            // σ = K u is p − p̄ by the contract of every minimiser's final state (and of the
            // uniform cold start): no transform. It is recomputed before convergence is accepted
            // (stale > 0), so a warm start that breaks the contract costs iterations, not
            // accuracy.
            let mean_p = p.iter().sum::<f64>() / n as f64;
            for (s, pi) in w.sigma.iter_mut().zip(p.iter()) {
                *s = pi - mean_p;
            }
        }
        w.stale = 1;
        w.energy = crate::fire::energy(u, &w.sigma, h, interaction, pressure);
        let mut stats = SolveStats {
            method: self.name(),
            iterations: 0,
            converged: false,
            reason: None,
            max_violation: 0.0,
            force_residual: f64::INFINITY,
            wall_s: 0.0,
            trace: Vec::new(),
        };
        let mut monitor = StopMonitor::new(STAGNATION, 1e12);
        loop {
            let (mut res, contact, min_gap) = match w.evaluated.take() {
                Some(grad) => grad,
                None => gradient(u, h, &w.sigma, law, pressure, &mut w.r, &mut w.local),
            };
            if res <= opts.tol_force && w.stale > 0 {
                // accept only on a σ computed from scratch
                kernel.stress(u, &mut w.sigma);
                w.stale = 0;
                (res, _, _) = gradient(u, h, &w.sigma, law, pressure, &mut w.r, &mut w.local);
            }
            if opts.trace {
                stats.trace.push(w.energy.0);
            }
            stats.force_residual = res;
            if res <= opts.tol_force {
                stats.converged = true;
                break;
            }
            if contact == 0 && pressure <= 0.0 && min_gap > detach_gap {
                return Err(ContactError::Detached { pressure, min_gap });
            }
            if let Some(reason) = monitor.check(res, stats.iterations, opts.tol_force) {
                stats.reason = Some(reason);
                break;
            }
            if stats.iterations >= opts.max_iter {
                stats.reason = Some(StopReason::IterationCap);
                break;
            }
            stats.iterations += 1;
            let slope = if self.beta == Beta::Lbfgs {
                lbfgs_direction(&mut w, kernel, &weights, u, h)
            } else {
                kernel.precondition(&w.r, &weights, &mut w.z);
                self.direction(&mut w, u, h)
            };
            if slope >= 0.0 {
                // not even −z descends: the gradient is at rounding level
                stats.reason = Some(StopReason::Stagnation);
                break;
            }
            kernel.stress(&w.d, &mut w.kd);
            if !step(&mut w, kernel, u, h, law, pressure) {
                if w.rz_old == 0.0 {
                    // −z did not lower the energy either: rounding level
                    stats.reason = Some(StopReason::Stagnation);
                    break;
                }
                w.rz_old = 0.0; // restart along −z
            }
        }
        if w.stale > 0 {
            // a converged state's σ is fresh already
            kernel.stress(u, &mut w.sigma);
        }
        for i in 0..n {
            p[i] = w.sigma[i] + pressure;
        }
        stats.iterations += coarse_iterations.unwrap_or(0);
        Ok(stats)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ADHESION: Interaction = Interaction::Adhesion {
        gamma0: 0.2,
        rho: 0.04,
    };

    /// A ray whose start (φ'(0), φ''(0)) is evaluated directly from the law.
    fn ray_with(law: Law, nodes: &RayNodes, a: f64, b: f64) -> Ray<'_> {
        let (mut s1, mut s2) = (a, b);
        for (&g, &d) in nodes.g[..nodes.len].iter().zip(&nodes.d[..nodes.len]) {
            let (_, d1, d2) = law.eval(g);
            s1 += d * d1;
            s2 += d * d * d2;
        }
        Ray {
            nodes,
            a,
            b,
            start: (s1, s2),
            law,
        }
    }

    fn ray(nodes: &RayNodes, a: f64, b: f64) -> Ray<'_> {
        ray_with(Law::new(ADHESION), nodes, a, b)
    }

    /// The nested start solves the grid of every other node (the heights injected) and
    /// interpolates its surface: at the shared nodes it is that solution, at the others the
    /// mean of their neighbours; where the grid is too small, its sides do not halve to even
    /// ones or the coarse grid does not resolve the cohesive zone, it leaves the start alone.
    #[test]
    fn nested_start_interpolates_the_coarse_solution_and_knows_when_not_to() {
        use crate::{Grid, Lattice, Surface};
        let opts = SolverOptions {
            tol_force: 1e-10,
            ..SolverOptions::default()
        };
        let ncg = NonlinearCg {
            nested_min_nodes: 1 << 14,
            ..NonlinearCg::default()
        };
        let fine = Model::new(&Surface::new(Lattice::Square, 7).unwrap()).unwrap();
        let coarse_surface = Surface::new(Lattice::Square, 6).unwrap();
        // the injected heights are the coarse grid's own samples of the surface
        for i in 0..64 {
            for j in 0..64 {
                let (a, b) = (
                    fine.heights()[2 * i * 128 + 2 * j],
                    coarse_surface.heights[[i, j]],
                );
                assert!((a - b).abs() <= 1e-12, "{i} {j}: {a} {b}");
            }
        }
        // ρ = 0.12: the cohesive zone ρ²E*/γ0 = 0.072 λ spans 4.6 spacings of 64²
        let wide = Interaction::Adhesion {
            gamma0: 0.2,
            rho: 0.12,
        };
        let mut coarse = Model::new(&coarse_surface).unwrap();
        let reference = coarse
            .solve_with(
                &NonlinearCg::default(),
                wide,
                0.5,
                &SolverOptions {
                    tol_force: NESTED_TOL,
                    ..opts.clone()
                },
                None,
            )
            .unwrap();
        let mut u = vec![7.0; 128 * 128];
        let its = ncg.nested_start(&fine, wide, 0.5, &opts, &mut u);
        assert_eq!(its, Some(reference.stats.iterations));
        let c = reference.displacement;
        for i in 0..64 {
            for j in 0..64 {
                let (i1, j1) = ((i + 1) % 64, (j + 1) % 64);
                assert_eq!(u[2 * i * 128 + 2 * j], c[[i, j]]);
                assert_eq!(u[(2 * i + 1) * 128 + 2 * j], 0.5 * (c[[i, j]] + c[[i1, j]]));
                assert_eq!(u[2 * i * 128 + 2 * j + 1], 0.5 * (c[[i, j]] + c[[i, j1]]));
                let mean = 0.25 * (c[[i, j]] + c[[i1, j]] + c[[i, j1]] + c[[i1, j1]]);
                assert_eq!(u[(2 * i + 1) * 128 + 2 * j + 1], mean);
            }
        }
        // not nested: too small a grid; ρ = 0.04 on 64² (zone 0.008 λ, half a spacing); sides
        // that halve to odd ones (2·(2k + 1))
        let untouched = |model: &Model, inter: Interaction, min: usize| {
            let mut u = vec![7.0; model.heights().len()];
            let ncg = NonlinearCg {
                nested_min_nodes: min,
                ..NonlinearCg::default()
            };
            ncg.nested_start(model, inter, 0.5, &opts, &mut u).is_none()
                && u.iter().all(|&x| x == 7.0)
        };
        assert!(untouched(&fine, wide, 1 << 15));
        assert!(untouched(&fine, ADHESION, 1 << 14));
        let g = Grid::periodic(98, 98, 1.0, 1.0).unwrap();
        let odd = Model::from_heights(g, ndarray::Array2::zeros((98, 98)).view()).unwrap();
        assert!(untouched(&odd, wide, 1));
    }

    /// Nodes (g, d) on a ray, γ(g) from the law.
    fn nodes(inter: Interaction, gd: &[(f64, f64)]) -> RayNodes {
        let law = Law::new(inter);
        let mut nodes = RayNodes::default();
        nodes.reserve(gd.len());
        for (k, &(g, d)) in gd.iter().enumerate() {
            nodes.set(k, g, d, law.eval(g).0, 1.0 / inter.range());
        }
        nodes.len = gd.len();
        nodes
    }

    #[test]
    fn fast_exponential_agrees_with_libm_to_a_few_ulp() {
        // e^y over the range the line search uses (y = −x/ρ down to −40, a little above 0)
        // and far beyond, against the correctly rounded-to-1-ulp libm exp
        let mut worst = 0.0f64;
        for k in 0..=200_000 {
            let y = -60.0 + k as f64 * 3e-4 + 1e-9 * (k % 7) as f64;
            let (a, b) = (exp_fast(y), y.exp());
            worst = worst.max(((a - b) / b).abs());
        }
        for &y in &[
            -700.0,
            -650.3,
            -1e-300,
            0.0,
            1e-17,
            0.5 * std::f64::consts::LN_2,
            300.7,
            700.0,
        ] {
            let (a, b) = (exp_fast(y), f64::exp(y));
            worst = worst.max(((a - b) / b).abs());
        }
        assert!(
            worst < 4.0 * f64::EPSILON,
            "largest relative error {worst:e}"
        );
        assert_eq!(exp_fast(0.0), 1.0);
        // clamped, not infinite or zero, beyond ±700 (those lanes are masked by the caller)
        assert_eq!(exp_fast(-1e6), exp_fast(-700.0));
        assert_eq!(exp_fast(1e6), exp_fast(700.0));
    }

    #[test]
    fn adhesive_sums_agree_with_the_law_node_by_node() {
        // nodes on and off the wall, moving up and down, beyond the cutoff and coming into it,
        // crossing the wall at some α: the factorised sums against Law::eval term by term
        let law = Law::new(ADHESION);
        let mut gd = Vec::new();
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..1003 {
            let g = if next() < 0.2 { 0.0 } else { 2.0 * next() };
            gd.push((g, 2.0 * next() - 1.0));
        }
        let nodes = nodes(ADHESION, &gd);
        let ray = ray_with(law, &nodes, 0.0, 0.0);
        for &alpha in &[0.0, 1e-3, 0.01, 0.05, 0.2, 0.7, 1.5, 3.0] {
            let (mut s, mut abs) = ([0.0; 3], [0.0; 3]);
            for &(g, d) in &gd {
                let (e, d1, d2) = law.eval((g + alpha * d).max(0.0));
                let e0 = law.eval(g).0;
                for (k, t) in [e - e0, d * d1, d * d * d2].into_iter().enumerate() {
                    s[k] += t;
                }
                for (k, t) in [e.abs() + e0.abs(), (d * d1).abs(), (d * d * d2).abs()]
                    .into_iter()
                    .enumerate()
                {
                    abs[k] += t;
                }
            }
            let (t1, t2, t0) = ray.adhesive_sums(alpha);
            // per term: the exponent c + αw (|c| ≤ 40) rounded to ~1e-14 absolute, the
            // exponential to a few ulp: 3e-14 relative, summed over the terms' magnitudes
            for (k, (t, name)) in [(t0, "φ"), (t1, "φ'"), (t2, "φ''")].into_iter().enumerate() {
                assert!(
                    (t - s[k]).abs() <= 3e-14 * abs[k],
                    "α = {alpha}: {name} {t} vs {} (sum of magnitudes {})",
                    s[k],
                    abs[k]
                );
            }
            assert!(abs[2] > 1.0, "α = {alpha}: the nodes reach the interaction");
        }
    }

    #[test]
    fn law_matches_the_interaction_and_its_finite_differences() {
        for inter in [
            ADHESION,
            Interaction::Repulsion {
                gamma_r: 0.2,
                rho: 0.04,
            },
        ] {
            let law = Law::new(inter);
            for &x in &[0.0, 0.01, 0.04, 0.1, 0.3] {
                let (e, d1, d2) = law.eval(x);
                assert!((e - inter.energy(x)).abs() < 1e-15, "{inter:?} {x}");
                assert!((d1 - inter.derivative(x)).abs() < 1e-13, "{inter:?} {x}");
                let h = 1e-6;
                let fd = (inter.derivative(x + h) - inter.derivative((x - h).max(0.0)))
                    / (x + h - (x - h).max(0.0));
                // central difference: error ~ h² γ'''' ≈ 1e-12 · γ0/ρ⁴ ≈ 1e-7; one-sided at 0
                assert!(
                    (d2 - fd).abs() < 1e-3 * inter.max_curvature(),
                    "{inter:?} {x}"
                );
            }
            // beyond the cutoff everything is below e⁻⁴⁰ of its scale
            assert_eq!(law.eval(law.cut), (0.0, 0.0, 0.0));
            assert!(inter.derivative(law.cut).abs() < 1e-16 * inter.max_curvature());
        }
    }

    #[test]
    fn line_search_solves_the_quadratic_exactly() {
        // no node within the interaction's reach: φ'(α) = a + α b, minimum at −a/b
        let empty = RayNodes::default();
        let ray = ray(&empty, -3.0, 2.0);
        let (alpha, phi) = ray.first_minimum(f64::MAX);
        assert!((alpha - 1.5).abs() < 1e-14);
        // φ(α) = a α + ½ b α²
        assert!((phi - (-3.0 * 1.5 + 0.5 * 2.0 * 2.25)).abs() < 1e-14);
        // the cap binds when the minimum lies beyond it
        assert_eq!(ray.first_minimum(1.0).0, 1.0);
    }

    #[test]
    fn line_search_stops_at_the_first_minimum_along_the_ray() {
        // One node at g = 0.3 moving to the wall (d = −1): φ' = −0.001 + 2α − 5 exp(−(0.3 − α)/0.04)
        // has a shallow minimum near α ≈ 0.0025 and a maximum near 0.195; at the wall (α = 0.3)
        // the energy is far lower (−0.11, the adhesion energy γ0 gained against 0.09 elastic).
        let nodes = nodes(ADHESION, &[(0.3, -1.0)]);
        let ray = ray(&nodes, -0.001, 2.0);
        let (alpha, phi) = ray.first_minimum(f64::MAX);
        // the first sign change of φ' from − to +, by a dense scan (independent of Newton)
        let mut first = f64::NAN;
        let mut prev = ray.start.0;
        assert!((prev - ray.slope(0.0).0).abs() < 1e-15);
        for k in 1..=200_000 {
            let x = k as f64 * 1e-6;
            let s = ray.slope(x).0;
            if prev < 0.0 && s >= 0.0 {
                first = x;
                break;
            }
            prev = s;
        }
        assert!(first < 0.02, "scan found {first}");
        assert!((alpha - first).abs() < 2e-6, "{alpha} vs scan {first}");
        assert!(ray.slope(alpha).1 > 0.0, "a minimum, not a maximum");
        assert!(phi < 0.0 && (phi - ray.slope(alpha).2).abs() < 1e-15);
        // the deeper state is beyond the barrier: the line search did not jump to it
        assert!(ray.slope(0.3).2 < phi - 0.1);
    }
}
