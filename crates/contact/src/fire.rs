//! FIRE (Bitzek et al. 2006, with the FIRE 2.0 half-step backtrack of Guénolé et al. 2020) on the
//! elastic surface height, mass-weighted in Fourier space (Zhou, Moseler & Müser 2019).
//!
//! The equations of motion are M ü = f with f = −∂U/∂u per unit area,
//! f = −(σ + p̄ + γ'(g)), and a modal mass m(q) = k(q) = qE*/2 (q ≠ 0), so that every elastic mode
//! has the same frequency and the step size is set by the interaction's stiffness, not by the grid.
//! The mean mode has mass `m0 = k_min`. The acceleration M⁻¹f is applied with one FFT pair.
//!
//! The hard wall is a projection: a node pushed below the substrate is put back on it and its
//! inward velocity removed; the pressure a contact node carries is whatever keeps it there. The
//! solve stops when the force residual (unbalanced pressure off contact, pull at contact) is at
//! most `tol_force`. FIRE keeps inertia only while the power f·v is positive, so from a warm start
//! it relaxes into the nearest minimum: that is how metastable branches are followed.
//!
//! Cost (session #13, issue 19: the draft's Figure 2 check grid and Figure 3 paths run FIRE,
//! where the cohesive zone is below a grid spacing). Per iteration: two transform pairs (σ = K u
//! and M⁻¹f) and three passes; on 64² the passes and libm's exponential are more than half of
//! the time (perf of the 64² FIRE paths of the adhesive bench after the first change below:
//! `relax` 35 %, `exp` 20 %, transforms 35 %). Changed, bit-identical (the same
//! arithmetic on everything the trajectory depends on):
//! - the energy and the copies of the last accepted state are only made where they are read
//!   (the `monotone` variant, a trace); the default FIRE never read them (a pass with a libm
//!   exponential per node and a sequential Kahan sum: 3.9 % of a cold draft's perf samples);
//! - the force pass leaves out the law's exponential where that cannot change a bit (`Skip`):
//!   at the wall, where γ'(0) is a constant, and, under adhesion, where γ'(g) is below a quarter
//!   of an ulp of σ + p̄.
//!
//! Tried and not kept: libm's exponential in the force pass replaced by nonlinear CG's
//! branch-free `exp_fast` (within 4 ulp, so every trajectory moves at the rounding level),
//! inlined in the pass: 25–50 % slower on the draft's 64² paths (`ADHESIVE_PATH=6
//! ADHESIVE_PATH_METHODS=fire cargo bench -p contact --bench adhesive`, Figure 2 adhesion,
//! repulsion, Figure 3 hexagonal, two runs each: 1.38–1.41, 3.07–3.27, 1.99 → 2.04–2.08,
//! 3.90–4.06, 2.92–2.99 CPU s; its 13-term Horner chain is scalar there and the pass branches
//! per node); in a separate branch-free pass into a scratch field (vectorised, two lanes
//! without AVX): 1.36–1.44, 2.87–2.92, 1.96–2.07 → 1.42–1.61, 2.75–2.82, 2.09–2.13, no gain
//! (as for nonlinear CG's gradient pass in session #12: the extra pass costs what the
//! exponential saves).

use crate::stop_monitor::StopMonitor;
use crate::{
    ContactError, Interaction, Minimizer, Model, SolveStats, SolverOptions, State, StopReason,
};

/// FIRE parameters (dimensionless: time in units of the elastic modes' period / 2π).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fire {
    /// Initial time step.
    pub dt0: f64,
    /// Largest time step.
    pub dt_max: f64,
    /// Steps with positive power before the step grows.
    pub n_min: usize,
    /// Step growth factor.
    pub f_inc: f64,
    /// Step shrink factor on a reset.
    pub f_dec: f64,
    /// Initial mixing α.
    pub alpha0: f64,
    /// α decay factor.
    pub f_alpha: f64,
    /// Undo every step that raises the potential energy beyond rounding (strict descent). FIRE
    /// is inertial: its potential energy may rise transiently while kinetic energy is converted
    /// back, so this costs iterations (about 3× at 2^8 nodes per side, more on finer grids where
    /// the last digits of the residual move the energy by less than its rounding).
    pub monotone: bool,
}

