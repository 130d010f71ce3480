//! `flow`: Reynolds thin-film flow through the gap of every stored point of a load path.
//!
//! # Input
//! `sweep`: one `sweep` stage whose artefact holds gap fields, `fields/<branch>_<index>/gap`
//! (`index` = the point's position in `points/*`). A sweep stores them where its `fields_at`
//! asks, or at every point with `fields_all` (what a flux-against-load curve needs). Points
//! without a stored gap are skipped and counted (`n_skipped`, a warning); a sweep without any is
//! an error that says how to ask for them.
//!
//! # Parameters
//! - `axis` (`x` | `y`, default `x`): the unit mean pressure drop is imposed along it. For the
//!   three models the fluid percolates along x and y alike below L_c and stops along both at
//!   the same load (up to the grid's anisotropy, see the report), so x is the default.
//! - `branches` (`loading` | `unloading` | `both`, default `both`): which branches to solve.
//! - `tol` (default 1e-10), `max_iter` (default 200): [`reynolds::FlowOptions`].
//! - `currents_at`: control values (loads in the sweep's `unit`) at which the current density
//!   of the nearest solved point of each branch is stored (default none).
//! - `current_last_flowing` (default false): store the current density at the last point of
//!   each branch where the fluid still flows (nearest to where the flow stops).
//!
//! # Artefact
//! - root attributes: `axis`, `tol`, `lattice`, `n`, `nx`, `ny`, `lx`, `ly`, `p_fc`,
//!   `unit_scale`, `interaction`, `gamma0` (0 for the hard wall), `rho`, `n_points`,
//!   `n_skipped`, `n_unconverged` (flow solves that did not converge),
//!   `n_contact_unconverged` (points whose contact solve did not converge);
//! - `points/*`, one entry per solved point in path order: `sweep_index`, `branch`, `step`,
//!   `load` (E* h0/λ), `strength`, `contact_area`, `contact_converged` (u8), `flux` (volume
//!   flux through the cell for a unit pressure drop), `conductivity` (effective; a uniform gap g
//!   gives g³), `percolating` (u8), `converged` (u8), `termination`, `iterations`, `residual`,
//!   `residual_floor`, `flux_rounding_error`, `conservation_error`, `flux_error_estimate`, `flowing_nodes`,
//!   `removed_nodes`, `wall_s`;
//! - `stops/*`, one entry per branch where the flow stops or starts between two solved points:
//!   `branch`, `index_flowing` and `index_blocked` (into `points/*`), `load_flowing`,
//!   `load_blocked`, `conductivity_flowing`, `contact_area_flowing`, `contact_area_blocked`;
//! - `currents/<branch>_<index>/{gap,pressure,current_x,current_y}` (pressure of the fluid,
//!   NaN in contact and in removed pools) with attributes `load`, `strength`, `flux`,
//!   `conductivity`, `contact_area`, `sweep_index`.
//!
//! A flow solve that does not converge is never used silently: it is kept with `converged = 0`
//! and its termination, listed in the stage's warnings, and the figure leaves it out. A point
//! whose contact solve did not converge is flagged likewise (`contact_converged = 0`).

use anyhow::{Context, Result, anyhow, bail};
use formats::gapfile;
use orchestrator::{InputSpec, Inputs, ParamSpec, ParamType, StageContext, StageReport, TypedKind};
use reynolds::{FlowAxis, FlowOptions, FlowResult};
use serde::Deserialize;
use serde_json::{Value, json};
use store::{ArtefactReader, ArtefactWriter, fields};

/// The `flow` stage kind.
pub struct FlowKind;

/// Bump when the artefact's content changes for the same parameters.
pub const CODE_VERSION: u64 = 5;

/// The group of a sweep point's fields.
pub fn fields_group(branch: &str, index: usize) -> String {
    format!("fields/{branch}_{index}")
}

