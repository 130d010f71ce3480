//! Local-refinement benchmark: `cargo bench -p contact --bench refinement`.
//!
//! Problem: the square model near percolation, hard wall; the saddle (1/2, 0) is refined. Base
//! grid 2^`REFINE_BASE` (default 9), refined 2^`REFINE_LEVELS` (default 2) times; the reference
//! is the uniform solve on the fine lattice. `REFINE_METHOD` picks the refinement:
//! `composite` (default, [`contact::refinement`]), `blockwise` (the same discretisation applied
//! blockwise without the fine lattice, [`contact::refinement::blocks`], margin `REFINE_MARGIN`
//! base cells, default 8; preconditioner `REFINE_PRECONDITIONER` = `additive` (default),
//! `galerkin` or `hierarchical`), `coupled` (domain decomposition with the cut
//! interface, [`contact::refinement::coupled`]) or `bandlimited` (the same with the first,
//! band-limited interface, to reproduce the diagnosis).
//!
//! Default mode: mean pressure `REFINE_FRAC` p_fc (default 0.227), windows of `REFINE_WINDOWS`
//! (default `64,128`) base cells square around the saddle; prints wall time (the machine may be
//! shared: compare within one run), iterations, the saddle gap and its relative difference from
//! the uniform solve, and the contact area.
//!
//! `REFINE_CRITICAL=1`: for the uniform fine, the base and the refined discretisation (window
//! `REFINE_WINDOW`, default 32), the load p_c at which the saddle closes (bisection to 1e-9
//! relative) and the saddle gap at l = −1e-2, −3e-3, −1e-3, −3e-4 from each one's own p_c
//! (defaults base 2^7). `REFINE_SKIP_REFERENCE=1` skips the uniform and base cases.
//!
//! `REFINE_SKIP_REFERENCE=1` in the default mode skips the uniform and base solves too (cost
//! of the refined solve alone, e.g. k = 4..6); each refined case then reports the process's
//! peak resident memory (VmHWM), so run one window per process for a memory figure.
//!
//! Cost measurements: `REFINE_MAX_ITER=n` caps the solver's iterations and accepts an
//! unconverged solve (seconds per iteration without a full solve); `REFINE_SETUP_ONLY=1` builds
//! each refined discretisation and stops (setup time and peak memory). The paper preset's deep
//! ladders: `REFINE_METHOD=blockwise REFINE_MARGIN=12 REFINE_BASE=10 REFINE_LEVELS=4
//! REFINE_WINDOWS=32 REFINE_SKIP_REFERENCE=1` (`just bench` runs it at k = 3 with
//! `REFINE_MAX_ITER=20`; `REFINE_LEVELS` and `REFINE_MAX_ITER` from the environment override).
//!
//! Each case prints one machine-readable line starting with `RESULT`. Measurements are in the
//! module docs of `contact::refinement`.

use contact::refinement::{Preconditioner, RefineOptions, RefinedModel, Window, coupled};
use contact::{Interaction, Lattice, Model, SolverOptions, Surface};
use std::time::Instant;

fn env<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn solver() -> SolverOptions {
    SolverOptions {
        tol_gap: 1e-13,
        max_iter: env("REFINE_MAX_ITER", 200_000),
        ..Default::default()
    }
}

/// Whether an unconverged solve is accepted (`REFINE_MAX_ITER` set: a cost measurement).
fn capped() -> bool {
    std::env::var("REFINE_MAX_ITER").is_ok()
}

/// One discretisation: uniform (or base alone), composite, or coupled.
enum Disc {
    Periodic(Box<Model>),
    Composite(Box<(RefinedModel, Option<contact::refinement::Refined>)>),
    Coupled(coupled::RefineOptions),
}

