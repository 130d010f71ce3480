//! Contact-solver benchmark: `cargo bench -p contact --bench hardwall`.
//!
//! Problem: cold hard-wall solve (no warm start) of the square model, mean pressure 0.3 p_fc (p_fc
//! of the sampled grid), to a maximum constraint violation ≤ 1e-10 h0. The bound is the
//! solver's `max_violation`: with S the nodes carrying pressure (p > 0) and g = G p − h − δ the
//! gap for the rigid approach δ (the mean of G p − h over S), it is
//! max(max_S |g|, max_{not S} (−g)), i.e. the largest gap where the wall pushes and the largest
//! penetration where it does not. Force balance is exact by construction (p ≥ 0, mean p = p̄,
//! u = G p).
//!
//! Every grid size and thread count runs in a fresh process (this binary re-executes itself), so
//! the peak resident memory (`VmHWM`) is that of one solve; the increment over the process's
//! baseline before the surface is built is reported per grid node in f64 values. Per case it
//! prints CPU time (all threads, from `/proc/self/task/*/schedstat`; the machine is shared, so
//! CPU time is the robust measure) and wall time (medians over repeated cold solves for small
//! grids), iterations, achieved violation, memory and the cost of one FFT pair (forward and
//! inverse real 2-D transform with the kernel multiply, i.e. one application of G) for reference.
//!
//! Environment:
//! - `HARDWALL_NS` grid exponents, default `8,9,10,11`;
//! - `HARDWALL_THREADS` rayon pool sizes, default `1,2`;
//! - `HARDWALL_TOL` violation bound, default 1e-10;
//! - `HARDWALL_MIN_CPU` repeat a case until this much CPU time is spent (s), default 1;
//! - `HARDWALL_PLAIN` grid exponents where Polonsky–Keer without the stiffness preconditioner
//!   (`PolonskyKeer::PLAIN`) also runs, single-threaded, for comparison; default `8,9,10`;
//! - `HARDWALL_FIRE` grid exponents for the FIRE cost table (hard wall: same problem; adhesion:
//!   γ0 = 0.2, ρ = 0.04, zero load), default `8,9,10`; empty to skip;
//! - `HARDWALL_DUMP=DIR` writes the heights and our pressure field per n (raw little-endian f64,
//!   row-major (n, n), first index x) as `DIR/heights_n{N}.f64`, `DIR/pressure_n{N}.f64` and
//!   a `DIR/case_n{N}.json` with the load, for `bench/peers/contact_peers.py`.
//!
//! Each case also prints one machine-readable line starting with `RESULT`.

use contact::elastic::ElasticKernel;
use contact::fire::Fire;
use contact::polonsky_keer::PolonskyKeer;
use contact::{Interaction, Lattice, Method, Model, Solution, SolverOptions, Surface};
use std::collections::BTreeMap;
use std::io::Write;
use std::process::Command;
use std::time::Instant;

const CHILD: &str = "HARDWALL_CHILD";

mod cpu_time;
#[path = "../../../bench/env_list.rs"]
mod env_list;
use cpu_time::cpu_seconds;
use env_list::env_list;

fn env_f64(name: &str, default: f64) -> f64 {
    std::env::var(name)
        .ok()
        .map(|s| {
            s.parse()
                .unwrap_or_else(|_| panic!("{name}: cannot parse {s:?}"))
        })
        .unwrap_or(default)
}

