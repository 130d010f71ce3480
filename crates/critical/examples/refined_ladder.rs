//! The refined ζ ladder of one model (crate docs of `critical::refined`):
//! `cargo run --release -p critical --example refined_ladder -- <model> <base_log2> <k> <window>
//! <margin> [ls]`, ls comma-separated (default −5e-2 … −1e-5, the 1-2-5 sequence).
//!
//! Solves p_c and the ladder on D(k − 1) (same window and margin), D(k), and D(k) with the margin
//! increased by `REFINED_DMARGIN` (default 4), and prints one CSV row per rung (`rung,…`), the p_c searches
//! (`pc,…`) and the running exponents with both grid errors (`zeta,…`). `REFINED_COMPARE` picks
//! the comparison runs: `levels,margin` (default), `levels`, `margin` or `none`.
//! `REFINED_COARSER_CSV=<file>`: take D(k − 1)'s rungs from the `rung,fine,…` rows of an earlier
//! run's output instead of solving it (its p_c is the guess; the window's contact count stands in
//! for the contact-set hash, so a frozen pair is one with an unchanged count).
//! `REFINED_FINE_CSV`, `REFINED_MARGIN_CSV`: the same for D(k) and D(k, margin + Δ) (all three
//! given: no solve, only the running exponents). `REFINED_PC_GUESS`: p_c/p_fc to start D(k)'s
//! search from (width `REFINED_NEXT_WIDTH`, default 2e-6). `REFINED_REL_TOL`: the p_c bracket's
//! relative width (default `RefinedOptions`'s). `REFINED_TOL_GAP`, `REFINED_MAX_ITER`: the solver's tolerance (h0,
//! default 1e-13) and iteration cap per attempt (default `RefinedOptions`'s, 2000). `REFINED_EDGE_DUMP` (any value):
//! print the runs of each rung's outermost ring of fine nodes (`edge,…` rows, see `dump_edge`).
//! `REFINED_DWINDOW=<Δw>`: also solve D(k) with the window widened by Δw base cells (or read
//! its rows, `fine` or `window`, from `REFINED_WINDOW_CSV`) and print each pair's change
//! (`zeta_window,…`): the window error, which neither Δk nor Δmargin sees (the contact lines
//! outside the window are the base grid's in all three).
//! `REFINED_PC`: p_c/p_fc of every D (no search: the rungs' reduced loads from it; for timing
//! rungs of a D whose p_c is known or close to another D's). With `REFINED_PC_GUESS` or
//! `REFINED_PC` set, the periodic base grid's own p_c search is skipped (and D(k − 1) starts
//! from the guess too). `REFINED_SEARCH`: `aimed` (default), `secant` (the search until
//! 2026-11-26) or `bisection`. `REFINED_PC_TRACE` (any value): print every probe of the p_c
//! searches (`probe,<name>,k,#,load/p_fc,saddle gap,iterations,wall_s`, through
//! `Refinement::critical_load_traced`; probe 0 is a fresh D's warm-up solve).
use critical::refined::{
    Discretisation, RefinedOptions, RefinedRung, Refinement, RungFlag, Search, base_guess,
    default_ls, running_zeta,
};
use std::io::Write;
use std::time::Instant;
use surface::Lattice;

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_default()
}

fn opt(v: Option<f64>) -> String {
    v.map_or("".into(), |v| format!("{v}"))
}

