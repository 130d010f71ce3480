//! One composite (refined) Polonsky–Keer solve pair near p_c, for the solver's convergence:
//! `pk_near_pc <model> <base_log2> <k> <window> <margin> <p0/p_fc> <p1/p_fc>`: solves cold at p0,
//! then at p1 warm-started from p0's solution, then p1 cold; prints iterations, violation,
//! contact count and CPU-relevant wall time of each (run with RAYON_NUM_THREADS=1).
//! `PK_TOL` (default 5e-12), `PK_MAX_ITER` (default 3000).
use contact::SolverOptions;
use contact::refinement::{RefineOptions, RefinedModel, Window};
use critical::ladder::axis_saddle;
use std::time::Instant;
use surface::{Lattice, Surface};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let lat: Lattice = a[1]
        .parse()
        .expect("model: square, hexagonal or triangular");
    let num = |i: usize| a[i].parse::<f64>().expect("number");
    let (n, k, w, margin) = (
        num(2) as u32,
        num(3) as u32,
        num(4) as usize,
        num(5) as usize,
    );
    let env = |k: &str, d: f64| std::env::var(k).map_or(d, |v| v.parse().expect(k));
    let s = Surface::new(lat, n).unwrap();
    let f = axis_saddle(&s).unwrap();
    let ropts = RefineOptions {
        levels: k,
        window: Window::centred(&s.grid, f.x, f.y, w, w),
        solver: SolverOptions {
            tol_gap: env("PK_TOL", 5e-12),
            max_iter: env("PK_MAX_ITER", 3000.0) as usize,
            ..Default::default()
        },
    };
    let t = Instant::now();
    let mut m = RefinedModel::blockwise(&s, &ropts, margin).unwrap();
    println!("setup {:.2} s", t.elapsed().as_secs_f64());
    let p_fc = s.p_fc_grid();
    let mut run = |what: &str, p: f64, warm: Option<&contact::refinement::Refined>| {
        let t = Instant::now();
        let r = m.solve(p * p_fc, warm).unwrap();
        let count = r.composite.pressure.iter().filter(|&&v| v > 0.0).count();
        println!(
            "{what}: load/p_fc {p} iterations {} converged {} violation {:.3e} contacts {count} {:.2} s",
            r.stats.iterations,
            r.stats.converged,
            r.stats.max_violation,
            t.elapsed().as_secs_f64()
        );
        r
    };
    let r0 = run("p0 cold", num(6), None);
    let p1 = num(7);
    run("p1 warm", p1, Some(&r0));
    run("p1 cold", p1, None);
}
