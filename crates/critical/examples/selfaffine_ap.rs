//! Relative contact area at the fluid percolation threshold of isotropic self-affine surfaces,
//! over an ensemble of seeds (docs/surfaces.md). One JSON line per seed on stdout, then a summary
//! line; progress on stderr.
//!
//! ```sh
//! cargo run --release -p critical --example selfaffine_ap -- N SEED_FIRST SEED_LAST \
//!     [REL_WIDTH [exact|gaussian [SUB]]]
//! ```
//! `SUB` > 0: the surface generated on 2^N × 2^N is sampled at every 2^SUB-th node (the same
//! continuum surface on a coarser grid, exact as long as q_s stays below the coarse grid's
//! Nyquist wavenumber 2^(N−SUB−1)), for a resolution study on the same surfaces.
//! H = 0.8, q_r = 2, q_s = 64 (units of 2π/L), rms slope 1 (the hard-wall threshold area does not
//! depend on the normalisation: scaling the heights scales every load), exact amplitudes,
//! periodic boundary.

use critical::leakage::{Boundary, PercolationOptions, percolation_load};
use surface::Amplitudes;

mod common;
use analysis::sample::mean_sd_sem;
use common::{EnsembleSurface, Positional};

fn main() {
    let args = Positional::from_env();
    let (n, seeds) = args.grid_and_seeds("10");
    let rel_width: f64 = args.get(3, "1e-6", "REL_WIDTH");
    let amplitudes = match args.get::<String>(4, "exact", "exact|gaussian").as_str() {
        "gaussian" => Amplitudes::Gaussian,
        _ => Amplitudes::Exact,
    };
    let sub: u32 = args.get(5, "0", "SUB");
    let surfaces = EnsembleSurface {
        n,
        hurst: 0.8,
        q_s: 64.0,
        amplitudes,
        sub,
    };
    let mut a = Vec::new();
    for seed in seeds {
        let field = surfaces.generate(seed);
        let opts = PercolationOptions {
            rel_width,
            ..Default::default()
        };
        let r = percolation_load(&field, Boundary::Periodic, &opts).expect("percolation load");
        println!(
            "{{\"n\": {n}, \"sub\": {sub}, \"seed\": {seed}, \"p_fc\": {}, \"l_c\": {}, \"l_c_over_p_fc\": {}, \
             \"a_p_raw\": {}, \"a_p_corrected\": {}, \"a_p_x\": {}, \"a_p_y\": {}, \
             \"bridging_nodes\": {}, \"probes\": {}, \"iterations\": {}, \"retries\": {}, \"wall_s\": {}}}",
            r.p_fc,
            r.any.l_c(),
            r.any.l_c() / r.p_fc,
            r.any.a_p_raw(),
            r.any.a_p_corrected(),
            r.x.a_p_raw(),
            r.y.a_p_raw(),
            r.any.bridging_nodes(),
            r.probes,
            r.iterations,
            r.retries,
            r.wall_s
        );
        eprintln!(
            "seed {seed}: a_p = {:.4} (corrected {:.4}), {} probes, {:.0} s",
            r.any.a_p_raw(),
            r.any.a_p_corrected(),
            r.probes,
            r.wall_s
        );
        a.push((r.any.a_p_raw(), r.any.a_p_corrected()));
    }
    let stat = |v: Vec<f64>| {
        let (m, sd, sem, _) = mean_sd_sem(&v);
        (m, sd, sem)
    };
    let (m, sd, sem) = stat(a.iter().map(|x| x.0).collect());
    let (mc, sdc, semc) = stat(a.iter().map(|x| x.1).collect());
    println!(
        "{{\"summary\": true, \"n\": {n}, \"sub\": {sub}, \"seeds\": {}, \"a_p_raw_mean\": {m}, \"a_p_raw_sd\": {sd}, \
         \"a_p_raw_sem\": {sem}, \"a_p_corrected_mean\": {mc}, \"a_p_corrected_sd\": {sdc}, \
         \"a_p_corrected_sem\": {semc}}}",
        a.len()
    );
}
