//! Constrained conjugate gradients in the contact pressure (Polonsky & Keer, Wear 231, 206, 1999)
//! for the hard-wall problem under force control, preconditioned by the elastic stiffness
//! (Vollebregt, J. Comput. Phys. 257, 333, 2014).
//!
//! Minimises the complementary energy Π(p) = ½⟨p, G p⟩ − ⟨p, h⟩ over p ≥ 0 with mean(p) = p̄,
//! where G is the compliance (1/k(q) for q ≠ 0). Each iteration: gap g = Gp − h shifted so that
//! its mean on the contact set S = {p > 0} vanishes (this shift is the body's rigid approach);
//! preconditioned gradient z = K g_F (K = G⁻¹ the stiffness, g_F the gap on the free set F and
//! zero off it; F is S and the nodes the last step found penetrating), restricted to F with its
//! mean there removed; conjugate direction t = z + β t_old on F with β = ⟨g, z⟩/⟨g_old, z_old⟩;
//! exact line search τ = ⟨g, t⟩/⟨t, G t − mean_F(G t)⟩; step, clip to p ≥ 0, rescale to the
//! imposed mean. Penetrating nodes are marked free (pressure −0.0) and join F for the next
//! direction (restarting the conjugacy), as in Vollebregt's bound-constrained CG: giving each
//! the pressure that lifts it alone (−g/G(0)) overshoots when thousands re-open together and
//! made 4096² solves cycle. Were S the whole cell, K would be G's exact inverse and one
//! iteration would do; with S a part of it the preconditioned operator is
//! still close to the identity away from the contact line, and the iteration count grows only
//! slowly with the grid. [`PolonskyKeer::PLAIN`] is the original method (z = g): one transform
//! pair per iteration instead of two, but 4–6× more iterations.
//!
//! Measured (benches/hardwall.rs, square model, p = 0.3 p_fc, violation ≤ 1e-10, one thread):
//! 24, 26, 31, 33, 33 iterations at 256², 512², 1024², 4096², 8192² against 89, 117, 155 plain;
//! CPU time at 1024² 1.2 s against 3.2 s plain.
//!
//! Cost per iteration: the stiffness transform pair (z, with ⟨g, z⟩ from Parseval in Fourier
//! space) and the compliance pair (G t). The displacement G p is updated from G t and the
//! rescaling without another transform. Clipping or re-opening changes p off the line by a
//! correction c: when c has at most [`DIRECT_CORRECTIONS`] non-zero nodes (all but the early
//! iterations) G c is summed directly from the real-space Green's function; otherwise G p is
//! recomputed (one pair, the cost of transforming c) with the next iteration's gap sums taken from
//! its rows. The displacement is also recomputed from scratch every [`REFRESH`] iterations and
//! before convergence is accepted, so rounding cannot accumulate.
//!
//! The vector passes are folded into the transforms' row passes (see
//! [`crate::spectral::Spectral::convolve_fused`]): the gap on S is written as the stiffness
//! transform reads it, the direction is built as the compliance transform reads it, the line-search
//! sums are taken as G t comes out, and one step pass updates p and u and measures the gap
//! statistics of the next iteration. The load is kept by a scalar σ (true fields = σ × stored), not
//! by a pass over the grid, and the direction is projected onto Σ_S t = 0 so that σ stays 1 up to
//! rounding between corrections. While the rms gap on S (a lower bound of the violation) is far
//! above the tolerance the step pass takes only sums; the extremes that give the violation are
//! measured near convergence and every `STATS_EVERY` iterations. Grid passes run over fixed chunks
//! whose partial sums are added in chunk order, so results do not depend on the number of threads.
//!
//! A coarse-to-fine start (solve on the grid of every second node, interpolate the pressure) was
//! measured for the plain method and saved under 6 % of the fine-grid iterations and no time, so
//! cold solves start from the uniform pressure.
//!
//! Stops when the constraint violation (max |g| on S, max penetration off S) is at most
//! `tol_gap`. Force balance is exact by construction (u = G p, mean p = p̄, p ≥ 0).

use crate::compliance::Compliance;
use crate::stop_monitor::StopMonitor;
use crate::{
    ContactError, Interaction, Minimizer, Model, SolveStats, SolverOptions, State, StopReason,
};
use rayon::prelude::*;

/// Iterations between exact recomputations of G p.
pub const REFRESH: usize = 50;
/// Largest number of corrected nodes whose displacement is summed directly (each costs about
/// one streaming pass over the grid; an FFT pair costs about as much as 20–40 such passes).
pub const DIRECT_CORRECTIONS: usize = 12;
/// The violation (max and min of the gap) is measured at least every this many iterations; in
/// between, while the rms gap is far above the tolerance, only the sums the iteration needs.
const STATS_EVERY: usize = 16;
/// Iterations without a 1 % improvement of the violation after which the solve is stagnant.
const STAGNATION: usize = 3000;

/// Consecutive re-open-only steps (no descent direction on the contact set) before the solve
/// stops as stagnated.
const MAX_REOPEN_ONLY: usize = 50;
/// Nodes per chunk of the grid passes (fixed, so partial sums do not depend on threads).
const CHUNK: usize = 1 << 14;

