//! Contact solutions to and from artefacts and JSON: shared by the CLI and the stage kinds.

use anyhow::Result;
use contact::{Interaction, Solution};
use serde_json::{Value, json};
use store::{ArtefactWriter, fields};

/// The interaction's parameters as JSON (`{"interaction": "adhesion", "gamma0": .., "rho": ..}`).
pub fn interaction_json(i: &Interaction) -> Value {
    match *i {
        Interaction::HardWall => json!({ "interaction": "hardwall" }),
        Interaction::Adhesion { gamma0, rho } => {
            json!({ "interaction": "adhesion", "gamma0": gamma0, "rho": rho })
        }
        Interaction::Repulsion { gamma_r, rho } => {
            json!({ "interaction": "repulsion", "gamma_r": gamma_r, "rho": rho })
        }
    }
}

/// Solver statistics as JSON.
pub fn stats_json(s: &contact::SolveStats) -> Value {
    json!({
        "method": s.method,
        "iterations": s.iterations,
        "converged": s.converged,
        "reason": s.reason.as_ref().map(|r| r.to_string()),
        "max_violation": s.max_violation,
        "force_residual": s.force_residual,
        "wall_s": s.wall_s,
    })
}

/// Scalar summary of a solution (what `saddleflow solve` prints).
pub fn solution_json(sol: &Solution) -> Value {
    let mut v = json!({
        "contact_area": sol.contact_area,
        "mean_gap": sol.mean_gap,
        "mean_pressure": sol.mean_pressure,
        "mean_displacement": sol.mean_displacement,
        "energy": sol.energy,
        "nx": sol.grid.nx,
        "ny": sol.grid.ny,
        "lx": sol.grid.lx,
        "ly": sol.grid.ly,
    });
    let obj = v.as_object_mut().expect("object");
    for (k, x) in stats_json(&sol.stats).as_object().expect("object") {
        obj.insert(k.clone(), x.clone());
    }
    for (k, x) in interaction_json(&sol.interaction)
        .as_object()
        .expect("object")
    {
        obj.insert(k.clone(), x.clone());
    }
    v
}

/// Writes a solution's fields (`height`, `displacement`, `gap`, `pressure`, shape (nx, ny), first
/// index x), the cell (`lx`, `ly`) and its summary as root attributes (ARCHITECTURE.md).
pub fn write_solution(
    out: &mut ArtefactWriter,
    heights: ndarray::ArrayView2<f64>,
    sol: &Solution,
) -> Result<()> {
    out.set_cell(sol.grid.lx, sol.grid.ly)?;
    out.write_f64_2d(fields::HEIGHT, heights)?;
    out.write_f64_2d(fields::DISPLACEMENT, sol.displacement.view())?;
    out.write_f64_2d(fields::GAP, sol.gap.view())?;
    out.write_f64_2d(fields::PRESSURE, sol.pressure.view())?;
    for (k, v) in solution_json(sol).as_object().expect("object") {
        match v {
            Value::Number(x) if x.is_i64() => out.set_attr(k, x.as_i64().unwrap_or_default())?,
            Value::Number(x) => out.set_attr(k, x.as_f64().unwrap_or(f64::NAN))?,
            Value::Bool(b) => out.set_attr(k, *b)?,
            Value::String(s) => out.set_attr(k, s.as_str())?,
            Value::Null => {}
            other => out.set_attr(k, other.clone())?,
        }
    }
    Ok(())
}
