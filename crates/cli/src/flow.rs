//! `saddleflow flow`: Reynolds thin-film flow on a gap field read from any HDF5 file; prints one
//! JSON object.
//!
//! Input (ARCHITECTURE.md): a 2-D dataset `gap` (or `--dataset PATH`) of shape (nx, ny), first
//! index x, finite and ≥ 0 (0 = contact), and root attributes `lx`, `ly`. `saddleflow solve --out`
//! writes such files; so can h5py or anything else.
//!
//! Output: `conductivity` (a uniform gap g gives g³), `flux` (volume flux through the cell for a
//! unit pressure drop), `percolating`, `converged`, `termination`, `iterations`, `residual`
//! (true relative residual), `conservation_error`, `flux_error_estimate`, `wall_s`, `nx`, `ny`, `lx`, `ly`, and some
//! more solver details; `underflow_nodes` counts open nodes whose conductivity g³ underflows
//! double precision (a field whose largest gap is outside [5.3e-52, 2.4e51] h0 is refused: see
//! `formats::gapfile::max_gap_range`). A solve that did not converge is still printed, with `converged: false`
//! and a warning on stderr. With `--fields OUT.h5` the gap, pressure and current density
//! (`current_x`, `current_y`) are written with the summary and provenance.

use crate::guard::{self, Output};
use anyhow::{Context, Result, bail};
use formats::gapfile;
use reynolds::{FlowOptions, solve};
use serde_json::{Value, json};
use std::path::PathBuf;
use store::{ArtefactReader, Provenance, fields};

/// Version of what `flow --fields` writes; bump when its results change.
const CODE_VERSION: u64 = 1;

#[derive(clap::Args)]
pub struct Args {
    /// HDF5 file with a 2-D `gap` dataset (nx, ny; first index x) and root attributes lx, ly.
    #[arg(long)]
    gap: PathBuf,
    /// Dataset holding the gap, if not `gap` (e.g. a group path).
    #[arg(long, default_value = "gap")]
    dataset: String,
    /// Flow direction: the mean pressure drops along x or y.
    #[arg(long, default_value = "x")]
    axis: String,
    /// Target true relative residual of the linear system, in (0, 1).
    #[arg(long, default_value_t = 1e-10)]
    tol: f64,
    /// Cap on preconditioned CG iterations.
    #[arg(long, default_value_t = 200)]
    max_iter: usize,
    /// Threads (default: one per core; at most 4 × the cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Write gap, pressure, current_x, current_y and the summary to this HDF5 file.
    #[arg(long)]
    fields: Option<PathBuf>,
}

pub fn run(a: Args) -> Result<()> {
    let axis = gapfile::parse_axis(&a.axis).context("--axis")?;
    if !(a.tol.is_finite() && a.tol > 0.0 && a.tol < 1.0) {
        bail!("--tol {:?}: allowed a number in (0, 1)", a.tol);
    }
    if a.max_iter == 0 {
        bail!("--max-iter 0: allowed an integer ≥ 1");
    }
    let fields_out = a
        .fields
        .as_deref()
        .map(|p| Output::check("--fields", p, &[("--gap", &a.gap)]))
        .transpose()?;
    let pool = guard::thread_pool(a.threads)?;
    let reader = ArtefactReader::open(&a.gap).context("--gap")?;
    let input = gapfile::read_gap(&reader, &a.dataset)?;
    drop(reader);
    let range = gapfile::check_gap_range(&input.gap)
        .with_context(|| format!("`{}`: dataset `{}`", a.gap.display(), a.dataset))?;
    if range.underflow_nodes > 0 {
        eprintln!(
            "warning: {} of {} open nodes have gaps below {:.3e} h0 whose cubes (conductivities) \
             underflow double precision: they count as closed or lose precision",
            range.underflow_nodes,
            range.open_nodes,
            f64::MIN_POSITIVE.cbrt()
        );
    }
    let (nx, ny) = input.gap.dim();
    let opts = FlowOptions {
        tolerance: a.tol,
        max_iterations: a.max_iter,
        return_fields: a.fields.is_some(),
        ..Default::default()
    };
    let res = pool
        .install(|| solve(input.gap.view(), input.lx, input.ly, axis, &opts))
        .with_context(|| format!("`{}`", a.gap.display()))?;
    if !res.converged {
        eprintln!(
            "warning: flow solve did not converge ({} after {} iterations, relative residual \
             {:.3e}, conservation error {:.3e}): the flux is not trustworthy",
            gapfile::termination_name(res.termination),
            res.iterations,
            res.relative_residual,
            res.conservation_error
        );
    }
    let mut summary = gapfile::flow_json(&res);
    let obj = summary.as_object_mut().expect("object");
    let contact = input.gap.iter().filter(|&&g| g <= 0.0).count() as f64 / (nx * ny) as f64;
    for (k, v) in [
        ("nx", json!(nx)),
        ("ny", json!(ny)),
        ("lx", json!(input.lx)),
        ("ly", json!(input.ly)),
        ("axis", json!(gapfile::axis_name(axis))),
        ("tolerance", json!(a.tol)),
        ("contact_fraction", json!(contact)),
        ("gap_file", json!(a.gap.display().to_string())),
        ("dataset", json!(a.dataset)),
        ("underflow_nodes", json!(range.underflow_nodes)),
    ] {
        obj.insert(k.into(), v);
    }
    if let Some(out) = &fields_out {
        let f = res
            .fields
            .as_ref()
            .expect("fields were requested from the solver");
        let params = json!({
            "gap_file": a.gap.display().to_string(), "dataset": a.dataset,
            "axis": gapfile::axis_name(axis), "tol": a.tol, "max_iter": a.max_iter,
        });
        let mut prov = Provenance::for_command("flow", CODE_VERSION, params)?;
        prov.wall_s = res.wall_seconds;
        prov.stats = Value::Object(obj.clone());
        if !res.converged {
            prov.warnings
                .push("flow solve did not converge: the flux is not trustworthy".into());
        }
        let mut w = out.create()?;
        w.set_cell(input.lx, input.ly)?;
        w.write_f64_2d(fields::GAP, input.gap.view())?;
        w.write_f64_2d(fields::PRESSURE, f.pressure.view())?;
        w.write_f64_2d(fields::CURRENT_X, f.current_x.view())?;
        w.write_f64_2d(fields::CURRENT_Y, f.current_y.view())?;
        for (k, v) in obj.iter() {
            match v {
                Value::Number(x) if x.is_i64() || x.is_u64() => {
                    w.set_attr(k, x.as_i64().unwrap_or_default())?
                }
                Value::Number(x) => w.set_attr(k, x.as_f64().unwrap_or(f64::NAN))?,
                Value::Bool(b) => w.set_attr(k, *b)?,
                Value::String(s) => w.set_attr(k, s.as_str())?,
                _ => {}
            }
        }
        w.write_provenance(&prov)?;
        let written = out.publish(w)?;
        obj.insert("fields".into(), json!(written.display().to_string()));
    }
    println!("{}", serde_json::to_string(&summary)?);
    Ok(())
}
