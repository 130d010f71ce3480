//! Adhesive-solver benchmark: `cargo bench -p contact --bench adhesive`.
//!
//! Problem: square model, exponential adhesion γ0 = 0.2, ρ = 0.04, mean pressure p̄ (default 0,
//! `ADHESIVE_PRESSURE`), force residual ≤ 1e-10 E* h0/λ judged by `contact::residuals` (the
//! same measure for every minimiser). Per grid: a cold solve (flat start) and a warm-started one
//! (from the cold solution at p̄ to p̄ + 0.01 p_fc, one step of a Figure 2 path), by
//! nonlinear CG (`nonlinear-cg`) and by FIRE beside it. Prints iterations, CPU time of the
//! process (all threads; the machine is shared, CPU time is the robust measure), wall time, the
//! mean gap, the contact area and the achieved residual, and one `RESULT` line per case.
//!
//! Environment:
//! - `ADHESIVE_NS` grid exponents, default `8,9,10`;
//! - `ADHESIVE_FIRE` grid exponents where FIRE runs too, default `8,9,10`;
//! - `ADHESIVE_CANDIDATES` grid exponents where the other candidates of
//!   `contact::nonlinear_cg` run too (Fletcher–Reeves, steepest descent, L-BFGS), default none;
//! - `ADHESIVE_PRESSURE` mean pressure (E* h0/λ), default 0;
//! - `ADHESIVE_TOL` force residuals to solve to, default `1e-10` (several: every case at each,
//!   the dumped displacement is the first's; `bench/peers/adhesive.sh` adds the residual tamaas
//!   reached, for a comparison at equal accuracy);
//! - `ADHESIVE_PATH` grid exponents: instead of the solves above, the draft preset's Figure 2
//!   and Figure 3 paths, warm-started point by point, by the methods of `ADHESIVE_PATH_METHODS`
//!   (default `auto,fire`): iterations per warm step, CPU time, points where they differ;
//!   with `ADHESIVE_PATH_POINTS` set, every point (area, mean gap);
//! - `ADHESIVE_DUMP=DIR` writes per n the heights and our displacement of the cold solve (raw
//!   little-endian f64, row-major (n, n), first index x) as `DIR/heights_n{N}.f64` and
//!   `DIR/ours_u_n{N}.f64`, for `bench/peers/adhesive_peers.py`.

use contact::fire::Fire;
use contact::nonlinear_cg::{Beta, NonlinearCg};
use contact::{Interaction, Lattice, Method, Minimizer, Model, Solution, SolverOptions, Surface};
use std::io::Write;
use std::time::Instant;

#[path = "../../../bench/env_list.rs"]
mod env_list;
use env_list::env_list;
mod cpu_time;
use cpu_time::cpu_seconds;

const ADHESION: Interaction = Interaction::Adhesion {
    gamma0: 0.2,
    rho: 0.04,
};

fn write_f64(path: &str, data: impl Iterator<Item = f64>) {
    let mut f = std::io::BufWriter::new(
        std::fs::File::create(path).unwrap_or_else(|e| panic!("{path}: {e}")),
    );
    for v in data {
        f.write_all(&v.to_le_bytes()).expect("write");
    }
}

fn run(
    model: &mut Model,
    method: &dyn Minimizer,
    pressure: f64,
    warm: Option<&Solution>,
    n: usize,
    case: &str,
    tol: f64,
) -> Solution {
    let opts = SolverOptions {
        tol_force: tol,
        ..SolverOptions::default()
    };
    let (c0, t0) = (cpu_seconds(), Instant::now());
    let sol = model
        .solve_with(method, ADHESION, pressure, &opts, warm)
        .expect("solve");
    let (cpu, wall) = (cpu_seconds() - c0, t0.elapsed().as_secs_f64());
    let s = &sol.stats;
    println!(
        "n = {n:5}  {case:4}  tol {tol:.1e}  {:13} {:6} it  cpu {cpu:8.3} s  wall {wall:8.3} s  mean gap {:.12}  area {:.6}  residual {:.1e}  converged {}",
        s.method, s.iterations, sol.mean_gap, sol.contact_area, s.force_residual, s.converged
    );
    println!(
        "RESULT n={n} case={case} tol={tol:e} method={} iterations={} cpu={cpu:.6} wall={wall:.6} mean_gap={:.15e} area={:.9} residual={:.3e} converged={}",
        s.method, s.iterations, sol.mean_gap, sol.contact_area, s.force_residual, s.converged
    );
    sol
}

