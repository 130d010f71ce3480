//! `saddleflow leakage`: leakage against load on a height file — a warm-started hard-wall load
//! path with, at every load, the contact area, the mean gap, the flux and conductivity along x
//! and y and the percolation of contact and fluid (`critical::leakage::leakage_path`). Prints
//! one JSON object; `--csv FILE` writes one row per load.

use crate::guard::{self, Output};
use crate::surface_cmd::{self, ReadArgs};
use anyhow::{Context, Result, bail};
use critical::leakage::{Boundary, LeakageOptions, LeakagePoint, SideEdges, leakage_path};
use serde_json::{Value, json};
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The height file: .h5 (height, lx, ly), .npy or text.
    #[arg(long)]
    surface: PathBuf,
    #[command(flatten)]
    read: ReadArgs,
    /// Mean pressures, comma-separated (E* h0/λ; with --relative, fractions of p_fc).
    #[arg(long, allow_hyphen_values = true)]
    loads: String,
    /// Read --loads as fractions of the full-contact pressure p_fc = −min(K h) (periodic kernel).
    #[arg(long)]
    relative: bool,
    /// periodic (one cell of a periodic surface; flow under a mean pressure drop) or free (a patch
    /// of a half-space; flow between reservoirs on opposite edges).
    #[arg(long, default_value = "periodic")]
    boundary: String,
    /// With --boundary free: the edges parallel to the flow are closed (noflux) or periodic.
    #[arg(long, default_value = "noflux")]
    sides: String,
    /// Polonsky–Keer tolerance on the constraint violation (h0).
    #[arg(long, default_value_t = 1e-10)]
    tol: f64,
    /// Target relative residual of the Reynolds solves, in (0, 1).
    #[arg(long, default_value_t = 1e-10)]
    flow_tol: f64,
    /// Threads (default: one per core; at most 4 × the cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Write one row per load to this CSV file.
    #[arg(long)]
    csv: Option<PathBuf>,
}

/// The boundary named by `--boundary` and `--sides`.
pub fn boundary(b: &str, sides: &str) -> Result<Boundary> {
    let sides = match sides {
        "noflux" | "no-flux" => SideEdges::NoFlux,
        "periodic" => SideEdges::Periodic,
        other => bail!("--sides {other:?}: allowed noflux, periodic"),
    };
    Ok(match b {
        "periodic" => Boundary::Periodic,
        "free" => Boundary::Free { sides },
        other => bail!("--boundary {other:?}: allowed periodic, free"),
    })
}

/// The JSON name of the boundary's side edges (null for periodic).
pub fn sides_name(b: Boundary) -> Value {
    match b {
        Boundary::Periodic => Value::Null,
        Boundary::Free {
            sides: SideEdges::NoFlux,
        } => json!("noflux"),
        Boundary::Free {
            sides: SideEdges::Periodic,
        } => json!("periodic"),
    }
}

fn parse_loads(s: &str) -> Result<Vec<f64>> {
    let loads: Vec<f64> = s
        .split(',')
        .map(|v| {
            let x: f64 = v
                .trim()
                .parse()
                .with_context(|| format!("--loads: {v:?} is not a number"))?;
            if !(x.is_finite() && x > 0.0) {
                bail!("--loads: {x:?} is out of range: allowed finite loads > 0");
            }
            Ok(x)
        })
        .collect::<Result<_>>()?;
    if loads.is_empty() {
        bail!("--loads: no loads given");
    }
    Ok(loads)
}

fn point_json(p: &LeakagePoint, p_fc: f64) -> Value {
    json!({
        "load": p.load,
        "load_over_p_fc": p.load / p_fc,
        "contact_area": p.area.raw,
        "contact_area_corrected": p.area.corrected,
        "mean_gap": p.mean_gap,
        "flux_x": p.flow_x.flux,
        "flux_y": p.flow_y.flux,
        "conductivity_x": p.flow_x.conductivity,
        "conductivity_y": p.flow_y.conductivity,
        "fluid_percolates_x": p.state.fluid_x,
        "fluid_percolates_y": p.state.fluid_y,
        "contact_blocks_x": p.state.blocked_x,
        "contact_blocks_y": p.state.blocked_y,
        "flow_converged": p.flow_x.converged && p.flow_y.converged,
        "flux_error_estimate": p.flow_x.flux_error_estimate.max(p.flow_y.flux_error_estimate),
        "iterations": p.iterations,
        "max_violation": p.max_violation,
    })
}

