//! Transform benchmark: `cargo bench -p contact --bench spectral`.
//!
//! CPU time of one convolution `ElasticKernel::stress` (a real 2-D FFT pair with the stiffness
//! multiplier: row transforms, the column pass of `contact::spectral`, inverse row transforms;
//! what FIRE and nonlinear CG call) and of one `ElasticKernel::apply_fused` with empty callbacks
//! (the same pair plus the quadratic form taken in Fourier space; what Polonsky–Keer calls)
//! on square grids, in a rayon pool of one thread (as the draft's stages mostly run: the grids
//! below `spectral::PARALLEL_MIN_NODES` are serial anyway). Each grid is repeated until
//! `SPECTRAL_MIN_CPU` seconds (default 1) of CPU time are spent; the smallest of
//! `SPECTRAL_REPEATS` (default 3) such timings is reported. The output's bits (and the
//! quadratic form's) are hashed (FNV-1a), so two builds can be compared for bit-identical results.
//!
//! Environment: `SPECTRAL_NS` grid exponents (default `6,7,8,9,10`), `SPECTRAL_MIN_CPU`,
//! `SPECTRAL_REPEATS`. Each case prints one machine-readable line starting with `RESULT`.

mod cpu_time;

use contact::elastic::ElasticKernel;
use contact::{Grid, Lattice};

fn env<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn main() {
    let ns: Vec<u32> = env("SPECTRAL_NS", "6,7,8,9,10".to_string())
        .split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| s.trim().parse().expect("SPECTRAL_NS: grid exponents"))
        .collect();
    let min_cpu: f64 = env("SPECTRAL_MIN_CPU", 1.0);
    let repeats: usize = env("SPECTRAL_REPEATS", 3);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    pool.install(|| {
        for n in ns {
            let grid = Grid::new(Lattice::Square, n).expect("grid");
            let mut kernel = ElasticKernel::new(&grid, 1.0);
            let len = grid.len();
            // a deterministic field with every wave present
            let mut x = 0x9e37_79b9_7f4a_7c15u64;
            let u: Vec<f64> = (0..len)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
                })
                .collect();
            let mut sigma = vec![0.0; len];
            let mut fused_in = u.clone();
            let mut quadratic = 0.0;
            for fused in [false, true] {
                let mut best = f64::INFINITY;
                let mut calls = 0usize;
                for _ in 0..repeats {
                    let t0 = cpu_time::cpu_seconds();
                    let mut k = 0usize;
                    loop {
                        if fused {
                            fused_in.copy_from_slice(&u);
                            quadratic = kernel
                                .apply_fused(
                                    true,
                                    &mut fused_in,
                                    |_, _| [0.0; 4],
                                    Some(&mut sigma),
                                    |_, _, _| [0.0; 4],
                                )
                                .1;
                        } else {
                            kernel.stress(&u, &mut sigma);
                        }
                        k += 1;
                        let dt = cpu_time::cpu_seconds() - t0;
                        if dt >= min_cpu {
                            best = best.min(dt / k as f64);
                            calls += k;
                            break;
                        }
                    }
                }
                let mut hash = 0xcbf2_9ce4_8422_2325u64;
                for v in sigma.iter().chain(fused.then_some(&quadratic)) {
                    for b in v.to_bits().to_le_bytes() {
                        hash = (hash ^ b as u64).wrapping_mul(0x100_0000_01b3);
                    }
                }
                let what = if fused { "fused" } else { "stress" };
                println!(
                    "{}² {what:6}: {:9.1} µs per convolution ({} calls), output hash {hash:016x}",
                    1usize << n,
                    best * 1e6,
                    calls
                );
                println!(
                    "RESULT spectral n={n} call={what} us_per_convolution={:.2} hash={hash:016x}",
                    best * 1e6
                );
            }
        }
    });
}