/// The Polonsky–Keer minimiser (hard wall only), by default with the stiffness preconditioner.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PolonskyKeer {
    /// Precondition the conjugate gradients with the stiffness K = G⁻¹ on the contact set
    /// (Vollebregt 2014): one more transform pair per iteration, 4–6× fewer iterations.
    pub preconditioned: bool,
}

impl PolonskyKeer {
    /// With the stiffness preconditioner (the default).
    pub const PRECONDITIONED: PolonskyKeer = PolonskyKeer {
        preconditioned: true,
    };
    /// The original method: conjugate gradients on the gap itself.
    pub const PLAIN: PolonskyKeer = PolonskyKeer {
        preconditioned: false,
    };
}

impl Default for PolonskyKeer {
    fn default() -> Self {
        PolonskyKeer::PRECONDITIONED
    }
}

/// Lanes of the vectorised grid passes: partial sums are kept per lane so that the reductions
/// vectorise instead of forming one serial chain of additions; lanes and chunks are combined in
/// a fixed order, so results do not depend on the number of threads.
const L: usize = 4;

/// Statistics of the gap d = σU − h (true units) on and off the contact set S = {P > 0}.
#[derive(Debug, Clone, Copy)]
struct GapStats {
    /// Σ_S (d − ref), Σ_S (d − ref)², |S|, with ref the previous shift.
    sum: f64,
    sum2: f64,
    count: f64,
    /// max_S d, min_S d, min off S of d.
    max_s: f64,
    min_s: f64,
    min_off: f64,
    /// Σ_S t of the last direction (to project it onto Σ_S t = 0).
    t_on: f64,
    /// Σ p (u/2 − h): the complementary energy (trace only).
    energy: f64,
    /// Whether the extremes (max_s, min_s, min_off) were taken.
    full: bool,
}

impl GapStats {
    const EMPTY: GapStats = GapStats {
        sum: 0.0,
        sum2: 0.0,
        count: 0.0,
        max_s: f64::NEG_INFINITY,
        min_s: f64::INFINITY,
        min_off: f64::INFINITY,
        t_on: 0.0,
        energy: 0.0,
        full: true,
    };

    fn merge(self, o: GapStats) -> GapStats {
        GapStats {
            sum: self.sum + o.sum,
            sum2: self.sum2 + o.sum2,
            count: self.count + o.count,
            max_s: self.max_s.max(o.max_s),
            min_s: self.min_s.min(o.min_s),
            min_off: self.min_off.min(o.min_off),
            t_on: self.t_on + o.t_on,
            energy: self.energy + o.energy,
            full: self.full && o.full,
        }
    }
}

/// Per-lane accumulators of [`GapStats`].
struct GapLanes {
    sum: [f64; L],
    sum2: [f64; L],
    count: [f64; L],
    max_s: [f64; L],
    min_s: [f64; L],
    min_off: [f64; L],
    t_on: [f64; L],
    energy: [f64; L],
}

impl GapLanes {
    fn new() -> Self {
        GapLanes {
            sum: [0.0; L],
            sum2: [0.0; L],
            count: [0.0; L],
            max_s: [f64::NEG_INFINITY; L],
            min_s: [f64::INFINITY; L],
            min_off: [f64::INFINITY; L],
            t_on: [0.0; L],
            energy: [0.0; L],
        }
    }

    /// One node with stored values U, P (true u = σU, p = σP), height h, direction t.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn node<const TRACE: bool, const WITH_T: bool, const FULL: bool>(
        &mut self,
        l: usize,
        uu: f64,
        pp: f64,
        h: f64,
        t: f64,
        sigma: f64,
        reference: f64,
    ) {
        let u = sigma * uu;
        let d = u - h;
        let on = pp > 0.0;
        let e = if on { d - reference } else { 0.0 };
        self.sum[l] += e;
        self.sum2[l] += e * e;
        self.count[l] += if on { 1.0 } else { 0.0 };
        if WITH_T {
            self.t_on[l] += if on { t } else { 0.0 };
        }
        if FULL {
            let hi = if on { d } else { f64::NEG_INFINITY };
            let lo = if on { d } else { f64::INFINITY };
            let off = if on { f64::INFINITY } else { d };
            self.max_s[l] = if hi > self.max_s[l] {
                hi
            } else {
                self.max_s[l]
            };
            self.min_s[l] = if lo < self.min_s[l] {
                lo
            } else {
                self.min_s[l]
            };
            self.min_off[l] = if off < self.min_off[l] {
                off
            } else {
                self.min_off[l]
            };
        }
        if TRACE {
            self.energy[l] += sigma * pp * (0.5 * u - h);
        }
    }

    fn total(&self, full: bool) -> GapStats {
        let mut s = GapStats::EMPTY;
        for l in 0..L {
            s = s.merge(GapStats {
                sum: self.sum[l],
                sum2: self.sum2[l],
                count: self.count[l],
                max_s: self.max_s[l],
                min_s: self.min_s[l],
                min_off: self.min_off[l],
                t_on: self.t_on[l],
                energy: self.energy[l],
                full,
            });
        }
        s
    }
}

