//! Several refined windows in one composite discretisation (contact::refinement, "Several
//! windows"): the triangular model, whose twelve saddles per cell (channels at 30°, 90°, 150°)
//! all carry flow, refined at every saddle against one window and against the uniform fine
//! solve, each discretisation at its own p_c (the load at which the first of the twelve saddles
//! closes). `explore` (ignored; MW_N, MW_K, MW_W, MW_M, MW_LATTICE) prints the same for other
//! grids.

use contact::refinement::{MultiOptions, Preconditioner, RefinedModel, Window, flow_saddles};
use contact::{Interaction, Lattice, Model, SolverOptions};
use surface::Surface;

fn solver() -> SolverOptions {
    SolverOptions {
        tol_gap: 1e-13,
        ..Default::default()
    }
}

/// Saddle gaps of the twelve saddles at the loads p_c (1 + l) of each discretisation.
struct Run {
    pc: f64,
    gaps: Vec<Vec<f64>>,
}

/// The load in (lo, hi) at which the smallest of `gaps` closes, to `rel` relative.
fn bisect(lo: f64, hi: f64, rel: f64, gaps: &mut dyn FnMut(f64) -> Vec<f64>) -> f64 {
    let (mut lo, mut hi) = (lo, hi);
    while hi / lo - 1.0 > rel {
        let mid = 0.5 * (lo + hi);
        if gaps(mid).iter().cloned().fold(f64::INFINITY, f64::min) > 0.0 {
            lo = mid
        } else {
            hi = mid
        }
    }
    0.5 * (lo + hi)
}

fn spread(g: &[f64]) -> f64 {
    g.iter().fold(0.0f64, |a, b| a.max(*b)) / g.iter().fold(f64::INFINITY, |a, b| a.min(*b)) - 1.0
}

/// 64² base refined ×2 (k = 1) against the uniform 128² solve, windows of 10² base cells at
/// every saddle (full composite operator) against one window at the axis saddle.
///
/// Measured (2026-11-26): p_c relative to uniform: all windows −8.2e-5 … see the assertions'
/// comments; the composite's floor here is the coarse hats' discretisation of the rest of the
/// cell (large contact patches with contact lines everywhere), not the necks.
#[test]
fn refining_every_saddle_beats_one_window() {
    let lat = Lattice::Triangular;
    let (n, k, w) = (6u32, 1u32, 10usize);
    let base = Surface::new(lat, n).unwrap();
    let fine = Surface::new(lat, n + k).unwrap();
    let f = 1usize << k;
    let saddles = flow_saddles(&base).unwrap();
    assert_eq!(saddles.len(), 12);
    let pfc = base.p_fc_grid();
    let ls = [-2e-2, -1e-2, -5e-3, -2e-3];
    let nodes: Vec<(usize, usize)> = saddles.iter().map(|s| s.node.unwrap()).collect();
    let uniform = {
        let mut um = Model::new(&fine).unwrap();
        let mut warm = None;
        let mut gaps = |p: f64| -> Vec<f64> {
            let s = um
                .solve(Interaction::HardWall, p, &solver(), warm.as_ref())
                .unwrap();
            assert!(s.stats.converged);
            let g = nodes.iter().map(|&(i, j)| s.gap[[f * i, f * j]]).collect();
            warm = Some(s);
            g
        };
        let pc = bisect(0.7 * pfc, 0.72 * pfc, 1e-8, &mut gaps);
        Run {
            pc,
            gaps: ls.iter().map(|l| gaps(pc * (1.0 + l))).collect(),
        }
    };
    let all: Vec<Window> = saddles.iter().map(|s| s.window(&base.grid, w, w)).collect();
    let axis = saddles
        .iter()
        .position(|s| s.channel_axis().is_some())
        .unwrap();
    let refined = |wins: Vec<Window>| -> Run {
        let mut model = RefinedModel::multi(
            &base,
            &MultiOptions {
                levels: k,
                windows: wins,
                solver: solver(),
            },
            None,
            Preconditioner::Additive,
        )
        .unwrap();
        let mut warm = None;
        let mut gaps = |p: f64| -> Vec<f64> {
            let r = model.solve(p, warm.as_ref()).unwrap();
            assert!(r.stats.converged, "{:?}", r.stats);
            let g = nodes.iter().map(|&(i, j)| r.base_gap[[i, j]]).collect();
            warm = Some(r);
            g
        };
        let pc = bisect(0.7 * pfc, 0.72 * pfc, 1e-8, &mut gaps);
        Run {
            pc,
            gaps: ls.iter().map(|l| gaps(pc * (1.0 + l))).collect(),
        }
    };
    let one = refined(vec![all[axis]]);
    let every = refined(all.clone());
    let alone = {
        let mut bm = Model::new(&base).unwrap();
        let mut gaps = |p: f64| -> Vec<f64> {
            let s = bm.solve(Interaction::HardWall, p, &solver(), None).unwrap();
            assert!(s.stats.converged);
            nodes.iter().map(|&(i, j)| s.gap[[i, j]]).collect()
        };
        let pc = bisect(0.7 * pfc, 0.72 * pfc, 1e-8, &mut gaps);
        Run {
            pc,
            gaps: ls.iter().map(|l| gaps(pc * (1.0 + l))).collect(),
        }
    };
    let err = |r: &Run, i: usize| -> f64 {
        r.gaps[i]
            .iter()
            .zip(&uniform.gaps[i])
            .fold(0.0f64, |a, (x, y)| a.max((x / y - 1.0).abs()))
    };
    eprintln!(
        "p_c relative to uniform: base alone {:+.3e}, one window {:+.3e}, every saddle {:+.3e}",
        alone.pc / uniform.pc - 1.0,
        one.pc / uniform.pc - 1.0,
        every.pc / uniform.pc - 1.0
    );
    for (i, l) in ls.iter().enumerate() {
        eprintln!(
            "l {l:e}: largest saddle gap error over the 12: base {:.3e}, one window {:.3e}, every saddle {:.3e}; \
             max/min − 1 of the 12 gaps: uniform {:.3e}, base {:.3e}, one {:.3e}, every {:.3e}",
            err(&alone, i),
            err(&one, i),
            err(&every, i),
            spread(&uniform.gaps[i]),
            spread(&alone.gaps[i]),
            spread(&one.gaps[i]),
            spread(&every.gaps[i])
        );
        // refining every saddle beats one window at every load, for the worst saddle and for
        // the isotropy of the twelve (measured: worst 1.1e-2, 2.2e-2, 4.1e-2, 7.5e-2 against
        // 3.8e-2, 3.2e-2, 0.25, 1.6; spread 1.3e-2, 1.3e-3, 5.0e-2, 3.1e-2 against 4.6e-2,
        // 3.8e-2, 0.22, 1.6)
        assert!(err(&every, i) < err(&one, i), "l {l}");
        assert!(spread(&every.gaps[i]) < spread(&one.gaps[i]), "l {l}");
        // the composite's floor on this small base (measured ≤ 7.5e-2, growing as |l| falls:
        // the coarse hats' discretisation of the rest of the cell shifts the load, see the
        // module docs); bound 2× above
        assert!(err(&every, i) < 0.15, "l {l}: {}", err(&every, i));
    }
    // p_c of the composite with every saddle refined: measured −1.3e-4 (one window −1.1e-5,
    // decided by a coarse saddle; base alone in the output): not better here; bound 2× above
    assert!((every.pc / uniform.pc - 1.0).abs() < 3e-4);
}

