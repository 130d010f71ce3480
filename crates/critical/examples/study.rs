//! Exploration: resolution study for one model.
//! `cargo run --release -p critical --example study -- square 6,7,8 4`
use critical::{ResolutionOptions, resolution_study};
use surface::Lattice;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let lattice: Lattice = a[1].parse().unwrap();
    let ns: Vec<u32> = a[2].split(',').map(|s| s.parse().unwrap()).collect();
    let k: usize = a[3].parse().unwrap();
    let mut o = ResolutionOptions::new(ns, k);
    if let Ok(v) = std::env::var("SADDLE") {
        let (a, b, k): (f64, f64, usize) = {
            let p: Vec<&str> = v.split(',').collect();
            (
                p[0].parse().unwrap(),
                p[1].parse().unwrap(),
                p[2].parse().unwrap(),
            )
        };
        o.critical.saddle_loads = if k == 0 {
            vec![]
        } else {
            (0..k)
                .map(|i| -a * (b / a).powf(i as f64 / (k - 1) as f64))
                .collect()
        };
    }
    if let Ok(v) = std::env::var("WIDTH") {
        o.critical.rel_width = v.parse().unwrap();
    }
    let s = resolution_study(lattice, &o).unwrap();
    for l in &s.levels {
        let av = &l.average;
        println!(
            "n={:2} h={:.5} K={} wall={:6.1}s solves={} iters={}",
            l.n,
            l.h,
            l.shifts.len(),
            l.wall_s,
            l.solves(),
            l.iterations()
        );
        for (nm, t) in [("any", &av.any), ("x", &av.x), ("y", &av.y)] {
            println!(
                "   {nm:>3} L_c={:.8}±{:.1e} a_raw={:.6}±{:.1e} a_corr={:.6}±{:.1e}",
                t.l_c.mean,
                t.l_c.sem,
                t.a_p_raw.mean,
                t.a_p_raw.sem,
                t.a_p_corrected.mean,
                t.a_p_corrected.sem
            );
        }
        if let Some(sg) = av.l_c_subgrid {
            println!(
                "   subgrid L_c={:.7}±{:.1e} zeta={:.4}",
                sg.mean,
                sg.sem,
                av.zeta.unwrap().mean
            );
        }
        for r in &l.results {
            println!(
                "      shift ({:.3},{:.3}) any L_c={:.8} a_raw={:.6} a_corr={:.6} | x {:.8} {:.6} | y {:.8} {:.6}",
                r.grid.shift.0,
                r.grid.shift.1,
                r.any.l_c(),
                r.any.a_p_raw(),
                r.any.a_p_corrected(),
                r.x.l_c(),
                r.x.a_p_corrected(),
                r.y.l_c(),
                r.y.a_p_corrected()
            );
        }
    }
    for e in &s.extrapolations {
        match &e.fit {
            Ok(f) => println!(
                "{:>22}: v0={:.7} ± {:.1e} (fit {:.1e}, subset {:?}) order={:.2}±{:.2}",
                e.name,
                f.v0,
                f.v0_error,
                f.v0_fit_error,
                f.v0_subset_spread,
                f.order,
                f.order_error
            ),
            Err(m) => println!("{:>22}: {m}", e.name),
        }
    }
    if let Some((r, e)) = s.p_fc_over_l_c() {
        println!("p_fc/L_c = {r:.5} ± {e:.1e}");
    }
    println!("total wall {:.1}s", s.wall_s);
}