/// Pass A over one chunk (read-only): statistics of the gap.
fn gap_pass<const TRACE: bool>(
    u: &[f64],
    p: &[f64],
    h: &[f64],
    t: &[f64],
    sigma: f64,
    reference: f64,
) -> GapStats {
    let mut acc = GapLanes::new();
    let (mut uc, mut pc) = (u.chunks_exact(L), p.chunks_exact(L));
    let (mut hc, mut tc) = (h.chunks_exact(L), t.chunks_exact(L));
    for (((u, p), h), t) in (&mut uc).zip(&mut pc).zip(&mut hc).zip(&mut tc) {
        for l in 0..L {
            acc.node::<TRACE, true, true>(l, u[l], p[l], h[l], t[l], sigma, reference);
        }
    }
    let (u, p, h, t) = (
        uc.remainder(),
        pc.remainder(),
        hc.remainder(),
        tc.remainder(),
    );
    for l in 0..u.len() {
        acc.node::<TRACE, true, true>(l, u[l], p[l], h[l], t[l], sigma, reference);
    }
    acc.total(true)
}

/// Pass B over one row: the conjugate direction (true units) t = g + β (t − m) on S, 0 off it,
/// with g = σU − h − shift and m the mean of the old t on S (so that Σ_S t = 0 and the step
/// keeps the load); returns Σ t and Σ g t.
#[allow(clippy::too_many_arguments)]
fn direction_row(
    t: &mut [f64],
    u: &[f64],
    p: &[f64],
    h: &[f64],
    sigma: f64,
    shift: f64,
    beta: f64,
    m: f64,
) -> [f64; 4] {
    let (mut st, mut sgt) = ([0.0; L], [0.0; L]);
    let node =
        |l: usize, t: &mut f64, u: f64, p: f64, h: f64, st: &mut [f64; L], sgt: &mut [f64; L]| {
            let g = sigma * u - h - shift;
            let tj = if p > 0.0 { g + beta * (*t - m) } else { 0.0 };
            *t = tj;
            st[l] += tj;
            sgt[l] += g * tj;
        };
    let mut tc = t.chunks_exact_mut(L);
    let (mut uc, mut pc, mut hc) = (u.chunks_exact(L), p.chunks_exact(L), h.chunks_exact(L));
    for (((t, u), p), h) in (&mut tc).zip(&mut uc).zip(&mut pc).zip(&mut hc) {
        for l in 0..L {
            node(l, &mut t[l], u[l], p[l], h[l], &mut st, &mut sgt);
        }
    }
    let (t, u, p, h) = (
        tc.into_remainder(),
        uc.remainder(),
        pc.remainder(),
        hc.remainder(),
    );
    for l in 0..t.len() {
        node(l, &mut t[l], u[l], p[l], h[l], &mut st, &mut sgt);
    }
    [st.iter().sum(), sgt.iter().sum(), 0.0, 0.0]
}

/// Whether a node is free to move in the preconditioned iteration: it carries pressure, or it is
/// a zero-pressure node marked (P = −0.0) by the last step as penetrating.
#[inline(always)]
fn free(p: f64) -> bool {
    p.to_bits() != 0
}

/// Pass B over one row (preconditioned): writes the gap on the free set F (the contact set and
/// the nodes marked penetrating), g = σU − h − shift on F and 0 off it, into `row` (the input
/// of the stiffness transform); returns Σ g t and Σ g for the old direction t, and |F|.
fn gradient_row(
    row: &mut [f64],
    u: &[f64],
    p: &[f64],
    h: &[f64],
    t: &[f64],
    sigma: f64,
    shift: f64,
) -> [f64; 4] {
    let (mut sgt, mut sg, mut count) = ([0.0; L], [0.0; L], [0.0; L]);
    for (k, row) in row.chunks_mut(L).enumerate() {
        for (l, out) in row.iter_mut().enumerate() {
            let j = k * L + l;
            let on = free(p[j]);
            let g = if on { sigma * u[j] - h[j] - shift } else { 0.0 };
            *out = g;
            sgt[l] += g * t[j];
            sg[l] += g;
            count[l] += if on { 1.0 } else { 0.0 };
        }
    }
    [sgt.iter().sum(), sg.iter().sum(), count.iter().sum(), 0.0]
}

/// Σ_F z over one row (F the free set, see [`free`]).
fn masked_sum(z: &[f64], p: &[f64]) -> f64 {
    let mut s = [0.0; L];
    for (k, z) in z.chunks(L).enumerate() {
        for (l, &v) in z.iter().enumerate() {
            s[l] += if free(p[k * L + l]) { v } else { 0.0 };
        }
    }
    s.iter().sum()
}

/// Pass C over one row (preconditioned): the direction t = (z − m_z) + β (t − m) on the free set
/// F, 0 off it, with z = K g the preconditioned gradient and m_z, m the means (so Σ_F t = 0);
/// returns Σ t.
fn direction_preconditioned_row(
    t: &mut [f64],
    z: &[f64],
    p: &[f64],
    mz: f64,
    beta: f64,
    m: f64,
) -> [f64; 4] {
    let mut st = [0.0; L];
    for (k, t) in t.chunks_mut(L).enumerate() {
        for (l, t) in t.iter_mut().enumerate() {
            let j = k * L + l;
            let tj = if free(p[j]) {
                (z[j] - mz) + beta * (*t - m)
            } else {
                0.0
            };
            *t = tj;
            st[l] += tj;
        }
    }
    [st.iter().sum(), 0.0, 0.0, 0.0]
}

