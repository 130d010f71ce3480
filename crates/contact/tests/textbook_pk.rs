//! The library's unpreconditioned Polonsky–Keer iteration (`Method::PolonskyKeerPlain`) against a
//! plain textbook version written here from the paper (Polonsky & Keer, Wear 231, 206, 1999,
//! section 3), compared iterate by iterate on small grids.
//!
//! The textbook version keeps every field in true units, recomputes the displacement u = G p
//! from scratch each iteration by a direct real-space convolution with the periodic Green's
//! function (built here by a direct DFT of 1/k(q), k(q) = E*|q|/2, E* = 1), and follows the
//! paper's steps literally:
//! 1. gap g = u − h on the contact set S = {p > 0}, shifted by its mean there (the rigid
//!    approach);
//! 2. G = Σ_S g²; direction t = g + δ (G/G_old) t_old on S, 0 off it (δ = 0 after a step that
//!    re-opened nodes, and in the first iteration);
//! 3. r = G t with its mean on S removed; step length τ = Σ_S g t / Σ_S r t;
//! 4. p ← p − τ t on S, negative pressures set to 0;
//! 5. nodes with p = 0 and g < 0 (penetrating) get p = −τ g, and δ = 0 if there are any;
//! 6. p ← p p̄N/Σp (the load constraint).
//!
//! The library differs from this in one respect the paper does not fix: before conjugating, it
//! removes the old direction's mean on the current contact set (t = g + β (t_old − m)), so that
//! Σ_S t = 0 and the step keeps the load up to rounding. When nodes were clipped in the last step
//! (S shrank) the paper's t_old no longer sums to zero on S. [`Textbook::project`] switches that
//! one difference on; the literal paper variant is compared too, up to the first clip.

use contact::{Interaction, Lattice, Method, Model, Solution, SolverOptions, Surface};
use std::f64::consts::PI;

/// Direct periodic convolution with the zero-mean Green's function of the half-space.
struct Green {
    nx: usize,
    ny: usize,
    /// g[a·ny + b]: displacement at offset (a, b) from a unit pressure on one node.
    g: Vec<f64>,
}

impl Green {
    fn new(nx: usize, ny: usize, lx: f64, ly: f64) -> Green {
        let n = (nx * ny) as f64;
        let wave = |k: usize, m: usize| {
            if k <= m / 2 {
                k as f64
            } else {
                k as f64 - m as f64
            }
        };
        let mut g = vec![0.0; nx * ny];
        for a in 0..nx {
            for b in 0..ny {
                let mut s = 0.0;
                for ka in 0..nx {
                    for kb in 0..ny {
                        let (qa, qb) = (wave(ka, nx), wave(kb, ny));
                        let q = (2.0 * PI * qa / lx).hypot(2.0 * PI * qb / ly);
                        if q > 0.0 {
                            let phase = 2.0
                                * PI
                                * (ka as f64 * a as f64 / nx as f64
                                    + kb as f64 * b as f64 / ny as f64);
                            s += phase.cos() / (0.5 * q);
                        }
                    }
                }
                g[a * ny + b] = s / n;
            }
        }
        Green { nx, ny, g }
    }

    /// u = G p.
    fn apply(&self, p: &[f64]) -> Vec<f64> {
        let (nx, ny) = (self.nx, self.ny);
        let mut u = vec![0.0; nx * ny];
        for i in 0..nx {
            for j in 0..ny {
                let mut s = 0.0;
                for k in 0..nx {
                    for l in 0..ny {
                        let (a, b) = ((i + nx - k) % nx, (j + ny - l) % ny);
                        s += self.g[a * ny + b] * p[k * ny + l];
                    }
                }
                u[i * ny + j] = s;
            }
        }
        u
    }
}

/// The textbook iteration's state.
struct Textbook<'a> {
    green: &'a Green,
    h: &'a [f64],
    mean_pressure: f64,
    /// Remove the old direction's mean on S before conjugating (the library's variant).
    project: bool,
    p: Vec<f64>,
    t: Vec<f64>,
    g_old: f64,
    conjugate: bool,
}

/// What one textbook iteration did.
struct Iterate {
    /// Nodes set to zero pressure by the clip.
    clipped: usize,
    /// Nodes re-opened (penetrating, given p = −τ g).
    reopened: usize,
}

impl<'a> Textbook<'a> {
    /// Starts from `start` rescaled to the load (as the library treats a warm start), or from
    /// the uniform pressure.
    fn new(
        green: &'a Green,
        h: &'a [f64],
        mean_pressure: f64,
        project: bool,
        start: Option<&[f64]>,
    ) -> Self {
        let n = h.len();
        let p = match start {
            Some(p0) => {
                let scale = mean_pressure * n as f64 / p0.iter().sum::<f64>();
                p0.iter().map(|&v| v * scale).collect()
            }
            None => vec![mean_pressure; n],
        };
        Textbook {
            green,
            h,
            mean_pressure,
            project,
            p,
            t: vec![0.0; n],
            g_old: 1.0,
            conjugate: false,
        }
    }

