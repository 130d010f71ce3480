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
                let fi = -(sigma[i] + pressure + interaction.derivative(g));
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