/// Gap sums over one row at σ = 1 (see [`GapStats`]): Σ_S e, Σ_S e², |S| and Σ_S t, with
/// e = u − h − `reference`.
fn gap_sums(u: &[f64], p: &[f64], h: &[f64], t: &[f64], reference: f64) -> [f64; 4] {
    let mut acc = GapLanes::new();
    for (k, u) in u.chunks(L).enumerate() {
        for (l, &u) in u.iter().enumerate() {
            let j = k * L + l;
            acc.node::<false, true, false>(l, u, p[j], h[j], t[j], 1.0, reference);
        }
    }
    let g = acc.total(false);
    [g.sum, g.sum2, g.count, g.t_on]
}

/// Line-search sums over one row of r = G t: Σ_F r and Σ r t (t vanishes off F; F = S
/// without the preconditioner, which marks no node).
fn line_row(r: &[f64], t: &[f64], p: &[f64]) -> [f64; 4] {
    let (mut sr, mut srt) = ([0.0; L], [0.0; L]);
    let (mut rc, mut tc, mut pc) = (r.chunks_exact(L), t.chunks_exact(L), p.chunks_exact(L));
    for ((r, t), p) in (&mut rc).zip(&mut tc).zip(&mut pc) {
        for l in 0..L {
            sr[l] += if free(p[l]) { r[l] } else { 0.0 };
            srt[l] += r[l] * t[l];
        }
    }
    let (r, t, p) = (rc.remainder(), tc.remainder(), pc.remainder());
    for l in 0..r.len() {
        sr[l] += if free(p[l]) { r[l] } else { 0.0 };
        srt[l] += r[l] * t[l];
    }
    [sr.iter().sum(), srt.iter().sum(), 0.0, 0.0]
}

/// What the step does with a node that ends at zero pressure while penetrating.
#[derive(Debug, Clone, Copy)]
enum Reopen {
    /// P = −κ' g (stored units): Polonsky–Keer's re-open with the step length.
    By(f64),
    /// P = −0.0: marked free, to move with the next direction (preconditioned).
    MarkFree,
}

/// The scalars of one step pass, in stored units (true = σ × stored).
#[derive(Debug, Clone, Copy)]
struct Step {
    /// τ' = τ/σ.
    tau: f64,
    reopen: Reopen,
    sigma: f64,
    shift: f64,
}

/// Result of the step pass (pass D).
#[derive(Debug, Clone)]
struct StepStats {
    psum: f64,
    corrected: usize,
    overlap: bool,
    /// Corrected nodes (index, correction), kept only while few.
    sparse: Vec<(usize, f64)>,
    /// Gap statistics of the stepped state at the old σ (without `t_on`).
    gap: GapStats,
}

impl StepStats {
    fn merge(mut self, o: StepStats) -> StepStats {
        self.psum += o.psum;
        self.corrected += o.corrected;
        self.overlap |= o.overlap;
        self.sparse.extend(o.sparse);
        self.gap = self.gap.merge(o.gap);
        self
    }
}

/// Pass D over one chunk starting at node `offset`, in stored units (true = σ × stored):
/// P ← max(P − τ' t, 0) with τ' = τ/σ, re-opening nodes that penetrate as `step.reopen` says;
/// U ← U − τ' r; the number of nodes corrected off the line is counted and the first
/// [`DIRECT_CORRECTIONS`] are listed. Also takes the gap statistics of the new state at the same σ (pass A of the next
/// iteration, valid when nothing was corrected and the rescaling is negligible).
fn step_pass<const TRACE: bool, const FULL: bool>(
    offset: usize,
    p: &mut [f64],
    u: &mut [f64],
    t: &[f64],
    r: &[f64],
    h: &[f64],
    step: Step,
) -> StepStats {
    let mut psum = [0.0; L];
    let mut acc = GapLanes::new();
    let mut s = StepStats {
        psum: 0.0,
        corrected: 0,
        overlap: false,
        sparse: Vec::new(),
        gap: GapStats::EMPTY,
    };
    // One node: returns the correction and whether the node re-opened.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn node<const TRACE: bool, const FULL: bool>(
        l: usize,
        p: &mut f64,
        u: &mut f64,
        t: f64,
        r: f64,
        h: f64,
        step: Step,
        psum: &mut [f64; L],
        acc: &mut GapLanes,
    ) -> (f64, bool) {
        let Step {
            tau, sigma, shift, ..
        } = step;
        let g = sigma * *u - h - shift;
        let target = *p - tau * t;
        let clipped = if target > 0.0 { target } else { 0.0 };
        let reopen = clipped == 0.0 && g < 0.0;
        let new = match (reopen, step.reopen) {
            (false, _) => clipped,
            (true, Reopen::By(k)) => -k * g,
            (true, Reopen::MarkFree) => -0.0,
        };
        let un = *u - tau * r;
        *p = new;
        *u = un;
        psum[l] += new;
        acc.node::<TRACE, false, FULL>(l, un, new, h, t, step.sigma, step.shift);
        (new - target, reopen)
    }
    let base = p.len() - p.len() % L;
    let record = |i: usize, cv: f64, reopen: bool, s: &mut StepStats| {
        s.corrected += 1;
        s.overlap |= reopen;
        if s.corrected <= DIRECT_CORRECTIONS {
            s.sparse.push((offset + i, cv));
        }
    };
    let (mut pc, mut uc) = (p.chunks_exact_mut(L), u.chunks_exact_mut(L));
    let (mut tc, mut rc, mut hc) = (t.chunks_exact(L), r.chunks_exact(L), h.chunks_exact(L));
    for (b, ((((p, u), t), r), h)) in (&mut pc)
        .zip(&mut uc)
        .zip(&mut tc)
        .zip(&mut rc)
        .zip(&mut hc)
        .enumerate()
    {
        let p: &mut [f64; L] = p.try_into().expect("chunk of L");
        let u: &mut [f64; L] = u.try_into().expect("chunk of L");
        let (t, r, h): (&[f64; L], &[f64; L], &[f64; L]) = (
            t.try_into().expect("chunk of L"),
            r.try_into().expect("chunk of L"),
            h.try_into().expect("chunk of L"),
        );
        let mut cv = [0.0; L];
        let mut reopen = [false; L];
        for l in 0..L {
            (cv[l], reopen[l]) = node::<TRACE, FULL>(
                l, &mut p[l], &mut u[l], t[l], r[l], h[l], step, &mut psum, &mut acc,
            );
        }
        // Corrections are rare after the first iterations: test the block once.
        if cv.iter().any(|&x| x != 0.0) {
            for l in 0..L {
                if cv[l] != 0.0 {
                    record(b * L + l, cv[l], reopen[l], &mut s);
                }
            }
        }
    }
    let (p, u) = (pc.into_remainder(), uc.into_remainder());
    let (t, r, h) = (tc.remainder(), rc.remainder(), hc.remainder());
    for l in 0..p.len() {
        let (cv, reopen) = node::<TRACE, FULL>(
            l, &mut p[l], &mut u[l], t[l], r[l], h[l], step, &mut psum, &mut acc,
        );
        if cv != 0.0 {
            record(base + l, cv, reopen, &mut s);
        }
    }
    s.psum = psum.iter().sum();
    s.gap = acc.total(FULL);
    s
}

