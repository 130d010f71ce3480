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
//! The records are declared once in [`crate::flow_artefact`] (writer and reader).
//!
//! A flow solve that does not converge is never used silently: it is kept with `converged = 0`
//! and its termination, listed in the stage's warnings, and the figure leaves it out. A point
//! whose contact solve did not converge is flagged likewise (`contact_converged = 0`).

use crate::flow_artefact::{FlowPoint, FlowStop, find_stops};
use crate::sweep::{Point, SweepData};
use crate::sweep_artefact::fields_group;
use anyhow::{Context, Result, anyhow, bail};
use contact::path::Branch;
use formats::gapfile;
use formats::records::Record;
use orchestrator::{InputSpec, Inputs, ParamSpec, ParamType, StageContext, StageReport, TypedKind};
use reynolds::{FlowAxis, FlowOptions};
use serde::Deserialize;
use serde_json::{Value, json};
use store::{ArtefactReader, ArtefactWriter, fields};

pub use crate::flow_artefact::FlowData;

/// The `flow` stage kind.
pub struct FlowKind;

/// Bump when the artefact's content changes for the same parameters.
pub const CODE_VERSION: u64 = 5;

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
    fn wanted_branch(&self, branch: Branch) -> bool {
        self.branches == "both" || self.branches == branch.name()
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
        let src = Source::open(inputs.one("sweep")?)?;
        let opts = FlowOptions {
            tolerance: params.tol,
            max_iterations: params.max_iter,
            return_fields: false,
            ..Default::default()
        };
        let (with_gap, skipped) = src.points_with_gap(ctx, params)?;
        let (points, (nx, ny)) = solve_points(ctx, &src, &with_gap, params.axis, &opts)?;
        let n_bad = warn_unconverged(ctx, &points);
        let contact_bad = points.iter().filter(|p| !p.contact_converged).count();
        if contact_bad > 0 {
            ctx.warn(format!(
                "{contact_bad} of {} points come from contact solves that did not converge \
                 (flagged contact_converged = 0)",
                points.len()
            ));
        }
        let stops = find_stops(&points);
        let current = current_points(params, &src, &points, &stops);
        for &i in &current {
            write_current(out, &src, &points[i], params.axis, &opts)?;
        }

        // artefact
        src.copy_attrs(out)?;
        out.set_attr("axis", gapfile::axis_name(params.axis))?;
        out.set_attr("tol", opts.tolerance)?;
        src.copy_more_attrs(out)?;
        for (k, v) in [
            ("nx", nx),
            ("ny", ny),
            ("n_points", points.len()),
            ("n_skipped", skipped),
            ("n_unconverged", n_bad),
            ("n_contact_unconverged", contact_bad),
        ] {
            out.set_attr(k, v as i64)?;
        }
        FlowPoint::write(&points, out, "points")?;
        FlowStop::write(&stops, out, "stops")?;
        let heads = headlines(ctx, params, &src, &points);
        crate::headline::write(out, &heads)?;
        Ok(report(
            &points,
            &stops,
            skipped,
            n_bad,
            contact_bad,
            current.len(),
        ))
    }
}

/// The input sweep: its points and what the flow needs of its attributes.
struct Source<'a> {
    r: &'a ArtefactReader,
    file: String,
    points: Vec<Point>,
    cell: (f64, f64),
    unit_scale: f64,
    strength_path: bool,
}

impl<'a> Source<'a> {
    fn open(r: &'a ArtefactReader) -> Result<Self> {
        Ok(Source {
            r,
            file: r.path().display().to_string(),
            points: SweepData::read_points(r)?,
            cell: r.cell()?,
            unit_scale: r.attr_f64("unit_scale").unwrap_or(1.0),
            strength_path: r.attr_str("control").is_ok_and(|c| c == "strength"),
        })
    }

    /// The sweep point's control value in the sweep's unit (what `currents_at` is given in).
    fn control_value(&self, k: usize) -> f64 {
        let p = &self.points[k];
        if self.strength_path {
            p.strength
        } else {
            p.load / self.unit_scale
        }
    }

