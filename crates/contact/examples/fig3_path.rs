//! Figure 3's γ0 path on one model, grid, tolerance and minimiser, with optional refinement of
//! its jumps; prints γ_p, γ_fc (brackets), γ_fc/γ_p, the reverse branch's thresholds and the
//! cost as one JSON line. The resolution study of docs/figure3.md ran this.
//!
//! ```text
//! cargo run --release -p contact --example fig3_path -- LATTICE N TOL METHOD [STEPS] [DEPTH] [AREA_JUMP]
//! cargo run --release -p contact --example fig3_path -- hexagonal 8 1e-8 fire 8 0
//! ```
//! LATTICE: hexagonal, square, triangular; N: grid exponent (2^N × 2^N); TOL: force-residual
//! tolerance (E* h0/λ); METHOD: fire, nonlinear-cg, auto; STEPS: steps per segment (8, the
//! paper preset's `fig3_steps`); DEPTH: bisection levels of every step that jumps (0: none);
//! AREA_JUMP: area change that makes a step a jump (0.02). The path is the `fig3_sweep` stage's
//! of pipeline/paper.toml: zero load, ρ = 0.04, γ0 from 0.005 to 50 in twelve segments (ends
//! 0.01, 0.02, 0.05, … 50) of STEPS equal steps each, up and back down.

use analysis::hysteresis::{BranchState, Thresholds, Transition};
use contact::path::{self, Branch, Control, PathSpec, Refinement};
use contact::{Interaction, Lattice, Method, Model, Solution, SolverOptions, Surface};

/// The fig3_sweep stage's segment ends (pipeline/paper.toml).
const ENDS: [f64; 12] = [
    0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0,
];

/// The γ0 values, as the sweep kind expands its segments (`sweep_params::expand`).
fn values(steps: usize) -> Vec<f64> {
    let mut out = vec![0.005];
    let mut a = 0.005;
    for &to in &ENDS {
        for k in 1..=steps {
            out.push(if k == steps {
                to
            } else {
                a + (to - a) * k as f64 / steps as f64
            });
        }
        a = to;
    }
    out
}

/// Fluid percolation along either axis (the sweep kind's `Point::fluid`).
fn fluid(sol: &Solution) -> (bool, bool) {
    let mask = sol.gap.mapv(|g| g == 0.0);
    let d = percolation::dual_percolation(mask.view());
    (
        d.fluid_percolates(percolation::Axis::X),
        d.fluid_percolates(percolation::Axis::Y),
    )
}

fn bracket(t: Option<Transition>) -> String {
    t.map_or("null".into(), |t| format!("[{}, {}]", t.x.0, t.x.1))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 4 {
        return Err("usage: fig3_path LATTICE N TOL METHOD [STEPS] [DEPTH] [AREA_JUMP]".into());
    }
    let lattice: Lattice = args[0].parse()?;
    let n: u32 = args[1].parse()?;
    let tol: f64 = args[2].parse()?;
    let method: Method = args[3].parse()?;
    let steps: usize = args.get(4).map_or(Ok(8), |s| s.parse())?;
    let depth: u32 = args.get(5).map_or(Ok(0), |s| s.parse())?;
    let area_jump: f64 = args.get(6).map_or(Ok(0.02), |s| s.parse())?;

    // FIG3_POINTS=1: every point on stderr
    let verbose = std::env::var_os("FIG3_POINTS").is_some();
    let surface = Surface::new(lattice, n)?;
    let mut model = Model::new(&surface)?;
    let spec = PathSpec {
        control: Control::Strength {
            load: 0.0,
            values: values(steps),
        },
        reverse: true,
        extension: Vec::new(),
        refine: Refinement { depth, area_jump },
    };
    let opts = SolverOptions {
        tol_force: tol,
        method,
        ..Default::default()
    };
    let inter = Interaction::Adhesion {
        gamma0: 0.005,
        rho: 0.04,
    };
    let mut states: Vec<(Branch, bool, BranchState)> = Vec::new();
    let topology = |s: &Solution| {
        let (fx, fy) = fluid(s);
        path::contact_topology(s) | (u64::from(fx) << 2) | (u64::from(fy) << 3)
    };
    let t0 = std::time::Instant::now();
    let result = path::run_with(&mut model, inter, &spec, &opts, topology, |p, s| {
        let (fx, fy) = fluid(s);
        let state = BranchState {
            x: p.strength,
            area: p.contact_area,
            fluid: fx || fy,
        };
        if verbose {
            eprintln!(
                "{} step {} γ0 {} area {} fluid {} refined {} converged {}",
                p.branch,
                p.step,
                p.strength,
                p.contact_area,
                fx || fy,
                p.refined,
                p.converged
            );
        }
        states.push((p.branch, p.converged, state));
        Ok::<(), std::convert::Infallible>(())
    })?;
    let wall = t0.elapsed().as_secs_f64();
    let of = |b: Branch| -> Vec<BranchState> {
        states
            .iter()
            .filter(|(br, ok, _)| *br == b && *ok)
            .map(|s| s.2)
            .collect()
    };
    let t = Thresholds::of(&of(Branch::Loading), &of(Branch::Unloading));
    let ratio = t
        .ratio()
        .map_or("null".into(), |(r, lo, hi)| format!("[{r}, {lo}, {hi}]"));
    let pts = &result.points;
    println!(
        "{{\"lattice\": \"{}\", \"n\": {n}, \"tol\": {tol:e}, \"method\": \"{}\", \"steps\": {steps}, \"depth\": {depth}, \"area_jump\": {area_jump}, \"gamma_p\": {}, \"gamma_fc\": {}, \"ratio\": {ratio}, \"break_up\": {}, \"trough_opening\": {}, \"points\": {}, \"refined\": {}, \"unconverged\": {}, \"iterations\": {}, \"wall_s\": {wall:.1}}}",
        args[0],
        method.name(),
        bracket(t.coalescence),
        bracket(t.full_contact),
        bracket(t.break_up),
        bracket(t.trough_opening),
        pts.len(),
        pts.iter().filter(|p| p.refined).count(),
        pts.iter().filter(|p| !p.converged).count(),
        pts.iter().map(|p| p.iterations).sum::<usize>(),
    );
    Ok(())
}