/// Runs `f` on fixed chunks of the grid, in parallel if asked, and returns the per-chunk results
/// in chunk order.
fn chunked<J: Send, R: Send>(
    jobs: Vec<J>,
    parallel: bool,
    f: impl Fn(J) -> R + Sync + Send,
) -> Vec<R> {
    if parallel {
        jobs.into_par_iter().map(f).collect()
    } else {
        jobs.into_iter().map(f).collect()
    }
}

impl Minimizer for PolonskyKeer {
    fn name(&self) -> &'static str {
        if self.preconditioned {
            "polonsky-keer"
        } else {
            "polonsky-keer-plain"
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
        debug_assert!(interaction.is_hard_wall());
        let (pre, name) = (self.preconditioned, self.name());
        let Model {
            heights: h,
            kernel,
            free,
            ..
        } = model;
        // The same iteration for the periodic and the free-boundary kernel (see compliance.rs).
        match (free.as_mut(), opts.trace) {
            (None, true) => relax::<true, _>(name, pre, h, kernel, pressure, opts, state),
            (None, false) => relax::<false, _>(name, pre, h, kernel, pressure, opts, state),
            (Some(f), true) => relax::<true, _>(name, pre, h, f, pressure, opts, state),
            (Some(f), false) => relax::<false, _>(name, pre, h, f, pressure, opts, state),
        }
    }
}

