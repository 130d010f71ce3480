//! `saddleflow leakage`: leakage against load on a height file — a warm-started hard-wall load
//! path with, at every load, the contact area, the mean gap, the flux and conductivity along x
//! and y and the percolation of contact and fluid (`critical::leakage::leakage_path`). Prints
//! one JSON object; `--csv FILE` writes one row per load. The loads are a list (`--loads`) or a
//! generated ladder (`--load-path START:STOP:COUNT[:log|lin]`).

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
    #[arg(
        long,
        allow_hyphen_values = true,
        required_unless_present = "load_path",
        conflicts_with = "load_path"
    )]
    loads: Option<String>,
    /// A generated ladder of loads instead of --loads: START:STOP:COUNT[:log|lin], COUNT loads
    /// from START to STOP inclusive, log-spaced (default) or linear (same units as --loads).
    #[arg(long, value_name = "START:STOP:COUNT[:log|lin]")]
    load_path: Option<String>,
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

/// Parses `--load-path START:STOP:COUNT[:log|lin]`: COUNT ≥ 2 loads from START to STOP
/// (0 < START < STOP), both included, geometric (`log`, the default) or arithmetic (`lin`);
/// COUNT = 1 gives START alone (then STOP must equal START).
pub fn parse_load_path(s: &str) -> Result<Vec<f64>> {
    let parts: Vec<&str> = s.split(':').map(str::trim).collect();
    if !(3..=4).contains(&parts.len()) {
        bail!("--load-path {s:?}: allowed START:STOP:COUNT or START:STOP:COUNT:log|lin");
    }
    let num = |what: &str, v: &str| -> Result<f64> {
        let x: f64 = v
            .parse()
            .with_context(|| format!("--load-path {s:?}: {what} {v:?} is not a number"))?;
        if !(x.is_finite() && x > 0.0) {
            bail!("--load-path {s:?}: {what} {x:?}: allowed a finite load > 0");
        }
        Ok(x)
    };
    let (start, stop) = (num("START", parts[0])?, num("STOP", parts[1])?);
    let count: usize = parts[2]
        .parse()
        .ok()
        .filter(|c| (1..=10_000).contains(c))
        .with_context(|| {
            format!(
                "--load-path {s:?}: COUNT {:?}: allowed an integer in 1..=10000",
                parts[2]
            )
        })?;
    let log = match parts.get(3).copied().unwrap_or("log") {
        "log" => true,
        "lin" | "linear" => false,
        other => bail!("--load-path {s:?}: spacing {other:?}: allowed log, lin"),
    };
    if count == 1 {
        if start != stop {
            bail!("--load-path {s:?}: COUNT 1 needs START = STOP");
        }
        return Ok(vec![start]);
    }
    if stop <= start {
        bail!("--load-path {s:?}: STOP {stop:?} must exceed START {start:?}");
    }
    let m = (count - 1) as f64;
    Ok((0..count)
        .map(|k| {
            let t = k as f64 / m;
            if k + 1 == count {
                stop
            } else if log {
                start * (stop / start).powf(t)
            } else {
                start + (stop - start) * t
            }
        })
        .collect())
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
    let loads = match (&a.loads, &a.load_path) {
        (Some(l), None) => parse_loads(l)?,
        (None, Some(p)) => parse_load_path(p)?,
        _ => bail!("give exactly one of --loads and --load-path"),
    };
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

#[cfg(test)]
mod tests {
    use super::parse_load_path;

    #[test]
    fn load_paths_are_generated_and_checked() {
        // oracle: 0.01, 0.1, 1 (log); 0, .. linear 1, 2, 3
        let v = parse_load_path("0.01:1:3").unwrap();
        assert_eq!(v.len(), 3);
        assert!((v[1] - 0.1).abs() < 1e-15 && v[0] == 0.01 && v[2] == 1.0);
        assert_eq!(parse_load_path("1:3:3:lin").unwrap(), vec![1.0, 2.0, 3.0]);
        assert_eq!(parse_load_path("0.2:0.2:1").unwrap(), vec![0.2]);
        for bad in ["1:0.5:3", "0:1:3", "1:2", "1:2:0", "1:2:3:cubic", "a:2:3"] {
            let e = parse_load_path(bad).unwrap_err().to_string();
            assert!(e.contains("--load-path"), "{bad}: {e}");
        }
    }
}
