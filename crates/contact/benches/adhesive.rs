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
//! - `ADHESIVE_DUMP=DIR` writes per n the heights and our displacement of the cold solve (raw
//!   little-endian f64, row-major (n, n), first index x) as `DIR/heights_n{N}.f64` and
//!   `DIR/ours_u_n{N}.f64`, for `bench/peers/adhesive_peers.py`.

use contact::fire::Fire;
use contact::nonlinear_cg::{Beta, NonlinearCg};
use contact::{Interaction, Lattice, Minimizer, Model, Solution, SolverOptions, Surface};
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
) -> Solution {
    let opts = SolverOptions {
        tol_force: 1e-10,
        ..SolverOptions::default()
    };
    let (c0, t0) = (cpu_seconds(), Instant::now());
    let sol = model
        .solve_with(method, ADHESION, pressure, &opts, warm)
        .expect("solve");
    let (cpu, wall) = (cpu_seconds() - c0, t0.elapsed().as_secs_f64());
    let s = &sol.stats;
    println!(
        "n = {n:5}  {case:4}  {:13} {:6} it  cpu {cpu:8.3} s  wall {wall:8.3} s  mean gap {:.12}  area {:.6}  residual {:.1e}  converged {}",
        s.method, s.iterations, sol.mean_gap, sol.contact_area, s.force_residual, s.converged
    );
    println!(
        "RESULT n={n} case={case} method={} iterations={} cpu={cpu:.6} wall={wall:.6} mean_gap={:.15e} area={:.9} residual={:.3e} converged={}",
        s.method, s.iterations, sol.mean_gap, sol.contact_area, s.force_residual, s.converged
    );
    sol
}

fn main() {
    let ns = env_list::<usize>("ADHESIVE_NS", "8,9,10");
    let fire = env_list::<usize>("ADHESIVE_FIRE", "8,9,10");
    let candidates = env_list::<usize>("ADHESIVE_CANDIDATES", "");
    let pressure: f64 = std::env::var("ADHESIVE_PRESSURE")
        .ok()
        .map(|s| s.parse().expect("ADHESIVE_PRESSURE: a number"))
        .unwrap_or(0.0);
    let dump = std::env::var("ADHESIVE_DUMP").ok();
    println!(
        "adhesive solve, square model, γ0 = 0.2, ρ = 0.04, p̄ = {pressure}, residual ≤ 1e-10; threads: {}",
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
                methods.push(Box::new(NonlinearCg { beta }));
            }
        }
        for (k, m) in methods.iter().enumerate() {
            let cold = run(&mut model, m.as_ref(), pressure, None, n, "cold");
            run(
                &mut model,
                m.as_ref(),
                pressure + step,
                Some(&cold),
                n,
                "warm",
            );
            if k == 0
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