/// The points of a sweep artefact that the flow stage needs.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepPoints {
    /// "loading" or "unloading".
    pub branch: Vec<String>,
    /// Step in the planned path.
    pub step: Vec<i64>,
    /// Mean pressure (E* h0/λ).
    pub load: Vec<f64>,
    /// γ0 or γr (0 for the hard wall).
    pub strength: Vec<f64>,
    /// Relative contact area.
    pub contact_area: Vec<f64>,
    /// The contact solve converged.
    pub converged: Vec<bool>,
}

impl SweepPoints {
    /// Reads `points/*` of a sweep artefact.
    pub fn read(r: &ArtefactReader) -> Result<Self> {
        let ctx = || {
            format!(
                "reading the points of sweep artefact `{}`",
                r.path().display()
            )
        };
        (|| -> Result<Self> {
            let p = SweepPoints {
                branch: r.read_strings("points/branch")?,
                step: r.read_i64_1d("points/step")?,
                load: r.read_f64_1d("points/load")?,
                strength: r.read_f64_1d("points/strength")?,
                contact_area: r.read_f64_1d("points/contact_area")?,
                converged: r
                    .read_u8_1d("points/converged")?
                    .into_iter()
                    .map(|c| c != 0)
                    .collect(),
            };
            let n = p.branch.len();
            for (k, len) in [
                ("step", p.step.len()),
                ("load", p.load.len()),
                ("strength", p.strength.len()),
                ("contact_area", p.contact_area.len()),
                ("converged", p.converged.len()),
            ] {
                if len != n {
                    bail!("points/{k} has {len} entries, points/branch has {n}");
                }
            }
            Ok(p)
        })()
        .with_context(ctx)
    }
    /// Number of points.
    pub fn len(&self) -> usize {
        self.branch.len()
    }
    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.branch.is_empty()
    }
}

/// One solved point.
struct Row {
    sweep_index: usize,
    res: FlowResult,
}

/// Deserialises a flow axis (`"x"`, `"y"`) through [`gapfile::parse_axis`].
pub(crate) fn de_axis<'de, D: serde::Deserializer<'de>>(d: D) -> Result<FlowAxis, D::Error> {
    let s = String::deserialize(d)?;
    gapfile::parse_axis(&s).map_err(serde::de::Error::custom)
}

/// The `flow` kind's parameters.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlowParams {
    /// Flow direction.
    #[serde(deserialize_with = "de_axis")]
    pub axis: FlowAxis,
    /// `loading`, `unloading` or `both`.
    pub branches: String,
    /// Target true relative residual.
    pub tol: f64,
    /// Cap on preconditioned CG iterations per solve.
    pub max_iter: usize,
    /// Loads at which the current density is stored.
    pub currents_at: Vec<f64>,
    /// Store the current density at the last flowing point of each branch.
    pub current_last_flowing: bool,
    /// Loads at which the loading branch's conductivity is a headline number.
    pub headline_at: Vec<f64>,
}

impl FlowParams {
    fn wanted_branch(&self, branch: &str) -> bool {
        self.branches == "both" || self.branches == branch
    }
}