/// A value from `/proc/self/status` in KiB.
fn status_kib(key: &str) -> u64 {
    let s = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    s.lines()
        .find(|l| l.starts_with(key))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn write_f64(path: &str, data: impl Iterator<Item = f64>) {
    let mut f = std::io::BufWriter::new(
        std::fs::File::create(path).unwrap_or_else(|e| panic!("{path}: {e}")),
    );
    for v in data {
        f.write_all(&v.to_le_bytes()).expect("write");
    }
}

/// Repeats `solve` (cold each time) until `min_cpu` seconds of CPU are spent (at least once, at
/// most 20 times); returns the last solution and the median CPU and wall times.
fn timed(min_cpu: f64, mut solve: impl FnMut() -> Solution) -> (Solution, f64, f64, usize) {
    let (mut cpus, mut walls) = (Vec::new(), Vec::new());
    let mut total = 0.0;
    loop {
        let (c0, t0) = (cpu_seconds(), Instant::now());
        let sol = solve();
        let (c, w) = (cpu_seconds() - c0, t0.elapsed().as_secs_f64());
        cpus.push(c);
        walls.push(w);
        total += c;
        if total >= min_cpu || cpus.len() >= 20 {
            let reps = cpus.len();
            return (sol, median(&mut cpus), median(&mut walls), reps);
        }
    }
}

/// CPU and wall seconds of one FFT pair (G applied to a field), median over repeats.
fn fft_pair_cost(surface: &Surface) -> (f64, f64) {
    let mut kernel = ElasticKernel::new(&surface.grid, 1.0);
    let n = surface.grid.len();
    let p: Vec<f64> = surface.heights.iter().copied().collect();
    let mut u = vec![0.0; n];
    kernel.displacement(&p, &mut u);
    let reps = ((1usize << 24) / n).clamp(4, 200);
    let (mut cpus, mut walls) = (Vec::new(), Vec::new());
    for _ in 0..5 {
        let (c0, t0) = (cpu_seconds(), Instant::now());
        for _ in 0..reps {
            kernel.displacement(&p, &mut u);
        }
        cpus.push((cpu_seconds() - c0) / reps as f64);
        walls.push(t0.elapsed().as_secs_f64() / reps as f64);
    }
    (median(&mut cpus), median(&mut walls))
}

/// One case in this process: `kind` is `pk`, `fire` or `fire-adhesion`.
fn child(spec: &str) {
    let parts: Vec<&str> = spec.split(':').collect();
    let (kind, e, threads): (&str, u32, usize) = (
        parts[0],
        parts[1].parse().expect("n"),
        parts[2].parse().expect("threads"),
    );
    let tol = env_f64("HARDWALL_TOL", 1e-10);
    let min_cpu = env_f64("HARDWALL_MIN_CPU", 1.0);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    pool.install(|| {
        let base_kib = status_kib("VmRSS:");
        let surface = Surface::new(Lattice::Square, e).expect("surface");
        let nodes = surface.grid.len();
        let p_fc = surface.p_fc_grid();
        let mut model = Model::new(&surface).expect("model");
        let (sol, cpu, wall, reps, extra) = match kind {
            "pk" | "pk-plain" => {
                let opts = SolverOptions {
                    tol_gap: tol,
                    method: Method::PolonskyKeer,
                    ..Default::default()
                };
                let pk = PolonskyKeer {
                    preconditioned: kind == "pk",
                };
                let (sol, cpu, wall, reps) = timed(min_cpu, || {
                    model
                        .solve_with(&pk, Interaction::HardWall, 0.3 * p_fc, &opts, None)
                        .expect("solve")
                });
                (sol, cpu, wall, reps, String::new())
            }
            "fire" => {
                // FIRE stops on the force residual; compare its gap with a tight PK solution.
                let opts = SolverOptions {
                    tol_force: env_f64("HARDWALL_FIRE_TOL", 1e-10),
                    ..Default::default()
                };
                let (sol, cpu, wall, reps) = timed(0.0, || {
                    model
                        .solve_with(&Fire::default(), Interaction::HardWall, 0.3 * p_fc, &opts, None)
                        .expect("solve")
                });
                let pk = model
                    .solve_with(
                        &PolonskyKeer::default(),
                        Interaction::HardWall,
                        0.3 * p_fc,
                        &SolverOptions {
                            tol_gap: 1e-12,
                            ..Default::default()
                        },
                        None,
                    )
                    .expect("pk");
                let dg = pk
                    .gap
                    .iter()
                    .zip(sol.gap.iter())
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0, f64::max);
                (sol, cpu, wall, reps, format!(" gap_diff_vs_pk={dg:.3e}"))
            }
            "fire-adhesion" => {
                let opts = SolverOptions::default();
                let (sol, cpu, wall, reps) = timed(0.0, || {
                    model
                        .solve(
                            Interaction::Adhesion {
                                gamma0: 0.2,
                                rho: 0.04,
                            },
                            0.0,
                            &opts,
                            None,
                        )
                        .expect("solve")
                });
                (sol, cpu, wall, reps, String::new())
            }
            other => panic!("unknown case {other}"),
        };
        let hwm_kib = status_kib("VmHWM:");
        let per_node = (hwm_kib.saturating_sub(base_kib)) as f64 * 1024.0 / (8.0 * nodes as f64);
        if kind == "pk"
            && let Ok(dir) = std::env::var("HARDWALL_DUMP")
        {
            let size = 1usize << e;
            write_f64(
                &format!("{dir}/heights_n{size}.f64"),
                surface.heights.iter().copied(),
            );
            write_f64(
                &format!("{dir}/pressure_n{size}.f64"),
                sol.pressure.iter().copied(),
            );
            let meta = format!(
                "{{\"n\": {size}, \"lx\": {}, \"ly\": {}, \"pressure\": {:e}, \"p_fc\": {:e}, \
                 \"contact_area\": {:e}, \"mean_gap\": {:e}}}\n",
                surface.grid.lx,
                surface.grid.ly,
                sol.mean_pressure,
                p_fc,
                sol.contact_area,
                sol.mean_gap
            );
            std::fs::write(format!("{dir}/case_n{size}.json"), meta).expect("write meta");
        }
        let (fft_cpu, fft_wall) = if kind.starts_with("pk") && std::env::var("HARDWALL_NO_FFT").is_err() {
            fft_pair_cost(&surface)
        } else {
            (f64::NAN, f64::NAN)
        };
        println!(
            "RESULT solver={kind} n={} threads={threads} cpu_s={cpu:.6} wall_s={wall:.6} reps={reps} \
             iterations={} converged={} violation={:.3e} force_residual={:.3e} contact_area={:.8} \
             mean_gap={:.10e} peak_kib={hwm_kib} base_kib={base_kib} f64_per_node={per_node:.2} \
             fft_pair_cpu_ms={:.4} fft_pair_wall_ms={:.4}{extra}",
            1usize << e,
            sol.stats.iterations,
            sol.stats.converged,
            sol.stats.max_violation,
            sol.stats.force_residual,
            sol.contact_area,
            sol.mean_gap,
            fft_cpu * 1e3,
            fft_wall * 1e3,
        );
    });
}

