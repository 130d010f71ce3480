//! `saddleflow constriction --surface FILE`: the fluid percolation load L_c of a height file, a
//! ladder of loads below it, and at every rung the flux and the last constriction (position,
//! gap, η of heights and gap, pressure-drop fraction), with running exponents and the β fit
//! (`critical::constriction`). Prints one JSON object.

use anyhow::{Result, bail};
use critical::constriction::{
    ConstrictionOptions, ConstrictionRung, ConstrictionStudy, Curvature, constriction_study,
    ladder_125,
};
use serde_json::{Value, json};
use std::path::PathBuf;

use crate::guard;
use crate::surface_cmd::{self, ReadArgs};

#[derive(clap::Args)]
pub struct Args {
    /// Height file: .h5 (height, lx, ly), .npy or text.
    #[arg(long)]
    surface: PathBuf,
    #[command(flatten)]
    read: ReadArgs,
    /// Boundary: periodic (only periodic is supported: the last constriction is the bottleneck
    /// of the widest path winding around the periodic cell).
    #[arg(long, default_value = "periodic")]
    boundary: String,
    /// Distances d = (L_c − L)/L_c of the rungs: "DMAX:DMIN" for the 1-2-5 sequence between
    /// them, or a comma-separated list.
    #[arg(long, default_value = "5e-2:1e-4")]
    ladder: String,
    /// A rung counts if the throat is at least this many nodes wide.
    #[arg(long, default_value_t = 2)]
    min_width: usize,
    /// A rung counts if at least this many nodes within --affine-radius of the constriction
    /// changed contact state against the state just below L_c (0: no check).
    #[arg(long, default_value_t = 1)]
    min_contact_changes: usize,
    /// Half-size (nodes) of that square.
    #[arg(long, default_value_t = 8)]
    affine_radius: usize,
    /// Pressure-drop square: half-size in nodes.
    #[arg(long, default_value_t = 2)]
    window: usize,
    /// β fit window "DLO:DHI" on the resolved rungs (default: all).
    #[arg(long, default_value = "0:1")]
    fit_window: String,
    /// Polonsky–Keer tolerance on the constraint violation (h0).
    #[arg(long, default_value_t = 1e-10)]
    tol: f64,
    /// Relative bracket width of L_c.
    #[arg(long, default_value_t = 1e-9)]
    rel_width: f64,
    /// Threads (default: one per core; at most 4 × the cores).
    #[arg(long)]
    threads: Option<usize>,
}

/// Parses `--ladder`: "DMAX:DMIN" (1-2-5 sequence) or "d1,d2,…".
pub fn parse_ladder(s: &str) -> Result<Vec<f64>> {
    let num = |t: &str| -> Result<f64> {
        t.trim()
            .parse::<f64>()
            .map_err(|e| anyhow::anyhow!("--ladder: {t:?} is not a number ({e})"))
    };
    let v = if let Some((a, b)) = s.split_once(':') {
        let (a, b) = (num(a)?, num(b)?);
        if !(a > 0.0 && b > 0.0 && a < 1.0 && b <= a) {
            bail!("--ladder {s}: DMAX:DMIN with 0 < DMIN ≤ DMAX < 1");
        }
        let v = ladder_125(a, b);
        if v.is_empty() {
            bail!("--ladder {s}: no member of the 1-2-5 sequence between {b} and {a}");
        }
        v
    } else {
        s.split(',').map(num).collect::<Result<Vec<_>>>()?
    };
    if let Some(d) = v.iter().find(|d| !(**d > 0.0 && **d < 1.0)) {
        bail!("--ladder {s}: distance {d} outside (0, 1) (d = (L_c − L)/L_c)");
    }
    Ok(v)
}

fn parse_window(s: &str) -> Result<(f64, f64)> {
    let Some((a, b)) = s.split_once(':') else {
        bail!("--fit-window {s}: expected DLO:DHI");
    };
    let p = |t: &str| {
        t.trim()
            .parse::<f64>()
            .map_err(|e| anyhow::anyhow!("--fit-window: {t:?} is not a number ({e})"))
    };
    Ok((p(a)?, p(b)?))
}

fn num(v: f64) -> Value {
    if v.is_finite() { json!(v) } else { Value::Null }
}

fn curvature_json(c: &Option<Curvature>) -> Value {
    match c {
        Some(c) => json!({
            "along": num(c.along), "across": num(c.across), "eta": num(c.eta),
            "is_saddle": c.is_saddle, "stencil": c.stencil,
        }),
        None => Value::Null,
    }
}

