//! The running exponents (scene `running`): the local slope d ln y / d ln|l| between
//! neighbouring rungs of every model's ladder, for ζ (saddle gap), υ (open-channel half width),
//! χ (blocked-channel half length) and β (flux), with the grid error against the next coarser
//! level and the propagated fit error (`critical::running`). This is what a scaling claim is
//! judged by: a window fit over the paper's 0.002 ≤ |l| ≤ 0.02 hides a drift that this table
//! shows pair by pair.
//!
//! Inputs `ladder`: one `ladder` stage per model (two or more levels each give grid errors; one
//! level flags every pair as "grid error unknown"); optional `refined` and `deep`:
//! `refined_ladder` stages (`kinds::refined_ladder`, at most one of each per model; a preset
//! without them gives the uniform rows only), whose running ζ, υ, χ and β pairs are added as
//! rows of their own; optional `window`: `refined_window` stages, each folded into the ladder
//! it checks (`kinds::refined_chain::read_linked`).
//!
//! Output `running_exponents.csv`, one row per model, exponent, measure, neighbouring pair of
//! rungs and method (uniform rows first, then the refined ones, then the deep ones, then the
//! neck rows of the refined and deep ladders, [`neck`]):
//! `model`, `exponent`, `l_hi` (the rung farther from L_c, signed), `l_lo` (the nearer one),
//! `value`, `grid_error` (|value − value on the next coarser level|, NaN if unknown; for β the
//! larger of that and |value − the same slope of the conductivity across|, the isotropy check
//! of `critical::running`),
//! `fit_error` (1σ from the measurements), `resolution` (finest spacing, λ) — the names of
//! `critical::running::RunningRecord::COLUMNS` — and `flag` (empty, or why the value must not be
//! used silently: grid error above 0.005, or unknown; β: along and across differ by more than
//! 0.005, or the flow across was not measured), and `method`: `uniform` (the ladder's finest
//! grid, as above), `refined` (input `refined`) or `refined_deep` (input `deep`, the
//! pipeline's deeper `refined_deep_*` stages, docs/near-critical.md: the same
//! columns) (a refined ladder's finest discretisation: `resolution` its
//! finest fine spacing, λ; `grid_error` the largest of the change from the discretisation with
//! one level fewer, from the margin check and, with a window check (input `window`,
//! `kinds::refined_window`), from the larger window at the check's level, NaN if one of them
//! is unknown; `fit_error` for ζ the
//! solver tolerance `tol_gap` as the 1σ of each saddle gap (a node value: no fit), relative to
//! g_s and propagated to the slope, for υ and χ the edge fits' 1σ propagated likewise, for β
//! the solver tolerance propagated to the flux (σ_K/K = 3 tol_gap/g_s); `flag` as
//! the refined kind gives it: grid error above 0.005 or unknown, a rung whose window is too
//! small or whose solve did not converge, a pair over which the window's contact set did not
//! change; with a window check also a window change above 0.005 or unknown). The refined pairs' l are measured from the refined discretisation's own p_c. The
//! refined β is the slope of the refined ladder's flux (`critical::refined_flow`): the square
//! cell's conductivity along the channel, the triangular and hexagonal refined saddle's own
//! two-terminal conductance (one refined window cannot give their cell's K; the neck's
//! conductance has the same exponent).
//!
//! The last column, `measure`, names the quantity whose slope the row is, on every row:
//! `saddle_gap` (ζ), `half_width` (υ: the contact-line fit r_c), `half_length` (χ from above:
//! the Hertz fit a), `flux` (β) — the rows that existed before — and, on the refined and deep
//! ladders, the neck lengths from the gap field ([`neck`]: `neck_width_rms` and
//! `neck_width_level` (υ), `neck_rise_length` (χ from below), all with that ladder's error
//! model). Why a column and not new `method` values: `method` says which ladder (which
//! discretisation) a row comes from, and the neck rows come from the same ladders as the
//! contact-line rows of the same pair — a neck υ and a contact-line υ of one refined pair share
//! their solves, their resolution and their level/margin/window comparisons; folding the
//! estimator into `method` would make one column mean two things and break every reader that
//! maps `method` to a ladder depth (`differences`, the smoke test). A column also names the
//! estimator of the old rows (which `method` never did), and it is appended last, so the
//! existing columns keep their positions and, without it, the existing rows are byte for byte
//! what they were (checked on the draft and smoke presets, docs/near-critical.md §12). A reader
//! that selects rows by `exponent` must now also select the measure (`differences`, the figure
//! and the tests do).
//!
//! Output `identity.csv` ([`identity`]): per refined and deep pair with a flux row,
//! β_identity = 3ζ_eff + υ_eff(rms width) − χ_eff(rise length, from below) against β_eff
//! (flux), with the difference, its error and flags.
//!
//! Output figure `running_exponents` (PNG, SVG; `figures::scenes::running`): one panel per
//! exponent, the local slope against the pair's geometric-mean |l| (log axis), the three models,
//! error bars grid error ⊕ fit error (an unknown grid error counts as 0 in the bar: those pairs
//! are flagged), the refined pairs as diamonds in the model's colour (the deep ones too, joined
//! by a dotted line, "(deep)" in the legend), the neck rows (υ: rms width in the υ panel, χ:
//! rise length, from below, in the χ panel) as stars joined by dash-dotted lines (legend in
//! the χ panel), flagged pairs hollow, the paper's value as a band (β: a dashed line, the paper
//! gives no error), the conjecture as a dotted line.
//!
//! Between the models ([`differences`]): `model_differences.csv` (the difference of two models'
//! running exponents at every pair both measured usably with the same measure, and its own
//! local slope) and `universality.csv` (whether that difference vanishes as |l| → 0: fits
//! Δ = c|l|^ω against Δ = Δ∞ + c|l|^ω over every range of the smallest-|l| pairs,
//! `analysis::difference`), each exponent's own measure first (the rows as before), then the
//! neck measures, both tables with a last column `measure`.
//!
//! Measurements that fail on a rung (a closed saddle node, an unresolved edge) are left out and
//! reported as stage warnings.

