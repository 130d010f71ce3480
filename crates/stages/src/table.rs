//! `table`: writes the data behind a scene as CSV side outputs (polars, through the `tables`
//! crate), under `output_dir` (default `results/tables`).
//!
//! Scenes:
//! - `fig2` (inputs `hardwall`, `adhesion`, `repulsion`: load-controlled `sweep`s) writes
//!   - `fig2.csv`, one row per path point: `interaction`, `branch`, `step`, `load`
//!     (E* h0/λ), `load_over_p_fc`, `contact_area`, `contact_area_corrected`, `mean_gap`,
//!     `iterations`, `force_residual`, `max_violation`, `converged`, `contact_clusters`,
//!     `fluid_percolates` (along x or y), `jump` (the state jumps between this point and the
//!     branch's next converged point);
//!   - `fig2_jumps.csv`, one row per jump of Figure 2's loops and per pull-off: `interaction`,
//!     `branch`, `event` (contact formation, coalescence, break-up, full contact, trough opening,
//!     pull-off, ...), `load_before`, `load_after`, `load_before_over_p_fc`,
//!     `load_after_over_p_fc`, `area_before`, `area_after`, `ratio` (jump over its neighbours'
//!     trend; empty for a pull-off, where the path ends: `load_after` is the first load without
//!     equilibrium and `area_after` is 0), `detector` (`trend`, `loop`, or `solver` for a
//!     pull-off);
//!   - `fig2_loops.csv`, one row per hysteresis loop between loading and unloading (loads at
//!     which the two branches are in different states): `interaction`, `load_lo`, `load_hi`,
//!     `load_lo_over_p_fc`, `load_hi_over_p_fc`, `max_area_difference`,
//!     `load_at_max_over_p_fc`.
//! - `fig6` (inputs `flow`: `flow` stages along load paths) writes `fig6.csv` (every flow
//!   point) and `fig6_stops.csv` (where the flow stops), columns in [`crate::fig6::tables`].
//! - `fig2_resolution` (inputs `hardwall`, `adhesion`, `repulsion`: the same load paths on one
//!   or more grids each) writes `fig2_jumps_resolution.csv`: every jump and pull-off of every
//!   grid, matched across grids, with the change of its position from the next coarser grid
//!   ([`jumptable::table`]); the hard wall has no rows unless something jumps.
//! - `fig3` (inputs `hexagonal`, `square`, `triangular`: zero-load γ0 `sweep`s, one or more
//!   grids each) writes `fig3.csv` (every point, [`fig3::points_table`]),
//!   `fig3_thresholds.csv` (γ_p, γ_fc, γ_fc/γ_p, break-up and trough opening per model and
//!   grid, [`fig3::thresholds_table`]) and `fig3_jumps.csv` (every jump, matched across
//!   grids, [`jumptable::table`]).
//! - `critical` (inputs `hexagonal`, `square`, `triangular`: `resolution` stages) writes
//!   - `critical.csv`, one row per model: L_c, a_p raw and perimeter-corrected extrapolated to
//!     zero grid spacing with their errors, the finest grid's sub-grid L_c and ζ, p_fc,
//!     p_fc/L_c, the paper's values and the deviations (columns in
//!     [`resolution::comparison_table`]);
//!   - `critical.md`, the same comparison as a Markdown table in concise notation.
//!
//! - `exponents` (input `exponents`): `exponents.csv` and `ladder_measurements.csv`, the
//!   near-critical exponents against the paper and the per-rung measurements behind them
//!   (columns in crates/stages/src/fig5.rs).
//!
//! Artefact: attributes `scene`, `rows` (JSON: file → number of rows).

use crate::fig5;
use crate::figure::check_relative;
use crate::{fig2, fig3, fig6, jumptable, resolution};
use anyhow::{Context, Result};
use orchestrator::{
    InputSpec, Inputs, ParamIssue, ParamSpec, ParamType, Params, StageContext, StageKind,
    StageReport,
};
use polars::prelude::{CsvWriter, SerWriter};
use serde_json::json;
use store::ArtefactWriter;
use tables::Table;

/// The `table` stage kind.
pub struct TableKind;

/// Bump when the tables change for the same inputs.
pub const CODE_VERSION: u64 = 2;

/// Scenes this kind tabulates.
pub const SCENES: &[&str] = &[
    "fig2",
    "fig2_resolution",
    "fig3",
    "fig6",
    "critical",
    "exponents",
];

/// The files a scene writes, relative to `output_dir`.
fn files(scene: &str) -> Vec<String> {
    match scene {
        "fig2" => vec![
            "fig2.csv".into(),
            "fig2_jumps.csv".into(),
            "fig2_loops.csv".into(),
        ],
        "fig6" => fig6::TABLE_FILES.iter().map(|s| s.to_string()).collect(),
        "fig2_resolution" => vec!["fig2_jumps_resolution.csv".into()],
        "fig3" => vec![
            "fig3.csv".into(),
            "fig3_thresholds.csv".into(),
            "fig3_jumps.csv".into(),
        ],
        "critical" => vec!["critical.csv".into(), "critical.md".into()],
        "exponents" => vec!["exponents.csv".into(), "ladder_measurements.csv".into()],
        _ => Vec::new(),
    }
}

