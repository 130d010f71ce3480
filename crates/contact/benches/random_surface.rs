//! Contact solver on a self-affine random surface: `cargo bench -p contact --bench random_surface`.
//!
//! Problem: an isotropic self-affine surface (H = 0.8, q_r = 2, q_s = 64 in units of 2π/L,
//! rms slope 1, exact amplitudes, seed 1; `surface::SelfAffine`, L = 1), cold hard-wall solve at
//! the mean pressure `RANDOM_LOAD` × p_fc (default 0.05; p_fc = −min(K h), the periodic
//! full-contact pressure), to a constraint violation ≤ 1e-10 (in the units of the heights).
//! Prints CPU time (all threads; the machine is shared),
//! wall time, iterations, the contact area and the achieved violation, and one `RESULT` line per
//! grid.
//!
//! Environment:
//! - `RANDOM_NS` grid exponents, default `10` (1024²; q_s = 64 needs n ≥ 7);
//! - `RANDOM_LOAD` load in units of p_fc, default 0.05;
//! - `RANDOM_THREADS` rayon pool size, default 1;
//! - `RANDOM_DUMP=DIR` writes the heights and our pressure (raw little-endian f64, row-major
//!   (n, n), first index x) as `DIR/random_heights_n{N}.f64`, `DIR/random_pressure_n{N}.f64`
//!   and the load in `DIR/random_case_n{N}.json`, for a side-by-side run of another code.

use contact::elastic::ElasticKernel;
use contact::{Interaction, Method, Model, SolverOptions};
use std::io::Write;
use std::time::Instant;
use surface::{Amplitudes, Normalisation, SelfAffine};

mod cpu_time;
#[path = "../../../bench/env_list.rs"]
mod env_list;
use cpu_time::cpu_seconds;
use env_list::env_list;

fn write_f64(path: &str, data: impl Iterator<Item = f64>) {
    let mut f = std::io::BufWriter::new(
        std::fs::File::create(path).unwrap_or_else(|e| panic!("{path}: {e}")),
    );
    for v in data {
        f.write_all(&v.to_le_bytes()).expect("write");
    }
}

fn main() {
    let ns: Vec<u32> = env_list("RANDOM_NS", "10");
    let load: f64 = env_list::<f64>("RANDOM_LOAD", "0.05")[0];
    let threads: usize = env_list::<usize>("RANDOM_THREADS", "1")[0];
    let dump = std::env::var("RANDOM_DUMP").ok();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool");
    for n in ns {
        pool.install(|| {
            let field = SelfAffine {
                n,
                length: 1.0,
                hurst: 0.8,
                q_r: 2.0,
                q_s: 64.0,
                normalisation: Normalisation::RmsSlope(1.0),
                amplitudes: Amplitudes::Exact,
                seed: 1,
            }
            .generate()
            .expect("surface");
            let h: Vec<f64> = field.heights.iter().copied().collect();
            let mut k = ElasticKernel::new(&field.grid, 1.0);
            let mut sigma = vec![0.0; h.len()];
            k.stress(&h, &mut sigma);
            let p_fc = -sigma.iter().copied().fold(f64::INFINITY, f64::min);
            let pressure = load * p_fc;
            let mut model = Model::from_heights(field.grid, field.heights.view()).expect("model");
            let opts = SolverOptions {
                tol_gap: 1e-10,
                method: Method::PolonskyKeer,
                ..Default::default()
            };
            let (c0, t0) = (cpu_seconds(), Instant::now());
            let sol = model
                .solve(Interaction::HardWall, pressure, &opts, None)
                .expect("solve");
            let (cpu, wall) = (cpu_seconds() - c0, t0.elapsed().as_secs_f64());
            println!(
                "n = {n} ({0}²): load {load} p_fc = {pressure:.6e}, {1} iterations, {cpu:.2} s CPU, \
                 {wall:.2} s wall, area {2:.6}, violation {3:.2e}, converged {4}",
                1usize << n,
                sol.stats.iterations,
                sol.contact_area,
                sol.stats.max_violation,
                sol.stats.converged
            );
            println!(
                "RESULT random_surface n={n} threads={threads} load_over_p_fc={load} \
                 iterations={} cpu_s={cpu:.4} wall_s={wall:.4} area={:.8} violation={:.3e}",
                sol.stats.iterations, sol.contact_area, sol.stats.max_violation
            );
            if let Some(dir) = &dump {
                write_f64(&format!("{dir}/random_heights_n{n}.f64"), h.iter().copied());
                write_f64(
                    &format!("{dir}/random_pressure_n{n}.f64"),
                    sol.pressure.iter().copied(),
                );
                std::fs::write(
                    format!("{dir}/random_case_n{n}.json"),
                    format!("{{\"n\": {n}, \"pressure\": {pressure:?}, \"p_fc\": {p_fc:?}}}"),
                )
                .expect("case file");
            }
        });
    }
}
