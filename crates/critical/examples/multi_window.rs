//! Every saddle of the cell refined ([`contact::refinement::RefinedModel::multi`],
//! [`contact::refinement::flow_saddles`]) and the flow through all of them
//! ([`critical::window_flow::refined_multi_flow`]): p_c of the refined discretisation (the load
//! at which the first saddle closes, bisection), then per reduced load the mean saddle gap of
//! each channel orientation, K along x and y and Kx/Ky, against the uniform fine grid 2^(n+k) at
//! the same reduced load from its own p_c, and the cost per solve.
//!
//! `nice cargo run --release -p critical --example multi_window -- [key=value ...]` with keys
//! `lattice` (triangular), `n` (base exponent, 8), `k` (levels, 2), `region` (base cells per
//! window side, 16), `margin` (blockwise margin, 8; `none` = full composite operator),
//! `one` (1: refine only the axis saddle instead, for comparison), `trim_along` (2),
//! `trim_across` (1), `loads` (-1e-3,-5e-4,-2e-4,-1e-4), `uniform` (1: also the uniform
//! reference), `tol_gap` (1e-13; the triangular composite at k ≥ 3 stops at its rounding floor
//! above it, ~9e-12: 2e-11 there), `rel_width` (1e-9), `bracket` (half width of the p_c bracket
//! around the base grid's p_c, relative, 1e-3; ±2e-4 holds every p_c(D) measured on the 1024²
//! base, docs/near-critical.md §7.2–7.3).
use contact::refinement::{
    MultiOptions, Preconditioner, Refined, RefinedModel, Window, flow_saddles,
};
use contact::{Interaction, Model, Solution, SolverOptions};
use critical::window_flow::{SaddleFlowWindow, refined_multi_flow, running};
use reynolds::{FlowAxis, FlowOptions};
use std::time::Instant;
use surface::{Lattice, Surface};

mod common;

fn bisect(lo: f64, hi: f64, rel: f64, closed: &mut dyn FnMut(f64) -> bool) -> f64 {
    let (mut lo, mut hi) = (lo, hi);
    assert!(!closed(lo), "bracket: closed at its low end {lo}");
    assert!(closed(hi), "bracket: open at its high end {hi}");
    while hi / lo - 1.0 > rel {
        let mid = 0.5 * (lo + hi);
        if closed(mid) { hi = mid } else { lo = mid }
    }
    0.5 * (lo + hi)
}