pub mod differences;
pub mod identity;
pub mod neck;

use crate::scene::{OutputSpec, Outputs, Scene};
use anyhow::{Context, Result};
use critical::refined::{Measured, Source};
use critical::running::{Exponent, RunningRecord, running_records};
use figures::scenes::running::{RunningCurve, RunningData, RunningPanel, RunningPoint};
use figures::style::Model;
use kinds::exponents::asymptotic::{GRID_BOUND, resolutions};
use kinds::exponents::{CONJECTURED, PAPER, symbol};
use kinds::ladder::LadderData;
use kinds::refined_chain::{Depth, Linked};
use kinds::refined_ladder::RefinedData;
use neck::Measure;
use orchestrator::{InputSpec, Inputs, Params, StageContext};
use store::ArtefactReader;
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

/// One row of `running_exponents.csv` (module docs): a uniform record or a refined pair.
#[derive(Clone, Debug, PartialEq)]
pub struct Row {
    /// The columns of [`RunningRecord::COLUMNS`] (its `flag` unused: see `flag`).
    pub rec: RunningRecord,
    /// Why the value must not be used silently (empty: usable).
    pub flag: String,
    /// Which ladder it comes from: `uniform`, or the refined input's
    /// [`kinds::refined_chain::Depth::name`] (`refined`, `refined_deep`).
    pub method: &'static str,
    /// What it measures (column `measure`; module docs).
    pub measure: Measure,
}

impl Row {
    /// Its error bar: grid error ⊕ fit error, an unknown (NaN) term counting as 0 (such a row is
    /// flagged). The figure's bars, the model differences and the identity use it.
    pub fn error(&self) -> f64 {
        let nan0 = |v: f64| if v.is_nan() { 0.0 } else { v };
        nan0(self.rec.grid_error).hypot(nan0(self.rec.fit_error))
    }
}

impl From<RunningRecord> for Row {
    fn from(rec: RunningRecord) -> Self {
        let flag = rec.flag.as_ref().map_or(String::new(), |f| f.to_string());
        Row {
            measure: Measure::of(rec.exponent),
            rec,
            flag,
            method: Source::Uniform.name(),
        }
    }
}

