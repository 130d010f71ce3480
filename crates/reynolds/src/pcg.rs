//! Preconditioned conjugate gradients with the multigrid V-cycle as preconditioner.
//!
//! The operator is symmetric positive semi-definite (constants on each flowing cluster are its
//! null space; the right-hand side is orthogonal to them), the preconditioner symmetric:
//! standard PCG applies and converges on the range. In the flux form the operator annihilates
//! constants exactly, so null-space components that the preconditioner adds to the iterate never
//! reach the residual.
//!
//! The recurrence residual is trusted only to decide when to stop: the true residual is then
//! recomputed, and if it misses the tolerance (recurrence drift) the iteration restarts from the
//! current iterate, at most [`MAX_RESTARTS`] times.

use crate::multigrid::Multigrid;
use crate::stencil::{REDUCE_BLOCK, dot};
use rayon::prelude::*;

/// Restarts after the recurrence residual claimed convergence but the true one disagreed.
const MAX_RESTARTS: usize = 3;
/// Stagnation: no improvement of the best residual by this factor ...
const STAGNATION_FACTOR: f64 = 0.5;
/// ... within this many iterations.
const STAGNATION_WINDOW: usize = 30;
/// Residual growth: the residual exceeds the best one by this factor.
const GROWTH_FACTOR: f64 = 1e8;

/// Why the iteration ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Stop {
    Converged,
    /// The true residual missed the tolerance but is at the rounding floor of the unknowns.
    RoundoffLimited,
    IterationCap,
    Stagnation,
    Growth,
    Breakdown,
}

pub(crate) struct Outcome {
    pub stop: Stop,
    pub iterations: usize,
}

/// Solves `A x = b` (`A` the finest operator of `mg`) from `x = 0`, to `‖b − A x‖ ≤ tol ‖b‖` by
/// the recurrence, with `true_residual(x)` (returning the true residual norm and its rounding
/// floor) as the final judge.
pub(crate) fn solve(
    mg: &mut Multigrid,
    b: &[f64],
    x: &mut [f64],
    tol: f64,
    max_iter: usize,
    true_residual: &dyn Fn(&[f64]) -> (f64, f64),
) -> Outcome {
    let len = b.len();
    let bnorm = dot(b, b).sqrt();
    x.fill(0.0);
    if bnorm == 0.0 {
        return Outcome {
            stop: Stop::Converged,
            iterations: 0,
        };
    }
    let target = tol * bnorm;
    let mut r = b.to_vec();
    let mut z = vec![0.0; len];
    let mut p = vec![0.0; len];
    let mut q = vec![0.0; len];
    let mut iterations = 0;
    let mut restarts = 0;
    let mut best = bnorm;
    let mut best_at = 0;
    'outer: loop {
        mg.apply(&r, &mut z);
        let mut rho = dot(&r, &z);
        p.copy_from_slice(&z);
        loop {
            if rho <= 0.0 || !rho.is_finite() {
                return Outcome {
                    stop: Stop::Breakdown,
                    iterations,
                };
            }
            if iterations >= max_iter {
                return Outcome {
                    stop: Stop::IterationCap,
                    iterations,
                };
            }
            let pq = mg.fine().apply_dot(&p, &mut q);
            if pq <= 0.0 || !pq.is_finite() {
                return Outcome {
                    stop: Stop::Breakdown,
                    iterations,
                };
            }
            let alpha = rho / pq;
            let rr = update(x, &mut r, &p, &q, alpha);
            iterations += 1;
            let rnorm = rr.sqrt();
            if rnorm < STAGNATION_FACTOR * best {
                best = rnorm;
                best_at = iterations;
            } else if rnorm < best {
                best = rnorm;
            }
            if rnorm <= target {
                let (t, floor) = true_residual(x);
                if t <= target {
                    return Outcome {
                        stop: Stop::Converged,
                        iterations,
                    };
                }
                if restarts >= MAX_RESTARTS || t <= floor {
                    return Outcome {
                        stop: if t <= floor {
                            Stop::RoundoffLimited
                        } else {
                            Stop::Stagnation
                        },
                        iterations,
                    };
                }
                restarts += 1;
                // Restart from the true residual.
                mg.fine().residual(b, x, &mut r);
                best_at = iterations;
                continue 'outer;
            }
            if rnorm > GROWTH_FACTOR * best {
                return Outcome {
                    stop: Stop::Growth,
                    iterations,
                };
            }
            if iterations - best_at > STAGNATION_WINDOW {
                let (t, floor) = true_residual(x);
                return Outcome {
                    stop: if t <= target {
                        Stop::Converged
                    } else if t <= floor {
                        Stop::RoundoffLimited
                    } else {
                        Stop::Stagnation
                    },
                    iterations,
                };
            }
            mg.apply(&r, &mut z);
            let rho_new = dot(&r, &z);
            let beta = rho_new / rho;
            rho = rho_new;
            direction(&mut p, &z, beta);
        }
    }
}

/// `x += α p`, `r −= α q`; returns `r·r` (deterministic block order).
fn update(x: &mut [f64], r: &mut [f64], p: &[f64], q: &[f64], alpha: f64) -> f64 {
    let partial: Vec<f64> = x
        .par_chunks_mut(REDUCE_BLOCK)
        .zip(r.par_chunks_mut(REDUCE_BLOCK))
        .zip(p.par_chunks(REDUCE_BLOCK).zip(q.par_chunks(REDUCE_BLOCK)))
        .map(|((x, r), (p, q))| {
            let mut s = 0.0;
            for k in 0..x.len() {
                x[k] += alpha * p[k];
                r[k] -= alpha * q[k];
                s += r[k] * r[k];
            }
            s
        })
        .collect();
    partial.iter().sum()
}

/// `p = z + β p`.
fn direction(p: &mut [f64], z: &[f64], beta: f64) {
    p.par_chunks_mut(REDUCE_BLOCK)
        .zip(z.par_chunks(REDUCE_BLOCK))
        .for_each(|(p, z)| {
            for k in 0..p.len() {
                p[k] = z[k] + beta * p[k];
            }
        });
}
