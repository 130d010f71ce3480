//! Exploration: one grid per model, printing brackets, areas and the saddle fit.
//! `cargo run --release -p critical --example explore -- square 7 0.0 0.0`
use critical::{CriticalOptions, find_critical};
use surface::{Grid, Lattice, Surface};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let lattice: Lattice = a[1].parse().unwrap();
    let n: u32 = a[2].parse().unwrap();
    let sx: f64 = a.get(3).map_or(0.0, |s| s.parse().unwrap());
    let sy: f64 = a.get(4).map_or(0.0, |s| s.parse().unwrap());
    let grid = Grid::new(lattice, n).unwrap().shifted(sx, sy).unwrap();
    let s = Surface::on_grid(lattice, grid);
    let mut o = CriticalOptions::default();
    if let Ok(v) = std::env::var("SADDLE") {
        let (a, b, k): (f64, f64, usize) = {
            let p: Vec<&str> = v.split(',').collect();
            (
                p[0].parse().unwrap(),
                p[1].parse().unwrap(),
                p[2].parse().unwrap(),
            )
        };
        o.saddle_loads = (0..k)
            .map(|i| -a * (b / a).powf(i as f64 / (k - 1) as f64))
            .collect();
    }
    if let Ok(t) = std::env::var("TOL") {
        o.tol_gap = t.parse().unwrap();
    }
    let r = find_critical(&s, &o, None).unwrap();
    println!(
        "{lattice} n={n} shift=({sx},{sy}) p_fc={:.6} wall={:.2}s probes={} samples={} iters={}",
        r.p_fc, r.wall_s, r.probes, r.sample_solves, r.iterations
    );
    for (name, t) in [("any", &r.any), ("x", &r.x), ("y", &r.y)] {
        println!(
            "  {name:>3}: L_c={:.10} [{:.12}, {:.12}] w={:.1e} a_raw={:.6} a_corr={:.6} bridging={} p_fc/L_c={:.4}",
            t.l_c(),
            t.bracket.lo,
            t.bracket.hi,
            t.bracket.rel_width(),
            t.a_p_raw(),
            t.a_p_corrected(),
            t.bridging_nodes(),
            r.p_fc / t.l_c()
        );
    }
    for g in &r.groups {
        println!("  group {:.1}° {:?}", g.angle_deg, g.points);
    }
    for smp in &r.samples {
        println!(
            "  l={:+.4} L={:.6} a={:.5} gaps={:?}",
            smp.reduced, smp.load, smp.area, smp.gap
        );
    }
    if let Some(sub) = &r.subgrid {
        for f in &sub.fits {
            println!(
                "  fit {:.0}°: L_c={:.7}±{:.1e} zeta={:.4}±{:.1e} chi2r={:.2e} pegged={} pts={}",
                f.angle_deg,
                f.l_c.0,
                f.l_c.1,
                f.zeta.0,
                f.zeta.1,
                f.reduced_chi2,
                f.pegged,
                f.points
            );
        }
        println!(
            "  subgrid L_c={:.7}±{:.1e} zeta={:.4}±{:.1e}",
            sub.l_c, sub.l_c_error, sub.zeta, sub.zeta_error
        );
    }
    for n in &r.notes {
        println!("  note: {n}");
    }
}