/// The running pairs of one refined ladder as rows (module docs), `method` its input's name.
pub fn refined_rows(d: &RefinedData, depth: Depth) -> Vec<Row> {
    d.running
        .iter()
        .map(|p| Row {
            rec: RunningRecord {
                model: d.lattice,
                exponent: match p.exponent {
                    Measured::SaddleGap => Exponent::Zeta,
                    Measured::OpenHalfWidth => Exponent::Upsilon,
                    Measured::BlockedHalfLength => Exponent::Chi,
                    Measured::Flux => Exponent::Beta,
                },
                l_hi: p.row.l_hi,
                l_lo: p.row.l_lo,
                value: p.row.value,
                grid_error: p.row.grid_error,
                fit_error: p.row.fit_error,
                resolution: d.spacing,
                flag: None,
            },
            flag: p.flag.clone(),
            method: depth.name(),
            measure: Measure::of(match p.exponent {
                Measured::SaddleGap => Exponent::Zeta,
                Measured::OpenHalfWidth => Exponent::Upsilon,
                Measured::BlockedHalfLength => Exponent::Chi,
                Measured::Flux => Exponent::Beta,
            }),
        })
        .collect()
}

/// The neck rows of one refined ladder ([`neck`]; its pairs `kinds::refined_neck::pairs`): `r`
/// its artefact, `windows` the window checks' artefacts (input `window`; the one that checks
/// it, if any, gives the window term). With a note for the caller to warn if its artefact, or
/// its window check's, has no neck lengths (written before they were stored).
pub fn neck_rows(
    link: &Linked,
    r: &ArtefactReader,
    windows: &[ArtefactReader],
) -> Result<(Vec<Row>, Option<String>)> {
    let d = &link.data;
    let neck = match kinds::refined_neck::read_linked(link, r, windows)? {
        Ok(n) => n,
        Err(note) => return Ok((Vec::new(), Some(format!("{note}: no neck rows")))),
    };
    let pairs = neck::pairs(&neck.ladder());
    Ok((
        neck::rows(d.lattice, &pairs, link.depth.name(), d.spacing),
        neck.note,
    ))
}

/// The cells of [`RunningRecord::COLUMNS`], in that order (one list of names).
#[allow(clippy::type_complexity)]
const CELLS: [fn(&[Row]) -> ColumnData; 8] = [
    |r| ColumnData::Str(r.iter().map(|r| r.rec.model.name().to_string()).collect()),
    |r| {
        ColumnData::Str(
            r.iter()
                .map(|r| r.rec.exponent.name().to_string())
                .collect(),
        )
    },
    |r| ColumnData::F64(r.iter().map(|r| r.rec.l_hi).collect()),
    |r| ColumnData::F64(r.iter().map(|r| r.rec.l_lo).collect()),
    |r| ColumnData::F64(r.iter().map(|r| r.rec.value).collect()),
    |r| ColumnData::F64(r.iter().map(|r| r.rec.grid_error).collect()),
    |r| ColumnData::F64(r.iter().map(|r| r.rec.fit_error).collect()),
    |r| ColumnData::F64(r.iter().map(|r| r.rec.resolution).collect()),
];

/// The table of [`Row`]s (columns in the module docs).
pub fn table(rows: &[Row]) -> Result<Table> {
    let mut t = Table::new();
    for (name, cell) in RunningRecord::COLUMNS.iter().zip(CELLS) {
        t.push(*name, cell(rows))?;
    }
    t.push(
        "flag",
        ColumnData::Str(rows.iter().map(|r| r.flag.clone()).collect()),
    )?;
    t.push(
        "method",
        ColumnData::Str(rows.iter().map(|r| r.method.to_string()).collect()),
    )?;
    t.push(
        "measure",
        ColumnData::Str(rows.iter().map(|r| r.measure.name().to_string()).collect()),
    )?;
    Ok(t)
}

