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
use surface::{Amplitudes, Normalisation, SelfAffine};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let num = |k: usize, d: &str| -> String { args.get(k).cloned().unwrap_or(d.into()) };
    let n: u32 = num(0, "10").parse().expect("N: grid exponent");
    let first: u64 = num(1, "1").parse().expect("SEED_FIRST");
    let last: u64 = num(2, "8").parse().expect("SEED_LAST");
    let rel_width: f64 = num(3, "1e-6").parse().expect("REL_WIDTH");
    let amplitudes = match num(4, "exact").as_str() {
        "gaussian" => Amplitudes::Gaussian,
        _ => Amplitudes::Exact,
    };
    let sub: u32 = num(5, "0").parse().expect("SUB");
    let mut a = Vec::new();
    for seed in first..=last {
        let field = SelfAffine {
            n,
            length: 1.0,
            hurst: 0.8,
            q_r: 2.0,
            q_s: 64.0,
            normalisation: Normalisation::RmsSlope(1.0),
            amplitudes,
            seed,
        }
        .generate()
        .expect("surface");
        let field = if sub == 0 {
            field
        } else {
            let step = 1usize << sub;
            let nn = (1usize << n) / step;
            let heights = field
                .heights
                .slice(ndarray::s![..;step, ..;step])
                .to_owned();
            let grid = surface::Grid::periodic(nn, nn, 1.0, 1.0).expect("grid");
            surface::HeightField::new(grid, heights).expect("field")
        };
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
        let m = v.iter().sum::<f64>() / v.len() as f64;
        let sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() as f64 - 1.0)).sqrt();
        (m, sd, sd / (v.len() as f64).sqrt())
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