impl TypedKind for FlowKind {
    type Params = FlowParams;
    /// Lower bound: the gap, the pressure and the two face conductances on the grid of the
    /// sweep's surface (the solver holds more: multigrid levels, Krylov vectors).
    fn memory_estimate(
        &self,
        _params: &orchestrator::Params,
        inputs: &std::collections::BTreeMap<String, Vec<orchestrator::Params>>,
    ) -> Option<u64> {
        let n = orchestrator::upstream_max(inputs, &["n"])?;
        Some(4 * crate::surface::field_bytes(n))
    }
    fn name(&self) -> &str {
        "flow"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "Reynolds flow (flux, conductivity, percolation) at every stored gap of a load path"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("axis", ParamType::one_of(&["x", "y"]))
                .default("x")
                .doc("flow direction: the mean pressure drops along it"),
            ParamSpec::new(
                "branches",
                ParamType::one_of(&["loading", "unloading", "both"]),
            )
            .default("both")
            .doc("which branches of the path to solve"),
            ParamSpec::new(
                "tol",
                ParamType::Float {
                    min: Some(0.0),
                    min_exclusive: true,
                    max: Some(1e-3),
                    max_exclusive: false,
                },
            )
            .default(1e-10)
            .doc("target true relative residual of each flow solve"),
            ParamSpec::new("max_iter", ParamType::int_range(1, 100_000))
                .default(200)
                .doc("cap on preconditioned CG iterations per solve"),
            ParamSpec::new(
                "currents_at",
                ParamType::Array {
                    elem: Box::new(ParamType::float()),
                    min_len: 0,
                    max_len: Some(100),
                },
            )
            .default(json!([]))
            .doc("loads (in the sweep's unit) at which the current density is stored"),
            ParamSpec::new("current_last_flowing", ParamType::Bool)
                .default(false)
                .doc("store the current density at the last flowing point of each branch"),
            ParamSpec::new(
                "headline_at",
                ParamType::Array {
                    elem: Box::new(ParamType::positive()),
                    min_len: 0,
                    max_len: Some(10),
                },
            )
            .default(json!([]))
            .doc("loads (in the sweep's unit) at which the loading branch's conductivity is a headline number (log-linear between the neighbouring points)"),
        ]
    }
    fn inputs(&self, _params: &FlowParams) -> Vec<InputSpec> {
        vec![
            InputSpec::one("sweep", &["sweep"])
                .doc("a load path whose artefact holds gap fields (fields_at or fields_all)"),
        ]
    }
    fn cost(&self, _params: &FlowParams) -> f64 {
        0.2
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &FlowParams,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let sweep = inputs.one("sweep")?;
        let sweep_file = sweep.path().display().to_string();
        let axis = params.axis;
        let opts = FlowOptions {
            tolerance: params.tol,
            max_iterations: params.max_iter,
            return_fields: false,
            ..Default::default()
        };
        let pts = SweepPoints::read(sweep)?;
        let (lx, ly) = sweep.cell()?;
        let unit_scale = sweep.attr_f64("unit_scale").unwrap_or(1.0);
        let control = sweep.attr_str("control").unwrap_or_else(|_| "load".into());

        // which points have a stored gap
        let selected: Vec<usize> = (0..pts.len())
            .filter(|&k| params.wanted_branch(&pts.branch[k]))
            .collect();
        let with_gap: Vec<usize> = selected
            .iter()
            .copied()
            .filter(|&k| sweep.has_dataset(&format!("{}/gap", fields_group(&pts.branch[k], k))))
            .collect();
        if with_gap.is_empty() {
            bail!(
                "sweep artefact `{sweep_file}` holds no gap fields for the {} points of the \
                 selected branches ({}); set `fields_all = true` (every point) or `fields_at` \
                 (chosen loads) on the sweep stage",
                selected.len(),
                params.branches
            );
        }
        let skipped = selected.len() - with_gap.len();
        if skipped > 0 {
            ctx.warn(format!(
                "{skipped} of {} points of the selected branches have no stored gap field and \
                 are skipped (the sweep stores fields only where `fields_at` asks; \
                 `fields_all = true` stores every point)",
                selected.len()
            ));
        }

        // solve
        let mut rows: Vec<Row> = Vec::with_capacity(with_gap.len());
        let (mut nx, mut ny) = (0usize, 0usize);
        for (done, &k) in with_gap.iter().enumerate() {
            let group = fields_group(&pts.branch[k], k);
            let gap = sweep
                .read_f64_2d(&format!("{group}/gap"))
                .with_context(|| format!("`{sweep_file}`: reading `{group}/gap`"))?;
            gapfile::check_gap_values(&gap)
                .map_err(|m| anyhow!("`{sweep_file}`: dataset `/{group}/gap`: {m}"))?;
            (nx, ny) = gap.dim();
            let res = reynolds::solve(gap.view(), lx, ly, axis, &opts)
                .map_err(|e| anyhow!("`{sweep_file}`: `{group}/gap`: {e}"))?;
            ctx.progress(
                (done + 1) as f64 / with_gap.len() as f64,
                &format!(
                    "{} load {:.5}: K = {:.3e}",
                    pts.branch[k], pts.load[k], res.conductivity
                ),
            );
            rows.push(Row {
                sweep_index: k,
                res,
            });
        }

        // flags
        let bad: Vec<&Row> = rows.iter().filter(|r| !r.res.converged).collect();
        if !bad.is_empty() {
            let list: Vec<String> = bad
                .iter()
                .take(10)
                .map(|r| {
                    format!(
                        "{} load {:.6}: {} after {} iterations (residual {:.2e}, conservation \
                         error {:.2e})",
                        pts.branch[r.sweep_index],
                        pts.load[r.sweep_index],
                        gapfile::termination_name(r.res.termination),
                        r.res.iterations,
                        r.res.relative_residual,
                        r.res.conservation_error
                    )
                })
                .collect();
            ctx.warn(format!(
                "{} of {} flow solves did not converge (flagged converged = 0, left out of \
                 figures){}: {}",
                bad.len(),
                rows.len(),
                if bad.len() > 10 { "; the first 10" } else { "" },
                list.join("; ")
            ));
        }
        let contact_bad = rows
            .iter()
            .filter(|r| !pts.converged[r.sweep_index])
            .count();
        if contact_bad > 0 {
            ctx.warn(format!(
                "{contact_bad} of {} points come from contact solves that did not converge \
                 (flagged contact_converged = 0)",
                rows.len()
            ));
        }

        // where the flow stops or starts along each branch (between consecutive solved points)
        let mut stops: Vec<(String, usize, usize)> = Vec::new(); // (branch, flowing, blocked)
        for br in ["loading", "unloading"] {
            let idx: Vec<usize> = (0..rows.len())
                .filter(|&i| pts.branch[rows[i].sweep_index] == br)
                .collect();
            for w in idx.windows(2) {
                let (a, b) = (&rows[w[0]].res, &rows[w[1]].res);
                if a.percolating != b.percolating {
                    let (f, bl) = if a.percolating {
                        (w[0], w[1])
                    } else {
                        (w[1], w[0])
                    };
                    stops.push((br.to_string(), f, bl));
                }
            }
        }

        // current densities
        let mut current_rows: Vec<usize> = Vec::new();
        for &target in &params.currents_at {
            for br in ["loading", "unloading"] {
                if let Some(i) = (0..rows.len())
                    .filter(|&i| pts.branch[rows[i].sweep_index] == br)
                    .min_by(|&a, &b| {
                        let d = |i: usize| {
                            let k = rows[i].sweep_index;
                            let v = if control == "strength" {
                                pts.strength[k]
                            } else {
                                pts.load[k] / unit_scale
                            };
                            (v - target).abs()
                        };
                        d(a).total_cmp(&d(b))
                    })
                {
                    current_rows.push(i);
                }
            }
        }
        if params.current_last_flowing {
            for br in ["loading", "unloading"] {
                let idx: Vec<usize> = (0..rows.len())
                    .filter(|&i| pts.branch[rows[i].sweep_index] == br)
                    .collect();
                // the flowing point next to a stop, or the last flowing point of the branch
                let mut chosen: Vec<usize> =
                    stops.iter().filter(|s| s.0 == br).map(|s| s.1).collect();
                if chosen.is_empty()
                    && let Some(&i) = idx.iter().rev().find(|&&i| rows[i].res.percolating)
                {
                    chosen.push(i);
                }
                current_rows.extend(chosen);
            }
        }
        current_rows.sort_unstable();
        current_rows.dedup();
        let copts = FlowOptions {
            return_fields: true,
            ..opts.clone()
        };
        for &i in &current_rows {
            let k = rows[i].sweep_index;
            let src = fields_group(&pts.branch[k], k);
            let gap = sweep.read_f64_2d(&format!("{src}/gap"))?;
            let res = reynolds::solve(gap.view(), lx, ly, axis, &copts)
                .map_err(|e| anyhow!("`{sweep_file}`: `{src}/gap`: {e}"))?;
            let f = res.fields.as_ref().expect("fields requested");
            let g = format!("currents/{}_{}", pts.branch[k], k);
            out.write_f64_2d(&format!("{g}/{}", fields::GAP), gap.view())?;
            out.write_f64_2d(&format!("{g}/{}", fields::PRESSURE), f.pressure.view())?;
            out.write_f64_2d(&format!("{g}/{}", fields::CURRENT_X), f.current_x.view())?;
            out.write_f64_2d(&format!("{g}/{}", fields::CURRENT_Y), f.current_y.view())?;
            out.set_attr_at(&g, "load", pts.load[k])?;
            out.set_attr_at(&g, "strength", pts.strength[k])?;
            out.set_attr_at(&g, "flux", res.flux)?;
            out.set_attr_at(&g, "conductivity", res.conductivity)?;
            out.set_attr_at(&g, "converged", res.converged)?;
            out.set_attr_at(&g, "contact_area", pts.contact_area[k])?;
            out.set_attr_at(&g, "sweep_index", k as i64)?;
        }

        // artefact
        out.set_cell(lx, ly)?;
        out.set_attr("axis", gapfile::axis_name(axis))?;
        out.set_attr("tol", opts.tolerance)?;
        for key in ["lattice", "interaction", "control"] {
            if let Ok(v) = sweep.attr_str(key) {
                out.set_attr(key, v)?;
            }
        }
        for key in ["p_fc", "rho"] {
            if let Ok(v) = sweep.attr_f64(key) {
                out.set_attr(key, v)?;
            }
        }
        out.set_attr("gamma0", sweep.attr_f64("gamma0").unwrap_or(0.0))?;
        out.set_attr("unit_scale", unit_scale)?;
        if let Ok(n) = sweep.attr_i64("n") {
            out.set_attr("n", n)?;
        }
        out.set_attr("nx", nx as i64)?;
        out.set_attr("ny", ny as i64)?;
        out.set_attr("n_points", rows.len() as i64)?;
        out.set_attr("n_skipped", skipped as i64)?;
        out.set_attr("n_unconverged", bad.len() as i64)?;
        out.set_attr("n_contact_unconverged", contact_bad as i64)?;
        write_rows(out, &rows, &pts)?;
        let sel = |f: &dyn Fn(&(String, usize, usize)) -> f64| -> Vec<f64> {
            stops.iter().map(f).collect()
        };
        out.write_strings(
            "stops/branch",
            &stops.iter().map(|s| s.0.as_str()).collect::<Vec<_>>(),
        )?;
        out.write_i64_1d(
            "stops/index_flowing",
            &stops.iter().map(|s| s.1 as i64).collect::<Vec<_>>(),
        )?;
        out.write_i64_1d(
            "stops/index_blocked",
            &stops.iter().map(|s| s.2 as i64).collect::<Vec<_>>(),
        )?;
        let load_of = |i: usize| pts.load[rows[i].sweep_index];
        let area_of = |i: usize| pts.contact_area[rows[i].sweep_index];
        out.write_f64_1d("stops/load_flowing", &sel(&|s| load_of(s.1)))?;
        out.write_f64_1d("stops/load_blocked", &sel(&|s| load_of(s.2)))?;
        out.write_f64_1d(
            "stops/conductivity_flowing",
            &sel(&|s| rows[s.1].res.conductivity),
        )?;
        out.write_f64_1d("stops/contact_area_flowing", &sel(&|s| area_of(s.1)))?;
        out.write_f64_1d("stops/contact_area_blocked", &sel(&|s| area_of(s.2)))?;

        // headline numbers: the loading branch's conductivity at given loads
        let mut heads = Vec::new();
        let lattice = sweep.attr_str("lattice").unwrap_or_default();
        let inter = sweep.attr_str("interaction").unwrap_or_default();
        for &x in &params.headline_at {
            let curve: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| pts.branch[r.sweep_index] == "loading" && r.res.converged)
                .map(|r| (pts.load[r.sweep_index] / unit_scale, r.res.conductivity))
                .collect();
            match curve
                .windows(2)
                .find(|w| w[0].0 <= x && x <= w[1].0 && w[0].1 > 0.0 && w[1].1 > 0.0)
            {
                Some(w) => {
                    let t = if w[1].0 > w[0].0 {
                        (x - w[0].0) / (w[1].0 - w[0].0)
                    } else {
                        0.0
                    };
                    let k = (w[0].1.ln() * (1.0 - t) + w[1].1.ln() * t).exp();
                    heads.push(crate::headline::Headline::new(
                        format!("K {lattice} {inter} at {x} p_fc"),
                        k,
                        f64::NAN,
                    ));
                }
                None => ctx.warn(format!(
                    "headline_at {x}: no two converged, flowing loading points bracket it; no headline"
                )),
            }
        }
        crate::headline::write(out, &heads)?;

        let iters: Vec<usize> = rows.iter().map(|r| r.res.iterations).collect();
        Ok(StageReport::with_stats(json!({
            "points": rows.len(),
            "skipped": skipped,
            "unconverged": bad.len(),
            "contact_unconverged": contact_bad,
            "iterations_total": iters.iter().sum::<usize>(),
            "iterations_max": iters.iter().copied().max().unwrap_or(0),
            "residual_max": rows.iter().map(|r| r.res.relative_residual).fold(0.0, f64::max),
            "conservation_error_max": rows
                .iter()
                .map(|r| r.res.conservation_error)
                .fold(0.0, f64::max),
            "solve_wall_s": rows.iter().map(|r| r.res.wall_seconds).sum::<f64>(),
            "stops": stops.iter().map(|s| json!({
                "branch": s.0,
                "load_flowing": load_of(s.1),
                "load_blocked": load_of(s.2),
                "conductivity_flowing": rows[s.1].res.conductivity,
                "contact_area": [area_of(s.1), area_of(s.2)],
            })).collect::<Vec<Value>>(),
            "currents": current_rows.len(),
        })))
    }
}