impl Disc {
    fn new(s: &Surface, method: &str, levels: u32, w: Option<usize>) -> Disc {
        let Some(w) = w else {
            return Disc::Periodic(Box::new(Model::new(s).expect("model")));
        };
        let window = Window::centred(&s.grid, 0.5, 0.0, w, w);
        match method {
            "composite" | "blockwise" => {
                let opts = RefineOptions {
                    levels,
                    window,
                    solver: solver(),
                };
                let pre = match env("REFINE_PRECONDITIONER", "additive".to_string()).as_str() {
                    "additive" => Preconditioner::Additive,
                    "galerkin" => Preconditioner::Galerkin,
                    "hierarchical" => Preconditioner::Hierarchical,
                    other => panic!(
                        "REFINE_PRECONDITIONER = {other:?}: additive, galerkin or hierarchical"
                    ),
                };
                let margin = (method == "blockwise").then(|| env("REFINE_MARGIN", 8));
                let model = RefinedModel::with_preconditioner(s, &opts, margin, pre)
                    .expect("refined model");
                Disc::Composite(Box::new((model, None)))
            }
            "coupled" | "bandlimited" => Disc::Coupled(coupled::RefineOptions {
                levels,
                window,
                tol_coupling: 1e-12,
                max_outer: 200,
                solver: solver(),
                interface: if method == "coupled" {
                    coupled::Interface::Cut
                } else {
                    coupled::Interface::BandLimited
                },
            }),
            other => {
                panic!("REFINE_METHOD = {other:?}: composite, blockwise, coupled or bandlimited")
            }
        }
    }

    /// (saddle gap at (1/2, 0), contact area, iterations) at mean pressure `load`.
    fn solve(&mut self, s: &Surface, load: f64) -> (f64, f64, usize) {
        match self {
            Disc::Periodic(m) => {
                let sol = m
                    .solve(Interaction::HardWall, load, &solver(), None)
                    .expect("solve");
                assert!(sol.stats.converged, "{:?}", sol.stats);
                let n = sol.grid.nx;
                (sol.gap[[n / 2, 0]], sol.contact_area, sol.stats.iterations)
            }
            Disc::Composite(b) => {
                let (m, warm) = &mut **b;
                let r = m.solve(load, warm.as_ref()).expect("composite solve");
                assert!(r.stats.converged || capped(), "{:?}", r.stats);
                let g = r
                    .fine_gap(r.lattice.0 / 2, 0)
                    .expect("saddle in the window");
                let out = (g, r.contact_area, r.stats.iterations);
                *warm = Some(r);
                out
            }
            Disc::Coupled(o) => {
                let r = coupled::solve_refined(s, load, o).expect("coupled solve");
                assert!(r.converged, "coupled: not converged");
                let f = 1usize << o.levels;
                let (fnx, fny) = (s.grid.nx * f, s.grid.ny * f);
                let a = (fnx / 2 + fnx - r.origin.0) % fnx;
                let b = (fny - r.origin.1) % fny;
                (r.window_gap[[a, b]], r.contact_area, r.outer_iterations)
            }
        }
    }
}