    fn iterate(&mut self) -> Iterate {
        let n = self.h.len();
        let u = self.green.apply(&self.p);
        let on: Vec<bool> = self.p.iter().map(|&v| v > 0.0).collect();
        let count = on.iter().filter(|&&s| s).count() as f64;
        // 1. gap, shifted to zero mean on S
        let mean_s = (0..n)
            .filter(|&i| on[i])
            .map(|i| u[i] - self.h[i])
            .sum::<f64>()
            / count;
        let g: Vec<f64> = (0..n).map(|i| u[i] - self.h[i] - mean_s).collect();
        // 2. conjugate direction
        let norm: f64 = (0..n).filter(|&i| on[i]).map(|i| g[i] * g[i]).sum();
        let beta = if self.conjugate && self.g_old > 0.0 {
            norm / self.g_old
        } else {
            0.0
        };
        self.g_old = norm;
        let m = if self.project {
            (0..n).filter(|&i| on[i]).map(|i| self.t[i]).sum::<f64>() / count
        } else {
            0.0
        };
        for i in 0..n {
            self.t[i] = if on[i] {
                g[i] + beta * (self.t[i] - m)
            } else {
                0.0
            };
        }
        // 3. r = G t minus its mean on S; exact step length
        let r = self.green.apply(&self.t);
        let r_mean = (0..n).filter(|&i| on[i]).map(|i| r[i]).sum::<f64>() / count;
        let (mut num, mut den) = (0.0, 0.0);
        for i in (0..n).filter(|&i| on[i]) {
            num += g[i] * self.t[i];
            den += (r[i] - r_mean) * self.t[i];
        }
        let tau = num / den;
        // 4. step on S and clip
        let mut clipped = 0;
        for i in (0..n).filter(|&i| on[i]) {
            self.p[i] -= tau * self.t[i];
            if self.p[i] < 0.0 {
                self.p[i] = 0.0;
                clipped += 1;
            }
        }
        // 5. re-open penetrating nodes
        let mut reopened = 0;
        for i in 0..n {
            if self.p[i] == 0.0 && g[i] < 0.0 {
                self.p[i] = -tau * g[i];
                reopened += 1;
            }
        }
        self.conjugate = reopened == 0;
        // 6. the load
        let total: f64 = self.p.iter().sum();
        let scale = self.mean_pressure * n as f64 / total;
        self.p.iter_mut().for_each(|v| *v *= scale);
        Iterate { clipped, reopened }
    }
}

