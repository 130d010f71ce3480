//! Local-refinement benchmark: `cargo bench -p contact --bench refinement`.
//!
//! Problem: the square model just below percolation (mean pressure `REFINE_FRAC` p_fc of the
//! base grid, default 0.21; the saddles are open), hard wall, sub-solve violation ≤ 1e-12 h0.
//! A uniform solve on the fine lattice (base 2^`REFINE_BASE` refined 2^`REFINE_LEVELS`, defaults
//! 9 and 2, i.e. 2048²) against refined solves with windows of `REFINE_WINDOWS` (default
//! `64,128,256`) base nodes square around the saddle (1/2, 0), coupling tolerance 1e-10 h0.
//! Prints wall time (the machine may be shared: compare within one run), outer iterations, the
//! saddle gap and its relative difference from the uniform solve, the channel width at the
//! saddle (open fine nodes on the line y = 0 joining the two maxima, inside the window) and the
//! contact area.
//!
//! Each case prints one machine-readable line starting with `RESULT`.
//!
//! `REFINE_CRITICAL=1` instead finds, for each discretisation (uniform fine, base, refined with
//! a `REFINE_WINDOW` window, default 32), the load at which the saddle closes and compares the
//! saddle gaps at the same reduced load from each one's own critical load (defaults base 2^7).
//! Measured (defaults): p_c/p_fc 0.228606867 uniform 512², 0.228630244 base 128², 0.228690466
//! refined (window 32²); saddle gap at l = −1e-2, −3e-3, −1e-3, −3e-4: uniform 3.176e-3,
//! 7.541e-4, 2.053e-4, 4.847e-5; base 3.133e-3, 7.234e-4, 1.768e-4, 4.231e-5; refined
//! 3.036e-3, 6.459e-4, 1.313e-4, 3.081e-5 (h0). REFINE_BASE=8 REFINE_WINDOW=64: p_c/p_fc
//! 0.228605358 uniform 1024², 0.228611988 base 256², 0.228634775 refined; saddle gap: uniform
//! 3.179e-3, 7.562e-4, 2.065e-4, 5.024e-5; base 3.169e-3, 7.487e-4, 1.987e-4, 4.644e-5; refined
//! 3.131e-3, 7.188e-4, 1.771e-4, 3.044e-5.
//!
//! Measured (REFINE_BASE=9 REFINE_FRAC=0.227 REFINE_WINDOWS=64,128,256, 2 cores shared with
//! other jobs): uniform 2048² 14.9 s, saddle gap 2.081248e-3 h0, channel 113 nodes; base 512²
//! alone −6.4e-5 relative; windows 64², 128², 256²: 36.9 s, 60.0 s, 208 s, 50, 48, 51 outer
//! iterations, +2.9e-5, +2.0e-5, +2.6e-5 relative, channel 112 nodes. With REFINE_LEVELS=3
//! REFINE_WINDOWS=64: uniform 4096² 72.2 s (saddle gap 2.081249e-3, channel 225), base alone
//! −6.5e-5, window 82.2 s, 46 outer iterations, +5.1e-5, channel 225. The refined solve is not yet
//! cheaper than the uniform one (see the cost notes in `contact::refinement`).

use contact::refinement::{RefineOptions, Window, solve_refined};
use contact::{Interaction, Lattice, Model, SolverOptions, Surface};
use std::time::Instant;

fn env<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Saddle gap at (1/2, 0) of the uniform solve (`w` = None) or the refined one at `frac` p_fc.
fn saddle_gap(s: &Surface, levels: u32, frac: f64, w: Option<usize>) -> f64 {
    let solver = SolverOptions {
        tol_gap: 1e-13,
        ..Default::default()
    };
    let load = frac * s.p_fc_grid();
    match w {
        None => {
            let sol = Model::new(s)
                .expect("model")
                .solve(Interaction::HardWall, load, &solver, None)
                .expect("solve");
            sol.gap[[s.grid.nx / 2, 0]]
        }
        Some(w) => {
            let opts = RefineOptions {
                levels,
                window: Window::centred(&s.grid, 0.5, 0.0, w, w),
                tol_coupling: 1e-12,
                max_outer: 200,
                solver,
            };
            let r = solve_refined(s, load, &opts).expect("refined solve");
            let f = 1usize << levels;
            let (fnx, fny) = (s.grid.nx * f, s.grid.ny * f);
            let a = (fnx / 2 + fnx - r.origin.0) % fnx;
            let b = (fny - r.origin.1) % fny;
            r.window_gap[[a, b]]
        }
    }
}

