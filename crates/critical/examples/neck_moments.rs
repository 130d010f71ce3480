//! υ and χ from the neck's gap field ([`critical::neck_moments`]) against the contact-line fits,
//! on refined ladders at several levels k of one base grid:
//! `cargo run --release -p critical --example neck_moments -- <model> <base_log2> <k_lo> <k_hi>
//! <window> <margin> [ls]` (ls comma-separated; default −1e-2 … −1e-5 and +1e-4 … +5e-3).
//!
//! Solves p_c(D) and the ladder of D(k) for k = k_lo … k_hi (same window and margin; each p_c
//! search starts from the previous one) and prints per rung (`rung,…`) the saddle gap, the open
//! half-width r_c of [`critical::scaling::open_half_width`] (as `Refinement::ladder` records it)
//! or the blocked half-length a, and the three neck lengths (rms width p = 2 and p = 1, level
//! width at g = g_s/2, rise length to g = 2 g_s); then per pair of neighbouring rungs and level
//! the running exponents and their change from k − 1 (`pair,…`).
//! `NECK_PC_GUESS`: p_c/p_fc to start the first p_c search from (skips the periodic base grid's
//! search). `NECK_PC_WIDTH` (default 2e-5): the relative width of every p_c search around its
//! guess (the first one's `NECK_PC_GUESS`, the next ones' the previous level's p_c; the pipeline
//! takes 2e-6 between levels; without `NECK_PC_GUESS` the first search takes 2e-4 around the
//! base grid's p_c). `NECK_TOL_GAP` (default 1e-12), `NECK_MAX_ITER` (default 3000):
//! the solver's tolerance and iteration cap per attempt.
//! `NECK_FLUX=1`: also the refined flux of every rung below p_c(D), as the pipeline's
//! `refined_ladder` kind measures it (as [`critical::refined_flow::ladder_with_flux`], with the
//! model's [`FluxMethod::of`]: the square cell's conductivity along the channel, elsewhere the
//! refined saddle's two-terminal conductance), printed per rung after each level's ladder
//! (`flux,…`: conductance, its 1σ, open fine nodes on the flow window's sides, flow wall time,
//! why none); its running β_eff = ln(K(l_hi)/K(l_lo)) / ln(l_hi/l_lo) and change from k − 1 end
//! each `pair` row (`beta,d_beta`; NaN without `NECK_FLUX`). `NECK_FLOW_SWEEPS`,
//! `NECK_FLOW_TOL`, `NECK_FLOW_MAX_ITER`: the flux's flow solver options (default
//! `reynolds::FlowOptions::default()`, the pipeline's: 1 sweep, 1e-10, 200).
//! `NECK_PC`: p_c/p_fc of the first level, given (no search; e.g. to rerun a level's rungs with
//! other flow options).
//! `NECK_COARSE_FLIPS=1`: after each level's ladder, per rung (`flips,…`) the number of base
//! nodes outside the fine region in contact, how many changed state since the previous rung,
//! and the distance (base cells) of the nearest changed one from the region's centre: the
//! coarse region's contact set changes one base node at a time (docs/near-critical.md §5n).
use critical::neck_moments::{NeckOptions, across_rms, neck_lengths};
use critical::refined::{Discretisation, RefinedOptions, Refinement, base_guess};
use critical::refined_flow::{FluxMethod, FluxSetup, ladder_rung_flux};
use std::collections::BTreeMap;
use std::io::Write;
use std::time::Instant;
use surface::Lattice;

/// The lengths of one rung (λ; NaN where the estimator or fit has no value).
#[derive(Clone, Debug)]
struct Row {
    l: f64,
    gap: f64,
    /// open_half_width r_c (l < 0) or blocked_half_length a (l > 0), and its 1σ
    edge: (f64, f64),
    rms2: f64,
    rms1: f64,
    level: f64,
    rise: f64,
    /// the refined flux's conductance (l < 0, `NECK_FLUX`; NaN otherwise)
    flux: f64,
    flagged: bool,
}

const NAMES: [&str; 7] = ["gap", "edge", "rms2", "rms1", "level", "rise", "beta"];

impl Row {
    fn get(&self, k: usize) -> f64 {
        [
            self.gap,
            self.edge.0,
            self.rms2,
            self.rms1,
            self.level,
            self.rise,
            self.flux,
        ][k]
    }
}