/// A row as a point of the figure: error bar grid ⊕ fit (an unknown one counts as 0: those
/// pairs are flagged and drawn hollow).
fn point(r: &Row) -> RunningPoint {
    RunningPoint {
        l_mid: (r.rec.l_hi * r.rec.l_lo).abs().sqrt(),
        value: r.rec.value,
        error: r.error(),
        flagged: !r.flag.is_empty(),
    }
}

/// The figure's data (module docs): one panel per exponent, one curve per model and method of
/// the exponent's own measure, and in the υ and χ panels one per model and refined method of
/// the neck's rms width and rise length.
pub fn figure_data(rows: &[Row]) -> RunningData {
    let methods = [
        Source::Uniform.name(),
        Depth::Refined.name(),
        Depth::Deep.name(),
    ];
    let panels = Exponent::ALL
        .iter()
        .enumerate()
        .map(|(k, &e)| {
            let neck = match e {
                Exponent::Upsilon => Some(Measure::NeckWidthRms),
                Exponent::Chi => Some(Measure::NeckRiseLength),
                _ => None,
            };
            let measures = std::iter::once(Measure::of(e)).chain(neck);
            let curves = measures
                .flat_map(|measure| {
                    Model::ALL
                        .iter()
                        .flat_map(move |&m| methods.map(|method| (measure, m, method)))
                })
                .filter_map(|(measure, m, method)| {
                    let points: Vec<RunningPoint> = rows
                        .iter()
                        .filter(|r| {
                            r.measure == measure
                                && r.rec.model.name() == m.name()
                                && r.method == method
                        })
                        .map(point)
                        .collect();
                    (!points.is_empty()).then_some(RunningCurve {
                        model: m,
                        refined: method != Source::Uniform.name(),
                        deep: method == Depth::Deep.name(),
                        neck: measure.is_neck(),
                        points,
                    })
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
        "running exponents ζ, υ, χ, β between neighbouring ladder rungs, with grid and fit errors, from the uniform ladders and (optional) the refined ones, there also υ and χ (from below) from the neck's gap field and the identity β = 3ζ + υ − χ per pair (tables and figure)"
    }
    fn code_version(&self) -> u64 {
        7
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        vec![
            InputSpec::many("ladder", &["ladder"]).doc("one `ladder` stage per model"),
            InputSpec::many("refined", &["refined_ladder"])
                .optional()
                .doc("one `refined_ladder` stage per model (optional): its running ζ, υ, χ, β as `refined` rows"),
            InputSpec::many("deep", &["refined_ladder"])
                .optional()
                .doc("one deeper `refined_ladder` stage per model (optional; the pipeline's `refined_deep_*`): its running ζ, υ, χ, β as `refined_deep` rows"),
            InputSpec::many("window", &["refined_window"])
                .optional()
                .doc("window checks (optional; the pipeline's `refined_deep_window_*`): each folds its window change into the grid error and flags of the ladder it checks (kinds::refined_window)"),
        ]
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![
            OutputSpec::table("running", "running_exponents.csv"),
            OutputSpec::table("differences", "model_differences.csv"),
            OutputSpec::table("universality", "universality.csv"),
            OutputSpec::table("identity", "identity.csv"),
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
        let mut rows: Vec<Row> = Vec::new();
        let mut notes = Vec::new();
        for r in inputs.all("ladder") {
            let d = LadderData::read(r)?;
            rows.extend(records(&d, &mut notes)?.into_iter().map(Row::from));
        }
        let linked = kinds::neck_truncation::read_flagged(inputs)?;
        for (l, _) in &linked {
            rows.extend(refined_rows(&l.data, l.depth));
        }
        // the neck rows after every other row (module docs)
        for (l, r) in &linked {
            let (neck, note) = neck_rows(l, r, inputs.all("window"))?;
            rows.extend(neck);
            notes.extend(note);
        }
        for n in notes {
            ctx.warn(n);
        }
        let pairs = differences::analyse(&rows)?;
        let mut out = Outputs::new()
            .table("running", table(&rows)?)
            .table("differences", differences::differences_table(&pairs)?)
            .table("universality", differences::universality_table(&pairs)?)
            .table(
                "identity",
                identity::identity_table(&identity::identity(&rows))?,
            );
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
