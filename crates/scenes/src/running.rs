//! The running exponents (scene `running`): the local slope d ln y / d ln|l| between
//! neighbouring rungs of every model's ladder, for ζ (saddle gap), υ (open-channel half width),
//! χ (blocked-channel half length) and β (flux), with the grid error against the next coarser
//! level and the propagated fit error (`critical::running`). This is what a scaling claim is
//! judged by: a window fit over the paper's 0.002 ≤ |l| ≤ 0.02 hides a drift that this table
//! shows pair by pair.
//!
//! Inputs `ladder`: one `ladder` stage per model (two or more levels each give grid errors; one
//! level flags every pair as "grid error unknown").
//!
//! Output `running_exponents.csv`, one row per model, exponent and neighbouring pair of rungs:
//! `model`, `exponent`, `l_hi` (the rung farther from L_c, signed), `l_lo` (the nearer one),
//! `value`, `grid_error` (|value − value on the next coarser level|, NaN if unknown),
//! `fit_error` (1σ from the measurements), `resolution` (finest spacing, λ), `flag` (empty, or
//! why the value must not be used silently: grid error above 0.005, or unknown).
//!
//! Measurements that fail on a rung (a closed saddle node, an unresolved edge) are left out and
//! reported as stage warnings.

use crate::scene::{OutputSpec, Outputs, Scene};
use anyhow::{Context, Result};
use critical::ladder::Rung;
use critical::running::{
    Exponent, MeasureOptions, Resolution, RunningRecord, measure, running_records,
};
use kinds::ladder::{LadderData, LadderLevel};
use orchestrator::{InputSpec, Inputs, Params, StageContext};
use store::ArtefactWriter;
use tables::Table;

/// Grid-error bound above which a running exponent is flagged (the 0.005).
pub const GRID_BOUND: f64 = 0.005;

/// The `running` scene.
pub struct Running;

/// A level's rungs as the measurement takes them.
fn rungs(level: &LadderLevel) -> Vec<Rung> {
    level
        .rungs
        .iter()
        .map(|r| Rung {
            l: r.l,
            load: r.load,
            contact_area: r.contact_area,
            window: r.window.clone(),
            iterations: 0,
            converged: r.converged,
            retried: false,
            wall_s: 0.0,
        })
        .collect()
}

/// β's points on one level: the flux of the converged, percolating rungs below L_c.
fn flux_points(level: &LadderLevel) -> Resolution {
    let first = level.rungs.first();
    Resolution {
        spacing: first.map_or(f64::NAN, |r| r.window.d_par.min(r.window.d_perp)),
        points: level
            .rungs
            .iter()
            .filter(|r| r.l < 0.0 && r.percolating && r.flow_converged && r.flux > 0.0)
            .map(|r| analysis::running::ScalingPoint::new(r.l, r.flux, 0.0))
            .collect(),
    }
}

/// Every running exponent of one ladder; failed measurements go to `notes`.
pub fn records(d: &LadderData, notes: &mut Vec<String>) -> Result<Vec<RunningRecord>> {
    let opts = MeasureOptions::default();
    let mut out = Vec::new();
    for e in [
        Exponent::Zeta,
        Exponent::Upsilon,
        Exponent::Chi,
        Exponent::Beta,
    ] {
        let mut levels = Vec::new();
        for level in &d.levels {
            if e == Exponent::Beta {
                levels.push(flux_points(level));
                continue;
            }
            match measure(&rungs(level), e, &opts, notes) {
                Ok(r) => levels.push(r),
                Err(why) => notes.push(format!("{} n = {}: {why}", d.lattice.name(), level.n)),
            }
        }
        levels.retain(|r| r.points.len() >= 2);
        if levels.is_empty() {
            notes.push(format!(
                "{} {}: fewer than two measured rungs on every level",
                d.lattice.name(),
                e.name()
            ));
            continue;
        }
        out.extend(
            running_records(d.lattice, e, &levels, GRID_BOUND)
                .with_context(|| format!("{} {}", d.lattice.name(), e.name()))?,
        );
    }
    Ok(out)
}

/// The table of [`RunningRecord`]s (columns in the module docs).
pub fn table(rows: &[RunningRecord]) -> Table {
    Table::new()
        .with_str("model", rows.iter().map(|r| r.model.name().to_string()))
        .with_str(
            "exponent",
            rows.iter().map(|r| r.exponent.name().to_string()),
        )
        .with_f64("l_hi", rows.iter().map(|r| r.l_hi))
        .with_f64("l_lo", rows.iter().map(|r| r.l_lo))
        .with_f64("value", rows.iter().map(|r| r.value))
        .with_f64("grid_error", rows.iter().map(|r| r.grid_error))
        .with_f64("fit_error", rows.iter().map(|r| r.fit_error))
        .with_f64("resolution", rows.iter().map(|r| r.resolution))
        .with_str(
            "flag",
            rows.iter()
                .map(|r| r.flag.as_ref().map_or(String::new(), |f| f.to_string())),
        )
}

impl Scene for Running {
    fn name(&self) -> &'static str {
        "running"
    }
    fn doc(&self) -> &'static str {
        "running exponents ζ, υ, χ, β between neighbouring ladder rungs, with grid and fit errors (table)"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        vec![InputSpec::many("ladder", &["ladder"]).doc("one `ladder` stage per model")]
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![OutputSpec::table("running", "running_exponents.csv")]
    }
    fn render(
        &self,
        ctx: &mut StageContext,
        _params: &Params,
        inputs: &Inputs,
        _out: &mut ArtefactWriter,
    ) -> Result<Outputs> {
        let mut rows = Vec::new();
        let mut notes = Vec::new();
        for r in inputs.all("ladder") {
            let d = LadderData::read(r)?;
            rows.extend(records(&d, &mut notes)?);
        }
        for n in notes {
            ctx.warn(n);
        }
        Ok(Outputs::new().table("running", table(&rows)))
    }
}