fn dir(params: &Params) -> String {
    params
        .str("output_dir")
        .unwrap_or("results/tables")
        .trim_end_matches('/')
        .to_string()
}

/// CSV bytes of a table (the same encoding as [`tables::write_csv`]).
pub fn csv_bytes(t: &Table) -> Result<Vec<u8>> {
    let mut df = t.to_dataframe()?;
    let mut bytes = Vec::new();
    CsvWriter::new(&mut bytes)
        .include_header(true)
        .with_null_value("".into())
        .finish(&mut df)
        .context("encoding CSV")?;
    Ok(bytes)
}

/// Figure 2's tables: points, jumps, loops.
fn fig2_tables(inputs: &Inputs) -> Result<Vec<Table>> {
    let sweeps = fig2::read(inputs)?;
    // points
    let (mut inter, mut branch, mut step, mut load, mut load_r) =
        (vec![], vec![], vec![], vec![], vec![]);
    let (mut area, mut area_c, mut gap, mut iters, mut force, mut viol) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    let (mut conv, mut clusters, mut fluid, mut jump) = (vec![], vec![], vec![], vec![]);
    // jumps
    let (mut j_inter, mut j_branch, mut j_event) = (vec![], vec![], vec![]);
    let (mut j_lb, mut j_la, mut j_ab, mut j_aa, mut j_ratio) =
        (vec![], vec![], vec![], vec![], vec![]);
    let (mut j_p_fc, mut j_det) = (vec![], vec![]);
    // loops
    let (mut l_inter, mut l_lo, mut l_hi, mut l_d, mut l_x, mut l_p_fc) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    for d in &sweeps {
        for (k, p) in d.points.iter().enumerate() {
            inter.push(d.interaction.clone());
            branch.push(p.branch.clone());
            step.push(p.step);
            load.push(p.load);
            load_r.push(p.load / d.p_fc);
            area.push(p.contact_area);
            area_c.push(p.contact_area_corrected);
            gap.push(p.mean_gap);
            iters.push(p.iterations);
            force.push(p.force_residual);
            viol.push(p.max_violation);
            conv.push(p.converged);
            clusters.push(p.contact_clusters);
            fluid.push(p.fluid_percolates_x || p.fluid_percolates_y);
            jump.push(d.jumps.iter().any(|j| j.index == k));
        }
        for j in &d.jumps {
            j_inter.push(d.interaction.clone());
            j_branch.push(j.branch.clone());
            j_event.push(j.event.clone());
            j_lb.push(j.load.0);
            j_la.push(j.load.1);
            j_ab.push(j.area.0);
            j_aa.push(j.area.1);
            j_ratio.push(j.ratio);
            j_p_fc.push(d.p_fc);
            j_det.push(j.detector.clone());
        }
        for l in &d.loops {
            l_inter.push(d.interaction.clone());
            l_lo.push(l.x.0);
            l_hi.push(l.x.1);
            l_d.push(l.max_area_difference);
            l_x.push(l.x_at_max);
            l_p_fc.push(d.p_fc);
        }
        for e in &d.ended {
            // the last point of the branch before it ended
            let last = d.branch_indices(&e.branch).last().map(|&k| &d.points[k]);
            j_inter.push(d.interaction.clone());
            j_branch.push(e.branch.clone());
            j_event.push("pull-off".to_string());
            j_lb.push(last.map_or(f64::NAN, |p| p.load));
            j_la.push(e.load);
            j_ab.push(last.map_or(f64::NAN, |p| p.contact_area));
            j_aa.push(0.0);
            j_ratio.push(f64::NAN);
            j_p_fc.push(d.p_fc);
            j_det.push("solver".to_string());
        }
    }
    let points = Table::new()
        .with_str("interaction", inter)
        .with_str("branch", branch)
        .with_i64("step", step)
        .with_f64("load", load)
        .with_f64("load_over_p_fc", load_r)
        .with_f64("contact_area", area)
        .with_f64("contact_area_corrected", area_c)
        .with_f64("mean_gap", gap)
        .with_i64("iterations", iters)
        .with_f64("force_residual", force)
        .with_f64("max_violation", viol)
        .with_bool("converged", conv)
        .with_i64("contact_clusters", clusters)
        .with_bool("fluid_percolates", fluid)
        .with_bool("jump", jump);
    let ratio = |a: &[f64]| -> Vec<f64> { a.iter().zip(&j_p_fc).map(|(x, p)| x / p).collect() };
    let jumps = Table::new()
        .with_str("interaction", j_inter)
        .with_str("branch", j_branch)
        .with_str("event", j_event)
        .with_f64("load_before", j_lb.clone())
        .with_f64("load_after", j_la.clone())
        .with_f64("load_before_over_p_fc", ratio(&j_lb))
        .with_f64("load_after_over_p_fc", ratio(&j_la))
        .with_f64("area_before", j_ab)
        .with_f64("area_after", j_aa)
        .with_f64("ratio", j_ratio)
        .with_str("detector", j_det);
    let over = |a: &[f64]| -> Vec<f64> { a.iter().zip(&l_p_fc).map(|(x, p)| x / p).collect() };
    let loops = Table::new()
        .with_str("interaction", l_inter)
        .with_f64("load_lo", l_lo.clone())
        .with_f64("load_hi", l_hi.clone())
        .with_f64("load_lo_over_p_fc", over(&l_lo))
        .with_f64("load_hi_over_p_fc", over(&l_hi))
        .with_f64("max_area_difference", l_d)
        .with_f64("load_at_max_over_p_fc", over(&l_x));
    Ok(vec![points, jumps, loops])
}