/// p_c and the ladder of one D; prints its rows.
fn run(
    name: &str,
    d: Discretisation,
    guess: f64,
    width: f64,
    ls: &[f64],
    opts: &RefinedOptions,
) -> (f64, Vec<RefinedRung>) {
    let t = Instant::now();
    let mut r = Refinement::new(d, opts).expect("refined discretisation");
    let label = format!("{name},k={}", d.levels);
    r.on_solve = Some(Box::new(move |p, it, ok, v, s| {
        eprintln!(
            "solve {label}: load {p:.15e} iterations {it} converged {ok} violation {v:.2e} {s:.2} s"
        );
    }));
    let setup = t.elapsed().as_secs_f64();
    let t = Instant::now();
    // REFINED_PC: p_c/p_fc given (no search; for timing rungs at a known p_c)
    let c = match std::env::var("REFINED_PC") {
        Ok(v) => {
            let pc = v.parse::<f64>().expect("REFINED_PC (p_c/p_fc)") * r.p_fc();
            critical::refined::ClosingLoad {
                lo: pc,
                hi: pc,
                probes: 0,
            }
        }
        Err(_) if std::env::var("REFINED_PC_TRACE").is_ok() => {
            // every solve of the search printed as it ends (the warm-up solve of a fresh D as
            // probe 0): `probe,<name>,k,#,load/p_fc,gap,iterations,wall_s`
            let p_fc = r.p_fc();
            let label = format!("{name},{}", d.levels);
            r.critical_load_traced(Some(guess), width, &mut |p| {
                println!(
                    "probe,{label},{},{:.15e},{:.6e},{},{:.2}",
                    p.index,
                    p.load / p_fc,
                    p.saddle_gap,
                    p.iterations,
                    p.wall_s
                );
            })
            .expect("p_c")
        }
        Err(_) => r.critical_load(Some(guess), width).expect("p_c"),
    };
    let pc = c.p_c();
    println!(
        "pc,{name},{},{},{},{},{},{:.15e},{:.6e},{},{},{:.2},{:.2},{}",
        d.lattice.name(),
        d.base_log2,
        d.levels,
        d.window,
        d.margin,
        pc / r.p_fc(),
        c.hi / c.lo - 1.0,
        c.probes,
        r.iterations,
        setup,
        t.elapsed().as_secs_f64(),
        load_average()
    );
    std::io::stdout().flush().ok();
    let rungs = r
        .ladder(pc, ls, &mut |g, _r, _| {
            println!(
                "rung,{name},{},{},{},{},{},{:e},{:.15e},{:.12e},{},{:.2},{},{},{},{},{},{},{},{},{}",
                d.lattice.name(),
                d.base_log2,
                d.levels,
                d.window,
                d.margin,
                g.l,
                g.load,
                g.saddle_gap,
                g.iterations,
                g.wall_s,
                g.edge.crossings,
                opt(g.edge.narrowest_open),
                opt(g.edge.narrowest_contact),
                g.window_contact,
                g.neck_nodes,
                g.flag
                    .map_or(String::new(), |f| f.to_string().replace(',', ";")),
                load_average(),
                g.edge.raw_crossings,
                g.edge.slivers
            );
            if std::env::var("REFINED_EDGE_DUMP").is_ok() {
                dump_edge(g.l, _r, 1usize << d.levels);
            }
            std::io::stdout().flush().ok();
        })
        .expect("ladder");
    (pc, rungs)
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    if a.len() < 6 {
        eprintln!("usage: refined_ladder <model> <base_log2> <k> <window> <margin> [ls]");
        std::process::exit(2);
    }
    let lattice: Lattice = a[1]
        .parse()
        .expect("model: square, hexagonal or triangular");
    let base_log2: u32 = a[2].parse().expect("base_log2");
    let levels: u32 = a[3].parse().expect("k");
    let window: usize = a[4].parse().expect("window (base cells)");
    let margin: usize = a[5].parse().expect("margin (base cells)");
    let ls: Vec<f64> = a.get(6).map_or_else(default_ls, |s| {
        s.split(',')
            .map(|v| v.trim().parse().expect("ls"))
            .collect()
    });
    let compare = std::env::var("REFINED_COMPARE").unwrap_or_else(|_| "levels,margin".into());
    let dmargin: usize = std::env::var("REFINED_DMARGIN")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(4);
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    let defaults = RefinedOptions::default();
    let opts = RefinedOptions {
        tol_gap: env("REFINED_TOL_GAP").unwrap_or(defaults.tol_gap),
        max_iter: env("REFINED_MAX_ITER").map_or(defaults.max_iter, |v| v as usize),
        rel_tol: env("REFINED_REL_TOL").unwrap_or(defaults.rel_tol),
        search: match std::env::var("REFINED_SEARCH").as_deref() {
            Ok("secant") => Search::Secant,
            Ok("bisection") => Search::Bisection,
            Ok("aimed") | Err(_) => Search::Aimed,
            Ok(v) => panic!("REFINED_SEARCH={v}: aimed (default), secant or bisection"),
        },
        ..defaults
    };
    println!(
        "# tol_gap {:e}, max_iter {}, rel_tol {:e}",
        opts.tol_gap, opts.max_iter, opts.rel_tol
    );
    let d = Discretisation {
        lattice,
        base_log2,
        levels,
        window,
        margin,
    };
    println!("# load average at start {}", load_average());
    println!(
        "pc,name,model,base_log2,k,window,margin,p_c_over_p_fc,bracket_rel,probes,iterations,setup_s,search_s,load_average"
    );
    println!(
        "rung,name,model,base_log2,k,window,margin,l,load,saddle_gap,iterations,wall_s,crossings,narrowest_open,narrowest_contact,window_contact,neck_nodes,flag,load_average,raw_crossings,slivers"
    );
    // a guess from the periodic base grid alone (skipped when REFINED_PC_GUESS or REFINED_PC
    // gives one: on a 1024² base that search costs minutes and its p_c is ~1e-5 off p_c(D))
    let mut guess = std::env::var("REFINED_PC_GUESS").map_or(f64::NAN, |v| {
        v.parse::<f64>().expect("REFINED_PC_GUESS (p_c/p_fc)") * lattice_p_fc(lattice, base_log2)
    });
    if std::env::var("REFINED_PC_GUESS").is_err() && std::env::var("REFINED_PC").is_err() {
        let t = Instant::now();
        let (base, _) = base_guess(d, &opts).expect("base p_c");
        println!(
            "# periodic base grid 2^{base_log2}: p_c/p_fc {:.10} ({} probes, {:.1} s)",
            base.p_c() / lattice_p_fc(lattice, base_log2),
            base.probes,
            t.elapsed().as_secs_f64()
        );
        guess = base.p_c();
    }
    let mut coarser = None;
    if let Ok(path) = std::env::var("REFINED_COARSER_CSV") {
        let (pc, rungs) = read_rungs(&path, levels - 1, margin);
        println!(
            "# D(k − 1) from {path}: p_c/p_fc {:.15e}",
            pc / lattice_p_fc(lattice, base_log2)
        );
        guess = pc;
        coarser = Some(rungs);
    } else if compare.contains("levels") && levels > 1 {
        let (pc, rungs) = run(
            "coarser",
            d.with_levels(levels - 1),
            guess,
            2e-4,
            &ls,
            &opts,
        );
        guess = pc;
        coarser = Some(rungs);
    }
    // REFINED_NEXT_WIDTH: the relative width of a search from another D's p_c (default 2e-6,
    // the refined_ladder kind's; the p_c's of D(k − 1), D(k) and D(k, margin + Δ) differ by
    // ≤ 6e-7 relative on 256² bases)
    let next_width = env("REFINED_NEXT_WIDTH").unwrap_or(2e-6);
    let mut width = if coarser.is_some() { next_width } else { 2e-4 };
    if let Ok(v) = std::env::var("REFINED_PC_GUESS") {
        guess = v.parse::<f64>().expect("REFINED_PC_GUESS (p_c/p_fc)")
            * lattice_p_fc(lattice, base_log2);
        width = next_width;
    }
    let (pc, fine) = match std::env::var("REFINED_FINE_CSV") {
        Ok(path) => read_rungs(&path, levels, margin),
        Err(_) => run("fine", d, guess, width, &ls, &opts),
    };
    let mut other = None;
    if let Ok(path) = std::env::var("REFINED_MARGIN_CSV") {
        other = Some(read_rungs(&path, levels, margin + dmargin).1);
    } else if compare.contains("margin") {
        let (_, rungs) = run(
            "margin",
            d.with_margin(margin + dmargin),
            pc,
            next_width,
            &ls,
            &opts,
        );
        other = Some(rungs);
    }
    // REFINED_DWINDOW: the window error, from D(k) with the window widened (or the rows of
    // REFINED_WINDOW_CSV, an earlier run's `fine` rows of that window)
    let window_rungs = match (
        std::env::var("REFINED_DWINDOW")
            .ok()
            .map(|v| v.parse::<usize>().expect("REFINED_DWINDOW (base cells)")),
        std::env::var("REFINED_WINDOW_CSV"),
    ) {
        (Some(dw), Ok(path)) => Some(read_rungs_of(&path, levels, margin, Some(window + dw)).1),
        (Some(dw), Err(_)) => Some(
            run(
                "window",
                d.with_window(window + dw),
                pc,
                next_width,
                &ls,
                &opts,
            )
            .1,
        ),
        _ => None,
    };
    if let Some(w) = &window_rungs {
        println!("zeta_window,l_hi,l_lo,value_wider,change");
        let wider = running_zeta(w, None, None, 0.005, opts.tol_gap);
        for z in running_zeta(&fine, None, None, 0.005, opts.tol_gap) {
            if let Some(zw) = wider
                .iter()
                .find(|zw| zw.l_hi == z.l_hi && zw.l_lo == z.l_lo)
            {
                println!(
                    "zeta_window,{:e},{:e},{:.5},{:.2e}",
                    z.l_hi,
                    z.l_lo,
                    zw.value,
                    (zw.value - z.value).abs()
                );
            }
        }
    }
    println!("zeta,l_hi,l_lo,value,error_levels,error_margin,grid_error,fit_error,flag");
    for z in running_zeta(
        &fine,
        coarser.as_deref(),
        other.as_deref(),
        0.005,
        opts.tol_gap,
    ) {
        println!(
            "zeta,{:e},{:e},{:.5},{:.2e},{:.2e},{:.2e},{:.1e},{}",
            z.l_hi,
            z.l_lo,
            z.value,
            z.error_levels,
            z.error_margin,
            z.grid_error,
            z.fit_error,
            z.flag
                .map_or(String::new(), |f| f.to_string().replace(',', ";"))
        );
    }
    println!("# load average at end {}", load_average());
}

