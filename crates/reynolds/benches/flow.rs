//! Flow-solver benchmark: `cargo bench -p reynolds --bench flow`.
//!
//! Field: `g = max(0, ε + cos 2πx + cos 2πy)` on the unit cell (a constriction of height ε at
//! the saddle points), flow along x, relative residual 1e-10. For every grid `2^n`, every ε and
//! every rayon pool size it prints the set-up and total wall time, iterations, true relative
//! residual, conservation error, conductivity and the peak resident memory of the case
//! (`VmHWM`, reset before each case through `/proc/self/clear_refs`).
//!
//! Environment:
//! - `FLOW_NS` grid exponents, default `9,10,11,12` (512² … 4096²);
//! - `FLOW_EPS` values of ε, default `1e-3,1e-1,1e-6`;
//! - `FLOW_THREADS` rayon pool sizes, default `1,2`;
//! - `FLOW_TOL` relative residual, default 1e-10;
//! - `FLOW_BOUNDARY` `periodic` (default: the periodic cell) or `reservoirs` (inlet and outlet
//!   reservoirs at x = 0 and x = 1, closed side edges);
//! - `FLOW_REPEAT` solves per case (the fastest is reported), default 1;
//! - `FLOW_DUMP=DIR` also writes each gap field as raw little-endian f64, row-major `(n, n)`
//!   (first index x), to `DIR/gap_n{N}_eps{ε}.f64`, for `bench/peers/flow_pyamg.py`.
//!
//! Each case also prints one machine-readable line starting with `RESULT`.

use ndarray::Array2;
use reynolds::{FlowAxis, FlowOptions, SideEdges, solve, solve_between_reservoirs};
use std::io::Write;

#[path = "../../../bench/env_list.rs"]
mod env_list;
use env_list::env_list;

fn gap_field(n: usize, eps: f64) -> Array2<f64> {
    let tau = std::f64::consts::TAU;
    Array2::from_shape_fn((n, n), |(i, j)| {
        let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
        (eps + (tau * x).cos() + (tau * y).cos()).max(0.0)
    })
}

fn status_kib(key: &str) -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    s.lines()
        .find(|l| l.starts_with(key))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()
}

/// CPU time (user + system) of the whole process, seconds.
fn cpu_seconds() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = s.rsplit_once(')').map(|(_, r)| r).unwrap_or("");
    let f: Vec<&str> = rest.split_whitespace().collect();
    let tick = |k: usize| f.get(k).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (tick(11) + tick(12)) / 100.0
}

fn reset_peak() {
    // "5" resets the peak resident set size (Linux ≥ 4.0); ignore failures.
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

fn main() {
    // `cargo bench` passes `--bench`; nothing else is accepted.
    let ns: Vec<u32> = env_list("FLOW_NS", "9,10,11,12");
    let epss: Vec<f64> = env_list("FLOW_EPS", "1e-3,1e-1,1e-6");
    let threads: Vec<usize> = env_list("FLOW_THREADS", "1,2");
    let repeat: usize = env_list("FLOW_REPEAT", "1")[0];
    let dump = std::env::var("FLOW_DUMP").ok();
    let reservoirs = match std::env::var("FLOW_BOUNDARY").as_deref() {
        Ok("reservoirs") => true,
        Ok("periodic") | Err(_) => false,
        Ok(other) => panic!("FLOW_BOUNDARY = {other:?}: allowed periodic, reservoirs"),
    };
    let options = FlowOptions {
        tolerance: env_list("FLOW_TOL", "1e-10")[0],
        ..FlowOptions::default()
    };
    println!(
        "{:>5} {:>7} {:>3} {:>8} {:>8} {:>8} {:>5} {:>9} {:>9} {:>13} {:>8}",
        "n",
        "eps",
        "thr",
        "setup_s",
        "total_s",
        "cpu_s",
        "iter",
        "residual",
        "conserv",
        "K",
        "peak_MiB"
    );
    for &e in &ns {
        let n = 1usize << e;
        for &eps in &epss {
            let gap = gap_field(n, eps);
            if let Some(dir) = &dump {
                let path = format!("{dir}/gap_n{n}_eps{eps:e}.f64");
                let mut f = std::io::BufWriter::new(
                    std::fs::File::create(&path).unwrap_or_else(|err| panic!("{path}: {err}")),
                );
                for v in gap.iter() {
                    f.write_all(&v.to_le_bytes()).expect("write gap");
                }
                eprintln!("wrote {path}");
            }
            for &t in &threads {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(t)
                    .build()
                    .expect("thread pool");
                let mut best: Option<reynolds::FlowResult> = None;
                let mut peak = 0;
                let mut cpu = f64::INFINITY;
                for _ in 0..repeat.max(1) {
                    reset_peak();
                    let c0 = cpu_seconds();
                    let r = pool
                        .install(|| {
                            if reservoirs {
                                let sides = SideEdges::NoFlux;
                                solve_between_reservoirs(
                                    gap.view(),
                                    1.0,
                                    1.0,
                                    FlowAxis::X,
                                    sides,
                                    &options,
                                )
                            } else {
                                solve(gap.view(), 1.0, 1.0, FlowAxis::X, &options)
                            }
                        })
                        .expect("valid input");
                    cpu = cpu.min(cpu_seconds() - c0);
                    peak = peak.max(status_kib("VmHWM:").unwrap_or(0));
                    if best
                        .as_ref()
                        .is_none_or(|b| r.wall_seconds < b.wall_seconds)
                    {
                        best = Some(r);
                    }
                }
                let r = best.expect("at least one run");
                println!(
                    "{:>5} {:>7.0e} {:>3} {:>8.3} {:>8.3} {:>8.2} {:>5} {:>9.2e} {:>9.2e} {:>13.6e} {:>8.0}{}",
                    n,
                    eps,
                    t,
                    r.setup_seconds,
                    r.wall_seconds,
                    cpu,
                    r.iterations,
                    r.relative_residual,
                    r.conservation_error,
                    r.conductivity,
                    peak as f64 / 1024.0,
                    if r.converged {
                        String::new()
                    } else {
                        format!("  NOT CONVERGED: {:?}", r.termination)
                    }
                );
                println!(
                    "RESULT solver=reynolds boundary={} n={n} eps={eps:e} threads={t} setup_s={} wall_s={} cpu_s={} \
                     iterations={} residual={:e} conservation={:e} flux={:e} peak_mib={:.0} converged={}",
                    if reservoirs { "reservoirs" } else { "periodic" },
                    r.setup_seconds,
                    r.wall_seconds,
                    cpu,
                    r.iterations,
                    r.relative_residual,
                    r.conservation_error,
                    r.flux,
                    peak as f64 / 1024.0,
                    r.converged
                );
            }
        }
    }
}