/// Forward values of a path of segments `(to, step)` from `from` (the sweep stage's rule:
/// ⌈(to − from)/step⌉ equal steps per segment).
fn segments(from: f64, segs: &[(f64, f64)]) -> Vec<f64> {
    let mut v = vec![from];
    let mut start = from;
    for &(to, step) in segs {
        let k = ((to - start) / step - 1e-9).ceil().max(1.0) as usize;
        v.extend((1..=k).map(|i| start + (to - start) * i as f64 / k as f64));
        start = to;
    }
    v
}

/// One solved point of a path: control value, area, mean gap, iterations, CPU seconds.
struct PathPoint {
    x: f64,
    area: f64,
    mean_gap: f64,
    iterations: usize,
    cpu: f64,
}

/// A quasi-static path as the sweep stage runs it: every point warm-started from the previous
/// one, the reverse branch retracing the forward values, then `extension` below the start;
/// ends at pull-off.
fn path(
    model: &mut Model,
    method: Method,
    interaction: impl Fn(f64) -> (Interaction, f64),
    values: &[f64],
    extension: &[f64],
    tol_force: f64,
) -> Vec<PathPoint> {
    let opts = SolverOptions {
        tol_force,
        method,
        ..SolverOptions::default()
    };
    let plan: Vec<f64> = values
        .iter()
        .chain(values.iter().rev().skip(1))
        .chain(extension)
        .copied()
        .collect();
    let mut prev: Option<Solution> = None;
    let mut out = Vec::new();
    for x in plan {
        let (inter, p) = interaction(x);
        let c0 = cpu_seconds();
        let sol = match model.solve(inter, p, &opts, prev.as_ref()) {
            Ok(s) => s,
            Err(contact::ContactError::Detached { .. }) => break,
            Err(e) => panic!("{e}"),
        };
        assert!(sol.stats.converged, "{method:?} at {x}: {:?}", sol.stats);
        out.push(PathPoint {
            x,
            area: sol.contact_area,
            mean_gap: sol.mean_gap,
            iterations: sol.stats.iterations,
            cpu: cpu_seconds() - c0,
        });
        prev = Some(sol);
    }
    out
}

/// `ADHESIVE_PATH=7`: the draft preset's Figure 2 adhesion and repulsion load paths (square
/// model) and Figure 3's γ0 path (hexagonal model) on 2^7, by the methods of
/// `ADHESIVE_PATH_METHODS` (default `auto,fire`; the first compared with the last) at the
/// pipeline's tolerance 1e-8: iterations per warm step, CPU time, and every point where the two
/// differ in area by more than one node or in mean gap by more than 1e-6 h0.
fn paths(ns: &[usize]) {
    // the first is compared with the last
    let methods: Vec<Method> = env_list("ADHESIVE_PATH_METHODS", "auto,fire");
    let fig2 = [
        (0.05, 0.005),
        (0.10, 0.025),
        (0.22, 0.005),
        (0.60, 0.025),
        (0.72, 0.005),
        (1.0, 0.025),
    ];
    let rep = [(0.06, 0.005), (0.35, 0.025), (0.50, 0.005), (1.0, 0.025)];
    let fig3: Vec<(f64, f64)> = [
        0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0,
    ]
    .iter()
    .scan(0.005, |from, &to| {
        let step = (to - *from) / 6.0;
        *from = to;
        Some((to, step * 1.000001))
    })
    .collect();
    for &e in ns {
        type Case = (
            &'static str,
            Lattice,
            Vec<f64>,
            Vec<f64>,
            Box<dyn Fn(f64, f64) -> (Interaction, f64)>,
        );
        let cases: Vec<Case> = vec![
            (
                "fig2 adhesion",
                Lattice::Square,
                segments(0.0025, &fig2),
                segments(0.0025, &[(-0.1, 0.0025)])
                    .into_iter()
                    .skip(1)
                    .collect(),
                Box::new(|x, pfc| (ADHESION, x * pfc)),
            ),
            (
                "fig2 repulsion",
                Lattice::Square,
                segments(0.0025, &rep),
                vec![],
                Box::new(|x, pfc| {
                    (
                        Interaction::Repulsion {
                            gamma_r: 0.2,
                            rho: 0.04,
                        },
                        x * pfc,
                    )
                }),
            ),
            (
                "fig3 hexagonal",
                Lattice::Hexagonal,
                segments(0.005, &fig3),
                vec![],
                Box::new(|x, _| {
                    (
                        Interaction::Adhesion {
                            gamma0: x,
                            rho: 0.04,
                        },
                        0.0,
                    )
                }),
            ),
        ];
        for (label, lattice, values, ext, inter) in cases {
            let s = Surface::new(lattice, e as u32).expect("surface");
            let pfc = s.p_fc_grid();
            let nodes = (s.grid.nx * s.grid.ny) as f64;
            let mut model = Model::new(&s).expect("model");
            let ext: Vec<f64> = if label.contains("adhesion") {
                ext
            } else {
                vec![]
            };
            let runs: Vec<(String, Vec<PathPoint>)> = methods
                .iter()
                .map(|&m| {
                    let pts = path(&mut model, m, |x| inter(x, pfc), &values, &ext, 1e-8);
                    (format!("{m:?}"), pts)
                })
                .collect();
            for (name, pts) in &runs {
                let it: usize = pts.iter().skip(1).map(|p| p.iterations).sum();
                let cpu: f64 = pts.iter().map(|p| p.cpu).sum();
                println!(
                    "PATH n={e} case={label:?} method={name} points={} cold_it={} warm_it_per_step={:.1} cpu={cpu:.3}",
                    pts.len(),
                    pts[0].iterations,
                    it as f64 / (pts.len() - 1).max(1) as f64
                );
            }
            if std::env::var("ADHESIVE_PATH_POINTS").is_ok() {
                for (name, pts) in &runs {
                    for p in pts {
                        println!(
                            "POINT case={label:?} method={name} x={:.6} area={:.9} mean_gap={:.12}",
                            p.x, p.area, p.mean_gap
                        );
                    }
                }
            }
            let (a, b) = (&runs[0].1, &runs[runs.len() - 1].1);
            if a.len() != b.len() {
                println!(
                    "  path lengths differ: {} vs {} (pull-off)",
                    a.len(),
                    b.len()
                );
            }
            for (k, (p, q)) in a.iter().zip(b).enumerate() {
                let da = (p.area - q.area).abs() * nodes;
                let dg = (p.mean_gap - q.mean_gap).abs();
                if da > 1.0 || dg > 1e-6 {
                    println!(
                        "  point {k} x={:.5}: area {:.6} vs {:.6} ({da:.0} nodes), mean gap {:.9} vs {:.9}",
                        p.x, p.area, q.area, p.mean_gap, q.mean_gap
                    );
                }
            }
        }
    }
}

