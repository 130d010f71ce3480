//! Constrained conjugate gradients in the contact pressure (Polonsky & Keer, Wear 231, 206, 1999)
//! for the hard-wall problem under force control.
//!
//! Minimises the complementary energy Π(p) = ½⟨p, G p⟩ − ⟨p, h⟩ over p ≥ 0 with mean(p) = p̄,
//! where G is the compliance (1/k(q) for q ≠ 0). Each iteration: gap g = Gp − h shifted so that
//! its mean on the contact set S = {p > 0} vanishes (this shift is the body's rigid approach);
//! conjugate direction t on S; exact line search τ = ⟨g, t⟩/⟨t, G t − mean_S(G t)⟩; step, clip to
//! p ≥ 0, re-open nodes that penetrate (p = −τ g there, restarting the conjugacy), rescale to the
//! imposed mean.
//!
//! Cost: one FFT pair for G t per iteration. The displacement G p is updated from G t and the
//! rescaling without another transform; only when clipping or re-opening changed p off the line
//! does the correction need a second pair, and the displacement is recomputed from scratch every
//! [`REFRESH`] iterations and before convergence is accepted, so rounding cannot accumulate.
//!
//! Stops when the constraint violation (max |g| on S, max penetration off S) is at most
//! `tol_gap`. Force balance is exact by construction (u = G p, mean p = p̄, p ≥ 0).

use crate::{
    ContactError, Interaction, Minimizer, Model, SolveStats, SolverOptions, State, StopReason,
};

/// Iterations between exact recomputations of G p.
pub const REFRESH: usize = 50;
/// Iterations without a 1 % improvement of the violation after which the solve is stagnant.
const STAGNATION: usize = 3000;

/// The Polonsky–Keer minimiser (hard wall only).
#[derive(Debug, Clone, Copy, Default)]
pub struct PolonskyKeer;

impl Minimizer for PolonskyKeer {
    fn name(&self) -> &'static str {
        "polonsky-keer"
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
        let Model {
            heights: h, kernel, ..
        } = model;
        let n = h.len();
        let nf = n as f64;
        let State { u, p } = state;

        // Start: the given pressure, clipped and rescaled; uniform if it carries no load.
        p.iter_mut().for_each(|v| *v = v.max(0.0));
        let sum: f64 = p.iter().sum();
        if sum > 0.0 && sum.is_finite() {
            let s = pressure * nf / sum;
            p.iter_mut().for_each(|v| *v *= s);
        } else {
            p.iter_mut().for_each(|v| *v = pressure);
        }
        kernel.displacement(p, u);

        let mut g = vec![0.0; n];
        let mut t = vec![0.0; n];
        let mut r = vec![0.0; n];
        let (mut conjugate, mut g_old) = (false, 1.0);
        let mut since_refresh = 0usize;
        let mut stats = SolveStats {
            method: self.name(),
            iterations: 0,
            converged: false,
            reason: None,
            max_violation: f64::INFINITY,
            force_residual: 0.0,
            wall_s: 0.0,
            trace: Vec::new(),
        };
        let (mut best, mut best_iter) = (f64::INFINITY, 0usize);
        let mut shift;

        loop {
            // Gap up to the rigid shift, and its mean on the contact set.
            let (mut sum_g, mut count) = (0.0, 0usize);
            let mut pi_energy = 0.0;
            for i in 0..n {
                let gi = u[i] - h[i];
                g[i] = gi;
                if p[i] > 0.0 {
                    sum_g += gi;
                    count += 1;
                }
                if opts.trace {
                    pi_energy += p[i] * (0.5 * u[i] - h[i]);
                }
            }
            shift = sum_g / count as f64;
            let (mut norm, mut viol) = (0.0, 0.0f64);
            for i in 0..n {
                let gi = g[i] - shift;
                g[i] = gi;
                if p[i] > 0.0 {
                    norm += gi * gi;
                    viol = viol.max(gi.abs());
                } else {
                    viol = viol.max(-gi);
                }
            }
            stats.max_violation = viol;
            if opts.trace {
                stats.trace.push(pi_energy / nf);
            }
            if viol <= opts.tol_gap {
                if since_refresh == 0 {
                    stats.converged = true;
                    break;
                }
                // Accept only on an exactly recomputed displacement.
                kernel.displacement(p, u);
                since_refresh = 0;
                continue;
            }
            if viol < 0.99 * best {
                best = viol;
                best_iter = stats.iterations;
            } else if stats.iterations - best_iter > STAGNATION {
                stats.reason = Some(StopReason::Stagnation);
                break;
            }
            if viol > 1e8 * best.max(opts.tol_gap) {
                stats.reason = Some(StopReason::ResidualGrowth);
                break;
            }
            if stats.iterations >= opts.max_iter {
                stats.reason = Some(StopReason::IterationCap);
                break;
            }
            stats.iterations += 1;

            // Conjugate direction on the contact set.
            let beta = if conjugate { norm / g_old } else { 0.0 };
            g_old = norm;
            for i in 0..n {
                t[i] = if p[i] > 0.0 { g[i] + beta * t[i] } else { 0.0 };
            }
            kernel.displacement(&t, &mut r);
            let (mut sr, mut st, mut sgt, mut srt) = (0.0, 0.0, 0.0, 0.0);
            for i in 0..n {
                if p[i] > 0.0 {
                    sr += r[i];
                    st += t[i];
                    sgt += g[i] * t[i];
                    srt += r[i] * t[i];
                }
            }
            let denom = srt - sr / count as f64 * st;
            let tau = sgt / denom;
            if !(denom > 0.0 && tau.is_finite()) {
                stats.reason = Some(StopReason::Stagnation);
                break;
            }

            // Step, clip, re-open penetrating nodes; g now holds the correction off the line.
            let (mut psum, mut corrected, mut overlap) = (0.0, 0usize, false);
            for i in 0..n {
                let target = p[i] - tau * t[i];
                let mut new = target.max(0.0);
                if new == 0.0 && g[i] < 0.0 {
                    new = -tau * g[i];
                    overlap = true;
                }
                let c = new - target;
                if c != 0.0 {
                    corrected += 1;
                }
                g[i] = c;
                p[i] = new;
                psum += new;
            }
            conjugate = !overlap;
            let s = pressure * nf / psum;
            if corrected > 0 {
                kernel.displacement_in_place(&mut g);
                for i in 0..n {
                    u[i] = s * (u[i] - tau * r[i] + g[i]);
                    p[i] *= s;
                }
            } else {
                for i in 0..n {
                    u[i] = s * (u[i] - tau * r[i]);
                    p[i] *= s;
                }
            }
            since_refresh += 1;
            if since_refresh >= REFRESH {
                kernel.displacement(p, u);
                since_refresh = 0;
            }
        }

        // Total surface height: the zero-mean G p plus the rigid approach that closes the contact
        // set on average. Nodes carrying pressure are in contact: their gap (within the tolerance
        // of zero) is set to exactly zero, and no node is left below the substrate.
        for i in 0..n {
            u[i] = if p[i] > 0.0 {
                h[i]
            } else {
                (u[i] - shift).max(h[i])
            };
        }
        Ok(stats)
    }
}
