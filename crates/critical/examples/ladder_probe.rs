//! Probe of the load ladder on one model and grid: L_c (unshifted grid, sub-grid when available),
//! then the ladder, the per-rung measurements and the exponent fits.
//! `cargo run --release -p critical --example ladder_probe -- square 9 0.15`
use critical::ladder::{LadderOptions, axis_saddle, solve_ladder};
use critical::scaling::{EdgeOptions, blocked_half_length, fit_exponent, open_half_width};
use critical::{CriticalOptions, find_critical};
use std::time::Instant;
use surface::{Lattice, Surface};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let lat = match a[1].as_str() {
        "square" => Lattice::Square,
        "hexagonal" => Lattice::Hexagonal,
        _ => Lattice::Triangular,
    };
    let n: u32 = a[2].parse().unwrap();
    let window: f64 = a[3].parse().unwrap();
    let s = Surface::new(lat, n).unwrap();
    let t = Instant::now();
    let c = find_critical(&s, &CriticalOptions::default(), None).unwrap();
    let l_c = c.subgrid.as_ref().map_or(c.l_c(), |g| g.l_c);
    println!(
        "L_c grid {} subgrid {:?} ({:.1} s)",
        c.l_c(),
        c.subgrid.as_ref().map(|g| (g.l_c, g.zeta)),
        t.elapsed().as_secs_f64()
    );
    let f = axis_saddle(&s).unwrap();
    println!("{f:?}");
    let ls = [-0.02, -0.01, -0.005, -0.002, 0.002, 0.005, 0.01, 0.02];
    let t = Instant::now();
    let rungs = solve_ladder(
        &s,
        &f,
        l_c,
        &ls,
        &LadderOptions {
            window,
            ..Default::default()
        },
        None,
        &mut |r, _| {
            println!(
                "l {:+.3} it {} conv {} {:.2}s",
                r.l, r.iterations, r.converged, r.wall_s
            )
        },
    )
    .unwrap();
    println!("ladder {:.1} s", t.elapsed().as_secs_f64());
    let (mut lm, mut gs, mut wd, mut lp, mut al) = (vec![], vec![], vec![], vec![], vec![]);
    for r in &rungs {
        if r.l < 0.0 {
            let e = open_half_width(&r.window, &EdgeOptions::default());
            println!(
                "l {:+.3} g_s {:.4e} half-width {:?}",
                r.l,
                r.window.saddle_gap(),
                e
            );
            lm.push(r.l);
            gs.push(r.window.saddle_gap());
            wd.push(e.map(|e| e.r).unwrap_or(f64::NAN));
        } else {
            let e = blocked_half_length(&r.window);
            println!("l {:+.3} half-length {:?}", r.l, e);
            lp.push(r.l);
            al.push(e.map(|e| e.r).unwrap_or(f64::NAN));
        }
    }
    println!("zeta {:?}", fit_exponent(&lm, &gs));
    println!("upsilon {:?}", fit_exponent(&lm, &wd));
    println!("chi {:?}", fit_exponent(&lp, &al));
}
