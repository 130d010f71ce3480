//! The grid passes of both Polonsky–Keer variants: gap statistics, line-search sums, the step
//! (clip, re-open, update the displacement along the line) and the exact recomputation. Each
//! pass runs over fixed chunks (or the transforms' rows) with per-lane partial sums combined in a
//! fixed order, so results do not depend on the number of threads.

use super::{CHUNK, DIRECT_CORRECTIONS};
use crate::compliance::Compliance;
use rayon::prelude::*;

/// Lanes of the vectorised grid passes: partial sums are kept per lane so that the reductions
/// vectorise instead of forming one serial chain of additions; lanes and chunks are combined in
/// a fixed order, so results do not depend on the number of threads.
pub(super) const L: usize = 4;

/// Statistics of the gap d = σU − h (true units) on and off the contact set S = {P > 0}.
#[derive(Debug, Clone, Copy)]
pub(super) struct GapStats {
    /// Σ_S (d − ref), Σ_S (d − ref)², |S|, with ref the previous shift.
    pub(super) sum: f64,
    pub(super) sum2: f64,
    pub(super) count: f64,
    /// max_S d, min_S d, min off S of d.
    pub(super) max_s: f64,
    pub(super) min_s: f64,
    pub(super) min_off: f64,
    /// Σ_S t of the last direction (to project it onto Σ_S t = 0).
    pub(super) t_on: f64,
    /// Σ p (u/2 − h): the complementary energy (trace only).
    pub(super) energy: f64,
    /// Whether the extremes (max_s, min_s, min_off) were taken.
    pub(super) full: bool,
}

impl GapStats {
    pub(super) const EMPTY: GapStats = GapStats {
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

    pub(super) fn merge(self, o: GapStats) -> GapStats {
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
pub(super) struct GapLanes {
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
pub(super) fn gap_pass<const TRACE: bool>(
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

/// Whether a node is free to move in the preconditioned iteration: it carries pressure, or it is
/// a zero-pressure node marked (P = −0.0) by the last step as penetrating.
#[inline(always)]
pub(super) fn free(p: f64) -> bool {
    p.to_bits() != 0
}

/// Gap sums over one row at σ = 1 (see [`GapStats`]): Σ_S e, Σ_S e², |S| and Σ_S t, with
/// e = u − h − `reference`.
pub(super) fn gap_sums(u: &[f64], p: &[f64], h: &[f64], t: &[f64], reference: f64) -> [f64; 4] {
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
pub(super) fn line_row(r: &[f64], t: &[f64], p: &[f64]) -> [f64; 4] {
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
pub(super) enum Reopen {
    /// P = −κ' g (stored units): Polonsky–Keer's re-open with the step length.
    By(f64),
    /// P = −0.0: marked free, to move with the next direction (preconditioned).
    MarkFree,
}

/// The scalars of one step pass, in stored units (true = σ × stored).
#[derive(Debug, Clone, Copy)]
pub(super) struct Step {
    /// τ' = τ/σ.
    pub(super) tau: f64,
    pub(super) reopen: Reopen,
    pub(super) sigma: f64,
    pub(super) shift: f64,
}

/// Result of the step pass (pass D).
#[derive(Debug, Clone)]
pub(super) struct StepStats {
    pub(super) psum: f64,
    pub(super) corrected: usize,
    pub(super) overlap: bool,
    /// Corrected nodes (index, correction), kept only while few.
    pub(super) sparse: Vec<(usize, f64)>,
    /// Gap statistics of the stepped state at the old σ (without `t_on`).
    pub(super) gap: GapStats,
}

impl StepStats {
    pub(super) fn merge(mut self, o: StepStats) -> StepStats {
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
pub(super) fn step_pass<const TRACE: bool, const FULL: bool>(
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
pub(super) fn chunked<J: Send, R: Send>(
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

/// Exact recomputation: P ← σP, U ← G P (so σ becomes 1); `finish(i, p_row, u_row)` reduces
/// over each row of the new state as it comes out (summed in row order).
pub(super) fn refresh<K: Compliance>(
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

/// Pass A over the whole grid: the gap statistics of the state (P, U) at scale σ, about
/// `reference` (the previous shift).
pub(super) fn measure_gap<const TRACE: bool>(
    u: &[f64],
    p: &[f64],
    h: &[f64],
    t: &[f64],
    sigma: f64,
    reference: f64,
    parallel: bool,
) -> GapStats {
    let jobs: Vec<_> = u
        .chunks(CHUNK)
        .zip(p.chunks(CHUNK))
        .zip(h.chunks(CHUNK).zip(t.chunks(CHUNK)))
        .collect();
    chunked(jobs, parallel, |((u, p), (h, t))| {
        gap_pass::<TRACE>(u, p, h, t, sigma, reference)
    })
    .into_iter()
    .fold(GapStats::EMPTY, GapStats::merge)
}

/// Pass D over the whole grid (see [`step_pass`]); `full`: also take the extremes of the new gap.
#[allow(clippy::too_many_arguments)]
pub(super) fn take_step<const TRACE: bool>(
    p: &mut [f64],
    u: &mut [f64],
    t: &[f64],
    r: &[f64],
    h: &[f64],
    step: Step,
    full: bool,
    parallel: bool,
) -> StepStats {
    let jobs: Vec<_> = p
        .chunks_mut(CHUNK)
        .zip(u.chunks_mut(CHUNK))
        .zip(t.chunks(CHUNK).zip(r.chunks(CHUNK)).zip(h.chunks(CHUNK)))
        .enumerate()
        .collect();
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
}