fn main() {
    let path_ns = env_list::<usize>("ADHESIVE_PATH", "");
    if !path_ns.is_empty() {
        paths(&path_ns);
        return;
    }
    let ns = env_list::<usize>("ADHESIVE_NS", "8,9,10");
    let fire = env_list::<usize>("ADHESIVE_FIRE", "8,9,10");
    let candidates = env_list::<usize>("ADHESIVE_CANDIDATES", "");
    let pressure: f64 = std::env::var("ADHESIVE_PRESSURE")
        .ok()
        .map(|s| s.parse().expect("ADHESIVE_PRESSURE: a number"))
        .unwrap_or(0.0);
    let tols = env_list::<f64>("ADHESIVE_TOL", "1e-10");
    let dump = std::env::var("ADHESIVE_DUMP").ok();
    println!(
        "adhesive solve, square model, γ0 = 0.2, ρ = 0.04, p̄ = {pressure}, residual ≤ {tols:?}; threads: {}",
        rayon::current_num_threads()
    );
    for &e in &ns {
        let s = Surface::new(Lattice::Square, e as u32).expect("surface");
        let n = s.grid.nx;
        let mut model = Model::new(&s).expect("model");
        let step = 0.01 * s.p_fc_grid();
        let mut methods: Vec<Box<dyn Minimizer>> = vec![Box::new(NonlinearCg::default())];
        if fire.contains(&e) {
            methods.push(Box::new(Fire::default()));
        }
        if candidates.contains(&e) {
            for beta in [Beta::FletcherReeves, Beta::SteepestDescent, Beta::Lbfgs] {
                methods.push(Box::new(NonlinearCg {
                    beta,
                    ..NonlinearCg::default()
                }));
            }
        }
        for (k, m) in methods.iter().enumerate() {
            for (t, &tol) in tols.iter().enumerate() {
                let cold = run(&mut model, m.as_ref(), pressure, None, n, "cold", tol);
                run(
                    &mut model,
                    m.as_ref(),
                    pressure + step,
                    Some(&cold),
                    n,
                    "warm",
                    tol,
                );
                if k == 0
                    && t == 0
                    && let Some(dir) = &dump
                {
                    write_f64(
                        &format!("{dir}/heights_n{n}.f64"),
                        s.heights.iter().copied(),
                    );
                    write_f64(
                        &format!("{dir}/ours_u_n{n}.f64"),
                        cold.displacement.iter().copied(),
                    );
                }
            }
        }
    }
}