impl Default for Fire {
    fn default() -> Self {
        Fire {
            dt0: 0.1,
            dt_max: 1.0,
            n_min: 5,
            f_inc: 1.1,
            f_dec: 0.5,
            alpha0: 0.1,
            f_alpha: 0.99,
            monotone: false,
        }
    }
}

/// Iterations without a 1 % improvement of the residual after which the solve is stagnant.
const STAGNATION: usize = 20_000;

impl Minimizer for Fire {
    fn name(&self) -> &'static str {
        "fire"
    }

    fn relax(
        &self,
        model: &mut Model,
        interaction: Interaction,
        pressure: f64,
        opts: &SolverOptions,
        state: &mut State,
    ) -> Result<SolveStats, ContactError> {
        let Model {
            heights: h, kernel, ..
        } = model;
        let n = h.len();
        let State { u, p } = state;
        let m0 = kernel.k_min();
        let weights = kernel.weights(|k| if k > 0.0 { k } else { m0 });
        // The stiffest interaction raises the highest preconditioned frequency to about
        // sqrt(1 + γ''_max ⟨1/m⟩); keep dt below ~1/ω_max.
        let omega2 = 1.0 + interaction.max_curvature() * mean_inverse_mass(kernel.k_max());
        let dt_max = self.dt_max.min(1.0 / omega2.sqrt());
        let detach_gap = 20.0 * interaction.range().max(1e-3);
        let skip = Skip::new(interaction);

        for (ui, hi) in u.iter_mut().zip(h.iter()) {
            *ui = ui.max(*hi);
        }
        let mut v = vec![0.0; n];
        let mut f = vec![0.0; n];
        let mut a = vec![0.0; n];
        let mut sigma = vec![0.0; n];
        // Nodes held by the wall (at contact and pushed into it): no acceleration, no velocity.
        let mut held = vec![false; n];
        let (mut dt, mut alpha, mut positive) = (self.dt0.min(dt_max), self.alpha0, 0usize);
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
        // The last accepted state: a step that raises the energy beyond rounding is undone. Kept
        // only in the monotone variant; the energy is evaluated only where it is used (monotone,
        // or a trace): the default FIRE never reads it, and its pass (a libm exponential per node
        // and a sequential Kahan sum) and the two copies were 4 % of the draft's samples (perf,
        // session #13) for nothing.
        let (mut u_prev, mut sigma_prev) = if self.monotone {
            (u.clone(), vec![0.0; n])
        } else {
            (Vec::new(), Vec::new())
        };
        let (mut e_prev, mut slack_prev) = (f64::INFINITY, 0.0);
        let mut rejected = 0usize;

        loop {
            kernel.stress(u, &mut sigma);
            if self.monotone || opts.trace {
                let (e, slack) = energy(u, &sigma, h, interaction, pressure);
                if self.monotone && e > e_prev + slack_prev {
                    u.copy_from_slice(&u_prev);
                    sigma.copy_from_slice(&sigma_prev);
                    v.iter_mut().for_each(|x| *x = 0.0);
                    alpha = self.alpha0;
                    positive = 0;
                    rejected += 1;
                    if rejected > 2 {
                        dt *= self.f_dec;
                    }
                } else {
                    rejected = 0;
                    if self.monotone {
                        u_prev.copy_from_slice(u);
                        sigma_prev.copy_from_slice(&sigma);
                    }
                    (e_prev, slack_prev) = (e, slack);
                }
            }
            if opts.trace {
                stats.trace.push(e_prev);
            }
            let (mut res, mut power, mut contact, mut min_gap) =
                (0.0f64, 0.0, 0usize, f64::INFINITY);
            for i in 0..n {
                let g = u[i] - h[i];
                let s = sigma[i] + pressure;
                // γ'(g) without its exponential where that is exact (see `Skip`).
                let d = if g == 0.0 {
                    skip.at_wall
                } else if skip.negligible(g, s) {
                    0.0
                } else {
                    interaction.derivative(g)
                };
                let fi = -(s + d);
                if g <= 0.0 {
                    contact += 1;
                    // The wall pushes (f < 0 is held); a pull (f > 0) is unbalanced.
                    res = res.max(fi);
                    held[i] = fi <= 0.0;
                    f[i] = fi.max(0.0);
                } else {
                    res = res.max(fi.abs());
                    held[i] = false;
                    f[i] = fi;
                    min_gap = min_gap.min(g);
                }
                power += f[i] * v[i];
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

            if power > 0.0 {
                positive += 1;
                if positive > self.n_min {
                    dt = (dt * self.f_inc).min(dt_max);
                    alpha *= self.f_alpha;
                }
            } else {
                positive = 0;
                dt *= self.f_dec;
                alpha = self.alpha0;
                v.iter_mut().for_each(|x| *x = 0.0);
            }
            kernel.precondition(&f, &weights, &mut a);
            // Restrict the preconditioned direction to the free nodes. Since f vanishes on the held
            // set, f·a = f·M⁻¹f > 0 is unchanged: still a descent direction, and the long-range
            // preconditioner no longer drives held nodes into the wall.
            let (mut vv, mut aa) = (0.0, 0.0);
            for i in 0..n {
                if held[i] {
                    a[i] = 0.0;
                    v[i] = 0.0;
                }
                v[i] += dt * a[i];
                vv += v[i] * v[i];
                aa += a[i] * a[i];
            }
            let mix = if aa > 0.0 {
                alpha * (vv / aa).sqrt()
            } else {
                0.0
            };
            for i in 0..n {
                v[i] = (1.0 - alpha) * v[i] + mix * a[i];
                u[i] += dt * v[i];
                if u[i] < h[i] {
                    u[i] = h[i];
                    v[i] = 0.0;
                }
            }
        }
        for i in 0..n {
            p[i] = sigma[i] + pressure;
        }
        Ok(stats)
    }
}

