//! Flow through a locally refined saddle against the uniform fine grid
//! ([`critical::window_flow`]): p_c of each discretisation (bisection on the saddle node's gap),
//! then per reduced load the saddle gap, the cell's K along the channel (uniform, refined
//! composite, base alone) and the running exponents β_eff = d ln K / d ln |l| and
//! ζ_eff = d ln g_s / d ln |l| between neighbouring loads.
//!
//! `cargo run --release -p critical --example window_flow -- [key=value ...]` with keys
//! `lattice` (square), `n` (base exponent, 5), `k` (levels, 2), `region` (base cells, 8),
//! `margin` (blockwise margin; `none` = full composite operator, default none),
//! `trim_along` (2), `trim_across` (1), `loads` (comma list, default
//! -1e-2,-5e-3,-2e-3,-1e-3,-5e-4), `uniform` (1: also the uniform 2^(n+k) reference),
//! `tol_gap` (1e-13), `rel_width` (1e-9), `bracket` (p_c bracket as fractions of p_fc, 0.2,0.25).
use critical::window_flow::{CompareOptions, compare, running};

mod common;

fn main() {
    let mut o = CompareOptions::default();
    for kv in common::KeyValue::from_env() {
        match kv.key.as_str() {
            "lattice" => o.lattice = kv.parse(),
            "n" => o.base_n = kv.parse(),
            "k" => o.levels = kv.parse(),
            "region" => o.region = kv.parse(),
            "margin" => o.margin = kv.optional(),
            "trim_along" => o.trim_along = kv.parse(),
            "trim_across" => o.trim_across = kv.parse(),
            "loads" => o.loads = kv.list(),
            "uniform" => o.uniform = kv.value == "1",
            "tol_gap" => o.tol_gap = kv.parse(),
            "rel_width" => o.rel_width = kv.parse(),
            "bracket" => match kv.list::<f64>()[..] {
                [a, b] => o.bracket = (a, b),
                _ => kv.bad(&"expected lo,hi (fractions of p_fc)"),
            },
            other => panic!(
                "unknown key {other:?}: lattice, n, k, region, margin, trim_along, trim_across, loads, uniform, tol_gap, rel_width, bracket"
            ),
        }
    }
    println!("{o:?}");
    let c = compare(&o).unwrap_or_else(|e| panic!("{e}"));
    println!(
        "p_c/p_fc: refined {:.10}, uniform {}; flow axis {:?}, flow window {:?}",
        c.pc_refined,
        c.pc_uniform.map_or("-".into(), |p| format!(
            "{p:.10} (refined {:+.2e})",
            c.pc_refined / p - 1.0
        )),
        c.axis,
        c.window
    );
    println!(
        "wall: refined {:.1} s, uniform {:.1} s",
        c.wall_refined, c.wall_uniform
    );
    println!(
        "{:>9} {:>12} {:>10} {:>12} {:>12} {:>10} {:>12} {:>10} {:>8} {:>8} {:>5} {:>10}",
        "l",
        "g_s refined",
        "g_s err",
        "K uniform",
        "K refined",
        "K err",
        "K base",
        "base err",
        "share",
        "spread",
        "open",
        "method"
    );
    for r in &c.rows {
        let w = &r.refined;
        let rel = |a: f64, b: Option<f64>| b.map_or(f64::NAN, |b| a / b - 1.0);
        println!(
            "{:>9.1e} {:>12.6e} {:>+10.2e} {:>12.6e} {:>12.6e} {:>+10.2e} {:>12.6e} {:>+10.2e} {:>8.6} {:>8.1e} {:>5} {:>+10.2e}",
            r.l,
            r.gap_refined,
            rel(r.gap_refined, r.gap_uniform),
            r.k_uniform.unwrap_or(f64::NAN),
            w.conductivity,
            rel(w.conductivity, r.k_uniform),
            w.conductivity_coarse,
            rel(w.conductivity_coarse, r.k_uniform),
            w.neck_share,
            w.isobar_spread,
            w.open_side_nodes,
            r.k_uniform_windowed
                .map_or(f64::NAN, |k| rel(k, r.k_uniform))
        );
    }
    let ls: Vec<f64> = c.rows.iter().map(|r| r.l).collect();
    let col = |f: &dyn Fn(&critical::window_flow::CompareRow) -> f64| -> Vec<f64> {
        c.rows.iter().map(f).collect()
    };
    let b_ref = running(&ls, &col(&|r| r.refined.conductivity));
    let b_base = running(&ls, &col(&|r| r.refined.conductivity_coarse));
    // the fine window's own flux (the neck alone, without the rest of the cell)
    let b_win = running(&ls, &col(&|r| r.refined.flux_window_fine));
    let z_ref = running(&ls, &col(&|r| r.gap_refined));
    let (b_uni, z_uni) = if o.uniform {
        (
            running(&ls, &col(&|r| r.k_uniform.unwrap())),
            running(&ls, &col(&|r| r.gap_uniform.unwrap())),
        )
    } else {
        (vec![f64::NAN; b_ref.len()], vec![f64::NAN; b_ref.len()])
    };
    println!(
        "{:>9} {:>9} {:>9} {:>9} {:>10} {:>9} {:>10} {:>9} {:>10}",
        "l_hi", "l_lo", "β uni", "β ref", "β err", "β base", "base err", "ζ ref", "ζ err"
    );
    for i in 0..b_ref.len() {
        println!(
            "{:>9.1e} {:>9.1e} {:>9.5} {:>9.5} {:>+10.2e} {:>+10.2e} {:>9.5} {:>+10.2e} {:>9.5} {:>+10.2e}",
            ls[i],
            ls[i + 1],
            b_uni[i],
            b_ref[i],
            b_ref[i] - b_uni[i],
            b_win[i] - b_ref[i],
            b_base[i],
            b_base[i] - b_uni[i],
            z_ref[i],
            z_ref[i] - z_uni[i]
        );
    }
}
