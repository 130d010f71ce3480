//! `saddleflow critical`: the percolation threshold of the hard-wall contact on one grid (or
//! averaged over sub-grid shifts); prints one JSON object. With `--surface FILE` instead of a
//! lattice: the fluid percolation load of any height file and the contact area there
//! (`critical::leakage::percolation_load`), periodic or between reservoirs.

use anyhow::{Context, Result, bail};
use critical::{CriticalOptions, CriticalResult, Transition, find_critical_shifted, shift_set};
use serde_json::{Value, json};
use surface::Lattice;

use crate::guard;
use crate::surface_cmd::{self, ReadArgs};
use critical::leakage::{PercolationOptions, percolation_load};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Surface model: square, triangular or hexagonal.
    #[arg(long, required_unless_present = "surface", conflicts_with = "surface")]
    lattice: Option<String>,
    /// Grid exponent: 2^n × 2^n nodes (3..=13).
    #[arg(long, required_unless_present = "surface", conflicts_with = "surface")]
    n: Option<u32>,
    /// A height file instead of a lattice: .h5 (height, lx, ly), .npy or text.
    #[arg(long)]
    surface: Option<PathBuf>,
    #[command(flatten)]
    read: ReadArgs,
    /// With --surface: periodic, or free (flow between reservoirs on opposite edges).
    #[arg(long, default_value = "periodic")]
    boundary: String,
    /// With --surface --boundary free: side edges noflux or periodic.
    #[arg(long, default_value = "noflux")]
    sides: String,
    /// Sub-grid shifts: K ≥ 1 averages over the K × K midpoint rule on [0, ½)² spacings; 0 (the
    /// default) solves the unshifted grid only (saddles on nodes).
    #[arg(long, default_value_t = 0)]
    shifts: usize,
    /// Polonsky–Keer tolerance on the constraint violation (h0).
    #[arg(long, default_value_t = 1e-10)]
    tol: f64,
    /// Target relative width (hi − lo)/hi of each load bracket.
    #[arg(long, default_value_t = 1e-9)]
    rel_width: f64,
    /// First load probed (E* h0/λ); default: from a coarse search on the 2^(n−2) grid.
    #[arg(long)]
    guess: Option<f64>,
    /// Reduced loads l = (L − L_c)/L_c < 0 of the saddle-gap samples, comma-separated; "none"
    /// skips the sub-grid estimate. Default: six values from −0.02 to −0.002.
    #[arg(long, allow_hyphen_values = true)]
    saddle_loads: Option<String>,
    /// Sample the saddle gaps on every shift (default: the first shift only).
    #[arg(long)]
    saddle_every_shift: bool,
    /// Threads (default: one per core; at most 4 × the cores).
    #[arg(long)]
    threads: Option<usize>,
}

fn parse_loads(s: &str) -> Result<Vec<f64>> {
    if s.trim() == "none" {
        return Ok(Vec::new());
    }
    s.split(',')
        .map(|v| {
            let x: f64 = v
                .trim()
                .parse()
                .with_context(|| format!("--saddle-loads: {v:?} is not a number"))?;
            if !(x.is_finite() && x < 0.0 && x > -1.0) {
                bail!("--saddle-loads: {x:?} is out of range: reduced loads must be in (−1, 0)");
            }
            Ok(x)
        })
        .collect()
}