fn write_rows(out: &mut ArtefactWriter, rows: &[Row], pts: &SweepPoints) -> Result<()> {
    let f = |out: &mut ArtefactWriter, k: &str, g: &dyn Fn(&Row) -> f64| {
        out.write_f64_1d(
            &format!("points/{k}"),
            &rows.iter().map(g).collect::<Vec<_>>(),
        )
    };
    let i = |out: &mut ArtefactWriter, k: &str, g: &dyn Fn(&Row) -> i64| {
        out.write_i64_1d(
            &format!("points/{k}"),
            &rows.iter().map(g).collect::<Vec<_>>(),
        )
    };
    let b = |out: &mut ArtefactWriter, k: &str, g: &dyn Fn(&Row) -> bool| {
        out.write_u8_1d(
            &format!("points/{k}"),
            &rows.iter().map(|r| g(r) as u8).collect::<Vec<_>>(),
        )
    };
    i(out, "sweep_index", &|r| r.sweep_index as i64)?;
    out.write_strings(
        "points/branch",
        &rows
            .iter()
            .map(|r| pts.branch[r.sweep_index].as_str())
            .collect::<Vec<_>>(),
    )?;
    i(out, "step", &|r| pts.step[r.sweep_index])?;
    f(out, "load", &|r| pts.load[r.sweep_index])?;
    f(out, "strength", &|r| pts.strength[r.sweep_index])?;
    f(out, "contact_area", &|r| pts.contact_area[r.sweep_index])?;
    b(out, "contact_converged", &|r| pts.converged[r.sweep_index])?;
    f(out, "flux", &|r| r.res.flux)?;
    f(out, "conductivity", &|r| r.res.conductivity)?;
    b(out, "percolating", &|r| r.res.percolating)?;
    b(out, "converged", &|r| r.res.converged)?;
    out.write_strings(
        "points/termination",
        &rows
            .iter()
            .map(|r| gapfile::termination_name(r.res.termination))
            .collect::<Vec<_>>(),
    )?;
    i(out, "iterations", &|r| r.res.iterations as i64)?;
    f(out, "residual", &|r| r.res.relative_residual)?;
    f(out, "residual_floor", &|r| r.res.residual_floor)?;
    f(out, "flux_rounding_error", &|r| r.res.flux_rounding_error)?;
    f(out, "conservation_error", &|r| r.res.conservation_error)?;
    f(out, "flux_error_estimate", &|r| r.res.flux_error_estimate)?;
    i(out, "flowing_nodes", &|r| r.res.flowing_nodes as i64)?;
    i(out, "removed_nodes", &|r| r.res.removed_nodes as i64)?;
    f(out, "wall_s", &|r| r.res.wall_seconds)?;
    Ok(())
}

