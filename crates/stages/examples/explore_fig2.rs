// scratch: not committed
use contact::{Interaction, Lattice, Model, SolverOptions, Surface};
use std::time::Instant;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let n: u32 = args[1].parse().unwrap();
    let which = args[2].as_str();
    let steps: usize = args.get(3).map(|s| s.parse().unwrap()).unwrap_or(40);
    let pmax: f64 = args.get(4).map(|s| s.parse().unwrap()).unwrap_or(1.0);
    let pmin: f64 = args.get(5).map(|s| s.parse().unwrap()).unwrap_or(0.0);
    let tol: f64 = args.get(6).map(|s| s.parse().unwrap()).unwrap_or(1e-8);
    let s = Surface::new(Lattice::Square, n).unwrap();
    let pfc = s.p_fc_grid();
    let mut m = Model::new(&s).unwrap();
    let inter = match which {
        "hardwall" => Interaction::HardWall,
        "adhesion" => Interaction::Adhesion {
            gamma0: 0.2,
            rho: 0.04,
        },
        _ => Interaction::Repulsion {
            gamma_r: 0.2,
            rho: 0.04,
        },
    };
    let opts = SolverOptions {
        tol_force: tol,
        ..Default::default()
    };
    let up: Vec<f64> = (1..=steps)
        .map(|k| pmax * k as f64 / steps as f64)
        .collect();
    let mut down: Vec<f64> = up.iter().rev().skip(1).copied().collect();
    // extend into tension
    for k in 0..=steps {
        down.push(-pmax * k as f64 / steps as f64);
    }
    let t0 = Instant::now();
    let mut prev = None;
    for (br, list) in [("up", &up), ("down", &down)] {
        for &p in list.iter() {
            if p < pmin {
                break;
            }
            match m.solve(inter, p * pfc, &opts, prev.as_ref()) {
                Ok(sol) => {
                    println!(
                        "{br} {:.5} a={:.5} it={} conv={} res={:.2e} t={:.2}",
                        p,
                        sol.contact_area,
                        sol.stats.iterations,
                        sol.stats.converged,
                        sol.stats.force_residual,
                        sol.stats.wall_s
                    );
                    prev = Some(sol);
                }
                Err(e) => {
                    println!("{br} {p:.5} ERR {e}");
                    break;
                }
            }
        }
    }
    eprintln!("total {:.2}s", t0.elapsed().as_secs_f64());
}