/// The `fine` or `margin` rungs of `levels` and `margin` of an earlier run and its p_c (E* h0/λ).
fn read_rungs(path: &str, levels: u32, margin: usize) -> (f64, Vec<RefinedRung>) {
    read_rungs_of(path, levels, margin, None)
}

/// [`read_rungs`], also the `window` rows, of one window if given.
fn read_rungs_of(
    path: &str,
    levels: u32,
    margin: usize,
    window: Option<usize>,
) -> (f64, Vec<RefinedRung>) {
    let text = std::fs::read_to_string(path).expect("REFINED_COARSER_CSV readable");
    let mut pc = f64::NAN;
    let mut rungs = Vec::new();
    for line in text.lines() {
        let c: Vec<&str> = line.split(',').collect();
        if c.len() < 7
            || !(c[1] == "fine" || c[1] == "margin" || c[1] == "window")
            || window.is_some_and(|w| c[5].parse::<usize>().ok() != Some(w))
            || c[4].parse::<u32>().ok() != Some(levels)
            || c[6].parse::<usize>().ok() != Some(margin)
        {
            continue;
        }
        if c[0] == "pc" {
            let lat: Lattice = c[2].parse().expect("model");
            let n: u32 = c[3].parse().expect("base");
            pc = c[7].parse::<f64>().expect("p_c") * lattice_p_fc(lat, n);
        } else if c[0] == "rung" {
            let num = |k: usize| c[k].parse::<f64>().ok();
            let edge = contact::refinement::EdgeRuns {
                crossings: c[12].parse().expect("crossings"),
                narrowest_open: num(13),
                narrowest_contact: num(14),
                all_contact: false,
                raw_crossings: c[12].parse().expect("crossings"),
                slivers: 0,
            };
            let contact: usize = c[15].parse().expect("window_contact");
            // runs before neck_nodes was printed have 18 columns, later ones 19
            let (neck, flag) = if c.len() >= 19 {
                (c[16].parse().expect("neck_nodes"), c[17])
            } else {
                (0, c[16])
            };
            rungs.push(RefinedRung {
                l: num(7).expect("l"),
                load: num(8).expect("load"),
                saddle_gap: num(9).expect("gap"),
                contact_area: f64::NAN,
                iterations: c[10].parse().expect("iterations"),
                wall_s: num(11).expect("wall"),
                edge,
                window_contact: contact,
                neck_nodes: neck,
                contact_hash: contact as u64,
                flag: (!flag.is_empty()).then_some(RungFlag::Window(edge)),
                // not in the example's CSV: the edge fits are the kind's (kinds::refined_ladder)
                half_width: (f64::NAN, f64::NAN),
                half_length: (f64::NAN, f64::NAN),
                edge_note: None,
                flux: (f64::NAN, f64::NAN),
                neck: critical::refined::NeckRecord::NONE,
            });
        }
    }
    assert!(
        pc.is_finite() && !rungs.is_empty(),
        "{path}: no fine rungs of k = {levels}"
    );
    (pc, rungs)
}

