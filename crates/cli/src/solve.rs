//! `saddleflow solve`: one contact problem at a fixed mean pressure; prints one JSON object.
//! The surface is one of the three lattices (`--lattice --n`) or any height file
//! (`--surface FILE`, see `surface_cmd`), with a periodic or free elastic boundary.

use crate::guard::{self, Output};
use crate::surface_cmd::{self, ReadArgs};
use anyhow::{Context, Result, bail};
use contact::free_kernel::Boundary;
use contact::{ContactError, Interaction, Lattice, Method, Model, SolverOptions, Surface};
use formats::solution as io;
use ndarray::Array2;
use serde_json::json;
use std::path::PathBuf;
use store::Provenance;
use surface::Grid;

/// Version of what `solve` writes; bump when its results change.
const CODE_VERSION: u64 = 1;

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
    /// Elastic boundary: periodic (the field is one cell of a periodic surface) or free (a patch
    /// of an infinite half-space; hard wall only).
    #[arg(long, default_value = "periodic")]
    boundary: String,
    /// Mean pressure in E* h0/λ; with `--relative`, in units of the full-contact pressure p_fc.
    #[arg(long, allow_hyphen_values = true)]
    pressure: f64,
    /// Read --pressure as a fraction of the grid's full-contact pressure p_fc (for a height
    /// file: −min(K h) with the periodic kernel).
    #[arg(long)]
    relative: bool,
    /// hardwall, adhesion or repulsion (the latter two on top of the hard wall).
    #[arg(long, default_value = "hardwall")]
    interaction: String,
    /// Interaction strength γ0 (adhesion) or γr (repulsion), E* h0²/λ. Default 0.2.
    #[arg(long, allow_hyphen_values = true)]
    gamma0: Option<f64>,
    /// Interaction range ρ, h0. Default 0.04.
    #[arg(long, allow_hyphen_values = true)]
    rho: Option<f64>,
    /// Tolerance: constraint violation bound (h0) for Polonsky–Keer, force residual bound
    /// (E* h0/λ) for FIRE. Defaults 1e-10 and 1e-8.
    #[arg(long)]
    tol: Option<f64>,
    /// Minimiser: auto, polonsky-keer (stiffness-preconditioned), polonsky-keer-plain or fire.
    #[arg(long, default_value = "auto")]
    method: String,
    /// Iteration cap.
    #[arg(long, default_value_t = 200_000)]
    max_iter: usize,
    /// Threads (default: one per core; at most 4 × the cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Write the fields (height, displacement, gap, pressure) and the summary to this HDF5 file.
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Default interaction strength γ0 or γr (E* h0²/λ) and range ρ (h0).
const GAMMA0_DEFAULT: f64 = 0.2;
const RHO_DEFAULT: f64 = 0.04;

/// The interaction `--interaction` names, with `--gamma0` and `--rho` (defaults if absent); a
/// warning if they were given to the hard wall, which has no parameter.
fn interaction(a: &Args) -> Result<Interaction> {
    let gamma = a.gamma0.unwrap_or(GAMMA0_DEFAULT);
    let rho = a.rho.unwrap_or(RHO_DEFAULT);
    let interaction = match a.interaction.as_str() {
        "hardwall" => {
            let given: Vec<&str> = [("--gamma0", a.gamma0), ("--rho", a.rho)]
                .into_iter()
                .filter_map(|(name, v)| v.map(|_| name))
                .collect();
            if !given.is_empty() {
                eprintln!(
                    "warning: {} ignored: the hard wall has no interaction parameters (use \
                     --interaction adhesion or repulsion)",
                    given.join(" and ")
                );
            }
            Interaction::HardWall
        }
        "adhesion" => Interaction::Adhesion { gamma0: gamma, rho },
        "repulsion" => Interaction::Repulsion {
            gamma_r: gamma,
            rho,
        },
        other => bail!("--interaction {other:?}: allowed values are hardwall, adhesion, repulsion"),
    };
    interaction.validate().context("--gamma0/--rho")?;
    Ok(interaction)
}

/// The problem's surface: a lattice or a height file.
struct Problem {
    grid: Grid,
    heights: Array2<f64>,
    p_fc: f64,
    lattice: Option<Lattice>,
    n: Option<u32>,
}

fn problem(a: &Args, boundary: Boundary) -> Result<Problem> {
    if let Some(path) = &a.surface {
        let r = surface_cmd::read_surface("--surface", path, &a.read)?;
        surface_cmd::check_solve_memory("--surface", path, &r.field)?;
        let p_fc = critical::leakage::full_contact_pressure(&r.field);
        if boundary == Boundary::Free && a.interaction != "hardwall" {
            bail!(
                "--boundary free --interaction {}: the free boundary is solved for the hard wall \
                 only (Polonsky–Keer); use --boundary periodic for adhesion and repulsion",
                a.interaction
            );
        }
        return Ok(Problem {
            grid: r.field.grid,
            heights: r.field.heights,
            p_fc,
            lattice: None,
            n: None,
        });
    }
    for (name, given) in [
        ("--lx", a.read.lx.is_some()),
        ("--ly", a.read.ly.is_some()),
        ("--detrend", a.read.detrend != "none"),
        ("--columns", a.read.columns),
    ] {
        if given {
            bail!("{name} applies to --surface FILE only, not to --lattice");
        }
    }
    let lattice: Lattice = a
        .lattice
        .as_deref()
        .unwrap_or_default()
        .parse()
        .context("--lattice")?;
    let n = a.n.expect("clap requires --n with --lattice");
    let surface = Surface::new(lattice, n).context("--n")?;
    Ok(Problem {
        grid: surface.grid,
        p_fc: surface.p_fc_grid(),
        heights: surface.heights,
        lattice: Some(lattice),
        n: Some(n),
    })
}