fn critical(base_n: u32, levels: u32, w: usize, method: &str) {
    let s = Surface::new(Lattice::Square, base_n).expect("base grid");
    let fine = Surface::new(Lattice::Square, base_n + levels).expect("fine grid");
    // (the base and fine p_fc are equal for the square model: its trough is on a node)
    let skip = env("REFINE_SKIP_REFERENCE", 0) == 1;
    let mut cases: Vec<(String, &Surface, Option<usize>)> = Vec::new();
    if !skip {
        cases.push(("uniform".into(), &fine, None));
        cases.push(("base".into(), &s, None));
    }
    cases.push((format!("{method}{w}"), &s, Some(w)));
    for (name, surf, win) in cases {
        let t = Instant::now();
        let mut d = Disc::new(surf, method, levels, win);
        let pfc = s.p_fc_grid();
        let (mut lo, mut hi) = (0.2, 0.25);
        while hi / lo - 1.0 > 1e-9 {
            let mid = 0.5 * (lo + hi);
            if d.solve(surf, mid * pfc).0 > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let pc = 0.5 * (lo + hi);
        let gaps: Vec<String> = [-1e-2, -3e-3, -1e-3, -3e-4, -1e-4]
            .iter()
            .map(|l| format!("{l:e}: {:.6e}", d.solve(surf, pc * (1.0 + l) * pfc).0))
            .collect();
        println!(
            "{name}: p_c/p_fc = {pc:.10}; saddle gap at l = {} ({:.1} s)",
            gaps.join(", "),
            t.elapsed().as_secs_f64()
        );
        println!("RESULT critical case={name} pc={pc:.10} {}", gaps.join(" "));
    }
}

fn main() {
    let method: String = env("REFINE_METHOD", "composite".to_string());
    if env("REFINE_CRITICAL", 0) == 1 {
        critical(
            env("REFINE_BASE", 7),
            env("REFINE_LEVELS", 2),
            env("REFINE_WINDOW", 32),
            &method,
        );
        return;
    }
    let base_n: u32 = env("REFINE_BASE", 9);
    let levels: u32 = env("REFINE_LEVELS", 2);
    let frac: f64 = env("REFINE_FRAC", 0.227);
    let windows: Vec<usize> = std::env::var("REFINE_WINDOWS")
        .unwrap_or_else(|_| "64,128".into())
        .split(',')
        .filter_map(|w| w.trim().parse().ok())
        .collect();
    let s = Surface::new(Lattice::Square, base_n).expect("base grid");
    let load = frac * s.p_fc_grid();
    let skip = env("REFINE_SKIP_REFERENCE", 0) == 1;
    let mut g_uni = f64::NAN;
    if !skip {
        // (the fine surface only for the reference: beyond 2^13 it is refused)
        let fine = Surface::new(Lattice::Square, base_n + levels).expect("fine grid");
        let t = Instant::now();
        let (g, a_uni, it) = Disc::new(&fine, &method, levels, None).solve(&fine, load);
        g_uni = g;
        let t_uni = t.elapsed().as_secs_f64();
        println!(
            "uniform {}²: {t_uni:.2} s, {it} iterations, saddle gap {g_uni:.12e}, area {a_uni:.8}",
            fine.grid.nx
        );
        println!(
            "RESULT uniform n={} wall_s={t_uni:.3} gap={g_uni:.15e} area={a_uni:.10}",
            fine.grid.nx
        );
        let t = Instant::now();
        let (g_c, a_c, _) = Disc::new(&s, &method, levels, None).solve(&s, load);
        println!(
            "base {}² alone: {:.2} s, saddle gap {g_c:.12e} (rel {:+.3e}), area {a_c:.8}",
            s.grid.nx,
            t.elapsed().as_secs_f64(),
            g_c / g_uni - 1.0,
        );
    }
    for w in windows {
        let (t, c0) = (Instant::now(), cpu_seconds());
        let mut d = Disc::new(&s, &method, levels, Some(w));
        let setup = t.elapsed().as_secs_f64();
        let c1 = cpu_seconds();
        if env("REFINE_SETUP_ONLY", 0) == 1 {
            let peak = peak_memory_mib();
            println!(
                "{method} window {w}² base cells: setup {setup:.2} s, peak memory {peak:.0} MiB"
            );
            println!(
                "RESULT method={method} window={w} setup_s={setup:.3} setup_cpu_s={:.2} peak_mib={peak:.0}",
                c1 - c0
            );
            continue;
        }
        let (gap, area, it) = d.solve(&s, load);
        let wall = t.elapsed().as_secs_f64();
        let per_iter = (wall - setup) / it.max(1) as f64;
        let (setup_cpu, solve_cpu) = (c1 - c0, cpu_seconds() - c1);
        let rel = gap / g_uni - 1.0;
        let peak = peak_memory_mib();
        println!(
            "{method} window {w}² base cells: {wall:.2} s (setup {setup:.2} s included), {it} iterations ({per_iter:.3} s each), saddle gap {gap:.12e} (rel {rel:+.3e}), area {area:.8}, peak memory {peak:.0} MiB"
        );
        println!(
            "RESULT method={method} window={w} wall_s={wall:.3} setup_s={setup:.3} iterations={it} s_per_iteration={per_iter:.4} setup_cpu_s={setup_cpu:.2} cpu_s_per_iteration={:.4} gap={gap:.15e} rel={rel:.3e} area={area:.10} peak_mib={peak:.0}",
            solve_cpu / it.max(1) as f64
        );
    }
}

/// CPU time of this process so far (user + system, all threads; s, 10 ms ticks): on a shared
/// machine the wall time is inflated, the CPU time much less. NaN where /proc is missing.
fn cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/self/stat")
        .ok()
        .and_then(|s| {
            let after = s.rsplit(')').next()?.to_string();
            let f: Vec<f64> = after
                .split_whitespace()
                .skip(11)
                .take(2)
                .filter_map(|v| v.parse().ok())
                .collect();
            (f.len() == 2).then(|| (f[0] + f[1]) / 100.0)
        })
        .unwrap_or(f64::NAN)
}

/// Peak resident memory of this process (VmHWM, MiB); NaN where /proc is missing.
fn peak_memory_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}