pub fn run(a: Args) -> Result<()> {
    if !(a.tol > 0.0 && a.tol <= contact::TOL_GAP_MAX) {
        bail!(
            "--tol {:?}: allowed 0 < tol ≤ {:e} (h0, the constraint violation)",
            a.tol,
            contact::TOL_GAP_MAX
        );
    }
    if !(a.rel_width.is_finite() && a.rel_width > 0.0 && a.rel_width < 1.0) {
        bail!("--rel-width {:?}: allowed a value in (0, 1)", a.rel_width);
    }
    if let Some(path) = &a.surface {
        return run_surface(&a, path);
    }
    let lattice: Lattice = a
        .lattice
        .as_deref()
        .unwrap_or_default()
        .parse()
        .context("--lattice")?;
    let n = a.n.expect("clap requires --n with --lattice");
    if !(surface::N_MIN..=surface::N_MAX).contains(&n) {
        bail!(
            "--n {}: allowed {}..={} (grids of 2^n × 2^n nodes)",
            n,
            surface::N_MIN,
            surface::N_MAX
        );
    }
    if a.shifts > 16 {
        bail!(
            "--shifts {}: allowed 0..=16 (K × K solves per grid)",
            a.shifts
        );
    }
    let opts = CriticalOptions {
        tol_gap: a.tol,
        rel_width: a.rel_width,
        guess: a.guess,
        saddle_loads: match &a.saddle_loads {
            Some(s) => parse_loads(s)?,
            None => critical::default_saddle_loads(),
        },
        ..Default::default()
    };
    opts.validate()?;
    let shifts = shift_set(a.shifts);
    let pool = guard::thread_pool(a.threads)?;
    let t0 = std::time::Instant::now();
    let study = pool.install(|| {
        find_critical_shifted(lattice, n, &shifts, &opts, None, None, a.saddle_every_shift)
    })?;
    let mut out = summary_json(&study.results, &study.average);
    let obj = out.as_object_mut().expect("object");
    obj.insert("lattice".into(), json!(lattice.name()));
    obj.insert("n".into(), json!(n));
    obj.insert("tol_gap".into(), json!(a.tol));
    obj.insert("rel_width".into(), json!(a.rel_width));
    // the widest bracket of any shift and transition: a bracket of doubles cannot shrink below
    // about ε, so a request under that is echoed beside what was reached
    let reached = study
        .results
        .iter()
        .flat_map(|r| [&r.any, &r.x, &r.y])
        .map(|t| t.bracket.rel_width())
        .fold(0.0, f64::max);
    if reached > a.rel_width {
        eprintln!(
            "warning: --rel-width {:?} was not reached: the widest bracket has relative width \
             {reached:.3e} (bracket ends are doubles, whose relative spacing is {:.1e} to \
             {:.1e})",
            a.rel_width,
            f64::EPSILON / 2.0,
            f64::EPSILON
        );
    }
    obj.insert("rel_width_reached".into(), json!(reached));
    obj.insert("p_fc_exact".into(), json!(lattice.exact().p_fc));
    obj.insert("wall_s".into(), json!(t0.elapsed().as_secs_f64()));
    println!("{}", serde_json::to_string(&out)?);
    Ok(())
}

/// `critical --surface FILE`: the fluid percolation load of a height file and a_p there.
fn run_surface(a: &Args, path: &std::path::Path) -> Result<()> {
    for (name, given) in [
        ("--shifts", a.shifts != 0),
        ("--saddle-loads", a.saddle_loads.is_some()),
        ("--saddle-every-shift", a.saddle_every_shift),
    ] {
        if given {
            bail!(
                "{name} applies to --lattice only (a height file has no sub-grid shifts or known saddles)"
            );
        }
    }
    let boundary = crate::leakage::boundary(&a.boundary, &a.sides)?;
    let pool = guard::thread_pool(a.threads)?;
    let r = surface_cmd::read_surface("--surface", path, &a.read)?;
    surface_cmd::check_solve_memory("--surface", path, &r.field)?;
    let opts = PercolationOptions {
        tol_gap: a.tol,
        rel_width: a.rel_width,
        guess: a.guess,
        ..Default::default()
    };
    let t0 = std::time::Instant::now();
    let res = pool.install(|| percolation_load(&r.field, boundary, &opts))?;
    let out = json!({
        "surface": path.display().to_string(),
        "boundary": res.boundary.name(),
        "sides": crate::leakage::sides_name(boundary),
        "nx": r.field.grid.nx,
        "ny": r.field.grid.ny,
        "lx": r.field.grid.lx,
        "ly": r.field.grid.ly,
        "p_fc": res.p_fc,
        "l_c": res.any.l_c(),
        "l_c_over_p_fc": res.any.l_c() / res.p_fc,
        "bracket": [res.any.bracket.lo, res.any.bracket.hi],
        "a_p_raw": res.any.a_p_raw(),
        "a_p_corrected": res.any.a_p_corrected(),
        "l_c_x": res.x.l_c(),
        "l_c_y": res.y.l_c(),
        "any": transition_json(&res.any),
        "x": transition_json(&res.x),
        "y": transition_json(&res.y),
        "tol_gap": a.tol,
        "rel_width": a.rel_width,
        "probes": res.probes,
        "retries": res.retries,
        "iterations": res.iterations,
        "wall_s": t0.elapsed().as_secs_f64(),
    });
    println!("{}", serde_json::to_string(&out)?);
    Ok(())
}