    /// The points of the selected branches that have a stored gap, and how many do not.
    fn points_with_gap(
        &self,
        ctx: &mut StageContext,
        params: &FlowParams,
    ) -> Result<(Vec<usize>, usize)> {
        let selected: Vec<usize> = (0..self.points.len())
            .filter(|&k| params.wanted_branch(self.points[k].branch))
            .collect();
        let with_gap: Vec<usize> = selected
            .iter()
            .copied()
            .filter(|&k| self.r.has_dataset(&format!("{}/gap", self.group(k))))
            .collect();
        if with_gap.is_empty() {
            bail!(
                "sweep artefact `{}` holds no gap fields for the {} points of the \
                 selected branches ({}); set `fields_all = true` (every point) or `fields_at` \
                 (chosen loads) on the sweep stage",
                self.file,
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
        Ok((with_gap, skipped))
    }

    fn group(&self, k: usize) -> String {
        fields_group(self.points[k].branch, k)
    }

    /// The stored gap of sweep point `k`, checked.
    fn gap(&self, k: usize) -> Result<ndarray::Array2<f64>> {
        let group = self.group(k);
        let gap = self
            .r
            .read_f64_2d(&format!("{group}/gap"))
            .with_context(|| format!("`{}`: reading `{group}/gap`", self.file))?;
        gapfile::check_gap_values(&gap)
            .map_err(|m| anyhow!("`{}`: dataset `/{group}/gap`: {m}", self.file))?;
        Ok(gap)
    }

    fn solve(
        &self,
        k: usize,
        gap: &ndarray::Array2<f64>,
        axis: FlowAxis,
        opts: &FlowOptions,
    ) -> Result<reynolds::FlowResult> {
        let (lx, ly) = self.cell;
        reynolds::solve(gap.view(), lx, ly, axis, opts)
            .map_err(|e| anyhow!("`{}`: `{}/gap`: {e}", self.file, self.group(k)))
    }

    /// The cell and the sweep's description, copied (written before `axis`).
    fn copy_attrs(&self, out: &mut ArtefactWriter) -> Result<()> {
        out.set_cell(self.cell.0, self.cell.1)
    }

    /// The sweep's description, copied (written after `axis` and `tol`).
    fn copy_more_attrs(&self, out: &mut ArtefactWriter) -> Result<()> {
        let r = self.r;
        for key in ["lattice", "interaction", "control"] {
            if let Ok(v) = r.attr_str(key) {
                out.set_attr(key, v)?;
            }
        }
        for key in ["p_fc", "rho"] {
            if let Ok(v) = r.attr_f64(key) {
                out.set_attr(key, v)?;
            }
        }
        out.set_attr("gamma0", r.attr_f64("gamma0").unwrap_or(0.0))?;
        out.set_attr("unit_scale", self.unit_scale)?;
        if let Ok(n) = r.attr_i64("n") {
            out.set_attr("n", n)?;
        }
        Ok(())
    }
}

/// One flow solve per sweep point with a gap; the grid of the last gap.
fn solve_points(
    ctx: &mut StageContext,
    src: &Source,
    with_gap: &[usize],
    axis: FlowAxis,
    opts: &FlowOptions,
) -> Result<(Vec<FlowPoint>, (usize, usize))> {
    let mut points = Vec::with_capacity(with_gap.len());
    let mut dim = (0, 0);
    for (done, &k) in with_gap.iter().enumerate() {
        let gap = src.gap(k)?;
        dim = gap.dim();
        let res = src.solve(k, &gap, axis, opts)?;
        let p = &src.points[k];
        ctx.progress(
            (done + 1) as f64 / with_gap.len() as f64,
            &format!(
                "{} load {:.5}: K = {:.3e}",
                p.branch, p.load, res.conductivity
            ),
        );
        points.push(FlowPoint::new(k, p, &res));
    }
    Ok((points, dim))
}

/// Warns about flow solves that did not converge; returns how many.
fn warn_unconverged(ctx: &mut StageContext, points: &[FlowPoint]) -> usize {
    let bad: Vec<&FlowPoint> = points.iter().filter(|p| !p.converged).collect();
    if !bad.is_empty() {
        let list: Vec<String> = bad
            .iter()
            .take(10)
            .map(|p| {
                format!(
                    "{} load {:.6}: {} after {} iterations (residual {:.2e}, conservation \
                     error {:.2e})",
                    p.branch,
                    p.load,
                    gapfile::termination_name(p.termination),
                    p.iterations,
                    p.residual,
                    p.conservation_error
                )
            })
            .collect();
        ctx.warn(format!(
            "{} of {} flow solves did not converge (flagged converged = 0, left out of \
             figures){}: {}",
            bad.len(),
            points.len(),
            if bad.len() > 10 { "; the first 10" } else { "" },
            list.join("; ")
        ));
    }
    bad.len()
}

/// The points whose current density is stored: per branch the one nearest to each of
/// `currents_at`, and with `current_last_flowing` the flowing point next to each stop (or the
/// branch's last flowing point); sorted, without repeats.
fn current_points(
    params: &FlowParams,
    src: &Source,
    points: &[FlowPoint],
    stops: &[FlowStop],
) -> Vec<usize> {
    let branches = [Branch::Loading, Branch::Unloading];
    let of = |br: Branch| -> Vec<usize> {
        (0..points.len())
            .filter(|&i| points[i].branch == br)
            .collect()
    };
    let mut chosen: Vec<usize> = Vec::new();
    for &target in &params.currents_at {
        for br in branches {
            let d = |i: usize| (src.control_value(points[i].sweep_index) - target).abs();
            if let Some(i) = of(br).into_iter().min_by(|&a, &b| d(a).total_cmp(&d(b))) {
                chosen.push(i);
            }
        }
    }
    if params.current_last_flowing {
        for br in branches {
            let mut at_stops: Vec<usize> = stops
                .iter()
                .filter(|s| s.branch == br)
                .map(|s| s.index_flowing)
                .collect();
            if at_stops.is_empty()
                && let Some(&i) = of(br).iter().rev().find(|&&i| points[i].percolating)
            {
                at_stops.push(i);
            }
            chosen.extend(at_stops);
        }
    }
    chosen.sort_unstable();
    chosen.dedup();
    chosen
}

/// `currents/<branch>_<index>/{gap,pressure,current_x,current_y}` of one point, solved again
/// with the fields returned.
fn write_current(
    out: &mut ArtefactWriter,
    src: &Source,
    p: &FlowPoint,
    axis: FlowAxis,
    opts: &FlowOptions,
) -> Result<()> {
    let k = p.sweep_index;
    let src_group = src.group(k);
    let gap = src.r.read_f64_2d(&format!("{src_group}/gap"))?;
    let copts = FlowOptions {
        return_fields: true,
        ..opts.clone()
    };
    let res = src.solve(k, &gap, axis, &copts)?;
    let f = res.fields.as_ref().expect("fields requested");
    let g = format!("currents/{}_{}", p.branch, k);
    out.write_f64_2d(&format!("{g}/{}", fields::GAP), gap.view())?;
    out.write_f64_2d(&format!("{g}/{}", fields::PRESSURE), f.pressure.view())?;
    out.write_f64_2d(&format!("{g}/{}", fields::CURRENT_X), f.current_x.view())?;
    out.write_f64_2d(&format!("{g}/{}", fields::CURRENT_Y), f.current_y.view())?;
    out.set_attr_at(&g, "load", p.load)?;
    out.set_attr_at(&g, "strength", p.strength)?;
    out.set_attr_at(&g, "flux", res.flux)?;
    out.set_attr_at(&g, "conductivity", res.conductivity)?;
    out.set_attr_at(&g, "converged", res.converged)?;
    out.set_attr_at(&g, "contact_area", p.contact_area)?;
    out.set_attr_at(&g, "sweep_index", k as i64)?;
    Ok(())
}

/// The loading branch's conductivity at each of `headline_at` (log-linear between the
/// converged, flowing points that bracket it); a warning where none do.
fn headlines(
    ctx: &mut StageContext,
    params: &FlowParams,
    src: &Source,
    points: &[FlowPoint],
) -> Vec<crate::headline::Headline> {
    let lattice = src.r.attr_str("lattice").unwrap_or_default();
    let inter = src.r.attr_str("interaction").unwrap_or_default();
    let curve: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p.branch == Branch::Loading && p.converged)
        .map(|p| (p.load / src.unit_scale, p.conductivity))
        .collect();
    let mut heads = Vec::new();
    for &x in &params.headline_at {
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
    heads
}

fn report(
    points: &[FlowPoint],
    stops: &[FlowStop],
    skipped: usize,
    n_bad: usize,
    contact_bad: usize,
    currents: usize,
) -> StageReport {
    let iters: Vec<usize> = points.iter().map(|p| p.iterations).collect();
    StageReport::with_stats(json!({
        "points": points.len(),
        "skipped": skipped,
        "unconverged": n_bad,
        "contact_unconverged": contact_bad,
        "iterations_total": iters.iter().sum::<usize>(),
        "iterations_max": iters.iter().copied().max().unwrap_or(0),
        "residual_max": points.iter().map(|p| p.residual).fold(0.0, f64::max),
        "conservation_error_max": points
            .iter()
            .map(|p| p.conservation_error)
            .fold(0.0, f64::max),
        "solve_wall_s": points.iter().map(|p| p.wall_s).sum::<f64>(),
        "stops": stops.iter().map(|s| json!({
            "branch": s.branch.name(),
            "load_flowing": s.load_flowing,
            "load_blocked": s.load_blocked,
            "conductivity_flowing": s.conductivity_flowing,
            "contact_area": [s.contact_area_flowing, s.contact_area_blocked],
        })).collect::<Vec<Value>>(),
        "currents": currents,
    }))
}