const CSV_COLUMNS: [&str; 15] = [
    "load",
    "load_over_p_fc",
    "contact_area",
    "contact_area_corrected",
    "mean_gap",
    "flux_x",
    "flux_y",
    "conductivity_x",
    "conductivity_y",
    "fluid_percolates_x",
    "fluid_percolates_y",
    "contact_blocks_x",
    "contact_blocks_y",
    "flow_converged",
    "iterations",
];

fn csv(rows: &[Value]) -> String {
    let mut s = CSV_COLUMNS.join(",");
    s.push('\n');
    for r in rows {
        let cells: Vec<String> = CSV_COLUMNS
            .iter()
            .map(|c| match &r[*c] {
                Value::Number(x) => x.to_string(),
                Value::Bool(b) => b.to_string(),
                other => other.to_string(),
            })
            .collect();
        let _ = writeln!(s, "{}", cells.join(","));
    }
    s
}

pub fn run(a: Args) -> Result<()> {
    let boundary = boundary(&a.boundary, &a.sides)?;
    if !(a.tol > 0.0 && a.tol <= contact::TOL_GAP_MAX) {
        bail!(
            "--tol {:?}: allowed 0 < tol ≤ {:e} (h0, the constraint violation)",
            a.tol,
            contact::TOL_GAP_MAX
        );
    }
    if !(a.flow_tol.is_finite() && a.flow_tol > 0.0 && a.flow_tol < 1.0) {
        bail!("--flow-tol {:?}: allowed a number in (0, 1)", a.flow_tol);
    }
    let loads = parse_loads(&a.loads)?;
    // the output rule before any work; the file is written atomically at the end
    if let Some(p) = a.csv.as_deref() {
        Output::check("--csv", p, &[("--surface", &a.surface)])?;
    }
    let pool = guard::thread_pool(a.threads)?;
    let r = surface_cmd::read_surface("--surface", &a.surface, &a.read)?;
    surface_cmd::check_solve_memory("--surface", &a.surface, &r.field)?;
    let field = r.field;
    let p_fc = critical::leakage::full_contact_pressure(&field);
    let loads: Vec<f64> = if a.relative {
        loads.iter().map(|l| l * p_fc).collect()
    } else {
        loads
    };
    let opts = LeakageOptions {
        tol_gap: a.tol,
        flow: reynolds::FlowOptions {
            tolerance: a.flow_tol,
            ..Default::default()
        },
        ..Default::default()
    };
    let path = pool.install(|| leakage_path(&field, boundary, &loads, &opts))?;
    let rows: Vec<Value> = path.points.iter().map(|p| point_json(p, p_fc)).collect();
    for p in &path.points {
        if !(p.flow_x.converged && p.flow_y.converged) {
            eprintln!(
                "warning: load {:e}: a Reynolds solve did not converge (x: {:?}, y: {:?})",
                p.load, p.flow_x.termination, p.flow_y.termination
            );
        }
    }
    // The fluid's last open load and first closed one along the path (the threshold lies
    // between; `saddleflow critical --surface` brackets it).
    let last_open = path
        .points
        .iter()
        .filter(|p| p.state.fluid_any())
        .map(|p| p.load)
        .reduce(f64::max);
    let first_closed = path
        .points
        .iter()
        .find(|p| !p.state.fluid_any())
        .map(|p| p.load);
    let mut out = json!({
        "surface": a.surface.display().to_string(),
        "boundary": boundary.name(),
        "sides": sides_name(boundary),
        "nx": field.grid.nx,
        "ny": field.grid.ny,
        "lx": field.grid.lx,
        "ly": field.grid.ly,
        "p_fc": p_fc,
        "tol_gap": a.tol,
        "last_percolating_load": last_open,
        "first_sealed_load": first_closed,
        "points": rows,
        "wall_s": path.wall_s,
    });
    if let Some(p) = &a.csv {
        store::fsutil::check_output_path("--csv", p, &[("--surface", &a.surface)])?;
        store::fsutil::write_atomic(p, csv(&rows).as_bytes())
            .with_context(|| format!("--csv `{}`", p.display()))?;
        out.as_object_mut()
            .expect("object")
            .insert("csv".into(), json!(p.display().to_string()));
    }
    println!("{}", serde_json::to_string(&out)?);
    Ok(())
}