fn relax<const TRACE: bool, K: Compliance>(
    name: &'static str,
    preconditioned: bool,
    h: &[f64],
    kernel: &mut K,
    pressure: f64,
    opts: &SolverOptions,
    state: &mut State,
) -> Result<SolveStats, ContactError> {
    let n = h.len();
    let nf = n as f64;
    let (_, ny) = kernel.shape();
    // p and u hold the stored values P, U; the true fields are σP and σU, with σ = p̄N/ΣP
    // keeping the imposed mean without a pass over the grid.
    let State { u, p } = state;
    let parallel = kernel.parallel();

    // Start: the given pressure, clipped and rescaled; uniform if it carries no load.
    // (+0.0 for every non-positive value: −0.0 marks free nodes in the preconditioned iteration)
    p.iter_mut()
        .for_each(|v| *v = if *v > 0.0 { *v } else { 0.0 });
    let sum: f64 = p.iter().sum();
    if sum > 0.0 && sum.is_finite() {
        let s = pressure * nf / sum;
        p.iter_mut().for_each(|v| *v *= s);
    } else {
        p.iter_mut().for_each(|v| *v = pressure);
    }
    kernel.displacement(p, u);
    let mut sigma = 1.0;

    let mut t = vec![0.0; n];
    let mut r = vec![0.0; n];
    // The preconditioned gradient z = K g (preconditioned solves only).
    let mut z = if preconditioned {
        vec![0.0; n]
    } else {
        Vec::new()
    };
    let (mut conjugate, mut g_old) = (false, 1.0);
    let mut since_refresh = 0usize;
    let mut stats = SolveStats {
        method: name,
        iterations: 0,
        converged: false,
        reason: None,
        max_violation: f64::INFINITY,
        force_residual: 0.0,
        wall_s: 0.0,
        trace: Vec::new(),
    };
    let mut monitor = StopMonitor::new(STAGNATION, 1e8);
    // Consecutive re-open-only steps (no descent direction on the contact set).
    let mut reopen_only = 0usize;
    let mut shift = 0.0;
    // Gap statistics of the current state if the step pass could take them.
    let mut ready: Option<GapStats> = None;

    loop {
        let reference = shift;
        // Fused statistics without the extremes suffice while the rms gap on S (a lower bound
        // of the violation) is far above the tolerance; near it, and every STATS_EVERY
        // iterations (for the stagnation and growth checks), the violation is measured exactly.
        let partial_ok = |gs: &GapStats| {
            let norm = gs.sum2 - gs.sum * (gs.sum / gs.count);
            (norm / gs.count).sqrt() > 1e3 * opts.tol_gap
                && !stats.iterations.is_multiple_of(STATS_EVERY)
                && stats.iterations < opts.max_iter
        };
        let gs = match ready.take() {
            Some(gs) if gs.full || partial_ok(&gs) => gs,
            _ => {
                let (uu, pp, tt): (&[f64], &[f64], &[f64]) = (u, p, &t);
                let jobs: Vec<_> = uu
                    .chunks(CHUNK)
                    .zip(pp.chunks(CHUNK))
                    .zip(h.chunks(CHUNK).zip(tt.chunks(CHUNK)))
                    .collect();
                chunked(jobs, parallel, |((u, p), (h, t))| {
                    gap_pass::<TRACE>(u, p, h, t, sigma, reference)
                })
                .into_iter()
                .fold(GapStats::EMPTY, GapStats::merge)
            }
        };
        let count = gs.count;
        let mean_e = gs.sum / count;
        shift = reference + mean_e;
        // Σ_S (d − shift)², from sums taken about the previous shift (close to this one, so the
        // difference does not cancel).
        let norm = (gs.sum2 - gs.sum * mean_e).max(0.0);
        // The violation exactly as max_S |d − shift| and max_{not S} (shift − d) would give it
        // (rounding of d − shift is monotone in d); without the extremes, the rms gap on S, a lower
        // bound far above the tolerance.
        let exact = gs.full;
        let viol = if exact {
            (gs.max_s - shift)
                .max(shift - gs.min_s)
                .max(if gs.min_off.is_finite() {
                    shift - gs.min_off
                } else {
                    0.0
                })
        } else {
            (norm / count).sqrt()
        };
        stats.max_violation = viol;
        if !(shift.is_finite() && norm.is_finite() && viol.is_finite()) {
            stats.reason = Some(StopReason::NonFinite);
            stats.max_violation = f64::INFINITY;
            break;
        }
        if TRACE {
            stats.trace.push(gs.energy / nf);
        }
        if exact {
            if viol <= opts.tol_gap {
                if since_refresh == 0 {
                    stats.converged = true;
                    break;
                }
                // Accept only on an exactly recomputed displacement.
                refresh(kernel, p, u, sigma, |_, _, _| [0.0; 4]);
                sigma = 1.0;
                since_refresh = 0;
                continue;
            }
            if let Some(reason) = monitor.check(viol, stats.iterations, opts.tol_gap) {
                stats.reason = Some(reason);
                break;
            }
        }
        if stats.iterations >= opts.max_iter {
            stats.reason = Some(StopReason::IterationCap);
            break;
        }
        stats.iterations += 1;

        // Conjugate direction on the contact set, built row by row as the transform reads it;
        // r = G t, with the line-search sums taken as its rows come out. Preconditioned, the
        // gradient is first mapped by K (one more transform pair).
        let m = gs.t_on / count;
        let (st, sgt, sr, srt, free_count) = if preconditioned {
            // z = K g on the free set F (g zero off it), and δ = ⟨g, z − m_z⟩_F from Parseval.
            let (uu, pp, tt): (&[f64], &[f64], &[f64]) = (u, p, &t);
            let ([sg_t, sg, free_count, _], quadratic, [sz, _, _, _]) = kernel.apply_fused(
                true,
                &mut z,
                |i, row| {
                    let o = i * ny..(i + 1) * ny;
                    gradient_row(
                        row,
                        &uu[o.clone()],
                        &pp[o.clone()],
                        &h[o.clone()],
                        &tt[o],
                        sigma,
                        shift,
                    )
                },
                None,
                |i, _, z| [masked_sum(z, &pp[i * ny..(i + 1) * ny]), 0.0, 0.0, 0.0],
            );
            let mz = sz / free_count;
            let delta = quadratic - mz * sg;
            let beta = if conjugate && g_old > 0.0 {
                delta / g_old
            } else {
                0.0
            };
            g_old = delta;
            let zz: &[f64] = &z;
            let ([st, _, _, _], _, [sr, srt, _, _]) = kernel.apply_fused(
                false,
                &mut t,
                |i, t| {
                    let o = i * ny..(i + 1) * ny;
                    direction_preconditioned_row(t, &zz[o.clone()], &pp[o], mz, beta, m)
                },
                Some(&mut r),
                |i, t, r| line_row(r, t, &pp[i * ny..(i + 1) * ny]),
            );
            // Σ_F g t = ⟨g, z − m_z⟩ + β ⟨g, t_old − m⟩.
            (st, delta + beta * (sg_t - m * sg), sr, srt, free_count)
        } else {
            // (g_old = 0 when the gap was exactly uniform on the contact set, e.g. a single node)
            let beta = if conjugate && g_old > 0.0 {
                norm / g_old
            } else {
                0.0
            };
            g_old = norm;
            let (uu, pp): (&[f64], &[f64]) = (u, p);
            let ([st, sgt, _, _], _, [sr, srt, _, _]) = kernel.apply_fused(
                false,
                &mut t,
                |i, t| {
                    let o = i * ny..(i + 1) * ny;
                    direction_row(
                        t,
                        &uu[o.clone()],
                        &pp[o.clone()],
                        &h[o],
                        sigma,
                        shift,
                        beta,
                        m,
                    )
                },
                Some(&mut r),
                |i, t, r| line_row(r, t, &pp[i * ny..(i + 1) * ny]),
            );
            (st, sgt, sr, srt, count)
        };
        let denom = srt - sr / free_count * st;
        let tau = sgt / denom;
        // G is positive definite on zero-mean fields, so denom ≤ 0 means t ≈ 0: the gap is
        // uniform on the contact set and the violation is penetration outside it (as from a
        // warm start between two solutions). Then take a pure re-open step: the penetrating
        // nodes receive the pressure that would lift each one alone, τ = 1/G(0).
        let tau = if denom > 0.0 && tau.is_finite() {
            reopen_only = 0;
            tau
        } else if reopen_only < MAX_REOPEN_ONLY {
            reopen_only += 1;
            1.0 / kernel.point_compliance()
        } else {
            stats.reason = Some(StopReason::Stagnation);
            break;
        };

        // Step, clip, re-open penetrating nodes; U follows along the line (the corrections off
        // it are applied below).
        let step = {
            let jobs: Vec<_> = p
                .chunks_mut(CHUNK)
                .zip(u.chunks_mut(CHUNK))
                .zip(t.chunks(CHUNK).zip(r.chunks(CHUNK)).zip(h.chunks(CHUNK)))
                .enumerate()
                .collect();
            let tau_s = tau / sigma;
            // Penetrating nodes: preconditioned, marked free (the next direction moves them
            // with the rest of the free set, as in Vollebregt's bound-constrained CG); plain,
            // re-opened with p = −τ g (Polonsky–Keer).
            let step = Step {
                tau: tau_s,
                reopen: if preconditioned {
                    Reopen::MarkFree
                } else {
                    Reopen::By(tau_s)
                },
                sigma,
                shift,
            };
            // The extremes of the next gap are needed only near convergence or for the periodic
            // stagnation check (see partial_ok).
            let full = (norm / count).sqrt() <= 1e4 * opts.tol_gap
                || stats.iterations.is_multiple_of(STATS_EVERY);
            chunked(jobs, parallel, |(k, ((p, u), ((t, r), h)))| {
                if full {
                    step_pass::<TRACE, true>(k * CHUNK, p, u, t, r, h, step)
                } else {
                    step_pass::<TRACE, false>(k * CHUNK, p, u, t, r, h, step)
                }
            })
            .into_iter()
            .reduce(StepStats::merge)
            .expect("at least one chunk")
        };
        conjugate = !step.overlap && reopen_only == 0;
        let sigma_new = pressure * nf / step.psum;
        if step.corrected > DIRECT_CORRECTIONS {
            // Many nodes left the line: recompute U = G(σP) exactly (the cost of transforming the
            // correction alone), and take the next iteration's gap sums from its rows as they
            // come out (without the extremes; the next iteration measures them if it needs them).
            let (hh, tt): (&[f64], &[f64]) = (h, &t);
            let [sum, sum2, count, t_on] = refresh(kernel, p, u, sigma_new, |i, p, u| {
                let o = i * ny..(i + 1) * ny;
                gap_sums(u, p, &hh[o.clone()], &tt[o], shift)
            });
            sigma = 1.0;
            since_refresh = 0;
            if !TRACE {
                ready = Some(GapStats {
                    sum,
                    sum2,
                    count,
                    t_on,
                    full: false,
                    ..GapStats::EMPTY
                });
            }
            continue;
        }
        if step.corrected > 0 {
            kernel.add_point_displacements(&step.sparse, u);
        }
        // The step pass measured the gap at the old σ; use that if nothing was corrected and
        // σ is unchanged up to rounding (as it is while the direction keeps Σ_S t = 0): the
        // statistics are then off by ~1e-12 |u|, and they only steer the iteration — the
        // convergence decision is always taken on an exact recomputation (since_refresh == 0).
        if step.corrected == 0 && (sigma_new / sigma - 1.0).abs() <= 1e-12 {
            // Without corrections the contact set is unchanged, so Σ_S t is the st above.
            ready = Some(GapStats {
                t_on: st,
                ..step.gap
            });
        }
        sigma = sigma_new;
        since_refresh += 1;
        if since_refresh >= REFRESH {
            refresh(kernel, p, u, sigma, |_, _, _| [0.0; 4]);
            sigma = 1.0;
            since_refresh = 0;
            ready = None;
        }
    }

    // Total surface height: the zero-mean G p plus the rigid approach that closes the contact
    // set on average. Nodes carrying pressure are in contact: their gap (within the tolerance
    // of zero) is set to exactly zero, and no node is left below the substrate.
    for i in 0..n {
        p[i] = if p[i] > 0.0 { p[i] * sigma } else { 0.0 };
        u[i] = if p[i] > 0.0 {
            h[i]
        } else {
            (sigma * u[i] - shift).max(h[i])
        };
    }
    Ok(stats)
}