/// Where the force pass can leave out the law's exponential and still produce the same bits
/// (session #13: libm's exponential was 20 % of the samples of the draft's 64² FIRE paths).
///
/// - At the wall (g = 0, every contact node: the projection puts u on h exactly) γ'(g) is the
///   constant γ'(0), computed once by the same [`Interaction::derivative`].
/// - Adhesion far from the wall: with s = σ + p̄ (normal, 2^e ≤ |s| < 2^(e+1)), s + γ'(g)
///   rounds to s when γ'(g) < ulp(s)/2 = 2^(e−53). γ'(g) = (γ0/ρ) e^(−g/ρ) ≤ 2^(e−55) where
///   g log2(e)/ρ ≥ log2(γ0/ρ) + 55 − e; the computed γ'(g) exceeds the exact one by a few ulp
///   at most, far inside the factor 4 of margin, so the sum is s either way.
struct Skip {
    /// γ'(0).
    at_wall: f64,
    /// log2(e)/ρ and log2(γ0/ρ) + 55 for adhesion of positive strength; None otherwise.
    far: Option<(f64, f64)>,
}

impl Skip {
    fn new(interaction: Interaction) -> Self {
        let far = match interaction {
            Interaction::Adhesion { gamma0, rho } if gamma0 > 0.0 => {
                Some((std::f64::consts::LOG2_E / rho, (gamma0 / rho).log2() + 55.0))
            }
            _ => None,
        };
        Skip {
            at_wall: interaction.derivative(0.0),
            far,
        }
    }

