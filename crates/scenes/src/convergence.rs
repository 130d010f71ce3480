//! The `critical` scenes' data from three `resolution` stages (one per model): the convergence
//! figure's series and the comparison table with the paper (moved here from the `resolution`
//! kind, which computes the extrapolations; this module only reads and arranges them).

use crate::scene::{OutputSpec, Outputs, Scene};
use anyhow::{Result, bail};
use figures::scenes::convergence::{ConvergenceData, ConvergenceSeries};
use kinds::resolution::{MODEL_INPUTS, ResolutionSummary, ResolvedQuantity, paper_a_p};
use orchestrator::{InputSpec, Inputs};
use orchestrator::{Params, StageContext};
use store::ArtefactReader;
use store::ArtefactWriter;
use tables::Table;

/// Inputs of the convergence figures and the table: one `resolution` stage per model.
pub fn scene_inputs() -> Vec<InputSpec> {
    MODEL_INPUTS
        .iter()
        .map(|(name, _)| {
            InputSpec::one(name, &["resolution"]).doc(&format!("resolution study, {name} model"))
        })
        .collect()
}

/// Each model's `resolution` artefact and its summary, checked to be that model's.
fn read_models(inputs: &Inputs) -> Result<Vec<(&ArtefactReader, ResolutionSummary)>> {
    let mut out = Vec::new();
    for (name, l) in MODEL_INPUTS {
        let r = inputs.one(name)?;
        let s = ResolutionSummary::read(r)?;
        if s.lattice != l {
            bail!("input `{name}` is the {} model's study", s.lattice.name());
        }
        out.push((r, s));
    }
    Ok(out)
}

/// Convergence figure data for `quantity` (`a_p_corrected`, `a_p_raw` or `l_c`): each model's
/// values against grid spacing, with the extrapolation curve and band, shifted by a reference so
/// the three models share one axis (the paper's a_p for areas, whose error bars are drawn at
/// zero spacing; the model's own extrapolated L_c, relative, for loads). `finest = Some(k)`
/// shows only the k finest grids of each model (a zoom on the approach to zero spacing; the
/// extrapolation is still the one of all grids).
pub fn convergence_data(
    inputs: &Inputs,
    quantity: &str,
    finest: Option<usize>,
) -> Result<ConvergenceData> {
    let models = read_models(inputs)?;
    let relative = quantity.starts_with("l_c");
    let mut qs = Vec::new();
    for (r, summary) in &models {
        let l = &summary.lattice;
        let mut q = ResolvedQuantity::read(r, quantity)?;
        if let Some(k) = finest {
            // levels are stored coarse to fine (descending h)
            let skip = q.points.len().saturating_sub(k.max(1));
            q.points.drain(..skip);
        }
        qs.push((*l, q));
    }
    let hmax = qs
        .iter()
        .flat_map(|(_, q)| q.points.iter().map(|p| p.h))
        .fold(0.0, f64::max);
    let mut series = Vec::new();
    for (l, q) in &qs {
        let (offset, scale) = if relative {
            (q.v0, 1.0 / q.v0)
        } else {
            (paper_a_p(*l).0, 1.0)
        };
        let tr = |v: f64| (v - offset) * scale;
        let fit: Vec<(f64, f64)> = (0..=40)
            .map(|k| {
                let x = hmax * k as f64 / 40.0;
                (x, tr(q.curve(x).0))
            })
            .collect();
        let band = fit
            .iter()
            .map(|&(x, _)| {
                let (y, e) = q.curve(x);
                (tr(y - e), tr(y + e))
            })
            .collect();
        series.push(ConvergenceSeries {
            label: l.name().to_string(),
            spacing: q.points.iter().map(|p| p.h).collect(),
            value: q.points.iter().map(|p| tr(p.v)).collect(),
            error: q.points.iter().map(|p| p.sem * scale).collect(),
            fit: if q.v0.is_finite() { fit } else { Vec::new() },
            fit_band: if q.v0.is_finite() { band } else { Vec::new() },
            extrapolated: q.v0.is_finite().then(|| (tr(q.v0), q.v0_error * scale)),
            reference: (!relative).then(|| (0.0, paper_a_p(*l).1)),
        });
    }
    let zoom = if finest.is_some() { " (zoom)" } else { "" };
    let (label, references) = match quantity {
        "a_p_corrected" => (
            format!("corrected $a$_p − paper{zoom}"),
            vec![(0.0, "paper".to_string())],
        ),
        "a_p_raw" => (
            format!("raw $a$_p − paper{zoom}"),
            vec![(0.0, "paper".to_string())],
        ),
        _ => (
            format!("$L$_c / $L$_c(0) − 1{zoom}"),
            vec![(0.0, "extrapolated".to_string())],
        ),
    };
    Ok(ConvergenceData {
        quantity_label: label,
        spacing_label: "grid spacing √(Δ$x$ Δ$y$) / $λ$".into(),
        series,
        references,
        reference_label: (!relative).then(|| "paper (1σ)".to_string()),
    })
}