/// One rung as JSON.
pub fn rung_json(r: &ConstrictionRung) -> Value {
    let c = r.constriction.as_ref().map(|c| {
        json!({
            "node": [c.node.0, c.node.1],
            "x": c.x,
            "y": c.y,
            "gap": c.gap,
            "tied": c.tied,
            "essential": c.essential,
            "width_nodes": c.width_nodes,
            "height_curvature": curvature_json(&c.height),
            "gap_curvature": curvature_json(&c.gap_curvature),
            "gap_curvature_status": c.gap_curvature_status.code(),
        })
    });
    json!({
        "d": r.d,
        "load": r.load,
        "contact_area": r.contact_area,
        "converged": r.converged,
        "flux": num(r.flux),
        "flux_error": num(r.flux_error),
        "flow_converged": r.flow_converged,
        "percolating": r.percolating,
        "constriction": c,
        "drop_fraction": r.drop.map(num),
        "drop_axial": r.drop_axial.map(|d| num(d.fraction)),
        "contact_changes": r.contact_changes,
        "same_constriction": r.same_constriction,
        "resolved": r.resolved,
        "note": r.note,
        "iterations": r.iterations,
    })
}

/// The whole study as JSON (shared with the pipeline's summary).
pub fn study_json(s: &ConstrictionStudy) -> Value {
    let slopes = |v: &[critical::constriction::RunningSlope]| -> Vec<Value> {
        v.iter()
            .map(|r| {
                json!({"d_hi": r.l_hi.abs(), "d_lo": r.l_lo.abs(), "value": num(r.value),
                       "error": num(r.fit_error)})
            })
            .collect()
    };
    let fit = |f: &Option<critical::scaling::ExponentFit>| match f {
        Some(f) => json!({"value": num(f.value), "error": num(f.error),
                          "prefactor": num(f.prefactor), "points": f.points}),
        None => Value::Null,
    };
    json!({
        "p_fc": s.p_fc,
        "l_c": s.l_c,
        "l_c_over_p_fc": s.l_c / s.p_fc,
        "bracket": [s.bracket.0, s.bracket.1],
        "l_c_x": s.l_c_x,
        "l_c_y": s.l_c_y,
        "a_p_raw": s.a_p_raw,
        "a_p_corrected": s.a_p_corrected,
        "axis": critical::axis_name(s.axis),
        "constriction": rung_json(&s.at_l_c),
        "rungs": s.rungs.iter().map(rung_json).collect::<Vec<_>>(),
        "running_beta": slopes(&s.running_beta),
        "running_gap_exponent": slopes(&s.running_gap),
        "beta_fit": fit(&s.beta_fit),
        "gap_exponent_fit": fit(&s.gap_fit),
        "notes": s.notes,
        "probes": s.probes,
        "iterations": s.iterations,
        "wall_s": s.wall_s,
    })
}

pub fn run(a: Args) -> Result<()> {
    if a.boundary != "periodic" {
        if a.boundary == "free" {
            bail!(
                "--boundary free: not supported by `constriction` yet (the last constriction is \
                 the bottleneck of the widest path winding around a periodic cell; a patch needs \
                 the edge-to-edge maximin path). Use --boundary periodic"
            );
        }
        bail!("--boundary {}: expected periodic or free", a.boundary);
    }
    let opts = ConstrictionOptions {
        tol_gap: a.tol,
        rel_width: a.rel_width,
        ladder: parse_ladder(&a.ladder)?,
        min_width: a.min_width,
        affine_radius: a.affine_radius,
        min_contact_changes: a.min_contact_changes,
        window_half_length: a.window,
        fit_window: parse_window(&a.fit_window)?,
        ..Default::default()
    };
    let pool = guard::thread_pool(a.threads)?;
    let r = surface_cmd::read_surface("--surface", &a.surface, &a.read)?;
    surface_cmd::check_solve_memory("--surface", &a.surface, &r.field)?;
    let s = pool.install(|| constriction_study(&r.field, &opts))?;
    let mut out = study_json(&s);
    let o = out.as_object_mut().expect("an object");
    o.insert("surface".into(), json!(a.surface.display().to_string()));
    o.insert("boundary".into(), json!("periodic"));
    o.insert("nx".into(), json!(r.field.grid.nx));
    o.insert("ny".into(), json!(r.field.grid.ny));
    o.insert("lx".into(), json!(r.field.grid.lx));
    o.insert("ly".into(), json!(r.field.grid.ly));
    o.insert("tol_gap".into(), json!(a.tol));
    o.insert("rel_width".into(), json!(a.rel_width));
    o.insert(
        "errors".into(),
        json!("running exponents carry the measurement errors only (flux: the flow solver's a-posteriori estimate; gap: tol_gap); one grid gives no grid error"),
    );
    println!("{}", serde_json::to_string(&out)?);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ladders_parse() {
        assert_eq!(
            parse_ladder("5e-2:5e-3").unwrap(),
            vec![5e-2, 2e-2, 1e-2, 5e-3]
        );
        assert_eq!(parse_ladder("0.1,0.03").unwrap(), vec![0.1, 0.03]);
        for bad in ["1e-3:1e-2", "0.5,2", "x", "0.3:0.25"] {
            assert!(parse_ladder(bad).is_err(), "{bad}");
        }
    }
}