    /// True where adding γ'(g) to s cannot change s (see above); false for subnormal or zero s.
    #[inline(always)]
    fn negligible(&self, g: f64, s: f64) -> bool {
        match self.far {
            Some((k, c)) => {
                let biased = ((s.to_bits() >> 52) & 0x7ff) as i64;
                biased > 0 && g * k >= c - (biased - 1023) as f64
            }
            None => false,
        }
    }
}

/// Energy per area of a state and its rounding slack: elastic ½⟨(u − ū)σ⟩ plus interaction
/// ⟨γ(g)⟩ plus load p̄ū. The slack (64 ulp of the sum of absolute contributions) is how much a step may
/// raise the energy and still count as not raising it.
pub(crate) fn energy(
    u: &[f64],
    sigma: &[f64],
    h: &[f64],
    interaction: Interaction,
    pressure: f64,
) -> (f64, f64) {
    let n = u.len() as f64;
    let mean_u = u.iter().sum::<f64>() / n;
    // Compensated (Kahan) summation: the error of the mean stays at a few ulp of the mean
    // absolute term, independent of the number of nodes, so a fixed slack is meaningful.
    let (mut e, mut c, mut abs) = (0.0f64, 0.0f64, 0.0f64);
    for i in 0..u.len() {
        let el = 0.5 * (u[i] - mean_u) * sigma[i];
        let it = interaction.energy((u[i] - h[i]).max(0.0));
        let y = el + it - c;
        let t = e + y;
        c = (t - e) - y;
        e = t;
        abs += el.abs() + it.abs();
    }
    let load = pressure * mean_u;
    (e / n + load, 64.0 * f64::EPSILON * (abs / n + load.abs()))
}

/// ⟨1/k(q)⟩ over the Brillouin zone of a grid whose largest stiffness is `k_max`: for a square
/// zone of half-width Q, ⟨1/|q|⟩ = 2 asinh(1)/Q, and k = qE*/2 with k_max = Q√2 E*/2.
fn mean_inverse_mass(k_max: f64) -> f64 {
    let q = k_max * 2.0 / 2f64.sqrt();
    2.0 * 2.0 * 1f64.asinh() / q
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Where `Skip` leaves the law out, the force is bit for bit what the full evaluation gives;
    /// and it does leave it out somewhere (at the wall, and far out under adhesion).
    #[test]
    fn skipped_derivatives_do_not_change_the_force() {
        let laws = [
            Interaction::Adhesion {
                gamma0: 0.2,
                rho: 0.04,
            },
            Interaction::Adhesion {
                gamma0: 20.0,
                rho: 0.04,
            },
            Interaction::Repulsion {
                gamma_r: 0.2,
                rho: 0.04,
            },
            Interaction::HardWall,
        ];
        let mut far = 0usize;
        for law in laws {
            let skip = Skip::new(law);
            assert_eq!(skip.at_wall.to_bits(), law.derivative(0.0).to_bits());
            for k in 0..4000 {
                // gaps from 0 to 8 h0 (200 ranges), stresses over 30 decades and both signs
                let g = k as f64 * 2e-3 + 1e-7 * (k % 13) as f64;
                for e in -20..10 {
                    for s in [
                        1.37 * 2f64.powi(e),
                        -0.91 * 2f64.powi(e),
                        2f64.powi(e),
                        -2f64.powi(e) * (1.0 - f64::EPSILON),
                    ] {
                        if skip.negligible(g, s) {
                            far += 1;
                            assert_eq!(
                                (s + law.derivative(g)).to_bits(),
                                s.to_bits(),
                                "{law:?} g = {g} s = {s}"
                            );
                        }
                    }
                }
            }
            assert!(!skip.negligible(5.0, 0.0) && !skip.negligible(5.0, -0.0));
            assert!(!skip.negligible(5.0, f64::MIN_POSITIVE / 2.0));
        }
        assert!(far > 100_000, "only {far} cases skipped");
    }
}