/// The comparison with the paper: one row per model (the `critical` table scene's CSV).
///
/// Columns: `model`; `grids_n` ("8..10"); `shift_rule` (m: m × m shifts per grid);
/// `finest_n`; the extrapolated `l_c`, `a_p_raw`, `a_p_corrected` with `_error` (1σ: fit ⊕
/// leave-one-grid-out spread); the finest grid's sub-grid estimate `l_c_subgrid_finest` and
/// `zeta_finest` with `_error`; the paper's `a_p_paper`, `a_p_paper_error`; the deviations
/// `a_p_corrected_minus_paper_sigma`, `a_p_raw_minus_paper_sigma` (in units of both errors
/// combined); `p_fc` (exact, continuum), `p_fc_over_l_c` with `_error`, the paper's
/// `p_fc_over_l_c_paper` (NaN for the square model) and `p_fc_over_l_c_minus_paper_percent`.
pub fn comparison_table(inputs: &Inputs) -> Result<Table> {
    let models = read_models(inputs)?;
    let rows: Vec<&ResolutionSummary> = models.iter().map(|(_, s)| s).collect();
    let col = |v: &dyn Fn(&ResolutionSummary) -> f64| rows.iter().map(|s| v(s)).collect::<Vec<_>>();
    let grids = |s: &ResolutionSummary| {
        s.levels
            .as_ref()
            .map(|l| {
                format!(
                    "{}..{}",
                    l.first().map_or(0, |l| l.n),
                    l.last().map_or(0, |l| l.n)
                )
            })
            .unwrap_or_default()
    };
    let sigma = |v: &dyn Fn(&ResolutionSummary) -> (f64, f64)| {
        col(&|s| {
            let (pa, pe) = paper_a_p(s.lattice);
            let (v, e) = v(s);
            (v - pa) / e.hypot(pe)
        })
    };
    let ratio_dev = col(&|s| 100.0 * (s.p_fc_over_l_c.0 / s.paper_p_fc_over_l_c - 1.0));
    Ok(Table::new()
        .with_str("model", rows.iter().map(|s| s.lattice.name().to_string()))
        .with_str("grids_n", rows.iter().map(|s| grids(s)))
        .with_i64("shift_rule", rows.iter().map(|s| s.shift_rule))
        .with_i64("finest_n", rows.iter().map(|s| s.finest_n))
        .with_f64("l_c", col(&|s| s.l_c.0))
        .with_f64("l_c_error", col(&|s| s.l_c.1))
        .with_f64("l_c_subgrid_finest", col(&|s| s.l_c_subgrid.0))
        .with_f64("l_c_subgrid_finest_error", col(&|s| s.l_c_subgrid.1))
        .with_f64("zeta_finest", col(&|s| s.zeta.0))
        .with_f64("zeta_finest_error", col(&|s| s.zeta.1))
        .with_f64("a_p_raw", col(&|s| s.a_p_raw.0))
        .with_f64("a_p_raw_error", col(&|s| s.a_p_raw.1))
        .with_f64("a_p_corrected", col(&|s| s.a_p_corrected.0))
        .with_f64("a_p_corrected_error", col(&|s| s.a_p_corrected.1))
        .with_f64("a_p_paper", col(&|s| s.paper_a_p.0))
        .with_f64("a_p_paper_error", col(&|s| s.paper_a_p.1))
        .with_f64(
            "a_p_corrected_minus_paper_sigma",
            sigma(&|s| s.a_p_corrected),
        )
        .with_f64("a_p_raw_minus_paper_sigma", sigma(&|s| s.a_p_raw))
        .with_f64("p_fc", col(&|s| s.p_fc_exact))
        .with_f64("p_fc_over_l_c", col(&|s| s.p_fc_over_l_c.0))
        .with_f64("p_fc_over_l_c_error", col(&|s| s.p_fc_over_l_c.1))
        .with_f64("p_fc_over_l_c_paper", col(&|s| s.paper_p_fc_over_l_c))
        .with_f64("p_fc_over_l_c_minus_paper_percent", ratio_dev))
}