#[test]
#[ignore]
fn explore() {
    let lat = match std::env::var("MW_LATTICE").as_deref() {
        Ok("hexagonal") => Lattice::Hexagonal,
        _ => Lattice::Triangular,
    };
    let n: u32 = std::env::var("MW_N").map_or(6, |v| v.parse().unwrap());
    let k: u32 = std::env::var("MW_K").map_or(2, |v| v.parse().unwrap());
    let w: usize = std::env::var("MW_W").map_or(6, |v| v.parse().unwrap());
    let m: usize = std::env::var("MW_M").map_or(8, |v| v.parse().unwrap());
    let base = Surface::new(lat, n).unwrap();
    let fine = Surface::new(lat, n + k).unwrap();
    let f = 1usize << k;
    let saddles = flow_saddles(&base).unwrap();
    let reps: Vec<usize> = vec![0, 4, 8];
    let pfc = base.p_fc_grid();
    // uniform fine p_c by bisection on the min saddle gap
    let mut um = Model::new(&fine).unwrap();
    let ugaps = |um: &mut Model, p: f64| -> Vec<f64> {
        let s = um.solve(Interaction::HardWall, p, &solver(), None).unwrap();
        assert!(s.stats.converged);
        saddles
            .iter()
            .map(|sd| {
                let (i, j) = sd.node.unwrap();
                s.gap[[f * i, f * j]]
            })
            .collect()
    };
    let pc = bisect(0.3 * pfc, 0.9 * pfc, 1e-7, &mut |p| ugaps(&mut um, p));
    eprintln!("{lat}: uniform 2^{} p_c/p_fc {:.8}", n + k, pc / pfc);
    let all: Vec<Window> = saddles.iter().map(|s| s.window(&base.grid, w, w)).collect();
    let axis = saddles
        .iter()
        .position(|s| s.channel_axis().is_some())
        .unwrap();
    let bisect = |gaps: &mut dyn FnMut(f64) -> Vec<f64>| bisect(0.69 * pfc, 0.74 * pfc, 1e-8, gaps);
    let ls = [-2e-2, -1e-2, -5e-3, -2e-3];
    let show = |name: &str, pcx: f64, g: &[Vec<f64>], gu: &[Vec<f64>]| {
        eprintln!("{name}: p_c rel {:+.3e}", pcx / pc - 1.0);
        for (k, l) in ls.iter().enumerate() {
            let mut line = format!("  l {l:e}:");
            for &r in &reps {
                line += &format!(" {:+.3e}", g[k][r] / gu[k][r] - 1.0);
            }
            let mx = g[k]
                .iter()
                .zip(&gu[k])
                .fold(0.0f64, |a, (x, y)| a.max((x / y - 1.0).abs()));
            let spread = g[k].iter().fold(0.0f64, |a, b| a.max(*b))
                / g[k].iter().fold(f64::INFINITY, |a, b| a.min(*b))
                - 1.0;
            eprintln!("{line} (max over 12 {mx:.3e}; max/min − 1 of the 12: {spread:.3e})");
        }
    };
    let gu: Vec<Vec<f64>> = ls.iter().map(|l| ugaps(&mut um, pc * (1.0 + l))).collect();
    let mut line = "uniform: max/min − 1 of the 12 gaps:".to_string();
    for g in &gu {
        line += &format!(
            " {:.3e}",
            g.iter().fold(0.0f64, |a, b| a.max(*b))
                / g.iter().fold(f64::INFINITY, |a, b| a.min(*b))
                - 1.0
        );
    }
    eprintln!("{line}");
    {
        let mut bm = Model::new(&base).unwrap();
        let mut gaps = |p: f64| -> Vec<f64> {
            let s = bm.solve(Interaction::HardWall, p, &solver(), None).unwrap();
            saddles
                .iter()
                .map(|sd| {
                    let (i, j) = sd.node.unwrap();
                    s.gap[[i, j]]
                })
                .collect()
        };
        let pcb = bisect(&mut gaps);
        let g: Vec<Vec<f64>> = ls.iter().map(|l| gaps(pcb * (1.0 + l))).collect();
        show("base", pcb, &g, &gu);
    }
    for (name, wins) in [("one", vec![all[axis]]), ("all", all.clone())] {
        let t = std::time::Instant::now();
        let mut model = RefinedModel::multi(
            &base,
            &MultiOptions {
                levels: k,
                windows: wins,
                solver: solver(),
            },
            (m > 0).then_some(m),
            Preconditioner::Additive,
        )
        .unwrap();
        let mut warm = None;
        let mut its = (0, 0);
        let mut gaps = |p: f64| -> Vec<f64> {
            let r = model.solve(p, warm.as_ref()).unwrap();
            assert!(r.stats.converged, "{:?}", r.stats);
            its = (its.0 + r.stats.iterations, its.1 + 1);
            let g = saddles
                .iter()
                .map(|sd| {
                    let (i, j) = sd.node.unwrap();
                    r.base_gap[[i, j]]
                })
                .collect();
            warm = Some(r);
            g
        };
        let pcx = bisect(&mut gaps);
        let g: Vec<Vec<f64>> = ls.iter().map(|l| gaps(pcx * (1.0 + l))).collect();
        show(
            &format!(
                "{name} ({} solves, {} its, {:.1} s)",
                its.1,
                its.0,
                t.elapsed().as_secs_f64()
            ),
            pcx,
            &g,
            &gu,
        );
    }
}