/// The library's plain iteration stopped after exactly `k` iterations (a violation bound it
/// cannot reach): its pressure field.
fn library_after(model: &mut Model, load: f64, k: usize, warm: Option<&Solution>) -> Vec<f64> {
    let opts = SolverOptions {
        tol_gap: 1e-15,
        max_iter: k,
        method: Method::PolonskyKeerPlain,
        ..Default::default()
    };
    let sol = model
        .solve(Interaction::HardWall, load, &opts, warm)
        .unwrap();
    assert_eq!(sol.stats.iterations, k);
    sol.pressure.iter().copied().collect()
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Runs both for `iterations` at `frac` p_fc, from the uniform pressure or (`from`) from the
/// library's converged solution at that load, and returns the pressure difference per iterate
/// (relative to the mean pressure), the iterations that clipped, and those that re-opened.
fn compare(
    lattice: Lattice,
    n: u32,
    (frac, from): (f64, Option<f64>),
    iterations: usize,
    project: bool,
) -> (Vec<f64>, Vec<usize>, Vec<usize>) {
    let s = Surface::new(lattice, n).unwrap();
    let grid = s.grid;
    let green = Green::new(grid.nx, grid.ny, grid.lx, grid.ly);
    let h: Vec<f64> = s.heights.iter().copied().collect();
    let load = frac * s.p_fc_grid();
    let mut model = Model::new(&s).unwrap();
    let warm = from.map(|f| {
        let opts = SolverOptions {
            tol_gap: 1e-12,
            method: Method::PolonskyKeerPlain,
            ..Default::default()
        };
        let load = f * s.p_fc_grid();
        model
            .solve(Interaction::HardWall, load, &opts, None)
            .unwrap()
    });
    let start: Option<Vec<f64>> = warm.as_ref().map(|w| w.pressure.iter().copied().collect());
    let mut tb = Textbook::new(&green, &h, load, project, start.as_deref());
    let (mut diffs, mut clips, mut reopens) = (Vec::new(), Vec::new(), Vec::new());
    for k in 1..=iterations {
        let it = tb.iterate();
        if it.clipped > 0 {
            clips.push(k);
        }
        if it.reopened > 0 {
            reopens.push(k);
        }
        let lib = library_after(&mut model, load, k, warm.as_ref());
        diffs.push(max_diff(&lib, &tb.p) / load);
    }
    (diffs, clips, reopens)
}

/// Rounding: the library applies G by FFT and updates u along the line (recomputing it every
/// 50 iterations), the textbook sums directly and recomputes; the first iterates agree to
/// ~1e-14 p̄. Conjugate gradients amplify such differences (loss of conjugacy): measured here,
/// up to ×2.5 per iteration on the hexagonal 32² warm start, to ~2e-8 p̄ by iteration 17, where
/// it levels off (the others stay below 1e-10). 1e-7 p̄ allows that and still catches any change
/// of the rule: the one difference between the library and the literal paper (see
/// `literal_paper_variant_agrees_until_a_clip`) moves the next iterate by 5e-2 p̄ at these loads.
const TOL: f64 = 1e-7;

#[test]
fn library_plain_pk_follows_the_textbook_iterate_by_iterate() {
    let mut reopened = false;
    // cold starts (the contact set shrinks) and warm starts from a smaller load (it grows:
    // penetrating nodes are re-opened)
    for (lattice, n, frac) in [
        (Lattice::Square, 4, (0.3, None)),
        (Lattice::Triangular, 4, (0.1, None)),
        (Lattice::Square, 5, (0.05, None)),
        (Lattice::Square, 4, (0.3, Some(0.1))),
        (Lattice::Hexagonal, 5, (0.2, Some(0.05))),
    ] {
        let (diffs, clips, reopens) = compare(lattice, n, frac, 25, true);
        reopened |= !reopens.is_empty();
        for (k, d) in diffs.iter().enumerate() {
            assert!(
                *d <= TOL,
                "{lattice:?} 2^{n} at {frac:?} p_fc, iteration {}: |Δp|/p̄ = {d:.3e} (clips at {clips:?}, re-opens at {reopens:?})",
                k + 1
            );
        }
        // the comparison exercised the set changes, not only CG on a fixed set
        assert!(
            !clips.is_empty(),
            "{lattice:?} 2^{n}: no clip in 25 iterations"
        );
    }
    assert!(reopened, "no iteration re-opened a node");
}

/// The paper's literal iteration (no projection of the old direction) agrees with the library
/// until the first step that clips a node without re-opening any (after which the paper's t_old
/// has a non-zero sum on the shrunken S and the two directions differ).
#[test]
fn literal_paper_variant_agrees_until_a_clip() {
    let (diffs, clips, _) = compare(Lattice::Square, 4, (0.3, None), 25, false);
    let first = clips.first().copied().unwrap_or(diffs.len());
    // iterations 1..=first are equal (the clip takes effect in the next direction)
    for (k, d) in diffs.iter().enumerate().take(first) {
        assert!(*d <= TOL, "iteration {}: |Δp|/p̄ = {d:.3e}", k + 1);
    }
    // and after it they differ: the projection is a real difference, not rounding
    assert!(diffs[first] > 1e4 * TOL, "{diffs:?}");
}

/// Run to convergence, the textbook iteration reaches the library's converged solution (same
/// contact set, pressures within what the violation bound allows).
#[test]
fn textbook_converges_to_the_library_solution() {
    let s = Surface::new(Lattice::Square, 4).unwrap();
    let grid = s.grid;
    let green = Green::new(grid.nx, grid.ny, grid.lx, grid.ly);
    let h: Vec<f64> = s.heights.iter().copied().collect();
    let load = 0.3 * s.p_fc_grid();
    let mut tb = Textbook::new(&green, &h, load, false, None);
    for _ in 0..400 {
        tb.iterate();
    }
    let mut model = Model::new(&s).unwrap();
    let opts = SolverOptions {
        tol_gap: 1e-12,
        method: Method::PolonskyKeerPlain,
        ..Default::default()
    };
    let sol = model
        .solve(Interaction::HardWall, load, &opts, None)
        .unwrap();
    assert!(sol.stats.converged);
    let lib: Vec<f64> = sol.pressure.iter().copied().collect();
    let set = |p: &[f64]| p.iter().map(|&v| v > 0.0).collect::<Vec<_>>();
    assert_eq!(set(&lib), set(&tb.p));
    // a gap error δ moves the pressure by at most ~k_max δ (k_max = π√2·16 on this grid):
    // 1e-12 → ~1e-10; 1e-8 of the load leaves room for the textbook's own residual
    let d = max_diff(&lib, &tb.p) / load;
    assert!(d <= 1e-8, "|Δp|/p̄ = {d:.3e}");
}