/// Exact recomputation: P ← σP, U ← G P (so σ becomes 1); `finish(i, p_row, u_row)` reduces
/// over each row of the new state as it comes out (summed in row order).
fn refresh<K: Compliance>(
    kernel: &mut K,
    p: &mut [f64],
    u: &mut [f64],
    sigma: f64,
    finish: impl Fn(usize, &[f64], &mut [f64]) -> crate::spectral::RowSums + Sync,
) -> crate::spectral::RowSums {
    let (_, _, sums) = kernel.apply_fused(
        false,
        p,
        |_, row| {
            row.iter_mut().for_each(|v| *v *= sigma);
            [0.0; 4]
        },
        Some(u),
        finish,
    );
    sums
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Lattice, Method, Surface};

    fn solve(n: u32, threads: usize, tol: f64) -> crate::Solution {
        let s = Surface::new(Lattice::Square, n).unwrap();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut m = Model::new(&s).unwrap();
            let opts = SolverOptions {
                tol_gap: tol,
                method: Method::PolonskyKeer,
                ..Default::default()
            };
            m.solve(Interaction::HardWall, 0.3 * s.p_fc_grid(), &opts, None)
                .unwrap()
        })
    }

    /// Chunked reductions are combined in a fixed order, so the pool size cannot change a bit
    /// (the grid is large enough for the parallel paths).
    #[test]
    fn results_are_bit_identical_for_any_thread_count() {
        let a = solve(8, 1, 1e-10);
        let b = solve(8, 2, 1e-10);
        assert!(a.stats.converged && b.stats.converged);
        assert_eq!(a.stats.iterations, b.stats.iterations);
        assert_eq!(a.pressure, b.pressure);
        assert_eq!(a.displacement, b.displacement);
    }

    /// The violation reported is the one the solution has: recomputed independently from the
    /// returned pressure with a fresh transform, against the rigid approach that is the mean gap
    /// on the contact set.
    #[test]
    fn reported_violation_is_the_true_one() {
        let sol = solve(7, 1, 1e-11);
        assert!(sol.stats.converged);
        let s = Surface::new(Lattice::Square, 7).unwrap();
        let mut kern = crate::elastic::ElasticKernel::new(&s.grid, 1.0);
        let p = sol.pressure.as_slice().unwrap();
        let mut u = vec![0.0; p.len()];
        kern.displacement(p, &mut u);
        let h = s.heights.as_slice().unwrap();
        let on: Vec<usize> = (0..p.len()).filter(|&i| p[i] > 0.0).collect();
        let shift = on.iter().map(|&i| u[i] - h[i]).sum::<f64>() / on.len() as f64;
        let mut viol = 0.0f64;
        for i in 0..p.len() {
            let g = u[i] - h[i] - shift;
            viol = viol.max(if p[i] > 0.0 { g.abs() } else { -g });
        }
        assert!(viol <= 1e-11 * 1.01, "violation {viol}");
        assert!(sol.stats.max_violation <= 1e-11);
    }

    /// The stiffness preconditioner changes the path, not the answer: both variants reach the
    /// same pressure field (to what the violation bound allows) on every model and at small,
    /// middling and near-full contact, the preconditioned one in fewer iterations (under half
    /// once the contact is not a small patch).
    #[test]
    fn preconditioned_and_plain_reach_the_same_solution() {
        for lattice in [Lattice::Square, Lattice::Triangular, Lattice::Hexagonal] {
            let s = Surface::new(lattice, 7).unwrap();
            for frac in [0.01, 0.3, 0.9] {
                let mut m = Model::new(&s).unwrap();
                let opts = SolverOptions {
                    tol_gap: 1e-11,
                    ..Default::default()
                };
                let load = frac * s.p_fc_grid();
                let mut run = |pk: PolonskyKeer| {
                    m.solve_with(&pk, Interaction::HardWall, load, &opts, None)
                        .unwrap()
                };
                let (a, b) = (run(PolonskyKeer::PRECONDITIONED), run(PolonskyKeer::PLAIN));
                let what = format!("{lattice:?} at {frac} p_fc");
                assert!(a.stats.converged && b.stats.converged, "{what}");
                assert_eq!(a.stats.method, "polonsky-keer");
                assert_eq!(b.stats.method, "polonsky-keer-plain");
                // A gap error δ moves the pressure by at most ~k_max δ (k_max = π√2·128·E*/λ
                // on the finest wave of this grid): 1e-11 h0 → ~6e-9; allow 1e-7 of the load.
                let dp = a
                    .pressure
                    .iter()
                    .zip(b.pressure.iter())
                    .map(|(x, y)| (x - y).abs())
                    .fold(0.0, f64::max);
                assert!(
                    dp <= 1e-7 * load.max(1.0),
                    "{what}: pressures differ by {dp}"
                );
                assert_eq!(a.contact_area, b.contact_area, "{what}");
                // (small contact patches need few iterations either way)
                let factor = if frac < 0.1 { 1 } else { 2 };
                assert!(
                    factor * a.stats.iterations < b.stats.iterations,
                    "{what}: {} preconditioned vs {} plain iterations",
                    a.stats.iterations,
                    b.stats.iterations
                );
            }
        }
    }
}