/// Windows nearer than margin + ORDER/2 base cells (blockwise) or sharing a base node (full
/// operator) are refused, the error naming both; apart enough, they are accepted.
#[test]
fn windows_too_close_are_refused_naming_both() {
    let s = Surface::new(Lattice::Square, 6).unwrap();
    let a = Window {
        i0: 4,
        j0: 4,
        wx: 6,
        wy: 6,
    };
    let build = |b: Window, margin: Option<usize>| {
        RefinedModel::multi(
            &s,
            &MultiOptions {
                levels: 1,
                windows: vec![a, b],
                solver: solver(),
            },
            margin,
            Preconditioner::Additive,
        )
        .map(|_| ())
    };
    // 12 base cells apart along x (nodes 10 and 22), margin 8: needs more than 8 + 4
    let near = Window { i0: 22, ..a };
    let e = build(near, Some(8)).unwrap_err().to_string();
    assert!(
        e.contains("window 0") && e.contains("window 1") && e.contains("i0: 22"),
        "{e}"
    );
    assert!(build(Window { i0: 23, ..a }, Some(8)).is_ok());
    // the full operator only needs them not to share a node; wrapping the period counts
    assert!(build(near, None).is_ok());
    let touching = Window { i0: 10, ..a };
    assert!(
        build(touching, None)
            .unwrap_err()
            .to_string()
            .contains("window 1")
    );
    let wrapped = Window { i0: 62, wx: 6, ..a };
    assert!(build(wrapped, None).is_err());
}