pub fn run(a: Args) -> Result<()> {
    let boundary = match a.boundary.as_str() {
        "periodic" => Boundary::Periodic,
        "free" => Boundary::Free,
        other => bail!("--boundary {other:?}: allowed periodic, free"),
    };
    let interaction = interaction(&a)?;
    let inputs: Vec<(&str, &std::path::Path)> = a
        .surface
        .iter()
        .map(|p| ("--surface", p.as_path()))
        .collect();
    let out = a
        .out
        .as_deref()
        .map(|p| Output::check("--out", p, &inputs))
        .transpose()?;
    let prob = problem(&a, boundary)?;
    let pool = guard::thread_pool(a.threads)?;
    let method: Method = a.method.parse().context("--method")?;
    let mut opts = SolverOptions {
        method,
        max_iter: a.max_iter,
        ..Default::default()
    };
    if let Some(t) = a.tol {
        opts.tol_gap = t;
        opts.tol_force = t;
        opts.validate().context("--tol")?;
    }
    if a.max_iter == 0 {
        bail!("--max-iter 0: allowed an integer ≥ 1");
    }
    if !a.pressure.is_finite() {
        bail!("--pressure {:?}: allowed a finite number", a.pressure);
    }
    let p_fc = prob.p_fc;
    let pressure = if a.relative {
        a.pressure * p_fc
    } else {
        a.pressure
    };
    let sol = pool.install(|| {
        Model::with_boundary(prob.grid, prob.heights.view(), boundary)
            .and_then(|mut m| m.solve(interaction, pressure, &opts, None))
    });
    let sol = match sol {
        // a load outside the representable range: name the option as given
        Err(e @ ContactError::Pressure { .. }) => {
            Err(anyhow::Error::new(e).context(if a.relative {
                format!(
                    "--pressure {:?} --relative (p̄ = {pressure:?} E* h0/λ)",
                    a.pressure
                )
            } else {
                format!("--pressure {:?}", a.pressure)
            }))
        }
        other => other.map_err(anyhow::Error::new),
    }?;
    if !sol.stats.converged {
        eprintln!(
            "warning: not converged after {} iterations: {}",
            sol.stats.iterations,
            sol.stats
                .reason
                .as_ref()
                .map(|r| r.to_string())
                .unwrap_or_default()
        );
    }
    let mut summary = io::solution_json(&sol);
    let obj = summary.as_object_mut().expect("object");
    // the cohesive zone ρ²E*/γ against the grid spacing: jumps and pull-off are mesh-dependent
    // below ~4 spacings (PHYSICS.md)
    if let Some(zone) = interaction.cohesive_zone_length(1.0) {
        let dx = prob.grid.lx / prob.grid.nx as f64;
        let spacings = zone / dx;
        if spacings < 4.0 {
            eprintln!(
                "warning: under-resolved cohesive zone: ρ²E*/γ = {zone:.3e} λ spans {spacings:.2} grid spacings (dx = {dx:.3e} λ), fewer than 4; instabilities depend on the mesh (use a larger --n)"
            );
        }
        obj.insert("cohesive_zone_spacings".into(), json!(spacings));
    }
    match (prob.lattice, &a.surface) {
        (Some(lattice), _) => {
            obj.insert("lattice".into(), json!(lattice.name()));
            obj.insert("n".into(), json!(prob.n));
        }
        (None, Some(path)) => {
            obj.insert("surface".into(), json!(path.display().to_string()));
        }
        (None, None) => unreachable!("a lattice or a surface"),
    }
    obj.insert(
        "boundary".into(),
        json!(if boundary == Boundary::Free {
            "free"
        } else {
            "periodic"
        }),
    );
    obj.insert("p_fc".into(), json!(p_fc));
    obj.insert("pressure_over_p_fc".into(), json!(pressure / p_fc));
    if let Some(out) = &out {
        let params = json!({
            "lattice": prob.lattice.map(|l| l.name()), "n": prob.n,
            "surface": a.surface.as_ref().map(|p| p.display().to_string()),
            "boundary": a.boundary, "pressure": pressure, "tol_gap": opts.tol_gap,
            "tol_force": opts.tol_force, "method": a.method, "interaction": io::interaction_json(&interaction),
        });
        let mut prov = Provenance::for_command("solve", CODE_VERSION, params)?;
        prov.wall_s = sol.stats.wall_s;
        prov.stats = io::stats_json(&sol.stats);
        let mut w = out.create()?;
        io::write_solution(&mut w, prob.heights.view(), &sol)?;
        if let Some(lattice) = prob.lattice {
            w.set_attr("lattice", lattice.name())?;
        }
        w.set_attr("p_fc", p_fc)?;
        w.write_provenance(&prov)?;
        let written = out.publish(w)?;
        obj.insert("out".into(), json!(written.display().to_string()));
    }
    println!("{}", serde_json::to_string(&summary)?);
    Ok(())
}