/// A `flow` artefact, read back (for the figure and table kinds).
#[derive(Clone, Debug, PartialEq)]
pub struct FlowData {
    /// Surface model.
    pub lattice: String,
    /// hardwall, adhesion or repulsion.
    pub interaction: String,
    /// γ0 (0 unless adhesion).
    pub gamma0: f64,
    /// Full-contact pressure of the grid.
    pub p_fc: f64,
    /// Flow axis.
    pub axis: String,
    /// Grid exponent.
    pub n: i64,
    /// Branch of each point.
    pub branch: Vec<String>,
    /// Mean pressure (E* h0/λ).
    pub load: Vec<f64>,
    /// Effective conductivity.
    pub conductivity: Vec<f64>,
    /// Flux for a unit pressure drop.
    pub flux: Vec<f64>,
    /// Fluid winds along the axis.
    pub percolating: Vec<bool>,
    /// Flow solve converged.
    pub converged: Vec<bool>,
    /// Contact solve converged.
    pub contact_converged: Vec<bool>,
    /// Relative contact area.
    pub contact_area: Vec<f64>,
}

impl FlowData {
    /// Reads a `flow` artefact.
    pub fn read(r: &ArtefactReader) -> Result<Self> {
        let ctx = || format!("reading flow artefact `{}`", r.path().display());
        (|| -> Result<Self> {
            let b = |k: &str| -> Result<Vec<bool>> {
                Ok(r.read_u8_1d(&format!("points/{k}"))?
                    .into_iter()
                    .map(|x| x != 0)
                    .collect())
            };
            let d = FlowData {
                lattice: r.attr_str("lattice")?,
                interaction: r.attr_str("interaction")?,
                gamma0: r.attr_f64("gamma0")?,
                p_fc: r.attr_f64("p_fc")?,
                axis: r.attr_str("axis")?,
                n: r.attr_i64("n")?,
                branch: r.read_strings("points/branch")?,
                load: r.read_f64_1d("points/load")?,
                conductivity: r.read_f64_1d("points/conductivity")?,
                flux: r.read_f64_1d("points/flux")?,
                percolating: b("percolating")?,
                converged: b("converged")?,
                contact_converged: b("contact_converged")?,
                contact_area: r.read_f64_1d("points/contact_area")?,
            };
            let n = d.branch.len();
            for (k, len) in [
                ("load", d.load.len()),
                ("conductivity", d.conductivity.len()),
                ("flux", d.flux.len()),
                ("percolating", d.percolating.len()),
                ("converged", d.converged.len()),
                ("contact_converged", d.contact_converged.len()),
                ("contact_area", d.contact_area.len()),
            ] {
                if len != n {
                    bail!("points/{k} has {len} entries, points/branch has {n}");
                }
            }
            Ok(d)
        })()
        .with_context(ctx)
    }

    /// Indices of the points of `branch` whose flow and contact solves converged, in path
    /// order; and how many of the branch's points were left out.
    pub fn usable(&self, branch: &str) -> (Vec<usize>, usize) {
        let all: Vec<usize> = (0..self.branch.len())
            .filter(|&k| self.branch[k] == branch)
            .collect();
        let ok: Vec<usize> = all
            .iter()
            .copied()
            .filter(|&k| self.converged[k] && self.contact_converged[k])
            .collect();
        let left_out = all.len() - ok.len();
        (ok, left_out)
    }
}