/// The coarse contact set of a rung (base nodes outside the fine region with pressure > 0):
/// its size, how many nodes changed state since the previous rung of the level, and the
/// periodic distance (base cells) from the fine region's centre of the nearest one that did.
fn coarse_flips(
    l: f64,
    rr: &contact::refinement::Refined,
    previous: &mut Option<Vec<bool>>,
) -> String {
    let (nx, ny) = rr.base_pressure.dim();
    let f = rr.lattice.0 / nx;
    let (x0, y0) = (rr.origin.0 / f, rr.origin.1 / f);
    let (wx, wy) = (rr.window_grid.nx / f, rr.window_grid.ny / f);
    let inside = |i: usize, j: usize| (i + nx - x0) % nx <= wx && (j + ny - y0) % ny <= wy;
    let (cx, cy) = (x0 as f64 + wx as f64 / 2.0, y0 as f64 + wy as f64 / 2.0);
    let mask: Vec<bool> = (0..nx * ny)
        .map(|k| !inside(k / ny, k % ny) && rr.base_pressure[[k / ny, k % ny]] > 0.0)
        .collect();
    let contacts = mask.iter().filter(|&&c| c).count();
    let (mut flipped, mut nearest) = (0usize, f64::INFINITY);
    if let Some(p) = previous.as_ref() {
        for (k, (a, b)) in mask.iter().zip(p).enumerate() {
            if a != b {
                flipped += 1;
                let d = |a: f64, c: f64, n: usize| {
                    let d = (a - c).rem_euclid(n as f64);
                    d.min(n as f64 - d)
                };
                let r = d((k / ny) as f64, cx, nx).hypot(d((k % ny) as f64, cy, ny));
                nearest = nearest.min(r);
            }
        }
    }
    *previous = Some(mask);
    format!("{l:e},{contacts},{flipped},{nearest:.1}")
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_default()
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 7 {
        eprintln!("usage: neck_moments <model> <base_log2> <k_lo> <k_hi> <window> <margin> [ls]");
        std::process::exit(2);
    }
    let lattice: Lattice = a[1].parse().expect("model");
    let base_log2: u32 = a[2].parse().expect("base_log2");
    let k_lo: u32 = a[3].parse().expect("k_lo");
    let k_hi: u32 = a[4].parse().expect("k_hi");
    let window: usize = a[5].parse().expect("window (base cells)");
    let margin: usize = a[6].parse().expect("margin (base cells)");
    let ls: Vec<f64> = a.get(7).map_or_else(
        || {
            vec![
                -1e-2, -5e-3, -2e-3, -1e-3, -5e-4, -2e-4, -1e-4, -5e-5, -2e-5, -1e-5, 1e-4, 2e-4,
                5e-4, 1e-3, 2e-3, 5e-3,
            ]
        },
        |s| {
            s.split(',')
                .map(|v| v.trim().parse().expect("ls"))
                .collect()
        },
    );
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    let opts = RefinedOptions {
        tol_gap: env("NECK_TOL_GAP").unwrap_or(1e-12),
        max_iter: env("NECK_MAX_ITER").map_or(3000, |v| v as usize),
        ..RefinedOptions::default()
    };
    let with_flux = std::env::var("NECK_FLUX").is_ok_and(|v| v == "1");
    let flips = std::env::var("NECK_COARSE_FLIPS").is_ok_and(|v| v == "1");
    let pc_width = env("NECK_PC_WIDTH").unwrap_or(2e-5);
    let t0 = Instant::now();
    println!(
        "# {} 2^{base_log2}, k = {k_lo}..{k_hi}, window {window}, margin {margin}, tol_gap {:e}, max_iter {}, p_c width {pc_width:e}, flux {}, load average {}",
        lattice.name(),
        opts.tol_gap,
        opts.max_iter,
        if with_flux {
            FluxMethod::of(lattice).name()
        } else {
            "no"
        },
        load_average()
    );
    let mut d = Discretisation {
        lattice,
        base_log2,
        levels: k_lo,
        window,
        margin,
    };
    // NECK_PC_GUESS: p_c/p_fc to start the first search from (width NECK_PC_WIDTH) instead of the
    // periodic base grid's search (minutes on a 1024² base)
    let known_pc = env("NECK_PC");
    let (mut guess, mut width, p_fc) = match env("NECK_PC_GUESS").or(known_pc) {
        Some(g) => {
            let p_fc = surface::Surface::new(lattice, base_log2)
                .expect("surface")
                .p_fc_grid();
            (g * p_fc, pc_width, p_fc)
        }
        None => {
            let (base, p_fc) = base_guess(d, &opts).expect("base p_c");
            (base.p_c(), 2e-4, p_fc)
        }
    };
    println!(
        "rung,k,l,saddle_gap,neck_nodes,edge,edge_sigma,rms2,rms1,level,level_asym,rise,rise_asym,flag,notes"
    );
    let no = NeckOptions::default();
    let mut levels: BTreeMap<u32, Vec<Row>> = BTreeMap::new();
    for k in k_lo..=k_hi {
        d = d.with_levels(k);
        let t = Instant::now();
        let mut r = Refinement::new(d, &opts).expect("refined discretisation");
        let c = match known_pc.filter(|_| k == k_lo) {
            Some(v) => critical::refined::ClosingLoad {
                lo: v * p_fc,
                hi: v * p_fc,
                probes: 0,
            },
            None => r.critical_load(Some(guess), width).expect("p_c"),
        };
        let pc = c.p_c();
        println!(
            "# k = {k}: p_c/p_fc {:.12} ({} probes, {:.1} s, load average {})",
            pc / p_fc,
            c.probes,
            t.elapsed().as_secs_f64(),
            load_average()
        );
        std::io::stdout().flush().ok();
        let mut rows = Vec::new();
        // the flux as critical::refined_flow::ladder_with_flux measures it, with the flow
        // options of the environment
        let setup = with_flux.then(|| {
            let mut s = FluxSetup::new(&r, FluxMethod::of(lattice)).expect("flux set-up");
            if let Some(v) = env("NECK_FLOW_SWEEPS") {
                s.flow.smoothing_sweeps = v as usize;
            }
            if let Some(v) = env("NECK_FLOW_TOL") {
                s.flow.tolerance = v;
            }
            if let Some(v) = env("NECK_FLOW_MAX_ITER") {
                s.flow.max_iterations = v as usize;
            }
            s
        });
        let mut fluxes = Vec::new();
        let mut previous: Option<Vec<bool>> = None;
        let mut flip_rows = Vec::new();
        let mut on_rung = |g: &critical::refined::RefinedRung,
                           rr: &contact::refinement::Refined,
                           w: &critical::ladder::Window| {
            if let Some(setup) = &setup {
                fluxes.push(ladder_rung_flux(setup, g, rr));
            }
            if flips {
                flip_rows.push(coarse_flips(g.l, rr, &mut previous));
            }
            let nl = neck_lengths(w, &no);
            let edge = if g.l < 0.0 {
                g.half_width
            } else {
                g.half_length
            };
            let mut notes = Vec::new();
            if let Some(e) = &g.edge_note {
                notes.push(format!("edge: {e}"));
            }
            let val = |r: Result<f64, critical::neck_moments::NeckError>,
                       what: &str,
                       notes: &mut Vec<String>| match r {
                Ok(v) => v,
                Err(e) => {
                    notes.push(format!("{what}: {e}"));
                    f64::NAN
                }
            };
            let (rms2, rms1, level, rise, la, ra) = if g.l < 0.0 {
                let lv = nl.across_level.clone().map(|t| (t.value, t.asymmetry));
                let rv = nl.along_rise.clone().map(|t| (t.value, t.asymmetry));
                let (level, la) = match lv {
                    Ok(v) => v,
                    Err(e) => {
                        notes.push(format!("level: {e}"));
                        (f64::NAN, f64::NAN)
                    }
                };
                let (rise, ra) = match rv {
                    Ok(v) => v,
                    Err(e) => {
                        notes.push(format!("rise: {e}"));
                        (f64::NAN, f64::NAN)
                    }
                };
                (
                    val(nl.across_rms.clone(), "rms2", &mut notes),
                    val(across_rms(w, 1.0, no.min_nodes), "rms1", &mut notes),
                    level,
                    rise,
                    la,
                    ra,
                )
            } else {
                let n = f64::NAN;
                (n, n, n, n, n, n)
            };
            let row = Row {
                l: g.l,
                gap: g.saddle_gap,
                edge,
                rms2,
                rms1,
                level,
                rise,
                flux: f64::NAN,
                flagged: g.flag.is_some(),
            };
            println!(
                "rung,{k},{:e},{:.10e},{},{:.6e},{:.1e},{:.8e},{:.8e},{:.8e},{:.1e},{:.8e},{:.1e},{},{}",
                g.l,
                g.saddle_gap,
                g.neck_nodes,
                edge.0,
                edge.1,
                rms2,
                rms1,
                level,
                la,
                rise,
                ra,
                g.flag
                    .map_or(String::new(), |f| f.to_string().replace(',', ";")),
                notes.join(" | ").replace(',', ";")
            );
            std::io::stdout().flush().ok();
            rows.push(row);
        };
        r.ladder(pc, &ls, &mut on_rung).expect("ladder");
        if flips {
            println!("flips,k,l,coarse_contacts,flipped,nearest_base_cells");
            for f in &flip_rows {
                println!("flips,{k},{f}");
            }
        }
        if let Some(setup) = &setup {
            println!(
                "# flow options: {} sweeps, tolerance {:e}, max_iterations {}",
                setup.flow.smoothing_sweeps, setup.flow.tolerance, setup.flow.max_iterations
            );
            println!("flux,k,l,conductance,sigma,open_side_nodes,wall_s,note");
            for (row, f) in rows.iter_mut().zip(&fluxes) {
                match f {
                    Ok(f) => {
                        row.flux = f.conductance;
                        println!(
                            "flux,{k},{:e},{:.10e},{:.1e},{},{:.1},",
                            row.l, f.conductance, f.sigma, f.open_side_nodes, f.wall_s
                        );
                    }
                    Err(e) => println!("flux,{k},{:e},NaN,NaN,,,{}", row.l, e.replace(',', ";")),
                }
            }
        }
        eprintln!(
            "k = {k}: {:.1} s wall, {} solves, {} iterations",
            t.elapsed().as_secs_f64(),
            r.solves,
            r.iterations
        );
        levels.insert(k, rows);
        guess = pc;
        width = pc_width;
    }
    // running exponents per pair and level, with the change from k − 1
    println!(
        "pair,k,l_hi,l_lo,zeta_gap,d_gap,edge,d_edge,edge_sigma,rms2,d_rms2,rms1,d_rms1,level,d_level,rise,d_rise,beta,d_beta,flagged"
    );
    let slope = |a: &Row, b: &Row, m: usize| {
        let (ya, yb) = (a.get(m), b.get(m));
        if ya.is_finite() && yb.is_finite() && ya > 0.0 && yb > 0.0 {
            (yb / ya).ln() / (b.l.abs() / a.l.abs()).ln()
        } else {
            f64::NAN
        }
    };
    let pairs_of = |rows: &[Row]| -> Vec<(Row, Row)> {
        let mut neg: Vec<&Row> = rows.iter().filter(|r| r.l < 0.0).collect();
        neg.sort_by(|a, b| b.l.abs().total_cmp(&a.l.abs()));
        let mut pos: Vec<&Row> = rows.iter().filter(|r| r.l > 0.0).collect();
        pos.sort_by(|a, b| b.l.abs().total_cmp(&a.l.abs()));
        let mut out = Vec::new();
        for side in [neg, pos] {
            for w in side.windows(2) {
                out.push((w[0].clone(), w[1].clone()));
            }
        }
        out
    };
    for (&k, rows) in &levels {
        let coarser = levels.get(&(k.wrapping_sub(1))).map(|r| pairs_of(r));
        for (a, b) in pairs_of(rows) {
            let mut cells = Vec::new();
            for m in 0..NAMES.len() {
                let v = slope(&a, &b, m);
                let dv = coarser
                    .as_ref()
                    .and_then(|c| c.iter().find(|(ca, cb)| ca.l == a.l && cb.l == b.l))
                    .map_or(f64::NAN, |(ca, cb)| v - slope(ca, cb, m));
                cells.push(format!("{v:.5},{dv:.1e}"));
                if m == 1 {
                    // the edge fits' 1σ propagated to the slope
                    let s = (a.edge.1 / a.edge.0).hypot(b.edge.1 / b.edge.0)
                        / (b.l.abs() / a.l.abs()).ln().abs();
                    cells.push(format!("{s:.1e}"));
                }
            }
            println!(
                "pair,{k},{:e},{:e},{},{}",
                a.l,
                b.l,
                cells.join(","),
                u8::from(a.flagged || b.flagged)
            );
        }
    }
    println!(
        "# total {:.1} s wall, load average {}",
        t0.elapsed().as_secs_f64(),
        load_average()
    );
}