/// The comparison table for reading: values with their 1σ errors in concise notation, the
/// paper's beside them (GitHub Markdown; the CSV has every number in full).
pub fn comparison_markdown(t: &Table) -> Result<String> {
    let n = t.n_rows();
    let s = |k: &str| t.str(k).map(|v| v.to_vec());
    let f = |k: &str| t.f64(k).map(|v| v.to_vec());
    let i = |k: &str| t.i64(k).map(|v| v.to_vec());
    let (model, grids, m) = (s("model")?, s("grids_n")?, i("shift_rule")?);
    let ve = |k: &str, sig: usize| -> Result<Vec<String>> {
        let (v, e) = (f(k)?, f(&format!("{k}_error"))?);
        Ok((0..n).map(|r| tables::concise(v[r], e[r], sig)).collect())
    };
    let plain = |k: &str, fmt: tables::FloatFormat| -> Result<Vec<String>> {
        Ok(f(k)?.iter().map(|&x| fmt.apply(x)).collect())
    };
    let (dev_c, dev_r) = (
        f("a_p_corrected_minus_paper_sigma")?,
        f("a_p_raw_minus_paper_sigma")?,
    );
    let md = Table::new()
        .with_str("model", model)
        .with_str(
            "grids n (shifts)",
            (0..n).map(|r| format!("{} ({}×{})", grids[r], m[r].max(1), m[r].max(1))),
        )
        .with_str("L_c", ve("l_c", 6)?)
        .with_str("L_c sub-grid (finest)", ve("l_c_subgrid_finest", 6)?)
        .with_str("ζ (finest)", ve("zeta_finest", 3)?)
        .with_str("p_fc", plain("p_fc", tables::FloatFormat::Significant(6))?)
        .with_str("p_fc/L_c", ve("p_fc_over_l_c", 4)?)
        .with_str(
            "paper",
            plain("p_fc_over_l_c_paper", tables::FloatFormat::Shortest)?,
        )
        .with_str("a_p raw", ve("a_p_raw", 5)?)
        .with_str("a_p corrected", ve("a_p_corrected", 5)?)
        .with_str("a_p paper", ve("a_p_paper", 5)?)
        .with_str(
            "Δ/σ corrected, raw",
            (0..n).map(|r| format!("{:+.1}, {:+.1}", dev_c[r], dev_r[r])),
        );
    Ok(md.to_markdown(tables::FloatFormat::Shortest))
}

/// The `convergence` scene, from three `resolution` stages (inputs `hexagonal`, `square`,
/// `triangular`): the convergence figure (against grid spacing, with the extrapolations to zero
/// spacing and their 1σ bands, stacked: (a) perimeter-corrected a_p minus the paper's value,
/// (b) the same on the three finest grids, (c) raw a_p minus the paper's, (d) L_c relative to
/// its extrapolation), `critical.csv` (one row per model, columns in [`comparison_table`]) and
/// `critical.md` (the same comparison as a Markdown table in concise notation).
pub struct Convergence;

/// The figure's panels, top to bottom: quantity and how many of the finest grids (`None`: all).
pub const PANELS: [(&str, Option<usize>); 4] = [
    ("a_p_corrected", None),
    ("a_p_corrected", Some(3)),
    ("a_p_raw", None),
    ("l_c", None),
];

impl Scene for Convergence {
    fn name(&self) -> &'static str {
        "convergence"
    }
    fn doc(&self) -> &'static str {
        "L_c and a_p against grid spacing, extrapolated, three models (figure), and the comparison with the paper (critical.csv, critical.md)"
    }
    fn code_version(&self) -> u64 {
        1
    }
    fn inputs(&self, _params: &Params) -> Vec<InputSpec> {
        scene_inputs()
    }
    fn outputs(&self, _params: &Params) -> Vec<OutputSpec> {
        vec![
            OutputSpec::figure("figure", "convergence"),
            OutputSpec::table("comparison", "critical.csv"),
            OutputSpec::text("markdown", "critical.md"),
        ]
    }
    fn render(
        &self,
        _ctx: &mut StageContext,
        _params: &Params,
        inputs: &Inputs,
        _out: &mut ArtefactWriter,
    ) -> Result<Outputs> {
        let panels = PANELS
            .iter()
            .map(|(q, k)| convergence_data(inputs, q, *k))
            .collect::<Result<Vec<_>>>()?;
        let t = comparison_table(inputs)?;
        let md = comparison_markdown(&t)?;
        let rows = t.n_rows();
        Ok(Outputs::new()
            .figure("figure", figures::scenes::convergence::stacked(&panels)?)
            .table("comparison", t)
            .text("markdown", md, rows))
    }
}