fn lattice_p_fc(lattice: Lattice, n: u32) -> f64 {
    surface::Surface::new(lattice, n)
        .expect("surface")
        .p_fc_grid()
}

/// `REFINED_EDGE_DUMP`: every run of the region's outermost ring of fine nodes (the ring the
/// window check read before 2026-11-26; it now reads the second ring, see
/// `contact::refinement::EdgeRuns`): `edge,l,state,ring index,nodes,(a;b) of its first node,
/// base nodes in it, state of the first node's two inner neighbours, gap/pressure of its first
/// four nodes`.
fn dump_edge(l: f64, r: &contact::refinement::Refined, f: usize) {
    let (rx, ry) = r.window_pressure.dim();
    let mut ring: Vec<(usize, usize)> = Vec::new();
    ring.extend((0..ry).map(|b| (0, b)));
    ring.extend((1..rx).map(|a| (a, ry - 1)));
    ring.extend((0..ry - 1).rev().map(|b| (rx - 1, b)));
    ring.extend((1..rx - 1).rev().map(|a| (a, 0)));
    let n = ring.len();
    let contact = |(a, b): (usize, usize)| r.window_pressure[[a, b]] > 0.0;
    let c = |k: usize| contact(ring[k]);
    let starts: Vec<usize> = (0..n).filter(|&k| c(k) != c((k + n - 1) % n)).collect();
    // the node `depth` rows inside the edge from (a, b)
    let inward = |(a, b): (usize, usize), depth: usize| {
        if a == 0 {
            (depth, b)
        } else if a == rx - 1 {
            (rx - 1 - depth, b)
        } else if b == 0 {
            (a, depth)
        } else {
            (a, ry - 1 - depth)
        }
    };
    for (i, &k) in starts.iter().enumerate() {
        let next = starts[(i + 1) % starts.len()];
        let len = (next + n - k) % n;
        let base = (0..len)
            .map(|t| ring[(k + t) % n])
            .filter(|&(a, b)| a % f == 0 && b % f == 0)
            .count();
        let fields: Vec<String> = (0..len.min(4))
            .map(|t| {
                let (a, b) = ring[(k + t) % n];
                format!(
                    "{:.2e}/{:.2e}",
                    r.window_gap[[a, b]],
                    r.window_pressure[[a, b]]
                )
            })
            .collect();
        let (a, b) = ring[k];
        println!(
            "edge,{l:e},{},{k},{len},({a};{b}),base={base},inner1={},inner2={},{}",
            if c(k) { "contact" } else { "open" },
            contact(inward(ring[k], 1)),
            contact(inward(ring[k], 2)),
            fields.join(" ")
        );
    }
}