/// `REFINE_CRITICAL=1`: the load p_c at which the saddle closes, by bisection (relative 1e-9),
/// for the uniform fine, the base and the refined discretisation, and the saddle gap of each at
/// the same reduced load l = p/p_c − 1 measured from its own p_c.
fn critical(base_n: u32, levels: u32, w: usize) {
    let s = Surface::new(Lattice::Square, base_n).expect("base grid");
    let fine = Surface::new(Lattice::Square, base_n + levels).expect("fine grid");
    // (the base and fine p_fc are equal for the square model: its trough is on a node)
    let cases: [(&str, &Surface, Option<usize>); 3] = [
        ("uniform", &fine, None),
        ("base", &s, None),
        ("refined", &s, Some(w)),
    ];
    for (name, surf, win) in cases {
        let (mut lo, mut hi) = (0.2, 0.25);
        while hi / lo - 1.0 > 1e-9 {
            let mid = 0.5 * (lo + hi);
            if saddle_gap(surf, levels, mid, win) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let pc = 0.5 * (lo + hi);
        let gaps: Vec<String> = [-1e-2, -3e-3, -1e-3, -3e-4]
            .iter()
            .map(|l| {
                format!(
                    "{l:e}: {:.6e}",
                    saddle_gap(surf, levels, pc * (1.0 + l), win)
                )
            })
            .collect();
        println!(
            "{name}: p_c/p_fc = {pc:.9}; saddle gap at l = {}",
            gaps.join(", ")
        );
        println!("RESULT critical case={name} pc={pc:.10} {}", gaps.join(" "));
    }
}

fn main() {
    if env("REFINE_CRITICAL", 0) == 1 {
        critical(
            env("REFINE_BASE", 7),
            env("REFINE_LEVELS", 2),
            env("REFINE_WINDOW", 32),
        );
        return;
    }
    let base_n: u32 = env("REFINE_BASE", 9);
    let levels: u32 = env("REFINE_LEVELS", 2);
    let frac: f64 = env("REFINE_FRAC", 0.21);
    let windows: Vec<usize> = std::env::var("REFINE_WINDOWS")
        .unwrap_or_else(|_| "64,128,256".into())
        .split(',')
        .filter_map(|w| w.trim().parse().ok())
        .collect();
    let s = Surface::new(Lattice::Square, base_n).expect("base grid");
    let fine = Surface::new(Lattice::Square, base_n + levels).expect("fine grid");
    let load = frac * s.p_fc_grid();
    let solver = SolverOptions {
        tol_gap: 1e-12,
        ..Default::default()
    };
    let (fnx, fny) = (fine.grid.nx, fine.grid.ny);
    let t = Instant::now();
    let uni = Model::new(&fine)
        .expect("model")
        .solve(Interaction::HardWall, load, &solver, None)
        .expect("uniform solve");
    let t_uni = t.elapsed().as_secs_f64();
    let g_uni = uni.gap[[fnx / 2, 0]];
    let open_uni = (0..fnx).filter(|&i| uni.gap[[i, 0]] > 0.0).count();
    println!(
        "uniform {fnx}²: {t_uni:.2} s, {} iterations, saddle gap {g_uni:.12e}, channel {open_uni} nodes, area {:.8}",
        uni.stats.iterations, uni.contact_area
    );
    println!(
        "RESULT uniform n={fnx} wall_s={t_uni:.3} gap={g_uni:.15e} area={:.10}",
        uni.contact_area
    );
    let t = Instant::now();
    let coarse = Model::new(&s)
        .expect("model")
        .solve(Interaction::HardWall, load, &solver, None)
        .expect("base solve");
    let g_c = coarse.gap[[s.grid.nx / 2, 0]];
    println!(
        "base {}² alone: {:.2} s, saddle gap {g_c:.12e} (rel {:+.3e}), area {:.8}",
        s.grid.nx,
        t.elapsed().as_secs_f64(),
        g_c / g_uni - 1.0,
        coarse.contact_area
    );
    for w in windows {
        let opts = RefineOptions {
            levels,
            window: Window::centred(&s.grid, 0.5, 0.0, w, w),
            tol_coupling: 1e-10,
            max_outer: 200,
            solver: solver.clone(),
        };
        let t = Instant::now();
        let r = solve_refined(&s, load, &opts).expect("refined solve");
        let wall = t.elapsed().as_secs_f64();
        let (mut gap, mut open) = (f64::NAN, 0usize);
        for a in 0..r.window_grid.nx {
            for b in 0..r.window_grid.ny {
                if !(r.origin.1 + b).is_multiple_of(fny) {
                    continue;
                }
                open += usize::from(r.window_gap[[a, b]] > 0.0);
                if (r.origin.0 + a) % fnx == fnx / 2 {
                    gap = r.window_gap[[a, b]];
                }
            }
        }
        let rel = gap / g_uni - 1.0;
        println!(
            "window {w}² base nodes ({}² fine): {wall:.2} s, {} outer, converged {}, saddle gap {gap:.12e} (rel {rel:+.3e}), channel {open} nodes, area {:.8}",
            r.window_grid.nx, r.outer_iterations, r.converged, r.contact_area
        );
        println!(
            "RESULT window={w} wall_s={wall:.3} outer={} gap={gap:.15e} rel={rel:.3e} open={open} area={:.10}",
            r.outer_iterations, r.contact_area
        );
    }
}