fn transition_json(t: &Transition) -> Value {
    json!({
        "l_c": t.l_c(),
        "bracket": [t.bracket.lo, t.bracket.hi],
        "rel_width": t.bracket.rel_width(),
        "a_p_raw": t.a_p_raw(),
        "a_p_corrected": t.a_p_corrected(),
        "contact_nodes": [t.area_lo.n_contact, t.area_hi.n_contact],
        "perimeter_faces": [t.area_lo.n_perimeter_edges, t.area_hi.n_perimeter_edges],
        "bridging_nodes": t.bridging_nodes(),
    })
}

fn result_json(r: &CriticalResult) -> Value {
    let groups: Vec<f64> = r.groups.iter().map(|g| g.angle_deg).collect();
    json!({
        "shift": [r.grid.shift.0, r.grid.shift.1],
        "p_fc": r.p_fc,
        "p_fc_over_l_c": r.p_fc_over_l_c(),
        "any": transition_json(&r.any),
        "x": transition_json(&r.x),
        "y": transition_json(&r.y),
        "saddle_channel_angles_deg": groups,
        "saddle_samples": r.samples.iter().map(|s| json!({
            "load": s.load,
            "reduced_load": s.reduced,
            "contact_area": s.area,
            "gap": s.gap,
        })).collect::<Vec<_>>(),
        "subgrid": r.subgrid.as_ref().map(|s| json!({
            "l_c": s.l_c,
            "l_c_error": s.l_c_error,
            "zeta": s.zeta,
            "zeta_error": s.zeta_error,
            "fits": s.fits.iter().map(|f| json!({
                "channel_angle_deg": f.angle_deg,
                "points": f.points,
                "l_c": f.l_c.0, "l_c_error": f.l_c.1,
                "zeta": f.zeta.0, "zeta_error": f.zeta.1,
                "amplitude": f.amplitude.0, "amplitude_error": f.amplitude.1,
                "reduced_chi2": f.reduced_chi2,
                "pegged": f.pegged,
            })).collect::<Vec<_>>(),
        })),
        "notes": r.notes,
        "probes": r.probes,
        "retries": r.retries,
        "sample_solves": r.sample_solves,
        "iterations": r.iterations,
        "wall_s": r.wall_s,
    })
}

/// The JSON summary: headline numbers (shift averages; with one shift, that grid's values), then
/// the per-shift details.
fn summary_json(results: &[CriticalResult], av: &critical::ShiftAverage) -> Value {
    let first = &results[0];
    let single = results.len() == 1;
    let sub = results.iter().find_map(|r| r.subgrid.as_ref());
    json!({
        "nx": first.grid.nx,
        "ny": first.grid.ny,
        "lx": first.grid.lx,
        "ly": first.grid.ly,
        "shifts": results.iter().map(|r| [r.grid.shift.0, r.grid.shift.1]).collect::<Vec<_>>(),
        "l_c": av.any.l_c.mean,
        "l_c_shift_sem": av.any.l_c.sem,
        "bracket": single.then_some([first.any.bracket.lo, first.any.bracket.hi]),
        "l_c_x": av.x.l_c.mean,
        "l_c_y": av.y.l_c.mean,
        "a_p_raw": av.any.a_p_raw.mean,
        "a_p_raw_shift_sem": av.any.a_p_raw.sem,
        "a_p_corrected": av.any.a_p_corrected.mean,
        "a_p_corrected_shift_sem": av.any.a_p_corrected.sem,
        "p_fc": av.p_fc.mean,
        "p_fc_over_l_c": av.p_fc_over_l_c.mean,
        "l_c_subgrid": sub.map(|s| s.l_c),
        "l_c_subgrid_error": sub.map(|s| s.l_c_error),
        "zeta": sub.map(|s| s.zeta),
        "zeta_error": sub.map(|s| s.zeta_error),
        "saddle_samples": first.samples.iter().map(|s| json!({
            "load": s.load,
            "reduced_load": s.reduced,
            "gap": s.gap,
        })).collect::<Vec<_>>(),
        "probes": results.iter().map(|r| r.probes).sum::<usize>(),
        "iterations": results.iter().map(|r| r.iterations).sum::<usize>(),
        "per_shift": results.iter().map(result_json).collect::<Vec<_>>(),
    })
}