impl StageKind for TableKind {
    /// Lower bound 0: tables of per-point data (kB), no grid-sized allocation.
    fn memory_estimate(
        &self,
        _params: &Params,
        _inputs: &std::collections::BTreeMap<String, Vec<Params>>,
    ) -> Option<u64> {
        Some(0)
    }
    fn name(&self) -> &str {
        "table"
    }
    fn code_version(&self) -> u64 {
        CODE_VERSION
    }
    fn doc(&self) -> &str {
        "writes the data behind a scene as CSV tables (side outputs under results/tables/)"
    }
    fn params(&self) -> Vec<ParamSpec> {
        vec![
            ParamSpec::new("scene", ParamType::one_of(SCENES)).doc("which scene's data"),
            ParamSpec::new("output_dir", ParamType::string())
                .default("results/tables")
                .doc("folder relative to the project root"),
        ]
    }
    fn check(&self, params: &Params) -> Result<(), ParamIssue> {
        check_relative("output_dir", &dir(params))
    }
    fn inputs(&self, params: &Params) -> Vec<InputSpec> {
        match params.str("scene") {
            Ok("fig2") => fig2::inputs(),
            Ok("fig6") => vec![fig6::flow_input()],
            Ok("fig2_resolution") => fig2::resolution_inputs(),
            Ok("fig3") => fig3::inputs(),
            Ok("critical") => resolution::scene_inputs(),
            Ok("exponents") => fig5::exponent_inputs(),
            _ => Vec::new(),
        }
    }
    fn side_outputs(&self, params: &Params) -> Vec<String> {
        let d = dir(params);
        files(params.str("scene").unwrap_or(""))
            .into_iter()
            .map(|f| format!("{d}/{f}"))
            .collect()
    }
    fn cost(&self, _params: &Params) -> f64 {
        0.01
    }
    fn run(
        &self,
        ctx: &mut StageContext,
        params: &Params,
        inputs: &Inputs,
        out: &mut ArtefactWriter,
    ) -> Result<StageReport> {
        let scene = params.str("scene")?;
        let d = dir(params);
        // (file contents, rows) in the order of `files(scene)`
        let encode = |t: &Table| -> Result<(Vec<u8>, usize)> { Ok((csv_bytes(t)?, t.n_rows())) };
        let contents: Vec<(Vec<u8>, usize)> = match scene {
            "fig2" => fig2_tables(inputs)?
                .iter()
                .map(encode)
                .collect::<Result<_>>()?,
            "fig6" => fig6::tables(inputs)?
                .iter()
                .map(encode)
                .collect::<Result<_>>()?,
            "fig2_resolution" => vec![encode(&jumptable::table(&fig2::read_resolution(inputs)?))?],
            "fig3" => {
                let models = fig3::read(inputs)?;
                crate::headline::write(out, &fig3::headlines(&models))?;
                [
                    fig3::points_table(&models),
                    fig3::thresholds_table(&models),
                    jumptable::table(&models),
                ]
                .iter()
                .map(encode)
                .collect::<Result<_>>()?
            }
            "critical" => {
                let t = resolution::comparison_table(inputs)?;
                let md = resolution::comparison_markdown(&t)?;
                vec![encode(&t)?, (md.into_bytes(), t.n_rows())]
            }
            "exponents" => {
                let r = inputs.one("exponents")?;
                [fig5::exponent_table(r)?, fig5::measurement_table(r)?]
                    .iter()
                    .map(encode)
                    .collect::<Result<_>>()?
            }
            other => anyhow::bail!("scene `{other}`: allowed {}", SCENES.join(", ")),
        };
        let mut rows = serde_json::Map::new();
        for (name, (bytes, n)) in files(scene).iter().zip(contents) {
            let path = format!("{d}/{name}");
            ctx.emit_file(&path, bytes);
            rows.insert(path, json!(n));
        }
        out.set_attr("scene", scene)?;
        out.set_attr("rows", serde_json::Value::Object(rows.clone()))?;
        Ok(StageReport::with_stats(json!({ "rows": rows })))
    }
}