fn main() {
    let (mut lattice, mut n, mut k, mut region, mut margin) =
        (Lattice::Triangular, 8u32, 2u32, 16usize, Some(8usize));
    let (mut one, mut trim_along, mut trim_across, mut uniform) = (false, 2usize, 1usize, true);
    let (mut tol_gap, mut rel_width, mut bracket) = (1e-13, 1e-9, 1e-3);
    let mut ls = vec![-1e-3, -5e-4, -2e-4, -1e-4];
    for kv in common::KeyValue::from_env() {
        match kv.key.as_str() {
            "lattice" => lattice = kv.parse(),
            "n" => n = kv.parse(),
            "k" => k = kv.parse(),
            "region" => region = kv.parse(),
            "margin" => margin = kv.optional(),
            "one" => one = kv.value == "1",
            "trim_along" => trim_along = kv.parse(),
            "trim_across" => trim_across = kv.parse(),
            "loads" => ls = kv.list(),
            "uniform" => uniform = kv.value == "1",
            "tol_gap" => tol_gap = kv.parse(),
            "rel_width" => rel_width = kv.parse(),
            "bracket" => bracket = kv.parse(),
            other => panic!("unknown key {other:?}"),
        }
    }
    let solver = SolverOptions {
        tol_gap,
        ..Default::default()
    };
    let fopts = FlowOptions::default();
    let base = Surface::new(lattice, n).expect("base grid");
    let f = 1usize << k;
    let saddles = flow_saddles(&base).expect("flow saddles");
    let nodes: Vec<(usize, usize)> = saddles.iter().map(|s| s.node.expect("on a node")).collect();
    // groups by channel angle (flow_saddles sorts by angle)
    let mut groups: Vec<(f64, Vec<usize>)> = Vec::new();
    for (i, s) in saddles.iter().enumerate() {
        match groups.last_mut() {
            Some((a, v)) if (*a - s.angle_deg).abs() < 1e-6 => v.push(i),
            _ => groups.push((s.angle_deg, vec![i])),
        }
    }
    let axis_saddle = saddles
        .iter()
        .position(|s| s.channel_axis().is_some())
        .expect("a saddle along a grid axis");
    let chosen: Vec<usize> = if one {
        vec![axis_saddle]
    } else {
        (0..saddles.len()).collect()
    };
    let regions: Vec<Window> = chosen
        .iter()
        .map(|&i| saddles[i].window(&base.grid, region, region))
        .collect();
    let flow_windows: Vec<SaddleFlowWindow> = chosen
        .iter()
        .zip(&regions)
        .map(|(&i, r)| {
            SaddleFlowWindow::around(
                *r,
                saddles[i].angle_deg,
                &base.grid,
                trim_along,
                trim_across,
            )
            .expect("flow window")
        })
        .collect();
    let group_means = |gap: &dyn Fn(usize) -> f64| -> Vec<f64> {
        groups
            .iter()
            .map(|(_, v)| v.iter().map(|&i| gap(i)).sum::<f64>() / v.len() as f64)
            .collect()
    };
    eprintln!(
        "{lattice}: base 2^{n}, k = {k} (fine spacing of 2^{}), {} windows of {region}² base cells, margin {margin:?}; groups at {:?}°",
        n + k,
        regions.len(),
        groups.iter().map(|g| g.0).collect::<Vec<_>>()
    );
    // p_c guess: the base grid's own
    let pfc = base.p_fc_grid();
    let mut bm = Model::new(&base).expect("base model");
    let mut bwarm: Option<Solution> = None;
    let pc_b = bisect(0.001 * pfc, 0.95 * pfc, 1e-7, &mut |p| {
        let s = bm
            .solve(Interaction::HardWall, p, &solver, bwarm.as_ref())
            .expect("base solve");
        let closed = nodes.iter().any(|&(i, j)| s.gap[[i, j]] <= 0.0);
        bwarm = Some(s);
        closed
    });
    eprintln!("base grid p_c/p_fc {:.10}", pc_b / pfc);

    // uniform reference
    let mut rows_u: Vec<(Vec<f64>, [f64; 2])> = Vec::new();
    let mut pc_u = f64::NAN;
    if uniform {
        let t = Instant::now();
        let fine = Surface::new(lattice, n + k).expect("fine grid");
        let mut um = Model::new(&fine).expect("uniform model");
        let mut warm: Option<Solution> = None;
        let mut solves = 0;
        let mut solve = |p: f64| -> Solution {
            let s = um
                .solve(Interaction::HardWall, p, &solver, warm.as_ref())
                .expect("uniform solve");
            assert!(s.stats.converged, "uniform at {p}: {:?}", s.stats);
            warm = Some(s.clone());
            solves += 1;
            s
        };
        pc_u = bisect(
            pc_b * (1.0 - bracket),
            pc_b * (1.0 + bracket),
            rel_width,
            &mut |p| {
                let s = solve(p);
                nodes.iter().any(|&(i, j)| s.gap[[f * i, f * j]] <= 0.0)
            },
        );
        for &l in &ls {
            let s = solve(pc_u * (1.0 + l));
            let g = s.gap.mapv(|v| v.max(0.0));
            let k2 = [FlowAxis::X, FlowAxis::Y].map(|axis| {
                let r = reynolds::solve(g.view(), fine.grid.lx, fine.grid.ly, axis, &fopts)
                    .expect("uniform flow");
                if r.converged {
                    r.conductivity
                } else {
                    eprintln!("uniform flow along {axis:?} at l = {l}: not converged ({:?}), K = {:e} not used", r.termination, r.conductivity);
                    f64::NAN
                }
            });
            rows_u.push((
                group_means(&|i| s.gap[[f * nodes[i].0, f * nodes[i].1]]),
                k2,
            ));
        }
        eprintln!(
            "uniform 2^{}: p_c/p_fc {:.10} ({:+.2e} from base), {solves} solves, {:.1} s",
            n + k,
            pc_u / pfc,
            pc_u / pc_b - 1.0,
            t.elapsed().as_secs_f64()
        );
    }

    // refined
    let t = Instant::now();
    let mut model = RefinedModel::multi(
        &base,
        &MultiOptions {
            levels: k,
            windows: regions.clone(),
            solver: solver.clone(),
        },
        margin,
        Preconditioner::Additive,
    )
    .expect("refined model");
    let setup = t.elapsed().as_secs_f64();
    let mut warm: Option<Refined> = None;
    let (mut solves, mut iterations, mut solve_s) = (0usize, 0usize, 0.0f64);
    let mut solve = |p: f64| -> Refined {
        let t = Instant::now();
        let mut r = model.solve(p, warm.as_ref()).expect("refined solve");
        if !r.stats.converged {
            r = model.solve(p, None).expect("refined solve, cold");
        }
        assert!(
            r.stats.converged,
            "refined solve at p = {p} did not converge (warm, then cold): {:?} after {} iterations, \
             largest violation {:.1e} against tol_gap {tol_gap:e}. Near p_c a composite can stop at \
             its rounding floor above a tight tol_gap (the triangular k = 3 one at ~9e-12, \
             docs/near-critical.md §7.3): rerun with a larger tol_gap=",
            r.stats.reason, r.stats.iterations, r.stats.max_violation
        );
        solves += 1;
        iterations += r.stats.iterations;
        solve_s += t.elapsed().as_secs_f64();
        warm = Some(r.clone());
        r
    };
    let pc_r = bisect(
        pc_b * (1.0 - bracket),
        pc_b * (1.0 + bracket),
        rel_width,
        &mut |p| {
            let r = solve(p);
            nodes.iter().any(|&(i, j)| r.base_gap[[i, j]] <= 0.0)
        },
    );
    let mut rows_r: Vec<(Vec<f64>, [f64; 2], Vec<usize>)> = Vec::new();
    let mut flow_s = 0.0;
    for &l in &ls {
        let r = solve(pc_r * (1.0 + l));
        let t = Instant::now();
        let k2 = [FlowAxis::X, FlowAxis::Y].map(|axis| {
            match refined_multi_flow(&r, &base.grid, &flow_windows, axis, &fopts) {
                Ok(m) => m.conductivity,
                Err(e) => {
                    eprintln!("refined flow along {axis:?} at l = {l}: {e}");
                    f64::NAN
                }
            }
        });
        flow_s += t.elapsed().as_secs_f64();
        let open_sides: Vec<usize> = [FlowAxis::X]
            .iter()
            .flat_map(|&axis| {
                refined_multi_flow(&r, &base.grid, &flow_windows, axis, &fopts)
                    .map(|m| m.windows)
                    .unwrap_or_default()
                    .into_iter()
                    .map(|w| w.open_side_nodes)
            })
            .collect();
        rows_r.push((
            group_means(&|i| r.base_gap[[nodes[i].0, nodes[i].1]]),
            k2,
            open_sides,
        ));
    }
    eprintln!(
        "refined: p_c/p_fc {:.10} ({:+.2e} from base{}), {solves} solves, {iterations} iterations, setup {setup:.1} s, {:.2} s and {:.0} iterations per solve, flow {:.2} s per load, {:.1} s in all",
        pc_r / pfc,
        pc_r / pc_b - 1.0,
        if uniform {
            format!(", {:+.2e} from uniform", pc_r / pc_u - 1.0)
        } else {
            String::new()
        },
        solve_s / solves as f64,
        iterations as f64 / solves as f64,
        flow_s / ls.len() as f64,
        t.elapsed().as_secs_f64()
    );
    for (c, &l) in ls.iter().enumerate() {
        let (g, k2, sides) = &rows_r[c];
        let gs: Vec<String> = g.iter().map(|v| format!("{v:.6e}")).collect();
        let mut line = format!(
            "l {l:e}: refined gaps {} (max/min − 1 {:.2e}), Kx {:.6e} Ky {:.6e} Kx/Ky {:.4}, open side nodes max {}",
            gs.join(" "),
            g.iter().cloned().fold(0.0, f64::max) / g.iter().cloned().fold(f64::INFINITY, f64::min)
                - 1.0,
            k2[0],
            k2[1],
            k2[0] / k2[1],
            sides.iter().max().unwrap_or(&0)
        );
        if let Some((gu, ku)) = rows_u.get(c) {
            let rel: Vec<String> = g
                .iter()
                .zip(gu)
                .map(|(a, b)| format!("{:+.2e}", a / b - 1.0))
                .collect();
            line += &format!(
                "; uniform gaps {} (max/min − 1 {:.2e}), Kx/Ky {:.4}; refined − uniform: gaps {}, Kx {:+.2e}, Ky {:+.2e}",
                gu.iter()
                    .map(|v| format!("{v:.6e}"))
                    .collect::<Vec<_>>()
                    .join(" "),
                gu.iter().cloned().fold(0.0, f64::max)
                    / gu.iter().cloned().fold(f64::INFINITY, f64::min)
                    - 1.0,
                ku[0] / ku[1],
                rel.join(" "),
                k2[0] / ku[0] - 1.0,
                k2[1] / ku[1] - 1.0
            );
        }
        println!("{line}");
    }
    for d in 0..2 {
        let r: Vec<f64> = rows_r.iter().map(|x| x.1[d]).collect();
        let mut line = format!(
            "β_eff along {}: refined {:?}",
            ["x", "y"][d],
            running(&ls, &r)
                .iter()
                .map(|v| format!("{v:.4}"))
                .collect::<Vec<_>>()
        );
        if !rows_u.is_empty() {
            let u: Vec<f64> = rows_u.iter().map(|x| x.1[d]).collect();
            line += &format!(
                ", uniform {:?}",
                running(&ls, &u)
                    .iter()
                    .map(|v| format!("{v:.4}"))
                    .collect::<Vec<_>>()
            );
        }
        println!("{line}");
    }
}
