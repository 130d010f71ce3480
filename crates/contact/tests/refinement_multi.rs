//! Several refined windows in one composite discretisation (contact::refinement, "Several
//! windows"): exploratory.

use contact::refinement::{MultiOptions, Preconditioner, RefinedModel, Window, flow_saddles};
use contact::{Interaction, Lattice, Model, SolverOptions};
use surface::Surface;

fn solver() -> SolverOptions {
    SolverOptions {
        tol_gap: 1e-13,
        ..Default::default()
    }
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
    let (mut lo, mut hi) = (0.3 * pfc, 0.9 * pfc);
    while hi / lo - 1.0 > 1e-7 {
        let mid = 0.5 * (lo + hi);
        let g = ugaps(&mut um, mid);
        if g.iter().cloned().fold(f64::INFINITY, f64::min) > 0.0 {
            lo = mid
        } else {
            hi = mid
        }
    }
    let pc = 0.5 * (lo + hi);
    eprintln!("{lat}: uniform 2^{} p_c/p_fc {:.8}", n + k, pc / pfc);
    let all: Vec<Window> = saddles.iter().map(|s| s.window(&base.grid, w, w)).collect();
    let axis = saddles
        .iter()
        .position(|s| s.channel_axis().is_some())
        .unwrap();
    let bisect = |gaps: &mut dyn FnMut(f64) -> Vec<f64>| {
        let (mut lo, mut hi) = (0.69 * pfc, 0.74 * pfc);
        while hi / lo - 1.0 > 1e-8 {
            let mid = 0.5 * (lo + hi);
            if gaps(mid).iter().cloned().fold(f64::INFINITY, f64::min) > 0.0 {
                lo = mid
            } else {
                hi = mid
            }
        }
        0.5 * (lo + hi)
    };
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
