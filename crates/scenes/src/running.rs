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
//! `value`, `grid_error` (|value − value on the next coarser level|, NaN if unknown; for β the
//! larger of that and |value − the same slope of the conductivity across|, the isotropy check
//! of `critical::running`),
//! `fit_error` (1σ from the measurements), `resolution` (finest spacing, λ) — the names of
//! `critical::running::RunningRecord::COLUMNS` — and `flag` (empty, or why the value must not be
//! used silently: grid error above 0.005, or unknown; β: along and across differ by more than
//! 0.005, or the flow across was not measured).
//!
//! Output figure `running_exponents` (PNG, SVG; `figures::scenes::running`): one panel per
//! exponent, the local slope against the pair's geometric-mean |l| (log axis), the three models,
//! error bars grid error ⊕ fit error (an unknown grid error counts as 0 in the bar: those pairs
//! are flagged), flagged pairs hollow, the paper's value as a band (β: a dashed line, the paper
//! gives no error), the conjecture as a dotted line.
//!
//! Measurements that fail on a rung (a closed saddle node, an unresolved edge) are left out and
//! reported as stage warnings.

use crate::scene::{OutputSpec, Outputs, Scene};
use anyhow::{Context, Result};
use critical::running::{Exponent, RunningRecord, running_records};
use figures::scenes::running::{RunningCurve, RunningData, RunningPanel, RunningPoint};
use figures::style::Model;
use kinds::exponents::asymptotic::{GRID_BOUND, resolutions};
use kinds::exponents::{CONJECTURED, PAPER, symbol};
use kinds::ladder::LadderData;
use orchestrator::{InputSpec, Inputs, Params, StageContext};
use store::ArtefactWriter;
use tables::{ColumnData, Table};

/// The `running` scene.
pub struct Running;

/// Every running exponent of one ladder; failed measurements go to `notes`.
pub fn records(d: &LadderData, notes: &mut Vec<String>) -> Result<Vec<RunningRecord>> {
    let mut out = Vec::new();
    for e in Exponent::ALL {
        let levels = resolutions(d, e, notes);
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

/// The cells of [`RunningRecord::COLUMNS`], in that order (one list of names).
#[allow(clippy::type_complexity)]
const CELLS: [fn(&[RunningRecord]) -> ColumnData; 8] = [
    |r| ColumnData::Str(r.iter().map(|r| r.model.name().to_string()).collect()),
    |r| ColumnData::Str(r.iter().map(|r| r.exponent.name().to_string()).collect()),
    |r| ColumnData::F64(r.iter().map(|r| r.l_hi).collect()),
    |r| ColumnData::F64(r.iter().map(|r| r.l_lo).collect()),
    |r| ColumnData::F64(r.iter().map(|r| r.value).collect()),
    |r| ColumnData::F64(r.iter().map(|r| r.grid_error).collect()),
    |r| ColumnData::F64(r.iter().map(|r| r.fit_error).collect()),
    |r| ColumnData::F64(r.iter().map(|r| r.resolution).collect()),
];

/// The table of [`RunningRecord`]s (columns in the module docs).
pub fn table(rows: &[RunningRecord]) -> Result<Table> {
    let mut t = Table::new();
    for (name, cell) in RunningRecord::COLUMNS.iter().zip(CELLS) {
        t.push(*name, cell(rows))?;
    }
    t.push(
        "flag",
        ColumnData::Str(
            rows.iter()
                .map(|r| r.flag.as_ref().map_or(String::new(), |f| f.to_string()))
                .collect(),
        ),
    )?;
    Ok(t)
}

/// The figure's data (module docs): one panel per exponent, one curve per model.
pub fn figure_data(rows: &[RunningRecord]) -> RunningData {
    let panels = Exponent::ALL
        .iter()
        .enumerate()
        .map(|(k, &e)| {
            let curves = Model::ALL
                .iter()
                .filter_map(|&m| {
                    let points: Vec<RunningPoint> = rows
                        .iter()
                        .filter(|r| r.exponent == e && r.model.name() == m.name())
                        .map(|r| RunningPoint {
                            l_mid: (r.l_hi * r.l_lo).abs().sqrt(),
                            value: r.value,
                            error: if r.grid_error.is_nan() {
                                0.0
                            } else {
                                r.grid_error
                            }
                            .hypot(r.fit_error),
                            flagged: r.flag.is_some(),
                        })
                        .collect();
                    (!points.is_empty()).then_some(RunningCurve { model: m, points })
                })
                .collect();
            RunningPanel {
                label: format!("local slope ${}$_{{eff}}", symbol(e.name())),
                paper: PAPER[k],
                conjecture: Some((CONJECTURED[k].0, CONJECTURED[k].1.to_string())),
                curves,
            }
        })
        .collect();
    RunningData { panels }
}

impl Scene for Running {
    fn name(&self) -> &'static str {
        "running"
    }
    fn doc(&self) -> &'static str {
        "running exponents ζ, υ, χ, β between neighbouring ladder rungs, with grid and fit errors (table and figure)"
    }
    fn code_version(&self) -> u64 {
        2
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        vec![InputSpec::many("ladder", &["ladder"]).doc("one `ladder` stage per model")]
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![
            OutputSpec::table("running", "running_exponents.csv"),
            OutputSpec::figure("figure", "running_exponents"),
        ]
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
        let mut out = Outputs::new().table("running", table(&rows)?);
        if rows.is_empty() {
            ctx.warn("no running exponent on any ladder: figure running_exponents not drawn");
        } else {
            out = out.figure(
                "figure",
                figures::scenes::running::figure(&figure_data(&rows))?,
            );
        }
        Ok(out)
    }
}