fn run_child(spec: &str) -> BTreeMap<String, String> {
    let exe = std::env::current_exe().expect("current exe");
    let out = Command::new(exe)
        .env(CHILD, spec)
        .output()
        .expect("spawn benchmark child");
    let stdout = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() {
        eprintln!("{}", String::from_utf8_lossy(&out.stderr));
        panic!("case {spec} failed: {}", out.status);
    }
    let line = stdout
        .lines()
        .find(|l| l.starts_with("RESULT "))
        .unwrap_or_else(|| panic!("case {spec}: no RESULT line in {stdout}"));
    println!("{line}");
    line.split_whitespace()
        .skip(1)
        .filter_map(|kv| kv.split_once('='))
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

fn main() {
    if let Ok(spec) = std::env::var(CHILD) {
        child(&spec);
        return;
    }
    let ns: Vec<u32> = env_list("HARDWALL_NS", "8,9,10,11");
    let threads: Vec<usize> = env_list("HARDWALL_THREADS", "1,2");
    let fire_ns: Vec<u32> = env_list("HARDWALL_FIRE", "8,9,10");
    let plain_ns: Vec<u32> = env_list("HARDWALL_PLAIN", "8,9,10");
    println!(
        "# cold hard-wall solve, square model, p = 0.3 p_fc, max violation <= {:e} h0 (Polonsky-Keer)",
        env_f64("HARDWALL_TOL", 1e-10)
    );
    let mut rows = Vec::new();
    for &e in &ns {
        for &t in &threads {
            rows.push(run_child(&format!("pk:{e}:{t}")));
        }
        if plain_ns.contains(&e) {
            rows.push(run_child(&format!("pk-plain:{e}:1")));
        }
    }
    let g = |r: &BTreeMap<String, String>, k: &str| r.get(k).cloned().unwrap_or_default();
    let f = |r: &BTreeMap<String, String>, k: &str| g(r, k).parse::<f64>().unwrap_or(f64::NAN);
    println!();
    println!(
        "{:>9} {:>5} {:>3} {:>8} {:>8} {:>5} {:>9} {:>8} {:>9} {:>10} {:>11} {:>12}",
        "solver",
        "n",
        "thr",
        "cpu_s",
        "wall_s",
        "iter",
        "violation",
        "peak_MiB",
        "f64/node",
        "fft_cpu_ms",
        "fft_wall_ms",
        "cpu/fft_pair"
    );
    for r in &rows {
        println!(
            "{:>9} {:>5} {:>3} {:>8.3} {:>8.3} {:>5} {:>9} {:>8.1} {:>9} {:>10.2} {:>11.2} {:>12.1}",
            g(r, "solver"),
            g(r, "n"),
            g(r, "threads"),
            f(r, "cpu_s"),
            f(r, "wall_s"),
            g(r, "iterations"),
            g(r, "violation"),
            f(r, "peak_kib") / 1024.0,
            g(r, "f64_per_node"),
            f(r, "fft_pair_cpu_ms"),
            f(r, "fft_pair_wall_ms"),
            f(r, "cpu_s") / (f(r, "fft_pair_cpu_ms") * 1e-3),
        );
    }
    if fire_ns.is_empty() {
        return;
    }
    println!();
    println!(
        "# FIRE (1 thread): hard wall as above (force residual <= {:e}, gap compared with PK at 1e-12), \
         and adhesion gamma0 = 0.2, rho = 0.04, zero load (force residual <= 1e-8)",
        env_f64("HARDWALL_FIRE_TOL", 1e-10)
    );
    let mut fire_rows = Vec::new();
    for &e in &fire_ns {
        for kind in ["fire", "fire-adhesion"] {
            fire_rows.push(run_child(&format!("{kind}:{e}:1")));
        }
    }
    println!();
    println!(
        "{:>14} {:>5} {:>8} {:>8} {:>6} {:>10} {:>10} {:>12}",
        "case", "n", "cpu_s", "wall_s", "iter", "force_res", "area", "gap_vs_pk"
    );
    for r in &fire_rows {
        println!(
            "{:>14} {:>5} {:>8.2} {:>8.2} {:>6} {:>10} {:>10.6} {:>12}",
            g(r, "solver"),
            g(r, "n"),
            f(r, "cpu_s"),
            f(r, "wall_s"),
            g(r, "iterations"),
            g(r, "force_residual"),
            f(r, "contact_area"),
            r.get("gap_diff_vs_pk").cloned().unwrap_or("-".into()),
        );
    }
}
